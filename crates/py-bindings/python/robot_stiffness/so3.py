"""The rotation group SO(3): ``exp``, ``log``, ``hat``, ``vee``, ``adjoint`` and Jacobians.

Names and conventions follow Sophus/manif and the Rust crate ``so3_stiffness::so3``:

* ``hat(w) @ v == np.cross(w, v)``; ``vee`` is its inverse (of the skew part).
* Perturbations are body-frame (right): ``R @ exp(d)``.
* ``exp(w + d) ≈ exp(w) @ exp(right_jacobian(w) @ d) ≈ exp(left_jacobian(w) @ d) @ exp(w)``.
* ``adjoint(R) == R``: ``R @ hat(w) @ R.T == hat(R @ w)``.

Angles and rotation vectors are in rad. Every function takes one item (a (3,) vector or a
(3, 3) matrix) or a batch with a leading dimension N, and returns the same leading shape.
Rotation inputs are checked (finite, ``‖RᵀR − I‖_F ≤ tol``, ``det R > 0``) and never silently
re-orthonormalised; call :func:`project_to_rotation` explicitly for measured matrices.
"""

from __future__ import annotations

from typing import Any, Union

import numpy as np
import numpy.typing as npt

from . import _core
from ._arguments import checked
from ._arrays import f64

__all__ = [
    "hat",
    "vee",
    "exp",
    "log",
    "adjoint",
    "left_jacobian",
    "right_jacobian",
    "left_jacobian_inverse",
    "right_jacobian_inverse",
    "distance",
    "project_to_rotation",
    "orthogonality_error",
    "DEFAULT_TOL",
]

#: Default tolerance on ``‖RᵀR − I‖_F`` for inputs that must be rotations.
DEFAULT_TOL = 1e-9

Array = npt.NDArray[np.float64]


@checked
def hat(w: Any) -> Array:
    """Skew-symmetric matrix of ``w`` (rad or any unit): ``hat(w) @ v == w × v``.

    ``w``: shape (3,) or (N, 3). Returns (3, 3) or (N, 3, 3), in the frame of ``w``.
    """
    return _core.so3_hat(f64(w, "w"))


@checked
def vee(m: Any) -> Array:
    """Inverse of :func:`hat`, applied to the skew part ``(m − mᵀ)/2``.

    ``m``: shape (3, 3) or (N, 3, 3). Returns (3,) or (N, 3), in the frame of ``m``.
    """
    return _core.so3_vee(f64(m, "m"))


@checked
def exp(w: Any) -> Array:
    """Exponential map (Rodrigues): the rotation by ‖w‖ rad about ``w/‖w‖``.

    ``w``: rotation vector(s) in rad, shape (3,) or (N, 3). Returns rotation matrices
    (3, 3) or (N, 3, 3); if ``w`` has components in frame B, ``exp(w)`` maps vectors of the
    rotated frame to B.
    """
    return _core.so3_exp(f64(w, "w"))


@checked
def log(R: Any, tol: float = DEFAULT_TOL) -> Array:
    """Logarithm map: the rotation vector ω (rad) with ``exp(ω) == R`` and ‖ω‖ ∈ [0, π].

    ``R``: rotation matrices, shape (3, 3) or (N, 3, 3), each checked to ``tol``.
    Returns (3,) or (N, 3), components in the frame R maps to (equivalently, R's own axis).
    Raises :class:`~robot_stiffness.InvalidValueError` naming the index of a non-rotation.
    """
    return _core.so3_log(f64(R, "R"), float(tol))


@checked
def adjoint(R: Any, tol: float = DEFAULT_TOL) -> Array:
    """Adjoint of SO(3), which is ``R`` itself: ``R @ hat(w) @ R.T == hat(R @ w)``.

    ``R``: (3, 3) or (N, 3, 3), checked to ``tol``. Returns the same shape. It maps a body-frame
    (A) rotation vector or moment to the frame R maps into (B).
    """
    return _core.so3_adjoint(f64(R, "R"), float(tol))


@checked
def left_jacobian(w: Any) -> Array:
    """Left Jacobian J_l(w): ``exp(w + d) ≈ exp(J_l(w) @ d) @ exp(w)`` (w, d in rad).

    ``w``: (3,) or (N, 3). Returns (3, 3) or (N, 3, 3). ``J_l(w) == exp(w) @ J_r(w)``.
    """
    return _core.so3_left_jacobian(f64(w, "w"))


@checked
def right_jacobian(w: Any) -> Array:
    """Right Jacobian J_r(w): ``exp(w + d) ≈ exp(w) @ exp(J_r(w) @ d)`` (w, d in rad).

    ``w``: (3,) or (N, 3). Returns (3, 3) or (N, 3, 3). ``J_r(w) == J_l(−w)``.
    """
    return _core.so3_right_jacobian(f64(w, "w"))


@checked
def left_jacobian_inverse(w: Any) -> Array:
    """Inverse of :func:`left_jacobian`, closed form; singular at ‖w‖ = 2πk, k ≥ 1 (rad).

    ``w``: (3,) or (N, 3). Returns (3, 3) or (N, 3, 3).
    """
    return _core.so3_left_jacobian_inverse(f64(w, "w"))


@checked
def right_jacobian_inverse(w: Any) -> Array:
    """Inverse of :func:`right_jacobian`, closed form; singular at ‖w‖ = 2πk, k ≥ 1 (rad).

    ``w``: (3,) or (N, 3). Returns (3, 3) or (N, 3, 3).
    """
    return _core.so3_right_jacobian_inverse(f64(w, "w"))


@checked
def distance(a: Any, b: Any, tol: float = DEFAULT_TOL) -> Union[float, Array]:
    """Geodesic distance ``‖log(aᵀ b)‖`` in rad, in [0, π] (bi-invariant metric).

    ``a``, ``b``: rotations of the same shape, (3, 3) or (N, 3, 3), both mapping into the same
    frame. Returns a float or an (N,) array.
    """
    out = _core.so3_distance(f64(a, "a"), f64(b, "b"), float(tol))
    return float(out) if out.ndim == 0 else out


@checked
def project_to_rotation(m: Any) -> Array:
    """The rotation nearest to ``m`` in the Frobenius norm (orthogonal polar factor, by SVD).

    Use it explicitly on measured matrices that are only approximately orthonormal.
    ``m``: (3, 3) or (N, 3, 3); raises :class:`~robot_stiffness.InvalidValueError` if a matrix
    has ``det ≤ 0`` or is rank deficient, naming its index.
    """
    return _core.so3_project_to_rotation(f64(m, "m"))


@checked
def orthogonality_error(m: Any) -> Union[float, Array]:
    """``‖mᵀ m − I‖_F`` (dimensionless) of a (3, 3) matrix or of each of (N, 3, 3) matrices."""
    out = _core.so3_orthogonality_error(f64(m, "m"))
    return float(out) if out.ndim == 0 else out
