//! The JSON reports of `cluster` and `reconstruct` against their schema,
//! `host/report.schema.json`: real reports of several runs validate, and the
//! checker rejects a report that breaks the schema.
//!
//! The checker is a small one for the keywords the schema uses (`type`,
//! `properties`, `required`, `additionalProperties`, `propertyNames`, `items`,
//! `enum`, `const`, `minimum`, `maximum`, `oneOf`, local `$ref`), with JSON
//! Schema 2020-12's meaning; any other keyword fails the test, so the schema
//! cannot use one that would go unchecked.

mod common;
use common::{run_with_report, SMALL};

use serde_json::Value;
use std::path::{Path, PathBuf};

fn dir(name: &str) -> PathBuf {
    common::dir("report_schema", name)
}

fn schema() -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("report.schema.json");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Where `value` breaks `schema` (resolving `$ref`s in `root`), each as
/// `path: what`; empty when it is valid.
fn errors(root: &Value, schema: &Value, value: &Value, at: &str) -> Vec<String> {
    let mut out = Vec::new();
    let Some(s) = schema.as_object() else {
        panic!("{at}: a schema must be an object, not {schema}");
    };
    macro_rules! fail {
        ($($what:tt)*) => { out.push(format!("{at}: {}", format!($($what)*))) };
    }
    for (key, arg) in s {
        match key.as_str() {
            "$schema" | "$id" | "$defs" | "title" | "description" => {}
            "$ref" => {
                let name = arg.as_str().unwrap().strip_prefix("#/$defs/").unwrap();
                let target = &root["$defs"][name];
                assert!(!target.is_null(), "{at}: no $defs/{name}");
                out.extend(errors(root, target, value, at));
            }
            "type" => {
                let types: Vec<&str> = match arg {
                    Value::String(t) => vec![t.as_str()],
                    Value::Array(a) => a.iter().map(|t| t.as_str().unwrap()).collect(),
                    _ => panic!("{at}: bad type {arg}"),
                };
                if !types.iter().any(|t| has_type(value, t)) {
                    fail!("{value} is not of type {arg}");
                }
            }
            "const" if value != arg => fail!("{value} is not {arg}"),
            "enum" if !arg.as_array().unwrap().contains(value) => {
                fail!("{value} is not one of {arg}")
            }
            "minimum" | "maximum" => {
                if let (Some(v), Some(limit)) = (value.as_f64(), arg.as_f64()) {
                    if (key == "minimum" && v < limit) || (key == "maximum" && v > limit) {
                        fail!("{v} is past the {key} {limit}");
                    }
                }
            }
            "const" | "enum" => {}
            "properties" => {
                if let Some(o) = value.as_object() {
                    for (name, sub) in arg.as_object().unwrap() {
                        if let Some(v) = o.get(name) {
                            out.extend(errors(root, sub, v, &format!("{at}.{name}")));
                        }
                    }
                }
            }
            "required" => {
                if let Some(o) = value.as_object() {
                    for name in arg.as_array().unwrap() {
                        if !o.contains_key(name.as_str().unwrap()) {
                            fail!("{name} is missing");
                        }
                    }
                }
            }
            "additionalProperties" => {
                if let Some(o) = value.as_object() {
                    let known = s.get("properties").and_then(Value::as_object);
                    for (name, v) in o {
                        if known.is_some_and(|k| k.contains_key(name)) {
                            continue;
                        }
                        match arg {
                            Value::Bool(false) => fail!("{name} is not allowed"),
                            sub => out.extend(errors(root, sub, v, &format!("{at}.{name}"))),
                        }
                    }
                }
            }
            "propertyNames" => {
                if let Some(o) = value.as_object() {
                    for name in o.keys() {
                        let name = Value::String(name.clone());
                        out.extend(errors(root, arg, &name, &format!("{at} (a name)")));
                    }
                }
            }
            "items" => {
                if let Some(a) = value.as_array() {
                    for (i, v) in a.iter().enumerate() {
                        out.extend(errors(root, arg, v, &format!("{at}[{i}]")));
                    }
                }
            }
            "oneOf" => {
                let branches: Vec<Vec<String>> = arg
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|sub| errors(root, sub, value, at))
                    .collect();
                let valid = branches.iter().filter(|e| e.is_empty()).count();
                if valid != 1 {
                    fail!("{valid} of oneOf's {} match: {branches:?}", branches.len());
                }
            }
            other => panic!("{at}: the checker does not know the keyword {other}"),
        }
    }
    out
}

