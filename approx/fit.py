"""Fitting piecewise analogs: given knots, adaptive knots (σ ≤ δ), minimax n intervals,
and a least-squares variant with end conditions.

Limits: ``n ≤ MAX_N`` (1000) intervals for the minimax placement and at most
``MAX_ADAPTIVE`` (10,000) intervals for adaptive knots; beyond them :func:`fit`
raises :class:`~approx.analog.ApproxError` at once instead of running for minutes.
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import solve_banded

from .analog import (ApproxError, PiecewiseAnalog, _sigma2, as_count, as_knots, as_real,
                     interval_sigma)

__all__ = ["fit", "fit_least_squares", "default_gamma", "MAX_N", "MAX_ADAPTIVE", "SIGMA_RULES"]

#: Readings of σ accepted by :func:`fit` (``sigma_rule``)
SIGMA_RULES = ("seed", "gamma_rms")

#: Largest ``n`` accepted by :func:`fit` (minimax placement of n intervals).
MAX_N = 1000
#: Largest number of intervals the adaptive rule (``delta``) may produce.
MAX_ADAPTIVE = 10_000


def _check_range(a, b):
    a, b = as_real(a, "a"), as_real(b, "b")
    if not a < b:
        raise ApproxError(f"a, b: expected a < b, got a={a}, b={b}")
    return a, b


def _vectorise(func, name):
    """``func`` checked on every call: real values of the shape of x, all finite."""
    if not callable(func):
        raise ApproxError(f"{name}: expected a callable {name}(x) of a numpy array, got "
                          f"{type(func).__name__}")

    def g(x):
        x = np.asarray(x, float)
        try:
            raw = func(x)
        except TypeError as e:
            raise ApproxError(f"{name}: could not be evaluated on a numpy array of x of shape "
                              f"{x.shape} (expected a vectorised function): {e}") from e
        v = np.asarray(raw)
        if v.dtype.kind not in "iuf":
            raise ApproxError(f"{name}: returned {type(raw).__name__} of dtype {v.dtype}; "
                              "expected real numbers")
        v = v.astype(float, copy=False)
        if v.shape != x.shape:
            try:
                v = np.broadcast_to(v, x.shape)
            except ValueError:
                raise ApproxError(f"{name}: returned shape {v.shape} for x of shape {x.shape}; "
                                  "expected the shape of x") from None
        if not np.all(np.isfinite(v)):
            bad = x[~np.isfinite(v)].ravel()[0]
            raise ApproxError(f"{name}: not finite at x = {float(bad)!r} (a dead point or a range "
                              "outside the mechanism's reach?)")
        return v
    g.checked = True
    return g


def _checked(func, name):
    return func if getattr(func, "checked", False) else _vectorise(func, name)


def _gamma(gamma, d2f, a, b):
    """The weight of (1) and the rule it came from."""
    if gamma is None:
        return default_gamma(d2f, a, b), "1 / (max f'' − min f'') on [a, b] (seed 004)"
    g = as_real(gamma, "gamma")
    if not g > 0:
        raise ApproxError(f"gamma: expected a positive weight, got {g}")
    return g, "given"


_count = as_count


def default_gamma(d2f, a, b, samples: int = 4001) -> float:
    """Seed 004's weight: γ = 1 / (max f'' − min f'') over [a, b] (gives 0.051 for its example).

    Parameters
    ----------
    d2f : callable
        f'' (vectorised).
    a, b : float
    samples : int
        Points of the uniform sample of [a, b] that give max and min.

    Returns
    -------
    float
        γ in units of 1 / [f''] (1 when f'' is constant).
    """
    a, b = _check_range(a, b)
    v = _checked(d2f, "d2f")(np.linspace(a, b, _count(samples, "samples", 2, 10 ** 8)))
    rng = float(np.max(v) - np.min(v))
    return 1.0 / rng if rng > 0 else 1.0


_U16 = np.linspace(0.0, 1.0, 18)[1:-1]
_W24 = np.linspace(0.7, 1.3, 24)


def _reach(d2f, x0, y0, b, delta, gamma, tol, hint=None):
    """Largest x ≤ b with σ([x0, x]) ≤ δ, to ``tol``; returns ``(x, f''(x))``.

    A bracketing search on the right end.  The first bracket comes from one vectorised
    evaluation of σ at b, at 16 ends spread evenly over (x0, b) and, with ``hint`` (the
    previous interval's width), at 24 ends within ±30 % of ``x0 + hint``; then secant
    steps in (log width, log σ) (σ grows like width^(5/2) for smooth f''), kept inside
    the bracket, a step of at least ``tol / 2`` (so the bracket closes to ``tol`` once the
    estimate is good), and a bisection after two updates of the same side.
    """
    x0f, y0f = np.float64(x0), np.float64(y0)

    def sig(x1):
        i2, _, y1 = _sigma2(d2f, x0f, np.float64(x1), y0=y0f)
        return float(np.sqrt(gamma * i2)), float(y1)

    cand = x0 + (b - x0) * _U16
    if hint is not None and hint > 0:
        cand = np.concatenate([cand, x0 + hint * _W24])
    cand = np.unique(cand[(cand > x0) & (cand < b)])
    cand = np.r_[cand, b]
    i2, _, yc = _sigma2(d2f, np.full(cand.shape, x0f), cand, y0=np.full(cand.shape, y0f))
    sc = np.sqrt(gamma * i2)
    if sc[-1] <= delta:
        return b, float(yc[-1])
    k = int(np.nonzero(~(sc <= delta))[0][0])        # the first infeasible end
    hi, s_hi = float(cand[k]), float(sc[k])
    if k > 0:
        lo, s_lo, y_lo = float(cand[k - 1]), float(sc[k - 1]), float(yc[k - 1])
    else:
        lo, s_lo, y_lo = x0, 0.0, y0
    same, last = 0, 0
    while hi - lo > tol:
        h_lo, h_hi = lo - x0, hi - x0
        x = np.nan
        if same < 2:
            with np.errstate(all="ignore"):
                if s_lo > 0 and h_lo > 0 and s_hi > s_lo:
                    p = np.log(s_hi / s_lo) / np.log(h_hi / h_lo)
                    if np.isfinite(p) and p > 1e-3:
                        x = x0 + h_lo * (delta / s_lo) ** (1 / p)
                else:
                    x = x0 + h_hi * (delta / s_hi) ** 0.4
        if not np.isfinite(x):
            x = 0.5 * (lo + hi)
        x = min(max(x, lo + 0.5 * tol), hi - 0.5 * tol)
        s, y = sig(x)
        side = 1 if s <= delta else -1
        same = same + 1 if side == last else 1
        last = side
        if side > 0:
            lo, s_lo, y_lo = x, s, y
        else:
            hi, s_hi = x, s
    if lo == x0:
        raise ApproxError(f"delta: σ ≤ {delta} needs an interval shorter than {tol:.1e} at "
                          f"x = {x0} (f'' grows without bound there?)")
    return lo, y_lo


def _greedy(d2f, a, b, delta, gamma, tol, max_intervals):
    """Knots by furthest reach at σ ≤ δ, or None when more than ``max_intervals`` are needed."""
    knots = _greedy_steps(d2f, a, b, delta, gamma, tol, max_intervals + 1)
    return knots if knots[-1] == b else None


def _greedy_steps(d2f, a, b, delta, gamma, tol, steps):
    """At most ``steps`` furthest reaches at σ ≤ δ from a (the knots reached, ending at b
    when b was reached)."""
    knots = [a]
    y = float(d2f(np.array([a]))[0])
    while knots[-1] < b and len(knots) <= steps:
        hint = knots[-1] - knots[-2] if len(knots) > 1 else None
        x, y = _reach(d2f, knots[-1], y, b, delta, gamma, tol, hint)
        knots.append(x)
    return np.array(knots)


def _equalise(d2f, a, b, n, gamma, rtol=1e-10, accept=1e-7, maxiter=60):
    """The minimax partition by equal σ: Newton on ``log σ_i − log σ_{i+1} = 0``.

    Start: equidistribution of σ^(2/5) (additive when σ ∝ width^(5/2)) over a uniform
    partition of 4n intervals.  The Jacobian is tridiagonal (σ_i depends on x_i and
    x_{i+1}); its entries come from one-sided differences of σ with each knot moved
    inwards, all intervals in one call of ``d2f``.  Steps keep every interval at least
    half its width and are halved until the largest residual falls.

    Returns ``(knots, sigma)``, or None when σ vanishes on an interval (f'' linear on
    a stretch) or σ cannot be equalised to ``accept`` relative.
    When σ_i are equal, the partition is minimax under the same condition that
    makes the greedy rule optimal (a sub-interval of a feasible interval is feasible).
    """
    m = 4 * n
    g = np.linspace(a, b, m + 1)
    i2, yg, _ = _sigma2(d2f, g[:-1], g[1:])
    s = np.sqrt(gamma * i2)
    scale = np.sqrt(gamma * np.diff(g)) * np.max(np.abs(yg)) * 1e-13   # rounding level
    if np.all(s <= scale):                    # f'' is linear: every partition is exact
        return np.linspace(a, b, n + 1), np.zeros(n)
    w = s ** 0.4
    W = np.r_[0.0, np.cumsum(w + 1e-9 * np.max(w))]   # stretches of zero σ: few knots
    x = np.interp(np.linspace(0.0, W[-1], n + 1), W, g)
    x[0], x[-1] = a, b
    if np.any(np.diff(x) <= 0):
        return None

    def evaluate(x):
        x0, x1 = x[:-1], x[1:]
        e = np.maximum(1e-7 * (x1 - x0), 64 * np.spacing(np.maximum(abs(x0), abs(x1))))
        xl, xr = x0 + e, x1 - e                      # ends moved inwards: stays in [a, b]
        i2 = _sigma2(d2f, np.stack([x0, xl, x0]), np.stack([x1, x1, xr]))[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            ls = 0.5 * np.log(gamma * i2)
            dL, dR = (ls[1] - ls[0]) / (xl - x0), (ls[0] - ls[2]) / (x1 - xr)
        return ls[0], dL, dR

    ls, dL, dR = evaluate(x)
    for _ in range(maxiter):
        if not np.all(np.isfinite(ls)):
            return None
        r = ls[:-1] - ls[1:]
        res = np.max(np.abs(r))
        if np.ptp(ls) <= rtol:
            break
        ab = np.zeros((3, n - 1))
        ab[0, 1:] = -dR[1:n - 1]
        ab[1] = dR[:n - 1] - dL[1:]
        ab[2, :-1] = dL[1:n - 1]
        try:
            with np.errstate(all="ignore"):
                step = solve_banded((1, 1), ab, -r)
        except (np.linalg.LinAlgError, ValueError):
            return None
        if not np.all(np.isfinite(step)):
            return None
        dh = np.diff(np.r_[0.0, step, 0.0])
        h = np.diff(x)
        shrink = dh < 0
        alpha = min(1.0, float(np.min(0.5 * h[shrink] / -dh[shrink]))) if shrink.any() else 1.0
        for _ in range(12):
            xt = x.copy()
            xt[1:-1] += alpha * step
            lt, dLt, dRt = evaluate(xt)
            if np.all(np.isfinite(lt)) and np.max(np.abs(lt[:-1] - lt[1:])) < res:
                break
            alpha *= 0.5
        else:
            break                                  # no progress: stop here
        x, ls, dL, dR = xt, lt, dLt, dRt
    if not np.all(np.isfinite(ls)) or np.ptp(ls) > accept:
        return None
    return x, np.exp(ls)


def _bracket_minimax(d2f, a, b, n, gamma, tol, rtol=1e-10):
    """The minimax partition by a bracketing search on δ (robust, slower than Newton).

    For a given δ, n − 1 furthest reaches leave a remainder [x_{n−1}, b] of error
    σ_rem(δ), which falls as δ grows; the minimax δ* solves σ_rem(δ) = δ.  The
    search keeps δ_lo (σ_rem > δ: n intervals do not suffice) and δ_hi (they do)
    and closes them by Illinois steps on log σ_rem − log δ against log δ, with
    bisection when a side has no finite value, to ``rtol`` relative.  Returns the
    knots of δ_hi (fewer than n intervals are split at their widest) and δ_hi.
    """
    def phi(delta):
        k = _greedy_steps(d2f, a, b, delta, gamma, tol, n - 1)
        if k[-1] == b:
            return -np.inf
        s = float(interval_sigma(d2f, k[-1], b, d2f(k[-1:])[0], d2f(np.array([b]))[0], gamma))
        return np.log(s) - np.log(delta) if s > 0 else -np.inf

    xa, xb = np.array([a]), np.array([b])
    hi = float(interval_sigma(d2f, a, b, d2f(xa)[0], d2f(xb)[0], gamma)) * (1 + 1e-12) + 1e-300
    p_hi = -np.inf                            # one interval reaches b at δ = σ(a, b)
    lo = hi * n ** -2.5
    p_lo = phi(lo)
    while p_lo <= 0 and lo > 1e-300:
        hi, p_hi = lo, p_lo
        lo *= 1e-3
        p_lo = phi(lo)
    if p_lo <= 0:                              # σ vanishes: every partition is exact
        lo = hi
    side = 0
    for _ in range(200):
        if hi - lo <= rtol * hi:
            break
        L, H = np.log(lo), np.log(hi)
        if np.isfinite(p_hi) and np.isfinite(p_lo) and p_lo > p_hi:
            t = L + (H - L) * p_lo / (p_lo - p_hi)
            t = min(max(t, L + 1e-3 * (H - L)), H - 1e-3 * (H - L))
        else:
            t = 0.5 * (L + H)
        mid = float(np.exp(t))
        p = phi(mid)
        if p > 0:
            lo, p_lo = mid, p
            if side == 1:
                p_hi *= 0.5                    # Illinois: halve the stale end's value
            side = 1
        else:
            hi, p_hi = mid, p
            if side == -1:
                p_lo *= 0.5
            side = -1
    x = _greedy(d2f, a, b, hi, gamma, tol, max_intervals=n)
    while x is None:                           # rounding at the edge: nudge δ up
        hi *= 1 + 1e-9
        x = _greedy(d2f, a, b, hi, gamma, tol, max_intervals=n)
    while x.size - 1 < n:                      # fewer needed: split the widest intervals
        i = int(np.argmax(np.diff(x)))
        x = np.insert(x, i + 1, 0.5 * (x[i] + x[i + 1]))
    return x, hi


_knots = as_knots


def fit(f, df, d2f, a: float, b: float, *, delta: float | None = None,
        gamma: float | None = None, knots=None, n: int | None = None,
        extrapolate: bool = False, sigma_rule: str = "seed") -> PiecewiseAnalog:
    """Piecewise-linear acceleration analog of ``f`` on ``[a, b]`` (seed 004).

    Parameters
    ----------
    f, df, d2f : callable
        The exact position function and its first and second analogs, vectorised:
        each maps a float array of any shape to real values of the same shape.
    a, b : float
        The range of the input x (its unit, e.g. m or rad), finite, ``a < b``.
    delta : float, optional
        Adaptive knots: every σ ≤ δ with the fewest intervals (greedy furthest
        reach, which is optimal when a sub-interval of a feasible interval is
        feasible; the tests check it against exhaustive search); at most
        ``MAX_ADAPTIVE`` intervals.
    gamma : float, optional
        Weight of (1), positive; default the seed's rule 1 / (max f'' − min f'').
    knots : array_like (m,), optional
        Use these knots (strictly increasing, from a to b, finite).
    n : int, optional
        n intervals placed to minimise the largest σ, ``1 ≤ n ≤ MAX_N`` (1000).
        The σ_i are equalised by Newton's method (vectorised over the intervals;
        n = 1000 takes well under a second for a closed-form f''), to 1e-7
        relative or better; when that fails (f'' linear on a stretch, so σ
        vanishes there) by a bracketing search on δ over the greedy reaches.
    extrapolate : bool
        Let the result evaluate outside [a, b].
    sigma_rule : "seed" or "gamma_rms"
        How σ is read.  "seed" (default): formula (1) as printed, ``σ = sqrt(γ ∫ e² dx)``
        (e = F'' − f''); with the seed's γ = 0.051 and δ = 0.005 it needs 7 intervals for
        the seed's example.  "gamma_rms": ``σ = γ · sqrt(∫ e² dx)``, the reading under
        which δ = 0.005 gives the paper's 4 intervals (knots 0.1478, 0.2268, 0.2749
        against the paper's 0.15003, 0.23099, 0.27900, whose σ are 0.0053–0.0056 by this
        reading and 0.023–0.025 by the printed one).  The result's ``sigma`` follows the
        rule; ``gamma`` stays γ and ``info["sigma_rule"]`` names the rule.

    Exactly one of ``delta``, ``knots``, ``n`` must be given.

    Returns
    -------
    PiecewiseAnalog

    Raises
    ------
    ApproxError
        Bad input, named in the message: non-finite or non-numeric a, b, delta,
        gamma, knots or n; n above ``MAX_N``; f, df or d2f not callable, of the
        wrong shape, or not finite at some x (the x is given).
    """
    a, b = _check_range(a, b)
    chosen = [v is not None for v in (delta, knots, n)]
    if sum(chosen) != 1:
        raise ApproxError("delta, knots, n: give exactly one of delta, knots, n")
    if not isinstance(extrapolate, (bool, np.bool_)):
        raise ApproxError(f"extrapolate: expected True or False, got {extrapolate!r}")
    if not isinstance(sigma_rule, str) or sigma_rule not in SIGMA_RULES:
        raise ApproxError(f"sigma_rule: expected one of {', '.join(SIGMA_RULES)}, got "
                          f"{sigma_rule!r}")
    # check the cheap arguments before any evaluation of f
    if delta is not None:
        delta = as_real(delta, "delta")
        if not delta > 0:
            raise ApproxError(f"delta: expected a positive tolerance, got {delta}")
    if n is not None:
        n = _count(n, "n", 1, MAX_N)
    # knots are placed to 1e-9 of the range (and never finer than a few ulps of x)
    tol = 8 * np.spacing(max(1.0, abs(a), abs(b))) + 1e-9 * (b - a)
    if knots is not None:
        x = _knots(knots)
        if abs(x[0] - a) > tol or abs(x[-1] - b) > tol:
            raise ApproxError(f"knots: must start at a={a} and end at b={b}, got "
                              f"[{x[0]}, {x[-1]}]")
    f, df, d2f = _vectorise(f, "f"), _vectorise(df, "df"), _vectorise(d2f, "d2f")
    gamma_user, rule = _gamma(gamma, d2f, a, b)
    # σ = γ sqrt(∫e²) is formula (1) with the weight γ²: every routine below takes it so
    gamma = gamma_user ** 2 if sigma_rule == "gamma_rms" else gamma_user
    info = {"sigma_rule": sigma_rule}
    if knots is not None:
        method = "knots"
    elif delta is not None:
        x = _greedy(d2f, a, b, delta, gamma, tol, MAX_ADAPTIVE)
        if x is None:
            raise ApproxError(f"delta: more than {MAX_ADAPTIVE} intervals needed for σ ≤ "
                              f"{delta}; expected a larger delta")
        method = f"adaptive, delta={delta}"
    else:
        if n == 1:
            x, top = np.array([a, b]), None
        else:
            eq = _equalise(d2f, a, b, n, gamma)
            if eq is not None:
                x, top = eq[0], float(np.max(eq[1]))
                info["minimax_by"] = "equal sigma (Newton)"
            else:
                x, top = _bracket_minimax(d2f, a, b, n, gamma, tol)
                info["minimax_by"] = "bracketing on delta"
        if top is not None:
            info["minimax_sigma"] = top
        method = f"minimax, n={n}"
    xa = np.array([a])
    an = PiecewiseAnalog.from_values(x, d2f(x), float(f(xa)[0]), float(df(xa)[0]), d2f, gamma,
                                     gamma_rule=rule, method=method, extrapolate=extrapolate,
                                     info=info)
    an.gamma = float(gamma_user)
    return an


def fit_least_squares(f, df, d2f, knots, *, end_conditions: bool = True,
                      gamma: float | None = None, extrapolate: bool = False) -> PiecewiseAnalog:
    """Knot values of F'' by least squares on f'' (beyond the seed).

    Minimises ``∫ (F'' − f'')² dx`` over [a, b] subject to ``F(a) = f(a)``,
    ``F'(a) = f'(a)`` (built in) and, when ``end_conditions``, ``F(b) = f(b)``,
    ``F'(b) = f'(b)``: an equality-constrained linear least-squares problem,
    solved through its KKT system.

    Parameters
    ----------
    f, df, d2f : callable
        As for :func:`fit`.
    knots : array_like (m,)
        Strictly increasing, finite, m ≥ 2; the range is ``[knots[0], knots[-1]]``.
    end_conditions : bool
    gamma : float, optional
        Weight of σ (1); default the seed's rule.
    extrapolate : bool

    Returns
    -------
    PiecewiseAnalog
        σ per interval of the least-squares broken line against f''.
    """
    x = _knots(knots)
    for name, v in (("end_conditions", end_conditions), ("extrapolate", extrapolate)):
        if not isinstance(v, (bool, np.bool_)):
            raise ApproxError(f"{name}: expected True or False, got {v!r}")
    a, b = float(x[0]), float(x[-1])
    f, df, d2f = _vectorise(f, "f"), _vectorise(df, "df"), _vectorise(d2f, "d2f")
    gamma, rule = _gamma(gamma, d2f, a, b)
    m = x.size
    # Gram matrix of the hat functions and right-hand side, Gauss–Legendre (48 points) on
    # every interval at once; the hats in the interval's own coordinate s ∈ [0, 1]
    t, w = np.polynomial.legendre.leggauss(48)
    h2 = 0.5 * np.diff(x)
    xs = (0.5 * (x[:-1] + x[1:]))[:, None] + h2[:, None] * t
    s = (xs - x[:-1, None]) / (2 * h2[:, None])
    ww = w * h2[:, None]
    v = d2f(xs)
    g00, g01, g11 = (np.sum(ww * p, 1) for p in ((1 - s) ** 2, (1 - s) * s, s * s))
    G = np.diag(np.r_[g00, 0.0] + np.r_[0.0, g11]) + np.diag(g01, 1) + np.diag(g01, -1)
    r = np.r_[np.sum(ww * (1 - s) * v, 1), 0.0] + np.r_[0.0, np.sum(ww * s * v, 1)]
    xa, xb = np.array([a]), np.array([b])
    fa, dfa = float(f(xa)[0]), float(df(xa)[0])
    if end_conditions:
        # F'(b) − F'(a) = ∫ F'' = Σ trapezoid weights · y;  F(b) − F(a) − F'(a)(b − a) =
        # ∫ (b − s) F''(s) ds, exact for hats by their moments.
        h = np.diff(x)
        C = np.zeros((2, m))
        C[0] = np.r_[h / 2, 0.0] + np.r_[0.0, h / 2]
        C[1] = (np.r_[h * (b - x[:-1]) / 2 - h * h / 6, 0.0]
                + np.r_[0.0, h * (b - x[:-1]) / 2 - h * h / 3])
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
