use super::*;
use crate::progress::Silent;
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
    orient(&arena, &mut all[..nf], v, clash, Seam::Flood).unwrap();
    let filled = fill_holes(
        &arena,
        all,
        nf,
        v,
        &[],
        &mut [],
        &mut [],
        max_hole,
        1e-6,
        &Silent,
    )
    .unwrap();
    let total = nf + filled.faces;
    clash.fill(false);
    let (_, bad) = orient(&arena, &mut all[..total], v, clash, Seam::Flood).unwrap();
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

/// A 6 x 6 grid of points, spacing 0.1, at height `z` and offset `x0`.
fn patch(x0: f32, z: f32) -> Vec<V3> {
    (0..36)
        .map(|i| [x0 + (i % 6) as f32 * 0.1, (i / 6) as f32 * 0.1, z])
        .collect()
}

#[test]
fn clusters_are_in_one_piece_of_the_data_only_when_their_points_are_linked() {
    use crate::clustering::knn::try_neighbours_in;
    use crate::meshing::candidates::try_pieces_in;
    use crate::progress::Silent;
    // Two patches 1 apart; cluster 0 and 1 split the first, cluster 2 is the
    // second, cluster 3 has no points.
    let mut points = patch(0.0, 0.0);
    points.extend(patch(2.0, 0.0));
    let labels: Vec<u32> = (0..72).map(|i| [0, 1, 2, 2][i / 18]).collect();
    let mut buf = vec![MaybeUninit::uninit(); 1 << 20];
    let arena = Arena::new(&mut buf);
    let nb = try_neighbours_in(&arena, &points, 8, &mut Silent).unwrap();
    let piece = try_pieces_in(&arena, &nb, &labels, &[0, 1, 2, 3], &Silent).unwrap();
    assert_eq!(piece, &[0, 0, 2, 3]);
    // A merged cluster lies in its representative's piece.
    let piece = try_pieces_in(&arena, &nb, &labels, &[0, 1, 2, 2], &Silent).unwrap();
    assert_eq!(piece, &[0, 0, 2, 2]);
}

/// The pieces are the same whether the points are cut into parts (one a
/// thread) or not: five patches far apart, twelve clusters in strips across
/// each, one cluster merged into a cluster of another patch (joining the
/// two), one merged cluster with no points, one without points alone.
#[test]
fn pieces_are_the_same_for_every_thread_count() {
    use crate::clustering::knn::try_neighbours_in;
    use crate::meshing::candidates::try_pieces_in;
    use crate::progress::{Claimed, Silent};
    let (cols, rows) = (60usize, 120usize);
    let mut points = Vec::new();
    let mut labels = Vec::new();
    for patch in 0..5usize {
        for i in 0..cols * rows {
            let (x, y) = (i % cols, i / cols);
            points.push([patch as f32 * 100.0 + x as f32 * 0.1, y as f32 * 0.1, 0.0]);
            labels.push((patch * 12 + y / 10) as u32);
        }
    }
    let mut rep: Vec<u32> = (0..62).collect();
    rep[30] = 7;
    rep[61] = 5;
    let mut want = vec![0u32; 62];
    for (c, w) in want.iter_mut().enumerate() {
        *w = match c {
            0..=11 | 24..=35 | 61 => 0,
            60 => 60,
            _ => (c / 12 * 12) as u32,
        };
    }
    let mut buf = vec![MaybeUninit::uninit(); 8 << 20];
    let arena = Arena::new(&mut buf);
    let nb = try_neighbours_in(&arena, &points, 8, &mut Silent).unwrap();
    let piece = try_pieces_in(&arena, &nb, &labels, &rep, &Silent).unwrap();
    assert_eq!(piece, &want[..]);
    for threads in [2, 3, 8] {
        let piece =
            try_pieces_in(&arena, &nb, &labels, &rep, &Claimed::backwards(threads)).unwrap();
        assert_eq!(piece, &want[..], "{threads} threads");
    }
}

#[test]
fn a_skipped_cluster_goes_into_the_mesh_only_where_joins_allows() {
    // The octahedron and a skipped cluster 6 just above one of its faces:
    // inserted when allowed, left out (faces untouched) when `joins` refuses
    // faces with it.
    let (mut v, f) = octahedron();
    v.push([0.3, 0.3, 0.5]);
    let list: Vec<u32> = (0..7).collect();
    let members = Members {
        start: &[0, 1, 2, 3, 4, 5, 6, 7],
        list: &list,
    };
    let run = |joins: &dyn Fn(&[[u32; 3]]) -> bool| {
        let mut buf = vec![MaybeUninit::uninit(); 1 << 16];
        let arena = Arena::new(&mut buf);
        let mut faces = f.clone();
        faces.extend([[0; 3]; 4]);
        let (nf, done) = insert_skipped(
            &arena,
            &mut faces,
            f.len(),
            &v,
            &members,
            1e-6,
            joins,
            &Silent,
        )
        .unwrap();
        (faces[..nf].to_vec(), done.clusters, done.left_out)
    };
    let (faces, inserted, left) = run(&|_| true);
    assert_eq!((inserted, left), (1, 0));
    assert!(faces.iter().any(|t| t.contains(&6)));
    assert!(closed_and_consistent(&faces));
    let (faces, inserted, left) = run(&|fs| fs.iter().all(|t| !t.contains(&6)));
    assert_eq!((inserted, left), (0, 1));
    assert_eq!(faces, f);
}

