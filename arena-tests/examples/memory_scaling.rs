//! Bytes per point of `reconstruct` as the cloud grows: the budget
//! (`arena_bytes`) and the measured arena peak on the generated demo shape at
//! 10k, 100k and 1M points, with 1000 clusters and with one cluster per 30 points.
//!
//! `cargo run --release -p arena-tests --example memory_scaling [N...]`

use arena_tests::cloud;
use std::mem::MaybeUninit;
use std::time::Instant;
use vsaqem_core::sample::Shape;
use vsaqem_core::{arena_bytes, reconstruct, Arena, Params, Silent};

fn main() {
    let sizes: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("point counts"))
        .collect();
    let sizes = if sizes.is_empty() {
        vec![10_000, 100_000, 1_000_000]
    } else {
        sizes
    };
    println!("| points | clusters | budget B | budget B/point | arena peak B | peak B/point | budget / peak | time s |");
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|");
    for per_30 in [false, true] {
        for &n in &sizes {
            let clusters = if per_30 { (n / 30) as u32 } else { 1000 };
            let params = Params {
                clusters,
                ..Params::default()
            };
            let points = cloud(Shape::Demo, n, 11);
            let budget = arena_bytes(n, &params);
            let mut buf = vec![MaybeUninit::uninit(); budget];
            let arena = Arena::new(&mut buf);
            let t = Instant::now();
            let r = reconstruct(&arena, &points, None, &params, &mut Silent);
            let secs = t.elapsed().as_secs_f64();
            let peak = arena.peak();
            match r {
                Ok(_) => println!(
                    "| {n} | {clusters} | {budget} | {:.1} | {peak} | {:.1} | {:.2} | {secs:.2} |",
                    budget as f64 / n as f64,
                    peak as f64 / n as f64,
                    budget as f64 / peak as f64
                ),
                Err(e) => println!("| {n} | {clusters} | {budget} | | error: {e} | | | |"),
            }
        }
    }
}
