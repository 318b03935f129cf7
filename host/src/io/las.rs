//! LAS 1.0-1.4 and LAZ (LASzip-compressed LAS) point clouds, decoded by the `las`
//! crate (and its `laz` feature): every point's `x y z` as `raw * scale + offset` in
//! `f64`, so georeferenced coordinates keep their precision; the colour of point
//! formats 2, 3, 5, 7, 8 and 10 (16 bits a channel, scaled to 8 when any value of
//! the file is above 255, as most writers scale it; taken as it is otherwise).
//! Intensity, classification and the other attributes are not kept.
//!
//! The header is checked here before the crate sees it, since it trusts the file's
//! counts: the scales and offsets must be finite (a scale of 0 too is an error), the
//! points (uncompressed) must fit in the bytes after the header, an extended record
//! and a LAZ chunk table must lie inside the file. Points are then decoded a batch
//! (at most 65,536 points and 8 MiB of records) at a time, so a count that lies
//! about a LAZ body fails where the data ends without reserving more than a batch; a damaged LAZ stream on which the decoder
//! panics is an error too (`quiet_catch` in `io`). A point with a non-finite
//! coordinate (only a huge scale can make one) is skipped and counted.
//!
//! Cost: one pass over the points; memory is the file, the output and one batch.

use super::{decode_guarded, At, Cloud, ReadErrorKind};
use ::las::{raw, PointDataBuilder, Reader};
use std::io::Cursor;

type Result<T> = core::result::Result<T, ReadErrorKind>;

/// Points decoded at a time, at most.
const BATCH: u64 = 1 << 16;
/// Bytes of point records decoded at a time, at most: a record may be 65,535
/// bytes long (extra bytes), and the decoder sizes its buffer for a batch
/// before it finds that a LAZ body ends early.
const BATCH_BYTES: u64 = 1 << 23;

/// The smallest point record of any format (format 0): a LAZ chunk starts with one
/// point uncompressed, so a file holds at most its length over this many chunks.
const MIN_RECORD: u64 = 20;

fn las_error(e: ::las::Error) -> ReadErrorKind {
    ReadErrorKind::file(format!("LAS: {e}"))
}

fn u64_at(data: &[u8], at: u64) -> Option<u64> {
    let at = usize::try_from(at).ok()?;
    let b = data.get(at..at.checked_add(8)?)?;
    Some(u64::from_le_bytes(b.try_into().ok()?))
}

/// The header's point count, as the `las` crate takes it (the legacy count unless
/// it is 0 in a 1.4 file).
fn point_count(h: &raw::Header) -> u64 {
    let legacy = u64::from(h.number_of_point_records);
    match h.large_file {
        Some(lf) if legacy == 0 => lf.number_of_point_records,
        _ => legacy,
    }
}

