//! Bindings of the uses of a VJM model: compensation (`vjm::compensate`) and measurement
//! planning (`vjm::design`). Every batch runs in Rust with the GIL released.

use numpy::{PyArrayDyn, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use vjm::{CompensateOptions, Load, NoiseModel, PlanSpec, PointMass};

use crate::convert::{batch, fixed, numpy_field, to_numpy, Rows};
use crate::errors::{run, value_error, PyResultExt};
use crate::results::native_field;
use crate::vjm::{parse_model, PyRobot};

/// The per-row numbers of a compensation, columns of the (N, 7) array returned.
const ROW_COLUMNS: [&str; 7] = [
    "position_error",
    "rotation_error",
    "deflection",
    "rotation_deflection",
    "inverse_condition",
    "iterations",
    "limit_joint",
];

/// Corrected joint targets: returns `(q (N, n), rows (N, 7), status list)`; the columns of
/// `rows` are `position_error, rotation_error, deflection, rotation_deflection,
/// inverse_condition, iterations, limit_joint` (0-based joint, −1 when none).
#[pyfunction]
#[pyo3(signature = (robot, model, compliance, q, wrench = None, payload = None, match_orientation = false, with_kc = true, allow_outside_limits = false, gravity = None))]
#[allow(clippy::too_many_arguments)] // a Python signature: its keywords and their defaults
pub fn vjm_compensate<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    model: &Bound<'py, PyAny>,
    compliance: PyReadonlyArrayDyn<'py, f64>,
    q: PyReadonlyArrayDyn<'py, f64>,
    wrench: Option<PyReadonlyArrayDyn<'py, f64>>,
    payload: Option<(f64, [f64; 3])>,
    match_orientation: bool,
    with_kc: bool,
    allow_outside_limits: bool,
    gravity: Option<[f64; 3]>,
) -> PyResult<CompensationArrays<'py>> {
    let chain = &robot.chain;
    let n = chain.n_joints();
    let model = parse_model(n, model)?;
    let c = fixed(&compliance, "compliance", &[model.n_params()])?;
    let gravity = gravity.map(vjm::gravity::Gravity::new).transpose().py()?;
    if gravity.is_some() {
        chain.mass_model().py()?; // before the work: a URDF without masses is named at once
    }
    let q = batch(&q, "q", &[n])?;
    let w = match &wrench {
        Some(w) => Some(batch(w, "wrench", &[6])?),
        None => None,
    };
    let load = load_of(&q, w.as_ref(), payload)?;
    check_inputs(py, chain, &q, load, allow_outside_limits)?;
    let mut opts = CompensateOptions::default();
    opts.match_orientation = match_orientation;
    opts.with_kc = with_kc;
    opts.gravity = gravity;
    let out = run(py, || {
        vjm::compensate(chain, &model, &c, &q.data, load, &opts)
    })?
    .py()?;
    arrays(py, out, n)
}

/// `(q, rows, status)` as returned to Python.
pub(crate) type CompensationArrays<'py> = (
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<f64>>,
    Vec<&'static str>,
);

/// The load from exactly one of a wrench array (as many rows as `q`) and a payload: the one
/// parsing of prediction and compensation loads.
pub(crate) fn load_of<'a>(
    q: &Rows<'_>,
    w: Option<&'a Rows<'a>>,
    payload: Option<(f64, [f64; 3])>,
) -> PyResult<Load<'a>> {
    let pm = match payload {
        Some((mass, centre)) => Some(
            // The payload's own check (finite, mass ≥ 0); its message names the value.
            PointMass::new(mass, centre).py()?,
        ),
        None => None,
    };
    let load = match (&w, pm) {
        (Some(w), None) => {
            if w.rows != q.rows {
                return Err(crate::errors::shape_error(format!(
                    "wrench has {} rows (dimension 0) but q has {}: one row per configuration",
                    w.rows, q.rows
                )));
            }
            Load::Wrench(&w.data)
        }
        (None, Some(pm)) => Load::Payload(pm),
        (Some(_), Some(_)) => {
            return Err(value_error(
                "give exactly one of wrench (N, 6) and payload (mass, cx, cy, cz), not both",
            ))
        }
        (None, None) => {
            return Err(value_error(
                "a load is needed: exactly one of wrench (N, 6) and payload (mass, cx, cy, cz)",
            ))
        }
    };
    Ok(load)
}

