//! `vsaqem reconstruct` end to end: formats, reports, errors, determinism.

mod common;
use common::{bin, run_with_report, SMALL};

use std::path::PathBuf;

fn dir(name: &str) -> PathBuf {
    common::dir("reconstruct", name)
}

#[test]
fn an_unknown_output_format_fails_before_any_work() {
    let d = dir("format");
    let out = d.join("mesh.stl");
    let r = bin()
        .args(["reconstruct", "-q"])
        .args(SMALL)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("mesh.stl") && stderr.contains("ply"),
        "{stderr}"
    );
    assert!(
        r.stdout.is_empty(),
        "work was done before the format was checked"
    );
    assert!(!out.exists());
}

#[test]
fn every_output_format_holds_the_reported_mesh() {
    let d = dir("formats");
    for ext in ["ply", "obj", "off"] {
        let out = d.join(format!("mesh.{ext}"));
        let json = d.join(format!("report_{ext}.json"));
        let r = run_with_report("reconstruct", SMALL, &out, &json);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        let (v, t) = vsaqem::io::read_mesh(&out).unwrap();
        let report = std::fs::read_to_string(&json).unwrap();
        let field = |k: &str| common::field(&report, k);
        assert_eq!(field("faces") as usize, t.len(), "{ext}");
        assert_eq!(field("vertices") as usize, v.len(), "{ext}");
        for key in [
            "solver_optimal",
            "candidate_facets",
            "boundary_edges",
            "arena_peak_bytes",
            "time_ms",
        ] {
            assert!(report.contains(key), "{key} missing from {report}");
        }
    }
}

#[test]
fn reconstruction_is_byte_identical_across_runs() {
    let d = dir("determinism");
    let run = |name: &str| {
        let out = d.join(name);
        let r = bin()
            .args(["reconstruct", "-q"])
            .args(SMALL)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        assert!(r.status.success());
        std::fs::read(out).unwrap()
    };
    assert_eq!(run("a.ply"), run("b.ply"));
}

#[test]
fn bad_input_leaves_no_output() {
    let d = dir("bad");
    let input = d.join("flat.xyz");
    let text: String = (0..200)
        .map(|i| format!("{} {} 0.5\n", i % 20, i / 20))
        .collect();
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
    assert_eq!(r.status.code(), Some(1));
    assert!(
        stderr.contains("flat.xyz") && stderr.contains("one plane"),
        "{stderr}"
    );
    assert!(!out.exists());
}
