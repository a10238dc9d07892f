//! Bindings of `vjm`: the robot (an immutable [`SerialChain`]), batched Jacobians, forward
//! kinematics, identification and prediction. Every batch runs in Rust with the GIL released.

use std::sync::Arc;
use vjm::Measurements;

use numpy::{PyArray3, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use pyo3::types::PyString;
use vjm::{IdentifyOptions, SerialChain, VirtualJointModel, Workspace};

use crate::convert::{batch, fixed, to_numpy};
use crate::errors::{run, value_error, PyResultExt};

/// What a pickled robot carries: URDF text, base link, tip link, and the path the text was
/// read from (recorded in saved models; never opened).
type RobotState = (String, String, String, Option<String>);

/// A serial chain between a base and a tip link (immutable; cheap to share).
#[pyclass(frozen, module = "robot_stiffness._core", name = "Robot")]
#[derive(Debug, Clone)]
pub struct PyRobot {
    pub(crate) chain: Arc<SerialChain>,
    /// The URDF text the chain was read from: what a pickle carries, so that the robot can be
    /// rebuilt where the file does not exist (a Dask worker on another machine).
    urdf: Arc<str>,
}

/// Parses a model spec: a string in the one model vocabulary ([`VirtualJointModel::parse`]:
/// `"traditional"`, `"extended"`, `"traditional + joint_tilt(J3x)"`, `"J1z,J2x"`), or a
/// sequence of spring labels such as `["J1z", "J2x"]` (1-based joint, axis z|x|y), listed
/// base → tip.
pub fn parse_model(n_joints: usize, spec: &Bound<'_, PyAny>) -> PyResult<VirtualJointModel> {
    if spec.is_instance_of::<PyString>() {
        let text: String = spec.extract()?;
        return VirtualJointModel::parse(n_joints, &text).py();
    }
    let labels: Vec<String> = spec.extract().map_err(|_| {
        value_error("model must be \"traditional\", \"extended\", a spec like \"traditional + joint_tilt(J3x)\" or a list of spring labels like [\"J1z\", \"J2x\"]")
    })?;
    let mut springs = Vec::with_capacity(labels.len());
    for (i, label) in labels.iter().enumerate() {
        springs.push(vjm::spring_label(label, n_joints).ok_or_else(|| {
            value_error(format!(
                "model[{i}] = `{label}` is not a spring label: expected J<joint><axis> with joint 1..{n_joints} and axis z, x or y (e.g. \"J3x\")"
            ))
        })?);
    }
    VirtualJointModel::from_springs(n_joints, springs).py()
}

impl PyRobot {
    fn n(&self) -> usize {
        self.chain.n_joints()
    }
}

#[pymethods]
impl PyRobot {
    /// The bundled Franka Emika Panda, `panda_link0` → `tip` (default the flange `panda_link8`).
    #[staticmethod]
    #[pyo3(signature = (tip = None))]
    fn bundled(tip: Option<&str>) -> PyResult<Self> {
        let chain = match tip {
            None => SerialChain::bundled(),
            Some(t) => SerialChain::bundled_with_tip(t).py()?,
        };
        Ok(Self {
            chain: Arc::new(chain),
            urdf: Arc::from(vjm::BUNDLED_URDF),
        })
    }

    /// The chain `base` → `tip` of a URDF file.
    #[staticmethod]
    fn from_urdf(
        py: Python<'_>,
        path: std::path::PathBuf,
        base: &str,
        tip: &str,
    ) -> PyResult<Self> {
        if !path.exists() {
            return Err(crate::errors::error(
                crate::errors::Kind::MissingFile,
                format!("URDF file `{}` does not exist", path.display()),
            ));
        }
        let (chain, xml) = run(py, || {
            SerialChain::from_urdf_file_with_text(&path, base, tip)
        })?
        .py()?;
        Ok(Self {
            chain: Arc::new(chain),
            urdf: Arc::from(xml),
        })
    }

    /// The chain `base` → `tip` of a URDF document given as a string.
    #[staticmethod]
    fn from_urdf_string(xml: &str, base: &str, tip: &str) -> PyResult<Self> {
        Ok(Self {
            chain: Arc::new(SerialChain::from_urdf_str(xml, base, tip).py()?),
            urdf: Arc::from(xml),
        })
    }

    /// Pickle support: the URDF text, base, tip and the path the text was read from (recorded,
    /// never opened), so that unpickling needs no file.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, RobotState)> {
        let restore = py.get_type::<PyRobot>().getattr("_from_pickle")?;
        let path = self.chain.urdf_source().and_then(|s| s.path.clone());
        Ok((
            restore,
            (
                self.urdf.to_string(),
                self.chain.base_link().to_string(),
                self.chain.tip_link().to_string(),
                path,
            ),
        ))
    }

    /// Rebuilds a pickled robot (see `__reduce__`).
    #[staticmethod]
    #[pyo3(signature = (xml, base, tip, path = None))]
    fn _from_pickle(xml: &str, base: &str, tip: &str, path: Option<&str>) -> PyResult<Self> {
        let chain = match path {
            Some(p) => SerialChain::from_urdf_str_read_from(xml, p, base, tip),
            None => SerialChain::from_urdf_str(xml, base, tip),
        }
        .py()?;
        Ok(Self {
            chain: Arc::new(chain),
            urdf: Arc::from(xml),
        })
    }

    /// Number of actuated joints n.
    #[getter]
    fn n_joints(&self) -> usize {
        self.n()
    }

    /// Names of the actuated joints, base → tip.
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.chain.joint_names().to_vec()
    }

    /// Joint limits (lower, upper) in rad, base → tip.
    #[getter]
    fn limits(&self) -> Vec<(f64, f64)> {
        self.chain.limits().to_vec()
    }

    /// Base link name.
    #[getter]
    fn base_link(&self) -> String {
        self.chain.base_link().to_string()
    }

    /// Tip link name.
    #[getter]
    fn tip_link(&self) -> String {
        self.chain.tip_link().to_string()
    }

    /// Parameter labels of a model spec, e.g. ["J1z", "J2z", ...].
    fn model_labels(&self, model: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
        Ok(parse_model(self.n(), model)?.labels())
    }

    /// Tip poses (N, 4, 4), homogeneous, tip frame in base frame.
    fn forward_kinematics<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArrayDyn<'py, f64>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let n = self.n();
        let q = batch(&q, "q", &[n])?;
        let chain = &self.chain;
        let out = run(py, || -> Result<Vec<f64>, vjm::VjmError> {
            let mut out = Vec::with_capacity(16 * q.rows);
            for qi in q.data.chunks_exact(n) {
                let t = chain.forward_kinematics(qi)?.to_homogeneous();
                for r in 0..4 {
                    for c in 0..4 {
                        out.push(t[(r, c)]);
                    }
                }
            }
            Ok(out)
        })?
        .py()?;
        to_numpy(py, out, &[q.rows, 4, 4])
    }

    /// Virtual-joint Jacobians (N, 6, m): tip point, base frame, rows [linear; angular].
    ///
    /// Written by the core straight into the returned C-ordered array, with the GIL released.
    fn jacobian<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArrayDyn<'py, f64>,
        model: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let n = self.n();
        let model = parse_model(n, model)?;
        let q = batch(&q, "q", &[n])?;
        jacobian_into_numpy(py, &self.chain, &model, &q.data, q.rows)
    }

    /// Predicted tip deflections (N, 6) `[dx, dy, dz, rx, ry, rz]` (m, rad; base frame).
    ///
    /// The poses and wrenches get identify's plausibility checks (angles inside the URDF limits
    /// unless `allow_outside_limits`, magnitudes), as `StiffnessModel.predict` does.
    #[pyo3(signature = (compliance, q, wrench, model, with_kc = false, allow_outside_limits = false))]
    #[allow(clippy::too_many_arguments)] // a Python signature: its keywords and their defaults
    fn predict_deflection<'py>(
        &self,
        py: Python<'py>,
        compliance: PyReadonlyArrayDyn<'py, f64>,
        q: PyReadonlyArrayDyn<'py, f64>,
        wrench: PyReadonlyArrayDyn<'py, f64>,
        model: &Bound<'py, PyAny>,
        with_kc: bool,
        allow_outside_limits: bool,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let n = self.n();
        let model = parse_model(n, model)?;
        let c = fixed(&compliance, "compliance", &[model.n_params()])?;
        let q = batch(&q, "q", &[n])?;
        let w = batch(&wrench, "wrench", &[6])?;
        check_rows(q.rows, &[("wrench", w.rows)])?;
        let chain = &self.chain;
        crate::use_model::check_inputs(
            py,
            chain,
            &q,
            vjm::Load::Wrench(&w.data),
            allow_outside_limits,
        )?;
        let out = run(py, || -> Result<Vec<f64>, vjm::VjmError> {
            let mut out = Vec::with_capacity(6 * q.rows);
            for (qi, wi) in q.data.chunks_exact(n).zip(w.data.chunks_exact(6)) {
                let mut f = [0.0; 6];
                f.copy_from_slice(wi);
                out.extend_from_slice(&vjm::predict_deflection(
                    chain, &model, &c, qi, &f, with_kc,
                )?);
            }
            Ok(out)
        })?
        .py()?;
        to_numpy(py, out, &[q.rows, 6])
    }

    fn __repr__(&self) -> String {
        format!(
            "Robot(base={:?}, tip={:?}, n_joints={})",
            self.chain.base_link(),
            self.chain.tip_link(),
            self.n()
        )
    }
}

