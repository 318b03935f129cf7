//! Region growing on every thread with the partition of growing as one.
//!
//! Region growing ([`partition`](super::partition)) pops points in the order
//! of their `(cost, point)` keys and gives each the cluster of the cheapest
//! offer it holds when popped. Its labels are those of a bottleneck-path
//! problem, which is what lets two threads compute them:
//!
//! - Give each final point `q` a *level* `λ(q)`: 0 for a seed (seeds go first,
//!   in seed order), else `max(key(q) + 1, λ(r))` with `r` the point whose offer
//!   `q` holds. It is the largest key popped so far when `q` is popped: a key
//!   below it pops at once, in the cascade of the point that set the level.
//! - An offer from final `r` of cluster `l` to `q` is the triple
//!   `(max(key(cost(q, l), q) + 1, λ(r)), λ(r), l)`. Of two offers the growth
//!   lets `q` keep the lesser triple: the first entry is when `q` would pop
//!   holding it, and on a tie, the offer made first wins (the lower level; on
//!   the same level the same cluster, one cascade floods one cluster; among
//!   seeds, the lower seed index).
//! - So every point holds the least offer of its final neighbours, its level
//!   the first entry of that triple, and every level comes down a chain of
//!   offers from a seed: the least such assignment, which the growth reaches.
//!
//! Here the points are cut into one slab a thread ([`MAX_SLABS`] at most)
//! across the longest axis of the seeds' box, at quantiles of the points in
//! proportion to the rates the slabs grew at last time ([`Shares`]: on a
//! machine whose cores run at different speeds the slabs end together). When
//! the last partition is known (a warm start), a point goes to the slab of
//! its last cluster's seed instead of its own, so the cuts follow the
//! clusters' borders, which move little from one partition to the next:
//! far fewer points are offered across a cut and grown again (the bunny's
//! 12 partitions in two slabs: 1,700-1,900 points grown again a run against
//! 7,857 with the cuts across the axis; at 250 clusters 5,896 against
//! 32,236). Each
//! slab grows from its own seeds over its own points on its own thread,
//! recording each point's level and the point whose offer it holds. Then a
//! repair makes the union what growing as one gives (its first step in
//! each slab at once, in tasks; the growth of step 2 on the calling
//! thread):
//!
//! 1. Points that a neighbour across a cut offers a lesser triple than the
//!    one they hold, and points no seed of their slab reached, are *reset*,
//!    with every point whose chain of offers runs through a reset point (its
//!    descendants: their levels are all higher; all in the slab of the
//!    point reset, a slab's growth offering only to its own points). Every
//!    slab resets its own, then every slab's reset points take the least
//!    offer of their final neighbours (which no slab changes meanwhile).
//! 2. The reset points grow in the order of their levels, as one growth, each
//!    offering to every neighbour when final. A final point that is offered a
//!    lesser triple than its own is reset there, with its descendants (their
//!    levels are above the one being popped, so nothing final hangs on them),
//!    and the points holding an offer of a reset point take again the least of
//!    their final neighbours'.
//!
//! The labels are the same as growing as one, bit for bit, whatever the
//! threads. The partition's energy is summed over the ranges of
//! [`parallel::TASKS`] tasks, in order, either way.
//!
//! Memory (scratch): 6 words a point (label, cost, last rival, offering
//! point, level), a byte a point for its slab and one for the repair's
//! flags, the heaps' 8 + 4 bytes and the list's 4 a point (each slab's cut
//! points, then its marked and reset points), a word a
//! point sampled for the cuts (at most [`CUT_SAMPLE`]), a byte a cluster for
//! its slab on a warm start. When the scratch has
//! no room, or the caller runs one thread ([`Progress::threads`]), region
//! growing runs as one. Cost: the slabs' growths at once, then O(k) per
//! point the repair grows again (about 0.5 % of the points a partition on
//! the bunny, 2 % with cuts across the axis).

use super::partition::{guessed, key, open_to, Ctx, Heap, FILTER, FINAL, GUESSES, NONE};
use crate::arena::{atomic_bytes, atomic_u32_rows, Alloc, Scratch};
use crate::math::V3;
use crate::parallel;
use crate::parallel::Task;
use crate::progress::Progress;
use core::sync::atomic::Ordering::Relaxed;
use core::sync::atomic::{AtomicU32, AtomicU8};

/// Most slabs of a region growing (one a thread).
const MAX_SLABS: usize = 8;
/// Fewest points a slab; fewer grow as one.
const MIN_SLAB_POINTS: usize = 4096;
/// Fewest clusters a slab.
const MIN_SLAB_CLUSTERS: usize = 32;
/// Most points sampled to place the cuts.
const CUT_SAMPLE: usize = 4096;

/// Set in a slab's count of points grown when it has finished.
const FINISHED: u32 = 1 << 31;
/// How many points a slab grows between updates of its count.
const COUNT_EVERY: usize = 256;

/// How the points are shared among the slabs: each slab's growth rate (points
/// a unit of time) when last measured, relative to the others. The slabs' cuts
/// follow it, so a thread that grows faster (another core, or a virtual core
/// whose host is less busy) gets more points and the slabs end together. The
/// labels are those of growing as one whatever the cuts: this moves only the
/// time. Kept across the partitions of one clustering.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Shares {
    rate: [u32; MAX_SLABS],
}

/// A slab's rate when shared evenly.
const EVEN: u32 = 1 << 16;

impl Default for Shares {
    fn default() -> Self {
        Shares {
            rate: [EVEN; MAX_SLABS],
        }
    }
}

impl Shares {
    /// The rates after a growth in `slabs` slabs in which `seen` is what the
    /// slab that finished first saw when it did: each slab's points grown so
    /// far ([`FINISHED`] set in those that had finished too). The rates
    /// measured are averaged with the last ones (one slow growth moves the
    /// cuts half the way) and kept within half and twice the even rate.
    fn learn(&mut self, slabs: usize, seen: &[u32; MAX_SLABS]) {
        let slabs = slabs.min(MAX_SLABS);
        let total: u64 = seen[..slabs].iter().map(|&d| (d & !FINISHED) as u64).sum();
        if slabs < 2 || total == 0 {
            return;
        }
        for (r, &d) in self.rate[..slabs].iter_mut().zip(seen) {
            let measured = ((d & !FINISHED) as u64 * slabs as u64 * EVEN as u64 / total) as u32;
            let mixed = ((*r as u64 + measured as u64) / 2) as u32;
            *r = mixed.clamp(EVEN / 2, EVEN * 2);
        }
    }

