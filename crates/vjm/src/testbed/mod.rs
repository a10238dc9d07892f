//! The virtual testbed: measurement campaigns simulated from a true robot that carries any of
//! the effects the diagnosis looks for, with laser-tracker and force-sensor noise.
//!
//! - [`TrueModel`]: linear virtual springs (3 per joint) plus [`Effect`]s: tilting compliance,
//!   harmonic-drive torsion, backlash, wrench bias, frame misalignment, geometric
//!   non-linearity (K_C); and effects no candidate explains ([`outside`]): pose drift, a
//!   compliant mount, a tool compliant along its axis.
//! - [`simulate`]: seeded poses within the joint limits and away from singularities, several
//!   wrenches per pose, the true response, instrument noise; returns a [`Campaign`] whose
//!   [`Dataset`](crate::dataset::Dataset) can be written as the measurement file. Weightless by
//!   default; with [`CampaignSpec::gravity`] the arm is measured under its own weight
//!   (see [`TrueModel::displacement_under_gravity`]).
//! - [`paper_study`]: the seed paper's Table I study on the bundled arm.
//!
//! Magnitudes and the noise model are stated in `docs/diagnose.md`.

mod campaign;
pub mod effects;
pub mod kinematics;
pub mod outside;
mod paper_study;
mod truth;

pub use campaign::{
    inverse_condition, simulate, simulate_at, simulate_at_monitored, simulate_monitored,
    simulate_planned_monitored, Campaign, CampaignSpec, CHECK_EVERY_ROWS,
};
pub use effects::{ForceSensorNoise, HarmonicDriveSpring, TrackerNoise};
pub use paper_study::{
    magnitude_error, paper_link_compliances, paper_link_share, paper_structural_link_share,
    paper_structural_truth, paper_study, paper_tilt_ratio, paper_torsion_share, paper_truth,
    vector_error, ClippedAngle, ErrorSummary, ModelErrors, PaperFigures, PaperStudy, PaperStudyRow,
    StructuralTruth, PAPER_FIGURES, PAPER_TABLE_I_DEG, PAPER_TORSION_SHARE, PAPER_WRENCHES,
};
pub use truth::{Effect, RestUnderGravity, TrueModel, MAX_GRAVITY_ITERATIONS, NOMINAL_TORSION};

use crate::dataset::DatasetError;

/// Errors of the testbed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TestbedError {
    /// The true model's compliance vector does not match the chain.
    #[error("the true model has {compliances} spring compliances, the chain needs {expected} (3 per joint)")]
    TruthSize {
        /// Compliances given.
        compliances: usize,
        /// 3 × joints.
        expected: usize,
    },
    /// The true model is inconsistent.
    #[error("invalid true model: {message}")]
    InvalidTruth {
        /// What is wrong.
        message: String,
    },
    /// The campaign specification is inconsistent.
    #[error("invalid campaign spec ({field}): {message}")]
    InvalidSpec {
        /// The field(s) at fault.
        field: &'static str,
        /// What is wrong.
        message: String,
    },
    /// No pose satisfying the limits, the height and the conditioning constraint was found.
    #[error("no acceptable pose found after {attempts} draws (relax min_inverse_condition, min_tip_height or limit_margin)")]
    NoPose {
        /// Draws made.
        attempts: usize,
    },
    /// Building the dataset failed (e.g. a displacement larger than plausible).
    #[error("simulated data rejected: {0}")]
    Dataset(DatasetError),
    /// The campaign cannot be simulated under gravity: the chain has no masses (the message
    /// names the link without `<inertial>`), or an equilibrium under the arm's weight did not
    /// settle (the message names the row and the configuration).
    #[error("cannot simulate under gravity: {message}")]
    Gravity {
        /// What is wrong.
        message: String,
    },
    /// The simulation was cancelled through its token.
    #[error("simulation cancelled")]
    Cancelled(#[from] stiffness_core::Cancelled),
    /// Fitting in the seed study failed.
    #[error("seed study fit failed: {message}")]
    Fit {
        /// What failed.
        message: String,
    },
}
