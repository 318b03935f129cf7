//! Work that the caller may spread over threads, with results that do not
//! depend on how it does.
//!
//! Core has no threads. A stage whose work splits into independent parts cuts
//! it into exactly [`TASKS`] tasks, whatever the machine: contiguous ranges of
//! its items, each task writing only its own part of the output and returning
//! its own partial result. The caller's [`Progress::run`] runs the tasks on
//! whatever threads it has (the default runs them one after another); core
//! then combines the partial results in task order. The cut depends only on
//! the item count, so every sum is taken in the same order and the output is
//! bit-identical for every thread count.
//!
//! Cost: two arrays of [`TASKS`] small entries on the stack per call; no arena
//! memory.

use crate::error::Result;
use crate::progress::{tick, Progress, Stage};
use core::ops::Range;

/// Items per wave of a long parallel stage: progress is reported, and a cancel
/// request honoured, between waves.
pub const WAVE: usize = 1 << 16;

/// Tasks a parallel stage is cut into, for any input and thread count.
pub const TASKS: usize = 64;

/// One task of a parallel stage. [`Progress::run`] calls [`Task::run`] of each
/// task exactly once, from any thread.
pub trait Task: Send {
    /// Do the work.
    fn run(&mut self);
}

/// The items of task `t` of [`TASKS`] over `n` items: contiguous, in order,
/// together covering `0..n`.
pub fn range(n: usize, t: usize) -> Range<usize> {
    let per = n.div_ceil(TASKS);
    let start = per.saturating_mul(t).min(n);
    start..per.saturating_mul(t + 1).min(n)
}

/// A task over a range of items and the rows of the output that belong to them.
struct Rows<'a, T, R, F> {
    f: &'a F,
    items: Range<usize>,
    rows: &'a mut [T],
    result: R,
}

impl<T: Send, R: Send, F: Fn(Range<usize>, &mut [T]) -> R + Sync> Task for Rows<'_, T, R, F> {
    fn run(&mut self) {
        self.result = (self.f)(self.items.clone(), self.rows);
    }
}

/// Runs `f(items, rows)` over [`TASKS`] contiguous ranges of the `out.len() /
/// width` items of `out`, where item `i` owns `out[i * width..(i + 1) * width]`
/// and `rows` is the part of `out` owned by `items`. Returns each task's
/// result, in task order. `width` 0 is taken as 1.
pub fn rows<T, R, F>(hooks: &dyn Progress, out: &mut [T], width: usize, f: F) -> [R; TASKS]
where
    T: Send,
    R: Send + Default,
    F: Fn(Range<usize>, &mut [T]) -> R + Sync,
{
    let width = width.max(1);
    let n = out.len() / width;
    let mut rest = out;
    let mut jobs: [Rows<T, R, F>; TASKS] = core::array::from_fn(|t| {
        let items = range(n, t);
        let (rows, tail) = core::mem::take(&mut rest).split_at_mut(items.len() * width);
        rest = tail;
        Rows {
            f: &f,
            items,
            rows,
            result: R::default(),
        }
    });
    let mut tasks = jobs.each_mut().map(|j| j as &mut dyn Task);
    hooks.run(&mut tasks);
    jobs.map(|j| j.result)
}

/// A task over a range of items and their entries in two outputs.
struct Pairs<'a, A, B, R, F> {
    f: &'a F,
    items: Range<usize>,
    a: &'a mut [A],
    b: &'a mut [B],
    result: R,
}

impl<A: Send, B: Send, R: Send, F: Fn(Range<usize>, &mut [A], &mut [B]) -> R + Sync> Task
    for Pairs<'_, A, B, R, F>
{
    fn run(&mut self) {
        self.result = (self.f)(self.items.clone(), self.a, self.b);
    }
}

/// Runs `f(items, a_part, b_part)` over [`TASKS`] contiguous ranges of the
/// items of `a` and `b` (one entry each per item; items beyond the shorter are
/// left out). Returns each task's result, in task order.
pub fn pairs<A, B, R, F>(hooks: &dyn Progress, a: &mut [A], b: &mut [B], f: F) -> [R; TASKS]
where
    A: Send,
    B: Send,
    R: Send + Default,
    F: Fn(Range<usize>, &mut [A], &mut [B]) -> R + Sync,
{
    let n = a.len().min(b.len());
    let (mut rest_a, mut rest_b) = (&mut a[..n], &mut b[..n]);
    let mut jobs: [Pairs<A, B, R, F>; TASKS] = core::array::from_fn(|t| {
        let items = range(n, t);
        let (a, tail_a) = core::mem::take(&mut rest_a).split_at_mut(items.len());
        let (b, tail_b) = core::mem::take(&mut rest_b).split_at_mut(items.len());
        (rest_a, rest_b) = (tail_a, tail_b);
        Pairs {
            f: &f,
            items,
            a,
            b,
            result: R::default(),
        }
    });
    let mut tasks = jobs.each_mut().map(|j| j as &mut dyn Task);
    hooks.run(&mut tasks);
    jobs.map(|j| j.result)
}

