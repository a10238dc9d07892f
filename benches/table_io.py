#!/usr/bin/env python3
"""Reading and writing a campaign-size VJM measurement table, next to the identification (issue 25).

Builds a seeded 7-joint campaign of N rows (default 1e6) on the bundled Panda with numpy
(joint angles inside the limits, random wrenches, displacements from the library's forward model
plus 10 µm noise, a ``pose`` and a ``set`` column), writes it with the library's writer
(``Measurements.to_csv_text``, timed), and times, in the same run:

* ``_core.vjm_read_csv`` (the Rust reader behind ``vjm.read_measurements`` and the CLI);
* the in-memory ``Robot.identify`` of the same rows (the reference of every ratio);
* the CLI ``robot-stiffness identify vjm FILE.csv`` end to end (a fresh interpreter: start-up,
  reading, identification, output), the same model and gravity setting as the in-memory run.

Every timing is the median of ``--repeat`` rounds; in a round every step runs once, in turn,
so that the ratios are taken under the same machine load. By default the fit is the weightless one
(``gravity=None``, CLI ``--no-gravity``), so that the ratios show the cost of the file; pass
``--gravity`` for the default gravity model on both sides. A markdown table goes to stdout.

Usage (from the workspace root, with the release extension importable, e.g. after
``bash /work/notes/dev_ext.sh`` and ``PYTHONPATH=crates/py-bindings/python``):
    python benches/table_io.py                 # 1e6 rows, 3 runs each
    python benches/table_io.py --rows 100000 --repeat 1
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable, List, Optional, Sequence

import numpy as np

from robot_stiffness import _core
from robot_stiffness.vjm import Measurements, Robot

SEED = 20261203
COMPLIANCE = np.array([1.0e-4, 1.0e-4, 1.5e-4, 1.5e-4, 3.0e-4, 4.0e-4, 5.0e-4])  # rad/(N·m)
LOADS_PER_POSE = 10


def campaign(robot: Robot, n: int) -> Measurements:
    """Seeded rows: poses inside the limits (LOADS_PER_POSE loads each), wrenches, noisy displacements."""
    rng = np.random.default_rng(SEED)
    lo = np.array([lower for lower, _ in robot.limits])
    hi = np.array([upper for _, upper in robot.limits])
    poses = -(-n // LOADS_PER_POSE)
    q = np.repeat(lo + (hi - lo) * (0.1 + 0.8 * rng.random((poses, robot.n_joints))), LOADS_PER_POSE, axis=0)[:n]
    w = rng.normal(size=(n, 6)) * np.array([30, 30, 30, 1.5, 1.5, 1.5])
    d = robot.predict_deflection(COMPLIANCE, q, w)[:, :3] + 1e-5 * rng.normal(size=(n, 3))
    pose = np.arange(n, dtype=np.int64) // LOADS_PER_POSE
    sets = ["test" if p % 4 == 0 else "train" for p in pose.tolist()]
    return Measurements(q=q, wrench=w, displacement=d, pose=pose, set=sets)


def median_times(repeat: int, steps: Sequence[Callable[[], object]]) -> List[float]:
    """The median time of each step over ``repeat`` rounds; in a round each step runs once, in order."""
    times: List[List[float]] = [[] for _ in steps]
    for _ in range(repeat):
        for f, ts in zip(steps, times):
            t0 = time.perf_counter()
            f()
            ts.append(time.perf_counter() - t0)
    return [statistics.median(ts) for ts in times]


def median_time(repeat: int, f: Callable[[], object]) -> float:
    """The median time of ``repeat`` runs of ``f``."""
    return median_times(repeat, [f])[0]


def main(argv: Optional[Sequence[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rows", type=int, default=1_000_000, help="rows of the campaign (default 1e6)")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs of each step; the median is reported")
    ap.add_argument("--gravity", action="store_true", help="fit under the default gravity on both sides")
    args = ap.parse_args(argv)

    robot = Robot.bundled()
    gravity_kw = {} if args.gravity else {"gravity": None}
    data = campaign(robot, args.rows)
    with tempfile.TemporaryDirectory(prefix="table-io-") as tmp:
        path = Path(tmp) / "campaign.csv"
        text = ""

        def write() -> None:
            nonlocal text
            text = data.to_csv_text()

        write()
        path.write_text(text)
        size = path.stat().st_size
        del text
        read = _core.vjm_read_csv(str(path), robot.n_joints)
        assert np.array_equal(read.q, data.q) and np.array_equal(read.displacement, data.displacement)
        del read
        robot.identify(data.q[:1000], data.wrench[:1000], data.displacement[:1000], **gravity_kw)  # warm-up
        cli = [sys.executable, "-m", "robot_stiffness.cli", "identify", "vjm", str(path), "--json",
               str(Path(tmp) / "id.json"), "--force"]
        if not args.gravity:
            cli.append("--no-gravity")
        steps: List[Callable[[], object]] = [
            write,
            lambda: _core.vjm_read_csv(str(path), robot.n_joints),
            lambda: robot.identify(data.q, data.wrench, data.displacement, **gravity_kw),
            lambda: subprocess.run(cli, check=True, stdout=subprocess.DEVNULL, env=os.environ.copy()),
            lambda: subprocess.run([sys.executable, "-c", "import robot_stiffness.cli"], check=True),
        ]
        # The steps take turns, one run each per round, so that a machine that slows down or
        # speeds up during the run moves every step's median alike and the ratios hold.
        t_write, t_read, t_identify, t_cli, t_start = median_times(args.repeat, steps)

    fit = "under gravity" if args.gravity else "weightless"
    print(f"robot_stiffness {_core.__version__}; {args.rows:,} rows × {robot.n_joints} joints "
          f"(+ pose, set), {size / 1e6:.0f} MB of CSV; {fit} fit; median of {args.repeat} rounds; "
          f"{os.cpu_count()} cores\n")
    print("| step | time | ratio to in-memory identify |")
    print("| --- | ---: | ---: |")
    rows = [
        ("write the CSV (`Measurements.to_csv_text`)", t_write),
        ("read the CSV (`_core.vjm_read_csv`)", t_read),
        ("in-memory `Robot.identify`", t_identify),
        ("CLI `identify vjm FILE.csv` end to end", t_cli),
        ("  of which interpreter start-up + `import robot_stiffness.cli`", t_start),
    ]
    for name, t in rows:
        print(f"| {name} | {t * 1e3:,.0f} ms | {t / t_identify:.1f}× |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
