//! Bindings of `vjm::stiffness_model`: the saved stiffness model (typed, not JSON text),
//! identification straight into a model, predictions, and the pose-table reader.

use std::sync::Arc;

use numpy::{PyArrayDyn, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use vjm::{SerialChain, StiffnessModel};

use crate::columns::PyPredictionColumns;
use crate::convert::{batch, to_numpy};
use crate::errors::{run, PyResultExt};
use crate::vjm::{IdentifyArgs, PyRobot};

/// A gear curve across the binding: `(joint (1-based), knots (N·m), coefficients
/// (rad/(N·m)))`.
type GearCurveTuple = (usize, Vec<f64>, Vec<f64>, f64);

/// A stiffness model bound to the robot it describes (immutable).
#[pyclass(frozen, module = "robot_stiffness._core", name = "StiffnessModel")]
#[derive(Debug, Clone)]
pub struct PyStiffnessModel {
    model: Arc<StiffnessModel>,
    chain: Arc<SerialChain>,
}

impl PyStiffnessModel {
    /// Wraps a model of `chain`.
    pub(crate) fn new(model: StiffnessModel, chain: Arc<SerialChain>) -> Self {
        Self {
            model: Arc::new(model),
            chain,
        }
    }
}

#[pymethods]
impl PyStiffnessModel {
    /// Parses the text of a model file (`to_json`) and checks it against `robot`, as `load`
    /// does: how a pickled model is rebuilt.
    #[staticmethod]
    fn from_json(text: &str, robot: &PyRobot) -> PyResult<Self> {
        let name = "<pickled model>";
        let model = StiffnessModel::from_json(text, name).py()?;
        model.check_robot(&robot.chain, name).py()?;
        Ok(Self::new(model, robot.chain.clone()))
    }

    /// Reads a model file and checks it against `robot` (content hash, URDF, links, joints).
    #[staticmethod]
    fn load(py: Python<'_>, path: std::path::PathBuf, robot: &PyRobot) -> PyResult<Self> {
        let chain = robot.chain.clone();
        let model = run(py, || StiffnessModel::load(&path, &chain))?.py()?;
        Ok(Self {
            model: Arc::new(model),
            chain,
        })
    }

    /// Writes the model file atomically.
    fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        let model = &self.model;
        run(py, || model.save(&path))?.py()
    }

    /// The file text (pretty JSON with schema and content hash).
    fn to_json(&self) -> String {
        self.model.to_json()
    }

    /// The text of the model file at `path`: `to_json` with the URDF's path relative to the
    /// folder of `path` (`urdf_relative`); `path` is not opened.
    fn to_json_at(&self, path: std::path::PathBuf) -> String {
        self.model.to_json_at(&path)
    }

    /// The model's records as a dict (the `model` object of the file).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = serde_json::to_string(&*self.model).map_err(|e| {
            crate::errors::internal_error(format!("cannot serialise the model: {e}"))
        })?;
        py.import("json")?.call_method1("loads", (text,))
    }

    /// SHA-256 of the model content (as stored in the file).
    #[getter]
    fn content_sha256(&self) -> String {
        self.model.content_sha256()
    }

    /// Spring labels in parameter order.
    #[getter]
    fn labels(&self) -> Vec<String> {
        self.model.springs().labels.clone()
    }

    /// The gravity the model was identified under, `[gx, gy, gz]` m/s² in the base frame;
    /// `None` for a weightless model (also every file written before gravity was recorded).
    #[getter]
    fn gravity(&self) -> Option<[f64; 3]> {
        self.model.gravity().map(|g| g.vector().into())
    }

    /// The model's gear curves ([`vjm::gear::GearCurve`]): `(joint, knots, coefficients,
    /// lost_motion)` with the joint 1-based, knots in N·m, coefficients in rad/(N·m) and the
    /// lost motion in rad (0 without); empty without curves.
    #[getter]
    fn gear_curves(&self) -> PyResult<Vec<GearCurveTuple>> {
        Ok(self
            .model
            .gear_curves()
            .py()?
            .iter()
            .map(|c| {
                (
                    c.joint() + 1,
                    c.knots().to_vec(),
                    c.coefficients().to_vec(),
                    c.lost_motion(),
                )
            })
            .collect())
    }

    /// This model with the gear curves `curves` (`(joint, knots, coefficients, lost_motion)`,
    /// joint 1-based, knots N·m, coefficients rad/(N·m), lost motion rad) in place of any it
    /// had; an error names the joint of a malformed curve or of one without a torsion spring.
    fn with_gear_curves(&self, curves: Vec<GearCurveTuple>) -> PyResult<Self> {
        let mut out = Vec::with_capacity(curves.len());
        for (joint, knots, coefficients, lost_motion) in curves {
            if joint == 0 {
                return Err(crate::errors::value_error(
                    "a gear curve's joint is 1-based (1 = the first joint), got 0",
                ));
            }
            out.push(
                vjm::gear::GearCurve::with_lost_motion(joint - 1, knots, coefficients, lost_motion)
                    .py()?,
            );
        }
        let model = (*self.model).clone().with_gear_curves(&out).py()?;
        Ok(Self::new(model, self.chain.clone()))
    }

    /// Whether the model predicts rotations.
    #[getter]
    fn has_rotations(&self) -> bool {
        self.model.has_rotations()
    }

    /// Number of identifiable combinations.
    #[getter]
    fn rank(&self) -> usize {
        self.model.identification().rank
    }

    /// What the data determine: the stored compliances without their weak directions
    /// (`vjm::StiffnessModel::determined_compliance`), rad/(N·m), parameter order.
    #[getter]
    fn determined_compliance(&self) -> PyResult<Vec<f64>> {
        self.model.determined_compliance().py()
    }

    /// Standard deviations of a new measurement's noise `[dx..rz]` under the noise model.
    fn measurement_stddev(&self) -> Vec<f64> {
        self.model.measurement_stddev().to_vec()
    }

    /// Corrected joint targets for q (N, n) under wrench (N, 6) or a payload
    /// `(mass, [cx, cy, cz])`, with this model's springs and compliances: `(q, rows, status)`
    /// as `vjm_compensate`. `match_orientation` defaults to whether the model has rotations;
    /// `gravity` / `recorded_gravity` as `vjm_compensate_model_file`.
    #[pyo3(signature = (q, wrench = None, payload = None, match_orientation = None, with_kc = true, allow_outside_limits = false, gravity = None, recorded_gravity = false))]
    #[allow(clippy::too_many_arguments)] // a Python signature: its keywords and their defaults
    fn compensate<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArrayDyn<'py, f64>,
        wrench: Option<PyReadonlyArrayDyn<'py, f64>>,
        payload: Option<(f64, [f64; 3])>,
        match_orientation: Option<bool>,
        with_kc: bool,
        allow_outside_limits: bool,
        gravity: Option<[f64; 3]>,
        recorded_gravity: bool,
    ) -> PyResult<crate::use_model::CompensationArrays<'py>> {
        let gravity = crate::use_model::model_gravity(gravity, recorded_gravity)?;
        let n = self.chain.n_joints();
        let q = batch(&q, "q", &[n])?;
        let w = wrench
            .as_ref()
            .map(|w| batch(w, "wrench", &[6]))
            .transpose()?;
        let load = crate::use_model::load_of(&q, w.as_ref(), payload)?;
        crate::use_model::check_inputs(py, &self.chain, &q, load, allow_outside_limits)?;
        let opts = crate::use_model::ModelCompensation {
            match_orientation,
            with_kc,
            gravity,
        };
        crate::use_model::compensate_with_model(py, &self.model, &self.chain, &q.data, load, &opts)
    }

    /// Predictions for q (N, n) under wrench (N, 6) or a payload `(mass, cx, cy, cz)`.
    /// Returns a dict of arrays: deflection (N, 6), stddev (N, 6), wrench (N, 6),
    /// identified (N,), excitation (N,). The inputs get identify's checks (joint angles inside
    /// the URDF limits unless `allow_outside_limits`).
    #[pyo3(signature = (q, wrench = None, payload = None, allow_outside_limits = false, gravity = None))]
    fn predict<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArrayDyn<'py, f64>,
        wrench: Option<PyReadonlyArrayDyn<'py, f64>>,
        payload: Option<(f64, f64, f64, f64)>,
        allow_outside_limits: bool,
        gravity: Option<[f64; 3]>,
    ) -> PyResult<PyPredictionColumns> {
        let n = self.chain.n_joints();
        let q = batch(&q, "q", &[n])?;
        let w = wrench
            .as_ref()
            .map(|w| batch(w, "wrench", &[6]))
            .transpose()?;
        let payload = payload.map(|(mass, cx, cy, cz)| (mass, [cx, cy, cz]));
        let load = crate::use_model::load_of(&q, w.as_ref(), payload)?;
        crate::use_model::check_inputs(py, &self.chain, &q, load, allow_outside_limits)?;
        let (model, chain) = (&self.model, &self.chain);
        let gravity = gravity.map(vjm::gravity::Gravity::new).transpose().py()?;
        let pred = run(py, || {
            model.predict_columns(chain, &q.data, load, gravity.as_ref())
        })?
        .py()?;
        PyPredictionColumns::new(py, pred)
    }

    /// The tip's static sag under the arm's weight at q (N, n) under `gravity` (m/s², base
    /// frame), with an optional payload `(mass, cx, cy, cz)`: the same dict as `predict`
    /// (`wrench` zeros). The configurations get identify's checks.
    #[pyo3(signature = (q, gravity, payload = None, allow_outside_limits = false))]
    fn predict_sag<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArrayDyn<'py, f64>,
        gravity: [f64; 3],
        payload: Option<(f64, f64, f64, f64)>,
        allow_outside_limits: bool,
    ) -> PyResult<PyPredictionColumns> {
        let n = self.chain.n_joints();
        let q = batch(&q, "q", &[n])?;
        let g = vjm::gravity::Gravity::new(gravity).py()?;
        let payload = payload
            .map(|(mass, cx, cy, cz)| vjm::PointMass::new(mass, [cx, cy, cz]))
            .transpose()
            .py()?;
        crate::use_model::check_arrays(py, &self.chain, &q, None, allow_outside_limits)?;
        let (model, chain) = (&self.model, &self.chain);
        let pred = run(py, || {
            model.predict_sag_columns(chain, &q.data, &g, payload.as_ref())
        })?
        .py()?;
        PyPredictionColumns::new(py, pred)
    }

    fn __repr__(&self) -> String {
        let r = self.model.robot();
        format!(
            "StiffnessModel(model={:?}, rank={}/{}, base={:?}, tip={:?}, rotations={})",
            self.model.springs().model,
            self.model.identification().rank,
            self.model.identification().n_params,
            r.base,
            r.tip,
            self.model.has_rotations()
        )
    }
}

