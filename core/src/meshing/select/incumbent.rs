//! Incumbents (step 5 of the module docs): the greedy dive, rounding, dropping
//! pieces worth less than nothing, and the large-neighbourhood search. Each one
//! only ever records a feasible selection, and only when it is better. Cost: a
//! dive is at most F propagations; rounding and piece dropping O(incidences of
//! the problem); a neighbourhood search at most its share of the node budget.

use super::bound::Losses;
use super::search::{Budget, Stack, NODES_PER_REPORT};
use super::solver::{Solver, ON, UNDECIDED};
use crate::arena::Alloc;
use crate::error::{Error, Result};
use crate::parallel::Task;
use crate::progress::{Progress, Silent};

/// Facets in one neighbourhood of the large-neighbourhood search, at first; a pass
/// without gain doubles it, up to [`MAX_NEIGHBOURHOOD_SIZE`].
const NEIGHBOURHOOD_SIZE: usize = 32;
/// Facets in one neighbourhood at most.
const MAX_NEIGHBOURHOOD_SIZE: usize = 256;
/// Search nodes per neighbourhood at most, per facet of the neighbourhood size.
const NODES_PER_NEIGHBOURHOOD_FACET: u64 = 50;
/// Passes of the neighbourhood search over a component at most.
const NEIGHBOURHOOD_PASSES: u32 = 12;
/// Neighbourhood flag: a facet the bound's picks would set otherwise than the
/// incumbent, whose neighbourhood is still to be searched in this pass.
const FLAG_SEED: u8 = 1;
/// Neighbourhood flag: a facet of the current neighbourhood.
const FLAG_IN_BALL: u8 = 2;

/// The current neighbourhood ("ball") of the large-neighbourhood search: its
/// facets and edges, each list ascending once the ball is complete.
pub(super) struct Neighbourhood<'a> {
    /// The ball's facets (a prefix is used).
    facets: &'a mut [u32],
    /// The ball's edges: every edge of its facets (a prefix is used).
    edges: &'a mut [u32],
}

impl<'a> Neighbourhood<'a> {
    /// Room for a ball of up to `facets` facets and `edges` edges, in `scratch`.
    pub(super) fn try_new_in<'b, A: Alloc<'b>>(
        scratch: &'a A,
        facets: usize,
        edges: usize,
    ) -> Result<Self> {
        Ok(Neighbourhood {
            facets: scratch.try_alloc_slice(facets, 0u32)?,
            edges: scratch.try_alloc_slice(edges, 0u32)?,
        })
    }

    /// Its facet and edge arrays, for scratch between balls.
    pub(super) fn arrays(&mut self) -> (&mut [u32], &mut [u32]) {
        (self.facets, self.edges)
    }
}

/// A second solver ([`Solver::try_lane_in`]) with its own search stack and
/// ball, on which the neighbourhood search searches a ball while the main
/// solver searches another.
pub(super) struct Lane<'a> {
    /// The lane's solver.
    solver: Solver<'a>,
    /// Its search stack.
    stack: Stack<'a>,
    /// Its ball.
    ball: Neighbourhood<'a>,
    /// Facets in `ball`.
    ball_facets: usize,
    /// Edges in `ball`.
    ball_edges: usize,
}

impl<'a> Lane<'a> {
    /// A lane beside `main`, in `scratch` (`lane_bytes` of it).
    pub(super) fn try_new_in<'b, A: Alloc<'b>>(
        scratch: &'a A,
        main: &Solver<'a>,
        facets: usize,
        edges: usize,
    ) -> Result<Self> {
        Ok(Lane {
            solver: main.try_lane_in(scratch)?,
            stack: Stack::try_new_in(scratch, facets)?,
            ball: Neighbourhood::try_new_in(scratch, facets, edges)?,
            ball_facets: 0,
            ball_edges: 0,
        })
    }
}

/// One ball's search as a parallel task ([`Solver::search_ball`] with a
/// budget of its own that reports nowhere).
struct BallTask<'t, 's, 'k> {
    solver: &'t mut Solver<'s>,
    ball: (&'t [u32], &'t [u32]),
    ball_size: usize,
    stack: &'t mut Stack<'k>,
    tolerance: f64,
    /// The budget's nodes left and used before the search.
    nodes: (u64, u64),
    /// The search's result.
    out: Result<(f64, f64)>,
    /// Nodes it used.
    used: u64,
}

