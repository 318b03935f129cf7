//! Facet selection: the exact 0/1 choice of candidate triangles, by
//! branch-and-bound in arena memory.
//!
//! ## What it optimises
//! E constraints, F candidate facets (each a triangle on 3 distinct edges, and in
//! up to 3 fold groups) with real scores `w_f` (any sign). Choose `b_f ∈ {0, 1}`
//! maximising
//!
//! ```text
//!   Σ_f w_f b_f  −  Σ_e pen_e · [deg_e = 1]          (seed Eq. 7, plus a border penalty)
//!   subject to  deg_e = Σ_{f ∋ e} b_f  ∈  A_e        for every edge e
//! ```
//!
//! `A_e ⊆ {0, 1, 2}` is the edge's mask (bit d set = degree d allowed). The default
//! `{0, 2}` ([`MASK_CLOSED`]) is seed Eq. 8, `2 b_e − Σ_{f ∋ e} b_f = 0`: every edge
//! of the result carries exactly two triangles. A border edge of an open surface
//! may also allow 1 ([`MASK_BORDER`]) at the price `pen_e ≥ 0`. Degrees of 3 or more
//! are never allowed. **Every mask must allow 0** (masks without bit 0 are rejected
//! with [`Error::BadParameter`]): then selecting nothing is always feasible, so
//! every answer, even a cut-short one, satisfies all constraints.
//!
//! *Fold groups* forbid fold-overs. Candidates are all 3-cycles of the cluster
//! graph, so both triangulations of a flat quad are candidates, and with the edge
//! rule alone the two together close a flat tetrahedron (a pocket) that blocks the
//! real surface. A surface never folds back onto itself, so around each edge the
//! caller groups the facets whose half-planes lie within a small angle of each other,
//! and at most one facet of a group may be selected: `Σ_{f ∈ G} b_f ≤ 1`. A group
//! is just one more constraint ("edge" below) with mask `{0, 1}`
//! ([`MASK_AT_MOST_ONE`]) and no penalty; a facet then has 3 to 6 constraints, and
//! everything below treats edges and groups alike, by their masks, except that on
//! each edge the facets fall into *classes*: a facet's group holding the most
//! facets of that edge, or the facet alone.
//!
//! ## How (deterministic; ties go to the lower index)
//! 1. *Propagation* (`propagate.rs`) to a fixpoint, at the root and at every node:
//!    an edge with `s` selected and `u` undecided facets can end at a degree in
//!    `D = {d ∈ A_e : s ≤ d ≤ s + u}`. `D = ∅` is a conflict; `D = {s}` turns its
//!    undecided facets off; `D = {s + u}` turns them on. For `{0, 2}` that is: a lone
//!    undecided facet goes off, a half-used edge with one candidate left takes it,
//!    a full edge drops the rest.
//! 2. *Components* (`propagate.rs`): after root propagation the undecided facets
//!    split into groups that share no edge; each is solved on its own, smallest first.
//! 3. *Bound* (`bound.rs`; admissible, Lagrangian decomposition): every undecided
//!    facet splits its score into shares `λ_{f,e}` over its 3 to 6 edges
//!    (`Σ_e λ_{f,e} = w_f`). Alone, an edge can take any `k` of its undecided facets
//!    with `s + k ∈ A_e`, at most one per class (a group allows no more); its best is
//!    `max_k (top-k shares of distinct classes) − pen_e [s + k = 1]`, so a pair is
//!    the best share plus the best of another class. Summing that over the
//!    edges, plus the selected facets' scores, bounds every completion for *every*
//!    split, since each facet's score is counted once through its shares. The best
//!    split gives the LP relaxation with each edge's convex hull (which includes
//!    "a selected facet needs a partner on a closed edge"). The split is improved
//!    by coordinate descent (one facet at a time, re-split so that its edges
//!    value it equally: the exact minimiser for that facet), on a smoothed dual with
//!    a falling temperature at the root, then locally, only where something changed,
//!    at every node. Refreshing every cache of a large problem runs in parallel
//!    tasks ([`crate::parallel`]), with the same result on any threads, and so
//!    do the root's smoothed sweeps, level by level (a facet's level one more
//!    than that of the last facet before it sharing an edge: the shares of a
//!    sweep in facet order, bit for bit). Each edge caches the best shares of its three best classes
//!    (and the second best of the first two) and its term, so a node
//!    costs work in proportion to what changed, plus one pass over the component.
//!    When the edges of every facet agree, their picks are a feasible
//!    completion worth exactly the bound: an incumbent for free.
//! 4. *Reduced-cost fixing* (`search.rs`): the cached top-3 give, per facet, the
//!    bound with the facet forced on or off; a value that cannot beat the incumbent
//!    is excluded.
//! 5. *Incumbent* (`incumbent.rs`): a greedy dive guided by the bound; rounding
//!    (facets at least half of whose edges pick them, repaired by removals only, so
//!    always feasible); dropping connected pieces worth less than nothing; then a
//!    large-neighbourhood search: around facets where the bound disagrees with the
//!    incumbent, re-solve a ball of 32 to 256 facets exactly with the rest fixed.
//!    A ball's search reads and writes only what hangs on its edges (and leaves
//!    only its facets' shares and incumbent changed), so when the caller has two
//!    threads, the next ball is grown at once and, if it shares no edge with
//!    this one, searched beside it on a *lane* (a second solver over the same
//!    incidence, its own copy of the state), given the nodes it would have in
//!    turn if the first used one; it is searched again in turn when it might
//!    have run out of the nodes it would have had in turn. The result is that
//!    of searching them one after the other.
//! 6. *Search* (`search.rs`): depth-first, on an explicit stack (no recursion, any
//!    depth). Strong branching: the six most contested facets (both forced values
//!    lose the most by the cached estimates) have both children bounded
//!    (propagation plus a few local re-splits); a child that cannot beat the
//!    incumbent fixes the facet the other way, else the facet whose children lose
//!    the most (product rule) is branched on, better child first. A node limit
//!    ([`SelectInput::node_limit`]) spans the whole run (neighbourhood searches
//!    included); when it is hit, the answer is the best incumbent and the reported
//!    upper bound is the largest bound of the unexplored subtrees: an honest gap.
//!
//! "Optimal" means no selection is better by more than `1e-9 · (1 + Σ |w_f|)` of
//! its component (rounding room for the floating-point bound).
//!
//! The solver's state, its incidence arrays and the assign/undo trail are in
//! `solver.rs`; each component is solved by `search.rs`'s `solve_component`;
//! this file holds the public interface, the checks and the driver.
//!
//! ## Cost
//! Memory: [`select_bytes_for`], about `65 F + 40 I + 100 E` bytes for `I` used
//! constraint slots (3 F to 6 F; [`select_bytes`] assumes 6 F), all from the arena,
//! of which only the `F`-byte result is persistent; on two threads or more, a
//! lane (`incumbent::Lane`, about `41 F + 24 I + 92 E` bytes more) when
//! the arena has room at the time (never counted in these bounds, and without
//! it the search runs ball after ball, to the same result). Time: O(F + E) for the checks,
//! incidence, propagation and components; O(I) per root sweep (30 per component);
//! per search node, O(facets + edges of its component) plus the re-splits around
//! what changed (at most 512), and the same again for each of its 12 probed
//! children (at most 128 re-splits each); a re-split costs O(incidences of its
//! facet's edges). The search is exponential in the worst case; the node limit caps
//! it. Measured times, node counts and gaps: `bench/select.md`.

