//! Stiffness identification from load increments: K_D ≈ ΨΩ⁺ (seed eq. 49) plus the
//! connection term, solved by the workspace's column-scaled SVD
//! ([`stiffness_core::lsq::ScaledSvd`], faer), which refuses a degenerate design.
//!
//! # Model
//! With Δζ_k = log(R₀ᵀR_k) (rad, body frame A at R₀) and τ_k the external moment (N·m, A):
//!
//! - first order: `τ_k = τ₀ + c + K_D Δζ_k + e_k`
//! - second order: `τ_k = τ₀ + c + K_D Δζ_k + ½ [Δζ_kᵀ H_i Δζ_k]_i + e_k`
//!
//! `c` is an optional offset (on by default): it absorbs the noise of the single reference
//! measurement, which eq. 49 would otherwise spread into every entry of K_D. The seed's
//! eq. 49 is the first-order model with `c = 0`.
//!
//! The stiffness is the covariant Hessian of the potential, `K = K_D + K_L`. Along the
//! exponential curve R₀exp(ζ) the measured moment is the body-frame gradient, while the
//! Euclidean gradient of f(ζ) = Φ(R₀exp ζ) is `J_r(ζ)ᵀ τ(ζ) ≈ τ − ½ hat(τ₀) ζ`; exponential
//! coordinates are normal coordinates of the bi-invariant metric, so
//! **`K_L = −½ hat(τ₀)`**. The seed's eq. 48b writes `−hat(τ₀)` because its structure
//! constants (eq. 31) are ±2 instead of ±1 (`[σ̂₁, σ̂₂] = σ̂₃`). Both are available through
//! [`ConnectionTerm`]; `docs/csjm-identification.md` has the derivation and the test that
//! pins it.

use faer::Mat;
use nalgebra::{Matrix3, Vector3};
use stiffness_core::lsq::{RankPolicy, ScaledSvd};

use super::dataset::CsjmDataset;
use super::error::IdentificationError;
use crate::so3;

/// Default limit on the condition number σ_max/σ_min of Ω = [Δζ₁ … Δζ_N].
///
/// Ω has one unit (rad), so its condition number is meaningful as is: loads about all three
/// axes give 1–20 (the soft axis moves more); loading only one or two axes leaves σ_min at the
/// pose-noise level (~1e-4 rad against ~0.05–0.3 rad), i.e. several hundred and more.
pub const DEFAULT_MAX_CONDITION: f64 = 100.0;

/// Limit on the condition number of the column-scaled regression matrix (offset, linear and
/// quadratic columns each scaled to unit norm). Only guards against an exactly degenerate
/// design, e.g. quadratic columns that duplicate each other; excitation is judged on Ω.
pub const MAX_REGRESSOR_CONDITION: f64 = 1e10;

/// Largest number of points of the det(K)-versus-N series (see [`DetPoint`]).
pub const MAX_CONVERGENCE_POINTS: usize = 128;

/// Order of the local model τ(Δζ).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum FitOrder {
    /// Linear in Δζ (seed eq. 49). Biased by the curvature of τ(Δζ) for large increments.
    First,
    /// Linear plus quadratic terms in Δζ: K_D is the slope at Δζ = 0 even for large increments.
    Second,
}

impl FitOrder {
    /// 1 or 2.
    pub fn as_u8(self) -> u8 {
        match self {
            FitOrder::First => 1,
            FitOrder::Second => 2,
        }
    }
}

/// Which connection term turns K_D into K.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum ConnectionTerm {
    /// `K_L = −½ hat(τ₀)`: Levi-Civita connection of the bi-invariant metric with the true
    /// structure constants of so(3). Gives the symmetric covariant Hessian. The default.
    LeviCivita,
    /// `K_L = −hat(τ₀)`, as printed in seed eq. 48b/50 (structure constants ±2). Reproduces the
    /// seed's Table 3; not symmetric for a conservative system.
    PaperEq48b,
    /// `K_L = 0`: the Euclidean slope K_D alone.
    None,
}

impl ConnectionTerm {
    /// The matrix K_L for a pre-load `tau0` (N·m, frame A).
    pub fn k_l(self, tau0: &Vector3<f64>) -> Matrix3<f64> {
        match self {
            ConnectionTerm::LeviCivita => -0.5 * so3::hat(tau0),
            ConnectionTerm::PaperEq48b => -so3::hat(tau0),
            ConnectionTerm::None => Matrix3::zeros(),
        }
    }

