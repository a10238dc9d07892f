//! Finite-difference derivatives of a potential on SO(3) along left-invariant fields
//! `L_i = R·hat(σ_i)` (body-frame perturbations `R·exp(ε hat σ_i)`), used as the independent
//! reference for the simulator's moments and the analytic stiffness.

use nalgebra::{Matrix3, Rotation3, Vector3};
use so3_stiffness::so3;

fn axis(i: usize, scale: f64) -> Vector3<f64> {
    let mut v = Vector3::zeros();
    v[i] = scale;
    v
}

/// `(L_i Φ)(R)` by central differences, i = 0..3.
pub fn body_gradient(
    phi: &dyn Fn(&Rotation3<f64>) -> f64,
    r: &Rotation3<f64>,
    h: f64,
) -> Vector3<f64> {
    Vector3::from_fn(|i, _| {
        (phi(&(r * so3::exp(&axis(i, h)))) - phi(&(r * so3::exp(&axis(i, -h))))) / (2.0 * h)
    })
}

/// `M_ij = L_j(L_i Φ)(R) = ∂²/∂s∂t Φ(R·exp(s σ_j)·exp(t σ_i))` by the 4-point central formula.
/// This is the Euclidean (component-wise) derivative of the body gradient: not symmetric.
pub fn iterated_derivatives(
    phi: &dyn Fn(&Rotation3<f64>) -> f64,
    r: &Rotation3<f64>,
    h: f64,
) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| {
        let f = |s: f64, t: f64| phi(&(r * so3::exp(&axis(j, s)) * so3::exp(&axis(i, t))));
        (f(h, h) - f(h, -h) - f(-h, h) + f(-h, -h)) / (4.0 * h * h)
    })
}

/// The covariant Hessian of Φ for the Levi-Civita connection of the bi-invariant metric:
/// `∇²Φ(X, Y) = X(YΦ) − (∇_X Y)Φ` with `∇_X Y = ½[X, Y]` on left-invariant fields, so
/// `H_ij = L_j(L_i Φ) − ½ [L_j, L_i]Φ` and `[L_j, L_i] = L_{σ_j × σ_i}`.
pub fn covariant_hessian(
    phi: &dyn Fn(&Rotation3<f64>) -> f64,
    r: &Rotation3<f64>,
    h: f64,
) -> Matrix3<f64> {
    let iterated = iterated_derivatives(phi, r, h);
    let gradient = body_gradient(phi, r, h);
    Matrix3::from_fn(|i, j| {
        iterated[(i, j)] - 0.5 * gradient.dot(&so3::bracket(&axis(j, 1.0), &axis(i, 1.0)))
    })
}

/// `d²/dt² Φ(R·exp(t x))` at t = 0 (second derivative along the geodesic through R).
pub fn geodesic_second_derivative(
    phi: &dyn Fn(&Rotation3<f64>) -> f64,
    r: &Rotation3<f64>,
    x: &Vector3<f64>,
    h: f64,
) -> f64 {
    (phi(&(r * so3::exp(&(x * h)))) - 2.0 * phi(r) + phi(&(r * so3::exp(&(x * -h))))) / (h * h)
}

/// Relative Frobenius distance ‖a − b‖ / ‖b‖.
pub fn relative_error(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    (a - b).norm() / b.norm()
}
