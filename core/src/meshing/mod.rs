//! The meshing half of VSA-QEM: from clusters to an oriented 2-manifold mesh,
//! one file per stage in the order data flows.
//!
//! 1. [`candidates`]: generators closer than a tolerance merged; candidate edges
//!    between clusters whose points are neighbours (plus the diagonals of
//!    4-cycles), candidate facets as the 3-cycles of that graph, fold groups of
//!    facets folded onto each other around an edge.
//! 2. [`border`]: the clusters on the border of the data (where an open surface
//!    or a scan ends), and where their vertices go on it.
//! 3. [`score`]: each facet's data fitting (seed Eq. 9) and coverage (Eq. 10).
//! 4. [`problem`]: the selection problem: a constraint per candidate edge (0 or 2
//!    facets, 1 at a penalty where a border may be) and per fold group (at most
//!    one facet), the facet scores as the objective (Eq. 7-8).
//! 5. [`select`]: the exact 0/1 choice of facets by
//!    branch-and-bound.
//! 6. [`output`]: the selected facets as a mesh: edge- and vertex-manifold,
//!    oriented, small holes closed, loops along the data's border kept open;
//!    [`fit`] then moves its vertices (not the boundary's) onto the data by
//!    regularised least squares, and [`distance`] measures how far the
//!    points are from it.
//!
//! [`reconstruct`](crate::reconstruct) runs one round of these stages in a
//! scratch scope, and another after refinement.

pub mod border;
pub mod candidates;
pub mod distance;
pub mod face_grid;
pub mod fit;
pub mod intersect;
pub mod output;
pub mod problem;
pub mod score;
pub mod select;

use crate::arena::Arena;
use crate::clustering::knn::Neighbours;
use crate::clustering::partition::Clusters;
use crate::clustering::quadric::Planes;
use crate::error::Result;
use crate::math::V3;
use crate::params::Params;
use crate::progress::{tick, Progress, Stage};
use output::{Mesh, MeshStats};
use select::SelectStats;

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
    /// Rounds for the genus run after them ([`crate::params::GAP_ROUNDS`]).
    pub gap_rounds: u32,
    /// Generators added by refinement.
    pub refine_added: u32,
    /// The facet selection (last round).
    pub selection: SelectStats,
    /// The output mesh.
    pub mesh: MeshStats,
    /// Arena peak in bytes at the end.
    pub peak: usize,
}

/// One meshing round (stages 1-6) in a scratch scope: only the mesh (when
/// `output` asks for it) stays in `arena`. The clusters it leaves uncovered are
/// written to `uncovered`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn try_mesh_round_in<'a>(
    arena: &'a Arena,
    points: &[V3],
    nb: &Neighbours,
    planes: &Planes,
    diag: f32,
    c: &Clusters,
    params: &Params,
    output: output::Output,
    uncovered: &mut [u32],
    progress: &mut dyn Progress,
) -> Result<(Option<Mesh<'a>>, MeshingStats)> {
    let gens = c.generators;
    arena.scratch(|s| {
        let p = problem::try_problem_in(s, points, nb, planes, diag, c, params, progress)?;
        let (cand, members, scores, groups) = (p.cand, p.members, p.scores, p.fold_groups);
        let nf = cand.facets.len();
        tick(progress, Stage::Selection, 0, nf as u64)?;
        let input = p.selection.input(params.node_limit);
        let (selected, sel) = select::try_select_with_in(s, &input, &mut *progress)?;
        tick(progress, Stage::Output, 0, 1)?;
        let (mesh, mesh_stats) = output::try_mesh_in(
            arena, s, points, nb, planes, &cand, &members, selected, gens, p.open, p.moved,
            p.piece, params, diag, output, uncovered, &*progress,
        )?;
        tick(progress, Stage::Output, 1, 1)?;
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
