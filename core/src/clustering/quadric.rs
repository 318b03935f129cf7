//! Plane quadrics of the points (seed Eq. 1-2) and diffused quadrics (Eq. 3).
//!
//! A point's plane quadric is `Q_p = a_p · u uᵀ` with `u = (n, -n·p)` and support
//! area `a_p = (mean k-NN distance)² / 2` (Eq. 2 as the reference implements it),
//! scaled down where the PCA normal is unreliable (see `confidence`).
//! It has rank one, so core stores its factor `√a_p · u` (4 × f32 = 16 bytes per
//! point) rather than the 10 coefficients: the same quadric, 24 bytes per point
//! less. The diffused quadric of Eq. 3, `Q_v(i) = Σ_{j ∈ N(i) ∪ {i}} Q_p(j)`,
//! is what clustering evaluates, over and over: for most clouds (see
//! [`LOCAL_MIN_POINTS`]) it is kept too, 10 coefficients about the point itself ([`Local`],
//! 40 bytes a point: one quadratic form a cost, well conditioned wherever the
//! cloud lies); for the others, it is evaluated from the factors when needed:
//! `[c,1]ᵀ Q_v(i) [c,1] = Σ_j (√a_j u_j · [c,1])²`, 13 dot products at k = 12.
//! Sums over clusters use the 10-coefficient [`Quadric`] in `f64`.

use crate::arena::{Alloc, Arena};
use crate::clustering::knn::Neighbours;
use crate::clustering::normals;
use crate::error::Result;
use crate::math::{dist2, Sym3, D3, V3};
use crate::parallel;
use crate::progress::{tick, Progress, Stage};

/// `√a · (n, -n·p)` for one point.
pub type Plane = [f32; 4];

/// Area-weighted planes of every point plus the scale of their diffused quadrics.
#[derive(Clone, Copy)]
pub struct Planes<'a> {
    /// One factor per point.
    pub planes: &'a [Plane],
    /// Mean over points of the total area weight of the diffused quadric
    /// (`trace` of its 3x3 block): the unit that turns squared distances into
    /// QEM values. Zero only when every neighbourhood is degenerate.
    pub mean_weight: f32,
    /// Noise floor of the planes, in absolute units: the median over points of
    /// the RMS distance from the tangent planes of a point's neighbourhood to
    /// their best common point (`√(min Q_v(i) / W_i)`, see [`noise_floor`]). No
    /// generator can do better than this on average, whatever the clustering.
    /// About 1e-4 of the diagonal on clean smooth samples (0 on planes and at
    /// sharp edges, which planes locate exactly), 0.4-0.7 σ under Gaussian noise
    /// of standard deviation σ.
    pub noise: f32,
    /// Each point's diffused quadric (Eq. 3) about the point itself where
    /// [`keeps_local`]; else empty.
    pub diffused: &'a [Local],
}

/// A point's diffused quadric about the point `p`: with `x = c - p`,
/// `xᵀ A x + 2 bᵀ x + d` as `[a_xx, a_xy, a_xz, a_yy, a_yz, a_zz, b_x, b_y, b_z, d]`.
pub type Local = [f32; 10];

/// `[x,1]ᵀ Q [x,1]` of a [`Local`] quadric, `x` relative to its point; never
/// negative (rounding below zero gives zero), and infinite where it is not a
/// number (an overflow of opposite signs), as a sum of squares would be.
#[inline]
pub fn local_eval(q: &Local, x: V3) -> f32 {
    let ax = [
        q[0] * x[0] + q[1] * x[1] + q[2] * x[2],
        q[1] * x[0] + q[3] * x[1] + q[4] * x[2],
        q[2] * x[0] + q[4] * x[1] + q[5] * x[2],
    ];
    let v = x[0] * (ax[0] + 2.0 * q[6])
        + x[1] * (ax[1] + 2.0 * q[7])
        + x[2] * (ax[2] + 2.0 * q[8])
        + q[9];
    if v.is_nan() {
        f32::INFINITY
    } else {
        v.max(0.0)
    }
}

/// `u · [c, 1]`.
#[inline]
pub fn plane_eval(u: Plane, c: V3) -> f32 {
    u[0] * c[0] + u[1] * c[1] + u[2] * c[2] + u[3]
}

