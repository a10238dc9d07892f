//! Bindings of `so3_stiffness::so3`: every function accepts one item or a batch `(N, …)` and
//! returns the same leading shape. Rotation inputs are checked (finite, orthonormal within `tol`,
//! det > 0) and the error names the batch index; nothing is silently re-orthonormalised.

use std::borrow::Cow;

use nalgebra::{Matrix3, Rotation3, Vector3};
use numpy::{PyArrayDyn, PyReadonlyArrayDyn};
use pyo3::prelude::*;

use crate::convert::{check_finite, single_or_batch, to_numpy};
use crate::errors::{run, value_error};

fn vec3(data: &[f64], i: usize) -> Vector3<f64> {
    Vector3::new(data[3 * i], data[3 * i + 1], data[3 * i + 2])
}

fn mat3(data: &[f64], i: usize) -> Matrix3<f64> {
    // Row-major 3×3 block.
    Matrix3::from_row_slice(&data[9 * i..9 * i + 9])
}

fn push_mat3(out: &mut Vec<f64>, m: &Matrix3<f64>) {
    for r in 0..3 {
        for c in 0..3 {
            out.push(m[(r, c)]);
        }
    }
}

fn leading(batched: bool, n: usize, item: &[usize]) -> Vec<usize> {
    let mut shape = if batched { vec![n] } else { vec![] };
    shape.extend_from_slice(item);
    shape
}

/// Vectors `(…, 3)` in, finite-checked.
fn vectors<'a>(
    arr: &'a PyReadonlyArrayDyn<'_, f64>,
    name: &str,
) -> PyResult<(Cow<'a, [f64]>, usize, bool)> {
    let (data, n, batched) = single_or_batch(arr, name, &[3])?;
    check_finite(&data, name, &leading(batched, n, &[3]))?;
    Ok((data, n, batched))
}

/// Matrices `(…, 3, 3)` in, finite-checked.
fn matrices<'a>(
    arr: &'a PyReadonlyArrayDyn<'_, f64>,
    name: &str,
) -> PyResult<(Cow<'a, [f64]>, usize, bool)> {
    let (data, n, batched) = single_or_batch(arr, name, &[3, 3])?;
    check_finite(&data, name, &leading(batched, n, &[3, 3]))?;
    Ok((data, n, batched))
}

/// Rotations `(…, 3, 3)` in, each checked with `rotation_from_matrix(·, tol)`.
fn rotations(
    arr: &PyReadonlyArrayDyn<'_, f64>,
    name: &str,
    tol: f64,
) -> PyResult<(Vec<Rotation3<f64>>, usize, bool)> {
    let (data, n, batched) = matrices(arr, name)?;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        match so3_stiffness::so3::rotation_from_matrix(&mat3(&data, i), tol) {
            Ok(r) => out.push(r),
            Err(e) => {
                let at = if batched {
                    format!("{name}[{i}]")
                } else {
                    name.to_string()
                };
                return Err(value_error(format!("{at}: {e}")));
            }
        }
    }
    Ok((out, n, batched))
}

fn vec_to_mat<'py>(
    py: Python<'py>,
    w: PyReadonlyArrayDyn<'py, f64>,
    f: fn(&Vector3<f64>) -> Matrix3<f64>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let (data, n, batched) = vectors(&w, "w")?;
    let out = run(py, || {
        let mut out = Vec::with_capacity(9 * n);
        for i in 0..n {
            push_mat3(&mut out, &f(&vec3(&data, i)));
        }
        out
    })?;
    to_numpy(py, out, &leading(batched, n, &[3, 3]))
}

/// hat(w) for w of shape (3,) or (N, 3).
#[pyfunction]
pub fn so3_hat<'py>(
    py: Python<'py>,
    w: PyReadonlyArrayDyn<'py, f64>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    vec_to_mat(py, w, so3_stiffness::so3::hat)
}

/// exp(w) for w of shape (3,) or (N, 3).
#[pyfunction]
pub fn so3_exp<'py>(
    py: Python<'py>,
    w: PyReadonlyArrayDyn<'py, f64>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    vec_to_mat(py, w, |w| so3_stiffness::so3::exp(w).into_inner())
}

/// left_jacobian(w).
#[pyfunction]
pub fn so3_left_jacobian<'py>(
    py: Python<'py>,
    w: PyReadonlyArrayDyn<'py, f64>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    vec_to_mat(py, w, so3_stiffness::so3::left_jacobian)
}

/// right_jacobian(w).
#[pyfunction]
pub fn so3_right_jacobian<'py>(
    py: Python<'py>,
    w: PyReadonlyArrayDyn<'py, f64>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    vec_to_mat(py, w, so3_stiffness::so3::right_jacobian)
}

/// left_jacobian_inverse(w).
#[pyfunction]
pub fn so3_left_jacobian_inverse<'py>(
    py: Python<'py>,
    w: PyReadonlyArrayDyn<'py, f64>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    vec_to_mat(py, w, so3_stiffness::so3::left_jacobian_inverse)
}

