//! Exact kinematics of a chain whose virtual springs are deflected: the testbed's own code path,
//! independent of the crate's analytic Jacobian and K_C (the tests compare the two).
//!
//! Every actuated joint j carries three virtual rotations about its child-frame spring axes
//! `[z, x, y] = [a, u, v]` (see [`crate::model::spring_axes`]), composed in that order after the
//! joint rotation and centred at the joint origin. Deflections `theta` are ordered joint-major,
//! `[z, x, y]` within a joint (3n values, rad).

use nalgebra::{DMatrix, Isometry3, Translation3, UnitQuaternion, Vector3};

use crate::chain::SerialChain;
use crate::model::spring_axes;

/// The tip point and the 3n-column virtual-joint Jacobian of a deflected chain, base frame.
#[derive(Debug, Clone)]
pub struct DeflectedPose {
    /// Tip point, base frame, m.
    pub tip: Vector3<f64>,
    /// 6×3n Jacobian, rows `[linear; angular]`, columns joint-major `[z, x, y]`: column s is
    /// `[ω_s × (p_tip − c_s); ω_s]` with ω_s the deflected spring axis and c_s its centre.
    pub jacobian: DMatrix<f64>,
}

fn rot(axis: &Vector3<f64>, angle: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_scaled_axis(axis * angle),
    )
}

/// Tip point and Jacobian at joint angles `q` (rad, n values) with spring deflections `theta`
/// (rad, 3n values). The caller guarantees the lengths (the testbed checks them once per
/// campaign).
pub fn deflected_pose(chain: &SerialChain, q: &[f64], theta: &[f64]) -> DeflectedPose {
    let n = chain.n_joints();
    let mut t = Isometry3::identity();
    let mut axes: Vec<Vector3<f64>> = Vec::with_capacity(3 * n);
    let mut centres: Vec<Vector3<f64>> = Vec::with_capacity(3 * n);
    for (j, joint) in chain.joints().iter().enumerate() {
        t = t * joint.origin() * rot(joint.axis(), q[j]);
        let local = spring_axes(joint.axis());
        for (k, w) in local.iter().enumerate() {
            axes.push(t.rotation * w);
            centres.push(t.translation.vector);
            t *= rot(w, theta[3 * j + k]);
        }
    }
    let tip = (t * chain.tip_offset()).translation.vector;
    let mut jac = DMatrix::zeros(6, 3 * n);
    for s in 0..3 * n {
        let lin = axes[s].cross(&(tip - centres[s]));
        for r in 0..3 {
            jac[(r, s)] = lin[r];
            jac[(r + 3, s)] = axes[s][r];
        }
    }
    DeflectedPose { tip, jacobian: jac }
}

/// Tip point only (cheaper), same conventions as [`deflected_pose`].
pub fn deflected_tip(chain: &SerialChain, q: &[f64], theta: &[f64]) -> Vector3<f64> {
    deflected_tip_frame(chain, q, theta).translation.vector
}

/// The tip frame (pose of the tip link in the base frame) of the deflected chain, same
/// conventions as [`deflected_pose`].
pub fn deflected_tip_frame(chain: &SerialChain, q: &[f64], theta: &[f64]) -> Isometry3<f64> {
    let mut t = Isometry3::identity();
    for (j, joint) in chain.joints().iter().enumerate() {
        t = t * joint.origin() * rot(joint.axis(), q[j]);
        for (k, w) in spring_axes(joint.axis()).iter().enumerate() {
            t *= rot(w, theta[3 * j + k]);
        }
    }
    t * chain.tip_offset()
}
