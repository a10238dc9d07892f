//! Error types of the crate.
//!
//! Every error carries the offending quantity in structured fields, so a caller can both
//! print a useful message and react programmatically (e.g. re-tension cable 3).

use thiserror::Error;

pub use stiffness_core::So3Error;

/// Which body a cable point belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Side {
    /// The moving platform (frame A, points `a_i`).
    Platform,
    /// The base (frame B, points `b_i`).
    Base,
}

impl std::fmt::Display for Side {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Side::Platform => f.write_str("platform point A"),
            Side::Base => f.write_str("base point B"),
        }
    }
}

/// Errors from the CSJM model ([`crate::csjm`]).
///
/// Cable numbers in this type are **1-based**, as in the seed paper (cable `i` runs from
/// `A_i` to `B_i`), so that messages can be matched with a drawing of the module.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum CsjmError {
    /// A geometric input (cable point, pose, load) contains NaN or ±∞.
    #[error("{what} is not finite{}", cable.map(|c| format!(" (cable {c})")).unwrap_or_default())]
    NonFinite {
        /// What was not finite.
        what: &'static str,
        /// The cable it belongs to (1-based), if any.
        cable: Option<usize>,
    },
    /// Two cable points of the same body coincide.
    #[error("{side}{first} and {side}{second} coincide (distance {distance:.3e} m)")]
    CoincidentPoints {
        /// The body both points belong to.
        side: Side,
        /// First cable (1-based).
        first: usize,
        /// Second cable (1-based).
        second: usize,
        /// Their distance, m.
        distance: f64,
    },
    /// A cable point lies at the joint centre O, so its cable has no moment arm.
    #[error("{side}{cable} lies at the joint centre O (distance {distance:.3e} m): cable {cable} has no moment arm")]
    PointAtCentre {
        /// The body the point belongs to.
        side: Side,
        /// Cable (1-based).
        cable: usize,
        /// Distance of the point from O, m.
        distance: f64,
    },
    /// A cable has (numerically) zero length at the requested pose, so its direction is undefined.
    #[error(
        "cable {cable} has zero length ({length:.3e} m) at this pose: A{cable} meets B{cable}"
    )]
    ZeroLengthCable {
        /// Cable (1-based).
        cable: usize,
        /// Its length, m.
        length: f64,
    },
    /// A cable is slack: cables can only pull, so the model is invalid at this pose/load.
    #[error("cable {cable} is slack: tension {tension:.6e} N ≤ 0")]
    SlackCable {
        /// Cable (1-based).
        cable: usize,
        /// Its (non-positive) tension, N.
        tension: f64,
    },
    /// A per-cable parameter is out of range.
    #[error("cable {cable}: {what} = {value:e} is invalid (must be {requirement})")]
    InvalidCableParameter {
        /// Cable (1-based).
        cable: usize,
        /// Which parameter (e.g. "stiffness [N/m]").
        what: &'static str,
        /// The value given.
        value: f64,
        /// What it must satisfy (e.g. "finite and ≥ 0").
        requirement: &'static str,
    },
    /// A solver option is out of range.
    #[error("invalid solver option {what} = {value:e}")]
    InvalidOption {
        /// Which option.
        what: &'static str,
        /// The value given.
        value: f64,
    },
    /// The equilibrium solver did not converge.
    #[error(
        "equilibrium solver did not converge after {iterations} iterations: \
         moment residual {residual:.3e} N·m > tolerance {tolerance:.3e} N·m ({reason})"
    )]
    NoConvergence {
        /// Iterations performed.
        iterations: usize,
        /// Final ‖τ_hold(R) − τ‖, N·m.
        residual: f64,
        /// The requested tolerance, N·m.
        tolerance: f64,
        /// Why it stopped.
        reason: &'static str,
    },
    /// A batch output buffer does not match its input.
    #[error("{what}: output has length {got}, expected {expected} (one per input)")]
    LengthMismatch {
        /// Which buffer.
        what: &'static str,
        /// Required length.
        expected: usize,
        /// Given length.
        got: usize,
    },
    /// One item of a batch failed; nothing after it was computed.
    #[error("item {index} (0-based) of the batch: {source}")]
    InBatch {
        /// 0-based index of the failing item.
        index: usize,
        /// What went wrong there.
        source: Box<CsjmError>,
    },
    /// An SO(3) input was invalid.
    #[error(transparent)]
    So3(#[from] So3Error),
}