mod bound;
mod incumbent;
mod propagate;
mod search;
mod solver;
#[cfg(test)]
mod tests;

use crate::arena::Alloc;
use crate::error::{Error, Result};
use crate::progress::{Flow, Progress, Stage};
use incumbent::{Lane, Neighbourhood};
use propagate::{ComponentSpan, Components};
use search::{Budget, Stack};
use solver::Solver;

/// Facets a selection needs for its neighbourhood search to run balls at
/// once on two threads (a lane costs about `42 F + 24 I + 92 E` bytes).
const MIN_LANE_FACETS: usize = 256;

/// Edge mask "degree 0 or 2": a closed 2-manifold edge (seed Eq. 8).
pub const MASK_CLOSED: u8 = 0b101;
/// Edge mask "degree 0, 1 or 2": an edge that may lie on the border of an open surface.
pub const MASK_BORDER: u8 = 0b111;
/// Constraint mask "at most one": a fold group (facets folded onto each other
/// around an edge, of which a surface uses at most one).
pub const MASK_AT_MOST_ONE: u8 = 0b011;
/// An unused slot of [`SelectInput::facet_edges`].
pub const UNUSED: u32 = u32::MAX;
/// Constraints one facet may belong to at most: its 3 edges and up to 3 fold groups.
pub const MAX_CONSTRAINTS: usize = 6;

