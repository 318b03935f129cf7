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
//!
//! ## The pipeline (see `../shared/DESIGN.md`, steps 1-7)
//! 0. [`clean()`] (optional, a separate pre-pass the caller runs first and
//!    compacts after): statistical outliers and small isolated fragments; its
//!    arena bound is [`clean_bytes`], never more than [`arena_bytes`].
//! 1. [`knn`]: sparse uniform grid and certified k nearest neighbours.
//! 2. [`normals`]: given normals, or PCA of each neighbourhood.
//! 3. [`quadric`]: area-weighted plane quadrics; diffused quadrics (seed Eq. 1-3).
//! 4. [`cluster`]: seeded initialisation, region growing (Eq. 4), QEM-optimal
//!    generators (Eq. 5), with [`split`] (Eq. 6) between rounds.
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]
#![allow(clippy::needless_range_loop)]

#[cfg(test)]
extern crate std;

pub mod arena;
pub mod border;
pub mod budget;
pub mod candidates;
pub mod clean;
pub mod cluster;
pub mod error;
pub mod knn;
pub mod math;
pub mod mesh;
pub mod normals;
pub mod params;
pub mod progress;
pub mod quadric;
pub mod sample;
pub mod score;
pub mod select;
pub mod smooth;
pub mod split;
pub mod validate;

pub use arena::{Alloc, Arena, Exhausted, Scratch};
pub use budget::{arena_bytes, clean_bytes, cluster_bytes, mesh_capacity};
pub use clean::{clean, CleanStats};
pub use cluster::{ClusterStats, Clusters};
pub use error::{Degeneracy, Error, Result};
pub use knn::Neighbours;
pub use math::V3;
pub use mesh::{Mesh, MeshStats};
pub use params::{Params, MAX_K};
pub use progress::{Flow, Progress, Silent, Stage};
pub use quadric::Planes;
pub use select::SelectStats;
pub use validate::Bounds;
// (SelectionProblem is defined below.)

/// Statistics of a run, per stage.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Stats {
    /// Input points.
    pub points: u32,
    /// Neighbours per point.
    pub k: u32,
    /// Average spacing (mean distance to the k nearest neighbours).
    pub spacing: f32,
    /// Points whose neighbour query fell back to a linear scan.
    pub linear_scans: u32,
    /// Reverse-only edges of the symmetrised neighbour graph.
    pub reverse_edges: u32,
    /// Clustering statistics.
    pub cluster: ClusterStats,
    /// Arena peak in bytes after the neighbour stage.
    pub peak_neighbours: usize,
    /// Arena peak in bytes after the quadric stage.
    pub peak_quadrics: usize,
    /// Arena peak in bytes after clustering.
    pub peak_clustering: usize,
}

/// Everything clustering produced, borrowed from the arena.
pub struct Clustered<'a> {
    /// Bounding box of the input.
    pub bounds: Bounds,
    /// The k-NN graph and its symmetrisation.
    pub neighbours: Neighbours<'a>,
    /// Area-weighted plane quadrics.
    pub planes: Planes<'a>,
    /// Labels and generators.
    pub clusters: Clusters<'a>,
    /// Statistics.
    pub stats: Stats,
}

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
    let (open, state) = cluster_stages(arena, points, normals, params, progress)?;
    Ok(open.close(arena, state.freeze()))
}

/// Clustering results before the clusters are final.
struct Open<'a> {
    bounds: Bounds,
    neighbours: Neighbours<'a>,
    planes: Planes<'a>,
    stats: Stats,
}

impl<'a> Open<'a> {
    fn close(self, arena: &Arena, clusters: Clusters<'a>) -> Clustered<'a> {
        let stats = Stats {
            cluster: clusters.stats,
            peak_clustering: self.stats.peak_clustering.max(arena.peak()),
            ..self.stats
        };
        Clustered {
            bounds: self.bounds,
            neighbours: self.neighbours,
            planes: self.planes,
            clusters,
            stats,
        }
    }
}

fn cluster_stages<'a>(
    arena: &'a Arena,
    points: &[V3],
    normals: Option<&[V3]>,
    params: &Params,
    progress: &mut dyn Progress,
) -> Result<(Open<'a>, cluster::ClusterState<'a>)> {
    progress::tick(progress, Stage::Validate, 0, 1)?;
    let bounds = validate::check(points, normals, params)?;
    progress::tick(progress, Stage::Validate, 1, 1)?;
    let neighbours = knn::try_neighbours_in(arena, points, params.k, progress)?;
    let peak_neighbours = arena.peak();
    let planes = quadric::try_planes_in(arena, points, normals, &neighbours, progress)?;
    let peak_quadrics = arena.peak();
    let state = cluster::try_cluster_state_in(
        arena,
        points,
        &neighbours,
        &planes,
        bounds.diag,
        params,
        progress,
    )?;
    let stats = Stats {
        points: points.len() as u32,
        k: params.k as u32,
        spacing: neighbours.spacing,
        linear_scans: neighbours.linear_scans,
        reverse_edges: neighbours.rev.len() as u32,
        cluster: state.stats,
        peak_neighbours,
        peak_quadrics,
        peak_clustering: arena.peak(),
    };
    Ok((
        Open {
            bounds,
            neighbours,
            planes,
            stats,
        },
        state,
    ))
}

