//! The rotation group SO(3): exponential and logarithm, hat/vee, adjoint, Jacobians, bracket,
//! geodesic distance, and explicit checks/projections for measured matrices.
//!
//! Vocabulary as in Sophus/manif. Conventions (see `docs/conventions.md`):
//! - `hat(ω) v = ω × v`, `vee` is its inverse (of the skew part).
//! - Perturbations are **body-frame (right)**: `R · exp(hat(δ))`.
//! - `exp(ω + δ) ≈ exp(ω) · exp(J_r(ω) δ)` and `exp(ω + δ) ≈ exp(J_l(ω) δ) · exp(ω)`.
//! - `adjoint(R) = R`, i.e. `R hat(ω) Rᵀ = hat(R ω)`.
//!
//! All angles are in radians. Every function is branch-safe near θ = 0 (Taylor series) and
//! [`log`] extracts the axis from the symmetric part near θ = π, where dividing by sin θ would
//! lose all precision.
//!
//! ```
//! use nalgebra::Vector3;
//! use stiffness_core::so3;
//! let w = Vector3::new(0.1, -0.2, 0.3);
//! let r = so3::exp(&w);
//! assert!((so3::log(&r) - w).norm() < 1e-15);
//! ```


use nalgebra::{Matrix3, Rotation3, Vector3};

use crate::fast_math;
use crate::so3_error::So3Error;

/// Below this angle the Jacobian coefficients use their Taylor series: the closed forms
/// subtract nearly equal numbers (θ − sin θ, 1/θ² − cot(θ/2)/(2θ)) and lose digits.
/// The series are carried to θ⁸ so that the truncation error at θ = 0.1 is below 1e-19.
const SERIES_ANGLE: f64 = 0.1;

/// Skew-symmetric matrix of `w`: `hat(w) v = w × v`.
pub fn hat(w: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -w.z, w.y, w.z, 0.0, -w.x, -w.y, w.x, 0.0)
}

/// Inverse of [`hat`], applied to the skew-symmetric part `(m − mᵀ)/2` of `m`.
pub fn vee(m: &Matrix3<f64>) -> Vector3<f64> {
    0.5 * Vector3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    )
}

/// sin(x)/x, exact to rounding for all x.
fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-4 {
        let x2 = x * x;
        1.0 - x2 / 6.0 + x2 * x2 / 120.0
    } else {
        x.sin() / x
    }
}

/// Coefficients (sin θ/θ, (1 − cos θ)/θ², (θ − sin θ)/θ³) of the Rodrigues-type formulas.
fn rodrigues_coefficients(theta: f64) -> (f64, f64, f64) {
    let t2 = theta * theta;
    let a = sinc(theta);
    // 1 − cos θ = 2 sin²(θ/2): no cancellation.
    let half_sinc = sinc(0.5 * theta);
    let b = 0.5 * half_sinc * half_sinc;
    let c = if theta < SERIES_ANGLE {
        // Σ (−1)^k θ^{2k} / (2k+3)!
        1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0 - t2 * t2 * t2 / 362_880.0
            + t2 * t2 * t2 * t2 / 39_916_800.0
    } else {
        (theta - theta.sin()) / (t2 * theta)
    };
    (a, b, c)
}

/// Exponential map: the rotation by angle ‖w‖ about w/‖w‖ (Rodrigues' formula).
pub fn exp(w: &Vector3<f64>) -> Rotation3<f64> {
    // R = I + a·hat(w) + b·hat(w)² with hat(w)² = w wᵀ − θ² I, i.e.
    // R = cos θ·I + a·hat(w) + b·w wᵀ: one sin_cos and no matrix product (hot path).
    let t2 = w.norm_squared();
    if !(t2 <= LARGE_SQUARED_NORM) {
        // ‖w‖² overflows (or w is not finite): the cold path with a scaled norm.
        return exp_large(w);
    }
    let (a, b, cos_t) = if t2 < 1e-8 {
        // θ < 1e-4: truncation error below θ⁶/5040 < 1e-27.
        let b = 0.5 - t2 / 24.0 + t2 * t2 / 720.0;
        (1.0 - t2 / 6.0 + t2 * t2 / 120.0, b, 1.0 - b * t2)
    } else {
        let theta = t2.sqrt();
        let (sin_t, cos_t) = theta.sin_cos();
        // 1 − cos θ without cancellation: sin²θ/(1 + cos θ) while cos θ > 0.
        let one_minus_cos = if cos_t > 0.0 {
            sin_t * sin_t / (1.0 + cos_t)
        } else {
            1.0 - cos_t
        };
        (sin_t / theta, one_minus_cos / t2, cos_t)
    };
    let (x, y, z) = (w.x, w.y, w.z);
    let (bxy, bxz, byz) = (b * x * y, b * x * z, b * y * z);
    Rotation3::from_matrix_unchecked(Matrix3::new(
        cos_t + b * x * x,
        bxy - a * z,
        bxz + a * y,
        bxy + a * z,
        cos_t + b * y * y,
        byz - a * x,
        bxz - a * y,
        byz + a * x,
        cos_t + b * z * z,
    ))
}

