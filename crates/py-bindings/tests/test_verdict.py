"""The verdict behind ``unexplained`` through Python and the CLI: noise levels given or not, bad
levels refused in one line, the words and the typed classes."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from conftest import listing, run_cli
from robot_stiffness import vjm
from robot_stiffness.results import BlockTest, Verdict


@pytest.fixture(scope="module")
def clean(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("clean")
    proc = run_cli(["simulate", "vjm", "--out", "c.csv", "--poses", "30", "--seed", "5"], cwd=d)
    assert proc.returncode == 0, proc.stderr
    return d / "c.csv"


@pytest.fixture(scope="module")
def drift(tmp_path_factory) -> Path:
    # A 0.2 mm offset per pose is outside the catalogue: the verdict must say so.
    d = tmp_path_factory.mktemp("drift")
    proc = run_cli(["simulate", "vjm", "--out", "c.csv", "--poses", "30", "--seed", "5",
                    "--effect", "pose_drift:sigma=2e-4"], cwd=d)
    assert proc.returncode == 0, proc.stderr
    return d / "c.csv"


def test_clean_data_have_no_verdict_and_a_typed_one(clean):
    robot = vjm.Robot.bundled()
    d = vjm.diagnose(robot, str(clean))
    assert not d.unexplained and not d.findings
    assert isinstance(d.verdict, Verdict)
    assert d.verdict.goodness_of_fit is None  # no noise level given
    assert d.verdict.remaining is None
    assert {b.block for b in d.verdict.blocks} == {
        "linear_in_wrench", "tool_frame", "pose_offsets", "pose_compliance", "angle_compliance", "springs"}
    assert all(isinstance(b, BlockTest) for b in d.verdict.blocks)
    assert d.verdict.lack_of_fit.p_value > 0.01


def test_a_given_noise_level_adds_the_goodness_of_fit(clean):
    robot = vjm.Robot.bundled()
    # The testbed's instruments: ≈ 21 µm tracker, 0.5 N and 0.05 N·m.
    d = vjm.diagnose(robot, str(clean), tracker_sigma=2.1213e-5, force_sigma=0.5, moment_sigma=0.05)
    g = d.verdict.goodness_of_fit
    assert g is not None and g.df > 0
    assert 0.8 < g.ratio < 1.2, g  # χ²/df ≈ 1 with the true noise
    assert not d.unexplained
    # A noise level 3× too small makes χ²/df ≈ 9: the goodness of fit rejects.
    d = vjm.diagnose(robot, str(clean), tracker_sigma=2.1213e-5 / 3, force_sigma=0.5 / 3, moment_sigma=0.05 / 3)
    assert d.verdict.goodness_of_fit is not None and d.verdict.goodness_of_fit.ratio > 5
    assert d.unexplained
    assert "noise" in (d.verdict.remaining or "")


def test_pose_drift_is_unexplained_in_words(drift):
    d = vjm.diagnose(vjm.Robot.bundled(), str(drift))
    assert d.unexplained
    assert "pose_offsets" in (d.verdict.remaining or ""), d.verdict.remaining
    j = json.loads(d.to_json())
    assert j["verdict"]["lack_of_fit"]["p_value"] < 1e-6


def test_a_gear_whose_stiffness_follows_its_angle_is_unexplained_in_words():
    # Outside the catalogue: the torsion compliance of joint 2 is c·(1 + 0.4·sin q2).
    robot = vjm.Robot.bundled()
    data = vjm.simulate(robot, [{"effect": "joint_torsion_angle_dependent", "joint": 2, "amplitude": 0.4}],
                        n_poses=40, seed=3)
    d = vjm.diagnose(robot, data.measurements)
    assert d.unexplained
    # The noise level not given: the angle_compliance block (each torsion column × sin q, cos q)
    # decides on the p of a wild cluster bootstrap, which the words quote when it is the one.
    angle = next(b for b in d.verdict.blocks if b.block == "angle_compliance")
    assert angle.wild_cluster_p_value is not None and angle.wild_cluster_p_value < 1e-6, angle
    remaining = d.verdict.remaining or ""
    assert "pose_compliance block" in remaining or "angle_compliance block" in remaining, remaining
    if "angle_compliance block" in remaining:
        assert "wild cluster bootstrap" in remaining, remaining
    in_json = next(b for b in json.loads(d.to_json())["verdict"]["blocks"] if b["block"] == "angle_compliance")
    assert in_json["wild_cluster_p_value"] == angle.wild_cluster_p_value
    # With the noise level given, its F test decides, and no bootstrap is drawn.
    given = vjm.diagnose(robot, data.measurements, tracker_sigma=2.1213e-5, force_sigma=0.5, moment_sigma=0.05)
    angle = next(b for b in given.verdict.blocks if b.block == "angle_compliance")
    assert given.unexplained and angle.f_test.p_value < 1e-6 and angle.wild_cluster_p_value is None, angle
    assert "compliance block" in (given.verdict.remaining or ""), given.verdict.remaining
    with pytest.raises(ValueError, match="amplitude"):
        vjm.simulate(robot, [{"effect": "joint_torsion_angle_dependent", "joint": 2, "amplitude": 1.0}])


@pytest.mark.parametrize("flag,value,message", [
    ("--tracker-sigma", "-1e-5", "must be positive"),
    ("--tracker-sigma", "nan", "--tracker-sigma"),
    ("--force-sigma", "-0.5", "must be zero or positive"),
    ("--moment-sigma", "inf", "--moment-sigma"),
])
def test_a_bad_noise_level_is_one_line_and_writes_nothing(clean, tmp_path, flag, value, message):
    before = listing(tmp_path)
    proc = run_cli(["diagnose", "vjm", str(clean), f"{flag}={value}", "--json", "d.json"], cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert any(message in line for line in lines), proc.stderr
    assert "Traceback" not in proc.stderr
    assert listing(tmp_path) == before


@pytest.mark.parametrize("kwargs,name", [
    ({"tracker_sigma": -1e-5}, "tracker_sigma"),
    ({"tracker_sigma": float("nan")}, "tracker_sigma"),
    ({"force_sigma": float("inf")}, "force_sigma"),
    ({"moment_sigma": -0.1}, "moment_sigma"),
])
def test_a_bad_noise_level_in_python_names_it(clean, kwargs, name):
    with pytest.raises(ValueError) as e:
        vjm.diagnose(vjm.Robot.bundled(), str(clean), **kwargs)
    assert name in str(e.value) and "\n" not in str(e.value)
