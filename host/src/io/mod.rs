//! File formats: point clouds in (PLY, text, PCD, LAS/LAZ, E57, and the vertices of
//! OBJ, OFF and STL meshes), meshes and labelled points out (PLY, OBJ, OFF), and
//! meshes back in (PLY, OBJ, OFF, STL) for evaluation.
//!
//! Every reader loads the whole file (inputs are tens of MB, at most
//! [`crate::limits::MAX_INPUT_BYTES`]; a stream that cannot open a file of its
//! format fails on its first bytes, see the `bounded` module) and parses the byte slice in
//! one pass: O(file size) time, memory proportional to the output. Readers are
//! written for hostile input:
//! - any malformed file is a [`ReadError`] naming the path, the place (1-based line for
//!   text, element index or byte offset for binary) and the offending value; never a
//!   panic (the decoders of other crates run under `quiet_catch`);
//! - nothing is reserved from a header count until the bytes that count promises are
//!   known to exist, so `element vertex 4000000000` over a 100-byte body fails at once,
//!   and every size computed from a header is checked arithmetic;
//! - positions must be finite: PCD, LAS/LAZ and E57, whose tools mark a missing
//!   measure with a NaN or an invalid flag, skip such points and count them
//!   ([`Cloud::invalid`]); the other formats reject them (the error names the vertex);
//! - normals pass through as read, NaN or zero included, because core decides what a
//!   bad normal means.
//!
//! Writers go through [`write_atomic`]: a reader of the target never sees half a file.

use std::cell::Cell;
use std::fmt;
use std::io;
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::sync::Once;

mod bounded;
pub mod e57;
pub mod las;
pub mod lzf;
pub mod obj;
pub mod off;
pub mod pcd;
pub mod ply;
pub mod stl;
pub mod write;
pub mod xyz;

pub use write::{
    stage, stage_to, write_atomic, write_mesh, write_points_ply, write_to, Coords, MeshFormat,
    MeshLayout, MeshOut, Precision, Staged, WriteError,
};

/// A point cloud as read from a file, in the file's own units (`f64`).
///
/// Invariant: `positions` is non-empty and every coordinate is finite; when present,
/// `normals` and `colors` have exactly one entry per position (normals may be NaN or
/// zero).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cloud {
    /// Point positions, all finite.
    pub positions: Vec<[f64; 3]>,
    /// Per-point normals exactly as stored in the file, if it has them.
    pub normals: Option<Vec<[f64; 3]>>,
    /// Per-point colours (8 bits a channel), if the file has them.
    pub colors: Option<Vec<[u8; 3]>>,
    /// Points the file holds but the cloud leaves out because a coordinate is NaN
    /// or infinite: formats whose tools mark missing points that way (PCD, LAS)
    /// skip them and count them here; the others reject them.
    pub invalid: usize,
}

/// A triangle mesh as read from a file: vertex positions (finite) and triangles whose
/// indices are all `< vertices.len()`. Polygons are triangulated as fans.
pub type Mesh = (Vec<[f64; 3]>, Vec<[u32; 3]>);

/// Extensions [`read_cloud`] understands (lower case, compared case-insensitively).
pub const CLOUD_EXTENSIONS: &str =
    ".ply, .xyz, .xyzn, .txt, .pts, .csv, .pcd, .las, .laz, .e57, .obj, .off, .stl";
/// Extensions [`read_mesh`] understands.
pub const MESH_EXTENSIONS: &str = ".ply, .obj, .off, .stl";

/// How to read a cloud, beyond what the file says.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ReadOptions {
    /// The columns of a text cloud (`--columns`), over its header or column count;
    /// for another format an error.
    pub columns: Option<xyz::Columns>,
    /// The format, as an extension from [`CLOUD_EXTENSIONS`] without the dot
    /// (`--format`), over the path's extension (or, for standard input, over
    /// what its first bytes say).
    pub format: Option<String>,
}

/// The path that names standard input (and, for writers, standard output).
pub const STDIO: &str = "-";

/// Whether `path` is [`STDIO`].
pub fn is_stdio(path: &Path) -> bool {
    path.as_os_str() == STDIO
}

/// Whether `ext` (lower case, no dot) is one of [`CLOUD_EXTENSIONS`].
pub fn is_cloud_extension(ext: &str) -> bool {
    CLOUD_EXTENSIONS
        .split(", ")
        .any(|e| e.strip_prefix('.') == Some(ext))
}

