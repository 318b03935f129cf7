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

/// Cleans `points` with `params` as the CLI does, then reconstructs the points
/// it keeps in the same buffer: `f` gets the cleaning's statistics, the kept
/// points and the reconstruction. Panics on an error (tests only).
pub fn clean_and_reconstruct<T>(
    points: &[V3],
    params: &vsaqem_core::Params,
    f: impl FnOnce(vsaqem_core::CleanStats, &[V3], &vsaqem_core::Reconstruction) -> T,
) -> T {
    use std::mem::MaybeUninit;
    use vsaqem_core::{arena_bytes, clean, clean_bytes, reconstruct, Arena, Silent};
    let n = points.len();
    let mut buf = vec![MaybeUninit::uninit(); arena_bytes(n, params).max(clean_bytes(n, params))];
    let mut keep = vec![true; n];
    let stats = {
        let arena = Arena::new(&mut buf);
        clean(&arena, points, params, &mut keep, &mut Silent).expect("cleaning")
    };
    let kept: Vec<V3> = points
        .iter()
        .zip(&keep)
        .filter(|(_, &k)| k)
        .map(|(p, _)| *p)
        .collect();
    assert_eq!(kept.len(), stats.kept as usize);
    let arena = Arena::new(&mut buf);
    let r = reconstruct(&arena, &kept, None, params, &mut Silent).expect("reconstruction");
    f(stats, &kept, &r)
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
            vsaqem_core::math::point_triangle_dist2(
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

/// A noisy variant of [`cloud`]: the same `n` clean points (returned first), then
/// each moved by isotropic Gaussian noise of standard deviation `sigma` times the
/// clean cloud's bounding-box diagonal (as the CLI's `--noise`), followed by
/// `outliers` extra points uniform in the clean cloud's bounding box.
pub fn noisy_cloud(
    shape: Shape,
    n: usize,
    seed: u64,
    sigma: f64,
    outliers: usize,
) -> (Vec<V3>, Vec<V3>) {
    use vsaqem_core::rng::Rng;
    use vsaqem_core::sample::gaussian;
    let clean = cloud(shape, n, seed);
    let diag = diagonal(&clean);
    let mut rng = Rng::new(seed ^ 0x05EE_D0F0_015E);
    let mut noisy: Vec<V3> = clean
        .iter()
        .map(|p| p.map(|c| (c as f64 + sigma * diag * gaussian(&mut rng)) as f32))
        .collect();
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in &clean {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    for _ in 0..outliers {
        noisy.push(core::array::from_fn(|a| {
            lo[a] + (hi[a] - lo[a]) * rng.unit_f64() as f32
        }));
    }
    (clean, noisy)
}

/// Exact distance from `p` to the clean surface of `shape` (the surface
/// [`vsaqem_core::sample::fill`] samples). For the wave, the nearest point of
/// the height field is found by a grid search refined twice (to about 1e-6 of
/// the distance); every other shape is closed-form.
pub fn distance_to_shape(shape: Shape, p: [f64; 3]) -> f64 {
    let [x, y, z] = p;
    let rho = (x * x + y * y).sqrt();
    let r = (x * x + y * y + z * z).sqrt();
    // Distance to a horizontal circle of radius `c` at height `h`.
    let circle = |c: f64, h: f64| ((rho - c).powi(2) + (z - h).powi(2)).sqrt();
    // Distance to an axis-aligned box surface of half-extents `h` at `centre`.
    let box_dist = |h: [f64; 3], centre: [f64; 3]| {
        let q: [f64; 3] = std::array::from_fn(|a| (p[a] - centre[a]).abs() - h[a]);
        let out = q.iter().map(|v| v.max(0.0).powi(2)).sum::<f64>().sqrt();
        if out > 0.0 {
            out
        } else {
            -q.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        }
    };
    match shape {
        Shape::Sphere => (r - 1.0).abs(),
        Shape::Torus => (((rho - 0.7).powi(2) + z * z).sqrt() - 0.25).abs(),
        Shape::Box => box_dist([0.9, 0.6, 0.4], [0.0; 3]),
        Shape::Cylinder => {
            // Closed cylinder radius 0.5, |z| <= 0.8: side and two discs.
            let side = ((rho - 0.5).powi(2) + (z.abs() - 0.8).max(0.0).powi(2)).sqrt();
            let cap = ((rho - 0.5).max(0.0).powi(2) + (z.abs() - 0.8).powi(2)).sqrt();
            side.min(cap)
        }
        Shape::Demo => demo_distance(p),
        Shape::Hemisphere => {
            if z >= 0.0 {
                (r - 1.0).abs()
            } else {
                circle(1.0, 0.0)
            }
        }
        Shape::Tube => ((rho - 0.6).powi(2) + (z.abs() - 0.8).max(0.0).powi(2)).sqrt(),
        Shape::HoledSphere => {
            // The radial projection p/|p| lies on the kept part when its height is
            // at most 0.7; otherwise the nearest point is on the rim.
            if r > 0.0 && z / r <= 0.7 {
                (r - 1.0).abs()
            } else {
                circle(0.51f64.sqrt(), 0.7)
            }
        }
        Shape::Wave => wave_distance(p),
        _ => unreachable!("no distance for {shape:?}"),
    }
}

/// The demo (see `sample.rs`): the box `[-0.8,0.8]x[-0.5,0.5]x[-0.5,0.1]` whose
/// top lacks the disc of radius 0.35 under the cylinder, the cylinder's side
/// (z in [0.1, 0.6]) and its top disc. Minimum over the pieces.
fn demo_distance(p: [f64; 3]) -> f64 {
    let (lo, hi) = ([-0.8, -0.5, -0.5], [0.8, 0.5, 0.1]);
    let (r, z0, z1) = (0.35, 0.1, 0.6);
    let [x, y, z] = p;
    let rho = (x * x + y * y).sqrt();
    let mut best = f64::INFINITY;
    // The six box faces, each a rectangle (the top one minus the disc).
    for axis in 0..3 {
        for side in [lo[axis], hi[axis]] {
            let mut q: [f64; 3] = std::array::from_fn(|a| p[a].clamp(lo[a], hi[a]));
            q[axis] = side;
            if axis == 2 && side == hi[2] {
                let qr = (q[0] * q[0] + q[1] * q[1]).sqrt();
                if qr < r {
                    // Inside the removed disc: the nearest kept point is on its rim.
                    let (dx, dy) = if qr > 0.0 {
                        (q[0] / qr, q[1] / qr)
                    } else {
                        (1.0, 0.0)
                    };
                    q[0] = r * dx;
                    q[1] = r * dy;
                }
            }
            let d = (0..3).map(|a| (p[a] - q[a]).powi(2)).sum::<f64>().sqrt();
            best = best.min(d);
        }
    }
    let side = ((rho - r).powi(2) + (z - z.clamp(z0, z1)).powi(2)).sqrt();
    let top = ((rho - r).max(0.0).powi(2) + (z - z1).powi(2)).sqrt();
    best.min(side).min(top)
}

/// Distance to the wave height field over `[-1, 1]^2`: the nearest point lies
/// within `|z - w(x, y)|` horizontally of `(x, y)`, so a grid over that window,
/// refined twice around its best cell, finds it.
fn wave_distance(p: [f64; 3]) -> f64 {
    use vsaqem_core::sample::wave;
    let d2 = |u: f64, v: f64| {
        let w = wave(u, v).0;
        (p[0] - u).powi(2) + (p[1] - v).powi(2) + (p[2] - w).powi(2)
    };
    let (mut cu, mut cv) = (p[0].clamp(-1.0, 1.0), p[1].clamp(-1.0, 1.0));
    let mut best = d2(cu, cv);
    let mut half = best.sqrt() + 1e-6;
    for _ in 0..3 {
        let step = half / 10.0;
        let (u0, v0) = (cu, cv);
        for i in -10..=10 {
            for j in -10..=10 {
                let u = (u0 + i as f64 * step).clamp(-1.0, 1.0);
                let v = (v0 + j as f64 * step).clamp(-1.0, 1.0);
                let d = d2(u, v);
                if d < best {
                    (best, cu, cv) = (d, u, v);
                }
            }
        }
        half = step;
    }
    best.sqrt()
}

/// The smallest interior angle of a triangle, in degrees (0 when degenerate).
pub fn min_angle_deg(t: [V3; 3]) -> f64 {
    let p = t.map(|q| q.map(|c| c as f64));
    let mut best = 180.0f64;
    for i in 0..3 {
        let u: [f64; 3] = std::array::from_fn(|a| p[(i + 1) % 3][a] - p[i][a]);
        let v: [f64; 3] = std::array::from_fn(|a| p[(i + 2) % 3][a] - p[i][a]);
        let c = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let s = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        let d = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
        best = best.min(s.atan2(d).to_degrees());
    }
    best
}

/// Long thin facets: minimum angle below 5° and longest edge over 3 times the
/// median edge length of the mesh (the slivers a stray generator pulls out).
pub fn long_thin_facets(v: &[V3], triangles: &[[u32; 3]]) -> usize {
    let len = |a: u32, b: u32| {
        let (p, q) = (v[a as usize], v[b as usize]);
        (0..3)
            .map(|k| ((p[k] - q[k]) as f64).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let mut edges: Vec<f64> = triangles
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
        .filter(|(a, b)| a < b)
        .map(|(a, b)| len(a, b))
        .collect();
    if edges.is_empty() {
        return 0;
    }
    edges.sort_by(f64::total_cmp);
    let median = edges[edges.len() / 2];
    triangles
        .iter()
        .filter(|t| {
            let longest = (0..3)
                .map(|k| len(t[k], t[(k + 1) % 3]))
                .fold(0.0, f64::max);
            min_angle_deg(t.map(|i| v[i as usize])) < 5.0 && longest > 3.0 * median
        })
        .count()
}

/// Boundary loops of a mesh: connected components of its boundary edges.
pub fn boundary_loops(triangles: &[[u32; 3]]) -> usize {
    let mut count: HashMap<(u32, u32), u32> = HashMap::new();
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut parent: HashMap<u32, u32> = HashMap::new();
    fn find(p: &mut HashMap<u32, u32>, i: u32) -> u32 {
        let mut r = i;
        while let Some(&q) = p.get(&r) {
            if q == r {
                break;
            }
            r = q;
        }
        p.insert(i, r);
        r
    }
    for (&(a, b), &c) in &count {
        if c == 1 {
            parent.entry(a).or_insert(a);
            parent.entry(b).or_insert(b);
            let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
            parent.insert(ra, rb);
        }
    }
    let keys: Vec<u32> = parent.keys().copied().collect();
    keys.into_iter()
        .filter(|&k| find(&mut parent, k) == k)
        .count()
}

/// The CLI's pre-passes in its order: [`vsaqem_core::clean`] (the points it
/// keeps), then [`vsaqem_core::smooth`], each in a buffer of its own
/// bound. Returns the points to reconstruct.
pub fn pre_passes(points: &[V3], params: &vsaqem_core::Params) -> vsaqem_core::Result<Vec<V3>> {
    use std::mem::MaybeUninit;
    let mut keep = vec![true; points.len()];
    let mut buf = vec![MaybeUninit::uninit(); vsaqem_core::clean_bytes(points.len(), params)];
    let arena = vsaqem_core::Arena::new(&mut buf);
    vsaqem_core::clean(&arena, points, params, &mut keep, &mut vsaqem_core::Silent)?;
    let mut kept: Vec<V3> = points
        .iter()
        .zip(&keep)
        .filter(|(_, &k)| k)
        .map(|(p, _)| *p)
        .collect();
    let need = vsaqem_core::smooth_bytes(kept.len(), params);
    let mut buf = vec![MaybeUninit::uninit(); need];
    let arena = vsaqem_core::Arena::new(&mut buf);
    vsaqem_core::smooth(&arena, &mut kept, params, &mut vsaqem_core::Silent)?;
    Ok(kept)
}
