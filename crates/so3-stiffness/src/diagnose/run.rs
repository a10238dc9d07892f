//! The CSJM diagnosis in named stages: the baseline fit, the forward selection, the findings
//! with their evidence, the connection term, the residuals and the report.

use nalgebra::DMatrix;
use stiffness_core::engine::fit::fit;
use stiffness_core::engine::select::Selection;
use stiffness_core::engine::NoDetail;
use stiffness_core::engine::{select, Compressed, SelectOptions};
use stiffness_core::{Cancel, Progress};

use super::candidates::{Samples, Term, BASELINE_COLUMNS};
use super::problem::{CsjmFit, CsjmProblem};
use super::report::{
    CandidateScore, CsjmDiagnosis, DefectEvidence, Evidence, Finding, ResidualReport, RowResult,
};
use super::{
    aliases_of, connection, effect_of, interpretation, parameters, split, structure, summary,
    DiagnoseError, DiagnoseOptions, Effect, CONNECTION_TERM, LINEAR_ALIAS_FRACTION, UNEXPLAINED_P,
};
use crate::identification::CsjmDataset;

/// The diagnosis proper: `progress` after each stage and selection step, `cancel` polled in
/// every pass, per scored candidate and per step.
pub(super) fn run_diagnosis(
    data: &CsjmDataset,
    options: &DiagnoseOptions,
    cancel: &Cancel,
    progress: &mut dyn FnMut(Progress),
) -> Result<CsjmDiagnosis, DiagnoseError> {
    options.validate()?;
    let samples = Samples::new(data, options.weight);
    let loaded = samples.len() - 1;
    let (train, test) = split(loaded, options)?;
    let problem =
        CsjmProblem::new(&samples, train, test, cancel.clone()).with_noise_from_baseline()?;
    let q = options.selection.fdr;

    let baseline_fit = fit(&problem, &[Term::Baseline], &())?;
    if baseline_fit.rank < BASELINE_COLUMNS {
        return Err(DiagnoseError::Unexcited {
            rank: baseline_fit.rank,
        });
    }
    progress(Progress {
        stage: "baseline",
        done: 1,
        total: 1,
    });
    cancel.check()?;

    let gravity_note = gravity_note(options, &samples);
    let selection = select_effects(&problem, &baseline_fit, options, progress)?;
    // The model is linear in its parameters: every fit shares the baseline's compressed design.
    let comp = baseline_fit.compressed.clone();
    let scores = candidate_scores(&problem, &comp, &selection, &gravity_note);
    let extended_fit = &selection.last;
    let extended_cov = problem.covariance(extended_fit);
    let baseline_cov = problem.covariance(&baseline_fit);
    let mut findings = findings_of(
        &problem,
        &comp,
        options,
        &selection,
        &extended_cov,
        &gravity_note,
        cancel,
    )?;

    let connection_term = connection::connection_test(&problem, extended_fit, &extended_cov, q);
    if connection_term.p_asymmetry < q {
        findings.push(Finding {
            effect: CONNECTION_TERM,
            joint: None,
            axis: None,
            aliases: Vec::new(),
            evidence: Evidence::Connection(connection_term.clone()),
            detail: NoDetail {},
        });
    }

    let all: Vec<usize> = (1..=loaded).collect();
    let residuals = ResidualReport {
        baseline: structure::residual_structure(&problem, &baseline_fit, &all),
        extended: structure::residual_structure(&problem, extended_fit, &all),
    };
    let unexplained = residuals.extended.p_bonferroni < UNEXPLAINED_P
        || (connection_term.p_asymmetry < q && connection_term.p_theory < UNEXPLAINED_P);

    let baseline = summary(&problem, &baseline_fit, &baseline_cov);
    let extended = summary(&problem, extended_fit, &extended_cov);
    let gain = 1.0 - extended.test_mean_rel_error / baseline.test_mean_rel_error;
    let rows = row_results(&problem, &samples, &baseline_fit, extended_fit, &all);
    progress(Progress {
        stage: "residuals",
        done: 1,
        total: 1,
    });
    Ok(CsjmDiagnosis {
        baseline,
        findings,
        extended,
        unexplained,
        gain,
        connection_term,
        residuals,
        scores,
        rejected_on_holdout: selection
            .rejected_on_holdout
            .iter()
            .map(|t| effect_of(*t).name())
            .collect(),
        rows,
        noise_sigma: problem.sigma().into(),
        n_train: problem.train.len(),
        n_test: problem.test.len(),
        fdr: q,
        split_seed: options.selection.split_seed,
    })
}

