//! Measurement planning: poses inside the joint limits and, per pose, wrenches chosen so that
//! the worst predicted standard error of the model's identifiable combinations is small, under
//! a stated noise model (docs/use-the-model.md#design).

use nalgebra::{DMatrix, DVector, Matrix3, SymmetricEigen};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;
use stiffness_core::num::Short;
use stiffness_core::{Monitor, Progress};

use crate::chain::SerialChain;
use crate::error::VjmError;
use crate::gravity::{GravityWorkspace, RowFrame};
use crate::identify::{CombinationTerm, IdentifyOptions};
use crate::instruments::{ForceSensorNoise, TrackerNoise};
use crate::kinematics::{inverse_condition_at, jacobian_in_place, Workspace};
use crate::measurements::Measurements;
use crate::model::VirtualJointModel;
use crate::model::NOMINAL_TORSION;

/// The noise of a campaign as the plan assumes it: laser-tracker displacement noise (per axis,
/// growing with the distance to the tracker) plus force/torque-sensor noise, which enters the
/// displacement equations as `−(J C Jᵀ)_t δW` and so needs a prior compliance C.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NoiseModel {
    /// Tracker noise (default: [`TrackerNoise::default`], 15 µm + 6 µm/m MPE read as 2σ, 2.5 m
    /// from the robot).
    pub tracker: TrackerNoise,
    /// Force/torque sensor noise (default: [`ForceSensorNoise::default`], 1 % of 100 N /
    /// 10 N·m as 2σ).
    pub force_sensor: ForceSensorNoise,
    /// Prior compliance per spring of the model, rad/(N·m) (default: the Panda-class
    /// [`NOMINAL_TORSION`], tilts 0).
    pub prior_compliance: Vec<f64>,
    /// The gravity the campaign is measured under, base frame (default `None`, weightless, as
    /// [`IdentifyOptions::gravity`]; Python and the CLI default to standard gravity). Under
    /// gravity each row is planned at the arm's sagged pose under the prior compliance — the
    /// Jacobian, tip point and tracker noise at θ₀ = C τ₀ — which is where a measurement under
    /// the weight takes its loaded − unloaded displacement (the coupling of gravity's stiffness
    /// into the load, ‖C K_G‖ ≈ 1e-2 of it, is left out).
    pub gravity: Option<crate::gravity::Gravity>,
}

impl NoiseModel {
    /// A typical campaign's instruments ([`TrackerNoise::default`],
    /// [`ForceSensorNoise::default`]) and a Panda-class prior ([`NOMINAL_TORSION`]) for `model`.
    pub fn typical(model: &VirtualJointModel) -> Self {
        let prior = model
            .springs()
            .iter()
            .map(|s| {
                // The torsion springs only (a link translation's prior is 0, like a tilt's).
                if s.axis == crate::model::SpringAxis::Z && !s.is_translation() {
                    NOMINAL_TORSION[s.joint % 7]
                } else {
                    0.0
                }
            })
            .collect();
        Self {
            tracker: TrackerNoise::default(),
            force_sensor: ForceSensorNoise::default(),
            prior_compliance: prior,
            gravity: None,
        }
    }

    /// The former name of [`NoiseModel::typical`].
    #[deprecated(note = "use NoiseModel::typical: planning's defaults are a typical campaign's")]
    pub fn testbed(model: &VirtualJointModel) -> Self {
        Self::typical(model)
    }
}

/// What [`design`] is asked for. Defaults: 24 poses × 4 wrenches, forces of 80 N
/// and moments of 3 N·m (the testbed campaign's largest), poses 0.1 rad inside the limits and
/// away from singularities (the testbed's filters), a pool of 300 candidate poses.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[non_exhaustive]
pub struct PlanSpec {
    /// Number of poses.
    pub n_poses: usize,
    /// Wrenches per pose.
    pub wrenches_per_pose: usize,
    /// Force magnitude of every planned wrench, N.
    pub force: f64,
    /// Moment magnitude of the wrenches that carry one, N·m.
    pub moment: f64,
    /// Poses stay this far inside each joint limit, rad.
    pub limit_margin: f64,
    /// Smallest inverse condition of the actuated Jacobian `[J_lin; 0.5 m·J_ang]`.
    pub min_inverse_condition: f64,
    /// Smallest tip height above the base, m.
    pub min_tip_height: f64,
    /// Candidate poses drawn (uniform within the limits, filtered).
    pub pool_size: usize,
    /// Seed of the pool.
    pub seed: u64,
}

impl Default for PlanSpec {
    fn default() -> Self {
        Self {
            n_poses: 24,
            wrenches_per_pose: 4,
            force: 80.0,
            moment: 3.0,
            limit_margin: 0.1,
            min_inverse_condition: 0.05,
            min_tip_height: 0.1,
            pool_size: 300,
            seed: 0,
        }
    }
}

/// One identifiable combination with its predicted standard error.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlannedCombination {
    /// Label as the identification prints it (e.g. `J1y + 1.000000*J2z`).
    pub label: String,
    /// Terms (parameter index, joint, axis, coefficient).
    pub terms: Vec<CombinationTerm>,
    /// Predicted standard error of the identification's estimate, rad/(N·m).
    pub stderr: f64,
    /// Whether the plan leaves the combination weak: its predicted standard error exceeds the
    /// size the prior gives it (Σ |coefficient|·compliance, a tilt taken as large as the
    /// model's median prior torsion) or any plausible compliance
    /// ([`crate::screening::is_weak`]): the identification will not tell it from 0.
    pub weak: bool,
}

/// The result of [`design`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Plan {
    /// Joint positions per measurement row, rows×n row-major, rad.
    pub q: Vec<f64>,
    /// Wrench per row, base frame at the tip point, N and N·m.
    pub wrench: Vec<[f64; 6]>,
    /// Pose index (0-based) per row.
    pub pose: Vec<usize>,
    /// Rank of the planned design (number of identifiable combinations).
    pub rank: usize,
    /// Every identifiable combination and its predicted standard error.
    pub combinations: Vec<PlannedCombination>,
    /// The largest predicted standard error, rad/(N·m).
    pub worst_stderr: f64,
    /// The noise model the prediction assumes.
    pub noise: NoiseModel,
    /// Fewest wrenches per pose with which diagnose's `pose_compliance` block (compliance
    /// that changes from pose to pose) can test a pose: [`pose_compliance_wrenches`].
    pub pose_compliance_wrenches: usize,
}

