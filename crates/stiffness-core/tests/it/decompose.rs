//! Capped decompositions: a NaN matrix ends in a named error (nalgebra's own loop never ends),
//! a finite one gives nalgebra's answer.

use std::time::{Duration, Instant};

use nalgebra::{DMatrix, Matrix3};
use stiffness_core::decompose::{iteration_cap, svd, symmetric_eigen};

#[test]
fn a_nan_matrix_is_refused_by_name_at_once() {
    let mut m = DMatrix::from_fn(8, 5, |i, j| (i * 5 + j) as f64);
    m[(3, 2)] = f64::NAN;
    let start = Instant::now();
    let err = svd(m.clone(), true, true, "SVD of the test matrix").unwrap_err();
    assert_eq!(err.what, "SVD of the test matrix");
    assert_eq!(err.iterations, iteration_cap(5));
    assert!(err.to_string().contains("did not converge"), "{err}");
    let sym = &m.transpose() * &m;
    assert!(symmetric_eigen(sym, "eigen").is_err());
    let m3 = Matrix3::new(1.0, f64::INFINITY, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
    assert!(svd(m3, false, false, "3×3").is_err());
    assert!(start.elapsed() < Duration::from_secs(1));
}

#[test]
fn a_finite_matrix_decomposes_as_with_nalgebra() {
    let m = DMatrix::from_fn(7, 4, |i, j| {
        ((i * 4 + j) as f64 * 0.37).sin() + (i == j) as u8 as f64
    });
    let capped = svd(m.clone(), true, true, "SVD").unwrap();
    let reference = m.clone().svd(true, true);
    for (a, b) in capped
        .singular_values
        .iter()
        .zip(reference.singular_values.iter())
    {
        assert!(
            (a - b).abs() < 1e-12 * reference.singular_values[0],
            "{a} vs {b}"
        );
    }
    let back = capped.recompose().unwrap();
    assert!((back - &m).norm() < 1e-12 * m.norm());
    let sym = m.transpose() * &m;
    let eig = symmetric_eigen(sym.clone(), "eigen").unwrap();
    let mut ours: Vec<f64> = eig.eigenvalues.iter().copied().collect();
    let mut theirs: Vec<f64> = sym.symmetric_eigenvalues().iter().copied().collect();
    ours.sort_by(f64::total_cmp);
    theirs.sort_by(f64::total_cmp);
    for (a, b) in ours.iter().zip(&theirs) {
        assert!((a - b).abs() < 1e-12 * theirs[3], "{a} vs {b}");
    }
}
