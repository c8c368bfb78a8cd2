"""Loop closure: damped Gauss–Newton on the stacked 6-vector loop residuals.

One routine serves one pose and a batch alike (vectorised over the batch: the
only Python loops run over Newton iterations and line-search halvings).  The
Jacobian is made dimensionless (translations and slides divided by the
mechanism's length scale) before its singular values are taken, so its
condition number means the same at any size of mechanism.  Steps use the
pseudo-inverse truncated to the expected rank (the unknowns minus the idle
freedoms, e.g. the spin of an S–S rod), which is least squares for
overconstrained loops (Bennett, Bricard) and keeps idle freedoms still.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from .errors import ClosureError, MechanismError
from .frames import log_so3
from .pose import Pose

__all__ = ["solve", "sweep", "predict", "SolverOptions"]


class SolverOptions:
    """Tolerances of the position solver.

    Parameters
    ----------
    xtol : float
        Convergence when the residual no longer falls: the largest (dimensionless)
        Newton step ≤ ``xtol``.  A residual at rounding level (1e-14) converges at once.
    rtol : float
        A converged pose with residual above ``rtol`` did not close ("no assembly").
    maxiter : int
    max_step : float
        Largest step in any dimensionless coordinate per iteration (rad), a
        trust region that keeps Newton on its branch.
    cond_limit : float
        Poses whose Jacobian condition number exceeds this are flagged near-singular.
    """

    def __init__(self, xtol=1e-12, rtol=1e-10, maxiter=60, max_step=0.5, cond_limit=1e7):
        self.xtol, self.rtol, self.maxiter = float(xtol), float(rtol), int(maxiter)
        self.max_step, self.cond_limit = float(max_step), float(cond_limit)


def _expected_rank(mech) -> int:
    n_unknown = mech.tree.nv - len(mech.inputs)
    idle = mech.mobility - len(mech.inputs)
    return n_unknown - idle


def _pinv_parts(J, rank):
    """Truncated SVD pieces of a batch of matrices: (U, inv_s, Vt, condition)."""
    if J.shape[-1] == 0 or J.shape[-2] == 0:         # open chain: nothing to solve
        k = min(J.shape[-2:])
        B = J.shape[:-2]
        return (np.zeros(B + (J.shape[-2], k)), np.zeros(B + (k,)),
                np.zeros(B + (k, J.shape[-1])), np.ones(B))
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    k = np.arange(s.shape[-1])
    keep = k < rank
    smax = s[..., :1]
    srank = s[..., rank - 1] if rank > 0 else np.ones(s.shape[:-1])
    with np.errstate(divide="ignore"):
        inv_s = np.where(keep & (s > 1e-300), 1.0 / np.where(s > 0, s, 1.0), 0.0)
        cond = np.where(srank > 0, smax[..., 0] / np.where(srank > 0, srank, 1.0), np.inf)
    return U, inv_s, Vt, cond


def _apply(mech, state, dv_scaled):
    """New state from a dimensionless step over all velocity coordinates."""
    t = mech.tree
    dv = dv_scaled.copy()
    dv[:, t.length_cols] *= t.scale
    q, rot = state
    q = q.copy()
    rot = rot.copy()
    for j in mech.joints:
        d = dv[:, t.v_offset[j.index]:t.v_offset[j.index] + j.nv]
        if j.kind == "S":
            si = t.s_index[j.index]
            _, rot[:, si] = j.update(None, rot[:, si], d)
        else:
            a = t.q_offset[j.index]
            q[:, a:a + j.nq] += d
    return q, rot


_BATCHED = ("link", "frame_a", "S", "r")


def _ks_take(ks, idx):
    """The kinematic state of batch elements ``idx``."""
    out = {k: ks[k][idx] for k in _BATCHED if k in ks}
    out["A"] = [a[idx] for a in ks["A"]]
    for k in ("carrier", "deps"):
        if k in ks:
            out[k] = ks[k]
    return out


def _ks_put(dst, idx, src, sub):
    """Store elements ``sub`` of ``src`` at positions ``idx`` of ``dst``."""
    for k in _BATCHED:
        if k in dst:
            dst[k][idx] = src[k][sub]
    for a, b in zip(dst["A"], src["A"]):
        a[idx] = b[sub]


def newton(mech, state, opts: SolverOptions):
    """Correct a batch of states (inputs already set) so that every loop closes.

    Each iteration evaluates the kinematic state once per line-search trial;
    the accepted trial's state serves the next iteration's Jacobian.  A pose is
    converged when its residual is at rounding level (≤ 1e-14), or when the
    Newton step computed at it is at most ``xtol`` and the residual stopped
    falling; the residual and condition number reported are those of the state
    returned.

    Returns ``(state, residual, iterations, condition, converged, ks)`` where
    ``ks`` is the kinematic state of the returned poses.
    """
    unknown = mech.unknown_columns()
    rank = _expected_rank(mech)
    q, rot = (a.copy() for a in state)
    B = q.shape[0]
    its = np.zeros(B, dtype=int)
    done = np.zeros(B, dtype=bool)
    cond = np.ones(B)
    ks_all = mech.kinematic_state((q, rot), twists=unknown.size > 0)
    res = _norm(mech._scaled_residual(ks_all))
    prev = np.full(B, np.inf)
    if unknown.size == 0:                        # open chain driven in every joint
        done[:] = True
    for _ in range(opts.maxiter):
        act = np.nonzero(~done)[0]
        if act.size == 0:
            break
        ks = _ks_take(ks_all, act)
        r = mech._scaled_residual(ks)
        J = mech._scaled_jacobian(ks)[:, :, unknown]
        U, inv_s, Vt, cond[act] = _pinv_parts(J, rank)
        its[act] += 1
        coef = np.einsum("bmk,bm->bk", U, r) * inv_s
        step_u = -np.einsum("bkn,bk->bn", Vt, coef)
        big = np.max(np.abs(step_u), axis=1)
        # converged: the residual at rounding level (the coordinates are then as accurate
        # as the condition number allows), or steps of at most xtol that no longer
        # reduce the residual
        stalled = (its[act] > 1) & (res[act] > 0.5 * prev[act])
        conv = ((big <= opts.xtol) & stalled) | (res[act] <= 1e-14)
        prev[act] = res[act]
        done[act[conv]] = True
        move = np.nonzero(~conv)[0]
        if move.size == 0:
            break
        act, step_u, big = act[move], step_u[move], big[move]
        step_u *= np.minimum(1.0, opts.max_step / np.maximum(big, 1e-300))[:, None]
        step = np.zeros((act.size, mech.tree.nv))
        step[:, unknown] = step_u
        # backtracking: accept the longest of 1, 1/2, 1/4 ... that does not raise the residual
        r0 = res[act]
        alpha = np.ones(act.size)
        pending = np.ones(act.size, dtype=bool)
        q0, rot0 = q[act], rot[act]
        for h in range(8):
            idx = np.nonzero(pending)[0]
            trial = _apply(mech, (q0[idx], rot0[idx]), step[idx] * alpha[idx, None])
            ks_t = mech.kinematic_state(trial)
            rn = _norm(mech._scaled_residual(ks_t))
            good = (rn <= r0[idx] * (1 + 1e-9)) | (rn < 1e-14) | (h == 7)
            g = act[idx[good]]
            q[g], rot[g] = trial[0][good], trial[1][good]
            res[g] = rn[good]
            _ks_put(ks_all, g, ks_t, good)
            pending[idx[good]] = False
            alpha[idx[~good]] *= 0.5
            if not pending.any():
                break
    left = np.nonzero(~done)[0]
    if left.size:                                 # not converged: condition at the last state
        J = mech._scaled_jacobian(_ks_take(ks_all, left))[:, :, unknown]
        cond[left] = _pinv_parts(J, rank)[3]
    return (q, rot), res, its, cond, done, ks_all


def predict(mech, pose: Pose, x_new, first=None):
    """First-order predictor: ``pose`` (one pose) moved along its first analogs to the
    inputs ``x_new``.  Returns the predicted state ``(q, rot)`` with the inputs set, and
    the dimensionless step of every velocity coordinate ``(nv,)``."""
    from .kinematics import analogs  # local: kinematics imports solver helpers
    if first is None:
        first = analogs(mech, pose, second=False)[0][0]
    x_new = np.asarray(x_new, float)
    dv = first @ (x_new - pose.inputs[0])
    dv[mech.tree.length_cols] /= mech.tree.scale
    q, rot = _apply(mech, pose.state, dv[None])
    q[:, mech.input_q_columns()] = x_new
    return (q, rot), dv


def _norm(r):
    return np.max(np.abs(r), axis=1) if r.shape[1] else np.zeros(r.shape[0])


def _inputs_array(mech, inputs):
    n = len(mech.inputs)
    if n == 0:
        raise MechanismError("no inputs declared: call add_input first")
    x = np.asarray(inputs, dtype=float)
    scalar = x.ndim == 0 or (x.ndim == 1 and n > 1 and x.shape[0] == n)
    if x.ndim == 0:
        x = x.reshape(1, 1)
    elif x.ndim == 1:
        x = x.reshape(1, n) if scalar else x.reshape(-1, 1)
    if x.ndim != 2 or x.shape[1] != n:
        raise MechanismError(f"inputs: expected shape (B, {n}) for {n} inputs "
                             f"{mech.input_labels()}, got {np.shape(inputs)}")
    if not np.all(np.isfinite(x)):
        raise MechanismError("inputs: contain non-finite values")
    return x, scalar and n >= 1 and x.shape[0] == 1


def _status(res, cond, conv, opts):
    status = np.zeros(res.shape, dtype=int)
    status[cond > opts.cond_limit] = 1
    status[~conv] = 2
    status[conv & (res > opts.rtol)] = 3
    return status


def solve(mech, inputs, guess: Pose | None = None, *, options: SolverOptions | None = None,
          raise_on_failure: bool = True) -> Pose:
    """Solve the loop-closure equations for one input value or a batch.

    Parameters
    ----------
    mech : Mechanism
    inputs : float or array_like, shape (B,) or (B, n_inputs)
        Input coordinates (rad or length), in the order of ``add_input`` calls.
    guess : Pose, optional
        Starting pose (one pose, or as many as inputs); default the assembly pose.
    options : SolverOptions, optional
    raise_on_failure : bool
        Raise :class:`ClosureError` (with the figures) when any input fails to
        close; otherwise return the poses with their ``status``.

    Returns
    -------
    Pose
    """
    opts = options or SolverOptions()
    x, scalar = _inputs_array(mech, inputs)
    B = x.shape[0]
    if guess is None:
        q, rot = mech.assembly()
    else:
        q, rot = guess.q, guess.rot
    if q.shape[0] not in (1, B):
        raise MechanismError(f"guess: has {q.shape[0]} poses, expected 1 or {B}")
    q = np.broadcast_to(q, (B,) + q.shape[1:]).copy()
    rot = np.broadcast_to(rot, (B,) + rot.shape[1:]).copy()
    q[:, mech.input_q_columns()] = x
    state, res, its, cond, conv, ks = newton(mech, (q, rot), opts)
    pose = Pose(mech, x, state[0], state[1], res, its, cond, _status(res, cond, conv, opts), scalar)
    pose._ks = ks
    bad = pose.status >= 2
    if raise_on_failure and bad.any():
        i = np.nonzero(bad)[0]
        raise ClosureError(
            f"loop closure failed for {i.size} of {B} inputs (first: inputs {x[i[0]].tolist()}, "
            f"{pose.status_text[i[0]]}, residual {res[i[0]]:.2e}, condition {cond[i[0]]:.2e})",
            inputs=x[i], residual=res[i], condition=cond[i])
    return pose


def sweep(mech, values, guess: Pose | None = None, *, options: SolverOptions | None = None,
          max_halvings: int = 12, return_pose: bool = False):
    """Continuation along a path of inputs; one row per value.

    Each step starts from a first-order predictor (the previous pose plus the
    velocity solution times the input increment) and is split in halves when
    the corrector fails, jumps more than half the predicted step away from the
    predictor, or loses the Jacobian's rank.  When a step cannot be completed
    the row is flagged (``status`` "dead point" with the condition number, or
    "no assembly") and the sweep stops there: the remaining rows say "not
    reached".  It never continues silently on another assembly branch.

    Returns
    -------
    pandas.DataFrame
        Columns ``input:<label>`` for every input, one per joint coordinate
        (``coordinate_labels()``), ``residual``, ``condition``, ``iterations``,
        ``status`` and ``reached:<label>`` (the input actually reached: differs
        from the requested one on a stopped row).
    Pose
        Only with ``return_pose=True``: the poses of the rows that were reached
        (for velocities, accelerations and analogs along the path).
    """
    from .kinematics import analogs  # local: kinematics imports solver helpers

    opts = options or SolverOptions()
    x, _ = _inputs_array(mech, values)
    start = solve(mech, x[0], guess, options=opts, raise_on_failure=False)
    rows_q, rows_rot = [start.q[0]], [start.rot[0]]
    res, cond, its, status = [start.residual[0]], [start.condition[0]], [start.iterations[0]], \
        ["ok" if start.status[0] == 0 else start.status_text[0]]
    cur, first_of = start, None
    unknown = mech.unknown_columns()
    stopped = start.status[0] >= 2
    for i in range(1, x.shape[0]):
        if stopped:
            break
        target = x[i]
        frac_done, h = 0.0, 1.0
        halvings = 0
        while frac_done < 1.0:
            h = min(h, 1.0 - frac_done)
            xt = x[i - 1] + (frac_done + h) * (target - x[i - 1])
            if first_of is not cur:                      # analogs once per accepted pose
                first, first_of = analogs(mech, cur, second=False)[0][0], cur
            pred, dv_s = predict(mech, cur, xt, first)
            st, r, it, c, conv, ks = newton(mech, pred, opts)
            jump = np.max(np.abs(_coord_distance(mech, st, pred)))
            step_len = np.max(np.abs(dv_s[unknown])) if unknown.size else 0.0
            okay = conv[0] and r[0] <= opts.rtol and c[0] <= opts.cond_limit and \
                jump <= 0.5 * max(step_len, 1e-3)
            if okay:
                cur = Pose(mech, xt[None], st[0], st[1], r, it, c, np.zeros(1, int), _ks=ks)
                frac_done += h
                h *= 2.0
                halvings = max(0, halvings - 1)
                continue
            halvings += 1
            h *= 0.5
            if halvings > max_halvings:
                stopped = True
                break
        if stopped:
            st_name = "no assembly" if (conv[0] and r[0] > opts.rtol) else "dead point"
            rows_q.append(cur.q[0])
            rows_rot.append(cur.rot[0])
            res.append(cur.residual[0])
            cond.append(cur.condition[0])
            its.append(0)
            status.append(st_name)
            reached_at = cur.inputs[0]
            break
        rows_q.append(cur.q[0])
        rows_rot.append(cur.rot[0])
        res.append(cur.residual[0])
        cond.append(cur.condition[0])
        its.append(cur.iterations[0])
        status.append("ok")
    n = len(rows_q)
    pose = Pose(mech, x[:n].copy(), np.array(rows_q), np.array(rows_rot),
                np.array(res), np.array(its), np.array(cond), np.zeros(n, int))
    df = pose.table()
    df["status"] = status
    reached = x[:n].copy()
    if stopped and n > 1 and status[-1] != "ok":
        reached[-1] = reached_at
    for k, lab in enumerate(mech.input_labels()):
        df[f"reached:{lab}"] = reached[:, k]
    if n < x.shape[0]:
        rest = pd.DataFrame({f"input:{lab}": x[n:, k] for k, lab in enumerate(mech.input_labels())})
        rest["status"] = "not reached"
        df = pd.concat([df, rest], ignore_index=True)
    if return_pose:
        ok = np.array(status) == "ok"
        pose = Pose(mech, pose.inputs[ok], pose.q[ok], pose.rot[ok], pose.residual[ok],
                    pose.iterations[ok], pose.condition[ok], pose.status[ok])
        return df, pose
    return df


def _coord_distance(mech, a, b):
    """Dimensionless distance per velocity coordinate between two states (B, nv)."""
    t = mech.tree
    out = np.zeros((a[0].shape[0], t.nv))
    for j in mech.joints:
        sl = slice(t.v_offset[j.index], t.v_offset[j.index] + j.nv)
        if j.kind == "S":
            si = t.s_index[j.index]
            rel = a[1][:, si] @ np.swapaxes(b[1][:, si], -1, -2)
            out[:, sl] = log_so3(rel)
        else:
            qa = a[0][:, t.q_offset[j.index]:t.q_offset[j.index] + j.nq]
            qb = b[0][:, t.q_offset[j.index]:t.q_offset[j.index] + j.nq]
            out[:, sl] = qa - qb
    out[:, t.length_cols] /= t.scale
    return out
