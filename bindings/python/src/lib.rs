//! `vsaqem._vsaqem`: the Python module's native part (the package `vsaqem`
//! re-exports it, with type stubs). Each function copies what it needs out of
//! the numpy arrays, releases the GIL, runs the CLI's own code on it, and
//! raises [`Error`] (a `ValueError`) with the CLI's message where the CLI would
//! exit 1.

use clap::Parser;
use numpy::ndarray::ArrayView2;
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::{PyTypeError, PyUserWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict};
use std::path::PathBuf;
use std::time::Instant;

create_exception!(
    _vsaqem,
    Error,
    PyValueError,
    "Bad input or parameters, with the message the vsaqem CLI gives."
);

/// An (N, 3) array of float32 or float64 in any memory order, as rows of f64;
/// `what` names the argument in errors.
fn rows3(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<[f64; 3]>> {
    let Ok(array) = obj.cast::<PyUntypedArray>() else {
        return Err(Error::new_err(format!(
            "{what}: expected a numpy array of shape (N, 3), got {}",
            obj.get_type().name()?
        )));
    };
    let shape = array.shape();
    if shape.len() != 2 || shape[1] != 3 {
        return Err(Error::new_err(format!(
            "{what}: expected shape (N, 3), got {shape:?}"
        )));
    }
    let collect =
        |v: ArrayView2<'_, f64>| v.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect();
    if let Ok(a) = array.cast::<PyArray2<f64>>() {
        return Ok(collect(a.readonly().as_array()));
    }
    if let Ok(a) = array.cast::<PyArray2<f32>>() {
        let a = a.readonly();
        let v = a.as_array();
        return Ok(v
            .rows()
            .into_iter()
            .map(|r| [r[0] as f64, r[1] as f64, r[2] as f64])
            .collect());
    }
    Err(Error::new_err(format!(
        "{what}: dtype {} is not float32 or float64 (convert with .astype(float))",
        array.dtype()
    )))
}

/// An error naming the first NaN or infinite coordinate of `rows`.
fn finite(rows: &[[f64; 3]], what: &str) -> PyResult<()> {
    match rows
        .iter()
        .enumerate()
        .find_map(|(i, p)| p.iter().position(|v| !v.is_finite()).map(|a| (i, a, p[a])))
    {
        Some((i, a, v)) => Err(Error::new_err(format!(
            "{what}: row {i}: coordinate {} is {v}, not a finite number",
            ["x", "y", "z"][a]
        ))),
        None => Ok(()),
    }
}

/// Rows of an (N, 3) integer array of vertex indices.
fn triangles3(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<[u32; 3]>> {
    let Ok(array) = obj.cast::<PyUntypedArray>() else {
        return Err(Error::new_err(format!(
            "{what}: expected a numpy array of shape (F, 3), got {}",
            obj.get_type().name()?
        )));
    };
    let shape = array.shape();
    if shape.len() != 2 || shape[1] != 3 {
        return Err(Error::new_err(format!(
            "{what}: expected shape (F, 3), got {shape:?}"
        )));
    }
    let index = |i: usize, v: i64| {
        u32::try_from(v)
            .map_err(|_| Error::new_err(format!("{what}: triangle {i} has vertex index {v}")))
    };
    macro_rules! rows {
        ($t:ty) => {
            if let Ok(a) = array.cast::<PyArray2<$t>>() {
                let a = a.readonly();
                return a
                    .as_array()
                    .rows()
                    .into_iter()
                    .enumerate()
                    .map(|(i, r)| {
                        Ok([
                            index(i, r[0] as i64)?,
                            index(i, r[1] as i64)?,
                            index(i, r[2] as i64)?,
                        ])
                    })
                    .collect();
            }
        };
    }
    rows!(i32);
    rows!(i64);
    rows!(u32);
    Err(Error::new_err(format!(
        "{what}: dtype {} is not an integer type (int32, int64 or uint32)",
        array.dtype()
    )))
}

/// (N, 3) float64 array of rows.
fn array3<'py>(py: Python<'py>, rows: &[[f64; 3]]) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    PyArray1::from_vec(py, flat).reshape([rows.len(), 3])
}

/// A JSON text as Python objects (the CLI's report as a dict).
fn json<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (text,))
}

