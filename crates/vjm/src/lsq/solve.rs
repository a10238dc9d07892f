//! Rank-revealing weighted least squares on a triangular factor.
//!
//! Input: the factor R of the whitened, augmented design `[A b]` (from
//! [`TriangularAccumulator`](super::TriangularAccumulator) or a dense QR). Steps:
//! 1. Column scaling: s_k = ‖A e_k‖ = ‖R e_k‖, so that the rank decision does not depend
//!    on the units of the parameters.
//! 2. SVD of the scaled m×m factor; rank r = #{σ_i > rank_rtol·σ_1}. Steps 1 and 2 are the
//!    workspace's one scaled SVD, [`stiffness_core::lsq::ScaledSvd`], under the rank policy
//!    the options carry.
//! 3. The null space in reduced row echelon form gives, canonically, which parameters
//!    alias which (connected supports), which are identifiable alone, and r base
//!    parameters `c_k + Σ β_kd c_d` (k independent, d dependent).
//! 4. Estimates are the minimum-norm solution (or non-negative LS); only quantities in
//!    the row space of A — identifiable parameters and base parameters — are reported.
//! 5. Covariance σ²·(AᵀA)⁺ with σ² = 1 when the whitening used the true noise, else
//!    σ² = RSS/(rows − r).

use nalgebra::{DMatrix, DVector};
use serde::Serialize;
use stiffness_core::lsq::{RankPolicy, ScaledSvd, WeakDirections};

use super::nnls::nnls;
use super::TriangularFactor;
use crate::error::VjmError;

/// Default of [`SolveOptions::zero_column_rtol`]: the workspace's one zero-column rule.
pub use stiffness_core::engine::ZERO_COLUMN_RTOL;

/// Options of the rank-revealing solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveOptions {
    /// Singular values of the column-scaled design below `rank_rtol·σ_max` count as zero.
    pub rank_rtol: f64,
    /// Entries of the (orthonormal, scaled) null space below this count as zero when
    /// deciding identifiability and aliasing.
    pub null_tol: f64,
    /// `true`: the rows were whitened with the true noise standard deviations, so σ² = 1.
    /// `false`: σ² is estimated from the residuals.
    pub noise_scale_known: bool,
    /// Constrain every parameter to be ≥ 0 (Lawson–Hanson NNLS on the scaled triangle).
    pub nonnegative: bool,
    /// Columns whose norm is below this fraction of the largest column norm are exactly
    /// zero (the parameter does not enter the data). Column scaling would otherwise blow a
    /// column of pure rounding (a torsion about an axis through the tip point: ~1e-17) up
    /// to unit norm and call it identifiable. This is the one units-dependent decision: for
    /// parameters in commensurate units (all compliances) keep the default; with columns
    /// of wildly different units set 0.
    pub zero_column_rtol: f64,
}

impl Default for SolveOptions {
    /// The identification's rank policy ([`RankPolicy::IDENTIFICATION`]), σ² estimated,
    /// unconstrained.
    fn default() -> Self {
        let policy = RankPolicy::IDENTIFICATION;
        Self {
            rank_rtol: policy.rank_rtol,
            null_tol: policy.null_tol,
            noise_scale_known: false,
            nonnegative: false,
            zero_column_rtol: policy.zero_column_rtol,
        }
    }
}

/// An identifiable linear combination Σ coefficient·x_param (a base parameter).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LinearCombination {
    /// `(parameter index, coefficient)`; the first term is the independent parameter with
    /// coefficient 1, the others are the dependent parameters folded into it.
    pub terms: Vec<(usize, f64)>,
    /// Estimated value of the combination.
    pub value: f64,
    /// Standard error, when a noise scale is known or estimable.
    pub stderr: Option<f64>,
}

