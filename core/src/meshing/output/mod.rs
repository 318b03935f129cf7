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
//!   and the hole closed again, at most three times. The clashes lie on a seam
//!   where one flood's fronts meet; when the repair then leaves a loop open
//!   (cutting a long seam merged holes past `max_hole`), it is redone from the
//!   selection with the shortest seams of several floods
//!   (`orient::Seam::Shortest`), kept if fewer loops stay open.
//! - No degenerate faces (dropped with the candidates), no duplicates (candidate
//!   facets are distinct vertex triples; a filled triangle equal to an existing
//!   face is refused), every vertex used.
//!
//! Memory: the mesh (12 bytes per vertex and per face) plus O(faces + candidate
//! edges) scratch. Cost: linear in faces and edges (times log F for the edge
//! table), at most three repairs of the selection, one of them with
//! `orient::FLOODS` floods per orientation.

pub mod densify;
mod gaps;
mod holes;
mod insert;
mod orient;
mod repair;
#[cfg(test)]
mod tests;

use crate::arena::{Alloc, Arena};
use crate::clustering::knn::Neighbours;
use crate::clustering::quadric::Planes;
use crate::error::Result;
use crate::math::{add, cross, dot, norm, sub, V3};
use crate::meshing::candidates::{Candidates, Members};
use crate::meshing::distance::{summarise, try_point_distances_in, MeshDistance};
use crate::meshing::fit::{mark_fixed, try_fit_vertices_in, FitStats, LAMBDA};
use crate::params::Params;
use crate::progress::Progress;

use densify::{densify, part_of_surface, Growing};
use holes::{fill_holes, Filled};
use insert::insert_skipped;
use orient::{orient, Seam};
use repair::{
    corner_fans, drop_bubbles, join_pieces, mark_pinches, mark_tangles, neck_pinches,
    retain_unmarked,
};

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
    /// a neck at a pinch, or by a tube from a closed piece.
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
    /// Vertices added where the mesh was farthest from the data
    /// ([`densify`]).
    pub densified: u32,
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
    /// ([`Output::IfFaithful`]), and rims of gaps the faces span (for
    /// [`Output::IfNoGaps`] only those); 0 when it allowed any distance.
    pub far_clusters: u32,
    /// The rims of gaps among them (listed after the far points).
    pub gap_rims: u32,
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

/// Faces of an edge, found by binary search in the sorted `(edge key, face)`
/// table; the run's end by a scan (an edge has one or two faces, rarely more).
pub(super) fn faces_of(table: &[(u64, u32)], key: u64) -> &[(u64, u32)] {
    let lo = table.partition_point(|x| x.0 < key);
    let len = table[lo..].iter().take_while(|x| x.0 == key).count();
    &table[lo..lo + len]
}

pub(super) fn key(u: u32, v: u32) -> u64 {
    let (a, b) = if u < v { (u, v) } else { (v, u) };
    ((a as u64) << 32) | b as u64
}

/// Vertices densifying may add to a mesh of `nv`: the fraction `densify` of
/// them, rounded up. Taken in f32, like the fraction, so that the product
/// snaps to the whole number the decimal fraction gives (0.1 as an f32 is a
/// little above 0.1: widened to f64, 260 vertices allowed 27). Exact for up
/// to 2^24 vertices, far past any cluster cap.
fn densify_budget(densify: f32, nv: usize) -> usize {
    if densify > 0.0 {
        libm::ceilf(densify * nv as f32) as usize
    } else {
        0
    }
}

