//! Gravity on a robot's virtual springs: `vjm::gravity` for Python.

use numpy::{PyArrayDyn, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use vjm::gravity::{
    deflection_under_gravity, gravity_sag, gravity_stiffness, gravity_torques, Gravity,
};
use vjm::stiffness_model::PointMass;

use crate::convert::{batch, fixed, to_numpy};
use crate::errors::{run, value_error, PyResultExt};
use crate::vjm::{parse_model, PyRobot};

/// The weight a call evaluates: gravity (m/s², base frame) and an optional payload (kg, centre
/// in the tip frame, m).
struct Weight {
    gravity: Gravity,
    payload: Option<PointMass>,
}

impl Weight {
    /// From the Python arguments: the gravity vector and the payload `(mass, (cx, cy, cz))`.
    fn parse(gravity: [f64; 3], payload: Option<(f64, [f64; 3])>) -> PyResult<Self> {
        // The gravity's error first, then the payload's (as before the two were one value).
        let gravity = Gravity::new(gravity).py()?;
        let payload = match payload {
            None => None,
            Some((m, c)) => Some(PointMass::new(m, c).map_err(|e| value_error(e.to_string()))?),
        };
        Ok(Self { gravity, payload })
    }
}

/// Evaluates `f` at every configuration of `q` ((N, n) rad) with `model` and `weight`, each
/// call giving the numbers of one `shape` block; returns them as an array of shape
/// `(N, *shape)`. The callers parse the model before the weight, so that an error names the
/// first bad argument in the signature's order.
fn per_configuration<'py, F>(
    py: Python<'py>,
    robot: &PyRobot,
    q: PyReadonlyArrayDyn<'py, f64>,
    model: &vjm::VirtualJointModel,
    weight: Weight,
    shape: &[usize],
    f: F,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>>
where
    F: Fn(
            &vjm::SerialChain,
            &vjm::VirtualJointModel,
            &[f64],
            &Gravity,
            Option<&PointMass>,
        ) -> Result<Vec<f64>, vjm::VjmError>
        + Send
        + Sync,
{
    let chain = &robot.chain;
    let n = chain.n_joints();
    let Weight {
        gravity: g,
        payload: p,
    } = weight;
    let q = batch(&q, "q", &[n])?;
    let out = run(py, || -> Result<Vec<f64>, vjm::VjmError> {
        let mut out = Vec::with_capacity(q.rows * shape.iter().product::<usize>());
        for qi in q.data.chunks_exact(n) {
            out.extend(f(chain, model, qi, &g, p.as_ref())?);
        }
        Ok(out)
    })?
    .py()?;
    let mut full = vec![q.rows];
    full.extend_from_slice(shape);
    to_numpy(py, out, &full)
}

/// Torques of gravity on the springs of `model`, (N, m), N·m; `q` is (N, n) rad.
#[pyfunction]
#[pyo3(signature = (robot, q, model, gravity, payload = None))]
pub fn vjm_gravity_torques<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    q: PyReadonlyArrayDyn<'py, f64>,
    model: &Bound<'py, PyAny>,
    gravity: [f64; 3],
    payload: Option<(f64, [f64; 3])>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let model = parse_model(robot.chain.n_joints(), model)?;
    let weight = Weight::parse(gravity, payload)?;
    let shape = [model.n_params()];
    per_configuration(py, robot, q, &model, weight, &shape, gravity_torques)
}

/// The stiffness of gravity K_G on the springs of `model`, (N, m, m), N·m/rad.
#[pyfunction]
#[pyo3(signature = (robot, q, model, gravity, payload = None))]
pub fn vjm_gravity_stiffness<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    q: PyReadonlyArrayDyn<'py, f64>,
    model: &Bound<'py, PyAny>,
    gravity: [f64; 3],
    payload: Option<(f64, [f64; 3])>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let model = parse_model(robot.chain.n_joints(), model)?;
    let weight = Weight::parse(gravity, payload)?;
    let shape = [model.n_params(), model.n_params()];
    // Symmetric, so its column-major storage reads as row-major.
    per_configuration(py, robot, q, &model, weight, &shape, |c, mo, q, g, p| {
        Ok(gravity_stiffness(c, mo, q, g, p)?.as_slice().to_vec())
    })
}

/// The tip's sag under its own weight (+ payload) against the rigid kinematics, (N, 6),
/// `[dx, dy, dz, rx, ry, rz]` (m, rad), base frame, at the springs' static equilibrium.
#[pyfunction]
#[pyo3(signature = (robot, compliance, q, model, gravity, payload = None))]
pub fn vjm_gravity_sag<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    compliance: PyReadonlyArrayDyn<'py, f64>,
    q: PyReadonlyArrayDyn<'py, f64>,
    model: &Bound<'py, PyAny>,
    gravity: [f64; 3],
    payload: Option<(f64, [f64; 3])>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let model = parse_model(robot.chain.n_joints(), model)?;
    let c = fixed(&compliance, "compliance", &[model.n_params()])?;
    let weight = Weight::parse(gravity, payload)?;
    per_configuration(py, robot, q, &model, weight, &[6], |ch, mo, q, g, p| {
        Ok(gravity_sag(ch, mo, &c, q, g, p)?.to_vec())
    })
}

/// Tip under `wrench` minus tip unloaded, both at the static equilibrium under gravity
/// (+ payload), (N, 6) `[dx, dy, dz, rx, ry, rz]` (m, rad), base frame.
#[pyfunction]
#[pyo3(signature = (robot, compliance, q, wrench, model, gravity, payload = None))]
#[allow(clippy::too_many_arguments)] // a Python signature: its keywords and their defaults
pub fn vjm_deflection_under_gravity<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    compliance: PyReadonlyArrayDyn<'py, f64>,
    q: PyReadonlyArrayDyn<'py, f64>,
    wrench: PyReadonlyArrayDyn<'py, f64>,
    model: &Bound<'py, PyAny>,
    gravity: [f64; 3],
    payload: Option<(f64, [f64; 3])>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let chain = &robot.chain;
    let n = chain.n_joints();
    let model = parse_model(n, model)?;
    let Weight {
        gravity: g,
        payload: p,
    } = Weight::parse(gravity, payload)?;
    let c = fixed(&compliance, "compliance", &[model.n_params()])?;
    let q = batch(&q, "q", &[n])?;
    let w = batch(&wrench, "wrench", &[6])?;
    if w.rows != q.rows {
        return Err(value_error(format!(
            "q has {} rows and wrench {}: give one wrench per configuration",
            q.rows, w.rows
        )));
    }
    let out = run(py, || -> Result<Vec<f64>, vjm::VjmError> {
        let mut out = Vec::with_capacity(q.rows * 6);
        for (qi, wi) in q.data.chunks_exact(n).zip(w.data.chunks_exact(6)) {
            let wi: [f64; 6] = [wi[0], wi[1], wi[2], wi[3], wi[4], wi[5]];
            out.extend(deflection_under_gravity(
                chain,
                &model,
                &c,
                qi,
                &wi,
                &g,
                p.as_ref(),
            )?);
        }
        Ok(out)
    })?
    .py()?;
    to_numpy(py, out, &[q.rows, 6])
}

/// Adds the gravity functions to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(vjm_gravity_torques, m)?)?;
    m.add_function(wrap_pyfunction!(vjm_gravity_stiffness, m)?)?;
    m.add_function(wrap_pyfunction!(vjm_gravity_sag, m)?)?;
    m.add_function(wrap_pyfunction!(vjm_deflection_under_gravity, m)?)?;
    Ok(())
}
