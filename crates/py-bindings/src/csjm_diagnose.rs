//! Bindings of `so3_stiffness::diagnose`: CSJM campaigns with hidden effects (testbed) and the
//! diagnosis of a CSJM measurement file (typed values, see [`crate::results`]).

use numpy::PyReadonlyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use so3_stiffness::csjm::PointLoad;
use so3_stiffness::diagnose::{
    diagnose_file_monitored, diagnose_monitored, simulate_campaign, CsjmCampaignSpec,
    CsjmDiagnosis, CsjmEffects, DiagnoseOptions,
};
use so3_stiffness::identification::campaign::GravityRecording;
use so3_stiffness::identification::ReadOptions;

use crate::convert::{check_effect_keys, numpy_field};
use crate::errors::{internal_error, run, value_error, IntoPyErr, PyResultExt};
use crate::interrupt::run_interruptible;
use crate::results::{csjm_rows, summary};

fn number(d: &Bound<'_, PyDict>, i: usize, key: &str) -> PyResult<f64> {
    d.get_item(key)?
        .ok_or_else(|| value_error(format!("effects[{i}] needs the key `{key}`")))?
        .extract::<f64>()
        .map_err(|_| value_error(format!("effects[{i}][`{key}`] must be a number")))
}

/// The hidden effects from a list of dicts: `platform_gravity` (the prototype's weight acting
/// but left out of the recorded moments), `cable_hysteresis` with `friction` (N, every cable),
/// `cable_nonlinearity` with `k2` (N/m², every cable).
fn effects(list: &Bound<'_, PyList>) -> PyResult<CsjmEffects> {
    let mut out = CsjmEffects::none();
    for (i, item) in list.iter().enumerate() {
        let d = item
            .cast::<PyDict>()
            .map_err(|_| value_error(format!("effects[{i}] must be a dict")))?;
        let name: String = d
            .get_item("effect")?
            .ok_or_else(|| value_error(format!("effects[{i}] needs the key `effect`")))?
            .extract()?;
        let valid: &[&str] = match name.as_str() {
            "cable_hysteresis" => &["friction"],
            "cable_nonlinearity" => &["k2"],
            _ => &[],
        };
        check_effect_keys(d, i, &name, valid)?;
        // Physical ranges: a friction force and a stiffening coefficient are ≥ 0.
        let non_negative = |key: &str, unit: &str| -> PyResult<f64> {
            let v = number(d, i, key)?;
            if !(v.is_finite() && v >= 0.0) {
                return Err(value_error(format!(
                    "effects[{i}] ({name}): `{key}` must be finite and ≥ 0 {unit}, got {v}"
                )));
            }
            Ok(v)
        };
        match name.as_str() {
            "platform_gravity" => {
                out.gravity = GravityRecording::Omitted(PointLoad::prototype_gravity());
            }
            "cable_hysteresis" => out.cable_friction = [non_negative("friction", "N")?; 6],
            "cable_nonlinearity" => out.cable_stiffening = [non_negative("k2", "N/m²")?; 6],
            other => {
                return Err(value_error(format!(
                    "effects[{i}]: unknown CSJM effect `{other}` (platform_gravity, cable_hysteresis, cable_nonlinearity)"
                )))
            }
        }
    }
    Ok(out)
}

/// Simulates the seed's CSJM campaign (pre-loaded reference, load increments, tracker and F/T
/// noise) with hidden effects; returns the CSV text and the true stiffness at R₀.
#[pyfunction]
#[pyo3(signature = (effects_list, seed = 0, increments = None, max_increment = None))]
pub fn csjm_simulate<'py>(
    py: Python<'py>,
    effects_list: &Bound<'py, PyList>,
    seed: u64,
    increments: Option<usize>,
    max_increment: Option<f64>,
) -> PyResult<PyCsjmCampaign> {
    let mut spec = CsjmCampaignSpec::new(effects(effects_list)?, seed);
    if let Some(n) = increments {
        spec.schedule.increments = n;
    }
    if let Some(m) = max_increment {
        spec.schedule.max_increment = m;
    }
    let campaign = run(py, || simulate_campaign(&spec))?.py()?;
    let mut buf = Vec::new();
    campaign.dataset.write_csv(&mut buf).py()?;
    let m = |x: &nalgebra::Matrix3<f64>| -> PyResult<Py<PyAny>> {
        let v: Vec<f64> = (0..3)
            .flat_map(|r| (0..3).map(move |c| x[(r, c)]))
            .collect();
        numpy_field(py, v, &[3, 3])
    };
    let k = &campaign.true_stiffness;
    Ok(PyCsjmCampaign {
        csv: String::from_utf8(buf).map_err(|e| internal_error(e.to_string()))?,
        true_k: m(&k.covariant)?,
        true_k_d: m(&k.euclidean)?,
        true_r0: m(campaign.true_r0.matrix())?,
    })
}