/// The arguments of [`PyRobot::identify`] (shared with the model-building identification).
#[derive(Debug)]
pub(crate) struct IdentifyArgs<'py, 'a> {
    pub q: PyReadonlyArrayDyn<'py, f64>,
    pub wrench: PyReadonlyArrayDyn<'py, f64>,
    pub displacement: PyReadonlyArrayDyn<'py, f64>,
    pub rotation: Option<PyReadonlyArrayDyn<'py, f64>>,
    pub noise_sigma: Option<PyReadonlyArrayDyn<'py, f64>>,
    pub noise_scale_known: bool,
    pub nonnegative: bool,
    pub dense: bool,
    pub method: &'a str,
    /// Skip the check of the joint angles against the URDF limits.
    pub allow_outside_limits: bool,
    /// The gravity the measurements were taken under (m/s², base frame), `None` weightless.
    pub gravity: Option<[f64; 3]>,
}

/// The measurement file an identification's arrays were read from: its path and, when the
/// reader hashed the bytes it read, their SHA-256 (else the file is hashed now).
#[derive(Debug, Clone, Copy)]
pub(crate) struct DataFile<'a> {
    pub path: &'a str,
    pub sha256: Option<&'a str>,
}

impl PyRobot {
    /// Identification; with `model_data` also the [`vjm::StiffnessModel`], built in the same
    /// call so that it cannot drift from the result. `model_data = Some(Some(path))` records the
    /// measurement file the arrays came from. `robust`: the model carries the cluster-robust
    /// covariance (one more pass over the data, about 10 µs per measurement) instead of the
    /// identification's own. With `model_data`, also the warnings of `vjm::screening::review`
    /// (outlier rows, implausible or negative compliances) as messages.
    pub(crate) fn identify_with<'py>(
        &self,
        py: Python<'py>,
        model: &Bound<'py, PyAny>,
        a: IdentifyArgs<'py, '_>,
        model_data: Option<Option<DataFile<'_>>>,
        robust: bool,
    ) -> PyResult<(
        vjm::Identification,
        Option<vjm::StiffnessModel>,
        Vec<String>,
    )> {
        let c = self.checked(model, &a)?;
        let chain = &self.chain;
        let rot = c.r.as_ref().map(|r| &*r.data);
        let (model, q, w, d, opts) = (&c.model, &c.q, &c.w, &c.d, &c.opts);
        let dense = a.dense;
        let id = run(py, || {
            if dense {
                c.check_measurements(chain, a.allow_outside_limits)
                    .map_err(IdentifyFailure::Data)?;
                return vjm::identify_dense(
                    chain,
                    model,
                    Measurements::new(&q.data, &w.data, &d.data).with_rotation(rot),
                    opts,
                )
                .map_err(IdentifyFailure::Core);
            }
            c.identify_checked(chain, a.allow_outside_limits)
        })?
        .py()?;
        let Some(file) = model_data else {
            return Ok((id, None, Vec::new()));
        };
        let data = match file {
            Some(DataFile {
                path,
                sha256: Some(sha256),
            }) => vjm::DataSource::file_with_sha256(path, q.rows, sha256.to_string()).py()?,
            Some(DataFile { path, sha256: None }) => {
                run(py, || vjm::DataSource::file(path, q.rows))?.py()?
            }
            None => vjm::DataSource::in_memory(q.rows),
        };
        let (built, warnings) = run(py, || {
            let m = vjm::StiffnessModel::from_identification(&id, chain, model, opts, data)?;
            let warnings: Vec<String> = vjm::screening::review(&id, &w.data, &d.data)
                .iter()
                .map(ToString::to_string)
                .collect();
            let m = if robust {
                m.with_robust_covariance(
                    chain,
                    Measurements::new(&q.data, &w.data, &d.data).with_rotation(rot),
                )?
            } else {
                m
            };
            Ok::<_, vjm::ModelError>((m, warnings))
        })?
        .py()?;
        Ok((id, Some(built), warnings))
    }

    /// The inputs of an identification with their shapes, row counts and options checked
    /// (shared by `identify` and `identify_partial`); the values are checked by
    /// [`Checked::check_measurements`], with the GIL released.
    pub(crate) fn checked<'a>(
        &self,
        model: &Bound<'_, PyAny>,
        a: &'a IdentifyArgs<'_, '_>,
    ) -> PyResult<Checked<'a>> {
        let method = match a.method {
            "auto" => vjm::SolveMethod::Auto,
            "normal_equations" => vjm::SolveMethod::NormalEquations,
            "qr" => vjm::SolveMethod::Qr,
            other => {
                return Err(value_error(format!(
                    "method must be 'auto', 'normal_equations' or 'qr', got {other:?}"
                )))
            }
        };
        let n = self.n();
        let model = parse_model(n, model)?;
        let q = batch(&a.q, "q", &[n])?;
        let w = batch(&a.wrench, "wrench", &[6])?;
        let d = batch(&a.displacement, "displacement", &[3])?;
        let r = match &a.rotation {
            Some(r) => Some(batch(r, "rotation", &[3])?),
            None => None,
        };
        check_rows(q.rows, &[("wrench", w.rows), ("displacement", d.rows)])?;
        if let Some(r) = &r {
            check_rows(q.rows, &[("rotation", r.rows)])?;
        }
        let mut opts = IdentifyOptions::default();
        if let Some(s) = &a.noise_sigma {
            let s = fixed(s, "noise_sigma", &[6])?;
            opts.noise_sigma.copy_from_slice(&s);
        }
        opts.noise_scale_known = a.noise_scale_known;
        opts.nonnegative = a.nonnegative;
        opts.use_rotations = r.is_some();
        opts.method = method;
        opts.gravity = a.gravity.map(vjm::gravity::Gravity::new).transpose().py()?;
        Ok(Checked {
            model,
            q,
            w,
            d,
            r,
            opts,
        })
    }
}

