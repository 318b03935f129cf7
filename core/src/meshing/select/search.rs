//! Solving one component, and its depth-first branch-and-bound (steps 4 and 6
//! of the module docs): a node propagates, re-splits locally, fixes facets by
//! reduced costs and picks its branching facet by strong branching; the search
//! runs on an explicit stack.
//! Cost per node: O(facets + edges of the problem) plus at most
//! [`NODE_RESPLITS`] re-splits, and the same for each probed child with
//! [`PROBE_RESPLITS`].

use super::bound::{Levels, Losses, Plan, MIN_SHARE_MOVE};
use super::incumbent::{Lane, Neighbourhood};
use super::solver::{Solver, UNDECIDED};
use crate::arena::Alloc;
use crate::error::{Error, Result};
use crate::progress::{Flow, Progress, Stage};

/// Facet re-splits per search node at most.
const NODE_RESPLITS: usize = 512;
/// Branching candidates whose children are bounded before choosing (strong branching).
const STRONG_BRANCHING_CANDIDATES: usize = 6;
/// Facet re-splits when bounding a candidate child.
const PROBE_RESPLITS: usize = 128;
/// Search nodes between two runs of the rounding heuristic.
const NODES_PER_ROUNDING: u64 = 16;
/// Nodes between two progress reports.
pub(super) const NODES_PER_REPORT: u64 = 1024;
/// Stack level flag: its second branch has been taken.
const SECOND_BRANCH_TAKEN: u8 = 1;
/// Stack level flag: its first branch set the facet on.
const FIRST_BRANCH_ON: u8 = 2;

/// The explicit search stack: one level per branching decision, `depth` levels.
pub(super) struct Stack<'a> {
    /// The facet branched on at each level.
    facets: &'a mut [u32],
    /// The trail length before the level's branch was assigned (undo to it to
    /// leave the branch).
    trail_marks: &'a mut [u32],
    /// [`SECOND_BRANCH_TAKEN`] and [`FIRST_BRANCH_ON`] per level.
    branch_flags: &'a mut [u8],
    /// The bound of the node that branched, per level.
    bounds: &'a mut [f64],
    /// Levels in use.
    pub(super) depth: usize,
}

impl<'a> Stack<'a> {
    /// An empty stack of up to `facets` levels, in `scratch`.
    pub(super) fn try_new_in<'b, A: Alloc<'b>>(scratch: &'a A, facets: usize) -> Result<Self> {
        Ok(Stack {
            facets: scratch.try_alloc_slice(facets, 0u32)?,
            trail_marks: scratch.try_alloc_slice(facets, 0u32)?,
            branch_flags: scratch.try_alloc_slice(facets, 0u8)?,
            bounds: scratch.try_alloc_slice(facets, 0.0f64)?,
            depth: 0,
        })
    }
}

/// Where a search draws its nodes from, reports its progress and runs its
/// parallel tasks.
pub(super) struct Budget<'r> {
    /// Nodes the search may still use.
    pub(super) nodes_left: u64,
    /// Nodes used so far in the run (reported every [`NODES_PER_REPORT`]).
    pub(super) nodes_used: u64,
    /// Told of progress (facets settled: `done` of `total`); a cancel request
    /// stops the run. Runs the parallel tasks of the caches' refreshes and of
    /// the root's sweeps.
    pub(super) progress: &'r mut dyn Progress,
    /// Facets settled before the current component.
    pub(super) done: u64,
    /// Facets in all.
    pub(super) total: u64,
}

impl Budget<'_> {
    /// Report progress; `false` when the run is to stop.
    pub(super) fn report(&mut self) -> bool {
        self.progress
            .report(Stage::Selection, self.done, self.total)
            == Flow::Continue
    }
}

/// What solving one component gave.
pub(super) struct Solved {
    /// The search finished: no selection of the component is better (within the
    /// tolerance of the module docs).
    pub(super) finished: bool,
    /// Objective of the incumbent on the component.
    pub(super) objective: f64,
    /// No selection of the component is worth more (`objective` when finished).
    pub(super) upper_bound: f64,
}

