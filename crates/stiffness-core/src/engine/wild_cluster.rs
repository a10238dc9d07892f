//! A nested test whose p-value comes from a wild cluster bootstrap, for when the rows' noise
//! level is not known and the F distribution does not hold.
//!
//! The F test of a block of columns assumes the whitened residuals are homoscedastic. When the
//! whitening is only an assumption (the noise level not given), their variance can follow the
//! pose — a force sensor's noise propagated through each pose's Jacobian — with the same
//! structure as a block's columns, and the F test's p-value is then too small on clean data.
//!
//! The test here is the cluster-robust Wald statistic of the block (clusters: groups of rows
//! whose noise may be correlated, the caller's choice), its
//! distribution under the null drawn by the restricted wild cluster bootstrap (WCR: the
//! restricted model's residuals, each cluster's multiplied by one random weight, refitted).
//! Every draw keeps each cluster's residual covariance as it is, so the reference follows
//! whatever the noise is within and between clusters; the Wald statistic is studentized, so a
//! block that carries real structure is not hidden by the structure inflating the draws (the
//! F ratio under WCR lost most of its power that way: p ≈ 1e-4…1e-2 where F's was 1e-20).
//!
//! # How it is computed
//! All from a triangular factor R of the whitened rows (columns `full` ⊇ `model`, and y) and
//! per-cluster moments, never from the rows again. Orthonormal coordinates `c = T Xᵀ e` of
//! any residual vector e are built from R: the model's columns (column-scaled SVD, the engine's
//! [`RANK_TOL`]) first, then the block's columns with the model projected out (`R_B − R₀ Γ`,
//! Γ their least-squares coefficients on the model). Per cluster g, over its rows,
//! `t_g = Σ z e₀` and `A_g = Σ z_B zᵀ` with `z = T x` (x a whitened row, e₀ its restricted
//! residual). A draw with weights `v_g` has coordinates `c = Σ v_g t_g`; the full model's
//! residual of the draw has block scores `u_g = v_g t_{g,B} − A_g c` in cluster g; the Wald
//! statistic is `c_Bᵀ (Σ u_g u_gᵀ)⁻¹ c_B`. The observed statistic is the draw with every
//! `v_g = 1`. A draw costs O(G · q · r) (G clusters, q the block's rank, r the full rank);
//! draws are evaluated in batches, each a matrix product over the stacked `A_g`.

use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::basis::{dot, norm, zero_norm, RANK_TOL};
use crate::lsq::{RankPolicy, ScaledSvd, TriangularFactor};

/// Draws in the first round; more are drawn only when the p-value is small.
const FIRST_DRAWS: usize = 999;
/// All draws when the first round gives p below [`EXTEND_BELOW`].
const ALL_DRAWS: usize = 1_999;
/// The first round's p under which the bootstrap draws on.
const EXTEND_BELOW: f64 = 0.05;

/// Most clusters the test keeps moments for (`r + q·r` numbers each, ≈ 4 KiB on a 7-joint
/// arm's angle block): more rows are grouped into this many clusters by the caller
/// ([`WildClusterTest::moments`] returns `None` above it). A draw costs O(G · q · r), and the
/// covariance of a block of rank q ≤ 14 (2n on a 7-joint arm) needs G ≫ q, not more: at 1024
/// clusters the bootstrap made a diagnosis of 2000 rows 0.14 s instead of 0.03 s (Panda, a
/// hidden tilt, noise not given / given).
pub const MAX_CLUSTERS: usize = 256;

/// Webb's six-point weights (±√½, ±1, ±√(3/2), equally likely): mean 0, variance 1, and
/// 6^G distinct draws, where Rademacher's ±1 has only 2^G on few clusters.
const WEBB: [f64; 6] = [
    -1.224_744_871_391_589,
    -1.0,
    -std::f64::consts::FRAC_1_SQRT_2,
    std::f64::consts::FRAC_1_SQRT_2,
    1.0,
    1.224_744_871_391_589,
];

/// The pseudo-inverse of a set of columns (length P each) from their column-scaled SVD
/// `A D = U Σ Vᵀ` under the diagnosis' rank policy ([`crate::lsq::ScaledSvd`]), kept as its
/// factors: the coordinates need them, not only a solution. `zero`: columns of this norm or
/// less are not in the data.
struct Pseudoinverse {
    /// Columns.
    p: usize,
    /// Per kept singular value k: `D V_k / σ_k` (length p).
    w: Vec<Vec<f64>>,
    /// Per kept singular value: `U_k` (length P).
    u: Vec<Vec<f64>>,
}