    /// Factor f in K_L = −f·hat(τ₀).
    fn factor(self) -> f64 {
        match self {
            ConnectionTerm::LeviCivita => 0.5,
            ConnectionTerm::PaperEq48b => 1.0,
            ConnectionTerm::None => 0.0,
        }
    }
}

/// Options of the stiffness fit.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct FitOptions {
    /// First- or second-order model.
    pub order: FitOrder,
    /// Connection term K_L.
    pub connection: ConnectionTerm,
    /// Fit an offset c (see the module docs). With it, τ₀ used in K_L is τ₀ + c.
    pub fit_offset: bool,
    /// Limit on the condition number of Ω = [Δζ₁ … Δζ_N] (see [`DEFAULT_MAX_CONDITION`]); above
    /// it the fit fails with [`IdentificationError::IllConditioned`] instead of inverting
    /// blindly.
    pub max_condition: f64,
    /// Compute the det(K)-versus-N series (one extra fit per prefix of the data; at most
    /// [`MAX_CONVERGENCE_POINTS`] evenly spaced prefixes).
    pub convergence_series: bool,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            order: FitOrder::First,
            connection: ConnectionTerm::LeviCivita,
            fit_offset: true,
            max_condition: DEFAULT_MAX_CONDITION,
            convergence_series: true,
        }
    }
}

impl FitOptions {
    /// Default options with the given model order.
    pub fn with_order(order: FitOrder) -> Self {
        FitOptions {
            order,
            ..FitOptions::default()
        }
    }

    /// Number of regression coefficients per moment component.
    pub fn parameters(&self) -> usize {
        let linear = 3 + usize::from(self.fit_offset);
        match self.order {
            FitOrder::First => linear,
            FitOrder::Second => linear + 6,
        }
    }

    /// Minimum number of load increments the fit needs (the reference row counts as a sample
    /// when an offset is fitted).
    pub fn min_increments(&self) -> usize {
        self.parameters() - usize::from(self.fit_offset)
    }
}

/// One point of the det(K)-versus-N series (seed Fig. 5).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetPoint {
    /// Number of load increments used (the first `n` in data order).
    pub n: usize,
    /// det(K) of the fit on those increments, (N·m/rad)³.
    pub det: f64,
}

/// Result of a stiffness identification at the reference pose R₀.
///
/// All matrices are in N·m/rad with components in frame A at R₀:
/// `K = K_D + K_L`, `δτ ≈ K δζ`.
#[derive(Debug, Clone, PartialEq)]
pub struct StiffnessEstimate {
    /// Identified stiffness K = K_D + K_L.
    pub k: Matrix3<f64>,
    /// Slope K_D = ∂τ/∂ζ at Δζ = 0.
    pub k_d: Matrix3<f64>,
    /// Connection term K_L (see [`ConnectionTerm`]).
    pub k_l: Matrix3<f64>,
    /// Standard error of every entry of K (NaN when the fit has no residual degrees of freedom).
    pub k_stderr: Matrix3<f64>,
    /// Pre-load used in K_L (N·m, frame A): the reference moment, plus the fitted offset if any.
    pub tau0: Vector3<f64>,
    /// Fitted offset c (zero without [`FitOptions::fit_offset`]), N·m.
    pub offset: Vector3<f64>,
    /// Second-order fits: Hessians H_i of τ_i(Δζ) at 0, τ_i ≈ … + ½ Δζᵀ H_i Δζ (N·m/rad²).
    pub curvature: Option<[Matrix3<f64>; 3]>,
    /// Number of load increments used.
    pub n: usize,
    /// Model order, 1 or 2.
    pub order: u8,
    /// Residual degrees of freedom per moment component.
    pub dof: usize,
    /// RMS of the moment residuals per component, N·m.
    pub residual_rms: Vector3<f64>,
    /// Singular values of Ω = [Δζ₁ … Δζ_N] (3×N), descending, rad.
    pub omega_singular_values: [f64; 3],
    /// Condition number σ_max/σ_min of Ω.
    pub omega_condition: f64,
    /// Condition number of the column-scaled regression matrix actually solved.
    pub regressor_condition: f64,
    /// det(K) against the number of increments used (empty if not requested).
    pub det_convergence: Vec<DetPoint>,
}

impl StiffnessEstimate {
    /// Symmetric part (K + Kᵀ)/2.
    pub fn k_symmetric(&self) -> Matrix3<f64> {
        0.5 * (self.k + self.k.transpose())
    }

    /// Relative asymmetry ‖K − Kᵀ‖_F / ‖K‖_F (0 for a conservative system without noise).
    pub fn asymmetry(&self) -> f64 {
        (self.k - self.k.transpose()).norm() / self.k.norm()
    }
}

