//! Instrument noise models of a stiffness campaign: a laser tracker's displacement noise and a
//! force/torque sensor's wrench noise, with the defaults of a typical campaign (a tracker 2.5 m
//! from the robot with a maximum permissible error of 15 µm + 6 µm/m, a 1 %-of-full-scale F/T
//! sensor of 100 N and 10 N·m). Planning ([`design`](fn@crate::design)) assumes them, the virtual testbed
//! draws its noise from them.

use serde::Serialize;

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
