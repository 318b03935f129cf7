//! Contract tests of the host's file formats: round trips through the writers, the same
//! values from every PLY encoding, and hostile inputs (truncated, lying headers,
//! non-finite values, garbage) that must give a `ReadError` naming the file and the
//! place, quickly and without a panic or a huge allocation.
//!
//! Fixtures are written by the tests into `CARGO_TARGET_TMPDIR`; no data file is
//! committed. The real models in `../shared/data` are read when present.

mod common;
use common::{check_msg, cloud_err};

use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

use vsaqem::io::{
    read_cloud, read_mesh, write_atomic, write_mesh, write_points_ply, Cloud, MeshFormat,
    MeshLayout, MeshOut,
};

fn dir(name: &str) -> PathBuf {
    common::dir("io_hostile", name)
}

fn put(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    fs::write(&p, bytes).unwrap();
    p
}

fn mesh_err(path: &Path, details: &[&str]) -> String {
    let msg = match read_mesh(path) {
        Ok((v, t)) => panic!(
            "{} read as {} vertices {} tris",
            path.display(),
            v.len(),
            t.len()
        ),
        Err(e) => e.to_string(),
    };
    check_msg(path, &msg, details);
    msg
}

fn le_f32(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

const XYZ_HEAD: &str = "property float x\nproperty float y\nproperty float z\n";

fn ply_head(format: &str, n: u64, extra: &str) -> String {
    format!("ply\nformat {format} 1.0\nelement vertex {n}\n{XYZ_HEAD}{extra}end_header\n")
}

// ---------------------------------------------------------------- round trips

#[test]
fn points_ply_round_trips_through_write_atomic() {
    let d = dir("points_ply");
    let pts: Vec<[f64; 3]> = (0..1000)
        .map(|i| {
            let t = i as f64 * 0.01;
            [t.sin(), t.cos(), t * 0.5 - 2.0]
        })
        .collect();
    let colors: Vec<[u8; 3]> = (0..1000).map(|i| [i as u8, 0, 255]).collect();
    let labels: Vec<u32> = (0..1000).map(|i| i / 7).collect();
    let path = d.join("labels.ply");
    write_atomic(&path, |w| {
        write_points_ply(w, &pts, &colors, Some(("cluster", &labels)))
    })
    .unwrap();
    let c = read_cloud(&path).unwrap();
    assert_eq!(c.normals, None);
    assert_eq!(c.positions.len(), pts.len());
    for (a, b) in c.positions.iter().zip(&pts) {
        for k in 0..3 {
            assert_eq!(a[k], b[k] as f32 as f64, "PLY stores f32");
        }
    }
}

fn sample_mesh() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let v = vec![
        [0.1, 0.2, 0.3],
        [1.0 / 3.0, -2.5e-7, 1e5],
        [-0.0, 7.0, 0.30000000000000004],
        [1.5, 1.5, -1.5],
    ];
    let t = vec![[0, 1, 2], [0, 2, 3], [3, 2, 1], [0, 3, 1]];
    (v, t)
}

#[test]
fn obj_and_off_round_trip_exactly() {
    let d = dir("obj_off");
    let (v, t) = sample_mesh();
    for name in ["m.obj", "m.OFF"] {
        let path = d.join(name);
        let fmt = MeshFormat::from_path(&path).unwrap();
        write_atomic(&path, |w| {
            write_mesh(w, &MeshLayout::plain(fmt), &MeshOut::new(&v, &t))
        })
        .unwrap();
        let (v2, t2) = read_mesh(&path).unwrap();
        assert_eq!(v2, v, "{name}: f64 coordinates must survive text exactly");
        assert_eq!(t2, t, "{name}");
    }
}

#[test]
fn ply_mesh_round_trips_with_f32_vertices() {
    let d = dir("ply_mesh");
    let (v, t) = sample_mesh();
    let path = d.join("m.ply");
    write_atomic(&path, |w| {
        write_mesh(
            w,
            &MeshLayout::plain(MeshFormat::Ply),
            &MeshOut::new(&v, &t),
        )
    })
    .unwrap();
    let (v2, t2) = read_mesh(&path).unwrap();
    let v32: Vec<[f64; 3]> = v.iter().map(|p| p.map(|c| c as f32 as f64)).collect();
    assert_eq!(v2, v32);
    assert_eq!(t2, t);
    // The same file read as a cloud gives the vertices.
    assert_eq!(read_cloud(&path).unwrap().positions, v32);
}