/// Identifies K at the dataset's reference pose.
///
/// ```
/// use nalgebra::{Matrix3, Vector3};
/// use so3_stiffness::identification::{identify, CsjmDataset, CsjmMeasurement, FitOptions};
/// use so3_stiffness::so3;
/// // A linear, symmetric joint: τ = τ₀ + K_D Δζ with K_D = K + ½hat(τ₀).
/// let k_true = Matrix3::new(30.0, 1.0, 0.5, 1.0, 28.0, -1.0, 0.5, -1.0, 7.0);
/// let tau0 = Vector3::new(0.1, -0.5, 0.2);
/// let k_d = k_true + 0.5 * so3::hat(&tau0);
/// let r0 = so3::exp(&Vector3::new(0.1, 0.2, -0.1));
/// let steps = [Vector3::new(0.01, 0.0, 0.0), Vector3::new(0.0, 0.01, 0.0),
///              Vector3::new(0.0, 0.0, 0.01), Vector3::new(-0.01, 0.005, 0.002)];
/// let poses = steps.iter().map(|z| CsjmMeasurement::new(r0 * so3::exp(z), tau0 + k_d * z)).collect();
/// let data = CsjmDataset::new(CsjmMeasurement::new(r0, tau0), poses).unwrap();
/// let est = identify(&data, &FitOptions::default()).unwrap();
/// assert!((est.k - k_true).norm() < 1e-9);
/// ```
pub fn identify(
    data: &CsjmDataset,
    options: &FitOptions,
) -> Result<StiffnessEstimate, IdentificationError> {
    let (dzeta, dtau) = data.increments();
    identify_increments(&data.reference().moment, &dzeta, &dtau, options)
}

/// Identifies K from increments: `dzeta[k]` = Δζ_k (rad, frame A at R₀), `dtau[k]` = Δτ_k
/// (N·m, frame A), `tau0` = the reference moment (N·m, frame A).
pub fn identify_increments(
    tau0: &Vector3<f64>,
    dzeta: &[Vector3<f64>],
    dtau: &[Vector3<f64>],
    options: &FitOptions,
) -> Result<StiffnessEstimate, IdentificationError> {
    if dzeta.len() != dtau.len() {
        return Err(IdentificationError::LengthMismatch {
            what: "identify_increments",
            left: dzeta.len(),
            right: dtau.len(),
        });
    }
    if !tau0.iter().all(|x| x.is_finite()) {
        return Err(IdentificationError::NonFiniteInput { what: "tau0" });
    }
    if !dzeta
        .iter()
        .chain(dtau)
        .all(|v| v.iter().all(|x| x.is_finite()))
    {
        return Err(IdentificationError::NonFiniteInput { what: "increments" });
    }
    if !(options.max_condition >= 1.0) {
        return Err(IdentificationError::InvalidSetting {
            field: "max_condition",
            message: format!(
                "must be ≥ 1, got {}",
                stiffness_core::num::Short(options.max_condition)
            ),
        });
    }
    let mut estimate = fit(tau0, dzeta, dtau, options)?;
    if options.convergence_series {
        let first = options.min_increments();
        estimate.det_convergence = convergence_sizes(first, dzeta.len())
            .into_iter()
            .filter_map(|n| fit(tau0, &dzeta[..n], &dtau[..n], options).ok())
            .map(|e| DetPoint {
                n: e.n,
                det: e.k.determinant(),
            })
            .collect();
    }
    Ok(estimate)
}

/// Prefix sizes of the det(K) series: every n from `first` to `last` when there are at most
/// [`MAX_CONVERGENCE_POINTS`], else that many evenly spaced (both ends included), so the
/// series costs O(N·points), not O(N²), on large files.
fn convergence_sizes(first: usize, last: usize) -> Vec<usize> {
    if last < first {
        return Vec::new();
    }
    let count = last - first + 1;
    if count <= MAX_CONVERGENCE_POINTS {
        return (first..=last).collect();
    }
    let step = (count - 1) as f64 / (MAX_CONVERGENCE_POINTS - 1) as f64;
    let mut sizes: Vec<usize> = (0..MAX_CONVERGENCE_POINTS)
        .map(|i| first + (i as f64 * step).round() as usize)
        .collect();
    sizes.dedup();
    sizes
}