/// Area weight `a` of a stored factor (`n` is unit, so `|√a n|² = a`).
#[inline]
pub fn plane_weight(u: Plane) -> f32 {
    u[0] * u[0] + u[1] * u[1] + u[2] * u[2]
}

impl Planes<'_> {
    /// `[c,1]ᵀ Q_v(i) [c,1]`: the diffused QEM of point `i`, at `p`, at `c`
    /// (Eq. 3): from its [`Local`] quadric where kept, else from the planes.
    #[inline(always)]
    pub fn diffused_qem(&self, nb: &Neighbours, p: V3, i: usize, c: V3) -> f32 {
        if let Some(q) = self.diffused.get(i) {
            return local_eval(q, [c[0] - p[0], c[1] - p[1], c[2] - p[2]]);
        }
        let e = plane_eval(self.planes[i], c);
        let mut sum = e * e;
        for &j in nb.of(i) {
            let e = plane_eval(self.planes[j as usize], c);
            sum += e * e;
        }
        sum
    }

    /// Total area weight of point `i`'s diffused quadric.
    #[inline(always)]
    pub fn diffused_weight(&self, nb: &Neighbours, i: usize) -> f32 {
        if let Some(q) = self.diffused.get(i) {
            return q[0] + q[3] + q[5];
        }
        let mut w = plane_weight(self.planes[i]);
        for &j in nb.of(i) {
            w += plane_weight(self.planes[j as usize]);
        }
        w
    }

    /// Add `Q_v(i)`, point `i` at `p`, into `q`.
    #[inline]
    pub fn accumulate_diffused(&self, nb: &Neighbours, p: V3, i: usize, q: &mut Quadric) {
        let Some(l) = self.diffused.get(i) else {
            q.add_plane(self.planes[i]);
            for &j in nb.of(i) {
                q.add_plane(self.planes[j as usize]);
            }
            return;
        };
        let l = Quadric::from_local(l);
        let p = [p[0] as f64, p[1] as f64, p[2] as f64];
        // About the origin: with x = c - p, A stays, b becomes b - A p and d
        // becomes d - 2 b·p + pᵀ A p.
        let ap = Sym3(l.a).mul(p);
        for a in 0..6 {
            q.a[a] += l.a[a];
        }
        for a in 0..3 {
            q.b[a] += l.b[a] - ap[a];
        }
        q.c += l.c - 2.0 * (l.b[0] * p[0] + l.b[1] * p[1] + l.b[2] * p[2])
            + (ap[0] * p[0] + ap[1] * p[1] + ap[2] * p[2]);
    }

    /// The same planes evaluated as a cloud outside [`keeps_local`]'s sizes
    /// is: from the planes alone.
    #[cfg(test)]
    pub(crate) fn without_local(self) -> Self {
        Planes {
            diffused: &[],
            ..self
        }
    }

    /// Ask for what [`Planes::diffused_qem`] of point `i` reads first.
    #[inline(always)]
    pub fn prefetch(&self, i: usize) {
        if self.diffused.is_empty() {
            crate::hint::prefetch(self.planes.as_ptr().wrapping_add(i));
        } else {
            crate::hint::prefetch(self.diffused.as_ptr().wrapping_add(i));
        }
    }
}

/// Clouds of [`LOCAL_MIN_POINTS`] to [`LOCAL_MAX_POINTS`] points keep each
/// point's diffused quadric as a [`Local`] (40 bytes a point): a cost is then
/// one quadratic form instead of `k + 1` plane terms, and a cluster's sum one
/// quadric a member instead of `k + 1` planes (the bunny at 1,000 clusters: 11 %
/// fewer instructions, its clustering a fifth faster). Smaller clouds cluster
/// in milliseconds either way and are the ones small targets run, whose memory
/// is what they lack (the firmware's 1,000 points in 160 KiB); from the upper
/// limit on, 40 bytes a point would take a 10M-point run past 1.2 GB.
pub const LOCAL_MIN_POINTS: usize = 1 << 13;

/// See [`LOCAL_MIN_POINTS`].
pub const LOCAL_MAX_POINTS: usize = 1 << 21;

