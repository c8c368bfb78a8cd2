"""Batched forward dynamics: B independent trajectories (initial states) in one call.

:func:`simulate_batch` integrates ``M(x) ẍ = Q(t, x, ẋ) − h(x, ẋ)`` for B members of
one :class:`~closure.dynamics.Dynamics` model with
:func:`closure.batch_integrate.integrate_batch` (scipy's RK45/DOP853 controller per
member).  Each stage of the active members is one compiled call for them all
(:func:`closure.dynamics_kernels.stage`, task ``RHS``), the kernel code that one
right-hand side of :meth:`~closure.dynamics.Dynamics.simulate` runs for its single
trajectory, with no Python per member (for a one-loop mechanism, 64 members at a time in
SIMD lanes, :mod:`closure.lane_kernels`: the same arithmetic, so a member's right-hand
side is the one ``simulate`` computes at the same state, bit for bit); for each member:

- its last solved pose moved along its own tangent (first analogs) to the stage's inputs,
  plus a second-order term along its last rates and, for one input, a third-order term
  from the second analogs of its last two poses;
- the solver's Newton (:func:`closure.solve_kernels._newton`) corrects it, so that each
  member is tracked on its own branch;
- the pose judged (closed, its condition number), the terms M, h, Q, the first analogs
  and the dampers' power formed there (with the Newton's last factorisation of the loop
  Jacobian where it is the pose's), ``ẍ = M⁻¹ (Q − h)``, and the member's base pose and
  tangent moved on.

The model's kernel data are packed once (``Dynamics._packed``, kept until the model
changes).  Given joint forces and drives (Python callables) are added by vectorised calls
over the members as ``M⁻¹ F``.  What the kernel cannot settle for a member is done pose
by pose here, as ``simulate`` does: a pose whose condition number exceeds
:data:`closure.integrate.RHS_COND` takes the dynamics' limit along its branch
(:func:`closure.integrate.regular_limit`); a member whose pose does not close, or whose
condition number exceeds ``options.cond_limit`` at a fold of the loop equations (a dead
point), is stopped (status 1 with a message) while the others go on.

At the output times the energies are those ``simulate`` reports: during the run each
member's solved pose nearest in time to every output time is kept
(:func:`closure.dynamics_kernels.nearest_poses`), its pose at the output time follows by
the tangent predictor and the solver's Newton, and kinetic, potential (gravity and
springs) and total energy and the balance ``energy + dissipated − work − E(0)`` come
from the compiled terms there: all members and times in one call of the stage.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .batch_integrate import BATCH_METHODS, integrate_batch
from .errors import MechanismError
from .frames import as_array
from .pose import Pose
from .solver import SolverOptions, _serial_blas_for, _status, _take_pose

__all__ = ["BatchDynamicsResult", "simulate_batch"]


@dataclass
class BatchDynamicsResult:
    """What :func:`simulate_batch` did for each member.

    Attributes
    ----------
    t_eval : (N,) ndarray
        Output times (s).
    x, xd : (B, n, N) ndarray
        Inputs and their rates at the output times (NaN after a member stopped).
    dissipated, work : (B, N) ndarray
        Integrated dampers' power and work of the given joint forces and drives (J).
    kinetic, potential, energy : (B, N) ndarray
        Kinetic, potential (gravity and springs) and total energy at the output times (J),
        as :meth:`~closure.dynamics.Dynamics.simulate` reports them (NaN after a member
        stopped, or where the pose at an output time did not close; all NaN without
        ``energy=True``).
    balance : (B, N) ndarray
        ``energy + dissipated − work − E(0)`` (J): zero for an exact solution.
    t_end : (B,) ndarray
        Where each member stopped (s).
    x_end : (B, n) ndarray
        The inputs there.
    status : (B,) int ndarray
        0 finished, 1 stopped (pose not closed, dead point, non-finite force), -1 step too
        small.
    message : (B,) object ndarray of str
    nfev, steps : (B,) int ndarray
        Right-hand-side evaluations and accepted steps of each member.
    method : str
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
    kinetic: np.ndarray | None = None
    potential: np.ndarray | None = None
    energy: np.ndarray | None = None
    balance: np.ndarray | None = None


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


