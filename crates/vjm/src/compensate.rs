//! Deflection compensation: corrected joint targets q' such that the tip, loaded, reaches the
//! pose the nominal targets give unloaded (docs/use-the-model.md).
//!
//! For each row the equation `FK(q') + δ(q', W) = FK(q_nominal)` is solved for q', where δ is
//! the model's tip deflection `J(q') Δθ` with `Δθ = C J(q')ᵀ W` or, with the complementary
//! stiffness, `Δθ = (I − C K_C)⁻¹ C Jᵀ W`. The position residual is in m; with
//! [`CompensateOptions::match_orientation`] the orientation residual
//! `log(exp(δ_rot) R(q') R(q_nominal)ᵀ)` (rad, base frame) is matched too. With gear curves
//! ([`compensate_with_gears`], [`crate::gear`]) a curved torsion spring deflects by its curve of
//! the torque it carries instead of `c τ`.
//!
//! The iteration is a damped Gauss–Newton (chord) method: the step uses the rigid actuated
//! Jacobian J_a, minimum-norm for redundant arms (`Δq = J_aᵀ (J_a J_aᵀ + λ²I)⁻¹ (−r)`), and
//! leaves out ∂δ/∂q, which is of relative size |C|·|W|·reach ≈ 1e-2: the iteration then
//! contracts the residual by about that factor per step (4–6 steps from a 1 mm deflection to
//! 1e-9 m) instead of quadratically, at a fraction of the cost of differentiating δ.

use nalgebra::{Matrix3, Rotation3, SMatrix, SVector, Vector3};
use serde::Serialize;
use stiffness_core::row_blocks::fill_row_blocks_pair;
use stiffness_core::so3::{exp, log};

use crate::chain::{check_finite, SerialChain};
use crate::contraction::Contraction;
use crate::error::VjmError;
use crate::gear::{torsion_springs, CurvedSprings, GearCurve};
use crate::gravity::{
    equilibrium_from, Compliances, EquilibriumScratch, GravityWorkspace, Loading,
};
use crate::kinematics::{jacobian_in_place, Workspace};
use crate::model::VirtualJointModel;
use crate::stiffness_model::Load;

/// Cap of the fixed-point iteration for `Δθ = C Jᵀ W + C K_C Δθ` (it contracts by ‖C K_C‖,
/// about 1e-2 for a cobot; failing to converge means the load is at or beyond buckling).
const DEFLECTION_MAX_ITERATIONS: usize = 200;

/// Options of [`compensate`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct CompensateOptions {
    /// Match the tip orientation as well as its position (needs a model identified with
    /// rotations to be meaningful). Default `false`: position only (3 equations; the
    /// remaining n − 3 joint directions are fixed by the minimum-norm steps).
    pub match_orientation: bool,
    /// Include the complementary stiffness K_C (the load-dependent Jacobian) in the
    /// deflection. Default `true`. It changes the deflection by a relative ‖C K_C‖ ≈
    /// c·|F|·reach (0.6 % for c = 1e-4 rad/(N·m), 80 N, 0.8 m); leave it on unless the model
    /// was identified from data that exclude it and that difference matters.
    pub with_kc: bool,
    /// Stop when the predicted position residual is at most this, m. Default 1e-9.
    pub position_tol: f64,
    /// With `match_orientation`: and the orientation residual at most this, rad. Default 1e-9.
    pub rotation_tol: f64,
    /// Stop (not converged) when a step is at most `step_rtol · max(1, ‖q‖)`. Default 1e-12.
    pub step_rtol: f64,
    /// Cap on Gauss–Newton steps per row. Default 50.
    pub max_iterations: usize,
    /// Rows whose task Jacobian has an inverse condition number σ_min/σ_max below this are
    /// reported [`CompensationStatus::NearSingular`]; below it the steps are damped with
    /// λ = threshold·σ_max. Default 1e-3.
    pub min_inverse_condition: f64,
    /// Length L (m) that puts rotation residuals and angular Jacobian rows on the scale of the
    /// linear ones (they are multiplied by L). Default 0.5 m.
    pub length: f64,
    /// Report corrected targets outside the chain's joint limits. Default `true`.
    pub check_limits: bool,
    /// Correct the tip's sag under the arm's own weight as well as the load's deflection:
    /// the model's loaded tip is then the springs' static equilibrium under gravity, the
    /// payload's weight and the wrench on the deflected chain
    /// ([`crate::gravity::static_equilibrium`], no linearisation; `with_kc` does not apply;
    /// with gear curves [`crate::gravity::static_equilibrium_with_gears`]),
    /// against the rigid kinematics. The chain needs its masses
    /// ([`SerialChain::mass_model`]). Default `None`: the load's deflection only (weightless).
    pub gravity: Option<crate::gravity::Gravity>,
}

impl Default for CompensateOptions {
    fn default() -> Self {
        Self {
            match_orientation: false,
            with_kc: true,
            position_tol: 1e-9,
            rotation_tol: 1e-9,
            step_rtol: 1e-12,
            max_iterations: 50,
            min_inverse_condition: 1e-3,
            length: 0.5,
            check_limits: true,
            gravity: None,
        }
    }
}

