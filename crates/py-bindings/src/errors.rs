//! The one place where Rust errors become Python exceptions.
//!
//! The exception classes are defined in Python (`robot_stiffness/_errors.py`) so that they can
//! derive from both `StiffnessError` and the natural built-in (`ValueError`, `FileNotFoundError`);
//! this module looks them up by name. Every heavy call runs through [`run`], which releases the
//! GIL and turns a panic of the core into `InternalError`, so a panic never reaches Python.
//! Advice in a core message is given in the Python API's words (`allow_outside_limits=True`,
//! `gravity=None`), never as a command-line flag.

use std::panic::{catch_unwind, AssertUnwindSafe};

use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyType;

/// The Python exception classes of `robot_stiffness._errors`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Wrong number of dimensions or size (`ShapeError`, a `ValueError`).
    Shape,
    /// Bad value: NaN, not a rotation, unknown option (`InvalidValueError`, a `ValueError`).
    Value,
    /// Unusable measurement file (`DataFileError`, a `ValueError`).
    DataFile,
    /// Missing or unreadable file (`MissingFileError`, a `FileNotFoundError`).
    MissingFile,
    /// Unusable robot description (`RobotModelError`, a `ValueError`).
    RobotModel,
    /// Identification impossible (`IdentificationError`, a `ValueError`).
    Identification,
    /// A caught panic or an inconsistent result (`InternalError`, a `RuntimeError`).
    Internal,
    /// An iteration cap was hit (`ConvergenceError`, a `RuntimeError`).
    Convergence,
    /// Cancelled with no Python exception to re-raise (`CancelledError`, a `RuntimeError`).
    Cancelled,
    /// Unusable stiffness model file: edited, stale schema, another robot (`ModelFileError`,
    /// a `ValueError`).
    ModelFile,
}

impl Kind {
    fn class_name(self) -> &'static str {
        match self {
            Kind::Shape => "ShapeError",
            Kind::Value => "InvalidValueError",
            Kind::DataFile => "DataFileError",
            Kind::MissingFile => "MissingFileError",
            Kind::RobotModel => "RobotModelError",
            Kind::Identification => "IdentificationError",
            Kind::Internal => "InternalError",
            Kind::Convergence => "ConvergenceError",
            Kind::Cancelled => "CancelledError",
            Kind::ModelFile => "ModelFileError",
        }
    }
}

/// Advice of the core that names a command-line flag or no option at all (the core serves both
/// front ends), as the Python API spells it. The command line words these back into its flags
/// (`CLI_NAMES` in `robot_stiffness/cli.py`).
const PYTHON_WORDS: &[(&str, &str)] = &[
    (
        "pass allow_outside_limits=True in Python or --allow-outside-limits on the command line",
        "pass allow_outside_limits=True",
    ),
    (
        "identify again with --save",
        "identify again and save the model (Identification.save)",
    ),
    (
        "or turn gravity off",
        "or pass gravity=None for a weightless arm",
    ),
];

/// `message` in the Python API's terms (see [`PYTHON_WORDS`]).
fn python_words(message: String) -> String {
    let mut message = message;
    for (core, python) in PYTHON_WORDS {
        if message.contains(core) {
            message = message.replace(core, python);
        }
    }
    message
}

/// A Python exception of the given kind carrying `message` (in the Python API's terms).
pub fn error(kind: Kind, message: impl Into<String>) -> PyErr {
    let message = python_words(message.into());
    Python::attach(|py| {
        let class = py
            .import("robot_stiffness._errors")
            .and_then(|m| m.getattr(kind.class_name()))
            .and_then(|c| c.cast_into::<PyType>().map_err(PyErr::from));
        match class {
            Ok(class) => PyErr::from_type(class, message),
            // `_core` imported on its own (not through the package): fall back to built-ins.
            Err(_) => match kind {
                Kind::MissingFile => PyFileNotFoundError::new_err(message),
                Kind::Internal | Kind::Convergence | Kind::Cancelled => {
                    PyRuntimeError::new_err(message)
                }
                _ => PyValueError::new_err(message),
            },
        }
    })
}

