//! Skipped clusters: generators the selection jumped over, put back into the
//! mesh.

use super::face_normal;
use super::repair::untangled;
use crate::arena::Alloc;
use crate::error::Result;
use crate::math::{closest_on_triangle, dist2, dot, V3};
use crate::meshing::candidates::{degenerate, Members};
use crate::progress::Progress;

/// Below this barycentric coordinate, a skipped cluster's generator goes into
/// the edge opposite it rather than into the face.
const EDGE_BARYCENTRIC: f32 = 0.15;

/// Every cluster with points that no face uses, and that no face could be
/// split to reach, is left out; the others are inserted.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Inserted {
    /// Generators put into the mesh.
    pub clusters: u32,
    /// Clusters with points that no face uses even so: no face, or every
    /// split there would give a degenerate or folded face.
    pub left_out: u32,
}

/// Puts into the mesh the generator of every cluster with points that no face
/// of `faces[..nf]` uses (the selection joined its neighbours straight across
/// it, cutting off the data there): into its nearest face, split in three, or,
/// when it lies nearest an edge of that face, into the edge, whose faces are
/// each split in two. A split that would make a degenerate face (edge or area
/// below `tol`) or turn a face over (its normal against the face it replaces)
/// is not made, nor one whose new faces would cross a face of the mesh or fold
/// onto a neighbour ([`untangled`]), or that `joins` refuses (a cluster of
/// one piece of the data put into a face of another, across the empty space
/// between them). Windings are kept, so orientation and edge-manifoldness
/// hold.
/// `faces` must have room for two more faces per insertion; clusters beyond
/// that room are left out. Cost: O(faces) per skipped cluster.
#[allow(clippy::too_many_arguments)]
pub(super) fn insert_skipped<'b, S: Alloc<'b>>(
    s: &S,
    faces: &mut [[u32; 3]],
    nf: usize,
    generators: &[V3],
    members: &Members,
    tol: f32,
    joins: &dyn Fn(&[[u32; 3]]) -> bool,
    hooks: &dyn Progress,
) -> Result<(usize, Inserted)> {
    let m = generators.len();
    s.scratch(|t| {
        let used = t.try_alloc_slice::<bool>(m, false)?;
        for f in &faces[..nf] {
            for &c in f {
                if let Some(u) = used.get_mut(c as usize) {
                    *u = true;
                }
            }
        }
        let mut nf = nf;
        let mut out = Inserted::default();
        for j in 0..m.min(members.len()) {
            if used[j] || members.of(j).is_empty() {
                continue;
            }
            let g = generators[j];
            // The nearest face (lowest index among equals).
            let mut nearest: Option<(usize, f32, [f32; 3])> = None;
            for (f, face) in faces[..nf].iter().enumerate() {
                let [a, b, c] =
                    face.map(|c| generators.get(c as usize).copied().unwrap_or([0.0; 3]));
                let (q, bary) = closest_on_triangle(g, a, b, c);
                let d2 = dist2(g, q);
                if nearest.is_none_or(|(_, e, _)| d2 < e) {
                    nearest = Some((f, d2, bary));
                }
            }
            let grown = nearest.and_then(|(f, _, bary)| {
                split_at(faces, nf, f, bary, j as u32, generators, tol, joins, hooks)
            });
            match grown {
                Some(n) => {
                    nf = n;
                    out.clusters += 1;
                }
                None => out.left_out += 1,
            }
        }
        Ok((nf, out))
    })
}

