//! The memory contract of `reconstruct`:
//! - `arena_bytes(n, &params)` is always enough: a run in a buffer of exactly that
//!   size succeeds, or, with a candidate graph too dense for the meshing capacity
//!   (only with few points per cluster), fails with `MeshCapacity`, never
//!   `Exhausted`; with the capacity raised, the raised budget holds too;
//! - it is not wasteful: at most twice the measured peak;
//! - what a cloud needs once its neighbour graph is known,
//!   `reconstruct_bytes_for(n, &params, reverse_edges, true)`, is enough and
//!   gives the same mesh; one byte less is a typed `ArenaTooSmall` naming that
//!   size, never a panic, and the buffer serves a later run unchanged;
//! - from a tiny budget to an ample one, every run succeeds with the same mesh
//!   or is refused with `ArenaTooSmall` (never `Exhausted` part-way), and the
//!   cloud's need is the exact threshold between the two;
//! - the peak grows linearly with the points.
//!
//! Shared clouds are read from `../shared/data/clouds` (skipped when absent).
//! The sweep over all of them is `#[ignore]`d in `cargo test`, as the other
//! sweeps are: CI runs it from the same build (`cargo test -p arena-tests
//! --test memory_budget -- --ignored`); the bunny's threshold test stays.

use arena_tests::{
    cloud, load_shared_cloud, mesh_capacity_may_run_out, shared_clouds, stem, topology, DENSE_BELOW,
};
use std::mem::MaybeUninit;
use std::panic::{catch_unwind, AssertUnwindSafe};
use vsaqem_core::sample::Shape;
use vsaqem_core::{
    arena_bytes, reconstruct, reconstruct_bytes_for, Arena, Error, Params, Silent, V3,
};

/// The parameter sets: the default, few and many clusters, k up and down, and
/// refinement (which runs meshing several times).
fn sets() -> Vec<(&'static str, Params)> {
    let p = |clusters: u32, k: usize, refine_rounds: u32| Params {
        clusters,
        k,
        refine_rounds,
        ..Params::default()
    };
    vec![
        ("1000 clusters", p(1000, 12, 0)),
        ("250 clusters", p(250, 12, 0)),
        ("2000 clusters", p(2000, 12, 0)),
        ("k = 6", p(1000, 6, 0)),
        ("k = 20, 2 refinements", p(1000, 20, 2)),
        ("500 clusters, 2 refinements", p(500, 12, 2)),
    ]
}

/// A mesh, the arena's peak and the neighbour graph's reverse-only edges.
struct Run {
    vertices: Vec<V3>,
    triangles: Vec<[u32; 3]>,
    peak: usize,
    reverse_edges: usize,
}

impl Run {
    /// What this cloud needs: a buffer of this size is enough wherever it
    /// starts; one that starts on an 8-byte boundary needs 7 bytes less
    /// ([`aligned_need`]).
    fn need(&self, n: usize, params: &Params) -> usize {
        reconstruct_bytes_for(n, params, self.reverse_edges, true)
    }
}

/// The threshold for a buffer that starts on an 8-byte boundary (checked):
/// `need` less the 7 bytes of alignment slack it includes.
fn aligned_need(buf: &[MaybeUninit<u8>], need: usize) -> usize {
    assert_eq!(
        buf.as_ptr() as usize % 8,
        0,
        "the test buffer is not 8-byte aligned"
    );
    need - 7
}

/// Reconstruct in `buf`, copying the mesh out.
fn run_in(buf: &mut [MaybeUninit<u8>], points: &[V3], params: &Params) -> Result<Run, Error> {
    let arena = Arena::new(buf);
    let r = reconstruct(&arena, points, None, params, &mut Silent)?;
    Ok(Run {
        vertices: r.mesh.vertices.to_vec(),
        triangles: r.mesh.triangles.to_vec(),
        peak: arena.peak(),
        reverse_edges: r.clustered.stats.reverse_edges as usize,
    })
}