    /// Slab `i`'s cumulative share of the first `slabs` slabs' points, up to
    /// and including it, of `of` (0 when `slabs` is 0).
    fn upto(&self, i: usize, slabs: usize, of: usize) -> usize {
        let slabs = slabs.min(MAX_SLABS);
        let sum: u64 = self.rate[..slabs].iter().map(|&r| r as u64).sum();
        let upto: u64 = self.rate[..=i.min(slabs.saturating_sub(1))]
            .iter()
            .map(|&r| r as u64)
            .sum();
        (upto * of as u64).checked_div(sum).unwrap_or(0) as usize
    }
}

/// Words of a point's slot.
const WORDS: usize = 6;
const LABEL: usize = 0;
const BEST: usize = 1;
const TRIED: usize = 2;
const FROM: usize = 3;
const LEVEL_HI: usize = 4;
const LEVEL_LO: usize = 5;
/// `TRIED` of a final point with a neighbour in another slab.
const CUT: u32 = FINAL;
/// `TRIED` of a final point offered a lesser triple across the cut.
const DIRTY: u32 = FINAL | 1;
/// The level of a point holding no offer.
const NO_LEVEL: u64 = u64::MAX;

/// Bytes of scratch [`grow_in_slabs`] takes for `n` points (beside the
/// guessed costs), with room for the alignment of each slice.
fn slabs_bytes(n: usize, clusters: usize) -> usize {
    n.saturating_mul(WORDS * 4 + 2 + 8 + 4 + 4)
        .saturating_add(n.min(CUT_SAMPLE).saturating_mul(4))
        .saturating_add(clusters)
        .saturating_add(7 * 64)
}

/// Every point's slot: [`WORDS`] atomic words, so the slabs grow at once
/// over one array, each reading and writing only its own points' slots
/// (relaxed loads and stores: plain moves on the targets we build for).
struct Slots<'s>(&'s [[AtomicU32; WORDS]]);

impl Slots<'_> {
    /// Point `p`'s words (`None` past the end): one bounds check for all of
    /// them, where the growth's inner loop reads and sets several.
    #[inline]
    fn slot(&self, p: usize) -> Option<&[AtomicU32; WORDS]> {
        self.0.get(p)
    }

    #[inline]
    fn get(&self, p: usize, w: usize, or: u32) -> u32 {
        self.0
            .get(p)
            .and_then(|s| s.get(w))
            .map_or(or, |a| a.load(Relaxed))
    }

    #[inline]
    fn set(&self, p: usize, w: usize, v: u32) {
        if let Some(a) = self.0.get(p).and_then(|s| s.get(w)) {
            a.store(v, Relaxed);
        }
    }

    #[inline]
    fn label(&self, p: usize) -> u32 {
        self.get(p, LABEL, NONE)
    }

    #[inline]
    fn best(&self, p: usize) -> f32 {
        f32::from_bits(self.get(p, BEST, f32::INFINITY.to_bits()))
    }

    #[inline]
    fn from(&self, p: usize) -> u32 {
        self.get(p, FROM, NONE)
    }

    #[inline]
    fn level(&self, p: usize) -> u64 {
        (self.get(p, LEVEL_HI, u32::MAX) as u64) << 32 | self.get(p, LEVEL_LO, u32::MAX) as u64
    }

    #[inline]
    fn set_level(&self, p: usize, level: u64) {
        self.set(p, LEVEL_HI, (level >> 32) as u32);
        self.set(p, LEVEL_LO, level as u32);
    }

    /// `p` holds the offer of `from`: cluster `label` at `cost`, level `level`.
    #[inline]
    fn hold(&self, p: usize, label: u32, cost: f32, from: u32, level: u64) {
        self.set(p, LABEL, label);
        self.set(p, BEST, cost.to_bits());
        self.set(p, FROM, from);
        self.set_level(p, level);
    }

    /// `p` holds nothing.
    #[inline]
    fn clear(&self, p: usize) {
        self.hold(p, NONE, f32::INFINITY, NONE, NO_LEVEL);
        self.set(p, TRIED, NONE);
    }

    /// The triple `p` holds (see the module docs); the greatest when none.
    #[inline]
    fn standing(&self, p: usize) -> (u64, u64, u32) {
        let label = self.label(p) & !FINAL;
        if label == NONE {
            return (NO_LEVEL, NO_LEVEL, NONE);
        }
        let from = self.from(p);
        let below = if from == NONE {
            0
        } else {
            self.level(from as usize)
        };
        (self.level(p), below, label)
    }
}

/// What the slabs and the repair read.
struct Shared<'a, 'p, 'x> {
    ctx: &'a Ctx<'p, 'x>,
    generators: &'a [V3],
    guess: &'a [(u32, f32)],
    slots: &'a Slots<'a>,
}

impl Shared<'_, '_, '_> {
    /// Point `p`'s cost to cluster `label`: its own when it holds that
    /// cluster, else guessed or computed.
    #[inline]
    fn cost(&self, p: usize, label: u32) -> f32 {
        if self.slots.label(p) & !FINAL == label {
            return self.slots.best(p);
        }
        guessed(self.guess, p, label).unwrap_or_else(|| match self.generators.get(label as usize) {
            Some(&c) => self.ctx.cost(p, c),
            None => f32::INFINITY,
        })
    }

    /// The offer of final point `r` to `q` (see the module docs) and its cost.
    #[inline]
    fn offer(&self, r: usize, q: usize) -> ((u64, u64, u32), f32) {
        let label = self.slots.label(r) & !FINAL;
        let level = self.slots.level(r);
        let cost = self.cost(q, label);
        let at = (key(cost, q as u32) + 1).max(level);
        ((at, level, label), cost)
    }
}

