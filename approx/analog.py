"""Piecewise-linear acceleration analogs (seed 004), integrated twice.

On knots ``a = x_0 < … < x_n = b`` the acceleration analog is approximated by
the broken line through ``y_i`` (formula 2): on interval i,
``F''(x) = k_i x + b_i`` with ``k_i = (y_{i+1} − y_i) / (x_{i+1} − x_i)`` (the
printed "+" is a misprint) and ``b_i = y_i − k_i x_i``; integrating (3),
``F'(x) = k_i x²/2 + b_i x + c_i`` and ``F(x) = k_i x³/6 + b_i x²/2 + c_i x + d_i``
with ``c_i, d_i`` from continuity (4) and ``F(a) = f(a), F'(a) = f'(a)``.  The
seed writes ``c_0 = f'(a), d_0 = f(a)``, true for its ``a = 0``; here the general
``c_0 = f'(a) − A_0(a)``, ``d_0 = f(a) − B_0(a)``.  These global coefficients
are what the table shows; evaluation uses the same cubics written about each
interval's left knot (``t = x − x_i``), so that results do not depend on where
the range lies (a fit on [1e6, 1e6 + 1] is as accurate as on [0, 1]).

The error of each interval is formula (1):
``σ_i = sqrt(γ ∫ (F'' − f'')² dx)`` over the interval, by Gauss–Legendre
quadrature (checked against a rule of half the order; adaptive quadrature when
they disagree).
"""
from __future__ import annotations

import numbers
from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numpy.polynomial.legendre import leggauss
from scipy.integrate import quad

__all__ = ["PiecewiseAnalog", "ApproxError", "TransferFunction", "interval_sigma",
           "sigma_of_intervals", "as_real", "as_real_array", "as_points", "as_knots", "as_count",
           "as_positive"]


class ApproxError(ValueError):
    """Bad input to an approximation (names the field and what was expected)."""


