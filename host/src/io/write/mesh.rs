//! Mesh files: the formats ([`MeshFormat`]), how a file stores coordinates
//! ([`Precision`] asked, [`Coords`] and [`MeshLayout`] chosen), and the writers
//! of PLY, OBJ, OFF and STL ([`write_mesh`]; GLB is [`super::glb`]).
//!
//! Which format carries what:
//!
//! | format | positions | vertex normals | vertex colours |
//! |---|---|---|---|
//! | PLY (binary) | `float` or `double` | `float nx ny nz` | `uchar red green blue` |
//! | OBJ | text, every digit of the `f64` or of the `f32` | `vn`, faces `a//a` | no |
//! | OFF | text, as OBJ | no | no |
//! | STL (binary) | `float32` only | no (a normal per face) | no |
//! | GLB | `float32`, or `float32` offsets from a `float64` origin | `NORMAL` | `COLOR_0` |

use super::{glb, invalid};
use serde::Serialize;
use std::io::{self, BufWriter, Write};
use std::path::Path;

/// Mesh output format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    /// Binary little-endian PLY: `float` or `double` `x y z`, then `float nx ny nz`
    /// and `uchar red green blue` when given; faces `list uchar int vertex_indices`.
    Ply,
    /// Wavefront OBJ text: `v`, `vn` when normals are given (faces `a//a`), 1-based.
    Obj,
    /// OFF text.
    Off,
    /// Binary STL: a face normal and three `float32` corners a triangle.
    Stl,
    /// glTF 2.0 binary (GLB), see [`super::glb`].
    Glb,
}

/// The extensions [`MeshFormat::from_path`] knows.
pub const MESH_OUTPUT_EXTENSIONS: &str = ".ply, .obj, .off, .stl, .glb";

impl MeshFormat {
    /// The format named by the extension of `path` (case-insensitive); `-`
    /// (standard output) is PLY.
    pub fn from_path(path: &Path) -> Result<MeshFormat, String> {
        if path.as_os_str() == "-" {
            return Ok(MeshFormat::Ply);
        }
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("ply") => Ok(MeshFormat::Ply),
            Some("obj") => Ok(MeshFormat::Obj),
            Some("off") => Ok(MeshFormat::Off),
            Some("stl") => Ok(MeshFormat::Stl),
            Some("glb") => Ok(MeshFormat::Glb),
            Some("gltf") => Err(format!(
                "{}: .gltf (JSON beside separate files) is not written; use .glb, glTF \
                 binary in one file",
                path.display()
            )),
            Some(other) => Err(format!(
                "{}: unknown mesh extension '.{other}' (supported: {MESH_OUTPUT_EXTENSIONS})",
                path.display()
            )),
            None => Err(format!(
                "{}: no extension to tell the mesh format (supported: \
                 {MESH_OUTPUT_EXTENSIONS}, or - for PLY on standard output)",
                path.display()
            )),
        }
    }

    /// The format's name in reports: `ply`, `obj`, `off`, `stl`, `glb`.
    pub fn name(self) -> &'static str {
        match self {
            MeshFormat::Ply => "ply",
            MeshFormat::Obj => "obj",
            MeshFormat::Off => "off",
            MeshFormat::Stl => "stl",
            MeshFormat::Glb => "glb",
        }
    }

    /// Whether the format holds a normal at each vertex ([`MeshOut::normals`]).
    pub fn has_vertex_normals(self) -> bool {
        matches!(self, MeshFormat::Ply | MeshFormat::Obj | MeshFormat::Glb)
    }

    /// Whether the format holds a colour at each vertex ([`MeshOut::colors`]).
    pub fn has_colors(self) -> bool {
        matches!(self, MeshFormat::Ply | MeshFormat::Glb)
    }

    /// How this format stores coordinates under `precision`, when `float32`
    /// would move some vertex by more than `auto` allows (`f32_too_coarse`):
    /// `auto` takes `float32` where it is close enough (PLY, GLB), keeps every
    /// digit in the text formats and has no choice in STL. STL with `f64` is an
    /// error (it holds `float32` only); GLB's `f64` is `float32` offsets from a
    /// `float64` origin (glTF has no `float64` positions).
    pub fn coords(self, precision: Precision, f32_too_coarse: bool) -> Result<Coords, String> {
        use MeshFormat::*;
        Ok(match (precision, self) {
            (Precision::F64, Stl) => {
                return Err("STL holds float32 coordinates only: --precision f64 needs \
                            .ply, .obj, .off or .glb"
                    .to_string())
            }
            (Precision::F64, Glb) => Coords::F32Offset,
            (Precision::F64, _) => Coords::F64,
            (Precision::F32, _) | (Precision::Auto, Stl) => Coords::F32,
            (Precision::Auto, Obj | Off) => Coords::F64,
            (Precision::Auto, Ply | Glb) if !f32_too_coarse => Coords::F32,
            (Precision::Auto, Glb) => Coords::F32Offset,
            (Precision::Auto, Ply) => Coords::F64,
        })
    }
}

