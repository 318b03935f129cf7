//! Core takes no memory from the heap: a counting global allocator sees no
//! allocation, reallocation or free while `cluster` and `reconstruct` run on a
//! buffer and input made beforehand.
//!
//! One test in this binary, and only the calling thread's allocations counted, so
//! nothing else (the test harness, other tests) can blur the count.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::mem::MaybeUninit;
use std::sync::atomic::{AtomicUsize, Ordering};
use vsaqem_core::sample::Shape;
use vsaqem_core::{arena_bytes, cluster, reconstruct, Arena, Params, Silent};

struct Counting;

static CALLS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

fn note() {
    if COUNTING.with(Cell::get) {
        CALLS.fetch_add(1, Ordering::Relaxed);
    }
}

// SAFETY: forwards every call to the system allocator unchanged; the counter is
// an atomic and the flag a const-initialised thread-local, neither allocates.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note();
        // SAFETY: the caller's contract is passed on as is.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note();
        // SAFETY: as above.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note();
        // SAFETY: as above.
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        note();
        // SAFETY: as above.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Heap calls made by this thread while `f` runs.
fn heap_calls<R>(f: impl FnOnce() -> R) -> (R, usize) {
    let before = CALLS.load(Ordering::Relaxed);
    COUNTING.with(|c| c.set(true));
    let out = f();
    COUNTING.with(|c| c.set(false));
    (out, CALLS.load(Ordering::Relaxed) - before)
}

#[test]
fn core_allocates_nothing_from_the_heap() {
    // The counter itself works.
    let (v, calls) = heap_calls(|| vec![1u8; 100]);
    assert!(calls >= 1, "the counting allocator saw nothing");
    drop(v);

    let mut points = vec![[0.0f32; 3]; 20000];
    vsaqem_core::sample::fill(Shape::Demo, 3, 0.0, &mut points);
    let params = Params {
        clusters: 400,
        refine_rounds: 2,
        ..Params::default()
    };
    let mut buf = vec![MaybeUninit::uninit(); arena_bytes(points.len(), &params)];

    let arena = Arena::new(&mut buf);
    let (faces, calls) = heap_calls(|| {
        reconstruct(&arena, &points, None, &params, &mut Silent).map(|r| r.mesh.triangles.len())
    });
    assert!(faces.expect("reconstruct") > 0);
    assert_eq!(calls, 0, "reconstruct made {calls} heap calls");

    let arena = Arena::new(&mut buf);
    let (clusters, calls) = heap_calls(|| {
        cluster(&arena, &points, None, &params, &mut Silent).map(|c| c.clusters.generators.len())
    });
    assert!(clusters.expect("cluster") >= 400);
    assert_eq!(calls, 0, "cluster made {calls} heap calls");

    // A failing run (an arena far too small) allocates nothing either.
    let arena = Arena::new(&mut buf[..5000]);
    let (result, calls) =
        heap_calls(|| reconstruct(&arena, &points, None, &params, &mut Silent).is_err());
    assert!(result);
    assert_eq!(calls, 0, "a failing reconstruct made {calls} heap calls");
}
