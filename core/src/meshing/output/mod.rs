//! From selected facets to an oriented, 2-manifold triangle mesh.
//!
//! - **Edge-manifold**: the selection gives every candidate edge 0 or 2 facets (1
//!   where a border is allowed); a facet that would be an edge's third is dropped
//!   and counted (never happens with a feasible selection).
//! - **Orientation**: faces are flooded across shared edges so neighbours traverse
//!   their common edge in opposite directions; each closed component is then turned
//!   outward by the sign of its volume. A component that cannot be oriented
//!   consistently (a Möbius band) is counted.
//! - **Vertex-manifold**: the corners at one generator are grouped by the faces
//!   that share an edge through it; a generator whose faces form several fans
//!   becomes one vertex per fan (same position), so every vertex's faces form a
//!   single fan.
//! - **Holes**: the selection may leave an edge with one facet (at the border
//!   penalty). Boundary loops of at most `max_hole` edges are closed by ears,
//!   shortest new edge first, never degenerate and never reusing an edge the mesh
//!   has, so edges keep at most two faces and the new faces follow the loop's
//!   orientation.
//! - **Twists**: edge constraints cannot see a fold-over between facets that share
//!   no edge, so a selection can be non-orientable. The faces around an edge where
//!   the orientation clashes are cut out (the two faces on each clashing edge)
//!   and the hole closed again, at most three times.
//! - No degenerate faces (dropped with the candidates), no duplicates (candidate
//!   facets are distinct vertex triples; a filled triangle equal to an existing
//!   face is refused), every vertex used.
//!
//! Memory: the mesh (12 bytes per vertex and per face) plus O(faces + candidate
//! edges) scratch. Cost: linear in faces and edges.

mod holes;
mod insert;
mod orient;
#[cfg(test)]
mod tests;

use crate::arena::{Alloc, Arena};
use crate::error::Result;
use crate::math::to_d3;
use crate::math::{add, cross, dist2, dot, norm, sub, V3};
use crate::meshing::candidates::degenerate;
use crate::meshing::candidates::{Candidates, Members};
use crate::meshing::distance::{summarise, try_point_distances_in, MeshDistance};
use crate::meshing::face_grid::FaceGrid;
use crate::meshing::fit::{try_fit_vertices_in, FitStats, LAMBDA};
use crate::meshing::intersect::{faces_intersect, folded};
use crate::union_find::UnionFind;

use holes::{fill_holes, Filled};
use insert::insert_skipped;
use orient::orient;

/// Facts about the output mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MeshStats {
    /// Vertices of the mesh.
    pub vertices: u32,
    /// Triangles of the mesh.
    pub faces: u32,
    /// Edges with exactly one face.
    pub boundary_edges: u32,
    /// Edge-connected components.
    pub components: u32,
    /// Components that could not be oriented consistently.
    pub non_orientable: u32,
    /// Small closed pieces beside a large surface (bubbles) removed; their
    /// clusters are inserted into the surface like skipped ones.
    pub bubbles_removed: u32,
    /// Generators where the surface pinched (their faces formed several fans):
    /// all but the largest fan were cut out and the holes closed again.
    pub pinches_repaired: u32,
    /// Pairs of faces that still cross each other or fold onto each other
    /// after repair (0 is the aim: a valid solid).
    pub tangled_pairs: u32,
    /// Thin parts joined to the surface (instead of cut out or dropped): by
    /// a neck at a pinch, or by a tube from a bubble.
    pub necks: u32,
    /// Extra vertices made to separate fans at non-manifold generators that
    /// pinch repair left (at the same position as the first: 0 is the aim).
    pub split_vertices: u32,
    /// Faces dropped because their edge already had two.
    pub dropped_faces: u32,
    /// Boundary loops closed by hole filling.
    pub holes_filled: u32,
    /// Faces added by hole filling.
    pub filled_faces: u32,
    /// Boundary loops left open (longer than the limit, or no admissible ear).
    pub holes_left: u32,
    /// Boundary loops kept open because they run along the border of the data.
    pub open_loops: u32,
    /// Orientation clashes cut out and closed again.
    pub repairs: u32,
    /// Clusters the selection skipped (no selected face used them) whose
    /// generators were then inserted into the faces nearest to them.
    pub inserted_clusters: u32,
    /// Clusters (with points) that no face uses even so: uncovered parts of
    /// the data (no face could be split to reach them without folding).
    pub uncovered_clusters: u32,
    /// Points in those clusters.
    pub uncovered_points: u32,
    /// What fitting the vertices to the data did ([`crate::meshing::fit`]).
    pub fit: FitStats,
    /// How far the points are from the mesh (relative to the diagonal), after
    /// fitting.
    pub distance: MeshDistance,
    /// Clusters with a point farther from the mesh than the round allowed
    /// ([`Output::IfFaithful`]); 0 when it allowed any distance.
    pub far_clusters: u32,
}

/// A triangle mesh in core coordinates.
#[derive(Clone, Copy)]
pub struct Mesh<'a> {
    /// Vertex positions.
    pub vertices: &'a [V3],
    /// Triangles, counter-clockwise seen from outside for closed components.
    pub triangles: &'a [[u32; 3]],
    /// The cluster each vertex comes from.
    pub vertex_cluster: &'a [u32],
    /// Statistics.
    pub stats: MeshStats,
}

const NO: u32 = u32::MAX;

