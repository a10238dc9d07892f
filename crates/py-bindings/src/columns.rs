//! Column results handed to Python as typed classes, read by attribute (as polars and
//! pydantic-core hand theirs), not as dict keys: the predictions of `StiffnessModel.predict` /
//! `predict_sag` and the measurement table read from a file. The columns are moved into the
//! numpy arrays (a 10⁶-row table is not copied again).

use pyo3::prelude::*;
use pyo3::types::{PyList, PyString};
use vjm::dataset::{Dataset, SetLabel};
use vjm::stiffness_model::PredictionColumns;

use crate::convert::{numpy_field, to_numpy_bool};

/// Predicted tip deflections of N rows (base frame): `deflection` (N, 6) `[dx, dy, dz, rx, ry,
/// rz]` in m and rad, `stddev` (N, 6) their standard deviations, `wrench` (N, 6) the wrench
/// used (N, N·m), `identified` (N,) bool, `excitation` (N,).
#[derive(Debug)]
#[pyclass(
    module = "robot_stiffness._core",
    name = "PredictionColumns",
    frozen,
    get_all
)]
pub struct PyPredictionColumns {
    /// (N, 6) float64, m and rad.
    pub deflection: Py<PyAny>,
    /// (N, 6) float64, standard deviations of `deflection`.
    pub stddev: Py<PyAny>,
    /// (N, 6) float64, N and N·m.
    pub wrench: Py<PyAny>,
    /// (N,) bool: the row lies in the identified space.
    pub identified: Py<PyAny>,
    /// (N,) float64: how far it leaves that space.
    pub excitation: Py<PyAny>,
}

impl PyPredictionColumns {
    /// Moves the columns into numpy arrays.
    pub fn new(py: Python<'_>, pred: PredictionColumns) -> PyResult<Self> {
        let rows = pred.rows();
        let f = |v: Vec<f64>, shape: &[usize]| numpy_field(py, v, shape);
        Ok(Self {
            deflection: f(pred.deflection, &[rows, 6])?,
            stddev: f(pred.stddev, &[rows, 6])?,
            wrench: f(pred.wrench, &[rows, 6])?,
            identified: to_numpy_bool(py, pred.identified, &[rows])?
                .into_any()
                .unbind(),
            excitation: f(pred.excitation, &[rows])?,
        })
    }
}

#[pymethods]
impl PyPredictionColumns {
    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let rows = self.identified.bind(py).len()?;
        Ok(format!("PredictionColumns(rows={rows})"))
    }
}

/// A VJM measurement table: `q` (N, n) rad, `wrench` (N, 6) N and N·m, `displacement` (N, 3) m,
/// `rotation` (N, 3) rad or None, `pose` (N,) int64 or None, `set` `list[str]` or None, and
/// `sha256` of the bytes read (hex) when the reader was asked for it, else None.
#[derive(Debug)]
#[pyclass(
    module = "robot_stiffness._core",
    name = "MeasurementColumns",
    frozen,
    get_all
)]
pub struct PyMeasurementColumns {
    /// (N, n) float64, rad.
    pub q: Py<PyAny>,
    /// (N, 6) float64, N and N·m.
    pub wrench: Py<PyAny>,
    /// (N, 3) float64, m.
    pub displacement: Py<PyAny>,
    /// (N, 3) float64, rad, or None.
    pub rotation: Py<PyAny>,
    /// (N,) int64, or None.
    pub pose: Py<PyAny>,
    /// `list[str]` of `train`/`test`, or None.
    pub set: Py<PyAny>,
    /// SHA-256 (hex) of the file's bytes as read, or None.
    pub sha256: Option<String>,
}

impl PyMeasurementColumns {
    /// Moves the dataset's columns into numpy arrays; `set` holds two shared strings.
    pub fn new(py: Python<'_>, d: Dataset<'_>, sha256: Option<String>) -> PyResult<Self> {
        let n = d.len();
        let c = d.into_columns();
        let f = |v: Vec<f64>, shape: &[usize]| numpy_field(py, v, shape);
        let set = match c.set {
            Some(labels) => {
                let train = PyString::new(py, SetLabel::Train.as_str());
                let test = PyString::new(py, SetLabel::Test.as_str());
                let items = labels.iter().map(|l| match l {
                    SetLabel::Train => &train,
                    SetLabel::Test => &test,
                });
                PyList::new(py, items)?.into_any().unbind()
            }
            None => py.None(),
        };
        Ok(Self {
            q: f(c.q, &[n, c.n_joints])?,
            wrench: f(c.wrench, &[n, 6])?,
            displacement: f(c.displacement, &[n, 3])?,
            rotation: c.rotation.map_or(Ok(py.None()), |r| f(r, &[n, 3]))?,
            pose: c.pose.map_or_else(
                || py.None(),
                |p| numpy::PyArray1::from_vec(py, p).into_any().unbind(),
            ),
            set,
            sha256,
        })
    }
}

#[pymethods]
impl PyMeasurementColumns {
    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let rows = self.q.bind(py).len()?;
        Ok(format!("MeasurementColumns(rows={rows})"))
    }
}

/// Registers the classes.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyPredictionColumns>()?;
    m.add_class::<PyMeasurementColumns>()?;
    Ok(())
}
