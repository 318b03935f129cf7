//! From selected facets to an oriented, 2-manifold triangle mesh (DESIGN step 11).
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
//! - No degenerate faces (dropped with the candidates), no duplicates (candidate
//!   facets are distinct vertex triples), every vertex used.
//!
//! Memory: the mesh (12 bytes per vertex and per face) plus O(faces + candidate
//! edges) scratch. Cost: linear in faces and edges.

use crate::arena::{Alloc, Arena};
use crate::candidates::{Candidates, Members};
use crate::error::Result;
use crate::math::V3;

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

/// Build the mesh of the `selected` candidate facets. Working memory comes from
/// `work`; the result is allocated in `out` (which may be the same allocator).
pub fn try_mesh_in<'o, 'b, W: Alloc<'b>>(
    out: &'o Arena<'b>,
    work: &W,
    cand: &Candidates,
    members: &Members,
    selected: &[bool],
    generators: &[V3],
) -> Result<Mesh<'o>> {
    let m = generators.len();
    let ne = cand.edges.len();
    work.scratch(|s| -> Result<Mesh<'o>> {
        // Faces (cluster triples) with their candidate edge ids, and edge -> faces.
        let nsel = selected.iter().filter(|&&b| b).count();
        let faces = s.try_alloc_slice::<[u32; 3]>(nsel, [0; 3])?;
        let fedges = s.try_alloc_slice::<[u32; 3]>(nsel, [0; 3])?;
        let edge_faces = s.try_alloc_slice::<[u32; 2]>(ne, [NO, NO])?;
        let mut nf = 0usize;
        let mut dropped = 0u32;
        for (i, _) in selected.iter().enumerate().filter(|(_, &b)| b) {
            let e = cand.facet_edges[i];
            if e.iter().any(|&x| edge_faces[x as usize][1] != NO) {
                dropped += 1;
                continue;
            }
            for &x in &e {
                let slot = &mut edge_faces[x as usize];
                if slot[0] == NO {
                    slot[0] = nf as u32;
                } else {
                    slot[1] = nf as u32;
                }
            }
            faces[nf] = cand.facets[i];
            fedges[nf] = e;
            nf += 1;
        }
        let faces = &mut faces[..nf];
        let fedges = &fedges[..nf];
        // Orientation: flip[f] says whether face f is reversed.
        let flip = s.try_alloc_slice::<bool>(nf, false)?;
        let comp = s.try_alloc_slice::<u32>(nf, NO)?;
        let queue = s.try_alloc_slice::<u32>(nf, 0)?;
        let mut components = 0u32;
        let mut non_orientable = 0u32;
        let cycle = |f: &[u32; 3], flipped: bool| if flipped { [f[0], f[2], f[1]] } else { *f };
        // +1 if the oriented cycle runs u -> v, -1 if v -> u.
        let dir = |c: [u32; 3], u: u32, v: u32| -> i32 {
            for k in 0..3 {
                if c[k] == u && c[(k + 1) % 3] == v {
                    return 1;
                }
                if c[k] == v && c[(k + 1) % 3] == u {
                    return -1;
                }
            }
            0
        };
        for start in 0..nf {
            if comp[start] != NO {
                continue;
            }
            let id = components;
            components += 1;
            comp[start] = id;
            let (mut head, mut tail) = (0usize, 0usize);
            queue[tail] = start as u32;
            tail += 1;
            let mut conflict = false;
            while head < tail {
                let f = queue[head] as usize;
                head += 1;
                let cf = cycle(&faces[f], flip[f]);
                for &e in &fedges[f] {
                    let [u, v] = cand.edges[e as usize];
                    let pair = edge_faces[e as usize];
                    let g = if pair[0] as usize == f {
                        pair[1]
                    } else {
                        pair[0]
                    };
                    if g == NO {
                        continue;
                    }
                    let g = g as usize;
                    let want_flip = {
                        let cg = cycle(&faces[g], false);
                        // g must run the edge opposite to f.
                        dir(cg, u, v) == dir(cf, u, v)
                    };
                    if comp[g] == NO {
                        comp[g] = id;
                        flip[g] = want_flip;
                        queue[tail] = g as u32;
                        tail += 1;
                    } else if flip[g] != want_flip {
                        conflict = true;
                    }
                }
            }
            if conflict {
                non_orientable += 1;
            }
        }
        // Outward: a component with negative signed volume is reversed.
        let volume = s.try_alloc_slice::<f64>(components as usize, 0.0)?;
        for f in 0..nf {
            let c = cycle(&faces[f], flip[f]);
            let p = c.map(|j| generators[j as usize].map(|x| x as f64));
            let det = p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1])
                - p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0])
                + p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0]);
            volume[comp[f] as usize] += det;
        }
        for f in 0..nf {
            if volume[comp[f] as usize] < 0.0 {
                flip[f] = !flip[f];
            }
            faces[f] = cycle(&faces[f], flip[f]);
        }
        // Vertex-manifold: union the corners at one generator across shared edges.
        let parent = s.try_alloc_slice::<u32>(3 * nf, 0)?;
        for (i, p) in parent.iter_mut().enumerate() {
            *p = i as u32;
        }
        let corner = |f: usize, v: u32, faces: &[[u32; 3]]| -> usize {
            let k = faces[f].iter().position(|&x| x == v).unwrap_or(0);
            3 * f + k
        };
        let mut boundary = 0u32;
        for (e, pair) in edge_faces.iter().enumerate() {
            match *pair {
                [NO, _] => {}
                [_, NO] => boundary += 1,
                [f, g] => {
                    let [u, v] = cand.edges[e];
                    for w in [u, v] {
                        let (a, b) = (corner(f as usize, w, faces), corner(g as usize, w, faces));
                        union(parent, a, b);
                    }
                }
            }
        }
        // One output vertex per corner group, numbered in face order.
        let vertex_of_root = s.try_alloc_slice::<u32>(3 * nf, NO)?;
        let mut nv = 0u32;
        for c in 0..3 * nf {
            let r = find(parent, c);
            if vertex_of_root[r] == NO {
                vertex_of_root[r] = nv;
                nv += 1;
            }
        }
        let vertices = out.try_alloc_slice::<V3>(nv as usize, [0.0; 3])?;
        let vertex_cluster = out.try_alloc_slice::<u32>(nv as usize, 0)?;
        let triangles = out.try_alloc_slice::<[u32; 3]>(nf, [0; 3])?;
        let used = s.try_alloc_slice::<bool>(m, false)?;
        for f in 0..nf {
            for k in 0..3 {
                let v = vertex_of_root[find(parent, 3 * f + k)];
                let cl = faces[f][k];
                vertices[v as usize] = generators[cl as usize];
                vertex_cluster[v as usize] = cl;
                triangles[f][k] = v;
                used[cl as usize] = true;
            }
        }
        let distinct = used.iter().filter(|&&u| u).count() as u32;
        let mut uncovered_clusters = 0;
        let mut uncovered_points = 0;
        for j in 0..members.len().min(m) {
            let size = members.of(j).len() as u32;
            if size > 0 && !used[j] {
                uncovered_clusters += 1;
                uncovered_points += size;
            }
        }
        Ok(Mesh {
            vertices,
            triangles,
            vertex_cluster,
            stats: MeshStats {
                vertices: nv,
                faces: nf as u32,
                boundary_edges: boundary,
                components,
                non_orientable,
                split_vertices: nv - distinct,
                dropped_faces: dropped,
                uncovered_clusters,
                uncovered_points,
            },
        })
    })
}

fn find(parent: &mut [u32], mut i: usize) -> usize {
    while parent[i] as usize != i {
        let p = parent[i] as usize;
        parent[i] = parent[p];
        i = p;
    }
    i
}

fn union(parent: &mut [u32], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
        parent[hi] = lo as u32;
    }
}