/// Above this ‖w‖² the products in [`exp`] and the Jacobians may overflow; [`axis_angle`]
/// takes over. (θ ≈ 1e150 rad: no physical rotation vector comes near.)
const LARGE_SQUARED_NORM: f64 = 1e300;

/// Unit axis n and the half angle θ/2 of a rotation vector w with ‖w‖² beyond
/// [`LARGE_SQUARED_NORM`], computed without overflow: w is scaled by its largest component
/// first, and the half angle is kept because θ itself may exceed `f64::MAX` (‖w‖ ≤ √3·MAX).
/// Non-finite w gives NaN (the bindings refuse it before).
fn axis_half_angle(w: &Vector3<f64>) -> (Vector3<f64>, f64) {
    let s = w.amax();
    let u = w / s;
    let un = u.norm();
    (u / un, (0.5 * s) * un)
}

/// [`exp`] for huge w: R = I + sin θ hat(n) + (1 − cos θ) hat(n)², with sin θ = 2 sin(θ/2)
/// cos(θ/2) and 1 − cos θ = 2 sin²(θ/2) from the half angle.
#[cold]
fn exp_large(w: &Vector3<f64>) -> Rotation3<f64> {
    let (n, half) = axis_half_angle(w);
    let (sh, ch) = half.sin_cos();
    let sin_t = 2.0 * sh * ch;
    let one_minus_cos = 2.0 * sh * sh;
    let k = hat(&n);
    Rotation3::from_matrix_unchecked(Matrix3::identity() + sin_t * k + one_minus_cos * (k * k))
}

/// Logarithm map: the rotation vector ω with `exp(ω) = r` and ‖ω‖ ∈ [0, π].
///
/// Exact at the identity; relative accuracy ~1e-16 for small angles; near θ = π the axis is
/// taken from the symmetric part `(R + Rᵀ)/2 = cos θ I + (1 − cos θ) n nᵀ` and only its sign
/// from the skew part. At exactly θ = π either of the two valid answers ±π n may be returned.
///
/// θ is not taken from libm's `atan2` but reduced by cos θ to atan(u) with |u| ≤ tan(π/6),
/// evaluated by a polynomial in u² (`fast_math`), which needs no square root and so overlaps
/// with the normalisation: θ = 2 atan(tan(θ/2)) for cos θ > ½, θ = π/2 − atan(cot θ) for
/// |cos θ| ≤ ½, θ = π − 2 atan(tan((π − θ)/2)) for cos θ < −½.
pub fn log(r: &Rotation3<f64>) -> Vector3<f64> {
    let m = r.matrix();
    // vee(R) = sin θ · n; cos θ = (tr R − 1)/2, summed as a tree (a shorter dependency chain
    // than `trace() − 1`).
    let s_vec = vee(m);
    let c = 0.5 * ((m[(0, 0)] + m[(1, 1)]) + (m[(2, 2)] - 1.0));
    let ss = s_vec.norm_squared(); // = sin²θ
    if c < -0.5 {
        return log_near_pi(m, &s_vec, c);
    }
    if c > 0.5 {
        // θ < π/3: ω = θ/sin θ · vee(R).
        if ss < 1e-8 {
            // θ < 1e-4: θ/sin θ = asin(s)/s = 1 + s²/6 + 3s⁴/40 + O(s⁶), s⁶ < 1e-24. No
            // division: θ = 0 gives exactly 0, and tiny θ keeps full relative accuracy
            // even where sin²θ underflows.
            return (1.0 + ss * (1.0 / 6.0 + ss * (3.0 / 40.0))) * s_vec;
        }
        // τ = tan(θ/2) = s/(1 + c) ≤ tan(π/6): θ/sin θ = 2 atan(τ)/s = 2(1 + τ² f(τ²))/(1 + c).
        // No square root and no cancellation.
        let one_plus_c = 1.0 + c;
        let tau2 = ss / (one_plus_c * one_plus_c);
        return ((2.0 + (2.0 * tau2) * fast_math::atan_tail(tau2)) / one_plus_c) * s_vec;
    }
    // θ ∈ [π/3, 2π/3]: sin θ ≥ 0.86, so the axis from vee(R) is as good as the symmetric
    // part's. t = cot θ = c/s, |t| ≤ tan(π/6): θ = π/2 − atan(t) = π/2 − t − t·t² f(t²), with t²
    // formed before the square root.
    let cot2 = (c * c) / ss;
    let poly = cot2 * fast_math::atan_tail(cot2);
    let s = ss.sqrt();
    let t = c / s;
    // π/2 as FRAC_PI_2 + its low part, so that θ is rounded once.
    let theta = std::f64::consts::FRAC_PI_2 + ((6.123_233_995_736_766e-17 - t * poly) - t);
    (theta / s) * s_vec
}