/// One slab's growth, a task of its own.
struct Slab<'a, 'p, 'x, 'h> {
    shared: &'a Shared<'a, 'p, 'x>,
    seeds: &'a [u32],
    part: &'a [u8],
    slab: u8,
    room: &'h mut [u64],
    /// Its points marked [`CUT`], in the order they were (room for every
    /// point of the slab), and how many; `None` when they did not fit (a
    /// seed given twice is offered from twice).
    cuts: &'h mut [u32],
    cut: Option<usize>,
    /// Its points made final.
    finals: usize,
    /// Every slab's count of points made final so far (now and then), with
    /// [`FINISHED`] once it has finished.
    counts: &'a [AtomicU32; MAX_SLABS],
    /// The counts when it finished.
    seen: [u32; MAX_SLABS],
}

impl Task for Slab<'_, '_, '_, '_> {
    fn run(&mut self) {
        let Slab {
            shared,
            seeds,
            part,
            slab,
            ..
        } = *self;
        let slots = shared.slots;
        let mine = |p: usize| part.get(p) == Some(&slab);
        let count = self.counts.get(slab as usize);
        let mut heap = Heap {
            keys: &mut *self.room,
            len: 0,
        };
        let (mut cut, mut finals) = (Some(0), 0);
        let cuts = &mut *self.cuts;
        let mut note = |q: usize| {
            cut = cut.and_then(|n| {
                *cuts.get_mut(n)? = q as u32;
                Some(n + 1)
            });
        };
        for (j, &sd) in seeds.iter().enumerate() {
            if mine(sd as usize) {
                slots.hold(sd as usize, j as u32 | FINAL, 0.0, NONE, 0);
                finals += 1;
            }
        }
        for &sd in seeds {
            // A seed given twice offers twice; it is noted once.
            let noted = slots.get(sd as usize, TRIED, NONE) == CUT;
            if mine(sd as usize)
                && offer_within(shared, &mut heap, part, slab, sd as usize)
                && !noted
            {
                note(sd as usize);
            }
        }
        while let Some(top) = heap.pop() {
            let q = (top & 0xFFFF_FFFF) as usize;
            let Some(w) = slots.slot(q) else {
                continue;
            };
            let label = w[LABEL].load(Relaxed);
            if label & FINAL != 0 {
                continue;
            }
            if heap.len > 0 {
                let next = (heap.keys[0] & 0xFFFF_FFFF) as usize;
                let nb = shared.ctx.nb;
                crate::hint::prefetch(nb.knn.as_ptr().wrapping_add(next * nb.k));
                crate::hint::prefetch(nb.rev_start.as_ptr().wrapping_add(next));
                crate::hint::prefetch(slots.0.as_ptr().wrapping_add(next));
            }
            w[LABEL].store(label | FINAL, Relaxed);
            finals += 1;
            if finals % COUNT_EVERY == 0 {
                if let Some(c) = count {
                    c.store(finals as u32 & !FINISHED, Relaxed);
                }
            }
            let from = w[FROM].load(Relaxed) as usize;
            slots.set_level(q, (top + 1).max(slots.level(from)));
            if offer_within(shared, &mut heap, part, slab, q) {
                note(q);
            }
        }
        (self.cut, self.finals) = (cut, finals);
        let done = finals.min(FINISHED as usize - 1) as u32 | FINISHED;
        if let Some(c) = count {
            c.store(done, Relaxed);
        }
        self.seen = core::array::from_fn(|i| self.counts.get(i).map_or(0, |c| c.load(Relaxed)));
    }
}

/// Offer the cluster of final point `q` to its unfinished neighbours in
/// `slab`, as region growing does; mark `q` [`CUT`] when a neighbour is in
/// another slab, and say whether it did.
fn offer_within(shared: &Shared, heap: &mut Heap, part: &[u8], slab: u8, q: usize) -> bool {
    let Shared {
        ctx,
        generators,
        guess,
        slots,
    } = *shared;
    let label = slots.label(q) & !FINAL;
    let Some(&c) = generators.get(label as usize) else {
        return false;
    };
    let rows = ctx.nb.rows(q);
    for row in rows {
        for &nbr in row {
            let nbr = nbr as usize;
            // A cost from the planes reads the neighbour's row; only such
            // costs are guessed ahead.
            if ctx.planes.diffused.is_empty() {
                crate::hint::prefetch(ctx.nb.knn.as_ptr().wrapping_add(nbr * ctx.nb.k));
                crate::hint::prefetch(guess.as_ptr().wrapping_add(nbr * GUESSES));
            }
            crate::hint::prefetch(slots.0.as_ptr().wrapping_add(nbr));
            ctx.planes.prefetch(nbr);
            crate::hint::prefetch(ctx.points.as_ptr().wrapping_add(nbr));
        }
    }
    let mut cut = false;
    let mut open = [0u32; FILTER];
    for chunk in rows.iter().flat_map(|row| row.chunks(FILTER)) {
        // The slab's neighbours still open to an offer of `label`, listed
        // without a branch on each, as in region growing as one.
        let mut count = 0;
        for &nbr in chunk {
            let p = nbr as usize;
            if part.get(p) != Some(&slab) {
                cut = true;
                continue;
            }
            let Some(w) = slots.slot(p) else {
                continue;
            };
            let t = w[LABEL].load(Relaxed);
            let tried = w[TRIED].load(Relaxed);
            let offered = open_to(t, tried, label);
            w[TRIED].store(if offered { label } else { tried }, Relaxed);
            open[count & (FILTER - 1)] = nbr;
            count += offered as usize;
        }
        for &nbr in open.iter().take(count) {
            let p = nbr as usize;
            let Some(w) = slots.slot(p) else {
                continue;
            };
            let t = w[LABEL].load(Relaxed);
            let e = guessed(guess, p, label).unwrap_or_else(|| ctx.cost(p, c));
            if t == NONE || e < f32::from_bits(w[BEST].load(Relaxed)) {
                // The level is set when it pops.
                w[LABEL].store(label, Relaxed);
                w[BEST].store(e.to_bits(), Relaxed);
                w[FROM].store(q as u32, Relaxed);
                if !heap.push(key(e, nbr)) {
                    // Full: drop stale entries (final points, superseded costs).
                    heap.retain(|k| {
                        let p = (k & 0xFFFF_FFFF) as usize;
                        slots.label(p) & FINAL == 0 && key(slots.best(p), p as u32) == k
                    });
                    // Live entries <= unfinished points of the slab: room now.
                    heap.push(key(e, nbr));
                }
            }
        }
    }
    if cut {
        slots.set(q, TRIED, CUT);
    }
    cut
}