class _Members:
    """The tracked poses of a batch and its calls of the compiled kernels.

    Per member: the base pose (``bq`` (B, nq), ``brot`` (B, ns, 3, 3) at inputs ``bx``
    (B, n): the last pose solved for it), its tangent (first analogs, ``tangent``
    (B, nv, n)) and its block of the kernels' fields (``blocks`` (B, size) over ``buf``:
    its last right-hand side, whose rates and velocity-product accelerations give the
    predictor's higher-order terms), updated in place by the kernels.
    """

    def __init__(self, dynamics, start: Pose, ok: np.ndarray, xd0: np.ndarray,
                 opts: SolverOptions):
        from . import dynamics_kernels as dk
        from .integrate import RHS_COND
        from .lstsq import _expected_rank
        mech = dynamics.m
        plan = mech.plan
        B, n = start.inputs.shape
        nv, nq = plan.nv, plan.nq
        self.dk, self.n, self.nv, self.mech, self.opts = dk, n, nv, mech, opts
        _, DI, DF = dynamics._packed()
        rank = _expected_rank(mech)
        fopts, iopt = dk.options(opts, rank, RHS_COND, n, nv, nq)
        self.layout = dk.layout(n, nv, nq)
        self.size = self.layout["size"]
        self.B = B
        self.bq = np.array(start.q, dtype=float, order="C")
        self.brot = np.array(start.rot, dtype=float, order="C")
        self.bx = np.array(start.inputs, dtype=float, order="C")
        self.tangent = np.zeros((B, nv, n))
        self.tangent[ok] = _start_tangents(mech, _take_pose(start, np.nonzero(ok)[0]),
                                           xd0[ok], opts)
        self.tangent0 = self.tangent.copy()
        self.buf = np.zeros(B * self.size)
        self.blocks = self.buf.reshape(B, self.size)
        # no output times: the stage's T, t, near and kept poses empty
        self._nokeep = (np.zeros(0), np.zeros(0), np.zeros((0, 0)), np.zeros((0, 0, nq)),
                        np.zeros((0, 0) + self.brot.shape[1:]), np.zeros((0, 0, n)),
                        np.zeros((0, 0, nv, n)))
        self._keep = None
        self._stage = dk.stage
        # the stage's arguments before the members' arrays
        self._stage_head = (*plan.packed, DI, DF, fopts, iopt, plan._ucols, plan._icols)

    def solve(self, members: np.ndarray, y: np.ndarray, t: np.ndarray) -> int:
        """The right-hand side of ``members`` (A,) int64 at times ``t`` (A,) and states ``y``
        (A, 2n + 2) (C-contiguous): one compiled call for them all
        (:func:`closure.dynamics_kernels.stage`, task ``RHS``: predictor, the solver's
        Newton, terms), into their rows of :attr:`blocks` (their bases and tangents moved
        in place; after :meth:`keep_outputs`, those whose code is ``OK`` kept for the
        output times, as :meth:`keep`).  Returns the number of members whose code is not
        ``OK``."""
        if self._keep is None:
            keep = self._nokeep
        else:
            keep = (self._T, np.ascontiguousarray(self._dir * t, dtype=float)) + self._keep
        return self._stage(*self._stage_head, members, self.bq.reshape(-1),
                           self.brot.reshape(-1, 3, 3), self.bx.reshape(-1),
                           self.tangent.reshape(-1, self.n), y.reshape(-1), self.buf, *keep)

    def keep_outputs(self, t_eval: np.ndarray, direction: float) -> None:
        """From now on keep, for every output time of ``t_eval`` (N,) and every member, its
        solved pose nearest in time (:func:`closure.dynamics_kernels.nearest_poses`):
        ``near`` (B, N) and the poses ``kept`` = (q, rot, inputs, tangent), each (B, N, ...).
        ``direction``: 1 forward, −1 backward in time."""
        B, N = self.B, t_eval.size
        self._dir = direction
        self._T = np.ascontiguousarray(direction * t_eval, dtype=float)
        self.near = np.full((B, N), np.inf)
        self.kept = tuple(np.zeros((B, N) + a.shape[1:]) for a in
                          (self.bq, self.brot, self.bx, self.tangent))
        self._keep = (self.near, *self.kept)

    def keep(self, t: np.ndarray, members: np.ndarray) -> None:
        """The bases of ``members`` (A,) int64, solved at times ``t`` (A,), as the poses
        kept for the output times around them (after :meth:`keep_outputs`)."""
        if members.size:
            self.dk.nearest_poses(self._T, np.ascontiguousarray(self._dir * t, dtype=float),
                                  members, self.bq, self.brot, self.bx, self.tangent,
                                  self.near, *self.kept)

    def field(self, blocks: np.ndarray, name: str, shape: tuple) -> np.ndarray:
        """Field ``name`` of the blocks (A, size) as an (A, *shape) view."""
        o = self.layout[name]
        return blocks[:, o:o + math.prod(shape)].reshape((len(blocks),) + shape)

    def rows(self, name: str, shape: tuple, members: np.ndarray) -> np.ndarray:
        """Field ``name`` of the blocks of ``members`` (A,) (ascending), an (A, *shape)
        copy."""
        v = self.field(self.blocks, name, shape)
        return v.copy() if len(members) == self.B else np.take(v, members, axis=0)

    def pose(self, g: int) -> Pose:
        """The Pose of member ``g``'s base with the figures of its block."""
        return self.pose_of(self.bq[g], self.brot[g], self.bx[g],
                            self.field(self.blocks, "fig", (5,))[g])

    def pose_of(self, q, rot, x, fig) -> Pose:
        """The one-row Pose of coordinates ``q`` (nq,), rotations ``rot`` (ns, 3, 3) at
        inputs ``x`` (n,) with a block's figures ``fig`` (5,) (a condition left NaN
        computed on demand)."""
        dk, mech = self.dk, self.mech
        cond = np.array([fig[dk.FIG_COND]])
        p = Pose(mech, x[None].copy(), q[None].copy(), rot[None].copy(),
                 np.array([fig[dk.FIG_RES]]), np.array([int(fig[dk.FIG_ITS])]), cond,
                 np.zeros(1, dtype=int), _cond_pending=bool(np.isnan(cond[0])))
        p.status = _status(mech, p.residual, p.condition, np.array([bool(fig[dk.FIG_CONV])]),
                           self.opts)
        return p

    def solve_from(self, q, rot, x, tangent, y) -> np.ndarray:
        """The stage (:meth:`solve`) of P poses from given bases instead of the members':
        coordinates ``q`` (P, nq), rotations ``rot`` (P, ns, 3, 3) at inputs ``x`` (P, n)
        with tangents ``tangent`` (P, nv, n), each moved to the inputs of its state ``y``
        (P, 2n + 2) with the first-order predictor (no earlier right-hand side) and
        corrected there; the arrays are C-contiguous and are moved in place as the
        members' bases are.  Returns the P fresh blocks (P, size)."""
        P = len(y)
        buf = np.zeros(P * self.size)
        self._stage(*self._stage_head, np.arange(P), q.reshape(-1), rot.reshape(-1, 3, 3),
                    x.reshape(-1), tangent.reshape(-1, self.n), y.reshape(-1), buf,
                    *self._nokeep)
        return buf.reshape(P, self.size)


