//! Cleaning before reconstruction: statistical outliers and small isolated
//! fragments. A separate pre-pass: [`clean`] marks which points to keep, the
//! caller compacts them and then runs [`reconstruct`](crate::reconstruct) on
//! what is left (in the same buffer: cleaning leaves nothing in the arena).
//!
//! Both filters work on the exact k-NN graph of [`knn`] (`k` of
//! [`Params`]), with `d_i` the mean distance from point `i` to its `k` nearest:
//!
//! 1. **Outliers** ([`Params::outlier_sigma`] `= t > 0`): with `μ` and `σ` the
//!    mean and standard deviation of `d_i` over all points, a point with
//!    `d_i > μ + t σ` is removed (the statistical filter of Rusu et al. 2008, as
//!    in PCL). Off by default.
//! 2. **Fragments** ([`Params::min_fragment`] `= m > 0`): the pieces of the cloud
//!    are the connected components of the k-NN graph on the points the first
//!    filter kept, with every edge longer than [`LINK_SPACINGS`] `× s` cut (`s`:
//!    the mean of `d_i` over those points, the average spacing). A piece of fewer
//!    than `m` points is dropped, except the largest piece (ties: the one holding
//!    the lowest point index), which is always kept. Default `m` 64.
//!
//! Why cut long edges: a blob of more than `k` points has all its nearest
//! neighbours inside itself, so the k-NN graph already separates it from
//! everything else; a smaller one (or a lone point) must borrow neighbours from
//! elsewhere, and only the cut tells it apart. An edge of a well-sampled surface
//! is at most about `1.5 s` (the k-th neighbour, k = 12); four spacings leave
//! room for regions sampled at a third of the average density before a surface
//! falls apart, and still separate anything farther than four spacings from the
//! rest.
//!
//! Memory: [`clean_bytes`](crate::clean_bytes), at most the neighbour stage of
//! [`reconstruct`](crate::reconstruct) (`4 k` bytes per point for the k-NN table,
//! plus the grid's scratch), all of it scratch. Cost: one k-NN query per point,
//! then O(n k) for both filters (union-find with path halving).

use crate::arena::Arena;
use crate::clustering::knn;
use crate::error::{Error, Result};
use crate::math::{dist2, V3};
use crate::parallel;
use crate::params::Params;
use crate::progress::{tick, Progress, Stage};
use crate::union_find;
use crate::validate;

/// Longest neighbour link inside one piece, in average spacings (see the module
/// docs).
pub const LINK_SPACINGS: f32 = 4.0;

/// What [`clean`] removed.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CleanStats {
    /// Points given.
    pub points: u32,
    /// Points kept.
    pub kept: u32,
    /// Points removed by the outlier filter.
    pub outliers: u32,
    /// Pieces dropped as fragments.
    pub fragments: u32,
    /// Points in the dropped fragments.
    pub fragment_points: u32,
    /// Pieces kept (0 when the fragment filter is off).
    pub pieces: u32,
    /// Average spacing: mean distance from a point to its `k` nearest (all points).
    pub spacing: f32,
    /// Mean neighbour distance above which a point is an outlier (`μ + t σ`; 0
    /// when the outlier filter is off).
    pub outlier_limit: f32,
    /// Longest link inside a piece ([`LINK_SPACINGS`] times the spacing of the
    /// points the outlier filter kept; 0 when the fragment filter is off).
    pub link: f32,
    /// Arena peak in bytes, the caller's earlier allocations included.
    pub peak: usize,
}

