//! STL meshes (reading), binary and ASCII. A binary file is an 80-byte header, a
//! little-endian `u32` triangle count and 50 bytes a triangle (normal, three corners
//! as `f32`, 2 attribute bytes), and its length must be exactly that; an ASCII file
//! starts with `solid` and lists `facet normal .. outer loop, vertex x y z` three
//! times, `endloop endfacet`. A file starting with `solid` whose length matches the
//! binary layout is binary (some exporters write such headers).
//!
//! STL stores corners by value: corners with the same coordinates (exactly; `-0`
//! is `0`) become one vertex, so the mesh is indexed and its vertices are the points
//! of the surface, each once.
//!
//! Cost: one pass over the bytes and a hash lookup per corner; memory is the output
//! and the hash map (about 40 bytes a vertex).

use super::{check_finite, parse_f64, At, Lines, Mesh, ReadErrorKind, Shown};
use std::collections::HashMap;

type Result<T> = core::result::Result<T, ReadErrorKind>;

/// Bytes of a binary STL before the triangles, and of one triangle.
const HEAD: usize = 84;
const TRIANGLE: usize = 50;

/// Corners merged into vertices by their exact coordinates.
#[derive(Default)]
struct Merge {
    index: HashMap<[u64; 3], u32>,
    vertices: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
}

impl Merge {
    fn with_capacity(triangles: usize) -> Self {
        Merge {
            // A closed mesh has about half as many vertices as triangles.
            index: HashMap::with_capacity(triangles / 2),
            vertices: Vec::with_capacity(triangles / 2),
            triangles: Vec::with_capacity(triangles),
        }
    }

    /// The vertex at `p` (finite), added when new.
    fn vertex(&mut self, p: [f64; 3], at: impl Fn() -> At) -> Result<u32> {
        // `+ 0.0` turns -0 into 0, so both are one vertex.
        let key = p.map(|v| (v + 0.0).to_bits());
        if let Some(&i) = self.index.get(&key) {
            return Ok(i);
        }
        let i = u32::try_from(self.vertices.len())
            .map_err(|_| ReadErrorKind::invalid(at(), "more than 2^32 vertices"))?;
        self.index.insert(key, i);
        self.vertices.push(p);
        Ok(i)
    }

    fn finish(self) -> Result<Mesh> {
        if self.triangles.is_empty() {
            return Err(ReadErrorKind::file("no triangles"));
        }
        Ok((self.vertices, self.triangles))
    }
}

/// Parses an STL mesh, binary or ASCII (see the module docs).
pub fn parse_mesh(data: &[u8]) -> Result<Mesh> {
    if data.is_empty() {
        return Err(ReadErrorKind::file("file is empty"));
    }
    let declared = data
        .get(80..HEAD)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as u64);
    let binary_len = declared.map(|n| HEAD as u64 + n * TRIANGLE as u64);
    if binary_len == Some(data.len() as u64) {
        return parse_binary(data);
    }
    let text = data.trim_ascii_start();
    if text.starts_with(b"solid") && !data.contains(&0) {
        return parse_ascii(data);
    }
    match (declared, binary_len) {
        (Some(n), Some(len)) => Err(ReadErrorKind::invalid(
            At::Byte(80),
            format!(
                "binary STL declares {n} triangles, {len} bytes, but the file has {} bytes",
                data.len()
            ),
        )),
        _ => Err(ReadErrorKind::file(format!(
            "not an STL file: {} bytes, no \"solid\" line and too short for a binary header",
            data.len()
        ))),
    }
}

fn parse_binary(data: &[u8]) -> Result<Mesh> {
    // The length was checked against the count: every triangle is there.
    let body = &data[HEAD..];
    let mut m = Merge::with_capacity(body.len() / TRIANGLE);
    for (t, tri) in body.chunks_exact(TRIANGLE).enumerate() {
        let at = HEAD + t * TRIANGLE;
        let mut corners = [0u32; 3];
        for (k, corner) in corners.iter_mut().enumerate() {
            let p: [f64; 3] = std::array::from_fn(|a| {
                let o = 12 + 12 * k + 4 * a;
                f32::from_le_bytes([tri[o], tri[o + 1], tri[o + 2], tri[o + 3]]) as f64
            });
            if !p.iter().all(|v| v.is_finite()) {
                return Err(ReadErrorKind::invalid(
                    At::Byte(at),
                    format!("triangle {t}: corner {k} is {p:?}, not finite"),
                ));
            }
            *corner = m.vertex(p, || At::Byte(at))?;
        }
        m.triangles.push(corners);
    }
    m.finish()
}