/// Fewest wrenches per pose with which diagnose's `pose_compliance` lack-of-fit block can
/// test a pose of an arm with `n_joints` joints. Within a pose the block frees 3 offsets and
/// a scale of each joint's torsion response; the pose's 3W equations must keep at least one
/// degree of freedom beyond those, 3W > 3 + n, so W = ⌊(3 + n)/3⌋ + 1 (4 for 6 or 7 joints).
pub fn pose_compliance_wrenches(n_joints: usize) -> usize {
    (3 + n_joints) / 3 + 1
}

/// Translation rows of the regressor `A[r][k] = J[r][k]·(J_kᵀ W)` (3×m) and the displacement
/// noise covariance of one row at a configuration whose Jacobian is `jac` (6×m column-major)
/// and tip point `p`.
struct PoseData {
    jac: Vec<f64>,
    /// The whitened translation rows `M = L⁻¹ J_lin` (3×m, column k at `3k..3k+3`).
    mw: Vec<f64>,
    /// Displacement noise covariance, m².
    cov: Matrix3<f64>,
}

/// Per-call scratch of [`pose_data`]: the kinematics workspace and, under gravity, the weight's.
struct PoseScratch {
    ws: Workspace,
    weight: Option<GravityWorkspace>,
    preload: Vec<f64>,
}

impl PoseScratch {
    fn new(
        chain: &SerialChain,
        model: &VirtualJointModel,
        noise: &NoiseModel,
    ) -> Result<Self, VjmError> {
        Ok(PoseScratch {
            ws: Workspace::new(chain, model)?,
            weight: noise
                .gravity
                .map(|g| GravityWorkspace::new(chain, model, &g, None))
                .transpose()?,
            preload: vec![0.0; model.n_params()],
        })
    }
}

fn pose_data(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    noise: &NoiseModel,
    scratch: &mut PoseScratch,
) -> Result<PoseData, VjmError> {
    let m = model.n_params();
    let mut jac = vec![0.0; 6 * m];
    let ws = &mut scratch.ws;
    jacobian_in_place(chain, model, q, ws, &mut jac)?;
    let mut p = ws.p;
    if let Some(weight) = scratch.weight.as_mut() {
        // The row's kinematics at the sagged pose under the prior, where it is measured.
        let mut tip_rotation = ws.tip_rotation(chain);
        weight.evaluate(chain, q)?;
        weight.sag(
            &noise.prior_compliance,
            RowFrame {
                jacobian: &mut jac,
                tip: &mut p,
                tip_rotation: &mut tip_rotation,
            },
            &mut scratch.preload,
        )?;
    }
    let sd = noise.tracker.displacement_sigma([p.x, p.y, p.z]);
    let fs = noise.force_sensor.sigma();
    // K = J_t C Jᵀ (3×6): displacement per unit wrench error.
    let mut cov = Matrix3::identity() * sd * sd;
    for a in 0..6 {
        let mut k = [0.0; 3];
        for s in 0..m {
            let g = noise.prior_compliance[s] * jac[6 * s + a];
            for (r, kr) in k.iter_mut().enumerate() {
                *kr += jac[6 * s + r] * g;
            }
        }
        for r in 0..3 {
            for c in 0..3 {
                cov[(r, c)] += k[r] * k[c] * fs[a] * fs[a];
            }
        }
    }
    let whiten = cov
        .cholesky()
        .and_then(|c| c.l().try_inverse())
        .ok_or_else(|| VjmError::Numerical {
            message: "the displacement noise covariance is not positive definite (check the tracker noise)".into(),
        })?;
    let mut mw = vec![0.0; 3 * m];
    for k in 0..m {
        for i in 0..3 {
            mw[3 * k + i] = (0..3).map(|r| whiten[(i, r)] * jac[6 * k + r]).sum();
        }
    }
    Ok(PoseData { jac, mw, cov })
}

/// Regressor translation rows (3×m) at a pose under `wrench`.
fn regressor(jac: &[f64], m: usize, wrench: &[f64; 6]) -> DMatrix<f64> {
    DMatrix::from_fn(3, m, |r, k| {
        let col = &jac[6 * k..6 * k + 6];
        let g: f64 = col.iter().zip(wrench).map(|(a, b)| a * b).sum();
        col[r] * g
    })
}

fn check_noise(model: &VirtualJointModel, noise: &NoiseModel) -> Result<(), VjmError> {
    if noise.prior_compliance.len() != model.n_params() {
        return Err(VjmError::ShapeMismatch {
            what: "prior compliance (one per spring)",
            expected: model.n_params(),
            got: noise.prior_compliance.len(),
        });
    }
    crate::chain::check_finite("prior compliance", &noise.prior_compliance, 0, 0)
}