/// Mark in `keep` the points to keep: `false` for statistical outliers and for
/// points of small isolated fragments (see the module docs; `params.k`,
/// [`Params::outlier_sigma`] and [`Params::min_fragment`]). With both filters off
/// every point is kept and no memory is used.
///
/// `points` are checked as for [`reconstruct`](crate::reconstruct) (finite, enough
/// of them, spanning 3D, a usable `k`); `keep` must have one entry per point
/// ([`Error::KeepLength`]). When fewer than `max(4, k + 1)` points would be left,
/// this fails with [`Error::TooFewKept`] (the largest piece is always kept, but
/// the outlier filter may thin it). On error `keep` is unspecified. Everything it
/// allocates is scratch: `arena` is as it was when this returns. Deterministic.
pub fn clean(
    arena: &Arena,
    points: &[V3],
    params: &Params,
    keep: &mut [bool],
    progress: &mut dyn Progress,
) -> Result<CleanStats> {
    clean_with_rows(arena, points, params, keep, None, progress).map(|(stats, _)| stats)
}

/// [`clean`], also writing the k-NN table it searched into `rows` (when given,
/// `points.len() * params.k` long, else [`Error::BadNeighbourTable`]) and returning
/// how many of its queries fell back to a linear scan: when every point is
/// kept, [`reconstruct_with_rows`](crate::reconstruct_with_rows) on the same
/// points takes it instead of searching again. With both filters off nothing
/// is searched and `rows` is left as it was (the count is then `None`).
pub fn clean_with_rows(
    arena: &Arena,
    points: &[V3],
    params: &Params,
    keep: &mut [bool],
    rows_out: Option<&mut [u32]>,
    progress: &mut dyn Progress,
) -> Result<(CleanStats, Option<u32>)> {
    validate::check(points, None, params)?;
    let n = points.len();
    if keep.len() != n {
        return Err(Error::KeepLength {
            points: n,
            keep: keep.len(),
        });
    }
    if let Some(r) = rows_out.as_deref() {
        knn::check_table_len(r.len(), n, params.k)?;
    }
    keep.fill(true);
    let mut stats = CleanStats {
        points: n as u32,
        kept: n as u32,
        peak: arena.peak(),
        ..CleanStats::default()
    };
    if !params.cleans() {
        return Ok((stats, None));
    }
    let k = params.k;
    let mut scans = 0;
    arena.scratch(|s| -> Result<()> {
        // The caller's table, when given, is searched into where it lies (not
        // into the arena and copied: that would hold it twice at the peak).
        let knn: &[u32] = match rows_out {
            Some(out) => {
                scans = knn::try_fill_knn_rows(s, points, k, out, Stage::Clean, progress)?;
                stats.spacing = knn::spacing(points, out, k, &*progress);
                out
            }
            None => {
                let rows = knn::try_knn_rows_in(s, points, k, Stage::Clean, progress)?;
                stats.spacing = rows.spacing;
                scans = rows.linear_scans;
                rows.knn
            }
        };
        // d_i: mean distance to the k nearest, point by point in parallel tasks.
        let mean = s.try_alloc_slice::<f32>(n, 0.0)?;
        parallel::rows(&*progress, mean, 1, |items, out: &mut [f32]| {
            for (i, d) in items.zip(out) {
                let p = points[i];
                let row = knn.get(i * k..(i + 1) * k).unwrap_or(&[]);
                let sum: f64 = row
                    .iter()
                    .filter_map(|&j| points.get(j as usize))
                    .map(|&q| libm::sqrt(dist2(p, q) as f64))
                    .sum();
                *d = (sum / k as f64) as f32;
            }
        });
        if params.outlier_sigma > 0.0 {
            let (mu, sigma) = mean_and_deviation(mean.iter().copied());
            let limit = mu + params.outlier_sigma as f64 * sigma;
            stats.outlier_limit = limit as f32;
            for (d, kept) in mean.iter().zip(keep.iter_mut()) {
                if *d as f64 > limit {
                    *kept = false;
                    stats.outliers += 1;
                }
            }
        }
        tick(progress, Stage::Clean, n as u64 / 2, n as u64)?;
        if params.min_fragment > 0 {
            let kept = mean.iter().zip(keep.iter()).filter(|(_, &k)| k);
            let (spacing, _) = mean_and_deviation(kept.map(|(&d, _)| d));
            let link = LINK_SPACINGS * spacing as f32;
            stats.link = link;
            drop_fragments(
                s,
                points,
                knn,
                k,
                link * link,
                params.min_fragment,
                keep,
                &mut stats,
                &*progress,
            )?;
        }
        Ok(())
    })?;
    stats.kept = keep.iter().filter(|&&k| k).count() as u32;
    stats.peak = arena.peak();
    tick(progress, Stage::Clean, n as u64, n as u64)?;
    let needed = validate::MIN_POINTS.max(k + 1);
    if (stats.kept as usize) < needed {
        return Err(Error::TooFewKept {
            points: n,
            kept: stats.kept as usize,
            needed,
            outliers: stats.outliers as usize,
            fragment_points: stats.fragment_points as usize,
        });
    }
    Ok((stats, Some(scans)))
}

