"""Virtual-joint stiffness models (VJM) of serial arms from URDF.

A :class:`Robot` is an immutable serial chain between a base and a tip link. Its virtual springs
are named ``J<joint><axis>``: joint 1-based from base to tip, axis ``z`` (torsion about the joint
axis) or ``x``/``y`` (tilts, in the joint's child frame; see ``docs/conventions.md``). Models:
``"traditional"`` (the n torsional springs), ``"extended"`` (3n springs, joint-major, ``[z, x, y]``
per joint) or any list of labels such as ``["J1z", "J2x", "J2z"]`` listed base → tip.

Units are SI: joint angles in rad, wrenches ``[fx, fy, fz, mx, my, mz]`` in N and N·m applied at
the tip point with base-frame components, displacements in m and rotations in rad with
base-frame components, compliances in rad/(N·m).

Every batched method takes arrays with one row per configuration/measurement: q (N, n),
wrench (N, 6), displacement (N, 3). C- and Fortran-ordered arrays are accepted; the work runs in
Rust with the GIL released. :meth:`Robot.identify` also accepts a pandas DataFrame with the
measurement-file columns.

Example::

    >>> import numpy as np
    >>> from robot_stiffness.vjm import Robot
    >>> robot = Robot.bundled()
    >>> q = np.array([[0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8]])
    >>> robot.jacobian(q, model="extended").shape
    (1, 6, 21)
"""

from __future__ import annotations

import contextlib
import math
import os
import warnings
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from ._equality import FieldEq
from . import _core
from ._arguments import DEFAULT_GRAVITY, checked, gravity_vector
from ._arrays import f64
from ._errors import (
    ArgumentTypeError,
    IdentificationError,
    InvalidValueError,
    ShapeError,
    StiffnessError,
    SuspiciousDataWarning,
)
from ._vjm_data import (
    Campaign,
    DataFile,
    Diagnosis,
    Measurements,
    diagnose,
    SeedStudy,
    read_measurements,
    seed_study,
    simulate,
)
from .model import StiffnessModel
from ._diagnosed_model import DiagnosedModel, diagnosed_model
from ._identify_partial import IdentificationPartial
from .results import _build
from ._use_model import (  # planning and compensation (docs/use-the-model.md)
    Compensation,
    Plan,
    PlannedCombination,
    compensate,
    compensate_with_model_file,
    design,
)
from ._tables import (
    DISPLACEMENT,
    ROTATION,
    WRENCH,
    blame_rows,
    columns,
    is_table,
    joint_columns,
    optional_columns,
)

__all__ = [
    "DEFAULT_GRAVITY",
    "Robot",
    "Identification",
    "IdentificationPartial",
    "Combination",
    "ModelSpec",
    "Measurements",
    "DataFile",
    "Campaign",
    "Diagnosis",
    "read_measurements",
    "simulate",
    "diagnose",
    "diagnosed_model",
    "DiagnosedModel",
    "seed_study",
    "SeedStudy",
    "design",
    "Plan",
    "PlannedCombination",
    "compensate",
    "compensate_with_model_file",
    "Compensation",
]

#: The one model vocabulary: ``"traditional"``, ``"extended"``, ``"J1z,J2x"``, what diagnose prints
#: (``"traditional + joint_tilt(J3x)"``), or a sequence of spring labels like ``["J1z", "J2x"]``.
ModelSpec = Union[str, Sequence[str]]

Array = npt.NDArray[np.float64]
PathLike = Union[str, "os.PathLike[str]"]


def _model(model: ModelSpec) -> Union[str, List[str]]:
    if isinstance(model, str):
        return model
    try:
        labels = list(model)
    except TypeError:
        labels = None
    if labels is not None and all(isinstance(s, str) for s in labels):
        return [str(s) for s in labels]
    raise ArgumentTypeError(
        f"model must be 'traditional', 'extended' or a list of spring labels like ['J1z', 'J2x'], "
        f"got {type(model).__name__} {repr(model)[:40]}"
    )


def _nan(values: Sequence[Optional[float]]) -> Array:
    return np.array([np.nan if v is None else float(v) for v in values], dtype=np.float64)


