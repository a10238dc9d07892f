#!/usr/bin/env python3
"""The CLI ``predict vjm`` of a campaign-size pose table, next to the identification (issue 25:
CLI ``predict`` ≤ 25× the in-memory ``identify`` of the same rows, ≤ 600 MB peak memory).

The seeded campaign of ``benches/table_io.py`` (1e6 rows by default, 7 joints, with ``dx..dz``,
``pose``, ``set``: a measurement file is a valid pose table) is written as CSV; a model is
identified from it in memory (weightless, the reference of every ratio, median of ``--repeat``)
and saved. Then, each in a fresh interpreter, median of ``--repeat`` runs:

* ``robot-stiffness predict vjm MODEL.json POSES.csv --out PRED.csv`` (default: the sag columns
  too, under standard gravity: the model records none) into a new PRED.csv (the previous run's
  is removed before each run, untimed); the same with ``--force`` over the previous run's file
  (the file system's cost of replacing 0.5 GB comes on top); and with ``--no-gravity``;
* with ``--parquet``, the same from a Parquet POSES file to a Parquet PRED file.

Peak memory is the child's own high-water mark, ``VmHWM`` of ``/proc/self/status`` read as it
exits (a launcher runs the CLI module and writes it to a file), the largest of the runs, in MB
(10⁶ bytes, the target's unit; figures before 2026-12-07 were MiB labelled MB, 4.9 % less).
Not ``ru_maxrss`` from ``os.wait4``: Linux carries the pre-``exec`` address space's high-water
mark into it, and a child forked (or vforked) from this process, which holds the campaign,
reported this process's size (837 MiB for a CLI run that peaks at 594 MiB). Then the
phases the command runs are timed one by one in this process (reading the table, ``predict``,
``predict_sag``, writing PRED.csv), to say where the time goes. A markdown table goes to stdout.

Usage (from the workspace root, with the release extension importable, e.g. after
``bash /work/notes/dev_ext.sh`` and ``PYTHONPATH=crates/py-bindings/python``):
    python benches/cli_predict.py                  # 1e6 rows, 3 runs each
    python benches/cli_predict.py --rows 100000 --repeat 1 --parquet
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
from typing import Callable, Dict, List, Optional, Sequence, Tuple

sys.path.insert(0, str(Path(__file__).resolve().parent))
from table_io import campaign, median_time  # noqa: E402  (the same seeded generator)

from robot_stiffness import _core  # noqa: E402
from robot_stiffness.model import StiffnessModel  # noqa: E402
from robot_stiffness.vjm import Robot  # noqa: E402


# Runs the CLI's main with the arguments after `-c CODE`, then writes the process's peak
# resident memory (KiB, its own address space since exec) to $CLI_PREDICT_PEAK_FILE.
LAUNCHER = """
import atexit, os, sys
def _peak():
    with open('/proc/self/status') as f:
        kib = next(int(line.split()[1]) for line in f if line.startswith('VmHWM:'))
    with open(os.environ['CLI_PREDICT_PEAK_FILE'], 'w') as out:
        out.write(str(kib))
