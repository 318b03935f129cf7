//! Core's bumpalo backend (feature `bumpalo`): an arena taken from a
//! `bumpalo::Bump` with an allocation limit works like one over a slice, and a
//! limit too small is the same typed `Exhausted`, never a panic.
//!
//! `cargo test -p vsaqem-core --features bumpalo --test bump_arena`
#![cfg(feature = "bumpalo")]

use bumpalo::Bump;
use std::mem::MaybeUninit;
use std::panic::{catch_unwind, AssertUnwindSafe};
use vsaqem_core::sample::{fill, Shape};
use vsaqem_core::{arena_bytes, reconstruct, Arena, Error, Params, Silent, V3};

fn setup() -> (Vec<V3>, Params) {
    let params = Params {
        clusters: 300,
        ..Params::default()
    };
    let mut points = vec![[0.0; 3]; 12000];
    fill(Shape::Demo, 4, 0.0, &mut points);
    (points, params)
}

#[test]
fn a_limit_too_small_is_exhausted_at_once_never_a_panic() {
    let (points, params) = setup();
    let need = arena_bytes(points.len(), &params);
    for limit in [0, 4096, need / 2, need - 1] {
        let bump = Bump::new();
        bump.set_allocation_limit(Some(limit));
        let got = catch_unwind(AssertUnwindSafe(|| {
            Arena::try_from_bump(&bump, need).map(|a| a.capacity())
        }));
        match got {
            Ok(Err(e)) => {
                assert_eq!(e.requested, need, "limit {limit}");
                assert!(e.available <= limit, "limit {limit}: {e}");
            }
            Ok(Ok(cap)) => panic!("limit {limit}: got {cap} bytes"),
            Err(_) => panic!("limit {limit}: panicked"),
        }
    }
    // A size no layout can have is the same error.
    let bump = Bump::new();
    let e = Arena::try_from_bump(&bump, usize::MAX).unwrap_err();
    assert_eq!(e.requested, usize::MAX);
}

#[test]
fn an_arena_from_a_bump_gives_the_mesh_of_a_slice_arena() {
    let (points, params) = setup();
    let need = arena_bytes(points.len(), &params);

    let mut buf = vec![MaybeUninit::uninit(); need];
    let arena = Arena::new(&mut buf);
    let slice = reconstruct(&arena, &points, None, &params, &mut Silent).unwrap();
    let (slice_mesh, slice_peak) = (
        (slice.mesh.vertices.to_vec(), slice.mesh.triangles.to_vec()),
        arena.peak(),
    );

    // A limit with room for the arena and bumpalo's chunk rounding.
    let bump = Bump::new();
    bump.set_allocation_limit(Some(2 * need + 4096));
    let arena = Arena::try_from_bump(&bump, need).unwrap();
    assert!(arena.capacity() + 7 >= need);
    let out = reconstruct(&arena, &points, None, &params, &mut Silent).unwrap();
    assert_eq!(
        (out.mesh.vertices.to_vec(), out.mesh.triangles.to_vec()),
        slice_mesh
    );
    assert_eq!(arena.peak(), slice_peak);
    assert!(bump.allocated_bytes() <= 2 * need + 4096);
}

#[test]
fn a_bump_arena_smaller_than_the_budget_fails_like_a_short_slice() {
    let (points, params) = setup();
    let need = arena_bytes(points.len(), &params);
    let bump = Bump::new();
    let arena = Arena::try_from_bump(&bump, need / 3).unwrap();
    let got = catch_unwind(AssertUnwindSafe(|| {
        reconstruct(&arena, &points, None, &params, &mut Silent).map(|_| ())
    }));
    match got {
        Ok(Err(Error::Exhausted(e))) => assert!(e.requested > e.available),
        Ok(Err(Error::ArenaTooSmall {
            needed, capacity, ..
        })) => assert!(needed > capacity && capacity <= need / 3),
        Ok(other) => panic!("{:?}", other.err()),
        Err(_) => panic!("panicked"),
    }
}
