//! `diagnose`: show what a stiffness model gets wrong on measured data, name the cause, extend
//! the model and measure the gain on rows the fit never saw.
//!
//! 1. The baseline (traditional VJM unless another [`VirtualJointModel`] is named) is fitted by
//!    weighted least squares on the training rows; the weights whiten each row's 3-D
//!    displacement noise: tracker noise plus force-sensor noise propagated through the fitted
//!    compliance (`Σ_i = σ_d² I + G_i Σ_W G_iᵀ`, `G_i = J_t C Jᵀ`).
//! 2. Residual structure: per-pose ANOVA, torque, load magnitude and direction correlations.
//! 3. Candidates from the [`candidates::catalogue`] are scored by nested-model F tests;
//!    Benjamini–Hochberg at level `fdr` across the catalogue decides which are significant; the
//!    most significant one must also lower the whitened error on the held-out rows to be
//!    accepted (otherwise the next one is tried); then all are re-scored against the extended
//!    model (forward selection). Significant candidates that make a finding unnecessary (its F
//!    test given the other has p > `alias_alpha`), or whose columns have |cos| ≥
//!    `alias_cosine` with the finding's after projecting out the model, are its aliases.
//! 4. The extended model is refitted and its held-out error reported.
//! 5. `unexplained` is set when the extended model's per-pose ANOVA stays significant.
//!
//! The statistics and the detectability threshold are explained in `docs/diagnose.md`.
//!
//! ```
//! use vjm::diagnose::{diagnose, DiagnoseOptions};
//! use vjm::testbed::{simulate, CampaignSpec, TrueModel};
//! let chain = vjm::SerialChain::bundled();
//! let spec = CampaignSpec { n_poses: 12, seed: 3, ..Default::default() };
//! let campaign = simulate(&chain, &TrueModel::nominal(7), &spec)?;
//! let result = diagnose(&chain, &campaign.dataset, &DiagnoseOptions::default())?;
//! assert_eq!(result.baseline.model, "traditional");
//! println!("{}", result.to_json());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod candidates;
mod engine;
pub mod linalg;
pub mod report;
pub use stiffness_core::stats;
pub mod structure;

use serde::Serialize;
use stiffness_core::{Cancel, Monitor};

use crate::chain::SerialChain;
use crate::dataset::{Dataset, DatasetError, SetLabel};
use crate::error::VjmError;
use crate::model::{SpringAxis, VirtualJointModel};
use crate::testbed::{ForceSensorNoise, TrackerNoise};
use candidates::{catalogue, Candidate, RowKinematics};
use engine::{Engine, Fit, Term};
use report::{
    Alias, CandidateScore, Diagnosis, Evidence, Finding, ModelSummary, Parameter, PoseError,
    ResidualReport, RowResult,
};
use stats::benjamini_hochberg;
use structure::residual_structure;

/// The noise the weights assume.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct NoiseAssumption {
    /// Per-axis standard deviation of a measured displacement, m.
    pub displacement_sigma: f64,
    /// Per-axis standard deviation of the recorded wrench `[f; m]`, N and N·m.
    pub wrench_sigma: [f64; 6],
}

impl Default for NoiseAssumption {
    /// The testbed's instruments: a laser tracker 2.5 m away (√2·(15 µm + 6 µm/m·2.5 m)/2 ≈
    /// 21 µm per axis of a displacement) and a 1 %-of-full-scale F/T sensor (100 N, 10 N·m).
    fn default() -> Self {
        let t = TrackerNoise::default();
        NoiseAssumption {
            displacement_sigma: t.displacement_sigma([0.0, 0.0, t.position[2]]),
            wrench_sigma: ForceSensorNoise::default().sigma(),
        }
    }
}

