"""The model a diagnosis found, saved and used (issue 24, item 3): ``vjm.diagnosed_model`` and
``diagnose vjm --save MODEL.json``; one model vocabulary (``identify --model`` reads what
``diagnose`` prints) and one default model."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import run_cli
from robot_stiffness import vjm

TILT = {"effect": "joint_tilt", "joint": 3, "axis": "x", "compliance": 6e-5}
BIAS = {"effect": "wrench_bias", "bias": [2.0, 0.0, -2.0, 0.0, 0.2, 0.0]}
FRAME = {"effect": "frame_misalignment", "rotation": [0.05, -0.03, 0.04]}


@pytest.fixture(scope="module")
def robot() -> vjm.Robot:
    return vjm.Robot.bundled()


def _held_out_error(robot, effects, model) -> float:
    """RMS error of the model's prediction of the true deflection (no noise, no measurement
    error: the applied wrench and the tip's true displacement) on a campaign it never saw."""
    fresh = vjm.simulate(robot, effects, n_poses=30, seed=777, noise=False)
    pred = model.predict(fresh.measurements.q, wrench=fresh.applied_wrench)
    return float(np.sqrt(np.mean((pred.deflection[:, :3] - fresh.true_displacement) ** 2)))


@pytest.mark.parametrize("error", [BIAS, FRAME], ids=["wrench_bias", "frame_misalignment"])
def test_the_saved_model_predicts_the_arm_without_the_measurement_error(robot, error):
    effects = [TILT, error]
    c = vjm.simulate(robot, effects, n_poses=40, wrenches_per_pose=4, seed=5)
    d = vjm.diagnose(robot, c.measurements)
    found = {f.effect for f in d.findings}
    assert {"joint_tilt", error["effect"]} <= found, d.extended.model
    saved = vjm.diagnosed_model(robot, c.measurements, d)
    assert "joint_tilt(J3x)" in saved.springs or "joint_tilt(J4x)" in saved.springs, saved.springs
    assert set(saved.corrected) == {error["effect"]} and saved.left_out == ()
    truth = error.get("bias", error.get("rotation"))
    np.testing.assert_allclose(saved.corrected[error["effect"]], truth, atol=0.1 * np.max(np.abs(truth)))
    # Against the same springs fitted on the raw rows (the error left in) and the traditional
    # model: the saved model predicts the true deflection of unseen poses several times better.
    raw = robot.identify(c.measurements.q, c.measurements.wrench, c.measurements.displacement, saved.springs)
    plain = robot.identify(c.measurements.q, c.measurements.wrench, c.measurements.displacement)
    e_saved = _held_out_error(robot, effects, saved.identification.stiffness_model)
    e_raw = _held_out_error(robot, effects, raw.stiffness_model)
    e_plain = _held_out_error(robot, effects, plain.stiffness_model)
    assert e_saved < 0.5 * e_raw and e_saved < 0.3 * e_plain, (e_saved, e_raw, e_plain)
    # Tracker noise is 10-ish µm per axis; the saved model is within a few µm of the truth.
    assert e_saved < 5e-6, e_saved


def test_findings_a_spring_model_cannot_hold_are_listed(robot):
    effects = [{"effect": "mount_compliance", "translation": 8e-6, "rotation": 0.0}]
    c = vjm.simulate(robot, effects, n_poses=40, wrenches_per_pose=4, seed=2)
    d = vjm.diagnose(robot, c.measurements)
    assert any(f.effect == "mount_translation" for f in d.findings), d.extended.model
    saved = vjm.diagnosed_model(robot, c.measurements, d)
    assert saved.springs == "traditional" and saved.corrected == {}
    assert [label for label, _ in saved.left_out] == ["mount_translation"]
    with pytest.raises(TypeError, match="diagnosis must be a Diagnosis"):
        vjm.diagnosed_model(robot, c.measurements, "extended")


def test_cli_diagnose_save_then_predict_and_the_printed_model_is_read_back(tmp_path):
    proc = run_cli(["simulate", "vjm", "--out", "c.csv", "--seed", "5", "--effect",
                    "joint_tilt:joint=3,axis=x,compliance=6e-5", "--effect", "wrench_bias:bias=2/0/-2/0/0.2/0"],
                   cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    proc = run_cli(["diagnose", "vjm", "c.csv", "--save", "m.json", "--json", "d.json"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "saved m.json: springs traditional + joint_tilt(J" in proc.stdout, proc.stdout
    assert "wrench_bias taken out of the rows" in proc.stdout
    model = json.loads((tmp_path / "m.json").read_text())["model"]
    assert len(model["springs"]["labels"]) == 8 and model["data"]["rows"] == 160
    proc = run_cli(["predict", "vjm", "m.json", "c.csv", "--out", "p.csv"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    # What diagnose printed is a model identify reads: its springs, or its other findings refused by name.
    printed = json.loads((tmp_path / "d.json").read_text())["extended"]["model"]
    assert "wrench_bias" in printed
    proc = run_cli(["identify", "vjm", "c.csv", "--model", printed], cwd=tmp_path)
    assert proc.returncode == 1 and "`wrench_bias` is an offset of the recorded wrench" in proc.stderr, proc.stderr
    springs = printed.replace(" + wrench_bias", "")
    proc = run_cli(["identify", "vjm", "c.csv", "--model", springs], cwd=tmp_path)
    assert proc.returncode == 0 and "8 parameters" in proc.stdout, proc.stdout + proc.stderr


def test_one_model_vocabulary_and_one_default(robot):
    c = vjm.simulate(robot, n_poses=12, seed=1)
    m = c.measurements
    a = robot.identify(m.q, m.wrench, m.displacement, "traditional + joint_tilt(J3x)")
    b = robot.identify(m.q, m.wrench, m.displacement, ["J1z", "J2z", "J3z", "J3x", "J4z", "J5z", "J6z", "J7z"])
    assert a.labels == b.labels and a.n_params == 8
    np.testing.assert_array_equal(a.compliance, b.compliance)
    # A link's translation is the spring J4tz of the same vocabulary, identified under gravity.
    t = robot.identify(m.q, m.wrench, m.displacement, "traditional + link_translation(J4z)")
    assert t.labels == robot.labels("traditional + J4tz") and "J4tz" in t.labels
    # design, identify, diagnose and compensate default to the traditional model.
    plan = vjm.design(robot, poses=3, wrenches_per_pose=2, pool_size=10)
    assert len(plan.combinations) == plan.rank <= 7
    assert robot.identify(m.q, m.wrench, m.displacement).model == "traditional"
    comp = vjm.compensate(robot, m.q[:2], [1e-4] * 7, wrench=m.wrench[:2], load_only=True)
    assert comp.q.shape == (2, 7)
    with pytest.raises(ValueError, match="without model= give 7 values"):
        vjm.compensate(robot, m.q[:2], [1e-4] * 8, wrench=m.wrench[:2])
