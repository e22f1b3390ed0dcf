//! Whether two kernel folders hold the same files, byte for byte (`kernel-builder --check`).

use std::collections::BTreeSet;
use std::path::Path;

/// Ok if `committed` and `fresh` hold the same file names with the same bytes; else the first
/// difference: a file only one of them has, or the first differing byte of a file.
pub fn same_files(committed: &Path, fresh: &Path) -> Result<(), String> {
    let names = |dir: &Path| -> Result<BTreeSet<String>, String> {
        let entries =
            std::fs::read_dir(dir).map_err(|e| format!("cannot read {}: {e}", dir.display()))?;
        let mut names = BTreeSet::new();
        for entry in entries {
            let entry = entry.map_err(|e| format!("cannot read {}: {e}", dir.display()))?;
            names.insert(entry.file_name().to_string_lossy().into_owned());
        }
        Ok(names)
    };
    let (a, b) = (names(committed)?, names(fresh)?);
    if let Some(n) = a.difference(&b).next() {
        return Err(format!("{n} is committed but not built"));
    }
    if let Some(n) = b.difference(&a).next() {
        return Err(format!("{n} is built but not committed"));
    }
    for n in &a {
        let read =
            |dir: &Path| std::fs::read(dir.join(n)).map_err(|e| format!("cannot read {n}: {e}"));
        let (x, y) = (read(committed)?, read(fresh)?);
        if x != y {
            let at = x
                .iter()
                .zip(&y)
                .position(|(p, q)| p != q)
                .unwrap_or(x.len().min(y.len()));
            return Err(format!(
                "{n} differs at byte {at} ({} committed bytes, {} built)",
                x.len(),
                y.len()
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::same_files;

    fn folder(files: &[(&str, &[u8])]) -> tempfile::TempDir {
        let d = tempfile::tempdir().unwrap();
        for (name, bytes) in files {
            std::fs::write(d.path().join(name), bytes).unwrap();
        }
        d
    }

    #[test]
    fn one_changed_byte_is_a_difference() {
        let module: Vec<u8> = (0..=255u8).cycle().take(4096).collect();
        let a = folder(&[("a_cs.spv", &module), ("manifest.toml", b"x")]);
        let b = folder(&[("a_cs.spv", &module), ("manifest.toml", b"x")]);
        assert_eq!(same_files(a.path(), b.path()), Ok(()));
        for at in [0, 1000, 4095] {
            let mut changed = module.clone();
            changed[at] ^= 1;
            let c = folder(&[("a_cs.spv", &changed), ("manifest.toml", b"x")]);
            let e = same_files(a.path(), c.path()).unwrap_err();
            assert!(e.contains(&format!("a_cs.spv differs at byte {at}")), "{e}");
        }
        let short = folder(&[("a_cs.spv", &module[..4000]), ("manifest.toml", b"x")]);
        let e = same_files(a.path(), short.path()).unwrap_err();
        assert!(e.contains("at byte 4000"), "{e}");
    }

    #[test]
    fn a_missing_or_extra_file_is_a_difference() {
        let a = folder(&[("a_cs.spv", b"1"), ("b_cs.spv", b"2")]);
        let b = folder(&[("a_cs.spv", b"1")]);
        assert!(same_files(a.path(), b.path())
            .unwrap_err()
            .contains("b_cs.spv is committed but not built"));
        assert!(same_files(b.path(), a.path())
            .unwrap_err()
            .contains("b_cs.spv is built but not committed"));
    }
}
