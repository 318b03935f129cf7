//! The `vsaqem` binary end to end: clear errors, no partial output, determinism.

mod common;
use common::{bin, run_with_report};

use std::path::{Path, PathBuf};

fn dir(name: &str) -> PathBuf {
    common::dir("cli", name)
}

/// Run `vsaqem cluster IN -o OUT` and expect failure with every `needles` in stderr
/// and no output file (nor temp file) left behind.
fn expect_failure(d: &Path, input: &Path, needles: &[&str]) {
    let out = d.join("out.ply");
    let r = bin()
        .args(["cluster", "-q"])
        .arg(input)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success(), "{}: succeeded", input.display());
    assert_eq!(r.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    for n in needles {
        assert!(
            stderr.contains(n),
            "{}: '{n}' not in: {stderr}",
            input.display()
        );
    }
    let left: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(!out.exists(), "partial output left: {left:?}");
    assert!(
        left.iter().all(|f| !f.to_string_lossy().ends_with(".tmp")),
        "temp left: {left:?}"
    );
}

fn write(d: &Path, name: &str, content: &[u8]) -> PathBuf {
    let p = d.join(name);
    std::fs::write(&p, content).unwrap();
    p
}

fn xyz(points: &[[f64; 3]]) -> Vec<u8> {
    points
        .iter()
        .map(|p| format!("{} {} {}\n", p[0], p[1], p[2]))
        .collect::<String>()
        .into_bytes()
}

#[test]
fn hostile_files_fail_with_a_clear_message_and_no_output() {
    let d = dir("hostile");
    let ply_head = "ply\nformat binary_little_endian 1.0\nelement vertex 1000\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    let mut truncated = ply_head.as_bytes().to_vec();
    truncated.extend(std::iter::repeat_n(0u8, 120));
    let cases: Vec<(PathBuf, Vec<&str>)> = vec![
        (write(&d, "truncated.ply", &truncated), vec!["truncated.ply", "1000"]),
        (write(&d, "empty.xyz", b""), vec!["empty.xyz"]),
        (write(&d, "nan.xyz", b"0 0 0\n1 0 0\n0 nan 1\n1 1 1\n"), vec!["nan.xyz", "line 3"]),
        (write(&d, "inf.xyz", b"0 0 0\n1 0 0\n0 1 inf\n1 1 1\n"), vec!["inf.xyz", "line 3"]),
        (write(&d, "columns.xyz", b"0 0 0\n1 0\n"), vec!["columns.xyz", "line 2"]),
        (write(&d, "single.xyz", b"0.5 0.25 1\n"), vec!["single.xyz", "1 points", "at least 4"]),
        (write(&d, "dups.xyz", &xyz(&[[0.3, 0.3, 0.3]; 50])), vec!["dups.xyz", "all points coincide"]),
        (
            write(&d, "coplanar.xyz", &xyz(&(0..100).map(|i| [(i % 10) as f64, (i / 10) as f64, 2.0]).collect::<Vec<_>>())),
            vec!["coplanar.xyz", "one plane"],
        ),
        (
            write(&d, "collinear.xyz", &xyz(&(0..100).map(|i| [i as f64, 2.0 * i as f64, 1.0]).collect::<Vec<_>>())),
            vec!["collinear.xyz", "one line"],
        ),
        (write(&d, "bad.pcd", b"VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 5\nHEIGHT 1\nPOINTS 5\nDATA binary_compressed\n"), vec!["bad.pcd", "compressed"]),
        (write(&d, "points.stl", b"solid"), vec!["points.stl", "no triangles"]),
        (write(&d, "organised.pcd", b"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 2\nDATA ascii\nnan nan nan\n1 2 3\n"), vec!["organised.pcd", "line 9: file ends after 2 of 4 points"]),
        (write(&d, "scan.e57", b"ASTM-E57"), vec!["scan.e57", "E57 header"]),
        (write(&d, "scan.fls", b"FARO"), vec!["scan.fls", "unknown extension", ".laz"]),
        (d.join("missing.ply"), vec!["missing.ply"]),
    ];
    for (path, needles) in cases {
        expect_failure(&d, &path, &needles);
    }
}

