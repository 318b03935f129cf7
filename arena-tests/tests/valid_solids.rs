//! What a user of a closed model asks of the mesh, checked by the host's
//! evaluator (an exact self-intersection test and a genus count of its own, not
//! core's statistics): a valid solid of the sampled surface's genus, with every
//! cluster of the data in it.

use arena_tests::cloud;
use std::mem::MaybeUninit;
use vsaqem::eval::{evaluate, Evaluation};
use vsaqem_core::sample::Shape;
use vsaqem_core::{arena_bytes, reconstruct, Arena, Params, Partition, Reconstruction, Silent, V3};

/// The closed generated shapes and their genus.
const CLOSED: [(Shape, u64); 5] = [
    (Shape::Sphere, 0),
    (Shape::Torus, 1),
    (Shape::Box, 0),
    (Shape::Cylinder, 0),
    (Shape::Demo, 0),
];

fn f64s(v: &[V3]) -> Vec<[f64; 3]> {
    v.iter().map(|p| p.map(f64::from)).collect()
}

/// `f` on the reconstruction of `pts` with `params` (in an arena of
/// `arena_bytes`) and the host's evaluation of its mesh (`samples` points on
/// it); `what` names the run when it fails.
fn judged<T>(
    pts: &[V3],
    params: &Params,
    samples: usize,
    what: &str,
    f: impl FnOnce(&Reconstruction, &Evaluation) -> T,
) -> T {
    let mut buf = vec![MaybeUninit::uninit(); arena_bytes(pts.len(), params)];
    let arena = Arena::new(&mut buf);
    let r = reconstruct(&arena, pts, None, params, &mut Silent)
        .unwrap_or_else(|e| panic!("{what}: {e}"));
    let e = evaluate(
        &f64s(pts),
        &f64s(r.mesh.vertices),
        r.mesh.triangles,
        samples,
    );
    f(&r, &e)
}

#[test]
fn closed_generated_shapes_are_valid_solids_of_their_genus_with_every_cluster_in_the_mesh() {
    for (shape, genus) in CLOSED {
        let pts = cloud(shape, 20_000, 1);
        for clusters in [250, 500, 1000, 2000] {
            let params = Params {
                clusters,
                ..Params::default()
            };
            judged(
                &pts,
                &params,
                1000,
                &format!("{shape:?} {clusters}"),
                |r, e| {
                    let what = format!(
                        "{shape:?} {clusters}: {:?} {:?} {:?}",
                        e.topology, e.validity, r.meshing.mesh
                    );
                    assert!(e.is_valid_solid(Some(genus)), "not a valid solid: {what}");
                    // Every cluster with points is a vertex of the mesh, or was merged
                    // with one whose generator is within 1e-6 of the diagonal of its own.
                    let c = &r.clustered.clusters;
                    let tol2 = (1e-6 * r.clustered.bounds.diag).powi(2);
                    let mut has_points = vec![false; c.generators.len()];
                    for &l in c.labels {
                        has_points[l as usize] = true;
                    }
                    let mut vertex = vec![false; c.generators.len()];
                    for &j in r.mesh.vertex_cluster {
                        vertex[j as usize] = true;
                    }
                    for (j, g) in c.generators.iter().enumerate() {
                        let in_mesh = vertex[j]
                            || c.generators.iter().enumerate().any(|(i, h)| {
                                vertex[i] && vsaqem_core::math::dist2(*g, *h) <= tol2
                            });
                        assert!(
                            !has_points[j] || in_mesh,
                            "cluster {j} of {shape:?} at {clusters} clusters is left out: {what}"
                        );
                    }
                    assert_eq!(r.meshing.mesh.uncovered_clusters, 0, "{what}");
                    assert_eq!(r.meshing.mesh.split_vertices, 0, "{what}");
                    assert_eq!(r.meshing.mesh.tangled_pairs, 0, "{what}");
                },
            );
        }
    }
}