@dataclass(frozen=True)
class Combination:
    """An identifiable linear combination of compliances (a base parameter).

    ``value = Σ coefficient_k · c_k`` in rad/(N·m) over ``terms`` (label, coefficient); the first
    term is the independent parameter with coefficient 1.
    """

    label: str
    terms: List[Tuple[str, float]]
    value: float
    stderr: float
    ci95: Tuple[float, float]
    #: The standard error exceeds the value or any plausible compliance (1e-2 rad/(N·m)):
    #: the data do not determine it (``docs/vjm.md``, weak estimates).
    weak: bool = False


@dataclass(frozen=True)
class IdentifiedParameter:
    """One parameter of an identification: the spring at ``joint`` (1-based, base → tip; its
    URDF name ``joint_name``) about ``axis`` (``z`` torsion, ``x``/``y`` tilt) or, when
    ``kind`` is ``"translation"`` (model ``full``), along it; ``compliance`` and ``stderr`` in
    rad/(N·m) (a translation's in m/N) and the 95 % interval ``ci95``, all None when the
    parameter is not identifiable on its own."""

    joint: int
    joint_name: str
    axis: str
    compliance: Optional[float]
    stderr: Optional[float]
    ci95: Optional[Tuple[float, float]]
    identifiable: bool
    #: Identifiable alone but weak: the standard error exceeds the compliance or 1e-2 rad/(N·m).
    weak: bool = False
    #: ``"rotation"`` (torsion, tilt) or ``"translation"``.
    kind: str = "rotation"

    @property
    def label(self) -> str:
        """The spring's label: ``J3x`` (rotation), ``J3tx`` (translation)."""
        return _spring_label(self.joint, self.axis, self.kind)


@dataclass(frozen=True)
class CombinationTerm:
    """One term of a combination: parameter index ``param`` (0-based, model order), its
    ``joint`` (1-based), ``axis`` and ``kind``, and the ``coefficient`` (dimensionless between
    springs of one kind)."""

    param: int
    joint: int
    axis: str
    coefficient: float
    #: ``"rotation"`` or ``"translation"``.
    kind: str = "rotation"

    @property
    def label(self) -> str:
        """The spring's label: ``J3x`` (rotation), ``J3tx`` (translation)."""
        return _spring_label(self.joint, self.axis, self.kind)


def _spring_label(joint: int, axis: str, kind: str) -> str:
    # The core's Spring labels (vjm::Spring's Display): a translation reads `J3tx`.
    return f"J{joint}{'t' if kind == 'translation' else ''}{axis}"


@dataclass(frozen=True)
class _CoreCombination:
    label: str
    terms: List[CombinationTerm]
    value: float
    stderr: Optional[float]
    ci95: Optional[Tuple[float, float]]
    weak: bool = False


@dataclass(frozen=True)
class _CoreIdentification:
    """The core's identification result, typed (built by :func:`results._build`)."""

    model: str
    n_params: int
    rank: int
    n_equations: int
    compliance: List[Optional[float]]
    stderr: List[Optional[float]]
    ci95: List[Optional[Tuple[float, float]]]
    identifiable: List[bool]
    parameters: List[IdentifiedParameter]
    combinations: List[_CoreCombination]
    aliases: List[List[int]]
    alias_labels: List[List[str]]
    residual_rms: float
    sigma2: Optional[float]
    singular_values: List[float]
    condition_number: Optional[float]
    method: str
    warnings: List[str] = field(default_factory=list)
    gravity_iterations: int = 0


def _json_parameter(p: IdentifiedParameter) -> Dict[str, object]:
    # As the core serialises a parameter: the kind only for a translation.
    out: Dict[str, object] = {"joint": p.joint, "axis": p.axis}
    if p.kind != "rotation":
        out["kind"] = p.kind
    out.update(
        {
            "joint_name": p.joint_name,
            "compliance": p.compliance,
            "stderr": p.stderr,
            "ci95": None if p.ci95 is None else list(p.ci95),
            "identifiable": p.identifiable,
            "weak": p.weak,
        }
    )
    return out


def _json_term(t: CombinationTerm) -> Dict[str, object]:
    # As the core serialises a term: the kind only for a translation.
    out: Dict[str, object] = {"param": t.param, "joint": t.joint, "axis": t.axis}
    if t.kind != "rotation":
        out["kind"] = t.kind
    out["coefficient"] = t.coefficient
    return out


