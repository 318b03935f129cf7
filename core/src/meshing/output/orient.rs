//! Orientation: faces flooded across shared edges so neighbours run their
//! common edge in opposite directions, each closed component turned outward;
//! where a component cannot be oriented, its seam of clashing edges placed by
//! the flood or, on request, the shortest of several.

use super::{dir, key, EdgeIndex, NO};
use crate::arena::Alloc;
use crate::error::Result;
use crate::math::V3;

fn det(p: [[f64; 3]; 3]) -> f64 {
    p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1])
        - p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0])
        + p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0])
}

/// Where the seam of a component that cannot be oriented goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Seam {
    /// Where the fronts of one breadth-first flood from the component's
    /// lowest face meet.
    Flood,
    /// The fewest clashing links of [`FLOODS`] floods spread over the first
    /// flood's order (the first from its lowest face), each shortened by
    /// [`shorten`]; ties go to the earliest flood.
    Shortest,
}

/// Floods tried for [`Seam::Shortest`].
pub(super) const FLOODS: usize = 8;

/// `f` as oriented: its cycle reversed when flipped.
fn cycle(f: [u32; 3], flipped: bool) -> [u32; 3] {
    if flipped {
        [f[0], f[2], f[1]]
    } else {
        f
    }
}

/// Calls `visit(g, wants_flip)` for every face `g` that shares an edge with
/// face `f` (turned over when `flipped`), with the flip that makes `g` run the
/// edge opposite to `f`. O(d) per edge, for the d edges at its lower vertex
/// (a few: [`EdgeIndex`]).
fn for_each_link(
    faces: &[[u32; 3]],
    table: &EdgeIndex,
    f: usize,
    flipped: bool,
    mut visit: impl FnMut(usize, bool),
) {
    let cf = cycle(faces[f], flipped);
    for k in 0..3 {
        let (u, v) = (cf[k], cf[(k + 1) % 3]);
        for &(_, g) in table.faces_of(key(u, v)) {
            let g = g as usize;
            if g != f {
                visit(g, dir(faces[g], u, v) == 1);
            }
        }
    }
}

/// Clashing links at face `f` and all its links.
fn clashes_at(faces: &[[u32; 3]], table: &EdgeIndex, flip: &[bool], f: usize) -> (u32, u32) {
    let (mut bad, mut links) = (0u32, 0u32);
    for_each_link(faces, table, f, flip[f], |g, want| {
        links += 1;
        bad += u32::from(flip[g] != want);
    });
    (bad, links)
}

/// Shorten the seam of `flip` over the faces `members`: a face most of whose
/// links clash turns over (which removes at least one clash), until none is
/// left; faces are visited in `members` order, then as their neighbours turn
/// (a queue in `queue`, `queued` all false on entry and on return). Each turn
/// removes a clash, so O((F + clashes) d) (see [`for_each_link`]).
fn shorten(
    faces: &[[u32; 3]],
    table: &EdgeIndex,
    flip: &mut [bool],
    members: &[u32],
    queue: &mut [u32],
    queued: &mut [bool],
) {
    let n = members.len();
    if n == 0 {
        return;
    }
    queue[..n].copy_from_slice(members);
    for &f in members {
        queued[f as usize] = true;
    }
    let (mut head, mut len) = (0usize, n);
    while len > 0 {
        let f = queue[head] as usize;
        head = (head + 1) % n;
        len -= 1;
        queued[f] = false;
        let (bad, links) = clashes_at(faces, table, flip, f);
        if 2 * bad <= links {
            continue;
        }
        flip[f] = !flip[f];
        for_each_link(faces, table, f, flip[f], |g, _| {
            if !queued[g] {
                queued[g] = true;
                queue[(head + len) % n] = g as u32;
                len += 1;
            }
        });
    }
}

/// Flood breadth-first from face `from` (its orientation kept as it is in
/// `flip`), across every link to a face `claim` takes (true the first time
/// it is asked about a face), giving each the orientation that runs the
/// shared edge opposite. The faces reached, `from` first, are left in
/// `order`; returns their count. O(F d) over the faces reached (see
/// [`for_each_link`]).
fn flood(
    faces: &[[u32; 3]],
    table: &EdgeIndex,
    from: usize,
    flip: &mut [bool],
    order: &mut [u32],
    mut claim: impl FnMut(usize) -> bool,
) -> usize {
    claim(from);
    order[0] = from as u32;
    let (mut head, mut len) = (0usize, 1usize);
    while head < len {
        let f = order[head] as usize;
        head += 1;
        for_each_link(faces, table, f, flip[f], |g, want| {
            if claim(g) {
                flip[g] = want;
                order[len] = g as u32;
                len += 1;
            }
        });
    }
    len
}