impl Pseudoinverse {
    fn of(columns: &[Vec<f64>], zero: f64) -> Self {
        let p = columns.len();
        let np = columns.first().map_or(0, Vec::len);
        let mut out = Pseudoinverse {
            p,
            w: Vec::new(),
            u: Vec::new(),
        };
        if p == 0 || np == 0 {
            return out;
        }
        // Only non-finite columns fail to converge (the data are finite-checked on entry):
        // nothing is in their span.
        let Ok(svd) = ScaledSvd::of_columns_in(
            columns,
            zero,
            &RankPolicy::DIAGNOSIS,
            true,
            "SVD of the wild cluster test's columns",
        ) else {
            return out;
        };
        for (s, u, v) in svd.kept_triplets() {
            out.w.push(v.iter().map(|x| x / s).collect());
            out.u.push(u.clone());
        }
        out
    }

    fn rank(&self) -> usize {
        self.w.len()
    }

    /// The least-squares coefficients of a column `b` (length P) on the columns.
    fn solve(&self, b: &[f64]) -> Vec<f64> {
        let mut x = vec![0.0; self.p];
        for (w, u) in self.w.iter().zip(&self.u) {
            let ub = dot(u, b);
            for (xj, wj) in x.iter_mut().zip(w) {
                *xj += wj * ub;
            }
        }
        x
    }
}

/// The wild cluster bootstrap test of a block (see the module's documentation): built from
/// the factor, then fed the rows' moments per cluster, then drawn.
#[derive(Debug, Clone)]
pub struct WildClusterTest {
    /// r × p, row-major (p = `full.len()`): the coordinates' map, model rows first.
    t: Vec<f64>,
    p: usize,
    r0: usize,
    q: usize,
    /// The restricted fit's coefficients, in the order of `model`.
    restricted: Vec<f64>,
}

impl WildClusterTest {
    /// The test of `model` against `full` (columns of `factor`, `model` ⊆ `full`; `y` the
    /// observation column), `factor` a triangular factor of the whitened training rows.
    pub fn new(factor: &TriangularFactor, model: &[usize], full: &[usize], y: usize) -> Self {
        let np = factor.ncols();
        let col = |k: usize| -> Vec<f64> { (0..np).map(|i| factor.r()[i * np + k]).collect() };
        let p = full.len();
        let zero = zero_norm(&full.iter().map(|&k| col(k)).collect::<Vec<_>>());
        let pos = |c: usize| {
            full.iter()
                .position(|&f| f == c)
                .expect("the model's columns are in the full model")
        };
        let pos0: Vec<usize> = model.iter().map(|&c| pos(c)).collect();
        let pos_b: Vec<usize> = (0..p).filter(|k| !pos0.contains(k)).collect();
        let model_cols: Vec<Vec<f64>> = model.iter().map(|&k| col(k)).collect();
        let svd0 = Pseudoinverse::of(&model_cols, zero);
        let restricted = svd0.solve(&col(y));
        // The block's columns with the model projected out, Γ their coefficients on it; a
        // column whose part outside the model is below RANK_TOL of its norm adds nothing.
        let mut gamma = Vec::with_capacity(pos_b.len());
        let mut perp = Vec::with_capacity(pos_b.len());
        for &k in &pos_b {
            let b = col(full[k]);
            let g = svd0.solve(&b);
            let mut r = b.clone();
            for (gj, c) in g.iter().zip(&model_cols) {
                for (ri, ci) in r.iter_mut().zip(c) {
                    *ri -= gj * ci;
                }
            }
            let kept = norm(&b) > zero && norm(&r) > RANK_TOL * norm(&b);
            if !kept {
                r.fill(0.0);
            }
            gamma.push(g);
            perp.push(r);
        }
        let svd_b = Pseudoinverse::of(&perp, 0.0);
        let (r0, q) = (svd0.rank(), svd_b.rank());
        let mut t = vec![0.0; (r0 + q) * p];
        for (a, w) in svd0.w.iter().enumerate() {
            for (j, &k) in pos0.iter().enumerate() {
                t[a * p + k] = w[j];
            }
        }
        for (a, w) in svd_b.w.iter().enumerate() {
            let row = &mut t[(r0 + a) * p..(r0 + a + 1) * p];
            for (kb, &k) in pos_b.iter().enumerate() {
                row[k] = w[kb];
                // c_B = W (s_B − Γᵀ s₀): the model's scores enter with −Γ w.
                for (j, &k0) in pos0.iter().enumerate() {
                    row[k0] -= gamma[kb][j] * w[kb];
                }
            }
        }
        WildClusterTest {
            t,
            p,
            r0,
            q,
            restricted,
        }
    }

