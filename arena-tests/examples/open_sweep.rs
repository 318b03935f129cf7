//! The open generated shapes over several sampling seeds: worst and median
//! boundary vertex distance to the true border, and points farther than 1 % of
//! the diagonal from the mesh. The test `open_surfaces.rs` checks one seed; this
//! shows how much that depends on the sample.
//! `cargo run --release -p arena-tests --example open_sweep [-- SEEDS]`
use std::mem::MaybeUninit;

use arena_tests::{boundary_vertices, cloud, diagonal, distance_to_mesh, to_border, topology};
use vsaqem_core::sample::Shape;
use vsaqem_core::{arena_bytes, reconstruct, Arena, Params, Silent};

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(8);
    println!("| shape | clusters | seed | open loops | holes left | clean manifold | worst % | median % | points > 1 % |");
    println!("|---|---:|---:|---:|---:|---|---:|---:|---:|");
    let (mut runs, mut over) = (0, 0);
    for shape in [
        Shape::Hemisphere,
        Shape::Tube,
        Shape::Wave,
        Shape::HoledSphere,
    ] {
        for clusters in [500, 1000] {
            for seed in 1..=seeds {
                let pts = cloud(shape, 20000, seed);
                let diag = diagonal(&pts);
                let params = Params {
                    clusters,
                    ..Params::default()
                };
                let mut buf = vec![MaybeUninit::uninit(); arena_bytes(pts.len(), &params)];
                let arena = Arena::new(&mut buf);
                let r = match reconstruct(&arena, &pts, None, &params, &mut Silent) {
                    Ok(r) => r,
                    Err(e) => {
                        println!("| {shape:?} | {clusters} | {seed} | failed: {e} | | | | |");
                        continue;
                    }
                };
                let (v, t) = (r.mesh.vertices, r.mesh.triangles);
                let mut d: Vec<f64> = boundary_vertices(t)
                    .iter()
                    .filter_map(|&i| to_border(shape, v[i as usize]))
                    .map(|x| 100.0 * x / diag)
                    .collect();
                d.sort_by(f64::total_cmp);
                let worst = d.last().copied().unwrap_or(f64::NAN);
                let median = d.get(d.len() / 2).copied().unwrap_or(f64::NAN);
                let far = pts
                    .iter()
                    .filter(|&&p| distance_to_mesh(p, v, t) as f64 > 0.01 * diag)
                    .count();
                runs += 1;
                over += usize::from(worst > 2.0);
                println!(
                    "| {shape:?} | {clusters} | {seed} | {} | {} | {} | {worst:.2} | {median:.2} | {far} |",
                    r.mesh.stats.open_loops,
                    r.mesh.stats.holes_left,
                    topology(v, t).is_clean_manifold()
                );
            }
        }
    }
    println!("\n{over} of {runs} runs have a boundary vertex farther than 2 % from the border");
}
