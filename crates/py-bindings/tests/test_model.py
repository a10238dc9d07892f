"""Stiffness model files and predictions from Python and the CLI: exact predictions through
aliases (UR5, all 18 springs), round trips, refusal of edited/stale/foreign files, payloads,
and bad input on the command line (one line, exit 1, nothing written)."""

from __future__ import annotations

import hashlib
import json
import sys
import sysconfig
from pathlib import Path
from typing import Optional

import numpy as np
import pytest

from conftest import listing, run_cli
from robot_stiffness import InvalidValueError, ModelFileError, StiffnessError
from robot_stiffness.model import STANDARD_GRAVITY, StiffnessModel
from robot_stiffness.vjm import Robot, simulate


def ur5_urdf() -> Optional[Path]:
    """example-robot-data's ur5_robot.urdf (installed under the cmeel prefix by the wheel)."""
    try:
        import example_robot_data as erd  # type: ignore

        p = Path(erd.getModelPath("ur5_robot.urdf"))
        for cand in (p, p / "ur5_robot.urdf", p / "ur_description/urdf/ur5_robot.urdf"):
            if cand.is_file():
                return cand
    except Exception:
        pass
    rel = "cmeel.prefix/share/example-robot-data/robots/ur_description/urdf/ur5_robot.urdf"
    for site in [sysconfig.get_paths()["purelib"], *sys.path]:
        p = Path(site) / rel
        if p.is_file():
            return p
    return None


def all_tilts(n: int, seed: int):
    """Tilt effects about x and y at every joint (the torsions are the nominal ones), seeded."""
    rng = np.random.default_rng(seed)
    return [
        {"effect": "joint_tilt", "joint": j, "axis": a, "compliance": float(rng.uniform(2e-5, 6e-5))}
        for j in range(1, n + 1)
        for a in ("x", "y")
    ]


def split(m):
    test = np.array([s == "test" for s in m.set])
    return ~test, test


def test_ur5_predictions_are_exact_although_springs_alias():
    urdf = ur5_urdf()
    if urdf is None:
        pytest.skip("example-robot-data's ur5_robot.urdf not found")
    robot = Robot.from_urdf(urdf, "base_link", "tool0")
    # Weightless: StiffnessModel.predict is the load's linear deflection (no sag).
    c = simulate(robot, all_tilts(6, 1), n_poses=40, seed=4, noise=False, gravity=None)
    m = c.measurements
    train, test = split(m)
    ident = robot.identify(m.q[train], m.wrench[train], m.displacement[train], model="extended", gravity=None)
    assert ident.rank < 18 and ident.aliases, "UR5 extended: some springs alias"
    assert np.isnan(ident.compliance).any()
    pred = ident.stiffness_model.predict(m.q[test], wrench=m.wrench[test])
    assert pred.identified.all()
    truth = m.displacement[test]  # noise-free: the recorded displacement is the truth
    rel = np.linalg.norm(pred.deflection[:, :3] - truth, axis=1) / np.linalg.norm(truth, axis=1)
    assert rel.max() <= 1e-9, rel.max()
    assert np.isnan(pred.deflection[:, 3:]).all() and np.isnan(pred.stddev[:, 3:]).all()


@pytest.fixture(scope="module")
def fitted(panda):
    c = simulate(panda, all_tilts(7, 2), n_poses=16, seed=8)
    m = c.measurements
    return m, panda.identify(m.q, m.wrench, m.displacement, model="extended", robust_covariance=True)