impl CompensateOptions {
    fn check(&self) -> Result<(), VjmError> {
        let positive = |name: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(VjmError::InvalidOption {
                    name,
                    message: format!(
                        "must be finite and > 0, got {}",
                        stiffness_core::num::Short(v)
                    ),
                })
            }
        };
        positive("position_tol", self.position_tol)?;
        positive("rotation_tol", self.rotation_tol)?;
        positive("step_rtol", self.step_rtol)?;
        positive("length", self.length)?;
        if !(self.min_inverse_condition.is_finite()
            && (0.0..1.0).contains(&self.min_inverse_condition))
        {
            return Err(VjmError::InvalidOption {
                name: "min_inverse_condition",
                message: format!(
                    "must be in [0, 1), got {}",
                    stiffness_core::num::Short(self.min_inverse_condition)
                ),
            });
        }
        if self.max_iterations == 0 || self.max_iterations > 10_000 {
            return Err(VjmError::InvalidOption {
                name: "max_iterations",
                message: format!("must be in 1..=10000, got {}", self.max_iterations),
            });
        }
        Ok(())
    }
}

/// Outcome of one row of [`compensate`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum CompensationStatus {
    /// The residual is within the tolerances, the task Jacobian well conditioned and the
    /// targets within the joint limits.
    Converged,
    /// Converged, but the corrected targets leave the joint limits (see
    /// [`CompensatedRow::limit_joint`]).
    OutsideLimits,
    /// The task Jacobian at the row is near singular (inverse condition below the option's
    /// threshold): steps were damped, the targets may be far from nominal or inaccurate.
    NearSingular,
    /// The tolerances were not reached within `max_iterations` or the steps stalled.
    NotConverged,
    /// The spring equilibrium with K_C has no solution at this load (buckling of the model).
    Unstable,
}

impl CompensationStatus {
    /// The name written in files: `converged`, `outside_limits`, `near_singular`,
    /// `not_converged`, `unstable`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Converged => "converged",
            Self::OutsideLimits => "outside_limits",
            Self::NearSingular => "near_singular",
            Self::NotConverged => "not_converged",
            Self::Unstable => "unstable",
        }
    }
}

/// Per-row report of [`compensate`] (the corrected targets are in [`Compensation::q`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CompensatedRow {
    /// Outcome.
    pub status: CompensationStatus,
    /// Gauss–Newton steps taken.
    pub iterations: usize,
    /// Predicted remaining position error of the loaded tip at the corrected targets, m.
    pub position_error: f64,
    /// Predicted remaining orientation error, rad (the uncorrected tilt when only the position
    /// is matched).
    pub rotation_error: f64,
    /// Predicted tip deflection without compensation (at the nominal targets), m.
    pub deflection: f64,
    /// Predicted tip rotation without compensation, rad.
    pub rotation_deflection: f64,
    /// Inverse condition number σ_min/σ_max of the task Jacobian at the corrected targets
    /// (the status is `near_singular` when this or the value at the nominal targets is below
    /// the threshold).
    pub inverse_condition: f64,
    /// First joint (0-based) whose corrected target is outside its limits, if any.
    pub limit_joint: Option<usize>,
}

/// Result of [`compensate`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Compensation {
    /// Corrected joint targets, N×n row-major, rad.
    pub q: Vec<f64>,
    /// Per-row reports.
    pub rows: Vec<CompensatedRow>,
}

/// Reusable scratch of [`compensate_in_place`]: one per thread.
#[derive(Debug, Clone)]
pub struct CompensationWorkspace {
    springs: Workspace,
    actuated: Workspace,
    actuated_model: VirtualJointModel,
    jac: Vec<f64>,
    jac_a: Vec<f64>,
    theta0: Vec<f64>,
    theta: Vec<f64>,
    ktheta: Vec<f64>,
    /// K_C's share `Δθ − θ0` of the row's last converged deflection: the next evaluation of
    /// the same row starts from it (a Gauss–Newton step moves q by about 1e-3 rad, then
    /// 1e-6, so the share hardly changes and the fixed point is a few steps away instead of
    /// seven). Reset at each row, so that a row's result does not depend on the rows before it.
    kc_share: Vec<f64>,
    kc_share_valid: bool,
    /// The springs are the actuated joints (a traditional model): the springs' Jacobian that
    /// [`loaded_tip`] leaves in `jac` is then the actuated Jacobian at the same q, bit for bit.
    springs_are_actuated: bool,
    /// The load's torque on each spring at θ = 0, N·m (the gear curves' argument).
    tau: Vec<f64>,
    dq: Vec<f64>,
    /// Under gravity: the weight's workspace (built at the first row that needs it) and the
    /// equilibrium's buffers, kept from one row to the next.
    weight: Option<GravityWorkspace>,
    equilibrium: EquilibriumScratch,
}

