//! The catalogue of CSJM effects and the regression columns each one adds to the linear model
//! `Δτ_k = c + K_D Δζ_k + e_k` (Δτ, c in N·m and Δζ in rad, components in frame A at R₀).
//!
//! A column is a 3-vector per sample: its contribution to the three moment components.

use nalgebra::{Rotation3, Vector3};
use serde::Serialize;

use crate::csjm::PointLoad;
use crate::identification::load::gravity_moment;
use crate::identification::CsjmDataset;
use crate::so3;

/// An effect the diagnosis can add to the baseline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Effect {
    /// Platform weight left out of the recorded moments: one column
    /// `−(τ_G(R_k) − τ_G(R₀))` (the prototype's G and ᴬr_G) scaled by a free α (α = 1: the
    /// whole prototype weight is missing).
    PlatformGravity,
    /// Friction hysteresis: offsets `H s_k`, `s_k,j = sign` of the recorded load change along
    /// axis j since the previous row (9 columns, N·m).
    CableHysteresis,
    /// Curvature of τ(Δζ): `½ Δζᵀ H_i Δζ` per component (18 columns, N·m/rad²).
    CableNonlinearity,
}

impl Effect {
    /// All effects, in catalogue order.
    pub const ALL: [Effect; 3] = [
        Effect::PlatformGravity,
        Effect::CableHysteresis,
        Effect::CableNonlinearity,
    ];

    /// The name used in the JSON output.
    pub fn name(self) -> &'static str {
        match self {
            Effect::PlatformGravity => "platform_gravity",
            Effect::CableHysteresis => "cable_hysteresis",
            Effect::CableNonlinearity => "cable_nonlinearity",
        }
    }

    /// Number of regression columns.
    pub fn n_columns(self) -> usize {
        match self {
            Effect::PlatformGravity => 1,
            Effect::CableHysteresis => 9,
            Effect::CableNonlinearity => 18,
        }
    }

    /// Unit of the effect's parameters.
    pub fn unit(self) -> &'static str {
        match self {
            Effect::PlatformGravity => "1 (fraction of the prototype weight moment)",
            Effect::CableHysteresis => "N·m",
            Effect::CableNonlinearity => "N·m/rad²",
        }
    }
}

/// Number of baseline columns: offset c and K_D, per moment component.
pub const BASELINE_COLUMNS: usize = 12;

/// The per-sample quantities every column is built from.
///
/// Sample 0 is the reference (Δζ = 0, Δτ = 0); sample k ≥ 1 is the k-th loaded row in file
/// (measurement) order.
#[derive(Debug, Clone)]
pub(crate) struct Samples {
    /// Measured reference pose R₀.
    pub r0: Rotation3<f64>,
    /// Recorded reference moment τ_ref, N·m, frame A.
    pub tau_ref: Vector3<f64>,
    /// Δζ_k = log(R₀ᵀR_k), rad.
    pub zeta: Vec<Vector3<f64>>,
    /// Δτ_k = τ_k − τ_ref, N·m.
    pub dtau: Vec<Vector3<f64>>,
    /// Sign of the recorded load change since the previous row, per axis (the reference:
    /// the sign of τ_ref, reached by loading from zero).
    pub signs: Vec<Vector3<f64>>,
    /// 1-based data rows of the file (0 for the reference and programmatic data).
    pub file_rows: Vec<usize>,
    /// The weight whose omission the gravity candidate tests.
    pub weight: PointLoad,
}

fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

impl Samples {
    pub fn new(data: &CsjmDataset, weight: PointLoad) -> Self {
        let (dz, dt) = data.increments();
        let reference = data.reference();
        let mut zeta = vec![Vector3::zeros()];
        zeta.extend(dz);
        let mut dtau = vec![Vector3::zeros()];
        dtau.extend(dt);
        let mut signs = vec![reference.moment.map(sign)];
        let mut previous = reference.moment;
        for m in data.measurements() {
            signs.push((m.moment - previous).map(sign));
            previous = m.moment;
        }
        let mut file_rows = vec![reference.row];
        file_rows.extend(data.measurements().iter().map(|m| m.row));
        Samples {
            r0: reference.orientation,
            tau_ref: reference.moment,
            zeta,
            dtau,
            signs,
            file_rows,
            weight,
        }
    }

    pub fn len(&self) -> usize {
        self.zeta.len()
    }

    /// Gravity moment of the weight at R₀·exp(ζ), N·m, frame A.
    pub fn gravity_at(&self, zeta: &Vector3<f64>) -> Vector3<f64> {
        let pose = self.r0 * so3::exp(zeta);
        gravity_moment(&pose, &self.weight.force_in_b(), &self.weight.point_in_a())
    }
}

/// Columns of one term at a sample with displacement `zeta` and load-change signs `signs`,
/// appended to `out`.
pub(crate) fn push_columns(
    term: Term,
    samples: &Samples,
    zeta: &Vector3<f64>,
    signs: &Vector3<f64>,
    out: &mut Vec<Vector3<f64>>,
) {
    let unit = |i: usize, v: f64| {
        let mut c = Vector3::zeros();
        c[i] = v;
        c
    };
    match term {
        Term::Baseline => {
            for i in 0..3 {
                out.push(unit(i, 1.0));
                for j in 0..3 {
                    out.push(unit(i, zeta[j]));
                }
            }
        }
        Term::Effect(Effect::PlatformGravity) => {
            out.push(-(samples.gravity_at(zeta) - samples.gravity_at(&Vector3::zeros())));
        }
        Term::Effect(Effect::CableHysteresis) => {
            for i in 0..3 {
                for j in 0..3 {
                    out.push(unit(i, signs[j]));
                }
            }
        }
        Term::Effect(Effect::CableNonlinearity) => {
            let z = zeta;
            let monomials = [
                0.5 * z.x * z.x,
                0.5 * z.y * z.y,
                0.5 * z.z * z.z,
                z.x * z.y,
                z.x * z.z,
                z.y * z.z,
            ];
            for i in 0..3 {
                for m in monomials {
                    out.push(unit(i, m));
                }
            }
        }
    }
}

/// A block of columns in a model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Term {
    /// Offset c and K_D.
    Baseline,
    /// A catalogue effect.
    Effect(Effect),
}

impl Term {
    pub fn n_columns(self) -> usize {
        match self {
            Term::Baseline => BASELINE_COLUMNS,
            Term::Effect(e) => e.n_columns(),
        }
    }
}

/// Parameter labels of a term, in column order.
pub(crate) fn labels(term: Term) -> Vec<(String, &'static str)> {
    const AXES: [&str; 3] = ["x", "y", "z"];
    let mut out = Vec::new();
    match term {
        Term::Baseline => {
            for (i, axis) in AXES.iter().enumerate() {
                out.push((format!("offset.{axis}"), "N·m"));
                for j in 0..3 {
                    out.push((format!("K_D[{i}][{j}]"), "N·m/rad"));
                }
            }
        }
        Term::Effect(Effect::PlatformGravity) => {
            out.push(("platform_gravity.alpha".into(), "1"));
        }
        Term::Effect(Effect::CableHysteresis) => {
            for a in AXES {
                for b in AXES {
                    out.push((format!("cable_hysteresis.tau_{a}_per_sign_{b}"), "N·m"));
                }
            }
        }
        Term::Effect(Effect::CableNonlinearity) => {
            const M: [&str; 6] = ["xx", "yy", "zz", "xy", "xz", "yz"];
            for a in AXES {
                for m in M {
                    out.push((format!("cable_nonlinearity.H_{a}[{m}]"), "N·m/rad²"));
                }
            }
        }
    }
    out
}
