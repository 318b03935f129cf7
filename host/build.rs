//! Sets `cfg(shared_data)` when the real models are beside the repository
//! (`../shared/data/clouds`). Tests that read them are
//! `#[cfg_attr(not(shared_data), ignore = "...")]`, so without the data
//! `cargo test` lists them as ignored, with the reason, instead of passing
//! them silently. (arena-tests builds with this script too.)
//!
//! The script re-runs when `../shared` changes. When `../shared` does not
//! exist at all it watches only itself (a missing path would rebuild the
//! crate on every build): after adding the data then, `touch host/build.rs`.

use std::path::Path;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(shared_data)");
    let manifest = std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR");
    let shared = Path::new(&manifest).join("../../shared");
    if shared.is_dir() {
        println!("cargo::rerun-if-changed={}", shared.display());
    } else {
        // This file (arena-tests builds with it too, hence the way round).
        let this = Path::new(&manifest).join("../host/build.rs");
        println!("cargo::rerun-if-changed={}", this.display());
    }
    if shared.join("data/clouds").is_dir() {
        println!("cargo::rustc-cfg=shared_data");
    }
}
