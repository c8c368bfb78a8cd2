"""Compiled evaluation of piecewise polynomials: the one evaluation path of every
surrogate (the seed's broken line, the spline and the Chebyshev form's Taylor pieces).

A :class:`Pieces` holds, for P pieces, the ascending coefficients of F in the local
coordinate ``t = x − origin[i]`` (``F = Σ_j coef[i, j] t^j``) and how x finds its piece:
equal pieces of width 1/inv_h from ``lo`` (an index by one multiplication), or the
sorted inner breakpoints (a binary search).  One loop over the points computes F, F′
and F″ together by Horner's scheme with derivatives, so a batch costs one pass over x
and one over the output; a Python float takes the same kernel through a scalar entry.

numba compiles the kernels on first use (``cache=True``: once per installation, then
loaded from the cache; the first-call time is reported by ``linkwright bench approx``).
The surrogates import this module when they are first evaluated, so ``import approx``
does not import numba.  The piece search and Horner's scheme come from
:mod:`closure.reduced_kernels`, where the reduced dynamics evaluate the same pieces.
"""
from __future__ import annotations

import numpy as np

from closure import reduced_kernels as _rk
from closure.reduced_kernels import _horner, _piece

#: the piece search and Horner's scheme are those of the reduced dynamics' kernel
#: (:mod:`closure.reduced_kernels`), so a surrogate evaluates to the same numbers in
#: both; their compiled code is in these kernels, whose cache index carries that
#: file's stamp
_njit = _rk.cached_njit(_rk, error_model="python")


@_njit
def _batch(x, lo, inv_h, inner, origin, coef, which, out, x_lo, x_hi):
    """F, F', F'' (``which`` < 0, out (3, n)) or one of them (out (1, n)) at x (n,).
    Returns the index of the first point that is not finite or not in [x_lo, x_hi]
    (nothing evaluated from it on), or −1."""
    P = coef.shape[0]
    for k in range(x.size):
        v = x[k]
        if not (x_lo <= v <= x_hi) or not np.isfinite(v):
            return k
        i = _piece(v, lo, inv_h, inner, P)
        p, d, dd = _horner(coef, i, v - origin[i])
        if which < 0:
            out[0, k] = p
            out[1, k] = d
            out[2, k] = dd
        elif which == 0:
            out[0, k] = p
        elif which == 1:
            out[0, k] = d
        else:
            out[0, k] = dd
    return -1


@_njit
def _scalar(v, lo, inv_h, inner, origin, coef):
    """F, F', F'' at a float v."""
    i = _piece(v, lo, inv_h, inner, coef.shape[0])
    return _horner(coef, i, v - origin[i])


class Pieces:
    """A piecewise polynomial F with its first two derivatives, evaluated compiled.

    Parameters
    ----------
    origin : array_like (P,)
        Each piece's local origin (its left end, or its centre).
    coef : array_like (P, K)
        Ascending coefficients of F in ``t = x − origin[i]`` on each piece.
    inner : array_like (P − 1,), optional
        Sorted inner breakpoints: x belongs to piece ``searchsorted(inner, x, 'right')``.
    lo, inv_h : float, optional
        Equal pieces instead (``inv_h > 0``): piece ``floor((x − lo) · inv_h)``.
    Points before the first or after the last breakpoint take the end pieces.
    """

    __slots__ = ("origin", "coef", "inner", "lo", "inv_h")

    def __init__(self, origin, coef, *, inner=None, lo: float = 0.0, inv_h: float = 0.0):
        self.coef = np.ascontiguousarray(coef, float)
        self.origin = np.ascontiguousarray(origin, float)
        self.inner = np.ascontiguousarray(np.zeros(0) if inner is None else inner, float)
        self.lo, self.inv_h = float(lo), float(inv_h)
        if self.coef.ndim != 2 or self.origin.shape != (self.coef.shape[0],) or (
                inv_h <= 0 and self.inner.shape != (self.coef.shape[0] - 1,)):
            raise ValueError("Pieces: origin (P,), coef (P, K) and inner (P − 1,) or "
                             f"inv_h > 0 expected, got {self.origin.shape}, {self.coef.shape}, "
                             f"{self.inner.shape}, inv_h={inv_h}")

    def __call__(self, x: np.ndarray, which: int | None = None, x_lo: float = -np.inf,
                 x_hi: float = np.inf):
        """``(F, F', F'')`` at x (a float array of any shape), or the one of index
        ``which``: arrays of x's shape (numpy floats for a 0-d x); and the flat index of
        the first point of x that is not finite or outside [x_lo, x_hi] (the results are
        then incomplete), or −1: one pass checks and evaluates."""
        xf = np.ascontiguousarray(x, float).ravel()
        out = np.empty((3 if which is None else 1, xf.size))
        bad = _batch(xf, self.lo, self.inv_h, self.inner, self.origin, self.coef,
                     -1 if which is None else which, out, x_lo, x_hi)
        shape = np.shape(x)                      # [()]: a 0-d x gives numpy floats
        if which is None:
            return tuple(r.reshape(shape)[()] for r in out), bad
        return out[0].reshape(shape)[()], bad

    def scalar(self, v: float):
        """``(F, F', F'')`` at a float v, as floats."""
        return _scalar(v, self.lo, self.inv_h, self.inner, self.origin, self.coef)