def _start_tangents(mech, start: Pose, xd0: np.ndarray, opts: SolverOptions) -> np.ndarray:
    """Each member's tangent at its start (B, nv, n), as
    :class:`closure.integrate.PoseTracker` takes it: the pose's first analogs, or at a
    singular start (condition above ``TANGENT_COND``) those of the branch leaving it in the
    direction of its rates (:func:`closure.solver.branch_tangent`)."""
    from .kinematics import analogs
    from .solver import TANGENT_COND, branch_tangent
    if not len(start):
        return np.zeros((0, mech.plan.nv, xd0.shape[1]))
    first = analogs(mech, start, second=False)[0]
    n = xd0.shape[1]
    for b in np.nonzero(start.condition > TANGENT_COND)[0]:
        direction = xd0[b] if np.any(xd0[b]) else np.eye(n)[0]
        first[b] = branch_tangent(mech, _take_pose(start, [b]), direction, opts)
    return first


def simulate_batch(dynamics, t_span, x0, xd0, *, t_eval=None, method: str = "DOP853",
                   rtol: float = 1e-10, atol: float = 1e-12, drive: Callable | None = None,
                   options: SolverOptions | None = None,
                   energy: bool = True) -> BatchDynamicsResult:
    """Forward dynamics of B members from ``x0, xd0`` (B, n) over ``t_span``.

    Parameters
    ----------
    dynamics : Dynamics
    t_span : (t0, t1) s
    x0, xd0 : (B, n) array_like
        Initial inputs and rates of the members (n = 1: (B,) too).  Each member starts
        from the solution of its ``x0`` reached by continuation from the assembly pose.
    t_eval : (N,) array_like, optional
        Output times; default none (only ``t_end``, ``x_end``).
    method : {"RK45", "DOP853"}
    rtol, atol : float
        The integrator's tolerances (per member, as scipy's).
    drive : callable, optional
        Vectorised forces on the inputs: ``drive(t (A,), x (A, n), xd (A, n)) -> (A, n)``.
        Given joint forces (``add_force``) are called as ``func(t (A,), q (A,), qd (A,))``
        and must accept arrays.
    options : SolverOptions, optional
        The position solver's tolerances; ``cond_limit`` is the condition number above
        which a member at a fold of the loop equations is stopped.
    energy : bool
        Evaluate the energies and the balance at the output times (default True).

    Returns
    -------
    BatchDynamicsResult
    """
    from .forward import _simulate_arguments
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
    ok0 = np.asarray(start.status) < 2
    mem = _Members(dynamics, start, ok0, xd0, opts)
    try:                                # (integrate_batch checks t_eval and names it)
        te = None if t_eval is None else np.asarray(t_eval, dtype=float)
    except (TypeError, ValueError):
        te = None
    keep = bool(energy) and te is not None and te.ndim == 1 and te.size > 0 \
        and bool(np.isfinite(te).all()) and bool((np.diff(te) > 0).all())
    if keep:
        mem.keep_outputs(te, 1.0 if t1 >= t0 else -1.0)
    rhs = _right_hand_side(dynamics, mem, ok0, drive, opts, keep)
    y0 = np.concatenate([x0, xd0, np.zeros((B, 2))], axis=1)
    with _serial_blas_for(mech.plan, mech.plan._ucols.size):   # as the solver's Newton
        res = integrate_batch(rhs, (t0, t1), y0, method=method, t_eval=t_eval, rtol=rtol,
                              atol=atol)
    out = BatchDynamicsResult(t_eval=res.t_eval, x=res.y[:, :n], xd=res.y[:, n:2 * n],
                              dissipated=res.y[:, 2 * n], work=res.y[:, 2 * n + 1],
                              t_end=res.t_end, x_end=res.y_end[:, :n], status=res.status,
                              message=res.message, nfev=res.nfev, steps=res.steps,
                              method=method)
    shape = (B, res.t_eval.size)
    out.kinetic, out.potential, out.energy, out.balance = (np.full(shape, np.nan)
                                                           for _ in range(4))
    if keep:
        _energies(dynamics, start, ok0, xd0, mem, out, opts)
    return out


