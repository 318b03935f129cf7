//! Clustering: seeded initialisation, region-growing partition (seed Eq. 4),
//! QEM-optimal generator update (Eq. 5), alternated with batch splitting (`split`).
//!
//! Energy minimised (a Lloyd-style alternation, so it never increases within a
//! round): `Σ_p E(p, c_label(p))` with
//! `E(p, c) = [c,1]ᵀ Q_v(p) [c,1] + λ W |p - c|²`, where `W` is the mean total
//! weight of a diffused quadric (so `λ` is dimensionless, see [`Params::lambda`]).
//!
//! - **Initialisation**: every connected component of the symmetrised k-NN graph gets
//!   one generator at a random point of it; the rest are drawn uniformly from all
//!   points (partial Fisher-Yates with a seeded SplitMix64). Generators start at
//!   their seed points.
//! - **Partition**: multi-source region growing on the symmetrised graph with a
//!   4-ary min-heap of `(cost, point)` keys packed in a `u64` (ties by point index:
//!   deterministic). Seeds go first; a point is pushed again only when a strictly
//!   cheaper cluster reaches it, and its first pop is final, so stale entries are
//!   skipped by a "finalised" bit. When the heap is full it is compacted (stale
//!   entries recognised by recomputing their cost), so `n` slots always suffice.
//!   Every label grows from a labelled neighbour, so clusters are connected.
//!   With two threads or more it runs in slabs, one a thread, and a repair
//!   that gives the labels of growing as one (`core/src/clustering/slabs.rs`).
//! - **Update**: `c_j = argmin Σ_{p ∈ j} E(p, c)`: the cluster's summed diffused
//!   quadric plus the λ term, solved around the cluster centroid
//!   ([`Quadric::minimizer`]). The next seed of a cluster is its member of least
//!   cost to the new generator.
//!
//! Memory: labels 4 B per point, plus O(clusters); a partition's scratch is
//! 32 B per point (guessed costs 16, heap 8, tentative cost and rival 8).
//! Cost per pass: O(n k log n).

use crate::arena::{padded_bytes, Alloc, Arena, Scratch};
use crate::clustering::knn::Neighbours;
use crate::clustering::quadric::{plane_eval, Planes, Quadric};
use crate::clustering::slabs::{self, Shares};
use crate::clustering::split;
use crate::clustering::sweep::{self, Start};
use crate::error::Result;
use crate::math::{dist2, dot, sub, V3};
use crate::parallel;
use crate::params::Params;
use crate::progress::{tick, Progress, Stage};
use crate::rng::Rng;
use crate::union_find;
use crate::validate::Bounds;

/// Label of a point not reached yet.
pub const NONE: u32 = 0x7FFF_FFFF;
pub(super) const FINAL: u32 = 0x8000_0000;

/// Rounds of splitting whose maximum error is kept in [`ClusterStats`].
pub const ROUNDS_KEPT: usize = 16;

/// Per-run clustering statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ClusterStats {
    /// Connected components of the symmetrised k-NN graph.
    pub components: u32,
    /// Generators placed by the initialisation.
    pub initial_clusters: u32,
    /// Clusters at the end.
    pub clusters: u32,
    /// Partition + update passes run in total.
    pub passes: u32,
    /// Splitting batches accepted.
    pub split_rounds: u32,
    /// Splitting batches undone because they raised the maximum error.
    pub rejected_batches: u32,
    /// Generators added by splitting.
    pub splits: u32,
    /// Whether the last series of passes ended because no generator moved.
    pub converged: bool,
    /// Energy of the last partition (sum of point costs).
    pub energy: f64,
    /// Largest point error (RMS distance from the generator to the point's
    /// neighbourhood planes) over all clusters, relative to the bounding-box
    /// diagonal, at the end.
    pub max_error: f32,
    /// `max_error` before each accepted splitting batch, then at the end: never
    /// increasing, because a batch that would raise it is undone and retried at
    /// half its size.
    pub error_per_round: [f32; ROUNDS_KEPT],
    /// The splitting tolerance used, relative to the diagonal: the larger of
    /// [`Params::tolerance`] and [`NOISE_TOLERANCE`] times the noise floor
    /// ([`Planes::noise`]).
    pub tolerance: f32,
    /// The noise floor of the planes ([`Planes::noise`]) relative to the diagonal.
    pub noise: f32,
}

/// Multiple of the noise floor ([`Planes::noise`]) below which the splitting
/// tolerance is not taken: the largest point error of a cluster of noisy points
/// sits a few times above the floor however many clusters there are, so a lower
/// tolerance only splits noise, up to the cap, and leaves too few points per
/// cluster to mesh. On clean clouds the floor is far below the default
/// tolerance, so this never binds there (`bench/notes.md` has the figures).
pub const NOISE_TOLERANCE: f32 = 4.0;

/// The result of clustering: a label per point, a generator per cluster.
pub struct Clusters<'a> {
    /// Cluster of each point, `0..generators.len()`.
    pub labels: &'a [u32],
    /// The QEM-optimal point of each cluster.
    pub generators: &'a [V3],
    /// A member of each cluster with the least cost to its generator.
    pub seeds: &'a [u32],
    /// Statistics.
    pub stats: ClusterStats,
}

/// Context shared by the passes.
pub(crate) struct Ctx<'p, 'a> {
    pub points: &'p [V3],
    pub nb: &'p Neighbours<'a>,
    pub planes: &'p Planes<'a>,
    /// `λ W`.
    pub lambda_w: f32,
}

impl<'p, 'a> Ctx<'p, 'a> {
    /// The context of clustering `points` with `params`.
    pub fn new(
        points: &'p [V3],
        nb: &'p Neighbours<'a>,
        planes: &'p Planes<'a>,
        params: &Params,
    ) -> Self {
        Ctx {
            points,
            nb,
            planes,
            lambda_w: params.lambda * planes.mean_weight,
        }
    }

    /// Seed Eq. 4. Always inlined, and the diffused QEM in it: as calls,
    /// region growing's offers took 23 M more instructions a one-thread
    /// bunny run (callgrind; plain `#[inline]` left both calls).
    #[inline(always)]
    pub fn cost(&self, i: usize, c: V3) -> f32 {
        self.planes.diffused_qem(self.nb, self.points[i], i, c)
            + self.lambda_w * dist2(self.points[i], c)
    }

    /// A lower bound of [`Ctx::cost`] from one plane instead of `k + 1`: the
    /// point's own plane term and the λ term (the terms left out are squares,
    /// and rounding a sum of non-negative terms is monotone). Where the
    /// point's diffused quadric is kept, the cost itself (as cheap).
    #[inline]
    pub fn cost_floor(&self, i: usize, c: V3) -> f32 {
        if !self.planes.diffused.is_empty() {
            return self.cost(i, c);
        }
        let e = plane_eval(self.planes.planes[i], c);
        e * e + self.lambda_w * dist2(self.points[i], c)
    }
}

