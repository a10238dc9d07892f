"""Pickling (what Dask sends to workers): robots rebuild without their URDF file, models and
results round-trip exactly."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest

from conftest import random_q
from robot_stiffness import csjm
from robot_stiffness.model import StiffnessModel
from robot_stiffness.vjm import Identification, Robot, diagnose, simulate
from robot_stiffness import _core


def round_trip(x):  # type: ignore[no-untyped-def]
    return pickle.loads(pickle.dumps(x, protocol=pickle.HIGHEST_PROTOCOL))


def same_robot(a: Robot, b: Robot) -> None:
    assert (a.base_link, a.tip_link, a.joint_names, a.limits) == (b.base_link, b.tip_link, b.joint_names, b.limits)


@pytest.mark.parametrize("tip", [None, "panda_hand_tcp"])
def test_bundled_robot_round_trips(tip, rng):
    robot = Robot.bundled(tip)
    back = round_trip(robot)
    same_robot(back, robot)
    q = random_q(robot, rng, 5)
    assert np.array_equal(back.jacobian(q), robot.jacobian(q))


def test_urdf_robot_needs_no_file_to_unpickle(tmp_path: Path, rng):
    # A copy of the bundled URDF in a file the test deletes before unpickling: a worker on
    # another machine does not have it either.
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(_bundled_urdf_text())
    robot = Robot.from_urdf(urdf, "panda_link0", "panda_link7")
    text = pickle.dumps(robot)
    urdf.unlink()
    back = pickle.loads(text)
    same_robot(back, robot)
    q = random_q(robot, rng, 4)
    assert np.array_equal(back.forward_kinematics(q), robot.forward_kinematics(q))
    # A model identified on the unpickled robot records the same URDF path and hash, so it
    # loads against the original robot.
    c = simulate(robot, n_poses=30, seed=3)
    m = c.measurements
    fitted = back.identify(m.q, m.wrench, m.displacement)
    assert fitted.stiffness_model is not None
    saved = tmp_path / "model.json"
    fitted.save(saved)
    loaded = StiffnessModel.load(saved, robot)
    here = robot.identify(m.q, m.wrench, m.displacement).stiffness_model
    assert here is not None
    assert loaded.to_dict()["robot"] == here.to_dict()["robot"]
    assert loaded.to_dict()["robot"]["urdf"] == str(urdf)


def _bundled_urdf_text() -> str:
    # The bundled robot pickles its URDF text: the first argument of its reduction.
    _, args = _core.Robot.bundled(None).__reduce__()
    return str(args[0])


def test_urdf_string_robot_round_trips(rng):
    robot = Robot.from_urdf_string(_bundled_urdf_text(), "panda_link0", "panda_link5")
    back = round_trip(robot)
    same_robot(back, robot)
    assert back.n_joints == 5


@pytest.fixture(scope="module")
def fitted() -> Identification:
    robot = Robot.bundled()
    m = simulate(robot, [{"effect": "joint_tilt", "joint": 2, "axis": "x", "compliance": 5e-5}], n_poses=40, seed=5).measurements
    return robot.identify(m.q, m.wrench, m.displacement, model="extended")


def test_identification_and_model_round_trip(fitted, rng):
    back = round_trip(fitted)
    assert back.to_dict() == fitted.to_dict()
    for name in ("compliance", "stderr", "ci95", "singular_values"):
        assert np.array_equal(getattr(back, name), getattr(fitted, name), equal_nan=True), name
    assert np.array_equal(back.identifiable, fitted.identifiable)
    assert (back.rank, back.labels, back.combinations, back.aliases) == (
        fitted.rank, fitted.labels, fitted.combinations, fitted.aliases)
    assert back.stiffness_model is not None and fitted.stiffness_model is not None
    assert back.stiffness_model.to_json() == fitted.stiffness_model.to_json()
    robot = fitted.stiffness_model.robot
    q = random_q(robot, rng, 6)
    w = rng.normal(size=(6, 6)) * 20
    a = fitted.stiffness_model.predict(q, wrench=w)
    b = back.stiffness_model.predict(q, wrench=w)
    assert np.array_equal(a.deflection, b.deflection, equal_nan=True)


def test_model_pickled_for_another_robot_is_refused(fitted):
    # The pickle carries the model text and the robot; a pickle whose robot was swapped is
    # checked on load like a file is.
    model = fitted.stiffness_model
    assert model is not None
    fn, (text, _) = model.__reduce__()
    with pytest.raises(Exception, match="tip|link|URDF|robot"):
        fn(text, Robot.bundled("panda_hand_tcp"))


def test_vjm_diagnosis_round_trips():
    robot = Robot.bundled()
    c = simulate(robot, [{"effect": "joint_tilt", "joint": 3, "axis": "x", "compliance": 6e-5}],
                 n_poses=40, seed=2, test_fraction=0.25)
    d = diagnose(robot, c.measurements)
    back = round_trip(d)
    assert back.to_dict() == d.to_dict()
    assert back.findings == d.findings


def same(a, b, where: str = "") -> None:  # type: ignore[no-untyped-def]
    """Equal, recursively through dataclasses, dicts, sequences and arrays (NaN equals NaN)."""
    assert type(a) is type(b), where
    if isinstance(a, np.ndarray):
        assert a.shape == b.shape and np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"), where
    elif hasattr(a, "__dataclass_fields__"):
        for name in a.__dataclass_fields__:
            same(getattr(a, name), getattr(b, name), f"{where}.{name}")
    elif isinstance(a, dict):
        assert list(a) == list(b), where
        for k in a:
            same(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{where}[{i}]")
    elif isinstance(a, float) and np.isnan(a):
        assert np.isnan(b), where
    else:
        assert a == b, where


def test_csjm_fit_and_diagnosis_round_trip(tmp_path: Path):
    c = csjm.simulate(seed=1)
    path = tmp_path / "csjm.csv"
    path.write_text(c.csv)
    fit = csjm.identify_csv(path)
    same(round_trip(fit), fit)
    d = csjm.diagnose(path)
    assert round_trip(d).to_dict() == d.to_dict()
