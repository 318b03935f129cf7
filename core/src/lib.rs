//! # vsaqem-core
//!
//! Variational Shape Reconstruction via Quadric Error Metrics (VSA-QEM) for point
//! clouds, in a fixed amount of memory that the caller supplies.
//!
//! `#![no_std]`, no `alloc`, no global allocator: every byte comes from an [`Arena`]
//! over a caller-owned buffer, and running out of it is an [`Error::Exhausted`]
//! value, never a panic. Core never panics on any input.
//!
//! How big a buffer: [`arena_bytes`]`(n, &params)` is always enough for
//! [`reconstruct`] on `n` points (an upper bound worked out stage by stage in
//! [`budget`], not an estimate), about 140 bytes per point at k = 12 plus some 2
//! KiB per cluster.
//!
//! ```
//! use core::mem::MaybeUninit;
//! use vsaqem_core::{arena_bytes, reconstruct, Arena, Params, Silent};
//! # let mut points = [[0.0f32; 3]; 3000];
//! # vsaqem_core::sample::fill(vsaqem_core::sample::Shape::Sphere, 1, 0.0, &mut points);
//! let params = Params { clusters: 100, ..Params::default() };
//! let mut buf = vec![MaybeUninit::uninit(); arena_bytes(points.len(), &params)];
//! let arena = Arena::new(&mut buf);
//! let out = reconstruct(&arena, &points, None, &params, &mut Silent).unwrap();
//! assert!(!out.mesh.triangles.is_empty());
//! ```
//!
//! ## Conventions
//! - Coordinates are `f32` and expected in `[-1, 1]^3`: the host centres and scales
//!   its `f64` input into that cube and maps results back. Core works on any finite
//!   input, but `f32` quadric solves lose precision far from the origin.
//! - Structure of arrays, `u32` indices (so at most `u32::MAX - 1` points).
//! - Reductions over many values (cluster quadrics, averages) accumulate in `f64`.
//! - Deterministic: the same input and [`Params`] give bit-identical results.
//! - Threads are the caller's: stages whose work splits into independent parts
//!   (the k-NN queries and the reverse-neighbour table, the plane quadrics,
//!   the generator updates, the facet selection's cache refreshes and root
//!   sweeps (level by level), the point-to-mesh distances, the fit's searches, the
//!   crossing-face test and the gap search) are cut into a fixed
//!   number of tasks ([`parallel`]) that the caller's [`Progress::run`] may run
//!   on any threads; the result is the same bytes for every thread count.
//!
//! ## The pipeline
//! The folders are its phases, and each file in them one stage, in the order data
//! flows. Equations are those of the seed paper (Zhao et al., SIGGRAPH 2023).
//!
//! **Pre-passes** ([`prepass`], optional; the caller runs them and compacts the
//! points they keep before reconstructing):
//! - [`mark_duplicates`]: exact duplicates (bitwise-equal positions), the
//!   first of each kept; before anything else, since piles of copies defeat
//!   the neighbour search and look like surface to the fragment filter.
//!   [`mark_duplicates_hashed`] gives the same marks faster, with twice the
//!   scratch.
//! - [`clean()`]: statistical outliers and small isolated fragments, on the exact
//!   k-NN graph; its arena bound is [`clean_bytes`], never more than
//!   [`arena_bytes`]. [`clean_with_rows`] also hands back that graph, which
//!   [`reconstruct_with_rows`] takes instead of searching again when every
//!   point was kept.
//! - [`smooth()`]: points onto the least-squares plane of
//!   their neighbours.
//!
//! **Clustering** ([`clustering`]; [`cluster`] runs it alone):
//! 1. [`validate`]: finite input, enough points, a usable `k`, points that span a
//!    surface; the bounding box.
//! 2. [`knn`](clustering::knn): certified k nearest neighbours from a sparse
//!    grid, and the symmetrised graph.
//! 3. [`normals`](clustering::normals) and [`quadric`](clustering::quadric):
//!    given normals or neighbourhood PCA; area-weighted plane quadrics and their
//!    diffusion (Eq. 1-3).
//! 4. [`partition`](clustering::partition): seeded initialisation, region-growing
//!    partition (Eq. 4), QEM-optimal generators (Eq. 5), alternated with
//!    [`split`](clustering::split): batch splitting where a point's error
//!    exceeds the tolerance (Eq. 6).
//!
//! **Meshing** ([`meshing`], one round in a scratch scope):
//! 5. [`candidates`](meshing::candidates): candidate edges, facets (3-cycles)
//!    and fold groups; [`border`](meshing::border): clusters where the data
//!    ends.
//! 6. [`score`](meshing::score): facet fitting and coverage (Eq. 9-10).
//! 7. [`problem`](meshing::problem) and [`select`](meshing::select): the exact 0/1 choice of
//!    facets under the edge rule (Eq. 7-8), by branch-and-bound.
//! 8. [`output`](meshing::output): an oriented, edge- and vertex-manifold mesh;
//!    small holes closed, loops along the data's border kept open; its vertices
//!    then [`fit`](meshing::fit) to the data by regularised least squares
//!    (boundary vertices stay, no face turns over), and the points' distances
//!    to it measured.
//! 9. Refinement ([`Params::refine_rounds`]): where a round leaves clusters without
//!    a face, they are split (past the cluster cap if need be, up to
//!    [`Params::cluster_limit`]) and the mesh is made again; after those
//!    rounds, one more for clusters still left out, kept only if its mesh
//!    leaves out no more points.
//!
//! **Infrastructure** beside the phases: [`arena`] (the only memory), [`budget`]
//! (how much of it a run can need), [`frame`] (into core's coordinates and
//! back), [`params`], [`error`], [`progress`]
//! (reporting and cancellation), [`math`] (vectors, the symmetric 3x3
//! eigenproblem), [`rng`] (the seeded generator), [`union_find`] and [`sample`]
//! (generated shapes for tests, benchmarks and demos).
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]
#![allow(clippy::needless_range_loop)]

