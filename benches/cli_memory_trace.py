#!/usr/bin/env python3
"""Where a CLI command's memory goes: the command runs in this process while a thread samples
the resident set (``VmRSS``) every 10 ms; the reading, predicting and writing functions of the
package are wrapped to print the resident set as each starts and ends, then the peak and the
process's high-water mark (``VmHWM``), in MiB.

Usage (any CLI arguments; the output file must not exist):
    python benches/cli_memory_trace.py predict vjm MODEL.json POSES.parquet --out PRED.parquet
"""
from __future__ import annotations

import sys
import threading
import time
from typing import Any, Callable, List, Tuple

T0 = time.perf_counter()


def status(field: str) -> int:
    """A ``/proc/self/status`` memory field, MiB."""
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) // 1024 for line in f if line.startswith(field + ":"))


def main() -> int:
    samples: List[Tuple[float, int]] = []
    marks: List[Tuple[float, str, int]] = []
    done = threading.Event()

    def sample() -> None:
        while not done.is_set():
            samples.append((time.perf_counter() - T0, status("VmRSS")))
            time.sleep(0.01)

    threading.Thread(target=sample, daemon=True).start()
    import robot_stiffness._columnar as columnar
    import robot_stiffness._use_tables as use_tables
    from robot_stiffness.cli import main as cli_main
    from robot_stiffness.model import StiffnessModel

    def traced(owner: Any, name: str) -> None:
        inner: Callable[..., Any] = getattr(owner, name)

        def call(*args: Any, **kwargs: Any) -> Any:
            marks.append((time.perf_counter() - T0, f"{name} starts", status("VmRSS")))
            try:
                return inner(*args, **kwargs)
            finally:
                marks.append((time.perf_counter() - T0, f"{name} ends", status("VmRSS")))

        setattr(owner, name, call)

    for name in ("read_plan", "write_predictions", "write_compensation"):
        traced(use_tables, name)
    for name in ("read_columns", "write_columns"):
        traced(columnar, name)
    for name in ("predict", "predict_sag", "compensate"):
        traced(StiffnessModel, name)
    try:
        return cli_main(sys.argv[1:])
    finally:
        done.set()
        for t, what, mib in marks:
            print(f"{t:6.2f} s  {what:28s} {mib:6d} MiB", file=sys.stderr)
        if samples:
            t, mib = max(samples, key=lambda s: s[1])
            print(f"peak sampled {mib} MiB at {t:.2f} s; VmHWM {status('VmHWM')} MiB", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
