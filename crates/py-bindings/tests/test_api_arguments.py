"""Issue 14, the Python API: every bad argument raises a StiffnessError subclass that is also
the natural built-in, names the argument, and nothing is silently converted (complex, bool,
truncated integers, CSV text where a path is expected)."""

from __future__ import annotations

import numpy as np
import pytest

import robot_stiffness as rs
from robot_stiffness import csjm, so3, vjm

from conftest import random_q, random_wrench


@pytest.fixture(scope="module")
def campaign():
    robot = vjm.Robot.bundled()
    return robot, vjm.simulate(robot, n_poses=12, wrenches_per_pose=3, seed=4)


def test_error_classes_are_exported_and_derive_from_builtins():
    assert issubclass(rs.ArgumentTypeError, rs.StiffnessError) and issubclass(rs.ArgumentTypeError, TypeError)
    assert issubclass(rs.OutputPathError, rs.StiffnessError) and issubclass(rs.OutputPathError, OSError)
    assert {"ArgumentTypeError", "OutputPathError"} <= set(rs.__all__)


@pytest.mark.parametrize(
    "call, cls, words",
    [
        (lambda r: vjm.simulate(r, n_poses=3, seed=-1), rs.InvalidValueError, ["seed", "-1"]),
        (lambda r: vjm.simulate(r, n_poses="x"), rs.ArgumentTypeError, ["n_poses", "'x'"]),
        (lambda r: vjm.simulate(r, n_poses=2.5), rs.InvalidValueError, ["n_poses", "2.5"]),
        (lambda r: vjm.simulate(r, n_poses=True), rs.ArgumentTypeError, ["n_poses", "bool"]),
        (lambda r: vjm.simulate(r, seed=2**64), rs.InvalidValueError, ["seed", "too large"]),
        (lambda r: vjm.simulate(r, force_max=float("nan")), rs.InvalidValueError, ["force_max", "finite"]),
        (lambda r: vjm.simulate(r, noise="yes"), rs.ArgumentTypeError, ["noise"]),
        (lambda r: vjm.simulate(r, bogus=1), rs.ArgumentTypeError, ["bogus"]),
        (lambda r: csjm.simulate(seed=-1), rs.InvalidValueError, ["seed"]),
        (lambda r: csjm.simulate(increments="many"), rs.ArgumentTypeError, ["increments"]),
        (lambda r: csjm.identify(np.stack([np.eye(3)] * 5), np.zeros((5, 3)), -1), rs.InvalidValueError, ["ref"]),
        (lambda r: csjm.identify(np.stack([np.eye(3)] * 5), np.zeros((5, 3)), 0, order="2"),
         rs.ArgumentTypeError, ["order"]),
        (lambda r: vjm.paper_study(r, seed=-1), rs.InvalidValueError, ["seed"]),
        (lambda r: vjm.paper_study(r, tilt_ratio="half"), rs.ArgumentTypeError, ["tilt_ratio"]),
        (lambda r: vjm.read_measurements("x.csv", -7), rs.InvalidValueError, ["n_joints"]),
        (lambda r: vjm.read_measurements(3, 7), rs.ArgumentTypeError, ["path"]),
        (lambda r: r.identify(np.zeros((4, 7)), np.zeros((4, 6)), np.zeros((4, 3)), method=3),
         rs.ArgumentTypeError, ["method"]),
        (lambda r: r.identify(np.zeros((4, 7)), np.zeros((4, 6)), np.zeros((4, 3)), nonnegative="no"),
         rs.ArgumentTypeError, ["nonnegative"]),
        (lambda r: vjm.Robot.bundled(tip=5), rs.ArgumentTypeError, ["tip"]),
        (lambda r: vjm.Robot(1), rs.ArgumentTypeError, ["Robot.bundled()"]),
        (lambda r: so3.log(np.eye(3), tol="x"), rs.ArgumentTypeError, ["tol"]),
        (lambda r: vjm.diagnose(r, {"q1": [0.0]}, progress=3), rs.ArgumentTypeError, ["progress"]),
        (lambda r: vjm.diagnose(r, 42), rs.ArgumentTypeError, ["data"]),
        (lambda r: r.gravity_torques(np.zeros(7), payload=(2.0,)), rs.ShapeError, ["payload", "(2.0,)"]),
        (lambda r: r.gravity_torques(np.zeros(7), payload=(2.0, (0.0, 0.1))), rs.ShapeError, ["centre", "3"]),
    ],
)
def test_bad_arguments_raise_package_errors_naming_the_argument(panda, call, cls, words):
    """Before the fix: OverflowError, TypeError or ValueError outside StiffnessError, or a
    silently truncated value."""
    with pytest.raises(cls) as e:
        call(panda)
    assert isinstance(e.value, rs.StiffnessError)
    for w in words:
        assert w in str(e.value), str(e.value)


