//! SO(3) Lie-group toolkit and the stiffness model of a cable-driven spherical joint module.
#![deny(missing_docs)]

pub mod error;
pub mod identification;
pub mod so3;

pub use error::So3Error;