impl<'t, 's, 'k> BallTask<'t, 's, 'k> {
    fn new(
        solver: &'t mut Solver<'s>,
        ball: (&'t [u32], &'t [u32]),
        ball_size: usize,
        stack: &'t mut Stack<'k>,
        tolerance: f64,
        nodes: (u64, u64),
    ) -> Self {
        BallTask {
            solver,
            ball,
            ball_size,
            stack,
            tolerance,
            nodes,
            out: Ok((0.0, 0.0)),
            used: 0,
        }
    }
}

impl Task for BallTask<'_, '_, '_> {
    fn run(&mut self) {
        let mut silent = Silent;
        let mut budget = Budget {
            nodes_left: self.nodes.0,
            nodes_used: self.nodes.1,
            progress: &mut silent,
            done: 0,
            total: 0,
        };
        self.out = self.solver.search_ball(
            self.ball,
            self.ball_size,
            self.stack,
            self.tolerance,
            &mut budget,
        );
        self.used = self.nodes.0 - budget.nodes_left;
    }
}

/// Tests' counts of the lane's ways, summed over every run: pairs kept,
/// second balls searched again in turn, next balls that shared an edge.
#[cfg(test)]
pub(super) static LANE_COUNTS: [core::sync::atomic::AtomicU32; 3] =
    [const { core::sync::atomic::AtomicU32::new(0) }; 3];

/// Count way `i` of [`LANE_COUNTS`] (nothing outside tests).
fn count_lane(_i: usize) {
    #[cfg(test)]
    LANE_COUNTS[_i].fetch_add(1, core::sync::atomic::Ordering::Relaxed);
}

/// Whether two ascending lists have no entry in common.
fn disjoint(a: &[u32], b: &[u32]) -> bool {
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            core::cmp::Ordering::Less => i += 1,
            core::cmp::Ordering::Greater => j += 1,
            core::cmp::Ordering::Equal => return false,
        }
    }
    true
}