/// `--precision`: the coordinates a mesh file holds ([`MeshFormat::coords`]
/// says what each gives in each format; `auto` measures `float32` against
/// [`AUTO_F32_SHARE`] of the tolerance). The variants' docs are `--help`'s.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Precision {
    /// float32 unless its spacing at the largest coordinate is over 1 % of the
    /// tolerance; OBJ and OFF keep every digit
    Auto,
    /// float32 (OBJ and OFF: the shortest text of the float32)
    F32,
    /// float64: PLY double, OBJ and OFF every digit, GLB float32 offsets from a
    /// float64 origin; not for STL
    F64,
}

impl Precision {
    /// `auto`, `f32` or `f64`, as on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Precision::Auto => "auto",
            Precision::F32 => "f32",
            Precision::F64 => "f64",
        }
    }
}

/// The share of the tolerance (`--tolerance` × the diagonal) by which `auto`
/// lets `float32` move a vertex: when the spacing of `float32` values at the
/// mesh's largest coordinate ([`f32_step`]) is larger, `auto` writes `float64`.
/// A 25 m object at UTM coordinates (y near 4,000,000, where `float32` values
/// are 0.25 apart) is past it at any tolerance below 100 %.
pub const AUTO_F32_SHARE: f64 = 0.01;

/// The spacing of `float32` values at magnitude `|x|`: storing a value near
/// `x` as `float32` moves it by at most half of it. Infinite past `f32::MAX`.
pub fn f32_step(x: f64) -> f64 {
    let x = x.abs() as f32;
    if !x.is_finite() || x == f32::MAX {
        return f64::INFINITY;
    }
    f64::from(f32::from_bits(x.to_bits() + 1)) - f64::from(x)
}

/// How a file holds its coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Coords {
    /// `float32` (OBJ and OFF: the shortest text that reads back to it).
    F32,
    /// `float64` (OBJ and OFF: the shortest text that reads back to it).
    F64,
    /// `float32` offsets from a `float64` origin (GLB: the node's translation).
    F32Offset,
}

/// A mesh file's format and how it holds coordinates; built by
/// [`MeshLayout::choose`] (or [`MeshLayout::plain`]), so an origin exists only
/// where the format stores one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshLayout {
    format: MeshFormat,
    coords: Coords,
    origin: [f64; 3],
}

impl MeshLayout {
    /// The layout `auto` gives a mesh whose coordinates `float32` holds closely
    /// enough: `float32` for PLY, STL and GLB, every digit for OBJ and OFF.
    pub fn plain(format: MeshFormat) -> MeshLayout {
        let coords = format.coords(Precision::Auto, false).unwrap_or(Coords::F32);
        MeshLayout {
            format,
            coords,
            origin: [0.0; 3],
        }
    }

    /// The layout `precision` gives `vertices` (file coordinates) in `format`,
    /// where `auto` lets `float32` move a vertex by at most `allowed` (file
    /// units): [`MeshFormat::coords`], with `float32` too coarse when
    /// [`f32_step`] at the largest coordinate exceeds `allowed`. The origin of
    /// [`Coords::F32Offset`] is the centre of the vertices' bounding box.
    /// Cost: one pass over the vertices.
    pub fn choose(
        format: MeshFormat,
        precision: Precision,
        vertices: &[[f64; 3]],
        allowed: f64,
    ) -> Result<MeshLayout, String> {
        let coords = format.coords(precision, f32_step(largest(vertices)) > allowed)?;
        let origin = match coords {
            Coords::F32Offset => centre(vertices),
            Coords::F32 | Coords::F64 => [0.0; 3],
        };
        Ok(MeshLayout {
            format,
            coords,
            origin,
        })
    }

    /// The format.
    pub fn format(&self) -> MeshFormat {
        self.format
    }

    /// How coordinates are held.
    pub fn coords(&self) -> Coords {
        self.coords
    }

    /// The origin of [`Coords::F32Offset`] coordinates (else `None`).
    pub fn origin(&self) -> Option<[f64; 3]> {
        (self.coords == Coords::F32Offset).then_some(self.origin)
    }

    /// The position `p` as the file holds it (a reader of `f64` gets exactly
    /// this from PLY, OBJ, OFF and STL; from a GLB, the offset plus the origin).
    /// OBJ and OFF in `float32` hold the shortest text of the `f32`, which an
    /// `f64` reader takes for the nearest `f64` to that text, not for the `f32`.
    pub fn stored(&self, p: [f64; 3]) -> [f64; 3] {
        match (self.coords, self.format) {
            (Coords::F64, _) => p,
            (Coords::F32, MeshFormat::Obj | MeshFormat::Off) => self
                .local(p)
                .map(|c| c.to_string().parse().unwrap_or(f64::from(c))),
            (Coords::F32 | Coords::F32Offset, _) => {
                let local = self.local(p);
                [0, 1, 2].map(|a| self.origin[a] + f64::from(local[a]))
            }
        }
    }