/// Rounds of cutting out orientation clashes at most (and of pinches).
const REPAIRS: u32 = 3;
/// Rounds of joining thin parts by necks at most.
const NECK_ROUNDS: u32 = 8;
/// Rounds of cutting out crossing or folded faces at most.
const UNTANGLE_ROUNDS: u32 = 8;

/// Faces of an edge, found by binary search in the sorted `(edge key, face)` table.
pub(super) fn faces_of(table: &[(u64, u32)], key: u64) -> &[(u64, u32)] {
    let lo = table.partition_point(|x| x.0 < key);
    let hi = lo + table[lo..].partition_point(|x| x.0 == key);
    &table[lo..hi]
}

pub(super) fn key(u: u32, v: u32) -> u64 {
    let (a, b) = if u < v { (u, v) } else { (v, u) };
    ((a as u64) << 32) | b as u64
}

/// `(edge key, face)` for every edge of every face, sorted.
pub(super) fn edge_table<'s, 'b, S: Alloc<'b>>(
    s: &'s S,
    faces: &[[u32; 3]],
) -> Result<&'s [(u64, u32)]> {
    let table = s.try_alloc_slice::<(u64, u32)>(3 * faces.len(), (0, 0))?;
    for (f, t) in faces.iter().enumerate() {
        for k in 0..3 {
            table[3 * f + k] = (key(t[k], t[(k + 1) % 3]), f as u32);
        }
    }
    table.sort_unstable();
    Ok(table)
}

/// +1 if the cycle `c` runs `u -> v`, -1 if `v -> u`, 0 if it has no such edge.
pub(super) fn dir(c: [u32; 3], u: u32, v: u32) -> i32 {
    for k in 0..3 {
        if c[k] == u && c[(k + 1) % 3] == v {
            return 1;
        }
        if c[k] == v && c[(k + 1) % 3] == u {
            return -1;
        }
    }
    0
}

/// Marks in `cut` both faces of every pair of `faces` (over `generators`) that
/// intersect other than at what they share ([`faces_intersect`], exact), and
/// of every edge whose two faces are folded onto each other ([`folded`]).
/// Returns the pairs marked. Candidates come from a [`FaceGrid`]: O(F k) for
/// k faces near a face, O(F) scratch.
fn mark_tangles<'b, S: Alloc<'b>>(
    s: &S,
    faces: &[[u32; 3]],
    generators: &[V3],
    cut: &mut [bool],
) -> Result<u32> {
    s.scratch(|t| {
        let at = |c: u32| to_d3(generators.get(c as usize).copied().unwrap_or([0.0; 3]));
        let corners = |f: u32| faces[f as usize].map(at);
        let mut pairs = 0;
        let mut mark = |a: u32, b: u32| {
            pairs += 1;
            for x in [a, b] {
                if let Some(c) = cut.get_mut(x as usize) {
                    *c = true;
                }
            }
        };
        let grid = FaceGrid::try_new_in(t, generators, faces)?;
        grid.for_each_overlapping_pair(|a, b| {
            let (fa, fb) = (faces[a as usize], faces[b as usize]);
            if faces_intersect(fa, &corners(a), fb, &corners(b)) {
                mark(a, b);
            }
        });
        let table = edge_table(t, faces)?;
        let mut i = 0;
        while i < table.len() {
            let k = table[i].0;
            let run = faces_of(&table[i..], k);
            if let [(_, f), (_, g)] = run {
                let (u, v) = ((k >> 32) as u32, k as u32);
                let third = |f: u32| {
                    let t = faces[f as usize];
                    t.into_iter().find(|&c| c != u && c != v).unwrap_or(u)
                };
                if folded(at(u), at(v), at(third(*f)), at(third(*g))) {
                    mark(*f, *g);
                }
            }
            i += run.len().max(1);
        }
        Ok(pairs)
    })
}

/// A closed piece of fewer faces than this, beside a piece at least
/// [`BUBBLE_RATIO`] times larger, is a bubble.
const BUBBLE_FACES: usize = 20;
/// See [`BUBBLE_FACES`].
const BUBBLE_RATIO: usize = 10;

/// The fan of every corner (`3 f + k`: corner `k` of face `f`): corners at one
/// generator are in one fan when their faces are linked through manifold
/// edges at it. Returns each corner's fan root; `table` is `faces`' edge
/// table. O(F) beyond the table.
fn corner_fans<'t, 'b, S: Alloc<'b>>(
    t: &'t S,
    faces: &[[u32; 3]],
    table: &[(u64, u32)],
) -> Result<&'t mut [u32]> {
    let mut fans = UnionFind::try_new_in(t, 3 * faces.len())?;
    let corner = |f: u32, v: u32| -> u32 {
        let k = faces[f as usize].iter().position(|&x| x == v).unwrap_or(0);
        3 * f + k as u32
    };
    let mut i = 0;
    while i < table.len() {
        let k = table[i].0;
        let run = faces_of(&table[i..], k);
        if let [(_, f), (_, g)] = run {
            for w in [(k >> 32) as u32, k as u32] {
                fans.union(corner(*f, w), corner(*g, w));
            }
        }
        i += run.len().max(1);
    }
    Ok(fans.into_roots())
}

/// The edge-connected pieces of a face list and which of them are bubbles
/// (see [`drop_bubbles`]).
struct Pieces<'t> {
    /// Per face, its piece's root (the piece's lowest face).
    root: &'t [u32],
    /// Per root, whether its piece is a bubble.
    bubble: &'t [bool],
}

