//! SO(3) Lie-group toolkit and the stiffness model of a cable-driven spherical joint module.
#![deny(missing_docs)]

pub mod csjm;
pub mod error;
pub mod so3;

pub use csjm::{CsjmGeometry, CsjmSimulator, Stiffness};
pub use error::{CsjmError, So3Error};
