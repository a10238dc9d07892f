"""The ``robot-stiffness`` console script.

Subcommands (``robot-stiffness COMMAND --help`` for each):

* ``simulate vjm OUT.csv`` — a virtual measurement campaign on a robot with hidden effects;
* ``identify vjm DATA.csv`` / ``identify csjm DATA.csv`` — identify compliances / stiffness;
* ``simulate csjm OUT.csv`` / ``diagnose csjm DATA.csv`` — the same for a cable-driven joint;
* ``diagnose vjm DATA.csv`` — what the baseline model gets wrong, the cause, the gain;
* ``demo`` — simulate → diagnose → report on the bundled arm, in under a minute.

Outputs are written atomically (temporary file, then rename) and only once everything has
succeeded. Any bad input gives one line on stderr and exit status 1.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

from . import __version__, cli_model
from ._errors import StiffnessError

PROG = "robot-stiffness"

EPILOG = """\
Measurement files are CSV with a header, SI units (m, rad, N, N·m), base-frame vectors:
  VJM : q1..qn, fx,fy,fz, mx,my,mz (wrench at the tip point), dx,dy,dz (tip displacement),
        optional rx,ry,rz, pose, set (train|test)
  CSJM: r11..r33 (platform orientation, row-major), tx,ty,tz (moment in the platform frame),
        ref (1 on the reference row)

Examples:
  robot-stiffness demo
  robot-stiffness simulate vjm campaign.csv --effect joint_tilt:joint=3,axis=x,compliance=5e-5
  robot-stiffness identify vjm campaign.csv --model extended --json id.json
  robot-stiffness diagnose vjm campaign.csv --json diagnosis.json --report report/
  robot-stiffness simulate csjm csjm.csv --effect cable_hysteresis:friction=2
  robot-stiffness identify csjm csjm.csv --json k.json
  robot-stiffness diagnose csjm csjm.csv --json d.json --report csjm-report/
  robot-stiffness identify vjm data.csv --urdf arm.urdf --base base_link --tip tool0 --json id.json
