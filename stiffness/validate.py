"""Input checks shared by the stiffness package.

Every public function converts its array arguments here, so that bad input
(wrong type, wrong shape, NaN or inf, a matrix that is not a rotation or a
rigid transform) raises :class:`StiffnessError` with the argument's name, what
was expected and what was given, never a numpy traceback.
"""
from __future__ import annotations


import numpy as np

from closure.checks import real_array, real_number

from .errors import StiffnessError

__all__ = ["as_array", "vec3", "points", "rotation", "transform", "matrix6", "number",
           "broadcast", "first_bad"]

#: tolerance of the orthonormality and last-row checks (dimensionless)
ROTATION_TOL = 1e-9


def _shape_text(trailing, ndim=None) -> str:
    dims = ", ".join("n" if d is None else str(d) for d in trailing)
    if ndim is not None and ndim == len(trailing):
        return f"({dims})" if len(trailing) != 1 else f"({dims},)"
    return f"(..., {dims})" if trailing else "an array"


def first_bad(mask: np.ndarray) -> tuple:
    """Index of the first True entry of ``mask`` (for messages)."""
    return tuple(int(i) for i in np.argwhere(mask)[0])


def as_array(x, name: str, trailing: tuple = (), *, ndim: int | None = None,
             finite: bool = True, what: str | None = None) -> np.ndarray:
    """``x`` as a float array after checking its type, shape and values.

    Parameters
    ----------
    x : array_like
        The argument.
    name : str
        Its name, used in messages.
    trailing : tuple of int or None
        Required trailing dimensions (``None``: any size); leading axes are free
        unless ``ndim`` is given.
    ndim : int, optional
        Required number of dimensions.
    finite : bool
        Reject NaN and inf.
    what : str, optional
        Text for "expected …" (default: the shape).

    Raises
    ------
    StiffnessError
        Naming ``name``, the expected shape and what was given.
    """
    expect = what or _shape_text(trailing, ndim) + " of numbers"
    a = real_array(x, name, StiffnessError, expect)
    k = len(trailing)
    ok = a.ndim >= k and all(d is None or a.shape[a.ndim - k + i] == d
                             for i, d in enumerate(trailing))
    if ndim is not None:
        ok = ok and a.ndim == ndim
    if not ok:
        raise StiffnessError(f"{name}: expected {what or 'shape ' + _shape_text(trailing, ndim)}, "
                             f"got shape {a.shape}")
    if finite and not np.all(np.isfinite(a)):
        bad = first_bad(~np.isfinite(a))
        raise StiffnessError(f"{name}: expected finite values, got {a[bad]} at index "
                             f"{bad if a.ndim else '()'}")
    return a


def vec3(x, name: str) -> np.ndarray:
    """Finite 3-vectors ``(..., 3)``."""
    return as_array(x, name, (3,))


def points(x, name: str, n: int | None = None) -> np.ndarray:
    """A finite point list ``(n, 3)`` (``n`` fixed when given)."""
    a = as_array(x, name, (n, 3), ndim=2, what=f"({n if n is not None else 'n'}, 3)")
    return a


def rotation(R, name: str = "R", tol: float = ROTATION_TOL) -> np.ndarray:
    """Proper rotations ``(..., 3, 3)``: rows orthonormal and right-handed to ``tol``."""
    R = as_array(R, name, (3, 3), what="a 3x3 rotation matrix (..., 3, 3)")
    if R.size == 0:
        return R
    r0, r1, r2 = R[..., 0, :], R[..., 1, :], R[..., 2, :]
    c = np.stack([r0[..., 1] * r1[..., 2] - r0[..., 2] * r1[..., 1],
                  r0[..., 2] * r1[..., 0] - r0[..., 0] * r1[..., 2],
                  r0[..., 0] * r1[..., 1] - r0[..., 1] * r1[..., 0]], -1)
    err = max(float(np.max(np.abs(np.einsum("...i,...i->...", r0, r0) - 1))),
              float(np.max(np.abs(np.einsum("...i,...i->...", r1, r1) - 1))),
              float(np.max(np.abs(np.einsum("...i,...i->...", r0, r1)))),
              float(np.max(np.abs(c - r2))))
    if err > tol:
        raise StiffnessError(f"{name}: not a proper rotation (|R Rᵀ − I| = {err:.1e}, "
                             f"tolerance {tol:.0e})")
    return R


def transform(T, name: str = "pose", tol: float = ROTATION_TOL) -> np.ndarray:
    """Rigid transforms ``(..., 4, 4)``: finite, last row ``(0, 0, 0, 1)``, proper rotation."""
    T = as_array(T, name, (4, 4), what="a 4x4 transform or a batch (B, 4, 4)")
    row = T[..., 3, :]
    if T.size and max(float(np.abs(row[..., :3]).max()), float(np.abs(row[..., 3] - 1).max())) > tol:
        bad = first_bad(np.abs(row - (0.0, 0.0, 0.0, 1.0)).max(-1) > tol)
        raise StiffnessError(f"{name}: last row must be (0, 0, 0, 1), got "
                             f"{T[bad + (3,)]}" + (f" at index {bad}" if bad else ""))
    rotation(T[..., :3, :3], f"{name} rotation", tol)
    return T


def matrix6(K, name: str = "K", *, single: bool = False) -> np.ndarray:
    """Finite 6x6 matrices ``(..., 6, 6)`` (exactly ``(6, 6)`` when ``single``)."""
    if single:
        return as_array(K, name, (6, 6), ndim=2, what="one 6x6 matrix (6, 6)")
    return as_array(K, name, (6, 6))


def number(x, name: str, *, positive: bool = False, nonnegative: bool = False,
           unit: str = "") -> float:
    """A finite real scalar (optionally > 0 or ≥ 0)."""
    return real_number(x, name, StiffnessError, positive=positive, nonnegative=nonnegative,
                       unit=unit)


def broadcast(**shapes) -> tuple:
    """The broadcast of the named batch shapes, or an error naming the arguments."""
    try:
        return np.broadcast_shapes(*shapes.values())
    except ValueError:
        desc = ", ".join(f"{k} {v}" for k, v in shapes.items())
        raise StiffnessError(f"{', '.join(shapes)}: batch shapes do not broadcast ({desc})") \
            from None


def reference_frame(frame, T) -> tuple:
    """``(R, p)`` of a result's frame (``r' = R (r − p)``, p in base coordinates, m):
    ``"base"`` or None the base origin and axes; ``"platform"`` the frame of the transforms
    ``T (..., 4, 4)``; or a pair ``(R, p)``, checked.  The caller checks batch shapes."""
    if frame is None or isinstance(frame, str) and frame == "base":
        return np.eye(3), np.zeros(3)
    if isinstance(frame, str):
        if frame != "platform":
            raise StiffnessError(f"frame: expected 'base' (or None), 'platform' or (R, p), got "
                                 f"{frame!r}")
        return np.swapaxes(T[..., :3, :3], -1, -2), T[..., :3, 3]
    try:
        R, p = frame
    except (TypeError, ValueError):
        raise StiffnessError("frame: expected 'base' (or None), 'platform' or (R, p) with R a "
                             f"3x3 rotation and p a 3-vector (m), got {type(frame).__name__}") \
            from None
    return rotation(R, "frame R"), vec3(p, "frame p")

