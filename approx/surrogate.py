"""A family of surrogate transfer functions with one interface (issue 16).

All three kinds are built from the same data as seed 004's analog — f'' of the loop
plus the start values f(a), f'(a) — and integrated twice exactly:

``linear``     the seed's broken line on f'' (:class:`~approx.analog.PiecewiseAnalog`,
               unchanged), cubic pieces of F;
``spline``     a cubic spline through f'' at the knots (``scipy.interpolate.CubicSpline``,
               not-a-knot ends by default), quintic pieces of F (:class:`SplineAnalog`);
``chebyshev``  one Chebyshev interpolant of f'' of degree m on [a, b] at Chebyshev points,
               a polynomial F of degree m + 2 (:class:`ChebyshevAnalog`).

Each has ``position``, ``velocity``, ``acceleration`` and ``all`` (the three at once, one
``searchsorted`` for the piecewise kinds), vectorised over x of any shape (a Python float
in gives a float out, by a short scalar path), and ``error``: an estimate made at the fit
from f'' alone.  With e = F − f, e(a) = e'(a) = 0, so

    |e'(x)| ≤ ∫_a^b |e''| ds = ``bound_dF``,   |e(x)| ≤ ∫_a^b (b − s) |e''(s)| ds = ``bound_F``,

the integrals by Gauss–Legendre quadrature (16 points on each piece, or on 32 equal
pieces for the global form); ``max_d2F`` is the largest |e''| at those nodes.

Every kind evaluates through one compiled kernel (:mod:`approx.kernels`): F, F′, F″ of
a piecewise polynomial by Horner's scheme in one pass over the points, a Python float by
the same kernel's scalar entry.  The Chebyshev form is evaluated inside [a, b] from
Taylor polynomials of degree 7 about the centres of equal pieces, built on its first
evaluation with the fewest pieces (a power of two, at most 1024) that agree with the
series to 1e-14 of each output's largest value, so its cost does not grow with the
degree; points beyond [a, b] use the series (Clenshaw's recurrence).

:func:`choose` fits each kind at growing sizes and returns the cheapest one (fewest
coefficients, or fastest evaluation) whose measured error meets a position or
drive-force tolerance, with the table it chose from.
"""
from __future__ import annotations

import time

import numpy as np
import pandas as pd
from numpy.polynomial import chebyshev as C

from .analog import (ApproxError, PiecewiseAnalog, TransferFunction, _error_estimate, _Pieces,
                     as_count, as_knots, as_points, as_positive, as_real_array)

__all__ = ["SplineAnalog", "ChebyshevAnalog", "fit_spline", "fit_chebyshev", "choose",
           "KINDS", "MAX_DEGREE"]

#: the kinds :func:`choose` knows
KINDS = ("linear", "spline", "chebyshev")
#: Largest degree of the Chebyshev interpolant of f''
MAX_DEGREE = 500

def _clenshaw(u, c):
    """Chebyshev series with coefficient columns ``c`` (K, m) at ``u``: (m,) + u.shape, by
    Clenshaw's recurrence in place (no temporaries per term; 2–3 times numpy's chebval)."""
    K, m = c.shape
    u2 = 2.0 * u
    b1 = np.zeros((m,) + u.shape)
    b2 = np.zeros_like(b1)
    tmp = np.empty_like(b1)
    cc = c.reshape((K, m) + (1,) * u.ndim)
    for j in range(K - 1, 0, -1):
        np.multiply(b1, u2, out=tmp)
        tmp -= b2
        tmp += cc[j]
        b1, b2, tmp = tmp, b1, b2
    np.multiply(b1, u, out=tmp)
    tmp -= b2
    tmp += cc[0]
    return tmp


#: degree of the Taylor pieces, and the most pieces tried
_PW_DEGREE, _PW_MAX_PIECES = 7, 1024


