"""Lagrange dynamics with the loop closures replaced by transfer functions.

:class:`ReducedDynamics` takes a :class:`closure.Dynamics` (mechanism, bodies, springs,
dampers, forces, gravity) and, for every non-input joint coordinate, a transfer function
of one input (surrogates of :mod:`approx`, or the engine's exact analogs): the link
poses then follow from the spanning tree without solving any loop, and the model is the
exact Lagrangian system of the kinematics those functions describe.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
import pandas as pd

from .dynamics import Dynamics, _inverse_arguments
from .forward import _simulate_arguments
from .errors import MechanismError
from .frames import _transform, as_array, input_rates, rot_y, skew

__all__ = ["ReducedDynamics"]


#: the Hooke joint's middle rotation (Ry(π/2)), as the joints' matrices have it
_U_MID = _transform(rot_y(np.pi / 2))


class ReducedDynamics:
    """Lagrange dynamics of a mechanism whose loop closures are replaced by transfer
    functions (the hook for surrogate kinematics, e.g. Kuzmin & Tomilova's analogs).

    For a mechanism made of one-mobility loops (or one-mobility groups of loops), each
    driven by its own input, every non-input joint coordinate is a function of one input:
    ``q_c = F_c(x_i)``.  Given ``F_c, F_c', F_c''``, the link poses follow from the
    spanning tree of the mechanism (no loop is solved), their twists are
    ``V_l = Σ_c P_lc S_c F_c'(x_i) ẋ_i`` and their accelerations add
    ``Σ_c P_lc (S_c F_c'' ẋ_i² + [V_carrier(c), S_c] q̇_c)``, so the model is the exact
    Lagrangian system of the kinematics the transfer functions describe:

        M(x) ẍ + h(x, ẋ) = Q(t, x, ẋ) + τ_drive,

    with the same bodies, gravity, springs, dampers and joint forces as ``dynamics``.
    Without dampers, forces or drives its energy is conserved exactly (up to the
    integrator); with the engine's exact analogs as the transfer functions it equals
    :class:`Dynamics` (the tests check both).

    All of it is one compiled call for a batch of states
    (:func:`closure.reduced_kernels.step`): the transfer functions given as polynomial
    pieces, the tree's link poses and column twists, the Newton–Euler sums, springs
    and dampers, and for forward dynamics ``M⁻¹ (Q − h + τ)``; Python evaluates only the
    drive, given joint forces and transfer functions that are not polynomial pieces.

    Parameters
    ----------
    dynamics : Dynamics
        The model (mechanism, bodies, elements, gravity), with the bodies, springs,
        dampers and forces it has when the reduced model is made.  Spherical joints are
        not supported (their rotations are not scalar functions of an input).
    transfers : mapping
        ``{coordinate label: (input, transfer)}`` for every non-input coordinate
        (labels as in ``Mechanism.coordinate_labels()``): ``input`` is an input label
        (``Mechanism.input_labels()``) or its index, ``transfer`` any object with
        ``position(x)``, ``velocity(x)``, ``acceleration(x)`` giving ``F, F', F''`` of
        that coordinate (rad or m) against the input (a float in, a float out, and
        arrays of shape (B,) in and out).  When it also has ``all(x)`` returning the
        three at once, that is used instead.  When it has ``kernel_form()`` returning
        its polynomial pieces (:func:`closure.reduced_kernels.pack_transfer`: the
        surrogates of :mod:`approx` and its constants do), the compiled kernel
        evaluates it (read once, here) and calls none of its methods.
    ranges : mapping, optional
        ``{input label: (low, high)}``, where the transfer functions hold (m or rad).
        :meth:`inverse` then refuses motions outside and :meth:`simulate` stops where an
        input reaches an end (status 1).

    Raises
    ------
    MechanismError
        Bad arguments, naming the argument (and the coordinate).
    """

    def __init__(self, dynamics: Dynamics, transfers, ranges=None):
        from collections.abc import Mapping
        if not isinstance(dynamics, Dynamics):
            raise MechanismError(f"dynamics: expected a closure Dynamics, got "
                                 f"{type(dynamics).__name__}")
        mech = dynamics.m
        for j in mech.joints:
            if j.kind == "S":
                raise MechanismError(f"dynamics: joint {j.name!r} is spherical; a reduced model "
                                     "needs scalar joint coordinates (R, P, C, H, U)")
        if not isinstance(transfers, Mapping):
            raise MechanismError(f"transfers: expected a mapping {{coordinate label: (input, "
                                 f"transfer)}}, got {type(transfers).__name__}")
        t = mech.tree
        self.dynamics, self.m = dynamics, mech
        labels = mech.coordinate_labels()
        inputs = mech.input_labels()
        ni, nv = len(inputs), t.nv
        inp = mech.input_columns()
        self._inp = inp
        self._nv, self._ni = nv, ni
        self._labels, self._inputs = labels, inputs
        of_input = np.full(nv, -1)
        of_input[inp] = np.arange(ni)
        maps = []
        for key in transfers:
            if not isinstance(key, str) or key not in labels:
                raise MechanismError(f"transfers: {key!r} is not a coordinate label; expected "
                                     f"some of {', '.join(labels)}")
            c = labels.index(key)
            if c in inp:
                raise MechanismError(f"transfers: {key!r} is an input; expected the dependent "
                                     "coordinates only")
            v = transfers[key]
            if not isinstance(v, (tuple, list)) or len(v) != 2:
                raise MechanismError(f"transfers[{key!r}]: expected a pair (input, transfer), "
                                     f"got {type(v).__name__}")
            which, obj = v
            if isinstance(which, str) and which in inputs:
                i = inputs.index(which)
            elif isinstance(which, (int, np.integer)) and not isinstance(which, (bool, np.bool_)) \
                    and 0 <= which < ni:
                i = int(which)
            else:
                raise MechanismError(f"transfers[{key!r}]: input {which!r} is not an input; "
                                     f"expected one of {', '.join(inputs)} or 0 … {ni - 1}")
            for name in ("position", "velocity", "acceleration"):
                if not callable(getattr(obj, name, None)):
                    raise MechanismError(f"transfers[{key!r}]: the transfer has no callable "
                                         f"{name}(x); expected an object with position, "
                                         "velocity and acceleration")
            of_input[c] = i
            maps.append((c, i, obj, callable(getattr(obj, "all", None)), key))
        missing = [labels[c] for c in range(nv) if of_input[c] < 0]
        if missing:
            raise MechanismError(f"transfers: no transfer for coordinate(s) "
                                 f"{', '.join(missing)}; every non-input coordinate needs one")
        self._maps = maps
        self._of_input = of_input
        self.transfers = {m[4]: (inputs[m[1]], m[2]) for m in maps}
        # ranges
        self.ranges = {}
        if ranges is not None:
            if not isinstance(ranges, Mapping):
                raise MechanismError(f"ranges: expected a mapping {{input label: (low, high)}}, "
                                     f"got {type(ranges).__name__}")
            for key, v in ranges.items():
                if key not in inputs:
                    raise MechanismError(f"ranges: {key!r} is not an input; expected some of "
                                         f"{', '.join(inputs)}")
                a = as_array(v, f"ranges[{key!r}]", finite=False)
                if a.shape != (2,) or not np.all(np.isfinite(a)) or not a[0] < a[1]:
                    raise MechanismError(f"ranges[{key!r}]: expected (low, high) with finite "
                                         f"low < high, got {v!r}")
                self.ranges[key] = (float(a[0]), float(a[1]))
        # the spanning tree: per tree joint (in the tree's order) its link, its parent
        # link and left · A(q) · right = Σ_m w_m C_m (closure.reduced_kernels.step):
        # R, P, C, H joints C_0 + sin θ C_1 + (1 − cos θ) C_2 + s C_3 (s the slide, or θ
        # for H with the pitch in C_3; backwards the sign in C_1 and C_3), U joints
        # Rz(φ) mid Rz(θ) (transposed backwards) with Rz(α) = P + cos α (E − P) +
        # sin α K1, P = e_z e_zᵀ: weights (1, cos φ, sin φ) ⊗ (1, cos θ, sin θ)
        from .reduced_kernels import _JM, J_LIN, J_U, pack
        tj = [mech.joints[t.parent_joint[li]] for li in t.order[1:]]
        K1 = np.zeros((4, 4))
        K1[0, 1], K1[1, 0] = -1.0, 1.0
        K2 = K1 @ K1
        Ez = np.zeros((4, 4))
        Ez[2, 3] = 1.0
        Pz = np.diag([0.0, 0.0, 1.0])
        rot_parts = (Pz, np.eye(3) - Pz, K1[:3, :3])       # Rz = Σ (1, cos, sin) · these
        mid = _U_MID[:3, :3]
        tree = []
        for li, j in zip(t.order[1:], tj):
            fwd = bool(t.forward[li])
            L, Rr = (j.frame_a, j.frame_b_inv) if fwd else (j.frame_b, j.frame_a_inv)
            sg = 1.0 if fwd else -1.0
            o = t.q_offset[j.index]
            C = np.zeros((_JM, 4, 4))
            if j.kind == "U":
                kind, qa, qb = J_U, o, o + 1
                E33 = np.zeros((4, 4))
                E33[3, 3] = 1.0
                C[0] = L @ E33 @ Rr
                for a_, A in enumerate(rot_parts):
                    for b_, Bm in enumerate(rot_parts):
                        R = A @ mid @ Bm
                        T = np.zeros((4, 4))
                        T[:3, :3] = R if fwd else R.T
                        C[1 + 3 * a_ + b_] = L @ T @ Rr
            else:
                kind = J_LIN
                qa = o if j.kind in "RCH" else -1
                qb = {"P": o, "C": o + 1, "H": o}.get(j.kind, -1)
                C[0] = L @ Rr
                if qa >= 0:
                    C[1], C[2] = sg * (L @ K1 @ Rr), L @ K2 @ Rr
                if qb >= 0:
                    C[3] = sg * (j.pitch if j.kind == "H" else 1.0) * (L @ Ez @ Rr)
            parent = t.link_index[j.link_a if fwd else j.link_b]
            tree.append((li, parent, kind, qa, qb, C))
        # tree columns: the coordinates that move links, each with its twist in its
        # carrier link's frame, Ad(frame_a) ξ; U's second column turns with φ about
        # frame_a's z: Ad(frame_a · Rz(φ) mid) ξ, linear in (1, cos φ, sin φ)
        tc = np.nonzero(np.abs(t.path_sign).sum(0) > 0)[0]
        columns, carrier, deps = [], [], []
        for j in mech.joints:
            for k, (prefix, xi, dep) in enumerate(j.columns(np.zeros((1, max(j.nq, 1))))):
                c = t.v_offset[j.index] + k
                if c not in tc:
                    continue
                fa = j.frame_a
                turns = (rot_parts if prefix is not None else (np.eye(3),))
                u = np.zeros((3, 6))
                for a_, A in enumerate(turns):
                    R = fa[:3, :3] @ A @ (mid if prefix is not None else np.eye(3))
                    sw = R @ xi[3:]
                    u[a_] = np.r_[R @ xi[:3] + np.cross(fa[:3, 3], sw), sw]
                uq = t.q_offset[j.index] if prefix is not None else -1
                columns.append((c, t.link_index[j.link_a], uq, u.ravel()))
                carrier.append(t.link_index[j.link_a])
                deps.append([int(np.nonzero(tc == t.v_offset[j.index] + d)[0][0]) for d in dep])
        carrier = np.array(carrier, dtype=int)
        li = [mech.links.index(b.link) for b in dynamics.bodies]
        self._bl = np.array(li, dtype=int)
        self._mass = np.array([b.mass for b in dynamics.bodies])
        self._com = np.array([b.com for b in dynamics.bodies]).reshape(-1, 3, 1)
        Ib = np.array([b.inertia for b in dynamics.bodies]).reshape(-1, 3, 3)
        # 6x6 spatial inertias in the link frames, twists (v, ω) about the link origin:
        # [[m E, −m [c]×], [m [c]×, I_c − m [c]×[c]×]]
        Cx = np.array([skew(c) for c in self._com[..., 0]]).reshape(-1, 3, 3)
        m_ = self._mass[:, None, None]
        Lb = np.zeros((len(li), 6, 6))
        Lb[:, :3, :3] = m_ * np.eye(3)
        Lb[:, :3, 3:] = -m_ * Cx
        Lb[:, 3:, :3] = m_ * Cx
        Lb[:, 3:, 3:] = Ib - m_ * (Cx @ Cx)
        bodies = (self._bl, t.path_sign[carrier][:, tc], t.path_sign[li][:, tc], Lb,
                  np.cumsum([0] + [len(d) for d in deps]), [i for d in deps for i in d])
        lin = [e for e in dynamics.elements if e.kind in ("spring", "damper")]
        lin_vals = np.array([(e.value, e.free, 0.0, 0.0) if e.kind == "spring" else
                             (0.0, 0.0, e.value, -e.value) for e in lin]).reshape(-1, 4)
        self._springs = [e for e in lin if e.kind == "spring"]
        self._forces = [e for e in dynamics.elements if e.kind == "force"]
        # transfers given as polynomial pieces are evaluated by the kernel, the others
        # (e.g. exact analogs) by their own methods before each call
        packed, self._pymaps = [], []
        for mp in maps:
            form_of = getattr(mp[2], "kernel_form", None)
            form = form_of() if callable(form_of) else None
            if form is None:
                self._pymaps.append(mp)
            else:
                packed.append((mp[0], mp[1], form))
        self._PI, self._PF = pack(tree, columns, inp, of_input, nv, len(t.links), bodies,
                                  ([e.column for e in lin], lin_vals), packed)
        self.info: dict = {}

    # ------------------------------------------------------------ kinematics and terms
    def _work(self, B: int) -> tuple:
        """A zeroed work array of the kernel for B states (:func:`reduced_kernels.layout`)
        and its views: ``x, xd, tau`` (B, n), ``g6`` (6,) (set to (g, 0)), ``q, d1, d2,
        qd, acc`` (B, nv), ``link`` (B, nlinks, 4, 4), ``S`` (B, c, 6), ``M`` (B, n, n),
        ``h, Q`` (B, n), ``diss`` (B,), ``out`` (B, 2n + 2)."""
        from types import SimpleNamespace

        from . import reduced_kernels as rk
        o = rk.layout(B, self._PI)
        W = np.zeros(o[-1])
        n, nv = self._ni, self._nv
        shapes = {"x": (B, n), "xd": (B, n), "tau": (B, n), "g6": (6,), "q": (B, nv),
                  "d1": (B, nv), "d2": (B, nv), "qd": (B, nv), "acc": (B, nv),
                  "link": (B, len(self.m.tree.links), 4, 4),
                  "S": (B, int(self._PI[rk.H_NC]), 6), "M": (B, n, n), "h": (B, n),
                  "Q": (B, n), "diss": (B,), "out": (B, 2 * n + 2)}
        views = SimpleNamespace(**{k: W[o[i]:o[i + 1]].reshape(s)
                                   for i, (k, s) in enumerate(shapes.items())})
        views.g6[:3] = self.dynamics.gravity
        return W, views

    def _python_transfers(self, x: np.ndarray, q: np.ndarray, d1: np.ndarray, d2: np.ndarray,
                          maps: list) -> None:
        """q, F', F'' (B, nv) columns of the transfers ``maps`` by their own methods at
        inputs x (B, ni); MechanismError naming the transfer that cannot be evaluated or
        returns a non-finite value."""
        one = x.shape[0] == 1
        cols = []
        for c, i, obj, has_all, key in maps:
            xi = float(x[0, i]) if one else x[:, i]
            try:
                r = obj.all(xi) if has_all else (obj.position(xi), obj.velocity(xi),
                                                 obj.acceleration(xi))
            except ValueError as e:
                raise MechanismError(f"transfers[{key!r}]: cannot be evaluated at "
                                     f"{self._inputs[i]} = {x[:, i].min():.6g} … "
                                     f"{x[:, i].max():.6g}: {e}") from None
            q[:, c], d1[:, c], d2[:, c] = r
            cols.append(c)
        if cols and not np.isfinite(q[:, cols].sum() + d1[:, cols].sum() + d2[:, cols].sum()):
            bad = ~(np.isfinite(q) & np.isfinite(d1) & np.isfinite(d2)).all(0)
            key = self._labels[int(np.argmax(bad))]
            raise MechanismError(f"transfers[{key!r}]: returned a non-finite value")

    def _transfer_failed(self, x: np.ndarray):
        """The error for inputs x (B, ni) at which the kernel's transfers failed: every
        transfer evaluated by its own methods names the culprit."""
        z = np.zeros((x.shape[0], self._nv))
        self._python_transfers(x, z, z.copy(), z.copy(), self._maps)
        raise MechanismError(f"transfers: cannot be evaluated at inputs {x.tolist()}")

    def _run(self, task: int, x: np.ndarray, xd: np.ndarray, t=0.0) -> tuple:
        """The kernel's ``task`` on inputs x, rates xd (B, ni): the views of its work
        array (:meth:`_work`) and the given joint forces' power (B,) (task TERMS adds
        their forces to Q)."""
        from . import reduced_kernels as rk
        B = x.shape[0]
        W, v = self._work(B)
        v.x[:], v.xd[:] = x, xd
        if self._pymaps:
            self._python_transfers(x, v.q, v.d1, v.d2, self._pymaps)
        if rk.step(task, B, W, self._PI, self._PF) != rk.OK:
            self._transfer_failed(x)
        work = np.zeros(B)
        if task == rk.TERMS:
            self._add_forces(t, v, v.Q, work)
        return v, work

    def _add_forces(self, t, v, Q: np.ndarray, work: np.ndarray) -> None:
        """The given joint forces at time t on the coordinates of ``v`` (:meth:`_work`),
        added to the generalised forces Q (B, ni) and their power to ``work`` (B,)."""
        B = Q.shape[0]
        for e in self._forces:
            qc, rate = v.q[:, e.qcolumn], v.qd[:, e.column]
            tau = np.broadcast_to(np.asarray(e.value(t, qc, rate), float), (B,))
            Q[:, self._of_input[e.column]] += v.d1[:, e.column] * tau
            work += tau * rate

    def _coordinates(self, x: np.ndarray) -> tuple:
        """q, F', F'' of every coordinate (B, nv) at inputs x (B, ni)."""
        from .reduced_kernels import COORDS
        v, _ = self._run(COORDS, x, np.zeros_like(x))
        return v.q, v.d1, v.d2

    def _evaluate(self, x: np.ndarray, xd: np.ndarray, t=0.0) -> tuple:
        """M, h, Q, q, q̇, link poses, the dampers' and the given forces' power at inputs
        x, rates xd (B, ni), by the compiled kernel (:mod:`closure.reduced_kernels`).

        The link twists are ``V = G ẋ`` (columns G per input) and their accelerations
        ``G ẍ + a`` (a: the velocity-product part); taken into each body's frame by
        ``Ad(L⁻¹)``, where its 6x6 spatial inertia Λ_b is constant,
        ``M = Σ G_bᵀ Λ_b G_b``, ``h = Σ G_bᵀ (Λ_b a_b − ad(V_b)ᵀ Λ_b V_b)`` and gravity
        ``Q = Σ G_bᵀ Λ_b (Rᵀ g, 0)`` (Newton–Euler, i.e. Lagrange's equations)."""
        from .reduced_kernels import TERMS
        v, work = self._run(TERMS, x, xd, t)
        return v.M, v.h, v.Q, v.q, v.qd, v.link, v.diss, work

    # ------------------------------------------------------------ public terms
    def _x(self, x, name):
        a = as_array(x, name)
        n = self._ni
        if a.ndim == 1 and a.size == n:
            a = a[None]
        if a.ndim != 2 or a.shape[1] != n:
            raise MechanismError(f"{name}: expected shape (B, {n}) (poses, inputs) or ({n},), "
                                 f"got {a.shape}")
        return a

    def _check_range(self, x, name):
        for k, (lo, hi) in self.ranges.items():
            i = self._inputs.index(k)
            v = x[:, i]
            tol = 1e-12 * max(1.0, abs(lo), abs(hi))
            if v.size and (v.min() < lo - tol or v.max() > hi + tol):
                bad = v[(v < lo - tol) | (v > hi + tol)][0]
                raise MechanismError(f"{name}: input {k!r} = {bad:.6g} is outside the range "
                                     f"[{lo}, {hi}] of the transfer functions")

    def terms(self, x, xd, t=0.0):
        """Mass matrix M (B, n, n), bias h (B, n), applied forces Q (B, n) and the
        coordinate rates q̇ (B, nv) at inputs ``x`` and rates ``xd`` ((B, n) or (n,));
        ``Q`` holds gravity, springs, dampers and given joint forces (not drives)."""
        x = self._x(x, "terms: x")
        xd = input_rates(xd, "terms: xd", x.shape)
        M, h, Q, _, qd, _, _, _ = self._evaluate(x, np.asarray(xd, float), t)
        return M, h, Q, qd

    def coordinates(self, x) -> pd.DataFrame:
        """Joint coordinates from the transfer functions at inputs ``x`` (B, n), with the
        loop-closure ``residual`` they leave (rad, or length / the mechanism's scale)."""
        x = self._x(x, "coordinates: x")
        q = self._coordinates(x)[0]
        out = pd.DataFrame(q, columns=[f"q:{c}" for c in self._labels])
        out["residual"] = self._residual(q)
        return out

    def _residual(self, q):
        ks = self.m.kinematic_state((q, np.zeros((q.shape[0], 0, 3, 3))), twists=False)
        r = ks.r
        if r.shape[1] == 0:
            return np.zeros(q.shape[0])
        return np.maximum(np.abs(r[..., :3]).max((1, 2)) / self.m.tree.scale,
                          np.abs(r[..., 3:]).max((1, 2)))

    def energy(self, x, xd) -> dict:
        """Kinetic, gravitational and spring energy (J), each (B,), at inputs ``x`` and
        rates ``xd``."""
        x = self._x(x, "energy: x")
        xd = np.asarray(input_rates(xd, "energy: xd", x.shape), float)
        out = self._energy(x, xd)
        del out["q"]
        return out

    def _energy(self, x, xd):
        dyn = self.dynamics
        M, _, _, q, _, link, _, _ = self._evaluate(x, xd)
        T = 0.5 * np.einsum("bi,bij,bj->b", xd, M, xd)
        Vg = np.zeros(len(x))
        if self._bl.size:
            Lb = link[:, self._bl]
            c = (Lb[..., :3, :3] @ self._com)[..., 0] + Lb[..., :3, 3]
            Vg = -np.einsum("k,bki,i->b", self._mass, c, dyn.gravity)
        Vs = sum(0.5 * e.value * (q[:, e.qcolumn] - e.free) ** 2
                 for e in self._springs) + np.zeros(len(x))
        return {"kinetic": T, "gravity": Vg, "spring": Vs, "total": T + Vg + Vs, "q": q}

    # ------------------------------------------------------------ inverse dynamics
    def inverse(self, t, x, xd=None, xdd=None) -> pd.DataFrame:
        """Drive forces of the inputs for a given input motion (vectorised over times).

        Parameters
        ----------
        t : (N,) times (s)
        x : (N, n) input values, or a callable ``x(t) -> (x, xd, xdd)`` each (N, n)
        xd, xdd : (N, n) rates and accelerations (when x is an array)

        Returns
        -------
        DataFrame: ``t``, inputs, ``drive:<input>`` (N or N·m), the joint coordinates
        from the transfer functions, and ``residual``: the loop-closure error those
        coordinates leave (rad, or length / the mechanism's scale).
        """
        t, x, xd, xdd = _inverse_arguments(self._ni, t, x, xd, xdd)
        self._check_range(x, "inverse: x")
        M, h, Q, q, _, _, _, _ = self._evaluate(x, xd, t)
        drive = np.einsum("bij,bj->bi", M, xdd) + h - Q
        out = pd.DataFrame({"t": t})
        for k, lab in enumerate(self._inputs):
            out[lab] = x[:, k]
            out[f"drive:{lab}"] = drive[:, k]
        vals = pd.DataFrame(q, columns=[f"q:{c}" for c in self._labels])
        out = pd.concat([out, vals], axis=1)
        out["residual"] = self._residual(q)
        return out

    # ------------------------------------------------------------ forward dynamics
    def _rhs(self, drive: Callable | None) -> Callable:
        """The integrator's right-hand side ``rhs(t, y) -> dy/dt`` (2n + 2,): y holds the
        inputs x (m or rad), their rates ẋ, the dissipated energy and the work of the
        drive and the given joint forces (J); dy/dt is ``(ẋ, ẍ, dissipated power, drive
        and force power)``, ẍ = M⁻¹ (Q − h + τ) with τ = ``drive(t, x, ẋ)`` (n,).

        One compiled call per right-hand side (:func:`closure.reduced_kernels.step`): the
        transfers, the terms, the solve and the powers, on one work array; Python only for
        the drive, the given joint forces and transfers that are not polynomial pieces."""
        from . import reduced_kernels as rk
        n = self._ni
        W, v = self._work(1)
        PI, PF, step, RHS, COORDS, OK = self._PI, self._PF, rk.step, rk.RHS, rk.COORDS, rk.OK
        xx, tau, out = W[:2 * n], v.tau[0], v.out[0]       # x, ẋ adjacent in W
        pymaps, forces = self._pymaps, self._forces

        def rhs(t, y):
            xx[:] = y[:2 * n]
            if pymaps:
                self._python_transfers(v.x, v.q, v.d1, v.d2, pymaps)
            if drive is not None:
                tau[:] = np.asarray(drive(t, y[:n], y[n:2 * n]), float).reshape(n)
            if forces:
                if drive is None:
                    tau[:] = 0.0
                if step(COORDS, 1, W, PI, PF) != OK:
                    self._transfer_failed(v.x)
                self._add_forces(t, v, v.tau, np.zeros(1))
            code = step(RHS, 1, W, PI, PF)
            if code != OK:
                if code == rk.TRANSFER:
                    self._transfer_failed(v.x)
                if code == rk.NON_FINITE:
                    raise MechanismError(f"simulate: non-finite generalised force at t = "
                                         f"{t:.6g} (drive or joint-force functions returned "
                                         "NaN or inf)")
                raise MechanismError(f"simulate: the reduced mass matrix is singular at t = "
                                     f"{t:.6g}, x = {y[:n].tolist()} (an input moves no mass: "
                                     "a transfer function's slope vanishes there)")
            return out.copy()
        return rhs

    def simulate(self, t_span, x0, xd0, *, t_eval=None, drive: Callable | None = None,
                 method: str = "DOP853", rtol: float = 1e-10, atol: float = 1e-12,
                 **ivp_kw) -> pd.DataFrame:
        """Forward dynamics of the reduced model by scipy's ``solve_ivp``.

        Parameters
        ----------
        t_span : (t0, t1) s
        x0, xd0 : (n,) initial inputs and rates
        t_eval : (N,) output times, optional (default the integrator's steps)
        drive : callable ``drive(t, x, xd) -> (n,)``, optional
            Forces on the inputs (N or N·m).
        method : {"RK23", "RK45", "DOP853", "Radau", "BDF", "LSODA"}
        rtol, atol : float
            The integrator's tolerances.

        Returns
        -------
        DataFrame per output time, with the columns of :meth:`Dynamics.simulate` except
        ``condition`` and ``flag``: ``t``, inputs, ``rate:<input>``, joint coordinates,
        ``kinetic, potential, energy, dissipated, work, balance`` and ``residual`` (the
        loop-closure error the transfer functions leave).  ``.attrs``: ``status``
        ("completed", or "left range" when an input reached an end of ``ranges``),
        ``message``, ``nfev``.
        """
        from scipy.integrate import solve_ivp

        from .integrate import check_method
        n = self._ni
        check_method(method)
        x0, xd0, t0, t1 = _simulate_arguments(n, x0, xd0, rtol, atol, drive, t_span)
        if t_eval is not None:
            t_eval = as_array(t_eval, "simulate: t_eval").ravel()
            if t_eval.size and (t_eval.min() < t0 or t_eval.max() > t1):
                raise MechanismError(f"simulate: t_eval must lie within t_span [{t0}, {t1}]")
        self._check_range(x0[None], "simulate: x0")

        rhs = self._rhs(drive)
        events = []
        for k, (lo, hi) in self.ranges.items():
            i = self._inputs.index(k)
            for end, sgn in ((lo, 1.0), (hi, -1.0)):
                ev = (lambda t, y, i=i, end=end, sgn=sgn: sgn * (y[i] - end))
                ev.terminal = True
                events.append(ev)
        sol = solve_ivp(rhs, (t0, t1), np.r_[x0, xd0, 0.0, 0.0], method=method, t_eval=t_eval,
                        rtol=rtol, atol=atol, events=events or None, **ivp_kw)
        if sol.status == -1:
            raise MechanismError(f"simulate: the integrator failed: {sol.message}")
        X, XD = sol.y[:n].T, sol.y[n:2 * n].T
        # one batch for the output rows and the start (E(0) of the balance)
        en = self._energy(np.concatenate([X, x0[None]]), np.concatenate([XD, xd0[None]]))
        e0 = en["total"][-1]
        q = en.pop("q")[:-1]
        en = {k: v[:-1] for k, v in en.items()}
        # the frame at once (pandas inserts a column at a time slowly)
        cols = {"t": sol.t}
        for k, lab in enumerate(self._inputs):
            cols[lab] = X[:, k]
            cols[f"rate:{lab}"] = XD[:, k]
        cols.update((f"q:{c}", q[:, k]) for k, c in enumerate(self._labels))
        cols["kinetic"] = en["kinetic"]
        cols["potential"] = en["gravity"] + en["spring"]
        cols["energy"] = en["total"]
        cols["dissipated"] = sol.y[2 * n]
        cols["work"] = sol.y[2 * n + 1]
        cols["balance"] = cols["energy"] + cols["dissipated"] - cols["work"] - e0
        cols["residual"] = self._residual(q) if len(q) else np.zeros(0)
        out = pd.DataFrame(cols)
        out.attrs["status"] = "completed" if sol.status == 0 else "left range"
        out.attrs["message"] = (sol.message if sol.status == 0 else
                                f"an input reached an end of its range at t = {sol.t_events}")
        out.attrs["nfev"] = sol.nfev
        return out
