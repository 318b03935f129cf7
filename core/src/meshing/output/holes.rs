//! Hole filling: boundary loops closed by ears; loops along the border of the
//! data kept open, their notches eared and their vertices moved onto the border.

use super::repair::untangled;
use super::{dir, edge_table, face_normal, faces_of, key};
use crate::arena::Alloc;
use crate::error::Result;
use crate::math::{add, cross, dist2, dot, norm, sub, V3};
use crate::meshing::candidates::degenerate;
use crate::progress::Progress;

/// Loops shorter than this are filled even along the border of the data: a real
/// border is long, while a spurious one (a few clusters that look like border on a
/// noisy or sharp closed surface) rings a small hole.
const MIN_OPEN_LOOP: usize = 12;

/// What hole filling did.
#[derive(Clone, Copy, Default)]
pub(super) struct Filled {
    /// Faces added.
    pub faces: usize,
    /// Loops closed.
    pub holes: u32,
    /// Loops left open (too long, or no admissible ear).
    pub left: u32,
    /// Loops kept open: most of their vertices are on the border of the data.
    pub open: u32,
}

/// Close the boundary loops of the oriented `faces[..nf]` that have at most
/// `max_hole` edges, appending faces after `nf` (room for one face per boundary
/// edge is required). Each loop is cut by ears, the shortest new edge first
/// (an ear turning against the loop's surrounding faces costs 16 times more); an
/// ear is never degenerate and never adds an edge the mesh already has, so every
/// edge keeps at most two faces. A loop with no admissible ear stays open, and
/// the faces along it are marked in `widen` (indices into `faces`).
#[allow(clippy::too_many_arguments)]
pub(super) fn fill_holes<'b, S: Alloc<'b>>(
    s: &S,
    faces: &mut [[u32; 3]],
    nf: usize,
    generators: &[V3],
    open: &[bool],
    along: &mut [bool],
    widen: &mut [bool],
    max_hole: u32,
    tol: f32,
    hooks: &dyn Progress,
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
                    hooks,
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
                    // No clean filling: the faces around the loop may go, for a
                    // wider hole with other ears.
                    for &f in side.iter() {
                        if let Some(w) = widen.get_mut(f as usize) {
                            *w = true;
                        }
                    }
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
/// mesh already has (`known`, or an earlier ear of this loop), and never
/// crosses a face of `faces[..at]` or an earlier ear, nor folds onto one
/// ([`untangled`]). Returns false,
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
    hooks: &dyn Progress,
) -> bool {
    let g = |j: u32| generators.get(j as usize).copied().unwrap_or([0.0; 3]);
    let mut len = poly.len();
    if len < 3 || at + len - 2 > faces.len() {
        return false;
    }
    let mut ears = 0usize;
    while len > 3 {
        // Ears that would cross the mesh or fold onto it (checked only for the
        // cheapest candidate, which is then refused and the next one tried).
        let mut refused = 0u128;
        let i = loop {
            let mut best: Option<(f32, usize)> = None;
            for i in 0..len {
                let (a, b, c) = (poly[(i + len - 1) % len], poly[i], poly[(i + 1) % len]);
                let repeats = faces[at..at + ears]
                    .iter()
                    .any(|f| key(f[0], f[2]) == key(a, c));
                if a == c
                    || known(a, c)
                    || repeats
                    || (i < 128 && refused & (1 << i) != 0)
                    || degenerate(g(a), g(b), g(c), tol)
                {
                    continue;
                }
                let turn = dot(cross(sub(g(b), g(a)), sub(g(c), g(b))), normal);
                let cost = dist2(g(a), g(c)) * if turn < 0.0 { 16.0 } else { 1.0 };
                if best.is_none_or(|(bc, _)| cost < bc) {
                    best = Some((cost, i));
                }
            }
            let Some((_, i)) = best else {
                break None;
            };
            let ear = [poly[(i + len - 1) % len], poly[i], poly[(i + 1) % len]];
            if i >= 128 || untangled(&faces[..at + ears], &[], &[ear], generators, hooks) {
                break Some(i);
            }
            refused |= 1 << i;
        };
        let Some(i) = i else { return false };
        faces[at + ears] = [poly[(i + len - 1) % len], poly[i], poly[(i + 1) % len]];
        ears += 1;
        poly.copy_within(i + 1..len, i);
        len -= 1;
    }
    let (a, b, c) = (poly[0], poly[1], poly[2]);
    if degenerate(g(a), g(b), g(c), tol)
        || !untangled(&faces[..at + ears], &[], &[[a, b, c]], generators, hooks)
    {
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
