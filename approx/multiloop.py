"""Surrogate analogs inside the engine's multi-DOF dynamics: the many-loop use of Kuzmin &
Tomilova's piecewise-linear acceleration analogs.

A machine such as a loader crane or a manipulator arm is made of one-mobility loops
(or one-mobility groups of loops), each driven by its own input (a hydraulic
cylinder): every joint coordinate of a loop is then a function of that loop's input
alone, ``q_c = f_c(x_i)``, whatever the other inputs do (the joint coordinates are
relative ones).  :func:`surrogate_dynamics` finds which input moves each coordinate
from the engine's exact first analogs, fits one surrogate per coordinate over its
input's range from the engine's exact analogs (:class:`LoopAnalogs`, not finite
differences), and hands them to ``Dynamics.reduced``: the reduced model is the exact
Lagrangian system of the surrogate kinematics (the loops are never solved again).
"""
from __future__ import annotations

import time

import numpy as np
import pandas as pd

from closure import REACHED, ClosureError, MechanismError, Pose, analogs

from .analog import ApproxError, as_count, as_points, as_real

__all__ = ["LoopAnalogs", "loop_inputs", "surrogate_dynamics", "ConstantTransfer"]


def _mechanism_of(obj, name):
    if not hasattr(obj, "inputs") or not hasattr(obj, "sweep") or not hasattr(obj, "tree"):
        raise ApproxError(f"{name}: expected a closure.Mechanism, got {type(obj).__name__}")
    if any(j.kind == "S" for j in obj.joints):
        raise ApproxError(f"{name}: the mechanism has a spherical joint; surrogate dynamics "
                          "needs scalar joint coordinates (R, P, C, H, U)")
    return obj


def _hold_of(mech, hold):
    q0 = mech.assembly()[0]
    x_asm = q0[0, mech.input_q_columns()].astype(float)
    if hold is None:
        return x_asm, x_asm
    labels = mech.input_labels()
    if not isinstance(hold, dict):
        raise ApproxError(f"hold: expected a mapping {{input label: value}}, got "
                          f"{type(hold).__name__}")
    h = x_asm.copy()
    for k, v in hold.items():
        if k not in labels:
            raise ApproxError(f"hold: {k!r} is not an input; expected some of "
                              f"{', '.join(labels)}")
        h[labels.index(k)] = as_real(v, f"hold[{k!r}]")
    return x_asm, h


