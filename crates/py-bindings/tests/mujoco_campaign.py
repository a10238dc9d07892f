"""Measurement campaigns recorded in MuJoCo with gravity on, in the form ``vjm.diagnose`` reads.

What a user records on a real arm, made by an engine we did not write (``mujoco_testbed.py``):
at each pose, the tip at static equilibrium under the arm's own weight, then under its own
weight and a tip wrench; the row's displacement is loaded − unloaded (base frame, m), with
tracker noise, and the recorded wrench carries F/T-sensor noise (the arm felt the true one).

Poses and wrenches are drawn as the project's simulator draws them (``vjm::testbed::campaign``
defaults): joint angles uniform inside each limit (clipped to ±π) with a 0.1 rad margin, a pose
rejected when its tip is lower than 0.1 m or the inverse condition number of
``[J_lin; 0.5 m · J_ang]`` (torsion columns) is below 0.05; forces 10–80 N and moments
0–3 N·m in uniformly random directions; a quarter of the poses held out (``set = test``).

The springs are Panda-class: torsions uniform in 2–10 kN·m/rad per joint, everything else
rigid, plus the hidden effect (:class:`Hidden`): a tilt spring at one joint, or a gear that
stiffens with torque (5 kN·m/rad below 15 N·m, 12 kN·m/rad above, continuous) — preloaded by
gravity differently in every pose, which is the point of measuring under gravity.

Everything random comes from one seeded ``numpy.random.Generator``: same seed, same campaign.
Needs mujoco; the arms of :data:`ARMS` need example-robot-data.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from mujoco_testbed import EXAMPLE_ARMS, STANDARD_GRAVITY, MujocoArm, SpringLaw, example_urdf

from robot_stiffness import vjm

#: The study's arms (names of :data:`mujoco_testbed.EXAMPLE_ARMS`). The bundled Panda is left
#: out: its kinematics and inertials are example-robot-data's Panda's (docs/gravity.md).
ARMS: Dict[str, Tuple[str, str, str]] = {k: EXAMPLE_ARMS[k] for k in ("panda", "xarm7", "ur10", "kinova")}

#: A tilt spring "very stiff" about the other axis, N·m/rad: far beyond anything measurable.
STIFF = 1e9

#: The study's hidden tilt stiffness, N·m/rad: a compliance of 2e-5 rad/(N·m), 0.04–0.2 × the
#: torsions' (the "0.1 × torsion" row of docs/diagnose.md §5, where the weightless simulator's
#: campaigns name it every time).
TILT_K = 5e4

#: The hardening gear of issue 22: (stiffness below the knee, stiffness above, knee torque).
GEAR = (5e3, 12e3, 15.0)


def urdf_text(rel: str) -> Optional[str]:
    """An example-robot-data URDF's text, or None when the package is not installed."""
    p = example_urdf(rel)
    return None if p is None else p.read_text()


@dataclass(frozen=True)
class Hidden:
    """The effect hidden in the data. ``kind``: ``"clean"`` (springs only), ``"tilt"`` (tilt
    springs ``tilt = (kx, ky)`` N·m/rad about the joint's tilt axes u, v of
    docs/conventions.md; ``math.inf`` = rigid) or ``"gear"`` (the hardening law :data:`GEAR`
    replaces the joint's torsion). ``joint`` is 0-based."""

    kind: str = "clean"
    joint: Optional[int] = None
    tilt: Tuple[float, float] = (math.inf, math.inf)

    def __post_init__(self) -> None:
        if self.kind not in ("clean", "tilt", "gear"):
            raise ValueError(f"hidden kind must be 'clean', 'tilt' or 'gear', got {self.kind!r}")
        if self.kind != "clean" and self.joint is None:
            raise ValueError(f"a hidden {self.kind} needs its joint (0-based)")

    def expected(self) -> Optional[Tuple[str, int, Tuple[Optional[str], ...]]]:
        """The finding ``diagnose`` should report: (effect, 1-based joint, the axes that count:
        a tilt's compliant axes, ``(None,)`` for a gear), or None."""
        if self.kind == "clean":
            return None
        assert self.joint is not None
        if self.kind == "gear":
            return ("joint_torsion_nonlinear", self.joint + 1, (None,))
        axes = tuple(a for a, k in zip("xy", self.tilt) if k < STIFF)
        return ("joint_tilt", self.joint + 1, axes)


