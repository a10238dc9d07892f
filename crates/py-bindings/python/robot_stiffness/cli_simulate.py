"""``simulate vjm`` and ``simulate csjm``: a virtual measurement campaign with hidden effects.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import re
import sys
from typing import Any, Dict, Iterator, Sequence, Tuple

from . import _cli_types as T
from ._cli_context import (
    FORCE_HELP,
    CliError,
    add_gravity_args,
    add_kinds,
    add_robot_args,
    check_input,
    data_file,
    gravity_of,
    gravity_words,
    json_text,
    robot_of,
)
from ._errors import DataFileError, StiffnessError
from ._interrupt import in_worker
from ._outputs import Outputs


def _parse_value(spec: str, key: str, text: str) -> Any:
    if key == "axis":
        return text
    if not text:
        raise CliError(f"--effect {spec!r}: {key}= has no value")
    if key == "joint":
        try:
            return int(text, 10)
        except ValueError:
            raise CliError(f"--effect {spec!r}: joint={text!r} must be an integer (1-based)") from None
    parts = text.replace(";", "/").split("/")
    try:
        values = [float(v) for v in parts]
    except ValueError:
        raise CliError(
            f"--effect {spec!r}: {key}={text!r} must be a number or numbers separated by '/'"
        ) from None
    if not all(math.isfinite(v) for v in values):
        raise CliError(f"--effect {spec!r}: {key}={text!r} must be finite")
    return values if len(values) > 1 or key in ("bias", "rotation") else values[0]


def parse_effect(spec: str) -> Dict[str, Any]:
    """``"joint_tilt:joint=3,axis=x,compliance=5e-5"`` → ``{"effect": "joint_tilt", ...}``.

    Malformed text is a :class:`CliError` naming the ``--effect`` argument; the names and
    ranges of the parameters are checked by the core (its messages are re-attributed to the
    ``--effect`` argument by :func:`_effect_errors`)."""
    name, _, rest = spec.partition(":")
    name = name.strip()
    if not name or not all(c.isalnum() or c == "_" for c in name):
        raise CliError(f"--effect {spec!r}: expected NAME:key=value,... (e.g. joint_tilt:joint=3,axis=x,compliance=5e-5)")
    effect: Dict[str, Any] = {"effect": name}
    for item in (s.strip() for s in rest.split(",")):
        if not item:
            if rest.strip():
                raise CliError(f"--effect {spec!r}: empty key=value item")
            continue
        key, eq, value = item.partition("=")
        key = key.strip()
        if not eq:
            raise CliError(f"--effect {spec!r}: expected key=value, got {item!r}")
        if not key or key == "effect":
            raise CliError(f"--effect {spec!r}: bad key in {item!r}")
        if key in effect:
            raise CliError(f"--effect {spec!r}: {key} is given twice")
        effect[key] = _parse_value(spec, key, value.strip())
    return effect


_FILE_CELL = re.compile(r"\bline \d+, column '(\w+)'")


_EFFECT_INDEX = re.compile(r"effects\[(\d+)\](?:\[`?(\w+)`?\])?:?\s*")


@contextlib.contextmanager
def _effect_errors(specs: Sequence[str]) -> Iterator[None]:
    """Re-attribute the core's ``effects[i] …`` messages to the user's ``--effect`` text."""
    try:
        yield
    except DataFileError as e:
        # The simulated campaign failed the measurement checks: no file of the user's is
        # involved, so a "line N, column 'dx'" would be wrong blame; name the cause instead.
        detail = _FILE_CELL.sub(r"simulated \1", " ".join(str(e).split()))
        detail = detail.split("; looks like")[0]
        culprit = f"--effect {specs[0]!r}" if len(specs) == 1 else "the --effect values"
        raise CliError(
            f"the simulated measurements are implausible ({detail}); check {culprit} and the load and "
            "size flags"
        ) from None
    except StiffnessError as e:
        text = str(e)
        m = _EFFECT_INDEX.search(text)
        if m is None or int(m.group(1)) >= len(specs):
            raise
        rest = (text[: m.start()] + (f"{m.group(2)} " if m.group(2) else "") + text[m.end():]).strip()
        raise CliError(f"--effect {specs[int(m.group(1))]!r}: {rest}") from None


def _table_out(args: argparse.Namespace) -> str:
    """The table a command writes: ``--out``, or the deprecated positional ``OUT.csv``
    (:func:`_warn_positional_out` warns once the command has succeeded, so that an error stays
    one line)."""
    if args.out_positional is not None and args.out is not None:
        raise CliError(f"the output is given twice ({args.out_positional} and --out {args.out}): give --out only")
    if args.out_positional is not None:
        return str(args.out_positional)
    if args.out is None:
        raise CliError("--out OUT.csv is required (the measurement file to write)")
    return str(args.out)


def _warn_positional_out(args: argparse.Namespace) -> None:
    if args.out_positional is not None:
        print(f"warning: the positional OUT.csv is deprecated; write --out {args.out_positional}", file=sys.stderr)


#: Flags of ``simulate vjm`` that draw the rows, which a plan gives instead.
_DRAW_FLAGS = (("poses", "--poses"), ("wrenches_per_pose", "--wrenches-per-pose"),
               ("force_max", "--force-max"), ("moment_max", "--moment-max"))


def _plan_rows(path: str, robot: Any) -> Tuple[Any, Any, Any]:
    """``(q, wrench, pose)`` of a plan (``design``'s PLAN.csv, or any table with q1..qn and
    fx..mz); without a ``pose`` column, consecutive rows at the same joint angles are one pose."""
    import numpy as np

    from ._use_tables import read_plan

    check_input(path, "--plan")
    with data_file(path):
        q, wrench, pose = read_plan(path, robot)
    if wrench is None:
        raise CliError(f"--plan {path}: missing columns fx,fy,fz,mx,my,mz (a plan gives the wrench of every row)")
    if pose is None:
        changes = np.any(q[1:] != q[:-1], axis=1)
        pose = np.concatenate([[0], np.cumsum(changes)]).astype(np.int64)
    return q, wrench, pose


def cmd_simulate(args: argparse.Namespace, out: Outputs) -> int:
    import numpy as np

    from .vjm import simulate

    path = _table_out(args)
    robot = robot_of(args)
    plan = None
    if args.plan is not None:
        given = [flag for name, flag in _DRAW_FLAGS if getattr(args, name) is not None]
        if given:
            raise CliError(f"--plan gives the poses and wrenches: drop {', '.join(given)}")
        plan = _plan_rows(args.plan, robot)
        size = f"{len(np.unique(plan[2]))} poses of the plan {args.plan}"
    else:
        poses = 40 if args.poses is None else args.poses
        per_pose = 4 if args.wrenches_per_pose is None else args.wrenches_per_pose
        rows = poses * per_pose
        if rows > T.MAX_ROWS:
            raise CliError(f"--poses {poses} × --wrenches-per-pose {per_pose} = {rows} rows; "
                           f"at most {T.MAX_ROWS} rows are simulated at once")
        size = f"{poses} poses × {per_pose} wrenches"
    csv_out = out.file(path, "--out")
    truth_out = out.file(args.truth, "--truth") if args.truth is not None else None
    specs = list(args.effect or [])
    effects = [parse_effect(e) for e in specs]
    draw = {} if plan is not None else {"n_poses": poses, "wrenches_per_pose": per_pose,
                                        "force_max": args.force_max, "moment_max": args.moment_max}
    with _effect_errors(specs):
        c = in_worker(simulate, robot, effects, seed=args.seed, noise=not args.no_noise,
                      gravity=gravity_of(args), plan=plan, **draw)
    csv_out.write_text(c.csv)
    if truth_out is not None:
        truth_out.write_text(json_text({"truth": c.truth.to_dict(), "spec": c.spec.to_dict()}))
    out.commit()
    names = ", ".join(e["effect"] for e in effects) or "none (torsional springs only)"
    print(f"wrote {path}: {len(c.measurements)} rows ({size}), "
          f"seed {args.seed}, {gravity_words(gravity_of(args))}, hidden effects: {names}")
    _warn_positional_out(args)
    return 0


def cmd_simulate_csjm(args: argparse.Namespace, out: Outputs) -> int:
    from .csjm import simulate as simulate_csjm

    path = _table_out(args)
    csv_out = out.file(path, "--out")
    truth_out = out.file(args.truth, "--truth") if args.truth is not None else None
    specs = list(args.effect or [])
    effects = [parse_effect(e) for e in specs]
    with _effect_errors(specs):
        c = in_worker(simulate_csjm, effects, seed=args.seed, increments=args.increments,
                      max_increment=args.max_increment)
    csv_out.write_text(c.csv)
    if truth_out is not None:
        truth_out.write_text(json_text({"K": c.true_K, "K_D": c.true_K_D, "R0": c.true_R0, "effects": effects}))
    out.commit()
    names = ", ".join(e["effect"] for e in effects) or "none"
    print(f"wrote {path}: CSJM campaign, seed {args.seed}, hidden effects: {names}")
    _warn_positional_out(args)
    return 0


def _add_table_out(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", metavar="OUT.csv", help="measurement file to write (required)")
    parser.add_argument("out_positional", nargs="?", metavar="OUT.csv", help=argparse.SUPPRESS)


def register(sub: Any) -> None:
    """Adds ``simulate`` (kinds ``vjm`` and ``csjm``) to the subcommand set ``sub``."""
    sim_sub = add_kinds(
        sub,
        "simulate",
        help="simulate a measurement campaign (virtual testbed)",
        description="Simulate a measurement campaign from a true model with hidden effects.",
    )
    sv = sim_sub.add_parser(
        "vjm",
        help="a serial arm",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Simulate loaded measurements of a serial arm: random poses inside the joint limits, random "
        "wrenches at the tip, laser-tracker and F/T-sensor noise, under the arm's own weight (tip under load − tip "
        "unloaded, both at the static equilibrium under gravity; --no-gravity for a weightless arm). Writes a VJM "
        "measurement file with pose and set (train/test) columns.",
        epilog="""\
