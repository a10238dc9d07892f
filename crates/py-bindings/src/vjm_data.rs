//! The VJM measurement file and campaigns: reading/validating a file or arrays into a
//! [`Dataset`], simulating campaigns with the testbed, and the seed's study.

use numpy::PyReadonlyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use vjm::dataset::Dataset;
use vjm::testbed::{self, CampaignSpec, Effect, HarmonicDriveSpring, TrueModel};
use vjm::SpringAxis;

use crate::columns::PyMeasurementColumns;
use crate::convert::{batch, check_effect_keys, fixed, numpy_field, pose_ids, set_labels};
use crate::errors::{run, value_error, IntoPyErr, PyResultExt};
use crate::interrupt::run_interruptible;
use crate::vjm::PyRobot;

/// A dataset over the caller's arrays, validated exactly as the file reader validates (row i =
/// line i + 2). Contiguous float64 and int64 columns are borrowed, not copied (a campaign of 10⁶
/// Panda rows is 128 MB of them), as `identify` borrows its input: the caller's arrays must not
/// be written by another Python thread while the call runs without the GIL.
pub fn dataset_from_arrays<'a>(
    n_joints: usize,
    q: &'a PyReadonlyArrayDyn<'_, f64>,
    wrench: &'a PyReadonlyArrayDyn<'_, f64>,
    displacement: &'a PyReadonlyArrayDyn<'_, f64>,
    rotation: Option<&'a PyReadonlyArrayDyn<'_, f64>>,
    pose: Option<&'a PyReadonlyArrayDyn<'_, i64>>,
    set: Option<&Bound<'_, PyAny>>,
) -> PyResult<Dataset<'a>> {
    let q = batch(q, "q", &[n_joints])?;
    let w = batch(wrench, "wrench", &[6])?;
    let d = batch(displacement, "displacement", &[3])?;
    let r = rotation.map(|r| batch(r, "rotation", &[3])).transpose()?;
    let pose = pose.map(pose_ids).transpose()?;
    let set = set.map(set_labels).transpose()?;
    Dataset::from_columns(
        n_joints,
        q.data,
        w.data,
        d.data,
        r.map(|r| r.data),
        pose,
        set,
    )
    .py()
}

/// Reads and validates a VJM measurement file for a chain of `n_joints` joints; with `sha256`,
/// the table's `sha256` is that of the bytes read (taken in the same pass), else None.
#[pyfunction]
#[pyo3(signature = (path, n_joints, sha256 = true))]
pub fn vjm_read_csv(
    py: Python<'_>,
    path: std::path::PathBuf,
    n_joints: usize,
    sha256: bool,
) -> PyResult<PyMeasurementColumns> {
    let (data, hash) = run(py, || {
        if sha256 {
            Dataset::read_csv_with_sha256(&path, n_joints).map(|(d, h)| (d, Some(h)))
        } else {
            Dataset::read_csv(&path, n_joints).map(|d| (d, None))
        }
    })?
    .py()?;
    PyMeasurementColumns::new(py, data, hash)
}

/// Validates arrays as a measurement table and returns the CSV text (full precision).
#[pyfunction]
#[pyo3(signature = (n_joints, q, wrench, displacement, rotation = None, pose = None, set = None))]
pub fn vjm_to_csv(
    n_joints: usize,
    q: PyReadonlyArrayDyn<'_, f64>,
    wrench: PyReadonlyArrayDyn<'_, f64>,
    displacement: PyReadonlyArrayDyn<'_, f64>,
    rotation: Option<PyReadonlyArrayDyn<'_, f64>>,
    pose: Option<PyReadonlyArrayDyn<'_, i64>>,
    set: Option<Bound<'_, PyAny>>,
) -> PyResult<String> {
    let data = dataset_from_arrays(
        n_joints,
        &q,
        &wrench,
        &displacement,
        rotation.as_ref(),
        pose.as_ref(),
        set.as_ref(),
    )?;
    let mut buf = Vec::new();
    data.to_writer(&mut buf).py()?;
    String::from_utf8(buf).map_err(|e| crate::errors::internal_error(e.to_string()))
}

fn get<'py, T: FromPyObjectOwned<'py>>(d: &Bound<'py, PyDict>, i: usize, key: &str) -> PyResult<T> {
    let item = d
        .get_item(key)?
        .ok_or_else(|| value_error(format!("effects[{i}] needs the key `{key}`")))?;
    item.extract::<T>().map_err(|_| {
        value_error(format!(
            "effects[{i}][`{key}`] has the wrong type ({})",
            item.get_type()
                .name()
                .map(|n| n.to_string())
                .unwrap_or_default()
        ))
    })
}

