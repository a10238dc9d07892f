//! Statistics used by the diagnosis: distribution tails (F, Student t, χ²), nested-model F tests,
//! Benjamini–Hochberg selection, one-way ANOVA and Spearman rank correlation.
//!
//! Everything here is self-contained (no statistics dependency) and checked in the tests against
//! closed forms and published table values. One module serves the whole workspace: the CSJM
//! identification and diagnosis (`so3_stiffness::stats`) and `vjm` (`vjm::stats`,
//! `vjm::diagnose::stats`) re-export it.

use serde::Serialize;

use crate::lsq::{RankPolicy, ScaledSvd};

/// ln Γ(x) for x > 0 (Lanczos approximation, g = 7, 9 terms; relative error < 1e-14).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection formula.
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Continued fraction for the incomplete beta function (modified Lentz).
fn beta_cf(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let qab = a + b;
    let qap = a + 1.0;
    let qam = a - 1.0;
    let mut c = 1.0;
    let mut d = 1.0 - qab * x / qap;
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..=10_000 {
        let m = m as f64;
        let m2 = 2.0 * m;
        let aa = m * (b - m) * x / ((qam + m2) * (a + m2));
        d = 1.0 + aa * d;
        if d.abs() < TINY {
            d = TINY;
        }
        c = 1.0 + aa / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        h *= d * c;
        let aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
        d = 1.0 + aa * d;
        if d.abs() < TINY {
            d = TINY;
        }
        c = 1.0 + aa / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < 1e-15 {
            break;
        }
    }
    h
}

/// The regularized incomplete beta function I_x(a, b), a, b > 0, x ∈ [0, 1].
pub fn beta_inc(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let ln_front = ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln();
    let front = ln_front.exp();
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_cf(a, b, x) / a
    } else {
        1.0 - front * beta_cf(b, a, 1.0 - x) / b
    }
}

/// Upper tail P(F > f) of Fisher's F distribution with (d1, d2) degrees of freedom.
pub fn f_sf(f: f64, d1: f64, d2: f64) -> f64 {
    if f.is_nan() {
        return f64::NAN;
    }
    if f <= 0.0 {
        return 1.0;
    }
    // P(F > f) = I_{d2/(d2 + d1 f)}(d2/2, d1/2); the complement form keeps precision for tiny p.
    let x = d2 / (d2 + d1 * f);
    beta_inc(d2 / 2.0, d1 / 2.0, x)
}

/// Two-sided p-value P(|T| > |t|) of Student's t distribution with `df` degrees of freedom.
pub fn t_two_sided(t: f64, df: f64) -> f64 {
    if t.is_nan() {
        return f64::NAN;
    }
    beta_inc(df / 2.0, 0.5, df / (df + t * t))
}

/// Regularized upper incomplete gamma Q(a, x).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let gln = ln_gamma(a);
    if x < a + 1.0 {
        // Series for P.
        let mut ap = a;
        let mut sum = 1.0 / a;
        let mut del = sum;
        for _ in 0..10_000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        1.0 - sum * (-x + a * x.ln() - gln).exp()
    } else {
        // Continued fraction for Q (modified Lentz).
        const TINY: f64 = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / TINY;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < TINY {
                d = TINY;
            }
            c = b + an / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (-x + a * x.ln() - gln).exp() * h
    }
}

/// Upper tail P(χ² > x) with `k` degrees of freedom.
pub fn chi2_sf(x: f64, k: f64) -> f64 {
    gamma_q(k / 2.0, x / 2.0)
}

/// Result of a nested-model F test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FTest {
    /// The F statistic ((SSE₀ − SSE₁)/q) / (SSE₁/(n − p₁)).
    pub f: f64,
    /// Numerator degrees of freedom q (extra parameters).
    pub df_num: f64,
    /// Denominator degrees of freedom n − p₁.
    pub df_den: f64,
    /// Upper-tail p-value.
    pub p_value: f64,
}

/// F test of a model with residual sum of squares `sse_full` (`df_den` residual degrees of
/// freedom) against the nested model with `sse_reduced` and `df_num` fewer parameters.
pub fn nested_f_test(sse_reduced: f64, sse_full: f64, df_num: usize, df_den: usize) -> FTest {
    let (q, d) = (df_num as f64, df_den as f64);
    if df_num == 0 || df_den == 0 || sse_full <= 0.0 {
        return FTest {
            f: 0.0,
            df_num: q,
            df_den: d,
            p_value: 1.0,
        };
    }
    let f = ((sse_reduced - sse_full).max(0.0) / q) / (sse_full / d);
    FTest {
        f,
        df_num: q,
        df_den: d,
        p_value: f_sf(f, q, d),
    }
}

