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
number is computed once, for the poses returned.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from .errors import ClosureError, MechanismError
from .checks import shown
from .frames import _log_so3
from .pose import STATUS, Pose

__all__ = ["solve", "sweep", "predict", "SolverOptions"]


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

    def replace(self, **kw) -> "SolverOptions":
        """A copy with some fields changed."""
        d = dict(xtol=self.xtol, rtol=self.rtol, maxiter=self.maxiter, max_step=self.max_step,
                 cond_limit=self.cond_limit, path_step=self.path_step)
        d.update(kw)
        return SolverOptions(**d)


def _expected_rank(mech) -> int:
    n_unknown = mech.tree.nv - len(mech.inputs)
    idle = mech.mobility - len(mech.inputs)
    return n_unknown - idle


#: singular values below this fraction of the largest are treated as zero in steps
#: (minimum-norm steps at exactly singular poses, never a 1/0 blow-up)
SINGULAR_RTOL = 1e-12


def _pinv_parts(J, rank):
    """Truncated SVD pieces of a batch of matrices: (U, inv_s, Vt, condition).

    Keeps the ``rank`` largest singular values, and of those only the ones above
    ``SINGULAR_RTOL`` times the largest; the condition is ``s_max / s_rank``."""
    if J.shape[-1] == 0 or J.shape[-2] == 0:         # open chain: nothing to solve
        k = min(J.shape[-2:])
        B = J.shape[:-2]
        return (np.zeros(B + (J.shape[-2], k)), np.zeros(B + (k,)),
                np.zeros(B + (k, J.shape[-1])), np.ones(B))
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    rank = min(rank, s.shape[-1])
    k = np.arange(s.shape[-1])
    keep = (k < rank) & (s > SINGULAR_RTOL * s[..., :1])
    with np.errstate(divide="ignore", over="ignore"):
        inv_s = np.where(keep & (s > 1e-300), 1.0 / np.where(s > 0, s, 1.0), 0.0)
    return U, inv_s, Vt, _cond_of(s, rank)


def _cond_of(s, rank):
    """``s_max / s_rank`` from singular values ``(..., k)`` (inf where ``s_rank`` is 0)."""
    rank = min(rank, s.shape[-1])
    srank = s[..., rank - 1] if rank > 0 else np.ones(s.shape[:-1])
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return np.where(srank > 0, s[..., 0] / np.where(srank > 0, srank, 1.0), np.inf)


def _condition(J, rank):
    """Condition number ``s_max / s_rank`` of a batch of matrices (as :func:`_pinv_parts`,
    from the singular values alone)."""
    if J.shape[-1] == 0 or J.shape[-2] == 0:
        return np.ones(J.shape[:-2])
    return _cond_of(np.linalg.svd(J, compute_uv=False), rank)


#: poses whose estimated condition number (an upper bound, within a factor min(m, n))
#: is at most this solve by the normal equations (Cholesky, one step of iterative
#: refinement); the others by the truncated SVD
FAST_COND = 1e6