def _json_combination(c: _CoreCombination) -> Dict[str, object]:
    return {
        "label": c.label,
        "terms": [_json_term(t) for t in c.terms],
        "value": c.value,
        "stderr": c.stderr,
        "ci95": None if c.ci95 is None else list(c.ci95),
        "weak": c.weak,
    }


@dataclass(frozen=True, eq=False)
class Identification(FieldEq):
    """The result of :meth:`Robot.identify`.

    Per parameter (model order, arrays of shape (m,)): ``compliance`` in rad/(N·m), NaN where the
    parameter is not identifiable on its own; ``stderr`` (NaN likewise); ``ci95`` (m, 2) 95 %
    intervals; ``identifiable`` (bool). ``parameters`` holds the same per parameter as
    :class:`IdentifiedParameter` (joint, joint name, axis). ``rank`` is the number of
    identifiable combinations, listed in ``combinations``; ``aliases`` groups parameter labels
    that alias each other. ``method`` is the streaming reduction that produced it
    (``"normal_equations"`` or ``"qr"``); ``sigma2`` the residual variance per equation (None
    when the noise scale was given as known). ``stiffness_model`` is the
    :class:`~robot_stiffness.model.StiffnessModel` to predict with (or :meth:`save`).
    ``warnings`` holds the messages of the :class:`~robot_stiffness.SuspiciousDataWarning`
    issued by :meth:`Robot.identify` (outlier rows, implausible or negative compliances).
    ``gravity_iterations``: the refits about the sagged equilibrium under gravity (0 weightless).
    """

    model: str
    n_params: int
    rank: int
    n_equations: int
    labels: List[str]
    compliance: Array
    stderr: Array
    ci95: Array
    identifiable: npt.NDArray[np.bool_]
    combinations: List[Combination]
    aliases: List[List[str]]
    residual_rms: float
    condition_number: float
    singular_values: Array
    method: str
    parameters: List[IdentifiedParameter] = field(default_factory=list, repr=False)
    sigma2: Optional[float] = field(default=None, repr=False)
    warnings: Tuple[str, ...] = field(default=(), repr=False)
    gravity_iterations: int = field(default=0, repr=False)
    #: Per parameter: identifiable alone but weak (standard error above the value or above
    #: 1e-2 rad/(N·m)); each combination has its own ``weak``.
    weak: npt.NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool), repr=False)
    stiffness_model: Optional["StiffnessModel"] = field(default=None, repr=False, compare=False)
    _combinations_json: List[Dict[str, object]] = field(default_factory=list, repr=False, compare=False)

    @checked
    def save(self, path: PathLike, *, force: bool = False) -> None:
        """Writes the stiffness model file (``docs/model-file.md``) to ``path``, atomically; read
        it back with :meth:`robot_stiffness.model.StiffnessModel.load`. An existing ``path`` is
        replaced only with ``force`` (see :meth:`~robot_stiffness.model.StiffnessModel.save`)."""
        if self.stiffness_model is None:
            raise InvalidValueError(
                "this identification carries no stiffness model (it was not made by Robot.identify)"
            )
        self.stiffness_model.save(path, force=force)

    @classmethod
    def _from_core(cls, value: Mapping[str, object], model: Optional["StiffnessModel"] = None) -> "Identification":
        core = _build(_CoreIdentification, value)
        assert isinstance(core, _CoreIdentification)
        ci = np.array(
            [[np.nan, np.nan] if c is None else [c[0], c[1]] for c in core.ci95], dtype=np.float64
        ).reshape(-1, 2)
        combos = [
            Combination(
                label=c.label,
                terms=[(t.label, t.coefficient) for t in c.terms],
                value=c.value,
                stderr=np.nan if c.stderr is None else c.stderr,
                ci95=(np.nan, np.nan) if c.ci95 is None else c.ci95,
                weak=c.weak,
            )
            for c in core.combinations
        ]
        return cls(
            model=core.model,
            n_params=core.n_params,
            rank=core.rank,
            n_equations=core.n_equations,
            labels=[p.label for p in core.parameters],
            compliance=_nan(core.compliance),
            stderr=_nan(core.stderr),
            ci95=ci,
            identifiable=np.array(core.identifiable, dtype=bool),
            combinations=combos,
            aliases=[list(a) for a in core.alias_labels],
            residual_rms=core.residual_rms,
            condition_number=np.inf if core.condition_number is None else core.condition_number,
            singular_values=np.array(core.singular_values, dtype=np.float64),
            method=core.method,
            parameters=core.parameters,
            sigma2=core.sigma2,
            warnings=tuple(core.warnings),
            gravity_iterations=core.gravity_iterations,
            weak=np.array([p.weak for p in core.parameters], dtype=bool),
            stiffness_model=model,
            _combinations_json=[_json_combination(c) for c in core.combinations],
        )

    def to_dict(self) -> Dict[str, object]:
        """The JSON form written by ``robot-stiffness identify vjm``: ``model``, ``n_params``,
        ``rank``, ``parameters`` [{``joint`` (1-based), ``axis`` (z|x|y), ``kind`` (only for a
        translation), ``compliance`` (rad/(N·m), a translation's m/N, or None), ``stderr``,
        ``identifiable``}], ``combinations`` (with ``value``),
        plus ``aliases`` and diagnostics."""
        return {
            "model": self.model,
            "n_params": self.n_params,
            "rank": self.rank,
            "n_equations": self.n_equations,
            "parameters": [_json_parameter(p) for p in self.parameters],
            "combinations": list(self._combinations_json),
            "aliases": [list(a) for a in self.aliases],
            "residual_rms": self.residual_rms,
            "condition_number": self.condition_number if math.isfinite(self.condition_number) else None,
            "method": self.method,
            "gravity_iterations": self.gravity_iterations,
            "warnings": list(self.warnings),
        }