effects (--effect NAME:key=value,...; joints are 1-based, base → tip; SI units):
  joint_tilt:joint=3,axis=x,compliance=5e-5          tilting compliance, rad/(N·m)
  joint_torsion_nonlinear:joint=2,ratio=2,t1=5,t2=15  harmonic-drive stiffening (ratio per segment, N·m)
  joint_backlash:joint=2,lost_motion=2e-4             lost motion, rad
  wrench_bias:bias=2/0/-2/0/0.2/0                     recorded wrench offset fx/fy/fz/mx/my/mz (N, N·m)
  frame_misalignment:rotation=0.01/-0.005/0           tracker frame rotation vector, rad
  geometric_nonlinearity                              load-dependent Jacobian (K_C)
  mount_compliance:translation=4e-6,rotation=1e-5     compliant mount, m/N and rad/(N·m)
  link_translation:joint=4,axis=z,compliance=4e-6     the link after joint 4 translates along its z, m/N
  tool_axial_compliance:compliance=1e-4               tool compliant along its axis, m/N (named as a link translation)
effects outside diagnose's catalogue (diagnose must say `unexplained`):
  pose_drift:sigma=5e-5                               an independent offset per pose, m
  sensor_crosstalk:coupling=0.05                      F/T cross-axis sensitivity (0.05 = 5 %)
  joint_torsion_angle_dependent:joint=2,amplitude=0.4 torsion compliance c·(1 + amplitude·sin q_joint)
