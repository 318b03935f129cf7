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

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn out_of_range_indices_are_their_own_roots_and_join_nothing() {
        let mut buf = [0u32; 3];
        let mut uf = UnionFind::new(&mut buf);
        assert_eq!(uf.find(9), 9);
        assert!(!uf.union(1, 9));
        assert_eq!(uf.into_roots(), &[0, 1, 2]);
    }
}
