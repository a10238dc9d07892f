"""``identify vjm`` and ``identify csjm``: compliances of a serial arm, stiffness of a cable-driven joint.
"""

from __future__ import annotations

import argparse
import warnings
from typing import Any

from . import _cli_types as T
from ._cli_context import (
    FORCE_HELP,
    add_gravity_args,
    add_kinds,
    add_robot_args,
    data_file,
    gravity_of,
    gravity_words,
    json_text,
    model_arg,
    robot_of,
)
from ._cli_model_file import add_save_option, claim_save, write_model
from ._errors import SuspiciousDataWarning
from ._interrupt import in_worker
from ._outputs import Outputs


def cmd_identify_vjm(args: argparse.Namespace, out: Outputs) -> int:
    from .vjm import read_measurements

    json_out = out.file(args.json, "--json") if args.json is not None else None
    save_out = claim_save(args, out)
    robot = robot_of(args)
    with data_file(args.data):
        # The file's fingerprint goes into a saved model only: without --save, no hash.
        data = in_worker(read_measurements, args.data, robot.n_joints, fingerprint=save_out is not None)
    with warnings.catch_warnings():
        if args.quiet:  # nothing but errors; the warnings stay in the result (--json "warnings")
            warnings.simplefilter("ignore", SuspiciousDataWarning)
        res = in_worker(
            robot.identify,
            data.q,
            data.wrench,
            data.displacement,
            model_arg(args.model),
            rotation=data.rotation if args.use_rotations else None,
            nonnegative=args.nonnegative,
            method=args.method,
            # The hash the reader took, else the path (a Parquet file, hashed now); no file
            # when no model is saved.
            data_file=(data.source or args.data) if save_out is not None else None,
            robust_covariance=save_out is not None,
            allow_outside_limits=args.allow_outside_limits,
            gravity=gravity_of(args),
        )
    doc = res.to_dict()
    if json_out is not None:
        json_out.write_text(json_text(doc))
    write_model(save_out, res)
    out.commit()
    if args.quiet:
        return 0
    print(f"{res.model} model: {res.n_params} parameters, rank {res.rank} from {len(data)} measurements "
          f"({gravity_words(gravity_of(args))})")
    for label, c, s, ok, weak in zip(res.labels, res.compliance, res.stderr, res.identifiable, res.weak):
        if ok:
            print(f"  {label:>5}  {c: .4e} ± {s:.1e} rad/(N·m)" + ("  weak" if weak else ""))
        else:
            print(f"  {label:>5}  not identifiable alone")
    if res.rank < res.n_params:
        print("identifiable combinations:")
        for comb in res.combinations:
            print(f"  {comb.label} = {comb.value:.4e} ± {comb.stderr:.1e}" + ("  weak" if comb.weak else ""))
    n_weak = sum(1 for comb in res.combinations if comb.weak)
    if n_weak:
        print(f"weak: {n_weak} of {res.rank} combinations have a standard error above their value or above "
              "1e-2 rad/(N·m): the data do not determine them; predict and compensate use what they determine")
    return 0


def cmd_identify_csjm(args: argparse.Namespace, out: Outputs) -> int:
    from .csjm import identify_csv

    json_out = out.file(args.json, "--json") if args.json is not None else None
    with data_file(args.data):
        fit = in_worker(identify_csv, args.data, order=args.order, project=args.project)
    doc = fit.to_dict()
    if json_out is not None:
        json_out.write_text(json_text(doc))
    out.commit()
    print(f"K (N·m/rad, platform frame A at R0), order {fit.order}, {fit.n} load increments:")
    for row, err in zip(fit.K, fit.K_stderr):
        print("  " + "  ".join(f"{v:10.3f}" for v in row) + "   ± " + " ".join(f"{e:.2g}" for e in err))
    return 0


def register(sub: Any) -> None:
    """Adds ``identify`` (kinds ``vjm`` and ``csjm``) to the subcommand set ``sub``."""
    ide_sub = add_kinds(
        sub,
        "identify",
        help="identify compliances (VJM) or a stiffness matrix (CSJM)",
        description="Identify stiffness parameters from a measurement file.",
    )
    iv = ide_sub.add_parser(
        "vjm",
        help="joint compliances of a serial arm",
        description="Rank-revealing identification of virtual-joint compliances (rad/(N·m)). Parameters that the "
        "data cannot identify are reported as null with the identifiable combinations. The displacements are "
        "fitted about the equilibrium under the arm's own weight (--gravity; --no-gravity: the weightless, linear "
        "fit); --save records the gravity in the model file.",
    )
    iv.add_argument("data", metavar="DATA.csv", help="VJM measurement file")
    add_robot_args(iv)
    iv.add_argument("--model", default="traditional", help=T.MODEL_HELP)
    iv.add_argument("--use-rotations", action="store_true", help="also use the rx,ry,rz columns")
    iv.add_argument("--allow-outside-limits", action="store_true",
                    help="accept joint angles outside the URDF limits (refused by default: degrees or a wrong "
                    "joint order?)")
    iv.add_argument("--nonnegative", action="store_true", help="constrain compliances to be ≥ 0")
    iv.add_argument("--method", choices=("auto", "normal_equations", "qr"), default="auto",
                    help="streaming reduction (default auto: normal equations, QR when κ > 1e4)")
    iv.add_argument("--json", metavar="OUT.json", help="write the result as JSON")
    add_gravity_args(iv)
    add_save_option(iv)
    iv.add_argument("--force", action="store_true", help=FORCE_HELP)
    iv.add_argument("--quiet", action="store_true",
                    help="print nothing but errors (no summary, no warning lines: the warnings stay in --json); "
                    "the exit status is unchanged")
    iv.set_defaults(func=cmd_identify_vjm)
    ic = ide_sub.add_parser(
        "csjm",
        help="3×3 rotational stiffness of a cable-driven spherical joint",
        description="Identify K (N·m/rad) at the reference pose from a CSJM measurement file.",
    )
    ic.add_argument("data", metavar="DATA.csv", help="CSJM measurement file")
    ic.add_argument("--order", type=int, choices=(1, 2), default=1,
                    help="1: linear fit (seed eq. 49); 2: also fits the curvature for large increments")
    ic.add_argument("--project", action="store_true",
                    help="project measured orientation matrices onto SO(3) instead of rejecting them")
    ic.add_argument("--json", metavar="OUT.json", help="write K, K_D, K_stderr, tau0, n, order as JSON")
    ic.add_argument("--force", action="store_true", help=FORCE_HELP)
    ic.set_defaults(func=cmd_identify_csjm)
