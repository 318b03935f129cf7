//! Repair of the selected faces towards a valid solid: crossing and folded
//! faces, pinches and thin parts (necks and tubes), bubbles. Each step finds
//! what to change through the edge table or the face grid and changes
//! `faces` in place; [`super::try_mesh_in`] runs them in its repair loop.

use super::{edge_table, face_normal, faces_of, key, NO};
use crate::arena::Alloc;
use crate::error::Result;
use crate::math::{dist2, dot, sub, to_d3, V3};
use crate::meshing::candidates::degenerate;
use crate::meshing::face_grid::FaceGrid;
use crate::meshing::intersect::{faces_intersect, folded};
use crate::parallel;
use crate::progress::Progress;
use crate::union_find::UnionFind;

/// Fewest faces [`untangled`] scans in parallel tasks (fewer: handing them
/// out costs about what it saves).
pub(super) const PARALLEL_SCAN: usize = 1024;

/// Marks in `cut` both faces of every pair of `faces` (over `generators`) that
/// intersect other than at what they share ([`faces_intersect`], exact), and
/// of every edge whose two faces are folded onto each other ([`folded`]).
/// Returns the pairs marked. Candidates come from a [`FaceGrid`], tested in
/// parallel tasks run by `hooks`: O(F k) for k faces near a face, O(F) scratch.
pub(super) fn mark_tangles<'b, S: Alloc<'b>>(
    s: &S,
    faces: &[[u32; 3]],
    generators: &[V3],
    cut: &mut [bool],
    hooks: &dyn Progress,
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
        let grid = FaceGrid::try_new_in(t, generators, faces, hooks)?;
        let crossing = |a: u32, b: u32| {
            let (fa, fb) = (faces[a as usize], faces[b as usize]);
            faces_intersect(fa, &corners(a), fb, &corners(b))
        };
        grid.overlapping_pairs_where(hooks, crossing, &mut mark);
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
/// generator are in one fan when their faces are linked through the edges at
/// it (on an edge of more faces, through its first two). Returns each corner's fan root; `table` is `faces`' edge
/// table. O(F) beyond the table.
pub(super) fn corner_fans<'t, 'b, S: Alloc<'b>>(
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
        if let [(_, f), (_, g), ..] = run {
            for w in [(k >> 32) as u32, k as u32] {
                fans.union(corner(*f, w), corner(*g, w));
            }
        }
        i += run.len().max(1);
    }
    Ok(fans.into_roots())
}

/// The edge-connected pieces of a face list, which of them are bubbles (see
/// [`drop_bubbles`]) and which are closed apart from the largest (see
/// [`join_pieces`]).
struct Pieces<'t> {
    /// Per face, its piece's root (the piece's lowest face).
    root: &'t [u32],
    /// Per root, whether its piece is a bubble.
    bubble: &'t [bool],
    /// Per root, whether its piece is closed and not the largest (ties: the
    /// lowest root is the largest).
    detached: &'t [bool],
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
        let first_largest = size.iter().position(|&n| n as usize == largest);
        let bubble = t.try_alloc_slice::<bool>(nf, false)?;
        let detached = t.try_alloc_slice::<bool>(nf, false)?;
        for r in 0..nf {
            let n = size[r] as usize;
            bubble[r] = closed[r] && n < BUBBLE_FACES && n * BUBBLE_RATIO <= largest;
            detached[r] = closed[r] && n > 0 && Some(r) != first_largest;
        }
        Ok(Pieces {
            root,
            bubble,
            detached,
        })
    }
}