/// [`rows`] over waves of [`WAVE`] items, reporting progress of `stage` after
/// each: `f` gets the items' global indices, and `combine` each task's result,
/// in order.
pub(crate) fn rows_in_waves<T, R, F>(
    progress: &mut dyn Progress,
    stage: Stage,
    out: &mut [T],
    width: usize,
    f: F,
    mut combine: impl FnMut(R),
) -> Result<()>
where
    T: Send,
    R: Send + Default,
    F: Fn(Range<usize>, &mut [T]) -> R + Sync,
{
    let width = width.max(1);
    let n = out.len() / width;
    for (w, wave) in out.chunks_mut(WAVE * width).enumerate() {
        let first = w * WAVE;
        let parts = rows(&*progress, wave, width, |items, rows| {
            f(first + items.start..first + items.end, rows)
        });
        parts.into_iter().for_each(&mut combine);
        tick(
            progress,
            stage,
            (first + wave.len() / width) as u64,
            n as u64,
        )?;
    }
    Ok(())
}

/// Runs `f(items)` over [`TASKS`] contiguous ranges of `0..n` and returns each
/// task's result, in task order.
pub fn ranges<R, F>(hooks: &dyn Progress, n: usize, f: F) -> [R; TASKS]
where
    R: Send + Default,
    F: Fn(Range<usize>) -> R + Sync,
{
    let g = |items: Range<usize>, _: &mut [()]| f(items);
    let mut jobs: [Rows<(), R, _>; TASKS] = core::array::from_fn(|t| Rows {
        f: &g,
        items: range(n, t),
        rows: &mut [],
        result: R::default(),
    });
    let mut tasks = jobs.each_mut().map(|j| j as &mut dyn Task);
    hooks.run(&mut tasks);
    jobs.map(|j| j.result)
}

/// Runs `f(items, part)` over [`TASKS`] contiguous ranges of `n` items, where
/// item `j` owns `out[at(j)..at(j + 1)]` (`at` not decreasing; positions past
/// `out`'s end are taken as its end) and `part` is what `items` own, beginning
/// at `out[at(items.start)]`. Returns each task's result, in task order.
pub fn segments<T, R, F>(
    hooks: &dyn Progress,
    out: &mut [T],
    n: usize,
    at: impl Fn(usize) -> usize,
    f: F,
) -> [R; TASKS]
where
    T: Send,
    R: Send + Default,
    F: Fn(Range<usize>, &mut [T]) -> R + Sync,
{
    let len = out.len();
    let mut rest = out;
    let mut taken = 0;
    let mut jobs: [Rows<T, R, F>; TASKS] = core::array::from_fn(|t| {
        let items = range(n, t);
        let end = at(items.end).min(len).max(taken);
        let (rows, tail) = core::mem::take(&mut rest).split_at_mut(end - taken);
        (rest, taken) = (tail, end);
        Rows {
            f: &f,
            items,
            rows,
            result: R::default(),
        }
    });
    let mut tasks = jobs.each_mut().map(|j| j as &mut dyn Task);
    hooks.run(&mut tasks);
    jobs.map(|j| j.result)
}

/// A task over a range of items and the parts of three outputs they own.
struct Triples<'a, A, B, C, R, F> {
    f: &'a F,
    items: Range<usize>,
    a: &'a mut [A],
    b: &'a mut [B],
    c: &'a mut [C],
    result: R,
}

impl<A, B, C, R, F> Task for Triples<'_, A, B, C, R, F>
where
    A: Send,
    B: Send,
    C: Send,
    R: Send,
    F: Fn(Range<usize>, &mut [A], &mut [B], &mut [C]) -> R + Sync,
{
    fn run(&mut self) {
        self.result = (self.f)(self.items.clone(), self.a, self.b, self.c);
    }
}

