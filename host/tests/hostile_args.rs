//! Arguments and inputs past what a run can hold: each is an error that names
//! the option (or file), the value and the limit, exits with 1 before any
//! work, and leaves no output behind; none is an allocation the system
//! refuses (an abort) or a capacity overflow (a panic).

mod common;
use common::bin;

use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::{Duration, Instant};

fn dir(name: &str) -> PathBuf {
    common::dir("hostile_args", name)
}

/// Runs `vsaqem ARGS`, expects exit 1 within a few seconds with every one of
/// `needles` on stderr and no panic, and nothing left in `d`.
fn fails(d: &Path, args: &[&str], needles: &[&str]) -> String {
    let t = Instant::now();
    let r: Output = bin().args(args).current_dir(d).output().unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr).into_owned();
    assert!(
        t.elapsed() < Duration::from_secs(20),
        "{args:?} took {:?}",
        t.elapsed()
    );
    assert_eq!(r.status.code(), Some(1), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    for n in needles {
        assert!(stderr.contains(n), "{args:?}: {n:?} not in: {stderr}");
    }
    let left: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(left.is_empty(), "{args:?} left {left:?}");
    stderr
}

#[test]
fn sample_points_past_the_limit_are_refused_before_any_is_made() {
    let d = dir("points");
    for points in ["18446744073709551615", "1000000000", "100000001"] {
        for command in ["reconstruct", "cluster"] {
            fails(
                &d,
                &[
                    command, "-q", "--sample", "sphere", "--points", points, "-o", "o.ply",
                ],
                &[&format!(
                    "--points {points} is more than the limit of 100000000"
                )],
            );
        }
    }
}

#[test]
fn memory_past_the_machine_is_refused_before_it_is_reserved() {
    let d = dir("memory");
    // More than any machine this runs on has, and than the 1 TiB cap.
    fails(
        &d,
        &[
            "reconstruct",
            "-q",
            "--points",
            "3000",
            "--memory",
            "100000GiB",
            "-o",
            "o.ply",
        ],
        &["--memory 107374182400000 bytes", "is more than", "memory"],
    );
    // Bytes per cluster past their limit.
    fails(
        &d,
        &[
            "reconstruct",
            "-q",
            "--points",
            "3000",
            "--mesh-bytes-per-cluster",
            "4294967295",
            "-o",
            "o.ply",
        ],
        &["--mesh-bytes-per-cluster 4294967295 is more than the limit of 1048576"],
    );
    // The most sample points with all neighbours and half as many clusters:
    // their least arena (239 GB) is named against the machine's memory before a point is made.
    if physical_memory().is_some_and(|b| b < 200 << 30) {
        fails(
            &d,
            &[
                "reconstruct",
                "-q",
                "--points",
                "100000000",
                "--clusters",
                "50000000",
                "--knn",
                "32",
                "-o",
                "o.ply",
            ],
            &[
                "this run needs at least",
                "100000000 points",
                "more than this machine's",
            ],
        );
    }
}

/// `MemTotal` of `/proc/meminfo`, in bytes.
fn physical_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

#[test]
fn eval_samples_past_the_limit_are_refused_before_reading() {
    let d = dir("eval");
    for samples in ["18446744073709551615", "10000000000", "10000001"] {
        fails(
            &d,
            &["eval", "--samples", samples, "points.xyz", "mesh.ply"],
            &[&format!(
                "--samples {samples} is more than the limit of 10000000"
            )],
        );
    }
}

#[test]
fn render_sizes_past_the_limit_are_refused_before_reading() {
    let d = dir("render");
    fails(
        &d,
        &[
            "render",
            "mesh.ply",
            "-o",
            "x.png",
            "--size",
            "8192x8192",
            "--supersample",
            "4",
        ],
        &["8192x8192 with 4x supersampling", "67108864"],
    );
    fails(
        &d,
        &[
            "render",
            "a.ply",
            "b.ply",
            "-o",
            "x.png",
            "--size",
            "8192x8192",
            "--supersample",
            "1",
        ],
        &[
            "2 meshes side by side at 8192x8192",
            "134217728 pixels",
            "67108864",
        ],
    );
}

