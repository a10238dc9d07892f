"""Shared fixtures of the pytest suite. Every random draw is seeded."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import Iterator, List, Sequence

import numpy as np
import pytest

from robot_stiffness.vjm import Robot

DATA = Path(__file__).parent / "data"


@pytest.fixture(scope="session", autouse=True)
def manifest_key_dir(tmp_path_factory) -> Iterator[Path]:
    """The state folder of the output manifests' signing key (robot_stiffness._outputs): one per
    test session, shared with the CLI subprocesses (run_cli passes the environment on), so the
    suite never writes into the user's ~/.local/state."""
    d = tmp_path_factory.mktemp("state")
    old = os.environ.get("ROBOT_STIFFNESS_STATE_DIR")
    os.environ["ROBOT_STIFFNESS_STATE_DIR"] = str(d)
    yield d
    if old is None:
        os.environ.pop("ROBOT_STIFFNESS_STATE_DIR", None)
    else:
        os.environ["ROBOT_STIFFNESS_STATE_DIR"] = old


@pytest.fixture(scope="session")
def panda() -> Robot:
    return Robot.bundled()


@pytest.fixture()
def rng() -> np.random.Generator:
    return np.random.default_rng(20261122)


def random_q(robot: Robot, rng: np.random.Generator, n: int) -> np.ndarray:
    """Joint angles inside the limits (10 % margin), rad."""
    lo = np.array([lower for lower, _ in robot.limits])
    hi = np.array([u for _, u in robot.limits])
    return lo + (hi - lo) * (0.1 + 0.8 * rng.random((n, robot.n_joints)))


def random_wrench(rng: np.random.Generator, n: int) -> np.ndarray:
    """Forces up to ~60 N and moments up to ~3 N·m, base frame."""
    return rng.normal(size=(n, 6)) * np.array([30, 30, 30, 1.5, 1.5, 1.5])


def run_cli(args: Sequence[str], cwd: Path) -> subprocess.CompletedProcess:
    """Runs the console script's module in a subprocess (same interpreter)."""
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    return subprocess.run(
        [sys.executable, "-m", "robot_stiffness.cli", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )


def listing(path: Path) -> List[str]:
    """Every file and directory under ``path`` (hidden ones included), relative."""
    return sorted(str(p.relative_to(path)) for p in path.rglob("*"))
