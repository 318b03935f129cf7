//! `reconstruct` never ends with exit 0 and an empty mesh: parameters that
//! cannot give one are refused before any work, and a run whose mesh has no
//! face with area fails, nothing written, unless `--allow-empty`.

mod common;
use common::bin;

use std::path::{Path, PathBuf};
use std::process::Output;

fn dir(name: &str) -> PathBuf {
    common::dir("empty_mesh", name)
}

/// `vsaqem reconstruct -q ARGS -o OUT --report JSON` in `d`, with the paths
/// of the mesh and the report.
fn reconstruct(d: &Path, args: &[&str]) -> (Output, PathBuf, PathBuf) {
    let (out, json) = (d.join("mesh.ply"), d.join("report.json"));
    let r = bin()
        .args(["reconstruct", "-q"])
        .args(args)
        .arg("-o")
        .arg(&out)
        .arg("--report")
        .arg(&json)
        .output()
        .unwrap();
    (r, out, json)
}

/// Asserts that `r` failed with exit 1, a message holding every `details`,
/// and wrote neither the mesh nor the report.
fn refused(r: &Output, out: &Path, json: &Path, details: &[&str]) -> String {
    let stderr = String::from_utf8_lossy(&r.stderr).to_string();
    assert_eq!(r.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    for d in details {
        assert!(stderr.contains(d), "message lacks {d:?}: {stderr}");
    }
    assert!(!out.exists(), "a mesh was written: {stderr}");
    assert!(!json.exists(), "a report was written: {stderr}");
    stderr
}

/// Writes `points` as an `x y z` text cloud at `path`.
fn write_xyz(path: &Path, points: &[[f64; 3]]) {
    let text: String = points
        .iter()
        .map(|p| format!("{} {} {}\n", p[0], p[1], p[2]))
        .collect();
    std::fs::write(path, text).unwrap();
}

#[test]
fn parameters_that_cannot_give_a_mesh_are_refused_before_any_work() {
    let d = dir("params");
    let sphere = ["--sample", "sphere", "--points", "4000"];
    for (args, details) in [
        (
            &["--clusters", "1"][..],
            &[
                "--clusters 1",
                "cannot enclose a volume",
                "use --clusters 4 or more",
            ][..],
        ),
        (
            &["--clusters", "3"],
            &[
                "--clusters 3",
                "cannot enclose a volume",
                "use --clusters 4 or more",
            ],
        ),
        (
            &["--epsilon", "1e-45"],
            &[
                "--epsilon 1e-45",
                "precision",
                "use --epsilon 1.1920929e-7 or more",
            ],
        ),
        (
            &["--fitting", "0", "--coverage", "0"],
            &["--fitting 0 and --coverage 0", "score 0", "positive weight"],
        ),
    ] {
        let all: Vec<&str> = sphere.iter().chain(args).copied().collect();
        let (r, out, json) = reconstruct(&d, &all);
        refused(&r, &out, &json, details);
        // Before any work: no report, not even its first line.
        assert!(r.stdout.is_empty(), "{args:?}: work was done first");
        // Nothing memory-related stands in for the cause.
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert!(!stderr.contains("memory"), "{args:?}: {stderr}");
    }
    // Each alone is fine: one weight of 0, the smallest epsilon, 4 clusters.
    for args in [
        &["--fitting", "0"][..],
        &["--coverage", "0"],
        &["--epsilon", "1.1920929e-7", "--clusters", "100"],
        &["--clusters", "4"],
    ] {
        let all: Vec<&str> = sphere.iter().chain(args).copied().collect();
        let (r, out, _) = reconstruct(&d, &all);
        assert!(
            r.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&r.stderr)
        );
        let (_, t) = vsaqem::io::read_mesh(&out).unwrap();
        assert!(!t.is_empty(), "{args:?}");
        std::fs::remove_file(&out).unwrap();
    }
}

#[test]
fn clustering_alone_still_takes_fewer_than_four_clusters() {
    let d = dir("cluster");
    let out = d.join("clusters.ply");
    let r = bin()
        .args(["cluster", "-q", "--sample", "sphere", "--points", "2000"])
        .args(["--clusters", "3", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(out.exists());
}

#[test]
fn a_mesh_without_faces_fails_and_writes_nothing() {
    let d = dir("no_faces");
    let tetra = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    let four = d.join("four.xyz");
    write_xyz(&four, &tetra);
    let mut more = tetra.to_vec();
    more.push([1.0, 1.0, 1.0]);
    let five = d.join("five.xyz");
    write_xyz(&five, &more);
    // 200,000 points at the tetrahedron's corners: 4 once merged.
    let piles: Vec<[f64; 3]> = (0..200_000).map(|i| tetra[i % 4]).collect();
    let piled = d.join("piled.xyz");
    write_xyz(&piled, &piles);
    for input in [&four, &five, &piled] {
        let name = input.to_str().unwrap();
        let (r, out, json) = reconstruct(&d, &[name, "--knn", "3", "--clusters", "4"]);
        let stderr = refused(
            &r,
            &out,
            &json,
            &["the mesh has no faces", "nothing written", "--allow-empty"],
        );
        common::check_msg(input, &stderr, &["per cluster", "give more points"]);
    }
    // Enough points per cluster, but none near enough a facet to support it:
    // the advice is the support distance.
    let (r, out, json) = reconstruct(
        &d,
        &[
            "--sample",
            "sphere",
            "--points",
            "50",
            "--knn",
            "3",
            "--clusters",
            "10",
        ],
    );
    refused(
        &r,
        &out,
        &json,
        &["the mesh has no faces", "larger --epsilon", "--allow-empty"],
    );
}

#[test]
fn allow_empty_writes_the_empty_mesh_with_a_warning() {
    let d = dir("allow");
    let four = d.join("four.xyz");
    write_xyz(
        &four,
        &[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ],
    );
    let name = four.to_str().unwrap();
    let args = [name, "--knn", "3", "--clusters", "4", "--allow-empty"];
    let (r, out, json) = reconstruct(&d, &args);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning") && stderr.contains("the mesh has no faces"),
        "{stderr}"
    );
    let (_, t) = vsaqem::io::read_mesh(&out).unwrap();
    assert!(t.is_empty());
    let report = std::fs::read_to_string(&json).unwrap();
    assert_eq!(common::field(&report, "faces"), 0.0);
}

#[test]
fn too_few_points_per_cluster_for_meshing_memory_says_how_few() {
    // 50 points at 10 clusters: the candidate graph outgrows meshing's
    // capacity; the message gives the points per cluster behind it.
    let d = dir("capacity");
    let (r, out, json) = reconstruct(
        &d,
        &["--sample", "sphere", "--points", "50", "--clusters", "10"],
    );
    refused(
        &r,
        &out,
        &json,
        &[
            "--mesh-bytes-per-cluster",
            "50 points, 2.5 per cluster of the cap 20",
        ],
    );
}