/// One selection problem. Constraint ("edge") ids index `0..edge_count`; a fold
/// group is a constraint like an edge, with mask [`MASK_AT_MOST_ONE`].
#[derive(Clone, Copy, Debug)]
pub struct SelectInput<'a> {
    /// The constraints of each candidate facet: its three edges and up to three
    /// fold groups, in any slots; unused slots hold [`UNUSED`]. At least three
    /// slots are used and the ids of one facet are distinct. [`widen`] and
    /// [`join`] build the rows.
    pub facet_edges: &'a [[u32; MAX_CONSTRAINTS]],
    /// Score of each facet (seed Eq. 7's `F_f + F_c`); finite, any sign.
    pub scores: &'a [f32],
    /// Number of constraints (candidate edges and fold groups).
    pub edge_count: usize,
    /// Allowed degrees of each edge (bit d = degree d allowed; bit 0 required,
    /// bits above 2 forbidden). `None`: every edge is [`MASK_CLOSED`].
    pub edge_mask: Option<&'a [u8]>,
    /// Cost of an edge ending with exactly one facet, finite and `>= 0`.
    /// `None`: no cost.
    pub edge_penalty: Option<&'a [f32]>,
    /// Search nodes allowed over the whole run (0: heuristics and root bound only).
    /// The pipeline passes [`Params::node_limit`](crate::Params::node_limit).
    pub node_limit: u64,
}

impl<'a> SelectInput<'a> {
    /// A closed-surface problem ([`MASK_CLOSED`] everywhere, no penalties) that may
    /// use `node_limit` search nodes (see [`SelectInput::node_limit`]).
    pub fn new(
        facet_edges: &'a [[u32; MAX_CONSTRAINTS]],
        scores: &'a [f32],
        edge_count: usize,
        node_limit: u64,
    ) -> Self {
        SelectInput {
            facet_edges,
            scores,
            edge_count,
            edge_mask: None,
            edge_penalty: None,
            node_limit,
        }
    }
}

/// A facet row with its three edges and no fold group.
pub fn widen(edges: [u32; 3]) -> [u32; MAX_CONSTRAINTS] {
    join(edges, [UNUSED; 3], 0)
}

/// A facet row with its three edges and the fold groups it is in at them
/// ([`UNUSED`] where it is in none); group `g` becomes constraint `first_group + g`
/// (usually the edge count).
pub fn join(edges: [u32; 3], groups: [u32; 3], first_group: u32) -> [u32; MAX_CONSTRAINTS] {
    let constraint_of_group = |i: usize| {
        if groups[i] == UNUSED {
            UNUSED
        } else {
            // Out of range (so rejected) rather than silently unused on overflow.
            first_group
                .checked_add(groups[i])
                .filter(|&v| v != UNUSED)
                .unwrap_or(UNUSED - 1)
        }
    };
    [
        edges[0],
        edges[1],
        edges[2],
        constraint_of_group(0),
        constraint_of_group(1),
        constraint_of_group(2),
    ]
}

/// What a run found and how sure it is.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SelectStats {
    /// The search finished: no selection is better (see the module docs' tolerance).
    pub optimal: bool,
    /// Objective of the returned selection.
    pub objective: f64,
    /// No feasible selection is worth more than this (equals `objective` when optimal).
    pub upper_bound: f64,
    /// `(upper_bound − objective) / max(1, |upper_bound|)`; 0 when optimal.
    pub gap: f64,
    /// Search nodes used (neighbourhood searches included).
    pub nodes: u64,
    /// Independent groups of facets left after root propagation.
    pub components: u32,
    /// Facets in the largest of them.
    pub largest_component: u32,
    /// Facets decided (off) by root propagation.
    pub forced: u32,
}