/// The result of [`solve_factor`] / [`solve_dense`].
#[derive(Debug, Clone, Serialize)]
pub struct RankRevealingSolution {
    /// Number of parameters m.
    pub n_params: usize,
    /// Numerical rank r of the design.
    pub rank: usize,
    /// Number of rows (scalar equations).
    pub n_equations: usize,
    /// Degrees of freedom rows − r.
    pub dof: usize,
    /// Per parameter: the estimate, or `None` when the parameter is not identifiable.
    pub estimate: Vec<Option<f64>>,
    /// Per parameter: the standard error (`None` when not identifiable or σ unknown).
    pub stderr: Vec<Option<f64>>,
    /// Per parameter: whether it is identifiable on its own.
    pub identifiable: Vec<bool>,
    /// The r base parameters (identifiable combinations), one per independent parameter.
    pub combinations: Vec<LinearCombination>,
    /// Groups of parameters that alias each other (each group sorted).
    pub aliases: Vec<Vec<usize>>,
    /// Null-space basis in parameter units, one vector (length m) per deficient direction.
    pub null_space: Vec<Vec<f64>>,
    /// Singular values of the column-scaled design, descending.
    pub singular_values: Vec<f64>,
    /// The column norms used for scaling (‖A e_k‖).
    pub column_scale: Vec<f64>,
    /// Residual sum of squares of the whitened equations at the estimate.
    pub rss: f64,
    /// σ² used for the covariance (`None` when unknown and not estimable).
    pub sigma2: Option<f64>,
    /// Full m×m covariance σ²·S⁻¹(A_sᵀA_s)⁺S⁻¹ (row-major), meaningful only on the row space.
    #[serde(skip)]
    pub covariance: Vec<f64>,
    /// The full parameter vector used for the estimates (minimum-norm or NNLS).
    #[serde(skip)]
    pub solution: Vec<f64>,
}

impl RankRevealingSolution {
    /// The weak directions of [`solution`](Self::solution)
    /// ([`stiffness_core::lsq::WeakDirections`]): those whose standard error exceeds their
    /// magnitude or [`MAX_PLAUSIBLE_COMPLIANCE`](crate::screening::MAX_PLAUSIBLE_COMPLIANCE).
    /// None without a noise scale.
    pub fn weak_directions(&self) -> Result<WeakDirections, crate::VjmError> {
        let covariance: &[f64] = if self.sigma2.is_some() {
            &self.covariance
        } else {
            &[]
        };
        WeakDirections::of(
            &self.solution,
            covariance,
            &self.column_scale,
            crate::screening::MAX_PLAUSIBLE_COMPLIANCE,
        )
        .map_err(|e| crate::VjmError::Numerical {
            message: e.to_string(),
        })
    }

    /// Value and standard error of wᵀx for any w; `None` when w is not in the row space
    /// of the design (not identifiable), judged with `null_tol` relative to ‖w‖.
    pub fn evaluate(&self, w: &[f64], null_tol: f64) -> Option<(f64, Option<f64>)> {
        if w.len() != self.n_params {
            return None;
        }
        let norm: f64 = w.iter().map(|v| v * v).sum::<f64>().sqrt();
        for n in &self.null_space {
            // n is in parameter units; compare in the scaled metric used for rank decisions.
            let dot: f64 = w.iter().zip(n).map(|(a, b)| a * b).sum();
            let nn: f64 = n.iter().map(|v| v * v).sum::<f64>().sqrt();
            if dot.abs() > null_tol * norm * nn {
                return None;
            }
        }
        let value = w.iter().zip(&self.solution).map(|(a, b)| a * b).sum();
        let m = self.n_params;
        let stderr = self.sigma2.map(|_| {
            let mut v = 0.0;
            for i in 0..m {
                for j in 0..m {
                    v += w[i] * self.covariance[i * m + j] * w[j];
                }
            }
            v.max(0.0).sqrt()
        });
        Some((value, stderr))
    }
}

