//! Every command with its standard output or standard error full
//! (`/dev/full`) or a pipe whose reader has gone: an error (exit 1) when what
//! failed is the command's result, the run's own exit code when it was only a
//! warning, never a panic (exit 101).
#![cfg(unix)]

mod common;
use common::bin;

use std::path::Path;
use std::process::{Command, Stdio};

/// Where the stream under test goes.
#[derive(Clone, Copy, Debug)]
enum Sink {
    /// `/dev/full`: every write fails with "No space left on device".
    Full,
    /// A pipe whose only reader has exited: every write fails with EPIPE.
    Closed,
}

impl Sink {
    fn stdio(self) -> Stdio {
        match self {
            Sink::Full => std::fs::OpenOptions::new()
                .write(true)
                .open("/dev/full")
                .unwrap()
                .into(),
            Sink::Closed => {
                // `true` holds the read end and exits without reading; once it
                // is gone nobody can read, so no write can race the close.
                let mut reader = Command::new("true").stdin(Stdio::piped()).spawn().unwrap();
                let write_end = reader.stdin.take().unwrap();
                reader.wait().unwrap();
                write_end.into()
            }
        }
    }
}

/// Runs `vsaqem ARGS` with stdout (`on_stdout`) or stderr to `sink`, the
/// other stream captured, and returns the exit code and what was captured.
fn run(args: &[&str], sink: Sink, on_stdout: bool) -> (Option<i32>, String) {
    let mut cmd = bin();
    cmd.args(args);
    if on_stdout {
        cmd.stdout(sink.stdio()).stderr(Stdio::piped());
    } else {
        cmd.stderr(sink.stdio()).stdout(Stdio::piped());
    }
    let r = cmd.output().unwrap();
    let other = if on_stdout { &r.stderr } else { &r.stdout };
    (r.status.code(), String::from_utf8_lossy(other).into_owned())
}

/// A fresh directory `name` for a test, or `None` (the test skipped, said
/// on stderr) on a system without `/dev/full`.
fn dir_if_dev_full(name: &str) -> Option<std::path::PathBuf> {
    if !Path::new("/dev/full").exists() {
        eprintln!("skipped: no /dev/full");
        return None;
    }
    Some(common::dir("closed_streams", name))
}

#[test]
fn no_command_panics_when_stdout_or_stderr_cannot_be_written() {
    let Some(d) = dir_if_dev_full("all") else {
        return;
    };
    let at = |name: &str| d.join(name).to_str().unwrap().to_string();
    let (mesh, cloud, png, pages) = (at("m.ply"), at("c.ply"), at("r.png"), at("man"));
    std::fs::create_dir(&pages).unwrap();
    // Both warn: the tolerance and --max-error are not met at the cluster cap.
    let warns = [
        "--sample",
        "sphere",
        "--points",
        "2000",
        "--clusters",
        "60",
        "--max-error",
        "0.001",
    ];
    let reconstruct = [&["reconstruct", "-q"][..], &warns, &["-o", &mesh]].concat();
    let to_stdout = [&["reconstruct", "-q"][..], &warns, &["-o", "-"]].concat();
    let cluster = [
        &["cluster", "-q"][..],
        &warns[..6],
        &["--max-clusters", "60"],
    ]
    .concat();
    let cluster = [&cluster[..], &["--tolerance", "0.0001", "-o", &cloud]].concat();
    // The inputs of eval and render.
    for args in [&reconstruct, &cluster] {
        let r = bin().args(args).stdout(Stdio::null()).output().unwrap();
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert!(r.status.success(), "{args:?}: {stderr}");
        assert!(stderr.contains("warning:"), "no warning to test: {stderr}");
    }

    // (arguments, exit code with stdout failing, with stderr failing)
    let cases: Vec<(Vec<&str>, i32, i32)> = vec![
        (reconstruct.clone(), 1, 0),
        // With the mesh on stdout the report's text goes to stderr: losing
        // it is an error.
        (to_stdout, 1, 1),
        (cluster.clone(), 1, 0),
        (vec!["eval", &cloud, &mesh], 1, 0),
        (vec!["eval", "--json", &cloud, &mesh], 1, 0),
        (vec!["render", &mesh, "-o", &png, "--size", "32x32"], 1, 0),
        (vec!["completions", "bash"], 1, 0),
        (vec!["man"], 1, 0),
        (vec!["man", "--dir", &pages], 0, 0),
        (vec!["--help"], 1, 0),
        (vec!["--version"], 1, 0),
        (vec!["reconstruct", "--help"], 1, 0),
        // Errors, whose message is lost when stderr cannot take it.
        (vec!["eval", "missing.ply", &mesh], 1, 1),
        (vec!["bogus"], 2, 2),
    ];
    for (args, on_stdout_fail, on_stderr_fail) in &cases {
        for sink in [Sink::Full, Sink::Closed] {
            let (code, stderr) = run(args, sink, true);
            assert_eq!(
                code,
                Some(*on_stdout_fail),
                "{args:?} {sink:?} stdout: {stderr}"
            );
            assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
            if *on_stdout_fail == 1 && !args.contains(&"missing.ply") {
                assert!(
                    stderr.contains("cannot write to standard output"),
                    "{args:?} {sink:?}: {stderr}"
                );
            }
            let (code, _) = run(args, sink, false);
            assert_eq!(code, Some(*on_stderr_fail), "{args:?} {sink:?} stderr");
        }
    }
}

