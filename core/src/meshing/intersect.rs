//! Whether two faces of a mesh intersect, decided exactly: the test that a
//! valid solid has no two faces meeting anywhere but along a shared edge or at a
//! shared vertex.
//!
//! Two triangles meet outside what they share by index (nothing, a vertex, or
//! an edge: the set X) iff an edge of one meets the other outside X. Their
//! intersection is convex and holds X; if it holds a point outside X it has an
//! extreme point outside X, and every extreme point of the intersection of two
//! triangles lies on an edge of one of them. So the pair test is at most six
//! segment-triangle tests, each made of Shewchuk's adaptive `orient3d` (and
//! `orient2d` in a coordinate plane when the segment lies in the triangle's
//! plane): exact signs, no tolerance. A vertex with another index at the same
//! position is not shared: touching there is an intersection (a vertex split in
//! place). Coordinates are `f64`; `f32` input converts exactly.
//!
//! Cost: O(1) per pair, no memory.

use crate::math::{cross_d, dot_d, sub_d};
use robust::{orient2d, orient3d, Coord, Coord3D};

type P = [f64; 3];

/// Two faces on an edge whose half-planes about it are less than this many
/// degrees apart are folded onto each other.
pub const FOLD_DEGREES: f64 = 10.0;
/// `cos(FOLD_DEGREES)`.
const FOLD_COS: f64 = 0.984_807_753_012_208;

/// Whether the faces `(u, v, c1)` and `(v, u, c2)` on the edge `uv` lie almost
/// on top of each other: their half-planes about the edge less than
/// [`FOLD_DEGREES`] apart (so a face whose orientation alone is flipped does
/// not count). False when either face has no area.
pub fn folded(u: P, v: P, c1: P, c2: P) -> bool {
    let e = sub_d(v, u);
    let (n1, n2) = (cross_d(e, sub_d(c1, u)), cross_d(e, sub_d(c2, u)));
    let len = libm::sqrt(dot_d(n1, n1) * dot_d(n2, n2));
    len > 0.0 && dot_d(n1, n2) > FOLD_COS * len
}
type C = Coord<f64>;

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
    let n = cross_d(sub_d(t[1], t[0]), sub_d(t[2], t[0])).map(f64::abs);
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
    use crate::math::{cross_d as cross, dot_d as dot, sub_d as sub};

    #[test]
    fn fold_constant_is_the_cosine_of_its_angle() {
        assert!((libm::cos(FOLD_DEGREES.to_radians()) - FOLD_COS).abs() < 1e-15);
        let (u, v) = ([0.0; 3], [1.0, 0.0, 0.0]);
        let at = |deg: f64| {
            [
                0.5,
                libm::cos(deg.to_radians()),
                libm::sin(deg.to_radians()),
            ]
        };
        assert!(folded(u, v, at(0.0), at(9.0)));
        assert!(!folded(u, v, at(0.0), at(11.0)));
        assert!(!folded(u, v, at(0.0), at(180.0)));
    }
    use crate::rng::Rng;
    use std::vec::Vec;

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
}
