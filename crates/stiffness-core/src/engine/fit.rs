//! Fits and nested scores on the compressed design.

use std::sync::Arc;

use super::basis::{orthogonalise, solve_columns, Basis};
use super::compressed::{Compressed, RowSet};
use super::Problem;
use crate::stats::{nested_f_test, FTest};
use crate::Cancelled;

/// A fitted model: terms, coefficients and the linearisation point its columns were built at.
#[derive(Debug, Clone)]
pub struct Fit<T, L> {
    /// Terms in order.
    pub terms: Vec<T>,
    /// Coefficients, one per column, in term order.
    pub coef: Vec<f64>,
    /// The linearisation point of the final columns.
    pub lin: L,
    /// Numerical rank of the training design.
    pub rank: usize,
    /// Per coefficient: `false` when its column is zero up to rounding on these data (the
    /// coefficient is 0 and is not an estimate).
    pub in_data: Vec<bool>,
    /// The compressed design at `lin`.
    pub compressed: Arc<Compressed>,
}

impl<T, L> Fit<T, L> {
    /// Number of parameters (columns).
    pub fn n_params(&self) -> usize {
        self.coef.len()
    }
}

/// Score of one candidate against a fit.
#[derive(Debug, Clone)]
pub struct Score<T> {
    /// The candidate.
    pub cand: T,
    /// Rank of its columns outside the model (0 = not testable).
    pub rank: usize,
    /// The nested F test (p = 1 when not testable).
    pub f_test: FTest,
    /// Training SSE with the candidate added.
    pub sse_full: f64,
    /// Training SSE of the model alone.
    pub sse_reduced: f64,
    /// The candidate's first column after projecting out the model (for alias cosines).
    pub first_residual: Vec<f64>,
}

/// Column indices of `terms` in the compressed design, in term order.
pub fn term_columns<P: Problem>(problem: &P, terms: &[P::Term]) -> Vec<usize> {
    terms.iter().flat_map(|t| problem.columns(*t)).collect()
}

/// Fits `terms` on the training rows. Models with bilinear terms are re-linearised at the new
/// coefficients and refitted until they settle (relative change ≤ 1e-9), at most 6 passes.
/// The iterations solve with the model's own columns ([`Problem::model_columns`]); the whole
/// design is compressed once, at the final point, and the coefficients solved on it.
pub fn fit<P: Problem>(
    problem: &P,
    terms: &[P::Term],
    lin0: &P::Lin,
) -> Result<Fit<P::Term, P::Lin>, Cancelled> {
    let bilinear = terms.iter().any(|t| problem.bilinear(*t));
    let passes = if bilinear { 6 } else { 1 };
    let cols = term_columns(problem, terms);
    let y = problem.observation_column();
    let mut lin = lin0.clone();
    let mut coef: Vec<f64> = Vec::new();
    let mut comp = problem.compress(&lin)?;
    let mut x = comp.columns(RowSet::Train, &cols);
    let mut yv = comp.column(RowSet::Train, y);
    let mut moved = false;
    for pass in 0..passes {
        let beta = solve_columns(&x, &yv).beta;
        let settled = !coef.is_empty()
            && beta
                .iter()
                .zip(&coef)
                .all(|(a, b): (&f64, &f64)| (a - b).abs() <= 1e-9 * (a.abs() + b.abs()) + 1e-300);
        coef = beta;
        if pass + 1 == passes || settled {
            break;
        }
        lin = problem.relinearise(terms, &coef);
        (x, yv) = problem.model_columns(&lin, &cols)?;
        moved = true;
    }
    if moved {
        comp = problem.compress(&lin)?;
        x = comp.columns(RowSet::Train, &cols);
        yv = comp.column(RowSet::Train, y);
    }
    let sol = solve_columns(&x, &yv);
    Ok(Fit {
        terms: terms.to_vec(),
        coef: sol.beta,
        lin,
        rank: sol.rank,
        in_data: sol.in_data,
        compressed: comp,
    })
}

/// SSE of a fit over `set` (training SSE, or the held-out SSE of the training fit).
pub fn sse<P: Problem>(problem: &P, fit: &Fit<P::Term, P::Lin>, set: RowSet) -> f64 {
    let cols = term_columns(problem, &fit.terms);
    fit.compressed
        .sse(set, &cols, &fit.coef, problem.observation_column())
}

