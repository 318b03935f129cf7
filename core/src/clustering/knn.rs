//! k nearest neighbours from a sparse uniform grid, and the symmetrised graph.
//!
//! The grid stores only occupied cells: points are sorted by cell key, distinct keys
//! go into a table with the start of each cell's run, and an open-addressing hash of
//! the occupied *columns* `(x, y)` answers "which cells are in column (x, y)" in
//! O(1) (a column's cells are contiguous, sorted by z). A query scans
//! rings of cells around the point's own cell (Chebyshev distance 0, 1, 2, ...) and
//! stops once the k-th best distance is below `r * h`: every point not yet seen lies
//! at least that far away, so the answer is *certified* exact, not approximate.
//! Ties are broken by point index, so the result equals a brute-force sort of
//! `(distance², index)`. The queries go cell by cell: the points of a cell's
//! 27-cell block (rings 0 and 1) are gathered once into rows of coordinates
//! (a `Batch`), each query of the cell takes the k best of them, and ring
//! 1's certificate ends almost every query there (the bunny: 4,570 to 3,160
//! instructions a query). Those it does not end, and the cells with more
//! around them than a batch holds, take the ring search: ring 1 visited
//! nearest cell first (by a lower bound on each cell's distance), stopping
//! at the first cell whose bound is beyond the k-th best so far, then rings
//! 2, 3, ...
//!
//! Memory: the result is `4 k` bytes per point (plus the reverse-edge table below);
//! the grid is scratch, about `16 + 40 / occupancy` bytes per point while queries run.
//! Cost: O(n log n) for the sort plus O(n k · points per ring) for the queries;
//! a point far from everything falls back to a linear scan, so no query does more
//! than O(n) work.
//!
//! The symmetrised graph (`i ~ j` when either is among the other's k nearest) is
//! `knn(i)` plus the *reverse-only* edges (`i` is in `knn(j)` but `j` is not in
//! `knn(i)`), kept in a compressed table: typically a third of `k` per point.

use crate::arena::{padded_bytes, Alloc, Arena};
use crate::error::{Error, Result};
use crate::math::{dist2, V3};
use crate::parallel;
use crate::parallel::Task;
use crate::params::MAX_K;
use crate::progress::{tick, Progress, Stage};
use crate::validate::Bounds;
use core::ops::Range;
use core::sync::atomic::{AtomicU32, Ordering::Relaxed};

/// The k-nearest-neighbour graph and its symmetrisation. See the module docs.
#[derive(Clone, Copy)]
pub struct Neighbours<'a> {
    /// Neighbours per point.
    pub k: usize,
    /// Row `i` (`knn[i*k .. i*k+k]`) lists the k nearest other points of `i`,
    /// nearest first, ties by index.
    pub knn: &'a [u32],
    /// `rev[rev_start[i] .. rev_start[i+1]]`: points `j` with `i` in `knn(j)` but
    /// `j` not in `knn(i)`, ascending.
    pub rev_start: &'a [u32],
    /// See `rev_start`.
    pub rev: &'a [u32],
    /// Mean distance from a point to its k nearest neighbours (average spacing).
    pub spacing: f32,
    /// Queries that fell back to a linear scan (isolated points).
    pub linear_scans: u32,
}

impl<'a> Neighbours<'a> {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.knn.len().checked_div(self.k).unwrap_or(0)
    }

    /// Whether the graph has no points.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The k nearest neighbours of `i`, nearest first.
    #[inline]
    pub fn of(&self, i: usize) -> &'a [u32] {
        &self.knn[i * self.k..(i + 1) * self.k]
    }

    /// The reverse-only neighbours of `i`.
    #[inline]
    pub fn reverse_of(&self, i: usize) -> &'a [u32] {
        &self.rev[self.rev_start[i] as usize..self.rev_start[i + 1] as usize]
    }

    /// Every neighbour of `i` in the symmetrised graph, each once.
    #[inline]
    pub fn symmetric(&self, i: usize) -> impl Iterator<Item = u32> + 'a {
        self.of(i).iter().chain(self.reverse_of(i)).copied()
    }

    /// [`Neighbours::symmetric`] as its two rows, the k nearest and the
    /// reverse-only, for hot loops: a loop over each row in turn costs
    /// fewer instructions than the chained iterator (region growing's,
    /// the slabs' and the sweeps' loops: 41.7 M fewer a one-thread bunny
    /// run, 1.4 %; 4.7 % at 300k points, where the sweeps run).
    #[inline]
    pub fn rows(&self, i: usize) -> [&'a [u32]; 2] {
        [self.of(i), self.reverse_of(i)]
    }
}

/// Cell edge length and counts of the sparse grid.
struct Grid<'s> {
    lo: V3,
    h: f32,
    dims: [u32; 3],
    /// Point indices sorted by cell.
    order: &'s [u32],
    /// Positions in `order`, for cache-friendly scans.
    sorted: &'s [V3],
    cell_keys: &'s [u64],
    cell_start: &'s [u32],
    /// Open-addressing table from a column key (`x, y` of a cell) to the first cell
    /// of that column: the cells of one column are contiguous, ordered by `z`.
    /// Entries `(key, first cell)`, `EMPTY_KEY` when free; length a power of 2.
    columns: &'s [(u64, u32)],
}

const EMPTY_KEY: u64 = u64::MAX;

#[inline]
fn pack(c: [u32; 3]) -> u64 {
    (c[0] as u64) << 42 | (c[1] as u64) << 21 | c[2] as u64
}

#[inline]
fn hash(key: u64) -> u64 {
    let mut z = key.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z ^= z >> 29;
    z
}

impl Grid<'_> {
    #[inline]
    fn cell_of(&self, p: V3) -> [u32; 3] {
        let mut c = [0u32; 3];
        for a in 0..3 {
            let t = (p[a] - self.lo[a]) / self.h;
            // `as` saturates (NaN -> 0): always a valid cell, never a panic.
            c[a] = (t as u32).min(self.dims[a] - 1);
        }
        c
    }

    /// First cell of column `(x, y)`, if any cell of it is occupied.
    #[inline]
    fn column(&self, x: u32, y: u32) -> Option<usize> {
        let key = pack([x, y, 0]) >> 21;
        let mask = self.columns.len() - 1;
        let mut slot = hash(key) as usize & mask;
        loop {
            let (k, first) = self.columns[slot];
            if k == key {
                return Some(first as usize);
            }
            if k == EMPTY_KEY {
                return None;
            }
            slot = (slot + 1) & mask;
        }
    }

    /// Calls `f(cell, z)` for the occupied cells of column `(x, y)` with `z`
    /// in `z_lo..=z_hi`, ascending: one column lookup, then a walk up the
    /// column's contiguous cells.
    #[inline(always)]
    fn for_column_cells(
        &self,
        x: u32,
        y: u32,
        z_lo: i64,
        z_hi: i64,
        mut f: impl FnMut(usize, i64),
    ) {
        let Some(first) = self.column(x, y) else {
            return;
        };
        let column = self.cell_keys[first] >> 21;
        let mut cell = first;
        while cell < self.cell_keys.len() && self.cell_keys[cell] >> 21 == column {
            let z = (self.cell_keys[cell] & 0x1F_FFFF) as i64;
            if z > z_hi {
                break;
            }
            if z >= z_lo {
                f(cell, z);
            }
            cell += 1;
        }
    }
}