/// Solves from the augmented factor R of `[A b]` (p = m + 1 columns).
pub fn solve_factor(
    factor: &TriangularFactor,
    opts: &SolveOptions,
) -> Result<RankRevealingSolution, VjmError> {
    check_options(opts)?;
    let (m, rows) = factor_shape(factor)?;
    let (p, r) = (m + 1, factor.r());
    let rss0 = r[m * p + m] * r[m * p + m];
    // A's columns in the triangle (R e_k), and z = Qᵀb, the triangle's last column.
    let cols: Vec<Vec<f64>> = (0..m)
        .map(|k| {
            (0..m)
                .map(|i| if i <= k { r[i * p + k] } else { 0.0 })
                .collect()
        })
        .collect();
    let z: Vec<f64> = (0..m).map(|i| r[i * p + m]).collect();
    let policy = RankPolicy {
        rank_rtol: opts.rank_rtol,
        null_tol: opts.null_tol,
        zero_column_rtol: opts.zero_column_rtol,
    };
    let svd =
        ScaledSvd::of_columns(&cols, &policy, true, "SVD of the scaled factor").map_err(|e| {
            VjmError::Numerical {
                message: e.to_string(),
            }
        })?;
    // A column not in the data keeps the scale 1: its coefficient and covariance are 0 and
    // its unit vector is in the null space.
    let scale: Vec<f64> = svd
        .column_norms()
        .iter()
        .map(|n| n.unwrap_or(1.0))
        .collect();
    let rank = svd.rank();
    let solution = if opts.nonnegative {
        let in_data = svd.in_data();
        let a = DMatrix::from_fn(m, m, |i, k| {
            if in_data[k] {
                cols[k][i] / scale[k]
            } else {
                0.0
            }
        });
        let y = nnls(&a, &DVector::from_column_slice(&z), opts.rank_rtol)?;
        y.iter().zip(&scale).map(|(yk, s)| yk / s).collect()
    } else {
        svd.solve(&z)
    };
    // Residual of the whitened equations: the part of b outside span(Q) plus the in-span misfit.
    let mut rss = rss0;
    for i in 0..m {
        let ri: f64 = (i..m).map(|k| cols[k][i] * solution[k]).sum::<f64>() - z[i];
        rss += ri * ri;
    }
    let dof = rows - rank;
    let sigma2 = if opts.noise_scale_known {
        Some(1.0)
    } else if dof > 0 {
        Some(rss / dof as f64)
    } else {
        None
    };
    // Row-major; 0 for a column not in the data (its coefficient is held at 0).
    let covariance = match sigma2 {
        Some(s2) => {
            let cov = svd.covariance_in_data(s2);
            (0..m * m).map(|ab| cov[(ab / m, ab % m)]).collect()
        }
        None => vec![0.0; m * m],
    };
    let null = NullStructure::of(svd.null_space(), m, opts.null_tol);
    let eval = |w: &[f64]| -> (f64, Option<f64>) {
        let value = w.iter().zip(&solution).map(|(a, b)| a * b).sum();
        let stderr = sigma2.map(|_| {
            let mut acc = 0.0;
            for i in 0..m {
                if w[i] == 0.0 {
                    continue;
                }
                for j in 0..m {
                    acc += w[i] * covariance[i * m + j] * w[j];
                }
            }
            acc.max(0.0).sqrt()
        });
        (value, stderr)
    };
    let combinations = null.base_parameters(&scale, opts.null_tol, eval);
    let null_space: Vec<Vec<f64>> = svd
        .null_space()
        .iter()
        .map(|v| v.iter().zip(&scale).map(|(vk, s)| vk / s).collect())
        .collect();
    let mut estimate = vec![None; m];
    let mut stderr = vec![None; m];
    for k in 0..m {
        if null.identifiable[k] {
            estimate[k] = Some(solution[k]);
            stderr[k] = sigma2.map(|_| covariance[k * m + k].max(0.0).sqrt());
        }
    }
    Ok(RankRevealingSolution {
        n_params: m,
        rank,
        n_equations: rows,
        dof,
        estimate,
        stderr,
        identifiable: null.identifiable,
        combinations,
        aliases: null.aliases,
        null_space,
        singular_values: svd.singular_values().to_vec(),
        column_scale: scale,
        rss,
        sigma2,
        covariance,
        solution,
    })
}

