"""Python and Rust give the same answers on the same inputs.

``data/reference.json`` holds deterministic inputs and the results the Rust core computes on
them *without* pyo3 or numpy (``tests/it/reference.rs``, run by ``cargo test``, fails if the file
is stale). Here the same inputs go through the Python API — numpy conversion, C and Fortran
layouts, GIL release, result conversion — and must match to 1e-12 (relative to each array's
largest entry; the streaming identification sums per thread, so bitwise equality is not
promised)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from robot_stiffness import csjm, so3
from robot_stiffness.vjm import Robot

from conftest import DATA

REF = json.loads((DATA / "reference.json").read_text())
RTOL = 1e-12


def close(actual, expected, what):
    a = np.asarray(actual, dtype=float)
    e = np.asarray([np.nan if v is None else v for v in np.ravel(np.asarray(expected, dtype=object))], dtype=float)
    e = e.reshape(a.shape)
    scale = np.nanmax(np.abs(e)) if np.isfinite(e).any() else 1.0
    np.testing.assert_array_equal(np.isnan(a), np.isnan(e), err_msg=what)
    ok = ~np.isnan(e)
    assert np.all(np.abs(a[ok] - e[ok]) <= RTOL * scale), f"{what}: max diff {np.abs(a[ok] - e[ok]).max():.3e}"


@pytest.mark.parametrize("layout", [np.ascontiguousarray, np.asfortranarray])
def test_so3_matches_rust(layout):
    w = layout(np.array(REF["so3"]["w"]))
    close(so3.exp(w), REF["so3"]["exp"], "exp")
    close(so3.log(so3.exp(w)), REF["so3"]["log_of_exp"], "log(exp)")
    close(so3.left_jacobian(w), REF["so3"]["left_jacobian"], "left_jacobian")
    close(so3.right_jacobian(w), REF["so3"]["right_jacobian"], "right_jacobian")


@pytest.mark.parametrize("layout", [np.ascontiguousarray, np.asfortranarray])
def test_vjm_matches_rust(layout):
    r = REF["vjm"]
    robot = Robot.bundled()
    q, w, d = (layout(np.array(r[k])) for k in ("q", "wrench", "displacement"))
    close(robot.jacobian(q[:3], model="extended"), r["jacobian_extended_first_rows"], "jacobian")
    for model in ("traditional", "extended"):
        res = robot.identify(q, w, d, model=model, method="qr", gravity=None)  # as the fixture: see reference.rs
        exp = r["identify"][model]
        assert res.rank == exp["rank"], model
        assert res.identifiable.tolist() == exp["identifiable"], model
        close(res.compliance, exp["compliance"], f"{model} compliance")
        close(res.stderr, exp["stderr"], f"{model} stderr")


@pytest.mark.parametrize("layout", [np.ascontiguousarray, np.asfortranarray])
def test_csjm_matches_rust(layout):
    c = REF["csjm"]
    R, tau = layout(np.array(c["R"])), layout(np.array(c["tau"]))
    for order in (1, 2):
        fit = csjm.identify(R, tau, ref=c["ref"], order=order)
        exp = c["fits"][f"order{order}"]
        for key in ("K", "K_D", "K_stderr", "tau0"):
            close(getattr(fit, key), exp[key], f"order {order} {key}")
        assert fit.n == exp["n"]
