//! Facet selection (DESIGN step 10): the exact 0/1 choice of candidate triangles,
//! by branch-and-bound in arena memory.
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
//! 1. *Propagation* to a fixpoint, at the root and at every node: an edge with `s`
//!    selected and `u` undecided facets can end at a degree in
//!    `D = {d ∈ A_e : s ≤ d ≤ s + u}`. `D = ∅` is a conflict; `D = {s}` turns its
//!    undecided facets off; `D = {s + u}` turns them on. For `{0, 2}` that is: a lone
//!    undecided facet goes off, a half-used edge with one candidate left takes it,
//!    a full edge drops the rest.
//! 2. *Components*: after root propagation the undecided facets split into groups
//!    that share no edge; each is solved on its own, smallest first.
//! 3. *Bound* (admissible, Lagrangian decomposition): every undecided facet splits
//!    its score into shares `λ_{f,e}` over its 3 to 6 edges (`Σ_e λ_{f,e} = w_f`).
//!    Alone, an edge can take any `k` of its undecided facets with `s + k ∈ A_e`,
//!    at most one per class (a group allows no more); its best is
//!    `max_k (top-k shares of distinct classes) − pen_e [s + k = 1]`, so a pair is
//!    the best share plus the best of another class. Summing that over the
//!    edges, plus the selected facets' scores, bounds every completion for *every*
//!    split, since each facet's score is counted once through its shares. The best
//!    split gives the LP relaxation with each edge's convex hull (which includes
//!    "a selected facet needs a partner on a closed edge"). The split is improved
//!    by coordinate descent (one facet at a time, re-split so that its edges
//!    value it equally: the exact minimiser for that facet), on a smoothed dual with
//!    a falling temperature at the root, then locally, only where something changed,
//!    at every node. Each edge caches the best shares of its three best classes
//!    (and the second best of the first two) and its term, so a node
//!    costs work in proportion to what changed, plus one pass over the component.
//!    When the edges of every facet agree, their picks are a feasible
//!    completion worth exactly the bound: an incumbent for free.
//! 4. *Reduced-cost fixing*: the cached top-3 give, per facet, the bound with the
//!    facet forced on or off; a value that cannot beat the incumbent is excluded.
//! 5. *Incumbent*: a greedy dive guided by the bound; rounding (facets at least
//!    half of whose edges pick them, repaired by removals only, so always feasible);
//!    dropping
//!    connected pieces worth less than nothing; then a large-neighbourhood search:
//!    around facets where the bound disagrees with the incumbent, re-solve a ball of
//!    32 to 256 facets exactly with the rest fixed.
//! 6. *Search*: depth-first, on an explicit stack (no recursion, any depth). Strong
//!    branching: the six most contested facets (both forced values lose the most
//!    by the cached estimates) have both children bounded (propagation plus a few
//!    local re-splits); a child that cannot beat the incumbent fixes the facet the
//!    other way, else the facet whose children lose the most (product rule) is
//!    branched on, better child first. A node limit spans the whole run
//!    (neighbourhood searches included); when it is hit, the answer is the best
//!    incumbent and the reported upper bound is the largest bound of the unexplored
//!    subtrees: an honest gap.
//!
//! "Optimal" means no selection is better by more than `1e-9 · (1 + Σ |w_f|)` of
//! its component (rounding room for the floating-point bound).
//!
//! ## Cost
//! Memory: [`select_bytes_for`], about `65 F + 40 I + 106 E` bytes for `I` used
//! constraint slots (3 F to 6 F; [`select_bytes`] assumes 6 F), all from the arena,
//! of which only the `F`-byte result is persistent. Time: O(F + E) for the checks,
//! incidence, propagation and components; O(incidences) per root sweep (30 per
//! component); per search node, a pass over the component's facets and edges plus
//! the re-splits around what changed, for the node and for its 12 probed children.
//! Measured (x86-64, one core, `sphere_benchmark` in arena-tests): candidates from
//! 60-150 points on a sphere with 6-8 neighbours (200-1200 facets, closed or with a
//! penalised open rim) are proved optimal in 3 ms to 3 s and at most 3000 nodes; a
//! node costs 0.5-1 ms in a component of about 1000 facets. With *every* edge a
//! possible (penalised) border, a few such instances are not proved within 200 000
//! nodes: the LP gap is larger there. With geometric fold groups added, the
//! class-aware edge terms make the bound tight: all 24 closed and all 24 open-rim
//! benchmark instances are proved in 20-500 nodes and 0.02-0.5 s. At about the
//! real size (800 points, 10 neighbours, one component of 9000 facets) 200 nodes
//! leave a gap near 90%: the incumbent heuristics find little there. The search
//! is exponential in the worst case; the node limit caps it.
//!
//! Those figures were taken with 150 root sweeps; the pipeline now runs 30, which
//! leaves the root bound slightly looser but found the same or better incumbents on
//! the pipeline's instances in a fifth of the time. With the pipeline's candidates
//! (seed rule plus quad diagonals, every edge a penalised border; about 3000 facets
//! in one component at 1000 clusters) the root and 200 nodes take 60-75 ms and
//! end 0.1-1 % from the bound; 250-500 clusters are usually proved optimal.

use crate::arena::Alloc;
use crate::error::{Error, Result};

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
    let g = |i: usize| {
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
    [edges[0], edges[1], edges[2], g(0), g(1), g(2)]
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

const UND: u8 = 0;
const ON: u8 = 1;
const OFF: u8 = 2;
const NEG: f64 = f64::NEG_INFINITY;
/// Coordinate-descent sweeps over a component at its root.
const ROOT_SWEEPS: u32 = 30;
/// Initial smoothing temperature at the root, relative to the mean |score|.
const ROOT_TAU0: f64 = 0.1;
/// Root sweeps between two halvings of the temperature.
const ROOT_TAU_EVERY: u32 = 10;
/// Smallest temperature (relative to the mean |score|); below it, hard sweeps.
const ROOT_TAU_MIN: f64 = 1e-4;
/// Root sweeps between two runs of the rounding heuristic.
const ROOT_ROUND_EVERY: u32 = 5;
/// Facet re-splits per search node at most.
const NODE_UPDATES: usize = 512;
/// Branching candidates whose children are bounded before choosing (strong branching).
const SB_CANDIDATES: usize = 6;
/// Facet re-splits when bounding a candidate child.
const SB_UPDATES: usize = 128;
/// Search nodes between two runs of the rounding heuristic.
const NODE_ROUND_EVERY: u64 = 16;
/// A re-split smaller than this (relative to the mean |score|) is not propagated.
const MOVE_EPS: f64 = 1e-7;
/// Facets in one neighbourhood of the large-neighbourhood search, at first; a pass
/// without gain doubles it, up to `LNS_MAX_SIZE`.
const LNS_SIZE: usize = 32;
const LNS_MAX_SIZE: usize = 256;
/// Search nodes per neighbourhood at most, per facet in it.
const LNS_NODES_PER_FACET: u64 = 50;
/// Passes of the neighbourhood search over a component at most.
const LNS_PASSES: u32 = 12;
const LNS_SEED: u8 = 1;
const LNS_IN: u8 = 2;
/// Nodes between two progress reports.
const REPORT_EVERY: u64 = 1024;

/// Bytes for `count` values of `T`, worst-case alignment padding included.
fn arr<T>(count: usize) -> usize {
    crate::arena::padded_bytes::<T>(count)
}

/// An upper bound on the arena bytes [`try_select_in`] uses for `facets` facets
/// and `edges` constraints (edges and fold groups), whatever their rows hold
/// (persistent result plus peak scratch): about `305 F + 106 E` bytes. See
/// [`select_bytes_for`] for a tighter figure.
pub fn select_bytes(facets: usize, edges: usize) -> usize {
    bytes(facets, edges, facets.saturating_mul(MAX_CONSTRAINTS))
}

/// The arena bytes [`try_select_in`] uses for `input` at most: about
/// `65 F + 40 I + 106 E` bytes for `I` used constraint slots (`185 F + 106 E` with
/// edges only). Cost O(F).
pub fn select_bytes_for(input: &SelectInput<'_>) -> usize {
    bytes(
        input.facet_edges.len(),
        input.edge_count,
        incidence_count(input.facet_edges),
    )
}

/// Used slots of the facet rows.
fn incidence_count(rows: &[[u32; MAX_CONSTRAINTS]]) -> usize {
    rows.iter()
        .map(|r| r.iter().filter(|&&e| e != UNUSED).count())
        .sum()
}

/// Arena bytes for `f` facets, `e` constraints and `ni` incidences.
fn bytes(f: usize, e: usize, ni: usize) -> usize {
    // Keep in step with the allocations in `try_select_in`.
    let list = [
        arr::<bool>(f),                  // result
        arr::<u32>(e.saturating_add(1)), // start
        arr::<u32>(ni),                  // inc
        arr::<u32>(f.saturating_add(1)), // fstart
        arr::<u32>(ni),                  // fcon
        arr::<u32>(ni),                  // owner
        arr::<u32>(ni),                  // cls
        arr::<u8>(f),                    // state
        arr::<u32>(e),                   // sel
        arr::<u32>(e),                   // und
        arr::<u32>(e),                   // edge queue
        arr::<bool>(e),                  // edge queue flags
        arr::<u32>(f),                   // facet queue
        arr::<bool>(f),                  // facet queue flags
        arr::<u32>(f),                   // trail
        arr::<f64>(ni),                  // share
        arr::<u8>(f),                    // picks
        arr::<f64>(ni),                  // con
        arr::<f64>(ni),                  // coff
        arr::<[u32; 3]>(e),              // top_id
        arr::<[f64; 5]>(e),              // top_v
        arr::<f64>(e),                   // term
        arr::<bool>(e),                  // in_e
        arr::<bool>(f),                  // in_f
        arr::<bool>(e),                  // dirty
        arr::<u32>(e),                   // dlist
        arr::<bool>(e),                  // mstale
        arr::<u32>(e),                   // mlist
        arr::<u32>(f),                   // work
        arr::<bool>(f),                  // seen
        arr::<bool>(f),                  // tmp
        arr::<u32>(e),                   // deg
        arr::<u8>(f),                    // flags
        arr::<u32>(f),                   // ball facets
        arr::<u32>(e),                   // ball edges
        arr::<u32>(f),                   // comp_f
        arr::<u32>(e),                   // comp_e
        arr::<[u32; 4]>(f),              // recs
        arr::<u32>(f),                   // stack facet
        arr::<u32>(f),                   // stack mark
        arr::<u8>(f),                    // stack info
        arr::<f64>(f),                   // stack bound
    ];
    list.iter().fold(0usize, |a, &b| a.saturating_add(b))
}

fn bad(name: &'static str, value: f32) -> Error {
    Error::BadParameter { name, value }
}

fn validate(input: &SelectInput<'_>) -> Result<()> {
    let nf = input.facet_edges.len();
    let ne = input.edge_count;
    if nf > (u32::MAX / MAX_CONSTRAINTS as u32) as usize {
        return Err(bad("facet_edges.len", nf as f32));
    }
    if ne > (u32::MAX - 1) as usize {
        return Err(bad("edge_count", ne as f32));
    }
    if input.scores.len() != nf {
        return Err(bad("scores.len", input.scores.len() as f32));
    }
    for (f, (edges, &w)) in input.facet_edges.iter().zip(input.scores).enumerate() {
        if edges.iter().filter(|&&e| e != UNUSED).count() < 3 {
            return Err(bad("facet_edges (fewer than 3 used slots)", f as f32));
        }
        for (i, &e) in edges.iter().enumerate() {
            if e == UNUSED {
                continue;
            }
            if e as usize >= ne {
                return Err(bad("facet_edges (edge id >= edge_count)", e as f32));
            }
            if edges[..i].contains(&e) {
                return Err(bad("facet_edges (repeated edge in facet)", f as f32));
            }
        }
        if !w.is_finite() {
            return Err(bad("scores", w));
        }
    }
    if let Some(m) = input.edge_mask {
        if m.len() != ne {
            return Err(bad("edge_mask.len", m.len() as f32));
        }
        if let Some(&bad_mask) = m.iter().find(|&&m| m & 1 == 0 || m > 0b111) {
            return Err(bad(
                "edge_mask (bit 0 required, bits 0..=2 only)",
                bad_mask as f32,
            ));
        }
    }
    if let Some(p) = input.edge_penalty {
        if p.len() != ne {
            return Err(bad("edge_penalty.len", p.len() as f32));
        }
        if let Some(&v) = p.iter().find(|&&v| !(v.is_finite() && v >= 0.0)) {
            return Err(bad("edge_penalty", v));
        }
    }
    Ok(())
}

/// Degrees in `mask` reachable from `s` selected and `u` undecided (bit set).
fn feasible(s: u32, u: u32, mask: u8) -> u8 {
    let mut bits = 0u8;
    for d in 0..3u32 {
        if (mask >> d) & 1 == 1 && d >= s && d <= s.saturating_add(u) {
            bits |= 1 << d;
        }
    }
    bits
}

/// Best value of one edge alone: `max over d ∈ A, s ≤ d ≤ s + u` of the sum of
/// the `d − s` best shares (`a1 ≥ a2`) minus `pen` when `d = 1`, with that `d − s`.
/// `−∞` when no degree is reachable. Ties go to the smaller degree.
fn edge_term(s: u32, u: u32, mask: u8, pen: f64, a1: f64, a2: f64) -> (f64, usize) {
    let mut best = NEG;
    let mut kb = 0;
    let top = s.saturating_add(u).min(2);
    let mut d = s;
    while d <= top {
        if (mask >> d) & 1 == 1 {
            let k = (d - s) as usize;
            let take = match k {
                0 => 0.0,
                1 => a1,
                _ => a1 + a2,
            };
            let val = take - if d == 1 { pen } else { 0.0 };
            if val > best {
                best = val;
                kb = k;
            }
        }
        d += 1;
    }
    (best, kb)
}

/// From an edge's cache (the best shares `v[0..3]` of its three best classes, at
/// incidences `id`, and the second best `v[3]`, `v[4]` of the first two classes):
/// once incidence `x` is left out, the best two shares of distinct classes, and
/// the best share of a class other than `x`'s (`same_as_top`: `x` is in the class
/// of `id[0]`).
fn others(id: &[u32; 3], v: &[f64; 5], x: u32, same_as_top: bool) -> (f64, f64, f64) {
    if x == id[0] {
        // v[3], v[1], v[2] come from three distinct classes.
        let (a, b, c) = (v[3], v[1], v[2]);
        let hi = a.max(b).max(c);
        let mid = if hi == a {
            b.max(c)
        } else if hi == b {
            a.max(c)
        } else {
            a.max(b)
        };
        (hi, mid, v[1])
    } else if x == id[1] {
        (v[0], v[4].max(v[2]), v[0])
    } else {
        (v[0], v[1], if same_as_top { v[1] } else { v[0] })
    }
}

/// The shares `t − c_i` with `k t = w + Σ c_i` over `k = c.len()` edges, the last
/// one taking the rounding so that they sum to `w` exactly as far as floating
/// point allows.
fn split(w: f64, c: &[f64]) -> [f64; MAX_CONSTRAINTS] {
    let k = c.len();
    let t = c.iter().fold(w, |a, &b| a + b) / k as f64;
    let mut out = [0.0; MAX_CONSTRAINTS];
    let mut rest = w;
    for i in 0..k - 1 {
        out[i] = t - c[i];
        rest -= out[i];
    }
    out[k - 1] = rest;
    out
}

/// A first-in first-out queue of distinct ids below its capacity.
struct Fifo<'a> {
    buf: &'a mut [u32],
    queued: &'a mut [bool],
    head: usize,
    len: usize,
}

