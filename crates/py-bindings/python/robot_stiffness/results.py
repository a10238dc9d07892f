"""Typed diagnosis results, the same classes for the VJM and the CSJM.

:func:`robot_stiffness.vjm.diagnose` and :func:`robot_stiffness.csjm.diagnose` return a
:class:`Diagnosis`: frozen dataclasses all the way down (:class:`ModelSummary`,
:class:`Finding` with its :class:`Evidence` and :class:`Alias` list, :class:`CandidateScore`,
:class:`FTest`, …) and the per-row data as numpy columns (:class:`DisplacementRows` for the
VJM, :class:`MomentRows` for the CSJM). Fields that only one model has are marked in their
docstring and are ``None`` for the other. ``Diagnosis.to_dict()`` / ``to_json()`` give the JSON
of ``robot-stiffness diagnose … --json`` (the keys of docs/diagnose.md and
docs/csjm-diagnose.md); the rows only with ``rows=True``. Results pickle.

How a result is built: the core hands over its result struct as plain Python values (dicts,
lists, numbers) and the rows as numpy columns; ``_core_values.build`` fills each dataclass from the
values by the dataclass's own type hints. So a field the core gains is one line here — its
name and type in the dataclass below (``tests/test_results_typed.py`` lists every key of the
core that no field takes).
"""

from __future__ import annotations

import dataclasses
import json
import math
import operator
import typing
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Dict, Iterator, List, Mapping, Optional, Union

import numpy as np
import numpy.typing as npt

from ._core_values import build as _build
from ._core_values import field_names as _field_names
from ._core_values import fits as _fits
from ._core_values import float_or_nan as _float
from ._core_values import hints as _hints
from ._core_values import json_key as _key
from ._core_values import Json, Record as _Result
from ._core_values import register_builder

__all__ = [
    "Diagnosis",
    "Finding",
    "Evidence",
    "ConnectionTest",
    "Alias",
    "ModelSummary",
    "Parameter",
    "CandidateScore",
    "FTest",
    "ChiSquareTest",
    "BlockTest",
    "Verdict",
    "Anova",
    "Correlation",
    "PoseAnova",
    "TorqueCorrelation",
    "DirectionCorrelation",
    "LoadingUnloading",
    "ResidualStructure",
    "ResidualReport",
    "PoseError",
    "PoseErrors",
    "DisplacementRows",
    "MomentRows",
]

VJM = "vjm"
CSJM = "csjm"


def _only(model: str, default: object = None, key: Optional[str] = None, former: Optional[str] = None) -> typing.Any:
    """A field only one model has: ``None`` (or ``default``) for the other, and left out of its
    JSON. ``former``: the key earlier versions wrote it under (read as well)."""
    meta = {"model": model, **({"key": key} if key else {}), **({"former": former} if former else {})}
    return field(default=default, metadata=meta)


# ----------------------------------------------------------------------------- statistics


@dataclass(frozen=True, eq=False)
class FTest(_Result):
    """A nested-model F test: statistic ``f`` with (``df_num``, ``df_den``) degrees of freedom,
    upper-tail ``p_value``."""

    f: float
    df_num: float
    df_den: float
    p_value: float


@dataclass(frozen=True, eq=False)
class Anova(_Result):
    """A one-way ANOVA: ``f`` with (``df_between``, ``df_within``) degrees of freedom."""

    f: float
    df_between: float
    df_within: float
    p_value: float


@dataclass(frozen=True, eq=False)
class Correlation(_Result):
    """Spearman's ``rho`` over ``n`` pairs, two-sided ``p_value``."""

    rho: float
    n: int
    p_value: float


@dataclass(frozen=True, eq=False)
class PoseAnova(_Result):
    """Per-pose ANOVA of the residuals, one per axis (None where not computable), and the
    Bonferroni-combined ``p_value`` (VJM)."""

    axes: List[Optional[Anova]]
    p_value: float


@dataclass(frozen=True, eq=False)
class TorqueCorrelation(_Result):
    """Correlation of the residual norm with the torque of ``joint`` (1-based) (VJM)."""

    joint: int
    correlation: Optional[Correlation]


@dataclass(frozen=True, eq=False)
class DirectionCorrelation(_Result):
    """The strongest correlation between a residual axis and a force axis (VJM)."""

    residual_axis: str
    force_axis: str
    correlation: Correlation
    p_bonferroni: float


