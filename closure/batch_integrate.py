"""Batched explicit Runge–Kutta integration: B independent ODE systems in lockstep.

:func:`integrate_batch` advances B independent initial-value problems
``y_b' = f(t, y_b)`` (different designs, parameters or initial states) together.
Each member keeps its own time, step size and error control; the members move in
lockstep only in the sense that one pass of the step loop makes one step *attempt*
for every member still running, and each Runge–Kutta stage evaluates the
right-hand side of all those members in one vectorised call::

    rhs(t, y, members) -> dydt                    # t (A,), y (A, m), members (A,)
    rhs(t, y, members) -> (dydt, failed)          # failed (A,) bool or str

The step-size controller is scipy's (``scipy.integrate._ivp.rk``): the same
initial step (``select_initial_step``), error norm, ``SAFETY``, ``MIN_FACTOR``,
``MAX_FACTOR``, error exponent, rejection rule, clipping to the end of the span
and first-same-as-last, and the same dense output (Dormand–Prince's quartic for
RK45, the 7th-order interpolant for DOP853).  A member's trajectory is therefore
the one ``scipy.integrate.solve_ivp(method=...)`` gives for that member alone: the
same sequence of accepted and rejected steps, the same ``nfev``, and states equal
to rounding (~1e-12 relative).  The step times agree to rounding amplified by the
controller: where the error estimate is far below the tolerance it is itself
rounding noise (scipy sums the stages by BLAS, this module element-wise), and the
next step size follows it as ``err^(-1/(order+1))``.  Which other members share the
batch, or their order, does not change a member's result, bit for bit: every
operation is element-wise over the members (``einsum`` without BLAS, row-wise
reductions).

Example
-------
>>> w = np.array([1.0, 2.0, 3.0])                   # a parameter per member (rad/s)
>>> def rhs(t, y, members):                         # harmonic oscillators
...     return np.stack([y[:, 1], -w[members] ** 2 * y[:, 0]], axis=1)
>>> res = integrate_batch(rhs, (0.0, 10.0), np.tile([1.0, 0.0], (3, 1)),
...                       t_eval=np.linspace(0, 10, 101), rtol=1e-8, atol=1e-10)
>>> res.y.shape, res.status.tolist()
((3, 2, 101), [0, 0, 0])

A member stops, and the others go on, when

- it reaches the end of the span (status 0);
- the right-hand side reports it failed (a dead point, a pose that does not close)
  by its ``failed`` output, or returns a non-finite row for it (status 1): the
  member stops at the start of the step being attempted (``t_end`` is its last
  accepted time) and its message says why;
- its step size falls below ten times the spacing of floating-point numbers at
  its time (status -1, as in scipy).

Unlike scipy, a non-finite derivative stops the member at once (scipy would keep
rejecting and shrinking the step until it is too small).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Callable, Sequence, Union

import numpy as np
from scipy.integrate import DOP853, RK45

from .errors import MechanismError

__all__ = ["BatchResult", "integrate_batch", "BATCH_METHODS", "FINISHED", "STOPPED",
           "STEP_TOO_SMALL", "SAFETY", "MIN_FACTOR", "MAX_FACTOR"]

#: scipy's step-size controller constants (``scipy.integrate._ivp.rk``)
SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0

#: member status codes
FINISHED, STOPPED, STEP_TOO_SMALL = 0, 1, -1
_RUNNING = -2

#: scipy's messages for statuses 0 and -1
_MSG_FINISHED = "The solver successfully reached the end of the integration interval."
_MSG_TOO_SMALL = "Required step size is less than spacing between numbers."

_EPS = np.finfo(float).eps

#: the right-hand side: ``rhs(t (A,), y (A, m), members (A,)) -> (A, m)`` or
#: ``-> ((A, m), failed (A,))``
RHS = Callable[[np.ndarray, np.ndarray, np.ndarray],
               Union[np.ndarray, "tuple[np.ndarray, np.ndarray]"]]


class _Tableau:
    """A scipy explicit Runge–Kutta method's coefficients (taken from its class)."""

    def __init__(self, cls):
        self.name = cls.__name__
        self.n_stages = cls.n_stages
        self.order = cls.error_estimator_order
        self.exponent = -1 / (cls.error_estimator_order + 1)
        self.C = [float(c) for c in cls.C]
        self.A = [np.array(cls.A[s, :s], dtype=float) for s in range(cls.n_stages)]
        self.B = np.array(cls.B, dtype=float)
        self.dop853 = cls is DOP853
        if self.dop853:
            self.E5, self.E3 = np.array(cls.E5, dtype=float), np.array(cls.E3, dtype=float)
            s0 = cls.n_stages + 1
            self.A_extra = [np.array(a[:s0 + k], dtype=float) for k, a in enumerate(cls.A_EXTRA)]
            self.C_extra = [float(c) for c in cls.C_EXTRA]
            self.D = np.array(cls.D, dtype=float)
        else:
            self.E = np.array(cls.E, dtype=float)
            self.P = np.array(cls.P, dtype=float)


