//! Shared helpers for the contract tests: generated clouds, the shared data, and
//! an independent checker of mesh invariants.

use std::collections::HashMap;
use std::path::PathBuf;
use vsaqem_core::sample::{fill, Shape};
use vsaqem_core::V3;

/// Points per cluster of the cap below which a run with the default meshing
/// capacity (`Params::mesh_bytes_per_cluster`) may fail with
/// `Error::MeshCapacity`: with fewer points per cluster the candidate graph gets
/// denser than that capacity reserves (README, known limits). With at least
/// this many, every test cloud fits, and the memory tests hold core to it.
pub const DENSE_BELOW: usize = 12;

/// Whether a run on `n` points may fail with `Error::MeshCapacity` under the
/// default capacity (see [`DENSE_BELOW`]).
pub fn mesh_capacity_may_run_out(n: usize, params: &vsaqem_core::Params) -> bool {
    let cap = (params.cluster_cap() as usize).min(n).max(1);
    n < DENSE_BELOW * cap
}

/// `n` points on `shape` (seeded).
pub fn cloud(shape: Shape, n: usize, seed: u64) -> Vec<V3> {
    let mut p = vec![[0.0; 3]; n];
    fill(shape, seed, 0.0, &mut p);
    p
}

/// The shared clouds (`../shared/data/clouds/*.ply`), sorted, or `None` (with a
/// message) when the folder is absent.
pub fn shared_clouds() -> Option<Vec<PathBuf>> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/clouds");
    let Ok(rd) = std::fs::read_dir(&dir) else {
        eprintln!(
            "skipped: {} not found (the shared data sits beside the repository)",
            dir.display()
        );
        return None;
    };
    let mut v: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "ply"))
        .collect();
    v.sort();
    Some(v)
}

/// The points of a shared cloud (binary little-endian PLY, `float x y z` only),
/// centred and scaled into `[-1, 1]^3` as the host does.
pub fn load_shared_cloud(path: &std::path::Path) -> Vec<V3> {
    let bytes = std::fs::read(path).unwrap();
    let h = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .expect("a PLY header")
        + 11;
    let raw: Vec<f32> = bytes[h..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    let mut pts: Vec<V3> = raw.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in &pts {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let s = (0..3).map(|a| hi[a] - lo[a]).fold(0.0f32, f32::max) / 2.0;
    for p in &mut pts {
        for a in 0..3 {
            p[a] = (p[a] - 0.5 * (lo[a] + hi[a])) / s;
        }
    }
    pts
}

/// The file stem of `path` (a cloud's name in reports).
pub fn stem(path: &std::path::Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Topological facts of a triangle mesh, computed without trusting the producer.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Topology {
    pub vertices: usize,
    pub faces: usize,
    pub edges: usize,
    pub boundary_edges: usize,
    pub non_manifold_edges: usize,
    pub non_manifold_vertices: usize,
    pub unused_vertices: usize,
    pub inconsistent_edges: usize,
    pub degenerate_faces: usize,
    pub duplicate_faces: usize,
    pub components: usize,
}

impl Topology {
    /// Euler characteristic `V - E + F` of the used vertices.
    pub fn euler(&self) -> i64 {
        (self.vertices - self.unused_vertices) as i64 - self.edges as i64 + self.faces as i64
    }

    /// Edge- and vertex-manifold, oriented, clean.
    pub fn is_clean_manifold(&self) -> bool {
        self.non_manifold_edges == 0
            && self.non_manifold_vertices == 0
            && self.inconsistent_edges == 0
            && self.degenerate_faces == 0
            && self.duplicate_faces == 0
            && self.unused_vertices == 0
    }
}

/// Check a mesh: every count in [`Topology`].
pub fn topology(vertices: &[V3], triangles: &[[u32; 3]]) -> Topology {
    let mut t = Topology {
        vertices: vertices.len(),
        faces: triangles.len(),
        ..Topology::default()
    };
    let mut edges: HashMap<(u32, u32), Vec<(usize, bool)>> = HashMap::new();
    let mut seen_faces = std::collections::HashSet::new();
    let mut used = vec![false; vertices.len()];
    for (f, tri) in triangles.iter().enumerate() {
        let [a, b, c] = *tri;
        if a == b || b == c || a == c || area(vertices, tri) <= 0.0 {
            t.degenerate_faces += 1;
        }
        let mut key = *tri;
        key.sort_unstable();
        if !seen_faces.insert(key) {
            t.duplicate_faces += 1;
        }
        for k in 0..3 {
            used[tri[k] as usize] = true;
            let (u, v) = (tri[k], tri[(k + 1) % 3]);
            edges
                .entry((u.min(v), u.max(v)))
                .or_default()
                .push((f, u < v));
        }
    }
    t.unused_vertices = used.iter().filter(|&&u| !u).count();
    t.edges = edges.len();
    for faces in edges.values() {
        match faces.len() {
            1 => t.boundary_edges += 1,
            2 => {
                if faces[0].1 == faces[1].1 {
                    t.inconsistent_edges += 1;
                }
            }
            _ => t.non_manifold_edges += 1,
        }
    }
    // Vertex fans: faces around a vertex connected through edges at that vertex.
    let mut around: Vec<Vec<usize>> = vec![Vec::new(); vertices.len()];
    for (f, tri) in triangles.iter().enumerate() {
        for &v in tri {
            around[v as usize].push(f);
        }
    }
    for (v, faces) in around.iter().enumerate() {
        if faces.len() < 2 {
            continue;
        }
        let mut comp: Vec<usize> = (0..faces.len()).collect();
        fn root(c: &mut [usize], mut i: usize) -> usize {
            while c[i] != i {
                i = c[i];
            }
            i
        }
        for i in 0..faces.len() {
            for j in i + 1..faces.len() {
                let (a, b) = (triangles[faces[i]], triangles[faces[j]]);
                let shared = a
                    .iter()
                    .filter(|x| **x != v as u32 && b.contains(x))
                    .count();
                if shared > 0 {
                    let (ri, rj) = (root(&mut comp, i), root(&mut comp, j));
                    comp[ri] = rj;
                }
            }
        }
        let fans = (0..faces.len())
            .filter(|&i| root(&mut comp, i) == i)
            .count();
        if fans > 1 {
            t.non_manifold_vertices += 1;
        }
    }
    // Components by faces sharing edges.
    let mut parent: Vec<usize> = (0..triangles.len()).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    for faces in edges.values() {
        for w in faces.windows(2) {
            let (a, b) = (find(&mut parent, w[0].0), find(&mut parent, w[1].0));
            parent[a] = b;
        }
    }
    t.components = (0..triangles.len())
        .filter(|&i| find(&mut parent, i) == i)
        .count();
    t
}

fn area(v: &[V3], t: &[u32; 3]) -> f64 {
    let p = t.map(|i| v[i as usize].map(|x| x as f64));
    let a = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
    let b = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
    let c = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    0.5 * (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt()
}

/// Signed volume (positive when faces point outward on a closed surface).
pub fn signed_volume(v: &[V3], triangles: &[[u32; 3]]) -> f64 {
    triangles
        .iter()
        .map(|t| {
            let p = t.map(|i| v[i as usize].map(|x| x as f64));
            p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1])
                - p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0])
                + p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0])
        })
        .sum::<f64>()
        / 6.0
}