class LoopAnalogs:
    """Exact f, f', f'' of every joint coordinate against one input of a multi-input
    mechanism, the other inputs held (from the engine's velocity and acceleration
    solutions, not finite differences).

    Parameters
    ----------
    mechanism : closure.Mechanism
    input : str
        The input label (``Mechanism.input_labels()``).
    a, b : float
        Its range (m or rad), ``a < b``.
    hold : dict, optional
        Values of the other inputs (default their assembly values).
    samples : int
        Poses of the guiding sweep over [a, b] (≥ 2): each batch is solved from the
        nearest of them.

    Notes
    -----
    ``all(x)`` returns three arrays of shape ``x.shape + (nv,)`` (one column per
    coordinate, ``Mechanism.coordinate_labels()`` order); the last batch is cached,
    so the coordinates of one loop cost one solve per batch.
    """

    def __init__(self, mechanism, input: str, a: float, b: float, *, hold=None,
                 samples: int = 65):
        m = _mechanism_of(mechanism, "mechanism")
        labels = m.input_labels()
        if not isinstance(input, str) or input not in labels:
            raise ApproxError(f"input: expected one of {', '.join(labels)}, got {input!r}")
        a, b = as_real(a, "a"), as_real(b, "b")
        if not a < b:
            raise ApproxError(f"a, b: expected a < b, got a={a}, b={b}")
        samples = as_count(samples, "samples", 2, 100_000)
        self.m, self.input, self.i = m, input, labels.index(input)
        self.a, self.b = a, b
        x_asm, self.hold = _hold_of(m, hold)
        self._cache: dict = {}
        self._index: dict = {}            # input value -> row of the stored solutions
        self._store: list = []
        i = self.i
        xs = np.linspace(a, b, samples)
        start = self.hold.copy()
        start[i] = x_asm[i]
        lead = np.linspace(x_asm, start, 9) if np.any(start != x_asm) else start[None]
        parts = []
        for side in (xs[xs >= start[i]], xs[xs < start[i]][::-1]):
            if not side.size:
                continue
            path = np.repeat(self.hold[None], side.size, 0)
            path[:, i] = side
            df, pose = m.sweep(np.r_[lead, path], return_pose=True)
            if not df.status.isin(REACHED).all():
                bad = df[~df.status.isin(REACHED)].iloc[0]
                raise ApproxError(f"a, b: the mechanism cannot be driven from its assembly "
                                  f"through {input} in [{a}, {b}] (other inputs held at "
                                  f"{self.hold.tolist()}): stopped ({bad.status}) at "
                                  f"{bad.filter(like='reached').tolist()}")
            k = len(lead)
            parts.append((pose.inputs[k:], pose.q[k:], pose.rot[k:]))
        self._guide = [np.concatenate([p[j] for p in parts]) for j in range(3)]
        self._gx = self._guide[0][:, i]
        self._gorder = np.argsort(self._gx, kind="stable")
        self._gx = self._gx[self._gorder]

    def guide(self):
        """The poses of the guiding sweep (a closure Pose, inputs increasing)."""
        inp, q, rot = (g[self._gorder] for g in self._guide)
        z = np.zeros(len(inp))
        return Pose(self.m, inp, q, rot, z, z, z, np.zeros(len(inp), int))

    def _solve(self, x):
        gx = self._gx
        if gx.size > 1:
            j = np.clip(np.searchsorted(gx, x), 1, gx.size - 1)
            j = np.where(np.abs(x - gx[j - 1]) <= np.abs(x - gx[j]), j - 1, j)
        else:
            j = np.zeros(x.size, int)
        near = self._gorder[j]
        inp, q, rot = (g[near] for g in self._guide)
        z = np.zeros(x.size)
        guess = Pose(self.m, inp, q, rot, z, z, z, np.zeros(x.size, int))
        X = np.repeat(self.hold[None], x.size, 0)
        X[:, self.i] = x
        return self.m.solve(X, guess=guess)

    def all(self, x):
        """``(f, f', f'')`` of every coordinate at input values ``x`` (any shape):
        arrays of shape ``x.shape + (nv,)`` (rad or m, per unit input, per unit input²).

        Every point solved is kept: a batch whose points were all solved before (by
        :meth:`prefetch` or earlier calls) costs no solve, and only new points are solved."""
        x = as_points(x, "x")
        key = (x.shape, x.tobytes())
        if key in self._cache:
            return self._cache[key]
        flat = x.ravel()
        nv = self.m.tree.nv
        if flat.size == 0:
            out = (np.zeros(x.shape + (nv,)),) * 3
        else:
            self.prefetch(flat)
            rows = np.fromiter((self._index[v] for v in flat.tolist()), int, flat.size)
            out = tuple(a[rows].reshape(x.shape + (nv,)) for a in self._store)
        if len(self._cache) >= 4:              # the last few batches (the coordinates of
            self._cache.pop(next(iter(self._cache)))    # a loop are fitted on the same x)
        self._cache[key] = out
        return out

    def prefetch(self, x) -> None:
        """Solve, in one batch, the points of ``x`` not solved before (kept for
        :meth:`all`)."""
        flat = as_points(x, "x").ravel()
        new = sorted({v for v in flat.tolist() if v not in self._index})
        if not new:
            return
        xs = np.array(new)
        try:
            pose = self._solve(xs)
        except ClosureError as e:
            raise ApproxError(f"x: the mechanism cannot reach every {self.input} in "
                              f"[{xs.min()}, {xs.max()}]: {e}") from None
        first, second = analogs(self.m, pose)
        base = len(self._index)
        self._index.update((v, base + k) for k, v in enumerate(new))
        add = (pose.q, first[:, :, self.i], second[:, :, self.i, self.i])
        self._store = [np.concatenate([s, a]) for s, a in zip(self._store, add)] \
            if self._store else [np.array(a) for a in add]

    def coordinate(self, c: int):
        """The exact ``(f, f', f'')`` of coordinate column ``c`` as three vectorised
        callables."""
        return (lambda x: self.all(x)[0][..., c], lambda x: self.all(x)[1][..., c],
                lambda x: self.all(x)[2][..., c])


