"""argparse ``type=`` validators of the console script, with plausibility caps.

A bad value is reported by argparse as one line naming the flag
(``robot-stiffness: error: argument --poses: must be a positive integer, got '-5'``).
The caps are documented in each flag's ``--help`` and below; they are far above any real
campaign and only stop typos (``1e9`` for ``1e3``) before a run that would take hours or
produce meaningless numbers.
"""

from __future__ import annotations

import argparse
import math
from typing import Callable, Optional

__all__ = [
    "MAX_POSES",
    "MAX_WRENCHES_PER_POSE",
    "MAX_ROWS",
    "MAX_INCREMENTS",
    "MAX_FORCE",
    "MAX_MOMENT",
    "MAX_CSJM_INCREMENT",
    "MAX_SEED",
    "count",
    "seed",
    "positive_float",
    "probability",
    "gravity",
    "MAX_GRAVITY",
]

#: ``simulate vjm --poses``.
MAX_POSES = 100_000
#: ``simulate vjm --wrenches-per-pose``.
MAX_WRENCHES_PER_POSE = 1_000
#: ``simulate vjm``: poses × wrenches per pose (a 2-million-row campaign is ~0.5 GB of CSV).
MAX_ROWS = 2_000_000
#: ``simulate csjm --increments``.
MAX_INCREMENTS = 100_000
#: ``simulate vjm --force-max``, N (a heavy industrial arm at full payload stays below).
MAX_FORCE = 10_000.0
#: ``simulate vjm --moment-max``, N·m.
MAX_MOMENT = 1_000.0
#: ``simulate csjm --max-increment``, N·m (the prototype is loaded with ≤ 1 N·m steps).
MAX_CSJM_INCREMENT = 100.0
#: ``--gravity``, m/s² per component (ten times the Earth's: a typo such as cm/s² stops here).
MAX_GRAVITY = 100.0
#: Seeds are unsigned 64-bit integers.
MAX_SEED = 2**64 - 1


def _integer(text: str) -> int:
    try:
        return int(text.strip(), 10)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None


def count(low: int, high: int) -> Callable[[str], int]:
    """An integer in [low, high]."""

    def parse(text: str) -> int:
        value = _integer(text)
        if value < low:
            what = "a positive integer" if low == 1 else f"an integer ≥ {low}"
            raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}")
        if value > high:
            raise argparse.ArgumentTypeError(f"must be at most {high}, got {text!r}")
        return value

    parse.__name__ = "integer"
    return parse


def seed(text: str) -> int:
    """A random seed: an integer in [0, 2**64 - 1]."""
    value = _integer(text)
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"must be an integer from 0 to 2**64 - 1, got {text!r}")
    return value


def _real(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return value


def positive_float(high: float, unit: Optional[str] = None) -> Callable[[str], float]:
    """A finite number in (0, high]."""

    def parse(text: str) -> float:
        value = _real(text)
        if value <= 0:
            raise argparse.ArgumentTypeError(f"must be positive, got {text!r}")
        if value > high:
            u = f" {unit}" if unit else ""
            raise argparse.ArgumentTypeError(f"must be at most {high:g}{u}, got {text!r}")
        return value

    parse.__name__ = "number"
    return parse


def nonnegative_float(high: float, unit: str) -> Callable[[str], float]:
    """A finite number in [0, high] (a noise level that may be exactly zero)."""

    def parse(text: str) -> float:
        value = _real(text)
        if value < 0:
            raise argparse.ArgumentTypeError(f"must be zero or positive ({unit}), got {text!r}")
        if value > high:
            raise argparse.ArgumentTypeError(f"must be at most {high:g} {unit}, got {text!r}")
        return value

    parse.__name__ = "number"
    return parse


def probability(text: str) -> float:
    """A number strictly between 0 and 1 (a false-discovery rate)."""
    value = _real(text)
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"must be between 0 and 1 (exclusive), got {text!r}")
    return value


def gravity(text: str) -> "tuple[float, float, float]":
    """``GX,GY,GZ``: the gravity vector in the base frame, m/s², each component finite and at
    most :data:`MAX_GRAVITY` in magnitude (``0,0,9.80665`` for a ceiling-mounted arm)."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) != 3:
        raise argparse.ArgumentTypeError(
            f"expected GX,GY,GZ (three numbers, m/s², base frame, e.g. 0,0,-9.80665), got {text!r}"
        )
    values = []
    for name, part in zip(("GX", "GY", "GZ"), parts):
        try:
            value = _real(part)
        except argparse.ArgumentTypeError:
            raise argparse.ArgumentTypeError(f"{name} must be a finite number (m/s²), got {part!r} in {text!r}") from None
        if abs(value) > MAX_GRAVITY:
            raise argparse.ArgumentTypeError(f"{name} must be at most {MAX_GRAVITY:g} m/s² in magnitude, got {text!r}")
        values.append(value)
    return (values[0], values[1], values[2])


gravity.__name__ = "gravity vector"


#: One help text for every ``--model`` (and ``diagnose --baseline``): the one model vocabulary
#: (``VirtualJointModel::parse``) and the one default.
MODEL_HELP = ("spring model: traditional (torsion only), extended (3 springs per joint), full (6 per joint: "
              "plus the link's translations J1tz,J1tx,J1ty; weightless only, --no-gravity), labels like "
              "J1z,J2x, or what diagnose prints, e.g. 'traditional + joint_tilt(J3x)' (default traditional)")
