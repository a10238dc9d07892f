//! Per-row kinematics of the diagnosis, computed on the fly in every pass (never stored for
//! all rows): the 3n-spring Jacobian at the tip point, spring torques, tip frame, and the exact
//! deflected-equilibrium response the geometric non-linearity candidate needs.
//!
//! Everything here is the crate's own kinematics (`vjm::kinematics`, re-exported as [`crate::jacobian`] and friends); the diagnosis does
//! not use the testbed, which is the independent code path the tests check it against.

use nalgebra::{DMatrix, Isometry3, UnitQuaternion, Vector3};

use super::candidates::{torque_sigma, RowKinematics};
use crate::chain::SerialChain;
use crate::dataset::Dataset;
use crate::kinematics::{jacobian_in_place, Workspace};
use crate::model::VirtualJointModel;

/// Reusable scratch that turns a dataset row into [`RowKinematics`].
#[derive(Debug, Clone)]
pub struct RowBuilder<'a> {
    chain: &'a SerialChain,
    model: VirtualJointModel,
    ws: Workspace,
    jac: Vec<f64>,
    wrench_sigma: [f64; 6],
    /// Per joint: its spring axes `[z, x, y]` in its child frame.
    local_axes: Vec<[Vector3<f64>; 3]>,
}

impl<'a> RowBuilder<'a> {
    /// Scratch for `chain`; `wrench_sigma` is the recorded wrench's per-axis noise (N, N·m)
    /// that sets each row's torsion-torque noise (backlash candidate).
    pub fn new(chain: &'a SerialChain, wrench_sigma: [f64; 6]) -> Self {
        let model = VirtualJointModel::extended(chain.n_joints());
        let ws = Workspace::new(chain, &model).expect("the extended model fits its own chain");
        let jac = vec![0.0; 6 * model.n_params()];
        let local_axes = chain
            .joints()
            .iter()
            .map(|j| crate::model::spring_axes(j.axis()))
            .collect();
        Self {
            chain,
            model,
            ws,
            jac,
            wrench_sigma,
            local_axes,
        }
    }

    /// The kinematics of row `i` of `data` (finite-checked on entry, so the evaluation
    /// cannot fail).
    pub fn row(&mut self, data: &Dataset<'_>, i: usize) -> RowKinematics {
        let q = data.q(i).to_vec();
        jacobian_in_place(self.chain, &self.model, &q, &mut self.ws, &mut self.jac)
            .expect("dataset rows are checked against the chain");
        let m = self.model.n_params();
        let jacobian = DMatrix::from_column_slice(6, m, &self.jac);
        let wrench = data.wrench(i);
        let tau: Vec<f64> = (0..m)
            .map(|s| (0..6).map(|r| jacobian[(r, s)] * wrench[r]).sum())
            .collect();
        let tau_sigma = torque_sigma(&jacobian, &self.wrench_sigma);
        // The tip frame of the evaluation the Jacobian came from (no second forward pass).
        let t = self.ws.p;
        RowKinematics {
            q,
            jacobian,
            tau,
            wrench,
            displacement: data.displacement(i),
            tip: [t.x, t.y, t.z],
            tau_sigma,
            tip_rotation: self.ws.tip_rotation(self.chain),
        }
    }

