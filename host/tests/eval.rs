//! `vsaqem eval` and `vsaqem::eval::evaluate` on hand-computed cases.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use vsaqem::eval::{dist2_point_triangle, evaluate, Evaluation};

/// The unit cube [0, 1]^3, vertex `x + 2y + 4z`, 12 outward (counter-clockwise) faces.
fn cube() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let v = (0..8)
        .map(|i| [(i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2 & 1) as f64])
        .collect();
    let t = vec![
        [0, 2, 3],
        [0, 3, 1],
        [4, 5, 7],
        [4, 7, 6],
        [0, 1, 5],
        [0, 5, 4],
        [2, 6, 7],
        [2, 7, 3],
        [0, 4, 6],
        [0, 6, 2],
        [1, 3, 7],
        [1, 7, 5],
    ];
    (v, t)
}

fn eval_mesh(points: &[[f64; 3]], (v, t): &(Vec<[f64; 3]>, Vec<[u32; 3]>)) -> Evaluation {
    evaluate(points, v, t, 2000)
}

const CENTRE: [f64; 3] = [0.5, 0.5, 0.5];

#[test]
fn distances_to_one_triangle_match_hand_computed_values() {
    let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let d = |p: [f64; 3]| dist2_point_triangle(p, &tri).sqrt();
    // Above the interior: the height.
    assert_eq!(d([0.25, 0.25, 2.0]), 2.0);
    // Beside the edge y = 0 (in the plane, and off it): 3-4-5.
    assert_eq!(d([0.5, -1.0, 0.0]), 1.0);
    assert_eq!(d([0.5, -3.0, 4.0]), 5.0);
    // Beside the hypotenuse x + y = 1, in the plane.
    assert!((d([1.0, 1.0, 0.0]) - 0.5f64.sqrt()).abs() < 1e-15);
    // Beyond the vertices.
    assert_eq!(d([-3.0, -4.0, 0.0]), 5.0);
    assert_eq!(d([4.0, 0.0, 4.0]), 5.0);
    assert_eq!(d([0.0, 5.0, -3.0]), 5.0);
    // On the triangle.
    assert_eq!(d([0.2, 0.3, 0.0]), 0.0);

    let v = tri.to_vec();
    let pts = [
        [0.25, 0.25, 2.0],
        [0.5, -3.0, 4.0],
        [-3.0, -4.0, 0.0],
        [0.2, 0.3, 0.0],
    ];
    let e = evaluate(&pts, &v, &[[0, 1, 2]], 100);
    let s = e.point_to_mesh.stats;
    assert_eq!(s.count, 4);
    assert_eq!(s.max, 5.0);
    assert_eq!(s.mean, 3.0);
    assert_eq!(s.rms, (54.0f64 / 4.0).sqrt());
    assert_eq!(s.p99, 5.0);
    // The points' box is 3.5 x 4.3 x 4 (diagonal 6.8): all but the last are far.
    assert_eq!(e.point_to_mesh.far, 3);
    assert_eq!(e.hausdorff, s.max.max(e.mesh_to_points.max));
    assert_eq!(e.chamfer, 0.5 * (s.mean + e.mesh_to_points.mean));
    assert_eq!(e.topology.boundary_edges, 3);
    assert_eq!(e.topology.euler, 1);
}

#[test]
fn closed_cube_has_sphere_topology_and_centre_at_half() {
    let m = cube();
    let e = eval_mesh(&[CENTRE, [0.5, 0.5, 1.0], [2.0, 0.5, 0.5]], &m);
    let t = e.topology;
    assert_eq!(
        (t.vertices, t.referenced_vertices, t.edges, t.faces),
        (8, 8, 18, 12)
    );
    assert_eq!(t.euler, 2);
    assert_eq!(t.boundary_edges, 0);
    assert_eq!(t.non_manifold_edges, 0);
    assert_eq!(t.non_manifold_vertices, 0);
    assert_eq!(t.components, 1);
    assert_eq!(t.inconsistent_edges, 0);
    assert_eq!(t.degenerate_faces, 0);
    assert_eq!(t.duplicate_faces, 0);
    assert!(t.is_closed_manifold());
    assert!((e.signed_volume - 1.0).abs() < 1e-15);
    let s = e.point_to_mesh.stats;
    assert_eq!(s.max, 1.0);
    assert_eq!(s.mean, 0.5);
    assert!((e.quality.min - 45.0).abs() < 1e-9);
    assert!((e.quality.p50 - 45.0).abs() < 1e-9);
    let centre_only = eval_mesh(&[CENTRE], &m);
    assert_eq!(centre_only.point_to_mesh.stats.max, 0.5);
}

