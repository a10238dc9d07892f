//! Fitting and scoring: whitened weighted least squares of a model made of spring terms and
//! candidate terms, and nested-model scoring of candidates against a fit.

use nalgebra::{Matrix3, Matrix6, Vector3};

use super::candidates::{
    candidate_columns, compliance_map, spring_column, Candidate, Linearisation, RowKinematics,
};
use super::linalg::{orthogonalise, solve_columns, Basis};
use super::stats::{nested_f_test, FTest};
use crate::chain::SerialChain;

/// One term of a model: a linear spring (index into the 3n springs) or a candidate extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Term {
    /// A linear virtual spring.
    Spring(usize),
    /// A candidate extension.
    Cand(Candidate),
}

impl Term {
    fn n_columns(&self) -> usize {
        match self {
            Term::Spring(_) => 1,
            Term::Cand(c) => c.n_columns(),
        }
    }
}

/// A fitted model.
#[derive(Debug, Clone)]
pub struct Fit {
    /// Terms in order.
    pub terms: Vec<Term>,
    /// Coefficients, one per column, in term order.
    pub coef: Vec<f64>,
    /// The linearisation point the final columns were built at.
    pub lin: Linearisation,
    /// Predicted displacement of every row (train and test), m.
    pub pred: Vec<[f64; 3]>,
    /// Numerical rank of the whitened training design.
    #[allow(dead_code)]
    pub rank: usize,
    /// Per coefficient: `false` when its column is zero up to rounding on these data (the
    /// coefficient is 0 and is not an estimate).
    pub in_data: Vec<bool>,
}

impl Fit {
    /// Number of parameters (columns).
    pub fn n_params(&self) -> usize {
        self.terms.iter().map(|t| t.n_columns()).sum()
    }
}

/// Score of one candidate against a fit.
#[derive(Debug, Clone)]
pub struct Score {
    /// The candidate.
    pub cand: Candidate,
    /// Rank of its columns outside the model (0 = not testable).
    pub rank: usize,
    /// The F test (p = 1 when not testable).
    pub f_test: FTest,
    /// Whitened training SSE with the candidate added.
    pub sse_full: f64,
    /// Whitened training SSE of the model alone.
    pub sse_reduced: f64,
    /// The candidate's first column after projecting out the model (for alias cosines).
    pub first_residual: Vec<f64>,
}

/// Precomputed rows, split and noise model.
#[derive(Debug)]
pub struct Engine<'a> {
    pub chain: &'a SerialChain,
    pub kin: Vec<RowKinematics>,
    pub train: Vec<usize>,
    pub test: Vec<usize>,
    pub tau_scale: Vec<f64>,
    /// Per row: L⁻¹ with Σ = L Lᵀ the displacement noise covariance.
    pub white: Vec<Matrix3<f64>>,
    /// Per row: √diag Σ, m.
    pub sigma_axis: Vec<[f64; 3]>,
    pub m: usize,
    /// Polled per candidate while scoring: once cancelled, scoring stops early (the result is
    /// incomplete) and the caller returns `Cancelled` at its next check.
    pub cancel: stiffness_core::Cancel,
}

impl<'a> Engine<'a> {
    /// The linearisation point for compliances `c` (3n).
    pub fn linearisation(&self, c: Vec<f64>) -> Linearisation {
        let spring_prediction = self
            .kin
            .iter()
            .map(|row| {
                let g = compliance_map(row, &c);
                let w = &row.wrench;
                std::array::from_fn(|r| (0..6).map(|k| g[(r, k)] * w[k]).sum())
            })
            .collect();
        Linearisation {
            compliance: c,
            spring_prediction,
        }
    }

    /// Sets the per-row noise covariance Σ_i = σ_d² I + G Σ_W Gᵀ with G = J_t |C| Jᵀ: tracker noise
    /// plus the force-sensor noise propagated through the compliance `c`.
    pub fn set_noise(&mut self, sigma_d: f64, sigma_w: &[f64; 6], c: &[f64]) {
        let cabs: Vec<f64> = c.iter().map(|v| v.abs()).collect();
        let sw = Matrix6::from_diagonal(&nalgebra::Vector6::from_iterator(
            sigma_w.iter().map(|s| s * s),
        ));
        self.white.clear();
        self.sigma_axis.clear();
        for row in &self.kin {
            let g = compliance_map(row, &cabs);
            let g = nalgebra::Matrix3x6::from_fn(|r, k| g[(r, k)]);
            let sigma = Matrix3::identity() * (sigma_d * sigma_d) + g * sw * g.transpose();
            let w = match sigma.cholesky() {
                Some(ch) => ch
                    .l()
                    .try_inverse()
                    .unwrap_or_else(|| Matrix3::identity() / sigma_d),
                None => Matrix3::identity() / sigma_d,
            };
            self.white.push(w);
            self.sigma_axis.push([
                sigma[(0, 0)].sqrt(),
                sigma[(1, 1)].sqrt(),
                sigma[(2, 2)].sqrt(),
            ]);
        }
    }

