//! Helpers shared by the host's integration tests.
#![allow(dead_code)] // each test binary uses its own subset

pub mod glb;

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};
use vsaqem::io::read_cloud;

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

/// Reads `path` as a cloud, expects an error, checks it names the file and contains
/// every `detail`, and that it came back (no giant allocation or endless
/// loop: 20 s, as the hostile-argument tests allow, because under qemu on a
/// loaded machine a read of milliseconds takes seconds).
pub fn cloud_err(path: &Path, details: &[&str]) -> String {
    let t = Instant::now();
    let r = read_cloud(path);
    assert!(
        t.elapsed() < Duration::from_secs(20),
        "took {:?}",
        t.elapsed()
    );
    let msg = match r {
        Ok(c) => panic!("{} read as {} points", path.display(), c.positions.len()),
        Err(e) => e.to_string(),
    };
    check_msg(path, &msg, details);
    msg
}

/// Checks that `msg` names the file of `path` and contains every `details`.
pub fn check_msg(path: &Path, msg: &str, details: &[&str]) {
    let name = path.file_name().unwrap().to_str().unwrap();
    assert!(msg.contains(name), "message does not name {name}: {msg}");
    for d in details {
        assert!(msg.contains(d), "message lacks {d:?}: {msg}");
    }
}