def _right_hand_side(dynamics, mem: _Members, ok0: np.ndarray, drive, opts: SolverOptions,
                     keep: bool):
    """``rhs(t (A,), y (A, 2n + 2), members (A,)) -> dydt or (dydt, failed)`` of
    :func:`closure.batch_integrate.integrate_batch`, y = (x, ẋ, dissipated, work);
    ``keep``: keep the poses nearest the output times (:meth:`_Members.keep`)."""
    from .integrate import is_fold, regular_limit
    dk = mem.dk
    mech = dynamics.m
    n, nv = mem.n, mem.nv
    forces = [e for e in dynamics.elements if e.kind == "force"]
    cond_limit = opts.cond_limit
    all_ok = bool(ok0.all())

    def drive_of(t, x, xd):
        tau = np.asarray(drive(t, x, xd), float)
        if tau.shape != (len(t), n):
            raise MechanismError(f"simulate_batch: drive must return shape "
                                 f"({len(t)}, {n}) for a vectorised call "
                                 f"drive(t (A,), x (A, n), xd (A, n)), got {tau.shape}")
        return tau

    def terms_of(xd, t):
        def fn(p):                          # given forces called with arrays, as elsewhere
            M, h, Q, _, first, diss, work = dynamics._evaluate(
                p, np.broadcast_to(xd, (len(p), n)), np.full(len(p), t))[:7]
            return M, h, Q, first, diss, work
        return fn

    def by_pose(g, t, y, code):
        """Member ``g`` where the kernel returned ``code``: the dynamics' limit along its
        branch near a singular configuration, or the terms solved here (as
        ``Dynamics.simulate``); returns ``(dydt, reason)``."""
        x, xd = y[:n], y[n:2 * n]
        fig = mem.field(mem.blocks, "fig", (5,))[g]
        if code == dk.NOT_CLOSED:
            return None, (f"the pose does not close (residual {fig[dk.FIG_RES]:.2e}, "
                          f"condition {fig[dk.FIG_COND]:.3g}) at x = {x.tolist()} "
                          f"(t = {t:.6g}): the motion reached past a fold of the loop "
                          "equations")
        p = mem.pose(g)
        cond = p.condition[0]
        if cond > cond_limit and is_fold(mech, p, mem.field(mem.blocks, "first", (nv, n))[g]):
            return None, (f"dead point: condition {cond:.3e} above {cond_limit:.3e} at "
                          f"x = {x.tolist()} (t = {t:.6g}), where the input rates blow up "
                          "(a fold)")
        M, h, Q, first, diss, work = regular_limit(mech, p, mem.tangent[g].copy(),
                                                   terms_of(xd, t), opts)
        from .solver import TANGENT_COND
        if cond <= TANGENT_COND:            # the tangent there, as PoseTracker.tangent
            mem.tangent[g] = first[0]
        F = Q[0] - h[0]
        dw = work[0]
        if drive is not None:
            tau = drive_of(np.array([t]), x[None], xd[None])[0]
            F = F + tau
            dw = dw + float(tau @ xd)
        if not np.all(np.isfinite(F)):
            return None, (f"non-finite generalised force at t = {t:.6g} (drive or "
                          "joint-force functions returned NaN or inf)")
        return np.r_[xd, np.linalg.solve(M[0], F), diss[0], dw], ""

    def rhs(t, y, members):
        A = len(members)
        failed = None                   # (A,) reasons, made when a member fails
        if all_ok:
            rows = slice(None)
            mk = np.array(members, dtype=np.int64)               # writable, contiguous copies
            yk = np.array(y, dtype=float, order="C")
        else:
            ok = ok0[members]
            failed = np.where(ok, "", "the start pose does not close").astype(object)
            rows = np.nonzero(ok)[0]
            if not rows.size:
                return np.full((A, 2 * n + 2), np.nan), failed
            mk = np.array(members[rows], dtype=np.int64)
            yk = np.array(y[rows], dtype=float, order="C")
        tk = np.asarray(t)[rows]
        n_bad = mem.solve(mk, yk, tk)
        blocks = mem.blocks
        out = mem.rows("out", (2 * n + 2,), mk)
        regular = n_bad == 0
        code = None if regular else mem.rows("code", (1,), mk)[:, 0].astype(np.int64)

        def fail(a, why):
            nonlocal failed
            if failed is None:
                failed = np.full(A, "", dtype=object)
            failed[a if all_ok else rows[a]] = why
            out[a] = np.nan

        if forces or drive is not None:           # given forces and drives: M⁻¹ F
            gi = slice(None) if regular else np.nonzero(code == dk.OK)[0]
            mg = mk[gi]
            xd = yk[gi, n:2 * n]
            first = mem.field(blocks, "first", (nv, n))[mg]
            qd = mem.field(blocks, "qd", (nv,))[mg]
            F = np.zeros(xd.shape)
            dw = np.zeros(len(xd))
            if forces:
                q = mem.field(blocks, "q", (mech.plan.nq,))[mg]
                for e in forces:
                    rate = qd[:, e.column]
                    tau = np.broadcast_to(np.asarray(e.value(tk[gi], q[:, e.qcolumn], rate),
                                                     float), (len(xd),))
                    F += first[:, e.column, :] * tau[:, None]
                    dw += tau * rate
            if drive is not None:
                tau = drive_of(tk[gi], yk[gi, :n], xd)
                F += tau
                dw += np.einsum("ij,ij->i", tau, xd)
            Minv = mem.field(blocks, "Minv", (n, n))[mg]
            out[gi, n:2 * n] += np.einsum("aij,aj->ai", Minv, F)
            out[gi, 2 * n + 1] = dw
            bad = ~np.isfinite(F).all(axis=1)
            for a in np.arange(len(out))[gi][bad]:
                fail(a, f"non-finite generalised force at t = {tk[a]:.6g} (drive or "
                        "joint-force functions returned NaN or inf)")
        if not regular:                           # pose by pose: what the kernel left
            for a in np.nonzero(code != dk.OK)[0]:
                row, why = by_pose(int(mk[a]), float(tk[a]), yk[a], int(code[a]))
                if row is None:
                    fail(a, why)
                else:
                    out[a] = row
        if keep and not regular:                  # the poses solved here, for the outputs
            sel = (code != dk.OK) & (code != dk.NOT_CLOSED)   # (the stage kept the OK ones)
            mem.keep(tk[sel], mk[sel])
        if all_ok:
            return out if failed is None else (out, failed)
        dydt = np.full((A, 2 * n + 2), np.nan)
        dydt[rows] = out
        return dydt, failed

    return rhs


