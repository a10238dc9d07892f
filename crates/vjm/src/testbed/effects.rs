//! The physics of the testbed's effects as pure functions of one spring or one measurement.
//!
//! Each function is the defining curve of its effect; the tests compare them with the curves
//! written independently (segment by segment) and with their limiting cases.

use serde::Serialize;

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

/// Laser tracker noise model: a maximum permissible error `±(a + b·L)` with `a` = 15 µm,
/// `b` = 6 µm/m and L the tracker–target distance, read as a 2σ bound per axis. A displacement
/// is the difference of two independent readings (loaded − unloaded), so its per-axis standard
/// deviation is `√2 · (a + b·L)/2`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrackerNoise {
    /// Constant part of the maximum permissible error, m.
    pub mpe_const: f64,
    /// Distance-proportional part, m per m.
    pub mpe_per_m: f64,
    /// Tracker position in the base frame, m.
    pub position: [f64; 3],
}

impl Default for TrackerNoise {
    fn default() -> Self {
        TrackerNoise {
            mpe_const: 15e-6,
            mpe_per_m: 6e-6,
            // 2.5 m in front of the robot, at about its shoulder height.
            position: [2.5, 0.0, 0.5],
        }
    }
}

impl TrackerNoise {
    /// A tracker whose displacement noise is plain isotropic Gaussian with per-axis standard
    /// deviation `sigma` (m) everywhere: no distance term (`mpe_per_m = 0`) and the constant
    /// part set so that `displacement_sigma` returns `sigma` (to rounding; `mpe_const = √2·σ`).
    /// Used by studies that sweep the instrument noise; the default stays the MPE model.
    pub fn isotropic(sigma: f64) -> Self {
        TrackerNoise {
            mpe_const: std::f64::consts::SQRT_2 * sigma,
            mpe_per_m: 0.0,
            ..Default::default()
        }
    }

    /// Per-axis standard deviation (m) of a displacement measured at tip point `p` (base frame).
    pub fn displacement_sigma(&self, p: [f64; 3]) -> f64 {
        let l = ((p[0] - self.position[0]).powi(2)
            + (p[1] - self.position[1]).powi(2)
            + (p[2] - self.position[2]).powi(2))
        .sqrt();
        std::f64::consts::SQRT_2 * 0.5 * (self.mpe_const + self.mpe_per_m * l)
    }
}

/// Six-axis force/torque sensor noise: accuracy `relative_accuracy` of full scale per axis, read
/// as a 2σ bound, independent between axes and readings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ForceSensorNoise {
    /// Full scale of the force axes, N.
    pub force_full_scale: f64,
    /// Full scale of the moment axes, N·m.
    pub moment_full_scale: f64,
    /// Accuracy as a fraction of full scale (0.01 = 1 %).
    pub relative_accuracy: f64,
}

impl Default for ForceSensorNoise {
    fn default() -> Self {
        ForceSensorNoise {
            force_full_scale: 100.0,
            moment_full_scale: 10.0,
            relative_accuracy: 0.01,
        }
    }
}

impl ForceSensorNoise {
    /// Per-axis standard deviations `[σ_fx, σ_fy, σ_fz, σ_mx, σ_my, σ_mz]` (N, N·m).
    pub fn sigma(&self) -> [f64; 6] {
        let f = 0.5 * self.relative_accuracy * self.force_full_scale;
        let m = 0.5 * self.relative_accuracy * self.moment_full_scale;
        [f, f, f, m, m, m]
    }
}