impl Solver<'_> {
    /// Solve one component (no problem open): a dive and piece dropping, the root
    /// bound (its sweeps and refreshes in parallel tasks of `budget`'s
    /// progress), and
    /// unless that proves the incumbent, another dive, the
    /// neighbourhood search and the search, within `budget`. The incumbent on
    /// the component's facets is left in `incumbent`.
    pub(super) fn solve_component(
        &mut self,
        facets: &[u32],
        edges: &[u32],
        stack: &mut Stack<'_>,
        ball: &mut Neighbourhood<'_>,
        lane: Option<&mut Lane<'_>>,
        budget: &mut Budget<'_>,
    ) -> Result<Solved> {
        let total_abs_score = facets
            .iter()
            .map(|&f| (self.scores[f as usize] as f64).abs())
            .sum::<f64>();
        let tolerance = 1e-9 * (1.0 + total_abs_score);
        self.score_scale = (total_abs_score / facets.len() as f64).max(f64::MIN_POSITIVE);
        self.min_share_move = MIN_SHARE_MOVE * self.score_scale;
        // The incumbent starts as "nothing" (worth 0, always feasible).
        let mut incumbent_value = 0.0f64;
        if let Some(v) = self.dive(facets, edges, incumbent_value, &*budget.progress) {
            incumbent_value = v;
        }
        incumbent_value += self.drop_incumbent_pieces(facets);
        // The root's sweeps read the terms and picks only (see root_bound).
        self.open_problem_with(facets, edges, Losses::Stale, &*budget.progress);
        // The root's sweeps borrow the stack's and the ball's arrays, whose
        // searches come after.
        let (order, last) = ball.arrays();
        let mut levels = Levels {
            level: &mut *stack.facets,
            order,
            start: &mut *stack.trail_marks,
            last,
            plan: Plan::Unplanned,
        };
        let root_bound = self.root_bound(
            facets,
            edges,
            &mut incumbent_value,
            tolerance,
            &mut levels,
            &*budget.progress,
        );
        self.close_problem(facets, edges);
        if root_bound <= incumbent_value + tolerance {
            return Ok(Solved {
                finished: true,
                objective: incumbent_value,
                upper_bound: incumbent_value,
            });
        }
        if let Some(v) = self.dive(facets, edges, incumbent_value, &*budget.progress) {
            incumbent_value = v;
            incumbent_value += self.drop_incumbent_pieces(facets);
        }
        self.neighbourhood_search(
            facets,
            edges,
            stack,
            ball,
            lane,
            &mut incumbent_value,
            tolerance,
            budget,
        )?;
        let (finished, upper_bound) = self.search(
            facets,
            edges,
            stack,
            &mut incumbent_value,
            tolerance,
            root_bound,
            budget,
        )?;
        if !finished {
            incumbent_value += self.drop_incumbent_pieces(facets);
        }
        Ok(Solved {
            finished,
            objective: incumbent_value,
            upper_bound: if finished {
                incumbent_value
            } else {
                upper_bound.min(root_bound).max(incumbent_value)
            },
        })
    }

    /// Process one search node (problem open): propagate, refresh, re-split locally,
    /// fix by reduced costs, and either prune (`None`) or return the branching
    /// facet, its better side and the node's bound.
    fn process_node(
        &mut self,
        facets: &[u32],
        edges: &[u32],
        incumbent_value: &mut f64,
        tolerance: f64,
        node_count: u64,
    ) -> Option<(usize, bool, f64)> {
        if !self.propagate() {
            return None;
        }
        self.flush_changed_edges();
        // A node pruned by its bound stops re-splitting there. (The same
        // stop after the fixings below moved the instructions by about 1 %
        // either way on three shared clouds: not taken; `bench/notes.md`.)
        self.resplit_queued_until(NODE_RESPLITS, Some((edges, *incumbent_value + tolerance)));
        loop {
            let bound = self.bound(edges);
            let to_beat = *incumbent_value + tolerance;
            if bound <= to_beat {
                return None;
            }
            let mut fixed_any = false;
            let mut disagreeing = 0;
            // The most contested facets (both forced values lose the most), best first.
            let mut contested = [(-1.0f64, usize::MAX); STRONG_BRANCHING_CANDIDATES];
            for &f in facets {
                let f = f as usize;
                if self.facet_state[f] != UNDECIDED {
                    continue;
                }
                let (loss_on, loss_off) = (self.loss_forced_on(f), self.loss_forced_off(f));
                match (bound - loss_on > to_beat, bound - loss_off > to_beat) {
                    (false, false) => return None,
                    (true, false) => {
                        self.assign(f, true);
                        fixed_any = true;
                        continue;
                    }
                    (false, true) => {
                        self.assign(f, false);
                        fixed_any = true;
                        continue;
                    }
                    (true, true) => {}
                }
                if !self.edges_agree(f) {
                    disagreeing += 1;
                }
                let contest = loss_on.min(loss_off);
                if contest > contested[STRONG_BRANCHING_CANDIDATES - 1].0 {
                    let mut i = STRONG_BRANCHING_CANDIDATES - 1;
                    while i > 0 && contest > contested[i - 1].0 {
                        contested[i] = contested[i - 1];
                        i -= 1;
                    }
                    contested[i] = (contest, f);
                }
            }
            if fixed_any {
                if !self.propagate() {
                    return None;
                }
                self.flush_changed_edges();
                self.resplit_queued(NODE_RESPLITS);
                continue;
            }
            if disagreeing == 0 {
                self.record_agreed_picks(facets);
                *incumbent_value = bound;
                return None;
            }
            if self.rounding_enabled && node_count % NODES_PER_ROUNDING == 0 {
                if let Some(v) = self.round(facets, edges, *incumbent_value) {
                    *incumbent_value = v;
                    if bound <= v + tolerance {
                        return None;
                    }
                }
            }
            // Strong branching: bound both children of each candidate; a child that
            // cannot beat the incumbent fixes the other value, else take the facet
            // whose children lose the most (product rule).
            let mut pick = None;
            let mut largest_product = -1.0;
            let mut forced = None;
            for &(_, f) in contested.iter().filter(|c| c.1 != usize::MAX) {
                let on = self.probe(edges, f, true);
                let off = self.probe(edges, f, false);
                match (on > to_beat, off > to_beat) {
                    (false, false) => return None,
                    (true, false) => forced = Some((f, true)),
                    (false, true) => forced = Some((f, false)),
                    (true, true) => {}
                }
                if forced.is_some() {
                    break;
                }
                let floor = 1e-6 * self.score_scale;
                let product = (bound - on).max(floor) * (bound - off).max(floor);
                if product > largest_product {
                    largest_product = product;
                    pick = Some((f, on >= off));
                }
            }
            self.flush_changed_edges();
            if let Some((f, on)) = forced {
                self.assign(f, on);
                if !self.propagate() {
                    return None;
                }
                self.flush_changed_edges();
                self.resplit_queued(NODE_RESPLITS);
                continue;
            }
            let (f, on) = pick?;
            return Some((f, on, bound));
        }
    }

    /// The bound of the current node's child with `f` set to `on`, after
    /// propagation and a few local re-splits (`−∞` when propagation fails). The
    /// state is restored; the caches wait for a flush.
    fn probe(&mut self, edges: &[u32], f: usize, on: bool) -> f64 {
        let mark = self.trail_len;
        self.assign(f, on);
        let bound = if self.propagate() {
            self.flush_changed_edges();
            self.resplit_queued(PROBE_RESPLITS);
            self.bound(edges)
        } else {
            f64::NEG_INFINITY
        };
        self.undo_to(mark);
        bound
    }

    /// Depth-first branch-and-bound over one problem (opens and closes it).
    /// Returns whether it finished and an upper bound on the problem's optimum.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn search(
        &mut self,
        facets: &[u32],
        edges: &[u32],
        stack: &mut Stack<'_>,
        incumbent_value: &mut f64,
        tolerance: f64,
        root_bound: f64,
        budget: &mut Budget<'_>,
    ) -> Result<(bool, f64)> {
        let base_mark = self.trail_len;
        stack.depth = 0;
        self.open_problem(facets, edges, &*budget.progress);
        let out = 'run: loop {
            if budget.nodes_left == 0 {
                // Unexplored: the current node (under the top level) and the second
                // branch of every level still on its first.
                let mut upper_bound = *incumbent_value;
                if stack.depth == 0 {
                    upper_bound = upper_bound.max(root_bound);
                }
                for i in 0..stack.depth {
                    if stack.branch_flags[i] & SECOND_BRANCH_TAKEN == 0 || i + 1 == stack.depth {
                        upper_bound = upper_bound.max(stack.bounds[i]);
                    }
                }
                break Ok((false, upper_bound));
            }
            budget.nodes_left -= 1;
            budget.nodes_used += 1;
            if budget.nodes_used % NODES_PER_REPORT == 0 && !budget.report() {
                break Err(Error::Cancelled);
            }
            if let Some((f, on, bound)) =
                self.process_node(facets, edges, incumbent_value, tolerance, budget.nodes_used)
            {
                let i = stack.depth;
                stack.facets[i] = f as u32;
                stack.trail_marks[i] = self.trail_len as u32;
                stack.branch_flags[i] = if on { FIRST_BRANCH_ON } else { 0 };
                stack.bounds[i] = bound;
                stack.depth += 1;
                self.assign(f, on);
                continue;
            }
            // Backtrack to the deepest level with an untried branch.
            loop {
                if stack.depth == 0 {
                    break 'run Ok((true, *incumbent_value));
                }
                let i = stack.depth - 1;
                self.undo_to(stack.trail_marks[i] as usize);
                if stack.branch_flags[i] & SECOND_BRANCH_TAKEN == 0 {
                    stack.branch_flags[i] |= SECOND_BRANCH_TAKEN;
                    let first_on = stack.branch_flags[i] & FIRST_BRANCH_ON != 0;
                    self.assign(stack.facets[i] as usize, !first_on);
                    break;
                }
                stack.depth -= 1;
            }
        };
        self.undo_to(base_mark);
        self.close_problem(facets, edges);
        out
    }
}