/// Runs `vsaqem ARGS` with `stdin`, in `d`; see [`fails`].
fn fails_with_stdin(d: &Path, args: &[&str], stdin: &Path, needles: &[&str]) {
    let t = Instant::now();
    let r = bin()
        .args(args)
        .current_dir(d)
        .stdin(std::fs::File::open(stdin).unwrap())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(t.elapsed() < Duration::from_secs(20), "{args:?}");
    assert_eq!(r.status.code(), Some(1), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    for n in needles {
        assert!(stderr.contains(n), "{args:?}: {n:?} not in: {stderr}");
    }
    assert_eq!(std::fs::read_dir(d).unwrap().count(), 0, "{args:?}");
}

#[cfg(unix)]
#[test]
fn endless_devices_fail_on_their_first_bytes() {
    let (zero, random) = (Path::new("/dev/zero"), Path::new("/dev/urandom"));
    if !zero.exists() || !random.exists() {
        return;
    }
    let d = dir("devices");
    for command in ["reconstruct", "cluster"] {
        fails(
            &d,
            &[command, "-q", "/dev/zero", "--format", "xyz", "-o", "o.ply"],
            &["/dev/zero: line 1: not text: byte 1 of the line is a NUL byte"],
        );
        fails(
            &d,
            &[
                command,
                "-q",
                "/dev/urandom",
                "--format",
                "ply",
                "-o",
                "o.ply",
            ],
            &["/dev/urandom: line 1: not"],
        );
        fails(
            &d,
            &[
                command,
                "-q",
                "/dev/urandom",
                "--format",
                "las",
                "-o",
                "o.ply",
            ],
            &["/dev/urandom: not a LAS file"],
        );
        // Zeros are a binary STL of no triangles, which ends at byte 84.
        fails(
            &d,
            &[command, "-q", "/dev/zero", "--format", "stl", "-o", "o.ply"],
            &["/dev/zero: binary STL declares 0 triangles, 84 bytes, but more follow"],
        );
        fails_with_stdin(
            &d,
            &[command, "-q", "-", "-o", "o.ply"],
            zero,
            &["standard input: not text, nor a binary STL"],
        );
        fails_with_stdin(
            &d,
            &[command, "-q", "-", "--format", "pcd", "-o", "o.ply"],
            random,
            // Line 1 of noise is text about once in 130 runs; one of the
            // first eight lines is not.
            &["standard input: line ", ": not text: byte "],
        );
    }
    // eval and render tell the format by the extension: links to the devices.
    let links = dir("device_links");
    for (name, to) in [
        ("z.xyz", zero),
        ("r.ply", random),
        ("r.obj", random),
        ("z.off", zero),
    ] {
        std::os::unix::fs::symlink(to, links.join(name)).unwrap();
    }
    let at = |name: &str| links.join(name).to_str().unwrap().to_string();
    let (z_xyz, r_ply, r_obj, z_off) = (at("z.xyz"), at("r.ply"), at("r.obj"), at("z.off"));
    fails(&d, &["eval", &z_xyz, &r_obj], &["z.xyz: line 1: not text"]);
    fails(&d, &["eval", &r_ply, &r_obj], &["r.ply: line 1: not"]);
    fails(&d, &["eval", &r_ply, &z_off], &["r.ply: line 1: not"]);
    fails(
        &d,
        &["render", &z_off, "-o", "x.png"],
        &["z.off: line 1: not text"],
    );
}

#[test]
fn a_file_past_the_input_limit_is_refused_before_a_byte_is_read() {
    let d = dir("huge");
    let inputs = dir("huge_input");
    let huge = inputs.join("huge.xyz");
    // Sparse: 4 GiB and a byte, none of it written.
    let f = std::fs::File::create(&huge).unwrap();
    f.set_len((4 << 30) + 1).unwrap();
    drop(f);
    let huge = huge.to_str().unwrap();
    fails(
        &d,
        &["cluster", "-q", huge, "-o", "o.ply"],
        &["huge.xyz: 4294967297 bytes, more than the limit of 4294967296 bytes"],
    );
    fails(&d, &["eval", huge, huge], &["huge.xyz: 4294967297 bytes"]);
    std::fs::remove_file(huge).unwrap();
}

/// `n` points spread over a sphere of radius `r` (a Fibonacci lattice), as text.
fn sphere_xyz(n: usize, r: f64) -> String {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let (s, t) = ((1.0 - z * z).sqrt(), golden * i as f64);
            format!("{:e} {:e} {:e}\n", r * s * t.cos(), r * s * t.sin(), r * z)
        })
        .collect()
}

