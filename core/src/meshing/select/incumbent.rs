//! Incumbents (step 5 of the module docs): the greedy dive, rounding, dropping
//! pieces worth less than nothing, and the large-neighbourhood search. Each one
//! only ever records a feasible selection, and only when it is better. Cost: a
//! dive is at most F propagations; rounding and piece dropping O(incidences of
//! the problem); a neighbourhood search at most its share of the node budget.

use super::search::{Budget, Stack};
use super::solver::{Solver, ON, UNDECIDED};
use crate::arena::Alloc;
use crate::error::Result;
use crate::progress::Progress;

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
        loop {
            if self.disagreements(facets) == 0 {
                let value = self.bound(edges);
                if value > value_to_beat {
                    self.record_agreed_picks(facets);
                    found = Some(value);
                }
                break;
            }
            let step_mark = self.trail_len;
            let mut took_any = false;
            for &f in facets {
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
            for &f in facets {
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
    #[allow(clippy::too_many_arguments)]
    pub(super) fn neighbourhood_search(
        &mut self,
        facets: &[u32],
        edges: &[u32],
        stack: &mut Stack<'_>,
        ball: &mut Neighbourhood<'_>,
        incumbent_value: &mut f64,
        tolerance: f64,
        budget: &mut Budget<'_>,
    ) -> Result<()> {
        let mut ball_size = NEIGHBOURHOOD_SIZE;
        for _ in 0..NEIGHBOURHOOD_PASSES {
            // Seeds: facets the bound's picks would set otherwise than the incumbent.
            self.open_problem(facets, edges, &*budget.progress);
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
            let value_before = *incumbent_value;
            for &seed in facets {
                if budget.nodes_left == 0 {
                    return Ok(());
                }
                if self.neighbourhood_flags[seed as usize] & FLAG_SEED == 0 {
                    continue;
                }
                let (ball_facets, ball_edges) = self.grow_ball(seed, ball_size, ball);
                // Fix the border to the incumbent; value the incumbent on the ball.
                let mark = self.trail_len;
                let mut incumbent_on_ball = 0.0f64;
                for i in 0..ball_facets {
                    let f = ball.facets[i] as usize;
                    self.neighbourhood_flags[f] &= !FLAG_SEED;
                    if self.incumbent[f] {
                        incumbent_on_ball += self.scores[f] as f64;
                    }
                }
                for i in 0..ball_edges {
                    let e = ball.edges[i] as usize;
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
                for i in 0..ball_edges {
                    self.edge_queue.push(ball.edges[i] as usize);
                }
                let mut ball_value = incumbent_on_ball;
                let ball_nodes = budget
                    .nodes_left
                    .min(NODES_PER_NEIGHBOURHOOD_FACET * ball_size as u64);
                let nodes_kept = budget.nodes_left - ball_nodes;
                budget.nodes_left = ball_nodes;
                self.rounding_enabled = false;
                let result = self.search(
                    &ball.facets[..ball_facets],
                    &ball.edges[..ball_edges],
                    stack,
                    &mut ball_value,
                    tolerance,
                    f64::INFINITY,
                    budget,
                );
                self.rounding_enabled = true;
                budget.nodes_left += nodes_kept;
                self.undo_to(mark);
                for i in 0..ball_facets {
                    self.neighbourhood_flags[ball.facets[i] as usize] &= !FLAG_IN_BALL;
                }
                result?;
                if ball_value > incumbent_on_ball + tolerance {
                    *incumbent_value += ball_value - incumbent_on_ball;
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
