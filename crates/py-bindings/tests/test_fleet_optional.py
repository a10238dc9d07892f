"""Dask is optional: the package (robot_stiffness.fleet included) imports without it, and the
fleet functions say how to get it when it is missing."""

from __future__ import annotations

import subprocess
import sys


def run(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)


def test_no_module_imports_dask():
    r = run(
        "import sys\n"
        "import robot_stiffness, robot_stiffness.vjm, robot_stiffness.csjm, robot_stiffness.so3\n"
        "import robot_stiffness.model, robot_stiffness.cli, robot_stiffness.report, robot_stiffness.fleet\n"
        "loaded = sorted(m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed'))\n"
        "print(loaded)\n"
        "assert not loaded\n"
    )
    assert r.returncode == 0, r.stdout + r.stderr


def test_fleet_without_dask_names_the_extra():
    # `None` in sys.modules makes `import distributed` fail as if it were not installed.
    r = run(
        "import sys\n"
        "sys.modules['distributed'] = None\n"
        "from robot_stiffness import fleet\n"
        "from robot_stiffness.vjm import Robot\n"
        "try:\n"
        "    fleet.diagnose_files(Robot.bundled(), ['a.csv'])\n"
        "except ImportError as e:\n"
        "    print(e)\n"
    )
    assert r.returncode == 0, r.stderr
    assert "robot-stiffness[dask]" in r.stdout
