"""The kinematic state of a batch of poses and the compiled plan that evaluates it.

:class:`KinematicState` is what travels between :class:`~closure.Mechanism`, the
solver and :mod:`closure.kinematics`: link poses, joint frames and matrices, the
loop residuals and the world-frame unit twists of the velocity coordinates, all
batched.  :class:`Plan` is built once per compiled mechanism (index arrays, the
constant joint frames stacked per role, the joint kinds grouped) so that one
evaluation is a fixed, short sequence of batched numpy operations whatever the
number of joints: no per-joint Python work in the solver's inner loop.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .frames import _inverse, _log_se3, _log_so3, _EYE3

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

    ``ks["link"]`` style access by field name is kept for older callers.
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

    # ---------------------------------------------------------- mapping compatibility
    def __getitem__(self, key: str):
        if key == "A":                  # the former per-joint list of (B, 4, 4) arrays
            return [self.A[:, k] for k in range(self.A.shape[1])]
        if key not in _FIELDS or (key == "S" and self.S is None):
            raise KeyError(key)
        return getattr(self, key)

    def __contains__(self, key: str) -> bool:
        return key in _FIELDS and getattr(self, key) is not None

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


_FIELDS = ("link", "frame_a", "A", "r", "S", "carrier", "deps", "first", "step")


def _rigid_inverse(T):
    """Inverse of rigid transforms ``(..., 4, 4)`` (unchecked)."""
    out = np.zeros(T.shape)
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -(Rt @ T[..., :3, 3:4])[..., 0]
    out[..., 3, 3] = 1.0
    return out


def _exp_so3(w):
    """Rotation matrices of rotation vectors ``(..., 3)`` (unchecked; series near 0, as
    :func:`closure.exp_so3`)."""
    th2 = np.einsum("...i,...i->...", w, w)
    small = th2 < 1e-8
    ths = np.sqrt(np.where(small, 1.0, th2))
    a = np.where(small, 1 - th2 / 6 + th2 ** 2 / 120, np.sin(ths) / ths)
    b = np.where(small, 0.5 - th2 / 24 + th2 ** 2 / 720, (1 - np.cos(ths)) / ths ** 2)
    K = np.zeros(w.shape[:-1] + (3, 3))
    x, y, z = w[..., 0], w[..., 1], w[..., 2]
    K[..., 0, 1], K[..., 0, 2] = -z, y
    K[..., 1, 0], K[..., 1, 2] = z, -x
    K[..., 2, 0], K[..., 2, 1] = -y, x
    return _EYE3 + a[..., None, None] * K + b[..., None, None] * (K @ K)


class Plan:
    """Index arrays and stacked constants of a compiled mechanism, and the batched
    evaluation of its kinematic state (built once per compiled tree).

    Parameters
    ----------
    mech : Mechanism
    tree : closure.mechanism._Tree
        The compiled spanning tree and loops of ``mech``.
    """

    def __init__(self, mech, tree):
        from .joints import _U_MID
        joints = mech.joints
        nj = len(joints)
        t = tree
        self.nj, self.nv, self.nl = nj, t.nv, len(t.links)
        self.scale, self.centre = t.scale, t.centre
        self._u_mid = _U_MID
        fa = np.array([j.frame_a for j in joints]).reshape(nj, 4, 4)
        fb = np.array([j.frame_b for j in joints]).reshape(nj, 4, 4)
        fai, fbi = _inverse(fa), _inverse(fb)          # batched: one call for all joints
        self.frames_a = fa
        # joint matrices: one template (identity) and the index arrays of each kind
        self._template = np.broadcast_to(np.eye(4), (nj, 4, 4)).copy()
        kinds = [j.kind for j in joints]

        def idx(ks):
            return np.array([j.index for j in joints if j.kind in ks], dtype=int)

        def qcol(ks, k=0):
            return np.array([t.q_offset[j.index] + k for j in joints if j.kind in ks], dtype=int)

        self.rot_j, self.rot_q = idx("RCH"), qcol("RCH")          # Rz(q) rotations
        self.slide_j = idx("PCH")                                   # Tz slides
        self.slide_q = np.array([t.q_offset[j.index] + (1 if j.kind == "C" else 0)
                                 for j in joints if j.kind in "PCH"], dtype=int)
        self.slide_pitch = np.array([j.pitch if j.kind == "H" else 1.0
                                     for j in joints if j.kind in "PCH"])
        self.has_pitch = bool(np.any([k == "H" for k in kinds]))
        self.s_j = idx("S")
        self.s_rot = np.array([t.s_index[j] for j in self.s_j], dtype=int)
        self.u_j, self.u_q0, self.u_q1 = idx("U"), qcol("U", 0), qcol("U", 1)
        # tree: per non-ground link (BFS order), its parent joint and the constants
        order = list(t.order[1:])
        tj = np.array([t.parent_joint[li] for li in order], dtype=int)
        fwd = np.array([t.forward[li] for li in order], dtype=bool)
        self.tree_j = tj
        self.tree_back = np.nonzero(~fwd)[0]
        self.all_forward = bool(fwd.all())
        self.tree_left = np.where(fwd[:, None, None], fa[tj], fb[tj]) if nj else fa[:0]
        self.tree_right = np.where(fwd[:, None, None], fbi[tj], fai[tj]) if nj else fa[:0]
        # levels of the tree: links of equal depth are composed in one product
        depth = np.zeros(self.nl, dtype=int)
        parent_link = np.zeros(self.nl, dtype=int)
        for li in order:
            j = joints[t.parent_joint[li]]
            p = t.link_index[j.link_a] if t.forward[li] else t.link_index[j.link_b]
            parent_link[li] = p
            depth[li] = depth[p] + 1
        pos = {li: k for k, li in enumerate(order)}
        self.levels = []
        for d in range(1, int(depth.max(initial=0)) + 1):
            ch = np.array([li for li in order if depth[li] == d], dtype=int)
            self.levels.append((ch, parent_link[ch], np.array([pos[li] for li in ch], dtype=int)))
        self.joint_link_a = t.joint_link_a
        # loops: the chord joints
        ch = np.array(t.chords, dtype=int)
        self.chords = ch
        self.chord_fbi = fbi[ch]
        self.chord_link_b = np.array([t.link_index[joints[c].link_b] for c in ch], dtype=int)
        # columns: joint, twist in that joint's frame, carrying link, U prefix columns
        col_joint, xi, carrier, deps, u_cols = [], [], [], [], []
        q0 = np.zeros((1, max(t.nq, 1)))
        for j in joints:
            for k, (prefix, x, dep) in enumerate(j.columns(q0[:, t.q_offset[j.index]:])):
                c = t.v_offset[j.index] + k
                col_joint.append(j.index)
                xi.append(x)
                carrier.append(t.link_index[j.link_a])
                deps.append(tuple(t.v_offset[j.index] + d for d in dep))
                if prefix is not None:
                    u_cols.append(c)
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
        self.w_unit = bool(np.all(self.sw == 1.0))
        self.v_cols = np.nonzero(self.sv != 0)[0]
        self.carrier = np.array(carrier, dtype=int)
        self.carrier.flags.writeable = False
        self.deps = tuple(deps)
        self.u_cols = np.array(u_cols, dtype=int)
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
        self.solve_cols = np.concatenate([self.unknown, self.input_v])   # step | analogs
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
        self.row_map_t = np.ascontiguousarray(M.T)
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

    # ------------------------------------------------------------------ evaluation
    def joint_matrices(self, q, rot) -> np.ndarray:
        """``A(q)`` of every joint ``(B, njoints, 4, 4)``."""
        B = q.shape[0]
        A = np.empty((B, self.nj, 4, 4))
        A[:] = self._template
        if self.rot_j.size:
            th = q[:, self.rot_q]
            c, s = np.cos(th), np.sin(th)
            rj = self.rot_j
            A[:, rj, 0, 0] = c
            A[:, rj, 0, 1] = -s
            A[:, rj, 1, 0] = s
            A[:, rj, 1, 1] = c
        if self.slide_j.size:
            A[:, self.slide_j, 2, 3] = q[:, self.slide_q] * self.slide_pitch if self.has_pitch \
                else q[:, self.slide_q]
        if self.s_j.size:
            A[:, self.s_j, :3, :3] = rot[:, self.s_rot]
        if self.u_j.size:
            A[:, self.u_j, :3, :3] = _rz(q[:, self.u_q0]) @ self._u_mid[:3, :3] @ \
                _rz(q[:, self.u_q1])
        return A

    def evaluate(self, q, rot, twists: bool = True) -> KinematicState:
        """The kinematic state of states ``q (B, nq)``, ``rot (B, ns, 3, 3)``."""
        B = q.shape[0]
        A = self.joint_matrices(q, rot)
        link = np.empty((B, self.nl, 4, 4))
        link[:, 0] = np.eye(4)
        if self.tree_j.size:
            Ae = A[:, self.tree_j]
            if not self.all_forward:
                b = self.tree_back
                Ae[:, b] = _rigid_inverse(Ae[:, b])
            rel = self.tree_left @ Ae @ self.tree_right
            for k, (ch, par, pos) in enumerate(self.levels):
                link[:, ch] = rel[:, pos] if k == 0 else link[:, par] @ rel[:, pos]
        frame_a = link[:, self.joint_link_a] @ self.frames_a
        ch = self.chords
        if ch.size:
            G = frame_a[:, ch] @ A[:, ch] @ self.chord_fbi @ \
                _rigid_inverse(link[:, self.chord_link_b])
            c = self.centre
            G[..., :3, 3] += G[..., :3, :3] @ c - c
            r = _loop_log(G)
        else:
            r = np.zeros((B, 0, 6))
        S = self.twists(q, frame_a) if twists else None
        return KinematicState(link, frame_a, A, r, S, self.carrier, self.deps)

    def twists(self, q, frame_a) -> np.ndarray:
        """World twists ``(B, nv, 6)`` of the velocity coordinates.

        Every unit twist in its joint frame has one axis in its rotation part and one in
        its translation part (``R``, ``P``, ``C``, ``H`` about or along z, the S joint's
        x, y, z), so ``ω = w_c · R e_k`` and ``v = s_c · R e_j + p × ω``: a gather of
        frame columns instead of a product."""
        Rt = np.swapaxes(frame_a[..., :3, :3], -1, -2)           # rows of Rt: columns of R
        S = np.empty((q.shape[0], self.nv, 6))
        w = Rt[:, self.col_joint, self.kw]                       # (B, nv, 3)
        if self.u_cols.size:                                      # second pin of U joints
            pre = _rz(q[:, self.u_q0]) @ self._u_mid[:3, :3]     # (B, nU, 3, 3)
            w[:, self.u_cols] = (frame_a[:, self.u_j, :3, :3] @ pre[..., 2:3])[..., 0]
        if not self.w_unit:
            w *= self.sw[:, None]
        p = frame_a[..., :3, 3][:, self.col_joint]
        S[..., 3:] = w
        v = S[..., :3]
        v[..., 0] = p[..., 1] * w[..., 2] - p[..., 2] * w[..., 1]
        v[..., 1] = p[..., 2] * w[..., 0] - p[..., 0] * w[..., 2]
        v[..., 2] = p[..., 0] * w[..., 1] - p[..., 1] * w[..., 0]
        if self.v_cols.size:
            v[:, self.v_cols] += Rt[:, self.col_joint[self.v_cols], self.kv[self.v_cols]] * \
                self.sv[self.v_cols, None]
        return S

    def scaled_jacobian(self, S, cols) -> np.ndarray:
        """Dimensionless loop Jacobian ``(B, 6·nloops, len(cols))`` of columns ``cols``:
        twists about the mechanism's centre (``v + ω × c``), translation rows divided by
        the length scale, length columns multiplied by it, one product with the constant
        row map and the loop coefficients."""
        Ss = S[:, cols] @ self.row_map_t                          # (B, k, 6)
        J = np.einsum("lc,bcs->blsc", self.loop_scaled[:, cols], Ss)
        return J.reshape(J.shape[0], -1, len(cols))

    def scaled_residual(self, r) -> np.ndarray:
        """Dimensionless loop residual ``(B, 6·nloops)``."""
        out = r.reshape(r.shape[0], -1).copy()
        if r.shape[1]:
            out.reshape(r.shape)[..., :3] /= self.scale
        return out

    def apply(self, q, rot, dv_scaled):
        """New ``(q, rot)`` from a dimensionless step ``(B, nv)`` over all coordinates."""
        q = q.copy()
        if self.scal_v.size:
            q[:, self.scal_q] += dv_scaled[:, self.scal_v] * self.col_scale[self.scal_v]
        if self.s_cols.size:
            rot = rot.copy()
            rot[:, self.s_order] = _exp_so3(dv_scaled[:, self.s_cols]) @ rot[:, self.s_order]
        else:
            rot = rot.copy()
        return q, rot

    def distance(self, a, b) -> np.ndarray:
        """Dimensionless distance per velocity coordinate between states ``(B, nv)``."""
        out = np.zeros((a[0].shape[0], self.nv))
        if self.scal_v.size:
            out[:, self.scal_v] = (a[0][:, self.scal_q] - b[0][:, self.scal_q]) / \
                self.col_scale[self.scal_v]
        if self.s_cols.size:
            so = self.s_order
            rel = a[1][:, so] @ np.swapaxes(b[1][:, so], -1, -2)
            rl = _rot_log(rel)
            out[:, self.s_cols] = _log_so3(rel) if rl is None else rl[0]
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
