"""``diagnose vjm`` and ``diagnose csjm``: what the model gets wrong, the cause, the gain.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, Optional, Sequence

from . import _cli_types as T
from ._cli_context import (
    FORCE_HELP,
    add_gravity_args,
    add_kinds,
    add_robot_args,
    clear_progress,
    data_file,
    gravity_of,
    json_text,
    model_arg,
    progress_reporter,
    robot_of,
    show_progress,
)
from ._cli_model_file import claim_save, write_model
from ._interrupt import in_worker
from ._outputs import Outputs


def diagnose_data(robot: Any, data: Any, args: argparse.Namespace, per_row: Optional[bool] = None) -> Any:
    """``vjm.diagnose`` with the command's options; ``per_row`` (default: when ``--rows`` or
    ``--report`` will use them) keeps the per-row predictions the residual plot draws."""
    from .vjm import diagnose

    if per_row is None:
        per_row = getattr(args, "rows", None) is not None or getattr(args, "report", None) is not None

    show = show_progress(args)
    try:
        return in_worker(
            diagnose,
            robot,
            data,
            baseline=None if args.baseline is None else model_arg(args.baseline),
            fdr=args.fdr,
            split_seed=args.split_seed,
            progress=progress_reporter(show),
            allow_outside_limits=getattr(args, "allow_outside_limits", False),
            tracker_sigma=getattr(args, "tracker_sigma", None),
            force_sigma=getattr(args, "force_sigma", None),
            moment_sigma=getattr(args, "moment_sigma", None),
            gravity=gravity_of(args),
            per_row=per_row,  # per-row predictions only when something will use them
        )
    finally:
        clear_progress(show)


def render_report(diagnosis: Any, directory: Path, args: argparse.Namespace, **kwargs: Any) -> None:
    """The report: drawn in the worker thread with progress per plot (Ctrl-C is seen at once and
    stops it before its next plot), written here (only the main thread touches the outputs)."""
    from .report import render_files, save_files

    show = show_progress(args)
    try:
        files = in_worker(render_files, diagnosis, progress=progress_reporter(show, "report"), **kwargs)
    finally:
        clear_progress(show)
    save_files(files, directory)


def _write_diagnosis(diagnosis: Any, json_out: Any, rows_out: Any) -> None:
    """The JSON summary (no per-row data) and, on request, the rows as CSV."""
    if json_out is not None:
        json_out.write_text(json_text(diagnosis.to_dict()))
    if rows_out is not None:
        rows_out.write_chunks(diagnosis.rows.csv_chunks() if diagnosis.rows is not None else ())


def _report_dir(out: Outputs, args: argparse.Namespace, files: Sequence[str]) -> Optional[Path]:
    if args.report is None:
        return None
    return out.directory(args.report, force=args.force, flag="--report", expected=files).path


def cmd_diagnose_vjm(args: argparse.Namespace, out: Outputs) -> int:
    from .report import REPORT_FILES, story
    from .vjm import read_measurements

    json_out = out.file(args.json, "--json") if args.json is not None else None
    rows_out = out.file(args.rows, "--rows") if args.rows is not None else None
    save_out = claim_save(args, out)
    report_dir = _report_dir(out, args, REPORT_FILES)
    robot = robot_of(args)
    with data_file(args.data):
        data = in_worker(read_measurements, args.data, robot.n_joints)
    result = diagnose_data(robot, data, args)
    saved = None
    if save_out is not None:
        from .vjm import diagnosed_model

        with data_file(args.data):
            saved = in_worker(diagnosed_model, robot, data, result, gravity=gravity_of(args),
                              data_file=data.source or args.data,
                              allow_outside_limits=args.allow_outside_limits)
        write_model(save_out, saved.identification)
    _write_diagnosis(result, json_out, rows_out)
    if report_dir is not None:
        render_report(result, report_dir, args, source=str(args.data))
    out.commit()
    for line in story(result):
        print(line)
    if args.report:
        print(f"report: {Path(args.report) / 'report.md'}")
    if saved is not None:
        fixes = "".join(f"; {k} taken out of the rows" for k in saved.corrected)
        print(f"saved {args.save}: springs {saved.springs} identified on all {len(data)} rows{fixes}")
        for curve in saved.gear_curves:
            parts = []
            if curve.knots:
                parts.append(f"knots {', '.join(f'{t:.3g}' for t in curve.knots)} N·m, "
                             f"coefficients {', '.join(f'{a:.3g}' for a in curve.coefficients)} rad/(N·m)")
            if curve.lost_motion > 0.0:
                parts.append(f"lost motion {curve.lost_motion:.3g} rad")
            print(f"  with the gear curve of joint {curve.joint}: {'; '.join(parts)}")
        for label, why in saved.left_out:
            print(f"  not in the saved model: {label} ({why})")
    return 0


def cmd_diagnose_csjm(args: argparse.Namespace, out: Outputs) -> int:
    from .csjm import diagnose as diagnose_csjm
    from .report import CSJM_REPORT_FILES, story

    json_out = out.file(args.json, "--json") if args.json is not None else None
    rows_out = out.file(args.rows, "--rows") if args.rows is not None else None
    report_dir = _report_dir(out, args, CSJM_REPORT_FILES)
    show = show_progress(args)
    try:
        with data_file(args.data):
            result = in_worker(
                diagnose_csjm, args.data, fdr=args.fdr, split_seed=args.split_seed, project=args.project,
                progress=progress_reporter(show),
            )
    finally:
        clear_progress(show)
    _write_diagnosis(result, json_out, rows_out)
    if report_dir is not None:
        render_report(result, report_dir, args, title="CSJM stiffness diagnosis", source=str(args.data))
    out.commit()
    for line in story(result):
        print(line)
    if args.report:
        print(f"report: {Path(args.report) / 'report.md'}")
    return 0


REPORT_HELP = (
    "write a Markdown report with PNG plots into DIR (created if missing; an existing non-empty "
    "folder needs --force)"
)


ROWS_HELP = "also write the per-row data (measured, baseline and extended values) as CSV"


def register(sub: Any) -> None:
    """Adds ``diagnose`` (kinds ``vjm`` and ``csjm``) to the subcommand set ``sub``."""
    dia_sub = add_kinds(
        sub,
        "diagnose",
        help="what the model gets wrong, the cause, the gain",
        description="Diagnose a stiffness model on measured data.",
    )
    dv = dia_sub.add_parser(
        "vjm",
        help="a serial arm's VJM measurements",
        description="Fit the baseline on the training rows, show the structure of its residuals, name the "
        "effects that explain them (false-discovery-rate control, confirmed on held-out poses), extend the "
        "model and measure the gain on held-out poses.",
    )
    dv.add_argument("data", metavar="DATA.csv", help="VJM measurement file")
    add_robot_args(dv)
    dv.add_argument("--baseline", default=None, help="baseline " + T.MODEL_HELP)
    dv.add_argument("--fdr", type=T.probability, default=None,
                    help="false discovery rate, between 0 and 1 (default 0.01)")
    dv.add_argument("--split-seed", type=T.seed, default=None,
                    help="seed of the held-out poses when the file has no set column (default 0)")
    dv.add_argument("--json", metavar="OUT.json", help="write the diagnosis as JSON (a summary: no per-row data)")
    dv.add_argument("--rows", metavar="ROWS.csv", help=ROWS_HELP)
    dv.add_argument("--report", metavar="DIR", help=REPORT_HELP)
    dv.add_argument("--save", metavar="MODEL.json",
                    help="save the springs of the model the diagnosis found (baseline + tilts) identified on every row, "
                    "wrench bias and tracker-frame rotation taken out, with a found gear's curve, as a model file for "
                    "predict and compensate")
    dv.add_argument("--force", action="store_true", help=FORCE_HELP)
    dv.add_argument("--quiet", action="store_true", help="no progress display")
    dv.add_argument("--allow-outside-limits", action="store_true",
                    help="accept joint angles outside the URDF limits (refused by default: degrees or a wrong "
                    "joint order?)")
    dv.add_argument("--tracker-sigma", type=T.positive_float(0.01, "m"), default=None, metavar="M",
                    help="the tracker's per-axis displacement noise, m, at most 0.01 (given: the verdict adds a "
                    "goodness-of-fit test against it; not given: it rests on the lack-of-fit test alone)")
    dv.add_argument("--force-sigma", type=T.nonnegative_float(1e3, "N"), default=None, metavar="N",
                    help="the force sensor's per-axis noise, N, at most 1000")
    dv.add_argument("--moment-sigma", type=T.nonnegative_float(1e2, "N·m"), default=None, metavar="NM",
                    help="the force sensor's per-axis moment noise, N·m, at most 100")
    add_gravity_args(dv)
    dv.set_defaults(func=cmd_diagnose_vjm)
    dc = dia_sub.add_parser(
        "csjm",
        help="a cable-driven spherical joint's measurements",
        description="Fit the first-order model Δτ = c + K_D Δζ on training rows, show the structure of its "
        "residuals, name effects (platform_gravity, cable_hysteresis, cable_nonlinearity, connection_term), extend "
        "the model and measure the gain on held-out rows.",
    )
    dc.add_argument("data", metavar="DATA.csv", help="CSJM measurement file")
    dc.add_argument("--fdr", type=T.probability, default=None,
                    help="false discovery rate, between 0 and 1 (default 0.01)")
    dc.add_argument("--split-seed", type=T.seed, default=None, help="seed of the held-out rows (default 0)")
    dc.add_argument("--project", action="store_true", help="project orientation matrices onto SO(3)")
    dc.add_argument("--json", metavar="OUT.json", help="write the diagnosis as JSON (a summary: no per-row data)")
    dc.add_argument("--rows", metavar="ROWS.csv", help=ROWS_HELP)
    dc.add_argument("--report", metavar="DIR", help=REPORT_HELP)
    dc.add_argument("--force", action="store_true", help=FORCE_HELP)
    dc.add_argument("--quiet", action="store_true", help="no progress display")
    dc.set_defaults(func=cmd_diagnose_csjm)