    /// The restricted fit's least-squares coefficients, in the order of `model` (a column not
    /// in the data, or in the span of the others, gets a coefficient that changes no
    /// prediction): every row's residual `y − X_model b` is what the moments are fed.
    pub fn restricted_coefficients(&self) -> &[f64] {
        &self.restricted
    }

    /// The block's rank outside the model (the Wald statistic's degrees of freedom).
    pub fn block_rank(&self) -> usize {
        self.q
    }

    /// The observed statistic: the block's cluster-robust (CR0) Wald statistic from the full
    /// model's residuals; `None` as for [`Self::p_value`].
    pub fn statistic(&self, moments: &ClusterMoments) -> Option<f64> {
        self.batch(moments)?.observed()
    }

    /// The draws' buffers over the clusters with rows; `None` when the block adds nothing
    /// outside the model or those clusters are too few for its covariance (at most its rank).
    fn batch(&self, moments: &ClusterMoments) -> Option<Batch> {
        let used = moments.used_clusters();
        (self.q > 0 && used.len() > self.q).then(|| Batch::new(moments, &used))
    }

    /// The Wald statistics of bootstrap draws with the given weights: per draw, one weight per
    /// cluster that has rows, in cluster order. `None` for a draw whose covariance is singular
    /// or whose weights are not one per such cluster, and for every draw where
    /// [`Self::p_value`] is `None`. [`Self::p_value`] draws its own weights; this is for checks
    /// of the draws against other code.
    pub fn draw_statistics(
        &self,
        moments: &ClusterMoments,
        draws: &[Vec<f64>],
    ) -> Vec<Option<f64>> {
        let Some(mut batch) = self.batch(moments) else {
            return vec![None; draws.len()];
        };
        let g = batch.w.nrows();
        let mut out = Vec::with_capacity(draws.len());
        for chunk in draws.chunks(BATCH) {
            for (k, w) in chunk.iter().enumerate() {
                let dst = batch.weights_mut(k);
                if w.len() == dst.len() {
                    dst.copy_from_slice(w);
                } else {
                    dst.fill(0.0);
                }
            }
            let walds = batch.walds(chunk.len());
            out.extend(
                chunk
                    .iter()
                    .zip(walds)
                    .map(|(w, s)| s.filter(|_| w.len() == g)),
            );
        }
        out
    }

    /// Empty moments for clusters `0..n_clusters`; `None` above [`MAX_CLUSTERS`].
    pub fn moments(&self, n_clusters: usize) -> Option<ClusterMoments> {
        (n_clusters <= MAX_CLUSTERS).then(|| {
            let r = self.r0 + self.q;
            ClusterMoments {
                r,
                q: self.q,
                t: vec![0.0; n_clusters * r],
                a: vec![0.0; n_clusters * self.q * r],
                used: vec![false; n_clusters],
                z: vec![0.0; r],
            }
        })
    }

    /// The p-value, `None` when the block adds nothing outside the model or the clusters with
    /// rows are too few for its covariance (at most its rank).
    ///
    /// Webb weights from `seed`; 999 draws, 1,999 when the first 999 give p < 0.05. With at
    /// least 10 draws at or above the observed statistic, p = (1 + their number) /
    /// (1 + draws). Beyond the draws' reach — a Benjamini–Hochberg family of ~70 candidates at
    /// 1 % decides at ~1e-4 — the tail is read from a scaled F(q, ν) whose mean and variance
    /// are the draws' (ν from the variance-to-mean² ratio; a statistic as light-tailed as χ²_q
    /// gets ν = ∞): the draws calibrate the reference, the reference extends it.
    pub fn p_value(&self, moments: &ClusterMoments, seed: u64) -> Option<f64> {
        let mut batch = self.batch(moments)?;
        let observed = batch.observed()?;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut draws: Vec<f64> = Vec::with_capacity(ALL_DRAWS);
        let mut at_least = 0usize;
        for target in [FIRST_DRAWS, ALL_DRAWS] {
            while draws.len() < target {
                // Weights drawn draw by draw, cluster by cluster: the stream does not depend on
                // the batch size.
                let d = BATCH.min(target - draws.len());
                for k in 0..d {
                    for w in batch.weights_mut(k) {
                        *w = WEBB[rng.random_range(0..WEBB.len())];
                    }
                }
                for w in batch.walds(d) {
                    // A draw whose covariance is singular counts as at least as large (the
                    // conservative side); ties within rounding too.
                    let w = w.unwrap_or(f64::INFINITY);
                    if w >= observed * (1.0 - 1e-12) {
                        at_least += 1;
                    }
                    draws.push(w);
                }
            }
            if (1 + at_least) as f64 / (1 + draws.len()) as f64 >= EXTEND_BELOW {
                break;
            }
        }
        let p_draws = (1 + at_least) as f64 / (1 + draws.len()) as f64;
        if at_least >= RESOLVED {
            return Some(p_draws);
        }
        Some(scaled_f_tail(&draws, observed, self.q as f64).min(p_draws))
    }
}

