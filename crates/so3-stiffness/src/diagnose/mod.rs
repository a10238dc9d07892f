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
//!    `cable_hysteresis`, `cable_nonlinearity`. Forward selection with nested F tests,
//!    Benjamini–Hochberg at each step, confirmation on the held-out rows; aliases when a
//!    candidate explains nothing beyond a finding it also explained alone, and
//!    `linear_stiffness` when an effect lies (almost) in the span of K_D itself.
//! 4. **Connection term**: the asymmetry of K_D tested against `hat(τ₀)`
//!    ([`connection::ConnectionTest`]); a finding when K_D is measurably asymmetric, telling
//!    the user that the symmetric covariant K is the stiffness.
//! 5. **Extended model**, its held-out error and the gain; `unexplained` when structure
//!    remains.
//!
//! ```
//! use so3_stiffness::diagnose::{diagnose, DiagnoseOptions};
//! use so3_stiffness::diagnose::testbed::{simulate_campaign, CsjmCampaignSpec, CsjmEffects};
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
mod engine;
pub mod report;
pub use crate::stats;
pub mod structure;
pub mod testbed;

use std::path::Path;

use nalgebra::Vector3;
use rand::rngs::StdRng;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use thiserror::Error;

pub use candidates::Effect;
use candidates::{labels, Samples, Term, BASELINE_COLUMNS};
pub use connection::ConnectionTest;
use engine::{Engine, Fit};
pub use report::{
    Alias, CandidateScore, CsjmDiagnosis, Evidence, Finding, ModelSummary, Parameter,
    ResidualReport, RowResult, SelectionEvidence,
};
use stats::{benjamini_hochberg, nested_f_test, FTest};
pub use testbed::{simulate_campaign, CsjmCampaign, CsjmCampaignSpec, CsjmEffects};

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
    /// False discovery rate q of the Benjamini–Hochberg selection (0 < q < 1).
    pub fdr: f64,
    /// Fraction of the loaded rows held out (0 < f < 1).
    pub test_fraction: f64,
    /// Seed of the train/test split (the same seed gives the same split).
    pub holdout_seed: u64,
    /// The platform weight the `platform_gravity` candidate tests for (the prototype's by
    /// default: 4.82 N at ᴬr_G = (0, 0, 0.081) m, z_B up).
    pub weight: PointLoad,
    /// How the measurement file is read by [`diagnose_file`].
    pub read: ReadOptions,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            fdr: 0.05,
            test_fraction: 0.25,
            holdout_seed: 0x5eed_d1a6,
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
    #[error("invalid diagnose option `{option}` = {value}: must be {requirement}")]
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
}

impl DiagnoseOptions {
    fn validate(&self) -> Result<(), DiagnoseError> {
        if !(self.fdr > 0.0 && self.fdr < 1.0) {
            return Err(DiagnoseError::InvalidOption {
                option: "fdr",
                value: self.fdr,
                requirement: "in (0, 1)",
            });
        }
        if !(self.test_fraction > 0.0 && self.test_fraction < 1.0) {
            return Err(DiagnoseError::InvalidOption {
                option: "test_fraction",
                value: self.test_fraction,
                requirement: "in (0, 1)",
            });
        }
        Ok(())
    }
}

