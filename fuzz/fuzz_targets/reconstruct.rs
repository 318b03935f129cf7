//! Core's `reconstruct` on up to 200 points, in an arena of exactly
//! `arena_bytes(n, &params)` bytes: it must not panic, must not run out of
//! that arena (`Exhausted`, `ArenaTooSmall`, `ArenaTooSmallForMeshing`), must
//! give triangles whose indices are in range over finite vertices, and must
//! give the same bytes (or the same error) a second time in a fresh arena.
//!
//! Layout: 14 parameter bytes (see `params`), a flag byte (bit 0: normals
//! follow the points), then points as three little-endian `u16`s each, mapped
//! onto `[-1, 1]` ([`unit`]), then with the flag three `i8`s a point as normals
//! (over 127, so zero and non-unit normals occur).
#![no_main]
use core::mem::MaybeUninit;
use libfuzzer_sys::fuzz_target;
use vsaqem_core::{arena_bytes, reconstruct, Arena, Error, Params, Partition, Silent, V3};
use vsaqem_fuzz::{unit, Bytes};

/// Most points a run takes.
const MAX_POINTS: usize = 200;

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    let params = params(b.array());
    let flags = b.u8();
    let with_normals = flags & 1 == 1;
    let per_point = if with_normals { 9 } else { 6 };
    let n = (b.len() / per_point).min(MAX_POINTS);
    let points: Vec<V3> = (0..n).map(|_| [(); 3].map(|()| unit(b.u16()))).collect();
    let normals: Option<Vec<V3>> = with_normals.then(|| {
        (0..n)
            .map(|_| b.array::<3>().map(|c| f32::from(c as i8) / 127.0))
            .collect()
    });

    let first = run(&points, normals.as_deref(), &params);
    let second = run(&points, normals.as_deref(), &params);
    assert!(first == second, "two runs differ: {params:?}");
});

/// The parameters from 14 bytes, over ranges that keep a run to milliseconds
/// and reach past the valid ranges (`k` 0 and 33, a border angle over 360).
fn params(p: [u8; 14]) -> Params {
    Params {
        k: usize::from(p[0] % 34),
        clusters: u32::from(p[1]),
        max_clusters: 2 * u32::from(p[2]),
        iterations: u32::from(p[3] & 7),
        split_iterations: u32::from((p[3] >> 3) & 3),
        split_rounds: u32::from(p[3] >> 5),
        tolerance: f32::from(p[4]) * 0.0005,
        seed: u64::from(p[5]),
        partition: match p[6] % 3 {
            0 => Partition::Auto,
            1 => Partition::Grow,
            _ => Partition::Sweep,
        },
        node_limit: 4 * u64::from(p[7]),
        fit_rounds: u32::from(p[8] & 3),
        refine_rounds: u32::from((p[8] >> 2) & 3),
        max_hole: 8 * u32::from(p[8] >> 4),
        densify: f32::from(p[9]) / 510.0,
        max_error: f32::from(p[10]) * 0.0002,
        refine_beyond: f32::from(p[11]) * 0.0001,
        border_angle: f32::from(p[12]) * 1.5,
        min_fragment: 0,
        lambda: [0.001, 0.0, 0.1, 1.0][usize::from(p[13] & 3)],
        border_penalty: [2.0, 0.0, 0.5, 20.0][usize::from((p[13] >> 2) & 3)],
        ..Params::default()
    }
}

/// What a run gives, in bits: the mesh (vertices, triangles, the vertices'
/// clusters) or the error's text.
#[derive(PartialEq)]
enum Outcome {
    Mesh(Vec<[u32; 3]>, Vec<[u32; 3]>, Vec<u32>),
    Failed(String),
}

fn run(points: &[V3], normals: Option<&[V3]>, params: &Params) -> Outcome {
    let mut buf = vec![MaybeUninit::uninit(); arena_bytes(points.len(), params)];
    let arena = Arena::new(&mut buf);
    match reconstruct(&arena, points, normals, params, &mut Silent) {
        Ok(out) => {
            let m = &out.mesh;
            let nv = m.vertices.len();
            for (i, v) in m.vertices.iter().enumerate() {
                assert!(v.iter().all(|c| c.is_finite()), "vertex {i} is {v:?}");
            }
            for (i, t) in m.triangles.iter().enumerate() {
                assert!(
                    t.iter().all(|&v| (v as usize) < nv),
                    "triangle {i} is {t:?} with {nv} vertices"
                );
            }
            assert_eq!(m.vertex_cluster.len(), nv);
            Outcome::Mesh(
                m.vertices.iter().map(|v| v.map(f32::to_bits)).collect(),
                m.triangles.to_vec(),
                m.vertex_cluster.to_vec(),
            )
        }
        Err(
            e @ (Error::Exhausted(_)
            | Error::ArenaTooSmall { .. }
            | Error::ArenaTooSmallForMeshing { .. }),
        ) => panic!(
            "{e} in an arena of arena_bytes({}) bytes ({} usable): {params:?}",
            points.len(),
            arena.capacity()
        ),
        Err(e) => Outcome::Failed(format!("{e:?}")),
    }
}
