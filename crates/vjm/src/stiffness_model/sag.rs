//! The tip's static sag under the arm's own weight (and a payload), predicted from a
//! [`StiffnessModel`]: what arm makers' absolute-accuracy options correct.

use super::{ModelError, PointMass, Prediction, StiffnessModel};
use crate::chain::{check_finite, SerialChain};
use crate::gravity::{
    gravity_sag_from, Compliances, EquilibriumScratch, Gravity, GravityWorkspace,
};
use stiffness_core::row_blocks::{fill_row_blocks, PREDICTION_BLOCK_ROWS};

impl StiffnessModel {
    /// The tip's static sag relative to the rigid forward kinematics at each of N
    /// configurations `q` (N×n row-major, rad) under `gravity` (base frame, m/s²), with the
    /// model's springs and the chain's link masses (plus `payload`, a point mass in the tip
    /// frame): `deflection` is `[dx, dy, dz, rx, ry, rz]` (m, rad; base frame) of the exact
    /// static equilibrium on the deflected chain ([`gravity_sag_with_gears`](crate::gravity::gravity_sag_with_gears): each gear curve
    /// of the model bends its spring by θ(τ_g)) with what the data determine
    /// ([`StiffnessModel::determined_compliance`]; the minimum-norm member of an aliased family
    /// may have negative entries, which the equilibrium accepts: its members agree on the sag to
    /// first order).
    ///
    /// `stddev`, `identified` and `excitation` are those of the sag's first-order part,
    /// `J C τ_g` — the regressor the weight's torque τ_g would give as a load — so a pose
    /// whose weight loads a direction the identification did not see is flagged exactly as
    /// [`predict`](Self::predict) flags such a load; `wrench` is zero (the weight is not a
    /// tip wrench). Errors name the row (0-based) of a bad configuration and the link of a
    /// missing inertial.
    pub fn predict_sag(
        &self,
        chain: &SerialChain,
        q: &[f64],
        gravity: &Gravity,
        payload: Option<&PointMass>,
    ) -> Result<Vec<Prediction>, ModelError> {
        self.check_robot(chain, "<model>")?;
        let n = chain.n_joints();
        let rows = q.len() / n;
        if q.len() != rows * n {
            return Err(crate::error::VjmError::ShapeMismatch {
                what: "q (N rows of n joint positions)",
                expected: rows * n + n,
                got: q.len(),
            }
            .into());
        }
        let model = self.spring_model()?;
        let m = model.n_params();
        // What the data determine; an aliased family's minimum-norm member may have negative
        // entries, which the equilibrium accepts (`static_equilibrium`).
        let c = self.determined_compliance()?;
        // The gears bend by their curves at the weight's torque, θ(τ_g).
        let gears = self.gear_curves()?;
        let axes = if self.noise.use_rotations { 6 } else { 3 };
        // Rows are independent: fixed-size blocks on every core, each with its own workspaces,
        // give the serial run's values and its first error whatever the number of threads.
        // Built once here too, so that a missing inertial is an error even for no rows.
        GravityWorkspace::new(chain, &model, gravity, payload)?;
        let mut out = vec![Prediction::UNSET; rows];
        fill_row_blocks(&mut out, PREDICTION_BLOCK_ROWS, |block, out| {
            let mut g = GravityWorkspace::new(chain, &model, gravity, payload)?;
            let mut jac = vec![0.0; 6 * m];
            let mut a = vec![0.0; 6 * m];
            let mut scratch = EquilibriumScratch::default();
            let springs = Compliances {
                linear: &c,
                gears: &gears,
            };
            for (i, o) in block.zip(out) {
                let qi = &q[i * n..(i + 1) * n];
                check_finite("q", qi, i, 0)?;
                // One rigid kinematics per row: the weight's workspace gives the Jacobian too.
                g.evaluate(chain, qi)?;
                g.kinematics().write_jacobian(&mut jac);
                // Row-major 6×m regressor of the weight's torques: a[r][k] = J[r][k]·τ_g,k.
                for (k, t) in g.torques().iter().enumerate() {
                    for r in 0..6 {
                        a[r * m + k] = jac[6 * k + r] * t;
                    }
                }
                let mut p = self.predict_row(&a, [0.0; 6], &c);
                // The workspace evaluated at this row gives the equilibrium its start.
                let exact = gravity_sag_from(chain, &model, &springs, qi, &g, &mut scratch)?;
                p.deflection[..axes].copy_from_slice(&exact[..axes]);
                *o = p;
            }
            Ok::<_, ModelError>(())
        })?;
        Ok(out)
    }
}
