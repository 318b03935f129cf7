//! What a mesh file carries beside its positions: a normal at each vertex,
//! from the final mesh, and a colour at each vertex, from the input points of
//! the vertex's cluster.
//!
//! Every vertex of core's mesh belongs to a cluster (`vsaqem_core::Mesh::
//! vertex_cluster`): a generator's vertex to its cluster, a vertex split off
//! at a pinch to the same one, and a vertex added by densifying to the
//! cluster of the input point it was placed at. Holes are closed with faces
//! between existing vertices, so no vertex is without a cluster. Each vertex
//! takes its cluster's mean colour, densified ones included (not the colour
//! of the one point they sit at): a colour is what the mesh's vertex stands
//! for, a patch of the input, as its position is.

use crate::geom::{cross, length, sub};

/// The unit normal of the triangle `p` (counter-clockwise seen from its
/// front), computed in `f64` on the difference vectors so that coordinates
/// far from the origin (UTM) lose nothing; zero for a triangle without area.
pub fn face_normal(p: [[f64; 3]; 3]) -> [f32; 3] {
    unit(cross(sub(p[1], p[0]), sub(p[2], p[0]))).unwrap_or([0.0; 3])
}

/// `v / |v|` as `f32`, `None` for a zero (or non-finite) `v`.
fn unit(v: [f64; 3]) -> Option<[f32; 3]> {
    let len = length(v);
    (len > 0.0 && len.is_finite()).then(|| v.map(|c| (c / len) as f32))
}

/// Area-weighted vertex normals: each triangle adds its cross product (its
/// unit normal times twice its area) to its three corners, and each sum is
/// scaled to unit length. For a closed mesh whose triangles are
/// counter-clockwise seen from outside (core's orientation) every normal
/// points outwards. A vertex whose sum is zero (no triangle, or triangles
/// that cancel) gets `(0, 0, 1)`, so every normal has unit length, as glTF
/// requires. Indices must be `< vertices.len()`. Cost: O(V + F), 24 bytes a
/// vertex of scratch.
pub fn vertex_normals(vertices: &[[f64; 3]], triangles: &[[u32; 3]]) -> Vec<[f32; 3]> {
    let mut sum = vec![[0.0f64; 3]; vertices.len()];
    for t in triangles {
        let p = t.map(|i| vertices[i as usize]);
        let n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
        for &i in t {
            let s = &mut sum[i as usize];
            for a in 0..3 {
                s[a] += n[a];
            }
        }
    }
    sum.into_iter()
        .map(|s| unit(s).unwrap_or([0.0, 0.0, 1.0]))
        .collect()
}

/// The colour of each vertex: the mean of the colours of its cluster's points.
/// `labels[i]` is the cluster of the point of colour `colors[i]` (core's
/// `Clusters::labels`, over the points core worked on, in its order), and
/// `vertex_cluster[v]` the cluster of vertex `v`. Channels are averaged as
/// stored (sRGB values, as PCL and Open3D average colours) and rounded. A
/// vertex whose cluster has no point (never in core's output) is mid grey.
/// Cost: O(points + clusters + vertices), 32 bytes a cluster.
pub fn vertex_colors(labels: &[u32], colors: &[[u8; 3]], vertex_cluster: &[u32]) -> Vec<[u8; 3]> {
    let clusters = vertex_cluster
        .iter()
        .chain(labels)
        .map(|&c| c as usize + 1)
        .max()
        .unwrap_or(0);
    // Per cluster: the three channel sums and the point count.
    let mut sum = vec![[0u64; 4]; clusters];
    for (&l, c) in labels.iter().zip(colors) {
        let s = &mut sum[l as usize];
        for k in 0..3 {
            s[k] += u64::from(c[k]);
        }
        s[3] += 1;
    }
    vertex_cluster
        .iter()
        .map(|&c| {
            let s = sum[c as usize];
            if s[3] == 0 {
                return [128; 3];
            }
            // Rounded to nearest: (2 sum + n) / 2n.
            [0, 1, 2].map(|k| ((2 * s[k] + s[3]) / (2 * s[3])) as u8)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An octahedron around `c`, its faces counter-clockwise from outside.
    fn octahedron(c: [f64; 3]) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let v = [
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ]
        .map(|p: [f64; 3]| [p[0] + c[0], p[1] + c[1], p[2] + c[2]]);
        let t = vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        (v.to_vec(), t)
    }

    #[test]
    fn normals_of_a_closed_octahedron_point_out_along_its_vertices_even_far_from_the_origin() {
        for c in [[0.0; 3], [500_000.0, 4_000_000.0, 100.0]] {
            let (v, t) = octahedron(c);
            let n = vertex_normals(&v, &t);
            for (p, n) in v.iter().zip(&n) {
                let out = sub(*p, c);
                for a in 0..3 {
                    assert!((f64::from(n[a]) - out[a]).abs() < 1e-6, "{n:?} at {p:?}");
                }
            }
            // Each face normal points out too.
            for tri in &t {
                let f = face_normal(tri.map(|i| v[i as usize]));
                let mid = sub(v[tri[0] as usize], c);
                let d: f64 = (0..3).map(|a| f64::from(f[a]) * mid[a]).sum();
                assert!(d > 0.0, "{tri:?}");
            }
        }
    }

    #[test]
    fn a_vertex_without_faces_gets_a_unit_normal_and_a_flat_face_a_zero_one() {
        let v = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [5.0, 5.0, 5.0]];
        let n = vertex_normals(&v, &[[0, 1, 2]]);
        assert_eq!(n, vec![[0.0, 0.0, 1.0]; 4]);
        assert_eq!(face_normal([[0.0; 3], [1.0; 3], [2.0; 3]]), [0.0; 3]);
    }

    #[test]
    fn each_vertex_takes_the_rounded_mean_colour_of_its_cluster() {
        let labels = [0, 0, 1, 1, 1, 2];
        let colors = [
            [255, 0, 0],
            [255, 0, 0],
            [0, 0, 255],
            [0, 0, 254],
            [0, 1, 254],
            [10, 20, 30],
        ];
        // Vertex 3 is in cluster 1 too (a densified one); cluster 3 is empty.
        let c = vertex_colors(&labels, &colors, &[0, 1, 2, 1, 3]);
        assert_eq!(
            c,
            vec![
                [255, 0, 0],
                [0, 0, 254],
                [10, 20, 30],
                [0, 0, 254],
                [128, 128, 128]
            ]
        );
        // Halves round up: (0 + 1) / 2.
        assert_eq!(vertex_colors(&[0, 0], &[[0; 3], [1; 3]], &[0]), [[1; 3]]);
    }
}