#[test]
fn bad_parameters_fail_before_any_work() {
    let d = dir("params");
    let out = d.join("o.ply");
    for args in [
        vec!["--knn", "0"],
        vec!["--knn", "40"],
        vec!["--tolerance", "-1"],
        vec!["--clusters", "0"],
    ] {
        let r = bin()
            .args(["cluster", "-q", "--points", "2000", "-o"])
            .arg(&out)
            .args(&args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert!(
            !r.status.success() && !stderr.contains("panicked"),
            "{args:?}: {stderr}"
        );
        assert!(!out.exists());
    }
}

#[test]
fn same_input_and_seed_give_byte_identical_files_and_another_seed_differs() {
    let d = dir("determinism");
    let run = |name: &str, seed: &str| {
        let out = d.join(name);
        let r = bin()
            .args([
                "cluster",
                "-q",
                "--sample",
                "torus",
                "--points",
                "6000",
                "--clusters",
                "200",
                "--seed",
                seed,
                "-o",
            ])
            .arg(&out)
            .output()
            .unwrap();
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        std::fs::read(out).unwrap()
    };
    let a = run("a.ply", "7");
    assert_eq!(a, run("b.ply", "7"));
    assert_ne!(a, run("c.ply", "8"));
}

#[test]
fn the_report_names_every_stage_and_the_json_report_is_written() {
    let d = dir("report");
    let out = d.join("o.ply");
    let json = d.join("r.json");
    let r = run_with_report(
        "cluster",
        ["--points", "5000", "--clusters", "100"],
        &out,
        &json,
    );
    assert!(r.status.success());
    let text = String::from_utf8_lossy(&r.stdout);
    for word in [
        "5000 points",
        "neighbours",
        "quadrics",
        "clustering",
        "arena peak",
        "bytes/point",
    ] {
        assert!(text.contains(word), "'{word}' missing from: {text}");
    }
    let j = std::fs::read_to_string(json).unwrap();
    for key in [
        "\"clusters\"",
        "\"arena_peak_bytes\"",
        "\"time_ms\"",
        "\"max_error_relative\"",
    ] {
        assert!(j.contains(key), "{key} missing: {j}");
    }
    // The output holds the points then the generators, each with a cluster id.
    let cloud = vsaqem::io::read_cloud(&out).unwrap();
    assert!(cloud.positions.len() > 5000);
}

#[test]
fn a_run_that_reaches_the_cluster_cap_with_the_tolerance_unmet_says_so() {
    let d = dir("cap");
    let run = |max_clusters: &str, split_rounds: &str, name: &str| {
        let (out, json) = (
            d.join(format!("{name}.ply")),
            d.join(format!("{name}.json")),
        );
        let args = ["--sample", "torus", "--points", "5000", "--clusters", "40"];
        let limits = [
            "--max-clusters",
            max_clusters,
            "--split-rounds",
            split_rounds,
        ];
        let r = run_with_report("reconstruct", args.into_iter().chain(limits), &out, &json);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        let j = std::fs::read_to_string(json).unwrap();
        (String::from_utf8_lossy(&r.stderr).into_owned(), j)
    };
    // Splitting may not add a cluster: 40 are far too few for 0.5 %.
    let (stderr, j) = run("40", "5", "capped");
    assert!(
        stderr.contains("warning") && stderr.contains("cluster cap 40 is reached"),
        "{stderr}"
    );
    assert!(j.contains("\"tolerance_met\": false"), "{j}");
    assert_eq!(common::field(&j, "cluster_cap"), 40.0);
    // With room and batches enough to split, the tolerance is met and
    // nothing is said.
    let (stderr, j) = run("1000", "20", "free");
    assert!(!stderr.contains("warning"), "{stderr}");
    assert!(j.contains("\"tolerance_met\": true"), "{j}");
}

#[test]
fn options_stand_under_their_headings_in_the_order_of_a_run() {
    use clap::CommandFactory;
    let cli = vsaqem::cli::Cli::command();
    for (name, headings) in [
        (
            "reconstruct",
            &[
                "Input",
                "Cleaning",
                "Clustering",
                "Meshing",
                "Output",
                "Run",
            ][..],
        ),
        (
            "cluster",
            &["Input", "Cleaning", "Clustering", "Output", "Run"][..],
        ),
    ] {
        let sub = cli.find_subcommand(name).unwrap();
        let mut seen: Vec<&str> = Vec::new();
        for arg in sub.get_arguments() {
            if arg.get_id() == "help" {
                continue;
            }
            let h = arg
                .get_help_heading()
                .unwrap_or_else(|| panic!("{name} --{} has no heading", arg.get_id()));
            if seen.last() != Some(&h) {
                seen.push(h);
            }
        }
        assert_eq!(seen, headings, "{name}");
        let of = |id: &str| {
            sub.get_arguments()
                .find(|a| a.get_id() == id)
                .and_then(|a| a.get_help_heading())
        };
        assert_eq!(of("knn"), Some("Clustering"));
        assert_eq!(of("output"), Some("Output"));
        assert_eq!(of("memory"), Some("Run"));
        assert_eq!(of("outlier_sigma"), Some("Cleaning"));
        assert_eq!(of("input"), Some("Input"));
    }
}

/// `vsaqem ARGS`: exit code, stdout and stderr.
fn run(args: &[&std::ffi::OsStr]) -> (Option<i32>, String, String) {
    let r = bin().args(args).output().unwrap();
    (
        r.status.code(),
        String::from_utf8_lossy(&r.stdout).into_owned(),
        String::from_utf8_lossy(&r.stderr).into_owned(),
    )
}

#[test]
fn an_output_that_is_the_input_is_refused_and_the_input_kept() {
    let d = dir("same_as_input");
    let points: Vec<[f64; 3]> = (0..400)
        .map(|i| {
            let (a, b) = (i as f64 * 0.7, i as f64 * 1.3);
            [a.cos() * b.sin(), a.sin() * b.sin(), b.cos()]
        })
        .collect();
    let input = write(&d, "cloud.xyz", &xyz(&points));
    let before = std::fs::read(&input).unwrap();
    std::fs::create_dir_all(d.join("sub")).unwrap();
    let by_another_name = d.join("sub/../cloud.xyz");
    let mesh = d.join("mesh.ply");
    for (flag, target) in [
        ("-o", &input),
        ("-o", &by_another_name),
        ("--report", &input),
    ] {
        // `cluster` writes PLY whatever the extension: the format is no reason
        // to refuse here.
        let mut args: Vec<&std::ffi::OsStr> = vec!["cluster".as_ref(), "-q".as_ref()];
        args.push(input.as_os_str());
        if flag == "-o" {
            args.extend(["-o".as_ref(), target.as_os_str()]);
        } else {
            args.extend([
                "-o".as_ref(),
                mesh.as_os_str(),
                "--report".as_ref(),
                target.as_os_str(),
            ]);
        }
        let (code, stdout, stderr) = run(&args);
        assert_eq!(code, Some(1), "{stderr}");
        assert!(
            stderr.contains(&format!("{flag} names the input file")),
            "{stderr}"
        );
        assert!(stdout.is_empty(), "work was done: {stdout}");
        assert_eq!(std::fs::read(&input).unwrap(), before);
    }
    assert!(!d.join("mesh.ply").exists());
}

#[test]
fn where_a_run_writes_is_checked_before_any_work_and_named_once() {
    let d = dir("locations");
    std::fs::create_dir(d.join("dir.ply")).unwrap();
    let missing = d.join("no_such_dir");
    let cases: Vec<(Vec<std::ffi::OsString>, &str, std::path::PathBuf)> = vec![
        (
            vec!["-o".into(), missing.join("mesh.ply").into()],
            "not found",
            missing.join("mesh.ply"),
        ),
        (
            vec![
                "-o".into(),
                d.join("mesh.ply").into(),
                "--report".into(),
                missing.join("r.json").into(),
            ],
            "not found",
            missing.join("r.json"),
        ),
        (
            vec![
                "-o".into(),
                d.join("mesh.ply").into(),
                "--report".into(),
                d.join("mesh.ply").into(),
            ],
            "--report names the same file as -o",
            d.join("mesh.ply"),
        ),
        (
            vec!["-o".into(), d.join("dir.ply").into()],
            "-o names a directory",
            d.join("dir.ply"),
        ),
        (
            vec![
                "-o".into(),
                d.join("mesh.ply").into(),
                "--report".into(),
                d.join("dir.ply").into(),
            ],
            "--report names a directory",
            d.join("dir.ply"),
        ),
        (
            vec![
                "-o".into(),
                d.join(format!("{}.ply", "a".repeat(252))).into(),
            ],
            // The OS's words follow ("File name too long" from glibc,
            // "Filename too long" from musl).
            "-o cannot be created: File",
            d.join(format!("{}.ply", "a".repeat(252))),
        ),
        (
            vec!["-o".into(), d.join("mesh.wrl").into()],
            "unknown mesh extension",
            d.join("mesh.wrl"),
        ),
        (
            vec![
                "-o".into(),
                d.join("mesh.stl").into(),
                "--precision".into(),
                "f64".into(),
            ],
            "STL holds float32 coordinates only",
            d.join("mesh.stl"),
        ),
    ];
    for (args, needle, path) in cases {
        let r = bin()
            .args(["reconstruct", "-q"])
            .args(common::SMALL)
            .args(&args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains(needle), "{args:?}: {stderr}");
        let shown = path.display().to_string();
        assert_eq!(stderr.matches(&shown).count(), 1, "{args:?}: {stderr}");
        assert!(r.stdout.is_empty(), "{args:?}: work was done");
    }
    // No probe or temporary file is left behind.
    let left: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left, ["dir.ply"]);
    // A missing input is named once too.
    let input = d.join("missing.ply");
    let (code, _, stderr) = run(&[
        "cluster".as_ref(),
        input.as_os_str(),
        "-o".as_ref(),
        d.join("c.ply").as_os_str(),
    ]);
    assert_eq!(code, Some(1));
    assert_eq!(
        stderr.matches(&*input.display().to_string()).count(),
        1,
        "{stderr}"
    );
}

