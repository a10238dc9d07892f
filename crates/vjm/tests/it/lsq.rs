//! The least-squares core: streaming factor vs faer's dense QR, rank decisions.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vjm::lsq::{dense_factor, solve_dense, SolveOptions, TriangularAccumulator, TriangularFactor};

fn random_matrix(rows: usize, cols: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..rows * cols)
        .map(|_| rng.random_range(-1.0..1.0))
        .collect()
}

/// RᵀR of a p×p row-major upper-triangular factor.
fn gram(f: &TriangularFactor) -> Vec<f64> {
    let p = f.ncols();
    let r = f.r();
    let mut g = vec![0.0; p * p];
    for a in 0..p {
        for b in 0..p {
            g[a * p + b] = (0..p).map(|i| r[i * p + a] * r[i * p + b]).sum();
        }
    }
    g
}

/// The streaming factor equals faer's QR R up to the signs of its rows, for row counts
/// that are not multiples of the block, with merges of uneven pieces, and for widths of one,
/// several and a ragged last panel of the compact-WY fold (16 columns a panel).
#[test]
fn accumulator_matches_dense_qr() {
    for (rows, cols, splits) in [
        (1300, 40, vec![0, 256, 257, 900]),
        (700, 86, vec![0, 300]),
        (1000, 8, vec![0, 333, 700]),
        (150, 22, vec![0, 64, 65]),
        (9, 5, vec![0]),
    ] {
        let a = random_matrix(rows, cols, rows as u64);
        // Pieces accumulated separately then merged, as threads do.
        let mut bounds = splits.clone();
        bounds.push(rows);
        let mut total: Option<TriangularAccumulator> = None;
        for w in bounds.windows(2) {
            let mut acc = TriangularAccumulator::new(cols);
            for i in w[0]..w[1] {
                acc.push_row(&a[i * cols..(i + 1) * cols]).unwrap();
            }
            match total.as_mut() {
                None => total = Some(acc),
                Some(t) => t.merge(acc).unwrap(),
            }
        }
        let streamed = total.unwrap().finish();
        assert_eq!(streamed.nrows(), rows);
        // Reference: faer QR of the same matrix (last column as the rhs).
        let design: Vec<f64> = (0..rows)
            .flat_map(|i| a[i * cols..i * cols + cols - 1].to_vec())
            .collect();
        let rhs: Vec<f64> = (0..rows).map(|i| a[i * cols + cols - 1]).collect();
        let reference = dense_factor(&design, rows, cols - 1, &rhs).unwrap();
        let (rs, rr) = (streamed.r(), reference.r());
        for i in 0..cols {
            let sign = if (rs[i * cols + i] > 0.0) == (rr[i * cols + i] > 0.0) {
                1.0
            } else {
                -1.0
            };
            for j in i..cols {
                let (x, y) = (rs[i * cols + j], sign * rr[i * cols + j]);
                assert!(
                    (x - y).abs() < 1e-12 * (rows as f64).sqrt(),
                    "({i},{j}): {x} vs {y}"
                );
            }
        }
        // And RᵀR = AᵀA directly.
        let g = gram(&streamed);
        for p in 0..cols {
            for q in 0..cols {
                let ata: f64 = (0..rows).map(|i| a[i * cols + p] * a[i * cols + q]).sum();
                assert!((g[p * cols + q] - ata).abs() < 1e-10 * rows as f64);
            }
        }
    }
}

