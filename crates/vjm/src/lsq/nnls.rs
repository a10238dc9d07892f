//! Lawson–Hanson non-negative least squares for the small (m×m) scaled triangle.

use nalgebra::{DMatrix, DVector};

use crate::error::VjmError;

/// min ‖A x − b‖ subject to x ≥ 0 (Lawson & Hanson 1974, ch. 23). The passive-set
/// subproblems are solved by SVD with relative cut-off `rtol`, so a rank-deficient A is
/// fine (the returned x is then one minimiser; A x is unique).
pub(crate) fn nnls(a: &DMatrix<f64>, b: &DVector<f64>, rtol: f64) -> Result<Vec<f64>, VjmError> {
    let n = a.ncols();
    let mut x = DVector::zeros(n);
    let mut passive = vec![false; n];
    let scale = a.norm() * b.norm().max(f64::MIN_POSITIVE);
    let tol = 1e-12 * scale.max(f64::MIN_POSITIVE);
    for _outer in 0..(3 * n + 10) {
        let w = a.transpose() * (b - a * &x);
        let cand = (0..n)
            .filter(|&j| !passive[j] && w[j] > tol)
            .max_by(|&i, &j| w[i].total_cmp(&w[j]));
        let Some(t) = cand else {
            return Ok(x.iter().copied().collect());
        };
        passive[t] = true;
        for _inner in 0..(3 * n + 10) {
            let idx: Vec<usize> = (0..n).filter(|&j| passive[j]).collect();
            let sub = DMatrix::from_fn(a.nrows(), idx.len(), |i, k| a[(i, idx[k])]);
            let svd =
                stiffness_core::decompose::svd(sub, true, true, "SVD of the NNLS subproblem")?;
            let eps = rtol * svd.singular_values.max();
            let s = svd.solve(b, eps).map_err(|e| VjmError::Numerical {
                message: format!("NNLS subproblem: {e}"),
            })?;
            let mut z = DVector::zeros(n);
            for (k, &j) in idx.iter().enumerate() {
                z[j] = s[k];
            }
            if idx.iter().all(|&j| z[j] > 0.0) {
                x = z;
                break;
            }
            let mut alpha = f64::INFINITY;
            for &j in &idx {
                if z[j] <= 0.0 {
                    alpha = alpha.min(x[j] / (x[j] - z[j]));
                }
            }
            x += (z - &x) * alpha;
            for &j in &idx {
                if x[j] <= 1e-15 * x.amax().max(f64::MIN_POSITIVE) {
                    x[j] = 0.0;
                    passive[j] = false;
                }
            }
        }
    }
    Err(VjmError::Numerical {
        message: "NNLS did not converge".into(),
    })
}