/// Predicted standard errors of the linear combinations `combinations` (each a list of
/// `(parameter, coefficient)`) as estimated by [`crate::identify`] with its defaults (equal
/// weights, translations) from the rows `q` (N×n) under `wrench` (N), with `noise`:
/// `Var(tᵀĉ) = tᵀ G S G t` with `G` a generalised inverse of `AᵀA` of rank `rank`, and
/// `S = Σ_i A_iᵀ Σ_i A_i` (sandwich: the estimator is unweighted, the noise is not).
pub fn predicted_stderr(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    wrench: &[[f64; 6]],
    rank: usize,
    combinations: &[Vec<(usize, f64)>],
    noise: &NoiseModel,
) -> Result<Vec<f64>, VjmError> {
    check_noise(model, noise)?;
    let n = chain.n_joints();
    let m = model.n_params();
    if q.len() != wrench.len() * n {
        return Err(VjmError::ShapeMismatch {
            what: "q (N×n row-major, one row per wrench)",
            expected: wrench.len() * n,
            got: q.len(),
        });
    }
    let mut scratch = PoseScratch::new(chain, model, noise)?;
    let mut info = DMatrix::<f64>::zeros(m, m);
    let mut meat = DMatrix::<f64>::zeros(m, m);
    for (i, w) in wrench.iter().enumerate() {
        crate::chain::check_finite("wrench", w, i, 0)?;
        let pd = pose_data(chain, model, &q[i * n..(i + 1) * n], noise, &mut scratch)?;
        let a = regressor(&pd.jac, m, w);
        info += a.transpose() * &a;
        let cov = DMatrix::from_fn(3, 3, |r, c| pd.cov[(r, c)]);
        meat += a.transpose() * cov * &a;
    }
    let g = generalised_inverse(&info, rank)?;
    let gsg = &g * meat * &g;
    Ok(combinations
        .iter()
        .map(|terms| {
            let t = DVector::from_fn(m, |k, _| {
                terms.iter().filter(|(p, _)| *p == k).map(|(_, c)| c).sum()
            });
            (t.transpose() * &gsg * &t)[(0, 0)].max(0.0).sqrt()
        })
        .collect())
}

/// `D (D M D)⁺_rank D` with D the inverse column norms: a generalised inverse of M (so
/// estimable functionals come out as with any other), computed on the scaled matrix.
fn generalised_inverse(info: &DMatrix<f64>, rank: usize) -> Result<DMatrix<f64>, VjmError> {
    let m = info.nrows();
    let (scale, eig) = scaled_eigen(info)?;
    if rank == 0 || rank > m {
        return Err(VjmError::Numerical {
            message: format!("the design has rank {rank} of {m} parameters"),
        });
    }
    let order = descending(&eig.eigenvalues);
    let mut g = DMatrix::<f64>::zeros(m, m);
    for &i in order.iter().take(rank) {
        let v = eig.eigenvectors.column(i);
        g += v * v.transpose() / eig.eigenvalues[i];
    }
    Ok(DMatrix::from_fn(m, m, |a, b| {
        g[(a, b)] * scale[a] * scale[b]
    }))
}

/// Column scaling (zero for columns of pure rounding, as in `lsq`) and the eigen-decomposition
/// of the scaled matrix.
fn scaled_eigen(
    info: &DMatrix<f64>,
) -> Result<(Vec<f64>, SymmetricEigen<f64, nalgebra::Dyn>), VjmError> {
    let m = info.nrows();
    let scale = super::column_scale(info);
    let scaled = DMatrix::from_fn(m, m, |a, b| info[(a, b)] * scale[a] * scale[b]);
    let eig = super::symmetric_eigen(scaled, "eigen-decomposition of the scaled information")?;
    Ok((scale, eig))
}

fn descending(values: &DVector<f64>) -> Vec<usize> {
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&a, &b| values[b].total_cmp(&values[a]));
    order
}

/// The candidate wrenches of every pose: the force along one of 13 directions (axes, face and
/// body diagonals; the sign does not change the information), alone or with the moment along
/// ±x, ±y or ±z.
fn candidate_wrenches(force: f64, moment: f64) -> Vec<[f64; 6]> {
    let mut dirs: Vec<[f64; 3]> = Vec::new();
    for x in -1i32..=1 {
        for y in -1i32..=1 {
            for z in -1i32..=1 {
                let v = [x as f64, y as f64, z as f64];
                // One of each ± pair: the first non-zero component positive.
                let first = v.iter().copied().find(|c| *c != 0.0);
                if first == Some(1.0) {
                    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                    dirs.push([v[0] / n, v[1] / n, v[2] / n]);
                }
            }
        }
    }
    let mut out = Vec::new();
    for d in &dirs {
        let f = [force * d[0], force * d[1], force * d[2]];
        out.push([f[0], f[1], f[2], 0.0, 0.0, 0.0]);
        if moment > 0.0 {
            for axis in 0..3 {
                for s in [1.0, -1.0] {
                    let mut w = [f[0], f[1], f[2], 0.0, 0.0, 0.0];
                    w[3 + axis] = s * moment;
                    out.push(w);
                }
            }
        }
    }
    out
}

/// Most random draws [`sample_poses`] makes, whatever the pool size: at a few µs a draw this
/// bounds the sampling to seconds, and a pool that needs more draws than this is refused.
const MAX_DRAWS: usize = 2_000_000;

/// Draws after which a sampler that has accepted nothing gives up: the chain cannot satisfy
/// the filters (a tip that never rises above the base, a chain that is always near-singular).
const HOPELESS_DRAWS: usize = 50_000;