/// `(edge key, face)` for every edge of every face, sorted.
///
/// By a counting sort on each edge's lower vertex (the key's high half),
/// then each vertex's few edges sorted in place: the order a sort of the
/// whole table gives, in time linear in the faces (plus the vertices: 4 bytes
/// of scratch each, the highest index's count).
pub(super) fn edge_table<'s, 'b, S: Alloc<'b>>(
    s: &'s S,
    faces: &[[u32; 3]],
) -> Result<&'s [(u64, u32)]> {
    let table = s.try_alloc_slice::<(u64, u32)>(3 * faces.len(), (0, 0))?;
    let edges = |t: &[u32; 3]| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])];
    let vertices = faces.iter().flatten().max().map_or(0, |&v| v as usize + 1);
    s.scratch(|t| -> Result<()> {
        // Where each lower vertex's edges end, then (counting down) begin.
        let end = t.try_alloc_slice::<u32>(vertices, 0)?;
        for face in faces {
            for (u, v) in edges(face) {
                end[u.min(v) as usize] += 1;
            }
        }
        let mut sum = 0u32;
        for e in end.iter_mut() {
            sum = sum.saturating_add(*e);
            *e = sum;
        }
        for (f, face) in faces.iter().enumerate() {
            for (u, v) in edges(face) {
                let at = &mut end[u.min(v) as usize];
                *at -= 1;
                table[*at as usize] = (key(u, v), f as u32);
            }
        }
        let mut from = 0;
        for &e in end.iter().skip(1).chain([&(table.len() as u32)]) {
            table[from..e as usize].sort_unstable();
            from = e as usize;
        }
        Ok(())
    })?;
    Ok(table)
}

/// An edge table ([`edge_table`]) with where each lower vertex's edges
/// begin in it: an edge's faces are found among its lower vertex's few edges
/// instead of by a binary search of the whole table. 4 bytes a vertex more.
pub(super) struct EdgeIndex<'s> {
    pub(super) table: &'s [(u64, u32)],
    start: &'s [u32],
}

impl<'s> EdgeIndex<'s> {
    pub(super) fn try_new_in<'b, S: Alloc<'b>>(s: &'s S, faces: &[[u32; 3]]) -> Result<Self> {
        let table = edge_table(s, faces)?;
        let vertices = table.last().map_or(0, |&(k, _)| (k >> 32) as usize + 1);
        let start = s.try_alloc_slice::<u32>(vertices + 1, 0)?;
        for &(k, _) in table {
            if let Some(c) = start.get_mut((k >> 32) as usize + 1) {
                *c += 1;
            }
        }
        for v in 1..start.len() {
            start[v] += start[v - 1];
        }
        Ok(EdgeIndex { table, start })
    }

    /// The faces of edge `key` (see [`faces_of`]).
    pub(super) fn faces_of(&self, key: u64) -> &'s [(u64, u32)] {
        let u = (key >> 32) as usize;
        match (self.start.get(u), self.start.get(u + 1)) {
            (Some(&a), Some(&b)) => self
                .table
                .get(a as usize..b as usize)
                .map_or(&[], |run| faces_of(run, key)),
            _ => &[],
        }
    }
}

/// Edges of `faces` that only one face has.
fn boundary_edges<'b, S: Alloc<'b>>(s: &S, faces: &[[u32; 3]]) -> Result<u32> {
    let table = edge_table(s, faces)?;
    let mut count = 0;
    let mut i = 0;
    while i < table.len() {
        let run = faces_of(&table[i..], table[i].0).len().max(1);
        count += u32::from(run == 1);
        i += run;
    }
    Ok(count)
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
    /// Only when no face spans a gap in the data (a face farther than twice
    /// `max_distance` from every point, where the data goes on past the
    /// rim): a round for the genus
    /// ([`crate::params::GAP_ROUNDS`]), whose points may be far.
    IfNoGaps {
        /// The refinement distance the gaps' bound is a multiple of.
        max_distance: f32,
        /// Whether clusters left out also call for a redo, and when.
        covered: Cover,
    },
    /// Only when every cluster with points has a face (a round that may split
    /// clusters left out past the cap, [`crate::params::GAP_ROOM`]); any
    /// distance otherwise.
    IfCovered,
    /// Only when at most `left_out` points lie in clusters with no face: the
    /// judgement of a round for clusters left out, against the mesh before
    /// it; any distance otherwise.
    IfNoWorse {
        /// Points the mesh before left out.
        left_out: u32,
    },
}