/// A design with known structure: columns [x, y, x + y, z, 0]: rank 3; parameter 3 (z) is
/// identifiable, {0, 1, 2} alias, 4 does not enter. Base parameters are named and exact.
#[test]
fn rank_deficient_design_structure() {
    let rows = 50;
    let base = random_matrix(rows, 3, 99);
    let truth = [1.0, 2.0, 3.0, 4.0, 5.0];
    let mut design = Vec::new();
    let mut rhs = Vec::new();
    for i in 0..rows {
        let (x, y, z) = (base[3 * i], base[3 * i + 1], base[3 * i + 2]);
        let row = [x, y, x + y, z, 0.0];
        rhs.push(row.iter().zip(&truth).map(|(a, b)| a * b).sum());
        design.extend(row);
    }
    let sol = solve_dense(&design, rows, 5, &rhs, &SolveOptions::default()).unwrap();
    assert_eq!(sol.rank, 3);
    assert_eq!(sol.identifiable, [false, false, false, true, false]);
    assert_eq!(sol.aliases, vec![vec![0, 1, 2], vec![4]]);
    assert!((sol.estimate[3].unwrap() - 4.0).abs() < 1e-12);
    assert!(sol
        .estimate
        .iter()
        .enumerate()
        .all(|(k, e)| e.is_some() == (k == 3)));
    // Each base parameter equals the same combination of the truth.
    assert_eq!(sol.combinations.len(), 3);
    for c in &sol.combinations {
        let expect: f64 = c.terms.iter().map(|&(k, w)| w * truth[k]).sum();
        assert!(
            (c.value - expect).abs() < 1e-12 * expect.abs().max(1.0),
            "{c:?}"
        );
    }
    // x_0 + x_2 and x_1 + x_2 are identifiable (they multiply x and y); x_0 alone is not.
    assert!((sol.evaluate(&[1.0, 0.0, 1.0, 0.0, 0.0], 1e-9).unwrap().0 - 4.0).abs() < 1e-12);
    assert!((sol.evaluate(&[0.0, 1.0, 1.0, 0.0, 0.0], 1e-9).unwrap().0 - 5.0).abs() < 1e-12);
    assert!(sol.evaluate(&[1.0, 0.0, 0.0, 0.0, 0.0], 1e-9).is_none());
    assert!(sol.evaluate(&[0.0, 0.0, 0.0, 0.0, 1.0], 1e-9).is_none());
    // Noise-free: zero residual, σ² ≈ 0.
    assert!(sol.rss < 1e-20);
}

/// Column scaling makes the rank independent of parameter units: multiplying a column by
/// 1e8 (a parameter in other units) changes neither rank nor structure — once the
/// zero-column cut-off, the one units-dependent decision, is off. With the default cut-off
/// (1e-12 of the largest column) a column 1e-14 times smaller counts as not entering.
#[test]
fn rank_is_unit_invariant() {
    let rows = 40;
    let mut a = random_matrix(rows, 4, 5);
    let rhs: Vec<f64> = random_matrix(rows, 1, 6);
    for i in 0..rows {
        a[4 * i + 1] *= 1e8;
        a[4 * i + 3] = a[4 * i] * 1e-6; // column 3 ∥ column 0, tiny units
    }
    let opts = SolveOptions {
        zero_column_rtol: 0.0,
        ..SolveOptions::default()
    };
    let sol = solve_dense(&a, rows, 4, &rhs, &opts).unwrap();
    assert_eq!(sol.rank, 3);
    assert_eq!(sol.aliases, vec![vec![0, 3]]);
    assert_eq!(sol.identifiable, [false, true, true, false]);
    let sol = solve_dense(&a, rows, 4, &rhs, &SolveOptions::default()).unwrap();
    assert_eq!(sol.aliases, vec![vec![3]]);
    assert_eq!(sol.identifiable, [true, true, true, false]);
}

/// Bad shapes and options are named.
#[test]
fn lsq_errors() {
    let err = solve_dense(&[1.0; 5], 2, 3, &[0.0; 2], &SolveOptions::default()).unwrap_err();
    assert!(err.to_string().contains("design matrix"), "{err}");
    let err = solve_dense(
        &[1.0, f64::NAN, 0.0, 1.0],
        2,
        2,
        &[0.0; 2],
        &SolveOptions::default(),
    )
    .unwrap_err();
    assert!(err.to_string().contains("row 0, column 1"), "{err}");
    let opts = SolveOptions {
        rank_rtol: 0.0,
        ..SolveOptions::default()
    };
    let err = solve_dense(&[1.0, 0.0, 0.0, 1.0], 2, 2, &[0.0; 2], &opts).unwrap_err();
    assert!(err.to_string().contains("rank_rtol"), "{err}");
    let mut acc = TriangularAccumulator::new(3);
    assert!(acc
        .push_row(&[1.0, 2.0])
        .unwrap_err()
        .to_string()
        .contains("expected 3"));
}
