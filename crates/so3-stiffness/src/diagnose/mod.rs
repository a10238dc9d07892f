//! Diagnosis of a CSJM measurement campaign: what the first-order stiffness model gets wrong,
//! which physical effect causes it, the extended model, and its gain on held-out rows
//! (issue 5, CSJM half). See `docs/csjm-diagnose.md`.
//!
//! 1. **Baseline**: `Δτ_k = c + K_D Δζ_k` (seed eq. 49 with an offset), fitted on the training
//!    rows (the reference row always among them; a seeded random quarter of the loaded rows
//!    held out). Its error is `test_mean_rel_error`: the mean over held-out rows of
//!    ‖Δζ_pred − Δζ_meas‖/‖Δζ_meas‖, Δζ_pred the displacement the model predicts for the
//!    recorded load.
//! 2. **Residual structure** against load magnitude, load direction and loading/unloading.
//! 3. **Candidates** ([`Effect`]) as columns appended to the linear model: `platform_gravity`,
//!    `cable_hysteresis`, `cable_nonlinearity`. The selection runs on the engine shared with
//!    the serial-arm diagnosis (`stiffness_core::engine`, the campaign as a [`Problem`] of
//!    moment components whitened per component): forward selection with nested F tests,
//!    Benjamini–Hochberg at `fdr` at each step, confirmation on the held-out rows; a
//!    significant effect is an alias of a finding when, with it in the model, the finding's F
//!    test has p > `alias_alpha` (or their one-column parts outside the model are collinear).
//!    On top, CSJM-specific: `linear_stiffness` when an effect lies (almost) in the span of
//!    K_D itself, and `cable_nonlinearity` for a gravity column that is only a curvature.
//!
//! [`Problem`]: stiffness_core::engine::Problem
//! 4. **Connection term**: the asymmetry of K_D tested against `hat(τ₀)`
//!    ([`connection::ConnectionTest`]); a finding when K_D is measurably asymmetric, telling
//!    the user that the symmetric covariant K is the stiffness.
//! 5. **Extended model**, its held-out error and the gain; `unexplained` when structure
//!    remains.
//!
//! ```
//! use so3_stiffness::diagnose::{diagnose, DiagnoseOptions};
//! use so3_stiffness::testbed::{simulate_campaign, CsjmCampaignSpec, CsjmEffects};
//! let campaign = simulate_campaign(&CsjmCampaignSpec::new(CsjmEffects::friction(2.0), 1))?;
//! let diagnosis = diagnose(&campaign.dataset, &DiagnoseOptions::default())?;
//! assert!(diagnosis.names("cable_hysteresis"));
//! println!(
//!     "held-out error {:.3} → {:.3}",
//!     diagnosis.baseline.test_mean_rel_error, diagnosis.extended.test_mean_rel_error
//! );
//! let json = diagnosis.to_json();
//! assert!(json.contains("\"findings\""));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod candidates;
pub mod connection;
mod problem;
pub mod report;
pub use crate::stats;
mod run;
pub mod structure;
/// The virtual testbed, now `crate::testbed` (kept here under its former path; feature
/// `testbed`).
#[cfg(feature = "testbed")]
pub use crate::testbed;
use run::run_diagnosis;
pub use stiffness_core::engine::schema::SelectionOptions;

use std::path::Path;

use nalgebra::{DMatrix, Vector3};
use rand::rngs::StdRng;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use thiserror::Error;

pub use candidates::Effect;
use candidates::{labels, Term, BASELINE_COLUMNS};
pub use connection::ConnectionTest;
use problem::{CsjmFit, CsjmProblem};
pub use report::{
    Alias, CandidateScore, CsjmDiagnosis, CsjmModelDetail, DefectEvidence, Evidence, Finding,
    ModelSummary, Parameter, ResidualReport, RowResult, SelectionEvidence,
};
use stiffness_core::engine::{Compressed, Selected};
use stiffness_core::{Cancel, Monitor};
#[cfg(feature = "testbed")]
pub use testbed::{simulate_campaign, CsjmCampaign, CsjmCampaignSpec, CsjmEffects};

/// Progress of a long diagnosis (the workspace-wide record).
pub use stiffness_core::Progress;

use crate::csjm::PointLoad;
use crate::identification::{CsjmDataset, IdentificationError, ReadOptions};
use crate::so3;

