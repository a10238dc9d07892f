//! Effects OUTSIDE the diagnosis catalogue: physics the testbed can simulate but `diagnose` has
//! no candidate for, so that its `unexplained` verdict can be checked. The diagnosis code must
//! not use this module (it would be the oracle feeding the code it checks).
//!
//! - A compliant mount: the whole arm, base frame included, moves as one rigid body under the
//!   reaction of the applied wrench: it translates by `c_t·f` and rotates by `c_r·M_base` about
//!   the base origin, `M_base = m + p × f` the applied moment about the base origin (wrench
//!   `[f; m]` at the tip point `p`, base frame).
//! - A tool compliant along its own axis: the tool tip moves by `c·(f·z)·z` on top of the arm's
//!   deflection, `z` the tip frame's z axis in the unloaded configuration (base frame).
//!
//! Pose drift (an offset per pose) is the third out-of-catalogue effect; it lives in
//! [`super::Effect::PoseDrift`] because the campaign, not the response, draws it.

use nalgebra::{Rotation3, Vector3};

/// The rigid motion of a compliant mount under an applied wrench `[f; m]` (N, N·m, base frame)
/// acting at the tip point `tip` (m, base frame): translation `c_t·f` (m) and rotation vector
/// `c_r·(m + tip × f)` (rad) about the base origin. `translation` is c_t in m/N, `rotation`
/// is c_r in rad/(N·m).
pub fn mount_motion(
    translation: f64,
    rotation: f64,
    wrench: &[f64; 6],
    tip: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    let f = Vector3::new(wrench[0], wrench[1], wrench[2]);
    let m = Vector3::new(wrench[3], wrench[4], wrench[5]);
    (translation * f, rotation * (m + tip.cross(&f)))
}

/// Where a point `p` (m, base frame, as the arm alone would place it) ends up after the mount
/// translates by `t` and rotates by the rotation vector `phi` about the base origin:
/// `t + exp(hat(φ))·p` (exact, not linearised).
pub fn moved_by_mount(t: &Vector3<f64>, phi: &Vector3<f64>, p: &Vector3<f64>) -> Vector3<f64> {
    t + Rotation3::new(*phi) * p
}

/// Tip displacement (m, base frame) of a tool with axial compliance `compliance` (m/N) along its
/// unit axis `axis` (base frame) under the applied force `f` (N, base frame): `c·(f·z)·z`.
pub fn tool_axial_displacement(
    compliance: f64,
    axis: &Vector3<f64>,
    f: &Vector3<f64>,
) -> Vector3<f64> {
    compliance * f.dot(axis) * axis
}