/// One slab's check across the cuts, a task of its own: mark [`DIRTY`] its
/// final points to which a final neighbour in another slab offers a lesser
/// triple than the one they hold, and list those and its points no seed
/// reached. Only the slab's [`CUT`] points (`list[..cut]`, as its growth
/// noted them) are looked at, every point of the slab when they did not
/// fit (`cut` `None`), and its open ones only when some were left open
/// (`open`). The marked points are written over the front of `list`
/// (`marked` of them, each once), in the order looked at.
struct Check<'a, 'p, 'x, 'h> {
    shared: &'a Shared<'a, 'p, 'x>,
    part: &'a [u8],
    slab: u8,
    list: &'h mut [u32],
    cut: Option<usize>,
    open: bool,
    marked: usize,
}

impl Task for Check<'_, '_, '_, '_> {
    fn run(&mut self) {
        let (shared, part, slab) = (self.shared, self.part, self.slab);
        let slots = shared.slots;
        // Whether a cut point of the slab is offered a lesser triple across
        // the cut (and is marked [`DIRTY`] then).
        let dirty = |q: usize| {
            if slots.get(q, TRIED, NONE) != CUT || slots.level(q) == 0 {
                return false;
            }
            let held = slots.standing(q);
            for row in shared.ctx.nb.rows(q) {
                for &r in row {
                    let r = r as usize;
                    if part.get(r) == Some(&slab)
                        || slots.label(r) & FINAL == 0
                        || slots.level(r) > held.0
                    {
                        continue;
                    }
                    if shared.offer(r, q).0 < held {
                        slots.set(q, TRIED, DIRTY);
                        return true;
                    }
                }
            }
            false
        };
        let list = &mut *self.list;
        let mut marked = 0;
        match self.cut {
            Some(cut) => {
                for i in 0..cut.min(list.len()) {
                    let q = list[i] as usize;
                    if dirty(q) {
                        // `marked <= i`: written over an entry already read.
                        list[marked] = q as u32;
                        marked += 1;
                    }
                }
            }
            None => {
                for (q, &h) in part.iter().enumerate() {
                    if h == slab && dirty(q) {
                        if let Some(slot) = list.get_mut(marked) {
                            *slot = q as u32;
                            marked += 1;
                        }
                    }
                }
            }
        }
        if self.open {
            for (q, &h) in part.iter().enumerate() {
                if h == slab && slots.label(q) & FINAL == 0 {
                    // Open points are not final, so none was marked dirty:
                    // with them the list holds at most the slab's points.
                    if let Some(slot) = list.get_mut(marked) {
                        *slot = q as u32;
                        marked += 1;
                    }
                }
            }
        }
        self.marked = marked;
    }
}

/// The first step of the repair in one slab, a task of its own: its
/// [`DIRTY`] points (among the marked ones its [`Check`] listed at the
/// front of the repair's list) cleared with their descendants
/// ([`Repair::clear_tree`]), which go on the list. The slabs' steps touch
/// only their own points' slots (a descendant is in its root's slab); what
/// they read of another slab's points (their offering point, never one of
/// this slab) does not depend on the other's progress.
struct ResetSlab<'a, 'p, 'x, 's> {
    repair: Repair<'a, 'p, 'x, 's>,
    fine: bool,
}

impl Task for ResetSlab<'_, '_, '_, '_> {
    fn run(&mut self) {
        let slots = self.repair.shared.slots;
        let marked = self.repair.listed;
        for i in 0..marked {
            let p = self.repair.list[i] as usize;
            if slots.label(p) & FINAL != 0
                && slots.get(p, TRIED, NONE) == DIRTY
                && !self.repair.clear_tree(p)
            {
                self.fine = false;
                return;
            }
        }
    }
}

/// The second step of the repair in one slab, a task of its own, once every
/// slab's first step is done: each open point of its list (reset, or
/// reached by no seed of the slab) takes the least offer of its final
/// neighbours into the slab's part of the heap ([`Repair::gather`]), once
/// (a point listed twice, marked and then reset as another's descendant,
/// is flagged in `gathered`). The final points, of every slab, stay as they
/// are meanwhile: a gather reads only those (and writes its own point,
/// which is open).
struct GatherSlab<'a, 'p, 'x, 's> {
    repair: Repair<'a, 'p, 'x, 's>,
    gathered: &'a [AtomicU8],
    fine: bool,
}

impl Task for GatherSlab<'_, '_, '_, '_> {
    fn run(&mut self) {
        let slots = self.repair.shared.slots;
        for i in 0..self.repair.listed {
            let p = self.repair.list[i] as usize;
            let Some(g) = self.gathered.get(p) else {
                continue;
            };
            if g.load(Relaxed) != 0 || slots.label(p) & FINAL != 0 {
                continue;
            }
            g.store(1, Relaxed);
            if !self.repair.gather(p) {
                self.fine = false;
                return;
            }
        }
    }
}

/// The repair on the calling thread (see the module docs): a heap of
/// `(level, point)` pairs and the list of reset points.
struct Repair<'a, 'p, 'x, 's> {
    shared: &'a Shared<'a, 'p, 'x>,
    levels: &'s mut [u64],
    points: &'s mut [u32],
    len: usize,
    list: &'s mut [u32],
    listed: usize,
}

impl Repair<'_, '_, '_, '_> {
    /// Push `(level, p)`; `false` when the heap is full of live entries.
    fn push(&mut self, level: u64, p: u32) -> bool {
        if self.len == self.levels.len() {
            self.compact();
            if self.len == self.levels.len() {
                return false;
            }
        }
        let mut i = self.len;
        self.len += 1;
        while i > 0 {
            let parent = (i - 1) / 2;
            if (self.levels[parent], self.points[parent]) <= (level, p) {
                break;
            }
            self.levels[i] = self.levels[parent];
            self.points[i] = self.points[parent];
            i = parent;
        }
        self.levels[i] = level;
        self.points[i] = p;
        true
    }

    fn pop(&mut self) -> Option<(u64, u32)> {
        if self.len == 0 {
            return None;
        }
        let top = (self.levels[0], self.points[0]);
        self.len -= 1;
        self.levels[0] = self.levels[self.len];
        self.points[0] = self.points[self.len];
        self.sift_down(0);
        Some(top)
    }

