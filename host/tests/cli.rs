//! The `vsaqem` binary end to end: clear errors, no partial output, determinism.

mod common;
use common::{bin, run_with_report};

use std::path::{Path, PathBuf};

fn dir(name: &str) -> PathBuf {
    common::dir("cli", name)
}

/// Run `vsaqem cluster IN -o OUT` and expect failure with every `needles` in stderr
/// and no output file (nor temp file) left behind.
fn expect_failure(d: &Path, input: &Path, needles: &[&str]) {
    let out = d.join("out.ply");
    let r = bin()
        .args(["cluster", "-q"])
        .arg(input)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success(), "{}: succeeded", input.display());
    assert_eq!(r.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    for n in needles {
        assert!(
            stderr.contains(n),
            "{}: '{n}' not in: {stderr}",
            input.display()
        );
    }
    let left: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(!out.exists(), "partial output left: {left:?}");
    assert!(
        left.iter().all(|f| !f.to_string_lossy().ends_with(".tmp")),
        "temp left: {left:?}"
    );
}

fn write(d: &Path, name: &str, content: &[u8]) -> PathBuf {
    let p = d.join(name);
    std::fs::write(&p, content).unwrap();
    p
}

fn xyz(points: &[[f64; 3]]) -> Vec<u8> {
    points
        .iter()
        .map(|p| format!("{} {} {}\n", p[0], p[1], p[2]))
        .collect::<String>()
        .into_bytes()
}

#[test]
fn hostile_files_fail_with_a_clear_message_and_no_output() {
    let d = dir("hostile");
    let ply_head = "ply\nformat binary_little_endian 1.0\nelement vertex 1000\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    let mut truncated = ply_head.as_bytes().to_vec();
    truncated.extend(std::iter::repeat_n(0u8, 120));
    let cases: Vec<(PathBuf, Vec<&str>)> = vec![
        (write(&d, "truncated.ply", &truncated), vec!["truncated.ply", "1000"]),
        (write(&d, "empty.xyz", b""), vec!["empty.xyz"]),
        (write(&d, "nan.xyz", b"0 0 0\n1 0 0\n0 nan 1\n1 1 1\n"), vec!["nan.xyz", "line 3"]),
        (write(&d, "inf.xyz", b"0 0 0\n1 0 0\n0 1 inf\n1 1 1\n"), vec!["inf.xyz", "line 3"]),
        (write(&d, "columns.xyz", b"0 0 0\n1 0\n"), vec!["columns.xyz", "line 2"]),
        (write(&d, "single.xyz", b"0.5 0.25 1\n"), vec!["single.xyz", "1 points", "at least 4"]),
        (write(&d, "dups.xyz", &xyz(&[[0.3, 0.3, 0.3]; 50])), vec!["dups.xyz", "all points coincide"]),
        (
            write(&d, "coplanar.xyz", &xyz(&(0..100).map(|i| [(i % 10) as f64, (i / 10) as f64, 2.0]).collect::<Vec<_>>())),
            vec!["coplanar.xyz", "one plane"],
        ),
        (
            write(&d, "collinear.xyz", &xyz(&(0..100).map(|i| [i as f64, 2.0 * i as f64, 1.0]).collect::<Vec<_>>())),
            vec!["collinear.xyz", "one line"],
        ),
        (write(&d, "bad.pcd", b"VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 5\nHEIGHT 1\nPOINTS 5\nDATA binary_compressed\n"), vec!["bad.pcd", "compressed"]),
        (write(&d, "points.stl", b"solid"), vec!["points.stl", "no triangles"]),
        (write(&d, "organised.pcd", b"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 2\nDATA ascii\nnan nan nan\n1 2 3\n"), vec!["organised.pcd", "line 9: file ends after 2 of 4 points"]),
        (write(&d, "scan.e57", b"ASTM-E57"), vec!["scan.e57", "E57 header"]),
        (write(&d, "scan.fls", b"FARO"), vec!["scan.fls", "unknown extension", ".laz"]),
        (d.join("missing.ply"), vec!["missing.ply"]),
    ];
    for (path, needles) in cases {
        expect_failure(&d, &path, &needles);
    }
}