/// Mean and (population) standard deviation, in `f64`; `(0, 0)` when empty.
fn mean_and_deviation(values: impl Iterator<Item = f32> + Clone) -> (f64, f64) {
    let (mut count, mut sum) = (0usize, 0.0f64);
    for v in values.clone() {
        count += 1;
        sum += v as f64;
    }
    if count == 0 {
        return (0.0, 0.0);
    }
    let mu = sum / count as f64;
    let var = values
        .map(|v| (v as f64 - mu) * (v as f64 - mu))
        .sum::<f64>()
        / count as f64;
    (mu, libm::sqrt(var))
}

/// Pieces of the kept points (k-NN links of squared length at most `link2`,
/// joined in parallel tasks of `hooks`: [`union_find::roots_of_links`]);
/// clears `keep` on the points of pieces smaller than `min` except the largest.
#[allow(clippy::too_many_arguments)]
fn drop_fragments(
    s: &crate::arena::Scratch<'_, '_>,
    points: &[V3],
    knn: &[u32],
    k: usize,
    link2: f32,
    min: u32,
    keep: &mut [bool],
    stats: &mut CleanStats,
    hooks: &dyn Progress,
) -> Result<()> {
    let n = points.len();
    let keep_now = &*keep;
    let root = union_find::roots_of_links(
        hooks,
        s.try_alloc_slice::<u32>(n, 0)?,
        |i| knn.get(i * k..(i + 1) * k).unwrap_or(&[]),
        |i, j| {
            let q = points.get(j as usize);
            keep_now[i] && q.is_some_and(|&q| keep_now[j as usize] && dist2(points[i], q) <= link2)
        },
    );
    let size = s.try_alloc_slice::<u32>(n, 0)?;
    for i in 0..n {
        if keep[i] {
            let r = root[i] as usize;
            size[r] += 1;
        }
    }
    // The largest piece; ties go to the lowest root (first in index order).
    let mut largest = 0usize;
    for r in 0..n {
        if size[r] > size[largest] {
            largest = r;
        }
    }
    for r in 0..n {
        if size[r] == 0 {
            continue;
        }
        if size[r] < min && r != largest {
            stats.fragments += 1;
            stats.fragment_points += size[r];
        } else {
            stats.pieces += 1;
        }
    }
    for i in 0..n {
        if keep[i] {
            let r = root[i] as usize;
            if size[r] < min && r != largest {
                keep[i] = false;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::budget::clean_bytes;
    use crate::progress::Silent;
    use crate::rng::Rng;
    use crate::sample::{fill, scene_fragment, Shape};
    use core::mem::MaybeUninit;
    use std::vec;
    use std::vec::Vec;

    fn sample(shape: Shape, n: usize) -> Vec<V3> {
        let mut p = vec![[0.0f32; 3]; n];
        fill(shape, 3, 0.0, &mut p);
        p
    }

    /// `clean` in an arena of exactly `clean_bytes`; also checks it leaves the
    /// arena as it found it.
    fn run(points: &[V3], params: &Params) -> Result<(Vec<bool>, CleanStats)> {
        let mut buf = vec![MaybeUninit::uninit(); clean_bytes(points.len(), params)];
        let arena = Arena::new(&mut buf);
        let mut keep = vec![false; points.len()];
        let stats = clean(&arena, points, params, &mut keep, &mut Silent)?;
        assert_eq!(arena.used(), 0, "cleaning left memory behind");
        Ok((keep, stats))
    }

    fn params(outlier_sigma: f32, min_fragment: u32) -> Params {
        Params {
            outlier_sigma,
            min_fragment,
            ..Params::default()
        }
    }

    #[test]
    fn off_keeps_every_point_and_the_default_keeps_a_closed_shape_whole() {
        for shape in [Shape::Sphere, Shape::Torus, Shape::Box, Shape::Demo] {
            let p = sample(shape, 8000);
            let (keep, s) = run(&p, &params(0.0, 0)).unwrap();
            assert!(keep.iter().all(|&k| k), "{shape:?}");
            assert_eq!((s.kept, s.outliers, s.fragment_points), (8000, 0, 0));
            let (keep, s) = run(&p, &Params::default()).unwrap();
            assert!(keep.iter().all(|&k| k), "{shape:?}: {s:?}");
            assert_eq!((s.pieces, s.fragments, s.outliers), (1, 0, 0), "{shape:?}");
        }
    }

    #[test]
    fn planted_outliers_far_from_the_surface_are_found_and_few_surface_points_go() {
        // A unit sphere of 20,000 points and 1 % more uniform in its bounding box.
        let mut p = sample(Shape::Sphere, 20_000);
        let mut rng = Rng::new(11);
        for _ in 0..200 {
            p.push(core::array::from_fn(|_| rng.unit_f64() as f32 * 2.0 - 1.0));
        }
        for sigma in [2.0, 3.0] {
            let (keep, s) = run(&p, &params(sigma, 0)).unwrap();
            // Farther than 4 average spacings from the surface: every one found.
            let far = 4.0 * s.spacing;
            for (i, q) in p.iter().enumerate().skip(20_000) {
                let off = (libm::sqrtf(dist2(*q, [0.0; 3])) - 1.0).abs();
                assert!(
                    !keep[i] || off < far,
                    "sigma {sigma}: outlier {i} at {off} kept"
                );
            }
            let surface_lost = keep[..20_000].iter().filter(|&&k| !k).count();
            assert!(
                surface_lost <= 20_000 / 200,
                "sigma {sigma}: {surface_lost} surface points removed"
            );
            assert_eq!(s.outliers as usize, keep.iter().filter(|&&k| !k).count());
            // Those left lie near the sphere (a third of the cube is within 4
            // spacings of it); with 1 % outliers the deviation is wide enough
            // that no surface point goes.
            let planted_kept = keep[20_000..].iter().filter(|&&k| k).count();
            assert!(
                planted_kept < 100,
                "sigma {sigma}: {planted_kept} of 200 kept"
            );
        }
    }

    #[test]
    fn a_small_blob_far_away_is_a_fragment_and_a_second_object_is_kept() {
        let n = 10_000;
        let p = sample(Shape::Scene, n);
        let nf = scene_fragment(n);
        let (keep, s) = run(&p, &params(0.0, 64)).unwrap();
        assert_eq!(
            (s.fragments, s.fragment_points, s.pieces),
            (1, nf as u32, 2),
            "{s:?}"
        );
        assert!(keep[..n - nf].iter().all(|&k| k), "an object lost points");
        assert!(keep[n - nf..].iter().all(|&k| !k), "the fragment survived");
        // Below the fragment's size nothing goes; off, nothing either.
        for min in [nf as u32, 0] {
            let (keep, s) = run(&p, &params(0.0, min)).unwrap();
            assert!(keep.iter().all(|&k| k), "min {min}: {s:?}");
        }
        // A blob of fewer than k points 10 spacings from a sphere: its
        // neighbours reach into the sphere, but the links are too long.
        let mut q = sample(Shape::Sphere, 5000);
        let (_, s0) = run(&q, &params(0.0, 64)).unwrap();
        let mut rng = Rng::new(5);
        let c = 1.0 + 10.0 * s0.spacing;
        for _ in 0..8 {
            q.push([c + 0.1 * s0.spacing * rng.unit_f64() as f32, 0.0, 0.0]);
        }
        let (keep, s) = run(&q, &params(0.0, 64)).unwrap();
        assert_eq!(
            (s.fragments, s.fragment_points, s.kept),
            (1, 8, 5000),
            "{s:?}"
        );
        assert!(keep[5000..].iter().all(|&k| !k));
    }

    #[test]
    fn the_largest_piece_stays_even_when_every_piece_is_small() {
        // Two blobs of 40 points, far apart, both under min_fragment: the first
        // (lowest index) is kept.
        let mut p = sample(Shape::Sphere, 40);
        let far: Vec<V3> = p.iter().map(|q| [q[0] + 10.0, q[1], q[2]]).collect();
        p.extend(far);
        let (keep, s) = run(&p, &params(0.0, 64)).unwrap();
        assert_eq!((s.kept, s.fragments, s.pieces), (40, 1, 1));
        assert!(keep[..40].iter().all(|&k| k));
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let p = sample(Shape::Sphere, 500);
        let mut buf = vec![MaybeUninit::uninit(); clean_bytes(p.len(), &Params::default())];
        let arena = Arena::new(&mut buf);
        let mut keep = vec![true; 499];
        assert_eq!(
            clean(&arena, &p, &Params::default(), &mut keep, &mut Silent),
            Err(Error::KeepLength {
                points: 500,
                keep: 499
            })
        );
        let mut keep = vec![true; 500];
        for sigma in [f32::NAN, -1.0, f32::INFINITY] {
            let e = clean(&arena, &p, &params(sigma, 0), &mut keep, &mut Silent).unwrap_err();
            assert!(
                matches!(
                    e,
                    Error::BadParameter {
                        name: "outlier_sigma",
                        ..
                    }
                ),
                "{sigma}: {e:?}"
            );
        }
        // Thirty specks of three points, k = 2: the one kept (the first) is too
        // small for a surface.
        let mut rng = Rng::new(9);
        let mut q = Vec::new();
        for _ in 0..30 {
            let c: V3 = core::array::from_fn(|_| rng.unit_f64() as f32 * 2.0 - 1.0);
            q.extend([c, [c[0] + 0.001, c[1], c[2]], [c[0], c[1] + 0.001, c[2]]]);
        }
        let mut keep = vec![true; 90];
        let specks = Params {
            k: 2,
            ..params(0.0, 64)
        };
        let e = clean(&arena, &q, &specks, &mut keep, &mut Silent).unwrap_err();
        assert_eq!(
            e,
            Error::TooFewKept {
                points: 90,
                kept: 3,
                needed: 4,
                outliers: 0,
                fragment_points: 87
            }
        );
    }

    #[test]
    fn cleaning_is_deterministic() {
        let mut p = sample(Shape::Scene, 6000);
        let mut rng = Rng::new(2);
        for _ in 0..60 {
            p.push(core::array::from_fn(|_| rng.unit_f64() as f32 * 2.0 - 1.0));
        }
        let a = run(&p, &params(2.5, 64)).unwrap();
        let b = run(&p, &params(2.5, 64)).unwrap();
        assert_eq!(a, b);
    }

    #[test]
    fn a_progress_callback_can_cancel_cleaning() {
        struct Cancel;
        impl Progress for Cancel {
            fn report(&mut self, stage: Stage, _: u64, _: u64) -> crate::Flow {
                assert_eq!(stage, Stage::Clean);
                crate::Flow::Cancel
            }
        }
        let p = sample(Shape::Sphere, 500);
        let mut buf = vec![MaybeUninit::uninit(); clean_bytes(p.len(), &Params::default())];
        let arena = Arena::new(&mut buf);
        let mut keep = vec![true; 500];
        let r = clean(&arena, &p, &Params::default(), &mut keep, &mut Cancel);
        assert_eq!(r, Err(Error::Cancelled));
        assert_eq!(arena.used(), 0);
    }
}
