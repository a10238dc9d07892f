//! The diagnosis result, serialisable to the JSON of issue 5's output contract
//! (`baseline`, `findings`, `extended`, `unexplained`) plus the material for a report.

use serde::Serialize;

use super::stats::FTest;
use super::structure::ResidualStructure;
use crate::dataset::SetLabel;

/// A fitted model and its errors: the shared summary (model name, e.g. `traditional` or
/// `traditional + joint_tilt(J3x)`; parameter count; mean over held-out and training rows of
/// ‖d_pred − d_meas‖/‖d_meas‖, translation only; parameters with labels and units).
pub type ModelSummary = stiffness_core::engine::schema::ModelSummary;

pub use stiffness_core::engine::schema::{Alias, Parameter, SelectionEvidence};

/// Why a finding was named: the engine's [`SelectionEvidence`] (its fields at the top level of
/// the JSON) and the candidate's estimate.
#[derive(Debug, Clone, Serialize)]
pub struct Evidence {
    /// The statistics the selection decided on (the clusters of the cluster-robust test are
    /// the poses).
    #[serde(flatten)]
    pub selection: SelectionEvidence,
    /// Estimated parameters of the candidate (in the final extended fit).
    pub estimate: Vec<f64>,
    /// Their unit.
    pub unit: &'static str,
}

/// A named effect (`joint_tilt`, `joint_torsion_nonlinear`, `joint_backlash`, `wrench_bias`,
/// `frame_misalignment`, `geometric_nonlinearity`, …; 1-based joint and axis where it has
/// them): the shared finding with the arm's [`Evidence`] and [`GearKnots`].
pub type Finding = stiffness_core::engine::schema::Finding<Evidence, GearKnots>;

/// What an arm's finding adds to the shared one.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GearKnots {
    /// `joint_torsion_nonlinear`: the knots t_k of its hinges, N·m (the gear curve's, with
    /// [`Evidence::estimate`] its coefficients; [`GearFinding::gear_curve`]); null otherwise.
    pub knots: Option<Vec<f64>>,
}

/// A finding read as a gear curve.
pub trait GearFinding {
    /// A `joint_torsion_nonlinear` or `joint_backlash` finding as the gear curve of its joint
    /// ([`GearCurve`](crate::gear::GearCurve)). Torsion: its hinges' knots (N·m) and the
    /// extended fit's coefficients (rad/(N·m), the change of tangent compliance beyond each
    /// knot; the candidate's column `J_jz (h_k(τ₀ + τ) − h_k(τ₀))` times them is the curve's
    /// excess under the load). Backlash: no knots and the extended fit's lost motion b (rad;
    /// the candidate's column `J_jz ½ (s(τ₀ + τ) − sign(τ₀))` times it is the curve's lost
    /// motion under the load). `Ok(None)` for any other effect; an error names the joint when
    /// the estimate is missing or not finite, or a lost motion is negative.
    fn gear_curve(&self) -> Result<Option<crate::gear::GearCurve>, crate::VjmError>;
}

impl GearFinding for Finding {
    fn gear_curve(&self) -> Result<Option<crate::gear::GearCurve>, crate::VjmError> {
        let Some(joint) = self.joint else {
            return Ok(None);
        };
        if self.effect == "joint_backlash" {
            let b = match self.evidence.estimate.as_slice() {
                [b] => *b,
                other => {
                    return Err(crate::VjmError::InvalidModel {
                        message: format!(
                            "the backlash finding of joint {joint} has {} estimates, it needs \
                             one lost motion (rad)",
                            other.len()
                        ),
                    })
                }
            };
            return crate::gear::GearCurve::with_lost_motion(joint - 1, vec![], vec![], b)
                .map(Some);
        }
        let Some(knots) = &self.detail.knots else {
            return Ok(None);
        };
        crate::gear::GearCurve::new(joint - 1, knots.clone(), self.evidence.estimate.clone())
            .map(Some)
    }
}

/// One joint's two curves as one: the knots and coefficients of the one that has them, the
/// lost motion of the one that has it; an error names the joint when both have knots or both
/// have lost motion (one finding per effect and joint).
fn merge_curves(
    a: &crate::gear::GearCurve,
    b: &crate::gear::GearCurve,
) -> Result<crate::gear::GearCurve, crate::VjmError> {
    let both = |what: &str| crate::VjmError::InvalidModel {
        message: format!(
            "joint {} has two findings with {what}: one gear curve cannot hold both",
            a.joint() + 1
        ),
    };
    if !a.knots().is_empty() && !b.knots().is_empty() {
        return Err(both("knots"));
    }
    if a.lost_motion() != 0.0 && b.lost_motion() != 0.0 {
        return Err(both("lost motion"));
    }
    let (shape, lost) = if a.knots().is_empty() { (b, a) } else { (a, b) };
    crate::gear::GearCurve::with_lost_motion(
        a.joint(),
        shape.knots().to_vec(),
        shape.coefficients().to_vec(),
        shape.lost_motion().max(lost.lost_motion()),
    )
}

/// The first-step score of one catalogue candidate against the baseline.
#[derive(Debug, Clone, Serialize)]
pub struct CandidateScore {
    /// Label, e.g. `joint_tilt(J3x)`.
    pub label: String,
    /// Effect name.
    pub effect: &'static str,
    /// 1-based joint or null.
    pub joint: Option<usize>,
    /// `x`, `y` or null.
    pub axis: Option<String>,
    /// False when the candidate's columns lie in the span of the baseline (not testable here).
    pub testable: bool,
    /// The F test (None when not testable).
    pub f_test: Option<FTest>,
}