/// [`log`] for cos θ = `c` < −½ (θ > 2π/3), from the matrix `m` and `s_vec` = vee(m).
#[inline]
fn log_near_pi(m: &Matrix3<f64>, s_vec: &Vector3<f64>, c: f64) -> Vector3<f64> {
    // n nᵀ ∝ (R + Rᵀ)/2 − cos θ I. Its column k with the largest diagonal entry (the largest
    // R_kk) is the best-conditioned multiple of n: v = (R + Rᵀ)e_k − 2c e_k, with no division
    // by sin θ. Scale factors drop out in the normalisation below.
    let d = m.diagonal();
    let k = if d.x >= d.y {
        if d.x >= d.z {
            0
        } else {
            2
        }
    } else if d.y >= d.z {
        1
    } else {
        2
    };
    // e_k without indexing a temporary (a scalar store into it stalls the vector reload).
    let e_k = Vector3::new(
        f64::from(u8::from(k == 0)),
        f64::from(u8::from(k == 1)),
        f64::from(u8::from(k == 2)),
    );
    let v = m.column(k) + m.row(k).transpose() - (2.0 * c) * e_k;
    let vv = v.norm_squared();
    // The sign of the axis from the skew part, and sin θ as the projection n·vee(R) = dot/‖v‖,
    // which (unlike ‖vee(R)‖) does not pick up the rounding noise of vee(R) across the axis as
    // sin θ → 0.
    let dot = v.dot(s_vec);
    // τ = tan((π − θ)/2) = sin θ/(1 − c) = |dot|/(‖v‖(1 − c)) ≤ tan(π/6):
    // θ = π − 2 atan(τ) = π − 2τ − 2τ·τ² f(τ²), with τ² formed before the square root.
    let one_minus_c = 1.0 - c;
    let tau2 = (dot * dot) / (vv * (one_minus_c * one_minus_c));
    let poly = tau2 * fast_math::atan_tail(tau2);
    let norm = vv.sqrt();
    let two_tau = 2.0 * dot.abs() / (norm * one_minus_c);
    // π as PI + its low part, so that θ is rounded once.
    let theta = std::f64::consts::PI + ((1.224_646_799_147_353_2e-16 - two_tau * poly) - two_tau);
    let factor = theta / norm;
    (if dot < 0.0 { -factor } else { factor }) * v
}

/// Adjoint of SO(3): `adjoint(r) = r`, so that `r hat(ω) rᵀ = hat(r ω)`.
pub fn adjoint(r: &Rotation3<f64>) -> Matrix3<f64> {
    *r.matrix()
}

/// Left Jacobian: `exp(w + δ) ≈ exp(left_jacobian(w) δ) · exp(w)`.
pub fn left_jacobian(w: &Vector3<f64>) -> Matrix3<f64> {
    if !(w.norm_squared() <= LARGE_SQUARED_NORM) {
        // J = I + (1 − cos θ)/θ hat(n) + (1 − sin θ/θ) hat(n)², from the half angle (the
        // θ-power form overflows).
        let (n, half) = axis_half_angle(w);
        let (sh, ch) = half.sin_cos();
        let k = hat(&n);
        // θ = 2·half may overflow to ∞: then sh²/half → 0 and sin θ/θ → 0, the limits.
        return Matrix3::identity() + (sh * sh / half) * k + (1.0 - sh * ch / half) * (k * k);
    }
    let (_, b, c) = rodrigues_coefficients(w.norm());
    let k = hat(w);
    Matrix3::identity() + b * k + c * k * k
}

/// Right Jacobian: `exp(w + δ) ≈ exp(w) · exp(right_jacobian(w) δ)`; equals `left_jacobian(−w)`.
pub fn right_jacobian(w: &Vector3<f64>) -> Matrix3<f64> {
    left_jacobian(&-w)
}

