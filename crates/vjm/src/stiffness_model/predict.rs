//! Predicted tip deflections and their standard deviations from a [`StiffnessModel`].

use super::columns::{Collect, PredictionColumns};
use super::gear_load::add_gear_load;
use super::uncertainty::{deflection_of, Uncertainty};
use super::{ModelError, StiffnessModel};
use crate::chain::{check_finite, SerialChain};
use crate::dataset::{MAX_PLAUSIBLE_FORCE, MAX_PLAUSIBLE_MOMENT};
use crate::error::VjmError;
use crate::gear::{torsion_springs, CurvedSprings};
use crate::gravity::{Gravity, GravityWorkspace, RowFrame};
use crate::kinematics::Workspace;
use crate::lanes::MAX_LANES;
use crate::model::VirtualJointModel;
use stiffness_core::num::Short;

/// Standard gravity, m/s² (acts along −z of the base frame for a [`PointMass`]).
pub const GRAVITY: f64 = 9.80665;

/// Default of [`EstimateRecord::identified_tol`](super::EstimateRecord::identified_tol):
/// a row whose scaled regressor leaves the identified row space by more than this (the sine
/// of the angle) is flagged. Structural aliases leave rounding (≲ 1e-12); a pose that really
/// excites an unseen direction leaves a visible fraction of it.
pub const IDENTIFIED_TOL: f64 = 1e-6;

/// A payload: a point mass `mass` (kg) at `centre` (m, tip frame), under gravity
/// [`GRAVITY`] along −z of the base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointMass {
    mass: f64,
    centre: [f64; 3],
}

impl PointMass {
    /// A point mass of `mass` kg (finite, ≥ 0) at `centre` (finite, m, tip frame). Its weight
    /// and the largest moment it can exert must be within a measurement file's caps
    /// ([`MAX_PLAUSIBLE_FORCE`], [`MAX_PLAUSIBLE_MOMENT`]): a prediction refuses the loads an
    /// identification refuses (10⁶ kg is a unit error, not a payload).
    pub fn new(mass: f64, centre: [f64; 3]) -> Result<Self, ModelError> {
        if !(mass.is_finite() && mass >= 0.0) {
            return Err(ModelError::Payload {
                message: format!(
                    "the mass must be a finite number ≥ 0 kg, got {}",
                    Short(mass)
                ),
            });
        }
        if let Some(k) = centre.iter().position(|c| !c.is_finite()) {
            return Err(ModelError::Payload {
                message: format!(
                    "the centre of mass {} must be finite, got {}",
                    ["cx", "cy", "cz"][k],
                    Short(centre[k])
                ),
            });
        }
        let weight = mass * GRAVITY;
        // The mass is finite and ≥ 0 (above): the weight is at most inf (an overflow), never NaN.
        if weight > MAX_PLAUSIBLE_FORCE {
            return Err(ModelError::Payload {
                message: format!(
                    "a mass of {} kg weighs {weight:.3e} N, more than physically plausible \
                     ({MAX_PLAUSIBLE_FORCE} N, the cap of a measurement file's forces); check \
                     the unit (kg)",
                    Short(mass)
                ),
            });
        }
        let arm = nalgebra::Vector3::from(centre).norm();
        let moment = arm * weight;
        if moment > MAX_PLAUSIBLE_MOMENT {
            return Err(ModelError::Payload {
                message: format!(
                    "a mass of {} kg at {arm:.3e} m from the tip point exerts up to \
                     {moment:.3e} N·m, more than physically plausible ({MAX_PLAUSIBLE_MOMENT} \
                     N·m, the cap of a measurement file's moments); check the units (kg, m)",
                    Short(mass)
                ),
            });
        }
        Ok(PointMass { mass, centre })
    }

    /// Mass, kg.
    pub fn mass(&self) -> f64 {
        self.mass
    }
    /// Centre of mass in the tip frame, m.
    pub fn centre(&self) -> [f64; 3] {
        self.centre
    }

