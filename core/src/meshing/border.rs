//! Border of the sampled surface (open surfaces, scans): which clusters lie on
//! the border of the data. A cluster is on it when the generators of the clusters
//! it shares a candidate edge with, projected onto its tangent plane, leave an
//! angular gap wider than a threshold around its own generator. Inside a surface
//! the adjacent clusters surround it (gaps of about 60°); where the data ends,
//! there is nothing on one side (gaps near 180°). It must also be at an end of the
//! candidate graph: one of its candidate edges has fewer than two candidate
//! facets. The gap alone also fires at thin parts and sharp edges of closed
//! surfaces; the second test keeps those inside. Last, the data must end there:
//! the cluster's member farthest into the gap has fewer than `AHEAD` of its k
//! nearest points ahead of it. Irregular samples (the vertices of CAD meshes,
//! with long thin triangles) leave gaps and frayed edges in the candidate graph
//! of closed surfaces; the points there go on.
//!
//! Clusters, not points: the k nearest neighbours of a point on a randomly
//! sampled surface bunch to one side often enough that a per-point gap test flags
//! interior points, while cluster neighbours are spread evenly by construction.
//! The measurements behind both choices are in `bench/notes.md`.
//!
//! Cost: O(E log E + n) time for E candidate edges, O(E + m) scratch, m bytes of
//! result. Deterministic.

use crate::arena::Alloc;
use crate::clustering::knn::Neighbours;
use crate::clustering::quadric::Planes;
use crate::error::Result;
use crate::math::{cross, dot, norm, perpendicular, sub, V3};
use crate::meshing::candidates::{Candidates, Members};
use crate::parallel;
use crate::progress::Progress;

/// The largest angular gap (radians, in `[0, 2π]`) around `p` among the points
/// `around`, projected onto the plane of unit normal `n` through `p`. Points that
/// project onto `p` are ignored; with fewer than two left the gap is 2π.
/// `scratch` holds the angles (at least `around.len()` long). Also returns the
/// unit direction, in the plane, through the middle of the gap (zero when there is
/// no gap to point into).
pub fn largest_gap(
    p: V3,
    n: V3,
    around: impl Iterator<Item = V3>,
    scratch: &mut [f32],
) -> (f32, V3) {
    const TAU: f32 = core::f32::consts::TAU;
    // A tangent basis.
    let u = perpendicular(n);
    let lu = norm(u);
    if lu.is_nan() || lu <= 0.0 {
        return (TAU, [0.0; 3]);
    }
    let u = [u[0] / lu, u[1] / lu, u[2] / lu];
    let v = cross(n, u);
    let mut m = 0;
    for q in around {
        if m == scratch.len() {
            break;
        }
        let d = sub(q, p);
        let (x, y) = (dot(d, u), dot(d, v));
        if x != 0.0 || y != 0.0 {
            scratch[m] = libm::atan2f(y, x);
            m += 1;
        }
    }
    if m < 2 {
        return (TAU, [0.0; 3]);
    }
    let ang = &mut scratch[..m];
    ang.sort_unstable_by(|a, b| a.total_cmp(b));
    let (mut gap, mut from) = (ang[0] + TAU - ang[m - 1], ang[m - 1]);
    for w in ang.windows(2) {
        if w[1] - w[0] > gap {
            (gap, from) = (w[1] - w[0], w[0]);
        }
    }
    let mid = from + 0.5 * gap;
    let (c, s) = (libm::cosf(mid), libm::sinf(mid));
    let dir = [
        c * u[0] + s * v[0],
        c * u[1] + s * v[1],
        c * u[2] + s * v[2],
    ];
    (gap, dir)
}

/// Neighbours of point `end` that lie ahead of it in direction `dir` (within
/// 60° of it in the tangent plane of unit normal `n`) at least this many: the
/// data goes on past `end`, so its cluster is not on the border. Inside a
/// surface about a third of the k neighbours lie in any such wedge.
const AHEAD: usize = 2;

/// Most adjacent clusters whose angles a parallel task holds on its stack
/// (more: the clusters one after another, their angles in scratch).
const STACK_ANGLES: usize = 64;

/// Whether the data goes on past point `end` in direction `dir` (see [`AHEAD`]).
fn data_beyond(points: &[V3], nb: &Neighbours, end: u32, n: V3, dir: V3) -> bool {
    let e = end as usize;
    let (Some(&x), Some(row)) = (points.get(e), nb.knn.get(e * nb.k..(e + 1) * nb.k)) else {
        return false;
    };
    let ahead = row
        .iter()
        .filter_map(|&q| points.get(q as usize))
        .filter(|&&q| {
            let d = sub(q, x);
            let h = dot(d, n);
            let t = [d[0] - h * n[0], d[1] - h * n[1], d[2] - h * n[2]];
            // cos(angle to dir) > 1/2, without the square root.
            let a = dot(t, dir);
            a > 0.0 && 4.0 * a * a > dot(t, t)
        })
        .count();
    ahead >= AHEAD
}