/// Run in a buffer of exactly `arena_bytes` and check the budget: it holds, and
/// it is at most twice the peak. A `MeshCapacity` failure must come from a
/// dense configuration, and the raised capacity's budget must hold in turn.
/// Returns the ratio of budget to peak (`None` after a `MeshCapacity`).
fn check_budget(name: &str, points: &[V3], params: &Params) -> Option<f64> {
    let n = points.len();
    let budget = arena_bytes(n, params);
    let mut buf = vec![MaybeUninit::uninit(); budget];
    match run_in(&mut buf, points, params) {
        Ok(run) => {
            let ratio = budget as f64 / run.peak as f64;
            eprintln!(
                "{name}: peak {} bytes ({:.1}/point), budget {budget} ({ratio:.2}x)",
                run.peak,
                run.peak as f64 / n as f64
            );
            assert!(run.peak <= budget, "{name}: peak above the budget");
            assert!(
                ratio <= 2.0,
                "{name}: budget {budget} is {ratio:.2}x the peak {}",
                run.peak
            );
            assert!(!run.triangles.is_empty(), "{name}: empty mesh");
            Some(ratio)
        }
        Err(e @ Error::MeshCapacity { .. }) => {
            eprintln!("{name}: {e}");
            assert!(
                mesh_capacity_may_run_out(n, params),
                "{name}: {n} points, at least {DENSE_BELOW} per cluster of the cap, \
                 must fit the default meshing capacity: {e}"
            );
            // The guarantee holds for any capacity: raise it, and its budget holds.
            let raised = Params {
                mesh_bytes_per_cluster: 32 * 1024,
                ..*params
            };
            let budget = arena_bytes(n, &raised);
            let mut buf = vec![MaybeUninit::uninit(); budget];
            let run = run_in(&mut buf, points, &raised)
                .unwrap_or_else(|e| panic!("{name}, raised capacity: {e}"));
            assert!(run.peak <= budget);
            None
        }
        Err(e) => panic!("{name}: {e} in a buffer of arena_bytes = {budget}"),
    }
}

#[test]
fn generated_shapes_fit_their_budget_within_twice_the_peak() {
    for shape in [Shape::Sphere, Shape::Box, Shape::Demo] {
        let points = cloud(shape, 30000, 2);
        for (set, params) in sets() {
            let ratio = check_budget(&format!("{shape:?}, {set}"), &points, &params);
            assert!(
                ratio.is_some(),
                "{shape:?}, {set}: 7.5 points per cluster or more fit"
            );
        }
    }
}

#[test]
#[cfg_attr(
    shared_data,
    ignore = "a sweep: six parameter sets on every shared cloud, minutes (CI runs it with --ignored)"
)]
#[cfg_attr(
    not(shared_data),
    ignore = "needs ../shared/data/clouds, not found when this crate was built"
)]
fn every_shared_cloud_fits_its_budget_within_twice_the_peak() {
    let Some(files) = shared_clouds() else { return };
    let sets = sets();
    let (default, others) = sets.split_first().unwrap();
    let mut ratios = Vec::new();
    for (i, path) in files.iter().enumerate() {
        let points = load_shared_cloud(path);
        // The default on every cloud, and two of the others in turn (each one
        // on four of the ten clouds).
        for (set, params) in [default, &others[i % 5], &others[(i + 2) % 5]] {
            let name = format!("{}, {set}", stem(path));
            ratios.extend(check_budget(&name, &points, params));
        }
    }
    let worst = ratios.iter().copied().fold(0.0, f64::max);
    eprintln!("budget / peak: at most {worst:.2}");
}

#[test]
fn one_byte_less_than_the_clouds_need_is_refused_and_the_buffer_serves_again() {
    one_byte_less_is_refused(vec![
        (
            "demo".into(),
            cloud(Shape::Demo, 30000, 2),
            Params::default(),
        ),
        (
            "torus, refinement".into(),
            cloud(Shape::Torus, 12000, 5),
            Params {
                clusters: 300,
                refine_rounds: 2,
                ..Params::default()
            },
        ),
    ]);
}

#[test]
#[cfg_attr(
    not(shared_data),
    ignore = "needs ../shared/data/clouds, not found when this crate was built"
)]
fn one_byte_less_than_the_bunny_needs_is_refused_and_the_buffer_serves_again() {
    let Some(files) = shared_clouds() else { return };
    let bunny = files.iter().filter(|p| stem(p) == "bunny");
    one_byte_less_is_refused(
        bunny
            .map(|p| (stem(p), load_shared_cloud(p), Params::default()))
            .collect(),
    );
}