/// Removes from `faces[..nf]` the bubbles: closed edge-connected pieces of
/// fewer than [`BUBBLE_FACES`] faces while another piece has at least
/// [`BUBBLE_RATIO`] times as many (a small object of its own is as large as
/// its neighbours and stays). Returns the faces kept (compacted to the front),
/// the bubbles removed and the pieces left. O(F log F).
pub(super) fn drop_bubbles<'b, S: Alloc<'b>>(
    s: &S,
    faces: &mut [[u32; 3]],
    nf: usize,
) -> Result<(usize, u32, u32)> {
    s.scratch(|t| {
        let Pieces { root, bubble, .. } = Pieces::try_new_in(t, &faces[..nf])?;
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

/// Joins each closed piece but the largest to the rest of the surface by a
/// tube, where one fits: a face of the piece and a face of another piece that
/// face each other go, and six faces join the two triangular holes (corners
/// paired so the tube twists least). Such a piece is most often the tip of a
/// thin part, which the selection closed on itself (then a bubble, see
/// [`drop_bubbles`]) or which repair cut off where it cut out crossing faces
/// and closed both sides of the cut, of any size (`bench/notes.md` has the
/// horse's leg tip); joined, the tip stays in the mesh and the surface keeps
/// its genus (one tube between two pieces makes no handle). Of each piece's
/// facing pairs the eight nearest are tried; a tube
/// is made only when it shares no vertex with either face's other corners, its
/// faces are not degenerate, it crosses or folds onto nothing ([`untangled`])
/// and `joins` takes its faces (not when it would join one piece of the data
/// to another across the empty space between them). Faces are appended from
/// `nf` while room is left below `cap`. Returns the face count and the tubes
/// made. O(B F) per piece of B faces.
#[allow(clippy::too_many_arguments)]
pub(super) fn join_pieces<'b, S: Alloc<'b>>(
    s: &S,
    faces: &mut [[u32; 3]],
    nf: usize,
    cap: usize,
    generators: &[V3],
    tol: f32,
    joins: &dyn Fn(&[[u32; 3]]) -> bool,
    hooks: &dyn Progress,
) -> Result<(usize, u32)> {
    s.scratch(|t| {
        let Pieces { root, detached, .. } = Pieces::try_new_in(t, &faces[..nf])?;
        let at = |c: u32| generators.get(c as usize).copied().unwrap_or([0.0; 3]);
        let centroid = |f: [u32; 3]| {
            let [a, b, c] = f.map(at);
            [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0)
        };
        let normal = |f: [u32; 3]| face_normal(f.map(at));
        let (mut nf, mut tubes) = (nf, 0u32);
        let original = nf;
        for r in 0..original {
            if root[r] as usize != r || !detached[r] || nf + 4 > cap {
                continue;
            }
            // The eight nearest facing pairs (this piece's face, another's).
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
            for &(_, fa, fb) in near.iter().filter(|x| x.0.is_finite()) {
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
                if flat
                    || !untangled(&faces[..nf], &[fa, fb], &tube, generators, hooks)
                    || !joins(&tube)
                {
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
pub(super) fn neck_pinches<'b, S: Alloc<'b>>(
    s: &S,
    faces: &mut [[u32; 3]],
    nf: usize,
    cap: usize,
    generators: &[V3],
    tol: f32,
    hooks: &dyn Progress,
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
                    || !untangled(&faces[..nf], &[fa, fb], &new, generators, hooks)
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
pub(super) fn mark_pinches<'b, S: Alloc<'b>>(
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
/// bounding box) and fold onto no face they share an edge with. O(faces),
/// the faces scanned in the parallel tasks of `hooks` when there are at
/// least [`PARALLEL_SCAN`] (the answer does not depend on the order).
pub(super) fn untangled(
    faces: &[[u32; 3]],
    replaced: &[usize],
    new: &[[u32; 3]],
    generators: &[V3],
    hooks: &dyn Progress,
) -> bool {
    let at = |c: u32| to_d3(generators.get(c as usize).copied().unwrap_or([0.0; 3]));
    let corners = |f: [u32; 3]| f.map(at);
    let bbox = |t: &[[f64; 3]; 3]| {
        let lo: [f64; 3] = core::array::from_fn(|k| t[0][k].min(t[1][k]).min(t[2][k]));
        let hi: [f64; 3] = core::array::from_fn(|k| t[0][k].max(t[1][k]).max(t[2][k]));
        (lo, hi)
    };
    // Only faces whose box meets the new faces' box can meet one of them: a
    // cheap first filter (in f32, exact like the f64 boxes below).
    let pos = |c: u32| generators.get(c as usize).copied().unwrap_or([0.0; 3]);
    let (mut nlo, mut nhi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in new.iter().flatten().map(|&c| pos(c)) {
        for k in 0..3 {
            nlo[k] = nlo[k].min(p[k]);
            nhi[k] = nhi[k].max(p[k]);
        }
    }
    // An axis at a time, so most faces are passed over after one coordinate
    // of each corner.
    let near = |f: &[u32; 3]| {
        (0..3).all(|k| {
            let [a, b, c] = f.map(|c| pos(c)[k]);
            let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
            !(lo > nhi[k] || nlo[k] > hi)
        })
    };
    // Does face `b` cross or fold onto new face `i`?
    let clash = |i: usize, b: [u32; 3]| {
        let a = new[i];
        let (pa, pb) = (corners(a), corners(b));
        let ((lo, hi), (blo, bhi)) = (bbox(&pa), bbox(&pb));
        if (0..3).any(|k| lo[k] > bhi[k] || blo[k] > hi[k]) {
            return false;
        }
        if faces_intersect(a, &pa, b, &pb) {
            return true;
        }
        // A shared edge: the two must not fold onto each other.
        (0..3).any(|k| {
            let (u, v) = (a[k], a[(k + 1) % 3]);
            if !(b.contains(&u) && b.contains(&v)) {
                return false;
            }
            let third = |f: [u32; 3]| f.into_iter().find(|&c| c != u && c != v);
            matches!((third(a), third(b)), (Some(c1), Some(c2)) if folded(at(u), at(v), at(c1), at(c2)))
        })
    };
    let crosses = |h: usize| {
        faces.get(h).is_some_and(|&b| {
            near(&b) && !replaced.contains(&h) && (0..new.len()).any(|i| clash(i, b))
        })
    };
    if hooks.threads() > 1 && faces.len() >= PARALLEL_SCAN {
        let found = parallel::ranges(hooks, faces.len(), |mut part| part.any(crosses));
        if found.contains(&true) {
            return false;
        }
    } else if (0..faces.len()).any(crosses) {
        return false;
    }
    // The new faces among themselves.
    !(1..new.len()).any(|i| new[..i].iter().any(|&b| clash(i, b)))
}

/// Moves the faces of `faces[..nf]` not marked in `marked` to the front, in
/// order; returns how many there are.
pub(super) fn retain_unmarked(faces: &mut [[u32; 3]], nf: usize, marked: &[bool]) -> usize {
    let mut w = 0;
    for f in 0..nf {
        if !marked.get(f).copied().unwrap_or(false) {
            faces[w] = faces[f];
            w += 1;
        }
    }
    w
}
