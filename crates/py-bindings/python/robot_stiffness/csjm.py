"""Cable-driven spherical joint modules (CSJM): identify the rotational stiffness K.

Frames (``docs/conventions.md``): B is the base, A the moving platform, both with origin at the
joint centre O. ``R = ᴮ_A R`` maps A-components to B-components. τ is the external moment on the
platform about O with components in A, in N·m. Displacements are body-frame:
``R = R₀ · exp(hat(Δζ))``. ``K = ∂τ/∂ζ`` (covariant), in N·m/rad, components in A at R₀.

The fit is the seed's K_D ≈ Ψ Ω⁺ (eq. 49) solved rank-revealingly, then ``K = K_D + K_L`` with
the connection term ``K_L = −½ hat(τ₀)`` (the seed prints −hat(τ₀); see ``docs/``).

Example::

    >>> import numpy as np
    >>> from robot_stiffness import csjm, so3
    >>> K = np.array([[30.0, 1.0, 0.5], [1.0, 28.0, -1.0], [0.5, -1.0, 7.0]])
    >>> steps = 0.01 * np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, 0.5, 0.2]])
    >>> R = np.concatenate([np.eye(3)[None], so3.exp(steps)])
    >>> tau = np.concatenate([np.zeros((1, 3)), steps @ K.T])
    >>> fit = csjm.identify(R, tau, ref=0)
    >>> bool(np.allclose(fit.K, K, rtol=1e-9))
    True
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from typing import Any, Dict, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from ._equality import FieldEq
from . import _core
from ._arguments import check_path, checked
from ._arrays import f64
from ._columnar import is_columnar_path, read_columns
from ._errors import ArgumentTypeError, DataFileError, InvalidValueError, ShapeError, reworded
from ._tables import MOMENT, ROTATION_MATRIX, columns, is_table
from ._vjm_data import ProgressCallback
from .results import Diagnosis

__all__ = [
    "StiffnessFit",
    "Campaign",
    "identify",
    "identify_csv",
    "read_measurements",
    "simulate",
    "diagnose",
]

Array = npt.NDArray[np.float64]
#: Rust names in core messages → the Python spelling (the CLI maps these on to its flags).
PYTHON_NAMES = {"RotationPolicy::Project": "project=True"}
PathLike = Union[str, "os.PathLike[str]"]
#: The core's DEFAULT_ORTHOGONALITY_TOL on ‖RᵀR − I‖_F, applied to Parquet/Arrow files as to CSV.
_ORTHOGONALITY_TOL = 5e-3


@dataclass(frozen=True, eq=False)
class StiffnessFit(FieldEq):
    """The identified stiffness at the reference pose R₀ (all in frame A at R₀).

    ``K`` (3, 3) N·m/rad, ``K_D`` the slope ∂τ/∂Δζ, ``K_L`` the connection term,
    ``K_stderr`` the standard error of every entry of K (NaN without residual degrees of
    freedom), ``tau0`` (3,) the pre-load in N·m used in K_L, ``n`` the number of load increments
    used, ``order`` 1 or 2. ``det_convergence`` is (k, 2): number of increments, det(K) in
    (N·m/rad)³ (the seed's Fig. 5). Diagnostics: ``regressor_condition``, ``dof`` (residual
    degrees of freedom), ``offset`` (3,) N·m the fitted moment offset, ``omega_singular_values``
    (3,); ``curvature`` (3, 3, 3) N·m/rad²: the Hessians H_i of τ_i(Δζ), τ_i ≈ … + ½ Δζᵀ H_i Δζ
    (None for ``order`` 1).
    """

    K: Array
    K_D: Array
    K_L: Array
    K_stderr: Array
    tau0: Array
    n: int
    order: int
    residual_rms: Array
    omega_condition: float
    asymmetry: float
    det_convergence: Array
    regressor_condition: float = field(default=float("nan"), repr=False)
    dof: int = field(default=0, repr=False)
    offset: Optional[Array] = field(default=None, repr=False, compare=False)
    omega_singular_values: Optional[Array] = field(default=None, repr=False, compare=False)
    curvature: Optional[Array] = field(default=None, repr=False, compare=False)

    @classmethod
    def _from_core(cls, d: "_core.CsjmEstimate") -> "StiffnessFit":
        conv = np.column_stack([d.det_convergence_n, d.det_convergence_det]).reshape(-1, 2)
        return cls(
            K=d.K,
            K_D=d.K_D,
            K_L=d.K_L,
            K_stderr=d.K_stderr,
            tau0=d.tau0,
            n=int(d.n),
            order=int(d.order),
            residual_rms=d.residual_rms,
            omega_condition=float(d.omega_condition),
            asymmetry=float(d.asymmetry),
            det_convergence=conv,
            regressor_condition=float(d.regressor_condition),
            dof=int(d.dof),
            offset=d.offset,
            omega_singular_values=d.omega_singular_values,
            curvature=d.curvature,
        )

    def to_dict(self) -> Dict[str, Any]:
        """The JSON form written by ``robot-stiffness identify csjm``: ``K``, ``K_D`` and
        ``K_stderr`` as 3×3 nested lists (row-major, N·m/rad), ``tau0``, ``n``, ``order``, plus
        ``K_L``, diagnostics and the det(K) convergence series."""

        def clean(x: Any) -> Any:
            if isinstance(x, np.ndarray):
                return [clean(v) for v in x.tolist()] if x.ndim else clean(x.item())
            if isinstance(x, list):
                return [clean(v) for v in x]
            if isinstance(x, float) and not np.isfinite(x):
                return None
            return x

        return {
            "K": clean(self.K),
            "K_D": clean(self.K_D),
            "K_stderr": clean(self.K_stderr),
            "tau0": clean(self.tau0),
            "n": self.n,
            "order": self.order,
            "K_L": clean(self.K_L),
            "residual_rms": clean(self.residual_rms),
            "omega_condition": clean(self.omega_condition),
            "regressor_condition": clean(self.regressor_condition),
            "asymmetry": clean(self.asymmetry),
            "det_convergence": [
                {"n": int(n), "det": clean(float(d))} for n, d in self.det_convergence
            ],
        }


def _table_arrays(table: Any) -> Tuple[Array, Array, int]:
    """(R (N, 3, 3), tau (N, 3), ref) from a table with the measurement-file columns."""
    r9 = columns(table, ROTATION_MATRIX, "the orientation")
    tau = columns(table, MOMENT, "the moment")
    flags = columns(table, ["ref"], "the reference flag")[:, 0]
    hits = np.flatnonzero(flags == 1)
    if len(hits) != 1:
        raise DataFileError(f"exactly one row must have ref = 1, found {len(hits)} (rows {hits.tolist()})")
    return r9.reshape(-1, 3, 3), tau, int(hits[0])


def _columnar_table(path: PathLike) -> Any:
    """The columns of a Parquet / Arrow IPC measurement file (read by suffix), for the table
    path of :func:`identify` and :func:`diagnose`, so that they get a DataFrame's checks."""
    return read_columns(path, ROTATION_MATRIX + MOMENT + ["ref"])


