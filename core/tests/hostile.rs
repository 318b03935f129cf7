//! Hostile input to core: typed errors, never a panic, never a NaN in the output.

use std::mem::MaybeUninit;
use vsaqem_core::sample::{fill, Shape};
use vsaqem_core::{
    cluster, cluster_bytes, Arena, Degeneracy, Error, Flow, Params, Progress, Silent, Stage, V3,
};

fn run(points: &[V3], normals: Option<&[V3]>, params: &Params) -> Result<(usize, Vec<V3>), Error> {
    let mut buf = vec![MaybeUninit::uninit(); cluster_bytes(points.len(), params)];
    let arena = Arena::new(&mut buf);
    let out = cluster(&arena, points, normals, params, &mut Silent)?;
    Ok((out.clusters.labels.len(), out.clusters.generators.to_vec()))
}

fn sphere(n: usize) -> Vec<V3> {
    let mut p = vec![[0.0; 3]; n];
    fill(Shape::Sphere, 1, 0.0, &mut p);
    p
}

#[test]
fn non_finite_coordinates_name_the_point_and_axis() {
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let mut p = sphere(500);
        p[123][2] = bad;
        match run(&p, None, &Params::default()) {
            Err(Error::NonFinite {
                index: 123,
                axis: 2,
                normal: false,
                ..
            }) => {}
            other => panic!("{bad}: {other:?}"),
        }
    }
    let e = Error::NonFinite {
        index: 7,
        axis: 1,
        value: f32::NAN,
        normal: false,
    };
    assert_eq!(
        e.to_string(),
        "point 7: coordinate y is NaN, not a finite number"
    );
}

#[test]
fn too_few_points_is_an_error() {
    for n in 0..4 {
        let p = sphere(n);
        assert!(
            matches!(run(&p, None, &Params { k: 1, ..Params::default() }), Err(Error::TooFewPoints { found, needed: 4 }) if found == n)
        );
    }
}

#[test]
fn degenerate_clouds_are_named() {
    let same = vec![[0.25, -0.5, 0.125]; 100];
    assert_eq!(
        run(&same, None, &Params::default()).unwrap_err(),
        Error::Degenerate(Degeneracy::Coincident)
    );
    // Duplicates of three distinct points: a plane.
    let tri: Vec<V3> = (0..90)
        .map(|i| [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.3]][i % 3])
        .collect();
    assert_eq!(
        run(&tri, None, &Params::default()).unwrap_err(),
        Error::Degenerate(Degeneracy::Coplanar)
    );
    let line: Vec<V3> = (0..200)
        .map(|i| {
            let t = i as f32 / 199.0;
            [t, 2.0 * t - 1.0, 0.5 - t]
        })
        .collect();
    assert_eq!(
        run(&line, None, &Params::default()).unwrap_err(),
        Error::Degenerate(Degeneracy::Collinear)
    );
    let plane: Vec<V3> = (0..400)
        .map(|i| {
            let (x, y) = ((i % 20) as f32 / 19.0, (i / 20) as f32 / 19.0);
            [x, y, 0.3 * x - 0.2 * y]
        })
        .collect();
    assert_eq!(
        run(&plane, None, &Params::default()).unwrap_err(),
        Error::Degenerate(Degeneracy::Coplanar)
    );
}

#[test]
fn bad_k_and_parameters_are_errors() {
    let p = sphere(20);
    for k in [0, 20, 21, 33] {
        assert!(
            matches!(
                run(
                    &p,
                    None,
                    &Params {
                        k,
                        ..Params::default()
                    }
                ),
                Err(Error::BadNeighbours { .. })
            ),
            "k = {k}"
        );
    }
    let bad = [
        Params {
            clusters: 0,
            ..Params::default()
        },
        Params {
            tolerance: f32::NAN,
            ..Params::default()
        },
        Params {
            tolerance: -1.0,
            ..Params::default()
        },
        Params {
            lambda: f32::INFINITY,
            ..Params::default()
        },
        Params {
            lambda: -0.1,
            ..Params::default()
        },
    ];
    for params in bad {
        assert!(
            matches!(run(&p, None, &params), Err(Error::BadParameter { .. })),
            "{params:?}"
        );
    }
}

