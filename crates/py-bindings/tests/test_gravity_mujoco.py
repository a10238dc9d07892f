"""Gravity against an engine we did not write: MuJoCo (mujoco_testbed.py) on six arms of
example-robot-data, rebuilt from their URDF kinematics and inertials.

Checked: the torques of gravity on every virtual spring (torsions and tilts), the stiffness of
gravity K_G (against central differences of MuJoCo's generalized gravity), the crate's linear
response at small loads, and the tip's sag under its own weight. Skipped with a reason when
mujoco or example-robot-data is not installed (scripts/test.sh installs both).
"""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional, Tuple

import numpy as np
import pytest

from robot_stiffness.vjm import Robot

mujoco = pytest.importorskip("mujoco", reason="mujoco is not installed (pip install mujoco)")

from mujoco_testbed import EXAMPLE_ARMS, MujocoArm, example_urdf  # noqa: E402

#: (URDF below example-robot-data's robots/, base link, tip link)
ARMS: List[Tuple[str, str, str]] = [
    *EXAMPLE_ARMS.values(),
    # The crate's bundled Panda (crates/vjm/data/panda_arm.urdf), to its tool centre point.
    ("bundled", "panda_link0", "panda_hand_tcp"),
]

_BUNDLED = Path(__file__).resolve().parents[2] / "vjm" / "data" / "panda_arm.urdf"


def _urdf_text(rel: str) -> Optional[str]:
    if rel == "bundled":
        return _BUNDLED.read_text()
    p = example_urdf(rel)
    return None if p is None else p.read_text()


def _arm(rel: str, base: str, tip: str) -> Tuple[Robot, MujocoArm, List[int]]:
    text = _urdf_text(rel)
    if text is None:
        pytest.skip(f"example-robot-data's {rel} not found")
    robot = Robot.bundled(tip) if rel == "bundled" else Robot.from_urdf_string(text, base, tip)
    arm = MujocoArm(text, base, tip, tilts=range(robot.n_joints))
    # The crate's extended order [J1z, J1x, J1y, J2z, ...] as MuJoCo dof indices.
    order: List[int] = []
    for k in range(robot.n_joints):
        order += [arm.q_dof[k], *arm.tilt_dof[k]]
    return robot, arm, order


def _q(robot: Robot, rng: np.random.Generator) -> np.ndarray:
    return rng.uniform(-1.3, 1.3, robot.n_joints)


@pytest.mark.parametrize("rel,base,tip", ARMS, ids=[a[0].split("/")[-1] for a in ARMS])
def test_gravity_torques_on_every_spring_are_mujocos(rel, base, tip):
    robot, arm, order = _arm(rel, base, tip)
    rng = np.random.default_rng(7)
    for _ in range(5):
        q = _q(robot, rng)
        ours = robot.gravity_torques(q, "extended")
        theirs = arm.generalized_gravity(q)[order]
        assert np.abs(theirs).max() > 0.1  # a real arm's weight, not an empty model
        np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-10 * np.abs(theirs).max())
    # A payload (1.5 kg, 5 cm along the tip's z) is one more body on the last joint.
    arm.set_payload((1.5, (0.0, 0.0, 0.05)))
    q = _q(robot, rng)
    ours = robot.gravity_torques(q, "extended", payload=(1.5, (0.0, 0.0, 0.05)))
    theirs = arm.generalized_gravity(q)[order]
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-10 * np.abs(theirs).max())
    # A ceiling-mounted arm: gravity along +z of the base.
    arm.set_payload(None)
    arm.set_gravity([0.0, 0.0, 9.80665])
    ours = robot.gravity_torques(q, "extended", gravity=(0.0, 0.0, 9.80665))
    theirs = arm.generalized_gravity(q)[order]
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-10 * np.abs(theirs).max())


@pytest.mark.parametrize("rel,base,tip", ARMS[::2], ids=[a[0].split("/")[-1] for a in ARMS[::2]])
def test_gravity_stiffness_is_the_derivative_of_mujocos_gravity(rel, base, tip):
    robot, arm, order = _arm(rel, base, tip)
    rng = np.random.default_rng(11)
    q = _q(robot, rng)
    ours = robot.gravity_stiffness(q, "extended")
    m = len(order)
    h = 1e-6
    fd = np.zeros((m, m))
    for i in range(m):
        e = np.zeros(arm.model.nv)
        e[order[i]] = h
        fd[:, i] = ((arm.generalized_gravity(q, e) - arm.generalized_gravity(q, -e)) / (2 * h))[order]
    assert np.abs(ours).max() > 1.0
    np.testing.assert_allclose(ours, fd, rtol=0, atol=1e-7 * np.abs(ours).max())
    np.testing.assert_array_equal(ours, ours.T)


