"""The tables of ``predict vjm`` and ``compensate vjm``: the pose table they read (POSES.csv,
TRAJ.csv) and the one they write (PRED.csv, COMP.csv), as CSV through the core's one table
reader and writer, or as Parquet / Arrow IPC (told by the file name) through pyarrow.

The columns are the same in every format; the core's lists name them
(``_core.VJM_PREDICTION_COLUMNS``, ``VJM_SAG_COLUMNS``, ``VJM_COMPENSATION_COLUMNS``). What CSV
writes as an empty cell is NaN in a float column of Parquet/Arrow (a rotation the model does not
predict, the standard deviation of an unidentified row) and a null in ``limit_joint`` (no joint
outside its limits; the joint is 1-based).
"""

from __future__ import annotations

import contextlib
import os
from typing import Any, Iterator, List, Optional, Tuple

import numpy as np

from . import _core
from ._columnar import columnar_format, is_columnar_path, read_columns, release_arrow_memory, write_columns
from ._errors import DataFileError, StiffnessError
from ._interrupt import in_worker
from ._tables import WRENCH, blame_rows, columns, joint_columns, optional_columns

__all__ = ["read_plan", "read_poses", "rows_of", "write_predictions", "write_compensation"]


def read_poses(path: str, robot: Any) -> Tuple[np.ndarray, Optional[np.ndarray]]:
    """``(q (N, n) rad, wrench (N, 6) or None)`` of a pose table: ``q1..qn`` and optionally
    ``fx..mz`` (N, N·m at the tip point, base frame); other columns are ignored."""
    q, wrench, _ = read_plan(path, robot)
    return q, wrench


def read_plan(path: str, robot: Any) -> Tuple[np.ndarray, Optional[np.ndarray], Optional[np.ndarray]]:
    """:func:`read_poses` and the ``pose`` column when the table has one: ``(q, wrench or None,
    pose (N,) int64 or None)`` — a plan of ``design`` or a measurement file."""
    n = robot.n_joints
    if not is_columnar_path(path):
        read = in_worker(_core.vjm_read_poses, path, robot._inner)  # Ctrl-C stays prompt
        return read
    table = read_columns(path, joint_columns(n) + WRENCH + ["pose"])
    try:
        q = columns(table, joint_columns(n), "the joint positions")
        wrench = optional_columns(table, WRENCH, "the wrench")
        ids = optional_columns(table, ["pose"], "the pose ids")
    except DataFileError as e:
        raise DataFileError(f"{os.fspath(path)}: {e}") from None
    del table
    release_arrow_memory()
    pose: Optional[np.ndarray] = None
    if ids is not None:
        flat = ids[:, 0]
        bad = np.flatnonzero(flat != np.round(flat))
        if bad.size:
            raise DataFileError(f"{os.fspath(path)}: row {bad[0]} (counting from 0), column 'pose': "
                                f"{flat[bad[0]]!r} is not an integer pose id")
        pose = flat.astype(np.int64)
    return q, wrench, pose


@contextlib.contextmanager
def rows_of(path: str) -> Iterator[None]:
    """Around the use of a pose table's values: a Parquet/Arrow table's bad cell is named by
    the file, column and row (from 0), as a DataFrame's; a CSV's by line, as the core reads it."""
    if not is_columnar_path(path):
        yield
        return
    try:
        with blame_rows():
            yield
    except StiffnessError as e:
        text = " ".join(str(e).split())
        if "(counting from 0)" not in text or os.fspath(path) in text:
            raise  # not about one of the table's cells (a model's, a payload's), or names it
        raise type(e)(f"{os.fspath(path)}: {text}") from None


def _prediction_names(n: int, sag: bool) -> List[str]:
    return joint_columns(n) + list(_core.VJM_PREDICTION_COLUMNS) + (list(_core.VJM_SAG_COLUMNS) if sag else [])


def write_predictions(path: Any, final: Any, q: np.ndarray, pred: Any, sag: Any = None) -> None:
    """PRED (see ``predict vjm --help``) to ``path``, in the format ``final``'s name says;
    with ``sag`` (a Prediction of ``StiffnessModel.predict_sag``) the sag columns too."""
    # The sag's (N, 6) arrays as predict_sag made them: the writer takes dx..dz of each row
    # (a contiguous copy of the first three columns cost 0.1 s per 10^6 rows).
    sag_columns = None if sag is None else (
        sag.deflection, sag.stddev, np.ascontiguousarray(sag.identified, dtype=bool))
    identified = np.ascontiguousarray(pred.identified, dtype=bool)
    fmt = columnar_format(final)
    if fmt is None:
        _core.vjm_write_predictions(str(path), q, pred.wrench, pred.deflection, pred.stddev, identified,
                                    sag_columns)
        return
    arrays: List[Any] = [q[:, j] for j in range(q.shape[1])]
    arrays += [pred.wrench[:, k] for k in range(6)] + [pred.deflection[:, k] for k in range(6)]
    arrays += [pred.stddev[:, k] for k in range(6)] + [identified]
    if sag_columns is not None:
        d, sd, ok = sag_columns
        arrays += [d[:, k] for k in range(3)] + [sd[:, k] for k in range(3)] + [ok]
    write_columns(path, _prediction_names(q.shape[1], sag is not None), arrays, fmt=fmt)


def write_compensation(path: Any, final: Any, q: np.ndarray, comp: Any) -> None:
    """COMP (see ``compensate vjm --help``) to ``path``, in the format ``final``'s name says:
    corrected and nominal targets ``q``, the predicted errors, ``iterations``, ``limit_joint``
    (1-based; empty in CSV, null in Parquet/Arrow when none) and ``status``."""
    iterations = np.ascontiguousarray(comp.iterations, dtype=np.int64)
    limit = np.ascontiguousarray(comp.limit_joint, dtype=np.int64)
    values = [comp.position_error, comp.rotation_error, comp.deflection, comp.rotation_deflection,
              comp.inverse_condition]
    fmt = columnar_format(final)
    if fmt is None:
        _core.vjm_write_compensation(str(path), comp.q, q, np.column_stack(values), iterations, limit,
                                     list(comp.status))
        return
    n = q.shape[1]
    names = joint_columns(n) + [f"{c}_nominal" for c in joint_columns(n)] + list(_core.VJM_COMPENSATION_COLUMNS)
    arrays: List[Any] = [comp.q[:, j] for j in range(n)] + [q[:, j] for j in range(n)] + values
    arrays += [iterations, np.ma.masked_array(limit + 1, mask=limit < 0),
               np.array(comp.status, dtype=object)]
    write_columns(path, names, arrays, fmt=fmt)
