//! Every tunable of the pipeline, with its unit and default, in one place.

use crate::error::{Error, Result, Unmeshable};

/// Largest supported neighbourhood size.
pub const MAX_K: usize = 32;

/// Parameters of a run. Distances are relative to the diagonal of the input's
/// bounding box, so the same values work at any scale.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Params {
    /// Neighbours per point (excluding the point itself), `1..=32`. Default 12.
    pub k: usize,
    /// Initial number of generators (clusters). Clamped to the number of points and
    /// raised to the number of connected components. Default 1000.
    pub clusters: u32,
    /// Upper bound on clusters that batch splitting and refinement may reach
    /// (refinement at the rims of gaps and of clusters the mesh leaves out may
    /// go a [`GAP_ROOM`]th beyond it); 0
    /// means twice `clusters`. Default 0.
    pub max_clusters: u32,
    /// Partition + generator-update passes before the first splitting batch; the
    /// loop stops early when no generator moves. Default 5.
    pub iterations: u32,
    /// Partition + update passes after each splitting batch. Default 2.
    pub split_iterations: u32,
    /// Splitting batches at most. Default 5.
    pub split_rounds: u32,
    /// Largest allowed QEM error of a point w.r.t. its cluster's generator, as a
    /// distance relative to the bounding-box diagonal (see `split`): the generator
    /// must lie within this RMS distance of the tangent planes of every point of the
    /// cluster's neighbourhoods. 0 disables splitting. Default 0.005 (0.5 %).
    /// The tolerance used is never below [`crate::clustering::partition::NOISE_TOLERANCE`]
    /// times the noise floor of the planes ([`crate::Planes::noise`]): no
    /// clustering gets below it, so a lower tolerance would only split noise.
    pub tolerance: f32,
    /// Weight of the squared Euclidean distance against the squared plane distance
    /// in the partition cost (seed Eq. 4), dimensionless: `E(p, c) = Q_v(p)(c) +
    /// lambda * W * |p - c|^2` with `W` the mean total area weight of a diffused
    /// quadric. Default 0.001.
    pub lambda: f32,
    /// Seed of the deterministic generator initialisation. Default 1.
    pub seed: u64,
    /// Support distance `ε` of the facet scores (seed Eq. 9), relative to the
    /// diagonal. Default 0.01.
    pub epsilon: f32,
    /// `α` of the coverage term (Eq. 10) in multiples of the average spacing.
    /// Default 5.
    pub alpha_scale: f32,
    /// Weight of the fitting term in the facet score. Default 0.4.
    pub fitting_weight: f32,
    /// Weight of the coverage term in the facet score. Default 0.3.
    pub coverage_weight: f32,
    /// Cost of a selected facet's edge left with no partner (a hole or border edge),
    /// in units of facet score (a facet scores about 0.5). Large values approach
    /// the paper's strict closed-surface constraint, under which one missing
    /// candidate anywhere forbids every closed surface; small ones let weak facets
    /// go at the price of a hole. Default 2.
    pub border_penalty: f32,
    /// Boundary loops of the selection with at most this many edges are closed by
    /// hole filling (0: none). Default 64.
    pub max_hole: u32,
    /// Border of the data, in degrees: a cluster whose adjacent clusters leave an
    /// angular gap wider than this around it, and that has a candidate edge with
    /// fewer than two candidate facets, lies where the data ends (an open
    /// surface, a scan's edge, a hole in the data). Edges between two such
    /// clusters may end with one facet at no cost (as may any edge with a single
    /// candidate facet), and boundary loops mostly along them stay open, their
    /// vertices moved onto the data's border; everywhere else the border penalty
    /// and hole filling apply. 360 turns detection off. Default 150.
    pub border_angle: f32,
    /// How each clustering pass partitions the points ([`Partition`]).
    /// Default [`Partition::Auto`].
    pub partition: Partition,
    /// Branch-and-bound search nodes allowed in facet selection. Default 200.
    pub node_limit: u64,
    /// Rounds of fitting the mesh's vertices to the data
    /// ([`crate::meshing::fit`]): each projects every point onto its nearest
    /// face and moves the vertices (not those on the boundary) by regularised
    /// least squares towards them, never turning a face over. 0 turns fitting
    /// off. Default 2 (a third round lowers the maximum distance by about 2 % more for 40 % more fitting time; `bench/notes.md`).
    pub fit_rounds: u32,
    /// Error-driven refinement without a new selection
    /// ([`crate::meshing::output::densify`]): at most this fraction of the
    /// mesh's vertices is added, each at the farthest point of a cluster that
    /// lies beyond the 99th percentile of the points' distances to the mesh,
    /// farthest first. 0 turns it off. Default 0.1 (on the shared clouds it
    /// lowered the median maximum distance by about 40 % for about 4 % more
    /// vertices; `bench/notes.md`).
    pub densify: f32,
    /// Rounds of refinement where clusters are left out of the mesh even after
    /// skipped clusters are inserted (each round splits them and selects
    /// again; a round runs only where one is needed). Default 2 (on the shared
    /// clouds it gave back the raw scan's second ear at 250 clusters and the
    /// gear's spokes at 2,000, for a third more time where it runs;
    /// `bench/notes.md`). Where clusters are still left out after them, one
    /// more round splits them, kept only if its mesh leaves out no more
    /// points; 0 turns all of them off.
    pub refine_rounds: u32,
    /// Error bound, as a fraction of the bounding-box diagonal: while some
    /// point is farther than this from the mesh, the farthest point of each
    /// such cluster becomes a generator and the mesh is made again, until every
    /// point is within the bound, the cluster cap is reached or
    /// [`MAX_ERROR_ROUNDS`] rounds have run ([`crate::MeshDistance`] in the
    /// statistics says how far the result is). 0 (the default): no bound.
    pub max_error: f32,
    /// Where refinement rounds also run without an error bound, as a fraction
    /// of the bounding-box diagonal: while some point that is part of the
    /// surface (not a stray point: see `part_of_surface` in the output stage;
    /// a point beyond the mesh's boundary always is) is farther than this from
    /// the mesh, the
    /// farthest such point of each cluster becomes a generator and the mesh is
    /// made again, at most `refine_rounds` times (after rounds for clusters
    /// left out). A goal, not a bound (that is `max_error`): when the rounds
    /// run out the mesh is written as it is. 0: rounds only for clusters left
    /// out. Default 0.0075 (on the shared clouds 1 % left the block at 250
    /// clusters at 0.95 %, 0.75 % brought it to 0.68 % and its true genus;
    /// `bench/notes.md`).
    pub refine_beyond: f32,
    /// Working memory reserved for a meshing round (candidate edges and facets,
    /// scores, selection, output), in bytes per cluster of the cap
    /// (`max_clusters`, or twice `clusters`), on top of 4 bytes per point: a
    /// capacity, like a buffer size. The candidate graph's size depends on the
    /// data, not only on `n` and these parameters (about 3 candidate facets per
    /// cluster on a well-sampled surface, far more with few points per cluster
    /// or thin parts), so [`crate::arena_bytes`] can promise a bound only
    /// because core holds meshing to it: a round may use this, plus whatever
    /// the earlier stages left of their worst cases, and a denser graph fails
    /// with [`Error::MeshCapacity`], whatever the buffer's size. 0 (the default)
    /// means `400 √k` bytes (1385 at k = 12; the candidate graph grows about
    /// like the neighbourhood's radius). Chosen from measurements
    /// (`bench/notes.md`): enough for clouds with 12 or more points per cluster
    /// of the cap, while [`crate::arena_bytes`] stays within twice the peak.
    pub mesh_bytes_per_cluster: u32,
    /// Statistical outlier filter of the cleaning pre-pass ([`crate::clean()`]),
    /// in standard deviations: a point whose mean distance to its `k` nearest
    /// neighbours exceeds the mean of that distance over all points by more than
    /// this many standard deviations is removed. Finite, `>= 0`; 0 turns the
    /// filter off. Usual values 2 to 3. Default 0 (off).
    pub outlier_sigma: f32,
    /// Fragment filter of the cleaning pre-pass ([`crate::clean()`]): connected
    /// pieces of the cloud (neighbours no farther apart than
    /// [`crate::prepass::clean::LINK_SPACINGS`] average spacings) with fewer points than
    /// this are dropped; the largest piece is always kept. 0 turns the filter
    /// off. Default 64.
    pub min_fragment: u32,
    /// Rounds of smoothing before reconstruction ([`crate::prepass::smooth::smooth`]):
    /// each moves every point onto the least-squares plane of its 24 nearest
    /// neighbours. For noise near the point spacing (about 1 % of the diagonal);
    /// rounds sharp edges. Default 0 (off).
    pub smooth_rounds: u32,
}

