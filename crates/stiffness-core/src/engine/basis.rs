//! Small dense least-squares kernels of the selection: an incrementally grown orthonormal basis
//! of the model's columns, used to score many candidate column blocks cheaply, and a
//! rank-revealing SVD solve for the coefficients.
//!
//! Columns are `Vec<f64>`. The engine feeds them the columns of the compressed factor R
//! (length P, [`super::Compressed`]) rather than the whitened columns over all rows (length
//! 3N): since `Z = Q R` with Q orthonormal, every inner product, projection, rank decision and
//! least-squares solution is the same, and the cost no longer depends on N.
//!
//! The diagnosis' rank policy ([`RankPolicy::DIAGNOSIS`]) is applied
//! here: a column whose norm is below
//! [`ZERO_COLUMN_RTOL`] of the largest column of the design it is part of is not in the data
//! ([`zero_norm`]: the fit leaves it out, and a test does not count it); a column whose part
//! outside a basis is below [`RANK_TOL`] of its own norm is in the basis's span; singular
//! values of the column-scaled design below `RANK_TOL·σ_max` are zero.

use crate::lsq::{RankPolicy, ScaledSvd};

/// Relative tolerance under which a column's part orthogonal to the basis is treated as zero
/// (the column lies in the span of the model: not testable on these data), and singular values
/// of a column-scaled design relative to the largest: the diagnosis' rank policy
/// ([`RankPolicy::DIAGNOSIS`]).
pub const RANK_TOL: f64 = RankPolicy::DIAGNOSIS.rank_rtol;

/// Columns whose norm is below this fraction of the largest column norm are exactly zero (the
/// parameter does not enter the data; e.g. a torsion about an axis through the tip point, whose
/// column is ~1e-17 of rounding); the same in every preset of
/// [`RankPolicy`].
pub const ZERO_COLUMN_RTOL: f64 = RankPolicy::DIAGNOSIS.zero_column_rtol;

/// The norm at or below which a column of a design is not in the data: [`ZERO_COLUMN_RTOL`]
/// of the largest of `cols` (the design's columns). A column that is zero in exact arithmetic
/// (a torsion about an axis through the tip point) comes out of the kinematics as rounding,
/// exactly 0 or 1e-17 of the others depending on the order of operations; without this rule a
/// test would count it as a parameter when it is not exactly 0.
pub fn zero_norm<'a>(cols: impl IntoIterator<Item = &'a Vec<f64>>) -> f64 {
    ZERO_COLUMN_RTOL * cols.into_iter().map(|c| norm(c)).fold(0.0, f64::max)
}

/// The inner product of two columns.
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The Euclidean norm of a column.
pub(crate) fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// An orthonormal basis of a set of columns (modified Gram–Schmidt with one re-orthogonalisation
/// pass, which is enough for working precision).
#[derive(Debug, Clone, Default)]
pub struct Basis {
    q: Vec<Vec<f64>>,
    /// Columns of this norm or less are not in the data and never added ([`zero_norm`]).
    zero: f64,
}

impl Basis {
    /// An empty basis that takes every non-zero column.
    pub fn new() -> Self {
        Basis {
            q: Vec::new(),
            zero: 0.0,
        }
    }

    /// An empty basis for columns of a design whose columns of norm `zero` or less are not in
    /// the data ([`zero_norm`] of the design's columns).
    pub fn in_data(zero: f64) -> Self {
        Basis {
            q: Vec::new(),
            zero,
        }
    }

    /// A basis of `cols`, leaving out those not in the data ([`zero_norm`] of `cols`).
    pub fn of_design(cols: &[Vec<f64>]) -> Self {
        let mut basis = Basis::in_data(zero_norm(cols));
        for c in cols {
            basis.push(c);
        }
        basis
    }

    /// Dimension of the spanned space.
    pub fn rank(&self) -> usize {
        self.q.len()
    }

    /// Removes from `v` its components along the basis (twice, for stability).
    pub fn project_out(&self, v: &mut [f64]) {
        for _ in 0..2 {
            for q in &self.q {
                let c = dot(q, v);
                for (vi, qi) in v.iter_mut().zip(q) {
                    *vi -= c * qi;
                }
            }
        }
    }

    /// Adds `col`; returns the norm of its part orthogonal to the basis relative to its own norm
    /// (0 when it was already in the span and nothing was added).
    pub fn push(&mut self, col: &[f64]) -> f64 {
        let n0 = norm(col);
        if n0 == 0.0 || n0 <= self.zero {
            return 0.0;
        }
        let mut v = col.to_vec();
        self.project_out(&mut v);
        let n1 = norm(&v);
        let rel = n1 / n0;
        if rel <= RANK_TOL {
            return 0.0;
        }
        v.iter_mut().for_each(|x| *x /= n1);
        self.q.push(v);
        rel
    }

