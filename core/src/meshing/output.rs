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

use crate::arena::{Alloc, Arena};
use crate::error::Result;
use crate::math::{add, cross, dist2, dot, norm, sub, V3};
use crate::meshing::candidates::degenerate;
use crate::meshing::candidates::{Candidates, Members};
use crate::union_find::UnionFind;

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
    /// Extra vertices made to separate fans at non-manifold generators.
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
    /// Clusters (with points) that no face uses: uncovered parts of the data.
    pub uncovered_clusters: u32,
    /// Points in those clusters.
    pub uncovered_points: u32,
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

/// Rounds of cutting out orientation clashes at most.
const REPAIRS: u32 = 3;

/// Faces of an edge, found by binary search in the sorted `(edge key, face)` table.
fn faces_of(table: &[(u64, u32)], key: u64) -> &[(u64, u32)] {
    let lo = table.partition_point(|x| x.0 < key);
    let hi = lo + table[lo..].partition_point(|x| x.0 == key);
    &table[lo..hi]
}

fn key(u: u32, v: u32) -> u64 {
    let (a, b) = if u < v { (u, v) } else { (v, u) };
    ((a as u64) << 32) | b as u64
}

/// `(edge key, face)` for every edge of every face, sorted.
fn edge_table<'s, 'b, S: Alloc<'b>>(s: &'s S, faces: &[[u32; 3]]) -> Result<&'s [(u64, u32)]> {
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
fn dir(c: [u32; 3], u: u32, v: u32) -> i32 {
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

fn det(p: [[f64; 3]; 3]) -> f64 {
    p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1])
        - p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0])
        + p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0])
}

/// Orient the faces in place: neighbours run their shared edge in opposite
/// directions, and each component encloses a positive volume. Returns the number
/// of components and of components that could not be oriented consistently; the
/// faces on both sides of an edge where the orientation clashes are marked in
/// `clash`.
fn orient<'b, S: Alloc<'b>>(
    s: &S,
    faces: &mut [[u32; 3]],
    generators: &[V3],
    clash: &mut [bool],
) -> Result<(u32, u32)> {
    let nf = faces.len();
    s.scratch(|t| {
        let table = edge_table(t, faces)?;
        let flip = t.try_alloc_slice::<bool>(nf, false)?;
        let comp = t.try_alloc_slice::<u32>(nf, NO)?;
        let queue = t.try_alloc_slice::<u32>(nf, 0)?;
        let cycle = |f: &[u32; 3], flipped: bool| if flipped { [f[0], f[2], f[1]] } else { *f };
        let (mut components, mut non_orientable) = (0u32, 0u32);
        for start in 0..nf {
            if comp[start] != NO {
                continue;
            }
            let id = components;
            components += 1;
            comp[start] = id;
            queue[0] = start as u32;
            let (mut head, mut tail) = (0usize, 1usize);
            let mut conflict = false;
            while head < tail {
                let f = queue[head] as usize;
                head += 1;
                let cf = cycle(&faces[f], flip[f]);
                for k in 0..3 {
                    let (u, v) = (cf[k], cf[(k + 1) % 3]);
                    for &(_, g) in faces_of(table, key(u, v)) {
                        let g = g as usize;
                        if g == f {
                            continue;
                        }
                        // g must run the edge opposite to f.
                        let want_flip = dir(faces[g], u, v) == 1;
                        if comp[g] == NO {
                            comp[g] = id;
                            flip[g] = want_flip;
                            queue[tail] = g as u32;
                            tail += 1;
                        } else if flip[g] != want_flip {
                            conflict = true;
                            clash[f] = true;
                            clash[g] = true;
                        }
                    }
                }
            }
            if conflict {
                non_orientable += 1;
            }
        }
        let volume = t.try_alloc_slice::<f64>(components as usize, 0.0)?;
        for f in 0..nf {
            let c = cycle(&faces[f], flip[f]);
            volume[comp[f] as usize] += det(c.map(|j| generators[j as usize].map(|x| x as f64)));
        }
        for f in 0..nf {
            if volume[comp[f] as usize] < 0.0 {
                flip[f] = !flip[f];
            }
            faces[f] = cycle(&faces[f], flip[f]);
        }
        Ok((components, non_orientable))
    })
}

