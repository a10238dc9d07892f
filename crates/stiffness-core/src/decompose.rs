//! Iterative matrix decompositions with a cap: one place that bounds every SVD and symmetric
//! eigen-decomposition of the workspace.
//!
//! nalgebra's `svd()`, `singular_values()`, `symmetric_eigen()` and `pseudo_inverse()` iterate
//! until convergence with no limit; on a matrix holding NaN or infinity they never converge and
//! the program spins forever (a NaN in a URDF did exactly that). These wrappers pass an
//! iteration cap and return [`NotConverged`], naming the decomposition, when it is hit.
//!
//! The cap, `1000 + 6 n²` for an n-column problem, follows LAPACK's `dbdsqr` (6 n² sweeps) with
//! a floor for tiny matrices: a finite, well-scaled matrix converges in a small fraction of it.

use nalgebra::allocator::Allocator;
use nalgebra::{
    DefaultAllocator, Dim, DimDiff, DimMin, DimMinimum, DimSub, OMatrix, SymmetricEigen, SVD, U1,
};
use thiserror::Error;

/// An iterative decomposition hit its iteration cap (almost always: non-finite input).
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error(
    "the {what} did not converge within {iterations} iterations (is an input NaN, infinite or \
     extreme?)"
)]
pub struct NotConverged {
    /// What was being decomposed, in words ("SVD of the design matrix").
    pub what: &'static str,
    /// The cap that was hit.
    pub iterations: usize,
}

/// The iteration cap for a problem with `n` columns: `1000 + 6 n²`.
pub fn iteration_cap(n: usize) -> usize {
    1000usize.saturating_add(n.saturating_mul(n).saturating_mul(6))
}

/// Relative convergence tolerance handed to nalgebra (its own default).
const EPS: f64 = f64::EPSILON;

/// The SVD of `m` (singular values sorted descending), capped; `what` names the matrix in the
/// error.
pub fn svd<R, C>(
    m: OMatrix<f64, R, C>,
    compute_u: bool,
    compute_v: bool,
    what: &'static str,
) -> Result<SVD<f64, R, C>, NotConverged>
where
    R: DimMin<C>,
    C: Dim,
    DimMinimum<R, C>: DimSub<U1>,
    DefaultAllocator: Allocator<R, C>
        + Allocator<C>
        + Allocator<R>
        + Allocator<DimDiff<DimMinimum<R, C>, U1>>
        + Allocator<DimMinimum<R, C>, C>
        + Allocator<R, DimMinimum<R, C>>
        + Allocator<DimMinimum<R, C>>,
{
    let iterations = iteration_cap(m.ncols().min(m.nrows()));
    if m.iter().any(|x| !x.is_finite()) {
        // Would not converge anyway; fail at once rather than after `iterations` sweeps.
        return Err(NotConverged { what, iterations });
    }
    SVD::try_new(m, compute_u, compute_v, EPS, iterations).ok_or(NotConverged { what, iterations })
}

/// The eigen-decomposition of the symmetric matrix `m` (lower triangle used), capped.
pub fn symmetric_eigen<D>(
    m: OMatrix<f64, D, D>,
    what: &'static str,
) -> Result<SymmetricEigen<f64, D>, NotConverged>
where
    D: DimSub<U1>,
    DefaultAllocator: Allocator<D, D> + Allocator<D> + Allocator<DimDiff<D, U1>>,
{
    let iterations = iteration_cap(m.ncols());
    if m.iter().any(|x| !x.is_finite()) {
        return Err(NotConverged { what, iterations });
    }
    SymmetricEigen::try_new(m, EPS, iterations).ok_or(NotConverged { what, iterations })
}
