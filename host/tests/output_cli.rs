//! What `vsaqem reconstruct` writes, end to end: coordinates in `float64`
//! where `float32` would lose the tolerance (georeferenced clouds), normals
//! and colours on the vertices, binary STL and GLB, and standard input and
//! output.

mod common;
use common::{bin, run_with_report, SMALL};

use serde_json::Value;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};
use vsaqem::io::{read_cloud, read_mesh};

fn dir(name: &str) -> PathBuf {
    common::dir("output", name)
}

/// `n` points on a sphere of radius `r` around `c` (a Fibonacci lattice), each
/// with the colour `colour(z)` of its height over the centre.
fn sphere(n: usize, c: [f64; 3], r: f64, colour: impl Fn(f64) -> [u8; 3]) -> String {
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let t = i as f64 * 0.618_033_988_749_895 * std::f64::consts::TAU;
            let s = (1.0 - z * z).sqrt();
            let p = [c[0] + r * s * t.cos(), c[1] + r * s * t.sin(), c[2] + r * z];
            let [cr, cg, cb] = colour(z);
            format!("{} {} {} {cr} {cg} {cb}\n", p[0], p[1], p[2])
        })
        .collect()
}

fn report(json: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap()
}

fn ok(r: &Output) {
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
}

/// The farthest any of `a` is from its partner in `b`.
fn farthest(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(p, q)| (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max)
}

const UTM: [f64; 3] = [500_000.0, 4_000_000.0, 100.0];

#[test]
fn a_georeferenced_cloud_is_written_in_f64_where_f32_would_lose_the_tolerance() {
    // A 25 m sphere at UTM coordinates: float32 values near y = 4,000,000
    // are 0.25 m apart; 1 % of the 0.5 % tolerance is about 2 mm.
    let d = dir("utm");
    let cloud = d.join("utm.xyz");
    std::fs::write(&cloud, sphere(4000, UTM, 12.5, |_| [0; 3])).unwrap();
    let args = [cloud.to_str().unwrap(), "--columns", "x,y,z,_,_,_"];
    let args = [&args[..], &["--clusters", "120"]].concat();
    let run = |out: &str, extra: &[&str]| {
        let (out, json) = (d.join(out), d.join(format!("{out}.json")));
        let r = run_with_report("reconstruct", [&args[..], extra].concat(), &out, &json);
        ok(&r);
        (read_mesh(&out).unwrap(), report(&json), r)
    };
    // OBJ keeps every digit of the f64 vertices: the mesh as core made it.
    let ((exact, t), obj, _) = run("mesh.obj", &[]);
    let ((v64, t64), ply, _) = run("mesh.ply", &[]);
    let ((v32, _), ply32, r32) = run("mesh32.ply", &["--precision", "f32"]);
    assert_eq!(obj["file"]["coordinates"], "f64");
    assert_eq!(ply["file"]["coordinates"], "f64");
    assert_eq!(ply["file"]["precision"], "auto");
    assert_eq!(ply32["file"]["coordinates"], "f32");
    let allowed = ply["file"]["f32_step_allowed"].as_f64().unwrap();
    let diagonal = ply["diagonal"].as_f64().unwrap();
    assert!(
        (allowed / (0.01 * 0.005 * diagonal) - 1.0).abs() < 1e-6,
        "{allowed}"
    );
    assert_eq!(ply["file"]["f32_step"], 0.25);
    // The double PLY holds the mesh exactly; float32 moves it past the
    // allowance, as its report says and a warning on stderr tells.
    assert_eq!(t64, t);
    assert_eq!(farthest(&v64, &exact), 0.0);
    assert_eq!(ply["file"]["rounding_max"], 0.0);
    let lost = farthest(&v32, &exact);
    assert!(
        lost > allowed,
        "float32 lost only {lost}, allowed {allowed}"
    );
    let reported = ply32["file"]["rounding_max"].as_f64().unwrap();
    assert!(
        (reported - lost).abs() <= 1e-12 * lost,
        "{reported} vs {lost}"
    );
    let stderr = String::from_utf8_lossy(&r32.stderr);
    assert!(
        stderr.contains("warning:") && stderr.contains("mesh32.ply") && stderr.contains("float32"),
        "{stderr}"
    );
    // The report's check read the positions as stored: the same verdict as
    // eval on the file, which reads the double PLY.
    let e = bin()
        .args(["eval", "--json", "--samples", "2000"])
        .arg(&cloud)
        .arg(d.join("mesh.ply"))
        .output()
        .unwrap();
    ok(&e);
    let e: Value = serde_json::from_slice(&e.stdout).unwrap();
    assert_eq!(e["validity"]["valid_solid"], ply["mesh"]["valid_solid"]);
    let far = e["point_to_mesh"]["distance"]["max_relative"]
        .as_f64()
        .unwrap();
    assert!(
        far > 0.0 && far < 0.01,
        "eval: the farthest point is {far} of the diagonal"
    );
    // GLB keeps float32, as offsets from an origin near the sphere's centre.
    let out = d.join("mesh.glb");
    let json = d.join("glb.json");
    ok(&run_with_report("reconstruct", &args, &out, &json));
    let glb = common::glb::check(&std::fs::read(&out).unwrap());
    let origin = glb.translation.expect("a translation");
    assert!(farthest(&[origin], &[UTM]) < 1.0, "{origin:?}");
    assert_eq!(report(&json)["file"]["coordinates"], "f32_offset");
    assert!(farthest(&glb.world(), &exact) < allowed / 100.0);
}

