//! The solver's state: the incidence of facets and constraints in both
//! directions, each facet's decision with the trail that undoes it, the
//! propagation queues, and the per-edge caches of the bound, all over scratch
//! slices allocated once per run. Cost: O(F + E + I log I) to build, for `I`
//! incidences (used row slots); O(incidences of its edges) to decide or undo a facet.

use super::{incidence_count, SelectInput, MASK_CLOSED, UNUSED};
use crate::arena::Alloc;
use crate::error::Result;

/// Facet state: not decided yet.
pub(super) const UNDECIDED: u8 = 0;
/// Facet state: selected.
pub(super) const ON: u8 = 1;
/// Facet state: left out.
pub(super) const OFF: u8 = 2;

/// A first-in first-out ring of distinct ids below its capacity: pushing an id
/// that is already queued does nothing, so the ring never overflows.
pub(super) struct Fifo<'a> {
    /// The ring: the queued ids from `head` on, `len` of them, wrapping around.
    items: &'a mut [u32],
    /// Whether each id is in the ring now.
    queued: &'a mut [bool],
    /// Position of the oldest queued id in `items`.
    head: usize,
    /// Number of queued ids, at most the capacity.
    len: usize,
}

impl<'a> Fifo<'a> {
    /// An empty queue for the ids `0..capacity`, in `scratch`.
    fn try_new_in<'b, A: Alloc<'b>>(scratch: &'a A, capacity: usize) -> Result<Self> {
        Ok(Fifo {
            items: scratch.try_alloc_slice(capacity, 0u32)?,
            queued: scratch.try_alloc_slice(capacity, false)?,
            head: 0,
            len: 0,
        })
    }

    /// Queue `i` unless it is queued already.
    pub(super) fn push(&mut self, i: usize) {
        if !self.queued[i] {
            self.queued[i] = true;
            let mut pos = self.head + self.len;
            if pos >= self.items.len() {
                pos -= self.items.len();
            }
            self.items[pos] = i as u32;
            self.len += 1;
        }
    }

    /// Take the oldest queued id.
    pub(super) fn pop(&mut self) -> Option<usize> {
        if self.len == 0 {
            return None;
        }
        let i = self.items[self.head] as usize;
        self.head += 1;
        if self.head == self.items.len() {
            self.head = 0;
        }
        self.len -= 1;
        self.queued[i] = false;
        Some(i)
    }

    /// Empty the queue.
    pub(super) fn clear(&mut self) {
        while self.pop().is_some() {}
    }
}

