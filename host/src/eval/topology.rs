//! Combinatorial checks of the triangle list: edges, fans, components, orientation.

use super::{zero_area, Topology};
use vsaqem_core::union_find::UnionFind;

/// Topology of `faces` (indices all `< nv`); `tris` are their positions.
/// O(F log F): one sort of the 3F half-edges and one of the 3F corners.
pub(super) fn topology(nv: usize, faces: &[[u32; 3]], tris: &[[[f64; 3]; 3]]) -> Topology {
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
        .zip(tris)
        .filter(|(f, tri)| f[0] == f[1] || f[1] == f[2] || f[0] == f[2] || zero_area(tri))
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
    let mut face_parent = vec![0u32; proper.len()];
    let mut fan_parent = vec![0u32; 3 * proper.len()];
    let mut faces_dsu = UnionFind::new(&mut face_parent);
    let mut fans = UnionFind::new(&mut fan_parent);
    for group in half.chunk_by(|x, y| x.0 == y.0) {
        t.edges += 1;
        match group.len() {
            1 => t.boundary_edges += 1,
            2 => {
                // Same direction iff both start at the same (lower or higher) vertex.
                let forward = |h: &(u64, u32, u8)| corners(h).0 == 3 * h.1 + u32::from(h.2);
                if forward(&group[0]) == forward(&group[1]) {
                    t.inconsistent_edges += 1;
                }
            }
            _ => t.non_manifold_edges += 1,
        }
        let (lo0, hi0) = corners(&group[0]);
        for h in &group[1..] {
            faces_dsu.union(group[0].1, h.1);
            let (lo, hi) = corners(h);
            fans.union(lo0, lo);
            fans.union(hi0, hi);
        }
    }
    t.components = (0..proper.len() as u32)
        .filter(|&f| faces_dsu.find(f) == f)
        .count();

    let mut vertex_fans: Vec<(u32, u32)> = (0..3 * proper.len() as u32)
        .map(|c| (proper[c as usize / 3][c as usize % 3], fans.find(c)))
        .collect();
    vertex_fans.sort_unstable();
    vertex_fans.dedup();
    for group in vertex_fans.chunk_by(|x, y| x.0 == y.0) {
        t.referenced_vertices += 1;
        if group.len() > 1 {
            t.non_manifold_vertices += 1;
        }
    }
    t.unreferenced_vertices = nv - t.referenced_vertices;
    t.euler = t.referenced_vertices as i64 - t.edges as i64 + proper.len() as i64;
    t
}