#: the methods, by scipy's names
BATCH_METHODS = {"RK45": _Tableau(RK45), "DOP853": _Tableau(DOP853)}


def _combo(coef: np.ndarray, K: np.ndarray) -> np.ndarray:
    """``Σ_j coef[j] K[j]`` over the first ``len(coef)`` rows of ``K`` (S, A, m) -> (A, m).

    ``einsum`` accumulates the terms in order, element by element (no BLAS), so a
    member's value does not depend on the other members or its position."""
    return np.einsum("s,sam->am", coef, K[:coef.size])


def _rms(x: np.ndarray) -> np.ndarray:
    """Root-mean-square of each row of ``x`` (A, m): scipy's ``norm``."""
    return np.sqrt((x * x).sum(axis=1)) / x.shape[1] ** 0.5


@dataclass
class BatchResult:
    """What :func:`integrate_batch` did for each member.

    Attributes
    ----------
    t_eval : (N,) ndarray
        Output times (units of ``t``, e.g. s).
    y : (B, m, N) ndarray
        State of each member at the output times; NaN at the times after the
        member stopped (``t_eval`` beyond ``t_end``).
    t_end : (B,) ndarray
        Time each member reached: ``t1`` when finished, else its last accepted time.
    y_end : (B, m) ndarray
        State of each member at ``t_end``.
    status : (B,) int ndarray
        0 reached the end of the span, 1 stopped by the right-hand side, -1 step
        size too small.
    message : (B,) object ndarray of str
        Why each member stopped.
    nfev : (B,) int ndarray
        Right-hand-side evaluations of each member (rows passed to ``rhs``; equals
        scipy's ``nfev`` for the member alone).
    steps : (B,) int ndarray
        Accepted steps.
    rejected : (B,) int ndarray
        Rejected step attempts.
    method : str
    t_steps : (B, S + 1) ndarray or None
        With ``keep_steps``: ``t0`` and the time after each accepted step, NaN-padded
        to the largest step count S.
    y_steps : (B, m, S + 1) ndarray or None
        With ``keep_steps``: the states at ``t_steps``.
    """

    t_eval: np.ndarray
    y: np.ndarray
    t_end: np.ndarray
    y_end: np.ndarray
    status: np.ndarray
    message: np.ndarray
    nfev: np.ndarray
    steps: np.ndarray
    rejected: np.ndarray
    method: str
    t_steps: np.ndarray | None = None
    y_steps: np.ndarray | None = None

    @property
    def success(self) -> np.ndarray:
        """(B,) bool: the member did not fail (a stop by the right-hand side is a success,
        like a terminal event in scipy)."""
        return self.status >= 0


# ---------------------------------------------------------------- input checks

