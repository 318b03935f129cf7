//! The mesh's vertices moved onto the data, by regularised least squares: fidelity
//! at no extra vertex.
//!
//! Every vertex starts at its cluster's QEM-optimal generator, which is optimal
//! for the cluster's tangent planes, not for the mesh: where faces meet at a
//! crease or wrap a thin part, the mesh runs farther from the data than it needs to.
//! A round projects every point `p` onto its nearest face (through a
//! [`FaceGrid`]), with barycentric coordinates `β_p` there, and then minimises,
//! over the vertex positions `x`,
//!
//! ```text
//! Σ_p |p − Σ_k β_pk x_k|²  +  λ Σ_v w_v |x_v − x⁰_v|²
//! ```
//!
//! where `x⁰` are the positions before fitting and `w_v` the number of points
//! whose coordinates touch `v` (`β_pv > 0`), so `λ` is dimensionless: each
//! point counts once in a vertex's anchor and at most once (`β² ≤ 1`) in its
//! data. The normal equations are
//! the same sparse matrix for the three coordinates (nonzeros on the mesh's
//! edges), solved by [`SWEEPS`] Gauss-Seidel sweeps in vertex order from the
//! current positions. A few rounds of projection and solve follow each other.
//!
//! Safety, the invariant every round keeps:
//! - a vertex on a boundary or non-manifold edge, or on a face with an index out
//!   of range, a repeated index, a non-finite corner or no area, never moves (the
//!   border of an open surface stays where the data ends);
//! - a vertex moves at most [`MAX_MOVE`] times its shortest incident edge away
//!   from `x⁰`: it stays among its neighbours, never reaching one of them
//!   (whether another part of the surface comes nearer than that is not
//!   tested yet: [`move_allowed`] is the place for such a test);
//! - every face keeps its orientation (its normal at a positive dot product with
//!   its normal before fitting) and at least [`MIN_AREA`] of its area: where
//!   [`move_allowed`] refuses a face, its vertices go back to where the round
//!   found them, until no face is refused.
//!
//! Memory: scratch only, O(n + V + F): 4 bytes per point (its nearest face,
//! where the next round's search starts; with more than one thread, and room
//! under the arena's peak so far, 12 more for its barycentric coordinates
//! there, which never raise the peak), 73 bytes per vertex
//! (anchors, positions at the round's start, reach, a fixed flag, the
//! accumulated normal equations, the start of its face list) and 36 per face
//! (the matrix's off-diagonal terms, the vertex-to-face lists), plus the face
//! grid of a round (at most 88 bytes per face; the edge keys that find the
//! boundary, 24 per face, come and go before). Cost per round: O(n × faces
//! near a point × log E) for the projections (as for the distances, which
//! take as long) plus O(SWEEPS × F) for the solve.
//! Deterministic: fixed orders throughout.

use crate::arena::{padded_bytes, Alloc};
use crate::error::Result;
use crate::math::{closest_on_triangle, dist2, dot, is_finite3, norm, sub, V3};
use crate::meshing::face_grid::FaceGrid;
use crate::meshing::output::{face_normal, key};
use crate::parallel;
use crate::progress::Progress;

/// Weight `λ` of the anchors against the data, dimensionless (see the module
/// docs): smaller follows the data closer, larger keeps the vertices nearer
/// their generators (which sit exactly on a crease where the data has one).
pub const LAMBDA: f32 = 0.1;
/// Gauss-Seidel sweeps per round (the data spreads each point over three
/// vertices, so the system is nearly diagonal and converges in a few).
pub const SWEEPS: u32 = 4;
/// A vertex moves at most this fraction of its shortest incident edge (before
/// fitting) away from where it started: two neighbours never meet.
pub const MAX_MOVE: f32 = 1.0 / 3.0;
/// A face keeps at least this fraction of its area before fitting.
pub const MIN_AREA: f32 = 0.25;
/// Passes of putting back the vertices of refused faces before the whole round
/// is undone (each pass can refuse faces the previous one made).
const SETTLE_PASSES: u32 = 8;

