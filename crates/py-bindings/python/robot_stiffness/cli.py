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

Each command is a module ``cli_<verb>`` with ``register(sub)`` (its parser) and its ``cmd_*``
functions; :data:`VERBS` lists them. What they share (the usage error, the robot and gravity
flags, input checks, progress) is in :mod:`robot_stiffness._cli_context`, the model file's side
(``--save``, the robot a model file names, ``--payload``) in :mod:`robot_stiffness._cli_model_file`.
This module holds the parser, the main loop and the exit statuses.
"""

from __future__ import annotations

import argparse
import os
import sys
import traceback
import warnings
from typing import Any, NoReturn, Optional, Sequence, Tuple

from . import (
    __version__,
    cli_compensate,
    cli_demo,
    cli_design,
    cli_diagnose,
    cli_identify,
    cli_predict,
    cli_simulate,
)
from ._cli_context import (
    CLI_NAMES,
    CliError,
    bundled_hint,
)
from ._cli_model_file import named_inputs
from ._errors import StiffnessError, SuspiciousDataWarning, reworded, rows_are_file_lines
from ._interrupt import (
    Cancelled,
    Terminated,
    cancel,
    flush_std_streams,
    signals_deferred,
    signals_raise,
    worker_running,
)
from ._outputs import Outputs

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


#: The commands, one module each, in the order ``--help`` lists them: ``register(sub)`` adds
#: the command's parser and sets its ``func(args, out)``; the main loop below runs it.
VERBS = (cli_simulate, cli_identify, cli_diagnose, cli_predict, cli_demo, cli_design, cli_compensate)


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
    for verb in VERBS:
        verb.register(sub)
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
            for path, what in named_inputs(args):  # the URDF and data a model file names
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
