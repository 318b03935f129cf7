//! The input formats a user brings, end to end: files written by these tests (LAS and
//! LAZ by the `las` crate, PCD `binary_compressed` by the project's own LZF
//! compressor, text clouds, OBJ/OFF/STL meshes) read and reconstructed by the
//! `vsaqem` binary, and their broken variants (lying headers, truncations, byte
//! flips) failing with a message that names the file, never a panic.
//!
//! The last test converts a shared cloud (`../shared/data/clouds/bunny.ply`) to a
//! georeferenced LAZ, a coloured XYZ and CSV, an organised PCD with NaN pixels, an
//! E57 of two scans and face-less OBJ and OFF files, and checks each gives the PLY's
//! accuracy (all but the LAZ, whose points are quantised, the PLY's very mesh):
//! `#[ignore]`d (eight reconstructions of 35k points).

mod common;
use common::{bin, cloud_err, field, run_with_report};

use std::fs;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use vsaqem::input::sample;
use vsaqem::io::{lzf, read_cloud, write_atomic, write_mesh, MeshFormat, MeshLayout, MeshOut};
use vsaqem_core::sample::Shape;

fn dir(name: &str) -> PathBuf {
    common::dir("formats", name)
}

fn put(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    fs::write(&p, bytes).unwrap();
    p
}

/// 4000 points on a unit sphere.
fn sphere() -> Vec<[f64; 3]> {
    sample(Shape::Sphere, 4000, 0.0, 7).positions
}

/// A colour per point, from its position.
fn colour_of(p: [f64; 3]) -> [u8; 3] {
    p.map(|v| ((v + 1.0) * 127.0).clamp(0.0, 255.0) as u8)
}

/// `vsaqem reconstruct INPUT ARGS` with a JSON report; panics with stderr on failure.
fn reconstruct(input: &Path, args: &[&str], out: &Path) -> String {
    let json = out.with_extension("json");
    let mut all = vec![input.to_str().unwrap()];
    all.extend(args);
    let r = run_with_report("reconstruct", all, out, &json);
    assert!(
        r.status.success(),
        "{}: {}",
        input.display(),
        String::from_utf8_lossy(&r.stderr)
    );
    fs::read_to_string(json).unwrap()
}