def _taylor_pieces(c0, a, b):
    """The Chebyshev series ``c0`` of F on [a, b] as Taylor polynomials of degree
    _PW_DEGREE about the centres of P equal pieces (:class:`approx.kernels.Pieces`), P the
    fewest (a power of two) whose F, F', F'' agree with the series to 1e-14 of each
    one's largest value on the range (measured at nine points of every piece); False
    when no P ≤ _PW_MAX_PIECES does."""
    import math

    from .kernels import Pieces
    D = _PW_DEGREE
    half = 0.5 * (b - a)
    ders = [np.asarray(c0, float)]
    for _ in range(D):
        ders.append(C.chebder(ders[-1]) / half if ders[-1].size > 1 else np.zeros(1))
    fact = np.array([math.factorial(j) for j in range(D + 1)], float)
    P = 1
    while P <= _PW_MAX_PIECES:
        h = (b - a) / P
        mid = a + h * (np.arange(P) + 0.5)
        u = (2 * mid - a - b) / (b - a)
        tay = np.array([C.chebval(u, d) for d in ders]) / fact[:, None]     # (D+1, P)
        pcs = Pieces(mid, tay.T, lo=a, inv_h=P / (b - a))
        xs = np.clip((mid[:, None] + np.linspace(-0.5, 0.5, 9) * h).ravel(), a, b)
        got, _ = pcs(xs)
        u = (2 * xs - a - b) / (b - a)
        refs = [C.chebval(u, ders[w]) for w in range(3)]
        if all(np.abs(g - r).max() <= 1e-14 * max(np.abs(r).max(), 1e-300)
               for g, r in zip(got, refs)):
            return pcs
        P *= 2
    return False


def _check_bool(v, name):
    if not isinstance(v, (bool, np.bool_)):
        raise ApproxError(f"{name}: expected True or False, got {v!r}")
    return bool(v)


class _Surrogate(_Pieces, TransferFunction):
    """Shared parts: range, evaluation (:class:`approx.analog._Pieces`), ``error``."""

    kind = ""
    a: float
    b_end: float
    extrapolate: bool
    error: dict

    def errors(self, f, df, d2f, samples: int = 2001) -> dict:
        """Largest |F − f|, |F' − f'|, |F'' − f''| over a uniform sample of [a, b]."""
        from .fit import _checked
        f, df, d2f = _checked(f, "f"), _checked(df, "df"), _checked(d2f, "d2f")
        x = np.linspace(self.a, self.b_end, as_count(samples, "samples", 2, 10 ** 8))
        F, F1, F2 = self.all(x)
        return {"max_abs_F": float(np.max(np.abs(F - f(x)))),
                "max_abs_dF": float(np.max(np.abs(F1 - df(x)))),
                "max_abs_d2F": float(np.max(np.abs(F2 - d2f(x))))}


class SplineAnalog(_Surrogate):
    """A piecewise polynomial F (degree 5 for the cubic spline on f''), in local powers of
    ``t = x − x_i`` on each interval ``[x_i, x_{i+1}]``.

    Attributes
    ----------
    knots : numpy.ndarray (n+1,)
    coef : numpy.ndarray (n, 6)
        Ascending coefficients of F on each interval in t (F = Σ coef[i, j] t^j).
    error : dict
        ``max_d2F``, ``bound_dF``, ``bound_F`` (module docstring).
    bc : str
        The spline's end condition.
    """

    kind = "spline"

    def __init__(self, knots, coef, *, error=None, bc="not-a-knot", extrapolate=False):
        self.knots = np.asarray(knots, float)
        self.coef = np.asarray(coef, float)
        self.a, self.b_end = float(self.knots[0]), float(self.knots[-1])
        self.error = error or {}
        self.bc, self.extrapolate = bc, extrapolate

    @property
    def n(self) -> int:
        """Number of intervals."""
        return self.coef.shape[0]

    @property
    def size(self) -> int:
        return self.n

    @property
    def n_coefficients(self) -> int:
        """Numbers stored to evaluate F, F', F'': the coefficients and the knots."""
        return self.coef.size + self.knots.size

    def __repr__(self):
        return (f"SplineAnalog({self.n} intervals on [{self.a:.6g}, {self.b_end:.6g}], "
                f"{self.bc}, bound |F − f| ≤ {self.error.get('bound_F', np.nan):.3g})")

    def _make_pieces(self):
        from .kernels import Pieces
        return Pieces(self.knots[:-1], self.coef, inner=self.knots[1:-1])

    @property
    def table(self) -> pd.DataFrame:
        """One row per interval: ``x0, x1`` and the coefficients ``p0 … p5`` of F in t."""
        d = {"x0": self.knots[:-1], "x1": self.knots[1:]}
        d.update({f"p{j}": self.coef[:, j] for j in range(self.coef.shape[1])})
        return pd.DataFrame(d)