/// When a round for the genus ([`Output::IfNoGaps`]) also asks that every
/// cluster with points has a face.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cover {
    /// It does not.
    No,
    /// Before the gaps: clusters left out are redone first.
    First,
    /// After them: where no face spans a gap, clusters left out are redone.
    After,
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
/// instead (their count is `stats.far_clusters`). Repair joins only clusters
/// of one `piece` of the data
/// ([`try_pieces_in`](crate::meshing::candidates::try_pieces_in)).
#[allow(clippy::too_many_arguments)]
pub fn try_mesh_in<'o, 'b, W: Alloc<'b>>(
    out: &'o Arena<'b>,
    work: &W,
    points: &[V3],
    nb: &Neighbours,
    planes: &Planes,
    cand: &Candidates,
    members: &Members,
    selected: &[bool],
    generators: &[V3],
    open: &[bool],
    moved: &[V3],
    piece: &[u32],
    params: &Params,
    diag: f32,
    output: Output,
    uncovered: &mut [u32],
    hooks: &dyn Progress,
) -> Result<(Option<Mesh<'o>>, MeshStats)> {
    let (max_hole, fit_rounds) = (params.max_hole, params.fit_rounds);
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
        let tol = crate::meshing::candidates::COINCIDENT * diag;
        let clash = s.try_alloc_slice::<bool>(faces.len(), false)?;
        // Clusters on a boundary loop kept open (along the border of the data).
        let along = s.try_alloc_slice::<bool>(m, false)?;
        let widen = s.try_alloc_slice::<bool>(faces.len(), false)?;
        // The repair from the selection: the seams of orientation clashes
        // placed by one flood; when the repair then left a loop open, redone
        // with the shortest seams, and that kept if it left fewer open (else
        // the first repair redone).
        let nf0 = nf;
        let mut work = Workspace {
            faces,
            fill_end,
            clash,
            widen,
            along,
            open,
            m,
            max_hole,
            tol,
        };
        let (mut attempt, mut first_left) = (0u32, 0u32);
        let Repair {
            nf,
            filled,
            repaired,
            pinched,
            necks: neck_count,
            non_orientable,
        } = loop {
            let seam = if attempt == 1 {
                Seam::Shortest
            } else {
                Seam::Flood
            };
            for (w, i) in (0..selected.len()).filter(|&i| keep[i]).enumerate() {
                work.faces[w] = cand.facets[i];
            }
            let repair = repair_selection(s, &mut work, nf0, generators, seam, hooks)?;
            if attempt == 0 && repair.repaired > 0 && repair.filled.left > 0 {
                (attempt, first_left) = (1, repair.filled.left);
                continue;
            }
            if attempt == 1 && repair.filled.left >= first_left {
                attempt = 2;
                continue;
            }
            break repair;
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
        // Closed pieces beside the largest (mostly tips of thin parts) are
        // joined to the rest by a tube where one fits; small ones (bubbles)
        // that none fits are dropped and their clusters inserted into the
        // surface like any other.
        // Faces repair adds (tubes, inserted clusters) join only clusters of
        // one piece of the data: a scan's separate pieces (an ear tip, a paw
        // seen apart from the body) are not joined across the empty space
        // between them.
        let one_piece = |f: &[[u32; 3]]| {
            let of = |c: u32| piece.get(c as usize);
            f.iter()
                .all(|t| of(t[0]) == of(t[1]) && of(t[1]) == of(t[2]))
        };
        let (nf, tubes) = join_pieces(s, faces, nf, fill_end, generators, tol, &one_piece, hooks)?;
        let (nf, bubbles, components) = drop_bubbles(s, faces, nf)?;
        // Clusters the selection skipped go into the mesh.
        let (nf, inserted) =
            insert_skipped(s, faces, nf, generators, members, tol, &one_piece, hooks)?;
        let faces = &mut faces[..nf];
        // Vertex-manifold: the corners at one generator, grouped by the faces
        // linked through the edges at it.
        let table = edge_table(s, faces)?;
        let fan = corner_fans(s, faces, table)?;
        let mut boundary = 0u32;
        let on_boundary = s.try_alloc_slice::<bool>(m, false)?;
        let mut i = 0;
        while i < table.len() {
            let k = table[i].0;
            let run = faces_of(&table[i..], k);
            if run.len() == 1 {
                boundary += 1;
                for v in [(k >> 32) as usize, k as u32 as usize] {
                    if let Some(b) = on_boundary.get_mut(v) {
                        *b = true;
                    }
                }
            }
            i += run.len().max(1);
        }
        // One output vertex per corner group, numbered in face order.
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
            densified: 0,
            uncovered_clusters: uncovered_clusters as u32,
            uncovered_points,
            fit: FitStats::default(),
            distance: MeshDistance::default(),
            far_clusters: 0,
            gap_rims: 0,
        };
        let mut stats = stats;
        let max_distance = match output {
            // Without an error bound, clusters left out are what refinement
            // splits first; with one, and after them, the points farthest
            // from the mesh are.
            Output::IfFaithful { .. }
            | Output::IfNoGaps {
                covered: Cover::First,
                ..
            }
            | Output::IfCovered
                if uncovered_clusters > 0 && params.max_error <= 0.0 =>
            {
                return Ok((None, stats))
            }
            Output::IfNoWorse { left_out } if uncovered_points > left_out => {
                return Ok((None, stats))
            }
            Output::IfFaithful { max_distance } | Output::IfNoGaps { max_distance, .. } => {
                max_distance
            }
            Output::Always | Output::IfCovered | Output::IfNoWorse { .. } => f32::INFINITY,
        };
        // The mesh is made in scratch and measured there; only a mesh that is
        // wanted is copied out. Room for the vertices densifying may add.
        let extra = densify_budget(params.densify, nv as usize);
        let cap_v = nv as usize + extra;
        let vertices = s.try_alloc_slice::<V3>(cap_v, [0.0; 3])?;
        let home = s.try_alloc_slice::<V3>(cap_v, [0.0; 3])?;
        let vertex_cluster = s.try_alloc_slice::<u32>(cap_v, 0)?;
        let triangles = s.try_alloc_slice::<[u32; 3]>(nf + 2 * extra, [0; 3])?;
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
                home[v as usize] = generators[c];
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
        let nv = nv as usize;
        let mut mesh = Growing {
            vertices,
            home,
            vertex_cluster,
            triangles,
            nv,
            nf,
        };
        // How far the data is from this mesh. Where it is farthest, vertices
        // are added.
        let d = s.try_alloc_slice::<f32>(points.len(), 0.0)?;
        // Each point's nearest face, where the next search for it starts.
        let hints = s.try_alloc_slice::<u32>(points.len(), u32::MAX)?;
        if extra > 0 {
            // Vertices moved onto the data's border were not checked for
            // crossings: where they cross, they go back to their generators;
            // then where every vertex is becomes its home, the untangled
            // layout that added vertices are checked against.
            let (back, _) = mesh.untangle(s, hooks)?;
            stats.fit.reverted += back;
            mesh.home[..nv].copy_from_slice(&mesh.vertices[..nv]);
            try_point_distances_in(
                s,
                points,
                &mesh.vertices[..nv],
                &mesh.triangles[..nf],
                d,
                Some(&mut *hints),
                hooks,
            )?;
            let p99 = s.scratch(|t| -> Result<f32> {
                Ok(summarise(t.try_alloc_copy::<f32>(d)?, 1.0).p99)
            })?;
            // Under an error bound every point beyond it is wanted in.
            let bound = params.max_distance(diag);
            let done = densify(
                s, points, members, nb, planes, &mut mesh, d, extra, p99, bound, tol, hooks,
            )?;
            stats.densified = done.added;
        }
        // The vertices fitted to the data, moving no boundary vertex. A vertex
        // of a face that then crosses another or folds onto its neighbour goes
        // back home (its generator, undoing the fit and any move onto the
        // border, or the point it was added at).
        let (nv, nf) = (mesh.nv, mesh.nf);
        stats.fit = try_fit_vertices_in(
            s,
            points,
            &mut mesh.vertices[..nv],
            &mesh.triangles[..nf],
            fit_rounds,
            LAMBDA,
            Some(&mut *hints),
            hooks,
        )?;
        // Then what repair could not resolve is counted on the final
        // positions (again only when a vertex went back: else it is the same).
        let (back, tangled) = mesh.untangle(s, hooks)?;
        stats.fit.reverted += back;
        stats.tangled_pairs = tangled;
        // How far the data is from the final mesh; the farthest point of every
        // cluster beyond `max_distance` goes to `uncovered` for refinement.
        try_point_distances_in(
            s,
            points,
            &mesh.vertices[..nv],
            &mesh.triangles[..nf],
            d,
            Some(&mut *hints),
            hooks,
        )?;
        let (nv, nf) = (mesh.nv, mesh.nf);
        let (vertices, triangles, vertex_cluster) = (
            &mesh.vertices[..nv],
            &mesh.triangles[..nf],
            &mesh.vertex_cluster[..nv],
        );
        // The vertices of boundary edges (the output is manifold, its faces
        // sound), when some point is beyond `refine_beyond`: a far point whose
        // nearest face touches one is data the mesh stops short of (a loop
        // kept open that is no border of the data, or one short of it),
        // whatever its spacing.
        let rim = s.try_alloc_slice::<bool>(nv, false)?;
        if params.max_error <= 0.0 && d.iter().any(|&e| e > max_distance) {
            mark_fixed(s, vertices, triangles, rim)?;
        }
        let at_rim = |i: u32| {
            hints
                .get(i as usize)
                .and_then(|&f| triangles.get(f as usize))
                .is_some_and(|t| t.iter().any(|&v| rim.get(v as usize) == Some(&true)))
        };
        stats.vertices = nv as u32;
        stats.faces = nf as u32;
        if stats.densified > 0 {
            // A vertex added on a boundary edge splits it in two: count them
            // on the final faces.
            stats.boundary_edges = s.scratch(|t| boundary_edges(t, triangles))?;
        }
        // Faces over gaps in the data (a tunnel the clusters straddle), by the
        // cluster whose walk found the gap's rim: the widest gap of each
        // cluster without a far point gets a generator after those.
        let gap = s.try_alloc_slice::<(f32, u32)>(members.len(), (0.0, u32::MAX))?;
        if max_distance.is_finite() {
            let search = gaps::GapSearch {
                points,
                nb,
                planes,
                members,
                vertices,
                vertex_cluster,
            };
            s.scratch(|t| -> Result<()> {
                let found = t.try_alloc_slice::<Option<(u32, f32, u32)>>(nf, None)?;
                let bound = gaps::GAP_SPAN * max_distance;
                gaps::faces_over_gaps(&search, triangles, bound, found, hooks, |cl, e, p| {
                    if let Some(g) = gap.get_mut(cl as usize) {
                        if e > g.0 {
                            *g = (e, p);
                        }
                    }
                });
                Ok(())
            })?;
        }
        // A round for the genus lists only the rims of gaps.
        let far_points = !matches!(output, Output::IfNoGaps { .. });
        let far = {
            let mut far = 0usize;
            for j in (0..members.len()).filter(|_| far_points) {
                // Under an error bound every point counts; refining towards
                // `refine_beyond`, only those that are part of the surface (a
                // stray point would draw a spike).
                let worst = members
                    .of(j)
                    .iter()
                    .filter_map(|&i| Some((*d.get(i as usize)?, i)))
                    .filter(|&(e, i)| {
                        params.max_error > 0.0
                            || e <= max_distance
                            || at_rim(i)
                            || part_of_surface(points, nb, planes, d, i, e)
                    })
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
                        // This cluster's far point comes first.
                        if let Some(g) = gap.get_mut(j) {
                            g.1 = u32::MAX;
                        }
                    }
                }
            }
            // Then the rims of gaps, widest first, each point once.
            let listed = far.min(uncovered.len());
            let rims = s.scratch(|t| -> Result<usize> {
                let taken = t.try_alloc_copy::<u32>(&uncovered[..listed])?;
                taken.sort_unstable();
                let gap = &mut gap[..];
                // Each point once (its widest gap), none already listed.
                gap.sort_unstable_by(|a, b| a.1.cmp(&b.1).then(b.0.total_cmp(&a.0)));
                let mut prev = u32::MAX;
                for g in gap.iter_mut() {
                    let p = g.1;
                    if p == prev || taken.binary_search(&p).is_ok() {
                        g.1 = u32::MAX;
                    }
                    prev = p;
                }
                gap.sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
                let mut more = 0;
                for &(_, p) in gap.iter().filter(|g| g.1 != u32::MAX) {
                    if let Some(slot) = uncovered.get_mut(listed + more) {
                        *slot = p;
                    }
                    more += 1;
                }
                Ok(more)
            })?;
            stats.gap_rims = rims as u32;
            stats.distance = summarise(d, diag);
            (far + rims) as u32
        };
        stats.far_clusters = far;
        let redo = if far_points { far } else { stats.gap_rims };
        if redo > 0 && max_distance.is_finite() {
            return Ok((None, stats));
        }
        // No gap: clusters left out (still at the front of `uncovered`).
        let after = matches!(
            output,
            Output::IfNoGaps {
                covered: Cover::After,
                ..
            }
        );
        if after && stats.uncovered_clusters > 0 && params.max_error <= 0.0 {
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

/// What [`repair_selection`] did.
struct Repair {
    /// Faces after it.
    nf: usize,
    filled: Filled,
    /// Rounds that cut out the faces on orientation clashes.
    repaired: u32,
    /// Generators where the surface pinched, cut out.
    pinched: u32,
    /// Thin parts joined by a neck.
    necks: u32,
    /// Components that could not be oriented consistently, at the end.
    non_orientable: u32,
}

/// The faces, their marks and the bounds [`repair_selection`] works in.
struct Workspace<'w> {
    /// Faces: the selection's first, then room for filling up to `fill_end`.
    faces: &'w mut [[u32; 3]],
    fill_end: usize,
    clash: &'w mut [bool],
    widen: &'w mut [bool],
    /// Clusters on a boundary loop kept open (along the border of the data).
    along: &'w mut [bool],
    /// Generators (clusters) on the border of the data.
    open: &'w [bool],
    /// Clusters in all.
    m: usize,
    max_hole: u32,
    tol: f32,
}

