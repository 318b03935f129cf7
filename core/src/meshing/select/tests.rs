//! Unit tests of facet selection: exact answers on small meshes, brute force on
//! random instances, node limits, hostile inputs and arena exhaustion.

extern crate std;
use super::*;
use crate::arena::Arena;
use crate::progress::{Backwards, Claimed, Silent};
use core::mem::MaybeUninit;
use std::vec;
use std::vec::Vec;

/// Node limit of these tests. They check proofs of optimality, so they need a
/// limit that proves every instance here, not the pipeline's default
/// ([`crate::Params::node_limit`]).
const PROOF_NODE_LIMIT: u64 = 20_000;

/// Facets given by vertex triples; edges numbered in order of appearance.
struct Mesh {
    facets: Vec<[u32; MAX_CONSTRAINTS]>,
    edges: Vec<(u32, u32)>,
}

fn mesh(tris: &[[u32; 3]]) -> Mesh {
    let mut edges: Vec<(u32, u32)> = Vec::new();
    let mut facets = Vec::new();
    for t in tris {
        let mut f = [0u32; 3];
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            let key = (a.min(b), a.max(b));
            let id = match edges.iter().position(|&e| e == key) {
                Some(p) => p,
                None => {
                    edges.push(key);
                    edges.len() - 1
                }
            };
            f[i] = id as u32;
        }
        facets.push(widen(f));
    }
    Mesh { facets, edges }
}

fn degrees(input: &SelectInput<'_>, sel: &[bool]) -> Vec<u32> {
    let mut deg = vec![0u32; input.edge_count];
    for (f, e) in input.facet_edges.iter().enumerate() {
        if sel[f] {
            for &e in e.iter().filter(|&&e| e != UNUSED) {
                deg[e as usize] += 1;
            }
        }
    }
    deg
}

/// Objective of `sel`, or `None` when some edge's degree is not allowed.
fn value(input: &SelectInput<'_>, sel: &[bool]) -> Option<f64> {
    let deg = degrees(input, sel);
    let mut v = 0.0;
    for (e, &d) in deg.iter().enumerate() {
        let m = input.edge_mask.map_or(MASK_CLOSED, |m| m[e]);
        if d > 2 || (m >> d) & 1 == 0 {
            return None;
        }
        if d == 1 {
            v -= input.edge_penalty.map_or(0.0, |p| p[e] as f64);
        }
    }
    for (f, &s) in sel.iter().enumerate() {
        if s {
            v += input.scores[f] as f64;
        }
    }
    Some(v)
}

fn brute(input: &SelectInput<'_>) -> f64 {
    let n = input.facet_edges.len();
    assert!(n <= 20);
    let mut best = f64::NEG_INFINITY;
    let mut sel = vec![false; n];
    for bits in 0u32..(1 << n) {
        for (f, s) in sel.iter_mut().enumerate() {
            *s = (bits >> f) & 1 == 1;
        }
        if let Some(v) = value(input, &sel) {
            best = best.max(v);
        }
    }
    best
}

fn run(input: &SelectInput<'_>) -> (Vec<bool>, SelectStats) {
    let n = select_bytes_for(input);
    assert!(n <= select_bytes(input.facet_edges.len(), input.edge_count));
    let mut buf = vec![MaybeUninit::<u8>::uninit(); n];
    let arena = Arena::new(&mut buf);
    let (sel, stats) = try_select_in(&arena, input, &mut |_, _| true).unwrap();
    assert!(arena.peak() <= n);
    let sel = sel.to_vec();
    let v = value(input, &sel).expect("selection must be feasible");
    assert!(
        (v - stats.objective).abs() < 1e-6,
        "{v} vs {}",
        stats.objective
    );
    assert!(stats.upper_bound >= stats.objective - 1e-9);
    (sel, stats)
}

fn err(input: &SelectInput<'_>) -> Error {
    let mut buf = vec![MaybeUninit::<u8>::uninit(); 1 << 16];
    let arena = Arena::new(&mut buf);
    try_select_in(&arena, input, &mut |_, _| true).unwrap_err()
}

/// Tetrahedron 0123 plus a low-scoring tent 014, 124, 204 over face 012.
fn tetra_and_tent() -> (Mesh, Vec<f32>) {
    let m = mesh(&[
        [0, 1, 2],
        [0, 3, 1],
        [1, 3, 2],
        [2, 3, 0],
        [0, 1, 4],
        [1, 2, 4],
        [2, 0, 4],
    ]);
    (m, vec![1.0, 1.0, 1.0, 1.0, 0.2, 0.2, 0.2])
}