/// Arena bytes of clustering `n` points into at most `cap` clusters (the
/// limit, [`Params::cluster_limit`]), partitioned by sweeps when `sweeps`
/// ([`Partition::sweeps`](crate::params::Partition::sweeps)): `(kept,
/// scratch)`. Kept: labels (4 per point), generators and seeds, and their
/// backups for undoing a splitting batch (32 per cluster of the cap); with
/// sweeps also the border flags and the labels' backup (5 per point). Scratch:
/// the largest of one step's, each in a scope of its own: the components (4 per
/// point), the initial seeds (9 per point), a partition (32 per point: costs
/// guessed, cost, rival, heap; sweeps: label and cost, stamps, a search, 19
/// per point and 9 per cluster), a generator update (member lists: 4 per point, 8 per
/// cluster; region growing's passes keep 4 per point across an update and a
/// partition), a splitting batch
/// ([`split::split_bytes`]) and a refinement ([`ClusterState::refine`], 9 per
/// cluster, then a partition). Keep in step with the functions named.
pub fn partition_bytes(n: usize, cap: usize, sweeps: bool) -> (usize, usize) {
    let sum = |list: &[usize]| list.iter().fold(0usize, |a, &b| a.saturating_add(b));
    let kept = sum(&[
        padded_bytes::<u32>(n),   // labels
        padded_bytes::<V3>(cap),  // generators
        padded_bytes::<u32>(cap), // seeds
        padded_bytes::<V3>(cap),  // backup_g
        padded_bytes::<u32>(cap), // backup_s
        if sweeps {
            padded_bytes::<u8>(n).saturating_add(padded_bytes::<u32>(n)) // border, backup_l
        } else {
            0
        },
    ]);
    let components = padded_bytes::<u32>(n);
    let seeds = sum(&[components, padded_bytes::<u32>(n), padded_bytes::<u8>(n)]);
    let partition = if sweeps {
        sweep::partition_bytes(n, cap)
    } else {
        sum(&[
            padded_bytes::<(u32, f32)>(n.saturating_mul(GUESSES)),
            padded_bytes::<f32>(n),
            padded_bytes::<u32>(n),
            padded_bytes::<u64>(n),
        ])
    };
    let update = sum(&[
        padded_bytes::<u32>(cap.saturating_add(1)), // start
        padded_bytes::<u32>(n),                     // members
        padded_bytes::<u32>(cap),                   // cursor
    ]);
    let refine = sum(&[padded_bytes::<(f32, u32)>(cap), padded_bytes::<bool>(cap)]);
    // Region growing's passes keep each point's cost to its generator across
    // the update and the partition.
    let own = if sweeps { 0 } else { padded_bytes::<f32>(n) };
    let scratch = seeds
        .max(own.saturating_add(partition.max(update)))
        .max(split::split_bytes(n, cap))
        .max(refine);
    (kept, scratch)
}

/// A clustering that can still grow: what [`try_cluster_state_in`] computes,
/// kept mutable so that meshing can ask for more generators where the mesh leaves
/// data uncovered ([`ClusterState::refine`]).
pub struct ClusterState<'a> {
    labels: &'a mut [u32],
    /// Per point, for sweeps: whether a neighbour may be of another cluster.
    border: &'a mut [u8],
    /// Whether passes partition by sweeps ([`Partition::sweeps`]).
    sweeps: bool,
    /// How region growing shares the points among its slabs.
    shares: Shares,
    generators: &'a mut [V3],
    seeds: &'a mut [u32],
    /// Generators and seeds kept by [`ClusterState::checkpoint`] (splitting's
    /// copies; empty without splitting).
    kept_g: &'a mut [V3],
    kept_s: &'a mut [u32],
    m: usize,
    /// The cluster cap (splitting's, and refinement's but at the rims of
    /// gaps and in clusters the mesh leaves out): the generators beyond it, up
    /// to `generators.len()` (the limit), are for those.
    cap: usize,
    /// Statistics so far.
    pub stats: ClusterStats,
}