def _springs(robot: Robot, arm: MujocoArm, rng: np.random.Generator):
    """Panda-class springs: torsions 2–10 kN·m/rad, tilts 3× stiffer; compliances in the
    crate's extended order and the same springs as MuJoCo laws."""
    n = robot.n_joints
    kz = rng.uniform(2e3, 1e4, n)
    kt = 3.0 * kz
    c = 1.0 / np.ravel(np.column_stack([kz, kt, kt]))
    laws = arm.springs_for(kz, {k: (kt[k], kt[k]) for k in range(n)})
    return c, laws


@pytest.mark.parametrize("rel,base,tip", ARMS, ids=[a[0].split("/")[-1] for a in ARMS])
def test_linear_response_is_mujocos_at_small_loads(rel, base, tip):
    robot, arm, _ = _arm(rel, base, tip)
    rng = np.random.default_rng(3)
    c, laws = _springs(robot, arm, rng)
    arm.set_gravity([0.0, 0.0, 0.0])
    for _ in range(3):
        q = _q(robot, rng)
        w = np.concatenate([rng.normal(0, 0.1, 3), rng.normal(0, 0.01, 3)])
        p0, _ = arm.tip(q)
        p1, _ = arm.tip(q, arm.equilibrium(q, laws, w))
        ours = robot.predict_deflection(c, q, w, "extended", allow_outside_limits=True)[:3]
        # Agreement to the geometric non-linearity (θ ~ 1e-5 rad here): measured ≤ 4e-5.
        assert np.linalg.norm(p1 - p0 - ours) <= 1e-3 * np.linalg.norm(ours)


@pytest.mark.parametrize("rel,base,tip", ARMS, ids=[a[0].split("/")[-1] for a in ARMS])
def test_sag_under_own_weight_is_mujocos(rel, base, tip):
    """The tip's static sag relative to the rigid kinematics: J C τ_g to first order, and
    J (K − K_G)⁻¹ τ_g with gravity's own stiffness, which must come closer to MuJoCo."""
    robot, arm, _ = _arm(rel, base, tip)
    rng = np.random.default_rng(5)
    c, laws = _springs(robot, arm, rng)
    for _ in range(2):
        q = _q(robot, rng)
        rigid, _ = arm.tip(q)
        sag, _ = arm.tip(q, arm.equilibrium(q, laws))
        truth = sag - rigid
        jac = robot.jacobian(q, "extended")[:3]
        tau = robot.gravity_torques(q, "extended")
        first = jac @ (c * tau)
        with_kg = jac @ np.linalg.solve(np.diag(1.0 / c) - robot.gravity_stiffness(q, "extended"), tau)
        e1 = np.linalg.norm(truth - first) / np.linalg.norm(truth)
        e2 = np.linalg.norm(truth - with_kg) / np.linalg.norm(truth)
        assert np.linalg.norm(truth) > 1e-4  # a visible sag (0.1 mm or more)
        assert e1 < 0.03, e1
        assert e2 < 0.02, e2


@pytest.mark.parametrize("rel,base,tip", ARMS, ids=[a[0].split("/")[-1] for a in ARMS])
def test_static_equilibrium_under_weight_and_load_is_mujocos(rel, base, tip):
    """The crate's non-linear equilibrium on the deflected chain is the same physics as
    MuJoCo's: the sag under the arm's weight with a payload, and what a measurement records
    (loaded − unloaded, both under gravity), agree to the solvers' tolerance."""
    robot, arm, _ = _arm(rel, base, tip)
    rng = np.random.default_rng(17)
    c, laws = _springs(robot, arm, rng)
    payload = (2.0, (0.01, -0.02, 0.08))
    arm.set_payload(payload)
    for _ in range(2):
        q = _q(robot, rng)
        rigid, rigid_r = arm.tip(q)
        rest_theta = arm.equilibrium(q, laws)
        rest, rest_r = arm.tip(q, rest_theta)
        sag = robot.gravity_sag(c, q, "extended", payload=payload)
        assert np.linalg.norm(rest - rigid) > 1e-4
        np.testing.assert_allclose(sag[:3], rest - rigid, rtol=0, atol=1e-9 * np.linalg.norm(rest - rigid))
        # The tip's rotation of the sag, as a rotation vector of R_rest R_rigidᵀ.
        dr = rest_r @ rigid_r.T
        angle = np.arccos(np.clip((np.trace(dr) - 1) / 2, -1, 1))
        assert abs(np.linalg.norm(sag[3:]) - angle) <= 1e-9 * max(angle, 1e-6)
        w = np.concatenate([rng.uniform(-30, 30, 3), rng.uniform(-1.5, 1.5, 3)])
        loaded, _ = arm.tip(q, arm.equilibrium(q, laws, w))
        d = robot.deflection_under_gravity(c, q, w, "extended", payload=payload)
        np.testing.assert_allclose(d[:3], loaded - rest, rtol=0, atol=1e-8 * np.linalg.norm(loaded - rest))
        # And the weightless linear model is off by much more than that: gravity matters.
        lin = robot.predict_deflection(c, q, w, "extended", allow_outside_limits=True)[:3]
        assert np.linalg.norm(lin - (loaded - rest)) > 100 * np.linalg.norm(d[:3] - (loaded - rest))