fn joint0(i: usize, joint: usize, n: usize) -> PyResult<usize> {
    if joint == 0 || joint > n {
        return Err(value_error(format!(
            "effects[{i}]: joint {joint} does not exist (joints are 1..{n}, base → tip)"
        )));
    }
    Ok(joint - 1)
}

/// The keys each effect accepts (besides `effect`).
fn effect_keys(name: &str) -> Option<&'static [&'static str]> {
    Some(match name {
        "joint_tilt" => &["joint", "axis", "compliance"],
        "joint_torsion_nonlinear" => &["joint", "k1", "k2", "k3", "t1", "t2", "ratio"],
        "joint_backlash" => &["joint", "lost_motion"],
        "link_translation" => &["joint", "axis", "compliance"],
        "joint_torsion_angle_dependent" => &["joint", "amplitude"],
        "wrench_bias" => &["bias"],
        "frame_misalignment" => &["rotation"],
        "geometric_nonlinearity" => &[],
        "pose_drift" => &["sigma"],
        "mount_compliance" => &["translation", "rotation"],
        "tool_axial_compliance" => &["compliance"],
        "sensor_crosstalk" => &["coupling"],
        _ => return None,
    })
}

/// `d[key]` as a number in `[0, max]` (`> 0` when `positive`), else an error naming the effect
/// and the key: the user's own words, not a line of the simulated file.
fn in_range(
    d: &Bound<'_, PyDict>,
    i: usize,
    name: &str,
    key: &str,
    positive: bool,
    max: f64,
    unit: &str,
) -> PyResult<f64> {
    let v: f64 = get(d, i, key)?;
    let low_ok = if positive { v > 0.0 } else { v >= 0.0 };
    if !(low_ok && v <= max) {
        let low = if positive { "> 0" } else { "≥ 0" };
        return Err(value_error(format!(
            "effects[{i}] ({name}): `{key}` must be {low} and at most {max} {unit}, got {v}"
        )));
    }
    Ok(v)
}

/// Largest tilt compliance an effect may have, rad/(N·m): 10 N·m would tilt the joint by
/// 0.1 rad, far beyond any arm (nominal values are ~1e-6–1e-4).
const MAX_EFFECT_COMPLIANCE: f64 = 1e-2;

/// `d["axis"]` as a spring axis: `x` or `y`, and `z` when `z_allowed`; `what` names it in the
/// error.
fn spring_axis(
    d: &Bound<'_, PyDict>,
    i: usize,
    what: &str,
    z_allowed: bool,
) -> PyResult<SpringAxis> {
    let axis: String = get(d, i, "axis")?;
    match (axis.as_str(), z_allowed) {
        ("x", _) => Ok(SpringAxis::X),
        ("y", _) => Ok(SpringAxis::Y),
        ("z", true) => Ok(SpringAxis::Z),
        (other, false) => Err(value_error(format!(
            "effects[{i}]: {what} `{other}` must be x or y"
        ))),
        (other, true) => Err(value_error(format!(
            "effects[{i}]: {what} `{other}` must be x, y or z"
        ))),
    }
}