#[test]
fn a_tetrahedron_beats_its_worse_tented_alternative() {
    let (m, w) = tetra_and_tent();
    let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
    let (sel, st) = run(&input);
    assert_eq!(sel, [true, true, true, true, false, false, false]);
    assert!(st.optimal && (st.objective - 4.0).abs() < 1e-6 && st.gap == 0.0);
    // Make the tent worth more than face 012: the bipyramid wins.
    let w2 = vec![0.1, 1.0, 1.0, 1.0, 0.5, 0.5, 0.5];
    let input = SelectInput::new(&m.facets, &w2, m.edges.len(), PROOF_NODE_LIMIT);
    let (sel, st) = run(&input);
    assert_eq!(sel, [false, true, true, true, true, true, true]);
    assert!(st.optimal && (st.objective - 4.5).abs() < 1e-6);
}

#[test]
fn two_tetrahedra_on_one_edge_only_one_is_taken() {
    // Edge 01 carries four candidate facets.
    let m = mesh(&[
        [0, 1, 2],
        [0, 3, 1],
        [1, 3, 2],
        [2, 3, 0],
        [1, 0, 4],
        [0, 5, 4],
        [4, 5, 1],
        [1, 5, 0],
    ]);
    let w = vec![1.0, 1.0, 1.0, 1.0, 0.9, 0.9, 0.9, 0.9];
    let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
    let (sel, st) = run(&input);
    assert_eq!(&sel[..4], &[true; 4]);
    assert_eq!(&sel[4..], &[false; 4]);
    assert!(st.optimal && (st.objective - 4.0).abs() < 1e-6);
    assert_eq!(st.components, 1);
}

/// Convex quad 0123 (in that order), all four triangles: 012 and 023 (diagonal
/// 02), 013 and 123 (diagonal 13); with `apexes`, also the octahedron's eight
/// faces over apex 4 above and apex 5 below. Returns the mesh and its
/// geometric fold groups: at each quad edge, the two quad triangles on it lie
/// on the same side (the quad's inside), so they form a group; on a diagonal
/// they lie on opposite sides, and the apex faces stand 90 degrees apart.
fn flat_quad(apexes: bool) -> (Mesh, Vec<Vec<usize>>) {
    let mut tris = vec![[0, 1, 2], [0, 2, 3], [0, 1, 3], [1, 2, 3]];
    if apexes {
        for (a, b) in [(0, 1), (1, 2), (2, 3), (3, 0)] {
            tris.push([a, b, 4]);
            tris.push([a, b, 5]);
        }
    }
    let m = mesh(&tris);
    let quad_tris: Vec<usize> = (0..4).collect();
    let groups = [(0, 1), (1, 2), (2, 3), (0, 3)]
        .iter()
        .map(|&(a, b)| {
            quad_tris
                .iter()
                .copied()
                .filter(|&f| tris[f].contains(&a) && tris[f].contains(&b))
                .collect::<Vec<usize>>()
        })
        .collect();
    (m, groups)
}

/// The rows of `m` plus the groups as constraints `edges..`, with their masks.
fn with_groups(m: &Mesh, groups: &[Vec<usize>]) -> (Vec<[u32; MAX_CONSTRAINTS]>, Vec<u8>) {
    let mut rows = m.facets.clone();
    let mut mask = vec![MASK_CLOSED; m.edges.len()];
    for g in groups {
        for &f in g {
            add_to(&mut rows, f, mask.len() as u32);
        }
        mask.push(MASK_AT_MOST_ONE);
    }
    (rows, mask)
}

#[test]
fn fold_groups_forbid_the_flat_tetrahedron_of_a_quads_two_triangulations() {
    let (m, groups) = flat_quad(false);
    assert!(groups.iter().all(|g| g.len() == 2));
    let w = vec![1.0f32; 4];
    // Edges only: both triangulations close a flat tetrahedron, worth 4.
    let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
    let (sel, st) = run(&input);
    assert_eq!(sel, [true; 4]);
    assert!(st.optimal && (st.objective - 4.0).abs() < 1e-9);
    // With the fold groups a quad alone cannot close: nothing.
    let (rows, mask) = with_groups(&m, &groups);
    let input = SelectInput {
        edge_mask: Some(&mask),
        ..SelectInput::new(&rows, &w, mask.len(), PROOF_NODE_LIMIT)
    };
    let (sel, st) = run(&input);
    assert_eq!(sel, [false; 4]);
    assert!(st.optimal && st.objective == 0.0);
    assert_eq!(brute(&input), 0.0);
}