/// Whether a cloud of `n` points keeps its diffused quadrics.
pub fn keeps_local(n: usize) -> bool {
    (LOCAL_MIN_POINTS..LOCAL_MAX_POINTS).contains(&n)
}

/// Arena bytes [`try_planes_in`] keeps (and uses) for `n` points.
pub fn planes_bytes(n: usize) -> usize {
    let local = if keeps_local(n) { n } else { 0 };
    crate::arena::padded_bytes::<Plane>(n)
        .saturating_add(crate::arena::padded_bytes::<Local>(local))
}

/// Compute every point's plane factor, and where [`keeps_local`] its diffused
/// quadric. O(n k) time; 16 bytes per point, 56 with the quadrics.
pub fn try_planes_in<'a>(
    arena: &'a Arena,
    points: &[V3],
    given_normals: Option<&[V3]>,
    nb: &Neighbours,
    progress: &mut dyn Progress,
) -> Result<Planes<'a>> {
    let local = keeps_local(points.len());
    try_planes_with(arena, points, given_normals, nb, local, progress)
}

/// [`try_planes_in`], keeping the diffused quadrics when `local` whatever the
/// cloud's size.
pub(crate) fn try_planes_with<'a>(
    arena: &'a Arena,
    points: &[V3],
    given_normals: Option<&[V3]>,
    nb: &Neighbours,
    local: bool,
    progress: &mut dyn Progress,
) -> Result<Planes<'a>> {
    let n = points.len();
    tick(progress, Stage::Quadrics, 0, n as u64)?;
    // Filled on every thread: the first touch of fresh pages, faults and
    // all, is not left to the calling thread alone.
    let planes = arena.try_alloc_slice_on::<Plane>(n, [0.0; 4], &*progress)?;
    parallel::rows_in_waves(
        progress,
        Stage::Quadrics,
        planes,
        1,
        |items, out: &mut [Plane]| {
            // PCA_LANES points at a time, their eigen-solves overlapping
            // (lanes past the range unused).
            for (chunk, first) in out.chunks_mut(PCA_LANES).zip(items.step_by(PCA_LANES)) {
                let is: [Option<usize>; PCA_LANES] =
                    core::array::from_fn(|l| (l < chunk.len()).then_some(first + l));
                let normals = normals::normals_of_lanes(points, given_normals, nb, is);
                for ((plane, i), normal) in chunk.iter_mut().zip(first..).zip(normals) {
                    *plane = plane_with(points, nb, i, normal);
                }
            }
        },
        |()| {},
    )?;
    let planes: &'a [Plane] = planes;
    let diffused: &'a [Local] = arena.try_alloc_from_fn_on(
        if local { n } else { 0 },
        |i| local_of(planes, points, nb, i),
        &*progress,
    )?;
    let view = Planes {
        planes,
        mean_weight: 0.0,
        noise: 0.0,
        diffused,
    };
    let (total, noise) = weight_and_floor(arena, &view, nb, &*progress)?;
    tick(progress, Stage::Quadrics, n as u64, n as u64)?;
    Ok(Planes {
        planes,
        mean_weight: (total / n.max(1) as f64) as f32,
        noise,
        diffused,
    })
}

/// The total weight of the points' diffused quadrics and their
/// [`noise_floor`], in scratch: each point's weight in parallel tasks of
/// `hooks`, summed in point order (the sum of one thread), then the floor's
/// bins the same way. Never inlined: the tasks' arrays stay off the stack of
/// the stages after (the firmware's deepest frames are in meshing).
#[inline(never)]
fn weight_and_floor(
    arena: &Arena,
    view: &Planes,
    nb: &Neighbours,
    hooks: &dyn Progress,
) -> Result<(f64, f32)> {
    let n = view.planes.len();
    arena.scratch(|s| -> Result<(f64, f32)> {
        let weights = s.try_alloc_slice::<f32>(n, 0.0)?;
        parallel::rows(hooks, weights, 1, |items, out: &mut [f32]| {
            for (i, w) in items.zip(out.iter_mut()) {
                *w = view.diffused_weight(nb, i);
            }
        });
        let total = weights.iter().map(|&w| w as f64).sum::<f64>();
        let bins = s.try_alloc_slice::<u8>(floor_samples(n), 0)?;
        Ok((total, noise_floor(view, nb, n, bins, hooks)))
    })
}

