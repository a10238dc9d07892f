"""Partial identification statistics: one part of a campaign, merged with the others and solved
once (``docs/fleet.md``). The statistic itself lives in Rust (``vjm::IdentificationPartial``: the
streaming QR factor of the part's whitened rows); this module wraps it for Python.
"""

from __future__ import annotations

from functools import reduce
from typing import TYPE_CHECKING, Any, Iterable, List, Tuple

from . import _core
from ._arguments import ModelSpec, checked, model_spec
from ._arrays import f64
from ._errors import ArgumentTypeError, InvalidValueError
from ._identification import Identification

if TYPE_CHECKING:  # pragma: no cover
    from .vjm import Robot



class IdentificationPartial:
    """The identification statistics of some measurements of one robot (immutable; pickles).

    Made by :meth:`robot_stiffness.vjm.Robot.identify_partial` (or :meth:`empty`). Parts of one
    campaign — disjoint sets of rows — :meth:`merge` in any grouping (``merge`` is associative),
    and :meth:`finish` solves once: the result equals ``Robot.identify(..., method="qr")`` on all
    the rows to rounding (1e-12 relative is tested). Parts must share robot, model and options
    (``noise_sigma``, ``noise_scale_known``, ``nonnegative``, rotations used or not); merging
    others raises :class:`~robot_stiffness.InvalidValueError` naming what differs.
    """

    __slots__ = ("_inner", "_robot")

    def __init__(self, inner: Any, robot: "Robot") -> None:
        """Wraps a ``robot_stiffness._core.IdentificationPartial``; use
        :meth:`Robot.identify_partial <robot_stiffness.vjm.Robot.identify_partial>` instead."""
        if not isinstance(inner, _core.IdentificationPartial):
            raise ArgumentTypeError("use Robot.identify_partial() or IdentificationPartial.empty()")
        self._inner = inner
        self._robot = robot

    @classmethod
    @checked
    def empty(
        cls,
        robot: "Robot",
        model: ModelSpec = "traditional",
        *,
        noise_sigma: Any = None,
        noise_scale_known: bool = False,
        nonnegative: bool = False,
        rotations: bool = False,
    ) -> "IdentificationPartial":
        """The statistics of no measurement: merging it changes nothing (a start value for a
        reduction over parts that may be empty)."""
        inner = _core.IdentificationPartial.empty(
            robot._inner,
            model_spec(model),
            noise_sigma=None if noise_sigma is None else f64(noise_sigma, "noise_sigma"),
            noise_scale_known=bool(noise_scale_known),
            nonnegative=bool(nonnegative),
            rotations=bool(rotations),
        )
        return cls(inner, robot)

    @checked
    def merge(self, other: "IdentificationPartial") -> "IdentificationPartial":
        """The statistics of this part's and ``other``'s measurements (a new partial)."""
        if not isinstance(other, IdentificationPartial):
            raise ArgumentTypeError(
                f"can only merge another IdentificationPartial, got {type(other).__name__}"
            )
        return IdentificationPartial(self._inner.merge(other._inner), self._robot)

    @classmethod
    @checked
    def merge_all(cls, parts: Iterable["IdentificationPartial"]) -> "IdentificationPartial":
        """All ``parts`` merged (in order; any grouping gives the same result to rounding)."""
        items: List[IdentificationPartial] = list(parts)
        for i, p in enumerate(items):
            if not isinstance(p, cls):
                raise ArgumentTypeError(f"parts[{i}] is a {type(p).__name__}, not an IdentificationPartial")
        if not items:
            raise InvalidValueError("merge_all needs at least one IdentificationPartial")
        return reduce(lambda a, b: a.merge(b), items)

    @checked
    def finish(self) -> "Identification":
        """The identification of every measurement merged in, with its stiffness model."""
        from .model import StiffnessModel

        core, core_model = self._inner.finish()
        return Identification._from_core(core, StiffnessModel(core_model, self._robot))

    @property
    def n_measurements(self) -> int:
        """Number of measurements (input rows) merged in."""
        return int(self._inner.n_measurements)

    @property
    def n_equations(self) -> int:
        """Number of scalar equations merged in (3 or 6 per measurement)."""
        return int(self._inner.n_equations)

    @property
    def labels(self) -> List[str]:
        """Parameter labels of the model, in parameter order."""
        return list(self._inner.labels)

    @property
    def robot(self) -> "Robot":
        """The robot the measurements were taken on."""
        return self._robot

    def __reduce__(self) -> Tuple[Any, ...]:
        return (IdentificationPartial, (self._inner, self._robot))

    def __repr__(self) -> str:
        return f"IdentificationPartial(labels={self.labels}, n_measurements={self.n_measurements})"

