//! `--threads`: the same bytes for every thread count.

mod common;

use common::{bin, dir};

/// Shapes that exercise every parallel stage: closed, with a handle, open
/// (border loops), noisy (splitting, refinement), and large enough for region
/// growing in slabs (2, 3 and 4 of them on 2, 3 and 8 threads).
const CASES: [(&str, &[&str]); 5] = [
    (
        "demo-slabs",
        &["--sample", "demo", "--points", "17000", "--clusters", "300"],
    ),
    (
        "sphere",
        &[
            "--sample",
            "sphere",
            "--points",
            "6000",
            "--clusters",
            "200",
        ],
    ),
    (
        "torus",
        &["--sample", "torus", "--points", "6000", "--clusters", "200"],
    ),
    (
        "holed",
        &[
            "--sample",
            "holed-sphere",
            "--points",
            "6000",
            "--clusters",
            "150",
        ],
    ),
    (
        "noisy-box",
        &[
            "--sample",
            "box",
            "--points",
            "8000",
            "--noise",
            "0.002",
            "--clusters",
            "250",
        ],
    ),
];

#[test]
fn the_mesh_is_byte_identical_on_1_2_3_and_8_threads() {
    identical_on_every_thread_count("identical", &[]);
}

/// The sweeps of `--partition sweep` (the default from 131,072 points) run on
/// every thread: they too must give the same bytes.
#[test]
fn the_mesh_partitioned_by_sweeps_is_byte_identical_on_1_2_3_and_8_threads() {
    identical_on_every_thread_count("sweeps", &["--partition", "sweep"]);
}

fn identical_on_every_thread_count(tag: &str, extra: &[&str]) {
    let d = dir("threads", tag);
    for (name, args) in CASES {
        let mut first: Option<Vec<u8>> = None;
        for threads in ["1", "2", "3", "8"] {
            let out = d.join(format!("{name}-{threads}.ply"));
            let run = bin()
                .args(["reconstruct", "-q", "--threads", threads])
                .args(args)
                .args(extra)
                .arg("-o")
                .arg(&out)
                .output()
                .unwrap();
            assert!(run.status.success(), "{name} on {threads} threads: {run:?}");
            let bytes = std::fs::read(&out).unwrap();
            assert!(bytes.len() > 1000, "{name}: an empty mesh");
            match &first {
                None => first = Some(bytes),
                Some(one) => assert!(
                    *one == bytes,
                    "{name}: the mesh on {threads} threads differs from the one on 1"
                ),
            }
        }
    }
}

#[test]
fn a_thread_count_out_of_range_is_refused_by_name() {
    for bad in ["0", "65", "-2", "many"] {
        let run = bin()
            .args(["reconstruct", "-q", "--threads", bad, "-o", "/dev/null"])
            .output()
            .unwrap();
        assert!(!run.status.success());
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(
            err.contains("--threads") && err.contains("1 to 64"),
            "{bad}: {err}"
        );
    }
}
