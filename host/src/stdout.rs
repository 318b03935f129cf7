//! Standard output that fails instead of panicking: `print!` panics when stdout
//! cannot be written (a pipe whose reader has gone, a full disk, `/dev/full`);
//! here that is an error the command returns, so the process exits with 1 and
//! says why. (A stdout closed before the start is `/dev/null` to a Rust
//! program: the runtime opens it there, so writing to it succeeds.)

use std::io::{self, Write};

/// Writes `text` to stdout and flushes it.
pub fn print(text: &str) -> Result<(), String> {
    write(text.as_bytes())
}

/// Writes `bytes` to stdout and flushes them.
pub fn write(bytes: &[u8]) -> Result<(), String> {
    let mut out = io::stdout().lock();
    out.write_all(bytes)
        .and_then(|()| out.flush())
        .map_err(|e| format!("cannot write to standard output: {e}"))
}
