//! Weighted least squares on the stacked moment components.
//!
//! Each sample contributes three observations (the components of Δτ_k), divided by the noise
//! standard deviation σ̂_i of their component (estimated once, from the per-component
//! residuals of the baseline on the training rows) so that every model of one diagnosis is
//! fitted with the same objective and nested F tests compare like with like. Columns are
//! scaled to unit norm and solved by SVD with a relative rank tolerance, so collinear columns
//! (e.g. a hysteresis offset that duplicates the constant offset) lower the rank instead of
//! blowing up the solve; the F tests use the ranks.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use super::candidates::{push_columns, Samples, Term};

/// Singular values below this fraction of the largest count as zero.
const RANK_TOLERANCE: f64 = 1e-10;

/// A fitted model.
#[derive(Debug, Clone)]
pub(crate) struct Fit {
    pub terms: Vec<Term>,
    pub beta: Vec<f64>,
    /// Covariance of β, s²(XᵀX)⁺ in whitened units.
    pub cov: DMatrix<f64>,
    /// Whitened SSE on the fitted rows.
    pub sse: f64,
    /// Rank of the design.
    pub rank: usize,
    /// Number of observations (3 per sample).
    pub n_obs: usize,
}

impl Fit {
    /// Residual degrees of freedom.
    pub fn dof(&self) -> usize {
        self.n_obs.saturating_sub(self.rank)
    }

    /// Offset c (N·m) and K_D (N·m/rad) of the baseline block (always the first term).
    pub fn offset_and_k_d(&self) -> (Vector3<f64>, Matrix3<f64>) {
        let b = &self.beta;
        let c = Vector3::new(b[0], b[4], b[8]);
        let k_d = Matrix3::from_fn(|i, j| b[4 * i + 1 + j]);
        (c, k_d)
    }

    /// Index of the first column of `term`, if in the model.
    pub fn start_of(&self, term: Term) -> Option<usize> {
        let mut start = 0;
        for t in &self.terms {
            if *t == term {
                return Some(start);
            }
            start += t.n_columns();
        }
        None
    }
}

/// Data, noise weights and the train/test split of one diagnosis.
#[derive(Debug, Clone)]
pub(crate) struct Engine<'a> {
    pub samples: &'a Samples,
    /// 1/σ̂_i per moment component, 1/(N·m).
    pub weights: Vector3<f64>,
    pub train: Vec<usize>,
    pub test: Vec<usize>,
}

impl<'a> Engine<'a> {
    pub fn new(samples: &'a Samples, train: Vec<usize>, test: Vec<usize>) -> Self {
        let mut engine = Engine {
            samples,
            weights: Vector3::repeat(1.0),
            train,
            test,
        };
        // Per-component noise level from the baseline's residuals on the training rows.
        let fit = engine.fit(&[Term::Baseline], &engine.train.clone());
        let residuals = engine.residuals(&fit, &engine.train);
        let dof = (engine.train.len().saturating_sub(4)).max(1) as f64;
        let sigma = Vector3::from_fn(|i, _| {
            (residuals.iter().map(|r| r[i] * r[i]).sum::<f64>() / dof).sqrt()
        });
        // A component without noise (synthetic data) keeps unit weight.
        engine.weights = sigma.map(|s| {
            if s > 0.0 && s.is_finite() {
                1.0 / s
            } else {
                1.0
            }
        });
        engine
    }

    /// Noise standard deviation per component, N·m (from the baseline, training rows).
    pub fn sigma(&self) -> Vector3<f64> {
        self.weights.map(|w| 1.0 / w)
    }