#[cfg(test)]
extern crate std;

pub mod arena;
pub mod budget;
pub mod error;
pub mod frame;
pub mod hint;
pub mod math;
pub mod parallel;
pub mod params;
pub mod progress;
pub mod rng;
pub mod sample;
pub mod union_find;
pub mod validate;

pub mod clustering;
pub mod meshing;
pub mod prepass;

pub use arena::{Alloc, Arena, Exhausted, Scratch};
pub use budget::{
    arena_bytes, clean_bytes, clean_bytes_for, cluster_bytes, cluster_bytes_for, mesh_capacity,
    reconstruct_bytes_for,
};
pub use clustering::knn::Neighbours;
pub use clustering::partition::{ClusterStats, Clusters};
pub use clustering::quadric::Planes;
pub use clustering::{Clustered, Stats};
pub use error::{Degeneracy, Error, Result, Unmeshable};
pub use frame::Frame;
pub use math::V3;
pub use meshing::distance::MeshDistance;
pub use meshing::fit::FitStats;
pub use meshing::output::{Mesh, MeshStats};
pub use meshing::problem::{selection_problem, SelectionProblem};
pub use meshing::select::SelectStats;
pub use meshing::MeshingStats;
pub use parallel::Task;
pub use params::{
    Params, Partition, GAP_ROUNDS, MAX_ERROR_ROUNDS, MAX_K, MIN_EPSILON, MIN_MESH_CLUSTERS,
    SWEEP_MIN_POINTS,
};
pub use prepass::clean::{clean, clean_with_rows, CleanStats};
pub use prepass::duplicates::{mark_duplicates, mark_duplicates_hashed};
pub use prepass::smooth::{smooth, smooth_bytes};
pub use progress::{Flow, Progress, Silent, Stage};
pub use validate::Bounds;

use meshing::output::{Cover, Output};