/// The k best `(d², index)` pairs seen so far, kept sorted (k <= 32).
struct Best {
    d2: [f32; MAX_K],
    idx: [u32; MAX_K],
    len: usize,
    k: usize,
}

impl Best {
    fn new(k: usize) -> Self {
        Best {
            d2: [0.0; MAX_K],
            idx: [0; MAX_K],
            len: 0,
            k,
        }
    }

    #[inline]
    fn worse(a: (f32, u32), b: (f32, u32)) -> bool {
        a.0 > b.0 || (a.0 == b.0 && a.1 > b.1)
    }

    #[inline]
    fn offer(&mut self, d2: f32, j: u32) {
        if self.len == self.k
            && !Self::worse((self.d2[self.len - 1], self.idx[self.len - 1]), (d2, j))
        {
            return;
        }
        let mut pos = if self.len < self.k {
            self.len
        } else {
            self.len - 1
        };
        while pos > 0 && Self::worse((self.d2[pos - 1], self.idx[pos - 1]), (d2, j)) {
            self.d2[pos] = self.d2[pos - 1];
            self.idx[pos] = self.idx[pos - 1];
            pos -= 1;
        }
        self.d2[pos] = d2;
        self.idx[pos] = j;
        if self.len < self.k {
            self.len += 1;
        }
    }

    fn kth(&self) -> f32 {
        if self.len < self.k {
            f32::INFINITY
        } else {
            self.d2[self.k - 1]
        }
    }
}

/// Bytes of scratch the grid needs for `n` points, whatever its occupancy: order
/// and sorted points (16 per point), then the larger of the sort keys (8 per
/// point, dropped before the tables) and the tables, with cells and columns at
/// most `n`: cell keys and starts (12 per cell) and the column hash (a power of
/// two of at least twice the columns, 16 bytes a slot: at most 64 per column).
/// About 92 bytes per point. Keep in step with `build_grid`.
pub fn grid_scratch_bytes(n: usize) -> usize {
    let slots = n
        .saturating_mul(2)
        .checked_next_power_of_two()
        .unwrap_or(usize::MAX);
    let tables = padded_bytes::<u64>(n)
        .saturating_add(padded_bytes::<u32>(n.saturating_add(1)))
        .saturating_add(padded_bytes::<(u64, u32)>(slots));
    padded_bytes::<u32>(n)
        .saturating_add(padded_bytes::<V3>(n))
        .saturating_add(padded_bytes::<u64>(n).max(tables))
}

/// Arena bytes of the neighbour stage for `n` points and `k` neighbours:
/// `(peak, kept)`. Kept: the k-NN table (`4 k` per point) and the reverse-only
/// table, at its worst (`4 (n + 1) + 4 k n`: no neighbour relation mutual; real
/// clouds have one or two reverse-only edges per point, but one point stored
/// many times reaches `k` a point, so no lower bound holds for every cloud:
/// see the test `copies_of_one_point_reach_the_reverse_tables_worst_case`). The peak adds the larger of the grid scratch and the
/// reverse table's cursor (4 per point). Keep in step with
/// [`try_neighbours_in`] and `reverse_edges_in`.
pub fn neighbours_bytes(n: usize, k: usize) -> (usize, usize) {
    neighbours_bytes_for(n, k, n.saturating_mul(k), true)
}

/// [`neighbours_bytes`] with `reverse_edges` reverse-only edges (the real count
/// instead of the worst case) and, unless `searched`, a k-NN table given by the
/// caller (not in the arena, no search scratch).
pub fn neighbours_bytes_for(
    n: usize,
    k: usize,
    reverse_edges: usize,
    searched: bool,
) -> (usize, usize) {
    let (knn, search) = if searched {
        (
            padded_bytes::<u32>(n.saturating_mul(k)),
            grid_scratch_bytes(n),
        )
    } else {
        (0, 0)
    };
    let rev =
        padded_bytes::<u32>(n.saturating_add(1)).saturating_add(padded_bytes::<u32>(reverse_edges));
    // The reverse-only bits of every row and the fill's cursor.
    let during_rev = rev.saturating_add(padded_bytes::<u32>(n).saturating_mul(2));
    let peak = knn.saturating_add(search.max(during_rev));
    (peak, knn.saturating_add(rev))
}

/// Compute the k nearest neighbours of every point and the reverse-edge table.
/// `points` must be finite (checked by the caller) and `k < points.len()`.
pub fn try_neighbours_in<'a>(
    arena: &'a Arena,
    points: &[V3],
    k: usize,
    progress: &mut dyn Progress,
) -> Result<Neighbours<'a>> {
    try_neighbours_checked_in(arena, points, k, &|_| Ok(()), progress)
}

/// [`try_neighbours_in`], calling `room` with the number of reverse-only edges
/// once they are counted, before their table is allocated: an error from it
/// ends the search.
pub fn try_neighbours_checked_in<'a>(
    arena: &'a Arena,
    points: &[V3],
    k: usize,
    room: &dyn Fn(usize) -> Result<()>,
    progress: &mut dyn Progress,
) -> Result<Neighbours<'a>> {
    let n = points.len();
    usable_k(k, n)?;
    tick(progress, Stage::Neighbours, 0, n as u64)?;
    let rows = try_knn_rows_in(arena, points, k, Stage::Neighbours, progress)?;
    let knn: &'a [u32] = rows.knn;
    let (rev_start, rev) = reverse_edges_in(arena, knn, k, room, &*progress)?;

    tick(progress, Stage::Neighbours, n as u64, n as u64)?;
    Ok(Neighbours {
        k,
        knn,
        rev_start,
        rev,
        spacing: rows.spacing,
        linear_scans: rows.linear_scans,
    })
}

