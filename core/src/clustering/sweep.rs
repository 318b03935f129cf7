//! The partition by synchronous sweeps ([`Partition::Sweep`](crate::params::Partition::Sweep)): the same
//! labels for any thread count, warm-started from the partition before, so
//! a pass after the first recomputes only what changed near the borders
//! between clusters.

use crate::arena::{atomic_bytes, atomic_u16s, atomic_u32s, padded_bytes, plain_u32s, Scratch};
use crate::clustering::partition::{Ctx, NONE};
use crate::error::Result;
use crate::math::V3;
use crate::parallel;
use crate::progress::Progress;
use core::sync::atomic::{AtomicU16, AtomicU8, Ordering::Relaxed};

/// Scratch bytes of [`partition`] over `n` points and at most `m` clusters:
/// labels and costs (8 per point, whole blocks), three stamps (6 per point,
/// 4 per block), a flag per cluster, and [`connect`]'s search (5 per point,
/// 4 per cluster). Keep in step with the functions named.
pub(crate) fn partition_bytes(n: usize, m: usize) -> usize {
    let blocks = n.div_ceil(BLOCK);
    [
        padded_bytes::<(u32, f32)>(blocks.saturating_mul(BLOCK)),
        3 * padded_bytes::<u16>(n),
        2 * padded_bytes::<u16>(blocks),
        padded_bytes::<u8>(m),
        padded_bytes::<u8>(n),
        padded_bytes::<u32>(m.saturating_add(1)),
        padded_bytes::<u32>(n),
    ]
    .iter()
    .fold(0usize, |a, &b| a.saturating_add(b))
}

/// Points per block: a sweep skips the blocks with no point due.
const BLOCK: usize = 64;

/// The number of the first sweep of a partition (0 and 1 stamp nothing yet).
const FIRST: u16 = 2;

/// How a partition starts.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Start {
    /// From the seeds alone: every other point unlabelled.
    Fresh,
    /// From the labels the points have (those of clusters past the first `m`
    /// unlabelled), after the generators moved or were added: only what
    /// changed is recomputed.
    Warm,
}

/// A point's label and cost after the sweep being computed (its current ones
/// where the sweep changes nothing).
#[derive(Clone, Copy)]
struct Next {
    label: u32,
    cost: f32,
}

const UNLABELLED: Next = Next {
    label: NONE,
    cost: f32::INFINITY,
};

impl Next {
    /// Whether `(cost, label)` is below `self`'s: the lower label among equal costs.
    fn beaten_by(&self, cost: f32, label: u32) -> bool {
        cost < self.cost || (cost == self.cost && label < self.label)
    }
}

/// Partition the points among `generators` (seed Eq. 4): every point takes the
/// cluster of least cost among its own and its neighbours' on the symmetrised
/// k-NN graph, every cluster holds its seed and is connected.
///
/// Computed by synchronous sweeps, so the labels are the same for any thread
/// count: a sweep reads only the labels the sweep before left, and each
/// parallel task writes only its own points.
/// - Seeds take their cluster first and keep it, so no cluster loses its seed.
/// - A point is due in a sweep when a neighbour took a new label in the sweep
///   before, and is offered those labels; in the first sweep of a warm start,
///   the points of `border` are due and offered all their neighbours' labels
///   (a point whose neighbours all share its label has nothing to change).
///   It takes the cheapest if cheaper than its own (ties to the lower label).
///   Every label a neighbour ever holds is thus offered once, and each change
///   lowers the point's `(cost, label)`, so the sweeps end.
/// - A point may then be cut off from its seed (the neighbours it was reached
///   through moved on): [`connect`] finds such points and grows them again.
/// - `border` ends marking every point with a neighbour of another cluster
///   (and maybe others): each point's last look at its neighbours comes after
///   their last change.
///
/// Memory: [`partition_bytes`] of scratch.
#[allow(clippy::too_many_arguments)]
pub(crate) fn partition(
    s: &Scratch,
    ctx: &Ctx,
    generators: &[V3],
    seeds: &[u32],
    labels: &mut [u32],
    border: &mut [u8],
    start: Start,
    hooks: &dyn Progress,
) -> Result<()> {
    numbered(
        s,
        ctx,
        generators,
        seeds,
        labels,
        border,
        start,
        hooks,
        u16::MAX - 1,
    )
}

