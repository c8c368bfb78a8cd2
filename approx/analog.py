"""Piecewise-linear acceleration analogs (seed 004), integrated twice.

On knots ``a = x_0 < … < x_n = b`` the acceleration analog is approximated by
the broken line through ``y_i`` (formula 2): on interval i,
``F''(x) = k_i x + b_i`` with ``k_i = (y_{i+1} − y_i) / (x_{i+1} − x_i)`` (the
printed "+" is a misprint) and ``b_i = y_i − k_i x_i``; integrating (3),
``F'(x) = k_i x²/2 + b_i x + c_i`` and ``F(x) = k_i x³/6 + b_i x²/2 + c_i x + d_i``
with ``c_i, d_i`` from continuity (4) and ``F(a) = f(a), F'(a) = f'(a)``.  The
seed writes ``c_0 = f'(a), d_0 = f(a)``, true for its ``a = 0``; here the general
``c_0 = f'(a) − A_0(a)``, ``d_0 = f(a) − B_0(a)``.

The error of each interval is formula (1):
``σ_i = sqrt(γ ∫ (F'' − f'')² dx)`` over the interval, by Gauss–Legendre
quadrature (checked against a rule of half the order; adaptive quadrature when
they disagree).
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numpy.polynomial.legendre import leggauss
from scipy.integrate import quad

__all__ = ["PiecewiseAnalog", "ApproxError", "TransferFunction"]


class ApproxError(ValueError):
    """Bad input to an approximation (names the field and what was expected)."""


_GL_HI = leggauss(48)
_GL_LO = leggauss(24)


def _gl(func, x0, x1, rule):
    """Gauss–Legendre integrals of ``func`` over many intervals at once."""
    t, w = rule
    x0, x1 = np.asarray(x0, float), np.asarray(x1, float)
    h = 0.5 * (x1 - x0)
    pts = (0.5 * (x0 + x1))[..., None] + h[..., None] * t
    return np.sum(func(pts, x0[..., None], x1[..., None]) * w, -1) * h


def interval_sigma(d2f, x0, x1, y0, y1, gamma):
    """σ of intervals ``[x0, x1]`` whose chord runs from ``y0`` to ``y1`` (vectorised)."""
    x0, x1, y0, y1 = np.broadcast_arrays(*(np.asarray(v, float) for v in (x0, x1, y0, y1)))

    def integrand(x, a, b):
        s = (x - a) / (b - a)
        chord = y0[..., None] + s * (y1 - y0)[..., None]
        return (chord - d2f(x)) ** 2

    hi = _gl(integrand, x0, x1, _GL_HI)
    lo = _gl(integrand, x0, x1, _GL_LO)
    scale = (np.maximum(np.abs(y0), np.abs(y1)) ** 2 + 1e-300) * np.abs(x1 - x0)
    atol = 1e-13 * scale
    bad = np.abs(hi - lo) > 1e-8 * np.abs(hi) + atol
    if np.any(bad):
        for idx in zip(*np.nonzero(np.atleast_1d(bad))):
            a_, b_, ya, yb = (np.atleast_1d(v)[idx] for v in (x0, x1, y0, y1))
            g = lambda x: (ya + (x - a_) / (b_ - a_) * (yb - ya) - float(np.asarray(d2f(np.array([x])))[0])) ** 2
            val, _ = quad(g, a_, b_, limit=400, epsabs=float(np.atleast_1d(atol)[idx]),
                          epsrel=1e-10)
            np.atleast_1d(hi)[idx] = val
    return np.sqrt(gamma * np.maximum(hi, 0.0))


class TransferFunction(ABC):
    """Interface shared by exact and surrogate transfer functions of a 1-DOF loop:
    ``position(x)``, ``velocity(x)`` (first analog) and ``acceleration(x)`` (second
    analog), each vectorised over ``x``."""

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
        ``q̈_out = f'(x) ẍ + f''(x) ẋ²``; ``mass_moment`` is ``m L²`` (kg·m²)."""
        x, xd, xdd = (np.asarray(v, float) for v in (x, xd, xdd))
        psi = self.velocity(x)
        return psi * mass_moment * (psi * xdd + self.acceleration(x) * xd ** 2)