/// Point `i`'s diffused quadric about itself, summed in `f64` in neighbour order.
fn local_of(planes: &[Plane], points: &[V3], nb: &Neighbours, i: usize) -> Local {
    let p = points[i];
    let p = [p[0] as f64, p[1] as f64, p[2] as f64];
    let mut q = Quadric::default();
    // Plane `u` about `p`: `u · [x + p, 1] = m · x + (u_w + m · p)`.
    let mut add = |u: Plane| {
        let m = [u[0] as f64, u[1] as f64, u[2] as f64];
        q.add_plane_f64(m, u[3] as f64 + m[0] * p[0] + m[1] * p[1] + m[2] * p[2]);
    };
    add(planes[i]);
    for &j in nb.of(i) {
        add(planes[j as usize]);
    }
    q.to_local()
}

/// Points whose normals [`try_planes_with`] finds at once
/// ([`normals::normals_of_lanes`]).
const PCA_LANES: usize = crate::math::SOLVE_LANES;

/// The plane factor of point `i`: its normal (with its surface variation,
/// as [`normals::normal_of`] gives them), and its support area (the squared
/// mean distance to its neighbours, halved) scaled by [`confidence`].
fn plane_with(points: &[V3], nb: &Neighbours, i: usize, (nrm, variation): (V3, f32)) -> Plane {
    let p = points[i];
    let row = nb.of(i);
    let mut mean = 0.0f64;
    for &j in row {
        mean += libm::sqrt(dist2(p, points[j as usize]) as f64);
    }
    mean /= row.len().max(1) as f64;
    let area = mean * mean / 2.0 * confidence(variation);
    let s = libm::sqrt(area);
    let d =
        -(nrm[0] as f64 * p[0] as f64 + nrm[1] as f64 * p[1] as f64 + nrm[2] as f64 * p[2] as f64);
    [
        (s * nrm[0] as f64) as f32,
        (s * nrm[1] as f64) as f32,
        (s * nrm[2] as f64) as f32,
        (s * d) as f32,
    ]
}

/// Octaves below and above the spacing that [`noise_floor`]'s histogram spans.
const FLOOR_OCTAVES: (i32, i32) = (-16, 4);
/// Bins per octave of that histogram (median to within 2^(1/16), 4.4 %).
const FLOOR_BINS_PER_OCTAVE: i32 = 8;
const FLOOR_BINS: usize = ((FLOOR_OCTAVES.1 - FLOOR_OCTAVES.0) * FLOOR_BINS_PER_OCTAVE) as usize;

/// The median over the first `n` points of `√(min_x Q_v(i)(x) / W_i)`: how far,
/// RMS, the tangent planes of a point's neighbourhood stay from any single
/// point. It is the least error [`crate::clustering::split`] can reach, so a tolerance below
/// it splits noise, not shape. The median of a log-scale histogram around the
/// spacing (160 bins on the stack), to within 4.4 %, over every point below
/// 8192 points and every `n / 4096`-th point beyond (at least 4096 of them: a
/// median needs no more, and the full pass cost as much as the quadrics). The
/// points' bins are found in parallel tasks of `hooks`, each into its byte of
/// `bins` (scratch of [`floor_samples`] bytes; fewer leave the floor 0), then
/// counted. O(min(n, 8192) k) time. 0 when no neighbourhood has weight.
pub fn noise_floor(
    planes: &Planes,
    nb: &Neighbours,
    n: usize,
    bins: &mut [u8],
    hooks: &dyn Progress,
) -> f32 {
    let unit = nb.spacing as f64;
    if !(unit > 0.0 && unit.is_finite()) {
        return 0.0;
    }
    let step = floor_step(n);
    // A byte a sampled point: its bin, or NO_BIN for a point without weight.
    const NO_BIN: u8 = u8::MAX;
    const _: () = assert!(FLOOR_BINS <= NO_BIN as usize);
    let Some(bins) = bins.get_mut(..floor_samples(n)) else {
        return 0.0;
    };
    parallel::rows(hooks, bins, 1, |items, out: &mut [u8]| {
        for (j, bin) in items.zip(out.iter_mut()) {
            *bin = floor_bin(planes, nb, j * step, unit).map_or(NO_BIN, |b| b as u8);
        }
    });
    let mut hist = [0u32; FLOOR_BINS];
    let mut count = 0u32;
    for &b in bins.iter().filter(|&&b| b != NO_BIN) {
        hist[b as usize] += 1;
        count += 1;
    }
    let mut seen = 0u32;
    for (b, &h) in hist.iter().enumerate() {
        seen += h;
        if 2 * seen > count {
            if b == 0 {
                return 0.0;
            }
            let octave = FLOOR_OCTAVES.0 as f64 + (b as f64 + 0.5) / FLOOR_BINS_PER_OCTAVE as f64;
            return (unit * libm::exp2(octave)) as f32;
        }
    }
    0.0
}