    /// Squared norm of the projection of `y` onto the span.
    pub fn explained(&self, y: &[f64]) -> f64 {
        self.q.iter().map(|q| dot(q, y).powi(2)).sum()
    }
}

/// The columns of a candidate made orthogonal to a model basis and orthonormalised among
/// themselves; `rank` may be below the candidate's column count.
#[derive(Debug, Clone)]
pub struct Orthogonalised {
    /// Orthonormal columns spanning the candidate's part outside the model.
    pub basis: Basis,
    /// Per input column: relative norm of its part outside the model (0 = in the model's span).
    pub outside: Vec<f64>,
    /// The first column's part outside the model, not normalised (for alias cosines).
    pub first_residual: Vec<f64>,
}

/// Orthogonalises candidate columns `cols` against `model`. A column not in the data of the
/// design `model ∪ cols` ([`zero_norm`]) is outside nothing and adds no rank.
pub fn orthogonalise(model: &Basis, cols: &[Vec<f64>]) -> Orthogonalised {
    let zero = model.zero.max(zero_norm(cols));
    let mut basis = Basis::in_data(zero);
    let mut outside = Vec::with_capacity(cols.len());
    let mut first_residual = Vec::new();
    for (k, c) in cols.iter().enumerate() {
        let n0 = norm(c);
        if n0 <= zero {
            if k == 0 {
                first_residual = vec![0.0; c.len()];
            }
            outside.push(0.0);
            continue;
        }
        let mut v = c.clone();
        model.project_out(&mut v);
        if k == 0 {
            first_residual = v.clone();
        }
        let rel = if n0 > 0.0 { norm(&v) / n0 } else { 0.0 };
        outside.push(rel);
        if rel > RANK_TOL {
            // Measure the remaining rank against the original column norm.
            let mut w = v.clone();
            basis.project_out(&mut w);
            if norm(&w) / n0 > RANK_TOL {
                let nw = norm(&w);
                w.iter_mut().for_each(|x| *x /= nw);
                basis.q.push(w);
            }
        }
    }
    Orthogonalised {
        basis,
        outside,
        first_residual,
    }
}

/// Cosine of the angle between two vectors (0 when either is zero).
pub fn cosine(a: &[f64], b: &[f64]) -> f64 {
    let (na, nb) = (norm(a), norm(b));
    if na == 0.0 || nb == 0.0 {
        0.0
    } else {
        dot(a, b) / (na * nb)
    }
}

/// Least-squares solution of `X β ≈ y` with `X` given by columns.
#[derive(Debug, Clone)]
pub struct ColumnSolution {
    /// Minimum-norm coefficients; exactly 0 for the columns flagged in `in_data`.
    pub beta: Vec<f64>,
    /// Numerical rank of the design.
    pub rank: usize,
    /// `false` for a column that is zero up to rounding (its parameter does not enter the
    /// data, e.g. a torsion about an axis through the tip point): its coefficient means
    /// nothing and must not be reported as an estimate.
    pub in_data: Vec<bool>,
}

/// Minimum-norm least-squares solution of `X β ≈ y` with `X` given by columns, through a
/// thin SVD of the column-scaled design with singular values below `RANK_TOL · σ_max`
/// discarded. Columns whose norm is below [`ZERO_COLUMN_RTOL`] of the largest
/// are left out (the same rule as the identification solver): scaling them to unit norm
/// would turn rounding into a spurious, huge coefficient.
pub fn solve_columns(cols: &[Vec<f64>], y: &[f64]) -> ColumnSolution {
    let p = cols.len();
    if p == 0 {
        return ColumnSolution {
            beta: Vec::new(),
            rank: 0,
            in_data: Vec::new(),
        };
    }
    let Ok(svd) = ScaledSvd::of_columns(
        cols,
        &RankPolicy::DIAGNOSIS,
        true,
        "SVD of the candidate columns",
    ) else {
        // Only non-finite columns fail to converge (the data are finite-checked on entry):
        // nothing is identifiable from them.
        return ColumnSolution {
            beta: vec![0.0; p],
            rank: 0,
            in_data: ScaledSvd::columns_in_data(cols, &RankPolicy::DIAGNOSIS),
        };
    };
    let (beta, rank, in_data) = (svd.solve(y), svd.rank(), svd.in_data());
    ColumnSolution {
        beta,
        rank,
        in_data,
    }
}