/// Statistics of the meshing half.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MeshingStats {
    /// Candidate edges (last round).
    pub candidate_edges: u32,
    /// Candidate facets (last round).
    pub candidate_facets: u32,
    /// Fold groups (sets of facets of which at most one may be used) (last round).
    pub fold_groups: u32,
    /// Clusters on the border of the data (see [`Params::border_angle`]) (last round).
    pub border_clusters: u32,
    /// Facets dropped as degenerate (last round).
    pub degenerate_facets: u32,
    /// Generators merged as coincident (last round).
    pub merged_generators: u32,
    /// Mean supports per facet (last round).
    pub mean_supports: f32,
    /// Refinement rounds run.
    pub refine_rounds: u32,
    /// Generators added by refinement.
    pub refine_added: u32,
    /// The facet selection (last round).
    pub selection: SelectStats,
    /// The output mesh.
    pub mesh: MeshStats,
    /// Arena peak in bytes at the end.
    pub peak: usize,
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

/// The whole of VSA-QEM: [`cluster`], then candidates, scores, exact selection and
/// a 2-manifold oriented mesh (DESIGN steps 8-11). Where the mesh leaves clusters
/// (data) uncovered, those clusters are split and the mesh is made again, up to
/// `params.refine_rounds` times.
///
/// Memory: never more than [`arena_bytes`]`(points.len(), params)` beyond what
/// `arena` already holds, so a buffer of that size never runs out. A candidate
/// graph denser than the meshing capacity allows
/// ([`Params::mesh_bytes_per_cluster`]) fails with [`Error::MeshCapacity`], even in
/// a larger buffer: the outcome never depends on the buffer's size.
pub fn reconstruct<'a>(
    arena: &'a Arena,
    points: &[V3],
    normals: Option<&[V3]>,
    params: &Params,
    progress: &mut dyn Progress,
) -> Result<Reconstruction<'a>> {
    // Meshing may use what the budget leaves (at least its capacity, more where
    // the earlier stages used less than their worst case), never more: so the
    // budget holds, and the outcome does not depend on the buffer's size.
    let end = arena
        .used()
        .saturating_add(budget::reconstruct_bound(points.len(), params));
    let (open, mut state) = cluster_stages(arena, points, normals, params, progress)?;
    // Clusters a round leaves without a face, for refinement: one buffer for all
    // rounds, so a round leaves nothing behind but, when it is the last, the mesh.
    let uncovered = arena.try_alloc_slice::<u32>(state.cap(), 0)?;
    let mut rounds = 0;
    let mut added = 0;
    let mut last = false;
    let (mesh, meshing) = loop {
        // The last round writes the mesh out; an earlier one only when it covers
        // every cluster (otherwise refinement follows and the mesh would be waste).
        last |= rounds >= params.refine_rounds || state.room() == 0;
        let output = if last {
            mesh::Output::Always
        } else {
            mesh::Output::IfCovered
        };
        let start = arena.used();
        let (round, over) = arena.with_ceiling(end, || {
            mesh_round(
                arena,
                points,
                &open.neighbours,
                &open.planes,
                open.bounds.diag,
                &state.view(),
                params,
                output,
                uncovered,
                progress,
            )
        });
        let (mesh, stats) = match round {
            Err(Error::Exhausted(e)) if over => {
                return Err(Error::MeshCapacity {
                    capacity: end.saturating_sub(start),
                    requested: e.requested,
                    available: e.available,
                })
            }
            other => other?,
        };
        if let Some(mesh) = mesh {
            break (mesh, stats);
        }
        let count = stats.mesh.uncovered_clusters as usize;
        let more = state.refine(
            arena,
            points,
            &open.neighbours,
            &open.planes,
            &uncovered[..count.min(uncovered.len())],
            params,
            progress,
        )?;
        if more == 0 {
            // Nothing to split: this round's mesh is the answer. Make it again,
            // written out (same clusters, same mesh).
            last = true;
            continue;
        }
        rounds += 1;
        added += more as u32;
    };
    let meshing = MeshingStats {
        peak: arena.peak(),
        refine_rounds: rounds,
        refine_added: added,
        ..meshing
    };
    let clustered = open.close(arena, state.freeze());
    Ok(Reconstruction {
        clustered,
        mesh,
        meshing,
    })
}