atexit.register(_peak)
from robot_stiffness.cli import main
sys.exit(main(sys.argv[1:]))
"""


def run_child(argv: List[str]) -> Tuple[float, float]:
    """Wall time (s) and peak resident memory (MB, 10⁶ bytes) of one CLI command (its arguments), run to
    completion in a fresh interpreter."""
    with tempfile.TemporaryDirectory(prefix="cli-peak-") as tmp:
        peak_file = Path(tmp) / "peak"
        env = dict(os.environ, CLI_PREDICT_PEAK_FILE=str(peak_file))
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-c", LAUNCHER, *argv], stdout=subprocess.DEVNULL, env=env)
        wall = time.perf_counter() - t0
        if proc.returncode != 0:
            raise SystemExit(f"robot-stiffness {' '.join(argv)} failed with exit status {proc.returncode}")
        return wall, int(peak_file.read_text()) * 1024 / 1e6


def median_child(repeat: int, argv: List[str], fresh: Optional[Path] = None,
                 scratch: Optional[Path] = None) -> Tuple[float, float]:
    """Median wall time and largest peak of ``repeat`` runs; with ``fresh``, that output file is
    removed before each run (untimed), so that the command writes a new file rather than
    replacing the previous run's. ``fresh`` must lie directly in ``scratch``, the bench's own
    temporary directory: nothing else is ever removed."""
    if fresh is not None and (scratch is None or fresh.resolve().parent != scratch.resolve()):
        raise ValueError(f"{fresh} is not in the bench's temporary directory {scratch}: not removing it")
    runs = []
    for _ in range(repeat):
        if fresh is not None:
            fresh.unlink(missing_ok=True)
        runs.append(run_child(argv))
    return statistics.median(t for t, _ in runs), max(m for _, m in runs)


def phases(robot: Robot, model_path: Path, poses: Path, out: Path, repeat: int) -> Dict[str, float]:
    """The steps of ``cmd_predict_vjm``, timed one by one (median of ``repeat``)."""
    from robot_stiffness import _use_tables

    model = StiffnessModel.load(model_path, robot)
    times: Dict[str, float] = {}
    times["read POSES.csv (`_core.vjm_read_poses`)"] = median_time(
        repeat, lambda: _core.vjm_read_poses(str(poses), robot._inner))
    q, wrench, _ = _core.vjm_read_poses(str(poses), robot._inner)
    times["`StiffnessModel.predict`"] = median_time(repeat, lambda: model.predict(q, wrench=wrench))
    pred = model.predict(q, wrench=wrench)
    times["`StiffnessModel.predict_sag`"] = median_time(repeat, lambda: model.predict_sag(q))
    sag = model.predict_sag(q)
    write: Callable[[], object] = lambda: _use_tables.write_predictions(out, out, q, pred, sag)  # noqa: E731
    times["write PRED.csv (`_use_tables.write_predictions`, the core's writer)"] = median_time(repeat, write)
    return times


def main(argv: Optional[Sequence[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rows", type=int, default=1_000_000, help="rows of the campaign (default 1e6)")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs of each step; the median is reported")
    ap.add_argument("--parquet", action="store_true", help="also Parquet in and out (needs pyarrow)")
    ap.add_argument("--no-phases", action="store_true", help="skip the in-process timing of the phases")
    args = ap.parse_args(argv)

    robot = Robot.bundled()
    data = campaign(robot, args.rows)
    with tempfile.TemporaryDirectory(prefix="cli-predict-") as tmp:
        work = Path(tmp)
        poses = work / "campaign.csv"
        poses.write_text(data.to_csv_text())
        size = poses.stat().st_size
        robot.identify(data.q[:1000], data.wrench[:1000], data.displacement[:1000], gravity=None)  # warm-up
        t_identify = median_time(
            args.repeat, lambda: robot.identify(data.q, data.wrench, data.displacement, gravity=None))
        model_path = work / "model.json"
        robot.identify(data.q, data.wrench, data.displacement, gravity=None).save(model_path)

        cli = ["predict", "vjm", str(model_path)]
        runs: List[Tuple[str, float, float]] = []
        pred = work / "pred.csv"
        t, mem = median_child(args.repeat, cli + [str(poses), "--out", str(pred)], fresh=pred, scratch=work)
        runs.append(("CLI `predict vjm MODEL.json POSES.csv --out PRED.csv` (with the sag), a new PRED.csv", t, mem))
        t, mem = median_child(args.repeat, cli + [str(poses), "--out", str(pred), "--force"])
        runs.append(("  the same with `--force` over the previous run's PRED.csv", t, mem))
        t, mem = median_child(args.repeat, cli + [str(poses), "--out", str(pred), "--no-gravity"], fresh=pred, scratch=work)
        runs.append(("  the same with `--no-gravity` (no sag columns), a new PRED.csv", t, mem))
        if args.parquet:
            from robot_stiffness._columnar import write_columns

            names = [f"q{j + 1}" for j in range(robot.n_joints)] + ["fx", "fy", "fz", "mx", "my", "mz"]
            cols = [data.q[:, j] for j in range(robot.n_joints)] + [data.wrench[:, k] for k in range(6)]
            pq_poses = work / "poses.parquet"
            write_columns(pq_poses, names, cols)
            pred_pq = work / "pred.parquet"
            t, mem = median_child(args.repeat, cli + [str(pq_poses), "--out", str(pred_pq)], fresh=pred_pq, scratch=work)
            runs.append(("CLI `predict vjm MODEL.json POSES.parquet --out PRED.parquet` (with the sag)", t, mem))
        t_start = median_time(
            args.repeat, lambda: subprocess.run([sys.executable, "-c", "import robot_stiffness.cli"], check=True))
        steps = {} if args.no_phases else phases(robot, model_path, poses, work / "pred-phases.csv", args.repeat)

    print(f"robot_stiffness {_core.__version__}; {args.rows:,} rows × {robot.n_joints} joints "
          f"(+ dx..dz, pose, set), {size / 1e6:.0f} MB of CSV; weightless model; median of {args.repeat} runs; "
          f"{os.cpu_count()} cores\n")
    print("| step | time | ratio to in-memory identify | peak memory |")
    print("| --- | ---: | ---: | ---: |")
    print(f"| in-memory `Robot.identify` (weightless) | {t_identify * 1e3:,.0f} ms | 1.0× | |")
    for name, t, mem in runs:
        print(f"| {name} | {t * 1e3:,.0f} ms | {t / t_identify:.1f}× | {mem:,.0f} MB |")
    print(f"| interpreter start-up + `import robot_stiffness.cli` | {t_start * 1e3:,.0f} ms | "
          f"{t_start / t_identify:.1f}× | |")
    for name, t in steps.items():
        print(f"| phase: {name} | {t * 1e3:,.0f} ms | {t / t_identify:.1f}× | |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
