//! Reading an input with a bound: a regular file larger than
//! [`MAX_INPUT_BYTES`] fails before a byte is read; a stream (standard input, a
//! pipe, a device) fails as soon as it passes that, or as soon as its first
//! bytes cannot open a file of its format ([`opening`]), so `/dev/zero` read as
//! text or `/dev/urandom` read as PLY fail at once instead of filling memory.
//!
//! Cost: one pass over the bytes; memory is the bytes read, grown a chunk at a
//! time, each reservation checked (an allocation the system refuses is an
//! error, not an abort).

use super::{is_stdio, At, ReadError, ReadErrorKind, Shown};
use crate::limits::MAX_INPUT_BYTES;
use std::fs::File;
use std::io::{self, Read};
use std::path::Path;

/// Bytes of a stream looked at ([`opening`]) before the rest is read.
const HEAD_BYTES: usize = 1 << 16;
/// Bytes read from a stream at a time.
const CHUNK: usize = 1 << 20;
/// Bytes of a binary STL before its triangles, and of one triangle.
const STL_HEAD: u64 = 84;
const STL_TRIANGLE: u64 = 50;

/// The bytes of `path` (`-`: standard input), at most [`MAX_INPUT_BYTES`];
/// `format` is the extension its bytes are read as (`None`: not known yet, for
/// standard input without `--format`).
pub(super) fn read_input(path: &Path, format: Option<&str>) -> Result<Vec<u8>, ReadError> {
    let fail = |kind| ReadError::new(path, kind);
    if is_stdio(path) {
        return read_stream(io::stdin().lock(), format).map_err(fail);
    }
    let mut file = File::open(path).map_err(|e| fail(ReadErrorKind::Io(e)))?;
    let meta = file.metadata().map_err(|e| fail(ReadErrorKind::Io(e)))?;
    if !meta.is_file() {
        return read_stream(file, format).map_err(fail);
    }
    let len = meta.len();
    if len > MAX_INPUT_BYTES {
        return Err(fail(ReadErrorKind::file(format!(
            "{len} bytes, more than the limit of {MAX_INPUT_BYTES} bytes (4 GiB) an input may have"
        ))));
    }
    let mut data = Vec::new();
    reserve(&mut data, len as usize + 1).map_err(fail)?;
    // A file that grows while it is read is still cut at the limit.
    (&mut file)
        .take(MAX_INPUT_BYTES + 1)
        .read_to_end(&mut data)
        .map_err(|e| fail(ReadErrorKind::Io(e)))?;
    over_limit(&data, MAX_INPUT_BYTES).map_err(fail)?;
    Ok(data)
}

/// `data.try_reserve(more)`, a refusal an error naming the size.
fn reserve(data: &mut Vec<u8>, more: usize) -> Result<(), ReadErrorKind> {
    data.try_reserve(more).map_err(|e| {
        ReadErrorKind::file(format!(
            "cannot hold {} bytes of input in memory: {e}",
            data.len().saturating_add(more)
        ))
    })
}

/// `Err` when `data` is longer than `limit` bytes.
fn over_limit(data: &[u8], limit: u64) -> Result<(), ReadErrorKind> {
    if data.len() as u64 > limit {
        return Err(ReadErrorKind::file(format!(
            "more than the limit of {limit} bytes (4 GiB) an input may have"
        )));
    }
    Ok(())
}

/// A stream read to its end, a chunk at a time, checked by [`opening`] once
/// its first [`HEAD_BYTES`] are in (or it ends), and held to the length that
/// gives and to [`MAX_INPUT_BYTES`].
fn read_stream(mut r: impl Read, format: Option<&str>) -> Result<Vec<u8>, ReadErrorKind> {
    let mut data = Vec::new();
    let mut longest: Option<Longest> = None;
    let mut checked = false;
    loop {
        reserve(&mut data, CHUNK)?;
        let n = (&mut r)
            .take(CHUNK as u64)
            .read_to_end(&mut data)
            .map_err(ReadErrorKind::Io)?;
        let end = n == 0;
        if !checked && (data.len() >= HEAD_BYTES || end) {
            checked = true;
            longest = opening(format, &data)?;
        }
        if let Some(l) = &longest {
            if data.len() as u64 > l.bytes {
                return Err(ReadErrorKind::invalid(At::Byte(l.bytes as usize), &l.why));
            }
        }
        over_limit(&data, MAX_INPUT_BYTES)?;
        if end {
            return Ok(data);
        }
    }
}

/// The most bytes a stream may hold, as its first bytes say, and the error
/// when it holds more.
#[derive(Debug, PartialEq)]
struct Longest {
    bytes: u64,
    why: String,
}