/// Regressor row for one sample.
fn regressor(z: &Vector3<f64>, options: &FitOptions, out: &mut Vec<f64>) {
    out.clear();
    if options.fit_offset {
        out.push(1.0);
    }
    out.extend_from_slice(z.as_slice());
    if options.order == FitOrder::Second {
        out.extend_from_slice(&[
            z.x * z.x,
            z.y * z.y,
            z.z * z.z,
            z.x * z.y,
            z.x * z.z,
            z.y * z.z,
        ]);
    }
}

fn singular_values_of_omega(dzeta: &[Vector3<f64>]) -> Result<[f64; 3], IdentificationError> {
    let omega_t = Mat::<f64>::from_fn(dzeta.len(), 3, |i, j| dzeta[i][j]);
    let s = omega_t
        .singular_values()
        .map_err(|_| IdentificationError::SvdFailed)?;
    let mut out = [0.0; 3];
    for (o, v) in out.iter_mut().zip(s) {
        *o = v;
    }
    Ok(out)
}

fn fit(
    tau0: &Vector3<f64>,
    dzeta: &[Vector3<f64>],
    dtau: &[Vector3<f64>],
    options: &FitOptions,
) -> Result<StiffnessEstimate, IdentificationError> {
    let n = dzeta.len();
    let required = options.min_increments();
    if n < required {
        return Err(IdentificationError::TooFewMeasurements {
            what: match options.order {
                FitOrder::First => "first-order fit",
                FitOrder::Second => "second-order fit",
            },
            usable: n,
            required,
        });
    }
    // Samples: the increments, plus the reference itself (Δζ = 0, Δτ = 0) when an offset is
    // fitted — then the reference is one noisy sample among others rather than an exact anchor.
    let zero = Vector3::zeros();
    let samples: Vec<(&Vector3<f64>, &Vector3<f64>)> = if options.fit_offset {
        std::iter::once((&zero, &zero))
            .chain(dzeta.iter().zip(dtau))
            .collect()
    } else {
        dzeta.iter().zip(dtau).collect()
    };
    let m = samples.len();
    let omega_singular_values = singular_values_of_omega(dzeta)?;
    let omega_condition = omega_singular_values[0] / omega_singular_values[2];
    let ls = LinearFit::of(&samples, options, omega_singular_values, omega_condition)?;
    let (beta, cov_diag) = (&ls.beta, &ls.cov_diag);

    let mut row = Vec::with_capacity(beta.len());
    let mut rss = Vector3::zeros();
    for (z, dt) in &samples {
        regressor(z, options, &mut row);
        for comp in 0..3 {
            let predicted: f64 = row.iter().zip(beta).map(|(r, b)| r * b[comp]).sum();
            rss[comp] += (dt[comp] - predicted).powi(2);
        }
    }
    let dof = m - beta.len();
    let sigma2 = if dof > 0 {
        rss / dof as f64
    } else {
        Vector3::repeat(f64::NAN)
    };

    let first_linear = usize::from(options.fit_offset);
    let offset = if options.fit_offset {
        Vector3::new(beta[0][0], beta[0][1], beta[0][2])
    } else {
        Vector3::zeros()
    };
    let mut k_d = Matrix3::zeros();
    let mut k_d_var = Matrix3::zeros();
    for i in 0..3 {
        for j in 0..3 {
            k_d[(i, j)] = beta[first_linear + j][i];
            k_d_var[(i, j)] = sigma2[i] * cov_diag[first_linear + j];
        }
    }
    // Variance of the pre-load used in K_L: the fitted τ₀ + c, or the single reference sample.
    let tau0_var: Vector3<f64> = if options.fit_offset {
        sigma2 * cov_diag[0]
    } else {
        sigma2
    };
    let tau0_used = tau0 + offset;
    let k_l = options.connection.k_l(&tau0_used);
    let k_stderr = stiffness_stderr(&k_d_var, &tau0_var, options.connection.factor());
    let curvature =
        (options.order == FitOrder::Second).then(|| curvature_of(beta, first_linear + 3));
    Ok(StiffnessEstimate {
        k: k_d + k_l,
        k_d,
        k_l,
        k_stderr,
        tau0: tau0_used,
        offset,
        curvature,
        n,
        order: options.order.as_u8(),
        dof,
        residual_rms: (rss / m as f64).map(f64::sqrt),
        omega_singular_values,
        omega_condition,
        regressor_condition: ls.condition,
        det_convergence: Vec::new(),
    })
}

/// The least-squares coefficients of the column-scaled regressor (one column of 3 per
/// parameter), the diagonal of (XᵀX)⁻¹ and the scaled regressor's condition number.
struct LinearFit {
    beta: Vec<[f64; 3]>,
    cov_diag: Vec<f64>,
    condition: f64,
}

