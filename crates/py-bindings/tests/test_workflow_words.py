"""The same words everywhere (issue 24, item 5): the help and docs/python.md show every command
of the workflow (plan → measure → identify → use); every effect the core's testbed accepts is
listed where effects are listed; the report's plots are counted right; the extras are spelled
as the package declares them; errors about arrays count rows from 0 as Python does (the command
line keeps the file's lines); the Python API's errors name Python arguments and the command
line's name its flags; ``identify vjm --quiet`` prints nothing but errors."""

from __future__ import annotations

import json
import re
import warnings
from pathlib import Path
from typing import Any, Callable, Dict, List

import numpy as np
import pytest

import robot_stiffness as rs
from conftest import listing, run_cli
from robot_stiffness import cli, vjm
from robot_stiffness.model import StiffnessModel
from robot_stiffness.report import CSJM_REPORT_FILES, REPORT_FILES
from test_vjm import PLANAR_2R

ROOT = Path(__file__).resolve().parents[3]
DOCS = ROOT / "docs"
PYTHON_MD = DOCS / "python.md"


def _commands() -> List[str]:
    """Every ``COMMAND [KIND]`` of the parser, e.g. ``identify vjm``, ``demo``."""
    import argparse

    def subparsers(p: argparse.ArgumentParser) -> Dict[str, argparse.ArgumentParser]:
        for action in p._actions:
            if isinstance(action, argparse._SubParsersAction):
                return dict(action.choices)
        return {}

    out = []
    for name, sub in subparsers(cli.build_parser()).items():
        kinds = subparsers(sub)
        out += [f"{name} {kind}" for kind in kinds] if kinds else [name]
    return out