"""


class CliError(Exception):
    """A usage problem found after parsing (reported like a data error)."""


# ----------------------------------------------------------------------------- outputs


class Outputs:
    """Stages output files and directories under temporary names; :meth:`commit` renames them
    into place at the very end, so a failure leaves nothing behind."""

    def __init__(self) -> None:
        self._staged: List[Tuple[Path, Path]] = []

    def _tmp_for(self, final: Path, directory: bool) -> Path:
        parent = final.parent if str(final.parent) else Path(".")
        if not parent.is_dir():
            raise CliError(f"output directory {parent} does not exist")
        if directory:
            if final.exists() and not final.is_dir():
                raise CliError(f"{final} exists and is not a directory")
            tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.tmp-", dir=parent))
        else:
            if final.is_dir():
                raise CliError(f"{final} is a directory, expected a file name")
            fd, name = tempfile.mkstemp(prefix=f".{final.name}.tmp-", dir=parent)
            os.close(fd)
            tmp = Path(name)
        self._staged.append((tmp, final))
        return tmp

    def file(self, final: str, text: str) -> None:
        """Stage ``text`` for the file ``final``."""
        tmp = self._tmp_for(Path(final), directory=False)
        tmp.write_text(text, encoding="utf-8")

    def directory(self, final: str) -> Path:
        """A temporary directory to fill, renamed to ``final`` on commit."""
        return self._tmp_for(Path(final), directory=True)

    def commit(self) -> None:
        for tmp, final in self._staged:
            if tmp.is_dir():
                old = None
                if final.exists():
                    old = final.with_name(f".{final.name}.old-{os.getpid()}")
                    os.replace(final, old)
                os.chmod(tmp, 0o755)
                os.replace(tmp, final)
                if old is not None:
                    shutil.rmtree(old, ignore_errors=True)
            else:
                os.chmod(tmp, 0o644)
                os.replace(tmp, final)
        self._staged.clear()

    def discard(self) -> None:
        for tmp, _ in self._staged:
            if tmp.is_dir():
                shutil.rmtree(tmp, ignore_errors=True)
            else:
                try:
                    tmp.unlink()
                except OSError:
                    pass
        self._staged.clear()


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


# ----------------------------------------------------------------------------- robot


def _add_robot_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("robot (default: the bundled 7-DoF Franka Emika Panda, panda_link0 → panda_link8)")
    g.add_argument("--urdf", metavar="FILE", help="URDF file of the robot")
    g.add_argument("--base", metavar="LINK", help="base link (required with --urdf)")
    g.add_argument("--tip", metavar="LINK", help="tip link; the tip point is its origin (required with --urdf)")


def _robot(args: argparse.Namespace) -> Any:
    from .vjm import Robot

    if args.urdf is None:
        if args.base is not None and args.base != "panda_link0":
            raise CliError("--base needs --urdf (the bundled arm's base is panda_link0)")
        return Robot.bundled(args.tip)
    if not args.base or not args.tip:
        raise CliError("--urdf needs both --base LINK and --tip LINK")
    return Robot.from_urdf(args.urdf, args.base, args.tip)


def _model_spec(text: str) -> Any:
    if text in ("traditional", "extended"):
        return text
    return [s.strip() for s in text.split(",") if s.strip()]


# ----------------------------------------------------------------------------- simulate


def _parse_value(key: str, text: str) -> Any:
    if key == "axis" or key == "effect":
        return text
    if key == "joint":
        try:
            return int(text)
        except ValueError:
            raise CliError(f"effect parameter joint={text!r} must be an integer (1-based)") from None
    parts = text.replace(";", "/").split("/")
    try:
        values = [float(v) for v in parts]
    except ValueError:
        raise CliError(f"effect parameter {key}={text!r} must be a number or numbers separated by '/'") from None
    return values if len(values) > 1 or key in ("bias", "rotation") else values[0]


def parse_effect(spec: str) -> Dict[str, Any]:
    """``"joint_tilt:joint=3,axis=x,compliance=5e-5"`` → ``{"effect": "joint_tilt", ...}``."""
    name, _, rest = spec.partition(":")
    effect: Dict[str, Any] = {"effect": name.strip()}
    for item in filter(None, (s.strip() for s in rest.split(","))):
        key, eq, value = item.partition("=")
        if not eq:
            raise CliError(f"--effect {spec!r}: expected key=value, got {item!r}")
        effect[key.strip()] = _parse_value(key.strip(), value.strip())
    return effect


def cmd_simulate(args: argparse.Namespace, out: Outputs) -> int:
    from .vjm import simulate

    robot = _robot(args)
    effects = [parse_effect(e) for e in args.effect or []]
    c = simulate(
        robot,
        effects,
        n_poses=args.poses,
        wrenches_per_pose=args.wrenches_per_pose,
        seed=args.seed,
        noise=not args.no_noise,
        force_max=args.force_max,
        moment_max=args.moment_max,
    )
    out.file(args.out, c.csv)
    if args.truth:
        out.file(args.truth, _json_text({"truth": c.truth, "spec": c.spec}))
    out.commit()
    names = ", ".join(e["effect"] for e in effects) or "none (torsional springs only)"
    print(f"wrote {args.out}: {len(c.measurements)} rows ({args.poses} poses × {args.wrenches_per_pose} wrenches), "
          f"seed {args.seed}, hidden effects: {names}")
    return 0


def cmd_simulate_csjm(args: argparse.Namespace, out: Outputs) -> int:
    from .csjm import simulate as simulate_csjm

    effects = [parse_effect(e) for e in args.effect or []]
    c = simulate_csjm(effects, seed=args.seed, increments=args.increments, max_increment=args.max_increment)
    out.file(args.out, c.csv)
    if args.truth:
        out.file(args.truth, _json_text({"K": c.true_K, "K_D": c.true_K_D, "R0": c.true_R0, "effects": effects}))
    out.commit()
    names = ", ".join(e["effect"] for e in effects) or "none"
    print(f"wrote {args.out}: CSJM campaign, seed {args.seed}, hidden effects: {names}")
    return 0


# ----------------------------------------------------------------------------- identify


def cmd_identify_vjm(args: argparse.Namespace, out: Outputs) -> int:
    from .vjm import read_measurements

    robot = _robot(args)
    data = read_measurements(args.data, robot.n_joints)
    res = robot.identify(
        data.q,
        data.wrench,
        data.displacement,
        _model_spec(args.model),
        rotation=data.rotation if args.use_rotations else None,
        nonnegative=args.nonnegative,
        method=args.method,
        data_file=args.data,
    )
    doc = res.to_dict()
    if args.json:
        out.file(args.json, _json_text(doc))
    cli_model.stage_model(args, res, out)
    out.commit()
    print(f"{res.model} model: {res.n_params} parameters, rank {res.rank} from {len(data)} measurements")
    for label, c, s, ok in zip(res.labels, res.compliance, res.stderr, res.identifiable):
        if ok:
            print(f"  {label:>5}  {c: .4e} ± {s:.1e} rad/(N·m)")
        else:
            print(f"  {label:>5}  not identifiable alone")
    if res.rank < res.n_params:
        print("identifiable combinations:")
        for comb in res.combinations:
            print(f"  {comb.label} = {comb.value:.4e}")
    return 0


def cmd_identify_csjm(args: argparse.Namespace, out: Outputs) -> int:
    from .csjm import identify_csv

    fit = identify_csv(args.data, order=args.order, project=args.project)
    doc = fit.to_dict()
    if args.json:
        out.file(args.json, _json_text(doc))
    out.commit()
    print(f"K (N·m/rad, platform frame A at R0), order {fit.order}, {fit.n} load increments:")
    for row, err in zip(fit.K, fit.K_stderr):
        print("  " + "  ".join(f"{v:10.3f}" for v in row) + "   ± " + " ".join(f"{e:.2g}" for e in err))
    return 0


# ----------------------------------------------------------------------------- diagnose


def _progress_printer(enabled: bool) -> Optional[Callable[[str, int, int], None]]:
    if not enabled:
        return None
    start = time.monotonic()

    def report(stage: str, done: int, total: int) -> None:
        sys.stderr.write(f"\r  diagnose: {stage} {done}/{total} ({time.monotonic() - start:.1f} s)\x1b[K")
        sys.stderr.flush()

    return report


def _diagnose(robot: Any, data: Any, args: argparse.Namespace) -> Any:
    from .vjm import diagnose

    show = sys.stderr.isatty() and not getattr(args, "quiet", False)
    try:
        return diagnose(
            robot,
            data,
            baseline=None if args.baseline is None else _model_spec(args.baseline),
            fdr=args.fdr,
            split_seed=args.split_seed,
            progress=_progress_printer(show),
        )
    finally:
        if show:
            sys.stderr.write("\r\x1b[K")
            sys.stderr.flush()


def cmd_diagnose_vjm(args: argparse.Namespace, out: Outputs) -> int:
    from .report import render_report, story
    from .vjm import read_measurements

    robot = _robot(args)
    data = read_measurements(args.data, robot.n_joints)
    result = _diagnose(robot, data, args).to_dict()
    if args.json:
        out.file(args.json, _json_text(result))
    if args.report:
        render_report(result, out.directory(args.report), source=str(args.data))
    out.commit()
    for line in story(result):
        print(line)
    if args.report:
        print(f"report: {Path(args.report) / 'report.md'}")
    return 0


def cmd_diagnose_csjm(args: argparse.Namespace, out: Outputs) -> int:
    from .csjm import diagnose as diagnose_csjm
    from .report import render_report, story

    result = diagnose_csjm(args.data, fdr=args.fdr, holdout_seed=args.split_seed, project=args.project).to_dict()
    if args.json:
        out.file(args.json, _json_text(result))
    if args.report:
        render_report(result, out.directory(args.report), title="CSJM stiffness diagnosis", source=str(args.data))
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


def cmd_demo(args: argparse.Namespace, out: Outputs) -> int:
    from .report import render_report, story
    from .vjm import Robot, seed_study, simulate

    t0 = time.monotonic()
    robot = Robot.bundled()
    campaign = simulate(robot, DEMO_EFFECTS, n_poses=40, wrenches_per_pose=4, seed=args.seed)
    result = _diagnose(robot, campaign.measurements, args).to_dict()
    study = seed_study(robot, seed=args.seed)
    directory = Path(args.out)
    staged = out.directory(str(directory))
    (staged / "campaign.csv").write_text(campaign.csv, encoding="utf-8")
    (staged / "truth.json").write_text(_json_text({"truth": campaign.truth, "spec": campaign.spec}), encoding="utf-8")
    (staged / "diagnosis.json").write_text(_json_text(result), encoding="utf-8")
    report_dir = staged / "report"
    report_dir.mkdir()
    render_report(result, report_dir, title="Stiffness diagnosis — demo on the bundled Panda",
                  source="campaign.csv (simulated)")
    out.commit()
    hidden = ", ".join(
        f"{e['effect']} at joint {e['joint']} about {e['axis']} ({e['compliance']:.0e} rad/(N·m))" for e in DEMO_EFFECTS
    )
    print(f"Simulated {len(campaign.measurements)} measurements (40 poses × 4 wrenches, laser-tracker and F/T noise) "
          f"on the bundled Franka Panda; hidden in the truth: {hidden}.")
    for line in story(result):
        print(line)
    print(f"Seed study (Table I poses): traditional {100 * study['traditional_verification_error']:.2f} % → "
          f"extended {100 * study['extended_verification_error']:.2f} % verification error "
          f"(the seed paper reports 7.75 % → 3.74 %).")
    print(f"Wrote {directory}/ (campaign.csv, diagnosis.json, report/report.md) in {time.monotonic() - t0:.1f} s.")
    return 0


# ----------------------------------------------------------------------------- parser


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
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
        "wrenches at the tip, laser-tracker and F/T-sensor noise. Writes a VJM measurement file with "
        "pose and set (train/test) columns.",
        epilog="""\