impl LinearFit {
    /// The column scaling and SVD of the workspace's least-squares layer
    /// ([`ScaledSvd`]): every column is in the data (none may be zero) and no singular value
    /// is cut, because the fit refuses rather than truncates (a CSJM fit with a degenerate
    /// design has no meaningful subset to report).
    const POLICY: RankPolicy = RankPolicy {
        rank_rtol: 0.0,
        null_tol: RankPolicy::IDENTIFICATION.null_tol,
        zero_column_rtol: 0.0,
    };

    /// β = D⁻¹ V Σ⁻¹ Uᵀ y for each moment component, cov(β) = σ² D⁻¹ V Σ⁻² Vᵀ D⁻¹; refused
    /// when Ω (the displacements) or the scaled regressor is too ill-conditioned.
    fn of(
        samples: &[(&Vector3<f64>, &Vector3<f64>)],
        options: &FitOptions,
        omega_singular_values: [f64; 3],
        omega_condition: f64,
    ) -> Result<Self, IdentificationError> {
        let (m, p) = (samples.len(), options.parameters());
        let mut row = Vec::with_capacity(p);
        let mut cols = vec![vec![0.0; m]; p];
        for (i, (z, _)) in samples.iter().enumerate() {
            regressor(z, options, &mut row);
            for (col, v) in cols.iter_mut().zip(&row) {
                col[i] = *v;
            }
        }
        if !(omega_condition <= options.max_condition) {
            return Err(IdentificationError::IllConditioned {
                matrix: "Ω (displacements)",
                condition: omega_condition,
                max_condition: options.max_condition,
                omega_singular_values,
            });
        }
        let ill = |condition: f64| IdentificationError::IllConditioned {
            matrix: "column-scaled regressor",
            condition,
            max_condition: MAX_REGRESSOR_CONDITION,
            omega_singular_values,
        };
        // Column scaling makes the condition number independent of units and load size.
        let svd = ScaledSvd::of_columns(&cols, &Self::POLICY, true, "SVD of the regressor")
            .map_err(|_| IdentificationError::SvdFailed)?;
        if svd.in_data().contains(&false) {
            return Err(ill(f64::INFINITY));
        }
        let s = svd.singular_values();
        let condition = s[0] / s[p - 1];
        if !(condition <= MAX_REGRESSOR_CONDITION) {
            return Err(ill(condition));
        }
        let mut beta = vec![[0.0; 3]; p];
        for comp in 0..3 {
            let y: Vec<f64> = samples.iter().map(|(_, tau)| tau[comp]).collect();
            for (b, x) in beta.iter_mut().zip(svd.solve(&y)) {
                b[comp] = x;
            }
        }
        let cov_diag = svd.covariance(1.0).diagonal().iter().copied().collect();
        Ok(Self {
            beta,
            cov_diag,
            condition,
        })
    }
}

/// Standard errors of K = K_D + K_L: K_D's from the fit, K_L's from the pre-load's variance
/// through the connection's `factor` (hat(τ)_ij involves τ_k with k ∉ {i, j} for i ≠ j;
/// the components are independent).
fn stiffness_stderr(k_d_var: &Matrix3<f64>, tau0_var: &Vector3<f64>, factor: f64) -> Matrix3<f64> {
    let f2 = factor.powi(2);
    let mut k_stderr = Matrix3::zeros();
    for i in 0..3 {
        for j in 0..3 {
            let kl_var = if i == j {
                0.0
            } else {
                f2 * tau0_var[3 - i - j]
            };
            k_stderr[(i, j)] = (k_d_var[(i, j)] + kl_var).sqrt();
        }
    }
    k_stderr
}

/// The Hessians of the three moment components from the quadratic coefficients starting at
/// `q` (order xx, yy, zz, xy, xz, yz).
fn curvature_of(beta: &[[f64; 3]], q: usize) -> [Matrix3<f64>; 3] {
    let mut h = [Matrix3::zeros(); 3];
    for (i, hi) in h.iter_mut().enumerate() {
        hi[(0, 0)] = 2.0 * beta[q][i];
        hi[(1, 1)] = 2.0 * beta[q + 1][i];
        hi[(2, 2)] = 2.0 * beta[q + 2][i];
        hi[(0, 1)] = beta[q + 3][i];
        hi[(1, 0)] = beta[q + 3][i];
        hi[(0, 2)] = beta[q + 4][i];
        hi[(2, 0)] = beta[q + 4][i];
        hi[(1, 2)] = beta[q + 5][i];
        hi[(2, 1)] = beta[q + 5][i];
    }
    h
}
