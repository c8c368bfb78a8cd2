"""Loop closure: damped Gauss–Newton on the stacked 6-vector loop residuals.

One routine serves one pose and a batch alike (vectorised over the batch: the
only Python loops run over Newton iterations and line-search halvings).  The
Jacobian is made dimensionless (translations and slides divided by the
mechanism's length scale) before its singular values are taken, so its
condition number means the same at any size of mechanism.  Steps use the
pseudo-inverse truncated to the expected rank (the unknowns minus the idle
freedoms, e.g. the spin of an S–S rod), which is least squares for
overconstrained loops (Bennett, Bricard) and keeps idle freedoms still.  It is
applied by batched Cholesky on the normal equations where the Jacobian is well
conditioned and by the truncated SVD elsewhere (:class:`_LstSq`); the condition
number is computed once, for the poses returned (for well-conditioned poses when it
is first read).

Each iteration makes one call to the mechanism's compiled :class:`~closure.state.Plan`
(link poses, loop residuals and column twists of the whole batch) and one
factorisation, which serves the Newton step and the first-order analogs at once
(the Jacobian's input columns are extra right-hand sides): the continuation's
predictor takes its tangent from the corrector's last iteration.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from .errors import ClosureError, MechanismError
from .checks import shown
from .kinematics import analogs
from .lstsq import (FAST_COND, SINGULAR_RTOL, _cond_of, _condition, _expected_rank, _LstSq,
                    _pinv_parts)
from .pose import KEEP_STATE, STATUS, Pose
from .state import KinematicState

__all__ = ["solve", "sweep", "predict", "SolverOptions"]

#: the least-squares helpers now live in closure.lstsq; kept importable from here
_FROM_LSTSQ = (SINGULAR_RTOL, _cond_of, _pinv_parts)


class SolverOptions:
    """Tolerances of the position solver.

    Parameters
    ----------
    xtol : float
        Convergence when the residual no longer falls: the largest (dimensionless)
        Newton step ≤ ``xtol``.  A residual at rounding level (1e-14) converges at once.
        Both are multiplied by ``1 + |centre| / scale`` of the mechanism: a model far
        from the world origin holds its coordinates to that many fewer digits.
    rtol : float
        A converged pose with residual above ``rtol`` did not close ("no assembly");
        multiplied, like ``xtol``, by ``1 + |centre| / scale``.
    maxiter : int
    max_step : float
        Largest step in any dimensionless coordinate per iteration (rad), a
        trust region that keeps Newton on its branch.
    cond_limit : float
        Poses whose Jacobian condition number exceeds this are flagged near-singular.

    path_step : float
        Continuation: largest predicted change of any (dimensionless) coordinate per
        internal step (rad).  Steps are subdivided below it whatever step the caller
        asks for, so that predictor and corrector agree and no branch is skipped.
    """

    def __init__(self, xtol=1e-12, rtol=1e-10, maxiter=60, max_step=0.5, cond_limit=1e7,
                 path_step=0.1):
        for name, v in (("xtol", xtol), ("rtol", rtol), ("max_step", max_step),
                        ("cond_limit", cond_limit), ("path_step", path_step)):
            if isinstance(v, bool) or not (isinstance(v, (int, float, np.integer, np.floating))
                                           and np.isfinite(v) and v > 0):
                raise MechanismError(f"SolverOptions: {name} must be a positive finite number, "
                                     f"got {v!r}")
        if isinstance(maxiter, bool) or not isinstance(maxiter, (int, np.integer)) or maxiter < 1:
            raise MechanismError(f"SolverOptions: maxiter must be a positive integer, got "
                                 f"{maxiter!r}")
        self.xtol, self.rtol, self.maxiter = float(xtol), float(rtol), int(maxiter)
        self.max_step, self.cond_limit = float(max_step), float(cond_limit)
        self.path_step = float(path_step)

    def _corrector(self) -> "SolverOptions":
        """The options of the continuation's corrector (at most 8 iterations), kept."""
        c = self.__dict__.get("_corrector_opts")
        if c is None or c.xtol != self.xtol or c.rtol != self.rtol or \
                c.max_step != self.max_step or c.cond_limit != self.cond_limit or \
                c.path_step != self.path_step or c.maxiter != min(self.maxiter, 8):
            c = self.replace(maxiter=min(self.maxiter, 8))
            self.__dict__["_corrector_opts"] = c
        return c

    def replace(self, **kw) -> "SolverOptions":
        """A copy with some fields changed."""
        d = dict(xtol=self.xtol, rtol=self.rtol, maxiter=self.maxiter, max_step=self.max_step,
                 cond_limit=self.cond_limit, path_step=self.path_step)
        d.update(kw)
        return SolverOptions(**d)