/// Draws `count` poses uniformly within the limits (clamped to ±π, `margin` inside), keeping
/// those above `min_tip_height` with inverse condition ≥ `min_inverse_condition`. At most
/// [`MAX_DRAWS`] draws (fewer when the acceptance rate seen so far says the pool cannot be
/// filled within them); the error then says which filter rejects the poses and by how much.
fn sample_poses(
    chain: &SerialChain,
    spec: &PlanSpec,
    monitor: &Monitor<'_>,
) -> Result<Vec<f64>, VjmError> {
    for (joint, &(lo, hi)) in chain.joints().iter().zip(chain.limits()) {
        let (lo, hi) = (lo.max(-std::f64::consts::PI), hi.min(std::f64::consts::PI));
        if hi - lo <= 2.0 * spec.limit_margin {
            return Err(VjmError::InvalidOption {
                name: "margin",
                message: format!(
                    "{} rad leaves no room inside the limits [{lo}, {hi}] rad of joint `{}`",
                    spec.limit_margin,
                    joint.name()
                ),
            });
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let n = chain.n_joints();
    let mut out = Vec::with_capacity(spec.pool_size * n);
    let cap = spec.pool_size.saturating_mul(2000).min(MAX_DRAWS);
    let (mut low_tip, mut low_condition) = (0usize, 0usize);
    let (mut highest_tip, mut best_condition) = (f64::NEG_INFINITY, 0.0f64);
    let mut attempts = 0usize;
    let mut ws = Workspace::new(chain, &VirtualJointModel::traditional(n))?;
    let mut q = Vec::with_capacity(n);
    while out.len() < spec.pool_size * n {
        let accepted = out.len() / n;
        // Acceptance so far, projected to the cap: stop as soon as the pool cannot be filled.
        let hopeless = attempts >= HOPELESS_DRAWS
            && (accepted as f64 / attempts as f64) * (cap as f64) < spec.pool_size as f64;
        if attempts >= cap || hopeless {
            return Err(VjmError::InvalidOption {
                name: "limit_margin/min_inverse_condition/min_tip_height",
                message: format!(
                    "only {accepted} acceptable poses in {attempts} draws, {} needed (a pool \
                     needs at most {cap} draws): {low_tip} draws put the tip `{}` less than {} m \
                     above the base `{}` (highest {} m), {low_condition} had an inverse condition \
                     below {} (best {}); use a smaller pool, a smaller margin, or a chain whose \
                     tip rises above its base",
                    spec.pool_size,
                    chain.tip_link(),
                    spec.min_tip_height,
                    chain.base_link(),
                    Short(highest_tip),
                    spec.min_inverse_condition,
                    Short(best_condition),
                ),
            });
        }
        attempts += 1;
        if attempts.is_multiple_of(4096) {
            monitor.report(Progress {
                stage: "poses",
                done: accepted,
                total: spec.pool_size,
            })?;
        }
        q.clear();
        q.extend(chain.limits().iter().map(|&(lo, hi)| {
            let (lo, hi) = (lo.max(-std::f64::consts::PI), hi.min(std::f64::consts::PI));
            rng.random_range(lo + spec.limit_margin..hi - spec.limit_margin)
        }));
        // One evaluation of the frames per draw: the tip height, then the Jacobian there.
        ws.evaluate(chain, &q);
        let tip_z = ws.p.z;
        highest_tip = highest_tip.max(tip_z);
        if tip_z < spec.min_tip_height {
            low_tip += 1;
            continue;
        }
        let condition = inverse_condition_at(&mut ws);
        best_condition = best_condition.max(condition);
        if condition < spec.min_inverse_condition {
            low_condition += 1;
            continue;
        }
        out.extend_from_slice(&q);
    }
    Ok(out)
}

/// Most rows a plan may have (poses × wrenches per pose): the planning time and the plan's
/// size grow with it, and this keeps the largest plan within a minute on two cores.
pub const MAX_MEASUREMENTS: usize = 100_000;

fn check_spec(spec: &PlanSpec) -> Result<(), VjmError> {
    let bad = |name: &'static str, message: String| Err(VjmError::InvalidOption { name, message });
    if spec.n_poses == 0 || spec.n_poses > 10_000 {
        return bad(
            "poses",
            format!("must be in 1..=10000, got {}", spec.n_poses),
        );
    }
    if spec.wrenches_per_pose == 0 || spec.wrenches_per_pose > 100 {
        return bad(
            "wrenches_per_pose",
            format!("must be in 1..=100, got {}", spec.wrenches_per_pose),
        );
    }
    if spec.n_poses * spec.wrenches_per_pose > MAX_MEASUREMENTS {
        return bad(
            "poses/wrenches_per_pose",
            format!(
                "{} poses × {} wrenches is {} measurements, more than the {MAX_MEASUREMENTS} a \
                 plan may have",
                spec.n_poses,
                spec.wrenches_per_pose,
                spec.n_poses * spec.wrenches_per_pose
            ),
        );
    }
    if !(spec.force.is_finite() && spec.force > 0.0) {
        return bad(
            "force",
            format!(
                "must be finite and > 0 N, got {}",
                stiffness_core::num::Short(spec.force)
            ),
        );
    }
    if !(spec.moment.is_finite() && spec.moment >= 0.0) {
        return bad(
            "moment",
            format!(
                "must be finite and ≥ 0 N·m, got {}",
                stiffness_core::num::Short(spec.moment)
            ),
        );
    }
    if !(spec.limit_margin.is_finite() && spec.limit_margin >= 0.0) {
        return bad(
            "margin",
            format!(
                "must be finite and ≥ 0 rad, got {}",
                stiffness_core::num::Short(spec.limit_margin)
            ),
        );
    }
    if spec.pool_size < spec.n_poses || spec.pool_size > 100_000 {
        return bad(
            "pool_size",
            format!(
                "must be in {}..=100000 (at least the number of poses), got {}",
                spec.n_poses, spec.pool_size
            ),
        );
    }
    Ok(())
}

/// Pose evaluations (a pose scored under every candidate wrench) the greedy selection makes
/// over the full pool: while `n_poses × pool_size` stays within it every step scans every
/// unchosen pose; beyond it each step scans a random sample of `EXACT_SCANS / n_poses` of
/// them (at least [`MIN_SCAN`]), so that the largest campaigns finish in seconds (stochastic
/// greedy). At about 10 µs an evaluation this is a few seconds on two cores.
const EXACT_SCANS: usize = 600_000;

/// The fewest poses a sampled step scans.
const MIN_SCAN: usize = 48;

/// Plans a campaign for `model` on `chain`: a pool of candidate poses (see [`PlanSpec`]), then
/// greedily, pose by pose, the pose and its wrenches (from 13 force directions × {no moment,
/// ±x, ±y, ±z}) that most reduce the predicted variances of the identifiable combinations
/// under `noise` — the sum of their logarithms until every combination is determined, then the
/// largest (minimax). Returns the rows and the predicted standard error of every combination,
/// as [`crate::identify`] (defaults) would estimate it from the planned rows.
pub fn design(
    chain: &SerialChain,
    model: &VirtualJointModel,
    spec: &PlanSpec,
    noise: &NoiseModel,
) -> Result<Plan, VjmError> {
    design_monitored(chain, model, spec, noise, &Monitor::none())
}

/// [`design`] polling `monitor`: it stops with [`VjmError::Cancelled`] within a few
/// milliseconds of a cancel (checked per draw batch, per pool chunk and per pose) and reports
/// the stages `poses` (sampling the pool), `pool` (its Jacobians), `selection` (poses
/// picked) and `check` (the predicted errors of the planned rows).
pub fn design_monitored(
    chain: &SerialChain,
    model: &VirtualJointModel,
    spec: &PlanSpec,
    noise: &NoiseModel,
    monitor: &Monitor<'_>,
) -> Result<Plan, VjmError> {
    check_spec(spec)?;
    check_noise(model, noise)?;
    model.check_chain(chain)?;
    let pool = sample_poses(chain, spec, monitor)?;
    let cands = candidate_wrenches(spec.force, spec.moment);
    let data = pool_data(chain, model, noise, &pool, spec.pool_size, monitor)?;
    // Identifiable combinations and rank of the model on the pool (structural for the chain).
    let (rank, functionals) =
        combinations_of(chain, model, &pool, &cands[..2.min(cands.len())], noise)?;
    if rank == 0 {
        return Err(VjmError::InvalidModel {
            message: format!(
                "no spring of the model moves the tip point of the chain `{}` → `{}` under any \
                 of the {} candidate poses (rank 0): there is nothing to identify; choose a tip \
                 link away from the joint axes",
                chain.base_link(),
                chain.tip_link(),
                spec.pool_size
            ),
        });
    }
    let pool_info = pool_information(&data, &cands, model.n_params(), monitor)?;
    let reduced = Reduced::new(&pool_info, rank, &functionals, data.len() * cands.len())?;
    let rows = greedy_rows(
        spec,
        chain.n_joints(),
        &pool,
        &data,
        &cands,
        &reduced,
        monitor,
    )?;
    monitor.report(Progress {
        stage: "check",
        done: 0,
        total: 1,
    })?;
    planned(chain, model, noise, rows, monitor)
}

/// Each pooled pose's Jacobian and whitening, reporting the stage `pool`.
fn pool_data(
    chain: &SerialChain,
    model: &VirtualJointModel,
    noise: &NoiseModel,
    pool: &[f64],
    pool_size: usize,
    monitor: &Monitor<'_>,
) -> Result<Vec<PoseData>, VjmError> {
    let mut scratch = PoseScratch::new(chain, model, noise)?;
    let mut data = Vec::with_capacity(pool_size);
    for (i, q) in pool.chunks_exact(chain.n_joints()).enumerate() {
        if i % 1024 == 0 {
            monitor.report(Progress {
                stage: "pool",
                done: i,
                total: pool_size,
            })?;
        }
        data.push(pose_data(chain, model, q, noise, &mut scratch)?);
    }
    Ok(data)
}

/// Whitened pool information over all candidates, for the scaling and the subspace basis:
/// Σ_w (L A_w)ᵀ(L A_w) = (MᵀM) ∘ (Jᵀ W J) with M = L J_lin and W = Σ_w w wᵀ, since the
/// whitened rows are L A_w = M diag(Jᵀ w).
fn pool_information(
    data: &[PoseData],
    cands: &[[f64; 6]],
    m: usize,
    monitor: &Monitor<'_>,
) -> Result<DMatrix<f64>, VjmError> {
    let mut wsum = [[0.0; 6]; 6];
    for w in cands {
        for a in 0..6 {
            for b in 0..6 {
                wsum[a][b] += w[a] * w[b];
            }
        }
    }
    let mut pool_info = DMatrix::<f64>::zeros(m, m);
    for (i, pd) in data.iter().enumerate() {
        if i % 1024 == 0 {
            monitor.check()?;
        }
        let jwj = |k: usize, l: usize| -> f64 {
            let (jk, jl) = (&pd.jac[6 * k..6 * k + 6], &pd.jac[6 * l..6 * l + 6]);
            (0..6)
                .map(|a| jk[a] * (0..6).map(|b| wsum[a][b] * jl[b]).sum::<f64>())
                .sum()
        };
        for k in 0..m {
            for l in 0..m {
                let mm: f64 = (0..3).map(|r| pd.mw[3 * k + r] * pd.mw[3 * l + r]).sum();
                pool_info[(k, l)] += mm * jwj(k, l);
            }
        }
    }
    Ok(pool_info)
}

/// The identifiable subspace's coordinates z (c = D B z), the combinations' functionals in
/// them, and the ridge that starts the planned information.
struct Reduced {
    basis: DMatrix<f64>,
    funcs: DMatrix<f64>,
    ridge: f64,
}

impl Reduced {
    /// From the pool information, the rank and the combinations' functionals; `candidates`
    /// counts the pool's (pose, wrench) pairs.
    fn new(
        pool_info: &DMatrix<f64>,
        rank: usize,
        functionals: &[Functional],
        candidates: usize,
    ) -> Result<Self, VjmError> {
        let m = pool_info.nrows();
        let (scale, eig) = scaled_eigen(pool_info)?;
        let order = descending(&eig.eigenvalues);
        let basis = DMatrix::from_fn(m, rank, |i, j| eig.eigenvectors[(i, order[j])] * scale[i]);
        // Functionals of the combinations in the reduced coordinates z (c = D B z).
        let funcs = DMatrix::from_fn(rank, functionals.len(), |i, j| {
            functionals[j]
                .iter()
                .map(|(p, c)| {
                    // c_p = Σ_i basis[p][i] z_i, so tᵀc = Σ_i (Σ_p t_p basis[p][i]) z_i.
                    c * basis[(*p, i)]
                })
                .sum()
        });
        let total_z = basis.transpose() * pool_info * &basis;
        let ridge = 1e-9 * total_z.trace() / (rank.max(1) * candidates) as f64;
        Ok(Self {
            basis,
            funcs,
            ridge,
        })
    }
}

/// The planned rows: joint angles (N×n), wrenches and pose indices.
struct PlannedRows {
    q: Vec<f64>,
    wrench: Vec<[f64; 6]>,
    pose: Vec<usize>,
}

/// Greedily, pose by pose, the pose whose best wrench most reduces the predicted variances,
/// then its wrenches one by one; reports the stage `selection`.
fn greedy_rows(
    spec: &PlanSpec,
    n: usize,
    pool: &[f64],
    data: &[PoseData],
    cands: &[[f64; 6]],
    reduced: &Reduced,
    monitor: &Monitor<'_>,
) -> Result<PlannedRows, VjmError> {
    let (m, rank) = reduced.basis.shape();
    let (basis, funcs, ridge) = (&reduced.basis, &reduced.funcs, reduced.ridge);
    let mut info = DMatrix::<f64>::identity(rank, rank) * ridge;
    let wrenches: Vec<SparseWrench> = cands.iter().map(SparseWrench::new).collect();
    let scorer = Scorer {
        data,
        basis,
        basis_rows: (0..m)
            .flat_map(|k| (0..rank).map(move |j| (k, j)))
            .map(|(k, j)| basis[(k, j)])
            .collect(),
        wrenches: &wrenches,
    };
    let mut remaining: Vec<usize> = (0..data.len()).collect();
    let scan = if spec.n_poses.saturating_mul(data.len()) <= EXACT_SCANS {
        usize::MAX
    } else {
        (EXACT_SCANS / spec.n_poses).max(MIN_SCAN)
    };
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed ^ 0x005e_ed0f_5ca7);
    let mut rows = PlannedRows {
        q: Vec::new(),
        wrench: Vec::new(),
        pose: Vec::new(),
    };
    for pose in 0..spec.n_poses {
        monitor.report(Progress {
            stage: "selection",
            done: pose,
            total: spec.n_poses,
        })?;
        let state = State::new(&info, funcs)?;
        let covered = super::symmetric_eigen(
            info.clone(),
            "eigen-decomposition of the planned information",
        )?
        .eigenvalues
        .min()
            > 1e3 * ridge;
        // The candidates of this step: every unchosen pose, or a random sample of them.
        let k = scan.min(remaining.len());
        if k < remaining.len() {
            for i in 0..k {
                let j = rng.random_range(i..remaining.len());
                remaining.swap(i, j);
            }
        }
        let p = best_pose(
            &scorer,
            &state,
            &remaining[..k],
            covered,
            funcs.ncols(),
            monitor,
        )?;
        let at = remaining.iter().position(|&x| x == p).unwrap_or(0);
        remaining.swap_remove(at);
        let mut used = vec![false; cands.len()];
        let mut scratch = Scratch::new(rank, funcs.ncols());
        for _ in 0..spec.wrenches_per_pose {
            monitor.check()?;
            // More wrenches per pose than candidates: the second round repeats the best ones.
            if used.iter().all(|&u| u) {
                used.fill(false);
            }
            let state = State::new(&info, funcs)?;
            let (_, d) = scorer.best_wrench(&state, p, covered, Some(&used), &mut scratch);
            used[d] = true;
            let g = scorer.reduced(p, &cands[d]);
            info += g.transpose() * &g;
            rows.q.extend_from_slice(&pool[p * n..(p + 1) * n]);
            rows.wrench.push(cands[d]);
            rows.pose.push(pose);
        }
    }
    Ok(rows)
}

/// The pose of `candidates` whose best single wrench scores best (ties: the lowest pose
/// index), scored in parallel chunks.
fn best_pose(
    scorer: &Scorer<'_>,
    state: &State<'_>,
    candidates: &[usize],
    covered: bool,
    n_funcs: usize,
    monitor: &Monitor<'_>,
) -> Result<usize, VjmError> {
    let rank = scorer.basis.ncols();
    let chunk = 64;
    let best = candidates
        .par_chunks(chunk)
        .map(|ps| -> Result<(f64, usize), VjmError> {
            monitor.check()?;
            let mut scratch = Scratch::new(rank, n_funcs);
            let mut best = (f64::INFINITY, usize::MAX);
            for &p in ps {
                let (s, _) = scorer.best_wrench(state, p, covered, None, &mut scratch);
                if s < best.0 || (s == best.0 && p < best.1) {
                    best = (s, p);
                }
            }
            Ok(best)
        })
        .try_reduce(
            || (f64::INFINITY, usize::MAX),
            |a, b| {
                Ok(if b.0 < a.0 || (b.0 == a.0 && b.1 < a.1) {
                    b
                } else {
                    a
                })
            },
        )?;
    if best.1 == usize::MAX {
        return Err(VjmError::Numerical {
            message: "no candidate pose improves the design (the information matrix is not finite)"
                .into(),
        });
    }
    Ok(best.1)
}

/// The plan of `rows`: its own combinations (as the identification of its rows will report
/// them), their predicted standard errors and whether each is weak.
fn planned(
    chain: &SerialChain,
    model: &VirtualJointModel,
    noise: &NoiseModel,
    rows: PlannedRows,
    monitor: &Monitor<'_>,
) -> Result<Plan, VjmError> {
    let (plan_rank, combos) = combinations_of_rows(chain, model, &rows.q, &rows.wrench, noise)?;
    monitor.check()?;
    let terms: Vec<Vec<(usize, f64)>> = combos.iter().map(|c| c.1.clone()).collect();
    let se = predicted_stderr(
        chain,
        model,
        &rows.q,
        &rows.wrench,
        plan_rank,
        &terms,
        noise,
    )?;
    // The size a combination has under the prior, a tilt (prior 0) as large as a typical
    // torsion: the scale its standard error is judged against.
    let mut positive: Vec<f64> = noise
        .prior_compliance
        .iter()
        .copied()
        .filter(|c| *c > 0.0)
        .collect();
    positive.sort_by(f64::total_cmp);
    let typical = positive.get(positive.len() / 2).copied().unwrap_or(0.0);
    let combinations: Vec<PlannedCombination> = combos
        .into_iter()
        .zip(se)
        .map(|((label, _, terms), stderr)| {
            let size: f64 = terms
                .iter()
                .map(|t| t.coefficient.abs() * noise.prior_compliance[t.param].max(typical))
                .sum();
            PlannedCombination {
                label,
                weak: crate::screening::is_weak(size, Some(stderr)),
                terms,
                stderr,
            }
        })
        .collect();
    let worst_stderr = combinations.iter().map(|c| c.stderr).fold(0.0, f64::max);
    Ok(Plan {
        q: rows.q,
        wrench: rows.wrench,
        pose: rows.pose,
        rank: plan_rank,
        combinations,
        worst_stderr,
        pose_compliance_wrenches: pose_compliance_wrenches(chain.n_joints()),
        noise: noise.clone(),
    })
}

/// A candidate wrench as its non-zero components `(index, value)` (at most 4 of 6).
struct SparseWrench {
    terms: Vec<(usize, f64)>,
}

impl SparseWrench {
    fn new(w: &[f64; 6]) -> Self {
        Self {
            terms: (0..6).filter(|&a| w[a] != 0.0).map(|a| (a, w[a])).collect(),
        }
    }
}

/// Scores candidate (pose, wrench) pairs against a [`State`]. The reduced whitened rows of a
/// pose are linear in the wrench, `g(w) = Σ_a w_a G_a` with `G_a = M diag(J_a) B` (M = L J_lin,
/// J_a the a-th row of the pose Jacobian, B the basis), so everything the Woodbury update
/// needs is formed once per pose for the six `G_a` and combined per wrench from its non-zero
/// components: `S = I + Σ w_a w_b G_a M⁻¹ G_bᵀ`, `h = Σ w_a G_a M⁻¹ T`.
struct Scorer<'a> {
    data: &'a [PoseData],
    basis: &'a DMatrix<f64>,
    /// `basis` row-major (m×r).
    basis_rows: Vec<f64>,
    wrenches: &'a [SparseWrench],
}

