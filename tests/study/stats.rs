//! The binomial interval of the study's rates.

use vjm::diagnose::stats::beta_inc;

/// Exact (Clopper–Pearson) two-sided `1 − alpha` interval of a binomial proportion with `k`
/// successes in `n` trials: the `alpha/2` and `1 − alpha/2` quantiles of Beta(k, n − k + 1) and
/// Beta(k + 1, n − k), found by bisection of the regularised incomplete beta function.
/// `(0, 1)` when `n = 0`.
pub fn clopper_pearson(k: usize, n: usize, alpha: f64) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let (kf, nf) = (k as f64, n as f64);
    // x such that I_x(a, b) = target (I is increasing in x).
    let quantile = |a: f64, b: f64, target: f64| {
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if beta_inc(a, b, mid) < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    };
    let lower = if k == 0 {
        0.0
    } else {
        quantile(kf, nf - kf + 1.0, alpha / 2.0)
    };
    let upper = if k == n {
        1.0
    } else {
        quantile(kf + 1.0, nf - kf, 1.0 - alpha / 2.0)
    };
    (lower, upper)
}