def _apply(mech, state, dv_scaled):
    """New state from a dimensionless step over all velocity coordinates."""
    q, rot = state
    return mech.plan.apply(q, rot, dv_scaled)


def _ks_take(ks: KinematicState, idx) -> KinematicState:
    """The kinematic state of batch elements ``idx`` (a copy)."""
    return ks.take(idx)


def _ks_put(dst: KinematicState, idx, src: KinematicState, sub) -> None:
    """Store elements ``sub`` of ``src`` at positions ``idx`` of ``dst``."""
    dst.put(idx, src, sub)


def newton(mech, state, opts: SolverOptions, columns=None, rank=None, exact_cond=True):
    """Correct a batch of states (inputs already set) so that every loop closes.

    Each iteration evaluates the kinematic state once per line-search trial;
    the accepted trial's state serves the next iteration's Jacobian.  A pose is
    converged when its Newton step is below ``xtol`` · offset (or below what rounding of
    the residual explains, 1e-15 · offset / σ_min, near a singular configuration)
    and its residual is at rounding level (≤ 1e-14 · offset) or stopped
    falling; the residual and condition number reported are those of the state
    returned.

    ``columns`` and ``rank`` (default: the unknowns and their expected rank) choose
    the coordinates that move.  Steps come from :class:`_LstSq` (normal equations where
    the Jacobian is well conditioned, the truncated SVD elsewhere); the condition
    number is computed once, for the returned poses.  With ``exact_cond=False`` it is
    left NaN for poses whose condition estimate is at most :data:`FAST_COND` (their
    estimate is below any condition a caller acts on) and exact elsewhere.

    With the default columns the same factorisation also gives the first-order
    analogs (the Jacobian's input columns are extra right-hand sides): they are
    returned as ``ks.first`` for the converged poses (NaN elsewhere).

    Returns ``(state, residual, iterations, condition, converged, ks)`` where
    ``ks`` is the :class:`KinematicState` of the returned poses.
    """
    plan = mech.plan
    default = columns is None
    unknown = plan.unknown if default else columns
    rank = _expected_rank(mech) if rank is None else rank
    nu = unknown.size
    if default:
        inp, cols, in_scale, u_scale = plan.input_v, plan.solve_cols, plan.input_cscale, \
            plan.unknown_cscale
    else:
        inp, cols = np.zeros(0, dtype=int), unknown
    ni = inp.size
    offset = plan.offset                                       # digits lost to the origin
    floor, xtol = 1e-14 * offset, opts.xtol * offset
    noise = 1e-15 * offset                                     # rounding in the residual
    q, rot = state
    B = q.shape[0]
    its = np.zeros(B, dtype=int)
    done = np.zeros(B, dtype=bool)
    cond = np.ones(B)
    ks_all = plan.evaluate(q, rot)
    q, rot = q.copy(), rot.copy()
    res = _norm(plan.scaled_residual(ks_all.r))
    prev = np.full(B, np.inf)
    first_all = np.full((B, plan.nv, ni), np.nan) if default else None
    last_step = np.full(B, np.nan)
    if default and ni:
        first_all[:, inp, np.arange(ni)] = 1.0
    if nu == 0:                                  # open chain driven in every joint
        done[:] = True
        if default:
            first_all[:, unknown] = 0.0
    act = np.nonzero(~done)[0]
    for _ in range(opts.maxiter):
        if act.size == 0:
            break
        whole = act.size == B
        S = ks_all.S if whole else ks_all.S[act]
        r = plan.scaled_residual(ks_all.r if whole else ks_all.r[act])
        Jc = plan.scaled_jacobian(S, cols)
        ls = _LstSq(Jc[:, :, :nu] if ni else Jc, rank)
        cond[act] = ls.cond
        its[act] += 1
        if ni:
            rhs = np.empty(r.shape + (1 + ni,))
            rhs[:, :, 0] = r
            rhs[:, :, 1:] = Jc[:, :, nu:] / in_scale
            X = ls.solve(rhs)
            step_u = -X[:, :, 0]
        else:
            step_u = -ls.solve(r[:, :, None])[:, :, 0]
        big = np.max(np.abs(step_u), axis=1)
        ra = res if whole else res[act]
        # converged: the residual at rounding level (the coordinates are then as accurate
        # as the condition number allows), or steps of at most xtol that no longer
        # reduce the residual
        stalled = (its[act] > 1) & (ra > 0.5 * (prev if whole else prev[act]))
        # near a singular configuration a residual at rounding level still leaves a
        # coordinate error of residual / σ_min: converged only once the step itself is
        # what rounding in the residual explains (noise / σ_min), or below xtol
        tol_step = np.maximum(xtol, noise * ls.inv_smin(xtol / noise))
        conv = (big <= tol_step) & ((ra <= floor) | stalled)
        prev[act] = ra
        if conv.any():
            ca = act[conv]
            done[ca] = True
            last_step[ca] = big[conv]
            if ni:
                first_all[ca[:, None], unknown] = -X[conv, :, 1:] * u_scale[:, None]
            if conv.all():
                break
            move = np.nonzero(~conv)[0]
            act, step_u, big = act[move], step_u[move], big[move]
        step_u *= np.minimum(1.0, opts.max_step / np.maximum(big, 1e-300))[:, None]
        step = np.zeros((act.size, plan.nv))
        step[:, unknown] = step_u
        # backtracking: accept the longest of 1, 1/2, 1/4 ... that does not raise the residual
        whole = act.size == B
        r0 = res if whole else res[act]
        q0, rot0 = (q, rot) if whole else (q[act], rot[act])
        trial_q, trial_rot = plan.apply(q0, rot0, step)
        ks_t = plan.evaluate(trial_q, trial_rot)
        rn = _norm(plan.scaled_residual(ks_t.r))
        good = (rn <= r0 * (1 + 1e-9)) | (rn < floor)
        if whole and good.all():                 # the full step everywhere: no gather
            q, rot, res, ks_all = trial_q, trial_rot, rn, ks_t
            continue
        alpha = np.ones(act.size)
        pending = np.ones(act.size, dtype=bool)
        idx = np.arange(act.size)
        for h in range(8):
            if h:
                idx = np.nonzero(pending)[0]
                trial_q, trial_rot = plan.apply(q0[idx], rot0[idx], step[idx] * alpha[idx, None])
                ks_t = plan.evaluate(trial_q, trial_rot)
                rn = _norm(plan.scaled_residual(ks_t.r))
                good = (rn <= r0[idx] * (1 + 1e-9)) | (rn < floor) | (h == 7)
            g = act[idx[good]]
            q[g], rot[g] = trial_q[good], trial_rot[good]
            res[g] = rn[good]
            ks_all.put(g, ks_t, good)
            pending[idx[good]] = False
            alpha[idx[~good]] *= 0.5
            if not pending.any():
                break
        act = np.nonzero(~done)[0]
    # the condition at the returned state: not converged, or a step by Cholesky
    left = np.nonzero(~done | (np.isnan(cond) & exact_cond))[0]
    if left.size:
        S = ks_all.S if left.size == B else ks_all.S[left]
        J = plan.scaled_jacobian(S, unknown)
        cond[left] = _condition(J, rank) if exact_cond else _LstSq(J, rank).cond
    ks_all.first = first_all
    ks_all.step = last_step if default else None
    return (q, rot), res, its, cond, done, ks_all