/// Per-thread buffers of [`Scorer`] (no allocation per candidate).
struct Scratch {
    /// `G_a`, 6 × (3×r) row-major.
    g: Vec<f64>,
    /// `G_a M⁻¹`, 6 × (3×r).
    y: Vec<f64>,
    /// `G_a M⁻¹ T`, 6 × (3×c).
    h: Vec<f64>,
    /// `G_a M⁻¹ G_bᵀ`, 6×6 × (3×3).
    q: Vec<f64>,
    /// `h(w)`, 3×c.
    hw: Vec<f64>,
}

impl Scratch {
    fn new(r: usize, c: usize) -> Self {
        Self {
            g: vec![0.0; 18 * r],
            y: vec![0.0; 18 * r],
            h: vec![0.0; 18 * c],
            q: vec![0.0; 36 * 9],
            hw: vec![0.0; 3 * c],
        }
    }
}

impl Scorer<'_> {
    /// The reduced whitened rows `L A B` (3×r) of pool pose `p` under `w`.
    fn reduced(&self, p: usize, w: &[f64; 6]) -> DMatrix<f64> {
        let pd = &self.data[p];
        let (m, r) = (self.basis.nrows(), self.basis.ncols());
        DMatrix::from_fn(3, r, |i, j| {
            (0..m)
                .map(|k| {
                    let u: f64 = (0..6).map(|a| pd.jac[6 * k + a] * w[a]).sum();
                    pd.mw[3 * k + i] * u * self.basis[(k, j)]
                })
                .sum()
        })
    }

    /// The best wrench (skipping `used` ones) at pose `p`: its score (lower is better; the
    /// largest variance when `covered`, else the sum of log-variances up to a constant) and
    /// its index. A wrench whose update is not positive definite scores as no improvement.
    fn best_wrench(
        &self,
        state: &State<'_>,
        p: usize,
        covered: bool,
        used: Option<&[bool]>,
        s: &mut Scratch,
    ) -> (f64, usize) {
        let pd = &self.data[p];
        let (m, r) = (self.basis.nrows(), self.basis.ncols());
        let c = state.funcs.ncols();
        // G_a[i][j] = Σ_k M[i][k] J[a][k] B[k][j].
        s.g.fill(0.0);
        for k in 0..m {
            let brow = &self.basis_rows[k * r..(k + 1) * r];
            for a in 0..6 {
                let jak = pd.jac[6 * k + a];
                if jak == 0.0 {
                    continue;
                }
                for i in 0..3 {
                    let f = pd.mw[3 * k + i] * jak;
                    let row = &mut s.g[(3 * a + i) * r..(3 * a + i + 1) * r];
                    for (x, b) in row.iter_mut().zip(brow) {
                        *x += f * b;
                    }
                }
            }
        }
        // Y = G M⁻¹ (18×r), H = G (M⁻¹ T) (18×c), Q_ab = Y_a G_bᵀ.
        for i in 0..18 {
            let gi = &s.g[i * r..(i + 1) * r];
            for j in 0..r {
                s.y[i * r + j] = (0..r).map(|l| gi[l] * state.inv[(l, j)]).sum();
            }
            for j in 0..c {
                s.h[i * c + j] = (0..r).map(|l| gi[l] * state.inv_f[(l, j)]).sum();
            }
        }
        for a in 0..6 {
            for b in 0..6 {
                for i in 0..3 {
                    let yi = &s.y[(3 * a + i) * r..(3 * a + i + 1) * r];
                    for j in 0..3 {
                        let gj = &s.g[(3 * b + j) * r..(3 * b + j + 1) * r];
                        s.q[(a * 6 + b) * 9 + 3 * i + j] =
                            yi.iter().zip(gj).map(|(x, y)| x * y).sum();
                    }
                }
            }
        }
        let mut best = (f64::INFINITY, 0);
        for (d, w) in self.wrenches.iter().enumerate() {
            if used.is_some_and(|u| u[d]) {
                continue;
            }
            let mut sm = nalgebra::Matrix3::<f64>::identity();
            for &(a, wa) in &w.terms {
                for &(b, wb) in &w.terms {
                    let q = &s.q[(a * 6 + b) * 9..(a * 6 + b) * 9 + 9];
                    for i in 0..3 {
                        for j in 0..3 {
                            sm[(i, j)] += wa * wb * q[3 * i + j];
                        }
                    }
                }
            }
            s.hw.fill(0.0);
            for &(a, wa) in &w.terms {
                for (x, h) in s.hw.iter_mut().zip(&s.h[3 * a * c..3 * (a + 1) * c]) {
                    *x += wa * h;
                }
            }
            let score = match cholesky3(&sm) {
                // h_jᵀ S⁻¹ h_j = ‖L⁻¹ h_j‖² by forward substitution.
                Some(l) => {
                    let var = |j: usize| -> f64 {
                        let z0 = s.hw[j] / l[0];
                        let z1 = (s.hw[c + j] - l[1] * z0) / l[2];
                        let z2 = (s.hw[2 * c + j] - l[3] * z0 - l[4] * z1) / l[5];
                        state.vars[j] - (z0 * z0 + z1 * z1 + z2 * z2)
                    };
                    score_of((0..c).map(var), &state.vars, covered)
                }
                None => score_of(state.vars.iter().copied(), &state.vars, covered),
            };
            if score < best.0 {
                best = (score, d);
            }
        }
        if best.0 == f64::INFINITY {
            // Every score non-finite: the first wrench not yet used.
            best.1 = (0..self.wrenches.len())
                .find(|&d| !used.is_some_and(|u| u[d]))
                .unwrap_or(0);
        }
        (best.0, best.1)
    }
}