#[test]
fn vertex_normals_point_out_of_a_closed_sphere_in_every_format_that_has_them() {
    let d = dir("normals");
    for ext in ["ply", "obj", "glb"] {
        let out = d.join(format!("sphere.{ext}"));
        let json = d.join(format!("{ext}.json"));
        ok(&run_with_report("reconstruct", SMALL, &out, &json));
        let r = report(&json);
        assert_eq!(r["mesh"]["watertight"], true);
        assert_eq!(r["file"]["normals"], true);
        let (v, n): (Vec<[f64; 3]>, Vec<[f64; 3]>) = match ext {
            "glb" => {
                let g = common::glb::check(&std::fs::read(&out).unwrap());
                let n = g.normals.clone().unwrap();
                (g.world(), n.iter().map(|n| n.map(f64::from)).collect())
            }
            "obj" => {
                let text = std::fs::read_to_string(&out).unwrap();
                let vn: Vec<[f64; 3]> = text
                    .lines()
                    .filter_map(|l| l.strip_prefix("vn "))
                    .map(|l| {
                        let c: Vec<f64> = l.split(' ').map(|x| x.parse().unwrap()).collect();
                        [c[0], c[1], c[2]]
                    })
                    .collect();
                (read_mesh(&out).unwrap().0, vn)
            }
            _ => {
                let c = read_cloud(&out).unwrap();
                (c.positions, c.normals.unwrap())
            }
        };
        assert_eq!(n.len(), v.len(), "{ext}: a normal per vertex");
        let centre: [f64; 3] =
            [0, 1, 2].map(|a| v.iter().map(|p| p[a]).sum::<f64>() / v.len() as f64);
        for (p, n) in v.iter().zip(&n) {
            let len = n.iter().map(|c| c * c).sum::<f64>().sqrt();
            assert!((len - 1.0).abs() < 1e-5, "{ext}: |{n:?}| = {len}");
            let out_dir: Vec<f64> = (0..3).map(|a| p[a] - centre[a]).collect();
            let r = out_dir.iter().map(|c| c * c).sum::<f64>().sqrt();
            let cos: f64 = (0..3).map(|a| n[a] * out_dir[a]).sum::<f64>() / r;
            // On a sphere a vertex normal is close to the radius.
            assert!(cos > 0.9, "{ext}: the normal at {p:?} is {n:?} (cos {cos})");
        }
    }
}