#[test]
fn cube_without_one_triangle_has_three_boundary_edges_and_euler_one() {
    let (v, mut t) = cube();
    t.remove(5);
    let e = evaluate(&[CENTRE], &v, &t, 500);
    let t = e.topology;
    assert_eq!(t.boundary_edges, 3);
    assert_eq!((t.edges, t.faces), (18, 11));
    assert_eq!(t.euler, 1);
    assert_eq!(t.inconsistent_edges, 0);
    assert_eq!(t.components, 1);
    assert!(!t.is_closed_manifold());
}

#[test]
fn two_cubes_sharing_one_vertex_make_one_non_manifold_vertex() {
    let (mut v, mut t) = cube();
    // The second cube is [1, 2]^3: its vertex 0 is the first cube's vertex 7.
    let map = |i: u32| if i == 0 { 7 } else { 8 + i - 1 };
    v.extend((1..8).map(|i| {
        [
            1.0 + (i & 1) as f64,
            1.0 + (i >> 1 & 1) as f64,
            1.0 + (i >> 2 & 1) as f64,
        ]
    }));
    let second: Vec<[u32; 3]> = cube().1.iter().map(|f| f.map(map)).collect();
    t.extend(second);
    let e = evaluate(&[CENTRE], &v, &t, 500);
    let t = e.topology;
    assert_eq!(t.non_manifold_vertices, 1);
    assert_eq!(t.non_manifold_edges, 0);
    assert_eq!(t.components, 2);
    assert_eq!((t.referenced_vertices, t.edges, t.faces), (15, 36, 24));
    assert_eq!(t.euler, 3);
    assert_eq!(t.inconsistent_edges, 0);
    assert!(!t.is_closed_manifold());
}

#[test]
fn flipped_face_makes_its_three_edges_inconsistent() {
    let (v, mut t) = cube();
    t[3].swap(1, 2);
    let e = evaluate(&[CENTRE], &v, &t, 500);
    assert_eq!(e.topology.inconsistent_edges, 3);
    assert_eq!(e.topology.boundary_edges, 0);
    assert_eq!(e.topology.euler, 2);
}

#[test]
fn three_faces_on_one_edge_make_a_non_manifold_edge() {
    let (mut v, mut t) = cube();
    // A fin on the edge 0-1 (bottom front), pointing out along -y -z.
    v.push([0.5, -1.0, -1.0]);
    t.push([0, 1, 8]);
    let e = evaluate(&[CENTRE], &v, &t, 500);
    assert_eq!(e.topology.non_manifold_edges, 1);
    // Its other two edges are boundary.
    assert_eq!(e.topology.boundary_edges, 2);
}

#[test]
fn degenerate_duplicate_and_unreferenced_are_counted() {
    let (mut v, mut t) = cube();
    v.push([0.5, 0.0, 0.0]); // 8: on the edge 0-1
    v.push([9.0, 9.0, 9.0]); // 9: referenced by nothing
    t.push([0, 8, 1]); // zero area
    t.push([0, 0, 1]); // repeated index
    t.push([3, 0, 2]); // same set as [0, 2, 3]
    let e = evaluate(&[CENTRE], &v, &t, 500);
    let t = e.topology;
    assert_eq!(t.degenerate_faces, 2);
    assert_eq!(t.duplicate_faces, 1);
    assert_eq!(t.vertices, 10);
    // Vertex 8 is referenced by the zero-area face (a proper face), 9 by nothing.
    assert_eq!(t.referenced_vertices, 9);
    assert_eq!(t.unreferenced_vertices, 1);
    assert_eq!(e.quality.min, 0.0);
}