def _gravity_args(
    gravity: Sequence[float], payload: Optional[Tuple[float, Sequence[float]]]
) -> Tuple[Tuple[float, float, float], Optional[Tuple[float, Tuple[float, float, float]]]]:
    g = gravity_vector(gravity)
    p = None
    if payload is not None:
        mass, centre = payload
        c = tuple(float(x) for x in centre)
        if len(c) != 3:
            raise ShapeError(f"payload centre must have 3 components (cx, cy, cz) in m, got {len(c)}")
        p = (float(mass), (c[0], c[1], c[2]))
    return (g[0], g[1], g[2]), p


def _why_gravity_failed(error: IdentificationError, run: Callable[[Optional[Sequence[float]]], Tuple[Any, Any]],
                        gravity: Optional[Sequence[float]]) -> IdentificationError:
    """The refits under gravity diverge on data in wrong units (kN, mm: compliances far too
    large to hold the arm) before the screening can say so: the weightless fit's findings
    (``run(None)``, only on that failure) are added to the message."""
    if gravity is None or "under gravity did not settle" not in str(error):
        return error
    try:
        core, _ = run(None)
    except StiffnessError:
        return error
    listed = core.get("warnings")
    found = [str(w) for w in listed] if isinstance(listed, list) else []
    if not found:
        return error
    return IdentificationError(f"{error}; the weightless fit of these data warns: {' | '.join(found)}")


