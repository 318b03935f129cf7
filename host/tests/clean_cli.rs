//! The cleaning pre-pass from the command line: report lines and JSON fields,
//! clear errors for bad flag values and for cleaning that leaves too little,
//! unchanged output when nothing is removed.

mod common;
use common::{bin, field};

use std::path::{Path, PathBuf};
use std::process::Output;

fn dir(name: &str) -> PathBuf {
    common::dir("clean", name)
}

/// `vsaqem <command> -q --points 6000 --clusters 200 <args> -o OUT`.
fn run(command: &str, args: &[&str], out: &Path) -> Output {
    bin()
        .args([command, "-q", "--points", "6000", "--clusters", "200"])
        .args(args)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap()
}

#[test]
fn the_report_counts_outliers_and_fragments() {
    let d = dir("report");
    let json = d.join("report.json");
    let json_arg = json.to_str().unwrap();
    let r = run(
        "reconstruct",
        &["--sample", "scene", "--report", json_arg],
        &d.join("mesh.ply"),
    );
    let stdout = String::from_utf8_lossy(&r.stdout);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(
        stdout.contains(
            "clean      outlier filter off, 1 fragment dropped (40 points; pieces under 64 \
             points); 5960 of 6000 points kept in 2 pieces\n"
        ),
        "{stdout}"
    );
    let report = std::fs::read_to_string(&json).unwrap();
    for (k, v) in [
        ("points_read", 6000.0),
        ("points", 5960.0),
        ("outliers_removed", 0.0),
        ("fragments_dropped", 1.0),
        ("fragment_points", 40.0),
        ("min_fragment", 64.0),
        ("components", 2.0),
        ("boundary_edges", 0.0),
    ] {
        assert_eq!(field(&report, k), v, "{k}");
    }

    // With the outlier filter on too, and for `cluster`.
    let r = run(
        "cluster",
        &["--sample", "scene", "--outliers", "3", "--report", json_arg],
        &d.join("clusters.ply"),
    );
    let stdout = String::from_utf8_lossy(&r.stdout);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let report = std::fs::read_to_string(&json).unwrap();
    let outliers = field(&report, "outliers_removed");
    let fragment_points = field(&report, "fragment_points");
    assert!(outliers > 0.0, "{report}");
    assert_eq!(
        field(&report, "points"),
        6000.0 - outliers - fragment_points
    );
    assert!(
        stdout.contains(&format!(
            "clean      {outliers} outliers removed (over 3 standard deviations)"
        )),
        "{stdout}"
    );

    // Both filters off: the line says so, and no field counts anything.
    let r = run(
        "reconstruct",
        &[
            "--sample",
            "scene",
            "--min-fragment",
            "0",
            "--report",
            json_arg,
        ],
        &d.join("mesh.ply"),
    );
    assert!(r.status.success());
    assert!(String::from_utf8_lossy(&r.stdout).contains("clean      off\n"));
    let report = std::fs::read_to_string(&json).unwrap();
    assert_eq!(field(&report, "fragment_points"), 0.0);
    assert_eq!(field(&report, "points"), 6000.0);
}

#[test]
fn bad_cleaning_values_fail_naming_the_option_and_the_value() {
    let d = dir("bad_values");
    let out = d.join("mesh.ply");
    for (flag, value) in [
        ("--outliers", "nan"),
        ("--outliers", "-1"),
        ("--outliers", "inf"),
        ("--outliers", "two"),
        ("--min-fragment", "-3"),
        ("--min-fragment", "1.5"),
        ("--min-fragment", "99999999999"),
    ] {
        for command in ["reconstruct", "cluster"] {
            let r = run(command, &["--sample", "sphere", flag, value], &out);
            let stderr = String::from_utf8_lossy(&r.stderr);
            assert!(!r.status.success(), "{command} {flag} {value} succeeded");
            assert!(
                stderr.contains(&format!("'{value}'")) && stderr.contains(flag),
                "{command} {flag} {value}: {stderr}"
            );
            assert!(r.stdout.is_empty() && !out.exists());
        }
    }
}

#[test]
fn cleaning_that_leaves_too_few_points_is_a_clear_error() {
    // Thirty specks of three points, far apart: with k = 2 each is a piece of
    // its own, and the largest (kept) is too small for a surface.
    let d = dir("too_few");
    let mut text = String::new();
    for i in 0..30 {
        let c = [(i % 5) as f64, (i / 5 % 3) as f64, (i / 15) as f64 * 1.3];
        for (dx, dy) in [(0.0, 0.0), (0.001, 0.0), (0.0, 0.001)] {
            text += &format!("{} {} {}\n", c[0] + dx, c[1] + dy, c[2]);
        }
    }
    let input = d.join("specks.xyz");
    std::fs::write(&input, text).unwrap();
    let out = d.join("mesh.ply");
    let r = bin()
        .args(["reconstruct", "-q", "--knn", "2", "--clusters", "20"])
        .arg(&input)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{stderr}");
    for needle in [
        "specks.xyz",
        "cleaning would remove 87 of 90 points",
        "87 in small fragments",
        "leaving 3",
        "--min-fragment 64",
    ] {
        assert!(stderr.contains(needle), "'{needle}' not in {stderr}");
    }
    assert!(!out.exists());
}

#[test]
fn a_run_that_removes_nothing_gives_the_same_mesh_as_no_cleaning() {
    let d = dir("same");
    let mesh = |name: &str, args: &[&str]| {
        let out = d.join(name);
        let r = run("reconstruct", &[&["--sample", "demo"], args].concat(), &out);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        std::fs::read(out).unwrap()
    };
    assert_eq!(
        mesh("default.ply", &[]),
        mesh("off.ply", &["--min-fragment", "0"])
    );
}