    /// The exact tip displacement (m, base frame) of linear springs of compliances `c` (3n,
    /// rad/(N·m)) under the row's wrench, with equilibrium in the deflected configuration:
    /// the fixed point `θ = C J(θ)ᵀ W`, then the deflected tip minus the unloaded one.
    ///
    /// The same kinematics as `vjm::kinematics::jacobian_deflected` (springs at the joint
    /// origins, composed `[z, x, y]` after the joint rotation), written for this loop: the
    /// joint rotations are composed once per row, nothing is allocated per iteration, and
    /// only the spring torques `J(θ)ᵀ W` are formed, not the Jacobian.
    pub fn exact_displacement(&self, row: &RowKinematics, c: &[f64]) -> [f64; 3] {
        let joints = self.chain.joints();
        let n = joints.len();
        let tq: Vec<Isometry3<f64>> = joints
            .iter()
            .zip(&row.q)
            .map(|(j, q)| {
                j.origin()
                    * Isometry3::from_parts(
                        nalgebra::Translation3::identity(),
                        UnitQuaternion::from_scaled_axis(j.axis() * *q),
                    )
            })
            .collect();
        let f = Vector3::new(row.wrench[0], row.wrench[1], row.wrench[2]);
        let m = Vector3::new(row.wrench[3], row.wrench[4], row.wrench[5]);
        let mut axes = vec![Vector3::zeros(); 3 * n];
        let mut centres = vec![Vector3::zeros(); 3 * n];
        // A spring of zero compliance never deflects: its rotation is the identity, which
        // composes exactly, so it is skipped (the traditional model's 2n tilts, at no change
        // to a single bit of the result).
        let active: Vec<bool> = c.iter().map(|ci| *ci != 0.0).collect();
        // The deflected tip point for deflections θ; fills the active springs' axes and
        // centres.
        let tip_at = |theta: &[f64], axes: &mut [Vector3<f64>], centres: &mut [Vector3<f64>]| {
            let mut t = Isometry3::identity();
            for (j, (tqj, locals)) in tq.iter().zip(&self.local_axes).enumerate() {
                t *= tqj;
                for (k, local) in locals.iter().enumerate() {
                    let s = 3 * j + k;
                    if !active[s] {
                        continue;
                    }
                    axes[s] = t.rotation * local;
                    centres[s] = t.translation.vector;
                    t.rotation *= spring_rotation(local, theta[s]);
                }
            }
            (t * self.chain.tip_offset()).translation.vector
        };
        let mut theta: Vec<f64> = row.tau.iter().zip(c).map(|(t, ci)| t * ci).collect();
        let mut next = vec![0.0; theta.len()];
        // |C·K_C| is of order |W|·reach·c ≈ 1e-2, so the iteration contracts fast; 100 steps
        // is a cap, not an expectation. The tip is the one at the last θ whose update moved it
        // by ≤ 1e-14 relative: it differs from the fixed point's by as little (about 1e-12 of
        // the column, which is the deflection's second-order part), so no further evaluation.
        let mut p = tip_at(&theta, &mut axes, &mut centres);
        for _ in 0..100 {
            for s in (0..theta.len()).filter(|s| active[*s]) {
                let tau = axes[s].cross(&(p - centres[s])).dot(&f) + axes[s].dot(&m);
                next[s] = c[s] * tau;
            }
            let change = next
                .iter()
                .zip(&theta)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            let scale = next.iter().map(|a| a.abs()).fold(1e-300, f64::max);
            if change <= 1e-14 * scale {
                break;
            }
            std::mem::swap(&mut theta, &mut next);
            p = tip_at(&theta, &mut axes, &mut centres);
        }
        [p.x - row.tip[0], p.y - row.tip[1], p.z - row.tip[2]]
    }
}

/// The rotation by `angle` (rad) about the unit axis `axis`. Spring deflections are of order
/// 1e-4 rad, where the Taylor series of `sin(θ/2)` and `cos(θ/2)` to the terms kept is exact
/// in double precision (the first term left out is below 1e-25 relative for |θ| < 1e-3); the
/// diagnosis evaluates 3n of them per iteration of every row's deflected equilibrium, so
/// they skip the library `sin_cos` and the normalisation of `from_scaled_axis`.
fn spring_rotation(axis: &Vector3<f64>, angle: f64) -> UnitQuaternion<f64> {
    if angle.abs() >= 1e-3 {
        return UnitQuaternion::from_scaled_axis(axis * angle);
    }
    let h = 0.5 * angle;
    let h2 = h * h;
    let sin = h * (1.0 - h2 / 6.0 * (1.0 - h2 / 20.0 * (1.0 - h2 / 42.0)));
    let cos = 1.0 - h2 / 2.0 * (1.0 - h2 / 12.0 * (1.0 - h2 / 30.0));
    let v = axis * sin;
    UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(cos, v.x, v.y, v.z))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The series branch against the library's rotation, on both sides of the switch, at the
    /// fixtures 0 and 1e-8, and about a skew axis.
    #[test]
    fn spring_rotation_equals_the_exponential_map() {
        let axes = [
            Vector3::z(),
            Vector3::x(),
            Vector3::new(0.3, -0.5, 0.8).normalize(),
        ];
        for axis in &axes {
            for angle in [
                0.0, 1e-8, -3e-6, 1e-4, -2.5e-4, 9.999e-4, -9.999e-4, 1e-3, 0.7,
            ] {
                let ours = spring_rotation(axis, angle);
                let lib = UnitQuaternion::from_scaled_axis(axis * angle);
                let d = (ours.coords - lib.coords).amax();
                assert!(d <= 2.0 * f64::EPSILON, "angle {angle}: off by {d:e}");
                assert!((ours.coords.norm() - 1.0).abs() <= 2.0 * f64::EPSILON);
            }
        }
    }
}
