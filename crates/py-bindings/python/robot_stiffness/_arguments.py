"""Scalar and path arguments of the public functions: one decorator, :func:`checked`.

It checks every parameter annotated ``int``, ``float``, ``bool``, ``str`` or ``PathLike``
(optionally ``Optional[...]``) before the call, so that the Rust core never sees a value that
pyo3 would reject with a bare ``TypeError``/``OverflowError``, and turns whatever built-in
``TypeError``/``ValueError``/``OverflowError`` still escapes into the package's classes, with
the function named. The rules:

* ``int``: an integer (Python, numpy) or an integral float (``40.0``), never ``bool``; ≥ 0 and
  < 2**64 (every integer parameter of the package is a count, an index or a seed);
* ``float``: a finite real number (not ``bool``, not complex, not a string);
* ``bool``: ``True``/``False`` (numpy booleans and the integers 0/1 too);
* ``str``: a string;
* ``PathLike``: a ``str`` or ``os.PathLike`` that does not look like file *contents* (CSV or
  XML text passed where a path is expected is refused, quoting at most 40 characters);
* ``Robot``: a :class:`robot_stiffness.vjm.Robot`.

It also names the rows of arrays as Python counts them: the core's checks of measurement
values speak of a file (``line 7, column 'q1'``, header = line 1) and count row i of arrays as
line i + 2; a call given no data file (no ``PathLike`` argument, no path as ``data`` or
``parts``) gets ``row 5 (counting from 0), column 'q1'`` instead. The command line, whose
arrays are the rows of a CSV file, keeps the lines (:func:`~robot_stiffness._errors.rows_are_file_lines`).
"""

from __future__ import annotations

import functools
import inspect
import math
import numbers
import os
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, TypeVar, Union, cast

import numpy as np

from ._errors import ArgumentTypeError, InvalidValueError, ShapeError, StiffnessError, arrays_are_file_rows, rows_of_arrays
from ._robot_handle import RobotHandle

__all__ = ["checked", "check_path", "integer", "real", "flag", "quote", "ModelSpec", "model_spec"]

F = TypeVar("F", bound=Callable[..., Any])

_U64 = 2**64


def quote(value: Any, limit: int = 40) -> str:
    """``repr`` of ``value`` cut to ``limit`` characters (with the full length when cut)."""
    text = repr(value)
    if len(text) <= limit:
        return text
    size = f", {len(value)} characters" if isinstance(value, (str, bytes)) else ""
    return f"{text[:limit]}…{size}"


def _type_name(value: Any) -> str:
    return type(value).__name__


def integer(value: Any, name: str) -> int:
    """``value`` as a non-negative integer < 2**64 (see the module docstring)."""
    if isinstance(value, (bool, np.bool_)):
        raise ArgumentTypeError(f"{name} must be an integer, got a bool ({value})")
    if isinstance(value, numbers.Integral):
        out = int(value)
    elif isinstance(value, numbers.Real) and not isinstance(value, numbers.Integral):
        f = float(value)
        if not math.isfinite(f) or not f.is_integer():
            raise InvalidValueError(f"{name} must be an integer, got {quote(value)}")
        out = int(f)
    else:
        raise ArgumentTypeError(f"{name} must be an integer, got {_type_name(value)} {quote(value)}")
    if out < 0:
        raise InvalidValueError(f"{name} must be ≥ 0, got {out}")
    if out >= _U64:
        raise InvalidValueError(f"{name} is too large ({out}; at most 2**64 - 1)")
    return out


def real(value: Any, name: str) -> float:
    """``value`` as a finite float."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise ArgumentTypeError(f"{name} must be a real number, got {_type_name(value)} {quote(value)}")
    f = float(value)
    if not math.isfinite(f):
        raise InvalidValueError(f"{name} must be finite, got {f}")
    return f


#: Gravity in the base frame, m/s²: 9.80665 along −z (a floor-mounted arm).
DEFAULT_GRAVITY: Tuple[float, float, float] = (0.0, 0.0, -9.80665)


def gravity_vector(value: Any, name: str = "gravity") -> Tuple[float, float, float]:
    """``value`` as a gravity vector ``(gx, gy, gz)``, m/s², base frame: three finite reals."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise ArgumentTypeError(f"{name} must be 3 numbers (gx, gy, gz) in m/s², got {_type_name(value)} {quote(value)}")
    if len(value) != 3:
        raise ShapeError(f"{name} must have 3 components (gx, gy, gz) in m/s², got {len(value)}")
    gx, gy, gz = (real(v, f"{name}[{i}]") for i, v in enumerate(value))
    return (gx, gy, gz)


