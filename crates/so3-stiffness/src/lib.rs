//! SO(3) Lie-group toolkit and the stiffness model of a cable-driven spherical joint module
//! (CSJM).
//!
//! - [`so3`]: `exp`, `log` (robust at θ = 0 and θ = π), `hat`, `vee`, `adjoint`, left/right
//!   Jacobians and their inverses, bracket, geodesic distance, and explicit checks/projections
//!   for measured rotation matrices.
//! - [`csjm`]: cable geometry (the seed prototype included), kinetostatics, a conservative
//!   simulator with an equilibrium solver on SO(3), and the analytic stiffness — the
//!   Levi-Civita (covariant, symmetric) model and the Euclidean one it corrects.
//! - [`identification`]: stiffness identification from measured poses and loads.
//! - [`diagnose`]: what the first-order model gets wrong, the cause, the gain (the shared
//!   engine of `stiffness_core::engine`).
//! - `testbed` (feature `testbed`, off by default): the virtual campaigns with hidden effects
//!   that the diagnosis is tested on (outside the model code: the diagnosis never imports it).
//!
//! Units are SI (m, rad, N, N·m). Frames: B base, A platform, common origin at the joint centre;
//! poses `R = ᴮ_A R`; displacements in the body frame, `R = R₀·exp(hat Δζ)`; τ is the external
//! moment on the platform in A; `K = ∂τ/∂ζ` (N·m/rad). See `docs/conventions.md`,
//! `docs/so3-stiffness.md` and `docs/seed-000-deviations.md`.
//!
//! ```
//! use nalgebra::{Rotation3, Vector3};
//! use so3_stiffness::csjm::{CsjmGeometry, CsjmSimulator, EquilibriumOptions, PointLoad};
//!
//! // The seed prototype, 80 N per cable at the home pose, 5 kN/m cables, with its weight.
//! let sim = CsjmSimulator::with_pretension(CsjmGeometry::prototype(), [5000.0; 6], [80.0; 6], &Rotation3::identity())?
//!     .with_load(PointLoad::prototype_gravity());
//! // Pose under an external moment (N·m, frame A), and the stiffness there.
//! let eq = sim.equilibrium(&Vector3::new(0.0, -3.0, 1.0), &EquilibriumOptions::default())?;
//! let k = eq.stiffness.covariant; // symmetric, N·m/rad
//! let k_euclidean = eq.stiffness.euclidean; // differs by ½ hat(τ)
//! assert!((k - k.transpose()).norm() < 1e-12 * k.norm());
//! assert!((k_euclidean - k_euclidean.transpose()).norm() > 1.0);
//! # Ok::<(), so3_stiffness::CsjmError>(())
//! ```
#![deny(missing_docs)]
// `!(x > 0.0)` is used on purpose throughout: unlike `x <= 0.0` it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod csjm;
pub mod diagnose;
pub mod error;
pub mod identification;
#[cfg(feature = "testbed")]
pub mod testbed;
pub use stiffness_core::so3;
pub use stiffness_core::stats;

pub use csjm::{CsjmGeometry, CsjmSimulator, Stiffness};
pub use error::CsjmError;
pub use stiffness_core::So3Error;
