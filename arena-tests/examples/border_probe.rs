//! Dev probe: clusters flagged as on the border of the data, per shape and angle,
//! and what the mesh then looks like. `cargo run --release -p arena-tests --example border_probe`
use std::mem::MaybeUninit;

use arena_tests::{cloud, topology};
use vsaqem_core::sample::{fill, Shape};
use vsaqem_core::{arena_bytes, reconstruct, Arena, Params, Silent};

fn main() {
    let shapes = [
        (Shape::Sphere, 0.0),
        (Shape::Box, 0.0),
        (Shape::Torus, 0.0),
        (Shape::Demo, 0.0),
        (Shape::Sphere, 0.01),
        (Shape::Box, 0.01),
        (Shape::Hemisphere, 0.0),
        (Shape::Tube, 0.0),
        (Shape::Wave, 0.0),
        (Shape::HoledSphere, 0.0),
        (Shape::Hemisphere, 0.01),
    ];
    for (shape, noise) in shapes {
        let mut pts = cloud(shape, 20000, 7);
        if noise > 0.0 {
            fill(shape, 7, noise * 3.4, &mut pts);
        }
        let mut line = format!("{shape:?} noise {noise}:");
        for deg in [120.0f32, 150.0, 170.0] {
            let params = Params {
                border_angle: deg,
                ..Params::default()
            };
            let mut buf = vec![MaybeUninit::<u8>::uninit(); arena_bytes(pts.len(), &params)];
            let arena = Arena::new(&mut buf);
            let r = match reconstruct(&arena, &pts, None, &params, &mut Silent) {
                Ok(r) => r,
                Err(e) => {
                    line += &format!("  {deg}°: {e}");
                    continue;
                }
            };
            let t = topology(r.mesh.vertices, r.mesh.triangles);
            line += &format!(
                "  {deg}°: {} border clusters, {} open loops, {} boundary edges, clean {}",
                r.meshing.border_clusters,
                r.mesh.stats.open_loops,
                t.boundary_edges,
                t.is_clean_manifold()
            );
        }
        println!("{line}");
    }
}