impl CompensationWorkspace {
    /// Scratch for `model` on `chain`.
    pub fn new(chain: &SerialChain, model: &VirtualJointModel) -> Result<Self, VjmError> {
        let n = chain.n_joints();
        let m = model.n_params();
        let actuated_model = VirtualJointModel::traditional(n);
        let springs_are_actuated = model.springs() == actuated_model.springs()
            && model.offsets() == actuated_model.offsets();
        Ok(Self {
            springs: Workspace::new(chain, model)?,
            actuated: Workspace::new(chain, &actuated_model)?,
            actuated_model,
            jac: vec![0.0; 6 * m],
            jac_a: vec![0.0; 6 * n],
            theta0: vec![0.0; m],
            theta: vec![0.0; m],
            ktheta: vec![0.0; m],
            kc_share: vec![0.0; m],
            kc_share_valid: false,
            springs_are_actuated,
            tau: vec![0.0; m],
            dq: vec![0.0; n],
            weight: None,
            equilibrium: EquilibriumScratch::default(),
        })
    }

    /// The actuated Jacobian at `q` (6×n, column-major), computed into `jac_a` unless the
    /// springs are the actuated joints, whose Jacobian [`loaded_tip`] left in `jac` — the
    /// caller's precondition is then that its last evaluation was at this `q`.
    fn evaluate_actuated(&mut self, chain: &SerialChain, q: &[f64]) -> Result<(), VjmError> {
        if self.springs_are_actuated {
            return Ok(());
        }
        jacobian_in_place(
            chain,
            &self.actuated_model,
            q,
            &mut self.actuated,
            &mut self.jac_a,
        )
    }

    /// The Jacobian [`Self::evaluate_actuated`] last gave.
    fn actuated_jacobian(&self) -> &[f64] {
        if self.springs_are_actuated {
            &self.jac
        } else {
            &self.jac_a
        }
    }
}

/// The loaded tip at one configuration, as the model predicts it.
#[derive(Debug, Clone, Copy)]
struct LoadedTip {
    /// Unloaded tip point and rotation.
    p: Vector3<f64>,
    r: Matrix3<f64>,
    /// Deflection `[translation; rotation]`, base frame.
    d: Vector3<f64>,
    phi: Vector3<f64>,
}

/// `K_C θ` in O(m), with K_C as in [`crate::complementary_stiffness`] at the workspace's last
/// evaluation: row k sums the springs before k through their total rotation
/// Ω_k = Σ_{i<k} θ_i w_i, and those at or after k through the tip motion
/// V_k = Σ_{i≥k} θ_i w_i × (p − c_i) (both terms are linear in w_i); a translation i adds
/// θ_i w_i to V and nothing to Ω, a translation k reads (Ω × w_k)·f only.
pub(crate) fn kc_times(ws: &Workspace, wrench: &[f64; 6], theta: &[f64], out: &mut [f64]) {
    let f = Vector3::new(wrench[0], wrench[1], wrench[2]);
    let mo = Vector3::new(wrench[3], wrench[4], wrench[5]);
    let m = theta.len();
    let tr = &ws.translation;
    let mut v = Vector3::zeros();
    for k in (0..m).rev() {
        // The column's linear part written out: through `kinematics::column`'s pair the
        // compiler spilled it and reloaded it across a partial store (a store-forwarding stall
        // that cost the weightless compensation 20 %).
        let wk = ws.w[k];
        let lin = if tr[k] {
            wk
        } else {
            wk.cross(&(ws.p - ws.c[k]))
        };
        v += lin * theta[k];
        // A translation's generalised force w_k·f does not see the tip move.
        out[k] = if tr[k] {
            0.0
        } else {
            ws.w[k].cross(&v).dot(&f)
        };
    }
    let mut omega = Vector3::zeros();
    for k in 0..m {
        let wk = ws.w[k];
        let dw = omega.cross(&wk);
        if tr[k] {
            // Only the rotations before k turn it; nothing before k adds to Ω.
            out[k] += dw.dot(&f);
            continue;
        }
        let r = ws.p - ws.c[k];
        out[k] += (dw.cross(&r) + wk.cross(&omega.cross(&r))).dot(&f) + dw.dot(&mo);
        omega += wk * theta[k];
    }
}

/// The load of one row: a fixed base-frame wrench, or a payload whose moment turns with the tip.
#[derive(Debug, Clone, Copy)]
enum RowLoad {
    Wrench([f64; 6]),
    Payload(crate::stiffness_model::PointMass),
}