CLEAN = Hidden()


def tilt(joint: int, kx: float = math.inf, ky: float = math.inf) -> Hidden:
    """A hidden tilt at ``joint`` (0-based): stiffness ``kx`` about u, ``ky`` about v."""
    return Hidden("tilt", joint, (kx, ky))


def gear(joint: int) -> Hidden:
    """A hidden hardening gear (:data:`GEAR`) at ``joint`` (0-based)."""
    return Hidden("gear", joint)


def hardening(k1: float = GEAR[0], k2: float = GEAR[1], knee: float = GEAR[2]) -> SpringLaw:
    """A torsion spring of stiffness ``k1`` up to the torque ``knee`` and ``k2`` beyond it,
    odd and continuous (the restoring torque, as mujoco_testbed's laws)."""
    th1 = knee / k1

    def law(th: float) -> float:
        a = abs(th)
        t = k1 * a if a <= th1 else knee + k2 * (a - th1)
        return -math.copysign(t, th)

    return law


@dataclass
class ArmSpec:
    """An arm: its name, URDF text, base and tip links."""

    name: str
    urdf: str
    base: str
    tip: str

    @classmethod
    def example(cls, name: str) -> Optional["ArmSpec"]:
        """One of :data:`ARMS` from example-robot-data, or None when it is not installed."""
        rel, base, tip = ARMS[name]
        text = urdf_text(rel)
        return None if text is None else cls(name, text, base, tip)


@dataclass
class MujocoCampaign:
    """What :func:`measure` returns: ``measurements`` as ``vjm.diagnose`` reads them, the truth
    (``torsion`` N·m/rad per joint, the ``hidden`` effect) and the noise levels used
    (``tracker_sigma`` m per axis, ``ft_sigma`` = (N, N·m) per axis), ``gravity_torque`` (N,
    n) the torque on each joint's torsion spring at the unloaded equilibrium (the weight's),
    ``torque_loaded`` (N_rows, n) the same under the load, N·m."""

    measurements: vjm.Measurements
    robot: vjm.Robot
    torsion: np.ndarray
    hidden: Hidden
    tracker_sigma: float
    ft_sigma: Tuple[float, float]
    gravity_torque: np.ndarray = field(repr=False)
    torque_loaded: np.ndarray = field(repr=False)
    #: the gravity the campaign was measured under, m/s², base frame
    gravity: Tuple[float, float, float] = (0.0, 0.0, -STANDARD_GRAVITY)

    def knee_crossings(self) -> float:
        """The share of rows whose load moves the hidden gear across its knee (±15 N·m): the
        only rows where its non-linearity shows in loaded − unloaded; NaN without a gear."""
        if self.hidden.kind != "gear":
            return math.nan
        assert self.hidden.joint is not None
        pose = np.asarray(self.measurements.pose)
        a = self.gravity_torque[pose, self.hidden.joint]
        b = self.torque_loaded[:, self.hidden.joint]
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        knee = GEAR[2]
        return float(np.mean(((lo < knee) & (hi > knee)) | ((lo < -knee) & (hi > -knee))))

    def noise_kwargs(self) -> Dict[str, float]:
        """The noise levels as ``diagnose``'s keyword arguments."""
        return {"tracker_sigma": self.tracker_sigma, "force_sigma": self.ft_sigma[0], "moment_sigma": self.ft_sigma[1]}


_ARM_CACHE: Dict[Tuple[str, str, str, Tuple[int, ...]], Tuple[vjm.Robot, MujocoArm]] = {}


def _models(spec: ArmSpec, tilts: Tuple[int, ...]) -> Tuple[vjm.Robot, MujocoArm]:
    """The crate's robot and the MuJoCo arm, built once per (arm, tilted joints)."""
    key = (spec.urdf, spec.base, spec.tip, tilts)
    if key not in _ARM_CACHE:
        robot = vjm.Robot.from_urdf_string(spec.urdf, spec.base, spec.tip)
        _ARM_CACHE[key] = (robot, MujocoArm(spec.urdf, spec.base, spec.tip, tilts=tilts))
    return _ARM_CACHE[key]


