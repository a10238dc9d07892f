//! When to stop a fixed-point iteration that contracts linearly (the static equilibrium's chord
//! steps, the compensation's K_C deflection): the one stopping rule both use.

/// The steps of a linearly converging iteration, one after the other.
///
/// With r = step / previous step < ½, the steps still to come sum to at most
/// `step · r / (1 − r)` (a geometric series), so an iteration can stop on that bound, one step
/// before its step is itself rounding-sized.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Contraction {
    previous: f64,
}

impl Contraction {
    /// Before the first step.
    pub(crate) fn new() -> Self {
        Self { previous: f64::NAN }
    }

    /// Records this step's size and returns a bound on what the steps still to come add: the
    /// geometric bound when the ratio to the previous step is below ½ and the caller `trusts`
    /// it (a contraction that has settled), else the step itself (the first step, a ratio
    /// near 1).
    pub(crate) fn remaining(&mut self, step: f64, trusted: bool) -> f64 {
        let ratio = step / self.previous; // NaN on the first step: not below ½
        self.previous = step;
        if trusted && ratio < 0.5 {
            step * ratio / (1.0 - ratio)
        } else {
            step
        }
    }
}
