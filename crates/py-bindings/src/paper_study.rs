//! The seed study's result as typed classes (`_core.vjm_paper_study`): the models' errors, the
//! 26 tests as columns, the clipped angles and the seed's own figures.

use numpy::PyArray1;
use pyo3::prelude::*;
use vjm::testbed::{ErrorSummary, ModelErrors, PaperStudy};

use crate::convert::{numpy_field, to_numpy_bool};

/// One error metric of one model over the 26 tests (fractions).
#[derive(Debug)]
#[pyclass(
    module = "robot_stiffness._core",
    name = "PaperErrors",
    frozen,
    get_all
)]
pub struct PyPaperErrors {
    /// Mean over the 16 identification tests.
    pub identification: f64,
    /// Mean over the 10 verification tests.
    pub verification: f64,
    /// Mean over all 26.
    pub all: f64,
    /// Largest verification error.
    pub verification_max: f64,
    /// Its test (1–26).
    pub verification_max_test: usize,
}

/// Both metrics of one model.
#[derive(Debug)]
#[pyclass(
    module = "robot_stiffness._core",
    name = "PaperModelErrors",
    frozen,
    get_all
)]
pub struct PyPaperModelErrors {
    /// |‖d_pred‖ − ‖d‖| / ‖d‖.
    pub magnitude: Py<PyPaperErrors>,
    /// ‖d_pred − d‖ / ‖d‖.
    pub vector: Py<PyPaperErrors>,
}

/// The 26 tests as columns: ids and flags (26,), vectors (26, 3) m, errors (26,).
#[derive(Debug)]
#[pyclass(
    module = "robot_stiffness._core",
    name = "PaperStudyRows",
    frozen,
    get_all
)]
pub struct PyPaperStudyRows {
    /// Test number 1–26.
    pub test: Py<PyAny>,
    /// Configuration 1–13.
    pub configuration: Py<PyAny>,
    /// Load 1–2.
    pub load: Py<PyAny>,
    /// Used for the identification.
    pub identification: Py<PyAny>,
    /// Measured displacement.
    pub measured: Py<PyAny>,
    /// The traditional model's prediction.
    pub traditional: Py<PyAny>,
    /// The extended model's prediction.
    pub extended: Py<PyAny>,
    /// The full model's prediction.
    pub full: Py<PyAny>,
    /// Errors of each model under each metric.
    pub traditional_magnitude_error: Py<PyAny>,
    /// See `traditional_magnitude_error`.
    pub traditional_vector_error: Py<PyAny>,
    /// See `traditional_magnitude_error`.
    pub extended_magnitude_error: Py<PyAny>,
    /// See `traditional_magnitude_error`.
    pub extended_vector_error: Py<PyAny>,
    /// See `traditional_magnitude_error`.
    pub full_magnitude_error: Py<PyAny>,
    /// See `traditional_magnitude_error`.
    pub full_vector_error: Py<PyAny>,
}

/// A Table I angle moved inside the joint limits (1-based configuration and joint, rad).
#[derive(Debug)]
#[pyclass(
    module = "robot_stiffness._core",
    name = "PaperClippedAngle",
    frozen,
    get_all
)]
pub struct PyPaperClippedAngle {
    /// Configuration 1–13.
    pub configuration: usize,
    /// Joint 1–7.
    pub joint: usize,
    /// The table's angle.
    pub table: f64,
    /// The angle used.
    pub used: f64,
}

/// The seed's own figures (fractions, magnitude metric).
#[derive(Debug)]
#[pyclass(
    module = "robot_stiffness._core",
    name = "PaperFigures",
    frozen,
    get_all
)]
pub struct PyPaperFigures {
    /// Traditional model, all 26 tests.
    pub traditional_all: f64,
    /// Extended model, all 26 tests.
    pub extended_all: f64,
    /// Extended model, largest verification error.
    pub extended_verification_max: f64,
    /// Its test.
    pub extended_verification_max_test: usize,
    /// Traditional model, largest verification error.
    pub traditional_verification_max: f64,
    /// The torsion share the seed states.
    pub torsion_share: f64,
}

/// The seed study (see `vjm.paper_study`).
#[derive(Debug)]
#[pyclass(module = "robot_stiffness._core", name = "PaperStudy", frozen, get_all)]
pub struct PyPaperStudy {
    /// The traditional model's errors.
    pub traditional: Py<PyPaperModelErrors>,
    /// The extended model's errors.
    pub extended: Py<PyPaperModelErrors>,
    /// The full model's errors.
    pub full: Py<PyPaperModelErrors>,
    /// The 26 tests.
    pub rows: Py<PyPaperStudyRows>,
    /// Rank of the extended model's identification.
    pub extended_rank: usize,
    /// Rank of the full model's identification.
    pub full_rank: usize,
    /// The truth's torsion share.
    pub torsion_share: f64,
    /// The truth's link share.
    pub link_share: f64,
    /// The truth's tilt ratio.
    pub tilt_ratio: f64,
    /// The longest link's bending compliance, m/N (0 without links).
    pub link_scale: f64,
    /// Angles moved inside the limits.
    pub clipped: Vec<Py<PyPaperClippedAngle>>,
    /// The seed's figures.
    pub paper: Py<PyPaperFigures>,
}

