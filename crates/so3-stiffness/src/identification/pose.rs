//! Pose measurement with a laser tracker (seed eqs. 51–54).
//!
//! Frames: L is the tracker frame, B the base, A the platform (both with origin at O).
//! The base pose ᴸ_B T is fitted to three or more points H_i whose coordinates are known in
//! B (ᴮp_Hi, m) and measured in L (ᴸp_Hi, m). The seed solves eq. 51 exactly with three
//! points and a cross-product fourth column (eq. 52), which yields a non-orthonormal matrix as
//! soon as the points are noisy; here the rigid transform minimising Σ‖ᴸp_i − ᴸ_B T ᴮp_i‖² is
//! computed (Kabsch/Horn, via SVD), which coincides with eq. 51 for exact data and reports the
//! fit residual otherwise.

use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

use super::error::IdentificationError;
use crate::so3;

/// Rigid fit of a frame to tracker points.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameFit {
    /// The fitted pose ᴸ_B T (maps B-coordinates to L-coordinates, m).
    pub transform: Isometry3<f64>,
    /// Distance between each measured point and its fitted position, m, in input order.
    pub residuals: Vec<f64>,
    /// RMS of [`FrameFit::residuals`], m (0 for three exact points).
    pub rms_residual: f64,
}

/// Least-squares rigid transform ᴸ_B T with ᴸp_i ≈ ᴸ_B T ᴮp_i (eq. 51 for N ≥ 3 points).
///
/// `points_in_base[i]` = ᴮp_Hi, `points_in_tracker[i]` = ᴸp_Hi, in m. Errors if fewer than
/// three points are given, the slices differ in length, a coordinate is not finite, or the
/// points are (nearly) collinear, in which case the rotation is not determined.
pub fn fit_frame_to_points(
    points_in_base: &[Point3<f64>],
    points_in_tracker: &[Point3<f64>],
) -> Result<FrameFit, IdentificationError> {
    let n = points_in_base.len();
    if n != points_in_tracker.len() {
        return Err(IdentificationError::LengthMismatch {
            what: "fit_frame_to_points (base points vs tracker points)",
            left: n,
            right: points_in_tracker.len(),
        });
    }
    if n < 3 {
        return Err(IdentificationError::Degenerate {
            message: format!(
                "{n} tracker points given; the base frame needs at least 3 non-collinear points"
            ),
        });
    }
    if !points_in_base
        .iter()
        .chain(points_in_tracker)
        .all(|p| p.coords.iter().all(|x| x.is_finite()))
    {
        return Err(IdentificationError::NonFiniteInput {
            what: "tracker point coordinates",
        });
    }
    let centroid =
        |pts: &[Point3<f64>]| pts.iter().map(|p| p.coords).sum::<Vector3<f64>>() / pts.len() as f64;
    let cb = centroid(points_in_base);
    let cl = centroid(points_in_tracker);
    let mut h = Matrix3::zeros();
    let mut spread = Matrix3::zeros();
    for (pb, pl) in points_in_base.iter().zip(points_in_tracker) {
        let db = pb.coords - cb;
        h += (pl.coords - cl) * db.transpose();
        spread += db * db.transpose();
    }
    // Collinear points: the B-side scatter has rank ≤ 1 and the rotation about the line is free.
    let sv = spread.symmetric_eigenvalues();
    let (largest, middle) = {
        let mut s = [sv[0], sv[1], sv[2]];
        s.sort_by(|a, b| b.total_cmp(a));
        (s[0], s[1])
    };
    if !(middle > 1e-12 * largest) || !(largest > 0.0) {
        return Err(IdentificationError::Degenerate {
            message: "the tracker points in the base frame are collinear (or coincident); \
                      the base orientation is not determined"
                .into(),
        });
    }
    let svd = h.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(IdentificationError::SvdFailed);
    };
    // R = U diag(1, 1, det(U Vᵀ)) Vᵀ: the nearest proper rotation (no reflection).
    let d = (u * v_t).determinant().signum();
    let r = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t;
    let rotation = Rotation3::from_matrix_unchecked(r);
    let t = cl - rotation * cb;
    let transform = Isometry3::from_parts(
        Translation3::from(t),
        UnitQuaternion::from_rotation_matrix(&rotation),
    );
    let residuals: Vec<f64> = points_in_base
        .iter()
        .zip(points_in_tracker)
        .map(|(pb, pl)| (transform * pb - pl).norm())
        .collect();
    let rms_residual = (residuals.iter().map(|r| r * r).sum::<f64>() / n as f64).sqrt();
    Ok(FrameFit {
        transform,
        residuals,
        rms_residual,
    })
}

/// ᴮ_A T = ᴸ_B T⁻¹ ᴸ_A T (eq. 53). The platform orientation is its rotation ᴮ_A R; its
/// translation ᴮ_A p should be ≈ 0 because A and B share the origin O (eq. 54).
pub fn platform_in_base(
    tracker_base: &Isometry3<f64>,
    tracker_platform: &Isometry3<f64>,
) -> Isometry3<f64> {
    tracker_base.inverse() * tracker_platform
}

/// Body-frame displacement Δζ = log(R₀ᵀ R), rad, components in A at R₀ (so R = R₀ exp(hat Δζ)).
pub fn body_displacement(r0: &Rotation3<f64>, r: &Rotation3<f64>) -> Vector3<f64> {
    so3::log(&(r0.inverse() * r))
}