#[test]
fn bad_parameters_fail_before_any_work() {
    let d = dir("params");
    let out = d.join("o.ply");
    for args in [
        vec!["--knn", "0"],
        vec!["--knn", "40"],
        vec!["--tolerance", "-1"],
        vec!["--clusters", "0"],
    ] {
        let r = bin()
            .args(["cluster", "-q", "--points", "2000", "-o"])
            .arg(&out)
            .args(&args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert!(
            !r.status.success() && !stderr.contains("panicked"),
            "{args:?}: {stderr}"
        );
        assert!(!out.exists());
    }
}

#[test]
fn same_input_and_seed_give_byte_identical_files_and_another_seed_differs() {
    let d = dir("determinism");
    let run = |name: &str, seed: &str| {
        let out = d.join(name);
        let r = bin()
            .args([
                "cluster",
                "-q",
                "--sample",
                "torus",
                "--points",
                "6000",
                "--clusters",
                "200",
                "--seed",
                seed,
                "-o",
            ])
            .arg(&out)
            .output()
            .unwrap();
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        std::fs::read(out).unwrap()
    };
    let a = run("a.ply", "7");
    assert_eq!(a, run("b.ply", "7"));
    assert_ne!(a, run("c.ply", "8"));
}

#[test]
fn the_report_names_every_stage_and_the_json_report_is_written() {
    let d = dir("report");
    let out = d.join("o.ply");
    let json = d.join("r.json");
    let r = run_with_report(
        "cluster",
        ["--points", "5000", "--clusters", "100"],
        &out,
        &json,
    );
    assert!(r.status.success());
    let text = String::from_utf8_lossy(&r.stdout);
    for word in [
        "5000 points",
        "neighbours",
        "quadrics",
        "clustering",
        "arena peak",
        "bytes/point",
    ] {
        assert!(text.contains(word), "'{word}' missing from: {text}");
    }
    let j = std::fs::read_to_string(json).unwrap();
    for key in [
        "\"clusters\"",
        "\"arena_peak_bytes\"",
        "\"time_ms\"",
        "\"max_error_relative\"",
    ] {
        assert!(j.contains(key), "{key} missing: {j}");
    }
    // The output holds the points then the generators, each with a cluster id.
    let cloud = vsaqem::io::read_cloud(&out).unwrap();
    assert!(cloud.positions.len() > 5000);
}

#[test]
fn a_run_that_reaches_the_cluster_cap_with_the_tolerance_unmet_says_so() {
    let d = dir("cap");
    let run = |max_clusters: &str, split_rounds: &str, name: &str| {
        let (out, json) = (
            d.join(format!("{name}.ply")),
            d.join(format!("{name}.json")),
        );
        let args = ["--sample", "torus", "--points", "5000", "--clusters", "40"];
        let limits = [
            "--max-clusters",
            max_clusters,
            "--split-rounds",
            split_rounds,
        ];
        let r = run_with_report("reconstruct", args.into_iter().chain(limits), &out, &json);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        let j = std::fs::read_to_string(json).unwrap();
        (String::from_utf8_lossy(&r.stderr).into_owned(), j)
    };
    // Splitting may not add a cluster: 40 are far too few for 0.5 %.
    let (stderr, j) = run("40", "5", "capped");
    assert!(
        stderr.contains("warning") && stderr.contains("cluster cap 40 is reached"),
        "{stderr}"
    );
    assert!(j.contains("\"tolerance_met\": false"), "{j}");
    assert_eq!(common::field(&j, "cluster_cap"), 40.0);
    // With room and batches enough to split, the tolerance is met and
    // nothing is said.
    let (stderr, j) = run("1000", "20", "free");
    assert!(!stderr.contains("warning"), "{stderr}");
    assert!(j.contains("\"tolerance_met\": true"), "{j}");
}
