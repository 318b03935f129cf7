//! Exact duplicates: points read at the same position, bit for bit. A
//! pre-pass before the neighbour search, which they would otherwise defeat:
//! `m` copies of a point are each other's nearest neighbours, so a k-NN query
//! among them finds only distance 0 and its certified search widens over the
//! whole pile (quadratic in `m`); and a pile of copies looks to the fragment
//! filter like a dense piece of the surface.
//!
//! [`mark_duplicates`] marks the first point at each position (in input order)
//! as the one that stays and counts the copies it stands for; the caller
//! compacts the marked points, which keeps their order, so a cloud whose
//! every point is stored several times becomes the cloud stored once.
//!
//! Cost: one sort of `n` indices by their key (`O(n log n)` comparisons, in
//! place, no memory beyond the caller's `order`), then one pass. Deterministic:
//! ties in the key are broken by index, so the order is total.
//! [`mark_duplicates_hashed`] gives the same marks from a sort of integers
//! (a hash of the key and the index), with 8 bytes a point of `order` instead
//! of 4.

use crate::error::{Error, Result};

/// Mark in `first` the first point (lowest index) at each key and return how
/// many points are copies of an earlier one (`first[i] == false`).
///
/// `key` is the position as the caller compares it, e.g. the bit patterns of
/// its coordinates (so that only bitwise-equal points are duplicates). `order`
/// is scratch of one `u32` per point; on return it holds the indices sorted by
/// key. Both must be `points.len()` long ([`Error::KeepLength`] otherwise), and
/// there must be fewer than `u32::MAX` points ([`Error::TooManyPoints`]).
pub fn mark_duplicates<P, K: Ord>(
    points: &[P],
    key: impl Fn(&P) -> K,
    order: &mut [u32],
    first: &mut [bool],
) -> Result<u32> {
    check_lengths(points.len(), order.len(), first.len())?;
    for (i, o) in order.iter_mut().enumerate() {
        *o = i as u32;
    }
    let at = |i: u32| points.get(i as usize).map(&key);
    order.sort_unstable_by(|&a, &b| at(a).cmp(&at(b)).then(a.cmp(&b)));
    Ok(mark_sorted(order.iter().copied(), at, first))
}

/// [`mark_duplicates`] with the points grouped by a hash of their key first:
/// the same marks and count, but the sort compares integers instead of
/// fetching and comparing keys (the bunny's 34,834 points: 11 M instructions
/// instead of 45 M). `hash` must give equal keys equal values
/// ([`f64_bits_hash`] for [`f64_bits`]); `order` is scratch of one `u64` a
/// point. Each point's `hash << 32 | index` is sorted, so a run of equal hashes
/// holds its points in input order; only a run whose keys differ (a
/// collision) is sorted again by key and index, and a point alone in its run
/// is first without a look at its key. On return `order`'s low 32
/// bits hold the indices, each key's points together and in input order.
/// Errors as [`mark_duplicates`].
pub fn mark_duplicates_hashed<P, K: Ord>(
    points: &[P],
    key: impl Fn(&P) -> K,
    hash: impl Fn(&K) -> u32,
    order: &mut [u64],
    first: &mut [bool],
) -> Result<u32> {
    let n = points.len();
    check_lengths(n, order.len(), first.len())?;
    for (i, (o, p)) in order.iter_mut().zip(points).enumerate() {
        *o = (hash(&key(p)) as u64) << 32 | i as u64;
    }
    order.sort_unstable();
    let index = |o: u64| (o & 0xFFFF_FFFF) as u32;
    let at = |o: u64| points.get(index(o) as usize).map(&key);
    let mut copies = 0;
    let mut start = 0;
    while let Some(&head) = order.get(start) {
        let len = order[start..]
            .iter()
            .position(|&o| o >> 32 != head >> 32)
            .unwrap_or(n - start);
        if len == 1 {
            // A hash of its own: the first at its key, without fetching the
            // key (in a large cloud that fetch misses the caches).
            if let Some(f) = first.get_mut(index(head) as usize) {
                *f = true;
            }
            start += 1;
            continue;
        }
        let run = &mut order[start..start + len];
        let k = at(head);
        if run.iter().any(|&o| at(o) != k) {
            // Equal hashes, unequal keys: by key, then by index (the low bits).
            run.sort_unstable_by(|&a, &b| at(a).cmp(&at(b)).then(a.cmp(&b)));
        }
        copies += mark_sorted(
            run.iter().map(|&o| index(o)),
            |i| points.get(i as usize).map(&key),
            first,
        );
        start += len;
    }
    Ok(copies)
}

/// The checks of [`mark_duplicates`]: `order` and `first` one entry a point,
/// and point indices that fit a `u32`.
fn check_lengths(n: usize, order: usize, first: usize) -> Result<()> {
    if order != n || first != n {
        return Err(Error::KeepLength {
            points: n,
            keep: if first != n { first } else { order },
        });
    }
    if u32::try_from(n).is_err() {
        return Err(Error::TooManyPoints {
            found: n,
            max: u32::MAX as usize,
        });
    }
    Ok(())
}

