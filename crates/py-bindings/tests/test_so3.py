"""SO(3): identities checked against an independent numpy implementation and finite differences."""

from __future__ import annotations

import numpy as np
import pytest

import robot_stiffness as rs
from robot_stiffness import so3


def expm_series(w: np.ndarray) -> np.ndarray:
    """exp(hat(w)) by scaling and squaring of the Taylor series: independent of Rodrigues."""
    k = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]], dtype=float)
    s = max(0, int(np.ceil(np.log2(max(np.linalg.norm(w), 1e-300)))) + 4)
    a = k / 2.0**s
    term = np.eye(3)
    out = np.eye(3)
    for n in range(1, 30):
        term = term @ a / n
        out = out + term
    for _ in range(s):
        out = out @ out
    return out


def random_vectors(rng: np.random.Generator, n: int, max_angle: float = 3.0) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    return v * rng.uniform(0.0, max_angle, size=(n, 1))


def test_hat_is_the_cross_product(rng):
    w, v = rng.normal(size=(2, 20, 3))
    h = so3.hat(w)
    assert h.shape == (20, 3, 3)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", h, v), np.cross(w, v), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(so3.vee(h), w)


def test_exp_matches_an_independent_series(rng):
    for w in random_vectors(rng, 25):
        np.testing.assert_allclose(so3.exp(w), expm_series(w), rtol=0, atol=1e-14)


def test_log_inverts_exp_including_small_and_near_pi_angles(rng):
    w = np.concatenate(
        [random_vectors(rng, 30), [[1e-10, -2e-10, 3e-11], [0.0, 0.0, np.pi - 1e-6]]]
    )
    np.testing.assert_allclose(so3.log(so3.exp(w)), w, rtol=0, atol=1e-9)
    small = so3.log(so3.exp(w[:-1]))
    np.testing.assert_allclose(small[-1], w[-2], rtol=1e-12, atol=0)


def test_right_and_left_jacobians_match_finite_differences(rng):
    h = 1e-6
    for w in random_vectors(rng, 10, max_angle=2.5):
        R = so3.exp(w)
        jr = so3.right_jacobian(w)
        jl = so3.left_jacobian(w)
        for k in range(3):
            d = np.zeros(3)
            d[k] = h
            # exp(w + d) ≈ exp(w) exp(J_r d) ≈ exp(J_l d) exp(w): central differences.
            right = (so3.log(R.T @ so3.exp(w + d)) - so3.log(R.T @ so3.exp(w - d))) / (2 * h)
            left = (so3.log(so3.exp(w + d) @ R.T) - so3.log(so3.exp(w - d) @ R.T)) / (2 * h)
            np.testing.assert_allclose(jr[:, k], right, atol=1e-8)
            np.testing.assert_allclose(jl[:, k], left, atol=1e-8)


def test_jacobian_identities_and_inverses(rng):
    w = random_vectors(rng, 12, max_angle=3.0)
    R = so3.exp(w)
    np.testing.assert_allclose(so3.left_jacobian(w), R @ so3.right_jacobian(w), atol=1e-14)
    np.testing.assert_allclose(so3.left_jacobian(-w), so3.right_jacobian(w), atol=0)
    eye = np.broadcast_to(np.eye(3), (12, 3, 3))
    np.testing.assert_allclose(so3.left_jacobian_inverse(w) @ so3.left_jacobian(w), eye, atol=1e-12)
    np.testing.assert_allclose(so3.right_jacobian_inverse(w) @ so3.right_jacobian(w), eye, atol=1e-12)


def test_adjoint_conjugates_hat(rng):
    w = random_vectors(rng, 8)
    v = rng.normal(size=(8, 3))
    R = so3.exp(w)
    ad = so3.adjoint(R)
    lhs = R @ so3.hat(v) @ np.transpose(R, (0, 2, 1))
    rhs = so3.hat(np.einsum("nij,nj->ni", ad, v))
    np.testing.assert_allclose(lhs, rhs, atol=1e-14)


def test_distance_and_projection(rng):
    w = random_vectors(rng, 5, max_angle=1.0)
    a = so3.exp(w)
    d = np.array([0.0, 0.0, 0.3])
    b = a @ so3.exp(d)
    np.testing.assert_allclose(so3.distance(a, b), 0.3, rtol=1e-13)
    assert isinstance(so3.distance(a[0], b[0]), float)
    noisy = a + 1e-4 * rng.normal(size=a.shape)
    p = so3.project_to_rotation(noisy)
    assert np.all(so3.orthogonality_error(p) < 1e-14)
    assert np.all(so3.distance(p, a) < 1e-3)


def test_fortran_and_strided_inputs_give_identical_results(rng):
    w = random_vectors(rng, 40)
    c = so3.exp(w)
    np.testing.assert_array_equal(so3.exp(np.asfortranarray(w)), c)
    big = np.zeros((40, 6))
    big[:, ::2] = w
    np.testing.assert_array_equal(so3.exp(big[:, ::2]), c)
    np.testing.assert_array_equal(so3.log(np.asfortranarray(c)), so3.log(c))
    np.testing.assert_array_equal(so3.exp(w.astype(np.float32)), so3.exp(w.astype(np.float32).astype(float)))
    assert so3.exp([0.1, 0.2, 0.3]).shape == (3, 3)


def test_bad_shapes_name_the_dimension():
    with pytest.raises(ValueError, match=r"w must have shape \(3,\) or \(N, 3\).*dimension 1 has size 2"):
        so3.exp(np.zeros((4, 2)))
    with pytest.raises(rs.ShapeError, match="dimension"):
        so3.log(np.zeros((2, 3, 4)))


def test_bad_values_are_named():
    with pytest.raises(rs.InvalidValueError, match=r"non-finite value \(NaN\) at index \[1, 2\]"):
        so3.exp(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, np.nan]]))
    R = np.stack([np.eye(3), 1.1 * np.eye(3)])
    with pytest.raises(ValueError, match=r"R\[1\].*not a rotation"):
        so3.log(R)
    with pytest.raises(rs.StiffnessError, match="determinant"):
        so3.project_to_rotation(np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(rs.InvalidValueError, match="numeric"):
        so3.exp(["a", "b", "c"])


def test_a_panic_in_the_core_becomes_internal_error():
    from robot_stiffness import _core

    with pytest.raises(rs.InternalError, match="deliberate panic") as info:
        _core._panic_for_tests()
    assert isinstance(info.value, RuntimeError) and isinstance(info.value, rs.StiffnessError)