impl Fifo<'_> {
    fn push(&mut self, i: usize) {
        if !self.queued[i] {
            self.queued[i] = true;
            let mut pos = self.head + self.len;
            if pos >= self.buf.len() {
                pos -= self.buf.len();
            }
            self.buf[pos] = i as u32;
            self.len += 1;
        }
    }

    fn pop(&mut self) -> Option<usize> {
        if self.len == 0 {
            return None;
        }
        let i = self.buf[self.head] as usize;
        self.head += 1;
        if self.head == self.buf.len() {
            self.head = 0;
        }
        self.len -= 1;
        self.queued[i] = false;
        Some(i)
    }

    fn clear(&mut self) {
        while self.pop().is_some() {}
    }
}

/// The explicit search stack (one level per branching decision).
struct Stack<'a> {
    facet: &'a mut [u32],
    mark: &'a mut [u32],
    /// bit 0: second branch taken; bit 1: the first branch was "on".
    info: &'a mut [u8],
    bound: &'a mut [f64],
    len: usize,
}

/// Where a search reports and draws its nodes from.
struct Budget<'r> {
    left: u64,
    used: u64,
    report: &'r mut dyn FnMut() -> bool,
}

/// All solver state, over scratch slices. "Edge" here means any constraint (an
/// edge or a fold group; only the mask tells them apart). Facet `f`'s incidences
/// are the numbers `x` in `fstart[f]..fstart[f + 1]`, one per used slot of its
/// row: `fcon[x]` is the edge, `owner[x] = f`, `x − fstart[f]` its bit in
/// `picks`; `share[x]` is its share of `w_f` on that edge, `con[x]` / `coff[x]`
/// what that edge's term loses if `f` is forced on / off.
///
/// The *problem* is the set of facets and edges being bounded (a component or a
/// neighbourhood): `in_f` / `in_e` mark it, and for its edges `term`, `top_*`,
/// `con`, `coff` and `picks` are kept in step with the state and the shares
/// (edges whose state changed wait in `dlist` until [`Solver::flush`]).
struct Solver<'a> {
    /// CSR: the incidences of facet f are `fstart[f]..fstart[f + 1]`.
    fstart: &'a [u32],
    /// The edge of each incidence.
    fcon: &'a [u32],
    /// The facet of each incidence.
    owner: &'a [u32],
    w: &'a [f32],
    masks: Option<&'a [u8]>,
    pens: Option<&'a [f32]>,
    /// CSR: the incidences of edge e are `inc[start[e]..start[e + 1]]`, grouped by
    /// class (see `cls`): classes by id, then the singletons; facets ascending within.
    start: &'a [u32],
    inc: &'a [u32],
    /// The *class* of each incidence on its edge: an at-most-one constraint
    /// (a fold group) of the facet that holds other facets of that edge, or
    /// [`UNUSED`] (a class of its own). A selection takes at most one facet per
    /// class, so an edge's term takes two shares from distinct classes only.
    cls: &'a [u32],
    state: &'a mut [u8],
    sel: &'a mut [u32],
    und: &'a mut [u32],
    /// Edges to propagate (also the repair queue of the rounding heuristic).
    eq: Fifo<'a>,
    /// Facets to re-split.
    fq: Fifo<'a>,
    trail: &'a mut [u32],
    trail_len: usize,
    share: &'a mut [f64],
    /// Bit i set: the facet's i-th edge (incidence `fstart[f] + i`) picks it.
    picks: &'a mut [u8],
    con: &'a mut [f64],
    coff: &'a mut [f64],
    top_id: &'a mut [[u32; 3]],
    /// Best shares of the three best classes, then the second best of the first two.
    top_v: &'a mut [[f64; 5]],
    term: &'a mut [f64],
    in_e: &'a mut [bool],
    in_f: &'a mut [bool],
    dirty: &'a mut [bool],
    dlist: &'a mut [u32],
    dlen: usize,
    /// Edges whose shares moved since their marginals were computed.
    mstale: &'a mut [bool],
    mlist: &'a mut [u32],
    mlen: usize,
    /// Sum of the scores of the problem's selected facets.
    fixed: f64,
    work: &'a mut [u32],
    seen: &'a mut [bool],
    /// A trial selection (rounding heuristic, piece dropping).
    tmp: &'a mut [bool],
    /// Degrees of the trial selection.
    deg: &'a mut [u32],
    /// Per-facet flags of the neighbourhood search (`LNS_*`).
    flags: &'a mut [u8],
    /// Whether search nodes run the rounding heuristic (off inside a neighbourhood,
    /// whose outside is fixed).
    rounding: bool,
    /// Mean |score| of the component, and the smallest re-split worth propagating.
    scale: f64,
    eps: f64,
    /// The incumbent (the run's result).
    best: &'a mut [bool],
}

impl<'a> Solver<'a> {
    fn mask(&self, e: usize) -> u8 {
        self.masks.map_or(MASK_CLOSED, |m| m[e])
    }

    fn pen(&self, e: usize) -> f64 {
        self.pens.map_or(0.0, |p| p[e] as f64)
    }

    fn incidences(&self, e: usize) -> core::ops::Range<usize> {
        self.start[e] as usize..self.start[e + 1] as usize
    }

    /// The incidences of facet `f`.
    fn slots(&self, f: usize) -> core::ops::Range<usize> {
        self.fstart[f] as usize..self.fstart[f + 1] as usize
    }