def _exact_condition(mech, ks, cond):
    """Fill in, in place, the conditions left NaN by ``newton(..., exact_cond=False)``
    from the kinematic state ``ks`` of the same poses."""
    idx = np.nonzero(np.isnan(cond))[0]
    if idx.size:
        S = ks.S if idx.size == cond.size else ks.S[idx]
        J = mech.plan.scaled_jacobian(S, mech.unknown_columns())
        cond[idx] = _condition(J, _expected_rank(mech))
    return cond


def predict(mech, state, first, x_from, x_new):
    """First-order predictor, batched: states ``(q, rot)`` solved at inputs ``x_from``
    (B, ni) moved along their first analogs ``first`` (B, nv, ni) to the inputs ``x_new``
    (B, ni).  Returns the predicted state with the inputs set, and the dimensionless
    step of every velocity coordinate ``(B, nv)``."""
    plan = mech.plan
    dv = np.einsum("bci,bi->bc", first, x_new - x_from) / plan.col_scale
    q, rot = plan.apply(state[0], state[1], dv)
    q[:, plan.input_q] = x_new
    return (q, rot), dv


def _take_pose(pose: Pose, idx) -> Pose:
    """Poses ``idx`` of a batch (with their kinematic state)."""
    idx = np.asarray(idx)
    return Pose(pose.mechanism, pose.inputs[idx], pose.q[idx], pose.rot[idx],
                pose.residual[idx], pose.iterations[idx], pose._raw_condition[idx],
                pose.status[idx], _ks=None if pose._ks is None else pose._ks.take(idx),
                _cond_pending=pose._cond_pending)


