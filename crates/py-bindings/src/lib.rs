//! Python extension module `robot_stiffness._core`.
//!
//! Thin wrappers over the core crates `so3-stiffness` and `vjm`. Array conversions live in
//! [`convert`], error mapping in [`errors`]; each binding module wraps one core module. The
//! public, documented Python API is the pure-Python package `robot_stiffness`, which calls these.
#![deny(missing_docs)]

use pyo3::prelude::*;

pub mod columns;
pub mod convert;
pub mod csjm;
pub mod csjm_diagnose;
pub mod diagnose;
pub mod errors;
pub mod gravity;
pub mod identify_partial;
pub mod interrupt;
pub mod output_tables;
pub mod paper_study;
pub mod results;
pub mod so3;
pub mod stiffness_model;
pub mod use_model;
pub mod vjm;
pub mod vjm_data;

/// Makes rust-numpy look up numpy's C-API capsule now, while the package is imported, rather
/// than at the first array a command passes: that lookup runs Python code (numpy's version
/// parsing, imports), and a `KeyboardInterrupt` raised inside it makes rust-numpy panic
/// ("Failed to access NumPy array API capsule"). The same steps are taken first through
/// fallible calls, so that an interrupt (or a broken numpy) during them is an ordinary
/// exception of the import; rust-numpy's own lookup then finds everything imported.
fn acquire_numpy_api(py: Python<'_>) -> PyResult<()> {
    let version = py.import("numpy")?.getattr("__version__")?;
    let major: u8 = py
        .import("numpy.lib")?
        .getattr("NumpyVersion")?
        .call1((version,))?
        .getattr("major")?
        .extract()?;
    let core = if major >= 2 {
        "numpy._core.multiarray"
    } else {
        "numpy.core.multiarray"
    };
    py.import(core)?.getattr("_ARRAY_API")?;
    numpy::npyffi::is_numpy_2(py);
    Ok(())
}

/// The compiled core of the `robot_stiffness` Python package.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    acquire_numpy_api(m.py())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(errors::_panic_for_tests, m)?)?;
    columns::register(m)?;
    so3::register(m)?;
    csjm::register(m)?;
    csjm_diagnose::register(m)?;
    diagnose::register(m)?;
    vjm::register(m)?;
    gravity::register(m)?;
    identify_partial::register(m)?;
    vjm_data::register(m)?;
    paper_study::register(m)?;
    stiffness_model::register(m)?;
    use_model::register(m)?;
    output_tables::register(m)?;
    Ok(())
}