/// The format of a cloud without a name, from its first bytes, as the
/// extension that names it: a PLY, LAS/LAZ (`LASF`), E57 (`ASTM-E57`), PCD
/// (a first line, after `#` comments, that starts with `VERSION` or `FIELDS`),
/// OFF or OBJ (a first statement `v`, `vn`, `f`, `o`, `g` or `mtllib`) header,
/// or a binary STL (its length is the one its triangle count gives); anything
/// else is read as text columns (`xyz`), whose reader names a line it cannot
/// read.
fn sniff(data: &[u8]) -> &'static str {
    let starts = |magic: &[u8]| data.starts_with(magic);
    if starts(b"ply\n") || starts(b"ply\r\n") {
        return "ply";
    }
    if starts(b"LASF") {
        return "las";
    }
    if starts(b"ASTM-E57") {
        return "e57";
    }
    if let Some(n) = data.get(80..84) {
        let count = u64::from(u32::from_le_bytes([n[0], n[1], n[2], n[3]]));
        if 84 + 50 * count == data.len() as u64 {
            return "stl";
        }
    }
    let first = data
        .split(|&b| b == b'\n')
        .map(|l| l.trim_ascii())
        .find(|l| !l.is_empty() && !l.starts_with(b"#"))
        .unwrap_or_default();
    let word = first
        .split(|b| b.is_ascii_whitespace())
        .next()
        .unwrap_or_default();
    match word {
        b"VERSION" | b"FIELDS" => "pcd",
        b"OFF" | b"COFF" | b"NOFF" | b"CNOFF" => "off",
        b"v" | b"vn" | b"vt" | b"f" | b"o" | b"g" | b"mtllib" => "obj",
        _ if first.starts_with(b"solid") => "stl",
        _ => "xyz",
    }
}

/// A cloud format, from the extension.
#[derive(Clone, Copy)]
enum CloudFormat {
    Ply,
    Text,
    Pcd,
    Las,
    E57,
    /// A mesh, whose vertices are the points.
    Mesh(fn(&[u8]) -> Result<Mesh, ReadErrorKind>),
}

/// Reads a point cloud with the default [`ReadOptions`], see [`read_cloud_with`].
pub fn read_cloud(path: &Path) -> Result<Cloud, ReadError> {
    read_cloud_with(path, &ReadOptions::default())
}

/// Reads a point cloud, choosing the format from `options.format` or else the
/// extension (case-insensitive): `.ply`; `.xyz`, `.xyzn`, `.txt`, `.pts`, `.csv`
/// (text, [`xyz`]); `.pcd`; `.las`, `.laz`; `.e57`; and the meshes `.obj`, `.off`,
/// `.stl`, whose vertices are the points (a PLY mesh is read that way too).
///
/// `-` ([`STDIO`]) reads standard input to its end, its format from
/// `options.format` or else from its first bytes (a PLY, PCD, LAS/LAZ, E57,
/// OFF, OBJ or STL header; else text columns); errors then name it
/// `standard input`.
///
/// Cost: one read of the file plus one pass over its bytes.
pub fn read_cloud_with(path: &Path, options: &ReadOptions) -> Result<Cloud, ReadError> {
    let stdin = if is_stdio(path) {
        let data = bounded::read_input(path, options.format.as_deref())?;
        if data.is_empty() {
            return Err(ReadError::new(path, ReadErrorKind::file("no data")));
        }
        Some(data)
    } else {
        None
    };
    let ext = match (&options.format, &stdin) {
        (Some(f), _) => Some(f.to_ascii_lowercase()),
        // Columns are named for text only.
        (None, Some(_)) if options.columns.is_some() => Some("xyz".to_string()),
        (None, Some(data)) => Some(sniff(data).to_string()),
        (None, None) => extension(path),
    };
    let format = match ext.as_deref() {
        Some("ply") => CloudFormat::Ply,
        Some("xyz" | "xyzn" | "txt" | "pts" | "csv") => CloudFormat::Text,
        Some("pcd") => CloudFormat::Pcd,
        Some("las" | "laz") => CloudFormat::Las,
        Some("e57") => CloudFormat::E57,
        Some("obj") => CloudFormat::Mesh(obj::parse_mesh),
        Some("off") => CloudFormat::Mesh(off::parse_mesh),
        Some("stl") => CloudFormat::Mesh(stl::parse_mesh),
        _ => return Err(unknown_extension(path, ext, CLOUD_EXTENSIONS)),
    };
    if let (Some(columns), false) = (&options.columns, matches!(format, CloudFormat::Text)) {
        return Err(ReadError::new(
            path,
            ReadErrorKind::unsupported(
                At::File,
                format!(
                    "--columns {columns} for a .{} file (it names the columns of text \
                     clouds: .xyz, .xyzn, .txt, .pts, .csv)",
                    ext.unwrap_or_default()
                ),
            ),
        ));
    }
    let data = match stdin {
        Some(data) => data,
        None => load(path, ext.as_deref())?,
    };
    let cloud = match format {
        CloudFormat::Ply => ply::parse_cloud(&data),
        CloudFormat::Text => xyz::parse_cloud(&data, options.columns.as_ref()),
        CloudFormat::Pcd => pcd::parse_cloud(&data),
        CloudFormat::Las => las::parse_cloud(data),
        CloudFormat::E57 => e57::parse_cloud(data),
        CloudFormat::Mesh(parse) => parse(&data).map(|(positions, _)| Cloud {
            positions,
            ..Cloud::default()
        }),
    };
    match cloud {
        Ok(c) if c.positions.is_empty() => {
            Err(ReadError::new(path, ReadErrorKind::file("no points")))
        }
        Ok(c) => match check_magnitudes(&c.positions) {
            Ok(()) => Ok(c),
            Err(kind) => Err(ReadError::new(path, kind)),
        },
        Err(kind) => Err(ReadError::new(path, kind)),
    }
}

