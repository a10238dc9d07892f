"""Input normalisation shared by the wrappers: dtype only; layout is handled in Rust.

Arrays are converted to float64 (no copy when they already are float64). C-contiguous arrays
are then read by the Rust core without copying; Fortran-ordered or strided arrays are copied
once, in Rust, into row-major order.

Accepted: any real floating dtype, and integer dtypes whose values convert to float64 exactly
(|x| ≤ 2**53; e.g. a wrench ``[0, 0, 10, 0, 0, 0]`` written with integers). Refused with
:class:`~robot_stiffness.InvalidValueError` naming the argument: complex (it would silently lose
its imaginary part), bool, strings, bytes, dates, and object arrays holding anything but real
numbers (e.g. ``None``).
"""

from __future__ import annotations

import numbers
from typing import Any, Optional

import numpy as np
import numpy.typing as npt

from ._errors import InvalidValueError

_EXACT = 2**53

_KIND_NAMES = {
    "b": "boolean",
    "c": "complex",
    "U": "string",
    "S": "bytes",
    "M": "date/time",
    "m": "time-delta",
    "V": "structured/void",
}


def _index(shape: Any, flat: int) -> str:
    idx = tuple(int(i) for i in np.unravel_index(flat, shape))
    return str(idx[0]) if len(idx) == 1 else str(idx)


def _from_objects(arr: npt.NDArray[Any], name: str) -> npt.NDArray[np.float64]:
    """An object array of real numbers → float64; anything else is refused at its index."""
    flat = arr.ravel()
    for i, v in enumerate(flat):
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
            raise InvalidValueError(
                f"{name} must hold real numbers; element {_index(arr.shape, i)} is "
                f"{type(v).__name__} {repr(v)[:40]}"
            )
        if isinstance(v, numbers.Integral) and abs(int(v)) > _EXACT:
            raise InvalidValueError(
                f"{name}: integer element {_index(arr.shape, i)} = {int(v)} cannot be represented "
                "exactly as a float64"
            )
    return flat.astype(np.float64).reshape(arr.shape)


def _from_numeric(arr: npt.NDArray[Any], name: str) -> npt.NDArray[np.float64]:
    kind = arr.dtype.kind
    if kind == "f":
        return arr.astype(np.float64, copy=False)
    if kind in "iu":
        big = arr > _EXACT
        if kind == "i":
            big |= arr < -_EXACT
        if big.any():
            i = int(np.flatnonzero(big.ravel())[0])
            raise InvalidValueError(
                f"{name}: integer element {_index(arr.shape, i)} = {arr.ravel()[i]} cannot be "
                "represented exactly as a float64"
            )
        return arr.astype(np.float64)
    what = _KIND_NAMES.get(kind, f"dtype {arr.dtype}")
    hint = " (its imaginary part would be lost)" if kind == "c" else ""
    raise InvalidValueError(f"{name} must be a real numeric array, got a {what} array{hint}")


def f64(x: Any, name: str) -> npt.NDArray[np.float64]:
    """``x`` as a float64 array; a clear error naming ``name`` if it is not real numbers."""
    if isinstance(x, np.ndarray) and x.dtype == np.float64:
        return x
    if hasattr(x, "to_numpy") and not isinstance(x, np.ndarray):  # pandas objects
        x = x.to_numpy()
    try:
        arr = np.asarray(x)
    except (TypeError, ValueError) as e:
        raise InvalidValueError(f"{name} must be a numeric array: {' '.join(str(e).split())}") from None
    if arr.dtype.kind == "O":
        return _from_objects(arr, name)
    return _from_numeric(arr, name)


def optional_f64(x: Any, name: str) -> Optional[npt.NDArray[np.float64]]:
    """:func:`f64`, passing ``None`` through."""
    return None if x is None else f64(x, name)