#[test]
fn fold_groups_in_an_octahedron_leave_one_triangulation_under_a_pyramid() {
    let (m, groups) = flat_quad(true);
    // Quad triangles worth more than the octahedron's faces: without groups
    // the flat tetrahedron (4 x 2.5) beats the octahedron (8) and a pyramid
    // closed by one triangulation (4 + 2 x 2.5).
    let mut w = vec![2.5f32; 4];
    w.extend((0..8).map(|i| if i % 2 == 0 { 1.0 } else { 0.9 }));
    let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
    let (sel, st) = run(&input);
    assert_eq!(&sel[..4], &[true; 4]);
    assert!(st.optimal && (st.objective - 10.0).abs() < 1e-5);
    let (rows, mask) = with_groups(&m, &groups);
    let input = SelectInput {
        edge_mask: Some(&mask),
        ..SelectInput::new(&rows, &w, mask.len(), PROOF_NODE_LIMIT)
    };
    let (sel, st) = run(&input);
    assert!(
        st.optimal && (st.objective - 9.0).abs() < 1e-5,
        "{}",
        st.objective
    );
    assert!((brute(&input) - 9.0).abs() < 1e-5);
    // The upper pyramid (even faces, worth 1.0) and one triangulation.
    assert_eq!(sel.iter().filter(|&&s| s).count(), 6);
    assert!(sel[..4] == [true, true, false, false] || sel[..4] == [false, false, true, true]);
    assert!((4..12).all(|f| sel[f] == (f % 2 == 0)));
}

#[test]
fn all_negative_scores_select_nothing() {
    let (m, _) = tetra_and_tent();
    let w = vec![-0.5; 7];
    let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
    let (sel, st) = run(&input);
    assert!(sel.iter().all(|&s| !s));
    assert!(st.optimal && st.objective == 0.0);
}

#[test]
fn a_negative_facet_is_taken_when_it_closes_a_surface() {
    let (m, _) = tetra_and_tent();
    let w = vec![-0.5, 1.0, 1.0, 1.0, -1.0, -1.0, -1.0];
    let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
    let (sel, st) = run(&input);
    assert_eq!(sel, [true, true, true, true, false, false, false]);
    assert!(st.optimal && (st.objective - 2.5).abs() < 1e-6);
}

#[test]
fn an_open_strip_keeps_its_border_only_when_worth_the_penalty() {
    // Strip 012, 213, 234: interior edges 12 and 23, the rest border edges.
    let m = mesh(&[[0, 1, 2], [2, 1, 3], [2, 3, 4]]);
    let interior = |e: &(u32, u32)| *e == (1, 2) || *e == (2, 3);
    let mask: Vec<u8> = m
        .edges
        .iter()
        .map(|e| {
            if interior(e) {
                MASK_CLOSED
            } else {
                MASK_BORDER
            }
        })
        .collect();
    let w = vec![1.0f32; 3];
    for (pen, expect) in [(0.1f32, 3.0 - 5.0 * 0.1), (1.0, 0.0)] {
        let pens = vec![pen; m.edges.len()];
        let input = SelectInput {
            edge_mask: Some(&mask),
            edge_penalty: Some(&pens),
            ..SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT)
        };
        let (sel, st) = run(&input);
        assert!(st.optimal);
        assert!(
            (st.objective - expect).abs() < 1e-6,
            "{pen}: {}",
            st.objective
        );
        assert!((brute(&input) - expect).abs() < 1e-6);
        assert_eq!(sel.iter().all(|&s| s), expect > 0.0);
    }
}

#[test]
fn a_lone_triangle_is_forced_off_and_nothing_is_optimal() {
    let m = mesh(&[[0, 1, 2], [1, 2, 3]]);
    let w = vec![5.0, 5.0];
    let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
    let (sel, st) = run(&input);
    assert_eq!(sel, [false, false]);
    assert!(st.optimal && st.objective == 0.0);
    assert_eq!((st.forced, st.components, st.nodes), (2, 0, 0));
}

#[test]
fn mask_zero_only_forbids_an_edge() {
    let (m, w) = tetra_and_tent();
    let mut mask = vec![MASK_CLOSED; m.edges.len()];
    mask[0] = 0b001; // edge 01: the tetrahedron and the tent both need it
    let input = SelectInput {
        edge_mask: Some(&mask),
        ..SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT)
    };
    let (sel, st) = run(&input);
    assert!(sel.iter().all(|&s| !s) && st.optimal);
}

/// Facet edges, scores, edge count, masks, penalties.
type Random = (
    Vec<[u32; MAX_CONSTRAINTS]>,
    Vec<f32>,
    usize,
    Vec<u8>,
    Vec<f32>,
);

/// Put facet `f` into constraint `id` (its first unused slot).
fn add_to(rows: &mut [[u32; MAX_CONSTRAINTS]], f: usize, id: u32) {
    let slot = rows[f].iter().position(|&e| e == UNUSED).unwrap();
    rows[f][slot] = id;
}