/// (m, rows) of an augmented factor with p = m + 1 columns: at least one parameter and as
/// many scalar equations as parameters.
fn factor_shape(factor: &TriangularFactor) -> Result<(usize, usize), VjmError> {
    let p = factor.ncols();
    if p < 2 {
        return Err(VjmError::ShapeMismatch {
            what: "augmented factor columns (m + 1)",
            expected: 2,
            got: p,
        });
    }
    let m = p - 1;
    let rows = factor.nrows();
    if rows < m {
        return Err(VjmError::TooFewMeasurements {
            have: rows,
            need: m,
            why: format!("a model with {m} parameters needs at least {m} scalar equations"),
        });
    }
    Ok((m, rows))
}

/// The null space (scaled coordinates, orthonormal columns of V beyond the rank) in reduced
/// row echelon form: which parameters are identifiable alone and which alias which.
struct NullStructure {
    /// The RREF rows, d × m.
    nt: DMatrix<f64>,
    pivots: Vec<usize>,
    is_pivot: Vec<bool>,
    identifiable: Vec<bool>,
    /// Connected components of the supports of the RREF rows, sorted.
    aliases: Vec<Vec<usize>>,
}

impl NullStructure {
    /// From an orthonormal basis of the scaled null space (`null`, vectors of length `m`).
    fn of(null: &[Vec<f64>], m: usize, null_tol: f64) -> Self {
        let d = null.len();
        let mut nt = DMatrix::from_fn(d, m, |i, k| null[i][k]);
        let pivots = rref_from_right(&mut nt, null_tol);
        let is_pivot: Vec<bool> = (0..m).map(|k| pivots.contains(&k)).collect();
        let mut identifiable = vec![true; m];
        for k in 0..m {
            if is_pivot[k] || (0..d).any(|i| nt[(i, k)].abs() > null_tol) {
                identifiable[k] = false;
            }
        }
        let mut parent: Vec<usize> = (0..m).collect();
        fn find(parent: &mut [usize], mut x: usize) -> usize {
            while parent[x] != x {
                parent[x] = parent[parent[x]];
                x = parent[x];
            }
            x
        }
        for i in 0..d {
            let support: Vec<usize> = (0..m).filter(|&k| nt[(i, k)].abs() > null_tol).collect();
            for w in support.windows(2) {
                let (a, b) = (find(&mut parent, w[0]), find(&mut parent, w[1]));
                parent[a] = b;
            }
        }
        let mut groups: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
        for (k, &ident) in identifiable.iter().enumerate() {
            if !ident {
                let root = find(&mut parent, k);
                groups.entry(root).or_default().push(k);
            }
        }
        let mut aliases: Vec<Vec<usize>> = groups.into_values().collect();
        aliases.sort();
        Self {
            nt,
            pivots,
            is_pivot,
            identifiable,
            aliases,
        }
    }

    /// Base parameters: for independent k, x_k − Σ_i N_ik (s_{D_i}/s_k) x_{D_i} (see module
    /// docs), valued by `eval` (value and standard error of wᵀx).
    fn base_parameters(
        &self,
        scale: &[f64],
        null_tol: f64,
        eval: impl Fn(&[f64]) -> (f64, Option<f64>),
    ) -> Vec<LinearCombination> {
        let m = self.is_pivot.len();
        (0..m)
            .filter(|&k| !self.is_pivot[k])
            .map(|k| {
                let mut w = vec![0.0; m];
                w[k] = 1.0;
                let mut terms = vec![(k, 1.0)];
                for (i, &dk) in self.pivots.iter().enumerate() {
                    let c = self.nt[(i, k)];
                    if c.abs() > null_tol {
                        let coef = -c * scale[dk] / scale[k];
                        w[dk] = coef;
                        terms.push((dk, coef));
                    }
                }
                let (value, stderr) = eval(&w);
                LinearCombination {
                    terms,
                    value,
                    stderr,
                }
            })
            .collect()
    }
}

/// Dense path: QR (faer) of the row-major `rows×cols` design with right-hand side `rhs`,
/// then [`solve_factor`]. Rows must already be whitened.
pub fn solve_dense(
    design: &[f64],
    rows: usize,
    cols: usize,
    rhs: &[f64],
    opts: &SolveOptions,
) -> Result<RankRevealingSolution, VjmError> {
    solve_factor(&dense_factor(design, rows, cols, rhs)?, opts)
}

