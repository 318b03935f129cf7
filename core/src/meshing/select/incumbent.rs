//! Incumbents (step 5 of the module docs): the greedy dive, rounding, dropping
//! pieces worth less than nothing, and the large-neighbourhood search. Each one
//! only ever records a feasible selection, and only when it is better. Cost: a
//! dive is at most F propagations; rounding and piece dropping O(incidences of
//! the problem); a neighbourhood search at most its share of the node budget.

use super::bound::Losses;
use super::search::{Budget, Stack, NODES_PER_REPORT};
use super::solver::{Solver, ON, UNDECIDED};
use super::MAX_CONSTRAINTS;
use crate::arena::Alloc;
use crate::error::{Error, Result};
use crate::parallel::Task;
use crate::progress::{Progress, Silent};
use core::sync::atomic::AtomicUsize;
use core::sync::atomic::Ordering::Relaxed;

/// Facets in one neighbourhood of the large-neighbourhood search, at first; a pass
/// without gain doubles it, up to [`MAX_NEIGHBOURHOOD_SIZE`].
const NEIGHBOURHOOD_SIZE: usize = 32;
/// Facets in one neighbourhood at most.
const MAX_NEIGHBOURHOOD_SIZE: usize = 256;
/// Search nodes per neighbourhood at most, per facet of the neighbourhood size.
const NODES_PER_NEIGHBOURHOOD_FACET: u64 = 50;
/// Passes of the neighbourhood search over a component at most.
const NEIGHBOURHOOD_PASSES: u32 = 12;
/// Balls searched at once at most beside a lane ([`Solver::search_group`]).
const MAX_GROUP: usize = 8;
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

/// A second solver ([`Solver::try_lane_in`]) with its own search stack, on
/// which the neighbourhood search searches balls while the main solver
/// searches others of the same group, and the group's balls.
pub(super) struct Lane<'a> {
    /// The lane's solver.
    solver: Solver<'a>,
    /// Its search stack.
    stack: Stack<'a>,
    /// The group's balls one after another (they share no facet and no
    /// edge, so they fit).
    group: Neighbourhood<'a>,
    /// Per facet of `group`: whether it was a seed of the neighbourhood
    /// search before the group (a ball searched again takes its seeds back).
    was_seed: &'a mut [bool],
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
            group: Neighbourhood::try_new_in(scratch, facets, edges)?,
            was_seed: scratch.try_alloc_slice(facets, false)?,
        })
    }
}

/// The balls of a group ([`Solver::search_group`]) and what their searches
/// share: ball `k` is `facets[facet_end[k]..facet_end[k + 1]]` with the
/// edges `edges[edge_end[k]..edge_end[k + 1]]`.
struct Group<'g> {
    facets: &'g [u32],
    edges: &'g [u32],
    facet_end: [usize; MAX_GROUP + 1],
    edge_end: [usize; MAX_GROUP + 1],
    count: usize,
    /// The next ball not yet taken by a worker.
    next: AtomicUsize,
    ball_size: usize,
    tolerance: f64,
    /// The budget's nodes left and used before the group.
    nodes: (u64, u64),
}

impl Group<'_> {
    /// Ball `k`'s facets and edges.
    fn ball(&self, k: usize) -> (&[u32], &[u32]) {
        (
            &self.facets[self.facet_end[k]..self.facet_end[k + 1]],
            &self.edges[self.edge_end[k]..self.edge_end[k + 1]],
        )
    }
}

/// What one ball's search found (its value on the ball and the incumbent's
/// value there), and the nodes it used.
type Searched = (Result<(f64, f64)>, u64);

/// One solver searching the balls of a group, as a parallel task: each
/// ball it takes (the next not yet taken, whatever the other worker does)
/// with the nodes the ball would have in turn if every ball before it in
/// the group used one. Which worker searches a ball does not change its
/// result: the balls share no edge, and both solvers hold the same state.
struct Worker<'t, 's, 'k> {
    solver: &'t mut Solver<'s>,
    stack: &'t mut Stack<'k>,
    group: &'t Group<'t>,
    /// Per ball: what its search found, when this worker took it.
    out: [Option<Searched>; MAX_GROUP],
}