/// Distance from `p` to the nearest of the triangles (brute force; tests only).
pub fn distance_to_mesh(p: V3, v: &[V3], triangles: &[[u32; 3]]) -> f32 {
    triangles
        .iter()
        .map(|t| {
            vsaqem_core::score::point_triangle_dist2(
                p,
                v[t[0] as usize],
                v[t[1] as usize],
                v[t[2] as usize],
            )
        })
        .fold(f32::INFINITY, f32::min)
        .sqrt()
}

/// Distance from `p` to the true border of the open generated `shape`
/// (hemisphere, tube, wave, holed sphere; for the wave, to a point of the border,
/// which is no less than the distance to the border). `None` for closed shapes.
pub fn to_border(shape: Shape, p: V3) -> Option<f64> {
    let [x, y, z] = p.map(|c| c as f64);
    let rho = (x * x + y * y).sqrt();
    let circle = |r: f64, h: f64| ((rho - r).powi(2) + (z - h).powi(2)).sqrt();
    Some(match shape {
        Shape::Hemisphere => circle(1.0, 0.0),
        Shape::Tube => circle(0.6, 0.8).min(circle(0.6, -0.8)),
        Shape::HoledSphere => circle(0.51f64.sqrt(), 0.7),
        Shape::Wave => {
            let (bx, by) = if 1.0 - x.abs() < 1.0 - y.abs() {
                (x.signum(), y.clamp(-1.0, 1.0))
            } else {
                (x.clamp(-1.0, 1.0), y.signum())
            };
            let bz = vsaqem_core::sample::wave(bx, by).0;
            ((x - bx).powi(2) + (y - by).powi(2) + (z - bz).powi(2)).sqrt()
        }
        _ => return None,
    })
}

/// Diagonal of the bounding box of `pts`.
pub fn diagonal(pts: &[V3]) -> f64 {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in pts {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a] as f64);
            hi[a] = hi[a].max(p[a] as f64);
        }
    }
    (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt()
}

/// The vertices on a boundary edge (an edge of one triangle), ascending.
pub fn boundary_vertices(triangles: &[[u32; 3]]) -> Vec<u32> {
    let mut count: HashMap<(u32, u32), u32> = HashMap::new();
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut out: Vec<u32> = count
        .iter()
        .filter(|(_, &c)| c == 1)
        .flat_map(|(&(a, b), _)| [a, b])
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}
