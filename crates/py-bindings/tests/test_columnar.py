"""Issue 25, item 2 (Python side): Parquet and Arrow IPC measurement files through pyarrow (the
``[parquet]`` extra), and pandas / polars / pyarrow frames read without extra copies. A columnar
file must give exactly what the CSV of the same rows gives, and every bad file a clear error
naming the file, the column and the row (counting from 0). Seeded campaigns throughout."""

from __future__ import annotations

import io
import sys
from pathlib import Path
from typing import Any, Dict

import numpy as np
import pytest

import robot_stiffness as rs
from robot_stiffness import csjm, vjm
from robot_stiffness._arrays import f64
from robot_stiffness._columnar import (
    arrow_column,
    columnar_format,
    is_columnar_path,
    read_columns,
    write_columns,
)
from robot_stiffness._tables import column

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")


@pytest.fixture(scope="module")
def campaign(panda) -> vjm.Measurements:
    return vjm.simulate(panda, n_poses=12, wrenches_per_pose=3, seed=11, test_fraction=0.25).measurements


def _frame(m: vjm.Measurements) -> Dict[str, Any]:
    """The measurement-file columns of ``m`` as named numpy arrays (set as a str array)."""
    cols: Dict[str, Any] = {f"q{j + 1}": m.q[:, j] for j in range(m.q.shape[1])}
    cols.update({n: m.wrench[:, k] for k, n in enumerate(["fx", "fy", "fz", "mx", "my", "mz"])})
    cols.update({n: m.displacement[:, k] for k, n in enumerate(["dx", "dy", "dz"])})
    cols["pose"] = np.asarray(m.pose, dtype=np.int64)
    cols["set"] = np.array(m.set)
    return cols


def _write(path: Path, cols: Dict[str, Any]) -> Path:
    write_columns(path, list(cols), list(cols.values()))
    return path


def _same(a: vjm.Measurements, b: vjm.Measurements) -> None:
    assert np.array_equal(a.q, b.q) and np.array_equal(a.wrench, b.wrench)
    assert np.array_equal(a.displacement, b.displacement)
    assert np.array_equal(np.asarray(a.pose), np.asarray(b.pose)) and list(a.set or []) == list(b.set or [])


def test_format_comes_from_the_suffix_in_any_case():
    assert columnar_format("a/b.PARQUET") == "parquet" and columnar_format("x.pq") == "parquet"
    assert {columnar_format(f"x{s}") for s in (".arrow", ".Feather", ".ipc")} == {"arrow"}
    assert columnar_format("x.csv") is None and columnar_format("parquet") is None
    assert is_columnar_path(Path("m.Pq")) and not is_columnar_path("m.csv")


@pytest.mark.parametrize("name", ["m.parquet", "m.PQ", "m.arrow", "m.feather", "m.ipc"])
def test_round_trip_keeps_every_value_and_type(tmp_path, campaign, name):
    cols = _frame(campaign)
    cols["flag"] = np.arange(len(campaign)) % 2 == 0
    got = read_columns(_write(tmp_path / name, cols))
    assert list(got) == list(cols)
    for k, v in cols.items():
        assert np.array_equal(got[k], v), k
    assert got["q1"].dtype == np.float64 and got["pose"].dtype == np.int64 and got["flag"].dtype == bool
    assert got["set"].dtype == object and got["set"][0] in ("train", "test")


def test_a_staged_name_takes_the_final_names_format(tmp_path, campaign):
    tmp = tmp_path / ".m.parquet.tmp-123"
    write_columns(tmp, ["q1"], [campaign.q[:, 0]], fmt=columnar_format("m.parquet"))
    assert tmp.read_bytes()[:4] == b"PAR1"
    assert np.array_equal(read_columns(tmp, fmt="parquet")["q1"], campaign.q[:, 0])
    with pytest.raises(rs.InvalidValueError, match="fmt="):
        read_columns(tmp)
    with pytest.raises(rs.InvalidValueError, match="'parquet' or 'arrow'"):
        write_columns(tmp, ["q1"], [campaign.q[:, 0]], fmt="csv")


def test_arrow_stream_format_is_read_too(tmp_path, campaign):
    table = pa.table(_frame(campaign))
    path = tmp_path / "m.arrow"
    with pa.OSFile(str(path), "wb") as sink, pa.ipc.new_stream(sink, table.schema) as w:
        w.write_table(table)
    _same(vjm.read_measurements(path, 7), campaign)


