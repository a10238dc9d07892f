//! Warnings about measurements that pass every check of [`crate::dataset`] but look wrong,
//! and about an identification whose result says so (issue 21): a row whose load or
//! displacement is orders of magnitude above the campaign's, compliances beyond any arm's
//! (a wrench in kN, a displacement in mm), compliances that are negative beyond doubt.
//!
//! These are warnings, not errors: each has a legitimate reading the tool cannot rule out. The
//! thresholds were chosen against the project's own simulated campaigns (four arms, 200 seeds,
//! traditional and extended models: no warning on any of them; docs/vjm.md "Warnings").
//!
//! ```
//! use vjm::screening::outlier_rows;
//! // 60 N on every row but the third, 5e4 N (a cell in the wrong unit, or a typo).
//! let mut wrench = vec![0.0; 6 * 8];
//! let displacement = vec![1e-4; 3 * 8];
//! for i in 0..8 {
//!     wrench[6 * i] = if i == 2 { 5e4 } else { 60.0 };
//! }
//! let found = outlier_rows(&wrench, &displacement);
//! assert_eq!(found.len(), 1);
//! assert!(found[0].to_string().contains("line 4"));
//! ```

use std::fmt;

use serde::Serialize;

use crate::Identification;

/// A row is an outlier when its load (or displacement) norm exceeds this many times the
/// median over the rows with a non-zero one. Clean simulated campaigns reach 2.1 (loads) and
/// 9.4 (displacements); a value in the wrong unit is 10³ off.
pub const OUTLIER_FACTOR: f64 = 100.0;
/// Length (m) that puts a moment on the scale of a force in a row's load norm
/// √(|f|² + (|m|/L)²): 3 N·m weigh as 30 N, so that pure-moment rows are not outliers among
/// pure-force rows.
pub const LOAD_LENGTH: f64 = 0.1;
/// Fewest rows with a non-zero load (displacement) for the median to be a scale.
pub const MIN_ROWS_FOR_OUTLIERS: usize = 3;
/// Largest plausible joint compliance, rad/(N·m) (a stiffness of 100 N·m/rad: 3 N·m turn a
/// joint by 1.7°). Arms are 1e-6..1e-3 (the simulated ones 1e-4..5e-4); a wrench in kN or a
/// displacement in mm gives 10³ times the true value.
pub const MAX_PLAUSIBLE_COMPLIANCE: f64 = 1e-2;

/// Whether an estimate `value` ± `stderr` (rad/(N·m)) is **weak**: its standard error exceeds
/// its magnitude (the data cannot tell it from 0) or [`MAX_PLAUSIBLE_COMPLIANCE`] (nor from
/// any plausible compliance). `identify` flags such parameters and combinations; `predict` and
/// `compensate` use what the data determine ([`crate::StiffnessModel::determined_compliance`]).
/// Without a standard error nothing is weak.
///
/// ```
/// use vjm::screening::is_weak;
/// assert!(!is_weak(1.5e-4, Some(2e-6)));
/// assert!(is_weak(-4.0e-2, Some(9.7e-2)));   // the data cannot tell it from 0
/// assert!(is_weak(2.9e-1, Some(1.5e-1)));    // ±0.15 rad/(N·m): no arm's compliance
/// assert!(!is_weak(1.0, None));
/// ```
pub fn is_weak(value: f64, stderr: Option<f64>) -> bool {
    stderr.is_some_and(|s| s > value.abs() || s > MAX_PLAUSIBLE_COMPLIANCE)
}
/// A compliance identifiable on its own is reported negative when it is below −this many
/// standard errors (clean simulated campaigns reach −4.3 on tilts whose true value is 0).
pub const NEGATIVE_SIGNIFICANCE: f64 = 5.0;
/// A negative compliance is reported only below −this × the largest |compliance| identifiable
/// alone as well (noise-free data give rounding, −1e-17 ± 1e-19).
pub const NEGATIVE_RELATIVE: f64 = 1e-3;
/// The compliance-scale warning reads the best-determined estimate; it needs at least this
/// many standard errors (below, the whole fit is noise and says nothing about units).
pub const SCALE_MIN_SIGNIFICANCE: f64 = 3.0;
/// Rows named in a message (the count is always given).
const ROWS_SHOWN: usize = 5;

/// What a row outlier is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Quantity {
    /// The wrench `fx..mz`, as √(|f|² + (|m|/L)²) with L = [`LOAD_LENGTH`].
    Load,
    /// The displacement `dx,dy,dz`.
    Displacement,
}

