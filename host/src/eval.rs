//! Quality of a reconstructed mesh against the point cloud it came from.
//!
//! [`evaluate`] measures, in `f64` and in the file's units:
//! - **point -> mesh**: the exact distance from every input point to the nearest
//!   triangle (Ericsson's closest point on a triangle), found through a uniform grid of
//!   triangle bounding boxes with a ring search that stops only when no unvisited cell
//!   can hold anything closer, so the result equals a brute-force scan;
//! - **mesh -> points**: the distance from area-uniform surface samples (seeded, so
//!   the same input gives the same numbers) to the nearest input point, through the same
//!   grid over the points;
//! - **Chamfer** (mean of the two means) and **Hausdorff** (max of the two maxima);
//! - **topology**: edges, boundary and non-manifold edges, non-manifold vertices (more
//!   than one fan of faces), components, orientation consistency, Euler characteristic,
//!   degenerate and duplicate faces;
//! - **triangle quality**: percentiles of the minimum angle of each face.
//!
//! Cost: O((P + S) · c + F log F) time, where P points and S samples each visit `c`
//! grid items on average (a few dozen on scanned models), and O(P + S + F) memory.
//! Queries are spread over the available cores; results do not depend on how many.

use crate::geom::{cross, dot, sub};
use std::thread;
use vsaqem_core::rng::Rng;
use vsaqem_core::union_find::UnionFind;

/// Surface samples of the mesh -> points direction unless told otherwise.
pub const DEFAULT_SAMPLES: usize = 100_000;
/// Seed of the surface sampling: fixed, so evaluations are reproducible.
pub const SAMPLE_SEED: u64 = 0x5EED_0000_0000_0001;
/// Points farther than this fraction of the points' bounding-box diagonal from the
/// mesh are counted in [`PointToMesh::far`].
pub const FAR_FRACTION: f64 = 0.01;
/// A face whose doubled area is at most this fraction of its longest edge squared
/// (i.e. whose largest angle is within about 1e-12 rad of 180°) counts as zero area.
pub const ZERO_AREA: f64 = 1e-12;

/// Summary of a set of distances (file units). All NaN when the set is empty.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stats {
    /// Number of distances.
    pub count: usize,
    /// Largest distance.
    pub max: f64,
    /// Mean distance.
    pub mean: f64,
    /// Root mean square distance.
    pub rms: f64,
    /// 99th percentile (nearest rank: the smallest value with at least 99 % of the
    /// set at or below it).
    pub p99: f64,
}

/// Distances from the input points to the mesh surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointToMesh {
    /// One distance per input point.
    pub stats: Stats,
    /// Points farther than [`FAR_FRACTION`] of the diagonal from the mesh.
    pub far: usize,
}

/// Combinatorial checks of the triangle list.
///
/// Faces with an index out of range are counted in `invalid_faces` and left out of
/// everything else. Faces with a repeated index are counted as degenerate and left out
/// of the combinatorial counts (edges, fans, components, orientation, Euler), which use
/// the remaining faces ("proper faces") and the vertices they reference.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Topology {
    /// Vertices in the vertex list.
    pub vertices: usize,
    /// Faces in the triangle list.
    pub faces: usize,
    /// Faces with an index `>= vertices`.
    pub invalid_faces: usize,
    /// Vertices referenced by a proper face.
    pub referenced_vertices: usize,
    /// Vertices referenced by no proper face (isolated or only in degenerate faces).
    pub unreferenced_vertices: usize,
    /// Distinct undirected edges of the proper faces.
    pub edges: usize,
    /// Edges with exactly one face.
    pub boundary_edges: usize,
    /// Edges with three or more faces.
    pub non_manifold_edges: usize,
    /// Referenced vertices whose incident faces form more than one fan (faces linked
    /// through edges incident to the vertex).
    pub non_manifold_vertices: usize,
    /// Connected components of proper faces, linked through shared edges.
    pub components: usize,
    /// Edges with two faces that traverse it in the same direction.
    pub inconsistent_edges: usize,
    /// `referenced_vertices - edges + proper faces`.
    pub euler: i64,
    /// Faces with a repeated index or zero area (see [`ZERO_AREA`]).
    pub degenerate_faces: usize,
    /// Faces with the same vertex set as an earlier face.
    pub duplicate_faces: usize,
}