/// Orient the faces in place: neighbours run their shared edge in opposite
/// directions, and each component encloses a positive volume. Returns the number
/// of components and of components that could not be oriented consistently; the
/// faces on both sides of an edge where the orientation clashes are marked in
/// `clash`.
///
/// A component is flooded breadth-first from its lowest face. An orientable
/// one comes out the same from any face; in one that is not (the selection
/// folded over somewhere, which edge constraints cannot see) the clashes
/// fall on a seam placed by `seam`. O(F d) time (see [`for_each_link`]) for [`Seam::Flood`] and
/// for orientable components, [`FLOODS`] times that for [`Seam::Shortest`];
/// O(F) scratch.
pub(super) fn orient<'b, S: Alloc<'b>>(
    s: &S,
    faces: &mut [[u32; 3]],
    generators: &[V3],
    clash: &mut [bool],
    seam: Seam,
) -> Result<(u32, u32)> {
    let nf = faces.len();
    s.scratch(|t| {
        let table = &EdgeIndex::try_new_in(t, faces)?;
        let flip = t.try_alloc_slice::<bool>(nf, false)?;
        let trial = t.try_alloc_slice::<bool>(nf, false)?;
        let comp = t.try_alloc_slice::<u32>(nf, NO)?;
        // Faces reached by the current trial flood, by stamp.
        let reached = t.try_alloc_slice::<u32>(nf, 0)?;
        let queue = t.try_alloc_slice::<u32>(nf, 0)?;
        let queued = t.try_alloc_slice::<bool>(nf, false)?;
        let order = t.try_alloc_slice::<u32>(nf, 0)?;
        let (mut components, mut non_orientable) = (0u32, 0u32);
        let mut stamp = 0u32;
        // Clashing links of the faces in `members`, each counted from both sides.
        let clashes = |flip: &[bool], members: &[u32]| {
            let bad = members.iter();
            bad.map(|&f| clashes_at(faces, table, flip, f as usize).0 as usize)
                .sum::<usize>()
        };
        for start in 0..nf {
            if comp[start] != NO {
                continue;
            }
            let id = components;
            components += 1;
            // The first flood: the component, in breadth-first order.
            let len = flood(faces, table, start, flip, order, |g| {
                let new = comp[g] == NO;
                comp[g] = id;
                new
            });
            let members = &order[..len];
            let mut best = clashes(flip, members);
            if best == 0 {
                continue;
            }
            non_orientable += 1;
            if seam == Seam::Flood {
                continue;
            }
            for k in 0..FLOODS {
                // A flood from a face `k / FLOODS` of the way through the first.
                stamp += 1;
                let from = members[k * len / FLOODS] as usize;
                trial[from] = false;
                flood(faces, table, from, trial, queue, |g| {
                    let new = reached[g] != stamp;
                    reached[g] = stamp;
                    new
                });
                shorten(faces, table, trial, members, queue, queued);
                let n = clashes(trial, members);
                if n < best {
                    best = n;
                    for &f in members {
                        flip[f as usize] = trial[f as usize];
                    }
                }
            }
        }
        // The clashes left, on both sides.
        for f in 0..nf {
            for_each_link(faces, table, f, flip[f], |g, want| {
                if flip[g] != want {
                    clash[f] = true;
                    clash[g] = true;
                }
            });
        }
        let volume = t.try_alloc_slice::<f64>(components as usize, 0.0)?;
        for f in 0..nf {
            let c = cycle(faces[f], flip[f]);
            volume[comp[f] as usize] += det(c.map(|j| generators[j as usize].map(|x| x as f64)));
        }
        for f in 0..nf {
            if volume[comp[f] as usize] < 0.0 {
                flip[f] = !flip[f];
            }
            faces[f] = cycle(faces[f], flip[f]);
        }
        Ok((components, non_orientable))
    })
}
