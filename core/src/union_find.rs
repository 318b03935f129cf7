//! The one union-find of the crate (clean's fragments, clustering's components,
//! merged generators, the mesh's corner fans), over a caller-owned slice of
//! parent indices: 4 bytes per element, nothing else.
//!
//! Every set's root is its lowest index, whatever order the unions come in, so
//! roots are deterministic and double as a canonical representative. `find`
//! halves the path it walks; a union costs two finds. Over `n` elements and `m`
//! operations the cost is O((n + m) log n) at worst, near-linear in practice.

use crate::arena::Alloc;
use crate::error::Result;
use crate::parallel::Task;
use crate::progress::Progress;

/// Most parts [`roots_of_links`] cuts its elements into (one a thread).
const MAX_PARTS: usize = 8;
/// Fewest elements a part of [`roots_of_links`]; fewer are joined as one.
const MIN_PART: usize = 4096;

/// Disjoint sets over `0..len()`, in a borrowed slice of parent indices.
///
/// Invariant: every entry of the slice is an index into it, and following
/// parents from any element reaches a root (an element that is its own parent)
/// no larger than any element of its set.
#[derive(Debug)]
pub struct UnionFind<'a> {
    parent: &'a mut [u32],
}

impl<'a> UnionFind<'a> {
    /// Singletons `0..parent.len()` in `parent` (overwritten). `parent.len()`
    /// must not exceed `u32::MAX`; entries past it are never reached.
    pub fn new(parent: &'a mut [u32]) -> Self {
        for (i, p) in parent.iter_mut().enumerate() {
            *p = i as u32;
        }
        UnionFind { parent }
    }

    /// The sets whose roots `roots` holds ([`UnionFind::into_roots`]'s
    /// result: entry `i` its set's lowest element).
    pub fn from_roots(roots: &'a mut [u32]) -> Self {
        UnionFind { parent: roots }
    }

    /// Singletons `0..n` in a slice from `arena`.
    pub fn try_new_in<'b, A: Alloc<'b>>(arena: &'a A, n: usize) -> Result<Self> {
        Ok(Self::new(arena.try_alloc_slice::<u32>(n, 0)?))
    }

    /// Elements.
    pub fn len(&self) -> usize {
        self.parent.len()
    }

    /// Whether there are no elements.
    pub fn is_empty(&self) -> bool {
        self.parent.is_empty()
    }

    /// The root of `i`'s set: its lowest element. Halves the path on the way.
    /// An index out of range is its own root.
    pub fn find(&mut self, mut i: u32) -> u32 {
        while let Some(&p) = self.parent.get(i as usize) {
            if p == i {
                break;
            }
            let grand = self.parent.get(p as usize).copied().unwrap_or(p);
            self.parent[i as usize] = grand;
            i = grand;
        }
        i
    }

    /// Joins the sets of `a` and `b` under the lower root. Returns whether they
    /// were apart. Indices out of range are ignored.
    pub fn union(&mut self, a: u32, b: u32) -> bool {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra == rb || ra as usize >= self.parent.len() || rb as usize >= self.parent.len() {
            return false;
        }
        self.parent[ra.max(rb) as usize] = ra.min(rb);
        true
    }

    /// Joins `a`'s set with the set of each of `others`: the sets
    /// [`union`](Self::union) would make one pair at a time, with `a`'s root
    /// found once instead of once a pair. Indices out of range are ignored.
    pub fn union_all(&mut self, a: u32, others: impl IntoIterator<Item = u32>) {
        let mut root = self.find(a);
        if root as usize >= self.parent.len() {
            return;
        }
        for b in others {
            let other = self.find(b);
            if other != root && (other as usize) < self.parent.len() {
                self.parent[root.max(other) as usize] = root.min(other);
                root = root.min(other);
            }
        }
    }

    /// Every element's root, in place: entry `i` of the result is `find(i)`.
    pub fn into_roots(mut self) -> &'a mut [u32] {
        for i in 0..self.parent.len() {
            let r = self.find(i as u32);
            self.parent[i] = r;
        }
        self.parent
    }
}

