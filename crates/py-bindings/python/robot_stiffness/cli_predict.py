"""``predict vjm MODEL.json POSES.csv --out PRED.csv``: predicted deflections with a saved model.
"""

from __future__ import annotations

import argparse
import sys
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
from ._errors import reworded
from ._interrupt import in_workers

PREDICT_EPILOG = """\
POSES.csv: a header and one row per pose: q1..qn (rad) and either fx,fy,fz,mx,my,mz (N, N·m, at
the tip point, base frame) or --payload. Other columns (dx, pose, set, ...) are ignored, so a
measurement file works.

PRED.csv: q1..qn, the wrench used fx..mz, the predicted deflection dx,dy,dz (m) and rx,ry,rz (rad)
in the base frame (under the gravity below unless --no-gravity: the load's deflection from the arm
at rest under its own weight, as identify under gravity fits it), their standard deviations sdx,sdy,sdz,srx,sry,srz, and identified. The standard
deviations are those of the predicted true deflection (parameter uncertainty), not of a new
measurement. Rotations are empty when the model was identified without rotations. A row with
identified=false excites a direction the identification data could not see: its values are a
minimum-norm guess and its standard deviations are empty.
Then, unless --no-gravity, the tip's static sag under the arm's own weight (and the --payload's)
relative to the rigid forward kinematics: sag_dx,sag_dy,sag_dz (m, base frame), their standard
deviations sag_sd_dx,sag_sd_dy,sag_sd_dz and sag_identified (as identified, for the load the
weight puts on the springs). The gravity is --gravity, else the one the model file records
(identify vjm --save), else 9.80665 m/s² along −z; the URDF must give the link masses.

Parquet (.parquet, .pq) or Arrow IPC (.arrow, .feather, .ipc) POSES and PRED files are read and
written with pyarrow (the [parquet] extra), told by the file name, with the same columns: an
empty CSV cell is NaN there.

The robot defaults to the one recorded in the model file (its URDF path, base and tip): the URDF
is looked for at its recorded absolute path, then relative to the model file's folder (a folder
moved together with its URDF), then as recorded relative to the current folder (older files).
--urdf, --base, --tip override it; --urdf alone takes base and tip from the model file. Either
way the model file is checked against it (URDF SHA-256, links, joints, content hash) and refused
if it does not match or was edited.

Example:
  robot-stiffness identify vjm campaign.csv --model extended --save model.json
  robot-stiffness predict vjm model.json poses.csv --payload 5,0,0,0.1 --out pred.csv
"""

def _largest_mm(values: Any) -> str:
    """The largest finite value in mm, or words when there is none (never "nan")."""
    # A masked reduction: no copy of the finite values (10^6 of them twice per predict).
    largest = float(np.fmax.reduce(values, where=np.isfinite(values), initial=-np.inf))
    return f"{largest * 1e3:.3f} mm" if largest > -np.inf else "not available"

def _position_norms(deflection: Any) -> Any:
    """|(dx, dy, dz)| of each row of an (N, 6) deflection, without copying the columns out
    (``np.linalg.norm`` of the slice took 0.14 s per 10^6 rows, this 0.02 s)."""
    d = deflection[:, :3]
    return np.sqrt(np.einsum("ij,ij->i", d, d))

def cmd_predict_vjm(args: argparse.Namespace, out: Any) -> int:
    from ._use_tables import read_poses, rows_of, write_predictions
    from .model import StiffnessModel

    staged = out.file(args.out, "--out")
    check_input(args.model_file, "MODEL.json")
    check_input(args.data, "POSES.csv")
    payload = None if args.payload is None else parse_payload(args.payload)
    robot = robot_for(args)
    model = StiffnessModel.load(args.model_file, robot)
    # The long Rust calls run in a worker so that Ctrl-C ends the command at once (in_worker).
    q, wrench = read_poses(args.data, robot)
    if payload is not None and wrench is not None:
        raise CliError(f"{args.data} has fx..mz columns and --payload was given: use one of them")
    if payload is None and wrench is None:
        raise CliError(f"{args.data}: missing columns fx,fy,fz,mx,my,mz (or give --payload MASS[,cx,cy,cz])")
    # identify's checks, with the file named in a bad cell's message and the flag in a bad payload's.
    with data_file(args.data), reworded(PAYLOAD_NAMES), rows_of(args.data):
        gravity = model_gravity_of(args)
        calls = [lambda: model.predict(q, wrench=wrench, payload=payload,
                                       allow_outside_limits=args.allow_outside_limits, gravity=gravity)]
        if gravity is not None:
            calls.append(lambda: model.predict_sag(q, gravity=gravity, payload=payload,
                                                   allow_outside_limits=args.allow_outside_limits))
        # Side by side: each leaves the other's gaps in the thread pool (predict's error first).
        pred, *rest = in_workers(*calls)
        sag = rest[0] if rest else None
    staged.write_with(lambda path: write_predictions(path, args.out, q, pred, sag))
    out.commit()
    n = q.shape[0]
    bad = np.flatnonzero(~pred.identified)
    d = _position_norms(pred.deflection)
    print(
        f"wrote {args.out}: {n} rows predicted with {args.model_file} "
        f"({len(model.labels)} springs, rank {model.rank}); largest |d| {_largest_mm(d)}"
    )
    if sag is not None:
        s = _position_norms(sag.deflection)
        print(f"sag under the arm's own weight (sag_dx..sag_dz): largest |sag| {_largest_mm(s)}")
    if not model.has_rotations:
        print("rotations unavailable: the model was identified without rotations (rx..rz, srx..srz empty)")
    if bad.size:
        print(
            f"warning: {bad.size} of {n} rows excite directions the identification data could not see "
            f"(first: line {bad[0] + 2} of {args.data}); they are marked identified=false, their values are "
            "a minimum-norm guess without standard deviations",
            file=sys.stderr,
        )
    return 0

def register(sub: Any) -> None:
    """Adds ``predict`` (with kind ``vjm``) to the subparsers ``sub`` of the main parser."""

    pre_sub = add_kinds(
        sub,
        "predict",
        help="predict tip deflections with a saved stiffness model",
        description="Predict tip deflections (with standard deviations) from a model saved by identify --save.",
    )
    pv = pre_sub.add_parser(
        "vjm",
        help="a serial arm",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Predict the tip deflection of a serial arm for each pose of POSES.csv under its wrench or "
        "a payload, from a saved VJM stiffness model.",
        epilog=PREDICT_EPILOG,
    )
    # dest model_file / data: the command's inputs, which no output may overwrite (cli._run).
    pv.add_argument("model_file", metavar="MODEL.json", help="stiffness model file (identify vjm --save)")
    pv.add_argument("data", metavar="POSES.csv", help="poses (q1..qn) and optionally fx..mz")
    pv.add_argument("--out", required=True, metavar="PRED.csv", help="predictions to write")
    pv.add_argument("--force", action="store_true", help=FORCE_HELP)
    pv.add_argument(
        "--payload",
        metavar="MASS[,cx,cy,cz]",
        help="a point mass in kg at (cx,cy,cz) m in the tip frame (default at the tip point), gravity "
        "9.80665 m/s² along −z of the base frame; instead of the fx..mz columns",
    )
    pv.add_argument("--allow-outside-limits", action="store_true",
                    help="accept joint angles outside the URDF limits (refused by default, as by identify: "
                    "degrees or a wrong joint order?)")
    add_robot_args(pv)
    add_gravity_args(pv, GRAVITY_DEFAULT_MODEL)
    pv.set_defaults(func=cmd_predict_vjm)
