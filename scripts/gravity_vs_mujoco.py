"""Gravity of the crate against MuJoCo on six arms of example-robot-data: the table of
docs/gravity.md.

    python3 scripts/gravity_vs_mujoco.py

Per arm, at 5 seeded configurations: the largest gravity torque on a virtual spring and the
largest difference from MuJoCo's generalized gravity; the same for K_G against central
differences of MuJoCo's gravity; with Panda-class springs (torsions 2–10 kN·m/rad, tilts 3×
stiffer) the tip's sag under its own weight and the error of the first-order sag J C τ_g, of
J (K − K_G)⁻¹ τ_g and of the crate's non-linear `gravity_sag`; and the error of the weightless
linear response J C Jᵀ W and of `deflection_under_gravity` for the displacement loaded −
unloaded under gravity (W up to 30 N, 1.5 N·m). Needs mujoco and
example-robot-data (scripts/test.sh installs both).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import List

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "crates" / "py-bindings" / "tests"))

from mujoco_testbed import EXAMPLE_ARMS, MujocoArm, example_urdf  # noqa: E402

from robot_stiffness.vjm import Robot  # noqa: E402

ARMS = list(EXAMPLE_ARMS.values())


def _find(rel: str) -> Path:
    p = example_urdf(rel)
    if p is None:
        raise SystemExit(f"example-robot-data's {rel} not found: pip install example-robot-data")
    return p


def main() -> None:
    print(
        "| arm | max τ_g (N·m) | max diff | max K_G (N·m/rad) | max diff | sag (mm) "
        "| J C τ_g error | J (K − K_G)⁻¹ τ_g error | `gravity_sag` error "
        "| loaded − unloaded vs J C Jᵀ W | vs `deflection_under_gravity` |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for rel, base, tip in ARMS:
        text = _find(rel).read_text()
        robot = Robot.from_urdf_string(text, base, tip)
        n = robot.n_joints
        arm = MujocoArm(text, base, tip, tilts=range(n))
        order: List[int] = []
        for k in range(n):
            order += [arm.q_dof[k], *arm.tilt_dof[k]]
        rng = np.random.default_rng(2026)
        tau_max = tau_diff = kg_max = kg_diff = 0.0
        sags: List[float] = []
        e1s: List[float] = []
        e2s: List[float] = []
        els: List[float] = []
        sag_exact: List[float] = []
        lin_exact: List[float] = []
        for _ in range(5):
            q = rng.uniform(-1.3, 1.3, n)
            tau = robot.gravity_torques(q, "extended")
            tau_max = max(tau_max, float(np.abs(tau).max()))
            tau_diff = max(tau_diff, float(np.abs(tau - arm.generalized_gravity(q)[order]).max()))
            kg = robot.gravity_stiffness(q, "extended")
            h = 1e-6
            fd = np.zeros_like(kg)
            for i in range(len(order)):
                e = np.zeros(arm.model.nv)
                e[order[i]] = h
                fd[:, i] = ((arm.generalized_gravity(q, e) - arm.generalized_gravity(q, -e)) / (2 * h))[order]
            kg_max = max(kg_max, float(np.abs(kg).max()))
            kg_diff = max(kg_diff, float(np.abs(kg - fd).max()))
            kz = rng.uniform(2e3, 1e4, n)
            kt = 3.0 * kz
            c = 1.0 / np.ravel(np.column_stack([kz, kt, kt]))
            laws = arm.springs_for(kz, {k: (kt[k], kt[k]) for k in range(n)})
            rigid, _ = arm.tip(q)
            rest, _ = arm.tip(q, arm.equilibrium(q, laws))
            truth = rest - rigid
            jac = robot.jacobian(q, "extended")[:3]
            first = jac @ (c * tau)
            with_kg = jac @ np.linalg.solve(np.diag(1.0 / c) - kg, tau)
            sags.append(float(np.linalg.norm(truth)) * 1e3)
            e1s.append(float(np.linalg.norm(truth - first) / np.linalg.norm(truth)))
            e2s.append(float(np.linalg.norm(truth - with_kg) / np.linalg.norm(truth)))
            exact = robot.gravity_sag(c, q, "extended")[:3]
            sag_exact.append(float(np.linalg.norm(truth - exact) / np.linalg.norm(truth)))
            w = np.concatenate([rng.uniform(-30, 30, 3), rng.uniform(-1.5, 1.5, 3)])
            loaded, _ = arm.tip(q, arm.equilibrium(q, laws, w))
            d = loaded - rest
            lin = robot.predict_deflection(c, q, w, "extended", allow_outside_limits=True)[:3]
            els.append(float(np.linalg.norm(d - lin) / np.linalg.norm(d)))
            ours = robot.deflection_under_gravity(c, q, w, "extended")[:3]
            lin_exact.append(float(np.linalg.norm(d - ours) / np.linalg.norm(d)))
        name = rel.split("/")[-1].removesuffix(".urdf")
        print(
            f"| {name} | {tau_max:.3g} | {tau_diff:.1e} | {kg_max:.3g} | {kg_diff:.1e} "
            f"| {min(sags):.2f}–{max(sags):.2f} | {100 * np.mean(e1s):.2f} % (max {100 * max(e1s):.2f} %) "
            f"| {100 * np.mean(e2s):.2f} % (max {100 * max(e2s):.2f} %) | {max(sag_exact):.0e} "
            f"| {100 * np.mean(els):.2f} % (max {100 * max(els):.2f} %) | {max(lin_exact):.0e} |"
        )


def compensation() -> None:
    """A 3 kg payload (5 cm along the tip's z) on 6 seeded configurations in the middle half of
    each joint's range: the tip's absolute error against the rigid kinematics in MuJoCo,
    uncompensated, after compensating the payload's load only (the weightless model), and after
    compensating weight and payload (`vjm.compensate(..., gravity=...)`)."""
    from robot_stiffness import vjm

    print()
    print("| arm | uncompensated (mm) | load only: remaining | weight + payload: remaining |")
    print("|---|---:|---:|---:|")
    for rel, base, tip in ARMS:
        text = _find(rel).read_text()
        robot = Robot.from_urdf_string(text, base, tip)
        n = robot.n_joints
        arm = MujocoArm(text, base, tip, tilts=range(n))
        rng = np.random.default_rng(23)
        kz = rng.uniform(2e3, 1e4, n)
        kt = 3.0 * kz
        c = 1.0 / np.ravel(np.column_stack([kz, kt, kt]))
        laws = arm.springs_for(kz, {k: (kt[k], kt[k]) for k in range(n)})
        mass, centre = 3.0, (0.0, 0.0, 0.05)
        arm.set_payload((mass, centre))
        lo, hi = np.array(robot.limits).T
        lo, hi = np.maximum(lo, -np.pi), np.minimum(hi, np.pi)
        q = lo + (hi - lo) * rng.uniform(0.25, 0.75, (6, n))
        full = vjm.compensate(robot, q, c, model="extended", payload=(mass, *centre), gravity=(0.0, 0.0, -9.80665))
        part = vjm.compensate(robot, q, c, model="extended", payload=(mass, *centre))
        before, left_part, left_full = [], [], []
        for i in range(len(q)):
            target, _ = arm.tip(q[i])
            b = np.linalg.norm(arm.tip(q[i], arm.equilibrium(q[i], laws))[0] - target)
            before.append(b)
            left_part.append(np.linalg.norm(arm.tip(part.q[i], arm.equilibrium(part.q[i], laws))[0] - target) / b)
            left_full.append(np.linalg.norm(arm.tip(full.q[i], arm.equilibrium(full.q[i], laws))[0] - target) / b)
        name = rel.split("/")[-1].removesuffix(".urdf")
        print(
            f"| {name} | {1e3 * min(before):.2f}–{1e3 * max(before):.2f} "
            f"| {100 * np.mean(left_part):.0f} % ({100 * min(left_part):.0f}–{100 * max(left_part):.0f} %) "
            f"| {max(left_full):.0e} |"
        )


if __name__ == "__main__":
    main()
    compensation()