/// [`noise_floor`] samples every this many points of `n`.
fn floor_step(n: usize) -> usize {
    (n / 4096).max(1)
}

/// Points [`noise_floor`] samples of `n` (at most 8191).
pub fn floor_samples(n: usize) -> usize {
    n.div_ceil(floor_step(n))
}

/// Arena scratch [`try_planes_in`] takes after the planes for `n` points:
/// each point's weight, then the noise floor's bins.
pub fn planes_scratch_bytes(n: usize) -> usize {
    crate::arena::padded_bytes::<f32>(n)
        .saturating_add(crate::arena::padded_bytes::<u8>(floor_samples(n)))
}

/// [`noise_floor`]'s histogram bin of point `i`, `None` when its diffused
/// quadric has no weight.
fn floor_bin(planes: &Planes, nb: &Neighbours, i: usize, unit: f64) -> Option<usize> {
    // About the point itself where its quadric is kept, else about the
    // origin (the minimiser does not depend on where the solve is centred, up
    // to rounding).
    let q = match planes.diffused.get(i) {
        Some(l) => Quadric::from_local(l),
        None => {
            let mut q = Quadric::default();
            planes.accumulate_diffused(nb, [0.0; 3], i, &mut q);
            q
        }
    };
    let w = q.a[0] + q.a[3] + q.a[5];
    if !(w > 0.0 && w.is_finite()) {
        return None;
    }
    let (x, _) = q.minimizer(0.0, [0.0; 3]);
    let v = libm::sqrt(q.eval(x).max(0.0) / w) / unit;
    Some(if v > 0.0 && v.is_finite() {
        let b = (libm::log2(v) - FLOOR_OCTAVES.0 as f64) * FLOOR_BINS_PER_OCTAVE as f64;
        b.clamp(0.0, (FLOOR_BINS - 1) as f64) as usize
    } else {
        0
    })
}

/// Surface variation at which a plane's weight halves.
pub const VARIATION_HALF_WEIGHT: f64 = 0.01;

/// Weight factor of a plane whose neighbourhood has surface variation `v`:
/// `1 / (1 + (v / 0.01)²)`. A PCA plane fitted across a sharp edge (v ≈ 0.05 -
/// 0.2) blends the two sides and would pull generators off the edge; down-weighted,
/// the clean planes of its neighbours locate the edge (`tests/features.rs`). On a
/// smooth, densely sampled surface v is ~1e-4 and the factor ~1. Given normals
/// have v = 0. (Our addition to seed Eq. 2.)
fn confidence(v: f32) -> f64 {
    let t = v as f64 / VARIATION_HALF_WEIGHT;
    1.0 / (1.0 + t * t)
}

/// A symmetric 4x4 quadric in `f64`: `xᵀ A x + 2 bᵀ x + c` for `x ∈ R³`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Quadric {
    /// Upper triangle of `A`: xx xy xz yy yz zz.
    pub a: [f64; 6],
    /// Linear part.
    pub b: [f64; 3],
    /// Constant.
    pub c: f64,
}

