//! Prediction of the tip deflection under a wrench (item 7).

use nalgebra::{DMatrix, DVector};

use crate::chain::{check_finite, SerialChain};
use crate::error::VjmError;
use crate::kinematics::{check_wrench, complementary_stiffness, jacobian};
use crate::model::VirtualJointModel;

/// The spring deflections Δθ (rad, one per spring) under `wrench` (N, N·m, base frame, at
/// the tip point) for compliances `compliance` (rad/(N·m)):
/// - without K_C: Δθ = C Jᵀ F (seed eq. 7);
/// - with K_C: the linearised equilibrium K_Θ Δθ = J(Δθ)ᵀF ≈ JᵀF + K_C Δθ, i.e.
///   Δθ = (I − C K_C)⁻¹ C Jᵀ F (seed eqs. 4–5, written with C so zero compliances are fine).
pub fn spring_deflection(
    chain: &SerialChain,
    model: &VirtualJointModel,
    compliance: &[f64],
    q: &[f64],
    wrench: &[f64; 6],
    with_kc: bool,
) -> Result<DVector<f64>, VjmError> {
    check_compliance(model, compliance)?;
    check_wrench(wrench, 0)?;
    let j = jacobian(chain, model, q)?;
    let f = DVector::from_column_slice(wrench);
    let c = DVector::from_column_slice(compliance);
    let tau = j.transpose() * f;
    let theta0 = c.component_mul(&tau);
    if !with_kc {
        return Ok(theta0);
    }
    let kc = complementary_stiffness(chain, model, q, wrench)?;
    identity_minus_c_times(&c, &kc)
        .lu()
        .solve(&theta0)
        .ok_or_else(|| VjmError::Numerical {
            message:
                "I − C·K_C is singular: the load reaches the buckling load of the spring model"
                    .into(),
        })
}

/// The tip deflection `[dx, dy, dz, rx, ry, rz]` (m, rad; base frame; rotation as a small
/// rotation vector) at joint positions `q` under `wrench`, `J Δθ` with Δθ from
/// [`spring_deflection`], with or without the complementary stiffness K_C.
///
/// ```
/// use vjm::{predict_deflection, SerialChain, VirtualJointModel};
/// let panda = SerialChain::bundled();
/// let model = VirtualJointModel::traditional(7);
/// let c = [1e-4; 7];
/// let q = [0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8];
/// let d = predict_deflection(&panda, &model, &c, &q, &[0.0, 0.0, -20.0, 0.0, 0.0, 0.0], false).unwrap();
/// assert!(d[2] < 0.0); // pushed down, it moves down
/// ```
pub fn predict_deflection(
    chain: &SerialChain,
    model: &VirtualJointModel,
    compliance: &[f64],
    q: &[f64],
    wrench: &[f64; 6],
    with_kc: bool,
) -> Result<[f64; 6], VjmError> {
    let theta = spring_deflection(chain, model, compliance, q, wrench, with_kc)?;
    let j = jacobian(chain, model, q)?;
    let d = j * theta;
    Ok([d[0], d[1], d[2], d[3], d[4], d[5]])
}

/// Checks that `compliance` has one finite value per spring of `model` (of any sign).
pub(crate) fn check_spring_vector(
    model: &VirtualJointModel,
    compliance: &[f64],
) -> Result<(), VjmError> {
    let m = model.n_params();
    if compliance.len() != m {
        return Err(VjmError::ShapeMismatch {
            what: "compliance (one per spring)",
            expected: m,
            got: compliance.len(),
        });
    }
    check_finite("compliance", compliance, 0, 0)
}

/// Checks that `compliance` has one finite value ≥ 0 per spring of `model` (rad/(N·m)).
pub(crate) fn check_compliance(
    model: &VirtualJointModel,
    compliance: &[f64],
) -> Result<(), VjmError> {
    check_spring_vector(model, compliance)?;
    if let Some(i) = compliance.iter().position(|&c| c < 0.0) {
        // A negative compliance is an unstable spring: the prediction would be meaningless.
        let s = model.springs()[i];
        return Err(VjmError::InvalidModel {
            message: format!(
                "compliance of spring J{}{} is {} rad/(N·m); compliances must be ≥ 0",
                s.joint + 1,
                s.axis,
                stiffness_core::num::Short(compliance[i])
            ),
        });
    }
    Ok(())
}

/// `I − C T` for the diagonal compliance `c` and a stiffness `t` (m×m): the tangent of the
/// springs' equilibrium `θ = C τ(θ)` where `t = ∂τ/∂θ`, in compliance form so that rigid
/// springs (c = 0) are fine.
pub(crate) fn identity_minus_c_times(c: &DVector<f64>, t: &DMatrix<f64>) -> DMatrix<f64> {
    let m = c.len();
    DMatrix::from_fn(m, m, |i, k| f64::from(u8::from(i == k)) - c[i] * t[(i, k)])
}