/// Makes `v` (a position in `positions`) a vertex of the faces `faces[..nf]`
/// at `faces[f]`, whose nearest point to `v` has barycentric coordinates
/// `bary`: the face is split in three around `v` or, when that point lies near
/// an edge (its smallest coordinate below [`EDGE_BARYCENTRIC`]) or the face
/// split is refused, the edge opposite the smallest coordinate is split, with
/// each of its faces split in two. Refused: a split that makes a degenerate
/// face (edge or area below `tol`), turns a face over (its normal against the
/// face it replaces), or whose new faces cross a face of the mesh or fold onto
/// a neighbour ([`untangled`]) or that `joins` refuses, and one with no room
/// for the two new faces in `faces`. Windings are kept, so orientation and
/// edge-manifoldness hold.
/// Returns the new face count, or `None` when nothing was split. O(faces).
#[allow(clippy::too_many_arguments)]
pub(super) fn split_at(
    faces: &mut [[u32; 3]],
    nf: usize,
    f: usize,
    bary: [f32; 3],
    v: u32,
    positions: &[V3],
    tol: f32,
    joins: &dyn Fn(&[[u32; 3]]) -> bool,
    hooks: &dyn Progress,
) -> Option<usize> {
    if f >= nf || nf + 2 > faces.len() {
        return None;
    }
    let pos = |c: u32| positions.get(c as usize).copied().unwrap_or([0.0; 3]);
    let normal = |f: [u32; 3]| face_normal(f.map(pos));
    let sound = |new: &[[u32; 3]], old: [u32; 3]| {
        let n = normal(old);
        new.iter().all(|&f| {
            let [a, b, c] = f.map(pos);
            !degenerate(a, b, c, tol) && dot(normal(f), n) > 0.0
        })
    };
    let [a, b, c] = faces[f];
    let in_face = [[a, b, v], [b, c, v], [c, a, v]];
    // The edge opposite the smallest coordinate.
    let k = (0..3)
        .min_by(|&x, &y| bary[x].total_cmp(&bary[y]))
        .unwrap_or(0);
    let (u, w) = (faces[f][(k + 1) % 3], faces[f][(k + 2) % 3]);
    // The faces on edge u-w (one or two on a manifold mesh), each split in two
    // around the new vertex, keeping its winding.
    let mut on_edge = [usize::MAX; 2];
    let mut halves = [[0u32; 3]; 4];
    let mut count = 0;
    for (h, face) in faces[..nf].iter().enumerate() {
        let Some(i) = (0..3).find(|&i| {
            let (p, q) = (face[i], face[(i + 1) % 3]);
            (p == u && q == w) || (p == w && q == u)
        }) else {
            continue;
        };
        if count == 2 {
            count = 3;
            break;
        }
        let (p, q, r) = (face[i], face[(i + 1) % 3], face[(i + 2) % 3]);
        on_edge[count] = h;
        halves[2 * count] = [p, v, r];
        halves[2 * count + 1] = [v, q, r];
        count += 1;
    }
    let edge_ok = || {
        count <= 2
            && (0..count).all(|i| sound(&halves[2 * i..2 * i + 2], faces[on_edge[i]]))
            && untangled(
                &faces[..nf],
                &on_edge[..count],
                &halves[..2 * count],
                positions,
                hooks,
            )
            && joins(&halves[..2 * count])
    };
    let face_ok = || {
        sound(&in_face, faces[f])
            && untangled(&faces[..nf], &[f], &in_face, positions, hooks)
            && joins(&in_face)
    };
    // The edge split when the point is near the edge, else the face split,
    // each the other's fallback; each test (an O(faces) scan) runs at most once.
    let on_edge_split = if bary[k] < EDGE_BARYCENTRIC {
        if edge_ok() {
            true
        } else if face_ok() {
            false
        } else {
            return None;
        }
    } else if face_ok() {
        false
    } else if edge_ok() {
        true
    } else {
        return None;
    };
    let mut nf = nf;
    if on_edge_split {
        for i in 0..count {
            faces[on_edge[i]] = halves[2 * i];
            faces[nf] = halves[2 * i + 1];
            nf += 1;
        }
    } else {
        faces[f] = in_face[0];
        faces[nf] = in_face[1];
        faces[nf + 1] = in_face[2];
        nf += 2;
    }
    Some(nf)
}