impl<'a> ClusterState<'a> {
    /// The current clusters.
    pub fn view(&self) -> Clusters<'_> {
        Clusters {
            labels: self.labels,
            generators: &self.generators[..self.m],
            seeds: &self.seeds[..self.m],
            stats: self.stats,
        }
    }

    /// Generators the cluster cap still allows (far points,
    /// [`ClusterState::refine_at`]'s `at`).
    pub fn room(&self) -> usize {
        self.cap.saturating_sub(self.m)
    }

    /// Generators the limit still allows: for clusters left out of the mesh
    /// ([`ClusterState::refine`] adds none when this is 0) and at the rims of
    /// gaps ([`ClusterState::refine_at`]'s `rims`).
    pub fn limit_room(&self) -> usize {
        self.generators.len() - self.m
    }

    /// Whether there are more clusters than the cap.
    pub fn past_cap(&self) -> bool {
        self.m > self.cap
    }

    /// Whether [`ClusterState::checkpoint`] would keep the clusters now: not
    /// when the partition is swept (its labels are not a function of the
    /// generators and seeds alone) or they are more than its room.
    pub fn can_checkpoint(&self) -> bool {
        !self.sweeps && self.m <= self.kept_g.len() && self.m <= self.kept_s.len()
    }

    /// Keep the current generators and seeds to go back to
    /// ([`ClusterState::restore`]). `false` (nothing kept) under sweeps,
    /// whose partition depends on the one before it, or where the copies
    /// have no room (more clusters than the cap, or no splitting).
    pub fn checkpoint(&mut self) -> bool {
        let m = self.m;
        if !self.can_checkpoint() {
            return false;
        }
        self.kept_g[..m].copy_from_slice(&self.generators[..m]);
        self.kept_s[..m].copy_from_slice(&self.seeds[..m]);
        true
    }

    /// Go back to the `m` clusters of the last [`ClusterState::checkpoint`]
    /// (which returned `true` with `m` clusters): region growing's partition
    /// of the same generators and seeds is the same partition.
    #[allow(clippy::too_many_arguments)]
    pub fn restore(
        &mut self,
        arena: &Arena,
        points: &[V3],
        nb: &Neighbours,
        planes: &Planes,
        m: usize,
        params: &Params,
        progress: &mut dyn Progress,
    ) -> Result<()> {
        let m = m.min(self.kept_g.len()).min(self.kept_s.len()).min(self.m);
        self.generators[..m].copy_from_slice(&self.kept_g[..m]);
        self.seeds[..m].copy_from_slice(&self.kept_s[..m]);
        self.m = 0;
        let ctx = Ctx::new(points, nb, planes, params);
        self.relax_after_adding(arena, &ctx, m, None, progress)?;
        Ok(())
    }

    /// The limit: the most generators this clustering can ever hold (the cap
    /// and the room beyond it for the rims of gaps, [`Params::cluster_limit`]).
    pub fn limit(&self) -> usize {
        self.generators.len()
    }

    /// The final clusters, for the arena's lifetime.
    pub fn freeze(self) -> Clusters<'a> {
        Clusters {
            labels: self.labels,
            generators: &self.generators[..self.m],
            seeds: &self.seeds[..self.m],
            stats: self.stats,
        }
    }

    /// Split each cluster of `targets` across its length (at the member
    /// farthest from the line through the generator and its worst point, of
    /// largest error, see `split`), as room under the limit allows (past the
    /// cap: data left out of the mesh is worse than a few more vertices, see
    /// [`Params::cluster_limit`]), then relax with `params.split_iterations`
    /// passes. Returns the generators added.
    #[allow(clippy::too_many_arguments)]
    pub fn refine(
        &mut self,
        arena: &Arena,
        points: &[V3],
        nb: &Neighbours,
        planes: &Planes,
        targets: &[u32],
        params: &Params,
        progress: &mut dyn Progress,
    ) -> Result<usize> {
        let ctx = Ctx::new(points, nb, planes, params);
        let m = self.m;
        let take = targets.len().min(self.limit_room());
        if take == 0 {
            return Ok(0);
        }
        let added = arena.scratch(|s| -> Result<usize> {
            let worst = s.try_alloc_slice::<(f32, u32)>(m, (-1.0, u32::MAX))?;
            let wanted = s.try_alloc_slice::<bool>(m, false)?;
            for &t in &targets[..take] {
                if let Some(w) = wanted.get_mut(t as usize) {
                    *w = true;
                }
            }
            for (i, &l) in self.labels.iter().enumerate() {
                let j = l as usize;
                if j < m && wanted[j] {
                    let e = split::point_error2(&ctx, i, self.generators[j]);
                    if e > worst[j].0 {
                        worst[j] = (e, i as u32);
                    }
                }
            }
            // The worst point lies at an end of the cluster; the new generator
            // goes to the member farthest from the line through the generator
            // and that point. A cluster of a strip one cluster wide (which has
            // no candidate facet) is split across the strip, into two clusters
            // side by side that facets can join, where splitting at the worst
            // point would only lengthen the strip.
            let along = s.try_alloc_slice::<u32>(m, u32::MAX)?;
            for j in 0..m {
                along[j] = worst[j].1;
                worst[j] = (-1.0, u32::MAX);
            }
            for (i, &l) in self.labels.iter().enumerate() {
                let j = l as usize;
                let Some(&w) = along.get(j).filter(|_| j < m && wanted[j]) else {
                    continue;
                };
                let (Some(&p), Some(&q)) = (points.get(i), points.get(w as usize)) else {
                    continue;
                };
                let g = self.generators[j];
                let (d, x) = (sub(q, g), sub(p, g));
                let dd = dot(d, d);
                let t = if dd > 0.0 { dot(x, d) / dd } else { 0.0 };
                let r = sub(x, [t * d[0], t * d[1], t * d[2]]);
                let e = dot(r, r);
                if e > worst[j].0 {
                    worst[j] = (e, i as u32);
                }
            }
            let (mut added, limit) = (0, self.generators.len());
            for j in 0..m {
                let (a, b) = (along[j], worst[j].1);
                for p in [Some(a), (b != a).then_some(b)].into_iter().flatten() {
                    if wanted[j] && p != u32::MAX && p != self.seeds[j] && m + added < limit {
                        self.generators[m + added] = points[p as usize];
                        self.seeds[m + added] = p;
                        added += 1;
                    }
                }
            }
            Ok(added)
        })?;
        self.relax_after_adding(arena, &ctx, added, Some(params), progress)
    }

    /// Adds a generator at each point of `at` (a point index), as room under the
    /// cap allows, and at each point of `rims` (the rims of gaps the faces
    /// span), as room under the cap, or with `past_cap` the limit, allows
    /// (see [`Params::cluster_limit`]). A point that is a cluster of its own
    /// hands the generator to the neighbour its own generator represents
    /// worst: a rim with `past_cap` (a round for the genus), a far point with
    /// `open` (the mesh has a boundary: on open data a far point beyond the
    /// border, the raw scan's under an error bound of 0.5 %). Then relaxes as
    /// [`ClusterState::refine`] does. A point that seeds its cluster hands that
    /// on to the cluster's member of least cost (O(n) each), unless the
    /// cluster's generator is on the point (an earlier round's, not moved
    /// since): it is then treated as a cluster of its own, since a second
    /// generator there would only be merged with the first. Returns the
    /// generators added.
    #[allow(clippy::too_many_arguments)]
    pub fn refine_at(
        &mut self,
        arena: &Arena,
        points: &[V3],
        nb: &Neighbours,
        planes: &Planes,
        at: &[u32],
        rims: &[u32],
        past_cap: bool,
        open: bool,
        params: &Params,
        progress: &mut dyn Progress,
    ) -> Result<usize> {
        let ctx = Ctx::new(points, nb, planes, params);
        let m = self.m;
        let mut added = 0;
        let cap = self.cap;
        let limit = if past_cap { self.generators.len() } else { cap };
        let under_cap = at.iter().map(|&p| (p, cap, false));
        let under_limit = rims.iter().map(|&p| (p, limit, true));
        for (p, end, rim) in under_cap.chain(under_limit) {
            if m + added >= end {
                continue;
            }
            let (Some(&q), Some(&l)) = (points.get(p as usize), self.labels.get(p as usize)) else {
                continue;
            };
            let (mut p, mut q) = (p, q);
            if self.seeds.get(l as usize) == Some(&p) {
                // p seeds its cluster: that cluster takes its member of least
                // cost instead, and p seeds the new one.
                // A generator already on p (one an earlier round put there,
                // which no update has moved) is not handed on: a second one
                // on p would only be merged with it.
                let g = self.generators[l as usize];
                let other = (0..points.len())
                    .filter(|&i| g != q && self.labels[i] == l && i != p as usize)
                    .map(|i| (ctx.cost(i, g), i as u32))
                    .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                match other {
                    Some((_, i)) => self.seeds[l as usize] = i,
                    // A point that alone makes its cluster cannot be split
                    // off again: its neighbour worst represented by its own
                    // generator goes instead: for a rim in a round for the
                    // genus (`past_cap`), further into the gap's wall; for a
                    // far point on open data, further beyond the border.
                    // (Not everywhere: on closed data it changed what the
                    // rounds of an error bound reach, the fandisk's 0.5 % no
                    // longer met.) Otherwise the cluster keeps it.
                    None if (if rim { past_cap } else { open }) => {
                        let Some(j) = self.worst_neighbour(points, nb, p) else {
                            continue;
                        };
                        (p, q) = (j, points[j as usize]);
                    }
                    None => continue,
                }
            }
            self.generators[m + added] = q;
            self.seeds[m + added] = p;
            added += 1;
        }
        // The new generators stay on their points (no generator update): an
        // update would pull them back towards where the mesh was too far from
        // the data.
        self.relax_after_adding(arena, &ctx, added, None, progress)
    }

    /// Of `p`'s neighbours that seed no cluster, the one farthest from its own
    /// cluster's generator (the lowest index among equals).
    fn worst_neighbour(&self, points: &[V3], nb: &Neighbours, p: u32) -> Option<u32> {
        nb.of(p as usize)
            .iter()
            .filter(|&&j| {
                let lj = self.labels[j as usize];
                self.seeds.get(lj as usize) != Some(&j)
            })
            .map(|&j| {
                let lj = self.labels[j as usize] as usize;
                (dist2(points[j as usize], self.generators[lj]), j)
            })
            .max_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)))
            .map(|(_, j)| j)
    }

    /// Takes the `added` generators written after the first `m` into the
    /// clustering: a new partition, then (with `params`)
    /// `params.split_iterations` passes of partition and generator update.
    fn relax_after_adding(
        &mut self,
        arena: &Arena,
        ctx: &Ctx,
        added: usize,
        params: Option<&Params>,
        progress: &mut dyn Progress,
    ) -> Result<usize> {
        if added == 0 {
            return Ok(0);
        }
        self.m += added;
        let grown = self.m;
        let mut st = State {
            labels: &mut *self.labels,
            generators: &mut *self.generators,
            seeds: &mut *self.seeds,
            border: &mut *self.border,
            sweeps: self.sweeps,
            shares: self.shares,
        };
        let total = &mut self.stats.energy;
        repartition(arena, ctx, &mut st, grown, Start::Warm, total, &*progress)?;
        self.shares = st.shares;
        if let Some(params) = params {
            let planned = self.stats.passes + params.split_iterations.max(1);
            passes(
                arena,
                ctx,
                &mut st,
                grown,
                params.split_iterations,
                &mut self.stats,
                progress,
                planned,
            )?;
        }
        self.stats.clusters = grown as u32;
        if self.sweeps {
            self.stats.energy = energy(ctx, self.labels, &self.generators[..grown], &*progress);
        }
        self.stats.max_error = relative(
            split::max_error2(ctx, self.labels, &self.generators[..grown], &*progress),
            Bounds::of(ctx.points).diag,
        );
        Ok(added)
    }
}

