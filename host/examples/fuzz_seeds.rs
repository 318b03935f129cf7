//! Seed inputs for the fuzz targets in `fuzz/`, made from core's generated
//! shapes (a sphere, a torus, a box, an open wave), so that no data file is
//! committed: `cargo run --release -p vsaqem --example fuzz_seeds -- DIR`
//! writes `DIR/<target>/<name>` for every target (`fuzz/seed.sh` runs it).
//!
//! The `eval` and `reconstruct` seeds use the byte layouts those targets
//! document (`fuzz/fuzz_targets/eval.rs`, `reconstruct.rs`).

use std::mem::MaybeUninit;
use std::path::{Path, PathBuf};
use vsaqem::io::{lzf, write_mesh, write_points_ply, MeshFormat, MeshLayout, MeshOut};
use vsaqem_core::sample::{fill, Shape};
use vsaqem_core::{arena_bytes, reconstruct, Arena, Params, Silent, V3};

/// The shapes, and the points each seed cloud has (small, so that a run is fast).
const SHAPES: [(&str, Shape); 4] = [
    ("sphere", Shape::Sphere),
    ("torus", Shape::Torus),
    ("box", Shape::Box),
    ("wave", Shape::Wave),
];
const POINTS: usize = 120;
/// Points of the clouds the seed meshes are made from (core's mesh of them at
/// 40 clusters).
const MESH_POINTS: usize = 800;

fn main() {
    let Some(dir) = std::env::args().nth(1).map(PathBuf::from) else {
        eprintln!("usage: fuzz_seeds DIR");
        std::process::exit(2);
    };
    let mut seeds = Seeds { dir, written: 0 };
    for (name, shape) in SHAPES {
        let core = points_of(shape, POINTS);
        let points: Vec<[f64; 3]> = core.iter().map(|p| p.map(f64::from)).collect();
        let normals: Vec<[f64; 3]> = points.iter().map(|&p| unit(p)).collect();
        let colours: Vec<[u8; 3]> = points
            .iter()
            .map(|p| p.map(|c| (127.5 + 127.0 * c) as u8))
            .collect();
        let (vertices, faces) = mesh(&points_of(shape, MESH_POINTS));
        clouds(&mut seeds, name, &points, &normals, &colours);
        meshes(&mut seeds, name, &vertices, &faces);
        seeds.put("eval", name, &eval_input(&points, &vertices, &faces));
        seeds.put("reconstruct", name, &reconstruct_input(&core, None));
        let core_normals: Vec<V3> = normals.iter().map(|n| n.map(|c| c as f32)).collect();
        seeds.put(
            "reconstruct",
            &format!("{name}_normals"),
            &reconstruct_input(&core, Some(&core_normals)),
        );
    }
    args(&mut seeds);
    println!("{} seeds in {}", seeds.written, seeds.dir.display());
}

struct Seeds {
    dir: PathBuf,
    written: usize,
}

impl Seeds {
    fn put(&mut self, target: &str, name: &str, bytes: &[u8]) {
        let dir = self.dir.join(target);
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| fail(&dir, e));
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap_or_else(|e| fail(&path, e));
        self.written += 1;
    }
}

fn fail(path: &Path, e: std::io::Error) -> ! {
    eprintln!("{}: {e}", path.display());
    std::process::exit(1);
}

fn points_of(shape: Shape, n: usize) -> Vec<V3> {
    let mut p = vec![[0.0f32; 3]; n];
    fill(shape, 1, 0.0, &mut p);
    p
}

fn unit(p: [f64; 3]) -> [f64; 3] {
    let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt().max(1e-9);
    p.map(|c| c / l)
}

/// Core's mesh of `points` at 40 clusters.
fn mesh(points: &[V3]) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let params = Params {
        clusters: 40,
        ..Params::default()
    };
    let mut buf = vec![MaybeUninit::uninit(); arena_bytes(points.len(), &params)];
    let arena = Arena::new(&mut buf);
    match reconstruct(&arena, points, None, &params, &mut Silent) {
        Ok(out) => (
            out.mesh.vertices.iter().map(|v| v.map(f64::from)).collect(),
            out.mesh.triangles.to_vec(),
        ),
        Err(e) => {
            eprintln!("no seed mesh: {e}");
            std::process::exit(1)
        }
    }
}

