"""Tables (pandas DataFrames, dicts of columns, numpy structured arrays) → measurement arrays.

The column names are those of the measurement files (see ``docs/python.md``):
VJM: ``q1..qn``, ``fx,fy,fz,mx,my,mz``, ``dx,dy,dz``, optional ``rx,ry,rz``, ``pose``, ``set``;
CSJM: ``r11..r33``, ``tx,ty,tz``, ``ref``.
"""

from __future__ import annotations

from typing import Any, List, Optional, Sequence

import numpy as np
import numpy.typing as npt

from ._arrays import f64
from ._errors import DataFileError, InvalidValueError


def is_table(x: Any) -> bool:
    """True for a pandas DataFrame, a mapping of columns or a structured array."""
    if isinstance(x, np.ndarray):
        return x.dtype.names is not None
    return hasattr(x, "columns") or isinstance(x, dict)


def column_names(table: Any) -> List[str]:
    if isinstance(table, np.ndarray):
        return list(table.dtype.names or ())
    if hasattr(table, "columns"):
        return [str(c) for c in table.columns]
    return [str(c) for c in table.keys()]


def columns(table: Any, names: Sequence[str], what: str) -> npt.NDArray[np.float64]:
    """The named columns as a C-ordered (N, len(names)) float64 array (one copy)."""
    available = column_names(table)
    lower = {c.lower(): c for c in available}
    cols = []
    for name in names:
        if name not in lower:
            raise DataFileError(
                f"missing column '{name}' for {what} (table columns: {', '.join(available)})"
            )
        try:
            col = f64(table[lower[name]], f"column '{lower[name]}'")
        except InvalidValueError as e:
            raise DataFileError(str(e)) from None
        if col.ndim != 1:
            raise DataFileError(f"column '{lower[name]}' must be one-dimensional, got shape {col.shape}")
        cols.append(col)
    lengths = {len(c) for c in cols}
    if len(lengths) > 1:
        raise DataFileError(f"the columns for {what} have different lengths {sorted(lengths)}")
    return np.ascontiguousarray(np.column_stack(cols))


def optional_columns(table: Any, names: Sequence[str], what: str) -> Optional[npt.NDArray[np.float64]]:
    """Like :func:`columns` when all ``names`` are present, None when none is; error if some."""
    available = {c.lower() for c in column_names(table)}
    present = [n for n in names if n in available]
    if not present:
        return None
    if len(present) != len(names):
        raise DataFileError(
            f"{what} columns must be given together: found {present}, need {list(names)}"
        )
    return columns(table, names, what)


def joint_columns(n: int) -> List[str]:
    return [f"q{j + 1}" for j in range(n)]


WRENCH = ["fx", "fy", "fz", "mx", "my", "mz"]
DISPLACEMENT = ["dx", "dy", "dz"]
ROTATION = ["rx", "ry", "rz"]
ROTATION_MATRIX = ["r11", "r12", "r13", "r21", "r22", "r23", "r31", "r32", "r33"]
MOMENT = ["tx", "ty", "tz"]