#[test]
fn out_of_range_faces_are_counted_and_ignored() {
    let (v, mut t) = cube();
    t.push([0, 1, 99]);
    let e = evaluate(&[CENTRE], &v, &t, 500);
    assert_eq!(e.topology.invalid_faces, 1);
    assert_eq!(e.topology.faces, 13);
    assert_eq!(e.topology.euler, 2);
    assert_eq!(e.point_to_mesh.stats.max, 0.5);
}

/// Points on a regular grid on each face of the unit cube, `n` per side.
fn cube_surface_points(n: usize) -> Vec<[f64; 3]> {
    let mut pts = Vec::new();
    for axis in 0..3 {
        for side in [0.0, 1.0] {
            for i in 0..n {
                for j in 0..n {
                    let (u, w) = (i as f64 / (n - 1) as f64, j as f64 / (n - 1) as f64);
                    let mut p = [0.0; 3];
                    p[axis] = side;
                    p[(axis + 1) % 3] = u;
                    p[(axis + 2) % 3] = w;
                    pts.push(p);
                }
            }
        }
    }
    pts
}

#[test]
fn densely_sampled_mesh_is_close_both_ways() {
    let n = 41;
    let pts = cube_surface_points(n);
    let e = evaluate(&pts, &cube().0, &cube().1, 20_000);
    assert_eq!(e.point_to_mesh.stats.max, 0.0);
    assert_eq!(e.point_to_mesh.far, 0);
    assert_eq!(e.mesh_to_points.count, 20_000);
    // No sample is farther from the grid than half a cell diagonal.
    let h = 1.0 / (n - 1) as f64;
    assert!(e.mesh_to_points.max <= h * 0.5f64.sqrt() + 1e-12);
    assert!(e.mesh_to_points.mean < 0.5 * h);
    assert!(e.chamfer < 0.25 * h);
    assert_eq!(e.hausdorff, e.mesh_to_points.max);
    assert!((e.diagonal - 3f64.sqrt()).abs() < 1e-15);
    // The same input gives the same numbers.
    assert_eq!(e, evaluate(&pts, &cube().0, &cube().1, 20_000));
}

#[test]
fn missing_geometry_gives_nan_not_a_panic() {
    let (v, t) = cube();
    let e = evaluate(&[], &v, &t, 100);
    assert!(e.point_to_mesh.stats.max.is_nan() && e.mesh_to_points.mean.is_nan());
    let e = evaluate(&[CENTRE], &v, &[], 100);
    assert_eq!(e.mesh_to_points.count, 0);
    assert_eq!(e.point_to_mesh.stats.max, f64::INFINITY);
    assert_eq!(e.topology.euler, 0);
    assert_eq!(e.topology.unreferenced_vertices, 8);
}

#[test]
fn a_cloud_smaller_than_1e_minus_100_is_measured_not_looped_on() {
    // Found by the `eval` fuzz target: fifteen points at the origin but one,
    // 1.3e-321 (subnormal) away, and faces on the origin. The spatial grid's
    // cell size underflowed to 0 and its coarsening loop never ended.
    let mut pts = vec![[0.0; 3]; 15];
    pts[0][0] = f64::from_bits(255);
    let faces = vec![[0, 0, 0]; 15];
    let e = evaluate(&pts, &[[0.0; 3]; 15], &faces, 1016);
    // (Squared, that distance underflows to 0.)
    assert!(e.point_to_mesh.stats.max <= f64::from_bits(255));
    assert_eq!((e.points, e.topology.faces), (15, 15));
    // The unit cube scaled by 1e-120 (the product of its sides underflows):
    // measured, its topology exact. (Its distances are not: squared areas
    // underflow too, so faces are measured as their edges and take no
    // samples; they stay within the cube.)
    let s = 1e-120;
    let scale = |p: [f64; 3]| p.map(|c| c * s);
    let pts: Vec<[f64; 3]> = cube_surface_points(11).into_iter().map(scale).collect();
    let (v, t) = cube();
    let v: Vec<[f64; 3]> = v.into_iter().map(scale).collect();
    let e = evaluate(&pts, &v, &t, 2000);
    assert!(e.hausdorff.is_finite() && e.hausdorff <= s * 3f64.sqrt());
    assert!(e.topology.is_closed_manifold());
}

// ---------------------------------------------------------------------------------
// The command

fn dir(name: &str) -> PathBuf {
    common::dir("eval", name)
}