#: The default ``gravity`` of the calls through a stiffness model (``StiffnessModel.predict_sag``,
#: ``StiffnessModel.compensate``, ``vjm.compensate_with_model_file``): the gravity the model was
#: identified under (``StiffnessModel.gravity``), :data:`DEFAULT_GRAVITY` when it records none.
RECORDED_GRAVITY = "recorded"

#: A ``gravity`` argument of those calls: a vector, None (weightless) or :data:`RECORDED_GRAVITY`.
ModelGravity = Union[Sequence[float], None, str]


def model_gravity(value: Any, recorded: Optional[Tuple[float, float, float]],
                  name: str = "gravity",
                  unrecorded: Optional[Tuple[float, float, float]] = DEFAULT_GRAVITY,
                  ) -> Optional[Tuple[float, float, float]]:
    """The gravity of a call through a stiffness model: ``value`` as a vector (None: weightless),
    or for :data:`RECORDED_GRAVITY` the model's ``recorded`` one, else ``unrecorded``
    (:data:`DEFAULT_GRAVITY`; None for a call that should stay weightless then, as ``predict``,
    which predicts what a weightless identification fitted)."""
    if isinstance(value, str):
        if value != RECORDED_GRAVITY:
            raise InvalidValueError(
                f"{name} must be 3 numbers (gx, gy, gz) in m/s², None (weightless) or {RECORDED_GRAVITY!r} "
                f"(the model's own), got {quote(value)}")
        return unrecorded if recorded is None else recorded
    return None if value is None else gravity_vector(value, name)