/// Fewest clusters [`crate::reconstruct`] takes: the four corners of a
/// tetrahedron, the least closed surface.
pub const MIN_MESH_CLUSTERS: u32 = 4;

/// Smallest [`Params::epsilon`] [`crate::reconstruct`] takes: the relative
/// precision of `f32` (`f32::EPSILON`, about `1.19e-7`), the spacing of the
/// coordinates near 1 in `[-1, 1]`. Below it, a point's distance to a facet is
/// rounding, and at about `1e-19` its square is 0 in `f32`.
pub const MIN_EPSILON: f32 = f32::EPSILON;

/// Meshing rounds at most that an error bound ([`Params::max_error`]) runs
/// after the first. Each adds a generator in every cluster with a point beyond
/// the bound, so the cluster count can grow by that much per round.
pub const MAX_ERROR_ROUNDS: u32 = 16;

/// Meshing rounds at most for the genus, after the refinement rounds
/// ([`Params::refine_rounds`]): while faces of the mesh span a gap in the data
/// (a slot or a tunnel the clusters straddle, so the mesh closes it: a wrong
/// genus), a generator goes to the gap's rim and the mesh is made again. Only
/// the rims are refined in these rounds (far points wait for the ordinary
/// ones), and they run only where the refinement distance is finite, the
/// clusters hold at least `k` points each on average and the last round's
/// mesh had no boundary (closed data). On the shared clouds the gear at 250
/// clusters runs 3 (its hub's radial holes, 0.1 wide, take one to three
/// generators a round), the gear at 500 and the horse at 250 one each.
pub const GAP_ROUNDS: u32 = 4;

