"""An independent physics oracle: the static equilibrium of a URDF arm in MuJoCo.

The arm is rebuilt as MJCF from the URDF's kinematics and ``<inertial>`` masses alone (no
meshes, no geometry): one body per link, nested as the URDF tree below the base link. Each
actuated joint of the base → tip chain is a hinge whose spring holds it at the commanded angle;
hidden tilts are two more hinges in the same body about the crate's tilt axes (u, v of
docs/conventions.md), composed after the joint as the crate composes its virtual springs.
Every other movable joint (a gripper's fingers, another arm) is welded at position 0, as the
crate does.

MuJoCo supplies the kinematics, the generalized force of gravity on every hinge
(``qfrc_bias`` at rest) and the generalized force of a tip wrench (``mj_applyFT``); the springs'
torques are applied here, so that a spring may be non-linear (a gear that stiffens with
torque). The equilibrium ``spring(θ) = gravity(θ) + load(θ)`` is solved by Newton's method with
a central-difference Jacobian of MuJoCo's force balance: nothing of the crate under test is used.

Units SI; the wrench ``[fx, fy, fz, mx, my, mz]`` is in base-frame components at the tip
point; the tip point is the origin of the tip link's frame.
"""

from __future__ import annotations

import math
import sys
import sysconfig
import xml.etree.ElementTree as ET
from pathlib import Path
from dataclasses import dataclass
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

import mujoco  # type: ignore

#: A spring law: torque (N·m) that the spring exerts for a deflection θ (rad); restoring, so
#: for a linear spring ``lambda th: -k * th``.
SpringLaw = Callable[[float], float]

STANDARD_GRAVITY = 9.80665

#: The arms of example-robot-data the gravity tests, studies and scripts use: name ->
#: (URDF below the package's robots/ folder, base link, tip link).
EXAMPLE_ARMS: Dict[str, Tuple[str, str, str]] = {
    "panda": ("panda_description/urdf/panda.urdf", "panda_link0", "panda_link8"),
    "ur10": ("ur_description/urdf/ur10_robot.urdf", "base_link", "tool0"),
    "z1": ("z1_description/urdf/z1.urdf", "link00", "link06"),
    "kinova": ("kinova_description/robots/kinova.urdf", "j2s6s200_link_base", "j2s6s200_end_effector"),
    "xarm7": ("xarm_description/urdf/xarm7.urdf", "link_base", "link_eef"),
    "baxter": ("baxter_description/urdf/baxter.urdf", "left_arm_mount", "left_gripper"),
}


def example_urdf(rel: str) -> Optional[Path]:
    """The path of an example-robot-data URDF (``rel`` below its robots/ folder, installed
    under the cmeel prefix by the wheel), or None when the package is not installed."""
    for site in [sysconfig.get_paths()["purelib"], *sys.path]:
        p = Path(site) / "cmeel.prefix/share/example-robot-data/robots" / rel
        if p.is_file():
            return p
    return None


def linear(k: float) -> SpringLaw:
    """A linear spring of stiffness ``k`` (N·m/rad)."""
    return lambda th: -k * th


def _floats(text: Optional[str], default: Sequence[float]) -> np.ndarray:
    if text is None:
        return np.array(default, dtype=float)
    return np.array([float(x) for x in text.split()], dtype=float)


def _rpy_matrix(rpy: np.ndarray) -> np.ndarray:
    r, p, y = rpy
    cx, sx, cy, sy, cz, sz = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx  # URDF: fixed axes x, y, z


def _quat(rot: np.ndarray) -> str:
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, rot.reshape(-1))
    return " ".join(repr(float(x)) for x in q)


def _vec(v: Sequence[float]) -> str:
    return " ".join(repr(float(x)) for x in v)