/// A failure of the checks of the measurements or of the identification itself.
#[derive(Debug)]
pub(crate) enum IdentifyFailure {
    /// The measurements fail the checks of a measurement file.
    Data(vjm::dataset::DatasetError),
    /// The identification failed.
    Core(vjm::VjmError),
}

impl crate::errors::IntoPyErr for IdentifyFailure {
    fn into_py_err(self) -> PyErr {
        match self {
            IdentifyFailure::Data(e) => e.into_py_err(),
            IdentifyFailure::Core(e) => e.into_py_err(),
        }
    }
}

impl Checked<'_> {
    /// `vjm::identify` with the checks of [`check_measurements`](Self::check_measurements)
    /// fused into its pass over the data (each chunk of rows is checked just before it is
    /// read, so the data are read from memory once). The errors are the same as checking
    /// first: a data error wins over an identification error.
    pub(crate) fn identify_checked(
        &self,
        chain: &SerialChain,
        allow_outside_limits: bool,
    ) -> Result<vjm::Identification, IdentifyFailure> {
        use vjm::dataset::ArrayChecks;
        let rot = self.r.as_ref().map(|r| &*r.data);
        let (q, w, d) = (&*self.q.data, &*self.w.data, &*self.d.data);
        let checks = ArrayChecks::new(
            chain.n_joints(),
            Measurements::new(q, w, d).with_rotation(rot),
            (!allow_outside_limits).then_some(chain),
        );
        let rows_ok = |start: usize, end: usize| checks.rows_ok(start, end);
        let fused = vjm::identify_checking_rows(
            chain,
            &self.model,
            Measurements::new(q, w, d).with_rotation(rot),
            &self.opts,
            &rows_ok,
        );
        match fused {
            Ok(Some(id)) => {
                checks.information().map_err(IdentifyFailure::Data)?;
                Ok(id)
            }
            // A row failed: its error, or (a non-finite value) identify's own.
            Ok(None) => {
                checks.report().map_err(IdentifyFailure::Data)?;
                vjm::identify(
                    chain,
                    &self.model,
                    Measurements::new(q, w, d).with_rotation(rot),
                    &self.opts,
                )
                .map_err(IdentifyFailure::Core)
            }
            Err(e) => {
                self.check_measurements(chain, allow_outside_limits)
                    .map_err(IdentifyFailure::Data)?;
                Err(IdentifyFailure::Core(e))
            }
        }
    }

    /// The same checks as a measurement file (units, magnitudes, information, joint limits):
    /// the Python API must not accept what the command line refuses. A non-finite value is
    /// left to identify's own check, which names the array, its row and column. Pure Rust:
    /// callers run it with the GIL released.
    pub(crate) fn check_measurements(
        &self,
        chain: &SerialChain,
        allow_outside_limits: bool,
    ) -> Result<(), vjm::dataset::DatasetError> {
        vjm::dataset::check_arrays(
            chain.n_joints(),
            Measurements::new(&self.q.data, &self.w.data, &self.d.data)
                .with_rotation(self.r.as_ref().map(|r| &*r.data)),
            (!allow_outside_limits).then_some(chain),
        )
        .map(|_| ())
    }
}