/// Whether `head`, the first bytes of a stream, can open a file of `format`
/// (an extension; `None`: standard input whose format its bytes will tell):
/// PLY's first line is `ply`, LAS's and E57's magic is there, the first line of
/// a text format (text columns, OBJ, OFF, PCD's header) is text, and a binary
/// STL's complete triangles have finite corners. `Some` when the stream can
/// hold no more than a binary STL's header gives.
fn opening(format: Option<&str>, head: &[u8]) -> Result<Option<Longest>, ReadErrorKind> {
    match format {
        Some("ply") => {
            first_line_text(head)?;
            let line = first_line(head);
            let magic = String::from_utf8_lossy(line);
            if magic.trim() != "ply" && (line.len() < head.len() || head.len() >= 4) {
                return Err(ReadErrorKind::line(
                    1,
                    format!(
                        "not a PLY file: first line is {}, expected \"ply\"",
                        Shown(&magic)
                    ),
                ));
            }
            Ok(None)
        }
        Some("las" | "laz") => magic(head, b"LASF", "LAS"),
        Some("e57") => magic(head, b"ASTM-E57", "E57"),
        Some("stl") => binary_stl(head),
        Some(format) => head_text(head, format == "pcd").map(|()| None),
        None if [&b"ply"[..], b"LASF", b"ASTM-E57"]
            .iter()
            .any(|m| head.starts_with(m)) =>
        {
            Ok(None)
        }
        // Binary, with no magic: a binary STL is the one format it can be.
        None => match head_text(head, true) {
            Ok(()) => Ok(None),
            Err(text) => binary_stl(head).map_err(|_| text).map(|longest| {
                longest.map(|l| Longest {
                    why: format!("not text, nor a binary STL: {}", l.why),
                    ..l
                })
            }),
        },
    }
}

fn first_line(head: &[u8]) -> &[u8] {
    head.split(|&b| b == b'\n').next().unwrap_or_default()
}

/// Lines at the start of a text format that must be text ([`head_text`]): a
/// stream of noise has a line of text by chance about once in 130 (a newline
/// early, before any NUL or bad UTF-8), eight in a row practically never, and
/// every real file of a text format has them (a PCD header has at least eight
/// lines up to and including `DATA`, or ends there).
const TEXT_LINES: usize = 8;

/// `Err` when one of the first [`TEXT_LINES`] lines of `head` holds a NUL
/// byte or is not UTF-8 (a character cut by the end of `head` passes). A line
/// starting with `DATA` ends the look when `pcd` (a binary PCD's data follows
/// it).
fn head_text(head: &[u8], pcd: bool) -> Result<(), ReadErrorKind> {
    let mut rest = head;
    for number in 1..=TEXT_LINES {
        let (line, more) = match rest.iter().position(|&b| b == b'\n') {
            Some(i) => (&rest[..i], Some(&rest[i + 1..])),
            None => (rest, None),
        };
        line_text(number, line, more.is_none())?;
        let data_follows = pcd && line.starts_with(b"DATA");
        match more {
            Some(more) if !more.is_empty() && !data_follows => rest = more,
            _ => break,
        }
    }
    Ok(())
}

/// `Err` when the first line of `head` (all of it without a newline) holds a
/// NUL byte or is not UTF-8 (but for a character the end of `head` cuts).
fn first_line_text(head: &[u8]) -> Result<(), ReadErrorKind> {
    let line = first_line(head);
    line_text(1, line, line.len() == head.len())
}

/// `Err` naming line `number` when `line` holds a NUL byte or is not UTF-8;
/// a character cut at its end passes when `cut` (the head ends there).
fn line_text(number: usize, line: &[u8], cut: bool) -> Result<(), ReadErrorKind> {
    if let Some(i) = line.iter().position(|&b| b == 0) {
        return Err(ReadErrorKind::line(
            number,
            format!("not text: byte {} of the line is a NUL byte", i + 1),
        ));
    }
    match std::str::from_utf8(line) {
        Err(e) if e.error_len().is_some() || !cut => Err(ReadErrorKind::line(
            number,
            format!(
                "not text: byte {} of the line is not valid UTF-8",
                e.valid_up_to() + 1
            ),
        )),
        _ => Ok(()),
    }
}

fn magic(head: &[u8], magic: &[u8], name: &str) -> Result<Option<Longest>, ReadErrorKind> {
    if head.starts_with(magic) {
        return Ok(None);
    }
    Err(ReadErrorKind::invalid(
        At::Byte(0),
        format!(
            "not a {name} file: it does not start with \"{}\"",
            String::from_utf8_lossy(magic)
        ),
    ))
}

