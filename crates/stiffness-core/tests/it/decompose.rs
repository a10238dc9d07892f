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

/// The closed form against nalgebra's iterative decomposition (an independent code path) on
/// seeded matrices of every kind a Gram matrix takes: full rank, rank 2 and 1, repeated
/// eigenvalues in a rotated frame, indefinite, and scales from 1e-12 to 1e12.
#[test]
fn three_by_three_eigenvalues_match_the_iterative_ones() {
    use rand::{Rng, SeedableRng};
    use stiffness_core::decompose::symmetric_eigenvalues_3;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(20261206);
    let random = |rng: &mut rand_chacha::ChaCha8Rng| {
        nalgebra::Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        )
    };
    for case in 0..3000 {
        let (u, v, w) = (random(&mut rng), random(&mut rng), random(&mut rng));
        let scale = 10f64.powi(rng.random_range(-12..=12));
        let m: Matrix3<f64> = scale
            * match case % 5 {
                0 => u * u.transpose() + v * v.transpose() + w * w.transpose(),
                1 => u * u.transpose() + v * v.transpose(),
                2 => u * u.transpose(),
                3 => {
                    // diag(1, 1, 2) in a random orthonormal frame: a repeated eigenvalue.
                    let r = nalgebra::Rotation3::new(u * 3.0);
                    r.matrix()
                        * Matrix3::from_diagonal(&nalgebra::Vector3::new(1.0, 1.0, 2.0))
                        * r.matrix().transpose()
                }
                _ => u * v.transpose() + v * u.transpose() + Matrix3::from_diagonal(&w),
            };
        let m = (m + m.transpose()) / 2.0;
        let closed = symmetric_eigenvalues_3(&m).unwrap();
        let mut iter: Vec<f64> = symmetric_eigen(m, "3×3")
            .unwrap()
            .eigenvalues
            .iter()
            .copied()
            .collect();
        iter.sort_by(f64::total_cmp);
        let norm = m.norm();
        for k in 0..3 {
            assert!(
                (closed[k] - iter[k]).abs() <= 1e-14 * norm,
                "case {case}: eigenvalue {k} {} vs {} (‖m‖ = {norm:e})",
                closed[k],
                iter[k]
            );
        }
    }
    assert_eq!(
        symmetric_eigenvalues_3(&Matrix3::from_diagonal(&nalgebra::Vector3::new(
            3.0, -1.0, 2.0
        ))),
        Some([-1.0, 2.0, 3.0])
    );
    assert_eq!(
        symmetric_eigenvalues_3(&Matrix3::new(
            1.0,
            f64::NAN,
            0.0,
            0.0,
            1.0,
            0.0,
            0.0,
            0.0,
            1.0
        )),
        None
    );
}