""",
    )
    _add_table_out(sv)
    add_robot_args(sv)
    sv.add_argument("--effect", action="append", metavar="SPEC", help="hidden effect in the truth (repeatable)")
    sv.add_argument("--plan", metavar="PLAN.csv",
                    help="measure at the poses and wrenches of this plan (design vjm --out PLAN.csv; any table "
                    "with q1..qn, fx..mz and optionally pose) instead of random ones")
    sv.add_argument("--poses", type=T.count(2, T.MAX_POSES), default=None,
                    help=f"number of configurations, 2..{T.MAX_POSES} (default 40)")
    sv.add_argument("--wrenches-per-pose", type=T.count(1, T.MAX_WRENCHES_PER_POSE), default=None,
                    help=f"wrenches per configuration, 1..{T.MAX_WRENCHES_PER_POSE}; poses × wrenches ≤ "
                    f"{T.MAX_ROWS} (default 4)")
    sv.add_argument("--force-max", type=T.positive_float(T.MAX_FORCE, "N"), default=None,
                    help=f"largest force magnitude, N, at most {T.MAX_FORCE:g} (default 80)")
    sv.add_argument("--moment-max", type=T.positive_float(T.MAX_MOMENT, "N·m"), default=None,
                    help=f"largest moment magnitude, N·m, at most {T.MAX_MOMENT:g} (default 3)")
    sv.add_argument("--seed", type=T.seed, default=0,
                    help="random seed, 0..2**64-1; same seed, same file (default 0)")
    sv.add_argument("--no-noise", action="store_true", help="no instrument noise")
    sv.add_argument("--truth", metavar="TRUTH.json", help="also write the hidden true model as JSON")
    add_gravity_args(sv)
    sv.add_argument("--force", action="store_true", help=FORCE_HELP)
    sv.set_defaults(func=cmd_simulate)
    sc = sim_sub.add_parser(
        "csjm",
        help="a cable-driven spherical joint",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Simulate the seed's CSJM campaign on the prototype: a pre-loaded reference pose and load "
        "increments, laser-tracker pose noise and F/T moment noise. Writes a CSJM measurement file.",
        epilog="""\
effects (--effect NAME:key=value,...):
  platform_gravity                       platform weight acting but left out of the recorded moments
  cable_hysteresis:friction=2            Coulomb friction in every cable, N
  cable_nonlinearity:k2=2e6              cable law t = k e + k2 e², N/m²
""",
    )
    _add_table_out(sc)
    sc.add_argument("--effect", action="append", metavar="SPEC", help="hidden effect (repeatable)")
    sc.add_argument("--increments", type=T.count(3, T.MAX_INCREMENTS), default=None,
                    help=f"load increments, 3..{T.MAX_INCREMENTS} (default 85, as the seed)")
    sc.add_argument("--max-increment", type=T.positive_float(T.MAX_CSJM_INCREMENT, "N·m"), default=None,
                    help=f"largest load increment, N·m, at most {T.MAX_CSJM_INCREMENT:g} (default 1)")
    sc.add_argument("--seed", type=T.seed, default=0, help="random seed, 0..2**64-1 (default 0)")
    sc.add_argument("--truth", metavar="TRUTH.json", help="also write the true stiffness as JSON")
    sc.add_argument("--force", action="store_true", help=FORCE_HELP)
    sc.set_defaults(func=cmd_simulate_csjm)
