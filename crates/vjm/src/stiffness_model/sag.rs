//! The tip's static sag under the arm's own weight (and a payload), predicted from a
//! [`StiffnessModel`]: what arm makers' absolute-accuracy options correct.

use std::ops::Range;

use pulp::{Simd, WithSimd};

use super::columns::{share_runs, Collect, PredictionColumns};
use super::uncertainty::Uncertainty;
use super::{ModelError, PointMass, Prediction, StiffnessModel};
use crate::chain::{check_finite, SerialChain};
use crate::gravity::{
    gravity_sag_from, Compliances, EquilibriumScratch, Gravity, GravityWorkspace,
};
use crate::lanes::kinematics::ChainLanes;
use crate::lanes::sag::{sag_batch, SagBatchOut, SagScratch, SagWeights};
use crate::lanes::{MAX_LANES, V};
use crate::model::VirtualJointModel;

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
    ///
    /// Rows are solved 8 or 16 at a time where the model's springs are linear and have no
    /// centre offsets (`lanes::sag`: plain fixed-point steps, the same equilibrium as the
    /// chord iterations to ~1e-13 of the sag); other rows and models go through the chord
    /// iterations.
    pub fn predict_sag(
        &self,
        chain: &SerialChain,
        q: &[f64],
        gravity: &Gravity,
        payload: Option<&PointMass>,
    ) -> Result<Vec<Prediction>, ModelError> {
        self.sag_rows(chain, q, gravity, payload)
    }

    /// [`predict_sag`](Self::predict_sag) as columns: the same values and errors, in the
    /// memory of the columns alone (no record per row in between).
    pub fn predict_sag_columns(
        &self,
        chain: &SerialChain,
        q: &[f64],
        gravity: &Gravity,
        payload: Option<&PointMass>,
    ) -> Result<PredictionColumns, ModelError> {
        self.sag_rows(chain, q, gravity, payload)
    }

    fn sag_rows<R: Collect>(
        &self,
        chain: &SerialChain,
        q: &[f64],
        gravity: &Gravity,
        payload: Option<&PointMass>,
    ) -> Result<R, ModelError> {
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
        // A campaign applies several loads at each pose, so a pose table repeats each
        // configuration over consecutive rows, and the weight's sag does not depend on the load.
        // A row's equilibrium, lanes included, does not depend on its neighbours: the same
        // values bit for bit.
        share_runs(q, n, |q| self.sag_each_row(chain, q, gravity, payload))
    }

    /// [`sag_rows`](Self::sag_rows) solving every row (`q` of checked shape).
    fn sag_each_row<R: Collect>(
        &self,
        chain: &SerialChain,
        q: &[f64],
        gravity: &Gravity,
        payload: Option<&PointMass>,
    ) -> Result<R, ModelError> {
        let rows = q.len() / chain.n_joints();
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
        let rest = GravityWorkspace::new(chain, &model, gravity, payload)?;
        let springs = Compliances {
            linear: &c,
            gears: &gears,
        };
        // Lane-wise where the lanes' equilibrium applies: linear springs (a curve of zero
        // coefficients is one) without centre offsets (`lanes::sag`); a row it leaves (a
        // deflection beyond 0.25 rad, steps that do not settle) and every row otherwise go
        // through the scalar chord iterations.
        crate::gear::torsion_springs(&model, &gears)?;
        let lanes = rest.kinematics().lanes();
        let linear = gears.iter().all(crate::gear::GearCurve::is_linear);
        let weights = (linear && !lanes.has_offsets())
            .then(|| sag_weights(chain, &c, gravity, payload))
            .transpose()?;
        let rows_of = SagRows {
            uncertainty: Uncertainty::new(self),
            chain,
            vjm: &model,
            springs: &springs,
            q,
            axes,
        };
        R::collect(rows, &|block, out| {
            let mut scalar = ScalarSag::new(&rest, m);
            match &weights {
                Some(weights) => pulp::Arch::new().dispatch(SagBlock {
                    rows: &rows_of,
                    chain: lanes,
                    weights,
                    block,
                    out,
                    scalar: &mut scalar,
                }),
                // No lanes: every row of every batch through the scalar code.
                None => {
                    let mut regressors = vec![0.0; MAX_LANES * 6 * m];
                    let mut sag = [[0.0; 6]; MAX_LANES];
                    for (first, batch) in block.step_by(MAX_LANES).zip(out.chunks_mut(MAX_LANES)) {
                        let solved = [false; MAX_LANES];
                        rows_of.finish_batch(
                            first,
                            batch,
                            &mut regressors,
                            &mut sag,
                            &solved,
                            &mut scalar,
                        )?;
                    }
                    Ok(())
                }
            }
        })
    }
}

/// The weights of `chain` (its bodies, the payload, gravity) and the springs' compliance `c`,
/// flattened for [`sag_batch`].
fn sag_weights(
    chain: &SerialChain,
    c: &[f64],
    gravity: &Gravity,
    payload: Option<&PointMass>,
) -> Result<SagWeights, ModelError> {
    let bodies = chain
        .mass_model()?
        .bodies()
        .iter()
        .map(|b| (b.mass, [b.com.x, b.com.y, b.com.z]))
        .collect();
    let payload = payload.map(|p| {
        let v = chain.tip_offset().rotation * nalgebra::Vector3::from(p.centre());
        (p.mass(), [v.x, v.y, v.z])
    });
    let g = gravity.vector();
    Ok(SagWeights {
        bodies,
        payload,
        gravity: [g.x, g.y, g.z],
        compliance: c.to_vec(),
    })
}

