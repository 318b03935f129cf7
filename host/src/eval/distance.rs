//! Distances between the points and the mesh surface, both ways, and their summary.

use super::grid::{bounds, Grid};
use super::{Stats, SAMPLE_SEED, ZERO_AREA};
use crate::geom::{cross, dot, sub};
use std::thread;
use vsaqem_core::rng::Rng;

fn axpy(a: [f64; 3], s: f64, d: [f64; 3]) -> [f64; 3] {
    [a[0] + s * d[0], a[1] + s * d[1], a[2] + s * d[2]]
}

/// Bounding-box diagonal of `points` (NaN when empty).
pub(super) fn diagonal(points: &[[f64; 3]]) -> f64 {
    let (lo, hi) = bounds(points.iter().copied());
    if points.is_empty() {
        return f64::NAN;
    }
    dot(sub(hi, lo), sub(hi, lo)).sqrt()
}

/// Squared distance from `p` to the segment `ab`.
fn dist2_segment(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let ab = sub(b, a);
    let len2 = dot(ab, ab);
    let t = if len2 > 0.0 {
        (dot(sub(p, a), ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let d = sub(p, axpy(a, t, ab));
    dot(d, d)
}

/// Squared distance from `p` to the triangle `t` (closest point by Voronoi regions,
/// Ericsson, *Real-Time Collision Detection* 5.1.5). Zero-area triangles are measured
/// as their three edges.
pub fn dist2_point_triangle(p: [f64; 3], t: &[[f64; 3]; 3]) -> f64 {
    let [a, b, c] = *t;
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let n = cross(ab, ac);
    let n2 = dot(n, n);
    let longest = dot(ab, ab).max(dot(ac, ac)).max(dot(sub(c, b), sub(c, b)));
    if n2 <= (ZERO_AREA * longest).powi(2) {
        return dist2_segment(p, a, b)
            .min(dist2_segment(p, b, c))
            .min(dist2_segment(p, a, c));
    }
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return dot(ap, ap);
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return dot(bp, bp);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return dist2_segment(p, a, b);
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return dot(cp, cp);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return dist2_segment(p, a, c);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return dist2_segment(p, b, c);
    }
    // Inside the prism over the face: the distance to the plane.
    let h = dot(ap, n);
    h * h / n2
}

/// Runs `f(chunk_index_offset, chunk)` over `out` split across the available cores.
fn parallel<T: Send>(out: &mut [T], f: impl Fn(usize, &mut [T]) + Sync) {
    let threads = thread::available_parallelism().map_or(1, |n| n.get());
    let chunk = out.len().div_ceil(threads).max(1024);
    if out.len() <= chunk {
        f(0, out);
        return;
    }
    thread::scope(|s| {
        for (i, part) in out.chunks_mut(chunk).enumerate() {
            let f = &f;
            s.spawn(move || f(i * chunk, part));
        }
    });
}

/// Squared distance from `p` to the box `lo`..`hi`.
fn sq_box_dist(p: [f64; 3], (lo, hi): &([f64; 3], [f64; 3])) -> f64 {
    (0..3)
        .map(|a| {
            let d = (lo[a] - p[a]).max(p[a] - hi[a]).max(0.0);
            d * d
        })
        .sum()
}

/// Distance from each point to the nearest triangle (INFINITY without triangles).
pub(super) fn point_to_mesh_distances(points: &[[f64; 3]], tris: &[[[f64; 3]; 3]]) -> Vec<f64> {
    let mut out = vec![f64::INFINITY; points.len()];
    if tris.is_empty() {
        return out;
    }
    let boxes: Vec<_> = tris.iter().map(|t| bounds(t.iter().copied())).collect();
    let grid = Grid::build(&boxes, 4.0 * tris.len() as f64);
    parallel(&mut out, |first, part| {
        // A triangle spans several cells: visit it once per query.
        let mut seen = vec![u32::MAX; tris.len()];
        for (j, d) in part.iter_mut().enumerate() {
            let q = (first + j) as u32;
            let p = points[first + j];
            *d = grid
                .nearest(p, |t, best2| {
                    let t = t as usize;
                    if seen[t] == q || sq_box_dist(p, &boxes[t]) >= best2 {
                        return f64::INFINITY;
                    }
                    seen[t] = q;
                    dist2_point_triangle(p, &tris[t])
                })
                .sqrt();
        }
    });
    out
}

/// `n` points uniform by area on the triangles (seeded by [`SAMPLE_SEED`]); none when
/// the total area is zero.
pub fn sample_surface(tris: &[[[f64; 3]; 3]], n: usize) -> Vec<[f64; 3]> {
    let mut cum = Vec::with_capacity(tris.len());
    let mut total = 0.0;
    for t in tris {
        let c = cross(sub(t[1], t[0]), sub(t[2], t[0]));
        total += dot(c, c).sqrt();
        cum.push(total);
    }
    if total.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) || !total.is_finite() {
        return Vec::new();
    }
    let mut rng = Rng::from_state(SAMPLE_SEED);
    (0..n)
        .map(|_| {
            let u = rng.unit_f64() * total;
            let i = cum.partition_point(|&c| c <= u).min(tris.len() - 1);
            let [a, b, c] = tris[i];
            let s = rng.unit_f64().sqrt();
            let v = rng.unit_f64();
            let (wb, wc) = (s * (1.0 - v), s * v);
            let p = axpy(a, wb, sub(b, a));
            axpy(p, wc, sub(c, a))
        })
        .collect()
}

/// Distance from each of `samples` surface samples to the nearest point.
pub(super) fn mesh_to_point_distances(
    points: &[[f64; 3]],
    tris: &[[[f64; 3]; 3]],
    samples: usize,
) -> Vec<f64> {
    if points.is_empty() {
        return Vec::new();
    }
    let s = sample_surface(tris, samples);
    let boxes: Vec<_> = points.iter().map(|&p| (p, p)).collect();
    let grid = Grid::build(&boxes, points.len() as f64);
    let mut out = vec![0.0; s.len()];
    parallel(&mut out, |first, part| {
        for (j, d) in part.iter_mut().enumerate() {
            let q = s[first + j];
            *d = grid
                .nearest(q, |i, _| {
                    let e = sub(points[i as usize], q);
                    dot(e, e)
                })
                .sqrt();
        }
    });
    out
}

/// Nearest-rank percentile `p` (0..=100) of sorted `v`.
pub(super) fn percentile(v: &[f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let rank = (p / 100.0 * v.len() as f64).ceil() as usize;
    v[rank.clamp(1, v.len()) - 1]
}

/// The summary of a set of distances.
pub(super) fn stats(mut v: Vec<f64>) -> Stats {
    if v.is_empty() {
        return Stats {
            count: 0,
            max: f64::NAN,
            mean: f64::NAN,
            rms: f64::NAN,
            p99: f64::NAN,
        };
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let rms = (v.iter().map(|d| d * d).sum::<f64>() / n).sqrt();
    v.sort_unstable_by(f64::total_cmp);
    Stats {
        count: v.len(),
        max: v[v.len() - 1],
        mean,
        rms,
        p99: percentile(&v, 99.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::rng_points;

    fn brute(p: [f64; 3], tris: &[[[f64; 3]; 3]]) -> f64 {
        tris.iter()
            .map(|t| dist2_point_triangle(p, t))
            .fold(f64::INFINITY, f64::min)
            .sqrt()
    }

    #[test]
    fn grid_search_equals_brute_force_on_random_triangle_soup() {
        let v = rng_points(600, 7, 1.0);
        let tris: Vec<[[f64; 3]; 3]> = v
            .chunks(3)
            .map(|c| {
                // Small triangles around a centre, plus a few long slivers.
                let s = if c[0][0] > 0.4 { 1.0 } else { 0.1 };
                [c[0], axpy(c[0], s, c[1]), axpy(c[0], s, c[2])]
            })
            .collect();
        let queries = rng_points(3000, 11, 3.0);
        let got = point_to_mesh_distances(&queries, &tris);
        for (q, d) in queries.iter().zip(&got) {
            assert_eq!(*d, brute(*q, &tris), "query {q:?}");
        }
    }

    #[test]
    fn degenerate_triangle_is_measured_as_its_segments() {
        let t = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        assert_eq!(dist2_point_triangle([1.5, 2.0, 0.0], &t), 4.0);
        assert_eq!(dist2_point_triangle([3.0, 0.0, 0.0], &t), 1.0);
        let point = [[1.0, 1.0, 1.0]; 3];
        assert_eq!(dist2_point_triangle([1.0, 1.0, 3.0], &point), 4.0);
    }

    #[test]
    fn percentile_is_nearest_rank() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile(&v, 99.0), 99.0);
        assert_eq!(percentile(&v, 50.0), 50.0);
        assert_eq!(percentile(&v, 1.0), 1.0);
        assert_eq!(percentile(&v, 0.0), 1.0);
        assert_eq!(percentile(&[3.0], 99.0), 3.0);
        assert!(percentile(&[], 5.0).is_nan());
    }

    #[test]
    fn samples_are_deterministic_and_on_the_surface() {
        let tris = [[[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]]];
        let a = sample_surface(&tris, 1000);
        assert_eq!(a, sample_surface(&tris, 1000));
        assert!(a
            .iter()
            .all(|p| p[2] == 0.0 && p[0] >= 0.0 && p[1] >= 0.0 && p[0] + p[1] <= 2.0 + 1e-12));
        // Uniform by area: x + y > 1 holds 1.5 of the area 2, so about 750 samples.
        let outer = a.iter().filter(|p| p[0] + p[1] > 1.0).count();
        assert!((650..850).contains(&outer), "{outer}");
    }
}