@checked
def identify(
    R: Any,
    tau: Any = None,
    ref: Optional[int] = None,
    *,
    order: int = 1,
    project: bool = False,
    tol: Optional[float] = None,
    convergence: bool = True,
) -> StiffnessFit:
    """Identify K at the reference pose from N ≥ 4 static equilibria.

    ``R``: (N, 3, 3) platform orientations ᴮ_A R; ``tau``: (N, 3) external moments on the
    platform about O, components in A, N·m; ``ref``: index of the reference row (R₀, τ₀).
    Alternatively pass one table (pandas DataFrame) with the measurement-file columns
    ``r11..r33, tx, ty, tz, ref`` as ``R``.

    ``order=2`` also fits the curvature of τ(Δζ) so that large load increments do not bias K.
    Matrices farther than ``tol`` (default 5e-3) from SO(3) raise
    :class:`~robot_stiffness.InvalidValueError` naming the row, unless ``project=True``.
    An ill-conditioned problem raises :class:`~robot_stiffness.IdentificationError`.
    """
    if is_table(R) and tau is None:
        R, tau, ref = _table_arrays(R)
    elif tau is None or ref is None:
        raise ShapeError("identify needs R (N, 3, 3), tau (N, 3) and ref, or one table")
    with reworded(PYTHON_NAMES):
        d = _core.csjm_identify(
            f64(R, "R"),
            f64(tau, "tau"),
            int(ref),
            order=int(order),
            project=bool(project),
            tol=None if tol is None else float(tol),
            convergence=bool(convergence),
        )
    return StiffnessFit._from_core(d)