/// Deterministic pseudo-random instances: triangles of a random graph; with
/// `groups`, the facets on each edge are also shuffled into runs, and runs of
/// two or more become at-most-one groups (random penalty or none).
fn random_instance(seed: u64, verts: u32, p: u32, border: bool, groups: bool) -> Random {
    let mut s = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut next = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 33) as u32
    };
    let mut tris = Vec::new();
    let mut adj = vec![false; (verts * verts) as usize];
    for a in 0..verts {
        for b in a + 1..verts {
            if next() % 100 < p {
                adj[(a * verts + b) as usize] = true;
            }
        }
    }
    for a in 0..verts {
        for b in a + 1..verts {
            for c in b + 1..verts {
                let e = |x: u32, y: u32| adj[(x * verts + y) as usize];
                if e(a, b) && e(b, c) && e(a, c) {
                    tris.push([a, b, c]);
                }
            }
        }
    }
    tris.truncate(16);
    let m = mesh(&tris);
    let w: Vec<f32> = (0..m.facets.len())
        .map(|_| (next() % 2001) as f32 / 1000.0 - 0.7)
        .collect();
    let mask: Vec<u8> = (0..m.edges.len())
        .map(|_| {
            if border && next() % 3 == 0 {
                MASK_BORDER
            } else {
                MASK_CLOSED
            }
        })
        .collect();
    let mut pens: Vec<f32> = (0..m.edges.len())
        .map(|_| (next() % 100) as f32 / 200.0)
        .collect();
    let (mut rows, mut mask, mut ne) = (m.facets, mask, m.edges.len());
    if groups {
        for e in 0..m.edges.len() as u32 {
            let mut on: Vec<usize> = (0..rows.len())
                .filter(|&f| rows[f][..3].contains(&e))
                .collect();
            for i in (1..on.len()).rev() {
                on.swap(i, next() as usize % (i + 1));
            }
            let mut rest = &on[..];
            while !rest.is_empty() {
                let n = (1 + next() as usize % 3).min(rest.len());
                if n >= 2 {
                    for &f in &rest[..n] {
                        add_to(&mut rows, f, ne as u32);
                    }
                    mask.push(MASK_AT_MOST_ONE);
                    pens.push(if next() % 2 == 0 {
                        0.0
                    } else {
                        (next() % 100) as f32 / 400.0
                    });
                    ne += 1;
                }
                rest = &rest[n..];
            }
        }
    }
    (rows, w, ne, mask, pens)
}

/// Solve 300 random instances (with random at-most-one groups when `groups`),
/// check each is proved optimal at the brute-force optimum, and return how many
/// have a group.
fn check_against_brute_force(groups: bool) -> u32 {
    let mut grouped = 0;
    for seed in 0..300u64 {
        let (fe, w, ne, mask, pens) =
            random_instance(seed, 7 + (seed % 4) as u32, 60, seed % 2 == 1, groups);
        grouped += (mask.contains(&MASK_AT_MOST_ONE)) as u32;
        let input = SelectInput {
            edge_mask: Some(&mask),
            edge_penalty: Some(&pens),
            ..SelectInput::new(&fe, &w, ne, PROOF_NODE_LIMIT)
        };
        let (_, st) = run(&input);
        let exact = brute(&input);
        assert!(st.optimal, "seed {seed}");
        assert!(
            (st.objective - exact).abs() < 1e-5,
            "seed {seed}: {} vs {exact}",
            st.objective
        );
    }
    grouped
}

#[test]
fn matches_brute_force_on_small_random_instances() {
    check_against_brute_force(false);
}

#[test]
fn matches_brute_force_with_random_at_most_one_groups() {
    let grouped = check_against_brute_force(true);
    assert!(grouped >= 200, "only {grouped} instances have a group");
}

#[test]
fn node_limits_still_give_feasible_selections_with_honest_bounds() {
    for seed in 0..120u64 {
        let (fe, w, ne, mask, pens) = random_instance(seed, 9, 70, seed % 2 == 1, seed >= 60);
        let exact = {
            let input = SelectInput {
                edge_mask: Some(&mask),
                edge_penalty: Some(&pens),
                ..SelectInput::new(&fe, &w, ne, PROOF_NODE_LIMIT)
            };
            brute(&input)
        };
        for limit in [0, 1, 2] {
            let input = SelectInput {
                edge_mask: Some(&mask),
                edge_penalty: Some(&pens),
                ..SelectInput::new(&fe, &w, ne, limit)
            };
            let (_, st) = run(&input);
            assert!(st.nodes <= limit);
            assert!(
                st.upper_bound >= exact - 1e-6,
                "seed {seed}: ub {} < {exact}",
                st.upper_bound
            );
            assert!(st.objective <= exact + 1e-6);
            assert!(st.gap >= 0.0);
            if st.optimal {
                assert!((st.objective - exact).abs() < 1e-5);
            }
        }
    }
}

