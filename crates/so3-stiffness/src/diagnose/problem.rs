//! The CSJM campaign as a [`Problem`] of the shared diagnosis engine
//! (`stiffness_core::engine`): its terms (the first-order block and the catalogue effects),
//! the per-component whitening of the moment observations, and the pass that compresses the
//! whitened design. Everything the selection decides is computed by the engine; what stays
//! here is CSJM-specific: predictions, residuals, the displacement error the report states,
//! the parameters' covariance (for standard errors and the connection-term test) and the
//! fraction of an effect's columns outside a model (the `linear_stiffness` alias).
//!
//! Each sample contributes three observations (the components of Δτ_k), divided by the noise
//! standard deviation σ̂_i of their component (estimated once, from the per-component
//! residuals of the baseline on the training rows), so that every model of one diagnosis is
//! fitted with the same objective and nested F tests compare like with like. The CSJM model
//! is linear in its parameters: the linearisation point is `()`.

use std::cell::OnceCell;
use std::ops::Range;
use std::sync::Arc;

use nalgebra::{DMatrix, Matrix3, Vector3};
use stiffness_core::engine::basis::Basis;
use stiffness_core::engine::{Compressed, CompressedAccumulator, Fit, Problem, RowSet};
use stiffness_core::lsq::{RankPolicy, ScaledSvd};
use stiffness_core::{Cancel, Cancelled};

use super::candidates::{push_columns, Effect, Samples, Term};

/// A fit of the engine on the CSJM problem.
pub(crate) type CsjmFit = Fit<Term, ()>;

/// Samples polled between two cancellation checks.
const CANCEL_EVERY: usize = 4096;

/// Every term of the design, in column order.
fn layout() -> impl Iterator<Item = Term> {
    std::iter::once(Term::Baseline).chain(Effect::ALL.into_iter().map(Term::Effect))
}

/// Data, noise weights and the train/test split of one diagnosis.
#[derive(Debug)]
pub(crate) struct CsjmProblem<'a> {
    pub samples: &'a Samples,
    /// 1/σ̂_i per moment component, 1/(N·m).
    pub weights: Vector3<f64>,
    /// Training samples (the reference among them), ascending.
    pub train: Vec<usize>,
    /// Held-out samples, ascending.
    pub test: Vec<usize>,
    /// Row set of each sample.
    sets: Vec<RowSet>,
    compressed: OnceCell<Arc<Compressed>>,
    cancel: Cancel,
}

impl<'a> CsjmProblem<'a> {
    /// The problem with unit weights; [`Self::with_noise_from_baseline`] sets the weights.
    pub fn new(samples: &'a Samples, train: Vec<usize>, test: Vec<usize>, cancel: Cancel) -> Self {
        let mut sets = vec![RowSet::Train; samples.len()];
        for &k in &test {
            sets[k] = RowSet::Test;
        }
        CsjmProblem {
            samples,
            weights: Vector3::repeat(1.0),
            train,
            test,
            sets,
            compressed: OnceCell::new(),
            cancel,
        }
    }

    /// The same problem whitened by the per-component noise level of the baseline's residuals
    /// on the training rows (a component without noise, as in synthetic data, keeps unit
    /// weight).
    pub fn with_noise_from_baseline(self) -> Result<Self, Cancelled> {
        let fit = stiffness_core::engine::fit::fit(&self, &[Term::Baseline], &())?;
        let residuals = self.residuals(&fit, &self.train);
        // 4 parameters (offset and a row of K_D) per component.
        let dof = self.train.len().saturating_sub(4).max(1) as f64;
        let sigma = Vector3::from_fn(|i, _| {
            (residuals.iter().map(|r| r[i] * r[i]).sum::<f64>() / dof).sqrt()
        });
        let weights = sigma.map(|s| {
            if s > 0.0 && s.is_finite() {
                1.0 / s
            } else {
                1.0
            }
        });
        Ok(CsjmProblem {
            weights,
            compressed: OnceCell::new(),
            ..self
        })
    }

    /// Noise standard deviation per component, N·m.
    pub fn sigma(&self) -> Vector3<f64> {
        self.weights.map(|w| 1.0 / w)
    }

    /// Number of columns of the compressed design (y included).
    fn ncols(&self) -> usize {
        layout().map(Term::n_columns).sum::<usize>() + 1
    }

    /// Columns of `terms` at displacement `zeta` with load-change signs `signs`.
    pub fn columns_at(
        &self,
        terms: &[Term],
        zeta: &Vector3<f64>,
        signs: &Vector3<f64>,
    ) -> Vec<Vector3<f64>> {
        let mut out = Vec::with_capacity(terms.iter().map(|t| t.n_columns()).sum());
        for t in terms {
            push_columns(*t, self.samples, zeta, signs, &mut out);
        }
        out
    }