/// What hole filling did.
/// Loops shorter than this are filled even along the border of the data: a real
/// border is long, while a spurious one (a few clusters that look like border on a
/// noisy or sharp closed surface) rings a small hole.
const MIN_OPEN_LOOP: usize = 12;

#[derive(Clone, Copy, Default)]
struct Filled {
    faces: usize,
    holes: u32,
    left: u32,
    /// Loops kept open: most of their vertices are on the border of the data.
    open: u32,
}

/// Close the boundary loops of the oriented `faces[..nf]` that have at most
/// `max_hole` edges, appending faces after `nf` (room for one face per boundary
/// edge is required). Each loop is cut by ears, the shortest new edge first
/// (an ear turning against the loop's surrounding faces costs 16 times more); an
/// ear is never degenerate and never adds an edge the mesh already has, so every
/// edge keeps at most two faces. A loop with no admissible ear stays open.
#[allow(clippy::too_many_arguments)]
fn fill_holes<'b, S: Alloc<'b>>(
    s: &S,
    faces: &mut [[u32; 3]],
    nf: usize,
    generators: &[V3],
    open: &[bool],
    along: &mut [bool],
    max_hole: u32,
    tol: f32,
) -> Result<Filled> {
    let mut out = Filled::default();
    along.fill(false);
    s.scratch(|t| {
        let table = edge_table(t, &faces[..nf])?;
        // Hole half-edges (from, to, face): the reverse of each boundary edge.
        // An edge with a single face: its key differs from both neighbours'.
        let alone = |i: usize| {
            let k = table[i].0;
            (i == 0 || table[i - 1].0 != k) && (i + 1 == table.len() || table[i + 1].0 != k)
        };
        let nh = (0..table.len()).filter(|&i| alone(i)).count();
        if nh == 0 {
            return Ok(out);
        }
        let holes = t.try_alloc_slice::<(u32, u32, u32)>(nh, (0, 0, 0))?;
        let mut w = 0;
        for (i, &(k, f)) in table.iter().enumerate() {
            if alone(i) {
                let (u, v) = ((k >> 32) as u32, k as u32);
                let c = faces[f as usize];
                holes[w] = if dir(c, u, v) == 1 {
                    (v, u, f)
                } else {
                    (u, v, f)
                };
                w += 1;
            }
        }
        holes.sort_unstable();
        if faces.len() - nf < nh {
            out.left = 1;
            return Ok(out);
        }
        let used = t.try_alloc_slice::<bool>(nh, false)?;
        let poly = t.try_alloc_slice::<u32>(nh, 0)?;
        // The face beside each loop edge poly[i] -> poly[i + 1] (for local normals).
        let beside = t.try_alloc_slice::<u32>(nh, 0)?;
        let added = t.try_alloc_slice::<u64>(nh, 0)?;
        let mut n_added = 0usize;
        let g = |j: u32| generators[j as usize];
        for h0 in 0..nh {
            if used[h0] {
                continue;
            }
            // Trace the loop through unused hole half-edges.
            let (first, mut cur, f0) = holes[h0];
            used[h0] = true;
            poly[0] = first;
            beside[0] = f0;
            let mut len = 1usize;
            let mut closed = true;
            while cur != first {
                let lo = holes.partition_point(|x| x.0 < cur);
                let next = (lo..nh)
                    .take_while(|&i| holes[i].0 == cur)
                    .find(|&i| !used[i]);
                let Some(h) = next else {
                    closed = false;
                    break;
                };
                used[h] = true;
                poly[len] = cur;
                beside[len] = holes[h].2;
                len += 1;
                cur = holes[h].1;
            }
            if !closed {
                out.left += 1;
                continue;
            }
            // A loop through a vertex twice (holes touching at a corner) is cut
            // there into simple loops, each handled on its own.
            loop {
                let pinch = (1..len)
                    .find_map(|j| poly[..j].iter().position(|&v| v == poly[j]).map(|i| (i, j)));
                let (lo, hi) = pinch.unwrap_or((0, len));
                let sub = &mut poly[lo..hi];
                let side = &mut beside[lo..hi];
                let mut normal = [0.0f32; 3];
                for &f in side.iter() {
                    normal = add(normal, face_normal(faces[f as usize].map(g)));
                }
                let n = sub.len();
                let on_border = sub
                    .iter()
                    .filter(|&&v| open.get(v as usize).copied().unwrap_or(false))
                    .count();
                if n >= MIN_OPEN_LOOP && 2 * on_border >= n {
                    out.open += 1;
                    for &v in sub.iter() {
                        if let Some(a) = along.get_mut(v as usize) {
                            *a = true;
                        }
                    }
                    let known = |a: u32, c: u32| {
                        !faces_of(table, key(a, c)).is_empty()
                            || added[..n_added].contains(&key(a, c))
                    };
                    let ears = fill_notches(
                        faces,
                        nf + out.faces,
                        sub,
                        side,
                        generators,
                        open,
                        tol,
                        known,
                    );
                    for &[a, _, c] in &faces[nf + out.faces..nf + out.faces + ears] {
                        added[n_added] = key(a, c);
                        n_added += 1;
                    }
                    out.faces += ears;
                } else if n < 3 || n > max_hole as usize {
                    out.left += 1;
                } else if fill_loop(
                    faces,
                    nf + out.faces,
                    sub,
                    normal,
                    generators,
                    tol,
                    |a, c| {
                        !faces_of(table, key(a, c)).is_empty()
                            || added[..n_added].contains(&key(a, c))
                    },
                ) && !{
                    // The last ear closes the loop: it must not repeat a face.
                    let mut tri = faces[nf + out.faces + n - 3];
                    tri.sort_unstable();
                    faces_of(table, key(tri[0], tri[1])).iter().any(|&(_, f)| {
                        let mut x = faces[f as usize];
                        x.sort_unstable();
                        x == tri
                    })
                } {
                    // The ears' new edges are the first and third corners.
                    let ears = n - 2;
                    for k in 0..ears {
                        let [a, _, c] = faces[nf + out.faces + k];
                        added[n_added] = key(a, c);
                        n_added += 1;
                    }
                    out.faces += ears;
                    out.holes += 1;
                } else {
                    out.left += 1;
                }
                if pinch.is_none() {
                    break;
                }
                poly.copy_within(hi..len, lo);
                beside.copy_within(hi..len, lo);
                len -= hi - lo;
            }
        }
        Ok(out)
    })
}