/// One meshing round in a scratch scope: only the mesh (when `output` asks for
/// it) stays in the arena. The clusters it leaves uncovered are written to
/// `uncovered`.
#[allow(clippy::too_many_arguments)]
fn mesh_round<'a>(
    arena: &'a Arena,
    points: &[V3],
    nb: &Neighbours,
    planes: &Planes,
    diag: f32,
    c: &Clusters,
    params: &Params,
    output: mesh::Output,
    uncovered: &mut [u32],
    progress: &mut dyn Progress,
) -> Result<(Option<Mesh<'a>>, MeshingStats)> {
    let gens = c.generators;
    arena.scratch(|s| {
        let p = problem_in(s, points, nb, planes, diag, c, params, progress)?;
        let (cand, members, scores, groups) = (p.cand, p.members, p.scores, p.fold_groups);
        let nf = cand.facets.len();
        progress::tick(progress, Stage::Selection, 0, nf as u64)?;
        let input = p.selection.input(params.node_limit);
        let mut cancelled = false;
        let (selected, sel) = select::try_select_in(s, &input, &mut |done, total| {
            cancelled = progress::tick(progress, Stage::Selection, done, total).is_err();
            !cancelled
        })?;
        progress::tick(progress, Stage::Output, 0, 1)?;
        let (mesh, mesh_stats) = mesh::try_mesh_in(
            arena,
            s,
            points,
            &cand,
            &members,
            selected,
            gens,
            p.open,
            p.moved,
            params.max_hole,
            diag,
            output,
            uncovered,
        )?;
        progress::tick(progress, Stage::Output, 1, 1)?;
        Ok((
            mesh,
            MeshingStats {
                candidate_edges: cand.edges.len() as u32,
                candidate_facets: cand.facets.len() as u32,
                fold_groups: groups,
                border_clusters: p.open.iter().filter(|&&b| b).count() as u32,
                degenerate_facets: cand.degenerate,
                merged_generators: cand.merged,
                mean_supports: scores.mean_supports,
                selection: sel,
                mesh: mesh_stats,
                ..MeshingStats::default()
            },
        ))
    })
}

/// The facet-selection problem of one meshing round and what it was built from.
struct Problem<'s> {
    cand: candidates::Candidates<'s>,
    members: candidates::Members<'s>,
    scores: score::Scores<'s>,
    fold_groups: u32,
    /// Per cluster: on the border of the data.
    open: &'s [bool],
    /// Per cluster on the border of the data: where its vertex goes when it ends on
    /// the mesh's boundary (see [`border::try_border_clusters_in`]).
    moved: &'s [V3],
    selection: SelectionProblem<'s>,
}