/// The k-NN table alone (no reverse edges): what [`try_knn_rows_in`] returns.
pub struct KnnRows<'a> {
    /// Row `i` (`knn[i*k .. i*k+k]`): the k nearest other points of `i`, nearest
    /// first, ties by index.
    pub knn: &'a mut [u32],
    /// Mean distance from a point to its k nearest neighbours.
    pub spacing: f32,
    /// Queries that fell back to a linear scan.
    pub linear_scans: u32,
}

/// The k nearest neighbours of every point, allocated from `a` (`4 k` bytes per
/// point; the grid is scratch on top, [`grid_scratch_bytes`]). Progress is
/// reported under `stage`. `points` must be finite and `k < points.len()`
/// (else [`Error::BadNeighbours`]).
pub fn try_knn_rows_in<'a, 'b, A: Alloc<'b>>(
    a: &'a A,
    points: &[V3],
    k: usize,
    stage: Stage,
    progress: &mut dyn Progress,
) -> Result<KnnRows<'a>> {
    usable_k(k, points.len())?;
    let knn = a.try_alloc_slice::<u32>(points.len() * k, 0)?;
    let linear_scans = try_fill_knn_rows(a, points, k, knn, stage, progress)?;
    let spacing = spacing(points, knn, k, &*progress);
    Ok(KnnRows {
        knn,
        spacing,
        linear_scans,
    })
}

/// [`try_knn_rows_in`] into the caller's table `knn` (`n k` entries, else
/// [`Error::BadNeighbourTable`]), with only the grid in scratch from `a`.
/// Returns the queries that fell back to a linear scan.
pub fn try_fill_knn_rows<'b, A: Alloc<'b>>(
    a: &A,
    points: &[V3],
    k: usize,
    knn: &mut [u32],
    stage: Stage,
    progress: &mut dyn Progress,
) -> Result<u32> {
    let n = points.len();
    usable_k(k, n)?;
    check_table_len(knn.len(), n, k)?;
    tick(progress, stage, 0, n as u64)?;
    let mut linear_scans = 0u32;
    a.scratch(|s| -> Result<()> {
        let grid = build_grid(s, points, k, &*progress)?;
        // The queries in the grid's order, a cell's points together: they
        // share one gathering of the cells around theirs ([`Batch`]). Each
        // row is set whole by the task that has its point, so the rows do
        // not depend on the tasks' order.
        let rows = crate::arena::atomic_u32s(knn);
        for wave in (0..n).step_by(parallel::WAVE) {
            let end = (wave + parallel::WAVE).min(n);
            let parts = parallel::ranges(&*progress, end - wave, |slots| {
                query_cells(&grid, wave + slots.start..wave + slots.end, k, rows)
            });
            linear_scans += parts.iter().sum::<u32>();
            tick(progress, stage, end as u64, n as u64)?;
        }
        Ok(())
    })?;
    Ok(linear_scans)
}

/// A k-NN table of `len` entries holds `n` rows of `k` (else
/// [`Error::BadNeighbourTable`], naming the rows it would hold and its length).
pub(crate) fn check_table_len(len: usize, n: usize, k: usize) -> Result<()> {
    if len == n.saturating_mul(k) {
        return Ok(());
    }
    Err(Error::BadNeighbourTable {
        row: len / k.max(1),
        entry: len as u64,
    })
}

/// `k` neighbours are possible among `n` points: `1 <= k <= MAX_K` and `k < n`
/// (else [`Error::BadNeighbours`]).
fn usable_k(k: usize, n: usize) -> Result<()> {
    if k == 0 || k > MAX_K || k >= n {
        return Err(Error::BadNeighbours { k, points: n });
    }
    Ok(())
}

/// Mean distance from a point to its `k` nearest (rows of `knn`, which must
/// index `points`), summed in a fixed order: per task of each wave of
/// [`parallel::WAVE`] points, each row nearest first. O(n k).
pub fn spacing(points: &[V3], knn: &[u32], k: usize, hooks: &dyn Progress) -> f32 {
    let k = k.max(1);
    let n = knn.len() / k;
    let mut total = 0.0f64;
    for (w, wave) in knn.chunks(parallel::WAVE * k).enumerate() {
        let first = w * parallel::WAVE;
        let parts = parallel::ranges(hooks, wave.len() / k, |items| {
            let mut sum = 0.0f64;
            for i in items {
                let p = points.get(first + i).copied().unwrap_or_default();
                for &j in &wave[i * k..(i + 1) * k] {
                    let q = points.get(j as usize).copied().unwrap_or(p);
                    sum += libm::sqrt(dist2(p, q) as f64);
                }
            }
            sum
        });
        for part in parts {
            total += part;
        }
    }
    (total / n.saturating_mul(k).max(1) as f64) as f32
}

/// The neighbour graph of `points` from a k-NN table the caller already has
/// (`knn`, row `i` the `k` nearest other points of `i`, nearest first, ties
/// by index: what [`crate::clean_with_rows`] writes), borrowed where it lies
/// (not copied: the arena holds only its reverse edges), so it must outlive
/// the arena's results: [`try_neighbours_in`] without the search. A table
/// of the wrong length, or with an entry that is out of range or the row's own
/// point, fails with [`Error::BadNeighbourTable`].
pub fn try_neighbours_from_in<'a>(
    arena: &'a Arena,
    points: &[V3],
    knn: &'a [u32],
    k: usize,
    linear_scans: u32,
    room: &dyn Fn(usize) -> Result<()>,
    progress: &mut dyn Progress,
) -> Result<Neighbours<'a>> {
    let n = points.len();
    usable_k(k, n)?;
    check_table_len(knn.len(), n, k)?;
    // The first bad entry of each task's rows, in parallel tasks; the first
    // task's with one names it.
    let bad = parallel::ranges(&*progress, n, |mut rows| {
        rows.find_map(|i| {
            let row = &knn[i * k..(i + 1) * k];
            let j = *row.iter().find(|&&j| j as usize >= n || j as usize == i)?;
            Some((i, j))
        })
    });
    if let Some((i, j)) = bad.into_iter().flatten().next() {
        return Err(Error::BadNeighbourTable {
            row: i,
            entry: j as u64,
        });
    }
    tick(progress, Stage::Neighbours, 0, n as u64)?;
    let (rev_start, rev) = reverse_edges_in(arena, knn, k, room, &*progress)?;
    tick(progress, Stage::Neighbours, n as u64, n as u64)?;
    Ok(Neighbours {
        k,
        knn,
        rev_start,
        rev,
        spacing: spacing(points, knn, k, &*progress),
        linear_scans,
    })
}

