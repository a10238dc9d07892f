//! Virtual joint method (VJM) stiffness models of serial robots.
//!
//! - [`SerialChain`]: an immutable chain extracted from a URDF between a base and a tip
//!   link (fixed joints folded in), or the bundled Franka Emika Panda ([`SerialChain::bundled`]).
//! - [`VirtualJointModel`]: which virtual springs (torsion `z`, tilts `x`, `y`) sit at which joint.
//! - [`jacobian`], [`complementary_stiffness`]: the 6×m virtual-joint Jacobian (rows
//!   `[linear; angular]`, base frame, at the tip point) and K_C = (∂Jᵀ/∂θ)F, with
//!   `_in_place` variants over a reusable [`Workspace`].
//! - [`identify`]: rank-revealing weighted least squares of the compliances from N
//!   measurements, streaming over threads (TSQR); [`identify_dense`] the dense reference.
//! - [`predict_deflection`], [`select_configurations`], [`dexterity`]; planning
//!   ([`design`](fn@design)) with the default [`instruments`].
//! - [`StiffnessModel`]: an identification saved as a versioned, hashed model file, and its
//!   predictions with standard deviations ([`stiffness_model`]).
//! - [`compensate`]: corrected joint targets so that the loaded tip reaches the nominal pose
//!   under a [`Load`] (wrenches or a payload).
//!
//! Conventions (frames, units, parameter order) are in `docs/conventions.md`; the method
//! and its deviations from the seed paper in `docs/vjm.md`.
//!
//! ```
//! use vjm::{identify, IdentifyOptions, SerialChain, VirtualJointModel, predict_deflection};
//! let panda = SerialChain::bundled();
//! let model = VirtualJointModel::traditional(7);
//! let truth = [2e-6, 3e-6, 4e-6, 5e-6, 6e-6, 7e-6, 8e-6];
//! let (mut q, mut f, mut d) = (vec![], vec![], vec![]);
//! for i in 0..20 {
//!     let qi: Vec<f64> = (0..7).map(|j| 0.3 * ((i * 7 + j) as f64).sin() - if j == 3 { 1.5 } else { 0.0 }).collect();
//!     let fi = [10.0 * (i as f64).cos(), 5.0, -20.0, 1.0, 0.5 * (i as f64).sin(), 2.0];
//!     let di = predict_deflection(&panda, &model, &truth, &qi, &fi, false).unwrap();
//!     q.extend(qi);
//!     f.extend(fi);
//!     d.extend(&di[..3]);
//! }
//! let id = identify(&panda, &model, vjm::Measurements::new(&q, &f, &d), &IdentifyOptions::default()).unwrap();
//! // The tip lies on joint 7's axis: its torsion cannot move the tip point.
//! assert_eq!(id.rank, 6);
//! assert_eq!(id.compliance[6], None);
//! assert!((id.compliance[0].unwrap() - 2e-6).abs() < 1e-15);
//! ```
#![deny(missing_docs)]

pub mod bounded;
mod chain;
mod compensate;
mod contraction;
pub mod dataset;
pub mod design;
pub mod diagnose;
mod error;
pub mod gear;
pub mod gravity;
mod hashing;
mod identify;
mod identify_partial;
pub mod instruments;
mod kinematics;
mod lanes;
pub mod lsq;
mod measurements;
mod model;
mod model_spec;
pub use model_spec::spring_label;
mod predict;
mod regressor;
pub mod screening;
pub mod stiffness_model;
pub use stiffness_core::stats;
#[cfg(feature = "testbed")]
pub mod testbed;

pub use chain::{
    ActuatedJoint, JointSpec, SerialChain, UrdfSource, BUNDLED_BASE, BUNDLED_FLANGE, BUNDLED_TCP,
    BUNDLED_URDF, BUNDLED_URDF_PATH,
};
pub use compensate::{
    compensate, compensate_in_place, compensate_with_gears, CompensateOptions, CompensatedRow,
    Compensation, CompensationBuffers, CompensationStatus, CompensationTargets,
    CompensationWorkspace,
};
pub use design::plan::{
    design, design_monitored, pose_compliance_wrenches, predicted_stderr, NoiseModel, Plan,
    PlanSpec, PlannedCombination,
};
pub use design::{dexterity, select_configurations, Selection};
pub use error::VjmError;
pub use hashing::{inertials_sha256, kinematics_sha256, sha256_hex, sha256_hex_reader};
pub use identify::{
    accumulate, build_design, identify, identify_checking_rows, identify_dense,
    identify_from_factor, Combination, CombinationTerm, Identification, IdentifyOptions,
    ParameterEstimate, RowCheck, SolveMethod, GRAVITY_TOLERANCE, MAX_GRAVITY_REFITS,
    NORMAL_EQUATIONS_MAX_CONDITION, NORMAL_EQUATIONS_RANK_RTOL, NORMAL_EQUATIONS_ROUNDING_FLOOR,
};
pub use identify_partial::IdentificationPartial;
pub use kinematics::{
    complementary_stiffness, complementary_stiffness_in_place, forward_kinematics_deflected,
    inverse_condition, jacobian, jacobian_batch_in_place, jacobian_batch_with_layout,
    jacobian_deflected, jacobian_in_place, JacobianLayout, Workspace,
};
pub use measurements::Measurements;
pub use model::{spring_axes, Spring, SpringAxis, SpringKind, VirtualJointModel, NOMINAL_TORSION};
pub use predict::{predict_deflection, spring_deflection};
pub use regressor::{regressor_rows, Measured};
pub use stiffness_model::{DataSource, Load, ModelError, PointMass, Prediction, StiffnessModel};
