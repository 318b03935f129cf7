//! `vsaqem eval`'s measures (distances both ways, topology, validity, quality)
//! and its text and JSON reports, on a small cloud and mesh. Layout: counts
//! `points`, `vertices`, `faces` (a byte each), a byte for the surface
//! samples (times 4), a byte for the expected genus (255: none); then the
//! points and the vertices as three little-endian `f64`s each (a NaN or
//! infinity becomes 0: the readers let only finite values through) and the
//! faces as three byte indices each (they may be out of range, which
//! `evaluate` counts).
#![no_main]
use libfuzzer_sys::fuzz_target;
use vsaqem::cmd::eval::EvalReport;
use vsaqem::eval::evaluate;
use vsaqem_fuzz::Bytes;

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    let [np, nv, nf, samples, genus] = b.array::<5>();
    let mut xyz = |n: u8| -> Vec<[f64; 3]> {
        (0..n)
            .map(|_| [(); 3].map(|()| Some(b.f64()).filter(|v| v.is_finite()).unwrap_or(0.0)))
            .collect()
    };
    let points = xyz(np);
    let vertices = xyz(nv);
    let faces: Vec<[u32; 3]> = (0..nf).map(|_| b.array::<3>().map(u32::from)).collect();
    let invalid = faces
        .iter()
        .filter(|f| f.iter().any(|&i| i >= u32::from(nv)))
        .count();

    let evaluation = evaluate(&points, &vertices, &faces, 4 * usize::from(samples));
    assert_eq!(evaluation.points, points.len());
    assert_eq!(evaluation.topology.faces, faces.len());
    assert_eq!(evaluation.topology.invalid_faces, invalid);
    let report = EvalReport {
        points_file: "points.xyz".into(),
        mesh_file: "mesh.off".into(),
        evaluation,
        expect_genus: (genus != 255).then_some(u64::from(genus)),
        read_ms: 0.0,
        eval_ms: 0.0,
    };
    assert!(!report.text().is_empty());
    if let Err(e) = report.json() {
        panic!("{e}");
    }
});
