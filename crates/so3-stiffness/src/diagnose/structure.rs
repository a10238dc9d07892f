//! What the residuals of a fit say: their structure against load magnitude, load direction
//! and loading/unloading, each with a p-value.
//!
//! Residual components are divided by their component's noise level σ̂_i first (so that the
//! noisier y channel of the F/T sensor does not look like structure).

use nalgebra::Vector3;
use serde::Serialize;

use super::problem::{CsjmFit, CsjmProblem};
use super::stats::{one_way_anova, spearman, Anova, Correlation};

/// Loading versus unloading along one axis: the mean scaled residual of that component for
/// rows whose recorded load rose along the axis minus rows whose load fell.
#[derive(Debug, Clone, Serialize)]
pub struct LoadingUnloading {
    /// Axis (`x`, `y`, `z`).
    pub axis: &'static str,
    /// Mean scaled residual (loading) − mean (unloading), in noise standard deviations.
    pub mean_difference: f64,
    /// Two-group ANOVA (equivalent to the pooled t test); None if a group is empty.
    pub test: Option<Anova>,
}

/// All residual-structure statistics of one fit on one set of rows.
#[derive(Debug, Clone, Serialize)]
pub struct ResidualStructure {
    /// Rows used (the reference excluded).
    pub n_rows: usize,
    /// RMS of the scaled residual components (≈ 1 when only noise remains).
    pub scaled_rms: f64,
    /// Spearman correlation of the scaled residual norm with the load increment ‖Δτ‖.
    pub load_magnitude: Option<Correlation>,
    /// ANOVA of the scaled residual norm grouped by the dominant axis and sign of Δτ
    /// (6 groups: ±x, ±y, ±z).
    pub load_direction: Option<Anova>,
    /// Loading versus unloading, per axis.
    pub loading_unloading: Vec<LoadingUnloading>,
    /// Smallest p-value of the 5 tests above × 5 (Bonferroni), capped at 1.
    pub p_bonferroni: f64,
}

pub(crate) fn residual_structure(
    problem: &CsjmProblem<'_>,
    fit: &CsjmFit,
    rows: &[usize],
) -> ResidualStructure {
    let rows: Vec<usize> = rows.iter().copied().filter(|&k| k != 0).collect();
    let samples = problem.samples;
    let scaled: Vec<Vector3<f64>> = problem
        .residuals(fit, &rows)
        .iter()
        .map(|r| r.component_mul(&problem.weights))
        .collect();
    let norms: Vec<f64> = scaled.iter().map(|r| r.norm()).collect();
    let n = rows.len();
    let scaled_rms = if n == 0 {
        f64::NAN
    } else {
        (scaled.iter().map(|r| r.norm_squared()).sum::<f64>() / (3 * n) as f64).sqrt()
    };
    let magnitudes: Vec<f64> = rows.iter().map(|&k| samples.dtau[k].norm()).collect();
    let load_magnitude = spearman(&magnitudes, &norms);
    let groups: Vec<usize> = rows
        .iter()
        .map(|&k| {
            let d = samples.dtau[k];
            let axis = d.iamax();
            2 * axis + usize::from(d[axis] < 0.0)
        })
        .collect();
    let load_direction = one_way_anova(&norms, &groups);
    const AXES: [&str; 3] = ["x", "y", "z"];
    let mut loading_unloading = Vec::with_capacity(3);
    for (j, axis) in AXES.iter().enumerate() {
        let mut values = Vec::new();
        let mut group = Vec::new();
        for (r, &k) in scaled.iter().zip(&rows) {
            let s = samples.signs[k][j];
            if s != 0.0 {
                values.push(r[j]);
                group.push(usize::from(s > 0.0));
            }
        }
        let mean = |g: usize| {
            let v: Vec<f64> = values
                .iter()
                .zip(&group)
                .filter(|(_, gg)| **gg == g)
                .map(|(v, _)| *v)
                .collect();
            if v.is_empty() {
                f64::NAN
            } else {
                v.iter().sum::<f64>() / v.len() as f64
            }
        };
        loading_unloading.push(LoadingUnloading {
            axis,
            mean_difference: mean(1) - mean(0),
            test: one_way_anova(&values, &group),
        });
    }
    let p_values = [
        load_magnitude.map(|c| c.p_value),
        load_direction.map(|a| a.p_value),
    ]
    .into_iter()
    .chain(loading_unloading.iter().map(|l| l.test.map(|a| a.p_value)))
    .flatten()
    .filter(|p| p.is_finite());
    let p_bonferroni = p_values.fold(1.0f64, |m, p| m.min(5.0 * p)).min(1.0);
    ResidualStructure {
        n_rows: n,
        scaled_rms,
        load_magnitude,
        load_direction,
        loading_unloading,
        p_bonferroni,
    }
}
