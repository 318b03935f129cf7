use super::mesh::{self, AUTO_F32_SHARE};
use super::*;

#[test]
fn points_ply_layout_is_19_bytes_per_point_with_colour_and_label() {
    let mut out = Vec::new();
    write_points_ply(
        &mut out,
        &[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]],
        &[[1, 2, 3], [4, 5, 6]],
        Some(("cluster", &[7, 8])),
    )
    .unwrap();
    let end = out.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    assert_eq!(out.len() - end, 2 * 19);
    assert_eq!(&out[end + 12..end + 15], &[1, 2, 3]);
    assert_eq!(&out[end + 15..end + 19], &7u32.to_le_bytes());
    let head = std::str::from_utf8(&out[..end]).unwrap();
    assert!(head.contains("property uint cluster\n"), "{head}");
}

/// A layout `precision` gives `v` in `format` when `auto` allows `allowed`.
fn layout(format: MeshFormat, precision: Precision, v: &[[f64; 3]], allowed: f64) -> MeshLayout {
    MeshLayout::choose(format, precision, v, allowed).unwrap()
}

#[test]
fn a_written_mesh_reads_back_at_the_positions_stored_says() {
    // Coordinates that f32 cannot hold: float32 layouts round them, the
    // others keep them.
    let v = [
        [0.1, 1e7 + 0.3, -2.0 / 3.0],
        [1.0 / 3.0, 2.0, 3.0],
        [4.0, 5.000_000_1, 6.0],
    ];
    let t = [[0, 1, 2]];
    type Parse = fn(&[u8]) -> Result<crate::io::Mesh, crate::io::ReadErrorKind>;
    let cases: [(MeshFormat, Precision, Parse, bool); 7] = [
        (
            MeshFormat::Ply,
            Precision::F32,
            crate::io::ply::parse_mesh,
            false,
        ),
        (
            MeshFormat::Ply,
            Precision::F64,
            crate::io::ply::parse_mesh,
            true,
        ),
        (
            MeshFormat::Obj,
            Precision::Auto,
            crate::io::obj::parse_mesh,
            true,
        ),
        (
            MeshFormat::Obj,
            Precision::F32,
            crate::io::obj::parse_mesh,
            false,
        ),
        (
            MeshFormat::Off,
            Precision::Auto,
            crate::io::off::parse_mesh,
            true,
        ),
        (
            MeshFormat::Off,
            Precision::F32,
            crate::io::off::parse_mesh,
            false,
        ),
        (
            MeshFormat::Stl,
            Precision::Auto,
            crate::io::stl::parse_mesh,
            false,
        ),
    ];
    for (format, precision, parse, exact) in cases {
        let layout = layout(format, precision, &v, 1.0);
        let mut out = Vec::new();
        write_mesh(&mut out, &layout, &MeshOut::new(&v, &t)).unwrap();
        // (The one triangle's corners are met in order, so STL's vertices
        // come back numbered as written.)
        let (read, tris) = parse(&out).unwrap();
        let stored: Vec<[f64; 3]> = v.iter().map(|&p| layout.stored(p)).collect();
        assert_eq!(read, stored, "{format:?} {precision:?}");
        assert_eq!(tris, t, "{format:?} {precision:?}");
        assert_eq!(stored == v, exact, "{format:?} {precision:?}");
    }
}

/// A closed octahedron of radius `r` around `c`, counter-clockwise from outside.
fn octahedron(c: [f64; 3], r: f64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let d = [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ];
    let v = d
        .iter()
        .map(|u: &[f64; 3]| [0, 1, 2].map(|a| c[a] + r * u[a] + 0.123_456_789 * a as f64))
        .collect();
    let t = vec![
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    (v, t)
}

/// The farthest any of `a` is from its partner in `b`.
fn farthest(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| crate::geom::length(crate::geom::sub(*p, *q)))
        .fold(0.0, f64::max)
}

