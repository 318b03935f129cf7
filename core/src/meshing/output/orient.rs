//! Orientation: faces flooded across shared edges so neighbours run their
//! common edge in opposite directions, each closed component turned outward.

use super::{dir, edge_table, faces_of, key, NO};
use crate::arena::Alloc;
use crate::error::Result;
use crate::math::V3;

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
pub(super) fn orient<'b, S: Alloc<'b>>(
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
