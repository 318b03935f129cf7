//! Combinatorial checks of the triangle list: edges, fans, components, orientation,
//! the same per component (for the genus), and the edges whose two faces fold onto
//! each other.

use super::{zero_area, Topology};
use vsaqem_core::meshing::intersect::folded;
use vsaqem_core::union_find::UnionFind;

/// What [`topology`] finds: the counts of the whole mesh, and per component.
pub(super) struct Surface {
    /// The whole mesh.
    pub topology: Topology,
    /// Components of proper faces, in the order of their first face.
    pub components: Vec<Component>,
    /// Edges with two faces (or a pair among three or more) folded onto each other
    /// ([`folded`]).
    pub folded_edges: usize,
}

/// One component of proper faces (linked through shared edges), counted on its own: a
/// vertex shared with another component counts in both.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct Component {
    pub faces: usize,
    pub vertices: usize,
    pub edges: usize,
    pub boundary_edges: usize,
    pub non_manifold_edges: usize,
    pub inconsistent_edges: usize,
    /// Vertices whose faces in this component form more than one fan.
    pub non_manifold_vertices: usize,
}

impl Component {
    /// The genus of a closed, consistently oriented manifold, `(2 - χ) / 2` with
    /// `χ = V - E + F` of the component; `None` for anything else.
    pub fn genus(&self) -> Option<u32> {
        let manifold = self.boundary_edges == 0
            && self.non_manifold_edges == 0
            && self.non_manifold_vertices == 0
            && self.inconsistent_edges == 0;
        let chi = self.vertices as i64 - self.edges as i64 + self.faces as i64;
        (manifold && chi <= 2 && chi % 2 == 0)
            .then(|| u32::try_from((2 - chi) / 2).ok())
            .flatten()
    }
}

/// Topology of `faces` (indices all `< vertices.len()`).
/// O(F log F): one sort of the 3F half-edges and one of the 3F corners.
pub(super) fn topology(vertices: &[[f64; 3]], faces: &[[u32; 3]]) -> Surface {
    let nv = vertices.len();
    let pos = |i: u32| vertices[i as usize];
    let mut t = Topology {
        vertices: nv,
        ..Topology::default()
    };
    let proper: Vec<[u32; 3]> = faces
        .iter()
        .copied()
        .filter(|f| f[0] != f[1] && f[1] != f[2] && f[0] != f[2])
        .collect();
    t.degenerate_faces = faces
        .iter()
        .filter(|f| {
            let tri = f.map(pos);
            f[0] == f[1]
                || f[1] == f[2]
                || f[0] == f[2]
                || !tri.iter().flatten().all(|c| c.is_finite())
                || zero_area(&tri)
        })
        .count();
    let mut sets: Vec<[u32; 3]> = faces
        .iter()
        .map(|f| {
            let mut s = *f;
            s.sort_unstable();
            s
        })
        .collect();
    sets.sort_unstable();
    sets.dedup();
    t.duplicate_faces = faces.len() - sets.len();

    // Half-edges (undirected key, face, local start corner), sorted by key then face.
    let mut half: Vec<(u64, u32, u8)> = Vec::with_capacity(3 * proper.len());
    for (fi, f) in proper.iter().enumerate() {
        for i in 0..3 {
            let (a, b) = (f[i], f[(i + 1) % 3]);
            let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
            half.push((key, fi as u32, i as u8));
        }
    }
    half.sort_unstable();
    // Corner 3 * face + i is vertex f[i] in face f. For a half-edge, the corners of
    // its lower and higher vertex.
    let corners = |&(_, fi, i): &(u64, u32, u8)| -> (u32, u32) {
        let f = proper[fi as usize];
        let (i, j) = (u32::from(i), (u32::from(i) + 1) % 3);
        let (ci, cj) = (3 * fi + i, 3 * fi + j);
        if f[i as usize] < f[j as usize] {
            (ci, cj)
        } else {
            (cj, ci)
        }
    };
    let opposite = |h: &(u64, u32, u8)| pos(proper[h.1 as usize][(usize::from(h.2) + 2) % 3]);
    let mut face_parent = vec![0u32; proper.len()];
    let mut fan_parent = vec![0u32; 3 * proper.len()];
    let mut faces_dsu = UnionFind::new(&mut face_parent);
    let mut fans = UnionFind::new(&mut fan_parent);
    let mut folded_edges = 0;
    for group in half.chunk_by(|x, y| x.0 == y.0) {
        let (u, v) = (pos((group[0].0 >> 32) as u32), pos(group[0].0 as u32));
        let fold = group.iter().enumerate().any(|(k, h)| {
            group[k + 1..]
                .iter()
                .any(|g| folded(u, v, opposite(h), opposite(g)))
        });
        folded_edges += usize::from(fold);
        let (lo0, hi0) = corners(&group[0]);
        for h in &group[1..] {
            faces_dsu.union(group[0].1, h.1);
            let (lo, hi) = corners(h);
            fans.union(lo0, lo);
            fans.union(hi0, hi);
        }
    }
    // Components numbered in the order of their first face.
    let mut comp = vec![u32::MAX; proper.len()];
    let mut components: Vec<Component> = Vec::new();
    for f in 0..proper.len() {
        let root = faces_dsu.find(f as u32) as usize;
        if comp[root] == u32::MAX {
            comp[root] = components.len() as u32;
            components.push(Component::default());
        }
        comp[f] = comp[root];
        components[comp[f] as usize].faces += 1;
    }
    t.components = components.len();

    for group in half.chunk_by(|x, y| x.0 == y.0) {
        let c = &mut components[comp[group[0].1 as usize] as usize];
        t.edges += 1;
        c.edges += 1;
        match group.len() {
            1 => {
                t.boundary_edges += 1;
                c.boundary_edges += 1;
            }
            2 => {
                // Same direction iff both start at the same (lower or higher) vertex.
                let forward = |h: &(u64, u32, u8)| corners(h).0 == 3 * h.1 + u32::from(h.2);
                if forward(&group[0]) == forward(&group[1]) {
                    t.inconsistent_edges += 1;
                    c.inconsistent_edges += 1;
                }
            }
            _ => {
                t.non_manifold_edges += 1;
                c.non_manifold_edges += 1;
            }
        }
    }

    // (vertex, component, fan) of every corner; a fan lies in one component.
    let mut vertex_fans: Vec<(u32, u32, u32)> = (0..3 * proper.len() as u32)
        .map(|c| {
            let fan = fans.find(c);
            (
                proper[c as usize / 3][c as usize % 3],
                comp[fan as usize / 3],
                fan,
            )
        })
        .collect();
    vertex_fans.sort_unstable();
    vertex_fans.dedup();
    for group in vertex_fans.chunk_by(|x, y| x.0 == y.0) {
        t.referenced_vertices += 1;
        if group.len() > 1 {
            t.non_manifold_vertices += 1;
        }
        for in_comp in group.chunk_by(|x, y| x.1 == y.1) {
            let c = &mut components[in_comp[0].1 as usize];
            c.vertices += 1;
            if in_comp.len() > 1 {
                c.non_manifold_vertices += 1;
            }
        }
    }
    t.unreferenced_vertices = nv - t.referenced_vertices;
    t.euler = t.referenced_vertices as i64 - t.edges as i64 + proper.len() as i64;
    Surface {
        topology: t,
        components,
        folded_edges,
    }
}