/// Reads a triangle mesh (`.ply` with a `face` element, `.obj`, `.off`, `.stl`),
/// triangulating polygons as fans. Same robustness rules as [`read_cloud`]; a face
/// index out of range is an error naming the face.
pub fn read_mesh(path: &Path) -> Result<Mesh, ReadError> {
    let ext = extension(path);
    let parse: fn(&[u8]) -> Result<Mesh, ReadErrorKind> = match ext.as_deref() {
        Some("ply") => ply::parse_mesh,
        Some("obj") => obj::parse_mesh,
        Some("off") => off::parse_mesh,
        Some("stl") => stl::parse_mesh,
        _ => return Err(unknown_extension(path, ext, MESH_EXTENSIONS)),
    };
    let data = load(path, ext.as_deref())?;
    parse(&data)
        .and_then(|mesh| check_magnitudes(&mesh.0).map(|()| mesh))
        .map_err(|kind| ReadError::new(path, kind))
}

fn extension(path: &Path) -> Option<String> {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
}

fn unknown_extension(path: &Path, ext: Option<String>, supported: &'static str) -> ReadError {
    ReadError::new(
        path,
        ReadErrorKind::UnknownExtension {
            ext: ext.unwrap_or_default(),
            supported,
        },
    )
}

/// The bytes of `path`, read as `ext`, at most [`crate::limits::MAX_INPUT_BYTES`].
fn load(path: &Path, ext: Option<&str>) -> Result<Vec<u8>, ReadError> {
    bounded::read_input(path, ext)
}

/// Why a file could not be read, with the path it came from.
///
/// `Display` gives one line: `path: place: what is wrong`, e.g.
/// `scan.xyz: line 17: expected 6 numbers like line 1, found 4`.
#[derive(Debug)]
pub struct ReadError {
    /// The file that was being read.
    pub path: PathBuf,
    /// What went wrong, and where in the file.
    pub kind: ReadErrorKind,
}

impl ReadError {
    /// Attaches the path to a parse failure.
    pub fn new(path: &Path, kind: ReadErrorKind) -> Self {
        ReadError {
            path: path.to_path_buf(),
            kind,
        }
    }
}