/// Parses one effect: a dict with `effect` and its parameters (1-based `joint`, SI units).
fn parse_effect(d: &Bound<'_, PyDict>, i: usize, truth: &TrueModel, n: usize) -> PyResult<Effect> {
    let name: String = get(d, i, "effect")?;
    if let Some(valid) = effect_keys(&name) {
        check_effect_keys(d, i, &name, valid)?;
    }
    Ok(match name.as_str() {
        "joint_tilt" => {
            let joint = joint0(i, get(d, i, "joint")?, n)?;
            let axis = spring_axis(d, i, "tilt axis", false)?;
            Effect::JointTilt {
                joint,
                axis,
                compliance: in_range(
                    d,
                    i,
                    &name,
                    "compliance",
                    false,
                    MAX_EFFECT_COMPLIANCE,
                    "rad/(N·m)",
                )?,
            }
        }
        "joint_torsion_nonlinear" => {
            let joint = joint0(i, get(d, i, "joint")?, n)?;
            let spring = if d.contains("k1")? {
                HarmonicDriveSpring {
                    k1: get(d, i, "k1")?,
                    k2: get(d, i, "k2")?,
                    k3: get(d, i, "k3")?,
                    t1: get(d, i, "t1")?,
                    t2: get(d, i, "t2")?,
                }
            } else {
                // Stiffening by `ratio` per segment from the joint's own linear compliance.
                let c1 = truth.compliance[3 * joint];
                if c1.is_nan() || c1 <= 0.0 {
                    return Err(value_error(format!(
                        "effects[{i}]: joint {} has no torsional compliance to stiffen; give k1, k2, k3",
                        joint + 1
                    )));
                }
                let ratio = in_range(d, i, &name, "ratio", true, 1e6, "")?;
                let t1 = in_range(d, i, &name, "t1", true, 1e4, "N·m")?;
                let t2: f64 = get(d, i, "t2")?;
                if !(t2 > t1 && t2 <= 1e4) {
                    return Err(value_error(format!(
                        "effects[{i}] ({name}): `t2` must be above t1 = {t1} and at most 10000 N·m, got {t2}"
                    )));
                }
                HarmonicDriveSpring::stiffening(c1, ratio, t1, t2)
            };
            Effect::TorsionNonlinear { joint, spring }
        }
        "link_translation" => {
            let joint = joint0(i, get(d, i, "joint")?, n)?;
            let axis = spring_axis(d, i, "link_translation axis", true)?;
            Effect::LinkTranslation {
                joint,
                axis,
                compliance: in_range(d, i, &name, "compliance", false, 1e-3, "m/N")?,
            }
        }
        "joint_backlash" => Effect::Backlash {
            joint: joint0(i, get(d, i, "joint")?, n)?,
            lost_motion: in_range(d, i, &name, "lost_motion", false, 0.1, "rad")?,
        },
        "joint_torsion_angle_dependent" => {
            let joint = joint0(i, get(d, i, "joint")?, n)?;
            let amplitude: f64 = get(d, i, "amplitude")?;
            // c·(1 + a·sin q) must stay a positive compliance.
            if !(amplitude.is_finite() && amplitude.abs() < 1.0) {
                return Err(value_error(format!(
                    "effects[{i}] ({name}): `amplitude` must be within (−1, 1), got {amplitude}"
                )));
            }
            Effect::TorsionAngleDependent { joint, amplitude }
        }
        "wrench_bias" => Effect::WrenchBias {
            bias: get(d, i, "bias")?,
        },
        "frame_misalignment" => Effect::FrameMisalignment {
            rotation: get(d, i, "rotation")?,
        },
        "geometric_nonlinearity" => Effect::GeometricNonlinearity,
        "pose_drift" => Effect::PoseDrift {
            sigma: in_range(d, i, &name, "sigma", false, 0.01, "m")?,
        },
        "mount_compliance" => Effect::MountCompliance {
            translation: in_range(d, i, &name, "translation", false, 1e-3, "m/N")?,
            rotation: in_range(d, i, &name, "rotation", false, 1e-2, "rad/(N·m)")?,
        },
        "tool_axial_compliance" => Effect::ToolAxialCompliance {
            compliance: in_range(d, i, &name, "compliance", false, 1e-2, "m/N")?,
        },
        "sensor_crosstalk" => Effect::SensorCrosstalk {
            coupling: in_range(d, i, &name, "coupling", false, 0.5, "(1 = 100 %)")?,
        },
        other => {
            return Err(value_error(format!(
                "effects[{i}]: unknown effect `{other}` (joint_tilt, joint_torsion_nonlinear, joint_backlash, link_translation, joint_torsion_angle_dependent, wrench_bias, frame_misalignment, geometric_nonlinearity, pose_drift, mount_compliance, tool_axial_compliance, sensor_crosstalk)"
            )))
        }
    })
}

/// The true model: torsional compliances (n,) or the nominal ones, plus effects.
fn true_model(
    n: usize,
    torsion: Option<PyReadonlyArrayDyn<'_, f64>>,
    effects: &Bound<'_, PyList>,
) -> PyResult<TrueModel> {
    let mut truth = match torsion {
        Some(t) => TrueModel::torsion_only(&fixed(&t, "torsion", &[n])?),
        None => TrueModel::nominal(n),
    };
    for (i, e) in effects.iter().enumerate() {
        let d = e
            .cast::<PyDict>()
            .map_err(|_| value_error(format!("effects[{i}] must be a dict")))?;
        let effect = parse_effect(d, i, &truth, n)?;
        truth = truth.with_effect(effect);
    }
    Ok(truth)
}

