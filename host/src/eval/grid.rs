//! A uniform grid of cubic cells over axis-aligned boxes, with an exact
//! nearest-item ring search and an enumeration of the overlapping pairs.

use crate::geom::sub;
use std::ops::Range;

/// A uniform grid of cubic cells over items given by axis-aligned boxes; each item is
/// listed in every cell its box overlaps (CSR: `start[cell]..start[cell + 1]` of
/// `items`). Memory: 4 bytes per cell plus 4 per (item, cell) pair.
pub(super) struct Grid {
    min: [f64; 3],
    h: f64,
    pub(super) dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
}

/// Largest number of cells a grid may have (64 MiB of offsets).
const MAX_CELLS: f64 = (1u64 << 24) as f64;

impl Grid {
    /// A grid of about `target` cells over `boxes`, coarsened while the (item, cell)
    /// pairs would exceed 32 per item (huge triangles). O(n + cells + pairs).
    pub(super) fn build(boxes: &[([f64; 3], [f64; 3])], target: f64) -> Grid {
        let lo = bounds(boxes.iter().map(|b| b.0)).0;
        let hi = bounds(boxes.iter().map(|b| b.1)).1;
        let ext = sub(hi, lo);
        let size = ext[0].max(ext[1]).max(ext[2]);
        let target = target.clamp(1.0, MAX_CELLS);
        let cells = |h: f64| -> f64 { ext.iter().map(|&e| (e / h).ceil().max(1.0)).product() };
        let mut h = if size > 0.0 {
            let floor = size * 1e-6;
            (ext.iter().map(|&e| e.max(floor)).product::<f64>() / target).cbrt()
        } else {
            1.0
        };
        if h == 0.0 {
            // The product above underflows for a box under about 1e-100 across
            // (at once for a subnormal size), and the coarsening below, which
            // multiplies `h`, would never end: one cell across the longest side.
            h = size;
        }
        while cells(h) > 2.0 * target {
            h *= 1.25;
        }
        let max_pairs = 32.0 * boxes.len() as f64 + f64::from(1u32 << 20);
        loop {
            let mut g = Grid {
                min: lo,
                h,
                dims: ext.map(|e| ((e / h).ceil() as usize).max(1)),
                start: Vec::new(),
                items: Vec::new(),
            };
            let ranges: Vec<_> = boxes
                .iter()
                .map(|b| (g.cell_of(b.0), g.cell_of(b.1)))
                .collect();
            let pairs: f64 = ranges
                .iter()
                .map(|(a, b)| (0..3).map(|i| (b[i] - a[i] + 1) as f64).product::<f64>())
                .sum();
            if pairs > max_pairs && g.dims.iter().any(|&d| d > 1) {
                h *= 1.5;
                continue;
            }
            let mut start = vec![0u32; g.dims.iter().product::<usize>() + 1];
            for r in &ranges {
                g.for_cells(r, |c| start[c + 1] += 1);
            }
            for i in 1..start.len() {
                start[i] += start[i - 1];
            }
            let mut next = start.clone();
            let mut items = vec![0u32; pairs as usize];
            for (i, r) in ranges.iter().enumerate() {
                g.for_cells(r, |c| {
                    items[next[c] as usize] = i as u32;
                    next[c] += 1;
                });
            }
            g.start = start;
            g.items = items;
            return g;
        }
    }

    /// Calls `f(cell)` for every cell of the inclusive index range `r`.
    fn for_cells(&self, r: &([usize; 3], [usize; 3]), mut f: impl FnMut(usize)) {
        for z in r.0[2]..=r.1[2] {
            for y in r.0[1]..=r.1[1] {
                for x in r.0[0]..=r.1[0] {
                    f(x + self.dims[0] * (y + self.dims[1] * z));
                }
            }
        }
    }

    /// The cell holding `p`, clamped into the grid.
    fn cell_of(&self, p: [f64; 3]) -> [usize; 3] {
        let mut c = [0; 3];
        for a in 0..3 {
            let t = ((p[a] - self.min[a]) / self.h).floor();
            c[a] = if t > 0.0 {
                (t as usize).min(self.dims[a] - 1)
            } else {
                0
            };
        }
        c
    }

