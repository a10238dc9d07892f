//! The rank-revealing SVD of a small design (`lsq::ScaledSvd`) against an independent path:
//! the normal equations solved by a Cholesky inverse of `XᵀX`, on designs whose columns differ
//! in scale by 10⁶ (the reason for the column scaling), with one column duplicated (rank
//! deficient) and one column not in the data.

use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;
use stiffness_core::lsq::{RankPolicy, ScaledSvd};

/// `rows` × 4 columns from `values`, column j scaled by 10^(2j − 3).
fn design(values: &[f64], rows: usize) -> Vec<Vec<f64>> {
    (0..4)
        .map(|j| {
            let scale = 10f64.powi(2 * j as i32 - 3);
            (0..rows).map(|i| values[i * 4 + j] * scale).collect()
        })
        .collect()
}

fn matrix(cols: &[Vec<f64>]) -> DMatrix<f64> {
    DMatrix::from_fn(cols[0].len(), cols.len(), |i, j| cols[j][i])
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 64,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x5eed_5d00),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// Full rank: the coefficients and the covariance are the normal equations' (to 1e-8 of
    /// their size, with a condition number of XᵀX up to ~1e12 from the column scales alone).
    #[test]
    fn a_full_rank_design_solves_as_its_normal_equations(
        values in proptest::collection::vec(-1.0f64..1.0, 48),
        y in proptest::collection::vec(-1.0f64..1.0, 12),
        s2 in 0.1f64..10.0,
    ) {
        let cols = design(&values, 12);
        let x = matrix(&cols);
        let xtx = x.transpose() * &x;
        // Column-equilibrated Cholesky inverse: (D XᵀX D)⁻¹ scaled back.
        let d = DVector::from_fn(4, |j, _| 1.0 / xtx[(j, j)].sqrt());
        let scaled = DMatrix::from_fn(4, 4, |i, j| xtx[(i, j)] * d[i] * d[j]);
        let Some(inv) = scaled.clone().cholesky().map(|c| c.inverse()) else {
            return Ok(()); // a draw too close to singular for the reference
        };
        prop_assume!(scaled.norm() * inv.norm() < 1e8);
        let inv = DMatrix::from_fn(4, 4, |i, j| inv[(i, j)] * d[i] * d[j]);
        let beta_ref = &inv * (x.transpose() * DVector::from_vec(y.clone()));
        let fit = ScaledSvd::of_columns(&cols, &RankPolicy::DIAGNOSIS, true, "test").unwrap();
        prop_assert_eq!(fit.rank(), 4);
        let beta = fit.solve(&y);
        for j in 0..4 {
            let tol = 1e-8 * (beta_ref[j].abs() + inv[(j, j)].sqrt());
            prop_assert!((beta[j] - beta_ref[j]).abs() <= tol, "β{}: {} vs {}", j, beta[j], beta_ref[j]);
        }
        let cov = fit.covariance(s2);
        for i in 0..4 {
            for j in 0..4 {
                let expected = s2 * inv[(i, j)];
                let tol = 1e-8 * s2 * (inv[(i, i)] * inv[(j, j)]).sqrt();
                prop_assert!((cov[(i, j)] - expected).abs() <= tol, "cov {} {}", i, j);
            }
        }
    }

    /// A duplicated column (scaled by 10³) makes the design rank 3: the fitted values are still
    /// the least-squares projection (the residual is orthogonal to every column), the two
    /// copies share the coefficient equally in scaled units, and a column of 1e-20 of the rest
    /// is not in the data (coefficient 0, covariance NaN).
    #[test]
    fn a_rank_deficient_design_gives_the_projection_and_drops_what_is_not_there(
        values in proptest::collection::vec(-1.0f64..1.0, 48),
        y in proptest::collection::vec(-1.0f64..1.0, 12),
    ) {
        let mut cols = design(&values, 12);
        cols[3] = cols[0].iter().map(|v| v * 1e3).collect();
        cols.push(cols[1].iter().map(|v| v * 1e-20 / 10f64.powi(-1)).collect());
        let fit = ScaledSvd::of_columns(&cols, &RankPolicy::DIAGNOSIS, true, "test").unwrap();
        prop_assert_eq!(fit.rank(), 3);
        prop_assert_eq!(fit.in_data(), vec![true, true, true, true, false]);
        let beta = fit.solve(&y);
        prop_assert_eq!(beta[4], 0.0);
        let x = matrix(&cols[..4]);
        let resid = DVector::from_vec(y.clone()) - &x * DVector::from_vec(beta[..4].to_vec());
        for (j, c) in cols[..4].iter().enumerate() {
            let n = c.iter().map(|v| v * v).sum::<f64>().sqrt();
            let along: f64 = c.iter().zip(resid.iter()).map(|(a, b)| a * b).sum();
            prop_assert!(along.abs() <= 1e-9 * n * (1.0 + resid.norm()), "column {}: {} vs {}", j, along, n);
        }
        // Equal shares of the scaled coefficient: β₀‖c₀‖ = β₃‖c₃‖.
        let n0 = cols[0].iter().map(|v| v * v).sum::<f64>().sqrt();
        prop_assert!((beta[0] * n0 - beta[3] * 1e3 * n0).abs() <= 1e-9 * (beta[0] * n0).abs().max(1e-12));
        let cov = fit.covariance(1.0);
        prop_assert!(cov[(4, 4)].is_nan() && cov[(0, 4)].is_nan() && cov[(1, 1)].is_finite());
        // The null space of the scaled design: p − rank orthonormal vectors that the scaled
        // columns annihilate, spanning the aliased pair's difference and the missing column.
        let null = fit.null_space();
        prop_assert_eq!(null.len(), 2);
        prop_assert_eq!(fit.singular_values().len(), 5);
        prop_assert!(fit.singular_values()[3] <= 1e-12 * fit.singular_values()[0]);
        let norms = fit.column_norms();
        for (a, va) in null.iter().enumerate() {
            for (b, vb) in null.iter().enumerate() {
                let dot: f64 = va.iter().zip(vb).map(|(x, y)| x * y).sum();
                prop_assert!((dot - f64::from(u8::from(a == b))).abs() < 1e-12, "{} {}: {}", a, b, dot);
            }
            let mut xv = [0.0; 12];
            for ((col, norm), vj) in cols.iter().zip(norms).zip(va) {
                for (x, c) in xv.iter_mut().zip(col) {
                    *x += norm.map_or(0.0, |n| c / n) * vj;
                }
            }
            prop_assert!(xv.iter().all(|x| x.abs() < 1e-12), "{:?}", xv);
            // Only the aliased pair (0, 3) and the missing column 4 move in the null space.
            prop_assert!(va[1].abs() < 1e-12 && va[2].abs() < 1e-12, "{:?}", va);
        }
        // The missing column's unit vector is in the span: its weight over the basis is 1.
        let e4: f64 = null.iter().map(|v| v[4] * v[4]).sum();
        prop_assert!((e4 - 1.0).abs() < 1e-12, "{}", e4);
    }
}