@pytest.mark.parametrize("suffix", [".parquet", ".arrow"])
def test_a_columnar_file_reads_and_identifies_as_its_csv(panda, tmp_path, campaign, suffix):
    csv = tmp_path / "m.csv"
    csv.write_text(campaign.to_csv_text())
    from_csv = vjm.read_measurements(csv, 7)
    from_file = vjm.read_measurements(_write(tmp_path / f"m{suffix}", _frame(campaign)), 7)
    _same(from_file, from_csv)
    a = panda.identify(from_csv.q, from_csv.wrench, from_csv.displacement, gravity=None)
    b = panda.identify(from_file.q, from_file.wrench, from_file.displacement, gravity=None)
    assert np.array_equal(a.compliance, b.compliance, equal_nan=True)
    da = vjm.diagnose(panda, csv, per_row=False, gravity=None)
    db = vjm.diagnose(panda, tmp_path / f"m{suffix}", per_row=False, gravity=None)
    assert [f.effect for f in da.findings] == [f.effect for f in db.findings]
    assert da.baseline["test_mean_rel_error"] == db.baseline["test_mean_rel_error"]


def test_several_row_groups_and_a_dictionary_set_column(tmp_path, campaign):
    cols = _frame(campaign)
    table = pa.table(cols).set_column(
        len(cols) - 1, "set", pa.array(cols["set"]).dictionary_encode()
    )
    path = tmp_path / "m.parquet"
    pq.write_table(table, str(path), row_group_size=7)
    assert pq.ParquetFile(str(path)).num_row_groups > 1
    _same(vjm.read_measurements(path, 7), campaign)


def test_extra_and_differently_cased_columns(tmp_path, campaign):
    cols = {k.upper() if k.startswith("q") else k: v for k, v in _frame(campaign).items()}
    cols["temperature"] = np.full(len(campaign), np.nan)
    cols["note"] = np.array([None] * len(campaign), dtype=object)  # never read: nulls are fine
    table = pa.table({k: (pa.array(list(v), type=pa.string()) if k == "note" else v) for k, v in cols.items()})
    path = tmp_path / "m.parquet"
    pq.write_table(table, str(path))
    _same(vjm.read_measurements(path, 7), campaign)


@pytest.mark.parametrize("suffix", [".parquet", ".arrow"])
def test_a_null_cell_names_the_file_column_and_row(tmp_path, campaign, suffix):
    cols: Dict[str, Any] = dict(_frame(campaign))
    q3 = cols["q3"].tolist()
    q3[5] = None
    cols["q3"] = pa.array(q3, type=pa.float64())
    path = tmp_path / f"m{suffix}"
    table = pa.table(cols)
    if suffix == ".parquet":
        pq.write_table(table, str(path))
    else:
        with pa.OSFile(str(path), "wb") as sink, pa.ipc.new_file(sink, table.schema) as w:
            w.write_table(table)
    with pytest.raises(rs.DataFileError) as e:
        vjm.read_measurements(path, 7)
    assert str(path) in str(e.value) and "column 'q3', row 5 (counting from 0)" in str(e.value)
    # The same table in memory: the same message, without a file.
    with pytest.raises(rs.DataFileError, match=r"column 'q3', row 5 \(counting from 0\)"):
        vjm.diagnose(vjm.Robot.bundled(), table)


def test_a_missing_column_names_it_and_the_file(tmp_path, campaign):
    cols = _frame(campaign)
    del cols["dy"]
    path = _write(tmp_path / "m.parquet", cols)
    with pytest.raises(rs.DataFileError) as e:
        vjm.read_measurements(path, 7)
    assert str(path) in str(e.value) and "missing column 'dy'" in str(e.value)


def test_text_where_numbers_are_needed_names_the_column(tmp_path, campaign):
    cols = _frame(campaign)
    cols["fy"] = np.array([f"{v:.3f}" for v in cols["fy"]])
    with pytest.raises(rs.DataFileError) as e:
        vjm.read_measurements(_write(tmp_path / "m.parquet", cols), 7)
    assert "column 'fy'" in str(e.value) and "str" in str(e.value)


@pytest.mark.parametrize("suffix", [".parquet", ".arrow"])
def test_a_corrupt_file_names_the_file_and_pyarrows_reason(tmp_path, suffix):
    path = tmp_path / f"m{suffix}"
    path.write_bytes(b"q1,q2\n1,2\n" * 20)
    with pytest.raises(rs.DataFileError) as e:
        vjm.read_measurements(path, 7)
    text = str(e.value)
    assert str(path) in text and ("Parquet" in text or "Arrow" in text) and len(text) > len(str(path)) + 40


def test_a_truncated_parquet_file_is_a_data_file_error(tmp_path, campaign):
    path = _write(tmp_path / "m.parquet", _frame(campaign))
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    with pytest.raises(rs.DataFileError, match="cannot be read as a Parquet file"):
        read_columns(path)


