"""Input checks shared by every linkwright package: each names the argument it rejects and
raises the calling package's own error class (a ValueError subclass)."""
from __future__ import annotations

from numbers import Real

import numpy as np

__all__ = ["real_array", "real_number", "shown"]


def shown(x) -> str:
    """``x`` for a message: its type and, for plain Python values, a short repr (never a
    numpy repr)."""
    if x is None or isinstance(x, (str, bytes, bool, int, float, complex)):
        return f"{type(x).__name__} {x!r:.60}"
    return type(x).__name__


def real_number(x, name: str, error: type[ValueError], *, positive: bool = False,
                nonnegative: bool = False, unit: str = "") -> float:
    """``x`` as a float after checking it is one finite real number (optionally > 0 or ≥ 0).

    Raises ``error`` with a message that starts with ``name`` and gives the ``unit``."""
    u = f" ({unit})" if unit else ""
    scalar = isinstance(x, (Real, np.integer, np.floating)) or \
        (isinstance(x, np.ndarray) and x.shape == () and x.dtype.kind in "iuf")
    if not scalar or isinstance(x, (bool, np.bool_)):
        raise error(f"{name}: expected a number{u}, got {type(x).__name__} {x!r}")
    try:
        v = float(x)
    except OverflowError:
        raise error(f"{name}: expected a finite number{u}, got {x!r:.60}") from None
    if not np.isfinite(v):
        raise error(f"{name}: expected a finite number{u}, got {v}")
    if positive and v <= 0:
        raise error(f"{name}: expected a positive number{u}, got {v}")
    if nonnegative and v < 0:
        raise error(f"{name}: expected a non-negative number{u}, got {v}")
    return v


def real_array(x, name: str, error: type[ValueError], expect: str = "numbers") -> np.ndarray:
    """``x`` as a float array after checking it holds real numbers (no strings, None,
    booleans, complex values, ragged nesting or objects); shape and finiteness are the
    caller's.

    Raises ``error`` with a message that starts with ``name`` and says ``expect``."""
    if isinstance(x, (str, bytes)) or x is None:
        raise error(f"{name}: expected {expect}, got {type(x).__name__} {x!r}")
    try:
        a = np.asarray(x)
        if a.dtype.kind == "c":
            want = "real numbers" if expect == "numbers" else f"{expect} (real, not complex)"
            raise error(f"{name}: expected {want}, got complex values")
        if a.dtype.kind == "b":
            raise error(f"{name}: expected {expect}, got booleans (True/False)")
        return a.astype(float, copy=a.dtype.kind not in "iuf")
    except error:
        raise
    except (TypeError, ValueError, OverflowError):
        raise error(f"{name}: expected {expect}, got {type(x).__name__} that is not a numeric "
                    "array") from None