/// A point cloud as the CLI reads it.
#[pyclass(frozen, module = "vsaqem")]
struct Cloud {
    /// (N, 3) float64 positions, in the file's units.
    #[pyo3(get)]
    points: Py<PyArray2<f64>>,
    /// (N, 3) float64 normals as stored, or None.
    #[pyo3(get)]
    normals: Option<Py<PyArray2<f64>>>,
    /// (N, 3) uint8 colours, or None.
    #[pyo3(get)]
    colors: Option<Py<PyArray2<u8>>>,
    /// Points the file marks missing (NaN coordinates in PCD, LAS, E57), skipped.
    #[pyo3(get)]
    invalid_skipped: usize,
}

#[pymethods]
impl Cloud {
    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "Cloud({} points{}{})",
            self.points.bind(py).shape()[0],
            if self.normals.is_some() {
                ", normals"
            } else {
                ""
            },
            if self.colors.is_some() {
                ", colors"
            } else {
                ""
            }
        )
    }
}

/// Read a point cloud with the CLI's readers (PLY, XYZ/TXT/PTS/CSV, PCD, LAS/LAZ,
/// E57, OBJ/OFF/STL vertices), the format told by the extension or `format`.
#[pyfunction]
#[pyo3(signature = (path, *, format=None))]
fn read(py: Python<'_>, path: PathBuf, format: Option<String>) -> PyResult<Cloud> {
    let options = host::io::ReadOptions {
        columns: None,
        format,
    };
    let cloud = py
        .detach(|| host::io::read_cloud_with(&path, &options))
        .map_err(|e| Error::new_err(e.to_string()))?;
    let colors = match &cloud.colors {
        Some(c) => {
            let flat: Vec<u8> = c.iter().flatten().copied().collect();
            Some(PyArray1::from_vec(py, flat).reshape([c.len(), 3])?.unbind())
        }
        None => None,
    };
    Ok(Cloud {
        points: array3(py, &cloud.positions)?.unbind(),
        normals: match &cloud.normals {
            Some(n) => Some(array3(py, n)?.unbind()),
            None => None,
        },
        colors,
        invalid_skipped: cloud.invalid,
    })
}

/// The `vsaqem eval` metrics of a mesh against the points it came from, as
/// the dict `vsaqem eval --json` prints.
#[pyfunction]
#[pyo3(signature = (points, vertices, triangles, *, samples=host::eval::DEFAULT_SAMPLES, expect_genus=None))]
fn evaluate<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    vertices: &Bound<'py, PyAny>,
    triangles: &Bound<'py, PyAny>,
    samples: usize,
    expect_genus: Option<u64>,
) -> PyResult<Bound<'py, PyAny>> {
    let points = rows3(points, "points")?;
    let vertices = rows3(vertices, "vertices")?;
    let triangles = triangles3(triangles, "triangles")?;
    finite(&points, "points")?;
    finite(&vertices, "vertices")?;
    if points.is_empty() {
        return Err(Error::new_err("points: no points"));
    }
    if triangles.is_empty() {
        return Err(Error::new_err(format!(
            "the mesh has no faces ({} vertices)",
            vertices.len()
        )));
    }
    if let Some((i, t)) = triangles
        .iter()
        .enumerate()
        .find(|(_, t)| t.iter().any(|&v| v as usize >= vertices.len()))
    {
        return Err(Error::new_err(format!(
            "triangles: triangle {i} is {t:?}, but there are {} vertices",
            vertices.len()
        )));
    }
    let text = py.detach(|| {
        let t = Instant::now();
        let evaluation = host::eval::evaluate(&points, &vertices, &triangles, samples);
        host::cmd::eval::EvalReport {
            points_file: "<points>".into(),
            mesh_file: "<mesh>".into(),
            evaluation,
            expect_genus,
            read_ms: 0.0,
            eval_ms: host::progress::ms(t.elapsed()),
        }
        .json()
    });
    json(py, &text.map_err(Error::new_err)?)
}

/// Options of the CLI that are not options of the functions here (the
/// functions take the points and return the mesh instead).
const NOT_OPTIONS: [&str; 10] = [
    "input",
    "output",
    "o",
    "report",
    "precision",
    "sample",
    "points",
    "noise",
    "format",
    "columns",
];