/// Candidates a [`Batch`] holds: the points of a cell and the 26 around it
/// (70 on the bunny at its median, 259 at most on the shared clouds); the
/// queries of a cell with more take [`ring_search`].
const BATCH: usize = 256;

/// The points of the cells at Chebyshev distance 0 and 1 from one cell, in
/// rows of coordinates, the cell itself first, then those sharing a face
/// with it, an edge, a corner: near ones early fill the k best with near
/// points, so fewer of the rest get past the k-th best.
struct Batch {
    /// The cell gathered, `usize::MAX` for none.
    cell: usize,
    /// Candidates held; more than [`BATCH`] when they did not fit.
    len: usize,
    x: [f32; BATCH],
    y: [f32; BATCH],
    z: [f32; BATCH],
    idx: [u32; BATCH],
}

impl Batch {
    fn new() -> Self {
        Batch {
            cell: usize::MAX,
            len: 0,
            x: [0.0; BATCH],
            y: [0.0; BATCH],
            z: [0.0; BATCH],
            idx: [0; BATCH],
        }
    }

    /// Gathers the cells around occupied cell `cell` of `grid`.
    fn gather(&mut self, grid: &Grid, cell: usize) {
        self.cell = cell;
        self.len = 0;
        let key = grid.cell_keys[cell];
        let c = [key >> 42, (key >> 21) & 0x1F_FFFF, key & 0x1F_FFFF].map(|v| v as i64);
        // Slot ranges of the occupied cells around, with how many axes they
        // are off `c` along.
        let mut runs = [(0u32, 0u32, 0u8); 27];
        let mut count = 0;
        let lo = |a: usize| (c[a] - 1).max(0);
        let hi = |a: usize| (c[a] + 1).min(grid.dims[a] as i64 - 1);
        for x in lo(0)..=hi(0) {
            for y in lo(1)..=hi(1) {
                let off = u8::from(x != c[0]) + u8::from(y != c[1]);
                grid.for_column_cells(x as u32, y as u32, c[2] - 1, c[2] + 1, |at, z| {
                    if count < runs.len() {
                        let (a, b) = (grid.cell_start[at], grid.cell_start[at + 1]);
                        runs[count] = (a, b, off + u8::from(z != c[2]));
                        count += 1;
                    }
                });
            }
        }
        for off in 0..=3 {
            for &(a, b, _) in runs[..count].iter().filter(|r| r.2 == off) {
                let (a, b) = (a as usize, b as usize);
                let end = self.len + (b - a);
                if end <= BATCH {
                    for (t, slot) in (self.len..end).zip(a..b) {
                        let q = grid.sorted[slot];
                        (self.x[t], self.y[t], self.z[t]) = (q[0], q[1], q[2]);
                        self.idx[t] = grid.order[slot];
                    }
                }
                self.len = end;
            }
        }
    }

    /// The k nearest of point `i` at `p` among the candidates (not `i`
    /// itself) into `best`: `None` when ring 1 certifies them as in
    /// [`ring_search`], else the ring the search goes on from (2, or 0 when
    /// the candidates did not fit and `best` is untouched).
    #[inline]
    fn search(&self, grid: &Grid, p: V3, i: u32, best: &mut Best) -> Option<i64> {
        if self.len > BATCH {
            return Some(0);
        }
        let n = self.len;
        let (x, y, z, idx) = (&self.x[..n], &self.y[..n], &self.z[..n], &self.idx[..n]);
        // The distances first, in a loop of vector instructions: `dist2(p,
        // q)`, term for term.
        let mut d2 = [0.0f32; BATCH];
        let d2 = &mut d2[..n];
        for (t, e) in d2.iter_mut().enumerate() {
            let d = [p[0] - x[t], p[1] - y[t], p[2] - z[t]];
            *e = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        }
        // Then the k best: one beyond the k-th best so far cannot enter.
        let mut kth = best.kth();
        for (&e, &j) in d2.iter().zip(idx) {
            if e <= kth && j != i {
                best.offer(e, j);
                kth = best.kth();
            }
        }
        let reach = grid.h + Gaps::new(grid, p, grid.cell_of(p)).inset();
        let max_r = grid.dims.iter().copied().max().unwrap_or(1) as i64;
        let done = best.kth() < reach * reach * (1.0 - 1e-5) || 1 >= max_r;
        (!done).then_some(2)
    }
}

/// The k-NN rows of the points in sorted `slots` of `grid` into `rows`
/// (row `i` at `i k`), each certified after ring 1 from its cell's
/// [`Batch`], else by [`ring_search`], else by a scan of every point.
/// Returns the scans.
fn query_cells(grid: &Grid, slots: Range<usize>, k: usize, rows: &[AtomicU32]) -> u32 {
    let mut scans = 0u32;
    let mut batch = Batch::new();
    // The cell of the first slot, then advanced as the slots pass its end.
    let mut cell = grid
        .cell_start
        .partition_point(|&s| s as usize <= slots.start)
        .saturating_sub(1);
    for slot in slots {
        while grid
            .cell_start
            .get(cell + 1)
            .is_some_and(|&e| e as usize <= slot)
        {
            cell += 1;
        }
        if batch.cell != cell {
            batch.gather(grid, cell);
        }
        let (i, p) = (grid.order[slot], grid.sorted[slot]);
        let mut best = Best::new(k);
        if let Some(from) = batch.search(grid, p, i, &mut best) {
            if !ring_search(grid, p, i, &mut best, from) {
                scans += 1;
                best = Best::new(k);
                for (t, &q) in grid.sorted.iter().enumerate() {
                    let j = grid.order[t];
                    if j != i {
                        best.offer(dist2(p, q), j);
                    }
                }
            }
        }
        if let Some(row) = rows.get(i as usize * k..(i as usize + 1) * k) {
            for (r, &j) in row.iter().zip(&best.idx[..k]) {
                r.store(j, Relaxed);
            }
        }
    }
    scans
}