/// One warning; its `Display` is the message shown to the user.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
#[non_exhaustive]
pub enum DataWarning {
    /// Rows whose load or displacement is more than [`OUTLIER_FACTOR`] × the median.
    Outliers {
        /// Load or displacement.
        quantity: Quantity,
        /// 0-based rows (line = row + 2), ascending.
        rows: Vec<usize>,
        /// The largest norm among them (N or m).
        largest: f64,
        /// The median norm of the rows with a non-zero one (N or m).
        median: f64,
    },
    /// The best-determined compliance (largest |value| / standard error, at least
    /// [`SCALE_MIN_SIGNIFICANCE`]) is beyond any arm's ([`MAX_PLAUSIBLE_COMPLIANCE`]).
    ComplianceScale {
        /// The parameter or combination.
        label: String,
        /// Its estimate (for a combination: |value| / Σ|coefficient|, a lower bound of its
        /// largest compliance), rad/(N·m).
        value: f64,
        /// The median force norm of the loaded rows, N (a hint: kN data give ≲ 0.1).
        median_force: f64,
    },
    /// Compliances identifiable on their own that are negative beyond doubt
    /// ([`NEGATIVE_SIGNIFICANCE`]), or negative at all when outlier rows were found: a spring
    /// cannot have a negative stiffness.
    NegativeCompliance {
        /// `(label, compliance, standard error)` per parameter.
        parameters: Vec<(String, f64, f64)>,
        /// Whether outlier rows were found (then every negative one is listed).
        after_outliers: bool,
    },
}

fn line_list(rows: &[usize]) -> String {
    let shown: Vec<String> = rows
        .iter()
        .take(ROWS_SHOWN)
        .map(|r| (r + 2).to_string())
        .collect();
    let more = if rows.len() > ROWS_SHOWN { ", …" } else { "" };
    format!("{}{more}", shown.join(", "))
}

impl fmt::Display for DataWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DataWarning::Outliers {
                quantity,
                rows,
                largest,
                median,
            } => {
                let (what, unit, cells) = match quantity {
                    Quantity::Load => ("load", "N", "fx..mz"),
                    Quantity::Displacement => ("displacement", "m", "dx,dy,dz"),
                };
                let s = if rows.len() == 1 { "" } else { "s" };
                write!(
                    f,
                    "{n} row{s} at line{s} {lines} (row + 2, as in a measurement file) {have} a \
                     {what} more than \
                     {OUTLIER_FACTOR} times the median row's (largest {largest:.3e} {unit}, \
                     median {median:.3e} {unit}): a cell in another unit or a typo? Check \
                     {cells} there; such a row dominates the fit (it can turn compliances \
                     negative)",
                    n = rows.len(),
                    lines = line_list(rows),
                    have = if rows.len() == 1 { "has" } else { "have" },
                )
            }
            DataWarning::ComplianceScale {
                label,
                value,
                median_force,
            } => write!(
                f,
                "the identified compliance {label} = {value:.3e} rad/(N·m) is beyond any arm's \
                 (at most {MAX_PLAUSIBLE_COMPLIANCE} rad/(N·m)): are the wrenches in kN (median \
                 force {median_force:.3e} N) or the displacements in mm? Expected N, N·m and m"
            ),
            DataWarning::NegativeCompliance {
                parameters,
                after_outliers,
            } => {
                let list: Vec<String> = parameters
                    .iter()
                    .map(|(l, c, s)| format!("{l} = {c:.3e} ± {s:.1e}"))
                    .collect();
                let why = if *after_outliers {
                    "with the outlier rows above in the fit".to_string()
                } else {
                    format!("more than {NEGATIVE_SIGNIFICANCE} standard errors below 0")
                };
                write!(
                    f,
                    "negative identified compliance{s} {} rad/(N·m) ({why}): a spring cannot \
                     have a negative stiffness; look for outlier rows or a wrong sign or frame \
                     of the wrench, or constrain with nonnegative=True (--nonnegative)",
                    list.join(", "),
                    s = if parameters.len() == 1 { "" } else { "s" },
                )
            }
        }
    }
}

/// The median of the strictly positive values, `None` with fewer than
/// [`MIN_ROWS_FOR_OUTLIERS`] of them.
fn positive_median(values: &[f64]) -> Option<f64> {
    let mut v: Vec<f64> = values.iter().copied().filter(|&x| x > 0.0).collect();
    if v.len() < MIN_ROWS_FOR_OUTLIERS {
        return None;
    }
    let k = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(k, f64::total_cmp);
    Some(*m)
}

fn outliers(quantity: Quantity, norms: &[f64]) -> Option<DataWarning> {
    let median = positive_median(norms)?;
    let cap = OUTLIER_FACTOR * median;
    let rows: Vec<usize> = (0..norms.len()).filter(|&i| norms[i] > cap).collect();
    let largest = rows.iter().map(|&i| norms[i]).fold(0.0, f64::max);
    (!rows.is_empty()).then_some(DataWarning::Outliers {
        quantity,
        rows,
        largest,
        median,
    })
}