def _cat_poses(poses, keep: bool = True) -> Pose:
    """One batch of the poses of a list of batches (with their kinematic states when
    ``keep`` and every part has one)."""
    cat = {f: np.concatenate([getattr(p, f) for p in poses])
           for f in ("inputs", "q", "rot", "residual", "iterations", "status")}
    cat["condition"] = np.concatenate([p._raw_condition for p in poses])
    kept = keep and all(p._ks is not None for p in poses)
    return Pose(poses[0].mechanism, **cat,
                _ks=KinematicState.concatenate([p._ks for p in poses]) if kept else None,
                _cond_pending=any(p._cond_pending for p in poses))


def _norm(r):
    return np.max(np.abs(r), axis=1) if r.shape[1] else np.zeros(r.shape[0])


def _options(options) -> "SolverOptions":
    """The solver options: the default for None, else a SolverOptions."""
    if options is None:
        return SolverOptions()
    if not isinstance(options, SolverOptions):
        raise MechanismError(f"options: expected a SolverOptions (or None), got "
                             f"{type(options).__name__}")
    return options


def _flag(v, name: str) -> bool:
    """A True/False argument (not a string, a number or None)."""
    if not isinstance(v, (bool, np.bool_)):
        raise MechanismError(f"{name}: expected True or False, got {shown(v)}")
    return bool(v)


def _inputs_array(mech, inputs, name: str = "inputs"):
    n = len(mech.inputs)
    if n == 0:
        raise MechanismError("no inputs declared: call add_input first")
    try:
        x = np.asarray(inputs, dtype=float)
    except (TypeError, ValueError):
        raise MechanismError(f"{name}: expected numbers (rad or length) for {n} input(s) "
                             f"{mech.input_labels()}, got {type(inputs).__name__}") from None
    if x.size == 0:
        raise MechanismError(f"{name}: empty; expected at least one value for {n} input(s) "
                             f"{mech.input_labels()}")
    scalar = x.ndim == 0 or (x.ndim == 1 and n > 1 and x.shape[0] == n)
    if x.ndim == 0:
        x = x.reshape(1, 1)
    elif x.ndim == 1:
        x = x.reshape(1, n) if scalar else x.reshape(-1, 1)
    if x.ndim != 2 or x.shape[1] != n:
        raise MechanismError(f"{name}: expected shape (B, {n}) for {n} inputs "
                             f"{mech.input_labels()}, got {np.shape(inputs)}")
    if not np.all(np.isfinite(x)):
        raise MechanismError(f"{name}: contain non-finite values")
    return x, scalar and n >= 1 and x.shape[0] == 1


def _origin_offset(mech) -> float:
    """``1 + |centre| / scale``: how many times the rounding of a pose's coordinates grows
    because the mechanism sits away from the world origin (tolerances scale with it)."""
    return mech.plan.offset


def _status(mech, res, cond, conv, opts):
    status = np.zeros(res.shape, dtype=int)
    status[cond > opts.cond_limit] = 1
    status[~conv] = 2
    status[conv & (res > opts.rtol * _origin_offset(mech))] = 3
    return status


def project(mech, state, opts: SolverOptions | None = None):
    """Move a batch of states onto the loop equations with every coordinate free
    (minimum-norm Gauss–Newton steps).  Returns ``(state, residual)``."""
    opts = opts or SolverOptions()
    nv = mech.tree.nv
    st, res, _, _, _, _ = newton(mech, state, opts, columns=np.arange(nv), rank=nv,
                                 exact_cond=False)
    return st, res


def _input_scale(mech) -> np.ndarray:
    """Per input: 1 for angles, the length scale for lengths (dimensionless inputs)."""
    return mech.plan.input_scale


#: longest input path (dimensionless: rad, or length / scale) a continuation follows
MAX_PATH = 1e4

#: beyond this condition number a pose's own first analogs are not trusted as the path's
#: tangent (at a singular configuration they are not unique): the previous tangent is kept
TANGENT_COND = 1e9