/// `ShapeError` with `message`.
pub fn shape_error(message: impl Into<String>) -> PyErr {
    error(Kind::Shape, message)
}

/// `InvalidValueError` with `message`.
pub fn value_error(message: impl Into<String>) -> PyErr {
    error(Kind::Value, message)
}

/// `InternalError` with `message`.
pub fn internal_error(message: impl Into<String>) -> PyErr {
    error(Kind::Internal, message)
}

/// Runs `f` with the GIL released, turning a panic into `InternalError`.
pub fn run<T, F>(py: Python<'_>, f: F) -> PyResult<T>
where
    F: FnOnce() -> T + Send,
    T: Send,
{
    py.detach(|| catch_unwind(AssertUnwindSafe(f)))
        .map_err(panic_error)
}

/// `InternalError` for a caught panic `payload` of the core.
pub fn panic_error(payload: Box<dyn std::any::Any + Send>) -> PyErr {
    let what = payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".to_string());
    internal_error(format!(
        "internal error in the Rust core (please report it with the inputs): {what}"
    ))
}

/// Test hook (private): panics inside [`run`], so the test suite can check that a panic of the
/// core surfaces as `InternalError` and never as pyo3's `PanicException`.
#[pyfunction]
pub fn _panic_for_tests(py: Python<'_>) -> PyResult<()> {
    run(py, || -> () {
        panic!("deliberate panic raised by the test suite")
    })
}

/// Conversion of a core crate's error into the matching Python exception.
pub trait IntoPyErr {
    /// The Python exception for this error.
    fn into_py_err(self) -> PyErr;
}

/// `result.py()?` converts a core error into its Python exception.
pub trait PyResultExt<T> {
    /// Maps the error with [`IntoPyErr`].
    fn py(self) -> PyResult<T>;
}

impl<T, E: IntoPyErr> PyResultExt<T> for Result<T, E> {
    fn py(self) -> PyResult<T> {
        self.map_err(IntoPyErr::into_py_err)
    }
}

impl IntoPyErr for so3_stiffness::So3Error {
    fn into_py_err(self) -> PyErr {
        value_error(self.to_string())
    }
}

impl IntoPyErr for vjm::VjmError {
    fn into_py_err(self) -> PyErr {
        use vjm::VjmError as E;
        let kind = match &self {
            E::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
                Kind::MissingFile
            }
            E::Io { .. } => Kind::MissingFile,
            E::Urdf { .. }
            | E::UrdfLimit { .. }
            | E::MissingLink { .. }
            | E::NotAncestor { .. }
            | E::ClosedChain { .. }
            | E::MimicJoint { .. }
            | E::UnsupportedJoint { .. }
            | E::InvalidAxis { .. }
            | E::InvalidJointValue { .. }
            | E::NoActuatedJoints { .. }
            | E::InvalidInertial { .. } => Kind::RobotModel,
            E::ShapeMismatch { .. } => Kind::Shape,
            E::TooFewMeasurements { .. } | E::Numerical { .. } => Kind::Identification,
            E::NotConverged(_) => Kind::Convergence,
            E::NonFinite { .. } | E::InvalidModel { .. } | E::InvalidOption { .. } => Kind::Value,
            _ => Kind::Value,
        };
        error(kind, self.to_string())
    }
}

impl IntoPyErr for so3_stiffness::identification::IdentificationError {
    fn into_py_err(self) -> PyErr {
        use so3_stiffness::identification::IdentificationError as E;
        let kind = match &self {
            E::Io { .. } => Kind::MissingFile,
            E::Csv { .. }
            | E::MissingColumn { .. }
            | E::DuplicateColumn { .. }
            | E::Parse { .. }
            | E::NonFinite { .. }
            | E::BadReferenceFlag { .. }
            | E::NotARotation { .. }
            | E::Reflection { .. }
            | E::MissingReference
            | E::MultipleReferences { .. } => Kind::DataFile,
            E::TooFewMeasurements { .. }
            | E::IllConditioned { .. }
            | E::SingularStiffness { .. }
            | E::SvdFailed => Kind::Identification,
            E::LengthMismatch { .. } => Kind::Shape,
            _ => Kind::Value,
        };
        error(kind, self.to_string())
    }
}