def as_real(value, name: str) -> float:
    """``value`` as a finite float, or :class:`ApproxError` naming ``name``.

    Accepts Python and numpy real scalars and 0-d real arrays; rejects booleans,
    complex numbers, strings, None, arrays of other shapes, NaN and ±inf.
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.ndarray)):
        raise ApproxError(f"{name}: expected a finite real number, got {value!r} "
                          f"({type(value).__name__})")
    if isinstance(value, np.ndarray):
        if value.shape != () or value.dtype.kind not in "iuf":
            raise ApproxError(f"{name}: expected a finite real number, got an array of shape "
                              f"{value.shape} and dtype {value.dtype}")
    try:
        v = float(value)
    except OverflowError:
        v = np.inf
    if not np.isfinite(v):
        raise ApproxError(f"{name}: expected a finite real number, got {v}")
    return v


def as_real_array(x, name: str = "x") -> np.ndarray:
    """``x`` as a float array of any shape, or :class:`ApproxError` naming ``name``
    (non-numeric or complex values); finiteness is not checked."""
    try:
        arr = np.asarray(x)
    except (TypeError, ValueError, OverflowError) as e:     # ragged sequences, huge ints
        raise ApproxError(f"{name}: expected real numbers (a float or an array), got "
                          f"{type(x).__name__} ({e})") from None
    if arr.dtype.kind not in "iuf":
        raise ApproxError(f"{name}: expected real numbers (a float or an array), got dtype "
                          f"{arr.dtype} ({type(x).__name__})")
    return arr.astype(float, copy=False)


def _not_finite(name, bad):
    return ApproxError(f"{name}: contains non-finite values ({bad}); expected finite numbers")


def as_points(x, name: str = "x") -> np.ndarray:
    """``x`` as a float array of any shape with finite entries, or :class:`ApproxError`
    naming ``name`` (non-numeric, complex or non-finite values)."""
    arr = as_real_array(x, name)
    if not np.all(np.isfinite(arr)):
        raise _not_finite(name, arr[~np.isfinite(arr)].ravel()[0])
    return arr


def as_knots(knots, name: str = "knots") -> np.ndarray:
    """Checked knots: a strictly increasing 1-D array of at least two finite values."""
    x = as_points(knots, name)
    if x.ndim != 1 or x.size < 2:
        raise ApproxError(f"{name}: expected a 1-D array of at least two values, got shape "
                          f"{x.shape}")
    if np.any(np.diff(x) <= 0):
        raise ApproxError(f"{name}: must be strictly increasing")
    return x


def as_count(n, name: str, low: int, high: int) -> int:
    """An integer count in [low, high] (floats equal to integers accepted)."""
    if isinstance(n, (bool, np.bool_)):
        raise ApproxError(f"{name}: expected an integer, got {bool(n)}")
    v = as_real(n, name)
    if v != int(v):
        raise ApproxError(f"{name}: expected an integer, got {v!r}")
    if not low <= v <= high:
        raise ApproxError(f"{name}: expected {low} ≤ {name} ≤ {high}, got {int(v)}"
                          + (f" ({high} is the documented maximum; σ falls like n^(-5/2) for "
                             f"smooth f'', so n = {high} already gives about "
                             f"{float(high) ** -2.5:.0e} of the one-interval σ)"
                             if v > high and name == "n" else ""))
    return int(v)


def as_positive(value, name: str, what: str = "a positive number", *,
                zero: bool = False) -> float:
    """``value`` as a finite float > 0 (≥ 0 with ``zero``), or ApproxError naming ``name``."""
    v = as_real(value, name)
    if v < 0 or (v == 0 and not zero):
        raise ApproxError(f"{name}: expected {what}, got {v}")
    return v


_GL_HI = leggauss(48)
_GL_LO = leggauss(24)
_NODES = np.concatenate([_GL_HI[0], _GL_LO[0]])        # both rules, evaluated in one call
_NHI = _GL_HI[0].size


def _sigma2(d2f, x0, x1, y0=None, y1=None):
    """``∫ (chord − f'')² dx`` over intervals ``[x0, x1]`` (any broadcast shape), with one
    call of ``d2f`` for the ends (when ``y0``/``y1`` are None) and both Gauss–Legendre
    rules; returns ``(integral, y0, y1)``.

    The chord at a node uses the node's own (rounded) abscissa, so the integrand is
    evaluated exactly where ``d2f`` is.  When the 48- and 24-point rules disagree the
    interval is integrated adaptively (``scipy.integrate.quad``).
    """
    x0, x1 = np.broadcast_arrays(np.asarray(x0, float), np.asarray(x1, float))
    h = 0.5 * (x1 - x0)
    pts = (0.5 * (x0 + x1))[..., None] + h[..., None] * _NODES
    ends = [v[..., None] for v, y in ((x0, y0), (x1, y1)) if y is None]
    v = d2f(np.concatenate(ends + [pts], -1)) if ends else d2f(pts)
    k = 0
    if y0 is None:
        y0, k = v[..., 0], k + 1
    if y1 is None:
        y1, k = v[..., k], k + 1
    y0, y1 = np.broadcast_arrays(np.asarray(y0, float), np.asarray(y1, float))
    fv = v[..., k:]
    s = (pts - x0[..., None]) / (x1 - x0)[..., None]
    e2 = (y0[..., None] + s * (y1 - y0)[..., None] - fv) ** 2
    hi = np.sum(e2[..., :_NHI] * _GL_HI[1], -1) * h
    lo = np.sum(e2[..., _NHI:] * _GL_LO[1], -1) * h
    scale = (np.maximum(np.abs(y0), np.abs(y1)) ** 2 + 1e-300) * np.abs(x1 - x0)
    atol = 1e-13 * scale
    bad = np.abs(hi - lo) > 1e-8 * np.abs(hi) + atol
    if np.any(bad):
        hi = np.array(hi, ndmin=1)
        for idx in zip(*np.nonzero(np.atleast_1d(bad))):
            a_, b_, ya, yb = (float(np.atleast_1d(w)[idx]) for w in (x0, x1, y0, y1))
            g = lambda x: (ya + (x - a_) / (b_ - a_) * (yb - ya)
                           - float(np.asarray(d2f(np.array([x])))[0])) ** 2
            hi[idx], _ = quad(g, a_, b_, limit=400, epsabs=float(np.atleast_1d(atol)[idx]),
                              epsrel=1e-10)
        hi = hi.reshape(np.shape(lo))
    return np.maximum(hi, 0.0), y0, y1


_GL16 = leggauss(16)


def _error_estimate(F2, d2f, breaks):
    """Error estimate of a surrogate from f'' alone: ``F2`` (its second analog) against
    ``d2f`` at 16 Gauss–Legendre nodes on each piece of ``breaks``.  With e = F − f and
    e(a) = e'(a) = 0: ``bound_dF`` = ∫|e''| ≥ max |e'|, ``bound_F`` = ∫(b − s)|e''(s)| ds
    ≥ max |e| (the integrals by the quadrature, times 1 + 1e-6), ``max_d2F`` the largest |e''| at the
    nodes (an estimate)."""
    x0, x1 = breaks[:-1], breaks[1:]
    h = 0.5 * (x1 - x0)
    pts = (0.5 * (x0 + x1))[:, None] + h[:, None] * _GL16[0]
    e = np.abs(F2(pts) - d2f(pts))
    w = h[:, None] * _GL16[1]
    b = breaks[-1]
    margin = 1 + 1e-6                       # for the quadrature of |e''| (kinks at its zeros)
    return {"max_d2F": float(e.max()), "bound_dF": margin * float(np.sum(w * e)),
            "bound_F": margin * float(np.sum(w * e * (b - pts)))}


def interval_sigma(d2f, x0, x1, y0, y1, gamma):
    """σ of intervals ``[x0, x1]`` whose chord runs from ``y0`` to ``y1`` (vectorised):
    formula (1), ``σ = sqrt(γ ∫ (chord − f'')² dx)``."""
    x0, x1, y0, y1 = np.broadcast_arrays(*(np.asarray(v, float) for v in (x0, x1, y0, y1)))
    return np.sqrt(gamma * _sigma2(d2f, x0, x1, y0, y1)[0])


def sigma_of_intervals(d2f, x0, x1, gamma):
    """σ of intervals ``[x0, x1]`` whose chord interpolates f'' at both ends; the ends
    are evaluated in the same call of ``d2f`` as the quadrature nodes.  Returns
    ``(sigma, f''(x0), f''(x1))``."""
    i2, y0, y1 = _sigma2(d2f, x0, x1)
    return np.sqrt(gamma * i2), y0, y1


class TransferFunction(ABC):
    """Interface shared by exact and surrogate transfer functions of a 1-DOF loop:
    ``position(x)``, ``velocity(x)`` (first analog) and ``acceleration(x)`` (second
    analog), each vectorised over ``x`` of any shape (the result has the shape of ``x``)."""

    @abstractmethod
    def position(self, x):
        """The output f(x)."""

    @abstractmethod
    def velocity(self, x):
        """The first analog f'(x)."""

    @abstractmethod
    def acceleration(self, x):
        """The second analog f''(x)."""

    def force(self, x, xd, xdd, mass_moment):
        """Drive force of seed 004 (5): ``Q = Ψ · I · q̈_out`` with ``Ψ = f'(x)`` and
        ``q̈_out = f'(x) ẍ + f''(x) ẋ²``.

        Parameters
        ----------
        x, xd, xdd : array_like, broadcast together
            Input coordinate, its rate and its acceleration (m, m/s, m/s² for a slide).
        mass_moment : float
            ``m L²`` of the output link (kg·m²).

        Returns
        -------
        numpy.ndarray
            Q (N for a slide input), of the broadcast shape.
        """
        x, xd, xdd = (as_points(v, name) for v, name in ((x, "x"), (xd, "xd"), (xdd, "xdd")))
        mass_moment = as_positive(mass_moment, "mass_moment", "a moment of inertia m L² ≥ 0 "
                                  "(kg·m²)", zero=True)
        try:
            x, xd, xdd = np.broadcast_arrays(x, xd, xdd)
        except ValueError:
            raise ApproxError(f"x, xd, xdd: shapes {x.shape}, {xd.shape}, {xdd.shape} do not "
                              "broadcast together") from None
        psi = self.velocity(x)
        return psi * mass_moment * (psi * xdd + self.acceleration(x) * xd ** 2)