/// One flag per cluster (index as in `members`): on the border of the data. A
/// cluster's normal is the sum of its points' plane normals, each flipped to
/// agree with the first; a cluster without points or without a usable normal is
/// not on the border. `angle >= 2π` flags nothing.
///
/// `moved` (a copy of the generators) gets the vertex positions for meshing: the
/// generator of a border cluster sits inside its points, about half a cluster
/// from where the data ends, so a mesh through it would stop short of the border
/// and leave a band of data uncovered. It moves along the gap's middle direction
/// to its farthest point that way, onto the border of the data.
#[allow(clippy::too_many_arguments)]
pub fn try_border_clusters_in<'a, 'b, A: Alloc<'b>>(
    a: &'a A,
    points: &[V3],
    members: &Members,
    planes: &Planes,
    nb: &Neighbours,
    cand: &Candidates,
    per_edge: &[u8],
    generators: &[V3],
    angle: f32,
    moved: &mut [V3],
    hooks: &dyn Progress,
) -> Result<&'a [bool]> {
    let m = members.len().min(generators.len()).min(moved.len());
    let out = a.try_alloc_slice(m, false)?;
    if angle.is_nan() || angle >= core::f32::consts::TAU {
        return Ok(out);
    }
    a.scratch(|s| -> Result<()> {
        // Adjacency (CSR) of the candidate edges, both directions.
        let start = s.try_alloc_slice::<u32>(m + 1, 0)?;
        let edges = cand
            .edges
            .iter()
            .filter(|e| (e[0] as usize) < m && (e[1] as usize) < m);
        for e in edges.clone() {
            start[e[0] as usize + 1] += 1;
            start[e[1] as usize + 1] += 1;
        }
        let mut most = 0;
        for j in 0..m {
            most = most.max(start[j + 1]);
            start[j + 1] += start[j];
        }
        let adj = s.try_alloc_slice::<u32>(start[m] as usize, 0)?;
        let cursor = s.try_alloc_copy::<u32>(&start[..m])?;
        for e in edges {
            for (x, y) in [(e[0], e[1]), (e[1], e[0])] {
                adj[cursor[x as usize] as usize] = y;
                cursor[x as usize] += 1;
            }
        }
        // Clusters at an end of the candidate graph: one of their edges has fewer
        // than two candidate facets (nothing on one side of it).
        let frayed = s.try_alloc_slice::<bool>(m, false)?;
        for (e, &c) in cand.edges.iter().zip(per_edge) {
            if c < 2 {
                for &j in e {
                    if let Some(f) = frayed.get_mut(j as usize) {
                        *f = true;
                    }
                }
            }
        }
        // Each cluster's verdict reads only the inputs: in parallel tasks
        // over ranges of clusters, each with its angles on its stack, when
        // the most adjacent clusters fit there; else one after another.
        let frayed = &*frayed;
        let (start, adj) = (&*start, &*adj);
        let verdict = |j: usize, angles: &mut [f32]| -> Option<V3> {
            let pts = members.of(j);
            let &first = pts.first()?;
            let reference = planes.planes[first as usize];
            let mut n = [0.0f32; 3];
            for &i in pts {
                let q = planes.planes[i as usize];
                let sign = if dot(
                    [q[0], q[1], q[2]],
                    [reference[0], reference[1], reference[2]],
                ) < 0.0
                {
                    -1.0
                } else {
                    1.0
                };
                for c in 0..3 {
                    n[c] += sign * q[c];
                }
            }
            let l = norm(n);
            if !(l > 0.0 && l.is_finite()) {
                return None;
            }
            let n = [n[0] / l, n[1] / l, n[2] / l];
            let around = adj[start[j] as usize..start[j + 1] as usize]
                .iter()
                .map(|&k| generators[k as usize]);
            let (gap, dir) = largest_gap(generators[j], n, around, angles);
            if !(gap > angle && frayed[j]) {
                return None;
            }
            // The member farthest into the gap: where the data ends, its
            // neighbours all lie behind it or along the border.
            let g = generators[j];
            let (mut reach, mut end) = (0.0f32, first);
            for &i in pts {
                let x = dot(sub(points[i as usize], g), dir);
                if x > reach {
                    (reach, end) = (x, i);
                }
            }
            if data_beyond(points, nb, end, n, dir) {
                return None;
            }
            Some([0, 1, 2].map(|c| g[c] + reach * dir[c]))
        };
        let most = most as usize;
        if most <= STACK_ANGLES && hooks.threads() >= 2 {
            parallel::pairs(hooks, &mut out[..m], &mut moved[..m], |js, out, moved| {
                let mut angles = [0.0f32; STACK_ANGLES];
                for (j, (o, v)) in js.zip(out.iter_mut().zip(moved)) {
                    if let Some(p) = verdict(j, &mut angles[..most]) {
                        (*o, *v) = (true, p);
                    }
                }
            });
        } else {
            let angles = s.try_alloc_slice::<f32>(most, 0.0)?;
            for j in 0..m {
                if let Some(p) = verdict(j, angles) {
                    (out[j], moved[j]) = (true, p);
                }
            }
        }
        Ok(())
    })?;
    Ok(out)
}
