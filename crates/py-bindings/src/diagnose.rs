//! Binding of `vjm::diagnose`: baseline fit, residual structure, named effects, extended model.
//! The result is handed over as typed values (see [`crate::results`]).

use numpy::PyReadonlyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use vjm::diagnose::{diagnose_monitored, DiagnoseOptions};

use crate::errors::{IntoPyErr, PyResultExt};
use crate::interrupt::run_interruptible;
use crate::results::{summary, vjm_per_pose, vjm_rows};
use crate::vjm::{parse_model, PyRobot};
use crate::vjm_data::dataset_from_arrays;

/// Diagnoses a measurement table on `robot`; returns `(summary, rows)`: the result without its
/// rows as native Python values, and the rows as numpy columns ([`crate::results`]).
///
/// `progress`, when given, is called as `progress(stage, done, total)` on the calling thread;
/// an exception it raises stops the run and propagates, as does Ctrl-C (`KeyboardInterrupt`).
#[pyfunction]
#[pyo3(signature = (robot, q, wrench, displacement, rotation = None, pose = None, set = None, baseline = None, fdr = None, test_fraction = None, split_seed = None, max_findings = None, progress = None, allow_outside_limits = false, tracker_sigma = None, force_sigma = None, moment_sigma = None, per_row = true, gravity = None))]
#[allow(clippy::too_many_arguments)] // a Python signature: its keywords and their defaults
pub fn vjm_diagnose<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    q: PyReadonlyArrayDyn<'py, f64>,
    wrench: PyReadonlyArrayDyn<'py, f64>,
    displacement: PyReadonlyArrayDyn<'py, f64>,
    rotation: Option<PyReadonlyArrayDyn<'py, f64>>,
    pose: Option<PyReadonlyArrayDyn<'py, i64>>,
    set: Option<Bound<'py, PyAny>>,
    baseline: Option<Bound<'py, PyAny>>,
    fdr: Option<f64>,
    test_fraction: Option<f64>,
    split_seed: Option<u64>,
    max_findings: Option<usize>,
    progress: Option<Py<PyAny>>,
    allow_outside_limits: bool,
    tracker_sigma: Option<f64>,
    force_sigma: Option<f64>,
    moment_sigma: Option<f64>,
    per_row: bool,
    gravity: Option<[f64; 3]>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let chain = &robot.chain;
    let n = chain.n_joints();
    let data = dataset_from_arrays(
        n,
        &q,
        &wrench,
        &displacement,
        rotation.as_ref(),
        pose.as_ref(),
        set.as_ref(),
    )?;
    let mut opts = DiagnoseOptions {
        allow_outside_limits,
        per_row,
        ..DiagnoseOptions::default()
    };
    // A noise level given by the user makes it known (the verdict adds the goodness of fit);
    // levels not given keep the default assumption.
    if let Some(v) = tracker_sigma {
        opts.noise.displacement_sigma = v;
        opts.noise_known = true;
    }
    if let Some(v) = force_sigma {
        opts.noise.wrench_sigma[..3].fill(v);
        opts.noise_known = true;
    }
    if let Some(v) = moment_sigma {
        opts.noise.wrench_sigma[3..].fill(v);
        opts.noise_known = true;
    }
    if let Some(b) = &baseline {
        opts.baseline = Some(parse_model(n, b)?);
    }
    if let Some(v) = fdr {
        opts.selection.fdr = v;
    }
    if let Some(v) = test_fraction {
        opts.selection.test_fraction = v;
    }
    if let Some(v) = split_seed {
        opts.selection.split_seed = v;
    }
    if let Some(v) = max_findings {
        opts.max_findings = v;
    }
    if let Some(g) = gravity {
        opts.gravity = Some(vjm::gravity::Gravity::new(g).py()?);
    }
    let mut result = run_interruptible(py, progress.as_ref(), |monitor| {
        diagnose_monitored(chain, &data, &opts, monitor)
    })?
    .map_err(IntoPyErr::into_py_err)?;
    let rows = vjm_rows(py, &std::mem::take(&mut result.rows))?;
    let per_pose = vjm_per_pose(py, &std::mem::take(&mut result.per_pose))?;
    let out = summary(py, &result)?;
    out.set_item("per_pose", per_pose)?;
    Ok((out, rows))
}

/// Registers the function on `m`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(vjm_diagnose, m)?)?;
    Ok(())
}