/// Scan rings from ring `from` until the k-th neighbour is certified, `best`
/// holding the k best of the rings before. Returns false when the rings
/// would cost more than a linear scan (the caller then does one).
fn ring_search(grid: &Grid, p: V3, self_idx: u32, best: &mut Best, from: i64) -> bool {
    let c = grid.cell_of(p);
    let gaps = Gaps::new(grid, p, c);
    let inset = gaps.inset();
    let n_cells = grid.cell_keys.len() as u64;
    let max_r = grid.dims.iter().copied().max().unwrap_or(1) as i64;
    let mut r: i64 = from;
    loop {
        // Cells visited up to ring r: (2r+1)^3. Stop when that exceeds the work of
        // scanning everything (isolated points, very uneven clouds).
        let side = (2 * r + 1) as u64;
        if r > 1 && side * side * side > 8 * n_cells + 64 {
            return false;
        }
        if r == 1 {
            visit_first_ring(grid, c, &gaps, best, p, self_idx);
        } else {
            visit_ring(grid, c, r, |slot| offer_slot(grid, best, p, self_idx, slot));
        }
        // Unseen points lie outside the cube of visited cells: at least `reach` away
        // (r cells plus p's distance to its own cell's nearest face). The margin
        // absorbs f32 rounding.
        let reach = r as f32 * grid.h + inset;
        if best.kth() < reach * reach * (1.0 - 1e-5) || r >= max_r {
            return true;
        }
        r += 1;
    }
}

/// Lower bounds on the distance from a point to the cells around its own, an
/// axis at a time: to a cell `d` cells away along an axis, at least `(|d| - 1)
/// h` plus the point's distance to its own cell's face on that side, each face
/// distance shrunk by the margin `ring_search`'s certificate uses and by a few
/// units in the last place of the coordinates (the faces' rounding and
/// `cell_of`'s), so that a bound never exceeds a distance `dist2` computes.
struct Gaps {
    below: [f32; 3],
    above: [f32; 3],
}

impl Gaps {
    fn new(grid: &Grid, p: V3, c: [u32; 3]) -> Self {
        let (mut below, mut above) = ([0.0f32; 3], [0.0f32; 3]);
        for a in 0..3 {
            let lo = grid.lo[a] + c[a] as f32 * grid.h;
            let hi = lo + grid.h;
            let slack = 8.0 * f32::EPSILON * (grid.lo[a].abs() + p[a].abs() + hi.abs());
            // A point clamped into the last cell (or rounding at a face) may sit
            // outside its cell by a hair: never let a gap go negative.
            below[a] = ((p[a] - lo) * (1.0 - 1e-4) - slack).max(0.0);
            above[a] = ((hi - p[a]) * (1.0 - 1e-4) - slack).max(0.0);
        }
        Gaps { below, above }
    }

    /// The point's distance to its own cell's nearest face (within the margins).
    fn inset(&self) -> f32 {
        self.below
            .iter()
            .chain(&self.above)
            .fold(f32::INFINITY, |m, &g| m.min(g))
    }

    /// The bound along axis `a` to a neighbouring cell (`d` of -1, 0, 1).
    #[inline]
    fn next(&self, a: usize, d: i64) -> f32 {
        match d {
            0 => 0.0,
            d if d > 0 => self.above[a],
            _ => self.below[a],
        }
    }
}

/// Ring 1 (the 26 cells around `c`), its occupied cells nearest first by
/// their bounds in `gaps`: once a cell's bound puts all its points beyond the
/// k-th best so far, so does every cell after it, and none of their points
/// could enter `best`, which ends as if each had been offered.
fn visit_first_ring(grid: &Grid, c: [u32; 3], gaps: &Gaps, best: &mut Best, p: V3, self_idx: u32) {
    let mut cells = [(0.0f32, 0u32); 26];
    let mut count = 0;
    let lo = |a: usize| (c[a] as i64 - 1).max(0);
    let hi = |a: usize| (c[a] as i64 + 1).min(grid.dims[a] as i64 - 1);
    let (z_lo, z_hi) = (lo(2), hi(2));
    for x in lo(0)..=hi(0) {
        let gx = gaps.next(0, x - c[0] as i64);
        for y in lo(1)..=hi(1) {
            let gy = gaps.next(1, y - c[1] as i64);
            let centre = x == c[0] as i64 && y == c[1] as i64;
            grid.for_column_cells(x as u32, y as u32, z_lo, z_hi, |cell, z| {
                if !(centre && z == c[2] as i64) && count < cells.len() {
                    let gz = gaps.next(2, z - c[2] as i64);
                    cells[count] = (gx * gx + gy * gy + gz * gz, cell as u32);
                    count += 1;
                }
            });
        }
    }
    let cells = &mut cells[..count];
    // Insertion sort: a few cells, nearly in order of their bounds already.
    for i in 1..cells.len() {
        let mut j = i;
        while j > 0 && cells[j - 1].0 > cells[j].0 {
            cells.swap(j - 1, j);
            j -= 1;
        }
    }
    for &(bound2, cell) in cells.iter() {
        // The margin of `ring_search`'s certificate.
        if best.kth() < bound2 * (1.0 - 1e-5) {
            break;
        }
        let cell = cell as usize;
        for slot in grid.cell_start[cell]..grid.cell_start[cell + 1] {
            offer_slot(grid, best, p, self_idx, slot as usize);
        }
    }
}

/// Offer `best` the point in sorted slot `slot` of `grid`, unless it is the
/// query point `self_idx` itself. Always inlined: as a call (plain
/// `#[inline]` left it one) the search took 13 % more instructions.
#[inline(always)]
fn offer_slot(grid: &Grid, best: &mut Best, p: V3, self_idx: u32, slot: usize) {
    let j = grid.order[slot];
    if j != self_idx {
        best.offer(dist2(p, grid.sorted[slot]), j);
    }
}

/// Call `f` with the sorted-slot of every point in the cells at Chebyshev distance
/// exactly `r` from cell `c`, clipped to the grid. One column lookup per `(x, y)`.
fn visit_ring(grid: &Grid, c: [u32; 3], r: i64, mut f: impl FnMut(usize)) {
    let lo = |a: usize| (c[a] as i64 - r).max(0);
    let hi = |a: usize| (c[a] as i64 + r).min(grid.dims[a] as i64 - 1);
    let (z_lo, z_hi) = (lo(2), hi(2));
    let (z_face_lo, z_face_hi) = (c[2] as i64 - r, c[2] as i64 + r);
    for x in lo(0)..=hi(0) {
        let ex = (x - c[0] as i64).abs() == r;
        for y in lo(1)..=hi(1) {
            // On the ring's side walls the whole z range is new; inside, only the
            // two z faces belong to ring r.
            let wall = ex || (y - c[1] as i64).abs() == r;
            grid.for_column_cells(x as u32, y as u32, z_lo, z_hi, |cell, z| {
                if wall || z == z_face_lo || z == z_face_hi {
                    for slot in grid.cell_start[cell]..grid.cell_start[cell + 1] {
                        f(slot as usize);
                    }
                }
            });
        }
    }
}

/// A slice of keys to sort, as a parallel task.
struct Sort<'s>(&'s mut [u64]);

