//! The verdict: does structure remain that the chosen model does not explain?
//!
//! - **Lack of fit** ([`nested_test`]): an F test of the model against a flexible alternative
//!   that contains it, with the alternative's own residual variance as the denominator, so the
//!   noise scale cancels: it needs no noise level from the user.
//! - **Goodness of fit** ([`goodness_of_fit`]): when the noise is known, the whitened SSE
//!   against χ² with its degrees of freedom.

use serde::Serialize;

use super::basis::{orthogonalise, zero_norm, Basis};
use super::compressed::RowSet;
use super::fit::{term_columns, Fit};
use super::Problem;
use crate::stats::{chi2_sf, nested_f_test, FTest};

/// The F test of `fit` against `fit` plus the columns of `extra` (all of them at once), on
/// the training rows, at `fit`'s linearisation point. The test has p = 1 and `df_num` 0 when
/// the extra columns add nothing outside the model.
pub fn nested_test<P: Problem>(
    problem: &P,
    fit: &Fit<P::Term, P::Lin>,
    extra: &[P::Term],
) -> FTest {
    let comp = &fit.compressed;
    let model = comp.columns(RowSet::Train, &term_columns(problem, &fit.terms));
    let cols = comp.columns(RowSet::Train, &term_columns(problem, extra));
    // The design is the model and the extra columns: what is not in its data counts nowhere.
    let mut basis = Basis::in_data(zero_norm(model.iter().chain(&cols)));
    for c in &model {
        basis.push(c);
    }
    let mut r = comp.column(RowSet::Train, problem.observation_column());
    basis.project_out(&mut r);
    let sse0: f64 = r.iter().map(|v| v * v).sum();
    let orth = orthogonalise(&basis, &cols);
    let k = orth.basis.rank();
    let sse1 = (sse0 - orth.basis.explained(&r)).max(0.0);
    let df_den = comp.n_obs(RowSet::Train).saturating_sub(basis.rank() + k);
    nested_f_test(sse0, sse1, k, df_den)
}

/// A χ² goodness-of-fit test of a whitened SSE.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ChiSquareTest {
    /// The statistic: the whitened SSE (Σ of squared residuals in noise units).
    pub chi2: f64,
    /// Degrees of freedom: observations − rank.
    pub df: f64,
    /// χ²/df: 1 when only the stated noise remains.
    pub ratio: f64,
    /// Upper-tail p-value (structure or noise above the stated level).
    pub p_value: f64,
}

/// The goodness of fit of `fit` on the training rows when the whitening used the true noise
/// level: SSE ~ χ²(n − rank) under the model.
pub fn goodness_of_fit<P: Problem>(problem: &P, fit: &Fit<P::Term, P::Lin>) -> ChiSquareTest {
    let sse = super::fit::sse(problem, fit, RowSet::Train);
    let df = fit.compressed.n_obs(RowSet::Train).saturating_sub(fit.rank) as f64;
    ChiSquareTest {
        chi2: sse,
        df,
        ratio: if df > 0.0 { sse / df } else { f64::NAN },
        p_value: if df > 0.0 { chi2_sf(sse, df) } else { 1.0 },
    }
}

/// Residual sum of squares and rank of the least-squares fit of column `y` on the columns
/// `cols` of a triangular factor `f` (P×P, row-major upper).
pub fn factor_sse(f: &crate::lsq::TriangularFactor, cols: &[usize], y: usize) -> (f64, usize) {
    let p = f.ncols();
    let col = |k: usize| -> Vec<f64> { (0..p).map(|i| f.r()[i * p + k]).collect() };
    let basis = Basis::of_design(&cols.iter().map(|&k| col(k)).collect::<Vec<_>>());
    let mut r = col(y);
    basis.project_out(&mut r);
    (r.iter().map(|v| v * v).sum(), basis.rank())
}

/// The F test of the model `model` (columns of the training factor `train`, observation `y`)
/// against the model plus further columns plus a block B of `n_block` parameters that is
/// handled by its sufficient statistics: `within` is the factor of the training design with B
/// projected out (e.g. a free offset per cluster), possibly over a subset of the columns;
/// `full_within` are the columns of model ∪ extra in `within`'s own numbering and `y_within`
/// its observation column. Then `rank(M ∪ A ∪ B) = rank_within(M ∪ A) + n_block`, and the SSE
/// of the full model is read from `within`.
pub fn nested_test_with_block(
    train: &crate::lsq::TriangularFactor,
    model: &[usize],
    y: usize,
    within: &crate::lsq::TriangularFactor,
    full_within: &[usize],
    y_within: usize,
    n_block: usize,
) -> FTest {
    let (sse0, rank0) = factor_sse(train, model, y);
    let (sse1, rank_w) = factor_sse(within, full_within, y_within);
    let rank1 = rank_w + n_block;
    let n = train.nrows();
    nested_f_test(
        sse0,
        sse1,
        rank1.saturating_sub(rank0),
        n.saturating_sub(rank1),
    )
}