class ChebyshevAnalog(_Surrogate):
    """One Chebyshev series for F on [a, b] (degree m + 2 for f'' of degree m).

    Attributes
    ----------
    coef : numpy.ndarray (m + 3, 3)
        Chebyshev coefficients of F, F', F'' (columns) in ``u = (2x − a − b)/(b − a)``.
    degree : int
        m, the degree of the interpolant of f''.
    error : dict
        ``max_d2F``, ``bound_dF``, ``bound_F`` (module docstring).
    """

    kind = "chebyshev"

    def __init__(self, a, b, coef, degree, *, error=None, extrapolate=False):
        self.a, self.b_end = float(a), float(b)
        self.coef = np.asarray(coef, float)
        self.degree = int(degree)
        self.error = error or {}
        self.extrapolate = extrapolate
        self._s, self._o = 2.0 / (self.b_end - self.a), (self.a + self.b_end) / (self.a - self.b_end)

    @property
    def size(self) -> int:
        return self.degree

    @property
    def n_coefficients(self) -> int:
        """Coefficients of F (those of F', F'' follow from them)."""
        return self.degree + 3

    def __repr__(self):
        return (f"ChebyshevAnalog(degree {self.degree} for f'' on [{self.a:.6g}, "
                f"{self.b_end:.6g}], bound |F − f| ≤ {self.error.get('bound_F', np.nan):.3g})")

    def _make_pieces(self):
        return _taylor_pieces(self.coef[:, 0], self.a, self.b_end)

    def _eval(self, x, which):
        """The Taylor pieces inside [a, b]; the series itself (Clenshaw's recurrence) beyond
        it, or where no pieces reproduce the series (a degree in the hundreds)."""
        pcs = self._pieces()
        v = self._scalar(x)
        if v is not None and self.a <= v <= self.b_end and pcs is not False:
            r = pcs.scalar(v)
            return r if which is None else r[which]
        x = as_real_array(x, "x")
        if pcs is not False:
            out, bad = pcs(x, which, self.a, self.b_end)
            if bad < 0:
                return out
            if not (self.extrapolate and np.isfinite(x.flat[bad])):
                raise self._refuse(x.flat[bad])
        x = as_points(x, "x")
        if not self.extrapolate and x.size and (x.min() < self.a or x.max() > self.b_end):
            raise self._refuse(x[(x < self.a) | (x > self.b_end)].ravel()[0])
        u = x * self._s + self._o
        if which is None:
            r = _clenshaw(u, self.coef)          # (3,) + x.shape
            return r[0], r[1], r[2]
        return _clenshaw(u, self.coef[:, which:which + 1])[0]

    def kernel_form(self) -> dict:
        """This surrogate for a compiled model (:meth:`approx.analog._Pieces.kernel_form`):
        its Taylor pieces inside [a, b] (none for a degree no pieces reproduce), beyond it
        the series ``coef`` (K, 3) in ``u = s x + o`` by Clenshaw's recurrence, as
        :meth:`all` evaluates them."""
        pcs = self._pieces()
        return {"pieces": None if pcs is False else
                (pcs.origin, pcs.coef, pcs.inner, pcs.lo, pcs.inv_h),
                "inside": (self.a, self.b_end), "series": self.coef,
                "series_map": (self._s, self._o), "accept": self._range()}

    @property
    def table(self) -> pd.DataFrame:
        """One row per Chebyshev coefficient: ``j, F, dF, d2F``."""
        return pd.DataFrame({"j": np.arange(self.coef.shape[0]), "F": self.coef[:, 0],
                             "dF": self.coef[:, 1], "d2F": self.coef[:, 2]})