/// Mark in `first` the first of each run of equal keys in `sorted` (indices
/// grouped by key, each group in input order) and return the copies.
fn mark_sorted<K: PartialEq>(
    sorted: impl Iterator<Item = u32>,
    at: impl Fn(u32) -> Option<K>,
    first: &mut [bool],
) -> u32 {
    let mut copies = 0u32;
    let mut last = None;
    for i in sorted {
        let k = at(i);
        let is_first = last.as_ref() != Some(&k);
        if let Some(f) = first.get_mut(i as usize) {
            *f = is_first;
        }
        if is_first {
            last = Some(k);
        } else {
            copies += 1;
        }
    }
    copies
}

/// The key of `mark_duplicates` for `f64` coordinates: their bit patterns,
/// with `-0.0` taken as `0.0` (the same position). NaN never equals a finite
/// value.
pub fn f64_bits(p: &[f64; 3]) -> [u64; 3] {
    p.map(|v| (v + 0.0).to_bits())
}

/// A hash of [`f64_bits`]'s key for [`mark_duplicates_hashed`]: each word
/// mixed in by a multiply and a shift, the high half kept.
pub fn f64_bits_hash(k: &[u64; 3]) -> u32 {
    let mut h = 0u64;
    for &v in k {
        h = (h ^ v).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        h ^= h >> 29;
    }
    (h >> 32) as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec;
    use std::vec::Vec;

    fn marked(points: &[[f64; 3]]) -> (Vec<bool>, u32) {
        let mut order = vec![0u32; points.len()];
        let mut first = vec![false; points.len()];
        let copies = mark_duplicates(points, f64_bits, &mut order, &mut first).unwrap();
        (first, copies)
    }

    #[test]
    fn the_first_copy_of_each_position_stays() {
        let a = [0.5, -1.0, 2.0];
        let b = [0.5, -1.0, 2.000_000_000_000_001];
        let pts = [a, b, a, [0.0, 0.0, 0.0], b, [-0.0, 0.0, -0.0], a];
        let (first, copies) = marked(&pts);
        assert_eq!(first, [true, true, false, true, false, false, false]);
        assert_eq!(copies, 4);
    }

    #[test]
    fn a_cloud_without_copies_keeps_every_point() {
        let pts: Vec<[f64; 3]> = (0..1000)
            .map(|i| [(i % 10) as f64, (i / 10 % 10) as f64, (i / 100) as f64])
            .collect();
        let (first, copies) = marked(&pts);
        assert!(first.iter().all(|&f| f));
        assert_eq!(copies, 0);
    }

    #[test]
    fn copies_stored_in_blocks_keep_the_first_block() {
        // Ten copies of 100 points, one after the other: the first 100 stay.
        let one: Vec<[f64; 3]> = (0..100)
            .map(|i| [i as f64, 1.0 / (i + 1) as f64, 0.0])
            .collect();
        let pts: Vec<[f64; 3]> = (0..10).flat_map(|_| one.iter().copied()).collect();
        let (first, copies) = marked(&pts);
        assert!(first[..100].iter().all(|&f| f));
        assert!(first[100..].iter().all(|&f| !f));
        assert_eq!(copies, 900);
    }

    /// The hashed marks against the sorted ones, with a real hash, a hash of
    /// two values and a constant (every run a collision).
    #[test]
    fn hashing_gives_the_same_marks() {
        let mut x = 12345u64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        // 3,000 points on a 6^3 grid (many copies), some at -0.0, and 1,000
        // points each alone at its position.
        let mut pts: Vec<[f64; 3]> = Vec::new();
        for _ in 0..3000 {
            let mut p = [0.0; 3];
            for v in p.iter_mut() {
                *v = (next() % 6) as f64 - if next() % 7 == 0 { 0.0 } else { 0.5 };
                if *v == 0.0 && next() % 2 == 0 {
                    *v = -0.0;
                }
            }
            pts.push(p);
            // Every third point alone at its position: a run of its own.
            if pts.len() % 3 == 0 {
                pts.push([pts.len() as f64 + 0.25, 9.0, -9.0]);
            }
        }
        let (want, want_copies) = marked(&pts);
        assert!(want_copies > 2000, "the grid repeats points");
        type Hash<'h> = &'h dyn Fn(&[u64; 3]) -> u32;
        let hashes: [Hash; 3] = [&f64_bits_hash, &|k| (k[0] & 1) as u32, &|_| 7];
        for hash in hashes {
            let mut order = vec![0u64; pts.len()];
            let mut first = vec![false; pts.len()];
            let copies =
                mark_duplicates_hashed(&pts, f64_bits, hash, &mut order, &mut first).unwrap();
            assert_eq!((first.as_slice(), copies), (want.as_slice(), want_copies));
            let mut seen: Vec<u64> = order.iter().map(|o| o & 0xFFFF_FFFF).collect();
            seen.sort_unstable();
            assert!(seen.iter().enumerate().all(|(i, &o)| o == i as u64));
        }
    }

    #[test]
    fn wrong_lengths_are_errors() {
        let pts = [[0.0; 3]; 3];
        let mut order = [0u32; 2];
        let mut first = [false; 3];
        assert!(matches!(
            mark_duplicates(&pts, f64_bits, &mut order, &mut first),
            Err(Error::KeepLength { points: 3, keep: 2 })
        ));
    }
}
