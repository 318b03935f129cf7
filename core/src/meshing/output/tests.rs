use super::*;
use std::mem::MaybeUninit;
use std::vec;
use std::vec::Vec;

/// Octahedron around the origin, faces counter-clockwise from outside.
fn octahedron() -> (Vec<V3>, Vec<[u32; 3]>) {
    let v = vec![
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ];
    let f = vec![
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    (v, f)
}

/// Every edge has exactly two faces running it in opposite directions.
fn closed_and_consistent(faces: &[[u32; 3]]) -> bool {
    let mut half: Vec<(u32, u32)> = faces
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
        .collect();
    half.sort_unstable();
    let n = half.len();
    half.dedup();
    half.len() == n
        && half
            .iter()
            .all(|&(a, b)| half.binary_search(&(b, a)).is_ok())
}

fn fill(faces: &[[u32; 3]], v: &[V3], max_hole: u32) -> (Vec<[u32; 3]>, Filled, u32) {
    let mut buf = vec![MaybeUninit::uninit(); 1 << 16];
    let arena = Arena::new(&mut buf);
    let nf = faces.len();
    let all = arena
        .try_alloc_slice::<[u32; 3]>(3 * nf + 8, [0; 3])
        .unwrap();
    all[..nf].copy_from_slice(faces);
    let clash = arena.try_alloc_slice::<bool>(all.len(), false).unwrap();
    orient(&arena, &mut all[..nf], v, clash).unwrap();
    let filled = fill_holes(&arena, all, nf, v, &[], &mut [], &mut [], max_hole, 1e-6).unwrap();
    let total = nf + filled.faces;
    clash.fill(false);
    let (_, bad) = orient(&arena, &mut all[..total], v, clash).unwrap();
    (all[..total].to_vec(), filled, bad)
}

#[test]
fn holes_close_into_a_consistently_oriented_surface() {
    let (v, f) = octahedron();
    assert!(closed_and_consistent(&f));
    // One face missing: a triangular hole gets exactly that face back.
    let (out, filled, bad) = fill(&f[1..], &v, 64);
    assert_eq!((filled.holes, filled.faces, filled.left, bad), (1, 1, 0, 0));
    assert!(closed_and_consistent(&out));
    let mut back = out[out.len() - 1];
    back.sort_unstable();
    assert_eq!(back, [0, 2, 4]);
    // Two faces around one vertex: a quad hole, two faces, no edge reused.
    let (out, filled, bad) = fill(&f[2..], &v, 64);
    assert_eq!((filled.holes, filled.faces, filled.left, bad), (1, 2, 0, 0));
    assert!(closed_and_consistent(&out));
    // The upper half gone: a square hole through four vertices of the waist.
    let (out, filled, _) = fill(&f[4..], &v, 64);
    assert_eq!((filled.holes, filled.faces), (1, 2));
    assert!(closed_and_consistent(&out));
}

#[test]
fn holes_longer_than_the_limit_stay_open() {
    let (v, f) = octahedron();
    let (out, filled, _) = fill(&f[2..], &v, 3);
    assert_eq!((filled.holes, filled.faces, filled.left), (0, 0, 1));
    assert_eq!(out.len(), 6);
    assert!(!closed_and_consistent(&out));
}

#[test]
fn an_ear_never_repeats_an_existing_edge_nor_stacks_onto_the_mesh() {
    // Two triangles sharing edge 0-2, bent along it: the outline 0-1-2-3 is one
    // hole whose ears at 1 and 3 would add 0-2 a second time (a third face on
    // it); the fill must use the diagonal 1-3 instead, closing a tetrahedron.
    let mut v = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 1.0],
    ];
    let f = [[0u32, 1, 2], [0, 2, 3]];
    let (out, filled, bad) = fill(&f, &v, 64);
    assert_eq!((filled.holes, filled.faces, filled.left, bad), (1, 2, 0, 0));
    assert!(closed_and_consistent(&out));
    for t in &out[2..] {
        assert!(t.contains(&1) && t.contains(&3), "{t:?}");
    }
    // Flat, the same filling would lie on the sheet (faces stacked on faces):
    // the hole stays open.
    v[3] = [0.0, 1.0, 0.0];
    let (out, filled, _) = fill(&f, &v, 64);
    assert_eq!((filled.holes, filled.faces, filled.left), (0, 0, 1));
    assert_eq!(out.len(), 2);
}
