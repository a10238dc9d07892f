"""``compensate vjm MODEL.json TRAJ.csv --out COMP.csv``: corrected joint targets for a trajectory
under load (``docs/use-the-model.md``).
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from ._cli_context import (
    FORCE_HELP,
    GRAVITY_DEFAULT_MODEL,
    CliError,
    add_gravity_args,
    add_kinds,
    add_robot_args,
    check_input,
    data_file,
    model_gravity_of,
)
from ._cli_model_file import PAYLOAD_NAMES, parse_payload, robot_for
from ._errors import DataFileError
from ._interrupt import in_worker
from ._outputs import Outputs


def plot_compensation(path: Any, comp: Any) -> None:
    """Predicted tip deflection along the trajectory before and after compensation (log scale)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.5))
    rows = np.arange(len(comp.deflection))
    ax.semilogy(rows, np.maximum(comp.deflection * 1e3, 1e-12), label="without compensation")
    ax.semilogy(rows, np.maximum(comp.position_error * 1e3, 1e-12), label="with compensation (predicted)")
    ax.set_xlabel("trajectory row")
    ax.set_ylabel("tip position error (mm)")
    ax.set_title("Deflection along the trajectory")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, format="png", dpi=110)
    plt.close(fig)

def cmd_compensate_vjm(args: argparse.Namespace, out: Outputs) -> int:
    from pathlib import Path

    from ._errors import InvalidValueError, MissingFileError, reworded
    from ._use_tables import read_poses, rows_of, write_compensation
    from .vjm import compensate_with_model_file

    for path, what in ((args.model_file, "MODEL.json"), (args.data, "TRAJ.csv")):
        check_input(path, what)
        if not Path(path).exists():
            raise MissingFileError(f"{what} {path}: file not found")
    # --out/--plot onto MODEL.json, TRAJ.csv, --urdf or the URDF the model names: refused by
    # `out` (cli._run gives it the inputs).
    comp_out = out.file(args.out, "--out")
    plot_out = out.file(args.plot, "--plot") if args.plot is not None else None
    payload = None if args.payload is None else parse_payload(args.payload)
    robot = robot_for(args)  # the robot the model file records, unless --urdf/--base/--tip
    q, wrench = read_poses(args.data, robot)
    if payload is not None and wrench is not None:
        raise InvalidValueError(f"{args.data} has fx..mz columns and --payload was given: use one of them")
    if payload is None and wrench is None:
        raise DataFileError(f"{args.data}: missing columns fx,fy,fz,mx,my,mz (or give --payload MASS[,cx,cy,cz])")
    # identify's checks, with the file named in a bad cell's message and the flag in a bad payload's.
    with data_file(args.data), reworded(PAYLOAD_NAMES), rows_of(args.data):
        comp = in_worker(
            compensate_with_model_file, robot, args.model_file, q, wrench=wrench, payload=payload,
            match_orientation=False if args.position_only else None, with_kc=not args.no_kc,
            allow_outside_limits=args.allow_outside_limits, gravity=model_gravity_of(args),
            load_only=args.load_only,
        )
    comp_out.write_with(lambda path: write_compensation(path, args.out, q, comp))
    if plot_out is not None:
        plot_compensation(plot_out.tmp, comp)
    out.commit()
    counts: dict = {}
    for s in comp.status:
        counts[s] = counts.get(s, 0) + 1
    ok = np.array([s == "converged" for s in comp.status])
    before = comp.deflection[np.isfinite(comp.deflection)]
    mean_before = f"{float(np.mean(before)) * 1e3:.4f} mm" if before.size else "not available (no row settled)"
    after = (f"{float(np.max(comp.position_error[ok])) * 1e3:.2e} mm" if ok.any() else "none (no row converged)")
    summary = ", ".join(f"{k} {v}" for k, v in sorted(counts.items()))
    what = "the load's deflection only" if args.load_only or args.no_gravity else "own weight + load"
    print(f"Compensated {len(comp.status)} rows ({what}): {summary}. Mean predicted deflection {mean_before}; "
          f"largest predicted remaining error of the converged rows {after}. Written {args.out}"
          + (f" and {args.plot}" if args.plot else "") + ".")
    bad = [i for i, s in enumerate(comp.status) if s != "converged"]
    for i in bad[:5]:
        print(f"  row {i + 1}: {comp.status[i]}" + (f" (joint {comp.limit_joint[i] + 1})" if comp.limit_joint[i] >= 0 else ""))
    if bad and not args.keep_going:
        # The file is written (every row with its status); the exit status tells a script.
        statuses = ", ".join(sorted({comp.status[i] for i in bad}))
        raise CliError(
            f"{len(bad)} of {len(comp.status)} rows are not converged within the limits ({statuses}); "
            f"{args.out} has every row with its status: pass --keep-going to accept that (exit 0)"
        )
    return 0


def register(sub: Any) -> None:
    """Adds ``compensate`` (kind ``vjm``) to the subcommand set ``sub``."""
    com_sub = add_kinds(
        sub,
        "compensate",
        help="corrected joint targets for a trajectory under load",
        description="Compensate the deflection of a trajectory with a saved model.",
    )
    cv = com_sub.add_parser(
        "vjm",
        help="joint targets so that the loaded tip reaches the nominal tip",
        description="For each row of TRAJ.csv (q1..qn nominal targets; fx..mz the expected load, or --payload) "
        "write corrected targets q1..qn, the predicted remaining error and a status (converged, "
        "outside_limits, near_singular, not_converged, unstable). By default the tip's sag under the arm's "
        "own weight is corrected with the load's deflection, so that the tip reaches the rigid kinematics' "
        "pose (the URDF must give the link masses); --load-only corrects the load's deflection only. "
        "Parquet (.parquet, .pq) or Arrow IPC (.arrow, .feather, .ipc) TRAJ and COMP files are read and "
        "written with pyarrow (the [parquet] extra), with the same columns (limit_joint is null there "
        "when no joint leaves its limits).",
    )
    cv.add_argument("model_file", metavar="MODEL.json", help="model file written by identify vjm --save")
    cv.add_argument("data", metavar="TRAJ.csv", help="trajectory: q1..qn and fx,fy,fz,mx,my,mz (or --payload)")
    add_robot_args(cv)
    cv.add_argument("--payload", metavar="MASS[,cx,cy,cz]",
                    help="the load is a point mass (kg) at (cx, cy, cz) m in the tip frame, gravity along −z of the base")
    cv.add_argument("--position-only", action="store_true",
                    help="match the position only (default: also the orientation when the model has rotations)")
    cv.add_argument("--no-kc", action="store_true", help="leave out the complementary stiffness K_C")
    add_gravity_args(cv, GRAVITY_DEFAULT_MODEL)
    cv.add_argument("--load-only", action="store_true",
                    help="correct the load's deflection only (weightless, the nominal tip is the unloaded tip), "
                    "not the arm's own sag: for a controller that already corrects the sag")
    cv.add_argument("--allow-outside-limits", action="store_true",
                    help="accept nominal joint angles outside the URDF limits (refused by default, as by identify: "
                    "degrees or a wrong joint order?)")
    cv.add_argument("--out", required=True, metavar="COMP.csv", help="corrected targets and per-row outcome")
    cv.add_argument("--plot", metavar="FILE.png", help="deflection along the trajectory before/after (PNG)")
    cv.add_argument("--keep-going", action="store_true",
                    help="exit 0 even when some rows do not converge (by default the file is written and the exit "
                    "status is 1)")
    cv.add_argument("--force", action="store_true", help=FORCE_HELP)
    cv.set_defaults(func=cmd_compensate_vjm)
