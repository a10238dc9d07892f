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
import os
import warnings
from typing import TYPE_CHECKING, Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import _core
from ._arguments import DEFAULT_GRAVITY, ModelSpec, checked, gravity_vector, model_spec
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
    Measurements,
    diagnose,
    PaperStudy,
    SeedStudy,
    read_measurements,
    paper_study,
    seed_study,
    simulate,
)
from .model import StiffnessModel
from ._diagnosed_model import DiagnosedModel, diagnosed_model
from ._identification import Combination, CombinationTerm, IdentifiedParameter, Identification
from ._identify_partial import IdentificationPartial
from ._use_model import (  # planning and compensation (docs/use-the-model.md)
    Compensation,
    Plan,
    PlannedCombination,
    compensate,
    compensate_with_model_file,
    design,
)
from ._robot_handle import RobotHandle
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

if TYPE_CHECKING:
    from .results import Diagnosis


def __getattr__(name: str) -> Any:
    # `vjm.Diagnosis` is loaded when first used: the diagnosis classes are a quarter of the
    # console script's Python start-up, and most commands do not diagnose.
    if name == "Diagnosis":
        from .results import Diagnosis

        return Diagnosis
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
    "paper_study",
    "PaperStudy",
    "seed_study",
    "SeedStudy",
    "design",
    "Plan",
    "PlannedCombination",
    "compensate",
    "compensate_with_model_file",
    "Compensation",
]

# The classes of the result live in `_identification` (below the modules that build one); their
# public name, in reprs, docs and pickles, stays `robot_stiffness.vjm.<name>`.
for _public in (Combination, CombinationTerm, IdentifiedParameter, Identification):
    _public.__module__ = __name__

Array = npt.NDArray[np.float64]
PathLike = Union[str, "os.PathLike[str]"]


def _gravity_args(
    gravity: Sequence[float], payload: Optional[Tuple[float, Sequence[float]]]
) -> Tuple[Tuple[float, float, float], Optional[Tuple[float, Tuple[float, float, float]]]]:
    g = gravity_vector(gravity)
    p = None
    if payload is not None:
        if not isinstance(payload, (tuple, list)) or len(payload) != 2:
            raise ShapeError(f"payload must be (mass_kg, (cx, cy, cz)) with the centre in the tip frame, m; "
                             f"got {payload!r}")
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


class Robot(RobotHandle):
    """A serial chain from a base link to a tip link, loaded from URDF (immutable).

    Fixed joints are folded in; revolute and continuous joints are actuated. Construct it with
    :meth:`bundled`, :meth:`from_urdf` or :meth:`from_urdf_string`.
    """

    __slots__ = ()

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
        return list(self._inner.model_labels(model_spec(model)))

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
        out = self._inner.jacobian(arr, model_spec(model))
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
        out = _core.vjm_gravity_torques(self._inner, arr, model_spec(model), *_gravity_args(gravity, payload))
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
        out = _core.vjm_gravity_stiffness(self._inner, arr, model_spec(model), *_gravity_args(gravity, payload))
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
            self._inner, f64(compliance, "compliance"), arr, model_spec(model), *_gravity_args(gravity, payload)
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
            self._inner, f64(compliance, "compliance"), arr, w, model_spec(model), *_gravity_args(gravity, payload)
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
                model_spec(model),
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
            model_spec(model),
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
            f64(compliance, "compliance"), arr, w, model_spec(model), bool(with_kc), bool(allow_outside_limits)
        )
        return out[0] if single else out

    def __repr__(self) -> str:
        return f"Robot(base={self.base_link!r}, tip={self.tip_link!r}, n_joints={self.n_joints})"
