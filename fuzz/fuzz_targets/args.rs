//! The command line, parsed only: an argv of NUL-separated byte strings (not
//! necessarily UTF-8) after `vsaqem`, then what a command works out from its
//! arguments before it reads a file (the core parameters, the output format,
//! the arena sizes for a point count from the first four bytes). Nothing is
//! read, written or run.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::ffi::OsStr;
use std::os::unix::ffi::OsStrExt;
use vsaqem::args::MemoryArgs;
use vsaqem::cli::{Cli, Command};
use vsaqem::io::MeshFormat;
use vsaqem_core::Params;
use vsaqem_fuzz::Bytes;

fuzz_target!(|data: &[u8]| {
    let mut bytes = Bytes::new(data);
    let points = bytes.u32() as usize;
    let words = bytes.rest().split(|&b| b == 0).map(OsStr::from_bytes);
    let cli = match <Cli as clap::Parser>::try_parse_from(
        std::iter::once(OsStr::new("vsaqem")).chain(words),
    ) {
        Ok(cli) => cli,
        Err(e) => {
            // Usage errors, --help and --version are all rendered text.
            assert!(!e.render().to_string().is_empty());
            return;
        }
    };
    match &cli.command {
        Command::Reconstruct(c) => {
            sizes(
                points,
                &c.params(),
                &c.memory,
                vsaqem_core::reconstruct_bytes_for,
            );
            if let Ok(format) = MeshFormat::from_path(&c.output) {
                let _ = format.coords(c.precision, false);
            }
        }
        Command::Cluster(c) => {
            let params = c.clean.apply(c.cluster.params());
            sizes(points, &params, &c.memory, vsaqem_core::cluster_bytes_for);
        }
        _ => {}
    }
});

/// The arena sizes a run of `n` points would ask for, as the commands work
/// them out: most and least, and the `--memory` check between them.
fn sizes(
    n: usize,
    params: &Params,
    memory: &MemoryArgs,
    least: fn(usize, &Params, usize, bool) -> usize,
) {
    let _ = params.validate();
    let most = vsaqem_core::arena_bytes(n, params);
    let least = least(n, params, 0, true);
    let _ = memory.arena_size(most, least, n);
    let _ = vsaqem_core::clean_bytes(n, params);
}