class _LstSq:
    """Minimum-norm least-squares solutions ``J X = R`` for a batch of matrices ``J``
    (B, m, n) truncated to ``rank``: the pseudo-inverse of :func:`_pinv_parts`.

    Where the expected rank is full (``min(m, n)``) the Gram matrix ``G`` (``J Jᵀ`` for
    wide, ``Jᵀ J`` for tall matrices) is factored by a batched Cholesky and solves take
    one step of iterative refinement; poses whose factorisation fails or whose condition
    estimate ``sqrt(tr G · tr G⁻¹)`` (at least the condition, at most ``min(m, n)``
    times it) exceeds :data:`FAST_COND`, and every pose of a mechanism whose expected
    rank is below ``min(m, n)``, use the truncated SVD as before (minimum-norm steps,
    never a 1/0).  No singular value is truncated at a Cholesky pose (its condition is
    far below ``1 / SINGULAR_RTOL``), so both give the same pseudo-inverse.

    Attributes
    ----------
    cond : (B,)
        ``s_max / s_rank`` for SVD poses, NaN for Cholesky poses (see :func:`_condition`).
    """

    def __init__(self, J, rank):
        B, m, n = J.shape
        k = min(m, n)
        self.J, self.wide = J, m < n
        self._inv_smin = np.zeros(B)
        self.fast = self._gram(J) if B and k and min(rank, k) == k else np.zeros(B, bool)
        self.slow = np.nonzero(~self.fast)[0]
        self.cond = np.full(B, np.nan)
        if self.slow.size:
            U, inv_s, Vt, cond = _pinv_parts(J[self.slow], rank)
            self.U, self.inv_s, self.Vt = U, inv_s, Vt
            self._inv_smin[self.slow] = np.max(inv_s, axis=1, initial=0.0)
            self.cond[self.slow] = cond

    def _gram(self, J):
        """Factor the Gram matrices; the poses that take the Cholesky path."""
        B = J.shape[0]
        Jt = np.swapaxes(J, 1, 2)
        G = J @ Jt if self.wide else Jt @ J
        ok = None
        try:
            L = np.linalg.cholesky(G)
        except np.linalg.LinAlgError:          # some not positive definite: screen them
            with np.errstate(all="ignore"):
                lam = np.linalg.eigvalsh(G)
            ok = lam[:, 0] > 1e-13 * lam[:, -1]
            L = np.tile(np.eye(G.shape[1]), (B, 1, 1))
            try:
                L[ok] = np.linalg.cholesky(G[ok])
            except np.linalg.LinAlgError:
                return np.zeros(B, dtype=bool)
        Linv = np.linalg.inv(L)                 # triangular with a positive diagonal
        tr_inv = np.einsum("bij,bij->b", Linv, Linv)                     # tr G⁻¹
        cest = np.sqrt(np.einsum("bij,bij->b", J, J) * tr_inv)           # ≥ s_max / s_min
        fast = cest <= FAST_COND                                         # False for NaN
        if ok is not None:
            fast &= ok
        if fast.all():
            self.Ginv = np.swapaxes(Linv, 1, 2) @ Linv                    # G⁻¹ = L⁻ᵀ L⁻¹
            self._inv_smin = np.sqrt(tr_inv)                             # ≥ 1 / s_min
        elif fast.any():
            Li = Linv[fast]
            self.Ginv = np.swapaxes(Li, 1, 2) @ Li
            self._inv_smin[fast] = np.sqrt(tr_inv[fast])
        return fast

    def inv_smin(self, above):
        """1 / (smallest kept singular value): exact for SVD poses; for Cholesky poses
        ``sqrt(tr G⁻¹)`` (at most ``sqrt(min(m, n))`` times it) where that is at most
        ``above``, else the 8th-power trace estimate (an upper bound within a factor
        ``min(m, n)^(1/16)``, nearly exact where that singular value stands apart; both to
        the eps · cond² ≤ 1e-4 of the normal equations)."""
        out = self._inv_smin.copy()
        big = self.fast & (out > above)
        if big.any():
            sel = big[self.fast]
            Gi = self.Ginv[sel]
            lam = out[big] ** 2                                          # tr G⁻¹
            M = Gi / lam[:, None, None]
            with np.errstate(all="ignore"):
                for p in (2, 4, 8):                  # λ_max(G⁻¹) ≤ tr(G⁻ᵖ)^(1/p)
                    M = M @ M
                    t = np.trace(M, axis1=1, axis2=2)
                    lam *= t ** (1.0 / p)
                    M /= t[:, None, None]
            out[big] = np.sqrt(lam)
        return out

    def solve(self, R):
        """``X`` (B, n, j) for right-hand sides ``R`` (B, m, j).  On the Cholesky poses one
        step of iterative refinement takes the relative error from about eps · cond² to
        (eps · cond²)² + eps · cond (≤ 1e-8 at ``FAST_COND``; the SVD's is eps · cond)."""
        B, m, n = self.J.shape
        X = np.zeros((B, n, R.shape[2]))
        if self.fast.any():
            allf = self.fast.all()
            J = self.J if allf else self.J[self.fast]
            Rf = R if allf else R[self.fast]
            Jt = np.swapaxes(J, 1, 2)
            Gi = self.Ginv
            if self.wide:
                Xf = Jt @ (Gi @ Rf)
                Xf += Jt @ (Gi @ (Rf - J @ Xf))
            else:
                Xf = Gi @ (Jt @ Rf)
                Xf += Gi @ (Jt @ (Rf - J @ Xf))
            if allf:
                return Xf
            X[self.fast] = Xf
        if self.slow.size:
            X[self.slow] = np.einsum("bkn,bk,bmk,bmj->bnj", self.Vt, self.inv_s, self.U,
                                     R[self.slow])
        return X


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

    Returns ``(state, residual, iterations, condition, converged, ks)`` where
    ``ks`` is the kinematic state of the returned poses.
    """
    unknown = mech.unknown_columns() if columns is None else columns
    rank = _expected_rank(mech) if rank is None else rank
    offset = _origin_offset(mech)                              # digits lost to the origin
    floor, xtol = 1e-14 * offset, opts.xtol * offset
    noise = 1e-15 * offset                                     # rounding in the residual
    q, rot = (a.copy() for a in state)
    B = q.shape[0]
    its = np.zeros(B, dtype=int)
    done = np.zeros(B, dtype=bool)
    cond = np.ones(B)
    ks_all = mech.kinematic_state((q, rot))
    res = _norm(mech._scaled_residual(ks_all))
    prev = np.full(B, np.inf)
    if unknown.size == 0:                        # open chain driven in every joint
        done[:] = True
    for _ in range(opts.maxiter):
        act = np.nonzero(~done)[0]
        if act.size == 0:
            break
        ks = ks_all if act.size == B else _ks_take(ks_all, act)     # read only
        r = mech._scaled_residual(ks)
        J = mech._scaled_jacobian(ks)[:, :, unknown]
        ls = _LstSq(J, rank)
        cond[act] = ls.cond
        its[act] += 1
        step_u = -ls.solve(r[:, :, None])[:, :, 0]
        big = np.max(np.abs(step_u), axis=1)
        # converged: the residual at rounding level (the coordinates are then as accurate
        # as the condition number allows), or steps of at most xtol that no longer
        # reduce the residual
        stalled = (its[act] > 1) & (res[act] > 0.5 * prev[act])
        # near a singular configuration a residual at rounding level still leaves a
        # coordinate error of residual / σ_min: converged only once the step itself is
        # what rounding in the residual explains (noise / σ_min), or below xtol
        tol_step = np.maximum(xtol, noise * ls.inv_smin(xtol / noise))
        conv = (big <= tol_step) & ((res[act] <= floor) | stalled)
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
            good = (rn <= r0[idx] * (1 + 1e-9)) | (rn < floor) | (h == 7)
            g = act[idx[good]]
            q[g], rot[g] = trial[0][good], trial[1][good]
            res[g] = rn[good]
            _ks_put(ks_all, g, ks_t, good)
            pending[idx[good]] = False
            alpha[idx[~good]] *= 0.5
            if not pending.any():
                break
    # the condition at the returned state: not converged, or a step by Cholesky
    left = np.nonzero(~done | (np.isnan(cond) & exact_cond))[0]
    if left.size:
        ks = ks_all if left.size == B else _ks_take(ks_all, left)
        J = mech._scaled_jacobian(ks)[:, :, unknown]
        cond[left] = _condition(J, rank) if exact_cond else _LstSq(J, rank).cond
    return (q, rot), res, its, cond, done, ks_all


def _exact_condition(mech, ks, cond):
    """Fill in, in place, the conditions left NaN by ``newton(..., exact_cond=False)``
    from the kinematic state ``ks`` of the same poses."""
    idx = np.nonzero(np.isnan(cond))[0]
    if idx.size:
        sub = ks if idx.size == cond.size else _ks_take(ks, idx)
        J = mech._scaled_jacobian(sub)[:, :, mech.unknown_columns()]
        cond[idx] = _condition(J, _expected_rank(mech))
    return cond


def predict(mech, state, first, x_from, x_new):
    """First-order predictor, batched: states ``(q, rot)`` solved at inputs ``x_from``
    (B, ni) moved along their first analogs ``first`` (B, nv, ni) to the inputs ``x_new``
    (B, ni).  Returns the predicted state with the inputs set, and the dimensionless
    step of every velocity coordinate ``(B, nv)``."""
    t = mech.tree
    dv = np.einsum("bci,bi->bc", first, x_new - x_from)
    dv[:, t.length_cols] /= t.scale
    q, rot = _apply(mech, state, dv)
    q[:, mech.input_q_columns()] = x_new
    return (q, rot), dv


def _take_pose(pose: Pose, idx) -> Pose:
    """Poses ``idx`` of a batch (with their kinematic state)."""
    idx = np.asarray(idx)
    return Pose(pose.mechanism, pose.inputs[idx], pose.q[idx], pose.rot[idx],
                pose.residual[idx], pose.iterations[idx], pose.condition[idx],
                pose.status[idx], _ks=_ks_take(pose.kinematics(), idx))


def _cat_poses(poses) -> Pose:
    """One batch of the poses of a list of batches (with their kinematic states)."""
    cat = {f: np.concatenate([getattr(p, f) for p in poses])
           for f in ("inputs", "q", "rot", "residual", "iterations", "condition", "status")}
    return Pose(poses[0].mechanism, **cat, _ks=_ks_cat([p.kinematics() for p in poses]))


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
    t = mech.tree
    return 1.0 + float(np.linalg.norm(t.centre)) / t.scale


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
    cols = mech.input_columns()
    return np.where(np.isin(cols, mech.tree.length_cols), mech.tree.scale, 1.0)


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
    res, cond = start.residual.astype(float).copy(), start.condition.astype(float).copy()
    its = np.zeros(B, dtype=int)                              # this path's iterations only
    ks_all = _ks_take(start.kinematics(), np.arange(B))       # a copy: updated in place
    first = np.zeros((B, t.nv, x_from.shape[1]))
    have = np.zeros(B, dtype=bool)
    if tangent is not None:
        first[:] = tangent
        have[:] = True
    need = np.ones(B, dtype=bool)
    lam, h = np.zeros(B), np.ones(B)
    stop = np.zeros(B, dtype=int)
    active = span_s > 0
    step_opts = opts.replace(maxiter=min(opts.maxiter, 8))
    from .kinematics import analogs   # local: kinematics imports solver helpers
    while active.any():
        a = np.nonzero(active)[0]
        nf = a[need[a]]
        if nf.size:
            cur = Pose(mech, x_cur[nf], q[nf], rot[nf], res[nf], its[nf], cond[nf],
                       np.zeros(nf.size, int), _ks=_ks_take(ks_all, nf))
            new = analogs(mech, cur, second=False)[0]
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
        jump = np.max(np.abs(_coord_distance(mech, st, (pq, prot))), axis=1)
        ok = conv & (r <= opts.rtol) & (jump <= 0.5 * big)
        g, sub = a[ok], np.nonzero(ok)[0]
        if g.size:
            q[g], rot[g], x_cur[g] = st[0][sub], st[1][sub], xt[sub]
            res[g], cond[g], its[g] = r[sub], c[sub], its[g] + it[sub]
            _ks_put(ks_all, g, ks, sub)
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
    _exact_condition(mech, ks_all, cond)
    pose = Pose(mech, x_cur, q, rot, res, its, cond, np.zeros(B, int), _ks=ks_all)
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
    q = q.copy()
    q[:, mech.input_q_columns()] = x0
    st, res, its, cond, conv, ks = newton(mech, (q, rot.copy()), opts, exact_cond=False)
    pose = Pose(mech, x0, st[0], st[1], res, its, cond, _status(mech, res, cond, conv, opts),
                _ks=ks)
    return _take_pose(pose, np.zeros(B, dtype=int)) if n == 1 and B > 1 else pose


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
        parts.append(_solve_batch(mech, x[sl], False, g, opts, continuation))
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
        res, cond = pose.residual, pose.condition
        status = _status(mech, res, cond, np.ones(B, bool), opts)
        status = np.where(start.status >= 2, start.status, np.where(stop > 0, stop, status))
        reached = pose.inputs
        pose = Pose(mech, x, pose.q, pose.rot, res, pose.iterations, cond, status, scalar,
                    _ks=pose._ks, reached=reached)
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
    pose = _cat_poses(poses)
    reached, pose.inputs = pose.inputs, x[:n].copy()
    pose.status = _status(mech, pose.residual, pose.condition, np.ones(n, bool), opts)
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


def _ks_cat(kss):
    """Concatenate kinematic states along the batch."""
    out = {k: np.concatenate([ks[k] for ks in kss]) for k in _BATCHED if k in kss[0]}
    out["A"] = [np.concatenate(a) for a in zip(*(ks["A"] for ks in kss))]
    for k in ("carrier", "deps"):
        if k in kss[0]:
            out[k] = kss[0][k]
    return out


def _coord_distance(mech, a, b):
    """Dimensionless distance per velocity coordinate between two states (B, nv)."""
    t = mech.tree
    out = np.zeros((a[0].shape[0], t.nv))
    for j in mech.joints:
        sl = slice(t.v_offset[j.index], t.v_offset[j.index] + j.nv)
        if j.kind == "S":
            si = t.s_index[j.index]
            rel = a[1][:, si] @ np.swapaxes(b[1][:, si], -1, -2)
            out[:, sl] = _log_so3(rel)
        else:
            qa = a[0][:, t.q_offset[j.index]:t.q_offset[j.index] + j.nq]
            qb = b[0][:, t.q_offset[j.index]:t.q_offset[j.index] + j.nq]
            out[:, sl] = qa - qb
    out[:, t.length_cols] /= t.scale
    return out