/// `options` (keyword arguments) as the command line `vsaqem COMMAND ...`
/// would give them, parsed by the CLI's own parser: the same defaults, ranges
/// and messages. `name_value` is `True` for a flag, `None` or `False` to leave
/// an option out, anything else its value.
fn parse_command(
    command: &str,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<host::cli::Command> {
    // `cluster` requires an output; the library functions write none (they
    // return what the command would write), so it is named and never used.
    let mut argv = vec![
        "vsaqem".to_string(),
        command.to_string(),
        "--quiet".into(),
        "--output".into(),
        "-".into(),
    ];
    for (key, value) in options.into_iter().flatten() {
        let key: String = key.extract()?;
        if NOT_OPTIONS.contains(&key.as_str()) || key == "quiet" {
            return Err(PyTypeError::new_err(format!(
                "{command}() got an unexpected keyword argument '{key}' (the mesh is \
                 returned, not written)"
            )));
        }
        let flag = format!("--{}", key.trim_end_matches('_').replace('_', "-"));
        if value.is_none() || value.is_instance_of::<PyBool>() && !value.extract::<bool>()? {
            continue;
        }
        argv.push(flag);
        if !value.is_instance_of::<PyBool>() {
            argv.push(value.str()?.to_string());
        }
    }
    match host::cli::Cli::try_parse_from(&argv) {
        Ok(cli) => Ok(cli.command),
        Err(e) => {
            let text = e.render().to_string();
            let first = text.lines().next().unwrap_or_default();
            Err(Error::new_err(
                first
                    .trim_start_matches("error: ")
                    .replace("--", "")
                    .to_string(),
            ))
        }
    }
}

/// The points (and normals, colours) a caller gives, checked as the readers
/// check a file's: finite, within the largest coordinate, one normal and one
/// colour per point.
fn given_cloud(
    points: &Bound<'_, PyAny>,
    normals: Option<&Bound<'_, PyAny>>,
    colors: Option<&Bound<'_, PyAny>>,
) -> PyResult<host::io::Cloud> {
    let positions = rows3(points, "points")?;
    for (i, p) in positions.iter().enumerate() {
        host::io::check_finite(*p, i as u64, None)
            .map_err(|e| Error::new_err(format!("points: {e}")))?;
    }
    let normals = normals.map(|n| rows3(n, "normals")).transpose()?;
    if let Some(n) = &normals {
        if n.len() != positions.len() {
            return Err(Error::new_err(format!(
                "normals: {} rows for {} points",
                n.len(),
                positions.len()
            )));
        }
    }
    let colors = colors.map(|c| colors3(c, positions.len())).transpose()?;
    if positions.is_empty() {
        return Err(Error::new_err("points: no points"));
    }
    Ok(host::io::Cloud {
        positions,
        normals,
        colors,
        invalid: 0,
    })
}

/// An (N, 3) uint8 array of colours, one per point.
fn colors3(obj: &Bound<'_, PyAny>, n: usize) -> PyResult<Vec<[u8; 3]>> {
    let a = obj.cast::<PyArray2<u8>>().map_err(|_| {
        Error::new_err("colors: expected a numpy array of shape (N, 3) and dtype uint8")
    })?;
    let a = a.readonly();
    let v = a.as_array();
    if v.ncols() != 3 || v.nrows() != n {
        return Err(Error::new_err(format!(
            "colors: shape {:?}, expected ({n}, 3)",
            v.shape()
        )));
    }
    Ok(v.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect())
}

/// A reconstructed mesh.
#[pyclass(frozen, module = "vsaqem")]
struct Mesh {
    /// (V, 3) float64 vertices, in the points' coordinates.
    #[pyo3(get)]
    vertices: Py<PyArray2<f64>>,
    /// (F, 3) int32 vertex indices, counter-clockwise seen from outside.
    #[pyo3(get)]
    triangles: Py<PyArray2<i32>>,
    /// (V, 3) uint8 colours (each vertex its cluster's mean), when colours were given.
    #[pyo3(get)]
    colors: Option<Py<PyArray2<u8>>>,
    /// The CLI's JSON report (`vsaqem reconstruct --report`), as a dict.
    #[pyo3(get)]
    report: Py<PyAny>,
}

#[pymethods]
impl Mesh {
    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "Mesh({} vertices, {} triangles)",
            self.vertices.bind(py).shape()[0],
            self.triangles.bind(py).shape()[0]
        )
    }
}

