//! Pose verification of an identified stiffness (seed eqs. 61–65).
//!
//! Given K at R₀ and a measured load increment Δτ (N·m, frame A), the predicted displacement
//! is Δζ_est = K⁻¹Δτ (eq. 61), the predicted pose R_est = R₀ exp(hat(Δζ_est)) (eq. 62, a
//! body-frame perturbation), and the estimation error E_θ = ‖log(R_actᵀ R_est)‖ (eqs. 63–65),
//! the geodesic angle between the measured and predicted poses, in rad.
//!
//! **Which matrix to invert.** Eq. 61 inverts K. But a measured increment Δτ is the difference
//! of A-frame components at two poses, and to first order `Δτ = K_D Δζ`, K_D = K − K_L
//! (that is how K_D is defined, eq. 48a). Inverting K instead of K_D mis-predicts by
//! K⁻¹K_L K_D⁻¹Δτ, i.e. by the pre-load relative to the stiffness (≈ 5–10 % for the seed's
//! τ₀). The seed's own Table 4 was computed with K_D (see `docs/seed-000-tables.md`).
//! [`StiffnessEstimate::predict_pose`] therefore uses K_D; the free functions take whatever
//! matrix is passed.

use nalgebra::{Matrix3, Rotation3, Vector3};

use super::error::IdentificationError;
use super::fit::StiffnessEstimate;
use crate::so3;

/// K is considered singular above this condition number.
const MAX_STIFFNESS_CONDITION: f64 = 1e12;

/// Outcome of one verification case.
#[derive(Debug, Clone, PartialEq)]
pub struct VerificationCase {
    /// Predicted displacement Δζ_est = K⁻¹Δτ, rad, frame A at R₀ (eq. 61).
    pub zeta_est: Vector3<f64>,
    /// Predicted pose R_est = R₀ exp(hat(Δζ_est)) (eq. 62).
    pub r_est: Rotation3<f64>,
    /// Estimation error E_θ = ‖log(R_actᵀ R_est)‖, rad (eq. 65).
    pub e_theta: f64,
}

/// Δζ_est = K⁻¹Δτ (eq. 61): `k` in N·m/rad, `dtau` in N·m (frame A); result in rad.
///
/// Errors if K is singular or ill-conditioned (condition number above 1e12) or not finite.
pub fn predict_displacement(
    k: &Matrix3<f64>,
    dtau: &Vector3<f64>,
) -> Result<Vector3<f64>, IdentificationError> {
    if !k.iter().chain(dtau.iter()).all(|x| x.is_finite()) {
        return Err(IdentificationError::NonFiniteInput {
            what: "stiffness or load increment",
        });
    }
    let sv = k.singular_values();
    let condition = sv.max() / sv.min();
    if !(condition <= MAX_STIFFNESS_CONDITION) {
        return Err(IdentificationError::SingularStiffness { condition });
    }
    k.lu()
        .solve(dtau)
        .ok_or(IdentificationError::SingularStiffness { condition })
}

/// R_est = R₀ exp(hat(K⁻¹Δτ)) (eqs. 61–62).
///
/// ```
/// use nalgebra::{Matrix3, Vector3};
/// use so3_stiffness::identification::predict_pose;
/// use so3_stiffness::so3;
/// let r0 = so3::exp(&Vector3::new(0.0, 0.1, 0.0));
/// let k = Matrix3::from_diagonal(&Vector3::new(30.0, 30.0, 7.0));
/// let r = predict_pose(&r0, &k, &Vector3::new(0.0, 0.0, 0.7)).unwrap();
/// assert!((so3::log(&(r0.inverse() * r)) - Vector3::new(0.0, 0.0, 0.1)).norm() < 1e-12);
/// ```
pub fn predict_pose(
    r0: &Rotation3<f64>,
    k: &Matrix3<f64>,
    dtau: &Vector3<f64>,
) -> Result<Rotation3<f64>, IdentificationError> {
    Ok(r0 * so3::exp(&predict_displacement(k, dtau)?))
}

/// E_θ = ‖log(R_actᵀ R_est)‖ in rad (eqs. 63–65).
pub fn estimation_error(r_act: &Rotation3<f64>, r_est: &Rotation3<f64>) -> f64 {
    so3::log(&(r_act.inverse() * r_est)).norm()
}

/// Runs eqs. 61–65 for one case.
pub fn verify(
    r0: &Rotation3<f64>,
    k: &Matrix3<f64>,
    dtau: &Vector3<f64>,
    r_act: &Rotation3<f64>,
) -> Result<VerificationCase, IdentificationError> {
    let zeta_est = predict_displacement(k, dtau)?;
    let r_est = r0 * so3::exp(&zeta_est);
    Ok(VerificationCase {
        zeta_est,
        r_est,
        e_theta: estimation_error(r_act, &r_est),
    })
}

impl StiffnessEstimate {
    /// Predicted pose under a measured load increment `dtau` (N·m, frame A) from the reference
    /// pose `r0`: R₀ exp(hat(K_D⁻¹Δτ)) — K_D, because measured A-frame increments follow
    /// K_D to first order (see the module docs of [`mod@crate::identification::verify`]).
    pub fn predict_pose(
        &self,
        r0: &Rotation3<f64>,
        dtau: &Vector3<f64>,
    ) -> Result<Rotation3<f64>, IdentificationError> {
        predict_pose(r0, &self.k_d, dtau)
    }

    /// Eqs. 61–65 for one verification case, predicting with K_D (see [`Self::predict_pose`]).
    pub fn verify(
        &self,
        r0: &Rotation3<f64>,
        dtau: &Vector3<f64>,
        r_act: &Rotation3<f64>,
    ) -> Result<VerificationCase, IdentificationError> {
        verify(r0, &self.k_d, dtau, r_act)
    }
}