/// Cut the simple loop `poly` (a hole, traversed the way its filling faces
/// turn, `normal` roughly their side) into `poly.len() - 2` ears written from
/// `faces[at]` on, the shortest new edge first (an ear turning against `normal`
/// costs 16 times more). An ear is never degenerate, never adds an edge the
/// mesh already has (`known`, or an earlier ear of this loop). Returns false,
/// with `faces` from `at` on left to be overwritten, when no admissible ear is
/// left. `poly` is consumed.
#[allow(clippy::too_many_arguments)]
fn fill_loop(
    faces: &mut [[u32; 3]],
    at: usize,
    poly: &mut [u32],
    normal: V3,
    generators: &[V3],
    tol: f32,
    known: impl Fn(u32, u32) -> bool,
) -> bool {
    let g = |j: u32| generators.get(j as usize).copied().unwrap_or([0.0; 3]);
    let mut len = poly.len();
    if len < 3 || at + len - 2 > faces.len() {
        return false;
    }
    let mut ears = 0usize;
    while len > 3 {
        let mut best: Option<(f32, usize)> = None;
        for i in 0..len {
            let (a, b, c) = (poly[(i + len - 1) % len], poly[i], poly[(i + 1) % len]);
            let repeats = faces[at..at + ears]
                .iter()
                .any(|f| key(f[0], f[2]) == key(a, c));
            if a == c || known(a, c) || repeats || degenerate(g(a), g(b), g(c), tol) {
                continue;
            }
            let turn = dot(cross(sub(g(b), g(a)), sub(g(c), g(b))), normal);
            let cost = dist2(g(a), g(c)) * if turn < 0.0 { 16.0 } else { 1.0 };
            if best.is_none_or(|(bc, _)| cost < bc) {
                best = Some((cost, i));
            }
        }
        let Some((_, i)) = best else { return false };
        faces[at + ears] = [poly[(i + len - 1) % len], poly[i], poly[(i + 1) % len]];
        ears += 1;
        poly.copy_within(i + 1..len, i);
        len -= 1;
    }
    let (a, b, c) = (poly[0], poly[1], poly[2]);
    if degenerate(g(a), g(b), g(c), tol) {
        return false;
    }
    faces[at + ears] = [a, b, c];
    true
}