/// The checks `identify` runs on its inputs, on the poses and per-row loads of a prediction
/// or a compensation (`vjm::dataset::check_poses`: plausible joint angles and loads, joint
/// angles inside the URDF limits unless `allow_outside_limits`), with the GIL released; a
/// non-finite value is named by its array, row (from 0) and column.
/// The payload's own check is [`PointMass::new`].
pub(crate) fn check_inputs(
    py: Python<'_>,
    chain: &vjm::SerialChain,
    q: &Rows<'_>,
    load: Load<'_>,
    allow_outside_limits: bool,
) -> PyResult<()> {
    let wrench = match load {
        Load::Wrench(w) => Some(w),
        _ => None,
    };
    check_arrays(py, chain, q, wrench, allow_outside_limits)
}

/// [`check_inputs`] of the poses and, when given, an (N, 6) wrench: the sag's poses are
/// checked without a wrench (no N×6 zeros made for the purpose).
pub(crate) fn check_arrays(
    py: Python<'_>,
    chain: &vjm::SerialChain,
    q: &Rows<'_>,
    wrench: Option<&[f64]>,
    allow_outside_limits: bool,
) -> PyResult<()> {
    let limits = (!allow_outside_limits).then_some(chain);
    let found = run(py, || {
        vjm::dataset::check_poses(chain.n_joints(), &q.data, wrench, limits)
    })?
    .py()?;
    if found == vjm::dataset::ArraysCheck::NonFinite {
        // Named by array, row and column here: a per-row evaluation would see a one-row slice.
        let n = chain.n_joints();
        let arrays = [("q", &q.data[..], n), ("wrench", wrench.unwrap_or(&[]), 6)];
        for (what, data, width) in arrays {
            if let Some(k) = data.iter().position(|v| !v.is_finite()) {
                return Err(vjm::VjmError::NonFinite {
                    what,
                    row: k / width,
                    column: k % width,
                    value: data[k],
                })
                .py();
            }
        }
    }
    Ok(())
}

/// The result arrays of a compensation.
fn arrays(py: Python<'_>, out: vjm::Compensation, n: usize) -> PyResult<CompensationArrays<'_>> {
    let rows = out.rows.len();
    let mut table = Vec::with_capacity(ROW_COLUMNS.len() * rows);
    for r in &out.rows {
        table.extend_from_slice(&[
            r.position_error,
            r.rotation_error,
            r.deflection,
            r.rotation_deflection,
            r.inverse_condition,
            r.iterations as f64,
            r.limit_joint.map_or(-1.0, |j| j as f64),
        ]);
    }
    let status = out.rows.iter().map(|r| r.status.as_str()).collect();
    Ok((
        to_numpy(py, out.q, &[rows, n])?,
        to_numpy(py, table, &[rows, ROW_COLUMNS.len()])?,
        status,
    ))
}

/// [`vjm_compensate`] with the springs and compliances of a model file (robot and content
/// hash checked on load). `match_orientation` defaults to whether the model has rotations.
/// `gravity` (m/s², base frame) corrects the sag under the arm's weight too; with
/// `recorded_gravity` the gravity is the one the model file records (standard gravity when it
/// records none) and `gravity` must be `None`.
#[pyfunction]
#[pyo3(signature = (robot, path, q, wrench = None, payload = None, match_orientation = None, with_kc = true, allow_outside_limits = false, gravity = None, recorded_gravity = false))]
#[allow(clippy::too_many_arguments)] // a Python signature: its keywords and their defaults
pub fn vjm_compensate_model_file<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    path: &str,
    q: PyReadonlyArrayDyn<'py, f64>,
    wrench: Option<PyReadonlyArrayDyn<'py, f64>>,
    payload: Option<(f64, [f64; 3])>,
    match_orientation: Option<bool>,
    with_kc: bool,
    allow_outside_limits: bool,
    gravity: Option<[f64; 3]>,
    recorded_gravity: bool,
) -> PyResult<CompensationArrays<'py>> {
    let chain = &robot.chain;
    let n = chain.n_joints();
    let gravity = model_gravity(gravity, recorded_gravity)?;
    // The inputs first (a bad payload is named even when the file is also bad), then the file.
    let q = batch(&q, "q", &[n])?;
    let w = match &wrench {
        Some(w) => Some(batch(w, "wrench", &[6])?),
        None => None,
    };
    let load = load_of(&q, w.as_ref(), payload)?;
    check_inputs(py, chain, &q, load, allow_outside_limits)?;
    let model = run(py, || vjm::StiffnessModel::load(path, chain))?.py()?;
    let opts = ModelCompensation {
        match_orientation,
        with_kc,
        gravity,
    };
    compensate_with_model(py, &model, chain, &q.data, load, &opts)
}