@dataclass(frozen=True, eq=False)
class LoadingUnloading(_Result):
    """Residual difference between loading and unloading about one axis (CSJM)."""

    axis: str
    mean_difference: float
    test: Optional[Anova]


@dataclass(frozen=True, eq=False)
class ResidualStructure(_Result):
    """The structure of one model's residuals: ``scaled_rms`` (1 = noise only), correlation
    with the load magnitude, and the model's own tests."""

    n_rows: int
    scaled_rms: float
    load_magnitude: Optional[Correlation]
    #: VJM: residual axis vs force axis; CSJM: ANOVA over load directions.
    load_direction: Optional[Union[DirectionCorrelation, Anova]]
    per_pose_anova: Optional[PoseAnova] = _only(VJM)
    torque: Optional[List[TorqueCorrelation]] = _only(VJM)
    loading_unloading: Optional[List[LoadingUnloading]] = _only(CSJM)
    p_bonferroni: Optional[float] = _only(CSJM)


@dataclass(frozen=True, eq=False)
class ResidualReport(_Result):
    """Residual structure of the baseline and of the extended model."""

    baseline: ResidualStructure
    extended: ResidualStructure


# ----------------------------------------------------------------------------- models


@dataclass(frozen=True, eq=False)
class Parameter(_Result):
    """One fitted parameter: ``label``, ``value`` (None when the data do not determine it),
    ``unit``; ``stderr`` (CSJM)."""

    label: str
    value: Optional[float]
    unit: str
    stderr: Optional[float] = _only(CSJM)


@dataclass(frozen=True, eq=False)
class ModelSummary(_Result):
    """A fitted model: name, parameter count, mean relative errors on held-out and training
    rows, parameters in model order. CSJM: ``rank`` of the design, ``k_d`` and ``k`` (3×3,
    N·m/rad, frame A at R₀, row-major)."""

    model: str
    n_params: int
    test_mean_rel_error: float
    train_mean_rel_error: float
    parameters: List[Parameter]
    rank: Optional[int] = _only(CSJM)
    k_d: Optional[List[List[float]]] = _only(CSJM)
    k: Optional[List[List[float]]] = _only(CSJM)


# ----------------------------------------------------------------------------- findings


@dataclass(frozen=True, eq=False)
class Alias(_Result):
    """A candidate that cannot be told apart from a finding on these data: ``effect``, its
    ``joint`` (1-based) and ``axis`` or None, ``delta_chi2`` (SSE with the alias − SSE with the
    finding, in noise variances), ``cosine`` of the one-column candidates' columns,
    ``p_finding_given_alias``; CSJM: ``note``."""

    effect: str
    joint: Optional[int]
    axis: Optional[str]
    delta_chi2: Optional[float]
    cosine: Optional[float] = None
    p_finding_given_alias: Optional[float] = None
    note: Optional[str] = _only(CSJM)


@dataclass(frozen=True, eq=False)
class Evidence(_Result):
    """Why a finding was named: its forward-selection ``step``, the F test of adding it, the
    Benjamini–Hochberg threshold it beat over ``n_candidates``, the share of the training SSE
    it removed and the held-out SSE before/after. ``estimate``: VJM its parameter values (in
    ``unit``), CSJM its :class:`Parameter` list."""

    step: int
    f_test: FTest
    n_candidates: int
    bh_threshold: float
    sse_reduction: float
    heldout_sse_before: float
    heldout_sse_after: float
    estimate: Union[List[float], List[Parameter]]
    cluster_robust: Optional[FTest] = None
    unit: Optional[str] = _only(VJM)
    fraction_outside_baseline: Optional[float] = _only(CSJM)
    interpretation: Optional[str] = _only(CSJM)


@dataclass(frozen=True, eq=False)
class ConnectionTest(_Result):
    """The CSJM connection-term test: is K_D asymmetric as −½hat(τ₀) predicts? (The JSON key
    of ``lambda_`` is ``lambda``.)"""

    asymmetry: List[float]
    asymmetry_stderr: List[float]
    tau0: List[float]
    chi2_asymmetry: float
    p_asymmetry: float
    chi2_theory: float
    p_theory: float
    lambda_: float = field(metadata={"key": "lambda"})
    lambda_stderr: float
    z_levi_civita: float
    z_paper_eq48b: float = field(metadata={"former": "z_seed_eq48b"})
    k: List[List[float]]
    k_d: List[List[float]]
    relative_difference: float
    interpretation: str