/// Candidates, scores, fold groups and the selection constraints (DESIGN steps
/// 8-10) for clusters `c`, allocated from `s`.
#[allow(clippy::too_many_arguments)]
fn problem_in<'s, 'b, A: Alloc<'b>>(
    s: &'s A,
    points: &[V3],
    nb: &Neighbours,
    planes: &Planes,
    diag: f32,
    c: &Clusters,
    params: &Params,
    progress: &mut dyn Progress,
) -> Result<Problem<'s>> {
    let gens = c.generators;
    progress::tick(progress, Stage::Candidates, 0, 1)?;
    let (rep, merged) = candidates::try_merge_in(s, gens, diag)?;
    let members = candidates::try_members_in(s, c.labels, rep)?;
    let cand = candidates::try_candidates_in(s, nb, c.labels, rep, merged, &members, gens, diag)?;
    // Clusters on the border of the data; their vertices move onto it.
    let per_edge = candidates::try_facets_per_edge_in(s, &cand)?;
    let moved = s.try_alloc_copy(gens)?;
    let angle = params.border_angle * (core::f32::consts::PI / 180.0);
    let open = border::try_border_clusters_in(
        s, points, &members, planes, &cand, per_edge, gens, angle, moved,
    )?;
    progress::tick(progress, Stage::Candidates, 1, 1)?;
    progress::tick(progress, Stage::Scoring, 0, 1)?;
    let sp = score::ScoreParams {
        epsilon: params.epsilon,
        alpha_scale: params.alpha_scale,
        fitting: params.fitting_weight,
        coverage: params.coverage_weight,
    };
    let scores = score::try_scores_in(s, points, &members, &cand, gens, nb.spacing, diag, &sp)?;
    progress::tick(progress, Stage::Scoring, 1, 1)?;
    // Constraints: candidate edges (0 or 2 facets) and fold groups (at most one
    // facet per 45-degree wedge around an edge), ids E.. for the groups.
    let groups = candidates::try_fold_groups_in(s, &cand, gens)?;
    let ne = cand.edges.len();
    let nf = cand.facets.len();
    // Edges may end with one facet at `border_penalty`, free between two clusters
    // on the border of the data; groups hold at most one.
    let masks = s.try_alloc_slice::<u8>(ne + groups.count as usize, select::MASK_BORDER)?;
    for m in masks[ne..].iter_mut() {
        *m = select::MASK_AT_MOST_ONE;
    }
    let penalties = s.try_alloc_slice::<f32>(masks.len(), 0.0)?;
    let on_border = |j: u32| open.get(j as usize).copied().unwrap_or(false);
    // An edge with a single candidate facet can never carry two (nothing lies
    // beyond it: the end of a scan, a small piece of surface), so a penalty there
    // would only price its one facet, and the data under it, out of the mesh.
    // Such edges are free, like those between two clusters on the border of the
    // data.
    for ((p, e), &c) in penalties[..ne]
        .iter_mut()
        .zip(cand.edges)
        .zip(per_edge.iter())
    {
        if c >= 2 && !(on_border(e[0]) && on_border(e[1])) {
            *p = params.border_penalty;
        }
    }
    // A facet whose three edges have no other candidate stands alone (a
    // stray triple of clusters): it keeps the penalty, else it would be
    // selected for free as a lone triangle.
    for fe in cand.facet_edges {
        let alone = |e: &u32| per_edge.get(*e as usize).is_some_and(|&c| c < 2);
        if fe.iter().all(alone) {
            for &e in fe {
                let (Some(p), Some(&[a, b])) =
                    (penalties.get_mut(e as usize), cand.edges.get(e as usize))
                else {
                    continue;
                };
                if !(on_border(a) && on_border(b)) {
                    *p = params.border_penalty;
                }
            }
        }
    }
    let rows = s.try_alloc_slice::<[u32; 6]>(nf, [u32::MAX; 6])?;
    for f in 0..nf {
        rows[f] = select::join(cand.facet_edges[f], groups.facet_groups[f], ne as u32);
    }
    Ok(Problem {
        cand,
        members,
        selection: SelectionProblem {
            rows,
            scores: scores.score,
            masks,
            penalties,
        },
        scores,
        fold_groups: groups.count,
        open,
        moved,
    })
}

/// The facet-selection problem (DESIGN step 10) as [`reconstruct`] builds it:
/// one constraint row per candidate facet (its three edges, then its fold groups),
/// the facet scores, and each constraint's mask and border penalty.
#[derive(Clone, Copy, Debug)]
pub struct SelectionProblem<'a> {
    /// Constraint ids of each facet ([`select::UNUSED`] in unused slots).
    pub rows: &'a [[u32; 6]],
    /// Score of each facet.
    pub scores: &'a [f32],
    /// Mask of each constraint (edges first, then fold groups).
    pub masks: &'a [u8],
    /// Penalty of each constraint for ending with one facet.
    pub penalties: &'a [f32],
}

impl SelectionProblem<'_> {
    /// The problem as input to [`select::try_select_in`].
    pub fn input(&self, node_limit: u64) -> select::SelectInput<'_> {
        select::SelectInput {
            edge_mask: Some(self.masks),
            edge_penalty: Some(self.penalties),
            ..select::SelectInput::new(self.rows, self.scores, self.masks.len(), node_limit)
        }
    }
}

/// The selection problem of the first meshing round of [`reconstruct`] for
/// `clustered` (made by [`cluster`] from the same `points` and `params`), kept in
/// `arena`; the candidates and scores it is built from live only in a scratch
/// scope. For oracle tests and for studying the solver on real instances.
pub fn selection_problem<'a>(
    arena: &'a Arena,
    points: &[V3],
    clustered: &Clustered<'_>,
    params: &Params,
) -> Result<SelectionProblem<'a>> {
    arena.scratch(|s| {
        let p = problem_in(
            s,
            points,
            &clustered.neighbours,
            &clustered.planes,
            clustered.bounds.diag,
            &clustered.clusters,
            params,
            &mut Silent,
        )?
        .selection;
        Ok(SelectionProblem {
            rows: arena.try_alloc_copy(p.rows)?,
            scores: arena.try_alloc_copy(p.scores)?,
            masks: arena.try_alloc_copy(p.masks)?,
            penalties: arena.try_alloc_copy(p.penalties)?,
        })
    })
}