    /// The edges of facet `f` (borrowed from the input, not from `self`).
    fn edges_of(&self, f: usize) -> &'a [u32] {
        let fcon: &'a [u32] = self.fcon;
        &fcon[self.fstart[f] as usize..self.fstart[f + 1] as usize]
    }

    /// The facet of incidence `x`.
    fn of(&self, x: u32) -> usize {
        self.owner[x as usize] as usize
    }

    /// `picks` of a facet all of whose edges pick it.
    fn all_pick(&self, f: usize) -> u8 {
        ((1u32 << (self.fstart[f + 1] - self.fstart[f])) - 1) as u8
    }

    /// Whether the edges of undecided facet `f` agree on it (all pick it or none).
    fn agreed(&self, f: usize) -> bool {
        self.picks[f] == 0 || self.picks[f] == self.all_pick(f)
    }

    fn d_on(&self, f: usize) -> f64 {
        self.slots(f).map(|x| self.con[x]).sum()
    }

    fn d_off(&self, f: usize) -> f64 {
        self.slots(f).map(|x| self.coff[x]).sum()
    }

    /// Queue the problem edges of `f` for a cache refresh.
    fn touch(&mut self, f: usize) {
        for &e in self.edges_of(f) {
            let e = e as usize;
            if self.in_e[e] && !self.dirty[e] {
                self.dirty[e] = true;
                self.dlist[self.dlen] = e as u32;
                self.dlen += 1;
            }
        }
    }

    /// Decide `f` (undecided) and queue its edges for propagation.
    fn assign(&mut self, f: usize, on: bool) {
        self.state[f] = if on { ON } else { OFF };
        self.trail[self.trail_len] = f as u32;
        self.trail_len += 1;
        if on && self.in_f[f] {
            self.fixed += self.w[f] as f64;
        }
        for &e in self.edges_of(f) {
            let e = e as usize;
            self.und[e] -= 1;
            if on {
                self.sel[e] += 1;
            }
            self.eq.push(e);
        }
        self.touch(f);
    }

    /// Undo every decision after trail position `mark`.
    fn undo_to(&mut self, mark: usize) {
        self.eq.clear();
        while self.trail_len > mark {
            self.trail_len -= 1;
            let f = self.trail[self.trail_len] as usize;
            let on = self.state[f] == ON;
            self.state[f] = UND;
            if on && self.in_f[f] {
                self.fixed -= self.w[f] as f64;
            }
            for &e in self.edges_of(f) {
                let e = e as usize;
                self.und[e] += 1;
                if on {
                    self.sel[e] -= 1;
                }
            }
            self.touch(f);
        }
    }

    /// Propagate the queued edges to a fixpoint. `false`: some edge cannot reach
    /// an allowed degree (the queue is then empty again).
    fn propagate(&mut self) -> bool {
        while let Some(e) = self.eq.pop() {
            let (s, u) = (self.sel[e], self.und[e]);
            let d = feasible(s, u, self.mask(e));
            if d == 0 {
                self.eq.clear();
                return false;
            }
            if u == 0 {
                continue;
            }
            // d != 0 implies s <= 2.
            let on = if d == 1 << s {
                false
            } else if s + u <= 2 && d == 1 << (s + u) {
                true
            } else {
                continue;
            };
            for k in self.incidences(e) {
                let f = self.of(self.inc[k]);
                if self.state[f] == UND {
                    self.assign(f, on);
                }
            }
        }
        true
    }

    /// Whether incidences `a` and `b` of one edge are in the same class.
    fn same(&self, a: u32, b: u32) -> bool {
        a == b || (self.cls[a as usize] == self.cls[b as usize] && self.cls[a as usize] != UNUSED)
    }

    /// Recompute edge `e`'s best shares per class and term from the state and
    /// shares. One pass: the incidences of a class are consecutive.
    fn refresh_top(&mut self, e: usize) {
        let (s, u, m, p) = (self.sel[e], self.und[e], self.mask(e), self.pen(e));
        // Class bests and their classes' second bests.
        let mut v = [NEG; 3];
        let mut v2 = [NEG; 3];
        let mut id = [u32::MAX; 3];
        let r = self.incidences(e);
        let mut k = r.start;
        while k < r.end {
            // One class: incidences k..j.
            let first = self.inc[k];
            let mut j = k;
            let (mut b1, mut b2, mut bx) = (NEG, NEG, u32::MAX);
            while j < r.end && self.same(first, self.inc[j]) {
                let x = self.inc[j];
                j += 1;
                if self.state[self.of(x)] != UND {
                    continue;
                }
                let sv = self.share[x as usize];
                if sv > b1 {
                    (b1, b2, bx) = (sv, b1, x);
                } else if sv > b2 {
                    b2 = sv;
                }
            }
            k = j;
            if bx == u32::MAX {
                continue;
            }
            if b1 > v[0] {
                (v, v2, id) = ([b1, v[0], v[1]], [b2, v2[0], v2[1]], [bx, id[0], id[1]]);
            } else if b1 > v[1] {
                (v, v2, id) = ([v[0], b1, v[1]], [v2[0], b2, v2[1]], [id[0], bx, id[1]]);
            } else if b1 > v[2] {
                (v[2], v2[2], id[2]) = (b1, b2, bx);
            }
        }
        self.term[e] = edge_term(s, u, m, p, v[0], v[1]).0;
        self.top_id[e] = id;
        self.top_v[e] = [v[0], v[1], v[2], v2[0], v2[1]];
    }

    /// [`others`] for incidence `x` of edge `e`.
    fn others_of(&self, e: usize, x: u32) -> (f64, f64, f64) {
        let id = &self.top_id[e];
        let top = id[0] != u32::MAX && self.same(x, id[0]);
        others(id, &self.top_v[e], x, top)
    }

    /// From edge `e`'s fresh best shares: for each undecided facet on it, whether
    /// the edge picks it and what the edge's term loses if it is forced on / off.
    fn refresh_marginals(&mut self, e: usize) {
        let (s, u, m, p) = (self.sel[e], self.und[e], self.mask(e), self.pen(e));
        let (id, v) = (self.top_id[e], self.top_v[e]);
        let (term, take) = edge_term(s, u, m, p, v[0], v[1]);
        for k in self.incidences(e) {
            let x = self.inc[k];
            let xi = x as usize;
            let f = self.of(x);
            let bit = 1u8 << (x - self.fstart[f]);
            if self.state[f] == UND {
                let (o1, o2, b) = self.others_of(e, x);
                let off = edge_term(s, u - 1, m, p, o1, o2).0;
                let on = self.share[xi] + edge_term(s + 1, u - 1, m, p, b, NEG).0;
                // An edge that no completion satisfies (two classes short) makes
                // the bound −∞; its marginals are moot.
                let finite = term.is_finite();
                self.con[xi] = if finite { term - on } else { 0.0 };
                self.coff[xi] = if finite { term - off } else { 0.0 };
                if id[..take].contains(&x) {
                    self.picks[f] |= bit;
                } else {
                    self.picks[f] &= !bit;
                }
            } else {
                self.con[xi] = 0.0;
                self.coff[xi] = 0.0;
                self.picks[f] &= !bit;
            }
        }
    }

    /// Recompute edge `e`'s whole cache.
    fn refresh(&mut self, e: usize) {
        self.refresh_top(e);
        self.refresh_marginals(e);
    }

    /// Bring the marginals of edges whose shares moved up to date.
    fn finish(&mut self) {
        for i in 0..self.mlen {
            let e = self.mlist[i] as usize;
            self.mstale[e] = false;
            self.refresh_marginals(e);
        }
        self.mlen = 0;
    }

    /// Refresh the edges whose state changed and queue their facets for re-splitting.
    fn flush(&mut self) {
        for i in 0..self.dlen {
            let e = self.dlist[i] as usize;
            self.dirty[e] = false;
            self.refresh(e);
            for k in self.incidences(e) {
                let f = self.of(self.inc[k]);
                if self.state[f] == UND {
                    self.fq.push(f);
                }
            }
        }
        self.dlen = 0;
    }

    fn drop_pending(&mut self) {
        self.finish();
        for i in 0..self.dlen {
            self.dirty[self.dlist[i] as usize] = false;
        }
        self.dlen = 0;
        self.fq.clear();
    }

    /// Refresh every edge of the current problem.
    fn refresh_all(&mut self, edges: &[u32]) {
        self.drop_pending();
        for &e in edges {
            self.refresh(e as usize);
        }
    }

    /// Make (`facets`, `edges`) the current problem, with fresh caches.
    fn open(&mut self, facets: &[u32], edges: &[u32]) {
        for &e in edges {
            self.in_e[e as usize] = true;
        }
        self.fixed = 0.0;
        for &f in facets {
            let f = f as usize;
            self.in_f[f] = true;
            if self.state[f] == ON {
                self.fixed += self.w[f] as f64;
            }
        }
        self.refresh_all(edges);
    }

    fn close(&mut self, facets: &[u32], edges: &[u32]) {
        self.drop_pending();
        for &e in edges {
            self.in_e[e as usize] = false;
        }
        for &f in facets {
            self.in_f[f as usize] = false;
        }
    }

    /// The Lagrangian bound of the current problem (caches must be fresh).
    fn bound(&self, edges: &[u32]) -> f64 {
        edges
            .iter()
            .fold(self.fixed, |a, &e| a + self.term[e as usize])
    }

    /// Undecided facets whose edges do not all agree on them.
    fn disagreements(&self, facets: &[u32]) -> u32 {
        facets
            .iter()
            .filter(|&&f| self.state[f as usize] == UND && !self.agreed(f as usize))
            .count() as u32
    }

    /// Coordinate descent on one facet, from the caches: re-split its score so that
    /// its `k` edges value it equally, which exactly minimises the bound over its
    /// shares (the others fixed): edge i's term is `max(off_i, λ_i + on_i)`, whose
    /// sum under `Σ λ_i = w` is at least `Σ off_i + max(0, w + Σ (on_i − off_i))`,
    /// reached when every `λ_i + on_i − off_i` is equal. A real change refreshes
    /// its edges and queues the other facets on them.
    fn rebalance(&mut self, f: usize) {
        let mut c = [0.0f64; MAX_CONSTRAINTS];
        let r = self.slots(f);
        for (ci, x) in c.iter_mut().zip(r) {
            let e = self.fcon[x] as usize;
            let (s, u, m, p) = (self.sel[e], self.und[e], self.mask(e), self.pen(e));
            let (o1, o2, b) = self.others_of(e, x as u32);
            let on = edge_term(s + 1, u - 1, m, p, b, NEG).0;
            let off = edge_term(s, u - 1, m, p, o1, o2).0;
            if !(on.is_finite() && off.is_finite()) {
                return;
            }
            *ci = on - off;
        }
        self.resplit(f, c);
    }

    /// Set facet `f`'s shares to `t − c_i` with `k t = w_f + Σ c_i` (`k` its edge
    /// count), and when that moves them, refresh its edges and queue the other
    /// facets on them.
    fn resplit(&mut self, f: usize, c: [f64; MAX_CONSTRAINTS]) {
        let r = self.slots(f);
        let new = split(self.w[f] as f64, &c[..r.len()]);
        let new = &new[..r.len()];
        if new
            .iter()
            .zip(&self.share[r.clone()])
            .all(|(a, b)| (a - b).abs() <= self.eps)
        {
            return;
        }
        self.share[r].copy_from_slice(new);
        for &e in self.edges_of(f) {
            let e = e as usize;
            self.refresh_top(e);
            if !self.mstale[e] {
                self.mstale[e] = true;
                self.mlist[self.mlen] = e as u32;
                self.mlen += 1;
            }
            for k in self.incidences(e) {
                let g = self.of(self.inc[k]);
                if g != f && self.state[g] == UND {
                    self.fq.push(g);
                }
            }
        }
    }

    /// Re-split queued facets, at most `cap` of them, then refresh the marginals.
    fn settle(&mut self, cap: usize) {
        let mut n = 0;
        while let Some(f) = self.fq.pop() {
            if self.state[f] == UND && self.in_f[f] {
                self.rebalance(f);
                n += 1;
                if n >= cap {
                    self.fq.clear();
                    break;
                }
            }
        }
        self.finish();
    }

    /// One coordinate-descent sweep over all facets on the dual smoothed at
    /// temperature `tau`: each edge's max becomes `tau · log Σ exp(value / tau)` over
    /// its allowed choices, which makes the dual smooth, so the descent cannot stall
    /// at a kink. Leaves the caches stale (refresh after).
    fn soft_sweep(&mut self, facets: &[u32], tau: f64) {
        for &f in facets {
            let f = f as usize;
            if self.state[f] != UND {
                continue;
            }
            let mut c = [0.0f64; MAX_CONSTRAINTS];
            let mut finite = true;
            let r = self.slots(f);
            for (ci, me) in c.iter_mut().zip(r.clone()) {
                let e = self.fcon[me] as usize;
                let me = me as u32;
                let mut top = NEG;
                for k in self.incidences(e) {
                    let x = self.inc[k];
                    if x != me && self.state[self.of(x)] == UND {
                        top = top.max(self.share[x as usize]);
                    }
                }
                let shift = if top.is_finite() { top } else { 0.0 };
                // Elementary symmetric sums of exp((λ − shift) / tau) over the
                // others, pairs from distinct classes only (a class's sum joins
                // at its end); `e1_on` leaves out the class of `me`.
                let (mut e1, mut e2, mut e1_on) = (0.0f64, 0.0f64, 0.0f64);
                let (mut run, mut prev) = (0.0f64, u32::MAX);
                for k in self.incidences(e) {
                    let x = self.inc[k];
                    if prev != u32::MAX && !self.same(prev, x) {
                        e2 += run * e1;
                        e1 += run;
                        if !self.same(prev, me) {
                            e1_on += run;
                        }
                        run = 0.0;
                    }
                    prev = x;
                    if x != me && self.state[self.of(x)] == UND {
                        run += libm::exp((self.share[x as usize] - shift) / tau);
                    }
                }
                if prev != u32::MAX {
                    e2 += run * e1;
                    e1 += run;
                    if !self.same(prev, me) {
                        e1_on += run;
                    }
                }
                let (s, u, m, p) = (self.sel[e], self.und[e], self.mask(e), self.pen(e));
                // tau · log Σ_k e_k exp((k shift − pen [d = 1]) / tau), d = base + k.
                let soft = |base: u32, spare: u32, esum: [f64; 3]| -> f64 {
                    let mut terms = [NEG; 3];
                    let mut hi = NEG;
                    let mut d = base;
                    while d <= base.saturating_add(spare).min(2) {
                        let k = (d - base) as usize;
                        if (m >> d) & 1 == 1 && esum[k] > 0.0 {
                            let pen = if d == 1 { p } else { 0.0 };
                            let t = libm::log(esum[k]) + (k as f64 * shift - pen) / tau;
                            terms[k] = t;
                            hi = hi.max(t);
                        }
                        d += 1;
                    }
                    if !hi.is_finite() {
                        return NEG;
                    }
                    let z: f64 = terms
                        .iter()
                        .filter(|t| t.is_finite())
                        .map(|&t| libm::exp(t - hi))
                        .sum();
                    tau * (hi + libm::log(z))
                };
                let on = soft(s + 1, u - 1, [1.0, e1_on, 0.0]);
                let off = soft(s, u - 1, [1.0, e1, e2]);
                finite &= on.is_finite() && off.is_finite();
                *ci = on - off;
            }
            if finite {
                let new = split(self.w[f] as f64, &c[..r.len()]);
                self.share[r.clone()].copy_from_slice(&new[..r.len()]);
            }
        }
    }

    /// Store the current state completed by the (agreeing) picks as the incumbent.
    fn record(&mut self, facets: &[u32]) {
        for &f in facets {
            let f = f as usize;
            self.best[f] = match self.state[f] {
                ON => true,
                UND => self.picks[f] != 0 && self.picks[f] == self.all_pick(f),
                _ => false,
            };
        }
    }

    /// Greedy dive from the current state (opens the problem itself): take every
    /// facet all of whose edges pick it, else the facet whose forced selection
    /// lowers the bound least, falling back to "off" on conflict, until the picks
    /// agree. Records and returns an improvement of `inc`.
    fn dive(&mut self, facets: &[u32], edges: &[u32], inc: f64) -> Option<f64> {
        self.open(facets, edges);
        let mark = self.trail_len;
        let mut found = None;
        loop {
            if self.disagreements(facets) == 0 {
                let value = self.bound(edges);
                if value > inc {
                    self.record(facets);
                    found = Some(value);
                }
                break;
            }
            let step = self.trail_len;
            let mut batch = false;
            for &f in facets {
                let f = f as usize;
                if self.state[f] == UND && self.picks[f] != 0 && self.agreed(f) {
                    self.assign(f, true);
                    batch = true;
                }
            }
            if batch {
                if self.propagate() {
                    self.flush();
                    continue;
                }
                self.undo_to(step);
                self.flush();
            }
            let mut pick = None;
            let mut least = f64::INFINITY;
            for &f in facets {
                let f = f as usize;
                if self.state[f] == UND && self.d_on(f) < least {
                    least = self.d_on(f);
                    pick = Some(f);
                }
            }
            let Some(f) = pick else { break };
            self.assign(f, true);
            if self.propagate() {
                self.flush();
                continue;
            }
            self.undo_to(step);
            self.assign(f, false);
            if self.propagate() {
                self.flush();
                continue;
            }
            break;
        }
        self.undo_to(mark);
        self.close(facets, edges);
        found
    }

    /// Local search on the trial selection `tmp`: drop every connected piece of it
    /// (facets linked through shared edges) whose score minus border penalties is
    /// negative. Dropping a whole piece takes its edges to degree 0, which is always
    /// allowed. Returns the objective gained.
    fn drop_pieces(&mut self, facets: &[u32]) -> f64 {
        for &f in facets {
            self.seen[f as usize] = false;
        }
        let mut gain = 0.0;
        for &root in facets {
            let root = root as usize;
            if !self.tmp[root] || self.seen[root] {
                continue;
            }
            self.seen[root] = true;
            self.work[0] = root as u32;
            let (mut head, mut tail) = (0usize, 1usize);
            let mut value = 0.0f64;
            while head < tail {
                let f = self.work[head] as usize;
                head += 1;
                value += self.w[f] as f64;
                for &e in self.edges_of(f) {
                    let e = e as usize;
                    let mut deg = 0;
                    for k in self.incidences(e) {
                        let g = self.of(self.inc[k]);
                        if self.tmp[g] {
                            deg += 1;
                            if !self.seen[g] {
                                self.seen[g] = true;
                                self.work[tail] = g as u32;
                                tail += 1;
                            }
                        }
                    }
                    if deg == 1 {
                        value -= self.pen(e);
                    }
                }
            }
            if value < 0.0 {
                gain -= value;
                for i in 0..tail {
                    self.tmp[self.work[i] as usize] = false;
                }
            }
        }
        gain
    }

    /// [`Self::drop_pieces`] applied to the incumbent.
    fn improve_best(&mut self, facets: &[u32]) -> f64 {
        for &f in facets {
            self.tmp[f as usize] = self.best[f as usize];
        }
        let gain = self.drop_pieces(facets);
        for &f in facets {
            self.best[f as usize] = self.tmp[f as usize];
        }
        gain
    }

    /// Rounding heuristic (caches fresh): take the selected facets and the
    /// undecided ones at least two of whose edges pick them, then repair by removal
    /// only (so the result is always feasible, 0 being allowed everywhere): an edge
    /// at a degree its mask forbids drops its lowest-scored facets down to the
    /// largest allowed degree below; then negative pieces go. Records the result
    /// when it beats `inc`. Cost O(incidences of the problem).
    fn round(&mut self, facets: &[u32], edges: &[u32], inc: f64) -> Option<f64> {
        for &f in facets {
            let f = f as usize;
            self.tmp[f] = match self.state[f] {
                ON => true,
                UND => 2 * self.picks[f].count_ones() >= self.slots(f).len() as u32,
                _ => false,
            };
        }
        for &e in edges {
            let e = e as usize;
            let mut d = 0;
            for k in self.incidences(e) {
                d += self.tmp[self.of(self.inc[k])] as u32;
            }
            self.deg[e] = d;
            self.eq.push(e);
        }
        while let Some(e) = self.eq.pop() {
            let m = self.mask(e);
            let d = self.deg[e];
            if d <= 2 && (m >> d) & 1 == 1 {
                continue;
            }
            // Largest allowed degree below d (0 always is).
            let mut target = d.min(2);
            while (m >> target) & 1 == 0 {
                target -= 1;
            }
            for _ in target..d {
                let mut worst = None;
                let mut low = f32::INFINITY;
                for k in self.incidences(e) {
                    let f = self.of(self.inc[k]);
                    if self.tmp[f] && self.w[f] <= low {
                        low = self.w[f];
                        worst = Some(f);
                    }
                }
                let Some(f) = worst else { break };
                self.tmp[f] = false;
                for &g in self.edges_of(f) {
                    self.deg[g as usize] -= 1;
                    self.eq.push(g as usize);
                }
            }
        }
        let mut value = 0.0f64;
        for &f in facets {
            if self.tmp[f as usize] {
                value += self.w[f as usize] as f64;
            }
        }
        for &e in edges {
            if self.deg[e as usize] == 1 {
                value -= self.pen(e as usize);
            }
        }
        value += self.drop_pieces(facets);
        if value > inc {
            for &f in facets {
                self.best[f as usize] = self.tmp[f as usize];
            }
            Some(value)
        } else {
            None
        }
    }

    /// Coordinate descent at the component's root (problem open): smoothed sweeps
    /// with a falling temperature, then exact ones. Returns the best bound seen;
    /// improves `inc` by rounding, or exactly when the picks agree.
    fn root_bound(&mut self, facets: &[u32], edges: &[u32], inc: &mut f64, tol: f64) -> f64 {
        let mut bound = f64::INFINITY;
        let mut tau = ROOT_TAU0 * self.scale;
        for it in 0..ROOT_SWEEPS {
            let b = self.bound(edges);
            bound = bound.min(b);
            if it % ROOT_ROUND_EVERY == ROOT_ROUND_EVERY - 1 {
                if let Some(v) = self.round(facets, edges, *inc) {
                    *inc = v;
                }
            }
            if self.disagreements(facets) == 0 {
                if b > *inc {
                    self.record(facets);
                    *inc = b;
                }
                break;
            }
            if b <= *inc + tol {
                break;
            }
            if it % ROOT_TAU_EVERY == ROOT_TAU_EVERY - 1 {
                tau *= 0.5;
            }
            if tau < ROOT_TAU_MIN * self.scale {
                for &f in facets {
                    if self.state[f as usize] == UND {
                        self.rebalance(f as usize);
                    }
                }
                self.fq.clear();
                self.finish();
            } else {
                self.soft_sweep(facets, tau);
                self.refresh_all(edges);
            }
        }
        bound
    }

    /// Process one search node (problem open): propagate, refresh, re-split locally,
    /// fix by reduced costs, and either prune (`None`) or return the branching
    /// facet, its better side and the node's bound.
    fn node(
        &mut self,
        facets: &[u32],
        edges: &[u32],
        inc: &mut f64,
        tol: f64,
        count: u64,
    ) -> Option<(usize, bool, f64)> {
        if !self.propagate() {
            return None;
        }
        self.flush();
        self.settle(NODE_UPDATES);
        loop {
            let bound = self.bound(edges);
            let thr = *inc + tol;
            if bound <= thr {
                return None;
            }
            let mut fixed_any = false;
            let mut disagree = 0;
            // The most contested facets (both forced values lose the most), best first.
            let mut cands = [(-1.0f64, usize::MAX); SB_CANDIDATES];
            for &f in facets {
                let f = f as usize;
                if self.state[f] != UND {
                    continue;
                }
                let (a, b) = (self.d_on(f), self.d_off(f));
                match (bound - a > thr, bound - b > thr) {
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
                if !self.agreed(f) {
                    disagree += 1;
                }
                let score = a.min(b);
                if score > cands[SB_CANDIDATES - 1].0 {
                    let mut i = SB_CANDIDATES - 1;
                    while i > 0 && score > cands[i - 1].0 {
                        cands[i] = cands[i - 1];
                        i -= 1;
                    }
                    cands[i] = (score, f);
                }
            }
            if fixed_any {
                if !self.propagate() {
                    return None;
                }
                self.flush();
                self.settle(NODE_UPDATES);
                continue;
            }
            if disagree == 0 {
                self.record(facets);
                *inc = bound;
                return None;
            }
            if self.rounding && count % NODE_ROUND_EVERY == 0 {
                if let Some(v) = self.round(facets, edges, *inc) {
                    *inc = v;
                    if bound <= v + tol {
                        return None;
                    }
                }
            }
            // Strong branching: bound both children of each candidate; a child that
            // cannot beat the incumbent fixes the other value, else take the facet
            // whose children lose the most (product rule).
            let mut pick = None;
            let mut most = -1.0;
            let mut fix = None;
            for &(_, f) in cands.iter().filter(|c| c.1 != usize::MAX) {
                let on = self.probe(edges, f, true);
                let off = self.probe(edges, f, false);
                match (on > thr, off > thr) {
                    (false, false) => return None,
                    (true, false) => fix = Some((f, true)),
                    (false, true) => fix = Some((f, false)),
                    (true, true) => {}
                }
                if fix.is_some() {
                    break;
                }
                let floor = 1e-6 * self.scale;
                let score = (bound - on).max(floor) * (bound - off).max(floor);
                if score > most {
                    most = score;
                    pick = Some((f, on >= off));
                }
            }
            self.flush();
            if let Some((f, on)) = fix {
                self.assign(f, on);
                if !self.propagate() {
                    return None;
                }
                self.flush();
                self.settle(NODE_UPDATES);
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
        let b = if self.propagate() {
            self.flush();
            self.settle(SB_UPDATES);
            self.bound(edges)
        } else {
            NEG
        };
        self.undo_to(mark);
        b
    }

    /// Depth-first branch-and-bound over one problem (opens and closes it).
    /// Returns whether it finished and an upper bound on the problem's optimum.
    #[allow(clippy::too_many_arguments)]
    fn search(
        &mut self,
        facets: &[u32],
        edges: &[u32],
        stack: &mut Stack<'_>,
        inc: &mut f64,
        tol: f64,
        root_bound: f64,
        budget: &mut Budget<'_>,
    ) -> Result<(bool, f64)> {
        let base = self.trail_len;
        stack.len = 0;
        self.open(facets, edges);
        let out = 'run: loop {
            if budget.left == 0 {
                // Unexplored: the current node (under the top level) and the second
                // branch of every level still on its first.
                let mut ub = *inc;
                if stack.len == 0 {
                    ub = ub.max(root_bound);
                }
                for i in 0..stack.len {
                    if stack.info[i] & 1 == 0 || i + 1 == stack.len {
                        ub = ub.max(stack.bound[i]);
                    }
                }
                break Ok((false, ub));
            }
            budget.left -= 1;
            budget.used += 1;
            if budget.used % REPORT_EVERY == 0 && !(budget.report)() {
                break Err(Error::Cancelled);
            }
            if let Some((f, on, bound)) = self.node(facets, edges, inc, tol, budget.used) {
                let i = stack.len;
                stack.facet[i] = f as u32;
                stack.mark[i] = self.trail_len as u32;
                stack.info[i] = if on { 2 } else { 0 };
                stack.bound[i] = bound;
                stack.len += 1;
                self.assign(f, on);
                continue;
            }
            // Backtrack to the deepest level with an untried branch.
            loop {
                if stack.len == 0 {
                    break 'run Ok((true, *inc));
                }
                let i = stack.len - 1;
                self.undo_to(stack.mark[i] as usize);
                if stack.info[i] & 1 == 0 {
                    stack.info[i] |= 1;
                    let first_on = stack.info[i] & 2 != 0;
                    self.assign(stack.facet[i] as usize, !first_on);
                    break;
                }
                stack.len -= 1;
            }
        };
        self.undo_to(base);
        self.close(facets, edges);
        out
    }

    /// Large-neighbourhood search on the incumbent: around each facet whose edges'
    /// picks disagree with the incumbent, take a ball of facets (breadth-first over
    /// shared edges), fix the facets bordering it to their incumbent values and solve
    /// the ball exactly (node-limited). A pass without gain doubles the ball size.
    /// Any result is feasible: the ball's edges see the fixed border, and the rest
    /// is unchanged.
    #[allow(clippy::too_many_arguments)]
    fn lns(
        &mut self,
        facets: &[u32],
        edges: &[u32],
        stack: &mut Stack<'_>,
        ball: (&mut [u32], &mut [u32]),
        inc: &mut f64,
        tol: f64,
        budget: &mut Budget<'_>,
    ) -> Result<()> {
        let mut size = LNS_SIZE;
        for _ in 0..LNS_PASSES {
            // Seeds: facets the bound's picks would set otherwise than the incumbent.
            self.open(facets, edges);
            for &f in facets {
                let f = f as usize;
                let agree = self.picks[f] == if self.best[f] { self.all_pick(f) } else { 0 };
                self.flags[f] = if agree { 0 } else { LNS_SEED };
            }
            self.close(facets, edges);
            let before = *inc;
            for &seed in facets {
                if budget.left == 0 {
                    return Ok(());
                }
                if self.flags[seed as usize] & LNS_SEED == 0 {
                    continue;
                }
                // The ball; `dirty` (idle: no problem is open) marks its edges.
                ball.0[0] = seed;
                self.flags[seed as usize] |= LNS_IN;
                let (mut head, mut nf, mut ne) = (0usize, 1usize, 0usize);
                while head < nf {
                    let f = ball.0[head] as usize;
                    head += 1;
                    for &e in self.edges_of(f) {
                        let e = e as usize;
                        if self.dirty[e] {
                            continue;
                        }
                        self.dirty[e] = true;
                        ball.1[ne] = e as u32;
                        ne += 1;
                        for k in self.incidences(e) {
                            let g = self.of(self.inc[k]);
                            if nf < size && self.state[g] == UND && self.flags[g] & LNS_IN == 0 {
                                self.flags[g] |= LNS_IN;
                                ball.0[nf] = g as u32;
                                nf += 1;
                            }
                        }
                    }
                }
                for i in 0..ne {
                    self.dirty[ball.1[i] as usize] = false;
                }
                ball.0[..nf].sort_unstable();
                ball.1[..ne].sort_unstable();
                // Fix the border to the incumbent; value the incumbent on the ball.
                let mark = self.trail_len;
                let mut old = 0.0f64;
                for i in 0..nf {
                    let f = ball.0[i] as usize;
                    self.flags[f] &= !LNS_SEED;
                    if self.best[f] {
                        old += self.w[f] as f64;
                    }
                }
                for i in 0..ne {
                    let e = ball.1[i] as usize;
                    let mut d = 0;
                    for k in self.incidences(e) {
                        let g = self.of(self.inc[k]);
                        d += self.best[g] as u32;
                        if self.state[g] == UND && self.flags[g] & LNS_IN == 0 {
                            self.assign(g, self.best[g]);
                        }
                    }
                    if d == 1 {
                        old -= self.pen(e);
                    }
                }
                self.eq.clear();
                for i in 0..ne {
                    self.eq.push(ball.1[i] as usize);
                }
                let mut value = old;
                let cap = budget.left.min(LNS_NODES_PER_FACET * size as u64);
                let left = budget.left - cap;
                budget.left = cap;
                self.rounding = false;
                let r = self.search(
                    &ball.0[..nf],
                    &ball.1[..ne],
                    stack,
                    &mut value,
                    tol,
                    f64::INFINITY,
                    budget,
                );
                self.rounding = true;
                budget.left += left;
                self.undo_to(mark);
                for i in 0..nf {
                    self.flags[ball.0[i] as usize] &= !LNS_IN;
                }
                r?;
                if value > old + tol {
                    *inc += value - old;
                }
            }
            if *inc <= before + tol {
                if size >= LNS_MAX_SIZE || size >= facets.len() {
                    break;
                }
                size *= 2;
            }
        }
        Ok(())
    }
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
    validate(input)?;
    let best = arena.try_alloc_slice(input.facet_edges.len(), false)?;
    if !progress(0, best.len() as u64) {
        return Err(Error::Cancelled);
    }
    let stats = arena.scratch(|s| -> Result<SelectStats> {
        let nf = input.facet_edges.len();
        let ne = input.edge_count;
        // Keep in step with `select_bytes`.
        let start = s.try_alloc_slice(ne + 1, 0u32)?;
        let ni = incidence_count(input.facet_edges);
        let inc = s.try_alloc_slice(ni, 0u32)?;
        let fstart = s.try_alloc_slice(nf + 1, 0u32)?;
        let fcon = s.try_alloc_slice(ni, 0u32)?;
        let owner = s.try_alloc_slice(ni, 0u32)?;
        let cls = s.try_alloc_slice(ni, UNUSED)?;
        let state = s.try_alloc_slice(nf, UND)?;
        let sel = s.try_alloc_slice(ne, 0u32)?;
        let und = s.try_alloc_slice(ne, 0u32)?;
        let eq = Fifo {
            buf: s.try_alloc_slice(ne, 0u32)?,
            queued: s.try_alloc_slice(ne, false)?,
            head: 0,
            len: 0,
        };
        let fq = Fifo {
            buf: s.try_alloc_slice(nf, 0u32)?,
            queued: s.try_alloc_slice(nf, false)?,
            head: 0,
            len: 0,
        };
        let trail = s.try_alloc_slice(nf, 0u32)?;
        let share = s.try_alloc_slice(ni, 0.0f64)?;
        let picks = s.try_alloc_slice(nf, 0u8)?;
        let con = s.try_alloc_slice(ni, 0.0f64)?;
        let coff = s.try_alloc_slice(ni, 0.0f64)?;
        let top_id = s.try_alloc_slice(ne, [u32::MAX; 3])?;
        let top_v = s.try_alloc_slice(ne, [NEG; 5])?;
        let term = s.try_alloc_slice(ne, 0.0f64)?;
        let in_e = s.try_alloc_slice(ne, false)?;
        let in_f = s.try_alloc_slice(nf, false)?;
        let dirty = s.try_alloc_slice(ne, false)?;
        let dlist = s.try_alloc_slice(ne, 0u32)?;
        let mstale = s.try_alloc_slice(ne, false)?;
        let mlist = s.try_alloc_slice(ne, 0u32)?;
        let work = s.try_alloc_slice(nf, 0u32)?;
        let seen = s.try_alloc_slice(nf, false)?;
        let tmp = s.try_alloc_slice(nf, false)?;
        let deg = s.try_alloc_slice(ne, 0u32)?;
        let flags = s.try_alloc_slice(nf, 0u8)?;
        let ball_f = s.try_alloc_slice(nf, 0u32)?;
        let ball_e = s.try_alloc_slice(ne, 0u32)?;
        let comp_f = s.try_alloc_slice(nf, 0u32)?;
        let comp_e = s.try_alloc_slice(ne, 0u32)?;
        let recs = s.try_alloc_slice(nf, [0u32; 4])?;
        let mut stack = Stack {
            facet: s.try_alloc_slice(nf, 0u32)?,
            mark: s.try_alloc_slice(nf, 0u32)?,
            info: s.try_alloc_slice(nf, 0u8)?,
            bound: s.try_alloc_slice(nf, 0.0f64)?,
            len: 0,
        };

        // Facet -> edge incidence (CSR of the used slots, in slot order), with an
        // even split of each score over the facet's edges.
        let mut x = 0usize;
        for (f, row) in input.facet_edges.iter().enumerate() {
            fstart[f] = x as u32;
            for &e in row.iter().filter(|&&e| e != UNUSED) {
                fcon[x] = e;
                owner[x] = f as u32;
                start[e as usize + 1] += 1;
                x += 1;
            }
            let k = x - fstart[f] as usize;
            let w = input.scores[f] as f64;
            share[fstart[f] as usize..x].fill(w / k as f64);
            share[x - 1] = w - (k - 1) as f64 * (w / k as f64);
        }
        fstart[nf] = x as u32;
        // Edge -> facet incidence (CSR), facets ascending within each edge.
        for e in 0..ne {
            start[e + 1] += start[e];
            und[e] = start[e + 1] - start[e];
        }
        for (x, &e) in fcon.iter().enumerate() {
            let e = e as usize;
            inc[(start[e] + sel[e]) as usize] = x as u32;
            sel[e] += 1;
        }
        sel.fill(0);
        // Classes (see `Solver::cls`): on each edge, a facet's fold group holding
        // the most facets of the edge (at least two; ties to the lower id). `deg`
        // (idle here) counts them.
        if let Some(masks) = input.edge_mask {
            let amo = |g: u32| masks[g as usize] & 0b100 == 0;
            for e in (0..ne).filter(|&e| !amo(e as u32)) {
                let r = start[e] as usize..start[e + 1] as usize;
                let groups = |x: u32| {
                    let f = owner[x as usize] as usize;
                    fcon[fstart[f] as usize..fstart[f + 1] as usize]
                        .iter()
                        .copied()
                        .filter(move |&g| g as usize != e && amo(g))
                };
                for &x in &inc[r.clone()] {
                    for g in groups(x) {
                        deg[g as usize] += 1;
                    }
                }
                for &x in &inc[r.clone()] {
                    let mut best = (1u32, UNUSED);
                    for g in groups(x) {
                        let c = deg[g as usize];
                        if c > best.0 || (c == best.0 && c >= 2 && g < best.1) {
                            best = (c, g);
                        }
                    }
                    cls[x as usize] = best.1;
                }
                for &x in &inc[r.clone()] {
                    for g in groups(x) {
                        deg[g as usize] = 0;
                    }
                }
                inc[r].sort_unstable_by_key(|&x| (cls[x as usize], x));
            }
        }

        let mut sv = Solver {
            fstart,
            fcon,
            owner,
            w: input.scores,
            masks: input.edge_mask,
            pens: input.edge_penalty,
            start,
            inc,
            cls,
            state,
            sel,
            und,
            eq,
            fq,
            trail,
            trail_len: 0,
            share,
            picks,
            con,
            coff,
            top_id,
            top_v,
            term,
            in_e,
            in_f,
            dirty,
            dlist,
            dlen: 0,
            mstale,
            mlist,
            mlen: 0,
            fixed: 0.0,
            work,
            seen,
            tmp,
            deg,
            flags,
            rounding: true,
            scale: 1.0,
            eps: 0.0,
            best: &mut *best,
        };

        // Root propagation. Only "off" can be forced here (0 is always allowed and
        // nothing is selected), so it never conflicts.
        for e in 0..ne {
            sv.eq.push(e);
        }
        let _always_feasible = sv.propagate();
        let mut stats = SelectStats {
            forced: sv.trail_len as u32,
            ..SelectStats::default()
        };

        // Components: undecided facets linked through shared edges (`dirty`, idle
        // here, marks the edges met).
        let (mut nc, mut fl, mut el) = (0usize, 0usize, 0usize);
        for root in 0..nf {
            if sv.state[root] != UND || sv.seen[root] {
                continue;
            }
            let (f0, e0) = (fl, el);
            sv.seen[root] = true;
            comp_f[fl] = root as u32;
            fl += 1;
            let mut head = f0;
            while head < fl {
                let f = comp_f[head] as usize;
                head += 1;
                for &e in sv.edges_of(f) {
                    let e = e as usize;
                    if sv.dirty[e] {
                        continue;
                    }
                    sv.dirty[e] = true;
                    comp_e[el] = e as u32;
                    el += 1;
                    for k in sv.incidences(e) {
                        let g = sv.of(sv.inc[k]);
                        if sv.state[g] == UND && !sv.seen[g] {
                            sv.seen[g] = true;
                            comp_f[fl] = g as u32;
                            fl += 1;
                        }
                    }
                }
            }
            comp_f[f0..fl].sort_unstable();
            comp_e[e0..el].sort_unstable();
            recs[nc] = [f0 as u32, (fl - f0) as u32, e0 as u32, (el - e0) as u32];
            nc += 1;
        }
        for &e in comp_e[..el].iter() {
            sv.dirty[e as usize] = false;
        }
        let recs = &mut recs[..nc];
        recs.sort_unstable_by_key(|r| (r[1], comp_f[r[0] as usize]));
        stats.components = nc as u32;
        stats.largest_component = recs.iter().map(|r| r[1]).max().unwrap_or(0);

        let total = nf as u64;
        let mut done = stats.forced as u64;
        let mut left = input.node_limit;
        let mut optimal = true;
        for r in recs.iter() {
            let facets = &comp_f[r[0] as usize..(r[0] + r[1]) as usize];
            let edges = &comp_e[r[2] as usize..(r[2] + r[3]) as usize];
            let abs = facets
                .iter()
                .map(|&f| (input.scores[f as usize] as f64).abs())
                .sum::<f64>();
            let tol = 1e-9 * (1.0 + abs);
            sv.scale = (abs / facets.len() as f64).max(f64::MIN_POSITIVE);
            sv.eps = MOVE_EPS * sv.scale;
            // The incumbent starts as "nothing" (worth 0, always feasible).
            let mut inc = 0.0f64;
            if let Some(v) = sv.dive(facets, edges, inc) {
                inc = v;
            }
            inc += sv.improve_best(facets);
            sv.open(facets, edges);
            let root = sv.root_bound(facets, edges, &mut inc, tol);
            sv.close(facets, edges);
            let (finished, ub) = if root <= inc + tol {
                (true, inc)
            } else {
                if let Some(v) = sv.dive(facets, edges, inc) {
                    inc = v;
                    inc += sv.improve_best(facets);
                }
                let mut report = || progress(done, total);
                let mut budget = Budget {
                    left,
                    used: stats.nodes,
                    report: &mut report,
                };
                sv.lns(
                    facets,
                    edges,
                    &mut stack,
                    (&mut *ball_f, &mut *ball_e),
                    &mut inc,
                    tol,
                    &mut budget,
                )?;
                let (finished, ub) =
                    sv.search(facets, edges, &mut stack, &mut inc, tol, root, &mut budget)?;
                left = budget.left;
                stats.nodes = budget.used;
                if !finished {
                    inc += sv.improve_best(facets);
                }
                (finished, ub.min(root).max(inc))
            };
            optimal &= finished;
            stats.objective += inc;
            stats.upper_bound += if finished { inc } else { ub };
            done += facets.len() as u64;
            if !progress(done, total) {
                return Err(Error::Cancelled);
            }
        }
        stats.optimal = optimal;
        if optimal {
            stats.upper_bound = stats.objective;
        }
        stats.gap = (stats.upper_bound - stats.objective) / stats.upper_bound.abs().max(1.0);
        Ok(stats)
    })?;
    Ok((best, stats))
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::arena::Arena;
    use core::mem::MaybeUninit;
    use std::vec;
    use std::vec::Vec;

    /// Node limit of these tests. They check proofs of optimality, so they need a
    /// limit that proves every instance here, not the pipeline's default
    /// ([`crate::Params::node_limit`]).
    const PROOF_NODE_LIMIT: u64 = 20_000;

    /// Facets given by vertex triples; edges numbered in order of appearance.
    struct Mesh {
        facets: Vec<[u32; MAX_CONSTRAINTS]>,
        edges: Vec<(u32, u32)>,
    }

    fn mesh(tris: &[[u32; 3]]) -> Mesh {
        let mut edges: Vec<(u32, u32)> = Vec::new();
        let mut facets = Vec::new();
        for t in tris {
            let mut f = [0u32; 3];
            for i in 0..3 {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                let key = (a.min(b), a.max(b));
                let id = match edges.iter().position(|&e| e == key) {
                    Some(p) => p,
                    None => {
                        edges.push(key);
                        edges.len() - 1
                    }
                };
                f[i] = id as u32;
            }
            facets.push(widen(f));
        }
        Mesh { facets, edges }
    }

    fn degrees(input: &SelectInput<'_>, sel: &[bool]) -> Vec<u32> {
        let mut deg = vec![0u32; input.edge_count];
        for (f, e) in input.facet_edges.iter().enumerate() {
            if sel[f] {
                for &e in e.iter().filter(|&&e| e != UNUSED) {
                    deg[e as usize] += 1;
                }
            }
        }
        deg
    }

    /// Objective of `sel`, or `None` when some edge's degree is not allowed.
    fn value(input: &SelectInput<'_>, sel: &[bool]) -> Option<f64> {
        let deg = degrees(input, sel);
        let mut v = 0.0;
        for (e, &d) in deg.iter().enumerate() {
            let m = input.edge_mask.map_or(MASK_CLOSED, |m| m[e]);
            if d > 2 || (m >> d) & 1 == 0 {
                return None;
            }
            if d == 1 {
                v -= input.edge_penalty.map_or(0.0, |p| p[e] as f64);
            }
        }
        for (f, &s) in sel.iter().enumerate() {
            if s {
                v += input.scores[f] as f64;
            }
        }
        Some(v)
    }

    fn brute(input: &SelectInput<'_>) -> f64 {
        let n = input.facet_edges.len();
        assert!(n <= 20);
        let mut best = f64::NEG_INFINITY;
        let mut sel = vec![false; n];
        for bits in 0u32..(1 << n) {
            for (f, s) in sel.iter_mut().enumerate() {
                *s = (bits >> f) & 1 == 1;
            }
            if let Some(v) = value(input, &sel) {
                best = best.max(v);
            }
        }
        best
    }

    fn run(input: &SelectInput<'_>) -> (Vec<bool>, SelectStats) {
        let n = select_bytes_for(input);
        assert!(n <= select_bytes(input.facet_edges.len(), input.edge_count));
        let mut buf = vec![MaybeUninit::<u8>::uninit(); n];
        let arena = Arena::new(&mut buf);
        let (sel, stats) = try_select_in(&arena, input, &mut |_, _| true).unwrap();
        assert!(arena.peak() <= n);
        let sel = sel.to_vec();
        let v = value(input, &sel).expect("selection must be feasible");
        assert!(
            (v - stats.objective).abs() < 1e-6,
            "{v} vs {}",
            stats.objective
        );
        assert!(stats.upper_bound >= stats.objective - 1e-9);
        (sel, stats)
    }

    fn err(input: &SelectInput<'_>) -> Error {
        let mut buf = vec![MaybeUninit::<u8>::uninit(); 1 << 16];
        let arena = Arena::new(&mut buf);
        try_select_in(&arena, input, &mut |_, _| true).unwrap_err()
    }

    /// Tetrahedron 0123 plus a low-scoring tent 014, 124, 204 over face 012.
    fn tetra_and_tent() -> (Mesh, Vec<f32>) {
        let m = mesh(&[
            [0, 1, 2],
            [0, 3, 1],
            [1, 3, 2],
            [2, 3, 0],
            [0, 1, 4],
            [1, 2, 4],
            [2, 0, 4],
        ]);
        (m, vec![1.0, 1.0, 1.0, 1.0, 0.2, 0.2, 0.2])
    }

    #[test]
    fn a_tetrahedron_beats_its_worse_tented_alternative() {
        let (m, w) = tetra_and_tent();
        let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
        let (sel, st) = run(&input);
        assert_eq!(sel, [true, true, true, true, false, false, false]);
        assert!(st.optimal && (st.objective - 4.0).abs() < 1e-6 && st.gap == 0.0);
        // Make the tent worth more than face 012: the bipyramid wins.
        let w2 = vec![0.1, 1.0, 1.0, 1.0, 0.5, 0.5, 0.5];
        let input = SelectInput::new(&m.facets, &w2, m.edges.len(), PROOF_NODE_LIMIT);
        let (sel, st) = run(&input);
        assert_eq!(sel, [false, true, true, true, true, true, true]);
        assert!(st.optimal && (st.objective - 4.5).abs() < 1e-6);
    }

    #[test]
    fn two_tetrahedra_on_one_edge_only_one_is_taken() {
        // Edge 01 carries four candidate facets.
        let m = mesh(&[
            [0, 1, 2],
            [0, 3, 1],
            [1, 3, 2],
            [2, 3, 0],
            [1, 0, 4],
            [0, 5, 4],
            [4, 5, 1],
            [1, 5, 0],
        ]);
        let w = vec![1.0, 1.0, 1.0, 1.0, 0.9, 0.9, 0.9, 0.9];
        let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
        let (sel, st) = run(&input);
        assert_eq!(&sel[..4], &[true; 4]);
        assert_eq!(&sel[4..], &[false; 4]);
        assert!(st.optimal && (st.objective - 4.0).abs() < 1e-6);
        assert_eq!(st.components, 1);
    }

    /// Convex quad 0123 (in that order), all four triangles: 012 and 023 (diagonal
    /// 02), 013 and 123 (diagonal 13); with `apexes`, also the octahedron's eight
    /// faces over apex 4 above and apex 5 below. Returns the mesh and its
    /// geometric fold groups: at each quad edge, the two quad triangles on it lie
    /// on the same side (the quad's inside), so they form a group; on a diagonal
    /// they lie on opposite sides, and the apex faces stand 90 degrees apart.
    fn flat_quad(apexes: bool) -> (Mesh, Vec<Vec<usize>>) {
        let mut tris = vec![[0, 1, 2], [0, 2, 3], [0, 1, 3], [1, 2, 3]];
        if apexes {
            for (a, b) in [(0, 1), (1, 2), (2, 3), (3, 0)] {
                tris.push([a, b, 4]);
                tris.push([a, b, 5]);
            }
        }
        let m = mesh(&tris);
        let quad_tris: Vec<usize> = (0..4).collect();
        let groups = [(0, 1), (1, 2), (2, 3), (0, 3)]
            .iter()
            .map(|&(a, b)| {
                quad_tris
                    .iter()
                    .copied()
                    .filter(|&f| tris[f].contains(&a) && tris[f].contains(&b))
                    .collect::<Vec<usize>>()
            })
            .collect();
        (m, groups)
    }

    /// The rows of `m` plus the groups as constraints `edges..`, with their masks.
    fn with_groups(m: &Mesh, groups: &[Vec<usize>]) -> (Vec<[u32; MAX_CONSTRAINTS]>, Vec<u8>) {
        let mut rows = m.facets.clone();
        let mut mask = vec![MASK_CLOSED; m.edges.len()];
        for g in groups {
            for &f in g {
                add_to(&mut rows, f, mask.len() as u32);
            }
            mask.push(MASK_AT_MOST_ONE);
        }
        (rows, mask)
    }

    #[test]
    fn fold_groups_forbid_the_flat_tetrahedron_of_a_quads_two_triangulations() {
        let (m, groups) = flat_quad(false);
        assert!(groups.iter().all(|g| g.len() == 2));
        let w = vec![1.0f32; 4];
        // Edges only: both triangulations close a flat tetrahedron, worth 4.
        let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
        let (sel, st) = run(&input);
        assert_eq!(sel, [true; 4]);
        assert!(st.optimal && (st.objective - 4.0).abs() < 1e-9);
        // With the fold groups a quad alone cannot close: nothing.
        let (rows, mask) = with_groups(&m, &groups);
        let input = SelectInput {
            edge_mask: Some(&mask),
            ..SelectInput::new(&rows, &w, mask.len(), PROOF_NODE_LIMIT)
        };
        let (sel, st) = run(&input);
        assert_eq!(sel, [false; 4]);
        assert!(st.optimal && st.objective == 0.0);
        assert_eq!(brute(&input), 0.0);
    }

    #[test]
    fn fold_groups_in_an_octahedron_leave_one_triangulation_under_a_pyramid() {
        let (m, groups) = flat_quad(true);
        // Quad triangles worth more than the octahedron's faces: without groups
        // the flat tetrahedron (4 x 2.5) beats the octahedron (8) and a pyramid
        // closed by one triangulation (4 + 2 x 2.5).
        let mut w = vec![2.5f32; 4];
        w.extend((0..8).map(|i| if i % 2 == 0 { 1.0 } else { 0.9 }));
        let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
        let (sel, st) = run(&input);
        assert_eq!(&sel[..4], &[true; 4]);
        assert!(st.optimal && (st.objective - 10.0).abs() < 1e-5);
        let (rows, mask) = with_groups(&m, &groups);
        let input = SelectInput {
            edge_mask: Some(&mask),
            ..SelectInput::new(&rows, &w, mask.len(), PROOF_NODE_LIMIT)
        };
        let (sel, st) = run(&input);
        assert!(
            st.optimal && (st.objective - 9.0).abs() < 1e-5,
            "{}",
            st.objective
        );
        assert!((brute(&input) - 9.0).abs() < 1e-5);
        // The upper pyramid (even faces, worth 1.0) and one triangulation.
        assert_eq!(sel.iter().filter(|&&s| s).count(), 6);
        assert!(sel[..4] == [true, true, false, false] || sel[..4] == [false, false, true, true]);
        assert!((4..12).all(|f| sel[f] == (f % 2 == 0)));
    }

    #[test]
    fn all_negative_scores_select_nothing() {
        let (m, _) = tetra_and_tent();
        let w = vec![-0.5; 7];
        let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
        let (sel, st) = run(&input);
        assert!(sel.iter().all(|&s| !s));
        assert!(st.optimal && st.objective == 0.0);
    }

    #[test]
    fn a_negative_facet_is_taken_when_it_closes_a_surface() {
        let (m, _) = tetra_and_tent();
        let w = vec![-0.5, 1.0, 1.0, 1.0, -1.0, -1.0, -1.0];
        let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
        let (sel, st) = run(&input);
        assert_eq!(sel, [true, true, true, true, false, false, false]);
        assert!(st.optimal && (st.objective - 2.5).abs() < 1e-6);
    }

    #[test]
    fn an_open_strip_keeps_its_border_only_when_worth_the_penalty() {
        // Strip 012, 213, 234: interior edges 12 and 23, the rest border edges.
        let m = mesh(&[[0, 1, 2], [2, 1, 3], [2, 3, 4]]);
        let interior = |e: &(u32, u32)| *e == (1, 2) || *e == (2, 3);
        let mask: Vec<u8> = m
            .edges
            .iter()
            .map(|e| {
                if interior(e) {
                    MASK_CLOSED
                } else {
                    MASK_BORDER
                }
            })
            .collect();
        let w = vec![1.0f32; 3];
        for (pen, expect) in [(0.1f32, 3.0 - 5.0 * 0.1), (1.0, 0.0)] {
            let pens = vec![pen; m.edges.len()];
            let input = SelectInput {
                edge_mask: Some(&mask),
                edge_penalty: Some(&pens),
                ..SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT)
            };
            let (sel, st) = run(&input);
            assert!(st.optimal);
            assert!(
                (st.objective - expect).abs() < 1e-6,
                "{pen}: {}",
                st.objective
            );
            assert!((brute(&input) - expect).abs() < 1e-6);
            assert_eq!(sel.iter().all(|&s| s), expect > 0.0);
        }
    }

    #[test]
    fn a_lone_triangle_is_forced_off_and_nothing_is_optimal() {
        let m = mesh(&[[0, 1, 2], [1, 2, 3]]);
        let w = vec![5.0, 5.0];
        let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
        let (sel, st) = run(&input);
        assert_eq!(sel, [false, false]);
        assert!(st.optimal && st.objective == 0.0);
        assert_eq!((st.forced, st.components, st.nodes), (2, 0, 0));
    }

    #[test]
    fn mask_zero_only_forbids_an_edge() {
        let (m, w) = tetra_and_tent();
        let mut mask = vec![MASK_CLOSED; m.edges.len()];
        mask[0] = 0b001; // edge 01: the tetrahedron and the tent both need it
        let input = SelectInput {
            edge_mask: Some(&mask),
            ..SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT)
        };
        let (sel, st) = run(&input);
        assert!(sel.iter().all(|&s| !s) && st.optimal);
    }

    /// Facet edges, scores, edge count, masks, penalties.
    type Random = (
        Vec<[u32; MAX_CONSTRAINTS]>,
        Vec<f32>,
        usize,
        Vec<u8>,
        Vec<f32>,
    );

    /// Put facet `f` into constraint `id` (its first unused slot).
    fn add_to(rows: &mut [[u32; MAX_CONSTRAINTS]], f: usize, id: u32) {
        let slot = rows[f].iter().position(|&e| e == UNUSED).unwrap();
        rows[f][slot] = id;
    }

    /// Deterministic pseudo-random instances: triangles of a random graph; with
    /// `groups`, the facets on each edge are also shuffled into runs, and runs of
    /// two or more become at-most-one groups (random penalty or none).
    fn random_instance(seed: u64, verts: u32, p: u32, border: bool, groups: bool) -> Random {
        let mut s = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let mut next = move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 33) as u32
        };
        let mut tris = Vec::new();
        let mut adj = vec![false; (verts * verts) as usize];
        for a in 0..verts {
            for b in a + 1..verts {
                if next() % 100 < p {
                    adj[(a * verts + b) as usize] = true;
                }
            }
        }
        for a in 0..verts {
            for b in a + 1..verts {
                for c in b + 1..verts {
                    let e = |x: u32, y: u32| adj[(x * verts + y) as usize];
                    if e(a, b) && e(b, c) && e(a, c) {
                        tris.push([a, b, c]);
                    }
                }
            }
        }
        tris.truncate(16);
        let m = mesh(&tris);
        let w: Vec<f32> = (0..m.facets.len())
            .map(|_| (next() % 2001) as f32 / 1000.0 - 0.7)
            .collect();
        let mask: Vec<u8> = (0..m.edges.len())
            .map(|_| {
                if border && next() % 3 == 0 {
                    MASK_BORDER
                } else {
                    MASK_CLOSED
                }
            })
            .collect();
        let mut pens: Vec<f32> = (0..m.edges.len())
            .map(|_| (next() % 100) as f32 / 200.0)
            .collect();
        let (mut rows, mut mask, mut ne) = (m.facets, mask, m.edges.len());
        if groups {
            for e in 0..m.edges.len() as u32 {
                let mut on: Vec<usize> = (0..rows.len())
                    .filter(|&f| rows[f][..3].contains(&e))
                    .collect();
                for i in (1..on.len()).rev() {
                    on.swap(i, next() as usize % (i + 1));
                }
                let mut rest = &on[..];
                while !rest.is_empty() {
                    let n = (1 + next() as usize % 3).min(rest.len());
                    if n >= 2 {
                        for &f in &rest[..n] {
                            add_to(&mut rows, f, ne as u32);
                        }
                        mask.push(MASK_AT_MOST_ONE);
                        pens.push(if next() % 2 == 0 {
                            0.0
                        } else {
                            (next() % 100) as f32 / 400.0
                        });
                        ne += 1;
                    }
                    rest = &rest[n..];
                }
            }
        }
        (rows, w, ne, mask, pens)
    }

    #[test]
    fn matches_brute_force_on_small_random_instances() {
        for seed in 0..300u64 {
            let (fe, w, ne, mask, pens) =
                random_instance(seed, 7 + (seed % 4) as u32, 60, seed % 2 == 1, false);
            let input = SelectInput {
                edge_mask: Some(&mask),
                edge_penalty: Some(&pens),
                ..SelectInput::new(&fe, &w, ne, PROOF_NODE_LIMIT)
            };
            let (_, st) = run(&input);
            let exact = brute(&input);
            assert!(st.optimal, "seed {seed}");
            assert!(
                (st.objective - exact).abs() < 1e-5,
                "seed {seed}: {} vs {exact}",
                st.objective
            );
        }
    }

    #[test]
    fn matches_brute_force_with_random_at_most_one_groups() {
        let mut grouped = 0;
        for seed in 0..300u64 {
            let (fe, w, ne, mask, pens) =
                random_instance(seed, 7 + (seed % 4) as u32, 60, seed % 2 == 1, true);
            grouped += (mask.contains(&MASK_AT_MOST_ONE)) as u32;
            let input = SelectInput {
                edge_mask: Some(&mask),
                edge_penalty: Some(&pens),
                ..SelectInput::new(&fe, &w, ne, PROOF_NODE_LIMIT)
            };
            let (_, st) = run(&input);
            let exact = brute(&input);
            assert!(st.optimal, "seed {seed}");
            assert!(
                (st.objective - exact).abs() < 1e-5,
                "seed {seed}: {} vs {exact}",
                st.objective
            );
        }
        assert!(grouped >= 200, "only {grouped} instances have a group");
    }

    #[test]
    fn node_limits_still_give_feasible_selections_with_honest_bounds() {
        for seed in 0..120u64 {
            let (fe, w, ne, mask, pens) = random_instance(seed, 9, 70, seed % 2 == 1, seed >= 60);
            let exact = {
                let input = SelectInput {
                    edge_mask: Some(&mask),
                    edge_penalty: Some(&pens),
                    ..SelectInput::new(&fe, &w, ne, PROOF_NODE_LIMIT)
                };
                brute(&input)
            };
            for limit in [0, 1, 2] {
                let input = SelectInput {
                    edge_mask: Some(&mask),
                    edge_penalty: Some(&pens),
                    ..SelectInput::new(&fe, &w, ne, limit)
                };
                let (_, st) = run(&input);
                assert!(st.nodes <= limit);
                assert!(
                    st.upper_bound >= exact - 1e-6,
                    "seed {seed}: ub {} < {exact}",
                    st.upper_bound
                );
                assert!(st.objective <= exact + 1e-6);
                assert!(st.gap >= 0.0);
                if st.optimal {
                    assert!((st.objective - exact).abs() < 1e-5);
                }
            }
        }
    }

    #[test]
    fn extreme_and_zero_scores_stay_exact() {
        let (m, _) = tetra_and_tent();
        let sets: [[f32; 7]; 4] = [
            [0.0; 7],
            [1e30, 1e30, 1e30, 1e30, -1e30, 2e30, 1e30],
            [1e-30, 1e-30, -1e-30, 1e-30, 3e-30, 1e-30, 1e-30],
            [
                f32::MAX,
                f32::MAX,
                f32::MAX,
                f32::MAX,
                f32::MIN,
                f32::MAX,
                f32::MAX,
            ],
        ];
        for w in &sets {
            let input = SelectInput::new(&m.facets, w, m.edges.len(), PROOF_NODE_LIMIT);
            let (_, st) = run(&input);
            let exact = brute(&input);
            assert!(st.optimal, "{w:?}");
            assert!(
                (st.objective - exact).abs() <= 1e-6 * exact.abs().max(1e-30),
                "{w:?}: {} vs {exact}",
                st.objective
            );
        }
    }

    #[test]
    fn cancellation_is_an_error() {
        let (m, w) = tetra_and_tent();
        let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
        let mut buf = vec![MaybeUninit::<u8>::uninit(); 1 << 16];
        let arena = Arena::new(&mut buf);
        let r = try_select_in(&arena, &input, &mut |_, _| false);
        assert_eq!(r.unwrap_err(), Error::Cancelled);
        let mut calls = 0;
        let r = try_select_in(&arena, &input, &mut |_, _| {
            calls += 1;
            calls < 2
        });
        assert_eq!(r.unwrap_err(), Error::Cancelled);
    }

    #[test]
    fn hostile_inputs_are_errors_not_panics() {
        let fe = [widen([0u32, 1, 2])];
        let w = [1.0f32];
        let is_bad = |e: Error| matches!(e, Error::BadParameter { .. });
        assert!(is_bad(err(&SelectInput::new(&fe, &w, 2, PROOF_NODE_LIMIT))));
        assert!(is_bad(err(&SelectInput::new(
            &[widen([0, 1, 1])],
            &w,
            3,
            PROOF_NODE_LIMIT
        ))));
        assert!(is_bad(err(&SelectInput::new(
            &[widen([u32::MAX, 1, 2])],
            &w,
            3,
            PROOF_NODE_LIMIT
        ))));
        // Groups: out of range, repeated, or too few slots used.
        assert!(is_bad(err(&SelectInput::new(
            &[join([0, 1, 2], [0, 9, UNUSED], 3)],
            &w,
            4,
            PROOF_NODE_LIMIT
        ))));
        assert!(is_bad(err(&SelectInput::new(
            &[[0, 1, 2, 3, UNUSED, 1]],
            &w,
            4,
            PROOF_NODE_LIMIT
        ))));
        assert!(is_bad(err(&SelectInput::new(
            &[[UNUSED, 1, UNUSED, 3, UNUSED, UNUSED]],
            &w,
            4,
            PROOF_NODE_LIMIT
        ))));
        assert!(is_bad(err(&SelectInput::new(
            &[join([0, 1, 2], [0, 0, 0], UNUSED - 1)],
            &w,
            4,
            PROOF_NODE_LIMIT
        ))));
        // Slots may be used in any order.
        let (sel, st) = run(&SelectInput::new(
            &[[UNUSED, 2, 3, UNUSED, 0, 1]],
            &w,
            4,
            PROOF_NODE_LIMIT,
        ));
        assert!(sel == [false] && st.optimal);
        assert!(is_bad(err(&SelectInput::new(
            &fe,
            &[f32::NAN],
            3,
            PROOF_NODE_LIMIT
        ))));
        assert!(is_bad(err(&SelectInput::new(
            &fe,
            &[f32::INFINITY],
            3,
            PROOF_NODE_LIMIT
        ))));
        assert!(is_bad(err(&SelectInput::new(
            &fe,
            &[],
            3,
            PROOF_NODE_LIMIT
        ))));
        let masks = [[0b101u8, 0b101, 0b100], [0b101, 0b1101, 0b101]];
        for m in &masks {
            let input = SelectInput {
                edge_mask: Some(m),
                ..SelectInput::new(&fe, &w, 3, PROOF_NODE_LIMIT)
            };
            assert!(is_bad(err(&input)));
        }
        let short = [0b101u8; 2];
        assert!(is_bad(err(&SelectInput {
            edge_mask: Some(&short),
            ..SelectInput::new(&fe, &w, 3, PROOF_NODE_LIMIT)
        })));
        for p in [[0.0f32, -1.0, 0.0], [0.0, f32::NAN, 0.0]] {
            assert!(is_bad(err(&SelectInput {
                edge_penalty: Some(&p),
                ..SelectInput::new(&fe, &w, 3, PROOF_NODE_LIMIT)
            })));
        }
        // Empty problems are fine.
        let (sel, st) = run(&SelectInput::new(&[], &[], 0, PROOF_NODE_LIMIT));
        assert!(sel.is_empty() && st.optimal && st.objective == 0.0);
        let (sel, st) = run(&SelectInput::new(&[], &[], 5, PROOF_NODE_LIMIT));
        assert!(sel.is_empty() && st.optimal);
    }

    #[test]
    fn a_small_arena_is_exhausted_not_a_panic() {
        let (m, w) = tetra_and_tent();
        let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
        let need = select_bytes_for(&input);
        for n in [0, 7, need / 2, need / 4 * 3] {
            let mut buf = vec![MaybeUninit::<u8>::uninit(); n];
            let arena = Arena::new(&mut buf);
            let e = try_select_in(&arena, &input, &mut |_, _| true).unwrap_err();
            assert!(matches!(e, Error::Exhausted(_)), "{n}: {e:?}");
        }
    }
}
