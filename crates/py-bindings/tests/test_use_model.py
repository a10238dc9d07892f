"""Planning (vjm.design, `design vjm`) and compensation (vjm.compensate, `compensate vjm`)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from conftest import listing, run_cli
from robot_stiffness import StiffnessError, vjm

NOMINAL_TORSION = [1.0e-4, 1.0e-4, 1.5e-4, 1.5e-4, 3.0e-4, 4.0e-4, 5.0e-4]


def nominal_extended() -> np.ndarray:
    c = np.zeros(21)
    c[0::3] = NOMINAL_TORSION
    c[1::3] = 0.3 * np.asarray(NOMINAL_TORSION)
    c[2::3] = 0.5 * np.asarray(NOMINAL_TORSION)
    return c


@pytest.fixture(scope="module")
def robot() -> vjm.Robot:
    return vjm.Robot.bundled()


@pytest.fixture(scope="module")
def plan(robot) -> vjm.Plan:
    return vjm.design(robot, model="extended", poses=10, wrenches_per_pose=3, seed=3, pool_size=60)


def test_design_returns_a_typed_plan_that_is_a_measurement_file(robot, plan, tmp_path):
    assert isinstance(plan, vjm.Plan)
    assert plan.q.shape == (30, 7) and plan.wrench.shape == (30, 6)
    assert list(plan.pose) == [i // 3 for i in range(30)]
    assert plan.rank == len(plan.combinations) == 15
    assert all(isinstance(c, vjm.PlannedCombination) and c.stderr > 0 for c in plan.combinations)
    assert plan.worst_stderr == max(c.stderr for c in plan.combinations)
    lo = np.array([lower for lower, _ in robot.limits])
    hi = np.array([h for _, h in robot.limits])
    assert np.all(plan.q >= lo + 0.1 - 1e-12) and np.all(plan.q <= hi - 0.1 + 1e-12)
    # Fill in dx, dy, dz (noise-free, a known truth): a valid file the identification reads and
    # whose combinations are the planned ones, with the truth's values.
    truth = nominal_extended()
    d = robot.predict_deflection(truth, plan.q, plan.wrench, model="extended")[:, :3]
    lines = plan.csv_text().splitlines()
    assert lines[0].endswith("pose,dx,dy,dz")
    filled = [lines[0]] + [
        line[: -len(",,")] + ",".join(repr(float(x)) for x in di) for line, di in zip(lines[1:], d)
    ]
    path = tmp_path / "plan.csv"
    path.write_text("\n".join(filled) + "\n")
    data = vjm.read_measurements(path, 7)
    res = robot.identify(data.q, data.wrench, data.displacement, model="extended", gravity=None)  # linear d
    assert res.rank == plan.rank
    assert [c.label for c in res.combinations] == [c.label for c in plan.combinations]
    labels = robot.labels("extended")
    for c in plan.combinations:
        expect = sum(coef * truth[labels.index(name)] for name, coef in c.terms)
        got = next(r.value for r in res.combinations if r.label == c.label)
        assert got == pytest.approx(expect, rel=1e-9, abs=1e-15)


def test_compensate_puts_the_loaded_tip_on_the_nominal_point(robot, plan):
    c = nominal_extended()
    out = vjm.compensate(robot, plan.q, c, model="extended", wrench=plan.wrench, load_only=True)
    assert isinstance(out, vjm.Compensation)
    assert set(out.status) == {"converged"}
    assert np.all(out.position_error <= 1e-9) and np.all(out.deflection > 1e-5)
    # Check through the dense prediction path (LU with K_C) and forward kinematics.
    d = robot.predict_deflection(c, out.q, plan.wrench, model="extended", with_kc=True)
    tip = robot.forward_kinematics(out.q)[:, :3, 3] + d[:, :3]
    nominal = robot.forward_kinematics(plan.q)[:, :3, 3]
    assert np.max(np.linalg.norm(tip - nominal, axis=1)) <= 2e-9
    # A payload on the tip point is the weight as a wrench.
    weight = np.tile([0.0, 0.0, -5.0 * 9.80665, 0.0, 0.0, 0.0], (len(plan.q), 1))
    a = vjm.compensate(robot, plan.q, c, wrench=weight, load_only=True)
    b = vjm.compensate(robot, plan.q, c, payload=(5.0,), load_only=True)
    np.testing.assert_array_equal(a.q, b.q)


def test_compensate_bad_input_is_one_clear_error(robot, plan):
    c = nominal_extended()
    with pytest.raises(StiffnessError, match="mass") as e:
        vjm.compensate(robot, plan.q, c, payload=(math.nan, 0.0, 0.0, 0.1))
    assert isinstance(e.value, ValueError)
    with pytest.raises(StiffnessError, match="q") as e:
        vjm.compensate(robot, plan.q[:, :6], c, wrench=plan.wrench)
    assert isinstance(e.value, ValueError)
    with pytest.raises(StiffnessError, match="exactly one"):
        vjm.compensate(robot, plan.q, c, wrench=plan.wrench, payload=(1.0,))
    w = plan.wrench.copy()
    w[4, 2] = math.nan
    with pytest.raises(StiffnessError, match="row 4") as e:
        vjm.compensate(robot, plan.q, c, wrench=w)
    assert isinstance(e.value, ValueError)


def test_cli_design_writes_the_plan(tmp_path):
    proc = run_cli(["design", "vjm", "--poses", "6", "--pool", "40", "--seed", "2", "--out", "plan.csv"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "noise model" in proc.stdout and "worst" in proc.stdout
    rows = (tmp_path / "plan.csv").read_text().splitlines()
    assert len(rows) == 1 + 24 and rows[0].startswith("q1,")


def write_trajectory(path: Path, q: np.ndarray, wrench: np.ndarray, extra: str = "") -> None:
    head = ",".join([f"q{j + 1}" for j in range(q.shape[1])] + ["fx", "fy", "fz", "mx", "my", "mz"])
    lines = [head + extra] + [",".join(repr(float(x)) for x in np.r_[qi, wi]) for qi, wi in zip(q, wrench)]
    path.write_text("\n".join(lines) + "\n")


def test_cli_compensate_bad_input_writes_nothing(plan, tmp_path):
    (tmp_path / "model.json").write_text("{}")
    write_trajectory(tmp_path / "traj.csv", plan.q, plan.wrench)
    before = listing(tmp_path)
    # No wrench columns and no --payload.
    (tmp_path / "nowrench.csv").write_text("q1,q2,q3,q4,q5,q6,q7\n" + ",".join(["0.1"] * 7) + "\n")
    (tmp_path / "qonly.csv").write_text("q1,q2,q3,q4,q5,q6,q7\n" + ",".join(["0.1", "-0.3", "0.1", "-2.0", "0.3", "1.8", "0.8"]) + "\n")
    cases = [
        (["nowrench.csv"], "missing columns fx,fy,fz,mx,my,mz"),
        (["traj8.csv"], "8 joint columns but the chain has 7"),
        (["trajnan.csv"], "line 3, column 'fz'"),
        (["qonly.csv", "--payload", "nan"], "finite"),
        (["traj.csv", "--payload", "1,2"], "MASS or MASS,cx,cy,cz"),
    ]
    q8 = np.c_[plan.q, np.zeros(len(plan.q))]
    (tmp_path / "traj8.csv").write_text(
        ",".join([f"q{j + 1}" for j in range(8)] + ["fx", "fy", "fz", "mx", "my", "mz"]) + "\n"
        + "\n".join(",".join(repr(float(x)) for x in np.r_[qi, wi]) for qi, wi in zip(q8, plan.wrench)) + "\n"
    )
    w = plan.wrench.copy()
    w[1, 2] = math.nan
    write_trajectory(tmp_path / "trajnan.csv", plan.q, w)
    before = listing(tmp_path)
    for args, needle in cases:
        proc = run_cli(["compensate", "vjm", "model.json", *args, "--out", "comp.csv", "--plot", "comp.png"],
                       cwd=tmp_path)
        assert proc.returncode in (1, 2), proc
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and needle in lines[0], proc.stderr
        assert listing(tmp_path) == before
    proc = run_cli(["compensate", "vjm", "missing.json", "traj.csv", "--out", "comp.csv"], cwd=tmp_path)
    assert proc.returncode == 1 and "missing.json" in proc.stderr and listing(tmp_path) == before


def test_cli_compensate_with_a_saved_model(robot, plan, tmp_path):
    # A campaign on the testbed, identified and saved by the CLI.
    proc = run_cli(["simulate", "vjm", "--out", "campaign.csv", "--seed", "4"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    proc = run_cli(["identify", "vjm", "campaign.csv", "--model", "extended", "--save", "model.json"], cwd=tmp_path)
    if proc.returncode == 2 and "--save" in proc.stderr:
        pytest.skip("identify vjm --save (the model file) is not on this branch yet")
    assert proc.returncode == 0, proc.stderr
    write_trajectory(tmp_path / "traj.csv", plan.q, plan.wrench)
    # --load-only: the extended model's aliased springs (negative minimum-norm members) cannot
    # hold the arm's weight (test_gravity_defaults.py checks that message).
    proc = run_cli(["compensate", "vjm", "model.json", "traj.csv", "--out", "comp.csv", "--plot", "comp.png",
                    "--load-only"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "comp.png").stat().st_size > 1000
    rows = (tmp_path / "comp.csv").read_text().splitlines()
    assert len(rows) == 1 + len(plan.q) and rows[0].startswith("q1,")
    assert all(r.endswith(",converged") for r in rows[1:])
    # Another robot (the TCP instead of the flange): refused, one line, nothing written.
    proc = run_cli(["compensate", "vjm", "model.json", "traj.csv", "--tip", "panda_hand_tcp", "--out", "c2.csv"],
                   cwd=tmp_path)
    assert proc.returncode == 1 and "another robot" in proc.stderr and not (tmp_path / "c2.csv").exists()


def test_stiffness_model_compensate_is_the_model_file_compensation(robot, plan, tmp_path):
    # One concept, one name: StiffnessModel.compensate (Python) = StiffnessModel::compensate
    # (Rust) = `compensate vjm MODEL.json` = vjm.compensate_with_model_file on the saved file.
    camp = vjm.simulate(robot, [], n_poses=16, wrenches_per_pose=4, seed=8)
    m = camp.measurements
    ident = robot.identify(m.q, m.wrench, m.displacement, model="extended")
    ident.save(tmp_path / "model.json")
    model = ident.stiffness_model
    # load_only: the extended model's aliased springs cannot hold the arm's weight (see
    # test_gravity_defaults.py for the sag through a model file).
    a = model.compensate(plan.q, payload=(5.0, 0.0, 0.0, 0.1), load_only=True)
    b = vjm.compensate_with_model_file(robot, str(tmp_path / "model.json"), plan.q, payload=(5.0, 0.0, 0.0, 0.1),
                                       load_only=True)
    assert a.status == b.status and all(s == "converged" for s in a.status)
    np.testing.assert_array_equal(a.q, b.q)
    # The corrected targets differ from the nominal ones by the deflection's worth (rad).
    assert np.max(np.abs(a.q - plan.q)) > 1e-5
    with pytest.raises(StiffnessError, match="payload"):
        model.compensate(plan.q, payload=(math.nan,))
