//! Predicted tip deflections and their standard deviations from a [`StiffnessModel`].

use super::{ModelError, StiffnessModel};
use crate::chain::{check_finite, SerialChain};
use crate::error::VjmError;
use crate::kinematics::Workspace;
use crate::load::Load;
use crate::regressor::{regressor_rows, Measured};

/// Default of [`EstimateRecord::identified_tol`](super::EstimateRecord::identified_tol):
/// a row whose scaled regressor leaves the identified row space by more than this (the sine
/// of the angle) is flagged. Structural aliases leave rounding (≲ 1e-12); a pose that really
/// excites an unseen direction leaves a visible fraction of it.
pub const IDENTIFIED_TOL: f64 = 1e-6;

/// The prediction for one row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// Tip deflection `[dx, dy, dz, rx, ry, rz]` (m, rad; base frame; rotation as a small
    /// rotation vector). `rx..rz` are NaN when the model has no rotations.
    pub deflection: [f64; 6],
    /// Standard deviation of each component of the predicted (true, noise-free) deflection
    /// from the parameter covariance, √(a V aᵀ); it does not include the noise of a new
    /// measurement (see [`StiffnessModel::measurement_stddev`]). NaN where unavailable
    /// (no rotations, no noise scale, or the row is not identified).
    pub stddev: [f64; 6],
    /// The wrench used (`[fx, fy, fz, mx, my, mz]`, N and N·m, base frame, at the tip point):
    /// the given one, or the payload's at this pose.
    pub wrench: [f64; 6],
    /// Whether every predicted component lies in the identified row space, i.e. is determined
    /// by the data whatever the aliased springs are.
    pub identified: bool,
    /// How far the row leaves the identified space: the largest over the predicted components
    /// of the sine of the angle between the scaled regressor row and the row space (0 when it
    /// lies in it; rounding gives ~1e-15).
    pub excitation: f64,
}

impl StiffnessModel {
    /// Predicts the tip deflection for N rows: `q` is N×n row-major (rad), `loads` one
    /// [`Load`] per row (a wrench, or a payload whose wrench follows the tip orientation).
    /// Linear in the compliances (no K_C), the model the identification fitted. Errors name
    /// the row (0-based) and column of a bad value.
    pub fn predict(
        &self,
        chain: &SerialChain,
        q: &[f64],
        loads: &[Load],
    ) -> Result<Vec<Prediction>, ModelError> {
        self.check_robot(chain, "<model>")?;
        let n = chain.n_joints();
        let rows = q.len() / n;
        if q.len() != rows * n {
            return Err(VjmError::ShapeMismatch {
                what: "q (N rows of n joint positions)",
                expected: rows * n + n,
                got: q.len(),
            }
            .into());
        }
        if loads.len() != rows {
            return Err(VjmError::ShapeMismatch {
                what: "loads (one per row of q)",
                expected: rows,
                got: loads.len(),
            }
            .into());
        }
        let model = self.spring_model()?;
        let m = model.n_params();
        let mut ws = Workspace::new(chain, &model)?;
        let mut a = vec![0.0; 6 * m];
        let mut out = Vec::with_capacity(rows);
        for i in 0..rows {
            let qi = &q[i * n..(i + 1) * n];
            check_finite("q", qi, i, 0)?;
            let load = &loads[i];
            load.check(i)?;
            let wrench = if load.depends_on_orientation() {
                let tip = chain.forward_kinematics(qi)?;
                load.wrench(tip.rotation.to_rotation_matrix().matrix())
            } else {
                load.wrench(&nalgebra::Matrix3::identity())
            };
            regressor_rows(chain, &model, qi, &wrench, Measured::Full, &mut ws, &mut a)?;
            out.push(self.predict_row(&a, wrench));
        }
        Ok(out)
    }

    /// Standard deviations `[dx..rz]` of a new measurement's noise under the model's noise
    /// model, σ·noise_sigma (m, rad); NaN when σ² is unknown or (rotations) not modelled.
    /// A band for a new measurement is √(stddev² + this²).
    pub fn measurement_stddev(&self) -> [f64; 6] {
        let mut s = [f64::NAN; 6];
        if let Some(s2) = self.noise.sigma2 {
            let axes = if self.noise.use_rotations { 6 } else { 3 };
            for (k, v) in s.iter_mut().enumerate().take(axes) {
                *v = s2.sqrt() * self.noise.noise_sigma[k];
            }
        }
        s
    }

    /// One row from its 6×m regressor `a` (row-major).
    fn predict_row(&self, a: &[f64], wrench: [f64; 6]) -> Prediction {
        let e = &self.estimate;
        let m = e.compliance.len();
        let axes = if self.noise.use_rotations { 6 } else { 3 };
        let mut deflection = [f64::NAN; 6];
        let mut stddev = [f64::NAN; 6];
        let mut excitation: f64 = 0.0;
        for r in 0..axes {
            let ar = &a[r * m..(r + 1) * m];
            deflection[r] = dot(ar, &e.compliance);
            if let Some(cov) = &e.covariance {
                let var: f64 = cov.iter().zip(ar).map(|(row, &ai)| ai * dot(row, ar)).sum();
                stddev[r] = var.max(0.0).sqrt();
            }
            let scaled: f64 = ar
                .iter()
                .zip(&e.column_scale)
                .map(|(x, s)| (x / s) * (x / s))
                .sum::<f64>()
                .sqrt();
            if scaled > 0.0 {
                let outside: f64 = e
                    .null_space
                    .iter()
                    .map(|nv| dot(ar, nv).powi(2))
                    .sum::<f64>()
                    .sqrt();
                excitation = excitation.max(outside / scaled);
            }
        }
        let identified = excitation <= e.identified_tol;
        if !identified {
            stddev = [f64::NAN; 6];
        }
        Prediction {
            deflection,
            stddev,
            wrench,
            identified,
            excitation,
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