class ConstantTransfer:
    """A coordinate that no input moves: F = value, F' = F'' = 0."""

    def __init__(self, value: float):
        self.value = float(value)

    def _like(self, x, v):
        return v if isinstance(x, (float, int)) else np.full(np.shape(x), v)

    def position(self, x):
        return self._like(x, self.value)

    def velocity(self, x):
        return self._like(x, 0.0)

    def acceleration(self, x):
        return self._like(x, 0.0)

    def kernel_form(self) -> dict:
        """One constant piece, for a compiled model
        (:meth:`approx.analog._Pieces.kernel_form`)."""
        return {"pieces": (np.zeros(1), np.full((1, 1), self.value), np.zeros(0), 0.0, 0.0)}


def loop_inputs(mechanism, ranges, *, hold=None, samples: int = 9, rel_tol: float = 1e-8,
                _loops=None):
    """Which input moves each joint coordinate, from the engine's exact first analogs.

    The analogs are taken at ``samples`` values of each input over its range (the others
    held) and at two corners of the box of ranges; coordinate c belongs to input i when
    ``max |∂q_c/∂x_i| · width_i`` exceeds ``rel_tol`` times the largest such figure of
    c (below it, a coupling is negligible).

    Parameters
    ----------
    mechanism : closure.Mechanism
    ranges : dict
        ``{input label: (low, high)}`` for every input.
    hold : dict, optional
        Values of the inputs not being varied (default their assembly values).
    samples : int
        Values of each input (≥ 2).

    Returns
    -------
    numpy.ndarray of int, shape (nv,)
        The input index of every coordinate (inputs map to themselves), −1 for a
        coordinate that no input moves.

    Raises
    ------
    ApproxError
        A coordinate that two inputs move (the mechanism is not made of loops driven
        by independent inputs), naming it.
    """
    m = _mechanism_of(mechanism, "mechanism")
    ranges = _ranges_of(m, ranges)
    labels = m.input_labels()
    lo = np.array([ranges[k][0] for k in labels])
    hi = np.array([ranges[k][1] for k in labels])
    _, h = _hold_of(m, hold)
    loops = _loops or [LoopAnalogs(m, k, *ranges[k], hold=hold, samples=samples)
                       for k in labels]
    first = [analogs(m, lp.guide(), second=False)[0] for lp in loops]
    if len(labels) > 1:                  # two corners of the box, by continuation
        for corner in (np.where(np.arange(len(labels)) % 2, lo, hi), lo):
            df, pose = m.sweep(np.linspace(h, corner, 9), return_pose=True)
            if not df.status.isin(REACHED).all():
                raise ApproxError(f"ranges: the mechanism cannot reach inputs "
                                  f"{corner.tolist()} from {h.tolist()} "
                                  f"({df.status.iloc[-1]})")
            first.append(analogs(m, pose, second=False)[0])
    first = np.concatenate(first)
    size = np.abs(first).max(0) * (hi - lo)              # (nv, ni)
    top = size.max(1)
    out = np.full(m.tree.nv, -1)
    names = m.coordinate_labels()
    for c in range(m.tree.nv):
        if top[c] == 0:
            continue
        dep = np.nonzero(size[c] > rel_tol * top[c])[0]
        if dep.size > 1:
            raise ApproxError(f"dynamics: coordinate {names[c]!r} moves with inputs "
                              f"{', '.join(labels[k] for k in dep)}; a reduced model needs "
                              "loops each driven by one input")
        out[c] = dep[0]
    return out


def _ranges_of(mech, ranges):
    labels = mech.input_labels()
    if not isinstance(ranges, dict):
        raise ApproxError(f"ranges: expected a mapping {{input label: (low, high)}} for "
                          f"every input ({', '.join(labels)}), got {type(ranges).__name__}")
    out = {}
    for k in labels:
        if k not in ranges:
            raise ApproxError(f"ranges: no range for input {k!r}; expected one for each of "
                              f"{', '.join(labels)}")
    for k, v in ranges.items():
        if k not in labels:
            raise ApproxError(f"ranges: {k!r} is not an input; expected some of "
                              f"{', '.join(labels)}")
        a = as_points(v, f"ranges[{k!r}]")
        if a.shape != (2,) or not a[0] < a[1]:
            raise ApproxError(f"ranges[{k!r}]: expected (low, high) with low < high, got {v!r}")
        out[k] = (float(a[0]), float(a[1]))
    return out


