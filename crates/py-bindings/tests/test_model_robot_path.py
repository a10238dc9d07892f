"""Model files find their robot from anywhere (issue 24): the URDF is recorded by absolute path
and relative to the model file (``urdf_relative``); ``--urdf`` alone takes base and tip from the
model file; a moved or changed URDF still gets a clear error; data that do not fit the bundled
Panda, used because ``--urdf`` was forgotten, say so."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path
from typing import List

import pytest

from conftest import listing, run_cli
from robot_stiffness import _core
from robot_stiffness.model import StiffnessModel
from robot_stiffness.vjm import Robot, simulate

#: The bundled Panda's URDF up to link 6: a 6-joint arm of the test's own, in its own file.
ARM = ["--base", "panda_link0", "--tip", "panda_link6"]
HINT = "pass --urdf ROBOT.urdf --base LINK --tip LINK for another arm"


def bundled_urdf_text() -> str:
    # The bundled robot pickles its URDF text: the first argument of its reduction.
    _, args = _core.Robot.bundled(None).__reduce__()
    return str(args[0])


def ok(args: List[str], cwd: Path) -> str:
    proc = run_cli(args, cwd=cwd)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc.stdout


def fails(args: List[str], cwd: Path) -> str:
    """The one error line of a failed command (exit status 1)."""
    proc = run_cli(args, cwd=cwd)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    return lines[0]


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> Path:
    """A folder with ``robot/arm.urdf`` (6 joints with ARM) and its campaign ``c.csv``."""
    d = tmp_path_factory.mktemp("arm")
    (d / "robot").mkdir()
    (d / "robot" / "arm.urdf").write_text(bundled_urdf_text())
    ok(["simulate", "vjm", "--out", "c.csv", "--poses", "10", "--seed", "3", "--urdf", "robot/arm.urdf", *ARM,
        "--no-gravity"], cwd=d)
    return d


def project(campaign: Path, where: Path) -> Path:
    """A project folder at ``where``: the URDF, the campaign, and ``models/m.json`` identified
    there with the URDF given relative to the project folder (as a user types it)."""
    shutil.copytree(campaign, where)
    (where / "models").mkdir()
    ok(["identify", "vjm", "c.csv", "--urdf", "robot/arm.urdf", *ARM, "--save", "models/m.json", "--no-gravity"],
       cwd=where)
    return where


def predict(model: Path, data: Path, *extra: str) -> List[str]:
    return ["predict", "vjm", str(model), str(data), "--out", "p.csv", "--no-gravity", *extra]


def test_the_model_file_records_the_urdf_absolute_and_relative(campaign, tmp_path):
    p = project(campaign, tmp_path / "proj")
    doc = json.loads((p / "models" / "m.json").read_text())
    assert doc["model"]["robot"]["urdf"] == str(p / "robot" / "arm.urdf")
    assert doc["urdf_relative"] == "../robot/arm.urdf"
    # Older readers' part of the file is unchanged: the hash is that of `model` alone.
    robot = Robot.from_urdf(p / "robot" / "arm.urdf", "panda_link0", "panda_link6")
    m = StiffnessModel.load(p / "models" / "m.json", robot)
    assert m.content_sha256 == doc["content_sha256"]
    assert "urdf_relative" not in m.to_json()


def test_predict_from_another_folder(campaign, tmp_path):
    p = project(campaign, tmp_path / "proj")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    ok(predict(p / "models" / "m.json", p / "c.csv"), cwd=elsewhere)
    assert (elsewhere / "p.csv").read_text().startswith("q1,q2,q3,q4,q5,q6,fx")
    # compensate resolves the robot the same way.
    comp = ["compensate", "vjm", str(p / "models" / "m.json"), str(p / "c.csv"), "--out", "comp.csv",
            "--no-gravity", "--position-only"]
    ok(comp, cwd=elsewhere)


def test_a_folder_moved_with_its_urdf_still_finds_it(campaign, tmp_path):
    p = project(campaign, tmp_path / "proj")
    moved = tmp_path / "moved" / "deeper"
    moved.parent.mkdir()
    p.rename(moved)
    assert not (p / "robot" / "arm.urdf").exists()
    out = ok(predict(Path("models/m.json"), Path("c.csv")), cwd=moved)
    assert "wrote p.csv" in out
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    ok(predict(moved / "models" / "m.json", moved / "c.csv"), cwd=elsewhere)
    # Writing over the URDF found there is refused: it is the model's input.
    line = fails(["predict", "vjm", str(moved / "models" / "m.json"), str(moved / "c.csv"),
                  "--out", str(moved / "robot" / "arm.urdf"), "--no-gravity", "--force"], cwd=elsewhere)
    assert "is an input file" in line, line


def test_a_lost_urdf_names_the_places_tried_and_urdf_alone_suffices(campaign, tmp_path):
    first = project(campaign, tmp_path / "proj")
    p = tmp_path / "moved"
    first.rename(p)
    kept = tmp_path / "kept.urdf"
    (p / "robot" / "arm.urdf").rename(kept)
    before = listing(tmp_path)
    line = fails(predict(Path("models/m.json"), Path("c.csv")), cwd=p)
    recorded = first / "robot" / "arm.urdf"
    assert f"models/m.json was identified on {recorded}, which does not exist here" in line, line
    assert f"(looked for {recorded}, models/../robot/arm.urdf)" in line, line
    assert "give --urdf ROBOT.urdf (base panda_link0 and tip panda_link6" in line, line
    assert listing(tmp_path) == before
    # --urdf alone: base and tip from the model file.
    ok(predict(Path("models/m.json"), Path("c.csv"), "--urdf", str(kept)), cwd=p)
    assert (p / "p.csv").read_text().startswith("q1,q2,q3,q4,q5,q6,fx")
    # ... and it is still checked: the whole Panda is another robot.
    (p / "p.csv").unlink()
    whole = tmp_path / "whole.urdf"
    whole.write_text(bundled_urdf_text() + "\n<!-- another file -->\n")
    line = fails(predict(Path("models/m.json"), Path("c.csv"), "--urdf", str(whole)), cwd=p)
    assert "another robot" in line, line
    assert not (p / "p.csv").exists()
    # Elsewhere --urdf still needs --base and --tip, and says so.
    line = fails(["identify", "vjm", "c.csv", "--urdf", str(kept), "--no-gravity"], cwd=p)
    assert "--urdf needs both --base LINK and --tip LINK" in line and "predict and compensate" in line, line


def test_a_changed_urdf_is_refused_by_its_content(campaign, tmp_path):
    p = project(campaign, tmp_path / "proj")
    urdf = p / "robot" / "arm.urdf"
    urdf.write_text(urdf.read_text() + "\n<!-- edited -->\n")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    line = fails(predict(p / "models" / "m.json", p / "c.csv"), cwd=elsewhere)
    assert "is for another robot" in line and "URDF content (SHA-256)" in line, line
    assert not (elsewhere / "p.csv").exists()


def test_a_copy_with_the_recorded_content_wins_over_an_edited_original(campaign, tmp_path):
    p = project(campaign, tmp_path / "proj")
    copy = tmp_path / "copy"
    shutil.copytree(p, copy)
    (p / "robot" / "arm.urdf").write_text(bundled_urdf_text() + "\n<!-- edited -->\n")
    ok(predict(Path("models/m.json"), Path("c.csv")), cwd=copy)


def test_the_python_save_records_the_urdf_relative_to_the_file(campaign, tmp_path):
    shutil.copy(campaign / "robot" / "arm.urdf", tmp_path / "arm.urdf")
    robot = Robot.from_urdf(tmp_path / "arm.urdf", "panda_link0", "panda_link6")
    m = simulate(robot, n_poses=10, seed=2, gravity=None).measurements
    ident = robot.identify(m.q, m.wrench, m.displacement, gravity=None)
    (tmp_path / "out").mkdir()
    ident.save(tmp_path / "out" / "m.json")
    doc = json.loads((tmp_path / "out" / "m.json").read_text())
    assert doc["urdf_relative"] == "../arm.urdf"
    assert doc["model"]["robot"]["urdf"] == str(tmp_path / "arm.urdf")
    loaded = StiffnessModel.load(tmp_path / "out" / "m.json", robot)
    assert loaded == ident.stiffness_model


def test_data_of_another_arm_without_urdf_hint_at_urdf(campaign, tmp_path):
    """Before: forgetting --urdf fell back to the bundled Panda, and the error only said the
    column count was wrong (or, for 7-joint data, suggested --allow-outside-limits)."""
    shutil.copy(campaign / "c.csv", tmp_path / "c6.csv")
    line = fails(["identify", "vjm", "c6.csv", "--no-gravity"], cwd=tmp_path)
    assert "6 joint columns but the chain has 7" in line, line
    assert "this is the bundled Panda (7 joints, no --urdf given)" in line and HINT in line, line
    line = fails(["diagnose", "vjm", "c6.csv", "--json", "d.json", "--no-gravity"], cwd=tmp_path)
    assert HINT in line, line
    # 7-joint data outside the Panda's limits (an xArm7's angles): both ways out are named.
    with open(campaign / "c.csv", newline="") as f:
        rows = list(csv.reader(f))
    head = rows[0][:6] + ["q7"] + rows[0][6:]
    body = [r[:6] + ["0.0"] + r[6:] for r in rows[1:]]
    col = head.index("q4")
    for r in body:
        r[col] = "1.0"  # the Panda's joint 4 stays within [-3.07, -0.07] rad
    with open(tmp_path / "x7.csv", "w", newline="") as f:
        csv.writer(f).writerows([head, *body])
    line = fails(["identify", "vjm", "x7.csv", "--no-gravity"], cwd=tmp_path)
    assert "outside the joint's limits" in line and "--allow-outside-limits" in line, line
    assert HINT in line, line
    # With --urdf given the robot is the user's: no such hint.
    line = fails(["identify", "vjm", "c6.csv", "--urdf", str(campaign / "robot" / "arm.urdf"),
                  "--base", "panda_link0", "--tip", "panda_link8", "--no-gravity"], cwd=tmp_path)
    assert "joint columns" in line and HINT not in line, line
    assert not (tmp_path / "d.json").exists()