/// The effect name of the connection-term finding.
pub const CONNECTION_TERM: &str = "connection_term";

/// Minimum training samples (the reference included): 3 observations each against the
/// baseline's 12 parameters and the largest candidate's 18.
pub const MIN_TRAIN_SAMPLES: usize = 12;
/// Minimum held-out rows.
pub const MIN_TEST_ROWS: usize = 3;
/// Residual structure or connection-term inconsistency below this p-value is `unexplained`.
pub const UNEXPLAINED_P: f64 = 0.01;
/// An effect whose columns keep less than this fraction of their energy outside the span of
/// the first-order model is reported as an alias of `linear_stiffness`.
pub const LINEAR_ALIAS_FRACTION: f64 = 0.05;

/// Options of [`diagnose`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct DiagnoseOptions {
    /// The selection and hold-out options every model shares (false discovery rate, also the
    /// level of the connection-term finding; held-out fraction of the loaded rows; split seed;
    /// alias thresholds).
    pub selection: SelectionOptions,
    /// The platform weight the `platform_gravity` candidate tests for (the prototype's by
    /// default: 4.82 N at ᴬr_G = (0, 0, 0.081) m, z_B up).
    pub weight: PointLoad,
    /// How the measurement file is read by [`diagnose_file`].
    pub read: ReadOptions,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            selection: SelectionOptions::default(),
            weight: PointLoad::prototype_gravity(),
            read: ReadOptions::default(),
        }
    }
}

/// Everything that can stop a diagnosis.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum DiagnoseError {
    /// The measurement file or dataset is invalid.
    #[error(transparent)]
    Data(#[from] IdentificationError),
    /// An option is out of range.
    #[error("invalid diagnose option `{option}` = {}: must be {requirement}", stiffness_core::num::Short(*.value))]
    InvalidOption {
        /// The option's name.
        option: &'static str,
        /// Its value.
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
    /// Too few rows for a split into training and held-out rows.
    #[error(
        "{loaded} loaded rows give {train} training samples (reference included) and {test} \
         held-out rows; the diagnosis needs at least {MIN_TRAIN_SAMPLES} and {MIN_TEST_ROWS}"
    )]
    TooFewRows {
        /// Loaded rows in the dataset.
        loaded: usize,
        /// Training samples.
        train: usize,
        /// Held-out rows.
        test: usize,
    },
    /// The training displacements do not excite all three axes: K_D cannot be fitted.
    #[error(
        "the first-order model has rank {rank} < {BASELINE_COLUMNS} on the training rows: \
         the displacements do not excite all three rotation axes"
    )]
    Unexcited {
        /// Rank of the baseline design.
        rank: usize,
    },
    /// The run was cancelled through its [`Cancel`] token.
    #[error("diagnosis cancelled")]
    Cancelled(#[from] stiffness_core::Cancelled),
}

impl DiagnoseOptions {
    fn validate(&self) -> Result<(), DiagnoseError> {
        self.selection
            .check()
            .map_err(|e| DiagnoseError::InvalidOption {
                option: e.option,
                value: e.value,
                requirement: e.requirement,
            })
    }
}

/// Reads a CSJM measurement file (see [`crate::identification::dataset`]) and diagnoses it.
pub fn diagnose_file(
    path: impl AsRef<Path>,
    options: &DiagnoseOptions,
) -> Result<CsjmDiagnosis, DiagnoseError> {
    diagnose_file_monitored(path, options, &Monitor::none())
}

/// [`diagnose_file`] under a [`Monitor`] (see [`diagnose_monitored`]).
pub fn diagnose_file_monitored(
    path: impl AsRef<Path>,
    options: &DiagnoseOptions,
    monitor: &Monitor<'_>,
) -> Result<CsjmDiagnosis, DiagnoseError> {
    options.validate()?;
    let data = CsjmDataset::from_csv_path(path, &options.read)?;
    diagnose_monitored(&data, options, monitor)
}

fn model_name(terms: &[Term]) -> String {
    let mut name = String::from("first_order_K_D");
    for t in terms {
        if let Term::Effect(e) = t {
            name.push_str(" + ");
            name.push_str(e.name());
        }
    }
    name
}

