//! E57 (ASTM E2807) point clouds, decoded by the `e57` crate: every scan of the
//! file, each moved by its pose into the file's frame and its spherical
//! coordinates turned Cartesian (the crate's defaults), one cloud of all of them.
//! Colours are kept when every scan has them; intensity is not kept.
//!
//! A point marked invalid (`cartesianInvalidState`: no return, or a direction
//! only) or with a non-finite coordinate is skipped and counted, as the E57 tools
//! do. The header's XML section must lie inside the file before the crate reads
//! it (the crate would reserve up to 50 MB for a lying length); decoding runs
//! under `quiet_catch` (in `io`), so a damaged file stays a read error.
//!
//! Cost: one pass over the points; memory is the file and the output.

use super::{decode_guarded, At, Cloud, ReadErrorKind};
use ::e57::{CartesianCoordinate, E57Reader};
use std::io::Cursor;

type Result<T> = core::result::Result<T, ReadErrorKind>;

/// Bytes of the E57 file header, and where it holds the XML offset and length.
const HEADER: usize = 48;
const XML_OFFSET: usize = 24;
const XML_LENGTH: usize = 32;

fn e57_error(e: ::e57::Error) -> ReadErrorKind {
    ReadErrorKind::file(format!("E57: {e}"))
}

fn u64_at(data: &[u8], at: usize) -> u64 {
    let mut b = [0u8; 8];
    b.copy_from_slice(&data[at..at + 8]);
    u64::from_le_bytes(b)
}

/// Checks the signature and that the XML section lies inside the file.
fn check_header(data: &[u8]) -> Result<()> {
    if !data.starts_with(b"ASTM-E57") {
        return Err(ReadErrorKind::invalid(
            At::Byte(0),
            "not an E57 file: it does not start with \"ASTM-E57\"",
        ));
    }
    if data.len() < HEADER {
        return Err(ReadErrorKind::file(format!(
            "the file ends inside the E57 header ({} bytes of {HEADER})",
            data.len()
        )));
    }
    let (offset, length) = (u64_at(data, XML_OFFSET), u64_at(data, XML_LENGTH));
    if offset
        .checked_add(length)
        .is_none_or(|end| end > data.len() as u64)
    {
        return Err(ReadErrorKind::invalid(
            At::Byte(XML_OFFSET),
            format!(
                "the header puts {length} bytes of XML at byte {offset}, past the end of \
                 the file ({} bytes)",
                data.len()
            ),
        ));
    }
    Ok(())
}

/// Parses an E57 cloud (the file's bytes).
pub fn parse_cloud(data: Vec<u8>) -> Result<Cloud> {
    check_header(&data)?;
    decode_guarded(data, decode, "E57", "data", "E57 decoder")
}

/// Decodes every scan; `done` counts the points decoded, for a message.
fn decode(data: Vec<u8>, done: &mut u64) -> Result<Cloud> {
    let file_len = data.len();
    let mut e57 = E57Reader::new(Cursor::new(data)).map_err(e57_error)?;
    let scans = e57.pointclouds();
    let total = scans
        .iter()
        .fold(0u64, |n, pc| n.saturating_add(pc.records));
    if total == 0 {
        return Err(ReadErrorKind::file(format!(
            "E57: no points ({} scans)",
            scans.len()
        )));
    }
    let with_color = scans.iter().all(|pc| pc.has_color());
    // The counts are the XML's: reserve no more points than bytes.
    let cap = usize::try_from(total).map_or(file_len, |n| n.min(file_len));
    let mut cloud = Cloud {
        positions: Vec::with_capacity(cap),
        ..Cloud::default()
    };
    let mut colors = Vec::with_capacity(if with_color { cap } else { 0 });
    for (scan, pc) in scans.iter().enumerate() {
        let mut points = e57.pointcloud_simple(pc).map_err(e57_error)?;
        points.intensity_to_color(false);
        for p in points {
            let p =
                p.map_err(|e| ReadErrorKind::file(format!("E57: scan {scan}, point {done}: {e}")))?;
            *done += 1;
            let CartesianCoordinate::Valid { x, y, z } = p.cartesian else {
                cloud.invalid += 1;
                continue;
            };
            if !(x.is_finite() && y.is_finite() && z.is_finite()) {
                cloud.invalid += 1;
                continue;
            }
            cloud.positions.push([x, y, z]);
            if with_color {
                let c = p.color.map_or([0.0; 3], |c| [c.red, c.green, c.blue]);
                colors.push(c.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8));
            }
        }
    }
    if cloud.positions.is_empty() {
        return Err(ReadErrorKind::file(format!(
            "no valid points: all {total} are marked invalid or not finite"
        )));
    }
    cloud.colors = with_color.then_some(colors);
    Ok(cloud)
}
