//! The rank-revealing SVD of a small dense design given by its columns, under a
//! [`RankPolicy`]: the one place where a design is column-scaled, its columns that are not in
//! the data are dropped, and its singular values are cut.
//!
//! Every column is divided by its norm, so that the rank decision does not depend on the
//! parameters' units; a column whose norm is at most
//! [`zero_column_rtol`](RankPolicy::zero_column_rtol) of the largest (or not finite) is not in
//! the data and enters as zeros; singular values at most
//! [`rank_rtol`](RankPolicy::rank_rtol)`·σ_max` are zero. The minimum-norm solution and the
//! covariance are then taken on the kept singular values and scaled back to the columns' units.
//!
//! The SVD is faer's. nalgebra's (`SVD::try_new` with ε = machine epsilon), used here before,
//! returned factors that do not reproduce the matrix when a singular value is exactly zero (an
//! aliased pair of columns, which the diagnosis meets all the time): on a 12×4 design with one
//! column a multiple of another, `‖U Σ Vᵀ − X‖ = 2e-3` for `‖X‖ = 2`, and the least-squares
//! coefficients off by 3e-4 relative (the residual not orthogonal to the columns;
//! `a_rank_deficient_design_gives_the_projection_and_drops_what_is_not_there`, and nalgebra
//! issues #1072 and #1172).

use faer::Mat;
use nalgebra::DMatrix;

use super::RankPolicy;
use crate::decompose::NotConverged;

/// A design's column-scaled SVD and its rank decision under a [`RankPolicy`]: columns divided
/// by their norms, columns not in the data zeroed, singular values at most `rank_rtol·σ_max`
/// cut; solutions and covariances in the columns' units. Computed with faer.
///
/// ```
/// use stiffness_core::lsq::{RankPolicy, ScaledSvd};
/// // y = 2·a + 0·b with b a multiple of a (rank 1) and c not in the data (1e-20 of the rest).
/// let cols = vec![vec![1.0, 0.0, 1.0], vec![1e3, 0.0, 1e3], vec![1e-20, 0.0, 0.0]];
/// let fit = ScaledSvd::of_columns(&cols, &RankPolicy::DIAGNOSIS, true, "example")?;
/// assert_eq!(fit.rank(), 1);
/// assert_eq!(fit.in_data(), [true, true, false]);
/// let beta = fit.solve(&[2.0, 0.0, 2.0]);
/// // The minimum-norm split in the scaled columns: a and b share the fit equally.
/// assert!((beta[0] + 1e3 * beta[1] - 2.0).abs() < 1e-12 && beta[2] == 0.0);
/// # Ok::<(), stiffness_core::decompose::NotConverged>(())
/// ```
#[derive(Debug, Clone)]
pub struct ScaledSvd {
    /// Each column's norm, `None` for a column not in the data.
    scales: Vec<Option<f64>>,
    /// The kept singular values, decreasing, each with its U_k (length rows; empty without
    /// U) and its right singular vector in the columns' units, D V_k (0 for a column not in
    /// the data): the rank decision is made once, here.
    kept: Vec<(f64, Vec<f64>, Vec<f64>)>,
    /// Every singular value of the scaled design, decreasing (the kept ones first).
    singular_values: Vec<f64>,
    /// The right singular vectors beyond the rank, in the scaled coordinates: an orthonormal
    /// basis of the scaled design's null space (when it has at least as many rows as columns).
    null_space: Vec<Vec<f64>>,
}

impl ScaledSvd {
    /// The SVD of the column-scaled design whose columns are `cols` (all of one length), with
    /// U when `with_u` (needed by [`solve`](Self::solve)), under `policy`. An error only when
    /// the SVD does not converge; `what` names the design in it.
    pub fn of_columns(
        cols: &[Vec<f64>],
        policy: &RankPolicy,
        with_u: bool,
        what: &'static str,
    ) -> Result<Self, NotConverged> {
        let zero = policy.zero_column_rtol * largest_norm(cols);
        Self::of_columns_in(cols, zero, policy, with_u, what)
    }

    /// [`of_columns`](Self::of_columns) for columns of a larger design: a column of norm `zero`
    /// or less is not in the data (e.g. `zero_column_rtol` of the largest column of the whole
    /// design, or 0 for exactly-zero columns only).
    pub fn of_columns_in(
        cols: &[Vec<f64>],
        zero: f64,
        policy: &RankPolicy,
        with_u: bool,
        what: &'static str,
    ) -> Result<Self, NotConverged> {
        let scales = column_scales(cols, zero);
        let rows = cols.first().map_or(0, Vec::len);
        let x = Mat::<f64>::from_fn(rows, cols.len(), |i, j| {
            scales[j].map_or(0.0, |s| cols[j][i] / s)
        });
        let not_converged = NotConverged {
            what,
            iterations: crate::decompose::iteration_cap(rows.min(cols.len())),
        };
        let svd = x.thin_svd().map_err(|_| not_converged)?;
        let sigma = svd.S().column_vector();
        let s_max = (0..sigma.nrows()).map(|k| sigma[k]).fold(0.0, f64::max);
        let cut = policy.rank_rtol * s_max.max(f64::MIN_POSITIVE);
        let (u, v) = (svd.U(), svd.V());
        let keep = |k: usize| sigma[k] > cut && sigma[k].is_finite();
        let kept = (0..sigma.nrows())
            .filter(|&k| keep(k))
            .map(|k| {
                let uk = if with_u {
                    (0..u.nrows()).map(|i| u[(i, k)]).collect()
                } else {
                    Vec::new()
                };
                let dv = scales
                    .iter()
                    .enumerate()
                    .map(|(j, sc)| sc.map_or(0.0, |n| v[(j, k)] / n))
                    .collect();
                (sigma[k], uk, dv)
            })
            .collect();
        let singular_values = (0..sigma.nrows()).map(|k| sigma[k]).collect();
        let null_space = (0..v.ncols())
            .filter(|&k| !keep(k))
            .map(|k| (0..v.nrows()).map(|j| v[(j, k)]).collect())
            .collect();
        Ok(ScaledSvd {
            scales,
            kept,
            singular_values,
            null_space,
        })
    }