    /// Calls `f(i, j)`, `i < j`, exactly once for every pair of items whose (closed)
    /// boxes overlap and the lower corner of whose boxes' intersection lies in
    /// a cell of a layer of `layers` (the cells' `z` index; `0..dims[2]`: every
    /// pair once): in that cell, which both boxes cover. So disjoint ranges of
    /// layers share no pair, and together cover every one. O(sum over cells
    /// of items²). Stops early, returning `false`, once `f` returns `false` or
    /// more than `limit` pairs of items sharing a cell have been looked at.
    pub(super) fn overlapping_pairs(
        &self,
        boxes: &[([f64; 3], [f64; 3])],
        layers: Range<usize>,
        limit: u64,
        mut f: impl FnMut(u32, u32) -> bool,
    ) -> bool {
        let mut looked = 0u64;
        for z in layers.start..layers.end.min(self.dims[2]) {
            for y in 0..self.dims[1] {
                for x in 0..self.dims[0] {
                    let id = x + self.dims[0] * (y + self.dims[1] * z);
                    let items = &self.items[self.start[id] as usize..self.start[id + 1] as usize];
                    for (k, &i) in items.iter().enumerate() {
                        let a = &boxes[i as usize];
                        for &j in &items[k + 1..] {
                            looked += 1;
                            if looked > limit {
                                return false;
                            }
                            let b = &boxes[j as usize];
                            let overlap = (0..3).all(|c| a.0[c] <= b.1[c] && b.0[c] <= a.1[c]);
                            let corner = [0, 1, 2].map(|c| a.0[c].max(b.0[c]));
                            if overlap
                                && self.cell_of(corner) == [x, y, z]
                                && !f(i.min(j), i.max(j))
                            {
                                return false;
                            }
                        }
                    }
                }
            }
        }
        true
    }

    /// The squared distance from `p` to the grid's box (0 inside it).
    fn box_dist2(&self, p: [f64; 3]) -> f64 {
        let mut d2 = 0.0;
        for ((&x, &lo), &n) in p.iter().zip(&self.min).zip(&self.dims) {
            let d = (lo - x).max(x - (lo + n as f64 * self.h)).max(0.0);
            d2 += d * d;
        }
        d2
    }

    /// Squared distance from `p` to the box of cell `c`.
    fn cell_dist2(&self, p: [f64; 3], c: [usize; 3]) -> f64 {
        let mut d2 = 0.0;
        for a in 0..3 {
            let lo = self.min[a] + c[a] as f64 * self.h;
            let d = (lo - p[a]).max(p[a] - (lo + self.h)).max(0.0);
            d2 += d * d;
        }
        d2
    }

    /// The smallest `dist2(item, best2)` over all items, exactly: cells are visited in
    /// rings of growing Chebyshev radius around the cell of `p` until the next ring is
    /// farther than the best distance. `dist2` may return `INFINITY` for an item it can
    /// show is not closer than `best2`. A ring's lower bound counts how far `p`
    /// lies outside the grid's box, so a point whose squared distances all
    /// overflow looks at no cell.
    pub(super) fn nearest(&self, p: [f64; 3], dist2: impl FnMut(u32, f64) -> f64) -> f64 {
        self.nearest_in_rings(p, dist2).0
    }

