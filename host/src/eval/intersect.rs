//! Self-intersections: pairs of faces that meet anywhere other than where they share
//! vertices by index, decided exactly.
//!
//! Two triangles meet outside what they share (nothing, a vertex, or an edge: the set
//! X) iff an edge of one meets the other outside X. Their intersection is convex and
//! holds X; if it holds a point outside X it has an extreme point outside X, and every
//! extreme point of the intersection of two triangles lies on an edge of one of them.
//! So the pair test is at most six segment-triangle tests, each made of Shewchuk's
//! adaptive `orient3d` (and `orient2d` in a coordinate plane when the segment lies in
//! the triangle's plane): exact signs, no tolerance. A vertex with another index at
//! the same position is not shared: touching there is an intersection (a vertex split
//! in place).
//!
//! Candidate pairs come from a uniform grid over the faces' bounding boxes with cells
//! about one face wide ([`Grid::overlapping_pairs`]): O(F · k) for F faces and k
//! faces whose boxes overlap a face's box, a dozen or two on a mesh.

use super::grid::{bounds, Grid};
use super::zero_area;
use crate::geom::{cross, sub};
use robust::{orient2d, orient3d, Coord, Coord3D};

type P = [f64; 3];
type C = Coord<f64>;

/// Cells per face at most in the candidate grid (4 bytes each).
const CELLS_PER_FACE: f64 = 16.0;

/// The number of pairs of `faces` (indices all `< vertices.len()`) that intersect
/// ([`faces_intersect`]). Faces with a repeated index, a non-finite coordinate or zero
/// area (counted as degenerate by the topology) are left out.
pub fn self_intersecting_pairs(vertices: &[P], faces: &[[u32; 3]]) -> usize {
    let mut n = 0;
    for_each_intersecting_pair(vertices, faces, |_, _| n += 1);
    n
}

/// Calls `f(i, j)`, `i < j` indices into `faces`, once for every intersecting pair,
/// as [`self_intersecting_pairs`] counts them.
fn for_each_intersecting_pair(vertices: &[P], faces: &[[u32; 3]], mut f: impl FnMut(u32, u32)) {
    let tested: Vec<u32> = (0..faces.len() as u32)
        .filter(|&i| {
            let g = faces[i as usize];
            let t = g.map(|v| vertices[v as usize]);
            g[0] != g[1]
                && g[1] != g[2]
                && g[0] != g[2]
                && t.iter().flatten().all(|c| c.is_finite())
                && !zero_area(&t)
        })
        .collect();
    if tested.len() < 2 {
        return;
    }
    let tris: Vec<[P; 3]> = tested
        .iter()
        .map(|&i| faces[i as usize].map(|v| vertices[v as usize]))
        .collect();
    let boxes: Vec<(P, P)> = tris.iter().map(|t| bounds(t.iter().copied())).collect();
    let grid = Grid::build(&boxes, face_sized_cells(&boxes));
    grid.overlapping_pairs(&boxes, |a, b| {
        let (a, b) = (a as usize, b as usize);
        let (i, j) = (tested[a], tested[b]);
        if faces_intersect(faces[i as usize], &tris[a], faces[j as usize], &tris[b]) {
            f(i, j);
        }
    });
}

/// A cell count whose cells are about as wide as the average box, at most
/// [`CELLS_PER_FACE`] per box.
fn face_sized_cells(boxes: &[(P, P)]) -> f64 {
    let n = boxes.len() as f64;
    let width = boxes
        .iter()
        .map(|(lo, hi)| (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max))
        .sum::<f64>()
        / n;
    let lo = bounds(boxes.iter().map(|b| b.0)).0;
    let hi = bounds(boxes.iter().map(|b| b.1)).1;
    let cells: f64 = if width > 0.0 {
        (0..3).map(|a| ((hi[a] - lo[a]) / width).max(1.0)).product()
    } else {
        n
    };
    cells.min(CELLS_PER_FACE * n)
}