/// A cloud written as ascii, binary LE and binary BE PLY with mixed types, extra
/// scalar and list properties, and elements before and after the vertices.
fn ply_variants(dir: &Path) -> Vec<PathBuf> {
    let pts: [[f64; 3]; 3] = [[1.5, -2.0, 3.25], [0.0, 100.0, -0.125], [7.0, 8.0, 9.0]];
    let nrm: [[f32; 3]; 3] = [[0.0, 0.0, 1.0], [0.6, 0.8, 0.0], [1.0, 0.0, 0.0]];
    let head = |format: &str| {
        format!(
            "ply\r\nformat {format} 1.0\r\ncomment mixed types\r\nobj_info scanner 1\r\n\
             element camera 1\r\nproperty list uchar float view\r\nproperty short id\r\n\
             element vertex 3\r\nproperty double x\r\nproperty uchar quality\r\n\
             property float32 y\r\nproperty list uint8 int32 junk\r\nproperty double z\r\n\
             property float nx\r\nproperty float ny\r\nproperty float nz\r\n\
             element face 2\r\nproperty list uchar int vertex_indices\r\n\
             property uint16 flags\r\nend_header\r\n"
        )
    };
    let mut ascii = head("ascii");
    ascii.push_str("2 0.5 0.25 -3\n");
    for (i, (p, n)) in pts.iter().zip(&nrm).enumerate() {
        ascii.push_str(&format!(
            "{} {} {} {} {} {} {} {} {}\n",
            p[0],
            i * 10,
            p[1],
            i,
            "5 ".repeat(i).trim_end(),
            p[2],
            n[0],
            n[1],
            n[2]
        ));
    }
    // The format string above inserts an empty field when the list is empty; squash it.
    let ascii = ascii.replace("  ", " ");
    let ascii = format!("{ascii}3 0 1 2 7\n4 0 1 2 0 65535\n");

    let binary = |big: bool| {
        let mut b = head(if big {
            "binary_big_endian"
        } else {
            "binary_little_endian"
        })
        .into_bytes();
        macro_rules! put {
            ($v:expr) => {
                if big {
                    b.extend_from_slice(&$v.to_be_bytes())
                } else {
                    b.extend_from_slice(&$v.to_le_bytes())
                }
            };
        }
        put!(2u8);
        put!(0.5f32);
        put!(0.25f32);
        put!(-3i16);
        for (i, (p, n)) in pts.iter().zip(&nrm).enumerate() {
            put!(p[0]);
            put!((i * 10) as u8);
            put!(p[1] as f32);
            put!(i as u8);
            for _ in 0..i {
                put!(5i32);
            }
            put!(p[2]);
            for c in n {
                put!(*c);
            }
        }
        put!(3u8);
        for i in [0i32, 1, 2] {
            put!(i);
        }
        put!(7u16);
        put!(4u8);
        for i in [0i32, 1, 2, 0] {
            put!(i);
        }
        put!(65535u16);
        b
    };
    vec![
        put(dir, "ascii.ply", ascii),
        put(dir, "le.PLY", binary(false)),
        put(dir, "be.ply", binary(true)),
    ]
}

#[test]
fn ply_ascii_le_and_be_read_the_same_values() {
    let d = dir("ply_variants");
    let want = Cloud {
        positions: vec![[1.5, -2.0, 3.25], [0.0, 100.0, -0.125], [7.0, 8.0, 9.0]],
        normals: Some(vec![
            [0.0, 0.0, 1.0],
            [0.6f32 as f64, 0.8f32 as f64, 0.0],
            [1.0, 0.0, 0.0],
        ]),
        ..Cloud::default()
    };
    for path in ply_variants(&d) {
        let c = read_cloud(&path).unwrap_or_else(|e| panic!("{e}"));
        if path.ends_with("ascii.ply") {
            // ASCII is parsed straight to f64, not through f32.
            assert_eq!(c.positions, want.positions);
            assert_eq!(c.normals.as_ref().unwrap()[1][0], 0.6);
        } else {
            assert_eq!(c, want, "{}", path.display());
        }
        let (v, t) = read_mesh(&path).unwrap();
        assert_eq!(v, want.positions);
        assert_eq!(t, vec![[0, 1, 2], [0, 1, 2], [0, 2, 0]]);
    }
}

#[test]
fn xyz_extensions_and_separators() {
    let d = dir("xyz_ext");
    let text = "# x y z nx ny nz\n1 2 3 0 0 1\n\n4,5,6,nan,0,0\r\n  7\t8 9 0 0 0\n";
    for name in ["a.xyz", "a.XYZN", "a.txt", "a.pts"] {
        let c = read_cloud(&put(&d, name, text)).unwrap();
        assert_eq!(
            c.positions,
            vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]]
        );
        let n = c.normals.unwrap();
        assert!(n[1][0].is_nan(), "normals pass through unchanged");
        assert_eq!(n[2], [0.0, 0.0, 0.0]);
    }
    let c = read_cloud(&put(&d, "b.xyz", "1 2 3\n4 5 6")).unwrap();
    assert_eq!(c.positions.len(), 2);
    assert_eq!(c.normals, None);
}