/// All solver state, over scratch slices. "Edge" here means any constraint (an
/// edge or a fold group; only the mask tells them apart).
///
/// Facet `f`'s *incidences* are the numbers `x` in
/// `facet_start[f]..facet_start[f + 1]`, one per used slot of its row, in slot
/// order: `incidence_edge[x]` is the edge, `incidence_facet[x] = f`, and
/// `x − facet_start[f]` is its bit in `picked_by[f]`. `shares[x]` is the facet's
/// share of its score on that edge; `loss_if_on[x]` / `loss_if_off[x]` are what
/// the edge's term loses if the facet is forced on / off.
///
/// The *problem* is the set of facets and edges being bounded (a component or a
/// neighbourhood): `facet_in_problem` / `edge_in_problem` mark it, and for its
/// edges `edge_terms`, `top_incidences`, `top_shares`, `loss_if_on`, `loss_if_off`
/// and `picked_by` are kept in step with the state and the shares, except for the
/// edges waiting in `changed_edges` (state changed; see
/// [`Solver::flush_changed_edges`]) or in `stale_edges` (shares moved, losses and
/// picks not yet redone; see [`Solver::refresh_stale_marginals`]), and for the
/// losses during the root's smoothed sweeps (refreshed without them: nothing
/// there reads them, and every later reader opens the problem again).
pub(super) struct Solver<'a> {
    /// CSR offsets of the facets: facet `f`'s incidences are
    /// `facet_start[f]..facet_start[f + 1]`, 3 to 6 of them; the last entry is the
    /// incidence count. Fixed after construction.
    pub(super) facet_start: &'a [u32],
    /// The edge of each incidence. Fixed after construction.
    pub(super) incidence_edge: &'a [u32],
    /// The facet of each incidence. Fixed after construction.
    pub(super) incidence_facet: &'a [u32],
    /// The input's score of each facet (finite).
    pub(super) scores: &'a [f32],
    /// The input's allowed degrees per edge (`None`: all [`MASK_CLOSED`]); read
    /// through [`Solver::edge_mask`].
    pub(super) edge_masks: Option<&'a [u8]>,
    /// The input's penalty per edge for ending with one facet (`None`: all 0);
    /// read through [`Solver::edge_penalty`].
    pub(super) edge_penalties: Option<&'a [f32]>,
    /// CSR offsets of the edges: edge `e`'s incidences are
    /// `edge_incidences[edge_start[e]..edge_start[e + 1]]`. Fixed after construction.
    pub(super) edge_start: &'a [u32],
    /// The incidences of each edge, grouped by class (see `incidence_class`):
    /// classes by id, then the singletons; ascending within a class, so facets
    /// ascending. Fixed after construction.
    pub(super) edge_incidences: &'a [u32],
    /// The *class* of each incidence on its edge: the at-most-one constraint (fold
    /// group) of the facet that holds the most facets of that edge (at least two;
    /// ties to the lower id), or [`UNUSED`] (a class of its own). A
    /// selection takes at most one facet per class, so an edge's term takes two
    /// shares from distinct classes only. All [`UNUSED`] without masks.
    pub(super) incidence_class: &'a [u32],
    /// [`UNDECIDED`], [`ON`] or [`OFF`] per facet; decided facets are exactly
    /// those on the trail.
    pub(super) facet_state: &'a mut [u8],
    /// Per edge, how many of its facets are [`ON`].
    pub(super) selected_count: &'a mut [u32],
    /// Per edge, how many of its facets are [`UNDECIDED`].
    pub(super) undecided_count: &'a mut [u32],
    /// Edges to propagate (also the repair queue of the rounding heuristic);
    /// empty whenever [`Solver::propagate`] has returned.
    pub(super) edge_queue: Fifo<'a>,
    /// Undecided facets to re-split (see [`Solver::resplit_queued`]).
    pub(super) facet_queue: Fifo<'a>,
    /// The decided facets in the order they were decided: `trail[..trail_len]`,
    /// each once. Undoing to a mark pops the facets after it.
    pub(super) trail: &'a mut [u32],
    /// Length of `trail`: the number of decided facets.
    pub(super) trail_len: usize,
    /// Share `λ` of each incidence in its facet's score; a facet's shares sum to
    /// its score up to rounding.
    pub(super) shares: &'a mut [f64],
    /// Per facet, bit `i` set: the `i`-th edge of the facet (incidence
    /// `facet_start[f] + i`) takes the facet in its best term. 0 for decided facets.
    pub(super) picked_by: &'a mut [u8],
    /// Per incidence of an undecided facet, its edge's term minus the best the
    /// edge can do with the facet on (its share included); 0 for decided facets
    /// and when no completion satisfies the edge.
    pub(super) loss_if_on: &'a mut [f64],
    /// Per incidence of an undecided facet, its edge's term minus the best the
    /// edge can do with the facet off; 0 as for `loss_if_on`.
    pub(super) loss_if_off: &'a mut [f64],
    /// Per edge, the incidences holding the best undecided share of its three
    /// best classes, best first (`u32::MAX` where there are fewer classes).
    pub(super) top_incidences: &'a mut [[u32; 3]],
    /// Per edge, the shares at `top_incidences` (descending), then the second
    /// best undecided share of the first two of those classes (`−∞` where none).
    pub(super) top_shares: &'a mut [[f64; 5]],
    /// Per edge, its term of the bound: [`super::bound::edge_term`] of its counts
    /// and its two best shares of distinct classes (`−∞`: no allowed degree).
    pub(super) edge_terms: &'a mut [f64],
    /// Whether each edge belongs to the open problem.
    pub(super) edge_in_problem: &'a mut [bool],
    /// Whether each facet belongs to the open problem.
    pub(super) facet_in_problem: &'a mut [bool],
    /// Whether each edge of the problem waits in `changed_edges`. All `false`
    /// while no problem is open, so [`Solver::walk_connected`] borrows it then to
    /// mark the edges it meets (and clears it again).
    pub(super) edge_changed: &'a mut [bool],
    /// The edges whose state changed since their caches were refreshed:
    /// `changed_edges[..changed_len]`, each once.
    pub(super) changed_edges: &'a mut [u32],
    /// Length of the list in `changed_edges`.
    pub(super) changed_len: usize,
    /// Whether each edge waits in `stale_edges`.
    pub(super) marginals_stale: &'a mut [bool],
    /// The edges whose shares moved since their losses and picks were computed:
    /// `stale_edges[..stale_len]`, each once.
    pub(super) stale_edges: &'a mut [u32],
    /// Length of the list in `stale_edges`.
    pub(super) stale_len: usize,
    /// Sum of the scores of the open problem's selected facets.
    pub(super) selected_score: f64,
    /// Breadth-first queue of a connected piece of the trial selection
    /// ([`Solver::drop_pieces`]).
    pub(super) piece_queue: &'a mut [u32],
    /// Facets met by a breadth-first walk (components, pieces); meaningful
    /// only during the walk.
    pub(super) visited: &'a mut [bool],
    /// A trial selection (rounding heuristic, piece dropping).
    pub(super) trial: &'a mut [bool],
    /// Per edge, its degree in `trial` (during rounding). At construction, a
    /// counter of facets per fold group.
    pub(super) trial_degree: &'a mut [u32],
    /// Per facet, the flags of the neighbourhood search
    /// ([`Solver::neighbourhood_search`]): a seed still to visit, in the current
    /// ball. Meaningful only during that search.
    pub(super) neighbourhood_flags: &'a mut [u8],
    /// Whether search nodes run the rounding heuristic (off inside a
    /// neighbourhood, whose outside is fixed).
    pub(super) rounding_enabled: bool,
    /// Mean |score| of the component being solved (positive).
    pub(super) score_scale: f64,
    /// The smallest share move a re-split propagates: `MIN_SHARE_MOVE` times
    /// `score_scale`.
    pub(super) min_share_move: f64,
    /// The incumbent: the best feasible selection found (the run's result).
    pub(super) incumbent: &'a mut [bool],
}