#[test]
fn coordinates_past_the_limit_are_named_with_their_value_and_float32_range_is_kept() {
    let inputs = dir("coordinates_input");
    let d = dir("coordinates");
    let text = inputs.join("huge.xyz");
    let mut cloud = sphere_xyz(2000, 1.0);
    cloud.push_str("1.7e308 0 0\n");
    std::fs::write(&text, cloud).unwrap();
    fails(
        &d,
        &["reconstruct", "-q", text.to_str().unwrap(), "-o", "o.ply"],
        &[
            "huge.xyz: line 2001: vertex 2000: x is 1.7e308, beyond the largest coordinate",
            "1e40",
        ],
    );
    let mut ply = b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty double x\n\
                    property double y\nproperty double z\nend_header\n"
        .to_vec();
    for v in [0.0f64, -1.7e308, 0.0] {
        ply.extend(v.to_le_bytes());
    }
    let double = inputs.join("double.ply");
    std::fs::write(&double, ply).unwrap();
    fails(
        &d,
        &["cluster", "-q", double.to_str().unwrap(), "-o", "o.ply"],
        &["double.ply: vertex 0: y is -1.7e308, beyond"],
    );
    fails(
        &d,
        &["eval", double.to_str().unwrap(), double.to_str().unwrap()],
        &["double.ply: vertex 0: y is -1.7e308"],
    );
    // Past float32's range but within the limit: written as float64, finite.
    let big = inputs.join("big.xyz");
    std::fs::write(&big, sphere_xyz(2000, 1e39)).unwrap();
    let out = inputs.join("big.ply");
    let r = bin()
        .args(["reconstruct", "-q", "--clusters", "100"])
        .arg(&big)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(
        r.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&r.stderr)
    );
    let cloud = vsaqem::io::read_cloud(&out).unwrap();
    let largest = cloud
        .positions
        .iter()
        .flatten()
        .fold(0f64, |m, v| m.max(v.abs()));
    assert!(
        largest > 5e38 && largest < 1.1e39,
        "largest coordinate {largest:e}"
    );
}

#[test]
fn render_checks_its_output_before_reading_any_mesh() {
    let d = dir("render_output");
    // The meshes do not exist: an error about them would mean they were read
    // before the output was checked.
    fails(
        &d,
        &["render", "mesh.ply", "-o", "nope/x.png"],
        &["nope/x.png: directory nope not found"],
    );
    fails(
        &d,
        &["render", "a.ply", "mesh.ply", "-o", "mesh.ply"],
        &["mesh.ply: -o names an input file"],
    );
    fails(
        &d,
        &["render", "mesh.ply", "--points", "c.ply", "-o", "c.ply"],
        &["c.ply: -o names an input file"],
    );
}

#[test]
fn a_huge_point_radius_is_refused_before_reading() {
    // It used to paint every dot's whole square: 100000 pixels took 10
    // minutes for a thousand points.
    let d = dir("point_radius");
    for radius in ["100000", "64.5", "nan", "inf"] {
        let t = Instant::now();
        let r = bin()
            .args(["render", "m.ply", "-o", "x.png", "--point-radius", radius])
            .current_dir(&d)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert!(t.elapsed() < Duration::from_secs(20), "{radius}");
        assert_eq!(r.status.code(), Some(2), "{radius}: {stderr}");
        assert!(stderr.contains("must be 0 to 64 pixels"), "{stderr}");
    }
}
