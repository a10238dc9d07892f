//! Bindings of `vjm::IdentificationPartial`: the identification statistics of one part of a
//! campaign, which merge (associatively) and finish into the identification of all parts.
//! They pickle (robot, model, options and the triangular factor), so parts can be computed on
//! Dask workers and merged anywhere.

use numpy::PyReadonlyArrayDyn;
use pyo3::prelude::*;
use vjm::Measurements;
use vjm::{IdentificationPartial, IdentifyOptions};

use crate::errors::{run, PyResultExt};
use crate::vjm::{parse_model, IdentifyArgs, IdentifyFailure, PyRobot};

/// Identification statistics of some measurements of one robot (immutable).
#[pyclass(
    frozen,
    module = "robot_stiffness._core",
    name = "IdentificationPartial"
)]
#[derive(Debug, Clone)]
pub struct PyIdentificationPartial {
    robot: PyRobot,
    inner: IdentificationPartial,
}

/// What a pickled partial carries besides the robot: model name and labels, `noise_sigma`,
/// `noise_scale_known`, `nonnegative`, `use_rotations`, R (row-major), equations, measurements.
type State = (
    String,
    Vec<String>,
    Vec<f64>,
    bool,
    bool,
    bool,
    Vec<f64>,
    usize,
    usize,
);

#[pymethods]
impl PyIdentificationPartial {
    /// The statistics of no measurement (the neutral element of `merge`).
    #[staticmethod]
    #[pyo3(signature = (robot, model, noise_sigma = None, noise_scale_known = false, nonnegative = false, rotations = false))]
    fn empty(
        robot: &PyRobot,
        model: &Bound<'_, PyAny>,
        noise_sigma: Option<PyReadonlyArrayDyn<'_, f64>>,
        noise_scale_known: bool,
        nonnegative: bool,
        rotations: bool,
    ) -> PyResult<Self> {
        let model = parse_model(robot.chain.n_joints(), model)?;
        let mut opts = IdentifyOptions::default();
        if let Some(s) = &noise_sigma {
            let s = crate::convert::fixed(s, "noise_sigma", &[6])?;
            opts.noise_sigma.copy_from_slice(&s);
        }
        opts.noise_scale_known = noise_scale_known;
        opts.nonnegative = nonnegative;
        opts.use_rotations = rotations;
        Ok(Self {
            robot: robot.clone(),
            inner: IdentificationPartial::empty(&robot.chain, &model, &opts).py()?,
        })
    }

