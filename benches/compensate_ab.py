#!/usr/bin/env python3
"""``StiffnessModel.compensate`` of two builds, run alternately (issue 25's ``compensate`` ≤ 4×).

This machine's run-to-run noise (±20 %) is larger than most single changes, so a before/after
comparison alternates the two builds: ``--baseline DIR`` is a directory holding an installed
``robot_stiffness`` package (e.g. ``pip install --target DIR --no-deps ./crates/py-bindings`` at
the older commit); the other build is the one this interpreter imports. Each run is a fresh
interpreter that builds the seeded campaign of ``benches/table_io.py``, identifies the weightless
7-spring model and times ``compensate(q, wrench=…, load_only=True)`` of the first ``--rows`` rows
(best of 3). The script prints both medians and how far apart the two builds' corrected targets
and reports are (same iterations, targets to rounding).

Usage:
    python benches/compensate_ab.py --baseline /tmp/basewheel --repeat 4
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Dict, List, Optional, Sequence

import numpy as np

CHILD = r"""
import sys, time
import numpy as np
sys.path.insert(0, sys.argv[3])
from table_io import campaign
from robot_stiffness.vjm import Robot
robot = Robot.bundled()
k = int(sys.argv[2])
data = campaign(robot, k)
model = robot.identify(data.q, data.wrench, data.displacement, gravity=None).stiffness_model
times = []
for _ in range(3):
    t = time.perf_counter()
    r = model.compensate(data.q, wrench=data.wrench, load_only=True)
    times.append(time.perf_counter() - t)
np.savez(sys.argv[1], q=np.asarray(r.q), iterations=np.asarray(r.iterations),
         position_error=np.asarray(r.position_error), inverse_condition=np.asarray(r.inverse_condition))
print(min(times))
"""


def main(argv: Optional[Sequence[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--baseline", required=True, type=Path, help="directory with the older robot_stiffness package")
    ap.add_argument("--rows", type=int, default=100_000, help="rows compensated (default 1e5)")
    ap.add_argument("--repeat", type=int, default=4, help="alternating rounds (default 4)")
    args = ap.parse_args(argv)
    if not (args.baseline / "robot_stiffness").is_dir():
        ap.error(f"--baseline {args.baseline}: no robot_stiffness package in it")
    benches = str(Path(__file__).resolve().parent)
    builds = {"baseline": {"PYTHONPATH": str(args.baseline)}, "this build": {}}
    times: Dict[str, List[float]] = {name: [] for name in builds}
    with tempfile.TemporaryDirectory() as tmp:
        outputs = {name: Path(tmp) / f"{i}.npz" for i, name in enumerate(builds)}
        for _ in range(args.repeat):
            for name, env in builds.items():
                run = subprocess.run([sys.executable, "-c", CHILD, str(outputs[name]), str(args.rows), benches],
                                     env={**os.environ, **env}, capture_output=True, text=True, check=True)
                times[name].append(float(run.stdout))
        a, b = (np.load(outputs[name]) for name in builds)
        for name, t in times.items():
            print(f"{name}: median {statistics.median(t) * 1e3:,.0f} ms of {[round(x * 1e3) for x in t]} ms")
        print(f"same iterations: {np.array_equal(a['iterations'], b['iterations'])}; "
              f"targets: largest difference {np.max(np.abs(a['q'] - b['q'])):.2e} rad; "
              f"largest position error {np.max(a['position_error']):.3e} / {np.max(b['position_error']):.3e} m; "
              f"inverse condition: largest relative difference "
              f"{np.max(np.abs(a['inverse_condition'] / b['inverse_condition'] - 1)):.1e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