/// Simulates a measurement campaign: the measurements, the CSV text and the hidden truth
/// ([`PyVjmCampaign`]).
///
/// With `plan` = `(q (N, n), wrench (N, 6), pose (N,))` the rows are measured at those joint
/// angles and wrenches (a plan of `design`) instead of random ones; `n_poses`,
/// `wrenches_per_pose`, `force_max` and `moment_max` are then not used.
#[pyfunction]
#[pyo3(signature = (robot, effects, n_poses = 40, wrenches_per_pose = 4, seed = 0, noise = true, torsion = None, force_max = None, moment_max = None, test_fraction = None, gravity = None, plan = None))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)] // a Python signature
pub fn vjm_simulate<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    effects: &Bound<'py, PyList>,
    n_poses: usize,
    wrenches_per_pose: usize,
    seed: u64,
    noise: bool,
    torsion: Option<PyReadonlyArrayDyn<'py, f64>>,
    force_max: Option<f64>,
    moment_max: Option<f64>,
    test_fraction: Option<f64>,
    gravity: Option<[f64; 3]>,
    plan: Option<(
        PyReadonlyArrayDyn<'py, f64>,
        PyReadonlyArrayDyn<'py, f64>,
        PyReadonlyArrayDyn<'py, i64>,
    )>,
) -> PyResult<PyVjmCampaign> {
    let chain = &robot.chain;
    let truth = true_model(chain.n_joints(), torsion, effects)?;
    let mut spec = CampaignSpec {
        n_poses,
        wrenches_per_pose,
        seed,
        noise,
        ..CampaignSpec::default()
    };
    if let Some(f) = force_max {
        spec.force_range = (spec.force_range.0.min(f), f);
    }
    if let Some(m) = moment_max {
        spec.moment_max = m;
    }
    if let Some(g) = gravity {
        spec.gravity = Some(vjm::gravity::Gravity::new(g).py()?);
        // Before the work, as identify and compensate do: a URDF without masses is a
        // RobotModelError naming the link.
        chain.mass_model().py()?;
    }
    if let Some(t) = test_fraction {
        spec.test_fraction = t;
    }
    let planned = plan
        .as_ref()
        .map(|(q, w, p)| planned_rows(chain.n_joints(), q, w, p))
        .transpose()?;
    let campaign = run_interruptible(py, None, |monitor| match &planned {
        None => testbed::simulate_monitored(chain, &truth, &spec, monitor),
        Some((q, w, p)) => {
            testbed::simulate_planned_monitored(chain, &truth, q, w, p, &spec, monitor)
        }
    })?
    .map_err(IntoPyErr::into_py_err)?;
    let n = campaign.dataset.len();
    let mut buf = Vec::new();
    campaign.dataset.to_writer(&mut buf).py()?;
    let f = |v: Vec<f64>, shape: &[usize]| numpy_field(py, v, shape);
    Ok(PyVjmCampaign {
        true_displacement: f(campaign.true_displacement.concat(), &[n, 3])?,
        applied_wrench: f(campaign.applied_wrench.concat(), &[n, 6])?,
        tip: f(campaign.tip.concat(), &[n, 3])?,
        measurements: Py::new(py, PyMeasurementColumns::new(py, campaign.dataset, None)?)?,
        csv: String::from_utf8(buf).map_err(|e| crate::errors::internal_error(e.to_string()))?,
        // The truth and the spec as native Python objects (their serialised fields).
        truth: crate::results::native_field(py, &truth)?,
        spec: crate::results::native_field(py, &spec)?,
    })
}

/// A simulated VJM campaign: what was measured (`measurements`, and `csv`, the same rows as a
/// measurement file) and the hidden truth: `true_displacement` (N, 3) m without noise,
/// `applied_wrench` (N, 6) N and N·m, `tip` (N, 3) m the rigid tip position (base frame), the
/// true model `truth` and the campaign `spec` (their serialised fields).
#[derive(Debug)]
#[pyclass(
    module = "robot_stiffness._core",
    name = "VjmCampaign",
    frozen,
    get_all
)]
pub struct PyVjmCampaign {
    /// The measured rows.
    pub measurements: Py<PyMeasurementColumns>,
    /// The rows as a measurement file.
    pub csv: String,
    /// (N, 3) m, noise-free.
    pub true_displacement: Py<PyAny>,
    /// (N, 6) N and N·m.
    pub applied_wrench: Py<PyAny>,
    /// (N, 3) m, base frame.
    pub tip: Py<PyAny>,
    /// The true model (a dict of its fields).
    pub truth: Py<PyAny>,
    /// The campaign's spec (a dict of its fields).
    pub spec: Py<PyAny>,
}

