//! The cleaning pre-pass (`vsaqem_core::clean`) as a caller uses it: clean,
//! compact the kept points, reconstruct in the same buffer.
//! - `clean_bytes` is always enough and at most about twice the measured peak;
//!   the peak is the exact threshold between success and `Exhausted`;
//! - several objects in one cloud each get one closed surface, and the stray
//!   fragment is dropped and counted;
//! - outliers in a sphere's bounding box leave no spike in its mesh.
//!
//! Shared clouds are read from `../shared/data/clouds` (skipped when absent).

use arena_tests::{clean_and_reconstruct, cloud, load_shared_cloud, shared_clouds, stem, topology};
use std::mem::MaybeUninit;
use vsaqem_core::rng::Rng;
use vsaqem_core::sample::{scene_fragment, Shape, SCENE_CUBE, SCENE_SPHERE};
use vsaqem_core::{arena_bytes, clean, clean_bytes, Arena, CleanStats, Error, Params, Silent, V3};

/// `points` with `extra` uniform outliers in `[-1, 1]^3` after them.
fn with_outliers(mut points: Vec<V3>, extra: usize, seed: u64) -> Vec<V3> {
    let mut rng = Rng::new(seed);
    for _ in 0..extra {
        points.push(std::array::from_fn(|_| rng.unit_f64() as f32 * 2.0 - 1.0));
    }
    points
}

/// Clean in `buf`: the stats and the arena's peak.
fn clean_in(
    buf: &mut [MaybeUninit<u8>],
    points: &[V3],
    params: &Params,
) -> Result<(CleanStats, usize), Error> {
    let arena = Arena::new(buf);
    let mut keep = vec![true; points.len()];
    let s = clean(&arena, points, params, &mut keep, &mut Silent)?;
    Ok((s, arena.peak()))
}

/// Check `clean_bytes` on one cloud: enough, at most `most` times the peak, and
/// the peak exact (8 bytes less is `Exhausted`, a typed error, and the buffer
/// still serves a whole run). Returns the ratio.
fn check_bound(name: &str, points: &[V3], params: &Params, most: f64) -> f64 {
    let bound = clean_bytes(points.len(), params);
    let mut buf = vec![MaybeUninit::uninit(); bound];
    let (stats, peak) = clean_in(&mut buf, points, params).unwrap();
    let ratio = bound as f64 / peak as f64;
    eprintln!(
        "{name}, k = {}: peak {peak} ({:.1} B/point), bound {bound} ({ratio:.2}x); {stats:?}",
        params.k,
        peak as f64 / points.len() as f64
    );
    assert!(peak <= bound && ratio <= most, "{name}: {ratio:.2}x");
    assert_eq!(clean_in(&mut buf[..peak], points, params).unwrap().1, peak);
    match clean_in(&mut buf[..peak - 8], points, params) {
        Err(Error::Exhausted(_)) => {}
        other => panic!("{name}: {other:?} one granule below the peak"),
    }
    // The pre-pass never needs more than the run after it.
    assert!(bound <= arena_bytes(points.len(), params), "{name}");
    ratio
}

/// The k-NN table is 4 k bytes per point, the grid's scratch is bounded at its
/// worst (one cell per point: 92 bytes) and uses about 24: at k = 12 and more
/// the bound is within twice the peak; at k = 6 the grid's share makes it 2.4x.
fn most_for(k: usize) -> f64 {
    if k >= 12 {
        2.0
    } else {
        2.5
    }
}

#[test]
fn clean_bytes_is_enough_and_at_most_about_twice_the_peak() {
    let generated = [
        ("sphere", cloud(Shape::Sphere, 20_000, 1)),
        ("scene", cloud(Shape::Scene, 20_000, 1)),
        (
            "demo + 1 % outliers",
            with_outliers(cloud(Shape::Demo, 20_000, 1), 200, 3),
        ),
    ];
    for (name, points) in &generated {
        for k in [6, 12, 20] {
            for outlier_sigma in [0.0, 2.0] {
                let params = Params {
                    k,
                    outlier_sigma,
                    ..Params::default()
                };
                check_bound(name, points, &params, most_for(k));
            }
        }
    }
}

#[test]
#[cfg_attr(
    not(shared_data),
    ignore = "needs ../shared/data/clouds, not found when this crate was built"
)]
fn clean_bytes_is_enough_and_at_most_about_twice_the_peak_on_the_shared_clouds() {
    let Some(paths) = shared_clouds() else { return };
    for path in paths {
        let points = load_shared_cloud(&path);
        let params = Params {
            outlier_sigma: 2.0,
            ..Params::default()
        };
        check_bound(&stem(&path), &points, &params, most_for(params.k));
    }
}