fn load_norms(wrench: &[f64]) -> Vec<f64> {
    wrench
        .chunks_exact(6)
        .map(|w| {
            let f2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
            let m2 = (w[3] * w[3] + w[4] * w[4] + w[5] * w[5]) / (LOAD_LENGTH * LOAD_LENGTH);
            (f2 + m2).sqrt()
        })
        .collect()
}

/// Rows whose load (`wrench` N×6) or displacement (`displacement` N×3) norm is more than
/// [`OUTLIER_FACTOR`] × the median of the rows with a non-zero one; at most one warning per
/// quantity. Values must be finite (the checks of [`crate::dataset`] ran).
pub fn outlier_rows(wrench: &[f64], displacement: &[f64]) -> Vec<DataWarning> {
    let d: Vec<f64> = displacement
        .chunks_exact(3)
        .map(|d| (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt())
        .collect();
    [
        outliers(Quantity::Load, &load_norms(wrench)),
        outliers(Quantity::Displacement, &d),
    ]
    .into_iter()
    .flatten()
    .collect()
}

/// Every warning about an identification `id` from `wrench` (N×6) and `displacement` (N×3):
/// [`outlier_rows`], then the compliance scale, then significantly negative compliances.
pub fn review(id: &Identification, wrench: &[f64], displacement: &[f64]) -> Vec<DataWarning> {
    let mut out = outlier_rows(wrench, displacement);
    let label = |p: &crate::ParameterEstimate| p.label();
    // The compliance scale is read on the best-determined estimate (largest |value| / its
    // standard error): a parameter identifiable alone, or a combination as the lower bound
    // |value| / Σ|β| of its largest compliance. A unit error scales every estimate by 10³,
    // the best-determined one too; an ill-conditioned design (the xArm7's extended model)
    // gives some estimates of ±1 rad/(N·m) but within a few standard errors of 0, while its
    // best-determined torsions stay plausible.
    let mut best: Option<(String, f64, f64)> = None;
    let mut consider = |name: String, v: f64, se: Option<f64>, scale: f64| {
        let z = match se {
            Some(s) if s > 0.0 => v.abs() / s,
            _ => f64::INFINITY, // no noise estimate: every estimate is as sure
        };
        let shown = v.abs() / scale;
        if shown.is_finite() && best.as_ref().is_none_or(|(_, _, b)| z > *b) {
            best = Some((name, shown, z));
        }
    };
    for p in &id.parameters {
        if let (true, Some(c)) = (p.identifiable, p.compliance) {
            consider(label(p), c, p.stderr, 1.0);
        }
    }
    for c in &id.combinations {
        let scale: f64 = c.terms.iter().map(|t| t.coefficient.abs()).sum();
        if scale > 0.0 {
            consider(c.label.clone(), c.value, c.stderr, scale);
        }
    }
    let implausible =
        |b: &(String, f64, f64)| b.1 > MAX_PLAUSIBLE_COMPLIANCE && b.2 >= SCALE_MIN_SIGNIFICANCE;
    if let Some((name, value, _)) = best.filter(implausible) {
        let forces: Vec<f64> = wrench
            .chunks_exact(6)
            .map(|w| (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt())
            .collect();
        out.push(DataWarning::ComplianceScale {
            label: name,
            value,
            median_force: positive_median(&forces).unwrap_or(0.0),
        });
    }
    // After an outlier row every negative compliance is suspect (the issue's case: one 5e4 N
    // row among 60 N rows turned two torsions negative, some by only 1.6 standard errors
    // since the outlier inflates them too); otherwise only one beyond doubt.
    let after_outliers = out
        .iter()
        .any(|w| matches!(w, DataWarning::Outliers { .. }));
    let margin = if after_outliers {
        0.0
    } else {
        NEGATIVE_SIGNIFICANCE
    };
    // Rounding (noise-free data give −1e-17 ± 1e-19) is not a negative compliance.
    let floor = NEGATIVE_RELATIVE
        * id.parameters
            .iter()
            .filter(|p| p.identifiable)
            .filter_map(|p| p.compliance)
            .fold(0.0f64, |a, c| a.max(c.abs()));
    let negative: Vec<(String, f64, f64)> = id
        .parameters
        .iter()
        .filter_map(|p| match (p.identifiable, p.compliance, p.stderr) {
            (true, Some(c), Some(s)) if c < -floor && c < -margin * s => Some((label(p), c, s)),
            _ => None,
        })
        .collect();
    if !negative.is_empty() {
        out.push(DataWarning::NegativeCompliance {
            parameters: negative,
            after_outliers,
        });
    }
    out
}