/// Draws at or above the observed statistic from which the bootstrap's own p is used.
const RESOLVED: usize = 10;

/// `P(X ≥ x)` for X a scaled F(q, ν) with the mean and variance of `draws` (infinite draws, from
/// a singular covariance, left out).
fn scaled_f_tail(draws: &[f64], x: f64, q: f64) -> f64 {
    let finite: Vec<f64> = draws.iter().copied().filter(|w| w.is_finite()).collect();
    let n = finite.len() as f64;
    if n < 2.0 {
        return 1.0;
    }
    let mean = finite.iter().sum::<f64>() / n;
    let var = finite.iter().map(|w| (w - mean).powi(2)).sum::<f64>() / (n - 1.0);
    // c·F(q, ν): mean c ν/(ν−2), variance/mean² = 2(q + ν − 2) / (q (ν − 4)).
    let ratio = var / (mean * mean);
    let nu = if ratio * q > 2.0 + 1e-9 {
        ((4.0 * ratio * q + 2.0 * q - 4.0) / (ratio * q - 2.0)).min(1e6)
    } else {
        1e6
    };
    let c = mean * (nu - 2.0) / nu;
    crate::stats::f_sf(x / c, q, nu)
}

/// Per-cluster moments of the rows for a [`WildClusterTest`]: `t_g = Σ z e` and
/// `A_g = Σ z_B zᵀ`, z the row's coordinates.
#[derive(Debug, Clone)]
pub struct ClusterMoments {
    r: usize,
    q: usize,
    t: Vec<f64>,
    a: Vec<f64>,
    used: Vec<bool>,
    z: Vec<f64>,
}

impl ClusterMoments {
    /// One scalar row of cluster `g`: its whitened values `x` over the test's `full` columns
    /// (in that order) and its restricted residual `e`.
    pub fn push_row(&mut self, test: &WildClusterTest, g: usize, x: &[f64], e: f64) {
        debug_assert_eq!(x.len(), test.p);
        let (r, q) = (self.r, self.q);
        for (zj, trow) in self.z.iter_mut().zip(test.t.chunks_exact(test.p)) {
            *zj = dot(trow, x);
        }
        self.used[g] = true;
        for (tj, zj) in self.t[g * r..(g + 1) * r].iter_mut().zip(&self.z) {
            *tj += zj * e;
        }
        let a = &mut self.a[g * q * r..(g + 1) * q * r];
        for (arow, &zb) in a.chunks_exact_mut(r).zip(&self.z[r - q..]) {
            for (aj, zj) in arow.iter_mut().zip(&self.z) {
                *aj += zb * zj;
            }
        }
    }

    fn used_clusters(&self) -> Vec<usize> {
        (0..self.used.len()).filter(|&g| self.used[g]).collect()
    }

    /// Adds another part's moments (the same clusters).
    pub fn merge(&mut self, other: &ClusterMoments) {
        for (a, b) in self.t.iter_mut().zip(&other.t) {
            *a += b;
        }
        for (a, b) in self.a.iter_mut().zip(&other.a) {
            *a += b;
        }
        for (a, b) in self.used.iter_mut().zip(&other.used) {
            *a |= b;
        }
    }
}

/// Draws evaluated together. A draw reads every cluster's `A_g` (G·q·r numbers, ≈ 1 MB at
/// 256 clusters on a 7-joint arm's extended model), more than a core's cache: read once per
/// batch, as one matrix product, instead of once per draw.
const BATCH: usize = 32;

/// The used clusters' moments as matrices, and the buffers of a batch of draws.
struct Batch {
    r: usize,
    q: usize,
    /// r × G: the clusters' `t_g`.
    t: DMatrix<f64>,
    /// G × q: the block's part of the `t_g`, a column per block coordinate.
    t_b: DMatrix<f64>,
    /// (q·G) × r: the `A_g` stacked by block coordinate then cluster (row `b·G + g` is row b
    /// of `A_g`), so that a column of `A c` read as G × q is the draw's `A_g c` per cluster.
    a: DMatrix<f64>,
    /// G × BATCH: the draws' weights, a column per draw.
    w: DMatrix<f64>,
    /// r × BATCH: the draws' coordinates `c = Σ w_g t_g`.
    c: DMatrix<f64>,
    /// (q·G) × BATCH: `A_g c` of every cluster and draw.
    ac: DMatrix<f64>,
    /// G × q: one draw's block scores `u_g`, a row per cluster.
    u: DMatrix<f64>,
    /// q × q: their sum of squares.
    v: DMatrix<f64>,
    x: Vec<f64>,
}

