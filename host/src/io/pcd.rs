//! PCD (Point Cloud Library) files, v0.7 and the older headers without `VERSION`:
//! `FIELDS` (or `COLUMNS`) with `x y z` and optional `normal_x normal_y normal_z`,
//! other fields skipped according to `SIZE`/`TYPE`/`COUNT`; `POINTS` (or
//! `WIDTH * HEIGHT`); `DATA ascii` or `DATA binary` (little-endian, row after row).
//! `DATA binary_compressed` is reported as not supported.
//!
//! Cost: one pass over the bytes; memory is the output.

use super::{check_finite, safe_capacity, At, Cloud, Lines, ReadErrorKind, Scalar, Shown};

type Result<T> = core::result::Result<T, ReadErrorKind>;

struct Field {
    name: String,
    ty: Scalar,
    count: usize,
}

fn field_type(ty: &str, size: &str) -> Option<Scalar> {
    Some(match (ty, size) {
        ("I", "1") => Scalar::I8,
        ("U", "1") => Scalar::U8,
        ("I", "2") => Scalar::I16,
        ("U", "2") => Scalar::U16,
        ("I", "4") => Scalar::I32,
        ("U", "4") => Scalar::U32,
        ("I", "8") => Scalar::I64,
        ("U", "8") => Scalar::U64,
        ("F", "4") => Scalar::F32,
        ("F", "8") => Scalar::F64,
        _ => return None,
    })
}

/// Values of one header keyword and the line that gave them.
type Entry<'a> = Option<(usize, Vec<&'a str>)>;

fn parse_u64(tok: &str, line: usize, key: &str) -> Result<u64> {
    tok.parse::<u64>().map_err(|_| {
        ReadErrorKind::line(
            line,
            format!("{key} {} is not a non-negative integer", Shown(tok)),
        )
    })
}

fn single<'a>(e: &Entry<'a>, key: &str) -> Result<Option<(usize, &'a str)>> {
    match e {
        None => Ok(None),
        Some((n, v)) if v.len() == 1 => Ok(Some((*n, v[0]))),
        Some((n, v)) => Err(ReadErrorKind::line(
            *n,
            format!("{key} takes one value, found {}", v.len()),
        )),
    }
}

/// An entry that must have one value per field.
fn per_field<'a>(e: Entry<'a>, nf: usize, key: &str) -> Result<Entry<'a>> {
    match e {
        Some((n, v)) if v.len() != nf => Err(ReadErrorKind::line(
            n,
            format!("{key} has {} entries but FIELDS has {nf}", v.len()),
        )),
        other => Ok(other),
    }
}