/// What every row of one `predict_sag` call shares.
struct SagRows<'a> {
    uncertainty: Uncertainty,
    chain: &'a SerialChain,
    vjm: &'a VirtualJointModel,
    springs: &'a Compliances<'a>,
    q: &'a [f64],
    axes: usize,
}

/// One block's buffers for the scalar path.
struct ScalarSag {
    g: GravityWorkspace,
    jac: Vec<f64>,
    scratch: EquilibriumScratch,
}

impl ScalarSag {
    fn new(rest: &GravityWorkspace, m: usize) -> Self {
        Self {
            g: rest.clone(),
            jac: vec![0.0; 6 * m],
            scratch: EquilibriumScratch::default(),
        }
    }
}

impl SagRows<'_> {
    /// Row `i` through the scalar code (the rigid kinematics of the weight's workspace and
    /// the chord iterations of the exact equilibrium): its sag, and its regressor into `a`.
    fn scalar_row(
        &self,
        i: usize,
        b: &mut ScalarSag,
        a: &mut [f64],
    ) -> Result<[f64; 6], ModelError> {
        let n = self.chain.n_joints();
        let m = self.vjm.n_params();
        let qi = &self.q[i * n..(i + 1) * n];
        check_finite("q", qi, i, 0)?;
        // One rigid kinematics per row: the weight's workspace gives the Jacobian too.
        b.g.evaluate(self.chain, qi)?;
        b.g.kinematics().write_jacobian(&mut b.jac);
        // Row-major 6×m regressor of the weight's torques: a[r][k] = J[r][k]·τ_g,k.
        for (k, t) in b.g.torques().iter().enumerate() {
            for r in 0..6 {
                a[r * m + k] = b.jac[6 * k + r] * t;
            }
        }
        // The workspace evaluated at this row gives the equilibrium its start.
        Ok(gravity_sag_from(
            self.chain,
            self.vjm,
            self.springs,
            qi,
            &b.g,
            &mut b.scratch,
        )?)
    }

    /// The predictions of the batch of rows from `first` into `out`: a row not `solved` by
    /// the lanes goes through [`scalar_row`](Self::scalar_row) (its regressor and sag into
    /// `regressor` and `sag`); then each row's deflection is its sag on the predicted axes (NaN
    /// beyond, no wrench) and the standard deviations are [`Uncertainty::fill`]'s.
    fn finish_batch(
        &self,
        first: usize,
        out: &mut [Prediction],
        regressor: &mut [f64],
        sag: &mut [[f64; 6]],
        solved: &[bool],
        scalar: &mut ScalarSag,
    ) -> Result<(), ModelError> {
        let m = self.vjm.n_params();
        for (l, o) in out.iter_mut().enumerate() {
            if !solved[l] {
                let a = &mut regressor[l * 6 * m..(l + 1) * 6 * m];
                sag[l] = self.scalar_row(first + l, scalar, a)?;
            }
            let mut deflection = [f64::NAN; 6];
            deflection[..self.axes].copy_from_slice(&sag[l][..self.axes]);
            *o = Prediction {
                deflection,
                wrench: [0.0; 6],
                ..Prediction::UNSET
            };
        }
        self.uncertainty.fill(regressor, out);
        Ok(())
    }
}

/// The rows of one block lane-wise, in the instruction set pulp dispatches to (rows the lanes
/// leave through the scalar code).
struct SagBlock<'a, 'b> {
    rows: &'b SagRows<'a>,
    chain: &'b ChainLanes,
    weights: &'b SagWeights,
    block: Range<usize>,
    out: &'b mut [Prediction],
    scalar: &'b mut ScalarSag,
}

impl WithSimd for SagBlock<'_, '_> {
    type Output = Result<(), ModelError>;
    #[inline(always)]
    fn with_simd<S: Simd>(self, s: S) -> Self::Output {
        let SagBlock {
            rows,
            chain,
            weights,
            block,
            out,
            scalar,
        } = self;
        let n = rows.chain.n_joints();
        let m = rows.vjm.n_params();
        let lanes = V::<S>::LANES;
        let mut sc = SagScratch::new(s, chain, weights);
        let mut regressor = vec![0.0; lanes * 6 * m];
        let mut sag = [[0.0; 6]; MAX_LANES];
        let mut solved = [false; MAX_LANES];
        let mut i = block.start;
        while i < block.end {
            let count = (block.end - i).min(lanes);
            let q = &rows.q[i * n..(i + count) * n];
            let outs = &mut out[i - block.start..i - block.start + count];
            // A row that is not finite is the scalar code's to report (it names the row).
            if !q.iter().all(|v| v.is_finite()) {
                solved.fill(false);
            } else {
                sag_batch(
                    s,
                    chain,
                    weights,
                    q,
                    count,
                    &mut sc,
                    SagBatchOut {
                        regressor: &mut regressor,
                        sag: &mut sag,
                        solved: &mut solved,
                    },
                );
            }
            rows.finish_batch(i, outs, &mut regressor, &mut sag, &solved, scalar)?;
            i += count;
        }
        Ok(())
    }
}