@checked
def read_measurements(path: PathLike, *, project: bool = False) -> Tuple[Array, Array, int]:
    """Read a CSJM measurement file: returns ``(R (N, 3, 3), tau (N, 3) in N·m, ref index)``.

    Columns ``r11..r33`` (ᴮ_A R, row-major), ``tx,ty,tz`` (moment in A, N·m), ``ref`` (1 on
    exactly one row). Errors name the row and column; a missing file raises
    :class:`~robot_stiffness.MissingFileError` (a ``FileNotFoundError``). A Parquet or Arrow IPC
    file (by suffix: ``.parquet``, ``.pq``, ``.arrow``, ``.feather``, ``.ipc``; the ``[parquet]``
    extra) gets the same orthogonality check and projection; its rows count from 0.
    """
    if is_columnar_path(check_path(path, "path")):
        R, tau, ref = _table_arrays(_columnar_table(path))
        from .so3 import orthogonality_error, project_to_rotation

        if not project:
            err = np.asarray(orthogonality_error(R)).reshape(-1)
            bad = np.flatnonzero(~(err <= _ORTHOGONALITY_TOL))
            if bad.size:
                row = int(bad[0])
                raise InvalidValueError(
                    f"{os.fspath(path)}: row {row} (counting from 0): r11..r33 is not a rotation "
                    f"(orthogonality error {err[row]:.3g} > {_ORTHOGONALITY_TOL}); pass project=True to project it"
                )
        # Accepted matrices are replaced by their nearest rotation, as the CSV reader does.
        return project_to_rotation(R), tau, ref
    with reworded(PYTHON_NAMES):
        R, tau, ref = _core.csjm_read_csv(path, project=project)
    return R, tau, int(ref)


@checked
def identify_csv(path: PathLike, *, order: int = 1, project: bool = False) -> StiffnessFit:
    """Read a CSJM measurement file and identify K (see :func:`identify`). A Parquet or Arrow
    IPC file (by suffix) takes the table path of :func:`identify`."""
    if is_columnar_path(check_path(path, "path")):
        return identify(_columnar_table(path), order=order, project=project)
    with reworded(PYTHON_NAMES):
        return StiffnessFit._from_core(_core.csjm_identify_csv(path, order=order, project=project))


@dataclass(frozen=True, eq=False)
class Campaign(FieldEq):
    """A simulated CSJM campaign: the measurement file text ``csv`` (columns ``r11..r33,
    tx,ty,tz,ref``) and the truth at the reference pose: ``true_K`` (covariant, symmetric) and
    ``true_K_D`` (N·m/rad, frame A at R₀), ``true_R0`` (ᴮ_A R₀)."""

    csv: str
    true_K: Array
    true_K_D: Array
    true_R0: Array


