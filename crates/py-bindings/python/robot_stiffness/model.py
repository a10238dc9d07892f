"""Stiffness model files: an identification saved for later use, and predictions from it.

A :class:`StiffnessModel` is what :meth:`robot_stiffness.vjm.Identification.save` writes and
:meth:`StiffnessModel.load` reads back: the robot (URDF path and SHA-256 of its text, base, tip,
joints), the springs, the identifiable combinations, the parameter vector used for prediction
with its covariance, the null space (what the data could not see), the noise model and the data
it came from. Loading refuses a file edited after it was saved, written for another schema
version, or describing another robot (:class:`~robot_stiffness.ModelFileError`). The file format
is documented field by field in ``docs/model-file.md``.

Predictions use only what the data identified: with aliased springs (on a UR5, J1y + J2z is all
the data can see) the prediction is still exact for every pose and load whose regressor lies in
the identified row space; a row that excites a direction the data never saw is flagged
(``identified`` False, no standard deviation) instead of being silently predicted.

Example::

    >>> from robot_stiffness.vjm import Robot, simulate
    >>> from robot_stiffness.model import StiffnessModel
    >>> robot = Robot.bundled()
    >>> data = simulate(robot, [], n_poses=12, seed=3).measurements
    >>> ident = robot.identify(data.q, data.wrench, data.displacement, model="extended")
    >>> pred = ident.stiffness_model.predict(data.q[:2], payload=(2.0, 0.0, 0.0, 0.05))
    >>> pred.deflection.shape, bool(pred.identified.all())
    ((2, 6), True)
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Dict, List, NamedTuple, Optional, Sequence, Tuple, Union, cast

import numpy as np
import numpy.typing as npt

from ._equality import FieldEq
from . import _core
from ._arguments import RECORDED_GRAVITY, ModelGravity, checked, model_gravity, real
from ._arrays import f64
from ._errors import InvalidValueError
from ._outputs import Outputs
from ._use_model import Compensation, _compensation, _q_and_wrench

if TYPE_CHECKING:  # pragma: no cover
    from .vjm import Robot

__all__ = ["StiffnessModel", "Prediction", "STANDARD_GRAVITY", "Payload", "GearCurve"]

Array = npt.NDArray[np.float64]
PathLike = Union[str, "os.PathLike[str]"]

class GearCurve(NamedTuple):
    """A joint's non-linear gear (``docs/gravity.md``, *Non-linear gears in the model*): its
    torsion spring deflects by θ(T) = c·T + Σ a_k h_k(T) + ½ b·sign(T) under the total torque T
    it carries, h_k(T) = sign(T)·max(|T| − t_k, 0), b the lost motion (sign(0) = 0). A curve
    may hold lost motion and no knots."""

    #: 1-based joint (base → tip); the model has its torsion spring ``J<joint>z``.
    joint: int
    #: The knots t_k, N·m.
    knots: Tuple[float, ...]
    #: The coefficients a_k, rad/(N·m): the tangent compliance's change beyond each knot.
    coefficients: Tuple[float, ...]
    #: The lost motion b, rad (≥ 0; 0 for a gear without backlash): the width of the dead band
    #: the joint crosses when its torque changes sign.
    lost_motion: float = 0.0


#: Standard gravity (m/s²) acting along −z of the base frame on a payload (vjm::STANDARD_GRAVITY).
STANDARD_GRAVITY = 9.80665

#: The ``urdf`` a model file records for the bundled arm (vjm::BUNDLED_URDF_PATH).
BUNDLED_URDF_PATH = "bundled:panda_arm.urdf"


def recorded_urdf(robot: Optional[Dict[str, Any]]) -> Optional[str]:
    """The URDF file a model's ``robot`` record names: the absolute path recorded when the model
    was built (older files: the path as given, relative to the current folder); None for the
    bundled arm, URDF text given directly, or no record. :meth:`StiffnessModel.save` never
    writes over it; the CLI protects it as an input of ``predict``/``compensate`` unless it
    found the URDF elsewhere (relative to the model file: ``urdf_relative``), then that one."""
    urdf = robot.get("urdf") if isinstance(robot, dict) else None
    if not isinstance(urdf, str) or not urdf or urdf == BUNDLED_URDF_PATH:
        return None
    return urdf


#: A payload: a mass in kg (at the tip point), or ``(mass, cx, cy, cz)`` with the centre of
#: mass in m in the tip frame.
Payload = Union[float, Sequence[float]]


@dataclass(frozen=True, eq=False)
class Prediction(FieldEq):
    """Predicted tip deflections, one row per pose (base frame).

    ``deflection`` (N, 6): ``[dx, dy, dz, rx, ry, rz]`` in m and rad (rotation vector); the
    rotations are NaN when the model was identified without rotations. ``stddev`` (N, 6): the
    standard deviation of the predicted **true** deflection from the parameter covariance,
    √(a V aᵀ) — not of a new measurement (add :meth:`StiffnessModel.measurement_stddev` in
    quadrature for that); NaN where unavailable. ``wrench`` (N, 6): the wrench used (N, N·m, at
    the tip point, base frame). ``identified`` (N,): the row lies in what the data identified.
    ``excitation`` (N,): how far it leaves that space (sine of the angle; ~1e-15 when inside).
    """

    deflection: Array
    stddev: Array
    wrench: Array
    identified: npt.NDArray[np.bool_]
    excitation: Array


def _prediction(columns: "_core.PredictionColumns") -> Prediction:
    """The core's prediction columns as a :class:`Prediction` (the same arrays, not copied)."""
    return Prediction(
        deflection=columns.deflection,
        stddev=columns.stddev,
        wrench=columns.wrench,
        identified=columns.identified,
        excitation=columns.excitation,
    )