#: degree of the Chebyshev proxy of f'' on which the linear and spline kinds place their
#: knots (the minimax placement asks for f'' at thousands of points; the proxy is a
#: polynomial, the surrogate's values at the knots come from the engine)
PROXY_DEGREE = 64


def _proxy(d2f, a, b):
    """The Chebyshev interpolant of f'' of degree PROXY_DEGREE, integrated twice from 0
    (only its f'' matters for the knots): one batch of the engine, shared by the
    coordinates of a loop."""
    from numpy.polynomial import chebyshev as C

    from .surrogate import ChebyshevAnalog
    m = PROXY_DEGREE
    u = C.chebpts1(m + 1)
    c2 = C.chebfit(u, d2f(0.5 * (a + b) + 0.5 * (b - a) * u), m)
    c1 = C.chebint(c2, lbnd=-1, scl=0.5 * (b - a))
    c0 = C.chebint(c1, lbnd=-1, scl=0.5 * (b - a))
    coef = np.zeros((m + 3, 3))
    coef[:, 0], coef[:m + 2, 1], coef[:m + 1, 2] = c0, c1, c2
    return ChebyshevAnalog(a, b, coef, m, extrapolate=True)


def _knots(kind, size, d2f, a, b):
    """The knots of a ``linear`` or ``spline`` fit of ``size`` intervals (minimax, equal σ,
    on a Chebyshev proxy of f'' of degree PROXY_DEGREE) and the proxy (None for one
    interval)."""
    from .fit import fit
    if size == 1:
        return np.array([a, b]), None
    proxy = _proxy(d2f, a, b)
    return fit(proxy.position, proxy.velocity, proxy.acceleration, a, b, n=size).knots, proxy


def _nodes(kind, knots):
    """Where the fits on ``knots`` ask for the exact analogs: the knots, the Gauss–Legendre
    nodes of the error estimate on every interval and, for ``linear``, those of its σ
    integrals (the same arithmetic as theirs, so that one batch serves them all)."""
    from .analog import _GL16, _NODES
    x0, x1 = knots[:-1], knots[1:]
    h = 0.5 * (x1 - x0)
    mid = 0.5 * (x0 + x1)
    parts = [knots, (mid[:, None] + h[:, None] * _GL16[0]).ravel()]
    if kind == "linear":
        parts.append((mid[:, None] + h[:, None] * _NODES).ravel())
    return np.concatenate(parts)


def _fit_one(kind, size, f, df, d2f, a, b, knots=None, proxy=None):
    """One surrogate of exact analogs (f, df, d2f) on [a, b]: ``chebyshev`` directly;
    ``linear`` and ``spline`` on the minimax knots (equal σ) for ``size`` intervals,
    placed on a Chebyshev proxy of degree PROXY_DEGREE (see :func:`_knots`; given
    ``knots`` are used as they are), with f'' (and f(a), f'(a), σ) from the exact analogs
    at those knots."""
    from .fit import MAX_N, default_gamma, fit
    from .surrogate import MAX_DEGREE, fit_chebyshev, fit_spline
    if kind == "chebyshev":
        return fit_chebyshev(f, df, d2f, a, b, degree=as_count(size, "size", 0, MAX_DEGREE))
    size = as_count(size, "size", 1, MAX_N)
    if knots is None:
        knots, proxy = _knots(kind, size, d2f, a, b)
    if kind == "linear":       # γ (for σ only): 1/(max f'' − min f'') on the proxy
        gamma = default_gamma(proxy.acceleration, a, b) if proxy is not None else None
        return fit(f, df, d2f, a, b, knots=knots, gamma=gamma)
    return fit_spline(f, df, d2f, a, b, knots=knots)