fn write_off(path: &Path, (v, t): &(Vec<[f64; 3]>, Vec<[u32; 3]>)) {
    let mut s = format!("OFF\n{} {} 0\n", v.len(), t.len());
    for p in v {
        s += &format!("{} {} {}\n", p[0], p[1], p[2]);
    }
    for f in t {
        s += &format!("3 {} {} {}\n", f[0], f[1], f[2]);
    }
    std::fs::write(path, s).unwrap();
}

fn write_xyz(path: &Path, pts: &[[f64; 3]]) {
    let s: String = pts
        .iter()
        .map(|p| format!("{} {} {}\n", p[0], p[1], p[2]))
        .collect();
    std::fs::write(path, s).unwrap();
}

fn run(args: &[&Path]) -> (Option<i32>, String, String) {
    let r = Command::new(env!("CARGO_BIN_EXE_vsaqem"))
        .arg("eval")
        .args(args)
        .output()
        .unwrap();
    (
        r.status.code(),
        String::from_utf8_lossy(&r.stdout).into_owned(),
        String::from_utf8_lossy(&r.stderr).into_owned(),
    )
}

#[test]
fn command_prints_text_and_json_reports() {
    let d = dir("reports");
    let (pts, mesh) = (d.join("pts.xyz"), d.join("cube.off"));
    write_xyz(&pts, &cube_surface_points(11));
    write_off(&mesh, &cube());
    let (code, out, err) = run(&[&pts, &mesh]);
    assert_eq!(code, Some(0), "{err}");
    for needle in [
        "points->mesh",
        "mesh->points",
        "chamfer",
        "Euler 2",
        "closed manifold: yes",
        "min angle",
    ] {
        assert!(out.contains(needle), "'{needle}' not in:\n{out}");
    }
    let (code, out, err) = run(&[
        &pts,
        &mesh,
        Path::new("--json"),
        Path::new("--samples"),
        Path::new("500"),
    ]);
    assert_eq!(code, Some(0), "{err}");
    let out = out.replace(' ', "");
    for needle in [
        "\"euler\":2,",
        "\"boundary_edges\":0,",
        "\"count\":500,",
        "\"hausdorff_relative\":",
        "\"min_angle_p50\":45",
    ] {
        assert!(out.contains(needle), "'{needle}' not in:\n{out}");
    }
}

#[test]
fn command_fails_cleanly_on_bad_input() {
    let d = dir("bad");
    let (pts, mesh, empty) = (d.join("pts.xyz"), d.join("cube.off"), d.join("empty.off"));
    write_xyz(&pts, &[CENTRE]);
    write_off(&mesh, &cube());
    write_off(&empty, &(vec![[0.0; 3]; 3], vec![]));
    let cases: [(&[&Path], &str); 3] = [
        (&[&d.join("missing.xyz"), &mesh], "missing.xyz"),
        (&[&pts, &empty], "no faces"),
        (&[&pts, &d.join("cube.glb")], "unknown extension"),
    ];
    for (args, needle) in cases {
        let (code, _, err) = run(args);
        assert_eq!(code, Some(1), "{err}");
        assert!(err.contains(needle) && !err.contains("panicked"), "{err}");
    }
}

// ---------------------------------------------------------------------------------
// Validity

type Mesh = (Vec<[f64; 3]>, Vec<[u32; 3]>);

/// The octahedron with vertices at ±1 on each axis, faces counter-clockwise outside.
fn octahedron() -> Mesh {
    let v = vec![
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ];
    let mut t = Vec::new();
    for (x, sx) in [(0u32, 1.0), (1, -1.0)] {
        for (y, sy) in [(2u32, 1.0), (3, -1.0)] {
            for (z, sz) in [(4u32, 1.0), (5, -1.0)] {
                t.push(if sx * sy * sz > 0.0 {
                    [x, y, z]
                } else {
                    [x, z, y]
                });
            }
        }
    }
    (v, t)
}