#[test]
fn an_error_bound_is_met_on_closed_shapes_as_an_independent_evaluation_measures_it() {
    for (shape, _) in CLOSED {
        let pts = cloud(shape, 20_000, 1);
        for bound in [0.01f32, 0.005] {
            let params = Params {
                max_error: bound,
                ..Params::default()
            };
            judged(&pts, &params, 0, &format!("{shape:?} {bound}"), |r, e| {
                let max = e.rel(e.point_to_mesh.stats.max);
                eprintln!(
                    "{shape:?} --max-error {bound}: max {max:.5} (core {:.5}), {} vertices, {} rounds",
                    r.meshing.mesh.distance.max,
                    r.mesh.vertices.len(),
                    r.meshing.refine_rounds
                );
                assert!(
                    max <= bound as f64,
                    "{shape:?} {bound}: farthest point at {max}"
                );
                assert!(
                    e.is_valid_solid(None),
                    "{shape:?} {bound}: {:?}",
                    e.validity
                );
            });
        }
    }
}

#[test]
fn vertices_added_where_the_mesh_is_farthest_stay_within_their_budget_and_bring_the_data_nearer() {
    for (shape, genus) in CLOSED {
        let pts = cloud(shape, 20_000, 1);
        let run = |densify: f32| {
            // No rounds for far points: they would differ with and without
            // densifying, and so would the clusters compared.
            let params = Params {
                clusters: 250,
                densify,
                refine_beyond: 0.0,
                ..Params::default()
            };
            judged(&pts, &params, 1000, &format!("{shape:?}"), |r, e| {
                assert!(
                    e.is_valid_solid(Some(genus)),
                    "{shape:?} densify {densify}: not a valid solid"
                );
                (
                    r.mesh.vertices.len(),
                    r.meshing.mesh.densified as usize,
                    e.point_to_mesh.stats.mean,
                )
            })
        };
        let (v0, added0, mean0) = run(0.0);
        let (v1, added1, mean1) = run(0.1);
        assert_eq!(added0, 0);
        assert_eq!(
            v1,
            v0 + added1,
            "{shape:?}: every added vertex is in the mesh"
        );
        assert!(
            added1 * 10 <= v0 + 9,
            "{shape:?}: {added1} added to {v0}, over the 10 % budget"
        );
        assert!(
            mean1 <= mean0,
            "{shape:?}: the mean distance rose from {mean0} to {mean1} with {added1} vertices added"
        );
    }
}

#[test]
fn points_farther_than_refine_beyond_draw_a_refinement_round_that_brings_them_in() {
    // At 60 clusters the faces of a cylinder and a hemisphere cut across
    // parts of the data by more than 0.75 % of the diagonal; a round with a
    // generator at each such cluster's farthest point brings them within it.
    for shape in [Shape::Cylinder, Shape::Hemisphere] {
        let pts = cloud(shape, 20_000, 1);
        let diag = arena_tests::diagonal(&pts);
        let run = |refine_beyond: f32| {
            let params = Params {
                clusters: 60,
                refine_beyond,
                ..Params::default()
            };
            judged(&pts, &params, 1000, &format!("{shape:?}"), |r, e| {
                (e.point_to_mesh.stats.max / diag, r.meshing.refine_added)
            })
        };
        let goal = Params::default().refine_beyond as f64;
        let (before, added0) = run(0.0);
        let (after, added) = run(goal as f32);
        assert_eq!(added0, 0, "{shape:?}: a round without a goal");
        assert!(before > goal, "{shape:?}: {before} already within {goal}");
        assert!(
            added > 0 && after <= goal,
            "{shape:?}: {after} after {added} generators"
        );
    }
}

