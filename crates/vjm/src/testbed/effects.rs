//! The physics of the testbed's effects as pure functions of one spring or one measurement.
//!
//! Each function is the defining curve of its effect; the tests compare them with the curves
//! written independently (segment by segment) and with their limiting cases.

use serde::Serialize;

pub use crate::instruments::{ForceSensorNoise, TrackerNoise};

/// A harmonic-drive style torsional spring: piecewise-linear torque → deflection curve with
/// three stiffness segments `k1` (|τ| ≤ `t1`), `k2` (`t1` < |τ| ≤ `t2`), `k3` (|τ| > `t2`),
/// odd in τ. Stiffnesses in N·m/rad, torques in N·m. Harmonic drives stiffen with load
/// (k1 < k2 < k3), which is what the catalogue column of `joint_torsion_nonlinear` looks for, but
/// any positive values are accepted.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HarmonicDriveSpring {
    /// Stiffness of the first segment, N·m/rad.
    pub k1: f64,
    /// Stiffness of the second segment, N·m/rad.
    pub k2: f64,
    /// Stiffness of the third segment, N·m/rad.
    pub k3: f64,
    /// End of the first segment, N·m (> 0).
    pub t1: f64,
    /// End of the second segment, N·m (> `t1`).
    pub t2: f64,
}

impl HarmonicDriveSpring {
    /// Deflection (rad) under torque `tau` (N·m):
    /// `θ = τ/k1` for |τ| ≤ t1, `t1/k1 + (|τ|−t1)/k2` up to t2, then `… + (|τ|−t2)/k3`, with
    /// the sign of τ.
    pub fn deflection(&self, tau: f64) -> f64 {
        let a = tau.abs();
        let mag = if a <= self.t1 {
            a / self.k1
        } else if a <= self.t2 {
            self.t1 / self.k1 + (a - self.t1) / self.k2
        } else {
            self.t1 / self.k1 + (self.t2 - self.t1) / self.k2 + (a - self.t2) / self.k3
        };
        mag.copysign(tau)
    }

    /// Tangent compliance dθ/dτ (rad/(N·m)) at torque `tau`.
    pub fn tangent_compliance(&self, tau: f64) -> f64 {
        let a = tau.abs();
        if a <= self.t1 {
            1.0 / self.k1
        } else if a <= self.t2 {
            1.0 / self.k2
        } else {
            1.0 / self.k3
        }
    }

    /// A spring whose first segment has compliance `c1` (rad/(N·m)) and which stiffens by
    /// `ratio` per segment: k2 = ratio·k1, k3 = ratio²·k1, split at `t1` and `t2` (N·m).
    pub fn stiffening(c1: f64, ratio: f64, t1: f64, t2: f64) -> Self {
        let k1 = 1.0 / c1;
        HarmonicDriveSpring {
            k1,
            k2: k1 * ratio,
            k3: k1 * ratio * ratio,
            t1,
            t2,
        }
    }
}

/// Lost motion of a joint with backlash `b` (rad, the full width of the dead band) under torque
/// `tau`: the unloaded reference sits in the middle of the band, so the loaded joint moves
/// `½·b·sign(τ)` on top of its elastic deflection; zero torque does not move it.
pub fn backlash_deflection(tau: f64, b: f64) -> f64 {
    if tau == 0.0 {
        0.0
    } else {
        0.5 * b * tau.signum()
    }
}

/// A vector rotated by the rotation vector `phi` (rad), Rodrigues' formula: `exp(hat(φ))·v`.
pub fn rotate(phi: [f64; 3], v: [f64; 3]) -> [f64; 3] {
    let th = (phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]).sqrt();
    if th < 1e-300 {
        return v;
    }
    let k = [phi[0] / th, phi[1] / th, phi[2] / th];
    let kxv = cross(k, v);
    let kdv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
    let (s, c) = th.sin_cos();
    [
        v[0] * c + kxv[0] * s + k[0] * kdv * (1.0 - c),
        v[1] * c + kxv[1] * s + k[1] * kdv * (1.0 - c),
        v[2] * c + kxv[2] * s + k[2] * kdv * (1.0 - c),
    ]
}

/// Cross product a × b.
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