def surrogate_dynamics(dynamics, *, ranges: dict, kind: str = "spline", size: int = 8,
                       hold=None, samples: int = 65):
    """The dynamics of ``dynamics`` with every loop closure replaced by surrogate analogs.

    Parameters
    ----------
    dynamics : closure.Dynamics
        A mechanism made of one-mobility loops, each driven by its own input (e.g. the
        hydraulic cylinders of a crane), with its bodies and elements.
    ranges : dict
        ``{input label: (low, high)}`` for every input (m or rad): where each surrogate
        is fitted (once) and where the reduced model holds.
    kind : {"linear", "spline", "chebyshev"}
        The surrogate family (:data:`approx.KINDS`): the broken line on f'' (Kuzmin &
        Tomilova), the cubic spline on f'' (both with ``size`` intervals on the minimax knots,
        placed on a degree-64 Chebyshev proxy of the exact f''; their values at the
        knots are the engine's), or one Chebyshev interpolant of f'' of degree ``size``.
    size : int
        Intervals (linear, spline; 1 … MAX_N) or degree (chebyshev; 0 … MAX_DEGREE).
    hold : dict, optional
        Values at which the other inputs are held while one loop is fitted (default
        their assembly values; the loops' coordinates do not depend on them).
    samples : int
        Poses of each loop's guiding sweep (≥ 2).

    Returns
    -------
    closure.reduced.ReducedDynamics
        With ``.info["fits"]``: a DataFrame, one row per coordinate: ``coordinate,
        input, kind, size, fit_s, max_abs_F, max_abs_dF, max_abs_d2F`` (errors against
        the engine on 401 points of the range), and ``.info["fit_s"]``, the total time.

    Raises
    ------
    ApproxError
        Bad arguments (named), a coordinate moved by two inputs, or a range the
        mechanism cannot be driven through.
    """
    from closure import Dynamics

    from .surrogate import KINDS

    if not isinstance(dynamics, Dynamics):
        raise ApproxError(f"dynamics: expected a closure.Dynamics, got "
                          f"{type(dynamics).__name__}")
    mech = _mechanism_of(dynamics.m, "dynamics")
    if not isinstance(kind, str) or kind not in KINDS:
        raise ApproxError(f"kind: expected one of {', '.join(KINDS)}, got {kind!r}")
    from .fit import MAX_N
    from .surrogate import MAX_DEGREE
    size = as_count(size, "size", 0 if kind == "chebyshev" else 1,
                    MAX_DEGREE if kind == "chebyshev" else MAX_N)
    samples = as_count(samples, "samples", 2, 100_000)
    ranges = _ranges_of(mech, ranges)
    t_start = time.perf_counter()
    labels = mech.coordinate_labels()
    inputs = mech.input_labels()
    loops = [LoopAnalogs(mech, k, *ranges[k], hold=hold, samples=samples) for k in inputs]
    owner = loop_inputs(mech, ranges, hold=hold, _loops=loops)
    inp = set(mech.input_columns().tolist())
    transfers, rows = {}, []
    q_asm = mech.assembly()[0][0]
    for i, name in enumerate(inputs):
        cols = [c for c in range(len(labels)) if owner[c] == i and c not in inp]
        if not cols:
            continue
        a, b = ranges[name]
        loop = loops[i]
        xs = np.linspace(a, b, 401)
        placed = {}
        if kind != "chebyshev":    # every coordinate's knots first, then one batch for all
            t0 = time.perf_counter()
            placed = {c: _knots(kind, size, loop.coordinate(c)[2], a, b) for c in cols}
            loop.prefetch(np.concatenate([xs, [a, b]] + [_nodes(kind, k) for k, _ in
                                                          placed.values()]))
            t_knots = (time.perf_counter() - t0) / len(cols)
        for c in cols:
            f, df, d2f = loop.coordinate(c)
            t0 = time.perf_counter()
            s = _fit_one(kind, size, f, df, d2f, a, b, *placed.get(c, (None, None)))
            s.extrapolate = True            # the reduced model stops at the range's ends
            t_fit = time.perf_counter() - t0 + (t_knots if placed else 0.0)
            F, F1, F2 = s.all(xs) if hasattr(s, "all") else \
                (s.position(xs), s.velocity(xs), s.acceleration(xs))
            rows.append({"coordinate": labels[c], "input": name, "kind": kind, "size": size,
                         "fit_s": t_fit, "max_abs_F": float(np.abs(F - f(xs)).max()),
                         "max_abs_dF": float(np.abs(F1 - df(xs)).max()),
                         "max_abs_d2F": float(np.abs(F2 - d2f(xs)).max())})
            transfers[labels[c]] = (name, s)
    for c in range(len(labels)):
        if owner[c] < 0:
            transfers[labels[c]] = (inputs[0], ConstantTransfer(q_asm[c]))
    try:
        red = dynamics.reduced(transfers, ranges)
    except MechanismError as e:
        raise ApproxError(str(e)) from None
    red.info["fits"] = pd.DataFrame(rows)
    red.info["fit_s"] = time.perf_counter() - t_start
    red.info["kind"], red.info["size"] = kind, size
    return red