/// An upper bound on the arena bytes [`try_select_in`] uses for `facets` facets
/// and `edges` constraints (edges and fold groups), whatever their rows hold
/// (persistent result plus peak scratch): about `305 F + 100 E` bytes. See
/// [`select_bytes_for`] for a tighter figure.
pub fn select_bytes(facets: usize, edges: usize) -> usize {
    bytes_needed(facets, edges, facets.saturating_mul(MAX_CONSTRAINTS))
}

/// The arena bytes [`try_select_in`] uses for `input` at most: about
/// `65 F + 40 I + 100 E` bytes for `I` used constraint slots (`185 F + 100 E` with
/// edges only). Cost O(F).
pub fn select_bytes_for(input: &SelectInput<'_>) -> usize {
    bytes_needed(
        input.facet_edges.len(),
        input.edge_count,
        incidence_count(input.facet_edges),
    )
}

/// Used slots of the facet rows: the number of facet-constraint incidences.
fn incidence_count(rows: &[[u32; MAX_CONSTRAINTS]]) -> usize {
    rows.iter()
        .map(|r| r.iter().filter(|&&e| e != UNUSED).count())
        .sum()
}

/// Bytes for `count` values of `T`, worst-case alignment padding included.
fn array_bytes<T>(count: usize) -> usize {
    crate::arena::padded_bytes::<T>(count)
}

/// Arena bytes for `facets` facets, `edges` constraints and `incidences` used
/// slots: the result plus every scratch array, saturating instead of overflowing.
fn bytes_needed(facets: usize, edges: usize, incidences: usize) -> usize {
    let (f, e, i) = (facets, edges, incidences);
    // Keep in step with the allocations in `try_select_in` and `Solver::try_new_in`.
    let list = [
        array_bytes::<bool>(f),                  // the result (the incumbent)
        array_bytes::<u32>(e.saturating_add(1)), // edge_start
        array_bytes::<u32>(i),                   // edge_incidences
        array_bytes::<u32>(f.saturating_add(1)), // facet_start
        array_bytes::<u32>(i),                   // incidence_edge
        array_bytes::<u32>(i),                   // incidence_facet
        array_bytes::<u32>(i),                   // incidence_class
        state_bytes(f, e, i),
        array_bytes::<u32>(f), // component facets
        array_bytes::<u32>(e), // component edges
        array_bytes::<ComponentSpan>(f),
        search_bytes(f, e),
    ];
    list.iter().fold(0usize, |a, &b| a.saturating_add(b))
}

/// Bytes of the arrays of a [`Solver`] that change as it runs (its state,
/// queues, trail, shares and caches), in `Solver::try_new_in`'s order.
fn state_bytes(f: usize, e: usize, i: usize) -> usize {
    let list = [
        array_bytes::<u8>(f),       // facet_state
        array_bytes::<u32>(e),      // selected_count
        array_bytes::<u32>(e),      // undecided_count
        array_bytes::<u32>(e),      // edge_queue ring
        array_bytes::<bool>(e),     // edge_queue flags
        array_bytes::<u32>(f),      // facet_queue ring
        array_bytes::<bool>(f),     // facet_queue flags
        array_bytes::<u32>(f),      // trail
        array_bytes::<f64>(i),      // shares
        array_bytes::<u8>(f),       // picked_by
        array_bytes::<f64>(i),      // loss_if_on
        array_bytes::<f64>(i),      // loss_if_off
        array_bytes::<[u32; 3]>(e), // top_incidences
        array_bytes::<[f64; 5]>(e), // top_shares
        array_bytes::<f64>(e),      // edge_terms
        array_bytes::<bool>(e),     // edge_in_problem
        array_bytes::<bool>(f),     // facet_in_problem
        array_bytes::<bool>(e),     // edge_changed
        array_bytes::<u32>(e),      // changed_edges
        array_bytes::<bool>(e),     // marginals_stale
        array_bytes::<u32>(e),      // stale_edges
        array_bytes::<u32>(f),      // piece_queue
        array_bytes::<bool>(f),     // visited
        array_bytes::<bool>(f),     // trial
        array_bytes::<u32>(e),      // trial_degree
        array_bytes::<u8>(f),       // neighbourhood_flags
    ];
    list.iter().fold(0usize, |a, &b| a.saturating_add(b))
}