/// A simulated CSJM campaign: the measurement file's text and the hidden truth at R₀ (frame A):
/// `true_K`, `true_K_D` (3, 3) N·m/rad and `true_R0` (3, 3) ᴮ_A R₀.
#[derive(Debug)]
#[pyclass(module = "robot_stiffness._core", name = "CsjmCampaign", frozen)]
pub struct PyCsjmCampaign {
    /// The measurement file's text.
    #[pyo3(get)]
    csv: String,
    /// (3, 3) N·m/rad, the covariant stiffness.
    #[pyo3(get, name = "true_K")]
    true_k: Py<PyAny>,
    /// (3, 3) N·m/rad, the slope ∂τ/∂Δζ.
    #[pyo3(get, name = "true_K_D")]
    true_k_d: Py<PyAny>,
    /// (3, 3), the reference orientation.
    #[pyo3(get, name = "true_R0")]
    true_r0: Py<PyAny>,
}

fn options(
    fdr: Option<f64>,
    test_fraction: Option<f64>,
    split_seed: Option<u64>,
    project: bool,
) -> DiagnoseOptions {
    let mut opts = DiagnoseOptions::default();
    if let Some(v) = fdr {
        opts.selection.fdr = v;
    }
    if let Some(v) = test_fraction {
        opts.selection.test_fraction = v;
    }
    if let Some(v) = split_seed {
        opts.selection.split_seed = v;
    }
    if project {
        opts.read = ReadOptions::projecting();
    }
    opts
}

/// Diagnoses CSJM measurements given as arrays (see `csjm_identify`); returns `(summary, rows)`
/// as [`vjm_diagnose`](crate::diagnose::vjm_diagnose) does. `progress`, when given, is called
/// as `progress(stage, done, total)` on the calling thread; an exception it raises (or Ctrl-C)
/// cancels the run and propagates.
#[pyfunction]
#[pyo3(signature = (r, tau, reference, fdr = None, test_fraction = None, split_seed = None, project = false, progress = None))]
#[allow(clippy::too_many_arguments)] // a Python signature: its keywords and their defaults
pub fn csjm_diagnose<'py>(
    py: Python<'py>,
    r: PyReadonlyArrayDyn<'py, f64>,
    tau: PyReadonlyArrayDyn<'py, f64>,
    reference: i64,
    fdr: Option<f64>,
    test_fraction: Option<f64>,
    split_seed: Option<u64>,
    project: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let data = crate::csjm::dataset_from_arrays(&r, &tau, reference, project, None)?;
    let opts = options(fdr, test_fraction, split_seed, project);
    let result = run_interruptible(py, progress.as_ref(), |monitor| {
        diagnose_monitored(&data, &opts, monitor)
    })?
    .map_err(IntoPyErr::into_py_err)?;
    typed(py, result)
}

/// Diagnoses a CSJM measurement file; returns `(summary, rows)`. `progress` as for
/// `csjm_diagnose`.
#[pyfunction]
#[pyo3(signature = (path, fdr = None, test_fraction = None, split_seed = None, project = false, progress = None))]
pub fn csjm_diagnose_csv<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    fdr: Option<f64>,
    test_fraction: Option<f64>,
    split_seed: Option<u64>,
    project: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let opts = options(fdr, test_fraction, split_seed, project);
    let result = run_interruptible(py, progress.as_ref(), |monitor| {
        diagnose_file_monitored(&path, &opts, monitor)
    })?
    .map_err(IntoPyErr::into_py_err)?;
    typed(py, result)
}

fn typed(
    py: Python<'_>,
    mut result: CsjmDiagnosis,
) -> PyResult<(Bound<'_, PyAny>, Bound<'_, PyDict>)> {
    let rows = csjm_rows(py, &std::mem::take(&mut result.rows))?;
    Ok((summary(py, &result)?, rows))
}

/// Registers the functions on `m`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyCsjmCampaign>()?;
    m.add_function(wrap_pyfunction!(csjm_simulate, m)?)?;
    m.add_function(wrap_pyfunction!(csjm_diagnose_csv, m)?)?;
    m.add_function(wrap_pyfunction!(csjm_diagnose, m)?)?;
    Ok(())
}