def _continue(mech, start: Pose, x_to, opts: SolverOptions, min_step: float = 1e-10,
              tangent=None):
    """Batched continuation of solved poses ``start`` (B poses) to the inputs ``x_to``.

    Every member walks the straight input path from its own inputs to its target
    with its own step: a first-order predictor along the analogs, capped so that no
    dimensionless coordinate is predicted to move more than ``opts.path_step``, then
    the Newton corrector; a step is accepted only when the corrector converges, the
    loops close and the corrected pose lies within half the predicted step of the
    predictor (so the path cannot hop to another branch); otherwise it is halved.
    A member whose step falls below ``min_step`` (dimensionless input) stops there:
    a fold of the loop equations (a dead point of the input) or the end of the
    assembly.  At a pose whose condition number exceeds ``TANGENT_COND`` (a singular
    configuration the branch crosses) the tangent of the previous pose is kept, so
    the path leaves the crossing on the branch it came in on; ``tangent`` (B, nv, ni)
    gives that previous tangent for the start poses.

    Returns
    -------
    pose : Pose
        Each member's last accepted pose (its ``inputs`` are where it stands).
    stop : (B,) int
        0 reached the target, 3 no assembly, 4 dead point.
    tangent : (B, nv, ni)
        The first analogs used last (the path's tangent at the returned poses).
    """
    t = mech.tree
    B = len(start)
    xs = _input_scale(mech)
    x_from = start.inputs.astype(float).copy()
    x_to = np.broadcast_to(np.asarray(x_to, float), x_from.shape).copy()
    span = x_to - x_from
    span_s = np.max(np.abs(span / xs), axis=1) if span.size else np.zeros(B)
    if span_s.max(initial=0.0) > MAX_PATH:
        i = int(np.argmax(span_s))
        raise MechanismError(f"inputs: {x_to[i].tolist()} lie {span_s[i]:.3g} (dimensionless) "
                             f"from the guess at {x_from[i].tolist()}; continuation follows "
                             f"paths up to {MAX_PATH:g}: give a guess nearer the inputs, or "
                             "continuation=False")
    q, rot = start.q.copy(), start.rot.copy()
    x_cur = x_from.copy()
    res, cond = start.residual.astype(float).copy(), start._raw_condition.astype(float).copy()
    its = np.zeros(B, dtype=int)                              # this path's iterations only
    ks_all = start.kinematics().take(np.arange(B))            # a copy: updated in place
    if ks_all.first is None:
        ks_all.first = np.full((B, t.nv, x_from.shape[1]), np.nan)
    first = np.zeros((B, t.nv, x_from.shape[1]))
    have = np.zeros(B, dtype=bool)
    if tangent is not None:
        first[:] = tangent
        have[:] = True
    need = np.ones(B, dtype=bool)
    lam, h = np.zeros(B), np.ones(B)
    stop = np.zeros(B, dtype=int)
    active = span_s > 0
    step_opts = opts._corrector()
    while active.any():
        a = np.nonzero(active)[0]
        nf = a[need[a]]
        if nf.size:
            # the analogs the corrector computed with its last step, else computed here
            new = ks_all.first[nf]
            miss = np.nonzero(np.isnan(new).any(axis=(1, 2)))[0]
            if miss.size:
                m_ = nf[miss]
                cur = Pose(mech, x_cur[m_], q[m_], rot[m_], res[m_], its[m_], cond[m_],
                           np.zeros(m_.size, int), _ks=ks_all.take(m_))
                new[miss] = analogs(mech, cur, second=False)[0]
            keep = have[nf] & (cond[nf] > TANGENT_COND)
            first[nf] = np.where(keep[:, None, None], first[nf], new)
            have[nf] = True
            need[nf] = False
        hh = np.minimum(h[a], 1.0 - lam[a])
        dx = x_from[a] + (lam[a] + hh)[:, None] * span[a] - x_cur[a]
        dv = np.einsum("bci,bi->bc", first[a], dx)
        dv[:, t.length_cols] /= t.scale
        # cap the predicted change of every coordinate at path_step
        shrink = np.minimum(1.0, opts.path_step / np.maximum(np.max(np.abs(dv), axis=1), 1e-300))
        hh = hh * shrink
        final = lam[a] + hh >= 1.0
        xt = np.where(final[:, None], x_to[a], x_cur[a] + dx * shrink[:, None])
        (pq, prot), dv = predict(mech, (q[a], rot[a]), first[a], x_cur[a], xt)
        big = np.max(np.abs(dv), axis=1)
        st, r, it, c, conv, ks = newton(mech, (pq, prot), step_opts, exact_cond=False)
        jump = np.max(np.abs(mech.plan.distance(st, (pq, prot))), axis=1)
        ok = conv & (r <= opts.rtol) & (jump <= 0.5 * big)
        g, sub = a[ok], np.nonzero(ok)[0]
        if g.size == B:                          # every member moved: take the arrays
            q, rot, x_cur, res, cond, its = st[0], st[1], xt, r, c, its + it
            ks_all = ks
        elif g.size:
            q[g], rot[g], x_cur[g] = st[0][sub], st[1][sub], xt[sub]
            res[g], cond[g], its[g] = r[sub], c[sub], its[g] + it[sub]
            ks_all.put(g, ks, sub)
        if g.size:
            lam[g] = np.where(final[sub], 1.0, lam[g] + hh[sub])
            h[g] = 2.0 * hh[sub]
            need[g] = True
            active[g[final[sub]]] = False
        bad, bsub = a[~ok], np.nonzero(~ok)[0]
        if bad.size:
            h[bad] = 0.5 * hh[bsub]
            dead = h[bad] * span_s[bad] < min_step
            if dead.any():
                d, dsub = bad[dead], bsub[dead]
                stop[d] = np.where(conv[dsub] & (r[dsub] > opts.rtol), 3, 4)
                active[d] = False
    # conditions left NaN (estimate ≤ FAST_COND) are computed when the pose is asked
    pose = Pose(mech, x_cur, q, rot, res, its, cond, np.zeros(B, int), _ks=ks_all,
                _cond_pending=True)
    return pose, stop, first