#[test]
fn extreme_and_zero_scores_stay_exact() {
    let (m, _) = tetra_and_tent();
    let sets: [[f32; 7]; 4] = [
        [0.0; 7],
        [1e30, 1e30, 1e30, 1e30, -1e30, 2e30, 1e30],
        [1e-30, 1e-30, -1e-30, 1e-30, 3e-30, 1e-30, 1e-30],
        [
            f32::MAX,
            f32::MAX,
            f32::MAX,
            f32::MAX,
            f32::MIN,
            f32::MAX,
            f32::MAX,
        ],
    ];
    for w in &sets {
        let input = SelectInput::new(&m.facets, w, m.edges.len(), PROOF_NODE_LIMIT);
        let (_, st) = run(&input);
        let exact = brute(&input);
        assert!(st.optimal, "{w:?}");
        assert!(
            (st.objective - exact).abs() <= 1e-6 * exact.abs().max(1e-30),
            "{w:?}: {} vs {exact}",
            st.objective
        );
    }
}

#[test]
fn cancellation_is_an_error() {
    let (m, w) = tetra_and_tent();
    let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
    let mut buf = vec![MaybeUninit::<u8>::uninit(); 1 << 16];
    let arena = Arena::new(&mut buf);
    let r = try_select_in(&arena, &input, &mut |_, _| false);
    assert_eq!(r.unwrap_err(), Error::Cancelled);
    let mut calls = 0;
    let r = try_select_in(&arena, &input, &mut |_, _| {
        calls += 1;
        calls < 2
    });
    assert_eq!(r.unwrap_err(), Error::Cancelled);
}

#[test]
fn hostile_inputs_are_errors_not_panics() {
    let fe = [widen([0u32, 1, 2])];
    let w = [1.0f32];
    let is_bad = |e: Error| matches!(e, Error::BadParameter { .. });
    assert!(is_bad(err(&SelectInput::new(&fe, &w, 2, PROOF_NODE_LIMIT))));
    assert!(is_bad(err(&SelectInput::new(
        &[widen([0, 1, 1])],
        &w,
        3,
        PROOF_NODE_LIMIT
    ))));
    assert!(is_bad(err(&SelectInput::new(
        &[widen([u32::MAX, 1, 2])],
        &w,
        3,
        PROOF_NODE_LIMIT
    ))));
    // Groups: out of range, repeated, or too few slots used.
    assert!(is_bad(err(&SelectInput::new(
        &[join([0, 1, 2], [0, 9, UNUSED], 3)],
        &w,
        4,
        PROOF_NODE_LIMIT
    ))));
    assert!(is_bad(err(&SelectInput::new(
        &[[0, 1, 2, 3, UNUSED, 1]],
        &w,
        4,
        PROOF_NODE_LIMIT
    ))));
    assert!(is_bad(err(&SelectInput::new(
        &[[UNUSED, 1, UNUSED, 3, UNUSED, UNUSED]],
        &w,
        4,
        PROOF_NODE_LIMIT
    ))));
    assert!(is_bad(err(&SelectInput::new(
        &[join([0, 1, 2], [0, 0, 0], UNUSED - 1)],
        &w,
        4,
        PROOF_NODE_LIMIT
    ))));
    // Slots may be used in any order.
    let (sel, st) = run(&SelectInput::new(
        &[[UNUSED, 2, 3, UNUSED, 0, 1]],
        &w,
        4,
        PROOF_NODE_LIMIT,
    ));
    assert!(sel == [false] && st.optimal);
    assert!(is_bad(err(&SelectInput::new(
        &fe,
        &[f32::NAN],
        3,
        PROOF_NODE_LIMIT
    ))));
    assert!(is_bad(err(&SelectInput::new(
        &fe,
        &[f32::INFINITY],
        3,
        PROOF_NODE_LIMIT
    ))));
    assert!(is_bad(err(&SelectInput::new(
        &fe,
        &[],
        3,
        PROOF_NODE_LIMIT
    ))));
    let masks = [[0b101u8, 0b101, 0b100], [0b101, 0b1101, 0b101]];
    for m in &masks {
        let input = SelectInput {
            edge_mask: Some(m),
            ..SelectInput::new(&fe, &w, 3, PROOF_NODE_LIMIT)
        };
        assert!(is_bad(err(&input)));
    }
    let short = [0b101u8; 2];
    assert!(is_bad(err(&SelectInput {
        edge_mask: Some(&short),
        ..SelectInput::new(&fe, &w, 3, PROOF_NODE_LIMIT)
    })));
    for p in [[0.0f32, -1.0, 0.0], [0.0, f32::NAN, 0.0]] {
        assert!(is_bad(err(&SelectInput {
            edge_penalty: Some(&p),
            ..SelectInput::new(&fe, &w, 3, PROOF_NODE_LIMIT)
        })));
    }
    // Empty problems are fine.
    let (sel, st) = run(&SelectInput::new(&[], &[], 0, PROOF_NODE_LIMIT));
    assert!(sel.is_empty() && st.optimal && st.objective == 0.0);
    let (sel, st) = run(&SelectInput::new(&[], &[], 5, PROOF_NODE_LIMIT));
    assert!(sel.is_empty() && st.optimal);
}