@pytest.mark.parametrize("rel,base,tip", [ARMS[0], ARMS[4], ARMS[6]], ids=["panda.urdf", "xarm7.urdf", "bundled"])
def test_compensating_weight_and_payload_leaves_nothing_when_run_in_mujoco(rel, base, tip):
    """Issue 22: a payload trajectory compensated with gravity, run in MuJoCo, reaches the
    nominal (rigid) tip: what remains is far below 5 % of the uncompensated absolute error.
    Compensating the payload's load alone (the weightless model) leaves most of it."""
    from robot_stiffness import vjm

    robot, arm, _ = _arm(rel, base, tip)
    rng = np.random.default_rng(23)
    c, laws = _springs(robot, arm, rng)
    mass, centre = 3.0, (0.0, 0.0, 0.05)
    arm.set_payload((mass, centre))
    lo, hi = np.array(robot.limits).T
    q = lo + (hi - lo) * rng.uniform(0.25, 0.75, (6, robot.n_joints))
    with_weight = vjm.compensate(robot, q, c, model="extended", payload=(mass, *centre), gravity=(0.0, 0.0, -9.80665))
    load_only = vjm.compensate(robot, q, c, model="extended", payload=(mass, *centre), load_only=True)
    assert all(s == "converged" for s in with_weight.status), with_weight.status
    for i in range(len(q)):
        target, _ = arm.tip(q[i])
        before = np.linalg.norm(arm.tip(q[i], arm.equilibrium(q[i], laws))[0] - target)
        after = np.linalg.norm(arm.tip(with_weight.q[i], arm.equilibrium(with_weight.q[i], laws))[0] - target)
        partial = np.linalg.norm(arm.tip(load_only.q[i], arm.equilibrium(load_only.q[i], laws))[0] - target)
        assert before > 5e-4  # half a millimetre or more of sag to correct
        assert after <= 1e-6 * before, (i, before, after)
        assert partial >= 0.2 * before, (i, before, partial)


@pytest.mark.parametrize("rel,base,tip", [ARMS[-1], EXAMPLE_ARMS["kinova"], EXAMPLE_ARMS["xarm7"]],
                         ids=["bundled", "kinova", "xarm7"])
def test_a_saved_model_predicts_the_sag_mujoco_finds(rel, base, tip):
    """A traditional model identified from a noise-free campaign (the testbed's, with the
    torsions of the MuJoCo arm): ``StiffnessModel.predict_sag`` — with and
    without a 2 kg payload — is the tip's static sag MuJoCo finds for those springs, to 1e-5 of
    it (the identification's and the equilibrium's accuracy), and every pose is identified."""
    text = _urdf_text(rel)
    if text is None:
        pytest.skip(f"example-robot-data's {rel} not found")
    robot = Robot.bundled(tip) if rel == "bundled" else Robot.from_urdf_string(text, base, tip)
    arm = MujocoArm(text, base, tip)
    rng = np.random.default_rng(9)
    kz = rng.uniform(2e3, 1e4, robot.n_joints)
    from robot_stiffness import vjm

    camp = vjm.simulate(robot, [], n_poses=30, noise=False, torsion=1.0 / kz, seed=4)
    m = camp.measurements
    model = robot.identify(m.q, m.wrench, m.displacement, "traditional").stiffness_model
    laws = arm.springs_for(kz, {})
    payload = (2.0, (0.0, 0.0, 0.05))
    for _ in range(3):
        q = rng.uniform(-1.2, 1.2, robot.n_joints)
        lo, hi = np.array(robot.limits).T
        q = np.clip(q, lo + 0.1, hi - 0.1)
        rigid, _ = arm.tip(q)
        for pl in (None, payload):
            arm.set_payload(pl)
            truth = arm.tip(q, arm.equilibrium(q, laws))[0] - rigid
            p = model.predict_sag(q, payload=None if pl is None else (pl[0], *pl[1]))
            assert bool(p.identified[0])
            assert np.linalg.norm(truth) > 1e-4
            np.testing.assert_allclose(p.deflection[0, :3], truth, rtol=0, atol=1e-5 * np.linalg.norm(truth))
        arm.set_payload(None)