/// The octahedron subdivided `levels` times (each face into four), on the unit sphere.
fn sphere(levels: u32) -> Mesh {
    let (mut v, mut t) = octahedron();
    for _ in 0..levels {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::new();
        for f in &t {
            let m = [0, 1, 2].map(|i| {
                let (a, b) = (f[i].min(f[(i + 1) % 3]), f[i].max(f[(i + 1) % 3]));
                *mid.entry((a, b)).or_insert_with(|| {
                    let p = [0, 1, 2].map(|k| v[a as usize][k] + v[b as usize][k]);
                    let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                    v.push(p.map(|c| c / n));
                    v.len() as u32 - 1
                })
            });
            next.extend([
                [f[0], m[0], m[2]],
                [m[0], f[1], m[1]],
                [m[2], m[1], f[2]],
                [m[0], m[1], m[2]],
            ]);
        }
        t = next;
    }
    (v, t)
}

/// A torus (radii 2 and 0.7) of `n` x `m` quads, each split in two.
fn torus(n: u32, m: u32) -> Mesh {
    let mut v = Vec::new();
    for i in 0..n {
        for j in 0..m {
            let (u, w) = (
                std::f64::consts::TAU * i as f64 / n as f64,
                std::f64::consts::TAU * j as f64 / m as f64,
            );
            let r = 2.0 + 0.7 * w.cos();
            v.push([r * u.cos(), r * u.sin(), 0.7 * w.sin()]);
        }
    }
    let id = |i: u32, j: u32| (i % n) * m + (j % m);
    let mut t = Vec::new();
    for i in 0..n {
        for j in 0..m {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            t.push([a, b, c]);
            t.push([a, c, d]);
        }
    }
    (v, t)
}

/// A tetrahedron with corners `c + s * (±1, ±1, ±1)` (even sign changes), faces
/// counter-clockwise outside, its vertices numbered from `first`.
fn tetrahedron(c: [f64; 3], s: f64, first: u32) -> Mesh {
    let v = [
        [1.0, 1.0, 1.0],
        [1.0, -1.0, -1.0],
        [-1.0, 1.0, -1.0],
        [-1.0, -1.0, 1.0],
    ]
    .iter()
    .map(|d| [0, 1, 2].map(|k| c[k] + s * d[k]))
    .collect();
    let t = [[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]]
        .iter()
        .map(|f: &[u32; 3]| f.map(|i| i + first))
        .collect();
    (v, t)
}

fn join(a: Mesh, b: Mesh) -> Mesh {
    let n = a.0.len() as u32;
    let mut v = a.0;
    v.extend(b.0);
    let mut t = a.1;
    t.extend(b.1.iter().map(|f| f.map(|i| i + n)));
    (v, t)
}

#[test]
fn octahedron_is_a_valid_solid_of_genus_zero() {
    let e = eval_mesh(&[[0.0; 3]], &octahedron());
    let v = &e.validity;
    assert_eq!(
        (
            v.self_intersecting_pairs,
            v.coincident_vertices,
            v.folded_edges,
            v.bubbles
        ),
        (0, 0, 0, 0)
    );
    assert_eq!((v.closed_components, v.genus.clone()), (1, vec![0]));
    assert!(e.topology.is_closed_manifold());
    assert!(e.is_valid_solid(None));
    assert!(e.is_valid_solid(Some(0)));
    assert!(!e.is_valid_solid(Some(1)));
    // The unit cube too, and the subdivided octahedron.
    assert!(eval_mesh(&[CENTRE], &cube()).is_valid_solid(Some(0)));
    assert!(eval_mesh(&[[0.0; 3]], &sphere(2)).is_valid_solid(Some(0)));
}

#[test]
fn torus_has_genus_one() {
    let e = eval_mesh(&[[0.0; 3]], &torus(16, 8));
    assert_eq!(e.validity.genus, vec![1]);
    assert_eq!(e.validity.handles(), 1);
    assert_eq!(e.topology.euler, 0);
    assert_eq!(e.validity.self_intersecting_pairs, 0);
    assert!(e.is_valid_solid(Some(1)));
    assert!(!e.is_valid_solid(Some(0)));
}