/// What fitting did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FitStats {
    /// Rounds of projection and solve run (a round in which no vertex moved
    /// ends fitting).
    pub rounds: u32,
    /// Vertices not where they started.
    pub moved: u32,
    /// Moves taken back: over all rounds because a face would have turned
    /// over or collapsed, and after fitting (by the output stage) because a
    /// face would have crossed another or folded onto its neighbour.
    pub reverted: u32,
}

/// Whether a face with corners `before` (before fitting) may have corners
/// `after`: it neither turns over (its normal stays at a positive dot product
/// with the one before) nor collapses (keeps [`MIN_AREA`] of its area). The one
/// place a move is judged; a later self-intersection test belongs here.
pub fn move_allowed(before: [V3; 3], after: [V3; 3]) -> bool {
    let (n0, n) = (face_normal(before), face_normal(after));
    let (a0, a) = (norm(n0), norm(n));
    dot(n0, n) > 0.0 && a >= MIN_AREA * a0 && a.is_finite()
}

/// The corners of `face`, when its indices are in range and distinct.
fn corners_of(vertices: &[V3], face: [u32; 3]) -> Option<[V3; 3]> {
    let [a, b, c] = face;
    if a == b || b == c || a == c {
        return None;
    }
    Some([
        *vertices.get(a as usize)?,
        *vertices.get(b as usize)?,
        *vertices.get(c as usize)?,
    ])
}

