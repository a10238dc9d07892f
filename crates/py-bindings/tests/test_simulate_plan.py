"""Plan → measure inside the package: ``vjm.simulate(plan=…)`` and ``simulate vjm --plan PLAN.csv
--out CAMPAIGN.csv`` measure at the rows ``design`` planned (issue 24, item 1)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from conftest import run_cli
from robot_stiffness import ArgumentTypeError, vjm

NOMINAL_TORSION = np.array([1.0e-4, 1.0e-4, 1.5e-4, 1.5e-4, 3.0e-4, 4.0e-4, 5.0e-4])


@pytest.fixture(scope="module")
def robot() -> vjm.Robot:
    return vjm.Robot.bundled()


@pytest.fixture(scope="module")
def plan(robot):
    return vjm.design(robot, model="traditional", poses=8, wrenches_per_pose=3, seed=5, pool_size=40)


def test_the_plan_rows_are_measured_as_the_random_draw_measures_them(robot):
    """The same rows, drawn at random by one campaign and given as a plan to another, get the same
    noise-free displacement: the plan path is the testbed's physics at the given q and wrench."""
    drawn = vjm.simulate(robot, n_poses=5, wrenches_per_pose=2, seed=21, noise=False)
    m = drawn.measurements
    planned = vjm.simulate(robot, plan=(m.q, drawn.applied_wrench, m.pose), seed=99, noise=False)
    p = planned.measurements
    np.testing.assert_array_equal(p.q, m.q)
    np.testing.assert_array_equal(p.pose, m.pose)
    np.testing.assert_array_equal(p.wrench, m.wrench)
    np.testing.assert_allclose(p.displacement, m.displacement, rtol=0, atol=1e-15)


def test_a_design_plan_is_measured_at_its_rows_with_noise_and_held_out_poses(robot, plan):
    c = vjm.simulate(robot, plan=plan, seed=3)
    m = c.measurements
    np.testing.assert_array_equal(m.q, plan.q)
    np.testing.assert_array_equal(m.pose, plan.pose)
    np.testing.assert_array_equal(c.applied_wrench, plan.wrench)
    # The F/T noise is on the recorded wrench, not on the applied one (sensor σ ≈ 0.1 N).
    assert 0 < np.max(np.abs(m.wrench[:, :3] - plan.wrench[:, :3])) < 2.0
    # Whole poses held out, as in a random campaign.
    sets = np.asarray(m.set)
    assert set(sets) == {"train", "test"}
    for p in np.unique(m.pose):
        assert len(set(sets[m.pose == p])) == 1
    # Same seed, same campaign; another seed, other noise.
    again = vjm.simulate(robot, plan=plan, seed=3)
    np.testing.assert_array_equal(again.measurements.displacement, m.displacement)
    other = vjm.simulate(robot, plan=plan, seed=4)
    assert np.max(np.abs(other.measurements.displacement - m.displacement)) > 1e-7


def test_identify_recovers_the_truth_from_a_noise_free_planned_campaign(robot, plan):
    c = vjm.simulate(robot, plan=plan, seed=0, noise=False, gravity=None)
    m = c.measurements
    res = robot.identify(m.q, m.wrench, m.displacement, "traditional", gravity=None)
    # The nominal truth has torsion springs only; the planned rows determine as many as the
    # plan's rank (the seventh, about the flange's own axis, is not seen at panda_link8's point).
    ok = ~np.isnan(res.compliance)
    assert ok.sum() == plan.rank == 6
    np.testing.assert_allclose(res.compliance[ok], NOMINAL_TORSION[ok], rtol=2e-3)


def test_a_bad_plan_is_refused_by_name(robot, plan):
    with pytest.raises(ArgumentTypeError, match="plan must be a Plan"):
        vjm.simulate(robot, plan="plan.csv")
    with pytest.raises(ValueError, match="rows"):
        vjm.simulate(robot, plan=(plan.q, plan.wrench[:-1], plan.pose))
    with pytest.raises(ValueError, match="plan q"):
        vjm.simulate(robot, plan=(plan.q[:, :6], plan.wrench, plan.pose))
    with pytest.raises(ArgumentTypeError, match="integer pose ids"):
        vjm.simulate(robot, plan=(plan.q, plan.wrench, plan.pose + 0.5))