/// A run whose report cannot be printed fails, and then leaves no file: the
/// mesh, the clusters, the JSON report and the PNG are staged and put in
/// place only after the text is out, and an earlier file of that name keeps
/// its content.
#[test]
fn a_run_that_cannot_print_its_report_leaves_no_file() {
    let Some(d) = dir_if_dev_full("no_file") else {
        return;
    };
    let at = |name: &str| d.join(name).to_str().unwrap().to_string();
    let (mesh, cloud, json, png, kept) = (
        at("m.ply"),
        at("c.ply"),
        at("r.json"),
        at("r.png"),
        at("kept.ply"),
    );
    let sample = ["--sample", "sphere", "--points", "2000", "--clusters", "60"];
    let made = |out: &str| {
        let args = [&["reconstruct", "-q"][..], &sample, &["-o", out]].concat();
        let r = bin().args(&args).stdout(Stdio::null()).output().unwrap();
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    };
    made(&kept);
    let before = std::fs::read(&kept).unwrap();
    let cases: Vec<Vec<&str>> = vec![
        [
            &["reconstruct"][..],
            &sample,
            &["-o", &mesh, "--report", &json],
        ]
        .concat(),
        [
            &["cluster"][..],
            &sample,
            &["-o", &cloud, "--report", &json],
        ]
        .concat(),
        // Over an existing file: it keeps its content.
        [&["reconstruct"][..], &sample, &["--seed", "7", "-o", &kept]].concat(),
        vec!["render", &kept, "-o", &png, "--size", "32x32"],
    ];
    for args in &cases {
        for sink in [Sink::Full, Sink::Closed] {
            let (code, stderr) = run(args, sink, true);
            assert_eq!(code, Some(1), "{args:?} {sink:?}: {stderr}");
            assert!(
                stderr.contains("cannot write to standard output"),
                "{stderr}"
            );
            let mut left: Vec<String> = std::fs::read_dir(&d)
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            left.sort();
            assert_eq!(left, ["kept.ply"], "{args:?} {sink:?} left files behind");
            assert!(
                std::fs::read(&kept).unwrap() == before,
                "{args:?}: kept.ply changed"
            );
        }
    }
    // The same runs with stdout working write every file.
    for args in &cases[..2] {
        let r = bin().args(args).stdout(Stdio::null()).output().unwrap();
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    }
    for file in [&mesh, &cloud, &json] {
        assert!(Path::new(file).is_file(), "{file} not written");
    }
}