/// Why the platform's weight is hard to see: to first order it is absorbed into K_D.
fn gravity_note(options: &DiagnoseOptions, samples: &Samples) -> String {
    let w = options.weight;
    let k_g = w.moment_derivative(&samples.r0);
    let k_g_sym = 0.5 * (k_g + k_g.transpose());
    format!(
        "to first order the omitted weight moment changes linearly with Δζ and is absorbed \
         into K_D (biasing K by the gravity stiffness, ‖sym ∂τ_G/∂ζ‖_F = {:.3} N·m/rad for \
         the assumed weight); only its curvature is testable on these data",
        k_g_sym.norm()
    )
}

/// Forward selection on the shared engine: nested F tests, Benjamini–Hochberg per step,
/// held-out confirmation, aliases.
fn select_effects(
    problem: &CsjmProblem<'_>,
    baseline_fit: &CsjmFit,
    options: &DiagnoseOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Selection<Term, ()>, DiagnoseError> {
    let pool: Vec<Term> = Effect::ALL.iter().map(|e| Term::Effect(*e)).collect();
    let select_opts = SelectOptions {
        fdr: options.selection.fdr,
        max_findings: Effect::ALL.len(),
        alias_cosine: options.selection.alias_cosine,
        alias_alpha: options.selection.alias_alpha,
        defer_cluster_robust: false,
    };
    Ok(select(
        problem,
        baseline_fit.clone(),
        pool,
        &[],
        &select_opts,
        progress,
    )?)
}

/// The first step's score of every effect, with the share of its columns outside K_D's span.
fn candidate_scores(
    problem: &CsjmProblem<'_>,
    comp: &Compressed,
    selection: &Selection<Term, ()>,
    gravity_note: &str,
) -> Vec<CandidateScore> {
    selection
        .first_scores
        .iter()
        .map(|s| {
            let e = effect_of(s.cand);
            let fraction = problem.fraction_outside(comp, &[Term::Baseline], s.cand);
            CandidateScore {
                effect: e.name(),
                n_columns: e.n_columns(),
                fraction_outside_baseline: fraction,
                f_test: s.f_test,
                note: (fraction < LINEAR_ALIAS_FRACTION).then(|| {
                    if e == Effect::PlatformGravity {
                        gravity_note.to_string()
                    } else {
                        "almost collinear with the first-order model on these data".into()
                    }
                }),
            }
        })
        .collect()
}

/// Each selected effect with its aliases, evidence, estimate and interpretation in the
/// extended fit (the selection's last).
fn findings_of(
    problem: &CsjmProblem<'_>,
    comp: &Compressed,
    options: &DiagnoseOptions,
    selection: &Selection<Term, ()>,
    extended_cov: &DMatrix<f64>,
    gravity_note: &str,
    cancel: &Cancel,
) -> Result<Vec<Finding>, DiagnoseError> {
    let extended_fit = &selection.last;
    let mut findings: Vec<Finding> = Vec::new();
    for f in &selection.findings {
        cancel.check()?;
        let effect = effect_of(f.cand);
        let fraction = problem.fraction_outside(comp, &[Term::Baseline], f.cand);
        findings.push(Finding {
            effect: effect.name(),
            joint: None,
            axis: None,
            aliases: aliases_of(
                problem,
                comp,
                options.selection.alias_cosine,
                f,
                fraction,
                gravity_note,
            ),
            evidence: Evidence::Selection(DefectEvidence {
                selection: f.evidence.clone(),
                fraction_outside_baseline: fraction,
                estimate: parameters(extended_fit, extended_cov, Some(f.cand)),
                interpretation: interpretation(problem, extended_fit, extended_cov, effect),
            }),
            detail: NoDetail {},
        });
    }
    Ok(findings)
}

/// Every loaded row with its set, Δζ, Δτ and both models' residuals.
fn row_results(
    problem: &CsjmProblem<'_>,
    samples: &Samples,
    baseline_fit: &CsjmFit,
    extended_fit: &CsjmFit,
    all: &[usize],
) -> Vec<RowResult> {
    let base_res = problem.residuals(baseline_fit, all);
    let ext_res = problem.residuals(extended_fit, all);
    all.iter()
        .enumerate()
        .map(|(r, &k)| RowResult {
            row: samples.file_rows[k],
            set: if problem.test.binary_search(&k).is_ok() {
                "test"
            } else {
                "train"
            },
            dzeta: samples.zeta[k].into(),
            dtau: samples.dtau[k].into(),
            baseline_residual: base_res[r].into(),
            extended_residual: ext_res[r].into(),
        })
        .collect()
}
