"""The model a diagnosis found, as a stiffness model to predict and compensate with
(``diagnose vjm --save MODEL.json``, :func:`robot_stiffness.vjm.diagnosed_model`).

A spring model holds the joints' virtual springs: the diagnosis' baseline and the tilts it found
(``traditional + joint_tilt(J3x)``, read by the one model vocabulary). The measurement errors it
found — a wrench bias, a tracker-frame rotation — are not the arm's: they are taken out of the
rows with the diagnosis' joint estimates (recorded wrench − bias; displacement rotated back by the
frame rotation) before the springs are identified on every row. What the arm does that a spring
model cannot hold (a link's or the mount's translation, a scaled K_C)
is left out and listed, so that the user knows what predictions will miss.

A gear's curve (``joint_torsion_nonlinear``) and its lost motion (``joint_backlash``) are kept:
the model file records them as the joint's gear curve (``gear_curves``: the finding's ``knots``
in N·m and the extended fit's coefficients in rad/(N·m); the backlash's estimate b in rad as
``lost_motion_rad``; one curve per joint when both are found), which ``predict`` and
``compensate`` evaluate. The springs are then identified on
the rows with the curve's share taken out (its first-order column, as ``predict`` evaluates it,
at the springs identified on the raw rows first), so that they do not absorb it twice.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from ._arguments import DEFAULT_GRAVITY
from ._equality import FieldEq
from . import so3
from ._errors import ArgumentTypeError
from .model import GearCurve

if TYPE_CHECKING:
    from ._vjm_data import DataFile
    from .vjm import Identification, Robot

#: Findings that are errors of the measurement, corrected in the rows before the fit.
CORRECTED = ("wrench_bias", "frame_misalignment")


@dataclass(frozen=True, eq=False)
class DiagnosedModel(FieldEq):
    """The springs of a diagnosis' model identified on every row of its data."""

    #: The identification of ``springs`` on the corrected rows; its ``stiffness_model`` is
    #: what ``predict``/``compensate`` use (``identification.save(path)``).
    identification: "Identification"
    #: The spring model in the one model vocabulary, e.g. ``traditional + joint_tilt(J3x)``.
    springs: str
    #: Measurement errors taken out of the rows: label → the estimate used (N, N·m or rad).
    corrected: Dict[str, List[float]]
    #: ``(label, why)`` of each finding the spring model does not hold.
    left_out: Tuple[Tuple[str, str], ...]
    #: The gears' curves the model holds (``joint_torsion_nonlinear`` and ``joint_backlash``
    #: findings, one curve per joint), as the saved
    #: model's :attr:`~robot_stiffness.model.StiffnessModel.gear_curves`.
    gear_curves: Tuple[GearCurve, ...] = ()


def _label(f: Any) -> str:
    if f.joint is None:
        return str(f.effect)
    return f"{f.effect}(J{f.joint}{f.axis or ''})"


def _estimate(diagnosis: Any, prefix: str) -> List[float]:
    """The extended fit's values of one finding's parameters (``wrench_bias.fx``, …)."""
    values = [p.value for p in diagnosis.extended.parameters if p.label.startswith(prefix + ".")]
    return [0.0 if v is None else float(v) for v in values]


def diagnosed_model(
    robot: "Robot",
    data: Any,
    diagnosis: Any,
    *,
    gravity: Optional[Sequence[float]] = DEFAULT_GRAVITY,
    data_file: Union[str, DataFile, None] = None,
    allow_outside_limits: bool = False,
) -> DiagnosedModel:
    """The spring model of ``diagnosis`` (of :func:`~robot_stiffness.vjm.diagnose` on ``data``,
    a :class:`~robot_stiffness.vjm.Measurements`) identified on every row of ``data`` under
    ``gravity`` (as the diagnosis was run), with its measurement errors taken out first; see the
    module documentation. ``data_file`` is recorded in the model file as :meth:`Robot.identify`
    records it."""
    if not hasattr(diagnosis, "findings") or not hasattr(diagnosis, "baseline"):
        raise ArgumentTypeError(f"diagnosis must be a Diagnosis of vjm.diagnose, got {type(diagnosis).__name__}")
    terms = [diagnosis.baseline.model]
    corrected: Dict[str, List[float]] = {}
    left_out: List[Tuple[str, str]] = []
    curves: List[GearCurve] = []

    def add(curve: GearCurve) -> None:
        """``curve`` as its joint's curve, merged with one found before (knots from the torsion
        finding, lost motion from the backlash finding)."""
        for i, have in enumerate(curves):
            if have.joint == curve.joint:
                shape = have if have.knots else curve
                curves[i] = shape._replace(lost_motion=max(have.lost_motion, curve.lost_motion))
                return
        curves.append(curve)

    for f in diagnosis.findings:
        if f.effect == "joint_tilt":
            terms.append(_label(f))
        elif f.effect in CORRECTED:
            corrected[f.effect] = _estimate(diagnosis, f.effect)
        elif f.effect == "joint_torsion_nonlinear" and f.knots is not None:
            coefficients = tuple(float(a) for a in f.evidence.estimate)
            if len(coefficients) == len(f.knots) and all(math.isfinite(a) for a in coefficients):
                add(GearCurve(int(f.joint), tuple(float(t) for t in f.knots), coefficients))
            else:
                left_out.append((_label(f), "its curve's coefficients are not determined by these data"))
        elif f.effect == "joint_backlash" and f.joint is not None:
            b = [float(x) for x in f.evidence.estimate]
            if len(b) == 1 and math.isfinite(b[0]) and b[0] > 0.0:
                add(GearCurve(int(f.joint), (), (), b[0]))
            else:
                left_out.append((_label(f), f"its lost motion {b} rad is not a positive number on these data"))
        else:
            left_out.append((_label(f), "not a virtual spring of a joint: predictions will not include it"))
    wrench = np.array(data.wrench, dtype=np.float64)
    displacement = np.array(data.displacement, dtype=np.float64)
    if "wrench_bias" in corrected:
        wrench -= np.asarray(corrected["wrench_bias"])  # recorded = applied + bias
    if "frame_misalignment" in corrected:
        # recorded = R(φ)·d: rotate back, d = R(−φ)·recorded (rows: recorded · R(−φ)ᵀ).
        displacement = displacement @ so3.exp(-np.asarray(corrected["frame_misalignment"])).T
    springs = " + ".join(terms)

    def fit(d: Any) -> "Identification":
        return robot.identify(
            data.q, wrench, d, springs, gravity=gravity, data_file=data_file,
            robust_covariance=True, allow_outside_limits=allow_outside_limits,
        )

    identification = fit(displacement)
    if curves:
        # The curves' share of each row (curved − linear prediction of the springs fitted on the
        # raw rows: the diagnosis' column times its coefficients) is taken out, the springs
        # fitted again, and the curves put in the saved model.
        first = identification.stiffness_model
        assert first is not None  # Robot.identify always makes one
        bent = first.with_gear_curves(curves)
        share = (
            bent.predict(data.q, wrench=wrench, gravity=gravity, allow_outside_limits=allow_outside_limits).deflection
            - first.predict(data.q, wrench=wrench, gravity=gravity, allow_outside_limits=allow_outside_limits).deflection
        )
        width = displacement.shape[1]
        identification = fit(displacement - np.nan_to_num(share[:, :width]))
        model = identification.stiffness_model
        assert model is not None
        identification = dataclasses.replace(identification, stiffness_model=model.with_gear_curves(curves))
    return DiagnosedModel(
        identification=identification, springs=springs, corrected=corrected, left_out=tuple(left_out),
        gear_curves=tuple(curves),
    )
