//! Survey of the cleaning pre-pass on the shared clouds (dev tool): pieces of the
//! k-NN graph cut at several link lengths, and what `clean` removes with the
//! outlier filter off, at 3 and at 2 standard deviations, with its time.
//!
//! `cargo run --release -p arena-tests --example clean_survey`
use arena_tests::{load_shared_cloud, shared_clouds, stem};
use std::mem::MaybeUninit;
use std::time::Instant;
use vsaqem_core::clustering::knn::try_neighbours_in;
use vsaqem_core::math::dist2;
use vsaqem_core::{clean, clean_bytes, Arena, Params, Silent, V3};

fn find(p: &mut [u32], mut i: u32) -> u32 {
    while p[i as usize] != i {
        p[i as usize] = p[p[i as usize] as usize];
        i = p[i as usize];
    }
    i
}

/// Sizes of the pieces, largest first, with links up to `mult` spacings.
fn pieces(pts: &[V3], knn: &[u32], k: usize, spacing: f32, mult: f32) -> Vec<u32> {
    let n = pts.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    let l2 = (mult * spacing).powi(2);
    for i in 0..n {
        for &j in &knn[i * k..(i + 1) * k] {
            if dist2(pts[i], pts[j as usize]) <= l2 {
                let (a, b) = (find(&mut parent, i as u32), find(&mut parent, j));
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
    let mut size = vec![0u32; n];
    for i in 0..n {
        size[find(&mut parent, i as u32) as usize] += 1;
    }
    let mut v: Vec<u32> = size.into_iter().filter(|&s| s > 0).collect();
    v.sort_unstable_by(|a, b| b.cmp(a));
    v
}

fn main() {
    let Some(paths) = shared_clouds() else { return };
    for path in paths {
        let pts = load_shared_cloud(&path);
        let name = stem(&path);
        let k = 12;
        let mut buf = vec![MaybeUninit::uninit(); 400 * pts.len() + (1 << 20)];
        {
            let arena = Arena::new(&mut buf);
            let nb = try_neighbours_in(&arena, &pts, k, &mut Silent).unwrap();
            let mut line = format!("{name} {} points:", pts.len());
            for mult in [1.5f32, 2.0, 3.0, 4.0, 6.0] {
                let p = pieces(&pts, nb.knn, k, nb.spacing, mult);
                let small: Vec<u32> = p.iter().copied().filter(|&s| s < 64).collect();
                line += &format!(
                    " | x{mult}: {} pieces {:?}, <64: {} ({} pts)",
                    p.len(),
                    &p[..p.len().min(4)],
                    small.len(),
                    small.iter().sum::<u32>()
                );
            }
            println!("{line}");
        }
        for sigma in [0.0f32, 3.0, 2.0] {
            let params = Params {
                outlier_sigma: sigma,
                ..Params::default()
            };
            let bytes = clean_bytes(pts.len(), &params);
            let mut buf = vec![MaybeUninit::uninit(); bytes];
            let arena = Arena::new(&mut buf);
            let mut keep = vec![true; pts.len()];
            let t = Instant::now();
            let s = clean(&arena, &pts, &params, &mut keep, &mut Silent).unwrap();
            let ms = t.elapsed().as_secs_f64() * 1e3;
            println!(
                "  outliers {sigma}: removed {} outliers, {} fragments ({} points), {} pieces kept, {ms:.1} ms, peak {} bound {bytes} ({:.2}x)",
                s.outliers,
                s.fragments,
                s.fragment_points,
                s.pieces,
                s.peak,
                bytes as f64 / s.peak as f64
            );
        }
    }
}
