"""Loop closure: damped Gauss–Newton on the stacked 6-vector loop residuals.

One routine serves one pose and a batch alike: the Newton iterations, line searches and
continuation paths run in one compiled kernel (:func:`closure.solve_kernels.drive`) that
treats every member of a batch on its own, so the Python layer here only checks the
arguments, makes the arrays and wraps the results.  The Jacobian is made dimensionless
(translations and slides divided by the mechanism's length scale) before its singular
values are taken, so its condition number means the same at any size of mechanism.
Steps use the pseudo-inverse truncated to the expected rank (the unknowns minus the
idle freedoms, e.g. the spin of an S–S rod), which is least squares for overconstrained
loops (Bennett, Bricard) and keeps idle freedoms still.  It is applied by Cholesky on
the normal equations where the Jacobian is well conditioned and by the truncated SVD
elsewhere (as :class:`_LstSq`); the condition number is computed once, for the poses
returned (for well-conditioned poses when it is first read).

Each iteration evaluates the kinematic state once per line-search trial and makes one
factorisation, which serves the Newton step and the first-order analogs at once (the
Jacobian's input columns are extra right-hand sides): the continuation's predictor takes
its tangent from the corrector's last iteration.  The last iteration of a batch member
whose kinematic state is not returned may converge on a bound of its step instead (no
analogs needed there: the same poses and figures).  The factorisation follows the
Jacobian's block structure (loops that share few joints: linear in the number of loops).
A batch solved by continuation from its guesses is one kernel call (each guess corrected,
then continued, members with the same guess sharing its correction), with no
per-member kinematic state outside the kernel unless the poses keep it.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from .errors import ClosureError, MechanismError
from .checks import shown
from .lstsq import (FAST_COND, SINGULAR_RTOL, _cond_of, _condition, _expected_rank, _LstSq,
                    _pinv_parts, _serial_blas_entries)
from .pose import KEEP_STATE, STATUS, Pose
from .state import KinematicState, _arr

__all__ = ["solve", "sweep", "predict", "SolverOptions"]

#: the least-squares helpers now live in closure.lstsq; kept importable from here
_FROM_LSTSQ = (SINGULAR_RTOL, _cond_of, _condition, _LstSq, _pinv_parts)


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
    the coordinates that move.  Steps are those of :class:`_LstSq` (normal equations where
    the Jacobian is well conditioned, the truncated SVD elsewhere); the condition
    number is computed once, for the returned poses.  With ``exact_cond=False`` it is
    left NaN for poses whose condition estimate is at most :data:`FAST_COND` (their
    estimate is below any condition a caller acts on) and exact elsewhere.

    With the default columns the same factorisation also gives the first-order
    analogs (the Jacobian's input columns are extra right-hand sides): they are
    returned as ``ks.first`` for the converged poses (NaN elsewhere).

    Every member is corrected on its own by the compiled kernel
    :func:`closure.solve_kernels.drive` (the same iterations for one pose or a batch).

    Returns ``(state, residual, iterations, condition, converged, ks)`` where
    ``ks`` is the :class:`KinematicState` of the returned poses.
    """
    plan = mech.plan
    default = columns is None
    rank = _expected_rank(mech) if rank is None else int(rank)
    if default:
        ucols, icols = plan._ucols, plan._icols
    else:
        ucols, icols = np.array(columns, dtype=np.int64).reshape(-1), _NO_COLS
    q, rot = state
    q = np.array(q, dtype=float)                 # copies: corrected in place
    rot = np.array(rot, dtype=float)
    plan._state_arrays(q, rot)
    B, nv, nj = q.shape[0], plan.nv, plan.nj
    link = np.empty((B, plan.nl, 4, 4))
    fa = np.empty((B, nj, 4, 4))
    A = np.empty((B, nj, 4, 4))
    r = np.empty((B, plan.chords.size, 6))
    S = np.empty((B, nv, 6))
    first = np.empty((B, nv, icols.size))
    res, cond, last = np.empty(B), np.empty(B), np.empty(B)
    its = np.empty(B, dtype=np.int64)
    flag = np.empty(B, dtype=np.int64)
    k = plan._kernels
    with _serial_blas_for(plan, ucols.size):
        k.drive(k.NEWTON, *plan.packed, _NO_X, _NO_X, q, rot, A, link, fa, r, S, first, res, cond,
                last, its, flag, _NO_T, False, _path_options(opts, 0.0),
                opts.maxiter, rank, ucols, icols, _NO_X)
    done = flag.astype(bool)
    if exact_cond:             # the SVD's condition at the returned state, as the flags need
        left = np.nonzero(~done | np.isnan(cond))[0]
        if left.size:
            if default and rank == _expected_rank(mech):
                cond[left] = plan.condition(S, left)
            else:
                cond[left] = _condition(plan.scaled_jacobian(S[left], ucols), rank)
    ks = KinematicState(link, fa, A, r, S, plan.carrier, plan.deps,
                        first if default else None, last if default else None)
    return (q, rot), res, its, cond, done, ks