/// A closed cylinder along x from `x0` to `x1`, radius 0.3, `sides` around,
/// `rings` segments long, its ends closed by fans around their centres;
/// appended to `v` and `f`.
fn capped_cylinder(
    x0: f32,
    x1: f32,
    rings: u32,
    sides: u32,
    v: &mut Vec<V3>,
    f: &mut Vec<[u32; 3]>,
) {
    let base = v.len() as u32;
    for r in 0..=rings {
        let x = x0 + (x1 - x0) * r as f32 / rings as f32;
        for s in 0..sides {
            let a = core::f32::consts::TAU * s as f32 / sides as f32;
            v.push([x, 0.3 * libm::cosf(a), 0.3 * libm::sinf(a)]);
        }
    }
    let at = |r: u32, s: u32| base + r * sides + s % sides;
    for r in 0..rings {
        for s in 0..sides {
            f.push([at(r, s), at(r + 1, s), at(r + 1, s + 1)]);
            f.push([at(r, s), at(r + 1, s + 1), at(r, s + 1)]);
        }
    }
    let (c0, c1) = (v.len() as u32, v.len() as u32 + 1);
    v.push([x0, 0.0, 0.0]);
    v.push([x1, 0.0, 0.0]);
    for s in 0..sides {
        f.push([c0, at(0, s + 1), at(0, s)]);
        f.push([c1, at(rings, s), at(rings, s + 1)]);
    }
}

#[test]
fn a_closed_piece_of_any_size_beside_the_largest_is_joined_by_a_tube_where_joins_allows() {
    // A long cylinder and, past its end, a short one of 24 faces (too large
    // for a bubble): their facing ends get a tube, and the two are one closed,
    // consistently oriented surface; when `joins` refuses, nothing changes.
    let (mut v, mut f) = (Vec::new(), Vec::new());
    capped_cylinder(0.0, 2.0, 4, 6, &mut v, &mut f);
    let short = f.len();
    capped_cylinder(2.2, 2.7, 1, 6, &mut v, &mut f);
    assert_eq!(f.len() - short, 24);
    let run = |joins: &dyn Fn(&[[u32; 3]]) -> bool| {
        let mut buf = vec![MaybeUninit::uninit(); 1 << 18];
        let arena = Arena::new(&mut buf);
        let mut faces = f.clone();
        let clash = arena.try_alloc_slice::<bool>(f.len(), false).unwrap();
        orient(&arena, &mut faces, &v, clash, Seam::Flood).unwrap();
        let oriented = faces.clone();
        let nf = faces.len();
        faces.extend([[0; 3]; 8]);
        let cap = faces.len();
        let (nf, tubes) =
            join_pieces(&arena, &mut faces, nf, cap, &v, 1e-6, joins, &Silent).unwrap();
        let (_, bubbles, pieces) = drop_bubbles(&arena, &mut faces, nf).unwrap();
        (oriented, faces[..nf].to_vec(), tubes, bubbles, pieces)
    };
    let (_, faces, tubes, bubbles, pieces) = run(&|_| true);
    assert_eq!((tubes, bubbles, pieces), (1, 0, 1));
    assert_eq!(faces.len(), f.len() + 4);
    assert!(closed_and_consistent(&faces));
    let (oriented, faces, tubes, _, pieces) = run(&|_| false);
    assert_eq!((tubes, pieces), (0, 2));
    assert_eq!(faces, oriented);
}

/// A Möbius band of `n` columns: `wide` rows of quads, but only one in the
/// three middle columns, whose faces come first. Returns the vertices, the
/// faces and how many faces the narrow part has.
fn pinched_moebius(n: usize, wide: usize) -> (Vec<V3>, Vec<[u32; 3]>, usize) {
    let mut v = Vec::new();
    for i in 0..n {
        let a = core::f32::consts::TAU * i as f32 / n as f32;
        for j in 0..=wide {
            let t = j as f32 / wide as f32 - 0.5;
            let r = 1.0 + t * libm::cosf(a / 2.0);
            v.push([
                r * libm::cosf(a),
                r * libm::sinf(a),
                t * libm::sinf(a / 2.0),
            ]);
        }
    }
    // Past the last column the band comes back to the first turned over.
    let at = |i: usize, j: usize| {
        if i == n {
            (wide - j) as u32
        } else {
            (i * (wide + 1) + j) as u32
        }
    };
    let narrow = |i: usize| (n / 2 - 1..n / 2 + 2).contains(&i);
    let (mut first, mut rest) = (Vec::new(), Vec::new());
    for i in 0..n {
        let rows = if narrow(i) { 1 } else { wide };
        for j in 0..rows {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            let into = if narrow(i) { &mut first } else { &mut rest };
            into.extend([[a, b, c], [a, c, d]]);
        }
    }
    let k = first.len();
    first.extend(rest);
    (v, first, k)
}