/// Whether faces `f` and `g` (vertex indices, each three distinct; `p` and `q` their
/// positions, neither of zero area) meet anywhere other than at the vertices and the
/// edge they share by index. Faces with the same three indices are duplicates, not
/// tested here: `false`.
pub fn faces_intersect(f: [u32; 3], p: &[P; 3], g: [u32; 3], q: &[P; 3]) -> bool {
    let f_in_g = f.map(|v| g.contains(&v));
    let g_in_f = g.map(|v| f.contains(&v));
    if f_in_g.iter().all(|&s| s) {
        return false;
    }
    if one_side(p, q, g_in_f) || one_side(q, p, f_in_g) {
        return false;
    }
    edge_meets(f, p, f_in_g, g, q) || edge_meets(g, q, g_in_f, f, p)
}

/// Whether the vertices of `q` not `shared` lie strictly on one side of `p`'s plane.
fn one_side(p: &[P; 3], q: &[P; 3], shared: [bool; 3]) -> bool {
    let mut signs = (0..3)
        .filter(|&i| !shared[i])
        .map(|i| orient3(p[0], p[1], p[2], q[i]));
    let first = signs.next().unwrap_or(0);
    first != 0 && signs.all(|s| s == first)
}

/// Whether an edge of face `f` (positions `p`; `shared[i]`: `f[i]` is a vertex of `g`)
/// meets face `g` (positions `q`) outside the vertices and edge they share.
fn edge_meets(f: [u32; 3], p: &[P; 3], shared: [bool; 3], g: [u32; 3], q: &[P; 3]) -> bool {
    (0..3).any(|i| {
        let j = (i + 1) % 3;
        match (shared[i], shared[j]) {
            // The shared edge itself.
            (true, true) => false,
            (false, false) => segment_meets_triangle(p[i], p[j], q),
            (true, false) => enters_at_corner(&corner_first(g, q, f[i]), p[j]),
            (false, true) => enters_at_corner(&corner_first(g, q, f[j]), p[i]),
        }
    })
}

/// The positions `q` of face `g` rotated so that vertex `v` comes first.
fn corner_first(g: [u32; 3], q: &[P; 3], v: u32) -> [P; 3] {
    let k = g.iter().position(|&x| x == v).unwrap_or(0);
    [q[k], q[(k + 1) % 3], q[(k + 2) % 3]]
}

/// Whether the closed segment `uv` meets the closed triangle `t`.
fn segment_meets_triangle(u: P, v: P, t: &[P; 3]) -> bool {
    let (su, sv) = (orient3(t[0], t[1], t[2], u), orient3(t[0], t[1], t[2], v));
    if su * sv > 0 {
        return false;
    }
    if su == 0 && sv == 0 {
        let k = drop_axis(t);
        let (a, b) = (project(u, k), project(v, k));
        let t = t.map(|p| project(p, k));
        return in_triangle2(a, t)
            || in_triangle2(b, t)
            || (0..3).any(|i| segments_meet2(a, b, t[i], t[(i + 1) % 3]));
    }
    // The line crosses the plane within the segment: inside the triangle iff it passes
    // no edge on the other side from the rest.
    let s = [
        orient3(u, v, t[0], t[1]),
        orient3(u, v, t[1], t[2]),
        orient3(u, v, t[2], t[0]),
    ];
    !(s.contains(&1) && s.contains(&-1))
}

/// Whether the segment from `t[0]` to `v` holds a point of triangle `t` other than
/// `t[0]`: `v` in `t`'s plane, inside the closed angle of `t` at `t[0]`.
fn enters_at_corner(t: &[P; 3], v: P) -> bool {
    if orient3(t[0], t[1], t[2], v) != 0 {
        return false;
    }
    let k = drop_axis(t);
    let [a, d, e] = t.map(|p| project(p, k));
    let w = project(v, k);
    let o = orient2(a, d, e);
    orient2(a, d, w) * o >= 0 && orient2(a, w, e) * o >= 0
}

// ---------------------------------------------------------------------------------
// Exact signs

fn sign(v: f64) -> i8 {
    i8::from(v > 0.0) - i8::from(v < 0.0)
}

/// The sign of the orientation of `d` against the plane through `a`, `b`, `c`: zero iff
/// the four are coplanar.
fn orient3(a: P, b: P, c: P, d: P) -> i8 {
    let q = |p: P| Coord3D {
        x: p[0],
        y: p[1],
        z: p[2],
    };
    sign(orient3d(q(a), q(b), q(c), q(d)))
}