#[test]
fn a_small_arena_is_exhausted_not_a_panic() {
    let (m, w) = tetra_and_tent();
    let input = SelectInput::new(&m.facets, &w, m.edges.len(), PROOF_NODE_LIMIT);
    let need = select_bytes_for(&input);
    for n in [0, 7, need / 2, need / 4 * 3] {
        let mut buf = vec![MaybeUninit::<u8>::uninit(); n];
        let arena = Arena::new(&mut buf);
        let e = try_select_in(&arena, &input, &mut |_, _| true).unwrap_err();
        assert!(matches!(e, Error::Exhausted(_)), "{n}: {e:?}");
    }
}

/// The candidate facets of a `side` x `side` grid of quads, each quad with
/// both diagonals (four triangles, two on each), and scores that vary.
fn crossed_grid(side: u32) -> (Mesh, Vec<f32>) {
    let at = |i: u32, j: u32| i * (side + 1) + j;
    let mut tris = Vec::new();
    for i in 0..side {
        for j in 0..side {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            tris.extend([[a, b, c], [a, c, d], [a, b, d], [b, c, d]]);
        }
    }
    let m = mesh(&tris);
    let scores = (0..m.facets.len())
        .map(|f| ((f * 7919) % 1000) as f32 / 500.0 - 0.9)
        .collect();
    (m, scores)
}

#[test]
fn the_selection_does_not_depend_on_the_order_its_tasks_run_in() {
    let (m, scores) = crossed_grid(12);
    let input = SelectInput::new(&m.facets, &scores, m.edges.len(), 200);
    let (forwards, stats) = run(&input);
    let mut buf = vec![MaybeUninit::<u8>::uninit(); select_bytes_for(&input)];
    let arena = Arena::new(&mut buf);
    let (backwards, again) = try_select_with_in(&arena, &input, &mut Backwards).unwrap();
    assert_eq!(forwards, backwards.to_vec());
    assert_eq!(stats.objective.to_bits(), again.objective.to_bits());
    assert_eq!(stats.upper_bound.to_bits(), again.upper_bound.to_bits());
}

/// Runs the tasks last first and counts the rounds of tasks.
struct CountingBackwards(core::cell::Cell<u32>);

impl crate::progress::Progress for CountingBackwards {
    fn report(&mut self, _: crate::progress::Stage, _: u64, _: u64) -> crate::progress::Flow {
        crate::progress::Flow::Continue
    }

    fn run(&self, tasks: &mut [&mut dyn crate::parallel::Task]) {
        self.0.set(self.0.get() + 1);
        crate::progress::Progress::run(&Backwards, tasks);
    }
}

#[test]
fn a_refresh_without_the_losses_leaves_the_picks_terms_and_top_shares_of_a_full_one() {
    // Side 3: fewer edges than a parallel refresh takes (one edge after
    // another); side 16: in tasks, run backwards.
    for side in [3, 16] {
        let (m, scores) = crossed_grid(side);
        let n = m.facets.len();
        let input = SelectInput::new(&m.facets, &scores, m.edges.len(), 200);
        let facets: Vec<u32> = (0..n as u32).collect();
        let edges: Vec<u32> = (0..m.edges.len() as u32).collect();
        let mut buf = vec![MaybeUninit::<u8>::uninit(); select_bytes_for(&input)];
        let arena = Arena::new(&mut buf);
        let mut incumbent = vec![false; n];
        let mut solver = solver::Solver::try_new_in(&arena, &input, &mut incumbent).unwrap();
        solver.open_problem(&facets, &edges, &Backwards);
        let mut disagreeing = 0;
        for temperature in [0.3, 0.1, 0.03] {
            for &f in &facets {
                solver.resplit_smoothed(f as usize, temperature);
            }
            let mut caches = Vec::new();
            for losses in [bound::Losses::Stale, bound::Losses::Fresh] {
                // Garbage in the picks first: a refresh must set every bit.
                solver.picked_by.fill(0b10_1010);
                let counted = solver.refresh_all(&facets, &edges, losses, &Backwards);
                // In tasks, the refresh counts the facets whose edges
                // disagree as it sets their picks.
                let want = (side == 16).then(|| solver.disagreements(&facets));
                assert_eq!(counted, want, "side {side}, {losses:?}");
                caches.push((
                    solver.picked_by.to_vec(),
                    solver
                        .edge_terms
                        .iter()
                        .map(|t| t.to_bits())
                        .collect::<Vec<_>>(),
                    solver
                        .top_shares
                        .iter()
                        .flatten()
                        .map(|t| t.to_bits())
                        .collect::<Vec<_>>(),
                    solver.top_incidences.to_vec(),
                ));
            }
            assert!(
                caches[0] == caches[1],
                "side {side}, temperature {temperature}"
            );
            disagreeing += solver.disagreements(&facets);
        }
        // The picks compared were not all alike.
        assert!(disagreeing > 0, "side {side}: every edge agreed");
    }
}

