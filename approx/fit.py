"""Fitting piecewise analogs: given knots, adaptive knots (σ ≤ δ), minimax n intervals,
and a least-squares variant with end conditions."""
from __future__ import annotations

import numpy as np

from .analog import ApproxError, PiecewiseAnalog, interval_sigma

__all__ = ["fit", "fit_least_squares", "default_gamma"]


def _check_range(a, b):
    if not (np.isfinite(a) and np.isfinite(b)):
        raise ApproxError(f"a, b: expected finite numbers, got a={a}, b={b}")
    if not a < b:
        raise ApproxError(f"a, b: expected a < b, got a={a}, b={b}")


def _vectorise(func, name):
    def g(x):
        v = np.asarray(func(np.asarray(x, float)), float)
        if v.shape != np.shape(x):
            v = np.broadcast_to(v, np.shape(x))
        if not np.all(np.isfinite(v)):
            bad = np.asarray(x)[~np.isfinite(v)].ravel()[0]
            raise ApproxError(f"{name}: not finite at x = {float(bad)!r} (a dead point or a range "
                              "outside the mechanism's reach?)")
        return v
    return g


def default_gamma(d2f, a, b, samples: int = 4001) -> float:
    """Seed 004's weight: γ = 1 / (max f'' − min f'') over [a, b] (gives 0.051 for its example)."""
    v = d2f(np.linspace(a, b, samples))
    rng = float(np.max(v) - np.min(v))
    return 1.0 / rng if rng > 0 else 1.0


def _reach(d2f, x0, b, delta, gamma, tol):
    """Largest x ≤ b with σ([x0, x]) ≤ δ (bisection on the right end)."""
    sig = lambda x1: float(interval_sigma(d2f, x0, x1, d2f(np.array([x0]))[0],
                                          d2f(np.array([x1]))[0], gamma))
    if sig(b) <= delta:
        return b
    lo, hi = x0, b
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if sig(mid) <= delta:
            lo = mid
        else:
            hi = mid
    if lo == x0:
        raise ApproxError(f"delta: σ ≤ {delta} needs an interval shorter than {tol:.1e} at "
                          f"x = {x0} (f'' grows without bound there?)")
    return lo


def _greedy(d2f, a, b, delta, gamma, tol, max_intervals=10_000):
    knots = [a]
    while knots[-1] < b:
        knots.append(_reach(d2f, knots[-1], b, delta, gamma, tol))
        if len(knots) - 1 > max_intervals:
            raise ApproxError(f"delta: more than {max_intervals} intervals needed")
    return np.array(knots)


def fit(f, df, d2f, a: float, b: float, *, delta: float | None = None,
        gamma: float | None = None, knots=None, n: int | None = None,
        extrapolate: bool = False) -> PiecewiseAnalog:
    """Piecewise-linear acceleration analog of ``f`` on ``[a, b]`` (seed 004).

    Parameters
    ----------
    f, df, d2f : callable
        The exact position function and its first and second analogs (vectorised).
    a, b : float
    delta : float, optional
        Adaptive knots: every σ ≤ δ with the fewest intervals (greedy furthest
        reach, which is optimal when a sub-interval of a feasible interval is
        feasible; the tests check it against exhaustive search).
    gamma : float, optional
        Weight of (1); default the seed's rule 1 / (max f'' − min f'').
    knots : array_like, optional
        Use these knots (sorted, from a to b).
    n : int, optional
        n intervals placed to minimise the largest σ: bisection on δ over the
        greedy count, so all intervals end with (nearly) equal σ.
    extrapolate : bool
        Let the result evaluate outside [a, b].

    Exactly one of ``delta``, ``knots``, ``n`` must be given.
    """
    _check_range(a, b)
    chosen = [v is not None for v in (delta, knots, n)]
    if sum(chosen) != 1:
        raise ApproxError("give exactly one of delta, knots, n")
    f, df, d2f = _vectorise(f, "f"), _vectorise(df, "df"), _vectorise(d2f, "d2f")
    rule = "given"
    if gamma is None:
        gamma = default_gamma(d2f, a, b)
        rule = "1 / (max f'' − min f'') on [a, b] (seed 004)"
    elif not (np.isfinite(gamma) and gamma >= 0):
        raise ApproxError(f"gamma: expected a non-negative weight, got {gamma}")
    tol = 1e-12 * max(1.0, abs(a), abs(b)) + 1e-9 * (b - a)
    info = {}
    if knots is not None:
        x = np.asarray(knots, float)
        if x.ndim != 1 or x.size < 2 or not np.all(np.isfinite(x)):
            raise ApproxError("knots: expected a 1-D array of at least two finite values")
        if np.any(np.diff(x) <= 0):
            raise ApproxError("knots: must be strictly increasing")
        if abs(x[0] - a) > tol or abs(x[-1] - b) > tol:
            raise ApproxError(f"knots: must start at a={a} and end at b={b}, got "
                              f"[{x[0]}, {x[-1]}]")
        method = "knots"
    elif delta is not None:
        if not (np.isfinite(delta) and delta > 0):
            raise ApproxError(f"delta: expected a positive tolerance, got {delta}")
        x = _greedy(d2f, a, b, delta, gamma, tol)
        method = f"adaptive, delta={delta}"
    else:
        if int(n) != n or n < 1:
            raise ApproxError(f"n: expected a positive integer, got {n}")
        n = int(n)
        one = float(interval_sigma(d2f, a, b, d2f(np.array([a]))[0], d2f(np.array([b]))[0],
                                   gamma))
        lo, hi = 0.0, one * (1 + 1e-12) + 1e-300
        best = np.array([a, b]) if n == 1 else None
        for _ in range(200):
            if n == 1 or hi - lo <= 1e-10 * hi:
                break
            mid = 0.5 * (lo + hi)
            try:
                xs = _greedy(d2f, a, b, mid, gamma, tol, max_intervals=n)
            except ApproxError:
                xs = None
            if xs is not None and xs.size - 1 <= n:
                hi, best = mid, xs
            else:
                lo = mid
        if best is None:
            best = _greedy(d2f, a, b, hi, gamma, tol, max_intervals=n)
        x = best
        if x.size - 1 < n:                      # fewer needed: split the widest intervals
            while x.size - 1 < n:
                i = int(np.argmax(np.diff(x)))
                x = np.insert(x, i + 1, 0.5 * (x[i] + x[i + 1]))
        info["minimax_sigma"] = hi
        method = f"minimax, n={n}"
    xa = np.array([a])
    return PiecewiseAnalog.from_values(x, d2f(x), float(f(xa)[0]), float(df(xa)[0]), d2f, gamma,
                                       gamma_rule=rule, method=method, extrapolate=extrapolate,
                                       info=info)