def branch_tangent(mech, pose: Pose, direction, opts: SolverOptions | None = None) -> np.ndarray:
    """First analogs ``(nv, ni)`` of the branch through one solved ``pose``, leaving it
    in the input ``direction`` (ni,).

    At a regular pose these are the pose's own analogs.  At a singular configuration
    (condition above ``TANGENT_COND``) they are not unique; the branch is then
    followed by continuation a short way (1e-4, dimensionless) along ``direction``
    and the analogs are taken there, where they are again unique."""
    from .kinematics import analogs
    first = analogs(mech, pose, second=False)[0][0]
    if pose.condition[0] <= TANGENT_COND:
        return first
    opts = opts or SolverOptions()
    d = np.asarray(direction, float).reshape(-1)
    d = d / max(np.max(np.abs(d / _input_scale(mech))), 1e-300)
    probe, stop, _ = _continue(mech, pose, pose.inputs + 1e-4 * d * _input_scale(mech), opts)
    if stop[0]:
        return first
    return analogs(mech, probe, second=False)[0][0]


def _start_pose(mech, guess: Pose | None, B: int, opts: SolverOptions) -> Pose:
    """The poses continuation starts from: the guess (or the assembly) corrected at its
    own inputs, broadcast to B members."""
    if guess is None:
        q, rot = mech.assembly()
        x0 = q[:, mech.input_q_columns()]
    else:
        if not isinstance(guess, Pose):
            raise MechanismError(f"guess: expected a Pose, got {type(guess).__name__}")
        if guess.mechanism is not mech:
            raise MechanismError("guess: a Pose of another mechanism")
        q, rot, x0 = guess.q, guess.rot, np.asarray(guess.inputs, float).reshape(len(guess), -1)
    if q.shape[0] not in (1, B):
        raise MechanismError(f"guess: has {q.shape[0]} poses, expected 1 or {B}")
    n = q.shape[0]
    if guess is not None and _settled(mech, guess, opts):
        # a pose the solver stopped at with its residual at rounding level and a step
        # below xtol: correcting it again would converge at once without moving it
        pose = Pose(mech, x0, guess.q, guess.rot, guess.residual, np.zeros(n, int),
                    guess._raw_condition, np.zeros(n, int), _ks=guess._ks,
                    _cond_pending=guess._cond_pending)
        return _take_pose(pose, np.zeros(B, dtype=int)) if n == 1 and B > 1 else pose
    q = q.copy()
    q[:, mech.input_q_columns()] = x0
    st, res, its, cond, conv, ks = newton(mech, (q, rot.copy()), opts, exact_cond=False)
    pose = Pose(mech, x0, st[0], st[1], res, its, cond, _status(mech, res, cond, conv, opts),
                _ks=ks, _cond_pending=True)
    return _take_pose(pose, np.zeros(B, dtype=int)) if n == 1 and B > 1 else pose