fn parse_ascii(data: &[u8]) -> Result<Mesh> {
    let mut m = Merge::default();
    let mut corners: Vec<u32> = Vec::with_capacity(3);
    let mut in_loop = false;
    for next in Lines::new(data, 0, 1).texts() {
        let (n, line) = next?;
        let mut toks = line.split_ascii_whitespace();
        let Some(key) = toks.next() else { continue };
        let facet = m.triangles.len();
        match key {
            "solid" | "endsolid" | "facet" | "endfacet" => {}
            "outer" => {
                corners.clear();
                in_loop = true;
            }
            "vertex" => {
                if !in_loop || corners.len() == 3 {
                    return Err(ReadErrorKind::line(
                        n,
                        format!("facet {facet}: a vertex outside an \"outer loop\" of 3"),
                    ));
                }
                let mut p = [0.0; 3];
                for (k, c) in ["x", "y", "z"].into_iter().enumerate() {
                    let tok = toks.next().ok_or_else(|| {
                        ReadErrorKind::line(n, format!("facet {facet}: vertex has no {c}"))
                    })?;
                    p[k] = parse_f64(tok, n, format_args!("facet {facet}: {c}"))?;
                }
                check_finite(p, m.vertices.len() as u64, Some(n))?;
                corners.push(m.vertex(p, || At::Line(n))?);
            }
            "endloop" => {
                let &[a, b, c] = corners.as_slice() else {
                    return Err(ReadErrorKind::line(
                        n,
                        format!("facet {facet}: {} vertices, a facet needs 3", corners.len()),
                    ));
                };
                m.triangles.push([a, b, c]);
                corners.clear();
                in_loop = false;
            }
            other => {
                return Err(ReadErrorKind::line(
                    n,
                    format!(
                        "unknown STL keyword {} (expected solid, facet, outer loop, vertex, \
                         endloop, endfacet or endsolid)",
                        Shown(other)
                    ),
                ))
            }
        }
    }
    m.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    const TETRA: [[f32; 3]; 4] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    const FACES: [[usize; 3]; 4] = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];

    fn binary(header: &[u8]) -> Vec<u8> {
        let mut d = header.to_vec();
        d.resize(80, b' ');
        d.extend((FACES.len() as u32).to_le_bytes());
        for f in FACES {
            d.extend([0u8; 12]);
            for &v in &f {
                d.extend(TETRA[v].iter().flat_map(|c| c.to_le_bytes()));
            }
            d.extend([0u8; 2]);
        }
        d
    }

    #[test]
    fn binary_and_ascii_merge_corners_into_four_vertices() {
        for header in [&b"made by a test"[..], b"solid but binary"] {
            let (v, t) = parse_mesh(&binary(header)).unwrap();
            assert_eq!((v.len(), t.len()), (4, 4));
            assert_eq!(t[0], [0, 1, 2]);
        }
        let mut text = String::from("solid t\n");
        for f in FACES {
            text += "  facet normal 0 0 0\n    outer loop\n";
            for &v in &f {
                let p = TETRA[v];
                // -0 and 0 are one vertex.
                let x = if p[0] == 0.0 {
                    "-0".to_string()
                } else {
                    p[0].to_string()
                };
                text += &format!("      vertex {x} {} {}\n", p[1], p[2]);
            }
            text += "    endloop\n  endfacet\n";
        }
        text += "endsolid t\n";
        let (v, t) = parse_mesh(text.as_bytes()).unwrap();
        assert_eq!((v.len(), t.len()), (4, 4));
    }

    #[test]
    fn broken_files_name_the_place() {
        let mut d = binary(b"x");
        d.pop();
        let e = parse_mesh(&d).unwrap_err().to_string();
        assert_eq!(
            e,
            "binary STL declares 4 triangles, 284 bytes, but the file has 283 bytes (at byte 80)"
        );
        let e = parse_mesh(
            b"solid\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\n",
        )
        .unwrap_err()
        .to_string();
        assert_eq!(e, "line 6: facet 0: 2 vertices, a facet needs 3");
        let e = parse_mesh(b"solid\nouter loop\nvertex 0 nan 0\n")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "line 3: vertex 0: y is NaN");
        let e = parse_mesh(b"solid x\nendsolid x\n")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "no triangles");
        assert!(parse_mesh(b"hello")
            .unwrap_err()
            .to_string()
            .starts_with("not an STL file"));
    }
}