    /// The model's Δτ (N·m) at displacement `zeta` with load-change signs `signs`.
    pub fn predict(
        &self,
        fit: &CsjmFit,
        zeta: &Vector3<f64>,
        signs: &Vector3<f64>,
    ) -> Vector3<f64> {
        self.columns_at(&fit.terms, zeta, signs)
            .iter()
            .zip(&fit.coef)
            .fold(Vector3::zeros(), |acc, (c, b)| acc + c * *b)
    }

    /// Unwhitened residuals Δτ_meas − Δτ_pred (N·m) of `rows`.
    pub fn residuals(&self, fit: &CsjmFit, rows: &[usize]) -> Vec<Vector3<f64>> {
        rows.iter()
            .map(|&k| {
                self.samples.dtau[k]
                    - self.predict(fit, &self.samples.zeta[k], &self.samples.signs[k])
            })
            .collect()
    }

    /// Index of the first coefficient of `term` in `fit`, if in the model.
    pub fn start_of(fit: &CsjmFit, term: Term) -> Option<usize> {
        let mut start = 0;
        for t in &fit.terms {
            if *t == term {
                return Some(start);
            }
            start += t.n_columns();
        }
        None
    }

    /// Offset c (N·m) and K_D (N·m/rad) of the baseline block (always the first term).
    pub fn offset_and_k_d(fit: &CsjmFit) -> (Vector3<f64>, Matrix3<f64>) {
        let b = &fit.coef;
        let c = Vector3::new(b[0], b[4], b[8]);
        let k_d = Matrix3::from_fn(|i, j| b[4 * i + 1 + j]);
        (c, k_d)
    }

    /// Covariance of `fit`'s coefficients, `s²(XᵀX)⁺` in the parameters' units, from the
    /// training factor of the compressed design with the engine's rank policy (columns scaled
    /// to unit norm, columns below `ZERO_COLUMN_RTOL` of the largest and singular values below
    /// `RANK_TOL·σ_max` dropped). `s²` is the training SSE over its residual degrees of
    /// freedom (NaN without any).
    pub fn covariance(&self, fit: &CsjmFit) -> DMatrix<f64> {
        let p = fit.coef.len();
        let cols = stiffness_core::engine::fit::term_columns(self, &fit.terms);
        let x = fit.compressed.columns(RowSet::Train, &cols);
        let Ok(svd) =
            ScaledSvd::of_columns(&x, &RankPolicy::DIAGNOSIS, false, "SVD of the CSJM design")
        else {
            return DMatrix::from_element(p, p, f64::NAN);
        };
        let n_obs = fit.compressed.n_obs(RowSet::Train);
        let sse = stiffness_core::engine::fit::sse(self, fit, RowSet::Train);
        let s2 = if n_obs > fit.rank {
            sse / (n_obs - fit.rank) as f64
        } else {
            f64::NAN
        };
        svd.covariance(s2)
    }

    /// Fraction of the (column-normalised, whitened) energy of `extra`'s columns on the
    /// training rows that lies outside the span of `model`'s columns at the fit's
    /// compressed design: near 0 means the effect is collinear with the model on these data.
    pub fn fraction_outside(&self, comp: &Compressed, model: &[Term], extra: Term) -> f64 {
        let mut basis = Basis::new();
        let cols = stiffness_core::engine::fit::term_columns(self, model);
        for c in comp.columns(RowSet::Train, &cols) {
            basis.push(&c);
        }
        let (mut total, mut outside) = (0.0, 0.0);
        for mut c in comp.columns(RowSet::Train, &self.columns(extra).collect::<Vec<_>>()) {
            let n2: f64 = c.iter().map(|v| v * v).sum();
            if n2 == 0.0 {
                continue;
            }
            basis.project_out(&mut c);
            total += 1.0;
            outside += c.iter().map(|v| v * v).sum::<f64>() / n2;
        }
        if total == 0.0 {
            0.0
        } else {
            outside / total
        }
    }