impl<'t> Pieces<'t> {
    /// The pieces of `faces`, in scratch from `t`. O(F log F).
    fn try_new_in<'b, S: Alloc<'b>>(t: &'t S, faces: &[[u32; 3]]) -> Result<Self> {
        let nf = faces.len();
        let table = edge_table(t, faces)?;
        let mut pieces = UnionFind::try_new_in(t, nf)?;
        let open = t.try_alloc_slice::<bool>(nf, false)?;
        let mut i = 0;
        while i < table.len() {
            let k = table[i].0;
            let run = faces_of(&table[i..], k);
            if let [(_, f)] = run {
                open[*f as usize] = true;
            }
            for w in run.windows(2) {
                pieces.union(w[0].1, w[1].1);
            }
            i += run.len().max(1);
        }
        let root = pieces.into_roots();
        let size = t.try_alloc_slice::<u32>(nf, 0)?;
        let closed = t.try_alloc_slice::<bool>(nf, true)?;
        for f in 0..nf {
            let r = root[f] as usize;
            size[r] += 1;
            closed[r] &= !open[f];
        }
        let largest = size.iter().copied().max().unwrap_or(0) as usize;
        let bubble = t.try_alloc_slice::<bool>(nf, false)?;
        for (r, b) in bubble.iter_mut().enumerate() {
            let n = size[r] as usize;
            *b = closed[r] && n < BUBBLE_FACES && n * BUBBLE_RATIO <= largest;
        }
        Ok(Pieces { root, bubble })
    }
}

/// Removes from `faces[..nf]` the bubbles: closed edge-connected pieces of
/// fewer than [`BUBBLE_FACES`] faces while another piece has at least
/// [`BUBBLE_RATIO`] times as many (a small object of its own is as large as
/// its neighbours and stays). Returns the faces kept (compacted to the front),
/// the bubbles removed and the pieces left. O(F log F).
fn drop_bubbles<'b, S: Alloc<'b>>(
    s: &S,
    faces: &mut [[u32; 3]],
    nf: usize,
) -> Result<(usize, u32, u32)> {
    s.scratch(|t| {
        let Pieces { root, bubble } = Pieces::try_new_in(t, &faces[..nf])?;
        let bubble = |r: usize| bubble[r];
        let pieces = |drop: bool| {
            (0..nf)
                .filter(|&r| root[r] as usize == r && bubble(r) == drop)
                .count() as u32
        };
        let (dropped, kept) = (pieces(true), pieces(false));
        let mut w = 0;
        for f in 0..nf {
            if !bubble(root[f] as usize) {
                faces[w] = faces[f];
                w += 1;
            }
        }
        Ok((w, dropped, kept))
    })
}

/// Joins each bubble (see [`drop_bubbles`]) to the rest of the surface by a
/// tube, where one fits: a face of the bubble and a face of another piece that
/// face each other go, and six faces join the two triangular holes (corners
/// paired so the tube twists least). The bubble is most often the tip of a
/// thin part the selection closed on itself; joined, the tip stays in the mesh
/// and the surface keeps its genus (one tube between two pieces makes no
/// handle). Of each bubble's facing pairs the eight nearest are tried; a tube
/// is made only when it shares no vertex with either face's other corners, its
/// faces are not degenerate and it crosses or folds onto nothing
/// ([`untangled`]). Faces are appended from `nf` while room is left below
/// `cap`. Returns the face count and the tubes made. O(B F) per bubble of B
/// faces.
fn join_bubbles<'b, S: Alloc<'b>>(
    s: &S,
    faces: &mut [[u32; 3]],
    nf: usize,
    cap: usize,
    generators: &[V3],
    tol: f32,
) -> Result<(usize, u32)> {
    s.scratch(|t| {
        let Pieces { root, bubble } = Pieces::try_new_in(t, &faces[..nf])?;
        let bubble = |r: usize| bubble[r];
        let at = |c: u32| generators.get(c as usize).copied().unwrap_or([0.0; 3]);
        let centroid = |f: [u32; 3]| {
            let [a, b, c] = f.map(at);
            [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0)
        };
        let normal = |f: [u32; 3]| face_normal(f.map(at));
        let (mut nf, mut tubes) = (nf, 0u32);
        let original = nf;
        for r in 0..original {
            if root[r] as usize != r || !bubble(r) || nf + 4 > cap {
                continue;
            }
            // The eight nearest facing pairs (bubble face, other face).
            let mut near = [(f32::INFINITY, 0usize, 0usize); 8];
            for fb in (0..original).filter(|&f| root[f] as usize == r) {
                let (cb, nb) = (centroid(faces[fb]), normal(faces[fb]));
                for fa in (0..original).filter(|&f| root[f] as usize != r) {
                    let (ca, na) = (centroid(faces[fa]), normal(faces[fa]));
                    let gap = sub(cb, ca);
                    if dot(na, nb) >= 0.0 || dot(gap, na) <= 0.0 || dot(gap, nb) >= 0.0 {
                        continue;
                    }
                    let d = dot(gap, gap);
                    if d < near[7].0 {
                        near[7] = (d, fa, fb);
                        near.sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
                    }
                }
            }
            for &(d, fa, fb) in near.iter().filter(|x| x.0.is_finite()) {
                let _ = d;
                let (a, b) = (faces[fa], faces[fb]);
                if a.iter().any(|x| b.contains(x)) {
                    continue;
                }
                // Pair a[i] with b[(s - i) mod 3], the shift that twists least.
                let shift = (0..3)
                    .min_by(|&x, &y| {
                        let cost = |sh: usize| -> f32 {
                            (0..3)
                                .map(|i| dist2(at(a[i]), at(b[(sh + 3 - i) % 3])))
                                .sum()
                        };
                        cost(x).total_cmp(&cost(y))
                    })
                    .unwrap_or(0);
                let bb = |i: usize| b[(shift + 6 - i) % 3];
                let mut tube = [[0u32; 3]; 6];
                for i in 0..3 {
                    let j = (i + 1) % 3;
                    tube[2 * i] = [a[i], a[j], bb(j)];
                    tube[2 * i + 1] = [a[i], bb(j), bb(i)];
                }
                let flat = tube.iter().any(|f| {
                    let [p, q, w] = f.map(at);
                    degenerate(p, q, w, tol)
                });
                if flat || !untangled(&faces[..nf], &[fa, fb], &tube, generators) {
                    continue;
                }
                faces[fa] = tube[0];
                faces[fb] = tube[1];
                faces[nf..nf + 4].copy_from_slice(&tube[2..]);
                nf += 4;
                tubes += 1;
                break;
            }
        }
        Ok((nf, tubes))
    })
}