/// Identification that also returns the stiffness model: `(result, StiffnessModel)`, the result
/// as native Python values ([`crate::results::summary`]).
/// `data_file` is the measurement file the arrays came from (hashed into the model, or
/// `data_sha256` recorded when the reader hashed what it read);
/// `robust_covariance` gives the model the cluster-robust covariance (one more data pass).
#[pyfunction]
#[pyo3(signature = (robot, q, wrench, displacement, model, rotation = None, noise_sigma = None, noise_scale_known = false, nonnegative = false, dense = false, method = "auto", data_file = None, robust_covariance = false, allow_outside_limits = false, gravity = None, data_sha256 = None))]
#[allow(clippy::too_many_arguments)] // a Python signature: its keywords and their defaults
pub fn vjm_identify_model<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    q: PyReadonlyArrayDyn<'py, f64>,
    wrench: PyReadonlyArrayDyn<'py, f64>,
    displacement: PyReadonlyArrayDyn<'py, f64>,
    model: &Bound<'py, PyAny>,
    rotation: Option<PyReadonlyArrayDyn<'py, f64>>,
    noise_sigma: Option<PyReadonlyArrayDyn<'py, f64>>,
    noise_scale_known: bool,
    nonnegative: bool,
    dense: bool,
    method: &str,
    data_file: Option<String>,
    robust_covariance: bool,
    allow_outside_limits: bool,
    gravity: Option<[f64; 3]>,
    data_sha256: Option<String>,
) -> PyResult<(Bound<'py, PyAny>, PyStiffnessModel)> {
    let args = IdentifyArgs {
        q,
        wrench,
        displacement,
        rotation,
        noise_sigma,
        noise_scale_known,
        nonnegative,
        dense,
        method,
        allow_outside_limits,
        gravity,
    };
    let (id, built, warnings) = robot.identify_with(
        py,
        model,
        args,
        Some(data_file.as_deref().map(|path| crate::vjm::DataFile {
            path,
            sha256: data_sha256.as_deref(),
        })),
        robust_covariance,
    )?;
    let result = crate::results::summary(py, &id)?;
    // The warnings of vjm::screening (messages), which Robot.identify issues and keeps.
    result.set_item("warnings", warnings)?;
    let built = built.ok_or_else(|| crate::errors::internal_error("no model was built"))?;
    Ok((result, PyStiffnessModel::new(built, robot.chain.clone())))
}

