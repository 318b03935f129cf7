//! The facet-selection problem of a meshing round: one constraint per candidate
//! edge and per fold group, the facet scores as the objective (seed Eq. 7-8).
//!
//! - **Edges** may end with 0 or 2 facets, or with 1 at [`Params::border_penalty`]
//!   (a hole edge, or the border of an open surface). The penalty is 0 on an edge
//!   between two clusters on the border of the data, and on an edge with a single
//!   candidate facet (nothing lies beyond it), except where that facet's three
//!   edges all have a single candidate: a lone triangle keeps the penalty.
//! - **Fold groups** hold at most one facet (facets within a small angle of each
//!   other around an edge: a surface never folds back onto itself).
//!
//! Cost: O(F + E) beyond the stages it calls, for F facets and E edges.

use super::border;
use super::candidates::{self, Candidates, Members};
use super::score::{self, ScoreParams, Scores};
use crate::arena::{Alloc, Arena};
use crate::clustering::knn::Neighbours;
use crate::clustering::partition::Clusters;
use crate::clustering::quadric::Planes;
use crate::clustering::Clustered;
use crate::error::Result;
use crate::math::V3;
use crate::meshing::select;
use crate::params::Params;
use crate::progress::{tick, Progress, Silent, Stage};

/// The facet-selection problem of one meshing round and what it was built from.
pub(crate) struct Problem<'s> {
    /// Candidate edges and facets.
    pub cand: Candidates<'s>,
    /// The points of each cluster.
    pub members: Members<'s>,
    /// Facet scores.
    pub scores: Scores<'s>,
    /// Fold groups (constraints after the edges).
    pub fold_groups: u32,
    /// Per cluster: on the border of the data.
    pub open: &'s [bool],
    /// Per cluster on the border of the data: where its vertex goes when it ends on
    /// the mesh's boundary (see [`border::try_border_clusters_in`]).
    pub moved: &'s [V3],
    /// Per cluster: the piece of the data it lies in
    /// ([`candidates::try_pieces_in`]).
    pub piece: &'s [u32],
    /// The constraints and objective.
    pub selection: SelectionProblem<'s>,
}

/// Candidates, border, scores, fold groups and the selection constraints for
/// clusters `c`, allocated from `s`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn try_problem_in<'s, 'b, A: Alloc<'b>>(
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
    tick(progress, Stage::Candidates, 0, 1)?;
    let (rep, merged) = candidates::try_merge_in(s, gens, diag)?;
    let members = candidates::try_members_in(s, c.labels, rep)?;
    let piece = candidates::try_pieces_in(s, nb, c.labels, rep, &*progress)?;
    let cand = candidates::try_candidates_in(
        s, &*progress, nb, c.labels, rep, merged, &members, gens, diag,
    )?;
    // Clusters on the border of the data; their vertices move onto it.
    let per_edge = candidates::try_facets_per_edge_in(s, &cand)?;
    let moved = s.try_alloc_copy(gens)?;
    let angle = params.border_angle * (core::f32::consts::PI / 180.0);
    let open = border::try_border_clusters_in(
        s, points, &members, planes, nb, &cand, per_edge, gens, angle, moved, &*progress,
    )?;
    tick(progress, Stage::Candidates, 1, 1)?;
    tick(progress, Stage::Scoring, 0, 1)?;
    let sp = ScoreParams::from(params);
    let scores = score::try_scores_in(
        s, points, &members, &cand, gens, nb.spacing, diag, &sp, &*progress,
    )?;
    tick(progress, Stage::Scoring, 1, 1)?;
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
        piece,
    })
}

/// The facet-selection problem as [`reconstruct`](crate::reconstruct) builds it:
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

/// The selection problem of the first meshing round of
/// [`reconstruct`](crate::reconstruct) for `clustered` (made by
/// [`cluster`](crate::cluster()) from the same `points` and `params`), kept in
/// `arena`; the candidates and scores it is built from live only in a scratch
/// scope. For oracle tests and for studying the solver on real instances.
pub fn selection_problem<'a>(
    arena: &'a Arena,
    points: &[V3],
    clustered: &Clustered<'_>,
    params: &Params,
) -> Result<SelectionProblem<'a>> {
    arena.scratch(|s| {
        let p = try_problem_in(
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
