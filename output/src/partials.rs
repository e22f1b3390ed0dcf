//! The temporary files of writes in progress (`.NAME.partial-XXXXXX` beside each output), so
//! that a process ended by a signal removes them ([`remove_all`], called by the CLI's signal
//! handler) and a later run names those that an earlier one could not remove ([`stale`]).

use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The temporary files being written now.
static PARTIALS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The most bytes of an output's name in its temporary file's name: with the dot, `.partial-`,
/// 6 random characters and an extension of up to 17 bytes, at most 255 bytes (NAME_MAX).
const NAME_IN_PREFIX: usize = 255 - 1 - 9 - 6 - 17;

/// The prefix of the temporary files of output `name` (`.NAME.partial-`, the name cut to
/// [`NAME_IN_PREFIX`] bytes on a character boundary, so every legal name has a legal temporary
/// name).
pub fn prefix(name: &str) -> String {
    let mut end = name.len().min(NAME_IN_PREFIX);
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    format!(".{}.partial-", &name[..end])
}

/// Records temporary file `path` while it is written.
pub(crate) fn begin(path: &Path) {
    lock().push(path.to_owned());
}

/// Forgets temporary file `path` (renamed into place or removed).
pub(crate) fn end(path: &Path) {
    lock().retain(|p| p != path);
}

fn lock() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    PARTIALS.lock().unwrap_or_else(|e| e.into_inner())
}

/// Removes every temporary file of a write in progress; returns how many were removed. For a
/// signal handler: it takes the lock only if no other thread holds it (a writer holds it for
/// a push or a retain only), so it cannot deadlock.
pub fn remove_all() -> usize {
    let Ok(list) = PARTIALS.try_lock() else {
        return 0;
    };
    list.iter()
        .filter(|p| std::fs::remove_file(p).is_ok())
        .count()
}

/// Temporary files of output `path` left by an earlier write that was killed (or by a write of
/// another process now): `.NAME.partial-*` in its folder.
pub fn stale(path: &Path) -> Vec<PathBuf> {
    let Some(name) = path.file_name() else {
        return Vec::new();
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_owned(),
        _ => PathBuf::from("."),
    };
    let prefix = prefix(&name.to_string_lossy());
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return Vec::new();
    };
    let mut found: Vec<PathBuf> = entries
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with(&prefix))
        .map(|e| e.path())
        .collect();
    found.sort();
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A registered temporary file is removed by `remove_all`, an ended one is not; `stale`
    /// finds an output's leftovers only.
    #[test]
    fn partials_are_removed_and_found() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("render.exr");
        let a = dir.path().join(".render.exr.partial-abc.exr");
        let b = dir.path().join(".other.exr.partial-abc.exr");
        std::fs::write(&a, "x").unwrap();
        std::fs::write(&b, "x").unwrap();
        assert_eq!(stale(&out), vec![a.clone()]);
        begin(&a);
        end(&b);
        assert!(remove_all() >= 1);
        assert!(!a.exists() && b.exists());
        end(&a);
        assert!(stale(&out).is_empty());
        let long = "é".repeat(127);
        let p = prefix(&long);
        assert!(p.len() + 6 + 17 <= 255, "{}", p.len());
        assert!(long.starts_with(p.trim_start_matches('.').trim_end_matches(".partial-")));
    }
}
