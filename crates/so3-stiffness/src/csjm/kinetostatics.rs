//! Kinetostatics of the CSJM (seed eqs. 38–43): cable lengths, directions, the 6×3 cable
//! Jacobian, the cable moment `JᵀT` and the derivative of `J` along body perturbations.
//!
//! Frames. At pose `R = ᴮ_A R` the cable vector in A is `c_i = Rᵀ b_i − a_i = c_i u_i`
//! (from `A_i` toward `B_i`). Under a body perturbation `R·exp(hat δζ)` the base point seen
//! from A moves by `δ(Rᵀ b_i) = −δζ × Rᵀ b_i`, hence `δc_i = −(a_i × u_i)·δζ` with `a_i` and
//! `u_i` both in **frame A** (using `Rᵀ b_i × u_i = a_i × u_i`). So row i of J is
//! `(a_i × u_i)ᵀ` in A, `δC = −J δζ` (eq. 40), and `JᵀT = Σ a_i × t_i u_i` (eq. 38) is the
//! moment the cables exert on the platform about O, in A. The tests check `δC = −J δζ`
//! against finite differences of the cable lengths.

use nalgebra::{Matrix3, Matrix6x3, Rotation3, Vector3};

use super::geometry::{CsjmGeometry, CABLES};
use crate::error::CsjmError;
use crate::so3::hat;

/// A cable shorter than this fraction of `‖a_i‖ + ‖b_i‖` has an undefined direction.
const ZERO_LENGTH_FRACTION: f64 = 1e-9;

/// Checks that every entry of a pose is finite (a `Rotation3` built unchecked may not be).
pub(crate) fn check_pose(pose: &Rotation3<f64>) -> Result<(), CsjmError> {
    if pose.matrix().iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(CsjmError::NonFinite {
            what: "pose R",
            cable: None,
        })
    }
}

/// Cable lengths, directions and Jacobian of a geometry at one pose.
#[derive(Debug, Clone, PartialEq)]
pub struct CableKinematics {
    platform_points_in_a: [Vector3<f64>; CABLES],
    base_points_in_a: [Vector3<f64>; CABLES],
    lengths: [f64; CABLES],
    directions_in_a: [Vector3<f64>; CABLES],
    jacobian: Matrix6x3<f64>,
}

impl CableKinematics {
    /// Kinematics of `geometry` at pose `pose = ᴮ_A R`.
    ///
    /// Errors if the pose is not finite or a cable has zero length (names the cable).
    pub fn new(geometry: &CsjmGeometry, pose: &Rotation3<f64>) -> Result<Self, CsjmError> {
        check_pose(pose)?;
        let r_t = pose.inverse();
        let platform_points_in_a = *geometry.platform_points();
        let base_points_in_a: [Vector3<f64>; CABLES] =
            std::array::from_fn(|i| r_t * geometry.base_point(i));
        let mut lengths = [0.0; CABLES];
        let mut directions_in_a = [Vector3::zeros(); CABLES];
        let mut jacobian = Matrix6x3::zeros();
        for i in 0..CABLES {
            let a = platform_points_in_a[i];
            let c = base_points_in_a[i] - a;
            let length = c.norm();
            if !(length > ZERO_LENGTH_FRACTION * (a.norm() + base_points_in_a[i].norm())) {
                return Err(CsjmError::ZeroLengthCable {
                    cable: i + 1,
                    length,
                });
            }
            let u = c / length;
            lengths[i] = length;
            directions_in_a[i] = u;
            jacobian.set_row(i, &a.cross(&u).transpose());
        }
        Ok(Self {
            platform_points_in_a,
            base_points_in_a,
            lengths,
            directions_in_a,
            jacobian,
        })
    }

    /// Cable lengths `c_i = ‖Rᵀ b_i − a_i‖`, m.
    pub fn lengths(&self) -> &[f64; CABLES] {
        &self.lengths
    }

    /// Unit cable directions `u_i` (from `A_i` toward `B_i`), components in A.
    pub fn directions_in_a(&self) -> &[Vector3<f64>; CABLES] {
        &self.directions_in_a
    }

    /// Base points `Rᵀ b_i`, m, components in A.
    pub fn base_points_in_a(&self) -> &[Vector3<f64>; CABLES] {
        &self.base_points_in_a
    }

    /// The 6×3 Jacobian, row i = `(a_i × u_i)ᵀ` (m, frame A): `δC = −J δζ` for `R·exp(hat δζ)`.
    pub fn jacobian(&self) -> &Matrix6x3<f64> {
        &self.jacobian
    }

    /// Moment of the cable tensions on the platform about O, `JᵀT` (eq. 38), N·m, frame A.
    /// `tensions` in N.
    pub fn cable_moment(&self, tensions: &[f64; CABLES]) -> Vector3<f64> {
        (0..CABLES).fold(Vector3::zeros(), |m, i| {
            m + self.jacobian.row(i).transpose() * tensions[i]
        })
    }

    /// `D = (∂Jᵀ/∂ζ¹ T, ∂Jᵀ/∂ζ² T, ∂Jᵀ/∂ζ³ T)` of eq. 45 (N·m/rad, frame A), at fixed tensions.
    ///
    /// With `P_i = I − u_i u_iᵀ`: `∂(a_i × u_i)/∂ζ = hat(a_i) P_i hat(Rᵀ b_i) / c_i`.
    pub fn jacobian_derivative_times_tensions(&self, tensions: &[f64; CABLES]) -> Matrix3<f64> {
        (0..CABLES).fold(Matrix3::zeros(), |d, i| {
            let u = self.directions_in_a[i];
            let projector = Matrix3::identity() - u * u.transpose();
            d + hat(&self.platform_points_in_a[i])
                * projector
                * hat(&self.base_points_in_a[i])
                * (tensions[i] / self.lengths[i])
        })
    }
}

/// Cable lengths (m) of `geometry` at pose `pose = ᴮ_A R`.
pub fn cable_lengths(
    geometry: &CsjmGeometry,
    pose: &Rotation3<f64>,
) -> Result<[f64; CABLES], CsjmError> {
    Ok(*CableKinematics::new(geometry, pose)?.lengths())
}

/// The 6×3 cable Jacobian (m, frame A) of `geometry` at pose `pose = ᴮ_A R`, row i = `(a_i × u_i)ᵀ`.
///
/// ```
/// use nalgebra::{Rotation3, Vector3};
/// use so3_stiffness::csjm::{jacobian, cable_lengths, CsjmGeometry};
/// use so3_stiffness::so3;
/// let g = CsjmGeometry::prototype();
/// let r = so3::exp(&Vector3::new(0.1, -0.05, 0.2));
/// let d = Vector3::new(1e-7, 2e-7, -1e-7);
/// let (c0, c1) = (cable_lengths(&g, &r).unwrap(), cable_lengths(&g, &(r * so3::exp(&d))).unwrap());
/// let predicted = -jacobian(&g, &r).unwrap() * d; // δC = −J δζ
/// for i in 0..6 {
///     assert!((c1[i] - c0[i] - predicted[i]).abs() < 1e-12);
/// }
/// ```
pub fn jacobian(
    geometry: &CsjmGeometry,
    pose: &Rotation3<f64>,
) -> Result<Matrix6x3<f64>, CsjmError> {
    Ok(*CableKinematics::new(geometry, pose)?.jacobian())
}