fn orient2(a: C, b: C, c: C) -> i8 {
    sign(orient2d(a, b, c))
}

/// The axis of the largest component of `t`'s normal. Dropping it maps `t`'s plane
/// one to one onto a coordinate plane (the component is far from zero on a face of
/// non-zero area), so orientations of points of that plane keep one common sign.
fn drop_axis(t: &[P; 3]) -> usize {
    let n = cross(sub(t[1], t[0]), sub(t[2], t[0])).map(f64::abs);
    if n[0] >= n[1] && n[0] >= n[2] {
        0
    } else if n[1] >= n[2] {
        1
    } else {
        2
    }
}

/// `p` without coordinate `axis` (exact).
fn project(p: P, axis: usize) -> C {
    Coord {
        x: p[(axis + 1) % 3],
        y: p[(axis + 2) % 3],
    }
}

/// Whether `p` lies in the closed triangle `t` (not degenerate).
fn in_triangle2(p: C, t: [C; 3]) -> bool {
    let s = [
        orient2(t[0], t[1], p),
        orient2(t[1], t[2], p),
        orient2(t[2], t[0], p),
    ];
    !(s.contains(&1) && s.contains(&-1))
}

/// Whether the closed segments `ab` and `cd` meet.
fn segments_meet2(a: C, b: C, c: C, d: C) -> bool {
    let (d1, d2) = (orient2(a, b, c), orient2(a, b, d));
    let (d3, d4) = (orient2(c, d, a), orient2(c, d, b));
    if d1 * d2 < 0 && d3 * d4 < 0 {
        return true;
    }
    (d1 == 0 && within(c, a, b))
        || (d2 == 0 && within(d, a, b))
        || (d3 == 0 && within(a, c, d))
        || (d4 == 0 && within(b, c, d))
}