@dataclass(frozen=True, eq=False)
class Finding(_Result):
    """A named effect: ``effect``, ``joint`` (1-based, base → tip) and ``axis`` or None, its
    ``aliases`` and the ``evidence`` (a :class:`ConnectionTest` for the CSJM's
    ``connection_term``); ``knots`` for a VJM ``joint_torsion_nonlinear``."""

    effect: str
    joint: Optional[int]
    axis: Optional[str]
    aliases: List[Alias]
    evidence: Union[Evidence, ConnectionTest]
    #: VJM ``joint_torsion_nonlinear``: the knots of its hinges, N·m (with
    #: ``evidence.estimate``, rad/(N·m), the gear curve a saved model holds); None otherwise.
    knots: Optional[List[float]] = _only(VJM)


@dataclass(frozen=True, eq=False)
class CandidateScore(_Result):
    """The first-step F test of one catalogue candidate against the baseline. VJM: ``label``,
    ``joint``, ``axis``, ``testable``; CSJM: ``n_columns``, ``fraction_outside_baseline``,
    ``note``."""

    effect: str
    f_test: Optional[FTest]
    label: Optional[str] = _only(VJM)
    joint: Optional[int] = _only(VJM)
    axis: Optional[str] = _only(VJM)
    testable: Optional[bool] = _only(VJM)
    n_columns: Optional[int] = _only(CSJM)
    fraction_outside_baseline: Optional[float] = _only(CSJM)
    note: Optional[str] = _only(CSJM)


@dataclass(frozen=True, eq=False)
class PoseError(_Result):
    """Mean relative error of one pose, baseline and extended; ``set`` is ``train``/``test``
    (VJM)."""

    pose: int
    set: str
    baseline: float
    extended: float


class PoseErrors(Sequence[PoseError]):
    """The per-pose errors of a VJM diagnosis: a read-only sequence of :class:`PoseError`
    kept as numpy columns, ``pose`` id (G,) int64, ``held_out`` (G,) bool, and the mean relative
    errors ``baseline`` and ``extended`` (G,). A campaign of 10⁵ poses crosses from the core as
    four arrays; a :class:`PoseError` is made only for an item read."""

    __slots__ = ("pose", "held_out", "baseline", "extended")

    pose: npt.NDArray[np.int64]
    held_out: npt.NDArray[np.bool_]
    baseline: npt.NDArray[np.float64]
    extended: npt.NDArray[np.float64]

    def __init__(self, pose: npt.ArrayLike, held_out: npt.ArrayLike, baseline: npt.ArrayLike,
                 extended: npt.ArrayLike) -> None:
        cols = {"pose": np.asarray(pose, dtype=np.int64), "held_out": np.asarray(held_out, dtype=np.bool_),
                "baseline": np.asarray(baseline, dtype=np.float64),
                "extended": np.asarray(extended, dtype=np.float64)}
        n = cols["pose"].shape
        for name, col in cols.items():
            if col.ndim != 1 or col.shape != n:
                raise ValueError(f"PoseErrors: column {name!r} has shape {col.shape}; every column must "
                                 f"be 1-D with the length of 'pose' {n}")
            object.__setattr__(self, name, col)

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"PoseErrors is read-only (cannot set {name!r})")

    def __getstate__(self) -> Dict[str, object]:
        return {n: getattr(self, n) for n in self.__slots__}

    def __setstate__(self, state: Dict[str, object]) -> None:
        for n in self.__slots__:
            object.__setattr__(self, n, state[n])

    def __len__(self) -> int:
        return int(self.pose.shape[0])

    def _item(self, i: int) -> PoseError:
        return PoseError(pose=int(self.pose[i]), set="test" if self.held_out[i] else "train",
                         baseline=float(self.baseline[i]), extended=float(self.extended[i]))

    @typing.overload
    def __getitem__(self, i: int) -> PoseError: ...

    @typing.overload
    def __getitem__(self, i: slice) -> "PoseErrors": ...

    def __getitem__(self, i: Union[int, slice]) -> Union[PoseError, "PoseErrors"]:
        if isinstance(i, slice):
            return PoseErrors(self.pose[i], self.held_out[i], self.baseline[i], self.extended[i])
        k = operator.index(i)
        n = len(self)
        if not -n <= k < n:
            raise IndexError(f"pose index {k} out of range for {n} poses")
        return self._item(k % n)

    def __iter__(self) -> Iterator[PoseError]:
        return (self._item(i) for i in range(len(self)))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, PoseErrors):
            return NotImplemented
        return all(np.array_equal(getattr(self, n), getattr(other, n), equal_nan=n in ("baseline", "extended"))
                   for n in self.__slots__)

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"PoseErrors({len(self)} poses, {int(self.held_out.sum())} held out)"

    def records(self) -> Iterator[Dict[str, Json]]:
        """One JSON-ready dict per pose, with the keys of the core's JSON."""
        sets = np.where(self.held_out, "test", "train").tolist()
        for p, st, b, e in zip(self.pose.tolist(), sets, self.baseline.tolist(), self.extended.tolist()):
            yield {"pose": p, "set": st, "baseline": b, "extended": e}

    @classmethod
    def _from_core(cls, value: object) -> "PoseErrors":
        """From the core's columns, or from the JSON form (a list of per-pose dicts)."""
        if isinstance(value, PoseErrors):
            return value
        if isinstance(value, Mapping):
            return cls(value["pose"], value["held_out"], value["baseline"], value["extended"])
        if isinstance(value, list):
            for k, v in enumerate(value):
                if not isinstance(v, Mapping):
                    raise TypeError(f"per_pose[{k}]: PoseError expects a mapping, got {type(v).__name__}")
            return cls([v["pose"] for v in value], [v["set"] == "test" for v in value],
                       [_float(v["baseline"]) for v in value], [_float(v["extended"]) for v in value])
        raise TypeError(f"PoseErrors expects columns or a list of per-pose mappings, got {type(value).__name__}")


