"""Typed descriptions of what the testbed simulates and what a plan assumes.

:func:`robot_stiffness.vjm.simulate` returns a campaign with its hidden ``truth``
(:class:`TrueModel`: the springs' linear compliances and the effects on top, one class per
effect kind) and its ``spec`` (:class:`CampaignSpec`); :func:`robot_stiffness.vjm.design`
returns a plan with the ``noise`` model it assumed (:class:`NoiseModel`). They are frozen
dataclasses built from the core's values (``_core_values.build``), with the core's keys:
``obj["key"]`` reads a field as the dicts of earlier versions did, and ``to_dict()`` gives the
JSON of ``robot-stiffness simulate vjm --truth``. Joints count from 1, as
:func:`~robot_stiffness.vjm.simulate` takes them. Units SI (m, rad, N, N·m, m/s²); vectors in
the robot's base frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

from ._core_values import Record, build, register_builder

__all__ = [
    "TrackerNoise",
    "ForceSensorNoise",
    "NoiseModel",
    "CampaignSpec",
    "TrueModel",
    "TrueEffect",
    "HarmonicDriveSpring",
    "JointTilt",
    "JointTorsionNonlinear",
    "LinkTranslation",
    "JointBacklash",
    "WrenchBias",
    "FrameMisalignment",
    "GeometricNonlinearity",
    "JointTorsionAngleDependent",
    "PoseDrift",
    "MountCompliance",
    "ToolAxialCompliance",
    "SensorCrosstalk",
]

Vector3 = Tuple[float, float, float]


# ----------------------------------------------------------------------------- instruments


@dataclass(frozen=True, eq=False)
class TrackerNoise(Record):
    """Laser-tracker noise: maximum permissible error ``mpe_const`` + ``mpe_per_m``·L (m, m/m;
    L the distance to the tracker), read as 2σ per axis on each reading; the tracker at
    ``position`` (m, base frame)."""

    mpe_const: float
    mpe_per_m: float
    position: Vector3


@dataclass(frozen=True, eq=False)
class ForceSensorNoise(Record):
    """Force/torque-sensor noise: ``relative_accuracy`` of full scale (``force_full_scale`` N,
    ``moment_full_scale`` N·m) per axis, read as 2σ."""

    force_full_scale: float
    moment_full_scale: float
    relative_accuracy: float


@dataclass(frozen=True, eq=False)
class NoiseModel(Record):
    """The noise a plan assumed: the instruments, the prior compliance per spring of the model
    (rad/(N·m)) and the gravity the campaign is measured under (m/s², base frame; None:
    weightless)."""

    tracker: TrackerNoise
    force_sensor: ForceSensorNoise
    prior_compliance: List[float]
    gravity: Optional[Vector3] = field(default=None, metadata={"omit_none": True})


# ----------------------------------------------------------------------------- campaign


@dataclass(frozen=True, eq=False)
class CampaignSpec(Record):
    """How a campaign was simulated: ``n_poses`` configurations × ``wrenches_per_pose``
    wrenches (force magnitude uniform in ``force_range`` N, moment up to ``moment_max`` N·m),
    ``test_fraction`` of the poses held out, the instruments and whether their ``noise`` was
    drawn, the poses ``limit_margin`` rad inside the limits, with an actuated Jacobian's
    inverse condition of at least ``min_inverse_condition`` and the tip ``min_tip_height`` m
    above the base, drawn from ``seed``; under ``gravity`` (m/s², base frame; None: weightless)."""

    n_poses: int
    wrenches_per_pose: int
    force_range: Tuple[float, float]
    moment_max: float
    test_fraction: float
    tracker: TrackerNoise
    force_sensor: ForceSensorNoise
    noise: bool
    limit_margin: float
    min_inverse_condition: float
    min_tip_height: float
    seed: int
    gravity: Optional[Vector3] = field(default=None, metadata={"omit_none": True})


# ----------------------------------------------------------------------------- true model


@dataclass(frozen=True, eq=False)
class TrueEffect(Record):
    """One effect of a true model on top of its linear springs; ``effect`` is its kind as
    :func:`~robot_stiffness.vjm.simulate` takes it (``"joint_tilt"``, …), the subclass its
    parameters."""

    effect: str


@dataclass(frozen=True, eq=False)
class JointTilt(TrueEffect):
    """A tilting spring of ``compliance`` rad/(N·m) at ``joint`` about ``axis`` (``"x"`` or
    ``"y"``)."""

    joint: int
    axis: str
    compliance: float


@dataclass(frozen=True, eq=False)
class HarmonicDriveSpring(Record):
    """A harmonic-drive torsion curve, odd in the torque τ: stiffness ``k1`` for |τ| ≤ ``t1``,
    ``k2`` up to ``t2``, ``k3`` beyond (N·m/rad; torques N·m)."""

    k1: float
    k2: float
    k3: float
    t1: float
    t2: float


@dataclass(frozen=True, eq=False)
class JointTorsionNonlinear(TrueEffect):
    """``joint``'s torsion follows the curve ``spring`` instead of its linear compliance."""

    joint: int
    spring: HarmonicDriveSpring


