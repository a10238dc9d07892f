//! `WeakDirections`: what an estimate's data determine.

use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use stiffness_core::lsq::WeakDirections;

/// Least squares on `a` (rows × m) with noise σ: (x̂, covariance σ²(AᵀA)⁻¹ row-major, column scale).
fn fit(a: &DMatrix<f64>, x_true: &[f64], sigma: f64, seed: u64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let x = DVector::from_column_slice(x_true);
    let noise = DVector::from_fn(a.nrows(), |_, _| {
        sigma * (rng.random::<f64>() * 2.0 - 1.0) * 3f64.sqrt()
    });
    let b = a * x + noise;
    let gram = a.transpose() * a;
    let inv = gram.clone().try_inverse().unwrap();
    let xh = &inv * a.transpose() * b;
    let cov = inv * (sigma * sigma);
    let scale = (0..a.ncols()).map(|k| a.column(k).norm()).collect();
    (
        xh.iter().cloned().collect(),
        cov.transpose().iter().cloned().collect(),
        scale,
    )
}

#[test]
fn on_a_diagonal_design_an_axis_is_weak_exactly_when_its_error_exceeds_its_value() {
    // Independent path: the principal axes are the parameters, so the rule is per parameter.
    let x = [1.0, 0.3, -0.02, 5e-3];
    let sd = [0.1, 0.5, 0.01, 1e-2];
    let cov: Vec<f64> = (0..16)
        .map(|k| {
            if k % 5 == 0 {
                sd[k / 5] * sd[k / 5]
            } else {
                0.0
            }
        })
        .collect();
    let weak = WeakDirections::of(&x, &cov, &[2.0, 1.0, 0.5, 3.0], f64::INFINITY).unwrap();
    assert_eq!(weak.len(), 2);
    let d = weak.determined(&x);
    let expected = [1.0, 0.0, -0.02, 0.0];
    for (a, b) in d.iter().zip(expected) {
        assert!((a - b).abs() < 1e-14, "{d:?}");
    }
    // The plausibility rule: a parameter known to ±0.1 is unusable when 0.05 is implausible;
    // −0.02 ± 0.01 stays.
    let strict = WeakDirections::of(&x, &cov, &[1.0; 4], 0.05).unwrap();
    assert_eq!(strict.determined(&x), vec![0.0, 0.0, -0.02, 0.0]);
    assert_eq!(strict.len(), 3);
}

#[test]
fn a_nearly_collinear_pair_is_found_and_removed_and_the_rest_kept() {
    // Columns 1 and 2 differ by 1e-6 of their length: their difference is noise at ±O(1e2)σ.
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let rows = 200;
    let mut a = DMatrix::from_fn(rows, 4, |_, _| rng.random::<f64>() - 0.5);
    for i in 0..rows {
        a[(i, 2)] = a[(i, 1)] * (1.0 + 1e-6) + 1e-6 * (rng.random::<f64>() - 0.5);
    }
    let x_true = [2e-4, 1e-4, 1e-4, 3e-4];
    let (xh, cov, scale) = fit(&a, &x_true, 1e-6, 9);
    let weak = WeakDirections::of(&xh, &cov, &scale, 1e-2).unwrap();
    assert_eq!(weak.len(), 1, "{xh:?}");
    let d = weak.determined(&xh);
    // What the data determine is kept, to a small fraction of its standard error: x0 and x3
    // (the removed axis is the difference x1 − x2, up to its tiny correlations).
    let sd = |k: usize| cov[k * 4 + k].sqrt();
    assert!(
        (d[0] - xh[0]).abs() < 0.1 * sd(0) && (d[3] - xh[3]).abs() < 0.1 * sd(3),
        "{d:?}"
    );
    // The fitted values move by |t|·σ of the removed axis (a few σ at most), not by its ±0.25.
    let moved = &a * (DVector::from_column_slice(&d) - DVector::from_column_slice(&xh));
    assert!(moved.norm() < 4.0 * 1e-6, "{}", moved.norm());
    // The difference, pure noise in x̂ (the two differ by far more), is gone.
    assert!((xh[1] - xh[2]).abs() > 1e-5, "{xh:?}");
    assert!(
        (d[1] - 1e-4).abs() < 1e-6 && (d[2] - 1e-4).abs() < 1e-6,
        "{d:?}"
    );
}

#[test]
fn without_a_covariance_nothing_is_weak() {
    let weak = WeakDirections::of(&[1.0, 2.0], &[0.0; 4], &[1.0, 1.0], 1e-2).unwrap();
    assert!(weak.is_empty());
    assert_eq!(weak.determined(&[1.0, 2.0]), vec![1.0, 2.0]);
    assert!(WeakDirections::of(&[1.0], &[f64::NAN], &[1.0], 1.0).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, rng_seed: proptest::test_runner::RngSeed::Fixed(7), ..ProptestConfig::default() })]

    #[test]
    fn determined_is_a_projection(seed in 0u64..10_000, m in 2usize..7) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let a = DMatrix::from_fn(3 * m + 2, m, |_, _| rng.random::<f64>() - 0.5);
        let x_true: Vec<f64> = (0..m).map(|_| rng.random::<f64>() * 1e-3).collect();
        let (xh, cov, scale) = fit(&a, &x_true, 1e-4, seed);
        let weak = WeakDirections::of(&xh, &cov, &scale, 1.0).unwrap();
        let once = weak.determined(&xh);
        let twice = weak.determined(&once);
        for (p, q) in once.iter().zip(&twice) {
            prop_assert!((p - q).abs() <= 1e-12 * (1.0 + p.abs()) * 1e3);
        }
        // A well-determined estimate (every axis many standard errors from 0) is untouched.
        let big: Vec<f64> = x_true.iter().map(|v| v + 1.0).collect();
        let (xb, covb, scaleb) = fit(&a, &big, 1e-6, seed);
        let none = WeakDirections::of(&xb, &covb, &scaleb, 1.0).unwrap();
        prop_assert!(none.is_empty());
        prop_assert_eq!(none.determined(&xb), xb);
    }
}