#: placeholders for the arguments a task of closure.solve_kernels.drive does not use
_NO_COLS, _NO_X, _NO_T = np.zeros(0, dtype=np.int64), np.zeros((0, 0)), np.zeros((0, 0, 0))


def _serial_blas_for(plan, n_cols):
    """:func:`closure.lstsq._serial_blas` for the Jacobians of ``n_cols`` columns."""
    return _serial_blas_entries(6 * plan.chords.size * n_cols)


def _exact_condition(mech, ks, cond):
    """Fill in, in place, the conditions left NaN by ``newton(..., exact_cond=False)``
    from the kinematic state ``ks`` of the same poses."""
    idx = np.nonzero(np.isnan(cond))[0]
    if idx.size:
        _expected_rank(mech)
        cond[idx] = mech.plan.condition(ks.S, idx)
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


def _options(options) -> "SolverOptions":
    """The solver options: the default for None, else a SolverOptions."""
    if options is None:
        return _DEFAULT_OPTIONS
    if not isinstance(options, SolverOptions):
        raise MechanismError(f"options: expected a SolverOptions (or None), got "
                             f"{type(options).__name__}")
    return options


#: the options of calls that give none (never changed: SolverOptions.replace copies)
_DEFAULT_OPTIONS = SolverOptions()


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
    """Status codes: 1 where the condition exceeds the limit, 2 not converged (``conv``;
    None: all converged), 3 converged with a residual above ``rtol`` · offset."""
    rtol = opts.rtol * mech.plan.offset
    if res.shape == (1,):                       # one pose: no array operations
        c = not conv[0] if conv is not None else False
        s = 2 if c else 3 if res[0] > rtol else 1 if cond[0] > opts.cond_limit else 0
        return np.array([s])
    status = np.zeros(res.shape, dtype=int)
    status[cond > opts.cond_limit] = 1
    if conv is None:
        status[res > rtol] = 3
        return status
    status[~conv] = 2
    status[conv & (res > rtol)] = 3
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
    gives that previous tangent for the start poses.  The members walk on their own in
    the compiled kernel :func:`closure.solve_kernels.drive`.

    Returns
    -------
    pose : Pose
        Each member's last accepted pose (its ``inputs`` are where it stands).
    stop : (B,) int
        0 reached the target, 3 no assembly, 4 dead point.
    tangent : (B, nv, ni)
        The first analogs used last (the path's tangent at the returned poses).
    """
    x_cur, q, rot, res, its, cond, ks, stop, tan = _walk(mech, start, x_to, opts, min_step,
                                                         tangent)
    # conditions left NaN (estimate ≤ FAST_COND) are computed when the pose is asked
    pose = Pose(mech, x_cur, q, rot, res, its, cond, np.zeros(len(start), int), _ks=ks,
                _cond_pending=True)
    return pose, stop, tan


def _walk(mech, start: Pose, x_to, opts: SolverOptions, min_step: float = 1e-10,
          tangent=None, owned: bool = False):
    """:func:`_continue` as arrays: ``(x_cur, q, rot, residual, iterations, condition, ks,
    stop, tangent)``.  With ``owned`` the arrays of ``start`` (and its kinematic state) are
    updated in place instead of copied."""
    plan = mech.plan
    B = len(start)
    get = _arr if owned else np.array
    x_from = np.array(start.inputs, dtype=float).reshape(B, -1)
    x_to = np.asarray(x_to, float)
    x_to = np.array(x_to if x_to.shape == x_from.shape else
                    np.broadcast_to(x_to, x_from.shape))
    ks = start.kinematics()
    q, rot = get(start.q, dtype=float), get(start.rot, dtype=float)
    link, fa, A, r, S = (get(a, dtype=float) for a in (ks.link, ks.frame_a, ks.A, ks.r, ks.S))
    ni = x_from.shape[1]
    first = np.full((B, plan.nv, ni), np.nan) if ks.first is None else \
        get(ks.first, dtype=float)
    step = np.full(B, np.nan) if ks.step is None else get(ks.step, dtype=float)
    res = get(start.residual, dtype=float)
    cond = get(start._raw_condition, dtype=float)
    tan = np.zeros((B, plan.nv, ni)) if tangent is None else \
        np.array(np.broadcast_to(tangent, (B, plan.nv, ni)), dtype=float)
    x_cur = np.empty((B, ni))
    its = np.empty(B, dtype=np.int64)
    stop = np.empty(B, dtype=np.int64)
    k = plan._kernels
    with _serial_blas_for(plan, plan._ucols.size):
        n = k.drive(k.CONTINUE, *plan.packed, x_from, x_to, q, rot, A, link, fa, r, S, first,
                    res, cond, step, its, stop, tan, tangent is not None,
                    _path_options(opts, min_step), min(opts.maxiter, 8), _expected_rank(mech),
                    plan._ucols, plan._icols, x_cur)
    if n < 0:                                   # a path longer than MAX_PATH
        _check_path(x_from, x_to, plan.input_scale)
    ks_out = KinematicState(link, fa, A, r, S, plan.carrier, plan.deps, first,
                            None if ks.step is None else step)
    return x_cur, q, rot, res, its, cond, ks_out, stop, tan


#: True: the solver kernel factors every Jacobian densely, whatever its block structure
#: (the reference the block-sparse factorisation of loop chains is tested and timed
#: against); never set by the engine itself
DENSE_LSQ = False


def _path_options(opts: SolverOptions, min_step: float) -> np.ndarray:
    """The solver kernel's tolerances: xtol, rtol, max_step, path_step, min_step,
    TANGENT_COND, dense (:data:`DENSE_LSQ`), MAX_PATH."""
    return np.array([opts.xtol, opts.rtol, opts.max_step, opts.path_step, min_step,
                     TANGENT_COND, 1.0 if DENSE_LSQ else 0.0, MAX_PATH])


def _check_path(x_from, x_to, xs) -> None:
    """Raise when an input path is longer than :data:`MAX_PATH` (dimensionless)."""
    span = x_to - x_from
    span_s = np.max(np.abs(span / xs), axis=1) if span.size else np.zeros(span.shape[0])
    if span_s.max(initial=0.0) > MAX_PATH:
        i = int(np.argmax(span_s))
        raise MechanismError(f"inputs: {x_to[i].tolist()} lie {span_s[i]:.3g} (dimensionless) "
                             f"from the guess at {x_from[i].tolist()}; continuation follows "
                             f"paths up to {MAX_PATH:g}: give a guess nearer the inputs, or "
                             "continuation=False")


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


def _guess_arrays(mech, guess: Pose | None, B: int):
    """``(q, rot, inputs)`` of the guess (or the assembly), checked: 1 or B poses."""
    if guess is None:
        q, rot = mech.assembly()
        x0 = q[:, mech.plan.input_q]
    else:
        if not isinstance(guess, Pose):
            raise MechanismError(f"guess: expected a Pose, got {type(guess).__name__}")
        if guess.mechanism is not mech:
            raise MechanismError("guess: a Pose of another mechanism")
        q, rot, x0 = guess.q, guess.rot, np.asarray(guess.inputs, float).reshape(len(guess), -1)
    if q.shape[0] not in (1, B):
        raise MechanismError(f"guess: has {q.shape[0]} poses, expected 1 or {B}")
    return q, rot, x0


def _start_pose(mech, guess: Pose | None, B: int, opts: SolverOptions, settled=None):
    """The poses continuation starts from: the guess (or the assembly) corrected at its
    own inputs, broadcast to B members; and whether they are the caller's to change (not
    the guess's own arrays).  ``settled``: :func:`_settled` of the guess when known."""
    q, rot, x0 = _guess_arrays(mech, guess, B)
    n = q.shape[0]
    if settled is None:
        settled = guess is not None and _settled(mech, guess, opts)
    if settled:
        # a pose the solver stopped at with its residual at rounding level and a step
        # below xtol: correcting it again would converge at once without moving it
        pose = Pose(mech, x0, guess.q, guess.rot, guess.residual, np.zeros(n, int),
                    guess._raw_condition, np.zeros(n, int), _ks=guess._ks,
                    _cond_pending=guess._cond_pending)
        if n == 1 and B > 1:
            return _take_pose(pose, np.zeros(B, dtype=int)), True
        return pose, False
    q = q.copy()
    q[:, mech.plan.input_q] = x0
    st, res, its, cond, conv, ks = newton(mech, (q, rot), opts, exact_cond=False)
    pose = Pose(mech, x0, st[0], st[1], res, its, cond, _status(mech, res, cond, conv, opts),
                _ks=ks, _cond_pending=True)
    return (_take_pose(pose, np.zeros(B, dtype=int)) if n == 1 and B > 1 else pose), True


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
    if len(guess) == 1:                        # one pose: scalar tests
        if not (ks.step[0] <= opts.xtol * off and guess.residual[0] <= 1e-14 * off) or \
                np.isnan(ks.first).any():
            return False
        a, b = guess.q[0, plan.input_q], guess.inputs[0]
        return a.shape == np.shape(b) and bool((a == b).all())
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
    if B > CHUNK and not _fused(mech, guess, opts, continuation):
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


def _fused(mech, guess, opts: SolverOptions, continuation: bool) -> bool:
    """True when :func:`solve` corrects the guesses and continues from them in one call of
    the compiled kernel (:func:`_solve_fused`): continuation on a mechanism with loops from
    a guess that is not already a settled pose (whose correction is skipped)."""
    if not (continuation and mech.tree.chords):
        return False
    return not (isinstance(guess, Pose) and guess.mechanism is mech and
                _settled(mech, guess, opts))


def _solve_fused(mech, x, scalar, guess, opts: SolverOptions) -> Pose:
    """The poses of :func:`solve` by continuation from the guesses (the assembly when
    None), at inputs ``x`` (B, ni): every member's guess corrected (Newton) and continued
    to its input in one call of :func:`closure.solve_kernels.drive` (task ``SOLVE``), the
    member's kinematic state kept in the kernel's scratch (returned only for batches of
    at most :data:`KEEP_STATE`): the poses of the two-step path (:func:`_start_pose`,
    :func:`_walk`) without its per-member temporaries."""
    plan = mech.plan
    q0, rot0, x0 = _guess_arrays(mech, guess, x.shape[0])
    B, ni = x.shape
    q = np.empty((B, plan.nq))
    q[:] = q0
    q[:, plan.input_q] = x0
    rot = np.empty((B, plan.ns, 3, 3))
    rot[:] = rot0
    x_from = np.empty((B, ni))
    x_from[:] = x0
    keep = B <= KEEP_STATE
    nb, nv = (B if keep else 0), plan.nv
    A, fa = np.empty((nb, plan.nj, 4, 4)), np.empty((nb, plan.nj, 4, 4))
    link, r = np.empty((nb, plan.nl, 4, 4)), np.empty((nb, plan.chords.size, 6))
    S, first = np.empty((nb, nv, 6)), np.empty((nb, nv, ni))
    res, cond, last = np.empty(B), np.empty(B), np.empty(B)
    its, flag = np.empty(B, dtype=np.int64), np.empty(B, dtype=np.int64)
    x_cur = np.empty((B, ni))
    k = plan._kernels
    with _serial_blas_for(plan, plan._ucols.size):
        n = k.drive(k.SOLVE, *plan.packed, x_from, _arr(x), q, rot, A, link, fa, r, S, first,
                    res, cond, last, its, flag, _NO_T, False, _path_options(opts, 1e-10),
                    opts.maxiter, _expected_rank(mech), plan._ucols, plan._icols, x_cur)
    if n < 0:                                   # a path longer than MAX_PATH
        _check_path(x_from, x, plan.input_scale)
    ks = KinematicState(link, fa, A, r, S, plan.carrier, plan.deps, first, last) if keep \
        else None
    pose = Pose(mech, x, q, rot, res, its, cond, np.zeros(B, dtype=int), scalar, _ks=ks,
                reached=x_cur, _cond_pending=True)
    if opts.cond_limit < FAST_COND:              # the flags need the exact figures
        pose._fill_condition()
    status = _status(mech, res, pose._raw_condition, None, opts)
    # the start's failure (2, 3), else where the path stopped (3, 4)
    pose.status = np.where(flag > 0, flag, status) if B > 1 else \
        np.array([flag[0] if flag[0] > 0 else status[0]])
    return pose


def _solve_batch(mech, x, scalar, guess, opts, continuation) -> Pose:
    """The poses of :func:`solve` at inputs ``x`` (B, ni), without raising."""
    B = x.shape[0]
    if _fused(mech, guess, opts, continuation):
        return _solve_fused(mech, x, scalar, guess, opts)
    # not fused: no loops, no continuation, or a settled guess (known when both hold)
    settled = True if continuation and mech.tree.chords else None
    start, owned = _start_pose(mech, guess, B, opts, settled)
    if continuation and mech.tree.chords:         # an open chain has no branch to follow
        reached, q, rot, res, its, cond, ks, stop, _ = _walk(mech, start, x, opts, owned=owned)
        if opts.cond_limit < FAST_COND:          # the flags need the exact figures
            _exact_condition(mech, ks, cond)
        status = _status(mech, res, cond, None, opts)
        if B == 1:
            if start.status[0] >= 2 or stop[0] > 0:
                status[0] = start.status[0] if start.status[0] >= 2 else stop[0]
        else:
            status = np.where(start.status >= 2, start.status, np.where(stop > 0, stop, status))
        pose = Pose(mech, x, q, rot, res, its, cond, status, scalar, _ks=ks, reached=reached,
                    _cond_pending=True)
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
    pose, stops = _sweep_rows(mech, cur, x, opts)
    n = len(pose)
    keep = return_pose and n <= KEEP_STATE
    reached, pose.inputs = pose.inputs, x[:n].copy()
    raw = pose._raw_condition.copy()
    exact = pose.condition              # the table's: one batched SVD from the kept twists
    if not keep:
        pose._ks = None
    cond = exact if opts.cond_limit < FAST_COND else raw
    pose.status = _status(mech, pose.residual, cond, np.ones(n, bool), opts)
    status = [s if s is not None else STATUS[int(c)] for s, c in zip(stops, pose.status)]
    cols = pose._columns()
    cols["status"] = status
    for k, lab in enumerate(mech.input_labels()):
        cols[f"reached:{lab}"] = reached[:, k]
    df = pd.DataFrame(cols)
    if n < x.shape[0]:
        rest = pd.DataFrame({f"input:{lab}": x[n:, k] for k, lab in enumerate(mech.input_labels())})
        rest["status"] = "not reached"
        df = pd.concat([df, rest], ignore_index=True)
    if return_pose:
        return df, _take_pose(pose, np.nonzero([s is None for s in stops])[0])
    return df


def _sweep_rows(mech, cur: Pose, x, opts: SolverOptions):
    """The poses of a sweep's rows from its solved first row ``cur`` (one pose at
    ``x[0]``): row i by continuation from row i − 1 to ``x[i]``, its tangent handed to
    the next row, until a row stops; all rows in one call of the compiled kernel
    :func:`closure.solve_kernels.drive`.  Returns the rows' poses (``inputs``: where
    each stands; its kinematic state kept) and per row None or why it stopped."""
    plan = mech.plan
    stops = [cur.status_text[0] if cur.status[0] >= 2 else None]
    n_req = x.shape[0]
    if cur.status[0] >= 2 or n_req == 1:
        return cur, stops
    ks = cur.kinematics()
    nv, ni = plan.nv, x.shape[1]

    def rows(a, shape):
        out = np.empty((n_req,) + shape)
        out[0] = a[0]
        return out
    q, rot = rows(cur.q, (plan.nq,)), rows(cur.rot, (plan.ns, 3, 3))
    A, link = rows(ks.A, (plan.nj, 4, 4)), rows(ks.link, (plan.nl, 4, 4))
    fa, r, S = rows(ks.frame_a, (plan.nj, 4, 4)), rows(ks.r, (plan.chords.size, 6)), \
        rows(ks.S, (nv, 6))
    first = rows(np.full((1, nv, ni), np.nan) if ks.first is None else ks.first, (nv, ni))
    res, cond = rows(cur.residual, ()), rows(cur._raw_condition, ())
    step = rows(np.full(1, np.nan) if ks.step is None else ks.step, ())
    x_cur = rows(cur.inputs, (ni,))
    its = np.zeros(n_req, dtype=np.int64)
    its[0] = cur.iterations[0]
    stop = np.zeros(n_req, dtype=np.int64)
    k = plan._kernels
    with _serial_blas_for(plan, plan._ucols.size):
        n = k.drive(k.SWEEP, *plan.packed, _NO_X, _arr(x), q, rot, A,
                    link, fa, r, S, first, res, cond, step, its, stop, np.zeros((1, nv, ni)),
                    False, _path_options(opts, 1e-10), min(opts.maxiter, 8),
                    _expected_rank(mech), plan._ucols, plan._icols, x_cur)
    if n < 0:                                   # row −n − 1 lies too far: raise, as _continue
        _check_path(x_cur[-n - 2:-n - 1], x[-n - 1:-n], plan.input_scale)
    stops += [STATUS[int(c)] if c else None for c in stop[1:n]]
    status = np.zeros(n, dtype=int)
    status[0] = cur.status[0]
    ks_rows = KinematicState(link[:n], fa[:n], A[:n], r[:n], S[:n], plan.carrier, plan.deps,
                             first[:n], None if ks.step is None else step[:n])
    pose = Pose(mech, x_cur[:n], q[:n], rot[:n], res[:n], its[:n], cond[:n], status,
                _ks=ks_rows, _cond_pending=n > 1 or cur._cond_pending)
    return pose, stops


def _ks_cat(kss) -> KinematicState:
    """Concatenate kinematic states along the batch."""
    return KinematicState.concatenate(kss)


def _coord_distance(mech, a, b):
    """Dimensionless distance per velocity coordinate between two states (B, nv)."""
    return mech.plan.distance(a, b)