/// `vsaqem reconstruct INPUT ARGS`, expected to fail with exit code 1 and every
/// `needles` in its message (which names the file).
fn reconstruct_fails(input: &Path, args: &[&str], needles: &[&str]) {
    let r = bin()
        .args(["reconstruct", "-q"])
        .arg(input)
        .args(args)
        .arg("-o")
        .arg(input.with_extension("out.ply"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{}: {stderr}", input.display());
    assert!(!stderr.contains("panicked"), "{stderr}");
    let name = input.file_name().unwrap().to_str().unwrap();
    for n in std::iter::once(&name).chain(needles) {
        assert!(stderr.contains(n), "'{n}' not in: {stderr}");
    }
}

// ---------------------------------------------------------------- writers

/// A LAS 1.4 file (LAZ when `compress`) of `points` at a 0.1 mm resolution, offset
/// to the whole units below their first point, with the colours when given (point
/// format 2, else 0).
fn las_file(points: &[[f64; 3]], colors: Option<&[[u8; 3]]>, compress: bool) -> Vec<u8> {
    let offset = points.first().map_or([0.0; 3], |p| p.map(f64::floor));
    las_file_at(points, colors, compress, offset, 1e-4)
}

fn las_file_at(
    points: &[[f64; 3]],
    colors: Option<&[[u8; 3]]>,
    compress: bool,
    offset: [f64; 3],
    scale: f64,
) -> Vec<u8> {
    let mut b = las::Builder::from((1, 4));
    b.point_format = las::point::Format::new(if colors.is_some() { 2 } else { 0 }).unwrap();
    b.point_format.is_compressed = compress;
    let t = |a: usize| las::Transform {
        scale,
        offset: offset[a],
    };
    b.transforms = las::Vector {
        x: t(0),
        y: t(1),
        z: t(2),
    };
    let mut w =
        las::Writer::new(std::io::Cursor::new(Vec::new()), b.into_header().unwrap()).unwrap();
    for (i, p) in points.iter().enumerate() {
        w.write_point(las::Point {
            x: p[0],
            y: p[1],
            z: p[2],
            color: colors.map(|c| {
                let [r, g, b] = c[i].map(|v| u16::from(v) * 257);
                las::Color::new(r, g, b)
            }),
            ..Default::default()
        })
        .unwrap();
    }
    w.close().unwrap();
    w.into_inner().unwrap().into_inner()
}

/// An organised PCD, `width` pixels a row, `DATA binary_compressed`, fields
/// `x y z rgb`: the points in order with every `gap`-th pixel and the end of the
/// last row NaN (no measure). Returns the file and the number of NaN pixels.
fn organised_pcd(points: &[[f64; 3]], width: usize, gap: usize) -> (Vec<u8>, usize) {
    let mut pixels: Vec<Option<[f64; 3]>> = Vec::new();
    for &p in points {
        if pixels.len() % gap == gap - 1 {
            pixels.push(None);
        }
        pixels.push(Some(p));
    }
    while pixels.len() % width != 0 {
        pixels.push(None);
    }
    let nan = pixels.iter().filter(|p| p.is_none()).count();
    let mut blocks = vec![Vec::new(); 4];
    for px in &pixels {
        let p = px.unwrap_or([f64::NAN; 3]);
        for a in 0..3 {
            blocks[a].extend((p[a] as f32).to_le_bytes());
        }
        let [r, g, b] = colour_of(p);
        let bits = u32::from(r) << 16 | u32::from(g) << 8 | u32::from(b);
        blocks[3].extend(f32::from_bits(bits).to_le_bytes());
    }
    let raw = blocks.concat();
    let packed = lzf::compress(&raw);
    let mut data = format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgb\n\
         SIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH {width}\nHEIGHT {}\n\
         VIEWPOINT 0 0 0 1 0 0 0\nPOINTS {}\nDATA binary_compressed\n",
        pixels.len() / width,
        pixels.len()
    )
    .into_bytes();
    data.extend((packed.len() as u32).to_le_bytes());
    data.extend((raw.len() as u32).to_le_bytes());
    data.extend(packed);
    (data, nan)
}

/// A text cloud `x y z r g b` (0-255), full precision.
fn coloured_xyz(points: &[[f64; 3]]) -> String {
    points
        .iter()
        .map(|&p| {
            let [r, g, b] = colour_of(p);
            format!("{} {} {} {r} {g} {b}\n", p[0], p[1], p[2])
        })
        .collect()
}

/// A UV sphere mesh: 30 rings of 60 vertices and the two poles.
fn uv_sphere() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let (rings, around) = (30u32, 60u32);
    let mut v = vec![[0.0, 0.0, 1.0]];
    for i in 1..rings {
        let t = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..around {
            let p = std::f64::consts::TAU * j as f64 / around as f64;
            v.push([t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]);
        }
    }
    v.push([0.0, 0.0, -1.0]);
    let south = v.len() as u32 - 1;
    let at = |i: u32, j: u32| 1 + (i - 1) * around + j % around;
    let mut t = Vec::new();
    for j in 0..around {
        t.push([0, at(1, j), at(1, j + 1)]);
        t.push([south, at(rings - 1, j + 1), at(rings - 1, j)]);
        for i in 1..rings - 1 {
            t.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            t.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    (v, t)
}

/// Binary STL of a mesh, corners by value.
fn stl_binary(v: &[[f64; 3]], t: &[[u32; 3]]) -> Vec<u8> {
    let mut d = vec![b' '; 80];
    d[..5].copy_from_slice(b"solid");
    d.extend((t.len() as u32).to_le_bytes());
    for f in t {
        d.extend([0u8; 12]);
        for &i in f {
            d.extend(v[i as usize].iter().flat_map(|c| (*c as f32).to_le_bytes()));
        }
        d.extend([0u8; 2]);
    }
    d
}

fn stl_ascii(v: &[[f64; 3]], t: &[[u32; 3]]) -> String {
    let mut s = String::from("solid sphere\n");
    for f in t {
        s += "facet normal 0 0 0\n outer loop\n";
        for &i in f {
            // The f32 a binary STL holds, printed exactly.
            let p = v[i as usize].map(|c| c as f32 as f64);
            s += &format!("  vertex {} {} {}\n", p[0], p[1], p[2]);
        }
        s += " endloop\nendfacet\n";
    }
    s + "endsolid sphere\n"
}

// ---------------------------------------------------------------- LAS, LAZ

#[test]
fn las_and_laz_keep_georeferenced_coordinates_to_their_resolution() {
    let d = dir("las");
    let pts: Vec<[f64; 3]> = sphere()
        .iter()
        .map(|p| [p[0] + 500_000.0, p[1] + 4_000_000.0, p[2] + 100.0])
        .collect();
    let colors: Vec<[u8; 3]> = sphere().into_iter().map(colour_of).collect();
    for (name, compress) in [("geo.las", false), ("geo.laz", true)] {
        let c = read_cloud(&put(&d, name, las_file(&pts, Some(&colors), compress))).unwrap();
        assert_eq!(c.positions.len(), pts.len());
        for (a, b) in c.positions.iter().zip(&pts) {
            for k in 0..3 {
                assert!(
                    (a[k] - b[k]).abs() <= 0.5e-4 + 1e-9,
                    "{name}: {a:?} vs {b:?}"
                );
            }
        }
        assert_eq!(c.colors.as_deref(), Some(&colors[..]), "{name}");
        assert_eq!(c.invalid, 0);
    }
}

#[test]
fn a_georeferenced_laz_reconstructs_like_the_centred_cloud() {
    let d = dir("laz_cli");
    let pts = sphere();
    let xyz = put(&d, "centred.xyz", coloured_xyz(&pts));
    let far: Vec<[f64; 3]> = pts
        .iter()
        .map(|p| [p[0] + 500_000.0, p[1] + 4_000_000.0, p[2]])
        .collect();
    let laz = put(&d, "far.laz", las_file(&far, None, true));
    let args = ["--clusters", "150"];
    let a = reconstruct(&xyz, &args, &d.join("centred.ply"));
    let b = reconstruct(&laz, &args, &d.join("far.ply"));
    assert_eq!(field(&b, "points_read"), 4000.0);
    assert_eq!(field(&b, "invalid_skipped"), 0.0);
    assert_eq!(field(&b, "boundary_edges"), 0.0);
    for key in ["distance_mean_relative", "distance_max_relative"] {
        let (x, y) = (field(&a, key), field(&b, key));
        assert!(
            (y - x).abs() <= 0.25 * x + 1e-4,
            "{key}: centred {x}, georeferenced LAZ {y}"
        );
    }
}

#[test]
fn broken_las_and_laz_files_are_errors_naming_the_file() {
    let d = dir("las_bad");
    let pts = sphere();
    let las = las_file(&pts, None, false);
    let laz = las_file(&pts, None, true);
    // Legacy point count (byte 107) and the 1.4 count (byte 247).
    let mut b = las.clone();
    b[107..111].copy_from_slice(&4_000_000_000u32.to_le_bytes());
    cloud_err(
        &put(&d, "count.las", &b),
        &["header declares 4000000000 points of 20 bytes but only 80000 bytes"],
    );
    let mut b = las.clone();
    b[107..111].copy_from_slice(&0u32.to_le_bytes());
    b[247..255].copy_from_slice(&u64::MAX.to_le_bytes());
    cloud_err(
        &put(&d, "count64.las", &b),
        &["header declares 18446744073709551615 points"],
    );
    // Scale x at byte 131.
    for (name, v) in [("zero_scale.las", 0.0f64), ("nan_scale.las", f64::NAN)] {
        let mut b = las.clone();
        b[131..139].copy_from_slice(&v.to_le_bytes());
        cloud_err(
            &put(&d, name, &b),
            &["x scale", "do not map to coordinates"],
        );
    }
    cloud_err(
        &put(&d, "short.las", &las[..las.len() - 7]),
        &["only 79993 bytes"],
    );
    cloud_err(
        &put(&d, "header.las", &las[..100]),
        &["ends inside the LAS header"],
    );
    cloud_err(&put(&d, "text.las", "x y z\n"), &["not a LAS file"]);
    // Offset to the point data (byte 96) past the end.
    let mut b = las.clone();
    b[96..100].copy_from_slice(&u32::MAX.to_le_bytes());
    cloud_err(
        &put(&d, "offset.las", &b),
        &["the header puts the points at byte 4294967295"],
    );
    // An extended record (1.4: start at byte 235) past the end.
    let mut b = las.clone();
    b[235..243].copy_from_slice(&(las.len() as u64 - 10).to_le_bytes());
    b[243..247].copy_from_slice(&1u32.to_le_bytes());
    cloud_err(
        &put(&d, "evlr.las", &b),
        &["extended variable length record"],
    );
    // LAZ: a larger count than the data, a cut body, a chunk table of 2^32 chunks.
    let mut b = laz.clone();
    b[107..111].copy_from_slice(&4_000_000_000u32.to_le_bytes());
    cloud_err(&put(&d, "count.laz", &b), &["LAS: point"]);
    cloud_err(&put(&d, "cut.laz", &laz[..laz.len() / 2]), &["chunk table"]);
    let start = u32::from_le_bytes(laz[96..100].try_into().unwrap()) as usize;
    let table = u64::from_le_bytes(laz[start..start + 8].try_into().unwrap()) as usize;
    let mut b = laz.clone();
    b[table + 4..table + 8].copy_from_slice(&u32::MAX.to_le_bytes());
    cloud_err(
        &put(&d, "chunks.laz", &b),
        &["chunk table declares 4294967295 chunks"],
    );
    reconstruct_fails(
        &put(&d, "cli.laz", &laz[..300]),
        &[],
        &["ends inside the LAS header"],
    );
    // Damaged compressed points: the decoder runs out of data, or gives up (it
    // panics on this one where debug assertions are on, as in the default
    // test profile, which must stay an error, silent on stderr; built without
    // them, as by `cargo test --release`, it runs on and out of data).
    let mut b = laz.clone();
    b[start + 200..start + 2000].fill(0);
    cloud_err(
        &put(&d, "zeros.laz", &b),
        &["LAS: point 0 of 4000", "damaged"],
    );
    let mut b = laz.clone();
    b[start + 200..start + 2000].fill(0x5a);
    let p = put(&d, "damaged.laz", &b);
    let damaged = if cfg!(debug_assertions) {
        "LAS: point 0: the compressed data is damaged"
    } else {
        "LAS: point 0 of 4000: IoError: failed to fill whole buffer"
    };
    cloud_err(&p, &[damaged, "damaged"]);
    reconstruct_fails(&p, &[], &[damaged, "damaged"]);
}

/// Deterministic byte flips and cuts: any outcome but a panic (or a hang) is fine.
fn mutations_never_panic(d: &Path, name: &str, seed: &[u8], rounds: usize) {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut rand = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for _ in 0..rounds {
        let mut m = seed.to_vec();
        for _ in 0..1 + rand() % 4 {
            let i = (rand() % m.len() as u64) as usize;
            m[i] = rand() as u8;
        }
        if rand() % 4 == 0 {
            m.truncate((rand() % m.len() as u64) as usize);
        }
        let p = put(d, name, &m);
        // A hang, not a speed: a read of these few kilobytes takes
        // milliseconds, but seconds under qemu on a loaded machine (CI's
        // aarch64 run once took 2.01 s), so the watchdog is generous.
        let t = Instant::now();
        let _ = read_cloud(&p);
        assert!(
            t.elapsed() < Duration::from_secs(60),
            "{name}: {:?}",
            t.elapsed()
        );
    }
}

#[test]
fn a_laz_of_long_records_that_lies_about_its_count_fails_in_bounded_memory() {
    // Found by the `las` fuzz target: records of 60,020 bytes (extra bytes) and
    // a count past the body; a batch of 65,536 such points was a 3.9 GB buffer,
    // sized before the decoder found that the body ends.
    let d = dir("laz_long_records");
    let mut b = las::Builder::from((1, 4));
    b.point_format = las::point::Format::new(0).unwrap();
    b.point_format.extra_bytes = 60_000;
    b.point_format.is_compressed = true;
    let mut w =
        las::Writer::new(std::io::Cursor::new(Vec::new()), b.into_header().unwrap()).unwrap();
    for i in 0..10 {
        let (x, y, z) = (f64::from(i), 1.0, 2.0);
        w.write_point(las::Point {
            x,
            y,
            z,
            extra_bytes: vec![7; 60_000],
            ..Default::default()
        })
        .unwrap();
    }
    w.close().unwrap();
    let mut laz = w.into_inner().unwrap().into_inner();
    // Legacy point count (byte 107) and the 1.4 count (byte 247).
    laz[107..111].copy_from_slice(&1_000_000u32.to_le_bytes());
    laz[247..255].copy_from_slice(&1_000_000u64.to_le_bytes());
    // cloud_err bounds the time to 2 s (zeroing 3.9 GB took longer, where the
    // allocation did not fail).
    cloud_err(
        &put(&d, "lying.laz", &laz),
        &["of 1000000", "the header's count is larger than the data"],
    );
}

#[test]
fn mutated_las_laz_and_compressed_pcd_never_panic() {
    let d = dir("mutate");
    let pts: Vec<[f64; 3]> = sphere().into_iter().take(300).collect();
    let colors: Vec<[u8; 3]> = pts.iter().map(|&p| colour_of(p)).collect();
    mutations_never_panic(&d, "m.las", &las_file(&pts, Some(&colors), false), 150);
    mutations_never_panic(&d, "m.laz", &las_file(&pts, Some(&colors), true), 200);
    mutations_never_panic(&d, "m.pcd", &organised_pcd(&pts, 16, 5).0, 150);
    let (v, t) = uv_sphere();
    mutations_never_panic(&d, "m.stl", &stl_binary(&v, &t[..40]), 60);
    mutations_never_panic(&d, "a.stl", stl_ascii(&v, &t[..20]).as_bytes(), 60);
}

// ---------------------------------------------------------------- E57

/// An E57 file of two scans of `points` (halves), with their colours, every
/// `gap`-th point marked invalid (and its coordinates NaN), the second scan
/// posed by a translation of `shift`. Returns the invalid count.
fn e57_file(path: &Path, points: &[[f64; 3]], gap: usize, shift: [f64; 3]) -> usize {
    use e57::{Quaternion, Record, RecordValue, Transform, Translation};
    let mut w = e57::E57Writer::from_file(path, "vsaqem-test").unwrap();
    let mut invalid = 0;
    let half = points.len() / 2;
    for (scan, part) in [&points[..half], &points[half..]].into_iter().enumerate() {
        let prototype = vec![
            Record::CARTESIAN_X_F64,
            Record::CARTESIAN_Y_F64,
            Record::CARTESIAN_Z_F64,
            Record::CARTESIAN_INVALID_STATE,
            Record::COLOR_RED_U8,
            Record::COLOR_GREEN_U8,
            Record::COLOR_BLUE_U8,
        ];
        let mut pc = w
            .add_pointcloud(&format!("scan-{scan}"), prototype)
            .unwrap();
        if scan == 1 {
            let [x, y, z] = shift;
            pc.set_transform(Some(Transform {
                rotation: Quaternion {
                    w: 1.0,
                    x: 0.0,
                    y: 0.0,
                    z: 0.0,
                },
                translation: Translation { x, y, z },
            }));
        }
        for (i, &p) in part.iter().enumerate() {
            let bad = i % gap == gap - 1;
            invalid += usize::from(bad);
            let p = if bad { [f64::NAN; 3] } else { p };
            let mut values: Vec<RecordValue> = p.iter().map(|&v| RecordValue::Double(v)).collect();
            values.push(RecordValue::Integer(if bad { 2 } else { 0 }));
            let [r, g, b] = colour_of(p);
            values.extend([r, g, b].map(|c| RecordValue::Integer(i64::from(c))));
            pc.add_point(values).unwrap();
        }
        pc.finalize().unwrap();
    }
    w.finalize().unwrap();
    invalid
}

#[test]
fn an_e57_of_two_posed_scans_skips_its_invalid_points() {
    let d = dir("e57");
    let pts = sphere();
    let shift = [1000.0, -20.0, 3.5];
    let path = d.join("scans.e57");
    let invalid = e57_file(&path, &pts, 13, shift);
    let c = read_cloud(&path).unwrap();
    assert_eq!(c.invalid, invalid);
    assert_eq!(c.positions.len() + invalid, pts.len());
    // The first valid point of each scan, the second moved by its pose.
    assert_eq!(c.positions[0], pts[0]);
    let half = pts.len() / 2;
    let second = (0..half).filter(|i| i % 13 != 12).count();
    let want = pts[half];
    for a in 0..3 {
        assert!((c.positions[second][a] - (want[a] + shift[a])).abs() < 1e-9);
    }
    assert_eq!(c.colors.as_ref().unwrap()[0], colour_of(pts[0]));
    // Without invalid points and poses, reconstructed.
    let one = d.join("one.e57");
    e57_file(&one, &pts, usize::MAX, [0.0; 3]);
    let r = reconstruct(&one, &["--clusters", "150"], &d.join("mesh.ply"));
    assert_eq!(field(&r, "points_read"), pts.len() as f64);
    assert_eq!(field(&r, "invalid_skipped"), 0.0);
}

#[test]
fn broken_e57_files_are_errors_naming_the_file() {
    let d = dir("e57_bad");
    let path = d.join("good.e57");
    e57_file(&path, &sphere()[..400], 7, [0.0; 3]);
    let good = fs::read(&path).unwrap();
    cloud_err(&put(&d, "text.e57", "x y z\n"), &["not an E57 file"]);
    cloud_err(
        &put(&d, "head.e57", &good[..30]),
        &["ends inside the E57 header"],
    );
    let mut b = good.clone();
    b[32..40].copy_from_slice(&(40_000_000u64).to_le_bytes());
    cloud_err(
        &put(&d, "xml.e57", &b),
        &["bytes of XML at byte", "past the end"],
    );
    cloud_err(
        &put(&d, "cut.e57", &good[..good.len() - 100]),
        &["E57: ", "not a multiple of the page size"],
    );
    let mut b = good.clone();
    b[2000..2100].fill(0x5a);
    cloud_err(
        &put(&d, "crc.e57", &b),
        &["E57: scan 0, point 0", "invalid checksum"],
    );
    mutations_never_panic(&d, "m.e57", &good, 150);
}

// ---------------------------------------------------------------- PCD

#[test]
fn an_organised_compressed_pcd_skips_its_nan_pixels_and_gives_the_same_mesh() {
    let d = dir("pcd");
    // Positions that are f32 already, so the PCD holds them exactly.
    let pts: Vec<[f64; 3]> = sphere()
        .iter()
        .map(|p| p.map(|v| v as f32 as f64))
        .collect();
    let (pcd, nan) = organised_pcd(&pts, 64, 9);
    let pcd = put(&d, "organised.pcd", pcd);
    let c = read_cloud(&pcd).unwrap();
    assert_eq!((c.positions.len(), c.invalid), (pts.len(), nan));
    assert_eq!(c.positions, pts);
    let colors = c.colors.unwrap();
    assert_eq!(colors[17], colour_of(pts[17]));
    let xyz = put(&d, "same.xyz", coloured_xyz(&pts));
    let args = ["--clusters", "150"];
    let a = reconstruct(&pcd, &args, &d.join("from_pcd.obj"));
    let b = reconstruct(&xyz, &args, &d.join("from_xyz.obj"));
    assert_eq!(field(&a, "invalid_skipped"), nan as f64);
    assert!(
        a.contains(&format!("\"points_read\": {}", pts.len())),
        "{a}"
    );
    assert_eq!(
        fs::read(d.join("from_pcd.obj")).unwrap(),
        fs::read(d.join("from_xyz.obj")).unwrap(),
        "the same points give the same mesh"
    );
    assert_eq!(field(&a, "vertices"), field(&b, "vertices"));
}

#[test]
fn broken_compressed_pcd_files_are_errors_naming_the_place() {
    let d = dir("pcd_bad");
    let pts: Vec<[f64; 3]> = sphere().into_iter().take(500).collect();
    let (good, _) = organised_pcd(&pts, 50, 7);
    let body = good
        .windows(22)
        .position(|w| w == b"DATA binary_compressed")
        .unwrap()
        + 23;
    let packed = u32::from_le_bytes(good[body..body + 4].try_into().unwrap()) as usize;
    // The decompressed size disagrees with the header.
    let mut b = good.clone();
    b[body + 4..body + 8].copy_from_slice(&u32::MAX.to_le_bytes());
    cloud_err(
        &put(&d, "size.pcd", &b),
        &["decompresses to 4294967295 bytes, but 600 points of 16 bytes need 9600"],
    );
    // The compressed size is past the end.
    let mut b = good.clone();
    b[body..body + 4].copy_from_slice(&(packed as u32 + 1).to_le_bytes());
    cloud_err(
        &put(&d, "packed.pcd", &b),
        &["compressed", "declared, only"],
    );
    // A cut stream, and a back-reference before the start.
    let mut b = good.clone();
    b.truncate(body + 8 + packed - 1);
    b[body..body + 4].copy_from_slice(&(packed as u32 - 1).to_le_bytes());
    cloud_err(
        &put(&d, "cut.pcd", &b),
        &["binary_compressed data: the stream"],
    );
    let mut b = good.clone();
    b[body + 8..body + 10].copy_from_slice(&[0x20, 0xff]);
    cloud_err(
        &put(&d, "backref.pcd", &b),
        &[
            "back-reference points before the start",
            &format!("at byte {}", body + 8),
        ],
    );
    // A width and height that overflow, and a huge COUNT.
    let head = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 4294967296\nHEIGHT 4294967296\n\
                DATA binary_compressed\n";
    cloud_err(
        &put(&d, "wh.pcd", head),
        &["WIDTH 4294967296 * HEIGHT 4294967296 overflows"],
    );
    let head = "FIELDS x y z h\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 9999999999999999999\n\
                WIDTH 1\nDATA binary\n";
    cloud_err(
        &put(&d, "count.pcd", head),
        &["line 4: field 'h': COUNT", "too large"],
    );
    // Every pixel without a measure: nothing to read.
    let (all_nan, _) = organised_pcd(&[[f64::NAN; 3]; 3], 4, 2);
    cloud_err(&put(&d, "all_nan.pcd", all_nan), &["no valid points"]);
}

// ---------------------------------------------------------------- text clouds

#[test]
fn a_coloured_xyz_is_read_as_colours_and_reconstructs() {
    let d = dir("xyz_colours");
    let pts = sphere();
    let p = put(&d, "coloured.xyz", coloured_xyz(&pts));
    let c = read_cloud(&p).unwrap();
    assert_eq!(c.normals, None, "x y z r g b is not x y z nx ny nz");
    assert_eq!(c.colors.unwrap()[5], colour_of(pts[5]));
    let report = reconstruct(&p, &["--clusters", "150"], &d.join("mesh.ply"));
    assert!(report.contains("\"normals_given\": false"), "{report}");
    assert_eq!(field(&report, "boundary_edges"), 0.0);
    // The same file as CSV with CloudCompare's header, and as PTS with intensity.
    let csv: String = std::iter::once("//X,Y,Z,R,G,B\n".to_string())
        .chain(
            coloured_xyz(&pts)
                .lines()
                .map(|l| l.replace(' ', ",") + "\n"),
        )
        .collect();
    let c = read_cloud(&put(&d, "coloured.csv", csv)).unwrap();
    assert_eq!(c.colors.unwrap()[5], colour_of(pts[5]));
    let pts_file: String = std::iter::once(format!("{}\n", pts.len()))
        .chain(pts.iter().map(|p| {
            let [r, g, b] = colour_of(*p);
            format!("{} {} {} -1203 {r} {g} {b}\n", p[0], p[1], p[2])
        }))
        .collect();
    let c = read_cloud(&put(&d, "scan.pts", pts_file)).unwrap();
    assert_eq!(c.positions.len(), pts.len());
    assert_eq!(c.colors.unwrap()[5], colour_of(pts[5]));
}

#[test]
fn the_columns_option_says_what_the_columns_are() {
    let d = dir("columns");
    let pts = sphere();
    // Unit normals in columns 5-7 after an intensity.
    let text: String = pts
        .iter()
        .map(|p| format!("{} {} {} 7 {} {} {}\n", p[0], p[1], p[2], p[0], p[1], p[2]))
        .collect();
    let p = put(&d, "normals.txt", text);
    // By the count, columns 5-7 of 7 would be colours or normals: unit, so normals.
    let r = reconstruct(&p, &["--clusters", "100"], &d.join("guess.ply"));
    assert!(r.contains("\"normals_given\": true"), "{r}");
    let r = reconstruct(
        &p,
        &["--clusters", "100", "--columns", "x,y,z,_,_,_,_"],
        &d.join("skip.ply"),
    );
    assert!(r.contains("\"normals_given\": false"), "{r}");
    reconstruct_fails(
        &p,
        &["--columns", "x,y,z,nx,ny,nz"],
        &["line 1: --columns x,y,z,nx,ny,nz names 6 columns, the line has 7"],
    );
    let r = bin()
        .args(["reconstruct", "-q", "--columns", "x,y"])
        .arg(&p)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(
        !r.status.success() && stderr.contains("no 'z' column"),
        "{stderr}"
    );
    let (pcd, _) = organised_pcd(&pts, 64, 9);
    reconstruct_fails(
        &put(&d, "cloud.pcd", pcd),
        &["--columns", "x,y,z"],
        &["--columns x,y,z for a .pcd file"],
    );
}

// ---------------------------------------------------------------- meshes, normals

#[test]
fn meshes_are_clouds_of_their_vertices() {
    let d = dir("meshes");
    let (v, t) = uv_sphere();
    for (ext, format) in [
        ("obj", MeshFormat::Obj),
        ("off", MeshFormat::Off),
        ("ply", MeshFormat::Ply),
    ] {
        let p = d.join(format!("sphere.{ext}"));
        write_atomic(&p, |w| {
            write_mesh(w, &MeshLayout::plain(format), &MeshOut::new(&v, &t))
        })
        .unwrap();
    }
    put(&d, "sphere.stl", stl_binary(&v, &t));
    put(&d, "ascii.stl", stl_ascii(&v, &t));
    let args = ["--clusters", "150"];
    let mut outputs = Vec::new();
    for name in [
        "sphere.obj",
        "sphere.off",
        "sphere.ply",
        "sphere.stl",
        "ascii.stl",
    ] {
        let input = d.join(name);
        let c = read_cloud(&input).unwrap();
        assert_eq!(c.positions.len(), v.len(), "{name}: STL corners are merged");
        let out = d.join(format!("{name}.mesh.off"));
        let r = reconstruct(&input, &args, &out);
        assert_eq!(field(&r, "points_read"), v.len() as f64, "{name}");
        assert_eq!(field(&r, "boundary_edges"), 0.0, "{name}");
        outputs.push(fs::read(out).unwrap());
    }
    assert_eq!(outputs[0], outputs[1], "OBJ and OFF hold the same vertices");
    assert_eq!(
        outputs[3], outputs[4],
        "binary and ASCII STL hold the same vertices"
    );
}

#[test]
fn normals_ignore_drops_the_file_normals() {
    let d = dir("normals");
    let text: String = sphere()
        .iter()
        .map(|p| format!("{} {} {} {} {} {}\n", p[0], p[1], p[2], p[0], p[1], p[2]))
        .collect();
    let p = put(&d, "sphere.xyzn", text);
    let used = reconstruct(&p, &["--clusters", "100"], &d.join("use.ply"));
    assert!(used.contains("\"normals_given\": true"), "{used}");
    let explicit = reconstruct(
        &p,
        &["--clusters", "100", "--normals", "use"],
        &d.join("use2.ply"),
    );
    assert_eq!(
        fs::read(d.join("use.ply")).unwrap(),
        fs::read(d.join("use2.ply")).unwrap()
    );
    assert!(explicit.contains("\"normals_given\": true"));
    let ignored = reconstruct(
        &p,
        &["--clusters", "100", "--normals", "ignore"],
        &d.join("ignore.ply"),
    );
    assert!(ignored.contains("\"normals_given\": false"), "{ignored}");
    let r = bin()
        .args(["reconstruct", "-q", "--normals", "flip"])
        .arg(&p)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(
        !r.status.success() && stderr.contains("use") && stderr.contains("ignore"),
        "{stderr}"
    );
}

// ---------------------------------------------------------------- a shared cloud

fn shared_bunny() -> Option<PathBuf> {
    let p = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/data/clouds/bunny.ply"
    ));
    if p.is_file() {
        Some(p.to_path_buf())
    } else {
        println!("skipped: {} not found", p.display());
        None
    }
}