#[test]
fn georeferenced_vertices_are_written_in_f64_where_f32_would_lose_the_tolerance() {
    // A 25 m object at UTM coordinates: the diagonal is about 43 m, so 1 % of
    // a 0.5 % tolerance is 2 mm; float32 values near y = 4,000,000 are 0.25 m
    // apart.
    let (v, t) = octahedron([500_000.0, 4_000_000.0, 100.0], 12.5);
    let allowed = AUTO_F32_SHARE * 0.005 * 43.3;
    assert_eq!(mesh::f32_step(4_000_012.5), 0.25);
    let auto = layout(MeshFormat::Ply, Precision::Auto, &v, allowed);
    assert_eq!(auto.coords(), Coords::F64);
    let f32 = layout(MeshFormat::Ply, Precision::F32, &v, allowed);
    for (l, far) in [(auto, false), (f32, true)] {
        let mut out = Vec::new();
        write_mesh(&mut out, &l, &MeshOut::new(&v, &t)).unwrap();
        let (read, _) = crate::io::ply::parse_mesh(&out).unwrap();
        let error = farthest(&read, &v);
        if far {
            assert!(error > allowed, "float32 moved vertices by only {error}");
        } else {
            assert_eq!(error, 0.0);
        }
    }
    // GLB keeps float32 but offsets from the centre: far below the allowance.
    let glb = layout(MeshFormat::Glb, Precision::Auto, &v, allowed);
    assert_eq!(glb.coords(), Coords::F32Offset);
    let stored: Vec<[f64; 3]> = v.iter().map(|&p| glb.stored(p)).collect();
    assert!(farthest(&stored, &v) < allowed / 1000.0);
    // STL cannot: auto keeps float32, f64 is refused.
    let stl = layout(MeshFormat::Stl, Precision::Auto, &v, allowed);
    assert_eq!(stl.coords(), Coords::F32);
    let e = MeshLayout::choose(MeshFormat::Stl, Precision::F64, &v, allowed).unwrap_err();
    assert!(e.contains("STL holds float32"), "{e}");
    // Near the origin float32 is close enough.
    let (v, _) = octahedron([0.0; 3], 12.5);
    let near = layout(MeshFormat::Ply, Precision::Auto, &v, allowed);
    assert_eq!(near.coords(), Coords::F32);
    assert_eq!(near.origin(), None);
}

#[test]
fn ply_holds_double_coordinates_normals_and_colours_that_read_back() {
    let (v, t) = octahedron([500_000.0, 4_000_000.0, 100.0], 12.5);
    let normals = crate::attributes::vertex_normals(&v, &t);
    let colors: Vec<[u8; 3]> = (0..v.len() as u8).map(|i| [i, 2 * i, 255 - i]).collect();
    let mesh = MeshOut {
        vertices: &v,
        triangles: &t,
        normals: Some(&normals),
        colors: Some(&colors),
    };
    let l = layout(MeshFormat::Ply, Precision::F64, &v, 0.0);
    let mut out = Vec::new();
    write_mesh(&mut out, &l, &mesh).unwrap();
    let end = out.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let head = std::str::from_utf8(&out[..end]).unwrap();
    for line in [
        "property double x\n",
        "property float nx\n",
        "property uchar red\n",
    ] {
        assert!(head.contains(line), "{head}");
    }
    // 24 + 12 + 3 bytes a vertex, 13 a face.
    assert_eq!(out.len() - end, v.len() * 39 + t.len() * 13);
    let (read, tris) = crate::io::ply::parse_mesh(&out).unwrap();
    assert_eq!(
        (read.as_slice(), tris.as_slice()),
        (v.as_slice(), t.as_slice())
    );
    let cloud = crate::io::ply::parse_cloud(&out).unwrap();
    assert_eq!(cloud.colors.as_deref(), Some(colors.as_slice()));
    let back: Vec<[f32; 3]> = cloud
        .normals
        .unwrap()
        .iter()
        .map(|n| n.map(|c| c as f32))
        .collect();
    assert_eq!(back, normals);
}

#[test]
fn obj_has_a_normal_per_vertex_and_faces_that_name_them() {
    let (v, t) = octahedron([0.0; 3], 1.0);
    let normals = crate::attributes::vertex_normals(&v, &t);
    let mesh = MeshOut {
        normals: Some(&normals),
        ..MeshOut::new(&v, &t)
    };
    let mut out = Vec::new();
    write_mesh(&mut out, &MeshLayout::plain(MeshFormat::Obj), &mesh).unwrap();
    let text = String::from_utf8(out.clone()).unwrap();
    assert_eq!(text.lines().filter(|l| l.starts_with("vn ")).count(), 6);
    assert!(text.contains("\nf 1//1 3//3 5//5\n"), "{text}");
    let (read, tris) = crate::io::obj::parse_mesh(&out).unwrap();
    assert_eq!((read, tris), (v, t));
}

