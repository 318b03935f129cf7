//! Self-intersections: pairs of faces that meet anywhere other than where they share
//! vertices by index, decided exactly.
//!
//! Two triangles meet outside what they share (nothing, a vertex, or an edge: the set
//! X) iff an edge of one meets the other outside X. Their intersection is convex and
//! holds X; if it holds a point outside X it has an extreme point outside X, and every
//! extreme point of the intersection of two triangles lies on an edge of one of them.
//! So the pair test is at most six segment-triangle tests, each made of Shewchuk's
//! adaptive `orient3d` (and `orient2d` in a coordinate plane when the segment lies in
//! the triangle's plane): exact signs, no tolerance. A vertex with another index at
//! the same position is not shared: touching there is an intersection (a vertex split
//! in place).
//!
//! Candidate pairs come from a uniform grid over the faces' bounding boxes with cells
//! about one face wide ([`Grid::overlapping_pairs`]): O(F · k) for F faces and k
//! faces whose boxes overlap a face's box, a dozen or two on a mesh.

use super::grid::{bounds, Grid};
use super::zero_area;
use std::ops::Range;
use vsaqem_core::meshing::intersect::faces_intersect;

type P = [f64; 3];

/// Cells per face at most in the candidate grid (4 bytes each).
const CELLS_PER_FACE: f64 = 16.0;

/// Pairs of faces sharing a grid cell that the test looks at at most, per
/// face (plus [`LOOKED_FLOOR`]): a face-sized grid over a mesh holds a few
/// faces a cell, while a pile of faces in one place (copies of one triangle)
/// would make the test quadratic in the pile.
const LOOKED_PER_FACE: u64 = 4096;
/// Pairs of faces with overlapping boxes the test decides exactly at most,
/// per face (plus [`TESTED_FLOOR`]). Meshes need 7-8 a face: the 40 meshes
/// of the shared clouds at most 7.85, Open3D's ball-pivoting and Poisson
/// bunnies 6.8, a 300 x 300 grid of a wavy surface 7.4 (`bench/notes.md`).
/// 100,000 copies of one triangle stop after about 7.4 M tests, 6 s (10,000
/// copies took 30 s before the limit).
const TESTED_PER_FACE: u64 = 64;
const LOOKED_FLOOR: u64 = 1 << 24;
const TESTED_FLOOR: u64 = 1 << 20;

/// How many pairs of faces intersect, and whether all were tested.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crossings {
    /// Intersecting pairs found.
    pub pairs: usize,
    /// Whether every candidate pair was tested: when `false`, the test
    /// stopped at its limits (a pile of faces in one place) and `pairs` is a
    /// lower bound.
    pub complete: bool,
}

/// The number of pairs of `faces` (indices all `< vertices.len()`) that intersect
/// ([`faces_intersect`]). Faces with a repeated index, a non-finite coordinate or zero
/// area (counted as degenerate by the topology) are left out. The test stops
/// after 4096 pairs sharing a grid cell or 64 exact tests a face, plus
/// 2^24 and 2^20 (`complete` false): meshes need 7-8 exact tests a face,
/// faces piled in one place as many as the pile.
pub fn self_intersecting_pairs(vertices: &[P], faces: &[[u32; 3]]) -> Crossings {
    let candidates = Candidates::new(vertices, faces);
    candidates.crossings_in(faces, 0..candidates.layers())
}

/// The faces [`self_intersecting_pairs`] tests (those with three distinct
/// indices, finite corners and an area), their corners and bounding boxes,
/// and the grid over the boxes: made once, then the pairs counted in one
/// range of the grid's layers or several (each its own limits), so that the
/// ranges may be counted on several threads.
pub(super) struct Candidates {
    tested: Vec<u32>,
    tris: Vec<[P; 3]>,
    boxes: Vec<(P, P)>,
    grid: Option<Grid>,
}

