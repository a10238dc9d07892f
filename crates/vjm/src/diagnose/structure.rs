//! What the residuals of a fit say: their structure against configuration (per-pose ANOVA), joint
//! torque, load magnitude and load direction, each with a p-value.
//!
//! Residual components are divided by their per-row, per-axis noise standard deviation first,
//! so that heteroscedastic noise (load-dependent force-sensor noise, tracker distance) does not
//! look like structure.

use serde::Serialize;

use super::candidates::RowKinematics;
use super::stats::{one_way_anova, spearman, Anova, Correlation};

/// Per-pose one-way ANOVA of the scaled residuals, one per axis, and their Bonferroni-combined
/// p-value.
#[derive(Debug, Clone, Serialize)]
pub struct PoseAnova {
    /// ANOVA of the x, y, z components (None when not computable).
    pub axes: [Option<Anova>; 3],
    /// min over axes of p × 3, capped at 1.
    pub p_value: f64,
}

/// Correlation of the residual with one joint's torque.
#[derive(Debug, Clone, Serialize)]
pub struct TorqueCorrelation {
    /// 1-based joint.
    pub joint: usize,
    /// Spearman correlation between the scaled residual projected on the joint's torsion
    /// direction `J_t[:, jz]/‖J_t[:, jz]‖` and the joint torque τ_jz.
    pub correlation: Option<Correlation>,
}

/// Structure of the residual against load direction: the largest |Spearman ρ| between a scaled
/// residual component and a component of the unit force direction (9 pairs).
#[derive(Debug, Clone, Serialize)]
pub struct DirectionCorrelation {
    /// Residual axis (`x`, `y`, `z`).
    pub residual_axis: &'static str,
    /// Force direction axis (`x`, `y`, `z`).
    pub force_axis: &'static str,
    /// The correlation.
    pub correlation: Correlation,
    /// Its p-value × 9, capped at 1.
    pub p_bonferroni: f64,
}

/// All residual-structure statistics of one fit on one set of rows.
#[derive(Debug, Clone, Serialize)]
pub struct ResidualStructure {
    /// Rows used.
    pub n_rows: usize,
    /// RMS of the scaled residual components (≈ 1 when only noise remains and the noise model
    /// is right).
    pub scaled_rms: f64,
    /// Per-pose ANOVA.
    pub per_pose_anova: PoseAnova,
    /// Per-joint torque correlations.
    pub torque: Vec<TorqueCorrelation>,
    /// Spearman correlation of the scaled residual norm with the force magnitude.
    pub load_magnitude: Option<Correlation>,
    /// Strongest residual/force-direction correlation.
    pub load_direction: Option<DirectionCorrelation>,
}

const AXES: [&str; 3] = ["x", "y", "z"];

/// Computes the residual structure over `rows` (indices into `kin`), with residuals `res[i]`
/// (m, base frame) and per-axis noise standard deviations `sigma[i]` (m).
pub fn residual_structure(
    kin: &[RowKinematics],
    rows: &[usize],
    res: &[[f64; 3]],
    sigma: &[[f64; 3]],
    groups: &[usize],
) -> ResidualStructure {
    let scaled: Vec<[f64; 3]> = rows
        .iter()
        .map(|&i| {
            [
                res[i][0] / sigma[i][0],
                res[i][1] / sigma[i][1],
                res[i][2] / sigma[i][2],
            ]
        })
        .collect();
    let g: Vec<usize> = rows.iter().map(|&i| groups[i]).collect();
    let n_rows = rows.len();
    let scaled_rms = (scaled
        .iter()
        .map(|v| v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
        .sum::<f64>()
        / (3.0 * n_rows.max(1) as f64))
        .sqrt();
    let axes: [Option<Anova>; 3] = std::array::from_fn(|k| {
        let v: Vec<f64> = scaled.iter().map(|s| s[k]).collect();
        one_way_anova(&v, &g)
    });
    let p_value = axes.iter().flatten().map(|a| a.p_value).fold(1.0, f64::min);
    let p_value = (3.0 * p_value).min(1.0);
    let n_joints = kin.first().map_or(0, |r| r.tau.len() / 3);
    let torque = (0..n_joints)
        .map(|j| {
            let mut proj = Vec::with_capacity(n_rows);
            let mut tau = Vec::with_capacity(n_rows);
            for (k, &i) in rows.iter().enumerate() {
                let jac = &kin[i].jacobian;
                let a = [jac[(0, 3 * j)], jac[(1, 3 * j)], jac[(2, 3 * j)]];
                let na = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
                let p = if na > 0.0 {
                    (scaled[k][0] * a[0] + scaled[k][1] * a[1] + scaled[k][2] * a[2]) / na
                } else {
                    0.0
                };
                proj.push(p);
                tau.push(kin[i].tau[3 * j]);
            }
            TorqueCorrelation {
                joint: j + 1,
                correlation: spearman(&proj, &tau),
            }
        })
        .collect();
    let fmag: Vec<f64> = rows
        .iter()
        .map(|&i| {
            let w = kin[i].wrench;
            (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt()
        })
        .collect();
    let rnorm: Vec<f64> = scaled
        .iter()
        .map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt())
        .collect();
    let load_magnitude = spearman(&rnorm, &fmag);
    let mut load_direction: Option<DirectionCorrelation> = None;
    for (ra, ra_name) in AXES.iter().enumerate() {
        for (fa, fa_name) in AXES.iter().enumerate() {
            let dir: Vec<f64> = rows
                .iter()
                .zip(&fmag)
                .map(|(&i, &m)| if m > 0.0 { kin[i].wrench[fa] / m } else { 0.0 })
                .collect();
            let r: Vec<f64> = scaled.iter().map(|s| s[ra]).collect();
            if let Some(c) = spearman(&r, &dir) {
                let better = load_direction
                    .as_ref()
                    .is_none_or(|b| c.rho.abs() > b.correlation.rho.abs());
                if better {
                    load_direction = Some(DirectionCorrelation {
                        residual_axis: ra_name,
                        force_axis: fa_name,
                        correlation: c,
                        p_bonferroni: (c.p_value * 9.0).min(1.0),
                    });
                }
            }
        }
    }
    ResidualStructure {
        n_rows,
        scaled_rms,
        per_pose_anova: PoseAnova { axes, p_value },
        torque,
        load_magnitude,
        load_direction,
    }
}
