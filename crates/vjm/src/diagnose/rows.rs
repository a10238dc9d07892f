//! Per-row kinematics of the diagnosis, computed on the fly in every pass (never stored for
//! all rows): the 3n-spring Jacobian at the tip point, spring torques, tip frame, and the exact
//! deflected-equilibrium response the geometric non-linearity candidate needs.
//!
//! Everything here is the crate's own kinematics (`vjm::kinematics`, re-exported as [`crate::jacobian`] and friends); the diagnosis does
//! not use the testbed, which is the independent code path the tests check it against.

use nalgebra::{DMatrix, DVector};

use super::candidates::{torque_sigma, RowKinematics};
use crate::chain::SerialChain;
use crate::dataset::Dataset;
use crate::kinematics::{
    forward_kinematics_deflected, jacobian_deflected, jacobian_in_place, Workspace,
};
use crate::model::VirtualJointModel;

/// Reusable scratch that turns a dataset row into [`RowKinematics`].
#[derive(Debug, Clone)]
pub struct RowBuilder<'a> {
    chain: &'a SerialChain,
    model: VirtualJointModel,
    ws: Workspace,
    jac: Vec<f64>,
    wrench_sigma: [f64; 6],
}

impl<'a> RowBuilder<'a> {
    /// Scratch for `chain`; `wrench_sigma` is the recorded wrench's per-axis noise (N, N·m)
    /// that sets each row's torsion-torque noise (backlash candidate).
    pub fn new(chain: &'a SerialChain, wrench_sigma: [f64; 6]) -> Self {
        let model = VirtualJointModel::extended(chain.n_joints());
        let ws = Workspace::new(chain, &model).expect("the extended model fits its own chain");
        let jac = vec![0.0; 6 * model.n_params()];
        Self {
            chain,
            model,
            ws,
            jac,
            wrench_sigma,
        }
    }

    /// The kinematics of row `i` of `data` (finite-checked on entry, so the evaluation
    /// cannot fail).
    pub fn row(&mut self, data: &Dataset, i: usize) -> RowKinematics {
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
        let frame = self
            .chain
            .forward_kinematics(&q)
            .expect("dataset rows are checked against the chain");
        let t = frame.translation.vector;
        RowKinematics {
            q,
            jacobian,
            tau,
            wrench,
            displacement: data.displacement(i),
            tip: [t.x, t.y, t.z],
            tau_sigma,
            tip_rotation: *frame.rotation.to_rotation_matrix().matrix(),
        }
    }

    /// The exact tip displacement (m, base frame) of linear springs of compliances `c` (3n,
    /// rad/(N·m)) under the row's wrench, with equilibrium in the deflected configuration:
    /// the fixed point `θ = C J(θ)ᵀ W`, then the deflected tip minus the unloaded one.
    pub fn exact_displacement(&self, row: &RowKinematics, c: &[f64]) -> [f64; 3] {
        let w = DVector::from_column_slice(&row.wrench);
        let mut theta: Vec<f64> = row.tau.iter().zip(c).map(|(t, ci)| t * ci).collect();
        // |C·K_C| is of order |W|·reach·c ≈ 1e-2, so the iteration contracts fast; 100 steps
        // is a cap, not an expectation.
        for _ in 0..100 {
            let Ok(j) = jacobian_deflected(self.chain, &self.model, &row.q, &theta) else {
                break;
            };
            let tau = j.transpose() * &w;
            let next: Vec<f64> = tau.iter().zip(c).map(|(t, ci)| t * ci).collect();
            let change = next
                .iter()
                .zip(&theta)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            let scale = next.iter().map(|a| a.abs()).fold(1e-300, f64::max);
            theta = next;
            if change <= 1e-14 * scale {
                break;
            }
        }
        match forward_kinematics_deflected(self.chain, &self.model, &row.q, &theta) {
            Ok(tip) => {
                let p = tip.translation.vector;
                [p.x - row.tip[0], p.y - row.tip[1], p.z - row.tip[2]]
            }
            Err(_) => [f64::NAN; 3],
        }
    }
}