def test_round_trip_is_bitwise(fitted, panda, tmp_path):
    m, ident = fitted
    path = tmp_path / "model.json"
    ident.save(path)
    back = StiffnessModel.load(path, panda)
    assert back.content_sha256 == ident.stiffness_model.content_sha256
    a = ident.stiffness_model.predict(m.q, payload=(3.0, 0.0, 0.05, 0.1))
    b = back.predict(m.q, payload=(3.0, 0.0, 0.05, 0.1))
    for name in ("deflection", "stddev", "wrench", "excitation"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    doc = json.loads(path.read_text())
    assert doc["schema"] == "robot-stiffness/vjm-model/1"
    assert doc["model"]["robot"]["urdf"] == "bundled:panda_arm.urdf"
    assert doc["model"]["data"]["rows"] == len(m)
    assert doc["model"]["estimate"]["covariance_method"] == "robust"
    assert back.labels == panda.labels("extended") and back.rank == ident.rank
    # Without robust_covariance the model carries the identification's own covariance.
    plain = panda.identify(m.q, m.wrench, m.displacement, model="extended")
    assert plain.stiffness_model.to_dict()["estimate"]["covariance_method"] == "model"


def test_edited_and_foreign_files_are_refused(fitted, panda, tmp_path):
    _, ident = fitted
    doc = json.loads(ident.stiffness_model.to_json())
    doc["model"]["estimate"]["compliance"][0] *= 1.0 + 1e-12
    edited = tmp_path / "edited.json"
    edited.write_text(json.dumps(doc))
    with pytest.raises(ModelFileError, match="edited.json.*edited") as e:
        StiffnessModel.load(edited, panda)
    assert isinstance(e.value, ValueError) and isinstance(e.value, StiffnessError)
    good = tmp_path / "good.json"
    ident.save(good)
    with pytest.raises(ModelFileError, match="another robot.*tip link"):
        StiffnessModel.load(good, Robot.bundled("panda_hand_tcp"))
    with pytest.raises(ModelFileError, match="schema"):
        stale = tmp_path / "stale.json"
        stale.write_text(good.read_text().replace("vjm-model/1", "vjm-model/0"))
        StiffnessModel.load(stale, panda)
    with pytest.raises(FileNotFoundError):
        StiffnessModel.load(tmp_path / "missing.json", panda)


def test_payload_is_gravity_on_a_point_mass(fitted, panda):
    _, ident = fitted
    q = np.array([0.3, -0.2, 0.1, -1.9, 0.4, 1.5, 0.7])
    c = np.array([0.05, -0.02, 0.1])
    pred = ident.stiffness_model.predict(q, payload=(2.5, *c))
    T = panda.forward_kinematics(q)
    r = T[:3, :3] @ c
    f = np.array([0.0, 0.0, -2.5 * STANDARD_GRAVITY])
    np.testing.assert_allclose(pred.wrench[0], np.r_[f, np.cross(r, f)], rtol=0, atol=1e-12)
    by_wrench = ident.stiffness_model.predict(q, wrench=pred.wrench[0])
    np.testing.assert_array_equal(by_wrench.deflection, pred.deflection)
    # A bare mass sits at the tip point: no moment.
    np.testing.assert_allclose(ident.stiffness_model.predict(q, payload=1.0).wrench[0, 3:], 0.0, atol=0)
    for bad in (float("nan"), -1.0, (1.0, 0.0, float("inf"), 0.0), (1.0, 2.0)):
        with pytest.raises(InvalidValueError):
            ident.stiffness_model.predict(q, payload=bad)
    with pytest.raises(InvalidValueError, match="not both"):
        ident.stiffness_model.predict(q, wrench=np.zeros(6), payload=1.0)
    with pytest.raises(ValueError):
        ident.stiffness_model.predict(np.zeros((2, 6)), wrench=np.zeros((2, 6)))


def test_rotations_need_a_model_identified_with_rotations(panda):
    c = simulate(panda, all_tilts(7, 3), n_poses=12, seed=5, noise=False)
    m = c.measurements
    q, w = m.q, m.wrench
    # Rotations from the crate's own linear model (the testbed records translations only).
    J = panda.jacobian(q, "extended")
    truth = np.full(21, 1e-4)
    theta = truth * np.einsum("nrk,nr->nk", J, w)
    rot = np.einsum("nrk,nk->nr", J[:, 3:, :], theta)
    disp = np.einsum("nrk,nk->nr", J[:, :3, :], theta)
    with_rot = panda.identify(q, w, disp, model="extended", rotation=rot, gravity=None)  # linear data
    assert with_rot.stiffness_model.has_rotations
    pred = with_rot.stiffness_model.predict(q[:3], wrench=w[:3])
    np.testing.assert_allclose(pred.deflection[:, 3:], rot[:3], rtol=1e-9, atol=1e-15)
    without = panda.identify(q, w, disp, model="extended")
    assert not without.stiffness_model.has_rotations
    assert np.isnan(without.stiffness_model.predict(q[:3], wrench=w[:3]).deflection[:, 3:]).all()


# ----------------------------------------------------------------------------- CLI


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    d = tmp_path_factory.mktemp("model-cli")
    assert run_cli(["simulate", "vjm", "--out", "c.csv", "--poses", "16", "--seed", "3"], cwd=d).returncode == 0
    proc = run_cli(["identify", "vjm", "c.csv", "--model", "extended", "--save", "m.json"], cwd=d)
    assert proc.returncode == 0, proc.stderr
    return d


def test_cli_identify_save_then_predict(saved, panda, tmp_path):
    doc = json.loads((saved / "m.json").read_text())
    data = doc["model"]["data"]
    assert data["file"] == "c.csv" and len(data["sha256"]) == 64
    # The reader's hash, taken as it read, is the file's (hashlib: an independent code path).
    assert data["sha256"] == hashlib.sha256((saved / "c.csv").read_bytes()).hexdigest()
    proc = run_cli(["predict", "vjm", "m.json", "c.csv", "--out", "p.csv"], cwd=saved)
    assert proc.returncode == 0, proc.stderr
    assert "rotations unavailable" in proc.stdout
    lines = (saved / "p.csv").read_text().splitlines()
    header = lines[0].split(",")
    assert header[:7] == [f"q{j}" for j in range(1, 8)] and header[-8] == "identified"
    # the sag under the arm's weight, as use-the-model.md documents it
    assert header[-7:] == ["sag_dx", "sag_dy", "sag_dz", "sag_sd_dx", "sag_sd_dy", "sag_sd_dz", "sag_identified"]
    rows = [line.split(",") for line in lines[1:]]
    col = {h: i for i, h in enumerate(header)}
    model = StiffnessModel.load(saved / "m.json", panda)
    q = np.array([[float(r[col[f"q{j}"]]) for j in range(1, 8)] for r in rows])
    w = np.array([[float(r[col[c]]) for c in ("fx", "fy", "fz", "mx", "my", "mz")] for r in rows])
    pred = model.predict(q, wrench=w)
    got = np.array([[float(r[col[c]]) for c in ("dx", "dy", "dz")] for r in rows])
    np.testing.assert_array_equal(got, pred.deflection[:, :3])
    assert all(r[col["rx"]] == "" and r[col["srz"]] == "" and r[col["identified"]] == "true" for r in rows)
    # Payload on a poses-only file.
    (saved / "poses.csv").write_text("q1,q2,q3,q4,q5,q6,q7\n0.1,-0.3,0.2,-2.0,0.1,1.8,0.5\n")
    proc = run_cli(["predict", "vjm", "m.json", "poses.csv", "--payload", "2,0,0,0.1", "--out", "pp.csv"], cwd=saved)
    assert proc.returncode == 0, proc.stderr
    row = (saved / "pp.csv").read_text().splitlines()[1].split(",")
    assert float(row[col["fz"]]) == -2 * STANDARD_GRAVITY


@pytest.mark.parametrize(
    "case, args, pattern",
    [
        ("edited", ["predict", "vjm", "edited.json", "c.csv", "--out", "out.csv"], "edited.json.*edited"),
        ("nan payload", ["predict", "vjm", "m.json", "poses.csv", "--payload", "nan", "--out", "out.csv"], "payload"),
        ("missing column", ["predict", "vjm", "m.json", "noq3.csv", "--out", "out.csv"], "noq3.csv.*q"),
        ("joint count", ["predict", "vjm", "m.json", "six.csv", "--out", "out.csv"], "six.csv.*6 joint columns"),
        ("no load", ["predict", "vjm", "m.json", "poses.csv", "--out", "out.csv"], "fx.*--payload"),
        ("two loads", ["predict", "vjm", "m.json", "c.csv", "--payload", "1", "--out", "out.csv"], "use one"),
        ("other robot", ["predict", "vjm", "m.json", "c.csv", "--tip", "panda_hand_tcp", "--out", "out.csv"],
         "another robot"),
        ("bad cell", ["predict", "vjm", "m.json", "badcell.csv", "--out", "out.csv"], "badcell.csv.*line 2.*q2"),
    ],
)
def test_cli_predict_bad_input(saved, tmp_path, case, args, pattern):
    import re
    import shutil

    for name in ("m.json", "c.csv"):
        shutil.copy(saved / name, tmp_path / name)
    doc = json.loads((saved / "m.json").read_text())
    doc["model"]["noise"]["sigma2"] *= 2
    (tmp_path / "edited.json").write_text(json.dumps(doc, indent=1))
    (tmp_path / "poses.csv").write_text("q1,q2,q3,q4,q5,q6,q7\n0.1,-0.3,0.2,-2.0,0.1,1.8,0.5\n")
    (tmp_path / "noq3.csv").write_text("q1,q2,q4,q5,q6,q7,q8,fx,fy,fz,mx,my,mz\n" + "0," * 12 + "0\n")
    (tmp_path / "six.csv").write_text("q1,q2,q3,q4,q5,q6,fx,fy,fz,mx,my,mz\n" + "0," * 11 + "0\n")
    (tmp_path / "badcell.csv").write_text("q1,q2,q3,q4,q5,q6,q7,fx,fy,fz,mx,my,mz\n0,abc" + ",0" * 11 + "\n")
    before = listing(tmp_path)
    proc = run_cli(args, cwd=tmp_path)
    assert proc.returncode == 1, (case, proc.stdout)
    err = proc.stderr.strip().splitlines()
    assert len(err) == 1, proc.stderr
    assert re.search(pattern, err[0]), (case, err[0])
    assert listing(tmp_path) == before, "nothing written"


def test_weird_arguments_raise_only_package_errors(fitted, panda, tmp_path, monkeypatch):
    """Every argument of the model API, a set of wrong values: only StiffnessError escapes."""
    from test_api_weird_arguments import WEIRD

    monkeypatch.chdir(tmp_path)
    m, ident = fitted
    path = tmp_path / "m.json"
    ident.save(path)
    model = ident.stiffness_model
    cases = [
        ("StiffnessModel.load", StiffnessModel.load, {"path": str(path), "robot": panda}),
        ("StiffnessModel.save", model.save, {"path": str(tmp_path / "out.json")}),
        ("Identification.save", ident.save, {"path": str(tmp_path / "out2.json")}),
        ("StiffnessModel.predict", model.predict, {"q": m.q[:2], "wrench": m.wrench[:2], "payload": None}),
        ("StiffnessModel.predict(payload)", model.predict, {"q": m.q[:2], "payload": (1.0, 0.0, 0.0, 0.1)}),
        ("Robot.identify(data_file)", panda.identify,
         {"q": m.q, "wrench": m.wrench, "displacement": m.displacement, "data_file": None}),
    ]
    escaped = []
    for name, fn, good in cases:
        for param in good:
            for value in WEIRD:
                kwargs = dict(good, **{param: value})
                try:
                    fn(**kwargs)
                except StiffnessError:
                    pass
                except Exception as e:  # noqa: BLE001 - the point of the test
                    escaped.append(f"{name}({param}={value!r}): {type(e).__name__}: {str(e)[:120]}")
    assert not escaped, "\n".join(escaped)


def test_cli_predict_uses_the_robot_recorded_in_the_model(tmp_path):
    """identify with --urdf, predict without: the model's URDF path, base and tip are used (and
    checked); --help documents the command."""
    urdf = ur5_urdf()
    if urdf is None:
        pytest.skip("example-robot-data's ur5_robot.urdf not found")
    robot = ["--urdf", str(urdf), "--base", "base_link", "--tip", "tool0"]
    assert run_cli(["simulate", "vjm", "--out", "c.csv", "--poses", "12", "--seed", "2", *robot], cwd=tmp_path).returncode == 0
    proc = run_cli(["identify", "vjm", "c.csv", "--model", "extended", "--save", "m.json", *robot], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    rec = json.loads((tmp_path / "m.json").read_text())["model"]["robot"]
    assert rec["urdf"] == str(urdf) and rec["tip"] == "tool0" and len(rec["urdf_sha256"]) == 64
    proc = run_cli(["predict", "vjm", "m.json", "c.csv", "--out", "p.csv"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "p.csv").read_text().splitlines()[0].startswith("q1,q2,q3,q4,q5,q6,fx")
    # The bundled arm is another robot.
    proc = run_cli(["predict", "vjm", "m.json", "c.csv", "--tip", "panda_link8", "--out", "p2.csv"], cwd=tmp_path)
    assert proc.returncode == 1 and "another robot" in proc.stderr and not (tmp_path / "p2.csv").exists()
    # --out must not overwrite an input.
    proc = run_cli(["predict", "vjm", "m.json", "c.csv", "--out", "m.json"], cwd=tmp_path)
    assert proc.returncode == 1 and "input" in proc.stderr
    help_text = run_cli(["predict", "vjm", "--help"], cwd=tmp_path).stdout
    assert "--payload" in help_text and "true deflection" in help_text


def test_cli_identify_save_into_a_missing_folder_writes_nothing(saved, tmp_path):
    import shutil

    shutil.copy(saved / "c.csv", tmp_path / "c.csv")
    before = listing(tmp_path)
    proc = run_cli(["identify", "vjm", "c.csv", "--json", "id.json", "--save", "nowhere/m.json"], cwd=tmp_path)
    assert proc.returncode == 1 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "--save" in proc.stderr
    assert listing(tmp_path) == before


def test_a_read_file_is_fingerprinted_once_and_its_hash_recorded(saved, panda, tmp_path):
    from robot_stiffness.vjm import DataFile, read_measurements

    path = saved / "c.csv"
    m = read_measurements(path, panda.n_joints)
    expected = hashlib.sha256(path.read_bytes()).hexdigest()
    assert m.source == DataFile(str(path), expected)
    assert read_measurements(path, panda.n_joints, fingerprint=False).source is None
    # Provenance is not content: the same rows from arrays compare equal.
    assert m == type(m)(q=m.q, wrench=m.wrench, displacement=m.displacement, pose=m.pose, set=m.set)
    # The recorded hash is the one the reader took, even if the file changes afterwards.
    copy = tmp_path / "c.csv"
    copy.write_bytes(path.read_bytes())
    mc = read_measurements(copy, panda.n_joints)
    copy.write_text("changed after reading\n")
    ident = panda.identify(mc.q, mc.wrench, mc.displacement, data_file=mc.source, gravity=None)
    ident.save(tmp_path / "m.json")
    data = json.loads((tmp_path / "m.json").read_text())["model"]["data"]
    assert (data["file"], data["sha256"]) == (str(copy), expected)
    with pytest.raises(ValueError, match="64 lowercase hex digits"):
        panda.identify(mc.q, mc.wrench, mc.displacement, data_file=DataFile(str(copy), "XYZ"), gravity=None)


def test_predict_sag_names_a_bad_pose_by_row_and_column(fitted, panda):
    """The sag's poses get identify's checks without a wrench: a NaN is named by array, row
    (from 0) and column; a pose outside the URDF limits is refused unless allowed."""
    _, ident = fitted
    q = np.tile([0.3, -0.2, 0.1, -1.9, 0.4, 1.5, 0.7], (5, 1))
    assert np.isfinite(ident.stiffness_model.predict_sag(q, gravity=(0.0, 0.0, -9.81)).deflection[:, :3]).all()
    bad = q.copy()
    bad[3, 2] = np.nan
    with pytest.raises(InvalidValueError, match=r"q.*row 3.*column 2"):
        ident.stiffness_model.predict_sag(bad, gravity=(0.0, 0.0, -9.81))
    outside = q.copy()
    outside[1, 3] = 0.5  # the Panda's joint 4 stops at -0.0698 rad
    with pytest.raises(StiffnessError):
        ident.stiffness_model.predict_sag(outside, gravity=(0.0, 0.0, -9.81))
    ident.stiffness_model.predict_sag(outside, gravity=(0.0, 0.0, -9.81), allow_outside_limits=True)