# ----------------------------------------------------------------------------- rows

Array = npt.NDArray[np.float64]


class _Rows:
    """Per-row columns (numpy, one row per measurement). ``held_out`` marks the test rows."""

    held_out: npt.NDArray[np.bool_]

    def __len__(self) -> int:
        return int(self.held_out.shape[0])

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            a, b = getattr(self, f.name), getattr(other, f.name)
            if not np.array_equal(a, b, equal_nan=a.dtype.kind == "f"):
                return False
        return True

    def records(self) -> Iterator[Dict[str, Json]]:
        """One JSON-ready dict per row, with the keys of the core's per-row JSON."""
        names = [f.name for f in dataclasses.fields(self) if f.name != "held_out"]  # type: ignore[arg-type]
        lead, vectors = names[0], names[1:]
        cols = {n: getattr(self, n).tolist() for n in names}
        sets = np.where(self.held_out, "test", "train").tolist()
        for i in range(len(self)):
            rec: Dict[str, Json] = {lead: cols[lead][i], "set": sets[i]}
            for n in vectors:
                rec[n] = cols[n][i]
            yield rec

    def csv_chunks(self, rows_per_chunk: int = 50_000) -> Iterator[str]:
        """The rows as CSV text in pieces: the header, then ``rows_per_chunk`` rows at a time
        (vector columns split into ``_x``, ``_y``, ``_z``; floats in their shortest exact form)."""
        names = [f.name for f in dataclasses.fields(self) if f.name != "held_out"]  # type: ignore[arg-type]
        lead, vectors = names[0], names[1:]
        yield ",".join([lead, "set"] + [f"{n}_{a}" for n in vectors for a in "xyz"]) + "\n"
        line = "%d,%s," + ",".join(["%r"] * (3 * len(vectors))) + "\n"
        for a in range(0, len(self), max(1, rows_per_chunk)):
            b = min(len(self), a + rows_per_chunk)
            values = np.concatenate([getattr(self, n)[a:b] for n in vectors], axis=1).tolist()
            sets = np.where(self.held_out[a:b], "test", "train").tolist()
            ids = getattr(self, lead)[a:b].tolist()
            yield "".join(line % (i, st, *v) for i, st, v in zip(ids, sets, values))

    def csv_text(self) -> str:
        """The rows as CSV with a header (see :meth:`csv_chunks`)."""
        return "".join(self.csv_chunks())