#[test]
fn interpenetrating_tetrahedra_intersect() {
    let m = join(
        tetrahedron([0.0; 3], 1.0, 0),
        tetrahedron([0.5, 0.3, 0.2], 1.0, 0),
    );
    let e = eval_mesh(&[[0.0; 3]], &m);
    assert!(e.validity.self_intersecting_pairs > 0);
    // Each is a closed manifold on its own: the combinatorics cannot tell.
    assert!(e.topology.is_closed_manifold());
    assert_eq!(e.validity.genus, vec![0, 0]);
    assert!(!e.is_valid_solid(None));
    // Apart, they are a valid (two-part) solid.
    let apart = join(
        tetrahedron([0.0; 3], 1.0, 0),
        tetrahedron([5.0, 0.0, 0.0], 1.0, 0),
    );
    assert!(eval_mesh(&[[0.0; 3]], &apart).is_valid_solid(Some(0)));
}

#[test]
fn pinch_split_in_place_is_caught() {
    // Two tetrahedra sharing one apex, the apex split into two vertices at the same
    // position: combinatorially two closed manifolds, geometrically one pinched solid.
    let apex = [0.0, 0.0, 0.0];
    let below = (
        vec![
            apex,
            [1.0, 0.0, -1.0],
            [-0.5, 0.8, -1.0],
            [-0.5, -0.8, -1.0],
        ],
        vec![[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]],
    );
    let above = (
        vec![apex, [1.0, 0.0, 1.0], [-0.5, -0.8, 1.0], [-0.5, 0.8, 1.0]],
        vec![[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]],
    );
    let e = eval_mesh(&[[0.0; 3]], &join(below, above));
    assert!(e.topology.is_closed_manifold());
    assert_eq!(e.topology.non_manifold_vertices, 0);
    assert_eq!(e.validity.coincident_vertices, 1);
    assert!(e.validity.self_intersecting_pairs > 0);
    assert!(!e.is_valid_solid(None));
}

#[test]
fn face_folded_onto_its_neighbour_makes_folded_edges() {
    // A triangular bipyramid whose top apex is pushed down to just above the bottom
    // one: each top face folds onto the bottom face across the equator edge.
    let ring: Vec<[f64; 3]> = (0..3)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / 3.0;
            [a.cos(), a.sin(), 0.0]
        })
        .collect();
    let mut v = ring;
    v.push([0.0, 0.0, 1.0]);
    v.push([0.0, 0.0, -1.0]);
    let t = vec![
        [0, 1, 3],
        [1, 2, 3],
        [2, 0, 3],
        [1, 0, 4],
        [2, 1, 4],
        [0, 2, 4],
    ];
    let e = evaluate(&[[0.0; 3]], &v, &t, 500);
    assert_eq!(e.validity.folded_edges, 0);
    assert!(e.is_valid_solid(Some(0)));
    v[3] = [0.0, 0.0, -0.9];
    let e = evaluate(&[[0.0; 3]], &v, &t, 500);
    assert!(e.topology.is_closed_manifold());
    assert_eq!(e.validity.folded_edges, 3);
    assert!(!e.is_valid_solid(None));
    // An orientation error alone is not a fold.
    let (v, mut t) = cube();
    t[3].swap(1, 2);
    assert_eq!(evaluate(&[CENTRE], &v, &t, 500).validity.folded_edges, 0);
}

#[test]
fn coplanar_triangles_intersect_only_where_they_overlap() {
    let v = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.2, 0.2, 0.0],
        [2.0, 0.5, 0.0],
        [0.5, 2.0, 0.0],
    ];
    // Overlapping, no shared vertex.
    let e = evaluate(&[[0.0; 3]], &v, &[[0, 1, 2], [4, 5, 6]], 100);
    assert_eq!(e.validity.self_intersecting_pairs, 1);
    // Sharing an edge, side by side in one plane: a flat square.
    let e = evaluate(&[[0.0; 3]], &v, &[[0, 1, 2], [2, 1, 3]], 100);
    assert_eq!(e.validity.self_intersecting_pairs, 0);
    assert_eq!(e.validity.folded_edges, 0);
    // Sharing an edge, the second folded back over the first.
    let e = evaluate(&[[0.0; 3]], &v, &[[0, 1, 2], [2, 1, 4]], 100);
    assert_eq!(e.validity.self_intersecting_pairs, 1);
    assert_eq!(e.validity.folded_edges, 1);
}

