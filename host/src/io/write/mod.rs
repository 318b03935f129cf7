//! Writing results: atomic replacement of the target file (or standard output),
//! labelled points as binary PLY, and meshes as PLY, OBJ, OFF, STL or glTF binary
//! ([`mesh`], [`glb`]).
//!
//! [`write_atomic`] writes a hidden temporary file beside the target (a short name of its
//! own, so a target's name may be as long as the file system allows), syncs it and renames
//! it over the target, so the target is either the old file or the complete new one.
//! Targets that are not regular files (`/dev/null`, `/dev/stdout`, a pipe) are written
//! in place: renaming over them would replace the device with a plain file. A symbolic
//! link is followed, so the link stays and the file it names gets the new content.
//! [`write_to`] does the same for a path, and writes `-` to standard output.
//! The format writers stream into any `Write` and validate their input first
//! (matching lengths, indices in range) so a bad call is an `InvalidInput` error, not a
//! corrupt file. Cost: O(output size), one 64 KiB buffer.

use std::fmt;
use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

pub mod glb;
pub mod mesh;
#[cfg(test)]
mod tests;

pub use mesh::{write_mesh, Coords, MeshFormat, MeshLayout, MeshOut, Precision};

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

/// A new hidden file in `dir`, `.vsaqem-<pid>-<n>.<kind>`, made with `create_new`
/// (never an existing file, whoever made it), and its path. The name is under
/// 50 bytes whatever the target's (for a `kind` of a few letters), so a target whose name is at the file
/// system's limit (255 bytes) still has one; `<n>` counts the calls of this
/// process, so no two calls get one name.
pub(crate) fn create_scratch(dir: &Path, kind: &str) -> io::Result<(PathBuf, File)> {
    static CALLS: AtomicU64 = AtomicU64::new(0);
    let pid = std::process::id();
    let mut tries = 0;
    loop {
        let n = CALLS.fetch_add(1, Ordering::Relaxed);
        let path = dir.join(format!(".vsaqem-{pid}-{n}.{kind}"));
        match fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&path)
        {
            // Left by another process with this pid (a crashed run, another
            // pid namespace): take the next number.
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists && tries < 64 => tries += 1,
            r => return r.map(|file| (path, file)),
        }
    }
}

/// Writes `path` atomically: `f` writes into a buffered hidden temporary file in the
/// same directory (made by `create_scratch`, with a short name of its own), which is flushed, `sync_all`ed and renamed over
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
    if path.file_name().is_none() {
        return Err(fail(io::Error::new(
            io::ErrorKind::InvalidInput,
            "the path has no file name",
        )));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let (tmp, file) = create_scratch(dir, "tmp").map_err(fail)?;
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

/// Writes `path` with `f`: `-` is standard output (an error, never a panic,
/// when it cannot be written: a closed pipe, a full disk); any other path goes
/// through [`write_atomic`]. The error names the target.
pub fn write_to(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), String> {
    if path.as_os_str() == "-" {
        crate::stdout::write_with(f)
    } else {
        write_atomic(path, f).map_err(|e| e.to_string())
    }
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