class _Pieces:
    """The evaluation shared by the piecewise surrogates: ``position``, ``velocity``,
    ``acceleration`` and ``all`` through one compiled kernel (:mod:`approx.kernels`, built
    on the first evaluation by :meth:`_make_pieces`), a Python float by its scalar entry.
    Subclasses hold ``a``, ``b_end`` and ``extrapolate``."""

    _pcs = None

    def _make_pieces(self):
        """The :class:`approx.kernels.Pieces` of F, or False where there is none."""
        raise NotImplementedError

    def _pieces(self):
        if self._pcs is None:
            self._pcs = self._make_pieces()
        return self._pcs

    def _range(self):
        """The x accepted: [a, b], or every finite x when extrapolating."""
        return (-np.inf, np.inf) if self.extrapolate else (self.a, self.b_end)

    def _refuse(self, v):
        """The error for a refused x = v (not finite, or outside the range)."""
        if not np.isfinite(v):
            return _not_finite("x", v)
        return ApproxError(f"x = {float(v)!r} outside [{self.a}, {self.b_end}]; set "
                           "extrapolate=True to evaluate beyond the range")

    @staticmethod
    def _scalar(x):
        """x as a float when it is a plain Python or numpy float/int (not bool), else None."""
        if type(x) in (float, int, np.float64):
            v = float(x)
            if v == v and v not in (np.inf, -np.inf):
                return v
        return None

    def _eval(self, x, which):
        v = self._scalar(x)
        if v is not None and (self.extrapolate or self.a <= v <= self.b_end):
            r = self._pieces().scalar(v)
            return r if which is None else r[which]
        x = as_real_array(x, "x")
        out, bad = self._pieces()(x, which, *self._range())
        if bad >= 0:
            raise self._refuse(x.flat[bad])
        return out

    def kernel_form(self) -> dict:
        """This surrogate as the polynomial pieces a compiled model evaluates
        (:func:`closure.reduced_kernels.pack_transfer`, used by
        :class:`closure.reduced.ReducedDynamics`): ``pieces`` (origin (P,), coef (P, K),
        inner (P − 1,), lo, inv_h: :class:`approx.kernels.Pieces`) on every x, and
        ``accept``: the x it evaluates ([a, b], or every finite x when extrapolating).
        The same numbers as :meth:`all`, which evaluates the same pieces by the same
        piece search and Horner scheme."""
        pcs = self._pieces()
        return {"pieces": (pcs.origin, pcs.coef, pcs.inner, pcs.lo, pcs.inv_h),
                "accept": self._range()}

    def position(self, x):
        """F(x), vectorised over ``x`` of any shape (a float for a float)."""
        return self._eval(x, 0)

    def velocity(self, x):
        """F'(x): the first analog."""
        return self._eval(x, 1)

    def acceleration(self, x):
        """F''(x): the second (acceleration) analog."""
        return self._eval(x, 2)

    def all(self, x):
        """``(F, F', F'')`` at x in one pass."""
        return self._eval(x, None)


