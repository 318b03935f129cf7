//! Input checks that run before any allocation: finite values, enough points, a
//! usable `k`, and points that span a surface. O(n), no memory.

use crate::error::{Degeneracy, Error, Result};
use crate::math::{Sym3, V3};
use crate::params::{Params, MAX_K};

/// Fewest points a surface can be made of (a tetrahedron).
pub const MIN_POINTS: usize = 4;
/// Most points core accepts: neighbour counts must fit in `u32`.
pub const MAX_POINTS: usize = (u32::MAX as usize) / (MAX_K + 1);

/// Bounding box of the points and its diagonal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// Smallest coordinates.
    pub lo: V3,
    /// Largest coordinates.
    pub hi: V3,
    /// Length of the diagonal.
    pub diag: f32,
}

impl Bounds {
    /// The bounding box of `points` (finite ones; empty gives infinite
    /// corners). O(n).
    pub fn of(points: &[V3]) -> Bounds {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in points {
            for axis in 0..3 {
                lo[axis] = lo[axis].min(p[axis]);
                hi[axis] = hi[axis].max(p[axis]);
            }
        }
        let e = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
        let diag = libm::sqrtf(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
        Bounds { lo, hi, diag }
    }
}

/// Check everything about the input that can be checked without memory.
pub fn check(points: &[V3], normals: Option<&[V3]>, params: &Params) -> Result<Bounds> {
    params.validate()?;
    let n = points.len();
    if n < MIN_POINTS {
        return Err(Error::TooFewPoints {
            found: n,
            needed: MIN_POINTS,
        });
    }
    if n > MAX_POINTS {
        return Err(Error::TooManyPoints {
            found: n,
            max: MAX_POINTS,
        });
    }
    if let Some(nr) = normals {
        if nr.len() != n {
            return Err(Error::NormalsLength {
                points: n,
                normals: nr.len(),
            });
        }
    }
    for (index, p) in points.iter().enumerate() {
        for axis in 0..3 {
            let value = p[axis];
            if !value.is_finite() {
                return Err(Error::NonFinite {
                    index,
                    axis: axis as u8,
                    value,
                    normal: false,
                });
            }
        }
    }
    if params.k == 0 || params.k > MAX_K || params.k >= n {
        return Err(Error::BadNeighbours {
            k: params.k,
            points: n,
        });
    }
    if let Some(d) = degeneracy(points) {
        return Err(Error::Degenerate(d));
    }
    Ok(Bounds::of(points))
}

/// Whether the points fail to span 3D: every point within `1e-6` of the extent
/// from a single point, line or plane (fitted by PCA in `f64`).
pub fn degeneracy(points: &[V3]) -> Option<Degeneracy> {
    let n = points.len() as f64;
    let mut c = [0.0f64; 3];
    for p in points {
        for a in 0..3 {
            c[a] += p[a] as f64;
        }
    }
    for v in c.iter_mut() {
        *v /= n;
    }
    let mut cov = [0.0f64; 6];
    let mut radius2 = 0.0f64;
    for p in points {
        let d = [p[0] as f64 - c[0], p[1] as f64 - c[1], p[2] as f64 - c[2]];
        cov[0] += d[0] * d[0];
        cov[1] += d[0] * d[1];
        cov[2] += d[0] * d[2];
        cov[3] += d[1] * d[1];
        cov[4] += d[1] * d[2];
        cov[5] += d[2] * d[2];
        radius2 = radius2.max(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    }
    if radius2 == 0.0 {
        return Some(Degeneracy::Coincident);
    }
    let tol = 1e-6 * libm::sqrt(radius2);
    let (_, v) = Sym3(cov).eigen();
    // Largest distance from the best-fit plane (normal v[0]) and line (direction v[2]).
    let mut off_plane = 0.0f64;
    let mut off_line = 0.0f64;
    for p in points {
        let d = [p[0] as f64 - c[0], p[1] as f64 - c[1], p[2] as f64 - c[2]];
        let along = |u: [f64; 3]| d[0] * u[0] + d[1] * u[1] + d[2] * u[2];
        off_plane = off_plane.max(along(v[0]).abs());
        let (a, b) = (along(v[0]), along(v[1]));
        off_line = off_line.max(libm::sqrt(a * a + b * b));
        // Both past the tolerance (on a surface, within the first few
        // points): neither verdict can come.
        if off_plane > tol && off_line > tol {
            return None;
        }
    }
    if off_line <= tol {
        Some(Degeneracy::Collinear)
    } else if off_plane <= tol {
        Some(Degeneracy::Coplanar)
    } else {
        None
    }
}