impl Candidates {
    /// The candidates among `faces` (indices all `< vertices.len()`).
    pub(super) fn new(vertices: &[P], faces: &[[u32; 3]]) -> Candidates {
        let tested: Vec<u32> = (0..faces.len() as u32)
            .filter(|&i| {
                let g = faces[i as usize];
                let t = g.map(|v| vertices[v as usize]);
                g[0] != g[1]
                    && g[1] != g[2]
                    && g[0] != g[2]
                    && t.iter().flatten().all(|c| c.is_finite())
                    && !zero_area(&t)
            })
            .collect();
        let tris: Vec<[P; 3]> = tested
            .iter()
            .map(|&i| faces[i as usize].map(|v| vertices[v as usize]))
            .collect();
        let boxes: Vec<(P, P)> = tris.iter().map(|t| bounds(t.iter().copied())).collect();
        let grid = (tested.len() >= 2).then(|| Grid::build(&boxes, face_sized_cells(&boxes)));
        Candidates {
            tested,
            tris,
            boxes,
            grid,
        }
    }

    /// Layers of the grid's cells (0 without a pair to test).
    pub(super) fn layers(&self) -> usize {
        self.grid.as_ref().map_or(0, |g| g.dims[2])
    }

    /// The intersecting pairs whose cell ([`Grid::overlapping_pairs`]) lies
    /// in `layers`, under the limits of [`self_intersecting_pairs`].
    pub(super) fn crossings_in(&self, faces: &[[u32; 3]], layers: Range<usize>) -> Crossings {
        let mut pairs = 0;
        let complete = self.for_each_in(faces, layers, |_, _| pairs += 1);
        Crossings { pairs, complete }
    }

    /// Calls `f(i, j)`, `i < j` indices into `faces`, once for every
    /// intersecting pair found in `layers`; `false` when it stopped at its
    /// limits.
    fn for_each_in(
        &self,
        faces: &[[u32; 3]],
        layers: Range<usize>,
        mut f: impl FnMut(u32, u32),
    ) -> bool {
        let Some(grid) = &self.grid else {
            return true;
        };
        let (tested, tris) = (&self.tested, &self.tris);
        let n = tested.len() as u64;
        let mut left = TESTED_PER_FACE * n + TESTED_FLOOR;
        grid.overlapping_pairs(
            &self.boxes,
            layers,
            LOOKED_PER_FACE * n + LOOKED_FLOOR,
            |a, b| {
                if left == 0 {
                    return false;
                }
                left -= 1;
                let (a, b) = (a as usize, b as usize);
                let (i, j) = (tested[a], tested[b]);
                if faces_intersect(faces[i as usize], &tris[a], faces[j as usize], &tris[b]) {
                    f(i, j);
                }
                true
            },
        )
    }
}

