//! The Lagrangian bound (step 3 of the module docs): each undecided facet's
//! score split into shares over its edges, each edge's best term from its cached
//! top shares per class, and coordinate descent on the split (exact re-splits
//! and smoothed sweeps at the root). Cost: O(incidences of an edge) to refresh
//! its cache; O(incidences of a facet's edges) per re-split; O(I) per sweep.

use super::solver::{Solver, ON, UNDECIDED};
use super::{MAX_CONSTRAINTS, UNUSED};
use crate::arena::{atomic_f64_words, F64Words};
use crate::parallel;
use crate::progress::Progress;

/// Where [`Solver::smoothed_shares_with`] reads the shares: the solver's own,
/// or their atomic view while a level's tasks set them.
trait Shares: Copy {
    fn share(&self, x: usize) -> f64;
}

impl Shares for &[f64] {
    #[inline(always)]
    fn share(&self, x: usize) -> f64 {
        self[x]
    }
}

impl Shares for F64Words<'_> {
    #[inline(always)]
    fn share(&self, x: usize) -> f64 {
        self.get(x)
    }
}

/// A re-split that moves no share by more than this (relative to the mean |score|
/// of the component) is not propagated to the facet's edges.
pub(super) const MIN_SHARE_MOVE: f64 = 1e-7;
/// Re-splits of a search node between two looks at its bound
/// ([`Solver::resplit_queued_until`]). A look sums a term per edge of the
/// problem: on the neighbourhood search's balls a small part of one
/// re-split, on a whole component of a few thousand edges about one. (8 and
/// 16 saved fewer instructions on the bunny than 32: stopped sooner, a node
/// leaves its shares less settled for the nodes after it; `bench/notes.md`.)
pub(super) const RESPLITS_PER_LOOK: usize = 32;
/// Coordinate-descent sweeps over a component at its root.
const ROOT_SWEEPS: u32 = 30;
/// Initial smoothing temperature at the root, relative to the mean |score|.
const ROOT_TEMPERATURE: f64 = 0.1;
/// Root sweeps between two halvings of the temperature.
const SWEEPS_PER_COOLING: u32 = 10;
/// Smallest temperature (relative to the mean |score|); below it, exact sweeps.
const MIN_TEMPERATURE: f64 = 1e-4;
/// Root sweeps between two runs of the rounding heuristic.
const SWEEPS_PER_ROUNDING: u32 = 5;
/// Edges of a problem from which refreshing all their caches computes them in
/// parallel tasks (fewer: on the calling thread; the caches are the same).
const PARALLEL_EDGES: usize = 256;
/// Undecided facets of one level of a root sweep from which its facets are
/// re-split in parallel tasks (fewer: on the calling thread; the shares are
/// the same), and the fewest facets of a sweep run by levels at all.
const PARALLEL_LEVEL: usize = 32;
/// Fewest undecided facets a level, on average, of a sweep run by levels
/// (fewer: one facet after another, the same shares; many small levels would
/// each pay for a round of tasks).
const MIN_MEAN_LEVEL: usize = 32;

/// Scratch of a sweep by levels ([`Solver::sweep_in_levels`]): arrays the
/// neighbourhood search and the search use later, idle while the root's
/// bound runs.
pub(super) struct Levels<'s> {
    /// Per position in the facet list: its level (0: a decided facet).
    pub(super) level: &'s mut [u32],
    /// Positions grouped by level, ascending within a level.
    pub(super) order: &'s mut [u32],
    /// Where each level ends in `order` (one more entry than levels).
    pub(super) start: &'s mut [u32],
    /// Per edge id: the level of the last facet on it so far.
    pub(super) last: &'s mut [u32],
    /// What the arrays hold, planned by the first sweep and kept for the
    /// next ones: it holds while no facet of the list is decided or set free
    /// again (the root's sweeps decide none); make it [`Plan::Unplanned`]
    /// for another list or state.
    pub(super) plan: Plan,
}

/// The levels of a sweep (see [`Solver::sweep_in_levels`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Plan {
    /// Not worked out yet.
    Unplanned,
    /// The facets are swept one after another (too few a level, or too few
    /// in all).
    Serial,
    /// Levels `1..=top`, in the arrays.
    Levels(usize),
}

/// Best value of one edge alone: the maximum over degrees `d` allowed by `mask`
/// with `selected ≤ d ≤ selected + undecided` of the sum of the `d − selected`
/// best shares (`best ≥ second`, of distinct classes) minus `penalty` when
/// `d = 1`, with that `d − selected`. `−∞` when no degree is reachable. Ties go
/// to the smaller degree.
pub(super) fn edge_term(
    selected: u32,
    undecided: u32,
    mask: u8,
    penalty: f64,
    best: f64,
    second: f64,
) -> (f64, usize) {
    let mut best_value = f64::NEG_INFINITY;
    let mut best_taken = 0;
    let top = selected.saturating_add(undecided).min(2);
    let mut d = selected;
    while d <= top {
        if (mask >> d) & 1 == 1 {
            let taken = (d - selected) as usize;
            let take = match taken {
                0 => 0.0,
                1 => best,
                _ => best + second,
            };
            let value = take - if d == 1 { penalty } else { 0.0 };
            if value > best_value {
                best_value = value;
                best_taken = taken;
            }
        }
        d += 1;
    }
    (best_value, best_taken)
}

