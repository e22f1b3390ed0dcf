//! The files a process reads, protected from everything it writes: every input is recorded once
//! (by the command line before any work, and by each output plan), and every output, planned
//! or written, is compared with all of them by path and by file identity (links included).

use anyhow::{bail, Result};
use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;

/// A file's identity (device, inode) after following links: two names of one file, through a
/// symbolic or a hard link, have the same identity.
pub(crate) type FileId = (u64, u64);

/// One protected input: what reads it (a flag such as "--volume"), its normalized path and its
/// identity.
#[derive(Clone, Debug)]
pub(crate) struct Input {
    pub what: String,
    pub path: PathBuf,
    pub id: Option<FileId>,
}

/// Every input recorded in this process.
static INPUTS: Mutex<Vec<Input>> = Mutex::new(Vec::new());

/// The identity of the file `path` names, following links (None where it does not exist, or
/// off Unix). Reads metadata only: never opens the file (a FIFO cannot block it).
pub(crate) fn file_id(path: &Path) -> Option<FileId> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        None
    }
}

/// Records `path` as an input of this process, read for `what`: no output of the process may
/// replace it, by any name. A directory protects each file directly in it (an eval folder's
/// report and images); a path that does not exist (an embedded volume's name) protects nothing.
pub fn protect(what: &str, path: &Path) {
    let Ok(meta) = std::fs::metadata(path) else {
        return;
    };
    let mut inputs = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
    let mut push = |p: &Path| {
        let input = Input {
            what: what.to_owned(),
            path: normalize(p),
            id: file_id(p),
        };
        let known = inputs
            .iter()
            .any(|i| i.path == input.path && i.id == input.id);
        if !known {
            inputs.push(input);
        }
    };
    if meta.is_dir() {
        if let Ok(entries) = std::fs::read_dir(path) {
            for entry in entries.flatten() {
                if entry
                    .file_type()
                    .is_ok_and(|t| t.is_file() || t.is_symlink())
                {
                    push(&entry.path());
                }
            }
        }
    } else {
        push(path);
    }
}

/// Every input recorded so far.
pub(crate) fn all() -> Vec<Input> {
    INPUTS.lock().unwrap_or_else(|e| e.into_inner()).clone()
}

/// The input that file output `path` would replace, by its path or (an existing output) by its
/// identity, if any. An input's identity is read again: a file removed since it was recorded
/// may have passed its inode number on to an unrelated file.
pub(crate) fn replaced_by(path: &Path) -> Option<Input> {
    let norm = normalize(path);
    let id = file_id(path);
    all().into_iter().find(|i| {
        let now = file_id(&i.path);
        i.path == norm || (id.is_some() && now == id && i.id == now)
    })
}

/// Refuses to write file output `path` (for `what`) where it would replace an input.
pub fn refuse_input(what: &str, path: &Path) -> Result<()> {
    if let Some(input) = replaced_by(path) {
        let same = normalize(path) == input.path;
        if same {
            bail!(
                "{what} {} would overwrite the input {}; choose another output path",
                path.display(),
                input.what
            );
        }
        bail!(
            "{what} {} would overwrite the input {} ({}): they are the same file (a link); \
             choose another output path",
            path.display(),
            input.what,
            input.path.display()
        );
    }
    Ok(())
}

/// Refuses an existing output `path` that is no regular file (a character or block device, a
/// FIFO, a socket): writing by rename would replace it, and opening it could block. Reads
/// metadata only.
pub fn refuse_special(what: &str, path: &Path) -> Result<()> {
    let Ok(meta) = std::fs::metadata(path) else {
        return Ok(());
    };
    if meta.is_file() || meta.is_dir() {
        return Ok(());
    }
    bail!(
        "{what} {} is {}, not a regular file: outputs are written to a new file and renamed into \
         place, which would replace it; give a regular file path",
        path.display(),
        special_kind(&meta)
    )
}

/// "a character device", "a FIFO", ... for a file that is neither a regular file nor a folder.
fn special_kind(meta: &std::fs::Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    let _ = meta;
    "a special file"
}

/// `path` made absolute (against the current directory) with `.` and `..` resolved lexically,
/// and its existing parent's symlinks resolved, so equal files compare equal.
pub(crate) fn normalize(path: &Path) -> PathBuf {
    let absolute = std::env::current_dir()
        .map(|cwd| cwd.join(path))
        .unwrap_or_else(|_| path.to_owned());
    let mut out = PathBuf::new();
    for part in absolute.components() {
        match part {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    match (out.parent(), out.file_name()) {
        (Some(dir), Some(name)) => match dir.canonicalize() {
            Ok(dir) => dir.join(name),
            Err(_) => out,
        },
        _ => out,
    }
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    /// A protected file is refused as an output by its own name, through a symbolic link and
    /// through a hard link; a folder protects the files in it.
    #[test]
    fn protected_inputs_are_refused_by_every_name() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("volume.vdb");
        std::fs::write(&input, "v").unwrap();
        let sym = dir.path().join("sym.json");
        let hard = dir.path().join("hard.json");
        std::os::unix::fs::symlink(&input, &sym).unwrap();
        std::fs::hard_link(&input, &hard).unwrap();
        let other = dir.path().join("other.json");
        assert!(
            refuse_input("--json", &sym).is_ok(),
            "nothing protected yet"
        );
        protect("--volume", &input);
        for p in [&input, &sym, &hard] {
            let e = refuse_input("--json", p).unwrap_err().to_string();
            assert!(e.contains("--volume"), "{e}");
        }
        assert!(refuse_input("--json", &other).is_ok());
        let folder = dir.path().join("eval");
        std::fs::create_dir(&folder).unwrap();
        std::fs::write(folder.join("eval.json"), "{}").unwrap();
        protect("--from-eval", &folder);
        assert!(refuse_input("--out", &folder.join("eval.json")).is_err());
        assert!(refuse_input("--out", &folder.join("new.json")).is_ok());
    }

    /// An input removed after it was recorded protects no unrelated file that reuses its inode
    /// number (file systems hand a freed inode to the next new file).
    #[test]
    fn a_removed_input_protects_no_new_file() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("gone.vdb");
        std::fs::write(&input, "v").unwrap();
        protect("--volume", &input);
        std::fs::remove_file(&input).unwrap();
        for k in 0..8 {
            let new = dir.path().join(format!("new{k}.json"));
            std::fs::write(&new, "n").unwrap();
            assert!(refuse_input("--json", &new).is_ok(), "{}", new.display());
        }
        assert!(
            refuse_input("--json", &input).is_err(),
            "its own path stays protected"
        );
    }

    /// A FIFO is refused as an output from its metadata alone (opening it would block).
    #[test]
    fn fifos_are_refused_without_opening_them() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe.json");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0);
        let e = refuse_special("--json", &fifo).unwrap_err().to_string();
        assert!(e.contains("FIFO"), "{e}");
        assert!(refuse_special("--json", &dir.path().join("new.json")).is_ok());
    }
}
