"""The console script end to end: demo, simulate → identify → diagnose, CSJM, and bad input
files (one line on stderr, exit status ≠ 0, nothing written)."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from conftest import listing, run_cli
from test_demo_plot import assert_residuals_drawn
from test_csjm import synthetic, write_csv
from test_vjm import PLANAR_2R


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("campaign")
    proc = run_cli(
        ["simulate", "vjm", "--out", "c.csv", "--poses", "30", "--seed", "11",
         "--effect", "joint_tilt:joint=3,axis=x,compliance=5e-5", "--truth", "truth.json"],
        cwd=d,
    )
    assert proc.returncode == 0, proc.stderr
    assert "wrote c.csv: 120 rows" in proc.stdout
    assert json.loads((d / "truth.json").read_text())["truth"]["effects"][0]["effect"] == "joint_tilt"
    return d / "c.csv"


def test_help_is_there_for_every_command(tmp_path):
    for args in (["--help"], ["simulate", "vjm", "--help"], ["identify", "vjm", "--help"],
                 ["identify", "csjm", "--help"], ["diagnose", "vjm", "--help"], ["demo", "--help"]):
        proc = run_cli(args, cwd=tmp_path)
        assert proc.returncode == 0 and "usage: robot-stiffness" in proc.stdout, args
    top = run_cli(["--help"], cwd=tmp_path).stdout
    assert "robot-stiffness demo" in top and "dx,dy,dz" in top


def test_demo_tells_the_story_and_writes_a_report(tmp_path):
    proc = run_cli(["demo", "--out", "demo"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.strip().splitlines()
    assert 4 <= len(lines) <= 10
    text = proc.stdout
    assert "Baseline (traditional" in text and "Named cause: joint_tilt" in text and "lower than the baseline" in text
    out = tmp_path / "demo"
    assert {"campaign.csv", "diagnosis.json", "truth.json", "report"} <= {p.name for p in out.iterdir()}
    report = (out / "report" / "report.md").read_text()
    assert "lower than the baseline's" in report
    for png in ("residuals.png", "errors_per_pose.png", "effects.png", "verdict.png"):
        assert (out / "report" / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # Its pixels, not its header: the demo once wrote axes without a single residual bar.
    assert_residuals_drawn(out / "report" / "residuals.png")
    result = json.loads((out / "diagnosis.json").read_text())
    assert result["extended"]["test_mean_rel_error"] <= 0.6 * result["baseline"]["test_mean_rel_error"]
    assert not [p for p in tmp_path.rglob(".*tmp-*")], "temporary files left behind"


def test_identify_vjm_json_contract(campaign, tmp_path):
    proc = run_cli(["identify", "vjm", str(campaign), "--model", "extended", "--json", "id.json"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads((tmp_path / "id.json").read_text())
    assert doc["model"] == "extended" and doc["n_params"] == 21 and 0 < doc["rank"] <= 21
    assert [(p["joint"], p["axis"]) for p in doc["parameters"][:3]] == [(1, "z"), (1, "x"), (1, "y")]
    for p in doc["parameters"]:
        assert isinstance(p["identifiable"], bool)
        assert (p["compliance"] is None) == (not p["identifiable"])
    assert len(doc["combinations"]) == doc["rank"] and all("value" in c for c in doc["combinations"])
    assert doc["method"] in ("normal_equations", "qr")


def test_diagnose_vjm_json_and_report(campaign, tmp_path):
    proc = run_cli(["diagnose", "vjm", str(campaign), "--json", "d.json", "--report", "rep"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads((tmp_path / "d.json").read_text())
    assert set(doc) >= {"baseline", "findings", "extended", "unexplained"}
    assert set(doc["baseline"]) >= {"model", "n_params", "test_mean_rel_error"}
    f = doc["findings"][0]
    assert set(f) >= {"effect", "joint", "axis", "aliases", "evidence"}
    named = [(x["effect"], x["joint"], x["axis"]) for x in doc["findings"]]
    named += [(a.get("effect", x["effect"]), a["joint"], a["axis"]) for x in doc["findings"] for a in x["aliases"]]
    assert ("joint_tilt", 3, "x") in named
    assert (tmp_path / "rep" / "report.md").exists()


def test_identify_csjm_json_contract(tmp_path):
    R, tau = synthetic(np.random.default_rng(4), noise=1e-3)
    write_csv(tmp_path / "m.csv", R, tau, ref=2)
    proc = run_cli(["identify", "csjm", "m.csv", "--json", "k.json"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads((tmp_path / "k.json").read_text())
    assert np.array(doc["K"]).shape == (3, 3) and np.array(doc["K_D"]).shape == (3, 3)
    assert np.array(doc["K_stderr"]).shape == (3, 3) and len(doc["tau0"]) == 3
    assert doc["n"] == len(R) - 1 and doc["order"] == 1


def _edit_csv(src: Path, dst: Path, edit) -> None:
    lines = src.read_text().splitlines()
    header = lines[0].split(",")
    rows = [line.split(",") for line in lines[1:]]
    header, rows = edit(header, rows)
    dst.write_text("\n".join([",".join(header)] + [",".join(r) for r in rows]) + "\n")


def _drop_column(name):
    def edit(header, rows):
        k = header.index(name)
        return header[:k] + header[k + 1:], [r[:k] + r[k + 1:] for r in rows]
    return edit


def _set_cell(name, row, value):
    def edit(header, rows):
        rows[row][header.index(name)] = value
        return header, rows
    return edit


@pytest.mark.parametrize(
    "case, edit, extra, message",
    [
        ("missing column", _drop_column("fz"), [], "missing column 'fz'"),
        ("NaN", _set_cell("mx", 4, "nan"), [], "line 6, column 'mx'"),
        ("millimetres", _set_cell("dy", 2, "1.5"), [], "looks like mm"),
        ("unknown link", None, ["--urdf", "arm.urdf", "--base", "base", "--tip", "hand"], "`hand` does not exist"),
        ("missing file", None, ["--urdf", "nope.urdf", "--base", "base", "--tip", "tool"], "nope.urdf"),
    ],
)
def test_bad_vjm_files_give_one_line_and_no_outputs(campaign, tmp_path, case, edit, extra, message):
    data = tmp_path / "bad.csv"
    if edit is None:
        shutil.copy(campaign, data)
    else:
        _edit_csv(campaign, data, edit)
    (tmp_path / "arm.urdf").write_text(PLANAR_2R)
    before = listing(tmp_path)
    for cmd in (["identify", "vjm", "bad.csv", "--json", "o.json"],
                ["diagnose", "vjm", "bad.csv", "--json", "o.json", "--report", "rep"]):
        proc = run_cli(cmd + extra, cwd=tmp_path)
        assert proc.returncode != 0, case
        err = proc.stderr.strip().splitlines()
        assert len(err) == 1, (case, proc.stderr)
        assert err[0].startswith("robot-stiffness: error:") and message in err[0], (case, err[0])
        assert listing(tmp_path) == before, f"{case}: outputs were written"


def test_bad_csjm_file_names_the_row_and_writes_nothing(tmp_path):
    R, tau = synthetic(np.random.default_rng(5))
    R[4, 0, 1] = -R[4, 0, 1]  # a dropped minus sign: not a rotation any more
    write_csv(tmp_path / "m.csv", R, tau, ref=0)
    before = listing(tmp_path)
    proc = run_cli(["identify", "csjm", "m.csv", "--json", "k.json"], cwd=tmp_path)
    assert proc.returncode != 0
    err = proc.stderr.strip().splitlines()
    assert len(err) == 1 and "data row 5" in err[0] and "not a rotation" in err[0]
    assert listing(tmp_path) == before


def test_installed_console_script():
    exe = shutil.which("robot-stiffness")
    if exe is None:
        pytest.skip("the console script is not on PATH (package not installed with pip)")
    proc = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and proc.stdout.startswith("robot-stiffness ")


def test_csjm_simulate_diagnose_and_report(tmp_path):
    proc = run_cli(["simulate", "csjm", "--out", "c.csv", "--effect", "cable_hysteresis:friction=2", "--seed", "3",
                    "--truth", "t.json"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    truth = json.loads((tmp_path / "t.json").read_text())
    assert np.array(truth["K"]).shape == (3, 3)
    proc = run_cli(["diagnose", "csjm", "c.csv", "--json", "d.json", "--report", "rep"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads((tmp_path / "d.json").read_text())
    assert set(doc) >= {"baseline", "findings", "extended", "unexplained"}
    assert "cable_hysteresis" in [f["effect"] for f in doc["findings"]]
    assert "Named cause: cable_hysteresis" in proc.stdout
    assert (tmp_path / "rep" / "report.md").read_text().startswith("# CSJM stiffness diagnosis")
    # --quiet and --split-seed as for the arm: the same split seed gives the same JSON.
    proc = run_cli(["diagnose", "csjm", "c.csv", "--quiet", "--split-seed", "0", "--json", "d0.json"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert json.loads((tmp_path / "d0.json").read_text()) == doc
    proc = run_cli(["identify", "csjm", "c.csv", "--json", "k.json"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    k = np.array(json.loads((tmp_path / "k.json").read_text())["K"])
    # Hysteresis biases K; it still has to be the right stiffness to within a third.
    assert np.linalg.norm(k - np.array(truth["K"])) < 0.35 * np.linalg.norm(truth["K"])
