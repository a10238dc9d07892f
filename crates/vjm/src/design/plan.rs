//! Measurement planning: poses inside the joint limits and, per pose, wrenches chosen so that
//! the worst predicted standard error of the model's identifiable combinations is small, under
//! a stated noise model (docs/use-the-model.md#design).

use nalgebra::{DMatrix, DVector, Matrix3, SymmetricEigen};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::chain::SerialChain;
use crate::error::VjmError;
use crate::identify::{identify_dense, CombinationTerm, IdentifyOptions};
use crate::kinematics::{jacobian_in_place, Workspace};
use crate::model::VirtualJointModel;
use crate::testbed::{inverse_condition, ForceSensorNoise, TrackerNoise, NOMINAL_TORSION};

/// The noise of a campaign as the plan assumes it: laser-tracker displacement noise (per axis,
/// growing with the distance to the tracker) plus force/torque-sensor noise, which enters the
/// displacement equations as `−(J C Jᵀ)_t δW` and so needs a prior compliance C.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NoiseModel {
    /// Tracker noise (default: the testbed's, 15 µm + 6 µm/m MPE read as 2σ).
    pub tracker: TrackerNoise,
    /// Force/torque sensor noise (default: the testbed's, 1 % of 100 N / 10 N·m as 2σ).
    pub force_sensor: ForceSensorNoise,
    /// Prior compliance per spring of the model, rad/(N·m) (default: the testbed's nominal
    /// torsions, tilts 0).
    pub prior_compliance: Vec<f64>,
}