/// Checks what the `las` crate trusts in a header (see the module docs).
fn check_header(data: &[u8]) -> Result<()> {
    if data.len() < 4 || &data[..4] != b"LASF" {
        return Err(ReadErrorKind::invalid(
            At::Byte(0),
            "not a LAS file: it does not start with \"LASF\"",
        ));
    }
    let h = raw::Header::read_from(data).map_err(|e| match e {
        ::las::Error::Io(_) => ReadErrorKind::file(format!(
            "the file ends inside the LAS header ({} bytes)",
            data.len()
        )),
        e => las_error(e),
    })?;
    let len = data.len() as u64;
    for (axis, scale, offset) in [
        ("x", h.x_scale_factor, h.x_offset),
        ("y", h.y_scale_factor, h.y_offset),
        ("z", h.z_scale_factor, h.z_offset),
    ] {
        if !(scale.is_finite() && scale != 0.0 && offset.is_finite()) {
            return Err(ReadErrorKind::file(format!(
                "the header's {axis} scale {scale} and offset {offset} do not map to \
                 coordinates (finite, scale not 0)"
            )));
        }
    }
    let start = u64::from(h.offset_to_point_data);
    if start > len || u64::from(h.header_size) > start {
        return Err(ReadErrorKind::file(format!(
            "the header puts the points at byte {start}, outside the header ({} bytes) \
             and the file ({len} bytes)",
            h.header_size
        )));
    }
    let count = point_count(&h);
    let record = u64::from(h.point_data_record_length);
    let body = count.checked_mul(record).and_then(|b| b.checked_add(start));
    let compressed = ::las::point::Format::new(h.point_data_record_format)
        .map_err(las_error)?
        .is_compressed;
    match body {
        Some(end) if compressed || end <= len => {}
        _ => {
            return Err(ReadErrorKind::invalid(
                At::Byte(start as usize),
                format!(
                    "header declares {count} points of {record} bytes but only {} bytes \
                     of data follow",
                    len - start
                ),
            ))
        }
    }
    if compressed {
        // The chunk table: its offset is the first 8 bytes of the point data
        // (u64::MAX: none); at it, a version and the number of chunks.
        if let Some(table) = u64_at(data, start).filter(|&t| t != u64::MAX) {
            let chunks = u64_at(data, table).map(|v| v >> 32);
            match chunks {
                Some(c) if c <= len / MIN_RECORD => {}
                Some(c) => {
                    return Err(ReadErrorKind::invalid(
                        At::Byte(table as usize),
                        format!("the LAZ chunk table declares {c} chunks in a file of {len} bytes"),
                    ))
                }
                None => {
                    return Err(ReadErrorKind::invalid(
                        At::Byte(start as usize),
                        format!(
                            "the LAZ chunk table offset {table} is outside the file ({len} bytes)"
                        ),
                    ))
                }
            }
        }
    }
    if let Some(evlr) = h.evlr {
        // An extended record: 60 bytes of header, its length at byte 20.
        let at = evlr.start_of_first_evlr;
        let fits = at
            .checked_add(20)
            .and_then(|l| u64_at(data, l))
            .and_then(|n| n.checked_add(at)?.checked_add(60))
            .is_some_and(|end| end <= len);
        if !fits {
            return Err(ReadErrorKind::invalid(
                At::Byte(at.min(len) as usize),
                format!("the extended variable length record at byte {at} does not fit in the file ({len} bytes)"),
            ));
        }
    }
    Ok(())
}

/// Parses a LAS or LAZ cloud (the file's bytes).
pub fn parse_cloud(data: Vec<u8>) -> Result<Cloud> {
    check_header(&data)?;
    decode_guarded(data, decode, "LAS", "compressed data", "LAZ decoder")
}