/// Every element's root (its set's lowest element) once each `i` of
/// `0..parent.len()` is joined with each `j` of `row(i)` for which
/// `linked(i, j)` (indices out of range ignored), in `parent` (overwritten):
/// what [`UnionFind::union_all`] of each `i` with its linked row, in order,
/// then [`UnionFind::into_roots`] give. With two threads or more in `hooks`
/// and at least 4,096 elements a thread, the elements are cut into
/// contiguous parts, one a thread: each part's task joins the links within it
/// in its own part of `parent` and flags the elements with a link leaving
/// the part, then the calling thread joins those elements' links between
/// parts (a pass over the flags, not over every link). The sets are the same
/// whatever the cut, and so are their lowest elements. O(n + links) time, no
/// memory but `parent`.
pub fn roots_of_links<'a, 'r, R, L>(
    hooks: &dyn Progress,
    parent: &'a mut [u32],
    row: R,
    linked: L,
) -> &'a mut [u32]
where
    R: Fn(usize) -> &'r [u32] + Sync,
    L: Fn(usize, u32) -> bool + Sync,
{
    let n = parent.len();
    // (Parts only below 2^31 elements: the join across them flags entries.)
    let parts = if n < ACROSS as usize {
        parts_of(hooks, n)
    } else {
        1
    };
    let per = n.div_ceil(parts);
    let part_of = |i: usize| {
        let start = i / per * per;
        start..(start + per).min(n)
    };
    if parts >= 2 {
        let mut rest = &mut *parent;
        let (row, linked) = (&row, &linked);
        let mut jobs: [Part<R, L>; MAX_PARTS] = core::array::from_fn(|t| {
            let start = (t * per).min(n);
            let len = per.min(n - start);
            let (part, tail) = core::mem::take(&mut rest).split_at_mut(len);
            rest = tail;
            Part {
                row,
                linked,
                start,
                parent: part,
            }
        });
        let mut tasks = jobs.each_mut().map(|j| j as &mut dyn Task);
        hooks.run(&mut tasks[..parts]);
    } else {
        UnionFind::new(&mut *parent);
    }
    // Every tree lies in one part now (all of them when there is one): join
    // the links that leave their element's part, found by the parts' tasks
    // ([`ACROSS`]) when parts were cut.
    if parts < 2 {
        let mut sets = UnionFind { parent };
        for i in 0..n {
            sets.union_all(i as u32, row(i).iter().copied().filter(|&j| linked(i, j)));
        }
        return sets.into_roots();
    }
    for i in 0..n {
        if parent[i] & ACROSS == 0 {
            continue;
        }
        parent[i] &= !ACROSS;
        let own = part_of(i);
        for &j in row(i) {
            if !own.contains(&(j as usize)) && linked(i, j) {
                join_flagged(parent, i as u32, j);
            }
        }
    }
    UnionFind { parent }.into_roots()
}

/// The flag on an element's parent entry, after the parts' tasks of
/// [`roots_of_links`], when it has a link leaving its part.
const ACROSS: u32 = 1 << 31;

/// [`UnionFind::union`] over parent entries some of which carry [`ACROSS`]
/// (each keeps its flag; indices out of range are ignored).
fn join_flagged(parent: &mut [u32], a: u32, b: u32) {
    let mut find = |mut x: u32| {
        while let Some(&e) = parent.get(x as usize) {
            let p = e & !ACROSS;
            if p == x {
                break;
            }
            let grand = parent.get(p as usize).map_or(p, |&g| g & !ACROSS);
            parent[x as usize] = grand | (e & ACROSS);
            x = grand;
        }
        x
    };
    let (ra, rb) = (find(a), find(b));
    let (lo, hi) = (ra.min(rb) as usize, ra.max(rb) as usize);
    if lo != hi && hi < parent.len() {
        parent[hi] = lo as u32 | (parent[hi] & ACROSS);
    }
}

/// The contiguous parts a union-find pass over `n` items is cut into: one
/// a thread of `hooks`, at most [`MAX_PARTS`], each at least [`MIN_PART`]
/// items; 1 when they are fewer.
pub(crate) fn parts_of(hooks: &dyn Progress, n: usize) -> usize {
    hooks.threads().min(MAX_PARTS).min(n / MIN_PART).max(1)
}

/// One part of [`roots_of_links`]: the elements `start..start + parent.len()`
/// joined by their links within the part, each left holding its root.
struct Part<'p, R, L> {
    row: &'p R,
    linked: &'p L,
    start: usize,
    parent: &'p mut [u32],
}