def test_integral_floats_are_accepted_as_counts(panda):
    a = vjm.simulate(panda, n_poses=4.0, wrenches_per_pose=2, seed=7)
    b = vjm.simulate(panda, n_poses=4, wrenches_per_pose=2, seed=np.uint64(7))
    np.testing.assert_array_equal(a.measurements.displacement, b.measurements.displacement)


# ----------------------------------------------------------------------------- paths


def test_csv_text_where_a_path_is_expected_is_named_not_printed(campaign):
    _, c = campaign
    text = c.csv
    assert len(text) > 1000
    for call in (lambda: vjm.read_measurements(text, 7), lambda: vjm.diagnose(vjm.Robot.bundled(), text),
                 lambda: csjm.identify_csv(text), lambda: csjm.diagnose(text), lambda: csjm.read_measurements(text)):
        with pytest.raises(rs.InvalidValueError) as e:
            call()
        msg = str(e.value)
        assert "looks like CSV text" in msg and len(msg) < 250, msg
        assert text[:80] not in msg


def test_urdf_text_where_a_path_is_expected_points_to_from_urdf_string():
    xml = "<robot name='r'>\n  <link name='a'/>\n</robot>\n"
    with pytest.raises(rs.InvalidValueError) as e:
        vjm.Robot.from_urdf(xml, "a", "a")
    assert "looks like XML text" in str(e.value) and "from_urdf_string" in str(e.value)


def test_missing_and_empty_files(tmp_path):
    with pytest.raises(rs.MissingFileError) as e:
        vjm.read_measurements(tmp_path / "nope.csv", 7)
    assert "nope.csv" in str(e.value)
    (tmp_path / "empty.csv").write_text("")
    with pytest.raises(rs.DataFileError) as e2:
        vjm.read_measurements(tmp_path / "empty.csv", 7)
    assert "Traceback" not in str(e2.value) and "\n" not in str(e2.value)


# ----------------------------------------------------------------------------- arrays


@pytest.mark.parametrize(
    "make, words",
    [
        (lambda q: q.astype(complex) + 1e-3j, ["q", "complex"]),
        (lambda q: q > 0, ["q", "boolean"]),
        (lambda q: q.astype(str), ["q", "string"]),
        (lambda q: [list(q[0][:-1]) + [None]], ["q", "element (0, 6)", "NoneType"]),
        (lambda q: np.full(q.shape, 2**60, dtype=np.int64), ["q", "exactly"]),
    ],
)
def test_arrays_of_the_wrong_kind_are_refused(panda, rng, make, words):
    """Before the fix complex input was silently truncated to its real part."""
    q = random_q(panda, rng, 3)
    with pytest.raises(rs.InvalidValueError) as e:
        panda.jacobian(make(q))
    for w in words:
        assert w in str(e.value), str(e.value)


