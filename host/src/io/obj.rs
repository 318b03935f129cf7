//! Wavefront OBJ meshes (reading): `v x y z [w | r g b]` and `f` with `a`, `a/b`,
//! `a//c`, `a/b/c` corners, 1-based or negative (relative) indices; polygons are
//! triangulated as fans. Every other statement (`vn`, `vt`, `g`, `usemtl`, ...) is
//! skipped. A face may only use vertices defined above it.
//!
//! Cost: one pass over the bytes; memory is the output.

use super::{check_finite, parse_f64, push_fan, Lines, Mesh, ReadErrorKind, Shown};

/// Parses an OBJ mesh.
pub fn parse_mesh(data: &[u8]) -> Result<Mesh, ReadErrorKind> {
    if data.is_empty() {
        return Err(ReadErrorKind::file("file is empty"));
    }
    let mut vertices: Vec<[f64; 3]> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut poly: Vec<u32> = Vec::new();
    let mut faces = 0u64;
    for next in Lines::new(data, 0, 1).texts() {
        let (n, line) = next?;
        let mut toks = line.split_ascii_whitespace();
        match toks.next() {
            Some("v") => {
                let mut p = [0.0; 3];
                for (k, c) in ["x", "y", "z"].into_iter().enumerate() {
                    let tok = toks.next().ok_or_else(|| {
                        ReadErrorKind::line(n, format!("vertex {}: no {c}", vertices.len()))
                    })?;
                    p[k] = parse_f64(tok, n, format_args!("vertex {}: {c}", vertices.len()))?;
                }
                check_finite(p, vertices.len() as u64, Some(n))?;
                vertices.push(p);
            }
            Some("f") => {
                poly.clear();
                for tok in toks {
                    let idx = tok.split('/').next().unwrap_or_default();
                    let bad = |why: &str| {
                        ReadErrorKind::line(
                            n,
                            format!("face {faces}: vertex reference {} {why}", Shown(tok)),
                        )
                    };
                    let i: i64 = idx.parse().map_err(|_| bad("is not an integer"))?;
                    let nv = vertices.len() as i64;
                    let resolved = if i > 0 { i - 1 } else { nv + i };
                    if i == 0 || !(0..nv).contains(&resolved) {
                        return Err(bad(&format!(
                            "is out of range ({nv} vertices defined so far)"
                        )));
                    }
                    poly.push(u32::try_from(resolved).map_err(|_| bad("exceeds 32 bits"))?);
                }
                if poly.len() < 3 {
                    return Err(ReadErrorKind::line(
                        n,
                        format!(
                            "face {faces}: {} vertices, a face needs at least 3",
                            poly.len()
                        ),
                    ));
                }
                push_fan(&poly, &mut triangles);
                faces += 1;
            }
            _ => {}
        }
    }
    if vertices.is_empty() {
        return Err(ReadErrorKind::file("no vertices (no \"v\" lines)"));
    }
    Ok((vertices, triangles))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slash_forms_negative_indices_and_quads() {
        let (v, t) = parse_mesh(
            b"# c\nv 0 0 0\nv 1 0 0\nv 1 1 0 1\nvn 0 0 1\nv 0 1 0\n\
              f 1/1/1 2//1 3/2\nf -4 -2 -1 \ng x\nf 1 2 3 4\n",
        )
        .unwrap();
        assert_eq!(v.len(), 4);
        assert_eq!(t, vec![[0, 1, 2], [0, 2, 3], [0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn out_of_range_reference_names_face_and_line() {
        let e = parse_mesh(b"v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\nf 1 2 9\n")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "line 5: face 1: vertex reference \"9\" is out of range (3 vertices defined so far)"
        );
        let e = parse_mesh(b"v 0 0 0\nf 0 1 1\n").unwrap_err().to_string();
        assert!(e.contains("face 0: vertex reference \"0\""), "{e}");
    }
}