/// An ASCII STL (`solid`, no NUL byte) opens any way; a binary one is as
/// long as its header's triangle count gives, and its triangles in `head` have
/// finite corners.
fn binary_stl(head: &[u8]) -> Result<Option<Longest>, ReadErrorKind> {
    if head.trim_ascii_start().starts_with(b"solid") && !head.contains(&0) {
        return Ok(None);
    }
    let Some(n) = head.get(80..STL_HEAD as usize) else {
        return Ok(None);
    };
    let count = u64::from(u32::from_le_bytes([n[0], n[1], n[2], n[3]]));
    let body = &head[STL_HEAD as usize..];
    for (t, tri) in body
        .chunks_exact(STL_TRIANGLE as usize)
        .take(count as usize)
        .enumerate()
    {
        let corners = tri[12..48].chunks_exact(4);
        if let Some(v) = corners
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .find(|v| !v.is_finite())
        {
            return Err(ReadErrorKind::invalid(
                At::Byte(STL_HEAD as usize + t * STL_TRIANGLE as usize),
                format!("binary STL: triangle {t} has the corner coordinate {v}, not finite"),
            ));
        }
    }
    let bytes = STL_HEAD + count * STL_TRIANGLE;
    Ok(Some(Longest {
        bytes,
        why: format!("binary STL declares {count} triangles, {bytes} bytes, but more follow"),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(format: Option<&str>, head: &[u8]) -> String {
        opening(format, head).unwrap_err().to_string()
    }

    #[test]
    fn streams_of_zeros_or_noise_fail_on_their_first_bytes() {
        let zeros = vec![0u8; HEAD_BYTES];
        assert_eq!(
            err(Some("xyz"), &zeros),
            "line 1: not text: byte 1 of the line is a NUL byte"
        );
        assert!(err(Some("ply"), &zeros).contains("NUL"));
        assert!(err(Some("ply"), b"PK\x03\x04 zip\n").contains("not a PLY file"));
        assert!(err(Some("las"), &zeros).contains("not a LAS file"));
        assert!(err(Some("xyz"), b"1 2 \xff\n").contains("byte 5 of the line is not valid UTF-8"));
        // Noise with a newline early: its first line is text by chance, the
        // next ones are not.
        assert_eq!(
            err(Some("pcd"), b"\n\n# a\n\x01\x80\x02\n"),
            "line 4: not text: byte 2 of the line is not valid UTF-8"
        );
        // A character cut before a newline is not one cut by the head's end.
        assert!(err(Some("xyz"), b"1 2 \xc3\n3").contains("line 1: not text"));
        // Zeros are a binary STL of no triangles: 84 bytes, no more.
        let l = opening(Some("stl"), &zeros).unwrap().unwrap();
        assert_eq!(l.bytes, 84);
        assert!(opening(None, &zeros)
            .unwrap()
            .unwrap()
            .why
            .starts_with("not text"));
        // Corners that are not finite.
        let mut stl = vec![0u8; 84 + 50];
        stl[80] = 1;
        stl[84 + 12..84 + 16].copy_from_slice(&f32::NAN.to_le_bytes());
        assert!(err(Some("stl"), &stl).contains("triangle 0"));
    }

    #[test]
    fn the_first_bytes_of_real_files_pass() {
        assert_eq!(
            opening(Some("ply"), b"ply\r\nformat ascii 1.0\n").unwrap(),
            None
        );
        assert_eq!(opening(Some("ply"), b"pl").unwrap(), None);
        assert_eq!(
            opening(Some("xyz"), "1 2 3 é\n".repeat(8).as_bytes()).unwrap(),
            None
        );
        // Only the first eight lines are looked at; a binary PCD's data
        // follows its DATA line.
        let ninth = "1 2 3\n".repeat(8) + "\0\n";
        assert_eq!(opening(Some("xyz"), ninth.as_bytes()).unwrap(), None);
        let pcd = b"FIELDS x y z\nPOINTS 1\nDATA binary\n\0\0\0\0\xff";
        assert_eq!(opening(Some("pcd"), pcd).unwrap(), None);
        assert_eq!(opening(None, pcd).unwrap(), None);
        // A character cut by the end of the head.
        assert_eq!(
            opening(Some("xyz"), &"1 2 é".as_bytes()[..5]).unwrap(),
            None
        );
        assert_eq!(opening(Some("stl"), b"solid cube\n").unwrap(), None);
        assert_eq!(opening(None, b"LASF\0\0\0").unwrap(), None);
        let mut stl = vec![0u8; 84 + 100];
        stl[80] = 2;
        assert_eq!(opening(None, &stl).unwrap().unwrap().bytes, 184);
    }
}