/// Whether `p`, collinear with `a` and `b`, lies between them.
fn within(p: C, a: C, b: C) -> bool {
    a.x.min(b.x) <= p.x && p.x <= a.x.max(b.x) && a.y.min(b.y) <= p.y && p.y <= a.y.max(b.y)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::dot;
    use vsaqem_core::rng::Rng;

    const A: [u32; 3] = [0, 1, 2];
    const B: [u32; 3] = [3, 4, 5];

    fn unit() -> [P; 3] {
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    }

    #[test]
    fn piercing_and_separate_triangles() {
        let pierce = [[0.2, 0.2, -1.0], [0.2, 0.2, 1.0], [5.0, 5.0, 0.0]];
        assert!(faces_intersect(A, &unit(), B, &pierce));
        let above = [[0.2, 0.2, 1e-300], [0.3, 0.2, 1.0], [0.2, 0.3, 1.0]];
        assert!(!faces_intersect(A, &unit(), B, &above));
        // A vertex of one resting on the other's interior, or on its edge.
        let resting = [[0.2, 0.2, 0.0], [0.3, 0.2, 1.0], [0.2, 0.3, 1.0]];
        assert!(faces_intersect(A, &unit(), B, &resting));
        let on_edge = [[0.5, 0.5, 0.0], [0.9, 0.9, 1.0], [0.9, 0.8, 1.0]];
        assert!(faces_intersect(A, &unit(), B, &on_edge));
        let beyond_edge = [[0.5, 0.5 + 1e-15, 0.0], [0.9, 0.9, 1.0], [0.9, 0.8, 1.0]];
        assert!(!faces_intersect(A, &unit(), B, &beyond_edge));
    }

    #[test]
    fn coplanar_triangles_intersect_when_they_overlap_or_touch() {
        let overlap = [[0.5, 0.5, 0.0], [-1.0, 0.2, 0.0], [0.2, -1.0, 0.0]];
        assert!(faces_intersect(A, &unit(), B, &overlap));
        let inside = [[0.1, 0.1, 0.0], [0.2, 0.1, 0.0], [0.1, 0.2, 0.0]];
        assert!(faces_intersect(A, &unit(), B, &inside));
        assert!(faces_intersect(B, &inside, A, &unit()));
        let apart = [[1.0, 1.0, 0.0], [2.0, 1.0, 0.0], [1.0, 2.0, 0.0]];
        assert!(!faces_intersect(A, &unit(), B, &apart));
        let touching = [[0.5, 0.5, 0.0], [2.0, 1.0, 0.0], [1.0, 2.0, 0.0]];
        assert!(faces_intersect(A, &unit(), B, &touching));
    }

    #[test]
    fn faces_sharing_an_edge_meet_only_when_folded_onto_each_other() {
        let p = unit();
        // Shares vertices 1 and 2 (the hypotenuse).
        let g = [2, 1, 3];
        let flat = [p[2], p[1], [1.0, 1.0, 0.0]];
        assert!(!faces_intersect(A, &p, g, &flat));
        let bent = [p[2], p[1], [1.0, 1.0, 0.7]];
        assert!(!faces_intersect(A, &p, g, &bent));
        let folded = [p[2], p[1], [0.2, 0.2, 0.0]];
        assert!(faces_intersect(A, &p, g, &folded));
        assert!(faces_intersect(g, &folded, A, &p));
        // The same geometry without sharing by index: the edges touch.
        assert!(faces_intersect(A, &p, B, &flat));
        // Duplicates are not tested here.
        assert!(!faces_intersect(A, &p, [2, 0, 1], &[p[2], p[0], p[1]]));
    }

    #[test]
    fn faces_sharing_a_vertex_meet_only_beyond_it() {
        let p = unit();
        let g = [0, 3, 4];
        let fan = [p[0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]];
        assert!(!faces_intersect(A, &p, g, &fan));
        let up = [p[0], [0.0, 0.0, 1.0], [-1.0, 0.0, 1.0]];
        assert!(!faces_intersect(A, &p, g, &up));
        // An edge from the shared vertex runs along the other face.
        let along = [p[0], [0.3, 0.3, 0.0], [0.0, 0.0, 1.0]];
        assert!(faces_intersect(A, &p, g, &along));
        // Along the other face's edge, in the opposite direction: only the vertex.
        let back = [p[0], [-0.3, 0.0, 0.0], [0.0, 0.0, 1.0]];
        assert!(!faces_intersect(A, &p, g, &back));
        // Crossing through the other face away from the shared vertex.
        let through = [p[0], [0.4, 0.4, -1.0], [0.4, 0.4, 1.0]];
        assert!(faces_intersect(A, &p, g, &through));
        // The vertex split in place: same position, other index.
        assert!(faces_intersect(A, &p, [6, 3, 4], &fan));
    }

    /// The intersection by intervals on the planes' common line in floating point,
    /// for triangles in general position; `None` when too close to call.
    fn float_intersect(p: &[P; 3], q: &[P; 3]) -> Option<bool> {
        let normal = |t: &[P; 3]| cross(sub(t[1], t[0]), sub(t[2], t[0]));
        let (np, nq) = (normal(p), normal(q));
        let dp = p.map(|x| dot(nq, sub(x, q[0])));
        let dq = q.map(|x| dot(np, sub(x, p[0])));
        let eps = 1e-9;
        if dp.iter().chain(&dq).any(|d| d.abs() < eps) {
            return None;
        }
        if dp.iter().all(|&d| d > 0.0) || dp.iter().all(|&d| d < 0.0) {
            return Some(false);
        }
        if dq.iter().all(|&d| d > 0.0) || dq.iter().all(|&d| d < 0.0) {
            return Some(false);
        }
        let dir = cross(np, nq);
        let span = |t: &[P; 3], d: [f64; 3]| {
            let mut s = Vec::new();
            for i in 0..3 {
                let j = (i + 1) % 3;
                if (d[i] > 0.0) != (d[j] > 0.0) {
                    let w = d[i] / (d[i] - d[j]);
                    let x = [0, 1, 2].map(|a| t[i][a] + w * (t[j][a] - t[i][a]));
                    s.push(dot(dir, x));
                }
            }
            (s[0].min(s[1]), s[0].max(s[1]))
        };
        let (a, b) = (span(p, dp), span(q, dq));
        let gap = a.0.max(b.0) - a.1.min(b.1);
        (gap.abs() > eps).then_some(gap < 0.0)
    }

    fn random_tri(r: &mut Rng, scale: f64) -> [P; 3] {
        let c = [0; 3].map(|_| r.unit_f64());
        [0; 3].map(|_| [0, 1, 2].map(|a| c[a] + (r.unit_f64() - 0.5) * scale))
    }

    #[test]
    fn exact_test_agrees_with_intervals_in_general_position() {
        let mut r = Rng::from_state(17);
        let (mut decided, mut hits) = (0, 0);
        for _ in 0..20_000 {
            let (p, q) = (random_tri(&mut r, 0.8), random_tri(&mut r, 0.8));
            if let Some(want) = float_intersect(&p, &q) {
                assert_eq!(faces_intersect(A, &p, B, &q), want, "{p:?} {q:?}");
                decided += 1;
                hits += usize::from(want);
            }
        }
        assert!(decided > 19_000 && hits > 500, "{decided} {hits}");
    }

    /// Faces over a few lattice vertices: many shared vertices and edges, coplanar
    /// and touching pairs, vertices split in place (two indices per position).
    fn lattice_soup(faces: usize, seed: u64) -> (Vec<P>, Vec<[u32; 3]>) {
        let mut r = Rng::from_state(seed);
        let mut v: Vec<P> = (0..27)
            .map(|i| [(i % 3) as f64, (i / 3 % 3) as f64, (i / 9) as f64])
            .collect();
        v.extend_from_within(..9);
        let mut f = Vec::new();
        while f.len() < faces {
            let t = [0; 3].map(|_| (r.unit_f64() * v.len() as f64) as u32);
            let p = t.map(|i| v[i as usize]);
            if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] && !zero_area(&p) {
                f.push(t);
            }
        }
        (v, f)
    }

    #[test]
    fn pair_test_ignores_vertex_order_and_argument_order() {
        let (v, f) = lattice_soup(300, 5);
        let pos = |t: [u32; 3]| t.map(|i| v[i as usize]);
        let mut hits = 0;
        for (i, &a) in f.iter().enumerate() {
            for &b in &f[i + 1..] {
                let want = faces_intersect(a, &pos(a), b, &pos(b));
                hits += usize::from(want);
                let (ra, rb) = ([a[1], a[2], a[0]], [b[2], b[1], b[0]]);
                assert_eq!(faces_intersect(b, &pos(b), a, &pos(a)), want);
                assert_eq!(faces_intersect(ra, &pos(ra), rb, &pos(rb)), want);
            }
        }
        assert!(hits > 1000, "{hits}");
    }

    #[test]
    fn grid_candidates_find_every_pair_brute_force_finds() {
        for (v, f) in [
            lattice_soup(400, 9),
            // Small scattered triangles and long slivers.
            {
                let mut r = Rng::from_state(23);
                let mut v = Vec::new();
                let mut f = Vec::new();
                for k in 0..600u32 {
                    let t = random_tri(&mut r, if k % 10 == 0 { 1.0 } else { 0.1 });
                    v.extend_from_slice(&t);
                    f.push([3 * k, 3 * k + 1, 3 * k + 2]);
                }
                (v, f)
            },
        ] {
            let pos = |t: [u32; 3]| t.map(|i| v[i as usize]);
            let mut want = Vec::new();
            for i in 0..f.len() {
                for j in i + 1..f.len() {
                    if faces_intersect(f[i], &pos(f[i]), f[j], &pos(f[j])) {
                        want.push((i as u32, j as u32));
                    }
                }
            }
            let mut got = Vec::new();
            for_each_intersecting_pair(&v, &f, |i, j| got.push((i, j)));
            got.sort_unstable();
            assert!(want.len() > 50, "{}", want.len());
            assert_eq!(got, want);
            assert_eq!(self_intersecting_pairs(&v, &f), want.len());
        }
    }

    #[test]
    fn degenerate_and_non_finite_faces_are_left_out() {
        let v = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.0, 0.0],
            [f64::NAN, 0.0, 0.0],
            [0.2, 0.2, 0.0],
        ];
        let f = [[0, 1, 2], [0, 3, 1], [0, 4, 5], [5, 5, 1]];
        assert_eq!(self_intersecting_pairs(&v, &f), 0);
    }
}