/// What went wrong while reading, independent of the path (parsers of byte slices
/// return this; [`ReadError`] adds the path).
#[derive(Debug)]
#[non_exhaustive]
pub enum ReadErrorKind {
    /// The file could not be read at all.
    Io(io::Error),
    /// The extension names no supported format (`ext` is empty when there is none).
    UnknownExtension {
        /// The extension found, lower case, without the dot.
        ext: String,
        /// The supported extensions, for the message.
        supported: &'static str,
    },
    /// A valid file using a feature this reader does not implement.
    Unsupported {
        /// Where the feature is declared.
        at: At,
        /// What it is.
        what: String,
    },
    /// The file is malformed.
    Invalid {
        /// Where the problem was found.
        at: At,
        /// What is wrong, with the offending value.
        what: String,
    },
    /// A position coordinate is finite but larger in magnitude than
    /// [`MAX_COORDINATE`].
    TooLarge {
        /// 0-based vertex (point) number.
        vertex: u64,
        /// 1-based line number, for text formats.
        line: Option<usize>,
        /// `"x"`, `"y"` or `"z"`.
        coord: &'static str,
        /// The value read.
        value: f64,
    },
    /// A position coordinate is NaN or infinite.
    NonFinite {
        /// 0-based vertex (point) number.
        vertex: u64,
        /// 1-based line number, for text formats.
        line: Option<usize>,
        /// `"x"`, `"y"` or `"z"`.
        coord: &'static str,
        /// The value read.
        value: f64,
    },
}

/// Where in a file a problem was found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum At {
    /// The file as a whole (empty, missing header line, ...).
    File,
    /// A 1-based line of a text file or text header.
    Line(usize),
    /// A byte offset into the file (binary bodies).
    Byte(usize),
}

impl ReadErrorKind {
    pub(crate) fn invalid(at: At, what: impl Into<String>) -> Self {
        ReadErrorKind::Invalid {
            at,
            what: what.into(),
        }
    }

    pub(crate) fn line(line: usize, what: impl Into<String>) -> Self {
        Self::invalid(At::Line(line), what)
    }

    pub(crate) fn file(what: impl Into<String>) -> Self {
        Self::invalid(At::File, what)
    }

    pub(crate) fn unsupported(at: At, what: impl Into<String>) -> Self {
        ReadErrorKind::Unsupported {
            at,
            what: what.into(),
        }
    }
}

fn fmt_at(f: &mut fmt::Formatter<'_>, at: At, what: &str) -> fmt::Result {
    match at {
        At::File => write!(f, "{what}"),
        At::Line(n) => write!(f, "line {n}: {what}"),
        At::Byte(b) => write!(f, "{what} (at byte {b})"),
    }
}

impl fmt::Display for ReadErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReadErrorKind::Io(e) => write!(f, "cannot read file: {e}"),
            ReadErrorKind::UnknownExtension { ext, supported } if ext.is_empty() => {
                write!(
                    f,
                    "no file extension to tell the format (supported: {supported})"
                )
            }
            ReadErrorKind::UnknownExtension { ext, supported } => {
                write!(f, "unknown extension '.{ext}' (supported: {supported})")
            }
            ReadErrorKind::Unsupported { at, what } => {
                fmt_at(f, *at, &format!("not supported: {what}"))
            }
            ReadErrorKind::Invalid { at, what } => fmt_at(f, *at, what),
            ReadErrorKind::NonFinite {
                vertex,
                line,
                coord,
                value,
            } => {
                if let Some(n) = line {
                    write!(f, "line {n}: ")?;
                }
                write!(f, "vertex {vertex}: {coord} is {value}")
            }
            ReadErrorKind::TooLarge {
                vertex,
                line,
                coord,
                value,
            } => {
                if let Some(n) = line {
                    write!(f, "line {n}: ")?;
                }
                write!(
                    f,
                    "vertex {vertex}: {coord} is {value:e}, beyond the largest coordinate \
                     vsaqem takes ({MAX_COORDINATE:e} in magnitude)"
                )
            }
        }
    }
}

impl fmt::Display for ReadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if is_stdio(&self.path) {
            write!(f, "standard input: {}", self.kind)
        } else {
            write!(f, "{}: {}", self.path.display(), self.kind)
        }
    }
}

impl std::error::Error for ReadError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.kind {
            ReadErrorKind::Io(e) => Some(e),
            _ => None,
        }
    }
}

/// The largest coordinate, in magnitude, a position may have: past float32's
/// 3.4e38 (the output is then float64), and far enough below float64's
/// 1.8e308 that the squares and products of the mesh's checks and of `eval`
/// stay finite (they are right at 1e50 and wrong at 1e60).
pub const MAX_COORDINATE: f64 = 1e40;

