"""The kinematic state of a batch of poses and the compiled plan that evaluates it.

:class:`KinematicState` is what travels between :class:`~closure.Mechanism`, the
solver and :mod:`closure.kinematics`: link poses, joint frames and matrices, the
loop residuals and the world-frame unit twists of the velocity coordinates, all
batched.  :class:`Plan` is built once per compiled mechanism (index arrays, the
constant joint frames stacked per role, packed for the compiled kernels of
:mod:`closure.solve_kernels`) so that one evaluation is one kernel call whatever the
number of joints or poses: no per-joint Python work in the solver's inner loop.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .frames import _inverse, _log_se3

__all__ = ["KinematicState", "Plan"]


@dataclass(slots=True, eq=False)
class KinematicState:
    """Link poses, joint frames, loop residuals and column twists of a batch of poses.

    Attributes
    ----------
    link : numpy.ndarray, shape (B, nlinks, 4, 4)
        World pose of every link (ground first).
    frame_a : numpy.ndarray, shape (B, njoints, 4, 4)
        World pose of each joint's frame on its link *a*.
    A : numpy.ndarray, shape (B, njoints, 4, 4)
        Joint transforms ``A(q)`` (link *b*'s joint frame in link *a*'s).
    r : numpy.ndarray, shape (B, nloops, 6)
        Loop residual twists ``log`` of each loop transform, about the mechanism's
        centre (translation in length units, rotation in rad).
    S : numpy.ndarray, shape (B, nv, 6), or None
        World twists ``(v, ω)`` of the velocity coordinates (None when not asked for).
    carrier : numpy.ndarray of int, shape (nv,)
        Per velocity coordinate: index of the link whose frame carries its twist.
    deps : tuple of tuple of int
        Per velocity coordinate: the earlier coordinates of the same joint that move
        its frame (the Hooke joint's second pin).
    first : numpy.ndarray, shape (B, nv, ni), or None
        First-order analogs at these poses when the solver computed them with the
        step (NaN rows where it did not converge); None otherwise.
    step : numpy.ndarray, shape (B,), or None
        Largest dimensionless Newton step the solver computed at these poses when it
        stopped there (NaN where it did not converge); None otherwise.
    """

    link: np.ndarray
    frame_a: np.ndarray
    A: np.ndarray
    r: np.ndarray
    S: np.ndarray | None
    carrier: np.ndarray
    deps: tuple
    first: np.ndarray | None = None
    step: np.ndarray | None = None

    def __len__(self) -> int:
        return self.link.shape[0]

    # ---------------------------------------------------------- batch operations
    def take(self, idx) -> "KinematicState":
        """The state of batch elements ``idx`` (copies)."""
        return KinematicState(self.link[idx], self.frame_a[idx], self.A[idx], self.r[idx],
                              None if self.S is None else self.S[idx], self.carrier, self.deps,
                              None if self.first is None else self.first[idx],
                              None if self.step is None else self.step[idx])

    def put(self, idx, src: "KinematicState", sub) -> None:
        """Store elements ``sub`` of ``src`` at positions ``idx`` (in place)."""
        self.link[idx] = src.link[sub]
        self.frame_a[idx] = src.frame_a[sub]
        self.A[idx] = src.A[sub]
        self.r[idx] = src.r[sub]
        if self.S is not None:
            self.S[idx] = src.S[sub]
        if self.first is not None:
            self.first[idx] = src.first[sub] if src.first is not None else np.nan
        if self.step is not None:
            self.step[idx] = src.step[sub] if src.step is not None else np.nan

    @staticmethod
    def concatenate(states) -> "KinematicState":
        """One state of a list of states, along the batch."""
        s0 = states[0]
        S = None if any(s.S is None for s in states) else np.concatenate([s.S for s in states])
        first = None if any(s.first is None for s in states) else \
            np.concatenate([s.first for s in states])
        step = None if any(s.step is None for s in states) else \
            np.concatenate([s.step for s in states])
        return KinematicState(*(np.concatenate([getattr(s, f) for s in states])
                                for f in ("link", "frame_a", "A", "r")),
                              S, s0.carrier, s0.deps, first, step)



def _arr(a, dtype=float) -> np.ndarray:
    """``a`` as a C-contiguous, writable array of ``dtype`` (copied only when it is not):
    the compiled kernels take one array type per argument, so a read-only or strided
    argument would compile them again."""
    a = np.ascontiguousarray(a, dtype=dtype)
    return a if a.flags.writeable else a.copy()


class Plan:
    """Index arrays and stacked constants of a compiled mechanism, and the batched
    evaluation of its kinematic state (built once per compiled tree).

    The constants are packed once for the compiled kernels of
    :mod:`closure.solve_kernels` (``packed``): every evaluation, step, Jacobian and
    distance below is one call of a kernel that loops over the batch.

    Parameters
    ----------
    mech : Mechanism
    tree : closure.topology.Topology
        The compiled spanning tree and loops of ``mech``.
    """

    def __init__(self, mech, tree):
        from . import lstsq, solve_kernels
        from .joints import _U_MID
        self._lstsq = lstsq
        joints = mech.joints
        nj = len(joints)
        t = tree
        self.nj, self.nv, self.nl, self.nq, self.ns = nj, t.nv, len(t.links), t.nq, t.ns
        self.scale, self.centre = t.scale, t.centre
        self._u_mid = _U_MID
        fa = np.array([j.frame_a for j in joints]).reshape(nj, 4, 4)
        fb = np.array([j.frame_b for j in joints]).reshape(nj, 4, 4)
        fai, fbi = _inverse(fa), _inverse(fb)          # batched: one call for all joints
        self.frames_a = fa
        # tree: per non-ground link (BFS order), the constants either side of its joint
        order = list(t.order[1:])
        tj = np.array([t.parent_joint[li] for li in order], dtype=int)
        fwd = np.array([t.forward[li] for li in order], dtype=bool)
        self.tree_left = np.where(fwd[:, None, None], fa[tj], fb[tj]) if nj else fa[:0]
        self.tree_right = np.where(fwd[:, None, None], fbi[tj], fai[tj]) if nj else fa[:0]
        self.joint_link_a = t.joint_link_a
        # loops: the chord joints
        ch = np.array(t.chords, dtype=int)
        self.chords = ch
        self.chord_fbi = fbi[ch]
        self.chord_link_b = np.array([t.link_index[joints[c].link_b] for c in ch], dtype=int)
        # columns: joint, twist in that joint's frame, carrying link
        col_joint, xi, carrier, deps = [], [], [], []
        q0 = np.zeros((1, max(t.nq, 1)))
        for j in joints:
            for k, (prefix, x, dep) in enumerate(j.columns(q0[:, t.q_offset[j.index]:])):
                col_joint.append(j.index)
                xi.append(x)
                carrier.append(t.link_index[j.link_a])
                deps.append(tuple(t.v_offset[j.index] + d for d in dep))
        self.col_joint = np.array(col_joint, dtype=int)
        xi = np.array(xi, dtype=float).reshape(-1, 6)
        # each unit twist: one axis k_w (weight s_w) in ω, one axis k_v (weight s_v) in v
        nz_w, nz_v = xi[:, 3:] != 0, xi[:, :3] != 0
        if (nz_w.sum(1) > 1).any() or (nz_v.sum(1) > 1).any():
            raise AssertionError("joint twists must have one axis per part")
        self.kw = np.where(nz_w.any(1), np.argmax(nz_w, 1), 2)
        self.kv = np.where(nz_v.any(1), np.argmax(nz_v, 1), 2)
        self.sw = xi[np.arange(len(xi)), 3 + self.kw]
        self.sv = xi[np.arange(len(xi)), self.kv]
        self.carrier = np.array(carrier, dtype=int)
        self.carrier.flags.writeable = False
        self.deps = tuple(deps)
        # dimensionless columns: length coordinates multiplied by the scale
        self.all_cols = np.arange(t.nv)
        self.col_scale = np.ones(t.nv)
        self.col_scale[t.length_cols] = t.scale
        # inputs (fixed for a compiled tree: add_input recompiles)
        self.input_v = np.array([t.v_offset[ji] + k for ji, k in mech.inputs], dtype=int)
        self.input_q = np.array([t.q_offset[ji] + k for ji, k in mech.inputs], dtype=int)
        self.unknown = np.setdiff1d(np.arange(t.nv), self.input_v)
        for arr in (self.input_v, self.input_q, self.unknown):
            arr.flags.writeable = False
        self.input_scale = np.where(np.isin(self.input_v, t.length_cols), t.scale, 1.0)
        self.input_cscale = self.col_scale[self.input_v]
        self.unknown_cscale = self.col_scale[self.unknown]
        #: 1 + |centre| / scale: digits of the coordinates lost to the world origin
        self.offset = 1.0 + float(np.linalg.norm(t.centre)) / t.scale
        self.rank: int | None = None            # expected rank, set once the mobility is known
        self.loop_coef = t.loop_coef
        self.loop_scaled = t.loop_coef * self.col_scale
        # world twist (v, ω) → dimensionless twist about the centre: ((v + ω × c) / L, ω)
        c, L = t.centre, t.scale
        M = np.eye(6)
        M[:3, :3] /= L
        M[:3, 3:] = -np.array([[0, -c[2], c[1]], [c[2], 0, -c[0]], [-c[1], c[0], 0]]) / L
        self.row_map = M
        # velocity coordinate → stored coordinate, and the spherical joints' columns
        scal_v, scal_q, s_cols = [], [], []
        for j in joints:
            v0 = t.v_offset[j.index]
            if j.kind == "S":
                s_cols.append(np.arange(v0, v0 + 3))
            else:
                scal_v += list(range(v0, v0 + j.nv))
                scal_q += list(range(t.q_offset[j.index], t.q_offset[j.index] + j.nq))
        self.scal_v = np.array(scal_v, dtype=int)
        self.scal_q = np.array(scal_q, dtype=int)
        self.s_cols = np.array(s_cols, dtype=int).reshape(-1, 3)
        self.s_order = np.array([t.s_index[j.index] for j in joints if j.kind == "S"], dtype=int)
        self._kernels = solve_kernels
        #: the kernels' view of these constants: (PI, PF, PM) of closure.solve_kernels.pack
        self.packed = solve_kernels.pack(self, mech, t)
        self._ucols = np.array(self.unknown, dtype=np.int64)      # writable copies: the
        self._icols = np.array(self.input_v, dtype=np.int64)      # kernels' one array type

    # ------------------------------------------------------------------ evaluation
    def _state_arrays(self, q, rot, name="state"):
        """``q (B, nq)`` and ``rot (B, ns, 3, 3)`` as contiguous float arrays, checked
        (the kernels do not check bounds)."""
        q = _arr(q)
        rot = _arr(rot)
        if q.ndim != 2 or q.shape[1] != self.nq or rot.shape != (q.shape[0], self.ns, 3, 3):
            from .errors import MechanismError
            raise MechanismError(f"{name}: expected q ({q.shape[0] if q.ndim else 'B'}, "
                                 f"{self.nq}) and rot (B, {self.ns}, 3, 3), got q "
                                 f"{q.shape} and rot {rot.shape}")
        return q, rot

    def joint_matrices(self, q, rot) -> np.ndarray:
        """``A(q)`` of every joint ``(B, njoints, 4, 4)``."""
        return self.evaluate(q, rot, twists=False).A

    def evaluate(self, q, rot, twists: bool = True) -> KinematicState:
        """The kinematic state of states ``q (B, nq)``, ``rot (B, ns, 3, 3)``."""
        q, rot = self._state_arrays(q, rot)
        B = q.shape[0]
        A = np.empty((B, self.nj, 4, 4))
        link = np.empty((B, self.nl, 4, 4))
        fa = np.empty((B, self.nj, 4, 4))
        r = np.empty((B, self.chords.size, 6))
        S = np.empty((B, self.nv, 6))
        self._kernels.evaluate_batch(*self.packed, q, rot, A, link, fa, r, S)
        return KinematicState(link, fa, A, r, S if twists else None, self.carrier, self.deps)

    def twists(self, q, frame_a) -> np.ndarray:
        """World twists ``(B, nv, 6)`` of the velocity coordinates.

        Every unit twist in its joint frame has one axis in its rotation part and one in
        its translation part (``R``, ``P``, ``C``, ``H`` about or along z, the S joint's
        x, y, z), so ``ω = w_c · R e_k`` and ``v = s_c · R e_j + p × ω``: a gather of
        frame columns instead of a product."""
        q = _arr(q)
        frame_a = _arr(frame_a)
        if q.ndim != 2 or q.shape[1] != self.nq or frame_a.shape != (q.shape[0], self.nj, 4, 4):
            from .errors import MechanismError
            raise MechanismError(f"twists: expected q (B, {self.nq}) and frame_a (B, "
                                 f"{self.nj}, 4, 4), got {q.shape} and {frame_a.shape}")
        S = np.empty((q.shape[0], self.nv, 6))
        self._kernels.twists_batch(*self.packed[:2], q, frame_a, S)
        return S

    def scaled_jacobian(self, S, cols) -> np.ndarray:
        """Dimensionless loop Jacobian ``(B, 6·nloops, len(cols))`` of columns ``cols``:
        twists about the mechanism's centre (``v + ω × c``), translation rows divided by
        the length scale, length columns multiplied by it (the constant row map and the
        loop coefficients)."""
        S = _arr(S)
        cols = np.array(cols, dtype=np.int64).reshape(-1)      # writable: one array type
        if S.ndim != 3 or S.shape[1:] != (self.nv, 6) or (cols.size and (
                cols.min() < 0 or cols.max() >= self.nv)):
            from .errors import MechanismError
            raise MechanismError(f"scaled_jacobian: expected S (B, {self.nv}, 6) and columns "
                                 f"below {self.nv}, got {S.shape}")
        J = np.empty((S.shape[0], 6 * self.chords.size, cols.size))
        self._kernels.scaled_jacobian_batch(*self.packed[:2], S, cols, J)
        return J

    def condition(self, S, idx) -> np.ndarray:
        """Condition numbers ``s_max / s_rank`` (SVD, expected rank) of the dimensionless
        Jacobian of the unknowns at the states ``idx`` of twists ``S`` (B, nv, 6) (the
        rank must be known: :func:`closure.lstsq._expected_rank`)."""
        lsq = self._lstsq
        S = _arr(np.asarray(S)[idx])
        if S.ndim != 3 or S.shape[1:] != (self.nv, 6):
            from .errors import MechanismError
            raise MechanismError(f"condition: expected S (B, {self.nv}, 6), got {S.shape}")
        m, n = 6 * self.chords.size, self._ucols.size
        if m == 0 or n == 0:
            return np.ones(S.shape[0])
        J = np.empty((S.shape[0], m, n))
        self._kernels.scaled_jacobian_batch(*self.packed[:2], S, self._ucols, J)
        with lsq._serial_blas_entries(m * n):  # numpy's SVD without the vectors
            return lsq._cond_of(np.linalg.svd(J, compute_uv=False), self.rank)

    def scaled_residual(self, r) -> np.ndarray:
        """Dimensionless loop residual ``(B, 6·nloops)``."""
        out = r.reshape(r.shape[0], -1).copy()
        if r.shape[1]:
            out.reshape(r.shape)[..., :3] /= self.scale
        return out

    def apply(self, q, rot, dv_scaled):
        """New ``(q, rot)`` from a dimensionless step ``(B, nv)`` over all coordinates."""
        q, rot = self._state_arrays(q, rot)
        dv = _arr(dv_scaled)
        if dv.shape != (q.shape[0], self.nv):
            from .errors import MechanismError
            raise MechanismError(f"apply: expected a step ({q.shape[0]}, {self.nv}), got "
                                 f"{dv.shape}")
        q_out, rot_out = np.empty_like(q), np.empty_like(rot)
        self._kernels.apply_batch(*self.packed[:2], q, rot, dv, q_out, rot_out)
        return q_out, rot_out

    def distance(self, a, b) -> np.ndarray:
        """Dimensionless distance per velocity coordinate between states ``(B, nv)``."""
        qa, ra = self._state_arrays(*a)
        qb, rb = self._state_arrays(*b)
        if qa.shape != qb.shape:
            from .errors import MechanismError
            raise MechanismError(f"distance: batches of {qa.shape[0]} and {qb.shape[0]} states")
        out = np.empty((qa.shape[0], self.nv))
        self._kernels.distance_batch(*self.packed[:2], qa, ra, qb, rb, out)
        return out


_SKEW_I, _SKEW_J = np.array([2, 0, 1]), np.array([1, 2, 0])


def _rot_log(R):
    """Rotation vectors of rotations ``(..., 3, 3)`` all below a quarter turn, with their
    angles and sines: ``(w, θ, θ², sin θ)`` (as :func:`closure.frames._log_so3`, whose
    small-angle series it shares); None when any turns a quarter turn or more."""
    v = 0.5 * (R[..., _SKEW_I, _SKEW_J] - R[..., _SKEW_J, _SKEW_I])     # sin θ · axis
    cth = 0.5 * (np.einsum("...ii->...", R) - 1.0)
    if not (cth > 0.0).all():
        return None
    th = np.arctan2(np.sqrt(np.einsum("...i,...i->...", v, v)), cth)
    th2 = th * th
    s_ = np.sin(th)
    small = th2 < 1e-10
    if small.any():
        scale = np.where(small, 1 + th2 / 6 + 7 * th2 * th2 / 360,
                         th / np.where(small, 1.0, s_))
    else:
        scale = th / s_
    return v * scale[..., None], th, th2, s_


def _loop_log(G):
    """``log`` of loop transforms ``(..., 4, 4)`` → twists ``(..., 6)``: the values of
    :func:`closure.frames.log_se3` (to rounding) in fewer operations for the usual case
    of rotations below a quarter turn; larger ones go through :func:`_log_se3`."""
    rl = _rot_log(G[..., :3, :3])
    if rl is None:                                 # a quarter turn or more: the full log
        return _log_se3(G)
    w, th, th2, s_ = rl
    # V⁻¹ p = p − ½ ω × p + e ω × (ω × p),  e = (1 − θ sin θ / (2 (1 − cos θ))) / θ²
    small = th2 < 1e-8
    if small.all():
        e = 1 / 12 + th2 / 720
    else:
        big = ~small
        e = (1 - th * s_ / np.where(big, 2 * (1 - np.cos(th)), 1.0)) / np.where(big, th2, 1.0)
        if small.any():
            e = np.where(small, 1 / 12 + th2 / 720, e)
    p = G[..., :3, 3:4]
    K = _skew_of(w)
    wp = K @ p
    out = np.empty(G.shape[:-2] + (6,))
    out[..., 3:] = w
    out[..., :3] = (p - 0.5 * wp + e[..., None, None] * (K @ wp))[..., 0]
    return out


#: the skew matrix of a 3-vector w is w @ _SKEW_BASIS reshaped to (3, 3)
_SKEW_BASIS = np.zeros((3, 3, 3))
_SKEW_BASIS[0, 2, 1], _SKEW_BASIS[0, 1, 2] = 1.0, -1.0
_SKEW_BASIS[1, 0, 2], _SKEW_BASIS[1, 2, 0] = 1.0, -1.0
_SKEW_BASIS[2, 1, 0], _SKEW_BASIS[2, 0, 1] = 1.0, -1.0
_SKEW_BASIS = _SKEW_BASIS.reshape(3, 9)


def _skew_of(w):
    """Skew matrices ``[w]×`` ``(..., 3, 3)`` of vectors ``(..., 3)`` (one product)."""
    return (w @ _SKEW_BASIS).reshape(w.shape[:-1] + (3, 3))


def _rz(th):
    """Rotations about z ``(..., 3, 3)`` (as :func:`closure.rot_z`, unchecked)."""
    c, s = np.cos(th), np.sin(th)
    out = np.zeros(th.shape + (3, 3))
    out[..., 0, 0], out[..., 0, 1] = c, -s
    out[..., 1, 0], out[..., 1, 1] = s, c
    out[..., 2, 2] = 1.0
    return out