fn has_type(v: &Value, t: &str) -> bool {
    match t {
        "null" => v.is_null(),
        "boolean" => v.is_boolean(),
        "string" => v.is_string(),
        "array" => v.is_array(),
        "object" => v.is_object(),
        "number" => v.is_number(),
        "integer" => v.is_u64() || v.is_i64() || v.as_f64().is_some_and(|f| f.fract() == 0.0),
        _ => panic!("unknown type {t}"),
    }
}

fn validate(report: &Value) -> Vec<String> {
    let root = schema();
    errors(&root, &root, report, "report")
}

/// `vsaqem COMMAND ARGS -o OUT --report JSON` in `d`: the report, parsed.
fn report(d: &Path, command: &str, args: &[&str], out: &str) -> Value {
    let (out, json) = (d.join(out), d.join(format!("{out}.json")));
    let r = run_with_report(command, args, &out, &json);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap()
}

#[test]
fn reports_of_cluster_and_reconstruct_match_the_schema() {
    let d = dir("real");
    // A file as input, for both commands.
    let cloud = d.join("cloud.xyz");
    let text: String = (0..3000)
        .map(|i| {
            let (t, p) = (
                i as f64 * 0.618_034 * std::f64::consts::TAU,
                (i as f64 + 0.5) / 3000.0,
            );
            let z = 1.0 - 2.0 * p;
            let r = (1.0 - z * z).sqrt();
            format!("{} {} {}\n", r * t.cos(), r * t.sin(), z)
        })
        .collect();
    std::fs::write(&cloud, text).unwrap();
    let cloud = cloud.to_str().unwrap();
    let runs: Vec<(&str, Vec<&str>, &str)> = vec![
        ("reconstruct", SMALL.to_vec(), "sample.ply"),
        ("reconstruct", vec![cloud, "--clusters", "80"], "file.obj"),
        (
            "reconstruct",
            vec![cloud, "--clusters", "80", "--precision", "f64"],
            "file.glb",
        ),
        ("reconstruct", SMALL.to_vec(), "sample.stl"),
        (
            "reconstruct",
            vec![
                "--sample",
                "hemisphere",
                "--points",
                "3000",
                "--clusters",
                "60",
                "--max-error",
                "0.01",
                "--min-fragment",
                "0",
                "--outliers",
                "2",
                "--threads",
                "1",
                "--memory",
                "64MiB",
            ],
            "bounded.off",
        ),
        ("cluster", SMALL.to_vec(), "clusters.ply"),
        (
            "cluster",
            vec![cloud, "--clusters", "50", "--smooth", "1"],
            "file_clusters.ply",
        ),
    ];
    for (command, args, out) in runs {
        let r = report(&d, command, &args, out);
        let errors = validate(&r);
        assert!(errors.is_empty(), "{command} {args:?}: {errors:#?}");
        assert_eq!(r["command"], command);
    }
}

#[test]
fn the_checker_rejects_a_report_that_breaks_the_schema() {
    let d = dir("broken");
    let good = report(&d, "reconstruct", &SMALL, "mesh.ply");
    assert!(validate(&good).is_empty());
    type Change = Box<dyn Fn(&mut Value)>;
    let broken: Vec<(&str, Change)> = vec![
        (
            "a field missing",
            Box::new(|r| drop(r.as_object_mut().unwrap().remove("points"))),
        ),
        (
            "a field unknown",
            Box::new(|r| r["mesh"]["volume"] = 1.into()),
        ),
        ("a count negative", Box::new(|r| r["faces"] = (-1).into())),
        (
            "a wrong type",
            Box::new(|r| r["mesh"]["valid_solid"] = "yes".into()),
        ),
        (
            "another version",
            Box::new(|r| r["schema_version"] = 2.into()),
        ),
        (
            "an unknown format",
            Box::new(|r| r["file"]["format"] = "gltf".into()),
        ),
        (
            "an origin that is not numbers",
            Box::new(|r| r["file"]["origin"] = "centre".into()),
        ),
        (
            "an unknown stage",
            Box::new(|r| r["time_ms"]["dreaming"] = 1.0.into()),
        ),
        (
            "an unknown sample",
            Box::new(|r| r["input"]["name"] = "teapot".into()),
        ),
        (
            "meshing in cluster",
            Box::new(|r| r["command"] = "cluster".into()),
        ),
    ];
    for (what, change) in broken {
        let mut r = good.clone();
        change(&mut r);
        assert!(!validate(&r).is_empty(), "{what}: accepted");
    }
}