    fn sift_down(&mut self, mut i: usize) {
        if i >= self.len {
            return;
        }
        let moving = (self.levels[i], self.points[i]);
        loop {
            let a = 2 * i + 1;
            if a >= self.len {
                break;
            }
            let b = a + 1;
            let at = if b < self.len
                && (self.levels[b], self.points[b]) < (self.levels[a], self.points[a])
            {
                b
            } else {
                a
            };
            if (self.levels[at], self.points[at]) >= moving {
                break;
            }
            self.levels[i] = self.levels[at];
            self.points[i] = self.points[at];
            i = at;
        }
        (self.levels[i], self.points[i]) = moving;
    }

    /// Keep only the entries of points that still hold that level, unfinished.
    fn compact(&mut self) {
        let slots = self.shared.slots;
        let mut w = 0;
        for r in 0..self.len {
            let (level, p) = (self.levels[r], self.points[r]);
            let p_ = p as usize;
            if slots.label(p_) & FINAL == 0 && slots.level(p_) == level {
                // One entry a point: a duplicate (same level pushed again
                // after a reset) is dropped by marking the level taken.
                self.levels[w] = level;
                self.points[w] = p;
                w += 1;
            }
        }
        self.len = w;
        // Duplicates: sort-free removal by a pass that keeps the first of
        // each point (the points' TRIED word is free while they are open).
        let mut kept = 0;
        for r in 0..self.len {
            let p = self.points[r] as usize;
            if slots.get(p, TRIED, NONE) != FINAL | 2 {
                slots.set(p, TRIED, FINAL | 2);
                self.levels[kept] = self.levels[r];
                self.points[kept] = self.points[r];
                kept += 1;
            }
        }
        for r in 0..kept {
            slots.set(self.points[r] as usize, TRIED, NONE);
        }
        self.len = kept;
        for i in (0..self.len / 2 + 1).rev() {
            self.sift_down(i);
        }
    }

    /// Open point `z` takes the least offer of its final neighbours (none:
    /// it holds nothing). `false` when the heap is full.
    fn gather(&mut self, z: usize) -> bool {
        let shared = self.shared;
        let slots = shared.slots;
        slots.clear(z);
        let mut best: Option<((u64, u64, u32), f32, u32)> = None;
        for row in shared.ctx.nb.rows(z) {
            for &y in row {
                let y_ = y as usize;
                // An offer is no earlier than its maker's level: one above the
                // least so far cannot win (no cost computed).
                if slots.label(y_) & FINAL == 0
                    || best.is_some_and(|((at, _, _), _, _)| slots.level(y_) > at)
                {
                    continue;
                }
                let (o, cost) = shared.offer(y_, z);
                if best.is_none_or(|(b, _, _)| o < b) {
                    best = Some((o, cost, y));
                }
            }
        }
        match best {
            Some(((at, _, label), cost, y)) => {
                slots.hold(z, label, cost, y, at);
                self.push(at, z as u32)
            }
            None => true,
        }
    }

    /// Clear final point `root` (listed already) and its descendants (the
    /// points whose chain of offers runs through it, all in its slab: a
    /// slab's growth offers only to its own points), listing the
    /// descendants, without gathering (the first step of the slabs' repair,
    /// [`ResetSlab`]). `false` when the list is full.
    fn clear_tree(&mut self, root: usize) -> bool {
        let slots = self.shared.slots;
        let nb = self.shared.ctx.nb;
        slots.clear(root);
        let (mut x, mut i) = (root as u32, self.listed);
        loop {
            for row in nb.rows(x as usize) {
                for &c in row {
                    let c_ = c as usize;
                    if slots.label(c_) & FINAL != 0 && slots.from(c_) == x && slots.level(c_) != 0 {
                        let Some(slot) = self.list.get_mut(self.listed) else {
                            return false;
                        };
                        *slot = c;
                        self.listed += 1;
                        slots.clear(c_);
                    }
                }
            }
            let Some(&next) = self.list[..self.listed].get(i) else {
                return true;
            };
            (x, i) = (next, i + 1);
        }
    }

    /// Restore the heap order of the first `len` entries.
    fn heapify(&mut self) {
        for i in (0..self.len / 2 + 1).rev() {
            self.sift_down(i);
        }
    }

    /// Reset final point `root` and its descendants, then let them, and the
    /// open points holding their offers, take their final neighbours' least
    /// offers. `false` when the list or the heap is full.
    fn reset(&mut self, root: usize) -> bool {
        let slots = self.shared.slots;
        let nb = self.shared.ctx.nb;
        let start = self.listed;
        let Some(slot) = self.list.get_mut(self.listed) else {
            return false;
        };
        *slot = root as u32;
        self.listed += 1;
        if !self.clear_tree(root) {
            return false;
        }
        for i in start..self.listed {
            let z = self.list[i] as usize;
            // Open points holding an offer of `z` (made while it was final).
            for row in nb.rows(z) {
                for &w in row {
                    let w_ = w as usize;
                    if slots.label(w_) & FINAL == 0
                        && slots.from(w_) == z as u32
                        && !self.gather(w_)
                    {
                        return false;
                    }
                }
            }
            if !self.gather(z) {
                return false;
            }
        }
        true
    }

    /// Grow the open points in the order of their levels (see the module
    /// docs). `false` when the list or the heap ran out of room.
    fn run(&mut self) -> bool {
        let shared = self.shared;
        let slots = shared.slots;
        while let Some((level, x)) = self.pop() {
            let x_ = x as usize;
            let label = slots.label(x_);
            if label & FINAL != 0 || label == NONE || slots.level(x_) != level {
                continue;
            }
            slots.set(x_, LABEL, label | FINAL);
            for row in shared.ctx.nb.rows(x_) {
                for &y in row {
                    let y_ = y as usize;
                    let held = slots.label(y_);
                    // Seeds never change, and an offer made at this level cannot
                    // beat a triple held from a lower one (no cost computed).
                    if (held & FINAL != 0 && slots.level(y_) == 0) || slots.level(y_) < level {
                        continue;
                    }
                    let (o, cost) = shared.offer(x_, y_);
                    if o >= slots.standing(y_) {
                        continue;
                    }
                    if held & FINAL != 0 {
                        if !self.reset(y_) {
                            return false;
                        }
                    } else {
                        slots.hold(y_, o.2, cost, x, o.0);
                        if !self.push(o.0, y) {
                            return false;
                        }
                    }
                }
            }
        }
        true
    }
}

