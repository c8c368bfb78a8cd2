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

from .errors import ClosureError, MechanismError
from .frames import cross, skew
from .kinematics import _bias, analogs, link_twists
from .pose import Pose
from .solver import predict

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
    c = np.asarray(com, float)
    I = np.asarray(inertia, float)
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
        self.com = np.asarray(self.com, float)
        self.inertia = np.asarray(self.inertia, float)
        if not (np.isfinite(self.mass) and self.mass > 0):
            raise MechanismError(f"body {self.link!r}: mass must be positive (kg), got {self.mass}")
        if self.com.shape != (3,) or not np.all(np.isfinite(self.com)):
            raise MechanismError(f"body {self.link!r}: com must be a finite 3-vector (m)")
        I = self.inertia
        if I.shape != (3, 3) or not np.all(np.isfinite(I)):
            raise MechanismError(f"body {self.link!r}: inertia must be a finite 3x3 tensor (kg·m²)")
        if np.abs(I - I.T).max() > 1e-9 * max(1.0, np.abs(I).max()):
            raise MechanismError(f"body {self.link!r}: inertia tensor must be symmetric")
        ev = np.linalg.eigvalsh(I)
        tol = 1e-9 * max(ev.max(), 1e-300)
        if ev.min() < -tol:
            raise MechanismError(f"body {self.link!r}: inertia tensor is not positive "
                                 f"semidefinite (eigenvalue {ev.min():.3g})")
        a, b, c = ev
        if a + b < c - tol:
            raise MechanismError(f"body {self.link!r}: principal moments {ev} violate the "
                                 "triangle inequality (no real body has them)")

    @property
    def J(self) -> np.ndarray:
        """The 4x4 pseudo-inertia in the link frame."""
        return pseudo_inertia(self.mass, self.com, self.inertia)


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
        self.m = mechanism
        self.gravity = np.asarray(gravity, float)
        if self.gravity.shape != (3,):
            raise MechanismError("gravity: expected a 3-vector (m/s²)")
        self.bodies: list[Body] = []
        self.elements: list[_JointElement] = []

    # ------------------------------------------------------------ model
    def add_body(self, link: str, mass: float, com=(0, 0, 0), inertia=None) -> Body:
        """Mass properties of ``link``: ``com`` in ground coordinates at the assembly pose
        (= link coordinates), ``inertia`` about the com (default zero: a point mass)."""
        if link not in self.m.links or link == self.m.ground:
            raise MechanismError(f"add_body: {link!r} is not a moving link; links: "
                                 f"{', '.join(self.m.links[1:])}")
        b = Body(link, float(mass), com, np.zeros((3, 3)) if inertia is None else inertia)
        self.bodies.append(b)
        return b

    def _coord(self, joint, index, what):
        j = self.m.joint(joint)
        if j.kind == "S":
            raise MechanismError(f"{what}: joint {joint!r} is spherical; springs, dampers and "
                                 "forces act on scalar joint coordinates")
        if not 0 <= index < j.nq:
            raise MechanismError(f"{what}: index {index} out of range for joint {joint!r}")
        t = self.m.tree
        return t.v_offset[j.index] + index, t.q_offset[j.index] + index

    def add_spring(self, joint: str, stiffness: float, free: float = 0.0, index: int = 0):
        """Linear spring on a joint coordinate: force ``−k (q − free)`` (N/m or N·m/rad)."""
        if not (np.isfinite(stiffness) and stiffness >= 0):
            raise MechanismError(f"add_spring: stiffness must be ≥ 0, got {stiffness}")
        c, qc = self._coord(joint, index, "add_spring")
        self.elements.append(_JointElement(c, qc, "spring", float(stiffness), float(free)))

    def add_damper(self, joint: str, coefficient: float, index: int = 0):
        """Viscous damper on a joint coordinate: force ``−c q̇`` (N·s/m or N·m·s/rad)."""
        if not (np.isfinite(coefficient) and coefficient >= 0):
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
        t = np.asarray(t, float)
        if callable(x):
            x, xd, xdd = (np.asarray(v, float).reshape(t.size, -1) for v in x(t))
        else:
            if xd is None or xdd is None:
                raise MechanismError("inverse: give xd and xdd with an array x, or a callable")
            x, xd, xdd = (np.asarray(v, float).reshape(t.size, -1) for v in (x, xd, xdd))
        df, pose = self.m.sweep(x, return_pose=True)
        if len(pose) != t.size:
            bad = df[df.status != "ok"].iloc[0]
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
    def simulate(self, t_span, x0, xd0, *, t_eval=None, drive: Callable | None = None,
                 method: str = "DOP853", rtol: float = 1e-10, atol: float = 1e-12,
                 stop_at_dead_point: bool = True, **ivp_kw) -> pd.DataFrame:
        """Forward dynamics by ``scipy.integrate.solve_ivp`` (any of its methods).

        Parameters
        ----------
        t_span : (t0, t1) s
        x0, xd0 : (n,) initial independent coordinates and rates
        drive : callable ``drive(t, x, xd) -> (n,)``, optional
            Forces on the inputs (N or N·m), e.g. from :meth:`inverse`.
        stop_at_dead_point : bool
            Stop when the Jacobian condition number passes the solver's limit.
            Whatever this says, the integration stops (with ``status`` 1 in
            ``.attrs["ivp"]`` and the reason in its ``message``) when a step
            reaches past a fold of the loop equations where no assembly exists.

        The integrator is scipy's (``solve_ivp``'s method classes, stepped here so
        that a dead point ends the run with the trajectory up to it).

        Returns
        -------
        DataFrame per output time: ``t``, inputs and their rates, joint
        coordinates, ``kinetic, potential, energy``, ``dissipated`` and
        ``work`` (integrated), ``balance`` = energy + dissipated − work − E(0)
        (zero for an exact solution), ``residual``, ``condition``; the
        solve_ivp result is in ``.attrs["ivp"]``.
        """
        mech = self.m
        n = len(mech.inputs)
        x0 = np.asarray(x0, float).reshape(n)
        xd0 = np.asarray(xd0, float).reshape(n)
        cache = {"pose": mech.solve(x0)}
        opts = None

        def pose_at(x):
            g = cache["pose"]
            if cache.get("first_of") is not g:
                cache["first"], cache["first_of"] = analogs(mech, g, second=False)[0], g
            (q, rot), _ = predict(mech, g, x, cache["first"][0])
            guess = Pose(mech, x[None], q, rot, g.residual, g.iterations, g.condition, g.status)
            p = mech.solve(x, guess=guess, options=opts, raise_on_failure=False)
            if p.status[0] >= 2:
                raise ClosureError(f"simulate: loops do not close at x = {x.tolist()} "
                                   f"({p.status_text[0]}, residual {p.residual[0]:.2e}, "
                                   f"condition {p.condition[0]:.2e})",
                                   inputs=x[None], residual=p.residual, condition=p.condition)
            cache["pose"] = p
            return p

        def rhs(t, y):
            x, xd = y[:n], y[n:2 * n]
            p = pose_at(x)
            M, h, Q, qd = self.terms(p, xd[None], t, _first_out=cache)
            F = Q[0] - h[0]
            tau = np.asarray(drive(t, x, xd), float) if drive is not None else None
            if tau is not None:
                F = F + tau
            xdd = np.linalg.solve(M[0], F)
            dw = cache["work"][0] + (float(tau @ xd) if tau is not None else 0.0)
            return np.r_[xd, xdd, cache["dissipated"][0], dw]

        import scipy.integrate as si
        from scipy.integrate._ivp.ivp import METHODS

        from .solver import SolverOptions
        if method not in METHODS:
            raise MechanismError(f"simulate: method {method!r} unknown; scipy offers "
                                 f"{', '.join(METHODS)}")
        limit = SolverOptions().cond_limit
        y0 = np.r_[x0, xd0, 0.0, 0.0]
        solver = METHODS[method](rhs, t_span[0], y0, t_span[1], rtol=rtol, atol=atol, **ivp_kw)
        ts, ys, dense = [t_span[0]], [y0], []
        status, message = "completed", "reached the end of the time span"
        while solver.status == "running":
            try:
                solver.step()
            except ClosureError as e:      # a stage beyond a fold of the loop equations
                status, message = "dead point", str(e)
                break
            if solver.status == "failed":
                raise ClosureError(f"simulate: the integrator failed at t = {solver.t}")
            dense.append(solver.dense_output())
            ts.append(solver.t)
            ys.append(solver.y.copy())
            if stop_at_dead_point and pose_at(solver.y[:n]).condition[0] > limit:
                status = "dead point"
                message = f"condition number above {limit:.0e} at t = {solver.t:.6g}"
                break
        ts = np.array(ts)
        if t_eval is None:
            t_out, Y = ts, np.array(ys).T
        else:
            t_out = np.asarray(t_eval, float)
            t_out = t_out[t_out <= ts[-1] + 1e-12 * max(1.0, abs(ts[-1]))]
            seg = np.clip(np.searchsorted(ts, t_out, side="right") - 1, 0, len(dense) - 1)
            Y = np.array([dense[k](tt) if dense else y0 for k, tt in zip(seg, t_out)]).T
        sol = si._ivp.ivp.OdeResult(t=t_out, y=Y, status=0 if status == "completed" else 1,
                                    message=message, success=True, nfev=solver.nfev,
                                    t_end=ts[-1])
        X, XD = sol.y[:n].T, sol.y[n:2 * n].T
        _, pose = mech.sweep(X, return_pose=True) if len(X) > 1 else (None, mech.solve(X[0]))
        if len(pose) != len(X):
            raise ClosureError("simulate: the loops could not be closed along the trajectory")
        en = self.energy(pose, XD)
        out = pd.DataFrame({"t": sol.t})
        for k, lab in enumerate(mech.input_labels()):
            out[lab] = X[:, k]
            out[f"rate:{lab}"] = XD[:, k]
        vals = pd.DataFrame(pose.values(), columns=[f"q:{c}" for c in mech.coordinate_labels()])
        out = pd.concat([out, vals], axis=1)
        out["kinetic"] = en["kinetic"]
        out["potential"] = en["gravity"] + en["spring"]
        out["energy"] = en["total"]
        out["dissipated"] = sol.y[2 * n]
        out["work"] = sol.y[2 * n + 1]
        out["balance"] = out.energy + out.dissipated - out.work - en["total"][0]
        out["residual"] = pose.residual
        out["condition"] = pose.condition
        out.attrs["ivp"] = sol
        return out
