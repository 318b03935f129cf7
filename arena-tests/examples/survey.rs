//! Survey: topology of reconstruct on generated shapes (dev tool).
use arena_tests::{cloud, topology};
use std::mem::MaybeUninit;
use vsaqem_core::sample::Shape;
use vsaqem_core::{arena_bytes, reconstruct, Arena, Params, Silent};
fn main() {
    let max_hole: u32 = std::env::var("HOLE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(64);
    for shape in [Shape::Sphere, Shape::Torus, Shape::Box, Shape::Demo] {
        let pts = cloud(shape, 30000, 2);
        for clusters in [250, 500, 1000, 2000] {
            let params = Params {
                clusters,
                max_hole,
                ..Params::default()
            };
            let mut buf = vec![MaybeUninit::uninit(); arena_bytes(pts.len(), &params)];
            let arena = Arena::new(&mut buf);
            let t = std::time::Instant::now();
            let r = reconstruct(&arena, &pts, None, &params, &mut Silent).unwrap();
            let topo = topology(r.mesh.vertices, r.mesh.triangles);
            let s = r.meshing;
            println!("{shape:?} {clusters} {:?} V {} F {} bnd {} nm {}/{} incons {} comp {} euler {} | opt {} gap {:.4} filled {} left {} split {} nonor {} rep {}",
                t.elapsed(), topo.vertices, topo.faces, topo.boundary_edges, topo.non_manifold_edges, topo.non_manifold_vertices, topo.inconsistent_edges, topo.components, topo.euler(),
                s.selection.optimal, s.selection.gap, s.mesh.holes_filled, s.mesh.holes_left, s.mesh.split_vertices, s.mesh.non_orientable, s.mesh.repairs);
        }
    }
}