/// Moves `vertices` towards `points` by `rounds` rounds of projection and
/// regularised least squares with anchor weight `lambda` (see the module docs;
/// [`LAMBDA`] is the default). `triangles` index `vertices`; faces that are
/// broken (out of range, repeated index, non-finite, no area) are left alone
/// with their vertices. Never turns a face over or collapses it; an infinite or
/// NaN `lambda`, no points or no faces move nothing. `hints`, when given
/// (as long as `points`), holds a face near each point (`u32::MAX`: none),
/// where the first round's search starts, and on return each point's nearest
/// face in the last round (unchanged when nothing moved). The nearest-face
/// searches run as parallel tasks through `hooks` ([`crate::parallel`]).
#[allow(clippy::too_many_arguments)]
pub fn try_fit_vertices_in<'b, A: Alloc<'b>>(
    scratch: &A,
    points: &[V3],
    vertices: &mut [V3],
    triangles: &[[u32; 3]],
    rounds: u32,
    lambda: f32,
    hints: Option<&mut [u32]>,
    hooks: &dyn Progress,
) -> Result<FitStats> {
    let mut stats = FitStats::default();
    let (nv, nf) = (vertices.len(), triangles.len());
    if rounds == 0 || nv == 0 || nf == 0 || points.is_empty() || !lambda.is_finite() {
        return Ok(stats);
    }
    let lambda = lambda.max(0.0) as f64;
    scratch.scratch(|s| -> Result<FitStats> {
        let fixed = s.try_alloc_slice::<bool>(nv, false)?;
        mark_fixed(s, vertices, triangles, fixed)?;
        let x0 = s.try_alloc_copy::<V3>(vertices)?;
        let prev = s.try_alloc_copy::<V3>(vertices)?;
        // How far each vertex may go: a fraction of its shortest incident edge.
        let reach = s.try_alloc_slice::<f32>(nv, f32::INFINITY)?;
        for &face in triangles {
            let Some(t) = corners_of(x0, face) else {
                continue;
            };
            for k in 0..3 {
                let l = libm::sqrtf(dist2(t[k], t[(k + 1) % 3]));
                for v in [face[k], face[(k + 1) % 3]] {
                    let r = &mut reach[v as usize];
                    *r = r.min(MAX_MOVE * l);
                }
            }
        }
        // Faces of each vertex (faces with distinct in-range indices only).
        let start = s.try_alloc_slice::<u32>(nv + 1, 0)?;
        for &face in triangles {
            if corners_of(x0, face).is_some() {
                for v in face {
                    start[v as usize + 1] += 1;
                }
            }
        }
        for v in 0..nv {
            start[v + 1] += start[v];
        }
        let incident = s.try_alloc_slice::<u32>(start[nv] as usize, 0)?;
        // `start[v]` as the cursor of `v`'s list, then shifted back.
        for (f, &face) in triangles.iter().enumerate() {
            if corners_of(x0, face).is_some() {
                for v in face.map(|v| v as usize) {
                    incident[start[v] as usize] = f as u32;
                    start[v] += 1;
                }
            }
        }
        start.copy_within(0..nv, 1);
        start[0] = 0;
        // The normal equations: diagonal, right-hand sides, anchor weights,
        // and per face the off-diagonal terms of its edges (k, k+1).
        let diag = s.try_alloc_slice::<f64>(nv, 0.0)?;
        let rhs = s.try_alloc_slice::<[f64; 3]>(nv, [0.0; 3])?;
        let weight = s.try_alloc_slice::<u32>(nv, 0)?;
        let off = s.try_alloc_slice::<[f64; 3]>(nf, [0.0; 3])?;
        // Each point's nearest face in the round before: where its search
        // starts in the next (the faces move a little between rounds).
        let hints = match hints {
            Some(h) if h.len() == points.len() => h,
            _ => s.try_alloc_slice::<u32>(points.len(), u32::MAX)?,
        };
        for _ in 0..rounds {
            diag.fill(0.0);
            rhs.fill([0.0; 3]);
            weight.fill(0);
            off.fill([0.0; 3]);
            s.scratch(|t| -> Result<()> {
                let vertices = &*vertices;
                let grid = FaceGrid::try_new_in(t, vertices, triangles, hooks)?;
                // The searches in parallel (each point's nearest face into its
                // hint), then the sums in point order. With more than one
                // thread, and room under the arena's peak so far, the tasks
                // also keep each point's barycentric coordinates there (12
                // bytes a point), leaving the calling thread only the sums;
                // else it works them out as it sums. The same function of the
                // same corners either way: the sums are the same, bit for bit.
                // Under the peak neither the arena's peak nor the resident
                // memory grows for them (`fits_under_peak`; both did at 10M
                // points on two threads: 1,102 to 1,150 MiB).
                let n = points.len();
                let keep = hooks.threads() > 1 && t.fits_under_peak(padded_bytes::<V3>(n));
                let betas = t.try_alloc_slice::<V3>(if keep { n } else { 0 }, [0.0; 3])?;
                let nearest = |p: V3, h: &mut u32| {
                    let hint = (*h != u32::MAX).then_some(*h);
                    *h = grid.nearest_from(p, hint).map_or(u32::MAX, |(f, _)| f);
                };
                // The corners of face `f` when it is in range and sound.
                let sound = |f: u32| corners_of(vertices, *triangles.get(f as usize)?);
                let coords = |p: V3, f: u32| {
                    let c = sound(f)?;
                    Some(closest_on_triangle(p, c[0], c[1], c[2]).1)
                };
                if keep {
                    parallel::pairs(hooks, &mut hints[..], betas, |items, h, b| {
                        for ((&p, h), b) in points[items].iter().zip(h).zip(b) {
                            nearest(p, h);
                            *b = coords(p, *h).unwrap_or([0.0; 3]);
                        }
                    });
                } else {
                    parallel::rows(hooks, &mut hints[..], 1, |items, h: &mut [u32]| {
                        for (&p, h) in points[items].iter().zip(h.iter_mut()) {
                            nearest(p, h);
                        }
                    });
                }
                // Point `p`'s share of the normal equations, on face `f`
                // (in range, its corners sound) at coordinates `beta`.
                let mut sum = |p: V3, f: u32, beta: V3| {
                    let face = triangles[f as usize];
                    for k in 0..3 {
                        let (v, b) = (face[k] as usize, beta[k] as f64);
                        diag[v] += b * b;
                        for (r, &x) in rhs[v].iter_mut().zip(&p) {
                            *r += b * x as f64;
                        }
                        weight[v] += (b > 0.0) as u32;
                        off[f as usize][k] += b * beta[(k + 1) % 3] as f64;
                    }
                };
                if keep {
                    for ((&p, &f), &beta) in points.iter().zip(hints.iter()).zip(&*betas) {
                        if sound(f).is_some() {
                            sum(p, f, beta);
                        }
                    }
                } else {
                    for (&p, &f) in points.iter().zip(hints.iter()) {
                        if let Some(c) = sound(f) {
                            sum(p, f, closest_on_triangle(p, c[0], c[1], c[2]).1);
                        }
                    }
                }
                Ok(())
            })?;
            for v in 0..nv {
                let w = lambda * weight[v] as f64;
                diag[v] += w;
                for (r, &x) in rhs[v].iter_mut().zip(&x0[v]) {
                    *r += w * x as f64;
                }
            }
            prev.copy_from_slice(vertices);
            for _ in 0..SWEEPS {
                for v in 0..nv {
                    if fixed[v] || diag[v] <= 0.0 || diag[v].is_nan() {
                        continue;
                    }
                    let mut r = rhs[v];
                    let faces = &incident[start[v] as usize..start[v + 1] as usize];
                    for &f in faces {
                        let face = triangles[f as usize];
                        let k = face.iter().position(|&u| u as usize == v).unwrap_or(0);
                        let (k1, k2) = ((k + 1) % 3, (k + 2) % 3);
                        for (u, a) in [
                            (face[k1], off[f as usize][k]),
                            (face[k2], off[f as usize][k2]),
                        ] {
                            let x = vertices[u as usize];
                            for i in 0..3 {
                                r[i] -= a * x[i] as f64;
                            }
                        }
                    }
                    let x: V3 = core::array::from_fn(|i| (r[i] / diag[v]) as f32);
                    vertices[v] = clamp_to(x0[v], x, reach[v]);
                }
            }
            stats.reverted += settle(vertices, prev, x0, triangles);
            stats.rounds += 1;
            if *vertices == *prev {
                break;
            }
        }
        stats.moved = vertices
            .iter()
            .zip(x0.iter())
            .filter(|(a, b)| a != b)
            .count() as u32;
        Ok(stats)
    })
}

