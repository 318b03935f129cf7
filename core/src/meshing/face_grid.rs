//! A sparse uniform grid over the faces of a mesh: which faces come near a point
//! or a box, without a scan of all faces. The point-to-mesh distances and the
//! self-intersection test both query it.
//!
//! Every face is entered in each cell its bounding box overlaps, beside each
//! face's bounding box (24 bytes), so that a query rules most faces out without
//! reading their corners. The cell size starts at the mean bounding-box extent
//! of the faces and doubles until the entries number at most
//! [`ENTRIES_PER_FACE`] per face and the grid at most [`MAX_CELLS_PER_AXIS`]
//! cells along an axis. The entries take one of two layouts, 8 bytes an entry
//! at most either way, so memory is at most `8 × ENTRIES_PER_FACE + 24` bytes
//! per face whatever the faces' shapes:
//!
//! - *dense*, when the grid has fewer cells than entries (a mesh of a few
//!   thousand faces): each cell's faces listed cell after cell (4 bytes an
//!   entry) and where each cell's list begins (4 bytes a cell), made by a
//!   counting sort; a cell's faces are found at once;
//! - *sparse*, otherwise: one sorted array of `(cell << 32) | face` keys, so
//!   a cell's faces are one run, found by binary search.
//!
//! Both list a cell's faces in ascending order and the cells in the same
//! order, so every answer is the same whichever layout the grid takes.
//!
//! Cost: building, O(E + C) dense and O(E log E) sparse for E entries and C
//! cells (the boxes, the count of entries and the dense layout's counting
//! sort in parallel tasks, the sort by runs of x-slices of the cells, one a
//! thread; the same grid on every thread count); a nearest-face query,
//! O(faces in the rings searched), times log E sparse; it falls back to a
//! scan of all faces when a ring would hold more cells than there are faces,
//! so a query never costs more than O(F) beyond that.

use crate::arena::Alloc;
use crate::error::Result;
use crate::math::point_triangle_dist2;
use crate::math::V3;
use crate::parallel;
use crate::parallel::Task;
use crate::progress::Progress;
use core::ops::Range;

/// Entries (face, cell) per face at most, on average.
pub const ENTRIES_PER_FACE: usize = 8;
/// Cells along an axis at most (10 bits of the packed cell key per axis).
pub const MAX_CELLS_PER_AXIS: u32 = 1 << 10;

/// The grid. Cell `(x, y, z)` holds the faces whose bounding box overlaps
/// `origin + h [x, x+1) × [y, y+1) × [z, z+1)`.
#[derive(Clone, Copy)]
pub struct FaceGrid<'a> {
    /// Sparse layout: sorted `(cell key << 32) | face` entries (empty when
    /// dense).
    entries: &'a [u64],
    /// Dense layout: where each cell's faces begin in `listed`, by cell index
    /// `(x dims[1] + y) dims[2] + z`, then the entry count (empty when
    /// sparse).
    starts: &'a [u32],
    /// Dense layout: the faces of each cell, cell after cell, ascending in a
    /// cell (empty when sparse).
    listed: &'a [u32],
    /// Each face's bounding box (empty, lowest above highest, for a face left
    /// out), so that a query rules most faces out without their corners.
    boxes: &'a [(V3, V3)],
    /// Lowest corner of the grid.
    origin: V3,
    /// Cell size (> 0).
    h: f32,
    /// Cells along each axis (each in `1..=MAX_CELLS_PER_AXIS`).
    dims: [u32; 3],
    /// The mesh's vertices.
    vertices: &'a [V3],
    /// The mesh's faces.
    faces: &'a [[u32; 3]],
}

/// Corners of face `f`, or `None` when an index is out of range or a
/// coordinate is not finite (such faces are left out of the grid).
fn corners(vertices: &[V3], face: [u32; 3]) -> Option<[V3; 3]> {
    let t = [
        *vertices.get(face[0] as usize)?,
        *vertices.get(face[1] as usize)?,
        *vertices.get(face[2] as usize)?,
    ];
    t.iter().flatten().all(|v| v.is_finite()).then_some(t)
}

