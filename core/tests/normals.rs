//! PCA normals against analytic normals.
//!
//! PCA recovers the normal of a neighbourhood's best-fit plane. On a plane that
//! is the plane's normal for any sampling. On a curved surface it equals the
//! analytic normal at the point when the neighbourhood is symmetric about the
//! normal axis; with random samples the tilt of a lopsided neighbourhood is a
//! property of the sampling, not of the estimator (measured and printed below).

use std::f64::consts::TAU;
use std::mem::MaybeUninit;
use vsaqem_core::clustering::knn::try_neighbours_in;
use vsaqem_core::clustering::normals::pca;
use vsaqem_core::math::V3;
use vsaqem_core::rng::Rng;
use vsaqem_core::{Arena, Silent};

/// Angle between two lines (orientation does not matter for plane quadrics).
fn line_angle(a: V3, b: V3) -> f64 {
    let d = (0..3).map(|i| a[i] as f64 * b[i] as f64).sum::<f64>().abs();
    let na = (0..3).map(|i| (a[i] as f64).powi(2)).sum::<f64>().sqrt();
    let nb = (0..3).map(|i| (b[i] as f64).powi(2)).sum::<f64>().sqrt();
    (d / (na * nb)).min(1.0).acos()
}

/// PCA error at each point listed in `check`.
fn errors(points: &[V3], check: &[usize], analytic: impl Fn(V3) -> V3) -> Vec<f64> {
    let mut buf = vec![MaybeUninit::uninit(); 128 << 20];
    let arena = Arena::new(&mut buf);
    let nb = try_neighbours_in(&arena, points, 12, &mut Silent).unwrap();
    check
        .iter()
        .map(|&i| line_angle(pca(points, &nb, i), analytic(points[i])))
        .collect()
}

fn worst(e: &[f64]) -> f64 {
    e.iter().copied().fold(0.0, f64::max)
}

#[test]
fn pca_normal_of_a_sampled_plane_is_the_plane_normal() {
    let mut rng = Rng::new(3);
    let plane: Vec<V3> = (0..20000)
        .map(|_| {
            let (x, y) = (rng.unit_f64() * 2.0 - 1.0, rng.unit_f64() * 2.0 - 1.0);
            [x as f32, y as f32, (0.2 * x - 0.1 * y + 0.3) as f32]
        })
        .collect();
    let all: Vec<usize> = (0..plane.len()).collect();
    let w = worst(&errors(&plane, &all, |_| [-0.2, 0.1, 1.0]));
    assert!(w < 1e-4, "plane: {w:e} rad");
}

/// Patches on the unit sphere: a centre plus two rings of 6 at geodesic radii
/// 0.01 and 0.02, each patch randomly placed and rotated, patches far apart: the
/// centre's 12 neighbours are its patch, symmetric about the radial axis.
#[test]
fn pca_normals_on_a_sphere_match_the_radial_direction() {
    let mut rng = Rng::new(5);
    let mut pts = Vec::new();
    let mut centres = Vec::new();
    // Well-separated centres: a Fibonacci lattice of 200 directions.
    for i in 0..200 {
        let z = 1.0 - (2.0 * i as f64 + 1.0) / 200.0;
        let t = i as f64 * TAU * 0.618_033_988_75;
        let r = (1.0 - z * z).sqrt();
        let c = [r * t.cos(), r * t.sin(), z];
        // Tangent frame, randomly rotated about c.
        let helper = if c[2].abs() < 0.9 {
            [0.0, 0.0, 1.0]
        } else {
            [1.0, 0.0, 0.0]
        };
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let unit = |a: [f64; 3]| {
            let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
            [a[0] / l, a[1] / l, a[2] / l]
        };
        let u = unit(cross(c, helper));
        let v = cross(c, u);
        let phase = rng.unit_f64() * TAU;
        centres.push(pts.len());
        pts.push(c.map(|x| x as f32));
        for (ring, rad) in [(0, 0.01f64), (1, 0.02)] {
            for j in 0..6 {
                let a = phase + (j as f64 + 0.5 * ring as f64) * TAU / 6.0;
                let dir = [0, 1, 2].map(|k| u[k] * a.cos() + v[k] * a.sin());
                // Geodesic distance rad from c along dir.
                let p = [0, 1, 2].map(|k| (c[k] * rad.cos() + dir[k] * rad.sin()) as f32);
                pts.push(p);
            }
        }
    }
    let e = errors(&pts, &centres, |p| p);
    let w = worst(&e);
    assert!(w < 1e-4, "sphere: worst {w:e} rad");
}

/// A regular (angle, height) grid on a cylinder of radius 0.5: every point away
/// from the two open ends has a neighbourhood symmetric about its radial line.
#[test]
fn pca_normals_on_a_cylinder_match_the_radial_direction() {
    let (rings, per_ring) = (200, 400);
    let step = TAU * 0.5 / per_ring as f64;
    let mut pts = Vec::new();
    let mut interior = Vec::new();
    for i in 0..rings {
        for j in 0..per_ring {
            let t = j as f64 * TAU / per_ring as f64;
            if (3..rings - 3).contains(&i) {
                interior.push(pts.len());
            }
            pts.push([
                (0.5 * t.cos()) as f32,
                (0.5 * t.sin()) as f32,
                (i as f64 * step) as f32,
            ]);
        }
    }
    let e = errors(&pts, &interior, |p| [p[0], p[1], 0.0]);
    let w = worst(&e);
    assert!(w < 1e-4, "cylinder: worst {w:e} rad");
}

/// Random samples: the error shrinks as the sampling gets denser (the tilt of a
/// lopsided neighbourhood is proportional to its radius). Printed for the record.
#[test]
fn pca_error_on_random_sphere_samples_shrinks_with_density() {
    let mut rng = Rng::new(9);
    let mut medians = Vec::new();
    for n in [5_000usize, 50_000] {
        let sphere: Vec<V3> = (0..n)
            .map(|_| {
                let z = rng.unit_f64() * 2.0 - 1.0;
                let t = rng.unit_f64() * TAU;
                let r = (1.0 - z * z).sqrt();
                [(r * t.cos()) as f32, (r * t.sin()) as f32, z as f32]
            })
            .collect();
        let all: Vec<usize> = (0..n).collect();
        let mut e = errors(&sphere, &all, |p| p);
        e.sort_by(f64::total_cmp);
        let (med, p99) = (e[n / 2], e[n * 99 / 100]);
        eprintln!(
            "random sphere n={n}: median {med:.2e}, p99 {p99:.2e}, worst {:.2e} rad",
            e[n - 1]
        );
        medians.push(med);
    }
    // Ten times the points: neighbourhood radius / sqrt(10), so the median error
    // must drop by well over half.
    assert!(medians[1] < 0.5 * medians[0], "{medians:?}");
}
