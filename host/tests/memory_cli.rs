//! `--memory`: the arena budget of `reconstruct` and `cluster`, checked before any
//! work against the least any cloud of that size needs, then by core against
//! what this cloud's neighbour graph needs as soon as it is counted.

mod common;
use common::{bin, field, run_with_report, SMALL};

use std::path::{Path, PathBuf};
use std::process::Output;
use vsaqem_core::{
    arena_bytes, clean_bytes_for, cluster_bytes, cluster_bytes_for, reconstruct_bytes_for, Params,
};

fn dir(name: &str) -> PathBuf {
    common::dir("memory", name)
}

fn params() -> Params {
    Params {
        clusters: 120,
        ..Params::default()
    }
}

fn run(command: &str, d: &Path, memory: &str) -> (Output, PathBuf, PathBuf) {
    let out = d.join(if command == "cluster" {
        "clusters.ply"
    } else {
        "mesh.ply"
    });
    let json = d.join("report.json");
    let args = SMALL.map(String::from).into_iter();
    let r = run_with_report(
        command,
        args.chain([format!("--memory={memory}")]),
        &out,
        &json,
    );
    (r, out, json)
}

#[test]
fn a_budget_below_the_least_fails_at_once_naming_the_bytes_needed() {
    // The least any 4000 points need: the run on cleaning's table (nothing
    // searched, no one-way edge), or the cleaning with the table outside.
    let p = params();
    let clean = clean_bytes_for(4000, &p, true);
    for (command, least, most) in [
        (
            "reconstruct",
            reconstruct_bytes_for(4000, &p, 0, false).max(clean),
            arena_bytes(4000, &p).max(vsaqem_core::clean_bytes(4000, &p)),
        ),
        (
            "cluster",
            cluster_bytes_for(4000, &p, 0, false).max(clean),
            cluster_bytes(4000, &p).max(vsaqem_core::clean_bytes(4000, &p)),
        ),
    ] {
        let d = dir(&format!("small_{command}"));
        let (r, out, json) = run(command, &d, &(least - 1).to_string());
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(1), "{command}: {stderr}");
        assert!(
            stderr.contains(&format!("needs at least {least} bytes"))
                && stderr.contains(&format!("up to {most},"))
                && stderr.contains(&format!("--memory {} bytes", least - 1)),
            "{command}: {stderr}"
        );
        assert!(!stderr.contains("panicked"), "{stderr}");
        // Nothing was run: no report, no output, no partial file.
        assert!(r.stdout.is_empty(), "{command} reported work");
        assert!(!out.exists() && !json.exists());
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 0);
    }
}

#[test]
fn the_bound_itself_is_enough_and_the_output_does_not_depend_on_the_budget() {
    let needed = arena_bytes(4000, &params());
    let d = dir("exact");
    let (r, out, json) = run("reconstruct", &d, &needed.to_string());
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let report = std::fs::read_to_string(&json).unwrap();
    assert_eq!(field(&report, "arena_reserved_bytes") as usize, needed);
    assert!(field(&report, "arena_peak_bytes") as usize <= needed);
    let exact = std::fs::read(&out).unwrap();
    // A bigger budget (with a unit) gives the same mesh, byte for byte.
    let d = dir("bigger");
    let (r, out, json) = run("reconstruct", &d, "64MiB");
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let report = std::fs::read_to_string(&json).unwrap();
    assert_eq!(field(&report, "arena_reserved_bytes") as usize, 64 << 20);
    assert_eq!(std::fs::read(&out).unwrap(), exact);
}

#[test]
fn the_clouds_own_need_is_reported_enough_and_a_granule_less_is_refused_after_the_search() {
    let worst = arena_bytes(4000, &params());
    let d = dir("worst");
    let (r, out, json) = run("reconstruct", &d, &worst.to_string());
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let report = std::fs::read_to_string(&json).unwrap();
    let needed = field(&report, "arena_needed_bytes") as usize;
    let peak = field(&report, "arena_peak_bytes") as usize;
    assert!(
        peak <= needed && needed < worst,
        "peak {peak}, needed {needed}, worst {worst}"
    );
    let mesh = std::fs::read(&out).unwrap();
    // The need reported is enough, for the same mesh.
    let d = dir("needed");
    let (r, out, _) = run("reconstruct", &d, &needed.to_string());
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(std::fs::read(&out).unwrap(), mesh);
    // A granule less (the need includes 7 bytes of alignment slack) passes the
    // check before any work (it is above the least), and is refused once the
    // one-way edges are counted, naming the need: no output.
    let d = dir("short");
    let (r, out, json) = run("reconstruct", &d, &(needed - 8).to_string());
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("one-way edges") && stderr.contains("(--memory)"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(!out.exists() && !json.exists());
}

#[test]
fn sizes_take_units_and_a_bad_one_is_named() {
    for (given, bytes) in [
        ("0.25GiB", 1usize << 28),
        ("48 MiB", 48 << 20),
        ("30000000", 30_000_000),
    ] {
        let d = dir("units");
        let (r, _, json) = run("cluster", &d, given);
        assert!(
            r.status.success(),
            "{given}: {}",
            String::from_utf8_lossy(&r.stderr)
        );
        let report = std::fs::read_to_string(&json).unwrap();
        assert_eq!(
            field(&report, "arena_reserved_bytes") as usize,
            bytes,
            "{given}"
        );
    }
    for bad in ["64XiB", "lots", "-3MiB", "1.5"] {
        let d = dir("bad_unit");
        let (r, out, _) = run("reconstruct", &d, bad);
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert!(!r.status.success(), "{bad} accepted");
        assert!(stderr.contains(&format!("'{bad}'")), "{bad}: {stderr}");
        assert!(!out.exists());
    }
}

#[test]
fn a_candidate_graph_too_dense_for_the_meshing_capacity_names_the_option() {
    // 4000 points in 1000 clusters, two points per cluster of the cap, and a
    // meshing capacity of one byte per cluster.
    let d = dir("dense");
    let out = d.join("mesh.ply");
    let r = bin()
        .args([
            "reconstruct",
            "-q",
            "--sample",
            "sphere",
            "--points",
            "4000",
        ])
        .args(["--clusters", "1000", "--mesh-bytes-per-cluster", "1", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("candidate graph is too dense")
            && stderr.contains("--mesh-bytes-per-cluster, now 1;")
            && stderr.contains("4000 points, 2.0 per cluster of the cap 2000)"),
        "{stderr}"
    );
    assert!(!out.exists());
}
