"""Input normalisation shared by the wrappers: dtype only; layout is handled in Rust.

Arrays are converted to float64 with ``numpy.asarray`` (no copy when they already are float64).
C-contiguous arrays are then read by the Rust core without copying; Fortran-ordered or strided
arrays are copied once, in Rust, into row-major order.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from ._errors import InvalidValueError


def f64(x: Any, name: str) -> npt.NDArray[np.float64]:
    """``x`` as a float64 array; a clear error naming ``name`` if it is not numeric."""
    if hasattr(x, "to_numpy") and not isinstance(x, np.ndarray):  # pandas objects
        x = x.to_numpy(dtype=np.float64)
    try:
        return np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InvalidValueError(f"{name} must be a numeric array: {e}") from None
