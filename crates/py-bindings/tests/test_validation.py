"""Issue 14 (Rust side through the bindings): long calls stop on Ctrl-C and on a raising
progress callback, non-finite robots and inputs are refused by name."""

from __future__ import annotations

import _thread
import dataclasses
import threading
import time

import numpy as np
import pytest

import robot_stiffness as rs
from robot_stiffness import so3, vjm
from robot_stiffness.vjm import Robot

TWO_JOINTS = """<?xml version="1.0"?>
<robot name="two">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="tool"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="{xyz}"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.5 0 0"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="tool_fixed" type="fixed"><parent link="l2"/><child link="tool"/><origin xyz="0.3 0 0"/></joint>
</robot>
"""


@pytest.fixture(scope="module")
def big_campaign():
    # 400 000 rows: a diagnosis of about 0.9 s on the development machine, long enough for an
    # interrupt to land mid-run (120 000 rows took 0.28 s once the rows went through the passes
    # in lane-wise batches; 48 000 rows had taken 0.28 s once the passes were fused).
    panda = Robot.bundled()
    camp = vjm.simulate(panda, [], n_poses=50000, wrenches_per_pose=8, seed=11)
    return panda, camp


# ----------------------------------------------------------------------------- robot model


def test_a_nan_origin_in_the_urdf_is_refused_naming_joint_and_attribute(tmp_path):
    path = tmp_path / "nan.urdf"
    path.write_text(TWO_JOINTS.format(xyz="nan 0 0.1"))
    with pytest.raises(rs.RobotModelError, match=r"joint `j1`: origin xyz"):
        Robot.from_urdf(path, "base", "tool")
    # The same file with a finite origin loads (the template itself is fine).
    path.write_text(TWO_JOINTS.format(xyz="0 0 0.1"))
    assert Robot.from_urdf(path, "base", "tool").n_joints == 2


# ----------------------------------------------------------------------------- SO(3)


def test_exp_of_a_huge_vector_is_a_rotation():
    r = so3.exp(np.array([1e308, -1e308, 1e308]))
    assert np.all(np.isfinite(r))
    assert np.allclose(r.T @ r, np.eye(3), atol=1e-13)
    assert abs(np.linalg.det(r) - 1.0) < 1e-13


def test_non_finite_so3_input_is_refused_naming_the_argument():
    with pytest.raises(rs.InvalidValueError, match=r"\bw\b.*non-finite"):
        so3.exp(np.array([np.nan, 0.0, 0.0]))


# ----------------------------------------------------------------------------- interruption


def test_a_raising_progress_callback_propagates_its_own_exception(big_campaign):
    panda, camp = big_campaign
    seen = []

    def callback(stage, done, total):
        seen.append(stage)
        if stage == "baseline":
            raise ValueError("stop here, please")

    with pytest.raises(ValueError, match="stop here, please"):
        vjm.diagnose(panda, camp.measurements, progress=callback)
    # Nothing after the raising call reached the callback (the passes over the rows report
    # their progress too, before the named stages).
    assert [s for s in seen if s != "pass over the rows"] == ["kinematics", "baseline"]
    assert seen[-1] == "baseline"


def test_keyboard_interrupt_raised_by_the_callback_propagates(big_campaign):
    panda, camp = big_campaign

    def callback(stage, done, total):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        vjm.diagnose(panda, camp.measurements, progress=callback)


def test_sigint_during_a_long_diagnose_ends_it_within_a_second(big_campaign):
    panda, camp = big_campaign
    start = time.perf_counter()
    vjm.diagnose(panda, camp.measurements)
    full = time.perf_counter() - start
    # The interrupt must land mid-run for the test to mean anything.
    assert full > 0.3, f"the diagnosis takes only {full:.2f} s; make the campaign larger"
    delay = full / 4
    timer = threading.Timer(delay, _thread.interrupt_main)
    start = time.perf_counter()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            vjm.diagnose(panda, camp.measurements)
    finally:
        timer.cancel()
    stopped_after = time.perf_counter() - start - delay
    # Without polling the interrupt surfaces only when the call returns, 0.75·full later.
    assert stopped_after < min(1.0, 0.5 * full), (
        f"stopped {stopped_after:.2f} s after Ctrl-C (full run {full:.2f} s)"
    )


# ----------------------------------------------------------------------------- effects, limits


def test_an_unknown_effect_key_is_refused_listing_the_valid_ones():
    panda = Robot.bundled()
    tilt = {"effect": "joint_tilt", "joint": 3, "axis": "x", "compliance": 5e-5, "complience": 1e-4}
    with pytest.raises(rs.InvalidValueError, match=r"unknown key `complience`.*joint, axis, compliance"):
        vjm.simulate(panda, [tilt], n_poses=4, wrenches_per_pose=2)
    from robot_stiffness import csjm

    with pytest.raises(rs.InvalidValueError, match=r"cable_hysteresis.*unknown key `frict`"):
        csjm.simulate([{"effect": "cable_hysteresis", "frict": 2.0}])


@pytest.mark.parametrize("value", [-1.0, float("nan")])
def test_a_bad_effect_value_blames_the_effect_not_a_file_column(value):
    panda = Robot.bundled()
    tilt = {"effect": "joint_tilt", "joint": 3, "axis": "x", "compliance": value}
    with pytest.raises(rs.StiffnessError) as info:
        vjm.simulate(panda, [tilt], n_poses=4, wrenches_per_pose=2)
    msg = str(info.value)
    assert "effects[0] (joint_tilt): `compliance`" in msg, msg
    assert "'dx'" not in msg and "line" not in msg, msg
    from robot_stiffness import csjm

    with pytest.raises(rs.InvalidValueError, match=r"cable_hysteresis.*`friction` must be finite and ≥ 0"):
        csjm.simulate([{"effect": "cable_hysteresis", "friction": value}])


def test_an_implausible_force_max_blames_the_campaign_not_a_file_column():
    panda = Robot.bundled()
    with pytest.raises(rs.StiffnessError) as info:
        vjm.simulate(panda, [], n_poses=4, wrenches_per_pose=2, force_max=1e9)
    msg = str(info.value)
    assert "force" in msg and "'dx'" not in msg and "line" not in msg, msg


def test_joint_angles_outside_the_limits_are_refused_unless_allowed(big_campaign):
    panda, camp = big_campaign
    m = camp.measurements
    q = np.array(m.q, copy=True)[:400]
    q[7, 3] = 1.0  # joint 4 of the Panda lives in [-3.07, -0.07] rad
    data = dataclasses.replace(
        m,
        q=q,
        wrench=np.asarray(m.wrench)[:400],
        displacement=np.asarray(m.displacement)[:400],
        pose=None if m.pose is None else list(m.pose)[:400],
        set=None if m.set is None else list(m.set)[:400],
    )
    # Row 7 of the arrays (line 9 of the file they would be written to).
    with pytest.raises(rs.DataFileError, match=r"row 7.*column 'q4' \(joint `panda_joint4`\)"):
        vjm.diagnose(panda, data)
    vjm.diagnose(panda, data, allow_outside_limits=True)


def test_the_new_error_classes_are_stiffness_errors():
    assert issubclass(rs.CancelledError, rs.StiffnessError) and issubclass(rs.CancelledError, RuntimeError)
    assert issubclass(rs.ConvergenceError, rs.StiffnessError) and issubclass(rs.ConvergenceError, RuntimeError)
