//! Facet scores: data fitting (seed Eq. 9) and coverage (Eq. 10).
//!
//! Supports of facet `(a, b, c)` are the points of clusters `a`, `b` and `c` (found
//! through the member lists, never by scanning all points) that lie within `ε` of
//! the triangle, `ε = epsilon × diagonal`, at exact point-triangle distance `d`.
//! - Fitting: `F_f = Σ_supports (1 - d/ε)`.
//! - Coverage: the share of the triangle covered by its supports projected onto
//!   its plane, capped at 1. The paper uses the area of a 2D α-shape with
//!   `α = alpha_scale × spacing`; we measure the union of disks of diameter `α`
//!   around the projected supports on a fixed lattice of 45 samples
//!   (barycentric step 1/8): a sample is covered when a support lies within `α/2`.
//!   Like the α-shape, this ignores gaps narrower than `α` and excludes empty
//!   regions wider than it.
//!
//! Score: `w_fit · F_f / S + w_cov · F_c`, where `S` is the mean number of supports
//! per facet: the reference's weighting (coverage scaled by supports per facet),
//! divided through by `S` so both terms are O(1). Every score is finite.
//!
//! Memory: the scores (4 bytes per facet each for score, fitting and coverage);
//! the coverage lattice of the facet being scored lives on the stack (a 45-bit
//! mask), so no scratch grows with the size of a cluster. Cost: O(Σ supports ×
//! 45) per run, in practice ~100 supports per facet.

use crate::arena::Alloc;
use crate::error::Result;
use crate::math::{cross, dot, norm, point_triangle_dist2, sub, V3};
use crate::meshing::candidates::{Candidates, Members};
use crate::parallel;
use crate::params::Params;
use crate::progress::Progress;

/// Lattice subdivisions of the coverage samples (45 samples).
const LATTICE: usize = 8;

/// Parameters of the facet scores.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ScoreParams {
    /// Support distance `ε` as a fraction of the bounding-box diagonal.
    pub epsilon: f32,
    /// `α` of the coverage term in multiples of the average spacing.
    pub alpha_scale: f32,
    /// Weight of the fitting term.
    pub fitting: f32,
    /// Weight of the coverage term.
    pub coverage: f32,
}

impl From<&Params> for ScoreParams {
    /// The score parameters of a run (their defaults live in [`Params`]).
    fn from(params: &Params) -> Self {
        ScoreParams {
            epsilon: params.epsilon,
            alpha_scale: params.alpha_scale,
            fitting: params.fitting_weight,
            coverage: params.coverage_weight,
        }
    }
}

/// Per-facet scores.
#[derive(Clone, Copy)]
pub struct Scores<'a> {
    /// The objective coefficient of each facet.
    pub score: &'a [f32],
    /// Fitting term (Eq. 9), unnormalised.
    pub fitting: &'a [f32],
    /// Coverage term (Eq. 10), in `[0, 1]`.
    pub coverage: &'a [f32],
    /// Mean number of supports per facet (`S`).
    pub mean_supports: f32,
}