/// [`partition`], numbering the sweeps again from [`FIRST`] after sweep `last`
/// (tests number them again often: the labels must not change).
#[allow(clippy::too_many_arguments)]
// Never inlined: its frame (sweep state, closures) would otherwise land in
// its callers' frames on the region-growing path too, which on the Cortex-M4F
// firmware (16 KiB of stack) took stack use from 15,324 to 19,696 bytes.
#[inline(never)]
fn numbered(
    s: &Scratch,
    ctx: &Ctx,
    generators: &[V3],
    seeds: &[u32],
    labels: &mut [u32],
    border: &mut [u8],
    start: Start,
    hooks: &dyn Progress,
    last: u16,
) -> Result<()> {
    let n = labels.len();
    let m = generators.len();
    let blocks = n.div_ceil(BLOCK);
    // Room for whole blocks, so that tasks own whole blocks.
    let next = s.try_alloc_slice(blocks * BLOCK, UNLABELLED)?;
    // Stamps: the sweep a point last took a new label in (its neighbours are
    // offered it in the next one), and the sweep a point, or a block of
    // points, is due in. A sweep compares them with its own number, so they
    // never need clearing. Those of odd and even sweeps are apart: a sweep
    // marks what is due in the next while it reads what is due in itself.
    let changed_at = atomic_u16s(s.try_alloc_slice::<u16>(n, 0)?);
    let due_at = [
        atomic_u16s(s.try_alloc_slice::<u16>(n, 0)?),
        atomic_u16s(s.try_alloc_slice::<u16>(n, 0)?),
    ];
    let block_due_at = [
        atomic_u16s(s.try_alloc_slice::<u16>(blocks, 0)?),
        atomic_u16s(s.try_alloc_slice::<u16>(blocks, 0)?),
    ];
    // Clusters that lost a point: only those can have been cut in two.
    let lost = atomic_bytes(s.try_alloc_slice::<u8>(m, 0)?);
    let border = atomic_bytes(border);
    let pinned = |p: usize, l: u32| seeds.get(l as usize) == Some(&(p as u32));
    let mark_due = |p: usize, t: u16| {
        due_at[usize::from(t % 2)][p].store(t, Relaxed);
        block_due_at[usize::from(t % 2)][p / BLOCK].store(t, Relaxed);
    };
    match start {
        Start::Fresh => labels.fill(NONE),
        Start::Warm => {
            for (l, b) in labels.iter_mut().zip(border) {
                if *l as usize >= m {
                    *l = NONE;
                    b.store(1, Relaxed);
                }
            }
        }
    }
    for (j, &sd) in seeds.iter().enumerate() {
        let Some(l) = labels.get_mut(sd as usize) else {
            continue;
        };
        if *l != j as u32 {
            if let Some(was) = lost.get(*l as usize) {
                was.store(1, Relaxed);
            }
            *l = j as u32;
            for row in ctx.nb.rows(sd as usize) {
                for &q in row {
                    border[q as usize].store(1, Relaxed);
                }
            }
        }
        border[sd as usize].store(1, Relaxed);
    }
    let warm = start == Start::Warm;
    let read = &*labels;
    parallel::rows(hooks, next, BLOCK, |items, rows: &mut [Next]| {
        for (p, nx) in (items.start * BLOCK..n).zip(rows.iter_mut()) {
            let l = read[p];
            if (l as usize) < m {
                // Costed when first needed.
                *nx = Next {
                    label: l,
                    cost: f32::NAN,
                };
            }
            if warm || pinned(p, l) {
                changed_at[p].store(FIRST - 1, Relaxed);
            }
            if warm && border[p].load(Relaxed) != 0 {
                mark_due(p, FIRST);
            }
        }
    });
    if !warm {
        for &sd in seeds {
            for row in ctx.nb.rows(sd as usize) {
                for &q in row {
                    mark_due(q as usize, FIRST);
                }
            }
        }
    }
    let labels = atomic_u32s(labels);
    let mut t = FIRST;
    loop {
        let (due_now, block_due_now) =
            (due_at[usize::from(t % 2)], block_due_at[usize::from(t % 2)]);
        let changes = parallel::rows(hooks, next, BLOCK, |items, rows: &mut [Next]| {
            let mut changes = 0u32;
            for (b, rows) in items.zip(rows.chunks_mut(BLOCK)) {
                if block_due_now[b].load(Relaxed) != t {
                    continue;
                }
                for (p, nx) in (b * BLOCK..n).zip(rows.iter_mut()) {
                    if due_now[p].load(Relaxed) != t {
                        continue;
                    }
                    let own = labels[p].load(Relaxed);
                    if pinned(p, own) {
                        continue;
                    }
                    if nx.cost.is_nan() {
                        nx.cost = generators
                            .get(nx.label as usize)
                            .map_or(f32::INFINITY, |&g| ctx.cost(p, g));
                    }
                    let mut best = *nx;
                    // Whether a neighbour is of another cluster.
                    let mut mixed = false;
                    // The labels costed so far (most neighbours share a few).
                    let mut tried = [NONE; 4];
                    for row in ctx.nb.rows(p) {
                        for &q in row {
                            let q = q as usize;
                            let c = labels[q].load(Relaxed);
                            mixed |= c != own;
                            if c == own
                                || changed_at[q].load(Relaxed) != t - 1
                                || tried.contains(&c)
                            {
                                continue;
                            }
                            tried.rotate_right(1);
                            tried[0] = c;
                            let Some(&g) = generators.get(c as usize) else {
                                continue;
                            };
                            if best.beaten_by(ctx.cost_floor(p, g), c) {
                                let e = ctx.cost(p, g);
                                if best.beaten_by(e, c) {
                                    best = Next { label: c, cost: e };
                                }
                            }
                        }
                    }
                    if best.label != own {
                        if let Some(was) = lost.get(own as usize) {
                            was.store(1, Relaxed);
                        }
                        *nx = best;
                        for row in ctx.nb.rows(p) {
                            for &q in row {
                                mark_due(q as usize, t + 1);
                            }
                        }
                        changes += 1;
                        mixed = true;
                    }
                    border[p].store(u8::from(mixed), Relaxed);
                }
            }
            changes
        });
        // The new labels, in the blocks that were due (a point changed when
        // its next label is not its label).
        let read_next = &*next;
        parallel::ranges(hooks, blocks, |items| {
            for b in items.filter(|&b| block_due_now[b].load(Relaxed) == t) {
                for (p, nx) in (b * BLOCK..n).zip(&read_next[b * BLOCK..(b + 1) * BLOCK]) {
                    if nx.label != labels[p].load(Relaxed) {
                        labels[p].store(nx.label, Relaxed);
                        changed_at[p].store(t, Relaxed);
                    }
                }
            }
        });
        if changes.iter().all(|&c| c == 0) {
            break;
        }
        if t >= last {
            // Out of numbers (a pass takes tens of sweeps): number again from
            // FIRST, carrying over the last sweep's changes and what is due
            // next.
            let renumber = |a: &AtomicU16, from: u16, to: u16| {
                a.store(if a.load(Relaxed) == from { to } else { 0 }, Relaxed);
            };
            changed_at.iter().for_each(|a| renumber(a, t, FIRST - 1));
            // Sweep t + 1 goes on as FIRST: its marks move over (to the
            // other parity when the two differ).
            let (from, to) = (usize::from((t + 1) % 2), usize::from(FIRST % 2));
            let carry = |marks: &[&[AtomicU16]; 2], i: usize| {
                let due = marks[from][i].load(Relaxed) == t + 1;
                marks[from][i].store(0, Relaxed);
                marks[1 - from][i].store(0, Relaxed);
                marks[to][i].store(if due { FIRST } else { 0 }, Relaxed);
            };
            (0..n).for_each(|p| carry(&due_at, p));
            (0..blocks).for_each(|b| carry(&block_due_at, b));
            t = FIRST;
        } else {
            t += 1;
        }
    }
    let labels = plain_u32s(labels);
    let reached = atomic_bytes(s.try_alloc_slice::<u8>(n, 0)?);
    connect(
        s,
        ctx,
        generators,
        seeds,
        labels,
        &mut next[..n],
        reached,
        lost,
        border,
        hooks,
    )
}