    /// Whether each column is in the data (a column that is not gets coefficient 0 and a NaN
    /// covariance).
    pub fn in_data(&self) -> Vec<bool> {
        self.scales.iter().map(Option::is_some).collect()
    }

    /// [`in_data`](Self::in_data) of a design without its SVD (e.g. when the SVD failed).
    pub fn columns_in_data(cols: &[Vec<f64>], policy: &RankPolicy) -> Vec<bool> {
        column_scales(cols, policy.zero_column_rtol * largest_norm(cols))
            .iter()
            .map(Option::is_some)
            .collect()
    }

    /// Singular values kept: the design's numerical rank.
    pub fn rank(&self) -> usize {
        self.kept.len()
    }

    /// The kept singular values in decreasing order, each as `(σ_k, U_k, D V_k)`: U_k of
    /// length rows (empty when the SVD was taken without U) and the right singular vector in
    /// the columns' units (`V_k[j] / ‖column j‖`, 0 for a column not in the data), so that the
    /// minimum-norm coefficients of `y` are `Σ_k D V_k (U_kᵀ y) / σ_k`.
    pub fn kept_triplets(&self) -> &[(f64, Vec<f64>, Vec<f64>)] {
        &self.kept
    }

    /// Every singular value of the column-scaled design, in decreasing order (the first
    /// [`rank`](Self::rank) are the kept ones).
    pub fn singular_values(&self) -> &[f64] {
        &self.singular_values
    }

    /// An orthonormal basis of the column-scaled design's null space: its right singular
    /// vectors beyond the rank, in the scaled coordinates (a column not in the data is a zero
    /// column there, so its unit vector is in this space). Complete when the design has at
    /// least as many rows as columns (a thin SVD has no more right singular vectors than rows).
    pub fn null_space(&self) -> &[Vec<f64>] {
        &self.null_space
    }

    /// Each column's norm (the scale of its coefficient), `None` for a column not in the data.
    pub fn column_norms(&self) -> &[Option<f64>] {
        &self.scales
    }

    /// The minimum-norm least-squares coefficients of `y` (one per column, in the columns'
    /// units; 0 for a column not in the data). Zeros when the SVD was taken without U.
    pub fn solve(&self, y: &[f64]) -> Vec<f64> {
        let mut beta = vec![0.0; self.scales.len()];
        for (sigma, u, dv) in &self.kept {
            debug_assert!(
                u.len() == y.len(),
                "ScaledSvd::solve needs the SVD taken with U"
            );
            let c = u.iter().zip(y).map(|(a, b)| a * b).sum::<f64>() / sigma;
            for (b, v) in beta.iter_mut().zip(dv) {
                *b += v * c;
            }
        }
        beta
    }

    /// `s2 (XᵀX)⁺` in the columns' units (p×p): the coefficients' covariance for a residual
    /// variance `s2`, on the kept singular values; NaN in the rows and columns of a column not
    /// in the data.
    pub fn covariance(&self, s2: f64) -> DMatrix<f64> {
        let p = self.scales.len();
        let mut cov = self.covariance_in_data(s2);
        for i in 0..p {
            for j in 0..p {
                if self.scales[i].is_none() || self.scales[j].is_none() {
                    cov[(i, j)] = f64::NAN;
                }
            }
        }
        cov
    }

    /// [`covariance`](Self::covariance) with 0 instead of NaN for a column not in the data:
    /// its coefficient is held at 0, so it neither varies nor covaries (a sandwich or a
    /// report that sums over every column wants numbers there).
    pub fn covariance_in_data(&self, s2: f64) -> DMatrix<f64> {
        let p = self.scales.len();
        let mut cov = DMatrix::zeros(p, p);
        for (sigma, _, vk) in &self.kept {
            let w = s2 / (sigma * sigma);
            for i in 0..p {
                let vw = vk[i] * w;
                for j in 0..p {
                    cov[(i, j)] += vw * vk[j];
                }
            }
        }
        cov
    }
}

/// The largest column norm (0 for none; a NaN norm is passed over).
fn largest_norm(cols: &[Vec<f64>]) -> f64 {
    cols.iter().map(|c| norm(c)).fold(0.0, f64::max)
}

fn norm(c: &[f64]) -> f64 {
    c.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// Each column's norm, `None` for a column not in the data: norm at most `zero`, or not
/// finite.
fn column_scales(cols: &[Vec<f64>], zero: f64) -> Vec<Option<f64>> {
    cols.iter()
        .map(|c| norm(c))
        .map(|n| (n > zero && n.is_finite()).then_some(n))
        .collect()
}
