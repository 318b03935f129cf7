//! OFF meshes (reading): `OFF` (also `COFF`, `NOFF`, `CNOFF`), then
//! `vertices faces edges`, one vertex per line (extra columns such as colours ignored),
//! one face per line as `k i1 .. ik [colour]`; `#` starts a comment. Polygons are
//! triangulated as fans. Binary OFF is reported as not supported.
//!
//! Cost: one pass over the bytes; memory is the output (capacity bounded by the bytes
//! present, never by the header counts alone).

use super::{
    check_finite, parse_f64, push_fan, safe_capacity, At, Lines, Mesh, ReadErrorKind, Shown,
};

type Result<T> = core::result::Result<T, ReadErrorKind>;

/// The next line with tokens once `#` comments are removed; `what` says what was
/// expected if the file ends first.
fn next<'a>(lines: &mut Lines<'a>, what: impl FnOnce() -> String) -> Result<(usize, Vec<&'a str>)> {
    loop {
        let Some(item) = lines.next_text() else {
            return Err(ReadErrorKind::line(lines.next_no(), what()));
        };
        let (n, line) = item?;
        let line = line.split('#').next().unwrap_or_default();
        let toks: Vec<&str> = line.split_ascii_whitespace().collect();
        if !toks.is_empty() {
            return Ok((n, toks));
        }
    }
}

/// Parses an OFF mesh.
pub fn parse_mesh(data: &[u8]) -> Result<Mesh> {
    if data.is_empty() {
        return Err(ReadErrorKind::file("file is empty"));
    }
    let mut lines = Lines::new(data, 0, 1);
    let (n, mut toks) = next(&mut lines, || "no OFF header".to_string())?;
    let magic = toks.remove(0);
    if !matches!(magic, "OFF" | "COFF" | "NOFF" | "CNOFF") {
        return Err(ReadErrorKind::line(
            n,
            format!(
                "not an OFF file: first word is {}, expected \"OFF\"",
                Shown(magic)
            ),
        ));
    }
    if toks.first() == Some(&"BINARY") {
        return Err(ReadErrorKind::unsupported(At::Line(n), "binary OFF"));
    }
    // The counts may share the OFF line.
    let (n, counts) = if toks.is_empty() {
        next(&mut lines, || {
            "missing the \"vertices faces edges\" line".to_string()
        })?
    } else {
        (n, toks)
    };
    let parse_count = |i: usize, what: &str| -> Result<u64> {
        let tok = counts.get(i).ok_or_else(|| {
            ReadErrorKind::line(
                n,
                format!("expected \"vertices faces edges\", no {what} count"),
            )
        })?;
        tok.parse::<u64>().map_err(|_| {
            ReadErrorKind::line(
                n,
                format!("{what} count {} is not a non-negative integer", Shown(tok)),
            )
        })
    };
    let nv = parse_count(0, "vertex")?;
    let nf = parse_count(1, "face")?;
    let avail = data.len() - lines.pos();
    // A vertex line is at least "0 0 0\n", a triangle line "3 0 0 0\n".
    let mut vertices = Vec::with_capacity(safe_capacity(nv, avail, 6));
    let mut triangles = Vec::with_capacity(safe_capacity(nf, avail, 8));
    for i in 0..nv {
        let (n, toks) = next(&mut lines, || {
            format!("file ends after {i} of {nv} vertices")
        })?;
        if toks.len() < 3 {
            return Err(ReadErrorKind::line(
                n,
                format!("vertex {i}: expected 3 numbers, found {}", toks.len()),
            ));
        }
        let mut p = [0.0; 3];
        for (k, c) in ["x", "y", "z"].into_iter().enumerate() {
            p[k] = parse_f64(toks[k], n, format_args!("vertex {i}: {c}"))?;
        }
        check_finite(p, i, Some(n))?;
        vertices.push(p);
    }
    let mut poly = Vec::new();
    for f in 0..nf {
        let (n, toks) = next(&mut lines, || format!("file ends after {f} of {nf} faces"))?;
        let k = toks[0].parse::<usize>().map_err(|_| {
            ReadErrorKind::line(
                n,
                format!(
                    "face {f}: vertex count {} is not a non-negative integer",
                    Shown(toks[0])
                ),
            )
        })?;
        if k < 3 || k > toks.len() - 1 {
            return Err(ReadErrorKind::line(
                n,
                format!(
                    "face {f}: {k} vertices declared, {} indices on the line (a face needs at least 3)",
                    toks.len() - 1
                ),
            ));
        }
        poly.clear();
        for tok in &toks[1..=k] {
            let idx = tok
                .parse::<u32>()
                .ok()
                .filter(|&v| u64::from(v) < nv)
                .ok_or_else(|| {
                    ReadErrorKind::line(
                        n,
                        format!(
                            "face {f}: vertex index {} is out of range (the file has {nv} vertices)",
                            Shown(tok)
                        ),
                    )
                })?;
            poly.push(idx);
        }
        push_fan(&poly, &mut triangles);
    }
    Ok((vertices, triangles))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comments_counts_on_header_line_and_quads() {
        let (v, t) =
            parse_mesh(b"OFF 4 1 0\n# c\n0 0 0\n1 0 0 # x\n1 1 0 255 0 0\n0 1 0\n4 0 1 2 3\n")
                .unwrap();
        assert_eq!(v.len(), 4);
        assert_eq!(t, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn huge_counts_fail_at_end_of_file() {
        let e = parse_mesh(b"OFF\n4000000000 1 0\n0 0 0\n")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "line 4: file ends after 1 of 4000000000 vertices");
    }

    #[test]
    fn bad_face_index_is_named() {
        let e = parse_mesh(b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "line 6: face 0: vertex index \"3\" is out of range (the file has 3 vertices)"
        );
    }
}
