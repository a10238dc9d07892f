//! Errors of the SO(3) toolkit ([`crate::so3`]).

use thiserror::Error;

/// Errors from the SO(3) toolkit ([`crate::so3`]).
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum So3Error {
    /// An input matrix or vector contains NaN or ±∞.
    #[error("{what} contains a non-finite entry at row {row}, column {col}")]
    NonFinite {
        /// Which argument was bad.
        what: &'static str,
        /// Row of the first non-finite entry (0-based).
        row: usize,
        /// Column of the first non-finite entry (0-based).
        col: usize,
    },
    /// The matrix is not orthonormal within the requested tolerance.
    #[error(
        "matrix is not a rotation: orthogonality error ‖MᵀM − I‖_F = {error:.3e} exceeds the tolerance {tol:.3e}; \
         use so3::project_to_rotation to project a measured matrix explicitly"
    )]
    NotOrthogonal {
        /// ‖MᵀM − I‖_F of the input.
        error: f64,
        /// The tolerance it was checked against.
        tol: f64,
    },
    /// The determinant is not positive: the matrix is (nearest to) a reflection, not a rotation.
    #[error(
        "matrix has determinant {det:.6e} ≤ 0: it is a reflection or singular, not a rotation"
    )]
    NonPositiveDeterminant {
        /// det(M).
        det: f64,
    },
    /// The matrix is (numerically) rank deficient, so its nearest rotation is not unique.
    #[error(
        "matrix is rank deficient (singular values {singular_values:?}); its nearest rotation is not unique"
    )]
    RankDeficient {
        /// Singular values, descending.
        singular_values: [f64; 3],
    },
}