def _start(f, df, d2f, a, b):
    from .fit import _check_range, _vectorise
    a, b = _check_range(a, b)
    return a, b, _vectorise(f, "f"), _vectorise(df, "df"), _vectorise(d2f, "d2f")


def _spline_from_values(x, y, f_a, df_a, bc):
    """Local quintic coefficients of F from the spline on (x, y) with F(a), F'(a)."""
    from scipy.interpolate import CubicSpline
    if x.size == 2:                            # one interval: the chord
        h = x[1] - x[0]
        a2 = np.array([[y[0], (y[1] - y[0]) / h, 0.0, 0.0]])
    else:
        cs = CubicSpline(x, y, bc_type=bc)
        a2 = cs.c[::-1].T                      # (n, 4) ascending in t
    h = np.diff(x)
    j = np.arange(4)
    # integrals over each interval: F' increment Σ a_j h^{j+1}/(j+1); F increment beyond
    # F'_i h: Σ a_j h^{j+2}/((j+1)(j+2))
    inc1 = np.sum(a2 * h[:, None] ** (j + 1) / (j + 1), 1)
    dfk = df_a + np.r_[0.0, np.cumsum(inc1)]
    inc0 = dfk[:-1] * h + np.sum(a2 * h[:, None] ** (j + 2) / ((j + 1) * (j + 2)), 1)
    fk = f_a + np.r_[0.0, np.cumsum(inc0)]
    coef = np.zeros((h.size, 6))
    coef[:, 0], coef[:, 1] = fk[:-1], dfk[:-1]
    coef[:, 2:] = a2 / ((j + 1) * (j + 2))
    return coef


def fit_spline(f, df, d2f, a: float, b: float, *, n: int | None = None, knots=None,
               bc: str = "not-a-knot", extrapolate: bool = False) -> SplineAnalog:
    """Cubic-spline analog: the spline through f'' at the knots, integrated twice from
    ``F(a) = f(a)``, ``F'(a) = f'(a)`` — the seed's data, a smoother curve.

    Parameters
    ----------
    f, df, d2f : callable
        Vectorised, as for :func:`~approx.fit.fit`.
    a, b : float
        The range, ``a < b``.
    n : int, optional
        Intervals, on the knots of the seed analog's minimax placement
        (``fit(..., n=n).knots``), ``1 ≤ n ≤ MAX_N``.
    knots : array_like, optional
        These knots (strictly increasing, from a to b).  Exactly one of n, knots.
    bc : str
        ``CubicSpline``'s ``bc_type``: "not-a-knot" (default), "natural" or "clamped"
        ("clamped" here: f''' = 0 at the ends).
    extrapolate : bool

    Returns
    -------
    SplineAnalog
    """
    from .fit import MAX_N, fit
    a, b, f, df, d2f = _start(f, df, d2f, a, b)
    if (n is None) == (knots is None):
        raise ApproxError("n, knots: give exactly one of n, knots")
    if not isinstance(bc, str) or bc not in ("not-a-knot", "natural", "clamped"):
        raise ApproxError(f"bc: expected 'not-a-knot', 'natural' or 'clamped', got {bc!r}")
    extrapolate = _check_bool(extrapolate, "extrapolate")
    if n is not None:
        n = as_count(n, "n", 1, MAX_N)
        x = fit(f, df, d2f, a, b, n=n).knots if n > 1 else np.array([a, b])
    else:
        x = as_knots(knots)
        tol = 8 * np.spacing(max(1.0, abs(a), abs(b))) + 1e-9 * (b - a)
        if abs(x[0] - a) > tol or abs(x[-1] - b) > tol:
            raise ApproxError(f"knots: must start at a={a} and end at b={b}, got "
                              f"[{x[0]}, {x[-1]}]")
    xa = np.array([a])
    coef = _spline_from_values(x, d2f(x), float(f(xa)[0]), float(df(xa)[0]), bc)
    sp = SplineAnalog(x, coef, bc=bc, extrapolate=True)
    sp.error = _error_estimate(sp.acceleration, d2f, x)
    sp.extrapolate = extrapolate
    return sp