/// Clean with `params`, keep what it keeps, reconstruct in the same buffer:
/// the stats and the mesh.
fn clean_then_mesh(points: &[V3], params: &Params) -> (CleanStats, Vec<V3>, Vec<[u32; 3]>) {
    clean_and_reconstruct(points, params, |stats, _, r| {
        (stats, r.mesh.vertices.to_vec(), r.mesh.triangles.to_vec())
    })
}

/// Connected components of a triangle mesh, as a label per vertex.
fn component_labels(vertices: usize, triangles: &[[u32; 3]]) -> Vec<usize> {
    let mut parent: Vec<usize> = (0..vertices).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    for t in triangles {
        for e in 0..3 {
            let (a, b) = (
                find(&mut parent, t[e] as usize),
                find(&mut parent, t[(e + 1) % 3] as usize),
            );
            parent[a.max(b)] = a.min(b);
        }
    }
    (0..vertices).map(|i| find(&mut parent, i)).collect()
}

#[test]
fn the_scene_gives_one_closed_surface_per_object_and_drops_the_fragment() {
    let n = 20_000;
    let points = cloud(Shape::Scene, n, 1);
    let params = Params::default();
    let (stats, vertices, triangles) = clean_then_mesh(&points, &params);
    let nf = scene_fragment(n) as u32;
    assert_eq!(
        (
            stats.fragments,
            stats.fragment_points,
            stats.pieces,
            stats.outliers
        ),
        (1, nf, 2, 0),
        "{stats:?}"
    );
    let topo = topology(&vertices, &triangles);
    assert!(topo.is_clean_manifold(), "{topo:?}");
    assert_eq!(
        (topo.components, topo.boundary_edges, topo.euler()),
        (2, 0, 4),
        "{topo:?}"
    );
    // Each component lies on one object: its vertices near that object's
    // surface (within 1 % of the scene's diagonal), and the two are different.
    let diag = 2.2f32;
    let to_sphere = |v: V3| {
        let d: f32 = (0..3)
            .map(|a| (v[a] - SCENE_SPHERE[a] as f32).powi(2))
            .sum();
        (d.sqrt() - 0.45).abs()
    };
    let to_cube = |v: V3| {
        let q: [f32; 3] = std::array::from_fn(|a| (v[a] - SCENE_CUBE[a] as f32).abs() - 0.3);
        let outside = q.iter().map(|x| x.max(0.0).powi(2)).sum::<f32>().sqrt();
        (outside + q[0].max(q[1]).max(q[2]).min(0.0)).abs()
    };
    let labels = component_labels(vertices.len(), &triangles);
    let mut objects = std::collections::BTreeMap::new();
    for (i, &v) in vertices.iter().enumerate() {
        let (ds, dc) = (to_sphere(v), to_cube(v));
        let on = if ds < dc { "sphere" } else { "cube" };
        assert!(
            ds.min(dc) < 0.01 * diag,
            "vertex {i} {v:?}: {ds} from the sphere, {dc} from the cube"
        );
        let first = *objects.entry(labels[i]).or_insert(on);
        assert_eq!(first, on, "a component spans both objects");
    }
    let mut on: Vec<&str> = objects.values().copied().collect();
    on.sort_unstable();
    assert_eq!(on, ["cube", "sphere"]);
}

#[test]
fn outliers_in_a_spheres_box_leave_no_spike_in_its_mesh() {
    // A unit sphere of 20,000 points and 1 % more uniform in its bounding box.
    let points = with_outliers(cloud(Shape::Sphere, 20_000, 1), 200, 7);
    let diag = 2.0 * 3f32.sqrt();
    let farthest = |params: &Params| {
        let (stats, vertices, triangles) = clean_then_mesh(&points, params);
        let topo = topology(&vertices, &triangles);
        let far = vertices
            .iter()
            .map(|v| (v.iter().map(|c| c * c).sum::<f32>().sqrt() - 1.0).abs())
            .fold(0.0f32, f32::max);
        eprintln!(
            "{stats:?}: {topo:?}, farthest vertex {:.3} % of the diagonal",
            far / diag * 100.0
        );
        (far, topo)
    };
    // With the outlier filter at 2 standard deviations, and with the default
    // (fragments only: most outliers are isolated points, pieces of one).
    for params in [
        Params {
            outlier_sigma: 2.0,
            ..Params::default()
        },
        Params::default(),
    ] {
        let (far, topo) = farthest(&params);
        assert!(
            far < 0.01 * diag,
            "{params:?}: a vertex {far} from the sphere"
        );
        assert!(
            topo.is_clean_manifold() && topo.boundary_edges == 0,
            "{topo:?}"
        );
        assert_eq!((topo.components, topo.euler()), (1, 2), "{topo:?}");
    }
    // Without cleaning the outliers do make spikes: the check above can fail.
    let (far_raw, _) = farthest(&Params {
        min_fragment: 0,
        ..Params::default()
    });
    assert!(
        far_raw > 0.01 * diag,
        "no spike without cleaning: {far_raw}"
    );
}