/// The room beyond the cluster cap ([`Params::cluster_cap`]) for generators
/// at the rims of gaps and for splitting clusters the mesh leaves out, as a
/// divisor of the cap: a thirty-second. Splitting can take the whole cap, and
/// a wrong genus or data left out is worse than a few more vertices (the gear
/// at 250 clusters: splitting ends at 486 of 500, then 20 generators in 5
/// rounds open its last hole, 6 of them past the cap; at seed 5 splitting
/// ends at 495 and the mesh left 36 clusters, 908 points, out). Kept
/// small because the meshing capacity is budgeted for every cluster of it
/// (a sixteenth put a sphere's budget above twice its peak).
pub const GAP_ROOM: u32 = 32;

/// How clustering partitions the points among the generators in each pass.
/// Either way every point takes a cluster its neighbours reach, every
/// cluster is connected and holds its seed, and the result does not depend
/// on the thread count.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Partition {
    /// [`Partition::Sweep`] from [`SWEEP_MIN_POINTS`] points on,
    /// [`Partition::Grow`] below.
    #[default]
    Auto,
    /// Region growing from the seeds over one priority queue, cheapest point
    /// first, every pass from scratch: one thread.
    Grow,
    /// Synchronous sweeps in parallel: each point takes the cheapest of its
    /// neighbours' clusters until none changes, each pass starting from the
    /// last one's labels. Each point ends with the least cost its neighbours
    /// offer (region growing settles a point before every offer is in), so
    /// the clusters, and the meshes, differ from `Grow`'s.
    Sweep,
}

/// Points from which [`Partition::Auto`] sweeps. Below, region growing is
/// faster on one thread, and its meshes are the ones the comparison with
/// Open3D and MeshLab was run on (the shared clouds are all smaller); swept,
/// they are as often valid solids of their true genus, but their distances
/// have not been through that comparison (`bench/notes.md`). From a million
/// points sweeps take half the time on one thread (a pass after the first
/// recomputes only the borders between clusters) and use every core.
pub const SWEEP_MIN_POINTS: usize = 131_072;