@dataclass(frozen=True, eq=False)
class DisplacementRows(_Rows):
    """VJM rows: ``pose`` id (N,), ``held_out`` (N,) bool, measured and predicted
    displacements ``measured``, ``baseline``, ``extended`` (N, 3) m, base frame."""

    pose: npt.NDArray[np.int64]
    held_out: npt.NDArray[np.bool_]
    measured: Array
    baseline: Array
    extended: Array


@dataclass(frozen=True, eq=False)
class MomentRows(_Rows):
    """CSJM rows: 1-based data ``row`` of the file (0 for arrays) (N,), ``held_out`` (N,) bool,
    ``dzeta`` (N, 3) rad, ``dtau`` and the moment residuals ``baseline_residual``,
    ``extended_residual`` (N, 3) N·m."""

    row: npt.NDArray[np.int64]
    held_out: npt.NDArray[np.bool_]
    dzeta: Array
    dtau: Array
    baseline_residual: Array
    extended_residual: Array


# ----------------------------------------------------------------------------- verdict


@dataclass(frozen=True, eq=False)
class ChiSquareTest(_Result):
    """A χ² goodness-of-fit test of a whitened SSE: ``chi2`` with ``df`` degrees of freedom,
    ``ratio`` = χ²/df (1 when only the stated noise remains), upper-tail ``p_value``."""

    chi2: float
    df: float
    ratio: float
    p_value: float


@dataclass(frozen=True, eq=False)
class BlockTest(_Result):
    """One block of the lack-of-fit alternative (``linear_in_wrench``, ``tool_frame``,
    ``pose_offsets``, ``pose_compliance``, ``angle_compliance``, ``springs``) tested alone
    against the extended model, and what structure in it means. ``pose_compliance`` (per pose,
    its own offsets and its own scale of each joint's torsion response) also decides
    ``unexplained``; ``angle_compliance`` (each joint's torsion compliance varying with sin and
    cos of its angle) decides too: on its F test when the noise level was given, else on
    ``wild_cluster_p_value``, the p of its cluster-robust Wald statistic by a wild cluster
    bootstrap over the measurements (the F distribution does not hold when the rows are
    whitened with an assumed noise level)."""

    block: str
    f_test: FTest
    meaning: str
    #: ``angle_compliance`` with the noise level not given: the p-value it decides on; None
    #: for the other blocks and when the noise level was given.
    wild_cluster_p_value: Optional[float] = None


@dataclass(frozen=True, eq=False)
class Verdict(_Result):
    """The tests behind ``Diagnosis.unexplained``: the ``lack_of_fit`` F test of the extended
    model against a flexible alternative (needs no noise level), the χ² ``goodness_of_fit`` when
    the noise level was given, the level ``alpha`` they were decided at, each alternative block
    alone, and what remains in words (``None`` when nothing does)."""

    lack_of_fit: FTest
    goodness_of_fit: Optional[ChiSquareTest]
    alpha: float
    blocks: List[BlockTest]
    #: What remains, in words, when the diagnosis is ``unexplained``; ``None`` (null in the JSON)
    #: when nothing remains.
    remaining: Optional[str]


# ----------------------------------------------------------------------------- diagnosis