#[test]
fn pcd_ascii_and_binary_read_the_same_values() {
    let d = dir("pcd");
    let head = |data: &str| {
        format!(
            "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n\
             FIELDS x y z rgb normal_x normal_y normal_z curvature hist\n\
             SIZE 4 4 4 4 4 4 4 4 2\nTYPE F F F U F F F F I\nCOUNT 1 1 1 1 1 1 1 1 3\n\
             WIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA {data}\n"
        )
    };
    let ascii = head("ascii") + "1 2 3 255 0 0 1 0.5 1 2 3\n4 5 6 0 1 0 0 0 -1 -2 -3\n";
    let mut bin = head("binary").into_bytes();
    for row in [[1.0f32, 2.0, 3.0], [4.0, 5.0, 6.0]] {
        bin.extend(le_f32(&row));
        bin.extend(0u32.to_le_bytes());
        bin.extend(le_f32(&[row[0] - 1.0, 0.0, 1.0, 0.5]));
        bin.extend([1i16, 2, 3].iter().flat_map(|v| v.to_le_bytes()));
    }
    let a = read_cloud(&put(&d, "a.pcd", ascii)).unwrap();
    let b = read_cloud(&put(&d, "b.PCD", bin)).unwrap();
    assert_eq!(a.positions, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
    assert_eq!(a.positions, b.positions);
    assert_eq!(a.normals, Some(vec![[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]));
    assert_eq!(b.normals, Some(vec![[0.0, 0.0, 1.0], [3.0, 0.0, 1.0]]));
}

// ------------------------------------------------------------- hostile: PLY

#[test]
fn ply_truncated_binary_body_names_counts_and_offset() {
    let d = dir("ply_trunc_bin");
    let mut b = ply_head("binary_little_endian", 3, "").into_bytes();
    let body_at = b.len();
    b.extend(le_f32(&[1.0, 2.0, 3.0, 4.0, 5.0]));
    let p = put(&d, "short.ply", &b);
    cloud_err(
        &p,
        &[
            "header declares 3 vertices of 12 bytes but only 20 bytes of data follow",
            &format!("byte {body_at}"),
        ],
    );
    // Truncated inside a list of the vertex element (the only way to get past the
    // up-front size check): the error names the vertex and the property.
    let mut b = ply_head(
        "binary_little_endian",
        2,
        "property list uchar float extra\n",
    )
    .into_bytes();
    b.extend(le_f32(&[1.0, 2.0, 3.0]));
    b.push(0);
    b.extend(le_f32(&[1.0, 2.0, 3.0]));
    b.push(3);
    b.extend(le_f32(&[9.0]));
    cloud_err(
        &put(&d, "list.ply", &b),
        &["vertex 1: list 'extra' of length 3 needs 12 bytes but only 4 remain"],
    );
}

#[test]
fn ply_every_truncation_of_a_binary_file_is_an_error() {
    let d = dir("ply_every_trunc");
    let full = fs::read(&ply_variants(&d)[1]).unwrap();
    for cut in 0..full.len() {
        let p = put(&d, "cut.ply", &full[..cut]);
        assert!(read_cloud(&p).is_err(), "cut at {cut} read fine");
        assert!(read_mesh(&p).is_err(), "cut at {cut} read fine as mesh");
    }
    assert!(read_cloud(&put(&d, "cut.ply", &full)).is_ok());
}

#[test]
fn ply_truncated_ascii_body_names_the_line() {
    let d = dir("ply_trunc_ascii");
    let p = put(&d, "short.ply", ply_head("ascii", 3, "") + "1 2 3\n4 5 6\n");
    cloud_err(&p, &["line 10: file ends after 2 of 3 vertices"]);
    let p = put(&d, "half.ply", ply_head("ascii", 2, "") + "1 2 3\n4 5\n");
    cloud_err(&p, &["line 9: vertex 1: line ends before property 'z'"]);
}

#[test]
fn ply_huge_counts_fail_fast_without_allocating() {
    let d = dir("ply_huge");
    let mut b = ply_head("binary_little_endian", 4_000_000_000, "").into_bytes();
    b.extend([0u8; 120]);
    cloud_err(
        &put(&d, "big.ply", &b),
        &["header declares 4000000000 vertices of 12 bytes but only 120 bytes of data follow"],
    );
    let b = ply_head("binary_big_endian", u64::MAX, "");
    cloud_err(&put(&d, "max.ply", b), &["18446744073709551615 vertices"]);
    // A huge element that is not the vertex element is checked the same way.
    let b = format!(
        "ply\nformat binary_little_endian 1.0\nelement junk 4000000000\nproperty double a\n\
         element vertex 1\n{XYZ_HEAD}end_header\n"
    );
    cloud_err(
        &put(&d, "junk.ply", b),
        &["4000000000 'junk' elements of 8 bytes"],
    );
    let b = ply_head("ascii", 4_000_000_000, "") + "1 2 3\n";
    cloud_err(
        &put(&d, "big_ascii.ply", b),
        &["file ends after 1 of 4000000000 vertices"],
    );
    // Too large for u64 at all.
    let b = ply_head("ascii", 1, "").replace("vertex 1", "vertex 99999999999999999999");
    cloud_err(
        &put(&d, "overflow.ply", b),
        &["line 3", "not a non-negative integer"],
    );
}

#[test]
fn ply_list_lengths_negative_or_huge_in_vertex_element() {
    let d = dir("ply_lists");
    let extra = "property list int uchar l\n";
    let p = put(
        &d,
        "neg.ply",
        ply_head("ascii", 1, extra) + "1 2 3 -2 1 1\n",
    );
    cloud_err(&p, &["line 9: vertex 0: list 'l' has length -2"]);
    let mut b = ply_head("binary_little_endian", 1, extra).into_bytes();
    b.extend(le_f32(&[1.0, 2.0, 3.0]));
    b.extend((-5i32).to_le_bytes());
    cloud_err(
        &put(&d, "neg_bin.ply", &b),
        &["vertex 0: list 'l' has negative length -5"],
    );
    let extra = "property list uint float l\n";
    let mut b = ply_head("binary_big_endian", 1, extra).into_bytes();
    b.extend([0u8; 12]);
    b.extend(4_000_000_000u32.to_be_bytes());
    cloud_err(
        &put(&d, "huge_bin.ply", &b),
        &["list 'l' of length 4000000000 needs 16000000000 bytes but only 0 remain"],
    );
}

#[test]
fn ply_non_finite_positions_name_the_vertex() {
    let d = dir("ply_nan");
    let mut b = ply_head("binary_little_endian", 3, "").into_bytes();
    b.extend(le_f32(&[0.0, 0.0, 0.0, 1.0, f32::NAN, 0.0, 0.0, 0.0, 0.0]));
    cloud_err(&put(&d, "nan.ply", &b), &["vertex 1: y is NaN"]);
    let p = put(
        &d,
        "inf.ply",
        ply_head("ascii", 2, "") + "1 2 3\n1 2 -inf\n",
    );
    cloud_err(&p, &["line 9: vertex 1: z is -inf"]);
    // Non-finite normals are not an error.
    let p = put(
        &d,
        "nrm.ply",
        ply_head(
            "ascii",
            1,
            "property float nx\nproperty float ny\nproperty float nz\n",
        ) + "1 2 3 nan 0 inf\n",
    );
    let n = read_cloud(&p).unwrap().normals.unwrap();
    assert!(n[0][0].is_nan() && n[0][2].is_infinite());
}

#[test]
fn ply_malformed_headers() {
    let d = dir("ply_header");
    let cases: &[(&str, String, &[&str])] = &[
        ("empty.ply", String::new(), &["file is empty"]),
        (
            "magic.ply",
            "PLY\nformat ascii 1.0\n".into(),
            &["line 1", "not a PLY file"],
        ),
        (
            "noend.ply",
            format!("ply\nformat ascii 1.0\nelement vertex 1\n{XYZ_HEAD}1 2 3\n"),
            &["line 7: data line \"1 2 3\" before end_header: the end_header line is missing"],
        ),
        (
            "format.ply",
            ply_head("binary_middle_endian", 1, ""),
            &["line 2: unknown format \"binary_middle_endian\""],
        ),
        (
            "noformat.ply",
            format!("ply\nelement vertex 1\n{XYZ_HEAD}end_header\n1 2 3\n"),
            &["no \"format\" line"],
        ),
        (
            "version.ply",
            ply_head("ascii", 1, "").replace("1.0", "2.0"),
            &["line 2: not supported: PLY version \"2.0\""],
        ),
        (
            "typo.ply",
            ply_head("ascii", 1, "property flaot intensity\n") + "1 2 3 4\n",
            &["line 7: unknown property type \"flaot\""],
        ),
        (
            "listtypo.ply",
            ply_head("ascii", 1, "property list uchar integer l\n"),
            &["line 7: unknown property type \"integer\""],
        ),
        (
            "floatlen.ply",
            ply_head("ascii", 1, "property list float int l\n"),
            &["line 7: list l: length type float32 is not an integer"],
        ),
        (
            "noy.ply",
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float z\n\
             end_header\n1 2\n"
                .into(),
            &["line 3: element vertex has no property 'y'"],
        ),
        (
            "listx.ply",
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\n\
             property float y\nproperty float z\nend_header\n1 1 2 3\n"
                .into(),
            &["vertex property 'x' is a list"],
        ),
        (
            "novertex.ply",
            "ply\nformat ascii 1.0\nelement face 0\nend_header\n".into(),
            &["no \"element vertex\""],
        ),
        (
            "orphan.ply",
            "ply\nformat ascii 1.0\nproperty float x\nend_header\n".into(),
            &["line 3: property before any element"],
        ),
        (
            "keyword.ply",
            ply_head("ascii", 1, "weird stuff\n"),
            &["line 7: unknown header line starting with \"weird\""],
        ),
        (
            "zero.ply",
            ply_head("ascii", 0, ""),
            &["line 3: element vertex declares 0 vertices"],
        ),
        (
            "headeronly.ply",
            ply_head("ascii", 2, ""),
            &["line 8: file ends after 0 of 2 vertices"],
        ),
        (
            "partialnormals.ply",
            ply_head("ascii", 1, "property float nx\n") + "1 2 3 4\n",
            &["element vertex has no property 'ny'"],
        ),
    ];
    for (name, text, details) in cases {
        cloud_err(&put(&d, name, text), details);
    }
}

#[test]
fn ply_ascii_wrong_columns_and_garbage() {
    let d = dir("ply_ascii_bad");
    let p = put(
        &d,
        "extra.ply",
        ply_head("ascii", 2, "") + "1 2 3\n4 5 6 7\n",
    );
    cloud_err(
        &p,
        &["line 9: vertex 1: 4 values on the line, the header declares 3"],
    );
    let p = put(
        &d,
        "garbage.ply",
        ply_head("ascii", 2, "") + "1 2 3\n4 five 6\n",
    );
    cloud_err(
        &p,
        &["line 9: vertex 1: property 'y': \"five\" is not a valid float32"],
    );
    let p = put(
        &d,
        "uchar.ply",
        ply_head("ascii", 1, "property uchar q\n") + "1 2 3 256\n",
    );
    cloud_err(&p, &["property 'q': \"256\" is not a valid uint8"]);
    let p = put(
        &d,
        "binary.ply",
        ply_head("ascii", 1, "") + "1 2 \u{0}\u{ff}\n",
    );
    cloud_err(&p, &["line 8: vertex 0: property 'z'"]);
    let mut b = ply_head("ascii", 1, "").into_bytes();
    b.extend([b'1', b' ', 0xff, 0xfe, b'\n']);
    cloud_err(&put(&d, "utf8.ply", &b), &["line 8: not text"]);
}

#[test]
fn ply_mesh_bad_faces() {
    let d = dir("ply_faces");
    let head = |nf: u64, fmt: &str| {
        format!(
            "ply\nformat {fmt} 1.0\nelement vertex 3\n{XYZ_HEAD}element face {nf}\n\
             property list uchar int vertex_indices\nend_header\n"
        )
    };
    let verts = "0 0 0\n1 0 0\n0 1 0\n";
    let p = put(
        &d,
        "range.ply",
        head(2, "ascii") + verts + "3 0 1 2\n3 0 1 3\n",
    );
    mesh_err(
        &p,
        &["line 14: face 1: vertex index 3 is out of range (the file has 3 vertices)"],
    );
    let p = put(&d, "neg.ply", head(1, "ascii") + verts + "3 0 -1 2\n");
    mesh_err(&p, &["face 0: vertex index -1 is out of range"]);
    let p = put(&d, "two.ply", head(1, "ascii") + verts + "2 0 1\n");
    mesh_err(&p, &["face 0: 2 vertex indices, a face needs at least 3"]);
    let mut b = head(1, "binary_little_endian").into_bytes();
    b.extend(le_f32(&[0.0; 9]));
    b.push(3);
    for i in [0i32, 1, 7] {
        b.extend(i.to_le_bytes());
    }
    mesh_err(
        &put(&d, "range_bin.ply", &b),
        &["face 0: vertex index 7 is out of range"],
    );
    let p = put(&d, "noface.ply", ply_head("ascii", 1, "") + "1 2 3\n");
    mesh_err(&p, &["no \"element face\""]);
    let p = put(
        &d,
        "floatidx.ply",
        head(0, "ascii").replace("uchar int", "uchar float") + verts,
    );
    mesh_err(&p, &["'vertex_indices' is not a list of integers"]);
}

// ------------------------------------------------------------- hostile: XYZ

#[test]
fn xyz_hostile_inputs() {
    let d = dir("xyz_bad");
    cloud_err(&put(&d, "empty.xyz", ""), &["file is empty"]);
    cloud_err(&put(&d, "blank.xyz", "\n\n# only\n"), &["no points"]);
    cloud_err(
        &put(&d, "cols.xyz", "1 2 3 4 5 6\n1 2 3 4 5 6\n1 2 3 4\n"),
        &["line 3: expected 6 numbers like line 1, found 4"],
    );
    cloud_err(
        &put(&d, "first.xyz", "# h\n1 2 3 4 5\n"),
        &["line 2: expected 3, 4, 6, 7, 9 or 10 numbers, found 5"],
    );
    cloud_err(
        &put(&d, "garbage.xyz", "1 2 3\n1 2 3\n1e 2 3\n"),
        &["line 3: column 1: \"1e\" is not a number"],
    );
    cloud_err(
        &put(&d, "nan.xyz", "1 2 3\n\n1 NaN 3\n"),
        &["line 3: vertex 1: y is NaN"],
    );
    cloud_err(
        &put(&d, "inf.xyz", "1 2 inf 0 0 1\n"),
        &["line 1: vertex 0: z is inf"],
    );
    cloud_err(
        &put(&d, "bin.xyz", [0xffu8, 0xfe, 0, 1]),
        &["line 1: not text"],
    );
    let e = cloud_err(
        &put(&d, "huge.xyz", format!("1 2 {}", "x".repeat(500))),
        &["line 1: column 3"],
    );
    assert!(e.len() < 200, "long tokens are cut in messages: {e}");
}

// ------------------------------------------------------------- hostile: PCD

fn pcd_head(points: &str, data: &str) -> String {
    format!(
        "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\n\
         POINTS {points}\nDATA {data}\n"
    )
}

#[test]
fn pcd_hostile_inputs() {
    let d = dir("pcd_bad");
    cloud_err(&put(&d, "empty.pcd", ""), &["file is empty"]);
    cloud_err(
        &put(
            &d,
            "compressed.pcd",
            pcd_head("2", "binary_compressed") + "\u{1}\u{2}",
        ),
        &["binary_compressed data needs two 4-byte sizes, only 2 bytes follow (at byte 107)"],
    );
    let mut b = pcd_head("2", "binary").into_bytes();
    b.extend(le_f32(&[1.0, 2.0, 3.0, 4.0]));
    cloud_err(
        &put(&d, "short.pcd", &b),
        &["header declares 2 points of 12 bytes but only 16 bytes of data follow"],
    );
    let b = pcd_head("4000000000", "binary").replace("WIDTH 2", "WIDTH 4000000000");
    cloud_err(&put(&d, "huge.pcd", b), &["4000000000 points of 12 bytes"]);
    let b = pcd_head("4000000000", "ascii").replace("WIDTH 2", "WIDTH 4000000000") + "1 2 3\n";
    cloud_err(
        &put(&d, "huge_ascii.pcd", b),
        &["line 11: file ends after 1 of 4000000000 points"],
    );
    cloud_err(
        &put(&d, "mismatch.pcd", pcd_head("3", "ascii")),
        &["line 8: POINTS 3 disagrees with WIDTH * HEIGHT = 2"],
    );
    cloud_err(
        &put(
            &d,
            "zero.pcd",
            pcd_head("0", "ascii").replace("WIDTH 2", "WIDTH 0"),
        ),
        &["line 9: the header declares 0 points"],
    );
    cloud_err(
        &put(&d, "cols.pcd", pcd_head("2", "ascii") + "1 2 3\n4 5\n"),
        &["line 11: expected 3 values, found 2"],
    );
    cloud_err(
        &put(&d, "garbage.pcd", pcd_head("2", "ascii") + "1 2 3\n4 x 6\n"),
        &["line 11: field 'y': \"x\" is not a valid float32"],
    );
    cloud_err(
        &put(
            &d,
            "allnan.pcd",
            pcd_head("2", "ascii") + "nan 2 3\n4 5 inf\n",
        ),
        &["no valid points: all 2 have a NaN or infinite coordinate"],
    );
    cloud_err(
        &put(
            &d,
            "type.pcd",
            pcd_head("2", "ascii").replace("TYPE F F F", "TYPE F Q F"),
        ),
        &["field 'y': TYPE \"Q\" with SIZE \"4\" is not a PCD type"],
    );
    cloud_err(
        &put(
            &d,
            "noz.pcd",
            pcd_head("2", "ascii").replace("x y z", "x y w"),
        ),
        &["line 2: FIELDS has no 'z'"],
    );
    cloud_err(
        &put(
            &d,
            "nodata.pcd",
            "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 1\n",
        ),
        &["no DATA line"],
    );
    cloud_err(
        &put(&d, "datakind.pcd", pcd_head("2", "binary_zipped")),
        &["line 9: unknown DATA kind \"binary_zipped\""],
    );
}

// ------------------------------------------------------- hostile: OBJ, OFF

#[test]
fn obj_and_off_hostile_inputs() {
    let d = dir("mesh_bad");
    mesh_err(&put(&d, "empty.obj", ""), &["file is empty"]);
    mesh_err(&put(&d, "empty.off", ""), &["file is empty"]);
    mesh_err(
        &put(
            &d,
            "range.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 3 2 -4\n",
        ),
        &["line 5: face 1: vertex reference \"-4\" is out of range"],
    );
    mesh_err(
        &put(&d, "garbage.obj", "v 0 0 zero\n"),
        &["line 1: vertex 0: z: \"zero\" is not a number"],
    );
    mesh_err(
        &put(&d, "nan.obj", "v 0 0 0\nv 0 nan 0\n"),
        &["line 2: vertex 1: y is NaN"],
    );
    mesh_err(
        &put(&d, "fgarbage.obj", "v 0 0 0\nf 1 1 a/1\n"),
        &["line 2: face 0: vertex reference \"a/1\" is not an integer"],
    );
    mesh_err(&put(&d, "none.obj", "# nothing\n"), &["no vertices"]);
    mesh_err(
        &put(
            &d,
            "range.off",
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
        ),
        &["line 6: face 0: vertex index \"3\" is out of range (the file has 3 vertices)"],
    );
    mesh_err(
        &put(&d, "huge.off", "OFF\n4000000000 4000000000 0\n0 0 0\n"),
        &["line 4: file ends after 1 of 4000000000 vertices"],
    );
    mesh_err(
        &put(
            &d,
            "short.off",
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n",
        ),
        &["line 6: face 0: 4 vertices declared, 3 indices on the line"],
    );
    mesh_err(&put(&d, "magic.off", "PLY\n"), &["line 1: not an OFF file"]);
    mesh_err(
        &put(&d, "inf.off", "OFF\n1 0 0\n0 inf 0\n"),
        &["line 3: vertex 0: y is inf"],
    );
    mesh_err(&put(&d, "m.stl", "solid"), &["no triangles"]);
    mesh_err(
        &put(&d, "m.glb", "glTF"),
        &["unknown extension '.glb'", ".ply, .obj, .off, .stl"],
    );
}

#[test]
fn unknown_extension_and_missing_file() {
    let d = dir("ext");
    cloud_err(
        &put(&d, "scan.fls", "x"),
        &[
            "unknown extension '.fls'",
            ".ply, .xyz, .xyzn, .txt, .pts, .csv, .pcd, .las, .laz, .e57, .obj, .off, .stl",
        ],
    );
    cloud_err(&put(&d, "noext", "1 2 3\n"), &["no file extension"]);
    let missing = d.join("missing.ply");
    let e = read_cloud(&missing).unwrap_err();
    assert!(
        std::error::Error::source(&e).is_some(),
        "I/O errors keep their source"
    );
    check_msg(&missing, &e.to_string(), &["cannot read file"]);
}

/// Deterministic byte flips and cuts of valid files: any outcome but a panic is fine.
#[test]
fn mutated_files_never_panic() {
    let d = dir("mutate");
    let mut seeds: Vec<(String, Vec<u8>)> = ply_variants(&d)
        .iter()
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().to_lowercase();
            (name, fs::read(p).unwrap())
        })
        .collect();
    seeds.push(("a.xyz".into(), b"1 2 3 0 0 1\n4 5 6 1 0 0\n".to_vec()));
    seeds.push((
        "a.pcd".into(),
        (pcd_head("2", "ascii") + "1 2 3\n4 5 6\n").into_bytes(),
    ));
    let mut bin = pcd_head("2", "binary").into_bytes();
    bin.extend(le_f32(&[1.0; 6]));
    seeds.push(("b.pcd".into(), bin));
    seeds.push((
        "a.obj".into(),
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/2 -1/3\n".to_vec(),
    ));
    seeds.push((
        "a.off".into(),
        b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n".to_vec(),
    ));
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut rand = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let special = [b'\n', b' ', b'-', b'9', 0, 0xff, b'#', b'/', b'e', b'n'];
    for (name, seed) in &seeds {
        for _ in 0..300 {
            let mut m = seed.clone();
            for _ in 0..1 + rand() % 4 {
                let i = (rand() % m.len() as u64) as usize;
                m[i] = if rand() % 2 == 0 {
                    special[(rand() % special.len() as u64) as usize]
                } else {
                    rand() as u8
                };
            }
            if rand() % 4 == 0 {
                m.truncate((rand() % m.len() as u64) as usize);
            }
            let p = put(&d, name, &m);
            let _ = read_cloud(&p);
            let _ = read_mesh(&p);
        }
    }
}