impl Topology {
    /// A closed, edge- and vertex-manifold, consistently oriented surface.
    pub fn is_closed_manifold(&self) -> bool {
        self.boundary_edges == 0
            && self.non_manifold_edges == 0
            && self.non_manifold_vertices == 0
            && self.inconsistent_edges == 0
    }
}

/// Minimum angle per face, in degrees (0 for degenerate faces). NaN without faces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quality {
    /// Smallest minimum angle.
    pub min: f64,
    /// 1st percentile (nearest rank).
    pub p1: f64,
    /// 5th percentile.
    pub p5: f64,
    /// Median.
    pub p50: f64,
}

/// Everything [`evaluate`] measures. Distances are in file units; divide by
/// `diagonal` (or use [`Evaluation::rel`]) for fractions of the points' extent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Evaluation {
    /// Input points.
    pub points: usize,
    /// Bounding-box diagonal of the input points.
    pub diagonal: f64,
    /// Input points -> mesh surface.
    pub point_to_mesh: PointToMesh,
    /// Surface samples -> nearest input point (`stats.count` samples).
    pub mesh_to_points: Stats,
    /// Mean of the two mean distances.
    pub chamfer: f64,
    /// Max of the two maximum distances.
    pub hausdorff: f64,
    /// Signed volume enclosed by the faces (file units cubed): positive when a closed
    /// mesh's faces are counter-clockwise seen from outside, negative when inward.
    pub signed_volume: f64,
    /// Combinatorial checks.
    pub topology: Topology,
    /// Minimum-angle distribution.
    pub quality: Quality,
}

impl Evaluation {
    /// `d` as a fraction of the points' bounding-box diagonal.
    pub fn rel(&self, d: f64) -> f64 {
        d / self.diagonal
    }
}

/// Evaluates the mesh (`vertices`, `triangles`) against `points`, with `samples`
/// surface samples for the mesh -> points direction ([`DEFAULT_SAMPLES`] is the usual
/// choice). Never panics: an empty point set or a mesh without area gives NaN distances.
pub fn evaluate(
    points: &[[f64; 3]],
    vertices: &[[f64; 3]],
    triangles: &[[u32; 3]],
    samples: usize,
) -> Evaluation {
    let nv = vertices.len();
    let valid: Vec<[u32; 3]> = triangles
        .iter()
        .copied()
        .filter(|t| t.iter().all(|&i| (i as usize) < nv))
        .collect();
    let tris: Vec<[[f64; 3]; 3]> = valid
        .iter()
        .map(|t| t.map(|i| vertices[i as usize]))
        .collect();

    let diagonal = diagonal(points);
    let to_mesh = point_to_mesh_distances(points, &tris);
    let far = to_mesh
        .iter()
        .filter(|&&d| d > FAR_FRACTION * diagonal)
        .count();
    let to_mesh = stats(to_mesh);
    let to_points = stats(mesh_to_point_distances(points, &tris, samples));

    let mut topology = topology(nv, &valid, &tris);
    topology.faces = triangles.len();
    topology.invalid_faces = triangles.len() - valid.len();
    Evaluation {
        points: points.len(),
        diagonal,
        point_to_mesh: PointToMesh {
            stats: to_mesh,
            far,
        },
        mesh_to_points: to_points,
        chamfer: 0.5 * (to_mesh.mean + to_points.mean),
        hausdorff: to_mesh.max.max(to_points.max),
        signed_volume: tris
            .iter()
            .map(|t| dot(t[0], cross(t[1], t[2])) / 6.0)
            .sum(),
        topology,
        quality: quality(&tris),
    }
}

// ---------------------------------------------------------------------------------
// Geometry helpers

fn axpy(a: [f64; 3], s: f64, d: [f64; 3]) -> [f64; 3] {
    [a[0] + s * d[0], a[1] + s * d[1], a[2] + s * d[2]]
}