#[test]
fn tiny_closed_component_beside_a_sphere_is_a_bubble() {
    let m = join(sphere(2), tetrahedron([3.0, 0.0, 0.0], 0.05, 0));
    let e = eval_mesh(&[[0.0; 3]], &m);
    let v = &e.validity;
    assert_eq!((v.bubbles, v.bubble_faces), (1, 4));
    assert_eq!((v.closed_components, v.genus.clone()), (2, vec![0, 0]));
    assert_eq!(v.self_intersecting_pairs, 0);
    assert!(!e.is_valid_solid(None));
    // Two tetrahedra alone: neither is ten times the other.
    let two = join(
        tetrahedron([0.0; 3], 1.0, 0),
        tetrahedron([5.0, 0.0, 0.0], 0.1, 0),
    );
    assert_eq!(eval_mesh(&[[0.0; 3]], &two).validity.bubbles, 0);
}

#[test]
fn hostile_positions_do_not_panic_and_are_not_valid() {
    let (mut v, t) = octahedron();
    v[0] = [f64::NAN, 0.0, 0.0];
    v[1] = [1e308, -1e308, f64::INFINITY];
    let mut t2 = t.clone();
    t2.push([0, 1, 77]);
    let e = eval_mesh(&[[0.0; 3]], &(v, t2));
    assert!(e.topology.degenerate_faces >= 4);
    assert!(!e.is_valid_solid(None));
}

#[test]
fn command_reports_validity_and_checks_the_expected_genus() {
    let d = dir("validity");
    let (pts, mesh) = (d.join("pts.xyz"), d.join("torus.off"));
    write_xyz(&pts, &torus(16, 8).0);
    write_off(&mesh, &torus(16, 8));
    let (code, out, err) = run(&[&pts, &mesh]);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        out.contains(
            "validity      self-intersecting pairs 0, coincident vertices 0, folded edges 0, \
             bubbles 0 (0 faces), closed components 1, genus [1]; valid solid: yes\n"
        ),
        "{out}"
    );
    let (_, out, _) = run(&[&pts, &mesh, Path::new("--expect-genus"), Path::new("0")]);
    assert!(
        out.contains("valid solid: no (genus 1, expected 0)"),
        "{out}"
    );
    assert!(out.contains("closed manifold: yes"), "{out}");
    let (_, out, _) = run(&[
        &pts,
        &mesh,
        Path::new("--json"),
        Path::new("--expect-genus"),
        Path::new("1"),
    ]);
    let out = out.replace([' ', '\n'], "");
    for needle in [
        "\"self_intersecting_pairs\":0,",
        "\"genus\":[1],",
        "\"handles\":1,",
        "\"expected_genus\":1,",
        "\"valid_solid\":true",
        "\"closed_manifold\":true",
    ] {
        assert!(out.contains(needle), "'{needle}' not in:\n{out}");
    }
}

#[test]
fn a_pile_of_copied_faces_is_judged_in_bounded_time_with_a_lower_bound() {
    // 20,000 copies of one triangle: 2e8 intersecting pairs, which the exact
    // test took about two minutes to count (10,000 copies took 30 s: quadratic
    // in the pile); it stops at its limit and says so, and the mesh is not a
    // valid solid.
    let d = dir("pile");
    let (pts, mesh) = (d.join("pts.xyz"), d.join("pile.off"));
    write_xyz(&pts, &[[0.1, 0.1, 0.0], [0.5, 0.2, 0.0], [0.2, 0.6, 0.0]]);
    let n = 20_000u32;
    let v: Vec<[f64; 3]> = (0..n)
        .flat_map(|_| [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        .collect();
    let f: Vec<[u32; 3]> = (0..n).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
    write_off(&mesh, &(v, f));
    let (code, out, err) = run(&[Path::new("--samples"), Path::new("100"), &pts, &mesh]);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        out.contains("or more (the test stopped at its limit: faces piled in one place)"),
        "{out}"
    );
    assert!(out.contains("valid solid: no"), "{out}");
    let (code, out, err) = run(&[
        Path::new("--json"),
        Path::new("--samples"),
        Path::new("100"),
        &pts,
        &mesh,
    ]);
    assert_eq!(code, Some(0), "{err}");
    let json: serde_json::Value = serde_json::from_str(&out).unwrap();
    let v = &json["validity"];
    assert_eq!(v["self_intersection_stopped"], true, "{out}");
    assert!(v["self_intersecting_pairs"].as_u64().unwrap() >= 2_000_000);
}