impl Task for Sort<'_> {
    fn run(&mut self) {
        self.0.sort_unstable();
    }
}

/// `order` = the points' indices by (cell of `grid`, index), `keys` its
/// scratch (one per point); returns the occupied cells. With `direct` and a
/// box of at most 2^32 cells, each point's cell index in the box (ascending
/// with the packed key) and its index go into one word, the words sorted in
/// two halves as parallel tasks of `hooks` and merged; else the indices are
/// sorted by two lookups of packed keys. The same order either way.
fn sort_by_cell(
    grid: &Grid,
    points: &[V3],
    keys: &mut [u64],
    order: &mut [u32],
    direct: bool,
    hooks: &dyn Progress,
) -> usize {
    let n = points.len().min(keys.len()).min(order.len());
    let (keys, order) = (&mut keys[..n], &mut order[..n]);
    let [_, dy, dz] = grid.dims.map(u64::from);
    let boxed = grid
        .dims
        .iter()
        .try_fold(1u64, |c, &d| c.checked_mul(u64::from(d)));
    if direct && boxed.is_some_and(|c| c <= 1 << 32) && u32::try_from(n).is_ok() {
        for (i, (k, p)) in keys.iter_mut().zip(points).enumerate() {
            let [x, y, z] = grid.cell_of(*p).map(u64::from);
            *k = ((x * dy + y) * dz + z) << 32 | i as u64;
        }
        // The halves sorted in two parallel tasks, then merged into `order`
        // (the keys are distinct: the same order as one sort of them all).
        let (a, b) = keys.split_at_mut(n / 2);
        let mut halves = [Sort(a), Sort(b)];
        let mut tasks = halves.each_mut().map(|h| h as &mut dyn Task);
        hooks.run(&mut tasks);
        let [Sort(a), Sort(b)] = halves;
        let (mut i, mut j, mut cells, mut last) = (0, 0, 0, u64::MAX);
        for o in order.iter_mut() {
            let k = match (a.get(i), b.get(j)) {
                (Some(&x), Some(&y)) if x < y => {
                    i += 1;
                    x
                }
                (_, Some(&y)) => {
                    j += 1;
                    y
                }
                (Some(&x), None) => {
                    i += 1;
                    x
                }
                (None, None) => break,
            };
            *o = k as u32;
            if k >> 32 != last {
                (cells, last) = (cells + 1, k >> 32);
            }
        }
        return cells.max(1);
    }
    for (i, (k, p)) in keys.iter_mut().zip(points).enumerate() {
        *k = pack(grid.cell_of(*p));
        order[i] = i as u32;
    }
    order.sort_unstable_by(|&a, &b| (keys[a as usize], a).cmp(&(keys[b as usize], b)));
    1 + order
        .windows(2)
        .filter(|w| keys[w[0] as usize] != keys[w[1] as usize])
        .count()
}

fn build_grid<'s>(
    s: &'s crate::arena::Scratch<'_, '_>,
    points: &[V3],
    k: usize,
    hooks: &dyn Progress,
) -> Result<Grid<'s>> {
    let n = points.len();
    let Bounds { lo, hi, diag } = Bounds::of(points);
    let ext = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    let max_ext = ext[0].max(ext[1]).max(ext[2]);
    let order = s.try_alloc_slice::<u32>(n, 0)?;
    let sorted = s.try_alloc_slice::<V3>(n, [0.0; 3])?;
    let mut grid = Grid {
        lo,
        h: 1.0,
        dims: [1; 3],
        order: &[],
        sorted: &[],
        cell_keys: &[],
        cell_start: &[],
        columns: &[],
    };
    // Sort by cell in a nested scope: the keys are dropped before the tables are
    // built, which keeps this stage's peak below the clustering stage's.
    let cells = s.scratch(|inner| -> Result<usize> {
        let keys = inner.try_alloc_slice::<u64>(n, 0)?;
        // Aim for about k/2 points per occupied cell, so one ring usually
        // certifies. The first guess assumes a surface (occupied cells ~ area /
        // h^2), then the measured occupancy corrects it to within 0.8-1.25 of
        // the aim (the shared block: 3.7 points a cell at the first guess
        // left 28 % of its queries uncertified after ring 1; corrected, its
        // queries take 31 % fewer instructions, the raw scan's 24 %).
        let target = (k as f32 * 0.5).max(2.0);
        let min_h = (max_ext / (1u32 << 20) as f32).max(f32::MIN_POSITIVE);
        let mut h = (diag * libm::sqrtf(target / n as f32)).max(min_h);
        if !(h.is_finite() && h > 0.0) {
            h = 1.0;
        }
        let mut cells = 0usize;
        for attempt in 0..4 {
            grid.h = h;
            for a in 0..3 {
                grid.dims[a] = ((ext[a] / h) as u32).saturating_add(1).min(1 << 21);
            }
            cells = sort_by_cell(&grid, points, keys, order, true, hooks);
            let ratio = target / (n as f32 / cells as f32);
            if attempt == 3 || (0.8..=1.25).contains(&ratio) {
                break;
            }
            // Occupancy of a surface grows with h^2, of a volume with h^3: the
            // square root of the ratio moves h the right way in both cases.
            let next = (h * libm::sqrtf(ratio).clamp(0.25, 4.0)).max(min_h);
            if next == h {
                break;
            }
            h = next;
        }
        Ok(cells)
    })?;
    for (slot, &i) in order.iter().enumerate() {
        sorted[slot] = points[i as usize];
    }
    let cell_keys = s.try_alloc_slice::<u64>(cells, 0)?;
    let cell_start = s.try_alloc_slice::<u32>(cells + 1, 0)?;
    let mut c = 0usize;
    let mut n_columns = 0usize;
    for slot in 0..n {
        let key = pack(grid.cell_of(sorted[slot]));
        if slot == 0 || key != cell_keys[c - 1] {
            if c == 0 || key >> 21 != cell_keys[c - 1] >> 21 {
                n_columns += 1;
            }
            cell_keys[c] = key;
            cell_start[c] = slot as u32;
            c += 1;
        }
    }
    cell_start[cells] = n as u32;
    let columns =
        s.try_alloc_slice::<(u64, u32)>((2 * n_columns).next_power_of_two(), (EMPTY_KEY, 0))?;
    let mask = columns.len() - 1;
    for (cell, &key) in cell_keys.iter().enumerate() {
        let col = key >> 21;
        if cell > 0 && cell_keys[cell - 1] >> 21 == col {
            continue;
        }
        let mut slot = hash(col) as usize & mask;
        while columns[slot].0 != EMPTY_KEY {
            slot = (slot + 1) & mask;
        }
        columns[slot] = (col, cell as u32);
    }
    grid.order = order;
    grid.sorted = sorted;
    grid.cell_keys = cell_keys;
    grid.cell_start = cell_start;
    grid.columns = columns;
    Ok(grid)
}