impl Solver<'_> {
    /// Store the current state completed by the (agreeing) picks as the incumbent.
    pub(super) fn record_agreed_picks(&mut self, facets: &[u32]) {
        for &f in facets {
            let f = f as usize;
            self.incumbent[f] = match self.facet_state[f] {
                ON => true,
                UNDECIDED => self.picked_by[f] != 0 && self.picked_by[f] == self.picked_by_all(f),
                _ => false,
            };
        }
    }

    /// Greedy dive from the current state (opens the problem itself): take every
    /// facet all of whose edges pick it, else the facet whose forced selection
    /// lowers the bound least, falling back to "off" on conflict, until the picks
    /// agree. Records and returns an improvement of `value_to_beat`. `hooks`
    /// run the refresh's parallel tasks.
    pub(super) fn dive(
        &mut self,
        facets: &[u32],
        edges: &[u32],
        value_to_beat: f64,
        hooks: &dyn Progress,
    ) -> Option<f64> {
        self.open_problem(facets, edges, hooks);
        let start_mark = self.trail_len;
        let mut found = None;
        // The facets still undecided, in the order of `facets` (in the piece
        // queue, idle until the pieces are dropped): a step only ever decides
        // more of them (a failed one is undone to where it began), so each
        // step's scans look at what the step before left, not at them all.
        let undecided = core::mem::take(&mut self.piece_queue);
        let mut left = 0;
        for &f in facets {
            if let Some(slot) = undecided.get_mut(left) {
                *slot = f;
                left += 1;
            }
        }
        loop {
            let mut kept = 0;
            for i in 0..left {
                let f = undecided[i];
                if self.facet_state[f as usize] == UNDECIDED {
                    undecided[kept] = f;
                    kept += 1;
                }
            }
            left = kept;
            let undecided = &undecided[..left];
            if self.disagreements(undecided) == 0 {
                let value = self.bound(edges);
                if value > value_to_beat {
                    self.record_agreed_picks(facets);
                    found = Some(value);
                }
                break;
            }
            let step_mark = self.trail_len;
            let mut took_any = false;
            for &f in undecided {
                let f = f as usize;
                if self.facet_state[f] == UNDECIDED && self.picked_by[f] != 0 && self.edges_agree(f)
                {
                    self.assign(f, true);
                    took_any = true;
                }
            }
            if took_any {
                if self.propagate() {
                    self.flush_changed_edges();
                    continue;
                }
                self.undo_to(step_mark);
                self.flush_changed_edges();
            }
            let mut cheapest = None;
            let mut least_loss = f64::INFINITY;
            for &f in undecided {
                let f = f as usize;
                if self.facet_state[f] == UNDECIDED && self.loss_forced_on(f) < least_loss {
                    least_loss = self.loss_forced_on(f);
                    cheapest = Some(f);
                }
            }
            let Some(f) = cheapest else { break };
            self.assign(f, true);
            if self.propagate() {
                self.flush_changed_edges();
                continue;
            }
            self.undo_to(step_mark);
            self.assign(f, false);
            if self.propagate() {
                self.flush_changed_edges();
                continue;
            }
            break;
        }
        self.piece_queue = undecided;
        self.undo_to(start_mark);
        self.close_problem(facets, edges);
        found
    }

    /// Local search on the trial selection `trial`: drop every connected piece of
    /// it (facets linked through shared edges) whose score minus border penalties
    /// is negative. Dropping a whole piece takes its edges to degree 0, which is
    /// always allowed. Returns the objective gained.
    pub(super) fn drop_pieces(&mut self, facets: &[u32]) -> f64 {
        for &f in facets {
            self.visited[f as usize] = false;
        }
        let mut gain = 0.0;
        for &seed in facets {
            let seed = seed as usize;
            if !self.trial[seed] || self.visited[seed] {
                continue;
            }
            self.visited[seed] = true;
            self.piece_queue[0] = seed as u32;
            let (mut head, mut tail) = (0usize, 1usize);
            let mut piece_value = 0.0f64;
            while head < tail {
                let f = self.piece_queue[head] as usize;
                head += 1;
                piece_value += self.scores[f] as f64;
                for &e in self.edges_of(f) {
                    let e = e as usize;
                    let mut degree = 0;
                    for k in self.edge_span(e) {
                        let g = self.facet_of(self.edge_incidences[k]);
                        if self.trial[g] {
                            degree += 1;
                            if !self.visited[g] {
                                self.visited[g] = true;
                                self.piece_queue[tail] = g as u32;
                                tail += 1;
                            }
                        }
                    }
                    if degree == 1 {
                        piece_value -= self.edge_penalty(e);
                    }
                }
            }
            if piece_value < 0.0 {
                gain -= piece_value;
                for i in 0..tail {
                    self.trial[self.piece_queue[i] as usize] = false;
                }
            }
        }
        gain
    }

    /// [`Self::drop_pieces`] applied to the incumbent; returns the objective gained.
    pub(super) fn drop_incumbent_pieces(&mut self, facets: &[u32]) -> f64 {
        for &f in facets {
            self.trial[f as usize] = self.incumbent[f as usize];
        }
        let gain = self.drop_pieces(facets);
        for &f in facets {
            self.incumbent[f as usize] = self.trial[f as usize];
        }
        gain
    }

    /// Rounding heuristic (caches fresh): take the selected facets and the
    /// undecided ones at least half of whose edges pick them, then repair by
    /// removal only (so the result is always feasible, 0 being allowed
    /// everywhere): an edge at a degree its mask forbids drops its lowest-scored
    /// facets down to the largest allowed degree below; then negative pieces go.
    /// Records the result when it beats `value_to_beat`. Cost O(incidences of the
    /// problem).
    pub(super) fn round(
        &mut self,
        facets: &[u32],
        edges: &[u32],
        value_to_beat: f64,
    ) -> Option<f64> {
        for &f in facets {
            let f = f as usize;
            self.trial[f] = match self.facet_state[f] {
                ON => true,
                UNDECIDED => {
                    2 * self.picked_by[f].count_ones() >= self.facet_incidences(f).len() as u32
                }
                _ => false,
            };
        }
        for &e in edges {
            let e = e as usize;
            let mut degree = 0;
            for k in self.edge_span(e) {
                degree += self.trial[self.facet_of(self.edge_incidences[k])] as u32;
            }
            self.trial_degree[e] = degree;
            self.edge_queue.push(e);
        }
        while let Some(e) = self.edge_queue.pop() {
            let mask = self.edge_mask(e);
            let degree = self.trial_degree[e];
            if degree <= 2 && (mask >> degree) & 1 == 1 {
                continue;
            }
            // Largest allowed degree below `degree` (0 always is).
            let mut target = degree.min(2);
            while (mask >> target) & 1 == 0 {
                target -= 1;
            }
            for _ in target..degree {
                let mut weakest = None;
                let mut lowest_score = f32::INFINITY;
                for k in self.edge_span(e) {
                    let f = self.facet_of(self.edge_incidences[k]);
                    if self.trial[f] && self.scores[f] <= lowest_score {
                        lowest_score = self.scores[f];
                        weakest = Some(f);
                    }
                }
                let Some(f) = weakest else { break };
                self.trial[f] = false;
                for &g in self.edges_of(f) {
                    self.trial_degree[g as usize] -= 1;
                    self.edge_queue.push(g as usize);
                }
            }
        }
        let mut value = 0.0f64;
        for &f in facets {
            if self.trial[f as usize] {
                value += self.scores[f as usize] as f64;
            }
        }
        for &e in edges {
            if self.trial_degree[e as usize] == 1 {
                value -= self.edge_penalty(e as usize);
            }
        }
        value += self.drop_pieces(facets);
        if value > value_to_beat {
            for &f in facets {
                self.incumbent[f as usize] = self.trial[f as usize];
            }
            Some(value)
        } else {
            None
        }
    }

    /// Large-neighbourhood search on the incumbent: around each facet whose edges'
    /// picks disagree with the incumbent, take a ball of facets (breadth-first over
    /// shared edges), fix the facets bordering it to their incumbent values and solve
    /// the ball exactly (node-limited). A pass without gain doubles the ball size.
    /// Any result is feasible: the ball's edges see the fixed border, and the rest
    /// is unchanged.
    ///
    /// With a `lane` (see [`Lane`]), two consecutive balls that share no edge are
    /// searched at once, the second on the lane, in parallel tasks of `budget`'s
    /// progress; the result is that of searching them in turn.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn neighbourhood_search(
        &mut self,
        facets: &[u32],
        edges: &[u32],
        stack: &mut Stack<'_>,
        ball: &mut Neighbourhood<'_>,
        mut lane: Option<&mut Lane<'_>>,
        incumbent_value: &mut f64,
        tolerance: f64,
        budget: &mut Budget<'_>,
    ) -> Result<()> {
        let mut ball_size = NEIGHBOURHOOD_SIZE;
        for _ in 0..NEIGHBOURHOOD_PASSES {
            // Seeds: facets the bound's picks would set otherwise than the
            // incumbent (only the picks are read: each ball opens its own
            // problem, and the search after them the whole one again).
            self.open_problem_with(facets, edges, Losses::Stale, &*budget.progress);
            for &f in facets {
                let f = f as usize;
                let incumbent_picks = if self.incumbent[f] {
                    self.picked_by_all(f)
                } else {
                    0
                };
                let agree = self.picked_by[f] == incumbent_picks;
                self.neighbourhood_flags[f] = if agree { 0 } else { FLAG_SEED };
            }
            self.close_problem(facets, edges);
            if let Some(lane) = lane.as_deref_mut() {
                lane.solver.copy_state_from(self);
            }
            let value_before = *incumbent_value;
            let mut i = 0;
            while i < facets.len() {
                if budget.nodes_left == 0 {
                    return Ok(());
                }
                let seed = facets[i];
                i += 1;
                if self.neighbourhood_flags[seed as usize] & FLAG_SEED == 0 {
                    continue;
                }
                let (ball_facets, ball_edges) = self.grow_ball(seed, ball_size, ball);
                let first = (&ball.facets[..ball_facets], &ball.edges[..ball_edges]);
                let pair = match lane.as_deref_mut() {
                    Some(lane) if budget.nodes_left >= 2 => {
                        self.second_ball(facets, i, first, ball_size, lane)
                    }
                    _ => None,
                };
                if let Some((j, lane)) = pair.zip(lane.as_deref_mut()) {
                    let ball = (first, lane);
                    if self.search_two(
                        ball,
                        ball_size,
                        stack,
                        tolerance,
                        budget,
                        incumbent_value,
                    )? {
                        i = j + 1;
                    }
                    continue;
                }
                for &f in first.0 {
                    self.neighbourhood_flags[f as usize] |= FLAG_IN_BALL;
                }
                let (value, before) =
                    self.search_ball(first, ball_size, stack, tolerance, budget)?;
                if value > before + tolerance {
                    *incumbent_value += value - before;
                }
                if let Some(lane) = lane.as_deref_mut() {
                    lane.solver.copy_ball_from(self, first.0);
                }
            }
            if *incumbent_value <= value_before + tolerance {
                if ball_size >= MAX_NEIGHBOURHOOD_SIZE || ball_size >= facets.len() {
                    break;
                }
                ball_size *= 2;
            }
        }
        Ok(())
    }

    /// Search ball `first` here and the lane's ball on the lane at once, in
    /// parallel tasks of `budget`'s progress, the second given the nodes it
    /// would have in turn if the first used one. Keeps the second's result
    /// (returns `true`) when the first did use one; else it is to be searched
    /// again in turn. Either way both solvers end with the same shares and
    /// incumbent. Never inlined: its tasks' frames stay off the stack of the
    /// one-thread search (the firmware's).
    #[inline(never)]
    fn search_two(
        &mut self,
        (first, lane): ((&[u32], &[u32]), &mut Lane<'_>),
        ball_size: usize,
        stack: &mut Stack<'_>,
        tolerance: f64,
        budget: &mut Budget<'_>,
        incumbent_value: &mut f64,
    ) -> Result<bool> {
        let second = (
            &lane.ball.facets[..lane.ball_facets],
            &lane.ball.edges[..lane.ball_edges],
        );
        for &f in first.0 {
            self.neighbourhood_flags[f as usize] |= FLAG_IN_BALL;
        }
        for &f in second.0 {
            lane.solver.neighbourhood_flags[f as usize] |= FLAG_IN_BALL;
        }
        let (left, used) = (budget.nodes_left, budget.nodes_used);
        let mut here = BallTask::new(self, first, ball_size, stack, tolerance, (left, used));
        let mut there = BallTask::new(
            &mut lane.solver,
            second,
            ball_size,
            &mut lane.stack,
            tolerance,
            (left - 1, used + 1),
        );
        budget.progress.run(&mut [&mut here, &mut there]);
        let (first_out, first_used) = (here.out, here.used);
        let (second_out, second_used) = (there.out, there.used);
        let (value, before) = first_out?;
        let (second_value, second_before) = second_out?;
        budget.nodes_left -= first_used;
        budget.nodes_used += first_used;
        if value > before + tolerance {
            *incumbent_value += value - before;
        }
        lane.solver.copy_ball_from(self, first.0);
        let kept = first_used == 1;
        if kept {
            count_lane(0);
            for &f in second.0 {
                self.neighbourhood_flags[f as usize] &= !FLAG_SEED;
            }
            self.copy_ball_from(&lane.solver, second.0);
            budget.nodes_left -= second_used;
            budget.nodes_used += second_used;
            if second_value > second_before + tolerance {
                *incumbent_value += second_value - second_before;
            }
        } else {
            // The lane's copy of the second ball is overwritten after its
            // search in turn.
            count_lane(1);
        }
        if budget.nodes_used / NODES_PER_REPORT != used / NODES_PER_REPORT && !budget.report() {
            return Err(Error::Cancelled);
        }
        Ok(kept)
    }

    /// The ball to search beside `first` (just grown from the seed before
    /// `facets[from]`): the next seed's, grown into the lane's ball, when it
    /// shares no edge with `first` (so neither search reads what the other
    /// writes, nor its border). Returns the seed's position in `facets`. The
    /// first ball's seed flags are cleared on the way, as searching it clears
    /// them; the second's are left.
    fn second_ball(
        &mut self,
        facets: &[u32],
        from: usize,
        first: (&[u32], &[u32]),
        ball_size: usize,
        lane: &mut Lane<'_>,
    ) -> Option<usize> {
        for &f in first.0 {
            self.neighbourhood_flags[f as usize] &= !(FLAG_SEED | FLAG_IN_BALL);
        }
        let j = from
            + facets[from..]
                .iter()
                .position(|&f| self.neighbourhood_flags[f as usize] & FLAG_SEED != 0)?;
        let (n_facets, n_edges) = self.grow_ball(facets[j], ball_size, &mut lane.ball);
        for &f in &lane.ball.facets[..n_facets] {
            self.neighbourhood_flags[f as usize] &= !FLAG_IN_BALL;
        }
        (lane.ball_facets, lane.ball_edges) = (n_facets, n_edges);
        let apart = disjoint(first.1, &lane.ball.edges[..n_edges]);
        if !apart {
            count_lane(2);
        }
        apart.then_some(j)
    }

    /// Search one ball (`ball`: its facets, flagged [`FLAG_IN_BALL`], and its
    /// edges) with its border fixed to the incumbent and at most its share of
    /// `budget`'s nodes; clears the ball's flags and restores the state.
    /// Returns the best value found on the ball and the incumbent's value there.
    fn search_ball(
        &mut self,
        ball: (&[u32], &[u32]),
        ball_size: usize,
        stack: &mut Stack<'_>,
        tolerance: f64,
        budget: &mut Budget<'_>,
    ) -> Result<(f64, f64)> {
        let (ball_facets, ball_edges) = ball;
        // Fix the border to the incumbent; value the incumbent on the ball.
        let mark = self.trail_len;
        let mut incumbent_on_ball = 0.0f64;
        for &f in ball_facets {
            let f = f as usize;
            self.neighbourhood_flags[f] &= !FLAG_SEED;
            if self.incumbent[f] {
                incumbent_on_ball += self.scores[f] as f64;
            }
        }
        for &e in ball_edges {
            let e = e as usize;
            let mut degree = 0;
            for k in self.edge_span(e) {
                let g = self.facet_of(self.edge_incidences[k]);
                degree += self.incumbent[g] as u32;
                if self.facet_state[g] == UNDECIDED
                    && self.neighbourhood_flags[g] & FLAG_IN_BALL == 0
                {
                    self.assign(g, self.incumbent[g]);
                }
            }
            if degree == 1 {
                incumbent_on_ball -= self.edge_penalty(e);
            }
        }
        self.edge_queue.clear();
        for &e in ball_edges {
            self.edge_queue.push(e as usize);
        }
        let mut ball_value = incumbent_on_ball;
        let ball_nodes = budget
            .nodes_left
            .min(NODES_PER_NEIGHBOURHOOD_FACET * ball_size as u64);
        let nodes_kept = budget.nodes_left - ball_nodes;
        budget.nodes_left = ball_nodes;
        self.rounding_enabled = false;
        let result = self.search(
            ball_facets,
            ball_edges,
            stack,
            &mut ball_value,
            tolerance,
            f64::INFINITY,
            budget,
        );
        self.rounding_enabled = true;
        budget.nodes_left += nodes_kept;
        self.undo_to(mark);
        for &f in ball_facets {
            self.neighbourhood_flags[f as usize] &= !FLAG_IN_BALL;
        }
        result?;
        Ok((ball_value, incumbent_on_ball))
    }

    /// Fill `ball` breadth-first from `seed` over shared edges with up to `size`
    /// undecided facets (flagged [`FLAG_IN_BALL`]) and all their edges, each list
    /// sorted; returns the numbers of facets and edges.
    fn grow_ball(
        &mut self,
        seed: u32,
        size: usize,
        ball: &mut Neighbourhood<'_>,
    ) -> (usize, usize) {
        ball.facets[0] = seed;
        self.neighbourhood_flags[seed as usize] |= FLAG_IN_BALL;
        self.walk_connected(ball.facets, ball.edges, size, |solver, g| {
            let flags = &mut solver.neighbourhood_flags[g];
            let new = *flags & FLAG_IN_BALL == 0;
            *flags |= FLAG_IN_BALL;
            new
        })
    }
}