    /// The displacement Δζ (rad) the model predicts for the recorded load of sample `k`:
    /// solves model(Δζ) = Δτ_k by Newton's method (finite-difference Jacobian, at most 20
    /// steps) from the linear solution K_D⁻¹(Δτ − c). None when the model is singular there.
    pub fn predict_displacement(&self, fit: &CsjmFit, k: usize) -> Option<Vector3<f64>> {
        let target = self.samples.dtau[k];
        let signs = self.samples.signs[k];
        let (_, k_d) = Self::offset_and_k_d(fit);
        let mut z = k_d
            .lu()
            .solve(&(target - self.predict(fit, &Vector3::zeros(), &signs)))?;
        let h = 1e-6;
        for _ in 0..20 {
            let r = self.predict(fit, &z, &signs) - target;
            let jac = Matrix3::from_fn(|i, j| {
                let mut dz = Vector3::zeros();
                dz[j] = h;
                (self.predict(fit, &(z + dz), &signs)[i] - self.predict(fit, &(z - dz), &signs)[i])
                    / (2.0 * h)
            });
            let step = jac.lu().solve(&r)?;
            z -= step;
            if step.norm() < 1e-13 {
                break;
            }
        }
        z.iter().all(|v| v.is_finite()).then_some(z)
    }

    /// Mean over `rows` (the reference excluded) of ‖Δζ_pred − Δζ_meas‖/‖Δζ_meas‖.
    pub fn mean_rel_error(&self, fit: &CsjmFit, rows: &[usize]) -> f64 {
        let mut sum = 0.0;
        let mut n = 0usize;
        for &k in rows {
            let measured = self.samples.zeta[k];
            if k == 0 || measured.norm() == 0.0 {
                continue;
            }
            let err = match self.predict_displacement(fit, k) {
                Some(z) => (z - measured).norm() / measured.norm(),
                None => f64::INFINITY,
            };
            sum += err;
            n += 1;
        }
        if n == 0 {
            f64::NAN
        } else {
            sum / n as f64
        }
    }

    /// One pass over every sample: `visit(k, whitened columns of every term, whitened Δτ)`.
    fn for_each_sample(
        &self,
        mut visit: impl FnMut(usize, &[Vector3<f64>], &Vector3<f64>),
    ) -> Result<(), Cancelled> {
        let all: Vec<Term> = layout().collect();
        for k in 0..self.samples.len() {
            if k % CANCEL_EVERY == 0 {
                self.cancel.check()?;
            }
            let cols: Vec<Vector3<f64>> = self
                .columns_at(&all, &self.samples.zeta[k], &self.samples.signs[k])
                .iter()
                .map(|c| c.component_mul(&self.weights))
                .collect();
            visit(k, &cols, &self.samples.dtau[k].component_mul(&self.weights));
        }
        Ok(())
    }
}

impl Problem for CsjmProblem<'_> {
    type Term = Term;
    type Lin = ();

    fn columns(&self, term: Term) -> Range<usize> {
        let mut start = 0;
        for t in layout() {
            if t == term {
                return start..start + t.n_columns();
            }
            start += t.n_columns();
        }
        unreachable!("every term is in the layout")
    }

    fn observation_column(&self) -> usize {
        self.ncols() - 1
    }

    fn bilinear(&self, _term: Term) -> bool {
        false
    }

    fn compress(&self, _lin: &()) -> Result<Arc<Compressed>, Cancelled> {
        if let Some(c) = self.compressed.get() {
            return Ok(c.clone());
        }
        let p = self.ncols();
        let mut acc = CompressedAccumulator::new(p);
        let mut row = vec![0.0; p];
        self.for_each_sample(|k, cols, y| {
            for i in 0..3 {
                for (dst, c) in row.iter_mut().zip(cols) {
                    *dst = c[i];
                }
                row[p - 1] = y[i];
                acc.push(self.sets[k], &row)
                    .expect("rows have the layout's width");
            }
        })?;
        let c = Arc::new(acc.finish());
        Ok(self.compressed.get_or_init(|| c).clone())
    }

    fn relinearise(&self, _terms: &[Term], _coef: &[f64]) {}

    /// Clusters are samples: the three moment components of one sample share its pose and
    /// load, so the robust test does not assume them independent.
    fn cluster_sums(&self, fit: &CsjmFit) -> Result<Vec<Vec<f64>>, Cancelled> {
        let idx = stiffness_core::engine::fit::term_columns(self, &fit.terms);
        let mut sums = Vec::with_capacity(self.train.len());
        self.for_each_sample(|k, cols, y| {
            if self.sets[k] != RowSet::Train {
                return;
            }
            let pred = idx
                .iter()
                .zip(&fit.coef)
                .fold(Vector3::zeros(), |acc, (&c, b)| acc + cols[c] * *b);
            let r = y - pred;
            sums.push(idx.iter().map(|&c| cols[c].dot(&r)).collect());
        })?;
        Ok(sums)
    }

    fn cancel(&self) -> &Cancel {
        &self.cancel
    }
}