/// The Cholesky factor of a symmetric 3×3 matrix as `[l00, l10, l11, l20, l21, l22]`, or `None`
/// when it is not (numerically) positive definite.
fn cholesky3(a: &nalgebra::Matrix3<f64>) -> Option<[f64; 6]> {
    let d0 = a[(0, 0)];
    if d0.is_nan() || d0 <= 0.0 {
        return None;
    }
    let l00 = d0.sqrt();
    let l10 = a[(1, 0)] / l00;
    let d1 = a[(1, 1)] - l10 * l10;
    if d1.is_nan() || d1 <= 0.0 {
        return None;
    }
    let l11 = d1.sqrt();
    let l20 = a[(2, 0)] / l00;
    let l21 = (a[(2, 1)] - l20 * l10) / l11;
    let d2 = a[(2, 2)] - l20 * l20 - l21 * l21;
    if d2.is_nan() || d2 <= 0.0 {
        return None;
    }
    Some([l00, l10, l11, l20, l21, d2.sqrt()])
}

/// The score of variances `vars` (after a candidate) given the current ones `now`: the largest
/// when `covered`, else `Σ ln max(v, MIN_POSITIVE)` minus the constant `Σ ln now` — as a
/// product of ratios, with one logarithm per candidate instead of one per combination.
fn score_of(vars: impl Iterator<Item = f64>, now: &[f64], covered: bool) -> f64 {
    if covered {
        return vars.fold(0.0, f64::max);
    }
    let (mut prod, mut acc) = (1.0f64, 0.0f64);
    for (v, &v0) in vars.zip(now) {
        let (v, v0) = (v.max(f64::MIN_POSITIVE), v0.max(f64::MIN_POSITIVE));
        let ratio = v / v0;
        if !(1e-100..=1e100).contains(&ratio) {
            acc += v.ln() - v0.ln();
            continue;
        }
        prod *= ratio;
        if !(1e-200..=1e200).contains(&prod) {
            acc += prod.ln();
            prod = 1.0;
        }
    }
    acc + prod.ln()
}