/// Build the reverse-only edge table: which of each row's neighbours do not
/// list the point back, found once in parallel tasks run by `hooks` (a bit a
/// neighbour, k ≤ 32), then two passes over those bits: O(n k^2) in the
/// tasks, O(n k) on the calling thread. Scratch: two words a point.
fn reverse_edges_in<'a>(
    arena: &'a Arena,
    knn: &[u32],
    k: usize,
    room: &dyn Fn(usize) -> Result<()>,
    hooks: &dyn Progress,
) -> Result<(&'a [u32], &'a [u32])> {
    let n = knn.len() / k;
    let rev_start = arena.try_alloc_slice::<u32>(n + 1, 0)?;
    let is_mutual = |i: usize, j: usize| knn[j * k..(j + 1) * k].contains(&(i as u32));
    let rev = arena.scratch(|s| -> Result<&'a [u32]> {
        // Bit b of one_way[i]: knn row i's b-th neighbour does not list i.
        let one_way = s.try_alloc_slice::<u32>(n, 0)?;
        parallel::rows(hooks, one_way, 1, |items, bits: &mut [u32]| {
            for (i, bits) in items.zip(bits.iter_mut()) {
                for (b, &j) in knn[i * k..(i + 1) * k].iter().enumerate() {
                    if !is_mutual(i, j as usize) {
                        *bits |= 1 << b;
                    }
                }
            }
        });
        // The set bits only (a third of k a point, typically), lowest first.
        let one_way_of = |i: usize| {
            let row = &knn[i * k..(i + 1) * k];
            let mut bits = one_way[i];
            core::iter::from_fn(move || {
                let b = bits.trailing_zeros() as usize;
                bits &= bits.wrapping_sub(1);
                row.get(b).map(|&j| j as usize)
            })
        };
        for i in 0..n {
            for j in one_way_of(i) {
                rev_start[j + 1] += 1;
            }
        }
        for i in 0..n {
            rev_start[i + 1] += rev_start[i];
        }
        let total = rev_start[n] as usize;
        room(total)?;
        let rev = arena.try_alloc_slice::<u32>(total, 0)?;
        // Fill in increasing i, so each list comes out ascending.
        let cursor = s.try_alloc_copy::<u32>(&rev_start[..n])?;
        for i in 0..n {
            for j in one_way_of(i) {
                let c = &mut cursor[j];
                rev[*c as usize] = i as u32;
                *c += 1;
            }
        }
        Ok(rev)
    })?;
    Ok((rev_start, rev))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::{Claimed, Silent};
    use crate::rng::Rng;
    use core::mem::MaybeUninit;
    use std::vec;
    use std::vec::Vec;

    /// Sorting the points by cell in one word each gives the order of the
    /// sort by two lookups, on grids of a few cells and of more than 2^32
    /// (where only the lookups run), with points sharing cells.
    #[test]
    fn points_sorted_by_cell_in_one_word_come_in_the_order_of_the_lookups() {
        let mut rng = Rng::new(17);
        let cloud: Vec<V3> = (0..3000)
            .map(|i| {
                let c = if i % 3 == 0 { 40.0 } else { 0.0 };
                core::array::from_fn(|_| c + (rng.unit_f64() as f32) * 2.0)
            })
            .collect();
        for (h, dims, direct_runs) in [
            (0.25, [169, 169, 169], true),
            (0.5, [7, 5, 3], true),
            (0.5, [1 << 21, 1 << 21, 2], false),
        ] {
            let grid = Grid {
                lo: [0.0; 3],
                h,
                dims,
                order: &[],
                sorted: &[],
                cell_keys: &[],
                cell_start: &[],
                columns: &[],
            };
            let (mut k1, mut o1) = (vec![0u64; cloud.len()], vec![0u32; cloud.len()]);
            let (mut k2, mut o2) = (k1.clone(), o1.clone());
            let c1 = sort_by_cell(
                &grid,
                &cloud,
                &mut k1,
                &mut o1,
                true,
                &Claimed::backwards(2),
            );
            let c2 = sort_by_cell(&grid, &cloud, &mut k2, &mut o2, false, &Silent);
            assert_eq!((c1, &o1), (c2, &o2), "h {h}");
            // The word sort ran where the box fits 32 bits (its keys hold
            // the point's index in the low half).
            assert_eq!(k1.iter().all(|&k| (k as u32) < 3000), direct_runs, "h {h}");
            assert!(c1 > 1 && c1 < cloud.len(), "{c1} cells");
        }
    }

    fn brute(points: &[V3], k: usize) -> Vec<u32> {
        let mut out = Vec::new();
        for (i, &p) in points.iter().enumerate() {
            let mut c: Vec<(f32, u32)> = points
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(j, &q)| (dist2(p, q), j as u32))
                .collect();
            c.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            out.extend(c[..k].iter().map(|x| x.1));
        }
        out
    }

    fn check(points: &[V3], k: usize) {
        let mut buf = vec![MaybeUninit::uninit(); 64 * 1024 * 1024];
        let arena = Arena::new(&mut buf);
        let nb = try_neighbours_in(&arena, points, k, &mut Silent).unwrap();
        let expect = brute(points, k);
        assert_eq!(nb.knn, &expect[..], "k = {k}, n = {}", points.len());
        // Symmetrised graph: j ~ i iff one is in the other's list, each once.
        for i in 0..points.len() {
            let mut sym: Vec<u32> = nb.symmetric(i).collect();
            let len = sym.len();
            sym.sort_unstable();
            sym.dedup();
            assert_eq!(sym.len(), len, "duplicate symmetric neighbour of {i}");
            for j in 0..points.len() {
                let linked = nb.of(i).contains(&(j as u32)) || nb.of(j).contains(&(i as u32));
                assert_eq!(linked, sym.binary_search(&(j as u32)).is_ok(), "{i} ~ {j}");
            }
        }
    }

    fn random_cloud(n: usize, seed: u64) -> Vec<V3> {
        let mut rng = Rng::new(seed);
        (0..n)
            .map(|_| core::array::from_fn(|_| rng.unit_f64() as f32 * 2.0 - 1.0))
            .collect()
    }

    #[test]
    fn knn_equals_brute_force_on_random_clouds() {
        for (n, k, seed) in [(50, 1, 1), (300, 12, 2), (700, 32, 3), (13, 12, 4)] {
            check(&random_cloud(n, seed), k);
        }
    }

    #[test]
    fn knn_equals_brute_force_on_clustered_clouds() {
        // Tight blobs far apart, plus isolated points: exercises the ring growth
        // and the linear-scan fallback.
        let mut rng = Rng::new(7);
        let mut pts = Vec::new();
        for b in 0..5 {
            let c = [b as f32 * 0.4 - 1.0, (b % 2) as f32, 0.3];
            for _ in 0..120 {
                pts.push(core::array::from_fn(|a| {
                    c[a] + (rng.unit_f64() as f32 - 0.5) * 1e-3
                }));
            }
        }
        pts.push([1.0, 1.0, 1.0]);
        pts.push([-1.0, -1.0, -1.0]);
        check(&pts, 12);
    }

    /// A crowded cell: more points around it than a [`Batch`] holds, so
    /// its queries take the ring search, beside ones that take a batch.
    #[test]
    fn knn_equals_brute_force_where_a_cell_is_crowded() {
        let mut rng = Rng::new(9);
        let mut pts = random_cloud(600, 8);
        for _ in 0..BATCH + 100 {
            pts.push(core::array::from_fn(|_| {
                0.1 + (rng.unit_f64() as f32 - 0.5) * 1e-3
            }));
        }
        check(&pts, 12);
    }

    /// Over more than one wave of queries, each task starting where the
    /// one before stopped (mid-cell): the rows are those of a ring search
    /// from each point.
    #[test]
    fn rows_over_waves_equal_ring_searches() {
        let mut rng = Rng::new(12);
        let pts: Vec<V3> = (0..parallel::WAVE + 3000)
            .map(|_| {
                let (u, v) = (rng.unit_f64() as f32, rng.unit_f64() as f32);
                [u, v, 0.1 * (5.0 * u).sin() * (4.0 * v).cos()]
            })
            .collect();
        let k = 12;
        let mut buf = vec![MaybeUninit::uninit(); 64 * 1024 * 1024];
        let arena = Arena::new(&mut buf);
        let rows = try_knn_rows_in(&arena, &pts, k, Stage::Neighbours, &mut Silent).unwrap();
        arena.scratch(|s| {
            let grid = build_grid(s, &pts, k, &Silent).unwrap();
            for (i, &p) in pts.iter().enumerate() {
                let mut best = Best::new(k);
                assert!(ring_search(&grid, p, i as u32, &mut best, 0));
                assert_eq!(&rows.knn[i * k..(i + 1) * k], &best.idx[..k], "row {i}");
            }
        });
    }

    #[test]
    fn knn_equals_brute_force_with_many_duplicates_and_ties() {
        // A lattice has many equal distances; every point appears three times.
        let mut pts = Vec::new();
        for x in 0..6 {
            for y in 0..6 {
                for _copy in 0..3 {
                    pts.push([x as f32 * 0.1, y as f32 * 0.1, 0.0]);
                }
            }
        }
        check(&pts, 12);
        check(&pts, 2);
    }

    /// Where most searches end in the first ring and pass over its far
    /// cells: jittered and lattice samples of a surface, at the origin and
    /// far from it (coordinates whose rounding is near the point spacing).
    #[test]
    fn knn_equals_brute_force_on_surfaces_near_and_far_from_the_origin() {
        let mut rng = Rng::new(11);
        for offset in [[0.0f32; 3], [1000.0, -2000.0, 500.0]] {
            let mut pts: Vec<V3> = (0..1500)
                .map(|_| {
                    let (u, v) = (rng.unit_f64() as f32, rng.unit_f64() as f32);
                    let z = 0.2 * (4.0 * u).sin() * (3.0 * v).cos();
                    [offset[0] + u, offset[1] + v, offset[2] + z]
                })
                .collect();
            for x in 0..20 {
                for y in 0..20 {
                    pts.push([
                        offset[0] + x as f32 / 16.0,
                        offset[1] + y as f32 / 16.0,
                        offset[2],
                    ]);
                }
            }
            check(&pts, 12);
            check(&pts, 5);
        }
    }

    #[test]
    fn spacing_is_the_mean_neighbour_distance() {
        // A square lattice of step 0.01: the 4 nearest are all at 0.01.
        let mut pts = Vec::new();
        for x in 0..40 {
            for y in 0..40 {
                pts.push([x as f32 * 0.01, y as f32 * 0.01, 0.5]);
            }
        }
        let mut buf = vec![MaybeUninit::uninit(); 8 << 20];
        let arena = Arena::new(&mut buf);
        let nb = try_neighbours_in(&arena, &pts, 4, &mut Silent).unwrap();
        // Corner and edge points also have their 4 nearest at 0.01 except corners
        // (0.01, 0.01, then diagonal 0.01414 twice... no: two at 0.01, two at 0.02).
        assert!((nb.spacing - 0.01).abs() < 2e-4, "{}", nb.spacing);
    }

    /// The bound's worst case for the reverse-only table (`k` entries a point)
    /// is reached, not only approached, by an ordinary defect: one point
    /// stored many times. Ties go by index, so every copy past the first
    /// `k + 1` lists the first `k`, none of which lists it back. So no bound
    /// below `k n` holds for every cloud.
    #[test]
    fn copies_of_one_point_reach_the_reverse_tables_worst_case() {
        let (n, k) = (1000, 12);
        let pts = vec![[0.25f32, -0.5, 0.75]; n];
        let mut buf = vec![MaybeUninit::uninit(); 1 << 20];
        let arena = Arena::new(&mut buf);
        let nb = try_neighbours_in(&arena, &pts, k, &mut Silent).unwrap();
        assert_eq!(nb.rev.len(), (n - k - 1) * k);
        let (_, kept) = neighbours_bytes(n, k);
        let used = padded_bytes::<u32>(n * k) + padded_bytes::<u32>(n + 1);
        assert!(used + padded_bytes::<u32>(nb.rev.len()) <= kept);
        assert!(nb.rev.len() * 100 >= n * k * 98, "within 2 % of the bound");
    }

    #[test]
    fn bad_k_is_an_error() {
        let pts = random_cloud(5, 1);
        let mut buf = vec![MaybeUninit::uninit(); 1 << 16];
        let arena = Arena::new(&mut buf);
        for k in [0, 5, 6, 33] {
            assert!(matches!(
                try_neighbours_in(&arena, &pts, k, &mut Silent),
                Err(Error::BadNeighbours { .. })
            ));
        }
    }
}
