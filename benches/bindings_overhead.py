#!/usr/bin/env python3
"""Overhead of the Python bindings: ``Robot.jacobian`` and ``Robot.identify`` against the same
Rust batched calls on the same arrays, in the same process and run (issue 12: within 1.3×).

Rust side: private helpers of the extension that time the core call inside Rust with the GIL
released — ``_core.vjm_jacobian_timed`` (``vjm::jacobian_batch_in_place`` into a freshly
allocated N·6·m buffer, as a Rust caller asking for N Jacobians does) and
``_core.vjm_identify_timed`` (``vjm::identify``). Python side: the public calls, wall time,
argument handling, input checks, result conversion and (for ``identify``) the stiffness model
included. Runs are interleaved so that load drifts hit both sides alike; the medians and their
ratio are printed, and the best-of ratio too (less sensitive to a shared machine).

Build the package in release mode first (``pip install ./crates/py-bindings`` or
``maturin develop --release``): a debug build times unoptimised Rust on both sides.

Usage (from the workspace root):
    python3 benches/bindings_overhead.py                 # Jacobian N = 1e4, 1e5; identify 1e6
    python3 benches/bindings_overhead.py --repeats 9 --fortran
    python3 benches/bindings_overhead.py --check 1.3     # exit 1 when a median ratio exceeds it
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from typing import Callable, List, Tuple

import numpy as np

from robot_stiffness import _core
from robot_stiffness.vjm import Robot

SEED = 20261201
COMPLIANCE = np.array([1.0e-4, 1.0e-4, 1.5e-4, 1.5e-4, 3.0e-4, 4.0e-4, 5.0e-4])  # rad/(N·m)


def data(robot: Robot, n: int, rng: np.random.Generator) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Seeded joint angles inside the limits, wrenches, and displacements with 10 µm noise."""
    lo = np.array([lower for lower, _ in robot.limits])
    hi = np.array([upper for _, upper in robot.limits])
    q = lo + (hi - lo) * (0.1 + 0.8 * rng.random((n, robot.n_joints)))
    w = rng.normal(size=(n, 6)) * np.array([30, 30, 30, 1.5, 1.5, 1.5])
    d = robot.predict_deflection(COMPLIANCE, q, w)[:, :3] + 1e-5 * rng.normal(size=(n, 3))
    return q, w, d


def interleaved(repeats: int, python: Callable[[], object], rust: Callable[[], float]) -> Tuple[List[float], List[float]]:
    py_times, rust_times = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        python()
        py_times.append(time.perf_counter() - t0)
        rust_times.append(rust())
    return py_times, rust_times


def report(name: str, n: int, py: List[float], rust: List[float]) -> float:
    ratio = statistics.median(py) / statistics.median(rust)
    best = min(py) / min(rust)
    print(
        f"{name:<34} N = {n:>9,}  Python median {statistics.median(py) * 1e3:9.2f} ms"
        f" ({statistics.median(py) / n * 1e9:7.1f} ns/row)  Rust median {statistics.median(rust) * 1e3:9.2f} ms"
        f" ({statistics.median(rust) / n * 1e9:7.1f} ns/row)  ratio {ratio:5.2f}  best-of ratio {best:5.2f}"
    )
    return ratio


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--jacobian-sizes", default="10000,100000", help="comma-separated N (default 1e4,1e5)")
    ap.add_argument("--identify-size", type=int, default=1_000_000, help="N of the identification (default 1e6)")
    ap.add_argument("--repeats", type=int, default=7, help="timed runs of each side (default 7)")
    ap.add_argument("--fortran", action="store_true", help="also time Fortran-ordered inputs (one copy each)")
    ap.add_argument("--check", type=float, default=None, help="exit 1 if a C-order median ratio exceeds this")
    args = ap.parse_args()

    robot = Robot.bundled()
    rng = np.random.default_rng(SEED)
    layouts = [("C", np.ascontiguousarray)] + ([("Fortran", np.asfortranarray)] if args.fortran else [])
    worst = 0.0
    print(f"robot_stiffness {_core.__version__}; {args.repeats} interleaved runs per row")
    for n in (int(s) for s in args.jacobian_sizes.split(",")):
        q, _, _ = data(robot, n, rng)
        for model in ("extended", "traditional"):
            for layout, convert in layouts:
                qa = convert(q)
                robot.jacobian(qa[:100], model)  # warm-up
                py, rust = interleaved(
                    args.repeats,
                    lambda qa=qa, model=model: robot.jacobian(qa, model),
                    lambda qa=qa, model=model: _core.vjm_jacobian_timed(robot._inner, qa, model, 1)[0],
                )
                ratio = report(f"jacobian {model} ({layout})", n, py, rust)
                if layout == "C":
                    worst = max(worst, ratio)
    n = args.identify_size
    q, w, d = data(robot, n, rng)
    for layout, convert in layouts:
        qa, wa, da = convert(q), convert(w), convert(d)
        robot.identify(qa[:1000], wa[:1000], da[:1000])  # warm-up
        py, rust = interleaved(
            args.repeats,
            lambda qa=qa, wa=wa, da=da: robot.identify(qa, wa, da),
            lambda qa=qa, wa=wa, da=da: _core.vjm_identify_timed(robot._inner, qa, wa, da, "traditional", 1)[0],
        )
        ratio = report(f"identify traditional ({layout})", n, py, rust)
        if layout == "C":
            worst = max(worst, ratio)
    if args.check is not None and worst > args.check:
        print(f"FAIL: a median ratio ({worst:.2f}) exceeds {args.check}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
