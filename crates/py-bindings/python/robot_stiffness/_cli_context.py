"""What every command of the CLI shares: the usage error, the robot and gravity options, the
checks of input files, the progress display.

The command modules (``cli`` and its verbs ``cli_<verb>``) import it; it imports none of them, so
that there is one :class:`CliError` whatever module runs as ``__main__``.
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
from pathlib import Path
from typing import Any, Callable, Iterator, Optional, Tuple

from . import _cli_types as T
from ._errors import DataFileError, StiffnessError, reworded
from ._interrupt import Cancelled, cancel


class CliError(Exception):
    """A usage problem found after parsing (reported like a data error)."""



FORCE_HELP = (
    "replace existing output files; in a non-empty output folder replace only the files "
    "robot-stiffness wrote there earlier (listed in its signed .robot-stiffness-manifest.json), "
    "every other file is left alone"
)


def add_kinds(sub: Any, command: str, help: str, description: str) -> Any:
    """Adds ``command`` to the subcommand set ``sub`` and returns its required ``KIND`` set
    (``vjm``, ``csjm``): every command but ``demo`` is ``robot-stiffness COMMAND KIND ...``."""
    parser = sub.add_parser(command, help=help, description=description)
    kinds = parser.add_subparsers(dest="kind", metavar="KIND")
    kinds.required = True
    return kinds


# ----------------------------------------------------------------------------- robot


def add_robot_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("robot (default: the bundled 7-DoF Franka Emika Panda, panda_link0 → panda_link8)")
    g.add_argument("--urdf", metavar="FILE", help="URDF file of the robot")
    g.add_argument("--base", metavar="LINK", help="base link (required with --urdf)")
    g.add_argument("--tip", metavar="LINK", help="tip link; the tip point is its origin (required with --urdf)")


GRAVITY_HELP = (
    "the gravity the arm was measured or is used under, m/s² in the base frame (default {default}; "
    "0,0,-9.80665 is a floor-mounted arm whose base z points up, 0,0,9.80665 a ceiling mount); the "
    "links' masses come from the URDF's <inertial> elements"
)
GRAVITY_DEFAULT = "0,0,-9.80665"
#: The default of the commands that read a model file (predict, compensate).
GRAVITY_DEFAULT_MODEL = "the gravity the model was identified under, 0,0,-9.80665 when it records none"


def add_gravity_args(p: argparse.ArgumentParser, default: str = GRAVITY_DEFAULT) -> None:
    """``--gravity GX,GY,GZ`` / ``--no-gravity``: one pair of flags for every command that models
    the arm's weight (simulate, design, identify, diagnose, predict, compensate, demo)."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--gravity", type=T.gravity, default=None, metavar="GX,GY,GZ",
                   help=GRAVITY_HELP.format(default=default))
    g.add_argument("--no-gravity", action="store_true",
                   help="a weightless arm (no inertials needed): the arm's own weight is left out")


def gravity_of(args: argparse.Namespace) -> Optional[Tuple[float, float, float]]:
    """The gravity of a command's flags: ``--gravity``, None for ``--no-gravity``, else the default."""
    from ._arguments import DEFAULT_GRAVITY

    if not hasattr(args, "no_gravity") or args.no_gravity:
        return None
    given = getattr(args, "gravity", None)
    return DEFAULT_GRAVITY if given is None else given


def model_gravity_of(args: argparse.Namespace) -> Any:
    """The gravity of a command that reads a model file: ``--gravity``, None for
    ``--no-gravity``, else the model's own (``RECORDED_GRAVITY``)."""
    from ._arguments import RECORDED_GRAVITY

    if args.no_gravity:
        return None
    return RECORDED_GRAVITY if args.gravity is None else args.gravity


def gravity_words(g: Optional[Tuple[float, float, float]]) -> str:
    """``under gravity 0,0,-9.80665 m/s²`` or ``weightless``: what a command's output says."""
    return "weightless" if g is None else f"under gravity {','.join(f'{v:g}' for v in g)} m/s²"


def robot_of(args: argparse.Namespace) -> Any:
    from .vjm import Robot

    if args.urdf is None:
        if args.base is not None and args.base != "panda_link0":
            raise CliError("--base needs --urdf (the bundled arm's base is panda_link0)")
        return Robot.bundled(args.tip)
    if not args.base or not args.tip:
        raise CliError("--urdf needs both --base LINK and --tip LINK (only predict and compensate take them "
                       "from the model file)")
    check_input(args.urdf, "--urdf")
    return Robot.from_urdf(args.urdf, args.base, args.tip)