    /// The statistics of `q`, `wrench`, `displacement` (and `rotation`), with the checks of
    /// `Robot.identify`.
    #[staticmethod]
    #[pyo3(signature = (robot, q, wrench, displacement, model, rotation = None, noise_sigma = None, noise_scale_known = false, nonnegative = false, allow_outside_limits = false))]
    #[allow(clippy::too_many_arguments)] // a Python signature: its keywords and their defaults
    fn accumulate<'py>(
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
        allow_outside_limits: bool,
    ) -> PyResult<Self> {
        let args = IdentifyArgs {
            q,
            wrench,
            displacement,
            rotation,
            noise_sigma,
            noise_scale_known,
            nonnegative,
            dense: false,
            method: "qr",
            allow_outside_limits,
            // The partial statistic is the weightless (linear) problem: vjm refuses gravity.
            gravity: None,
        };
        let c = robot.checked(model, &args)?;
        let chain = &robot.chain;
        let inner = run(py, || {
            c.check_measurements(chain, allow_outside_limits)
                .map_err(IdentifyFailure::Data)?;
            IdentificationPartial::accumulate(
                chain,
                &c.model,
                Measurements::new(&c.q.data, &c.w.data, &c.d.data)
                    .with_rotation(c.r.as_ref().map(|r| &*r.data)),
                &c.opts,
            )
            .map_err(IdentifyFailure::Core)
        })?
        .py()?;
        Ok(Self {
            robot: robot.clone(),
            inner,
        })
    }

    /// The statistics of both parts' measurements (disjoint parts of one campaign).
    fn merge(&self, other: &Self) -> PyResult<Self> {
        Ok(Self {
            robot: self.robot.clone(),
            inner: self.inner.merge(&other.inner).py()?,
        })
    }

    /// Solves: the identification (the core's result as Python values, as `vjm_identify_model`
    /// returns it) and its stiffness model.
    fn finish<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, crate::stiffness_model::PyStiffnessModel)> {
        let chain = &self.robot.chain;
        let inner = &self.inner;
        let id = run(py, || inner.finish(chain))?.py()?;
        let data = vjm::DataSource::in_memory(inner.measurements());
        let built = run(py, || {
            vjm::StiffnessModel::from_identification(
                &id,
                chain,
                inner.model(),
                inner.options(),
                data,
            )
        })?
        .py()?;
        Ok((
            crate::results::summary(py, &id)?,
            crate::stiffness_model::PyStiffnessModel::new(built, chain.clone()),
        ))
    }

    /// Number of measurements merged in.
    #[getter]
    fn n_measurements(&self) -> usize {
        self.inner.measurements()
    }

    /// Number of scalar equations (whitened rows) merged in.
    #[getter]
    fn n_equations(&self) -> usize {
        self.inner.factor().nrows()
    }

    /// Parameter labels of the model, e.g. ["J1z", ...].
    #[getter]
    fn labels(&self) -> Vec<String> {
        self.inner.model().labels()
    }

    /// The robot the statistics belong to.
    #[getter]
    fn robot(&self) -> PyRobot {
        self.robot.clone()
    }

    /// Pickle support (see [`State`]).
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (PyRobot, State))> {
        let restore = py
            .get_type::<PyIdentificationPartial>()
            .getattr("_from_pickle")?;
        let o = self.inner.options();
        let f = self.inner.factor();
        Ok((
            restore,
            (
                self.robot.clone(),
                (
                    self.inner.model().name().to_string(),
                    self.inner.model().labels(),
                    o.noise_sigma.to_vec(),
                    o.noise_scale_known,
                    o.nonnegative,
                    o.use_rotations,
                    f.r().to_vec(),
                    f.nrows(),
                    self.inner.measurements(),
                ),
            ),
        ))
    }

    /// Rebuilds a pickled partial (see `__reduce__`).
    #[staticmethod]
    fn _from_pickle(py: Python<'_>, robot: &PyRobot, state: State) -> PyResult<Self> {
        let robot = robot.clone();
        let (name, labels, sigma, scale_known, nonnegative, rotations, r, equations, measurements) =
            state;
        // The named models by name (the result reports it), any other by its labels.
        let spec = if name == "traditional" || name == "extended" {
            pyo3::types::PyString::new(py, &name).into_any()
        } else {
            pyo3::types::PyList::new(py, &labels)?.into_any()
        };
        let model = parse_model(robot.chain.n_joints(), &spec)?;
        if model.labels() != labels {
            return Err(crate::errors::value_error(format!(
                "pickled partial: model `{name}` has springs {:?}, the pickle lists {labels:?}",
                model.labels()
            )));
        }
        let mut opts = IdentifyOptions::default();
        if sigma.len() != 6 {
            return Err(crate::errors::shape_error(format!(
                "pickled partial: noise_sigma has {} values, expected 6",
                sigma.len()
            )));
        }
        opts.noise_sigma.copy_from_slice(&sigma);
        opts.noise_scale_known = scale_known;
        opts.nonnegative = nonnegative;
        opts.use_rotations = rotations;
        let inner = IdentificationPartial::from_parts(
            &robot.chain,
            &model,
            &opts,
            r,
            equations,
            measurements,
        )
        .py()?;
        Ok(Self { robot, inner })
    }

    fn __repr__(&self) -> String {
        format!(
            "IdentificationPartial(model={:?}, n_measurements={})",
            self.inner.model().name(),
            self.inner.measurements()
        )
    }
}

/// Registers the class on `m`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyIdentificationPartial>()
}