fn diagonal(points: &[[f64; 3]]) -> f64 {
    let (lo, hi) = bounds(points.iter().copied());
    if points.is_empty() {
        return f64::NAN;
    }
    dot(sub(hi, lo), sub(hi, lo)).sqrt()
}

fn bounds(it: impl Iterator<Item = [f64; 3]>) -> ([f64; 3], [f64; 3]) {
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

/// Whether a triangle has (numerically) zero area; see [`ZERO_AREA`].
fn zero_area(t: &[[f64; 3]; 3]) -> bool {
    let (ab, ac, bc) = (sub(t[1], t[0]), sub(t[2], t[0]), sub(t[2], t[1]));
    let n = cross(ab, ac);
    let longest = dot(ab, ab).max(dot(ac, ac)).max(dot(bc, bc));
    dot(n, n).sqrt() <= ZERO_AREA * longest
}

/// Squared distance from `p` to the segment `ab`.
fn dist2_segment(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let ab = sub(b, a);
    let len2 = dot(ab, ab);
    let t = if len2 > 0.0 {
        (dot(sub(p, a), ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let d = sub(p, axpy(a, t, ab));
    dot(d, d)
}

/// Squared distance from `p` to the triangle `t` (closest point by Voronoi regions,
/// Ericsson, *Real-Time Collision Detection* 5.1.5). Zero-area triangles are measured
/// as their three edges.
pub fn dist2_point_triangle(p: [f64; 3], t: &[[f64; 3]; 3]) -> f64 {
    let [a, b, c] = *t;
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let n = cross(ab, ac);
    let n2 = dot(n, n);
    let longest = dot(ab, ab).max(dot(ac, ac)).max(dot(sub(c, b), sub(c, b)));
    if n2 <= (ZERO_AREA * longest).powi(2) {
        return dist2_segment(p, a, b)
            .min(dist2_segment(p, b, c))
            .min(dist2_segment(p, a, c));
    }
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return dot(ap, ap);
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return dot(bp, bp);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return dist2_segment(p, a, b);
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return dot(cp, cp);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return dist2_segment(p, a, c);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return dist2_segment(p, b, c);
    }
    // Inside the prism over the face: the distance to the plane.
    let h = dot(ap, n);
    h * h / n2
}

// ---------------------------------------------------------------------------------
// Uniform grid with an exact nearest-item ring search

/// A uniform grid of cubic cells over items given by axis-aligned boxes; each item is
/// listed in every cell its box overlaps (CSR: `start[cell]..start[cell + 1]` of
/// `items`). Memory: 4 bytes per cell plus 4 per (item, cell) pair.
struct Grid {
    min: [f64; 3],
    h: f64,
    dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
}

/// Largest number of cells a grid may have (64 MiB of offsets).
const MAX_CELLS: f64 = (1u64 << 24) as f64;

impl Grid {
    /// A grid of about `target` cells over `boxes`, coarsened while the (item, cell)
    /// pairs would exceed 32 per item (huge triangles). O(n + cells + pairs).
    fn build(boxes: &[([f64; 3], [f64; 3])], target: f64) -> Grid {
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
    /// show is not closer than `best2`.
    fn nearest(&self, p: [f64; 3], mut dist2: impl FnMut(u32, f64) -> f64) -> f64 {
        let c = self.cell_of(p);
        let reach = (0..3)
            .map(|a| c[a].max(self.dims[a] - 1 - c[a]))
            .max()
            .unwrap_or(0);
        let mut best2 = f64::INFINITY;
        for k in 0..=reach {
            // Any cell of ring k is at least (k - 1) * h away.
            let lb = k.saturating_sub(1) as f64 * self.h;
            if lb * lb >= best2 {
                break;
            }
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
        best2
    }
}

/// Runs `f(chunk_index_offset, chunk)` over `out` split across the available cores.
fn parallel<T: Send>(out: &mut [T], f: impl Fn(usize, &mut [T]) + Sync) {
    let threads = thread::available_parallelism().map_or(1, |n| n.get());
    let chunk = out.len().div_ceil(threads).max(1024);
    if out.len() <= chunk {
        f(0, out);
        return;
    }
    thread::scope(|s| {
        for (i, part) in out.chunks_mut(chunk).enumerate() {
            let f = &f;
            s.spawn(move || f(i * chunk, part));
        }
    });
}

/// Squared distance from `p` to the box `lo`..`hi`.
fn sq_box_dist(p: [f64; 3], (lo, hi): &([f64; 3], [f64; 3])) -> f64 {
    (0..3)
        .map(|a| {
            let d = (lo[a] - p[a]).max(p[a] - hi[a]).max(0.0);
            d * d
        })
        .sum()
}

/// Distance from each point to the nearest triangle (INFINITY without triangles).
fn point_to_mesh_distances(points: &[[f64; 3]], tris: &[[[f64; 3]; 3]]) -> Vec<f64> {
    let mut out = vec![f64::INFINITY; points.len()];
    if tris.is_empty() {
        return out;
    }
    let boxes: Vec<_> = tris.iter().map(|t| bounds(t.iter().copied())).collect();
    let grid = Grid::build(&boxes, 4.0 * tris.len() as f64);
    parallel(&mut out, |first, part| {
        // A triangle spans several cells: visit it once per query.
        let mut seen = vec![u32::MAX; tris.len()];
        for (j, d) in part.iter_mut().enumerate() {
            let q = (first + j) as u32;
            let p = points[first + j];
            *d = grid
                .nearest(p, |t, best2| {
                    let t = t as usize;
                    if seen[t] == q || sq_box_dist(p, &boxes[t]) >= best2 {
                        return f64::INFINITY;
                    }
                    seen[t] = q;
                    dist2_point_triangle(p, &tris[t])
                })
                .sqrt();
        }
    });
    out
}

/// `n` points uniform by area on the triangles (seeded by [`SAMPLE_SEED`]); none when
/// the total area is zero.
pub fn sample_surface(tris: &[[[f64; 3]; 3]], n: usize) -> Vec<[f64; 3]> {
    let mut cum = Vec::with_capacity(tris.len());
    let mut total = 0.0;
    for t in tris {
        let c = cross(sub(t[1], t[0]), sub(t[2], t[0]));
        total += dot(c, c).sqrt();
        cum.push(total);
    }
    if total.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) || !total.is_finite() {
        return Vec::new();
    }
    let mut rng = Rng::from_state(SAMPLE_SEED);
    (0..n)
        .map(|_| {
            let u = rng.unit_f64() * total;
            let i = cum.partition_point(|&c| c <= u).min(tris.len() - 1);
            let [a, b, c] = tris[i];
            let s = rng.unit_f64().sqrt();
            let v = rng.unit_f64();
            let (wb, wc) = (s * (1.0 - v), s * v);
            let p = axpy(a, wb, sub(b, a));
            axpy(p, wc, sub(c, a))
        })
        .collect()
}

/// Distance from each of `samples` surface samples to the nearest point.
fn mesh_to_point_distances(
    points: &[[f64; 3]],
    tris: &[[[f64; 3]; 3]],
    samples: usize,
) -> Vec<f64> {
    if points.is_empty() {
        return Vec::new();
    }
    let s = sample_surface(tris, samples);
    let boxes: Vec<_> = points.iter().map(|&p| (p, p)).collect();
    let grid = Grid::build(&boxes, points.len() as f64);
    let mut out = vec![0.0; s.len()];
    parallel(&mut out, |first, part| {
        for (j, d) in part.iter_mut().enumerate() {
            let q = s[first + j];
            *d = grid
                .nearest(q, |i, _| {
                    let e = sub(points[i as usize], q);
                    dot(e, e)
                })
                .sqrt();
        }
    });
    out
}

/// Nearest-rank percentile `p` (0..=100) of sorted `v`.
fn percentile(v: &[f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let rank = (p / 100.0 * v.len() as f64).ceil() as usize;
    v[rank.clamp(1, v.len()) - 1]
}

fn stats(mut v: Vec<f64>) -> Stats {
    if v.is_empty() {
        return Stats {
            count: 0,
            max: f64::NAN,
            mean: f64::NAN,
            rms: f64::NAN,
            p99: f64::NAN,
        };
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let rms = (v.iter().map(|d| d * d).sum::<f64>() / n).sqrt();
    v.sort_unstable_by(f64::total_cmp);
    Stats {
        count: v.len(),
        max: v[v.len() - 1],
        mean,
        rms,
        p99: percentile(&v, 99.0),
    }
}

// ---------------------------------------------------------------------------------
// Topology

/// Topology of `faces` (indices all `< nv`); `tris` are their positions.
/// O(F log F): one sort of the 3F half-edges and one of the 3F corners.
fn topology(nv: usize, faces: &[[u32; 3]], tris: &[[[f64; 3]; 3]]) -> Topology {
    let mut t = Topology {
        vertices: nv,
        ..Topology::default()
    };
    let proper: Vec<[u32; 3]> = faces
        .iter()
        .copied()
        .filter(|f| f[0] != f[1] && f[1] != f[2] && f[0] != f[2])
        .collect();
    t.degenerate_faces = faces
        .iter()
        .zip(tris)
        .filter(|(f, tri)| f[0] == f[1] || f[1] == f[2] || f[0] == f[2] || zero_area(tri))
        .count();
    let mut sets: Vec<[u32; 3]> = faces
        .iter()
        .map(|f| {
            let mut s = *f;
            s.sort_unstable();
            s
        })
        .collect();
    sets.sort_unstable();
    sets.dedup();
    t.duplicate_faces = faces.len() - sets.len();

    // Half-edges (undirected key, face, local start corner), sorted by key then face.
    let mut half: Vec<(u64, u32, u8)> = Vec::with_capacity(3 * proper.len());
    for (fi, f) in proper.iter().enumerate() {
        for i in 0..3 {
            let (a, b) = (f[i], f[(i + 1) % 3]);
            let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
            half.push((key, fi as u32, i as u8));
        }
    }
    half.sort_unstable();
    // Corner 3 * face + i is vertex f[i] in face f. For a half-edge, the corners of
    // its lower and higher vertex.
    let corners = |&(_, fi, i): &(u64, u32, u8)| -> (u32, u32) {
        let f = proper[fi as usize];
        let (i, j) = (u32::from(i), (u32::from(i) + 1) % 3);
        let (ci, cj) = (3 * fi + i, 3 * fi + j);
        if f[i as usize] < f[j as usize] {
            (ci, cj)
        } else {
            (cj, ci)
        }
    };
    let mut face_parent = vec![0u32; proper.len()];
    let mut fan_parent = vec![0u32; 3 * proper.len()];
    let mut faces_dsu = UnionFind::new(&mut face_parent);
    let mut fans = UnionFind::new(&mut fan_parent);
    for group in half.chunk_by(|x, y| x.0 == y.0) {
        t.edges += 1;
        match group.len() {
            1 => t.boundary_edges += 1,
            2 => {
                // Same direction iff both start at the same (lower or higher) vertex.
                let forward = |h: &(u64, u32, u8)| corners(h).0 == 3 * h.1 + u32::from(h.2);
                if forward(&group[0]) == forward(&group[1]) {
                    t.inconsistent_edges += 1;
                }
            }
            _ => t.non_manifold_edges += 1,
        }
        let (lo0, hi0) = corners(&group[0]);
        for h in &group[1..] {
            faces_dsu.union(group[0].1, h.1);
            let (lo, hi) = corners(h);
            fans.union(lo0, lo);
            fans.union(hi0, hi);
        }
    }
    t.components = (0..proper.len() as u32)
        .filter(|&f| faces_dsu.find(f) == f)
        .count();

    let mut vertex_fans: Vec<(u32, u32)> = (0..3 * proper.len() as u32)
        .map(|c| (proper[c as usize / 3][c as usize % 3], fans.find(c)))
        .collect();
    vertex_fans.sort_unstable();
    vertex_fans.dedup();
    for group in vertex_fans.chunk_by(|x, y| x.0 == y.0) {
        t.referenced_vertices += 1;
        if group.len() > 1 {
            t.non_manifold_vertices += 1;
        }
    }
    t.unreferenced_vertices = nv - t.referenced_vertices;
    t.euler = t.referenced_vertices as i64 - t.edges as i64 + proper.len() as i64;
    t
}

// ---------------------------------------------------------------------------------
// Triangle quality

/// The smallest interior angle of `t`, in degrees (0 when it has zero area).
pub fn min_angle_deg(t: &[[f64; 3]; 3]) -> f64 {
    if zero_area(t) {
        return 0.0;
    }
    (0..3)
        .map(|i| {
            let (u, v) = (sub(t[(i + 1) % 3], t[i]), sub(t[(i + 2) % 3], t[i]));
            let c = cross(u, v);
            dot(c, c).sqrt().atan2(dot(u, v)).to_degrees()
        })
        .fold(f64::INFINITY, f64::min)
}

fn quality(tris: &[[[f64; 3]; 3]]) -> Quality {
    let mut a: Vec<f64> = tris.iter().map(min_angle_deg).collect();
    a.sort_unstable_by(f64::total_cmp);
    Quality {
        min: a.first().copied().unwrap_or(f64::NAN),
        p1: percentile(&a, 1.0),
        p5: percentile(&a, 5.0),
        p50: percentile(&a, 50.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(p: [f64; 3], tris: &[[[f64; 3]; 3]]) -> f64 {
        tris.iter()
            .map(|t| dist2_point_triangle(p, t))
            .fold(f64::INFINITY, f64::min)
            .sqrt()
    }

    fn rng_points(n: usize, seed: u64, scale: f64) -> Vec<[f64; 3]> {
        let mut r = Rng::from_state(seed);
        (0..n)
            .map(|_| [0; 3].map(|_| (r.unit_f64() - 0.5) * scale))
            .collect()
    }

    #[test]
    fn grid_search_equals_brute_force_on_random_triangle_soup() {
        let v = rng_points(600, 7, 1.0);
        let tris: Vec<[[f64; 3]; 3]> = v
            .chunks(3)
            .map(|c| {
                // Small triangles around a centre, plus a few long slivers.
                let s = if c[0][0] > 0.4 { 1.0 } else { 0.1 };
                [c[0], axpy(c[0], s, c[1]), axpy(c[0], s, c[2])]
            })
            .collect();
        let queries = rng_points(3000, 11, 3.0);
        let got = point_to_mesh_distances(&queries, &tris);
        for (q, d) in queries.iter().zip(&got) {
            assert_eq!(*d, brute(*q, &tris), "query {q:?}");
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

    #[test]
    fn degenerate_triangle_is_measured_as_its_segments() {
        let t = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        assert_eq!(dist2_point_triangle([1.5, 2.0, 0.0], &t), 4.0);
        assert_eq!(dist2_point_triangle([3.0, 0.0, 0.0], &t), 1.0);
        let point = [[1.0, 1.0, 1.0]; 3];
        assert_eq!(dist2_point_triangle([1.0, 1.0, 3.0], &point), 4.0);
    }

    #[test]
    fn percentile_is_nearest_rank() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile(&v, 99.0), 99.0);
        assert_eq!(percentile(&v, 50.0), 50.0);
        assert_eq!(percentile(&v, 1.0), 1.0);
        assert_eq!(percentile(&v, 0.0), 1.0);
        assert_eq!(percentile(&[3.0], 99.0), 3.0);
        assert!(percentile(&[], 5.0).is_nan());
    }

    #[test]
    fn samples_are_deterministic_and_on_the_surface() {
        let tris = [[[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]]];
        let a = sample_surface(&tris, 1000);
        assert_eq!(a, sample_surface(&tris, 1000));
        assert!(a
            .iter()
            .all(|p| p[2] == 0.0 && p[0] >= 0.0 && p[1] >= 0.0 && p[0] + p[1] <= 2.0 + 1e-12));
        // Uniform by area: x + y > 1 holds 1.5 of the area 2, so about 750 samples.
        let outer = a.iter().filter(|p| p[0] + p[1] > 1.0).count();
        assert!((650..850).contains(&outer), "{outer}");
    }

    #[test]
    fn min_angle_of_a_right_isosceles_triangle_is_45() {
        let t = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert!((min_angle_deg(&t) - 45.0).abs() < 1e-12);
        let flat = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        assert_eq!(min_angle_deg(&flat), 0.0);
    }
}
