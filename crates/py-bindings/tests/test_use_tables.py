"""Issue 25: the tables of ``predict vjm`` and ``compensate vjm`` in every format. The CSV ones
are written by the core's table writer; read back here by Python's own parser, every number is
the in-memory result bit for bit (shortest round-trip text). Parquet and Arrow IPC inputs and
outputs (pyarrow) carry the same columns and values, NaN where CSV leaves a cell empty and a null
``limit_joint`` where no joint leaves its limits; a bad Parquet cell is named by column and row."""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Dict, List

import numpy as np
import pytest

from conftest import run_cli

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

from robot_stiffness._columnar import read_columns, write_columns  # noqa: E402
from robot_stiffness.model import StiffnessModel  # noqa: E402
from robot_stiffness.vjm import Robot  # noqa: E402

WRENCH = ["fx", "fy", "fz", "mx", "my", "mz"]


@pytest.fixture(scope="module")
def model_dir(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("use-tables")
    assert run_cli(["simulate", "vjm", "--out", "c.csv", "--poses", "20", "--seed", "5"], cwd=d).returncode == 0
    proc = run_cli(["identify", "vjm", "c.csv", "--model", "extended", "--save", "m.json"], cwd=d)
    assert proc.returncode == 0, proc.stderr
    # Compensating the arm's own sag needs springs that do not alias: the traditional model.
    proc = run_cli(["identify", "vjm", "c.csv", "--model", "traditional", "--save", "t.json"], cwd=d)
    assert proc.returncode == 0, proc.stderr
    return d


def read_csv_columns(path: Path) -> Dict[str, List[str]]:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    return {h: [r[i] for r in body] for i, h in enumerate(header)}


def as_float(cell: str) -> float:
    return math.nan if cell == "" else float(cell)


def same_floats(got: np.ndarray, want: np.ndarray, what: str) -> None:
    both_nan = np.isnan(got) & np.isnan(want)
    assert np.array_equal(got[~both_nan], want[~both_nan]), what
    assert np.array_equal(np.isnan(got), np.isnan(want)), f"{what}: NaN cells differ"


def test_predict_csv_is_the_in_memory_prediction_bit_for_bit_and_parquet_the_same(model_dir, tmp_path):
    robot = Robot.bundled()
    for args, name in (([], "p.csv"), (["--no-gravity"], "pw.csv")):
        proc = run_cli(["predict", "vjm", "m.json", "c.csv", "--out", str(tmp_path / name), *args], cwd=model_dir)
        assert proc.returncode == 0, proc.stderr
    cols = read_csv_columns(tmp_path / "p.csv")
    model = StiffnessModel.load(model_dir / "m.json", robot)
    q = np.array([[float(v) for v in cols[f"q{j}"]] for j in range(1, 8)]).T
    w = np.array([[float(v) for v in cols[c]] for c in WRENCH]).T
    pred = model.predict(q, wrench=w)
    sag = model.predict_sag(q)
    for k, c in enumerate(["dx", "dy", "dz", "rx", "ry", "rz"]):
        same_floats(np.array([as_float(v) for v in cols[c]]), pred.deflection[:, k], c)
        same_floats(np.array([as_float(v) for v in cols["s" + c]]), pred.stddev[:, k], "s" + c)
    for k, c in enumerate(["sag_dx", "sag_dy", "sag_dz"]):
        same_floats(np.array([as_float(v) for v in cols[c]]), sag.deflection[:, k], c)
        same_floats(np.array([as_float(v) for v in cols[c.replace("sag_", "sag_sd_")]]), sag.stddev[:, k], c)
    assert cols["identified"] == ["true" if b else "false" for b in pred.identified]
    assert all(v == "" for v in cols["rx"]), "the model has no rotations: empty cells"
    assert "sag_dx" not in read_csv_columns(tmp_path / "pw.csv")

    # The same poses as Parquet in, Parquet and Arrow IPC out: the same columns and values.
    names = [f"q{j}" for j in range(1, 8)] + WRENCH
    write_columns(tmp_path / "poses.parquet", names, [q[:, j] for j in range(7)] + [w[:, k] for k in range(6)])
    for out in ("p.parquet", "p.arrow"):
        proc = run_cli(["predict", "vjm", str(model_dir / "m.json"), "poses.parquet", "--out", out], cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
        table = read_columns(tmp_path / out)
        assert list(table) == list(cols), out
        for c, cells in cols.items():
            if c in ("identified", "sag_identified"):
                assert table[c].dtype == np.bool_ and list(table[c]) == [v == "true" for v in cells], c
            else:
                same_floats(table[c], np.array([as_float(v) for v in cells]), f"{out}: {c}")


def test_compensate_in_every_format_agrees_with_the_in_memory_result(model_dir, tmp_path):
    robot = Robot.bundled()
    proc = run_cli(["compensate", "vjm", "t.json", "c.csv", "--out", str(tmp_path / "comp.csv")], cwd=model_dir)
    assert proc.returncode == 0, proc.stderr
    cols = read_csv_columns(tmp_path / "comp.csv")
    q0 = np.array([[float(v) for v in cols[f"q{j}_nominal"]] for j in range(1, 8)]).T
    w = read_columns_csv_wrench(model_dir / "c.csv")
    comp = StiffnessModel.load(model_dir / "t.json", robot).compensate(q0, wrench=w)
    for j in range(7):
        same_floats(np.array([float(v) for v in cols[f"q{j + 1}"]]), comp.q[:, j], f"q{j + 1}")
    for c in ("position_error", "rotation_error", "deflection", "rotation_deflection", "inverse_condition"):
        same_floats(np.array([as_float(v) for v in cols[c]]), getattr(comp, c), c)
    assert cols["iterations"] == [str(int(i)) for i in comp.iterations]
    assert cols["limit_joint"] == ["" if j < 0 else str(j + 1) for j in comp.limit_joint]
    assert cols["status"] == list(comp.status)

    names = [f"q{j}" for j in range(1, 8)] + WRENCH
    write_columns(tmp_path / "traj.parquet", names, [q0[:, j] for j in range(7)] + [w[:, k] for k in range(6)])
    proc = run_cli(["compensate", "vjm", str(model_dir / "t.json"), "traj.parquet", "--out", "comp.parquet"],
                   cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    table = pq.read_table(tmp_path / "comp.parquet")
    assert table.column_names == list(cols)
    limit = table.column("limit_joint").to_pylist()
    assert limit == [None if j < 0 else int(j) + 1 for j in comp.limit_joint]
    assert table.column("status").to_pylist() == list(comp.status)
    same_floats(table.column("q1").to_numpy(), comp.q[:, 0], "q1")


def read_columns_csv_wrench(path: Path) -> np.ndarray:
    cols = read_csv_columns(path)
    return np.array([[float(v) for v in cols[c]] for c in WRENCH]).T


def test_compensate_reports_a_joint_outside_its_limits_as_null_in_parquet(model_dir, tmp_path):
    """Nominal targets at joint 4's upper limit: the correction leaves it for some rows."""
    robot = Robot.bundled()
    cols = read_csv_columns(model_dir / "c.csv")
    q0 = np.array([[float(v) for v in cols[f"q{j}"]] for j in range(1, 8)]).T[:6].copy()
    q0[:, 3] = -0.0698  # the Panda's joint 4 upper limit (rad): a correction may cross it
    w = np.tile([0.0, 0.0, -80.0, 0.0, 0.0, 0.0], (6, 1))
    names = [f"q{j}" for j in range(1, 8)] + WRENCH
    write_columns(tmp_path / "t.parquet", names, [q0[:, j] for j in range(7)] + [w[:, k] for k in range(6)])
    proc = run_cli(["compensate", "vjm", str(model_dir / "t.json"), "t.parquet", "--out", "c.parquet",
                    "--allow-outside-limits", "--keep-going"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    comp = StiffnessModel.load(model_dir / "t.json", robot).compensate(q0, wrench=w, allow_outside_limits=True)
    limit = pq.read_table(tmp_path / "c.parquet").column("limit_joint").to_pylist()
    assert limit == [None if j < 0 else int(j) + 1 for j in comp.limit_joint]


def test_a_bad_parquet_pose_names_its_column_and_row(model_dir, tmp_path):
    cols = read_csv_columns(model_dir / "c.csv")
    q = np.array([[float(v) for v in cols[f"q{j}"]] for j in range(1, 8)]).T
    q[4, 2] = np.nan
    write_columns(tmp_path / "bad.parquet", [f"q{j}" for j in range(1, 8)], [q[:, j] for j in range(7)])
    for verb, model, out in (("predict", "m.json", "p.parquet"), ("compensate", "t.json", "c.parquet")):
        proc = run_cli([verb, "vjm", str(model_dir / model), "bad.parquet", "--payload", "2", "--out", out],
                       cwd=tmp_path)
        assert proc.returncode == 1, (verb, proc.stdout, proc.stderr)
        assert "bad.parquet" in proc.stderr and "'q3'" in proc.stderr and "row 4" in proc.stderr, proc.stderr
        assert not (tmp_path / out).exists()
    write_columns(tmp_path / "short.parquet", [f"q{j}" for j in range(1, 7)], [q[:, j] for j in range(6)])
    proc = run_cli(["predict", "vjm", str(model_dir / "m.json"), "short.parquet", "--payload", "2", "--out", "p.pq"],
                   cwd=tmp_path)
    assert proc.returncode == 1 and "missing column 'q7'" in proc.stderr, proc.stderr