/// Coefficient of hat(w)² in the inverse Jacobians: 1/θ² − (1 + cos θ)/(2 θ sin θ).
///
/// Singular (non-finite) at θ = 2π k, k ≥ 1, where the Jacobian itself is singular.
fn inverse_jacobian_coefficient(theta: f64) -> f64 {
    if theta < SERIES_ANGLE {
        let t2 = theta * theta;
        1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30_240.0 + t2 * t2 * t2 / 1_209_600.0
    } else {
        // (1 + cos θ)/sin θ = cot(θ/2) stays finite at θ = π.
        1.0 / (theta * theta) - 1.0 / (2.0 * theta * (0.5 * theta).tan())
    }
}

/// Inverse of [`left_jacobian`] (closed form). Singular at ‖w‖ = 2π k, k ≥ 1.
pub fn left_jacobian_inverse(w: &Vector3<f64>) -> Matrix3<f64> {
    if !(w.norm_squared() <= LARGE_SQUARED_NORM) {
        // J⁻¹ = I − (θ/2) hat(n) + (1 − (θ/2) cot(θ/2)) hat(n)²: entries of order θ, finite
        // while θ/2 is (always, for finite w), unless cot(θ/2) is itself huge.
        let (n, half) = axis_half_angle(w);
        let k = hat(&n);
        return Matrix3::identity() - half * k + (1.0 - half / half.tan()) * (k * k);
    }
    let k = hat(w);
    Matrix3::identity() - 0.5 * k + inverse_jacobian_coefficient(w.norm()) * k * k
}

/// Inverse of [`right_jacobian`] (closed form). Singular at ‖w‖ = 2π k, k ≥ 1.
pub fn right_jacobian_inverse(w: &Vector3<f64>) -> Matrix3<f64> {
    left_jacobian_inverse(&-w)
}

/// Lie bracket of so(3) in vector form: `vee(hat(a) hat(b) − hat(b) hat(a)) = a × b`.
pub fn bracket(a: &Vector3<f64>, b: &Vector3<f64>) -> Vector3<f64> {
    a.cross(b)
}

/// Geodesic distance (bi-invariant metric): `‖log(aᵀ b)‖` ∈ [0, π], in rad.
pub fn distance(a: &Rotation3<f64>, b: &Rotation3<f64>) -> f64 {
    log(&(a.inverse() * b)).norm()
}

/// Orthogonality error `‖mᵀ m − I‖_F` of a 3×3 matrix (0 for an exact rotation or reflection).
pub fn orthogonality_error(m: &Matrix3<f64>) -> f64 {
    (m.transpose() * m - Matrix3::identity()).norm()
}

fn check_finite(m: &Matrix3<f64>, what: &'static str) -> Result<(), So3Error> {
    for col in 0..3 {
        for row in 0..3 {
            if !m[(row, col)].is_finite() {
                return Err(So3Error::NonFinite { what, row, col });
            }
        }
    }
    Ok(())
}

/// The rotation nearest to `m` in the Frobenius norm (orthogonal polar factor, via SVD).
///
/// Use this, explicitly, for measured matrices (e.g. from a tracker) that are only
/// approximately orthonormal. Errors if `m` has a non-finite entry, `det m ≤ 0` (its nearest
/// orthogonal matrix would be a reflection), or `m` is numerically rank deficient.
///
/// ```
/// use nalgebra::{Matrix3, Vector3};
/// use stiffness_core::so3;
/// let noisy = so3::exp(&Vector3::new(0.3, 0.0, 0.1)).into_inner() + Matrix3::repeat(1e-4);
/// let r = so3::project_to_rotation(&noisy).unwrap();
/// assert!(so3::orthogonality_error(r.matrix()) < 1e-14);
/// ```
pub fn project_to_rotation(m: &Matrix3<f64>) -> Result<Rotation3<f64>, So3Error> {
    check_finite(m, "matrix to project")?;
    let det = m.determinant();
    if det <= 0.0 {
        return Err(So3Error::NonPositiveDeterminant { det });
    }
    let svd = m.svd(true, true);
    let mut sv: [f64; 3] = [
        svd.singular_values[0],
        svd.singular_values[1],
        svd.singular_values[2],
    ];
    sv.sort_by(|a, b| b.total_cmp(a));
    if !(sv[2] > sv[0] * 1e3 * f64::EPSILON) {
        return Err(So3Error::RankDeficient {
            singular_values: sv,
        });
    }
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(So3Error::RankDeficient {
            singular_values: sv,
        });
    };
    // det m > 0 and all σ > 0 ⇒ det(U Vᵀ) = +1: a proper rotation.
    Ok(Rotation3::from_matrix_unchecked(u * v_t))
}