def _rows(path: Path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_cli_design_then_simulate_at_the_plan_then_identify(tmp_path):
    proc = run_cli(["design", "vjm", "--model", "traditional", "--poses", "6", "--wrenches-per-pose", "2",
                    "--pool", "30", "--out", "plan.csv"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    proc = run_cli(["simulate", "vjm", "--plan", "plan.csv", "--out", "campaign.csv", "--seed", "2",
                    "--effect", "joint_tilt:joint=2,axis=x,compliance=5e-5"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    assert "12 rows (6 poses of the plan plan.csv)" in proc.stdout, proc.stdout
    planned, measured = _rows(tmp_path / "plan.csv"), _rows(tmp_path / "campaign.csv")
    assert len(planned) == len(measured) == 12
    for a, b in zip(planned, measured):
        assert [float(a[f"q{j}"]) for j in range(1, 8)] == [float(b[f"q{j}"]) for j in range(1, 8)]
        assert a["pose"] == b["pose"] and b["dx"] != ""
    proc = run_cli(["identify", "vjm", "campaign.csv"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr


def test_cli_plan_without_pose_column_groups_equal_rows(tmp_path):
    q = "0.1,-0.4,0.2,-2.0,0.1,1.6,0.7"
    r = "0.3,0.2,-0.1,-1.5,0.4,2.0,0.1"
    lines = ["q1,q2,q3,q4,q5,q6,q7,fx,fy,fz,mx,my,mz"]
    for qi in (q, q, r, r):
        lines.append(f"{qi},20,0,-30,0,1,0")
    (tmp_path / "mine.csv").write_text("\n".join(lines) + "\n")
    proc = run_cli(["simulate", "vjm", "--plan", "mine.csv", "--out", "c.csv"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert [row["pose"] for row in _rows(tmp_path / "c.csv")] == ["0", "0", "1", "1"]


def test_cli_plan_errors_name_the_cause(tmp_path):
    (tmp_path / "noload.csv").write_text("q1,q2,q3,q4,q5,q6,q7\n0.1,-0.4,0.2,-2.0,0.1,1.6,0.7\n")
    proc = run_cli(["simulate", "vjm", "--plan", "noload.csv", "--out", "c.csv"], cwd=tmp_path)
    assert proc.returncode == 1 and "--plan noload.csv: missing columns fx,fy,fz,mx,my,mz" in proc.stderr, proc.stderr
    proc = run_cli(["simulate", "vjm", "--plan", "noload.csv", "--poses", "5", "--out", "c.csv"], cwd=tmp_path)
    assert proc.returncode == 1 and "drop --poses" in proc.stderr, proc.stderr
    (tmp_path / "bad.csv").write_text("q1,q2,q3,q4,q5,q6,q7,fx,fy,fz,mx,my,mz\n0.1,-0.4,x,-2.0,0.1,1.6,0.7,1,0,0,0,0,0\n")
    proc = run_cli(["simulate", "vjm", "--plan", "bad.csv", "--out", "c.csv"], cwd=tmp_path)
    assert proc.returncode == 1 and "bad.csv" in proc.stderr and "q3" in proc.stderr, proc.stderr
    assert not (tmp_path / "c.csv").exists()


def test_cli_out_flag_and_the_deprecated_positional(tmp_path):
    proc = run_cli(["simulate", "vjm", "old.csv", "--poses", "3", "--wrenches-per-pose", "1"], cwd=tmp_path)
    assert proc.returncode == 0 and (tmp_path / "old.csv").is_file()
    assert "deprecated" in proc.stderr and "--out old.csv" in proc.stderr, proc.stderr
    proc = run_cli(["simulate", "vjm", "a.csv", "--out", "b.csv"], cwd=tmp_path)
    assert proc.returncode == 1 and "given twice" in proc.stderr, proc.stderr
    proc = run_cli(["simulate", "vjm"], cwd=tmp_path)
    assert proc.returncode == 1 and "--out OUT.csv is required" in proc.stderr, proc.stderr
    proc = run_cli(["simulate", "csjm", "--out", "k.csv", "--increments", "5"], cwd=tmp_path)
    assert proc.returncode == 0 and (tmp_path / "k.csv").is_file(), proc.stderr
    assert not (tmp_path / "a.csv").exists() and not (tmp_path / "b.csv").exists()
