#!/usr/bin/env python3
"""Two builds of the package running the same CLI command alternately: the A/B comparison for a
machine whose speed drifts by ±20 % within minutes (issue 25's figures of 2026-12-07).

The baseline is a package installed into a directory of its own, e.g. from a worktree of the
older commit::

    git worktree add /tmp/old <commit>
    (cd /tmp/old && CARGO_TARGET_DIR=/tmp/old/target pip install --no-deps --target /tmp/oldwheel ./crates/py-bindings)
    python benches/cli_ab.py --baseline /tmp/oldwheel --repeat 4 -- \\
        predict vjm MODEL.json POSES.csv --out /tmp/ab/PRED.csv

Each round runs the baseline (``PYTHONPATH`` set to it), then the installed package, in fresh
interpreters; the file after ``--out`` (or ``--json``) is removed before each run (it must not
exist before the first: the command refuses to overwrite). Prints the wall time of every run and the median per
build, and checks that both builds wrote the same bytes.
"""
from __future__ import annotations

import argparse
import hashlib
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Dict, List

LAUNCHER = "import sys; from robot_stiffness.cli import main; sys.exit(main(sys.argv[1:]))"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--baseline", required=True, help="directory holding the baseline robot_stiffness package")
    parser.add_argument("--repeat", type=int, default=4, help="rounds (each runs both builds once)")
    parser.add_argument("command", nargs=argparse.REMAINDER, help="-- then the CLI arguments")
    args = parser.parse_args()
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    # The command's output file: `--out` (predict, compensate) or `--json` (identify, diagnose).
    flag = next((f for f in ("--out", "--json") if f in command), None)
    if flag is None or command.index(flag) + 1 >= len(command):
        parser.error("the command needs --out FILE or --json FILE (removed before each run)")
    out = Path(command[command.index(flag) + 1])
    if out.exists():
        parser.error(f"{out} exists: give an {flag} file this script may remove")
    times: Dict[str, List[float]] = {"baseline": [], "installed": []}
    digests: Dict[str, str] = {}
    for _ in range(max(args.repeat, 1)):
        for build in times:
            env = dict(os.environ)
            env.pop("PYTHONPATH", None)
            if build == "baseline":
                env["PYTHONPATH"] = args.baseline
            t0 = time.perf_counter()
            proc = subprocess.run([sys.executable, "-c", LAUNCHER, *command], env=env,
                                  stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            wall = time.perf_counter() - t0
            if proc.returncode != 0:
                raise SystemExit(f"{build}: exit status {proc.returncode}: {proc.stderr.strip()}")
            digests[build] = hashlib.sha256(out.read_bytes()).hexdigest()
            out.unlink()
            times[build].append(wall)
            print(f"{build:9s} {wall:.3f} s", flush=True)
    for build, t in times.items():
        print(f"median {build}: {statistics.median(t):.3f} s over {len(t)} runs")
    same = digests["baseline"] == digests["installed"]
    print("outputs: " + ("the same bytes" if same else "DIFFERENT"))
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