class Robot:
    """A serial chain from a base link to a tip link, loaded from URDF (immutable).

    Fixed joints are folded in; revolute and continuous joints are actuated. Construct it with
    :meth:`bundled`, :meth:`from_urdf` or :meth:`from_urdf_string`.
    """

    __slots__ = ("_inner",)

    def __init__(self, inner: Any) -> None:
        """Wraps a ``robot_stiffness._core.Robot``; use the class methods instead."""
        if not isinstance(inner, _core.Robot):
            raise ArgumentTypeError("use Robot.bundled(), Robot.from_urdf() or Robot.from_urdf_string()")
        self._inner = inner

    @classmethod
    @checked
    def bundled(cls, tip: Optional[str] = None) -> "Robot":
        """The bundled 7-DoF Franka Emika Panda arm, base ``panda_link0``, tip the flange
        ``panda_link8`` unless another link of the bundled URDF (e.g. ``panda_hand_tcp``) is named."""
        return cls(_core.Robot.bundled(tip))

    @classmethod
    @checked
    def from_urdf(cls, path: PathLike, base: str, tip: str) -> "Robot":
        """The chain ``base`` → ``tip`` of the URDF file at ``path``.

        Raises :class:`~robot_stiffness.MissingFileError` (a ``FileNotFoundError``) if the file
        does not exist and :class:`~robot_stiffness.RobotModelError` naming the link or joint
        when the chain cannot be built (unknown link, base not an ancestor of tip, mimic joint…).
        """
        return cls(_core.Robot.from_urdf(path, base, tip))

    @classmethod
    @checked
    def from_urdf_string(cls, xml: str, base: str, tip: str) -> "Robot":
        """The chain ``base`` → ``tip`` of a URDF document given as text."""
        return cls(_core.Robot.from_urdf_string(xml, base, tip))

    @property
    def n_joints(self) -> int:
        """Number of actuated joints n."""
        return int(self._inner.n_joints)

    @property
    def joint_names(self) -> List[str]:
        """Actuated joint names, base → tip."""
        return list(self._inner.joint_names)

    @property
    def limits(self) -> List[Tuple[float, float]]:
        """Joint position limits (lower, upper) in rad, base → tip (±inf for continuous joints)."""
        return list(self._inner.limits)

    @property
    def base_link(self) -> str:
        """Name of the base link (the frame of every base-frame quantity)."""
        return str(self._inner.base_link)

    @property
    def tip_link(self) -> str:
        """Name of the tip link; the tip point is its origin."""
        return str(self._inner.tip_link)

    @checked
    def labels(self, model: ModelSpec = "extended") -> List[str]:
        """Parameter labels of ``model`` in parameter order, e.g. ``["J1z", "J1x", "J1y", ...]``."""
        return list(self._inner.model_labels(_model(model)))

    def _q(self, q: Any) -> Tuple[Array, bool]:
        arr = f64(q, "q")
        if arr.ndim == 1:
            return arr.reshape(1, -1), True
        return arr, False

    @checked
    def forward_kinematics(self, q: Any) -> Array:
        """Tip poses: homogeneous transforms of the tip frame in the base frame (m).

        ``q``: joint angles in rad, (n,) or (N, n). Returns (4, 4) or (N, 4, 4).
        """
        arr, single = self._q(q)
        out = self._inner.forward_kinematics(arr)
        return out[0] if single else out

    @checked
    def jacobian(self, q: Any, model: ModelSpec = "extended") -> Array:
        """Virtual-joint Jacobians at the tip point, base frame, rows ``[linear; angular]``.

        ``q``: joint angles in rad, (n,) or (N, n). Column k is the tip twist (m/rad, rad/rad)
        per rad of deflection of spring k of ``model``. Returns (6, m) or (N, 6, m).
        """
        arr, single = self._q(q)
        out = self._inner.jacobian(arr, _model(model))
        return out[0] if single else out

    def gravity_torques(
        self,
        q: Any,
        model: ModelSpec = "extended",
        *,
        gravity: Sequence[float] = DEFAULT_GRAVITY,
        payload: Optional[Tuple[float, Sequence[float]]] = None,
    ) -> Array:
        """Torques of gravity on the virtual springs, N·m: (m,) or (N, m).

        ``q`` in rad, (n,) or (N, n); ``gravity`` in m/s², base frame (default 9.80665 along
        −z); ``payload`` = ``(mass_kg, (cx, cy, cz))`` with the centre in the tip frame, m.
        Positive in each spring's rotation sense (τ_g = −∂U_g/∂θ, docs/gravity.md). The bodies
        come from the URDF's ``<inertial>`` elements; a link with a shape and no inertial is an
        error naming it.
        """
        arr, single = self._q(q)
        out = _core.vjm_gravity_torques(self._inner, arr, _model(model), *_gravity_args(gravity, payload))
        return out[0] if single else out

    def gravity_stiffness(
        self,
        q: Any,
        model: ModelSpec = "extended",
        *,
        gravity: Sequence[float] = DEFAULT_GRAVITY,
        payload: Optional[Tuple[float, Sequence[float]]] = None,
    ) -> Array:
        """The stiffness of gravity K_G = ∂τ_g/∂θ on the virtual springs, N·m/rad, symmetric:
        (m, m) or (N, m, m). The tangent stiffness under gravity and a tip wrench W is
        K_θ − K_G − K_C(W) (docs/gravity.md). Arguments as :meth:`gravity_torques`."""
        arr, single = self._q(q)
        out = _core.vjm_gravity_stiffness(self._inner, arr, _model(model), *_gravity_args(gravity, payload))
        return out[0] if single else out

    def gravity_sag(
        self,
        compliance: Any,
        q: Any,
        model: ModelSpec = "extended",
        *,
        gravity: Sequence[float] = DEFAULT_GRAVITY,
        payload: Optional[Tuple[float, Sequence[float]]] = None,
    ) -> Array:
        """The tip's static sag under the arm's own weight (and ``payload``) relative to the
        rigid forward kinematics: ``[dx, dy, dz, rx, ry, rz]`` (m, rad; base frame), (6,) or
        (N, 6). ``compliance``: (m,) rad/(N·m) for the springs of ``model`` (0 = rigid). Solved
        on the deflected chain (no linearisation; docs/gravity.md)."""
        arr, single = self._q(q)
        out = _core.vjm_gravity_sag(
            self._inner, f64(compliance, "compliance"), arr, _model(model), *_gravity_args(gravity, payload)
        )
        return out[0] if single else out

    def deflection_under_gravity(
        self,
        compliance: Any,
        q: Any,
        wrench: Any,
        model: ModelSpec = "extended",
        *,
        gravity: Sequence[float] = DEFAULT_GRAVITY,
        payload: Optional[Tuple[float, Sequence[float]]] = None,
    ) -> Array:
        """What a measurement under gravity records: the tip under ``wrench`` (N, N·m at the
        tip point, base frame) minus the tip unloaded, both at the springs' static equilibrium
        under the arm's weight (and ``payload``). ``[dx, dy, dz, rx, ry, rz]`` (m, rad), (6,) or
        (N, 6); one wrench per configuration."""
        arr, single = self._q(q)
        w = f64(wrench, "wrench")
        if w.ndim == 1:
            w = w.reshape(1, -1)
        out = _core.vjm_deflection_under_gravity(
            self._inner, f64(compliance, "compliance"), arr, w, _model(model), *_gravity_args(gravity, payload)
        )
        return out[0] if single else out

    @checked
    def identify(
        self,
        q: Any,
        wrench: Any = None,
        displacement: Any = None,
        model: ModelSpec = "traditional",
        *,
        rotation: Any = None,
        noise_sigma: Any = None,
        noise_scale_known: bool = False,
        nonnegative: bool = False,
        dense: bool = False,
        method: str = "auto",
        data_file: Union[PathLike, DataFile, None] = None,
        robust_covariance: bool = False,
        allow_outside_limits: bool = False,
        gravity: Optional[Sequence[float]] = DEFAULT_GRAVITY,
    ) -> Identification:
        """Rank-revealing weighted least-squares identification of the spring compliances.

        Either arrays — ``q`` (N, n) joint angles in rad, ``wrench`` (N, 6) in N and N·m at the
        tip point (base frame), ``displacement`` (N, 3) measured tip displacement in m (base
        frame), optional ``rotation`` (N, 3) measured tip rotation vector in rad (base frame) —
        or a single table (pandas DataFrame, dict of columns) with the measurement-file columns
        ``q1..qn, fx..mz, dx,dy,dz`` (and ``rx,ry,rz`` when present) passed as ``q``.

        ``noise_sigma``: per-axis noise standard deviations ``[dx, dy, dz, rx, ry, rz]`` (m, rad)
        used as weights; only their ratios matter unless ``noise_scale_known``. ``nonnegative``
        constrains compliances to be ≥ 0. ``dense`` uses the dense reference solver instead of
        the streaming one (same answer to ~1e-10). ``method`` picks the streaming reduction:
        ``"auto"`` (normal equations, re-read through QR when the column-scaled design's condition
        number exceeds 1e4), ``"normal_equations"`` or ``"qr"``; ``Identification.method`` says
        which one produced the result. ``data_file``: the measurement file the arrays were read
        from; its path and SHA-256 are recorded in the saved model (``Identification.save``):
        a path is hashed now, a :class:`DataFile` (``Measurements.source`` of a file read with
        :func:`read_measurements`) gives the hash its reader took.
        ``robust_covariance``: give the stiffness model the cluster-robust covariance (valid for
        force-sensor noise, which is correlated within a measurement; one more pass over the data,
        about 10 µs per measurement) instead of the identification's own; the CLI's ``--save``
        uses it. See ``docs/model-file.md``. The data get the checks of a measurement file
        (implausible units or magnitudes, no load, no displacement, joint angles outside the
        URDF limits — ``allow_outside_limits=True`` to accept those).

        ``gravity`` (m/s², base frame; default :data:`DEFAULT_GRAVITY`, 9.80665 along −z): the
        measurements were taken under the arm's weight (bodies from the URDF's inertials, an
        error naming a link without one), so each displacement (loaded − unloaded) is fitted
        about the sagged equilibrium; the model records it (``StiffnessModel.gravity``).
        ``None``: a weightless arm, the linear fit (no inertials needed).

        Parameters that cannot be identified from these data get NaN (never a number), and the
        identifiable combinations are reported. Raises :class:`~robot_stiffness.ShapeError`
        naming the array and dimension, :class:`~robot_stiffness.InvalidValueError` for NaN,
        :class:`~robot_stiffness.IdentificationError` for too few measurements. Data that pass
        those checks but look wrong — a row whose load or displacement is over 100 times the
        median row's, a best-determined compliance above 1e-2 rad/(N·m) (kN? mm?), a compliance
        more than 5 standard errors below 0 — give a :class:`~robot_stiffness.SuspiciousDataWarning` per
        finding (also in ``Identification.warnings``; see ``docs/vjm.md``).
        """
        from_table, q, wrench, displacement, rotation = self._measurement_arrays(
            "identify", q, wrench, displacement, rotation)
        q_arr = f64(q, "q")
        # A table's cells are named by column and row; arrays keep the core's array/row/column.
        def run(g: Optional[Sequence[float]]) -> Tuple[Dict[str, "_core._CoreValue"], Any]:
            return self._identify(q_arr, wrench, displacement, model, rotation, noise_sigma, noise_scale_known,
                                  nonnegative, dense, method, data_file, robust_covariance, allow_outside_limits, g)

        with blame_rows() if from_table else contextlib.nullcontext():
            try:
                core, core_model = run(gravity)
            except IdentificationError as e:
                raise _why_gravity_failed(e, run, gravity) from None
        result = Identification._from_core(core, StiffnessModel(core_model, self))
        for message in result.warnings:
            # stacklevel: this method, its @checked wrapper, the caller.
            warnings.warn(message, SuspiciousDataWarning, stacklevel=3)
        return result

    def _measurement_arrays(self, what: str, q: Any, wrench: Any, displacement: Any,
                            rotation: Any) -> Tuple[bool, Any, Any, Any, Any]:
        """The arrays of a measurement table passed as ``q``, or the arrays as given; whether
        they came from a table comes first."""
        from_table = is_table(q) and wrench is None and displacement is None
        if from_table:
            table = q
            q = columns(table, joint_columns(self.n_joints), "joint angles")
            wrench = columns(table, WRENCH, "the wrench")
            displacement = columns(table, DISPLACEMENT, "the displacement")
            if rotation is None:
                rotation = optional_columns(table, ROTATION, "rotation")
        elif wrench is None or displacement is None:
            raise ShapeError(
                f"{what} needs q, wrench and displacement arrays, or one table with the "
                "measurement columns as its first argument"
            )
        return from_table, q, wrench, displacement, rotation

    @checked
    def identify_partial(
        self,
        q: Any,
        wrench: Any = None,
        displacement: Any = None,
        model: ModelSpec = "traditional",
        *,
        rotation: Any = None,
        noise_sigma: Any = None,
        noise_scale_known: bool = False,
        nonnegative: bool = False,
        allow_outside_limits: bool = False,
        gravity: Optional[Sequence[float]] = None,
    ) -> IdentificationPartial:
        """The identification statistics of these measurements, to be merged with those of the
        campaign's other parts (:meth:`IdentificationPartial.merge`) and solved once
        (:meth:`IdentificationPartial.finish`): for campaigns split across processes or
        machines (``docs/fleet.md``). Same inputs, units and checks as :meth:`identify`; the
        statistic is the streaming QR factor, so the finished result equals
        ``identify(..., method="qr", gravity=None)`` on all the rows to rounding.

        Weightless only: the statistic is that of the linear problem, and under gravity the
        design depends on the compliances (:meth:`identify` refits about the sagged
        equilibrium). So ``gravity`` must be ``None`` (its default here, unlike every other
        call): any other value is an :class:`~robot_stiffness.InvalidValueError`; identify
        measurements taken under gravity with :meth:`identify` on all the rows.
        """
        if gravity is not None:
            raise InvalidValueError(
                "identify_partial() is weightless only (the partial statistic is the linear problem; under "
                "gravity the design depends on the compliances): pass gravity=None, or identify all the rows "
                f"with Robot.identify(gravity=...); got gravity={gravity!r}"
            )
        from_table, q, wrench, displacement, rotation = self._measurement_arrays(
            "identify_partial", q, wrench, displacement, rotation)
        with blame_rows() if from_table else contextlib.nullcontext():
            inner = _core.IdentificationPartial.accumulate(
                self._inner,
                f64(q, "q"),
                f64(wrench, "wrench"),
                f64(displacement, "displacement"),
                _model(model),
                rotation=None if rotation is None else f64(rotation, "rotation"),
                noise_sigma=None if noise_sigma is None else f64(noise_sigma, "noise_sigma"),
                noise_scale_known=bool(noise_scale_known),
                nonnegative=bool(nonnegative),
                allow_outside_limits=bool(allow_outside_limits),
            )
        return IdentificationPartial(inner, self)

    def __reduce__(self) -> Tuple[Any, ...]:
        # The core robot pickles its URDF text (and the path it was read from, recorded but
        # never opened), base and tip: a worker rebuilds it without the file.
        return (Robot, (self._inner,))

    def _identify(self, q_arr: Array, wrench: Any, displacement: Any, model: ModelSpec, rotation: Any,
                  noise_sigma: Any, noise_scale_known: bool, nonnegative: bool, dense: bool, method: str,
                  data_file: Any, robust_covariance: bool, allow_outside_limits: bool = False,
                  gravity: Optional[Sequence[float]] = DEFAULT_GRAVITY) -> Tuple[Dict[str, "_core._CoreValue"], Any]:
        # One call identifies and builds the stiffness model from the same arrays.
        core, core_model = _core.vjm_identify_model(
            self._inner,
            q_arr,
            f64(wrench, "wrench"),
            f64(displacement, "displacement"),
            _model(model),
            rotation=None if rotation is None else f64(rotation, "rotation"),
            noise_sigma=None if noise_sigma is None else f64(noise_sigma, "noise_sigma"),
            noise_scale_known=bool(noise_scale_known),
            nonnegative=bool(nonnegative),
            dense=bool(dense),
            method=str(method),
            data_file=None if data_file is None else (
                data_file.path if isinstance(data_file, DataFile) else os.fspath(data_file)),
            robust_covariance=bool(robust_covariance),
            allow_outside_limits=bool(allow_outside_limits),
            gravity=None if gravity is None else gravity_vector(gravity),
            data_sha256=data_file.sha256 if isinstance(data_file, DataFile) else None,
        )
        return core, core_model

    @checked
    def predict_deflection(
        self,
        compliance: Any,
        q: Any,
        wrench: Any,
        model: ModelSpec = "traditional",
        with_kc: bool = False,
        *,
        allow_outside_limits: bool = False,
    ) -> Array:
        """Predicted tip deflection ``[dx, dy, dz, rx, ry, rz]`` (m, rad; base frame).

        ``compliance``: (m,) rad/(N·m) for the springs of ``model`` (NaN not allowed: use 0 for
        an unidentified spring only if that is what you mean). ``q``: (n,) or (N, n) rad;
        ``wrench``: (6,) or (N, 6) N and N·m at the tip point, base frame. ``with_kc`` includes
        the complementary stiffness K_C (geometric non-linearity under load). The poses and
        wrenches get identify's plausibility checks (joint limits unless
        ``allow_outside_limits``; angles and loads of plausible magnitude).
        Returns (6,) or (N, 6).
        """
        arr, single = self._q(q)
        w = f64(wrench, "wrench")
        if w.ndim == 1:
            w = w.reshape(1, -1)
        out = self._inner.predict_deflection(
            f64(compliance, "compliance"), arr, w, _model(model), bool(with_kc), bool(allow_outside_limits)
        )
        return out[0] if single else out

    def __repr__(self) -> str:
        return f"Robot(base={self.base_link!r}, tip={self.tip_link!r}, n_joints={self.n_joints})"
