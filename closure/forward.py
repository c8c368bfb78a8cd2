"""Forward dynamics of one trajectory: :meth:`closure.Dynamics.simulate`.

The model (:class:`closure.Dynamics`: bodies, springs, dampers, given forces and the
compiled terms of Lagrange's equations) lives in :mod:`closure.dynamics`; this module
integrates it.  :func:`simulate` solves the start, makes the pose tracker
(:class:`closure.integrate.PoseTracker`) and the right-hand side :func:`_rhs` (three
compiled calls per stage: predictor, the solver's Newton, terms and ``M⁻¹ (Q − h)``; only
given joint forces and drives, which are Python callables, and poses near a singular
configuration are handled in Python), runs scipy's method class
(:func:`closure.integrate.integrate`) and tabulates the output times with their energies
and energy balance.  B trajectories at once are :mod:`closure.batch_dynamics`.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
import pandas as pd

from .checks import real_number
from .errors import MechanismError
from .frames import as_array
from .pose import Pose
from .solver import TANGENT_COND, SolverOptions, _serial_blas_for, _take_pose

__all__ = ["simulate"]


def simulate(dynamics, t_span, x0, xd0, *, guess: Pose | None = None, t_eval=None,
             drive: Callable | None = None, method: str = "DOP853", rtol: float = 1e-10,
             atol: float = 1e-12, stop_at_dead_point: bool = True,
             options: SolverOptions | None = None, **ivp_kw) -> pd.DataFrame:
    """Forward dynamics of ``dynamics`` (:class:`closure.Dynamics`) from ``x0, xd0``: the
    arguments and the table of :meth:`closure.Dynamics.simulate`."""
    from .integrate import PoseTracker, check_method, integrate, poses_at, regular_limit
    mech = dynamics.m
    n = len(mech.inputs)
    check_method(method)
    x0, xd0, t0, t1 = _simulate_arguments(n, x0, xd0, rtol, atol, drive, t_span)
    opts = options or SolverOptions()
    start = mech.solve(x0, guess=guess, options=opts)
    start.scalar = False
    tracker = PoseTracker(mech, start, opts, xd0 if np.any(xd0) else np.eye(n)[0],
                          dynamics=dynamics._packed()[1:])
    rhs = _rhs(dynamics, tracker, drive, opts)
    y0 = np.r_[x0, xd0, 0.0, 0.0]
    with _serial_blas_for(mech.plan, mech.plan._ucols.size):    # as the solver's Newton
        run = integrate(rhs, tracker, (t0, t1), y0, method=method, rtol=rtol, atol=atol,
                        stop_at_dead_point=stop_at_dead_point, cond_limit=opts.cond_limit,
                        ivp_kw=ivp_kw)
    t_out = None
    if t_eval is not None:
        t_out = np.asarray(t_eval, float).ravel()
        t_end = run["t"][-1]
        t_out = t_out[t_out <= t_end + 1e-12 * max(1.0, abs(t_end))]
    t_out, Y, pose = poses_at(mech, run, t_out, opts)
    from .integrate import IntegrationResult
    sol = IntegrationResult(t=t_out, y=Y, status=0 if run["status"] == "completed" else 1,
                            message=run["message"], success=True, nfev=run["nfev"],
                            steps=run["steps"], t_end=float(run["t"][-1]))
    X, XD = Y[:n].T, Y[n:2 * n].T
    en = dynamics.energy(pose, XD)
    for i in np.nonzero(pose.condition > TANGENT_COND)[0]:     # singular rows: the limit
        k = min(np.searchsorted(run["t"], t_out[i], side="right") - 1, len(run["t"]) - 1)
        lim = regular_limit(mech, _take_pose(pose, [i]), run["tangents"][k],
                            lambda p: tuple(dynamics.energy(p, np.broadcast_to(XD[i], (len(p), n)))
                                            [key] for key in ("kinetic", "gravity", "spring",
                                                              "total")), opts)
        for key, v in zip(("kinetic", "gravity", "spring", "total"), lim):
            en[key][i] = v[0]
    cols = {"t": t_out}                        # the table's columns, built at once
    for k, lab in enumerate(mech.input_labels()):
        cols[lab] = X[:, k]
        cols[f"rate:{lab}"] = XD[:, k]
    vals = pose.values()
    for k, c in enumerate(mech.coordinate_labels()):
        cols[f"q:{c}"] = vals[:, k]
    cols["kinetic"] = en["kinetic"]
    cols["potential"] = en["gravity"] + en["spring"]
    cols["energy"] = en["total"]
    cols["dissipated"] = Y[2 * n]
    cols["work"] = Y[2 * n + 1]
    e0 = regular_limit(mech, start, tracker.first,
                       lambda p: (dynamics.energy(p, np.broadcast_to(xd0, (len(p), n)))["total"],),
                       opts)[0][0]
    cols["balance"] = cols["energy"] + cols["dissipated"] - cols["work"] - e0
    cols["residual"] = pose.residual
    cols["condition"] = pose.condition
    cols["flag"] = _row_flags(cols, opts.cond_limit, rtol)
    out = pd.DataFrame(cols)
    out.attrs["ivp"] = sol
    out.attrs["status"] = "completed" if sol.status == 0 else "dead point"
    out.attrs["message"] = sol.message
    return out


def _rhs(dynamics, tracker, drive, opts: SolverOptions):
    """Forward dynamics' right-hand side ``rhs(t, y)``, y = (x, ẋ, dissipated, work).

    The tracker (made with this model's kernel data) predicts the pose from its last
    one, the solver's Newton corrects it, and :func:`closure.dynamics_kernels.step`
    (task ``RHS``) forms the terms there and ``M⁻¹ (Q − h)`` and moves the tracker on;
    drives and given joint forces (Python callables) are added here as ``M⁻¹ F``.  A
    pose whose condition number exceeds :data:`closure.integrate.RHS_COND` takes
    :func:`closure.integrate.regular_limit` (the dynamics as their limit along the
    branch, by the same kernels); a pose that does not close raises ClosureError (the
    integrator stops there: a dead point)."""
    from . import dynamics_kernels as dk
    from .integrate import regular_limit
    from .state import _arr
    mech = dynamics.m
    n = len(mech.inputs)
    forces = [e for e in dynamics.elements if e.kind == "force"]
    extra = drive is not None or bool(forces)
    lay, buf = tracker.layout, tracker.buf

    def view(name, shape):
        o = lay[name]
        return buf[o:o + int(np.prod(shape))].reshape(shape)
    out, Minv = view("out", (2 * n + 2,)), view("Minv", (n, n))
    first, qd, q = view("first", (mech.tree.nv, n)), view("qd", (mech.tree.nv,)), \
        view("q", (mech.tree.nq,))
    solve, RHS = tracker.solve, dk.RHS

    def bad_force(t):
        return MechanismError(f"simulate: non-finite generalised force at t = {t:.6g} "
                              f"(drive or joint-force functions returned NaN or inf)")

    def terms_of(xd, t):
        def fn(p):
            M_, h_, Q_, _, first_, diss, work = dynamics._evaluate(
                p, np.broadcast_to(xd, (len(p), n)), t)[:7]
            return M_, h_, Q_, first_, diss, work
        return fn

    def by_pose(t, y, code):
        """The pose-by-pose path: a pose that does not close, a near-singular pose
        (the limit along the branch), or terms the kernel could not solve with."""
        x, xd = y[:n], y[n:2 * n]
        if code == dk.NOT_CLOSED:
            raise tracker.not_closed(x)
        p = tracker.pose
        M_, h_, Q_, first_, diss, work = regular_limit(mech, p, tracker.first,
                                                       terms_of(xd, t), opts)
        tracker.tangent(p, first_[0])
        F = Q_[0] - h_[0]
        tau = None
        if drive is not None:
            tau = np.asarray(drive(t, x, xd), float).reshape(n)
            F = F + tau
        if not np.all(np.isfinite(F)):
            raise bad_force(t)
        xdd = np.linalg.solve(M_[0], F)
        dw = work[0] + (float(tau @ xd) if tau is not None else 0.0)
        return np.r_[xd, xdd, diss[0], dw]

    def rhs(t, y):
        if y.dtype != np.float64 or not y.flags.c_contiguous:
            y = _arr(y)
        code = solve(RHS, y)
        if code:
            return by_pose(t, y, code)
        if not extra:
            return out.copy()
        xd = y[n:2 * n]
        F = np.zeros(n)
        dw = 0.0
        for e in forces:                      # given joint forces, through the analogs
            rate = qd[[e.column]]
            tau = np.broadcast_to(np.asarray(e.value(t, q[[e.qcolumn]], rate), float),
                                  (1,))
            F += first[e.column] * tau[0]
            dw += float(tau[0] * rate[0])
        if drive is not None:
            tau = np.asarray(drive(t, y[:n], xd), float).reshape(n)
            F += tau
            dw += float(tau @ xd)
        if not np.all(np.isfinite(F)):
            raise bad_force(t)
        res = out.copy()
        res[n:2 * n] += Minv @ F
        res[2 * n + 1] = dw
        return res

    return rhs


def _finite_vector(v, n, name):
    a = as_array(v, f"simulate: {name}", finite=False)
    try:
        a = a.reshape(n)
    except ValueError:
        raise MechanismError(f"simulate: {name} must be {n} number(s), got shape "
                             f"{a.shape}") from None
    if not np.all(np.isfinite(a)):
        raise MechanismError(f"simulate: {name} must be finite, got {a.tolist()}")
    return a


def _simulate_arguments(n, x0, xd0, rtol, atol, drive, t_span):
    """The checked arguments shared by both ``simulate`` methods: ``x0, xd0`` (n,), and
    ``t0 < t1``; tolerances positive, ``drive`` callable or None."""
    x0 = _finite_vector(x0, n, "x0")
    xd0 = _finite_vector(xd0, n, "xd0")
    for name, v in (("rtol", rtol), ("atol", atol)):
        real_number(v, f"simulate: {name}", MechanismError)
        if not (np.isfinite(v) and v > 0):
            raise MechanismError(f"simulate: {name} must be a positive number, got {v!r}")
    if drive is not None and not callable(drive):
        raise MechanismError(f"simulate: drive must be callable as drive(t, x, xd), got "
                             f"{type(drive).__name__}")
    ts = as_array(t_span, "simulate: t_span", finite=False)
    if ts.shape != (2,):
        raise MechanismError(f"simulate: t_span must be (t0, t1), got shape {ts.shape}")
    t0, t1 = (float(v) for v in ts)
    if not (np.isfinite(t0) and np.isfinite(t1) and t1 > t0):
        raise MechanismError(f"simulate: t_span must be (t0, t1) with t1 > t0, got {t_span}")
    return x0, xd0, t0, t1


def _row_flags(out, cond_limit: float, rtol: float) -> list:
    """Why each output row is doubtful (empty string when it is not); ``out`` maps the
    columns ``kinetic, potential, work, dissipated, condition, balance`` to arrays."""
    if len(out["condition"]) == 0:
        return []
    scale = (np.abs(out["kinetic"]).max() + np.ptp(out["potential"]) + np.abs(out["work"]).max()
             + np.abs(out["dissipated"]).max())
    tol = max(1e-6, 1e4 * rtol) * max(scale, 1e-300)
    flags = []
    for c, b in zip(np.asarray(out["condition"]), np.asarray(out["balance"])):
        f = []
        if c > cond_limit:
            f.append(f"near-singular (condition {c:.2e})")
        if abs(b) > tol:
            f.append(f"energy balance error {b:.2e} J")
        flags.append("; ".join(f))
    return flags