_PAYLOAD_NAMES = ("payload mass (kg)", "payload cx (m)", "payload cy (m)", "payload cz (m)")


def _payload(payload: Payload) -> tuple:
    """``(mass, cx, cy, cz)`` from a mass or a sequence of 1 or 4 real numbers."""
    scalar = isinstance(payload, (str, bytes)) or not hasattr(payload, "__len__")
    items: List[Any] = [payload] if scalar else list(cast(Sequence[Any], payload))
    if len(items) not in (1, 4):
        raise InvalidValueError(
            f"payload must be a mass in kg or (mass, cx, cy, cz), got {len(items)} numbers"
        )
    values = [real(v, name) for v, name in zip(items, _PAYLOAD_NAMES)]
    if values[0] < 0:
        raise InvalidValueError(f"payload mass must be ≥ 0 kg, got {values[0]}")
    return tuple(values + [0.0] * (4 - len(values)))


class StiffnessModel:
    """A saved stiffness model bound to the robot it describes (immutable).

    Obtain one from :attr:`robot_stiffness.vjm.Identification.stiffness_model` or :meth:`load`.
    """

    __slots__ = ("_inner", "_robot")

    def __init__(self, inner: Any, robot: "Robot") -> None:
        """Wraps a ``robot_stiffness._core.StiffnessModel``; use :meth:`load` instead."""
        if not isinstance(inner, _core.StiffnessModel):
            raise TypeError("use StiffnessModel.load(path, robot) or Identification.stiffness_model")
        self._inner = inner
        self._robot = robot

    @classmethod
    @checked
    def load(cls, path: PathLike, robot: Robot) -> "StiffnessModel":
        """Reads the model file at ``path`` for ``robot``.

        Raises :class:`~robot_stiffness.ModelFileError` naming the file when it was edited after
        it was saved (content hash), has another schema version, is not a model file, or was
        identified on another robot (URDF content, base or tip link, joints);
        :class:`~robot_stiffness.MissingFileError` when it cannot be read.
        """
        return cls(_core.StiffnessModel.load(os.fspath(path), robot._inner), robot)

    @checked
    def save(self, path: PathLike, *, force: bool = False) -> None:
        """Writes the model file to ``path`` atomically (a failure leaves ``path`` untouched).

        Raises :class:`~robot_stiffness.OutputPathError` when ``path`` exists (unless ``force``),
        is not a regular file (a FIFO, a device, a symbolic link: never replaced), or is the
        URDF this model names; the rules of the CLI's outputs (``docs/python.md``)."""
        urdf = recorded_urdf(self.to_dict().get("robot"))
        out = Outputs(inputs=[] if urdf is None else [(urdf, "the URDF this model names")], force=force,
                      hint="force=True")
        try:
            out.file(path).write_text(self._text_at(path))
            out.commit()
        finally:
            out.discard()

    def to_json(self) -> str:
        """The model file's text."""
        return str(self._inner.to_json())

    def _text_at(self, path: PathLike) -> str:
        """The text of the model file at ``path``: :meth:`to_json` with ``urdf_relative``, the
        URDF's path relative to the folder of ``path`` (``docs/model-file.md``)."""
        return str(self._inner.to_json_at(os.fspath(path)))

    def __eq__(self, other: object) -> bool:
        # The model file's text is the model (it names the robot by its URDF hash, base and tip).
        if type(other) is not type(self):
            return NotImplemented
        return self.to_json() == other.to_json()  # type: ignore[attr-defined]

    __hash__ = None  # type: ignore[assignment]

    def __reduce__(self) -> Tuple[Any, ...]:
        # Pickled as the model file's text and the robot (which pickles its URDF text): no
        # file is needed where it is unpickled, and the text is checked again there.
        return (_model_from_json, (self.to_json(), self._robot))

    def to_dict(self) -> Dict[str, Any]:
        """The model's content as a dict (``robot``, ``springs``, ``identification``,
        ``estimate``, ``noise``, ``data``, ``created_by``; see ``docs/model-file.md``)."""
        return dict(self._inner.to_dict())

    @property
    def robot(self) -> "Robot":
        """The robot the model is bound to."""
        return self._robot

    @property
    def labels(self) -> List[str]:
        """Spring labels in parameter order, e.g. ``["J1z", "J1x", ...]``."""
        return list(self._inner.labels)

    @property
    def rank(self) -> int:
        """Number of identifiable combinations."""
        return int(self._inner.rank)

    @property
    def gear_curves(self) -> List[GearCurve]:
        """The model's non-linear gears (read-only; empty for a model without curves): one
        :class:`GearCurve` per curved joint, as the model file's ``gear_curves`` records them.
        :meth:`predict`, :meth:`predict_sag` and :meth:`compensate` evaluate them."""
        return [
            GearCurve(int(j), tuple(float(t) for t in k), tuple(float(a) for a in c), float(b))
            for j, k, c, b in self._inner.gear_curves
        ]

    @checked
    def with_gear_curves(self, curves: Sequence[Any]) -> "StiffnessModel":
        """This model with the gear curves ``curves`` (each a :class:`GearCurve` or a
        ``(joint, knots, coefficients[, lost_motion])`` tuple: 1-based joint, knots in N·m,
        coefficients in rad/(N·m), lost motion in rad, 0 when left out) in place of any it had.
        An error names the joint of a malformed curve or of one whose joint has no torsion spring
        in the model."""
        tuples = []
        for curve in curves:
            j, k, c, *rest = curve
            if len(rest) > 1:
                raise InvalidValueError(f"the gear curve of joint {j}: (joint, knots, coefficients[, lost_motion]), "
                                 f"got {len(rest) + 3} entries")
            tuples.append((
                int(j),
                [real(t, f"the gear curve of joint {j}: knot {i}") for i, t in enumerate(k)],
                [real(a, f"the gear curve of joint {j}: coefficient {i}") for i, a in enumerate(c)],
                real(rest[0], f"the gear curve of joint {j}: lost_motion") if rest else 0.0,
            ))
        return StiffnessModel(self._inner.with_gear_curves(tuples), self._robot)

    @property
    def determined_compliance(self) -> npt.NDArray[np.float64]:
        """What the data determine, rad/(N·m) per spring (parameter order): the stored
        compliances without their weak directions — those whose standard error exceeds their
        magnitude or 1e-2 rad/(N·m). What :meth:`predict`, :meth:`predict_sag` and
        :meth:`compensate` use (docs/vjm.md, weak estimates)."""
        return np.array(self._inner.determined_compliance, dtype=np.float64)

    @property
    def gravity(self) -> Optional[Tuple[float, float, float]]:
        """The gravity the model was identified under, ``(gx, gy, gz)`` m/s² in the base frame
        (``Robot.identify(gravity=...)``); None for a weightless model and for files written
        before gravity was recorded. The default gravity of :meth:`predict_sag` and
        :meth:`compensate` (standard gravity when None)."""
        g = self._inner.gravity
        return None if g is None else (float(g[0]), float(g[1]), float(g[2]))

    @property
    def has_rotations(self) -> bool:
        """Whether the model predicts rotations (identified with measured rotations)."""
        return bool(self._inner.has_rotations)

    @property
    def content_sha256(self) -> str:
        """SHA-256 of the model content, as stored in the file."""
        return str(self._inner.content_sha256)

    def measurement_stddev(self) -> Array:
        """Standard deviations (6,) of a new measurement's noise ``[dx..rz]`` (m, rad) under the
        model's noise model, σ·noise_sigma; NaN when unknown or not modelled (rotations)."""
        return np.asarray(self._inner.measurement_stddev(), dtype=np.float64)

    @checked
    def predict(
        self,
        q: Any,
        wrench: Any = None,
        payload: Optional[Payload] = None,
        allow_outside_limits: bool = False,
        gravity: ModelGravity = RECORDED_GRAVITY,
    ) -> Prediction:
        """Predicted tip deflections and their standard deviations.

        ``q``: joint angles in rad, (n,) or (N, n). The load is either ``wrench`` — (6,) or
        (N, 6), ``[fx, fy, fz, mx, my, mz]`` in N and N·m at the tip point, base frame — or
        ``payload`` — a mass in kg, or ``(mass, cx, cy, cz)`` with the centre of mass in m in
        the tip frame, under gravity 9.80665 m/s² along −z of the base frame. Returns a
        :class:`Prediction` with one row per configuration.

        The inputs get the checks of :meth:`robot_stiffness.vjm.Robot.identify` (a
        :class:`~robot_stiffness.DataFileError` naming the row and column): joint angles
        within two turns (else degrees?) and inside the URDF limits —
        ``allow_outside_limits=True`` to accept those — forces up to 1e5 N and moments up to
        1e4 N·m, a payload whose weight and moment stay within those.

        ``gravity`` (m/s², base frame; default ``"recorded"``: :attr:`gravity`, the one the
        model was identified under, weightless when it records none; None: weightless): under
        gravity the deflection is the load's from the arm at rest under its own weight — what
        a measurement under gravity records and ``identify(gravity=...)`` fits — taken at the
        sagged pose with gravity's stiffness coupling into the load's torque (docs/gravity.md);
        the URDF must then give the link masses. A model with :attr:`gear_curves` adds each
        curved joint's deflection beyond its linear spring, the curve's change from the
        weight's preload to preload + load (first order, as the diagnosis fits it).
        """
        g = model_gravity(gravity, self.gravity, unrecorded=None)
        arr = f64(q, "q")
        if arr.ndim == 1:
            arr = arr.reshape(1, -1)
        w = None
        if wrench is not None:
            w = f64(wrench, "wrench")
            if w.ndim == 1:
                w = np.broadcast_to(w.reshape(1, -1), (arr.shape[0], w.shape[0])).copy()
        p = None if payload is None else _payload(payload)
        d = self._inner.predict(arr, wrench=w, payload=p, allow_outside_limits=bool(allow_outside_limits),
                                gravity=g)
        return _prediction(d)

    @checked
    def predict_sag(
        self,
        q: Any,
        gravity: ModelGravity = RECORDED_GRAVITY,
        payload: Optional[Payload] = None,
        allow_outside_limits: bool = False,
    ) -> Prediction:
        """The tip's static sag under the arm's own weight (and ``payload``), relative to the
        rigid forward kinematics, m and rad, base frame: what an absolute-accuracy correction
        removes (docs/gravity.md).

        ``q``: joint angles in rad, (n,) or (N, n); ``gravity`` in m/s², base frame (default
        ``"recorded"``: :attr:`gravity`, the one the model was identified under, or 9.80665
        along −z when it records none); ``payload`` as for :meth:`predict`. The link masses come from the
        robot's URDF inertials. ``deflection`` is the exact static equilibrium with what the
        data determine (:attr:`determined_compliance`; a model with aliased springs may store
        negative entries, which the equilibrium accepts); ``stddev``, ``identified`` and ``excitation`` are
        those of ``J C τ_g``: a pose whose weight loads a direction the identification did not
        see is flagged. ``wrench`` is zero.
        """
        arr = f64(q, "q")
        if arr.ndim == 1:
            arr = arr.reshape(1, -1)
        p = None if payload is None else _payload(payload)
        g = model_gravity(gravity, self.gravity)
        if g is None:
            raise InvalidValueError("predict_sag() needs a gravity vector: a weightless arm does not sag")
        d = self._inner.predict_sag(arr, g, payload=p,
                                    allow_outside_limits=bool(allow_outside_limits))
        return _prediction(d)

    @checked
    def compensate(
        self,
        q: Any,
        wrench: Any = None,
        payload: Optional[Payload] = None,
        match_orientation: Optional[bool] = None,
        with_kc: bool = True,
        allow_outside_limits: bool = False,
        gravity: ModelGravity = RECORDED_GRAVITY,
        load_only: bool = False,
    ) -> Compensation:
        """Corrected joint targets so that the tip, loaded, reaches where the nominal targets
        put it unloaded — :func:`robot_stiffness.vjm.compensate` with this model's springs and
        compliances (the same concept as ``robot-stiffness compensate vjm MODEL.json``).

        ``q``: nominal targets in rad, (n,) or (N, n). The load as for :meth:`predict`.
        ``match_orientation`` defaults to whether the model was identified with rotations;
        ``with_kc`` includes the complementary stiffness K_C. The inputs get the checks of
        :meth:`predict` (``allow_outside_limits``). See ``docs/use-the-model.md``.

        By default the sag under the arm's own weight is corrected too (the nominal tip is the
        rigid kinematics' pose; the loaded tip the springs' static equilibrium under ``gravity``,
        the payload's weight and the wrench), with ``gravity`` as for :meth:`predict_sag`; the
        URDF must give the link masses. ``load_only=True`` (or ``gravity=None``) corrects the
        load's deflection only, weightless, as before gravity was modelled: for a controller
        that already corrects the arm's own sag.
        """
        arr, w = _q_and_wrench(q, wrench)
        p = None
        if payload is not None:
            mass, cx, cy, cz = _payload(payload)
            p = (mass, [cx, cy, cz])
        g = None if load_only else model_gravity(gravity, self.gravity)
        out = self._inner.compensate(arr, wrench=w, payload=p, match_orientation=match_orientation,
                                     with_kc=bool(with_kc), allow_outside_limits=bool(allow_outside_limits),
                                     gravity=g)
        return _compensation(*out)

    def __repr__(self) -> str:
        return repr(self._inner)


def _model_from_json(text: str, robot: "Robot") -> StiffnessModel:
    """Rebuilds a pickled :class:`StiffnessModel` (the model file's text, checked against
    ``robot`` as :meth:`StiffnessModel.load` checks a file)."""
    return StiffnessModel(_core.StiffnessModel.from_json(text, robot._inner), robot)