/// Makes every cluster connected (see [`partition`]), marking the points it
/// moves and their neighbours in `border`: marks in `reached` (all
/// 0 on entry, and on return) the points a search from their seed within
/// their cluster reaches, for the clusters `lost` marks (the others only ever
/// grew, each point from a neighbour that kept the label), unlabels the
/// points not reached, and grows those again, each keeping the cheapest label
/// its labelled neighbours offer.
#[allow(clippy::too_many_arguments)]
fn connect(
    s: &Scratch,
    ctx: &Ctx,
    generators: &[V3],
    seeds: &[u32],
    labels: &mut [u32],
    next: &mut [Next],
    reached: &[AtomicU8],
    lost: &[AtomicU8],
    border: &[AtomicU8],
    hooks: &dyn Progress,
) -> Result<()> {
    let m = generators.len();
    let lost = |l: u32| lost.get(l as usize).is_some_and(|f| f.load(Relaxed) != 0);
    if !(0..m as u32).any(lost) {
        return Ok(());
    }
    // Cluster j's search queue is queue[start[j]..start[j + 1]]: its members'
    // count.
    let start = s.try_alloc_slice::<u32>(m + 1, 0)?;
    for &l in labels.iter() {
        if let Some(c) = start.get_mut(l as usize + 1).filter(|_| lost(l)) {
            *c += 1;
        }
    }
    for j in 0..m {
        start[j + 1] += start[j];
    }
    let queue = s.try_alloc_slice::<u32>(start[m] as usize, 0)?;
    let read = &*labels;
    let begin = |j: usize| start[j] as usize;
    parallel::segments(hooks, queue, m, begin, |clusters, part: &mut [u32]| {
        let mut at = 0;
        for j in clusters {
            let size = (start[j + 1] - start[j]) as usize;
            let Some(queue) = part.get_mut(at..at + size) else {
                break;
            };
            at += size;
            let sd = seeds[j] as usize;
            if size == 0 || !lost(j as u32) || read.get(sd) != Some(&(j as u32)) {
                continue;
            }
            queue[0] = sd as u32;
            reached[sd].store(1, Relaxed);
            let (mut head, mut tail) = (0, 1);
            while head < tail {
                let p = queue[head] as usize;
                head += 1;
                for row in ctx.nb.rows(p) {
                    for &q in row {
                        let qi = q as usize;
                        if read[qi] == j as u32 && reached[qi].load(Relaxed) == 0 && tail < size {
                            reached[qi].store(1, Relaxed);
                            queue[tail] = q;
                            tail += 1;
                        }
                    }
                }
            }
        }
    });
    let cut = parallel::rows(hooks, labels, 1, |items, rows: &mut [u32]| {
        let mut cut = 0usize;
        for (p, l) in items.zip(rows.iter_mut()) {
            if reached[p].load(Relaxed) == 0 && lost(*l) {
                cut += 1;
                *l = NONE;
            }
            reached[p].store(0, Relaxed);
        }
        cut
    });
    let mut left: usize = cut.iter().sum();
    while left > 0 {
        let read = &*labels;
        let grown = parallel::rows(hooks, next, 1, |items, rows: &mut [Next]| {
            let mut grown = 0usize;
            for (p, nx) in items.zip(rows.iter_mut()) {
                if read[p] != NONE {
                    continue;
                }
                let mut best = UNLABELLED;
                for row in ctx.nb.rows(p) {
                    for &q in row {
                        let c = read[q as usize];
                        let Some(&g) = generators.get(c as usize).filter(|_| c != best.label)
                        else {
                            continue;
                        };
                        let e = ctx.cost(p, g);
                        if best.label == NONE || best.beaten_by(e, c) {
                            best = Next { label: c, cost: e };
                        }
                    }
                }
                if best.label != NONE {
                    *nx = best;
                    reached[p].store(1, Relaxed);
                    border[p].store(1, Relaxed);
                    for row in ctx.nb.rows(p) {
                        for &q in row {
                            border[q as usize].store(1, Relaxed);
                        }
                    }
                    grown += 1;
                }
            }
            grown
        });
        let next = &*next;
        parallel::rows(hooks, labels, 1, |items, rows: &mut [u32]| {
            for (p, l) in items.zip(rows.iter_mut()) {
                if reached[p].load(Relaxed) != 0 {
                    *l = next[p].label;
                    reached[p].store(0, Relaxed);
                }
            }
        });
        let grown: usize = grown.iter().sum();
        if grown == 0 {
            // Points in no seed's component (none: every component holds
            // one) keep NONE.
            break;
        }
        left = left.saturating_sub(grown);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arena::Arena;
    use crate::clustering::knn::try_neighbours_in;
    use crate::clustering::quadric::try_planes_with;
    use crate::parallel::Task;
    use crate::params::Params;
    use crate::progress::Backwards;
    use crate::progress::{Flow, Silent, Stage};
    use crate::rng::Rng;
    use crate::sample::{fill, Shape};
    use core::mem::MaybeUninit;
    use std::vec;
    use std::vec::Vec;

    /// Runs the tasks on three threads at once.
    struct Threads;
    impl Progress for Threads {
        fn report(&mut self, _: Stage, _: u64, _: u64) -> Flow {
            Flow::Continue
        }
        fn run(&self, tasks: &mut [&mut dyn Task]) {
            let chunk = tasks.len().div_ceil(3).max(1);
            std::thread::scope(|s| {
                for part in tasks.chunks_mut(chunk) {
                    s.spawn(move || part.iter_mut().for_each(|t| t.run()));
                }
            });
        }
    }

    /// A fresh partition, then a warm one after every generator moved: the
    /// labels do not depend on the order or the threads the tasks run on,
    /// every point is labelled, every seed keeps its cluster, every cluster
    /// is connected, and every point with a neighbour of another cluster is
    /// flagged on the border.
    #[test]
    fn sweeps_give_the_same_connected_clusters_in_any_task_order() {
        sweeps_in_any_task_order(true);
        // Costed from the planes alone, with the one-plane floor, as the
        // largest clouds are.
        sweeps_in_any_task_order(false);
    }

    fn sweeps_in_any_task_order(local: bool) {
        let mut buf = vec![MaybeUninit::uninit(); 16 * 1024 * 1024];
        let arena = Arena::new(&mut buf);
        let mut points = vec![[0.0f32; 3]; 6000];
        fill(Shape::Torus, 3, 0.0, &mut points);
        let params = Params::default();
        let nb = try_neighbours_in(&arena, &points, params.k, &mut Silent).unwrap();
        let planes = try_planes_with(&arena, &points, None, &nb, local, &mut Silent).unwrap();
        let ctx = Ctx::new(&points, &nb, &planes, &params);
        let n = points.len();
        let mut rng = Rng::new(5);
        let seeds: Vec<u32> = {
            let mut all: Vec<u32> = (0..n as u32).collect();
            for i in 0..120 {
                let j = i + rng.below((n - i) as u32) as usize;
                all.swap(i, j);
            }
            all[..120].to_vec()
        };
        let generators: Vec<V3> = seeds.iter().map(|&s| points[s as usize]).collect();
        let moved: Vec<V3> = generators
            .iter()
            .map(|g| [g[0] + 0.01, g[1] - 0.005, g[2]])
            .collect();
        // One partition of `labels` (with `border`) by `generators`.
        let part = |generators: &[V3],
                    labels: &mut Vec<u32>,
                    border: &mut Vec<u8>,
                    start: Start,
                    hooks: &dyn Progress,
                    last: u16| {
            arena
                .scratch(|s| {
                    numbered(
                        s, &ctx, generators, &seeds, labels, border, start, hooks, last,
                    )
                })
                .unwrap();
        };
        let run = |hooks: &dyn Progress| {
            let (mut labels, mut border) = (vec![NONE; n], vec![1u8; n]);
            part(
                &generators,
                &mut labels,
                &mut border,
                Start::Fresh,
                hooks,
                u16::MAX - 1,
            );
            let fresh = (labels.clone(), border.clone());
            part(
                &moved,
                &mut labels,
                &mut border,
                Start::Warm,
                hooks,
                u16::MAX - 1,
            );
            (fresh, (labels, border))
        };
        let (fresh, warm) = run(&Silent);
        // Numbered again every few sweeps (odd and even wraps): the same.
        for last in [5u16, 6] {
            let (mut labels, mut border) = (vec![NONE; n], vec![1u8; n]);
            part(
                &generators,
                &mut labels,
                &mut border,
                Start::Fresh,
                &Silent,
                last,
            );
            assert_eq!(labels, fresh.0, "numbered again after sweep {last}");
        }
        assert_eq!(run(&Backwards), (fresh.clone(), warm.clone()));
        assert_eq!(run(&Threads), (fresh.clone(), warm.clone()));
        assert_ne!(fresh, warm, "moving every generator changed nothing");
        for (labels, border) in [&fresh, &warm] {
            assert!(labels.iter().all(|&l| (l as usize) < seeds.len()));
            for (j, &sd) in seeds.iter().enumerate() {
                assert_eq!(labels[sd as usize], j as u32);
                // A search from the seed within the cluster reaches all of it.
                let mut seen = vec![false; n];
                let mut stack = vec![sd as usize];
                seen[sd as usize] = true;
                let mut reached = 0;
                while let Some(p) = stack.pop() {
                    reached += 1;
                    for q in nb.symmetric(p) {
                        let q = q as usize;
                        if !seen[q] && labels[q] == j as u32 {
                            seen[q] = true;
                            stack.push(q);
                        }
                    }
                }
                let size = labels.iter().filter(|&&l| l == j as u32).count();
                assert_eq!(reached, size, "cluster {j} in pieces");
            }
            for p in 0..n {
                if nb.symmetric(p).any(|q| labels[q as usize] != labels[p]) {
                    assert_eq!(border[p], 1, "point {p} on a border, not flagged");
                }
            }
        }
    }
}