impl Partition {
    /// Whether `n` points are partitioned by sweeps.
    pub fn sweeps(self, n: usize) -> bool {
        match self {
            Partition::Auto => n >= SWEEP_MIN_POINTS,
            Partition::Grow => false,
            Partition::Sweep => true,
        }
    }
}

impl Default for Params {
    fn default() -> Self {
        Params {
            k: 12,
            clusters: 1000,
            max_clusters: 0,
            iterations: 5,
            split_iterations: 2,
            split_rounds: 5,
            tolerance: 0.005,
            lambda: 0.001,
            seed: 1,
            epsilon: 0.01,
            alpha_scale: 5.0,
            fitting_weight: 0.4,
            coverage_weight: 0.3,
            border_penalty: 2.0,
            max_hole: 64,
            border_angle: 150.0,
            partition: Partition::Auto,
            node_limit: 200,
            fit_rounds: 2,
            densify: 0.1,
            refine_rounds: 2,
            max_error: 0.0,
            refine_beyond: 0.0075,
            mesh_bytes_per_cluster: 0,
            outlier_sigma: 0.0,
            min_fragment: 64,
            smooth_rounds: 0,
        }
    }
}

impl Params {
    /// Meshing rounds refinement may run after the first: `refine_rounds`, or
    /// at least [`MAX_ERROR_ROUNDS`] with an error bound.
    pub fn refinement_rounds(&self) -> u32 {
        if self.max_error > 0.0 {
            self.refine_rounds.max(MAX_ERROR_ROUNDS)
        } else {
            self.refine_rounds
        }
    }

    /// The largest distance from a point to the mesh that `max_error` allows,
    /// for a cloud of bounding-box diagonal `diag` (just inside the bound, so
    /// that an evaluation in other units still finds it met); infinite without
    /// a bound.
    pub fn max_distance(&self, diag: f32) -> f32 {
        if self.max_error > 0.0 {
            self.max_error * diag * (1.0 - 1e-4)
        } else {
            f32::INFINITY
        }
    }

    /// How far a point may be from the mesh before a refinement round runs
    /// for it: the error bound when there is one ([`Params::max_distance`]),
    /// else `refine_beyond` of the diagonal; infinite when neither is set.
    pub fn refine_distance(&self, diag: f32) -> f32 {
        if self.max_error > 0.0 {
            self.max_distance(diag)
        } else if self.refine_beyond > 0.0 {
            self.refine_beyond * diag
        } else {
            f32::INFINITY
        }
    }

    /// The cluster cap splitting works towards, and refinement's but at the
    /// rims of gaps.
    pub fn cluster_cap(&self) -> u32 {
        if self.max_clusters == 0 {
            self.clusters.saturating_mul(2)
        } else {
            self.max_clusters.max(self.clusters)
        }
    }

    /// The most clusters a run can hold: the cap and a [`GAP_ROOM`]th of it
    /// for generators at the rims of gaps the faces span and in clusters the
    /// mesh leaves out.
    pub fn cluster_limit(&self) -> u32 {
        let cap = self.cluster_cap();
        cap.saturating_add(cap / GAP_ROOM)
    }

    /// Meshing working memory per cluster of the cap, in bytes (see
    /// [`Params::mesh_bytes_per_cluster`]).
    pub fn mesh_capacity_per_cluster(&self) -> usize {
        if self.mesh_bytes_per_cluster == 0 {
            let k = self.k.clamp(1, MAX_K) as f32;
            (400.0 * libm::sqrtf(k)) as usize
        } else {
            self.mesh_bytes_per_cluster as usize
        }
    }

    /// Whether [`crate::clean()`] has anything to do: one of its filters is on.
    pub fn cleans(&self) -> bool {
        self.outlier_sigma > 0.0 || self.min_fragment > 0
    }

    /// Whether [`crate::reconstruct`] can make a mesh under these parameters
    /// at all, whatever the cloud: at least [`MIN_MESH_CLUSTERS`] clusters, a
    /// facet score with a positive weight, and `epsilon` at least
    /// [`MIN_EPSILON`]. Clustering alone ([`crate::cluster`]) needs none of
    /// this. O(1).
    pub fn meshable(&self) -> core::result::Result<(), Unmeshable> {
        if self.clusters < MIN_MESH_CLUSTERS {
            return Err(Unmeshable::TooFewClusters {
                clusters: self.clusters,
            });
        }
        if self.fitting_weight == 0.0 && self.coverage_weight == 0.0 {
            return Err(Unmeshable::NoScore);
        }
        if self.epsilon < MIN_EPSILON {
            return Err(Unmeshable::EpsilonBelowPrecision {
                epsilon: self.epsilon,
            });
        }
        Ok(())
    }