    pub fn columns(
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

    fn design(&self, terms: &[Term], rows: &[usize]) -> (DMatrix<f64>, DVector<f64>) {
        let p: usize = terms.iter().map(|t| t.n_columns()).sum();
        let mut x = DMatrix::zeros(3 * rows.len(), p);
        let mut y = DVector::zeros(3 * rows.len());
        for (r, &k) in rows.iter().enumerate() {
            let cols = self.columns(terms, &self.samples.zeta[k], &self.samples.signs[k]);
            for i in 0..3 {
                let w = self.weights[i];
                y[3 * r + i] = w * self.samples.dtau[k][i];
                for (j, c) in cols.iter().enumerate() {
                    x[(3 * r + i, j)] = w * c[i];
                }
            }
        }
        (x, y)
    }

    /// Least-squares fit of `terms` on `rows`.
    pub fn fit(&self, terms: &[Term], rows: &[usize]) -> Fit {
        let (mut x, y) = self.design(terms, rows);
        let (m, p) = x.shape();
        let scale: Vec<f64> = (0..p)
            .map(|j| {
                let n = x.column(j).norm();
                if n > 0.0 {
                    n
                } else {
                    1.0
                }
            })
            .collect();
        for (j, s) in scale.iter().enumerate() {
            x.column_mut(j).scale_mut(1.0 / s);
        }
        let svd = x.clone().svd(true, true);
        let (Some(u), Some(v_t)) = (svd.u.as_ref(), svd.v_t.as_ref()) else {
            unreachable!("SVD computed with u and v_t")
        };
        let s = &svd.singular_values;
        let s_max = s.iter().copied().fold(0.0, f64::max);
        let keep: Vec<usize> = (0..s.len())
            .filter(|&k| s[k] > RANK_TOLERANCE * s_max && s[k].is_finite())
            .collect();
        let rank = keep.len();
        let mut beta_scaled = DVector::zeros(p);
        for &k in &keep {
            let coef = u.column(k).dot(&y) / s[k];
            beta_scaled += v_t.row(k).transpose() * coef;
        }
        let fitted = &x * &beta_scaled;
        let sse = (&y - fitted).norm_squared();
        let s2 = if m > rank {
            sse / (m - rank) as f64
        } else {
            f64::NAN
        };
        let mut cov = DMatrix::zeros(p, p);
        for &k in &keep {
            let vk = v_t.row(k).transpose();
            cov += (&vk * vk.transpose()) * (s2 / (s[k] * s[k]));
        }
        for i in 0..p {
            for j in 0..p {
                cov[(i, j)] /= scale[i] * scale[j];
            }
        }
        let beta = (0..p).map(|j| beta_scaled[j] / scale[j]).collect();
        Fit {
            terms: terms.to_vec(),
            beta,
            cov,
            sse,
            rank,
            n_obs: m,
        }
    }

    /// The model's Δτ (N·m) at displacement `zeta` with load-change signs `signs`.
    pub fn predict(&self, fit: &Fit, zeta: &Vector3<f64>, signs: &Vector3<f64>) -> Vector3<f64> {
        self.columns(&fit.terms, zeta, signs)
            .iter()
            .zip(&fit.beta)
            .fold(Vector3::zeros(), |acc, (c, b)| acc + c * *b)
    }

    /// Unwhitened residuals Δτ_meas − Δτ_pred (N·m) of `rows`.
    pub fn residuals(&self, fit: &Fit, rows: &[usize]) -> Vec<Vector3<f64>> {
        rows.iter()
            .map(|&k| {
                self.samples.dtau[k]
                    - self.predict(fit, &self.samples.zeta[k], &self.samples.signs[k])
            })
            .collect()
    }

    /// Whitened SSE of `rows`.
    pub fn sse(&self, fit: &Fit, rows: &[usize]) -> f64 {
        self.residuals(fit, rows)
            .iter()
            .map(|r| r.component_mul(&self.weights).norm_squared())
            .sum()
    }

    /// The displacement Δζ (rad) the model predicts for the recorded load of sample `k`:
    /// solves model(Δζ) = Δτ_k by Newton's method (finite-difference Jacobian) from the
    /// linear solution K_D⁻¹(Δτ − c). None when the model is singular there.
    pub fn predict_displacement(&self, fit: &Fit, k: usize) -> Option<Vector3<f64>> {
        let target = self.samples.dtau[k];
        let signs = self.samples.signs[k];
        let (_, k_d) = fit.offset_and_k_d();
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
    pub fn mean_rel_error(&self, fit: &Fit, rows: &[usize]) -> f64 {
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

    /// Fraction of the (column-normalised, whitened) energy of `extra`'s columns on the
    /// training rows that lies outside the span of `model`'s columns: near 0 means the
    /// candidate is collinear with the model on these data (aliased with it).
    pub fn fraction_outside(&self, model: &[Term], extra: Term) -> f64 {
        let (x, _) = self.design(model, &self.train);
        let (e, _) = self.design(&[extra], &self.train);
        let svd = x.clone().svd(true, false);
        let Some(u) = svd.u.as_ref() else {
            return f64::NAN;
        };
        let s = &svd.singular_values;
        let s_max = s.iter().copied().fold(0.0, f64::max);
        let basis: Vec<usize> = (0..s.len()).filter(|&k| s[k] > 1e-9 * s_max).collect();
        let (mut total, mut outside) = (0.0, 0.0);
        for j in 0..e.ncols() {
            let col = e.column(j);
            let norm2 = col.norm_squared();
            if norm2 == 0.0 {
                continue;
            }
            let mut r = col.clone_owned();
            for &k in &basis {
                let uk = u.column(k);
                r -= uk * uk.dot(&col);
            }
            total += 1.0;
            outside += r.norm_squared() / norm2;
        }
        if total == 0.0 {
            0.0
        } else {
            outside / total
        }
    }
}
