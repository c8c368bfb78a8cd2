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

from .dynamics import Dynamics, _inverse_arguments, _simulate_arguments
from .errors import MechanismError
from .frames import _cross, _inverse, as_array, input_rates, skew
from .state import _SKEW_BASIS

__all__ = ["ReducedDynamics"]


#: ad(V) = Σ_m V_m _AD3[m]: the Lie bracket [V, ·] of twists (v, ω)
_AD3 = np.zeros((6, 6, 6))
for _k in range(3):
    _E = _SKEW_BASIS.reshape(3, 3, 3)[_k]
    _AD3[3 + _k, :3, :3] = _AD3[3 + _k, 3:, 3:] = _E      # ω×
    _AD3[_k, :3, 3:] = _E                                 # v×
del _k, _E


def _solve_small(M, F):
    """M⁻¹ F for a symmetric positive definite M: closed forms for n ≤ 2 (numpy's solve
    costs more than the arithmetic there), numpy's LU above; LinAlgError if singular."""
    n = F.shape[0]
    if n == 1:
        m = float(M[0, 0])
        if not m > 0:
            raise np.linalg.LinAlgError("singular")
        return F / m
    if n == 2:
        a, b, c, d = M.ravel().tolist()
        det = a * d - b * c
        if not abs(det) > 1e-14 * (abs(a * d) + abs(b * c)):
            raise np.linalg.LinAlgError("singular")
        f0, f1 = F.tolist()
        return np.array([(d * f0 - b * f1) / det, (a * f1 - c * f0) / det])
    return np.linalg.solve(M, F)


