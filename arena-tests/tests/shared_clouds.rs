//! The promises of a mesh on the real models (`../shared/data/clouds`; skipped,
//! with a message, when absent), judged by the host's evaluator (exact
//! self-intersection test, genus count and point-to-mesh distances of its own,
//! not core's statistics), on the points a user's run keeps (cleaned as the CLI
//! cleans, by default):
//! - at 250, 500, 1,000 and 2,000 clusters: no self-intersecting pair, no
//!   coincident vertices, no folded edge, an oriented edge- and vertex-manifold
//!   mesh; a closed model is a valid solid of its true genus (except the pairs
//!   in [`SHORT`], which are checked to still fall short, so that a fix has to
//!   update the list and the README);
//! - the raw scan: under 1 % of its points (those dropped as fragments count)
//!   farther than 1 % of the diagonal at 250, 500 and 1,000 clusters;
//! - `--max-error` 1 % and 0.5 %: met on every model (except [`SHORT_BOUND`]),
//!   and where it is not, core's report says by how much.
//!
//! 60 reconstructions, minutes, so `#[ignore]`d in `cargo test`; CI runs them
//! from the same build (`cargo test -p arena-tests --test shared_clouds -- --ignored`).

use arena_tests::{clean_and_reconstruct, load_shared_cloud, shared_clouds, stem};
use vsaqem::eval::{evaluate, Evaluation};
use vsaqem_core::{Params, V3};

/// The closed models and their genus (`../shared/data/SOURCES.md`; the bunny's
/// base has small holes in the data, which the mesh closes).
const GENUS: [(&str, u64); 9] = [
    ("armadillo", 0),
    ("block", 3),
    ("bolt", 0),
    ("bunny", 0),
    ("fandisk", 0),
    ("gear", 12),
    ("horse", 0),
    ("kitten", 1),
    ("rocker_arm", 1),
];

/// Closed models that are not yet a valid solid of their genus at a cluster
/// count, and why (README, "Known limits"). None: the gear at 250 was the
/// last, until the rounds for the genus.
const SHORT: [(&str, u32, &str); 0] = [];

/// Models and bounds where `--max-error` is not met, and why. None: the raw
/// scan at 0.5 % was the last (it stopped near 1 %, its far points beyond the
/// open border clusters of one point that refinement skipped).
const SHORT_BOUND: [(&str, f32, &str); 0] = [];

/// The cloud's points, those cleaning keeps (as the CLI runs it), and the mesh
/// of the kept points with `params`, with core's statistics of it.
struct Run {
    all: Vec<[f64; 3]>,
    kept: Vec<[f64; 3]>,
    vertices: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
    /// Core's largest point-to-mesh distance, relative to the diagonal.
    core_max: f32,
    /// Rounds for the genus run.
    gap_rounds: u32,
}

fn run(points: &[V3], params: &Params) -> Run {
    let f64s = |v: &[V3]| v.iter().map(|p| p.map(f64::from)).collect::<Vec<_>>();
    clean_and_reconstruct(points, params, |_, kept, r| Run {
        all: f64s(points),
        kept: f64s(kept),
        vertices: f64s(r.mesh.vertices),
        triangles: r.mesh.triangles.to_vec(),
        core_max: r.meshing.mesh.distance.max,
        gap_rounds: r.meshing.gap_rounds,
    })
}

fn summary(e: &Evaluation) -> String {
    format!(
        "{:?} {:?}, max {:.3} %",
        e.topology,
        e.validity,
        100.0 * e.rel(e.point_to_mesh.stats.max)
    )
}

#[test]
#[cfg_attr(
    shared_data,
    ignore = "60 reconstructions of the shared clouds: minutes (CI runs it with --ignored)"
)]
#[cfg_attr(
    not(shared_data),
    ignore = "needs ../shared/data/clouds, not found when this crate was built"
)]
fn shared_clouds_give_valid_meshes_at_every_cluster_count() {
    let Some(files) = shared_clouds() else { return };
    let mut failures = Vec::new();
    for path in &files {
        let name = stem(path);
        let points = load_shared_cloud(path);
        let genus = GENUS.iter().find(|g| g.0 == name).map(|g| g.1);
        for clusters in [250u32, 500, 1000, 2000] {
            let params = Params {
                clusters,
                ..Params::default()
            };
            let r = run(&points, &params);
            let e = evaluate(&r.kept, &r.vertices, &r.triangles, 0);
            let what = format!("{name} at {clusters} clusters: {}", summary(&e));
            eprintln!("{what}");
            if !e.is_sound() {
                failures.push(format!("not a sound mesh: {what}"));
            }
            if let Some(g) = genus {
                let valid = e.is_valid_solid(Some(g));
                let short = SHORT.iter().find(|s| s.0 == name && s.1 == clusters);
                match (valid, short) {
                    (false, None) => {
                        failures.push(format!("not a valid solid of genus {g}: {what}"))
                    }
                    (true, Some(s)) => failures.push(format!(
                        "now a valid solid (remove it from SHORT and the README's known limits; was: {}): {what}",
                        s.2
                    )),
                    _ => {}
                }
            }
            if name == "bunny_scan000" && r.gap_rounds > 0 {
                // Open data: its mesh has a boundary, and rounds for the
                // genus are for closed surfaces.
                failures.push(format!("{} rounds for the genus: {what}", r.gap_rounds));
            }
            if name == "bunny_scan000" && clusters <= 1000 {
                // Every point of the file, those cleaning dropped counting as far.
                let all = evaluate(&r.all, &r.vertices, &r.triangles, 0);
                let dropped = r.all.len() - r.kept.len();
                let far = all.point_to_mesh.far.max(dropped);
                if 100 * far >= r.all.len() {
                    failures.push(format!(
                        "{far} of {} points farther than 1 % of the diagonal: {what}",
                        r.all.len()
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
#[cfg_attr(
    shared_data,
    ignore = "20 reconstructions of the shared clouds under an error bound: minutes (CI runs it with --ignored)"
)]
#[cfg_attr(
    not(shared_data),
    ignore = "needs ../shared/data/clouds, not found when this crate was built"
)]
fn an_error_bound_is_met_on_the_shared_clouds_as_an_independent_evaluation_measures_it() {
    let Some(files) = shared_clouds() else { return };
    let mut failures = Vec::new();
    for path in &files {
        let name = stem(path);
        let points = load_shared_cloud(path);
        for bound in [0.01f32, 0.005] {
            let params = Params {
                max_error: bound,
                ..Params::default()
            };
            let r = run(&points, &params);
            let e = evaluate(&r.kept, &r.vertices, &r.triangles, 0);
            let max = e.rel(e.point_to_mesh.stats.max);
            let what = format!(
                "{name} --max-error {bound}: {} vertices, {}",
                r.vertices.len(),
                summary(&e)
            );
            eprintln!("{what}");
            let short = SHORT_BOUND.iter().find(|s| s.0 == name && s.1 == bound);
            match (max <= f64::from(bound), short) {
                (false, None) => failures.push(format!("bound not met: {what}")),
                (true, Some(s)) => failures.push(format!(
                    "bound now met (remove it from SHORT_BOUND and the README; was: {}): {what}",
                    s.2
                )),
                _ => {}
            }
            // Core's own measure agrees with the evaluator's (the report says
            // honestly how far it is).
            let core = f64::from(r.core_max);
            if (core - max).abs() > 1e-3 * max.max(1e-9) + 1e-6 {
                failures.push(format!("core says {core}, the evaluator {max}: {what}"));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