/// Region growing over `labels.len()` points from `seeds` (their clusters'
/// generators `generators`, costs `guess` computed ahead, possibly empty) in
/// slabs at once, one a thread of `hooks`, then repaired (module docs): the
/// labels of growing as one, and the energy (the points' costs summed by the
/// tasks' ranges, in order). The slabs' points in proportion to `shares`,
/// which learns from the growth how fast each slab grew. With `last`,
/// `labels` holds the last partition (a warm start) and each point goes to
/// the slab of its last cluster's seed. `None` when `hooks` has one thread,
/// the slabs would be too small, or the scratch has no room (`labels`
/// untouched).
#[allow(clippy::too_many_arguments)]
pub(crate) fn grow_in_slabs(
    s: &Scratch,
    ctx: &Ctx,
    generators: &[V3],
    seeds: &[u32],
    guess: &[(u32, f32)],
    labels: &mut [u32],
    last: bool,
    shares: &mut Shares,
    hooks: &dyn Progress,
) -> Option<f64> {
    let n = labels.len();
    let slabs = hooks
        .threads()
        .min(MAX_SLABS)
        .min(n / MIN_SLAB_POINTS)
        .min(seeds.len() / MIN_SLAB_CLUSTERS);
    if slabs < 2 || s.available() < slabs_bytes(n, seeds.len()) || u32::try_from(n).is_err() {
        return None;
    }
    let bounds = cuts(s, ctx, seeds, slabs, shares)?;
    let open = [
        NONE,
        f32::INFINITY.to_bits(),
        NONE,
        NONE,
        u32::MAX,
        u32::MAX,
    ];
    // Filled on every thread: 6 MB at a million points.
    let words = s.try_alloc_slice_on::<[u32; WORDS]>(n, open, hooks).ok()?;
    let part = s.try_alloc_slice_on::<u8>(n, 0, hooks).ok()?;
    let gathered = s.try_alloc_slice_on::<u8>(n, 0, hooks).ok()?;
    let levels = s.try_alloc_slice_on::<u64>(n, 0, hooks).ok()?;
    let points = s.try_alloc_slice_on::<u32>(n, 0, hooks).ok()?;
    let list = s.try_alloc_slice_on::<u32>(n, 0, hooks).ok()?;
    let slots = Slots(atomic_u32_rows(words));
    let gathered = atomic_bytes(gathered);
    let (axis, bounds) = bounds;
    let bounds = &bounds[..slabs - 1];
    let slab_at = |p: usize| {
        let x = ctx.points.get(p).map_or(0.0, |q| q[axis]);
        bounds.iter().filter(|&&b| x > b).count() as u8
    };
    // With the last partition in `labels`, a point goes to the slab of its
    // last cluster's seed, so the cuts run between clusters, where the
    // partition moves little, instead of through them: fewer points are
    // offered across a cut, and fewer are grown again on one thread.
    let of_cluster = s
        .try_alloc_slice::<u8>(if last { seeds.len() } else { 0 }, 0)
        .ok()?;
    for (h, &sd) in of_cluster.iter_mut().zip(seeds) {
        *h = slab_at(sd as usize);
    }
    let of_cluster = &*of_cluster;
    let last_labels = &*labels;
    let counts = parallel::rows(hooks, part, 1, |points, part: &mut [u8]| {
        let mut count = [0usize; MAX_SLABS];
        for (h, p) in part.iter_mut().zip(points) {
            let slab = last_labels
                .get(p)
                .and_then(|&l| of_cluster.get(l as usize))
                .map_or_else(|| slab_at(p), |&h| h);
            *h = slab;
            count[slab as usize] += 1;
        }
        count
    });
    let mut count = [0usize; MAX_SLABS];
    for c in &counts {
        for (a, b) in count.iter_mut().zip(c) {
            *a += b;
        }
    }
    let part = &*part;
    let shared = Shared {
        ctx,
        generators,
        guess,
        slots: &slots,
    };
    // Each slab's part of the room (its heap, then its part of the
    // repair's heap) and of the list (its cut points, then the repair's
    // list): one slot a point of the slab.
    let (mut cut, mut finals, mut marked) =
        ([None; MAX_SLABS], [0usize; MAX_SLABS], [0usize; MAX_SLABS]);
    let grown = [const { AtomicU32::new(0) }; MAX_SLABS];
    {
        let mut cuts = split_by(list, &count).into_iter();
        let mut i = 0;
        let mut jobs: [Slab; MAX_SLABS] = split_by(levels, &count).map(|room| {
            let job = Slab {
                shared: &shared,
                seeds,
                part,
                slab: i as u8,
                room,
                cuts: cuts.next().unwrap_or_default(),
                cut: Some(0),
                finals: 0,
                counts: &grown,
                seen: [0; MAX_SLABS],
            };
            i += 1;
            job
        });
        let mut tasks = jobs.each_mut().map(|j| j as &mut dyn Task);
        hooks.run(&mut tasks[..slabs]);
        for (i, j) in jobs.iter().enumerate() {
            (cut[i], finals[i]) = (j.cut, j.finals);
        }
        // The slab that finished while all the others were growing, if one
        // did (else they ended within a few hundred points of each other).
        let first = jobs[..slabs]
            .iter()
            .enumerate()
            .find(|(i, j)| (0..slabs).all(|k| k == *i || j.seen[k] & FINISHED == 0));
        if let Some((_, j)) = first {
            shares.learn(slabs, &j.seen);
        }
    }
    {
        let lists = split_by(list, &count);
        let mut i = 0;
        let mut jobs: [Check; MAX_SLABS] = lists.map(|list| {
            let job = Check {
                shared: &shared,
                part,
                slab: i as u8,
                list,
                cut: cut[i],
                open: finals[i] < count[i],
                marked: 0,
            };
            i += 1;
            job
        });
        let mut tasks = jobs.each_mut().map(|j| j as &mut dyn Task);
        hooks.run(&mut tasks[..slabs]);
        for (m, j) in marked.iter_mut().zip(&jobs) {
            *m = j.marked;
        }
    }
    // The repair's first two steps in each slab at once (its resets, then
    // its gathers, in the slab's own part of the list and the heap), then
    // the growth of the open points as one, from the slabs' heaps put
    // together. The open points and the offers they hold are those of
    // resetting and gathering one point after another: each reset only
    // removes final points, and each open point holds the least offer of
    // the final points that are left.
    let mut lens = [0usize; MAX_SLABS];
    {
        let mut heaps = split_by(levels, &count)
            .into_iter()
            .zip(split_by(points, &count));
        let mut lists = split_by(list, &count).into_iter();
        let mut resets: [ResetSlab; MAX_SLABS] = core::array::from_fn(|i| {
            let (l, q) = heaps.next().unwrap_or_default();
            ResetSlab {
                repair: Repair {
                    shared: &shared,
                    levels: l,
                    points: q,
                    len: 0,
                    list: lists.next().unwrap_or_default(),
                    listed: marked[i],
                },
                fine: true,
            }
        });
        let mut tasks = resets.each_mut().map(|j| j as &mut dyn Task);
        hooks.run(&mut tasks[..slabs]);
        if resets.iter().any(|r| !r.fine) {
            return None;
        }
        let mut gathers = resets.map(|r| GatherSlab {
            repair: r.repair,
            gathered,
            fine: true,
        });
        let mut tasks = gathers.each_mut().map(|j| j as &mut dyn Task);
        hooks.run(&mut tasks[..slabs]);
        for (len, g) in lens.iter_mut().zip(&gathers) {
            if !g.fine {
                return None;
            }
            *len = g.repair.len;
        }
    }
    // The slabs' heaps side by side at the front, made one heap.
    let mut total = 0;
    let mut from = 0;
    for (&len, &c) in lens.iter().zip(&count).take(slabs) {
        levels.copy_within(from..from + len, total);
        points.copy_within(from..from + len, total);
        total += len;
        from += c;
    }
    let mut repair = Repair {
        shared: &shared,
        levels,
        points,
        len: total,
        list,
        listed: 0,
    };
    repair.heapify();
    if !repair.run() {
        return None;
    }
    let energy = parallel::rows(hooks, labels, 1, |points, labels: &mut [u32]| {
        let mut sum = 0.0f64;
        for (p, l) in points.zip(labels) {
            *l = slots.label(p) & !FINAL;
            sum += slots.best(p) as f64;
        }
        sum
    });
    Some(energy.iter().fold(0.0, |a, b| a + b))
}