/// Score every candidate facet.
#[allow(clippy::too_many_arguments)]
pub fn try_scores_in<'a, 'b, A: Alloc<'b>>(
    arena: &'a A,
    points: &[V3],
    members: &Members,
    cand: &Candidates,
    generators: &[V3],
    spacing: f32,
    diag: f32,
    params: &ScoreParams,
    hooks: &dyn Progress,
) -> Result<Scores<'a>> {
    let f = cand.facets.len();
    let score = arena.try_alloc_slice::<f32>(f, 0.0)?;
    let fitting = arena.try_alloc_slice::<f32>(f, 0.0)?;
    let coverage = arena.try_alloc_slice::<f32>(f, 0.0)?;
    let eps = (params.epsilon * diag).max(f32::MIN_POSITIVE);
    let radius = 0.5 * params.alpha_scale * spacing;
    // Facets are independent: parallel tasks over ranges of them (the support
    // count is an integer sum, the same in any order).
    let supports = parallel::pairs(hooks, fitting, coverage, |items, fits, covs| {
        let mut supports = 0u64;
        for ((i, fit_out), cov_out) in items.zip(fits.iter_mut()).zip(covs.iter_mut()) {
            let t = cand.facets[i];
            let (a, b, c) = (
                generators[t[0] as usize],
                generators[t[1] as usize],
                generators[t[2] as usize],
            );
            // A frame in the triangle's plane: e1 along ab, e2 perpendicular.
            let ab = sub(b, a);
            let n = cross(ab, sub(c, a));
            let (lab, ln) = (norm(ab), norm(n));
            if !(lab > 0.0 && ln > 0.0) {
                continue;
            }
            let e1 = ab.map(|v| v / lab);
            let nn = n.map(|v| v / ln);
            let e2 = cross(nn, e1);
            let mut lattice = Lattice::new(
                [0.0, 0.0],
                [lab, 0.0],
                [dot(sub(c, a), e1), dot(sub(c, a), e2)],
                radius,
            );
            let mut fit = 0.0f32;
            for &cl in &t {
                for &p in members.of(cl as usize) {
                    let q = points[p as usize];
                    let d2 = point_triangle_dist2(q, a, b, c);
                    if d2 < eps * eps {
                        fit += 1.0 - libm::sqrtf(d2) / eps;
                        let r = sub(q, a);
                        lattice.cover([dot(r, e1), dot(r, e2)]);
                        supports += 1;
                    }
                }
            }
            *fit_out = fit;
            *cov_out = lattice.share();
        }
        supports
    });
    let total_supports: u64 = supports.iter().sum();
    let mean = if f > 0 {
        total_supports as f32 / f as f32
    } else {
        0.0
    };
    for i in 0..f {
        let fit = if mean > 0.0 { fitting[i] / mean } else { 0.0 };
        let sc = params.fitting * fit + params.coverage * coverage[i];
        score[i] = if sc.is_finite() { sc } else { 0.0 };
    }
    Ok(Scores {
        score,
        fitting,
        coverage,
        mean_supports: mean,
    })
}

/// The coverage samples of one triangle (2D): `LATTICE` barycentric steps per
/// side, 45 samples, and which of them lie within `radius` of a support seen so
/// far. Supports are fed one at a time, so none need storing.
struct Lattice {
    samples: [[f32; 2]; SAMPLES],
    covered: u64,
    r2: f32,
}

/// Samples of the lattice: `(LATTICE + 1)(LATTICE + 2) / 2`.
const SAMPLES: usize = (LATTICE + 1) * (LATTICE + 2) / 2;
const ALL: u64 = (1 << SAMPLES) - 1;

impl Lattice {
    fn new(a: [f32; 2], b: [f32; 2], c: [f32; 2], radius: f32) -> Self {
        let mut samples = [[0.0; 2]; SAMPLES];
        let mut x = 0;
        for i in 0..=LATTICE {
            for j in 0..=(LATTICE - i) {
                let (u, v) = (i as f32 / LATTICE as f32, j as f32 / LATTICE as f32);
                let w = 1.0 - u - v;
                samples[x] = [
                    w * a[0] + u * b[0] + v * c[0],
                    w * a[1] + u * b[1] + v * c[1],
                ];
                x += 1;
            }
        }
        Lattice {
            samples,
            covered: 0,
            r2: radius * radius,
        }
    }

    /// Mark the samples within the radius of support `q`.
    fn cover(&mut self, q: [f32; 2]) {
        let mut open = !self.covered & ALL;
        while open != 0 {
            let x = open.trailing_zeros() as usize;
            open &= open - 1;
            let s = self.samples[x];
            let (dx, dy) = (q[0] - s[0], q[1] - s[1]);
            if dx * dx + dy * dy <= self.r2 {
                self.covered |= 1 << x;
            }
        }
    }