impl Quadric {
    /// A kept [`Local`] quadric, widened (its `x` relative to its point).
    pub fn from_local(l: &Local) -> Quadric {
        let l = l.map(|v| v as f64);
        Quadric {
            a: [l[0], l[1], l[2], l[3], l[4], l[5]],
            b: [l[6], l[7], l[8]],
            c: l[9],
        }
    }

    /// As a [`Local`] quadric, rounded to `f32`.
    pub fn to_local(&self) -> Local {
        let (a, b) = (self.a, self.b);
        [a[0], a[1], a[2], a[3], a[4], a[5], b[0], b[1], b[2], self.c].map(|v| v as f32)
    }

    /// Add the rank-one quadric `u uᵀ`.
    #[inline]
    pub fn add_plane(&mut self, u: Plane) {
        self.add_plane_f64([u[0] as f64, u[1] as f64, u[2] as f64], u[3] as f64);
    }

    /// Add the rank-one quadric of the plane `m · x + w`.
    #[inline]
    pub fn add_plane_f64(&mut self, m: D3, w: f64) {
        let u = [m[0], m[1], m[2], w];
        self.add_outer(u, u);
    }

    /// Add `w u uᵀ`.
    #[inline]
    pub fn add_plane_scaled(&mut self, u: Plane, w: f64) {
        let u = [u[0] as f64, u[1] as f64, u[2] as f64, u[3] as f64];
        self.add_outer([w * u[0], w * u[1], w * u[2], w * u[3]], u);
    }

    /// Add the symmetric `l rᵀ` (`l` a multiple of `r`), entry by entry.
    #[inline]
    fn add_outer(&mut self, l: [f64; 4], r: [f64; 4]) {
        self.a[0] += l[0] * r[0];
        self.a[1] += l[0] * r[1];
        self.a[2] += l[0] * r[2];
        self.a[3] += l[1] * r[1];
        self.a[4] += l[1] * r[2];
        self.a[5] += l[2] * r[2];
        self.b[0] += l[0] * r[3];
        self.b[1] += l[1] * r[3];
        self.b[2] += l[2] * r[3];
        self.c += l[3] * r[3];
    }

    /// Add another quadric.
    pub fn add(&mut self, o: &Quadric) {
        for (x, y) in self.a.iter_mut().zip(o.a) {
            *x += y;
        }
        for (x, y) in self.b.iter_mut().zip(o.b) {
            *x += y;
        }
        self.c += o.c;
    }

    /// `[x,1]ᵀ Q [x,1]`.
    pub fn eval(&self, x: D3) -> f64 {
        let ax = Sym3(self.a).mul(x);
        x[0] * (ax[0] + 2.0 * self.b[0])
            + x[1] * (ax[1] + 2.0 * self.b[1])
            + x[2] * (ax[2] + 2.0 * self.b[2])
            + self.c
    }

    /// The minimiser of `Q(x) + mu |x - centre|²` (seed Eq. 5 plus the λ term).
    ///
    /// Solved for the displacement from `centre` through the eigen-decomposition of
    /// `A + mu I`, dropping eigenvalues below `1e-9` of the largest: with `mu > 0`
    /// the system is well-posed; with `mu = 0` a rank-deficient `A` (a planar or
    /// cylindrical cluster) gets the least-norm displacement, i.e. the optimum
    /// closest to `centre`. Returns the point and the numerical rank.
    pub fn minimizer(&self, mu: f64, centre: D3) -> (D3, u32) {
        let [one] = Quadric::minimizers(&[(self, mu, centre)]);
        one
    }

