//! Noise report: generated shapes with Gaussian noise and uniform outliers,
//! reconstructed at default parameters, measured against the clean surface.
//!
//! `cargo run --release -p arena-tests --example noise_report [-- SHAPE...]`
//! prints a Markdown table (bench/noise.md). Distances are % of the clean
//! cloud's bounding-box diagonal:
//! - max / mean: from the mesh (100,000 area-uniform samples, plus every vertex for
//!   the max) to the exact clean surface (`arena_tests::distance_to_shape`);
//! - far: clean points (the 20,000 before noise) farther than 1 % from the mesh;
//! - spikes: vertices farther than 3 σ + 0.5 % from the clean surface;
//! - thin: facets with a minimum angle below 5° and the longest edge over 3 times
//!   the median edge (`arena_tests::long_thin_facets`).

use arena_tests::{boundary_loops, distance_to_shape, long_thin_facets, noisy_cloud, topology};
use std::mem::MaybeUninit;
use vsaqem_core::sample::Shape;
use vsaqem_core::{arena_bytes, reconstruct, Arena, Params, Silent};

const POINTS: usize = 20_000;
const SEED: u64 = 3;
const SAMPLES: usize = 100_000;

fn main() {
    let names: Vec<String> = std::env::args().skip(1).collect();
    let shapes = [
        ("sphere", Shape::Sphere),
        ("torus", Shape::Torus),
        ("box", Shape::Box),
        ("demo", Shape::Demo),
        ("hemisphere", Shape::Hemisphere),
        ("tube", Shape::Tube),
        ("wave", Shape::Wave),
        ("holed-sphere", Shape::HoledSphere),
    ];
    println!("| shape | noise σ % | outliers | cleaning | removed | vertices | faces | closed / boundary loops | max % | mean % | clean points > 1 % | spikes | long thin facets |");
    println!("|---|---:|---:|---|---:|---:|---:|---|---:|---:|---:|---:|---:|");
    for (name, shape) in shapes {
        if !names.is_empty() && !names.iter().any(|n| n == name) {
            continue;
        }
        for outliers in [0, POINTS / 100] {
            for sigma in [0.0, 0.0025, 0.005, 0.01] {
                // The CLI's defaults (fragments under 64 points dropped); with
                // outliers also the statistical filter at 2 σ; from 0.5 % noise
                // also two rounds of smoothing.
                let filter = if outliers == 0 { 0.0 } else { 2.0 };
                let mut variants = vec![(0.0, 0)];
                if outliers > 0 {
                    variants.push((filter, 0));
                }
                if sigma >= 0.005 {
                    variants.push((filter, 2));
                }
                for (outlier_sigma, smooth_rounds) in variants {
                    row(name, shape, sigma, outliers, outlier_sigma, smooth_rounds);
                }
            }
        }
    }
}

fn row(
    name: &str,
    shape: Shape,
    sigma: f64,
    outliers: usize,
    outlier_sigma: f32,
    smooth_rounds: u32,
) {
    let (clean, noisy) = noisy_cloud(shape, POINTS, SEED, sigma, outliers);
    let diag = arena_tests::diagonal(&clean);
    let params = Params {
        outlier_sigma,
        smooth_rounds,
        ..Params::default()
    };
    let mut flags = Vec::new();
    if outlier_sigma > 0.0 {
        flags.push(format!("`--outliers {outlier_sigma}`"));
    }
    if smooth_rounds > 0 {
        flags.push(format!("`--smooth {smooth_rounds}`"));
    }
    let cleaning = if flags.is_empty() {
        "default".to_string()
    } else {
        flags.join(" ")
    };
    // The host's order: clean, keep what stays, smooth, reconstruct.
    let kept = match arena_tests::pre_passes(&noisy, &params) {
        Ok(kept) => kept,
        Err(e) => {
            println!(
                "| {name} | {:.2} | {outliers} | {cleaning} | failed: {e} |||||||||",
                100.0 * sigma
            );
            return;
        }
    };
    let removed = noisy.len() - kept.len();
    let mut buf = vec![MaybeUninit::uninit(); arena_bytes(kept.len(), &params)];
    let arena = Arena::new(&mut buf);
    let r = match reconstruct(&arena, &kept, None, &params, &mut Silent) {
        Ok(r) => r,
        Err(e) => {
            println!(
                "| {name} | {:.2} | {outliers} | {cleaning} | {removed} | failed: {e} ||||||||",
                100.0 * sigma
            );
            return;
        }
    };
    let (v, t) = (r.mesh.vertices, r.mesh.triangles);
    let topo = topology(v, t);
    let v64: Vec<[f64; 3]> = v.iter().map(|p| p.map(|c| c as f64)).collect();
    let tris: Vec<[[f64; 3]; 3]> = t.iter().map(|f| f.map(|i| v64[i as usize])).collect();
    let to_shape = |p: [f64; 3]| distance_to_shape(shape, p) / diag;
    let samples = vsaqem::eval::sample_surface(&tris, SAMPLES);
    let mean = samples.iter().map(|&p| to_shape(p)).sum::<f64>() / samples.len().max(1) as f64;
    let vd: Vec<f64> = v64.iter().map(|&p| to_shape(p)).collect();
    let max = samples
        .iter()
        .map(|&p| to_shape(p))
        .chain(vd.iter().copied())
        .fold(0.0, f64::max);
    let spikes = vd.iter().filter(|&&d| d > 3.0 * sigma + 0.005).count();
    let clean64: Vec<[f64; 3]> = clean.iter().map(|p| p.map(|c| c as f64)).collect();
    let far = vsaqem::eval::evaluate(&clean64, &v64, t, 1000)
        .point_to_mesh
        .far;
    let closed = if topo.boundary_edges == 0 {
        "closed".to_string()
    } else {
        format!("open, {} loops", boundary_loops(t))
    };
    println!(
        "| {name} | {:.2} | {outliers} | {cleaning} | {removed} | {} | {} | {closed} | {:.2} | {:.3} | {} ({:.2} %) | {spikes} | {} |",
        100.0 * sigma,
        topo.vertices,
        topo.faces,
        100.0 * max,
        100.0 * mean,
        far,
        100.0 * far as f64 / clean.len() as f64,
        long_thin_facets(v, t),
    );
}
