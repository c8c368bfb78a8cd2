"""Dynamics on the closure engine: Lagrange's equations in the independent coordinates.

Seed 000 writes the kinetic energy of link i as ``½ tr(Ȧ_i J_i Ȧ_iᵀ)`` with the
4x4 pseudo-inertia ``J_i`` (for our ``(x, y, z, 1)`` convention
``J = [[∫ r rᵀ dm, m c], [m cᵀ, m]]``).  With ``Ȧ = V^ A`` this is
``½ Vᵀ Λ V`` for the link's world twist V and the 6x6 spatial inertia Λ
built from ``A J Aᵀ``.  The mechanism's independent coordinates x are its
inputs; every link twist is ``V_l = Γ_l(x) ẋ`` (first analogs) and its
acceleration ``Γ_l ẍ + a_l(x, ẋ)`` (second analogs), so Lagrange's equations
take the Newton–Euler form

    M(x) ẍ + h(x, ẋ) = Q(t, x, ẋ) + τ_drive,
    M = Σ Γ_lᵀ Λ_l Γ_l,   h = Σ Γ_lᵀ (Λ_l a_l + V_l ×* Λ_l V_l),

computed from the engine's velocity and acceleration solutions (no finite
differences).  Q collects gravity, springs, dampers and given joint forces,
mapped through the analogs of their joints.  Forward dynamics integrates x, ẋ
with scipy's ``solve_ivp`` and solves the dependent coordinates by the
engine at every step (coordinate partitioning).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import pandas as pd

from .checks import real_number
from .errors import ClosureError, MechanismError
from .frames import as_array, as_index, as_number, cross, input_rates, skew
from .kinematics import _bias, analogs, link_twists
from .pose import REACHED, Pose
from .solver import TANGENT_COND, SolverOptions, _take_pose

__all__ = ["Body", "Dynamics", "pseudo_inertia"]


def pseudo_inertia(mass: float, com, inertia) -> np.ndarray:
    """4x4 pseudo-inertia ``J = [[Σ, m c], [m cᵀ, m]]`` (seed 000, in (x, y, z, 1) order).

    Parameters
    ----------
    mass : float (kg)
    com : (3,) centre of mass in the link frame (m)
    inertia : (3, 3) inertia tensor about the centre of mass, link axes (kg·m²)

    ``Σ = ∫ r rᵀ dm = ½ tr(I) E − I + m c cᵀ`` (about the link origin): the
    seed's diagonal entries ``½(−I_xx + I_yy + I_zz)`` etc.
    """
    mass = as_number(mass, "pseudo_inertia: mass")
    c = as_array(com, "pseudo_inertia: com", (3,))
    I = as_array(inertia, "pseudo_inertia: inertia", (3, 3))
    if c.shape != (3,) or I.shape != (3, 3):
        raise MechanismError(f"pseudo_inertia: expected com (3,) and inertia (3, 3), got "
                             f"{c.shape} and {I.shape}")
    _check_mass_properties(mass, I, "pseudo_inertia", physical=False)
    return _pseudo_inertia(mass, c, I)


def _check_mass_properties(mass, I, what, physical=True):
    """A positive mass and a symmetric, positive semidefinite inertia tensor whose principal
    moments satisfy the triangle inequality (only when ``physical``: the formula of
    :func:`pseudo_inertia` holds without it); raises MechanismError naming ``what``."""
    if not mass > 0:
        raise MechanismError(f"{what}: mass must be positive (kg), got {mass}")
    if np.abs(I - I.T).max() > 1e-9 * max(1.0, np.abs(I).max()):
        raise MechanismError(f"{what}: inertia tensor must be symmetric")
    ev = np.linalg.eigvalsh(I)
    tol = 1e-9 * max(ev.max(), 1e-300)
    if ev.min() < -tol:
        raise MechanismError(f"{what}: inertia tensor is not positive "
                             f"semidefinite (eigenvalue {ev.min():.3g})")
    a, b, c = ev
    if physical and a + b < c - tol:
        raise MechanismError(f"{what}: principal moments {ev} violate the "
                             "triangle inequality (no real body has them)")


def _pseudo_inertia(mass, c, I):
    """:func:`pseudo_inertia` of checked mass properties."""
    S = 0.5 * np.trace(I) * np.eye(3) - I + mass * np.outer(c, c)
    J = np.zeros((4, 4))
    J[:3, :3] = S
    J[:3, 3] = J[3, :3] = mass * c
    J[3, 3] = mass
    return J


@dataclass
class Body:
    """Mass properties of a link (link frame = ground frame at the assembly pose)."""

    link: str
    mass: float
    com: np.ndarray
    inertia: np.ndarray

    def __post_init__(self):
        self.mass = as_number(self.mass, f"body {self.link!r}: mass")
        self.com = as_array(self.com, f"body {self.link!r}: com", finite=False)
        self.inertia = as_array(self.inertia, f"body {self.link!r}: inertia", finite=False)
        if not self.mass > 0:
            raise MechanismError(f"body {self.link!r}: mass must be positive (kg), got {self.mass}")
        if self.com.shape != (3,) or not np.all(np.isfinite(self.com)):
            raise MechanismError(f"body {self.link!r}: com must be a finite 3-vector (m)")
        I = self.inertia
        if I.shape != (3, 3) or not np.all(np.isfinite(I)):
            raise MechanismError(f"body {self.link!r}: inertia must be a finite 3x3 tensor (kg·m²)")
        _check_mass_properties(self.mass, I, f"body {self.link!r}")

    @property
    def J(self) -> np.ndarray:
        """The 4x4 pseudo-inertia in the link frame."""
        return _pseudo_inertia(self.mass, self.com, self.inertia)


@dataclass
class _JointElement:
    column: int            # velocity coordinate
    qcolumn: int           # stored coordinate
    kind: str              # spring, damper, force
    value: object          # stiffness, coefficient or callable
    free: float = 0.0


class Dynamics:
    """Dynamics of a mechanism whose inputs are its independent coordinates.

    Parameters
    ----------
    mechanism : Mechanism
        Its inputs (``add_input``) are the independent coordinates x; their
        count must equal the mobility less idle freedoms.
    gravity : (3,) array_like
        Gravitational acceleration in the ground frame (m/s²); default (0, 0, −9.81).
    """

    def __init__(self, mechanism, gravity=(0.0, 0.0, -9.81)):
        from .mechanism import Mechanism
        if not isinstance(mechanism, Mechanism):
            raise MechanismError(f"mechanism: expected a Mechanism, got {type(mechanism).__name__}")
        self.m = mechanism
        self.gravity = as_array(gravity, "gravity", finite=False)
        if self.gravity.shape != (3,) or not np.all(np.isfinite(self.gravity)):
            raise MechanismError(f"gravity: expected a finite 3-vector (m/s²), got {gravity!r}")
        self.bodies: list[Body] = []
        self.elements: list[_JointElement] = []

    # ------------------------------------------------------------ model
    def add_body(self, link: str, mass: float, com=(0, 0, 0), inertia=None) -> Body:
        """Mass properties of ``link``: ``com`` in ground coordinates at the assembly pose
        (= link coordinates), ``inertia`` about the com (default zero: a point mass)."""
        if not isinstance(link, str) or link not in self.m.links or link == self.m.ground:
            raise MechanismError(f"add_body: {link!r} is not a moving link; links: "
                                 f"{', '.join(self.m.links[1:])}")
        b = Body(link, as_number(mass, f"add_body: {link!r}: mass"), com, np.zeros((3, 3)) if inertia is None else inertia)
        self.bodies.append(b)
        return b

    def _coord(self, joint, index, what):
        j = self.m.joint(joint)
        index = as_index(index, f"{what}: index")
        if j.kind == "S":
            raise MechanismError(f"{what}: joint {joint!r} is spherical; springs, dampers and "
                                 "forces act on scalar joint coordinates")
        if not 0 <= index < j.nq:
            raise MechanismError(f"{what}: index {index} out of range for joint {joint!r}")
        t = self.m.tree
        return t.v_offset[j.index] + index, t.q_offset[j.index] + index

    def add_spring(self, joint: str, stiffness: float, free: float = 0.0, index: int = 0):
        """Linear spring on a joint coordinate: force ``−k (q − free)`` (N/m or N·m/rad)."""
        stiffness = as_number(stiffness, "add_spring: stiffness")
        free = as_number(free, "add_spring: free")
        if not stiffness >= 0:
            raise MechanismError(f"add_spring: stiffness must be ≥ 0, got {stiffness}")
        c, qc = self._coord(joint, index, "add_spring")
        self.elements.append(_JointElement(c, qc, "spring", float(stiffness), float(free)))

    def add_damper(self, joint: str, coefficient: float, index: int = 0):
        """Viscous damper on a joint coordinate: force ``−c q̇`` (N·s/m or N·m·s/rad)."""
        coefficient = as_number(coefficient, "add_damper: coefficient")
        if not coefficient >= 0:
            raise MechanismError(f"add_damper: coefficient must be ≥ 0, got {coefficient}")
        c, qc = self._coord(joint, index, "add_damper")
        self.elements.append(_JointElement(c, qc, "damper", float(coefficient)))

    def add_force(self, joint: str, func: Callable, index: int = 0):
        """A given force or torque on a joint coordinate: ``func(t, q, qd)`` with the
        coordinate's value and rate (arrays), returning the force (N or N·m)."""
        if not callable(func):
            raise MechanismError("add_force: func must be callable as func(t, q, qd)")
        c, qc = self._coord(joint, index, "add_force")
        self.elements.append(_JointElement(c, qc, "force", func))

    # ------------------------------------------------------------ terms
    def _link_inertias(self, link_poses):
        """World spatial inertias Λ (B, nb, 6, 6) and com positions (B, nb, 3) of the bodies."""
        li = [self.m.links.index(b.link) for b in self.bodies]
        A = link_poses[:, li]
        R, p = A[..., :3, :3], A[..., :3, 3]
        m = np.array([b.mass for b in self.bodies])
        c = np.einsum("bkij,kj->bki", R, np.array([b.com for b in self.bodies])) + p
        Ic = np.einsum("bkij,kjl,bkml->bkim", R, np.array([b.inertia for b in self.bodies]), R)
        C = skew(c)
        Lam = np.zeros(A.shape[:2] + (6, 6))
        Lam[..., :3, :3] = m[:, None, None] * np.eye(3)
        Lam[..., :3, 3:] = -m[:, None, None] * C
        Lam[..., 3:, :3] = m[:, None, None] * C
        Lam[..., 3:, 3:] = Ic - m[:, None, None] * (C @ C)
        return Lam, c, m

    def terms(self, pose: Pose, xd, t=0.0, _first_out=None):
        # _first_out (internal, simulate): receives the first analogs of ``pose`` and the
        # powers of dampers ("dissipated") and given joint forces ("work"), (B,) each
        """M (B, n, n), h (B, n), applied forces Q (B, n) and the coordinate rates (B, nv).

        ``Q`` holds gravity, springs, dampers and given joint forces (not drives)."""
        mech = self.m
        B = len(pose)
        if _first_out is None:        # a public call (simulate passes the integrator's state)
            xd = input_rates(xd, "terms: xd", (B, len(mech.inputs)))
        xd = np.broadcast_to(np.asarray(xd, float), (B, len(mech.inputs)))
        ks = pose.kinematics()
        first, second = analogs(mech, pose, ks=ks)
        if _first_out is not None:
            _first_out["first"], _first_out["first_of"] = first, pose
            _first_out["dissipated"], _first_out["work"] = np.zeros(B), np.zeros(B)
        n = first.shape[2]
        qd = np.einsum("bci,bi->bc", first, xd)
        M = np.zeros((B, n, n))
        h = np.zeros((B, n))
        Q = np.zeros((B, n))
        if self.bodies:
            li = [mech.links.index(b.link) for b in self.bodies]
            Gam = np.stack([link_twists(mech, ks, first[:, :, i])[:, li] for i in range(n)], -1)
            qdd0 = np.einsum("bcij,bi,bj->bc", second, xd, xd)
            acc0 = (link_twists(mech, ks, qdd0)
                    + np.einsum("lc,bcs->bls", mech.tree.path_sign, _bias(mech, ks, qd, qd)))[:, li]
            V = np.einsum("bksi,bi->bks", Gam, xd)
            Lam, c, m = self._link_inertias(ks["link"])
            LV = np.einsum("bkst,bkt->bks", Lam, V)
            # V ×* (Λ V) for wrenches (f, m): (ω × f, v × f + ω × m)
            w, v = V[..., 3:], V[..., :3]
            cross_star = np.concatenate([cross(w, LV[..., :3]),
                                         cross(v, LV[..., :3]) + cross(w, LV[..., 3:])], -1)
            M = np.einsum("bksi,bkst,bktj->bij", Gam, Lam, Gam)
            h = np.einsum("bksi,bks->bi", Gam,
                          np.einsum("bkst,bkt->bks", Lam, acc0) + cross_star)
            f = np.broadcast_to(m[None, :, None] * self.gravity, c.shape)
            Wg = np.concatenate([f, cross(c, f)], -1)
            Q += np.einsum("bksi,bks->bi", Gam, Wg)
        for e in self.elements:
            q = pose.q[:, e.qcolumn]
            if e.kind == "spring":
                tau = -e.value * (q - e.free)
            elif e.kind == "damper":
                tau = -e.value * qd[:, e.column]
            else:
                tau = np.broadcast_to(np.asarray(e.value(t, q, qd[:, e.column]), float), (B,))
            Q += first[:, e.column, :] * tau[:, None]
            if _first_out is not None:        # the element powers, for the energy balance
                p = tau * qd[:, e.column]
                if e.kind == "damper":
                    _first_out["dissipated"] -= p
                elif e.kind == "force":
                    _first_out["work"] += p
        return M, h, Q, qd

    def energy(self, pose: Pose, xd) -> dict:
        """Kinetic, gravitational and spring energy (J), each (B,)."""
        xd = input_rates(xd, "energy: xd", (len(pose), len(self.m.inputs)))
        M, _, _, _ = self.terms(pose, xd)
        xd = np.broadcast_to(np.asarray(xd, float), (len(pose), len(self.m.inputs)))
        T = 0.5 * np.einsum("bi,bij,bj->b", xd, M, xd)
        Vg = np.zeros(len(pose))
        if self.bodies:
            ks = self.m.kinematic_state(pose.state, twists=False)
            _, c, m = self._link_inertias(ks["link"])
            Vg = -np.einsum("k,bki,i->b", m, c, self.gravity)
        Vs = sum(0.5 * e.value * (pose.q[:, e.qcolumn] - e.free) ** 2
                 for e in self.elements if e.kind == "spring") + np.zeros(len(pose))
        return {"kinetic": T, "gravity": Vg, "spring": Vs, "total": T + Vg + Vs}


    # ------------------------------------------------------------ inverse dynamics
    def inverse(self, t, x, xd=None, xdd=None) -> pd.DataFrame:
        """Drive forces of the inputs for a given input motion.

        Parameters
        ----------
        t : (N,) times (s)
        x : (N, n) input values, or a callable ``x(t) -> (x, xd, xdd)`` each (N, n)
        xd, xdd : (N, n) rates and accelerations (when x is an array)

        Returns
        -------
        DataFrame: ``t``, inputs, ``drive:<input>`` (N or N·m), the joint
        coordinates, ``residual`` and ``condition``.  Nothing is integrated.
        """
        t = as_array(t, "inverse: t")
        if t.ndim != 1 or t.size == 0:
            raise MechanismError(f"inverse: t must be a non-empty 1-D array of times, got shape "
                                 f"{t.shape}")
        if callable(x):
            motion = x(t)
            if not isinstance(motion, (tuple, list)) or len(motion) != 3:
                raise MechanismError("inverse: the callable x(t) must return (x, xd, xdd)")
        else:
            if xd is None or xdd is None:
                raise MechanismError("inverse: give xd and xdd with an array x, or a callable")
            motion = (x, xd, xdd)
        n = len(self.m.inputs)
        arrays = []
        for name, v in zip(("x", "xd", "xdd"), motion):
            a = as_array(v, f"inverse: {name}")
            if a.size != t.size * n:
                raise MechanismError(f"inverse: {name} must have shape ({t.size}, {n}) "
                                     f"(times, inputs), got {a.shape}")
            arrays.append(a.reshape(t.size, n))
        x, xd, xdd = arrays
        df, pose = self.m.sweep(x, return_pose=True)
        if len(pose) != t.size:
            bad = df[~df.status.isin(REACHED)].iloc[0]
            raise ClosureError(f"inverse: the motion cannot be followed past row {bad.name} "
                               f"({bad.status}, condition {bad.condition:.2e})")
        M, h, Q, _ = self.terms(pose, xd, t)
        drive = np.einsum("bij,bj->bi", M, xdd) + h - Q
        out = pd.DataFrame({"t": t})
        for k, lab in enumerate(self.m.input_labels()):
            out[lab] = x[:, k]
            out[f"drive:{lab}"] = drive[:, k]
        vals = pd.DataFrame(pose.values(), columns=[f"q:{c}" for c in self.m.coordinate_labels()])
        out = pd.concat([out, vals], axis=1)
        out["residual"] = pose.residual
        out["condition"] = pose.condition
        return out

    # ------------------------------------------------------------ forward dynamics
    def simulate(self, t_span, x0, xd0, *, guess: Pose | None = None, t_eval=None,
                 drive: Callable | None = None, method: str = "DOP853", rtol: float = 1e-10,
                 atol: float = 1e-12, stop_at_dead_point: bool = True,
                 options: SolverOptions | None = None, **ivp_kw) -> pd.DataFrame:
        """Forward dynamics by one of scipy's ``solve_ivp`` method classes.

        Parameters
        ----------
        t_span : (t0, t1) s
        x0, xd0 : (n,) initial independent coordinates and rates
        guess : Pose, optional
            The branch to start on: the initial pose is reached by continuation from
            this pose (default the assembly pose), so a start far from the assembly
            keeps the branch of ``guess``.
        t_eval : (N,) output times, optional
            Default: the integrator's own steps (their poses, solved during the run).
        drive : callable ``drive(t, x, xd) -> (n,)``, optional
            Forces on the inputs (N or N·m), e.g. from :meth:`inverse`.
        method : {"RK23", "RK45", "DOP853", "Radau", "BDF", "LSODA"}
        rtol, atol : float
            The integrator's tolerances.
        stop_at_dead_point : bool
            Stop when the condition number passes the solver's limit at a fold of
            the loop equations (a toggle: the input rates blow up there).  A
            singular configuration that the branch crosses with bounded rates (a
            parallelogram passing its flat position) never stops the run.
            Whatever this says, the run stops with status 1 when a stage reaches
            past a fold where no assembly exists.

        Returns
        -------
        DataFrame per output time: ``t``, inputs and their rates, joint
        coordinates, ``kinetic, potential, energy``, ``dissipated`` and ``work``
        (integrated), ``balance`` = energy + dissipated − work − E(0) (zero for
        an exact solution), ``residual``, ``condition`` and ``flag`` (empty, or
        why a row is doubtful: a condition number above the limit, or an energy
        balance error above ``max(1e-6, 1e4·rtol)`` of the run's energy scale).
        ``.attrs["ivp"]`` is an :class:`~closure.integrate.IntegrationResult`
        (status 0 completed, 1 stopped at a dead point; message; RHS calls);
        ``.attrs["status"]`` and ``.attrs["message"]`` repeat its verdict.
        """
        from .integrate import PoseTracker, check_method, integrate, poses_at, regular_limit
        mech = self.m
        n = len(mech.inputs)
        check_method(method)
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
        opts = options or SolverOptions()
        start = mech.solve(x0, guess=guess, options=opts)
        start.scalar = False
        tracker = PoseTracker(mech, start, opts, xd0 if np.any(xd0) else np.eye(n)[0])
        buf = {}

        def terms_of(xd, t):
            def fn(p):
                M, h, Q, _ = self.terms(p, np.broadcast_to(xd, (len(p), n)), t, _first_out=buf)
                return M, h, Q, buf["first"], buf["dissipated"], buf["work"]
            return fn

        def rhs(t, y):
            x, xd = y[:n], y[n:2 * n]
            p = tracker.at(x)
            M, h, Q, first, diss, work = regular_limit(mech, p, tracker.first, terms_of(xd, t),
                                                       opts)
            buf["dissipated"], buf["work"] = diss, work
            tracker.tangent(p, first[0])
            F = Q[0] - h[0]
            tau = None
            if drive is not None:
                tau = np.asarray(drive(t, x, xd), float).reshape(n)
                F = F + tau
            if not np.all(np.isfinite(F)):
                raise MechanismError(f"simulate: non-finite generalised force at t = {t:.6g} "
                                     f"(drive or joint-force functions returned NaN or inf)")
            xdd = np.linalg.solve(M[0], F)
            dw = buf["work"][0] + (float(tau @ xd) if tau is not None else 0.0)
            return np.r_[xd, xdd, buf["dissipated"][0], dw]

        y0 = np.r_[x0, xd0, 0.0, 0.0]
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
        en = self.energy(pose, XD)
        for i in np.nonzero(pose.condition > TANGENT_COND)[0]:     # singular rows: the limit
            k = min(np.searchsorted(run["t"], t_out[i], side="right") - 1, len(run["t"]) - 1)
            lim = regular_limit(mech, _take_pose(pose, [i]), run["tangents"][k],
                                lambda p: tuple(self.energy(p, np.broadcast_to(XD[i], (len(p), n)))
                                                [key] for key in ("kinetic", "gravity", "spring",
                                                                  "total")), opts)
            for key, v in zip(("kinetic", "gravity", "spring", "total"), lim):
                en[key][i] = v[0]
        out = pd.DataFrame({"t": t_out})
        for k, lab in enumerate(mech.input_labels()):
            out[lab] = X[:, k]
            out[f"rate:{lab}"] = XD[:, k]
        vals = pd.DataFrame(pose.values(), columns=[f"q:{c}" for c in mech.coordinate_labels()])
        out = pd.concat([out, vals], axis=1)
        out["kinetic"] = en["kinetic"]
        out["potential"] = en["gravity"] + en["spring"]
        out["energy"] = en["total"]
        out["dissipated"] = Y[2 * n]
        out["work"] = Y[2 * n + 1]
        e0 = regular_limit(mech, start, tracker.first,
                           lambda p: (self.energy(p, np.broadcast_to(xd0, (len(p), n)))["total"],),
                           opts)[0][0]
        out["balance"] = out.energy + out.dissipated - out.work - e0
        out["residual"] = pose.residual
        out["condition"] = pose.condition
        out["flag"] = _row_flags(out, opts.cond_limit, rtol)
        out.attrs["ivp"] = sol
        out.attrs["status"] = "completed" if sol.status == 0 else "dead point"
        out.attrs["message"] = sol.message
        return out


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


def _row_flags(out: pd.DataFrame, cond_limit: float, rtol: float) -> list:
    """Why each output row is doubtful (empty string when it is not)."""
    scale = (np.abs(out.kinetic).max() + np.ptp(out.potential) + np.abs(out.work).max()
             + np.abs(out.dissipated).max())
    tol = max(1e-6, 1e4 * rtol) * max(scale, 1e-300)
    flags = []
    for c, b in zip(out.condition.to_numpy(), out.balance.to_numpy()):
        f = []
        if c > cond_limit:
            f.append(f"near-singular (condition {c:.2e})")
        if abs(b) > tol:
            f.append(f"energy balance error {b:.2e} J")
        flags.append("; ".join(f))
    return flags
