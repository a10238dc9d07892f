//! Bindings of `so3_stiffness::identification`: the CSJM stiffness fit from orientations and
//! moments (arrays or the measurement file), returned as a dict of numpy arrays.

use nalgebra::{Matrix3, Rotation3, Vector3};
use numpy::PyReadonlyArrayDyn;
use pyo3::prelude::*;
use so3_stiffness::identification::{
    dataset::DEFAULT_ORTHOGONALITY_TOL, identify, CsjmDataset, CsjmMeasurement, FitOptions,
    FitOrder, ReadOptions, StiffnessEstimate,
};
use so3_stiffness::so3;

use crate::convert::{batch, check_finite, numpy_field, to_numpy};
use crate::errors::{run, shape_error, value_error, PyResultExt};

fn mat_to_vec(m: &Matrix3<f64>) -> Vec<f64> {
    (0..3)
        .flat_map(|r| (0..3).map(move |c| (r, c)))
        .map(|(r, c)| m[(r, c)])
        .collect()
}

fn fit_options(order: u8, convergence: bool) -> PyResult<FitOptions> {
    let order = match order {
        1 => FitOrder::First,
        2 => FitOrder::Second,
        other => return Err(value_error(format!("order must be 1 or 2, got {other}"))),
    };
    let mut opts = FitOptions::with_order(order);
    opts.convergence_series = convergence;
    Ok(opts)
}

/// A CSJM stiffness estimate as a typed class (all in frame A at R₀): `K`, `K_D`, `K_L`,
/// `K_stderr` (3, 3) N·m/rad, `tau0`, `offset` (3,) N·m, `n` increments, `order`, `dof`,
/// `residual_rms`, `omega_singular_values` (3,), `omega_condition`, `regressor_condition`,
/// `asymmetry`, the det(K) series `det_convergence_n`/`det_convergence_det`, and `curvature`
/// (3, 3, 3) N·m/rad² or None.
#[derive(Debug)]
#[pyclass(module = "robot_stiffness._core", name = "CsjmEstimate", frozen)]
pub struct PyCsjmEstimate {
    /// (3, 3) N·m/rad.
    #[pyo3(get, name = "K")]
    k: Py<PyAny>,
    /// (3, 3) N·m/rad, the slope ∂τ/∂Δζ.
    #[pyo3(get, name = "K_D")]
    k_d: Py<PyAny>,
    /// (3, 3) N·m/rad, the connection term.
    #[pyo3(get, name = "K_L")]
    k_l: Py<PyAny>,
    /// (3, 3) N·m/rad, standard errors of K.
    #[pyo3(get, name = "K_stderr")]
    k_stderr: Py<PyAny>,
    /// (3,) N·m, the pre-load.
    #[pyo3(get)]
    tau0: Py<PyAny>,
    /// (3,) N·m, the fitted moment offset.
    #[pyo3(get)]
    offset: Py<PyAny>,
    /// Load increments used.
    #[pyo3(get)]
    n: usize,
    /// 1 or 2.
    #[pyo3(get)]
    order: u8,
    /// Residual degrees of freedom.
    #[pyo3(get)]
    dof: usize,
    /// (3,) N·m.
    #[pyo3(get)]
    residual_rms: Py<PyAny>,
    /// (3,).
    #[pyo3(get)]
    omega_singular_values: Py<PyAny>,
    #[pyo3(get)]
    omega_condition: f64,
    #[pyo3(get)]
    regressor_condition: f64,
    #[pyo3(get)]
    asymmetry: f64,
    /// (k,) increments of the det(K) series.
    #[pyo3(get)]
    det_convergence_n: Py<PyAny>,
    /// (k,) det(K), (N·m/rad)³.
    #[pyo3(get)]
    det_convergence_det: Py<PyAny>,
    /// (3, 3, 3) N·m/rad², or None for order 1.
    #[pyo3(get)]
    curvature: Py<PyAny>,
}