impl Batch {
    fn new(m: &ClusterMoments, used: &[usize]) -> Self {
        let (r, q, g) = (m.r, m.q, used.len());
        let t = DMatrix::from_fn(r, g, |j, k| m.t[used[k] * r + j]);
        let t_b = DMatrix::from_fn(g, q, |k, b| m.t[used[k] * r + r - q + b]);
        let a = DMatrix::from_fn(q * g, r, |row, j| {
            let (b, k) = (row / g, row % g);
            m.a[used[k] * q * r + b * r + j]
        });
        Batch {
            r,
            q,
            t,
            t_b,
            a,
            w: DMatrix::zeros(g, BATCH),
            c: DMatrix::zeros(r, BATCH),
            ac: DMatrix::zeros(q * g, BATCH),
            u: DMatrix::zeros(g, q),
            v: DMatrix::zeros(q, q),
            x: vec![0.0; q],
        }
    }

    /// The observed statistic: the draw with every weight 1. A statistic that is not a number
    /// (moments that are not) tests nothing: every draw's comparison with it would be false
    /// and p would come out at its smallest.
    fn observed(&mut self) -> Option<f64> {
        self.weights_mut(0).fill(1.0);
        self.walds(1)[0].filter(|w| w.is_finite())
    }

    /// The weights of draw `k` of the batch, one per used cluster.
    fn weights_mut(&mut self, k: usize) -> &mut [f64] {
        let g = self.w.nrows();
        &mut self.w.as_mut_slice()[k * g..(k + 1) * g]
    }

    /// `c_Bᵀ (Σ u_g u_gᵀ)⁻¹ c_B` of the batch's first `d` draws; `None` for a draw whose
    /// covariance is singular.
    fn walds(&mut self, d: usize) -> Vec<Option<f64>> {
        let (r, q, g) = (self.r, self.q, self.w.nrows());
        self.c.gemm(1.0, &self.t, &self.w, 0.0);
        self.ac.gemm(1.0, &self.a, &self.c, 0.0);
        (0..d)
            .map(|k| {
                let w = &self.w.as_slice()[k * g..(k + 1) * g];
                let ac = &self.ac.as_slice()[k * q * g..(k + 1) * q * g];
                for (u, (tb, acb)) in self
                    .u
                    .as_mut_slice()
                    .chunks_exact_mut(g)
                    .zip(self.t_b.as_slice().chunks_exact(g).zip(ac.chunks_exact(g)))
                {
                    for (((ui, wi), ti), ai) in u.iter_mut().zip(w).zip(tb).zip(acb) {
                        *ui = wi * ti - ai;
                    }
                }
                self.v.gemm_tr(1.0, &self.u, &self.u, 0.0);
                let c_b: Vec<f64> = (0..q).map(|i| self.c[(r - q + i, k)]).collect();
                quadratic_form(&mut self.v, &c_b, &mut self.x)
            })
            .collect()
    }
}

/// `cᵀ V⁻¹ c` by a Cholesky factor of the symmetric `v` (overwritten, lower triangle), `None`
/// when a pivot is below 1e-13 of V's largest diagonal (a singular covariance).
fn quadratic_form(v: &mut DMatrix<f64>, c: &[f64], x: &mut [f64]) -> Option<f64> {
    let q = c.len();
    let scale = (0..q).map(|i| v[(i, i)]).fold(0.0, f64::max);
    for j in 0..q {
        let mut d = v[(j, j)];
        for k in 0..j {
            d -= v[(j, k)] * v[(j, k)];
        }
        if d <= 1e-13 * scale || scale <= 0.0 {
            return None;
        }
        let d = d.sqrt();
        v[(j, j)] = d;
        for i in j + 1..q {
            let mut s = v[(i, j)];
            for k in 0..j {
                s -= v[(i, k)] * v[(j, k)];
            }
            v[(i, j)] = s / d;
        }
    }
    for i in 0..q {
        let mut s = c[i];
        for k in 0..i {
            s -= v[(i, k)] * x[k];
        }
        x[i] = s / v[(i, i)];
    }
    Some(x.iter().map(|x| x * x).sum())
}