    /// Share of the samples covered.
    fn share(&self) -> f32 {
        self.covered.count_ones() as f32 / SAMPLES as f32
    }
}

/// Share of the lattice samples of triangle `(a, b, c)` (2D) within `radius` of
/// some support.
pub fn lattice_coverage(
    supports: &[[f32; 2]],
    a: [f32; 2],
    b: [f32; 2],
    c: [f32; 2],
    radius: f32,
) -> f32 {
    let mut lattice = Lattice::new(a, b, c, radius);
    for &q in supports {
        lattice.cover(q);
    }
    lattice.share()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// Brute force: the minimum over a fine barycentric sampling of the triangle.
    #[test]
    fn point_triangle_distance_matches_dense_sampling_in_every_region() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.2, 0.9, 0.0]);
        // Above the interior, beside each edge, beyond each vertex.
        let cases: [(V3, f32); 7] = [
            ([0.4, 0.3, 0.5], 0.5),
            ([0.5, -0.4, 0.3], (0.16f32 + 0.09).sqrt()),
            ([-0.5, -0.5, 0.0], (0.5f32).sqrt()),
            ([1.5, -0.2, 0.0], (0.25f32 + 0.04).sqrt()),
            ([0.2, 1.4, 0.1], (0.25f32 + 0.01).sqrt()),
            ([0.4, 0.3, 0.0], 0.0),
            ([0.0, 0.0, 0.0], 0.0),
        ];
        for (p, want) in cases {
            let got = point_triangle_dist2(p, a, b, c).sqrt();
            assert!((got - want).abs() < 1e-5, "{p:?}: {got} vs {want}");
        }
        let mut rng = Rng::new(4);
        for _ in 0..500 {
            let r = |rng: &mut Rng| {
                core::array::from_fn::<f32, 3, _>(|_| rng.unit_f64() as f32 * 2.0 - 1.0)
            };
            let (a, b, c, p) = (r(&mut rng), r(&mut rng), r(&mut rng), r(&mut rng));
            let mut best = f32::INFINITY;
            let steps = 300;
            for i in 0..=steps {
                for j in 0..=(steps - i) {
                    let (u, v) = (i as f32 / steps as f32, j as f32 / steps as f32);
                    let w = 1.0 - u - v;
                    let q: V3 = core::array::from_fn(|k| w * a[k] + u * b[k] + v * c[k]);
                    best = best.min(crate::math::dist2(p, q));
                }
            }
            let got = point_triangle_dist2(p, a, b, c);
            assert!(got <= best + 1e-6, "closest point missed: {got} > {best}");
            assert!(
                best.sqrt() - got.sqrt() < 0.01,
                "sampling is 0.01 fine: {got} vs {best}"
            );
        }
    }

    #[test]
    fn coverage_is_full_half_or_empty_as_sampled() {
        let (a, b, c) = ([0.0, 0.0], [1.0, 0.0], [0.0, 1.0]);
        let mut grid = std::vec::Vec::new();
        for i in 0..=40 {
            for j in 0..=40 {
                let (x, y) = (i as f32 / 40.0, j as f32 / 40.0);
                if x + y <= 1.0 {
                    grid.push([x, y]);
                }
            }
        }
        assert_eq!(lattice_coverage(&grid, a, b, c, 0.03), 1.0);
        assert_eq!(lattice_coverage(&[], a, b, c, 0.03), 0.0);
        let left: std::vec::Vec<[f32; 2]> = grid.iter().copied().filter(|p| p[0] < 0.5).collect();
        let half = lattice_coverage(&left, a, b, c, 0.03);
        // Samples at x <= 0.5 (the column x = 0.5 is 0.025 from the supports,
        // within the radius): 9 + 8 + 7 + 6 + 5 = 35 of 45.
        assert_eq!(half, 35.0 / 45.0);
    }
}
