"""The model a diagnosis found, as a stiffness model to predict and compensate with
(``diagnose vjm --save MODEL.json``, :func:`robot_stiffness.vjm.diagnosed_model`).

A spring model holds the joints' virtual springs: the diagnosis' baseline and the tilts it found
(``traditional + joint_tilt(J3x)``, read by the one model vocabulary). The measurement errors it
found — a wrench bias, a tracker-frame rotation — are not the arm's: they are taken out of the
rows with the diagnosis' joint estimates (recorded wrench − bias; displacement rotated back by the
frame rotation) before the springs are identified on every row. What the arm does that a spring
model cannot hold (a link's or the mount's translation, a gear's curve, lost motion, a scaled K_C)
is left out and listed, so that the user knows what predictions will miss.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ._arguments import DEFAULT_GRAVITY
from ._equality import FieldEq
from . import so3
from ._errors import ArgumentTypeError

if TYPE_CHECKING:
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
    data_file: Optional[str] = None,
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
    for f in diagnosis.findings:
        if f.effect == "joint_tilt":
            terms.append(_label(f))
        elif f.effect in CORRECTED:
            corrected[f.effect] = _estimate(diagnosis, f.effect)
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
    identification = robot.identify(
        data.q, wrench, displacement, springs, gravity=gravity, data_file=data_file,
        robust_covariance=True, allow_outside_limits=allow_outside_limits,
    )
    return DiagnosedModel(
        identification=identification, springs=springs, corrected=corrected, left_out=tuple(left_out),
    )