    /// [`Grid::nearest`], and the rings of cells it looked at.
    fn nearest_in_rings(
        &self,
        p: [f64; 3],
        mut dist2: impl FnMut(u32, f64) -> f64,
    ) -> (f64, usize) {
        let c = self.cell_of(p);
        let reach = (0..3)
            .map(|a| c[a].max(self.dims[a] - 1 - c[a]))
            .max()
            .unwrap_or(0);
        // How far `p` lies outside the grid's box, which every cell is too.
        let outside2 = self.box_dist2(p);
        let mut best2 = f64::INFINITY;
        let mut rings = 0;
        for k in 0..=reach {
            // Any cell of ring k is at least (k - 1) * h away from the cell of
            // `p` along one axis, on top of how far `p` lies outside the box.
            let lb = k.saturating_sub(1) as f64 * self.h;
            if outside2 + lb * lb >= best2 {
                break;
            }
            rings += 1;
            let lo = c.map(|v| v as isize - k as isize);
            let hi = c.map(|v| v as isize + k as isize);
            for z in lo[2].max(0)..=hi[2].min(self.dims[2] as isize - 1) {
                let z_edge = z == lo[2] || z == hi[2];
                for y in lo[1].max(0)..=hi[1].min(self.dims[1] as isize - 1) {
                    let yz_edge = z_edge || y == lo[1] || y == hi[1];
                    let step = if yz_edge { 1 } else { (2 * k).max(1) };
                    let mut x = lo[0];
                    while x <= hi[0] {
                        if x >= 0 && x < self.dims[0] as isize {
                            let cell = [x as usize, y as usize, z as usize];
                            if self.cell_dist2(p, cell) < best2 {
                                let id =
                                    cell[0] + self.dims[0] * (cell[1] + self.dims[1] * cell[2]);
                                let (s, e) = (self.start[id] as usize, self.start[id + 1] as usize);
                                for &item in &self.items[s..e] {
                                    best2 = best2.min(dist2(item, best2));
                                }
                            }
                        }
                        x += step as isize;
                    }
                }
            }
        }
        (best2, rings)
    }
}

/// The smallest box holding every point of `it` (inverted when empty).
pub(super) fn bounds(it: impl Iterator<Item = [f64; 3]>) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in it {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::rng_points;
    use crate::geom::dot;

    #[test]
    fn points_far_outside_the_grid_are_found_exactly_and_past_overflow_at_once() {
        // A fuzz input (fuzz/REPORT.md): surface samples within 1e-80 of the
        // origin against points out to 1e302 went through every ring of cells
        // for each sample, every distance being infinite. Here 4,096 points in
        // a cube, queries 1e3 to 1e219 outside it on every side.
        let pts = rng_points(4096, 11, 1.0);
        let boxes: Vec<_> = pts.iter().map(|&p| (p, p)).collect();
        let grid = Grid::build(&boxes, pts.len() as f64);
        assert!(grid.dims.iter().all(|&d| d > 8), "dims {:?}", grid.dims);
        for (n, q) in rng_points(64, 12, 1.0).into_iter().enumerate() {
            let far = 10f64.powi(3 + (n as i32 % 5) * 54);
            let mut p = q;
            p[n % 3] += if n % 2 == 0 { far } else { -far };
            let (got, rings) = grid.nearest_in_rings(p, |i, _| {
                dot(sub(pts[i as usize], p), sub(pts[i as usize], p))
            });
            let want = pts
                .iter()
                .map(|&x| dot(sub(x, p), sub(x, p)))
                .fold(f64::INFINITY, f64::min);
            assert_eq!(got, want, "query {p:?}");
            if far > 1e155 {
                // Every squared distance overflows, as the box's does: no
                // cell can be nearer, none is looked at.
                assert_eq!(rings, 0, "{rings} rings for {p:?}");
            }
        }
    }

    #[test]
    fn nearest_point_search_equals_brute_force_on_a_flat_cloud() {
        // All points in one plane: the grid has a single layer of cells.
        let pts: Vec<[f64; 3]> = rng_points(2000, 3, 1.0)
            .into_iter()
            .map(|p| [p[0], p[1], 0.0])
            .collect();
        let boxes: Vec<_> = pts.iter().map(|&p| (p, p)).collect();
        let grid = Grid::build(&boxes, pts.len() as f64);
        assert_eq!(grid.dims[2], 1);
        for q in rng_points(500, 5, 2.0) {
            let got = grid.nearest(q, |i, _| {
                dot(sub(pts[i as usize], q), sub(pts[i as usize], q))
            });
            let want = pts
                .iter()
                .map(|&p| dot(sub(p, q), sub(p, q)))
                .fold(f64::INFINITY, f64::min);
            assert_eq!(got, want);
        }
    }
}