/// Widest angle (degrees) at a notch: a vertex of a loop kept open that is not
/// itself on the border of the data, where the loop turns into the surface
/// between its neighbours.
const NOTCH_DEGREES: f32 = 135.0;

/// Along a loop kept open because it runs on the border of the data, close the
/// notches: where a facet next to the border was not selected, the loop dips
/// into the surface through a cluster that is not on the border (its neighbours
/// along the loop are), about a cluster's width deep. An ear across such a
/// vertex (turning the hole's way, at most [`NOTCH_DEGREES`] wide) puts the loop
/// back onto the border. Ears are written from `faces[at]` on (room for one per
/// loop edge is required); `poly` and `beside` (the loop's vertices, and the
/// face beside each loop edge `poly[i] -> poly[i + 1]`) are updated as ears cut
/// vertices off. Like hole filling, an ear is never degenerate and never adds
/// an edge the mesh (`known`) or an earlier ear already has. Returns the ears
/// written.
#[allow(clippy::too_many_arguments)]
fn fill_notches(
    faces: &mut [[u32; 3]],
    at: usize,
    poly: &mut [u32],
    beside: &mut [u32],
    generators: &[V3],
    open: &[bool],
    tol: f32,
    known: impl Fn(u32, u32) -> bool,
) -> usize {
    let g = |j: u32| generators.get(j as usize).copied().unwrap_or([0.0; 3]);
    let unit = |v: V3| {
        let l = norm(v);
        if l > 0.0 {
            [v[0] / l, v[1] / l, v[2] / l]
        } else {
            [0.0; 3]
        }
    };
    let cos_max = libm::cosf(NOTCH_DEGREES.to_radians());
    let mut len = poly.len().min(beside.len());
    let mut ears = 0usize;
    while len > MIN_OPEN_LOOP && at + ears < faces.len() {
        // The sharpest notch first (the smallest angle, the lowest position on ties).
        let mut best: Option<(f32, usize)> = None;
        for i in 0..len {
            let prev = (i + len - 1) % len;
            let (a, b, c) = (poly[prev], poly[i], poly[(i + 1) % len]);
            if open.get(b as usize).copied().unwrap_or(true) || a == c {
                continue;
            }
            let (pa, pb, pc) = (g(a), g(b), g(c));
            let normal = |f: u32| {
                let face = faces.get(f as usize).copied().unwrap_or([0; 3]);
                unit(face_normal(face.map(g)))
            };
            let n = add(normal(beside[prev]), normal(beside[i]));
            let (ba, bc) = (unit(sub(pa, pb)), unit(sub(pc, pb)));
            let cos = dot(ba, bc);
            let turn = dot(cross(sub(pb, pa), sub(pc, pb)), n);
            if turn <= 0.0 || cos < cos_max || best.is_some_and(|(bc, _)| bc >= cos) {
                continue;
            }
            let repeats = faces[at..at + ears]
                .iter()
                .any(|f| key(f[0], f[2]) == key(a, c));
            if known(a, c) || repeats || degenerate(pa, pb, pc, tol) {
                continue;
            }
            best = Some((cos, i));
        }
        let Some((_, i)) = best else { break };
        let prev = (i + len - 1) % len;
        faces[at + ears] = [poly[prev], poly[i], poly[(i + 1) % len]];
        beside[prev] = (at + ears) as u32;
        ears += 1;
        poly.copy_within(i + 1..len, i);
        beside.copy_within(i + 1..len, i);
        len -= 1;
    }
    ears
}

