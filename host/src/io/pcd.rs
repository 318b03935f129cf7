//! PCD (Point Cloud Library) files, v0.7 and the older headers without `VERSION`:
//! `FIELDS` (or `COLUMNS`) in any order with `x y z`, optional
//! `normal_x normal_y normal_z` and a packed colour `rgb` or `rgba` (4 bytes,
//! `0x..RRGGBB`, as PCL stores it); every other field is skipped by its
//! `SIZE`/`TYPE`/`COUNT`. `POINTS` (or `WIDTH * HEIGHT`: organised clouds are read
//! row after row). `DATA ascii`, `DATA binary` (little-endian, point after point) or
//! `DATA binary_compressed` (two little-endian `u32`, the compressed and the
//! decompressed size, then an LZF stream of the points field after field, see
//! [`super::lzf`]).
//!
//! A point with a NaN or infinite coordinate is how PCL marks a pixel without a
//! measure in an organised cloud: it is skipped and counted ([`Cloud::invalid`]).
//! A file whose header and body disagree is an error naming the line or byte.
//! Every size computed from the header is checked arithmetic, and nothing is
//! reserved before the bytes it stands for are known to be there.
//!
//! Cost: one pass over the bytes; memory is the output (and, for
//! `binary_compressed`, the decompressed body).

use super::{lzf, safe_capacity, At, Cloud, Lines, ReadErrorKind, Scalar, Shown};

type Result<T> = core::result::Result<T, ReadErrorKind>;

struct Field {
    name: String,
    ty: Scalar,
    count: usize,
    /// Bytes of one point's values of this field (`count * ty.size()`).
    bytes: usize,
    /// Offset of the field in a binary row, and of its block in a compressed body
    /// (times the point count).
    offset: usize,
    /// First column of the field in an ASCII row.
    column: usize,
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

#[derive(Clone, Copy, PartialEq, Eq)]
enum Data {
    Ascii,
    Binary,
    Compressed,
}

/// The header: fields, point count, the body's encoding and where it starts.
struct Header {
    fields: Vec<Field>,
    fields_line: usize,
    points: u64,
    data: Data,
    /// Byte offset of the body.
    body: usize,
    /// Line number of the body's first line.
    body_line: usize,
}

impl Header {
    /// Bytes of one point over every field (their sum was checked as the fields
    /// were built, since each `COUNT` is the file's).
    fn row_bytes(&self) -> usize {
        self.fields.last().map_or(0, |f| f.offset + f.bytes)
    }