/// Decodes every point; `done` counts those decoded, for a message.
fn decode(data: Vec<u8>, done: &mut u64) -> Result<Cloud> {
    let file_len = data.len();
    let mut reader = Reader::new(Cursor::new(data)).map_err(las_error)?;
    let count = reader.header().number_of_points();
    if count == 0 {
        return Err(ReadErrorKind::file("the header declares 0 points"));
    }
    // The count is the header's: reserve at most a point per 2 bytes of the file
    // (the vectors grow past that for a LAZ file that packs points tighter).
    let cap = usize::try_from(count).map_or(file_len / 2, |c| c.min(file_len / 2));
    let mut cloud = Cloud {
        positions: Vec::with_capacity(cap),
        ..Cloud::default()
    };
    let has_color = reader.header().point_format().has_color;
    let mut wide: Vec<[u16; 3]> = Vec::with_capacity(if has_color { cap } else { 0 });
    let mut batch = PointDataBuilder::new().for_header(reader.header()).build();
    let record = u64::from(reader.header().point_format().len()).max(1);
    let batch_points = BATCH.min(BATCH_BYTES / record).max(1);
    while *done < count {
        let n = reader
            .fill_points(batch_points.min(count - *done), &mut batch)
            .map_err(|e| {
                ReadErrorKind::file(format!(
                    "LAS: point {done} of {count}: {e} (the header's count is larger than \
                     the data, or the data is damaged)"
                ))
            })?;
        if n == 0 {
            return Err(ReadErrorKind::file(format!(
                "the file ends after {done} of {count} points"
            )));
        }
        let colors = batch.rgb();
        let mut colors = colors.into_iter().flatten();
        for ((x, y), z) in batch.x().zip(batch.y()).zip(batch.z()) {
            let c = colors.next();
            let p = [x, y, z];
            if !p.iter().all(|v| v.is_finite()) {
                cloud.invalid += 1;
                continue;
            }
            cloud.positions.push(p);
            if let Some((r, g, b)) = c {
                wide.push([r, g, b]);
            }
        }
        *done += n;
    }
    if cloud.positions.is_empty() {
        return Err(ReadErrorKind::file(format!(
            "no valid points: all {count} have a non-finite coordinate"
        )));
    }
    if has_color {
        let shift = if wide.iter().flatten().any(|&c| c > 255) {
            8
        } else {
            0
        };
        cloud.colors = Some(wide.iter().map(|c| c.map(|v| (v >> shift) as u8)).collect());
    }
    Ok(cloud)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ::las::{point::Format, Builder, Color, Point, Writer};

    /// A LAS (or LAZ, `compress`) file of `points` in format `format` (1.4).
    pub(crate) fn write(points: &[[f64; 3]], format: u8, compress: bool) -> Vec<u8> {
        let mut b = Builder::from((1, 4));
        b.point_format = Format::new(format).unwrap();
        b.point_format.is_compressed = compress;
        b.transforms.x.scale = 0.001;
        b.transforms.x.offset = 500_000.0;
        b.transforms.y.scale = 0.001;
        b.transforms.y.offset = 4_000_000.0;
        b.transforms.z.scale = 0.001;
        let header = b.into_header().unwrap();
        let mut w = Writer::new(Cursor::new(Vec::new()), header).unwrap();
        for (i, p) in points.iter().enumerate() {
            let mut q = Point {
                x: p[0],
                y: p[1],
                z: p[2],
                ..Default::default()
            };
            let f = Format::new(format).unwrap();
            if f.has_color {
                q.color = Some(Color::new(i as u16 * 4096, 0, 65535));
            }
            if f.has_gps_time {
                q.gps_time = Some(0.0);
            }
            w.write_point(q).unwrap();
        }
        w.close().unwrap();
        w.into_inner().unwrap().into_inner()
    }

    fn points() -> Vec<[f64; 3]> {
        vec![
            [500_000.125, 4_000_000.5, 12.25],
            [500_001.0, 4_000_001.0, -3.0],
        ]
    }

    #[test]
    fn las_and_laz_keep_georeferenced_coordinates_and_colour() {
        for compress in [false, true] {
            let c = parse_cloud(write(&points(), 3, compress)).unwrap();
            assert_eq!(c.positions, points(), "compressed: {compress}");
            assert_eq!(c.colors, Some(vec![[0, 0, 255], [16, 0, 255]]));
            assert_eq!(c.invalid, 0);
        }
        let c = parse_cloud(write(&points(), 0, false)).unwrap();
        assert_eq!((c.positions.len(), c.colors), (2, None));
    }

    #[test]
    fn a_lying_count_is_an_error_at_the_header() {
        let mut data = write(&points(), 0, false);
        // Legacy point count at byte 107.
        data[107..111].copy_from_slice(&4_000_000_000u32.to_le_bytes());
        let e = parse_cloud(data).unwrap_err().to_string();
        assert!(
            e.contains("header declares 4000000000 points of 20 bytes"),
            "{e}"
        );
    }

    #[test]
    fn not_a_las_file() {
        let e = parse_cloud(b"PLY\n".to_vec()).unwrap_err().to_string();
        assert!(e.contains("does not start with \"LASF\""), "{e}");
        let e = parse_cloud(b"LASF".to_vec()).unwrap_err().to_string();
        assert!(e.contains("ends inside the LAS header"), "{e}");
    }
}