def _settled(mech, guess: Pose, opts: SolverOptions) -> bool:
    """True when every member of ``guess`` is a pose the solver stopped at (its kept
    state holds the step and analogs computed there) with a residual at rounding level
    and a Newton step below ``xtol``: Newton from it converges at its first iteration
    without moving, so the start needs no correction."""
    ks = guess._ks
    if ks is None or ks.step is None or ks.first is None or ks.S is None:
        return False
    plan = mech.plan
    off = plan.offset
    with np.errstate(invalid="ignore"):
        return bool(np.all(ks.step <= opts.xtol * off) and
                    np.all(guess.residual <= 1e-14 * off) and
                    not np.isnan(ks.first).any() and
                    np.array_equal(guess.q[:, plan.input_q], guess.inputs))


def solve(mech, inputs, guess: Pose | None = None, *, options: SolverOptions | None = None,
          raise_on_failure: bool = True, continuation: bool = True) -> Pose:
    """Solve the loop-closure equations for one input value or a batch.

    Parameters
    ----------
    mech : Mechanism
    inputs : float or array_like, shape (B,) or (B, n_inputs)
        Input coordinates (rad or length), in the order of ``add_input`` calls.
    guess : Pose, optional
        Starting pose (one pose, or as many as inputs); default the assembly pose.
        The solution stays on the guess's assembly branch.
    options : SolverOptions, optional
    raise_on_failure : bool
        Raise :class:`ClosureError` (with the figures) when any input fails to
        close; otherwise return the poses with their ``status``.
    continuation : bool
        True (default): every input is reached by batched continuation from the
        guess (see :func:`sweep`), so a far input is reached on the guess's branch
        or reported as not reached ("dead point", with ``reached`` saying where the
        path stopped).  False: one Newton correction from the guess (fast for
        near guesses, no branch guarantee).

    Returns
    -------
    Pose
        With ``reached``: the inputs actually reached (equal to ``inputs`` where
        ``status`` is "ok" or "near-singular").
    """
    opts = _options(options)
    raise_on_failure = _flag(raise_on_failure, "raise_on_failure")
    continuation = _flag(continuation, "continuation")
    x, scalar = _inputs_array(mech, inputs)
    B = x.shape[0]
    if B > CHUNK:
        pose = _solve_chunked(mech, x, guess, opts, continuation)
    else:
        pose = _solve_batch(mech, x, scalar, guess, opts, continuation)
    if B > KEEP_STATE:
        pose._ks = None                             # recomputed if asked: memory per pose
    bad = pose.status >= 2
    if raise_on_failure and bad.any():
        i = np.nonzero(bad)[0]
        where = ""
        if pose.reached is not None and pose.status[i[0]] == 4:
            where = f", reached {pose.reached[i[0]].tolist()}"
        raise ClosureError(
            f"loop closure failed for {i.size} of {B} inputs (first: inputs {x[i[0]].tolist()}, "
            f"{pose.status_text[i[0]]}{where}, residual {pose.residual[i[0]]:.2e}, condition "
            f"{pose.condition[i[0]]:.2e})",
            inputs=x[i], residual=pose.residual[i], condition=pose.condition[i])
    return pose


#: batches above this many inputs are solved in chunks of it (each member's path is
#: independent of the others, so the poses are the same; the chunks' temporaries stay
#: in cache and peak memory no longer grows with the batch beyond the returned poses)
CHUNK = 2048


def _solve_chunked(mech, x, guess, opts, continuation) -> Pose:
    """:func:`_solve_batch` over chunks of ``CHUNK`` inputs, concatenated."""
    B = x.shape[0]
    if guess is not None and isinstance(guess, Pose) and len(guess) not in (1, B):
        raise MechanismError(f"guess: has {len(guess)} poses, expected 1 or {B}")
    parts = []
    for a in range(0, B, CHUNK):
        sl = np.arange(a, min(a + CHUNK, B))
        g = guess if guess is None or not isinstance(guess, Pose) or len(guess) == 1 \
            else _take_pose(guess, sl)
        part = _solve_batch(mech, x[sl], False, g, opts, continuation)
        part._ks = None                             # kept only for small batches
        parts.append(part)
    pose = _cat_poses(parts)
    if parts[0].reached is not None:
        pose.reached = np.concatenate([p.reached for p in parts])
    return pose