    /// Values of one point in an ASCII row.
    fn columns(&self) -> usize {
        self.fields.last().map_or(0, |f| f.column + f.count)
    }
}

fn parse_header(data: &[u8]) -> Result<Header> {
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
                _ => {
                    return Err(ReadErrorKind::line(
                        n,
                        "expected \"DATA ascii|binary|binary_compressed\"",
                    ))
                }
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
    let data_enc = match data_kind {
        "ascii" => Data::Ascii,
        "binary" => Data::Binary,
        "binary_compressed" => Data::Compressed,
        other => {
            return Err(ReadErrorKind::line(
                data_line,
                format!(
                    "unknown DATA kind {} (expected ascii, binary or binary_compressed)",
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
    let mut fields: Vec<Field> = Vec::with_capacity(nf);
    let (mut offset, mut column) = (0usize, 0usize);
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
        let (count_line, count) = match &counts {
            None => (fields_line, 1),
            Some((n, c)) => match c[i].parse::<usize>() {
                Ok(k) if k >= 1 => (*n, k),
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
        let too_large = || {
            ReadErrorKind::line(
                count_line,
                format!("field '{name}': COUNT {count} makes a point too large"),
            )
        };
        let bytes = count.checked_mul(ty.size()).ok_or_else(too_large)?;
        fields.push(Field {
            name: (*name).to_string(),
            ty,
            count,
            bytes,
            offset,
            column,
        });
        offset = offset.checked_add(bytes).ok_or_else(too_large)?;
        column = column.checked_add(count).ok_or_else(too_large)?;
    }

    // Point count.
    let width = single(&width_e, "WIDTH")?
        .map(|(n, t)| parse_u64(t, n, "WIDTH"))
        .transpose()?;
    let height = single(&height_e, "HEIGHT")?
        .map(|(n, t)| parse_u64(t, n, "HEIGHT"))
        .transpose()?;
    let wh = match (width, height) {
        (Some(w), h) => Some(w.checked_mul(h.unwrap_or(1)).ok_or_else(|| {
            ReadErrorKind::file(format!("WIDTH {w} * HEIGHT {} overflows", h.unwrap_or(1)))
        })?),
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
    Ok(Header {
        fields,
        fields_line,
        points,
        data: data_enc,
        body: lines.pos(),
        body_line: lines.next_no(),
    })
}

/// Which fields the cloud takes its values from.
struct Plan {
    xyz: [usize; 3],
    normals: Option<[usize; 3]>,
    /// A packed `rgb`/`rgba` field of 4 bytes.
    rgb: Option<usize>,
}

fn plan(h: &Header) -> Result<Plan> {
    let fields = &h.fields;
    let find = |name: &str| -> Result<Option<usize>> {
        match fields.iter().position(|f| f.name == name) {
            Some(i) if fields[i].count != 1 => Err(ReadErrorKind::line(
                h.fields_line,
                format!("field '{name}' has COUNT {}, expected 1", fields[i].count),
            )),
            other => Ok(other),
        }
    };
    let mut xyz = [0usize; 3];
    for (k, name) in ["x", "y", "z"].into_iter().enumerate() {
        xyz[k] = find(name)?
            .ok_or_else(|| ReadErrorKind::line(h.fields_line, format!("FIELDS has no '{name}'")))?;
    }
    let normals = match [find("normal_x")?, find("normal_y")?, find("normal_z")?] {
        [Some(a), Some(b), Some(c)] => Some([a, b, c]),
        [None, None, None] => None,
        _ => {
            return Err(ReadErrorKind::line(
                h.fields_line,
                "FIELDS has some but not all of normal_x normal_y normal_z",
            ))
        }
    };
    // A colour of another shape (e.g. COUNT 3) is skipped like any extra field.
    let rgb = fields
        .iter()
        .position(|f| (f.name == "rgb" || f.name == "rgba") && f.count == 1 && f.bytes == 4);
    Ok(Plan { xyz, normals, rgb })
}

/// `0x..RRGGBB` as PCL packs a colour into 4 bytes.
fn unpack(bits: u32) -> [u8; 3] {
    [(bits >> 16) as u8, (bits >> 8) as u8, bits as u8]
}

/// The cloud being built: points with finite positions, the others counted.
struct Builder {
    cloud: Cloud,
    normals: Vec<[f64; 3]>,
    colors: Vec<[u8; 3]>,
}

impl Builder {
    fn new(cap: usize, plan: &Plan) -> Self {
        let cap_if = |on: bool| if on { cap } else { 0 };
        Builder {
            cloud: Cloud {
                positions: Vec::with_capacity(cap),
                ..Cloud::default()
            },
            normals: Vec::with_capacity(cap_if(plan.normals.is_some())),
            colors: Vec::with_capacity(cap_if(plan.rgb.is_some())),
        }
    }

    /// Adds a point, or counts it as invalid when a coordinate is not finite.
    fn push(&mut self, p: [f64; 3], normal: Option<[f64; 3]>, color: Option<[u8; 3]>) {
        if !p.iter().all(|v| v.is_finite()) {
            self.cloud.invalid += 1;
            return;
        }
        self.cloud.positions.push(p);
        self.normals.extend(normal);
        self.colors.extend(color);
    }

    fn finish(self, h: &Header, plan: &Plan) -> Result<Cloud> {
        if self.cloud.positions.is_empty() {
            return Err(ReadErrorKind::file(format!(
                "no valid points: all {} have a NaN or infinite coordinate",
                h.points
            )));
        }
        Ok(Cloud {
            normals: plan.normals.map(|_| self.normals),
            colors: plan.rgb.map(|_| self.colors),
            ..self.cloud
        })
    }
}

/// Parses a PCD cloud.
pub fn parse_cloud(data: &[u8]) -> Result<Cloud> {
    let h = parse_header(data)?;
    let plan = plan(&h)?;
    match h.data {
        Data::Ascii => parse_ascii(data, &h, &plan),
        Data::Binary => parse_binary(data, &h, &plan),
        Data::Compressed => parse_compressed(data, &h, &plan),
    }
}

/// Decodes the points of a binary body; `at(i, f)` is where point `i`'s value of
/// field `f` starts in `bytes` (in range: the caller checked the body's size).
fn decode_points(
    h: &Header,
    plan: &Plan,
    bytes: &[u8],
    at: impl Fn(usize, &Field) -> usize,
) -> Result<Cloud> {
    // points * row_bytes <= bytes.len(), checked by the caller: `points` fits.
    let n = h.points as usize;
    let mut b = Builder::new(n, plan);
    let value = |i: usize, k: usize| {
        let f = &h.fields[k];
        f.ty.decode(&bytes[at(i, f)..], false).unwrap_or(f64::NAN)
    };
    for i in 0..n {
        let p = plan.xyz.map(|k| value(i, k));
        let normal = plan.normals.map(|nk| nk.map(|k| value(i, k)));
        let color = plan.rgb.map(|k| {
            let s = at(i, &h.fields[k]);
            unpack(u32::from_le_bytes([
                bytes[s],
                bytes[s + 1],
                bytes[s + 2],
                bytes[s + 3],
            ]))
        });
        b.push(p, normal, color);
    }
    b.finish(h, plan)
}

/// `points * row_bytes`, when that fits in `avail` bytes.
fn body_fits(h: &Header, avail: usize) -> Option<usize> {
    h.points
        .checked_mul(h.row_bytes() as u64)
        .filter(|&need| need <= avail as u64)
        .map(|need| need as usize)
}

fn parse_binary(data: &[u8], h: &Header, plan: &Plan) -> Result<Cloud> {
    let avail = data.len() - h.body;
    let row = h.row_bytes();
    if body_fits(h, avail).is_none() {
        return Err(ReadErrorKind::invalid(
            At::Byte(h.body),
            format!(
                "header declares {} points of {row} bytes but only {avail} bytes of data follow",
                h.points
            ),
        ));
    }
    decode_points(h, plan, &data[h.body..], |i, f| i * row + f.offset)
}

fn parse_compressed(data: &[u8], h: &Header, plan: &Plan) -> Result<Cloud> {
    let body = &data[h.body..];
    let size_at = |k: usize| {
        body.get(4 * k..4 * k + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    let (Some(packed), Some(unpacked)) = (size_at(0), size_at(1)) else {
        return Err(ReadErrorKind::invalid(
            At::Byte(h.body),
            format!(
                "binary_compressed data needs two 4-byte sizes, only {} bytes follow",
                body.len()
            ),
        ));
    };
    let stream = &body[8..];
    if packed > stream.len() {
        return Err(ReadErrorKind::invalid(
            At::Byte(h.body),
            format!(
                "binary_compressed data of {packed} bytes declared, only {} follow",
                stream.len()
            ),
        ));
    }
    let row = h.row_bytes();
    let want = h.points.checked_mul(row as u64);
    if want != Some(unpacked as u64) {
        let want = want.map_or("more than 2^64".to_string(), |n| n.to_string());
        return Err(ReadErrorKind::invalid(
            At::Byte(h.body),
            format!(
                "binary_compressed data decompresses to {unpacked} bytes, but {} points \
                 of {row} bytes need {want}",
                h.points
            ),
        ));
    }
    if unpacked > packed.saturating_mul(lzf::MAX_RATIO) {
        return Err(ReadErrorKind::invalid(
            At::Byte(h.body),
            format!(
                "{packed} compressed bytes cannot decompress to {unpacked} \
                 (LZF expands at most {} times)",
                lzf::MAX_RATIO
            ),
        ));
    }
    let fields = lzf::decompress(&stream[..packed], unpacked).map_err(|e| {
        ReadErrorKind::invalid(
            At::Byte(h.body + 8 + e.at),
            format!("binary_compressed data: {}", e.what),
        )
    })?;
    // Field after field: field f's block starts at points * offset.
    let n = h.points as usize;
    decode_points(h, plan, &fields, |i, f| n * f.offset + i * f.bytes)
}

fn parse_ascii(data: &[u8], h: &Header, plan: &Plan) -> Result<Cloud> {
    let avail = data.len() - h.body;
    let columns = h.columns();
    let mut b = Builder::new(
        safe_capacity(h.points, avail, columns.saturating_mul(2)),
        plan,
    );
    let mut lines = Lines::new(data, h.body, h.body_line);
    let mut toks: Vec<&str> = Vec::with_capacity(columns.min(avail));
    for index in 0..h.points {
        let (n, line) = loop {
            let Some(next) = lines.next_text() else {
                return Err(ReadErrorKind::line(
                    lines.next_no(),
                    format!("file ends after {index} of {} points", h.points),
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
        let bad = |f: &Field, tok: &str| {
            ReadErrorKind::line(
                n,
                format!(
                    "field '{}': {} is not a valid {}",
                    f.name,
                    Shown(tok),
                    f.ty.name()
                ),
            )
        };
        // Every value is checked, skipped fields too: a garbled line is an error.
        for f in &h.fields {
            for tok in &toks[f.column..f.column + f.count] {
                f.ty.parse_text(tok).ok_or_else(|| bad(f, tok))?;
            }
        }
        let value = |k: usize| {
            let f = &h.fields[k];
            f.ty.parse_text(toks[f.column]).unwrap_or(f64::NAN)
        };
        let p = plan.xyz.map(value);
        let normal = plan.normals.map(|nk| nk.map(value));
        let color = plan
            .rgb
            .map(|k| {
                let f = &h.fields[k];
                let tok = toks[f.column];
                // A float field holds the colour's bits (PCL writes them as a float).
                let bits = match f.ty {
                    Scalar::F32 => tok.parse::<f32>().ok().map(f32::to_bits),
                    _ => tok
                        .parse::<u32>()
                        .ok()
                        .or_else(|| tok.parse::<i32>().ok().map(|v| v as u32)),
                };
                bits.map(unpack).ok_or_else(|| bad(f, tok))
            })
            .transpose()?;
        b.push(p, normal, color);
    }
    b.finish(h, plan)
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z rgb normal_x normal_y normal_z\n\
        SIZE 4 4 4 4 4 4 4\nTYPE F F F U F F F\nCOUNT 1 1 1 1 1 1 1\nWIDTH 2\nHEIGHT 1\n\
        VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\n";

    #[test]
    fn ascii_with_colour_and_normals() {
        let c = parse_cloud(
            format!("{HEAD}DATA ascii\n1 2 3 4278255360 0 0 1\n4 5 6 0 nan 0 0\n").as_bytes(),
        )
        .unwrap();
        assert_eq!(c.positions, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        assert!(c.normals.unwrap()[1][0].is_nan());
        assert_eq!(c.colors, Some(vec![[0, 255, 0], [0, 0, 0]]));
        assert_eq!(c.invalid, 0);
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
        assert_eq!((c.normals, c.colors), (None, None));
    }

    /// A compressed body of `points` rows given field by field.
    fn compressed(head: &str, blocks: &[Vec<u8>]) -> Vec<u8> {
        let raw: Vec<u8> = blocks.concat();
        let packed = lzf::compress(&raw);
        let mut data = head.as_bytes().to_vec();
        data.extend((packed.len() as u32).to_le_bytes());
        data.extend((raw.len() as u32).to_le_bytes());
        data.extend(packed);
        data
    }

    fn f32s(v: &[f32]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    }

    #[test]
    fn compressed_organised_cloud_in_any_field_order_skips_nan_pixels() {
        // 2 x 2 organised, fields z, rgb, x, pad (COUNT 3), y; one NaN pixel.
        let head = "FIELDS z rgb x pad y\nSIZE 4 4 4 1 4\nTYPE F F F U F\nCOUNT 1 1 1 3 1\n\
                    WIDTH 2\nHEIGHT 2\nDATA binary_compressed\n";
        let nan = f32::NAN;
        let rgb: Vec<u8> = [0x00ff_0000u32, 0x0000_ff00, 0, 0x0000_00ff]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let data = compressed(
            head,
            &[
                f32s(&[3.0, 6.0, nan, 9.0]),
                rgb,
                f32s(&[1.0, 4.0, nan, 7.0]),
                vec![0xee; 12],
                f32s(&[2.0, 5.0, nan, 8.0]),
            ],
        );
        let c = parse_cloud(&data).unwrap();
        assert_eq!(
            c.positions,
            vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]]
        );
        assert_eq!(c.colors, Some(vec![[255, 0, 0], [0, 255, 0], [0, 0, 255]]));
        assert_eq!(c.invalid, 1);
    }

    #[test]
    fn compressed_sizes_that_lie_are_errors_before_any_allocation() {
        let head = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1000000000\nHEIGHT 4\n\
                    DATA binary_compressed\n";
        let mut data = head.as_bytes().to_vec();
        data.extend(16u32.to_le_bytes());
        data.extend(u32::MAX.to_le_bytes());
        data.extend([0u8; 16]);
        let e = parse_cloud(&data).unwrap_err().to_string();
        assert!(e.contains("decompresses to 4294967295 bytes"), "{e}");
        let e = parse_cloud(&data[..head.len() + 3])
            .unwrap_err()
            .to_string();
        assert!(e.contains("two 4-byte sizes"), "{e}");
    }

    #[test]
    fn a_huge_count_is_an_error_not_an_overflow() {
        let e = parse_cloud(
            b"FIELDS x y z h\nSIZE 4 4 4 8\nTYPE F F F F\nCOUNT 1 1 1 4611686018427387904\n\
              POINTS 1\nDATA binary\n",
        )
        .unwrap_err()
        .to_string();
        assert_eq!(
            e,
            "line 4: field 'h': COUNT 4611686018427387904 makes a point too large"
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
