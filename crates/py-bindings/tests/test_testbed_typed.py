"""The truth and spec of a simulated campaign and a plan's noise model are typed classes
(``robot_stiffness.testbed``) that carry every key the core sends, and give it back."""

from __future__ import annotations

import pickle
import re

import pytest

from robot_stiffness import _core, testbed, vjm
from robot_stiffness._core_values import build
from robot_stiffness import InvalidValueError

# One of every effect kind, with the parameters simulate takes (joints 1-based).
ALL_EFFECTS = [
    {"effect": "joint_tilt", "joint": 2, "axis": "x", "compliance": 5e-5},
    {"effect": "joint_torsion_nonlinear", "joint": 3, "ratio": 3.0, "t1": 5.0, "t2": 20.0},
    {"effect": "link_translation", "joint": 4, "axis": "y", "compliance": 1e-7},
    {"effect": "joint_backlash", "joint": 5, "lost_motion": 1e-3},
    {"effect": "wrench_bias", "bias": [1.0, 2.0, 3.0, 0.1, 0.2, 0.3]},
    {"effect": "frame_misalignment", "rotation": [0.01, 0.02, 0.0]},
    {"effect": "geometric_nonlinearity"},
    {"effect": "joint_torsion_angle_dependent", "joint": 6, "amplitude": 0.2},
    {"effect": "pose_drift", "sigma": 1e-5},
    {"effect": "mount_compliance", "translation": 1e-7, "rotation": 1e-6},
    {"effect": "tool_axial_compliance", "compliance": 1e-6},
    {"effect": "sensor_crosstalk", "coupling": 0.01},
]


@pytest.fixture(scope="module")
def robot():
    return vjm.Robot.bundled()


def test_every_effect_kind_of_the_core_has_its_class(robot):
    # The core names the kinds it accepts; a kind it gains without a class here fails.
    with pytest.raises(InvalidValueError) as e:
        vjm.simulate(robot, [{"effect": "no_such_effect"}], n_poses=4)
    listed = re.search(r"\(([^)]*)\)", str(e.value))
    assert listed is not None
    assert set(listed.group(1).split(", ")) == set(testbed.EFFECTS)
    assert {e["effect"] for e in ALL_EFFECTS} == set(testbed.EFFECTS)


@pytest.mark.parametrize("gravity", [None, vjm.DEFAULT_GRAVITY])
def test_truth_and_spec_carry_every_key_of_the_core(robot, gravity):
    g = None if gravity is None else tuple(float(x) for x in gravity)
    core = _core.vjm_simulate(robot._inner, ALL_EFFECTS, n_poses=6, wrenches_per_pose=2, seed=4, gravity=g)
    truth, spec = build(testbed.TrueModel, core.truth), build(testbed.CampaignSpec, core.spec)
    # Back to the core's value, key for key: a key no field takes would be lost here.
    assert truth.to_dict() == core.truth
    assert spec.to_dict() == core.spec
    assert ("gravity" in spec.to_dict()) == (gravity is not None)
    kinds = [type(e) for e in truth.effects]
    assert kinds == [testbed.EFFECTS[e["effect"]] for e in ALL_EFFECTS]
    # Two kinds with the same keys stay apart (the tag decides, not the keys).
    assert isinstance(truth.effects[0], testbed.JointTilt)
    assert isinstance(truth.effects[2], testbed.LinkTranslation)
    spring = truth.effects[1].spring
    assert isinstance(spring, testbed.HarmonicDriveSpring) and spring.t1 == 5.0 and spring.t2 == 20.0
    assert spec.n_poses == 6 and spec.wrenches_per_pose == 2 and spec.seed == 4


def test_a_campaign_and_a_plan_are_typed_and_pickle(robot):
    c = vjm.simulate(robot, ALL_EFFECTS[:4], n_poses=4, seed=2)
    assert isinstance(c.truth, testbed.TrueModel) and isinstance(c.spec, testbed.CampaignSpec)
    assert [e.joint for e in c.truth.effects] == [2, 3, 4, 5]  # as given: 1-based
    assert c.truth["effects"][0]["joint"] == 2  # the dict access of earlier versions
    assert c.spec.gravity == pytest.approx((0.0, 0.0, -9.80665))
    assert len(c.truth.compliance) == 3 * robot.n_joints
    assert pickle.loads(pickle.dumps(c)) == c
    plan = vjm.design(robot, poses=4, seed=1)
    noise = plan.noise
    assert isinstance(noise, testbed.NoiseModel) and isinstance(noise.tracker, testbed.TrackerNoise)
    assert noise.tracker.mpe_const == pytest.approx(15e-6) and noise.force_sensor.relative_accuracy == 0.01
    assert len(noise.prior_compliance) == robot.n_joints
    assert pickle.loads(pickle.dumps(plan)) == plan
    weightless = vjm.design(robot, poses=4, seed=1, gravity=None).noise
    assert weightless.gravity is None and "gravity" not in weightless.to_dict()


def test_an_unknown_effect_value_is_refused_by_name():
    with pytest.raises(TypeError, match="not an effect"):
        build(testbed.TrueModel, {"compliance": [1e-4], "effects": [{"effect": "teleportation"}]})
