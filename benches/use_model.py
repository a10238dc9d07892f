#!/usr/bin/env python3
"""Using a model on campaign-size arrays in Python, next to the identification (issue 25:
``StiffnessModel.predict`` of 1e6 rows ≤ 5×, ``compensate`` of 1e5 rows ≤ 4× the in-memory
``identify`` of the same 1e6 rows, in the same run).

The seeded campaign of ``benches/table_io.py`` (1e6 rows by default) is identified in memory
(weightless, the reference of every ratio) and the model is used on its rows: ``predict`` with
the wrenches (deflection and standard deviations), ``predict_sag`` (the exact static
equilibrium under the arm's weight), and ``compensate`` of the first ``--compensate-rows`` rows
both weightless-load only (``load_only=True``) and with the sag corrected (the default). Every
timing is the median of ``--repeat`` runs; a markdown table goes to stdout.

Usage (from the workspace root, with the release extension installed):
    python benches/use_model.py                     # 1e6 rows, compensate 1e5, 3 runs each
    python benches/use_model.py --rows 100000 --compensate-rows 10000 --repeat 1
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import List, Optional, Sequence, Tuple

sys.path.insert(0, str(Path(__file__).resolve().parent))
from table_io import campaign, median_time  # noqa: E402  (the same seeded generator)

from robot_stiffness import _core  # noqa: E402
from robot_stiffness.vjm import Robot  # noqa: E402


def main(argv: Optional[Sequence[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rows", type=int, default=1_000_000, help="rows of the campaign (default 1e6)")
    ap.add_argument("--compensate-rows", type=int, default=100_000, help="rows compensated (default 1e5)")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs of each step; the median is reported")
    args = ap.parse_args(argv)

    robot = Robot.bundled()
    data = campaign(robot, args.rows)
    q, w = data.q, data.wrench
    robot.identify(q[:1000], w[:1000], data.displacement[:1000], gravity=None)  # warm-up
    t_identify = median_time(args.repeat, lambda: robot.identify(q, w, data.displacement, gravity=None))
    model = robot.identify(q, w, data.displacement, gravity=None).stiffness_model
    k = args.compensate_rows
    steps: List[Tuple[str, float, str]] = [
        (f"`StiffnessModel.predict(q, wrench=…)`, {args.rows:,} rows",
         median_time(args.repeat, lambda: model.predict(q, wrench=w)), "≤ 5×"),
        (f"`StiffnessModel.predict_sag(q)`, {args.rows:,} rows",
         median_time(args.repeat, lambda: model.predict_sag(q)), ""),
        (f"`StiffnessModel.compensate(q, wrench=…, load_only=True)`, {k:,} rows",
         median_time(args.repeat, lambda: model.compensate(q[:k], wrench=w[:k], load_only=True)), "≤ 4×"),
        (f"`StiffnessModel.compensate(q, wrench=…)` with the sag, {k:,} rows",
         median_time(args.repeat, lambda: model.compensate(q[:k], wrench=w[:k])), ""),
    ]
    print(f"robot_stiffness {_core.__version__}; {args.rows:,} rows × {robot.n_joints} joints; "
          f"{len(model.labels)} springs, weightless identification; median of {args.repeat} runs; "
          f"{os.cpu_count()} cores\n")
    print("| step | time | ratio to in-memory identify | target |")
    print("| --- | ---: | ---: | ---: |")
    print(f"| in-memory `Robot.identify` (weightless), {args.rows:,} rows | {t_identify * 1e3:,.0f} ms | 1.0× | |")
    for name, t, target in steps:
        print(f"| {name} | {t * 1e3:,.0f} ms | {t / t_identify:.1f}× | {target} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