/// The clustering half of VSA-QEM: neighbours, quadrics, partition and splitting.
///
/// `points` should lie in `[-1, 1]^3` (see the crate docs); `normals`, when given,
/// are used where finite and non-zero. Fails with a typed error on bad input or
/// when `arena` is too small; never panics.
pub fn cluster<'a>(
    arena: &'a Arena,
    points: &[V3],
    normals: Option<&[V3]>,
    params: &Params,
    progress: &mut dyn Progress,
) -> Result<Clustered<'a>> {
    cluster_with_rows(arena, points, normals, None, params, progress)
}

/// [`cluster`] on the k-NN table the caller already has for these points, when
/// given (see [`reconstruct_with_rows`]).
pub fn cluster_with_rows<'a>(
    arena: &'a Arena,
    points: &[V3],
    normals: Option<&[V3]>,
    rows: Option<&Rows<'a>>,
    params: &Params,
    progress: &mut dyn Progress,
) -> Result<Clustered<'a>> {
    let need = budget::cluster_bound_for;
    Ok(
        clustering::try_clustering_in(arena, points, normals, rows, params, need, progress)?
            .close(arena),
    )
}

/// A k-NN table of a set of points, as [`clean_with_rows`] writes it: row `i`
/// (`knn[i * k..(i + 1) * k]`, `k` = [`Params::k`]) lists the `k` nearest
/// other points of `i`, nearest first, ties by index.
#[derive(Clone, Copy, Debug)]
pub struct Rows<'r> {
    /// The table.
    pub knn: &'r [u32],
    /// Queries of it that fell back to a linear scan (for the statistics).
    pub linear_scans: u32,
}

/// A reconstruction: the mesh and how it was made.
pub struct Reconstruction<'a> {
    /// Everything clustering produced.
    pub clustered: Clustered<'a>,
    /// The mesh, in core coordinates.
    pub mesh: Mesh<'a>,
    /// Statistics of the meshing half.
    pub meshing: MeshingStats,
}

/// The whole of VSA-QEM: [`cluster`], then rounds of meshing (candidates, scores,
/// exact selection, a 2-manifold oriented mesh). Where a round leaves clusters
/// (data) uncovered, those clusters are split and the mesh is made again, up to
/// `params.refine_rounds` times. Parameters that cannot give a mesh of any
/// cloud ([`Params::meshable`]) fail with [`Error::Unmeshable`] before any
/// work; the mesh may still come out empty (no face selected), which the
/// caller sees in [`MeshStats::faces`].
///
/// Memory: never more than [`arena_bytes`]`(points.len(), params)` beyond what
/// `arena` already holds, so a buffer of that size never runs out. A candidate
/// graph denser than the meshing capacity allows
/// ([`Params::mesh_bytes_per_cluster`]) fails with [`Error::MeshCapacity`], even in
/// a larger buffer: a buffer of that size or more always gives the same outcome.
/// A smaller one is checked against what this cloud needs
/// ([`reconstruct_bytes_for`]; [`Error::ArenaTooSmall`] when short) and then
/// gives the same mesh, or [`Error::ArenaTooSmallForMeshing`] where meshing
/// needed more than its capacity.
pub fn reconstruct<'a>(
    arena: &'a Arena,
    points: &[V3],
    normals: Option<&[V3]>,
    params: &Params,
    progress: &mut dyn Progress,
) -> Result<Reconstruction<'a>> {
    reconstruct_with_rows(arena, points, normals, None, params, progress)
}