/// The incidence arrays while they are built, before they are frozen into a
/// [`Solver`].
struct IncidenceBuilder<'a> {
    facet_start: &'a mut [u32],
    incidence_edge: &'a mut [u32],
    incidence_facet: &'a mut [u32],
    edge_start: &'a mut [u32],
    edge_incidences: &'a mut [u32],
    incidence_class: &'a mut [u32],
}

impl IncidenceBuilder<'_> {
    /// Facet → edge incidence (CSR of the used slots, in slot order), with an even
    /// split of each score over the facet's edges into `shares`; counts each
    /// edge's incidences into `edge_start[e + 1]`.
    fn link_facets(&mut self, input: &SelectInput<'_>, shares: &mut [f64]) {
        let mut x = 0usize;
        for (f, row) in input.facet_edges.iter().enumerate() {
            self.facet_start[f] = x as u32;
            for &e in row.iter().filter(|&&e| e != UNUSED) {
                self.incidence_edge[x] = e;
                self.incidence_facet[x] = f as u32;
                self.edge_start[e as usize + 1] += 1;
                x += 1;
            }
            let k = x - self.facet_start[f] as usize;
            let score = input.scores[f] as f64;
            shares[self.facet_start[f] as usize..x].fill(score / k as f64);
            shares[x - 1] = score - (k - 1) as f64 * (score / k as f64);
        }
        self.facet_start[input.facet_edges.len()] = x as u32;
    }

    /// Edge → facet incidence (CSR), facets ascending within each edge, from the
    /// counts [`Self::link_facets`] left; sets every edge's undecided count.
    /// `filled` (all 0) counts the incidences placed per edge, and is all 0 again
    /// after.
    fn link_edges(&mut self, undecided_count: &mut [u32], filled: &mut [u32]) {
        for e in 0..undecided_count.len() {
            self.edge_start[e + 1] += self.edge_start[e];
            undecided_count[e] = self.edge_start[e + 1] - self.edge_start[e];
        }
        for (x, &e) in self.incidence_edge.iter().enumerate() {
            let e = e as usize;
            self.edge_incidences[(self.edge_start[e] + filled[e]) as usize] = x as u32;
            filled[e] += 1;
        }
        filled.fill(0);
    }

    /// Classes (see [`Solver::incidence_class`]): on each edge, a facet's fold
    /// group holding the most facets of the edge (at least two; ties to the lower
    /// id); then each edge's incidences sorted by class. `group_size` (all 0)
    /// counts facets per group and is all 0 again after. Cost O(I log I).
    fn assign_classes(&mut self, masks: &[u8], group_size: &mut [u32]) {
        let at_most_one = |g: u32| masks[g as usize] & 0b100 == 0;
        let (facet_start, incidence_edge, incidence_facet) = (
            &*self.facet_start,
            &*self.incidence_edge,
            &*self.incidence_facet,
        );
        for e in (0..masks.len()).filter(|&e| !at_most_one(e as u32)) {
            let span = self.edge_start[e] as usize..self.edge_start[e + 1] as usize;
            let groups = |x: u32| {
                let f = incidence_facet[x as usize] as usize;
                incidence_edge[facet_start[f] as usize..facet_start[f + 1] as usize]
                    .iter()
                    .copied()
                    .filter(move |&g| g as usize != e && at_most_one(g))
            };
            for &x in &self.edge_incidences[span.clone()] {
                for g in groups(x) {
                    group_size[g as usize] += 1;
                }
            }
            for &x in &self.edge_incidences[span.clone()] {
                let mut best = (1u32, UNUSED);
                for g in groups(x) {
                    let size = group_size[g as usize];
                    if size > best.0 || (size == best.0 && size >= 2 && g < best.1) {
                        best = (size, g);
                    }
                }
                self.incidence_class[x as usize] = best.1;
            }
            for &x in &self.edge_incidences[span.clone()] {
                for g in groups(x) {
                    group_size[g as usize] = 0;
                }
            }
            let classes = &*self.incidence_class;
            self.edge_incidences[span].sort_unstable_by_key(|&x| (classes[x as usize], x));
        }
    }
}