/// Mean relative error per pose, before and after the extension.
#[derive(Debug, Clone, Serialize)]
pub struct PoseError {
    /// Pose id (the file's `pose` column, or the configuration's order of appearance).
    pub pose: i64,
    /// Whether the pose was used for fitting or held out.
    pub set: SetLabel,
    /// Mean relative error of the baseline over the pose's rows.
    pub baseline: f64,
    /// Mean relative error of the extended model over the pose's rows.
    pub extended: f64,
}

/// Measured and predicted displacements of one row (m, base frame), for residual plots.
#[derive(Debug, Clone, Serialize)]
pub struct RowResult {
    /// Pose id.
    pub pose: i64,
    /// Train or test.
    pub set: SetLabel,
    /// Measured displacement.
    pub measured: [f64; 3],
    /// Baseline prediction.
    pub baseline: [f64; 3],
    /// Extended-model prediction.
    pub extended: [f64; 3],
}

/// Residual structure before and after the extension, on the training rows.
pub type ResidualReport = stiffness_core::engine::schema::ResidualReport<ResidualStructure>;

/// The full result of [`diagnose`](super::diagnose).
#[derive(Debug, Clone, Serialize)]
pub struct Diagnosis {
    /// The baseline model.
    pub baseline: ModelSummary,
    /// Named effects, in the order they were accepted.
    pub findings: Vec<Finding>,
    /// The baseline extended by the findings, refitted.
    pub extended: ModelSummary,
    /// True when structure remains that no catalogue effect explains: the extended model's
    /// lack-of-fit test (no noise level needed) or, when the noise level was given, its
    /// goodness-of-fit test rejects; see [`Verdict`].
    pub unexplained: bool,
    /// The tests behind `unexplained`, and what remains in words.
    pub verdict: Verdict,
    /// Relative reduction of the held-out error, 1 − extended/baseline.
    pub gain: f64,
    /// Residual statistics.
    pub residuals: ResidualReport,
    /// First-step scores of the whole catalogue.
    pub scores: Vec<CandidateScore>,
    /// Candidates significant on the training rows but not confirmed on the held-out rows.
    pub rejected_on_holdout: Vec<String>,
    /// Mount compliances and link translations significant against the model but not against
    /// every joint spring: a few springs missing from the model mimic them.
    pub explained_by_springs: Vec<String>,
    /// Per-pose errors.
    pub per_pose: Vec<PoseError>,
    /// Per-row measured and predicted displacements.
    pub rows: Vec<RowResult>,
    /// Training and held-out row counts.
    pub n_train: usize,
    /// Held-out rows.
    pub n_test: usize,
    /// False discovery rate used.
    pub fdr: f64,
}

/// The tests behind [`Diagnosis::unexplained`].
#[derive(Debug, Clone, Serialize)]
pub struct Verdict {
    /// F test of the extended model against the flexible alternative (the extended model
    /// plus every spring and every block of [`Alternative`](super::candidates::Alternative)),
    /// with the alternative's residual variance as denominator: it needs no noise level.
    pub lack_of_fit: FTest,
    /// χ² test of the extended model's whitened SSE, only when the noise level was given.
    pub goodness_of_fit: Option<stiffness_core::engine::ChiSquareTest>,
    /// The level the verdict's tests were decided at.
    pub alpha: f64,
    /// Each block of the alternative tested alone against the extended model.
    pub blocks: Vec<BlockTest>,
    /// What remains, in words (`None` when nothing does).
    pub remaining: Option<String>,
}

/// One block of the lack-of-fit alternative tested against the extended model.
#[derive(Debug, Clone, Serialize)]
pub struct BlockTest {
    /// Block name, e.g. `linear_in_wrench`.
    pub block: String,
    /// Its nested F test.
    pub f_test: FTest,
    /// The same nested test's p-value from a wild cluster bootstrap, the clusters the
    /// measurements (beyond 256 rows, runs of consecutive rows;
    /// `stiffness_core::engine::wild_cluster`), where it is computed: the `angle_compliance`
    /// block, which decides on it when the noise level is not given (the F distribution then
    /// does not hold). `None` (null) for the other blocks and when the noise level is given.
    pub wild_cluster_p_value: Option<f64>,
    /// What structure in this block means.
    pub meaning: String,
}

impl Diagnosis {
    /// The gear curves of the findings ([`GearFinding::gear_curve`]), one per joint in the order
    /// its first finding was found: a joint's `joint_torsion_nonlinear` and `joint_backlash`
    /// findings are one curve (the torsion's knots and coefficients with the backlash's lost
    /// motion).
    pub fn gear_curves(&self) -> Result<Vec<crate::gear::GearCurve>, crate::VjmError> {
        let mut out: Vec<crate::gear::GearCurve> = Vec::new();
        for f in &self.findings {
            let Some(curve) = f.gear_curve()? else {
                continue;
            };
            match out.iter_mut().find(|c| c.joint() == curve.joint()) {
                None => out.push(curve),
                Some(have) => *have = merge_curves(have, &curve)?,
            }
        }
        Ok(out)
    }

    /// The result as pretty JSON.
    pub fn to_json(&self) -> String {
        // Serialising plain structs of numbers and strings cannot fail; non-finite floats
        // become null.
        serde_json::to_string_pretty(self).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
    }
}
