//! Helpers shared by the host's integration tests.
#![allow(dead_code)] // each test binary uses its own subset

pub mod glb;

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The `vsaqem` binary under test.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_vsaqem"))
}

/// Runs `vsaqem COMMAND -q ARGS -o OUT --report JSON`.
pub fn run_with_report<S: AsRef<OsStr>>(
    command: &str,
    args: impl IntoIterator<Item = S>,
    out: &Path,
    json: &Path,
) -> Output {
    bin()
        .args([command, "-q"])
        .args(args)
        .arg("-o")
        .arg(out)
        .arg("--report")
        .arg(json)
        .output()
        .unwrap()
}

/// A fresh, empty directory `group/name` under the target's temporary folder.
pub fn dir(group: &str, name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(group)
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A small built-in sample for quick runs: 4000 points on a sphere, 120 clusters.
pub const SMALL: [&str; 6] = [
    "--sample",
    "sphere",
    "--points",
    "4000",
    "--clusters",
    "120",
];

/// The value of a top-level numeric field of a JSON report.
pub fn field(report: &str, key: &str) -> f64 {
    let v: serde_json::Value = serde_json::from_str(report).unwrap();
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} missing or not a number in {report}"))
}