/// [`reconstruct`] on the k-NN table the caller already has for these points,
/// when given (from [`clean_with_rows`], when cleaning kept every point): the
/// neighbour search is not run again and the table is borrowed where it lies
/// (so it outlives the results), not copied into `arena`; the result is the
/// same as [`reconstruct`]'s. A
/// table of the wrong length or with an entry out of range or equal to its row
/// fails with [`Error::BadNeighbourTable`]; one that lists other neighbours
/// than the nearest gives another (valid) mesh.
pub fn reconstruct_with_rows<'a>(
    arena: &'a Arena,
    points: &[V3],
    normals: Option<&[V3]>,
    rows: Option<&Rows<'a>>,
    params: &Params,
    progress: &mut dyn Progress,
) -> Result<Reconstruction<'a>> {
    params.meshable().map_err(Error::Unmeshable)?;
    // Meshing may use what the worst-case budget leaves (at least its
    // capacity, more where the earlier stages used less than their worst
    // case), never more: so the outcome does not depend on the buffer's size.
    // A buffer smaller than that budget but as large as this cloud needs
    // (checked in the clustering) gives the same mesh, or fails with
    // `ArenaTooSmall` where meshing needed more than its capacity.
    let end = arena
        .used()
        .saturating_add(budget::reconstruct_bound(points.len(), params));
    let need = budget::reconstruct_bound_for;
    let mut clustering =
        clustering::try_clustering_in(arena, points, normals, rows, params, need, progress)?;
    // Points farther than this from the mesh call for a refinement round.
    let max_distance = params.refine_distance(clustering.bounds.diag);
    // Clusters a round leaves without a face, for refinement: one buffer for all
    // rounds, so a round leaves nothing behind but, when it is the last, the mesh.
    let uncovered = arena.try_alloc_slice::<u32>(clustering.state.limit(), 0)?;
    let mut rounds = 0;
    let mut gap_rounds = 0;
    let mut added = 0;
    let mut last = false;
    // Whether the last round's mesh had a boundary (open data). Rounds for
    // the genus are for closed surfaces and do not run then: the raw scan at
    // 500 clusters ran one, for one generator, and its farthest kept point
    // went from 1.24 to 2.30 % of the diagonal. On open data a far point that
    // is a cluster of its own refines at a neighbour
    // ([`ClusterState::refine_at`](clustering::partition::ClusterState::refine_at)).
    let mut open = false;
    // A round that only asked for cover found nothing to split, or a split
    // past the cap was undone.
    let mut cover_done = false;
    // After clusters left out were split past the cap, or generators put at
    // the rims of gaps in a round that also left clusters out: the clusters
    // before (kept by a checkpoint), the points that round left out, the
    // generators it added and what the round did. The next round is judged
    // on the points it leaves out.
    let mut judged: Option<(usize, u32, u32, Judged)> = None;
    // Rims were judged no help to the data left out: split first.
    let mut splits_first = false;
    // Rounds for clusters left out, after the refinement rounds: each
    // judged by the next mesh (undone, and the last, when that leaves out
    // more points); the points the last mesh left out.
    let mut cover_rounds = 0;
    let mut cover_stop = false;
    let mut left_out = 0u32;
    let (mesh, meshing) = loop {
        // The last round writes the mesh out; an earlier one only when it covers
        // every cluster and meets the error bound (otherwise refinement follows
        // and the mesh would be waste). After the refinement rounds, rounds for
        // the genus write it out unless faces span a gap in the data. While
        // refinement rounds are left, a round with no room under the cap still
        // splits the clusters it leaves out, past the cap (the gear at 250
        // clusters, seed 5: splitting took 495 of the 500, and 36 clusters,
        // 908 points, stayed out of the mesh).
        let state = &clustering.state;
        let covered = judged.is_some()
            || (!cover_done
                && rounds < params.refinement_rounds()
                && state.limit_room() > 0
                && params.max_error <= 0.0);
        let cover_round = params.refine_rounds > 0
            && rounds >= params.refinement_rounds()
            && !cover_stop
            && cover_rounds < COVER_ROUNDS
            && left_out > 0
            && state.limit_room() > 0
            && state.can_checkpoint()
            && params.max_error <= 0.0;
        let output = if last {
            Output::Always
        } else if rounds < params.refinement_rounds() && state.room() > 0 {
            Output::IfFaithful { max_distance }
        } else if gap_rounds < GAP_ROUNDS
            && state.limit_room() > 0
            && max_distance.is_finite()
            && !open
            && coarse(points.len(), state.view().generators.len(), params)
        {
            // Rims first: where faces span a gap, the data beside it is often
            // what the mesh leaves out (the gear at 250 clusters, 20
            // iterations, seed 3: 60 clusters left out, 1 after a round of
            // rims).
            let cover = match (covered, splits_first) {
                (false, _) => Cover::No,
                (true, false) => Cover::After,
                (true, true) => Cover::First,
            };
            Output::IfNoGaps {
                max_distance,
                covered: cover,
            }
        } else if covered || cover_round {
            match judged {
                // The last round for clusters left out: its mesh is the
                // answer unless it leaves out more points than the one before.
                Some((_, before, _, Judged::Cover)) if !cover_round => {
                    Output::IfNoWorse { left_out: before }
                }
                _ => Output::IfCovered,
            }
        } else {
            Output::Always
        };
        let cover_round = cover_round && matches!(output, Output::IfCovered);
        let (mesh, stats) = mesh_round_within(arena, end, || {
            meshing::try_mesh_round_in(
                arena,
                points,
                &clustering.neighbours,
                &clustering.planes,
                clustering.bounds.diag,
                &clustering.state.view(),
                params,
                output,
                uncovered,
                progress,
            )
        })?;
        if let Some(mesh) = mesh {
            break (mesh, stats);
        }
        // Add generators at the points farthest beyond the bound and at the
        // rims of gaps the faces span, or else split the clusters left out (at
        // their worst point).
        let (n_out, n_far) = (stats.mesh.uncovered_clusters, stats.mesh.far_clusters);
        // A judged round (rims, or a split past the cap, after a mesh that
        // left clusters out) is undone when this mesh leaves out as many
        // points (rims) or more (a split), and the rounds go on from the
        // clusters before it: after rims, splitting the clusters left out
        // first (the gear at 250 clusters, seed 5: the rims left 36 clusters,
        // 908 points, out; the splits none); after a split, without such
        // splits, as they would have (the armadillo at 250 clusters: 379
        // points left out before a split, 492 after).
        if let Some((m, before, more, kind)) = judged.take() {
            let left = stats.mesh.uncovered_points;
            let worse = match kind {
                Judged::Rims => left >= before,
                Judged::Split | Judged::Cover => left > before,
            };
            if n_out > 0 && worse {
                let (nb, planes) = (&clustering.neighbours, &clustering.planes);
                let state = &mut clustering.state;
                state.restore(arena, points, nb, planes, m, params, progress)?;
                match kind {
                    Judged::Rims => {
                        gap_rounds -= 1;
                        splits_first = true;
                    }
                    Judged::Cover => {
                        cover_rounds -= 1;
                        cover_stop = true;
                    }
                    Judged::Split => {
                        rounds -= 1;
                        cover_done = true;
                    }
                }
                added -= more;
                continue;
            }
        }
        open = stats.mesh.boundary_edges > 0;
        left_out = stats.mesh.uncovered_points;
        let len = uncovered.len();
        let targets = &uncovered[..(n_out.max(n_far) as usize).min(len)];
        let rims_from = (n_far.saturating_sub(stats.mesh.gap_rims) as usize).min(len);
        let (far, rims) = targets.split_at(rims_from.min(targets.len()));
        let (state, nb, planes) = (
            &mut clustering.state,
            &clustering.neighbours,
            &clustering.planes,
        );
        // Rounds for the genus (rims of gaps found) and for clusters left out
        // go past the cap.
        let genus = matches!(output, Output::IfNoGaps { .. }) && n_far > 0;
        // A round judged by the next mesh: rims in a round that also left
        // clusters out, or a split of clusters left out that goes past the
        // cap (kept clusters: at most the cap, so only a split past it).
        let m = state.view().generators.len();
        let left = stats.mesh.uncovered_points;
        let after = matches!(
            output,
            Output::IfNoGaps {
                covered: Cover::After,
                ..
            }
        );
        let judge_rims = genus && left > 0 && after;
        let judge_split = n_far == 0 && params.max_error <= 0.0;
        let kept = (judge_rims || judge_split) && state.checkpoint();
        let more = if n_far > 0 {
            state.refine_at(
                arena, points, nb, planes, far, rims, genus, open, params, progress,
            )?
        } else {
            state.refine(arena, points, nb, planes, targets, params, progress)?
        };
        if kept && more > 0 && (judge_rims || state.past_cap() || cover_round) {
            let kind = if judge_rims {
                Judged::Rims
            } else if cover_round {
                Judged::Cover
            } else {
                Judged::Split
            };
            judged = Some((m, left, more as u32, kind));
        }
        if more == 0 {
            // Nothing to split. After a round that only asked for cover (no
            // room under the cap), the rounds go on as they would have without
            // it (the same clusters: the next round makes the same mesh and
            // judges it as before). Otherwise, a round for clusters still left
            // out among them, this round's mesh is the answer: make it again,
            // written out (same clusters, same mesh).
            let cover_only = matches!(output, Output::IfCovered | Output::IfNoGaps { .. });
            if cover_only && n_far == 0 && !cover_done && !cover_round {
                cover_done = true;
            } else {
                last = true;
            }
            continue;
        }
        if genus {
            gap_rounds += 1;
        } else if cover_round {
            cover_rounds += 1;
        } else {
            rounds += 1;
        }
        added += more as u32;
    };
    let meshing = MeshingStats {
        peak: arena.peak(),
        refine_rounds: rounds + cover_rounds,
        gap_rounds,
        refine_added: added,
        ..meshing
    };
    Ok(Reconstruction {
        clustered: clustering.close(arena),
        mesh,
        meshing,
    })
}