/// Reconstruct a closed mesh from points: `vsaqem reconstruct`, in process.
/// Keyword arguments are the CLI's options with `_` for `-` (e.g.
/// `clusters=500`, `max_error=0.005`, `min_fragment=0`, `threads=2`,
/// `memory="100MB"`, `lambda_=0.001`); see `vsaqem reconstruct --help`.
#[pyfunction]
#[pyo3(signature = (points, normals=None, colors=None, **options))]
fn reconstruct(
    py: Python<'_>,
    points: &Bound<'_, PyAny>,
    normals: Option<&Bound<'_, PyAny>>,
    colors: Option<&Bound<'_, PyAny>>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<Mesh> {
    let host::cli::Command::Reconstruct(mut cmd) = parse_command("reconstruct", options)? else {
        return Err(Error::new_err("not a reconstruct command"));
    };
    cmd.input.given = Some(host::args::Given::new(given_cloud(
        points, normals, colors,
    )?));
    let made = py
        .detach(|| host::cmd::reconstruct::reconstruct(&cmd))
        .map_err(Error::new_err)?;
    warn(py, &made.warnings)?;
    let triangles: Vec<i32> = made
        .triangles
        .iter()
        .flatten()
        .map(|&i| i32::try_from(i).map_err(|_| Error::new_err("more than 2^31 vertices")))
        .collect::<PyResult<_>>()?;
    let colors = match &made.colors {
        Some(c) => {
            let flat: Vec<u8> = c.iter().flatten().copied().collect();
            Some(PyArray1::from_vec(py, flat).reshape([c.len(), 3])?.unbind())
        }
        None => None,
    };
    Ok(Mesh {
        vertices: array3(py, &made.vertices)?.unbind(),
        triangles: PyArray1::from_vec(py, triangles)
            .reshape([made.triangles.len(), 3])?
            .unbind(),
        colors,
        report: json(py, &made.report_json)?.unbind(),
    })
}

/// Points clustered.
#[pyclass(frozen, module = "vsaqem")]
struct Clusters {
    /// (M, 3) float64: the points clustered (after cleaning and merging exact
    /// duplicates), in the order given.
    #[pyo3(get)]
    points: Py<PyArray2<f64>>,
    /// (M,) int32: the cluster of each point.
    #[pyo3(get)]
    labels: Py<PyArray1<i32>>,
    /// (C, 3) float64: each cluster's generator (its QEM-optimal point).
    #[pyo3(get)]
    generators: Py<PyArray2<f64>>,
    /// The CLI's JSON report (`vsaqem cluster --report`), as a dict.
    #[pyo3(get)]
    report: Py<PyAny>,
}

#[pymethods]
impl Clusters {
    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "Clusters({} points, {} clusters)",
            self.points.bind(py).shape()[0],
            self.generators.bind(py).shape()[0]
        )
    }
}

/// Cluster points: `vsaqem cluster`, in process (keyword arguments as for
/// `reconstruct`, the clustering and cleaning ones).
#[pyfunction]
#[pyo3(signature = (points, normals=None, **options))]
fn cluster(
    py: Python<'_>,
    points: &Bound<'_, PyAny>,
    normals: Option<&Bound<'_, PyAny>>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<Clusters> {
    let host::cli::Command::Cluster(mut cmd) = parse_command("cluster", options)? else {
        return Err(Error::new_err("not a cluster command"));
    };
    cmd.input.given = Some(host::args::Given::new(given_cloud(points, normals, None)?));
    let made = py
        .detach(|| host::cmd::cluster::cluster(&cmd))
        .map_err(Error::new_err)?;
    warn(py, &made.warnings)?;
    let labels: Vec<i32> = made.labels.iter().map(|&l| l as i32).collect();
    Ok(Clusters {
        points: array3(py, &made.points)?.unbind(),
        labels: PyArray1::from_vec(py, labels).unbind(),
        generators: array3(py, &made.generators)?.unbind(),
        report: json(py, &made.report_json)?.unbind(),
    })
}

/// Each of `warnings` as a Python `UserWarning`.
fn warn(py: Python<'_>, warnings: &[String]) -> PyResult<()> {
    for warning in warnings {
        let text = std::ffi::CString::new(warning.as_str()).unwrap_or_default();
        PyErr::warn(py, &py.get_type::<PyUserWarning>(), &text, 1)?;
    }
    Ok(())
}

#[pymodule]
fn _vsaqem(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Clusters>()?;
    m.add_function(wrap_pyfunction!(cluster, m)?)?;
    m.add_class::<Mesh>()?;
    m.add_function(wrap_pyfunction!(reconstruct, m)?)?;
    m.add("Error", m.py().get_type::<Error>())?;
    m.add_class::<Cloud>()?;
    m.add_function(wrap_pyfunction!(read, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate, m)?)?;
    Ok(())
}