/// Run the whole clustering: initialisation, then rounds of partition/update
/// passes separated by splitting batches. The state stays open for refinement;
/// [`ClusterState::freeze`] makes it final.
pub fn try_cluster_state_in<'a>(
    arena: &'a Arena,
    points: &[V3],
    nb: &Neighbours,
    planes: &Planes,
    diag: f32,
    params: &Params,
    progress: &mut dyn Progress,
) -> Result<ClusterState<'a>> {
    let n = points.len();
    let ctx = Ctx::new(points, nb, planes, params);
    let planned = params.iterations.max(1) + params.split_rounds * params.split_iterations.max(1);
    tick(progress, Stage::Clustering, 0, planned as u64)?;
    let labels = arena.try_alloc_slice::<u32>(n, NONE)?;
    // The components (one union-find) give the least cluster count and a
    // seed in each.
    let (components, wanted, cap, generators, seeds) = arena.scratch(|s| {
        let (root, components) = components(s, nb, &*progress)?;
        let wanted = (params.clusters as usize).min(n).max(components as usize);
        let cap = (params.cluster_cap() as usize).min(n).max(wanted);
        let limit = (params.cluster_limit() as usize).min(n).max(cap);
        let generators = arena.try_alloc_slice::<V3>(limit, [0.0; 3])?;
        let seeds = arena.try_alloc_slice::<u32>(limit, 0)?;
        initial_seeds(s, root, params.seed, &mut seeds[..wanted])?;
        Ok::<_, crate::Error>((components, wanted, cap, generators, seeds))
    })?;
    for j in 0..wanted {
        generators[j] = points[seeds[j] as usize];
    }
    let mut stats = ClusterStats {
        components,
        initial_clusters: wanted as u32,
        ..ClusterStats::default()
    };
    let mut m = wanted;
    let tol2 = {
        let t = if params.tolerance > 0.0 {
            (params.tolerance * diag).max(NOISE_TOLERANCE * planes.noise)
        } else {
            0.0
        };
        stats.tolerance = relative(t * t, diag);
        stats.noise = relative(planes.noise * planes.noise, diag);
        t * t
    };
    // State: generators and seeds, and for sweeps labels too (a sweep starts
    // from the labels before it); region growing's labels are always their
    // partition, so its state is restored exactly from a copy of the first two.
    let sweeps = params.partition.sweeps(n);
    let border = arena.try_alloc_slice::<u8>(if sweeps { n } else { 0 }, 1)?;
    let mut st = State {
        labels,
        generators,
        seeds,
        border,
        sweeps,
        shares: Shares::default(),
    };
    let total = &mut stats.energy;
    repartition(arena, &ctx, &mut st, m, Start::Fresh, total, &*progress)?;
    let pass = |st: &mut State,
                m: usize,
                count: u32,
                stats: &mut ClusterStats,
                progress: &mut dyn Progress| {
        passes(arena, &ctx, st, m, count, stats, progress, planned)
    };
    pass(&mut st, m, params.iterations, &mut stats, progress)?;
    let mut err2 = split::max_error2(&ctx, st.labels, &st.generators[..m], &*progress);
    // Splitting's copies of the state; refinement's after it (none without
    // splitting).
    let (mut kept_g, mut kept_s): (&mut [V3], &mut [u32]) = (&mut [], &mut []);
    if params.tolerance > 0.0 && params.split_rounds > 0 {
        let backup_g = arena.try_alloc_slice::<V3>(cap, [0.0; 3])?;
        let backup_s = arena.try_alloc_slice::<u32>(cap, 0)?;
        let backup_l = arena.try_alloc_slice::<u32>(if sweeps { n } else { 0 }, NONE)?;
        let mut limit = usize::MAX;
        let mut relax = true;
        let mut attempts = 0;
        while attempts < params.split_rounds && err2 > tol2 && m < cap {
            attempts += 1;
            backup_g[..m].copy_from_slice(&st.generators[..m]);
            backup_s[..m].copy_from_slice(&st.seeds[..m]);
            if sweeps {
                backup_l.copy_from_slice(st.labels);
            }
            let added = arena.scratch(|s| {
                split::try_split_in(
                    s,
                    &ctx,
                    st.labels,
                    st.generators,
                    st.seeds,
                    m,
                    cap,
                    tol2,
                    limit,
                    &*progress,
                )
            })?;
            if added == 0 {
                break;
            }
            let grown = m + added;
            let total = &mut stats.energy;
            repartition(arena, &ctx, &mut st, grown, Start::Warm, total, &*progress)?;
            if relax {
                pass(
                    &mut st,
                    grown,
                    params.split_iterations,
                    &mut stats,
                    progress,
                )?;
            }
            let after = split::max_error2(&ctx, st.labels, &st.generators[..grown], &*progress);
            if after <= err2 {
                // Accepted: the maximum error never grows from one batch to the next.
                let r = stats.split_rounds as usize;
                if r < ROUNDS_KEPT {
                    stats.error_per_round[r] = relative(err2, diag);
                }
                stats.split_rounds += 1;
                stats.splits += added as u32;
                m = grown;
                err2 = after;
                limit = usize::MAX;
                relax = true;
            } else {
                // Rejected: restore the state exactly. Retry the same batch without
                // relaxation (only the new generators' regions change), then with
                // half the batch.
                st.generators[..m].copy_from_slice(&backup_g[..m]);
                st.seeds[..m].copy_from_slice(&backup_s[..m]);
                if sweeps {
                    // The labels before the batch; their border flags are
                    // gone with the batch: every point is looked at again.
                    st.labels.copy_from_slice(backup_l);
                    st.border.fill(1);
                } else {
                    let total = &mut stats.energy;
                    repartition(arena, &ctx, &mut st, m, Start::Warm, total, &*progress)?;
                }
                stats.rejected_batches += 1;
                if relax {
                    relax = false;
                } else {
                    limit = added / 2;
                    if limit == 0 {
                        break;
                    }
                }
            }
        }
        (kept_g, kept_s) = (backup_g, backup_s);
    }
    stats.max_error = relative(err2, diag);
    let r = stats.split_rounds as usize;
    if r < ROUNDS_KEPT {
        stats.error_per_round[r] = stats.max_error;
    }
    stats.clusters = m as u32;
    if sweeps {
        stats.energy = energy(&ctx, st.labels, &st.generators[..m], &*progress);
    }
    tick(progress, Stage::Clustering, planned as u64, planned as u64)?;
    let State {
        labels,
        generators,
        seeds,
        border,
        sweeps,
        shares,
    } = st;
    Ok(ClusterState {
        labels,
        border,
        sweeps,
        shares,
        generators,
        seeds,
        kept_g,
        kept_s,
        m,
        cap,
        stats,
    })
}

/// Labels, generators and seeds of a run, and for sweeps which points lie on
/// a border between clusters.
struct State<'x> {
    labels: &'x mut [u32],
    generators: &'x mut [V3],
    seeds: &'x mut [u32],
    border: &'x mut [u8],
    sweeps: bool,
    /// How region growing shares the points among its slabs.
    shares: Shares,
}

/// Partition the points among the first `m` clusters of `st` (scratch from
/// `arena`): by sweeps from `start`, or by region growing (always from the
/// seeds alone), which also sets `energy` (sweeps leave it to [`energy`],
/// once at the end: it would cost a pass over the points).
fn repartition(
    arena: &Arena,
    ctx: &Ctx,
    st: &mut State,
    m: usize,
    start: Start,
    energy: &mut f64,
    hooks: &dyn Progress,
) -> Result<()> {
    repartition_knowing(arena, ctx, st, m, start, None, energy, hooks)
}

/// [`repartition`], with each point's cost to its cluster's generator known
/// (`own`, as [`update`] leaves it) for region growing to look up.
#[allow(clippy::too_many_arguments)]
fn repartition_knowing(
    arena: &Arena,
    ctx: &Ctx,
    st: &mut State,
    m: usize,
    start: Start,
    own: Option<&[f32]>,
    energy: &mut f64,
    hooks: &dyn Progress,
) -> Result<()> {
    let (g, s_) = (&st.generators[..m], &st.seeds[..m]);
    arena.scratch(|s| {
        if st.sweeps {
            sweep::partition(s, ctx, g, s_, st.labels, st.border, start, hooks)
        } else {
            *energy = partition(s, ctx, g, s_, st.labels, start, own, &mut st.shares, hooks)?;
            Ok(())
        }
    })
}

/// The energy of a partition: the sum of its points' costs (parallel tasks
/// over ranges of points, summed in task order).
fn energy(ctx: &Ctx, labels: &[u32], generators: &[V3], hooks: &dyn Progress) -> f64 {
    let sums = parallel::ranges(hooks, labels.len(), |items| {
        items
            .filter_map(|p| Some(ctx.cost(p, *generators.get(labels[p] as usize)?) as f64))
            .sum::<f64>()
    });
    sums.iter().sum()
}