/// The gravity of a compensation through a stiffness model: the one given, or with
/// `recorded` the model's own ([`ModelGravity::Recorded`]).
pub(crate) fn model_gravity(gravity: Option<[f64; 3]>, recorded: bool) -> PyResult<ModelGravity> {
    let given = gravity.map(vjm::gravity::Gravity::new).transpose().py()?;
    match (given, recorded) {
        (Some(_), true) => Err(value_error(
            "give either gravity or recorded_gravity=True, not both",
        )),
        (Some(g), false) => Ok(ModelGravity::Given(Some(g))),
        (None, false) => Ok(ModelGravity::Given(None)),
        (None, true) => Ok(ModelGravity::Recorded),
    }
}

/// Which gravity a compensation through a stiffness model corrects the sag under.
#[derive(Debug, Clone, Copy)]
pub(crate) enum ModelGravity {
    /// This one; `None`: the load's deflection only (weightless).
    Given(Option<vjm::gravity::Gravity>),
    /// The gravity the model was identified under, standard gravity when it records none.
    Recorded,
}

/// The options of a compensation through a stiffness model (Python keywords).
pub(crate) struct ModelCompensation {
    pub match_orientation: Option<bool>,
    pub with_kc: bool,
    pub gravity: ModelGravity,
}

/// Compensation through `model` (its springs and compliances; its robot checked against
/// `chain`): the one path of `vjm_compensate_model_file` and `StiffnessModel.compensate`.
/// `match_orientation` defaults to whether the model has rotations.
pub(crate) fn compensate_with_model<'py>(
    py: Python<'py>,
    model: &vjm::StiffnessModel,
    chain: &vjm::SerialChain,
    q: &[f64],
    load: Load<'_>,
    o: &ModelCompensation,
) -> PyResult<CompensationArrays<'py>> {
    let mut opts = CompensateOptions::default();
    opts.match_orientation = o.match_orientation.unwrap_or(model.has_rotations());
    opts.with_kc = o.with_kc;
    opts.gravity = match o.gravity {
        ModelGravity::Given(g) => g,
        ModelGravity::Recorded => Some(model.gravity().unwrap_or_default()),
    };
    if opts.gravity.is_some() {
        // Before the work: a URDF without masses is named at once.
        chain.mass_model().py()?;
    }
    let out = run(py, || model.compensate(chain, q, load, &opts))?.py()?;
    arrays(py, out, chain.n_joints())
}

/// Plans a VJM campaign ([`PyDesignPlan`]): `poses` poses × `wrenches_per_pose` wrenches,
/// noise of the testbed's instruments with its nominal compliances as the prior, measured
/// under `gravity` (base frame, m/s²; None weightless). Runs on a
/// worker thread: Ctrl-C stops it within [`crate::interrupt::POLL_INTERVAL`] (the core checks
/// its token per pose and per chunk of candidates), and `progress(stage, done, total)`, when
/// given, is called on the calling thread.
#[pyfunction]
#[pyo3(signature = (robot, model, poses = 24, wrenches_per_pose = 4, seed = 0, margin = 0.1, pool_size = 300, force = 80.0, moment = 3.0, progress = None, gravity = None))]
#[allow(clippy::too_many_arguments)] // a Python signature: its keywords and their defaults
pub fn vjm_design(
    py: Python<'_>,
    robot: &PyRobot,
    model: &Bound<'_, PyAny>,
    poses: usize,
    wrenches_per_pose: usize,
    seed: u64,
    margin: f64,
    pool_size: usize,
    force: f64,
    moment: f64,
    progress: Option<Py<PyAny>>,
    gravity: Option<[f64; 3]>,
) -> PyResult<PyDesignPlan> {
    let chain = &robot.chain;
    let model = parse_model(chain.n_joints(), model)?;
    if gravity.is_some() {
        // Before the work, as identify does: a URDF without masses names the link.
        chain.mass_model().py()?;
    }
    let mut spec = PlanSpec::default();
    spec.n_poses = poses;
    spec.wrenches_per_pose = wrenches_per_pose;
    spec.seed = seed;
    spec.limit_margin = margin;
    spec.pool_size = pool_size.max(poses);
    spec.force = force;
    spec.moment = moment;
    let mut noise = NoiseModel::typical(&model);
    noise.gravity = gravity.map(vjm::gravity::Gravity::new).transpose().py()?;
    let plan = crate::interrupt::run_interruptible(py, progress.as_ref(), |monitor| {
        vjm::design_monitored(chain, &model, &spec, &noise, monitor)
    })?
    .py()?;
    PyDesignPlan::new(py, plan, chain.n_joints())
}

