"""Exception hierarchy of :mod:`robot_stiffness`.

Every error raised by the package derives from :class:`StiffnessError`. Where a built-in
exception is the natural category, the class also derives from it, so callers may catch either:
``except ValueError`` catches a bad shape, ``except FileNotFoundError`` a missing file.
The Rust core's error enums are mapped onto these classes in one place
(``crates/py-bindings/src/errors.rs``).
"""

from __future__ import annotations

import contextlib
import re
import threading
from typing import Iterator, Mapping

__all__ = [
    "StiffnessError",
    "ShapeError",
    "InvalidValueError",
    "DataFileError",
    "MissingFileError",
    "MissingDependencyError",
    "RobotModelError",
    "IdentificationError",
    "ModelFileError",
    "InternalError",
    "ConvergenceError",
    "CancelledError",
    "ArgumentTypeError",
    "OutputPathError",
    "SuspiciousDataWarning",
    "reworded",
    "rows_of_arrays",
    "rows_are_file_lines",
    "arrays_are_file_rows",
]


class StiffnessError(Exception):
    """Base class of every error raised by :mod:`robot_stiffness`."""


class ShapeError(StiffnessError, ValueError):
    """An array has the wrong number of dimensions or a wrong size; the message names the dimension."""


class InvalidValueError(StiffnessError, ValueError):
    """A value is not acceptable: NaN/inf, a matrix that is not a rotation, an unknown option..."""


class DataFileError(StiffnessError, ValueError):
    """A measurement file cannot be used: missing column, unparsable cell, implausible units...

    The message names the file, the row and/or the column.
    """


class MissingFileError(StiffnessError, FileNotFoundError):
    """A file given by the user does not exist or cannot be read."""


class MissingDependencyError(StiffnessError, ImportError):
    """An optional package a feature needs is not installed (pyarrow for Parquet and Arrow
    files); the message says which ``pip install`` provides it."""


class RobotModelError(StiffnessError, ValueError):
    """A robot description cannot be used: unknown link, base not an ancestor of tip, closed
    chain, mimic or unsupported joint..."""


class IdentificationError(StiffnessError, ValueError):
    """Identification cannot proceed: too few measurements, a singular problem..."""


class ModelFileError(StiffnessError, ValueError):
    """A stiffness model file cannot be used: edited after it was saved (content hash), written
    for another schema version, not a model file, or describing another robot (URDF content,
    base, tip, joints). The message names the file and what differs."""


class ArgumentTypeError(StiffnessError, TypeError):
    """An argument has the wrong type (a string where a number is expected, a float where an
    integer is, CSV text where a path is...); the message names the argument."""


class OutputPathError(StiffnessError, OSError):
    """An output cannot be written where asked: its folder is missing or read-only, it is a
    folder or an input file, or a non-empty folder holds files the tool did not write.

    Nothing is written or removed when this is raised.
    """


class InternalError(StiffnessError, RuntimeError):
    """A bug inside the Rust core (a caught panic). Please report it with the inputs."""


class ConvergenceError(StiffnessError, RuntimeError):
    """An iterative computation hit its iteration cap (almost always: non-finite or extreme
    input reached a solver). The message names the computation and the cap."""


class CancelledError(StiffnessError, RuntimeError):
    """A long computation was cancelled without a Python exception to re-raise.

    Ctrl-C during a long call raises the ordinary ``KeyboardInterrupt`` and an exception raised
    by a ``progress`` callback propagates as itself; this class covers a cancel with neither
    cause."""
class SuspiciousDataWarning(UserWarning):
    """Measurements that passed every check, or an identification from them, look wrong: a
    row whose load or displacement is orders of magnitude above the others, a compliance
    beyond any arm's (wrenches in kN? displacements in mm?), a compliance negative beyond
    doubt. Issued by :meth:`robot_stiffness.vjm.Robot.identify` (the messages are also in
    ``Identification.warnings``; the command line prints them as ``warning:`` lines). Turn it
    into an error with ``warnings.simplefilter("error", SuspiciousDataWarning)``."""


@contextlib.contextmanager
def reworded(names: Mapping[str, str]) -> Iterator[None]:
    """Within the block, a :class:`StiffnessError` whose message names a term of another
    front end (a Rust name such as ``RotationPolicy::Project``) is re-raised, same class,
    with the caller's term (``project=True`` in Python, ``--project`` on the command line)."""
    try:
        yield
    except StiffnessError as e:
        text = str(e)
        better = text
        for old, new in names.items():
            better = better.replace(old, new)
        if better == text:
            raise
        raise type(e)(better) from None


#: A cell the core's checks name by file line: for arrays it counts row i as line i + 2.
_LINE_CELL = re.compile(r"\bline (\d+), column '")


def rows_of_arrays(message: str) -> str:
    """A core message about arrays given in Python, with rows counted from 0 as the arrays
    count them: the core's checks speak of a measurement *file* (header = line 1) and count
    row i of arrays as line i + 2, so ``line 7, column 'q1'`` becomes
    ``row 5 (counting from 0), column 'q1'``."""
    return _LINE_CELL.sub(lambda m: f"row {max(int(m.group(1)) - 2, 0)} (counting from 0), column '", message)


_file_lines_depth = [0]
_file_lines_lock = threading.Lock()


@contextlib.contextmanager
def rows_are_file_lines() -> Iterator[None]:
    """Within the block (every thread: the command line computes in a worker thread), arrays
    passed to the API are the rows of a CSV file, so errors keep the core's file lines
    (header = line 1) instead of rows counted from 0. The command line runs its commands so."""
    with _file_lines_lock:
        _file_lines_depth[0] += 1
    try:
        yield
    finally:
        with _file_lines_lock:
            _file_lines_depth[0] -= 1


def arrays_are_file_rows() -> bool:
    """Whether :func:`rows_are_file_lines` is in force."""
    return _file_lines_depth[0] > 0
