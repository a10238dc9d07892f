//! Conservative point loads on the platform: a force with constant components in the base
//! frame B (a weight, a counterweight on a cord over a fixed pulley) applied at a point fixed
//! in the platform frame A.
//!
//! Such a load has the potential `V(R) = −f_B · (R p_A)`, so it can be added to the cable
//! potential and the whole system stays conservative (its stiffness is symmetric).

use nalgebra::{Matrix3, Rotation3, Vector3};

use crate::error::CsjmError;
use crate::so3::hat;

/// Weight of the seed prototype's platform with its force/torque sensor, N (seed IV.A).
pub const PROTOTYPE_PLATFORM_WEIGHT: f64 = 4.82;

/// Centre of mass of the seed prototype's platform, m, frame A (seed IV.A).
pub const PROTOTYPE_CENTRE_OF_MASS_IN_A: Vector3<f64> = Vector3::new(0.0, 0.0, 0.081);

/// A force with constant base-frame components applied at a platform-fixed point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointLoad {
    point_in_a: Vector3<f64>,
    force_in_b: Vector3<f64>,
}

impl PointLoad {
    /// A force `force_in_b` (N, components in B) applied at `point_in_a` (m, from O, in A).
    pub fn new(point_in_a: Vector3<f64>, force_in_b: Vector3<f64>) -> Result<Self, CsjmError> {
        if !point_in_a.iter().all(|x| x.is_finite()) {
            return Err(CsjmError::NonFinite {
                what: "load application point (frame A)",
                cable: None,
            });
        }
        if !force_in_b.iter().all(|x| x.is_finite()) {
            return Err(CsjmError::NonFinite {
                what: "load force (frame B)",
                cable: None,
            });
        }
        Ok(Self {
            point_in_a,
            force_in_b,
        })
    }

    /// Weight `weight` (N, ≥ 0) at the centre of mass `centre_of_mass_in_a` (m, frame A), for a
    /// base frame whose z axis points **up** (gravity along −z_B).
    pub fn gravity(weight: f64, centre_of_mass_in_a: Vector3<f64>) -> Result<Self, CsjmError> {
        if !(weight.is_finite() && weight >= 0.0) {
            return Err(CsjmError::InvalidOption {
                what: "weight [N]",
                value: weight,
            });
        }
        Self::new(centre_of_mass_in_a, Vector3::new(0.0, 0.0, -weight))
    }

    /// The seed prototype's platform weight: 4.82 N at ᴬr_G = (0, 0, 0.081) m, z_B up.
    pub fn prototype_gravity() -> Self {
        Self {
            point_in_a: PROTOTYPE_CENTRE_OF_MASS_IN_A,
            force_in_b: Vector3::new(0.0, 0.0, -PROTOTYPE_PLATFORM_WEIGHT),
        }
    }

    /// Application point, m, frame A.
    pub fn point_in_a(&self) -> Vector3<f64> {
        self.point_in_a
    }

    /// Force, N, frame B.
    pub fn force_in_b(&self) -> Vector3<f64> {
        self.force_in_b
    }

    /// Potential energy `−f_B · (R p_A)`, J (zero when the point is at O).
    pub fn potential(&self, pose: &Rotation3<f64>) -> f64 {
        -self.force_in_b.dot(&(pose * self.point_in_a))
    }

    /// Moment of the load about O, N·m, components in A: `p_A × (Rᵀ f_B)`.
    pub fn moment_in_a(&self, pose: &Rotation3<f64>) -> Vector3<f64> {
        self.point_in_a.cross(&(pose.inverse() * self.force_in_b))
    }

    /// Derivative of [`PointLoad::moment_in_a`] along body perturbations `R·exp(hat δ)`:
    /// `∂m/∂δ = hat(p_A) hat(Rᵀ f_B)` (since `∂(Rᵀf)/∂δ = hat(Rᵀ f)`).
    pub fn moment_derivative(&self, pose: &Rotation3<f64>) -> Matrix3<f64> {
        hat(&self.point_in_a) * hat(&(pose.inverse() * self.force_in_b))
    }
}