/// Checks that a position is finite and within [`MAX_COORDINATE`]; `vertex`
/// and `line` locate it for the message.
pub fn check_finite(p: [f64; 3], vertex: u64, line: Option<usize>) -> Result<(), ReadErrorKind> {
    for (value, coord) in p.into_iter().zip(["x", "y", "z"]) {
        if !value.is_finite() {
            return Err(ReadErrorKind::NonFinite {
                vertex,
                line,
                coord,
                value,
            });
        }
        if value.abs() > MAX_COORDINATE {
            return Err(ReadErrorKind::TooLarge {
                vertex,
                line,
                coord,
                value,
            });
        }
    }
    Ok(())
}

/// [`check_finite`] on every position, for the readers that skip the points
/// that are not finite (PCD, LAS, E57) and as the last word on the others.
fn check_magnitudes(positions: &[[f64; 3]]) -> Result<(), ReadErrorKind> {
    positions
        .iter()
        .zip(0u64..)
        .try_for_each(|(&p, i)| check_finite(p, i, None))
}

thread_local! {
    /// Set while `quiet_catch` runs its closure on this thread.
    static QUIET: Cell<bool> = const { Cell::new(false) };
}

/// Runs `f`, turning a panic into `Err` without a message on stderr, for the
/// decoders of other crates: the `laz` decoder asserts on some damaged streams
/// (laz 0.13: `sym < (1 << 16)` in its arithmetic decoder) instead of returning an
/// error; this keeps a damaged file a read error. Only this thread's panics
/// inside `f` are silenced: the panic hook installed here hands every other panic
/// to the previous hook.
pub(crate) fn quiet_catch<T>(f: impl FnOnce() -> T) -> std::thread::Result<T> {
    static HOOK: Once = Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !QUIET.with(Cell::get) {
                previous(info);
            }
        }));
    });
    QUIET.with(|q| q.set(true));
    let r = std::panic::catch_unwind(AssertUnwindSafe(f));
    QUIET.with(|q| q.set(false));
    r
}

/// `decode(data, &mut done)` under [`quiet_catch`]: a panic of the decoder
/// becomes the error `"{what}: point {done}: the {damaged} is damaged (the
/// {decoder} gave up)"`, `done` being the points decoded before it.
pub(crate) fn decode_guarded(
    data: Vec<u8>,
    decode: fn(Vec<u8>, &mut u64) -> Result<Cloud, ReadErrorKind>,
    what: &str,
    damaged: &str,
    decoder: &str,
) -> Result<Cloud, ReadErrorKind> {
    let mut done = 0u64;
    match quiet_catch(|| decode(data, &mut done)) {
        Ok(cloud) => cloud,
        Err(_) => Err(ReadErrorKind::file(format!(
            "{what}: point {done}: the {damaged} is damaged (the {decoder} gave up)"
        ))),
    }
}

/// A token from a file, quoted and cut to a readable length for an error message.
pub(crate) struct Shown<'a>(pub &'a str);

impl fmt::Display for Shown<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const MAX: usize = 40;
        let s = self.0;
        match s.char_indices().nth(MAX) {
            None => write!(f, "\"{}\"", s.escape_debug()),
            Some((cut, _)) => write!(f, "\"{}...\"", s[..cut].escape_debug()),
        }
    }
}

/// Lines of a byte slice with 1-based numbers; `\n` or `\r\n` endings, a last line
/// without a newline included, no empty line after a final newline.
pub(crate) struct Lines<'a> {
    data: &'a [u8],
    pos: usize,
    next_no: usize,
}

impl<'a> Lines<'a> {
    /// Lines of `data` from byte `pos`, the first numbered `first_no`.
    pub(crate) fn new(data: &'a [u8], pos: usize, first_no: usize) -> Self {
        Lines {
            data,
            pos: pos.min(data.len()),
            next_no: first_no,
        }
    }

    /// Byte offset of the next line.
    pub(crate) fn pos(&self) -> usize {
        self.pos
    }

    /// Number the next line will have (one past the last line at end of data).
    pub(crate) fn next_no(&self) -> usize {
        self.next_no
    }

