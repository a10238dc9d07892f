"""``design vjm --out PLAN.csv``: plan a campaign's poses and wrenches (``docs/use-the-model.md``).
"""

from __future__ import annotations

import argparse
from typing import Any

from . import _cli_types as T
from ._cli_context import (
    FORCE_HELP,
    add_gravity_args,
    add_kinds,
    add_robot_args,
    clear_progress,
    gravity_of,
    gravity_words,
    progress_reporter,
    robot_of,
    show_progress,
)
from ._interrupt import in_worker
from ._outputs import Outputs

NOISE_LINE = (
    "noise model: laser tracker ±(15 µm + 6 µm/m·L) as 2σ per axis on each of the two readings "
    "(tracker at (2.5, 0, 0.5) m), force/torque sensor 1 % of 100 N / 10 N·m as 2σ, entering "
    "through the testbed's nominal compliances; estimator: identify vjm with its defaults"
)

def cmd_design_vjm(args: argparse.Namespace, out: Outputs) -> int:
    from .vjm import design

    plan_out = out.file(args.out, "--out")
    robot = robot_of(args)
    model: Any = args.model  # the one model vocabulary, read by the core
    show = show_progress(args)
    try:
        # The callback shows progress on a terminal and stops the core once Ctrl-C was seen.
        plan = in_worker(design, robot, model=model, poses=args.poses, wrenches_per_pose=args.wrenches_per_pose,
                         seed=args.seed, margin=args.margin, pool_size=max(args.pool, args.poses),
                         progress=progress_reporter(show, "design"), gravity=gravity_of(args))
    finally:
        clear_progress(show)
    plan_out.write_text(plan.csv_text())
    out.commit()
    print(f"Planned {len(plan.pose)} measurements ({args.poses} poses × {args.wrenches_per_pose} wrenches) "
          f"for the {args.model} model, {gravity_words(gravity_of(args))}: rank {plan.rank}.")
    print(NOISE_LINE + ".")
    print("Predicted standard error of every identifiable combination (rad/(N·m)):")
    for c in plan.combinations:
        print(f"  {c.label:<40} {c.stderr:.3e}" + ("  weak" if c.weak else ""))
    print(f"worst: {plan.worst_stderr:.3e}; written {args.out}")
    weak = [c.label for c in plan.combinations if c.weak]
    if weak:
        print(f"warning: {len(weak)} combination(s) left weak (predicted standard error above the size the prior gives "
              f"them or above 1e-2 rad/(N·m)): the identification will not tell them from 0; plan more poses or "
              f"wrenches, or a model without them. predict and compensate use only what the data determine.")
    need = plan.pose_compliance_wrenches
    if args.wrenches_per_pose >= need:
        print(f"diagnose can test whether the compliance changes from pose to pose (pose_compliance block: "
              f"≥ {need} wrenches per pose).")
    else:
        print(f"note: with {args.wrenches_per_pose} wrenches per pose diagnose cannot test whether the compliance "
              f"changes from pose to pose (pose_compliance block); plan ≥ {need} (--wrenches-per-pose {need}).")
    return 0


def register(sub: Any) -> None:
    """Adds ``design`` (kind ``vjm``) to the subcommand set ``sub``."""
    des_sub = add_kinds(
        sub,
        "design",
        help="plan a measurement campaign (poses and wrenches)",
        description="Plan where and how to measure for a VJM identification.",
    )
    dv = des_sub.add_parser(
        "vjm",
        help="poses and wrenches that minimise the worst predicted standard error",
        description="Poses inside the joint limits and, per pose, wrenches (80 N, 3 N·m) chosen greedily to "
        "minimise the worst predicted standard error of the identifiable combinations. Prints the predicted "
        "standard error of every combination; PLAN.csv is a measurement file with empty dx,dy,dz.",
    )
    add_robot_args(dv)
    dv.add_argument("--model", default="traditional", help=T.MODEL_HELP)
    dv.add_argument("--poses", type=T.count(1, 10000), default=24, help="number of poses (default 24)")
    dv.add_argument("--wrenches-per-pose", type=T.count(1, 100), default=4,
                    help="wrenches per pose (default 4); poses × wrenches at most 100000")
    dv.add_argument("--margin", type=T.positive_float(3.2, "rad"), default=0.1,
                    help="stay this far inside every joint limit, rad (default 0.1)")
    dv.add_argument("--pool", type=T.count(1, 100000), default=300, help="candidate poses drawn (default 300)")
    dv.add_argument("--seed", type=T.seed, default=0, help="seed of the candidate poses (default 0)")
    dv.add_argument("--out", required=True, metavar="PLAN.csv", help="the planned rows (dx,dy,dz empty)")
    add_gravity_args(dv)
    dv.add_argument("--force", action="store_true", help=FORCE_HELP)
    dv.set_defaults(func=cmd_design_vjm)