#[test]
fn an_output_name_at_the_length_limit_is_written_and_a_failed_run_leaves_nothing() {
    let d = dir("long_name");
    // 250 and 251 bytes: legal (NAME_MAX is 255), but not with a suffix.
    let stem = "a".repeat(246);
    let (mesh, json) = (
        d.join(format!("{stem}.ply")),
        d.join(format!("{stem}.json")),
    );
    let r = run_with_report("reconstruct", common::SMALL, &mesh, &json);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(0), "{stderr}");
    assert!(std::fs::read(&mesh).unwrap().starts_with(b"ply\n"));
    common::field(&std::fs::read_to_string(&json).unwrap(), "schema_version");
    std::fs::remove_file(&mesh).unwrap();
    std::fs::remove_file(&json).unwrap();
    // A run that fails after its work (refinement towards a bound it cannot
    // meet leaves too few points per cluster for meshing's memory) leaves
    // neither file nor a temporary one.
    let r = run_with_report(
        "reconstruct",
        [
            "--sample",
            "sphere",
            "--points",
            "2000",
            "--clusters",
            "400",
            "--max-error",
            "0.00001",
        ],
        &mesh,
        &json,
    );
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("meshing needs more"), "{stderr}");
    let left: Vec<_> = std::fs::read_dir(&d).unwrap().collect();
    assert!(left.is_empty(), "left: {left:?}");
}