/// The design nalgebra's SVD got wrong (found by the property above): 12×4, column 3 = 10³ ×
/// column 0. The least-squares fit must still be the projection: `numpy.linalg.lstsq` puts
/// 221.47 (in units of column 0) on the aliased pair, which the minimum-norm split shares
/// equally; nalgebra's factors gave 221.62.
#[test]
fn the_aliased_design_nalgebra_got_wrong_fits_as_lstsq_does() {
    #[rustfmt::skip]
    let values = [
        0.8035778781543886, 0.0, 0.9305020702001121, 0.0, 0.0, -0.7863370740266376, 0.0, 0.0,
        0.1882983568264204, -0.5895086409908097, 0.0, 0.0, 0.0, 0.0, 0.9570328122252311, 0.0,
        0.10961453114603496, -0.15779642451629652, 0.0, 0.0, 0.3831875042936415,
        0.755221226784644, 0.19018875574730837, 0.0, -0.006994690673085627, 0.3804370929092475,
        -0.9763323648533857, 0.0, 0.12307341492562968, 0.0, -0.6945280378598856, 0.0, 0.0,
        -0.7069605280555766, 0.32499736088544795, 0.0, 0.6399529972819378, 0.5417623855480895,
        0.4013936870353717, 0.0, 0.0, 0.06727513608271717, 0.620805364437946, 0.0,
        -0.8430265788774145, -0.7014566973609611, -0.17910288772135655, 0.0,
    ];
    let mut y = [0.0; 12];
    y[11] = -0.5131158931970792;
    let mut cols = design(&values, 12);
    cols[3] = cols[0].iter().map(|v| v * 1e3).collect();
    let fit = ScaledSvd::of_columns(&cols, &RankPolicy::DIAGNOSIS, true, "test").unwrap();
    let beta = fit.solve(&y);
    // numpy.linalg.lstsq (LAPACK gelsd) of the same design: 2.21470484e-4 + 1e3 · 0.221470484.
    let pair = beta[0] + 1e3 * beta[3];
    assert!((pair - 221.470_705).abs() < 1e-4, "{pair}");
    assert!((beta[1] - 0.381_001_805).abs() < 1e-8, "{}", beta[1]);
    assert!((beta[2] + 0.004_062_781_91).abs() < 1e-10, "{}", beta[2]);
}