impl Task for Worker<'_, '_, '_> {
    fn run(&mut self) {
        let g = self.group;
        loop {
            let k = g.next.fetch_add(1, Relaxed);
            if k >= g.count {
                break;
            }
            let ball = g.ball(k);
            for &f in ball.0 {
                self.solver.neighbourhood_flags[f as usize] |= FLAG_IN_BALL;
            }
            let mut silent = Silent;
            let left = g.nodes.0 - k as u64;
            let mut budget = Budget {
                nodes_left: left,
                nodes_used: g.nodes.1 + k as u64,
                progress: &mut silent,
                done: 0,
                total: 0,
            };
            let out =
                self.solver
                    .search_ball(ball, g.ball_size, self.stack, g.tolerance, &mut budget);
            self.out[k] = Some((out, left - budget.nodes_left));
        }
    }
}

/// Tests' counts of the lane's ways, summed over every run: balls kept
/// beside the group's first, balls searched again in turn, next balls that
/// shared an edge with the group.
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
                if let Some(lane) = lane.as_deref_mut().filter(|_| budget.nodes_left >= 2) {
                    i = self.search_group(
                        facets,
                        i - 1,
                        first,
                        ball_size,
                        lane,
                        stack,
                        tolerance,
                        budget,
                        incumbent_value,
                    )?;
                    continue;
                }
                let (value, before) =
                    self.search_ball(first, ball_size, stack, tolerance, budget)?;
                if value > before + tolerance {
                    *incumbent_value += value - before;
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

    /// Search ball `first` (just grown from the seed at `facets[at]`, its
    /// facets flagged [`FLAG_IN_BALL`]) and the balls of the next seeds with
    /// it, as long as none shares an edge with one before it (at most
    /// [`MAX_GROUP`], and no more than the nodes left), as parallel tasks of
    /// `budget`'s progress: this solver and the lane each search the next
    /// ball not yet taken. The result is that of searching them in turn:
    /// each ball is given the nodes it would have in turn if every ball
    /// before it used one, and is kept when its search would have taken
    /// the same steps under the nodes left in turn (below); from the first
    /// ball that is not, the balls are searched again in turn (their seeds
    /// and state as before). Both solvers end with the
    /// same shares and incumbent. Returns where the seeds go on in
    /// `facets`. Never inlined: its tasks' frames stay off the stack of the
    /// one-thread search (the firmware's).
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn search_group(
        &mut self,
        facets: &[u32],
        at: usize,
        first: (&[u32], &[u32]),
        ball_size: usize,
        lane: &mut Lane<'_>,
        stack: &mut Stack<'_>,
        tolerance: f64,
        budget: &mut Budget<'_>,
        incumbent_value: &mut f64,
    ) -> Result<usize> {
        let Lane {
            solver: lane_solver,
            stack: lane_stack,
            group: store,
            was_seed,
        } = lane;
        let (mut facet_end, mut edge_end) = ([0usize; MAX_GROUP + 1], [0usize; MAX_GROUP + 1]);
        let mut seed_at = [0usize; MAX_GROUP];
        let (nf, ne) = (first.0.len(), first.1.len());
        store.facets[..nf].copy_from_slice(first.0);
        store.edges[..ne].copy_from_slice(first.1);
        for (w, &f) in was_seed.iter_mut().zip(first.0) {
            *w = self.neighbourhood_flags[f as usize] & FLAG_SEED != 0;
        }
        (seed_at[0], facet_end[1], edge_end[1]) = (at, nf, ne);
        let most = MAX_GROUP.min(usize::try_from(budget.nodes_left).unwrap_or(MAX_GROUP));
        let mut count = 1;
        let mut from = at + 1;
        while count < most {
            // Searching the ball before clears its seeds (and its ball's
            // flags): the next seed is the one the search in turn would take.
            for &f in &store.facets[facet_end[count - 1]..facet_end[count]] {
                self.neighbourhood_flags[f as usize] &= !(FLAG_SEED | FLAG_IN_BALL);
            }
            let Some(next) = facets[from.min(facets.len())..]
                .iter()
                .position(|&f| self.neighbourhood_flags[f as usize] & FLAG_SEED != 0)
            else {
                break;
            };
            let (f0, e0) = (facet_end[count], edge_end[count]);
            if store.facets.len() - f0 < ball_size
                || store.edges.len() - e0 < MAX_CONSTRAINTS.saturating_mul(ball_size)
            {
                break;
            }
            let mut tail = Neighbourhood {
                facets: &mut store.facets[f0..],
                edges: &mut store.edges[e0..],
            };
            let (nf, ne) = self.grow_ball(facets[from + next], ball_size, &mut tail);
            for (w, &f) in was_seed[f0..f0 + nf]
                .iter_mut()
                .zip(&store.facets[f0..f0 + nf])
            {
                let flags = &mut self.neighbourhood_flags[f as usize];
                *w = *flags & FLAG_SEED != 0;
                *flags &= !FLAG_IN_BALL;
            }
            let edges = &store.edges[e0..e0 + ne];
            if !(0..count).all(|k| disjoint(&store.edges[edge_end[k]..edge_end[k + 1]], edges)) {
                count_lane(2);
                break;
            }
            seed_at[count] = from + next;
            (facet_end[count + 1], edge_end[count + 1]) = (f0 + nf, e0 + ne);
            count += 1;
            from += next + 1;
        }
        for &f in &store.facets[..facet_end[count]] {
            self.neighbourhood_flags[f as usize] &= !FLAG_IN_BALL;
        }
        let group = Group {
            facets: &store.facets[..facet_end[count]],
            edges: &store.edges[..edge_end[count]],
            facet_end,
            edge_end,
            count,
            next: AtomicUsize::new(0),
            ball_size,
            tolerance,
            nodes: (budget.nodes_left, budget.nodes_used),
        };
        let mut here = Worker {
            solver: self,
            stack,
            group: &group,
            out: [const { None }; MAX_GROUP],
        };
        let mut there = Worker {
            solver: lane_solver,
            stack: lane_stack,
            group: &group,
            out: [const { None }; MAX_GROUP],
        };
        budget.progress.run(&mut [&mut here, &mut there]);
        let (here, there) = (here.out, there.out);
        let used_before = budget.nodes_used;
        // In turn ball k would have had the nodes left after the balls
        // before it (`budget.nodes_left` as the loop goes), not the
        // `given` it had here. A search ends where its nodes run out or
        // where its tree does, and in `used` nodes it took the same steps
        // under any limit of at least `used`: ball k is kept when it
        // ended within both limits (`used < given`: its tree ended) or
        // the two limits are one; else it and the balls after it are
        // searched again in turn.
        let cap = NODES_PER_NEIGHBOURHOOD_FACET * ball_size as u64;
        let mut next_seed = at + 1;
        let mut in_turn = true;
        for k in 0..count {
            let (ball, _) = group.ball(k);
            // (A task the progress never ran leaves its balls unsearched:
            // they are searched again in turn.)
            let searched = match (&here[k], &there[k]) {
                (Some(o), _) => Some((o, false)),
                (None, Some(o)) => Some((o, true)),
                (None, None) => None,
            };
            let given = (group.nodes.0 - k as u64).min(cap);
            let in_turn_limit = budget.nodes_left.min(cap);
            in_turn = in_turn
                && searched.is_some_and(|(&(_, used), _)| {
                    used <= in_turn_limit && (used < given || in_turn_limit == given)
                });
            let Some((&(result, used), on_lane)) = searched.filter(|_| in_turn) else {
                // Searched again in turn: its state and seeds as before.
                count_lane(1);
                in_turn = false;
                match searched {
                    Some((_, true)) => lane_solver.copy_ball_from(self, ball),
                    Some((_, false)) => self.copy_ball_from(lane_solver, ball),
                    None => {}
                }
                let seeds = &was_seed[group.facet_end[k]..group.facet_end[k + 1]];
                for (&f, &seed) in ball.iter().zip(seeds) {
                    if seed {
                        self.neighbourhood_flags[f as usize] |= FLAG_SEED;
                    }
                }
                continue;
            };
            let (value, before) = result?;
            if k > 0 {
                count_lane(0);
            }
            budget.nodes_left -= used;
            budget.nodes_used += used;
            if value > before + tolerance {
                *incumbent_value += value - before;
            }
            if on_lane {
                self.copy_ball_from(lane_solver, ball);
            } else {
                lane_solver.copy_ball_from(self, ball);
            }
            for &f in ball {
                self.neighbourhood_flags[f as usize] &= !FLAG_SEED;
            }
            next_seed = seed_at[k] + 1;
        }
        if budget.nodes_used / NODES_PER_REPORT != used_before / NODES_PER_REPORT
            && !budget.report()
        {
            return Err(Error::Cancelled);
        }
        Ok(next_seed)
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