#[test]
fn limits_that_are_broken_are_named_with_both_numbers() {
    let d = dir("limits");
    let out = d.join("o.ply");
    let r = bin()
        .args([
            "reconstruct",
            "-q",
            "--points",
            "3000",
            "--clusters",
            "5000",
            "-o",
        ])
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("more clusters than points (5000 > 3000)") && !stderr.contains("memory"),
        "{stderr}"
    );
    let r = bin()
        .args(["cluster", "-q", "--points", "3000", "--knn", "40", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(stderr.contains("more than the limit of 32"), "{stderr}");
    assert!(!out.exists());
}

#[test]
fn completions_and_man_pages_come_from_the_options() {
    for shell in ["bash", "zsh", "fish", "elvish", "powershell"] {
        let (code, script, stderr) = run(&["completions".as_ref(), shell.as_ref()]);
        assert_eq!(code, Some(0), "{shell}: {stderr}");
        assert!(
            script.contains("reconstruct") && script.contains("max-error"),
            "{shell}: {script}"
        );
    }
    let (code, page, _) = run(&["man".as_ref()]);
    assert_eq!(code, Some(0));
    assert!(
        page.contains(".TH vsaqem 1") && page.contains("reconstruct"),
        "{page}"
    );
    let d = dir("man");
    let (code, _, stderr) = run(&["man".as_ref(), "--dir".as_ref(), d.as_os_str()]);
    assert_eq!(code, Some(0), "{stderr}");
    let page = std::fs::read_to_string(d.join("vsaqem-reconstruct.1")).unwrap();
    assert!(page.contains("max\\-error"), "{page}");
    let (code, _, stderr) = run(&["man".as_ref(), "--dir".as_ref(), d.join("nope").as_os_str()]);
    assert_eq!(code, Some(1), "{stderr}");
    // A page that cannot be written is an error, and leaves no temporary file.
    std::fs::remove_file(d.join("vsaqem.1")).unwrap();
    std::fs::create_dir(d.join("vsaqem.1")).unwrap();
    let (code, _, stderr) = run(&["man".as_ref(), "--dir".as_ref(), d.as_os_str()]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("vsaqem.1: cannot write"), "{stderr}");
    let left: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|f| f.starts_with('.'))
        .collect();
    assert!(left.is_empty(), "left: {left:?}");
}

