//! Standard output that fails instead of panicking: `print!` panics when stdout
//! cannot be written (a pipe whose reader has gone, a full disk, `/dev/full`);
//! here that is an error the command returns, so the process exits with 1 and
//! says why. (A stdout closed before the start is `/dev/null` to a Rust
//! program: the runtime opens it there, so writing to it succeeds.) The same
//! holds for standard error ([`eprint()`]), where `eprint!` would panic.
//! A warning ([`warn()`]) that stderr cannot take is dropped: it is advice
//! about a result that stands, not the result.

use std::io::{self, BufWriter, Write};

/// Writes `text` to stdout and flushes it.
pub fn print(text: &str) -> Result<(), String> {
    write(text.as_bytes())
}

/// Writes `bytes` to stdout and flushes them.
pub fn write(bytes: &[u8]) -> Result<(), String> {
    write_with(|w| w.write_all(bytes))
}

/// Runs `f` on a buffered stdout (64 KiB), then flushes it: a mesh written
/// with `-o -` goes out in large writes, and any failure is the error
/// returned. What `f` wrote before a failure has gone out: a reader of the
/// pipe sees a truncated stream, which it cannot take for a whole file (a
/// PLY's header gives its counts, a GLB's its length, JSON ends in a brace).
pub fn write_with(f: impl FnOnce(&mut dyn Write) -> io::Result<()>) -> Result<(), String> {
    let mut out = BufWriter::with_capacity(1 << 16, io::stdout().lock());
    f(&mut out)
        .and_then(|()| out.flush())
        .map_err(|e| format!("cannot write to standard output: {e}"))
}

/// Writes `text` to stderr: an error where `eprint!` would panic.
pub fn eprint(text: &str) -> Result<(), String> {
    let mut err = io::stderr().lock();
    err.write_all(text.as_bytes())
        .and_then(|()| err.flush())
        .map_err(|e| format!("cannot write to standard error: {e}"))
}

/// Writes the warning `line` and a newline to stderr (`eprintln!` without its
/// panic), or drops it when stderr cannot take it (closed, full): the run it
/// warns about has its result either way.
pub fn warn(line: std::fmt::Arguments) {
    let _ = eprint(&format!("{line}\n"));
}