    /// The next line as text without its ending; non-UTF-8 is an error on that line.
    pub(crate) fn next_text(&mut self) -> Option<Result<(usize, &'a str), ReadErrorKind>> {
        let (no, bytes) = self.next()?;
        Some(match std::str::from_utf8(bytes) {
            Ok(s) => Ok((no, s)),
            Err(e) => Err(ReadErrorKind::line(
                no,
                format!(
                    "not text: byte {} of the line is not valid UTF-8",
                    e.valid_up_to() + 1
                ),
            )),
        })
    }
}

impl<'a> Lines<'a> {
    /// The remaining lines as text, see [`Lines::next_text`].
    pub(crate) fn texts(self) -> impl Iterator<Item = Result<(usize, &'a str), ReadErrorKind>> {
        let mut lines = self;
        std::iter::from_fn(move || lines.next_text())
    }
}

impl<'a> Iterator for Lines<'a> {
    type Item = (usize, &'a [u8]);

    fn next(&mut self) -> Option<Self::Item> {
        let rest = self.data.get(self.pos..).filter(|r| !r.is_empty())?;
        let (line, used) = match rest.iter().position(|&b| b == b'\n') {
            Some(i) => (&rest[..i], i + 1),
            None => (rest, rest.len()),
        };
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        self.pos += used;
        let no = self.next_no;
        self.next_no += 1;
        Some((no, line))
    }
}

/// Numeric type of a PLY property or PCD field; values are widened to `f64`
/// (exact for everything but 64-bit integers beyond 2^53, which only skipped fields use).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Scalar {
    pub(crate) fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::I64 | Scalar::U64 | Scalar::F64 => 8,
        }
    }

    pub(crate) fn is_int(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    pub(crate) fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "int8",
            Scalar::U8 => "uint8",
            Scalar::I16 => "int16",
            Scalar::U16 => "uint16",
            Scalar::I32 => "int32",
            Scalar::U32 => "uint32",
            Scalar::I64 => "int64",
            Scalar::U64 => "uint64",
            Scalar::F32 => "float32",
            Scalar::F64 => "float64",
        }
    }

    /// Decodes one value from the start of `b`; `None` if `b` is too short.
    #[inline]
    pub(crate) fn decode(self, b: &[u8], big_endian: bool) -> Option<f64> {
        macro_rules! num {
            ($t:ty) => {{
                let raw = b.get(..std::mem::size_of::<$t>())?.try_into().ok()?;
                (if big_endian {
                    <$t>::from_be_bytes(raw)
                } else {
                    <$t>::from_le_bytes(raw)
                }) as f64
            }};
        }
        Some(match self {
            Scalar::I8 => num!(i8),
            Scalar::U8 => num!(u8),
            Scalar::I16 => num!(i16),
            Scalar::U16 => num!(u16),
            Scalar::I32 => num!(i32),
            Scalar::U32 => num!(u32),
            Scalar::I64 => num!(i64),
            Scalar::U64 => num!(u64),
            Scalar::F32 => num!(f32),
            Scalar::F64 => num!(f64),
        })
    }

    /// Parses a text token: integers must be integers in range, floats any `f64`
    /// syntax (`nan` and `inf` included, so they can be reported as such).
    pub(crate) fn parse_text(self, tok: &str) -> Option<f64> {
        let (lo, hi): (i64, i64) = match self {
            Scalar::F32 | Scalar::F64 => return tok.parse::<f64>().ok(),
            Scalar::U64 => return tok.parse::<u64>().ok().map(|v| v as f64),
            Scalar::I8 => (i8::MIN.into(), i8::MAX.into()),
            Scalar::U8 => (0, u8::MAX.into()),
            Scalar::I16 => (i16::MIN.into(), i16::MAX.into()),
            Scalar::U16 => (0, u16::MAX.into()),
            Scalar::I32 => (i32::MIN.into(), i32::MAX.into()),
            Scalar::U32 => (0, u32::MAX.into()),
            Scalar::I64 => (i64::MIN, i64::MAX),
        };
        let v = tok.parse::<i64>().ok()?;
        (lo..=hi).contains(&v).then_some(v as f64)
    }
}

/// Parses an `f64` text token, reporting it on failure.
pub(crate) fn parse_f64(
    tok: &str,
    line: usize,
    what: fmt::Arguments<'_>,
) -> Result<f64, ReadErrorKind> {
    tok.parse::<f64>()
        .map_err(|_| ReadErrorKind::line(line, format!("{what}: {} is not a number", Shown(tok))))
}