/// `x`, or the point at distance `r` from `c` towards it when farther; `c` when
/// `x` is not finite.
fn clamp_to(c: V3, x: V3, r: f32) -> V3 {
    if !is_finite3(x) {
        return c;
    }
    let d = sub(x, c);
    let l = norm(d);
    if l <= r {
        return x;
    }
    let s = r / l;
    if !(s.is_finite() && s >= 0.0) {
        return c;
    }
    core::array::from_fn(|i| c[i] + d[i] * s)
}

/// Puts back, to `prev` (where the round found them), the vertices of every
/// face [`move_allowed`] refuses (before: `x0`), pass after pass until none is
/// refused; after [`SETTLE_PASSES`] passes, every vertex goes back. A face none
/// of whose vertices moved is as the round found it, so it is not judged again.
/// Returns the vertices put back.
fn settle(vertices: &mut [V3], prev: &[V3], x0: &[V3], triangles: &[[u32; 3]]) -> u32 {
    let mut reverted = 0u32;
    for _ in 0..SETTLE_PASSES {
        let mut refused = false;
        for &face in triangles {
            let (Some(before), Some(after)) = (corners_of(x0, face), corners_of(vertices, face))
            else {
                continue;
            };
            let moved = face
                .iter()
                .any(|&v| vertices[v as usize] != prev[v as usize]);
            if !moved || move_allowed(before, after) {
                continue;
            }
            refused = true;
            for v in face.map(|v| v as usize) {
                if vertices[v] != prev[v] {
                    vertices[v] = prev[v];
                    reverted += 1;
                }
            }
        }
        if !refused {
            return reverted;
        }
    }
    // Still refusing: the round is undone (the positions it started from were
    // allowed).
    for (x, &p) in vertices.iter_mut().zip(prev) {
        if *x != p {
            *x = p;
            reverted += 1;
        }
    }
    reverted
}