/// Benjamini–Hochberg step-up: which hypotheses are rejected at false discovery rate `q`.
/// NaN p-values are never rejected.
pub fn benjamini_hochberg(p_values: &[f64], q: f64) -> Vec<bool> {
    let m = p_values.len();
    let mut order: Vec<usize> = (0..m).filter(|&i| !p_values[i].is_nan()).collect();
    order.sort_by(|&a, &b| p_values[a].total_cmp(&p_values[b]));
    let mut k_max = 0;
    for (rank, &i) in order.iter().enumerate() {
        if p_values[i] <= q * (rank + 1) as f64 / m as f64 {
            k_max = rank + 1;
        }
    }
    let mut rejected = vec![false; m];
    for &i in &order[..k_max] {
        rejected[i] = true;
    }
    rejected
}

/// Result of a one-way analysis of variance.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Anova {
    /// Between-group mean square over within-group mean square.
    pub f: f64,
    /// Degrees of freedom between groups (groups − 1).
    pub df_between: f64,
    /// Degrees of freedom within groups (n − groups).
    pub df_within: f64,
    /// Upper-tail p-value of F.
    pub p_value: f64,
}

/// One-way ANOVA of `values` grouped by `groups` (group ids, any usize labels).
/// Returns `None` when there are fewer than two groups or no within-group replication.
pub fn one_way_anova(values: &[f64], groups: &[usize]) -> Option<Anova> {
    let n_groups = groups.iter().copied().max()? + 1;
    let mut sum = vec![0.0; n_groups];
    let mut count = vec![0usize; n_groups];
    for (&v, &g) in values.iter().zip(groups) {
        sum[g] += v;
        count[g] += 1;
    }
    let used = count.iter().filter(|&&c| c > 0).count();
    let n = values.len();
    if used < 2 || n <= used {
        return None;
    }
    let grand = values.iter().sum::<f64>() / n as f64;
    let mut ss_between = 0.0;
    for g in 0..n_groups {
        if count[g] > 0 {
            let mean = sum[g] / count[g] as f64;
            ss_between += count[g] as f64 * (mean - grand).powi(2);
        }
    }
    let mut ss_within = 0.0;
    for (&v, &g) in values.iter().zip(groups) {
        ss_within += (v - sum[g] / count[g] as f64).powi(2);
    }
    let df_b = (used - 1) as f64;
    let df_w = (n - used) as f64;
    if ss_within <= 0.0 {
        return None;
    }
    let f = (ss_between / df_b) / (ss_within / df_w);
    Some(Anova {
        f,
        df_between: df_b,
        df_within: df_w,
        p_value: f_sf(f, df_b, df_w),
    })
}

/// Ranks (1-based, ties get their average rank).
pub fn ranks(x: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..x.len()).collect();
    order.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let mut r = vec![0.0; x.len()];
    let mut i = 0;
    while i < order.len() {
        let mut j = i;
        while j + 1 < order.len() && x[order[j + 1]] == x[order[i]] {
            j += 1;
        }
        let avg = (i + j) as f64 / 2.0 + 1.0;
        for &k in &order[i..=j] {
            r[k] = avg;
        }
        i = j + 1;
    }
    r
}

/// Pearson correlation; NaN when either input is constant.
pub fn pearson(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let mx = x.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx).powi(2);
        syy += (b - my).powi(2);
    }
    if sxx <= 0.0 || syy <= 0.0 {
        return f64::NAN;
    }
    sxy / (sxx * syy).sqrt()
}

/// Rank correlation with its two-sided p-value.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Correlation {
    /// Spearman's ρ.
    pub rho: f64,
    /// Number of pairs.
    pub n: usize,
    /// Two-sided p-value (t approximation with n − 2 degrees of freedom).
    pub p_value: f64,
}

/// Spearman rank correlation of `x` and `y` (equal lengths, ≥ 3 pairs), p-value from
/// t = ρ √((n−2)/(1−ρ²)).
pub fn spearman(x: &[f64], y: &[f64]) -> Option<Correlation> {
    let n = x.len();
    if n < 3 || y.len() != n {
        return None;
    }
    let rho = pearson(&ranks(x), &ranks(y));
    if rho.is_nan() {
        return None;
    }
    let df = (n - 2) as f64;
    let t = rho * (df / (1.0 - rho * rho).max(1e-300)).sqrt();
    Some(Correlation {
        rho,
        n,
        p_value: t_two_sided(t, df),
    })
}