/// Evaluates the model's loaded tip at `q`; `None` when the K_C equilibrium diverges.
#[allow(clippy::needless_range_loop)] // indexes four parallel per-spring arrays
fn loaded_tip(
    chain: &SerialChain,
    springs: &ModelSprings<'_>,
    q: &[f64],
    load: &RowLoad,
    opts: &CompensateOptions,
    ws: &mut CompensationWorkspace,
) -> Result<Option<LoadedTip>, VjmError> {
    let (model, compliance, curved) = (springs.model, springs.compliance, &springs.curved);
    jacobian_in_place(chain, model, q, &mut ws.springs, &mut ws.jac)?;
    let p = ws.springs.p;
    let r = ws.springs.tip_rotation(chain);
    if let Some(g) = &opts.gravity {
        // The weight's sag and the load's deflection together, on the deflected chain.
        let (payload, wrench) = match load {
            RowLoad::Wrench(w) => (None, Some(*w)),
            RowLoad::Payload(pm) => (Some(pm), None),
        };
        if ws.weight.as_ref().is_none_or(|w| w.gravity() != *g) {
            ws.weight = Some(GravityWorkspace::new(chain, model, g, None)?);
        }
        let weight = ws
            .weight
            .as_mut()
            .expect("the weight's workspace was just built");
        weight.set_payload(payload);
        weight.evaluate(chain, q)?;
        let loading = Loading {
            gravity: Some(*g),
            payload,
            wrench,
        };
        let springs = Compliances {
            linear: compliance,
            gears: curved.curves(),
        };
        let settled = equilibrium_from(
            chain,
            model,
            &springs,
            q,
            &loading,
            Some(&*weight),
            &mut ws.equilibrium,
        );
        return match settled {
            Ok(eq) => {
                let d = eq.tip.translation.vector - p;
                let phi = (eq.tip.rotation.to_rotation_matrix()
                    * Rotation3::from_matrix_unchecked(r.transpose()))
                .scaled_axis();
                Ok(Some(LoadedTip { p, r, d, phi }))
            }
            Err(VjmError::Numerical { .. }) => Ok(None), // beyond the springs' stability
            Err(e) => Err(e),
        };
    }
    let wrench = match load {
        RowLoad::Wrench(w) => *w,
        RowLoad::Payload(pm) => pm.wrench_at(&r),
    };
    let m = compliance.len();
    for k in 0..m {
        let col = &ws.jac[6 * k..6 * k + 6];
        let tau: f64 = col.iter().zip(&wrench).map(|(a, b)| a * b).sum();
        ws.tau[k] = tau;
        ws.theta0[k] = compliance[k] * tau;
        ws.theta[k] = ws.theta0[k];
    }
    let warm = opts.with_kc && ws.kc_share_valid;
    if warm {
        for ((t, t0), s) in ws.theta.iter_mut().zip(&ws.theta0).zip(&ws.kc_share) {
            *t = t0 + s;
        }
    } else {
        // A curved spring deflects by c τ + e(τ) (`crate::gear`).
        curved.add_excess(&ws.tau, &mut ws.theta);
    }
    if opts.with_kc {
        let mut converged = false;
        // A linear contraction, r = ‖C K_C‖ ≈ 1e-2 under a tip load: the bound on the changes
        // still to come ends the iterations a step before the change itself is rounding.
        let mut changes = Contraction::new();
        for _ in 0..DEFLECTION_MAX_ITERATIONS {
            kc_times(&ws.springs, &wrench, &ws.theta, &mut ws.ktheta);
            let mut change = 0.0f64;
            let mut scale = 0.0f64;
            for k in 0..m {
                let mut next = ws.theta0[k] + compliance[k] * ws.ktheta[k];
                if let Some(curve) = curved.of(k) {
                    // The curve at the spring's whole torque, the load's and K_C's.
                    let e = curve.excess(ws.tau[k] + ws.ktheta[k]);
                    if e != 0.0 {
                        next += e;
                    }
                }
                change = change.max((next - ws.theta[k]).abs());
                scale = scale.max(next.abs());
                ws.theta[k] = next;
            }
            if !scale.is_finite() {
                break;
            }
            if changes.remaining(change, true) <= 1e-15 * scale || scale == 0.0 {
                converged = true;
                break;
            }
        }
        if !converged {
            ws.kc_share_valid = false;
            return Ok(None);
        }
        for ((s, t), t0) in ws.kc_share.iter_mut().zip(&ws.theta).zip(&ws.theta0) {
            *s = t - t0;
        }
        ws.kc_share_valid = true;
    }
    let mut d = [0.0; 6];
    for k in 0..m {
        let col = &ws.jac[6 * k..6 * k + 6];
        for (x, c) in d.iter_mut().zip(col) {
            *x += c * ws.theta[k];
        }
    }
    Ok(Some(LoadedTip {
        p,
        r,
        d: Vector3::new(d[0], d[1], d[2]),
        phi: Vector3::new(d[3], d[4], d[5]),
    }))
}

/// Orientation error `log(exp(φ) R R*ᵀ)`, rad, base frame.
fn rotation_residual(t: &LoadedTip, target: &Matrix3<f64>) -> Vector3<f64> {
    // so3::log is accurate down to θ = 0 (nalgebra's Rotation3 angle takes the acos of the
    // trace, which is NaN when rounding puts the trace just above 3).
    let loaded = exp(&t.phi) * Rotation3::from_matrix_unchecked(t.r);
    log(&(loaded * Rotation3::from_matrix_unchecked(target.transpose())))
}

