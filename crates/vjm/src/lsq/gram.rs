//! Normal equations: a triangular factor from the Gram matrix `[A b]ᵀ[A b]`.
//!
//! Accumulating the Gram matrix costs half the arithmetic of a streaming QR and vectorises
//! well, but it squares the condition number: entries carry a relative error ~ε, so the
//! singular values of A below ~√ε·σ₁ (about 1e-8 relative) are lost in rounding and an
//! estimate's relative error grows like κ²ε. Callers therefore use it only with a rank
//! cut-off well above that floor and a bound on κ (see `crate::SolveMethod`).
//!
//! The factor is built so that the rest of the solver is shared with the QR path: the Gram
//! matrix is scaled to unit diagonal (so the eigen-decomposition's absolute errors are
//! relative to each column's norm), decomposed as `G_s = U Λ Uᵀ` (faer), and the QR of the
//! square `Λ^{1/2} Uᵀ` gives R_s with R_sᵀR_s = G_s; unscaling its columns gives R with
//! RᵀR = G. Negative eigenvalues (rounding of a semi-definite matrix) are taken as 0.

use faer::{Mat, Side};

use super::TriangularFactor;
use crate::error::VjmError;

/// The triangular factor R (p×p, RᵀR = G) of the p×p row-major symmetric Gram matrix
/// `gram` of a matrix with `rows` rows. See the module documentation for the numerics.
///
/// ```
/// use vjm::lsq::{factor_from_gram, TriangularAccumulator};
/// // Rows (1, x) for x = 0..9: G = [[10, 45], [45, 285]].
/// let g = factor_from_gram(2, &[10.0, 45.0, 45.0, 285.0], 10).unwrap();
/// let r = g.r();
/// assert!((r[0] * r[0] - 10.0).abs() < 1e-12);
/// assert!((r[0] * r[1] - 45.0).abs() < 1e-12);
/// assert!((r[1] * r[1] + r[3] * r[3] - 285.0).abs() < 1e-11);
/// ```
pub fn factor_from_gram(p: usize, gram: &[f64], rows: usize) -> Result<TriangularFactor, VjmError> {
    if gram.len() != p * p {
        return Err(VjmError::ShapeMismatch {
            what: "Gram matrix (p·p)",
            expected: p * p,
            got: gram.len(),
        });
    }
    for i in 0..p {
        crate::chain::check_finite("Gram matrix", &gram[i * p..(i + 1) * p], i, 0)?;
    }
    let scale: Vec<f64> = (0..p)
        .map(|k| {
            let g = gram[k * p + k];
            if g > 0.0 {
                g.sqrt()
            } else {
                1.0
            }
        })
        .collect();
    let gs = Mat::<f64>::from_fn(p, p, |i, j| {
        // Symmetrise: the caller's two triangles may differ in the last bit.
        0.5 * (gram[i * p + j] + gram[j * p + i]) / (scale[i] * scale[j])
    });
    let evd = gs
        .self_adjoint_eigen(Side::Lower)
        .map_err(|e| VjmError::Numerical {
            message: format!(
                "eigen-decomposition of the scaled {p}×{p} Gram matrix did not converge: {e:?}"
            ),
        })?;
    let u = evd.U();
    let lambda = evd.S().column_vector();
    let half = Mat::<f64>::from_fn(p, p, |i, j| lambda[i].max(0.0).sqrt() * u[(j, i)]);
    let r = half.qr().thin_R().to_owned();
    let mut out = vec![0.0; p * p];
    for i in 0..p {
        for j in i..p {
            out[i * p + j] = r[(i, j)] * scale[j];
        }
    }
    Ok(TriangularFactor::from_upper(p, out, rows)?)
}