@dataclass
class PiecewiseAnalog(TransferFunction):
    """A twice-integrated piecewise-linear acceleration analog.

    Attributes
    ----------
    knots : numpy.ndarray (n+1,)
    y : numpy.ndarray (n+1,)
        ``F''`` at the knots (= ``f''(x_i)`` for interpolation).
    k, b, c, d : numpy.ndarray (n,)
        Coefficients of formula (3) per interval (global powers of x).
    sigma : numpy.ndarray (n,)
        Error (1) of each interval.
    gamma : float
        The weight used in (1); ``gamma_rule`` says where it came from.
    extrapolate : bool
        Evaluate outside ``[a, b]`` with the end intervals' cubics instead of raising.
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

    @classmethod
    def from_values(cls, knots, y, f_a, df_a, d2f=None, gamma=1.0, **kw) -> "PiecewiseAnalog":
        """Build the coefficients (2)–(4) from knot values ``y`` of ``F''``."""
        x = np.asarray(knots, float)
        y = np.asarray(y, float)
        k = np.diff(y) / np.diff(x)
        b = y[:-1] - k * x[:-1]
        n = k.size
        c = np.empty(n)
        d = np.empty(n)
        A = lambda i, t: k[i] * t ** 2 / 2 + b[i] * t
        Bf = lambda i, t: k[i] * t ** 3 / 6 + b[i] * t ** 2 / 2 + c[i] * t
        c[0] = df_a - A(0, x[0])
        d[0] = 0.0
        d[0] = f_a - Bf(0, x[0])
        for i in range(1, n):                     # continuity of F' and F at x_i, formula (4)
            c[i] = (A(i - 1, x[i]) + c[i - 1]) - A(i, x[i])
            d[i] = (Bf(i - 1, x[i]) + d[i - 1]) - (k[i] * x[i] ** 3 / 6 + b[i] * x[i] ** 2 / 2
                                                   + c[i] * x[i])
        sigma = interval_sigma(d2f, x[:-1], x[1:], y[:-1], y[1:], gamma) if d2f is not None \
            else np.full(n, np.nan)
        return cls(x, y, k, b, c, d, sigma, float(gamma), **kw)

    # ---------------------------------------------------------------- evaluation
    @property
    def a(self) -> float:
        return float(self.knots[0])

    @property
    def b_end(self) -> float:
        return float(self.knots[-1])

    @property
    def n(self) -> int:
        """Number of intervals."""
        return self.k.size

    def _interval(self, x):
        x = np.asarray(x, dtype=float)
        if not np.all(np.isfinite(x)):
            raise ApproxError("x: contains non-finite values")
        if not self.extrapolate:
            lo, hi = self.knots[0], self.knots[-1]
            out = (x < lo) | (x > hi)
            if np.any(out):
                bad = x[out].ravel()[0]
                raise ApproxError(f"x = {float(bad)!r} outside [{lo}, {hi}]; set extrapolate=True to "
                                  "evaluate the end cubics beyond the range")
        # interval i holds [x_i, x_{i+1}); the last interval is closed at b
        i = np.clip(np.searchsorted(self.knots, x, side="right") - 1, 0, self.n - 1)
        return x, i

    def position(self, x):
        """F(x), vectorised (Horner)."""
        x, i = self._interval(x)
        return ((self.k[i] / 6 * x + self.b[i] / 2) * x + self.c[i]) * x + self.d[i]

    def velocity(self, x):
        """F'(x): the first analog."""
        x, i = self._interval(x)
        return (self.k[i] / 2 * x + self.b[i]) * x + self.c[i]

    def acceleration(self, x):
        """F''(x): the second (acceleration) analog."""
        x, i = self._interval(x)
        return self.k[i] * x + self.b[i]

    @property
    def table(self) -> pd.DataFrame:
        """One row per interval: ``x0, x1, k, b, c, d, sigma``."""
        return pd.DataFrame({"x0": self.knots[:-1], "x1": self.knots[1:], "k": self.k,
                             "b": self.b, "c": self.c, "d": self.d, "sigma": self.sigma})

    def errors(self, f, df, d2f, samples: int = 2001) -> dict:
        """Largest |F − f|, |F' − f'|, |F'' − f''| over a uniform sample of [a, b]."""
        x = np.linspace(self.a, self.b_end, samples)
        return {"max_abs_F": float(np.max(np.abs(self.position(x) - f(x)))),
                "max_abs_dF": float(np.max(np.abs(self.velocity(x) - df(x)))),
                "max_abs_d2F": float(np.max(np.abs(self.acceleration(x) - d2f(x))))}
