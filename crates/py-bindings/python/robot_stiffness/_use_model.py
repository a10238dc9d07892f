"""Using a VJM stiffness model: plan a campaign (:func:`design`) and compensate the deflection
of a trajectory (:func:`compensate`, :func:`compensate_with_model_file`).

See ``docs/use-the-model.md`` for the methods, the stopping rule and the noise model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, List, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

from ._equality import FieldEq
from . import _core
from ._arguments import (
    DEFAULT_GRAVITY,
    RECORDED_GRAVITY,
    ModelGravity,
    ModelSpec,
    checked,
    gravity_vector,
    model_gravity,
    model_spec,
)
from ._arrays import f64
from ._errors import ArgumentTypeError, ShapeError
from ._robot_handle import RobotHandle

if TYPE_CHECKING:
    from .testbed import NoiseModel

Array = npt.NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class PlannedCombination(FieldEq):
    """One identifiable combination of compliances and its predicted standard error."""

    #: As the identification prints it, e.g. ``J1y + 1.000000*J2z``.
    label: str
    #: Predicted standard error of the identification's estimate, rad/(N·m).
    stderr: float
    #: ``(label, coefficient)`` per term; the first term has coefficient 1.
    terms: Tuple[Tuple[str, float], ...]
    #: The plan leaves it weak: its predicted standard error exceeds the size the prior gives it
    #: (a tilt as large as a typical torsion) or 1e-2 rad/(N·m).
    weak: bool = False


@dataclass(frozen=True, eq=False)
class Plan(FieldEq):
    """A planned VJM campaign (rows = poses × wrenches per pose)."""

    #: Joint positions per row, (rows, n), rad.
    q: Array
    #: Wrench per row, (rows, 6), N and N·m at the tip point, base frame.
    wrench: Array
    #: Pose index per row (0-based).
    pose: npt.NDArray[np.int64]
    #: Number of identifiable combinations.
    rank: int
    #: Every identifiable combination with its predicted standard error.
    combinations: Tuple[PlannedCombination, ...]
    #: The largest predicted standard error, rad/(N·m).
    worst_stderr: float
    #: The noise model assumed (tracker, force sensor, prior compliance, gravity).
    noise: NoiseModel
    #: Fewest wrenches per pose with which diagnose's ``pose_compliance`` block (compliance
    #: that changes from pose to pose) can test a pose: 3W > 3 + n (4 for 6 or 7 joints).
    pose_compliance_wrenches: int

    def csv_text(self) -> str:
        """The plan as a VJM measurement file with empty ``dx,dy,dz`` (fill them in)."""
        n = self.q.shape[1]
        head = [f"q{j + 1}" for j in range(n)] + ["fx", "fy", "fz", "mx", "my", "mz", "pose", "dx", "dy", "dz"]
        lines = [",".join(head)]
        for qi, wi, p in zip(self.q, self.wrench, self.pose):
            vals = [repr(float(x)) for x in qi] + [repr(float(x)) for x in wi] + [str(int(p)), "", "", ""]
            lines.append(",".join(vals))
        return "\n".join(lines) + "\n"


@dataclass(frozen=True, eq=False)
class Compensation(FieldEq):
    """Corrected joint targets and per-row outcome of :func:`compensate`."""

    #: Corrected joint targets, (N, n), rad.
    q: Array
    #: Predicted remaining position error of the loaded tip, (N,), m.
    position_error: Array
    #: Predicted remaining orientation error, (N,), rad.
    rotation_error: Array
    #: Predicted deflection without compensation, (N,), m.
    deflection: Array
    #: Predicted rotation without compensation, (N,), rad.
    rotation_deflection: Array
    #: Inverse condition number of the task Jacobian at the corrected targets, (N,).
    inverse_condition: Array
    #: Gauss–Newton steps per row, (N,).
    iterations: npt.NDArray[np.int64]
    #: First joint (0-based) outside its limits, −1 when none, (N,).
    limit_joint: npt.NDArray[np.int64]
    #: ``converged``, ``outside_limits``, ``near_singular``, ``not_converged`` or ``unstable``.
    status: Tuple[str, ...]


def _model_of(model: Optional[ModelSpec], compliance: Array, n_joints: int) -> ModelSpec:
    """``model``, or (None) the model the number of compliances names: n traditional, 3n extended."""
    if model is not None:
        return model
    if compliance.ndim == 1 and compliance.size in (n_joints, 3 * n_joints):
        return "traditional" if compliance.size == n_joints else "extended"
    raise ShapeError(
        f"compliance has shape {compliance.shape}: without model= give {n_joints} values (traditional) or "
        f"{3 * n_joints} (extended), or name the springs with model="
    )


def _robot_inner(robot: Any) -> Any:
    if not isinstance(robot, RobotHandle):
        raise ArgumentTypeError(f"robot must be a robot_stiffness.vjm.Robot, got {type(robot).__name__}")
    return robot._inner


def _payload(payload: Any) -> Optional[Tuple[float, List[float]]]:
    if payload is None:
        return None
    try:
        values = [float(v) for v in payload]
    except (TypeError, ValueError):
        raise ArgumentTypeError("payload must be (mass,) or (mass, cx, cy, cz): kg and m in the tip frame") from None
    if len(values) not in (1, 4):
        raise ArgumentTypeError(f"payload must be (mass,) or (mass, cx, cy, cz), got {len(values)} values")
    centre = values[1:] if len(values) == 4 else [0.0, 0.0, 0.0]
    return values[0], centre


def _compensation(q: Array, rows: Array, status: List[str]) -> Compensation:
    return Compensation(
        q=q,
        position_error=rows[:, 0],
        rotation_error=rows[:, 1],
        deflection=rows[:, 2],
        rotation_deflection=rows[:, 3],
        inverse_condition=rows[:, 4],
        iterations=rows[:, 5].astype(np.int64),
        limit_joint=rows[:, 6].astype(np.int64),
        status=tuple(status),
    )


def _q_and_wrench(q: Any, wrench: Any) -> Tuple[Array, Optional[Array]]:
    arr = f64(q, "q")
    if arr.ndim == 1:
        arr = arr.reshape(1, -1)
    w = None
    if wrench is not None:
        w = f64(wrench, "wrench")
        if w.ndim == 1:
            w = w.reshape(1, -1)
    return arr, w


@checked
def compensate(
    robot: Any,
    q: Any,
    compliance: Any,
    model: Optional[ModelSpec] = None,
    wrench: Any = None,
    payload: Any = None,
    match_orientation: bool = False,
    with_kc: bool = True,
    allow_outside_limits: bool = False,
    gravity: Optional[Sequence[float]] = DEFAULT_GRAVITY,
    load_only: bool = False,
) -> Compensation:
    """Corrected joint targets so that the loaded tip reaches the nominal unloaded tip.

    ``q``: nominal targets (N, n) rad; ``compliance``: (m,) rad/(N·m) for the springs of
    ``model`` (None: the traditional model for n values, the extended one for 3n; for aliased springs any vector reproducing the identifiable combinations, e.g. the
    minimum-norm solution); the load is ``wrench`` (N, 6) N and N·m at the tip point, base frame,
    or ``payload`` ``(mass,)`` / ``(mass, cx, cy, cz)`` kg and m in the tip frame (gravity along −z
    of the base). ``match_orientation`` matches the tip orientation too; ``with_kc`` includes the
    complementary stiffness K_C in the deflection. The inputs get the checks of
    :meth:`Robot.identify <robot_stiffness.vjm.Robot.identify>` (implausible angles or loads,
    joint angles outside the URDF limits — ``allow_outside_limits=True`` to accept those).

    By default the tip's sag under the arm's own weight is corrected too, under ``gravity``
    (m/s², base frame; default ``DEFAULT_GRAVITY``, 9.80665 along −z): the nominal tip is then
    the rigid kinematics' pose, and the loaded tip the springs' static equilibrium under the
    arm's weight, the payload's weight and the wrench (docs/gravity.md; the URDF must give the
    masses, an error naming a link without one). ``load_only=True`` (or ``gravity=None``)
    corrects the load's deflection only, weightless, as before gravity was modelled: for a
    controller that already corrects the arm's own sag.
    """
    inner = _robot_inner(robot)
    arr, w = _q_and_wrench(q, wrench)
    g = None if load_only or gravity is None else gravity_vector(gravity)
    c = f64(compliance, "compliance")
    out = _core.vjm_compensate(
        inner, model_spec(_model_of(model, c, robot.n_joints)), c, arr, w, _payload(payload),
        bool(match_orientation), bool(with_kc), allow_outside_limits=bool(allow_outside_limits),
        gravity=g,
    )
    return _compensation(*out)


@checked
def compensate_with_model_file(
    robot: Any,
    path: str,
    q: Any,
    wrench: Any = None,
    payload: Any = None,
    match_orientation: Optional[bool] = None,
    with_kc: bool = True,
    allow_outside_limits: bool = False,
    gravity: ModelGravity = RECORDED_GRAVITY,
    load_only: bool = False,
) -> Compensation:
    """:func:`compensate` with the springs and compliances of a saved model file (``identify vjm
    --save``); the file's robot and content hash are checked. ``match_orientation`` defaults to
    whether the model was identified with rotations. The sag under the arm's weight is
    corrected unless ``load_only`` or ``gravity=None``; ``gravity`` defaults to the one the
    model was identified under (``"recorded"``; standard gravity when the file records none)."""
    inner = _robot_inner(robot)
    arr, w = _q_and_wrench(q, wrench)
    # The recorded gravity is resolved where the file is read (the core); text other than
    # "recorded" is refused here, as StiffnessModel.compensate refuses it.
    recorded = not load_only and isinstance(gravity, str) and model_gravity(gravity, None) is not None
    g = None if load_only or recorded or gravity is None else gravity_vector(gravity)
    out = _core.vjm_compensate_model_file(
        inner, str(path), arr, w, _payload(payload), match_orientation, bool(with_kc),
        allow_outside_limits=bool(allow_outside_limits), gravity=g, recorded_gravity=recorded,
    )
    return _compensation(*out)


@checked
def design(
    robot: Any,
    model: ModelSpec = "traditional",
    poses: int = 24,
    wrenches_per_pose: int = 4,
    seed: int = 0,
    margin: float = 0.1,
    pool_size: int = 300,
    progress: Optional[Callable[[str, int, int], None]] = None,
    gravity: Optional[Sequence[float]] = DEFAULT_GRAVITY,
) -> Plan:
    """Plans a campaign: ``poses`` poses inside the joint limits (``margin`` rad inside) and
    ``wrenches_per_pose`` wrenches each (80 N, 3 N·m), chosen greedily to minimise the worst
    predicted standard error of the identifiable combinations of ``model``, under the testbed's
    laser-tracker and force/torque-sensor noise with its nominal compliances as the prior.
    Limits: ``poses`` ≤ 10 000, ``wrenches_per_pose`` ≤ 100, at most 100 000 measurements
    (poses × wrenches), ``pool_size`` ≤ 100 000 (the largest take under a minute).
    ``progress(stage, done, total)`` is called during the run (stages ``poses``, ``pool``,
    ``selection``, ``check``); an exception it raises, or Ctrl-C, stops it.

    ``gravity`` (m/s², base frame; default ``DEFAULT_GRAVITY``, as :meth:`Robot.identify
    <robot_stiffness.vjm.Robot.identify>`): the campaign is measured under the arm's weight, so
    each row is planned at the arm's sagged pose under the prior (the URDF must give the link
    masses); ``None``: weightless."""
    if progress is not None and not callable(progress):
        raise ArgumentTypeError(f"progress must be callable as progress(stage, done, total), got {type(progress).__name__}")
    inner = _robot_inner(robot)
    plan = _core.vjm_design(
        inner, model_spec(model), int(poses), int(wrenches_per_pose), int(seed), float(margin), int(pool_size),
        progress=progress, gravity=None if gravity is None else gravity_vector(gravity))
    labels = robot.labels(model)
    # A non-finite standard error arrives as None: an unbounded one.
    combos = tuple(
        PlannedCombination(
            label=c.label,
            stderr=math.inf if c.stderr is None else float(c.stderr),
            terms=tuple((labels[param], float(coefficient)) for param, coefficient in c.terms),
            weak=bool(c.weak),
        )
        for c in plan.combinations
    )
    from ._core_values import build
    from .testbed import NoiseModel

    noise = build(NoiseModel, plan.noise)
    assert isinstance(noise, NoiseModel)
    return Plan(
        q=plan.q,
        wrench=plan.wrench,
        pose=plan.pose,
        rank=int(plan.rank),
        combinations=combos,
        worst_stderr=math.inf if plan.worst_stderr is None else float(plan.worst_stderr),
        noise=noise,
        pose_compliance_wrenches=int(plan.pose_compliance_wrenches),
    )
