"""The stiffness model file on the command line: ``--save`` (identify, diagnose), the robot and
the campaign a model file names (predict, compensate), a ``--payload``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any, List, Optional, Tuple

from ._cli_context import (
    CliError,
    check_input,
    robot_of,
)

#: The core's name of a bad payload, as the command line spells it (predict and compensate).
PAYLOAD_NAMES = {"invalid payload:": "--payload:"}

def add_save_option(parser: argparse.ArgumentParser) -> None:
    """``--save MODEL.json`` on ``identify vjm``."""
    parser.add_argument(
        "--save",
        metavar="MODEL.json",
        help="write the stiffness model file (for predict; see docs/model-file.md)",
    )

def claim_save(args: argparse.Namespace, out: Any) -> Any:
    """Reserves the ``--save`` output (before any work, so a bad path fails first); None without."""
    return out.file(args.save, "--save") if getattr(args, "save", None) is not None else None

def write_model(staged: Any, result: Any) -> None:
    """Fills the reserved ``--save`` output with the model file of ``result`` (an Identification),
    recording the URDF relative to the file's final place (``urdf_relative``)."""
    if staged is not None:
        staged.write_text(result.stiffness_model._text_at(staged.final))

def parse_payload(text: str) -> List[float]:
    parts = [p.strip() for p in text.split(",")]
    if len(parts) not in (1, 4):
        raise CliError(f"--payload {text!r}: expected MASS or MASS,cx,cy,cz (kg, m in the tip frame)")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise CliError(f"--payload {text!r}: expected numbers, MASS or MASS,cx,cy,cz (kg, m)") from None
    return values + [0.0] * (4 - len(values))

def _recorded_robot(path: str) -> Optional[dict]:
    """The ``robot`` record of a model file (``urdf``, ``base``, ``tip``) with where its URDF
    is: ``found``, the file to load (None when absent from every place ``tried``), or None when
    the file cannot be read as one (the loader then reports what is wrong). The core reads it
    with the loader's size and nesting bounds: Python's ``json`` recurses (RecursionError on
    200 000 nested ``[``); it looks for the URDF at the recorded absolute path, relative to the
    model file's folder (``urdf_relative``), then as recorded relative to the current folder,
    preferring a file with the recorded content (vjm::stiffness_model::RecordedRobot)."""
    from . import _core

    if not Path(path).is_file():  # a FIFO would block; a folder or a missing file is reported later
        return None
    rec = _core.vjm_model_file_robot(path)
    if rec is None:
        return None
    urdf, base, tip, found, tried = rec
    return {"urdf": urdf, "base": base, "tip": tip, "found": found, "tried": list(tried)}

def _recorded_data(path: str) -> List[str]:
    """Where the campaign a model file was identified from may be: its recorded name as given
    and beside the model file (only the name is recorded). Read after the core has bounded the
    file (``_recorded_robot``), so Python's ``json`` cannot recurse deeply here."""
    try:
        doc = json.loads(Path(path).read_text(encoding="utf-8"))
        name = doc["model"]["data"]["file"]
    except (OSError, ValueError, KeyError, TypeError):
        return []
    if not isinstance(name, str) or not name:
        return []
    return [c for c in {name, str(Path(path).parent / name)} if Path(c).is_file()]

def named_inputs(args: argparse.Namespace) -> List[Tuple[str, str]]:
    """The files the command's model file names (its URDF and the campaign it was identified
    from), with what they are: inputs that no output may replace, even when ``--urdf``
    overrides the robot."""
    model_file = getattr(args, "model_file", None)
    if not model_file:
        return []
    from .model import recorded_urdf

    robot = _recorded_robot(model_file)
    if robot is None:
        return []
    urdf = robot.get("found") or recorded_urdf(robot)  # the one loaded, else the one recorded
    named = [] if urdf is None else [(urdf, f"the URDF {model_file} names")]
    named += [(d, f"the data {model_file} was identified from") for d in _recorded_data(model_file)]
    return named

def robot_for(args: argparse.Namespace) -> Any:
    """The robot of ``predict``/``compensate``: the one the model file records (its URDF found
    as :func:`_recorded_robot` says), ``--urdf`` alone with the recorded base and tip, or
    ``--urdf/--base/--tip`` (``--base``/``--tip`` without ``--urdf``: the bundled arm)."""
    from .model import BUNDLED_URDF_PATH, recorded_urdf
    from .vjm import Robot

    if args.base is not None or args.tip is not None:
        return robot_of(args)
    rec = _recorded_robot(args.model_file)
    if args.urdf is not None:
        if rec is None:
            raise CliError(
                f"--urdf needs --base LINK and --tip LINK here: {args.model_file} has no readable robot record "
                "to take them from"
            )
        check_input(args.urdf, "--urdf")
        return Robot.from_urdf(args.urdf, str(rec["base"]), str(rec["tip"]))
    if rec is None:
        return Robot.bundled()
    urdf, base, tip = recorded_urdf(rec), rec.get("base"), rec.get("tip")
    if rec.get("urdf") == BUNDLED_URDF_PATH:
        return Robot.bundled(tip)
    give = f"give --urdf ROBOT.urdf (base {base} and tip {tip} are taken from {args.model_file})"
    if not urdf:
        raise CliError(f"{args.model_file} records no URDF path: {give}")
    if rec.get("found") is None:
        tried = ", ".join(rec.get("tried") or [urdf])
        raise CliError(
            f"{args.model_file} was identified on {urdf}, which does not exist here (looked for {tried}): {give}"
        )
    return Robot.from_urdf(rec["found"], str(base), str(tip))