/// Inputs of an identification after [`PyRobot::checked`]: row-major, borrowed when the
/// arrays were C-contiguous.
pub(crate) struct Checked<'a> {
    pub model: VirtualJointModel,
    pub q: crate::convert::Rows<'a>,
    pub w: crate::convert::Rows<'a>,
    pub d: crate::convert::Rows<'a>,
    pub r: Option<crate::convert::Rows<'a>>,
    pub opts: IdentifyOptions,
}

/// Benchmark helper (private): runs the core's streaming `vjm::identify` `repeats` times on the
/// given arrays, timed inside Rust with the GIL released, and returns the seconds of each run.
/// `scripts/overhead.py` compares these with the wall time of the Python call.
#[pyfunction]
#[pyo3(signature = (robot, q, wrench, displacement, model, repeats = 1))]
pub fn vjm_identify_timed<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    q: PyReadonlyArrayDyn<'py, f64>,
    wrench: PyReadonlyArrayDyn<'py, f64>,
    displacement: PyReadonlyArrayDyn<'py, f64>,
    model: &Bound<'py, PyAny>,
    repeats: usize,
) -> PyResult<Vec<f64>> {
    let n = robot.n();
    let model = parse_model(n, model)?;
    let q = batch(&q, "q", &[n])?;
    let w = batch(&wrench, "wrench", &[6])?;
    let d = batch(&displacement, "displacement", &[3])?;
    let chain = &robot.chain;
    let opts = IdentifyOptions::default();
    run(py, || -> Result<Vec<f64>, vjm::VjmError> {
        let mut times = Vec::with_capacity(repeats);
        for _ in 0..repeats {
            let start = std::time::Instant::now();
            let id = vjm::identify(
                chain,
                &model,
                Measurements::new(&q.data, &w.data, &d.data),
                &opts,
            )?;
            times.push(start.elapsed().as_secs_f64());
            std::hint::black_box(id);
        }
        Ok(times)
    })?
    .py()
}