#[test]
fn binary_stl_is_84_bytes_and_50_a_triangle_with_outward_face_normals() {
    let c = [500_000.0, 4_000_000.0, 100.0];
    let (v, t) = octahedron(c, 12.5);
    let l = MeshLayout::plain(MeshFormat::Stl);
    let mut out = Vec::new();
    write_mesh(&mut out, &l, &MeshOut::new(&v, &t)).unwrap();
    assert_eq!(out.len(), 84 + 50 * t.len());
    assert!(!out.starts_with(b"solid"));
    assert_eq!(&out[80..84], &(t.len() as u32).to_le_bytes());
    for (k, tri) in t.iter().enumerate() {
        let at = 84 + 50 * k;
        let f = |i: usize| f32::from_le_bytes(out[at + 4 * i..at + 4 * i + 4].try_into().unwrap());
        let n = [f(0), f(1), f(2)];
        let out_dir = crate::geom::sub(v[tri[0] as usize], c);
        let d: f64 = (0..3).map(|a| f64::from(n[a]) * out_dir[a]).sum();
        assert!(d > 0.0, "face {k}: {n:?}");
        assert_eq!(&out[at + 48..at + 50], &[0, 0]);
    }
    // STL stores corners: the reader numbers vertices as it meets them.
    let (read, tris) = crate::io::stl::parse_mesh(&out).unwrap();
    let corners = |v: &[[f64; 3]], t: &[[u32; 3]]| -> Vec<[[f64; 3]; 3]> {
        t.iter().map(|tri| tri.map(|i| v[i as usize])).collect()
    };
    let stored: Vec<[f64; 3]> = v.iter().map(|&p| l.stored(p)).collect();
    assert_eq!(corners(&read, &tris), corners(&stored, &t));
}

#[test]
fn mismatched_lengths_and_bad_indices_are_invalid_input() {
    let mut out = Vec::new();
    let e = write_points_ply(&mut out, &[[0.0; 3]], &[[0; 3]; 2], None).unwrap_err();
    assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
    let e = write_points_ply(&mut out, &[[0.0; 3]], &[], Some(("a b", &[1]))).unwrap_err();
    assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
    let obj = MeshLayout::plain(MeshFormat::Obj);
    let e = write_mesh(&mut out, &obj, &MeshOut::new(&[[0.0; 3]], &[[0, 0, 1]])).unwrap_err();
    assert!(e.to_string().contains("triangle 0"), "{e}");
    let v = [[0.0; 3]; 3];
    for format in [MeshFormat::Ply, MeshFormat::Glb] {
        let normals = [[0.0, 0.0, 1.0]; 2];
        let mesh = MeshOut {
            normals: Some(&normals),
            ..MeshOut::new(&v, &[[0, 1, 2]])
        };
        let e = write_mesh(&mut out, &MeshLayout::plain(format), &mesh).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
        let colors = [[0u8; 3]; 4];
        let mesh = MeshOut {
            colors: Some(&colors),
            ..MeshOut::new(&v, &[[0, 1, 2]])
        };
        let e = write_mesh(&mut out, &MeshLayout::plain(format), &mesh).unwrap_err();
        assert!(e.to_string().contains("4 colours for 3 vertices"), "{e}");
    }
}

