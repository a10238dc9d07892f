"""scripts/verify_packages.py (the CI packaging check) removes only the folder it made: a
``package-check`` folder without its marker is left as it is, with an error naming it."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
SCRIPT = ROOT / "scripts" / "verify_packages.py"


def _run(target: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "CARGO_TARGET_DIR": str(target)}
    return subprocess.run([sys.executable, str(SCRIPT), "stiffness-core"], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=120)


pytestmark = pytest.mark.skipif(shutil.which("cargo") is None or not (ROOT / "Cargo.toml").is_file(),
                                reason="needs the workspace and cargo")


def test_a_folder_it_did_not_make_is_left_alone(tmp_path):
    mine = tmp_path / "package-check"
    mine.mkdir()
    (mine / "notes.txt").write_text("the user's")
    r = _run(tmp_path)
    assert r.returncode == 2
    assert "was not made by this script" in r.stderr and str(mine) in r.stderr
    assert (mine / "notes.txt").read_text() == "the user's"


def test_its_own_folder_is_replaced_and_a_missing_crate_is_named(tmp_path):
    own = tmp_path / "package-check"
    own.mkdir()
    (own / ".made-by-verify-packages").write_text("")
    (own / "stale.txt").write_text("from an earlier run")
    r = _run(tmp_path)
    assert r.returncode == 2
    assert "stiffness-core-" in r.stderr and "run cargo package first" in r.stderr
    assert not (own / "stale.txt").exists() and (own / ".made-by-verify-packages").exists()