/// Reads a CSJM measurement file (see [`crate::identification::dataset`]) and diagnoses it.
pub fn diagnose_file(
    path: impl AsRef<Path>,
    options: &DiagnoseOptions,
) -> Result<CsjmDiagnosis, DiagnoseError> {
    options.validate()?;
    let data = CsjmDataset::from_csv_path(path, &options.read)?;
    diagnose(&data, options)
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

fn parameters(fit: &Fit, only: Option<Term>) -> Vec<Parameter> {
    let mut out = Vec::new();
    let mut index = 0;
    for t in &fit.terms {
        for (label, unit) in labels(*t) {
            if only.is_none_or(|o| o == *t) {
                out.push(Parameter {
                    label,
                    value: fit.beta[index],
                    stderr: fit.cov[(index, index)].max(0.0).sqrt(),
                    unit,
                });
            }
            index += 1;
        }
    }
    out
}

fn summary(engine: &Engine<'_>, fit: &Fit) -> ModelSummary {
    let (c, k_d) = fit.offset_and_k_d();
    let alpha = fit
        .start_of(Term::Effect(Effect::PlatformGravity))
        .map_or(0.0, |i| fit.beta[i]);
    let tau0 = engine.samples.tau_ref + c + alpha * engine.samples.gravity_at(&Vector3::zeros());
    let k = k_d - 0.5 * so3::hat(&tau0);
    ModelSummary {
        model: model_name(&fit.terms),
        n_params: fit.beta.len(),
        rank: fit.rank,
        test_mean_rel_error: engine.mean_rel_error(fit, &engine.test),
        train_mean_rel_error: engine.mean_rel_error(fit, &engine.train),
        k_d: connection::rows(&k_d),
        k: connection::rows(&k),
        parameters: parameters(fit, None),
    }
}

fn f_test(engine: &Engine<'_>, reduced: &Fit, full: &Fit) -> FTest {
    let _ = engine;
    nested_f_test(
        reduced.sse,
        full.sse,
        full.rank.saturating_sub(reduced.rank),
        full.dof(),
    )
}

fn interpretation(engine: &Engine<'_>, fit: &Fit, effect: Effect) -> String {
    let start = fit.start_of(Term::Effect(effect)).unwrap_or(0);
    let beta = &fit.beta[start..start + effect.n_columns()];
    let se = |i: usize| fit.cov[(start + i, start + i)].max(0.0).sqrt();
    match effect {
        Effect::PlatformGravity => {
            let w = engine.samples.weight;
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
    options.validate()?;
    let samples = Samples::new(data, options.weight);
    let loaded = samples.len() - 1;
    let mut order: Vec<usize> = (1..=loaded).collect();
    order.shuffle(&mut StdRng::seed_from_u64(options.holdout_seed));
    let n_test = ((options.test_fraction * loaded as f64).round() as usize).min(loaded);
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
    let engine = Engine::new(&samples, train, test);
    let q = options.fdr;

    let baseline_fit = engine.fit(&[Term::Baseline], &engine.train);
    if baseline_fit.rank < BASELINE_COLUMNS {
        return Err(DiagnoseError::Unexcited {
            rank: baseline_fit.rank,
        });
    }

    // First-step scores of the whole catalogue.
    let gravity_note = {
        let w = options.weight;
        let k_g = w.moment_derivative(&samples.r0);
        let k_g_sym = 0.5 * (k_g + k_g.transpose());
        format!(
            "to first order the omitted weight moment changes linearly with Δζ and is absorbed \
             into K_D (biasing K by the gravity stiffness, ‖sym ∂τ_G/∂ζ‖_F = {:.3} N·m/rad for \
             the assumed weight); only its curvature is testable on these data",
            k_g_sym.norm()
        )
    };
    let scores: Vec<CandidateScore> = Effect::ALL
        .iter()
        .map(|&e| {
            let full = engine.fit(&[Term::Baseline, Term::Effect(e)], &engine.train);
            let fraction = engine.fraction_outside(&[Term::Baseline], Term::Effect(e));
            CandidateScore {
                effect: e.name(),
                n_columns: e.n_columns(),
                fraction_outside_baseline: fraction,
                f_test: f_test(&engine, &baseline_fit, &full),
                note: (fraction < LINEAR_ALIAS_FRACTION).then(|| {
                    if e == Effect::PlatformGravity {
                        gravity_note.clone()
                    } else {
                        "almost collinear with the first-order model on these data".into()
                    }
                }),
            }
        })
        .collect();

    // Forward selection: nested F tests, BH per step, held-out confirmation.
    let mut terms = vec![Term::Baseline];
    let mut current = baseline_fit.clone();
    let mut accepted: Vec<(Effect, SelectionEvidence, Vec<Alias>)> = Vec::new();
    let mut rejected_on_holdout: Vec<&'static str> = Vec::new();
    loop {
        let pool: Vec<Effect> = Effect::ALL
            .iter()
            .copied()
            .filter(|e| {
                !terms.contains(&Term::Effect(*e)) && !rejected_on_holdout.contains(&e.name())
            })
            .collect();
        if pool.is_empty() {
            break;
        }
        let fits: Vec<Fit> = pool
            .iter()
            .map(|&e| {
                let mut t = terms.clone();
                t.push(Term::Effect(e));
                engine.fit(&t, &engine.train)
            })
            .collect();
        let tests: Vec<FTest> = fits.iter().map(|f| f_test(&engine, &current, f)).collect();
        let p: Vec<f64> = tests.iter().map(|t| t.p_value).collect();
        let passing = benjamini_hochberg(&p, q);
        let mut ranked: Vec<usize> = (0..pool.len()).filter(|&i| passing[i]).collect();
        ranked.sort_by(|&a, &b| p[a].total_cmp(&p[b]));
        let heldout_before = engine.sse(&current, &engine.test);
        let mut chosen = None;
        for &i in &ranked {
            let after = engine.sse(&fits[i], &engine.test);
            if after < heldout_before {
                chosen = Some((i, after));
                break;
            }
            rejected_on_holdout.push(pool[i].name());
        }
        let Some((i, heldout_after)) = chosen else {
            break;
        };
        let effect = pool[i];
        let rank_in_bh = ranked.iter().position(|&r| r == i).unwrap_or(0) + 1;
        let with_x = &fits[i];
        let s2 = with_x.sse / with_x.dof().max(1) as f64;
        let mut aliases = Vec::new();
        for &j in &ranked {
            if j == i {
                continue;
            }
            let mut t = with_x.terms.clone();
            t.push(Term::Effect(pool[j]));
            let both = engine.fit(&t, &engine.train);
            let beyond = f_test(&engine, with_x, &both);
            if beyond.p_value > q {
                aliases.push(Alias {
                    effect: pool[j].name(),
                    joint: None,
                    axis: None,
                    delta_chi2: Some((fits[j].sse - with_x.sse) / s2),
                    note: format!(
                        "also significant alone (p = {:.2e}) but explains nothing beyond {} \
                         (p = {:.2}): the two cannot be told apart on these data",
                        p[j],
                        effect.name(),
                        beyond.p_value
                    ),
                });
            }
        }
        if effect == Effect::PlatformGravity
            && !aliases
                .iter()
                .any(|a| a.effect == Effect::CableNonlinearity.name())
        {
            let beyond_curvature = engine.fraction_outside(
                &[Term::Baseline, Term::Effect(Effect::CableNonlinearity)],
                Term::Effect(effect),
            );
            if beyond_curvature < LINEAR_ALIAS_FRACTION {
                aliases.push(Alias {
                    effect: Effect::CableNonlinearity.name(),
                    joint: None,
                    axis: None,
                    delta_chi2: None,
                    note: format!(
                        "only {:.2} % of the gravity column lies outside the span of the \
                         first-order model plus quadratic terms in Δζ: its testable part is a \
                         curvature of τ(Δζ), which the mechanism's own geometry or stiffening \
                         cables also produce",
                        100.0 * beyond_curvature
                    ),
                });
            }
        }
        let fraction = engine.fraction_outside(&[Term::Baseline], Term::Effect(effect));
        if fraction < LINEAR_ALIAS_FRACTION {
            aliases.push(Alias {
                effect: "linear_stiffness",
                joint: None,
                axis: None,
                delta_chi2: None,
                note: if effect == Effect::PlatformGravity {
                    gravity_note.clone()
                } else {
                    format!(
                        "only {:.1} % of the effect's column energy lies outside the span of \
                         K_D: most of it is absorbed into the linear stiffness",
                        100.0 * fraction
                    )
                },
            });
        }
        let evidence = SelectionEvidence {
            step: accepted.len() + 1,
            f_test: tests[i],
            n_candidates: pool.len(),
            bh_threshold: q * rank_in_bh as f64 / pool.len() as f64,
            sse_reduction: 1.0 - with_x.sse / current.sse,
            heldout_sse_before: heldout_before,
            heldout_sse_after: heldout_after,
            fraction_outside_baseline: fraction,
            estimate: Vec::new(),
            interpretation: String::new(),
        };
        terms.push(Term::Effect(effect));
        current = fits[i].clone();
        accepted.push((effect, evidence, aliases));
    }

    let extended_fit = current;
    let mut findings: Vec<Finding> = accepted
        .into_iter()
        .map(|(effect, mut evidence, aliases)| {
            evidence.estimate = parameters(&extended_fit, Some(Term::Effect(effect)));
            evidence.interpretation = interpretation(&engine, &extended_fit, effect);
            Finding {
                effect: effect.name(),
                joint: None,
                axis: None,
                aliases,
                evidence: Evidence::Selection(evidence),
            }
        })
        .collect();

    let connection_term = connection::connection_test(&engine, &extended_fit, q);
    if connection_term.p_asymmetry < q {
        findings.push(Finding {
            effect: CONNECTION_TERM,
            joint: None,
            axis: None,
            aliases: Vec::new(),
            evidence: Evidence::Connection(connection_term.clone()),
        });
    }

    let all: Vec<usize> = (1..=loaded).collect();
    let residuals = ResidualReport {
        baseline: structure::residual_structure(&engine, &baseline_fit, &all),
        extended: structure::residual_structure(&engine, &extended_fit, &all),
    };
    let unexplained = residuals.extended.p_bonferroni < UNEXPLAINED_P
        || (connection_term.p_asymmetry < q && connection_term.p_theory < UNEXPLAINED_P);

    let baseline = summary(&engine, &baseline_fit);
    let extended = summary(&engine, &extended_fit);
    let gain = 1.0 - extended.test_mean_rel_error / baseline.test_mean_rel_error;
    let base_res = engine.residuals(&baseline_fit, &all);
    let ext_res = engine.residuals(&extended_fit, &all);
    let rows = all
        .iter()
        .enumerate()
        .map(|(r, &k)| RowResult {
            row: samples.file_rows[k],
            set: if engine.test.binary_search(&k).is_ok() {
                "test"
            } else {
                "train"
            },
            dzeta: samples.zeta[k].into(),
            dtau: samples.dtau[k].into(),
            baseline_residual: base_res[r].into(),
            extended_residual: ext_res[r].into(),
        })
        .collect();
    Ok(CsjmDiagnosis {
        baseline,
        findings,
        extended,
        unexplained,
        gain,
        connection_term,
        residuals,
        scores,
        rejected_on_holdout,
        rows,
        noise_sigma: engine.sigma().into(),
        n_train: engine.train.len(),
        n_test: engine.test.len(),
        fdr: q,
        holdout_seed: options.holdout_seed,
    })
}