/// Reads a pose table (q1..qn, optional fx..mz, optional pose) for `robot`:
/// `(q (N, n), wrench (N, 6) or None, pose ids (N,) int64 or None)`, each array moved from
/// the reader, not copied.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn vjm_read_poses<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    robot: &PyRobot,
) -> PyResult<(
    Bound<'py, PyArrayDyn<f64>>,
    Option<Bound<'py, PyArrayDyn<f64>>>,
    Option<Bound<'py, numpy::PyArray1<i64>>>,
)> {
    let n = robot.chain.n_joints();
    let table = run(py, || vjm::stiffness_model::PoseTable::read_csv(&path, n))?.py()?;
    let rows = table.len();
    let q = to_numpy(py, table.q, &[rows, n])?;
    let w = table
        .wrench
        .map(|w| to_numpy(py, w, &[rows, 6]))
        .transpose()?;
    let pose = table.pose.map(|ids| numpy::PyArray1::from_vec(py, ids));
    Ok((q, w, pose))
}

/// `(urdf, base, tip, found, tried)` of the model file at `path`: the recorded URDF path,
/// base and tip, the URDF file to load (`None` when none of the places tried holds it) and the
/// places tried in order (`vjm::stiffness_model::RecordedRobot`); `None` when the file has no
/// readable robot record. The file is read with the loader's bounds (size, nesting), so the
/// CLI never hands an unbounded text to Python's recursive `json`.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn vjm_model_file_robot(
    py: Python<'_>,
    path: std::path::PathBuf,
) -> PyResult<Option<(Option<String>, String, String, Option<String>, Vec<String>)>> {
    let recorded = run(py, || vjm::StiffnessModel::recorded_robot(&path))?;
    let shown = |p: std::path::PathBuf| p.to_string_lossy().into_owned();
    Ok(recorded.map(|r| {
        (
            r.record.urdf,
            r.record.base,
            r.record.tip,
            r.urdf.map(shown),
            r.tried.into_iter().map(shown).collect(),
        )
    }))
}

/// Registers the class and functions on `m`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyStiffnessModel>()?;
    m.add_function(wrap_pyfunction!(vjm_identify_model, m)?)?;
    m.add_function(wrap_pyfunction!(vjm_read_poses, m)?)?;
    m.add_function(wrap_pyfunction!(vjm_model_file_robot, m)?)?;
    Ok(())
}
