"""The ``robot-stiffness`` console script.

Subcommands (``robot-stiffness COMMAND --help`` for each):

* ``design vjm --out PLAN.csv`` — plan a campaign's poses and wrenches;
* ``simulate vjm --out OUT.csv`` — a virtual measurement campaign on a robot with hidden effects;
* ``identify vjm DATA.csv`` / ``identify csjm DATA.csv`` — identify compliances / stiffness;
* ``simulate csjm --out OUT.csv`` / ``diagnose csjm DATA.csv`` — the same for a cable-driven joint;
* ``diagnose vjm DATA.csv`` — what the baseline model gets wrong, the cause, the gain;
* ``predict vjm MODEL.json POSES.csv`` / ``compensate vjm MODEL.json TRAJ.csv`` — use a saved
  stiffness model: predicted deflections, corrected joint targets;
* ``demo`` — simulate → diagnose → report on the bundled arm, in under a minute.

Every output path is checked before the computation starts; outputs are staged under
temporary names and renamed into place only once everything has succeeded, and an output
folder never loses a file the tool did not write (see :mod:`robot_stiffness._outputs`).
Any bad input gives one line on stderr and exit status 1 (2 for a bad flag); Ctrl-C exits
with 130 and SIGTERM with 143, removing every temporary.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import re
import sys
import time
import traceback
import warnings
from pathlib import Path
from typing import Any, Dict, Iterator, List, NoReturn, Optional, Sequence, Tuple

from . import __version__, cli_model
from . import _cli_types as T
from ._errors import DataFileError, StiffnessError, SuspiciousDataWarning, reworded, rows_are_file_lines
from ._interrupt import (
    Cancelled,
    Terminated,
    cancel,
    flush_std_streams,
    in_worker,
    signals_deferred,
    signals_raise,
    worker_running,
)
from ._outputs import Outputs
from ._cli_context import (
    CLI_NAMES,
    FORCE_HELP,
    CliError,
    add_gravity_args,
    add_robot_args,
    bundled_hint,
    check_input,
    clear_progress,
    data_file,
    gravity_of,
    gravity_words,
    progress_reporter,
    robot_of,
    show_progress,
)


PROG = "robot-stiffness"

EPILOG = """\
Measurement files are CSV with a header, SI units (m, rad, N, N·m), base-frame vectors:
  VJM : q1..qn, fx,fy,fz, mx,my,mz (wrench at the tip point), dx,dy,dz (tip displacement),
        optional rx,ry,rz, pose, set (train|test)
  CSJM: r11..r33 (platform orientation, row-major), tx,ty,tz (moment in the platform frame),
        ref (1 on the reference row)

Examples (a serial arm: plan → measure → identify → use):
  robot-stiffness demo
  robot-stiffness design vjm --poses 24 --out plan.csv       (measure at its rows: fill dx,dy,dz)
  robot-stiffness simulate vjm --out campaign.csv --effect joint_tilt:joint=3,axis=x,compliance=5e-5
  robot-stiffness identify vjm campaign.csv --model extended --json id.json --save model.json
  robot-stiffness diagnose vjm campaign.csv --json diagnosis.json --report report/
  robot-stiffness predict vjm model.json poses.csv --out pred.csv --payload 2.5
  robot-stiffness compensate vjm model.json trajectory.csv --out corrected.csv
  robot-stiffness identify vjm data.csv --urdf arm.urdf --base base_link --tip tool0 --json id.json
A cable-driven spherical joint:
  robot-stiffness simulate csjm --out csjm.csv --effect cable_hysteresis:friction=2
  robot-stiffness identify csjm csjm.csv --json k.json
  robot-stiffness diagnose csjm csjm.csv --json d.json --report csjm-report/

Gravity: simulate, design, identify, diagnose, predict, compensate and demo model the arm's own weight (link
masses from the URDF's <inertial> elements) under 9.80665 m/s² along −z of the base by default
(predict and compensate: the gravity the model file records); --gravity GX,GY,GZ for another mount
(0,0,9.80665 on a ceiling), --no-gravity for a weightless arm. Under gravity a link without
<inertial> is an error naming it.