impl NoiseModel {
    /// The testbed's instruments and a Panda-class prior ([`NOMINAL_TORSION`]) for `model`.
    pub fn testbed(model: &VirtualJointModel) -> Self {
        let prior = model
            .springs()
            .iter()
            .map(|s| {
                if s.axis == crate::model::SpringAxis::Z {
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
        }
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
}

/// Translation rows of the regressor `A[r][k] = J[r][k]·(J_kᵀ W)` (3×m) and the displacement
/// noise covariance of one row at a configuration whose Jacobian is `jac` (6×m column-major)
/// and tip point `p`.
struct PoseData {
    jac: Vec<f64>,
    /// Displacement noise covariance, m².
    cov: Matrix3<f64>,
    /// Inverse Cholesky factor of `cov` (whitening).
    whiten: Matrix3<f64>,
}

fn pose_data(
    chain: &SerialChain,
    model: &VirtualJointModel,
    q: &[f64],
    noise: &NoiseModel,
    ws: &mut Workspace,
) -> Result<PoseData, VjmError> {
    let m = model.n_params();
    let mut jac = vec![0.0; 6 * m];
    jacobian_in_place(chain, model, q, ws, &mut jac)?;
    let p = ws.p;
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
    Ok(PoseData { jac, cov, whiten })
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
    let mut ws = Workspace::new(chain, model)?;
    let mut info = DMatrix::<f64>::zeros(m, m);
    let mut meat = DMatrix::<f64>::zeros(m, m);
    for (i, w) in wrench.iter().enumerate() {
        crate::chain::check_finite("wrench", w, i, 0)?;
        let pd = pose_data(chain, model, &q[i * n..(i + 1) * n], noise, &mut ws)?;
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

/// Draws `count` poses uniformly within the limits (clamped to ±π, `margin` inside), keeping
/// those above `min_tip_height` with inverse condition ≥ `min_inverse_condition`.
fn sample_poses(chain: &SerialChain, spec: &PlanSpec) -> Result<Vec<f64>, VjmError> {
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
    let cap = 2000 * spec.pool_size;
    let mut attempts = 0;
    while out.len() < spec.pool_size * n {
        attempts += 1;
        if attempts > cap {
            return Err(VjmError::InvalidOption {
                name: "limit_margin/min_inverse_condition/min_tip_height",
                message: format!(
                    "only {} acceptable poses in {cap} draws; relax the margin or the filters",
                    out.len() / n
                ),
            });
        }
        let q: Vec<f64> = chain
            .limits()
            .iter()
            .map(|&(lo, hi)| {
                let (lo, hi) = (lo.max(-std::f64::consts::PI), hi.min(std::f64::consts::PI));
                rng.random_range(lo + spec.limit_margin..hi - spec.limit_margin)
            })
            .collect();
        let tip = chain.forward_kinematics(&q)?.translation.vector;
        if tip.z < spec.min_tip_height || inverse_condition(chain, &q) < spec.min_inverse_condition
        {
            continue;
        }
        out.extend_from_slice(&q);
    }
    Ok(out)
}

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
    if !(spec.force.is_finite() && spec.force > 0.0) {
        return bad(
            "force",
            format!("must be finite and > 0 N, got {}", spec.force),
        );
    }
    if !(spec.moment.is_finite() && spec.moment >= 0.0) {
        return bad(
            "moment",
            format!("must be finite and ≥ 0 N·m, got {}", spec.moment),
        );
    }
    if !(spec.limit_margin.is_finite() && spec.limit_margin >= 0.0) {
        return bad(
            "margin",
            format!("must be finite and ≥ 0 rad, got {}", spec.limit_margin),
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
    check_spec(spec)?;
    check_noise(model, noise)?;
    model.check_chain(chain)?;
    let n = chain.n_joints();
    let m = model.n_params();
    let pool = sample_poses(chain, spec)?;
    let cands = candidate_wrenches(spec.force, spec.moment);
    let mut ws = Workspace::new(chain, model)?;
    let data: Vec<PoseData> = pool
        .chunks_exact(n)
        .map(|q| pose_data(chain, model, q, noise, &mut ws))
        .collect::<Result<_, _>>()?;
    // Identifiable combinations and rank of the model on the pool (structural for the chain).
    let pool_comb = combinations_of(chain, model, &pool, &cands[..2.min(cands.len())], noise)?;
    let rank = pool_comb.0;
    // Whitened pool information over all candidates, for the scaling and the subspace basis.
    let whitened = |p: usize, w: &[f64; 6]| pool_whitened(&data[p], m, w);
    let mut pool_info = DMatrix::<f64>::zeros(m, m);
    for p in 0..data.len() {
        for w in &cands {
            let a = whitened(p, w);
            pool_info += a.transpose() * &a;
        }
    }
    let (scale, eig) = scaled_eigen(&pool_info)?;
    let order = descending(&eig.eigenvalues);
    let basis = DMatrix::from_fn(m, rank, |i, j| eig.eigenvectors[(i, order[j])] * scale[i]);
    // Functionals of the combinations in the reduced coordinates z (c = D B z).
    let funcs = DMatrix::from_fn(rank, pool_comb.1.len(), |i, j| {
        pool_comb.1[j]
            .iter()
            .map(|(p, c)| {
                // c_p = Σ_i basis[p][i] z_i, so tᵀc = Σ_i (Σ_p t_p basis[p][i]) z_i.
                c * basis[(*p, i)]
            })
            .sum()
    });
    let reduce = |a: DMatrix<f64>| a * &basis;
    let total_z = basis.transpose() * &pool_info * &basis;
    let ridge = 1e-9 * total_z.trace() / (rank.max(1) * data.len() * cands.len()) as f64;
    let mut info = DMatrix::<f64>::identity(rank, rank) * ridge;
    let mut chosen = vec![false; data.len()];
    let mut rows_q = Vec::new();
    let mut rows_w = Vec::new();
    let mut rows_p = Vec::new();
    for pose in 0..spec.n_poses {
        let state = State::new(&info, &funcs)?;
        let covered = super::symmetric_eigen(
            info.clone(),
            "eigen-decomposition of the planned information",
        )?
        .eigenvalues
        .min()
            > 1e3 * ridge;
        let score = |vars: &[f64]| -> f64 {
            if covered {
                vars.iter().copied().fold(0.0, f64::max)
            } else {
                vars.iter().map(|v| v.max(f64::MIN_POSITIVE).ln()).sum()
            }
        };
        // The pose whose best single wrench scores best.
        let mut best = (f64::INFINITY, usize::MAX);
        for p in (0..data.len()).filter(|&p| !chosen[p]) {
            for w in &cands {
                let s = score(&state.after(&reduce(whitened(p, w))));
                if s < best.0 {
                    best = (s, p);
                }
            }
        }
        let p = best.1;
        if p == usize::MAX {
            return Err(VjmError::Numerical {
                message:
                    "no candidate pose improves the design (the information matrix is not finite)"
                        .into(),
            });
        }
        chosen[p] = true;
        let mut used = vec![false; cands.len()];
        for _ in 0..spec.wrenches_per_pose {
            let state = State::new(&info, &funcs)?;
            let mut pick = (f64::INFINITY, 0);
            for (d, w) in cands.iter().enumerate().filter(|(d, _)| !used[*d]) {
                let s = score(&state.after(&reduce(whitened(p, w))));
                if s < pick.0 {
                    pick = (s, d);
                }
            }
            used[pick.1] = true;
            let g = reduce(whitened(p, &cands[pick.1]));
            info += g.transpose() * &g;
            rows_q.extend_from_slice(&pool[p * n..(p + 1) * n]);
            rows_w.push(cands[pick.1]);
            rows_p.push(pose);
        }
    }
    // The plan's own combinations (as the identification of its rows will report them) and
    // their predicted standard errors.
    let (plan_rank, combos) = combinations_of_rows(chain, model, &rows_q, &rows_w, noise)?;
    let terms: Vec<Vec<(usize, f64)>> = combos.iter().map(|c| c.1.clone()).collect();
    let se = predicted_stderr(chain, model, &rows_q, &rows_w, plan_rank, &terms, noise)?;
    let combinations: Vec<PlannedCombination> = combos
        .into_iter()
        .zip(se)
        .map(|((label, _, terms), stderr)| PlannedCombination {
            label,
            terms,
            stderr,
        })
        .collect();
    let worst_stderr = combinations.iter().map(|c| c.stderr).fold(0.0, f64::max);
    Ok(Plan {
        q: rows_q,
        wrench: rows_w,
        pose: rows_p,
        rank: plan_rank,
        combinations,
        worst_stderr,
        noise: noise.clone(),
    })
}

/// The whitened regressor rows `L⁻¹ A` (3×m) of a pool pose under `w`.
fn pool_whitened(pd: &PoseData, m: usize, w: &[f64; 6]) -> DMatrix<f64> {
    let a = regressor(&pd.jac, m, w);
    let l = DMatrix::from_fn(3, 3, |r, c| pd.whiten[(r, c)]);
    l * a
}

/// Inverse information and the current variances of the functionals, for rank-3 updates.
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

    /// Variances after adding the rows `g` (3×r), by Woodbury:
    /// `v_j − h_jᵀ (I + g M⁻¹ gᵀ)⁻¹ h_j` with `h_j = g M⁻¹ t_j`.
    fn after(&self, g: &DMatrix<f64>) -> Vec<f64> {
        let y = g * &self.inv;
        let s = DMatrix::<f64>::identity(g.nrows(), g.nrows()) + &y * g.transpose();
        let h = g * &self.inv_f;
        let Some(sinv) = s.cholesky().map(|c| c.inverse()) else {
            return self.vars.clone();
        };
        let sh = &sinv * &h;
        (0..self.funcs.ncols())
            .map(|j| self.vars[j] - h.column(j).dot(&sh.column(j)))
            .collect()
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

/// Rank and combinations reported by [`identify_dense`] on noise-free data at the rows (the
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
    let id = identify_dense(chain, model, q, &f, &d, None, &IdentifyOptions::default())?;
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