/// [`segments`] over three outputs: item `j` of `n` owns
/// `a[ab_at(j)..ab_at(j + 1)]`, the same of `b`, and `c[c_at(j)..c_at(j +
/// 1)]`; `f(items, a_part, b_part, c_part)` gets what `items` own, each part
/// beginning at the entry of `items.start`. `ab_at` and `c_at` must not
/// decrease; positions past an output's end are taken as its end. Returns
/// each task's result, in task order.
#[allow(clippy::too_many_arguments)]
pub fn segments3<A, B, C, R, F>(
    hooks: &dyn Progress,
    a: &mut [A],
    b: &mut [B],
    c: &mut [C],
    n: usize,
    ab_at: impl Fn(usize) -> usize,
    c_at: impl Fn(usize) -> usize,
    f: F,
) -> [R; TASKS]
where
    A: Send,
    B: Send,
    C: Send,
    R: Send + Default,
    F: Fn(Range<usize>, &mut [A], &mut [B], &mut [C]) -> R + Sync,
{
    let ab_len = a.len().min(b.len());
    let (mut rest_a, mut rest_b, mut rest_c) = (&mut a[..ab_len], &mut b[..ab_len], c);
    let (mut taken_ab, mut taken_c) = (0, 0);
    let mut jobs: [Triples<A, B, C, R, F>; TASKS] = core::array::from_fn(|t| {
        let items = range(n, t);
        let end_ab = ab_at(items.end).min(ab_len).max(taken_ab);
        let (a, tail_a) = core::mem::take(&mut rest_a).split_at_mut(end_ab - taken_ab);
        let (b, tail_b) = core::mem::take(&mut rest_b).split_at_mut(end_ab - taken_ab);
        let end_c = c_at(items.end).min(taken_c + rest_c.len()).max(taken_c);
        let (c, tail_c) = core::mem::take(&mut rest_c).split_at_mut(end_c - taken_c);
        (rest_a, rest_b, rest_c) = (tail_a, tail_b, tail_c);
        (taken_ab, taken_c) = (end_ab, end_c);
        Triples {
            f: &f,
            items,
            a,
            b,
            c,
            result: R::default(),
        }
    });
    let mut tasks = jobs.each_mut().map(|j| j as &mut dyn Task);
    hooks.run(&mut tasks);
    jobs.map(|j| j.result)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Silent;

    #[test]
    fn ranges_cover_every_item_once_in_order() {
        for n in [0, 1, 5, 63, 64, 65, 1000, 4097] {
            let mut next = 0;
            for t in 0..TASKS {
                let r = range(n, t);
                assert_eq!(r.start, next.min(n), "n {n} task {t}");
                next = r.end.max(next);
            }
            assert_eq!(next, n);
        }
    }

    #[test]
    fn rows_hand_each_task_the_rows_of_its_items() {
        let mut out = [0u32; 3 * 100];
        let sums = rows(&Silent, &mut out, 3, |items, rows: &mut [u32]| {
            assert_eq!(rows.len(), 3 * items.len());
            for (i, row) in items.clone().zip(rows.chunks_mut(3)) {
                row.fill(i as u32);
            }
            items.len()
        });
        assert_eq!(sums.iter().sum::<usize>(), 100);
        for (i, row) in out.chunks(3).enumerate() {
            assert!(row.iter().all(|&v| v == i as u32));
        }
    }

    #[test]
    fn segments3_hand_each_task_the_parts_its_items_own() {
        // Item j owns j % 3 entries of a and b and one of c.
        let n = 200;
        let ab_at = |j: usize| (0..j).map(|i| i % 3).sum::<usize>();
        let mut a = [0u32; 200];
        let mut b = [0u64; 200];
        let mut c = [0u8; 200];
        let len = ab_at(n);
        let counts = segments3(
            &Silent,
            &mut a[..len],
            &mut b[..len],
            &mut c[..n],
            n,
            ab_at,
            |j| j,
            |items, a: &mut [u32], b: &mut [u64], c: &mut [u8]| {
                let base = ab_at(items.start);
                assert_eq!(a.len(), ab_at(items.end) - base);
                assert_eq!(c.len(), items.len());
                for j in items.clone() {
                    for k in ab_at(j)..ab_at(j + 1) {
                        a[k - base] = j as u32;
                        b[k - base] = j as u64;
                    }
                    c[j - items.start] = (j % 251) as u8;
                }
                items.len()
            },
        );
        assert_eq!(counts.iter().sum::<usize>(), n);
        for j in 0..n {
            assert!(a[ab_at(j)..ab_at(j + 1)].iter().all(|&v| v == j as u32));
            assert!(b[ab_at(j)..ab_at(j + 1)].iter().all(|&v| v == j as u64));
            assert_eq!(c[j], (j % 251) as u8);
        }
    }
}
