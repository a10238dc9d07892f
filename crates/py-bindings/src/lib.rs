//! Python extension module `robot_stiffness._core`.
use pyo3::prelude::*;

/// The compiled core of the `robot_stiffness` Python package.
#[pymodule]
fn _core(_m: &Bound<'_, PyModule>) -> PyResult<()> {
    Ok(())
}