def test_a_missing_file_is_file_not_found_naming_it(tmp_path):
    path = tmp_path / "absent.parquet"
    with pytest.raises(FileNotFoundError) as e:
        vjm.read_measurements(path, 7)
    assert isinstance(e.value, rs.MissingFileError) and str(path) in str(e.value)


def test_without_pyarrow_the_error_says_which_extra_to_install(monkeypatch, tmp_path, campaign):
    path = _write(tmp_path / "m.parquet", _frame(campaign))
    for name in [m for m in sys.modules if m == "pyarrow" or m.startswith("pyarrow.")]:
        monkeypatch.setitem(sys.modules, name, None)  # `import pyarrow` now raises ImportError
    for call in (lambda: vjm.read_measurements(path, 7), lambda: csjm.identify_csv(path),
                 lambda: write_columns(tmp_path / "o.arrow", ["a"], [np.zeros(2)])):
        with pytest.raises(ImportError) as e:
            call()
        assert isinstance(e.value, rs.MissingDependencyError) and isinstance(e.value, rs.StiffnessError)
        assert "pip install 'robot-stiffness[parquet]'" in str(e.value)
    # The CSV route needs no pyarrow.
    csv = tmp_path / "m.csv"
    csv.write_text(campaign.to_csv_text())
    assert len(vjm.read_measurements(csv, 7)) == len(campaign)


def test_write_refuses_mismatched_columns(tmp_path):
    with pytest.raises(rs.ShapeError, match="different lengths"):
        write_columns(tmp_path / "m.parquet", ["a", "b"], [np.zeros(3), np.zeros(4)])
    with pytest.raises(rs.ShapeError, match="one-dimensional"):
        write_columns(tmp_path / "m.parquet", ["a"], [np.zeros((3, 2))])
    with pytest.raises(rs.InvalidValueError, match="distinct"):
        write_columns(tmp_path / "m.parquet", ["a", "A"], [np.zeros(3), np.zeros(3)])
    assert not (tmp_path / "m.parquet").exists()


# ---- frames in memory: pandas, polars, pyarrow -------------------------------------------------


def _frames(campaign: vjm.Measurements) -> Dict[str, Any]:
    cols = _frame(campaign)
    frames: Dict[str, Any] = {"pyarrow": pa.table(cols), "pyarrow batch": pa.RecordBatch.from_pydict(cols)}
    try:
        import pandas as pd

        frames["pandas"] = pd.DataFrame(cols)
    except ImportError:
        pass
    try:
        import polars as pl

        frames["polars"] = pl.DataFrame(cols)
    except ImportError:
        pass
    return frames


def test_identify_on_every_frame_equals_identify_on_arrays(panda, campaign):
    m = campaign
    ref = panda.identify(m.q, m.wrench, m.displacement, gravity=None)
    for name, frame in _frames(m).items():
        got = panda.identify(frame, gravity=None)
        assert np.array_equal(got.compliance, ref.compliance, equal_nan=True), name
        assert np.array_equal(got.stderr, ref.stderr, equal_nan=True), name
        d = vjm.diagnose(panda, frame, per_row=False, gravity=None)
        assert d.baseline["test_mean_rel_error"] == vjm.diagnose(panda, m, per_row=False, gravity=None).baseline[
            "test_mean_rel_error"
        ], name


def test_float64_frame_columns_are_read_where_they_are(campaign):
    """One copy in all: the final column_stack. Each float64 column on its way there is a view of
    the frame's own buffer (no astype / to_numpy copy)."""
    source = np.ascontiguousarray(campaign.q[:, 2])
    frames: Dict[str, Any] = {"pyarrow": pa.table({"q3": source})}
    if _importable("polars"):
        import polars as pl

        frames["polars"] = pl.DataFrame({"q3": source})
    if _importable("pandas"):
        import pandas as pd

        frames["pandas"] = pd.DataFrame({"q1": source, "q3": source})
    for name, frame in frames.items():
        col = f64(column(frame, "q3"), "q3")
        assert col.dtype == np.float64 and np.array_equal(col, source), name
        assert np.shares_memory(col, np.asarray(column(frame, "q3"))), name
    table = pa.table({"q3": source})
    assert np.shares_memory(arrow_column(table["q3"], "q3"), table["q3"].chunk(0).to_numpy())


def _importable(name: str) -> bool:
    try:
        __import__(name)
    except ImportError:
        return False
    return True


def test_a_polars_null_is_refused_by_row_not_turned_into_nan(panda, campaign):
    pl = pytest.importorskip("polars")
    cols = _frame(campaign)
    frame = pl.DataFrame(cols).with_columns(
        pl.when(pl.int_range(pl.len()) == 4).then(None).otherwise(pl.col("dz")).alias("dz")
    )
    with pytest.raises(rs.DataFileError, match=r"column 'dz', row 4 \(counting from 0\)"):
        panda.identify(frame, gravity=None)