impl<'a> Solver<'a> {
    /// The solver of `input` with every facet undecided and no problem open,
    /// its arrays in `scratch` (the allocations [`super::bytes_needed`] counts,
    /// in its order), the result in `incumbent` (all `false`).
    pub(super) fn try_new_in<'b, A: Alloc<'b>>(
        scratch: &'a A,
        input: &SelectInput<'a>,
        incumbent: &'a mut [bool],
    ) -> Result<Self> {
        let facets = input.facet_edges.len();
        let edges = input.edge_count;
        let edge_start = scratch.try_alloc_slice(edges + 1, 0u32)?;
        let incidences = incidence_count(input.facet_edges);
        let edge_incidences = scratch.try_alloc_slice(incidences, 0u32)?;
        let facet_start = scratch.try_alloc_slice(facets + 1, 0u32)?;
        let incidence_edge = scratch.try_alloc_slice(incidences, 0u32)?;
        let incidence_facet = scratch.try_alloc_slice(incidences, 0u32)?;
        let incidence_class = scratch.try_alloc_slice(incidences, UNUSED)?;
        let facet_state = scratch.try_alloc_slice(facets, UNDECIDED)?;
        let selected_count = scratch.try_alloc_slice(edges, 0u32)?;
        let undecided_count = scratch.try_alloc_slice(edges, 0u32)?;
        let edge_queue = Fifo::try_new_in(scratch, edges)?;
        let facet_queue = Fifo::try_new_in(scratch, facets)?;
        let trail = scratch.try_alloc_slice(facets, 0u32)?;
        let shares = scratch.try_alloc_slice(incidences, 0.0f64)?;
        let picked_by = scratch.try_alloc_slice(facets, 0u8)?;
        let loss_if_on = scratch.try_alloc_slice(incidences, 0.0f64)?;
        let loss_if_off = scratch.try_alloc_slice(incidences, 0.0f64)?;
        let top_incidences = scratch.try_alloc_slice(edges, [u32::MAX; 3])?;
        let top_shares = scratch.try_alloc_slice(edges, [f64::NEG_INFINITY; 5])?;
        let edge_terms = scratch.try_alloc_slice(edges, 0.0f64)?;
        let edge_in_problem = scratch.try_alloc_slice(edges, false)?;
        let facet_in_problem = scratch.try_alloc_slice(facets, false)?;
        let edge_changed = scratch.try_alloc_slice(edges, false)?;
        let changed_edges = scratch.try_alloc_slice(edges, 0u32)?;
        let marginals_stale = scratch.try_alloc_slice(edges, false)?;
        let stale_edges = scratch.try_alloc_slice(edges, 0u32)?;
        let piece_queue = scratch.try_alloc_slice(facets, 0u32)?;
        let visited = scratch.try_alloc_slice(facets, false)?;
        let trial = scratch.try_alloc_slice(facets, false)?;
        let trial_degree = scratch.try_alloc_slice(edges, 0u32)?;
        let neighbourhood_flags = scratch.try_alloc_slice(facets, 0u8)?;

        let mut builder = IncidenceBuilder {
            facet_start,
            incidence_edge,
            incidence_facet,
            edge_start,
            edge_incidences,
            incidence_class,
        };
        builder.link_facets(input, shares);
        builder.link_edges(undecided_count, selected_count);
        if let Some(masks) = input.edge_mask {
            builder.assign_classes(masks, trial_degree);
        }
        let IncidenceBuilder {
            facet_start,
            incidence_edge,
            incidence_facet,
            edge_start,
            edge_incidences,
            incidence_class,
        } = builder;

        Ok(Solver {
            facet_start,
            incidence_edge,
            incidence_facet,
            scores: input.scores,
            edge_masks: input.edge_mask,
            edge_penalties: input.edge_penalty,
            edge_start,
            edge_incidences,
            incidence_class,
            facet_state,
            selected_count,
            undecided_count,
            edge_queue,
            facet_queue,
            trail,
            trail_len: 0,
            shares,
            picked_by,
            loss_if_on,
            loss_if_off,
            top_incidences,
            top_shares,
            edge_terms,
            edge_in_problem,
            facet_in_problem,
            edge_changed,
            changed_edges,
            changed_len: 0,
            marginals_stale,
            stale_edges,
            stale_len: 0,
            selected_score: 0.0,
            piece_queue,
            visited,
            trial,
            trial_degree,
            neighbourhood_flags,
            rounding_enabled: true,
            score_scale: 1.0,
            min_share_move: 0.0,
            incumbent,
        })
    }