@checked
def simulate(
    effects: Sequence[Dict[str, Any]] = (),
    *,
    seed: int = 0,
    increments: Optional[int] = None,
    max_increment: Optional[float] = None,
) -> Campaign:
    """Simulate the seed's CSJM campaign on the prototype (pre-loaded reference pose, 85 load
    increments of up to 1 N·m by default, laser-tracker pose noise and F/T moment noise) with
    hidden ``effects``:

    * ``{"effect": "platform_gravity"}`` — the platform weight acts but is left out of the
      recorded moments;
    * ``{"effect": "cable_hysteresis", "friction": 2.0}`` — Coulomb friction in every cable, N;
    * ``{"effect": "cable_nonlinearity", "k2": 2e6}`` — cable law t = k e + k₂ e², N/m².

    Same seed, same data.
    """
    d = _core.csjm_simulate(
        [dict(e) for e in effects],
        seed=int(seed),
        increments=None if increments is None else int(increments),
        max_increment=None if max_increment is None else float(max_increment),
    )
    return Campaign(csv=d.csv, true_K=d.true_K, true_K_D=d.true_K_D, true_R0=d.true_R0)


def _split_seed(split_seed: Optional[int], holdout_seed: Optional[int]) -> Optional[int]:
    """``split_seed``, or the deprecated ``holdout_seed`` (with a warning); not both."""
    if holdout_seed is None:
        return split_seed
    if split_seed is not None:
        raise ArgumentTypeError("give split_seed alone: holdout_seed is its former name")
    warnings.warn("csjm.diagnose(holdout_seed=…) is deprecated: use split_seed", DeprecationWarning, stacklevel=4)
    return holdout_seed


@checked
def diagnose(
    data: Any,
    tau: Any = None,
    ref: Optional[int] = None,
    *,
    fdr: Optional[float] = None,
    test_fraction: Optional[float] = None,
    split_seed: Optional[int] = None,
    project: bool = False,
    progress: Optional[ProgressCallback] = None,
    holdout_seed: Optional[int] = None,
) -> Diagnosis:
    """Diagnose a CSJM campaign: fit the first-order baseline Δτ = c + K_D Δζ on training rows,
    show the structure of its residuals, name effects (``platform_gravity``,
    ``cable_hysteresis``, ``cable_nonlinearity``, ``connection_term``) by F tests with
    Benjamini–Hochberg at ``fdr`` (default 0.01, as for the arm) confirmed on held-out rows,
    refit and measure the gain. The selection runs on the same engine as :func:`vjm.diagnose`.
    ``progress(stage, done, total)`` is called as the run goes; an exception it raises stops
    the run and propagates (so does Ctrl-C).

    ``data``: a measurement-file path, a table (DataFrame) with the file's columns, or arrays
    ``R`` (N, 3, 3), ``tau`` (N, 3) N·m in frame A and ``ref`` as for :func:`identify`. ``test_mean_rel_error`` compares predicted and measured
    body-frame displacements Δζ (rad). ``split_seed``: seed of the train/test split (default 0,
    as for :func:`vjm.diagnose`); ``holdout_seed`` is its former name, deprecated.
    """
    if progress is not None and not callable(progress):
        raise ArgumentTypeError(f"progress must be callable as progress(stage, done, total), got {type(progress).__name__}")
    split_seed = _split_seed(split_seed, holdout_seed)
    if tau is None and ref is None and isinstance(data, (str, os.PathLike)) and is_columnar_path(check_path(data, "data")):
        data = _columnar_table(data)
    if tau is None and ref is None and is_table(data):
        data, tau, ref = _table_arrays(data)
    if tau is None and ref is None and isinstance(data, (str, os.PathLike)):
        with reworded(PYTHON_NAMES):
            summary, rows = _core.csjm_diagnose_csv(
                check_path(data, "data"), fdr=fdr, test_fraction=test_fraction, split_seed=split_seed,
                project=bool(project), progress=progress,
            )
    elif tau is not None and ref is not None:
        with reworded(PYTHON_NAMES):
            summary, rows = _core.csjm_diagnose(
                f64(data, "R"), f64(tau, "tau"), int(ref), fdr=fdr, test_fraction=test_fraction,
                split_seed=split_seed, project=bool(project), progress=progress,
            )
    else:
        raise ShapeError("diagnose needs a measurement-file path, or R (N, 3, 3), tau (N, 3) and ref")
    return Diagnosis._from_core("csjm", summary, rows)