def _energies(dynamics, start: Pose, ok0: np.ndarray, xd0: np.ndarray, mem: _Members,
              out: BatchDynamicsResult, opts: SolverOptions) -> None:
    """Kinetic, potential and total energy and the balance at the output times into
    ``out``, as ``Dynamics.simulate`` forms them: each member's pose at an output time
    from its solved pose nearest in time (kept during the run; an output time no stage
    came near takes the nearest kept pose of another output time) by the tangent
    predictor and the solver's Newton, and the energies there by the compiled terms, all
    members and times in one call of the batch's stage (:meth:`_Members.solve_from`); a
    pose whose condition exceeds ``TANGENT_COND`` takes the energies' limit along its
    branch (:func:`closure.integrate.regular_limit`), as does a start above
    ``RHS_COND``."""
    from .integrate import RHS_COND, regular_limit
    from .solver import TANGENT_COND
    mech, dk = dynamics.m, mem.dk
    n = xd0.shape[1]
    B, N = mem.near.shape

    def energies(p, xd):
        e = dynamics.energy(p, np.broadcast_to(xd, (len(p), n)))
        return e["kinetic"], e["gravity"], e["spring"], e["total"]

    def limit(p, first, xd):
        return [v[0] for v in regular_limit(mech, p, first, lambda pp: energies(pp, xd), opts)]

    # E(0): at each member's start
    e0 = np.full(B, np.nan)
    idx0 = np.nonzero(ok0)[0]
    if idx0.size:
        p0 = _take_pose(start, idx0)
        e0[idx0] = energies(p0, xd0[idx0])[3]
        for k in np.nonzero(p0.condition > RHS_COND)[0]:
            e0[idx0[k]] = limit(_take_pose(p0, [k]), mem.tangent0[idx0[k]], xd0[idx0[k]])[3]
    # the poses at the output times, from the kept poses
    X = np.moveaxis(out.x, 2, 1)                               # (B, N, n)
    XD = np.moveaxis(out.xd, 2, 1)
    live = ok0[:, None] & np.isfinite(X).all(axis=2) & np.isfinite(XD).all(axis=2)
    src = np.broadcast_to(np.arange(N), (B, N)).copy()         # whose kept pose
    for b in np.nonzero((live & np.isinf(mem.near)).any(axis=1))[0]:
        have = np.nonzero(np.isfinite(mem.near[b]))[0]
        if have.size:                               # the nearest output time with one
            T = out.t_eval
            src[b] = have[np.argmin(np.abs(T[:, None] - T[have][None, :]), axis=1)]
        else:
            live[b] = False
    bi, ki = np.nonzero(live)
    if not bi.size:
        return
    si = src[bi, ki]
    kq, krot, kx, ktan = (a[bi, si] for a in mem.kept)         # copies, moved by the stage
    tan0 = ktan.copy()
    xd = XD[bi, ki]
    y = np.ascontiguousarray(np.concatenate([X[bi, ki], xd, np.zeros((bi.size, 2))], axis=1))
    with _serial_blas_for(mech.plan, mech.plan._ucols.size):
        blocks = mem.solve_from(kq, krot, kx, ktan, y)
    code = mem.field(blocks, "code", (1,))[:, 0]
    fig = mem.field(blocks, "fig", (5,))
    M, en = mem.field(blocks, "M", (n, n)), mem.field(blocks, "en", (3,))
    kin = 0.5 * np.einsum("bi,bij,bj->b", xd, M, xd)
    vg, vs = en[:, 1].copy(), en[:, 2].copy()
    tot = kin + vg + vs
    for j in np.nonzero(fig[:, dk.FIG_COND] > TANGENT_COND)[0]:  # singular: the limit
        if code[j] != dk.NOT_CLOSED:
            kin[j], vg[j], vs[j], tot[j] = limit(mem.pose_of(kq[j], krot[j], kx[j], fig[j]),
                                                 tan0[j], xd[j])
    closed = code != dk.NOT_CLOSED                  # energies NaN where it did not close
    bi, ki = bi[closed], ki[closed]
    out.kinetic[bi, ki] = kin[closed]
    out.potential[bi, ki] = (vg + vs)[closed]
    out.energy[bi, ki] = tot[closed]
    out.balance[bi, ki] = tot[closed] + out.dissipated[bi, ki] - out.work[bi, ki] - e0[bi]