    /// Allowed degrees of edge `e` (bit d: degree d).
    pub(super) fn edge_mask(&self, e: usize) -> u8 {
        self.edge_masks.map_or(MASK_CLOSED, |m| m[e])
    }

    /// Cost of edge `e` ending with exactly one facet.
    pub(super) fn edge_penalty(&self, e: usize) -> f64 {
        self.edge_penalties.map_or(0.0, |p| p[e] as f64)
    }

    /// Positions in `edge_incidences` of edge `e`'s incidences.
    pub(super) fn edge_span(&self, e: usize) -> core::ops::Range<usize> {
        self.edge_start[e] as usize..self.edge_start[e + 1] as usize
    }

    /// The incidences of facet `f`.
    pub(super) fn facet_incidences(&self, f: usize) -> core::ops::Range<usize> {
        self.facet_start[f] as usize..self.facet_start[f + 1] as usize
    }

    /// The edges of facet `f` (borrowed from the incidence arrays, not from
    /// `self`, so `self` may change while they are walked).
    pub(super) fn edges_of(&self, f: usize) -> &'a [u32] {
        let incidence_edge: &'a [u32] = self.incidence_edge;
        &incidence_edge[self.facet_start[f] as usize..self.facet_start[f + 1] as usize]
    }

    /// The facet of incidence `x`.
    pub(super) fn facet_of(&self, x: u32) -> usize {
        self.incidence_facet[x as usize] as usize
    }

    /// `picked_by` of a facet all of whose edges pick it.
    pub(super) fn picked_by_all(&self, f: usize) -> u8 {
        ((1u32 << (self.facet_start[f + 1] - self.facet_start[f])) - 1) as u8
    }

    /// Whether the edges of undecided facet `f` agree on it (all pick it or none).
    pub(super) fn edges_agree(&self, f: usize) -> bool {
        self.picks_agree(f, self.picked_by[f])
    }

    /// [`Solver::edges_agree`] with `picked` as the facet's picks (a mask
    /// not yet stored, as a refresh's tasks have it).
    pub(super) fn picks_agree(&self, f: usize, picked: u8) -> bool {
        picked == 0 || picked == self.picked_by_all(f)
    }

    /// Breadth-first walk over shared edges from `facets[0]` (already claimed):
    /// appends to `facets` the undecided facets that `claim` accepts (`claim`
    /// marks them, so it accepts each once), at most `max_facets` facets in all,
    /// and to `edges` every edge of the facets reached. Both lists come back
    /// sorted; returns their lengths. Marks the edges met in `edge_changed`
    /// (so no problem may be open) and clears them again. Cost O(incidences of
    /// the edges met).
    pub(super) fn walk_connected(
        &mut self,
        facets: &mut [u32],
        edges: &mut [u32],
        max_facets: usize,
        mut claim: impl FnMut(&mut Self, usize) -> bool,
    ) -> (usize, usize) {
        let (mut head, mut facet_count, mut edge_count) = (0usize, 1usize, 0usize);
        while head < facet_count {
            let f = facets[head] as usize;
            head += 1;
            for &e in self.edges_of(f) {
                let e = e as usize;
                if self.edge_changed[e] {
                    continue;
                }
                self.edge_changed[e] = true;
                edges[edge_count] = e as u32;
                edge_count += 1;
                for k in self.edge_span(e) {
                    let g = self.facet_of(self.edge_incidences[k]);
                    if facet_count < max_facets
                        && self.facet_state[g] == UNDECIDED
                        && claim(self, g)
                    {
                        facets[facet_count] = g as u32;
                        facet_count += 1;
                    }
                }
            }
        }
        for &e in &edges[..edge_count] {
            self.edge_changed[e as usize] = false;
        }
        facets[..facet_count].sort_unstable();
        edges[..edge_count].sort_unstable();
        (facet_count, edge_count)
    }

    /// Queue the problem edges of `f` for a cache refresh.
    pub(super) fn mark_edges_changed(&mut self, f: usize) {
        for &e in self.edges_of(f) {
            let e = e as usize;
            if self.edge_in_problem[e] && !self.edge_changed[e] {
                self.edge_changed[e] = true;
                self.changed_edges[self.changed_len] = e as u32;
                self.changed_len += 1;
            }
        }
    }

    /// Decide `f` (undecided), push it on the trail and queue its edges for
    /// propagation.
    pub(super) fn assign(&mut self, f: usize, on: bool) {
        self.facet_state[f] = if on { ON } else { OFF };
        self.trail[self.trail_len] = f as u32;
        self.trail_len += 1;
        if on && self.facet_in_problem[f] {
            self.selected_score += self.scores[f] as f64;
        }
        for &e in self.edges_of(f) {
            let e = e as usize;
            self.undecided_count[e] -= 1;
            if on {
                self.selected_count[e] += 1;
            }
            self.edge_queue.push(e);
        }
        self.mark_edges_changed(f);
    }

    /// Undo every decision after trail position `mark`, and drop any pending
    /// propagation.
    pub(super) fn undo_to(&mut self, mark: usize) {
        self.edge_queue.clear();
        while self.trail_len > mark {
            self.trail_len -= 1;
            let f = self.trail[self.trail_len] as usize;
            let on = self.facet_state[f] == ON;
            self.facet_state[f] = UNDECIDED;
            if on && self.facet_in_problem[f] {
                self.selected_score -= self.scores[f] as f64;
            }
            for &e in self.edges_of(f) {
                let e = e as usize;
                self.undecided_count[e] += 1;
                if on {
                    self.selected_count[e] -= 1;
                }
            }
            self.mark_edges_changed(f);
        }
    }
}

