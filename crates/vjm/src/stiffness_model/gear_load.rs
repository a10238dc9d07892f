//! The load's deflection of a model's gear curves in [`predict`](super::StiffnessModel::predict)
//! and [`predict_under_gravity`](super::StiffnessModel::predict_under_gravity).
//!
//! A curved torsion spring k deflects under the load by `θ(τ₀ + τ) − θ(τ₀)` ([`GearCurve`]):
//! its linear part `c_k τ` is the model's linear prediction, and its excess beyond it moves the
//! tip by `J_k (e(τ₀ + τ) − e(τ₀))`, `e(T) = Σ_i a_i h_i(T) + ½ b sign(T)` (sign(0) = 0) — the
//! columns of the diagnosis' `joint_torsion_nonlinear` and `joint_backlash` candidates times
//! their coefficients (the backlash's with `sign`, the mean of a known torque), to first order
//! in the compliances as the linear prediction is: J_k is the spring's Jacobian column at the
//! row's (sagged) pose, τ₀ its preload under the weight (0 weightless) and τ the load's torque
//! on it with gravity's coupling, all as the linear prediction takes them.
//!
//! [`GearCurve`]: crate::gear::GearCurve

use crate::gear::CurvedSprings;

/// Adds each curved spring's excess under the load to the first `axes` components of
/// `deflection` (m, rad; base frame): `J_k (e(τ₀ + τ) − e(τ₀))` with `jacobian` the row's 6×m
/// Jacobian (column-major) and `torque(k)` the spring's `(τ₀, τ)` (N·m). A change of exactly 0
/// (a curve of zero coefficients and no lost motion, or a torque within the first knot that
/// keeps its sign) adds nothing, so such a
/// model predicts what the model without curves predicts, bit for bit.
pub(super) fn add_gear_load(
    curved: &CurvedSprings<'_>,
    jacobian: &[f64],
    torque: impl Fn(usize) -> (f64, f64),
    axes: usize,
    deflection: &mut [f64; 6],
) {
    for (k, curve) in curved.iter() {
        let (preload, load) = torque(k);
        let change = curve.excess(preload + load) - curve.excess(preload);
        if change != 0.0 {
            let col = &jacobian[6 * k..6 * k + 6];
            for (d, j) in deflection.iter_mut().zip(col).take(axes) {
                *d += j * change;
            }
        }
    }
}
