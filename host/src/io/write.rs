//! Writing results: atomic replacement of the target file, labelled points as binary
//! PLY, and meshes as binary PLY, OBJ or OFF.
//!
//! [`write_atomic`] writes a hidden temporary file beside the target, syncs it and renames
//! it over the target, so the target is either the old file or the complete new one.
//! Targets that are not regular files (`/dev/null`, `/dev/stdout`, a pipe) are written
//! in place: renaming over them would replace the device with a plain file. A symbolic
//! link is followed, so the link stays and the file it names gets the new content.
//! The format writers stream into any `Write` and validate their input first
//! (matching lengths, indices in range) so a bad call is an `InvalidInput` error, not a
//! corrupt file. Cost: O(output size), one 64 KiB buffer.

use std::fmt;
use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// Why [`write_atomic`] failed; the target is unchanged.
#[derive(Debug)]
pub struct WriteError {
    /// The target path.
    pub path: PathBuf,
    /// The underlying failure (from the closure, the file system or the rename).
    pub source: io::Error,
}

impl fmt::Display for WriteError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: cannot write: {}", self.path.display(), self.source)
    }
}

impl std::error::Error for WriteError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&self.source)
    }
}

/// Removes the temporary file unless disarmed (also when the closure panics).
struct TempGuard {
    path: Option<PathBuf>,
}

impl Drop for TempGuard {
    fn drop(&mut self) {
        if let Some(p) = self.path.take() {
            let _ = fs::remove_file(p);
        }
    }
}

/// Writes `path` atomically: `f` writes into a buffered hidden temporary file in the
/// same directory (`.<name>.<pid>.tmp`), which is flushed, `sync_all`ed and renamed over
/// `path`. On any error (or panic in `f`) the temporary file is removed and an existing
/// `path` is left untouched. A `path` that exists and is not a regular file or a
/// directory (a device, a pipe, a socket) is opened and written directly, without the
/// atomicity; a symbolic link is resolved first.
pub fn write_atomic(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), WriteError> {
    let fail = |source: io::Error| WriteError {
        path: path.to_path_buf(),
        source,
    };
    let resolved;
    let mut path = path;
    if let Ok(meta) = fs::metadata(path) {
        if !meta.is_file() && !meta.is_dir() {
            let file = fs::OpenOptions::new()
                .write(true)
                .open(path)
                .map_err(fail)?;
            let mut w = BufWriter::with_capacity(1 << 16, file);
            f(&mut w).map_err(fail)?;
            w.flush().map_err(fail)?;
            return Ok(());
        }
        if fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) {
            resolved = fs::canonicalize(path).map_err(fail)?;
            path = &resolved;
        }
    }
    let name = path.file_name().ok_or_else(|| {
        fail(io::Error::new(
            io::ErrorKind::InvalidInput,
            "the path has no file name",
        ))
    })?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".{}.tmp", std::process::id()));
    let tmp = dir.join(tmp_name);

    let file = File::create(&tmp).map_err(fail)?;
    let mut guard = TempGuard {
        path: Some(tmp.clone()),
    };
    let mut w = BufWriter::with_capacity(1 << 16, file);
    f(&mut w).map_err(fail)?;
    let file = w.into_inner().map_err(|e| fail(e.into_error()))?;
    file.sync_all().map_err(fail)?;
    drop(file);
    fs::rename(&tmp, path).map_err(fail)?;
    guard.path = None;
    // Make the rename itself durable where directories can be synced; best effort.
    #[cfg(unix)]
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

fn invalid(msg: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, msg)
}

/// Writes points as binary little-endian PLY: `float x y z`, then `uchar red green blue`
/// when `colors` is non-empty (it must then have one entry per point), then one `uint`
/// property named `extra_u32.0` (e.g. a cluster label) when given, one value per point.
/// Coordinates are rounded to `f32`. 12–19 bytes per point.
pub fn write_points_ply(
    w: &mut dyn Write,
    points: &[[f64; 3]],
    colors: &[[u8; 3]],
    extra_u32: Option<(&str, &[u32])>,
) -> io::Result<()> {
    let n = points.len();
    if !colors.is_empty() && colors.len() != n {
        return Err(invalid(format!("{} colors for {n} points", colors.len())));
    }
    if let Some((name, values)) = extra_u32 {
        if name.is_empty() || name.contains(|c: char| c.is_whitespace() || !c.is_ascii()) {
            return Err(invalid(format!(
                "PLY property name {name:?} must be non-empty ASCII without spaces"
            )));
        }
        if values.len() != n {
            return Err(invalid(format!(
                "{} '{name}' values for {n} points",
                values.len()
            )));
        }
    }
    let mut head = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by vsaqem\nelement vertex {n}\n\
         property float x\nproperty float y\nproperty float z\n"
    );
    if !colors.is_empty() {
        head.push_str("property uchar red\nproperty uchar green\nproperty uchar blue\n");
    }
    if let Some((name, _)) = extra_u32 {
        head.push_str(&format!("property uint {name}\n"));
    }
    head.push_str("end_header\n");
    w.write_all(head.as_bytes())?;
    let mut buf = Vec::with_capacity(1 << 16);
    for (i, p) in points.iter().enumerate() {
        for c in p {
            buf.extend_from_slice(&(*c as f32).to_le_bytes());
        }
        if let Some(c) = colors.get(i) {
            buf.extend_from_slice(c);
        }
        if let Some((_, values)) = extra_u32 {
            buf.extend_from_slice(&values[i].to_le_bytes());
        }
        if buf.len() >= (1 << 16) - 32 {
            w.write_all(&buf)?;
            buf.clear();
        }
    }
    w.write_all(&buf)
}