    /// The wrench `[fx, fy, fz, mx, my, mz]` (N, N·m) the payload exerts at the tip point, base
    /// frame components, at joint positions `q`: F = (0, 0, −m·g) and M = (R·c) × F with R the
    /// tip orientation.
    pub fn wrench(&self, chain: &SerialChain, q: &[f64]) -> Result<[f64; 6], VjmError> {
        let tip = chain.forward_kinematics(q)?;
        Ok(self.wrench_at(tip.rotation.to_rotation_matrix().matrix()))
    }

    /// The same wrench for a tip frame of orientation `tip_rotation` (base ← tip), for callers
    /// that already evaluated the kinematics.
    pub fn wrench_at(&self, tip_rotation: &nalgebra::Matrix3<f64>) -> [f64; 6] {
        let r = tip_rotation * nalgebra::Vector3::from(self.centre);
        let f = nalgebra::Vector3::new(0.0, 0.0, -self.mass * GRAVITY);
        let m = r.cross(&f);
        [f.x, f.y, f.z, m.x, m.y, m.z]
    }
}

/// The load of every row of a prediction.
#[derive(Debug, Clone, Copy)]
#[non_exhaustive]
pub enum Load<'a> {
    /// One wrench per row, N×6 row-major `[fx, fy, fz, mx, my, mz]` (N, N·m, at the tip
    /// point, base frame).
    Wrench(&'a [f64]),
    /// The same payload on every row; its wrench depends on the pose.
    Payload(PointMass),
}

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
    /// The wrench used (given, or the payload's at this pose).
    pub wrench: [f64; 6],
    /// Whether every predicted component lies in the identified row space, i.e. is determined
    /// by the data whatever the aliased springs are.
    pub identified: bool,
    /// How far the row leaves the identified space: the largest over the predicted components
    /// of the sine of the angle between the scaled regressor row and the row space (0 when it
    /// lies in it; rounding gives ~1e-15).
    pub excitation: f64,
}

impl Prediction {
    /// The placeholder of a row not yet predicted (every value NaN, not identified).
    pub(crate) const UNSET: Prediction = Prediction {
        deflection: [f64::NAN; 6],
        stddev: [f64::NAN; 6],
        wrench: [f64::NAN; 6],
        identified: false,
        excitation: f64::NAN,
    };
}

impl StiffnessModel {
    /// Predicts the tip deflection for N rows: `q` is N×n row-major (rad), `load` the wrench
    /// per row or a payload. Linear in the compliances (no K_C), the model the identification
    /// fitted, for a weightless arm. A model with gear curves ([`Self::gear_curves`]) adds each
    /// curved torsion spring's excess beyond its linear compliance at the load's torque τ on it,
    /// `J_k (Σ a_i h_i(τ) + ½ b sign(τ))` (the diagnosis' `joint_torsion_nonlinear` and
    /// `joint_backlash` columns times their coefficients, with sign(0) = 0 and `sign`, not the
    /// diagnosis' erf: the mean deflection of a known torque; `docs/gravity.md`, *Non-linear
    /// gears in the model*); `stddev`,
    /// `identified` and `excitation` are the linear springs' (the curves are taken as known).
    /// Errors name the row (0-based) and column of a bad value.
    pub fn predict(
        &self,
        chain: &SerialChain,
        q: &[f64],
        load: Load<'_>,
    ) -> Result<Vec<Prediction>, ModelError> {
        self.predict_rows(chain, q, load, None)
    }