/// Up to `count` update + partition passes over the first `m` clusters; stops
/// early when no generator moves.
#[allow(clippy::too_many_arguments)]
fn passes(
    arena: &Arena,
    ctx: &Ctx,
    st: &mut State,
    m: usize,
    count: u32,
    stats: &mut ClusterStats,
    progress: &mut dyn Progress,
    planned: u32,
) -> Result<()> {
    stats.converged = false;
    // Region growing: each point's cost to its cluster's new generator, which
    // the update computes to pick the seeds and the partition looks up.
    arena.scratch(|outer| {
        let own = outer.try_alloc_slice::<f32>(if st.sweeps { 0 } else { st.labels.len() }, 0.0)?;
        for _ in 0..count.max(1) {
            let moved = arena.scratch(|s| {
                update(
                    s,
                    ctx,
                    st.labels,
                    &mut st.generators[..m],
                    &mut st.seeds[..m],
                    own,
                    &*progress,
                )
            })?;
            stats.passes += 1;
            tick(
                progress,
                Stage::Clustering,
                stats.passes as u64,
                planned as u64,
            )?;
            if !moved {
                stats.converged = true;
                break;
            }
            let own = Some(&*own).filter(|o| !o.is_empty());
            repartition_knowing(
                arena,
                ctx,
                st,
                m,
                Start::Warm,
                own,
                &mut stats.energy,
                &*progress,
            )?;
        }
        Ok(())
    })
}

fn relative(err2: f32, diag: f32) -> f32 {
    if diag > 0.0 {
        libm::sqrtf(err2.max(0.0)) / diag
    } else {
        0.0
    }
}

/// Component root of every point (the smallest index of its component) by
/// union-find over the k-NN edges, in scratch, in parallel tasks of `hooks`
/// ([`union_find::roots_of_links`]). Returns the roots and their count.
fn components<'s>(
    s: &'s Scratch,
    nb: &Neighbours,
    hooks: &dyn Progress,
) -> Result<(&'s mut [u32], u32)> {
    let n = nb.len();
    let parent = s.try_alloc_slice::<u32>(n, 0)?;
    let roots = union_find::roots_of_links(hooks, parent, |i| nb.of(i), |_, _| true);
    let count = roots
        .iter()
        .enumerate()
        .filter(|&(i, &r)| r == i as u32)
        .count() as u32;
    Ok((roots, count))
}

/// One seed in each component (`root`: each point's component root, from
/// [`components`]; a uniformly random member), then uniform draws without
/// replacement from all points until `seeds` is full. `seeds.len()` must be at
/// least the number of components.
fn initial_seeds(s: &Scratch, root: &[u32], seed: u64, seeds: &mut [u32]) -> Result<()> {
    let n = root.len();
    let mut rng = Rng::new(seed);
    // A random permutation of the points (Fisher-Yates).
    let order = s.try_alloc_slice::<u32>(n, 0)?;
    for (i, o) in order.iter_mut().enumerate() {
        *o = i as u32;
    }
    for i in 0..n {
        let j = i + rng.below((n - i) as u32) as usize;
        order.swap(i, j);
    }
    // `mark[root]`: component seeded; `mark[p] | 2`: point chosen.
    let mark = s.try_alloc_slice::<u8>(n, 0)?;
    let mut count = 0usize;
    for &p in order.iter() {
        let r = root[p as usize] as usize;
        if mark[r] & 1 == 0 && count < seeds.len() {
            mark[r] |= 1;
            mark[p as usize] |= 2;
            seeds[count] = p;
            count += 1;
        }
    }
    for &p in order.iter() {
        if count >= seeds.len() {
            break;
        }
        if mark[p as usize] & 2 == 0 {
            mark[p as usize] |= 2;
            seeds[count] = p;
            count += 1;
        }
    }
    Ok(())
}

/// Children per node of [`Heap`]: four keys of 8 bytes share a cache line, and
/// the tree is half as deep as a binary one.
const ARITY: usize = 4;

/// Min-heap of packed `(cost bits << 32 | point)` keys over an arena slice.
pub(super) struct Heap<'s> {
    pub(super) keys: &'s mut [u64],
    pub(super) len: usize,
}

impl Heap<'_> {
    pub(super) fn push(&mut self, key: u64) -> bool {
        if self.len == self.keys.len() {
            return false;
        }
        self.len += 1;
        self.sift_up(self.len - 1, key);
        true
    }

    /// Put `key` into the hole at `i`, or where it rises to from there.
    #[inline(always)]
    fn sift_up(&mut self, mut i: usize, key: u64) {
        while i > 0 {
            let parent = (i - 1) / ARITY;
            if self.keys[parent] <= key {
                break;
            }
            self.keys[i] = self.keys[parent];
            i = parent;
        }
        self.keys[i] = key;
    }

    pub(super) fn pop(&mut self) -> Option<u64> {
        if self.len == 0 {
            return None;
        }
        let top = self.keys[0];
        self.len -= 1;
        let moving = self.keys[self.len];
        // Bottom-up: the least child rises into the hole down to a leaf,
        // with no comparison against `moving` on the way (the last key
        // belongs near the bottom), then `moving` rises from there to its
        // place: the same heap as sifting it down from the root, with fewer
        // comparisons and mispredicted branches (one-thread bunny run,
        // callgrind: 16 M fewer instructions, 0.21 M fewer mispredictions).
        let mut i = 0;
        while let Some((least, at)) = self.least_child(i) {
            self.keys[i] = least;
            i = at;
        }
        // (With the heap now empty, `moving` is the top itself, left in
        // the unused slot 0.)
        self.sift_up(i, moving);
        Some(top)
    }

    /// The least child of node `i` and where it is, `None` for a leaf.
    #[inline(always)]
    fn least_child(&self, i: usize) -> Option<(u64, usize)> {
        let first = ARITY * i + 1;
        let end = (first + ARITY).min(self.len);
        if first >= end {
            return None;
        }
        // The grandchildren are 16 keys in a row: fetch them while the
        // children are compared.
        let grand = ARITY * first + 1;
        crate::hint::prefetch(self.keys.as_ptr().wrapping_add(grand));
        crate::hint::prefetch(self.keys.as_ptr().wrapping_add(grand + 8));
        // Picked without branches (which of four random keys is least is a
        // coin toss for the branch predictor).
        let (mut least, mut at) = (self.keys[first], first);
        let mut offer = |c: usize, k: u64| {
            let lower = k < least;
            least = if lower { k } else { least };
            at = if lower { c } else { at };
        };
        if let Some(four) = self.keys[first..end].first_chunk::<ARITY>() {
            // All four children: one bounds check, the loop unrolled
            // (31 M fewer instructions a one-thread bunny run than the
            // loop below for every node).
            for (c, &k) in four.iter().enumerate().skip(1) {
                offer(first + c, k);
            }
        } else {
            for c in first + 1..end {
                offer(c, self.keys[c]);
            }
        }
        Some((least, at))
    }

    fn sift_down(&mut self, mut i: usize) {
        let Some(&moving) = self.keys.get(i).filter(|_| i < self.len) else {
            return;
        };
        // The moving key stays in hand while the smaller children rise into
        // the hole.
        while let Some((least, at)) = self.least_child(i) {
            if least >= moving {
                break;
            }
            self.keys[i] = least;
            i = at;
        }
        self.keys[i] = moving;
    }

    /// Keep only entries for which `live` holds, then restore the heap order.
    pub(super) fn retain(&mut self, mut live: impl FnMut(u64) -> bool) {
        let mut w = 0;
        for r in 0..self.len {
            let k = self.keys[r];
            if live(k) {
                self.keys[w] = k;
                w += 1;
            }
        }
        self.len = w;
        for i in (0..self.len.div_ceil(ARITY)).rev() {
            self.sift_down(i);
        }
    }
}

#[inline]
pub(super) fn key(cost: f32, point: u32) -> u64 {
    // Non-negative finite floats order like their bit patterns; anything else
    // (never produced from finite input) sorts last.
    let bits = if cost >= 0.0 && cost.is_finite() {
        cost.to_bits()
    } else if cost < 0.0 {
        0
    } else {
        f32::INFINITY.to_bits()
    };
    (bits as u64) << 32 | point as u64
}

/// Clusters of each point costed ahead of region growing, [`GUESSES`] a point.
pub(super) const GUESSES: usize = 2;

/// Point `p`'s cost to cluster `label` when it was computed ahead (`guess`,
/// [`GUESSES`] `(cluster, cost)` a point, empty when cold).
#[inline]
pub(super) fn guessed(guess: &[(u32, f32)], p: usize, label: u32) -> Option<f32> {
    let row = guess.get(p * GUESSES..(p + 1) * GUESSES)?;
    row.iter().find(|&&(l, _)| l == label).map(|&(_, e)| e)
}

