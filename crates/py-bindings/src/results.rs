//! Diagnosis results handed to Python as typed values: the summary as native Python objects
//! (dicts, lists, numbers, strings, `None` — built from the core struct's `Serialize`, so a field
//! the core gains arrives without a change here) and the per-row part as numpy columns (one
//! array per quantity instead of a dict per row: 2·10⁵ rows would otherwise cost seconds and
//! hundreds of MB). `robot_stiffness.results` turns both into the typed result classes.

use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use serde::Serialize;
use serde_json::Value;

use crate::convert::to_numpy;
use crate::errors::internal_error;

/// A serialisable core value as native Python objects (non-finite floats become `None`, as in
/// the core's JSON). The key `rows` is dropped: rows travel as columns (see [`vjm_rows`]).
pub fn summary<'py, T: Serialize>(py: Python<'py>, value: &T) -> PyResult<Bound<'py, PyAny>> {
    let mut v = serde_json::to_value(value)
        .map_err(|e| internal_error(format!("the result could not be converted: {e}")))?;
    if let Value::Object(map) = &mut v {
        map.remove("rows");
    }
    native(py, &v)
}

/// A serialisable core value's fields as native Python objects, owned: a field of a typed
/// result class (non-finite floats become `None`).
pub fn native_field<T: Serialize>(py: Python<'_>, value: &T) -> PyResult<Py<PyAny>> {
    let v = serde_json::to_value(value)
        .map_err(|e| internal_error(format!("the result could not be converted: {e}")))?;
    Ok(native(py, &v)?.unbind())
}

/// A JSON value as native Python objects (non-finite floats were already `null`).
pub fn native<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => b.into_pyobject(py)?.to_owned().into_any(),
        Value::Number(n) => {
            if let Some(u) = n.as_u64() {
                u.into_pyobject(py)?.into_any()
            } else if let Some(i) = n.as_i64() {
                i.into_pyobject(py)?.into_any()
            } else {
                n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any()
            }
        }
        Value::String(s) => s.into_pyobject(py)?.into_any(),
        Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(native(py, item)?)?;
            }
            list.into_any()
        }
        Value::Object(map) => {
            let dict = PyDict::new(py);
            for (k, item) in map {
                dict.set_item(k, native(py, item)?)?;
            }
            dict.into_any()
        }
    })
}

fn flat3(rows: usize, get: impl Fn(usize) -> [f64; 3]) -> Vec<f64> {
    (0..rows).flat_map(get).collect()
}

/// The per-row part of a VJM diagnosis as columns: `pose` (N,) int64, `held_out` (N,) bool,
/// `measured`, `baseline`, `extended` (N, 3) m, base frame.
pub fn vjm_rows<'py>(
    py: Python<'py>,
    rows: &[vjm::diagnose::report::RowResult],
) -> PyResult<Bound<'py, PyDict>> {
    let n = rows.len();
    let out = PyDict::new(py);
    let pose: Vec<i64> = rows.iter().map(|r| r.pose).collect();
    out.set_item("pose", PyArray1::from_vec(py, pose))?;
    let held_out: Vec<bool> = rows
        .iter()
        .map(|r| r.set == vjm::dataset::SetLabel::Test)
        .collect();
    out.set_item("held_out", PyArray1::from_vec(py, held_out))?;
    out.set_item(
        "measured",
        to_numpy(py, flat3(n, |i| rows[i].measured), &[n, 3])?,
    )?;
    out.set_item(
        "baseline",
        to_numpy(py, flat3(n, |i| rows[i].baseline), &[n, 3])?,
    )?;
    out.set_item(
        "extended",
        to_numpy(py, flat3(n, |i| rows[i].extended), &[n, 3])?,
    )?;
    Ok(out)
}

/// The per-pose errors of a VJM diagnosis as columns (10⁵ poses in a large campaign: four
/// arrays instead of 10⁵ dicts): `pose` (G,) int64, `held_out` (G,) bool, `baseline`,
/// `extended` (G,) mean relative errors.
pub fn vjm_per_pose<'py>(
    py: Python<'py>,
    poses: &[vjm::diagnose::report::PoseError],
) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let pose: Vec<i64> = poses.iter().map(|p| p.pose).collect();
    out.set_item("pose", PyArray1::from_vec(py, pose))?;
    let held_out: Vec<bool> = poses
        .iter()
        .map(|p| p.set == vjm::dataset::SetLabel::Test)
        .collect();
    out.set_item("held_out", PyArray1::from_vec(py, held_out))?;
    let baseline: Vec<f64> = poses.iter().map(|p| p.baseline).collect();
    out.set_item("baseline", PyArray1::from_vec(py, baseline))?;
    let extended: Vec<f64> = poses.iter().map(|p| p.extended).collect();
    out.set_item("extended", PyArray1::from_vec(py, extended))?;
    Ok(out)
}

/// The per-row part of a CSJM diagnosis as columns: `row` (N,) int64 (1-based data row of the
/// file, 0 for arrays), `held_out` (N,) bool, `dzeta` (N, 3) rad, `dtau`, `baseline_residual`,
/// `extended_residual` (N, 3) N·m.
pub fn csjm_rows<'py>(
    py: Python<'py>,
    rows: &[so3_stiffness::diagnose::report::RowResult],
) -> PyResult<Bound<'py, PyDict>> {
    let n = rows.len();
    let out = PyDict::new(py);
    let row: Vec<i64> = rows.iter().map(|r| r.row as i64).collect();
    out.set_item("row", PyArray1::from_vec(py, row))?;
    let held_out: Vec<bool> = rows.iter().map(|r| r.set == "test").collect();
    out.set_item("held_out", PyArray1::from_vec(py, held_out))?;
    out.set_item("dzeta", to_numpy(py, flat3(n, |i| rows[i].dzeta), &[n, 3])?)?;
    out.set_item("dtau", to_numpy(py, flat3(n, |i| rows[i].dtau), &[n, 3])?)?;
    out.set_item(
        "baseline_residual",
        to_numpy(py, flat3(n, |i| rows[i].baseline_residual), &[n, 3])?,
    )?;
    out.set_item(
        "extended_residual",
        to_numpy(py, flat3(n, |i| rows[i].extended_residual), &[n, 3])?,
    )?;
    Ok(out)
}
