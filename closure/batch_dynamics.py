"""Batched forward dynamics: B independent trajectories (initial states) in one call.

:func:`simulate_batch` integrates ``M(x) ẍ = Q(t, x, ẋ) − h(x, ẋ)`` for B members of
one :class:`~closure.dynamics.Dynamics` model with
:func:`closure.batch_integrate.integrate_batch` (scipy's RK45/DOP853 controller per
member).  Each stage of each active member is handled in one batched pass:

- the pose of every active member is corrected by one batched Newton solve of the
  loops (``mechanism.solve(..., continuation=False)``) from that member's own last
  pose (its branch: every member is tracked on its own branch);
- M, h, Q and the first analogs of all active members come from one ``TERMS`` call
  of :func:`closure.dynamics_kernels.step` (via ``Dynamics._evaluate``);
- ``ẍ = M⁻¹ (Q − h + drive)`` by one batched ``numpy.linalg.solve``.

A member whose pose does not close, or whose condition number exceeds
``options.cond_limit`` (a dead point), is stopped (status 1 with a message); the
others go on.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .batch_integrate import BATCH_METHODS, integrate_batch
from .errors import MechanismError
from .frames import as_array
from .pose import Pose
from .solver import SolverOptions, _status, _take_pose, newton

__all__ = ["BatchDynamicsResult", "simulate_batch"]


@dataclass
class BatchDynamicsResult:
    """What :func:`simulate_batch` did for each member.

    t_eval (N,); x, xd (B, n, N) (NaN after a member stopped); dissipated, work
    (B, N) integrated damper and given-force work; t_end (B,) and x_end (B, n): where
    each member stopped; status (B,) int
    (0 finished, 1 stopped: pose not closed / dead point, -1 step too small);
    message (B,) str; nfev, steps (B,) int; method str.
    """

    t_eval: np.ndarray
    x: np.ndarray
    xd: np.ndarray
    dissipated: np.ndarray
    work: np.ndarray
    t_end: np.ndarray
    x_end: np.ndarray
    status: np.ndarray
    message: np.ndarray
    nfev: np.ndarray
    steps: np.ndarray
    method: str


def _states(a, name, n):
    a = as_array(a, f"simulate_batch: {name}", finite=False)
    if a.ndim == 1 and n == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[1] != n or a.shape[0] == 0:
        raise MechanismError(f"simulate_batch: {name} must have shape (B, {n}) (members, "
                             f"inputs), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise MechanismError(f"simulate_batch: {name} must be finite")
    return np.ascontiguousarray(a, dtype=float)


def simulate_batch(dynamics, t_span, x0, xd0, *, t_eval=None, method: str = "DOP853",
                   rtol: float = 1e-10, atol: float = 1e-12, drive: Callable | None = None,
                   options: SolverOptions | None = None) -> BatchDynamicsResult:
    """Forward dynamics of B members from ``x0, xd0`` (B, n) over ``t_span``.

    ``drive``, if given, must be vectorised: ``drive(t (A,), x (A, n), xd (A, n)) ->
    (A, n)``.  Given joint forces (``add_force``) are called as ``func(t (A,), q (A,),
    qd (A,))`` and must accept arrays.  Each member starts from the solution of its
    ``x0`` reached by continuation from the assembly pose.
    """
    from .dynamics import _simulate_arguments
    mech = dynamics.m
    n = len(mech.inputs)
    if method not in BATCH_METHODS:
        raise MechanismError(f"simulate_batch: method must be one of {sorted(BATCH_METHODS)}, "
                             f"got {method!r}")
    x0 = _states(x0, "x0", n)
    xd0 = _states(xd0, "xd0", n)
    if x0.shape != xd0.shape:
        raise MechanismError(f"simulate_batch: xd0 must have the shape of x0 {x0.shape}, "
                             f"got {xd0.shape}")
    _, _, t0, t1 = _simulate_arguments(n, np.zeros(n), np.zeros(n), rtol, atol, drive, t_span)
    if options is not None and not isinstance(options, SolverOptions):
        raise MechanismError("simulate_batch: options must be a SolverOptions")
    opts = options or SolverOptions()
    B = len(x0)
    start = mech.solve(x0, options=opts, raise_on_failure=False)
    start.scalar = False
    bad0 = np.asarray(start.status) >= 2
    cur_q, cur_rot, cur_x = start.q.copy(), start.rot.copy(), start.inputs.copy()
    cond_limit = opts.cond_limit
    # predictor along the first analogs where joint coordinates and rates coincide
    predict = mech.plan.nq == mech.plan.nv and start.rot.shape[1] == 0
    cur_first = np.zeros((B, mech.plan.nv, n))
    input_q = mech.plan.input_q

    def rhs(t, y, members):
        A = len(members)
        x, xd = y[:, :n], y[:, n:2 * n]
        q = cur_q[members]
        if predict:                         # along each member's tangent (first analogs)
            q = q + np.einsum("avn,an->av", cur_first[members], x - cur_x[members])
        q[:, input_q] = x
        # one batched Newton correction of all active members (solve_kernels.drive NEWTON)
        st, res, its, cnd, conv, ks = newton(mech, (q, cur_rot[members]), opts,
                                            exact_cond=False)
        pose = Pose(mech, x.copy(), st[0], st[1], res, its, cnd,
                    _status(mech, res, cnd, conv, opts), False, _ks=ks, _cond_pending=True)
        status = np.asarray(pose.status)
        cond = pose._raw_condition          # NaN: not computed, known below FAST_COND
        failed = np.full(A, "", dtype=object)
        notclosed = (status >= 2) | bad0[members]
        dead = ~notclosed & ((status == 1) | (cond > cond_limit))
        for i in np.nonzero(notclosed)[0]:
            failed[i] = f"the pose does not close (status {status[i]}, cond {cond[i]:.3g}) at x = {x[i].tolist()} (t = {t[i]:.6g})"
        for i in np.nonzero(dead)[0]:
            failed[i] = f"dead point: condition {cond[i]:.3e} above {cond_limit:.3e} " \
                        f"at x = {x[i].tolist()} (t = {t[i]:.6g})"
        ok = ~(notclosed | dead)
        dydt = np.full((A, 2 * n + 2), np.nan)
        if not ok.any():
            return dydt, failed
        idx = np.nonzero(ok)[0]
        p = pose if ok.all() else _take_pose(pose, idx)
        cur_q[members[idx]] = p.q
        cur_rot[members[idx]] = p.rot
        cur_x[members[idx]] = x[idx]
        xdo, to = xd[idx], t[idx]
        M, h, Q, _qd, first, diss, work = dynamics._evaluate(p, xdo, to)[:7]
        cur_first[members[idx]] = first
        F = Q - h
        if drive is not None:
            tau = np.asarray(drive(to, x[idx], xdo), float)
            if tau.shape != (len(idx), n):
                raise MechanismError(f"simulate_batch: drive must return shape "
                                     f"({len(idx)}, {n}) for a vectorised call "
                                     f"drive(t (A,), x (A, n), xd (A, n)), got {tau.shape}")
            F = F + tau
            work = work + np.einsum("ij,ij->i", tau, xdo)
        xdd = np.linalg.solve(M, F[..., None])[..., 0]
        dydt[idx, :n] = xdo
        dydt[idx, n:2 * n] = xdd
        dydt[idx, 2 * n] = diss
        dydt[idx, 2 * n + 1] = work
        return dydt, failed

    y0 = np.concatenate([x0, xd0, np.zeros((B, 2))], axis=1)
    res = integrate_batch(rhs, (t0, t1), y0, method=method, t_eval=t_eval, rtol=rtol,
                          atol=atol)
    return BatchDynamicsResult(t_eval=res.t_eval, x=res.y[:, :n], xd=res.y[:, n:2 * n],
                               dissipated=res.y[:, 2 * n], work=res.y[:, 2 * n + 1],
                               t_end=res.t_end, x_end=res.y_end[:, :n], status=res.status, message=res.message,
                               nfev=res.nfev, steps=res.steps, method=method)