fn text(lines: impl Iterator<Item = String>) -> Vec<u8> {
    lines.map(|l| l + "\n").collect::<String>().into_bytes()
}

fn clouds(
    seeds: &mut Seeds,
    name: &str,
    points: &[[f64; 3]],
    normals: &[[f64; 3]],
    colours: &[[u8; 3]],
) {
    let n = points.len();
    // PLY: binary little-endian with colours, ASCII with normals, big-endian doubles.
    let mut ply = Vec::new();
    write_points_ply(&mut ply, points, colours, None).expect("in memory");
    seeds.put("ply", &format!("{name}_binary.ply"), &ply);
    let mut ascii = format!(
        "ply\nformat ascii 1.0\nelement vertex {n}\nproperty float x\nproperty float y\n\
         property float z\nproperty float nx\nproperty float ny\nproperty float nz\nend_header\n"
    )
    .into_bytes();
    ascii.extend(text(points.iter().zip(normals).map(|(p, q)| {
        format!("{} {} {} {} {} {}", p[0], p[1], p[2], q[0], q[1], q[2])
    })));
    seeds.put("ply", &format!("{name}_ascii.ply"), &ascii);
    let mut be = format!(
        "ply\nformat binary_big_endian 1.0\nelement vertex {n}\nproperty double x\n\
         property double y\nproperty double z\nend_header\n"
    )
    .into_bytes();
    for p in points {
        for c in p {
            be.extend_from_slice(&c.to_be_bytes());
        }
    }
    seeds.put("ply", &format!("{name}_be.ply"), &be);

    // Text: bare columns, a CSV with a header, and named columns (mode byte odd).
    let mut xyzn = vec![0u8];
    xyzn.extend(text(points.iter().zip(normals).map(|(p, q)| {
        format!("{} {} {} {} {} {}", p[0], p[1], p[2], q[0], q[1], q[2])
    })));
    seeds.put("text", &format!("{name}.xyzn"), &xyzn);
    let mut csv = b"\0x,y,z,red,green,blue\n".to_vec();
    csv.extend(text(points.iter().zip(colours).map(|(p, c)| {
        format!("{},{},{},{},{},{}", p[0], p[1], p[2], c[0], c[1], c[2])
    })));
    seeds.put("text", &format!("{name}.csv"), &csv);
    let mut named = b"\x01x y z _\n".to_vec();
    named.extend(text(
        points
            .iter()
            .map(|p| format!("{} {} {} 0.5", p[0], p[1], p[2])),
    ));
    seeds.put("text", &format!("{name}_columns.txt"), &named);

    // PCD: ascii, binary, binary_compressed (field after field, LZF).
    let head = |data: &str| {
        format!(
            "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n\
             WIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA {data}\n"
        )
        .into_bytes()
    };
    let mut pcd = head("ascii");
    pcd.extend(text(
        points.iter().map(|p| format!("{} {} {}", p[0], p[1], p[2])),
    ));
    seeds.put("pcd", &format!("{name}_ascii.pcd"), &pcd);
    let mut pcd = head("binary");
    for p in points {
        for c in p {
            pcd.extend_from_slice(&(*c as f32).to_le_bytes());
        }
    }
    seeds.put("pcd", &format!("{name}_binary.pcd"), &pcd);
    let mut body = Vec::new();
    for axis in 0..3 {
        for p in points {
            body.extend_from_slice(&(p[axis] as f32).to_le_bytes());
        }
    }
    let packed = lzf::compress(&body);
    let mut pcd = head("binary_compressed");
    pcd.extend_from_slice(&(packed.len() as u32).to_le_bytes());
    pcd.extend_from_slice(&(body.len() as u32).to_le_bytes());
    pcd.extend_from_slice(&packed);
    seeds.put("pcd", &format!("{name}_compressed.pcd"), &pcd);

    // LAS 1.4 (point format 0, and 2 with colours) and LAZ.
    for (ext, compress, rgb) in [
        ("las", false, false),
        ("rgb.las", false, true),
        ("laz", true, true),
    ] {
        seeds.put(
            "las",
            &format!("{name}.{ext}"),
            &las(points, rgb.then_some(colours), compress),
        );
    }

    // E57: one scan, double coordinates, colours.
    seeds.put(
        "e57",
        &format!("{name}.e57"),
        &e57(&seeds.dir, points, colours),
    );
}

