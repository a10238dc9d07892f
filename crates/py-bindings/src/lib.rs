//! Python extension module `robot_stiffness._core`.
//!
//! Thin wrappers over the core crates `so3-stiffness` and `vjm`. Array conversions live in
//! [`convert`], error mapping in [`errors`]; each binding module wraps one core module. The
//! public, documented Python API is the pure-Python package `robot_stiffness`, which calls these.
#![deny(missing_docs)]

use pyo3::prelude::*;

pub mod convert;
pub mod csjm;
pub mod csjm_diagnose;
pub mod diagnose;
pub mod errors;
pub mod identify_partial;
pub mod interrupt;
pub mod results;
pub mod so3;
pub mod stiffness_model;
pub mod use_model;
pub mod vjm;
pub mod vjm_data;

/// The compiled core of the `robot_stiffness` Python package.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(errors::_panic_for_tests, m)?)?;
    so3::register(m)?;
    csjm::register(m)?;
    csjm_diagnose::register(m)?;
    diagnose::register(m)?;
    vjm::register(m)?;
    identify_partial::register(m)?;
    vjm_data::register(m)?;
    stiffness_model::register(m)?;
    use_model::register(m)?;
    Ok(())
}
