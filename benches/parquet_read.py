#!/usr/bin/env python3
"""Reading a campaign-size VJM measurement table from Parquet and Arrow IPC against the same rows
as CSV (issue 25, target: Parquet ≥ 5× faster than CSV).

The seeded campaign of ``benches/table_io.py`` (1e6 rows by default, 7 joints, ``pose`` and ``set``
columns) is written once as CSV (``Measurements.to_csv_text``) and as Parquet and Arrow IPC
(``robot_stiffness._columnar.write_columns``: pyarrow's defaults, snappy-compressed Parquet,
uncompressed Arrow). ``vjm.read_measurements`` is timed on each (median of ``--repeat`` runs),
checked to give the same arrays, and compared with the in-memory ``Robot.identify`` of the same
rows (weightless fit). A markdown table goes to stdout.

Usage (from the workspace root, with the extension importable, e.g. after
``bash /work/notes/dev_ext.sh`` and ``PYTHONPATH=crates/py-bindings/python``; needs pyarrow):
    python benches/parquet_read.py                 # 1e6 rows, 3 runs each
    python benches/parquet_read.py --rows 100000 --repeat 1
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path
from typing import Any, Dict, Optional, Sequence

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from table_io import campaign, median_time  # noqa: E402  (the same seeded generator)

from robot_stiffness import _core  # noqa: E402
from robot_stiffness._columnar import write_columns  # noqa: E402
from robot_stiffness.vjm import Measurements, Robot, read_measurements  # noqa: E402


def file_columns(m: Measurements) -> Dict[str, Any]:
    cols: Dict[str, Any] = {f"q{j + 1}": m.q[:, j] for j in range(m.q.shape[1])}
    cols.update({n: m.wrench[:, k] for k, n in enumerate(["fx", "fy", "fz", "mx", "my", "mz"])})
    cols.update({n: m.displacement[:, k] for k, n in enumerate(["dx", "dy", "dz"])})
    cols["pose"] = np.asarray(m.pose, dtype=np.int64)
    cols["set"] = np.asarray(m.set, dtype=object)
    return cols


def main(argv: Optional[Sequence[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rows", type=int, default=1_000_000, help="rows of the campaign (default 1e6)")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs of each step; the median is reported")
    args = ap.parse_args(argv)

    robot = Robot.bundled()
    data = campaign(robot, args.rows)
    with tempfile.TemporaryDirectory(prefix="parquet-read-") as tmp:
        paths = {"CSV": Path(tmp) / "campaign.csv", "Parquet": Path(tmp) / "campaign.parquet",
                 "Arrow IPC": Path(tmp) / "campaign.arrow"}
        paths["CSV"].write_text(data.to_csv_text())
        cols = file_columns(data)
        write_columns(paths["Parquet"], list(cols), list(cols.values()))
        write_columns(paths["Arrow IPC"], list(cols), list(cols.values()))
        times: Dict[str, float] = {}
        sizes: Dict[str, int] = {}
        for name, path in paths.items():
            sizes[name] = path.stat().st_size
            got = read_measurements(path, robot.n_joints)
            assert np.array_equal(got.q, data.q) and np.array_equal(got.displacement, data.displacement), name
            assert got.set == data.set and np.array_equal(np.asarray(got.pose), np.asarray(data.pose)), name
            del got
            times[name] = median_time(args.repeat, lambda p=path: read_measurements(p, robot.n_joints))
        robot.identify(data.q[:1000], data.wrench[:1000], data.displacement[:1000], gravity=None)  # warm-up
        t_identify = median_time(
            args.repeat, lambda: robot.identify(data.q, data.wrench, data.displacement, gravity=None)
        )

    import pyarrow

    print(f"robot_stiffness {_core.__version__}, pyarrow {pyarrow.__version__}; {args.rows:,} rows × "
          f"{robot.n_joints} joints (+ pose, set); median of {args.repeat} runs; {os.cpu_count()} cores\n")
    print("| `vjm.read_measurements` of | size | time | CSV time / this | ratio to in-memory identify |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for name, t in times.items():
        print(f"| {name} | {sizes[name] / 1e6:.0f} MB | {t * 1e3:,.0f} ms | {times['CSV'] / t:.1f}× | "
              f"{t / t_identify:.1f}× |")
    print(f"| (in-memory `Robot.identify`, weightless) | | {t_identify * 1e3:,.0f} ms | | 1.0× |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
