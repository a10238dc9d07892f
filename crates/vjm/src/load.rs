//! The load a task puts on the tip: a wrench given in the base frame, or a payload whose
//! weight acts at its centre of mass (which turns with the tip).

use nalgebra::{Matrix3, Vector3};

use crate::chain::check_finite;
use crate::error::VjmError;

/// Standard gravity, m/s² (the payload's weight is `mass · STANDARD_GRAVITY` along −z of the
/// base frame).
pub const STANDARD_GRAVITY: f64 = 9.80665;

/// The expected load at the tip point.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Load {
    /// A wrench `[fx, fy, fz, mx, my, mz]` (N, N·m), base-frame components, at the tip point;
    /// constant in the base frame whatever the configuration.
    Wrench([f64; 6]),
    /// A payload of `mass` (kg) whose centre of mass sits at `com` (m) in the tip frame, with
    /// gravity along −z of the base frame: force `(0, 0, −m g)`, moment `(R_tip com) × force`
    /// about the tip point. The moment depends on the tip orientation.
    Payload {
        /// Mass, kg (finite, ≥ 0).
        mass: f64,
        /// Centre of mass in the tip frame, m.
        com: [f64; 3],
    },
}

impl Load {
    /// Checks the load for finite values (and a non-negative mass); `row` is reported.
    pub fn check(&self, row: usize) -> Result<(), VjmError> {
        match self {
            Load::Wrench(w) => check_finite("wrench", w, row, 0),
            Load::Payload { mass, com } => {
                check_finite("payload mass", &[*mass], row, 0)?;
                check_finite("payload centre of mass", com, row, 0)?;
                if *mass < 0.0 {
                    return Err(VjmError::InvalidOption {
                        name: "payload",
                        message: format!("row {row}: the mass must be ≥ 0 kg, got {mass}"),
                    });
                }
                Ok(())
            }
        }
    }

    /// Whether the base-frame wrench depends on the tip orientation (a payload with its
    /// centre of mass off the tip point).
    pub fn depends_on_orientation(&self) -> bool {
        matches!(self, Load::Payload { mass, com } if *mass != 0.0 && com.iter().any(|c| *c != 0.0))
    }

    /// The wrench (base frame, at the tip point) when the tip frame has rotation
    /// `tip_rotation` (base ← tip).
    pub fn wrench(&self, tip_rotation: &Matrix3<f64>) -> [f64; 6] {
        match *self {
            Load::Wrench(w) => w,
            Load::Payload { mass, com } => {
                let f = Vector3::new(0.0, 0.0, -mass * STANDARD_GRAVITY);
                let m = (tip_rotation * Vector3::from(com)).cross(&f);
                [f.x, f.y, f.z, m.x, m.y, m.z]
            }
        }
    }
}
