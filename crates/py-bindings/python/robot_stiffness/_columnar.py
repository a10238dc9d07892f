"""Parquet and Arrow IPC measurement tables through pyarrow (the optional ``[parquet]`` extra).

One concern: a columnar file ↔ named numpy columns. What the columns mean (``q1..qn``, the
wrench, ``pose``, ``set``…) and their checks stay in :mod:`._tables` and the readers that use it,
so a Parquet file gets exactly the checks and messages of a pandas DataFrame with the same
columns.

Numeric columns reach numpy without a copy where Arrow's layout allows it: a column of one
chunk without nulls of a fixed-width type (float64, int64…) is a view of pyarrow's buffer; a
column of several chunks (several Parquet row groups) is concatenated once. Strings (the ``set``
column) become numpy object arrays. Rows count from 0 in every message.

The format comes from the file name (``.parquet``/``.pq``: Parquet; ``.arrow``/``.feather``/
``.ipc``: Arrow IPC) or from an explicit ``fmt``: a writer that stages its output under a
temporary name passes the final name's format (:func:`columnar_format`).
"""

from __future__ import annotations

import os
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

from ._errors import DataFileError, InvalidValueError, MissingDependencyError, MissingFileError, ShapeError

__all__ = [
    "FORMATS",
    "columnar_format",
    "is_columnar_path",
    "is_arrow_table",
    "arrow_column",
    "read_columns",
    "write_columns",
]

PathLike = Union[str, "os.PathLike[str]"]

#: File-name suffix (lower case) → format name.
FORMATS = {".parquet": "parquet", ".pq": "parquet", ".arrow": "arrow", ".feather": "arrow", ".ipc": "arrow"}
_NAMES = {"parquet": "Parquet", "arrow": "Arrow IPC"}


def columnar_format(path: PathLike) -> Optional[str]:
    """``"parquet"`` or ``"arrow"`` (Arrow IPC) from the file name's suffix, any case; None otherwise."""
    return FORMATS.get(os.path.splitext(os.fspath(path))[1].lower())


def is_columnar_path(path: PathLike) -> bool:
    """True when the file name says Parquet (``.parquet``, ``.pq``) or Arrow IPC (``.arrow``,
    ``.feather``, ``.ipc``), any case."""
    return columnar_format(path) is not None


def _pyarrow() -> Any:
    try:
        import pyarrow  # type: ignore[import-untyped,import-not-found,unused-ignore]
    except ImportError:
        raise MissingDependencyError(
            "Parquet and Arrow files need pyarrow: pip install 'robot-stiffness[parquet]'"
        ) from None
    return pyarrow


def release_arrow_memory() -> None:
    """Hand the memory Arrow's pool keeps after freed tables back to the system: once a file's
    columns are numpy arrays, its decoded table is garbage, but mimalloc (pyarrow's default
    pool) kept it: 188 of the 426 MiB a `predict vjm` held after reading 10^6 Parquet rows."""
    _pyarrow().default_memory_pool().release_unused()


def _format(path: PathLike, fmt: Optional[str]) -> str:
    if fmt is None:
        found = columnar_format(path)
        if found is None:
            raise InvalidValueError(
                f"{os.fspath(path)}: not a Parquet or Arrow file name (suffixes: {', '.join(FORMATS)}); "
                "pass fmt='parquet' or fmt='arrow'"
            )
        return found
    if fmt not in _NAMES:
        raise InvalidValueError(f"fmt must be 'parquet' or 'arrow', got {fmt!r}")
    return fmt


def is_arrow_table(x: Any) -> bool:
    """True for a pyarrow Table or RecordBatch (checked without importing pyarrow)."""
    return type(x).__module__.startswith("pyarrow") and hasattr(x, "column_names") and hasattr(x, "schema")


def arrow_column(col: Any, name: str) -> npt.NDArray[Any]:
    """A pyarrow (Chunked)Array as a numpy array: a view of Arrow's buffer for one chunk of a
    fixed-width type without nulls, one concatenation for several chunks, object arrays for
    strings (dictionary-encoded or not). A null cell is refused, naming the column and its row."""
    if col.null_count:
        pa = _pyarrow()
        import pyarrow.compute as pc  # type: ignore[import-untyped,import-not-found,unused-ignore]

        row = pc.index(pc.is_null(col), pa.scalar(True)).as_py()
        raise DataFileError(f"column '{name}', row {row} (counting from 0): empty cell (null)")
    chunks = getattr(col, "chunks", None)
    if hasattr(col.type, "index_type"):  # dictionary-encoded: a few values, indexed per row
        parts = [np.asarray(c.dictionary.to_numpy(zero_copy_only=False))[c.indices.to_numpy()]
                 for c in (chunks if chunks is not None else [col])]
        return parts[0] if len(parts) == 1 else np.concatenate(parts)
    if chunks is not None and len(chunks) == 1:
        col = chunks[0]
    # zero_copy_only=False: booleans (bit-packed) and strings must be converted; fixed-width
    # numbers of one chunk without nulls are still returned as views.
    return np.asarray(col.to_numpy(zero_copy_only=False))