/// From an edge's cache (`top[0..3]`: the best shares of its three best classes,
/// at incidences `top_at`; `top[3]`, `top[4]`: the second best of the first two
/// classes): once incidence `x` is left out, the best two shares of distinct
/// classes, and the best share of a class other than `x`'s (`in_top_class`: `x`
/// is in the class of `top_at[0]`).
fn shares_without(
    top_at: &[u32; 3],
    top: &[f64; 5],
    x: u32,
    in_top_class: bool,
) -> (f64, f64, f64) {
    if x == top_at[0] {
        // top[3], top[1], top[2] come from three distinct classes.
        let (a, b, c) = (top[3], top[1], top[2]);
        let highest = a.max(b).max(c);
        let middle = if highest == a {
            b.max(c)
        } else if highest == b {
            a.max(c)
        } else {
            a.max(b)
        };
        (highest, middle, top[1])
    } else if x == top_at[1] {
        (top[0], top[4].max(top[2]), top[0])
    } else {
        (top[0], top[1], if in_top_class { top[1] } else { top[0] })
    }
}

/// `exp(x)`, with `exp(0) = 1` without the call (libm gives exactly 1
/// there too: the same value). The soft maxima shift by their largest term,
/// so one term of each is 0.
#[inline(always)]
fn exp(x: f64) -> f64 {
    if x == 0.0 {
        1.0
    } else {
        libm::exp(x)
    }
}

/// `ln(x)`, with `ln(1) = 0` without the call (libm gives exactly 0 there
/// too). The first elementary symmetric sum of each soft maximum is 1.
#[inline(always)]
fn ln(x: f64) -> f64 {
    if x == 1.0 {
        0.0
    } else {
        libm::log(x)
    }
}

/// The shares `t − c_i` of `score` with `k t = score + Σ c_i` over the
/// `k = on_minus_off.len()` edges (`c = on_minus_off`), the last one taking the
/// rounding so that they sum to `score` exactly as far as floating point allows.
#[inline(always)]
fn equalising_shares(score: f64, on_minus_off: &[f64]) -> [f64; MAX_CONSTRAINTS] {
    let k = on_minus_off.len();
    let t = on_minus_off.iter().fold(score, |a, &b| a + b) / k as f64;
    let mut out = [0.0; MAX_CONSTRAINTS];
    let mut rest = score;
    for i in 0..k - 1 {
        out[i] = t - on_minus_off[i];
        rest -= out[i];
    }
    out[k - 1] = rest;
    out
}

/// Whether a refresh of every edge brings the losses (`loss_if_on`,
/// `loss_if_off`) up to date too, or leaves them stale (the top shares,
/// terms and picks are fresh either way).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Losses {
    Fresh,
    Stale,
}

/// The state of one edge that its term depends on besides the shares.
#[derive(Clone, Copy)]
struct EdgeCounts {
    /// Its selected facets.
    selected: u32,
    /// Its undecided facets.
    undecided: u32,
    /// Its allowed degrees.
    mask: u8,
    /// Its cost for ending with one facet.
    penalty: f64,
}

/// One soft maximum of [`Solver::smoothed_shares_with`]: over the degrees
/// `base..=base + spare` (at most 2) the mask allows, of the elementary
/// symmetric sums `sums` shifted by `shift`, less `penalty` at degree 1.
#[derive(Clone, Copy)]
struct SoftMax {
    base: u32,
    spare: u32,
    sums: [f64; 3],
    shift: f64,
    mask: u8,
    penalty: f64,
}

impl SoftMax {
    /// A lane not used (no degree allowed).
    const NONE: SoftMax = SoftMax {
        base: 3,
        spare: 0,
        sums: [0.0; 3],
        shift: 0.0,
        mask: 0,
        penalty: 0.0,
    };
}

impl EdgeCounts {
    /// [`edge_term`] of this edge with best shares `best` and `second`.
    fn term(self, best: f64, second: f64) -> (f64, usize) {
        edge_term(
            self.selected,
            self.undecided,
            self.mask,
            self.penalty,
            best,
            second,
        )
    }
}

