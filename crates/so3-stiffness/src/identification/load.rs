//! Load measurement (seed eqs. 55–56): the F/T-sensor wrench and the platform's own weight,
//! as a moment about O with components in frame A.
//!
//! Wrenches are `[f; m]` (N, N·m) — force first, as everywhere in this workspace — and twists
//! `[v; ω]`. For a pose g = (R, p) the adjoint is `Ad_g = [[R, hat(p)R], [0, R]]`, and a wrench
//! measured in frame S maps to frame A by `ᴬW = Ad_{ˢ_A T}ᵀ ˢW` (eq. 55), where ˢ_A T is the pose
//! of A in S. That is `ᴬf = Rᵀ ˢf`, `ᴬm = Rᵀ(ˢm − p × ˢf)`: the moment is taken about A's origin.

use nalgebra::{Isometry3, Matrix6, Rotation3, Vector3, Vector6};

use crate::so3;

/// Adjoint of a rigid transform for `[v; ω]` twists: `[[R, hat(p)R], [0, R]]`.
pub fn adjoint_se3(pose: &Isometry3<f64>) -> Matrix6<f64> {
    let r = pose.rotation.to_rotation_matrix().into_inner();
    let p = pose.translation.vector;
    let mut ad = Matrix6::zeros();
    ad.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    ad.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&(so3::hat(&p) * r));
    ad.fixed_view_mut::<3, 3>(3, 3).copy_from(&r);
    ad
}

/// ᴬW_E = Ad_{ˢ_A T}ᵀ ˢW_E (eq. 55).
///
/// `platform_in_sensor` is ˢ_A T (pose of A in the sensor frame S, m); `wrench_in_sensor` is
/// `[f; m]` measured by the sensor (N, N·m, about the sensor origin, S components). The
/// result is `[f; m]` about O with A components.
pub fn sensor_wrench_to_platform(
    platform_in_sensor: &Isometry3<f64>,
    wrench_in_sensor: &Vector6<f64>,
) -> Vector6<f64> {
    adjoint_se3(platform_in_sensor).transpose() * wrench_in_sensor
}

/// Moment of the platform weight about O, components in A, N·m (eq. 56, done with the
/// rotation ᴮ_A R the weight actually depends on: ᴬτ_G = ᴬr_G × (ᴮ_A Rᵀ ᴮG)).
///
/// `orientation` = ᴮ_A R; `weight_in_base` = ᴮG, the gravity force on the platform (N, e.g.
/// (0, 0, −4.82) if B's z axis points up); `centre_of_mass_in_platform` = ᴬr_G (m, from O).
pub fn gravity_moment(
    orientation: &Rotation3<f64>,
    weight_in_base: &Vector3<f64>,
    centre_of_mass_in_platform: &Vector3<f64>,
) -> Vector3<f64> {
    centre_of_mass_in_platform.cross(&(orientation.inverse() * weight_in_base))
}

/// Total moment ᴬτ = ᴬτ_E + ᴬτ_G about O, N·m, components in A.
pub fn total_moment(
    platform_in_sensor: &Isometry3<f64>,
    wrench_in_sensor: &Vector6<f64>,
    orientation: &Rotation3<f64>,
    weight_in_base: &Vector3<f64>,
    centre_of_mass_in_platform: &Vector3<f64>,
) -> Vector3<f64> {
    let external = sensor_wrench_to_platform(platform_in_sensor, wrench_in_sensor);
    external.fixed_rows::<3>(3).into_owned()
        + gravity_moment(orientation, weight_in_base, centre_of_mass_in_platform)
}