def _read_table(path: str, columns: Optional[Sequence[str]], fmt: str) -> Any:
    pa = _pyarrow()
    wanted = None if columns is None else {c.lower() for c in columns}

    def keep(names: Sequence[str]) -> Optional[List[str]]:
        return None if wanted is None else [n for n in names if n.lower() in wanted]

    if fmt == "parquet":
        import pyarrow.parquet as pq  # type: ignore[import-untyped,import-not-found,unused-ignore]

        schema = pq.read_schema(path)
        # Text columns (the `set` labels) stay dictionary-encoded, as Parquet stores them:
        # building a million Python strings through Arrow's decoder would cost more than the numbers.
        text = [fld.name for fld in schema if pa.types.is_string(fld.type) or pa.types.is_large_string(fld.type)]
        with pq.ParquetFile(path, read_dictionary=text or None) as f:
            return f.read(columns=keep(list(schema.names)), use_threads=True)
    import pyarrow.ipc as ipc  # type: ignore[import-untyped,import-not-found,unused-ignore]

    # The file is read into memory, not memory-mapped: the arrays must stay valid if the file
    # is replaced or truncated afterwards (an mmap would then fault).
    with pa.OSFile(path, "rb") as source:
        try:
            table = ipc.open_file(source).read_all()
        except pa.ArrowInvalid:  # not the random-access file format: try the stream format
            source.seek(0)
            table = ipc.open_stream(source).read_all()
    kept = keep(table.column_names)
    return table if kept is None else table.select(kept)


def read_columns(
    path: PathLike, columns: Optional[Sequence[str]] = None, *, fmt: Optional[str] = None
) -> Dict[str, npt.NDArray[Any]]:
    """The columns of a Parquet or Arrow IPC (file or stream format) file as numpy arrays.

    ``columns``: read only the columns with these names (case-insensitive; absent ones are
    skipped, the caller reports what it misses), None for all. ``fmt``: ``"parquet"`` or
    ``"arrow"``; None takes it from the suffix. Raises :class:`MissingFileError` for a missing
    file, :class:`DataFileError` naming the file for an unreadable one (with pyarrow's reason)
    or for a column name given twice, and naming the column and row for a null cell;
    :class:`MissingDependencyError` without pyarrow.
    """
    p = os.fspath(path)
    kind = _format(p, fmt)
    pa = _pyarrow()
    if not os.path.isfile(p):
        if os.path.isdir(p):
            raise DataFileError(f"{p}: is a folder, not a {_NAMES[kind]} file")
        raise MissingFileError(f"{p}: file not found")
    try:
        table = _read_table(p, columns, kind)
    except (pa.ArrowException, OSError) as e:
        raise DataFileError(f"{p}: cannot be read as a {_NAMES[kind]} file: {' '.join(str(e).split())}") from None
    out: Dict[str, npt.NDArray[Any]] = {}
    seen: Dict[str, str] = {}
    for name, col in zip(table.column_names, table.columns):
        if name.lower() in seen:
            raise DataFileError(f"{p}: column '{name}' appears twice (also as '{seen[name.lower()]}')")
        seen[name.lower()] = name
        try:
            out[name] = arrow_column(col, name)
        except DataFileError as e:
            raise DataFileError(f"{p}: {e}") from None
    return out


# Rows converted and written at a time: a row group of a Parquet file, a record batch of an
# Arrow IPC file. Only one slice's Arrow copies exist at once, so a table of 10^7 rows costs the
# memory of 2^17 rows. (At 2^20, pyarrow's default row group, writing 33 strided columns of 10^6
# rows took +393 MiB against +185 MiB; smaller groups had looked slow only because of the
# dictionary encoding of floats, now off: see `write_columns`.)
ROWS_PER_GROUP = 1 << 17


