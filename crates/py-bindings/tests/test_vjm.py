"""VJM bindings: shapes and layouts, kinematics against independent paths, identification,
errors, and the data/testbed/diagnose front ends."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import robot_stiffness as rs
from robot_stiffness import so3, vjm
from robot_stiffness.vjm import Robot

from conftest import random_q, random_wrench

NOMINAL = np.array([1.0e-4, 1.0e-4, 1.5e-4, 1.5e-4, 3.0e-4, 4.0e-4, 5.0e-4])

PLANAR_2R = """<?xml version="1.0"?>
<robot name="planar2r">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="tool"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.5 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="tool_fixed" type="fixed"><parent link="l2"/><child link="tool"/><origin xyz="0.3 0 0"/></joint>
</robot>
"""


def test_robot_properties(panda):
    assert panda.n_joints == 7
    assert panda.base_link == "panda_link0" and panda.tip_link == "panda_link8"
    assert panda.joint_names[0] == "panda_joint1"
    assert panda.labels("extended")[:4] == ["J1z", "J1x", "J1y", "J2z"]
    assert panda.labels("traditional") == [f"J{j}z" for j in range(1, 8)]
    assert Robot.bundled("panda_hand_tcp").tip_link == "panda_hand_tcp"


def test_jacobian_shapes_and_layouts(panda, rng):
    q = random_q(panda, rng, 9)
    j = panda.jacobian(q, model="extended")
    assert j.shape == (9, 6, 21) and j.flags.c_contiguous
    np.testing.assert_array_equal(panda.jacobian(np.asfortranarray(q)), j)
    np.testing.assert_array_equal(panda.jacobian(q[3]), j[3])
    strided = np.zeros((9, 14))
    strided[:, ::2] = q
    np.testing.assert_array_equal(panda.jacobian(strided[:, ::2]), j)
    np.testing.assert_array_equal(panda.jacobian(np.asfortranarray(q)[::-1])[::-1], j)
    assert panda.jacobian(q, model=["J2x", "J5z"]).shape == (9, 6, 2)
    np.testing.assert_array_equal(panda.jacobian(q, model=["J2x", "J5z"])[:, :, 0], j[:, :, 4])


def test_torsion_columns_are_derivatives_of_forward_kinematics(panda, rng):
    """The z spring of joint j rotates exactly like the joint: an independent code path (FK)."""
    h = 1e-6
    for q in random_q(panda, rng, 4):
        jac = panda.jacobian(q, model="traditional")
        for k in range(7):
            dq = np.zeros(7)
            dq[k] = h
            tp, tm = panda.forward_kinematics(q + dq), panda.forward_kinematics(q - dq)
            lin = (tp[:3, 3] - tm[:3, 3]) / (2 * h)
            ang = so3.log(tp[:3, :3] @ tm[:3, :3].T) / (2 * h)
            np.testing.assert_allclose(jac[:3, k], lin, atol=1e-8)
            np.testing.assert_allclose(jac[3:, k], ang, atol=1e-8)


def test_urdf_string_planar_arm_matches_the_textbook_jacobian():
    robot = Robot.from_urdf_string(PLANAR_2R, "base", "tool")
    assert robot.n_joints == 2
    q = np.array([0.3, -0.7])
    j = robot.jacobian(q, model="traditional")
    a, b = 0.5, 0.3
    expected_lin = np.array(
        [
            [-a * np.sin(q[0]) - b * np.sin(q.sum()), -b * np.sin(q.sum())],
            [a * np.cos(q[0]) + b * np.cos(q.sum()), b * np.cos(q.sum())],
            [0.0, 0.0],
        ]
    )
    np.testing.assert_allclose(j[:3], expected_lin, atol=1e-15)
    np.testing.assert_allclose(j[3:], [[0, 0], [0, 0], [1, 1]], atol=1e-15)
    t = robot.forward_kinematics(q)
    np.testing.assert_allclose(
        t[:3, 3], [a * np.cos(q[0]) + b * np.cos(q.sum()), a * np.sin(q[0]) + b * np.sin(q.sum()), 0.1], atol=1e-15
    )


def test_prediction_equals_j_c_jt_w(panda, rng):
    q = random_q(panda, rng, 6)
    w = random_wrench(rng, 6)
    c = rng.uniform(1e-5, 1e-4, size=21)
    j = panda.jacobian(q, model="extended")
    expected = np.einsum("nik,k,njk,nj->ni", j, c, j, w)
    got = panda.predict_deflection(c, q, w, model="extended")
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-18)
    assert panda.predict_deflection(c, q[0], w[0], model="extended").shape == (6,)


def _campaign(panda, rng, n=80, model="traditional", c=NOMINAL):
    q = random_q(panda, rng, n)
    w = random_wrench(rng, n)
    d = panda.predict_deflection(c, q, w, model=model)[:, :3]
    return q, w, d


def test_identify_recovers_identifiable_combinations_noise_free(panda, rng):
    q, w, d = _campaign(panda, rng)
    res = panda.identify(q, w, d, model="traditional", gravity=None)  # the weightless linear model's data
    ok = res.identifiable
    np.testing.assert_allclose(res.compliance[ok], NOMINAL[ok], rtol=1e-9)
    assert res.compliance.shape == (7,) and res.identifiable.dtype == bool
    assert np.all(np.isnan(res.compliance[~ok]))
    for comb in res.combinations:
        value = sum(coef * NOMINAL[res.labels.index(lbl)] for lbl, coef in comb.terms)
        assert comb.value == pytest.approx(value, rel=1e-9)


def test_identify_methods_agree_and_say_which_ran(panda, rng):
    """The normal-equations and QR reductions give the same identification on a
    well-conditioned campaign (κ ≈ 70: rounding ~κ²ε); ``method`` reports the one used, and an
    unknown name is a ValueError naming the choices."""
    extended = np.repeat(NOMINAL, 3) * np.tile([1.0, 0.1, 0.1], 7)  # [z, x, y] per joint
    q, w, d = _campaign(panda, rng, n=150, model="extended", c=extended)
    d = d + 1e-6 * rng.normal(size=d.shape)
    ne = panda.identify(q, w, d, model="extended", method="normal_equations")
    qr = panda.identify(q, w, d, model="extended", method="qr")
    auto = panda.identify(q, w, d, model="extended")
    assert (ne.method, qr.method, auto.method) == ("normal_equations", "qr", "normal_equations")
    assert ne.rank == qr.rank == 15
    ok = qr.identifiable
    np.testing.assert_array_equal(ne.identifiable, ok)
    np.testing.assert_allclose(ne.compliance[ok], qr.compliance[ok], rtol=1e-9)
    np.testing.assert_allclose(ne.stderr[ok], qr.stderr[ok], rtol=1e-7)
    with pytest.raises(ValueError, match="normal_equations"):
        panda.identify(q, w, d, model="extended", method="cholesky")


def test_flange_on_the_last_axis_makes_its_torsion_unidentifiable(panda, rng):
    """The flange point lies on joint 7's axis: its torsion cannot move the tip point, so from
    translations alone J7z must be reported as not identifiable (NaN), never as a number."""
    q, w, d = _campaign(panda, rng)
    assert np.abs(panda.jacobian(q, "traditional")[:, :3, 6]).max() < 1e-12
    res = panda.identify(q, w, d, model="traditional")
    assert res.rank == 6
    assert not res.identifiable[6] and np.isnan(res.compliance[6])


def test_streaming_dense_dataframe_and_layouts_agree(panda, rng):
    pd = pytest.importorskip("pandas")
    q, w, d = _campaign(panda, rng, n=120)
    d = d + 2e-6 * rng.normal(size=d.shape)
    ref = panda.identify(q, w, d, model="extended")
    dense = panda.identify(q, w, d, model="extended", dense=True)
    ok = ref.identifiable
    np.testing.assert_array_equal(dense.identifiable, ok)
    np.testing.assert_allclose(dense.compliance[ok], ref.compliance[ok], rtol=1e-10)
    cols = [f"q{i}" for i in range(1, 8)] + ["fx", "fy", "fz", "mx", "my", "mz", "dx", "dy", "dz"]
    df = pd.DataFrame(np.column_stack([q, w, d]), columns=cols)
    from_df = panda.identify(df, model="extended")
    fortran = panda.identify(np.asfortranarray(q), np.asfortranarray(w), np.asfortranarray(d), model="extended")
    for other in (from_df, fortran):
        np.testing.assert_array_equal(other.identifiable, ok)
        np.testing.assert_allclose(other.compliance[ok], ref.compliance[ok], rtol=1e-12)
        np.testing.assert_allclose(other.stderr[ok], ref.stderr[ok], rtol=1e-12)


def test_to_dict_has_the_cli_contract(panda, rng):
    q, w, d = _campaign(panda, rng)
    doc = panda.identify(q, w, d, model="extended").to_dict()
    assert doc["model"] == "extended" and doc["n_params"] == 21
    p = doc["parameters"][4]
    assert (p["joint"], p["axis"]) == (2, "x")
    assert set(p) >= {"joint", "axis", "compliance", "stderr", "identifiable"}
    assert all(("value" in c) for c in doc["combinations"]) and len(doc["combinations"]) == doc["rank"]


def test_shape_errors_name_the_array_and_dimension(panda, rng):
    q, w, d = _campaign(panda, rng, n=20)
    with pytest.raises(ValueError, match=r"q must have shape \(N, 7\): dimension 1 has size 6"):
        panda.identify(q[:, :6], w, d)
    with pytest.raises(rs.ShapeError, match=r"wrench must have shape \(N, 6\): dimension 1 has size 5"):
        panda.identify(q, w[:, :5], d)
    with pytest.raises(rs.ShapeError, match=r"displacement has 19 rows \(dimension 0\) but q has 20"):
        panda.identify(q, w, d[:19])
    with pytest.raises(rs.ShapeError, match=r"compliance must have shape \[7\]"):
        panda.predict_deflection(np.ones(6), q, w)


def test_value_errors_name_the_item(panda, rng):
    q, w, d = _campaign(panda, rng, n=20)
    w[4, 2] = np.nan
    with pytest.raises(rs.InvalidValueError, match=r"wrench.*row 4, column 2"):
        panda.identify(q, w, d)
    with pytest.raises(ValueError, match="unknown model `fancy`"):
        panda.jacobian(q, model="fancy")
    with pytest.raises(ValueError, match=r"model\[1\] = `J9q`"):
        panda.jacobian(q, model=["J1z", "J9q"])
    q2, w2, d2 = _campaign(panda, rng, n=2)
    with pytest.raises(rs.IdentificationError, match="too few measurements"):
        panda.identify(q2, w2, d2, model="extended")


def test_robot_errors(tmp_path: Path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        Robot.from_urdf(tmp_path / "missing.urdf", "base", "tool")
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(PLANAR_2R)
    with pytest.raises(rs.RobotModelError, match="the tip link `hand` does not exist"):
        Robot.from_urdf(urdf, "base", "hand")
    with pytest.raises(ValueError, match="not an ancestor"):
        Robot.from_urdf(urdf, "l2", "l1")
    assert Robot.from_urdf(str(urdf), "base", "tool").n_joints == 2


def test_simulate_and_diagnose_name_a_hidden_tilt(panda):
    camp = vjm.simulate(panda, [{"effect": "joint_tilt", "joint": 3, "axis": "x", "compliance": 5e-5}],
                        n_poses=30, seed=5)
    m = camp.measurements
    assert len(m) == 120 and m.q.shape == (120, 7) and m.set is not None and m.pose is not None
    seen = []
    result = vjm.diagnose(panda, m, progress=lambda stage, done, total: seen.append(stage))
    assert seen, "progress was never reported"
    named = [(f["effect"], f["joint"], f["axis"]) for f in result.findings]
    aliases = [(a.get("effect", f["effect"]), a["joint"], a["axis"]) for f in result.findings for a in f["aliases"]]
    assert ("joint_tilt", 3, "x") in named + aliases
    assert result.extended["test_mean_rel_error"] <= 0.6 * result.baseline["test_mean_rel_error"]


def test_measurement_table_round_trip_and_errors(panda, tmp_path: Path):
    camp = vjm.simulate(panda, [], n_poses=4, wrenches_per_pose=2, seed=3)
    path = tmp_path / "c.csv"
    path.write_text(camp.csv)
    back = vjm.read_measurements(path, 7)
    np.testing.assert_array_equal(back.q, camp.measurements.q)
    np.testing.assert_array_equal(back.displacement, camp.measurements.displacement)
    assert back.set == camp.measurements.set
    assert back.to_csv_text() == camp.csv
    with pytest.raises(FileNotFoundError):
        vjm.read_measurements(tmp_path / "nope.csv", 7)
    lines = camp.csv.splitlines()
    header = lines[0].split(",")
    k = header.index("dz")
    row = lines[1].split(",")
    row[k] = str(float(row[k]) * 1000.0 + 1.0)  # millimetres
    (tmp_path / "mm.csv").write_text("\n".join([lines[0], ",".join(row)] + lines[2:]) + "\n")
    with pytest.raises(rs.DataFileError, match=r"line 2, column 'dz'.*mm"):
        vjm.read_measurements(tmp_path / "mm.csv", 7)