impl Solver<'_> {
    /// Whether incidences `a` and `b` of one edge are in the same class.
    fn same_class(&self, a: u32, b: u32) -> bool {
        a == b
            || (self.incidence_class[a as usize] == self.incidence_class[b as usize]
                && self.incidence_class[a as usize] != UNUSED)
    }

    /// What edge `e`'s term depends on besides the shares.
    #[inline]
    fn edge_counts(&self, e: usize) -> EdgeCounts {
        EdgeCounts {
            selected: self.selected_count[e],
            undecided: self.undecided_count[e],
            mask: self.edge_mask(e),
            penalty: self.edge_penalty(e),
        }
    }

    /// Edge `e`'s best term with the facet of its undecided incidence `x` forced
    /// on (not counting the facet's share), and with it forced off, from the
    /// cached top shares; `counts` are the edge's.
    #[inline(always)]
    fn forced_terms(&self, e: usize, x: u32, counts: EdgeCounts) -> (f64, f64) {
        let EdgeCounts {
            selected,
            undecided,
            mask,
            penalty,
        } = counts;
        let (best, second, best_other_class) = self.edge_shares_without(e, x);
        let on = edge_term(
            selected + 1,
            undecided - 1,
            mask,
            penalty,
            best_other_class,
            f64::NEG_INFINITY,
        )
        .0;
        let off = edge_term(selected, undecided - 1, mask, penalty, best, second).0;
        (on, off)
    }

    /// Recompute edge `e`'s best shares per class and its term from the state and
    /// the shares.
    #[inline(always)]
    fn refresh_top_shares(&mut self, e: usize) {
        let (term, at, top) = self.edge_top(e);
        self.edge_terms[e] = term;
        self.top_incidences[e] = at;
        self.top_shares[e] = top;
    }

    /// Edge `e`'s term, top incidences and top shares (see
    /// [`Solver::refresh_top_shares`]), from the state and the shares. One
    /// pass: the incidences of a class are consecutive. Always inlined, as
    /// are the bound's other small helpers on the hot paths (the refresh,
    /// the forced terms, the losses, the marginals, the equalising split):
    /// as calls, each passing its tuples back through memory, they cost the
    /// selection about 30 M more instructions a one-thread bunny run
    /// (callgrind).
    #[inline(always)]
    fn edge_top(&self, e: usize) -> (f64, [u32; 3], [f64; 5]) {
        let counts = self.edge_counts(e);
        // The best share of the three best classes, each class's second best, and
        // the incidences of the bests.
        let mut best = [f64::NEG_INFINITY; 3];
        let mut second = [f64::NEG_INFINITY; 3];
        let mut best_at = [u32::MAX; 3];
        let incidences = &self.edge_incidences[self.edge_span(e)];
        let mut k = 0;
        while k < incidences.len() {
            // One class: positions k..j (one incidence when it has no class).
            let class = self.incidence_class[incidences[k] as usize];
            let mut j = k + 1;
            if class != UNUSED {
                while j < incidences.len() && self.incidence_class[incidences[j] as usize] == class
                {
                    j += 1;
                }
            }
            let (mut class_best, mut class_second, mut class_best_at) =
                (f64::NEG_INFINITY, f64::NEG_INFINITY, u32::MAX);
            for &x in &incidences[k..j] {
                if self.facet_state[self.facet_of(x)] != UNDECIDED {
                    continue;
                }
                let share = self.shares[x as usize];
                if share > class_best {
                    (class_best, class_second, class_best_at) = (share, class_best, x);
                } else if share > class_second {
                    class_second = share;
                }
            }
            k = j;
            if class_best_at == u32::MAX {
                continue;
            }
            if class_best > best[0] {
                (best, second, best_at) = (
                    [class_best, best[0], best[1]],
                    [class_second, second[0], second[1]],
                    [class_best_at, best_at[0], best_at[1]],
                );
            } else if class_best > best[1] {
                (best, second, best_at) = (
                    [best[0], class_best, best[1]],
                    [second[0], class_second, second[1]],
                    [best_at[0], class_best_at, best_at[1]],
                );
            } else if class_best > best[2] {
                (best[2], second[2], best_at[2]) = (class_best, class_second, class_best_at);
            }
        }
        (
            counts.term(best[0], best[1]).0,
            best_at,
            [best[0], best[1], best[2], second[0], second[1]],
        )
    }

    /// [`shares_without`] for incidence `x` of edge `e`.
    #[inline(always)]
    fn edge_shares_without(&self, e: usize, x: u32) -> (f64, f64, f64) {
        let top_at = &self.top_incidences[e];
        let in_top_class = top_at[0] != u32::MAX && self.same_class(x, top_at[0]);
        shares_without(top_at, &self.top_shares[e], x, in_top_class)
    }

    /// From edge `e`'s fresh top shares: for each undecided facet on it, whether
    /// the edge picks it and (when `losses` is fresh) what the edge's term
    /// loses if it is forced on / off.
    fn refresh_marginals(&mut self, e: usize, losses: Losses) {
        let counts = self.edge_counts(e);
        let (top_at, top) = (self.top_incidences[e], self.top_shares[e]);
        let (term, taken) = counts.term(top[0], top[1]);
        for k in self.edge_span(e) {
            let x = self.edge_incidences[k];
            let xi = x as usize;
            let f = self.facet_of(x);
            let bit = 1u8 << (x - self.facet_start[f]);
            let undecided = self.facet_state[f] == UNDECIDED;
            if losses == Losses::Fresh {
                let (on, off) = if undecided {
                    self.losses(e, x, counts, term)
                } else {
                    (0.0, 0.0)
                };
                self.loss_if_on[xi] = on;
                self.loss_if_off[xi] = off;
            }
            if undecided && top_at[..taken].contains(&x) {
                self.picked_by[f] |= bit;
            } else {
                self.picked_by[f] &= !bit;
            }
        }
    }

    /// Incidence `x` of an undecided facet on edge `e` (its counts and its
    /// best term `term`): what the term loses if the facet is forced on, and
    /// off.
    #[inline(always)]
    fn losses(&self, e: usize, x: u32, counts: EdgeCounts, term: f64) -> (f64, f64) {
        let (on_term, off) = self.forced_terms(e, x, counts);
        let on = self.shares[x as usize] + on_term;
        // An edge that no completion satisfies (two classes short) makes the
        // bound −∞; its marginals are moot.
        if term.is_finite() {
            (term - on, term - off)
        } else {
            (0.0, 0.0)
        }
    }

    /// Facet `f`'s `picked_by` bits from its edges' fresh top shares, as
    /// [`Solver::refresh_marginals`] sets them, and with `losses` its losses
    /// if forced on and off, one per incidence.
    #[inline(always)]
    fn facet_marginals(&self, f: usize, mut losses: Option<(&mut [f64], &mut [f64])>) -> u8 {
        let mut picked = 0u8;
        if self.facet_state[f] != UNDECIDED {
            if let Some((on, off)) = losses {
                on.fill(0.0);
                off.fill(0.0);
            }
            return picked;
        }
        for (i, x) in self.facet_incidences(f).enumerate() {
            let e = self.incidence_edge[x] as usize;
            let counts = self.edge_counts(e);
            let (top_at, top) = (&self.top_incidences[e], &self.top_shares[e]);
            let (term, taken) = counts.term(top[0], top[1]);
            if let Some((on, off)) = losses.as_mut() {
                (on[i], off[i]) = self.losses(e, x as u32, counts, term);
            }
            picked |= u8::from(top_at[..taken].contains(&(x as u32))) << i;
        }
        picked
    }

    /// Recompute edge `e`'s cache (its losses only when `losses` is fresh).
    fn refresh_edge(&mut self, e: usize, losses: Losses) {
        self.refresh_top_shares(e);
        self.refresh_marginals(e, losses);
    }

    /// Bring the marginals of the edges whose shares moved up to date.
    pub(super) fn refresh_stale_marginals(&mut self) {
        for i in 0..self.stale_len {
            let e = self.stale_edges[i] as usize;
            self.marginals_stale[e] = false;
            self.refresh_marginals(e, Losses::Fresh);
        }
        self.stale_len = 0;
    }

    /// Refresh the edges whose state changed and queue their undecided facets for
    /// re-splitting.
    pub(super) fn flush_changed_edges(&mut self) {
        for i in 0..self.changed_len {
            let e = self.changed_edges[i] as usize;
            self.edge_changed[e] = false;
            self.refresh_edge(e, Losses::Fresh);
            for k in self.edge_span(e) {
                let f = self.facet_of(self.edge_incidences[k]);
                if self.facet_state[f] == UNDECIDED {
                    self.facet_queue.push(f);
                }
            }
        }
        self.changed_len = 0;
    }

    /// Bring the stale marginals up to date, then forget the changed edges and the
    /// queued re-splits (before every edge is refreshed, or the problem closed).
    fn drop_pending_updates(&mut self) {
        self.refresh_stale_marginals();
        for i in 0..self.changed_len {
            self.edge_changed[self.changed_edges[i] as usize] = false;
        }
        self.changed_len = 0;
        self.facet_queue.clear();
    }

    /// Refresh every edge of the current problem (`facets`, `edges`), with
    /// `Losses::Stale` leaving `loss_if_on` and `loss_if_off` as they are
    /// (the top shares, terms and picks are fresh either way). For many edges
    /// (both lists ascending), in parallel tasks run by `hooks`: the edges'
    /// top shares, each task writing those of a range of edge ids, then the
    /// marginals facet by facet, each task writing those of a range of facet
    /// ids (every edge of a problem's facet is in the problem, and the
    /// marginals of a facet outside it are never read). Else one edge after
    /// another. The caches read are the same either way.
    pub(super) fn refresh_all(
        &mut self,
        facets: &[u32],
        edges: &[u32],
        losses: Losses,
        hooks: &dyn Progress,
    ) -> Option<u32> {
        self.drop_pending_updates();
        let ascending = |list: &[u32]| list.windows(2).all(|w| w[0] < w[1]);
        let ends = match (edges.first(), edges.last(), facets.first(), facets.last()) {
            (Some(&e_first), Some(&e_last), Some(&f_first), Some(&f_last))
                if edges.len() >= PARALLEL_EDGES && ascending(edges) && ascending(facets) =>
            {
                Some((e_first, e_last, f_first, f_last))
            }
            _ => None,
        };
        let Some((e_first, e_last, f_first, f_last)) = ends else {
            for &e in edges {
                self.refresh_edge(e as usize, losses);
            }
            return None;
        };
        let (e0, e1) = (e_first as usize, e_last as usize + 1);
        let terms = core::mem::take(&mut self.edge_terms);
        let top_at = core::mem::take(&mut self.top_incidences);
        let tops = core::mem::take(&mut self.top_shares);
        let this = &*self;
        let at = |j: usize| edges.get(j).map_or(e1, |&e| e as usize) - e0;
        parallel::segments3(
            hooks,
            &mut terms[e0..e1],
            &mut top_at[e0..e1],
            &mut tops[e0..e1],
            edges.len(),
            at,
            at,
            |items, terms, top_at, tops| {
                let base = at(items.start);
                for j in items {
                    let e = edges[j] as usize;
                    let i = e - e0 - base;
                    (terms[i], top_at[i], tops[i]) = this.edge_top(e);
                }
            },
        );
        (self.edge_terms, self.top_incidences, self.top_shares) = (terms, top_at, tops);
        let (f0, f1) = (f_first as usize, f_last as usize + 1);
        let f_at = |j: usize| facets.get(j).map_or(f1, |&f| f as usize) - f0;
        if losses == Losses::Stale {
            let picked = core::mem::take(&mut self.picked_by);
            let this = &*self;
            let disagreeing = parallel::segments(
                hooks,
                &mut picked[f0..f1],
                facets.len(),
                f_at,
                |items, picked| {
                    let base = f_at(items.start);
                    let mut disagreeing = 0u32;
                    for j in items {
                        let f = facets[j] as usize;
                        let p = this.facet_marginals(f, None);
                        picked[f - f0 - base] = p;
                        disagreeing += u32::from(this.disagrees(f, p));
                    }
                    disagreeing
                },
            );
            self.picked_by = picked;
            return Some(disagreeing.iter().sum());
        }
        let (x0, x1) = (self.facet_start[f0] as usize, self.facet_start[f1] as usize);
        let on = core::mem::take(&mut self.loss_if_on);
        let off = core::mem::take(&mut self.loss_if_off);
        let picked = core::mem::take(&mut self.picked_by);
        let this = &*self;
        let x_at = |j: usize| {
            facets
                .get(j)
                .map_or(x1, |&f| this.facet_start[f as usize] as usize)
                - x0
        };
        let disagreeing = parallel::segments3(
            hooks,
            &mut on[x0..x1],
            &mut off[x0..x1],
            &mut picked[f0..f1],
            facets.len(),
            x_at,
            f_at,
            |items, on, off, picked| {
                let (base_x, base_f) = (x_at(items.start), f_at(items.start));
                let mut disagreeing = 0u32;
                for j in items {
                    let f = facets[j] as usize;
                    let xs = this.facet_incidences(f);
                    let lo = xs.start - x0 - base_x;
                    let n = xs.len();
                    let p =
                        this.facet_marginals(f, Some((&mut on[lo..lo + n], &mut off[lo..lo + n])));
                    picked[f - f0 - base_f] = p;
                    disagreeing += u32::from(this.disagrees(f, p));
                }
                disagreeing
            },
        );
        (self.loss_if_on, self.loss_if_off, self.picked_by) = (on, off, picked);
        Some(disagreeing.iter().sum())
    }

    /// Make (`facets`, `edges`) the current problem, with fresh caches (see
    /// [`Solver::refresh_all`] for `hooks`).
    pub(super) fn open_problem(&mut self, facets: &[u32], edges: &[u32], hooks: &dyn Progress) {
        self.open_problem_with(facets, edges, Losses::Fresh, hooks);
    }

    /// [`Solver::open_problem`], with the losses left stale for `Losses::Stale`
    /// (for a caller that reads only the terms and picks before the problem is
    /// opened again).
    pub(super) fn open_problem_with(
        &mut self,
        facets: &[u32],
        edges: &[u32],
        losses: Losses,
        hooks: &dyn Progress,
    ) {
        for &e in edges {
            self.edge_in_problem[e as usize] = true;
        }
        self.selected_score = 0.0;
        for &f in facets {
            let f = f as usize;
            self.facet_in_problem[f] = true;
            if self.facet_state[f] == ON {
                self.selected_score += self.scores[f] as f64;
            }
        }
        let _ = self.refresh_all(facets, edges, losses, hooks);
    }

    /// End the current problem (`facets`, `edges`); no edge waits for a refresh after.
    pub(super) fn close_problem(&mut self, facets: &[u32], edges: &[u32]) {
        self.drop_pending_updates();
        for &e in edges {
            self.edge_in_problem[e as usize] = false;
        }
        for &f in facets {
            self.facet_in_problem[f as usize] = false;
        }
    }

    /// The Lagrangian bound of the current problem (caches must be fresh).
    pub(super) fn bound(&self, edges: &[u32]) -> f64 {
        edges
            .iter()
            .fold(self.selected_score, |a, &e| a + self.edge_terms[e as usize])
    }

    /// The bound lost by forcing undecided facet `f` on, by the cached marginals.
    pub(super) fn loss_forced_on(&self, f: usize) -> f64 {
        self.facet_incidences(f).map(|x| self.loss_if_on[x]).sum()
    }

    /// The bound lost by forcing undecided facet `f` off, by the cached marginals.
    pub(super) fn loss_forced_off(&self, f: usize) -> f64 {
        self.facet_incidences(f).map(|x| self.loss_if_off[x]).sum()
    }

    /// Undecided facets whose edges do not all agree on them.
    pub(super) fn disagreements(&self, facets: &[u32]) -> u32 {
        facets
            .iter()
            .filter(|&&f| self.disagrees(f as usize, self.picked_by[f as usize]))
            .count() as u32
    }

    /// Whether facet `f`, picked by the edges of mask `picked`, is undecided
    /// and its edges disagree on it.
    fn disagrees(&self, f: usize, picked: u8) -> bool {
        self.facet_state[f] == UNDECIDED && !self.picks_agree(f, picked)
    }

    /// Coordinate descent on one facet, from the caches: re-split its score so that
    /// its `k` edges value it equally, which exactly minimises the bound over its
    /// shares (the others fixed): edge i's term is `max(off_i, λ_i + on_i)`, whose
    /// sum under `Σ λ_i = w` is at least `Σ off_i + max(0, w + Σ (on_i − off_i))`,
    /// reached when every `λ_i + on_i − off_i` is equal. A real change refreshes
    /// its edges and queues the other facets on them.
    pub(super) fn rebalance(&mut self, f: usize) {
        let mut on_minus_off = [0.0f64; MAX_CONSTRAINTS];
        let incidences = self.facet_incidences(f);
        for (slot, x) in on_minus_off.iter_mut().zip(incidences) {
            let e = self.incidence_edge[x] as usize;
            let (on, off) = self.forced_terms(e, x as u32, self.edge_counts(e));
            if !(on.is_finite() && off.is_finite()) {
                return;
            }
            *slot = on - off;
        }
        self.set_shares(f, on_minus_off);
    }

    /// Set facet `f`'s shares to [`equalising_shares`] of its score and
    /// `on_minus_off`, and when that moves them by more than `min_share_move`,
    /// refresh its edges' top shares, mark their marginals stale and queue the
    /// other undecided facets on them.
    fn set_shares(&mut self, f: usize, on_minus_off: [f64; MAX_CONSTRAINTS]) {
        let incidences = self.facet_incidences(f);
        let new = equalising_shares(self.scores[f] as f64, &on_minus_off[..incidences.len()]);
        let new = &new[..incidences.len()];
        if new
            .iter()
            .zip(&self.shares[incidences.clone()])
            .all(|(a, b)| (a - b).abs() <= self.min_share_move)
        {
            return;
        }
        self.shares[incidences].copy_from_slice(new);
        for &e in self.edges_of(f) {
            let e = e as usize;
            self.refresh_top_shares(e);
            if !self.marginals_stale[e] {
                self.marginals_stale[e] = true;
                self.stale_edges[self.stale_len] = e as u32;
                self.stale_len += 1;
            }
            for k in self.edge_span(e) {
                let g = self.facet_of(self.edge_incidences[k]);
                if g != f && self.facet_state[g] == UNDECIDED {
                    self.facet_queue.push(g);
                }
            }
        }
    }

    /// Re-split queued facets of the problem, at most `cap` of them (the rest are
    /// dropped from the queue), then refresh the marginals.
    pub(super) fn resplit_queued(&mut self, cap: usize) {
        self.resplit_queued_until(cap, None);
    }

    /// [`Solver::resplit_queued`], stopping early (the rest dropped from the
    /// queue) once the bound over `edges` is at most `to_beat` when `prune` is
    /// `Some((edges, to_beat))`, looked at every [`RESPLITS_PER_LOOK`]
    /// re-splits. An exact re-split never raises the bound, so a node whose
    /// bound has come down that far is pruned whatever the rest of its
    /// re-splits would do; they would only refine the shares it leaves.
    pub(super) fn resplit_queued_until(&mut self, cap: usize, prune: Option<(&[u32], f64)>) {
        let mut done = 0;
        while let Some(f) = self.facet_queue.pop() {
            if self.facet_state[f] == UNDECIDED && self.facet_in_problem[f] {
                self.rebalance(f);
                done += 1;
                let pruned = || {
                    done % RESPLITS_PER_LOOK == 0
                        && prune.is_some_and(|(edges, to_beat)| self.bound(edges) <= to_beat)
                };
                if done >= cap || pruned() {
                    self.facet_queue.clear();
                    break;
                }
            }
        }
        self.refresh_stale_marginals();
    }

    /// One coordinate-descent sweep over all facets, in order, on the dual
    /// smoothed at `temperature` (see [`Solver::smoothed_shares`]): each
    /// facet's new shares from the shares as the sweep has left them.
    /// Leaves the caches stale (refresh after).
    ///
    /// A facet's new shares read only the facets sharing an edge with it, so
    /// the sweep runs level by level ([`Solver::sweep_in_levels`]), each level
    /// in parallel tasks of `hooks`, when the levels are few: the same shares
    /// as one facet after another, bit for bit.
    fn smoothed_sweep(
        &mut self,
        facets: &[u32],
        temperature: f64,
        levels: &mut Levels<'_>,
        hooks: &dyn Progress,
    ) {
        if !self.sweep_in_levels(facets, temperature, levels, hooks) {
            for &f in facets {
                self.resplit_smoothed(f as usize, temperature);
            }
        }
    }

    /// Set facet `f`'s shares to [`Solver::smoothed_shares`] (unchanged when
    /// there are none).
    pub(super) fn resplit_smoothed(&mut self, f: usize, temperature: f64) {
        if let Some(new) = self.smoothed_shares(f, temperature) {
            let incidences = self.facet_incidences(f);
            let n = incidences.len();
            self.shares[incidences].copy_from_slice(&new[..n]);
        }
    }

    /// [`Solver::smoothed_sweep`] by levels, when `facets` (ascending) has
    /// at least [`MIN_MEAN_LEVEL`] undecided facets a level on average;
    /// returns whether it ran. An undecided facet's level is one more than
    /// the highest level of the facets before it (in `facets`) that share an
    /// edge with it. So two facets of one level share no edge, and every
    /// facet before a facet and sharing an edge with it is of a lower level,
    /// every one after it of a higher: sweeping the levels in turn, each
    /// level's facets from the shares the levels before left, gives each
    /// facet the shares it reads one facet after another. A level of
    /// [`PARALLEL_LEVEL`] facets or more is computed in parallel tasks, each
    /// setting its facets' shares in place (no facet of the level reads
    /// them: an atomic view of the shares, [`atomic_f64_words`]); a smaller
    /// one on the calling thread. The levels are worked out by the first
    /// sweep and kept in `levels` for the next ones ([`Levels::plan`]): the
    /// root's 30 sweeps plan once.
    pub(super) fn sweep_in_levels(
        &mut self,
        facets: &[u32],
        temperature: f64,
        levels: &mut Levels<'_>,
        hooks: &dyn Progress,
    ) -> bool {
        if levels.plan == Plan::Unplanned {
            levels.plan = self.plan_levels(facets, levels);
        }
        let Plan::Levels(top) = levels.plan else {
            return false;
        };
        let (order, start) = (&*levels.order, &*levels.start);
        for l in 1..=top {
            let list = &order[start[l - 1] as usize..start[l] as usize];
            if list.len() < PARALLEL_LEVEL {
                for &j in list {
                    self.resplit_smoothed(facets[j as usize] as usize, temperature);
                }
                continue;
            }
            // Facets of one level share no edge, so none reads another's
            // shares: each task sets its facets' shares in place.
            let shares = core::mem::take(&mut self.shares);
            {
                let words = atomic_f64_words(&mut *shares);
                let this = &*self;
                parallel::ranges(hooks, list.len(), |items| {
                    for &j in &list[items] {
                        let f = facets[j as usize] as usize;
                        if let Some(new) = this.smoothed_shares_with(f, temperature, words) {
                            for (x, v) in this.facet_incidences(f).zip(new) {
                                words.set(x, v);
                            }
                        }
                    }
                });
            }
            self.shares = shares;
        }
        true
    }

    /// The levels of [`Solver::sweep_in_levels`] for `facets`, into `levels`'
    /// arrays: level `l`'s positions in `facets` are `order[start[l -
    /// 1]..start[l]]`. [`Plan::Serial`] when the facets are too few, not
    /// ascending, the arrays too short, or the levels too many for their
    /// facets.
    fn plan_levels(&self, facets: &[u32], levels: &mut Levels<'_>) -> Plan {
        let n = facets.len();
        let Levels {
            level,
            order,
            start,
            last,
            ..
        } = levels;
        if n < PARALLEL_LEVEL
            || level.len() < n
            || order.len() < n
            || !facets.windows(2).all(|w| w[0] < w[1])
        {
            return Plan::Serial;
        }
        for &f in facets {
            for &e in self.edges_of(f as usize) {
                last[e as usize] = 0;
            }
        }
        let mut top = 0u32;
        for (j, &f) in facets.iter().enumerate() {
            let f = f as usize;
            level[j] = 0;
            if self.facet_state[f] != UNDECIDED {
                continue;
            }
            let edges = self.edges_of(f);
            let l = 1 + edges.iter().map(|&e| last[e as usize]).max().unwrap_or(0);
            for &e in edges {
                last[e as usize] = l;
            }
            level[j] = l;
            top = top.max(l);
        }
        let top = top as usize;
        if top + 2 > start.len() || top.saturating_mul(MIN_MEAN_LEVEL) > n {
            return Plan::Serial;
        }
        // Positions by level, ascending within a level (a counting sort): level
        // l's are `order[start[l - 1]..start[l]]` after the scatter.
        start[..top + 2].fill(0);
        for &l in &level[..n] {
            start[l as usize + 1] += 1;
        }
        for l in 0..=top {
            start[l + 1] += start[l];
        }
        for (j, &l) in level[..n].iter().enumerate() {
            order[start[l as usize] as usize] = j as u32;
            start[l as usize] += 1;
        }
        Plan::Levels(top)
    }

    /// Coordinate descent on facet `f` on the dual smoothed at `temperature`:
    /// each edge's max becomes `temperature · log Σ exp(value / temperature)`
    /// over its allowed choices, which makes the dual smooth, so the descent
    /// cannot stall at a kink. Returns `f`'s new shares, `None` for a decided
    /// facet or an edge no choice satisfies. Reads only the shares of the other
    /// facets on `f`'s edges. Inlined into both callers: as a call, its
    /// soft max stayed a call too (callgrind: 1 % more instructions a run).
    #[inline(always)]
    fn smoothed_shares(&self, f: usize, temperature: f64) -> Option<[f64; MAX_CONSTRAINTS]> {
        self.smoothed_shares_with(f, temperature, &*self.shares)
    }

    /// [`Solver::smoothed_shares`] with the shares read from `shares`.
    ///
    /// Each constraint of `f` gives two soft maxima (`f` on, `f` off), each a
    /// chain of logarithms, an exponential and divisions (a few hundred
    /// cycles of latency, little work). The chains are independent, so they
    /// are taken a step at a time across all of them: every constraint's
    /// sums, then every soft maximum's terms, their exponentials, their
    /// logarithms, each computed as it would be alone (selection, one
    /// thread: 5.5 ms less a bunny run).
    #[inline(always)]
    fn smoothed_shares_with(
        &self,
        f: usize,
        temperature: f64,
        shares: impl Shares,
    ) -> Option<[f64; MAX_CONSTRAINTS]> {
        if self.facet_state[f] != UNDECIDED {
            return None;
        }
        let incidences = self.facet_incidences(f);
        let n = incidences.len().min(MAX_CONSTRAINTS);
        // Lane 2j: constraint j's soft maximum with f on; 2j + 1: with f off.
        let mut lanes = [SoftMax::NONE; 2 * MAX_CONSTRAINTS];
        for (j, own) in incidences.clone().take(n).enumerate() {
            let e = self.incidence_edge[own] as usize;
            let own = own as u32;
            let mut top_other = f64::NEG_INFINITY;
            for k in self.edge_span(e) {
                let x = self.edge_incidences[k];
                if x != own && self.facet_state[self.facet_of(x)] == UNDECIDED {
                    top_other = top_other.max(shares.share(x as usize));
                }
            }
            let shift = if top_other.is_finite() {
                top_other
            } else {
                0.0
            };
            // Elementary symmetric sums of exp((λ − shift) / temperature) over
            // the others, pairs from distinct classes only (a class's sum joins
            // at its end); `sum1_other_classes` leaves out the class of `own`.
            let (mut sum1, mut sum2, mut sum1_other_classes) = (0.0f64, 0.0f64, 0.0f64);
            let (mut class_sum, mut previous) = (0.0f64, u32::MAX);
            for k in self.edge_span(e) {
                let x = self.edge_incidences[k];
                if previous != u32::MAX && !self.same_class(previous, x) {
                    sum2 += class_sum * sum1;
                    sum1 += class_sum;
                    if !self.same_class(previous, own) {
                        sum1_other_classes += class_sum;
                    }
                    class_sum = 0.0;
                }
                previous = x;
                if x != own && self.facet_state[self.facet_of(x)] == UNDECIDED {
                    class_sum += exp((shares.share(x as usize) - shift) / temperature);
                }
            }
            if previous != u32::MAX {
                sum2 += class_sum * sum1;
                sum1 += class_sum;
                if !self.same_class(previous, own) {
                    sum1_other_classes += class_sum;
                }
            }
            let EdgeCounts {
                selected,
                undecided,
                mask,
                penalty,
            } = self.edge_counts(e);
            let lane = |base: u32, sums: [f64; 3]| SoftMax {
                base,
                spare: undecided - 1,
                sums,
                shift,
                mask,
                penalty,
            };
            lanes[2 * j] = lane(selected + 1, [1.0, sum1_other_classes, 0.0]);
            lanes[2 * j + 1] = lane(selected, [1.0, sum1, sum2]);
        }
        let lanes = &lanes[..2 * n];
        // temperature · log Σ_k sums[k] exp((k shift − penalty [d = 1]) /
        // temperature), over the degrees d = base + k allowed.
        let mut terms = [[f64::NEG_INFINITY; 3]; 2 * MAX_CONSTRAINTS];
        let mut highest = [f64::NEG_INFINITY; 2 * MAX_CONSTRAINTS];
        for ((lane, terms), highest) in lanes.iter().zip(&mut terms).zip(&mut highest) {
            let mut d = lane.base;
            while d <= lane.base.saturating_add(lane.spare).min(2) {
                let k = (d - lane.base) as usize;
                if (lane.mask >> d) & 1 == 1 && lane.sums[k] > 0.0 {
                    let cost = if d == 1 { lane.penalty } else { 0.0 };
                    let t = ln(lane.sums[k]) + (k as f64 * lane.shift - cost) / temperature;
                    terms[k] = t;
                    *highest = highest.max(t);
                }
                d += 1;
            }
        }
        let mut z = [0.0f64; 2 * MAX_CONSTRAINTS];
        for ((z, terms), &highest) in z.iter_mut().zip(&terms).zip(&highest).take(2 * n) {
            if highest.is_finite() {
                *z = terms
                    .iter()
                    .filter(|t| t.is_finite())
                    .map(|&t| exp(t - highest))
                    .sum();
            }
        }
        let soft_max = |l: usize| {
            if highest[l].is_finite() {
                temperature * (highest[l] + ln(z[l]))
            } else {
                f64::NEG_INFINITY
            }
        };
        let mut on_minus_off = [0.0f64; MAX_CONSTRAINTS];
        let mut finite = true;
        for (j, slot) in on_minus_off.iter_mut().enumerate().take(n) {
            let (on, off) = (soft_max(2 * j), soft_max(2 * j + 1));
            finite &= on.is_finite() && off.is_finite();
            *slot = on - off;
        }
        finite.then(|| equalising_shares(self.scores[f] as f64, &on_minus_off[..n]))
    }

    /// Coordinate descent at the component's root (problem open): smoothed sweeps
    /// with a falling temperature, then exact ones. Returns the lowest bound seen;
    /// improves `incumbent_value` by rounding, or exactly when the picks agree.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn root_bound(
        &mut self,
        facets: &[u32],
        edges: &[u32],
        incumbent_value: &mut f64,
        tolerance: f64,
        levels: &mut Levels<'_>,
        hooks: &dyn Progress,
    ) -> f64 {
        let mut lowest = f64::INFINITY;
        let mut temperature = ROOT_TEMPERATURE * self.score_scale;
        // The disagreements the last sweep's refresh counted in its tasks
        // (the bound and rounding change no pick or state).
        let mut counted = None;
        for sweep in 0..ROOT_SWEEPS {
            let current = self.bound(edges);
            lowest = lowest.min(current);
            if sweep % SWEEPS_PER_ROUNDING == SWEEPS_PER_ROUNDING - 1 {
                if let Some(v) = self.round(facets, edges, *incumbent_value) {
                    *incumbent_value = v;
                }
            }
            let disagreeing = counted.take().unwrap_or_else(|| self.disagreements(facets));
            if disagreeing == 0 {
                if current > *incumbent_value {
                    self.record_agreed_picks(facets);
                    *incumbent_value = current;
                }
                break;
            }
            if current <= *incumbent_value + tolerance {
                break;
            }
            if sweep % SWEEPS_PER_COOLING == SWEEPS_PER_COOLING - 1 {
                temperature *= 0.5;
            }
            if temperature < MIN_TEMPERATURE * self.score_scale {
                for &f in facets {
                    if self.facet_state[f as usize] == UNDECIDED {
                        self.rebalance(f as usize);
                    }
                }
                self.facet_queue.clear();
                self.refresh_stale_marginals();
            } else {
                self.smoothed_sweep(facets, temperature, levels, hooks);
                // The sweeps read only the shares, the bound and rounding
                // only the terms and picks; every later reader of the losses
                // opens the problem again (a fresh refresh).
                counted = self.refresh_all(facets, edges, Losses::Stale, hooks);
            }
        }
        lowest
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_shortcuts_give_what_libm_gives() {
        for x in [0.0, -0.0, -3.5, 1e-300, 0.7, 2.0] {
            assert_eq!(super::exp(x).to_bits(), libm::exp(x).to_bits(), "exp {x}");
        }
        for x in [1.0, 1e-300, 0.7, 2.0, 1.0 + f64::EPSILON] {
            assert_eq!(super::ln(x).to_bits(), libm::log(x).to_bits(), "ln {x}");
        }
    }
}
