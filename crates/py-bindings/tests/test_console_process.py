"""The console script's own process: numpy's OpenBLAS gets one thread there (the core's thread
pool takes the cores) unless the user chose; a library import changes nothing; and the
diagnosis classes load only when a command diagnoses."""
from __future__ import annotations

import os
import subprocess
import sys
from typing import Dict, Optional

import pytest

from robot_stiffness import _console_process, results, vjm

BLAS = "OPENBLAS_NUM_THREADS"


def _in_child(code: str, *, argv0: Optional[str], blas: Optional[str]) -> str:
    """Runs ``code`` in a fresh interpreter (``sys.argv[0]`` set to ``argv0`` first, as the
    console script's launcher sets it) and returns its stdout, stripped."""
    env: Dict[str, str] = dict(os.environ)
    env.pop(BLAS, None)
    if blas is not None:
        env[BLAS] = blas
    prologue = "import sys\n" + (f"sys.argv[0] = {argv0!r}\n" if argv0 is not None else "")
    done = subprocess.run([sys.executable, "-c", prologue + code], capture_output=True, text=True, env=env,
                          timeout=120, check=True)
    return done.stdout.strip()


SHOW_BLAS = f"import os, robot_stiffness, numpy\nprint(os.environ.get({BLAS!r}))"


def test_the_console_script_gives_numpys_blas_one_thread() -> None:
    assert _in_child(SHOW_BLAS, argv0="/usr/local/bin/robot-stiffness", blas=None) == "1"


def test_a_users_choice_of_blas_threads_is_kept() -> None:
    assert _in_child(SHOW_BLAS, argv0="/usr/local/bin/robot-stiffness", blas="3") == "3"


def test_a_library_import_leaves_the_environment_alone() -> None:
    assert _in_child(SHOW_BLAS, argv0=None, blas=None) == "None"


@pytest.mark.parametrize(
    "orig_argv, argv0, expected",
    [
        (["python3", "-m", "robot_stiffness.cli", "identify"], "-m", True),
        (["python3", "-m", "robot_stiffness.cli", "identify"], "/site/robot_stiffness/cli.py", True),
        (["python3", "/venv/bin/robot-stiffness", "demo"], "/venv/bin/robot-stiffness", True),
        (["python3", "-m", "pytest"], "-m", False),
        (["python3", "script.py", "-m", "robot_stiffness.cli"], "script.py", False),
        (["python3"], "", False),
    ],
)
def test_the_console_script_is_told_by_how_python_was_started(
    monkeypatch: pytest.MonkeyPatch, orig_argv: list, argv0: str, expected: bool
) -> None:
    monkeypatch.setattr(sys, "orig_argv", orig_argv, raising=False)
    monkeypatch.setattr(sys, "argv", [argv0])
    assert _console_process.launched_as_console_script() is expected


def test_vjm_loads_without_the_diagnosis_classes() -> None:
    code = ("import sys, robot_stiffness.vjm as vjm\nprint('robot_stiffness.results' in sys.modules)\n"
            "import robot_stiffness.results as r\nprint(vjm.Diagnosis is r.Diagnosis)")
    assert _in_child(code, argv0=None, blas=None).split() == ["False", "True"]


def test_vjm_still_names_the_diagnosis_class_and_nothing_else() -> None:
    assert vjm.Diagnosis is results.Diagnosis
    assert "Diagnosis" in vjm.__all__
    with pytest.raises(AttributeError, match="no attribute 'Diagnose'"):
        vjm.Diagnose  # noqa: B018