#[test]
fn a_two_colour_cloud_gives_two_colour_vertices() {
    // Red above the equator, blue below: each vertex takes its cluster's mean,
    // so clusters on one side are pure and those across the equator a mix.
    let d = dir("colours");
    let cloud = d.join("two.xyz");
    let colour = |z: f64| if z > 0.0 { [255, 0, 0] } else { [0, 0, 255] };
    std::fs::write(&cloud, sphere(4000, [0.0; 3], 1.0, colour)).unwrap();
    let args = [
        cloud.to_str().unwrap(),
        "--columns",
        "x,y,z,r,g,b",
        "--clusters",
        "120",
    ];
    for ext in ["ply", "glb"] {
        let out = d.join(format!("two.{ext}"));
        let json = d.join(format!("{ext}.json"));
        ok(&run_with_report("reconstruct", args, &out, &json));
        assert_eq!(report(&json)["file"]["colors"], true);
        let (v, c) = if ext == "glb" {
            let g = common::glb::check(&std::fs::read(&out).unwrap());
            (g.world(), g.colors.unwrap())
        } else {
            let c = read_cloud(&out).unwrap();
            (c.positions, c.colors.unwrap())
        };
        let mut pure = 0;
        for (p, c) in v.iter().zip(&c) {
            // A mix of red and blue, nothing else.
            let sum = u32::from(c[0]) + u32::from(c[2]);
            assert!(c[1] == 0 && (254..=256).contains(&sum), "{ext}: {c:?}");
            if p[2] > 0.5 {
                assert_eq!(*c, [255, 0, 0], "{ext}: at {p:?}");
            } else if p[2] < -0.5 {
                assert_eq!(*c, [0, 0, 255], "{ext}: at {p:?}");
            }
            pure += usize::from(*c == [255, 0, 0] || *c == [0, 0, 255]);
        }
        assert!(pure * 10 >= v.len() * 7, "{ext}: {pure} of {}", v.len());
        assert!(c.contains(&[255, 0, 0]) && c.contains(&[0, 0, 255]));
    }
    // A cloud without colours gives a file without them.
    let out = d.join("plain.ply");
    let json = d.join("plain.json");
    ok(&run_with_report("reconstruct", SMALL, &out, &json));
    assert_eq!(report(&json)["file"]["colors"], false);
    assert!(read_cloud(&out).unwrap().colors.is_none());
}

#[test]
fn stl_and_glb_hold_the_reported_mesh() {
    let d = dir("stl_glb");
    let mut meshes = Vec::new();
    for ext in ["stl", "glb", "ply"] {
        let out = d.join(format!("sphere.{ext}"));
        let json = d.join(format!("{ext}.json"));
        ok(&run_with_report("reconstruct", SMALL, &out, &json));
        let r = report(&json);
        assert_eq!(r["file"]["format"], ext);
        let (faces, vertices) = (
            r["mesh"]["faces"].as_u64().unwrap() as usize,
            r["mesh"]["vertices"].as_u64().unwrap() as usize,
        );
        let bytes = std::fs::read(&out).unwrap();
        let (v, t) = if ext == "glb" {
            let g = common::glb::check(&bytes);
            assert!(g.normals.is_some() && g.colors.is_none());
            assert!(g.translation.is_none(), "no origin near the origin");
            let t: Vec<[u32; 3]> = g.indices.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
            (g.world(), t)
        } else {
            if ext == "stl" {
                assert_eq!(bytes.len(), 84 + 50 * faces);
            }
            read_mesh(&out).unwrap()
        };
        assert_eq!((v.len(), t.len()), (vertices, faces), "{ext}");
        meshes.push((v, t));
    }
    // The same float32 vertices in each (STL numbers them as it meets them).
    let corners = |(v, t): &(Vec<[f64; 3]>, Vec<[u32; 3]>)| -> Vec<[[f64; 3]; 3]> {
        t.iter().map(|tri| tri.map(|i| v[i as usize])).collect()
    };
    assert_eq!(corners(&meshes[0]), corners(&meshes[2]));
    assert_eq!(corners(&meshes[1]), corners(&meshes[2]));
    // STL cannot hold f64: refused before any work.
    let r = bin()
        .args(["reconstruct", "-q", "--precision", "f64", "-o"])
        .arg(d.join("f64.stl"))
        .args(SMALL)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("f64.stl: STL holds float32"), "{stderr}");
    assert!(r.stdout.is_empty() && !d.join("f64.stl").exists());
}

/// `vsaqem ARGS` with `input` on standard input and stdout to `stdout` (piped
/// when `None`).
fn piped(args: &[&str], input: &[u8], stdout: Option<Stdio>) -> Output {
    let mut child = bin()
        .args(args)
        .stdin(Stdio::piped())
        .stdout(stdout.unwrap_or(Stdio::piped()))
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    // The child may fail before it reads everything: a broken pipe is fine.
    let _ = stdin.write_all(input);
    drop(stdin);
    child.wait_with_output().unwrap()
}

