"""Issue 12, memory: the measurement columns reach the core without copies (float64 and int64
arrays are borrowed, `set` is read item by item). Every layout and type a user may pass must give
the same table and the same diagnosis as the plain one, and every bad value the same clear error
as before, naming the row."""

from __future__ import annotations

import numpy as np
import pytest

import robot_stiffness as rs
from robot_stiffness import vjm


@pytest.fixture(scope="module")
def measurements() -> vjm.Measurements:
    robot = vjm.Robot.bundled()
    return vjm.simulate(robot, n_poses=12, wrenches_per_pose=3, seed=4).measurements


def _with(m: vjm.Measurements, **changes: object) -> vjm.Measurements:
    fields = dict(q=m.q, wrench=m.wrench, displacement=m.displacement, rotation=m.rotation, pose=m.pose, set=m.set)
    fields.update(changes)
    return vjm.Measurements(**fields)  # type: ignore[arg-type]


def _strided(a: np.ndarray) -> np.ndarray:
    """The same values as a view with a stride of two items (not contiguous)."""
    out = np.repeat(a[:, None], 2, axis=1)[:, 0]
    assert not out.flags["C_CONTIGUOUS"]
    return out


def test_pose_and_set_in_every_layout_give_the_same_table(measurements):
    m = measurements
    assert m.pose is not None and m.set is not None
    plain = m.to_csv_text()
    pose = np.asarray(m.pose)
    variants = {
        "strided int64": _with(m, pose=_strided(pose.astype(np.int64))),
        "int32": _with(m, pose=pose.astype(np.int32)),
        "uint16": _with(m, pose=pose.astype(np.uint16)),
        "list of int": _with(m, pose=[int(p) for p in pose]),
        "whole floats": _with(m, pose=pose.astype(np.float64)),
        "set as tuple": _with(m, set=tuple(m.set)),
        "set as numpy strings": _with(m, set=np.array(m.set)),
        "set with case and spaces": _with(m, set=[f" {s.upper()} " for s in m.set]),
    }
    for name, v in variants.items():
        assert v.to_csv_text() == plain, name


def test_borrowed_columns_diagnose_as_copies_do(panda, measurements):
    m = measurements
    a = vjm.diagnose(panda, m, per_row=False)
    # Fortran-ordered float columns and a strided pose column take the copying path.
    b = vjm.diagnose(
        panda,
        _with(m, q=np.asfortranarray(m.q), wrench=np.asfortranarray(m.wrench), pose=_strided(np.asarray(m.pose))),
        per_row=False,
    )
    assert [f.effect for f in a.findings] == [f.effect for f in b.findings]
    assert a.baseline["test_mean_rel_error"] == b.baseline["test_mean_rel_error"]
    assert a.extended["test_mean_rel_error"] == b.extended["test_mean_rel_error"]


def test_a_set_label_that_is_not_a_string_names_its_row(panda, measurements):
    m = measurements
    labels: list = list(m.set or [])
    labels[5] = 1
    with pytest.raises(ValueError) as e:
        vjm.diagnose(panda, _with(m, set=labels))
    assert isinstance(e.value, rs.StiffnessError)
    assert "set[5]" in str(e.value) and "int" in str(e.value)


def test_an_unknown_set_label_names_its_row(panda, measurements):
    m = measurements
    labels = list(m.set or [])
    labels[7] = "validation"
    with pytest.raises(ValueError) as e:
        vjm.diagnose(panda, _with(m, set=labels))
    assert "set[7] = `validation`" in str(e.value)


def test_pose_ids_beyond_int64_are_refused_not_wrapped(panda, measurements):
    m = measurements
    pose = np.asarray(m.pose).astype(np.uint64)
    pose[3] = np.uint64(2**63 + 5)
    with pytest.raises(rs.DataFileError) as e:
        vjm.diagnose(panda, _with(m, pose=pose))
    assert "column 'pose', row 3" in str(e.value)


def test_a_two_dimensional_pose_column_is_a_shape_error(panda, measurements):
    m = measurements
    with pytest.raises(rs.ShapeError):
        vjm.diagnose(panda, _with(m, pose=np.asarray(m.pose).reshape(-1, 1)))


def test_a_single_string_as_set_is_refused_as_such(panda, measurements):
    with pytest.raises(ValueError) as e:
        vjm.diagnose(panda, _with(measurements, set="train"))
    assert "one string" in str(e.value)
