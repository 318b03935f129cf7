//! `vsaqem._vsaqem`: the Python module's native part (the package `vsaqem`
//! re-exports it, with type stubs). Each function copies what it needs out of
//! the numpy arrays, releases the GIL, runs the CLI's own code on it, and
//! raises [`Error`] (a `ValueError`) with the CLI's message where the CLI would
//! exit 1.

use numpy::ndarray::ArrayView2;
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
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
    let collect = |v: ArrayView2<'_, f64>| v.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect();
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
        u32::try_from(v).map_err(|_| {
            Error::new_err(format!("{what}: triangle {i} has vertex index {v}"))
        })
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
            if self.normals.is_some() { ", normals" } else { "" },
            if self.colors.is_some() { ", colors" } else { "" }
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

#[pymodule]
fn _vsaqem(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("Error", m.py().get_type::<Error>())?;
    m.add_class::<Cloud>()?;
    m.add_function(wrap_pyfunction!(read, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate, m)?)?;
    Ok(())
}
