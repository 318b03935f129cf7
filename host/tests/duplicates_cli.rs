//! Exact duplicate points: merged as they are read (the first copy of each
//! position kept, with its colour), counted in the report, and so neither a
//! pile of copies nor a cloud stored several times changes the mesh.

mod common;
use common::{bin, run_with_report};

use std::path::{Path, PathBuf};

fn dir(name: &str) -> PathBuf {
    common::dir("duplicates", name)
}

/// `n` points spread evenly over the unit sphere (a Fibonacci lattice), with
/// a colour each.
fn sphere(n: usize) -> Vec<([f64; 3], [u8; 3])> {
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let t = i as f64 * 2.399_963_229_728_653;
            let c = [(i % 256) as u8, (i / 256 % 256) as u8, 7];
            ([r * t.cos(), r * t.sin(), z], c)
        })
        .collect()
}

/// Writes `points` as text columns x y z r g b, every digit kept.
fn write_xyz(path: &Path, points: &[([f64; 3], [u8; 3])]) {
    let text: String = points
        .iter()
        .map(|(p, c)| {
            format!(
                "{:?} {:?} {:?} {} {} {}\n",
                p[0], p[1], p[2], c[0], c[1], c[2]
            )
        })
        .collect();
    std::fs::write(path, text).unwrap();
}

/// Runs `reconstruct` on `input` at 150 clusters, with a JSON report; returns
/// the mesh's bytes and the report.
fn reconstruct(input: &Path, d: &Path, name: &str) -> (Vec<u8>, String) {
    let out = d.join(format!("{name}.ply"));
    let json = d.join(format!("{name}.json"));
    let args = [
        input.to_str().unwrap(),
        "--columns",
        "x,y,z,r,g,b",
        "--clusters",
        "150",
    ];
    let r = run_with_report("reconstruct", args, &out, &json);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let text = String::from_utf8_lossy(&r.stdout).to_string();
    let report = std::fs::read_to_string(&json).unwrap();
    assert!(text.starts_with("input "), "{text}");
    (std::fs::read(&out).unwrap(), report)
}

#[test]
fn a_cloud_stored_ten_times_gives_the_mesh_of_the_cloud_stored_once() {
    let d = dir("ten_times");
    let once = sphere(3000);
    // Ten copies one after the other; the copies after the first carry other
    // colours, which the first copy's override.
    let mut ten = once.clone();
    for c in 1..10u8 {
        ten.extend(once.iter().map(|&(p, _)| (p, [c, 255 - c, c])));
    }
    let (a, b) = (d.join("once.xyz"), d.join("ten.xyz"));
    write_xyz(&a, &once);
    write_xyz(&b, &ten);
    let (mesh_once, report_once) = reconstruct(&a, &d, "once");
    let (mesh_ten, report_ten) = reconstruct(&b, &d, "ten");
    assert!(mesh_once == mesh_ten, "the meshes differ");
    let field = |r: &str, k: &str| common::field(r, k);
    assert_eq!(field(&report_once, "duplicates_merged"), 0.0);
    assert_eq!(field(&report_ten, "duplicates_merged"), 27_000.0);
    assert_eq!(field(&report_ten, "points_read"), 30_000.0);
    assert_eq!(field(&report_ten, "points"), 3000.0);
    assert_eq!(field(&report_ten, "fragments_dropped"), 0.0);
}

#[test]
fn a_pile_of_copies_is_one_point_to_the_fragment_filter() {
    // 2,000 copies of one point inside the sphere were "the largest piece" and
    // the sphere a fragment; merged, the pile is one stray point, dropped, and
    // the mesh is the sphere's.
    let d = dir("pile");
    let once = sphere(3000);
    let mut piled = once.clone();
    piled.extend(std::iter::repeat_n(([0.3, 0.2, 0.1], [1, 2, 3]), 2000));
    let (a, b) = (d.join("sphere.xyz"), d.join("piled.xyz"));
    write_xyz(&a, &once);
    write_xyz(&b, &piled);
    let (mesh_once, _) = reconstruct(&a, &d, "sphere");
    let (mesh_piled, report) = reconstruct(&b, &d, "piled");
    assert!(mesh_once == mesh_piled, "the pile changed the mesh");
    let field = |k: &str| common::field(&report, k);
    assert_eq!(field("duplicates_merged"), 1999.0);
    assert_eq!(field("fragments_dropped"), 1.0);
    assert_eq!(field("fragment_points"), 1.0);
    assert_eq!(field("points"), 3000.0);
}

#[test]
fn many_copies_of_few_positions_are_merged_before_any_search() {
    // 200,000 points at 4 positions: the neighbour search and the cleaning
    // pre-pass took minutes over the piles; merged first, the run stops at
    // once on the 4 distinct points, and says so.
    let d = dir("four");
    let input = d.join("four.xyz");
    let corners = ["0 0 0\n", "1 0 0\n", "0 1 0\n", "0 0 1\n"];
    let text: String = (0..200_000).map(|i| corners[i % 4]).collect();
    std::fs::write(&input, text).unwrap();
    let out = d.join("mesh.ply");
    let r = bin()
        .args(["reconstruct", "-q"])
        .arg(&input)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{stderr}");
    common::check_msg(
        &input,
        &stderr,
        &[
            "with 4 points",
            "4 distinct of 200000 read: 199996 exact duplicates merged",
        ],
    );
    assert!(!out.exists());
}

#[test]
fn cluster_reports_the_duplicates_merged_and_writes_the_distinct_points() {
    let d = dir("cluster");
    let once = sphere(2000);
    let mut twice = once.clone();
    twice.extend(once.iter().copied());
    let input = d.join("twice.xyz");
    write_xyz(&input, &twice);
    let (out, json) = (d.join("clusters.ply"), d.join("clusters.json"));
    let args = [
        input.to_str().unwrap(),
        "--columns",
        "x,y,z,r,g,b",
        "--clusters",
        "50",
    ];
    let r = run_with_report("cluster", args, &out, &json);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let text = String::from_utf8_lossy(&r.stdout);
    assert!(
        text.contains("4000 points, 2000 exact duplicates merged (2000 distinct)"),
        "{text}"
    );
    let report = std::fs::read_to_string(&json).unwrap();
    assert_eq!(common::field(&report, "duplicates_merged"), 2000.0);
    // The points written: the distinct ones, then the generators.
    let written = vsaqem::io::read_cloud(&out).unwrap();
    let clusters = common::field(&report, "clusters") as usize;
    assert_eq!(written.positions.len(), 2000 + clusters);
}