/// Scores of the candidates `pool` against `fit` with the terms `given` added to the model
/// (their columns at `fit`'s linearisation point). Stops early once cancelled.
pub fn score_given<P: Problem>(
    problem: &P,
    fit: &Fit<P::Term, P::Lin>,
    given: &[P::Term],
    pool: &[P::Term],
) -> Result<Vec<Score<P::Term>>, Cancelled> {
    let mut terms = fit.terms.clone();
    terms.extend_from_slice(given);
    let comp = &fit.compressed;
    let basis = Basis::of_design(&comp.columns(RowSet::Train, &term_columns(problem, &terms)));
    let mut r = comp.column(RowSet::Train, problem.observation_column());
    basis.project_out(&mut r);
    let sse0: f64 = r.iter().map(|v| v * v).sum();
    let n_obs = comp.n_obs(RowSet::Train);
    let mut out = Vec::with_capacity(pool.len());
    for cand in pool {
        problem.cancel().check()?;
        let cc = comp.columns(RowSet::Train, &term_columns(problem, &[*cand]));
        let orth = orthogonalise(&basis, &cc);
        let k = orth.basis.rank();
        let red = orth.basis.explained(&r);
        let sse1 = (sse0 - red).max(0.0);
        let df_den = n_obs.saturating_sub(basis.rank() + k);
        let f_test = if k == 0 {
            nested_f_test(sse0, sse0, 0, df_den)
        } else {
            nested_f_test(sse0, sse1, k, df_den)
        };
        out.push(Score {
            cand: *cand,
            rank: k,
            f_test,
            sse_full: sse1,
            sse_reduced: sse0,
            first_residual: orth.first_residual,
        });
    }
    Ok(out)
}

/// Scores of `pool` against `fit`.
pub fn score<P: Problem>(
    problem: &P,
    fit: &Fit<P::Term, P::Lin>,
    pool: &[P::Term],
) -> Result<Vec<Score<P::Term>>, Cancelled> {
    score_given(problem, fit, &[], pool)
}

/// `‖(I − P) s‖²` over the training rows for a signal column `s` of the compressed design
/// (P the projector on `fit`'s columns): the non-centrality of the F test of a candidate that
/// models the signal exactly.
pub fn orthogonal_energy<P: Problem>(
    problem: &P,
    fit: &Fit<P::Term, P::Lin>,
    signal: usize,
) -> f64 {
    let comp = &fit.compressed;
    let basis = Basis::of_design(&comp.columns(RowSet::Train, &term_columns(problem, &fit.terms)));
    let mut s = comp.column(RowSet::Train, signal);
    basis.project_out(&mut s);
    s.iter().map(|v| v * v).sum()
}

/// Cluster-robust (CR1 sandwich) Wald test that the last `k` coefficients of `fit` are zero,
/// from the per-cluster score sums `s_g = X_gᵀ r_g` the problem computes in one pass and the
/// training Gram `XᵀX = R_Sᵀ R_S` of the compressed design. `None` with fewer than 3 clusters.
pub fn cluster_robust<P: Problem>(
    problem: &P,
    fit: &Fit<P::Term, P::Lin>,
    k: usize,
) -> Result<Option<FTest>, Cancelled> {
    let p = fit.coef.len();
    if k == 0 || k > p {
        return Ok(None);
    }
    let sums = problem.cluster_sums(fit)?;
    Ok(cluster_robust_from_sums(problem, fit, k, &sums))
}

/// [`cluster_robust`] from per-cluster score sums the caller has already accumulated (in a
/// pass of its own over the rows, e.g. one it makes anyway; see
/// [`super::SelectOptions::defer_cluster_robust`]): one `Vec` of `fit.coef.len()` sums per
/// cluster that has training rows, as [`Problem::cluster_sums`] returns them.
pub fn cluster_robust_from_sums<P: Problem>(
    problem: &P,
    fit: &Fit<P::Term, P::Lin>,
    k: usize,
    sums: &[Vec<f64>],
) -> Option<FTest> {
    let p = fit.coef.len();
    if k == 0 || k > p {
        return None;
    }
    // The compressed (R-factor) columns have the training rows' XᵀX.
    let x = fit
        .compressed
        .columns(RowSet::Train, &term_columns(problem, &fit.terms));
    crate::stats::cluster_robust_wald_from_sums(&x, sums, &fit.coef, k)
}