/// Bytes of a neighbourhood (its facets and edges) and a search stack.
fn search_bytes(f: usize, e: usize) -> usize {
    let list = [
        array_bytes::<u32>(f), // neighbourhood facets
        array_bytes::<u32>(e), // neighbourhood edges
        array_bytes::<u32>(f), // stack facets
        array_bytes::<u32>(f), // stack trail marks
        array_bytes::<u8>(f),  // stack branch flags
        array_bytes::<f64>(f), // stack bounds
    ];
    list.iter().fold(0usize, |a, &b| a.saturating_add(b))
}

/// Bytes of a lane (`incumbent::Lane`): a solver's state and incumbent, a
/// group of balls (a neighbourhood's arrays) and their seed flags, and a
/// search stack.
fn lane_bytes(f: usize, e: usize, i: usize) -> usize {
    state_bytes(f, e, i)
        .saturating_add(array_bytes::<bool>(f))
        .saturating_add(array_bytes::<bool>(f))
        .saturating_add(search_bytes(f, e))
}

fn bad_parameter(name: &'static str, value: f32) -> Error {
    Error::BadParameter { name, value }
}

/// Check `input` against the contract of [`SelectInput`]'s fields. Cost O(F + E).
fn validate(input: &SelectInput<'_>) -> Result<()> {
    let facets = input.facet_edges.len();
    let edges = input.edge_count;
    if facets > (u32::MAX / MAX_CONSTRAINTS as u32) as usize {
        return Err(bad_parameter("facet_edges.len", facets as f32));
    }
    if edges > (u32::MAX - 1) as usize {
        return Err(bad_parameter("edge_count", edges as f32));
    }
    if input.scores.len() != facets {
        return Err(bad_parameter("scores.len", input.scores.len() as f32));
    }
    for (f, (row, &score)) in input.facet_edges.iter().zip(input.scores).enumerate() {
        if row.iter().filter(|&&e| e != UNUSED).count() < 3 {
            return Err(bad_parameter(
                "facet_edges (fewer than 3 used slots)",
                f as f32,
            ));
        }
        for (i, &e) in row.iter().enumerate() {
            if e == UNUSED {
                continue;
            }
            if e as usize >= edges {
                return Err(bad_parameter(
                    "facet_edges (edge id >= edge_count)",
                    e as f32,
                ));
            }
            if row[..i].contains(&e) {
                return Err(bad_parameter(
                    "facet_edges (repeated edge in facet)",
                    f as f32,
                ));
            }
        }
        if !score.is_finite() {
            return Err(bad_parameter("scores", score));
        }
    }
    if let Some(masks) = input.edge_mask {
        if masks.len() != edges {
            return Err(bad_parameter("edge_mask.len", masks.len() as f32));
        }
        if let Some(&bad_mask) = masks.iter().find(|&&m| m & 1 == 0 || m > 0b111) {
            return Err(bad_parameter(
                "edge_mask (bit 0 required, bits 0..=2 only)",
                bad_mask as f32,
            ));
        }
    }
    if let Some(penalties) = input.edge_penalty {
        if penalties.len() != edges {
            return Err(bad_parameter("edge_penalty.len", penalties.len() as f32));
        }
        if let Some(&v) = penalties.iter().find(|&&v| !(v.is_finite() && v >= 0.0)) {
            return Err(bad_parameter("edge_penalty", v));
        }
    }
    Ok(())
}

/// Select facets (see the module docs). Returns one flag per facet, allocated from
/// `arena` (an [`Arena`](crate::Arena)'s persistent end, or a scratch scope that
/// outlives the call), and the run's statistics. The selection always satisfies every edge's
/// mask, also when the node limit cuts the search short.
///
/// `progress(done, total)` is told how many of the facets are settled, at the
/// start, after each component and every 1024 search nodes; returning `false`
/// stops the run with [`Error::Cancelled`].
///
/// Errors: [`Error::BadParameter`] for an edge id out of range or repeated within a
/// facet, a non-finite score, a mask without bit 0 or with bits above 2, a negative
/// or non-finite penalty, or mismatched lengths; [`Error::Exhausted`] when the arena
/// has less than [`select_bytes`] free. An empty problem is not an error: it gives
/// an empty selection.
pub fn try_select_in<'a, 'b, A: Alloc<'b>>(
    arena: &'a A,
    input: &SelectInput<'_>,
    progress: &mut dyn FnMut(u64, u64) -> bool,
) -> Result<(&'a mut [bool], SelectStats)> {
    try_select_with_in(arena, input, &mut Callback(progress))
}