// ------------------------------------------------------------- write_atomic

fn dir_entries(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn write_atomic_failure_leaves_no_target_and_no_temp() {
    let d = dir("atomic_fail");
    let target = d.join("out.ply");
    let e = write_atomic(&target, |w| {
        w.write_all(b"partial")?;
        Err(std::io::Error::other("disk on fire"))
    })
    .unwrap_err();
    assert!(
        e.to_string().contains("out.ply") && e.to_string().contains("disk on fire"),
        "{e}"
    );
    assert!(
        dir_entries(&d).is_empty(),
        "left behind: {:?}",
        dir_entries(&d)
    );
}

#[test]
fn write_atomic_failure_keeps_existing_target() {
    let d = dir("atomic_keep");
    let target = put(&d, "mesh.obj", "old contents\n");
    let r = write_atomic(&target, |w| {
        w.write_all(&[b'x'; 100_000])?;
        Err(std::io::Error::other("stop"))
    });
    assert!(r.is_err());
    assert_eq!(fs::read_to_string(&target).unwrap(), "old contents\n");
    assert_eq!(dir_entries(&d), vec!["mesh.obj".to_string()]);
}

#[test]
fn write_atomic_panic_in_closure_leaves_no_temp() {
    let d = dir("atomic_panic");
    let target = d.join("p.off");
    let r = std::panic::catch_unwind(|| {
        let _ = write_atomic(&target, |w| {
            w.write_all(b"OFF\n")?;
            panic!("writer bug");
        });
    });
    assert!(r.is_err());
    assert!(
        dir_entries(&d).is_empty(),
        "left behind: {:?}",
        dir_entries(&d)
    );
}

#[test]
fn write_atomic_success_replaces_target_completely() {
    let d = dir("atomic_ok");
    let target = put(&d, "big.xyz", "old\n");
    let line = "0.1 0.2 0.3\n";
    write_atomic(&target, |w| {
        for _ in 0..50_000 {
            w.write_all(line.as_bytes())?;
        }
        Ok(())
    })
    .unwrap();
    let got = fs::read_to_string(&target).unwrap();
    assert_eq!(got.len(), 50_000 * line.len());
    assert_eq!(dir_entries(&d), vec!["big.xyz".to_string()]);
    assert_eq!(read_cloud(&target).unwrap().positions.len(), 50_000);
    // A missing directory is an error naming the target.
    let e = write_atomic(&d.join("no/such/dir/x.ply"), |_| Ok(())).unwrap_err();
    assert!(e.to_string().contains("x.ply"), "{e}");
}

// ------------------------------------------------------------- real data

fn shared_data() -> Option<PathBuf> {
    let p = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data"));
    if p.is_dir() {
        Some(p.to_path_buf())
    } else {
        println!("skipped: ../shared/data not found");
        None
    }
}

/// The vertex count a PLY header declares.
fn header_vertex_count(bytes: &[u8]) -> u64 {
    let text = String::from_utf8_lossy(&bytes[..bytes.len().min(4096)]);
    text.lines()
        .find_map(|l| l.strip_prefix("element vertex "))
        .and_then(|n| n.trim().parse().ok())
        .expect("element vertex line")
}

#[test]
#[cfg_attr(
    not(shared_data),
    ignore = "needs ../shared/data/clouds, not found when this crate was built"
)]
fn shared_clouds_read_with_header_counts() {
    let Some(data) = shared_data() else { return };
    let clouds = data.join("clouds");
    let mut seen = 0;
    if clouds.is_dir() {
        for entry in fs::read_dir(&clouds).unwrap() {
            let p = entry.unwrap().path();
            if p.extension().is_some_and(|e| e.eq_ignore_ascii_case("ply")) {
                let want = header_vertex_count(&fs::read(&p).unwrap());
                let t = Instant::now();
                let c = read_cloud(&p).unwrap_or_else(|e| panic!("{e}"));
                println!(
                    "{}: {} points in {:?}",
                    p.display(),
                    c.positions.len(),
                    t.elapsed()
                );
                assert_eq!(c.positions.len() as u64, want, "{}", p.display());
                seen += 1;
            }
        }
        assert!(seen > 0, "no .ply in {}", clouds.display());
    } else {
        println!("skipped: ../shared/data/clouds not found");
    }

    let t = Instant::now();
    let block = read_cloud(&data.join("block.xyz")).unwrap_or_else(|e| panic!("{e}"));
    println!("block.xyz: {:?}", t.elapsed());
    assert_eq!(block.positions.len(), 50_000);
    let n = block.normals.expect("block.xyz has normals");
    assert_eq!(n.len(), 50_000);
    let len = (n[0][0] * n[0][0] + n[0][1] * n[0][1] + n[0][2] * n[0][2]).sqrt();
    assert!((len - 1.0).abs() < 1e-6, "unit normals, got length {len}");

    let scan = read_cloud(&data.join("bunny_scan000.ply")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scan.positions.len(), 40_256);
    assert_eq!(scan.normals, None);

    let horse = read_cloud(&data.join("horse.ply")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(horse.positions.len(), 48_485);
    assert_eq!(horse.normals.map(|n| n.len()), Some(48_485));
    let (v, t) = read_mesh(&data.join("horse.ply")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((v.len(), t.len()), (48_485, 96_966));
}

#[test]
#[cfg_attr(
    not(shared_data),
    ignore = "needs ../shared/data/clouds, not found when this crate was built"
)]
fn shared_meshes_read_with_documented_counts() {
    let Some(data) = shared_data() else { return };
    // Counts from ../shared/data/SOURCES.md.
    let cases = [
        ("bunny.ply", 35_947, 69_451),
        ("armadillo.obj", 43_243, 86_482),
        ("kitten.off", 33_612, 67_224),
        ("fandisk.off", 6_475, 12_946),
        ("rocker_arm.off", 10_044, 20_088),
        ("gear.off", 11_182, 22_408),
        ("bolt.obj", 328, 652),
    ];
    for (name, nv, nt) in cases {
        let p = data.join(name);
        if !p.exists() {
            println!("skipped: {} not found", p.display());
            continue;
        }
        let (v, t) = read_mesh(&p).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((v.len(), t.len()), (nv, nt), "{name}");
    }
}