fn face_normal(p: [V3; 3]) -> V3 {
    cross(sub(p[1], p[0]), sub(p[2], p[0]))
}

/// When [`try_mesh_in`] writes the mesh out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Output {
    /// Always.
    Always,
    /// Only when every cluster with points has a face: a round that leaves data
    /// uncovered is redone after refinement, and its mesh would be thrown away.
    IfCovered,
}

/// Build the mesh of the `selected` candidate facets, closing boundary loops of
/// at most `max_hole` edges (0: none). `diag` is the bounding-box diagonal (for
/// the degeneracy tolerance of filled faces). Working memory comes from `work`;
/// the result is allocated in `out` (which may be the same allocator), unless
/// `output` says it is not wanted (then `None`, and `out` is untouched). The
/// clusters with points but no face are written to the front of `uncovered`
/// (their count is `stats.uncovered_clusters`), as far as it has room.
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
        // Room for hole filling: the selection's boundary edges, then three per
        // face removed by repairs.
        let room = if max_hole > 0 {
            boundary0 + 2 * nf + 16
        } else {
            0
        };
        let faces = s.try_alloc_slice::<[u32; 3]>(nf + room, [0; 3])?;
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
        let (components, non_orientable) = loop {
            clash[..nf].fill(false);
            let (components, non_orientable) = orient(s, &mut faces[..nf], generators, clash)?;
            if max_hole == 0 {
                break (components, non_orientable);
            }
            // Close the holes; a clash (the selection folded over somewhere, which
            // edge constraints cannot see) is cut out and closed again, a few
            // times at most.
            let more = fill_holes(s, faces, nf, generators, open, along, max_hole, tol)?;
            filled.faces += more.faces;
            filled.holes += more.holes;
            filled.left = more.left;
            filled.open = more.open;
            nf += more.faces;
            if non_orientable == 0 || repaired == REPAIRS {
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
            let mut w = 0;
            for f in 0..nf {
                if !clash[f] {
                    faces[w] = faces[f];
                    w += 1;
                }
            }
            nf = w;
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
            let mut w = 0;
            for f in 0..nf {
                if !stray[f] {
                    faces[w] = faces[f];
                    w += 1;
                }
            }
            Ok(w)
        })?;
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
            split_vertices: nv - distinct,
            dropped_faces: dropped,
            holes_filled: filled.holes,
            repairs: repaired,
            filled_faces: filled.faces as u32,
            holes_left: filled.left,
            open_loops: filled.open,
            uncovered_clusters: uncovered_clusters as u32,
            uncovered_points,
        };
        if output == Output::IfCovered && uncovered_clusters > 0 {
            return Ok((None, stats));
        }
        let vertices = out.try_alloc_slice::<V3>(nv as usize, [0.0; 3])?;
        let vertex_cluster = out.try_alloc_slice::<u32>(nv as usize, 0)?;
        let triangles = out.try_alloc_slice::<[u32; 3]>(nf, [0; 3])?;
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
        let mesh = Mesh {
            vertices,
            triangles,
            vertex_cluster,
            stats,
        };
        Ok((Some(mesh), stats))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::MaybeUninit;
    use std::vec;
    use std::vec::Vec;

    /// Octahedron around the origin, faces counter-clockwise from outside.
    fn octahedron() -> (Vec<V3>, Vec<[u32; 3]>) {
        let v = vec![
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ];
        let f = vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        (v, f)
    }

    /// Every edge has exactly two faces running it in opposite directions.
    fn closed_and_consistent(faces: &[[u32; 3]]) -> bool {
        let mut half: Vec<(u32, u32)> = faces
            .iter()
            .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
            .collect();
        half.sort_unstable();
        let n = half.len();
        half.dedup();
        half.len() == n
            && half
                .iter()
                .all(|&(a, b)| half.binary_search(&(b, a)).is_ok())
    }

    fn fill(faces: &[[u32; 3]], v: &[V3], max_hole: u32) -> (Vec<[u32; 3]>, Filled, u32) {
        let mut buf = vec![MaybeUninit::uninit(); 1 << 16];
        let arena = Arena::new(&mut buf);
        let nf = faces.len();
        let all = arena
            .try_alloc_slice::<[u32; 3]>(3 * nf + 8, [0; 3])
            .unwrap();
        all[..nf].copy_from_slice(faces);
        let clash = arena.try_alloc_slice::<bool>(all.len(), false).unwrap();
        orient(&arena, &mut all[..nf], v, clash).unwrap();
        let filled = fill_holes(&arena, all, nf, v, &[], &mut [], max_hole, 1e-6).unwrap();
        let total = nf + filled.faces;
        clash.fill(false);
        let (_, bad) = orient(&arena, &mut all[..total], v, clash).unwrap();
        (all[..total].to_vec(), filled, bad)
    }

    #[test]
    fn holes_close_into_a_consistently_oriented_surface() {
        let (v, f) = octahedron();
        assert!(closed_and_consistent(&f));
        // One face missing: a triangular hole gets exactly that face back.
        let (out, filled, bad) = fill(&f[1..], &v, 64);
        assert_eq!((filled.holes, filled.faces, filled.left, bad), (1, 1, 0, 0));
        assert!(closed_and_consistent(&out));
        let mut back = out[out.len() - 1];
        back.sort_unstable();
        assert_eq!(back, [0, 2, 4]);
        // Two faces around one vertex: a quad hole, two faces, no edge reused.
        let (out, filled, bad) = fill(&f[2..], &v, 64);
        assert_eq!((filled.holes, filled.faces, filled.left, bad), (1, 2, 0, 0));
        assert!(closed_and_consistent(&out));
        // The upper half gone: a square hole through four vertices of the waist.
        let (out, filled, _) = fill(&f[4..], &v, 64);
        assert_eq!((filled.holes, filled.faces), (1, 2));
        assert!(closed_and_consistent(&out));
    }

    #[test]
    fn holes_longer_than_the_limit_stay_open() {
        let (v, f) = octahedron();
        let (out, filled, _) = fill(&f[2..], &v, 3);
        assert_eq!((filled.holes, filled.faces, filled.left), (0, 0, 1));
        assert_eq!(out.len(), 6);
        assert!(!closed_and_consistent(&out));
    }

    #[test]
    fn an_ear_never_repeats_an_existing_edge() {
        // A flat sheet of two triangles sharing edge 0-2: its outline 0-1-2-3 is
        // one hole whose ears at 1 and 3 would add 0-2 a second time (a third face
        // on it); the fill must use the diagonal 1-3 instead.
        let v = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        let f = [[0u32, 1, 2], [0, 2, 3]];
        let (out, filled, bad) = fill(&f, &v, 64);
        assert_eq!((filled.holes, filled.faces, filled.left, bad), (1, 2, 0, 0));
        assert!(closed_and_consistent(&out));
        for t in &out[2..] {
            assert!(t.contains(&1) && t.contains(&3), "{t:?}");
        }
    }
}
