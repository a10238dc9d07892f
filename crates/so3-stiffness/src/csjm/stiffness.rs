//! The CSJM stiffness model on SO(3) (seed eqs. 33, 44, 45, corrected; see
//! `docs/seed-000-deviations.md`).
//!
//! Conventions (`docs/conventions.md`): displacement in the body frame, `R = R₀·exp(hat Δζ)`;
//! τ is the **external** moment on the platform about O, components in A (N·m);
//! `K = ∂τ/∂ζ` as a covariant derivative (N·m/rad).
//!
//! With Φ the potential energy, the external moment that holds the platform is the body
//! gradient `τ_i = L_i Φ`, and
//!
//! - **Euclidean** (the earlier cable-driven-manipulator model, component-wise derivative):
//!   `K_D = ∂τ/∂ζ = −(D − Jᵀ diag(k) J) − Σ_loads hat(p) hat(Rᵀ f)`;
//! - **Levi-Civita** (bi-invariant metric, `∇_{L_j} L_i = ½ [L_j, L_i]`):
//!   `K = K_D − ½ hat(τ)`, the covariant Hessian of Φ — symmetric for this conservative system.
//!
//! `K_D − K_Dᵀ = hat(τ)`: the Euclidean model's asymmetry is exactly the commutator term
//! `[L_j, L_i]Φ`, which the connection term removes.

use nalgebra::{Matrix3, Rotation3, SymmetricEigen, Vector3};

use super::geometry::{CsjmGeometry, CABLES};
use super::kinetostatics::CableKinematics;
use super::loads::PointLoad;
use crate::error::CsjmError;
use crate::so3::hat;

/// Stiffness of the CSJM at one loaded pose, N·m/rad, frame A.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stiffness {
    /// `K = K_D − ½ hat(τ)`: the covariant (Levi-Civita) stiffness, symmetric.
    pub covariant: Matrix3<f64>,
    /// `K_D = ∂τ/∂ζ`: the Euclidean (component-wise) stiffness, asymmetric under load.
    pub euclidean: Matrix3<f64>,
    /// The external moment τ on the platform at this pose, N·m, frame A.
    pub external_moment: Vector3<f64>,
}

impl Stiffness {
    /// Builds both variants from the Euclidean stiffness `K_D` and the external moment τ.
    pub fn from_euclidean(euclidean: Matrix3<f64>, external_moment: Vector3<f64>) -> Self {
        Self {
            covariant: euclidean + levi_civita_term(&external_moment),
            euclidean,
            external_moment,
        }
    }

    /// The connection term `K − K_D = −½ hat(τ)`.
    pub fn connection_term(&self) -> Matrix3<f64> {
        self.covariant - self.euclidean
    }

    /// The seed's printed model `K_D − hat(τ)` (eqs. 45/48b with γ = ±2): kept only to
    /// document the deviation; it is not symmetric for a conservative system.
    pub fn paper_eq48b(&self) -> Matrix3<f64> {
        self.euclidean - hat(&self.external_moment)
    }

    /// Eigenvalues of the symmetric part of the covariant stiffness, ascending (N·m/rad).
    pub fn principal_stiffnesses(&self) -> Vector3<f64> {
        let sym = 0.5 * (self.covariant + self.covariant.transpose());
        let mut e: [f64; 3] = SymmetricEigen::new(sym).eigenvalues.into();
        e.sort_by(f64::total_cmp);
        Vector3::from(e)
    }

    /// True if the equilibrium is stable: the covariant stiffness is positive definite.
    pub fn is_stable(&self) -> bool {
        self.principal_stiffnesses()[0] > 0.0
    }
}

/// The Levi-Civita connection term `−½ hat(τ)` (N·m/rad) for an external moment τ (N·m, A).
///
/// The seed's eq. 48b prints `−hat(τ)` because its eq. 31 doubles the structure constants.
pub fn levi_civita_term(external_moment_in_a: &Vector3<f64>) -> Matrix3<f64> {
    -0.5 * hat(external_moment_in_a)
}

fn check_cable_inputs(
    tensions: &[f64; CABLES],
    cable_stiffness: &[f64; CABLES],
) -> Result<(), CsjmError> {
    for i in 0..CABLES {
        if !tensions[i].is_finite() {
            return Err(CsjmError::NonFinite {
                what: "cable tension",
                cable: Some(i + 1),
            });
        }
        if tensions[i] <= 0.0 {
            return Err(CsjmError::SlackCable {
                cable: i + 1,
                tension: tensions[i],
            });
        }
        let k = cable_stiffness[i];
        if !(k.is_finite() && k >= 0.0) {
            return Err(CsjmError::InvalidCableParameter {
                cable: i + 1,
                what: "stiffness [N/m]",
                value: k,
                requirement: "finite and ≥ 0",
            });
        }
    }
    Ok(())
}

/// Analytic stiffness at a loaded pose (eqs. 44–45 in this crate's conventions).
///
/// - `pose`: `ᴮ_A R`;
/// - `tensions`: cable tensions `t_s` (N, all > 0);
/// - `cable_stiffness`: `k_s = ∂t_s/∂c_s` of each cable with its driving unit (N/m, ≥ 0);
/// - `loads`: conservative point loads (e.g. [`PointLoad::prototype_gravity`]).
///
/// The platform is assumed in static equilibrium, so the external moment is
/// `τ = −(JᵀT + Σ p × Rᵀf)`. Errors name the cable for a slack (≤ 0) or non-finite tension,
/// an invalid stiffness, or a zero-length cable.
///
/// ```
/// use nalgebra::Rotation3;
/// use so3_stiffness::csjm::{stiffness_at, CsjmGeometry};
/// let g = CsjmGeometry::prototype();
/// let s = stiffness_at(&g, &Rotation3::identity(), &[60.0; 6], &[4000.0; 6], &[]).unwrap();
/// let k = s.covariant;
/// assert!((k - k.transpose()).norm() < 1e-10 * k.norm());
/// assert!(s.is_stable());
/// ```
pub fn stiffness_at(
    geometry: &CsjmGeometry,
    pose: &Rotation3<f64>,
    tensions: &[f64; CABLES],
    cable_stiffness: &[f64; CABLES],
    loads: &[PointLoad],
) -> Result<Stiffness, CsjmError> {
    check_cable_inputs(tensions, cable_stiffness)?;
    let kin = CableKinematics::new(geometry, pose)?;
    Ok(stiffness_from_kinematics(
        &kin,
        pose,
        tensions,
        cable_stiffness,
        loads,
    ))
}

/// Stiffness from already computed kinematics; inputs assumed validated.
pub(crate) fn stiffness_from_kinematics(
    kin: &CableKinematics,
    pose: &Rotation3<f64>,
    tensions: &[f64; CABLES],
    cable_stiffness: &[f64; CABLES],
    loads: &[PointLoad],
) -> Stiffness {
    let j = kin.jacobian();
    // Derivative of the cable moment JᵀT along body perturbations: D − Jᵀ diag(k) J (eq. 45).
    let mut cable_moment_derivative = kin.jacobian_derivative_times_tensions(tensions);
    for (row, &k) in j.row_iter().zip(cable_stiffness) {
        cable_moment_derivative -= k * row.transpose() * row;
    }
    let mut internal_moment = kin.cable_moment(tensions);
    let mut internal_moment_derivative = cable_moment_derivative;
    for load in loads {
        internal_moment += load.moment_in_a(pose);
        internal_moment_derivative += load.moment_derivative(pose);
    }
    // Equilibrium: external + internal moments vanish.
    Stiffness::from_euclidean(-internal_moment_derivative, -internal_moment)
}