/// Region growing from `seeds` (seed Eq. 4). Returns the total energy.
///
/// With `start` [`Start::Warm`], `labels` holds the last partition, and where
/// costs are summed from the planes (no [`Planes::diffused`] kept: a kept
/// quadric's cost is as cheap as looking one up) the costs region growing will
/// most likely ask for are computed first, in parallel tasks over ranges of
/// points: each point's cost to its own last
/// cluster (`own[p]` when given, as [`update`] leaves it) and to the first
/// other cluster among its neighbours' last labels. The growth then looks them
/// up instead of computing them; a cost is the same function of the same point
/// and generator either way, so the partition does not depend on what was
/// guessed.
#[allow(clippy::too_many_arguments)]
pub(crate) fn partition(
    s: &Scratch,
    ctx: &Ctx,
    generators: &[V3],
    seeds: &[u32],
    labels: &mut [u32],
    start: Start,
    own: Option<&[f32]>,
    shares: &mut Shares,
    hooks: &dyn Progress,
) -> Result<f64> {
    let n = labels.len();
    let warm = start == Start::Warm && ctx.planes.diffused.is_empty();
    // (Guessing ahead with kept quadrics: the same instructions, and the
    // clustering of the bunny 4 ms slower on two threads.)
    let guess =
        s.try_alloc_slice_on::<(u32, f32)>(if warm { GUESSES * n } else { 0 }, (NONE, 0.0), hooks)?;
    if warm {
        let last = &*labels;
        parallel::rows(hooks, guess, GUESSES, |points, rows: &mut [(u32, f32)]| {
            for (p, row) in points.zip(rows.chunks_exact_mut(GUESSES)) {
                let mine = last[p];
                let other = ctx
                    .nb
                    .symmetric(p)
                    .map(|q| last[q as usize])
                    .find(|&l| l != mine);
                for (k, (slot, l)) in row.iter_mut().zip([Some(mine), other]).enumerate() {
                    if let Some((l, &c)) = l.and_then(|l| Some((l, generators.get(l as usize)?))) {
                        let known = own.and_then(|o| o.get(p)).filter(|_| k == 0);
                        *slot = (l, known.copied().unwrap_or_else(|| ctx.cost(p, c)));
                    }
                }
            }
        });
    }
    if hooks.threads() > 1 {
        let guess = &*guess;
        let grown = s.scratch(|inner| {
            let last = start == Start::Warm;
            slabs::grow_in_slabs(
                inner, ctx, generators, seeds, guess, labels, last, shares, hooks,
            )
        });
        if let Some(energy) = grown {
            return Ok(energy);
        }
    }
    labels.fill(NONE);
    let mut f = Front {
        guess,
        labels,
        // Cost of each point's tentative label, so a rival cluster is compared
        // without recomputing it.
        best: s.try_alloc_slice::<f32>(n, f32::INFINITY)?,
        // The last rival cluster each point was costed against: a boundary point
        // is offered the same rival by several of its neighbours, costed once.
        tried: s.try_alloc_slice::<u32>(n, NONE)?,
        heap: Heap {
            keys: s.try_alloc_slice::<u64>(n, 0)?,
            len: 0,
        },
    };
    // Seeds are final before anything grows, so no cluster can lose its seed.
    for (j, &sd) in seeds.iter().enumerate() {
        f.labels[sd as usize] = j as u32 | FINAL;
    }
    for &sd in seeds {
        f.best[sd as usize] = 0.0;
        grow_from(ctx, generators, &mut f, sd as usize);
    }
    while let Some(top) = f.heap.pop() {
        let q = (top & 0xFFFF_FFFF) as usize;
        if f.labels[q] & FINAL != 0 {
            continue;
        }
        // The next point to pop, unless this one pushes a cheaper one.
        if f.heap.len > 0 {
            let next = (f.heap.keys[0] & 0xFFFF_FFFF) as usize;
            crate::hint::prefetch(ctx.nb.knn.as_ptr().wrapping_add(next * ctx.nb.k));
            crate::hint::prefetch(ctx.nb.rev_start.as_ptr().wrapping_add(next));
            crate::hint::prefetch(f.labels.as_ptr().wrapping_add(next));
        }
        f.labels[q] |= FINAL;
        grow_from(ctx, generators, &mut f, q);
    }
    let labels = f.labels;
    // Every component holds a seed, so every point was reached; a point that was
    // not (impossible by construction) would keep NONE and be caught by tests.
    for l in labels.iter_mut() {
        *l &= !FINAL;
    }
    // Summed by the ranges of parallel tasks, in order: the sum of region
    // growing in slabs, bit for bit.
    let best = &*f.best;
    let sums = (0..parallel::TASKS).map(|t| {
        let items = parallel::range(n, t);
        best.get(items)
            .map_or(0.0, |b| b.iter().fold(0.0, |a, &c| a + c as f64))
    });
    Ok(sums.fold(0.0, |a, b| a + b))
}

/// The growing front of a partition: labels (with the final bit), the tentative
/// cost and last rival of each point, and the heap.
struct Front<'s, 'l> {
    /// [`GUESSES`] `(cluster, cost)` a point, computed ahead (empty when cold).
    guess: &'s [(u32, f32)],
    labels: &'l mut [u32],
    best: &'s mut [f32],
    tried: &'s mut [u32],
    heap: Heap<'s>,
}

/// Neighbours region growing filters at a time (a power of two): a
/// point's k-NN row (12 by default) in one go, a long reverse row in parts.
pub(super) const FILTER: usize = 16;

/// Whether a neighbour holding `held` (its label, [`FINAL`] set when final)
/// and last tried with `tried` is open to an offer of cluster `label`: not
/// final, not holding it, not tried with it. Without a branch (see
/// [`grow_from`]).
#[inline(always)]
pub(super) fn open_to(held: u32, tried: u32, label: u32) -> bool {
    (held & FINAL == 0) & (held != label) & (tried != label)
}

/// Offer the cluster of the final point `q` to its unfinished neighbours.
fn grow_from(ctx: &Ctx, generators: &[V3], f: &mut Front, q: usize) {
    let label = f.labels[q] & !FINAL;
    let c = generators[label as usize];
    // Ask for every neighbour's rows before the first is read: the misses
    // then overlap instead of coming one after another.
    let rows = ctx.nb.rows(q);
    for row in rows {
        for &nbr in row {
            // A cost from the planes reads the neighbour's row; only such
            // costs are guessed ahead.
            if ctx.planes.diffused.is_empty() {
                crate::hint::prefetch(ctx.nb.knn.as_ptr().wrapping_add(nbr as usize * ctx.nb.k));
                crate::hint::prefetch(f.guess.as_ptr().wrapping_add(nbr as usize * GUESSES));
            }
            crate::hint::prefetch(f.labels.as_ptr().wrapping_add(nbr as usize));
            crate::hint::prefetch(f.tried.as_ptr().wrapping_add(nbr as usize));
            ctx.planes.prefetch(nbr as usize);
            crate::hint::prefetch(ctx.points.as_ptr().wrapping_add(nbr as usize));
        }
    }
    let mut open = [0u32; FILTER];
    for part in rows.iter().flat_map(|row| row.chunks(FILTER)) {
        // The neighbours still open to an offer of `label` (neither final,
        // nor holding it, nor tried with it), listed without a branch on
        // each, then offered: which neighbours are open (one in six on the
        // bunny) follows no pattern a branch predictor learns. Each is
        // marked tried as it is listed, so a neighbour in both rows is
        // listed once, as when each was offered in turn. (Callgrind, the
        // bunny at one thread: mispredicted branches 22.9 M to 20.0 M a
        // run, for 107 M more instructions; `bench/notes.md`.)
        let mut count = 0;
        for &nbr in part {
            let t = f.labels[nbr as usize];
            let tried = &mut f.tried[nbr as usize];
            let offered = open_to(t, *tried, label);
            *tried = if offered { label } else { *tried };
            open[count & (FILTER - 1)] = nbr;
            count += offered as usize;
        }
        for &nbr in open.iter().take(count) {
            let t = f.labels[nbr as usize];
            let e =
                guessed(f.guess, nbr as usize, label).unwrap_or_else(|| ctx.cost(nbr as usize, c));
            if t == NONE || e < f.best[nbr as usize] {
                f.labels[nbr as usize] = label;
                f.best[nbr as usize] = e;
                if !f.heap.push(key(e, nbr)) {
                    // Full: drop stale entries (final points, superseded costs).
                    let (labels, best) = (&*f.labels, &*f.best);
                    f.heap.retain(|k| {
                        let p = (k & 0xFFFF_FFFF) as usize;
                        labels[p] & FINAL == 0 && key(best[p], p as u32) == k
                    });
                    // Live entries <= unfinished points < n: there is room now.
                    f.heap.push(key(e, nbr));
                }
            }
        }
    }
}