/// Joins, at pinched generators, a fan that belongs to another piece of the
/// surface than the generator's largest fan (a thin part that the selection
/// made a closed piece of its own, touching the rest at one vertex) to that
/// fan by a neck: a face of each fan at the vertex goes, and four faces join
/// the two holes, so the vertex has one fan and the pieces are one surface
/// with no handle. Faces facing each other most closely are tried first; a
/// neck is made only when its new edges are new, its faces not degenerate (edge
/// or area below `tol`) and it crosses or folds onto no face ([`untangled`]).
/// Faces are appended from `nf` while room is left below `cap`. Returns the
/// new face count and the necks made. O(F log F) plus O(F) per neck tried.
fn neck_pinches<'b, S: Alloc<'b>>(
    s: &S,
    faces: &mut [[u32; 3]],
    nf: usize,
    cap: usize,
    generators: &[V3],
    tol: f32,
) -> Result<(usize, u32)> {
    s.scratch(|t| {
        let m = generators.len();
        let table = edge_table(t, &faces[..nf])?;
        let fan = corner_fans(t, &faces[..nf], table)?;
        let piece = Pieces::try_new_in(t, &faces[..nf])?.root;
        let size = t.try_alloc_slice::<u32>(3 * nf, 0)?;
        for &r in fan.iter() {
            size[r as usize] += 1;
        }
        let best = t.try_alloc_slice::<u32>(m, NO)?;
        for c in 0..3 * nf {
            let (g, r) = (faces[c / 3][c % 3] as usize, fan[c]);
            if let Some(b) = best.get_mut(g) {
                if *b == NO || size[r as usize] > size[*b as usize] {
                    *b = r;
                }
            }
        }
        // Corners grouped by generator, in corner order.
        let order = t.try_alloc_slice::<u64>(3 * nf, 0)?;
        for (c, o) in order.iter_mut().enumerate() {
            *o = (faces[c / 3][c % 3] as u64) << 32 | c as u64;
        }
        order.sort_unstable();
        let mut joined = UnionFind::try_new_in(t, nf)?;
        let touched = t.try_alloc_slice::<bool>(cap.max(nf), false)?;
        let mut added = [0u64; 64];
        let mut n_added = 0usize;
        let (mut nf, mut necks) = (nf, 0u32);
        let at = |c: u32| generators.get(c as usize).copied().unwrap_or([0.0; 3]);
        let centroid = |f: [u32; 3]| {
            let [a, b, c] = f.map(at);
            [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0)
        };
        let mut i = 0;
        while i < order.len() {
            let v = (order[i] >> 32) as u32;
            let run = order[i..]
                .iter()
                .take_while(|&&o| (o >> 32) as u32 == v)
                .count();
            let group = &order[i..i + run];
            i += run;
            let Some(&b) = best.get(v as usize) else {
                continue;
            };
            let face = |o: u64| (o as u32 as usize) / 3;
            let Some(a_face) = group
                .iter()
                .map(|&o| face(o))
                .find(|&f| fan[3 * f..3 * f + 3].contains(&b))
            else {
                continue;
            };
            for &ob in group {
                let cb = ob as u32 as usize;
                if fan[cb] == b || joined.find(piece[cb / 3]) == joined.find(piece[a_face]) {
                    continue;
                }
                // The closest pair of a face of the largest fan and of this one.
                let mut pick: Option<(f32, usize, usize)> = None;
                for &oa in group.iter().filter(|&&o| fan[o as u32 as usize] == b) {
                    for &oc in group.iter().filter(|&&o| fan[o as u32 as usize] == fan[cb]) {
                        let (fa, fb) = (face(oa), face(oc));
                        if touched[fa] || touched[fb] {
                            continue;
                        }
                        let d = dist2(centroid(faces[fa]), centroid(faces[fb]));
                        if pick.is_none_or(|(e, _, _)| d < e) {
                            pick = Some((d, fa, fb));
                        }
                    }
                }
                let Some((_, fa, fb)) = pick else { continue };
                let rot = |f: [u32; 3]| {
                    let k = f.iter().position(|&x| x == v).unwrap_or(0);
                    (f[(k + 1) % 3], f[(k + 2) % 3])
                };
                let ((a1, a2), (b1, b2)) = (rot(faces[fa]), rot(faces[fb]));
                let new = [[v, b1, a2], [v, a1, b2], [a1, a2, b1], [a1, b1, b2]];
                let fresh = |p: u32, q: u32| {
                    faces_of(table, key(p, q)).is_empty() && !added[..n_added].contains(&key(p, q))
                };
                let distinct = a1 != b1 && a1 != b2 && a2 != b1 && a2 != b2;
                if !distinct
                    || nf + 2 > cap
                    || n_added + 3 > added.len()
                    || !(fresh(a2, b1) && fresh(a1, b2) && fresh(a1, b1))
                    || new.iter().any(|f| {
                        let [p, q, r] = f.map(at);
                        degenerate(p, q, r, tol)
                    })
                    || !untangled(&faces[..nf], &[fa, fb], &new, generators)
                {
                    continue;
                }
                faces[fa] = new[0];
                faces[fb] = new[1];
                faces[nf] = new[2];
                faces[nf + 1] = new[3];
                for f in [fa, fb, nf, nf + 1] {
                    touched[f] = true;
                }
                nf += 2;
                for (p, q) in [(a2, b1), (a1, b2), (a1, b1)] {
                    added[n_added] = key(p, q);
                    n_added += 1;
                }
                joined.union(piece[fa], piece[fb]);
                necks += 1;
                break;
            }
        }
        Ok((nf, necks))
    })
}