    /// `p` as the `float32` the file holds: rounded, or its offset from the
    /// origin rounded.
    pub(super) fn local(&self, p: [f64; 3]) -> [f32; 3] {
        [0, 1, 2].map(|a| (p[a] - self.origin[a]) as f32)
    }
}

/// The largest coordinate magnitude of `vertices` (0 for none).
fn largest(vertices: &[[f64; 3]]) -> f64 {
    vertices
        .iter()
        .flatten()
        .fold(0.0f64, |m, c| m.max(c.abs()))
}

/// The centre of the bounding box of `vertices` (the origin for none).
fn centre(vertices: &[[f64; 3]]) -> [f64; 3] {
    if vertices.is_empty() {
        return [0.0; 3];
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in vertices {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a]))
}

/// A mesh to write: positions in file coordinates, triangles, and optionally a
/// unit normal and a colour at each vertex (one per vertex; formats that have
/// no place for them leave them out, see the module docs).
#[derive(Clone, Copy, Debug)]
pub struct MeshOut<'a> {
    /// Vertex positions (file coordinates, `f64`).
    pub vertices: &'a [[f64; 3]],
    /// Triangles, indices into `vertices`.
    pub triangles: &'a [[u32; 3]],
    /// A unit normal at each vertex.
    pub normals: Option<&'a [[f32; 3]]>,
    /// A colour at each vertex.
    pub colors: Option<&'a [[u8; 3]]>,
}

impl<'a> MeshOut<'a> {
    /// Positions and triangles only.
    pub fn new(vertices: &'a [[f64; 3]], triangles: &'a [[u32; 3]]) -> Self {
        MeshOut {
            vertices,
            triangles,
            normals: None,
            colors: None,
        }
    }

    /// Every index `< vertices.len()`, and one normal and colour per vertex.
    fn check(&self) -> io::Result<()> {
        let nv = self.vertices.len();
        if let Some((t, tri)) = self
            .triangles
            .iter()
            .enumerate()
            .find(|(_, tri)| tri.iter().any(|&i| i as usize >= nv))
        {
            return Err(invalid(format!(
                "triangle {t} {tri:?} indexes past the {nv} vertices"
            )));
        }
        if let Some(n) = self.normals.filter(|n| n.len() != nv) {
            return Err(invalid(format!("{} normals for {nv} vertices", n.len())));
        }
        if let Some(c) = self.colors.filter(|c| c.len() != nv) {
            return Err(invalid(format!("{} colours for {nv} vertices", c.len())));
        }
        Ok(())
    }
}

/// Writes a triangle mesh in `layout`'s format and coordinates, with the
/// normals and colours the format has a place for. Every index must be
/// `< vertices.len()` (and `<= i32::MAX` for PLY, the triangles at most
/// `u32::MAX` for STL, the file under 4 GiB for GLB), checked first. Cost:
/// O(V + F), buffers of 64 KiB.
pub fn write_mesh(w: &mut dyn Write, layout: &MeshLayout, mesh: &MeshOut) -> io::Result<()> {
    mesh.check()?;
    match layout.format {
        MeshFormat::Ply => write_ply(w, layout, mesh),
        MeshFormat::Obj => write_obj(w, layout, mesh),
        MeshFormat::Off => write_off(w, layout, mesh),
        MeshFormat::Stl => write_stl(w, layout, mesh),
        MeshFormat::Glb => glb::write_glb(w, layout, mesh),
    }
}

/// Appends `bytes` to `buf`, handing `buf` to `w` when it is nearly full.
fn push(w: &mut dyn Write, buf: &mut Vec<u8>, bytes: &[u8]) -> io::Result<()> {
    if buf.len() + bytes.len() > 1 << 16 {
        w.write_all(buf)?;
        buf.clear();
    }
    buf.extend_from_slice(bytes);
    Ok(())
}

