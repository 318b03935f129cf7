//! Feature migration: QEM-optimal generators move onto sharp features.

use std::mem::MaybeUninit;
use vsaqem_core::rng::Rng;
use vsaqem_core::{cluster, cluster_bytes, Arena, Params, Silent, V3};

/// Two half-planes of width `w` meeting at the y axis with dihedral `angle`.
fn dihedral(angle: f64, n: usize, seed: u64) -> Vec<V3> {
    let mut rng = Rng::new(seed);
    let w = 0.3;
    let (c, s) = (angle.cos(), angle.sin());
    (0..n)
        .map(|i| {
            let t = rng.unit_f64() * w;
            let y = (rng.unit_f64() - 0.5) * 2.0 * w;
            if i % 2 == 0 {
                [-t as f32, y as f32, 0.0]
            } else {
                // The second half-plane: direction (cos, 0, sin) from the axis, with
                // the first half-plane along -x the dihedral is `angle`.
                [(-t * c) as f32, y as f32, (t * s) as f32]
            }
        })
        .collect()
}

#[test]
fn generator_of_a_cluster_on_two_planes_lands_on_their_intersection_line() {
    for (deg, seed) in [(90.0f64, 1u64), (60.0, 2), (120.0, 3), (150.0, 4)] {
        let pts = dihedral(deg.to_radians(), 8000, seed);
        let params = Params {
            clusters: 1,
            tolerance: 0.0,
            ..Params::default()
        };
        let mut buf = vec![MaybeUninit::uninit(); cluster_bytes(pts.len(), &params)];
        let arena = Arena::new(&mut buf);
        let out = cluster(&arena, &pts, None, &params, &mut Silent).unwrap();
        assert_eq!(out.clusters.generators.len(), 1);
        let g = out.clusters.generators[0];
        // Distance from the y axis (the intersection line).
        let d = ((g[0] as f64).powi(2) + (g[2] as f64).powi(2)).sqrt();
        let diag = out.bounds.diag as f64;
        eprintln!(
            "{deg} deg: generator {g:?}, {:.2e} of the diagonal from the line",
            d / diag
        );
        assert!(
            d <= 1e-3 * diag,
            "{deg} deg: generator {g:?} is {d} from the line (diag {diag})"
        );
        // The centroid is off the line: the generator migrated to the feature.
        let cx = pts.iter().map(|p| p[0] as f64).sum::<f64>() / pts.len() as f64;
        let cz = pts.iter().map(|p| p[2] as f64).sum::<f64>() / pts.len() as f64;
        assert!(
            (cx * cx + cz * cz).sqrt() > 20.0 * d,
            "{deg} deg: no closer than the centroid"
        );
    }
}

/// With exact normals and no Euclidean term the optimum is exactly on the line:
/// the solve itself adds no bias.
#[test]
fn with_exact_normals_the_qem_optimum_is_on_the_line_to_rounding() {
    let pts = dihedral(75f64.to_radians(), 6000, 7);
    let (c, s) = (75f64.to_radians().cos(), 75f64.to_radians().sin());
    let normals: Vec<V3> = (0..pts.len())
        .map(|i| {
            if i % 2 == 0 {
                [0.0, 0.0, 1.0]
            } else {
                [(-s) as f32, 0.0, (-c) as f32]
            }
        })
        .collect();
    let params = Params {
        clusters: 1,
        tolerance: 0.0,
        lambda: 0.0,
        ..Params::default()
    };
    let mut buf = vec![MaybeUninit::uninit(); cluster_bytes(pts.len(), &params)];
    let arena = Arena::new(&mut buf);
    let out = cluster(&arena, &pts, Some(&normals), &params, &mut Silent).unwrap();
    let g = out.clusters.generators[0];
    let d = ((g[0] as f64).powi(2) + (g[2] as f64).powi(2)).sqrt();
    assert!(d <= 1e-6, "generator {g:?} is {d} from the line");
}