_EYE4 = np.eye(4)


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
        three at once, that is used instead.
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
        self._fast = all(mp[3] for mp in maps)     # every transfer has all(x)
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
        # the spanning tree, compiled for one pass per call
        tj = [mech.joints[t.parent_joint[li]] for li in t.order[1:]]
        self._order = [(li, t.link_index[j.link_a if t.forward[li] else j.link_b], k)
                       for k, (li, j) in enumerate(zip(t.order[1:], tj))]
        self._tj = tj
        fwd = np.array([t.forward[li] for li in t.order[1:]])
        self._fwd = fwd
        self._left = np.array([j.frame_a if f else j.frame_b for j, f in zip(tj, fwd)])
        self._right = np.array([j.frame_b_inv if f else j.frame_a_inv for j, f in zip(tj, fwd)])
        # R and P joints: left · A(±q) · right = C0 + a C1 + b C2 with (a, b) =
        # (±sin θ, 1 − cos θ) or (±s, 0): constant matrices, one product per call
        K1 = np.zeros((4, 4))
        K1[0, 1], K1[1, 0] = -1.0, 1.0
        K2 = K1 @ K1
        Ez = np.zeros((4, 4))
        Ez[2, 3] = 1.0
        self._Rk = np.array([k for k, j in enumerate(tj) if j.kind == "R"], dtype=int)
        self._Rq = np.array([t.q_offset[tj[k].index] for k in self._Rk], dtype=int)
        self._Pk = np.array([k for k, j in enumerate(tj) if j.kind == "P"], dtype=int)
        self._Pq = np.array([t.q_offset[tj[k].index] for k in self._Pk], dtype=int)
        self._Ok = [k for k, j in enumerate(tj) if j.kind not in "RP"]
        self._sgn = np.where(fwd, 1.0, -1.0)
        C = np.zeros((len(tj), 3, 4, 4))
        for k, j in enumerate(tj):
            L, Rr = self._left[k], self._right[k]
            C[k, 0] = L @ Rr
            if j.kind == "R":
                C[k, 1], C[k, 2] = L @ K1 @ Rr, L @ K2 @ Rr
            elif j.kind == "P":
                C[k, 1] = L @ Ez @ Rr
        self._C0 = C[:, 0]
        self._C12 = C[:, 1:].reshape(len(tj), 2, 16)
        # tree columns: the coordinates that move links
        tc = np.nonzero(np.abs(t.path_sign).sum(0) > 0)[0]
        self._tc = tc
        xi, fa, carrier, deps, uprefix = [], [], [], [], []
        for j in mech.joints:
            for k, (prefix, x, dep) in enumerate(j.columns(np.zeros((1, max(j.nq, 1))))):
                c = t.v_offset[j.index] + k
                if c not in tc:
                    continue
                pos = int(np.nonzero(tc == c)[0][0])
                xi.append(x)
                fa.append(j.frame_a)
                carrier.append(t.link_index[j.link_a])
                deps.append([int(np.nonzero(tc == t.v_offset[j.index] + d)[0][0]) for d in dep])
                if prefix is not None:
                    uprefix.append((pos, j))
        self._xi = np.array(xi).reshape(-1, 6)
        # the column twists in their carrier link's frame: Ad(frame_a) ξ (U's second
        # column moves with the first coordinate and is recomputed per call)
        self._fa = fa_ = np.array(fa).reshape(-1, 4, 4)
        sw = np.einsum("cij,cj->ci", fa_[:, :3, :3], self._xi[:, 3:])
        sv = np.einsum("cij,cj->ci", fa_[:, :3, :3], self._xi[:, :3]) + np.cross(fa_[:, :3, 3], sw)
        self._sv, self._sw = sv[..., None], sw[..., None]
        self._carrier = np.array(carrier, dtype=int)
        self._dep_ptr = np.cumsum([0] + [len(d) for d in deps]).astype(np.int64)
        self._dep_idx = np.array([i for d in deps for i in d], dtype=np.int64)
        self._uprefix = uprefix
        li = [mech.links.index(b.link) for b in dynamics.bodies]
        self._bl = np.array(li, dtype=int)
        self._mass = np.array([b.mass for b in dynamics.bodies])
        self._com = np.array([b.com for b in dynamics.bodies]).reshape(-1, 3, 1)
        self._Ib = np.array([b.inertia for b in dynamics.bodies]).reshape(-1, 3, 3)
        # 6x6 spatial inertias in the link frames, twists (v, ω) about the link origin:
        # [[m E, −m [c]×], [m [c]×, I_c − m [c]×[c]×]]
        Cx = np.array([skew(c) for c in self._com[..., 0]]).reshape(-1, 3, 3)
        m_ = self._mass[:, None, None]
        self._Lb = np.zeros((len(li), 6, 6))
        self._Lb[:, :3, :3] = m_ * np.eye(3)
        self._Lb[:, :3, 3:] = -m_ * Cx
        self._Lb[:, 3:, :3] = m_ * Cx
        self._Lb[:, 3:, 3:] = self._Ib - m_ * (Cx @ Cx)
        self._gkey = None
        self._Pb = t.path_sign[li][:, tc]
        self._Pc = t.path_sign[self._carrier][:, tc]
        self._E = np.eye(ni)[of_input[tc]]                 # (ntc, ni) one-hot
        lin = [e for e in dynamics.elements if e.kind in ("spring", "damper")]
        self._lin_cols = np.array([e.column for e in lin], dtype=int)
        self._lin_k = np.array([e.value if e.kind == "spring" else 0.0 for e in lin])
        self._lin_free = np.array([e.free if e.kind == "spring" else 0.0 for e in lin])
        self._lin_c = np.array([e.value if e.kind == "damper" else 0.0 for e in lin])
        self._lin_nc = -self._lin_c
        self._lin_E = np.eye(ni)[of_input[self._lin_cols]].reshape(len(lin), ni)
        self._springs = [e for e in lin if e.kind == "spring"]
        self._forces = [e for e in dynamics.elements if e.kind == "force"]
        self.info: dict = {}

    # ------------------------------------------------------------ kinematics
    def _coordinates(self, x):
        """q, F', F'' of every coordinate (B, nv) at inputs x (B, ni)."""
        B = x.shape[0]
        nv = self._nv
        out = np.zeros((3, B, nv))
        out[0][:, self._inp] = x
        out[1][:, self._inp] = 1.0
        if B == 1 and self._fast:                # one pose: scalar calls, no array traffic
            xs = x[0].tolist()
            q0, q1, q2 = out[0, 0], out[1, 0], out[2, 0]
            try:
                for c, i, obj, has_all, key in self._maps:
                    q0[c], q1[c], q2[c] = obj.all(xs[i])
            except (ValueError, TypeError):
                pass                             # the general path names the culprit
            else:
                if np.isfinite(out.sum()):
                    return out[0], out[1], out[2]
        one = B == 1
        for c, i, obj, has_all, key in self._maps:
            xi = float(x[0, i]) if one else x[:, i]
            try:
                r = obj.all(xi) if has_all else (obj.position(xi), obj.velocity(xi),
                                                 obj.acceleration(xi))
            except ValueError as e:
                raise MechanismError(f"transfers[{key!r}]: cannot be evaluated at "
                                     f"{self._inputs[i]} = {x[:, i].min():.6g} … "
                                     f"{x[:, i].max():.6g}: {e}") from None
            if one:
                out[:, 0, c] = r
            else:
                out[:, :, c] = r
        if not np.isfinite(out.sum()):
            bad = ~np.isfinite(out).all((0, 1))
            key = self._labels[int(np.argmax(bad))]
            raise MechanismError(f"transfers[{key!r}]: returned a non-finite value")
        return out[0], out[1], out[2]

    def _links(self, q):
        """World poses of every link (B, nlinks, 4, 4) from the coordinates by the tree."""
        B = q.shape[0]
        t = self.m.tree
        ab = np.zeros((B, len(self._tj), 2))
        if self._Rk.size:
            th = q[:, self._Rq]
            ab[:, self._Rk, 0] = np.sin(th) * self._sgn[self._Rk]
            ab[:, self._Rk, 1] = 1.0 - np.cos(th)
        if self._Pk.size:
            ab[:, self._Pk, 0] = q[:, self._Pq] * self._sgn[self._Pk]
        rel = (ab[:, :, None, :] @ self._C12)[:, :, 0].reshape(B, -1, 4, 4) + self._C0
        for k in self._Ok:                        # C, H, U joints: the general product
            j = self._tj[k]
            o = t.q_offset[j.index]
            A = j.matrix(q[:, o:o + j.nq])
            if not self._fwd[k]:
                A = _inverse(A)
            rel[:, k] = self._left[k] @ A @ self._right[k]
        link = np.empty((B, len(t.links), 4, 4))
        link[:, 0] = _EYE4
        if B == 1:                                # one pose: 2-D products into place
            r, out = rel[0], link[0]
            for li, parent, k in self._order:
                np.dot(out[parent], r[k], out=out[li])
            return link
        for li, parent, k in self._order:
            np.matmul(link[:, parent], rel[:, k], out=link[:, li])
        return link

    def _g6(self, gravity):
        """(g, 0) as a 6-vector, kept while ``gravity`` is unchanged."""
        if self._gkey is None or not np.array_equal(self._gkey, gravity):
            self._gkey = np.array(gravity, float)
            self._gvec = np.r_[self._gkey, 0.0, 0.0, 0.0]
        return self._gvec

    def _twists(self, link, q):
        """World unit twists (B, ntc, 6) of the tree columns."""
        Lc = link[:, self._carrier]
        R, p = Lc[..., :3, :3], Lc[..., :3, 3]
        S = np.empty(Lc.shape[:2] + (6,))
        S[..., 3:] = w = (R @ self._sw)[..., 0]
        S[..., :3] = (R @ self._sv)[..., 0] + _cross(p, w)
        t = self.m.tree
        for pos, j in self._uprefix:
            o = t.q_offset[j.index]
            F = Lc[:, pos] @ self._fa[pos] @ j.columns(q[:, o:o + j.nq])[1][0]
            w = F[:, :3, :3] @ self._xi[pos, 3:]
            S[:, pos, 3:] = w
            S[:, pos, :3] = F[:, :3, :3] @ self._xi[pos, :3] + _cross(F[:, :3, 3], w)
        return S

    def _evaluate(self, x, xd, t=0.0, powers=False):
        """M, h, Q (and the element powers) at inputs x, rates xd (B, ni).

        The link twists are ``V = G ẋ`` (columns G per input) and their accelerations
        ``G ẍ + a`` (a: the velocity-product part); taken into each body's frame by
        ``Ad(L⁻¹)``, where its 6x6 spatial inertia Λ_b is constant,
        ``M = Σ G_bᵀ Λ_b G_b``, ``h = Σ G_bᵀ (Λ_b a_b − ad(V_b)ᵀ Λ_b V_b)`` and gravity
        ``Q = Σ G_bᵀ Λ_b (Rᵀ g, 0)`` (Newton–Euler, i.e. Lagrange's equations)."""
        dyn = self.dynamics
        B, n = x.shape
        q, d1, d2 = self._coordinates(x)
        xr = xd[:, self._of_input]                       # rate of each coordinate's input
        qd = d1 * xr
        M = np.zeros((B, n, n))
        h = np.zeros((B, n))
        Q = np.zeros((B, n))
        link = None
        if self._bl.size:
            from .kernels import newton_euler
            link = self._links(q)
            S = self._twists(link, q)                                   # (B, c, 6)
            acc = d2 * xr * xr
            Qg = np.empty((B, n))
            newton_euler(S, qd, d1, acc, self._tc, self._Pc, self._dep_ptr, self._dep_idx,
                         self._Pb, self._E, self._bl, link, self._Lb, self._g6(dyn.gravity),
                         _AD3, M, h, Qg)
            Q += Qg
        diss, work = np.zeros(B), np.zeros(B)
        if self._lin_cols.size:                  # springs and dampers, all at once
            cols = self._lin_cols
            rate = qd[:, cols]
            tau = rate * self._lin_nc                               # −c q̇ (dampers)
            if self._springs:
                tau -= self._lin_k * (q[:, cols] - self._lin_free)
            Q += (d1[:, cols] * tau) @ self._lin_E
            if powers:
                diss += (rate * rate) @ self._lin_c
        for e in self._forces:
            qc, rate = q[:, e.qcolumn], qd[:, e.column]
            tau = np.broadcast_to(np.asarray(e.value(t, qc, rate), float), (B,))
            Q[:, self._of_input[e.column]] += d1[:, e.column] * tau
            if powers:
                work += tau * rate
        return M, h, Q, q, qd, link, diss, work

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

        def rhs(t, y):
            x, xd = y[:n], y[n:2 * n]
            M, h, Q, _, _, _, diss, work = self._evaluate(x[None], xd[None], t, powers=True)
            F = Q[0] - h[0]
            dw = work[0]
            if drive is not None:
                tau = np.asarray(drive(t, x, xd), float).reshape(n)
                F = F + tau
                dw += float(tau @ xd)
            if not np.all(np.isfinite(F)):
                raise MechanismError(f"simulate: non-finite generalised force at t = {t:.6g} "
                                     f"(drive or joint-force functions returned NaN or inf)")
            out = np.empty(2 * n + 2)
            try:
                out[:n], out[n:2 * n] = xd, _solve_small(M[0], F)
            except np.linalg.LinAlgError:
                raise MechanismError(f"simulate: the reduced mass matrix is singular at t = "
                                     f"{t:.6g}, x = {x.tolist()} (an input moves no mass: a "
                                     "transfer function's slope vanishes there)") from None
            out[2 * n], out[2 * n + 1] = diss[0], dw
            return out

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
        out = pd.DataFrame({"t": sol.t})
        for k, lab in enumerate(self._inputs):
            out[lab] = X[:, k]
            out[f"rate:{lab}"] = XD[:, k]
        out = pd.concat([out, pd.DataFrame(q, columns=[f"q:{c}" for c in self._labels])], axis=1)
        out["kinetic"] = en["kinetic"]
        out["potential"] = en["gravity"] + en["spring"]
        out["energy"] = en["total"]
        out["dissipated"] = sol.y[2 * n]
        out["work"] = sol.y[2 * n + 1]
        out["balance"] = out.energy + out.dissipated - out.work - e0
        out["residual"] = self._residual(q) if len(q) else np.zeros(0)
        out.attrs["status"] = "completed" if sol.status == 0 else "left range"
        out.attrs["message"] = (sol.message if sol.status == 0 else
                                f"an input reached an end of its range at t = {sol.t_events}")
        out.attrs["nfev"] = sol.nfev
        return out