/// The rows of the task Jacobian used for a position-only or a full-pose task.
#[derive(Debug, Clone, Copy)]
struct Task<const D: usize> {
    /// Rows of the 6×n actuated Jacobian, `[linear; angular]`.
    rows: [usize; D],
    /// Factor per row (1 for linear rows, L for angular ones).
    scale: [f64; D],
}

/// The two small symmetric solves the steps need, for the 3×3 and 6×6 task Gram matrices
/// (nalgebra's eigen-decomposition is not generic over a const dimension).
trait SmallSymmetric<const D: usize> {
    /// Smallest and largest eigenvalue.
    fn extreme_eigenvalues(&self) -> (f64, f64);
    /// `self⁻¹ b` by Cholesky; `None` when not positive definite.
    fn solve_spd(&self, b: &SVector<f64, D>) -> Option<SVector<f64, D>>;
}

impl SmallSymmetric<3> for SMatrix<f64, 3, 3> {
    /// In closed form (a position task, the common case); (0, 0) — reported as singular —
    /// for a NaN.
    fn extreme_eigenvalues(&self) -> (f64, f64) {
        match stiffness_core::decompose::symmetric_eigenvalues_3(self) {
            Some([lo, _, hi]) => (lo, hi),
            None => (0.0, 0.0),
        }
    }
    fn solve_spd(&self, b: &SVector<f64, 3>) -> Option<SVector<f64, 3>> {
        self.cholesky().map(|c| c.solve(b))
    }
}

impl SmallSymmetric<6> for SMatrix<f64, 6, 6> {
    /// (0, 0) — reported as singular — when the capped decomposition fails (NaN).
    fn extreme_eigenvalues(&self) -> (f64, f64) {
        match stiffness_core::decompose::symmetric_eigen(*self, "task J Jᵀ") {
            Ok(e) => (e.eigenvalues.min(), e.eigenvalues.max()),
            Err(_) => (0.0, 0.0),
        }
    }
    fn solve_spd(&self, b: &SVector<f64, 6>) -> Option<SVector<f64, 6>> {
        self.cholesky().map(|c| c.solve(b))
    }
}

impl<const D: usize> Task<D>
where
    SMatrix<f64, D, D>: SmallSymmetric<D>,
{
    fn column(&self, jac_a: &[f64], j: usize) -> SVector<f64, D> {
        SVector::<f64, D>::from_fn(|r, _| jac_a[6 * j + self.rows[r]] * self.scale[r])
    }

    /// `J Jᵀ` (D×D) of the n-column task Jacobian, and its inverse condition σ_min/σ_max.
    fn gram(&self, jac_a: &[f64], n: usize) -> (SMatrix<f64, D, D>, f64, f64) {
        let mut g = SMatrix::<f64, D, D>::zeros();
        for j in 0..n {
            let c = self.column(jac_a, j);
            g += c * c.transpose();
        }
        let (lmin, lmax) = g.extreme_eigenvalues();
        let (lmin, lmax) = (lmin.max(0.0), lmax.max(0.0));
        let inv_cond = if lmax > 0.0 {
            (lmin / lmax).sqrt()
        } else {
            0.0
        };
        (g, inv_cond, lmax)
    }

    /// One damped minimum-norm step `Δq = Jᵀ(J Jᵀ + λ²I)⁻¹(−r)` into `dq`, with λ = 0 when
    /// the task is well conditioned and λ = threshold·σ_max otherwise; returns σ_min/σ_max.
    fn step(
        &self,
        jac_a: &[f64],
        residual: SVector<f64, D>,
        threshold: f64,
        dq: &mut [f64],
    ) -> f64 {
        let (mut g, inv_cond, lmax) = self.gram(jac_a, dq.len());
        if inv_cond < threshold {
            g += SMatrix::<f64, D, D>::identity()
                * (threshold * threshold * lmax).max(f64::MIN_POSITIVE);
        }
        let y = g.solve_spd(&(-residual)).unwrap_or_else(SVector::zeros);
        for (j, x) in dq.iter_mut().enumerate() {
            *x = self.column(jac_a, j).dot(&y);
        }
        inv_cond
    }
}

const POSITION_TASK: Task<3> = Task {
    rows: [0, 1, 2],
    scale: [1.0; 3],
};

fn pose_task(length: f64) -> Task<6> {
    Task {
        rows: [0, 1, 2, 3, 4, 5],
        scale: [1.0, 1.0, 1.0, length, length, length],
    }
}