/// The augmented triangular factor of `[A b]` by a dense faer QR.
pub fn dense_factor(
    design: &[f64],
    rows: usize,
    cols: usize,
    rhs: &[f64],
) -> Result<TriangularFactor, VjmError> {
    if design.len() != rows * cols {
        return Err(VjmError::ShapeMismatch {
            what: "design matrix (rows·cols)",
            expected: rows * cols,
            got: design.len(),
        });
    }
    if rhs.len() != rows {
        return Err(VjmError::ShapeMismatch {
            what: "right-hand side (rows)",
            expected: rows,
            got: rhs.len(),
        });
    }
    for i in 0..rows {
        crate::chain::check_finite("design matrix", &design[i * cols..(i + 1) * cols], i, 0)?;
        crate::chain::check_finite("right-hand side", &rhs[i..i + 1], i, 0)?;
    }
    let p = cols + 1;
    if rows < p {
        // Too short for a thin QR with the rhs; the accumulator handles any row count.
        let mut acc = super::TriangularAccumulator::new(p);
        let mut row = vec![0.0; p];
        for i in 0..rows {
            row[..cols].copy_from_slice(&design[i * cols..(i + 1) * cols]);
            row[cols] = rhs[i];
            acc.push_row_unchecked(&row);
        }
        return Ok(acc.finish());
    }
    let a = faer::Mat::<f64>::from_fn(rows, p, |i, j| {
        if j < cols {
            design[i * cols + j]
        } else {
            rhs[i]
        }
    });
    let qr = a.qr();
    let r = qr.thin_R();
    let mut out = vec![0.0; p * p];
    for i in 0..p {
        for j in i..p {
            out[i * p + j] = r[(i, j)];
        }
    }
    Ok(TriangularFactor::from_upper(p, out, rows)?)
}

fn check_options(opts: &SolveOptions) -> Result<(), VjmError> {
    if !(opts.rank_rtol > 0.0 && opts.rank_rtol < 1.0) {
        return Err(VjmError::InvalidOption {
            name: "rank_rtol",
            message: format!(
                "must be in (0, 1), got {}",
                stiffness_core::num::Short(opts.rank_rtol)
            ),
        });
    }
    if !(opts.zero_column_rtol >= 0.0 && opts.zero_column_rtol < 1.0) {
        return Err(VjmError::InvalidOption {
            name: "zero_column_rtol",
            message: format!(
                "must be in [0, 1), got {}",
                stiffness_core::num::Short(opts.zero_column_rtol)
            ),
        });
    }
    if !(opts.null_tol > 0.0 && opts.null_tol < 1.0) {
        return Err(VjmError::InvalidOption {
            name: "null_tol",
            message: format!(
                "must be in (0, 1), got {}",
                stiffness_core::num::Short(opts.null_tol)
            ),
        });
    }
    Ok(())
}

/// Reduced row echelon form of the d×m matrix `a` in place, choosing pivot columns from
/// the last column towards the first (so tip-side parameters become the dependent ones)
/// and, in each column, the largest remaining entry (partial pivoting). Returns the pivot
/// column of each row.
fn rref_from_right(a: &mut DMatrix<f64>, tol: f64) -> Vec<usize> {
    let (d, m) = a.shape();
    let mut pivots = Vec::with_capacity(d);
    let mut row = 0;
    for col in (0..m).rev() {
        if row == d {
            break;
        }
        let (best, val) = (row..d)
            .map(|i| (i, a[(i, col)].abs()))
            .fold((row, -1.0), |acc, x| if x.1 > acc.1 { x } else { acc });
        if val <= tol {
            continue;
        }
        a.swap_rows(row, best);
        let pv = a[(row, col)];
        for j in 0..m {
            a[(row, j)] /= pv;
        }
        for i in 0..d {
            if i != row {
                let f = a[(i, col)];
                if f != 0.0 {
                    for j in 0..m {
                        let t = a[(row, j)];
                        a[(i, j)] -= f * t;
                    }
                }
            }
        }
        pivots.push(col);
        row += 1;
    }
    pivots
}
