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
    DefaultAllocator, Dim, DimDiff, DimMin, DimMinimum, DimSub, Matrix3, OMatrix, SymmetricEigen,
    SVD, U1,
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

/// The eigenvalues of the symmetric 3×3 matrix `m` (upper triangle used), ascending, in closed
/// form (no iteration: the per-row conditioning of a position task, where nalgebra's iterative
/// decomposition cost a third of a compensation). `None` for a non-finite entry.
///
/// The trigonometric solution of the characteristic cubic (Smith 1961) — with q = tr/3,
/// p = ‖m − qI‖_F/√6 and B = (m − qI)/p, the eigenvalues are q + 2p cos(φ + 2πk/3),
/// φ = acos(det(B)/2)/3 — is accurate for the eigenvalue farthest from the other two only: at
/// a double root acos loses half the digits. So that one is kept, its eigenvector taken as the
/// largest cross product of two rows of m − λI, and the other two are the eigenvalues of m on
/// the plane orthogonal to it (a 2×2 problem, solved with a hypotenuse, which has no such
/// loss). Each eigenvalue is then within a few ε·‖m‖ of the exact one; test:
/// `three_by_three_eigenvalues_match_the_iterative_ones` (rank 1 and repeated roots included).
pub fn symmetric_eigenvalues_3(m: &Matrix3<f64>) -> Option<[f64; 3]> {
    if m.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let m =
        m.upper_triangle() + m.upper_triangle().transpose() - Matrix3::from_diagonal(&m.diagonal());
    let off = m[(0, 1)].powi(2) + m[(0, 2)].powi(2) + m[(1, 2)].powi(2);
    let q = m.trace() / 3.0;
    let shifted = m - Matrix3::identity() * q;
    let p2 = shifted.norm_squared();
    if off == 0.0 || p2 == 0.0 {
        // Diagonal (or a multiple of the identity): the diagonal, sorted.
        let mut v = [m[(0, 0)], m[(1, 1)], m[(2, 2)]];
        v.sort_by(f64::total_cmp);
        return Some(v);
    }
    let p = (p2 / 6.0).sqrt();
    let r = ((shifted / p).determinant() / 2.0).clamp(-1.0, 1.0);
    let phi = r.acos() / 3.0;
    // r ≥ 0: the largest root is the one apart (φ ≤ π/6); else the smallest.
    let lone = if r >= 0.0 {
        q + 2.0 * p * phi.cos()
    } else {
        q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos()
    };
    let a = m - Matrix3::identity() * lone;
    let (r0, r1, r2) = (
        a.row(0).transpose(),
        a.row(1).transpose(),
        a.row(2).transpose(),
    );
    let candidates = [r0.cross(&r1), r0.cross(&r2), r1.cross(&r2)];
    let v = candidates
        .iter()
        .max_by(|x, y| x.norm_squared().total_cmp(&y.norm_squared()))
        .expect("three candidates");
    let norm = v.norm();
    if norm == 0.0 || !norm.is_finite() {
        // m − λI of rank ≤ 1: λ is a double root and m has two distinct eigenvalues at most;
        // the cubic's other roots are then exact enough (no acos end-point involved twice).
        let mut all = [
            q + 2.0 * p * phi.cos(),
            q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos(),
            q + 2.0 * p * (phi + 4.0 * std::f64::consts::FRAC_PI_3).cos(),
        ];
        all.sort_by(f64::total_cmp);
        return Some(all);
    }
    let v = v / norm;
    // An orthonormal basis of the plane orthogonal to v.
    let helper = if v.x.abs() < 0.6 {
        nalgebra::Vector3::x()
    } else {
        nalgebra::Vector3::y()
    };
    let e1 = (helper - v * v.dot(&helper)).normalize();
    let e2 = v.cross(&e1);
    let (x, y, z) = (e1.dot(&(m * e1)), e1.dot(&(m * e2)), e2.dot(&(m * e2)));
    let mean = (x + z) / 2.0;
    let radius = ((x - z) / 2.0).hypot(y);
    let mut all = [lone, mean - radius, mean + radius];
    all.sort_by(f64::total_cmp);
    Some(all)
}