@dataclass(repr=False)
class PiecewiseAnalog(_Pieces, TransferFunction):
    """A twice-integrated piecewise-linear acceleration analog.

    On interval i, ``[x_i, x_{i+1}]``, with the local coordinate ``t = x − x_i``:

        F''(x) = y_i + k_i t
        F'(x)  = F'_i + y_i t + k_i t²/2
        F(x)   = F_i + F'_i t + y_i t²/2 + k_i t³/6

    which is the seed's cubic (3) written about the interval's left knot.  The
    evaluation uses these local forms (accurate far from x = 0: a cubic in global
    powers of x loses every digit at x ~ 1e6); the global coefficients ``k, b, c,
    d`` are kept for the table and for comparison with the seed.

    Attributes
    ----------
    knots : numpy.ndarray (n+1,)
    y : numpy.ndarray (n+1,)
        ``F''`` at the knots (= ``f''(x_i)`` for interpolation).
    k, b, c, d : numpy.ndarray (n,)
        Coefficients of formula (3) per interval (global powers of x).
    sigma : numpy.ndarray (n,)
        Error (1) of each interval.
    error : dict
        With f'' known: ``max_d2F``, ``bound_dF`` ≥ max |F' − f'|, ``bound_F`` ≥ max |F − f|
        (the estimate every surrogate carries; see :mod:`approx.surrogate`).
    gamma : float
        The weight used in (1); ``gamma_rule`` says where it came from.
    extrapolate : bool
        Evaluate outside ``[a, b]`` with the end intervals' cubics instead of raising.
    fk, dfk : numpy.ndarray (n+1,)
        ``F`` and ``F'`` at the knots (the local coefficients).  Built by
        :meth:`from_values`; derived from ``k, b, c, d`` when the analog is
        constructed from global coefficients.
    """

    knots: np.ndarray
    y: np.ndarray
    k: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray
    sigma: np.ndarray
    gamma: float
    gamma_rule: str = ""
    method: str = "interpolation"
    extrapolate: bool = False
    info: dict = field(default_factory=dict)
    fk: np.ndarray | None = None
    dfk: np.ndarray | None = None
    error: dict = field(default_factory=dict)

    def __repr__(self) -> str:
        n = len(self.knots) - 1
        return (f"PiecewiseAnalog({n} interval{'s' if n != 1 else ''} on "
                f"[{self.knots[0]:.6g}, {self.knots[-1]:.6g}], {self.method}, largest error "
                f"σ = {np.max(self.sigma):.3g}, γ = {self.gamma:.3g} ({self.gamma_rule or 'given'}))")

    def __post_init__(self):
        x = self.knots = np.asarray(self.knots, float)
        if self.fk is None or self.dfk is None:       # from global coefficients (3)
            k, b, c, d = (np.asarray(v, float) for v in (self.k, self.b, self.c, self.d))
            xl = np.r_[x[:-1], x[-1]]
            i = np.r_[np.arange(k.size), k.size - 1]
            self.dfk = (k[i] / 2 * xl + b[i]) * xl + c[i]
            self.fk = ((k[i] / 6 * xl + b[i] / 2) * xl + c[i]) * xl + d[i]

    @classmethod
    def from_values(cls, knots, y, f_a, df_a, d2f=None, gamma=1.0, **kw) -> "PiecewiseAnalog":
        """Build the coefficients (2)–(4) from knot values ``y`` of ``F''``.

        Parameters
        ----------
        knots : array_like (n+1,)
            Strictly increasing.
        y : array_like (n+1,)
            ``F''`` at the knots.
        f_a, df_a : float
            ``F(a) = f(a)`` and ``F'(a) = f'(a)`` at the first knot.
        d2f : callable, optional
            The exact f'' for σ (formula 1); σ is NaN without it.
        gamma : float
            Weight of (1).

        Continuity (4) is built in: ``F'`` and ``F`` at each knot accumulate the exact
        integrals of the broken line over the intervals before it (vectorised; no
        recursion in global powers of x).
        """
        x = as_knots(knots)
        y = as_points(y, "y")
        if y.shape != x.shape:
            raise ApproxError(f"y: expected one value per knot (knots has shape {x.shape}), got "
                              f"shape {y.shape}")
        f_a, df_a = as_real(f_a, "f_a"), as_real(df_a, "df_a")
        gamma = as_positive(gamma, "gamma", "a positive weight")
        if d2f is not None and not callable(d2f):
            raise ApproxError(f"d2f: expected a callable d2f(x) or None, got {type(d2f).__name__}")
        h = np.diff(x)
        k = np.diff(y) / h
        n = k.size
        # F' and F at the knots: exact integrals of the broken line, interval by interval
        dfk = df_a + np.r_[0.0, np.cumsum(h * (y[:-1] + y[1:]) / 2)]
        fk = f_a + np.r_[0.0, np.cumsum(h * dfk[:-1] + h * h * (2 * y[:-1] + y[1:]) / 6)]
        # global coefficients of (3) for the table: F'' = k x + b, F' = k x²/2 + b x + c,
        # F = k x³/6 + b x²/2 + c x + d, equal to the local forms at x_i
        xi = x[:-1]
        b = y[:-1] - k * xi
        c = dfk[:-1] - (k * xi / 2 + b) * xi
        d = fk[:-1] - ((k * xi / 6 + b / 2) * xi + c) * xi
        sigma = interval_sigma(d2f, x[:-1], x[1:], y[:-1], y[1:], gamma) if d2f is not None \
            else np.full(n, np.nan)
        an = cls(x, y, k, b, c, d, sigma, float(gamma), fk=fk, dfk=dfk, **kw)
        if d2f is not None:
            ext, an.extrapolate = an.extrapolate, True
            an.error = _error_estimate(an.acceleration, d2f, x)
            an.extrapolate = ext
        return an

    # ---------------------------------------------------------------- evaluation
    @property
    def a(self) -> float:
        """First knot (start of the range)."""
        return float(self.knots[0])

    @property
    def b_end(self) -> float:
        """Last knot (end of the range)."""
        return float(self.knots[-1])

    @property
    def n(self) -> int:
        """Number of intervals."""
        return self.k.size

    def _make_pieces(self):
        # interval i holds [x_i, x_{i+1}); the last one is closed at b (the end intervals
        # extend beyond a and b when extrapolating)
        from .kernels import Pieces
        n = self.n
        coef = np.stack([self.fk[:n], self.dfk[:n], np.asarray(self.y, float)[:n] / 2,
                         np.asarray(self.k, float) / 6], 1)
        return Pieces(self.knots[:-1], coef, inner=self.knots[1:-1])

    @property
    def table(self) -> pd.DataFrame:
        """One row per interval: ``x0, x1, k, b, c, d, sigma`` (global coefficients of (3))."""
        return pd.DataFrame({"x0": self.knots[:-1], "x1": self.knots[1:], "k": self.k,
                             "b": self.b, "c": self.c, "d": self.d, "sigma": self.sigma})

    def errors(self, f, df, d2f, samples: int = 2001) -> dict:
        """Largest |F − f|, |F' − f'|, |F'' − f''| over a uniform sample of [a, b]."""
        from .fit import _checked
        f, df, d2f = _checked(f, "f"), _checked(df, "df"), _checked(d2f, "d2f")
        x = np.linspace(self.a, self.b_end, as_count(samples, "samples", 2, 10 ** 8))
        return {"max_abs_F": float(np.max(np.abs(self.position(x) - f(x)))),
                "max_abs_dF": float(np.max(np.abs(self.velocity(x) - df(x)))),
                "max_abs_d2F": float(np.max(np.abs(self.acceleration(x) - d2f(x))))}