/// right_jacobian_inverse(w).
#[pyfunction]
pub fn so3_right_jacobian_inverse<'py>(
    py: Python<'py>,
    w: PyReadonlyArrayDyn<'py, f64>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    vec_to_mat(py, w, so3_stiffness::so3::right_jacobian_inverse)
}

/// vee(m) of the skew part of m, shape (3, 3) or (N, 3, 3).
#[pyfunction]
pub fn so3_vee<'py>(
    py: Python<'py>,
    m: PyReadonlyArrayDyn<'py, f64>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let (data, n, batched) = matrices(&m, "m")?;
    let out = run(py, || {
        let mut out = Vec::with_capacity(3 * n);
        for i in 0..n {
            out.extend_from_slice(so3_stiffness::so3::vee(&mat3(&data, i)).as_slice());
        }
        out
    })?;
    to_numpy(py, out, &leading(batched, n, &[3]))
}

/// log(R) for rotations checked to `tol`.
#[pyfunction]
pub fn so3_log<'py>(
    py: Python<'py>,
    r: PyReadonlyArrayDyn<'py, f64>,
    tol: f64,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let (rots, n, batched) = rotations(&r, "R", tol)?;
    let out = run(py, || {
        let mut out = Vec::with_capacity(3 * n);
        for r in &rots {
            out.extend_from_slice(so3_stiffness::so3::log(r).as_slice());
        }
        out
    })?;
    to_numpy(py, out, &leading(batched, n, &[3]))
}

/// adjoint(R) for rotations checked to `tol`.
#[pyfunction]
pub fn so3_adjoint<'py>(
    py: Python<'py>,
    r: PyReadonlyArrayDyn<'py, f64>,
    tol: f64,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let (rots, n, batched) = rotations(&r, "R", tol)?;
    let mut out = Vec::with_capacity(9 * n);
    for r in &rots {
        push_mat3(&mut out, &so3_stiffness::so3::adjoint(r));
    }
    to_numpy(py, out, &leading(batched, n, &[3, 3]))
}

/// Geodesic distance between rotations `a` and `b` (same leading shape).
#[pyfunction]
pub fn so3_distance<'py>(
    py: Python<'py>,
    a: PyReadonlyArrayDyn<'py, f64>,
    b: PyReadonlyArrayDyn<'py, f64>,
    tol: f64,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let (ra, n, batched) = rotations(&a, "a", tol)?;
    let (rb, nb, batched_b) = rotations(&b, "b", tol)?;
    if n != nb || batched != batched_b {
        return Err(crate::errors::shape_error(format!(
            "a and b must have the same shape: dimension 0 of a is {n}, of b is {nb}"
        )));
    }
    let out: Vec<f64> = ra
        .iter()
        .zip(&rb)
        .map(|(x, y)| so3_stiffness::so3::distance(x, y))
        .collect();
    to_numpy(py, out, &leading(batched, n, &[]))
}

/// Nearest rotation (polar factor) of each matrix.
#[pyfunction]
pub fn so3_project_to_rotation<'py>(
    py: Python<'py>,
    m: PyReadonlyArrayDyn<'py, f64>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let (data, n, batched) = matrices(&m, "m")?;
    let mut out = Vec::with_capacity(9 * n);
    for i in 0..n {
        match so3_stiffness::so3::project_to_rotation(&mat3(&data, i)) {
            Ok(r) => push_mat3(&mut out, r.matrix()),
            Err(e) => {
                let at = if batched {
                    format!("m[{i}]")
                } else {
                    "m".into()
                };
                return Err(value_error(format!("{at}: {e}")));
            }
        }
    }
    to_numpy(py, out, &leading(batched, n, &[3, 3]))
}

/// ‖mᵀm − I‖_F of each matrix.
#[pyfunction]
pub fn so3_orthogonality_error<'py>(
    py: Python<'py>,
    m: PyReadonlyArrayDyn<'py, f64>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let (data, n, batched) = matrices(&m, "m")?;
    let out: Vec<f64> = (0..n)
        .map(|i| so3_stiffness::so3::orthogonality_error(&mat3(&data, i)))
        .collect();
    to_numpy(py, out, &leading(batched, n, &[]))
}

/// Registers the functions on `m`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(so3_hat, m)?)?;
    m.add_function(wrap_pyfunction!(so3_vee, m)?)?;
    m.add_function(wrap_pyfunction!(so3_exp, m)?)?;
    m.add_function(wrap_pyfunction!(so3_log, m)?)?;
    m.add_function(wrap_pyfunction!(so3_adjoint, m)?)?;
    m.add_function(wrap_pyfunction!(so3_left_jacobian, m)?)?;
    m.add_function(wrap_pyfunction!(so3_right_jacobian, m)?)?;
    m.add_function(wrap_pyfunction!(so3_left_jacobian_inverse, m)?)?;
    m.add_function(wrap_pyfunction!(so3_right_jacobian_inverse, m)?)?;
    m.add_function(wrap_pyfunction!(so3_distance, m)?)?;
    m.add_function(wrap_pyfunction!(so3_project_to_rotation, m)?)?;
    m.add_function(wrap_pyfunction!(so3_orthogonality_error, m)?)?;
    Ok(())
}