fn parameters(fit: &CsjmFit, cov: &DMatrix<f64>, only: Option<Term>) -> Vec<Parameter> {
    let mut out = Vec::new();
    let mut index = 0;
    for t in &fit.terms {
        for (label, unit) in labels(*t) {
            if only.is_none_or(|o| o == *t) {
                out.push(Parameter {
                    label,
                    value: Some(fit.coef[index]),
                    stderr: Some(cov[(index, index)].max(0.0).sqrt()),
                    unit,
                });
            }
            index += 1;
        }
    }
    out
}

fn summary(problem: &CsjmProblem<'_>, fit: &CsjmFit, cov: &DMatrix<f64>) -> ModelSummary {
    let (c, k_d) = CsjmProblem::offset_and_k_d(fit);
    let alpha = CsjmProblem::start_of(fit, Term::Effect(Effect::PlatformGravity))
        .map_or(0.0, |i| fit.coef[i]);
    let tau0 = problem.samples.tau_ref + c + alpha * problem.samples.gravity_at(&Vector3::zeros());
    let k = k_d - 0.5 * so3::hat(&tau0);
    ModelSummary {
        model: model_name(&fit.terms),
        n_params: fit.coef.len(),
        test_mean_rel_error: problem.mean_rel_error(fit, &problem.test),
        train_mean_rel_error: problem.mean_rel_error(fit, &problem.train),
        parameters: parameters(fit, cov, None),
        detail: CsjmModelDetail {
            rank: fit.rank,
            k_d: connection::rows(&k_d),
            k: connection::rows(&k),
        },
    }
}

fn interpretation(
    problem: &CsjmProblem<'_>,
    fit: &CsjmFit,
    cov: &DMatrix<f64>,
    effect: Effect,
) -> String {
    let start = CsjmProblem::start_of(fit, Term::Effect(effect)).unwrap_or(0);
    let beta = &fit.coef[start..start + effect.n_columns()];
    let se = |i: usize| cov[(start + i, start + i)].max(0.0).sqrt();
    match effect {
        Effect::PlatformGravity => {
            let w = problem.samples.weight;
            let moment = w
                .point_in_a()
                .cross(&w.force_in_b())
                .norm()
                .max(w.point_in_a().norm() * w.force_in_b().norm());
            format!(
                "the recorded moments miss α = {:.2} ± {:.2} times the moment of the assumed \
                 platform weight ({:.2} N at ‖r_G‖ = {:.3} m, up to {:.3} N·m): add eq. 56 \
                 (τ_G = r_G × Rᵀ G) to the recorded moments",
                beta[0],
                se(0),
                w.force_in_b().norm(),
                w.point_in_a().norm(),
                moment
            )
        }
        Effect::CableHysteresis => {
            let h = nalgebra::Matrix3::from_fn(|i, j| beta[3 * i + j]);
            let width = 2.0 * (h * Vector3::repeat(1.0)).norm();
            format!(
                "loading and unloading reach different poses: the moment offset switches with \
                 the direction of the load change (‖H‖_F = {:.3} N·m; loop width up to ≈ {:.3} \
                 N·m): friction in the cables. Identify K from increments in one direction, \
                 or keep the offsets in the model",
                h.norm(),
                width
            )
        }
        Effect::CableNonlinearity => {
            let norm = beta.iter().map(|b| b * b).sum::<f64>().sqrt();
            format!(
                "τ(Δζ) is curved (‖H‖ = {norm:.1} N·m/rad²): the stiffness changes with the \
                 load (stiffening cables, or the mechanism's own geometric curvature at large \
                 increments). Use the second-order fit (FitOrder::Second) or smaller increments"
            )
        }
    }
}

/// Diagnoses a CSJM dataset (rows in measurement order; see the module docs).
///
/// Errors: invalid options, too few rows to split, displacements that do not excite all
/// three axes on the training rows.
pub fn diagnose(
    data: &CsjmDataset,
    options: &DiagnoseOptions,
) -> Result<CsjmDiagnosis, DiagnoseError> {
    run_diagnosis(data, options, &Cancel::new(), &mut |_| {})
}