#[test]
fn a_sweep_by_levels_leaves_the_shares_of_a_sweep_facet_after_facet() {
    // The crossed grid's facets in a scrambled order (a grid order would chain
    // every facet to the one before: one level a facet).
    let (m, scores) = crossed_grid(16);
    let n = m.facets.len();
    let perm: Vec<usize> = (0..n).map(|i| (i * 385) % n).collect();
    let facet_edges: Vec<_> = perm.iter().map(|&i| m.facets[i]).collect();
    let scores: Vec<f32> = perm.iter().map(|&i| scores[i]).collect();
    let input = SelectInput::new(&facet_edges, &scores, m.edges.len(), 200);
    let facets: Vec<u32> = (0..n as u32).collect();
    let edges: Vec<u32> = (0..m.edges.len() as u32).collect();
    // The shares after each sweep, and the rounds of tasks run.
    let sweeps = |by_levels: bool| -> (Vec<Vec<u64>>, u32) {
        let mut buf = vec![MaybeUninit::<u8>::uninit(); select_bytes_for(&input)];
        let arena = Arena::new(&mut buf);
        let mut incumbent = vec![false; n];
        let mut solver = solver::Solver::try_new_in(&arena, &input, &mut incumbent).unwrap();
        let hooks = CountingBackwards(core::cell::Cell::new(0));
        solver.open_problem(&facets, &edges, &hooks);
        let (mut level, mut order, mut start) = (vec![0u32; n], vec![0u32; n], vec![0u32; n]);
        let mut last = vec![0u32; edges.len()];
        let mut levels = bound::Levels {
            level: &mut level,
            order: &mut order,
            start: &mut start,
            last: &mut last,
            plan: bound::Plan::Unplanned,
        };
        let before = hooks.0.get();
        let mut after = Vec::new();
        for temperature in [0.2, 0.1, 0.05, 0.02] {
            if by_levels {
                assert!(solver.sweep_in_levels(&facets, temperature, &mut levels, &hooks));
                // Planned by the first sweep, kept for the next.
                assert!(matches!(levels.plan, bound::Plan::Levels(_)));
            } else {
                for &f in &facets {
                    solver.resplit_smoothed(f as usize, temperature);
                }
            }
            after.push(solver.shares.iter().map(|s| s.to_bits()).collect());
            solver.refresh_all(&facets, &edges, bound::Losses::Fresh, &Silent);
        }
        (after, hooks.0.get() - before)
    };
    let (levelled, rounds) = sweeps(true);
    let (serial, none) = sweeps(false);
    assert_eq!(none, 0);
    assert!(
        rounds >= 4,
        "{rounds} rounds of tasks: no level ran in parallel"
    );
    assert_eq!(levelled, serial);
}

/// The crossed grid with pseudo-random scores from `seed`, and a third of
/// its edges allowed to end on one facet at a random penalty.
fn bordered_grid(side: u32, seed: u64) -> (Mesh, Vec<f32>, Vec<u8>, Vec<f32>) {
    let (m, _) = crossed_grid(side);
    let mut s = seed;
    let mut next = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 33) as u32
    };
    let scores = (0..m.facets.len())
        .map(|_| (next() % 2001) as f32 / 1000.0 - 0.9)
        .collect();
    let mask = (0..m.edges.len())
        .map(|_| {
            if next() % 3 == 0 {
                MASK_BORDER
            } else {
                MASK_CLOSED
            }
        })
        .collect();
    let pens = (0..m.edges.len())
        .map(|_| (next() % 100) as f32 / 200.0)
        .collect();
    (m, scores, mask, pens)
}

