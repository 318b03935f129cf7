//! Open surfaces: generated shapes whose data ends (a hemisphere, an open tube, a
//! wavy patch, a sphere with a hole) give manifold meshes whose boundary follows
//! the true border, and cover their points.

use std::mem::MaybeUninit;

use arena_tests::{cloud, distance_to_mesh, topology};
use vsaqem_core::sample::{wave, Shape};
use vsaqem_core::{arena_bytes, reconstruct, Arena, Params, Silent, V3};

/// Distance from `p` to the true border of `shape` (for the wave, to a point of
/// the border, which is no less than the distance to the border).
fn to_border(shape: Shape, p: V3) -> f64 {
    let [x, y, z] = p.map(|c| c as f64);
    let rho = (x * x + y * y).sqrt();
    let circle = |r: f64, h: f64| ((rho - r).powi(2) + (z - h).powi(2)).sqrt();
    match shape {
        Shape::Hemisphere => circle(1.0, 0.0),
        Shape::Tube => circle(0.6, 0.8).min(circle(0.6, -0.8)),
        Shape::HoledSphere => circle(0.51f64.sqrt(), 0.7),
        Shape::Wave => {
            let (bx, by) = if 1.0 - x.abs() < 1.0 - y.abs() {
                (x.signum(), y.clamp(-1.0, 1.0))
            } else {
                (x.clamp(-1.0, 1.0), y.signum())
            };
            let bz = wave(bx, by).0;
            ((x - bx).powi(2) + (y - by).powi(2) + (z - bz).powi(2)).sqrt()
        }
        _ => unreachable!(),
    }
}

fn diagonal(pts: &[V3]) -> f64 {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in pts {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a] as f64);
            hi[a] = hi[a].max(p[a] as f64);
        }
    }
    (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt()
}

#[test]
fn open_shapes_keep_their_border_and_cover_their_points() {
    // (shape, boundary loops of the true surface)
    let shapes = [
        (Shape::Hemisphere, 1),
        (Shape::Tube, 2),
        (Shape::Wave, 1),
        (Shape::HoledSphere, 1),
    ];
    let mut worst_all = 0.0f64;
    for (shape, loops) in shapes {
        let pts = cloud(shape, 20000, 3);
        let diag = diagonal(&pts);
        for clusters in [500, 1000] {
            let params = Params {
                clusters,
                ..Params::default()
            };
            let mut buf = vec![MaybeUninit::uninit(); arena_bytes(pts.len(), &params)];
            let arena = Arena::new(&mut buf);
            let r = reconstruct(&arena, &pts, None, &params, &mut Silent).unwrap();
            let (v, t) = (r.mesh.vertices, r.mesh.triangles);
            let topo = topology(v, t);
            let what = format!("{shape:?} {clusters}");
            eprintln!(
                "{what}: {topo:?}; {} border clusters, {} open loops",
                r.meshing.border_clusters, r.mesh.stats.open_loops
            );
            assert!(topo.is_clean_manifold(), "{what}: {topo:?}");
            assert!(topo.boundary_edges > 0, "{what}: closed over the border");
            assert_eq!(r.mesh.stats.open_loops, loops, "{what}: border loops");
            // Every boundary vertex within 2 % of the diagonal of the true border.
            let mut count = vec![0u32; v.len()];
            for tri in t {
                for k in 0..3 {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    let key = (a.min(b), a.max(b));
                    let shared = t.iter().filter(|u| {
                        (0..3).any(|j| (u[j].min(u[(j + 1) % 3]), u[j].max(u[(j + 1) % 3])) == key)
                    });
                    if shared.count() == 1 {
                        count[a as usize] += 1;
                    }
                }
            }
            let mut d: Vec<f64> = (0..v.len())
                .filter(|&i| count[i] > 0)
                .map(|i| to_border(shape, v[i]) / diag)
                .collect();
            d.sort_by(f64::total_cmp);
            let worst = d.last().copied().unwrap_or(0.0);
            eprintln!(
                "{what}: {} boundary vertices, median {:.2} %, worst {:.2} % of the diagonal from the border; {} holes left",
                d.len(),
                100.0 * d[d.len() / 2],
                100.0 * worst,
                r.mesh.stats.holes_left
            );
            worst_all = worst_all.max(worst);
            // The boundary runs on the border: every boundary vertex within 2 % of
            // the diagonal of it, the median within 1 %.
            assert!(
                worst <= 0.02,
                "{what}: a boundary vertex is {:.2} % from the border",
                100.0 * worst
            );
            assert!(
                d[d.len() / 2] <= 0.01,
                "{what}: the median boundary vertex is {:.2} % from the border",
                100.0 * d[d.len() / 2]
            );
            // At least 99 % of the points within 1 % of the diagonal of the mesh.
            let far = pts
                .iter()
                .step_by(7)
                .filter(|&&p| distance_to_mesh(p, v, t) as f64 > 0.01 * diag)
                .count();
            let n = pts.len().div_ceil(7);
            eprintln!("{what}: {far} of {n} sampled points farther than 1 %");
            assert!(
                100 * far <= n,
                "{what}: {far} of {n} sampled points are farther than 1 %"
            );
        }
    }
    eprintln!(
        "worst boundary vertex: {:.2} % of the diagonal from the true border",
        100.0 * worst_all
    );
}