@dataclass(frozen=True, eq=False)
class LinkTranslation(TrueEffect):
    """A translational spring of ``compliance`` m/N in the link after ``joint``, along its
    ``axis`` (``"x"``, ``"y"`` or ``"z"`` of the joint's child frame)."""

    joint: int
    axis: str
    compliance: float


@dataclass(frozen=True, eq=False)
class JointBacklash(TrueEffect):
    """Lost motion at ``joint``: it moves an extra ½·``lost_motion``·sign(τ) rad under load
    (``lost_motion`` the full dead-band width)."""

    joint: int
    lost_motion: float


@dataclass(frozen=True, eq=False)
class WrenchBias(TrueEffect):
    """The recorded wrench is the applied one plus ``bias`` [fx, fy, fz, mx, my, mz] (N, N·m,
    base frame)."""

    bias: List[float]


@dataclass(frozen=True, eq=False)
class FrameMisalignment(TrueEffect):
    """The tracker's frame is rotated from the base: recorded displacements are exp(hat(φ))·d,
    φ = ``rotation`` (rotation vector, rad)."""

    rotation: List[float]


@dataclass(frozen=True, eq=False)
class GeometricNonlinearity(TrueEffect):
    """Equilibrium in the deflected configuration (the load-dependent Jacobian, K_C) and the
    exact tip motion, instead of the linear J C Jᵀ W."""


@dataclass(frozen=True, eq=False)
class JointTorsionAngleDependent(TrueEffect):
    """``joint``'s torsion compliance depends on its own angle, c·(1 + ``amplitude``·sin q),
    ``amplitude`` in (−1, 1) (outside the diagnosis catalogue)."""

    joint: int
    amplitude: float


@dataclass(frozen=True, eq=False)
class PoseDrift(TrueEffect):
    """Every pose's displacements carry an independent offset of per-axis standard deviation
    ``sigma`` m (outside the diagnosis catalogue)."""

    sigma: float


@dataclass(frozen=True, eq=False)
class MountCompliance(TrueEffect):
    """A compliant mount: the arm translates by ``translation``·f (m/N) and rotates by
    ``rotation``·(m + p × f) (rad/(N·m)) about the base origin (outside the diagnosis
    catalogue)."""

    translation: float
    rotation: float


@dataclass(frozen=True, eq=False)
class ToolAxialCompliance(TrueEffect):
    """A tool compliant along its own axis z (the unloaded tip frame's): the tool tip moves by
    ``compliance``·(f·z)·z, m/N (outside the diagnosis catalogue)."""

    compliance: float


@dataclass(frozen=True, eq=False)
class SensorCrosstalk(TrueEffect):
    """The force sensor's cross-axis sensitivity: f_rec = f + ``coupling``·(f_z, f_x, f_y),
    moments exact (outside the diagnosis catalogue)."""

    coupling: float


#: Each effect class by the ``effect`` key of its core value.
EFFECTS: Dict[str, type] = {
    "joint_tilt": JointTilt,
    "joint_torsion_nonlinear": JointTorsionNonlinear,
    "link_translation": LinkTranslation,
    "joint_backlash": JointBacklash,
    "wrench_bias": WrenchBias,
    "frame_misalignment": FrameMisalignment,
    "geometric_nonlinearity": GeometricNonlinearity,
    "joint_torsion_angle_dependent": JointTorsionAngleDependent,
    "pose_drift": PoseDrift,
    "mount_compliance": MountCompliance,
    "tool_axial_compliance": ToolAxialCompliance,
    "sensor_crosstalk": SensorCrosstalk,
}


def _effect_from_core(value: object) -> object:
    """An effect's class by its ``effect`` tag (two kinds may share their other keys)."""
    if not isinstance(value, dict) or value.get("effect") not in EFFECTS:
        raise TypeError(f"not an effect of a true model: {value!r}")
    return build(EFFECTS[value["effect"]], value)


register_builder(TrueEffect, _effect_from_core)


@dataclass(frozen=True, eq=False)
class TrueModel(Record):
    """A simulated arm's hidden truth: the linear ``compliance`` of every spring (3n values,
    rad/(N·m): torsion, tilt x, tilt y per joint) and the ``effects`` on top of them."""

    compliance: List[float]
    effects: List[TrueEffect]