def _inverse_condition(robot: vjm.Robot, q: np.ndarray) -> float:
    j = np.array(robot.jacobian(q, "traditional"))
    j[3:] *= 0.5
    s = np.linalg.svd(j, compute_uv=False)
    return float(s.min() / s.max()) if s.max() > 0 else 0.0


def _poses(robot: vjm.Robot, n_poses: int, rng: np.random.Generator) -> List[np.ndarray]:
    lims = [(max(lo, -math.pi), min(hi, math.pi)) for lo, hi in robot.limits]
    out: List[np.ndarray] = []
    attempts = 0
    while len(out) < n_poses:
        attempts += 1
        if attempts > 2000 * n_poses:  # the simulator's cap
            raise RuntimeError(f"no acceptable pose after {attempts} attempts")
        q = np.array([rng.uniform(lo + 0.1, hi - 0.1) if hi - lo > 0.2 else 0.5 * (lo + hi) for lo, hi in lims])
        if robot.forward_kinematics(q)[2, 3] < 0.1 or _inverse_condition(robot, q) < 0.05:
            continue
        out.append(q)
    return out


def _torques(arm: MujocoArm, springs: List[SpringLaw], theta: np.ndarray) -> np.ndarray:
    """The torque each joint's torsion spring carries at deflection ``theta``, N·m."""
    return np.array([-springs[d](float(theta[d])) for d in arm.q_dof])


def _unit(rng: np.random.Generator) -> np.ndarray:
    while True:
        v = rng.standard_normal(3)
        n = float(np.linalg.norm(v))
        if n > 1e-6:
            return v / n


def measure(
    arm_spec: ArmSpec,
    n_poses: int = 40,
    wrenches_per_pose: int = 4,
    seed: int = 0,
    tracker_sigma: float = 10e-6,
    ft_sigma: Tuple[float, float] = (0.5, 0.05),
    hidden: Hidden = CLEAN,
    *,
    force_range: Tuple[float, float] = (10.0, 80.0),
    moment_max: float = 3.0,
    test_fraction: float = 0.25,
    torsion: Optional[Sequence[float]] = None,
    gravity: Sequence[float] = (0.0, 0.0, -STANDARD_GRAVITY),
) -> MujocoCampaign:
    """A campaign measured in MuJoCo under gravity (module docstring). ``torsion`` (n,)
    N·m/rad overrides the seeded Panda-class draw; ``tracker_sigma`` is the per-axis noise of
    the recorded displacement (m), ``ft_sigma`` that of the recorded force (N) and moment
    (N·m); ``gravity`` (m/s², base frame) may be set to zero for a weightless control."""
    rng = np.random.default_rng(seed)
    tilts = (hidden.joint,) if hidden.kind == "tilt" and hidden.joint is not None else ()
    robot, arm = _models(arm_spec, tuple(tilts))
    arm.set_gravity(gravity)  # the arm is shared between calls: set it every time
    n = robot.n_joints
    kz = rng.uniform(2e3, 1e4, n) if torsion is None else np.asarray(torsion, dtype=float)
    laws: Dict[int, SpringLaw] = {}
    tilt_springs: Dict[int, Tuple[float, float]] = {}
    if hidden.kind == "gear":
        assert hidden.joint is not None
        laws[hidden.joint] = hardening()
    if hidden.kind == "tilt":
        assert hidden.joint is not None
        # MuJoCo needs a finite spring on each hinge it has: "rigid" is STIFF.
        tilt_springs[hidden.joint] = tuple(min(k, STIFF) for k in hidden.tilt)  # type: ignore[assignment]
    springs = arm.springs_for(kz, tilt_springs, laws)
    poses = _poses(robot, n_poses, rng)
    n_test = min(max(round(test_fraction * n_poses), 1), n_poses - 1)
    held_out = set(rng.permutation(n_poses)[:n_test].tolist())
    q_rows, w_rec, disp, pose_ids, sets, tau_g, tau_w = [], [], [], [], [], [], []
    f_lo, f_hi = force_range
    for p, q in enumerate(poses):
        rest = arm.equilibrium(q, springs)
        p0, _ = arm.tip(q, rest)
        tau_g.append(_torques(arm, springs, rest))
        for _ in range(wrenches_per_pose):
            fm = rng.uniform(f_lo, f_hi) if f_hi > f_lo else f_lo
            fdir, mdir = _unit(rng), _unit(rng)
            mm = moment_max * rng.random()
            w = np.concatenate([fm * fdir, mm * mdir])
            loaded = arm.equilibrium(q, springs, w)
            p1, _ = arm.tip(q, loaded)
            tau_w.append(_torques(arm, springs, loaded))
            q_rows.append(q)
            disp.append(p1 - p0 + rng.normal(0.0, tracker_sigma, 3))
            w_rec.append(w + np.concatenate([rng.normal(0.0, ft_sigma[0], 3), rng.normal(0.0, ft_sigma[1], 3)]))
            pose_ids.append(p)
            sets.append("test" if p in held_out else "train")
    m = vjm.Measurements(
        q=np.array(q_rows),
        wrench=np.array(w_rec),
        displacement=np.array(disp),
        pose=np.array(pose_ids, dtype=np.int64),
        set=sets,
    )
    g = tuple(float(x) for x in gravity)
    return MujocoCampaign(m, robot, kz, hidden, float(tracker_sigma), (float(ft_sigma[0]), float(ft_sigma[1])),
                          np.array(tau_g), np.array(tau_w), (g[0], g[1], g[2]))


