//! Robot-free foundations shared by every crate of the robot-stiffness workspace.
//!
//! - [`stats`]: distribution tails, nested F tests, Benjamini–Hochberg, ANOVA, rank
//!   correlation, cluster-robust Wald tests (used by both diagnoses and the identification).
//! - [`cancel`]: one cooperative cancellation and progress mechanism for every long loop: a
//!   cheap [`Cancel`] token polled per chunk / candidate / step, a [`Progress`] record, and the
//!   [`Monitor`] that bundles both for a computation.
//! - [`decompose`]: SVD and symmetric eigen-decomposition with an iteration cap (nalgebra's
//!   own loop forever on NaN) and a named [`NotConverged`] error.
//! - [`table`]: the one CSV reader and writer of measurement tables (chunked, parallel, errors
//!   naming line and column).
//! - [`num`]: [`num::Short`], the one format of a number quoted in a message (`1e308`, not 309
//!   digits).
//!
//! - [`so3`]: the Lie toolkit of rotations (`exp`, `log`, `hat`, `vee`, `adjoint`, the left and
//!   right Jacobians), shared by both model crates (it is geometry, not a robot; `so3-stiffness`
//!   re-exports it); [`engine`]: the diagnosis engine both models run on; [`lsq`]: the
//!   streaming least-squares accumulator; [`row_blocks`]: rows on every core in fixed blocks,
//!   results independent of the thread count.
//!
//! This crate knows nothing about robots, URDF or cables; the model crates (`so3-stiffness`,
//! `vjm`) depend on it, never the other way round.
//!
//! ```
//! use stiffness_core::{Cancel, Cancelled, Monitor, Progress};
//! // A long loop polls the monitor once per chunk and reports its progress.
//! fn long_job(monitor: &Monitor<'_>) -> Result<u64, Cancelled> {
//!     let mut sum = 0u64;
//!     for chunk in 0..100u64 {
//!         monitor.check()?;
//!         sum += chunk;
//!         monitor.report(Progress { stage: "sum", done: chunk as usize + 1, total: 100 })?;
//!     }
//!     Ok(sum)
//! }
//! let cancel = Cancel::new();
//! assert_eq!(long_job(&Monitor::new(cancel.clone())), Ok(4950));
//! cancel.cancel(); // e.g. from a Ctrl-C handler on another thread
//! assert_eq!(long_job(&Monitor::new(cancel)), Err(Cancelled));
//! ```
#![deny(missing_docs)]
// `!(x > 0.0)` is used on purpose throughout: unlike `x <= 0.0` it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod cancel;
pub mod decompose;
pub mod engine;
mod fast_math;
pub mod lsq;
pub mod num;
pub mod row_blocks;
pub mod so3;
mod so3_error;
pub mod stats;
pub mod table;

pub use cancel::{Cancel, Cancelled, Monitor, Progress};
pub use decompose::NotConverged;
pub use so3_error::So3Error;