fn las(points: &[[f64; 3]], colours: Option<&[[u8; 3]]>, compress: bool) -> Vec<u8> {
    let mut b = las::Builder::from((1, 4));
    b.point_format = las::point::Format::new(if colours.is_some() { 2 } else { 0 }).expect("0, 2");
    b.point_format.is_compressed = compress;
    let t = las::Transform {
        scale: 1e-4,
        offset: 0.0,
    };
    b.transforms = las::Vector { x: t, y: t, z: t };
    let header = b.into_header().expect("a valid header");
    let mut w = las::Writer::new(std::io::Cursor::new(Vec::new()), header).expect("in memory");
    for (i, p) in points.iter().enumerate() {
        w.write_point(las::Point {
            x: p[0],
            y: p[1],
            z: p[2],
            color: colours.map(|c| {
                let [r, g, b] = c[i].map(|v| u16::from(v) * 257);
                las::Color::new(r, g, b)
            }),
            ..Default::default()
        })
        .expect("in memory");
    }
    w.close().expect("in memory");
    w.into_inner().expect("in memory").into_inner()
}

fn e57(dir: &Path, points: &[[f64; 3]], colours: &[[u8; 3]]) -> Vec<u8> {
    use e57::{Record, RecordValue};
    let path = dir.join("seed.e57.tmp");
    let mut w = e57::E57Writer::from_file(&path, "vsaqem-fuzz-seed").unwrap_or_else(|e| {
        eprintln!("{}: {e}", path.display());
        std::process::exit(1)
    });
    let prototype = vec![
        Record::CARTESIAN_X_F64,
        Record::CARTESIAN_Y_F64,
        Record::CARTESIAN_Z_F64,
        Record::COLOR_RED_U8,
        Record::COLOR_GREEN_U8,
        Record::COLOR_BLUE_U8,
    ];
    let mut pc = w
        .add_pointcloud("scan", prototype)
        .expect("a valid prototype");
    for (p, c) in points.iter().zip(colours) {
        let mut values: Vec<RecordValue> = p.iter().map(|&v| RecordValue::Double(v)).collect();
        values.extend(c.map(|v| RecordValue::Integer(i64::from(v))));
        pc.add_point(values).expect("values of the prototype");
    }
    pc.finalize().expect("written");
    w.finalize().expect("written");
    let bytes = std::fs::read(&path).unwrap_or_else(|e| fail(&path, e));
    let _ = std::fs::remove_file(&path);
    bytes
}

fn meshes(seeds: &mut Seeds, name: &str, vertices: &[[f64; 3]], faces: &[[u32; 3]]) {
    let out = MeshOut::new(vertices, faces);
    for (format, selector, ext) in [
        (MeshFormat::Obj, 0u8, "obj"),
        (MeshFormat::Off, 1, "off"),
        (MeshFormat::Stl, 2, "stl"),
    ] {
        let mut bytes = vec![selector];
        write_mesh(&mut bytes, &MeshLayout::plain(format), &out).expect("in memory");
        seeds.put("mesh", &format!("{name}.{ext}"), &bytes);
    }
    // ASCII STL, which the writer does not make.
    let mut stl = b"\x02solid seed\n".to_vec();
    for f in faces {
        let [a, b, c] = f.map(|i| vertices[i as usize]);
        stl.extend(
            format!(
                "facet normal 0 0 1\nouter loop\nvertex {} {} {}\nvertex {} {} {}\n\
                 vertex {} {} {}\nendloop\nendfacet\n",
                a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]
            )
            .bytes(),
        );
    }
    stl.extend(b"endsolid seed\n");
    seeds.put("mesh", &format!("{name}_ascii.stl"), &stl);
    let mut ply = Vec::new();
    write_mesh(&mut ply, &MeshLayout::plain(MeshFormat::Ply), &out).expect("in memory");
    seeds.put("ply", &format!("{name}_mesh.ply"), &ply);
}