    /// [`predict`](Self::predict) for an arm under `gravity` (base frame, m/s²): the load's
    /// deflection from the arm at rest under its own weight, what a measurement under gravity
    /// records (loaded − unloaded) and what [`identify`](crate::identify) with
    /// [`IdentifyOptions::gravity`](crate::IdentifyOptions::gravity) fits. Each row is moved
    /// to the sagged pose θ₀ ([`GravityWorkspace::sag`]: its Jacobian there) and the load's
    /// torque gets gravity's coupling, τ_eff = τ + K_G Δθ
    /// ([`GravityWorkspace::effective_torques`]): `d = J(θ₀) C τ_eff`, linear in the load.
    /// A gear curve adds `J_k(θ₀) (e(τ₀ + τ_eff) − e(τ₀))` for its spring k, its excess
    /// `e(T) = Σ a_i h_i(T) + ½ b sign(T)` at the total torque with the preload τ₀ of the sag
    /// (the lost motion adds `½ b (sign(τ₀ + τ_eff) − sign(τ₀))`: nothing while the load keeps
    /// the preload's sign, `± b` when it reverses it): the curve's
    /// change from the weight's working point, to first order in the compliances as the rest
    /// of the prediction (the exact equilibrium with curves is
    /// [`deflection_under_gravity_with_gears`](crate::gravity::deflection_under_gravity_with_gears);
    /// they differ by the load's K_C and by ‖C K_G‖ ≈ 1e-2 of the curve's share).
    /// `stddev`, `identified` and `excitation` are the weightless prediction's: the
    /// identification's row space is that of the weightless regressor, and the weight moves a
    /// row's regressor by ‖C K_G‖ ≈ 1e-2 of it, which would flag rows of a rank-deficient model
    /// that the data do determine. The link masses come from the chain's inertials (an error
    /// naming a link without one).
    pub fn predict_under_gravity(
        &self,
        chain: &SerialChain,
        q: &[f64],
        load: Load<'_>,
        gravity: &Gravity,
    ) -> Result<Vec<Prediction>, ModelError> {
        self.predict_rows(chain, q, load, Some(gravity))
    }

    /// [`predict`](Self::predict) (`gravity` None) or
    /// [`predict_under_gravity`](Self::predict_under_gravity) as columns: the same values and
    /// errors, in the memory of the columns alone (no record per row in between).
    pub fn predict_columns(
        &self,
        chain: &SerialChain,
        q: &[f64],
        load: Load<'_>,
        gravity: Option<&Gravity>,
    ) -> Result<PredictionColumns, ModelError> {
        self.predict_rows(chain, q, load, gravity)
    }

