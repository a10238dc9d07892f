//! The parts of a diagnosis' output that every model writes the same way: a fitted
//! [`Parameter`], an [`Alias`] of a finding, and the [`SelectionEvidence`] that made a candidate
//! a finding. The model crates' reports (`vjm::diagnose::Diagnosis`,
//! `so3_stiffness::diagnose::CsjmDiagnosis`) are built from these, so both serialise them to the
//! same JSON, and the Python results (`robot_stiffness.results`) read them with one class each.
//!
//! Non-finite numbers serialise as JSON `null`; an optional field a model does not have is left
//! out of the JSON rather than written as `null` (a VJM parameter has no standard error in the
//! diagnosis, a VJM alias no note).

use serde::Serialize;

use crate::stats::FTest;

/// One fitted parameter.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Parameter {
    /// Label, e.g. `J3z`, `wrench_bias.fx`, `K_D[0][1]`, `platform_gravity.alpha`.
    pub label: String,
    /// Estimate; `None` (JSON null) when the parameter does not enter these data at all (its
    /// column is zero up to rounding, e.g. a torsion about an axis through the tip point).
    pub value: Option<f64>,
    /// Standard error where the model reports one (CSJM; NaN, JSON null, when not estimable);
    /// `None`: not reported, and absent from the JSON.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stderr: Option<f64>,
    /// Unit (SI).
    pub unit: &'static str,
}

/// A candidate (or a part of the model itself) that cannot be told apart from a finding on
/// these data.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Alias {
    /// Effect name; for the CSJM also `linear_stiffness`, the baseline's K_D.
    pub effect: &'static str,
    /// 1-based joint (base → tip) or null.
    pub joint: Option<usize>,
    /// `x`, `y` (a joint alias of both tilts: `x+y`) or null.
    pub axis: Option<String>,
    /// |cosine| between the two candidates' columns after projecting out the model
    /// (single-column candidates only).
    pub cosine: Option<f64>,
    /// (SSE with the alias − SSE with the finding) / σ̂², in units of noise variance; NaN
    /// (JSON null) for an alias found by span rather than scored against the finding.
    pub delta_chi2: f64,
    /// p-value of the finding's F test once the alias is in the model (0 when not computed
    /// because the alias is not significant itself; NaN/null when not a scored candidate).
    pub p_finding_given_alias: f64,
    /// Why they are aliases, where the model says it (CSJM); absent from the JSON otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

impl Alias {
    /// An alias found by span rather than by scoring: no Δχ², no F test (both NaN), a note
    /// saying why.
    pub fn not_a_candidate(effect: &'static str, note: String) -> Self {
        Alias {
            effect,
            joint: None,
            axis: None,
            cosine: None,
            delta_chi2: f64::NAN,
            p_finding_given_alias: f64::NAN,
            note: Some(note),
        }
    }
}

/// The statistics that made a candidate a finding, as [`select`](super::select::select) decided on
/// them (training rows whitened by the model's noise model; held-out rows for the
/// confirmation).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SelectionEvidence {
    /// Selection step (1 = first finding).
    pub step: usize,
    /// Nested-model F test of adding the candidate to the model of that step.
    pub f_test: FTest,
    /// Testable candidates at that step (the Benjamini–Hochberg family size).
    pub n_candidates: usize,
    /// The Benjamini–Hochberg threshold the p-value had to beat: q · rank / m.
    pub bh_threshold: f64,
    /// 1 − SSE_full/SSE_reduced on the training rows: the fraction of the whitened SSE the
    /// candidate removed.
    pub sse_reduction: f64,
    /// Cluster-robust (CR1 sandwich) Wald test of the candidate's parameters in the model of
    /// that step, the clusters the model's (a pose, a sample): valid without independence
    /// within a cluster (reported, not used to select).
    pub cluster_robust: Option<FTest>,
    /// Whitened SSE on the held-out rows before adding the candidate.
    pub heldout_sse_before: f64,
    /// Whitened SSE on the held-out rows after adding it (lower: confirmed).
    pub heldout_sse_after: f64,
}

/// No detail beyond the shared fields (a model's [`ModelSummary`] or [`Finding`] that adds
/// nothing); serialises to no JSON keys.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct NoDetail {}

/// A fitted model and its errors; `D`: what the model adds (its fields at the top level of
/// the JSON, after the shared ones), e.g. the CSJM's rank and 3×3 stiffness matrices.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelSummary<D = NoDetail> {
    /// Model name, e.g. `traditional + joint_tilt(J3x)` or `first_order_K_D + cable_hysteresis`.
    pub model: String,
    /// Number of parameters (columns of the design; the rank may be lower).
    pub n_params: usize,
    /// Mean over the held-out rows of the model's relative error (each model's measure: VJM
    /// ‖d_pred − d_meas‖/‖d_meas‖ of the translation, CSJM the same of Δζ).
    pub test_mean_rel_error: f64,
    /// The same over the training rows.
    pub train_mean_rel_error: f64,
    /// Fitted parameters, in model order, with labels and units.
    pub parameters: Vec<Parameter>,
    /// The model's own fields.
    #[serde(flatten)]
    pub detail: D,
}

