"""Unaligned float64 arrays (numpy allows them: buffers rebuilt by pickle protocol 5 or Dask's
serialisation, ``frombuffer`` at an odd offset) give the same results as aligned copies.

Regression: the bindings read them as Rust slices, which panicked in debug builds ("The
pointer must be aligned", a ``PanicException`` that hung a Dask worker) and was undefined
behaviour in release builds."""

from __future__ import annotations

import numpy as np

from conftest import random_q, random_wrench
from robot_stiffness.vjm import Robot


def unaligned(a: np.ndarray) -> np.ndarray:
    """A copy of ``a`` (C order) at an address one byte past an aligned one."""
    buf = np.zeros(a.nbytes + 1, dtype=np.uint8)
    out: np.ndarray = np.ndarray(a.shape, dtype=np.float64, buffer=buf, offset=1)
    out[...] = a
    assert not out.flags.aligned
    return out


def test_kinematics_of_unaligned_inputs(panda: Robot, rng):
    q = random_q(panda, rng, 50)
    assert np.array_equal(panda.jacobian(unaligned(q)), panda.jacobian(q))
    assert np.array_equal(panda.forward_kinematics(unaligned(q)), panda.forward_kinematics(q))
    assert np.array_equal(panda.jacobian(unaligned(q)[::3]), panda.jacobian(q[::3]))


def test_identification_of_unaligned_inputs(panda: Robot, rng):
    q = random_q(panda, rng, 300)
    w = random_wrench(rng, 300)
    c = np.array([1.0e-4, 1.0e-4, 1.5e-4, 1.5e-4, 3.0e-4, 4.0e-4, 5.0e-4])
    d = panda.predict_deflection(unaligned(c), unaligned(q), unaligned(w))[:, :3]
    assert np.array_equal(d, panda.predict_deflection(c, q, w)[:, :3])
    d = d + 1e-6 * rng.normal(size=d.shape)
    a = panda.identify(unaligned(q), unaligned(w), unaligned(d))
    b = panda.identify(q, w, d)
    assert a.to_dict() == b.to_dict()
    pa = panda.identify_partial(unaligned(q), unaligned(w), unaligned(d)).finish()
    pb = panda.identify_partial(q, w, d).finish()
    assert pa.to_dict() == pb.to_dict()
