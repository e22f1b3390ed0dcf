//! Helpers shared by the host's integration tests.

use std::process::Command;

/// `host` run under an address-space limit of `kib` KiB (`ulimit -v`), as a user with a memory
/// limit runs it: memory checks must refuse before an allocation aborts the process.
pub fn host_under_ulimit(kib: u64) -> Command {
    let mut c = Command::new("sh");
    c.arg("-c")
        .arg(format!("ulimit -v {kib} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_host"));
    c
}