/// A cell count whose cells are about as wide as the average box, at most
/// [`CELLS_PER_FACE`] per box.
fn face_sized_cells(boxes: &[(P, P)]) -> f64 {
    let n = boxes.len() as f64;
    let width = boxes
        .iter()
        .map(|(lo, hi)| (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max))
        .sum::<f64>()
        / n;
    let lo = bounds(boxes.iter().map(|b| b.0)).0;
    let hi = bounds(boxes.iter().map(|b| b.1)).1;
    let cells: f64 = if width > 0.0 {
        (0..3).map(|a| ((hi[a] - lo[a]) / width).max(1.0)).product()
    } else {
        n
    };
    cells.min(CELLS_PER_FACE * n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use vsaqem_core::rng::Rng;

    fn random_tri(r: &mut Rng, scale: f64) -> [P; 3] {
        let c = [0; 3].map(|_| r.unit_f64());
        [0; 3].map(|_| [0, 1, 2].map(|a| c[a] + (r.unit_f64() - 0.5) * scale))
    }

    /// Faces over a few lattice vertices: many shared vertices and edges, coplanar
    /// and touching pairs, vertices split in place (two indices per position).
    fn lattice_soup(faces: usize, seed: u64) -> (Vec<P>, Vec<[u32; 3]>) {
        let mut r = Rng::from_state(seed);
        let mut v: Vec<P> = (0..27)
            .map(|i| [(i % 3) as f64, (i / 3 % 3) as f64, (i / 9) as f64])
            .collect();
        v.extend_from_within(..9);
        let mut f = Vec::new();
        while f.len() < faces {
            let t = [0; 3].map(|_| (r.unit_f64() * v.len() as f64) as u32);
            let p = t.map(|i| v[i as usize]);
            if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] && !zero_area(&p) {
                f.push(t);
            }
        }
        (v, f)
    }

    #[test]
    fn pair_test_ignores_vertex_order_and_argument_order() {
        let (v, f) = lattice_soup(300, 5);
        let pos = |t: [u32; 3]| t.map(|i| v[i as usize]);
        let mut hits = 0;
        for (i, &a) in f.iter().enumerate() {
            for &b in &f[i + 1..] {
                let want = faces_intersect(a, &pos(a), b, &pos(b));
                hits += usize::from(want);
                let (ra, rb) = ([a[1], a[2], a[0]], [b[2], b[1], b[0]]);
                assert_eq!(faces_intersect(b, &pos(b), a, &pos(a)), want);
                assert_eq!(faces_intersect(ra, &pos(ra), rb, &pos(rb)), want);
            }
        }
        assert!(hits > 1000, "{hits}");
    }

    #[test]
    fn grid_candidates_find_every_pair_brute_force_finds() {
        let mut cut = false;
        for (v, f) in [
            lattice_soup(400, 9),
            // Small scattered triangles and long slivers.
            {
                let mut r = Rng::from_state(23);
                let mut v = Vec::new();
                let mut f = Vec::new();
                for k in 0..600u32 {
                    let t = random_tri(&mut r, if k % 10 == 0 { 1.0 } else { 0.1 });
                    v.extend_from_slice(&t);
                    f.push([3 * k, 3 * k + 1, 3 * k + 2]);
                }
                (v, f)
            },
        ] {
            let pos = |t: [u32; 3]| t.map(|i| v[i as usize]);
            let mut want = Vec::new();
            for i in 0..f.len() {
                for j in i + 1..f.len() {
                    if faces_intersect(f[i], &pos(f[i]), f[j], &pos(f[j])) {
                        want.push((i as u32, j as u32));
                    }
                }
            }
            let candidates = Candidates::new(&v, &f);
            let layers = candidates.layers();
            let mut got = Vec::new();
            assert!(candidates.for_each_in(&f, 0..layers, |i, j| got.push((i, j))));
            got.sort_unstable();
            assert!(want.len() > 50, "{}", want.len());
            assert_eq!(got, want);
            let all = Crossings {
                pairs: want.len(),
                complete: true,
            };
            assert_eq!(self_intersecting_pairs(&v, &f), all);
            // Cut into ranges of layers, each pair is found in exactly one.
            cut |= layers >= 3;
            for parts in [2, 3, layers].into_iter().filter(|&p| p <= layers) {
                let mut got = Vec::new();
                for k in 0..parts {
                    let range = layers * k / parts..layers * (k + 1) / parts;
                    assert!(candidates.for_each_in(&f, range, |i, j| got.push((i, j))));
                }
                got.sort_unstable();
                assert_eq!(got, want, "{parts} parts");
            }
        }
        assert!(cut, "no mesh had three layers to cut");
    }

    #[test]
    fn a_pile_of_copies_stops_the_test_with_a_lower_bound() {
        // 3,000 copies of one triangle: 4.5 M intersecting pairs, more than
        // the test decides for 3,000 faces (64 a face and 1 M).
        let n = 3000u32;
        let v: Vec<P> = (0..n)
            .flat_map(|_| [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
            .collect();
        let f: Vec<[u32; 3]> = (0..n).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
        let c = self_intersecting_pairs(&v, &f);
        assert!(!c.complete);
        let limit = (TESTED_PER_FACE * u64::from(n) + TESTED_FLOOR) as usize;
        assert_eq!(c.pairs, limit);
        // 300 copies (44,850 pairs) are counted in full.
        let c = self_intersecting_pairs(&v[..900], &f[..300]);
        assert_eq!(
            c,
            Crossings {
                pairs: 300 * 299 / 2,
                complete: true
            }
        );
    }

    #[test]
    fn degenerate_and_non_finite_faces_are_left_out() {
        let v = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.0, 0.0],
            [f64::NAN, 0.0, 0.0],
            [0.2, 0.2, 0.0],
        ];
        let f = [[0, 1, 2], [0, 3, 1], [0, 4, 5], [5, 5, 1]];
        assert_eq!(self_intersecting_pairs(&v, &f).pairs, 0);
    }
}
