#!/usr/bin/env python3
"""The cost and the calibration of diagnose's wild cluster bootstrap (docs/diagnose.md §3.6).

Without the noise level, the verdict's ``angle_compliance`` block decides on a wild cluster
bootstrap; with it, on its F test. Two measurements, both on the bundled Panda:

* ``cost``: ``vjm.diagnose(..., per_row=False)`` of a seeded campaign with a hidden J3x tilt
  (so the verdict looks twice), weightless (``gravity=None``), 10 loads per pose, at each of
  ``--sizes`` rows, the noise not given and given (the testbed's levels); best of
  ``--repeat`` wall times. The difference is the bootstrap's price: its pass over the rows
  and its draws.
* ``calibration``: clean campaigns (nominal truth, standard gravity, the testbed's noise) of
  ``--poses`` × ``--wrenches`` rows, seeds 30000…, noise not given: how often the bootstrap's
  p falls below 0.01, 0.05 and 0.5 (uniform: 1 %, 5 %, 50 %), and how many runs raise any
  alarm. Above 256 rows the bootstrap's clusters are runs of consecutive rows. ``--arm``: the
  bundled Panda, or an arm of example-robot-data by the MuJoCo testbed's names
  (``crates/py-bindings/tests/mujoco_testbed.py``: ur10, z1, kinova, xarm7, baxter).
* ``power``: the same campaigns with one effect hidden (``--effect``, JSON as ``simulate``
  takes it, seeds 31000…): how many are ``unexplained`` or name a finding, and how often the
  bootstrap's p is below 1e-3.

Usage::

    python3 benches/wild_bootstrap.py cost --sizes 160,2000,10000,100000
    python3 benches/wild_bootstrap.py calibration --poses 40 --wrenches 10 --seeds 200
    python3 benches/wild_bootstrap.py calibration --arm z1 --poses 40 --wrenches 4 --seeds 200
    python3 benches/wild_bootstrap.py power --arm z1 --seeds 50 \
        --effect '{"effect": "joint_torsion_angle_dependent", "joint": 2, "amplitude": 0.2}'
"""
import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from robot_stiffness import vjm

HIDDEN_TILT = {"effect": "joint_tilt", "joint": 3, "axis": "x", "compliance": 4.5e-5}
#: The testbed's noise levels, stated: tracker (m), force sensor (N, N·m).
GIVEN = {"tracker_sigma": 2.1213e-5, "force_sigma": 0.5, "moment_sigma": 0.05}


def cost(sizes: list, repeat: int) -> None:
    robot = vjm.Robot.bundled()
    print("| rows | not given (s) | given (s) | findings |")
    print("|---:|---:|---:|---|")
    for n in sizes:
        c = vjm.simulate(robot, [HIDDEN_TILT], n_poses=max(n // 10, 1), wrenches_per_pose=10,
                         seed=1, gravity=None)
        best = {}
        for given in (False, True):
            times = []
            for _ in range(repeat):
                t0 = time.perf_counter()
                d = vjm.diagnose(robot, c.measurements, per_row=False, gravity=None,
                                 **(GIVEN if given else {}))
                times.append(time.perf_counter() - t0)
            best[given] = min(times)
        found = ", ".join(f"{f.effect} J{f.joint}{f.axis or ''}" for f in d.findings)
        print(f"| {len(c.measurements)} | {best[False]:.3f} | {best[True]:.3f} | {found} |",
              flush=True)


def arm(name: str) -> "vjm.Robot":
    """The bundled Panda (``bundled``) or an example-robot-data arm by the testbed's name."""
    if name == "bundled":
        return vjm.Robot.bundled()
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "crates/py-bindings/tests"))
    from mujoco_testbed import EXAMPLE_ARMS, example_urdf

    if name not in EXAMPLE_ARMS:
        raise SystemExit(f"unknown arm {name!r}: one of bundled, {', '.join(EXAMPLE_ARMS)}")
    rel, base, tip = EXAMPLE_ARMS[name]
    path = example_urdf(rel)
    if path is None:
        raise SystemExit(f"{name}: example-robot-data is not installed ({rel} not found)")
    return vjm.Robot.from_urdf(path, base, tip)


def calibration(robot: "vjm.Robot", name: str, poses: int, wrenches: int, seeds: int) -> None:
    ps, alarms = [], 0
    for s in range(seeds):
        c = vjm.simulate(robot, [], n_poses=poses, wrenches_per_pose=wrenches, seed=30000 + s)
        d = vjm.diagnose(robot, c.measurements, per_row=False)
        block = next(b for b in d.verdict.blocks if b.block == "angle_compliance")
        if block.wild_cluster_p_value is not None:
            ps.append(block.wild_cluster_p_value)
        alarms += bool(d.findings) or bool(d.unexplained)
    p = np.array(ps)
    print(f"{name}: {poses} poses x {wrenches} wrenches, {seeds} clean campaigns, noise not given: "
          f"bootstrap p computed in {len(p)}; below 0.01 {int(np.sum(p < 0.01))}, "
          f"below 0.05 {int(np.sum(p < 0.05))}, below 0.5 {int(np.sum(p < 0.5))}; "
          f"any alarm in {alarms}")


def power(robot: "vjm.Robot", name: str, effect: dict, poses: int, wrenches: int,
          seeds: int) -> None:
    flagged = named = small_p = 0
    for s in range(seeds):
        c = vjm.simulate(robot, [effect], n_poses=poses, wrenches_per_pose=wrenches,
                         seed=31000 + s)
        d = vjm.diagnose(robot, c.measurements, per_row=False)
        block = next(b for b in d.verdict.blocks if b.block == "angle_compliance")
        flagged += bool(d.unexplained)
        named += bool(d.findings)
        p = block.wild_cluster_p_value
        small_p += p is not None and p < 1e-3
    print(f"{name}: {json.dumps(effect)}, {poses} poses x {wrenches} wrenches, {seeds} campaigns, "
          f"noise not given: unexplained in {flagged}, a finding named in {named}, "
          f"bootstrap p < 1e-3 in {small_p}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="what", required=True)
    c = sub.add_parser("cost")
    c.add_argument("--sizes", default="160,2000,10000,100000")
    c.add_argument("--repeat", type=int, default=3)
    k = sub.add_parser("calibration")
    k.add_argument("--arm", default="bundled")
    k.add_argument("--poses", type=int, default=40)
    k.add_argument("--wrenches", type=int, default=10)
    k.add_argument("--seeds", type=int, default=200)
    w = sub.add_parser("power")
    w.add_argument("--arm", default="bundled")
    w.add_argument("--effect", required=True, help="one effect as simulate takes it, JSON")
    w.add_argument("--poses", type=int, default=40)
    w.add_argument("--wrenches", type=int, default=4)
    w.add_argument("--seeds", type=int, default=50)
    args = ap.parse_args()
    if args.what == "power":
        if min(args.poses, args.wrenches, args.seeds) < 1:
            ap.error("--poses, --wrenches and --seeds must be >= 1")
        try:
            effect = json.loads(args.effect)
        except json.JSONDecodeError as e:
            ap.error(f"--effect is not JSON: {e}")
        power(arm(args.arm), args.arm, effect, args.poses, args.wrenches, args.seeds)
    elif args.what == "cost":
        if args.repeat < 1:
            ap.error("--repeat must be >= 1")
        cost([int(s) for s in args.sizes.split(",") if s], args.repeat)
    else:
        if min(args.poses, args.wrenches, args.seeds) < 1:
            ap.error("--poses, --wrenches and --seeds must be >= 1")
        calibration(arm(args.arm), args.arm, args.poses, args.wrenches, args.seeds)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
