//! Cable-driven spherical joint module (CSJM): geometry, kinetostatics, a conservative
//! simulator and the stiffness model on SO(3) (seed paper 000, section II).
//!
//! Frames (see `docs/conventions.md`): B is the base, A the moving platform, both with origin
//! at the joint centre O; the pose is `R = ᴮ_A R`; displacements are body-frame,
//! `R = R₀·exp(hat Δζ)`; τ is the external moment on the platform about O in A (N·m);
//! `K = ∂τ/∂ζ` (covariant), N·m/rad.
//!
//! Stable entry points used by the identification module:
//! [`CsjmGeometry::prototype`], [`CsjmSimulator::equilibrium`] (pose under an external moment,
//! with optional [`PointLoad::prototype_gravity`]), [`stiffness_at`] / [`CsjmSimulator::stiffness`].
//!
//! ```
//! use nalgebra::{Rotation3, Vector3};
//! use so3_stiffness::csjm::{CsjmGeometry, CsjmSimulator, EquilibriumOptions, PointLoad};
//! let sim = CsjmSimulator::with_pretension(CsjmGeometry::prototype(), [4000.0; 6], [60.0; 6], &Rotation3::identity())
//!     .unwrap()
//!     .with_load(PointLoad::prototype_gravity());
//! let eq = sim.equilibrium(&Vector3::new(-0.06, -3.08, 1.07), &EquilibriumOptions::default()).unwrap();
//! let k = eq.stiffness.covariant; // N·m/rad, frame A, symmetric
//! assert!((k - k.transpose()).norm() <= 1e-9 * k.norm());
//! ```

mod geometry;
mod kinetostatics;
mod loads;
mod simulator;
mod stiffness;

pub use geometry::{CsjmGeometry, PrototypeDimensions, CABLES};
pub use kinetostatics::{cable_lengths, jacobian, CableKinematics};
pub use loads::{PointLoad, PROTOTYPE_CENTRE_OF_MASS_IN_A, PROTOTYPE_PLATFORM_WEIGHT};
pub use simulator::{Cable, CsjmSimulator, Equilibrium, EquilibriumOptions};
pub use stiffness::{levi_civita_term, stiffness_at, Stiffness};