/// Upper bound on how many rows `count` can really be, given `avail` bytes and at
/// least `min_row` bytes per row: the capacity it is safe to reserve.
pub(crate) fn safe_capacity(count: u64, avail: usize, min_row: usize) -> usize {
    let fit = avail / min_row.max(1);
    usize::try_from(count).map_or(fit, |c| c.min(fit))
}

/// Splits a fan-triangulated polygon `poly` (already validated indices) into `out`.
pub(crate) fn push_fan(poly: &[u32], out: &mut Vec<[u32; 3]>) {
    if let Some((&first, rest)) = poly.split_first() {
        for pair in rest.windows(2) {
            out.push([first, pair[0], pair[1]]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_strip_crlf_and_number_from_one() {
        let v: Vec<_> = Lines::new(b"a\r\nb\n\nc", 0, 1).collect();
        assert_eq!(
            v,
            vec![
                (1, &b"a"[..]),
                (2, &b"b"[..]),
                (3, &b""[..]),
                (4, &b"c"[..])
            ]
        );
        assert_eq!(Lines::new(b"a\n", 0, 1).count(), 1);
    }

    #[test]
    fn scalar_text_rejects_out_of_range_and_fractions() {
        assert_eq!(Scalar::U8.parse_text("255"), Some(255.0));
        assert_eq!(Scalar::U8.parse_text("256"), None);
        assert_eq!(Scalar::U8.parse_text("-1"), None);
        assert_eq!(Scalar::I32.parse_text("1.5"), None);
        assert!(Scalar::F32.parse_text("nan").unwrap().is_nan());
        assert_eq!(Scalar::F64.parse_text("1e3"), Some(1000.0));
    }

    #[test]
    fn scalar_decode_respects_endianness_and_length() {
        assert_eq!(Scalar::I16.decode(&[0xff, 0xfe], false), Some(-257.0));
        assert_eq!(Scalar::I16.decode(&[0xff, 0xfe], true), Some(-2.0));
        assert_eq!(Scalar::F32.decode(&[0, 0, 0x80], false), None);
    }

    #[test]
    fn safe_capacity_is_bounded_by_bytes() {
        assert_eq!(safe_capacity(4_000_000_000, 120, 12), 10);
        assert_eq!(safe_capacity(3, 120, 12), 3);
        assert_eq!(safe_capacity(u64::MAX, 0, 0), 0);
    }

    #[test]
    fn shown_truncates_long_tokens() {
        let long = "x".repeat(100);
        let s = Shown(&long).to_string();
        assert!(s.len() < 50 && s.ends_with("...\""), "{s}");
    }

    #[test]
    fn standard_input_is_told_by_its_first_bytes() {
        let mut stl = vec![0u8; 84 + 50];
        stl[80] = 1;
        for (data, ext) in [
            (&b"ply\nformat ascii 1.0\n"[..], "ply"),
            (b"ply\r\nformat ascii 1.0\r\n", "ply"),
            (b"LASF\0\0", "las"),
            (b"ASTM-E57\0", "e57"),
            (b"# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\n", "pcd"),
            (b"FIELDS x y z\n", "pcd"),
            (b"# a comment\n\nOFF\n3 1 0\n", "off"),
            (b"# blender\nmtllib a.mtl\nv 1 2 3\n", "obj"),
            (b"v 1 2 3\n", "obj"),
            (&stl, "stl"),
            (b"solid cube\n  facet normal 0 0 1\n", "stl"),
            (b"1 2 3\n4 5 6\n", "xyz"),
            (b"//X,Y,Z\n1,2,3\n", "xyz"),
            (b"x y z r g b\n", "xyz"),
            (b"\x00\x01binary junk", "xyz"),
        ] {
            assert_eq!(sniff(data), ext, "{:?}", String::from_utf8_lossy(data));
        }
    }

    #[test]
    fn standard_input_is_named_so_in_errors() {
        let e = ReadError::new(Path::new("-"), ReadErrorKind::file("no data"));
        assert_eq!(e.to_string(), "standard input: no data");
        assert!(is_cloud_extension("laz") && !is_cloud_extension("glb"));
    }

    #[test]
    fn fan_triangulates_polygons() {
        let mut t = Vec::new();
        push_fan(&[0, 1, 2, 3], &mut t);
        assert_eq!(t, vec![[0, 1, 2], [0, 2, 3]]);
    }
}