def _real(value, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise MechanismError(f"{name} must be a real number; got {value!r}") from None
    return v


def _check_inputs(rhs, t_span, y0, method, t_eval, rtol, atol, max_step, first_step,
                  keep_steps):
    if not callable(rhs):
        raise MechanismError(f"rhs must be callable as rhs(t, y, members); got {type(rhs).__name__}")
    if not isinstance(method, str) or method not in BATCH_METHODS:
        raise MechanismError(f"method must be one of {sorted(BATCH_METHODS)}; got {method!r}")
    try:
        span = np.asarray(t_span, dtype=float)
    except (TypeError, ValueError):
        raise MechanismError(f"t_span must be a pair (t0, t1) of finite times; got {t_span!r}") from None
    if span.shape != (2,) or not np.isfinite(span).all():
        raise MechanismError(f"t_span must be a pair (t0, t1) of finite times; got {t_span!r}")
    t0, t1 = float(span[0]), float(span[1])

    if np.iscomplexobj(y0):
        raise MechanismError("y0 must be real (complex states are not supported)")
    try:
        y = np.array(y0, dtype=float)
    except (TypeError, ValueError):
        raise MechanismError("y0 must be a real (B, m) array of initial states") from None
    if y.ndim != 2 or y.shape[0] < 1 or y.shape[1] < 1:
        raise MechanismError(f"y0 must be a (B, m) array with B ≥ 1 members and m ≥ 1 "
                             f"components; got shape {y.shape}")
    if not np.isfinite(y).all():
        bad = np.nonzero(~np.isfinite(y).all(axis=1))[0]
        raise MechanismError(f"y0 must be finite; members {bad[:10].tolist()} are not")
    B, m = y.shape

    try:
        r = np.asarray(rtol, dtype=float)
    except (TypeError, ValueError):
        raise MechanismError(f"rtol must be a positive number or a (B,) array; got {rtol!r}") from None
    if r.ndim > 1 or (r.ndim == 1 and r.shape != (B,)):
        raise MechanismError(f"rtol must be a scalar or a (B,) = ({B},) array; got shape {r.shape}")
    if not (np.isfinite(r) & (r > 0)).all():
        raise MechanismError(f"rtol must be positive and finite; got {rtol!r}")
    if (r < 100 * _EPS).any():
        warnings.warn(f"At least one element of `rtol` is too small. Setting "
                      f"`rtol = np.maximum(rtol, {100 * _EPS})`.", stacklevel=3)
        r = np.maximum(r, 100 * _EPS)
    try:
        a = np.asarray(atol, dtype=float)
        a_full = np.broadcast_to(a, (B, m))
    except (TypeError, ValueError):
        raise MechanismError(f"atol must be a positive number or an array broadcastable to "
                             f"(B, m) = ({B}, {m}) (per component: (m,); per member: "
                             f"(B, 1)); got {np.shape(atol) if not isinstance(atol, str) else atol!r}") from None
    if not (np.isfinite(a) & (a > 0)).all():
        raise MechanismError(f"atol must be positive and finite; got {atol!r}")

    ms = _real(max_step, "max_step")
    if not ms > 0:
        raise MechanismError(f"max_step must be positive; got {max_step!r}")
    fs = None
    if first_step is not None:
        fs = _real(first_step, "first_step")
        if not fs > 0:
            raise MechanismError(f"first_step must be positive; got {first_step!r}")
        if fs > abs(t1 - t0):
            raise MechanismError(f"first_step must not exceed the span |t1 - t0| = "
                                 f"{abs(t1 - t0):g}; got {first_step!r}")

    if t_eval is None:
        te = np.empty(0)
    else:
        try:
            te = np.array(t_eval, dtype=float)
        except (TypeError, ValueError):
            raise MechanismError("t_eval must be a 1-D array of times") from None
        if te.ndim != 1:
            raise MechanismError(f"t_eval must be 1-D; got shape {te.shape}")
        if not np.isfinite(te).all():
            raise MechanismError("t_eval must be finite")
        if ((te < min(t0, t1)) | (te > max(t0, t1))).any():
            raise MechanismError(f"t_eval must lie within t_span [{min(t0, t1):g}, "
                                 f"{max(t0, t1):g}]")
        dt = np.diff(te)
        if (t1 > t0 and (dt <= 0).any()) or (t1 < t0 and (dt >= 0).any()):
            raise MechanismError("t_eval must be strictly " +
                                 ("increasing" if t1 > t0 else "decreasing") +
                                 " (in the direction of t_span)")
    if not isinstance(keep_steps, (bool, np.bool_)):
        raise MechanismError(f"keep_steps must be a bool; got {keep_steps!r}")
    return t0, t1, y, np.broadcast_to(r, (B,))[:, None].copy(), a_full.copy(), ms, fs, te


# ---------------------------------------------------------------- the batch state

class _Work:
    """The running members' row-aligned arrays (compacted when members leave)."""

    __slots__ = ("idx", "t", "y", "f", "h_abs", "retry", "ie", "rtol", "atol", "nfev", "steps",
                 "rejected")

    def take(self, keep: np.ndarray) -> None:
        for name in self.__slots__:
            setattr(self, name, getattr(self, name)[keep])
        self.idx.flags.writeable = False        # passed to rhs as ``members``


class _Out:
    """Per-member results (indexed by the member's position in the batch)."""

    def __init__(self, B, m, N, t0, y0):
        self.y = np.full((B, m, N), np.nan)
        self.t_end = np.full(B, t0)
        self.y_end = y0.copy()
        self.status = np.full(B, _RUNNING)
        self.message = np.full(B, "", dtype=object)
        self.nfev = np.zeros(B, dtype=np.int64)
        self.steps = np.zeros(B, dtype=np.int64)
        self.rejected = np.zeros(B, dtype=np.int64)

    def stop(self, w: _Work, rows: np.ndarray, code: int, messages) -> None:
        """Members ``w.idx[rows]`` stop at their current (last accepted) time."""
        g = w.idx[rows]
        self.status[g] = code
        self.t_end[g] = w.t[rows]
        self.y_end[g] = w.y[rows]
        self.nfev[g] = w.nfev[rows]
        self.steps[g] = w.steps[rows]
        self.rejected[g] = w.rejected[rows]
        if isinstance(messages, str):
            self.message[g] = messages
        else:
            for k, msg in zip(g, messages):
                self.message[k] = msg


def _frozen(a: np.ndarray) -> np.ndarray:
    """A read-only view of ``a`` (``rhs`` must not change the integrator's arrays)."""
    v = a.view()
    v.flags.writeable = False
    return v


def _evaluate(rhs, t, y, members):
    """One vectorised call of ``rhs`` on A members (the caller counts ``nfev``).

    Returns ``(dydt (A, m), bad (A,) bool, reasons)``: ``reasons`` is None when no row
    is bad, else the messages of the bad rows."""
    A, m = y.shape
    res = rhs(t, y, members)
    failed = None
    if isinstance(res, tuple):
        if len(res) != 2:
            raise MechanismError("rhs must return dydt (A, m) or a pair (dydt, failed)")
        res, failed = res
    f = np.asarray(res, dtype=float)
    if f.shape != (A, m):
        raise MechanismError(f"rhs returned shape {f.shape}; expected (A, m) = ({A}, {m}) "
                             "for A members")
    flag = None
    if failed is not None:
        fl = np.asarray(failed)
        if fl.shape != (A,):
            raise MechanismError(f"rhs: failed must have shape (A,) = ({A},); got {fl.shape}")
        if fl.dtype.kind == "b":
            flag = fl
        elif fl.dtype.kind in "US":
            flag = np.char.str_len(fl) > 0
        elif fl.dtype.kind == "O":
            flag = np.fromiter((bool(s) for s in fl), bool, count=A)
        else:
            raise MechanismError(f"rhs: failed must be a bool or str array; got dtype {fl.dtype}")
    if np.isfinite(np.add.reduce(f, axis=None)) and (flag is None or not flag.any()):
        return f, None, None                     # the common case: one reduction
    bad = ~np.isfinite(f).all(axis=1)
    if flag is not None:
        bad |= flag
    if not bad.any():                            # finite rows whose sum overflowed
        return f, None, None
    reasons = []
    for i in np.nonzero(bad)[0]:
        if flag is not None and flag[i]:
            why = str(fl[i]) if fl.dtype.kind != "b" else "failed"
            reasons.append(f"stopped by the right-hand side at t = {t[i]:.9g}: {why}")
        else:
            reasons.append(f"stopped: the right-hand side returned non-finite values at "
                           f"t = {t[i]:.9g}")
    return f, bad, reasons


# ---------------------------------------------------------------- the integrator

def integrate_batch(rhs: RHS, t_span: Sequence[float], y0: np.ndarray, *,
                    method: str = "RK45", t_eval: np.ndarray | None = None,
                    rtol: float | np.ndarray = 1e-3, atol: float | np.ndarray = 1e-6,
                    max_step: float = np.inf, first_step: float | None = None,
                    keep_steps: bool = False) -> BatchResult:
    """Integrate B independent systems ``y_b' = f(t, y_b)`` over ``t_span`` in lockstep.

    Parameters
    ----------
    rhs : callable
        ``rhs(t, y, members)`` with ``t`` (A,) the times of the A members being
        evaluated, ``y`` (A, m) their states and ``members`` (A,) int their indices in
        the batch (ascending; use them to look up per-member parameters).  Returns
        ``dydt`` (A, m), or ``(dydt, failed)`` with ``failed`` (A,) bool, or (A,) str
        where a non-empty string is the reason.  A failed row, or a row of ``dydt``
        with a non-finite value, stops that member (status 1).  ``rhs`` must not
        modify its arguments (``members`` and the states kept are read-only).
    t_span : (2,) float
        ``(t0, t1)``, common to all members (units of t, e.g. s); ``t1 < t0``
        integrates backwards.
    y0 : (B, m) array_like
        Initial states, finite.
    method : {"RK45", "DOP853"}
        Dormand–Prince 5(4) or 8(5,3), as scipy's classes of these names.
    t_eval : (N,) array_like, optional
        Output times within ``t_span``, strictly monotonic in its direction; each
        member's state there comes from the dense output of the accepted step that
        covers it (scipy's rule: the step ``(t_old, t_new]``; a point at ``t0`` is
        ``y0``).  None: no dense output (N = 0; see ``y_end``).
    rtol : float or (B,) array
        Relative tolerance, positive (values below 100 eps are raised to it with a
        warning, as scipy does).
    atol : float or array broadcastable to (B, m)
        Absolute tolerance (units of y), positive: (m,) per component, (B, 1) per
        member.
    max_step : float
        Largest step (units of t), positive; default unbounded.
    first_step : float, optional
        First step (units of t), in ``(0, |t1 - t0|]``; default: scipy's
        ``select_initial_step`` for each member.
    keep_steps : bool
        Also return the accepted step times and states (``t_steps``, ``y_steps``).

    Returns
    -------
    BatchResult

    Raises
    ------
    MechanismError
        (a ``ValueError``) for bad input, naming the argument; or when ``rhs``
        returns an array of the wrong shape.

    Notes
    -----
    One pass of the step loop makes one step attempt for every running member;
    each stage is one ``rhs`` call on all of them.  Per member, the attempt, the
    error norm ``‖err / (atol + max(|y|, |y_new|) rtol)‖ / √m``, the acceptance and
    the next step size are scipy's, so the accepted steps are those of
    ``solve_ivp(method=method)`` for the member alone; ``nfev`` counts as scipy's
    (2 at the start, ``n_stages`` per attempt, 3 per dense output of DOP853).
    The arithmetic is element-wise over members (no BLAS), so a member's result is
    bit-for-bit independent of the batch it is in; it agrees with scipy's (which
    sums the stages by BLAS) to rounding, amplified in the step times where the
    error estimate is itself at rounding level (see the module docstring).

    The cost per pass is a fixed Python/numpy overhead (~0.15 ms for RK45) plus
    ~0.3 µs per member (m = 2), besides ``rhs``: from B ≈ 100 on, a member-step
    costs under 5 % of a step of scipy's single-trajectory ``solve_ivp``.
    """
    t0, t1, y0, rtol_b, atol_b, max_step, first_step, te = _check_inputs(
        rhs, t_span, y0, method, t_eval, rtol, atol, max_step, first_step, keep_steps)
    tab = BATCH_METHODS[method]
    B, m = y0.shape
    N = te.size
    d = 1.0 if t1 >= t0 else -1.0
    te_dir = d * te                              # increasing
    out = _Out(B, m, N, t0, y0)
    if N:
        out.y[:, :, te == t0] = y0[:, :, None]   # the dense output there is y0 exactly

    w = _Work()
    w.idx = np.arange(B)
    w.idx.flags.writeable = False
    w.t = np.full(B, t0)
    w.y = y0.copy()
    w.rtol, w.atol = rtol_b, atol_b
    w.ie = np.zeros(B, dtype=np.int64)
    w.retry = np.zeros(B, dtype=bool)
    w.nfev = np.ones(B, dtype=np.int64)
    w.steps = np.zeros(B, dtype=np.int64)
    w.rejected = np.zeros(B, dtype=np.int64)
    w.h_abs = np.zeros(B)
    records = []

    # the derivative at t0
    f, bad, why = _evaluate(rhs, _frozen(w.t), _frozen(y0), w.idx)
    w.f = f.copy()
    if why is not None:
        out.stop(w, bad, STOPPED, why)
        w.take(~bad)
    span = abs(t1 - t0)
    if span == 0.0:                              # nothing to integrate (scipy: finished at once)
        out.stop(w, np.ones(w.idx.size, bool), FINISHED, _MSG_FINISHED)
        w.take(np.zeros(w.idx.size, bool))
    elif first_step is not None:
        w.h_abs = np.full(w.idx.size, first_step)
    elif w.idx.size:                             # scipy's select_initial_step, per member
        scale = w.atol + np.abs(w.y) * w.rtol
        d0, d1 = _rms(w.y / scale), _rms(w.f / scale)
        with np.errstate(divide="ignore", invalid="ignore"):
            h0 = np.where((d0 < 1e-5) | (d1 < 1e-5), 1e-6, 0.01 * d0 / d1)
        h0 = np.minimum(h0, span)
        w.nfev += 1
        f1, bad, why = _evaluate(rhs, w.t + h0 * d, w.y + (h0 * d)[:, None] * w.f, w.idx)
        d2 = _rms((f1 - w.f) / scale) / h0
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            h1 = np.where((d1 <= 1e-15) & (d2 <= 1e-15), np.maximum(1e-6, h0 * 1e-3),
                          (0.01 / np.where(d1 > d2, d1, d2)) ** (1 / (tab.order + 1)))
        w.h_abs = np.minimum(np.minimum(np.minimum(100 * h0, h1), span), max_step)
        if why is not None:
            out.stop(w, bad, STOPPED, why)
            w.take(~bad)

    S = tab.n_stages
    while w.idx.size:
        # step start: clip to [min_step, max_step] (fresh steps), give up below min_step
        min_step = 10 * np.abs(np.nextafter(w.t, d * np.inf) - w.t)
        clipped = np.where(w.h_abs > max_step, max_step, np.maximum(w.h_abs, min_step))
        h_abs = np.where(w.retry, w.h_abs, clipped)
        small = h_abs < min_step
        if small.any():
            out.stop(w, small, STEP_TOO_SMALL, _MSG_TOO_SMALL)
            w.take(~small)
            h_abs = h_abs[~small]
            if not w.idx.size:
                break
        h = h_abs * d
        t_new = w.t + h
        t_new = np.where(d * (t_new - t1) > 0, t1, t_new)
        h = t_new - w.t
        h_abs = np.abs(h)
        hc = h[:, None]

        # the stages; the last one is f at the new state (first same as last)
        K = np.empty((S + 1, w.idx.size, m))
        K[0] = w.f
        w.nfev += S
        for s in range(1, S + 1):
            if s < S:
                ts = w.t + tab.C[s] * h
                ys = w.y + _combo(tab.A[s], K) * hc
            else:
                ts = w.t + h
                y_new = w.y + hc * _combo(tab.B, K)
                ys = _frozen(y_new)
            k, bad, why = _evaluate(rhs, ts, ys, w.idx)
            if why is not None:
                w.nfev[bad] -= S - s             # the stages not evaluated
                out.stop(w, bad, STOPPED, why)
                keep = ~bad
                w.take(keep)
                if not w.idx.size:
                    break
                K, h, h_abs, t_new, k = K[:, keep], h[keep], h_abs[keep], t_new[keep], k[keep]
                hc = h[:, None]
                if s == S:
                    y_new = y_new[keep]
            K[s] = k
        if not w.idx.size:
            break

        # error norm, acceptance and the next step size (scipy's rules)
        scale = w.atol + np.maximum(np.abs(w.y), np.abs(y_new)) * w.rtol
        if tab.dop853:
            e5 = _combo(tab.E5, K) / scale
            e3 = _combo(tab.E3, K) / scale
            n5 = np.sqrt((e5 * e5).sum(axis=1)) ** 2
            n3 = np.sqrt((e3 * e3).sum(axis=1)) ** 2
            denom = n5 + 0.01 * n3
            en = np.where(denom > 0, np.abs(h) * n5 / np.sqrt(np.where(denom > 0, denom, 1) * m),
                          0.0)
        else:
            en = _rms(_combo(tab.E, K) * hc / scale)
        g = SAFETY * np.maximum(en, 1e-300) ** tab.exponent   # (only en < 1e-300 differs: grows 10x)
        acc = en < 1
        # accepted: min(MAX_FACTOR, g) (MAX_FACTOR at en = 0), at most 1 after a rejection;
        # rejected: max(MIN_FACTOR, g) -- Python's min/max, NaN-safe as scipy's
        grow = np.where(en == 0, MAX_FACTOR, np.where(g < MAX_FACTOR, g, MAX_FACTOR))
        grow = np.where(w.retry & ~(grow < 1), 1.0, grow)
        w.h_abs = h_abs * np.where(acc, grow, np.where(g > MIN_FACTOR, g, MIN_FACTOR))

        # dense output at the t_eval points the accepted steps cover
        failed = None
        ie_new = w.ie
        if N and acc.any():
            rows = np.nonzero(acc)[0]
            i_new = np.searchsorted(te_dir, d * t_new[rows], side="right")
            ie_new = w.ie.copy()
            ie_new[rows] = i_new
            sel = rows[i_new > w.ie[rows]]
            if sel.size:
                failed = _dense(rhs, tab, w, K, h, y_new, sel, te, ie_new, out)
        com = acc if failed is None else acc & ~failed
        if com.all():                            # the common case: every attempt accepted
            w.t, w.y, w.f, w.ie = t_new, y_new, K[S], ie_new
        else:
            w.t = np.where(com, t_new, w.t)
            w.y[com] = y_new[com]
            w.f[com] = K[S][com]
            w.ie = np.where(com, ie_new, w.ie)
        w.steps += com
        w.rejected += ~acc
        w.retry = ~acc
        if keep_steps and com.any():
            records.append((w.idx[com], w.steps[com], t_new[com], y_new[com]))
        leave = com & (d * (t_new - t1) >= 0)
        if leave.any():
            out.stop(w, leave, FINISHED, _MSG_FINISHED)
        if failed is not None:
            leave |= failed
        if leave.any():
            w.take(~leave)

    t_steps = y_steps = None
    if keep_steps:
        width = int(out.steps.max()) + 1
        t_steps = np.full((B, width), np.nan)
        y_steps = np.full((B, m, width), np.nan)
        t_steps[:, 0] = t0
        y_steps[:, :, 0] = y0
        for g, k, tn, yn in records:
            t_steps[g, k] = tn
            y_steps[g, :, k] = yn
    return BatchResult(t_eval=te, y=out.y, t_end=out.t_end, y_end=out.y_end,
                       status=out.status, message=out.message, nfev=out.nfev,
                       steps=out.steps, rejected=out.rejected, method=method,
                       t_steps=t_steps, y_steps=y_steps)


def _dense(rhs, tab: _Tableau, w: _Work, K, h, y_new, sel, te, ie_new, out: _Out):
    """Evaluate the accepted steps' interpolants of rows ``sel`` at the t_eval points
    ``[w.ie, ie_new)`` they cover and store them in ``out.y``.  Returns the (A,) bool
    rows whose extra DOP853 stages failed (those steps are not committed)."""
    failed = np.zeros(w.idx.size, dtype=bool)
    Ks = np.take(K, sel, axis=1)
    hs = h[sel]
    if tab.dop853:                               # three extra stages for the interpolant
        S1 = tab.n_stages + 1
        Kx = np.empty((S1 + len(tab.C_extra), sel.size, w.y.shape[1]))
        Kx[:S1] = Ks
        for k, (a, c) in enumerate(zip(tab.A_extra, tab.C_extra)):
            dy = _combo(a, Kx) * hs[:, None]
            w.nfev[sel] += 1
            kk, bad, why = _evaluate(rhs, w.t[sel] + c * hs, w.y[sel] + dy, w.idx[sel])
            if why is not None:
                failed[sel[bad]] = True
                out.stop(w, sel[bad], STOPPED, why)
                keep = ~bad
                sel, hs, Kx, Ks, kk = sel[keep], hs[keep], Kx[:, keep], Ks[:, keep], kk[keep]
                if not sel.size:
                    return failed
            Kx[S1 + k] = kk
    y_old = w.y[sel]
    start, stop = w.ie[sel], ie_new[sel]
    cnt = stop - start
    rep = np.repeat(np.arange(sel.size), cnt)
    pt = start[rep] + (np.arange(rep.size) - np.repeat(np.cumsum(cnt) - cnt, cnt))
    x = (te[pt] - w.t[sel][rep]) / hs[rep]
    hc = hs[:, None]
    if tab.dop853:                               # scipy's Dop853DenseOutput
        dy = y_new[sel] - y_old
        f_old, f_new = Ks[0], Ks[tab.n_stages]
        F = np.empty((3 + tab.D.shape[0],) + dy.shape)
        F[0], F[1], F[2] = dy, hc * f_old - dy, 2 * dy - hc * (f_new + f_old)
        F[3:] = hc * np.einsum("ks,sam->kam", tab.D, Kx)
        F = np.take(F[::-1], rep, axis=1)        # (7, P, m), highest order first
        xr = x[:, None]
        yr = F[0] * xr
        for i in range(1, F.shape[0]):
            yr += F[i]
            yr *= xr if i % 2 == 0 else 1 - xr
        yr += np.take(y_old, rep, axis=0)
    else:                                        # scipy's RkDenseOutput
        Q = np.take(np.einsum("sk,sam->kam", tab.P, Ks), rep, axis=1)    # (4, P, m)
        xr = x[:, None]
        p = xr                                   # x, x², x³, x⁴ (scipy's cumprod)
        yr = Q[0] * p
        for k in range(1, Q.shape[0]):
            p = p * xr
            yr += Q[k] * p
        yr *= hs[rep, None]
        yr += np.take(y_old, rep, axis=0)
    out.y[w.idx[sel][rep], :, pt] = yr
    return failed