def flag(value: Any, name: str) -> bool:
    """``value`` as a bool (bool, numpy bool, 0 or 1)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, numbers.Integral) and int(value) in (0, 1):
        return bool(value)
    raise ArgumentTypeError(f"{name} must be True or False, got {_type_name(value)} {quote(value)}")


def check_path(value: Any, name: str) -> str:
    """``value`` as a path string; refuses file contents passed where a path is expected."""
    if isinstance(value, bytes):
        raise ArgumentTypeError(f"{name} must be a path (str or os.PathLike), got bytes {quote(value)}")
    if not isinstance(value, (str, os.PathLike)):
        raise ArgumentTypeError(f"{name} must be a path (str or os.PathLike), got {_type_name(value)} {quote(value)}")
    path = os.fspath(value)
    if not isinstance(path, str):
        raise ArgumentTypeError(f"{name} must be a text path, got {_type_name(path)} {quote(path)}")
    if "\n" in path or "\r" in path or "\x00" in path:
        what = "XML text" if path.lstrip().startswith("<") else "CSV text" if "," in path else "text"
        raise InvalidValueError(
            f"{name} looks like {what} rather than a file path ({quote(path)}); pass the name of a file"
            + (" (or use Robot.from_urdf_string for URDF text)" if what == "XML text" else "")
        )
    return path


def _check_str(value: Any, name: str) -> str:
    if not isinstance(value, str):
        raise ArgumentTypeError(f"{name} must be a string, got {_type_name(value)} {quote(value)}")
    return value


def _robot(value: Any, name: str) -> Any:
    if not isinstance(value, RobotHandle):
        raise ArgumentTypeError(
            f"{name} must be a robot_stiffness.vjm.Robot (Robot.bundled(), Robot.from_urdf(...)), "
            f"got {_type_name(value)} {quote(value)}"
        )
    return value


_CHECKS: Dict[str, Callable[[Any, str], Any]] = {
    "int": integer,
    "float": real,
    "bool": flag,
    "str": _check_str,
    "PathLike": check_path,
    "Robot": _robot,
}


def _rule(annotation: Any) -> Tuple[Optional[Callable[[Any, str], Any]], bool]:
    """(check, optional) for an annotation string such as ``"Optional[int]"``."""
    if not isinstance(annotation, str):
        return None, False
    text = annotation.replace(" ", "")
    optional = False
    if text.startswith("Optional[") and text.endswith("]"):
        text, optional = text[len("Optional["):-1], True
    return _CHECKS.get(text), optional


#: Parameters that take a data file's path (or paths) besides those annotated ``PathLike``.
_DATA_PARAMETERS = ("data", "parts")


def _is_path(value: Any) -> bool:
    if isinstance(value, (str, os.PathLike)):
        return True
    return isinstance(value, (list, tuple)) and any(isinstance(v, (str, os.PathLike)) for v in value)


def _file_parameters(sig: inspect.Signature) -> Tuple[Dict[str, int], Dict[str, bool]]:
    """Positions and names of the parameters that may name a data file: ``{name: position}``
    (-1 for keyword-only) and ``{name: True when any non-None value is a file}``; for the
    others (``data``, ``parts``) only a path value is."""
    positions: Dict[str, int] = {}
    any_value: Dict[str, bool] = {}
    for i, (pname, param) in enumerate(sig.parameters.items()):
        annotated = isinstance(param.annotation, str) and "PathLike" in param.annotation
        if annotated or pname in _DATA_PARAMETERS:
            positions[pname] = i if param.kind in (param.POSITIONAL_ONLY, param.POSITIONAL_OR_KEYWORD) else -1
            any_value[pname] = annotated
    return positions, any_value


def checked(fn: F) -> F:
    """Decorator: check the annotated scalar/path arguments of ``fn`` and turn built-in
    argument errors into :class:`StiffnessError` subclasses naming the function.

    Only the arguments actually passed are checked (defaults are the package's own); this
    costs a few µs per call, no ``inspect.Signature.bind``."""
    sig = inspect.signature(fn)
    positional: List[Optional[Tuple[str, Callable[[Any, str], Any], bool]]] = []
    by_name: Dict[str, Tuple[str, Callable[[Any, str], Any], bool]] = {}
    for pname, param in sig.parameters.items():
        check, optional = _rule(param.annotation)
        rule = None if check is None else (pname, check, optional)
        if param.kind in (param.POSITIONAL_ONLY, param.POSITIONAL_OR_KEYWORD):
            positional.append(rule)
        if rule is not None and param.kind != param.POSITIONAL_ONLY:
            by_name[pname] = rule
    where = f"{fn.__qualname__}()"
    file_positions, file_any_value = _file_parameters(sig)

    def reads_a_file(args: Tuple[Any, ...], kwargs: Dict[str, Any]) -> bool:
        for pname, pos in file_positions.items():
            if pname in kwargs:
                value = kwargs[pname]
            elif 0 <= pos < len(args):
                value = args[pos]
            else:
                continue
            if value is not None and (file_any_value[pname] or _is_path(value)):
                return True
        return False

    def apply(rule: Tuple[str, Callable[[Any, str], Any], bool], value: Any) -> Any:
        pname, check, optional = rule
        if value is None and optional:
            return None
        try:
            return check(value, pname)
        except StiffnessError as e:
            raise type(e)(f"{where}: {e}") from None

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        if any(positional[: len(args)]):
            args = tuple(
                apply(rule, a) if rule is not None else a
                for rule, a in zip(positional, args)
            ) + args[len(positional):]
        for key in kwargs.keys() & by_name.keys():
            kwargs[key] = apply(by_name[key], kwargs[key])
        try:
            return fn(*args, **kwargs)
        except StiffnessError as e:
            text = str(e)
            if "line " not in text or arrays_are_file_rows() or reads_a_file(args, kwargs):
                raise
            better = rows_of_arrays(text)
            if better == text:
                raise
            raise type(e)(better) from None
        except TypeError as e:
            raise ArgumentTypeError(f"{where}: {e}") from None
        except (ValueError, OverflowError) as e:
            raise InvalidValueError(f"{where}: {e}") from None

    return cast(F, wrapper)


#: The one model vocabulary: ``"traditional"``, ``"extended"``, ``"J1z,J2x"``, what diagnose prints
#: (``"traditional + joint_tilt(J3x)"``), or a sequence of spring labels like ``["J1z", "J2x"]``.
ModelSpec = Union[str, Sequence[str]]


def model_spec(model: Any) -> Union[str, List[str]]:
    """A :data:`ModelSpec` as the core takes it: the text itself, or the labels as a list of
    ``str``; anything else is an :class:`~robot_stiffness.ArgumentTypeError`."""
    if isinstance(model, str):
        return model
    try:
        labels = list(model)
    except TypeError:
        labels = None
    if labels is not None and all(isinstance(s, str) for s in labels):
        return [str(s) for s in labels]
    raise ArgumentTypeError(
        "model must be 'traditional', 'extended', a spec like 'traditional + joint_tilt(J3x)' or a "
        f"sequence of spring labels like ['J1z', 'J2x'], got {type(model).__name__} {repr(model)[:40]}"
    )