    /// [`Quadric::minimizer`] of `L` quadrics at once, each what it gives
    /// alone (their eigen-solves overlap, [`Sym3::pseudo_solve_lanes`]).
    #[inline]
    pub fn minimizers<const L: usize>(qs: &[(&Quadric, f64, D3); L]) -> [(D3, u32); L] {
        let systems = qs.map(|(q, mu, centre)| {
            let mut m = Sym3(q.a);
            m.0[0] += mu;
            m.0[3] += mu;
            m.0[5] += mu;
            // Gradient of Q at the centre (halved): A x + b.
            let g = Sym3(q.a).mul(centre);
            let rhs = [-(g[0] + q.b[0]), -(g[1] + q.b[1]), -(g[2] + q.b[2])];
            (m, rhs)
        });
        let solved = Sym3::pseudo_solve_lanes(&systems, 1e-9);
        core::array::from_fn(|l| {
            let ((d, rank), centre) = (solved[l], qs[l].2);
            ([centre[0] + d[0], centre[1] + d[1], centre[2] + d[2]], rank)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::dot_d;
    use crate::rng::Rng;

    fn random_quadric(rng: &mut Rng, planes: usize) -> Quadric {
        let mut q = Quadric::default();
        for _ in 0..planes {
            let n: [f64; 3] = core::array::from_fn(|_| rng.unit_f64() * 2.0 - 1.0);
            let len = libm::sqrt(dot_d(n, n));
            let p: [f64; 3] = core::array::from_fn(|_| rng.unit_f64() - 0.5);
            let w = 0.1 + rng.unit_f64();
            let n = [n[0] / len, n[1] / len, n[2] / len];
            let s = libm::sqrt(w);
            q.add_plane([
                (s * n[0]) as f32,
                (s * n[1]) as f32,
                (s * n[2]) as f32,
                (-s * dot_d(n, p)) as f32,
            ]);
        }
        q
    }

    /// The eigen-based solve against two independent oracles: Cramer's rule on the
    /// normal equations, and random probes around the answer (none may be lower).
    #[test]
    fn qem_optimal_point_equals_brute_force_minimiser() {
        let mut rng = Rng::new(11);
        for case in 0..300 {
            let q = random_quadric(&mut rng, 3 + case % 5);
            let mu = if case % 2 == 0 { 0.0 } else { 1e-3 };
            let centre = [0.1, -0.2, 0.05];
            let f = |x: D3| {
                let d = [x[0] - centre[0], x[1] - centre[1], x[2] - centre[2]];
                q.eval(x) + mu * dot_d(d, d)
            };
            let (x, rank) = q.minimizer(mu, centre);
            assert_eq!(rank, 3);
            // Cramer: (A + mu I) y = mu centre - b.
            let mut m = Sym3(q.a).full();
            for a in 0..3 {
                m[a][a] += mu;
            }
            let r = [
                mu * centre[0] - q.b[0],
                mu * centre[1] - q.b[1],
                mu * centre[2] - q.b[2],
            ];
            let det3 = |m: [[f64; 3]; 3]| {
                m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                    - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                    + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
            };
            let det = det3(m);
            let y: D3 = core::array::from_fn(|c| {
                let mut mc = m;
                for row in 0..3 {
                    mc[row][c] = r[row];
                }
                det3(mc) / det
            });
            let dist = libm::sqrt((0..3).map(|a| (x[a] - y[a]) * (x[a] - y[a])).sum::<f64>());
            let scale = 1.0 + libm::sqrt(dot_d(y, y));
            assert!(dist < 1e-6 * scale, "case {case}: {x:?} vs Cramer {y:?}");
            let fx = f(x);
            for _ in 0..50 {
                let step = 1e-3 * rng.unit_f64();
                let d: D3 = core::array::from_fn(|_| (rng.unit_f64() - 0.5) * step);
                let probe = [x[0] + d[0], x[1] + d[1], x[2] + d[2]];
                assert!(
                    f(probe) >= fx - 1e-12 * (1.0 + fx.abs()),
                    "case {case}: probe lower"
                );
            }
        }
    }

    #[test]
    fn planar_cluster_without_lambda_stays_at_the_centre_in_plane() {
        // All planes are z = 0.3: rank 1. The optimum is the centre projected onto
        // the plane.
        let mut q = Quadric::default();
        for w in [1.0f32, 2.0, 0.5] {
            let s = libm::sqrtf(w);
            q.add_plane([0.0, 0.0, s, -0.3 * s]);
        }
        let (x, rank) = q.minimizer(0.0, [0.2, -0.4, 0.9]);
        assert_eq!(rank, 1);
        assert!((x[0] - 0.2).abs() < 1e-12 && (x[1] + 0.4).abs() < 1e-12);
        assert!((x[2] - 0.3).abs() < 1e-6);
    }

    /// A point's kept diffused quadric is the sum of its neighbourhood's
    /// planes: its cost at generators near and far, its weight, and a
    /// cluster's summed quadric (its value and its optimum) agree with those
    /// taken from the planes, up to `f32` rounding; the costs are never
    /// negative.
    #[test]
    fn kept_diffused_quadrics_equal_the_sums_of_their_planes() {
        use crate::arena::Arena;
        use crate::clustering::knn::try_neighbours_in;
        use crate::progress::Silent;
        use crate::sample::{fill, Shape};
        use core::mem::MaybeUninit;
        use std::vec;
        use std::vec::Vec;
        let mut buf = vec![MaybeUninit::uninit(); 4 << 20];
        let arena = Arena::new(&mut buf);
        let mut points = vec![[0.0f32; 3]; 5000];
        fill(Shape::Demo, 2, 0.003, &mut points);
        // Far from the origin, where a plane's offset dwarfs its distances.
        for p in points.iter_mut() {
            p[0] += 40.0;
            p[2] -= 25.0;
        }
        let nb = try_neighbours_in(&arena, &points, 12, &mut Silent).unwrap();
        let kept = try_planes_with(&arena, &points, None, &nb, true, &mut Silent).unwrap();
        assert_eq!(kept.diffused.len(), points.len());
        let planes = kept.without_local();
        let mut rng = Rng::new(9);
        let mut members: Vec<usize> = Vec::new();
        for _ in 0..2000 {
            let i = (rng.next_u64() % points.len() as u64) as usize;
            let p = points[i];
            let w = planes.diffused_weight(&nb, i) as f64;
            let wk = kept.diffused_weight(&nb, i) as f64;
            assert!((w - wk).abs() <= 1e-5 * w, "weight {wk} against {w}");
            // Generators from a hundredth of a spacing to a tenth of the
            // shape away.
            let r = libm::pow(10.0, -4.0 + 3.0 * rng.unit_f64()) as f32;
            let c: V3 = core::array::from_fn(|k| p[k] + r * (rng.unit_f64() as f32 - 0.5));
            let e = planes.diffused_qem(&nb, p, i, c) as f64;
            let ek = kept.diffused_qem(&nb, p, i, c) as f64;
            assert!(ek >= 0.0);
            // Far enough out for the form's terms to overflow: no number, but
            // a cost that sorts last, as the planes' sum of squares does.
            let huge = [c[0] + 1e30, c[1] - 1e30, c[2] + 1e30];
            assert_eq!(kept.diffused_qem(&nb, p, i, huge), f32::INFINITY);
            assert_eq!(planes.diffused_qem(&nb, p, i, huge), f32::INFINITY);
            // The planes' sum rounds each term at the scale of its offset
            // (`√a n·p`, the point 47 units out): an error of at most `f √a_j`
            // a term, so `2 f √(w e) + w f²` in all (Cauchy-Schwarz); the
            // kept form rounds relative to the weight's reach `w r²`.
            let f = 4.0 * f32::EPSILON as f64 * 47.0;
            let scale = w * (r as f64) * (r as f64);
            let tol = 1e-4 * (e + scale) + 2.0 * f * libm::sqrt(w * e) + w * f * f;
            assert!((e - ek).abs() <= tol, "{ek} against {e} at {r}");
            if members.len() < 60 {
                members.push(i);
            }
        }
        let (mut q, mut qk) = (Quadric::default(), Quadric::default());
        for &i in &members {
            planes.accumulate_diffused(&nb, points[i], i, &mut q);
            kept.accumulate_diffused(&nb, points[i], i, &mut qk);
        }
        let centre = points[members[0]].map(|v| v as f64);
        let (x, _) = q.minimizer(0.0, centre);
        let (xk, _) = qk.minimizer(0.0, centre);
        let (v, vk) = (q.eval(x), qk.eval(xk));
        let w = q.a[0] + q.a[3] + q.a[5];
        assert!((v - vk).abs() <= 1e-3 * v + 1e-9 * w, "{vk} against {v}");
        let d2: f64 = (0..3).map(|k| (x[k] - xk[k]) * (x[k] - xk[k])).sum();
        assert!(d2 < 1e-6, "optimum moved by {}", libm::sqrt(d2));
    }
}
