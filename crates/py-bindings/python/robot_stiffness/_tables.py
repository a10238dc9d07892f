"""Tables (pandas/polars DataFrames, pyarrow Tables, dicts of columns, numpy structured arrays)
→ measurement arrays.

The column names are those of the measurement files (see ``docs/python.md``):
VJM: ``q1..qn``, ``fx,fy,fz,mx,my,mz``, ``dx,dy,dz``, optional ``rx,ry,rz``, ``pose``, ``set``;
CSJM: ``r11..r33``, ``tx,ty,tz``, ``ref``.
"""

from __future__ import annotations

import contextlib
import re
from typing import Any, Iterator, List, Optional, Sequence

import numpy as np
import numpy.typing as npt

from ._arrays import f64
from ._columnar import arrow_column, is_arrow_table
from ._errors import DataFileError, InvalidValueError, StiffnessError


def is_table(x: Any) -> bool:
    """True for a pandas or polars DataFrame, a pyarrow Table, a mapping of columns or a
    structured array."""
    if isinstance(x, np.ndarray):
        return x.dtype.names is not None
    return hasattr(x, "columns") or isinstance(x, dict)


def column_names(table: Any) -> List[str]:
    if isinstance(table, np.ndarray):
        return list(table.dtype.names or ())
    if is_arrow_table(table):  # its .columns are the arrays, not the names
        return [str(c) for c in table.column_names]
    if hasattr(table, "columns"):
        return [str(c) for c in table.columns]
    return [str(c) for c in table.keys()]


def column(table: Any, key: str) -> Any:
    """The column ``key`` (an exact name of :func:`column_names`) as the table holds it: a
    pandas/polars Series (converted later by ``to_numpy``, a view where the frame's layout
    allows), an array or a list; a pyarrow column becomes numpy here (a view of its buffer
    when it can be), refusing a null cell by row. A polars null is refused the same way (its
    ``to_numpy`` would turn it into NaN, or an integer column into floats)."""
    if is_arrow_table(table):
        return arrow_column(table[key], key)
    col = table[key]
    null_count = getattr(col, "null_count", None)
    if callable(null_count) and not hasattr(col, "isna"):  # polars (pandas has isna, no null_count)
        if null_count():
            row = int(col.is_null().arg_true()[0])
            raise DataFileError(f"column '{key}', row {row} (counting from 0): empty cell (null)")
    return col


def columns(table: Any, names: Sequence[str], what: str) -> npt.NDArray[np.float64]:
    """The named columns as a C-ordered (N, len(names)) float64 array (one copy: float64
    columns are read where they are and copied once into the result)."""
    available = column_names(table)
    lower = {c.lower(): c for c in available}
    cols = []
    for name in names:
        if name not in lower:
            raise DataFileError(
                f"missing column '{name}' for {what} (table columns: {', '.join(available)})"
            )
        try:
            col = f64(column(table, lower[name]), f"column '{lower[name]}'")
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


_LINE = re.compile(r"\bline (\d+), column '")
_ARRAY_CELL = re.compile(r"\bin (q|wrench|displacement|rotation) at row (\d+), column (\d+)")


def _array_column(array: str, k: int) -> Optional[str]:
    names = {"wrench": WRENCH, "displacement": DISPLACEMENT, "rotation": ROTATION}.get(array)
    if array == "q":
        return f"q{k + 1}"
    return names[k] if names is not None and k < len(names) else None


def rows_not_lines(message: str) -> str:
    """The core reports a measurement *file*'s cells by line (header = line 1); for a table or
    arrays given in Python that is wrong blame. Rewrite ``line N, column 'c'`` as
    ``row N-2 (counting from 0), column 'c'`` and ``in wrench at row r, column k`` as
    ``in column 'fy', row r``."""
    message = _LINE.sub(lambda m: f"row {int(m.group(1)) - 2} (counting from 0), column '", message)

    def cell(m: "re.Match[str]") -> str:
        name = _array_column(m.group(1), int(m.group(3)))
        if name is None:
            return m.group(0)
        return f"in column '{name}' ({m.group(1)}), row {m.group(2)} (counting from 0)"

    return _ARRAY_CELL.sub(cell, message)


@contextlib.contextmanager
def blame_rows() -> Iterator[None]:
    """Within the block, core errors about data given in Python name rows, not file lines."""
    try:
        yield
    except StiffnessError as e:
        text = str(e)
        better = rows_not_lines(text)
        if better == text:
            raise
        raise type(e)(better) from None