def test_the_help_examples_show_every_command(tmp_path):
    commands = _commands()
    assert {"design vjm", "predict vjm", "compensate vjm", "identify vjm", "demo"} <= set(commands)
    proc = run_cli(["--help"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    examples = proc.stdout[proc.stdout.index("Examples"):]
    missing = [c for c in commands if f"robot-stiffness {c}" not in examples]
    assert not missing, f"the --help examples omit {missing}"
    # The examples use the current spelling: no positional output of simulate.
    assert not re.search(r"simulate (vjm|csjm) \w+\.csv", examples), examples


def test_python_md_shows_design_predict_and_compensate():
    text = PYTHON_MD.read_text(encoding="utf-8")
    for needle in ("vjm.design(", "model.predict(", "model.compensate(", "vjm.compensate(",
                   "design vjm", "predict vjm", "compensate vjm"):
        assert needle in text, needle


def _core_effects(panda) -> List[str]:
    """The effect names the core accepts, from its own error message (``vjm_data.rs``)."""
    with pytest.raises(rs.InvalidValueError) as e:
        vjm.simulate(panda, [{"effect": "no_such_effect"}], n_poses=2)
    m = re.search(r"unknown effect `no_such_effect` \(([^)]*)\)", str(e.value))
    assert m, str(e.value)
    names = [n.strip() for n in m.group(1).split(",")]
    assert len(names) >= 12 and "mount_compliance" in names, names
    return names


def test_every_effect_the_core_accepts_is_in_the_simulate_help_and_the_docs(panda, tmp_path):
    names = _core_effects(panda)
    proc = run_cli(["simulate", "vjm", "--help"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert [n for n in names if not re.search(rf"\b{n}\b", proc.stdout)] == []
    python_md = PYTHON_MD.read_text(encoding="utf-8")
    assert [n for n in names if f"`{n}" not in python_md] == []
    docstring = vjm.simulate.__doc__ or ""
    assert [n for n in names if f'"{n}"' not in docstring] == []


def test_the_report_plots_are_counted_right():
    assert len(REPORT_FILES) - 1 == 4 and len(CSJM_REPORT_FILES) - 1 == 2
    for path in [ROOT / "README.md", *DOCS.glob("*.md")]:
        text = path.read_text(encoding="utf-8")
        assert not re.search(r"\b(three|3) (PNG )?plots\b", text, re.IGNORECASE), path
    python_md = PYTHON_MD.read_text(encoding="utf-8")
    assert "four PNG plots" in python_md
    assert all(f"`{name}`" in python_md for name in REPORT_FILES if name.endswith(".png"))


def test_the_extras_are_spelled_as_the_package_declares_them():
    pyproject = (ROOT / "crates" / "py-bindings" / "pyproject.toml").read_text(encoding="utf-8")
    assert re.search(r"^name = \"robot-stiffness\"$", pyproject, re.MULTILINE)
    assert re.search(r"^dask = ", pyproject, re.MULTILINE) and re.search(r"^parquet = ", pyproject, re.MULTILINE)
    for path in [ROOT / "README.md", *DOCS.glob("*.md")]:
        text = path.read_text(encoding="utf-8")
        for m in re.finditer(r"(\S*)\[(dask|parquet)\]", text):
            assert m.group(1).endswith(("robot-stiffness", "./crates/py-bindings")), (path, m.group(0))


def test_verdict_remaining_is_documented_as_it_is():
    """``remaining`` is words when the diagnosis is ``unexplained`` and None when nothing
    remains: the field's type, its docstring and docs/python.md say so."""
    from robot_stiffness.results import Verdict

    assert "Optional[str]" in str(Verdict.__annotations__["remaining"])
    assert "None" in (Verdict.__doc__ or "")
    python_md = PYTHON_MD.read_text(encoding="utf-8")
    lines = [ln for ln in python_md.splitlines() if "remaining" in ln and "verdict" in ln]
    assert lines and all("None" in ln for ln in lines), lines


# ----------------------------------------------------------------------------- rows, not lines


@pytest.fixture(scope="module")
def fitted(panda):
    m = vjm.simulate(panda, [], n_poses=10, seed=3).measurements
    q, w, d = np.array(m.q), np.array(m.wrench), np.array(m.displacement)
    ident = panda.identify(q, w, d, "traditional")
    return q, w, d, ident


def _bad(a: np.ndarray, row: int, col: int, value: float) -> np.ndarray:
    out = a.copy()
    out[row, col] = value
    return out


def _calls(panda, ident, model_path: str) -> Dict[str, Callable[..., Any]]:
    sm = ident.stiffness_model
    c = np.nan_to_num(ident.compliance)
    return {
        "Robot.identify": lambda q, w, d: panda.identify(q, w, d, "traditional"),
        "Robot.identify_partial": lambda q, w, d: panda.identify_partial(q, w, d, "traditional"),
        "Robot.predict_deflection": lambda q, w, d: panda.predict_deflection(c, q, w, model="traditional"),
        "StiffnessModel.predict": lambda q, w, d: sm.predict(q, wrench=w),
        "StiffnessModel.compensate": lambda q, w, d: sm.compensate(q, wrench=w),
        "vjm.compensate": lambda q, w, d: vjm.compensate(panda, q, c, model="traditional", wrench=w),
        "vjm.compensate_with_model_file": lambda q, w, d: vjm.compensate_with_model_file(
            panda, model_path, q, wrench=w),
    }


def test_errors_about_arrays_name_rows_counted_from_0(panda, fitted, tmp_path):
    q, w, d, ident = fitted
    ident.save(tmp_path / "m.json")
    cases = [
        ("NaN in q", (_bad(q, 5, 1, np.nan), w, d), r"\brow 5\b"),
        ("NaN in the wrench", (q, _bad(w, 5, 2, np.nan), d), r"\brow 5\b"),
        ("outside the limits", (_bad(q, 5, 0, 3.0), w, d), r"row 5 \(counting from 0\), column 'q1'.*outside"),
        ("degrees", (_bad(q, 5, 2, -135.0), w, d), r"row 5 \(counting from 0\), column 'q3'.*degrees"),
        ("kN", (q, _bad(w, 5, 0, 1e9), d), r"row 5 \(counting from 0\), column 'fx'.*plausible"),
    ]
    for name, fn in _calls(panda, ident, str(tmp_path / "m.json")).items():
        for case, args, pattern in cases:
            if name == "Robot.predict_deflection" and case.startswith("NaN"):
                continue  # test_predict_deflection_names_the_row_of_a_nan
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", rs.SuspiciousDataWarning)
                with pytest.raises(rs.StiffnessError) as e:
                    fn(*args)
            msg = str(e.value)
            assert re.search(pattern, msg) and "line" not in msg, (name, case, msg)


def test_predict_deflection_names_the_row_of_a_nan(panda, fitted):
    q, w, _, ident = fitted
    c = np.nan_to_num(ident.compliance)
    with pytest.raises(rs.InvalidValueError, match=r"\brow 5\b"):
        panda.predict_deflection(c, _bad(q, 5, 1, np.nan), w, model="traditional")


def test_the_command_line_keeps_the_lines_of_its_files(panda, fitted, tmp_path):
    q, w, d, _ = fitted
    header = [f"q{j + 1}" for j in range(7)] + ["fx", "fy", "fz", "mx", "my", "mz", "dx", "dy", "dz"]
    rows = np.column_stack([_bad(q, 5, 0, 3.0), w, d])
    (tmp_path / "c.csv").write_text(",".join(header) + "\n" + "\n".join(",".join(repr(float(v)) for v in r)
                                                                       for r in rows) + "\n")
    proc = run_cli(["identify", "vjm", "c.csv"], cwd=tmp_path)
    assert proc.returncode == 1, proc.stderr
    assert "line 7, column 'q1'" in proc.stderr and "counting from 0" not in proc.stderr, proc.stderr
    # ... and advises its own flag, not the Python argument.
    assert "--allow-outside-limits" in proc.stderr and "allow_outside_limits" not in proc.stderr, proc.stderr


# ----------------------------------------------------------------------------- Python words


def test_python_errors_name_python_arguments_and_the_cli_its_flags(panda, fitted, tmp_path):
    q, w, d, ident = fitted
    # Joint angles outside the limits.
    with pytest.raises(rs.DataFileError) as e:
        panda.identify(_bad(q, 5, 0, 3.0), w, d)
    assert "allow_outside_limits=True" in str(e.value) and "--" not in str(e.value), str(e.value)
    # A link without <inertial> under gravity.
    arm = vjm.Robot.from_urdf_string(PLANAR_2R, "base", "tool")
    with pytest.raises(rs.StiffnessError) as e:
        vjm.simulate(arm, [], n_poses=4)
    assert "gravity=None" in str(e.value) and "--no-gravity" not in str(e.value), str(e.value)
    (tmp_path / "arm.urdf").write_text(PLANAR_2R)
    proc = run_cli(["simulate", "vjm", "--out", "s.csv", "--urdf", "arm.urdf", "--base", "base", "--tip", "tool",
                    "--poses", "6"], cwd=tmp_path)
    assert proc.returncode == 1 and "--no-gravity" in proc.stderr and "gravity=None" not in proc.stderr, proc.stderr
    # A model file edited after it was saved.
    path = tmp_path / "m.json"
    ident.save(path)
    doc = json.loads(path.read_text())
    doc["model"]["created_by"] = "edited by hand"
    path.write_text(json.dumps(doc))
    with pytest.raises(rs.ModelFileError) as e:
        StiffnessModel.load(path, panda)
    assert "Identification.save" in str(e.value) and "--save" not in str(e.value), str(e.value)
    header = [f"q{j + 1}" for j in range(7)]
    (tmp_path / "poses.csv").write_text(",".join(header) + "\n" + "\n".join(",".join(repr(float(v)) for v in r)
                                                                          for r in q) + "\n")
    proc = run_cli(["predict", "vjm", "m.json", "poses.csv", "--out", "p.csv", "--payload", "1"], cwd=tmp_path)
    assert proc.returncode == 1 and "--save" in proc.stderr and "Identification.save" not in proc.stderr, proc.stderr


# ----------------------------------------------------------------------------- identify --quiet


def _campaign_csv(path: Path, m: Any, wrench: Any = None) -> None:
    q, w, d = np.asarray(m.q), np.asarray(m.wrench if wrench is None else wrench), np.asarray(m.displacement)
    header = [f"q{j + 1}" for j in range(q.shape[1])] + ["fx", "fy", "fz", "mx", "my", "mz", "dx", "dy", "dz"]
    rows = np.column_stack([q, w, d])
    path.write_text(",".join(header) + "\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in rows) + "\n")


def test_identify_quiet_prints_nothing_but_errors(panda, tmp_path):
    m = vjm.simulate(panda, [], n_poses=15, seed=1, force_max=60.0).measurements
    _campaign_csv(tmp_path / "c.csv", m)
    loud = run_cli(["identify", "vjm", "c.csv"], cwd=tmp_path)
    assert loud.returncode == 0 and "traditional model" in loud.stdout, loud.stderr
    quiet = run_cli(["identify", "vjm", "c.csv", "--quiet", "--json", "id.json", "--save", "m.json"], cwd=tmp_path)
    assert quiet.returncode == 0 and quiet.stdout == "" and quiet.stderr == "", (quiet.stdout, quiet.stderr)
    assert json.loads((tmp_path / "id.json").read_text())["n_params"] == 7 and (tmp_path / "m.json").is_file()
    # A warning (one row at 5e4 N) stays in the JSON, not on the terminal.
    w = np.array(m.wrench)
    w[7, :3] *= 5e4 / np.linalg.norm(w[7, :3])
    _campaign_csv(tmp_path / "o.csv", m, wrench=w)
    loud = run_cli(["identify", "vjm", "o.csv"], cwd=tmp_path)
    assert loud.returncode == 0 and "warning:" in loud.stderr, loud.stderr
    quiet = run_cli(["identify", "vjm", "o.csv", "--quiet", "--json", "o.json"], cwd=tmp_path)
    assert quiet.returncode == 0 and quiet.stdout == "" and quiet.stderr == "", (quiet.stdout, quiet.stderr)
    assert json.loads((tmp_path / "o.json").read_text())["warnings"]
    # An error is still printed, with the same exit status.
    (tmp_path / "bad.csv").write_text("q1,q2\n1,2\n")
    before = listing(tmp_path)
    proc = run_cli(["identify", "vjm", "bad.csv", "--quiet", "--json", "bad.json"], cwd=tmp_path)
    assert proc.returncode == 1 and proc.stdout == "", (proc.stdout, proc.stderr)
    assert proc.stderr.startswith("robot-stiffness: error:") and len(proc.stderr.splitlines()) == 1, proc.stderr
    assert listing(tmp_path) == before