def _solve_batch(mech, x, scalar, guess, opts, continuation) -> Pose:
    """The poses of :func:`solve` at inputs ``x`` (B, ni), without raising."""
    B = x.shape[0]
    start = _start_pose(mech, guess, B, opts)
    if continuation and mech.tree.chords:         # an open chain has no branch to follow
        pose, stop, _ = _continue(mech, start, x, opts)
        res, cond = pose.residual, pose._raw_condition
        if opts.cond_limit < FAST_COND:          # the flags need the exact figures
            _exact_condition(mech, pose.kinematics(), cond)
        status = _status(mech, res, cond, np.ones(B, bool), opts)
        status = np.where(start.status >= 2, start.status, np.where(stop > 0, stop, status))
        reached = pose.inputs
        pose = Pose(mech, x, pose.q, pose.rot, res, pose.iterations, cond, status, scalar,
                    _ks=pose._ks, reached=reached, _cond_pending=True)
    else:
        q, rot = start.q.copy(), start.rot.copy()
        q[:, mech.input_q_columns()] = x
        state, res, its, cond, conv, ks = newton(mech, (q, rot), opts)
        pose = Pose(mech, x, state[0], state[1], res, its, cond,
                    _status(mech, res, cond, conv, opts),
                    scalar, _ks=ks)
    return pose


def sweep(mech, values, guess: Pose | None = None, *, options: SolverOptions | None = None,
          return_pose: bool = False):
    """Continuation along a path of inputs; one row per value.

    Between consecutive values the path is subdivided internally (see
    :class:`SolverOptions` ``path_step``): each internal step starts from a
    first-order predictor and is accepted only when the corrector stays within
    half the predicted step of it, so the rows returned lie on the branch of the
    first row whatever step is asked for.  A singular configuration that the
    branch crosses smoothly (a parallelogram passing its flat position) is passed,
    with its condition number in the row.  When the path cannot go on (a fold:
    the input's dead point, or the end of the assembly) the row is flagged
    ("dead point" or "no assembly", ``reached:<label>`` saying where it stopped)
    and the remaining rows say "not reached".

    Returns
    -------
    pandas.DataFrame
        Columns ``input:<label>`` for every input, one per joint coordinate
        (``coordinate_labels()``), ``residual``, ``condition``, ``iterations`` (the
        Newton iterations from the previous row), ``status`` ("ok", "near-singular"
        where the condition exceeds the limit, or why the path stopped: see
        :data:`closure.REACHED`) and ``reached:<label>`` (the input actually reached:
        differs from the requested one on a stopped row).
    Pose
        Only with ``return_pose=True``: the poses of the rows that were reached
        (for velocities, accelerations and analogs along the path).
    """
    opts = _options(options)
    return_pose = _flag(return_pose, "return_pose")
    x, _ = _inputs_array(mech, values, "values")
    cur = solve(mech, x[0], guess, options=opts, raise_on_failure=False)
    poses, stops = [cur], [cur.status_text[0] if cur.status[0] >= 2 else None]
    stopped = cur.status[0] >= 2
    tangent = None
    for i in range(1, x.shape[0]):
        if stopped:
            break
        nxt, stop, tangent = _continue(mech, cur, x[i][None], opts, tangent=tangent)
        poses.append(nxt)
        if stop[0]:
            stops.append(STATUS[int(stop[0])])
            stopped = True
            break
        stops.append(None)
        cur = nxt
    n = len(poses)
    pose = _cat_poses(poses, keep=return_pose and n <= KEEP_STATE)
    reached, pose.inputs = pose.inputs, x[:n].copy()
    cond = pose.condition if opts.cond_limit < FAST_COND else pose._raw_condition
    pose.status = _status(mech, pose.residual, cond, np.ones(n, bool), opts)
    status = [s if s is not None else STATUS[int(c)] for s, c in zip(stops, pose.status)]
    df = pose.table()
    df["status"] = status
    for k, lab in enumerate(mech.input_labels()):
        df[f"reached:{lab}"] = reached[:, k]
    if n < x.shape[0]:
        rest = pd.DataFrame({f"input:{lab}": x[n:, k] for k, lab in enumerate(mech.input_labels())})
        rest["status"] = "not reached"
        df = pd.concat([df, rest], ignore_index=True)
    if return_pose:
        return df, _take_pose(pose, np.nonzero([s is None for s in stops])[0])
    return df


def _ks_cat(kss) -> KinematicState:
    """Concatenate kinematic states along the batch."""
    return KinematicState.concatenate(kss)


def _coord_distance(mech, a, b):
    """Dimensionless distance per velocity coordinate between two states (B, nv)."""
    return mech.plan.distance(a, b)
