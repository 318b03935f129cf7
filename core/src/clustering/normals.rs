//! Unit normals: the caller's when usable, otherwise PCA of the neighbourhood.
//!
//! PCA: the eigenvector of the smallest eigenvalue of the covariance of the point
//! and its k neighbours, computed in `f64` around their centroid (O(k) per point,
//! no memory). Orientation is irrelevant downstream (plane quadrics use `n nᵀ`), so
//! none is computed.

use crate::clustering::knn::Neighbours;
use crate::math::{to_d3, Sym3, V3};

/// A usable given normal: finite and not (near) zero. Returned unit length.
pub fn usable(n: V3) -> Option<V3> {
    let len2 = n[0] as f64 * n[0] as f64 + n[1] as f64 * n[1] as f64 + n[2] as f64 * n[2] as f64;
    if !(len2.is_finite() && len2 > 1e-12) {
        return None;
    }
    let inv = 1.0 / libm::sqrt(len2);
    Some([
        (n[0] as f64 * inv) as f32,
        (n[1] as f64 * inv) as f32,
        (n[2] as f64 * inv) as f32,
    ])
}

/// PCA normal of point `i` over itself and its k nearest neighbours. A degenerate
/// neighbourhood (all points equal) yields an arbitrary but deterministic unit
/// vector; its weight is zero anyway (see `quadric`).
pub fn pca(points: &[V3], nb: &Neighbours, i: usize) -> V3 {
    pca_with_variation(points, nb, i).0
}

/// PCA normal and *surface variation* `λ0 / (λ0 + λ1 + λ2)` of the neighbourhood
/// covariance: 0 on a plane, small on a smooth surface, up to 1/3 where the
/// neighbourhood straddles a sharp feature or is pure noise.
pub fn pca_with_variation(points: &[V3], nb: &Neighbours, i: usize) -> (V3, f32) {
    let (_, vals, vecs) = neighbourhood_pca(points, i, nb.of(i));
    with_variation(vals, vecs)
}

/// The normal (the least eigenvalue's vector) and the surface variation of
/// an eigen-decomposition.
fn with_variation(vals: [f64; 3], vecs: [[f64; 3]; 3]) -> (V3, f32) {
    let v = vecs[0];
    let total = vals[0].max(0.0) + vals[1].max(0.0) + vals[2].max(0.0);
    let variation = if total > 0.0 {
        (vals[0].max(0.0) / total) as f32
    } else {
        0.0
    };
    ([v[0] as f32, v[1] as f32, v[2] as f32], variation)
}

/// Centroid, eigenvalues (ascending) and eigenvectors of the covariance of point
/// `i` and the points `row` indexes, in `f64`. Indices out of range are skipped.
pub fn neighbourhood_pca(
    points: &[V3],
    i: usize,
    row: &[u32],
) -> ([f64; 3], [f64; 3], [[f64; 3]; 3]) {
    let (c, s) = covariance(points, i, row);
    let (vals, vecs) = s.eigen();
    (c, vals, vecs)
}

/// Centroid and covariance (unnormalised) of point `i` and the points `row`
/// indexes, in `f64`. Indices out of range are skipped.
fn covariance(points: &[V3], i: usize, row: &[u32]) -> ([f64; 3], Sym3) {
    // The point, then its neighbours, to `f`: two loops, not one chained
    // iterator (the same terms in the same order, fewer instructions).
    fn around(points: &[V3], i: usize, row: &[u32], mut f: impl FnMut(&V3)) {
        points.get(i).into_iter().for_each(&mut f);
        row.iter()
            .filter_map(|&j| points.get(j as usize))
            .for_each(f);
    }
    let mut c = [0.0f64; 3];
    let mut m = 0.0f64;
    let mut add = |q: &V3| {
        let q = to_d3(*q);
        for a in 0..3 {
            c[a] += q[a];
        }
        m += 1.0;
    };
    around(points, i, row, &mut add);
    if m > 0.0 {
        for v in c.iter_mut() {
            *v /= m;
        }
    }
    let mut s = [0.0f64; 6];
    let mut spread = |q: &V3| {
        let q = to_d3(*q);
        let d = [q[0] - c[0], q[1] - c[1], q[2] - c[2]];
        s[0] += d[0] * d[0];
        s[1] += d[0] * d[1];
        s[2] += d[0] * d[2];
        s[3] += d[1] * d[1];
        s[4] += d[1] * d[2];
        s[5] += d[2] * d[2];
    };
    around(points, i, row, &mut spread);
    (c, Sym3(s))
}

/// The normal of point `i` and its surface variation: the given normal (variation
/// 0) when usable, else PCA.
pub fn normal_of(points: &[V3], given: Option<&[V3]>, nb: &Neighbours, i: usize) -> (V3, f32) {
    match given_normal(given, i) {
        Some(n) => (n, 0.0),
        None => pca_with_variation(points, nb, i),
    }
}

/// Point `i`'s given normal when there is one and it is [`usable`].
fn given_normal(given: Option<&[V3]>, i: usize) -> Option<V3> {
    given.and_then(|g| g.get(i).copied()).and_then(usable)
}

/// [`normal_of`] of the `L` points `is` at once (`None`: a lane not used,
/// whose result is meaningless), each what it gives alone: the eigen-solves
/// of those without a usable given normal overlap ([`Sym3::eigen_lanes`];
/// the others solve a zero matrix, which stops at once). The normals stage
/// spent about a tenth of a run in eigen-solves, most of it waiting on their
/// divisions and square roots.
pub fn normals_of_lanes<const L: usize>(
    points: &[V3],
    given: Option<&[V3]>,
    nb: &Neighbours,
    is: [Option<usize>; L],
) -> [(V3, f32); L] {
    let usable_given = is.map(|i| i.and_then(|i| given_normal(given, i)));
    let covariances: [Sym3; L] = core::array::from_fn(|l| match (is[l], usable_given[l]) {
        (Some(i), None) => covariance(points, i, nb.of(i)).1,
        _ => Sym3::default(),
    });
    let solved = Sym3::eigen_lanes(&covariances);
    core::array::from_fn(|l| match usable_given[l] {
        Some(n) => (n, 0.0),
        None => with_variation(solved[l].0, solved[l].1),
    })
}