/// Marks in `cut` the faces to cut out at pinched generators: at each of the
/// `m` generators whose corners fall into several fans (faces linked through
/// manifold edges at it), every face of a fan other than the largest (ties: the
/// first). Returns the pinched generators. O(F log F) time, O(F) scratch.
fn mark_pinches<'b, S: Alloc<'b>>(
    s: &S,
    faces: &[[u32; 3]],
    m: usize,
    cut: &mut [bool],
) -> Result<u32> {
    s.scratch(|t| {
        let nf = faces.len();
        let table = edge_table(t, faces)?;
        let root = corner_fans(t, faces, table)?;
        let size = t.try_alloc_slice::<u32>(3 * nf, 0)?;
        for &r in root.iter() {
            size[r as usize] += 1;
        }
        // The largest fan at each generator, and whether it has another.
        let best = t.try_alloc_slice::<u32>(m, NO)?;
        let pinched = t.try_alloc_slice::<bool>(m, false)?;
        for c in 0..3 * nf {
            let (g, r) = (faces[c / 3][c % 3] as usize, root[c]);
            let Some(b) = best.get_mut(g) else {
                continue;
            };
            if *b == NO {
                *b = r;
            } else if *b != r {
                pinched[g] = true;
                if size[r as usize] > size[*b as usize] {
                    *b = r;
                }
            }
        }
        for c in 0..3 * nf {
            let g = faces[c / 3][c % 3] as usize;
            if pinched.get(g).copied().unwrap_or(false) && root[c] != best[g] {
                if let Some(x) = cut.get_mut(c / 3) {
                    *x = true;
                }
            }
        }
        Ok(pinched.iter().filter(|&&p| p).count() as u32)
    })
}

/// Whether the faces `new`, which replace `faces[r]` for each `r` of
/// `replaced`, cross no other face of `faces` (exact test, candidates by
/// bounding box) and fold onto no face they share an edge with. O(faces).
pub(super) fn untangled(
    faces: &[[u32; 3]],
    replaced: &[usize],
    new: &[[u32; 3]],
    generators: &[V3],
) -> bool {
    let at = |c: u32| to_d3(generators.get(c as usize).copied().unwrap_or([0.0; 3]));
    let corners = |f: [u32; 3]| f.map(at);
    let bbox = |t: &[[f64; 3]; 3]| {
        let lo: [f64; 3] = core::array::from_fn(|k| t[0][k].min(t[1][k]).min(t[2][k]));
        let hi: [f64; 3] = core::array::from_fn(|k| t[0][k].max(t[1][k]).max(t[2][k]));
        (lo, hi)
    };
    let others = faces
        .iter()
        .enumerate()
        .filter(|(h, _)| !replaced.contains(h))
        .map(|(_, &f)| f);
    for (i, &a) in new.iter().enumerate() {
        let pa = corners(a);
        let (lo, hi) = bbox(&pa);
        let earlier = new[..i].iter().copied();
        for b in others.clone().chain(earlier) {
            let pb = corners(b);
            let (blo, bhi) = bbox(&pb);
            if (0..3).any(|k| lo[k] > bhi[k] || blo[k] > hi[k]) {
                continue;
            }
            if faces_intersect(a, &pa, b, &pb) {
                return false;
            }
            // A shared edge: the two must not fold onto each other.
            for k in 0..3 {
                let (u, v) = (a[k], a[(k + 1) % 3]);
                if b.contains(&u) && b.contains(&v) {
                    let third = |f: [u32; 3]| f.into_iter().find(|&c| c != u && c != v);
                    if let (Some(c1), Some(c2)) = (third(a), third(b)) {
                        if folded(at(u), at(v), at(c1), at(c2)) {
                            return false;
                        }
                    }
                }
            }
        }
    }
    true
}

/// Moves the faces of `faces[..nf]` not marked in `marked` to the front, in
/// order; returns how many there are.
fn retain_unmarked(faces: &mut [[u32; 3]], nf: usize, marked: &[bool]) -> usize {
    let mut w = 0;
    for f in 0..nf {
        if !marked.get(f).copied().unwrap_or(false) {
            faces[w] = faces[f];
            w += 1;
        }
    }
    w
}

/// A face's normal, not normalised (twice its area long).
pub(super) fn face_normal(p: [V3; 3]) -> V3 {
    cross(sub(p[1], p[0]), sub(p[2], p[0]))
}