#[test]
fn the_shortest_seam_crosses_a_moebius_band_where_it_is_narrowest() {
    // Flooded from a face of the narrow part, the fronts meet across the
    // wide part (a seam of several links); the shortest seam is one link,
    // across the narrow part or where it meets the wide part.
    let (v, f, narrow) = pinched_moebius(16, 4);
    let run = |seam: Seam| {
        let mut buf = vec![MaybeUninit::uninit(); 1 << 16];
        let arena = Arena::new(&mut buf);
        let mut faces = f.clone();
        let clash = arena.try_alloc_slice::<bool>(f.len(), false).unwrap();
        let (components, bad) = orient(&arena, &mut faces, &v, clash, seam).unwrap();
        assert_eq!((components, bad), (1, 1));
        (0..f.len()).filter(|&i| clash[i]).collect::<Vec<_>>()
    };
    let flood = run(Seam::Flood);
    assert!(
        flood.len() > 4 && flood.iter().all(|&i| i >= narrow),
        "{flood:?}"
    );
    let shortest = run(Seam::Shortest);
    assert_eq!(shortest.len(), 2, "{shortest:?}");
    assert!(shortest.iter().any(|&i| i < narrow), "{shortest:?}");
}

#[test]
fn densifying_adds_at_most_the_fraction_of_the_vertices_rounded_up() {
    use super::densify_budget;
    assert_eq!(densify_budget(0.1, 260), 26);
    assert_eq!(densify_budget(0.1, 261), 27);
    assert_eq!(densify_budget(0.1, 1_000), 100);
    assert_eq!(densify_budget(0.1, 7), 1);
    assert_eq!(densify_budget(0.0, 260), 0);
    assert_eq!(densify_budget(1.0, 260), 260);
    for nv in 1..5_000 {
        let b = densify_budget(0.1, nv);
        assert!(b * 10 >= nv && b * 10 < nv + 10, "{nv}: {b}");
    }
}

/// The edge table is the whole table sorted: random faces over few vertices
/// (so some share edges, repeat an index or are copies), a fan of 40 faces
/// around one vertex (80 edges with it as their lower vertex), and none.
#[test]
fn the_edge_table_is_every_edge_sorted() {
    let mut rng = crate::rng::Rng::new(7);
    let random: Vec<[u32; 3]> = (0..500)
        .map(|_| [rng.below(60), rng.below(60), rng.below(60)])
        .collect();
    let fan: Vec<[u32; 3]> = (0..40).map(|i| [7, 8 + (i + 1) % 40, 8 + i]).collect();
    for faces in [random, fan, Vec::new()] {
        let mut want: Vec<(u64, u32)> = faces
            .iter()
            .enumerate()
            .flat_map(|(f, t)| (0..3).map(move |k| (key(t[k], t[(k + 1) % 3]), f as u32)))
            .collect();
        want.sort_unstable();
        let mut buf = vec![MaybeUninit::uninit(); 1 << 16];
        let arena = Arena::new(&mut buf);
        let got = arena.scratch(|s| edge_table(s, &faces).map(|t| t.to_vec()));
        assert_eq!(got.unwrap(), want);
    }
}

#[test]
fn untangled_says_the_same_on_one_thread_and_in_tasks() {
    use crate::progress::Claimed;
    // A 40 x 40 grid of squares in z = 0 (3,200 faces: scanned in tasks),
    // and triangles through it, above it, and on it sharing an edge.
    let side = 41u32;
    let (mut v, faces) = crate::meshing::fit::tests::grid(side);
    assert!(faces.len() >= repair::PARALLEL_SCAN);
    let base = v.len() as u32;
    let mut cases = Vec::new();
    for (i, &(x, y)) in [(3.3f32, 7.6f32), (20.5, 20.5), (39.2, 0.4), (10.0, 10.0)]
        .iter()
        .enumerate()
    {
        let k = base + 3 * i as u32;
        // Upright through the plane: crosses the faces there.
        v.extend([[x, y, -1.0], [x + 0.3, y, 1.0], [x, y + 0.3, 1.0]]);
        cases.push(([k, k + 1, k + 2], false));
    }
    let k = v.len() as u32;
    v.extend([[5.0, 5.0, 1.0], [6.0, 5.0, 1.0], [5.0, 6.0, 2.0]]);
    cases.push(([k, k + 1, k + 2], true));
    // On the grid's first face's edge, folded flat onto it.
    let k = v.len() as u32;
    v.push([0.5, -0.5, 0.0]);
    cases.push(([1, 0, k], true));
    cases.push(([0, 1, side + 1], false));
    for (new, clear) in cases {
        let one = repair::untangled(&faces, &[], &[new], &v, &Silent);
        let tasks = repair::untangled(&faces, &[], &[new], &v, &Claimed::backwards(2));
        assert_eq!(one, clear, "{new:?}");
        assert_eq!(tasks, clear, "{new:?} in tasks");
    }
}
