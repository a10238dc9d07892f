//! The diagnosis result, serialisable to the JSON of issue 5's output contract
//! (`baseline`, `findings`, `extended`, `unexplained`) plus the material for a report.

use serde::Serialize;

use super::connection::ConnectionTest;
use super::stats::FTest;
use super::structure::ResidualStructure;

/// A fitted model and its errors.
#[derive(Debug, Clone, Serialize)]
pub struct ModelSummary {
    /// Model name, e.g. `first_order_K_D` or `first_order_K_D + cable_hysteresis`.
    pub model: String,
    /// Number of parameters (columns; the rank may be lower, see `rank`).
    pub n_params: usize,
    /// Rank of the training design.
    pub rank: usize,
    /// Mean over held-out rows of ‖Δζ_pred − Δζ_meas‖/‖Δζ_meas‖, Δζ_pred solved from the
    /// recorded Δτ with the model.
    pub test_mean_rel_error: f64,
    /// The same over the training rows (the reference excluded).
    pub train_mean_rel_error: f64,
    /// The model's K_D (N·m/rad, frame A at R₀, row-major).
    pub k_d: [[f64; 3]; 3],
    /// The covariant K = K_D − ½hat(τ₀) (N·m/rad, row-major; symmetric for a conservative
    /// joint).
    pub k: [[f64; 3]; 3],
    /// Fitted parameters, in model order.
    pub parameters: Vec<Parameter>,
}

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

/// A named effect.
#[derive(Debug, Clone, Serialize)]
pub struct Finding {
    /// `platform_gravity`, `cable_hysteresis`, `cable_nonlinearity` or `connection_term`.
    pub effect: &'static str,
    /// Always null for the CSJM.
    pub joint: Option<usize>,
    /// Always null for the CSJM.
    pub axis: Option<String>,
    /// Candidates indistinguishable from this one on these data.
    pub aliases: Vec<Alias>,
    /// The statistics behind the finding.
    pub evidence: Evidence,
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
#[derive(Debug, Clone, Serialize)]
pub struct ResidualReport {
    /// Baseline residuals.
    pub baseline: ResidualStructure,
    /// Extended-model residuals.
    pub extended: ResidualStructure,
}

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
