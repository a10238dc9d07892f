"""The console script's own process: what it is, and what it sets before numpy is imported.

The package is imported both as a library (``import robot_stiffness``: the caller's process, left
as it is) and as the console script ``robot-stiffness`` (or ``python -m robot_stiffness.cli``):
a process of its own, whose arithmetic runs in the Rust core on a thread pool that takes every
core. There, numpy's OpenBLAS would start a thread per core at import that spins (≈ 0.1 CPU-s
each) waiting for BLAS work the commands do not give it, on the cores the reader and the
identification are using. The console script gives it one thread unless the user chose.
"""

from __future__ import annotations

import os
import sys

#: Environment set for the console script's process when the user has not set it.
CONSOLE_ENVIRONMENT = {"OPENBLAS_NUM_THREADS": "1"}


def launched_as_console_script() -> bool:
    """Whether this process is the console script (or ``python -m robot_stiffness.cli``).

    While ``-m`` locates its module (the package's import), ``sys.argv[0]`` is ``"-m"``; the
    module is then the word after the interpreter's ``-m`` (a script's own ``-m`` argument
    does not count)."""
    first = sys.argv[0] if sys.argv else ""
    if first == "-m" or os.path.basename(os.path.dirname(first)) == "robot_stiffness":
        argv = list(getattr(sys, "orig_argv", []))
        return "-m" in argv[:-1] and argv[argv.index("-m") + 1] == "robot_stiffness.cli"
    return os.path.basename(first) in ("robot-stiffness", "robot-stiffness.exe")


def leave_cores_to_the_core() -> None:
    """In the console script's process, before numpy is imported: numpy's BLAS on one thread
    (:data:`CONSOLE_ENVIRONMENT`), unless the user set the variable. A library import changes
    nothing."""
    if "numpy" in sys.modules or not launched_as_console_script():
        return
    for name, value in CONSOLE_ENVIRONMENT.items():
        os.environ.setdefault(name, value)