#[test]
#[ignore = "eight reconstructions of a 35k-point shared cloud"]
fn a_shared_cloud_converted_to_laz_xyz_and_organised_pcd_keeps_its_accuracy() {
    let Some(ply) = shared_bunny() else { return };
    let d = dir("shared");
    let pts = read_cloud(&ply).unwrap().positions;
    let colors: Vec<[u8; 3]> = pts
        .iter()
        .map(|&p| colour_of(p.map(|v| v * 10.0)))
        .collect();
    let offset = [500_000.0, 4_000_000.0, 0.0];
    let far: Vec<[f64; 3]> = pts
        .iter()
        .map(|p| [p[0] + offset[0], p[1] + offset[1], p[2]])
        .collect();
    let laz = put(
        &d,
        "bunny.laz",
        las_file_at(&far, Some(&colors), true, offset, 1e-6),
    );
    let xyz = put(&d, "bunny.xyz", coloured_xyz(&pts));
    let csv: String = std::iter::once("X,Y,Z,R,G,B\n".to_string())
        .chain(
            coloured_xyz(&pts)
                .lines()
                .map(|l| l.replace(' ', ",") + "\n"),
        )
        .collect();
    let csv = put(&d, "bunny.csv", csv);
    let (pcd, nan) = organised_pcd(&pts, 640, 11);
    let pcd = put(&d, "bunny.pcd", pcd);
    let e57 = d.join("bunny.e57");
    e57_file(&e57, &pts, usize::MAX, [0.0; 3]);
    // Meshes without faces: their vertices are the points.
    let (obj, off) = (d.join("bunny.obj"), d.join("bunny.off"));
    write_atomic(&obj, |w| {
        write_mesh(
            w,
            &MeshLayout::plain(MeshFormat::Obj),
            &MeshOut::new(&pts, &[]),
        )
    })
    .unwrap();
    write_atomic(&off, |w| {
        write_mesh(
            w,
            &MeshLayout::plain(MeshFormat::Off),
            &MeshOut::new(&pts, &[]),
        )
    })
    .unwrap();
    let base = reconstruct(&ply, &[], &d.join("ply.mesh.obj"));
    let key = |r: &str, k: &str| field(r, k);
    println!(
        "bunny.ply: distance max {:.4} %, mean {:.5} %",
        100.0 * key(&base, "distance_max_relative"),
        100.0 * key(&base, "distance_mean_relative")
    );
    let inputs = [
        (&xyz, true),
        (&csv, true),
        (&pcd, true),
        (&e57, true),
        (&obj, true),
        (&off, true),
        (&laz, false),
    ];
    for (input, same_mesh) in inputs {
        let out = d.join(format!(
            "{}.mesh.obj",
            input.extension().unwrap().to_str().unwrap()
        ));
        let r = reconstruct(input, &[], &out);
        let (max, mean) = (
            key(&r, "distance_max_relative"),
            key(&r, "distance_mean_relative"),
        );
        println!(
            "{}: distance max {:.4} %, mean {:.5} %, {} invalid skipped",
            input.display(),
            100.0 * max,
            100.0 * mean,
            key(&r, "invalid_skipped")
        );
        assert_eq!(key(&r, "points_read"), pts.len() as f64);
        assert_eq!(key(&r, "boundary_edges"), key(&base, "boundary_edges"));
        if same_mesh {
            assert_eq!(
                fs::read(&out).unwrap(),
                fs::read(d.join("ply.mesh.obj")).unwrap(),
                "{}: the same points give the PLY's mesh",
                input.display()
            );
        }
        for (k, got) in [
            ("distance_max_relative", max),
            ("distance_mean_relative", mean),
        ] {
            let want = key(&base, k);
            assert!(
                got <= want * 1.25 + 1e-4,
                "{}: {k} {got} against the PLY's {want}",
                input.display()
            );
        }
    }
    let r = fs::read_to_string(d.join("pcd.mesh.json")).unwrap();
    assert_eq!(key(&r, "invalid_skipped"), nan as f64);
}
