//! Optional denoising before reconstruction ([`Params::smooth_rounds`]): each
//! round moves every point onto the least-squares plane of its [`SMOOTH_K`]
//! nearest neighbours (the plane through their centroid, normal to the PCA
//! direction of least spread), all points at once from the previous round's
//! positions.
//!
//! Why: with Gaussian noise near the point spacing (1 % of the diagonal on a
//! 20,000-point shape is about 1.4 spacings) the cloud is a shell a few points
//! thick, the k-NN graph joins points across it, clusters interleave and the
//! candidate graph outgrows meshing. Projecting onto a plane fitted to 24 points
//! divides the noise along the normal by about √24 per round, while moving
//! points along the surface very little. The price: sharp edges and corners are
//! rounded over about a neighbourhood's width, so it is off by default.
//!
//! Cost per round: one k-NN search and O(k) per point; arena: the k-NN rows and a
//! copy of the points, freed on return ([`smooth_bytes`]). Deterministic.

use crate::arena::Alloc;
use crate::clustering::knn::try_knn_rows_in;
use crate::clustering::normals::neighbourhood_pca;
use crate::error::Result;
use crate::math::{to_d3, V3};
use crate::params::{Params, MAX_K};
use crate::progress::{tick, Progress, Stage};

/// Neighbours of the plane each point is moved onto (fewer when the cloud is
/// smaller).
pub const SMOOTH_K: usize = 24;

fn smooth_k(n: usize) -> usize {
    SMOOTH_K.min(MAX_K).min(n.saturating_sub(1))
}

/// Move the points onto their neighbourhood planes, `params.smooth_rounds` times
/// (0: nothing happens). The arena is left as it was. Fails like the k-NN search
/// (too few points, non-finite coordinates) or with [`crate::Error::Exhausted`].
pub fn smooth<'b, A: Alloc<'b>>(
    arena: &A,
    points: &mut [V3],
    params: &Params,
    progress: &mut dyn Progress,
) -> Result<()> {
    let n = points.len();
    let k = smooth_k(n);
    for _ in 0..params.smooth_rounds {
        arena.scratch(|s| -> Result<()> {
            let rows = try_knn_rows_in(s, points, k, Stage::Clean, progress)?;
            let moved = s.try_alloc_copy::<V3>(points)?;
            for (i, row) in rows.knn.chunks_exact(k).enumerate() {
                if let Some(q) = project(points, i, row) {
                    moved[i] = q;
                }
                if i % 4096 == 0 {
                    tick(progress, Stage::Clean, i as u64, n as u64)?;
                }
            }
            points.copy_from_slice(moved);
            Ok(())
        })?;
    }
    Ok(())
}

/// Point `i` projected onto the least-squares plane of itself and `row`; `None`
/// when the neighbourhood has no plane (all points on a line or equal).
fn project(points: &[V3], i: usize, row: &[u32]) -> Option<V3> {
    let p = to_d3(*points.get(i)?);
    let (c, vals, vecs) = neighbourhood_pca(points, i, row);
    // A plane needs two directions of spread.
    let spread = vals[1] > 1e-12 * vals[2].max(1e-300);
    if !spread {
        return None;
    }
    let nrm = vecs[0];
    let h = (p[0] - c[0]) * nrm[0] + (p[1] - c[1]) * nrm[1] + (p[2] - c[2]) * nrm[2];
    let q = [p[0] - h * nrm[0], p[1] - h * nrm[1], p[2] - h * nrm[2]];
    if q.iter().all(|v| v.is_finite()) {
        Some(q.map(|v| v as f32))
    } else {
        None
    }
}

/// Arena bytes [`smooth`] needs on `n` points (0 when `params.smooth_rounds` is
/// 0): the k-NN rows and their grid scratch, and a copy of the points.
pub fn smooth_bytes(n: usize, params: &Params) -> usize {
    if params.smooth_rounds == 0 {
        return 0;
    }
    crate::budget::smooth_bound(n, smooth_k(n))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arena::Arena;
    use crate::progress::Silent;
    use crate::sample::{fill, Shape};
    use core::mem::MaybeUninit;

    fn radial_rms(p: &[V3]) -> f64 {
        let s: f64 = p
            .iter()
            .map(|q| {
                let r = (to_d3(*q).iter().map(|v| v * v).sum::<f64>()).sqrt();
                (r - 1.0) * (r - 1.0)
            })
            .sum();
        (s / p.len() as f64).sqrt()
    }

    #[test]
    fn smoothing_divides_the_noise_on_a_sphere_and_is_off_by_default() {
        // The unit sphere at 20,000 points with noise of 1 % of its diagonal.
        let mut pts = std::vec![[0.0f32; 3]; 20000];
        fill(Shape::Sphere, 5, 0.0346, &mut pts);
        let noisy = radial_rms(&pts);
        let mut buf = std::vec![MaybeUninit::uninit(); 8 << 20];
        let arena = Arena::new(&mut buf);
        let before = pts.clone();
        smooth(&arena, &mut pts, &Params::default(), &mut Silent).unwrap();
        assert_eq!(pts, before, "0 rounds must not move anything");
        let params = Params {
            smooth_rounds: 2,
            ..Params::default()
        };
        smooth(&arena, &mut pts, &params, &mut Silent).unwrap();
        assert_eq!(arena.used(), 0, "smoothing leaves the arena as it was");
        let smoothed = radial_rms(&pts);
        assert!(
            smoothed < 0.4 * noisy,
            "radial noise {noisy} only went down to {smoothed}"
        );
        let mut again = before.clone();
        smooth(&arena, &mut again, &params, &mut Silent).unwrap();
        assert_eq!(again, pts, "deterministic");
    }

    #[test]
    fn its_bound_is_enough() {
        let mut pts = std::vec![[0.0f32; 3]; 3000];
        fill(Shape::Torus, 2, 0.005, &mut pts);
        let params = Params {
            smooth_rounds: 1,
            ..Params::default()
        };
        let need = smooth_bytes(pts.len(), &params);
        let mut buf = std::vec![MaybeUninit::uninit(); need];
        let arena = Arena::new(&mut buf);
        smooth(&arena, &mut pts, &params, &mut Silent).unwrap();
        assert!(arena.peak() <= need);
    }
}
