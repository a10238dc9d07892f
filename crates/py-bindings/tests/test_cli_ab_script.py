"""benches/cli_ab.py removes the --out file between runs: only one that did not exist before it
started and that the command it ran wrote; a file already there is refused and left alone."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import robot_stiffness
from conftest import run_cli

ROOT = Path(__file__).resolve().parents[3]
SCRIPT = ROOT / "benches" / "cli_ab.py"
# The installed package as the "baseline": both builds are the same, so the outputs agree.
INSTALLED = str(Path(robot_stiffness.__file__).resolve().parents[1])


def _ab(tmp_path: Path, out: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    return subprocess.run([sys.executable, str(SCRIPT), "--baseline", INSTALLED, "--repeat", "1", "--",
                           "predict", "vjm", "m.json", "c.csv", "--out", str(out)],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)


def test_cli_ab_refuses_an_existing_output_and_removes_only_its_own(tmp_path):
    assert run_cli(["simulate", "vjm", "--out", "c.csv", "--poses", "8", "--seed", "3"], cwd=tmp_path).returncode == 0
    assert run_cli(["identify", "vjm", "c.csv", "--save", "m.json"], cwd=tmp_path).returncode == 0
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    mine = tmp_path / "mine.csv"
    mine.write_text("a user's file\n")
    refused = _ab(tmp_path, mine)
    assert refused.returncode == 2 and "exists" in refused.stderr, refused
    assert mine.read_text() == "a user's file\n"
    ran = _ab(tmp_path, tmp_path / "pred.csv")
    assert ran.returncode == 0, ran
    assert "outputs: the same bytes" in ran.stdout
    assert not (tmp_path / "pred.csv").exists()
    after = {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.name != "mine.csv"}
    assert after == before, "cli_ab.py touched files it did not write"