impl IntoPyErr for vjm::dataset::DatasetError {
    fn into_py_err(self) -> PyErr {
        use vjm::dataset::DatasetError as E;
        let kind = match &self {
            E::Io { .. } => Kind::MissingFile,
            E::Shape { .. } => Kind::Shape,
            _ => Kind::DataFile,
        };
        error(kind, self.to_string())
    }
}

impl IntoPyErr for vjm::diagnose::DiagnoseError {
    fn into_py_err(self) -> PyErr {
        match self {
            vjm::diagnose::DiagnoseError::Model(e) => e.into_py_err(),
            vjm::diagnose::DiagnoseError::Dataset(e) => e.into_py_err(),
            vjm::diagnose::DiagnoseError::JointCount { .. } => error(Kind::Shape, self.to_string()),
            vjm::diagnose::DiagnoseError::TooFewRows { .. } => {
                error(Kind::Identification, self.to_string())
            }
            vjm::diagnose::DiagnoseError::Cancelled(_) => error(Kind::Cancelled, self.to_string()),
            other => error(Kind::Value, other.to_string()),
        }
    }
}

impl IntoPyErr for so3_stiffness::diagnose::DiagnoseError {
    fn into_py_err(self) -> PyErr {
        match self {
            so3_stiffness::diagnose::DiagnoseError::Data(e) => e.into_py_err(),
            so3_stiffness::diagnose::DiagnoseError::TooFewRows { .. }
            | so3_stiffness::diagnose::DiagnoseError::Unexcited { .. } => {
                error(Kind::Identification, self.to_string())
            }
            so3_stiffness::diagnose::DiagnoseError::Cancelled(_) => {
                error(Kind::Cancelled, self.to_string())
            }
            other => error(Kind::Value, other.to_string()),
        }
    }
}

impl IntoPyErr for vjm::testbed::TestbedError {
    fn into_py_err(self) -> PyErr {
        match self {
            vjm::testbed::TestbedError::Dataset(d) => d.into_py_err(),
            vjm::testbed::TestbedError::Cancelled(_) => error(Kind::Cancelled, self.to_string()),
            other => error(Kind::Value, other.to_string()),
        }
    }
}

impl IntoPyErr for vjm::ModelError {
    fn into_py_err(self) -> PyErr {
        use vjm::ModelError as E;
        if let E::Vjm(inner) = self {
            return inner.into_py_err();
        }
        let kind = match &self {
            E::Read { .. } | E::Write { .. } => Kind::MissingFile,
            E::Format { .. }
            | E::Limit { .. }
            | E::Schema { .. }
            | E::Edited { .. }
            | E::OtherRobot { .. } => Kind::ModelFile,
            E::Table { .. } => Kind::DataFile,
            E::Cancelled => Kind::Cancelled,
            _ => Kind::Value,
        };
        error(kind, self.to_string())
    }
}

/// A table the core writes: a failed write is an `OSError` with the system's errno (the
/// Python caller words it for the output it stages), a bad shape `ShapeError`.
impl IntoPyErr for stiffness_core::table::TableError {
    fn into_py_err(self) -> PyErr {
        use stiffness_core::table::TableError as E;
        match self {
            E::Io { source, .. } => {
                PyOSError::new_err((source.raw_os_error().unwrap_or(0), source.to_string()))
            }
            E::Shape { .. } => error(Kind::Shape, self.to_string()),
            E::Cancelled => error(Kind::Cancelled, self.to_string()),
            other => error(Kind::DataFile, other.to_string()),
        }
    }
}
