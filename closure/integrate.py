"""Forward dynamics: scipy's ``solve_ivp`` method classes, stepped with the loops closed.

The integrator advances the independent coordinates x and their rates; at every
stage the dependent coordinates are solved by one Newton correction from a
first-order predictor along the last solved pose's tangent (coordinate
partitioning).  The poses solved at the accepted steps are kept: output at the
step times reuses them, output at other times starts from them, and nothing is
solved twice.

A singular configuration is told apart by what the tangent does there:

- at a *fold* (a toggle or dead point of the inputs) the dependent rates blow up
  (``|dq/dx|`` grows like the condition number) and the motion cannot go on: the
  run stops with status "dead point";
- at a *crossing* of a singular configuration on a branch that stays mobile (a
  parallelogram passing its flat position) the rates stay bounded (``|dq/dx|`` far
  below the square root of the condition number): the run goes on, keeping the
  tangent it came in with, and the rows there are flagged with their condition.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.integrate as si

from .errors import ClosureError, MechanismError
from .pose import Pose
from .solver import (TANGENT_COND, SolverOptions, _cat_poses, _origin_offset, _status,
                     branch_tangent, newton, predict)

__all__ = ["IntegrationResult", "METHODS"]

#: scipy's public ``solve_ivp`` method classes, by name
METHODS = {name: getattr(si, name) for name in ("RK23", "RK45", "DOP853", "Radau", "BDF",
                                                  "LSODA")}


@dataclass
class IntegrationResult:
    """What the integrator did (``.attrs["ivp"]`` of :meth:`Dynamics.simulate`'s table).

    Attributes
    ----------
    t : (N,) output times (s)
    y : (2n + 2, N) state at the output times: x, ẋ, dissipated and work (J)
    status : int
        0 the time span was completed, 1 the run stopped at a dead point.
    message : str
    success : bool
        The integrator did not fail (a dead-point stop is a success).
    nfev : int
        Right-hand-side evaluations.
    steps : int
        Accepted steps.
    t_end : float
        Time reached (s).
    """

    t: np.ndarray
    y: np.ndarray
    status: int
    message: str
    success: bool
    nfev: int
    steps: int
    t_end: float


class PoseTracker:
    """Solves the dependent coordinates at the integrator's stages.

    Each call starts from the last solved pose, moves along its tangent (first
    analogs) to the new inputs, and corrects by Newton.  The tangent of a pose whose
    condition exceeds ``TANGENT_COND`` is not trusted (at a singular configuration
    it is not unique): the previous tangent is kept, so the motion leaves a
    crossing on the branch it came in on.

    The last pose is kept as arrays (``q``, ``rot``, inputs ``x``; its figures in
    ``fig``) with the tangent ``first`` (nv, ni), all updated in place by the compiled
    kernels: :func:`closure.dynamics_kernels.step` predicts, the solver's Newton
    (:func:`closure.solve_kernels.drive`) corrects, ``step`` judges and moves the base;
    forward dynamics' right-hand side is all of it and the terms at the pose in one call
    (``step`` task ``RHS``; ``dynamics`` = the ``(DI, DF)`` of
    :func:`closure.dynamics_kernels.pack`).  ``pose`` is the :class:`Pose` of those
    arrays."""

    def __init__(self, mech, pose: Pose, opts: SolverOptions, direction, dynamics=None):
        from . import dynamics_kernels as dk
        from .lstsq import _expected_rank
        from .solver import _NO_COLS, _NO_T, _NO_X
        self.m, self.opts = mech, opts
        self._k = dk
        plan = mech.plan
        n = len(mech.inputs)
        nv, nq = plan.nv, plan.nq
        rank = _expected_rank(mech)
        self.fopts, self.iopt = dk.options(opts, rank, RHS_COND, n, nv, nq)
        self.layout = dk.layout(n, nv, nq)
        self.first = np.array(branch_tangent(mech, pose, direction, opts), dtype=float)
        self.q = np.array(pose.q[0], dtype=float)
        self.rot = np.array(pose.rot[0], dtype=float)
        self.x = np.array(pose.inputs[0], dtype=float)
        #: a member's block of the kernels' outputs (closure.dynamics_kernels.layout)
        self.buf = np.zeros(self.layout["size"])
        o = self.layout["fig"]
        #: residual, iterations, condition (NaN: at most RHS_COND, not computed), converged,
        #: closed: of the last pose the kernels solved
        self.fig = self.buf[o:o + 5]
        self._code = self.layout["code"]
        self._pose: Pose | None = pose
        # the solver's batch-of-one state, corrected in place by its Newton (no analogs
        # asked of it: the step poses need none, the right-hand side's kernel forms its own)
        ns, nj, nl, nc = plan.ns, plan.nj, plan.nl, plan.chords.size
        q1, rot1 = np.zeros((1, nq)), np.zeros((1, ns, 3, 3))
        A1, link1, fa1 = np.zeros((1, nj, 4, 4)), np.zeros((1, nl, 4, 4)), np.zeros((1, nj, 4, 4))
        r1, S1, first1 = np.zeros((1, nc, 6)), np.zeros((1, nv, 6)), np.zeros((1, nv, 0))
        res1, cond1, last1 = np.zeros(1), np.zeros(1), np.zeros(1)
        its1, flag1 = np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64)
        sk = plan._kernels
        self._newton = sk.drive
        self._newton_args = (sk.NEWTON, *plan.packed, _NO_X, _NO_X, q1, rot1, A1, link1, fa1, r1,
                             S1, first1, res1, cond1, last1, its1, flag1, _NO_T, False,
                             self.fopts, opts.maxiter, rank, plan._ucols, _NO_COLS, _NO_X)
        DI, DF = dynamics if dynamics is not None else dk.NO_DYNAMICS
        #: the arguments of closure.dynamics_kernels.step before ``y`` and ``buf``
        self.step_args = (*plan.packed, DI, DF, self.fopts, self.iopt, plan._ucols, plan._icols,
                          q1, rot1, link1, S1, res1, cond1, its1, flag1, self.q, self.rot, self.x,
                          self.first)

    @property
    def pose(self) -> Pose:
        """The last solved pose."""
        if self._pose is None:
            self._pose = self._figures_pose(self.x)
        return self._pose

    def _figures_pose(self, x) -> Pose:
        """The Pose of the arrays and figures (a condition left NaN computed here)."""
        fig = self.fig
        cond = np.array([fig[2]])
        p = Pose(self.m, np.array(x, dtype=float).reshape(1, -1), self.q[None].copy(),
                 self.rot[None].copy(), np.array([fig[0]]), np.array([int(fig[1])]), cond,
                 np.zeros(1, dtype=int), _cond_pending=bool(np.isnan(cond[0])))
        p.status = _status(self.m, p.residual, p.condition, np.array([bool(fig[3])]),
                           self.opts)
        return p

    def not_closed(self, x) -> ClosureError:
        """The error of inputs ``x`` where the last correction did not close."""
        fig = self.fig
        X = np.array(x, dtype=float).reshape(1, -1)
        r, c = np.array([fig[0]]), np.array([fig[2]])
        return ClosureError(f"the loops do not close at x = {X[0].tolist()} (residual "
                            f"{r[0]:.2e}, condition {c[0]:.2e}): the motion reached past a fold "
                            "of the loop equations", inputs=X, residual=r, condition=c)

    def solve(self, task: int, y: np.ndarray) -> int:
        """Predict, correct and judge the pose at the inputs ``y[:ni]`` (a contiguous float
        array; ``task`` TRACK or RHS of :func:`closure.dynamics_kernels.step`, whose code
        is returned); the base moves unless the pose does not close."""
        k = self._k
        if task == k.RHS:                   # one call: predictor, Newton, terms
            code = int(self.buf[self._code]) if k.step(k.RHS, *self.step_args, y, self.buf) \
                else k.OK
        else:
            k.step(k.PREDICT, *self.step_args, y, self.buf)
            self._newton(*self._newton_args)
            code = k.step(task, *self.step_args, y, self.buf)
        if code != k.NOT_CLOSED:
            self._pose = None
        return code

    def tangent(self, pose: Pose, first: np.ndarray) -> None:
        """Adopt ``first`` (nv, ni) as the tangent at ``pose`` unless it is singular."""
        if pose.condition[0] <= TANGENT_COND:
            self.first[...] = first

    def at(self, x: np.ndarray) -> Pose:
        """The pose at inputs ``x`` (n,), on the branch of the last pose."""
        x = np.array(x, dtype=float).reshape(-1)
        if self.solve(self._k.TRACK, x):
            raise self.not_closed(x)
        self._pose = self._figures_pose(x)
        return self._pose


def solve_along(mech, base: Pose, first: np.ndarray, X: np.ndarray, opts: SolverOptions) -> Pose:
    """Poses at inputs ``X`` (B, n) from one solved pose ``base`` and its branch tangent
    ``first`` (nv, n): first-order predictor, then one batched Newton correction.

    Raises ClosureError when a pose does not close (the inputs lie past a fold)."""
    B = X.shape[0]
    pred, _ = predict(mech, (np.repeat(base.q, B, 0), np.repeat(base.rot, B, 0)),
                      np.broadcast_to(first, (B,) + first.shape), base.inputs, X)
    st, r, it, c, conv, ks = newton(mech, pred, opts)
    bad = ~conv | (r > opts.rtol)
    if bad.any():
        i = int(np.argmax(bad))
        raise ClosureError(f"the loops do not close at x = {X[i].tolist()} (residual "
                           f"{r[i]:.2e}, condition {c[i]:.2e}): the motion reached past a fold "
                           "of the loop equations", inputs=X[bad], residual=r[bad],
                           condition=c[bad])
    return Pose(mech, X.copy(), st[0], st[1], r, it, c, _status(mech, r, c, conv, opts),
                _ks=ks)


#: above this condition number the dynamics are evaluated as their limit along the
#: branch (see :func:`regular_limit`): analogs computed from the pose lose about
#: eps · cond² there
RHS_COND = 1e3


def regular_limit(mech, pose: Pose, first: np.ndarray, fn, opts: SolverOptions, eps=1e-2):
    """``fn(pose)`` at a pose of one element, or, near a singular configuration that
    the branch crosses (condition above ``RHS_COND``), its value along the branch.

    Near such a crossing the analogs, and so masses and forces, computed from the
    pose itself lose accuracy like eps · cond² (and are not unique at the crossing),
    while along the branch they are smooth.  The value is then the sixth-order
    symmetric combination ``(15 S₁ − 6 S₂ + S₃) / 20``, ``S_k = f(kε) + f(−kε)``, of
    the values at poses ``±ε, ±2ε, ±3ε`` (dimensionless input) along the branch,
    solved from ``first``; its error is O(ε⁶ f⁽⁶⁾).  Where those poses do not exist
    (a fold within 3ε), and near a fold itself (see :func:`is_fold`: there the
    analogs are large and as accurate as the condition allows), the pose's own value
    is returned.  ``fn`` maps a Pose batch
    to a tuple of arrays."""
    if pose.condition[0] <= RHS_COND or first.shape[1] != 1 or is_fold(mech, pose, first):
        return fn(pose)
    from .solver import _input_scale
    d = eps * _input_scale(mech)[0]
    offs = np.array([1, -1, 2, -2, 3, -3.0])[:, None] * d
    try:
        near = solve_along(mech, pose, first, pose.inputs[0] + offs,
                           opts.replace(maxiter=min(opts.maxiter, 15)))
    except ClosureError:
        return fn(pose)
    if near.condition.max() > RHS_COND:
        return fn(pose)
    w = np.array([15, 15, -6, -6, 1, 1.0]) / 20
    return tuple(np.einsum("k,k...->...", w, v)[None] for v in fn(near))


def is_fold(mech, pose: Pose, first: np.ndarray) -> bool:
    """True when a near-singular ``pose`` is a fold of the inputs (a dead point): its
    dimensionless first analogs exceed the square root of the condition number."""
    f = np.abs(first).copy()
    f[mech.tree.length_cols] /= mech.tree.scale
    return bool(f.max() > np.sqrt(pose.condition[0]))


def integrate(rhs, tracker: PoseTracker, t_span, y0, *, method, rtol, atol, stop_at_dead_point,
              cond_limit, ivp_kw):
    """Step ``METHODS[method]`` over ``t_span``; returns the step times, states, dense
    outputs, step poses, status and message."""
    n = tracker.first.shape[1]
    solver = METHODS[method](rhs, t_span[0], y0, t_span[1], rtol=rtol, atol=atol, **ivp_kw)
    ts, ys, dense = [t_span[0]], [np.asarray(y0, float)], []
    poses, tangents = [tracker.pose], [tracker.first.copy()]
    status, message = "completed", "reached the end of the time span"
    span = abs(t_span[1] - t_span[0])
    tiny = 0                                    # consecutive steps below 1e-12 of the span
    while solver.status == "running":
        try:
            solver.step()
        except ClosureError as e:      # a stage beyond a fold of the loop equations
            status, message = "dead point", f"at t = {solver.t:.6g}: {e}"
            break
        if solver.status == "failed":
            raise ClosureError(f"simulate: the integrator failed at t = {solver.t:.6g} "
                               f"({solver.__class__.__name__})")
        tiny = tiny + 1 if abs(solver.t - ts[-1]) < 1e-12 * span else 0
        if tiny >= 100:
            raise ClosureError(f"simulate: the integrator stalled at t = {solver.t:.9g} (100 "
                               f"steps below {1e-12 * span:.1e} s; condition "
                               f"{tracker.pose.condition[0]:.2e}): the right-hand side is not "
                               "smooth there; try a looser rtol/atol")
        dense.append(solver.dense_output())
        ts.append(solver.t)
        ys.append(solver.y.copy())
        p = tracker.at(solver.y[:n])
        poses.append(p)
        tangents.append(tracker.first.copy())
        if stop_at_dead_point and p.condition[0] > cond_limit:
            from .kinematics import analogs
            first = analogs(tracker.m, p, second=False)[0][0]
            if is_fold(tracker.m, p, first):
                status = "dead point"
                message = (f"condition number {p.condition[0]:.2e} above {cond_limit:.0e} at "
                           f"t = {solver.t:.6g}, where the input rates blow up (a fold)")
                break
    return dict(t=np.array(ts), y=np.array(ys), dense=dense, poses=poses, tangents=tangents,
                status=status, message=message, nfev=solver.nfev, steps=len(ts) - 1)


def poses_at(mech, run: dict, t_out: np.ndarray, opts: SolverOptions):
    """States and poses at output times: the step poses where ``t_out`` are the step
    times, else dense output corrected by Newton from the step pose before each time."""
    ts, dense = run["t"], run["dense"]
    n = run["tangents"][0].shape[1]
    if t_out is None:
        return run["t"], run["y"].T, _cat_poses(run["poses"])
    seg = np.clip(np.searchsorted(ts, t_out, side="right") - 1, 0, len(ts) - 1)
    Y = np.empty((run["y"].shape[1], t_out.size))
    for k in np.unique(seg):                      # one dense call per step holding outputs
        sel = seg == k
        Y[:, sel] = dense[k](t_out[sel]) if k < len(dense) else run["y"][k][:, None]
    X = Y[:n].T
    base = _cat_poses([run["poses"][k] for k in seg])
    pred, _ = predict(mech, base.state, np.array([run["tangents"][k] for k in seg]),
                      base.inputs, X)
    st, r, it, c, conv, ks = newton(mech, pred, opts)
    if not conv.all() or (r > opts.rtol).any():
        i = int(np.argmax(~conv | (r > opts.rtol * _origin_offset(mech))))
        raise ClosureError(f"simulate: the loops do not close at output time {t_out[i]:.6g} "
                           f"(residual {r[i]:.2e}, condition {c[i]:.2e})")
    return t_out, Y, Pose(mech, X.copy(), st[0], st[1], r, it, c, _status(mech, r, c, conv, opts),
                          _ks=ks)


def check_method(method: str) -> None:
    if method not in METHODS:
        raise MechanismError(f"simulate: method {method!r} unknown; expected one of scipy's "
                             f"{', '.join(METHODS)}")