def fit_least_squares(f, df, d2f, knots, *, end_conditions: bool = True,
                      gamma: float | None = None, extrapolate: bool = False) -> PiecewiseAnalog:
    """Knot values of F'' by least squares on f'' (beyond the seed).

    Minimises ``∫ (F'' − f'')² dx`` over [a, b] subject to ``F(a) = f(a)``,
    ``F'(a) = f'(a)`` (built in) and, when ``end_conditions``, ``F(b) = f(b)``,
    ``F'(b) = f'(b)``: an equality-constrained linear least-squares problem,
    solved through its KKT system.
    """
    x = np.asarray(knots, float)
    if x.ndim != 1 or x.size < 2 or np.any(np.diff(x) <= 0):
        raise ApproxError("knots: expected a strictly increasing 1-D array of ≥ 2 values")
    a, b = float(x[0]), float(x[-1])
    _check_range(a, b)
    f, df, d2f = _vectorise(f, "f"), _vectorise(df, "df"), _vectorise(d2f, "d2f")
    rule = "given"
    if gamma is None:
        gamma = default_gamma(d2f, a, b)
        rule = "1 / (max f'' − min f'') on [a, b] (seed 004)"
    m = x.size
    # quadrature of the hat-function Gram matrix and right-hand side
    t, w = np.polynomial.legendre.leggauss(48)
    G = np.zeros((m, m))
    r = np.zeros(m)
    for i in range(m - 1):
        h = 0.5 * (x[i + 1] - x[i])
        xs = 0.5 * (x[i] + x[i + 1]) + h * t
        s = (xs - x[i]) / (2 * h)
        phi = np.stack([1 - s, s])                   # hats of knots i and i+1
        ww = w * h
        G[i:i + 2, i:i + 2] += (phi * ww) @ phi.T
        r[i:i + 2] += (phi * ww) @ d2f(xs)
    xa, xb = np.array([a]), np.array([b])
    fa, dfa = float(f(xa)[0]), float(df(xa)[0])
    if end_conditions:
        # F'(b) − F'(a) = ∫ F'' = Σ trapezoid weights · y;  F(b) − F(a) − F'(a)(b − a) =
        # ∫ (b − s) F''(s) ds, exact for hats by their moments.
        C = np.zeros((2, m))
        for i in range(m - 1):
            h = x[i + 1] - x[i]
            C[0, i] += h / 2
            C[0, i + 1] += h / 2
            # ∫ over [x_i, x_{i+1}] of (b − s) times each hat
            C[1, i] += h * (b - x[i]) / 2 - h * h / 6
            C[1, i + 1] += h * (b - x[i]) / 2 - h * h / 3
        d = np.array([float(df(xb)[0]) - dfa, float(f(xb)[0]) - fa - dfa * (b - a)])
        KKT = np.block([[G, C.T], [C, np.zeros((2, 2))]])
        y = np.linalg.solve(KKT, np.r_[r, d])[:m]
    else:
        y = np.linalg.solve(G, r)
    return PiecewiseAnalog.from_values(x, y, fa, dfa, d2f, gamma,
                                       gamma_rule=rule,
                                       method="least squares" + (", end conditions"
                                                                 if end_conditions else ""),
                                       extrapolate=extrapolate)
