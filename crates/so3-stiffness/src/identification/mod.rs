//! Stiffness identification of a CSJM from measured poses and loads, and verification of the
//! identified stiffness (seed 000, sections III–IV).
//!
//! Pipeline:
//! 1. [`pose`]: tracker points → base frame (eqs. 51–53), platform orientation ᴮ_A R,
//!    displacement Δζ = log(R₀ᵀR);
//! 2. [`load`]: F/T wrench → moment about O in frame A (eq. 55) plus platform weight (eq. 56);
//! 3. [`dataset`]: the measurement file (one row per equilibrium, strictly validated);
//! 4. [`fit`]: K_D ≈ ΨΩ⁺ (eq. 49) with a rank-revealing SVD, first or second order, then
//!    K = K_D + K_L with the corrected connection term K_L = −½hat(τ₀);
//! 5. [`mod@verify`]: R_est = R₀exp(hat(K⁻¹Δτ)) and E_θ (eqs. 61–65);
//! 6. [`campaign`]: the seed experiment on the conservative simulator, with stated noise models.
//!
//! Frames and units follow `docs/conventions.md`: τ is the external moment on the platform
//! about O with components in A (N·m); Δζ is a body-frame rotation vector (rad); K is in
//! N·m/rad.

pub mod campaign;
pub mod dataset;
pub mod error;
pub mod fit;
pub mod load;
pub mod pose;
pub mod verify;

pub use dataset::{CsjmDataset, CsjmMeasurement, ReadOptions, RotationPolicy};
pub use error::IdentificationError;
pub use fit::{
    identify, identify_increments, ConnectionTerm, DetPoint, FitOptions, FitOrder,
    StiffnessEstimate,
};
pub use verify::{estimation_error, predict_displacement, predict_pose, verify, VerificationCase};