    fn predict_rows<R: Collect>(
        &self,
        chain: &SerialChain,
        q: &[f64],
        load: Load<'_>,
        gravity: Option<&Gravity>,
    ) -> Result<R, ModelError> {
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
        if let Load::Wrench(w) = load {
            if w.len() != 6 * rows {
                return Err(VjmError::ShapeMismatch {
                    what: "wrench (one [fx, fy, fz, mx, my, mz] per row of q)",
                    expected: 6 * rows,
                    got: w.len(),
                }
                .into());
            }
        }
        let model = self.spring_model()?;
        let m = model.n_params();
        // Built once here too, so that a missing inertial is an error even for no rows.
        if let Some(g) = gravity {
            GravityWorkspace::new(chain, &model, g, None)?;
        }
        // Rows are independent: fixed-size blocks on every core, each with its own workspace,
        // give the serial run's values and its first error whatever the number of threads.
        let c = self.determined_compliance()?;
        // The gears' excess under the load (`gear_load`), on their torsion springs.
        let gears = self.gear_curves()?;
        let gear_springs = torsion_springs(&model, &gears)?;
        let curved = CurvedSprings::new(&gears, &gear_springs);
        let axes = if self.noise.use_rotations { 6 } else { 3 };
        let uncertainty = Uncertainty::new(self);
        R::collect(rows, &|block, out| {
            let mut ws = Workspace::new(chain, &model)?;
            // The regressors of a batch of rows, whose standard deviations are then taken
            // lane-wise (`Uncertainty::fill`).
            let mut regressors = vec![0.0; MAX_LANES * 6 * m];
            let mut jacobians = vec![0.0; MAX_LANES * 6 * m];
            let mut weight = gravity
                .map(|g| SaggedRow::new(chain, &model, g))
                .transpose()?;
            for (rows_of_batch, batch) in block.step_by(MAX_LANES).zip(out.chunks_mut(MAX_LANES)) {
                // The rows' weightless regressors from their Jacobians, lane-wise: what the
                // standard deviations are taken from in every case, and the deflection of a
                // weightless model without gear curves.
                self.weightless_batch(WeightlessBatch {
                    chain,
                    ws: &ws,
                    q,
                    first: rows_of_batch,
                    load,
                    c: &c,
                    axes,
                    jacobians: &mut jacobians,
                    regressors: &mut regressors,
                    out: batch,
                })?;
                if weight.is_some() || !curved.curves().is_empty() {
                    for (l, o) in batch.iter_mut().enumerate() {
                        let i = rows_of_batch + l;
                        self.adjust_deflection(AdjustRow {
                            chain,
                            model: &model,
                            q: &q[i * n..(i + 1) * n],
                            i,
                            c: &c,
                            curved: &curved,
                            axes,
                            ws: &mut ws,
                            weight: weight.as_mut(),
                            out: o,
                        })?;
                    }
                }
                uncertainty.fill(&regressors, batch);
            }
            Ok(())
        })
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

    /// Moves a row's weightless deflection (set by [`Self::weightless_batch`]) to what the
    /// load does under gravity (the sagged regressor's) and adds the gears' excess.
    fn adjust_deflection(&self, row: AdjustRow<'_, '_>) -> Result<(), ModelError> {
        let AdjustRow {
            chain,
            model,
            q: qi,
            i,
            c,
            curved,
            axes,
            ws,
            weight,
            out: o,
        } = row;
        let m = model.n_params();
        let wrench = o.wrench;
        // The row's rigid kinematics and Jacobian in `ws` (its q and wrench were checked by
        // `weightless_batch`), which the sag and the gears start from. The lanes gave the
        // weightless regressor; this scalar evaluation is what `SaggedRow` and the gears read.
        ws.evaluate_jacobian(chain, qi);
        let weight = match weight {
            Some(sagged) => {
                // The identification's row space is the weightless regressor's: `identified`,
                // `stddev` and `excitation` stay its; the deflection is the sagged one.
                let b = sagged
                    .regressor(chain, qi, &wrench, c, ws)
                    .map_err(|e| at_row(e, i))?;
                for (r, d) in o.deflection.iter_mut().enumerate() {
                    if d.is_finite() {
                        *d = dot(&b[r * m..(r + 1) * m], c);
                    }
                }
                Some(&*sagged)
            }
            None => None,
        };
        if curved.curves().is_empty() {
            return Ok(());
        }
        match weight {
            // At the sagged pose: its Jacobian, the preload τ₀ and the load's torque
            // with gravity's coupling, as the linear prediction above.
            Some(s) => add_gear_load(
                curved,
                &s.jac,
                |k| (s.preload[k], s.effective[k]),
                axes,
                &mut o.deflection,
            ),
            // Weightless: no preload, the load's torque J_kᵀ W at q.
            None => add_gear_load(
                curved,
                &ws.jac,
                |k| (0.0, dot(&ws.jac[6 * k..6 * k + 6], &wrench)),
                axes,
                &mut o.deflection,
            ),
        }
        Ok(())
    }
}

/// A row of [`StiffnessModel::predict_rows`] under gravity or with gear curves, and what it
/// shares with the others.
struct AdjustRow<'a, 'b> {
    chain: &'a SerialChain,
    model: &'a VirtualJointModel,
    q: &'a [f64],
    i: usize,
    c: &'a [f64],
    curved: &'a CurvedSprings<'a>,
    axes: usize,
    ws: &'b mut Workspace,
    weight: Option<&'b mut SaggedRow>,
    out: &'b mut Prediction,
}

/// A batch of weightless rows of [`StiffnessModel::predict_rows`] (no gear curves).
struct WeightlessBatch<'a, 'b> {
    chain: &'a SerialChain,
    ws: &'b Workspace,
    q: &'a [f64],
    first: usize,
    load: Load<'a>,
    c: &'a [f64],
    axes: usize,
    jacobians: &'b mut [f64],
    regressors: &'b mut [f64],
    out: &'b mut [Prediction],
}

impl StiffnessModel {
    /// The deflections and regressors of a batch of weightless rows from their Jacobians,
    /// evaluated lane-wise (`lanes::gram::jacobian_batch`); the rows are checked first, in
    /// order, as the per-row path checks them.
    fn weightless_batch(&self, b: WeightlessBatch<'_, '_>) -> Result<(), ModelError> {
        let n = b.chain.n_joints();
        let m = b.ws.n_params();
        let count = b.out.len();
        let rows = &b.q[b.first * n..(b.first + count) * n];
        for (l, o) in b.out.iter_mut().enumerate() {
            let i = b.first + l;
            let qi = &rows[l * n..(l + 1) * n];
            check_finite("q", qi, i, 0)?;
            let wrench = match b.load {
                Load::Wrench(w) => {
                    let wi = &w[6 * i..6 * i + 6];
                    check_finite("wrench", wi, i, 0)?;
                    [wi[0], wi[1], wi[2], wi[3], wi[4], wi[5]]
                }
                Load::Payload(p) => p.wrench(b.chain, qi)?,
            };
            o.wrench = wrench;
        }
        let jac = &mut b.jacobians[..count * 6 * m];
        crate::lanes::gram::jacobian_batch(
            b.ws.lanes(),
            rows,
            jac,
            crate::kinematics::JacobianLayout::ColumnMajor,
        );
        for (l, o) in b.out.iter_mut().enumerate() {
            let (j, a) = (
                &jac[l * 6 * m..(l + 1) * 6 * m],
                &mut b.regressors[l * 6 * m..(l + 1) * 6 * m],
            );
            // a[r][k] = J[r][k] · (J_kᵀ W), as `regressor_rows`.
            for k in 0..m {
                let col = &j[6 * k..6 * k + 6];
                let g: f64 = col.iter().zip(&o.wrench).map(|(x, y)| x * y).sum();
                for r in 0..6 {
                    a[r * m + k] = col[r] * g;
                }
            }
            o.deflection = deflection_of(a, b.c, b.axes);
        }
        Ok(())
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// A numerical error of row `i` under gravity, with the row named.
fn at_row(e: VjmError, i: usize) -> VjmError {
    match e {
        VjmError::Numerical { message } => VjmError::Numerical {
            message: format!("row {i}, under gravity: {message}"),
        },
        other => other,
    }
}

/// Per-thread scratch of [`StiffnessModel::predict_under_gravity`]: the weight's workspace and
/// the row's Jacobian, torques and preload.
struct SaggedRow {
    weight: GravityWorkspace,
    jac: Vec<f64>,
    tau: Vec<f64>,
    effective: Vec<f64>,
    preload: Vec<f64>,
    /// The last row's sagged regressor (row-major 6×m).
    regressor: Vec<f64>,
}

impl SaggedRow {
    fn new(
        chain: &SerialChain,
        model: &VirtualJointModel,
        gravity: &Gravity,
    ) -> Result<Self, VjmError> {
        let m = model.n_params();
        Ok(SaggedRow {
            weight: GravityWorkspace::new(chain, model, gravity, None)?,
            jac: vec![0.0; 6 * m],
            tau: vec![0.0; m],
            effective: vec![0.0; m],
            preload: vec![0.0; m],
            regressor: vec![0.0; 6 * m],
        })
    }

    /// The row-major 6×m regressor of a row under gravity at compliances `c`:
    /// `a[r][k] = J(θ₀)[r][k] · τ_eff,k` (see [`StiffnessModel::predict_under_gravity`]).
    /// `ws` holds the row's kinematics at θ = 0, as [`regressor_rows`] left it for `q`.
    fn regressor(
        &mut self,
        chain: &SerialChain,
        q: &[f64],
        wrench: &[f64; 6],
        c: &[f64],
        ws: &Workspace,
    ) -> Result<&[f64], VjmError> {
        let m = self.tau.len();
        self.jac.copy_from_slice(&ws.jac);
        let mut tip = ws.p;
        let mut tip_rotation = ws.tip_rotation(chain);
        self.weight.evaluate(chain, q)?;
        let frame = RowFrame {
            jacobian: &mut self.jac,
            tip: &mut tip,
            tip_rotation: &mut tip_rotation,
        };
        self.weight.sagged_load(
            c,
            frame,
            wrench,
            &mut self.preload,
            &mut self.tau,
            &mut self.effective,
        )?;
        for k in 0..m {
            for r in 0..6 {
                self.regressor[r * m + k] = self.jac[6 * k + r] * self.effective[k];
            }
        }
        Ok(&self.regressor)
    }
}