/// When [`try_mesh_in`] writes the mesh out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Output {
    /// Always.
    Always,
    /// Only when every cluster with points has a face and every point lies
    /// within `max_distance` (absolute; infinite for no limit) of the mesh: a
    /// round that falls short is redone after refinement, and its mesh would
    /// be thrown away.
    IfFaithful {
        /// The largest distance from a point to the mesh allowed.
        max_distance: f32,
    },
}

/// Build the mesh of the `selected` candidate facets, closing boundary loops of
/// at most `max_hole` edges (0: none), and fit its vertices to `points` in
/// `fit_rounds` rounds (0: none; see [`crate::meshing::fit`]). `diag` is the bounding-box diagonal (for
/// the degeneracy tolerance of filled faces). Working memory comes from `work`;
/// the result is allocated in `out` (which may be the same allocator), unless
/// `output` says it is not wanted (then `None`, and `out` is untouched). The
/// clusters with points but no face are written to the front of `uncovered`
/// (their count is `stats.uncovered_clusters`), as far as it has room; when
/// a distance bound is not met, the farthest point of each cluster beyond it
/// instead (their count is `stats.far_clusters`).
#[allow(clippy::too_many_arguments)]
pub fn try_mesh_in<'o, 'b, W: Alloc<'b>>(
    out: &'o Arena<'b>,
    work: &W,
    points: &[V3],
    cand: &Candidates,
    members: &Members,
    selected: &[bool],
    generators: &[V3],
    open: &[bool],
    moved: &[V3],
    max_hole: u32,
    fit_rounds: u32,
    diag: f32,
    output: Output,
    uncovered: &mut [u32],
) -> Result<(Option<Mesh<'o>>, MeshStats)> {
    let m = generators.len();
    let ne = cand.edges.len();
    work.scratch(|s| -> Result<(Option<Mesh<'o>>, MeshStats)> {
        // Faces (cluster triples); a face that would be an edge's third is dropped.
        let keep = s.try_alloc_slice::<bool>(selected.len(), false)?;
        let (nf, dropped, boundary0) = s.scratch(|t| -> Result<(usize, u32, usize)> {
            let count = t.try_alloc_slice::<u8>(ne, 0)?;
            let (mut nf, mut dropped) = (0usize, 0u32);
            for (i, _) in selected.iter().enumerate().filter(|(_, &b)| b) {
                let e = cand.facet_edges[i];
                if e.iter().any(|&x| count[x as usize] >= 2) {
                    dropped += 1;
                    continue;
                }
                for &x in &e {
                    count[x as usize] += 1;
                }
                keep[i] = true;
                nf += 1;
            }
            Ok((nf, dropped, count.iter().filter(|&&c| c == 1).count()))
        })?;
        // Room for hole filling (the selection's boundary edges, then three per
        // face removed by repairs) and for inserting skipped clusters (two each).
        let fill_room = if max_hole > 0 {
            boundary0 + 2 * nf + 16
        } else {
            0
        };
        let fill_end = nf + fill_room;
        let faces = s.try_alloc_slice::<[u32; 3]>(fill_end + 2 * m, [0; 3])?;
        for (w, i) in (0..selected.len()).filter(|&i| keep[i]).enumerate() {
            faces[w] = cand.facets[i];
        }
        let tol = crate::meshing::candidates::COINCIDENT * diag;
        let clash = s.try_alloc_slice::<bool>(faces.len(), false)?;
        // Clusters on a boundary loop kept open (along the border of the data).
        let along = s.try_alloc_slice::<bool>(m, false)?;
        let mut nf = nf;
        let mut filled = Filled::default();
        let mut repaired = 0u32;
        let (mut unpinched, mut pinched, mut untangled, mut widened) = (0u32, 0u32, 0u32, 0u32);
        let (mut necked, mut neck_count) = (0u32, 0u32);
        let widen = s.try_alloc_slice::<bool>(faces.len(), false)?;
        let (_, non_orientable) = loop {
            clash[..nf].fill(false);
            let (components, non_orientable) = orient(s, &mut faces[..nf], generators, clash)?;
            if max_hole == 0 {
                break (components, non_orientable);
            }
            // Close the holes; a clash (the selection folded over somewhere, which
            // edge constraints cannot see) is cut out and closed again, a few
            // times at most.
            widen[..nf].fill(false);
            let more = fill_holes(
                s,
                &mut faces[..fill_end],
                nf,
                generators,
                open,
                along,
                widen,
                max_hole,
                tol,
            )?;
            filled.faces += more.faces;
            filled.holes += more.holes;
            filled.left = more.left;
            filled.open = more.open;
            nf += more.faces;
            if non_orientable == 0 || repaired == REPAIRS {
                // A generator whose faces form several fans (the surface pinched
                // there) keeps its largest fan; the others are cut out and their
                // holes closed without it, so no vertex needs splitting in place.
                // Faces that cross others (exact test) or fold onto their
                // neighbour are cut out and their holes closed again.
                if untangled < UNTANGLE_ROUNDS {
                    clash[..nf].fill(false);
                    let crossing = mark_tangles(s, &faces[..nf], generators, clash)?;
                    if crossing > 0 {
                        untangled += 1;
                        nf = retain_unmarked(faces, nf, clash);
                        continue;
                    }
                }
                // A hole no ear could close cleanly is widened by the faces
                // around it and closed again.
                if widened < UNTANGLE_ROUNDS && widen[..nf].contains(&true) {
                    widened += 1;
                    nf = retain_unmarked(faces, nf, widen);
                    continue;
                }
                // A thin part hanging at one vertex joins the surface by a neck.
                if necked < NECK_ROUNDS {
                    let (grown, necks) = neck_pinches(s, faces, nf, fill_end, generators, tol)?;
                    if necks > 0 {
                        necked += 1;
                        neck_count += necks;
                        nf = grown;
                        continue;
                    }
                }
                if unpinched < REPAIRS {
                    clash[..nf].fill(false);
                    let pinches = mark_pinches(s, &faces[..nf], m, clash)?;
                    if pinches > 0 {
                        unpinched += 1;
                        pinched += pinches;
                        nf = retain_unmarked(faces, nf, clash);
                        continue;
                    }
                }
                if more.faces > 0 {
                    clash[..nf].fill(false);
                    break orient(s, &mut faces[..nf], generators, clash)?;
                }
                break (components, non_orientable);
            }
            repaired += 1;
            // Only the faces on both sides of a clashing edge go: cutting their
            // whole neighbourhood opened holes too large to close (block, 250
            // clusters: 27 % of the points left uncovered).
            nf = retain_unmarked(faces, nf, clash);
        };
        // A face none of whose edges has a second face (a stray triangle, or one
        // left when the faces around it were cut out) is a hole no ear can close
        // (its filling would repeat it): it goes.
        let nf = s.scratch(|t| -> Result<usize> {
            let table = edge_table(t, &faces[..nf])?;
            let lone =
                |f: &[u32; 3]| (0..3).all(|k| faces_of(table, key(f[k], f[(k + 1) % 3])).len() < 2);
            let stray = t.try_alloc_slice::<bool>(nf, false)?;
            for (f, x) in faces[..nf].iter().zip(stray.iter_mut()) {
                *x = lone(f);
            }
            Ok(retain_unmarked(faces, nf, stray))
        })?;
        // Small closed pieces beside a large surface (bubbles at a pinch) go;
        // their clusters are then inserted into the surface like any other.
        let (nf, tubes) = join_bubbles(s, faces, nf, faces.len() - 2 * m, generators, tol)?;
        let (nf, bubbles, components) = drop_bubbles(s, faces, nf)?;
        // Clusters the selection skipped go into the mesh.
        let (nf, inserted) = insert_skipped(s, faces, nf, generators, members, tol)?;
        let faces = &mut faces[..nf];
        // Vertex-manifold: union the corners at one generator across shared edges.
        let table = edge_table(s, faces)?;
        let mut fans = UnionFind::try_new_in(s, 3 * nf)?;
        let corner = |f: usize, v: u32| -> u32 {
            let k = faces[f].iter().position(|&x| x == v).unwrap_or(0);
            (3 * f + k) as u32
        };
        let mut boundary = 0u32;
        let on_boundary = s.try_alloc_slice::<bool>(m, false)?;
        let mut i = 0;
        while i < table.len() {
            let k = table[i].0;
            let run = faces_of(&table[i..], k);
            match run {
                [_] => {
                    boundary += 1;
                    for v in [(k >> 32) as usize, k as u32 as usize] {
                        if let Some(b) = on_boundary.get_mut(v) {
                            *b = true;
                        }
                    }
                }
                [(_, f), (_, g), ..] => {
                    let (u, v) = ((k >> 32) as u32, k as u32);
                    for w in [u, v] {
                        fans.union(corner(*f as usize, w), corner(*g as usize, w));
                    }
                }
                [] => {}
            }
            i += run.len().max(1);
        }
        // One output vertex per corner group, numbered in face order.
        let fan = fans.into_roots();
        let vertex_of_root = s.try_alloc_slice::<u32>(3 * nf, NO)?;
        let mut nv = 0u32;
        for c in 0..3 * nf {
            let r = fan[c] as usize;
            if vertex_of_root[r] == NO {
                vertex_of_root[r] = nv;
                nv += 1;
            }
        }
        let used = s.try_alloc_slice::<bool>(m, false)?;
        for face in faces.iter() {
            for &cl in face {
                used[cl as usize] = true;
            }
        }
        let distinct = used.iter().filter(|&&u| u).count() as u32;
        let mut uncovered_clusters = 0;
        let mut uncovered_points = 0;
        for j in 0..members.len().min(m) {
            let size = members.of(j).len() as u32;
            if size > 0 && !used[j] {
                if let Some(slot) = uncovered.get_mut(uncovered_clusters) {
                    *slot = j as u32;
                }
                uncovered_clusters += 1;
                uncovered_points += size;
            }
        }
        let stats = MeshStats {
            vertices: nv,
            faces: nf as u32,
            boundary_edges: boundary,
            components,
            non_orientable,
            bubbles_removed: bubbles,
            tangled_pairs: 0,
            pinches_repaired: pinched,
            necks: neck_count + tubes,
            split_vertices: nv - distinct,
            dropped_faces: dropped,
            holes_filled: filled.holes,
            repairs: repaired,
            filled_faces: filled.faces as u32,
            holes_left: filled.left,
            open_loops: filled.open,
            inserted_clusters: inserted.clusters,
            uncovered_clusters: uncovered_clusters as u32,
            uncovered_points,
            fit: FitStats::default(),
            distance: MeshDistance::default(),
            far_clusters: 0,
        };
        let mut stats = stats;
        let max_distance = match output {
            // Without a distance bound, clusters left out are what refinement
            // splits; with one, the points farthest from the mesh are.
            Output::IfFaithful { max_distance }
                if uncovered_clusters > 0 && max_distance.is_infinite() =>
            {
                return Ok((None, stats))
            }
            Output::IfFaithful { max_distance } => max_distance,
            Output::Always => f32::INFINITY,
        };
        // The mesh is made in scratch and measured there; only a mesh that is
        // wanted is copied out.
        let vertices = s.try_alloc_slice::<V3>(nv as usize, [0.0; 3])?;
        let vertex_cluster = s.try_alloc_slice::<u32>(nv as usize, 0)?;
        let triangles = s.try_alloc_slice::<[u32; 3]>(nf, [0; 3])?;
        for f in 0..nf {
            for k in 0..3 {
                let v = vertex_of_root[fan[3 * f + k] as usize];
                let cl = faces[f][k];
                let c = cl as usize;
                // A border cluster's vertex on the boundary goes onto the data's border.
                let to_border = on_boundary[c] && open.get(c).copied().unwrap_or(false);
                vertices[v as usize] = match moved.get(c) {
                    Some(&p) if to_border => p,
                    _ => generators[c],
                };
                vertex_cluster[v as usize] = cl;
                triangles[f][k] = v;
            }
        }
        // A vertex on a loop kept open whose cluster was not seen as on the border
        // (its neighbours left a narrower gap) also moves onto the data's border:
        // outwards, away from its boundary faces, to its farthest point that way.
        for v in 0..nv as usize {
            let c = vertex_cluster[v] as usize;
            if !(on_boundary[c] && along[c]) || open.get(c).copied().unwrap_or(false) {
                continue;
            }
            let g = generators[c];
            let mut d = [0.0f32; 3];
            for &(k, f) in table.iter() {
                let (a, b) = ((k >> 32) as usize, k as u32 as usize);
                if (a != c && b != c) || faces_of(table, k).len() != 1 {
                    continue;
                }
                let face = faces[f as usize].map(|x| generators[x as usize]);
                let e = sub(generators[b], generators[a]);
                let mut w = cross(e, face_normal(face));
                let centroid = [0, 1, 2].map(|i| (face[0][i] + face[1][i] + face[2][i]) / 3.0);
                if dot(w, sub(g, centroid)) < 0.0 {
                    w = [-w[0], -w[1], -w[2]];
                }
                let l = norm(w);
                if l > 0.0 && l.is_finite() {
                    d = add(d, [w[0] / l, w[1] / l, w[2] / l]);
                }
            }
            let l = norm(d);
            if !(l > 0.0 && l.is_finite()) {
                continue;
            }
            let d = [d[0] / l, d[1] / l, d[2] / l];
            let reach = members
                .of(c)
                .iter()
                .filter_map(|&i| points.get(i as usize))
                .map(|&p| dot(sub(p, g), d))
                .fold(0.0f32, f32::max);
            vertices[v] = [0, 1, 2].map(|i| g[i] + reach * d[i]);
        }
        // The vertices fitted to the data, moving no boundary vertex. A vertex
        // of a face that then crosses another or folds onto its neighbour goes
        // back to its generator (undoing the fit and any move onto the border).
        stats.fit = try_fit_vertices_in(s, points, vertices, triangles, fit_rounds, LAMBDA)?;
        // Then what repair could not resolve is counted on the final
        // positions (again only when a vertex went back: else it is the same).
        let (back, tangled) = s.scratch(|t| -> Result<(u32, u32)> {
            let cut = t.try_alloc_slice::<bool>(nf, false)?;
            let found = mark_tangles(t, triangles, vertices, cut)?;
            if found == 0 {
                return Ok((0, 0));
            }
            let mut back = 0;
            for (f, _) in cut.iter().enumerate().filter(|(_, &c)| c) {
                for &v in &triangles[f] {
                    let v = v as usize;
                    let home = generators[vertex_cluster[v] as usize];
                    if vertices[v] != home {
                        vertices[v] = home;
                        back += 1;
                    }
                }
            }
            if back == 0 {
                return Ok((0, found));
            }
            cut.fill(false);
            Ok((back, mark_tangles(t, triangles, vertices, cut)?))
        })?;
        stats.fit.reverted += back;
        stats.tangled_pairs = tangled;
        // How far the data is from this mesh; the farthest point of every
        // cluster beyond `max_distance` goes to `uncovered` for refinement.
        let far = s.scratch(|t| -> Result<u32> {
            let d = t.try_alloc_slice::<f32>(points.len(), 0.0)?;
            try_point_distances_in(t, points, vertices, triangles, d)?;
            let mut far = 0usize;
            for j in 0..members.len() {
                let worst = members
                    .of(j)
                    .iter()
                    .filter_map(|&i| Some((*d.get(i as usize)?, i)))
                    .fold(None, |w: Option<(f32, u32)>, (e, i)| match w {
                        Some((x, _)) if x >= e => w,
                        _ => Some((e, i)),
                    });
                if let Some((e, i)) = worst {
                    if e > max_distance {
                        if let Some(slot) = uncovered.get_mut(far) {
                            *slot = i;
                        }
                        far += 1;
                    }
                }
            }
            stats.distance = summarise(d, diag);
            Ok(far as u32)
        })?;
        stats.far_clusters = far;
        if far > 0 && max_distance.is_finite() {
            return Ok((None, stats));
        }
        let mesh = Mesh {
            vertices: out.try_alloc_copy(vertices)?,
            triangles: out.try_alloc_copy(triangles)?,
            vertex_cluster: out.try_alloc_copy(vertex_cluster)?,
            stats,
        };
        Ok((Some(mesh), stats))
    })
}
