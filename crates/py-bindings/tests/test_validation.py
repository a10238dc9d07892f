"""Issue 14 (Rust side through the bindings): long calls stop on Ctrl-C and on a raising
progress callback, non-finite robots and inputs are refused by name."""

from __future__ import annotations

import _thread
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
    # 16 000 rows: a diagnosis of about a second on the development machine, long enough for
    # an interrupt to land mid-run.
    panda = Robot.bundled()
    camp = vjm.simulate(panda, [], n_poses=2000, wrenches_per_pose=8, seed=11)
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
    # Nothing after the raising call reached the callback.
    assert seen == ["kinematics", "baseline"]


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
