"""Gravity, one default everywhere (issue 22, item 2): simulate, identify, diagnose, predict,
compensate and demo work under standard gravity unless told ``gravity=None`` /
``--no-gravity``; a link without ``<inertial>`` is then an error naming it."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from conftest import listing, run_cli
import robot_stiffness as rs
from robot_stiffness import InvalidValueError, RobotModelError, vjm
from test_vjm import PLANAR_2R

G = vjm.DEFAULT_GRAVITY
ARM = ["--urdf", "arm.urdf", "--base", "base", "--tip", "tool"]


@pytest.fixture(scope="module")
def campaign():
    """Noise-free data of the bundled arm under the default (standard) gravity."""
    robot = vjm.Robot.bundled()
    return robot, vjm.simulate(robot, [], n_poses=30, seed=5, noise=False)


def _relative_error(res, truth):
    ok = res.identifiable
    return float(np.max(np.abs(res.compliance[ok] - truth[ok]) / truth[ok]))


def test_the_defaults_are_standard_gravity(campaign):
    robot, camp = campaign
    m = camp.measurements
    truth = np.asarray(camp.truth["compliance"], dtype=float)[::3]  # [z, x, y] per joint: the torsions
    assert G == (0.0, 0.0, -9.80665)
    # Simulated under gravity: the same campaign weightless records other displacements.
    weightless = vjm.simulate(robot, [], n_poses=30, seed=5, noise=False, gravity=None).measurements
    np.testing.assert_array_equal(weightless.q, m.q)
    assert np.max(np.abs(weightless.displacement - m.displacement)) > 1e-6
    explicit = vjm.simulate(robot, [], n_poses=30, seed=5, noise=False, gravity=G).measurements
    np.testing.assert_array_equal(explicit.displacement, m.displacement)
    # Identified with the default (gravity): the truth; weightless: biased, measurably.
    res = robot.identify(m.q, m.wrench, m.displacement)
    flat = robot.identify(m.q, m.wrench, m.displacement, gravity=None)
    assert _relative_error(res, truth) < 1e-5
    assert _relative_error(flat, truth) > 1e-4
    assert _relative_error(flat, truth) > 100 * _relative_error(res, truth)
    # The model records the gravity it was identified under; weightless records none.
    assert res.stiffness_model.gravity == G
    assert flat.stiffness_model.gravity is None
    # diagnose defaults to gravity as well: its baseline fits the weighted data exactly.
    d = vjm.diagnose(robot, m, per_row=False)
    d0 = vjm.diagnose(robot, m, per_row=False, gravity=None)
    assert d.baseline.test_mean_rel_error < 0.1 * d0.baseline.test_mean_rel_error


def test_identify_partial_is_weightless_only_and_says_so(campaign):
    robot, camp = campaign
    m = camp.measurements
    part = robot.identify_partial(m.q, m.wrench, m.displacement)  # gravity=None: its default
    full = robot.identify(m.q, m.wrench, m.displacement, method="qr", gravity=None)
    np.testing.assert_allclose(part.finish().compliance, full.compliance, rtol=1e-10)
    with pytest.raises(InvalidValueError, match="gravity=None") as e:
        robot.identify_partial(m.q, m.wrench, m.displacement, gravity=G)
    assert isinstance(e.value, ValueError) and "Robot.identify" in str(e.value)


def test_a_link_without_inertial_is_named_unless_gravity_is_off():
    robot = vjm.Robot.from_urdf_string(PLANAR_2R, "base", "tool")
    calls = [
        lambda g: vjm.simulate(robot, [], n_poses=6, gravity=g),
        lambda g: robot.identify(m.q, m.wrench, m.displacement, gravity=g),
        lambda g: vjm.diagnose(robot, m, gravity=g),
        lambda g: vjm.compensate(robot, m.q[:3], [1e-4, 1e-4], model="traditional", wrench=m.wrench[:3], gravity=g),
    ]
    m = vjm.simulate(robot, [], n_poses=6, gravity=None).measurements
    for call in calls:
        with pytest.raises(RobotModelError, match="link `l1`.*inertial") as e:
            call(G)
        assert isinstance(e.value, ValueError)
        call(None)  # weightless: no inertials needed
    res = robot.identify(m.q, m.wrench, m.displacement, gravity=None)
    with pytest.raises(RobotModelError, match="link `l1`"):
        res.stiffness_model.compensate(m.q[:3], wrench=m.wrench[:3])
    res.stiffness_model.compensate(m.q[:3], wrench=m.wrench[:3], load_only=True)


def test_compensate_corrects_the_sag_by_default_and_the_load_only_on_request(campaign):
    robot, _ = campaign
    rng = np.random.default_rng(3)
    lo, hi = np.array(robot.limits).T
    q = lo + (hi - lo) * (0.3 + 0.4 * rng.random((5, 7)))
    c = np.full(21, 1e-4)
    payload = (3.0, 0.0, 0.0, 0.05)
    nominal = robot.forward_kinematics(q)[:, :3, 3]
    full = vjm.compensate(robot, q, c, payload=payload)
    assert set(full.status) == {"converged"}
    # The tip at the corrected targets, sagging under weight + payload, is the nominal rigid tip.
    sag = robot.gravity_sag(c, full.q, model="extended", payload=(payload[0], payload[1:]))
    tip = robot.forward_kinematics(full.q)[:, :3, 3] + sag[:, :3]
    assert np.max(np.linalg.norm(tip - nominal, axis=1)) < 1e-8
    # load_only: the load's deflection only, weightless (= gravity=None), a different answer.
    load = vjm.compensate(robot, q, c, payload=payload, load_only=True)
    np.testing.assert_array_equal(load.q, vjm.compensate(robot, q, c, payload=payload, gravity=None).q)
    assert np.max(np.abs(load.q - full.q)) > 1e-4
    assert np.all(full.deflection > load.deflection)  # the arm's own sag adds to the payload's


def test_predict_sag_follows_the_gravity_and_the_model_record(campaign):
    robot, camp = campaign
    m = camp.measurements
    model = robot.identify(m.q, m.wrench, m.displacement, model="traditional").stiffness_model
    q = m.q[::4]
    floor = model.predict_sag(q).deflection[:, :3]
    np.testing.assert_array_equal(floor, model.predict_sag(q, gravity=G).deflection[:, :3])
    ceiling = model.predict_sag(q, gravity=(0.0, 0.0, 9.80665)).deflection[:, :3]
    assert np.min(np.linalg.norm(floor, axis=1)) > 1e-4  # 0.1 mm at least
    # Upside down the weight pulls the other way: the sag changes sign (to its non-linear part).
    assert np.linalg.norm(ceiling + floor) < 0.05 * np.linalg.norm(floor)
    assert np.all(np.sign(ceiling[:, 2]) == -np.sign(floor[:, 2]))
    with pytest.raises(InvalidValueError, match="gravity"):
        model.predict_sag(q, gravity="standard")


def _read(path: Path):
    with path.open() as f:
        return list(csv.DictReader(f))


def test_cli_predict_writes_the_sag_columns(campaign, tmp_path):
    robot, _ = campaign
    assert run_cli(["simulate", "vjm", "--out", "c.csv", "--poses", "8", "--seed", "2"], cwd=tmp_path).returncode == 0
    proc = run_cli(["identify", "vjm", "c.csv", "--save", "m.json"], cwd=tmp_path)
    assert proc.returncode == 0 and "under gravity 0,0,-9.80665" in proc.stdout, proc.stderr
    proc = run_cli(["predict", "vjm", "m.json", "c.csv", "--out", "p.csv"], cwd=tmp_path)
    assert proc.returncode == 0 and "sag" in proc.stdout, proc.stderr
    rows = _read(tmp_path / "p.csv")
    names = ["sag_dx", "sag_dy", "sag_dz", "sag_sd_dx", "sag_sd_dy", "sag_sd_dz", "sag_identified"]
    assert list(rows[0])[-7:] == names
    from robot_stiffness.model import StiffnessModel

    model = StiffnessModel.load(tmp_path / "m.json", robot)
    q = np.array([[float(r[f"q{j}"]) for j in range(1, 8)] for r in rows])
    want = model.predict_sag(q)
    got = np.array([[float(r[k]) for k in names[:3]] for r in rows])
    np.testing.assert_allclose(got, want.deflection[:, :3], rtol=1e-12, atol=1e-18)
    sd = np.array([[float(r[k]) for k in names[3:6]] for r in rows])
    np.testing.assert_allclose(sd, want.stddev[:, :3], rtol=1e-12)
    assert [r["sag_identified"] for r in rows] == ["true" if x else "false" for x in want.identified]
    # A ceiling mount flips the sag; --no-gravity leaves the columns out.
    proc = run_cli(["predict", "vjm", "m.json", "c.csv", "--out", "up.csv", "--gravity", "0,0,9.80665"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    up = np.array([[float(r[k]) for k in names[:3]] for r in _read(tmp_path / "up.csv")])
    assert np.all(np.sign(up[:, 2]) == -np.sign(got[:, 2]))
    proc = run_cli(["predict", "vjm", "m.json", "c.csv", "--out", "flat.csv", "--no-gravity"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    flat = _read(tmp_path / "flat.csv")
    assert not any(k.startswith("sag_") for k in flat[0])
    # Under gravity the load's deflection is taken about the sagged pose with gravity's
    # coupling (what identify under gravity fits): close to the weightless one, not equal.
    d_g = np.array([[float(r[k]) for k in ("dx", "dy", "dz")] for r in rows])
    d_0 = np.array([[float(r[k]) for k in ("dx", "dy", "dz")] for r in flat])
    rel = np.linalg.norm(d_g - d_0, axis=1) / np.linalg.norm(d_0, axis=1)
    assert np.all(rel > 1e-5) and np.all(rel < 0.05), rel
    np.testing.assert_allclose(d_0, model.predict(q, wrench=np.array(
        [[float(r[k]) for k in ("fx", "fy", "fz", "mx", "my", "mz")] for r in flat]), gravity=None).deflection[:, :3],
        rtol=1e-12)
    proc = run_cli(["predict", "vjm", "m.json", "c.csv", "--out", "x.csv", "--gravity", "0,0,-9.8", "--no-gravity"],
                   cwd=tmp_path)
    assert proc.returncode == 2 and "not allowed with" in proc.stderr


def test_cli_compensate_load_only(tmp_path):
    assert run_cli(["simulate", "vjm", "--out", "c.csv", "--poses", "4", "--seed", "6"], cwd=tmp_path).returncode == 0
    assert run_cli(["identify", "vjm", "c.csv", "--save", "m.json"], cwd=tmp_path).returncode == 0
    both = run_cli(["compensate", "vjm", "m.json", "c.csv", "--out", "a.csv"], cwd=tmp_path)
    load = run_cli(["compensate", "vjm", "m.json", "c.csv", "--out", "b.csv", "--load-only"], cwd=tmp_path)
    assert both.returncode == 0 and load.returncode == 0, (both.stderr, load.stderr)
    assert "own weight + load" in both.stdout and "load's deflection only" in load.stdout
    a, b = _read(tmp_path / "a.csv"), _read(tmp_path / "b.csv")
    da = np.array([float(r["deflection"]) for r in a])
    db = np.array([float(r["deflection"]) for r in b])
    assert np.all(np.abs(da - db) > 1e-5)  # the arm's own sag, beyond 10 µm on every row


def test_cli_without_inertials_one_line_naming_the_link_and_no_gravity_round_trip(tmp_path):
    (tmp_path / "arm.urdf").write_text(PLANAR_2R)
    before = listing(tmp_path)
    for args in (["simulate", "vjm", "--out", "s.csv", *ARM, "--poses", "6"],):
        proc = run_cli(args, cwd=tmp_path)
        lines = proc.stderr.strip().splitlines()
        assert proc.returncode == 1 and len(lines) == 1, proc.stderr
        assert "link `l1`" in lines[0] and "--no-gravity" in lines[0], lines[0]
        assert listing(tmp_path) == before
    # Weightless, end to end.
    proc = run_cli(["simulate", "vjm", "--out", "c.csv", *ARM, "--poses", "6", "--no-gravity"], cwd=tmp_path)
    assert proc.returncode == 0 and "weightless" in proc.stdout, proc.stderr
    before = listing(tmp_path)
    for args in (["identify", "vjm", "c.csv", *ARM, "--save", "m.json"],
                 ["diagnose", "vjm", "c.csv", *ARM, "--quiet"]):
        proc = run_cli(args, cwd=tmp_path)
        lines = proc.stderr.strip().splitlines()
        assert proc.returncode == 1 and len(lines) == 1, proc.stderr
        assert "link `l1`" in lines[0] and "--no-gravity" in lines[0], lines[0]
        assert listing(tmp_path) == before
    proc = run_cli(["identify", "vjm", "c.csv", *ARM, "--no-gravity", "--save", "m.json"], cwd=tmp_path)
    assert proc.returncode == 0 and "weightless" in proc.stdout, proc.stderr
    assert run_cli(["diagnose", "vjm", "c.csv", *ARM, "--no-gravity", "--quiet"], cwd=tmp_path).returncode == 0
    for verb in ("predict", "compensate"):
        proc = run_cli([verb, "vjm", "m.json", "c.csv", "--out", f"{verb}.csv"], cwd=tmp_path)
        assert proc.returncode == 1 and "link `l1`" in proc.stderr and "--no-gravity" in proc.stderr, proc.stderr
        assert not (tmp_path / f"{verb}.csv").exists()
        go_on = ["--keep-going"] if verb == "compensate" else []  # a two-joint arm: near-singular rows
        proc = run_cli([verb, "vjm", "m.json", "c.csv", "--out", f"{verb}.csv", "--no-gravity", *go_on], cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
    assert "sag_dx" not in (tmp_path / "predict.csv").read_text().splitlines()[0]


def test_compensating_the_sag_through_a_model_file_uses_its_gravity(campaign, tmp_path):
    robot, camp = campaign
    m = camp.measurements
    q = m.q[:4]
    trad = robot.identify(m.q, m.wrench, m.displacement, model="traditional")
    trad.save(tmp_path / "t.json")
    a = trad.stiffness_model.compensate(q, payload=(2.0,))
    b = vjm.compensate_with_model_file(robot, str(tmp_path / "t.json"), q, payload=(2.0,))
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.q, trad.stiffness_model.compensate(q, payload=(2.0,), gravity=G).q)
    ceiling = trad.stiffness_model.compensate(q, payload=(2.0,), gravity=(0.0, 0.0, 9.80665))
    assert np.max(np.abs(ceiling.q - a.q)) > 1e-4
    # An extended model's aliased springs are stored as the minimum-norm member of their family
    # (negative entries): the sag is the equilibrium of what the data determine, which every
    # member shares to first order (before: refused). It agrees with the traditional model's,
    # which sees the same torsions, to a small fraction of the sag.
    ext = robot.identify(m.q, m.wrench, m.displacement, model="extended")
    assert np.nanmin(ext.stiffness_model.to_dict()["estimate"]["compliance"]) < 0
    e = ext.stiffness_model.compensate(q, payload=(2.0,))
    assert set(e.status) == {"converged"}
    np.testing.assert_allclose(e.deflection, a.deflection, rtol=0.1)
    ext.save(tmp_path / "e.json")
    write = "\n".join([",".join([f"q{j}" for j in range(1, 8)] + ["fx", "fy", "fz", "mx", "my", "mz"])]
                      + [",".join(repr(float(x)) for x in [*qi, 0, 0, -20, 0, 0, 0]) for qi in q]) + "\n"
    (tmp_path / "traj.csv").write_text(write)
    proc = run_cli(["compensate", "vjm", "e.json", "traj.csv", "--out", "c.csv"], cwd=tmp_path)
    assert proc.returncode == 0 and "converged 4" in proc.stdout, proc.stdout + proc.stderr
    assert run_cli(["compensate", "vjm", "e.json", "traj.csv", "--out", "c2.csv", "--load-only"],
                   cwd=tmp_path).returncode == 0


def test_wrenches_in_kn_under_gravity_fail_naming_the_units(campaign):
    # Compliances 1000× too large cannot hold the arm: the refits under gravity diverge before
    # the screening runs, so the error carries the weightless fit's warning about the units.
    robot, camp = campaign
    m = camp.measurements
    with pytest.raises(rs.IdentificationError, match="did not settle.*kN") as e:
        robot.identify(m.q, np.array(m.wrench) * 1e-3, m.displacement)
    assert isinstance(e.value, ValueError)