def fit_chebyshev(f, df, d2f, a: float, b: float, *, degree: int,
                  extrapolate: bool = False) -> ChebyshevAnalog:
    """Global Chebyshev analog: f'' interpolated at the ``degree + 1`` Chebyshev points of
    the first kind on [a, b], integrated twice from ``F(a) = f(a)``, ``F'(a) = f'(a)``.

    Parameters
    ----------
    f, df, d2f : callable
        Vectorised, as for :func:`~approx.fit.fit`.
    a, b : float
    degree : int
        Degree of the interpolant of f'', ``0 ≤ degree ≤ MAX_DEGREE``; F has degree + 3
        coefficients.
    extrapolate : bool

    Returns
    -------
    ChebyshevAnalog
    """
    a, b, f, df, d2f = _start(f, df, d2f, a, b)
    m = as_count(degree, "degree", 0, MAX_DEGREE)
    extrapolate = _check_bool(extrapolate, "extrapolate")
    u = C.chebpts1(m + 1)
    x = 0.5 * (a + b) + 0.5 * (b - a) * u
    c2 = C.chebfit(u, d2f(x), m)
    half = 0.5 * (b - a)                       # dx = half du
    xa = np.array([a])
    c1 = C.chebint(c2, lbnd=-1, scl=half)
    c1[0] += float(df(xa)[0])
    c0 = C.chebint(c1, lbnd=-1, scl=half)
    c0[0] += float(f(xa)[0])
    coef = np.zeros((m + 3, 3))
    coef[:, 0], coef[:m + 2, 1], coef[:m + 1, 2] = c0, c1, c2
    ch = ChebyshevAnalog(a, b, coef, m, extrapolate=True)
    # (by the series itself: the Taylor pieces of large batches are built when first used)
    ch.error = _error_estimate(lambda v: _clenshaw(v * ch._s + ch._o, coef[:, 2:3])[0], d2f,
                               np.linspace(a, b, 33))
    ch.extrapolate = extrapolate
    return ch


# ---------------------------------------------------------------------------- choose
_SIZES = {"linear": [1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256, 384, 512,
                     768, 1000],
          "spline": [1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256, 384, 512,
                     768, 1000],
          "chebyshev": [2, 3, 4, 6, 8, 10, 12, 16, 20, 24, 32, 40, 48, 64, 80, 96, 128, 160,
                        192, 256, 320, 384, 500]}


def _build(kind, size, f, df, d2f, a, b):
    from .fit import fit
    if kind == "linear":
        return fit(f, df, d2f, a, b, n=size)
    if kind == "spline":
        return fit_spline(f, df, d2f, a, b, n=size)
    return fit_chebyshev(f, df, d2f, a, b, degree=size)


def _n_coef(s):
    if isinstance(s, PiecewiseAnalog):
        return 4 * s.n + s.knots.size
    return s.n_coefficients