effects (--effect NAME:key=value,...; joints are 1-based, base → tip; SI units):
  joint_tilt:joint=3,axis=x,compliance=5e-5          tilting compliance, rad/(N·m)
  joint_torsion_nonlinear:joint=2,ratio=2,t1=5,t2=15  harmonic-drive stiffening (ratio per segment, N·m)
  joint_backlash:joint=2,lost_motion=2e-4             lost motion, rad
  wrench_bias:bias=2/0/-2/0/0.2/0                     recorded wrench offset fx/fy/fz/mx/my/mz (N, N·m)
  frame_misalignment:rotation=0.01/-0.005/0           tracker frame rotation vector, rad
  geometric_nonlinearity                              load-dependent Jacobian (K_C)
""",
    )
    sv.add_argument("out", metavar="OUT.csv", help="measurement file to write")
    _add_robot_args(sv)
    sv.add_argument("--effect", action="append", metavar="SPEC", help="hidden effect in the truth (repeatable)")
    sv.add_argument("--poses", type=int, default=40, help="number of configurations (default 40)")
    sv.add_argument("--wrenches-per-pose", type=int, default=4, help="wrenches per configuration (default 4)")
    sv.add_argument("--force-max", type=float, default=None, help="largest force magnitude, N (default 80)")
    sv.add_argument("--moment-max", type=float, default=None, help="largest moment magnitude, N·m (default 3)")
    sv.add_argument("--seed", type=int, default=0, help="random seed; same seed, same file (default 0)")
    sv.add_argument("--no-noise", action="store_true", help="no instrument noise")
    sv.add_argument("--truth", metavar="TRUTH.json", help="also write the hidden true model as JSON")
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
    sc.add_argument("out", metavar="OUT.csv", help="measurement file to write")
    sc.add_argument("--effect", action="append", metavar="SPEC", help="hidden effect (repeatable)")
    sc.add_argument("--increments", type=int, default=None, help="load increments (default 85, as the seed)")
    sc.add_argument("--max-increment", type=float, default=None, help="largest load increment, N·m (default 1)")
    sc.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    sc.add_argument("--truth", metavar="TRUTH.json", help="also write the true stiffness as JSON")
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
        "data cannot identify are reported as null with the identifiable combinations.",
    )
    iv.add_argument("data", metavar="DATA.csv", help="VJM measurement file")
    _add_robot_args(iv)
    iv.add_argument("--model", default="traditional",
                    help="traditional (torsion only), extended (3 springs per joint) or labels like J1z,J2x (default traditional)")
    iv.add_argument("--use-rotations", action="store_true", help="also use the rx,ry,rz columns")
    iv.add_argument("--nonnegative", action="store_true", help="constrain compliances to be ≥ 0")
    iv.add_argument("--method", choices=("auto", "normal_equations", "qr"), default="auto",
                    help="streaming reduction (default auto: normal equations, QR when κ > 1e4)")
    iv.add_argument("--json", metavar="OUT.json", help="write the result as JSON")
    cli_model.add_save_option(iv)
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
    _add_robot_args(dv)
    dv.add_argument("--baseline", default=None, help="baseline model (default traditional)")
    dv.add_argument("--fdr", type=float, default=None, help="false discovery rate (default 0.01)")
    dv.add_argument("--split-seed", type=int, default=None,
                    help="seed of the held-out poses when the file has no set column (default 0)")
    dv.add_argument("--json", metavar="OUT.json", help="write the diagnosis as JSON")
    dv.add_argument("--report", metavar="DIR", help="write a Markdown report with PNG plots into DIR")
    dv.add_argument("--quiet", action="store_true", help="no progress display")
    dv.set_defaults(func=cmd_diagnose_vjm)
    dc = dia_sub.add_parser(
        "csjm",
        help="a cable-driven spherical joint's measurements",
        description="Fit the first-order model Δτ = c + K_D Δζ on training rows, show the structure of its "
        "residuals, name effects (platform_gravity, cable_hysteresis, cable_nonlinearity, connection_term), extend "
        "the model and measure the gain on held-out rows.",
    )
    dc.add_argument("data", metavar="DATA.csv", help="CSJM measurement file")
    dc.add_argument("--fdr", type=float, default=None, help="false discovery rate (default 0.05)")
    dc.add_argument("--split-seed", type=int, default=None, help="seed of the held-out rows")
    dc.add_argument("--project", action="store_true", help="project orientation matrices onto SO(3)")
    dc.add_argument("--json", metavar="OUT.json", help="write the diagnosis as JSON")
    dc.add_argument("--report", metavar="DIR", help="write a Markdown report with PNG plots into DIR")
    dc.set_defaults(func=cmd_diagnose_csjm)

    cli_model.add_commands(sub)  # predict

    # demo
    demo = sub.add_parser(
        "demo",
        help="simulate → diagnose → report on the bundled arm (< 1 min)",
        description="Simulate a campaign on the bundled Franka Panda with a hidden tilting compliance, diagnose "
        "it, write a report, and print the story.",
    )
    demo.add_argument("--out", default="robot-stiffness-demo", metavar="DIR",
                      help="output directory (default ./robot-stiffness-demo)")
    demo.add_argument("--seed", type=int, default=1, help="campaign seed (default 1)")
    demo.add_argument("--quiet", action="store_true", help="no progress display")
    demo.set_defaults(func=cmd_demo, baseline=None, fdr=None, split_seed=None)
    return p


def _one_line(e: BaseException) -> str:
    text = " ".join(str(e).split())
    if isinstance(e, StiffnessError):
        return text or type(e).__name__
    if isinstance(e, FileNotFoundError) and e.filename:
        return f"file not found: {e.filename}"
    return text or type(e).__name__


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of the ``robot-stiffness`` console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    out = Outputs()
    try:
        return int(args.func(args, out))
    except (StiffnessError, CliError, OSError, ValueError) as e:
        out.discard()
        print(f"{PROG}: error: {_one_line(e)}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        out.discard()
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    finally:
        out.discard()


if __name__ == "__main__":
    sys.exit(main())