/// For each case: the mesh made in the buffer the run says it needs is the
/// mesh made in the worst-case buffer, and one byte less is refused.
fn one_byte_less_is_refused(cases: Vec<(String, Vec<V3>, Params)>) {
    for (name, points, params) in cases {
        let mut buf = vec![MaybeUninit::uninit(); arena_bytes(points.len(), &params)];
        let first = run_in(&mut buf, &points, &params).unwrap();
        let need = first.need(points.len(), &params);
        assert!(
            first.peak <= need && need <= buf.len(),
            "{name}: peak {}, need {need}, worst case {}",
            first.peak,
            buf.len()
        );
        let at = aligned_need(&buf, need);
        let enough = run_in(&mut buf[..at], &points, &params).unwrap();
        assert!(
            enough.vertices == first.vertices && enough.triangles == first.triangles,
            "{name}: another mesh in {at} bytes"
        );
        let short = &mut buf[..at - 1];
        let outcome = catch_unwind(AssertUnwindSafe(|| run_in(short, &points, &params)));
        match outcome {
            Ok(Err(e @ Error::ArenaTooSmall { needed, .. })) => {
                eprintln!(
                    "{name}: peak {} bytes, need {need} ({:.1}/point, worst case {:.1}); one less: {e}",
                    first.peak,
                    need as f64 / points.len() as f64,
                    buf.len() as f64 / points.len() as f64
                );
                assert_eq!(needed, need, "{name}: the size named");
            }
            Ok(Err(e)) => panic!("{name}: {e}"),
            Ok(Ok(_)) => panic!("{name}: succeeded below its need {at}"),
            Err(_) => panic!("{name}: panicked"),
        }
        let again = run_in(&mut buf, &points, &params).unwrap();
        assert_eq!(again.peak, first.peak, "{name}");
        assert!(
            again.vertices == first.vertices && again.triangles == first.triangles,
            "{name}: a different mesh from the same buffer"
        );
    }
}

#[test]
fn from_a_tiny_budget_to_an_ample_one_runs_succeed_or_are_refused_never_panic() {
    let cases = [
        (
            "cylinder",
            cloud(Shape::Cylinder, 5000, 7),
            Params {
                clusters: 120,
                ..Params::default()
            },
        ),
        (
            "sphere, refinement",
            cloud(Shape::Sphere, 3000, 8),
            Params {
                clusters: 80,
                refine_rounds: 2,
                k: 8,
                ..Params::default()
            },
        ),
    ];
    for (name, points, params) in cases {
        let budget = arena_bytes(points.len(), &params);
        let mut buf = vec![MaybeUninit::uninit(); budget];
        let reference = run_in(&mut buf, &points, &params).unwrap();
        let topo = topology(&reference.vertices, &reference.triangles);
        assert!(topo.is_clean_manifold(), "{name}: {topo:?}");
        // 30 budgets from 64 bytes to the bound, geometric, and the peak itself.
        let mut budgets: Vec<usize> = (0..30)
            .map(|i| (64.0 * (budget as f64 / 64.0).powf(i as f64 / 29.0)) as usize)
            .collect();
        let need = aligned_need(&buf, reference.need(points.len(), &params));
        budgets.extend([reference.peak - 1, reference.peak, need - 1, need]);
        let (mut ok, mut refused) = (0, 0);
        for b in budgets {
            let b = b.min(budget);
            let slice = &mut buf[..b];
            let outcome = catch_unwind(AssertUnwindSafe(|| run_in(slice, &points, &params)));
            match outcome {
                Err(_) => panic!("{name}: panicked with {b} bytes"),
                Ok(Ok(run)) => {
                    ok += 1;
                    assert!(b >= need, "{name}: {b} bytes, below the need {need}");
                    assert!(
                        run.vertices == reference.vertices && run.triangles == reference.triangles,
                        "{name}: {b} bytes gave another mesh"
                    );
                }
                Ok(Err(e @ Error::ArenaTooSmall { .. })) => {
                    refused += 1;
                    assert!(b < need, "{name}: {b} bytes refused ({e})");
                }
                Ok(Err(e)) => panic!("{name}: {b} bytes: {e}"),
            }
        }
        eprintln!(
            "{name}: {ok} budgets enough, {refused} refused (need {need}, peak {})",
            reference.peak
        );
        assert!(ok >= 2 && refused >= 20, "{name}: {ok} / {refused}");
    }
}

#[test]
fn the_peak_grows_linearly_with_the_points() {
    // Clusters in proportion to the points (one per 30), so every stage scales:
    // a part that grew faster than the points (a dense grid, a quadratic
    // candidate search) shows as more bytes per point at 100k than at 10k.
    let per_point = |n: usize| {
        let params = Params {
            clusters: (n / 30) as u32,
            ..Params::default()
        };
        let points = cloud(Shape::Demo, n, 11);
        let mut buf = vec![MaybeUninit::uninit(); arena_bytes(n, &params)];
        let run = run_in(&mut buf, &points, &params).unwrap();
        let b = run.peak as f64 / n as f64;
        eprintln!("{n} points: {b:.1} bytes per point");
        b
    };
    let (small, large) = (per_point(10_000), per_point(100_000));
    assert!(
        large <= 1.25 * small && small <= 1.25 * large,
        "bytes per point: {small:.1} at 10k, {large:.1} at 100k"
    );
}