/// Bounding box of three points.
fn bbox(t: &[V3; 3]) -> (V3, V3) {
    let mut lo = t[0];
    let mut hi = t[0];
    for p in &t[1..] {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (lo, hi)
}

fn pack(c: [u32; 3]) -> u64 {
    ((c[0] as u64) << 20) | ((c[1] as u64) << 10) | c[2] as u64
}

/// The faces of one cell, in either layout.
#[derive(Clone, Copy)]
enum Run<'a> {
    Keys(&'a [u64]),
    Faces(&'a [u32]),
}

impl Run<'_> {
    fn len(&self) -> usize {
        match self {
            Run::Keys(k) => k.len(),
            Run::Faces(f) => f.len(),
        }
    }

    fn get(&self, i: usize) -> Option<u32> {
        match self {
            Run::Keys(k) => k.get(i).map(|&e| e as u32),
            Run::Faces(f) => f.get(i).copied(),
        }
    }
}

/// Most runs of x-slices a dense grid's counting sort is cut into.
const MAX_PARTS: usize = 8;

/// One run of x-slices of a dense grid's cells, as a parallel task: it
/// counts the entries of its cells (`starts`, from cell `first`), or, with
/// `fill`, fills its cells' lists (`listed`, from position `base` of the
/// whole list) from their ends, the faces from the last, as the counting
/// sort on one thread does.
struct Slices<'g, 'a> {
    grid: &'g FaceGrid<'a>,
    x: Range<u32>,
    first: usize,
    starts: &'g mut [u32],
    listed: &'g mut [u32],
    base: usize,
    fill: bool,
}

impl Task for Slices<'_, '_> {
    fn run(&mut self) {
        let grid = self.grid;
        if self.x.is_empty() {
            return;
        }
        let (x, first, base) = (self.x.clone(), self.first, self.base);
        let [_, dy, dz] = grid.dims.map(|d| d as usize);
        let (starts, listed, fill) = (&mut *self.starts, &mut *self.listed, self.fill);
        let mut visit = |f: usize| {
            let Some((c0, c1)) = grid.cell_range(f) else {
                return;
            };
            for cx in c0[0].max(x.start)..=c1[0].min(x.end - 1) {
                for cy in c0[1]..=c1[1] {
                    // The cells of this x and y: one run of the part's counts.
                    let at = (cx as usize * dy + cy as usize) * dz;
                    let Some(run) = (at + c0[2] as usize)
                        .checked_sub(first)
                        .and_then(|lo| starts.get_mut(lo..lo + (c1[2] - c0[2]) as usize + 1))
                    else {
                        continue;
                    };
                    if !fill {
                        run.iter_mut().for_each(|s| *s += 1);
                        continue;
                    }
                    for s in run {
                        *s = s.saturating_sub(1);
                        if let Some(slot) = (*s as usize)
                            .checked_sub(base)
                            .and_then(|i| listed.get_mut(i))
                        {
                            *slot = f as u32;
                        }
                    }
                }
            }
        };
        if fill {
            (0..grid.faces.len()).rev().for_each(&mut visit);
        } else {
            (0..grid.faces.len()).for_each(&mut visit);
        }
    }
}

impl<'a> FaceGrid<'a> {
    /// The grid of `faces` over `vertices`, in memory from `alloc`, built in
    /// parallel tasks of `hooks`. Faces with an index out of range or a
    /// non-finite corner are left out (never found).
    pub fn try_new_in<'b, A: Alloc<'b>>(
        alloc: &'a A,
        vertices: &'a [V3],
        faces: &'a [[u32; 3]],
        hooks: &dyn Progress,
    ) -> Result<FaceGrid<'a>> {
        Self::try_build_in(alloc, vertices, faces, true, hooks)
    }

    /// [`FaceGrid::try_new_in`], in the dense layout when `dense` and the
    /// grid has fewer cells than entries, else sparse.
    fn try_build_in<'b, A: Alloc<'b>>(
        alloc: &'a A,
        vertices: &'a [V3],
        faces: &'a [[u32; 3]],
        dense: bool,
        hooks: &dyn Progress,
    ) -> Result<FaceGrid<'a>> {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        let mut extent = 0.0f64;
        let mut counted = 0usize;
        let empty = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        // The boxes in parallel tasks, then the bounds and the mean extent
        // summed face after face (the same sum on every thread count).
        let boxes = alloc.try_alloc_from_fn_on(
            faces.len(),
            |f| {
                faces
                    .get(f)
                    .and_then(|&face| corners(vertices, face))
                    .map_or(empty, |t| bbox(&t))
            },
            hooks,
        )?;
        for &(a, b) in boxes.iter() {
            if !(0..3).all(|k| a[k] <= b[k]) {
                continue;
            }
            for k in 0..3 {
                lo[k] = lo[k].min(a[k]);
                hi[k] = hi[k].max(b[k]);
                extent += (b[k] - a[k]) as f64;
            }
            counted += 1;
        }
        let mut grid = FaceGrid {
            entries: &[],
            starts: &[],
            listed: &[],
            boxes,
            origin: lo,
            h: 1.0,
            dims: [1; 3],
            vertices,
            faces,
        };
        if counted == 0 {
            return Ok(grid);
        }
        let span = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f32, f32::max);
        let floor = span / MAX_CELLS_PER_AXIS as f32;
        let mut h = ((extent / (3 * counted) as f64) as f32).max(floor);
        if h.is_nan() || h <= 0.0 || !h.is_finite() {
            h = if span > 0.0 && span.is_finite() {
                span
            } else {
                1.0
            };
        }
        let cap = counted.saturating_mul(ENTRIES_PER_FACE);
        let total = loop {
            grid.h = h;
            grid.dims = core::array::from_fn(|k| grid.cell_of_coord(hi[k], k) + 1);
            let total = grid.count_entries(hooks);
            if total <= cap && grid.dims.iter().all(|&d| d <= MAX_CELLS_PER_AXIS) {
                break total;
            }
            h *= 2.0;
        };
        let cells = grid
            .dims
            .iter()
            .fold(1usize, |n, &d| n.saturating_mul(d as usize));
        let fits_u32 = total
            .checked_add(cells)
            .is_some_and(|x| x < u32::MAX as usize);
        if dense && cells < total && fits_u32 {
            // A counting sort: each cell's count, their running sums (where
            // each cell's list ends), then the faces from the last, each
            // cell's list filled from its end, so ascending in a cell. The
            // cells are cut into runs of x-slices, one a thread ([`Slices`]):
            // each run's counts and lists are its own part of the arrays.
            let all = alloc.try_alloc_slice::<u32>(total + cells + 1, 0)?;
            let (listed, starts) = all.split_at_mut(total);
            grid.sort_pass(&mut starts[..cells], None, hooks);
            let mut sum = 0u32;
            for s in starts.iter_mut() {
                sum = sum.saturating_add(*s);
                *s = sum;
            }
            grid.sort_pass(&mut starts[..cells], Some(listed), hooks);
            grid.starts = starts;
            grid.listed = listed;
            return Ok(grid);
        }
        let entries = alloc.try_alloc_slice::<u64>(total, 0)?;
        let mut w = 0;
        for f in 0..faces.len() {
            grid.for_cells_of(f, |c| {
                entries[w] = (pack(c) << 32) | f as u64;
                w += 1;
            });
        }
        entries.sort_unstable();
        grid.entries = entries;
        Ok(grid)
    }

    /// One pass of the dense layout's counting sort over runs of x-slices
    /// ([`Slices`]), one a thread of `hooks` ([`MAX_PARTS`] at most): the
    /// counts into `starts` (the cells' counts) without `listed`, else, with
    /// `starts` the ends of the cells' lists, each run's lists filled into its
    /// part of `listed` (from where its first cell's list begins to where its
    /// last cell's ends).
    fn sort_pass(&self, starts: &mut [u32], listed: Option<&mut [u32]>, hooks: &dyn Progress) {
        let parts = hooks
            .threads()
            .clamp(1, MAX_PARTS)
            .min(self.dims[0] as usize);
        let slice = self.dims[1] as usize * self.dims[2] as usize;
        let x_at = |j: usize| (j * self.dims[0] as usize / parts) as u32;
        let fill = listed.is_some();
        let end_before = |c: usize| match c.checked_sub(1) {
            Some(c) if fill => starts.get(c).map_or(0, |&e| e as usize),
            _ => 0,
        };
        let bounds: [usize; MAX_PARTS + 1] =
            core::array::from_fn(|j| end_before(x_at(j.min(parts)) as usize * slice));
        let listed = listed.unwrap_or(&mut []);
        let (mut rest_s, mut rest_l) = (starts, listed);
        let mut jobs: [Slices; MAX_PARTS] = core::array::from_fn(|j| {
            let x = if j < parts {
                x_at(j)..x_at(j + 1)
            } else {
                0..0
            };
            let n = (x.len() * slice).min(rest_s.len());
            let (own, tail) = core::mem::take(&mut rest_s).split_at_mut(n);
            rest_s = tail;
            let m = if fill && j < parts {
                bounds[j + 1] - bounds[j]
            } else {
                0
            };
            let m = m.min(rest_l.len());
            let (list, tail) = core::mem::take(&mut rest_l).split_at_mut(m);
            rest_l = tail;
            Slices {
                grid: self,
                first: x.start as usize * slice,
                x,
                starts: own,
                listed: list,
                base: bounds[j.min(parts)],
                fill,
            }
        });
        let mut tasks = jobs.each_mut().map(|j| j as &mut dyn Task);
        hooks.run(&mut tasks[..parts]);
    }

    /// Cell `c`'s index in the dense layout (`(x dims[1] + y) dims[2] + z`).
    fn index(&self, c: [u32; 3]) -> usize {
        let [_, dy, dz] = self.dims.map(|d| d as usize);
        (c[0] as usize * dy + c[1] as usize) * dz + c[2] as usize
    }

    /// Cell `c`'s identity in the grid's layout: its index dense, its key
    /// sparse (both ascend in the order of the cells).
    fn id(&self, c: [u32; 3]) -> u64 {
        if self.starts.is_empty() {
            pack(c)
        } else {
            self.index(c) as u64
        }
    }

    /// Entries (face, cell) of the grid.
    fn entry_count(&self) -> usize {
        self.entries.len() + self.listed.len()
    }

    /// The cell coordinate of `v` along axis `k`, clamped to the grid.
    fn cell_of_coord(&self, v: f32, k: usize) -> u32 {
        let c = (v - self.origin[k]) / self.h;
        if c >= 0.0 {
            (c as u32).min(MAX_CELLS_PER_AXIS * 2)
        } else {
            0
        }
    }

    /// Face `face`'s bounding box, or `None` for a face left out (its box
    /// empty).
    fn face_box(&self, face: usize) -> Option<(V3, V3)> {
        let &(lo, hi) = self.boxes.get(face)?;
        (0..3).all(|k| lo[k] <= hi[k]).then_some((lo, hi))
    }

    /// The cells face `face`'s bounding box overlaps, as an inclusive range,
    /// or `None` for a face left out.
    #[inline(always)]
    fn cell_range(&self, face: usize) -> Option<([u32; 3], [u32; 3])> {
        let (lo, hi) = self.face_box(face)?;
        Some(self.cells_of_box(lo, hi))
    }

    /// Calls `f` with every cell face `face`'s bounding box overlaps.
    fn for_cells_of(&self, face: usize, mut f: impl FnMut([u32; 3])) {
        let Some((c0, c1)) = self.cell_range(face) else {
            return;
        };
        for x in c0[0]..=c1[0] {
            for y in c0[1]..=c1[1] {
                for z in c0[2]..=c1[2] {
                    f([x, y, z]);
                }
            }
        }
    }

    /// Entries the current cell size gives (saturating), counted in
    /// parallel tasks of `hooks`.
    fn count_entries(&self, hooks: &dyn Progress) -> usize {
        let counts = parallel::ranges(hooks, self.faces.len(), |faces| {
            let mut total = 0usize;
            for face in faces {
                if let Some((c0, c1)) = self.cell_range(face) {
                    let cells = (0..3).fold(1usize, |n, k| {
                        n.saturating_mul((c1[k] - c0[k]) as usize + 1)
                    });
                    total = total.saturating_add(cells);
                }
            }
            total
        });
        counts.iter().fold(0usize, |a, &b| a.saturating_add(b))
    }

    /// The faces entered in cell `c` (each at most once), ascending.
    pub fn cell(&self, c: [u32; 3]) -> impl Iterator<Item = u32> + 'a {
        let run = self.run(c);
        (0..run.len()).filter_map(move |i| run.get(i))
    }

    /// The faces of cell `c` (none outside the grid).
    fn run(&self, c: [u32; 3]) -> Run<'a> {
        if (0..3).any(|k| c[k] >= self.dims[k]) {
            return Run::Faces(&[]);
        }
        if self.starts.is_empty() {
            let key = pack(c);
            let entries = self.entries;
            let start = entries.partition_point(|&e| (e >> 32) < key);
            let len = entries[start..]
                .iter()
                .take_while(|&&e| (e >> 32) == key)
                .count();
            return Run::Keys(&entries[start..start + len]);
        }
        let i = self.index(c);
        let listed = match (self.starts.get(i), self.starts.get(i + 1)) {
            (Some(&b), Some(&e)) => self.listed.get(b as usize..e as usize),
            _ => None,
        };
        Run::Faces(listed.unwrap_or(&[]))
    }

    /// Grid dimensions.
    pub fn dims(&self) -> [u32; 3] {
        self.dims
    }

    /// The range of cells the box `[lo, hi]` overlaps, clamped to the grid.
    pub fn cells_of_box(&self, lo: V3, hi: V3) -> ([u32; 3], [u32; 3]) {
        let c0 = core::array::from_fn(|k| self.cell_of_coord(lo[k], k).min(self.dims[k] - 1));
        let c1 = core::array::from_fn(|k| self.cell_of_coord(hi[k], k).min(self.dims[k] - 1));
        (c0, c1)
    }

    /// Calls `f(a, b)`, `a < b`, once for every pair of faces whose bounding
    /// boxes overlap (touching counts), in the order of the grid's cells. Each
    /// pair is reported in one cell only: the one holding the lowest corner of
    /// the two boxes' overlap. O(Σ over cells of its faces²).
    pub fn for_each_overlapping_pair(&self, f: impl FnMut(u32, u32)) {
        self.pairs_in_cells(0..self.entry_count(), f);
    }

    /// The overlapping pairs that pass `test` (see
    /// [`FaceGrid::for_each_overlapping_pair`]), handed to `found` in the
    /// order of the cells as there: parallel tasks run by `hooks` count them,
    /// each over the cells that begin in its share of the entries, and only
    /// the cells of a task that found some are tested again on the calling
    /// thread to hand them over. For rare pairs, such as crossing faces: a
    /// count a task keeps the stack small (core runs in 16 KiB of stack).
    pub fn overlapping_pairs_where(
        &self,
        hooks: &dyn Progress,
        test: impl Fn(u32, u32) -> bool + Sync,
        mut found: impl FnMut(u32, u32),
    ) {
        let n = self.entry_count();
        let counts = parallel::ranges(hooks, n, |items| {
            let mut count = 0u32;
            self.pairs_in_cells(items, |a, b| count += u32::from(test(a, b)));
            count
        });
        for (t, &count) in counts.iter().enumerate() {
            if count > 0 {
                self.pairs_in_cells(parallel::range(n, t), |a, b| {
                    if test(a, b) {
                        found(a, b)
                    }
                });
            }
        }
    }

    /// [`FaceGrid::for_each_overlapping_pair`] over the cells whose first entry
    /// is in `range` of the entries.
    fn pairs_in_cells(&self, range: Range<usize>, mut f: impl FnMut(u32, u32)) {
        if self.starts.is_empty() {
            let key_at = |i: usize| self.entries[i] >> 32;
            let mut i = range.start;
            while i > 0 && i < range.end && key_at(i) == key_at(i - 1) {
                i += 1;
            }
            while i < range.end {
                let key = key_at(i);
                let run = self.entries[i..]
                    .iter()
                    .take_while(|&&e| e >> 32 == key)
                    .count();
                self.pairs_in_run(key, Run::Keys(&self.entries[i..i + run]), &mut f);
                i += run;
            }
            return;
        }
        let cells = self.starts.len() - 1;
        let mut c = self.starts[..cells].partition_point(|&s| (s as usize) < range.start);
        while c < cells && (self.starts[c] as usize) < range.end {
            let (b, e) = (self.starts[c] as usize, self.starts[c + 1] as usize);
            if let Some(listed) = self.listed.get(b..e).filter(|l| !l.is_empty()) {
                self.pairs_in_run(c as u64, Run::Faces(listed), &mut f);
            }
            c += 1;
        }
    }

    /// The overlapping pairs of the faces `cell` of the cell `id` (see
    /// [`FaceGrid::id`]) whose overlap's lowest corner lies in that cell.
    fn pairs_in_run(&self, id: u64, cell: Run, f: &mut impl FnMut(u32, u32)) {
        let boxed = |face: u32| self.face_box(face as usize);
        for x in 0..cell.len() {
            let Some((a, (alo, ahi))) = cell.get(x).and_then(|a| Some((a, boxed(a)?))) else {
                continue;
            };
            for y in x + 1..cell.len() {
                let Some((b, (blo, bhi))) = cell.get(y).and_then(|b| Some((b, boxed(b)?))) else {
                    continue;
                };
                if (0..3).any(|k| alo[k] > bhi[k] || blo[k] > ahi[k]) {
                    continue;
                }
                let lo: V3 = core::array::from_fn(|k| alo[k].max(blo[k]));
                let (first, _) = self.cells_of_box(lo, lo);
                if self.id(first) == id {
                    f(a.min(b), a.max(b));
                }
            }
        }
    }

    /// Offers face `f` to `best`, the nearest face to `p` so far and its
    /// squared distance (the lower index among equals). Always inlined: as a
    /// call it cost the queries 8 % more instructions (callgrind).
    #[inline(always)]
    fn offer(&self, p: V3, f: u32, best: &mut Option<(u32, f32)>) {
        // A face whose box is no nearer than the best cannot win.
        if let (Some((_, e)), Some((lo, hi))) = (*best, self.boxes.get(f as usize)) {
            let gap2: f32 = (0..3)
                .map(|k| {
                    let d = (lo[k] - p[k]).max(p[k] - hi[k]).max(0.0);
                    d * d
                })
                .sum();
            if gap2 > e {
                return;
            }
        }
        let Some(t) = self
            .faces
            .get(f as usize)
            .and_then(|&t| corners(self.vertices, t))
        else {
            return;
        };
        let d2 = point_triangle_dist2(p, t[0], t[1], t[2]);
        let better = match *best {
            None => true,
            Some((g, e)) => d2 < e || (d2 == e && f < g),
        };
        if better && d2.is_finite() {
            *best = Some((f, d2));
        }
    }

    /// The face nearest to `p` and its squared distance (exact point-triangle
    /// distance; ties go to the lower face index), or `None` without faces.
    pub fn nearest(&self, p: V3) -> Option<(u32, f32)> {
        self.nearest_from(p, None)
    }

    /// [`FaceGrid::nearest`], starting from face `hint` (a face near `p`, such
    /// as its nearest before the vertices moved a little): its distance
    /// prunes every cell farther away, so a good hint leaves one or two cells
    /// to search. The answer is the nearest face whatever the hint; among
    /// faces at exactly the same distance it may differ.
    pub fn nearest_from(&self, p: V3, hint: Option<u32>) -> Option<(u32, f32)> {
        if self.entry_count() == 0 || !p.iter().all(|v| v.is_finite()) {
            return None;
        }
        let mut best: Option<(u32, f32)> = None;
        let offer = |f: u32, best: &mut Option<(u32, f32)>| self.offer(p, f, best);
        if let Some(h) = hint {
            offer(h, &mut best);
        }
        // The point's cell, unclamped (it may lie outside the grid).
        let cell: [i64; 3] =
            core::array::from_fn(|k| floor_clamped((p[k] - self.origin[k]) / self.h));
        // Rings that cannot reach the grid hold nothing: start at the first that can.
        let gap = (0..3)
            .map(|k| {
                let d = self.dims[k] as i64;
                if cell[k] < 0 {
                    -cell[k]
                } else if cell[k] >= d {
                    cell[k] - d + 1
                } else {
                    0
                }
            })
            .max()
            .unwrap_or(0);
        let reach = self.dims.iter().map(|&d| d as i64).max().unwrap_or(1) + gap;
        // How far the point is inside its own cell (0 outside the grid).
        let inset = if gap > 0 {
            0.0
        } else {
            (0..3)
                .map(|k| {
                    let lo = self.origin[k] + cell[k] as f32 * self.h;
                    (p[k] - lo).min(lo + self.h - p[k]).max(0.0)
                })
                .fold(f32::INFINITY, f32::min)
        };
        let mut r = gap;
        loop {
            // Cells in ring r: (2r+1)^3 - (2r-1)^3; past the faces' count, scan.
            let ring_cells = 24 * r * r + 2;
            if ring_cells > self.faces.len() as i64 + 64 {
                for f in 0..self.faces.len() as u32 {
                    offer(f, &mut best);
                }
                return best;
            }
            let found = core::cell::Cell::new(best);
            self.visit_ring(
                p,
                cell,
                r,
                || found.get().map_or(f32::INFINITY, |(_, d2)| d2),
                |f| {
                    let mut b = found.get();
                    offer(f, &mut b);
                    found.set(b);
                },
            );
            best = found.get();
            // Every face not yet seen lies outside the block of rings 0..=r:
            // at least r h plus the point's inset in its own cell away.
            let bound = r as f32 * self.h + inset;
            match best {
                Some((_, d2)) if d2 <= bound * bound => return best,
                _ if r > reach => return best,
                _ => {}
            }
            r += 1;
        }
    }

    /// Calls `f` for every face entered in a cell at Chebyshev distance exactly
    /// `r` from `c` (cells outside the grid hold nothing) whose box is nearer to
    /// `p` than `sqrt(near2())` (asked again before each cell, so a nearer face
    /// found on the way prunes the rest).
    fn visit_ring(
        &self,
        p: V3,
        c: [i64; 3],
        r: i64,
        near2: impl Fn() -> f32,
        mut f: impl FnMut(u32),
    ) {
        let inside = |v: i64, k: usize| v >= 0 && v < self.dims[k] as i64;
        // Squared distance from p to cell v's slab along axis k.
        let gap2 = |v: i64, k: usize| {
            let lo = self.origin[k] + v as f32 * self.h;
            let d = (lo - p[k]).max(p[k] - (lo + self.h)).max(0.0);
            d * d
        };
        for x in c[0] - r..=c[0] + r {
            if !inside(x, 0) {
                continue;
            }
            let gx = gap2(x, 0);
            for y in c[1] - r..=c[1] + r {
                if !inside(y, 1) {
                    continue;
                }
                let gxy = gx + gap2(y, 1);
                let edge = (x - c[0]).abs() == r || (y - c[1]).abs() == r;
                let mut z = c[2] - r;
                while z <= c[2] + r {
                    if inside(z, 2) && gxy + gap2(z, 2) < near2() {
                        for face in self.cell([x as u32, y as u32, z as u32]) {
                            f(face);
                        }
                    }
                    // Inside the ring's x-y border only its two z faces count.
                    z += if edge || r == 0 { 1 } else { 2 * r };
                }
            }
        }
    }
}

