"""Input checks and the task's length scale, shared by the synthesis package.

Every public function converts its arguments here, so that bad input (wrong
type, wrong shape, NaN or inf, a matrix that is not a rigid transform) raises
:class:`SynthesisError` naming the argument, what was expected and what was
given, never a numpy traceback.  :func:`task_scale` gives the sizes that make
the package's tolerances relative to the task (invariant under rigid motion
and change of length unit).
"""
from __future__ import annotations


import numpy as np

from closure.checks import real_array, real_number

from .errors import SynthesisError

__all__ = ["array", "vec3", "unit", "number", "integer", "transform", "screw", "screws", "line",
           "task_scale", "task_scales", "ROTATION_TOL"]

#: tolerance of the orthonormality and last-row checks of transforms (dimensionless)
ROTATION_TOL = 1e-9


def _shape_text(shape) -> str:
    dims = ", ".join("n" if d is None else str(d) for d in shape)
    return f"({dims},)" if len(shape) == 1 else f"({dims})"


def array(x, name: str, shape: tuple | None, *, what: str | None = None) -> np.ndarray:
    """``x`` as a finite float array of ``shape`` (``None`` in a place: any size there;
    ``shape=None``: any shape).

    Raises
    ------
    SynthesisError
        Naming ``name``, the expected shape and what was given.
    """
    expect = what or (f"shape {_shape_text(shape)}" if shape is not None else "an array")
    a = real_array(x, name, SynthesisError, expect)
    if shape is not None and (a.ndim != len(shape) or
                              any(d is not None and a.shape[i] != d for i, d in enumerate(shape))):
        raise SynthesisError(f"{name}: expected {expect}, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        bad = tuple(int(i) for i in np.argwhere(~np.isfinite(a))[0])
        raise SynthesisError(f"{name}: expected finite values, got {a[bad]} at index {bad}")
    return a


def vec3(x, name: str) -> np.ndarray:
    """A finite 3-vector ``(3,)``."""
    return array(x, name, (3,), what="a finite 3-vector (3,)")


def unit(x, name: str, tol: float = 1e-6) -> np.ndarray:
    """A direction of unit length to ``tol``, returned normalised."""
    v = vec3(x, name)
    n = float(np.linalg.norm(v))
    if n == 0:
        raise SynthesisError(f"{name}: zero vector, expected a unit direction")
    if abs(n - 1) > tol:
        raise SynthesisError(f"{name}: length {n:.6g} is not 1 within {tol:g}; expected a unit "
                             "direction (normalise it first)")
    return v / n


def number(x, name: str, *, positive: bool = False, unit_: str = "") -> float:
    """A finite real scalar (optionally > 0)."""
    return real_number(x, name, SynthesisError, positive=positive, unit=unit_)


def integer(x, name: str, *, low: int = 0) -> int:
    """An integer ``≥ low``."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, np.integer)) or x < low:
        raise SynthesisError(f"{name}: expected an integer ≥ {low}, got {x!r}")
    return int(x)


def transform(T, name: str = "T", *, batch: bool = False, tol: float = ROTATION_TOL) -> np.ndarray:
    """A rigid transform ``(4, 4)`` (or a batch ``(n, 4, 4)`` when ``batch``): finite, last
    row ``(0, 0, 0, 1)`` and a proper rotation block, to ``tol``."""
    shape = (None, 4, 4) if batch else (4, 4)
    T = array(T, name, shape, what="a finite 4x4 rigid transform"
              + (" batch (n, 4, 4)" if batch else " (4, 4)"))
    Tb = T.reshape(-1, 4, 4)
    row = np.abs(Tb[:, 3] - (0.0, 0.0, 0.0, 1.0)).max(-1)
    if row.size and row.max() > tol:
        i = int(np.argmax(row))
        raise SynthesisError(f"{name}: last row must be (0, 0, 0, 1), got {Tb[i, 3]}"
                             + (f" at index {i}" if batch else ""))
    R = Tb[:, :3, :3]
    err = np.abs(R @ np.swapaxes(R, -1, -2) - np.eye(3)).max((-2, -1)) if R.size else np.zeros(0)
    det = np.linalg.det(R) if R.size else np.ones(0)
    bad = (err > tol) | (det < 0)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise SynthesisError(f"{name}: rotation block is not a proper rotation (|R Rᵀ − I| = "
                             f"{err[i]:.1e}, det = {det[i]:.3g}, tolerance {tol:.0e})"
                             + (f" at index {i}" if batch else ""))
    return T


def screw(s, name: str):
    """``s`` after checking it is a :class:`Screw`."""
    from .screw import Screw
    if not isinstance(s, Screw):
        raise SynthesisError(f"{name}: expected a Screw, got {type(s).__name__}")
    return s


def screws(seq, name: str = "screws", n: int | None = None) -> list:
    """A list of :class:`Screw` (exactly ``n`` when given)."""
    from .screw import Screw
    if isinstance(seq, (str, bytes, Screw)) or not hasattr(seq, "__iter__"):
        raise SynthesisError(f"{name}: expected a sequence of Screw, got {type(seq).__name__}")
    out = list(seq)
    if n is not None and len(out) != n:
        raise SynthesisError(f"{name}: expected {n} screws, got {len(out)}")
    return [screw(s, f"{name}[{k}]") for k, s in enumerate(out)]


def line(ln, name: str):
    """``ln`` after checking it is a :class:`Line`."""
    from .screw import Line
    if not isinstance(ln, Line):
        raise SynthesisError(f"{name}: expected a Line, got {type(ln).__name__}")
    return ln


def task_scale(transforms, axes=(), points=()) -> tuple[np.ndarray, float, float]:
    """Centre, extent and reach of a synthesis task (lengths in the task's unit).

    Parameters
    ----------
    transforms : array_like, shape (n, 4, 4)
        The positions' displacements (position 1, the identity, may be included).
    axes, points : array_like, shape (m, 3)
        Unit directions and points of the task's screw axes.

    Returns
    -------
    centre : numpy.ndarray (3,)
        The point nearest to all the axes in the least-squares sense (in directions
        where that is undetermined, e.g. along parallel axes, the mean of the axis
        points): it moves with the task under a rigid motion.
    extent : float
        The task's own size about ``centre``: the largest translation of the
        displacements written about the centre and the largest distance of an axis
        from it.  Unchanged by a rigid motion of the whole task, multiplied by
        s when lengths are; the package normalises the task by it.
    reach : float
        ``max(extent, |centre|)``: the size of the coordinates, which sets their
        round-off (``reach · ε``); residuals and round-off tolerances are relative to it.

    A task without any length (pure rotations about axes through the origin) is
    scale-free: both sizes are then 1.
    """
    T = np.asarray(transforms, float).reshape(1, -1, 4, 4)
    U = np.asarray(axes, float).reshape(1, -1, 3)
    P = np.asarray(points, float).reshape(1, -1, 3)
    c, extent, reach = task_scales(T, U, P)
    return c[0], float(extent[0]), float(reach[0])


def task_scales(transforms, axes, points) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`task_scale` of S tasks at once.

    Parameters
    ----------
    transforms : numpy.ndarray, shape (S, n, 4, 4)
        Each task's displacements.
    axes, points : numpy.ndarray, shape (S, k, 3)
        Unit directions and points of each task's screw axes (k may be 0).

    Returns
    -------
    centre : numpy.ndarray (S, 3)
    extent, reach : numpy.ndarray (S,)
    """
    T, U, P = transforms, axes, points
    S = T.shape[0]
    c = P.mean(1) if P.shape[1] else np.zeros((S, 3))
    if U.shape[1]:
        Q = np.eye(3) - U[..., :, None] * U[..., None, :]               # projectors ⊥ axes
        b = np.einsum("snij,snj->si", Q, P - c[:, None])
        A = np.linalg.pinv(Q.sum(1), rcond=1e-8, hermitian=True)
        c = c + np.einsum("sij,sj->si", A, b)
        # distances of the axes (lines, whatever point the user gave) from the centre
        d = np.einsum("snij,snj->sni", Q, P - c[:, None])
    else:
        d = P - c[:, None]
    # translations of C T C⁻¹ with C the shift by −c: t + R c − c
    t = T[..., :3, 3] + np.einsum("snij,sj->sni", T[..., :3, :3], c) - c[:, None]
    extent = np.maximum(np.linalg.norm(t, axis=2).max(1, initial=0.0),
                        np.linalg.norm(d, axis=2).max(1, initial=0.0))
    reach = np.maximum(extent, np.linalg.norm(c, axis=1))
    zero = extent == 0
    extent = np.where(zero, np.where(reach > 0, reach, 1.0), extent)
    return c, extent, np.where(zero, extent, reach)