# ---- CSJM ---------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def csjm_csv() -> str:
    return csjm.simulate(seed=3).csv


def _csjm_columns(text: str) -> Dict[str, Any]:
    data = np.genfromtxt(io.StringIO(text), delimiter=",", names=True)
    assert data.dtype.names is not None
    return {n: np.ascontiguousarray(data[n]) for n in data.dtype.names}


@pytest.mark.parametrize("suffix", [".parquet", ".feather"])
def test_csjm_columnar_file_identifies_as_its_csv(tmp_path, csjm_csv, suffix):
    csv = tmp_path / "c.csv"
    csv.write_text(csjm_csv)
    path = _write(tmp_path / f"c{suffix}", _csjm_columns(csjm_csv))
    a, b = csjm.identify_csv(csv), csjm.identify_csv(path)
    assert np.array_equal(a.K, b.K) and np.array_equal(a.K_stderr, b.K_stderr, equal_nan=True)
    Ra, ta, ra = csjm.read_measurements(csv)
    Rb, tb, rb = csjm.read_measurements(path)
    assert np.array_equal(Ra, Rb) and np.array_equal(ta, tb) and ra == rb
    assert csjm.diagnose(csv).baseline == csjm.diagnose(path).baseline


def test_csjm_columnar_not_a_rotation_names_the_row(tmp_path, csjm_csv):
    cols = _csjm_columns(csjm_csv)
    cols["r12"] = cols["r12"].copy()
    cols["r12"][6] += 0.5
    path = _write(tmp_path / "c.parquet", cols)
    with pytest.raises(rs.InvalidValueError, match=r"row 6 \(counting from 0\)"):
        csjm.read_measurements(path)
    R, _, _ = csjm.read_measurements(path, project=True)
    assert np.allclose(R[6] @ R[6].T, np.eye(3), atol=1e-12)


@pytest.mark.parametrize("suffix", [".parquet", ".arrow"])
@pytest.mark.parametrize("rows", [0, 1, 7, 8, 9, 23])
def test_a_table_written_in_slices_reads_back_whole(tmp_path, monkeypatch, suffix, rows):
    """Rows go in slices of ROWS_PER_GROUP (Parquet row groups, Arrow record batches): every
    slice boundary, strided and masked columns and strings read back cell for cell."""
    import robot_stiffness._columnar as columnar

    monkeypatch.setattr(columnar, "ROWS_PER_GROUP", 8)
    rng = np.random.default_rng(7)
    grid = rng.normal(size=(rows, 3))  # its columns are strided views
    joint = np.ma.masked_array(np.arange(rows, dtype=np.int64), mask=np.arange(rows) % 3 == 0)
    names = np.array([f"r{i}" for i in range(rows)], dtype=object)
    ok = np.arange(rows) % 2 == 0
    path = tmp_path / f"t{suffix}"
    write_columns(path, ["a", "b", "joint", "name", "ok"], [grid[:, 0], grid[:, 2], joint, names, ok])
    table = pa.ipc.open_file(str(path)).read_all() if suffix == ".arrow" else pq.read_table(str(path))
    assert table.num_rows == rows
    assert np.array_equal(table.column("a").to_numpy(), grid[:, 0])
    assert np.array_equal(table.column("b").to_numpy(), grid[:, 2])
    assert table.column("joint").to_pylist() == [None if i % 3 == 0 else i for i in range(rows)]
    assert table.column("name").to_pylist() == list(names)
    assert table.column("ok").to_pylist() == ok.tolist()
    if suffix == ".parquet":
        assert pq.ParquetFile(str(path)).num_row_groups == max(1, -(-rows // 8))


def test_parquet_keeps_dictionaries_for_text_only(tmp_path):
    """Computed floats, nearly all distinct, are written plain (a dictionary attempt on them cost
    12x the time and a quarter more bytes: benches/parquet_dictionary.py); a text column, such
    as a compensation status, keeps its dictionary."""
    rng = np.random.default_rng(3)
    rows = 5000
    status = np.array(["converged", "outside_limits"] * (rows // 2), dtype=object)
    path = tmp_path / "t.parquet"
    write_columns(path, ["x", "status"], [rng.normal(size=rows), status])
    group = pq.ParquetFile(str(path)).metadata.row_group(0)
    encodings = {group.column(k).path_in_schema: set(group.column(k).encodings) for k in range(2)}
    assert not any("DICTIONARY" in e for e in encodings["x"]), encodings
    assert any("DICTIONARY" in e for e in encodings["status"]), encodings
    assert pq.read_table(str(path)).column("status").to_pylist() == list(status)