/// What a round judged by the next mesh did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Judged {
    /// Put generators at the rims of gaps (undone when the next mesh leaves
    /// out as many points).
    Rims,
    /// Split clusters left out past the cap (undone when it leaves out more).
    Split,
    /// A round for clusters still left out after the refinement rounds
    /// (undone, and the last, when it leaves out more).
    Cover,
}

/// Rounds for clusters still left out after the refinement rounds (none when
/// they are off), each judged by the next mesh: undone, and that mesh made
/// again from the clusters before it, when it leaves out more points. The
/// raw scan at 500 clusters: 501 points left out after two rounds, 31 after
/// this one (`bench/notes.md`).
const COVER_ROUNDS: u32 = 1;

/// Whether `clusters` clusters of `n` points are coarser than the sampling:
/// at least `k` points each on average. Only then do rounds for the genus
/// run: a gap narrower than the clusters is what they open, and where the
/// clusters are about as fine as the sampling, a face far from every point
/// spans a sparsely sampled part of the surface instead (the flat faces of a
/// CAD model's vertices: the fandisk at 2,000 clusters, 3 points each, ran 3
/// rounds for its rims, with no change to the genus, for 2.3 times the time).
fn coarse(n: usize, clusters: usize, params: &Params) -> bool {
    n >= params.k.saturating_mul(clusters)
}

/// Runs a meshing round under the ceiling `end`: running out of memory there is
/// the meshing capacity's limit ([`Error::MeshCapacity`]); running out of a
/// buffer that ends below the ceiling is [`Error::ArenaTooSmallForMeshing`].
fn mesh_round_within<T>(arena: &Arena, end: usize, round: impl FnOnce() -> Result<T>) -> Result<T> {
    let start = arena.used();
    match arena.with_ceiling(end, round) {
        (Err(Error::Exhausted(e)), true) => Err(Error::MeshCapacity {
            capacity: end.saturating_sub(start),
            requested: e.requested,
            available: e.available,
        }),
        // The buffer ended below the ceiling: a larger one would have gone on.
        (Err(Error::Exhausted(_)), false) => Err(Error::ArenaTooSmallForMeshing {
            needed: budget::buffer_for(end),
            capacity: arena.capacity(),
        }),
        (other, _) => other,
    }
}