_NOT_THE_PANDA = re.compile(r"joint columns but the chain has (\d+) actuated joints|outside the joint's limits")


@contextlib.contextmanager
def bundled_hint(args: argparse.Namespace) -> Iterator[None]:
    """Data that do not fit the bundled Panda, which a command without ``--urdf`` (and without a
    model file naming its robot) falls back to: the error says so and how to name another arm,
    besides the advice about the data themselves (``--allow-outside-limits``)."""
    try:
        yield
    except (StiffnessError, CliError) as e:
        text = str(e)
        m = _NOT_THE_PANDA.search(text)
        if m is None or getattr(args, "urdf", "") is not None or getattr(args, "model_file", None):
            raise
        tip = getattr(args, "tip", None)
        joints = f"{m.group(1)} joints" if m.group(1) else ("7 joints" if tip is None else f"tip {tip}")
        raise type(e)(f"{text}; this is the bundled Panda ({joints}, no --urdf given): pass --urdf ROBOT.urdf "
                      "--base LINK --tip LINK for another arm") from None


#: The Python spelling of an option in a message (the Python API's errors name its arguments,
#: ``crates/py-bindings/src/errors.rs`` words the core's advice so) → the command line's flag.
CLI_NAMES = {
    "project=True": "--project",
    "RotationPolicy::Project": "--project",
    # A link without <inertial> while gravity is on (every command that models the weight).
    "(or turn gravity off)": "(or pass --no-gravity for a weightless arm)",
    "or turn gravity off": "or pass --no-gravity for a weightless arm",
    "gravity=None": "--no-gravity",
    "(load_only=True)": "(--load-only)",
    # Joint angles outside the URDF limits.
    "allow_outside_limits=True": "--allow-outside-limits",
    # A model file of another schema, or edited.
    "identify again and save the model (Identification.save)": "identify again with --save",
}


def check_input(path: str, what: str) -> None:
    """An input file must be a readable regular file (checked before anything is computed)."""
    p = Path(path)
    if not path:
        raise CliError(f"{what}: empty file name")
    if not p.exists():
        raise CliError(f"{what} {path}: no such file")
    if p.is_dir():
        raise CliError(f"{what} {path} is a folder, expected a file")
    if not os.access(p, os.R_OK):
        raise CliError(f"{what} {path}: permission denied")
    if p.is_file() and p.stat().st_size == 0:
        raise CliError(f"{what} {path} is empty")


@contextlib.contextmanager
def data_file(path: str) -> Iterator[None]:
    """Name the measurement file in its errors (the core names only line and column)."""
    check_input(path, "DATA.csv")
    try:
        with reworded(CLI_NAMES):
            yield
    except DataFileError as e:
        text = " ".join(str(e).split())
        if path in text:
            raise
        raise CliError(f"{path}: {text}") from None


# ----------------------------------------------------------------------------- progress


def progress_reporter(enabled: bool, what: str = "diagnose") -> Callable[[str, int, int], None]:
    """The progress callback of the core (and of the report): shows progress on a terminal when
    ``enabled`` and stops the computation (raises :class:`Cancelled`) once the command was
    interrupted."""
    start = time.monotonic()

    def report(stage: str, done: int, total: int) -> None:
        if cancel.is_set():
            raise Cancelled("interrupted")
        if enabled:
            sys.stderr.write(f"\r  {what}: {stage} {done}/{total} ({time.monotonic() - start:.1f} s)\x1b[K")
            sys.stderr.flush()

    return report


def show_progress(args: argparse.Namespace) -> bool:
    return sys.stderr.isatty() and not getattr(args, "quiet", False)


def clear_progress(show: bool) -> None:
    if show:
        sys.stderr.write("\r\x1b[K")
        sys.stderr.flush()


# ----------------------------------------------------------------------------- outputs and flags


def json_text(obj: Any) -> str:
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


def model_arg(text: str) -> Any:
    """A ``--model``/``--baseline`` value: the one model vocabulary, read by the core
    (``traditional``, ``extended``, ``J1z,J2x``, ``traditional + joint_tilt(J3x)`` as diagnose
    prints it)."""
    return text