/// Clusters whose generators [`update`] solves for at once.
const UPDATE_LANES: usize = crate::math::SOLVE_LANES;

/// Recompute every generator as its cluster's QEM optimum and pick the next seeds.
/// Returns whether any generator moved. Clusters are independent: parallel
/// tasks over ranges of clusters, each summing its members in point order (the
/// sums of a serial pass over the points, bit for bit). When `own` has a slot
/// per point, it is left holding each point's cost to its cluster's new
/// generator (infinite for a point in none of the clusters), computed in
/// parallel tasks over ranges of points.
pub(crate) fn update(
    s: &Scratch,
    ctx: &Ctx,
    labels: &[u32],
    generators: &mut [V3],
    seeds: &mut [u32],
    own: &mut [f32],
    hooks: &dyn Progress,
) -> Result<bool> {
    let m = generators.len();
    let (start, members) = members_in(s, labels, m)?;
    let (start, members) = (&*start, &*members);
    let of = |j: usize| &members[start[j] as usize..start[j + 1] as usize];
    // A cluster's quadric (its members' diffused ones summed in point
    // order), its minimiser's weight and its centroid.
    let summed = |j: usize| {
        let mut quadric = Quadric::default();
        let mut sum = [0.0f64; 3];
        for &i in of(j) {
            ctx.planes.accumulate_diffused(
                ctx.nb,
                ctx.points[i as usize],
                i as usize,
                &mut quadric,
            );
            let p = ctx.points[i as usize];
            for a in 0..3 {
                sum[a] += p[a] as f64;
            }
        }
        let count = of(j).len() as f64;
        let centre = if count == 0.0 {
            [0.0; 3]
        } else {
            [sum[0] / count, sum[1] / count, sum[2] / count]
        };
        (quadric, ctx.lambda_w as f64 * count, centre)
    };
    let moved = parallel::rows(hooks, generators, 1, |clusters, out: &mut [V3]| {
        let mut moved = false;
        // UPDATE_LANES clusters at a time, their solves overlapping (an
        // empty cluster, or a lane past the range, solves a zero quadric and
        // is not kept).
        for (chunk, first) in out
            .chunks_mut(UPDATE_LANES)
            .zip(clusters.step_by(UPDATE_LANES))
        {
            let sums: [_; UPDATE_LANES] = core::array::from_fn(|l| {
                if l < chunk.len() {
                    summed(first + l)
                } else {
                    (Quadric::default(), 0.0, [0.0; 3])
                }
            });
            let solved = Quadric::minimizers::<UPDATE_LANES>(&core::array::from_fn(|l| {
                let (quadric, mu, centre) = &sums[l];
                (quadric, *mu, *centre)
            }));
            for (l, g_out) in chunk.iter_mut().enumerate() {
                if of(first + l).is_empty() {
                    continue;
                }
                let x = solved[l].0;
                let g = [x[0] as f32, x[1] as f32, x[2] as f32];
                if g.iter().all(|v| v.is_finite()) && g != *g_out {
                    *g_out = g;
                    moved = true;
                }
            }
        }
        moved
    });
    // Next seeds: the member of least cost to the new generator, ties by index.
    let generators = &*generators;
    if own.len() == labels.len() {
        parallel::rows(hooks, own, 1, |points, out: &mut [f32]| {
            for (p, e) in points.zip(out.iter_mut()) {
                *e = generators
                    .get(labels[p] as usize)
                    .map_or(f32::INFINITY, |&g| ctx.cost(p, g));
            }
        });
    }
    let own = &*own;
    parallel::rows(hooks, seeds, 1, |clusters, out: &mut [u32]| {
        for (j, seed) in clusters.zip(out.iter_mut()) {
            let mut best = f32::INFINITY;
            for &i in of(j) {
                let e = match own.get(i as usize) {
                    Some(&e) => e,
                    None => ctx.cost(i as usize, generators[j]),
                };
                if e < best || (best == f32::INFINITY && e == f32::INFINITY) {
                    best = e;
                    *seed = i;
                }
            }
        }
    });
    Ok(moved.contains(&true))
}

