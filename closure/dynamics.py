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

The terms are formed by the compiled kernels of :mod:`closure.dynamics_kernels`
(about each body's centre of mass).  This module holds the model; forward dynamics
(:meth:`Dynamics.simulate`) is :mod:`closure.forward`, whose right-hand side is three
compiled calls there and in the position solver (predictor, Newton, terms and
``M⁻¹ (Q − h)``), and B trajectories at once :mod:`closure.batch_dynamics`.  The same model with
every loop replaced by transfer functions of the inputs is :mod:`closure.reduced`
(:meth:`Dynamics.reduced`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import pandas as pd

from .errors import ClosureError, MechanismError
from .frames import as_array, as_index, as_number, input_rates
from .kinematics import _check_pose
from .pose import REACHED, Pose
from .solver import SolverOptions

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
    def _model_key(self) -> tuple:
        """What :func:`closure.dynamics_kernels.pack` reads of this model: gravity, every
        body's link and mass properties, every element's coordinate, kind, coefficient and
        free value (bodies, elements and gravity may change between calls)."""
        return (np.asarray(self.gravity, float).tobytes(),
                tuple((b.link, float(b.mass), np.asarray(b.com, float).tobytes(),
                       np.asarray(b.inertia, float).tobytes()) for b in self.bodies),
                tuple((e.column, e.qcolumn, e.kind,
                       None if e.kind == "force" else float(e.value), float(e.free))
                      for e in self.elements))

    def _packed(self):
        """The compiled kernels' view of this model (:func:`closure.dynamics_kernels.pack`):
        ``(plan, DI, DF)``, packed once per model and compiled plan and packed again only
        when the model changed (:meth:`_model_key`)."""
        from . import dynamics_kernels
        plan = self.m.plan
        key = self._model_key()
        cached = self.__dict__.get("_pack_cache")
        if cached is not None and cached[0] is plan and cached[1] == key:
            return cached[2]
        packed = (plan, *dynamics_kernels.pack(self, plan))
        self._pack_cache = (plan, key, packed)
        return packed

    def _evaluate(self, pose: Pose, xd, t=0.0):
        """M, h, Q (given joint forces included), the coordinate rates, first analogs, the
        dampers' and given forces' powers (``dissipated``, ``work``) and the gravity and
        spring energies at ``pose`` and rates ``xd`` (B, n): one call of the compiled
        :func:`closure.dynamics_kernels.step` (task ``TERMS``), the given forces (Python
        callables) added here through the first analogs."""
        from . import dynamics_kernels as dk
        from .integrate import RHS_COND
        from .lstsq import _expected_rank
        from .solver import _DEFAULT_OPTIONS
        from .state import _arr
        mech = self.m
        B, n = len(pose), len(mech.inputs)
        plan, DI, DF = self._packed()
        nv, nq = plan.nv, plan.nq
        fopts, iopt = dk.options(_DEFAULT_OPTIONS, _expected_rank(mech), RHS_COND, n, nv, nq)
        lay = dk.layout(n, nv, nq)
        size = lay["size"]
        buf = np.zeros(B * size)
        y = _arr(np.broadcast_to(xd, (B, n))).reshape(-1)
        z1, zi = np.zeros(1), np.zeros(1, dtype=np.int64)
        dk.step(dk.TERMS, *plan.packed, DI, DF, fopts, iopt, plan._ucols, plan._icols,
                _arr(pose.q), _arr(pose.rot), _NO_LINK, _NO_S, z1, z1, zi, zi, z1, _NO_ROT, z1,
                _NO_FIRST, y, buf)
        blocks = buf.reshape(B, size)

        def field(name, shape):
            o = lay[name]
            return blocks[:, o:o + int(np.prod(shape))].reshape((B,) + shape).copy()
        M, h, Q = field("M", (n, n)), field("h", (n,)), field("Q", (n,))
        first, qd, en = field("first", (nv, n)), field("qd", (nv,)), field("en", (3,))
        work = np.zeros(B)
        for e in self.elements:
            if e.kind != "force":
                continue
            q = pose.q[:, e.qcolumn]
            tau = np.broadcast_to(np.asarray(e.value(t, q, qd[:, e.column]), float), (B,))
            Q += first[:, e.column, :] * tau[:, None]
            work += tau * qd[:, e.column]
        return M, h, Q, qd, first, en[:, 0], work, en[:, 1], en[:, 2]

    def terms(self, pose: Pose, xd, t=0.0):
        """M (B, n, n), h (B, n), applied forces Q (B, n) and the coordinate rates (B, nv).

        ``Q`` holds gravity, springs, dampers and given joint forces (not drives)."""
        _check_pose(self.m, pose, "terms")
        xd = input_rates(xd, "terms: xd", (len(pose), len(self.m.inputs)))
        return self._evaluate(pose, xd, t)[:4]

    def energy(self, pose: Pose, xd) -> dict:
        """Kinetic, gravitational and spring energy (J), each (B,)."""
        _check_pose(self.m, pose, "energy")
        xd = input_rates(xd, "energy: xd", (len(pose), len(self.m.inputs)))
        M, _, _, _, _, _, _, Vg, Vs = self._evaluate(pose, xd)
        T = 0.5 * np.einsum("bi,bij,bj->b", xd, M, xd)
        return {"kinetic": T, "gravity": Vg, "spring": Vs, "total": T + Vg + Vs}


    # ------------------------------------------------------------ reduced model (hook)
    def reduced(self, transfers, ranges=None):
        """This model with every loop closure replaced by given transfer functions.

        See :class:`closure.reduced.ReducedDynamics` (the same arguments after
        ``dynamics``; this returns one): each
        non-input coordinate becomes a function of one input, ``q_c = F_c(x_i)``, given
        by any object with ``position``, ``velocity`` and ``acceleration`` (for example
        the surrogates of ``approx``, or exact analogs); the loops are then never
        solved.
        """
        from .reduced import ReducedDynamics
        return ReducedDynamics(self, transfers, ranges)

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
        t, x, xd, xdd = _inverse_arguments(len(self.m.inputs), t, x, xd, xdd)
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
    def simulate_batch(self, t_span, x0, xd0, **options):
        """B independent trajectories in one call (initial states ``x0, xd0`` (B, n)), each
        with its own steps and error control: see
        :func:`closure.batch_dynamics.simulate_batch` (the same arguments after this model)."""
        from .batch_dynamics import simulate_batch
        return simulate_batch(self, t_span, x0, xd0, **options)

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
        from .forward import simulate
        return simulate(self, t_span, x0, xd0, guess=guess, t_eval=t_eval, drive=drive,
                        method=method, rtol=rtol, atol=atol,
                        stop_at_dead_point=stop_at_dead_point, options=options, **ivp_kw)


#: placeholders for the arguments of closure.dynamics_kernels.step that TERMS does not use
_NO_LINK, _NO_S = np.zeros((1, 0, 4, 4)), np.zeros((1, 0, 6))
_NO_ROT, _NO_FIRST = np.zeros((0, 3, 3)), np.zeros((0, 0))


def _inverse_arguments(n, t, x, xd, xdd):
    """The checked motion of both ``inverse`` methods: times ``t`` (T,) and ``x, xd, xdd``
    (T, n), given as arrays or by a callable ``x(t) → (x, xd, xdd)``."""
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
    arrays = []
    for name, v in zip(("x", "xd", "xdd"), motion):
        a = as_array(v, f"inverse: {name}")
        if a.size != t.size * n:
            raise MechanismError(f"inverse: {name} must have shape ({t.size}, {n}) "
                                 f"(times, inputs), got {a.shape}")
        arrays.append(a.reshape(t.size, n))
    return (t, *arrays)
