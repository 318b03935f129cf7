//! One neighbour search: the k-NN table cleaning searched, given to
//! `reconstruct_with_rows`, gives the mesh `reconstruct` makes by searching
//! again; a table that is not one for the points is a typed error.

use std::mem::MaybeUninit;
use vsaqem_core::sample::{fill, Shape};
use vsaqem_core::{
    arena_bytes, clean_bytes, clean_with_rows, reconstruct, reconstruct_with_rows, Arena, Error,
    Params, Rows, Silent, V3,
};

fn shape(s: Shape, n: usize, noise: f64) -> Vec<V3> {
    let mut p = vec![[0.0; 3]; n];
    fill(s, 3, noise, &mut p);
    p
}

/// The cleaning pass's table, with every point kept.
fn cleaned_rows(points: &[V3], params: &Params) -> (Vec<u32>, u32) {
    let mut buf = vec![MaybeUninit::uninit(); clean_bytes(points.len(), params)];
    let arena = Arena::new(&mut buf);
    let mut keep = vec![false; points.len()];
    let mut knn = vec![0u32; points.len() * params.k];
    let (stats, scans) = clean_with_rows(
        &arena,
        points,
        params,
        &mut keep,
        Some(&mut knn),
        &mut Silent,
    )
    .unwrap();
    assert_eq!(stats.kept, stats.points, "these shapes lose no point");
    (
        knn,
        scans.expect("the fragment filter is on by default, so a table was searched"),
    )
}

fn mesh(
    points: &[V3],
    rows: Option<&Rows>,
    params: &Params,
) -> Result<(Vec<V3>, Vec<[u32; 3]>), Error> {
    let mut buf = vec![MaybeUninit::uninit(); arena_bytes(points.len(), params)];
    let arena = Arena::new(&mut buf);
    let out = match rows {
        Some(r) => reconstruct_with_rows(&arena, points, None, Some(r), params, &mut Silent)?,
        None => reconstruct(&arena, points, None, params, &mut Silent)?,
    };
    Ok((out.mesh.vertices.to_vec(), out.mesh.triangles.to_vec()))
}

#[test]
fn the_cleaning_table_gives_the_mesh_a_fresh_search_gives() {
    let params = Params {
        clusters: 150,
        ..Params::default()
    };
    for (s, noise) in [
        (Shape::Torus, 0.0),
        (Shape::Sphere, 0.003),
        (Shape::HoledSphere, 0.0),
    ] {
        let points = shape(s, 5000, noise);
        let (knn, linear_scans) = cleaned_rows(&points, &params);
        let rows = Rows {
            knn: &knn,
            linear_scans,
        };
        let given = mesh(&points, Some(&rows), &params).unwrap();
        let searched = mesh(&points, None, &params).unwrap();
        assert!(!given.1.is_empty());
        assert!(given == searched, "{s:?}: the meshes differ");
    }
}

#[test]
fn a_table_that_is_not_one_for_the_points_is_refused_by_row_and_entry() {
    let params = Params {
        clusters: 100,
        ..Params::default()
    };
    let points = shape(Shape::Sphere, 2000, 0.0);
    let (knn, _) = cleaned_rows(&points, &params);
    let k = params.k;
    let check = |table: &[u32], row: usize, entry: u64| {
        let rows = Rows {
            knn: table,
            linear_scans: 0,
        };
        match mesh(&points, Some(&rows), &params) {
            Err(Error::BadNeighbourTable { row: r, entry: e }) if (r, e) == (row, entry) => {}
            other => panic!(
                "expected row {row} entry {entry}: {:?}",
                other.map(|m| m.1.len())
            ),
        }
    };
    check(
        &knn[..knn.len() - 1],
        (knn.len() - 1) / k,
        knn.len() as u64 - 1,
    );
    let mut own = knn.clone();
    own[7 * k + 3] = 7;
    check(&own, 7, 7);
    let mut far = knn.clone();
    far[1999 * k] = 2000;
    check(&far, 1999, 2000);
    // Of two, the one in the lower row (the rows are checked in parallel tasks).
    let mut two = knn.clone();
    two[1500 * k + 1] = 1500;
    two[30 * k + 5] = 9999;
    check(&two, 30, 9999);
    let e = Error::BadNeighbourTable { row: 7, entry: 7 }.to_string();
    assert!(e.contains("row 7") && e.contains("entry 7"), "{e}");
}