Outputs: every output path is checked before the run. No output may be an input (or the URDF a
model file names); outputs are regular files (a FIFO, device, socket or symbolic link is refused). An existing
output file is replaced only with --force. A --report/--out folder is created if missing; an
existing non-empty one needs --force, and then only the files robot-stiffness wrote there earlier
(its signed .robot-stiffness-manifest.json) are replaced — nothing else is touched.
Exit status: 0 done, 1 error (one line on stderr), 2 bad flag, 130 Ctrl-C, 143 SIGTERM.
ROBOT_STIFFNESS_DEBUG=1 shows the traceback of an internal error.
"""


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors: ``robot-stiffness: error: argument --poses: …``."""

    def error(self, message: str) -> NoReturn:
        hint = f" (see {self.prog} --help)"
        self.exit(2, f"{PROG}: error: {' '.join(message.split())}{hint}\n")


def _json_text(obj: Any) -> str:
    def clean(x: Any) -> Any:
        if isinstance(x, float) and not math.isfinite(x):
            return None
        if isinstance(x, dict):
            return {k: clean(v) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [clean(v) for v in x]
        if hasattr(x, "tolist"):
            return clean(x.tolist())
        return x

    return json.dumps(clean(obj), indent=2, allow_nan=False) + "\n"


def _model_spec(text: str) -> Any:
    """A ``--model``/``--baseline`` value: the one model vocabulary, read by the core
    (``traditional``, ``extended``, ``J1z,J2x``, ``traditional + joint_tilt(J3x)`` as diagnose
    prints it)."""
    return text


# ----------------------------------------------------------------------------- simulate


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
        truth_out.write_text(_json_text({"truth": c.truth, "spec": c.spec}))
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
        truth_out.write_text(_json_text({"K": c.true_K, "K_D": c.true_K_D, "R0": c.true_R0, "effects": effects}))
    out.commit()
    names = ", ".join(e["effect"] for e in effects) or "none"
    print(f"wrote {path}: CSJM campaign, seed {args.seed}, hidden effects: {names}")
    _warn_positional_out(args)
    return 0


# ----------------------------------------------------------------------------- identify


def cmd_identify_vjm(args: argparse.Namespace, out: Outputs) -> int:
    from .vjm import read_measurements

    json_out = out.file(args.json, "--json") if args.json is not None else None
    save_out = cli_model.claim_save(args, out)
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
            _model_spec(args.model),
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
        json_out.write_text(_json_text(doc))
    cli_model.write_model(save_out, res)
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
        json_out.write_text(_json_text(doc))
    out.commit()
    print(f"K (N·m/rad, platform frame A at R0), order {fit.order}, {fit.n} load increments:")
    for row, err in zip(fit.K, fit.K_stderr):
        print("  " + "  ".join(f"{v:10.3f}" for v in row) + "   ± " + " ".join(f"{e:.2g}" for e in err))
    return 0


# ----------------------------------------------------------------------------- diagnose


def _diagnose(robot: Any, data: Any, args: argparse.Namespace, per_row: Optional[bool] = None) -> Any:
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
            baseline=None if args.baseline is None else _model_spec(args.baseline),
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


def _render(diagnosis: Any, directory: Path, args: argparse.Namespace, **kwargs: Any) -> None:
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
        json_out.write_text(_json_text(diagnosis.to_dict()))
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
    save_out = cli_model.claim_save(args, out)
    report_dir = _report_dir(out, args, REPORT_FILES)
    robot = robot_of(args)
    with data_file(args.data):
        data = in_worker(read_measurements, args.data, robot.n_joints)
    result = _diagnose(robot, data, args)
    saved = None
    if save_out is not None:
        from .vjm import diagnosed_model

        with data_file(args.data):
            saved = in_worker(diagnosed_model, robot, data, result, gravity=gravity_of(args),
                              data_file=data.source or args.data,
                              allow_outside_limits=args.allow_outside_limits)
        cli_model.write_model(save_out, saved.identification)
    _write_diagnosis(result, json_out, rows_out)
    if report_dir is not None:
        _render(result, report_dir, args, source=str(args.data))
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
    with data_file(args.data):
        result = in_worker(
            diagnose_csjm, args.data, fdr=args.fdr, holdout_seed=args.split_seed, project=args.project
        )
    _write_diagnosis(result, json_out, rows_out)
    if report_dir is not None:
        _render(result, report_dir, args, title="CSJM stiffness diagnosis", source=str(args.data))
    out.commit()
    for line in story(result):
        print(line)
    if args.report:
        print(f"report: {Path(args.report) / 'report.md'}")
    return 0


# ----------------------------------------------------------------------------- demo

DEMO_EFFECTS: List[Dict[str, Any]] = [
    {"effect": "joint_tilt", "joint": 2, "axis": "x", "compliance": 6e-5},
]


def _seed_study_lines(study: Any) -> List[str]:
    """The demo's two lines on the seed study: ours next to the seed's for the same metric
    (the seed's is the error of the deflection magnitude), then the vector error."""
    paper, trad, ext = study.paper, study.traditional, study.extended
    return [
        f"Seed study (Table I poses, truth at the seed's {100 * study.torsion_share:.1f} % torsion share), "
        f"error of the deflection magnitude (the seed's metric): traditional {100 * trad.magnitude.all:.2f} % → "
        f"extended {100 * ext.magnitude.all:.2f} % over the 26 tests (seed: {100 * paper.traditional_all:.2f} % → "
        f"{100 * paper.extended_all:.2f} %); worst verification test, extended: "
        f"{100 * ext.magnitude.verification_max:.1f} % at test {ext.magnitude.verification_max_test} "
        f"(seed: {100 * paper.extended_verification_max:.1f} % at test {paper.extended_verification_max_test}).",
        f"Seed study, error of the deflection vector ‖d_pred − d‖/‖d‖ (the seed does not report it): "
        f"traditional {100 * trad.vector.all:.2f} % → extended {100 * ext.vector.all:.2f} % over the 26 tests; "
        f"worst verification test, extended: {100 * ext.vector.verification_max:.1f} % at test "
        f"{ext.vector.verification_max_test}.",
    ]


def _structural_study_lines(study: Any) -> List[str]:
    """The demo's line on the seed study with compliant links: the three models in the seed's
    metric next to the seed's two figures."""
    paper, trad, ext, full = study.paper, study.traditional, study.extended, study.full
    return [
        f"Seed study with compliant links (truth: {100 * study.torsion_share:.1f} % torsion, links "
        f"{100 * study.link_share:.1f} %, sized so the extended model keeps the seed's "
        f"{100 * paper.extended_all:.2f} % without noise), magnitude error over the 26 tests: "
        f"traditional {100 * trad.magnitude.all:.2f} % → extended {100 * ext.magnitude.all:.2f} % → "
        f"full {100 * full.magnitude.all:.2f} % (6-D link springs, {study.full_rank} identifiable of 42; "
        f"seed: {100 * paper.traditional_all:.2f} % → {100 * paper.extended_all:.2f} %); worst "
        f"verification test: extended {100 * ext.magnitude.verification_max:.1f} % at test "
        f"{ext.magnitude.verification_max_test}, full {100 * full.magnitude.verification_max:.1f} % at "
        f"test {full.magnitude.verification_max_test}.",
    ]


def cmd_demo(args: argparse.Namespace, out: Outputs) -> int:
    from .report import REPORT_FILES, story
    from .vjm import Robot, seed_study, simulate

    t0 = time.monotonic()
    directory = Path(args.out)
    files = ["campaign.csv", "truth.json", "diagnosis.json"] + [f"report/{f}" for f in REPORT_FILES]
    staged = out.directory(directory, force=args.force, flag="--out", expected=files).path
    robot = Robot.bundled()
    gravity = gravity_of(args)
    campaign = in_worker(simulate, robot, DEMO_EFFECTS, n_poses=40, wrenches_per_pose=4, seed=args.seed,
                         gravity=gravity)
    # The report's residual plot draws the per-row predictions: keep them.
    result = _diagnose(robot, campaign.measurements, args, per_row=True)
    study = in_worker(seed_study, robot, seed=args.seed)
    structural = in_worker(seed_study, robot, links=True, seed=args.seed)
    (staged / "campaign.csv").write_text(campaign.csv, encoding="utf-8")
    (staged / "truth.json").write_text(_json_text({"truth": campaign.truth, "spec": campaign.spec}), encoding="utf-8")
    (staged / "diagnosis.json").write_text(_json_text(result.to_dict()), encoding="utf-8")
    report_dir = staged / "report"
    report_dir.mkdir()
    _render(result, report_dir, args, title="Stiffness diagnosis — demo on the bundled Panda",
            source="campaign.csv (simulated)")
    out.commit()
    hidden = ", ".join(
        f"{e['effect']} at joint {e['joint']} about {e['axis']} ({e['compliance']:.0e} rad/(N·m))" for e in DEMO_EFFECTS
    )
    print(f"Simulated {len(campaign.measurements)} measurements (40 poses × 4 wrenches, laser-tracker and F/T noise, "
          f"{gravity_words(gravity)}) on the bundled Franka Panda; hidden in the truth: {hidden}.")
    for line in story(result):
        print(line)
    for line in _seed_study_lines(study) + _structural_study_lines(structural):
        print(line)
    print(f"Wrote {directory}/ (campaign.csv, diagnosis.json, report/report.md) in {time.monotonic() - t0:.1f} s.")
    return 0


# ----------------------------------------------------------------------------- parser


REPORT_HELP = (
    "write a Markdown report with PNG plots into DIR (created if missing; an existing non-empty "
    "folder needs --force)"
)
ROWS_HELP = "also write the per-row data (measured, baseline and extended values) as CSV"
def _add_table_out(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", metavar="OUT.csv", help="measurement file to write (required)")
    parser.add_argument("out_positional", nargs="?", metavar="OUT.csv", help=argparse.SUPPRESS)


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog=PROG,
        description="Model, identify and diagnose the stiffness of robots: virtual-joint models (VJM) "
        "of serial arms from URDF and cable-driven spherical joints (CSJM).",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    # simulate
    sim = sub.add_parser("simulate", help="simulate a measurement campaign (virtual testbed)",
                         description="Simulate a measurement campaign from a true model with hidden effects.")
    sim_sub = sim.add_subparsers(dest="kind", metavar="KIND")
    sim_sub.required = True
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

    # identify
    ide = sub.add_parser("identify", help="identify compliances (VJM) or a stiffness matrix (CSJM)",
                         description="Identify stiffness parameters from a measurement file.")
    ide_sub = ide.add_subparsers(dest="kind", metavar="KIND")
    ide_sub.required = True
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
    cli_model.add_save_option(iv)
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

    # diagnose
    dia = sub.add_parser("diagnose", help="what the model gets wrong, the cause, the gain",
                         description="Diagnose a stiffness model on measured data.")
    dia_sub = dia.add_subparsers(dest="kind", metavar="KIND")
    dia_sub.required = True
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
    dc.add_argument("--split-seed", type=T.seed, default=None, help="seed of the held-out rows")
    dc.add_argument("--project", action="store_true", help="project orientation matrices onto SO(3)")
    dc.add_argument("--json", metavar="OUT.json", help="write the diagnosis as JSON (a summary: no per-row data)")
    dc.add_argument("--rows", metavar="ROWS.csv", help=ROWS_HELP)
    dc.add_argument("--report", metavar="DIR", help=REPORT_HELP)
    dc.add_argument("--force", action="store_true", help=FORCE_HELP)
    dc.set_defaults(func=cmd_diagnose_csjm)

    cli_model.add_commands(sub)  # predict

    # demo
    demo = sub.add_parser(
        "demo",
        help="simulate → diagnose → report on the bundled arm (< 1 min)",
        description="Simulate a campaign on the bundled Franka Panda with a hidden tilting compliance under "
        "standard gravity, diagnose it under the same gravity, write a report, and print the story.",
    )
    demo.add_argument("--out", default="robot-stiffness-demo", metavar="DIR",
                      help="output folder (default ./robot-stiffness-demo); created if missing, an "
                      "existing non-empty folder needs --force")
    demo.add_argument("--force", action="store_true", help=FORCE_HELP)
    demo.add_argument("--seed", type=T.seed, default=1, help="campaign seed (default 1)")
    demo.add_argument("--quiet", action="store_true", help="no progress display")
    add_gravity_args(demo)
    demo.set_defaults(func=cmd_demo, baseline=None, fdr=None, split_seed=None)
    from .cli_use import register as register_use_commands  # design, compensate

    register_use_commands(sub)
    return p


def _user_path(name: str, out: Outputs) -> str:
    """A path in an OS error with any temporary prefix replaced by the user's own output path."""
    for tmp, final in out.staged():
        if name == str(tmp) or name.startswith(str(tmp) + os.sep):
            return str(final) + name[len(str(tmp)):]
    return name


def _one_line(e: BaseException, out: Outputs) -> str:
    text = " ".join(str(e).split())
    if isinstance(e, StiffnessError):
        return text or type(e).__name__
    if isinstance(e, OSError) and e.filename:
        reason = "file not found" if isinstance(e, FileNotFoundError) else (e.strerror or type(e).__name__).lower()
        return f"{reason}: {_user_path(str(e.filename), out)}"
    return text or type(e).__name__


def _quiet_broken_pipe() -> None:
    """stdout's reader went away (``| head``): point stdout at /dev/null so that the final
    flush at exit does not complain (the recipe of the Python docs, signal/SIGPIPE note)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):
        pass


def _outcome(e: BaseException, out: Outputs) -> Tuple[int, Optional[str]]:
    """Exit status and stderr line for an exception that ended a command."""
    if isinstance(e, BrokenPipeError):
        _quiet_broken_pipe()
        return 0, None
    written = "the outputs were already written" if out.committed else "no output was written"
    if isinstance(e, KeyboardInterrupt):
        return 130, f"{PROG}: interrupted; {written}"
    if isinstance(e, Terminated):
        return 143, f"{PROG}: terminated; {written}"
    if isinstance(e, (StiffnessError, CliError, Cancelled, OSError)):
        return 1, f"{PROG}: error: {_one_line(e, out)}"
    # A bug: one line, the traceback only on request.
    if os.environ.get("ROBOT_STIFFNESS_DEBUG"):
        traceback.print_exception(type(e), e, e.__traceback__)
    return 1, (
        f"{PROG}: internal error ({type(e).__name__}: {_one_line(e, out)}); please report it with the "
        "command line and inputs (ROBOT_STIFFNESS_DEBUG=1 shows the traceback)"
    )


def _run(args: argparse.Namespace) -> int:
    cancel.clear()
    inputs = [getattr(args, k, None) for k in ("data", "urdf", "model_file")]
    out = Outputs(inputs=inputs, force=bool(getattr(args, "force", False)))
    with signals_raise():
        try:
            for path, what in cli_model.named_inputs(args):  # the URDF and data a model file names
                out.add_input(path, what)
            # The core's Python terms as the command line's flags; the arrays a command passes
            # on are a CSV file's rows, named by file line.
            with bundled_hint(args), reworded(CLI_NAMES), rows_are_file_lines():
                return int(args.func(args, out))
        except (Exception, KeyboardInterrupt, Terminated) as e:
            with signals_deferred():
                code, line = _outcome(e, out)
                out.discard()
            if line is not None:
                print(line, file=sys.stderr)
            return code
        finally:
            with signals_deferred():
                out.discard()


def _warning_lines() -> None:
    """The package's warnings (:class:`SuspiciousDataWarning`) as one ``robot-stiffness:
    warning: …`` line on stderr each, without Python's file and line; others as Python
    shows them."""
    python_way = warnings.showwarning

    def show(message: Any, category: Any, filename: str, lineno: int, file: Any = None,
             line: Optional[str] = None) -> None:
        if isinstance(category, type) and issubclass(category, SuspiciousDataWarning):
            print(f"{PROG}: warning: {' '.join(str(message).split())}", file=sys.stderr, flush=True)
        else:
            python_way(message, category, filename, lineno, file, line)

    warnings.showwarning = show


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of the ``robot-stiffness`` console script; returns the exit status.

    Exit status: 0 success, 1 a bad input or an error (one line on stderr), 2 a bad flag,
    130 Ctrl-C, 143 SIGTERM. Every temporary file is removed in all of these cases.
    Warnings about the data go to stderr as ``robot-stiffness: warning: …`` lines.
    """
    _warning_lines()
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except BrokenPipeError:  # `robot-stiffness --help | head -1`
        _quiet_broken_pipe()
        return 0
    try:
        code = _run(args)
    except KeyboardInterrupt:  # a second Ctrl-C while the first one was being handled
        code = 130
    except Terminated:
        code = 143
    if worker_running() or code in (130, 143):
        # Interrupted while the core may still be computing in the worker thread: nothing will
        # use its result, and the interpreter cannot finalize safely around a thread that is
        # inside native code and calls back into Python (the progress callback).
        flush_std_streams()
        os._exit(code)
    return code


if __name__ == "__main__":
    sys.exit(main())