/// Marks in `fixed` the vertices that must not move: on an edge without
/// exactly two faces (the boundary, or non-manifold), or on a broken face (an
/// index out of range, a repeated index, a non-finite corner, no area). On a
/// manifold mesh of sound faces: the vertices of its boundary edges.
pub(crate) fn mark_fixed<'b, A: Alloc<'b>>(
    s: &A,
    vertices: &[V3],
    triangles: &[[u32; 3]],
    fixed: &mut [bool],
) -> Result<()> {
    s.scratch(|t| -> Result<()> {
        let keys = t.try_alloc_slice::<u64>(3 * triangles.len(), u64::MAX)?;
        let mut w = 0;
        for &face in triangles {
            let broken = match corners_of(vertices, face) {
                None => true,
                Some(c) => {
                    let n = face_normal(c);
                    !(c.iter().all(|&v| is_finite3(v)) && is_finite3(n) && dot(n, n) > 0.0)
                }
            };
            if broken {
                for v in face {
                    if let Some(x) = fixed.get_mut(v as usize) {
                        *x = true;
                    }
                }
                continue;
            }
            for k in 0..3 {
                keys[w] = key(face[k], face[(k + 1) % 3]);
                w += 1;
            }
        }
        let keys = &mut keys[..w];
        keys.sort_unstable();
        let mut i = 0;
        while i < keys.len() {
            let run = keys[i..].iter().take_while(|&&k| k == keys[i]).count();
            if run != 2 {
                for v in [(keys[i] >> 32) as usize, keys[i] as u32 as usize] {
                    if let Some(x) = fixed.get_mut(v) {
                        *x = true;
                    }
                }
            }
            i += run;
        }
        Ok(())
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::arena::Arena;
    use crate::progress::Silent;
    use crate::rng::Rng;
    use std::mem::MaybeUninit;
    use std::vec;
    use std::vec::Vec;

    /// A flat `n x n` grid of vertices with spacing 1 in the plane z = 0, two
    /// faces per square, counter-clockwise seen from +z.
    pub(crate) fn grid(n: u32) -> (Vec<V3>, Vec<[u32; 3]>) {
        let v = (0..n * n)
            .map(|i| [(i % n) as f32, (i / n) as f32, 0.0])
            .collect();
        let mut f = Vec::new();
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                let a = y * n + x;
                f.push([a, a + 1, a + n + 1]);
                f.push([a, a + n + 1, a + n]);
            }
        }
        (v, f)
    }

    fn on_border(v: V3, n: u32) -> bool {
        let m = (n - 1) as f32;
        v[0] == 0.0 || v[1] == 0.0 || v[0] == m || v[1] == m
    }

    /// Points on a lattice over the grid at height `h`.
    fn layer(n: u32, h: f32) -> Vec<V3> {
        let m = 10 * (n - 1);
        (0..=m)
            .flat_map(|y| (0..=m).map(move |x| [x as f32 / 10.0, y as f32 / 10.0, h]))
            .collect()
    }

    fn fit(points: &[V3], v: &mut [V3], f: &[[u32; 3]], rounds: u32, lambda: f32) -> FitStats {
        let mut buf = vec![MaybeUninit::uninit(); 1 << 20];
        let arena = Arena::new(&mut buf);
        let stats =
            try_fit_vertices_in(&arena, points, v, f, rounds, lambda, None, &Silent).unwrap();
        assert_eq!(arena.used(), 0, "fitting leaves nothing in the arena");
        stats
    }

    #[test]
    fn inner_vertices_move_towards_points_above_and_the_border_stays() {
        let (v0, f) = grid(6);
        let pts = layer(6, 0.1);
        let mut v = v0.clone();
        let stats = fit(&pts, &mut v, &f, 3, LAMBDA);
        assert_eq!((stats.moved, stats.reverted), (16, 0), "{stats:?}");
        for (a, b) in v.iter().zip(&v0) {
            if on_border(*b, 6) {
                assert_eq!(a, b, "a boundary vertex moved");
            } else {
                // Up to about the points' height (beside the border a little
                // beyond, making up for the border's faces, which tilt).
                assert!(a[2] > 0.05 && a[2] < 0.15, "{a:?}");
                // Towards the points, not along the plane.
                let slide = (a[0] - b[0]).abs().max((a[1] - b[1]).abs());
                assert!(slide < 0.01, "{a:?} slid {slide}");
            }
        }
        // A stronger anchor holds the vertices back.
        let mut held = v0.clone();
        fit(&pts, &mut held, &f, 3, 10.0);
        let height = |v: &[V3]| v.iter().map(|x| x[2]).sum::<f32>();
        assert!(height(&held) > 0.0 && height(&held) < 0.5 * height(&v));
    }

    #[test]
    fn huge_or_infinite_lambda_moves_nothing_beyond_rounding() {
        let (v0, f) = grid(5);
        for lambda in [1e30, f32::INFINITY, f32::NAN] {
            let mut v = v0.clone();
            fit(&layer(5, 0.2), &mut v, &f, 3, lambda);
            let far = v
                .iter()
                .zip(&v0)
                .map(|(a, b)| dist2(*a, *b))
                .fold(0.0, f32::max);
            assert!(far < 1e-40, "lambda {lambda}: a vertex moved {far}");
        }
    }

    /// With more than one thread the search tasks keep each point's
    /// barycentric coordinates: the vertices are the same, bit for bit, as
    /// when the calling thread works them out (one thread, or no room for
    /// them), on points above and below a bumpy grid and scattered far off.
    #[test]
    fn kept_coordinates_give_the_fit_of_one_thread() {
        use crate::progress::Claimed;
        let (mut v0, f) = grid(9);
        let mut rng = Rng::new(11);
        for v in v0.iter_mut() {
            v[2] = (rng.unit_f64() as f32 - 0.5) * 0.2;
        }
        let mut pts = layer(9, 0.05);
        for p in pts.iter_mut().step_by(3) {
            p[2] = -p[2] + (rng.unit_f64() as f32 - 0.5) * 0.3;
        }
        pts.extend((0..200).map(|_| [0; 3].map(|_| (rng.unit_f64() as f32 - 0.5) * 30.0)));
        // `touched` bytes of scratch before the fit, as earlier stages leave
        // the arena's peak: the room the coordinates may take.
        let run = |hooks: &dyn Progress, room: usize, touched: usize| {
            let mut buf = vec![MaybeUninit::uninit(); room];
            let arena = Arena::new(&mut buf);
            arena.scratch(|s| s.try_alloc_slice::<u8>(touched, 0).map(|_| ()))?;
            let mut v = v0.clone();
            let stats = try_fit_vertices_in(&arena, &pts, &mut v, &f, 3, LAMBDA, None, hooks);
            assert_eq!(arena.used(), 0);
            Ok::<_, crate::arena::Exhausted>((stats.unwrap(), v, arena.peak()))
        };
        let (stats, want, peak) = run(&Silent, 1 << 20, 0).unwrap();
        assert!(stats.moved > 30, "{stats:?}");
        // The least room one thread fits in (a search over sizes): none left
        // for the coordinates, so the calling thread works them out.
        let fits = |room: usize| {
            let mut buf = vec![MaybeUninit::uninit(); room];
            let arena = Arena::new(&mut buf);
            let mut v = v0.clone();
            try_fit_vertices_in(&arena, &pts, &mut v, &f, 3, LAMBDA, None, &Silent).is_ok()
        };
        let (mut lo, mut hi) = (0usize, 1 << 20);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if fits(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        let tight = hi;
        assert!(tight + 12 * pts.len() < 1 << 20);
        // Kept where an earlier scratch reached deep enough (2 and 3 threads),
        // not kept without one (4) nor without room (8).
        let deep = peak + padded_bytes::<V3>(pts.len());
        for (threads, room, touched) in [
            (2, 1 << 20, deep),
            (3, 1 << 20, deep),
            (4, 1 << 20, 0),
            (8, tight, 0),
        ] {
            let (s, v, _) = run(&Claimed::backwards(threads), room, touched).unwrap();
            assert_eq!(s, stats, "{threads} threads");
            assert!(v == want, "{threads} threads: the vertices differ");
        }
    }

    /// The coordinates the search tasks keep never raise the arena's peak:
    /// without an earlier scratch as deep, two threads reach the peak of one.
    #[test]
    fn kept_coordinates_never_raise_the_peak() {
        use crate::progress::Claimed;
        let (v0, f) = grid(9);
        let pts = layer(9, 0.05);
        let peak = |hooks: &dyn Progress| {
            let mut buf = vec![MaybeUninit::uninit(); 1 << 20];
            let arena = Arena::new(&mut buf);
            let mut v = v0.clone();
            try_fit_vertices_in(&arena, &pts, &mut v, &f, 2, LAMBDA, None, hooks).unwrap();
            arena.peak()
        };
        let one = peak(&Silent);
        for threads in [2, 3] {
            assert_eq!(peak(&Claimed::backwards(threads)), one, "{threads} threads");
        }
    }

    #[test]
    fn no_face_turns_over_or_collapses_under_adversarial_points() {
        // Two slivers: inner vertices moved next to the middle of an edge
        // across, so a short move turns a face over.
        let (mut v0, f) = grid(7);
        v0[3 * 7 + 3] = [3.9, 3.5, 0.0];
        v0[4 * 7 + 1] = [1.5, 4.9, 0.0];
        let mut rng = Rng::new(5);
        let mut reverted = 0;
        for trial in 0..40 {
            // Points far below, far to the side, or piled on one spot.
            let mut pts: Vec<V3> = (0..300)
                .map(|_| {
                    let mut r = |s: f32| (rng.unit_f64() as f32 - 0.5) * s;
                    match trial % 4 {
                        0 => [3.0 + r(1.0), 3.0 + r(1.0), -5.0 + r(1.0)],
                        1 => [r(40.0), r(40.0), r(40.0)],
                        2 => [3.2 + r(0.1), 2.9 + r(0.1), r(0.1)],
                        _ => [
                            r(6.0) + 3.0,
                            r(6.0) + 3.0,
                            if r(1.0) > 0.0 { 2.0 } else { -2.0 },
                        ],
                    }
                })
                .collect();
            pts.extend(layer(7, -0.3).iter().step_by(7 + trial));
            let mut v = v0.clone();
            reverted += fit(&pts, &mut v, &f, 3, 0.0).reverted;
            for face in &f {
                let before = face.map(|i| v0[i as usize]);
                let after = face.map(|i| v[i as usize]);
                assert!(
                    move_allowed(before, after),
                    "trial {trial}: {face:?} {after:?}"
                );
            }
            for (a, b) in v.iter().zip(&v0) {
                assert!(norm(sub(*a, *b)) <= MAX_MOVE * 1.0001, "{a:?} from {b:?}");
            }
        }
        assert!(reverted > 0, "the points never pushed a face over");
    }

    #[test]
    fn refused_faces_have_their_vertices_put_back() {
        // One free vertex pushed across its neighbours turns faces over.
        let (v0, f) = grid(3);
        let mut v = v0.clone();
        v[4] = [2.5, 1.0, 0.0];
        let reverted = settle(&mut v, &v0, &v0, &f);
        assert_eq!((reverted, v), (1, v0));
        assert!(!move_allowed(
            [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            [[0.0; 3], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]
        ));
        assert!(!move_allowed(
            [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 0.1, 0.0]]
        ));
    }

    #[test]
    fn empty_broken_and_non_finite_input_is_fine() {
        let (v0, f) = grid(4);
        let pts = layer(4, 0.1);
        assert_eq!(fit(&[], &mut [], &[], 3, LAMBDA), FitStats::default());
        let mut v = v0.clone();
        assert_eq!(fit(&[], &mut v, &f, 3, LAMBDA), FitStats::default());
        assert_eq!(fit(&pts, &mut v, &[], 3, LAMBDA), FitStats::default());
        assert_eq!(fit(&pts, &mut v, &f, 0, LAMBDA), FitStats::default());
        assert_eq!(v, v0);
        // Out-of-range and repeated indices, NaN points and vertices: no
        // panic, and the vertices of broken faces stay.
        let mut bad = f.clone();
        bad.push([0, 1, 99]);
        bad.push([5, 5, 6]);
        let mut pts = pts.clone();
        pts.push([f32::NAN, 0.0, 0.0]);
        pts.push([f32::INFINITY; 3]);
        let mut v = v0.clone();
        fit(&pts, &mut v, &bad, 3, LAMBDA);
        assert_eq!((v[5], v[6]), (v0[5], v0[6]));
        let mut v = v0.clone();
        v[5] = [f32::NAN; 3];
        fit(&pts, &mut v, &f, 3, LAMBDA);
        assert!(v[5][0].is_nan());
        assert!(v.iter().enumerate().all(|(i, x)| i == 5 || is_finite3(*x)));
        assert_eq!(v[6], v0[6], "a vertex beside the NaN one moved");
    }
}