/// Options of [`diagnose`].
#[derive(Debug, Clone)]
pub struct DiagnoseOptions {
    /// The baseline model; `None` = traditional (one torsional spring per joint).
    pub baseline: Option<VirtualJointModel>,
    /// False discovery rate of the Benjamini–Hochberg selection (default 0.01).
    pub fdr: f64,
    /// Fraction of poses held out when the file has no `set` column (default 0.25).
    pub test_fraction: f64,
    /// Seed of the pose hold-out (default 0).
    pub split_seed: u64,
    /// Noise model of the weights.
    pub noise: NoiseAssumption,
    /// Most findings to name (default 6).
    pub max_findings: usize,
    /// |cos| at or above which two candidates are aliases (default 0.99).
    pub alias_cosine: f64,
    /// A significant candidate b is an alias of a finding a when, with b in the model, the
    /// F test of a has p above this level (default 0.05): the data cannot tell a from b.
    pub alias_alpha: f64,
    /// Level of the per-pose ANOVA that sets `unexplained` (default 0.01).
    pub unexplained_alpha: f64,
    /// Accept joint angles outside the URDF limits (default `false`: such a row is refused,
    /// naming row and joint, since it usually means degrees or a wrong joint order).
    /// Continuous joints have no limits.
    pub allow_outside_limits: bool,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            baseline: None,
            fdr: 0.01,
            test_fraction: 0.25,
            split_seed: 0,
            noise: NoiseAssumption::default(),
            max_findings: 6,
            alias_cosine: 0.99,
            alias_alpha: 0.05,
            unexplained_alpha: 0.01,
            allow_outside_limits: false,
        }
    }
}

