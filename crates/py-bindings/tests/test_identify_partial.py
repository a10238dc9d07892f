"""Partial identification statistics through Python: parts merged in any grouping (also after
pickling) equal the single-pass identification; incompatible parts are refused."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from robot_stiffness import ArgumentTypeError, InvalidValueError, ShapeError
from robot_stiffness.vjm import Identification, IdentificationPartial, Robot, simulate


@pytest.fixture(scope="module")
def campaign():  # type: ignore[no-untyped-def]
    robot = Robot.bundled()
    effects = [{"effect": "joint_tilt", "joint": 4, "axis": "y", "compliance": 4e-5}]
    return robot, simulate(robot, effects, n_poses=150, wrenches_per_pose=4, seed=12).measurements


def assert_same(a: Identification, b: Identification, tol: float) -> None:
    """Same rank, aliases and identifiable set; compliances and base parameters within ``tol``
    relative to the largest of them (a compliance 100× smaller than its neighbours carries
    their rounding too), standard errors and the residual within ``tol`` each."""
    assert (a.rank, a.aliases, a.n_equations, a.labels) == (b.rank, b.aliases, b.n_equations, b.labels)
    assert np.array_equal(a.identifiable, b.identifiable)
    ok = a.identifiable
    x, y = a.compliance[ok], b.compliance[ok]
    assert np.max(np.abs(x - y)) <= tol * np.max(np.abs(y)), np.max(np.abs(x - y)) / np.max(np.abs(y))
    sx, sy = a.stderr[ok], b.stderr[ok]
    assert np.all(np.abs(sx - sy) <= tol * sy), np.max(np.abs(sx - sy) / sy)
    va = np.array([c.value for c in a.combinations])
    vb = np.array([c.value for c in b.combinations])
    assert np.max(np.abs(va - vb)) <= tol * np.max(np.abs(vb))
    assert abs(a.residual_rms - b.residual_rms) <= tol * b.residual_rms


@pytest.mark.parametrize("model", ["traditional", "extended"])
@pytest.mark.parametrize("rotations", [False, True])
def test_three_parts_in_two_groupings_equal_the_single_pass(campaign, model, rotations):
    robot, m = campaign
    rot = None
    if rotations:
        # The simulated campaign measures no rotations: predicted ones with 1 µrad noise.
        rng = np.random.default_rng(7)
        c = np.full(21, 5e-5)
        rot = robot.predict_deflection(c, m.q, m.wrench, "extended")[:, 3:] + 1e-6 * rng.normal(size=(len(m), 3))
    single = robot.identify(m.q, m.wrench, m.displacement, model, rotation=rot, method="qr", gravity=None)
    cuts = [0, 97, 401, len(m)]
    parts = [
        robot.identify_partial(m.q[s:e], m.wrench[s:e], m.displacement[s:e], model,
                               rotation=None if rot is None else rot[s:e])
        for s, e in zip(cuts, cuts[1:])
    ]
    # Each part travels through pickle, as it does to and from a Dask worker.
    parts = [pickle.loads(pickle.dumps(p)) for p in parts]
    left = parts[0].merge(parts[1]).merge(parts[2])
    right = parts[0].merge(parts[1].merge(parts[2]))
    assert left.n_measurements == right.n_measurements == len(m)
    for merged in (left, right, IdentificationPartial.merge_all(parts)):
        got = merged.finish()
        assert got.method == "qr"
        assert_same(got, single, 1e-12)
        assert got.stiffness_model is not None


def test_empty_partial_is_neutral(campaign):
    robot, m = campaign
    whole = robot.identify_partial(m.q, m.wrench, m.displacement)
    empty = IdentificationPartial.empty(robot)
    assert empty.n_measurements == 0
    assert_same(empty.merge(whole).finish(), whole.finish(), 1e-14)


def test_a_table_works_like_arrays(campaign):
    pd = pytest.importorskip("pandas")
    robot, m = campaign
    table = pd.DataFrame(m.to_dataframe())
    a = robot.identify_partial(table).finish()
    b = robot.identify_partial(m.q, m.wrench, m.displacement).finish()
    assert_same(a, b, 1e-15)


def test_incompatible_parts_are_refused_naming_what_differs(campaign):
    robot, m = campaign
    a = robot.identify_partial(m.q[:200], m.wrench[:200], m.displacement[:200])
    cases = [
        (robot.identify_partial(m.q[200:], m.wrench[200:], m.displacement[200:], "extended"), "model"),
        (robot.identify_partial(m.q[200:], m.wrench[200:], m.displacement[200:],
                                noise_sigma=[2e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5]), "options"),
        (IdentificationPartial.empty(Robot.bundled("panda_hand_tcp")), "robot kinematics"),
    ]
    for other, what in cases:
        with pytest.raises(InvalidValueError, match=f"different {what}"):
            a.merge(other)
    with pytest.raises(ArgumentTypeError, match="IdentificationPartial"):
        a.merge("not a partial")  # type: ignore[arg-type]
    with pytest.raises(InvalidValueError, match="at least one"):
        IdentificationPartial.merge_all([])


def test_bad_part_is_refused_like_identify(campaign):
    robot, m = campaign
    with pytest.raises(ShapeError, match="wrench"):
        robot.identify_partial(m.q[:10], m.wrench[:9], m.displacement[:10])
    q = m.q[:20].copy()
    q[3, 1] = 7.0  # outside joint 2's limits
    with pytest.raises(Exception, match="q2"):
        robot.identify_partial(q, m.wrench[:20], m.displacement[:20])