impl<'p, 'r, R, L> Task for Part<'p, R, L>
where
    R: Fn(usize) -> &'r [u32] + Sync,
    L: Fn(usize, u32) -> bool + Sync,
{
    fn run(&mut self) {
        let (start, len) = (self.start, self.parent.len());
        let mut sets = UnionFind::new(self.parent);
        for i in start..start + len {
            let within = (self.row)(i)
                .iter()
                .filter_map(|&j| (j as usize).checked_sub(start).map(|d| (j, d)))
                .filter(|&(j, d)| d < len && (self.linked)(i, j))
                .map(|(_, d)| d as u32);
            sets.union_all((i - start) as u32, within);
        }
        // Local roots are the parts' lowest elements, so global ones too;
        // an element with a link leaving the part is flagged for the join
        // across parts ([`ACROSS`]).
        let roots = sets.into_roots();
        for (i, r) in (start..).zip(roots.iter_mut()) {
            *r += start as u32;
            let out = |&j: &u32| !(start..start + len).contains(&(j as usize));
            if (self.row)(i).iter().any(|j| out(j) && (self.linked)(i, *j)) {
                *r |= ACROSS;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Claimed;

    #[test]
    fn roots_are_the_lowest_element_whatever_the_union_order() {
        let mut buf = [0u32; 8];
        let mut uf = UnionFind::new(&mut buf);
        assert!(uf.union(7, 5));
        assert!(uf.union(5, 3));
        assert!(!uf.union(3, 7));
        assert!(uf.union(6, 1));
        assert_eq!(uf.find(7), 3);
        assert_eq!(uf.find(6), 1);
        assert!(uf.union(7, 6));
        let roots = uf.into_roots();
        assert_eq!(roots, &[0, 1, 2, 1, 4, 1, 1, 1]);
    }

    /// `union_all` makes the sets and roots of one `union` a pair, on random
    /// graphs, out-of-range indices among them.
    #[test]
    fn union_all_gives_the_roots_of_pairwise_unions() {
        let mut x = 99u64;
        let mut next = |n: u64| {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 33) % n
        };
        for _ in 0..50 {
            let n = 1 + next(60) as usize;
            let rows: std::vec::Vec<(u32, [u32; 3])> = (0..next(80))
                .map(|_| {
                    (
                        next(n as u64 + 2) as u32,
                        [0; 3].map(|_| next(n as u64 + 2) as u32),
                    )
                })
                .collect();
            let (mut a, mut b) = (std::vec![0u32; n], std::vec![0u32; n]);
            let (mut pairs, mut all) = (UnionFind::new(&mut a), UnionFind::new(&mut b));
            for &(i, row) in &rows {
                for j in row {
                    pairs.union(i, j);
                }
                all.union_all(i, row);
            }
            assert_eq!(pairs.into_roots(), all.into_roots());
        }
    }

    /// Cut into parts or not, `roots_of_links` gives the roots of `union_all`
    /// a row at a time: on graphs of mostly near links (most inside a part)
    /// with far ones and out-of-range ones among them, a predicate dropping
    /// some, and a chain that only links between parts join into one set.
    #[test]
    fn roots_of_links_are_those_of_joining_one_row_at_a_time() {
        let mut rng = crate::rng::Rng::new(7);
        let mut next = |n: u64| rng.next_u64() % n;
        for (n, k) in [(10usize, 3usize), (9000, 2), (20_000, 3), (33_333, 1)] {
            let rows: std::vec::Vec<u32> = (0..n * k)
                .map(|e| match next(20) {
                    0 => next(n as u64 + 5) as u32,
                    1 => ((e / k + n / 3) % n) as u32,
                    _ => ((e / k) as u64 + 1 + next(3)) as u32,
                })
                .collect();
            let row = |i: usize| &rows[i * k..(i + 1) * k];
            let linked = |i: usize, j: u32| (i as u32 ^ j) % 7 != 3;
            let mut want = std::vec![0u32; n];
            let mut sets = UnionFind::new(&mut want);
            for i in 0..n {
                sets.union_all(i as u32, row(i).iter().copied().filter(|&j| linked(i, j)));
            }
            let want = sets.into_roots();
            let sets_count = want
                .iter()
                .enumerate()
                .filter(|&(i, &r)| r == i as u32)
                .count();
            // The large graphs (cut into parts) hold several sets, not one
            // and not all singletons.
            assert!(
                n < 100 || (sets_count > 1 && sets_count < n),
                "n {n}: {sets_count} sets"
            );
            for threads in [1, 2, 3, 8] {
                let mut got = std::vec![5u32; n];
                let got = roots_of_links(&Claimed::backwards(threads), &mut got, row, linked);
                assert_eq!(got, &*want, "n {n}, {threads} threads");
            }
        }
        // A chain whose links all run from one part to the next.
        let n = 4 * MIN_PART;
        let across: std::vec::Vec<u32> = (0..n as u32)
            .map(|i| (i + MIN_PART as u32) % n as u32)
            .collect();
        let mut got = std::vec![0u32; n];
        let roots = roots_of_links(
            &Claimed::backwards(4),
            &mut got,
            |i| &across[i..i + 1],
            |_, _| true,
        );
        let mut want = std::vec![0u32; n];
        for (i, w) in want.iter_mut().enumerate() {
            *w = (i % MIN_PART) as u32;
        }
        assert_eq!(roots, &*want);
    }

    #[test]
    fn out_of_range_indices_are_their_own_roots_and_join_nothing() {
        let mut buf = [0u32; 3];
        let mut uf = UnionFind::new(&mut buf);
        assert_eq!(uf.find(9), 9);
        assert!(!uf.union(1, 9));
        assert_eq!(uf.into_roots(), &[0, 1, 2]);
    }
}