#[test]
fn a_mesh_that_cannot_be_written_leaves_no_file_in_any_format() {
    let dir = scratch_dir("refused");
    let v = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let colors = [[0u8; 3]; 2];
    for ext in ["ply", "obj", "off", "stl", "glb"] {
        let path = dir.join(format!("mesh.{ext}"));
        let format = MeshFormat::from_path(&path).unwrap();
        let mesh = MeshOut {
            colors: Some(&colors),
            ..MeshOut::new(&v, &[[0, 1, 2]])
        };
        let e = write_to(&path, |w| write_mesh(w, &MeshLayout::plain(format), &mesh)).unwrap_err();
        assert!(
            e.contains(&*path.display().to_string()) && e.contains("2 colours"),
            "{e}"
        );
    }
    assert_eq!(fs::read_dir(&dir).unwrap().count(), 0, "a file was left");
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_target_name_at_the_length_limit_is_written_and_a_failure_leaves_nothing() {
    let dir = scratch_dir("long");
    // 250 bytes: legal (NAME_MAX is 255), longer than 255 with a suffix.
    let path = dir.join(format!("{}.ply", "a".repeat(246)));
    write_atomic(&path, |w| w.write_all(b"whole")).unwrap();
    assert_eq!(fs::read(&path).unwrap(), b"whole");
    let e = write_atomic(&path, |w| {
        w.write_all(b"half")?;
        Err(io::Error::other("refused"))
    })
    .unwrap_err();
    assert!(e.to_string().ends_with("cannot write: refused"), "{e}");
    let left: Vec<_> = fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(
        left,
        std::slice::from_ref(&path),
        "a temporary file was left"
    );
    assert_eq!(fs::read(&path).unwrap(), b"whole");
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn scratch_names_are_short_and_new_for_every_call() {
    let dir = scratch_dir("scratch");
    let (a, _) = create_scratch(&dir, "tmp").unwrap();
    let (b, _) = create_scratch(&dir, "tmp").unwrap();
    assert_ne!(a, b);
    for p in [&a, &b] {
        let name = p.file_name().unwrap().to_str().unwrap();
        assert!(name.starts_with(".vsaqem-") && name.len() < 50, "{name}");
    }
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn obj_keeps_full_f64_precision() {
    let mut out = Vec::new();
    let x = 0.1f64 + 0.2;
    let obj = MeshLayout::plain(MeshFormat::Obj);
    write_mesh(&mut out, &obj, &MeshOut::new(&[[x, 0.0, 0.0]], &[])).unwrap();
    assert!(String::from_utf8(out)
        .unwrap()
        .contains("v 0.30000000000000004 0 0\n"));
}

fn scratch_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vsaqem-{name}-{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

#[cfg(unix)]
#[test]
fn a_symlink_target_keeps_the_link_and_gets_the_content() {
    let dir = scratch_dir("symlink");
    let real = dir.join("real.txt");
    fs::write(&real, "old").unwrap();
    let link = dir.join("link.txt");
    std::os::unix::fs::symlink(&real, &link).unwrap();
    write_atomic(&link, |w| w.write_all(b"new")).unwrap();
    assert!(fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(fs::read_to_string(&real).unwrap(), "new");
    fs::remove_dir_all(&dir).unwrap();
}

/// A pipe stands in for `/dev/null` and `/dev/stdout`: renaming a file over it
/// would turn the special file into a plain one (as root, `/dev/null` itself).
#[cfg(unix)]
#[test]
fn a_pipe_is_written_in_place_not_replaced() {
    use std::io::Read;
    use std::os::unix::fs::FileTypeExt;
    let dir = scratch_dir("fifo");
    let fifo = dir.join("out.ply");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if !made.is_ok_and(|s| s.success()) {
        eprintln!("skipped: mkfifo is not available");
        return;
    }
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || {
            let mut s = String::new();
            File::open(fifo).unwrap().read_to_string(&mut s).unwrap();
            s
        })
    };
    write_atomic(&fifo, |w| w.write_all(b"through the pipe")).unwrap();
    // Checked before joining: had the pipe been replaced, the reader would wait forever.
    assert!(fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
    let leftovers = fs::read_dir(&dir).unwrap().count();
    assert_eq!(leftovers, 1, "no temporary file beside the pipe");
    assert_eq!(reader.join().unwrap(), "through the pipe");
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn mesh_format_from_extension() {
    assert_eq!(
        MeshFormat::from_path(Path::new("a/B.OBJ")),
        Ok(MeshFormat::Obj)
    );
    assert_eq!(
        MeshFormat::from_path(Path::new("m.stl")),
        Ok(MeshFormat::Stl)
    );
    assert_eq!(
        MeshFormat::from_path(Path::new("m.GLB")),
        Ok(MeshFormat::Glb)
    );
    assert_eq!(MeshFormat::from_path(Path::new("-")), Ok(MeshFormat::Ply));
    let e = MeshFormat::from_path(Path::new("m.wrl")).unwrap_err();
    assert!(
        e.contains("'.wrl'") && e.contains(".ply, .obj, .off, .stl, .glb"),
        "{e}"
    );
    let e = MeshFormat::from_path(Path::new("m.gltf")).unwrap_err();
    assert!(e.contains("use .glb"), "{e}");
}
