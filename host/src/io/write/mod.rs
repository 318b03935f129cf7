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
//! [`stage`] and [`stage_to`] stop before the rename: a command that writes several
//! files, or prints a report after its file, commits them ([`Staged::commit`]) only
//! when everything else has succeeded, so a failure leaves none of them.
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

/// A file written in full beside its target but not yet in its place:
/// [`Staged::commit`] renames it over the target; dropping it uncommitted
/// (an error later in the run, a panic) removes it and leaves the target as it
/// was. A run that writes several files stages them all and commits them last,
/// so a failure at any step before (a full standard output included) leaves
/// none of them behind.
#[must_use = "a staged file is removed unless it is committed"]
pub struct Staged {
    /// The temporary file; `None` once committed, or when the target was
    /// written in place (standard output, a device, a pipe).
    tmp: Option<PathBuf>,
    /// The file the temporary one becomes (a symbolic link resolved).
    target: PathBuf,
    /// The target as the caller named it, for errors.
    named: PathBuf,
}

impl Staged {
    /// Nothing to commit: the target was written in place.
    fn in_place(path: &Path) -> Self {
        Staged {
            tmp: None,
            target: path.to_path_buf(),
            named: path.to_path_buf(),
        }
    }

    /// Renames the file over its target (and syncs the directory where that
    /// can be done, best effort). On failure the temporary file is removed and
    /// the target is unchanged.
    pub fn commit(mut self) -> Result<(), WriteError> {
        let Some(tmp) = self.tmp.take() else {
            return Ok(());
        };
        if let Err(source) = fs::rename(&tmp, &self.target) {
            let _ = fs::remove_file(&tmp);
            return Err(WriteError {
                path: self.named.clone(),
                source,
            });
        }
        #[cfg(unix)]
        if let Ok(d) = File::open(parent_dir(&self.target)) {
            let _ = d.sync_all();
        }
        Ok(())
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if let Some(p) = self.tmp.take() {
            let _ = fs::remove_file(p);
        }
    }
}

/// The directory `path` is in (`.` for a bare name).
pub(crate) fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
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

/// Writes `path` atomically: [`stage`], then [`Staged::commit`]. On any error
/// (or panic in `f`) the temporary file is removed and an existing `path` is
/// left untouched.
pub fn write_atomic(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), WriteError> {
    stage(path, f)?.commit()
}

/// Writes what `path` is to hold without putting it in place yet: `f` writes
/// into a buffered hidden temporary file in the same directory (made by
/// `create_scratch`, with a short name of its own), which is flushed and
/// `sync_all`ed; [`Staged::commit`] renames it over `path`. On any error (or
/// panic in `f`) the temporary file is removed. A `path` that exists and is
/// not a regular file or a directory (a device, a pipe, a socket) is opened
/// and written directly, without the atomicity, and there is nothing left to
/// commit; a symbolic link is resolved first.
pub fn stage(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<Staged, WriteError> {
    let fail = |source: io::Error| WriteError {
        path: path.to_path_buf(),
        source,
    };
    let named = path;
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
            return Ok(Staged::in_place(path));
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
    let (tmp, file) = create_scratch(parent_dir(path), "tmp").map_err(fail)?;
    // From here on, dropping `staged` (an error, a panic in `f`) removes `tmp`.
    let staged = Staged {
        tmp: Some(tmp),
        target: path.to_path_buf(),
        named: named.to_path_buf(),
    };
    let mut w = BufWriter::with_capacity(1 << 16, file);
    f(&mut w).map_err(fail)?;
    let file = w.into_inner().map_err(|e| fail(e.into_error()))?;
    file.sync_all().map_err(fail)?;
    Ok(staged)
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

/// [`write_to`], but a file is only staged ([`stage`]): `-` is written to
/// standard output at once, and nothing is in place for a file until the
/// caller commits it.
pub fn stage_to(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<Staged, String> {
    if path.as_os_str() == "-" {
        crate::stdout::write_with(f)?;
        Ok(Staged::in_place(path))
    } else {
        stage(path, f).map_err(|e| e.to_string())
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