/// Corrected joint targets for N rows: `q_nominal` N×n row-major (rad), `load` one wrench per
/// row (N×6, base frame, at the tip point) or one payload for all rows,
/// `compliance` one value per spring of `model` (rad/(N·m); for a model with aliased springs
/// any vector that reproduces the identifiable combinations, e.g. the minimum-norm solution).
/// Input errors (shapes, NaN) fail the call naming the row; per-row numerical
/// outcomes are in [`CompensatedRow::status`].
///
/// ```
/// use vjm::{compensate, CompensateOptions, CompensationStatus, Load, SerialChain, VirtualJointModel};
/// let panda = SerialChain::bundled();
/// let model = VirtualJointModel::traditional(7);
/// let c = [1e-4; 7];
/// let q = [0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8];
/// let load = Load::Wrench(&[0.0, 0.0, -50.0, 0.0, 0.0, 0.0]);
/// let out = compensate(&panda, &model, &c, &q, load, &CompensateOptions::default()).unwrap();
/// assert_eq!(out.rows[0].status, CompensationStatus::Converged);
/// assert!(out.rows[0].position_error <= 1e-9 && out.rows[0].deflection > 1e-4);
/// ```
pub fn compensate(
    chain: &SerialChain,
    model: &VirtualJointModel,
    compliance: &[f64],
    q_nominal: &[f64],
    load: Load<'_>,
    opts: &CompensateOptions,
) -> Result<Compensation, VjmError> {
    compensate_with_gears(chain, model, compliance, &[], q_nominal, load, opts)
}

/// [`compensate`] with non-linear gears ([`GearCurve`], on the torsion springs of `model`; an
/// error names a joint without one): the model's loaded tip bends each curved spring by its
/// curve. Under gravity ([`CompensateOptions::gravity`]) that is the exact equilibrium with the
/// curves ([`crate::gravity::static_equilibrium_with_gears`]); weightless, the curved spring deflects by
/// `c τ + e(τ)` at the load's torque τ (with K_C, `τ = Jᵀ W + (K_C Δθ)_k`), `e(T) = Σ a h(T)`
/// the curve's excess. Without curves it is [`compensate`], bit for bit.
pub fn compensate_with_gears(
    chain: &SerialChain,
    model: &VirtualJointModel,
    compliance: &[f64],
    gears: &[GearCurve],
    q_nominal: &[f64],
    load: Load<'_>,
    opts: &CompensateOptions,
) -> Result<Compensation, VjmError> {
    let springs = torsion_springs(model, gears)?;
    let curved = CurvedSprings::new(gears, &springs);
    let n = chain.n_joints().max(1);
    let mut q = vec![0.0; q_nominal.len()];
    let mut rows = vec![
        CompensatedRow {
            status: CompensationStatus::NotConverged,
            iterations: 0,
            position_error: f64::NAN,
            rotation_error: f64::NAN,
            deflection: f64::NAN,
            rotation_deflection: f64::NAN,
            inverse_condition: f64::NAN,
            limit_joint: None,
        };
        q_nominal.len() / n
    ];
    // Every input checked once, on all rows (errors name the row), before any work.
    check_inputs(chain, model, compliance, q_nominal, load, opts)?;
    // Rows are independent (each starts from its nominal targets): fixed-size blocks on
    // every core, each with its own workspace, give the serial run's values and first error
    // whatever the number of threads.
    fill_row_blocks_pair(
        &mut rows,
        &mut q,
        n,
        COMPENSATION_BLOCK_ROWS,
        |range, rows, q| {
            let mut ws = CompensationWorkspace::new(chain, model)?;
            let spring = ModelSprings {
                model,
                compliance,
                curved,
            };
            let targets = CompensationTargets { q_nominal, load };
            let out = CompensationBuffers { q, rows };
            compensate_rows(chain, &spring, targets, opts, &mut ws, range, out)
        },
    )?;
    Ok(Compensation { q, rows })
}

/// The rows a batch compensation corrects: nominal joint targets `q_nominal` (N×n row-major,
/// rad, base frame as the chain's) and the load they carry ([`Load`]: one wrench per row, or
/// one payload for all).
#[derive(Debug, Clone, Copy)]
pub struct CompensationTargets<'a> {
    /// Nominal joint targets, N×n row-major, rad.
    pub q_nominal: &'a [f64],
    /// The load of every row.
    pub load: Load<'a>,
}

/// The caller-owned outputs of [`compensate_in_place`]: the corrected joint targets `q` (N×n
/// row-major, rad) and one report per row `rows` (N), for the N rows of its [`CompensationTargets`].
#[derive(Debug)]
pub struct CompensationBuffers<'a> {
    /// Corrected joint targets, N×n row-major, rad.
    pub q: &'a mut [f64],
    /// One report per row.
    pub rows: &'a mut [CompensatedRow],
}