/// Errors of [`diagnose`].
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DiagnoseError {
    /// The file's joint count does not match the chain.
    #[error("the data have {data} joint values per row but the chain has {chain} actuated joints")]
    JointCount {
        /// Joints in the data.
        data: usize,
        /// Joints of the chain.
        chain: usize,
    },
    /// The baseline model does not fit the chain or is unsupported.
    #[error("baseline model: {0}")]
    Model(#[from] VjmError),
    /// The split failed (e.g. no test rows).
    #[error("{0}")]
    Dataset(#[from] DatasetError),
    /// Too few training observations for the baseline.
    #[error("{observations} training observations (3 per row) cannot fit a {params}-parameter baseline and test extensions; add rows")]
    TooFewRows {
        /// 3 × training rows.
        observations: usize,
        /// Baseline parameters.
        params: usize,
    },
    /// The run was cancelled through its [`Cancel`] token.
    #[error("diagnosis cancelled")]
    Cancelled(#[from] stiffness_core::Cancelled),
    /// An option is out of range.
    #[error("option `{name}`: {message}")]
    InvalidOption {
        /// The option.
        name: &'static str,
        /// What is wrong.
        message: String,
    },
}

/// Progress of a long diagnosis (the workspace-wide record).
pub use stiffness_core::Progress;

/// Diagnoses `data` measured on `chain`; see the module docs.
pub fn diagnose(
    chain: &SerialChain,
    data: &Dataset,
    opts: &DiagnoseOptions,
) -> Result<Diagnosis, DiagnoseError> {
    diagnose_with_progress(chain, data, opts, &mut |_| {})
}

/// [`diagnose`] under a [`Monitor`]: progress goes to its sink, and its token is polled per
/// stage, per scored candidate and per selection step, so that a cancel ends the run within
/// one candidate fit with [`DiagnoseError::Cancelled`].
pub fn diagnose_monitored(
    chain: &SerialChain,
    data: &Dataset,
    opts: &DiagnoseOptions,
    monitor: &Monitor<'_>,
) -> Result<Diagnosis, DiagnoseError> {
    run_diagnosis(chain, data, opts, monitor.cancel_token(), &mut |p| {
        // A cancel requested by the sink is seen at the check that follows every report.
        let _ = monitor.report(p);
    })
}

fn axis_index(a: SpringAxis) -> usize {
    match a {
        SpringAxis::Z => 0,
        SpringAxis::X => 1,
        SpringAxis::Y => 2,
    }
}

fn check_options(opts: &DiagnoseOptions) -> Result<(), DiagnoseError> {
    let bad =
        |name: &'static str, message: String| Err(DiagnoseError::InvalidOption { name, message });
    if !(opts.fdr > 0.0 && opts.fdr < 1.0) {
        return bad("fdr", format!("must be in (0, 1), got {}", opts.fdr));
    }
    if !(opts.test_fraction > 0.0 && opts.test_fraction < 1.0) {
        return bad(
            "test_fraction",
            format!("must be in (0, 1), got {}", opts.test_fraction),
        );
    }
    let n = &opts.noise;
    if !(n.displacement_sigma > 0.0 && n.displacement_sigma.is_finite())
        || n.wrench_sigma.iter().any(|s| !(s.is_finite() && *s >= 0.0))
    {
        return bad(
            "noise",
            "displacement sigma must be > 0 and wrench sigmas ≥ 0, all finite".into(),
        );
    }
    if !(opts.unexplained_alpha > 0.0 && opts.unexplained_alpha < 1.0) {
        return bad(
            "unexplained_alpha",
            format!("must be in (0, 1), got {}", opts.unexplained_alpha),
        );
    }
    Ok(())
}

/// Everything computed before candidate selection.
struct Prepared<'a> {
    eng: Engine<'a>,
    baseline_model: VirtualJointModel,
    labels: Vec<SetLabel>,
    groups: Vec<usize>,
    in_model: Vec<bool>,
    base_fit: Fit,
}

fn prepare<'a>(
    chain: &'a SerialChain,
    data: &Dataset,
    opts: &DiagnoseOptions,
    cancel: &Cancel,
) -> Result<Prepared<'a>, DiagnoseError> {
    check_options(opts)?;
    let n = chain.n_joints();
    if data.n_joints() != n {
        return Err(DiagnoseError::JointCount {
            data: data.n_joints(),
            chain: n,
        });
    }
    if !opts.allow_outside_limits {
        data.check_joint_limits(chain)?;
    }
    let baseline_model = match &opts.baseline {
        Some(m) => {
            if m.n_joints() != n {
                return Err(DiagnoseError::Model(VjmError::InvalidModel {
                    message: format!(
                        "the baseline is for {} joints but the chain has {n}",
                        m.n_joints()
                    ),
                }));
            }
            if m.offsets().iter().any(|o| o.norm() != 0.0) {
                return Err(DiagnoseError::Model(VjmError::InvalidModel {
                    message: "diagnose models springs at the joint origins; spring offsets are not supported".into(),
                }));
            }
            m.clone()
        }
        None => VirtualJointModel::traditional(n),
    };
    let labels = data.split(opts.test_fraction, opts.split_seed)?;
    let train: Vec<usize> = (0..data.len())
        .filter(|&i| labels[i] == SetLabel::Train)
        .collect();
    let test: Vec<usize> = (0..data.len())
        .filter(|&i| labels[i] == SetLabel::Test)
        .collect();
    let n_base = baseline_model.n_params();
    if 3 * train.len() < n_base + 10 {
        return Err(DiagnoseError::TooFewRows {
            observations: 3 * train.len(),
            params: n_base,
        });
    }
    let m = 3 * n;
    let zeros = vec![0.0; m];
    let kin: Vec<RowKinematics> = (0..data.len())
        .map(|i| {
            // Polled every few thousand rows: the kinematics of a million rows take seconds.
            if i % 4096 == 0 {
                cancel.check()?;
            }
            let q = data.q(i).to_vec();
            let pose = crate::testbed::kinematics::deflected_pose(chain, &q, &zeros);
            let w = data.wrench(i);
            let wv = nalgebra::DVector::from_column_slice(&w);
            let tau: Vec<f64> = (pose.jacobian.transpose() * wv).iter().cloned().collect();
            let tau_sigma = candidates::torque_sigma(&pose.jacobian, &opts.noise.wrench_sigma);
            Ok(RowKinematics {
                q,
                jacobian: pose.jacobian,
                tau,
                wrench: w,
                displacement: data.displacement(i),
                tip: [pose.tip.x, pose.tip.y, pose.tip.z],
                tau_sigma,
            })
        })
        .collect::<Result<_, stiffness_core::Cancelled>>()?;
    let tau_scale: Vec<f64> = (0..n)
        .map(|j| {
            (train
                .iter()
                .map(|&i| kin[i].tau[3 * j].powi(2))
                .sum::<f64>()
                / train.len() as f64)
                .sqrt()
        })
        .collect();
    let groups = data.pose_groups();
    let mut eng = Engine {
        chain,
        kin,
        train,
        test,
        tau_scale,
        white: Vec::new(),
        sigma_axis: Vec::new(),
        m,
        cancel: cancel.clone(),
    };
    cancel.check()?;
    // Baseline: a first fit with tracker noise only gives the compliance that propagates the
    // force-sensor noise; then the weighted fit.
    let base_terms: Vec<Term> = baseline_model
        .springs()
        .iter()
        .map(|s| Term::Spring(3 * s.joint + axis_index(s.axis)))
        .collect();
    let mut in_model = vec![false; m];
    for t in &base_terms {
        if let Term::Spring(s) = t {
            in_model[*s] = true;
        }
    }
    eng.set_noise(opts.noise.displacement_sigma, &[0.0; 6], &zeros);
    let lin0 = eng.linearisation(zeros.clone());
    let pre = eng.fit(&base_terms, &lin0);
    cancel.check()?;
    let c_pre = eng.compliances(&pre);
    eng.set_noise(
        opts.noise.displacement_sigma,
        &opts.noise.wrench_sigma,
        &c_pre,
    );
    let base_fit = eng.fit(&base_terms, &eng.linearisation(c_pre.clone()));
    Ok(Prepared {
        eng,
        baseline_model,
        labels,
        groups,
        in_model,
        base_fit,
    })
}

