//! Where a run writes, checked before any work: a run of minutes that could
//! not have written its result, or would have written it over its own input,
//! fails at once instead, naming the path once and what is wrong with it.
//!
//! `-` (standard output) passes every check, but not as both targets. A
//! target that exists and is not a regular file (`/dev/null`, a pipe) is
//! written in place, so only its existence is checked.

use crate::io::is_stdio;
use crate::io::write::{create_scratch, parent_dir};
use std::fs;
use std::io;
use std::path::{Path, PathBuf};

/// Checks that a run reading `input` (`None`: a built-in sample) can write
/// `output` (`-o`) and `report` (`--report`): [`check_targets`] with one input.
pub fn check_outputs(
    input: Option<&Path>,
    output: &Path,
    report: Option<&Path>,
) -> Result<(), String> {
    check_targets(input.as_slice(), output, report)
}

/// Checks that a run reading `inputs` can write `output` (`-o`) and `report`
/// (`--report`): neither is one of the input files nor the other one (by
/// canonical path, or by device and inode where both exist), neither is a
/// directory, and each one's directory exists and takes a new file (a probe
/// file is made there and removed).
pub fn check_targets(inputs: &[&Path], output: &Path, report: Option<&Path>) -> Result<(), String> {
    let targets = std::iter::once(("-o", output)).chain(report.map(|r| ("--report", r)));
    let which = if inputs.len() > 1 { "an" } else { "the" };
    for (flag, path) in targets.clone() {
        for &input in inputs.iter().filter(|i| !is_stdio(i)) {
            if same_file(input, path) {
                return Err(format!(
                    "{}: {flag} names {which} input file; write to another file",
                    path.display()
                ));
            }
        }
        writable(flag, path)?;
    }
    if let Some(report) = report {
        if is_stdio(output) && is_stdio(report) {
            return Err(
                "-o - and --report - both name standard output; give the report a file".to_string(),
            );
        }
        if same_file(output, report) {
            return Err(format!(
                "{}: --report names the same file as -o; give the report another name",
                report.display()
            ));
        }
    }
    Ok(())
}

/// Whether `a` and `b` are one regular file (existing or to be made): the same
/// device and inode where both exist (hard links, symbolic links), else the
/// same canonical path. Two names of one device are not: writing twice to
/// `/dev/null` is fine.
fn same_file(a: &Path, b: &Path) -> bool {
    if is_stdio(a) || is_stdio(b) {
        return false;
    }
    let special = |p: &Path| fs::metadata(p).is_ok_and(|m| !m.is_file());
    if special(a) || special(b) {
        return false;
    }
    #[cfg(unix)]
    if let (Ok(ma), Ok(mb)) = (fs::metadata(a), fs::metadata(b)) {
        use std::os::unix::fs::MetadataExt;
        return ma.dev() == mb.dev() && ma.ino() == mb.ino();
    }
    match (resolved(a), resolved(b)) {
        (Some(x), Some(y)) => x == y,
        _ => false,
    }
}

/// The canonical path of `p`, or of its directory joined with its name when
/// `p` does not exist yet; `None` when neither resolves.
fn resolved(p: &Path) -> Option<PathBuf> {
    fs::canonicalize(p)
        .ok()
        .or_else(|| Some(fs::canonicalize(parent_dir(p)).ok()?.join(p.file_name()?)))
}

/// Whether `path` (given as `flag`) can be written as `write_atomic` writes
/// it: not a directory, in a directory that exists and takes a new file, with
/// a name the file system takes (not over its length limit).
fn writable(flag: &str, path: &Path) -> Result<(), String> {
    if is_stdio(path) {
        return Ok(());
    }
    let shown = path.display();
    // A symbolic link is followed: the file it names is replaced.
    let target = fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    let unusable = match fs::metadata(&target) {
        Ok(m) if m.is_dir() => return Err(format!("{shown}: {flag} names a directory")),
        Ok(m) if !m.is_file() => return Ok(()),
        Ok(_) => None,
        Err(e) if e.kind() == io::ErrorKind::NotFound => None,
        // A name longer than the file system takes, a loop of links, or a
        // directory that does not exist or cannot be searched (said below).
        Err(e) => Some(e),
    };
    if target.file_name().is_none() {
        return Err(format!("{shown}: {flag} needs a file name"));
    }
    let dir = parent_dir(&target);
    match fs::metadata(dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => return Err(format!("{shown}: {} is not a directory", dir.display())),
        Err(_) => return Err(format!("{shown}: directory {} not found", dir.display())),
    }
    match create_scratch(dir, "probe") {
        Ok((probe, _)) => {
            let _ = fs::remove_file(&probe);
        }
        Err(e) => {
            return Err(format!(
                "{shown}: cannot write in directory {}: {e}",
                dir.display()
            ))
        }
    }
    match unusable {
        Some(e) => Err(format!("{shown}: {flag} cannot be created: {e}")),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("vsaqem-outputs-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn the_input_by_another_name_is_refused_and_a_new_file_beside_it_is_not() {
        let d = dir("same");
        let input = d.join("cloud.ply");
        fs::write(&input, b"ply").unwrap();
        // The same file through `..`, and through a hard link.
        let dotted = d.join("sub/../cloud.ply");
        fs::create_dir_all(d.join("sub")).unwrap();
        let linked = d.join("link.ply");
        fs::hard_link(&input, &linked).unwrap();
        for out in [&input, &dotted, &linked] {
            let e = check_outputs(Some(&input), out, None).unwrap_err();
            assert!(e.contains("-o names the input file"), "{e}");
            assert_eq!(e.matches(&*out.display().to_string()).count(), 1, "{e}");
        }
        let e = check_outputs(Some(&input), &d.join("mesh.ply"), Some(&dotted)).unwrap_err();
        assert!(e.contains("--report names the input file"), "{e}");
        let e =
            check_outputs(None, &d.join("mesh.ply"), Some(&d.join("sub/../mesh.ply"))).unwrap_err();
        assert!(e.contains("--report names the same file as -o"), "{e}");
        check_outputs(Some(&input), &d.join("mesh.ply"), Some(&d.join("r.json"))).unwrap();
        // The probe is gone.
        let mut left: Vec<_> = fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        left.sort();
        assert_eq!(left, ["cloud.ply", "link.ply", "sub"]);
    }

    #[test]
    fn a_missing_directory_or_a_directory_as_the_target_is_refused() {
        let d = dir("missing");
        let e = check_outputs(None, &d.join("nope/mesh.ply"), None).unwrap_err();
        assert!(e.contains("directory") && e.contains("not found"), "{e}");
        let e = check_outputs(None, &d, None).unwrap_err();
        assert!(e.ends_with("-o names a directory"), "{e}");
        let file = d.join("file");
        fs::write(&file, b"").unwrap();
        let e = check_outputs(None, &file.join("mesh.ply"), None).unwrap_err();
        assert!(e.contains("is not a directory"), "{e}");
    }

    #[test]
    fn devices_and_stdout_pass() {
        check_outputs(None, Path::new("-"), None).unwrap();
        check_outputs(Some(Path::new("-")), Path::new("-"), None).unwrap();
        let e = check_outputs(None, Path::new("-"), Some(Path::new("-"))).unwrap_err();
        assert!(e.contains("both name standard output"), "{e}");
        #[cfg(unix)]
        check_outputs(
            Some(Path::new("/dev/null")),
            Path::new("/dev/null"),
            Some(Path::new("/dev/null")),
        )
        .unwrap();
    }
}
