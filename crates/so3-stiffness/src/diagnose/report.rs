//! The diagnosis result, serialisable to the JSON of issue 5's output contract
//! (`baseline`, `findings`, `extended`, `unexplained`) plus the material for a report.

use serde::Serialize;

use super::connection::ConnectionTest;
use super::stats::FTest;
use super::structure::ResidualStructure;

/// A fitted model and its errors: the shared summary (model name, parameter count, mean
/// relative errors of Δζ on held-out and training rows, parameters with standard errors) and
/// the CSJM's [`CsjmModelDetail`].
pub type ModelSummary = stiffness_core::engine::schema::ModelSummary<CsjmModelDetail>;

/// What a CSJM model summary adds to the shared one.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CsjmModelDetail {
    /// Rank of the training design (≤ `n_params`).
    pub rank: usize,
    /// The model's K_D (N·m/rad, frame A at R₀, row-major).
    pub k_d: [[f64; 3]; 3],
    /// The covariant K = K_D − ½hat(τ₀) (N·m/rad, row-major; symmetric for a conservative
    /// joint).
    pub k: [[f64; 3]; 3],
}

/// A named effect (`platform_gravity`, `cable_hysteresis`, `cable_nonlinearity` or
/// `connection_term`; joint and axis always null): the shared finding with the CSJM's
/// [`Evidence`].
pub type Finding = stiffness_core::engine::schema::Finding<Evidence>;

pub use stiffness_core::engine::schema::{Alias, Parameter, SelectionEvidence};

/// Why a defect effect was named: the engine's [`SelectionEvidence`] (its fields at the top
/// level of the JSON; the clusters of the cluster-robust test are the samples, whose three
/// components need not be independent) and what the estimate says.
#[derive(Debug, Clone, Serialize)]
pub struct DefectEvidence {
    /// The statistics the selection decided on.
    #[serde(flatten)]
    pub selection: SelectionEvidence,
    /// Fraction of the effect's column energy outside the span of the first-order model
    /// (near 0: aliased with the linear stiffness).
    pub fraction_outside_baseline: f64,
    /// Estimated parameters (in the final extended fit), with standard errors.
    pub estimate: Vec<Parameter>,
    /// What the estimate means physically.
    pub interpretation: String,
}

/// The statistics behind a finding.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum Evidence {
    /// A defect effect selected by the F tests.
    Selection(DefectEvidence),
    /// The connection term.
    Connection(ConnectionTest),
}

/// The first-step score of one catalogue effect against the baseline.
#[derive(Debug, Clone, Serialize)]
pub struct CandidateScore {
    /// Effect name.
    pub effect: &'static str,
    /// Number of columns.
    pub n_columns: usize,
    /// Fraction of its column energy outside the span of the first-order model.
    pub fraction_outside_baseline: f64,
    /// The F test against the baseline (training rows).
    pub f_test: FTest,
    /// Remark (e.g. aliasing with the linear stiffness).
    pub note: Option<String>,
}

/// Residual structure before and after the extension (all loaded rows).
pub type ResidualReport = stiffness_core::engine::schema::ResidualReport<ResidualStructure>;

/// Measured and predicted quantities of one row, for residual plots.
#[derive(Debug, Clone, Serialize)]
pub struct RowResult {
    /// 1-based data row of the file (0 for programmatic data).
    pub row: usize,
    /// `train` or `test`.
    pub set: &'static str,
    /// Measured Δζ, rad.
    pub dzeta: [f64; 3],
    /// Recorded Δτ, N·m.
    pub dtau: [f64; 3],
    /// Baseline moment residual Δτ − Δτ_pred, N·m.
    pub baseline_residual: [f64; 3],
    /// Extended-model moment residual, N·m.
    pub extended_residual: [f64; 3],
}

/// The full result of [`diagnose`](super::diagnose).
#[derive(Debug, Clone, Serialize)]
pub struct CsjmDiagnosis {
    /// The baseline: the first-order fit Δτ = c + K_D Δζ.
    pub baseline: ModelSummary,
    /// Named effects: defects in the order accepted, then `connection_term` if K_D is
    /// measurably asymmetric.
    pub findings: Vec<Finding>,
    /// The baseline extended by the defect findings, refitted on the training rows.
    pub extended: ModelSummary,
    /// True when structure remains that no candidate explains: the extended model's
    /// residual-structure tests (Bonferroni p < 0.01) or an asymmetry of K_D that is not the
    /// connection term (p < 0.01).
    pub unexplained: bool,
    /// Relative reduction of the held-out error, 1 − extended/baseline.
    pub gain: f64,
    /// The connection-term test on the extended model.
    pub connection_term: ConnectionTest,
    /// Residual statistics.
    pub residuals: ResidualReport,
    /// First-step scores of the whole catalogue.
    pub scores: Vec<CandidateScore>,
    /// Effects significant on the training rows but not confirmed on the held-out rows.
    pub rejected_on_holdout: Vec<&'static str>,
    /// Per-row data and residuals.
    pub rows: Vec<RowResult>,
    /// Noise level per moment component estimated from the baseline, N·m.
    pub noise_sigma: [f64; 3],
    /// Training rows (the reference included).
    pub n_train: usize,
    /// Held-out rows.
    pub n_test: usize,
    /// False discovery rate used.
    pub fdr: f64,
    /// Seed of the train/test split.
    pub split_seed: u64,
}

impl CsjmDiagnosis {
    /// The result as pretty JSON (non-finite numbers become `null`).
    pub fn to_json(&self) -> String {
        // Plain structs of numbers and strings cannot fail to serialise.
        serde_json::to_string_pretty(self).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
    }

    /// Names of the defect findings (the connection term excluded).
    pub fn defect_effects(&self) -> Vec<&'static str> {
        self.findings
            .iter()
            .filter(|f| f.effect != super::CONNECTION_TERM)
            .map(|f| f.effect)
            .collect()
    }

    /// Whether `effect` is a finding or an alias of one.
    pub fn names(&self, effect: &str) -> bool {
        self.findings
            .iter()
            .any(|f| f.effect == effect || f.aliases.iter().any(|a| a.effect == effect))
    }
}