fn write_ply(w: &mut dyn Write, layout: &MeshLayout, mesh: &MeshOut) -> io::Result<()> {
    let (nv, nt) = (mesh.vertices.len(), mesh.triangles.len());
    if nv > i32::MAX as usize {
        return Err(invalid(format!("{nv} vertices do not fit PLY int indices")));
    }
    let double = layout.coords == Coords::F64;
    let ty = if double { "double" } else { "float" };
    let mut head = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by vsaqem\nelement vertex {nv}\n\
         property {ty} x\nproperty {ty} y\nproperty {ty} z\n"
    );
    if mesh.normals.is_some() {
        head.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if mesh.colors.is_some() {
        head.push_str("property uchar red\nproperty uchar green\nproperty uchar blue\n");
    }
    head.push_str(&format!(
        "element face {nt}\nproperty list uchar int vertex_indices\nend_header\n"
    ));
    w.write_all(head.as_bytes())?;
    let mut buf = Vec::with_capacity(1 << 16);
    let mut row = Vec::with_capacity(51);
    for (i, &p) in mesh.vertices.iter().enumerate() {
        row.clear();
        if double {
            for c in p {
                row.extend_from_slice(&c.to_le_bytes());
            }
        } else {
            for c in layout.local(p) {
                row.extend_from_slice(&c.to_le_bytes());
            }
        }
        if let Some(n) = mesh.normals {
            for c in n[i] {
                row.extend_from_slice(&c.to_le_bytes());
            }
        }
        if let Some(c) = mesh.colors {
            row.extend_from_slice(&c[i]);
        }
        push(w, &mut buf, &row)?;
    }
    for tri in mesh.triangles {
        row.clear();
        row.push(3);
        for &i in tri {
            // i < nv <= i32::MAX, checked above.
            row.extend_from_slice(&(i as i32).to_le_bytes());
        }
        push(w, &mut buf, &row)?;
    }
    w.write_all(&buf)
}

/// The coordinates of `p` as `layout`'s text: every digit of the `f64`, or of
/// the `f32`.
fn text_coords(layout: &MeshLayout, p: [f64; 3]) -> String {
    match layout.coords {
        Coords::F64 => format!("{} {} {}", p[0], p[1], p[2]),
        Coords::F32 | Coords::F32Offset => {
            let [x, y, z] = layout.local(p);
            format!("{x} {y} {z}")
        }
    }
}

fn write_obj(w: &mut dyn Write, layout: &MeshLayout, mesh: &MeshOut) -> io::Result<()> {
    let (nv, nt) = (mesh.vertices.len(), mesh.triangles.len());
    let mut w = BufWriter::with_capacity(1 << 16, w);
    writeln!(w, "# written by vsaqem: {nv} vertices, {nt} triangles")?;
    for &p in mesh.vertices {
        writeln!(w, "v {}", text_coords(layout, p))?;
    }
    if let Some(normals) = mesh.normals {
        for [x, y, z] in normals {
            writeln!(w, "vn {x} {y} {z}")?;
        }
        for [a, b, c] in mesh.triangles.iter().map(|t| t.map(|i| i + 1)) {
            writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")?;
        }
    } else {
        for [a, b, c] in mesh.triangles.iter().map(|t| t.map(|i| i + 1)) {
            writeln!(w, "f {a} {b} {c}")?;
        }
    }
    w.flush()
}

fn write_off(w: &mut dyn Write, layout: &MeshLayout, mesh: &MeshOut) -> io::Result<()> {
    let (nv, nt) = (mesh.vertices.len(), mesh.triangles.len());
    let mut w = BufWriter::with_capacity(1 << 16, w);
    writeln!(w, "OFF\n{nv} {nt} 0")?;
    for &p in mesh.vertices {
        writeln!(w, "{}", text_coords(layout, p))?;
    }
    for [a, b, c] in mesh.triangles {
        writeln!(w, "3 {a} {b} {c}")?;
    }
    w.flush()
}

/// The 80-byte header of a binary STL: not starting with `solid`, which
/// readers take for an ASCII file.
const STL_HEADER: &[u8] = b"binary STL written by vsaqem";

fn write_stl(w: &mut dyn Write, layout: &MeshLayout, mesh: &MeshOut) -> io::Result<()> {
    let nt = u32::try_from(mesh.triangles.len()).map_err(|_| {
        invalid(format!(
            "{} triangles do not fit a binary STL's 32-bit count",
            mesh.triangles.len()
        ))
    })?;
    let mut head = [0u8; 84];
    head[..STL_HEADER.len()].copy_from_slice(STL_HEADER);
    head[80..].copy_from_slice(&nt.to_le_bytes());
    w.write_all(&head)?;
    let mut buf = Vec::with_capacity(1 << 16);
    let mut row = Vec::with_capacity(50);
    for tri in mesh.triangles {
        let p = tri.map(|i| mesh.vertices[i as usize]);
        row.clear();
        for c in crate::attributes::face_normal(p) {
            row.extend_from_slice(&c.to_le_bytes());
        }
        for q in p {
            for c in layout.local(q) {
                row.extend_from_slice(&c.to_le_bytes());
            }
        }
        row.extend_from_slice(&[0, 0]);
        push(w, &mut buf, &row)?;
    }
    w.write_all(&buf)
}