#[test]
fn a_cloud_on_standard_input_becomes_a_ply_on_standard_output() {
    let d = dir("stdio");
    let text = sphere(4000, [0.0; 3], 1.0, |_| [0; 3]);
    // The same mesh from a file.
    let cloud = d.join("cloud.xyz");
    std::fs::write(&cloud, &text).unwrap();
    let file = d.join("file.ply");
    let cols = ["--columns", "x,y,z,_,_,_", "--clusters", "120"];
    ok(&run_with_report(
        "reconstruct",
        [&[cloud.to_str().unwrap()], &cols[..]].concat(),
        &file,
        &d.join("file.json"),
    ));
    let json = d.join("stdin.json");
    let args = [
        &[
            "reconstruct",
            "-q",
            "-",
            "-o",
            "-",
            "--report",
            json.to_str().unwrap(),
        ],
        &cols[..],
    ]
    .concat();
    let r = piped(&args, text.as_bytes(), None);
    ok(&r);
    // Stdout is the PLY and nothing else; the report's text is on stderr.
    let from_stdin = vsaqem::io::ply::parse_mesh(&r.stdout).unwrap();
    assert_eq!(read_mesh(&file).unwrap(), from_stdin);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(
        stderr.contains("input      standard input: 4000 points"),
        "{stderr}"
    );
    assert!(
        stderr.contains("file       binary PLY, float32"),
        "{stderr}"
    );
    let r = report(&json);
    assert_eq!(r["output"], "-");
    assert_eq!(
        r["input"],
        serde_json::json!({ "kind": "file", "path": "-" })
    );
    // A PLY on stdin is told by its header; --format names a format outright.
    let mut ply = Vec::new();
    let pts = read_cloud(&cloud).unwrap().positions;
    vsaqem::io::write_points_ply(&mut ply, &pts, &[], None).unwrap();
    let plain = ["reconstruct", "-q", "-", "-o", "-", "--clusters", "120"];
    let r = piped(&plain, &ply, None);
    ok(&r);
    assert!(!vsaqem::io::ply::parse_mesh(&r.stdout).unwrap().1.is_empty());
    let r = piped(&[&plain[..], &["--format", "xyz"]].concat(), &ply, None);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{stderr}");
    assert!(stderr.starts_with("error: standard input: "), "{stderr}");
    assert!(r.stdout.is_empty());
    // render -o - writes the PNG to stdout (not a file named "-"), the same
    // bytes as to a file, and says so on stderr.
    let png = d.join("file.png");
    let file = file.to_str().unwrap();
    let render = ["render", file, "--size", "48x32", "-o"];
    ok(&piped(
        &[&render[..], &[png.to_str().unwrap()]].concat(),
        b"",
        None,
    ));
    let r = bin()
        .args([&render[..], &["-"]].concat())
        .current_dir(&d)
        .output()
        .unwrap();
    ok(&r);
    assert!(
        r.stdout == std::fs::read(&png).unwrap(),
        "stdout is not the PNG"
    );
    assert!(!d.join("-").exists(), "a file named '-' was written");
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(stderr, "wrote the PNG to standard output (48x32)\n");
}

#[test]
fn bad_standard_input_and_a_full_standard_output_are_errors_not_panics() {
    let args = ["reconstruct", "-q", "-", "-o", "-", "--clusters", "120"];
    let r = piped(&args, b"", None);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr, "error: standard input: no data\n");
    let r = piped(&args, b"1 2 3\n4 5\n", None);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.starts_with("error: standard input: line 2"),
        "{stderr}"
    );
    // -o - and --report - cannot share stdout.
    let r = piped(&[&args[..], &["--report", "-"]].concat(), b"", None);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(stderr.contains("both name standard output"), "{stderr}");
    // A disk that is full: the write fails, the process says so.
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        eprintln!("skipped: no /dev/full");
        return;
    };
    let text = sphere(4000, [0.0; 3], 1.0, |_| [0; 3]);
    let r = piped(
        &[&args[..], &["--columns", "x,y,z,_,_,_"]].concat(),
        text.as_bytes(),
        Some(full.into()),
    );
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("cannot write to standard output") && !stderr.contains("panicked"),
        "{stderr}"
    );
    // With -o - the report's text goes to stderr: a full stderr is an error
    // too (exit 1; a panic would exit 101), though it cannot say so.
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    let r = bin()
        .args(["reconstruct", "-q", "-o", "-"])
        .args(SMALL)
        .stdout(Stdio::null())
        .stderr(full)
        .status()
        .unwrap();
    assert_eq!(r.code(), Some(1));
}
