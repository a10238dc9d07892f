"""robot-stiffness: stiffness modelling, identification and diagnosis of robots.

Submodules:

* :mod:`robot_stiffness.so3` — the rotation group: ``exp``, ``log``, ``hat``, ``vee``,
  ``adjoint``, ``left_jacobian``, ``right_jacobian``…
* :mod:`robot_stiffness.csjm` — cable-driven spherical joint modules: identify the 3×3
  rotational stiffness K (N·m/rad) from platform orientations and moments.
* :mod:`robot_stiffness.vjm` — virtual-joint models of serial arms from URDF: Jacobians,
  rank-revealing identification of joint compliances (rad/(N·m)), prediction.
* :mod:`robot_stiffness.model` — stiffness model files (``Identification.save``,
  ``StiffnessModel.load``) and predictions with standard deviations.
* :mod:`robot_stiffness.results` — the typed diagnosis result (``Diagnosis``, ``Finding``, …),
  the same classes for ``vjm.diagnose`` and ``csjm.diagnose``.
* :mod:`robot_stiffness.testbed` — the typed truth and spec of a simulated campaign
  (``TrueModel`` and its effects, ``CampaignSpec``) and a plan's ``NoiseModel``.

Units are SI (m, rad, N, N·m); frames are named in every docstring and follow
``docs/conventions.md``. Every error derives from :class:`StiffnessError`.
The console script ``robot-stiffness`` (see ``robot-stiffness --help``) drives the same code
from measurement files.
"""

from __future__ import annotations

import importlib as _importlib
from typing import TYPE_CHECKING as _TYPE_CHECKING
from typing import Any as _Any
from typing import List as _List

from ._console_process import leave_cores_to_the_core
from ._interrupt import leave_quietly_while_starting

# Before the extension and numpy load (a few hundred ms): a Ctrl-C of the console script then
# exits 130 without a traceback, and numpy's BLAS does not spin on the cores the core's
# thread pool is about to use.
leave_quietly_while_starting()
leave_cores_to_the_core()

from . import _core  # noqa: E402
from ._errors import (  # noqa: E402
    ArgumentTypeError,
    CancelledError,
    ConvergenceError,
    DataFileError,
    IdentificationError,
    InternalError,
    InvalidValueError,
    MissingDependencyError,
    MissingFileError,
    ModelFileError,
    OutputPathError,
    RobotModelError,
    ShapeError,
    StiffnessError,
    SuspiciousDataWarning,
)

__version__: str = _core.__version__

# The submodules load on first use (PEP 562): `robot_stiffness.vjm`, `from robot_stiffness
# import vjm` and `import robot_stiffness.vjm` work as before, and a command of the console
# script pays only for the modules it uses (the five took ≈ 35 ms of every start-up).
_SUBMODULES = ("csjm", "model", "results", "so3", "testbed", "vjm")

if _TYPE_CHECKING:
    from . import csjm, model, results, so3, testbed, vjm  # noqa: F401


def __getattr__(name: str) -> _Any:
    if name in _SUBMODULES:
        return _importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> _List[str]:
    return sorted(set(globals()) | set(_SUBMODULES))

__all__ = [
    "__version__",
    "csjm",
    "model",
    "results",
    "so3",
    "testbed",
    "vjm",
    "StiffnessError",
    "ShapeError",
    "InvalidValueError",
    "DataFileError",
    "MissingFileError",
    "MissingDependencyError",
    "RobotModelError",
    "IdentificationError",
    "ModelFileError",
    "InternalError",
    "ConvergenceError",
    "CancelledError",
    "ArgumentTypeError",
    "OutputPathError",
    "SuspiciousDataWarning",
]