/// Strict conversion: accepts `m` only if `‖mᵀm − I‖_F ≤ tol` and `det m > 0`; returns it
/// unchanged (never silently re-orthonormalised).
///
/// ```
/// use nalgebra::Matrix3;
/// use stiffness_core::so3;
/// assert!(so3::rotation_from_matrix(&Matrix3::identity(), 1e-12).is_ok());
/// assert!(so3::rotation_from_matrix(&(Matrix3::identity() * 1.01), 1e-6).is_err());
/// ```
pub fn rotation_from_matrix(m: &Matrix3<f64>, tol: f64) -> Result<Rotation3<f64>, So3Error> {
    check_finite(m, "rotation matrix")?;
    let error = orthogonality_error(m);
    if !(error <= tol) {
        return Err(So3Error::NotOrthogonal { error, tol });
    }
    let det = m.determinant();
    if det <= 0.0 {
        return Err(So3Error::NonPositiveDeterminant { det });
    }
    Ok(Rotation3::from_matrix_unchecked(*m))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rot_err(a: &Rotation3<f64>, b: &Rotation3<f64>) -> f64 {
        (a.matrix() - b.matrix()).norm()
    }

    #[test]
    fn log_is_exact_at_identity() {
        assert_eq!(log(&Rotation3::identity()), Vector3::zeros());
    }

    #[test]
    fn log_small_angle_is_accurate() {
        let w = Vector3::new(0.6, -0.48, 0.64) * 1e-8; // ‖w‖ = 1e-8
        let rel = (log(&exp(&w)) - w).norm() / w.norm();
        assert!(rel < 1e-12, "relative error {rel:e}");
    }

    #[test]
    fn log_near_and_at_pi() {
        let n = Vector3::new(1.0, 2.0, -2.0) / 3.0;
        for theta in [
            std::f64::consts::PI - 1e-9,
            std::f64::consts::PI - 1e-6,
            2.0,
        ] {
            let w = n * theta;
            assert!((log(&exp(&w)) - w).norm() < 1e-9, "θ = {theta}");
        }
        let w = n * std::f64::consts::PI;
        let l = log(&exp(&w));
        assert!((l - w).norm() < 1e-9 || (l + w).norm() < 1e-9, "{l:?}");
        assert!(rot_err(&exp(&l), &exp(&w)) < 1e-12);
    }

    #[test]
    fn rodrigues_matches_nalgebra() {
        let w = Vector3::new(0.7, -1.1, 2.3);
        assert!(rot_err(&exp(&w), &Rotation3::new(w)) < 1e-14);
    }

    #[test]
    fn right_jacobian_first_order() {
        let w = Vector3::new(0.4, -0.9, 1.7);
        let d = Vector3::new(1e-6, -2e-6, 0.5e-6);
        let lhs = log(&(exp(&w).inverse() * exp(&(w + d))));
        assert!((lhs - right_jacobian(&w) * d).norm() < 1e-11);
        let lhs = log(&(exp(&(w + d)) * exp(&w).inverse()));
        assert!((lhs - left_jacobian(&w) * d).norm() < 1e-11);
    }

    #[test]
    fn inverses_are_inverses() {
        for w in [
            Vector3::new(0.01, 0.02, -0.03),
            Vector3::new(1.0, -2.0, 0.5),
        ] {
            let e = (right_jacobian(&w) * right_jacobian_inverse(&w) - Matrix3::identity()).norm();
            assert!(e < 1e-13);
            let e = (left_jacobian(&w) * left_jacobian_inverse(&w) - Matrix3::identity()).norm();
            assert!(e < 1e-13);
        }
    }

    #[test]
    fn projection_and_strict_conversion() {
        let r = exp(&Vector3::new(0.2, 0.3, -0.1));
        let noisy = r.matrix() * 1.001;
        assert!(matches!(
            rotation_from_matrix(&noisy, 1e-6),
            Err(So3Error::NotOrthogonal { .. })
        ));
        assert!(rot_err(&project_to_rotation(&noisy).unwrap(), &r) < 1e-14);
        let reflection = -Matrix3::<f64>::identity();
        assert!(matches!(
            project_to_rotation(&reflection),
            Err(So3Error::NonPositiveDeterminant { .. })
        ));
        let mut nan = Matrix3::identity();
        nan[(1, 2)] = f64::NAN;
        assert_eq!(
            project_to_rotation(&nan),
            Err(So3Error::NonFinite {
                what: "matrix to project",
                row: 1,
                col: 2
            })
        );
    }
}