/// A `progress(done, total)` callback as a [`Progress`] that runs tasks one
/// after another.
struct Callback<'f>(&'f mut dyn FnMut(u64, u64) -> bool);

impl Progress for Callback<'_> {
    fn report(&mut self, _: Stage, done: u64, total: u64) -> Flow {
        if (self.0)(done, total) {
            Flow::Continue
        } else {
            Flow::Cancel
        }
    }
}

/// [`try_select_in`] reporting to `progress` (stage [`Stage::Selection`],
/// facets settled of all) and running the parallel tasks of the caches'
/// refreshes through it. The selection does not depend on how it runs them.
pub fn try_select_with_in<'a, 'b, A: Alloc<'b>>(
    arena: &'a A,
    input: &SelectInput<'_>,
    progress: &mut dyn Progress,
) -> Result<(&'a mut [bool], SelectStats)> {
    validate(input)?;
    let selection = arena.try_alloc_slice(input.facet_edges.len(), false)?;
    let report = |progress: &mut dyn Progress, done: u64, total: u64| -> Result<()> {
        match progress.report(Stage::Selection, done, total) {
            Flow::Continue => Ok(()),
            Flow::Cancel => Err(Error::Cancelled),
        }
    };
    report(progress, 0, selection.len() as u64)?;
    let stats = arena.scratch(|scratch| -> Result<SelectStats> {
        let facet_count = input.facet_edges.len();
        let edge_count = input.edge_count;
        // Keep in step with `bytes_needed`.
        let mut solver = Solver::try_new_in(scratch, input, &mut *selection)?;
        let mut ball = Neighbourhood::try_new_in(scratch, facet_count, edge_count)?;
        let mut components = Components::try_new_in(scratch, facet_count, edge_count)?;
        let mut stack = Stack::try_new_in(scratch, facet_count)?;
        // A lane for the neighbourhood search when balls can run at once
        // and the arena has room (never counted in `bytes_needed`).
        let incidences = solver.shares.len();
        let mut lane = if progress.threads() >= 2
            && facet_count >= MIN_LANE_FACETS
            && scratch.available() >= lane_bytes(facet_count, edge_count, incidences)
        {
            Some(Lane::try_new_in(scratch, &solver, facet_count, edge_count)?)
        } else {
            None
        };

        let mut stats = SelectStats {
            forced: solver.propagate_root(),
            ..SelectStats::default()
        };
        let spans = solver.find_components(&mut components);
        stats.components = spans as u32;
        stats.largest_component = components.spans[..spans]
            .iter()
            .map(|c| c.facet_count)
            .max()
            .unwrap_or(0);

        let total = facet_count as u64;
        let mut done = stats.forced as u64;
        let mut nodes_left = input.node_limit;
        let mut optimal = true;
        for span in components.spans[..spans].iter() {
            let facets = components.facets_of(span);
            let mut budget = Budget {
                nodes_left,
                nodes_used: stats.nodes,
                progress: &mut *progress,
                done,
                total,
            };
            let solved = solver.solve_component(
                facets,
                components.edges_of(span),
                &mut stack,
                &mut ball,
                lane.as_mut(),
                &mut budget,
            )?;
            nodes_left = budget.nodes_left;
            stats.nodes = budget.nodes_used;
            optimal &= solved.finished;
            stats.objective += solved.objective;
            stats.upper_bound += solved.upper_bound;
            done += facets.len() as u64;
            report(progress, done, total)?;
        }
        stats.optimal = optimal;
        if optimal {
            stats.upper_bound = stats.objective;
        }
        stats.gap = (stats.upper_bound - stats.objective) / stats.upper_bound.abs().max(1.0);
        Ok(stats)
    })?;
    Ok((selection, stats))
}