/// A plan's rows, checked for shape and row count: joint angles (N·n), wrenches, pose ids.
#[allow(clippy::type_complexity)]
fn planned_rows(
    n: usize,
    q: &PyReadonlyArrayDyn<'_, f64>,
    wrench: &PyReadonlyArrayDyn<'_, f64>,
    pose: &PyReadonlyArrayDyn<'_, i64>,
) -> PyResult<(Vec<f64>, Vec<[f64; 6]>, Vec<i64>)> {
    let q = batch(q, "plan q", &[n])?;
    let w = batch(wrench, "plan wrench", &[6])?;
    let p = pose_ids(pose)?;
    if w.rows != q.rows || p.len() != q.rows {
        return Err(value_error(format!(
            "the plan's q, wrench and pose have {}, {} and {} rows: they must describe the same rows",
            q.rows,
            w.rows,
            p.len()
        )));
    }
    if q.rows == 0 {
        return Err(value_error("the plan has no rows"));
    }
    let wrenches = w
        .data
        .chunks_exact(6)
        .map(|c| [c[0], c[1], c[2], c[3], c[4], c[5]])
        .collect();
    Ok((q.data.into_owned(), wrenches, p.into_owned()))
}

/// The seed's study (Table I configurations, two wrenches each). Joints only (`links` false):
/// tilting springs of `tilt_ratio` × the torsional compliance, or (None) of the ratio
/// calibrated to the seed's torsion share. With `links`: the structural truth whose links bend,
/// at `link_share` (None: the share calibrated to the seed's extended-model error). Returns it
/// as native Python objects (its serialised fields; `robot_stiffness` builds the typed
/// `PaperStudy`) with the truth's `tilt_ratio` and `link_scale` (m/N, 0 without links).
#[pyfunction]
#[pyo3(signature = (robot, tilt_ratio = None, noise = true, seed = 0, links = false, link_share = None))]
pub fn vjm_paper_study<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    tilt_ratio: Option<f64>,
    noise: bool,
    seed: u64,
    links: bool,
    link_share: Option<f64>,
) -> PyResult<Py<crate::paper_study::PyPaperStudy>> {
    let chain = &robot.chain;
    if let Some(r) = tilt_ratio {
        if !(r.is_finite() && r >= 0.0) {
            return Err(value_error(format!(
                "tilt_ratio must be finite and ≥ 0, got {r}"
            )));
        }
        if links {
            return Err(value_error(
                "tilt_ratio applies to the joints-only truth; with links the tilts are calibrated \
                 to the seed's torsion share",
            ));
        }
    }
    if let Some(share) = link_share {
        if !links {
            return Err(value_error("link_share needs links=True"));
        }
        if !(share > 0.0 && share < 1.0) {
            return Err(value_error(format!(
                "link_share must be within (0, 1), got {share}"
            )));
        }
    }
    let (study, ratio, scale) = run(py, || -> Result<_, testbed::TestbedError> {
        let (truth, ratio, scale) = match (links, tilt_ratio) {
            (true, _) => {
                let share = match link_share {
                    Some(s) => s,
                    None => testbed::paper_structural_link_share(chain)?,
                };
                let t = testbed::paper_structural_truth(chain, share)?;
                (t.truth, t.tilt_ratio, t.link_scale)
            }
            (false, Some(r)) => {
                let torsion: Vec<f64> = (0..chain.n_joints())
                    .map(|j| testbed::NOMINAL_TORSION[j % 7])
                    .collect();
                (TrueModel::with_tilts(&torsion, r), r, 0.0)
            }
            (false, None) => {
                let (truth, r) = testbed::paper_truth(chain)?;
                (truth, r, 0.0)
            }
        };
        Ok((
            testbed::paper_study(chain, &truth, noise, seed)?,
            ratio,
            scale,
        ))
    })?
    .map_err(IntoPyErr::into_py_err)?;
    crate::paper_study::paper_study(py, &study, ratio, scale)
}

/// Registers the functions on `m`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(vjm_read_csv, m)?)?;
    m.add_function(wrap_pyfunction!(vjm_to_csv, m)?)?;
    m.add_class::<PyVjmCampaign>()?;
    m.add_function(wrap_pyfunction!(vjm_simulate, m)?)?;
    m.add_function(wrap_pyfunction!(vjm_paper_study, m)?)?;
    Ok(())
}
