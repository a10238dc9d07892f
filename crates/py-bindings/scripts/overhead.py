"""Python-call overhead of the VJM identification on N = 1e6 measurements.

Compares the wall time of ``Robot.identify`` (numpy conversion, GIL release, result conversion
and the Python wrapper included) with the time of the same core call ``vjm::identify`` measured
inside Rust on the same arrays (``_core.vjm_identify_timed``). Not a test: run it by hand on an
idle machine, with the package built in release mode (``pip install ./crates/py-bindings``).

    python crates/py-bindings/scripts/overhead.py [--n 1000000] [--repeats 5] [--model traditional]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from robot_stiffness import _core
from robot_stiffness.vjm import Robot


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1_000_000, help="measurements (default 1e6)")
    ap.add_argument("--repeats", type=int, default=5, help="timed runs of each (default 5)")
    ap.add_argument("--model", default="traditional", help="traditional or extended")
    ap.add_argument("--fortran", action="store_true", help="pass Fortran-ordered arrays (one copy)")
    args = ap.parse_args()

    robot = Robot.bundled()
    rng = np.random.default_rng(0)
    lo = np.array([lower for lower, _ in robot.limits])
    hi = np.array([u for _, u in robot.limits])
    q = lo + (hi - lo) * (0.1 + 0.8 * rng.random((args.n, robot.n_joints)))
    w = rng.normal(size=(args.n, 6)) * np.array([30, 30, 30, 1.5, 1.5, 1.5])
    c = np.array([1.0e-4, 1.0e-4, 1.5e-4, 1.5e-4, 3.0e-4, 4.0e-4, 5.0e-4])
    d = robot.predict_deflection(c, q, w)[:, :3] + 1e-5 * rng.normal(size=(args.n, 3))
    if args.fortran:
        q, w, d = (np.asfortranarray(a) for a in (q, w, d))

    robot.identify(q[:1000], w[:1000], d[:1000], model=args.model)  # warm-up
    py_times, rust_times = [], []
    for _ in range(args.repeats):
        # Interleaved so that machine-load drifts hit both alike.
        t0 = time.perf_counter()
        robot.identify(q, w, d, model=args.model)
        py_times.append(time.perf_counter() - t0)
        rust_times.extend(_core.vjm_identify_timed(robot._inner, q, w, d, args.model, 1))
    py_med, rust_med = statistics.median(py_times), statistics.median(rust_times)
    print(f"N = {args.n:,}, model = {args.model}, {'Fortran' if args.fortran else 'C'}-ordered input, {args.repeats} runs each")
    print(f"  Python robot.identify : median {py_med * 1e3:9.2f} ms  (min {min(py_times) * 1e3:.2f} ms)")
    print(f"  Rust   vjm::identify  : median {rust_med * 1e3:9.2f} ms  (min {min(rust_times) * 1e3:.2f} ms)")
    print(f"  overhead: {100.0 * (py_med / rust_med - 1.0):+.2f} % (median), {100.0 * (min(py_times) / min(rust_times) - 1.0):+.2f} % (min)")


if __name__ == "__main__":
    main()