/// Orient the first `nf` faces (the selection's), close their holes and
/// repair them: faces on orientation clashes (seams placed by `seam`),
/// crossing or folded faces, holes no ear closes cleanly, thin parts hanging
/// at one vertex and pinched generators are cut out or joined, and the holes
/// closed again, each a bounded number of rounds. Cost: each round is linear
/// in the faces (times log F for the edge table).
fn repair_selection<'b, S: Alloc<'b>>(
    s: &S,
    w: &mut Workspace,
    nf: usize,
    generators: &[V3],
    seam: Seam,
    hooks: &dyn Progress,
) -> Result<Repair> {
    let Workspace {
        faces,
        fill_end,
        clash,
        widen,
        along,
        open,
        m,
        max_hole,
        tol,
    } = w;
    let (faces, clash, widen, along) = (&mut **faces, &mut **clash, &mut **widen, &mut **along);
    let (fill_end, open, m, max_hole, tol) = (*fill_end, *open, *m, *max_hole, *tol);
    let mut nf = nf;
    let mut filled = Filled::default();
    let mut repaired = 0u32;
    let (mut unpinched, mut pinched, mut untangled, mut widened) = (0u32, 0u32, 0u32, 0u32);
    let (mut necked, mut neck_count) = (0u32, 0u32);
    let (_, non_orientable) = loop {
        clash[..nf].fill(false);
        let (components, non_orientable) = orient(s, &mut faces[..nf], generators, clash, seam)?;
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
            hooks,
        )?;
        filled.faces += more.faces;
        filled.holes += more.holes;
        filled.left = more.left;
        filled.open = more.open;
        nf += more.faces;
        if non_orientable == 0 || repaired == REPAIRS {
            // Faces that cross others (exact test) or fold onto their
            // neighbour are cut out and their holes closed again.
            if untangled < UNTANGLE_ROUNDS {
                clash[..nf].fill(false);
                let crossing = mark_tangles(s, &faces[..nf], generators, clash, hooks)?;
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
                let (grown, necks) = neck_pinches(s, faces, nf, fill_end, generators, tol, hooks)?;
                if necks > 0 {
                    necked += 1;
                    neck_count += necks;
                    nf = grown;
                    continue;
                }
            }
            // Any other generator whose faces form several fans (the
            // surface pinched there) keeps its largest fan; the others are
            // cut out and their holes closed without it, so no vertex
            // needs splitting in place.
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
                break orient(s, &mut faces[..nf], generators, clash, seam)?;
            }
            break (components, non_orientable);
        }
        repaired += 1;
        // Only the faces on both sides of a clashing edge go: cutting their
        // whole neighbourhood opened holes too large to close (block, 250
        // clusters: 27 % of the points left uncovered).
        nf = retain_unmarked(faces, nf, clash);
    };
    Ok(Repair {
        nf,
        filled,
        repaired,
        pinched,
        necks: neck_count,
        non_orientable,
    })
}