def tilt_axes(a: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """The tilt axes u, v of a joint with axis a (docs/conventions.md, written again here)."""
    a = a / np.linalg.norm(a)
    u = np.array([1.0, 0.0, 0.0]) - a * a[0]
    if np.linalg.norm(u) < 1e-9:
        u = np.array([0.0, 1.0, 0.0]) - a * a[1]
    u = u / np.linalg.norm(u)
    return u, np.cross(a, u)


@dataclass
class _Joint:
    name: str
    kind: str
    parent: str
    child: str
    xyz: np.ndarray
    rpy: np.ndarray
    axis: np.ndarray


def _parse(urdf: str) -> Tuple[Dict[str, ET.Element], List[_Joint]]:
    root = ET.fromstring(urdf)
    links = {link.get("name", ""): link for link in root.findall("link")}
    joints = []
    for j in root.findall("joint"):
        origin = j.find("origin")
        axis = j.find("axis")
        joints.append(
            _Joint(
                name=j.get("name", ""),
                kind=j.get("type", "fixed"),
                parent=j.find("parent").get("link"),  # type: ignore[union-attr]
                child=j.find("child").get("link"),  # type: ignore[union-attr]
                xyz=_floats(origin.get("xyz") if origin is not None else None, (0, 0, 0)),
                rpy=_floats(origin.get("rpy") if origin is not None else None, (0, 0, 0)),
                axis=_floats(axis.get("xyz") if axis is not None else None, (1, 0, 0)),
            )
        )
    return links, joints


class MujocoArm:
    """A URDF arm from ``base`` to ``tip`` in MuJoCo, with springs at the chain's joints.

    ``tilts``: the joints (0-based) that get two tilt hinges (their springs set per call).
    """

    def __init__(self, urdf: str, base: str, tip: str, tilts: Sequence[int] = ()) -> None:
        links, joints = _parse(urdf)
        by_child = {j.child: j for j in joints}
        path: List[_Joint] = []
        link = tip
        while link != base:
            path.append(by_child[link])
            link = by_child[link].parent
        path.reverse()
        chain = [j for j in path if j.kind in ("revolute", "continuous")]
        self.chain_names = [j.name for j in chain]
        self.n = len(chain)
        self.tilts = sorted(set(tilts))
        children: Dict[str, List[_Joint]] = {}
        for j in joints:
            children.setdefault(j.parent, []).append(j)
        chain_set = {j.name for j in chain}

        def inertial(name: str) -> str:
            el = links[name].find("inertial")
            if el is None:
                return ""
            mass = float(el.find("mass").get("value"))  # type: ignore[union-attr]
            origin = el.find("origin")
            xyz = _floats(origin.get("xyz") if origin is not None else None, (0, 0, 0))
            if mass <= 0.0:
                return ""
            # Statics need the mass and its centre only; the inertia is a placeholder.
            inertia = max(mass, 1e-6) * 1e-3
            return f'<inertial pos="{_vec(xyz)}" mass="{mass!r}" diaginertia="{inertia} {inertia} {inertia}"/>'

        def body(j: _Joint) -> str:
            rot = _rpy_matrix(j.rpy)
            parts = [f'<body name="{j.child}" pos="{_vec(j.xyz)}" quat="{_quat(rot)}">', inertial(j.child)]
            if j.name in chain_set:
                k = self.chain_names.index(j.name)
                a = j.axis / np.linalg.norm(j.axis)
                parts.append(f'<joint name="q{k}" type="hinge" axis="{_vec(a)}" limited="false"/>')
                if k in self.tilts:
                    u, v = tilt_axes(a)
                    parts.append(f'<joint name="t{k}x" type="hinge" axis="{_vec(u)}" limited="false"/>')
                    parts.append(f'<joint name="t{k}y" type="hinge" axis="{_vec(v)}" limited="false"/>')
            for c in children.get(j.child, []):
                parts.append(body(c))
            if j.child == tip:
                # Compiled off the body's origin: MuJoCo skips body_ipos of a body whose
                # inertial frame it found to be its own frame (body_sameframe), even when the
                # position is changed later.
                parts.append('<body name="__payload" pos="0 0 0"><inertial pos="0.1 0.2 0.3" mass="1" diaginertia="1e-3 1e-3 1e-3"/></body>')
            parts.append("</body>")
            return "".join(parts)

        world = "".join(body(c) for c in children.get(base, []))
        xml = (
            '<mujoco model="testbed"><compiler angle="radian" autolimits="true"/>'
            f'<option gravity="0 0 {-STANDARD_GRAVITY!r}"/>'
            f"<worldbody>{world}</worldbody></mujoco>"
        )
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._tip = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, tip)
        self._payload = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "__payload")
        self._payload_mass0 = 0.0
        self.set_payload(None)

        def dof(name: str) -> int:
            jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)
            return int(m.jnt_dofadr[jid])

        self.q_dof = [dof(f"q{k}") for k in range(self.n)]
        self.tilt_dof = {k: (dof(f"t{k}x"), dof(f"t{k}y")) for k in self.tilts}
        assert m.nv == self.n + 2 * len(self.tilts), "only the chain's hinges move"

    # -- settings ------------------------------------------------------------------------
    def set_gravity(self, g: Sequence[float]) -> None:
        self.model.opt.gravity[:] = np.asarray(g, dtype=float)

    def set_payload(self, payload: Optional[Tuple[float, Sequence[float]]]) -> None:
        """A point mass ``(kg, (cx, cy, cz))`` in the tip frame, or ``None``."""
        mass, centre = payload if payload is not None else (0.0, (0.0, 0.0, 0.0))
        # A zero mass is refused by nothing at run time, and weighs nothing.
        self.model.body_mass[self._payload] = float(mass)
        self.model.body_ipos[self._payload] = np.asarray(centre, dtype=float)

    # -- forces --------------------------------------------------------------------------
    def _qpos(self, q: Sequence[float], theta: np.ndarray) -> np.ndarray:
        """qpos from commanded angles q and the spring deflections theta (nv,)."""
        x = np.array(theta, dtype=float)
        for k in range(self.n):
            x[self.q_dof[k]] += q[k]
        return x  # every joint is a hinge: qpos and qvel share indices

    def generalized_gravity(self, q: Sequence[float], theta: Optional[np.ndarray] = None) -> np.ndarray:
        """The torque gravity applies to every hinge (nv,), N·m: −qfrc_bias at rest."""
        d = self.data
        d.qpos[:] = self._qpos(q, np.zeros(self.model.nv) if theta is None else theta)
        d.qvel[:] = 0.0
        mujoco.mj_forward(self.model, d)
        return -np.array(d.qfrc_bias)

    def _load(self, wrench: Optional[Sequence[float]]) -> np.ndarray:
        """Generalized force of the tip wrench at the current kinematics."""
        out = np.zeros(self.model.nv)
        if wrench is None:
            return out
        w = np.asarray(wrench, dtype=float)
        point = np.array(self.data.xpos[self._tip])
        mujoco.mj_applyFT(self.model, self.data, w[:3].copy(), w[3:].copy(), point, self._tip, out)
        return out

    def _residual(self, q: Sequence[float], theta: np.ndarray, springs: List[SpringLaw], wrench) -> np.ndarray:
        r = self.generalized_gravity(q, theta) + self._load(wrench)
        for i, law in enumerate(springs):
            r[i] += law(float(theta[i]))
        return r

    def springs_for(
        self,
        torsion: Sequence[float],
        tilt: Optional[Dict[int, Tuple[float, float]]] = None,
        laws: Optional[Dict[int, SpringLaw]] = None,
    ) -> List[SpringLaw]:
        """Spring laws per dof: linear torsions (N·m/rad) per joint, linear tilts per tilted
        joint, and non-linear torsion laws that replace a joint's linear one."""
        out: List[SpringLaw] = [linear(0.0)] * self.model.nv
        for k in range(self.n):
            out[self.q_dof[k]] = laws[k] if laws and k in laws else linear(float(torsion[k]))
        for k, (kx, ky) in (tilt or {}).items():
            dx, dy = self.tilt_dof[k]
            out[dx] = linear(float(kx))
            out[dy] = linear(float(ky))
        return out

    def equilibrium(
        self,
        q: Sequence[float],
        springs: List[SpringLaw],
        wrench: Optional[Sequence[float]] = None,
        *,
        tol: float = 1e-12,
        max_iter: int = 50,
    ) -> np.ndarray:
        """The spring deflections θ (nv,) at static equilibrium under gravity and ``wrench``."""
        nv = self.model.nv
        theta = np.zeros(nv)
        h = 1e-7
        for _ in range(max_iter):
            r = self._residual(q, theta, springs, wrench)
            jac = np.zeros((nv, nv))
            for i in range(nv):
                e = np.zeros(nv)
                e[i] = h
                jac[:, i] = (self._residual(q, theta + e, springs, wrench) - self._residual(q, theta - e, springs, wrench)) / (2 * h)
            step = np.linalg.solve(jac, -r)
            theta = theta + step
            if np.max(np.abs(step)) < tol:
                return theta
        raise RuntimeError(f"MuJoCo equilibrium did not converge in {max_iter} Newton steps")

    def tip(self, q: Sequence[float], theta: Optional[np.ndarray] = None) -> Tuple[np.ndarray, np.ndarray]:
        """Tip position (3,) and rotation (3, 3), base frame, at q with deflections theta."""
        d = self.data
        d.qpos[:] = self._qpos(q, np.zeros(self.model.nv) if theta is None else theta)
        mujoco.mj_kinematics(self.model, d)
        return np.array(d.xpos[self._tip]), np.array(d.xmat[self._tip]).reshape(3, 3)