    fn term_columns(&self, term: &Term, i: usize, lin: &Linearisation) -> Vec<[f64; 3]> {
        match term {
            Term::Spring(s) => vec![spring_column(&self.kin[i], *s)],
            Term::Cand(c) => {
                candidate_columns(self.chain, c, &self.kin[i], i, lin, &self.tau_scale)
            }
        }
    }

    fn whiten(&self, i: usize, v: [f64; 3]) -> [f64; 3] {
        let w = self.white[i] * Vector3::new(v[0], v[1], v[2]);
        [w.x, w.y, w.z]
    }

    /// Whitened columns of `terms` over `rows` (3 entries per row).
    pub fn design(&self, terms: &[Term], rows: &[usize], lin: &Linearisation) -> Vec<Vec<f64>> {
        let p: usize = terms.iter().map(|t| t.n_columns()).sum();
        let mut cols = vec![Vec::with_capacity(3 * rows.len()); p];
        for &i in rows {
            let mut k = 0;
            for t in terms {
                for c in self.term_columns(t, i, lin) {
                    let w = self.whiten(i, c);
                    cols[k].extend_from_slice(&w);
                    k += 1;
                }
            }
        }
        cols
    }

    /// Whitened measurements over `rows`.
    pub fn observations(&self, rows: &[usize]) -> Vec<f64> {
        rows.iter()
            .flat_map(|&i| self.whiten(i, self.kin[i].displacement))
            .collect()
    }

    /// Fits `terms` on the training rows. Models with bilinear candidates are re-linearised
    /// at the new compliances and refitted until the coefficients settle (at most 6 passes).
    pub fn fit(&self, terms: &[Term], lin0: &Linearisation) -> Fit {
        let bilinear = terms
            .iter()
            .any(|t| matches!(t, Term::Cand(c) if c.bilinear()));
        let passes = if bilinear { 6 } else { 1 };
        let y = self.observations(&self.train);
        let mut lin = lin0.clone();
        let mut coef = Vec::new();
        let mut rank = 0;
        let mut in_data = Vec::new();
        for pass in 0..passes {
            let cols = self.design(terms, &self.train, &lin);
            let sol = solve_columns(&cols, &y);
            let beta = sol.beta;
            rank = sol.rank;
            in_data = sol.in_data;
            let mut c = vec![0.0; self.m];
            let mut k = 0;
            for t in terms {
                if let Term::Spring(s) = t {
                    c[*s] = beta[k];
                }
                k += t.n_columns();
            }
            let settled = !coef.is_empty()
                && beta.iter().zip(&coef).all(|(a, b): (&f64, &f64)| {
                    (a - b).abs() <= 1e-9 * (a.abs() + b.abs()) + 1e-300
                });
            coef = beta;
            if pass + 1 == passes || settled {
                break;
            }
            lin = self.linearisation(c);
        }
        let pred = (0..self.kin.len())
            .map(|i| {
                let mut p = [0.0; 3];
                let mut k = 0;
                for t in terms {
                    for c in self.term_columns(t, i, &lin) {
                        for r in 0..3 {
                            p[r] += coef[k] * c[r];
                        }
                        k += 1;
                    }
                }
                p
            })
            .collect();
        Fit {
            terms: terms.to_vec(),
            coef,
            lin,
            pred,
            rank,
            in_data,
        }
    }

    /// The compliances (3n) of the spring terms of a fit.
    pub fn compliances(&self, fit: &Fit) -> Vec<f64> {
        let mut c = vec![0.0; self.m];
        let mut k = 0;
        for t in &fit.terms {
            if let Term::Spring(s) = t {
                c[*s] = fit.coef[k];
            }
            k += t.n_columns();
        }
        c
    }

    /// Whitened SSE of a fit's predictions over `rows`.
    pub fn sse(&self, fit: &Fit, rows: &[usize]) -> f64 {
        rows.iter()
            .map(|&i| {
                let d = self.kin[i].displacement;
                let p = fit.pred[i];
                let r = self.whiten(i, [d[0] - p[0], d[1] - p[1], d[2] - p[2]]);
                r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
            })
            .sum()
    }