def _checked_column(name: str, values: Any) -> Any:
    """``values`` as a one-dimensional numpy (or masked numpy) array Arrow can hold, or an error
    naming the column."""
    if isinstance(values, np.ma.MaskedArray) and values.dtype.kind in "fiub":
        # Masked cells are nulls (what an empty CSV cell is), e.g. "no joint" in COMP files.
        if values.ndim != 1:
            raise ShapeError(f"column '{name}' must be one-dimensional, got shape {values.shape}")
        return values
    arr = np.asarray(values)
    if arr.ndim != 1:
        raise ShapeError(f"column '{name}' must be one-dimensional, got shape {arr.shape}")
    kind = arr.dtype.kind
    if kind == "O":
        bad = next((i for i, v in enumerate(arr) if not isinstance(v, str)), None)
        if bad is not None:
            raise InvalidValueError(
                f"column '{name}': element {bad} is {type(arr[bad]).__name__}, expected str (object columns hold strings)"
            )
        return arr
    if kind not in "fiubU":
        raise InvalidValueError(f"column '{name}': cannot write a column of dtype {arr.dtype}")
    return arr


def _arrow_array(pa: Any, arr: Any) -> Any:
    """A checked column (or a slice of one) as an Arrow array."""
    if isinstance(arr, np.ma.MaskedArray):
        return pa.array(np.ascontiguousarray(arr.data), mask=np.ma.getmaskarray(arr))
    kind = arr.dtype.kind
    if kind == "O":
        return pa.array(arr, type=pa.string())
    # A contiguous fixed-width numpy array without a mask is wrapped by pyarrow, not copied.
    return pa.array(np.ascontiguousarray(arr) if kind in "fiu" else arr)


def write_columns(
    path: PathLike, names: Sequence[str], arrays: Sequence[Any], *, fmt: Optional[str] = None
) -> None:
    """Write numpy columns (float, int, bool, str) as a Parquet or Arrow IPC (file format) file;
    the masked cells of a ``numpy.ma`` column are nulls.

    ``fmt``: ``"parquet"`` or ``"arrow"``; None takes it from ``path``'s suffix. A caller that
    writes atomically passes its staging path with the final name's format:
    ``write_columns(tmp, names, arrays, fmt=columnar_format(final))``. Overwrites ``path``.
    The rows go in slices of ``ROWS_PER_GROUP`` (Parquet row groups, Arrow record batches), so
    memory beyond the input arrays is one slice's.
    """
    p = os.fspath(path)
    kind = _format(p, fmt)
    pa = _pyarrow()
    names = [str(n) for n in names]
    if len(names) != len(arrays):
        raise ShapeError(f"{len(names)} column names for {len(arrays)} columns")
    if len({n.lower() for n in names}) != len(names):
        raise InvalidValueError(f"column names must be distinct (case-insensitively): {names}")
    cols = [_checked_column(n, a) for n, a in zip(names, arrays)]
    lengths = {len(c) for c in cols}
    if len(lengths) > 1:
        raise ShapeError(f"the columns have different lengths {sorted(lengths)}")
    rows = lengths.pop() if lengths else 0

    def piece(start: int) -> Any:
        stop = min(start + ROWS_PER_GROUP, rows)
        return pa.Table.from_arrays([_arrow_array(pa, c[start:stop]) for c in cols], names=names)

    starts = range(0, max(rows, 1), ROWS_PER_GROUP)  # one (empty) piece for no rows
    schema = pa.Table.from_arrays([_arrow_array(pa, c[:0]) for c in cols], names=names).schema
    if kind == "parquet":
        import pyarrow.parquet as pq  # type: ignore[import-untyped,import-not-found,unused-ignore]

        # Dictionary pages only for text (a status, a label): on computed floats, nearly all
        # distinct, pyarrow's default dictionary attempt made 33 columns of 10^6 rows slower
        # and the file larger (`python benches/parquet_dictionary.py`: 7.09 s and 332 MB
        # against 0.57 s and 264 MB in groups of 2^17; 1.67 s against 0.73 s in one group).
        text = [f.name for f in schema if pa.types.is_string(f.type) or pa.types.is_large_string(f.type)]
        with pq.ParquetWriter(p, schema, use_dictionary=text) as writer:
            for start in starts:
                writer.write_table(piece(start))
        return
    import pyarrow.ipc as ipc  # type: ignore[import-untyped,import-not-found,unused-ignore]

    with pa.OSFile(p, "wb") as sink, ipc.new_file(sink, schema) as writer:
        for start in starts:
            writer.write_table(piece(start))