/// The Jacobians of the `rows` configurations `q` (row-major N×n) as a new C-ordered numpy
/// array (N, 6, m), filled by the core in place with the GIL released: no intermediate buffer.
fn jacobian_into_numpy<'py>(
    py: Python<'py>,
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    rows: usize,
) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let m = model.n_params();
    let out = PyArray3::<f64>::zeros(py, [rows, 6, m], false);
    {
        let mut guard = out.readwrite();
        let slice = guard.as_slice_mut().map_err(|e| {
            crate::errors::internal_error(format!("new Jacobian array is not contiguous: {e}"))
        })?;
        run(py, || -> Result<(), vjm::VjmError> {
            let mut ws = Workspace::new(chain, model)?;
            vjm::jacobian_batch_with_layout(
                chain,
                model,
                q,
                &mut ws,
                slice,
                vjm::JacobianLayout::RowMajor,
            )
        })?
        .py()?;
    }
    Ok(out)
}

/// Benchmark helper (private): runs the core's batched `vjm::jacobian_batch_in_place` on `q`
/// `repeats` times, timed inside Rust with the GIL released, and returns the seconds of each
/// run. Each run allocates and fills its own N·6·m output, as a Rust caller asking for N
/// Jacobians would; `benches/bindings_overhead.py` compares these with `Robot.jacobian`.
#[pyfunction]
#[pyo3(signature = (robot, q, model, repeats = 1))]
pub fn vjm_jacobian_timed<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    q: PyReadonlyArrayDyn<'py, f64>,
    model: &Bound<'py, PyAny>,
    repeats: usize,
) -> PyResult<Vec<f64>> {
    let n = robot.n();
    let model = parse_model(n, model)?;
    let q = batch(&q, "q", &[n])?;
    let chain = &robot.chain;
    run(py, || -> Result<Vec<f64>, vjm::VjmError> {
        let mut ws = Workspace::new(chain, &model)?;
        let mut times = Vec::with_capacity(repeats);
        for _ in 0..repeats {
            let start = std::time::Instant::now();
            let mut out = vec![0.0; q.rows * 6 * model.n_params()];
            vjm::jacobian_batch_in_place(chain, &model, &q.data, &mut ws, &mut out)?;
            times.push(start.elapsed().as_secs_f64());
            std::hint::black_box(out);
        }
        Ok(times)
    })?
    .py()
}

/// All arrays must have as many rows as `q`.
fn check_rows(n: usize, others: &[(&str, usize)]) -> PyResult<()> {
    for (name, rows) in others {
        if *rows != n {
            return Err(crate::errors::shape_error(format!(
                "{name} has {rows} rows (dimension 0) but q has {n}: one row per measurement"
            )));
        }
    }
    Ok(())
}

/// Registers the class on `m`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyRobot>()?;
    m.add_function(wrap_pyfunction!(vjm_identify_timed, m)?)?;
    m.add_function(wrap_pyfunction!(vjm_jacobian_timed, m)?)?;
    Ok(())
}