#[test]
fn the_voids_of_a_random_sampling_are_no_gaps_and_run_no_round_for_the_genus() {
    // A random sampling leaves empty disks up to about twice its spacing
    // wide: faces over them are as far from the data as faces across a slot,
    // but they lie in the surface. Neither shape has a slot, so neither runs
    // a round for the genus (both did, with 35 generators each, before the
    // rims' tangent planes were asked). Faces that cut a sharp edge (the
    // box's) may: their rims lie off the faces' plane, as a slot's do.
    for shape in [Shape::Sphere, Shape::Cylinder] {
        let pts = cloud(shape, 5000, 7);
        let params = Params {
            clusters: 120,
            ..Params::default()
        };
        let mut buf = vec![MaybeUninit::uninit(); arena_bytes(pts.len(), &params)];
        let arena = Arena::new(&mut buf);
        let r = reconstruct(&arena, &pts, None, &params, &mut Silent)
            .unwrap_or_else(|e| panic!("{shape:?}: {e}"));
        assert_eq!(
            r.meshing.gap_rounds, 0,
            "{shape:?}: {} generators added",
            r.meshing.refine_added
        );
    }
}

/// The partition by sweeps (the default from 131,072 points) gives clusters
/// of its own, so its meshes are judged too: valid solids of their genus, and
/// every point in a cluster that holds its seed and is connected.
#[test]
fn closed_generated_shapes_partitioned_by_sweeps_are_valid_solids_of_their_genus() {
    for (shape, genus) in CLOSED {
        let pts = cloud(shape, 10_000, 1);
        let adj = knn_graph(&pts);
        for clusters in [250, 1000] {
            let params = Params {
                clusters,
                partition: Partition::Sweep,
                ..Params::default()
            };
            judged(
                &pts,
                &params,
                1000,
                &format!("{shape:?} {clusters} sweeps"),
                |r, e| {
                    let c = &r.clustered.clusters;
                    let what = format!(
                        "{shape:?} {clusters} sweeps: {:?} {:?} {:?}",
                        e.topology, e.validity, r.meshing.mesh
                    );
                    assert!(e.is_valid_solid(Some(genus)), "not a valid solid: {what}");
                    assert!(c.labels.iter().all(|&l| (l as usize) < c.generators.len()));
                    for (j, &sd) in c.seeds.iter().enumerate() {
                        assert_eq!(c.labels[sd as usize], j as u32, "{what}: seed {j}");
                    }
                    assert_eq!(
                        connected_clusters(c.labels, c.seeds, &adj),
                        c.generators.len(),
                        "{what}: a cluster in pieces"
                    );
                },
            );
        }
    }
}

/// The symmetrised k-NN graph of `pts` (k = 12), brute force: 10,000
/// points are few enough for a test.
fn knn_graph(pts: &[V3]) -> Vec<Vec<usize>> {
    let k = Params::default().k;
    let n = pts.len();
    let mut adj = vec![Vec::new(); n];
    for i in 0..n {
        let mut d: Vec<(f32, usize)> = (0..n)
            .filter(|&j| j != i)
            .map(|j| {
                let v = [0, 1, 2].map(|a| pts[i][a] - pts[j][a]);
                (v[0] * v[0] + v[1] * v[1] + v[2] * v[2], j)
            })
            .collect();
        d.select_nth_unstable_by(k, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for &(_, j) in &d[..k] {
            adj[i].push(j);
            adj[j].push(i);
        }
    }
    adj
}

/// How many clusters are connected over the graph `adj`: a search from each
/// seed within its cluster reaches all of it.
fn connected_clusters(labels: &[u32], seeds: &[u32], adj: &[Vec<usize>]) -> usize {
    let mut seen = vec![false; labels.len()];
    let mut whole = 0;
    for (j, &sd) in seeds.iter().enumerate() {
        let mut stack = vec![sd as usize];
        seen[sd as usize] = true;
        let mut reached = 0;
        while let Some(p) = stack.pop() {
            reached += 1;
            for &q in &adj[p] {
                if !seen[q] && labels[q] == j as u32 {
                    seen[q] = true;
                    stack.push(q);
                }
            }
        }
        whole += usize::from(reached == labels.iter().filter(|&&l| l == j as u32).count());
    }
    whole
}