/// [`compensate`] of `targets` into caller-owned buffers `out` (targets N×n, reports N) with
/// a reusable workspace: no allocation per row. Every input is checked before anything is
/// written.
pub fn compensate_in_place(
    chain: &SerialChain,
    model: &VirtualJointModel,
    compliance: &[f64],
    targets: CompensationTargets<'_>,
    opts: &CompensateOptions,
    ws: &mut CompensationWorkspace,
    out: CompensationBuffers<'_>,
) -> Result<(), VjmError> {
    let CompensationTargets { q_nominal, load } = targets;
    let CompensationBuffers {
        q: q_out,
        rows: rows_out,
    } = out;
    let rows = check_inputs(chain, model, compliance, q_nominal, load, opts)?;
    let n = chain.n_joints();
    if q_out.len() != rows * n {
        return Err(VjmError::ShapeMismatch {
            what: "corrected targets output (N×n)",
            expected: rows * n,
            got: q_out.len(),
        });
    }
    if rows_out.len() != rows {
        return Err(VjmError::ShapeMismatch {
            what: "row reports output (N)",
            expected: rows,
            got: rows_out.len(),
        });
    }
    if ws.jac.len() != 6 * model.n_params() || ws.jac_a.len() != 6 * n {
        return Err(VjmError::InvalidModel {
            message: "the compensation workspace was built for another chain or model; create it with CompensationWorkspace::new(chain, model)".into(),
        });
    }
    let spring = ModelSprings {
        model,
        compliance,
        curved: CurvedSprings::new(&[], &[]),
    };
    compensate_rows(
        chain,
        &spring,
        targets,
        opts,
        ws,
        0..rows,
        CompensationBuffers {
            q: q_out,
            rows: rows_out,
        },
    )
}

/// The model's springs as a compensation evaluates them: the spring model, its compliances
/// (rad/(N·m)) and its gear curves.
#[derive(Debug, Clone, Copy)]
struct ModelSprings<'a> {
    model: &'a VirtualJointModel,
    compliance: &'a [f64],
    curved: CurvedSprings<'a>,
}

/// Rows per block of a multi-threaded [`compensate`]: a Gauss–Newton solve per row costs
/// tens of µs, so 256 rows amortise a block's workspace and balance well on 10³–10⁶ rows.
const COMPENSATION_BLOCK_ROWS: usize = 256;

/// Checks the inputs of a compensation (options, shapes, finite values of every row) and
/// returns the number of rows N.
fn check_inputs(
    chain: &SerialChain,
    model: &VirtualJointModel,
    compliance: &[f64],
    q_nominal: &[f64],
    load: Load<'_>,
    opts: &CompensateOptions,
) -> Result<usize, VjmError> {
    opts.check()?;
    model.check_chain(chain)?;
    let n = chain.n_joints();
    let rows = q_nominal.len() / n;
    if compliance.len() != model.n_params() {
        return Err(VjmError::ShapeMismatch {
            what: "compliance (one per spring)",
            expected: model.n_params(),
            got: compliance.len(),
        });
    }
    check_finite("compliance", compliance, 0, 0)?;
    if q_nominal.len() != rows * n || rows == 0 {
        return Err(VjmError::ShapeMismatch {
            what: "q_nominal (N×n row-major)",
            expected: rows * n + n,
            got: q_nominal.len(),
        });
    }
    if let Load::Wrench(w) = load {
        if w.len() != 6 * rows {
            return Err(VjmError::ShapeMismatch {
                what: "wrench (one [fx, fy, fz, mx, my, mz] per row of q_nominal)",
                expected: 6 * rows,
                got: w.len(),
            });
        }
    }
    for i in 0..rows {
        check_finite("q", &q_nominal[i * n..(i + 1) * n], i, 0)?;
        if let Load::Wrench(w) = load {
            check_finite("wrench", &w[6 * i..6 * i + 6], i, 0)?;
        }
    }
    Ok(rows)
}

/// The rows `range` of checked targets into their block of the outputs (`out` holds those
/// rows only).
fn compensate_rows(
    chain: &SerialChain,
    springs: &ModelSprings<'_>,
    targets: CompensationTargets<'_>,
    opts: &CompensateOptions,
    ws: &mut CompensationWorkspace,
    range: std::ops::Range<usize>,
    out: CompensationBuffers<'_>,
) -> Result<(), VjmError> {
    let CompensationTargets { q_nominal, load } = targets;
    let CompensationBuffers {
        q: q_out,
        rows: rows_out,
    } = out;
    let n = chain.n_joints();
    let first = range.start;
    for i in range {
        let row_load = match load {
            Load::Wrench(w) => RowLoad::Wrench(w[6 * i..6 * i + 6].try_into().expect("6 values")),
            Load::Payload(pm) => RowLoad::Payload(pm),
        };
        let qn = &q_nominal[i * n..(i + 1) * n];
        let k = i - first;
        let q = &mut q_out[k * n..(k + 1) * n];
        rows_out[k] = compensate_row(chain, springs, qn, &row_load, opts, ws, q)?;
    }
    Ok(())
}