#[test]
fn unusable_normals_fall_back_to_pca_and_a_length_mismatch_is_an_error() {
    let p = sphere(2000);
    let short = vec![[0.0, 0.0, 1.0]; 10];
    assert_eq!(
        run(&p, Some(&short), &Params::default()).unwrap_err(),
        Error::NormalsLength {
            points: 2000,
            normals: 10
        }
    );
    // NaN, zero and infinite normals are ignored point by point.
    let mut normals: Vec<V3> = p.clone();
    normals[3] = [f32::NAN, 0.0, 1.0];
    normals[4] = [0.0, 0.0, 0.0];
    normals[5] = [f32::INFINITY, 0.0, 0.0];
    let (n, gens) = run(
        &p,
        Some(&normals),
        &Params {
            clusters: 50,
            ..Params::default()
        },
    )
    .unwrap();
    assert_eq!(n, 2000);
    assert!(gens.iter().flatten().all(|v| v.is_finite()));
}

#[test]
fn extreme_but_finite_coordinates_never_panic_or_produce_nan() {
    for scale in [1e-30f32, 1e-6, 1e6, 1e30, f32::MAX / 4.0] {
        let p: Vec<V3> = sphere(1000).iter().map(|q| q.map(|v| v * scale)).collect();
        match run(
            &p,
            None,
            &Params {
                clusters: 40,
                ..Params::default()
            },
        ) {
            Ok((_, gens)) => assert!(
                gens.iter().flatten().all(|v| v.is_finite()),
                "scale {scale}: NaN generator"
            ),
            Err(e) => eprintln!("scale {scale}: {e}"),
        }
    }
}

#[test]
fn duplicate_heavy_clouds_cluster_without_nan() {
    let base = sphere(1500);
    let mut p = Vec::new();
    for q in &base {
        for _ in 0..4 {
            p.push(*q);
        }
    }
    let (n, gens) = run(
        &p,
        None,
        &Params {
            clusters: 100,
            ..Params::default()
        },
    )
    .unwrap();
    assert_eq!(n, 6000);
    assert!(gens.iter().flatten().all(|v| v.is_finite()));
}

#[test]
fn every_arena_size_gives_a_result_or_a_memory_error() {
    let p = sphere(600);
    let params = Params {
        clusters: 30,
        ..Params::default()
    };
    let need = cluster_bytes(p.len(), &params);
    let mut buf = vec![MaybeUninit::uninit(); need];
    let mut ok = 0;
    for size in (0..need).step_by(need / 97).chain([need]) {
        let arena = Arena::new(&mut buf[..size]);
        match cluster(&arena, &p, None, &params, &mut Silent) {
            Ok(_) => ok += 1,
            Err(Error::Exhausted(e)) => assert!(e.available < e.requested, "{size}: {e:?}"),
            Err(Error::ArenaTooSmall {
                needed, capacity, ..
            }) => assert!(
                capacity < needed && needed <= need,
                "{size}: {needed} {capacity}"
            ),
            Err(e) => panic!("{size}: {e}"),
        }
    }
    assert!(ok >= 1, "the predicted size must succeed");
}

#[test]
fn a_progress_callback_can_cancel_every_stage() {
    struct CancelAt(Stage);
    impl Progress for CancelAt {
        fn report(&mut self, stage: Stage, _: u64, _: u64) -> Flow {
            if stage == self.0 {
                Flow::Cancel
            } else {
                Flow::Continue
            }
        }
    }
    let p = sphere(3000);
    let params = Params {
        clusters: 50,
        ..Params::default()
    };
    for stage in [
        Stage::Validate,
        Stage::Neighbours,
        Stage::Quadrics,
        Stage::Clustering,
    ] {
        let mut buf = vec![MaybeUninit::uninit(); cluster_bytes(p.len(), &params)];
        let arena = Arena::new(&mut buf);
        assert!(
            matches!(
                cluster(&arena, &p, None, &params, &mut CancelAt(stage)),
                Err(Error::Cancelled)
            ),
            "{stage:?}"
        );
    }
}