#[cfg(unix)]
#[test]
fn a_stdout_that_cannot_be_written_is_an_error_not_a_panic() {
    use std::process::Stdio;
    let d = dir("stdout");
    let full = Path::new("/dev/full");
    if full.exists() {
        let mesh = d.join("mesh.ply");
        let mesh = mesh.to_str().unwrap();
        for args in [
            vec!["completions", "bash"],
            vec!["reconstruct", "--help"],
            vec![
                "reconstruct",
                "-q",
                "--points",
                "3000",
                "--clusters",
                "80",
                "-o",
                mesh,
            ],
        ] {
            let r = bin()
                .args(&args)
                .stdout(std::fs::File::create(full).unwrap())
                .output()
                .unwrap();
            let stderr = String::from_utf8_lossy(&r.stderr);
            assert_eq!(r.status.code(), Some(1), "{args:?}: {stderr}");
            assert!(
                stderr.contains("cannot write to standard output") && !stderr.contains("panicked"),
                "{args:?}: {stderr}"
            );
        }
    }
    // A pipe whose reader has gone: the report cannot be printed.
    let mut child = bin()
        .args([
            "reconstruct",
            "-q",
            "--points",
            "3000",
            "--clusters",
            "80",
            "-o",
        ])
        .arg(d.join("piped.ply"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let r = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("cannot write to standard output"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}
