//! Small dense linear algebra: 3-vectors and the symmetric 3x3 eigenproblem
//! (cyclic Jacobi, f64). Everything here is branch-light, allocation-free and
//! deterministic: the same inputs give bit-identical outputs on every target.

#![allow(missing_docs)]
pub type V3 = [f32; 3];

#[inline]
pub fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[inline]
pub fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
pub fn dot(a: V3, b: V3) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
pub fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// A vector perpendicular to `n` (not normalised): `n` crossed with the x axis,
/// or with the y axis when `n` is close to x. Non-zero for any non-zero `n`.
#[inline]
pub fn perpendicular(n: V3) -> V3 {
    let axis = if n[0].abs() < 0.6 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    cross(n, axis)
}

/// The point of triangle `(a, b, c)` nearest to `p`, and its barycentric
/// coordinates `[u, v, w]` (`q = u a + v b + w c`), by the Voronoi regions of
/// the vertices, edges and face. A degenerate triangle (zero area) gives its
/// nearest vertex.
pub fn closest_on_triangle(p: V3, a: V3, b: V3, c: V3) -> (V3, [f32; 3]) {
    closest_in_line(p, a, b, c)
}

/// [`closest_on_triangle`], always inlined: where only the distance is
/// wanted ([`point_triangle_dist2`], in the nearest-face queries and the
/// facets' scores, 650 thousand calls a bunny run) the coordinates are then
/// never computed, nor the point passed back through memory (callgrind: 35
/// M fewer instructions a one-thread bunny run, 1.4 %).
#[inline(always)]
fn closest_in_line(p: V3, a: V3, b: V3, c: V3) -> (V3, [f32; 3]) {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        let q = [a[0] + v * ab[0], a[1] + v * ab[1], a[2] + v * ab[2]];
        return (q, [1.0 - v, v, 0.0]);
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        let q = [a[0] + w * ac[0], a[1] + w * ac[1], a[2] + w * ac[2]];
        return (q, [1.0 - w, 0.0, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        let bc = sub(c, b);
        let q = [b[0] + w * bc[0], b[1] + w * bc[1], b[2] + w * bc[2]];
        return (q, [0.0, 1.0 - w, w]);
    }
    let denom = va + vb + vc;
    if denom == 0.0 || !denom.is_finite() {
        // Degenerate triangle: the nearest vertex.
        let (da, db, dc) = (dot(ap, ap), dot(bp, bp), dot(cp, cp));
        return if da <= db && da <= dc {
            (a, [1.0, 0.0, 0.0])
        } else if db <= dc {
            (b, [0.0, 1.0, 0.0])
        } else {
            (c, [0.0, 0.0, 1.0])
        };
    }
    let v = vb / denom;
    let w = vc / denom;
    let q = [
        a[0] + ab[0] * v + ac[0] * w,
        a[1] + ab[1] * v + ac[1] * w,
        a[2] + ab[2] * v + ac[2] * w,
    ];
    (q, [1.0 - v - w, v, w])
}

/// Squared distance from `p` to triangle `(a, b, c)` (see
/// [`closest_on_triangle`]).
#[inline(always)]
pub fn point_triangle_dist2(p: V3, a: V3, b: V3, c: V3) -> f32 {
    let (q, _) = closest_in_line(p, a, b, c);
    let d = sub(p, q);
    dot(d, d)
}

/// Squared distance, computed the same way everywhere so that ties compare exactly.
#[inline]
pub fn dist2(a: V3, b: V3) -> f32 {
    let d = sub(a, b);
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}

#[inline]
pub fn norm(a: V3) -> f32 {
    libm::sqrtf(dot(a, a))
}

#[inline]
pub fn is_finite3(a: V3) -> bool {
    a[0].is_finite() && a[1].is_finite() && a[2].is_finite()
}

pub type D3 = [f64; 3];

#[inline]
pub fn to_d3(a: V3) -> D3 {
    [a[0] as f64, a[1] as f64, a[2] as f64]
}

#[inline]
pub fn sub_d(a: D3, b: D3) -> D3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
pub fn cross_d(a: D3, b: D3) -> D3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[inline]
pub fn dot_d(a: D3, b: D3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// How many eigen-solves the stages that make many take at once
/// ([`Sym3::eigen_lanes`]): four where a processor runs ahead out of order
/// and overlaps them; one on a bare-metal target (a microcontroller: in
/// order, `f64` in software), where the lanes would only cost code (14 KB
/// of the Cortex-M4F firmware's flash). Each solve is the same either way.
pub const SOLVE_LANES: usize = if cfg!(target_os = "none") { 1 } else { 4 };

/// Symmetric 3x3 matrix stored as its upper triangle: xx xy xz yy yz zz.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sym3(pub [f64; 6]);

/// One Jacobi rotation of [`Sym3::eigen`] in the `(P, Q)` plane: `a <- Jᵀ a J`
/// and `v <- v J`, zeroing `a[P][Q]` (nothing when it is 0 already).
#[inline(always)]
fn rotate<const P: usize, const Q: usize>(a: &mut [D3; 3], v: &mut [D3; 3]) {
    if a[P][Q] == 0.0 {
        return;
    }
    let theta = (a[Q][Q] - a[P][P]) / (2.0 * a[P][Q]);
    let t = theta.signum() / (theta.abs() + libm::sqrt(theta * theta + 1.0));
    let t = if theta == 0.0 { 1.0 } else { t };
    let c = 1.0 / libm::sqrt(t * t + 1.0);
    let s = t * c;
    for row in a.iter_mut() {
        let (ap, aq) = (row[P], row[Q]);
        row[P] = c * ap - s * aq;
        row[Q] = s * ap + c * aq;
    }
    let (rp, rq) = (a[P], a[Q]);
    for k in 0..3 {
        a[P][k] = c * rp[k] - s * rq[k];
        a[Q][k] = s * rp[k] + c * rq[k];
    }
    for row in v.iter_mut() {
        let (vp, vq) = (row[P], row[Q]);
        row[P] = c * vp - s * vq;
        row[Q] = s * vp + c * vq;
    }
}

/// [`rotate`] in the `(P, Q)` plane of every matrix of `a` (vectors `v`)
/// still `live`, one after another.
#[inline(always)]
fn rotate_live<const P: usize, const Q: usize, const L: usize>(
    a: &mut [[D3; 3]; L],
    v: &mut [[D3; 3]; L],
    live: &[bool; L],
) {
    for ((a, v), &live) in a.iter_mut().zip(v.iter_mut()).zip(live) {
        if live {
            rotate::<P, Q>(a, v);
        }
    }
}

impl Sym3 {
    #[inline]
    pub fn full(&self) -> [[f64; 3]; 3] {
        let s = &self.0;
        [[s[0], s[1], s[2]], [s[1], s[3], s[4]], [s[2], s[4], s[5]]]
    }

    #[inline]
    pub fn mul(&self, v: D3) -> D3 {
        let m = self.full();
        [dot_d(m[0], v), dot_d(m[1], v), dot_d(m[2], v)]
    }

    /// Eigenvalues ascending with unit eigenvectors (`vectors[i]` belongs to
    /// `values[i]`), by cyclic Jacobi rotations. Converges quadratically; a fixed cap
    /// of sweeps keeps the cost bounded for any input, including NaN.
    pub fn eigen(&self) -> ([f64; 3], [D3; 3]) {
        let [one] = Sym3::eigen_lanes(&[*self]);
        one
    }

    /// [`Sym3::eigen`] of `L` matrices at once, each bit for bit what it gives
    /// alone: each matrix takes the same rotations in the same order and stops
    /// at the same sweep. A rotation is a chain of two divisions and two
    /// square roots (about a hundred cycles of latency, a few of work), so
    /// one matrix's rotations leave the processor idle; the matrices' are
    /// independent, and taken in turn, plane by plane, they overlap.
    #[inline]
    pub fn eigen_lanes<const L: usize>(ms: &[Sym3; L]) -> [([f64; 3], [D3; 3]); L] {
        let mut a: [[D3; 3]; L] = core::array::from_fn(|l| ms[l].full());
        let mut v = [[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]; L];
        let mut live = [true; L];
        for _sweep in 0..32 {
            let mut any = false;
            for (a, live) in a.iter().zip(live.iter_mut()) {
                let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
                let diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
                if off <= 1e-30 * diag || off == 0.0 || off.is_nan() {
                    *live = false;
                }
                any |= *live;
            }
            if !any {
                break;
            }
            // The three planes in turn, each rotation's indices constants.
            rotate_live::<0, 1, L>(&mut a, &mut v, &live);
            rotate_live::<0, 2, L>(&mut a, &mut v, &live);
            rotate_live::<1, 2, L>(&mut a, &mut v, &live);
        }
        core::array::from_fn(|l| {
            let (a, v) = (&a[l], &v[l]);
            let vals = [a[0][0], a[1][1], a[2][2]];
            let col = |i: usize| [v[0][i], v[1][i], v[2][i]];
            let mut idx = [0usize, 1, 2];
            // Sort ascending; NaN (never produced from finite input) sorts last.
            idx.sort_unstable_by(|&i, &j| vals[i].total_cmp(&vals[j]));
            (
                [vals[idx[0]], vals[idx[1]], vals[idx[2]]],
                [col(idx[0]), col(idx[1]), col(idx[2])],
            )
        })
    }

    /// Solve `self * x = b` through the eigen-decomposition, treating eigenvalues
    /// below `rel * max|eigenvalue|` as zero (least-norm solution in those directions).
    /// Returns the solution and the numerical rank.
    pub fn pseudo_solve(&self, b: D3, rel: f64) -> (D3, u32) {
        let [one] = Sym3::pseudo_solve_lanes(&[(*self, b)], rel);
        one
    }

    /// [`Sym3::pseudo_solve`] of `L` systems at once, each what it gives alone
    /// (their eigen-solves overlap, [`Sym3::eigen_lanes`]).
    #[inline]
    pub fn pseudo_solve_lanes<const L: usize>(
        systems: &[(Sym3, D3); L],
        rel: f64,
    ) -> [(D3, u32); L] {
        let solved = Sym3::eigen_lanes(&systems.map(|(m, _)| m));
        core::array::from_fn(|l| {
            let ((vals, vecs), b) = (solved[l], systems[l].1);
            let max = vals.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let mut x = [0.0; 3];
            let mut rank = 0;
            if max > 0.0 && max.is_finite() {
                for i in 0..3 {
                    if vals[i].abs() > rel * max {
                        rank += 1;
                        let w = dot_d(vecs[i], b) / vals[i];
                        for (xk, vk) in x.iter_mut().zip(vecs[i]) {
                            *xk += w * vk;
                        }
                    }
                }
            }
            (x, rank)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn jacobi_reconstructs_random_symmetric_matrices() {
        let mut rng = Rng::new(1);
        for _ in 0..1000 {
            let s = Sym3(core::array::from_fn(|_| rng.unit_f64() * 2.0 - 1.0));
            let (vals, vecs) = s.eigen();
            assert!(vals[0] <= vals[1] && vals[1] <= vals[2]);
            for i in 0..3 {
                let av = s.mul(vecs[i]);
                for k in 0..3 {
                    assert!((av[k] - vals[i] * vecs[i][k]).abs() < 1e-12, "{s:?}");
                }
                assert!((dot_d(vecs[i], vecs[i]) - 1.0).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn eigen_lanes_give_each_matrix_what_it_gives_alone() {
        let mut rng = Rng::new(5);
        let mut random =
            |scale: f64| Sym3(core::array::from_fn(|_| (rng.unit_f64() - 0.5) * scale));
        // Matrices that stop at different sweeps: diagonal ones at once, zero,
        // NaN at the cap's first check, nearly diagonal ones after a sweep or
        // two, random ones later; rank one and repeated eigenvalues.
        let mut ms = std::vec![
            Sym3([1.0, 0.0, 0.0, 2.0, 0.0, 3.0]),
            Sym3::default(),
            Sym3([f64::NAN, 1.0, 0.0, 1.0, 0.0, 1.0]),
            Sym3([1.0, 1e-9, 0.0, 2.0, 1e-12, 3.0]),
            Sym3([1.0, 1.0, 1.0, 1.0, 1.0, 1.0]),
            Sym3([2.0, 0.0, 0.0, 2.0, 0.0, 5.0]),
            Sym3([1e300, 1e-300, 3.0, 1e-10, 0.0, -1e300]),
        ];
        for _ in 0..400 {
            ms.push(random(2.0));
            ms.push(random(1e-6));
        }
        let bits = |(vals, vecs): ([f64; 3], [D3; 3])| {
            let mut b = std::vec::Vec::new();
            b.extend(vals.map(f64::to_bits));
            b.extend(vecs.iter().flatten().map(|x| x.to_bits()));
            b
        };
        // Alone: the sweeps of one matrix, as `eigen` took them before it
        // took lanes.
        let one = |m: &Sym3| {
            let mut a = m.full();
            let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
            for _sweep in 0..32 {
                let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
                let diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
                if off <= 1e-30 * diag || off == 0.0 || off.is_nan() {
                    break;
                }
                rotate::<0, 1>(&mut a, &mut v);
                rotate::<0, 2>(&mut a, &mut v);
                rotate::<1, 2>(&mut a, &mut v);
            }
            let vals = [a[0][0], a[1][1], a[2][2]];
            let mut idx = [0usize, 1, 2];
            idx.sort_unstable_by(|&i, &j| vals[i].total_cmp(&vals[j]));
            (
                idx.map(|i| vals[i]),
                idx.map(|i| [v[0][i], v[1][i], v[2][i]]),
            )
        };
        let alone: std::vec::Vec<_> = ms.iter().map(one).collect();
        for (m, &want) in ms.iter().zip(&alone) {
            assert_eq!(bits(m.eigen()), bits(want), "{m:?}");
        }
        for start in 0..ms.len() - 4 {
            let four = [ms[start], ms[start + 1], ms[start + 2], ms[start + 3]];
            for (l, got) in Sym3::eigen_lanes(&four).into_iter().enumerate() {
                assert_eq!(bits(got), bits(alone[start + l]), "matrix {}", start + l);
            }
        }
    }

    #[test]
    fn pseudo_solve_drops_null_directions() {
        // Rank 2: diag(2, 4, 0). b has a component in the null direction.
        let s = Sym3([2.0, 0.0, 0.0, 4.0, 0.0, 0.0]);
        let (x, rank) = s.pseudo_solve([2.0, 4.0, 7.0], 1e-9);
        assert_eq!(rank, 2);
        assert!((x[0] - 1.0).abs() < 1e-12 && (x[1] - 1.0).abs() < 1e-12 && x[2] == 0.0);
    }

    #[test]
    fn degenerate_matrices_do_not_produce_nan() {
        let (vals, vecs) = Sym3::default().eigen();
        assert!(vals.iter().all(|v| *v == 0.0));
        assert!(vecs.iter().flatten().all(|v| v.is_finite()));
        let (x, rank) = Sym3::default().pseudo_solve([1.0, 1.0, 1.0], 1e-9);
        assert_eq!((x, rank), ([0.0; 3], 0));
    }
}