/// `all` cut into [`MAX_SLABS`] consecutive parts of `count` entries (as
/// many as there are, the last ones empty).
fn split_by<'s, T>(all: &'s mut [T], count: &[usize; MAX_SLABS]) -> [&'s mut [T]; MAX_SLABS] {
    let mut rest = all;
    core::array::from_fn(|i| {
        // (The length read before the slice is taken out.)
        let c = count[i].min(rest.len());
        let (part, tail) = core::mem::take(&mut rest).split_at_mut(c);
        rest = tail;
        part
    })
}

/// The axis of the longest side of the seeds' box and the `slabs - 1`
/// coordinates along it that cut the points into slabs of counts in
/// proportion to `shares` (quantiles of an even sample of at most
/// [`CUT_SAMPLE`] points, sorted in scratch): a slab's growth costs in
/// proportion to its points.
fn cuts(
    s: &Scratch,
    ctx: &Ctx,
    seeds: &[u32],
    slabs: usize,
    shares: &Shares,
) -> Option<(usize, [f32; MAX_SLABS])> {
    let at = |p: usize| ctx.points.get(p).copied().unwrap_or([0.0; 3]);
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for &sd in seeds {
        let p = at(sd as usize);
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let axis = (0..3)
        .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
        .unwrap_or(0);
    let n = ctx.points.len();
    let m = n.min(CUT_SAMPLE);
    let along = s.try_alloc_slice::<f32>(m, 0.0).ok()?;
    for (i, v) in along.iter_mut().enumerate() {
        // In u64: `i * n` overflows a 32-bit usize past a million points.
        *v = at((i as u64 * n as u64 / m as u64) as usize)[axis];
    }
    along.sort_unstable_by(f32::total_cmp);
    let mut bounds = [f32::INFINITY; MAX_SLABS];
    for (i, b) in bounds[..slabs - 1].iter_mut().enumerate() {
        *b = along
            .get(shares.upto(i, slabs, along.len()))
            .copied()
            .unwrap_or(f32::INFINITY);
    }
    Some((axis, bounds))
}

#[cfg(test)]
mod tests {
    use super::super::partition::{partition, Ctx, NONE};
    use super::*;
    use crate::arena::Arena;
    use crate::clustering::knn::try_neighbours_in;
    use crate::clustering::quadric::try_planes_in;
    use crate::clustering::sweep::Start;
    use crate::params::Params;
    use crate::progress::{Claimed, Silent};
    use crate::rng::Rng;
    use crate::sample::{fill, Shape};
    use core::mem::MaybeUninit;
    use std::format;
    use std::vec;
    use std::vec::Vec;

    /// Region growing in 2, 3 and 4 slabs gives the labels and the energy of
    /// growing as one, fresh and warm: on a regular grid whose seeds sit on a lattice
    /// (costs tie everywhere, so the order of offers decides) and on sampled
    /// shapes from random seeds.
    #[test]
    fn slabs_grow_the_partition_of_growing_as_one() {
        let grid: Vec<V3> = (0..130 * 130)
            .map(|i| [(i % 130) as f32, (i / 130) as f32, 0.0])
            .collect();
        let lattice: Vec<u32> = (0..13)
            .flat_map(|y| (0..13).map(move |x| (y * 10 + 5) * 130 + x * 10 + 5))
            .collect();
        // A grid with a slot cut from its right side: past the cut between
        // the slabs the points are two arms, joined only through the left
        // slab, and no seed lies in the lower arm, so the right slab's
        // growth leaves it open and the repair reaches it.
        let mut arms = Vec::new();
        let mut arm_seeds = Vec::new();
        for y in 0..100u32 {
            for x in 0..200u32 {
                if x >= 70 && (40..60).contains(&y) {
                    continue;
                }
                if x % 8 == 4 && y % 8 == 4 && !(x >= 70 && y < 40) {
                    arm_seeds.push(arms.len() as u32);
                }
                arms.push([x as f32, y as f32, 0.0]);
            }
        }
        // The grid again with one seed given twice (two clusters from one
        // point: the growths offer from it twice).
        let mut twice = lattice.clone();
        twice.push(lattice[84]);
        let mut clouds = vec![(grid.clone(), lattice), (arms, arm_seeds), (grid, twice)];
        for (shape, seed) in [
            (Shape::Demo, 3),
            (Shape::Torus, 4),
            (Shape::Scene, 5),
            (Shape::Box, 6),
            (Shape::Wave, 7),
        ] {
            let mut points = vec![[0.0f32; 3]; 16_500];
            fill(shape, seed, 0.002, &mut points);
            let mut rng = Rng::new(seed);
            // The scene's stray fragment (its last points) gets a seed too.
            let mut seeds: Vec<u32> = vec![points.len() as u32 - 1];
            while seeds.len() < 130 + 40 * (seed as usize % 3) {
                let p = (rng.next_u64() % points.len() as u64) as u32;
                if !seeds.contains(&p) {
                    seeds.push(p);
                }
            }
            clouds.push((points, seeds));
        }
        for (c, (points, seeds)) in clouds.iter().enumerate() {
            let mut buf = vec![MaybeUninit::uninit(); 16 << 20];
            let arena = Arena::new(&mut buf);
            let nb = try_neighbours_in(&arena, points, Params::default().k, &mut Silent).unwrap();
            let planes = try_planes_in(&arena, points, None, &nb, &mut Silent).unwrap();
            // Every other cloud costed from the planes alone, as the largest are.
            let planes = if c % 2 == 1 {
                planes.without_local()
            } else {
                planes
            };
            let params = Params::default();
            let ctx = Ctx::new(points, &nb, &planes, &params);
            let generators: Vec<V3> = seeds.iter().map(|&s| points[s as usize]).collect();
            // Warm: the last partition from generators moved a little.
            let moved: Vec<V3> = generators
                .iter()
                .map(|g| [g[0] + 0.3, g[1] - 0.2, g[2]])
                .collect();
            let mut last = vec![NONE; points.len()];
            arena
                .scratch(|s| {
                    partition(
                        s,
                        &ctx,
                        &moved,
                        seeds,
                        &mut last,
                        Start::Fresh,
                        None,
                        &mut Shares::default(),
                        &Silent,
                    )
                })
                .unwrap();
            // Generators away from their seeds: costs above those of the
            // seeds' neighbours, so offers come down long cascades.
            let mut rotated = generators.clone();
            rotated.rotate_left(1);
            for (start, generators) in [
                (Start::Fresh, &generators),
                (Start::Warm, &generators),
                (Start::Warm, &moved),
                (Start::Fresh, &rotated),
            ] {
                let mut one = last.clone();
                let e1 = arena
                    .scratch(|s| {
                        let even = &mut Shares::default();
                        partition(
                            s, &ctx, generators, seeds, &mut one, start, None, even, &Silent,
                        )
                    })
                    .unwrap();
                assert!(
                    one.iter().all(|&l| l != NONE),
                    "cloud {c}: a point left out"
                );
                // Even shares, and shares skewed either way (each growth
                // then learns from its tasks run one after another).
                let skewed = Shares {
                    rate: [
                        2 * EVEN,
                        EVEN / 2,
                        EVEN,
                        EVEN / 2,
                        2 * EVEN,
                        EVEN,
                        EVEN,
                        EVEN,
                    ],
                };
                let mut reversed = skewed;
                reversed.rate.reverse();
                for (threads, shares) in [2, 3, 4]
                    .into_iter()
                    .flat_map(|t| [Shares::default(), skewed, reversed].map(|s| (t, s)))
                {
                    let mut two = last.clone();
                    let hooks = Claimed::backwards(threads);
                    let mut learnt = shares;
                    let e2 = arena
                        .scratch(|s| {
                            let sh = &mut learnt;
                            partition(
                                s, &ctx, generators, seeds, &mut two, start, None, sh, &hooks,
                            )
                        })
                        .unwrap();
                    let at = format!("cloud {c}, {start:?}, {threads} slabs, {shares:?}");
                    // The slabs' growths, checks, resets and gathers, when
                    // even (skewed, a small slab's list may run out of room
                    // for its resets, and the growth falls back to one: once
                    // here, cloud 3 in 4 slabs).
                    if shares == Shares::default() {
                        assert_eq!(hooks.full_rounds.get(), 4, "{at}: the slabs did not run");
                    }
                    let differ = one.iter().zip(&two).filter(|(a, b)| a != b).count();
                    assert_eq!(differ, 0, "{at}: labels differ");
                    assert_eq!(e1.to_bits(), e2.to_bits(), "{at}: energy");
                }
            }
        }
    }

    /// The cuts follow the rates: even by default; a slab that finished
    /// first while another had grown half as many points gets its rate moved
    /// half the way to twice the other's; rates stay within half and twice
    /// the even one; a growth that measured nothing leaves them.
    #[test]
    fn shares_follow_the_rates_measured() {
        let mut sh = Shares::default();
        assert_eq!([0, 1, 2].map(|i| sh.upto(i, 3, 3000)), [1000, 2000, 3000]);
        assert_eq!(sh.upto(0, 0, 3000), 0);
        let mut seen = [0u32; MAX_SLABS];
        seen[0] = 2000 | FINISHED;
        seen[1] = 1000;
        sh.learn(2, &seen);
        // Measured 4/3 and 2/3 of the even rate, averaged with 1.
        assert_eq!(&sh.rate[..3], &[EVEN * 7 / 6, EVEN * 5 / 6, EVEN]);
        assert!((699..=700).contains(&sh.upto(0, 2, 1200)));
        seen[1] = 0;
        for _ in 0..20 {
            sh.learn(2, &seen);
        }
        assert!(sh.rate[0] > EVEN * 19 / 10 && sh.rate[0] <= EVEN * 2);
        assert_eq!(sh.rate[1], EVEN / 2);
        let before = sh;
        sh.learn(2, &[0; MAX_SLABS]);
        sh.learn(1, &seen);
        assert_eq!(sh, before);
    }
}