impl PyCsjmEstimate {
    fn new(py: Python<'_>, est: &StiffnessEstimate) -> PyResult<Self> {
        let f = |v: Vec<f64>, shape: &[usize]| numpy_field(py, v, shape);
        let (ns, dets): (Vec<f64>, Vec<f64>) = est
            .det_convergence
            .iter()
            .map(|p| (p.n as f64, p.det))
            .unzip();
        let len = ns.len();
        Ok(Self {
            k: f(mat_to_vec(&est.k), &[3, 3])?,
            k_d: f(mat_to_vec(&est.k_d), &[3, 3])?,
            k_l: f(mat_to_vec(&est.k_l), &[3, 3])?,
            k_stderr: f(mat_to_vec(&est.k_stderr), &[3, 3])?,
            tau0: f(est.tau0.as_slice().to_vec(), &[3])?,
            offset: f(est.offset.as_slice().to_vec(), &[3])?,
            n: est.n,
            order: est.order,
            dof: est.dof,
            residual_rms: f(est.residual_rms.as_slice().to_vec(), &[3])?,
            omega_singular_values: f(est.omega_singular_values.to_vec(), &[3])?,
            omega_condition: est.omega_condition,
            regressor_condition: est.regressor_condition,
            asymmetry: est.asymmetry(),
            det_convergence_n: f(ns, &[len])?,
            det_convergence_det: f(dets, &[len])?,
            curvature: match &est.curvature {
                Some(h) => f(h.iter().flat_map(mat_to_vec).collect(), &[3, 3, 3])?,
                None => py.None(),
            },
        })
    }
}

/// A CSJM dataset from arrays: `r` (N, 3, 3) orientations ᴮ_A R, `tau` (N, 3) moments in A
/// (N·m), `reference` the row of R₀/τ₀. Matrices farther than `tol` from SO(3) are rejected
/// (naming the row) unless `project`; accepted ones are replaced by their nearest rotation,
/// as the file reader does.
pub fn dataset_from_arrays(
    r: &PyReadonlyArrayDyn<'_, f64>,
    tau: &PyReadonlyArrayDyn<'_, f64>,
    reference: i64,
    project: bool,
    tol: Option<f64>,
) -> PyResult<CsjmDataset> {
    let rr = batch(r, "R", &[3, 3])?;
    let tt = batch(tau, "tau", &[3])?;
    if rr.rows != tt.rows {
        return Err(shape_error(format!(
            "tau has {} rows (dimension 0) but R has {}: one row per measurement",
            tt.rows, rr.rows
        )));
    }
    let n = rr.rows;
    check_finite(&rr.data, "R", &[n, 3, 3])?;
    check_finite(&tt.data, "tau", &[n, 3])?;
    let reference = usize::try_from(reference)
        .ok()
        .filter(|&i| i < n)
        .ok_or_else(|| {
            value_error(format!(
                "ref = {reference} is not a row index of R (0 ≤ ref < {n})"
            ))
        })?;
    let tol = tol.unwrap_or(DEFAULT_ORTHOGONALITY_TOL);
    let mut measurements = Vec::with_capacity(n);
    for i in 0..n {
        let m = Matrix3::from_row_slice(&rr.data[9 * i..9 * i + 9]);
        let err = so3::orthogonality_error(&m);
        if !project && (err.is_nan() || err > tol) {
            return Err(value_error(format!(
                "R[{i}] is not a rotation matrix: orthogonality error ‖RᵀR − I‖_F = {err:.3e} exceeds the tolerance {tol:.3e} (pass project=True to project measured matrices onto SO(3))"
            )));
        }
        let rot: Rotation3<f64> =
            so3::project_to_rotation(&m).map_err(|e| value_error(format!("R[{i}]: {e}")))?;
        let moment = Vector3::new(tt.data[3 * i], tt.data[3 * i + 1], tt.data[3 * i + 2]);
        let mut meas = CsjmMeasurement::new(rot, moment);
        meas.orthogonality_error = err;
        meas.row = i + 1;
        measurements.push(meas);
    }
    let r0 = measurements.remove(reference);
    CsjmDataset::new(r0, measurements).py()
}