@dataclass
class Outcome:
    """One diagnosis of one campaign, reduced to what the study counts."""

    alarm: bool  # any finding, or unexplained
    #: an alarm beyond the geometric non-linearity, which every MuJoCo campaign really has
    #: (the equilibrium is solved on the deflected chain): unexplained, or another finding
    alarm_beyond_geometry: bool
    named: bool  # the hidden effect among the findings at its joint (and axis)
    named_or_alias: bool  # ... or among a finding's aliases
    joint_alias: bool  # ... among them as a joint alias (axes 'x+y')
    #: a finding that is neither the hidden effect (nor its alias) nor geometric_nonlinearity
    wrong: bool
    unexplained: bool
    findings: List[str]
    baseline_test: float
    extended_test: float


GEOMETRY = "geometric_nonlinearity"


def _label(effect: str, joint: Optional[int], axis: Optional[str]) -> str:
    return effect + ("" if joint is None else f" J{joint}") + ("" if axis is None else axis)


def judge(camp: MujocoCampaign, noise_given: bool, weightless: bool = False) -> Outcome:
    """Diagnose ``camp`` (the noise levels given to diagnose or not) under the gravity it was
    measured with (``weightless``: with today's weightless model, the baseline of issue 22),
    and count."""
    kwargs: Dict[str, Any] = camp.noise_kwargs() if noise_given else {}
    gravity = None if weightless or not any(camp.gravity) else camp.gravity
    d = vjm.diagnose(camp.robot, camp.measurements, per_row=False, gravity=gravity, **kwargs)
    want = camp.hidden.expected()

    def hit(effect: str, joint: Optional[int], axis: Optional[str]) -> bool:
        # A joint alias names its axes joined by '+' (`joint_tilt J4 x+y`): it counts when one
        # of them is a compliant axis of the hidden tilt.
        axes = axis.split("+") if axis is not None else [None]
        return (
            want is not None and effect == want[0] and joint == want[1] and any(a in want[2] for a in axes)
        )

    named = any(hit(f.effect, f.joint, f.axis) for f in d.findings)
    alias = named or any(hit(a.effect or f.effect, a.joint, a.axis) for f in d.findings for a in f.aliases)
    joint_alias = any(
        hit(a.effect or f.effect, a.joint, a.axis) and "+" in (a.axis or "") for f in d.findings for a in f.aliases
    )
    wrong = any(
        f.effect != GEOMETRY
        and not hit(f.effect, f.joint, f.axis)
        and not any(hit(a.effect or f.effect, a.joint, a.axis) for a in f.aliases)
        for f in d.findings
    )
    return Outcome(
        alarm=bool(d.findings) or bool(d.unexplained),
        alarm_beyond_geometry=bool(d.unexplained) or any(f.effect != GEOMETRY for f in d.findings),
        named=named,
        named_or_alias=alias,
        joint_alias=joint_alias,
        wrong=wrong,
        unexplained=bool(d.unexplained),
        findings=[_label(f.effect, f.joint, f.axis) for f in d.findings],
        baseline_test=float(d.baseline.test_mean_rel_error),
        extended_test=float(d.extended.test_mean_rel_error),
    )