/// [`diagnose`] with a progress callback, called after each stage and each selection step.
pub fn diagnose_with_progress(
    data: &CsjmDataset,
    options: &DiagnoseOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<CsjmDiagnosis, DiagnoseError> {
    run_diagnosis(data, options, &Cancel::new(), progress)
}

/// [`diagnose`] under a [`Monitor`]: progress goes to its sink, and its token is polled per
/// pass, per scored candidate and per selection step, so that a cancel ends the run promptly
/// with [`DiagnoseError::Cancelled`].
pub fn diagnose_monitored(
    data: &CsjmDataset,
    options: &DiagnoseOptions,
    monitor: &Monitor<'_>,
) -> Result<CsjmDiagnosis, DiagnoseError> {
    run_diagnosis(data, options, monitor.cancel_token(), &mut |p| {
        // A cancel requested by the sink is seen at the check that follows every report.
        let _ = monitor.report(p);
    })
}

/// The train/test split: a seeded random `test_fraction` of the loaded rows held out, the
/// reference always trained on.
fn split(
    loaded: usize,
    options: &DiagnoseOptions,
) -> Result<(Vec<usize>, Vec<usize>), DiagnoseError> {
    let mut order: Vec<usize> = (1..=loaded).collect();
    order.shuffle(&mut StdRng::seed_from_u64(options.selection.split_seed));
    let n_test = ((options.selection.test_fraction * loaded as f64).round() as usize).min(loaded);
    let mut test: Vec<usize> = order[..n_test].to_vec();
    test.sort_unstable();
    let mut train: Vec<usize> = std::iter::once(0)
        .chain(order[n_test..].iter().copied())
        .collect();
    train.sort_unstable();
    if train.len() < MIN_TRAIN_SAMPLES || test.len() < MIN_TEST_ROWS {
        return Err(DiagnoseError::TooFewRows {
            loaded,
            train: train.len(),
            test: test.len(),
        });
    }
    Ok((train, test))
}

/// The report's aliases of one finding: the engine's (candidates the data cannot tell from
/// it), then the CSJM-specific ones: a gravity column that is only a curvature of τ(Δζ), and
/// an effect (almost) in the span of K_D itself (`linear_stiffness`).
fn aliases_of(
    problem: &CsjmProblem<'_>,
    comp: &Compressed,
    alias_cosine: f64,
    selected: &Selected<Term>,
    fraction: f64,
    gravity_note: &str,
) -> Vec<Alias> {
    let effect = effect_of(selected.cand);
    let mut aliases: Vec<Alias> = selected
        .aliases
        .iter()
        .map(|a| {
            let b = effect_of(a.cand);
            let note = match a.cosine {
                Some(c) if c >= alias_cosine => format!(
                    "its column and {}'s are collinear outside the model (|cos| = {c:.4}): the \
                     two cannot be told apart on these data",
                    effect.name()
                ),
                _ => format!(
                    "once it is in the model, {} explains nothing more (p = {:.2}): the two \
                     cannot be told apart on these data",
                    effect.name(),
                    a.p_finding_given_alias
                ),
            };
            Alias {
                effect: b.name(),
                joint: None,
                axis: None,
                cosine: a.cosine,
                delta_chi2: a.delta_chi2,
                p_finding_given_alias: a.p_finding_given_alias,
                note: Some(note),
            }
        })
        .collect();
    if effect == Effect::PlatformGravity
        && !aliases
            .iter()
            .any(|a| a.effect == Effect::CableNonlinearity.name())
    {
        let beyond_curvature = problem.fraction_outside(
            comp,
            &[Term::Baseline, Term::Effect(Effect::CableNonlinearity)],
            selected.cand,
        );
        if beyond_curvature < LINEAR_ALIAS_FRACTION {
            aliases.push(Alias::not_a_candidate(
                Effect::CableNonlinearity.name(),
                format!(
                    "only {:.2} % of the gravity column lies outside the span of the \
                     first-order model plus quadratic terms in Δζ: its testable part is a \
                     curvature of τ(Δζ), which the mechanism's own geometry or stiffening \
                     cables also produce",
                    100.0 * beyond_curvature
                ),
            ));
        }
    }
    if fraction < LINEAR_ALIAS_FRACTION {
        aliases.push(Alias::not_a_candidate(
            "linear_stiffness",
            if effect == Effect::PlatformGravity {
                gravity_note.to_string()
            } else {
                format!(
                    "only {:.1} % of the effect's column energy lies outside the span of \
                     K_D: most of it is absorbed into the linear stiffness",
                    100.0 * fraction
                )
            },
        ));
    }
    aliases
}

fn effect_of(term: Term) -> Effect {
    match term {
        Term::Effect(e) => e,
        Term::Baseline => unreachable!("the pool holds catalogue effects only"),
    }
}
