//! Open surfaces: generated shapes whose data ends (a hemisphere, an open tube, a
//! wavy patch, a sphere with a hole) give manifold meshes whose boundary follows
//! the true border, and cover their points.

use std::mem::MaybeUninit;

use arena_tests::{boundary_vertices, cloud, diagonal, distance_to_mesh, to_border, topology};
use vsaqem_core::sample::Shape;
use vsaqem_core::{arena_bytes, reconstruct, Arena, Params, Silent};

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
            let mut d: Vec<f64> = boundary_vertices(t)
                .iter()
                .filter_map(|&i| to_border(shape, v[i as usize]))
                .map(|x| x / diag)
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
