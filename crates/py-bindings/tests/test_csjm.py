"""CSJM identification bindings: recovery on synthetic data, layouts, tables, errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import robot_stiffness as rs
from robot_stiffness import csjm, so3

K_TRUE = np.array([[30.0, 1.0, 0.5], [1.0, 28.0, -1.0], [0.5, -1.0, 7.0]])
COLUMNS = ["r11", "r12", "r13", "r21", "r22", "r23", "r31", "r32", "r33", "tx", "ty", "tz", "ref"]


def synthetic(rng: np.random.Generator, n: int = 20, noise: float = 0.0):
    """A linear conservative joint: τ = τ₀ + K_D Δζ with K_D = K + ½ hat(τ₀) (Levi-Civita)."""
    tau0 = np.array([0.1, -0.5, 0.2])
    k_d = K_TRUE + 0.5 * so3.hat(tau0)
    r0 = so3.exp(np.array([0.1, 0.2, -0.1]))
    z = 0.02 * rng.normal(size=(n, 3))
    R = np.concatenate([r0[None], r0 @ so3.exp(z)])
    tau = np.concatenate([tau0[None], tau0 + z @ k_d.T + noise * rng.normal(size=(n, 3))])
    return R, tau


def write_csv(path: Path, R: np.ndarray, tau: np.ndarray, ref: int) -> None:
    flags = np.zeros(len(R))
    flags[ref] = 1
    table = np.column_stack([R.reshape(-1, 9), tau, flags])
    lines = [",".join(COLUMNS)] + [",".join(repr(float(v)) for v in row[:-1]) + f",{int(row[-1])}" for row in table]
    path.write_text("\n".join(lines) + "\n")


def test_recovers_k_noise_free(rng):
    R, tau = synthetic(rng)
    fit = csjm.identify(R, tau, ref=0)
    np.testing.assert_allclose(fit.K, K_TRUE, rtol=0, atol=1e-9 * np.abs(K_TRUE).max())
    np.testing.assert_allclose(fit.K_L, -0.5 * so3.hat(tau[0]), atol=1e-12)
    assert fit.n == 20 and fit.order == 1
    assert fit.K.shape == fit.K_D.shape == fit.K_stderr.shape == (3, 3)
    assert fit.det_convergence.shape[1] == 2 and fit.det_convergence[-1, 1] == pytest.approx(np.linalg.det(fit.K))


def test_reference_row_anywhere_and_layouts_agree(rng):
    R, tau = synthetic(rng, noise=1e-3)
    a = csjm.identify(R, tau, ref=0)
    perm = np.r_[1:6, 0, 6:len(R)]
    b = csjm.identify(R[perm], tau[perm], ref=5)
    np.testing.assert_allclose(b.K, a.K, rtol=1e-12)
    c = csjm.identify(np.asfortranarray(R), np.asfortranarray(tau), ref=0)
    np.testing.assert_array_equal(c.K, a.K)
    np.testing.assert_array_equal(c.K_stderr, a.K_stderr)


def test_file_dataframe_and_arrays_agree(rng, tmp_path: Path):
    pd = pytest.importorskip("pandas")
    R, tau = synthetic(rng, noise=1e-3)
    path = tmp_path / "m.csv"
    write_csv(path, R, tau, ref=0)
    from_file = csjm.identify_csv(path)
    R2, tau2, ref = csjm.read_measurements(path)
    assert ref == 0 and R2.shape == R.shape
    from_arrays = csjm.identify(R2, tau2, ref)
    from_df = csjm.identify(pd.read_csv(path))
    for other in (from_arrays, from_df):
        np.testing.assert_allclose(other.K, from_file.K, rtol=1e-12)
        np.testing.assert_allclose(other.K_stderr, from_file.K_stderr, rtol=1e-10)
    doc = from_file.to_dict()
    assert set(doc) >= {"K", "K_D", "K_stderr", "tau0", "n", "order"}
    assert np.array(doc["K"]).shape == (3, 3)


def test_second_order_is_unbiased_by_large_increments(rng):
    """τ with a quadratic term: the first-order fit is biased, the second-order fit is not."""
    R, tau = synthetic(rng, n=40)
    z = np.stack([so3.log(R[0].T @ r) for r in R])
    quad = 200.0 * np.stack([z[:, 0] * z[:, 1], z[:, 1] ** 2, z[:, 0] * z[:, 2]], axis=1)
    tau = tau + quad
    first = csjm.identify(R, tau, ref=0, order=1)
    second = csjm.identify(R, tau, ref=0, order=2)
    err = lambda k: np.linalg.norm(k - K_TRUE) / np.linalg.norm(K_TRUE)  # noqa: E731
    assert err(second.K) < 1e-9
    assert err(first.K) > 1e3 * err(second.K)


def test_errors_name_the_row(rng, tmp_path: Path):
    R, tau = synthetic(rng, n=6)
    bad = R.copy()
    bad[3] = bad[3] * 1.05
    with pytest.raises(rs.InvalidValueError, match=r"R\[3\] is not a rotation matrix"):
        csjm.identify(bad, tau, ref=0)
    assert csjm.identify(bad, tau, ref=0, project=True).n == 6
    with pytest.raises(ValueError, match=r"ref = 9 is not a row index"):
        csjm.identify(R, tau, ref=9)
    with pytest.raises(rs.ShapeError, match=r"tau has 6 rows \(dimension 0\) but R has 7"):
        csjm.identify(R, tau[:6], ref=0)
    with pytest.raises(rs.IdentificationError, match="at least"):
        csjm.identify(R[:3], tau[:3], ref=0)
    nan = tau.copy()
    nan[2, 1] = np.nan
    with pytest.raises(rs.InvalidValueError, match=r"tau contains a non-finite value \(NaN\) at index \[2, 1\]"):
        csjm.identify(R, nan, ref=0)
    path = tmp_path / "two_refs.csv"
    write_csv(path, R, tau, ref=0)
    text = path.read_text().splitlines()
    text[3] = text[3][:-1] + "1"
    path.write_text("\n".join(text) + "\n")
    with pytest.raises(rs.DataFileError, match="2 rows have ref = 1"):
        csjm.identify_csv(path)
    with pytest.raises(FileNotFoundError):
        csjm.identify_csv(tmp_path / "missing.csv")
