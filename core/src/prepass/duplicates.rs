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
    let n = points.len();
    if order.len() != n || first.len() != n {
        return Err(Error::KeepLength {
            points: n,
            keep: if first.len() != n {
                first.len()
            } else {
                order.len()
            },
        });
    }
    if u32::try_from(n).is_err() {
        return Err(Error::TooManyPoints {
            found: n,
            max: u32::MAX as usize,
        });
    }
    for (i, o) in order.iter_mut().enumerate() {
        *o = i as u32;
    }
    let at = |i: u32| points.get(i as usize).map(&key);
    order.sort_unstable_by(|&a, &b| at(a).cmp(&at(b)).then(a.cmp(&b)));
    // Runs of equal keys: the first of each run has the lowest index.
    let mut copies = 0u32;
    let mut last = None;
    for &i in order.iter() {
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
    Ok(copies)
}

/// The key of `mark_duplicates` for `f64` coordinates: their bit patterns,
/// with `-0.0` taken as `0.0` (the same position). NaN never equals a finite
/// value.
pub fn f64_bits(p: &[f64; 3]) -> [u64; 3] {
    p.map(|v| (v + 0.0).to_bits())
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