/// The members of each of `m` clusters, ascending, by a counting sort of
/// `labels` (points labelled `m` or more are in none): cluster `j`'s are
/// `members[start[j]..start[j + 1]]`. 4 bytes per point and per cluster.
pub(crate) fn members_in<'s>(
    s: &'s Scratch,
    labels: &[u32],
    m: usize,
) -> Result<(&'s mut [u32], &'s mut [u32])> {
    let start = s.try_alloc_slice::<u32>(m + 1, 0)?;
    for &l in labels {
        if let Some(c) = start.get_mut(l as usize + 1).filter(|_| (l as usize) < m) {
            *c += 1;
        }
    }
    for j in 0..m {
        start[j + 1] += start[j];
    }
    let members = s.try_alloc_slice::<u32>(start[m] as usize, 0)?;
    let cursor = s.try_alloc_slice::<u32>(m, 0)?;
    cursor.copy_from_slice(&start[..m]);
    for (i, &l) in labels.iter().enumerate() {
        if let Some(c) = cursor.get_mut(l as usize) {
            members[*c as usize] = i as u32;
            *c += 1;
        }
    }
    Ok((start, members))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clustering::knn::try_neighbours_in;
    use crate::clustering::quadric::try_planes_in;
    use crate::progress::Silent;
    use core::mem::MaybeUninit;
    use std::vec;
    use std::vec::Vec;

    /// An 11 x 11 plate of spacing 1 (point `(x, y)` at `y * 11 + x`), its
    /// neighbours and planes.
    fn plate<'a>(arena: &'a Arena) -> (Vec<V3>, Neighbours<'a>, Planes<'a>) {
        let points: Vec<V3> = (0..121)
            .map(|i| [(i % 11) as f32, (i / 11) as f32, 0.0])
            .collect();
        let nb = try_neighbours_in(arena, &points, Params::default().k, &mut Silent).unwrap();
        let planes = try_planes_in(arena, &points, None, &nb, &mut Silent).unwrap();
        (points, nb, planes)
    }

    fn at(x: i32, y: i32) -> u32 {
        (y * 11 + x) as u32
    }

    /// A clustering of the plate with generators on the points `seeds_at`
    /// (room for two more), partitioned by region growing from them.
    fn clustered_plate<'a>(
        arena: &'a Arena,
        (points, nb, planes): &(Vec<V3>, Neighbours, Planes),
        seeds_at: &[u32],
        cap: usize,
    ) -> ClusterState<'a> {
        let m = seeds_at.len();
        let labels = arena.try_alloc_slice::<u32>(points.len(), NONE).unwrap();
        let generators = arena.try_alloc_slice::<V3>(m + 2, [0.0; 3]).unwrap();
        let seeds = arena.try_alloc_slice::<u32>(m + 2, 0).unwrap();
        for (j, &p) in seeds_at.iter().enumerate() {
            generators[j] = points[p as usize];
            seeds[j] = p;
        }
        let params = Params::default();
        let ctx = Ctx::new(points, nb, planes, &params);
        arena
            .scratch(|s| {
                let (g, sd) = (&generators[..m], &seeds[..m]);
                partition(
                    s,
                    &ctx,
                    g,
                    sd,
                    labels,
                    Start::Fresh,
                    None,
                    &mut Shares::default(),
                    &Silent,
                )
            })
            .unwrap();
        ClusterState {
            labels,
            border: &mut [],
            sweeps: false,
            shares: Shares::default(),
            generators,
            seeds,
            kept_g: arena.try_alloc_slice::<V3>(m, [0.0; 3]).unwrap(),
            kept_s: arena.try_alloc_slice::<u32>(m, 0).unwrap(),
            m,
            cap,
            stats: ClusterStats::default(),
        }
    }

    /// Clusters left out of the mesh are split past the cap (splitting may
    /// have taken all of it), as far as the limit allows and no further.
    #[test]
    fn clusters_left_out_are_split_past_the_cap_up_to_the_limit() {
        let mut buf = vec![MaybeUninit::uninit(); 4 * 1024 * 1024];
        let arena = Arena::new(&mut buf);
        let plate = plate(&arena);
        let (points, nb, planes) = &plate;
        let seeds_at = [at(2, 2), at(8, 2), at(2, 8), at(8, 8)];
        let m = seeds_at.len();
        // The cap is reached; the limit leaves room for two more.
        let mut state = clustered_plate(&arena, &plate, &seeds_at, m);
        assert_eq!((state.room(), state.limit_room()), (0, 2));
        let params = Params::default();
        let added = state
            .refine(
                &arena,
                points,
                nb,
                planes,
                &[0, 1, 2, 3],
                &params,
                &mut Silent,
            )
            .unwrap();
        assert_eq!(added, 2);
        assert_eq!((state.m, state.limit_room()), (m + 2, 0));
        // Every point is in one of the clusters, each cluster holds its seed.
        for (i, &l) in state.labels.iter().enumerate() {
            assert!((l as usize) < m + 2, "point {i}: label {l}");
        }
        for j in 0..m + 2 {
            assert_eq!(state.labels[state.seeds[j] as usize], j as u32);
        }
        // Nothing is left under the limit: no more are added.
        let more = state
            .refine(&arena, points, nb, planes, &[0], &params, &mut Silent)
            .unwrap();
        assert_eq!(more, 0);
    }

    /// Going back to a checkpoint gives the clusters it kept, labels and all.
    #[test]
    fn a_restored_checkpoint_is_the_same_clustering() {
        let mut buf = vec![MaybeUninit::uninit(); 4 * 1024 * 1024];
        let arena = Arena::new(&mut buf);
        let plate = plate(&arena);
        let (points, nb, planes) = &plate;
        let seeds_at = [at(2, 2), at(8, 2), at(2, 8), at(8, 8)];
        let m = seeds_at.len();
        let mut state = clustered_plate(&arena, &plate, &seeds_at, m);
        let params = Params::default();
        assert!(state.checkpoint());
        let labels = state.labels.to_vec();
        let generators = state.generators[..m].to_vec();
        let added = state
            .refine(&arena, points, nb, planes, &[0, 1], &params, &mut Silent)
            .unwrap();
        assert_eq!(added, 2);
        assert_ne!(state.labels.to_vec(), labels, "the split changed nothing");
        state
            .restore(&arena, points, nb, planes, m, &params, &mut Silent)
            .unwrap();
        assert_eq!(state.m, m);
        assert_eq!(state.labels.to_vec(), labels);
        assert_eq!(state.generators[..m].to_vec(), generators);
        assert_eq!(state.seeds[..m].to_vec(), seeds_at.to_vec());
        // More clusters than the copies hold: nothing kept.
        state
            .refine(&arena, points, nb, planes, &[0], &params, &mut Silent)
            .unwrap();
        assert!(!state.checkpoint());
    }

    /// In a round for the genus, a rim point that alone makes its cluster
    /// cannot be split off again: its neighbour worst represented by its own
    /// generator gets the generator.
    #[test]
    fn a_rim_point_alone_in_its_cluster_hands_its_generator_to_a_neighbour() {
        let mut buf = vec![MaybeUninit::uninit(); 4 * 1024 * 1024];
        let arena = Arena::new(&mut buf);
        let plate = plate(&arena);
        let (points, nb, planes) = &plate;
        // p at the plate's middle, generators at p and at the 8 points around
        // it: p's cluster is p alone.
        let mut seeds_at = vec![at(5, 5)];
        for (dx, dy) in [
            (-1, -1),
            (0, -1),
            (1, -1),
            (-1, 0),
            (1, 0),
            (-1, 1),
            (0, 1),
            (1, 1),
        ] {
            seeds_at.push(at(5 + dx, 5 + dy));
        }
        let m = seeds_at.len();
        let mut state = clustered_plate(&arena, &plate, &seeds_at, m);
        let alone = state.labels.iter().filter(|&&l| l == 0).count();
        assert_eq!(alone, 1, "p is not alone in its cluster");
        let p = at(5, 5);
        let params = Params::default();
        let added = state
            .refine_at(
                &arena,
                points,
                nb,
                planes,
                &[],
                &[p],
                true,
                false,
                &params,
                &mut Silent,
            )
            .unwrap();
        assert_eq!(added, 1);
        let new = state.seeds[m];
        assert!(
            nb.of(p as usize).contains(&new) && !seeds_at.contains(&new),
            "{new}"
        );
    }

    /// A far point that seeds a cluster whose generator is on it (as an
    /// earlier round leaves it) gets no second generator there, which would
    /// only be merged with the first: on open data its neighbour worst
    /// represented gets it, on closed data none is added.
    #[test]
    fn a_far_point_under_its_own_generator_gets_no_second_one() {
        let mut buf = vec![MaybeUninit::uninit(); 4 * 1024 * 1024];
        let arena = Arena::new(&mut buf);
        let plate = plate(&arena);
        let (points, nb, planes) = &plate;
        // Generators at the middle p and at the four corners: p's cluster
        // holds p and the points around it.
        let seeds_at = [at(5, 5), at(0, 0), at(10, 0), at(0, 10), at(10, 10)];
        let (p, m) = (seeds_at[0], seeds_at.len());
        let params = Params::default();
        for open in [true, false] {
            let mut state = clustered_plate(&arena, &plate, &seeds_at, m + 2);
            assert!(state.labels.iter().filter(|&&l| l == 0).count() > 1);
            let added = state
                .refine_at(
                    &arena,
                    points,
                    nb,
                    planes,
                    &[p],
                    &[],
                    false,
                    open,
                    &params,
                    &mut Silent,
                )
                .unwrap();
            assert_eq!(added, open as usize, "open {open}");
            let g = &state.generators[..m + added];
            for (i, a) in g.iter().enumerate() {
                assert!(!g[..i].contains(a), "open {open}: two generators at {a:?}");
            }
            assert_eq!(state.seeds[0], p);
            if open {
                assert!(nb.of(p as usize).contains(&state.seeds[m]));
            }
        }
    }

    /// Pops come out in ascending key order, whatever order the pushes came in
    /// and however they interleave with pops; a full heap refuses a push and
    /// `retain` keeps exactly the live keys, still in order.
    #[test]
    fn the_heap_pops_in_key_order_across_pushes_pops_and_retain() {
        let mut rng = Rng::new(7);
        let mut buf = [0u64; 300];
        let mut heap = Heap {
            keys: &mut buf,
            len: 0,
        };
        let mut mirror: Vec<u64> = Vec::new();
        for round in 0..2000u32 {
            if rng.below(3) > 0 || mirror.is_empty() {
                let key = (rng.below(1000) as u64) << 32 | round as u64;
                let pushed = heap.push(key);
                assert_eq!(pushed, mirror.len() < 300);
                if pushed {
                    mirror.push(key);
                }
            } else {
                mirror.sort_unstable();
                assert_eq!(heap.pop(), Some(mirror.remove(0)));
            }
            if round % 500 == 499 {
                heap.retain(|k| k & 1 == 0);
                mirror.retain(|k| k & 1 == 0);
            }
        }
        mirror.sort_unstable();
        for want in mirror {
            assert_eq!(heap.pop(), Some(want));
        }
        assert_eq!(heap.pop(), None);
    }
}
