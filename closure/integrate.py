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
    crossing on the branch it came in on."""

    def __init__(self, mech, pose: Pose, opts: SolverOptions, direction):
        self.m, self.opts = mech, opts
        self.pose = pose
        self.first = branch_tangent(mech, pose, direction, opts)

    def tangent(self, pose: Pose, first: np.ndarray) -> None:
        """Adopt ``first`` (nv, ni) as the tangent at ``pose`` unless it is singular."""
        if pose.condition[0] <= TANGENT_COND:
            self.first = first

    def at(self, x: np.ndarray) -> Pose:
        """The pose at inputs ``x`` (n,), on the branch of the last pose."""
        p = solve_along(self.m, self.pose, self.first, np.asarray(x, float)[None], self.opts)
        self.pose = p
        return p


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
