//! The CLI's output tables (`PRED.csv`, `COMP.csv`) written by the core's one CSV writer
//! (`vjm::stiffness_model::{PredictionTable, CompensationTable}`): shortest round-trip
//! numbers formatted on every core, Ctrl-C checked while it writes.
//!
//! The Python caller passes the temporary file it staged; it renames it over the output only
//! after a complete write, so an error or an interrupt leaves the output as it was.

use std::fs::File;
use std::io::BufWriter;
use std::path::PathBuf;

use numpy::{PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use stiffness_core::table::TableError;
use vjm::stiffness_model::{
    status_from_name, CompensationTable, PredictionTable, SagColumns, COMPENSATION_COLUMNS,
    PREDICTION_COLUMNS, SAG_COLUMNS,
};
use vjm::CompensationStatus;

use crate::convert::{batch, column};
use crate::errors::{shape_error, value_error, PyResultExt};
use crate::interrupt::run_interruptible;

/// Creates `path` and runs `write` on it (buffered) in an interruptible worker.
fn write_file<F>(py: Python<'_>, path: PathBuf, write: F) -> PyResult<()>
where
    F: FnOnce(BufWriter<File>, &stiffness_core::Cancel) -> Result<(), TableError> + Send,
{
    run_interruptible(py, None, |monitor| {
        let file = File::create(&path).map_err(|source| TableError::Io {
            path: path.clone(),
            source,
        })?;
        write(
            BufWriter::with_capacity(1 << 20, file),
            monitor.cancel_token(),
        )
    })?
    .py()
}

/// n of a joint-position array of shape (N, n).
fn joints(q: &PyReadonlyArrayDyn<'_, f64>) -> PyResult<usize> {
    match q.shape() {
        [_, n] => Ok(*n),
        shape => Err(shape_error(format!(
            "q must have shape (N, n), got {shape:?}"
        ))),
    }
}

fn same_rows(name: &str, rows: usize, expected: usize) -> PyResult<()> {
    if rows != expected {
        return Err(shape_error(format!(
            "{name} has {rows} rows, q has {expected}"
        )));
    }
    Ok(())
}

/// Writes `PRED.csv` to `path`: q (N, n) rad, wrench (N, 6), deflection (N, 6), stddev
/// (N, 6), identified (N,) bool, and optionally the sag as `predict_sag` returns it
/// (deflection (N, 6) m and rad, stddev (N, 6), identified (N,) bool), of which dx..dz and
/// their standard deviations are written.
#[pyfunction]
#[pyo3(signature = (path, q, wrench, deflection, stddev, identified, sag=None))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)] // a Python signature
pub fn vjm_write_predictions(
    py: Python<'_>,
    path: PathBuf,
    q: PyReadonlyArrayDyn<'_, f64>,
    wrench: PyReadonlyArrayDyn<'_, f64>,
    deflection: PyReadonlyArrayDyn<'_, f64>,
    stddev: PyReadonlyArrayDyn<'_, f64>,
    identified: PyReadonlyArrayDyn<'_, bool>,
    sag: Option<(
        PyReadonlyArrayDyn<'_, f64>,
        PyReadonlyArrayDyn<'_, f64>,
        PyReadonlyArrayDyn<'_, bool>,
    )>,
) -> PyResult<()> {
    let n_joints = joints(&q)?;
    let q = batch(&q, "q", &[n_joints])?;
    let rows = q.rows;
    let wrench = batch(&wrench, "wrench", &[6])?;
    let deflection = batch(&deflection, "deflection", &[6])?;
    let stddev = batch(&stddev, "stddev", &[6])?;
    for (name, r) in [
        ("wrench", wrench.rows),
        ("deflection", deflection.rows),
        ("stddev", stddev.rows),
    ] {
        same_rows(name, r, rows)?;
    }
    let identified = column(&identified, "identified", rows)?;
    let sag = match &sag {
        None => None,
        Some((d, sd, id)) => {
            let d = batch(d, "sag deflection", &[6])?;
            let sd = batch(sd, "sag stddev", &[6])?;
            same_rows("sag deflection", d.rows, rows)?;
            same_rows("sag stddev", sd.rows, rows)?;
            Some((d.data, sd.data, column(id, "sag identified", rows)?))
        }
    };
    let table = PredictionTable {
        n_joints,
        q: &q.data,
        wrench: &wrench.data,
        deflection: &deflection.data,
        stddev: &stddev.data,
        identified: &identified,
        sag: sag.as_ref().map(|(d, sd, id)| SagColumns {
            deflection: d,
            stddev: sd,
            identified: id,
        }),
    };
    write_file(py, path, |out, cancel| table.write_csv(out, cancel))
}

/// Writes `COMP.csv` to `path`: corrected q (N, n) and nominal q (N, n) rad; values (N, 5):
/// position_error m, rotation_error rad, deflection m, rotation_deflection rad,
/// inverse_condition; iterations (N,) and limit_joint (N,) int64 (0-based, −1 for none);
/// status: N status names.
#[pyfunction]
#[allow(clippy::too_many_arguments)] // a Python signature: its keywords and their defaults
pub fn vjm_write_compensation(
    py: Python<'_>,
    path: PathBuf,
    q: PyReadonlyArrayDyn<'_, f64>,
    q_nominal: PyReadonlyArrayDyn<'_, f64>,
    values: PyReadonlyArrayDyn<'_, f64>,
    iterations: PyReadonlyArrayDyn<'_, i64>,
    limit_joint: PyReadonlyArrayDyn<'_, i64>,
    status: Vec<String>,
) -> PyResult<()> {
    let n_joints = joints(&q)?;
    let q = batch(&q, "q", &[n_joints])?;
    let rows = q.rows;
    let q_nominal = batch(&q_nominal, "q_nominal", &[n_joints])?;
    same_rows("q_nominal", q_nominal.rows, rows)?;
    let values = batch(&values, "values", &[5])?;
    same_rows("values", values.rows, rows)?;
    let iterations = column(&iterations, "iterations", rows)?;
    let limit_joint = column(&limit_joint, "limit_joint", rows)?;
    same_rows("status", status.len(), rows)?;
    let status = status
        .iter()
        .enumerate()
        .map(|(i, s)| {
            status_from_name(s)
                .ok_or_else(|| value_error(format!("status of row {i}: unknown status '{s}'")))
        })
        .collect::<PyResult<Vec<CompensationStatus>>>()?;
    // One column per value: (N, 5) row-major to five (N,) columns.
    let col = |k: usize| -> Vec<f64> { values.data.iter().skip(k).step_by(5).copied().collect() };
    let cols: Vec<Vec<f64>> = (0..5).map(col).collect();
    let table = CompensationTable {
        n_joints,
        q: &q.data,
        q_nominal: &q_nominal.data,
        position_error: &cols[0],
        rotation_error: &cols[1],
        deflection: &cols[2],
        rotation_deflection: &cols[3],
        inverse_condition: &cols[4],
        iterations: &iterations,
        limit_joint: &limit_joint,
        status: &status,
    };
    write_file(py, path, |out, cancel| table.write_csv(out, cancel))
}

/// Registers the functions on `m`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // The column names, from the one list the writers use (Parquet/Arrow outputs name theirs
    // the same way).
    m.add("VJM_PREDICTION_COLUMNS", PREDICTION_COLUMNS.to_vec())?;
    m.add("VJM_SAG_COLUMNS", SAG_COLUMNS.to_vec())?;
    m.add("VJM_COMPENSATION_COLUMNS", COMPENSATION_COLUMNS.to_vec())?;
    m.add_function(wrap_pyfunction!(vjm_write_predictions, m)?)?;
    m.add_function(wrap_pyfunction!(vjm_write_compensation, m)?)?;
    Ok(())
}