/// The `eval` target's layout: counts, samples / 4, genus, points, vertices
/// (little-endian `f64`s), faces (byte indices); at most 255 of each.
fn eval_input(points: &[[f64; 3]], vertices: &[[f64; 3]], faces: &[[u32; 3]]) -> Vec<u8> {
    let points = &points[..points.len().min(255)];
    let vertices = &vertices[..vertices.len().min(255)];
    let faces: Vec<[u32; 3]> = faces
        .iter()
        .copied()
        .filter(|f| f.iter().all(|&i| (i as usize) < vertices.len()))
        .take(255)
        .collect();
    let mut out = vec![
        points.len() as u8,
        vertices.len() as u8,
        faces.len() as u8,
        64,
        0,
    ];
    for p in points.iter().chain(vertices) {
        for c in p {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    for f in &faces {
        out.extend(f.map(|i| i as u8));
    }
    out
}

/// The `reconstruct` target's layout: 14 parameter bytes (24 clusters, k = 12,
/// otherwise near the defaults), a flag byte, `u16` coordinates, `i8` normals.
fn reconstruct_input(points: &[V3], normals: Option<&[V3]>) -> Vec<u8> {
    let mut out = vec![
        12,
        24,
        0,
        0b0101_0101,
        10,
        1,
        0,
        50,
        0b0000_1010,
        51,
        0,
        75,
        100,
        0,
    ];
    out.push(u8::from(normals.is_some()));
    for p in points {
        for c in p {
            let q = ((c.clamp(-1.0, 1.0) + 1.0) * 32767.5).round() as u16;
            out.extend_from_slice(&q.to_le_bytes());
        }
    }
    for n in normals.into_iter().flatten() {
        out.extend(n.map(|c| (c.clamp(-1.0, 1.0) * 127.0).round() as i8 as u8));
    }
    out
}

/// The `args` target's layout: a point count (`u32`), then the words of a
/// command line after `vsaqem`, NUL-separated: the README's commands.
fn args(seeds: &mut Seeds) {
    let lines: [&[&str]; 8] = [
        &["reconstruct", "-o", "demo.ply"],
        &[
            "reconstruct",
            "bunny.ply",
            "-o",
            "bunny.obj",
            "--clusters",
            "500",
            "--report",
            "r.json",
        ],
        &[
            "reconstruct",
            "scan.xyz",
            "--columns",
            "x y z _ nx ny nz",
            "--memory",
            "64MiB",
            "--threads",
            "2",
            "-o",
            "m.off",
        ],
        &[
            "cluster",
            "-q",
            "in.laz",
            "-o",
            "c.ply",
            "--knn",
            "16",
            "--outlier-sigma",
            "2.5",
        ],
        &[
            "reconstruct",
            "--sample",
            "torus",
            "--points",
            "3000",
            "--max-error",
            "0.01",
            "--precision",
            "f64",
            "-o",
            "t.stl",
        ],
        &["eval", "--expect-genus", "0", "--json", "a.ply", "b.ply"],
        &["render", "m.ply", "-o", "m.png"],
        &["completions", "bash"],
    ];
    for (i, words) in lines.iter().enumerate() {
        let mut out = 3000u32.to_le_bytes().to_vec();
        out.extend(words.join("\0").bytes());
        seeds.put("args", &format!("line{i}"), &out);
    }
}
