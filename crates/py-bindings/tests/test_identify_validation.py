"""Issue 14: `Robot.identify` on arrays gets the checks of a measurement file (units,
magnitudes, zero-information data, joint limits), as `identify vjm` on the command line does.
Before the fix the Python API identified millimetres, 1e308 loads and all-zero wrenches
("rank 0") without a word."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import robot_stiffness as rs
from robot_stiffness import vjm
from robot_stiffness.vjm import Robot


@pytest.fixture(scope="module")
def campaign():
    panda = Robot.bundled()
    camp = vjm.simulate(panda, [], n_poses=12, wrenches_per_pose=4, seed=5)
    m = camp.measurements
    return panda, np.array(m.q), np.array(m.wrench), np.array(m.displacement), camp


def test_clean_arrays_identify(campaign):
    panda, q, w, d, _ = campaign
    res = panda.identify(q, w, d)
    assert res.rank == 6  # J7z is unseen from the tip point on its axis


def test_millimetres_are_refused_naming_row_and_column(campaign):
    panda, q, w, d, _ = campaign
    with pytest.raises(rs.DataFileError, match=r"column 'd[xyz]'.*looks like mm"):
        panda.identify(q, w, d * 1000.0)


def test_an_implausible_load_cell_is_refused(campaign):
    panda, q, w, d, _ = campaign
    w = w.copy()
    w[3, 2] = 1e308
    with pytest.raises(rs.DataFileError, match=r"column 'fz'.*1e308|column 'fz'.*larger than"):
        panda.identify(q, w, d)


def test_all_zero_wrenches_are_refused_not_rank_0(campaign):
    panda, q, w, d, _ = campaign
    with pytest.raises(rs.DataFileError, match="no load|wrench"):
        panda.identify(q, np.zeros_like(w), d)


def test_all_zero_displacements_are_refused(campaign):
    panda, q, w, d, _ = campaign
    with pytest.raises(rs.DataFileError, match="displacement"):
        panda.identify(q, w, np.zeros_like(d))


def test_joint_angles_outside_the_limits_are_refused_unless_allowed(campaign):
    panda, q, w, d, _ = campaign
    q = q.copy()
    q[5, 3] = 0.5  # the Panda's joint 4 lives in [-3.07, -0.07] rad
    with pytest.raises(rs.DataFileError, match=r"q4.*panda_joint4|panda_joint4.*q4"):
        panda.identify(q, w, d)
    res = panda.identify(q, w, d, allow_outside_limits=True)
    assert res.rank >= 6


def test_cli_identify_refuses_angles_outside_the_limits_unless_allowed(campaign, tmp_path: Path):
    _, q, w, d, camp = campaign
    data = tmp_path / "data.csv"
    text = camp.csv.splitlines()
    header = text[0].split(",")
    col = header.index("q4")
    cells = text[1].split(",")
    cells[col] = "0.5"
    text[1] = ",".join(cells)
    data.write_text("\n".join(text) + "\n")
    run = [sys.executable, "-m", "robot_stiffness.cli", "identify", "vjm", str(data)]
    bad = subprocess.run(run, capture_output=True, text=True, timeout=120)
    assert bad.returncode == 1, bad.stderr
    assert bad.stderr.count("\n") == 1 and "panda_joint4" in bad.stderr, bad.stderr
    ok = subprocess.run(run + ["--allow-outside-limits"], capture_output=True, text=True, timeout=120)
    assert ok.returncode == 0, ok.stderr
