//! SO(3) Lie-group toolkit and the stiffness model of a cable-driven spherical joint module.
#![deny(missing_docs)]
// `!(x > 0.0)` is used on purpose throughout: unlike `x <= 0.0` it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod csjm;
pub mod error;
pub mod identification;
pub mod so3;

pub use csjm::{CsjmGeometry, CsjmSimulator, Stiffness};
pub use error::{CsjmError, So3Error};