/// Mesh output format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    /// Binary little-endian PLY, `float` vertices, `list uchar int vertex_indices`.
    Ply,
    /// Wavefront OBJ text, 1-based indices.
    Obj,
    /// OFF text.
    Off,
}

impl MeshFormat {
    /// The position `p` as [`write_mesh`] stores it in this format: PLY's
    /// `float` rounds each coordinate to `f32`; OBJ and OFF keep the `f64`.
    pub fn stored(self, p: [f64; 3]) -> [f64; 3] {
        match self {
            MeshFormat::Ply => p.map(|c| c as f32 as f64),
            MeshFormat::Obj | MeshFormat::Off => p,
        }
    }

    /// The format named by the extension of `path` (case-insensitive).
    pub fn from_path(path: &Path) -> Result<MeshFormat, String> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("ply") => Ok(MeshFormat::Ply),
            Some("obj") => Ok(MeshFormat::Obj),
            Some("off") => Ok(MeshFormat::Off),
            Some(other) => Err(format!(
                "{}: unknown mesh extension '.{other}' (supported: .ply, .obj, .off)",
                path.display()
            )),
            None => Err(format!(
                "{}: no extension to tell the mesh format (supported: .ply, .obj, .off)",
                path.display()
            )),
        }
    }
}

/// Writes a triangle mesh. PLY rounds coordinates to `f32`; OBJ and OFF print every
/// coordinate with `{}` (shortest text that reads back to the same `f64`).
/// Every index must be `< vertices.len()` (and `<= i32::MAX` for PLY), checked first.
pub fn write_mesh(
    w: &mut dyn Write,
    fmt: MeshFormat,
    vertices: &[[f64; 3]],
    triangles: &[[u32; 3]],
) -> io::Result<()> {
    let nv = vertices.len();
    if let Some((t, tri)) = triangles
        .iter()
        .enumerate()
        .find(|(_, tri)| tri.iter().any(|&i| i as usize >= nv))
    {
        return Err(invalid(format!(
            "triangle {t} {tri:?} indexes past the {nv} vertices"
        )));
    }
    let nt = triangles.len();
    match fmt {
        MeshFormat::Ply => {
            if nv > i32::MAX as usize {
                return Err(invalid(format!("{nv} vertices do not fit PLY int indices")));
            }
            write!(
                w,
                "ply\nformat binary_little_endian 1.0\ncomment written by vsaqem\n\
                 element vertex {nv}\nproperty float x\nproperty float y\nproperty float z\n\
                 element face {nt}\nproperty list uchar int vertex_indices\nend_header\n"
            )?;
            let mut buf = Vec::with_capacity(1 << 16);
            for p in vertices {
                for c in p {
                    buf.extend_from_slice(&(*c as f32).to_le_bytes());
                }
                if buf.len() >= (1 << 16) - 16 {
                    w.write_all(&buf)?;
                    buf.clear();
                }
            }
            for tri in triangles {
                buf.push(3);
                for &i in tri {
                    // i < nv <= i32::MAX, checked above.
                    buf.extend_from_slice(&(i as i32).to_le_bytes());
                }
                if buf.len() >= (1 << 16) - 16 {
                    w.write_all(&buf)?;
                    buf.clear();
                }
            }
            w.write_all(&buf)
        }
        MeshFormat::Obj => {
            let mut w = BufWriter::with_capacity(1 << 16, w);
            writeln!(w, "# written by vsaqem: {nv} vertices, {nt} triangles")?;
            for [x, y, z] in vertices {
                writeln!(w, "v {x} {y} {z}")?;
            }
            for [a, b, c] in triangles {
                writeln!(w, "f {} {} {}", a + 1, b + 1, c + 1)?;
            }
            w.flush()
        }
        MeshFormat::Off => {
            let mut w = BufWriter::with_capacity(1 << 16, w);
            writeln!(w, "OFF\n{nv} {nt} 0")?;
            for [x, y, z] in vertices {
                writeln!(w, "{x} {y} {z}")?;
            }
            for [a, b, c] in triangles {
                writeln!(w, "3 {a} {b} {c}")?;
            }
            w.flush()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_ply_layout_is_19_bytes_per_point_with_colour_and_label() {
        let mut out = Vec::new();
        write_points_ply(
            &mut out,
            &[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]],
            &[[1, 2, 3], [4, 5, 6]],
            Some(("cluster", &[7, 8])),
        )
        .unwrap();
        let end = out.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        assert_eq!(out.len() - end, 2 * 19);
        assert_eq!(&out[end + 12..end + 15], &[1, 2, 3]);
        assert_eq!(&out[end + 15..end + 19], &7u32.to_le_bytes());
        let head = std::str::from_utf8(&out[..end]).unwrap();
        assert!(head.contains("property uint cluster\n"), "{head}");
    }

    #[test]
    fn a_written_mesh_reads_back_at_the_positions_stored_says() {
        // Coordinates that f32 cannot hold: PLY rounds them, OBJ and OFF not.
        let v = [
            [0.1, 1e7 + 0.3, -2.0 / 3.0],
            [1.0 / 3.0, 2.0, 3.0],
            [4.0, 5.000_000_1, 6.0],
        ];
        let t = [[0, 1, 2]];
        for (fmt, parse) in [
            (
                MeshFormat::Ply,
                crate::io::ply::parse_mesh as fn(&[u8]) -> _,
            ),
            (MeshFormat::Obj, crate::io::obj::parse_mesh),
            (MeshFormat::Off, crate::io::off::parse_mesh),
        ] {
            let mut out = Vec::new();
            write_mesh(&mut out, fmt, &v, &t).unwrap();
            let (read, _) = parse(&out).unwrap();
            let stored: Vec<[f64; 3]> = v.iter().map(|&p| fmt.stored(p)).collect();
            assert_eq!(read, stored, "{fmt:?}");
        }
        assert_ne!(MeshFormat::Ply.stored(v[0]), v[0]);
    }

    #[test]
    fn mismatched_lengths_and_bad_indices_are_invalid_input() {
        let mut out = Vec::new();
        let e = write_points_ply(&mut out, &[[0.0; 3]], &[[0; 3]; 2], None).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
        let e = write_points_ply(&mut out, &[[0.0; 3]], &[], Some(("a b", &[1]))).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
        let e = write_mesh(&mut out, MeshFormat::Obj, &[[0.0; 3]], &[[0, 0, 1]]).unwrap_err();
        assert!(e.to_string().contains("triangle 0"), "{e}");
    }

    #[test]
    fn obj_keeps_full_f64_precision() {
        let mut out = Vec::new();
        let x = 0.1f64 + 0.2;
        write_mesh(&mut out, MeshFormat::Obj, &[[x, 0.0, 0.0]], &[]).unwrap();
        assert!(String::from_utf8(out)
            .unwrap()
            .contains("v 0.30000000000000004 0 0\n"));
    }

    fn scratch_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("vsaqem-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[cfg(unix)]
    #[test]
    fn a_symlink_target_keeps_the_link_and_gets_the_content() {
        let dir = scratch_dir("symlink");
        let real = dir.join("real.txt");
        fs::write(&real, "old").unwrap();
        let link = dir.join("link.txt");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        write_atomic(&link, |w| w.write_all(b"new")).unwrap();
        assert!(fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(fs::read_to_string(&real).unwrap(), "new");
        fs::remove_dir_all(&dir).unwrap();
    }

    /// A pipe stands in for `/dev/null` and `/dev/stdout`: renaming a file over it
    /// would turn the special file into a plain one (as root, `/dev/null` itself).
    #[cfg(unix)]
    #[test]
    fn a_pipe_is_written_in_place_not_replaced() {
        use std::io::Read;
        use std::os::unix::fs::FileTypeExt;
        let dir = scratch_dir("fifo");
        let fifo = dir.join("out.ply");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("skipped: mkfifo is not available");
            return;
        }
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || {
                let mut s = String::new();
                File::open(fifo).unwrap().read_to_string(&mut s).unwrap();
                s
            })
        };
        write_atomic(&fifo, |w| w.write_all(b"through the pipe")).unwrap();
        // Checked before joining: had the pipe been replaced, the reader would wait forever.
        assert!(fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
        let leftovers = fs::read_dir(&dir).unwrap().count();
        assert_eq!(leftovers, 1, "no temporary file beside the pipe");
        assert_eq!(reader.join().unwrap(), "through the pipe");
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn mesh_format_from_extension() {
        assert_eq!(
            MeshFormat::from_path(Path::new("a/B.OBJ")),
            Ok(MeshFormat::Obj)
        );
        let e = MeshFormat::from_path(Path::new("m.stl")).unwrap_err();
        assert!(
            e.contains("'.stl'") && e.contains(".ply, .obj, .off"),
            "{e}"
        );
    }
}