def test_exact_integer_arrays_are_accepted(panda, rng):
    q = np.array([[0, 0, 0, -2, 0, 2, 1]] * 2, dtype=np.int32)  # inside the Panda's limits
    w = np.array([[0, 0, 10, 0, 0, 1]] * 2, dtype=np.int64)
    c = np.full(7, 1e-5)
    expected = panda.predict_deflection(c, q.astype(float), w.astype(float))
    np.testing.assert_array_equal(panda.predict_deflection(c, q, w), expected)


def _table(c):
    df = c.measurements.to_dataframe()
    return {k: list(df[k]) for k in df.columns}


def test_a_table_error_names_the_column_and_row_not_a_file_line(panda, campaign):
    """Before the fix a dict with a NaN blamed "line 7" of a file the user never had."""
    _, c = campaign
    table = _table(c)
    table["dx"][5] = float("nan")
    with pytest.raises(rs.StiffnessError) as e:
        vjm.diagnose(panda, table)
    msg = str(e.value)
    assert "line" not in msg and "column 'dx'" in msg and "row 5" in msg, msg
    with pytest.raises(rs.StiffnessError) as e2:
        panda.identify(table)
    msg = str(e2.value)
    assert "column 'dx'" in msg and "row 5" in msg, msg


def test_a_string_cell_in_a_table_names_the_column(panda, campaign):
    _, c = campaign
    table = _table(c)
    table["fx"][3] = "abc"
    with pytest.raises(rs.DataFileError) as e:
        vjm.diagnose(panda, table)
    assert "column 'fx'" in str(e.value)


def test_non_integral_pose_ids_are_refused_not_truncated(panda, campaign):
    _, c = campaign
    table = _table(c)
    table["pose"] = [p + (0.7 if i == 4 else 0.0) for i, p in enumerate(table["pose"])]
    with pytest.raises(rs.DataFileError) as e:
        vjm.diagnose(panda, table)
    assert "column 'pose', row 4" in str(e.value) and "whole numbers" in str(e.value)
    m = c.measurements
    bad = vjm.Measurements(m.q, m.wrench, m.displacement, pose=m.pose + 0.5, set=m.set)
    with pytest.raises(rs.DataFileError):
        vjm.diagnose(panda, bad)


def test_good_tables_still_work(panda, campaign, rng):
    _, c = campaign
    d1 = vjm.diagnose(panda, _table(c))
    d2 = vjm.diagnose(panda, c.measurements)
    assert d1.baseline["test_mean_rel_error"] == d2.baseline["test_mean_rel_error"]
    q = random_q(panda, rng, 5)
    w = random_wrench(rng, 5)
    assert panda.predict_deflection(np.full(7, 1e-5), q, w).shape == (5, 6)


def _not_a_rotation_csv(tmp_path):
    from test_csjm import synthetic, write_csv

    R, tau = synthetic(np.random.default_rng(5))
    R[4, 0, 1] += 0.3  # not a rotation any more
    path = tmp_path / "m.csv"
    write_csv(path, R, tau, ref=0)
    return path


def test_core_messages_use_the_python_spelling_not_a_rust_name(tmp_path):
    """Before the fix: "(pass RotationPolicy::Project …)" — a Rust name."""
    path = _not_a_rotation_csv(tmp_path)
    for call in (lambda: csjm.identify_csv(path), lambda: csjm.read_measurements(path), lambda: csjm.diagnose(path)):
        with pytest.raises(rs.StiffnessError) as e:
            call()
        assert "project=True" in str(e.value) and "::" not in str(e.value), str(e.value)


def test_the_cli_names_its_own_flag(tmp_path):
    from conftest import run_cli

    _not_a_rotation_csv(tmp_path)
    for cmd in (["identify", "csjm", "m.csv"], ["diagnose", "csjm", "m.csv"]):
        proc = run_cli(cmd, cwd=tmp_path)
        line = proc.stderr.strip()
        assert proc.returncode == 1 and "--project" in line and "::" not in line and "m.csv" in line, line
