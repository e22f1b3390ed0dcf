//! Paths that are not regular files (a symlink to `/dev/zero`, a FIFO, a directory) are refused
//! before reading, with an error naming the path: no endless read, no hang, no OOM.
#![cfg(unix)]

use std::path::Path;
use std::sync::mpsc;
use std::time::Duration;
use volume_io::{load_volume_with, LoadOptions};

/// Loads `path` on a thread; the error text, or a failure if it loads or takes over 10 s.
fn load_error(path: &Path) -> String {
    let (send, recv) = mpsc::channel();
    let owned = path.to_owned();
    std::thread::spawn(move || {
        let result = load_volume_with(&owned, &LoadOptions::default());
        let _ = send.send(result.map(|_| ()).map_err(|e| format!("{e:#}")));
    });
    match recv.recv_timeout(Duration::from_secs(10)) {
        Ok(Err(e)) => e,
        Ok(Ok(())) => panic!("{} loaded", path.display()),
        Err(_) => panic!("loading {} did not finish in 10 s", path.display()),
    }
}

#[test]
fn non_regular_files_are_refused_unread() {
    let dir = std::env::temp_dir().join(format!("volume-io-non-regular-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for ext in ["vdb", "nvdb"] {
        let zero = dir.join(format!("zero.{ext}"));
        std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
        let fifo = dir.join(format!("fifo.{ext}"));
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        assert!(made.is_ok_and(|s| s.success()), "mkfifo failed");
        let sub = dir.join(format!("dir.{ext}"));
        std::fs::create_dir(&sub).unwrap();
        for path in [&zero, &fifo, &sub] {
            let e = load_error(path);
            assert!(
                e.contains(&path.display().to_string()) && e.contains("not a regular file"),
                "{}: {e}",
                path.display()
            );
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
