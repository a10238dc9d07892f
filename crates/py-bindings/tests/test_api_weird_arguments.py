"""Every public function, every argument, a set of wrong values: the call either works or raises
a StiffnessError subclass — never a bare TypeError/ValueError/OverflowError/AttributeError…
(issue 14: "every exception the package raises for bad arguments is a StiffnessError")."""

from __future__ import annotations

import inspect
import math
from typing import Any, Callable, Dict, List, Tuple

import numpy as np
import pytest

import robot_stiffness as rs
from robot_stiffness import csjm, so3, vjm
from robot_stiffness.report import write_report

WEIRD: List[Any] = [
    None, -1, 0, 2**70, 1.5, math.nan, math.inf, "x", "", b"x", True, 1 + 1j, [], {}, object(),
    np.array([1j]), np.array(["a"]), [[1.0, None]],
]


def _cases(tmp_path) -> List[Tuple[str, Callable[..., Any], Dict[str, Any]]]:
    robot = vjm.Robot.bundled()
    c = vjm.simulate(robot, n_poses=4, wrenches_per_pose=2, seed=1)
    m = c.measurements
    csv = tmp_path / "c.csv"
    csv.write_text(c.csv)
    R = np.stack([np.eye(3)] + [so3.exp(0.01 * np.eye(3)[k]) for k in range(3)] + [so3.exp([0.01, 0.01, 0.0])])
    tau = np.array([[0, 0, 0], [0.3, 0, 0], [0, 0.3, 0], [0, 0, 0.1], [0.3, 0.3, 0.0]], dtype=float)
    q1 = m.q[0]
    return [
        ("Robot.bundled", vjm.Robot.bundled, {"tip": None}),
        ("Robot.from_urdf_string", vjm.Robot.from_urdf_string, {"xml": "<robot/>", "base": "a", "tip": "b"}),
        ("Robot.labels", robot.labels, {"model": "extended"}),
        ("Robot.forward_kinematics", robot.forward_kinematics, {"q": q1}),
        ("Robot.jacobian", robot.jacobian, {"q": q1, "model": "extended"}),
        ("Robot.identify", robot.identify, {"q": m.q, "wrench": m.wrench, "displacement": m.displacement,
                                            "model": "traditional", "method": "auto", "nonnegative": False}),
        ("Robot.predict_deflection", robot.predict_deflection,
         {"compliance": np.full(7, 1e-5), "q": q1, "wrench": m.wrench[0], "model": "traditional", "with_kc": False}),
        ("vjm.read_measurements", vjm.read_measurements, {"path": str(csv), "n_joints": 7}),
        ("vjm.simulate", vjm.simulate, {"robot": robot, "effects": [], "n_poses": 3, "wrenches_per_pose": 1,
                                        "seed": 0, "noise": True, "force_max": None, "moment_max": None}),
        ("vjm.diagnose", vjm.diagnose, {"robot": robot, "data": m, "fdr": None, "split_seed": None,
                                        "max_findings": None, "test_fraction": None}),
        ("csjm.identify", csjm.identify, {"R": R, "tau": tau, "ref": 0, "order": 1, "project": False, "tol": None}),
        ("csjm.simulate", csjm.simulate, {"effects": [], "seed": 0, "increments": 5, "max_increment": None}),
        ("Robot.from_urdf", vjm.Robot.from_urdf, {"path": str(tmp_path / "none.urdf"), "base": "a", "tip": "b"}),
        ("vjm.paper_study", vjm.paper_study, {"robot": robot, "tilt_ratio": 0.5, "noise": True, "seed": 0}),
        ("Measurements.to_csv_text", lambda **kw: vjm.Measurements(**kw).to_csv_text(),
         {"q": m.q, "wrench": m.wrench, "displacement": m.displacement, "pose": m.pose, "set": m.set}),
        ("csjm.diagnose", csjm.diagnose, {"data": R, "tau": tau, "ref": 0, "fdr": None, "split_seed": None,
                                          "project": False, "test_fraction": None}),
        ("csjm.identify_csv", csjm.identify_csv, {"path": str(csv), "order": 1, "project": False}),
        ("csjm.read_measurements", csjm.read_measurements, {"path": str(csv), "project": False}),
        ("so3.exp", so3.exp, {"w": [0.1, 0.0, 0.0]}),
        ("so3.hat", so3.hat, {"w": [0.1, 0.0, 0.0]}),
        ("so3.vee", so3.vee, {"m": np.zeros((3, 3))}),
        ("so3.adjoint", so3.adjoint, {"R": np.eye(3), "tol": 1e-9}),
        ("so3.right_jacobian_inverse", so3.right_jacobian_inverse, {"w": [0.1, 0.0, 0.0]}),
        ("so3.project_to_rotation", so3.project_to_rotation, {"m": np.eye(3)}),
        ("so3.orthogonality_error", so3.orthogonality_error, {"m": np.eye(3)}),
        ("so3.log", so3.log, {"R": np.eye(3), "tol": 1e-9}),
        ("so3.distance", so3.distance, {"a": np.eye(3), "b": np.eye(3), "tol": 1e-9}),
        ("write_report", write_report, {"result": vjm.diagnose(robot, m), "out_dir": str(tmp_path / "rep"),
                                        "force": True, "title": "t", "source": None}),
    ]


def test_weird_arguments_raise_only_package_errors(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a weird value may be a valid relative path ("x")
    escaped = []
    for name, fn, good in _cases(tmp_path):
        for param in good:
            for value in WEIRD:
                kwargs = dict(good)
                kwargs[param] = value
                try:
                    fn(**kwargs)
                except rs.StiffnessError:
                    pass
                except Exception as e:  # noqa: BLE001 - the point of the test
                    escaped.append(f"{name}({param}={value!r}): {type(e).__name__}: {str(e)[:120]}")
    assert not escaped, "\n".join(escaped)


def test_the_cases_cover_every_scalar_parameter_of_the_simple_functions(tmp_path):
    """Keeps the table above honest when a parameter is added."""
    names = {n for n, _, _ in _cases(tmp_path)}
    assert {"vjm.simulate", "csjm.simulate", "csjm.identify", "vjm.diagnose"} <= names
    sim = inspect.signature(vjm.simulate).parameters
    assert {"n_poses", "wrenches_per_pose", "seed"} <= set(sim)


@pytest.mark.parametrize("value", [5, 3.0, object()])
def test_model_of_the_wrong_type_is_named(panda, value):
    with pytest.raises(rs.ArgumentTypeError) as e:
        panda.jacobian(np.zeros(7), model=value)
    assert "model" in str(e.value)