def _eval_time(s, x, repeat=3):
    """Seconds per point for F, F', F'' of a batch, and per scalar call of the three."""
    fn = s.all if hasattr(s, "all") else (lambda v: (s.position(v), s.velocity(v),
                                                     s.acceleration(v)))
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn(x)
        best = min(best, time.perf_counter() - t0)
    xs = x[:: max(1, x.size // 50)].tolist()
    t0 = time.perf_counter()
    for v in xs:
        fn(v)
    return best / x.size, (time.perf_counter() - t0) / len(xs)


def choose(f, df, d2f, a: float, b: float, *, tol: float, target: str = "position",
           cost: str = "coefficients", kinds=KINDS, samples: int = 4001):
    """The cheapest surrogate that meets a tolerance, and the table it was chosen from.

    Every kind is fitted at growing sizes (intervals n for "linear" and "spline", degree of
    the f'' interpolant for "chebyshev") until its measured error on ``samples`` uniform
    points of [a, b] meets ``tol`` (or its largest size is reached).

    Parameters
    ----------
    f, df, d2f : callable
        Vectorised exact analogs.
    a, b : float
    tol : float
        Positive.  For ``target="position"``: largest |F − f| (unit of f).  For
        ``target="force"``: largest relative error of each term of the drive force
        ``Q = I (f'² ẍ + f' f'' ẋ²)``, i.e. ``max |F'² − f'²| / max f'²`` and
        ``max |F'F'' − f'f''| / max |f'f''|`` both ≤ tol, so that
        ``|ΔQ| ≤ tol · I (max f'² |ẍ| + max |f'f''| ẋ²)`` for any motion.
    target : "position" or "force"
    cost : "coefficients" (fewest stored numbers) or "time" (fastest batch evaluation of
        F, F', F'' per point)
    kinds : iterable of "linear", "spline", "chebyshev"
    samples : int
        Points of the check, 2 … 10⁶.

    Returns
    -------
    (surrogate, table)
        The chosen surrogate (``PiecewiseAnalog``, ``SplineAnalog`` or ``ChebyshevAnalog``)
        and a DataFrame, one row per fit tried: ``kind, size, coefficients, fit_s,
        eval_s_batch, eval_s_scalar, max_abs_F, force_rel, bound_F, meets, chosen``;
        evaluation times are measured for the fits that meet ``tol`` (all of them with
        ``cost="time"``) and NaN for the others.

    Raises
    ------
    ApproxError
        Bad arguments (named), or no kind meets ``tol`` within its largest size.
    """
    a, b, f, df, d2f = _start(f, df, d2f, a, b)
    tol = as_positive(tol, "tol", "a positive tolerance")
    if not isinstance(target, str) or target not in ("position", "force"):
        raise ApproxError(f"target: expected 'position' or 'force', got {target!r}")
    if not isinstance(cost, str) or cost not in ("coefficients", "time"):
        raise ApproxError(f"cost: expected 'coefficients' or 'time', got {cost!r}")
    if isinstance(kinds, str):
        kinds = (kinds,)
    try:
        kinds = tuple(kinds)
    except TypeError:
        raise ApproxError(f"kinds: expected some of {KINDS}, got {kinds!r}") from None
    if not kinds or any(not isinstance(k, str) or k not in KINDS for k in kinds) \
            or len(set(kinds)) != len(kinds):
        raise ApproxError(f"kinds: expected distinct names among {KINDS}, got {kinds!r}")
    samples = as_count(samples, "samples", 2, 10 ** 6)
    x = np.linspace(a, b, samples)
    fx, dfx, d2fx = f(x), df(x), d2f(x)
    p2 = dfx ** 2
    p3 = dfx * d2fx
    s2, s3 = max(np.max(np.abs(p2)), 1e-300), max(np.max(np.abs(p3)), 1e-300)
    xt = np.linspace(a, b, 10_000)
    rows, made = [], []
    for kind in kinds:
        for size in _SIZES[kind]:
            t0 = time.perf_counter()
            try:
                s = _build(kind, size, f, df, d2f, a, b)
            except ApproxError:
                break
            t_fit = time.perf_counter() - t0
            F, F1, F2 = (s.all(x) if hasattr(s, "all") else
                         (s.position(x), s.velocity(x), s.acceleration(x)))
            e_pos = float(np.max(np.abs(F - fx)))
            e_force = float(max(np.max(np.abs(F1 ** 2 - p2)) / s2,
                                np.max(np.abs(F1 * F2 - p3)) / s3))
            ok = (e_pos if target == "position" else e_force) <= tol
            tb, ts = _eval_time(s, xt) if ok or cost == "time" else (np.nan, np.nan)
            rows.append({"kind": kind, "size": size, "coefficients": _n_coef(s), "fit_s": t_fit,
                         "eval_s_batch": tb, "eval_s_scalar": ts, "max_abs_F": e_pos,
                         "force_rel": e_force, "bound_F": s.error["bound_F"], "meets": ok})
            made.append(s)
            if ok:
                break
    table = pd.DataFrame(rows)
    passing = table.index[table.meets]
    if not len(passing):
        raise ApproxError(f"tol: no surrogate among {', '.join(kinds)} meets {target} tolerance "
                          f"{tol} within its largest size; expected a larger tol")
    key = "coefficients" if cost == "coefficients" else "eval_s_batch"
    best = min(passing, key=lambda i: (table.loc[i, key], table.loc[i, "coefficients"]))
    table["chosen"] = table.index == best
    return made[best], table
