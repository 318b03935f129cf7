//! # vsaqem-core
//!
//! Variational Shape Reconstruction via Quadric Error Metrics (VSA-QEM) for point
//! clouds, in a fixed amount of memory that the caller supplies.
//!
//! `#![no_std]`, no `alloc`, no global allocator: every byte comes from an [`Arena`]
//! over a caller-owned buffer, and running out of it is an [`Error::Exhausted`]
//! value, never a panic. Core never panics on any input.
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
pub mod candidates;
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
pub mod split;
pub mod validate;

pub use arena::{Alloc, Arena, Exhausted, Scratch};
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
pub fn reconstruct<'a>(
    arena: &'a Arena,
    points: &[V3],
    normals: Option<&[V3]>,
    params: &Params,
    progress: &mut dyn Progress,
) -> Result<Reconstruction<'a>> {
    let (open, mut state) = cluster_stages(arena, points, normals, params, progress)?;
    let mut rounds = 0;
    let mut added = 0;
    let (mesh, meshing) = loop {
        let (mesh, stats, uncovered) = mesh_round(
            arena,
            points,
            &open.neighbours,
            &open.planes,
            open.bounds.diag,
            &state.view(),
            params,
            progress,
        )?;
        if uncovered.is_empty() || rounds >= params.refine_rounds {
            break (mesh, stats);
        }
        let more = state.refine(
            arena,
            points,
            &open.neighbours,
            &open.planes,
            uncovered,
            params,
            progress,
        )?;
        if more == 0 {
            break (mesh, stats);
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

/// One meshing round in a scratch scope; the mesh and the list of clusters it
/// leaves uncovered stay in the arena.
#[allow(clippy::too_many_arguments)]
fn mesh_round<'a>(
    arena: &'a Arena,
    points: &[V3],
    nb: &Neighbours,
    planes: &Planes,
    diag: f32,
    c: &Clusters,
    params: &Params,
    progress: &mut dyn Progress,
) -> Result<(Mesh<'a>, MeshingStats, &'a [u32])> {
    let gens = c.generators;
    arena.scratch(|s| {
        let p = problem_in(s, points, nb, planes, diag, c, params, progress)?;
        let (cand, members, scores, groups) = (p.cand, p.members, p.scores, p.fold_groups);
        let nf = cand.facets.len();
        progress::tick(progress, Stage::Selection, 0, nf as u64)?;
        let input = p.selection.input(params.node_limit);
        let mut cancelled = false;
        let (selected, sel) = select::try_select_in(arena, &input, &mut |done, total| {
            cancelled = progress::tick(progress, Stage::Selection, done, total).is_err();
            !cancelled
        })?;
        progress::tick(progress, Stage::Output, 0, 1)?;
        let mesh = mesh::try_mesh_in(
            arena,
            s,
            &cand,
            &members,
            selected,
            gens,
            p.open,
            p.moved,
            params.max_hole,
            diag,
        )?;
        // Clusters with points but no face.
        let uncovered = s.scratch(|t| -> Result<&'a [u32]> {
            let used = t.try_alloc_slice::<bool>(gens.len(), false)?;
            for &cl in mesh.vertex_cluster {
                used[cl as usize] = true;
            }
            let count = (0..members.len())
                .filter(|&j| !members.of(j).is_empty() && !used[j])
                .count();
            let list = arena.try_alloc_slice::<u32>(count, 0)?;
            let mut w = 0;
            for j in 0..members.len() {
                if !members.of(j).is_empty() && !used[j] {
                    list[w] = j as u32;
                    w += 1;
                }
            }
            Ok(list)
        })?;
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
                mesh: mesh.stats,
                ..MeshingStats::default()
            },
            uncovered,
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
    let moved = s.try_alloc_copy(gens)?;
    let angle = params.border_angle * (core::f32::consts::PI / 180.0);
    let open =
        border::try_border_clusters_in(s, points, &members, planes, &cand, gens, angle, moved)?;
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
    for (p, e) in penalties[..ne].iter_mut().zip(cand.edges) {
        if !(on_border(e[0]) && on_border(e[1])) {
            *p = params.border_penalty;
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
            node_limit,
            ..select::SelectInput::new(self.rows, self.scores, self.masks.len())
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

/// Arena bytes that are always enough for [`cluster`] on `n` points with `params`:
/// the largest sum of live allocations over the stages, with the reverse-edge table
/// at its worst case (no mutual neighbours). See `../shared/DESIGN.md`, "Memory".
pub fn cluster_bytes(n: usize, params: &Params) -> usize {
    let k = params.k.clamp(1, MAX_K);
    let n = n.max(validate::MIN_POINTS);
    // Every component gets a generator, and a component has at least k + 1 points.
    let cap = (params.cluster_cap() as usize).max(n / (k + 1) + 1).min(n);
    let knn = 4 * k * n + 64;
    let rev = 4 * (n + 1) + 4 * k * n + 128;
    let neighbour_stage = knn + (knn::grid_scratch_bytes(n)).max(rev + 4 * n);
    let planes = 16 * n + 64;
    let cluster_stage = knn + rev + planes + cluster::cluster_bytes(n, cap);
    neighbour_stage.max(cluster_stage)
}

/// Arena bytes for [`reconstruct`] on `n` points: [`cluster_bytes`] plus the
/// meshing stages, estimated at 8 KiB per cluster of the cap and 4 bytes per point
/// (member lists). The meshing part is an estimate, not yet a proven bound.
pub fn reconstruct_bytes(n: usize, params: &Params) -> usize {
    let cap = (params.cluster_cap() as usize).max(1);
    cluster_bytes(n, params) + 4 * n + 8192 * cap
}