fn compensate_row(
    chain: &SerialChain,
    springs: &ModelSprings<'_>,
    q_nominal: &[f64],
    load: &RowLoad,
    opts: &CompensateOptions,
    ws: &mut CompensationWorkspace,
    q: &mut [f64],
) -> Result<CompensatedRow, VjmError> {
    let n = q.len();
    q.copy_from_slice(q_nominal);
    let mut report = CompensatedRow {
        status: CompensationStatus::Unstable,
        iterations: 0,
        position_error: f64::NAN,
        rotation_error: f64::NAN,
        deflection: f64::NAN,
        rotation_deflection: f64::NAN,
        inverse_condition: f64::NAN,
        limit_joint: None,
    };
    ws.kc_share_valid = false; // each row from its own start
    let Some(nominal) = loaded_tip(chain, springs, q, load, opts, ws)? else {
        return Ok(report);
    };
    // Conditioning at the nominal targets (a row can start at a singularity and leave it).
    ws.evaluate_actuated(chain, q)?;
    let nominal_inverse_condition = if opts.match_orientation {
        pose_task(opts.length).gram(ws.actuated_jacobian(), n).1
    } else {
        POSITION_TASK.gram(ws.actuated_jacobian(), n).1
    };
    // The actuated Jacobian is at the current q until the first step moves it.
    let mut actuated_current = true;
    report.deflection = nominal.d.norm();
    report.rotation_deflection = nominal.phi.norm();
    let (target_p, target_r) = (nominal.p, nominal.r);
    let mut tip = nominal;
    let l = opts.length;
    let mut dq = std::mem::take(&mut ws.dq);
    dq.resize(n, 0.0);
    let pose = pose_task(l);
    let converged;
    loop {
        let rp = tip.p + tip.d - target_p;
        let rr = rotation_residual(&tip, &target_r);
        report.position_error = rp.norm();
        report.rotation_error = rr.norm();
        let done = report.position_error <= opts.position_tol
            && (!opts.match_orientation || report.rotation_error <= opts.rotation_tol);
        if done || report.iterations >= opts.max_iterations {
            converged = done;
            break;
        }
        if !actuated_current {
            ws.evaluate_actuated(chain, q)?;
        }
        report.inverse_condition = if opts.match_orientation {
            let r = SVector::<f64, 6>::new(rp.x, rp.y, rp.z, l * rr.x, l * rr.y, l * rr.z);
            pose.step(
                ws.actuated_jacobian(),
                r,
                opts.min_inverse_condition,
                &mut dq,
            )
        } else {
            POSITION_TASK.step(
                ws.actuated_jacobian(),
                rp,
                opts.min_inverse_condition,
                &mut dq,
            )
        };
        actuated_current = false;
        let mut norm_dq = 0.0;
        let mut norm_q = 0.0;
        for (x, d) in q.iter_mut().zip(dq.iter()) {
            *x += d;
            norm_dq += d * d;
            norm_q += *x * *x;
        }
        report.iterations += 1;
        match loaded_tip(chain, springs, q, load, opts, ws)? {
            Some(t) => tip = t,
            None => {
                report.status = CompensationStatus::Unstable;
                ws.dq = dq;
                return Ok(report);
            }
        }
        if norm_dq.sqrt() <= opts.step_rtol * norm_q.sqrt().max(1.0) {
            let rp = tip.p + tip.d - target_p;
            report.position_error = rp.norm();
            report.rotation_error = rotation_residual(&tip, &target_r).norm();
            converged = report.position_error <= opts.position_tol
                && (!opts.match_orientation || report.rotation_error <= opts.rotation_tol);
            break;
        }
    }
    ws.dq = dq;
    // Conditioning at the final targets (also when the first residual was already small).
    if !actuated_current {
        ws.evaluate_actuated(chain, q)?;
    }
    report.inverse_condition = if opts.match_orientation {
        pose.gram(ws.actuated_jacobian(), n).1
    } else {
        POSITION_TASK.gram(ws.actuated_jacobian(), n).1
    };
    if opts.check_limits {
        report.limit_joint = chain
            .limits()
            .iter()
            .zip(q.iter())
            .position(|(&(lo, hi), &x)| x < lo || x > hi);
    }
    report.status = if !converged {
        CompensationStatus::NotConverged
    } else if report.inverse_condition.min(nominal_inverse_condition) < opts.min_inverse_condition {
        CompensationStatus::NearSingular
    } else if report.limit_joint.is_some() {
        CompensationStatus::OutsideLimits
    } else {
        CompensationStatus::Converged
    };
    Ok(report)
}

impl crate::stiffness_model::StiffnessModel {
    /// [`compensate`] with this model's springs and compliance vector (any member of the
    /// family that reproduces the identifiable combinations: the compensation, like a
    /// prediction, depends on the aliased springs only through those combinations when the
    /// rows lie in the identified row space). The robot is checked against the model first.
    pub fn compensate(
        &self,
        chain: &SerialChain,
        q_nominal: &[f64],
        load: Load<'_>,
        opts: &CompensateOptions,
    ) -> Result<Compensation, crate::stiffness_model::ModelError> {
        self.check_robot(chain, "<model>")?;
        let model = self.spring_model()?;
        // What the data determine: K_C and the equilibria are non-linear in C and would
        // amplify the noise of a barely seen direction.
        let compliance = self.determined_compliance()?;
        let gears = self.gear_curves()?;
        Ok(compensate_with_gears(
            chain,
            &model,
            &compliance,
            &gears,
            q_nominal,
            load,
            opts,
        )?)
    }
}