/// `floor(t)` clamped to ±2^30, as an integer (0 for NaN): what
/// `libm::floorf(t).clamp(-2^30, 2^30) as i64` gives, inline. libm's
/// `floorf` is a call of about twenty instructions, three of them a
/// nearest-face query (450 thousand calls a bunny run).
#[inline(always)]
fn floor_clamped(t: f32) -> i64 {
    // Clamped first: the bounds are whole numbers, so the floor commutes
    // with the clamp, and every value left converts to i64 exactly.
    let t = t.clamp(-(1 << 30) as f32, (1 << 30) as f32);
    let c = t as i64;
    c - i64::from(c as f32 > t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arena::Arena;
    use crate::progress::{Backwards, Claimed, Silent};
    use crate::rng::Rng;
    use std::mem::MaybeUninit;
    use std::vec;
    use std::vec::Vec;

    #[test]
    fn floor_clamped_is_libm_floor_clamped() {
        let libm_way = |t: f32| libm::floorf(t).clamp(-(1 << 30) as f32, (1 << 30) as f32) as i64;
        let mut cases = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            -1.5,
            2.999_999_8,
            -2.999_999_8,
            8_388_607.5,
            -8_388_607.5,
            16_777_217.0,
            1e9,
            -1e9,
            1.5e9,
            -1.5e9,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1e-45,
            -1e-45,
        ];
        let mut rng = Rng::new(3);
        for _ in 0..100_000 {
            cases.push((rng.unit_f64() as f32 - 0.5) * 2000.0);
            cases.push(f32::from_bits(rng.next_u64() as u32));
        }
        for t in cases {
            assert_eq!(floor_clamped(t), libm_way(t), "{t:e}");
        }
    }

    fn soup(seed: u64, n: usize) -> (Vec<V3>, Vec<[u32; 3]>) {
        let mut rng = Rng::new(seed);
        let mut v = Vec::new();
        let mut f = Vec::new();
        for i in 0..n {
            let c: V3 = core::array::from_fn(|_| rng.unit_f64() as f32 * 2.0 - 1.0);
            let s = if i % 7 == 0 { 0.5 } else { 0.05 };
            for _ in 0..3 {
                v.push(core::array::from_fn(|k| {
                    c[k] + (rng.unit_f64() as f32 - 0.5) * s
                }));
            }
            let b = 3 * i as u32;
            f.push([b, b + 1, b + 2]);
        }
        (v, f)
    }

    /// A wavy sheet of `m` by `m` squares, two faces each: a surface, whose
    /// grid has fewer cells than entries.
    fn sheet(m: usize) -> (Vec<V3>, Vec<[u32; 3]>) {
        let at = |i: usize, j: usize| (i * (m + 1) + j) as u32;
        let mut v = Vec::new();
        for i in 0..=m {
            for j in 0..=m {
                let (x, y) = (i as f32 / m as f32, j as f32 / m as f32);
                v.push([x, y, 0.05 * libm::sinf(7.0 * x) * libm::cosf(5.0 * y)]);
            }
        }
        let mut f = Vec::new();
        for i in 0..m {
            for j in 0..m {
                f.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                f.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        (v, f)
    }

    /// The layouts: the sheet is dense and the soup sparse unless forced.
    #[test]
    fn a_surface_takes_the_dense_layout_and_a_sparse_grid_the_sorted_one() {
        let mut buf = vec![MaybeUninit::uninit(); 1 << 21];
        let arena = Arena::new(&mut buf);
        let (v, f) = sheet(40);
        let dense = FaceGrid::try_new_in(&arena, &v, &f, &Silent).unwrap();
        assert!(!dense.starts.is_empty() && dense.entries.is_empty());
        assert_eq!(
            dense.starts.len(),
            dense.dims.iter().product::<u32>() as usize + 1
        );
        assert!(dense.starts.len() <= dense.listed.len());
        let sorted = FaceGrid::try_build_in(&arena, &v, &f, false, &Silent).unwrap();
        assert!(sorted.starts.is_empty() && !sorted.entries.is_empty());
        assert_eq!(dense.entry_count(), sorted.entry_count());
        let (v, f) = soup(3, 400);
        let grid = FaceGrid::try_new_in(&arena, &v, &f, &Silent).unwrap();
        assert!(
            grid.starts.is_empty(),
            "the soup's grid has more cells than entries"
        );
    }

    /// The dense grid's counting sort cut into runs of x-slices, one a
    /// thread, run in any order: the same counts and lists as on one thread.
    #[test]
    fn a_dense_grid_built_on_several_threads_is_the_one_built_on_one() {
        let mut buf = vec![MaybeUninit::uninit(); 1 << 22];
        let arena = Arena::new(&mut buf);
        for (v, f) in [sheet(40), sheet(7), sheet(1)] {
            let one = FaceGrid::try_new_in(&arena, &v, &f, &Silent).unwrap();
            assert!(!one.starts.is_empty());
            for threads in [2, 3, 8] {
                let forwards = Claimed {
                    backwards: false,
                    ..Claimed::backwards(threads)
                };
                for many in [forwards, Claimed::backwards(threads)] {
                    let grid = FaceGrid::try_new_in(&arena, &v, &f, &many).unwrap();
                    assert_eq!(grid.dims, one.dims);
                    assert_eq!(grid.starts, one.starts, "{threads} threads");
                    assert_eq!(grid.listed, one.listed, "{threads} threads");
                }
            }
        }
    }

    /// Both layouts list the same faces in every cell, in the same order, and
    /// so give the same nearest faces and the same pairs in the same order.
    #[test]
    fn both_layouts_give_the_same_answers() {
        let mut buf = vec![MaybeUninit::uninit(); 1 << 22];
        let arena = Arena::new(&mut buf);
        for (v, f) in [sheet(40), sheet(7), soup(3, 400)] {
            let dense = FaceGrid::try_build_in(&arena, &v, &f, true, &Silent).unwrap();
            let sorted = FaceGrid::try_build_in(&arena, &v, &f, false, &Silent).unwrap();
            assert_eq!(dense.dims, sorted.dims);
            let [dx, dy, dz] = dense.dims;
            for c in
                (0..dx).flat_map(|x| (0..dy).flat_map(move |y| (0..dz).map(move |z| [x, y, z])))
            {
                let (a, b): (Vec<u32>, Vec<u32>) =
                    (dense.cell(c).collect(), sorted.cell(c).collect());
                assert_eq!(a, b, "cell {c:?}");
                assert!(a.windows(2).all(|w| w[0] < w[1]), "cell {c:?}: {a:?}");
            }
            assert_eq!(dense.cell([dx, 0, 0]).count(), 0);
            let pairs = |g: &FaceGrid| {
                let mut all = Vec::new();
                g.for_each_overlapping_pair(|a, b| all.push((a, b)));
                let mut some = Vec::new();
                g.overlapping_pairs_where(
                    &Backwards,
                    |a, b| (a ^ b) % 5 == 0,
                    |a, b| some.push((a, b)),
                );
                (all, some)
            };
            let (all, some) = pairs(&dense);
            assert_eq!((&all, &some), (&pairs(&sorted).0, &pairs(&sorted).1));
            assert!(all.len() > 50 && !some.is_empty(), "{} pairs", all.len());
            let mut rng = Rng::new(11);
            for _ in 0..2000 {
                let p: V3 = core::array::from_fn(|_| (rng.unit_f64() as f32 * 2.0 - 0.5) * 1.5);
                assert_eq!(dense.nearest(p), sorted.nearest(p), "point {p:?}");
            }
        }
    }

    #[test]
    fn nearest_equals_a_scan_of_all_faces() {
        for dense in [false, true] {
            nearest_equals_a_scan(soup(3, 400), dense);
            nearest_equals_a_scan(sheet(30), dense);
        }
    }

    fn nearest_equals_a_scan((v, f): (Vec<V3>, Vec<[u32; 3]>), dense: bool) {
        let mut buf = vec![MaybeUninit::uninit(); 1 << 20];
        let arena = Arena::new(&mut buf);
        let grid = FaceGrid::try_build_in(&arena, &v, &f, dense, &Silent).unwrap();
        assert!(grid.entry_count() <= ENTRIES_PER_FACE * f.len());
        let mut rng = Rng::new(9);
        for i in 0..2000 {
            // Points inside the grid, and some far outside it.
            let s = if i % 10 == 0 { 6.0 } else { 1.2 };
            let p: V3 = core::array::from_fn(|_| (rng.unit_f64() as f32 * 2.0 - 1.0) * s);
            let brute = f
                .iter()
                .enumerate()
                .map(|(i, t)| {
                    let d = point_triangle_dist2(
                        p,
                        v[t[0] as usize],
                        v[t[1] as usize],
                        v[t[2] as usize],
                    );
                    (d, i as u32)
                })
                .fold(
                    (f32::INFINITY, u32::MAX),
                    |a, b| if b.0 < a.0 { b } else { a },
                );
            let (face, d2) = grid.nearest(p).unwrap();
            assert_eq!(d2, brute.0, "point {p:?}");
            assert_eq!(face, brute.1);
        }
    }

    #[test]
    fn overlapping_pairs_are_those_a_scan_of_all_pairs_finds_once_each() {
        for dense in [false, true] {
            overlapping_pairs_are_those_of_a_scan(soup(5, 300), dense);
            overlapping_pairs_are_those_of_a_scan(sheet(12), dense);
        }
    }

    fn overlapping_pairs_are_those_of_a_scan((v, f): (Vec<V3>, Vec<[u32; 3]>), dense: bool) {
        let mut buf = vec![MaybeUninit::uninit(); 1 << 20];
        let arena = Arena::new(&mut buf);
        let grid = FaceGrid::try_build_in(&arena, &v, &f, dense, &Silent).unwrap();
        let mut got = Vec::new();
        grid.for_each_overlapping_pair(|a, b| got.push((a, b)));
        let boxes: Vec<(V3, V3)> = f.iter().map(|t| bbox(&t.map(|i| v[i as usize]))).collect();
        let mut want = Vec::new();
        for a in 0..f.len() {
            for b in a + 1..f.len() {
                let (p, q) = (boxes[a], boxes[b]);
                if (0..3).all(|k| p.0[k] <= q.1[k] && q.0[k] <= p.1[k]) {
                    want.push((a as u32, b as u32));
                }
            }
        }
        let n = got.len();
        got.sort_unstable();
        got.dedup();
        assert_eq!(got.len(), n, "a pair was reported twice");
        assert_eq!(got, want);
        assert!(want.len() > 20, "{}", want.len());
    }

    #[test]
    fn pairs_tested_in_parallel_tasks_come_in_the_order_of_the_scan() {
        let (v, f) = soup(5, 300);
        let mut buf = vec![MaybeUninit::uninit(); 1 << 20];
        let arena = Arena::new(&mut buf);
        let grid = FaceGrid::try_new_in(&arena, &v, &f, &Silent).unwrap();
        // Few pairs pass, and every pair passes.
        for keep in [7u32, 1] {
            let test = |a: u32, b: u32| (a + b) % keep == 0;
            let mut want = Vec::new();
            grid.for_each_overlapping_pair(|a, b| {
                if test(a, b) {
                    want.push((a, b))
                }
            });
            let mut got = Vec::new();
            grid.overlapping_pairs_where(&Backwards, test, |a, b| got.push((a, b)));
            assert_eq!(got, want, "keep {keep}");
            assert!(want.len() > 20 || keep > 1, "{}", want.len());
        }
    }

    #[test]
    fn empty_and_broken_meshes_find_nothing_and_do_not_panic() {
        let mut buf = vec![MaybeUninit::uninit(); 1 << 16];
        let arena = Arena::new(&mut buf);
        let grid = FaceGrid::try_new_in(&arena, &[], &[], &Silent).unwrap();
        assert_eq!(grid.nearest([0.0; 3]), None);
        let v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [f32::NAN, 1.0, 0.0]];
        let grid = FaceGrid::try_new_in(&arena, &v, &[[0, 1, 2], [0, 1, 9]], &Silent).unwrap();
        assert_eq!(grid.nearest([0.0; 3]), None);
        let v = [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]];
        let grid = FaceGrid::try_new_in(&arena, &v, &[[0, 1, 2]], &Silent).unwrap();
        assert_eq!(grid.nearest([1.0, 0.0, 0.0]), Some((0, 1.0)));
    }
}