/// A planned campaign: `q` (N, n) rad, `wrench` (N, 6) N and N·m (base frame), `pose` (N,)
/// int64 pose ids, the `rank` the plan reaches, its `combinations`
/// ([`PyPlannedCombination`]), `worst_stderr` (None when not finite), the `noise` model assumed
/// (a dict of its fields) and `pose_compliance_wrenches`.
#[derive(Debug)]
#[pyclass(module = "robot_stiffness._core", name = "DesignPlan", frozen, get_all)]
pub struct PyDesignPlan {
    /// (N, n) float64, rad.
    pub q: Py<PyAny>,
    /// (N, 6) float64, N and N·m.
    pub wrench: Py<PyAny>,
    /// (N,) int64.
    pub pose: Py<PyAny>,
    /// Rank reached.
    pub rank: usize,
    /// The planned combinations.
    pub combinations: Vec<Py<PyPlannedCombination>>,
    /// The largest predicted standard error, or None when it is not finite.
    pub worst_stderr: Option<f64>,
    /// The noise model assumed (a dict of its fields).
    pub noise: Py<PyAny>,
    /// Wrenches per pose of the pose-compliance rows.
    pub pose_compliance_wrenches: usize,
}

/// A combination of parameters a plan determines: its label, its predicted standard error
/// (rad/(N·m); None when not finite), its terms `(parameter index, coefficient)` and whether it
/// is weak.
#[derive(Debug)]
#[pyclass(
    module = "robot_stiffness._core",
    name = "PlannedCombination",
    frozen,
    get_all
)]
pub struct PyPlannedCombination {
    /// E.g. `J1y + J2z`.
    pub label: String,
    /// Predicted standard error, or None when it is not finite.
    pub stderr: Option<f64>,
    /// `(parameter index, coefficient)` of each term.
    pub terms: Vec<(usize, f64)>,
    /// Above its value or above 1e-2 rad/(N·m).
    pub weak: bool,
}

impl PyDesignPlan {
    fn new(py: Python<'_>, plan: vjm::Plan, n_joints: usize) -> PyResult<Self> {
        let rows = plan.pose.len();
        let pose: Vec<i64> = plan.pose.iter().map(|&p| p as i64).collect();
        Ok(Self {
            q: numpy_field(py, plan.q, &[rows, n_joints])?,
            wrench: numpy_field(py, plan.wrench.concat(), &[rows, 6])?,
            pose: numpy::PyArray1::from_vec(py, pose).into_any().unbind(),
            rank: plan.rank,
            combinations: plan
                .combinations
                .iter()
                .map(|c| {
                    Py::new(
                        py,
                        PyPlannedCombination {
                            label: c.label.clone(),
                            stderr: c.stderr.is_finite().then_some(c.stderr),
                            terms: c.terms.iter().map(|t| (t.param, t.coefficient)).collect(),
                            weak: c.weak,
                        },
                    )
                })
                .collect::<PyResult<_>>()?,
            worst_stderr: plan.worst_stderr.is_finite().then_some(plan.worst_stderr),
            noise: native_field(py, &plan.noise)?,
            pose_compliance_wrenches: plan.pose_compliance_wrenches,
        })
    }
}

/// Registers the functions on `m`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyDesignPlan>()?;
    m.add_class::<PyPlannedCombination>()?;
    m.add_function(wrap_pyfunction!(vjm_compensate, m)?)?;
    m.add_function(wrap_pyfunction!(vjm_design, m)?)?;
    m.add_function(wrap_pyfunction!(vjm_compensate_model_file, m)?)?;
    Ok(())
}