/// Parses a PCD cloud.
pub fn parse_cloud(data: &[u8]) -> Result<Cloud> {
    if data.is_empty() {
        return Err(ReadErrorKind::file("file is empty"));
    }
    let mut lines = Lines::new(data, 0, 1);
    let (mut fields_e, mut size_e, mut type_e, mut count_e): (Entry, Entry, Entry, Entry) =
        (None, None, None, None);
    let (mut width_e, mut height_e, mut points_e): (Entry, Entry, Entry) = (None, None, None);
    let (data_line, data_kind) = loop {
        let Some(next) = lines.next_text() else {
            return Err(ReadErrorKind::file(format!(
                "header has no DATA line ({} lines read)",
                lines.next_no() - 1
            )));
        };
        let (n, line) = next?;
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut toks = line.split_ascii_whitespace();
        let key = toks.next().unwrap_or_default().to_ascii_uppercase();
        let values: Vec<&str> = toks.collect();
        let slot = match key.as_str() {
            "VERSION" | "VIEWPOINT" => continue,
            "FIELDS" | "COLUMNS" => &mut fields_e,
            "SIZE" => &mut size_e,
            "TYPE" => &mut type_e,
            "COUNT" => &mut count_e,
            "WIDTH" => &mut width_e,
            "HEIGHT" => &mut height_e,
            "POINTS" => &mut points_e,
            "DATA" => match values.as_slice() {
                [kind] => break (n, *kind),
                _ => return Err(ReadErrorKind::line(n, "expected \"DATA ascii|binary\"")),
            },
            _ => {
                return Err(ReadErrorKind::line(
                    n,
                    format!("unknown header line starting with {}", Shown(line)),
                ))
            }
        };
        if slot.is_some() {
            return Err(ReadErrorKind::line(n, format!("second {key} line")));
        }
        *slot = Some((n, values));
    };
    let binary = match data_kind {
        "ascii" => false,
        "binary" => true,
        "binary_compressed" => {
            return Err(ReadErrorKind::unsupported(
                At::Line(data_line),
                "DATA binary_compressed (re-save the cloud as ascii or binary)",
            ))
        }
        other => {
            return Err(ReadErrorKind::line(
                data_line,
                format!(
                    "unknown DATA kind {} (expected ascii or binary)",
                    Shown(other)
                ),
            ))
        }
    };

    // Fields.
    let Some((fields_line, names)) = fields_e else {
        return Err(ReadErrorKind::file("header has no FIELDS line"));
    };
    let nf = names.len();
    let (size_line, sizes) = per_field(size_e, nf, "SIZE")?
        .ok_or_else(|| ReadErrorKind::file("header has no SIZE line"))?;
    let (type_line, types) = per_field(type_e, nf, "TYPE")?
        .ok_or_else(|| ReadErrorKind::file("header has no TYPE line"))?;
    let counts = per_field(count_e, nf, "COUNT")?;
    let mut fields = Vec::with_capacity(nf);
    for (i, name) in names.iter().enumerate() {
        let ty = field_type(types[i], sizes[i]).ok_or_else(|| {
            ReadErrorKind::line(
                type_line.max(size_line),
                format!(
                    "field '{name}': TYPE {} with SIZE {} is not a PCD type",
                    Shown(types[i]),
                    Shown(sizes[i])
                ),
            )
        })?;
        let count = match &counts {
            None => 1,
            Some((n, c)) => match c[i].parse::<usize>() {
                Ok(k) if k >= 1 => k,
                _ => {
                    return Err(ReadErrorKind::line(
                        *n,
                        format!(
                            "field '{name}': COUNT {} is not a positive integer",
                            Shown(c[i])
                        ),
                    ))
                }
            },
        };
        fields.push(Field {
            name: (*name).to_string(),
            ty,
            count,
        });
    }
    let find = |name: &str| -> Result<Option<usize>> {
        match fields.iter().position(|f| f.name == name) {
            Some(i) if fields[i].count != 1 => Err(ReadErrorKind::line(
                fields_line,
                format!("field '{name}' has COUNT {}, expected 1", fields[i].count),
            )),
            other => Ok(other),
        }
    };
    let mut xyz = [0usize; 3];
    for (k, name) in ["x", "y", "z"].into_iter().enumerate() {
        xyz[k] = find(name)?
            .ok_or_else(|| ReadErrorKind::line(fields_line, format!("FIELDS has no '{name}'")))?;
    }
    let normal_idx = [find("normal_x")?, find("normal_y")?, find("normal_z")?];
    let normal_idx = match normal_idx {
        [Some(a), Some(b), Some(c)] => Some([a, b, c]),
        [None, None, None] => None,
        _ => {
            return Err(ReadErrorKind::line(
                fields_line,
                "FIELDS has some but not all of normal_x normal_y normal_z",
            ))
        }
    };

    // Point count.
    let width = single(&width_e, "WIDTH")?
        .map(|(n, t)| parse_u64(t, n, "WIDTH"))
        .transpose()?;
    let height = single(&height_e, "HEIGHT")?
        .map(|(n, t)| parse_u64(t, n, "HEIGHT"))
        .transpose()?;
    let wh = match (width, height) {
        (Some(w), h) => Some(
            w.checked_mul(h.unwrap_or(1))
                .ok_or_else(|| ReadErrorKind::file("WIDTH * HEIGHT overflows"))?,
        ),
        _ => None,
    };
    let points = match single(&points_e, "POINTS")? {
        Some((n, t)) => {
            let p = parse_u64(t, n, "POINTS")?;
            if let Some(wh) = wh.filter(|&wh| wh != p) {
                return Err(ReadErrorKind::line(
                    n,
                    format!("POINTS {p} disagrees with WIDTH * HEIGHT = {wh}"),
                ));
            }
            p
        }
        None => wh.ok_or_else(|| ReadErrorKind::file("header has neither POINTS nor WIDTH"))?,
    };
    if points == 0 {
        return Err(ReadErrorKind::line(
            data_line,
            "the header declares 0 points",
        ));
    }

    let body = lines.pos();
    let avail = data.len() - body;
    let columns: usize = fields.iter().map(|f| f.count).sum();
    let row_bytes: usize = fields.iter().map(|f| f.count * f.ty.size()).sum();
    let min_row = if binary { row_bytes } else { 2 * columns };
    let cap = safe_capacity(points, avail, min_row);
    let mut positions = Vec::with_capacity(cap);
    let mut normals = Vec::with_capacity(if normal_idx.is_some() { cap } else { 0 });

    if binary {
        let fits = points
            .checked_mul(row_bytes as u64)
            .is_some_and(|need| need <= avail as u64);
        if !fits {
            return Err(ReadErrorKind::invalid(
                At::Byte(body),
                format!(
                    "header declares {points} points of {row_bytes} bytes but only {avail} \
                     bytes of data follow"
                ),
            ));
        }
        let mut offsets = Vec::with_capacity(nf);
        let mut off = 0;
        for f in &fields {
            offsets.push(off);
            off += f.count * f.ty.size();
        }
        let value = |row: &[u8], i: usize| {
            row.get(offsets[i]..)
                .and_then(|b| fields[i].ty.decode(b, false))
                .unwrap_or(f64::NAN)
        };
        // points * row_bytes <= avail, checked above.
        for (i, row) in data[body..]
            .chunks_exact(row_bytes)
            .take(points as usize)
            .enumerate()
        {
            let p = xyz.map(|k| value(row, k));
            check_finite(p, i as u64, None)?;
            positions.push(p);
            if let Some(nk) = normal_idx {
                normals.push(nk.map(|k| value(row, k)));
            }
        }
    } else {
        let mut toks: Vec<&str> = Vec::with_capacity(columns);
        let mut starts = Vec::with_capacity(nf);
        let mut col = 0;
        for f in &fields {
            starts.push(col);
            col += f.count;
        }
        let mut vals = vec![0.0f64; columns];
        for index in 0..points {
            let (n, line) = loop {
                let Some(next) = lines.next_text() else {
                    return Err(ReadErrorKind::line(
                        lines.next_no(),
                        format!("file ends after {index} of {points} points"),
                    ));
                };
                let (n, line) = next?;
                if !line.trim().is_empty() {
                    break (n, line);
                }
            };
            toks.clear();
            toks.extend(line.split_ascii_whitespace());
            if toks.len() != columns {
                return Err(ReadErrorKind::line(
                    n,
                    format!("expected {columns} values, found {}", toks.len()),
                ));
            }
            for (fi, f) in fields.iter().enumerate() {
                for c in starts[fi]..starts[fi] + f.count {
                    vals[c] = f.ty.parse_text(toks[c]).ok_or_else(|| {
                        ReadErrorKind::line(
                            n,
                            format!(
                                "field '{}': {} is not a valid {}",
                                f.name,
                                Shown(toks[c]),
                                f.ty.name()
                            ),
                        )
                    })?;
                }
            }
            let p = xyz.map(|k| vals[starts[k]]);
            check_finite(p, index, Some(n))?;
            positions.push(p);
            if let Some(nk) = normal_idx {
                normals.push(nk.map(|k| vals[starts[k]]));
            }
        }
    }
    Ok(Cloud {
        positions,
        normals: normal_idx.map(|_| normals),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z rgb normal_x normal_y normal_z\n\
        SIZE 4 4 4 4 4 4 4\nTYPE F F F U F F F\nCOUNT 1 1 1 1 1 1 1\nWIDTH 2\nHEIGHT 1\n\
        VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\n";

    #[test]
    fn ascii_with_skipped_field_and_normals() {
        let c = parse_cloud(
            format!("{HEAD}DATA ascii\n1 2 3 4278190080 0 0 1\n4 5 6 0 nan 0 0\n").as_bytes(),
        )
        .unwrap();
        assert_eq!(c.positions, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        assert!(c.normals.unwrap()[1][0].is_nan());
    }

    #[test]
    fn binary_without_version_and_count_lines() {
        let mut data =
            b"FIELDS x y z i\nSIZE 8 8 8 2\nTYPE F F F I\nWIDTH 2\nHEIGHT 1\nDATA binary\n"
                .to_vec();
        for v in [1.0f64, 2.0, 3.0] {
            data.extend_from_slice(&v.to_le_bytes());
        }
        data.extend_from_slice(&(-1i16).to_le_bytes());
        for v in [4.0f64, 5.0, 6.0] {
            data.extend_from_slice(&v.to_le_bytes());
        }
        data.extend_from_slice(&7i16.to_le_bytes());
        let c = parse_cloud(&data).unwrap();
        assert_eq!(c.positions, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        assert_eq!(c.normals, None);
    }

    #[test]
    fn compressed_is_reported_unsupported() {
        let e = parse_cloud(format!("{HEAD}DATA binary_compressed\n").as_bytes())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 11: not supported: DATA binary_compressed"),
            "{e}"
        );
    }

    #[test]
    fn sizes_must_match_fields() {
        let e = parse_cloud(b"FIELDS x y z\nSIZE 4 4\nTYPE F F F\nPOINTS 1\nDATA ascii\n1 2 3\n")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "line 2: SIZE has 2 entries but FIELDS has 3");
    }
}
