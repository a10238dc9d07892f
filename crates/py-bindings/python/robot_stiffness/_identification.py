"""The result of a VJM identification (:class:`Identification`) and its parts, typed.

:mod:`robot_stiffness.vjm` re-exports every public name; they live here, below it, so that the
modules vjm imports (``_identify_partial`` builds an :class:`Identification`) need not import
vjm back.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from ._arguments import checked
from ._equality import FieldEq
from ._errors import InvalidValueError
from ._core_values import build

if TYPE_CHECKING:  # pragma: no cover
    from .model import StiffnessModel

__all__ = ["Combination", "CombinationTerm", "IdentifiedParameter", "Identification"]

Array = npt.NDArray[np.float64]
PathLike = Union[str, "os.PathLike[str]"]


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
    """The core's identification result, typed (built by ``_core_values.build``)."""

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
        core = build(_CoreIdentification, value)
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