    /// Check every field against its documented range.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, value: f32| Err(Error::BadParameter { name, value });
        if self.clusters == 0 {
            return bad("clusters", 0.0);
        }
        if !(self.tolerance.is_finite() && self.tolerance >= 0.0) {
            return bad("tolerance", self.tolerance);
        }
        if !(self.lambda.is_finite() && self.lambda >= 0.0) {
            return bad("lambda", self.lambda);
        }
        for (name, v) in [
            ("epsilon", self.epsilon),
            ("alpha_scale", self.alpha_scale),
            ("fitting_weight", self.fitting_weight),
            ("coverage_weight", self.coverage_weight),
            ("border_penalty", self.border_penalty),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(name, v);
            }
        }
        if !(self.densify.is_finite() && (0.0..=1.0).contains(&self.densify)) {
            return bad("densify", self.densify);
        }
        if !(self.max_error.is_finite() && self.max_error >= 0.0) {
            return bad("max_error", self.max_error);
        }
        if !(self.refine_beyond.is_finite() && self.refine_beyond >= 0.0) {
            return bad("refine_beyond", self.refine_beyond);
        }
        if !(self.outlier_sigma.is_finite() && self.outlier_sigma >= 0.0) {
            return bad("outlier_sigma", self.outlier_sigma);
        }
        if !(self.border_angle.is_finite() && self.border_angle > 0.0 && self.border_angle <= 360.0)
        {
            return bad("border_angle", self.border_angle);
        }
        if self.epsilon <= 0.0 {
            return bad("epsilon", self.epsilon);
        }
        if self.clusters >= 1 << 30 {
            return bad("clusters", self.clusters as f32);
        }
        if self.max_clusters >= 1 << 30 {
            return bad("max_clusters", self.max_clusters as f32);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{reconstruct, sample, Arena, Silent};
    use core::mem::MaybeUninit;

    #[test]
    fn meshable_refuses_exactly_what_cannot_give_a_mesh() {
        let ok = Params::default();
        assert_eq!(ok.meshable(), Ok(()));
        let p = |f: fn(&mut Params)| {
            let mut p = Params::default();
            f(&mut p);
            p.meshable()
        };
        assert_eq!(
            p(|p| p.clusters = 3),
            Err(Unmeshable::TooFewClusters { clusters: 3 })
        );
        assert_eq!(p(|p| p.clusters = MIN_MESH_CLUSTERS), Ok(()));
        assert_eq!(
            p(|p| {
                p.fitting_weight = 0.0;
                p.coverage_weight = 0.0
            }),
            Err(Unmeshable::NoScore)
        );
        assert_eq!(p(|p| p.fitting_weight = 0.0), Ok(()));
        assert_eq!(p(|p| p.coverage_weight = 0.0), Ok(()));
        assert_eq!(
            p(|p| p.epsilon = 1e-45),
            Err(Unmeshable::EpsilonBelowPrecision { epsilon: 1e-45 })
        );
        assert_eq!(p(|p| p.epsilon = MIN_EPSILON), Ok(()));
    }

    #[test]
    fn reconstruct_refuses_unmeshable_parameters_before_any_work() {
        // An arena of no bytes: any work would run out of it first.
        let mut points = [[0.0f32; 3]; 500];
        sample::fill(sample::Shape::Sphere, 1, 0.0, &mut points);
        let mut buf: [MaybeUninit<u8>; 0] = [];
        let arena = Arena::new(&mut buf);
        let params = Params {
            clusters: 3,
            ..Params::default()
        };
        let r = reconstruct(&arena, &points, None, &params, &mut Silent);
        assert!(matches!(
            r,
            Err(Error::Unmeshable(Unmeshable::TooFewClusters {
                clusters: 3
            }))
        ));
    }
}