impl<'a> Fifo<'a> {
    /// A queue of the same capacity as `other`, in `scratch`, empty.
    fn try_like_in<'b, A: Alloc<'b>>(scratch: &'a A, other: &Fifo<'_>) -> Result<Self> {
        Fifo::try_new_in(scratch, other.items.len())
    }

    /// Make this queue hold what `other` holds (same capacity).
    fn copy_from(&mut self, other: &Fifo<'_>) {
        self.items.copy_from_slice(other.items);
        self.queued.copy_from_slice(other.queued);
        (self.head, self.len) = (other.head, other.len);
    }
}

impl<'a> Solver<'a> {
    /// A *lane*: a second solver over the same incidence arrays (shared, they
    /// never change) with its own copy of every array that does, in `scratch`,
    /// so that a neighbourhood can be searched on it while another is searched
    /// on `self`. Its state is set by [`Solver::copy_state_from`]; the bytes it
    /// takes are counted by `state_bytes` in the module above.
    pub(super) fn try_lane_in<'s, 'b, A: Alloc<'b>>(&self, scratch: &'s A) -> Result<Solver<'s>>
    where
        'a: 's,
    {
        let (f, e, i) = (
            self.facet_state.len(),
            self.edge_terms.len(),
            self.shares.len(),
        );
        Ok(Solver {
            facet_start: self.facet_start,
            incidence_edge: self.incidence_edge,
            incidence_facet: self.incidence_facet,
            scores: self.scores,
            edge_masks: self.edge_masks,
            edge_penalties: self.edge_penalties,
            edge_start: self.edge_start,
            edge_incidences: self.edge_incidences,
            incidence_class: self.incidence_class,
            facet_state: scratch.try_alloc_slice(f, UNDECIDED)?,
            selected_count: scratch.try_alloc_slice(e, 0u32)?,
            undecided_count: scratch.try_alloc_slice(e, 0u32)?,
            edge_queue: Fifo::try_like_in(scratch, &self.edge_queue)?,
            facet_queue: Fifo::try_like_in(scratch, &self.facet_queue)?,
            trail: scratch.try_alloc_slice(f, 0u32)?,
            trail_len: 0,
            shares: scratch.try_alloc_slice(i, 0.0f64)?,
            picked_by: scratch.try_alloc_slice(f, 0u8)?,
            loss_if_on: scratch.try_alloc_slice(i, 0.0f64)?,
            loss_if_off: scratch.try_alloc_slice(i, 0.0f64)?,
            top_incidences: scratch.try_alloc_slice(e, [u32::MAX; 3])?,
            top_shares: scratch.try_alloc_slice(e, [f64::NEG_INFINITY; 5])?,
            edge_terms: scratch.try_alloc_slice(e, 0.0f64)?,
            edge_in_problem: scratch.try_alloc_slice(e, false)?,
            facet_in_problem: scratch.try_alloc_slice(f, false)?,
            edge_changed: scratch.try_alloc_slice(e, false)?,
            changed_edges: scratch.try_alloc_slice(e, 0u32)?,
            changed_len: 0,
            marginals_stale: scratch.try_alloc_slice(e, false)?,
            stale_edges: scratch.try_alloc_slice(e, 0u32)?,
            stale_len: 0,
            selected_score: 0.0,
            piece_queue: scratch.try_alloc_slice(f, 0u32)?,
            visited: scratch.try_alloc_slice(f, false)?,
            trial: scratch.try_alloc_slice(f, false)?,
            trial_degree: scratch.try_alloc_slice(e, 0u32)?,
            neighbourhood_flags: scratch.try_alloc_slice(f, 0u8)?,
            rounding_enabled: true,
            score_scale: 1.0,
            min_share_move: 0.0,
            incumbent: scratch.try_alloc_slice(f, false)?,
        })
    }

    /// Make every changing array and value of this lane equal to `main`'s (no
    /// problem open in either).
    pub(super) fn copy_state_from(&mut self, main: &Solver<'_>) {
        self.facet_state.copy_from_slice(main.facet_state);
        self.selected_count.copy_from_slice(main.selected_count);
        self.undecided_count.copy_from_slice(main.undecided_count);
        self.edge_queue.copy_from(&main.edge_queue);
        self.facet_queue.copy_from(&main.facet_queue);
        self.trail.copy_from_slice(main.trail);
        self.trail_len = main.trail_len;
        self.shares.copy_from_slice(main.shares);
        self.picked_by.copy_from_slice(main.picked_by);
        self.loss_if_on.copy_from_slice(main.loss_if_on);
        self.loss_if_off.copy_from_slice(main.loss_if_off);
        self.top_incidences.copy_from_slice(main.top_incidences);
        self.top_shares.copy_from_slice(main.top_shares);
        self.edge_terms.copy_from_slice(main.edge_terms);
        self.edge_in_problem.copy_from_slice(main.edge_in_problem);
        self.facet_in_problem.copy_from_slice(main.facet_in_problem);
        self.edge_changed.copy_from_slice(main.edge_changed);
        self.changed_edges.copy_from_slice(main.changed_edges);
        self.changed_len = main.changed_len;
        self.marginals_stale.copy_from_slice(main.marginals_stale);
        self.stale_edges.copy_from_slice(main.stale_edges);
        self.stale_len = main.stale_len;
        self.selected_score = main.selected_score;
        self.piece_queue.copy_from_slice(main.piece_queue);
        self.visited.copy_from_slice(main.visited);
        self.trial.copy_from_slice(main.trial);
        self.trial_degree.copy_from_slice(main.trial_degree);
        self.neighbourhood_flags
            .copy_from_slice(main.neighbourhood_flags);
        self.rounding_enabled = main.rounding_enabled;
        self.score_scale = main.score_scale;
        self.min_share_move = main.min_share_move;
        self.incumbent.copy_from_slice(main.incumbent);
    }

    /// Copy what a neighbourhood search leaves behind on facets `facets` (their
    /// shares and their incumbent bits) from `from`.
    pub(super) fn copy_ball_from(&mut self, from: &Solver<'_>, facets: &[u32]) {
        for &f in facets {
            let f = f as usize;
            let x = self.facet_incidences(f);
            self.shares[x.clone()].copy_from_slice(&from.shares[x]);
            self.incumbent[f] = from.incumbent[f];
        }
    }
}