/// K from arrays: `r` (N, 3, 3) orientations ᴮ_A R, `tau` (N, 3) moments in A (N·m), `reference`
/// the row of R₀/τ₀. Matrices farther than `tol` from SO(3) are rejected (naming the row)
/// unless `project`; accepted ones are replaced by their nearest rotation, as the file reader does.
#[pyfunction]
#[pyo3(signature = (r, tau, reference, order = 1, project = false, tol = None, convergence = true))]
#[allow(clippy::too_many_arguments)] // a Python signature: its keywords and their defaults
pub fn csjm_identify<'py>(
    py: Python<'py>,
    r: PyReadonlyArrayDyn<'py, f64>,
    tau: PyReadonlyArrayDyn<'py, f64>,
    reference: i64,
    order: u8,
    project: bool,
    tol: Option<f64>,
    convergence: bool,
) -> PyResult<PyCsjmEstimate> {
    let data = dataset_from_arrays(&r, &tau, reference, project, tol)?;
    let opts = fit_options(order, convergence)?;
    let est = run(py, || identify(&data, &opts))?.py()?;
    PyCsjmEstimate::new(py, &est)
}

/// (R (N, 3, 3), tau (N, 3), index of the reference row).
type MeasurementArrays<'py> = (
    Bound<'py, numpy::PyArrayDyn<f64>>,
    Bound<'py, numpy::PyArrayDyn<f64>>,
    usize,
);

/// Reads a CSJM measurement file: returns (R (N, 3, 3), tau (N, 3), ref index).
#[pyfunction]
#[pyo3(signature = (path, project = false))]
pub fn csjm_read_csv<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    project: bool,
) -> PyResult<MeasurementArrays<'py>> {
    let opts = if project {
        ReadOptions::projecting()
    } else {
        ReadOptions::default()
    };
    let data = run(py, || CsjmDataset::from_csv_path(&path, &opts))?.py()?;
    let all: Vec<&CsjmMeasurement> = std::iter::once(data.reference())
        .chain(data.measurements())
        .collect();
    // Keep file order: the reference goes back to its own row.
    let mut rows: Vec<(usize, &CsjmMeasurement)> = all.iter().map(|m| (m.row, *m)).collect();
    rows.sort_by_key(|(row, _)| *row);
    let reference = rows
        .iter()
        .position(|(row, _)| *row == data.reference().row)
        .unwrap_or(0);
    let n = rows.len();
    let mut r = Vec::with_capacity(9 * n);
    let mut t = Vec::with_capacity(3 * n);
    for (_, m) in &rows {
        r.extend(mat_to_vec(m.orientation.matrix()));
        t.extend_from_slice(m.moment.as_slice());
    }
    Ok((
        to_numpy(py, r, &[n, 3, 3])?,
        to_numpy(py, t, &[n, 3])?,
        reference,
    ))
}

/// Identifies K from a measurement file (the CLI path).
#[pyfunction]
#[pyo3(signature = (path, order = 1, project = false))]
pub fn csjm_identify_csv<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    order: u8,
    project: bool,
) -> PyResult<PyCsjmEstimate> {
    let read = if project {
        ReadOptions::projecting()
    } else {
        ReadOptions::default()
    };
    let opts = fit_options(order, true)?;
    let est = run(py, || {
        CsjmDataset::from_csv_path(&path, &read).and_then(|data| identify(&data, &opts))
    })?
    .py()?;
    PyCsjmEstimate::new(py, &est)
}

/// Registers the functions on `m`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyCsjmEstimate>()?;
    m.add_function(wrap_pyfunction!(csjm_identify, m)?)?;
    m.add_function(wrap_pyfunction!(csjm_read_csv, m)?)?;
    m.add_function(wrap_pyfunction!(csjm_identify_csv, m)?)?;
    Ok(())
}