fn errors(py: Python<'_>, e: &ErrorSummary) -> PyResult<Py<PyPaperErrors>> {
    Py::new(
        py,
        PyPaperErrors {
            identification: e.identification,
            verification: e.verification,
            all: e.all,
            verification_max: e.verification_max,
            verification_max_test: e.verification_max_test,
        },
    )
}

fn model_errors(py: Python<'_>, m: &ModelErrors) -> PyResult<Py<PyPaperModelErrors>> {
    Py::new(
        py,
        PyPaperModelErrors {
            magnitude: errors(py, &m.magnitude)?,
            vector: errors(py, &m.vector)?,
        },
    )
}

fn rows(py: Python<'_>, study: &PaperStudy) -> PyResult<Py<PyPaperStudyRows>> {
    let r = &study.rows;
    let n = r.len();
    let ids = |f: fn(&vjm::testbed::PaperStudyRow) -> usize| -> Py<PyAny> {
        PyArray1::from_vec(py, r.iter().map(|x| f(x) as i64).collect())
            .into_any()
            .unbind()
    };
    let vectors = |f: fn(&vjm::testbed::PaperStudyRow) -> [f64; 3]| {
        numpy_field(py, r.iter().flat_map(f).collect(), &[n, 3])
    };
    let errors = |f: fn(&vjm::testbed::PaperStudyRow) -> f64| {
        numpy_field(py, r.iter().map(f).collect(), &[n])
    };
    Py::new(
        py,
        PyPaperStudyRows {
            test: ids(|x| x.test),
            configuration: ids(|x| x.configuration),
            load: ids(|x| x.load),
            identification: to_numpy_bool(py, r.iter().map(|x| x.identification).collect(), &[n])?
                .into_any()
                .unbind(),
            measured: vectors(|x| x.measured)?,
            traditional: vectors(|x| x.traditional)?,
            extended: vectors(|x| x.extended)?,
            full: vectors(|x| x.full)?,
            traditional_magnitude_error: errors(|x| x.traditional_magnitude_error)?,
            traditional_vector_error: errors(|x| x.traditional_vector_error)?,
            extended_magnitude_error: errors(|x| x.extended_magnitude_error)?,
            extended_vector_error: errors(|x| x.extended_vector_error)?,
            full_magnitude_error: errors(|x| x.full_magnitude_error)?,
            full_vector_error: errors(|x| x.full_vector_error)?,
        },
    )
}

/// The typed study, with the truth's tilt ratio and link scale.
pub fn paper_study(
    py: Python<'_>,
    study: &PaperStudy,
    tilt_ratio: f64,
    link_scale: f64,
) -> PyResult<Py<PyPaperStudy>> {
    let clipped = study
        .clipped
        .iter()
        .map(|c| {
            Py::new(
                py,
                PyPaperClippedAngle {
                    configuration: c.configuration,
                    joint: c.joint,
                    table: c.table,
                    used: c.used,
                },
            )
        })
        .collect::<PyResult<Vec<_>>>()?;
    let p = &study.paper;
    Py::new(
        py,
        PyPaperStudy {
            traditional: model_errors(py, &study.traditional)?,
            extended: model_errors(py, &study.extended)?,
            full: model_errors(py, &study.full)?,
            rows: rows(py, study)?,
            extended_rank: study.extended_rank,
            full_rank: study.full_rank,
            torsion_share: study.torsion_share,
            link_share: study.link_share,
            tilt_ratio,
            link_scale,
            clipped,
            paper: Py::new(
                py,
                PyPaperFigures {
                    traditional_all: p.traditional_all,
                    extended_all: p.extended_all,
                    extended_verification_max: p.extended_verification_max,
                    extended_verification_max_test: p.extended_verification_max_test,
                    traditional_verification_max: p.traditional_verification_max,
                    torsion_share: p.torsion_share,
                },
            )?,
        },
    )
}

/// Registers the classes on `m`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyPaperErrors>()?;
    m.add_class::<PyPaperModelErrors>()?;
    m.add_class::<PyPaperStudyRows>()?;
    m.add_class::<PyPaperClippedAngle>()?;
    m.add_class::<PyPaperFigures>()?;
    m.add_class::<PyPaperStudy>()?;
    Ok(())
}
