"""The base class of :class:`robot_stiffness.vjm.Robot`.

The modules below :mod:`robot_stiffness.vjm` (argument checks, the model's use) take a robot
argument but cannot import vjm, which imports them: they check against this base, which holds
the Rust chain (``_core.Robot``) and nothing else.
"""

from __future__ import annotations

from typing import Any

__all__ = ["RobotHandle"]


class RobotHandle:
    """A serial chain held by the Rust core: ``_inner`` is a ``robot_stiffness._core.Robot``.
    Only :class:`robot_stiffness.vjm.Robot` derives from it."""

    __slots__ = ("_inner",)
    _inner: Any