/// Detectability of a hidden effect on these data: `‖(I − P) W s‖²` over the training rows,
/// where `s` is the effect's displacement signal per row (m, base frame; e.g. the noise-free
/// difference between campaigns with and without the effect), `W` the per-row whitening of the
/// noise model and `P` the projector on the baseline's whitened columns. It is the
/// non-centrality of the nested F test of a candidate that models the effect exactly, in units
/// of noise variance. `docs/diagnose.md` states the threshold the acceptance tests use.
pub fn detectability(
    chain: &SerialChain,
    data: &Dataset,
    signal: &[[f64; 3]],
    opts: &DiagnoseOptions,
) -> Result<f64, DiagnoseError> {
    if signal.len() != data.len() {
        return Err(DiagnoseError::InvalidOption {
            name: "signal",
            message: format!("{} rows, the data have {}", signal.len(), data.len()),
        });
    }
    let p = prepare(chain, data, opts, &Cancel::new())?;
    Ok(p.eng.orthogonal_energy(&p.base_fit, signal))
}

/// [`diagnose`] with a progress callback, called after each stage and each selection step.
pub fn diagnose_with_progress(
    chain: &SerialChain,
    data: &Dataset,
    opts: &DiagnoseOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Diagnosis, DiagnoseError> {
    run_diagnosis(chain, data, opts, &Cancel::new(), progress)
}

/// The diagnosis proper: `progress` after each stage and selection step, `cancel` polled after
/// each of them and per scored candidate.
fn run_diagnosis(
    chain: &SerialChain,
    data: &Dataset,
    opts: &DiagnoseOptions,
    cancel: &Cancel,
    progress: &mut dyn FnMut(Progress),
) -> Result<Diagnosis, DiagnoseError> {
    let Prepared {
        eng,
        baseline_model,
        labels,
        groups,
        in_model,
        base_fit,
    } = prepare(chain, data, opts, cancel)?;
    let pose_id = |i: usize| data.pose(i).unwrap_or(groups[i] as i64);
    progress(Progress {
        stage: "kinematics",
        done: 1,
        total: 1,
    });
    cancel.check()?;

    progress(Progress {
        stage: "baseline",
        done: 1,
        total: 1,
    });
    cancel.check()?;

    // Forward selection.
    let mut pool = catalogue(&in_model);
    let first_scores = eng.score(&base_fit, &pool);
    cancel.check()?;
    let scores_report: Vec<CandidateScore> = first_scores
        .iter()
        .map(|s| CandidateScore {
            label: s.cand.label(),
            effect: s.cand.effect(),
            joint: s.cand.joint().map(|j| j + 1),
            axis: s.cand.axis().map(|a| a.to_string()),
            testable: s.rank > 0,
            f_test: (s.rank > 0).then_some(s.f_test),
        })
        .collect();
    let mut current = base_fit.clone();
    let mut findings: Vec<(Candidate, Vec<Alias>, Evidence)> = Vec::new();
    let mut rejected_on_holdout = Vec::new();
    let mut scores = first_scores;
    for step in 1..=opts.max_findings {
        let testable: Vec<&engine::Score> = scores.iter().filter(|s| s.rank > 0).collect();
        if testable.is_empty() {
            break;
        }
        let p: Vec<f64> = testable.iter().map(|s| s.f_test.p_value).collect();
        let rejected = benjamini_hochberg(&p, opts.fdr);
        let mut order: Vec<usize> = (0..testable.len()).filter(|&k| rejected[k]).collect();
        order.sort_by(|&a, &b| {
            p[a].total_cmp(&p[b])
                .then(testable[b].f_test.f.total_cmp(&testable[a].f_test.f))
        });
        let mut accepted = None;
        for &k in &order {
            cancel.check()?;
            let s = testable[k];
            let mut terms = current.terms.clone();
            terms.push(Term::Cand(s.cand));
            let trial = eng.fit(&terms, &current.lin);
            let before = eng.sse(&current, &eng.test);
            let after = eng.sse(&trial, &eng.test);
            if after < before {
                accepted = Some((k, trial, before, after));
                break;
            }
            rejected_on_holdout.push(s.cand.label());
            pool.retain(|c| *c != s.cand);
        }
        let Some((k, trial, before, after)) = accepted else {
            break;
        };
        let a = testable[k];
        let df_a = a.f_test.df_den.max(1.0);
        let sigma2 = a.sse_full / df_a;
        // Aliases: significant candidates b such that, once b is in the model, the data no
        // longer need a (its F test given b has p > alias_alpha), or whose columns are
        // near-collinear with a's after projecting out the model.
        let bh_cut = {
            let mut sorted = p.clone();
            sorted.sort_by(|x, y| x.total_cmp(y));
            (0..sorted.len())
                .filter(|&r| sorted[r] <= opts.fdr * (r + 1) as f64 / sorted.len() as f64)
                .map(|r| sorted[r])
                .fold(0.0, f64::max)
        };
        let mut aliases = Vec::new();
        for b in &testable {
            cancel.check()?;
            if b.cand == a.cand {
                continue;
            }
            let delta = (b.sse_full - a.sse_full) / sigma2;
            let cosine = (a.cand.n_columns() == 1 && b.cand.n_columns() == 1)
                .then(|| linalg::cosine(&a.first_residual, &b.first_residual).abs());
            let collinear = cosine.is_some_and(|c| c >= opts.alias_cosine);
            let p_given = if b.f_test.p_value <= bh_cut {
                eng.score_given(&current, &[b.cand], &[a.cand])[0]
                    .f_test
                    .p_value
            } else {
                0.0
            };
            if collinear || p_given > opts.alias_alpha {
                aliases.push((b.cand, cosine, delta, p_given));
            }
        }
        let rank_a = p.iter().filter(|&&v| v <= p[k]).count();
        let evidence = Evidence {
            step,
            f_test: a.f_test,
            n_candidates: testable.len(),
            bh_threshold: opts.fdr * rank_a as f64 / testable.len() as f64,
            sse_reduction: 1.0 - a.sse_full / a.sse_reduced,
            cluster_robust: eng.cluster_robust(&trial, &groups, a.cand.n_columns()),
            heldout_sse_before: before,
            heldout_sse_after: after,
            estimate: Vec::new(),
            unit: a.cand.unit(),
        };
        pool.retain(|c| *c != a.cand && !aliases.iter().any(|(b, _, _, _)| b == c));
        findings.push((
            a.cand,
            aliases
                .into_iter()
                .map(|(b, cosine, delta, p_given)| Alias {
                    effect: b.effect(),
                    joint: b.joint().map(|j| j + 1),
                    axis: b.axis().map(|x| x.to_string()),
                    cosine,
                    delta_chi2: delta,
                    p_finding_given_alias: p_given,
                })
                .collect(),
            evidence,
        ));
        current = trial;
        progress(Progress {
            stage: "selection",
            done: step,
            total: opts.max_findings,
        });
        cancel.check()?;
        if pool.is_empty() {
            break;
        }
        scores = eng.score(&current, &pool);
        cancel.check()?;
    }

    // Extended model: refit all terms together (re-linearised from the baseline).
    let ext_terms = current.terms.clone();
    cancel.check()?;
    let ext_fit = if findings.is_empty() {
        base_fit.clone()
    } else {
        eng.fit(&ext_terms, &base_fit.lin)
    };
    // Estimates of each finding in the final fit.
    let mut k = 0;
    let mut estimates: Vec<(Candidate, Vec<f64>)> = Vec::new();
    for t in &ext_fit.terms {
        let nc = match t {
            Term::Spring(_) => 1,
            Term::Cand(c) => c.n_columns(),
        };
        if let Term::Cand(c) = t {
            estimates.push((*c, ext_fit.coef[k..k + nc].to_vec()));
        }
        k += nc;
    }
    for (cand, _, ev) in findings.iter_mut() {
        if let Some((_, e)) = estimates.iter().find(|(c, _)| c == cand) {
            ev.estimate = e.clone();
        }
    }

    let residuals = |fit: &Fit| -> Vec<[f64; 3]> {
        (0..eng.kin.len())
            .map(|i| {
                let d = eng.kin[i].displacement;
                let p = fit.pred[i];
                [d[0] - p[0], d[1] - p[1], d[2] - p[2]]
            })
            .collect()
    };
    let res_base = residuals(&base_fit);
    let res_ext = residuals(&ext_fit);
    let struct_base = residual_structure(&eng.kin, &eng.train, &res_base, &eng.sigma_axis, &groups);
    let struct_ext = residual_structure(&eng.kin, &eng.train, &res_ext, &eng.sigma_axis, &groups);
    let unexplained = struct_ext.per_pose_anova.p_value < opts.unexplained_alpha;

    let summary = |fit: &Fit, name: String| ModelSummary {
        model: name,
        n_params: fit.n_params(),
        test_mean_rel_error: eng.mean_rel_error(fit, &eng.test),
        train_mean_rel_error: eng.mean_rel_error(fit, &eng.train),
        parameters: parameters(fit),
    };
    let base_name = baseline_model.name().to_string();
    let ext_name = if findings.is_empty() {
        base_name.clone()
    } else {
        let mut s = base_name.clone();
        for (c, _, _) in &findings {
            s.push_str(" + ");
            s.push_str(&c.label());
        }
        s
    };
    let baseline = summary(&base_fit, base_name);
    let extended = summary(&ext_fit, ext_name);
    let gain = 1.0 - extended.test_mean_rel_error / baseline.test_mean_rel_error;

    // Per-pose errors and per-row results for the report.
    let mut per_pose: Vec<PoseError> = Vec::new();
    let n_groups = groups.iter().copied().max().map_or(0, |g| g + 1);
    for g in 0..n_groups {
        let rows: Vec<usize> = (0..data.len()).filter(|&i| groups[i] == g).collect();
        if rows.is_empty() {
            continue;
        }
        per_pose.push(PoseError {
            pose: pose_id(rows[0]),
            set: labels[rows[0]],
            baseline: eng.mean_rel_error(&base_fit, &rows),
            extended: eng.mean_rel_error(&ext_fit, &rows),
        });
    }
    let rows = (0..data.len())
        .map(|i| RowResult {
            pose: pose_id(i),
            set: labels[i],
            measured: eng.kin[i].displacement,
            baseline: base_fit.pred[i],
            extended: ext_fit.pred[i],
        })
        .collect();
    progress(Progress {
        stage: "done",
        done: 1,
        total: 1,
    });
    Ok(Diagnosis {
        baseline,
        findings: findings
            .into_iter()
            .map(|(c, aliases, evidence)| Finding {
                effect: c.effect(),
                joint: c.joint().map(|j| j + 1),
                axis: c.axis().map(|a| a.to_string()),
                aliases,
                evidence,
            })
            .collect(),
        extended,
        unexplained,
        gain,
        residuals: ResidualReport {
            baseline: struct_base,
            extended: struct_ext,
        },
        scores: scores_report,
        rejected_on_holdout,
        per_pose,
        rows,
        n_train: eng.train.len(),
        n_test: eng.test.len(),
        fdr: opts.fdr,
    })
}

fn parameters(fit: &Fit) -> Vec<Parameter> {
    let mut out = Vec::new();
    let mut k = 0;
    for t in &fit.terms {
        match t {
            Term::Spring(s) => {
                let axis = ["z", "x", "y"][s % 3];
                out.push(Parameter {
                    label: format!("J{}{}", s / 3 + 1, axis),
                    value: fit.in_data[k].then_some(fit.coef[k]),
                    unit: "rad/(N·m)",
                });
                k += 1;
            }
            Term::Cand(c) => {
                let names: Vec<String> = match c {
                    Candidate::WrenchBias => ["fx", "fy", "fz", "mx", "my", "mz"]
                        .iter()
                        .map(|a| format!("wrench_bias.{a}"))
                        .collect(),
                    Candidate::FrameMisalignment => ["x", "y", "z"]
                        .iter()
                        .map(|a| format!("frame_misalignment.{a}"))
                        .collect(),
                    _ => vec![c.label()],
                };
                for name in names {
                    out.push(Parameter {
                        label: name,
                        value: fit.in_data[k].then_some(fit.coef[k]),
                        unit: c.unit(),
                    });
                    k += 1;
                }
            }
        }
    }
    out
}