/// Inverse information and the current variances of the functionals, for the rank-3
/// (Woodbury) updates of [`Scorer`].
struct State<'a> {
    inv: DMatrix<f64>,
    funcs: &'a DMatrix<f64>,
    inv_f: DMatrix<f64>,
    vars: Vec<f64>,
}

impl<'a> State<'a> {
    fn new(info: &DMatrix<f64>, funcs: &'a DMatrix<f64>) -> Result<Self, VjmError> {
        let inv = info
            .clone()
            .cholesky()
            .map(|c| c.inverse())
            .ok_or_else(|| VjmError::Numerical {
                message: "the planned information matrix lost positive definiteness".into(),
            })?;
        let inv_f = &inv * funcs;
        let vars = (0..funcs.ncols())
            .map(|j| funcs.column(j).dot(&inv_f.column(j)))
            .collect();
        Ok(Self {
            inv,
            funcs,
            inv_f,
            vars,
        })
    }
}

/// A linear functional of the compliances: `(parameter, coefficient)` terms.
type Functional = Vec<(usize, f64)>;

type CombinationDef = (String, Functional, Vec<CombinationTerm>);

/// Rank and identifiable combinations of the model on poses `q` each under `wrenches`.
fn combinations_of(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    wrenches: &[[f64; 6]],
    noise: &NoiseModel,
) -> Result<(usize, Vec<Functional>), VjmError> {
    let n = chain.n_joints();
    let mut rows_q = Vec::new();
    let mut rows_w = Vec::new();
    for qi in q.chunks_exact(n) {
        for w in wrenches {
            rows_q.extend_from_slice(qi);
            rows_w.push(*w);
        }
    }
    let (rank, defs) = combinations_of_rows(chain, model, &rows_q, &rows_w, noise)?;
    Ok((rank, defs.into_iter().map(|d| d.1).collect()))
}

/// Rank and combinations reported by [`crate::identify`] on noise-free data at the rows (the
/// combinations depend on the design, not on the values).
fn combinations_of_rows(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    wrench: &[[f64; 6]],
    noise: &NoiseModel,
) -> Result<(usize, Vec<CombinationDef>), VjmError> {
    let n = chain.n_joints();
    let mut d = Vec::with_capacity(3 * wrench.len());
    let mut f = Vec::with_capacity(6 * wrench.len());
    for (i, w) in wrench.iter().enumerate() {
        let x = crate::predict_deflection(
            chain,
            model,
            &noise.prior_compliance,
            &q[i * n..(i + 1) * n],
            w,
            false,
        )?;
        d.extend_from_slice(&x[..3]);
        f.extend_from_slice(w);
    }
    let id = crate::identify(
        chain,
        model,
        Measurements::new(q, &f, &d),
        &IdentifyOptions::default(),
    )?;
    let defs = id
        .combinations
        .iter()
        .map(|c| {
            (
                c.label.clone(),
                c.terms.iter().map(|t| (t.param, t.coefficient)).collect(),
                c.terms.clone(),
            )
        })
        .collect();
    Ok((id.rank, defs))
}