#[test]
fn balls_searched_in_groups_beside_a_lane_give_the_selection_of_balls_in_turn() {
    use core::sync::atomic::Ordering::Relaxed;
    let counts = || incumbent::LANE_COUNTS.each_ref().map(|c| c.load(Relaxed));
    let start = counts();
    let compare = |input: &SelectInput<'_>| {
        let bytes = 2 * select_bytes_for(input) + 64 * input.facet_edges.len();
        let solve = |progress: &mut dyn crate::progress::Progress| {
            let mut buf = vec![MaybeUninit::<u8>::uninit(); bytes];
            let arena = Arena::new(&mut buf);
            let (sel, st) = try_select_with_in(&arena, input, progress).unwrap();
            let bits = [st.objective, st.upper_bound, st.gap].map(f64::to_bits);
            (sel.to_vec(), bits, st.nodes, arena.peak())
        };
        let (one, one_bits, one_nodes, one_peak) = solve(&mut Silent);
        for backwards in [false, true] {
            let (two, two_bits, two_nodes, two_peak) = solve(&mut Claimed {
                threads: 2,
                backwards,
                full_rounds: Default::default(),
            });
            assert_eq!(one, two, "limit {}", input.node_limit);
            assert_eq!((one_bits, one_nodes), (two_bits, two_nodes));
            assert!(two_peak > one_peak, "no lane was taken");
        }
    };
    // The crossed grid's facets scrambled (`shift` 0: in grid order).
    for (side, shift, limit) in [(12, 0, 200), (14, 385, 200), (12, 101, 400)] {
        let (m, scores) = crossed_grid(side);
        let n = m.facets.len();
        let order = |i: usize| if shift == 0 { i } else { (i * shift) % n };
        let facet_edges: Vec<_> = (0..n).map(|i| m.facets[order(i)]).collect();
        let scores: Vec<f32> = (0..n).map(|i| scores[order(i)]).collect();
        compare(&SelectInput::new(
            &facet_edges,
            &scores,
            m.edges.len(),
            limit,
        ));
    }
    // Node limits that end the search within a group of balls, where the
    // nodes of the balls before one decide whether its result counts.
    let (m, scores, mask, pens) = bordered_grid(12, 12348);
    for limit in 20..=40 {
        compare(&SelectInput {
            edge_mask: Some(&mask),
            edge_penalty: Some(&pens),
            ..SelectInput::new(&m.facets, &scores, m.edges.len(), limit)
        });
    }
    // Every way of the groups ran: balls kept beside the first, balls
    // searched again in turn, next balls refused for an edge in common.
    let end = counts();
    for (i, way) in ["kept", "searched again", "refused"].iter().enumerate() {
        assert!(end[i] > start[i], "no pair {way}: {start:?} to {end:?}");
    }
}

#[test]
fn re_splits_stop_at_the_first_look_that_finds_the_node_pruned() {
    let (m, scores) = crossed_grid(16);
    let n = m.facets.len();
    let input = SelectInput::new(&m.facets, &scores, m.edges.len(), 200);
    let facets: Vec<u32> = (0..n as u32).collect();
    let edges: Vec<u32> = (0..m.edges.len() as u32).collect();
    // Every facet queued once, then re-split (at most 100 000 of them) with
    // a bar to prune at: the shares' bits, the bound after, and how many
    // facets' shares moved.
    let resplit = |bar: Option<f64>| -> (Vec<u64>, f64, f64, usize) {
        let mut buf = vec![MaybeUninit::<u8>::uninit(); select_bytes_for(&input)];
        let arena = Arena::new(&mut buf);
        let mut incumbent = vec![false; n];
        let mut solver = solver::Solver::try_new_in(&arena, &input, &mut incumbent).unwrap();
        solver.open_problem(&facets, &edges, &Silent);
        let start = solver.bound(&edges);
        let before = solver.shares.to_vec();
        for &f in &facets {
            solver.facet_queue.push(f as usize);
        }
        solver.resplit_queued_until(100_000, bar.map(|b| (&edges[..], b)));
        assert!(solver.facet_queue.pop().is_none(), "queue left");
        let moved = facets
            .iter()
            .filter(|&&f| {
                solver
                    .facet_incidences(f as usize)
                    .any(|x| solver.shares[x] != before[x])
            })
            .count();
        let bits = solver.shares.iter().map(|s| s.to_bits()).collect();
        (bits, start, solver.bound(&edges), moved)
    };
    let (all, start, end, moved) = resplit(None);
    assert!(end < start, "the re-splits did not lower the bound");
    assert!(
        moved > 2 * bound::RESPLITS_PER_LOOK,
        "only {moved} facets moved"
    );
    // Below the bound at the end: no look prunes, the same shares.
    assert_eq!(resplit(Some(end - 1.0)).0, all);
    // Above the bound at the start: the first look prunes.
    let (_, _, first, few) = resplit(Some(start + 1.0));
    assert!(few <= bound::RESPLITS_PER_LOOK, "{few} facets moved");
    assert!(first <= start + 1.0);
    // Halfway down: stops at a look with the bound at the bar or under it,
    // before the end.
    let bar = (start + end) / 2.0;
    let (halfway, _, stopped, _) = resplit(Some(bar));
    assert!(
        stopped <= bar && stopped > end,
        "{stopped} against {bar}, {end}"
    );
    assert_ne!(halfway, all);
}