    /// Mean relative translation error ‖d_pred − d‖/‖d‖ over `rows`.
    pub fn mean_rel_error(&self, fit: &Fit, rows: &[usize]) -> f64 {
        // Rows with zero measured displacement have no relative error (0/0); they are left out
        // rather than counted as perfect. NaN when no row is left.
        let (sum, count) = rows
            .iter()
            .filter_map(|&i| {
                let d = self.kin[i].displacement;
                let p = fit.pred[i];
                let e =
                    ((d[0] - p[0]).powi(2) + (d[1] - p[1]).powi(2) + (d[2] - p[2]).powi(2)).sqrt();
                let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                (n > 0.0).then_some(e / n)
            })
            .fold((0.0, 0usize), |(s, c), r| (s + r, c + 1));
        if count == 0 {
            f64::NAN
        } else {
            sum / count as f64
        }
    }

    /// Nested-model scores of every candidate in `pool` against `fit` on the training rows.
    pub fn score(&self, fit: &Fit, pool: &[Candidate]) -> Vec<Score> {
        self.score_given(fit, &[], pool)
    }

    /// Scores of `pool` against `fit` with the candidates `given` added to the model (their
    /// columns at `fit`'s linearisation point).
    pub fn score_given(&self, fit: &Fit, given: &[Candidate], pool: &[Candidate]) -> Vec<Score> {
        let mut terms = fit.terms.clone();
        terms.extend(given.iter().map(|c| Term::Cand(*c)));
        let cols = self.design(&terms, &self.train, &fit.lin);
        let mut basis = Basis::new();
        for c in &cols {
            basis.push(c);
        }
        let y = self.observations(&self.train);
        let mut r = y.clone();
        basis.project_out(&mut r);
        let sse0: f64 = r.iter().map(|v| v * v).sum();
        let n_obs = y.len();
        pool.iter()
            .take_while(|_| !self.cancel.is_cancelled())
            .map(|cand| {
                let cc = self.design(&[Term::Cand(*cand)], &self.train, &fit.lin);
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
                Score {
                    cand: *cand,
                    rank: k,
                    f_test,
                    sse_full: sse1,
                    sse_reduced: sse0,
                    first_residual: orth.first_residual,
                }
            })
            .collect()
    }
}

impl Engine<'_> {
    /// `‖(I − P) W s‖²` over the training rows, P the projector on `fit`'s whitened columns.
    pub fn orthogonal_energy(&self, fit: &Fit, signal: &[[f64; 3]]) -> f64 {
        let cols = self.design(&fit.terms, &self.train, &fit.lin);
        let mut basis = Basis::new();
        for c in &cols {
            basis.push(c);
        }
        let mut s: Vec<f64> = self
            .train
            .iter()
            .flat_map(|&i| self.whiten(i, signal[i]))
            .collect();
        basis.project_out(&mut s);
        s.iter().map(|v| v * v).sum()
    }
}

impl Engine<'_> {
    /// Cluster-robust (pose-clustered, CR1 sandwich) Wald test that the last `k` coefficients
    /// of `fit` are zero, on the training rows: `W = βᵀ V⁻¹ β / k` against F(k, G − 1), with
    /// `V = B (Σ_g s_g s_gᵀ) B · G/(G − 1)`, `B = (XᵀX)⁺`, `s_g = X_gᵀ r_g` summed over pose g.
    /// It does not assume independence within a pose, so it checks a finding against
    /// within-pose correlation of the residuals. `None` with fewer than 3 poses.
    pub fn cluster_robust(&self, fit: &Fit, groups: &[usize], k: usize) -> Option<FTest> {
        let cols = self.design(&fit.terms, &self.train, &fit.lin);
        let p = cols.len();
        if k == 0 || k > p {
            return None;
        }
        let n = 3 * self.train.len();
        let x = nalgebra::DMatrix::from_fn(n, p, |i, j| cols[j][i]);
        let y = nalgebra::DVector::from_vec(self.observations(&self.train));
        let beta = nalgebra::DVector::from_column_slice(&fit.coef);
        let r = &y - &x * &beta;
        // One cluster id per observation (3 per row).
        let cluster: Vec<usize> = self.train.iter().flat_map(|&i| [groups[i]; 3]).collect();
        super::stats::cluster_robust_wald(&x, &r, &beta, &cluster, k)
    }
}