/// Cluster-robust (CR1 sandwich) Wald test that the last `k` of the coefficients `beta` of the
/// regression `y ≈ X β` (residuals `r = y − Xβ`) are zero, with observation `i` in cluster
/// `cluster[i]`: `V = B (Σ_g s_g s_gᵀ) B · G/(G − 1)`, `B = (XᵀX)⁺`, `s_g = Σ_{i∈g} x_i r_i`;
/// `W = β_kᵀ V_kk⁺ β_k / k` against F(k, G − 1). `None` with fewer than 3 clusters or
/// inconsistent shapes.
pub fn cluster_robust_wald(
    x: &nalgebra::DMatrix<f64>,
    r: &nalgebra::DVector<f64>,
    beta: &nalgebra::DVector<f64>,
    cluster: &[usize],
    k: usize,
) -> Option<FTest> {
    let (n, p) = x.shape();
    if k == 0 || k > p || r.len() != n || beta.len() != p || cluster.len() != n {
        return None;
    }
    let mut ids: Vec<usize> = cluster.to_vec();
    ids.sort_unstable();
    ids.dedup();
    let mut sums = vec![vec![0.0; p]; ids.len()];
    for (o, c) in cluster.iter().enumerate() {
        let gi = ids.binary_search(c).ok()?;
        for (j, s) in sums[gi].iter_mut().enumerate() {
            *s += x[(o, j)] * r[o];
        }
    }
    let columns: Vec<Vec<f64>> = x
        .column_iter()
        .map(|c| c.iter().copied().collect())
        .collect();
    cluster_robust_wald_from_sums(&columns, &sums, beta.as_slice(), k)
}

/// [`cluster_robust_wald`] from its sufficient statistics: the design's `columns` (p of them,
/// all of one length; the columns of its R factor serve as well, having the same `XᵀX`) and
/// the per-cluster score sums `s_g = Σ_{i∈g} x_i r_i` (one p-vector per cluster), so that the
/// rows never need to be held at once. The bread `(XᵀX)⁺` is the column-scaled SVD's under the
/// diagnosis' rank policy ([`ScaledSvd`], as the wild cluster test's pseudo-inverse), so the
/// statistic does not depend on the columns' units; a column not in the data contributes
/// nothing. `None` with fewer than 3 clusters, inconsistent shapes or an SVD that does not
/// converge.
pub fn cluster_robust_wald_from_sums(
    columns: &[Vec<f64>],
    sums: &[Vec<f64>],
    beta: &[f64],
    k: usize,
) -> Option<FTest> {
    let p = columns.len();
    let g = sums.len();
    let rows = columns.first().map_or(0, Vec::len);
    if k == 0
        || k > p
        || beta.len() != p
        || sums.iter().any(|s| s.len() != p)
        || columns.iter().any(|c| c.len() != rows)
    {
        return None;
    }
    if g < 3 {
        return None;
    }
    let mut meat = nalgebra::DMatrix::<f64>::zeros(p, p);
    for s in sums {
        let s = nalgebra::DVector::from_column_slice(s);
        meat += &s * s.transpose();
    }
    let bread = ScaledSvd::of_columns(
        columns,
        &RankPolicy::DIAGNOSIS,
        false,
        "SVD of the cluster-robust test's design",
    )
    .ok()?
    .covariance_in_data(1.0);
    let v = &bread * meat * &bread * (g as f64 / (g as f64 - 1.0));
    let vcc = v.view((p - k, p - k), (k, k)).into_owned();
    let bc = nalgebra::DVector::from_column_slice(&beta[p - k..]);
    // The k×k block is a covariance, inverted for the statistic: only its exact zeros are cut
    // (a capped SVD: nalgebra's `pseudo_inverse` loops forever on NaN).
    let vinv = crate::decompose::svd(vcc, true, true, "SVD of the cluster-robust covariance")
        .ok()?
        .pseudo_inverse(1e-300)
        .ok()?;
    let w = (bc.transpose() * vinv * &bc)[(0, 0)];
    let f = w / k as f64;
    let d2 = (g - 1) as f64;
    Some(FTest {
        f,
        df_num: k as f64,
        df_den: d2,
        p_value: f_sf(f, k as f64, d2),
    })
}

/// Two-sided 95 % quantile of Student's t with `dof` degrees of freedom (0.975 quantile),
/// from the Cornish–Fisher expansion (Abramowitz & Stegun 26.7.5) for dof ≥ 3 and exact
/// values below; `None` for dof = 0. Relative error below 1e-3 for dof ≥ 3.
pub fn student_t_975(dof: usize) -> Option<f64> {
    match dof {
        0 => None,
        1 => Some(12.706_204_736_174_7),
        2 => Some(4.302_652_729_749_46),
        _ => {
            let z: f64 = 1.959_963_984_540_054;
            let v = dof as f64;
            let z2 = z * z;
            let g1 = (z2 * z + z) / 4.0;
            let g2 = (5.0 * z2 * z2 * z + 16.0 * z2 * z + 3.0 * z) / 96.0;
            let g3 = (3.0 * z.powi(7) + 19.0 * z.powi(5) + 17.0 * z.powi(3) - 15.0 * z) / 384.0;
            let g4 = (79.0 * z.powi(9) + 776.0 * z.powi(7) + 1482.0 * z.powi(5)
                - 1920.0 * z.powi(3)
                - 945.0 * z)
                / 92160.0;
            Some(z + g1 / v + g2 / (v * v) + g3 / v.powi(3) + g4 / v.powi(4))
        }
    }
}
