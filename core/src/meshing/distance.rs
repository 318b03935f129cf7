//! How far the data is from the mesh: every point's exact distance to its
//! nearest face, found through a [`FaceGrid`], and the maximum, 99th percentile
//! and mean of those distances. What the user of a reconstruction asks first
//! ("is every part of my data in the mesh, and how far is the farthest point?"),
//! and what error-driven refinement acts on.
//!
//! Memory: the grid (at most 88 bytes per face) and the distances the caller
//! passes (4 bytes per point). Cost: O(n × faces near a point × log E) for n
//! points and E grid entries; O(n) more for the percentile (a selection, not a
//! sort).

use crate::arena::Alloc;
use crate::error::Result;
use crate::math::V3;
use crate::meshing::face_grid::FaceGrid;
use crate::parallel;
use crate::progress::Progress;

/// Distances from the input points to the mesh, as fractions of the bounding-box
/// diagonal of the points.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MeshDistance {
    /// The largest.
    pub max: f32,
    /// The 99th percentile (nearest rank).
    pub p99: f32,
    /// The mean.
    pub mean: f32,
    /// The point at the largest distance (the lowest index among equals).
    pub farthest: u32,
}

/// Writes to `out[i]` the distance from `points[i]` to the nearest face of the
/// mesh (`f32::INFINITY` when the mesh has no usable face). `out` must be as
/// long as `points`; extra entries of either are ignored. `hints`, when given
/// (as long as `points`), holds a face near each point (`u32::MAX`: none),
/// where its search starts (a good one prunes most of it; the distance is the
/// same whatever the hint), and on return its nearest face. The searches run
/// as parallel tasks through `hooks` ([`crate::parallel`]).
pub fn try_point_distances_in<'b, A: Alloc<'b>>(
    alloc: &A,
    points: &[V3],
    vertices: &[V3],
    faces: &[[u32; 3]],
    out: &mut [f32],
    hints: Option<&mut [u32]>,
    hooks: &dyn Progress,
) -> Result<()> {
    alloc.scratch(|s| {
        let grid = FaceGrid::try_new_in(s, vertices, faces, hooks)?;
        let n = points.len().min(out.len());
        let search = |i: usize, hint: Option<u32>| {
            let near = grid.nearest_from(points[i], hint.filter(|&f| f != u32::MAX));
            let d = near.map_or(f32::INFINITY, |(_, d2)| libm::sqrtf(d2));
            (near.map_or(u32::MAX, |(f, _)| f), d)
        };
        // Without hints (or the wrong number), every search starts afresh.
        match hints.filter(|h| h.len() == points.len()) {
            Some(hints) => {
                parallel::pairs(hooks, &mut out[..n], hints, |items, d, h| {
                    for ((i, d), h) in items.zip(d.iter_mut()).zip(h.iter_mut()) {
                        (*h, *d) = search(i, Some(*h));
                    }
                });
            }
            None => {
                parallel::rows(hooks, &mut out[..n], 1, |items, d: &mut [f32]| {
                    for (i, d) in items.zip(d.iter_mut()) {
                        *d = search(i, None).1;
                    }
                });
            }
        }
        Ok(())
    })
}

/// The summary of `distances` (absolute, as [`try_point_distances_in`] gives
/// them) relative to `diag`. Reorders `distances` (the percentile is a
/// selection). All zero for no points.
pub fn summarise(distances: &mut [f32], diag: f32) -> MeshDistance {
    let n = distances.len();
    if n == 0 {
        return MeshDistance::default();
    }
    let scale = if diag > 0.0 && diag.is_finite() {
        1.0 / diag
    } else {
        1.0
    };
    let mut max = f32::NEG_INFINITY;
    let mut farthest = 0u32;
    let mut sum = 0.0f64;
    for (i, &d) in distances.iter().enumerate() {
        if d > max {
            max = d;
            farthest = i as u32;
        }
        sum += d as f64;
    }
    // Nearest rank: the smallest value with at least 99 % of the points at or
    // below it.
    let rank = (n * 99).div_ceil(100).max(1) - 1;
    let (_, p99, _) = distances.select_nth_unstable_by(rank, f32::total_cmp);
    MeshDistance {
        max: max * scale,
        p99: *p99 * scale,
        mean: (sum / n as f64) as f32 * scale,
        farthest,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arena::Arena;
    use crate::progress::Silent;
    use std::mem::MaybeUninit;
    use std::vec;

    #[test]
    fn distances_to_a_square_and_their_summary() {
        let v = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        let f = [[0, 1, 2], [0, 2, 3]];
        // 100 points at heights 0.00 .. 0.99 above the square, one beside it.
        let mut pts: vec::Vec<V3> = (0..100).map(|i| [0.5, 0.5, i as f32 / 100.0]).collect();
        pts.push([3.0, 0.5, 0.0]);
        let mut buf = vec![MaybeUninit::uninit(); 1 << 16];
        let arena = Arena::new(&mut buf);
        let mut d = vec![0.0f32; pts.len()];
        try_point_distances_in(&arena, &pts, &v, &f, &mut d, None, &Silent).unwrap();
        assert_eq!(d[37], 0.37);
        assert_eq!(d[100], 2.0);
        assert_eq!(arena.used(), 0, "the grid is scratch");
        let s = summarise(&mut d, 2.0);
        assert_eq!(s.max, 1.0);
        assert_eq!(s.farthest, 100);
        // Rank 100 of 101 (nearest rank of 99 %): the second largest, 0.99.
        assert_eq!(s.p99, 0.99 / 2.0);
        let mean = ((0..100).map(|i| i as f64 / 100.0).sum::<f64>() + 2.0) / 101.0;
        assert!((s.mean as f64 - mean / 2.0).abs() < 1e-6);
    }

    #[test]
    fn no_faces_means_infinitely_far() {
        let mut buf = vec![MaybeUninit::uninit(); 1 << 12];
        let arena = Arena::new(&mut buf);
        let mut d = [0.0f32; 2];
        try_point_distances_in(
            &arena,
            &[[0.0; 3], [1.0; 3]],
            &[],
            &[],
            &mut d,
            None,
            &Silent,
        )
        .unwrap();
        assert_eq!(d, [f32::INFINITY; 2]);
        assert_eq!(summarise(&mut [], 1.0), MeshDistance::default());
    }
}