/// The residuals' structure before and after the extension; `S`: the model's own statistics
/// of it (the arm's per-pose ANOVA and correlations, the CSJM's loading/unloading split).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResidualReport<S> {
    /// The baseline model's residuals.
    pub baseline: S,
    /// The extended model's residuals.
    pub extended: S,
}

/// A named effect: which one, where, what it cannot be told from, and why it was named; `E`:
/// the model's evidence (embedding [`SelectionEvidence`] for a selected candidate), `D`: what
/// the model adds (its fields at the top level of the JSON, after the shared ones).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Finding<E, D = NoDetail> {
    /// Effect name (the model's catalogue).
    pub effect: &'static str,
    /// 1-based joint (base → tip) or null (an effect of no joint, and every CSJM effect).
    pub joint: Option<usize>,
    /// `x` or `y` (tilts), a link translation's axis, or null.
    pub axis: Option<String>,
    /// Candidates indistinguishable from this one on these data.
    pub aliases: Vec<Alias>,
    /// The statistics behind the finding.
    pub evidence: E,
    /// The model's own fields.
    #[serde(flatten)]
    pub detail: D,
}

/// An option of a diagnosis outside its range: which one, its value, the range it needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OptionOutOfRange {
    /// The option's name, e.g. `fdr`.
    pub option: &'static str,
    /// Its value.
    pub value: f64,
    /// The range it needs, e.g. `in (0, 1)`.
    pub requirement: &'static str,
}

/// The options every model's diagnosis shares: the statistical selection and the hold-out
/// split. Each model's `DiagnoseOptions` holds one (`selection`) next to its own options.
///
/// ```
/// use stiffness_core::engine::schema::SelectionOptions;
/// let mut opts = SelectionOptions::default();
/// assert_eq!((opts.fdr, opts.test_fraction, opts.split_seed), (0.01, 0.25, 0));
/// opts.fdr = 1.5;
/// assert_eq!(opts.check().unwrap_err().option, "fdr");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[non_exhaustive]
pub struct SelectionOptions {
    /// False discovery rate q of the Benjamini–Hochberg selection, in (0, 1) (default 0.01);
    /// also the level of the verdict's tests.
    pub fdr: f64,
    /// Fraction of the poses (rows, for a joint module) held out when the data have no split
    /// of their own, in (0, 1) (default 0.25).
    pub test_fraction: f64,
    /// Seed of the hold-out split: the same seed gives the same split (default
    /// [`DEFAULT_SPLIT_SEED`](super::DEFAULT_SPLIT_SEED), 0, for every model).
    pub split_seed: u64,
    /// |cos| at or above which two one-column candidates are aliases, in (0, 1] (default 0.99).
    pub alias_cosine: f64,
    /// A significant candidate b is an alias of a finding a when, with b in the model, the F
    /// test of a has p above this level, in (0, 1) (default 0.05): the data cannot tell a
    /// from b.
    pub alias_alpha: f64,
}

impl Default for SelectionOptions {
    fn default() -> Self {
        SelectionOptions {
            fdr: 0.01,
            test_fraction: 0.25,
            split_seed: super::DEFAULT_SPLIT_SEED,
            alias_cosine: 0.99,
            alias_alpha: 0.05,
        }
    }
}

impl SelectionOptions {
    /// The first option outside its range (NaN fails every check): `fdr`, `test_fraction`
    /// and `alias_alpha` in (0, 1), `alias_cosine` in (0, 1].
    pub fn check(&self) -> Result<(), OptionOutOfRange> {
        let open = |x: f64| x > 0.0 && x < 1.0;
        for (option, value, ok, requirement) in [
            ("fdr", self.fdr, open(self.fdr), "in (0, 1)"),
            (
                "test_fraction",
                self.test_fraction,
                open(self.test_fraction),
                "in (0, 1)",
            ),
            (
                "alias_cosine",
                self.alias_cosine,
                self.alias_cosine > 0.0 && self.alias_cosine <= 1.0,
                "in (0, 1]",
            ),
            (
                "alias_alpha",
                self.alias_alpha,
                open(self.alias_alpha),
                "in (0, 1)",
            ),
        ] {
            if !ok {
                return Err(OptionOutOfRange {
                    option,
                    value,
                    requirement,
                });
            }
        }
        Ok(())
    }
}