@dataclass(frozen=True, eq=False)
class Diagnosis(_Result):
    """The result of ``vjm.diagnose`` / ``csjm.diagnose``.

    ``baseline`` and ``extended`` models, ``findings`` in the order accepted, ``unexplained``
    (structure remains that no candidate explains), ``gain`` = 1 − extended/baseline held-out
    error, the residual structure, the first-step ``scores`` of the catalogue, candidates
    ``rejected_on_holdout``, row counts, the ``fdr`` used. ``model_kind`` is ``"vjm"`` or
    ``"csjm"``. VJM: ``per_pose`` errors; CSJM: ``connection_term``, ``noise_sigma`` (N·m),
    ``split_seed``. ``rows``: the per-row data (numpy columns).
    """

    model_kind: str = field(metadata={"json": False})
    baseline: ModelSummary
    findings: List[Finding]
    extended: ModelSummary
    unexplained: bool
    gain: float
    residuals: ResidualReport
    scores: List[CandidateScore]
    rejected_on_holdout: List[str]
    n_train: int
    n_test: int
    fdr: float
    per_pose: Optional[PoseErrors] = _only(VJM)
    verdict: Optional[Verdict] = _only(VJM)
    explained_by_springs: Optional[List[str]] = _only(VJM)
    connection_term: Optional[ConnectionTest] = _only(CSJM)
    noise_sigma: Optional[List[float]] = _only(CSJM)
    split_seed: Optional[int] = _only(CSJM, former="holdout_seed")
    rows: Optional[Union[DisplacementRows, MomentRows]] = field(default=None, repr=False, metadata={"json": False})

    def to_dict(self, *, rows: bool = False) -> Dict[str, Json]:
        """The JSON of ``robot-stiffness diagnose … --json``; with ``rows=True`` also ``rows``,
        one dict per measurement row (large: ~400 bytes a row)."""
        out = super().to_dict()
        if rows and self.rows is not None:
            out["rows"] = list(self.rows.records())
        return out

    def to_json(self, *, rows: bool = False, indent: Optional[int] = 2) -> str:
        """:meth:`to_dict` as JSON text (non-finite numbers as null)."""
        return json.dumps(_finite(self.to_dict(rows=rows)), indent=indent, allow_nan=False)

    def __getitem__(self, key: str) -> object:
        if key == "rows":  # the per-row dicts of earlier versions
            return [] if self.rows is None else list(self.rows.records())
        return super().__getitem__(key)

    @classmethod
    def _from_dict(cls, d: Mapping[str, object]) -> "Diagnosis":
        """From :meth:`to_dict`'s form (with or without ``rows``)."""
        kind = CSJM if "connection_term" in d else VJM
        row_cls = DisplacementRows if kind == VJM else MomentRows
        records = d.get("rows") or []
        assert isinstance(records, list)
        names = _field_names(row_cls)
        columns: Dict[str, np.ndarray] = {"held_out": np.array([r["set"] == "test" for r in records], dtype=bool)}
        columns[names[0]] = np.array([r[names[0]] for r in records], dtype=np.int64)
        for n in names[2:]:
            columns[n] = np.array([r[n] for r in records], dtype=np.float64).reshape(-1, 3)
        return cls._from_core(kind, {k: v for k, v in d.items() if k != "rows"}, columns)

    @classmethod
    def _from_core(cls, model_kind: str, summary: Mapping[str, object],
                   rows: Mapping[str, np.ndarray]) -> "Diagnosis":
        row_cls = DisplacementRows if model_kind == VJM else MomentRows
        built = _build(cls, {**summary, "model_kind": model_kind})
        assert isinstance(built, Diagnosis)
        return dataclasses.replace(built, rows=row_cls(**{k: rows[k] for k in _field_names(row_cls)}))


# ----------------------------------------------------------------------------- building

# The per-pose errors arrive as columns (or, from JSON, as a list of records), not as a mapping
# of their fields: they build themselves.
register_builder(PoseErrors, PoseErrors._from_core)


def _finite(x: Json) -> Json:
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_finite(v) for v in x]
    return x


def _unmapped_keys(tp: type, value: object, path: str = "") -> List[str]:
    """Keys of a core value that no field of ``tp`` takes (``a.b[0].c`` paths); empty when the
    classes cover everything the core sends. Used by the tests to catch a field the core gained."""
    out: List[str] = []
    origin = typing.get_origin(tp)
    if origin is Union:
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if value is None:
            return out
        arm = next((a for a in args if _fits(a, value)), args[0])
        return _unmapped_keys(arm, value, path)
    if tp is PoseErrors and isinstance(value, dict):
        return [f"{path}{k}" for k in value if k not in PoseErrors.__slots__]
    if dataclasses.is_dataclass(tp) and isinstance(value, dict):
        hints = _hints(tp)
        by_key = {_key(f): f for f in dataclasses.fields(tp)}
        for k, v in value.items():
            if k not in by_key:
                out.append(f"{path}{k}")
            else:
                out += _unmapped_keys(hints[by_key[k].name], v, f"{path}{k}.")  # type: ignore[arg-type]
        return out
    if origin in (list, List) and isinstance(value, list):
        (item,) = typing.get_args(tp)
        for i, v in enumerate(value):
            out += _unmapped_keys(item, v, f"{path[:-1]}[{i}].")
    return out

