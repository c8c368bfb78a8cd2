"""Compiled kernels of the position solver (numba): kinematic state, loop Jacobian,
minimum-norm steps, damped Newton and continuation, one pose at a time.

Every kernel loops over the members of a batch and treats each on its own (the batched
numpy code they replace decided per member too), so one pose and a batch of 2,048 run the
same instructions and a member's result does not depend on the batch it is in.  The
mechanism's structure comes packed once per compiled tree (:func:`pack`, kept by
:class:`closure.state.Plan`) into three arrays: ``PI`` (int64: counts, then each table's
offset, then the tables: joint kinds, coordinate offsets, the tree's links in BFS order,
the chords, the columns' joints and axes, the inputs and unknowns), ``PF`` (float64:
pitches, centre, scale, the U joint's middle rotation, the row map to dimensionless twists
about the centre, the loop coefficients, the columns' weights and scales) and ``PM``
(the constant 4x4 frames: joints on link a, either side of each tree joint, the chords'
link-b frames inverted).  Three arrays rather than a tuple of forty keep the compiled code
small (every array passed costs code at every call).

The algorithms are those of the numpy code they replace (the same formulas, branch tests
and tolerances, IEEE arithmetic as numpy's: ``error_model="numpy"``), so results agree
with it to rounding:

* :func:`_evaluate` — joint matrices ``A(q)``, link poses through the spanning tree,
  joint frames, loop residual twists (``log`` of the loop transforms about the centre)
  and the world twists of the velocity coordinates (:meth:`closure.state.Plan.evaluate`);
* :func:`_factor`, :func:`_svd_parts`, :func:`_lsq_solve`, :func:`_inv_smin` — the
  pseudo-inverse truncated to the expected rank, by Cholesky of the Gram matrix (``J Jᵀ``
  wide, ``Jᵀ J`` tall) with one step of iterative refinement where the condition
  estimate ``sqrt(‖J‖²_F · tr G⁻¹)`` is at most ``FAST_COND``, by the truncated SVD
  (LAPACK's gesdd, as numpy) elsewhere (:class:`closure.lstsq._LstSq`): singular values
  are computed only for SVD poses (the exact condition numbers asked for later come from
  numpy's SVD without the vectors, :meth:`closure.state.Plan.condition`);
* :func:`drive` — damped Gauss–Newton with backtracking and the fused first analogs
  (:func:`closure.solver.newton`), and the continuation around it: predictor along the
  analogs, corrector, acceptance and step halving (:func:`closure.solver._continue`), for
  a batch of targets or a sweep's rows, each member on its own.

Inside a member the helpers take whole arrays and indices rather than views (a view costs
two atomic reference-count updates, more than a 4x4 product's arithmetic).

numba compiles the kernels on the first solve (``cache=True``: once per installation,
then loaded from the cache); :mod:`closure.state` imports this module when a mechanism is
first compiled, so ``import closure`` does not import numba.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .lstsq import FAST_COND, SINGULAR_RTOL      # constants of the kernels once compiled

__all__ = ["pack", "KIND_CODE", "drive", "evaluate_batch", "twists_batch", "apply_batch",
           "distance_batch", "scaled_jacobian_batch", "lsq_batch", "NEWTON", "CONTINUE",
           "SWEEP"]

_JIT = dict(cache=True, nogil=True, error_model="numpy")

#: joint kind → code used by the kernels
KIND_CODE = {"R": 0, "P": 1, "C": 2, "H": 3, "U": 4, "S": 5}

# PI's header: counts, then the offsets of the tables in PI, PF and PM
(H_NJ, H_NL, H_NC, H_NV,
 O_KIND, O_QOFF, O_SIDX, O_JLA, O_TLI, O_TPL, O_TJ, O_TFWD, O_CJ, O_CLB, O_COLJ, O_KW, O_KV,
 O_UQ0, O_SCALV, O_SCALQ, O_SCOLS, O_SORD, O_INV, O_INQ, O_UNK,
 F_PITCH, F_CENTRE, F_SCALE, F_OFFSET, F_UMID, F_ROWMAP, F_LOOP, F_SW, F_SV, F_COLSC, F_INCS,
 F_INSC, F_UNKCS,
 M_FA, M_TL, M_TR, M_CFBI, HEADER) = range(43)


def pack(plan, mech, tree):
    """The kernels' view of a compiled mechanism: ``(PI, PF, PM)`` (module notes)."""
    joints = mech.joints
    t = tree
    order = list(t.order[1:])
    tree_pl = []
    for li in order:
        j = joints[t.parent_joint[li]]
        tree_pl.append(t.link_index[j.link_a] if t.forward[li] else t.link_index[j.link_b])
    col_uq0 = np.full(t.nv, -1)                 # the U joints' second pins: their φ column
    for j in joints:
        if j.kind == "U":
            col_uq0[t.v_offset[j.index] + 1] = t.q_offset[j.index]
    ints = {O_KIND: [KIND_CODE[j.kind] for j in joints], O_QOFF: t.q_offset,
            O_SIDX: t.s_index, O_JLA: t.joint_link_a, O_TLI: order, O_TPL: tree_pl,
            O_TJ: [t.parent_joint[li] for li in order],
            O_TFWD: [int(t.forward[li]) for li in order], O_CJ: plan.chords,
            O_CLB: plan.chord_link_b, O_COLJ: plan.col_joint, O_KW: plan.kw, O_KV: plan.kv,
            O_UQ0: col_uq0, O_SCALV: plan.scal_v, O_SCALQ: plan.scal_q,
            O_SCOLS: plan.s_cols.reshape(-1), O_SORD: plan.s_order, O_INV: plan.input_v,
            O_INQ: plan.input_q, O_UNK: plan.unknown}
    flts = {F_PITCH: [j.pitch for j in joints], F_CENTRE: t.centre, F_SCALE: [t.scale],
            F_OFFSET: [plan.offset], F_UMID: plan._u_mid[:3, :3].reshape(-1),
            F_ROWMAP: plan.row_map.reshape(-1), F_LOOP: plan.loop_scaled.reshape(-1),
            F_SW: plan.sw, F_SV: plan.sv, F_COLSC: plan.col_scale, F_INCS: plan.input_cscale,
            F_INSC: plan.input_scale, F_UNKCS: plan.unknown_cscale}
    mats = {M_FA: plan.frames_a, M_TL: plan.tree_left, M_TR: plan.tree_right,
            M_CFBI: plan.chord_fbi}
    head = np.zeros(HEADER, dtype=np.int64)
    head[[H_NJ, H_NL, H_NC, H_NV]] = len(joints), len(t.links), len(t.chords), t.nv
    parts, n = [head], HEADER
    for key, v in ints.items():
        v = np.asarray(v, dtype=np.int64).reshape(-1)
        head[key] = n
        parts.append(v)
        n += v.size
    PI = np.concatenate(parts)
    parts, n = [], 0
    for key, v in flts.items():
        v = np.asarray(v, dtype=float).reshape(-1)
        PI[key] = n
        parts.append(v)
        n += v.size
    PF = np.concatenate(parts)
    parts, n = [], 0
    for key, v in mats.items():
        v = np.asarray(v, dtype=float).reshape(-1, 4, 4)
        PI[key] = n
        parts.append(v)
        n += v.shape[0]
    PM = np.ascontiguousarray(np.concatenate(parts))
    return PI, PF, PM


# ---------------------------------------------------------------------- small rigid algebra
# The helpers take whole arrays and indices rather than views: a view costs two atomic
# reference-count updates, several times a 4x4 product's own work.
@numba.njit(**_JIT)
def _rigid_mul(A, ia, B, ib, out, io):
    """``out[io] = A[ia] @ B[ib]`` for rigid transforms (last rows 0 0 0 1; ``out[io]``
    is neither operand)."""
    for i in range(3):
        a0, a1, a2, a3 = A[ia, i, 0], A[ia, i, 1], A[ia, i, 2], A[ia, i, 3]
        for j in range(3):
            out[io, i, j] = a0 * B[ib, 0, j] + a1 * B[ib, 1, j] + a2 * B[ib, 2, j]
        out[io, i, 3] = a0 * B[ib, 0, 3] + a1 * B[ib, 1, 3] + a2 * B[ib, 2, 3] + a3
    out[io, 3, 0] = 0.0
    out[io, 3, 1] = 0.0
    out[io, 3, 2] = 0.0
    out[io, 3, 3] = 1.0


@numba.njit(**_JIT)
def _rigid_inv(T, it, out, io):
    """``out[io] = T[it]⁻¹`` of a rigid transform."""
    for i in range(3):
        for j in range(3):
            out[io, i, j] = T[it, j, i]
    for i in range(3):
        out[io, i, 3] = -(T[it, 0, i] * T[it, 0, 3] + T[it, 1, i] * T[it, 1, 3] +
                          T[it, 2, i] * T[it, 2, 3])
    out[io, 3, 0] = 0.0
    out[io, 3, 1] = 0.0
    out[io, 3, 2] = 0.0
    out[io, 3, 3] = 1.0


@numba.njit(**_JIT)
def _exp_so3(w0, w1, w2, out, io):
    """``out[io]``: the rotation matrix of the rotation vector ``w`` (series near 0, as
    :func:`closure.exp_so3`)."""
    th2 = w0 * w0 + w1 * w1 + w2 * w2
    if th2 < 1e-8:
        a = 1 - th2 / 6 + th2 ** 2 / 120
        b = 0.5 - th2 / 24 + th2 ** 2 / 720
    else:
        th = math.sqrt(th2)
        a = math.sin(th) / th
        b = (1 - math.cos(th)) / th ** 2
    K = ((0.0, -w2, w1), (w2, 0.0, -w0), (-w1, w0, 0.0))
    for i in range(3):
        for j in range(3):
            kk = K[i][0] * K[0][j] + K[i][1] * K[1][j] + K[i][2] * K[2][j]
            out[io, i, j] = (1.0 if i == j else 0.0) + a * K[i][j] + b * kk


@numba.njit(**_JIT)
def _log_so3(R, ir, out):
    """Rotation vector ``out`` (3,) of the rotation ``R[ir, :3, :3]`` at any angle (as
    :func:`closure.frames._log_so3`: past a quarter turn the axis from the symmetric
    part)."""
    v0 = 0.5 * (R[ir, 2, 1] - R[ir, 1, 2])
    v1 = 0.5 * (R[ir, 0, 2] - R[ir, 2, 0])
    v2 = 0.5 * (R[ir, 1, 0] - R[ir, 0, 1])
    s = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    th = math.atan2(s, (R[ir, 0, 0] + R[ir, 1, 1] + R[ir, 2, 2] - 1) / 2)
    if th < 1e-5:
        sc = 1 + th ** 2 / 6 + 7 * th ** 4 / 360
    else:
        sc = th / math.sin(th)
    out[0], out[1], out[2] = v0 * sc, v1 * sc, v2 * sc
    if th > np.pi / 2:
        c = math.cos(th)
        best, k = -np.inf, 0
        for i in range(3):
            d = ((R[ir, i, i] + R[ir, i, i]) / 2 - c) / (1 - c)
            if d > best:
                best, k = d, i
        a0 = ((R[ir, 0, k] + R[ir, k, 0]) / 2 - (c if k == 0 else 0.0)) / (1 - c)
        a1 = ((R[ir, 1, k] + R[ir, k, 1]) / 2 - (c if k == 1 else 0.0)) / (1 - c)
        a2 = ((R[ir, 2, k] + R[ir, k, 2]) / 2 - (c if k == 2 else 0.0)) / (1 - c)
        n = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        a0, a1, a2 = a0 / n, a1 / n, a2 / n
        d = a0 * v0 + a1 * v1 + a2 * v2
        sg = -1.0 if d < 0 else 1.0
        out[0], out[1], out[2] = a0 * sg * th, a1 * sg * th, a2 * sg * th


@numba.njit(**_JIT)
def _rot_log(R, ir, out):
    """Rotation vector ``out`` (3,) of the rotation ``R[ir, :3, :3]`` below a quarter turn
    (as :func:`closure.state._rot_log`); returns ``(θ, θ², sin θ)``, or θ = −1 (``out``
    untouched) when it turns a quarter turn or more."""
    v0 = 0.5 * (R[ir, 2, 1] - R[ir, 1, 2])
    v1 = 0.5 * (R[ir, 0, 2] - R[ir, 2, 0])
    v2 = 0.5 * (R[ir, 1, 0] - R[ir, 0, 1])
    cth = 0.5 * (R[ir, 0, 0] + R[ir, 1, 1] + R[ir, 2, 2] - 1.0)
    if not cth > 0.0:
        return -1.0, 0.0, 0.0
    th = math.atan2(math.sqrt(v0 * v0 + v1 * v1 + v2 * v2), cth)
    th2 = th * th
    s_ = math.sin(th)
    if th2 < 1e-10:
        sc = 1 + th2 / 6 + 7 * th2 * th2 / 360
    else:
        sc = th / s_
    out[0], out[1], out[2] = v0 * sc, v1 * sc, v2 * sc
    return th, th2, s_


@numba.njit(**_JIT)
def _loop_log(G, ig, r, ir, w):
    """``r[ir]``: the twist ``(v, ω)``, ``log`` of the loop transform ``G[ig]`` (as
    :func:`closure.state._loop_log`, with :func:`closure.frames._log_se3` past a quarter
    turn); ``w`` (3,) scratch."""
    th, th2, s_ = _rot_log(G, ig, w)
    if th < 0.0:
        _log_so3(G, ig, w)
        th2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
        if th2 < 1e-8:
            e = 1 / 12 + th2 / 720
        else:
            t = math.sqrt(th2)
            e = (1 - t * math.sin(t) / (2 * (1 - math.cos(t)))) / t ** 2
    elif th2 < 1e-8:
        e = 1 / 12 + th2 / 720
    else:
        e = (1 - th * s_ / (2 * (1 - math.cos(th)))) / th2
    p0, p1, p2 = G[ig, 0, 3], G[ig, 1, 3], G[ig, 2, 3]
    w0, w1, w2 = w[0], w[1], w[2]
    # V⁻¹ p = p − ½ ω × p + e ω × (ω × p)
    c0 = w1 * p2 - w2 * p1
    c1 = w2 * p0 - w0 * p2
    c2 = w0 * p1 - w1 * p0
    d0 = w1 * c2 - w2 * c1
    d1 = w2 * c0 - w0 * c2
    d2 = w0 * c1 - w1 * c0
    r[ir, 0] = p0 - 0.5 * c0 + e * d0
    r[ir, 1] = p1 - 0.5 * c1 + e * d1
    r[ir, 2] = p2 - 0.5 * c2 + e * d2
    r[ir, 3], r[ir, 4], r[ir, 5] = w0, w1, w2


# ---------------------------------------------------------------------- array helpers
@numba.njit(**_JIT)
def _copy(src, dst):
    """``dst[...] = src`` for C-contiguous arrays of one shape (a flat loop: numba's
    broadcasting assignment compiles to far more code)."""
    s, d = src.reshape(src.size), dst.reshape(dst.size)
    for i in range(s.size):
        d[i] = s[i]


@numba.njit(**_JIT)
def _fill(dst, v):
    """``dst[...] = v`` for a C-contiguous array."""
    d = dst.reshape(dst.size)
    for i in range(d.size):
        d[i] = v


# ---------------------------------------------------------------------- kinematic state
@numba.njit(**_JIT)
def _evaluate(PI, PF, PM, q, rot, A, link, fa, r, S, T, w3):
    """The kinematic state of one member: ``A`` (nj, 4, 4), ``link`` (nl, 4, 4), ``fa``
    (nj, 4, 4), ``r`` (nc, 6) and ``S`` (nv, 6) overwritten
    (:meth:`closure.state.Plan.evaluate`); ``T`` (3, 4, 4) and ``w3`` (3,) scratch."""
    nj, nc = PI[H_NJ], PI[H_NC]
    o_kind, o_qoff, o_sidx, o_pitch, o_um = PI[O_KIND], PI[O_QOFF], PI[O_SIDX], PI[F_PITCH], \
        PI[F_UMID]
    # joint matrices
    for j in range(nj):
        for a in range(4):
            for b in range(4):
                A[j, a, b] = 1.0 if a == b else 0.0
        k = PI[o_kind + j]
        qj = PI[o_qoff + j]
        if k == 0 or k == 2 or k == 3:                 # R, C, H: Rz(θ)
            c, s = math.cos(q[qj]), math.sin(q[qj])
            A[j, 0, 0], A[j, 0, 1], A[j, 1, 0], A[j, 1, 1] = c, -s, s, c
            if k == 2:
                A[j, 2, 3] = q[qj + 1]
            elif k == 3:
                A[j, 2, 3] = q[qj] * PF[o_pitch + j]
        elif k == 1:                                    # P: Tz(s)
            A[j, 2, 3] = q[qj]
        elif k == 5:                                    # S: the rotation
            si = PI[o_sidx + j]
            for a in range(3):
                for b in range(3):
                    A[j, a, b] = rot[si, a, b]
        else:                                           # U: Rz(φ) Ry(π/2) Rz(θ)
            c, s = math.cos(q[qj]), math.sin(q[qj])
            c2, s2 = math.cos(q[qj + 1]), math.sin(q[qj + 1])
            for b in range(3):                          # Rz(φ) umid into T[0, :3, :3]
                T[0, 0, b] = c * PF[o_um + b] - s * PF[o_um + 3 + b]
                T[0, 1, b] = s * PF[o_um + b] + c * PF[o_um + 3 + b]
                T[0, 2, b] = PF[o_um + 6 + b]
            for a in range(3):                          # ... Rz(θ)
                A[j, a, 0] = T[0, a, 0] * c2 + T[0, a, 1] * s2
                A[j, a, 1] = T[0, a, 0] * -s2 + T[0, a, 1] * c2
                A[j, a, 2] = T[0, a, 2]
    # links through the tree, parents first: T_link = T_parent (left A^±1 right)
    for a in range(4):
        for b in range(4):
            link[0, a, b] = 1.0 if a == b else 0.0
    o_tli, o_tpl, o_tj, o_tfwd = PI[O_TLI], PI[O_TPL], PI[O_TJ], PI[O_TFWD]
    m_tl, m_tr = PI[M_TL], PI[M_TR]
    for k in range(PI[H_NL] - 1):
        j = PI[o_tj + k]
        if PI[o_tfwd + k]:
            _rigid_mul(PM, m_tl + k, A, j, T, 0)
        else:
            _rigid_inv(A, j, T, 1)
            _rigid_mul(PM, m_tl + k, T, 1, T, 0)
        li, pl = PI[o_tli + k], PI[o_tpl + k]
        if pl == 0:
            _rigid_mul(T, 0, PM, m_tr + k, link, li)
        else:
            _rigid_mul(T, 0, PM, m_tr + k, T, 1)
            _rigid_mul(link, pl, T, 1, link, li)
    o_jla, m_fa = PI[O_JLA], PI[M_FA]
    for j in range(nj):
        _rigid_mul(link, PI[o_jla + j], PM, m_fa + j, fa, j)
    # loops: G = F_a A F_b⁻¹ T_b⁻¹ about the centre, and its log
    o_cj, o_clb, m_cf, o_c = PI[O_CJ], PI[O_CLB], PI[M_CFBI], PI[F_CENTRE]
    c0, c1, c2 = PF[o_c], PF[o_c + 1], PF[o_c + 2]
    for k in range(nc):
        c = PI[o_cj + k]
        _rigid_mul(fa, c, A, c, T, 0)
        _rigid_mul(T, 0, PM, m_cf + k, T, 1)
        _rigid_inv(link, PI[o_clb + k], T, 0)
        _rigid_mul(T, 1, T, 0, T, 2)
        for a in range(3):
            T[2, a, 3] += (T[2, a, 0] * c0 + T[2, a, 1] * c1 + T[2, a, 2] * c2) - PF[o_c + a]
        _loop_log(T, 2, r, k, w3)
    _twists(PI, PF, q, fa, S)


@numba.njit(**_JIT)
def _twists(PI, PF, q, fa, S):
    """World twists ``S`` (nv, 6) of the velocity coordinates from the joint frames ``fa``:
    ``ω = s_w R e_kw`` (a U joint's second pin: ``R Rz(φ) umid e_z``), ``v = p × ω +
    s_v R e_kv`` (:meth:`closure.state.Plan.twists`)."""
    o_colj, o_kw, o_kv, o_uq0 = PI[O_COLJ], PI[O_KW], PI[O_KV], PI[O_UQ0]
    o_sw, o_sv, o_um = PI[F_SW], PI[F_SV], PI[F_UMID]
    u02, u12, u22 = PF[o_um + 2], PF[o_um + 5], PF[o_um + 8]
    for ci in range(PI[H_NV]):
        j = PI[o_colj + ci]
        u = PI[o_uq0 + ci]
        if u >= 0:
            c, s = math.cos(q[u]), math.sin(q[u])
            e0 = c * u02 - s * u12
            e1 = s * u02 + c * u12
            e2 = u22
            w0 = fa[j, 0, 0] * e0 + fa[j, 0, 1] * e1 + fa[j, 0, 2] * e2
            w1 = fa[j, 1, 0] * e0 + fa[j, 1, 1] * e1 + fa[j, 1, 2] * e2
            w2 = fa[j, 2, 0] * e0 + fa[j, 2, 1] * e1 + fa[j, 2, 2] * e2
        else:
            a = PI[o_kw + ci]
            w0, w1, w2 = fa[j, 0, a], fa[j, 1, a], fa[j, 2, a]
        sw = PF[o_sw + ci]
        if sw != 1.0:
            w0, w1, w2 = w0 * sw, w1 * sw, w2 * sw
        p0, p1, p2 = fa[j, 0, 3], fa[j, 1, 3], fa[j, 2, 3]
        S[ci, 3], S[ci, 4], S[ci, 5] = w0, w1, w2
        v0 = p1 * w2 - p2 * w1
        v1 = p2 * w0 - p0 * w2
        v2 = p0 * w1 - p1 * w0
        sv = PF[o_sv + ci]
        if sv != 0.0:
            a = PI[o_kv + ci]
            v0 += fa[j, 0, a] * sv
            v1 += fa[j, 1, a] * sv
            v2 += fa[j, 2, a] * sv
        S[ci, 0], S[ci, 1], S[ci, 2] = v0, v1, v2


@numba.njit(**_JIT)
def _scaled_residual(r, scale, out):
    """Dimensionless loop residual (translations / scale) into ``out``; returns its largest
    absolute entry (0 without loops)."""
    big = 0.0
    for k in range(r.shape[0]):
        for s in range(6):
            v = r[k, s] / scale if s < 3 else r[k, s]
            out[6 * k + s] = v
            if abs(v) > big or v != v:
                big = abs(v)
    return big


@numba.njit(**_JIT)
def _scaled_jacobian(PI, PF, S, cols, J):
    """Dimensionless loop Jacobian ``J`` (6·nloops, len(cols)) of columns ``cols``: the
    twists about the centre with translations / scale (the row map), times the loop
    coefficients with length columns × scale."""
    nc, nv, o_rm, o_lp = PI[H_NC], PI[H_NV], PI[F_ROWMAP], PI[F_LOOP]
    for k in range(cols.shape[0]):
        c = cols[k]
        for s in range(6):
            v = 0.0
            for t in range(6):
                v += S[c, t] * PF[o_rm + 6 * s + t]
            for lp in range(nc):
                J[6 * lp + s, k] = PF[o_lp + nv * lp + c] * v


@numba.njit(**_JIT)
def _apply(PI, PF, q, rot, dv, q_out, rot_out, R3):
    """New ``(q, rot)`` from a dimensionless step ``dv`` (nv) over all coordinates;
    ``R3`` (1, 3, 3) scratch."""
    o_v, o_q, o_cs = PI[O_SCALV], PI[O_SCALQ], PI[F_COLSC]
    o_sc, o_so = PI[O_SCOLS], PI[O_SORD]
    for i in range(q.shape[0]):
        q_out[i] = q[i]
    for i in range(PI[O_SCALQ] - PI[O_SCALV]):
        v, qi = PI[o_v + i], PI[o_q + i]
        q_out[qi] = q[qi] + dv[v] * PF[o_cs + v]
    for k in range(PI[O_INV] - PI[O_SORD]):
        _exp_so3(dv[PI[o_sc + 3 * k]], dv[PI[o_sc + 3 * k + 1]], dv[PI[o_sc + 3 * k + 2]],
                 R3, 0)
        si = PI[o_so + k]
        for a in range(3):
            for b in range(3):
                rot_out[si, a, b] = R3[0, a, 0] * rot[si, 0, b] + R3[0, a, 1] * rot[si, 1, b] + \
                    R3[0, a, 2] * rot[si, 2, b]


@numba.njit(**_JIT)
def _distance(PI, PF, qa, rota, qb, rotb, out, R3, w3):
    """Dimensionless distance per velocity coordinate between two states into ``out``
    (nv) (:meth:`closure.state.Plan.distance`); returns its largest absolute entry;
    ``R3`` (1, 3, 3) and ``w3`` (3,) scratch."""
    o_v, o_q, o_cs = PI[O_SCALV], PI[O_SCALQ], PI[F_COLSC]
    o_sc, o_so = PI[O_SCOLS], PI[O_SORD]
    for c in range(out.shape[0]):
        out[c] = 0.0
    for i in range(PI[O_SCALQ] - PI[O_SCALV]):
        v, qi = PI[o_v + i], PI[o_q + i]
        out[v] = (qa[qi] - qb[qi]) / PF[o_cs + v]
    for k in range(PI[O_INV] - PI[O_SORD]):
        si = PI[o_so + k]
        for a in range(3):
            for b in range(3):
                R3[0, a, b] = rota[si, a, 0] * rotb[si, b, 0] + rota[si, a, 1] * rotb[si, b, 1] + \
                    rota[si, a, 2] * rotb[si, b, 2]
        th, _, _ = _rot_log(R3, 0, w3)
        if th < 0.0:
            _log_so3(R3, 0, w3)
        for a in range(3):
            out[PI[o_sc + 3 * k + a]] = w3[a]
    big = 0.0
    for c in range(out.shape[0]):
        d = abs(out[c])
        if d > big or d != d:
            big = d
    return big


# ---------------------------------------------------------------------- least squares
@numba.njit(**_JIT)
def _factor(J, rank, G, L, Linv, Ginv):
    """Cholesky path of the minimum-norm solve of ``J`` (m, n) truncated to ``rank``:
    the Gram matrix ``G`` (``J Jᵀ`` wide, ``Jᵀ J`` tall) factored, ``Ginv = G⁻¹``.

    Returns ``(fast, sqrt(tr G⁻¹))``; ``fast`` is False (the SVD path) when the expected
    rank is below ``min(m, n)``, the factorisation fails or the condition estimate
    ``sqrt(‖J‖²_F · tr G⁻¹)`` (≥ s_max / s_min) exceeds ``FAST_COND``."""
    m, n = J.shape
    k = min(m, n)
    if k == 0 or min(rank, k) != k:
        return False, 0.0
    if m < n:                                           # wide: G = J Jᵀ
        for i in range(k):
            for j in range(i + 1):
                s = 0.0
                for t in range(n):
                    s += J[i, t] * J[j, t]
                G[i, j] = s
    else:                                               # tall: G = Jᵀ J, row by row
        for i in range(k):
            for j in range(i + 1):
                G[i, j] = 0.0
        for t in range(m):
            for i in range(k):
                a = J[t, i]
                for j in range(i + 1):
                    G[i, j] += a * J[t, j]
    for i in range(k):
        for j in range(i):
            G[j, i] = G[i, j]
    for j in range(k):                                  # G = L Lᵀ
        d = G[j, j]
        for t in range(j):
            d -= L[j, t] * L[j, t]
        if not d > 0.0:
            return False, 0.0
        d = math.sqrt(d)
        L[j, j] = d
        for i in range(j + 1, k):
            s = G[i, j]
            for t in range(j):
                s -= L[i, t] * L[j, t]
            L[i, j] = s / d
    tr_inv = 0.0
    for j in range(k):                                  # L⁻¹, lower triangular
        Linv[j, j] = 1.0 / L[j, j]
        for i in range(j + 1, k):
            s = 0.0
            for t in range(j, i):
                s -= L[i, t] * Linv[t, j]
            Linv[i, j] = s / L[i, i]
        for i in range(j, k):
            tr_inv += Linv[i, j] * Linv[i, j]
    jj = 0.0
    for i in range(m):
        for j in range(n):
            jj += J[i, j] * J[i, j]
    cest = math.sqrt(jj * tr_inv)
    if not cest <= FAST_COND:
        return False, 0.0
    for i in range(k):                                  # G⁻¹ = L⁻ᵀ L⁻¹
        for j in range(i + 1):
            s = 0.0
            for t in range(i, k):
                s += Linv[t, i] * Linv[t, j]
            Ginv[i, j] = s
            Ginv[j, i] = s
    return True, math.sqrt(tr_inv)


@numba.njit(**_JIT)
def _cond_of(s, rank):
    """``s_max / s_rank`` of singular values ``s`` (inf where ``s_rank`` is 0)."""
    rk = min(rank, s.shape[0])
    srank = s[rk - 1] if rk > 0 else 1.0
    if srank > 0:
        return s[0] / srank
    return np.inf


@numba.njit(**_JIT)
def _svd_parts(J, rank, U, inv_s, Vt):
    """Truncated SVD of ``J`` (m, n): into ``U`` (m, k), ``inv_s`` (k), ``Vt`` (k, n) the
    ``rank`` largest singular values above ``SINGULAR_RTOL`` times the largest inverted,
    the others dropped.  Returns ``(s_max / s_rank, 1 / s_min kept)``; ``(1, 0)`` for an
    empty ``J``."""
    m, n = J.shape
    k = min(m, n)
    if k == 0:
        return 1.0, 0.0
    Uf, s, Vtf = np.linalg.svd(J, full_matrices=False)
    rk = min(rank, k)
    big = 0.0
    for i in range(k):
        if i < rk and s[i] > SINGULAR_RTOL * s[0] and s[i] > 1e-300:
            inv_s[i] = 1.0 / s[i]
        else:
            inv_s[i] = 0.0
        if inv_s[i] > big:
            big = inv_s[i]
        for a in range(m):
            U[a, i] = Uf[a, i]
        for b in range(n):
            Vt[i, b] = Vtf[i, b]
    return _cond_of(s, rank), big


@numba.njit(**_JIT)
def _lsq_solve(J, fast, Ginv, U, inv_s, Vt, R, X, T1, T2):
    """Minimum-norm ``X`` (n, j) of ``J X = R`` (R: m, j): Cholesky poses with one step of
    iterative refinement, SVD poses by the truncated pseudo-inverse; ``T1`` (k, j) and
    ``T2`` (m, j) scratch."""
    m, n = J.shape
    nr = R.shape[1]
    k = min(m, n)
    if not fast:                        # X = V diag(inv_s) Uᵀ R, rows of U and Vt in turn
        for c in range(nr):
            for i in range(k):
                T1[i, c] = 0.0
            for a in range(m):
                r_ = R[a, c]
                for i in range(k):
                    T1[i, c] += U[a, i] * r_
            for i in range(k):
                T1[i, c] *= inv_s[i]
            for b in range(n):
                X[b, c] = 0.0
            for i in range(k):
                t1 = T1[i, c]
                for b in range(n):
                    X[b, c] += Vt[i, b] * t1
        return
    wide = m < n
    for it in range(2):                 # X = J⁺ R, then X += J⁺ (R − J X)
        for c in range(nr):
            if it == 0:
                for a in range(m):
                    T2[a, c] = R[a, c]
            else:
                for a in range(m):
                    s = 0.0
                    for b in range(n):
                        s += J[a, b] * X[b, c]
                    T2[a, c] = R[a, c] - s
            if wide:                    # Jᵀ (G⁻¹ T2)
                for i in range(k):
                    s = 0.0
                    for a in range(k):
                        s += Ginv[i, a] * T2[a, c]
                    T1[i, c] = s
                for b in range(n):
                    s = 0.0
                    for a in range(m):
                        s += J[a, b] * T1[a, c]
                    X[b, c] = s if it == 0 else X[b, c] + s
            else:                       # G⁻¹ (Jᵀ T2), Jᵀ T2 row by row
                for i in range(k):
                    T1[i, c] = 0.0
                for a in range(m):
                    t2 = T2[a, c]
                    for i in range(k):
                        T1[i, c] += J[a, i] * t2
                for b in range(n):
                    s = 0.0
                    for a in range(k):
                        s += Ginv[b, a] * T1[a, c]
                    X[b, c] = s if it == 0 else X[b, c] + s


@numba.njit(**_JIT)
def _inv_smin(fast, inv0, above, Ginv, M1, M2):
    """1 / (smallest kept singular value): ``inv0`` for SVD poses, and for Cholesky poses
    where ``sqrt(tr G⁻¹)`` is at most ``above``; else the 8th-power trace estimate of
    ``λ_max(G⁻¹)`` (:meth:`closure.lstsq._LstSq.inv_smin`); ``M1``, ``M2`` (k, k)
    scratch."""
    if not fast or not inv0 > above:
        return inv0
    k = Ginv.shape[0]
    lam = inv0 ** 2
    for i in range(k):
        for j in range(k):
            M1[i, j] = Ginv[i, j] / lam
    p = 1.0
    for _ in range(3):                  # λ_max(G⁻¹) ≤ tr(G⁻ᵖ)^(1/p), p = 2, 4, 8
        p *= 2.0
        t = 0.0
        for i in range(k):
            for j in range(k):
                s = 0.0
                for a in range(k):
                    s += M1[i, a] * M1[a, j]
                M2[i, j] = s
            t += M2[i, i]
        lam *= t ** (1.0 / p)
        for i in range(k):
            for j in range(k):
                M1[i, j] = M2[i, j] / t
    return math.sqrt(lam)


@numba.njit(**_JIT)
def _lsq_work(m, n, nr):
    """Scratch of the least-squares kernels for ``J`` (m, n) and ``nr`` right-hand sides:
    ``(G, L, Linv, Ginv, U, inv_s, Vt, M, T1, T2)``."""
    k = min(m, n)
    nr = max(nr, 1)
    return (np.zeros((k, k)), np.zeros((k, k)), np.zeros((k, k)), np.zeros((k, k)),
            np.zeros((m, k)), np.zeros(k), np.zeros((k, n)), np.zeros((k, k)),
            np.zeros((k, nr)), np.zeros((m, nr)))


# ---------------------------------------------------------------------- solver
@numba.njit(**_JIT)
def _lsq(J, rank, W):
    """Factor ``J`` (Cholesky or truncated SVD) into the buffers ``W`` of :func:`_lsq_work`;
    returns ``(fast, cond, inv0)``: ``cond`` NaN on the Cholesky path, ``inv0`` its
    ``sqrt(tr G⁻¹)`` or the SVD's 1 / (smallest kept singular value)."""
    fast, inv0 = _factor(J, rank, W[0], W[1], W[2], W[3])
    if fast:
        return True, np.nan, inv0
    cond, inv0 = _svd_parts(J, rank, W[4], W[5], W[6])
    return False, cond, inv0


@numba.njit(**_JIT)
def _copy_state(a, b):
    """State ``a`` into ``b`` (both ``(q, rot, A, link, frame_a, r, S, first)``)."""
    _copy(a[0], b[0])
    _copy(a[1], b[1])
    _copy(a[2], b[2])
    _copy(a[3], b[3])
    _copy(a[4], b[4])
    _copy(a[5], b[5])
    _copy(a[6], b[6])
    _copy(a[7], b[7])


#: tasks of :func:`drive`
NEWTON, CONTINUE, SWEEP = 0, 1, 2


@numba.njit(**_JIT)
def drive(task, PI, PF, PM, x_from, x_to, q, rot, A, link, fa, r, S, first, res, cond, last,
          its, flag, tangent, have, fopts, maxiter, rank, ucols, icols, x_cur):
    """The position solver over a batch, every member on its own; the state arrays
    ``(B, ...)`` (``q``, ``rot``, ``A``, ``link``, ``fa``, ``r``, ``S``, ``first``) and
    the figures ``res``, ``cond``, ``last`` (the last Newton step), ``its``, ``flag`` are
    updated in place.  ``fopts`` = (xtol, rtol, max_step, path_step, min_step,
    tangent_cond, unused, longest path); ``ucols`` the columns solved for,
    ``icols`` the inputs' (their analogs go to ``first``).

    * ``NEWTON`` (:func:`closure.solver.newton`): damped Gauss–Newton on every member
      from its ``q``, ``rot``; ``flag`` converged (1) or not; the condition of the last
      step's factorisation, or where not converged at the returned state (NaN on the
      Cholesky path).
    * ``CONTINUE`` (:func:`closure.solver._continue`): every solved member walks from
      ``x_from`` to ``x_to`` (B, ni) by predictor along its analogs (``tangent`` (B, nv,
      ni); ``have``: given) and Newton corrector; ``x_cur`` where each stands, ``flag``
      its stop code (0 reached, 3 no assembly, 4 dead point), ``its`` the path's
      iterations.
    * ``SWEEP`` (:func:`closure.solver.sweep`): rows 1, 2 ... from the solved row 0
      (element 0 of every array): row i by continuation from row i − 1 to ``x_to[i]``,
      each row's tangent (``tangent[0]``) handed to the next, until a row stops.

    Newton (:func:`closure.solver.newton`): each iteration factors the dimensionless
    Jacobian of ``ucols`` (:func:`_lsq`), takes the minimum-norm step and the analogs
    (the input columns are extra right-hand sides) from it, stops when the step is below
    ``xtol`` · offset (or below what rounding of the residual explains near a singular
    configuration) and the residual is at rounding level or stopped falling, else caps
    the step at ``max_step`` and backtracks (1, 1/2 ... 1/128) to the first trial that
    does not raise the residual.  Continuation: the predictor's change of any coordinate
    is capped at ``path_step``; a step is accepted when the corrector converges, the
    loops close (``rtol``) and the corrected pose lies within half the predicted step of
    the predictor, else halved down to ``min_step`` (then stop); at a pose whose
    condition exceeds ``tangent_cond`` the previous tangent is kept.

    Returns the number of members (rows) filled, or −(b + 1) when member (row) b's path
    is longer than ``fopts[7]`` (then nothing is done for it)."""
    xtol, rtol, max_step, path_step, min_step, tangent_cond = \
        fopts[0], fopts[1], fopts[2], fopts[3], fopts[4], fopts[5]
    scale, offset = PF[PI[F_SCALE]], PF[PI[F_OFFSET]]
    o_inv, o_unk, o_incs, o_unkcs = PI[O_INV], PI[O_UNK], PI[F_INCS], PI[F_UNKCS]
    o_cs, o_inq, o_insc = PI[F_COLSC], PI[O_INQ], PI[F_INSC]
    floor, xtl, noise = 1e-14 * offset, xtol * offset, 1e-15 * offset
    B, nq = q.shape
    ns, nv, ni = rot.shape[1], first.shape[1], first.shape[2]
    m = 6 * PI[H_NC]
    nu = ucols.shape[0]
    nj, nl, nc = A.shape[1], link.shape[1], r.shape[1]
    # scratch: the corrector's state, the line search's trial, the predicted state
    co = (np.zeros(nq), np.zeros((ns, 3, 3)), np.zeros((nj, 4, 4)), np.zeros((nl, 4, 4)),
          np.zeros((nj, 4, 4)), np.zeros((nc, 6)), np.zeros((nv, 6)), np.zeros((nv, ni)))
    tq, trot, tA, tlink = np.zeros(nq), np.zeros((ns, 3, 3)), np.zeros((nj, 4, 4)), \
        np.zeros((nl, 4, 4))
    tfa, tr, tS = np.zeros((nj, 4, 4)), np.zeros((nc, 6)), np.zeros((nv, 6))
    pq, prot = np.zeros(nq), np.zeros((ns, 3, 3))
    rs, Ju, Jin = np.zeros(m), np.zeros((m, nu)), np.zeros((m, ni))
    R, X, step = np.zeros((m, 1 + ni)), np.zeros((nu, 1 + ni)), np.zeros(nv)
    T, R3, w3 = np.zeros((3, 4, 4)), np.zeros((1, 3, 3)), np.zeros(3)
    W = _lsq_work(m, nu, 1 + ni)
    newf, dx, xt, dv = np.zeros((nv, ni)), np.zeros(ni), np.zeros(ni), np.zeros(nv)
    cq, crot, cA, clink, cfa, cr, cS, cfirst = co
    sweep = task == SWEEP
    newton_only = task == NEWTON
    if sweep:
        _fill(tangent, 0.0)
    n = x_to.shape[0] if sweep else B
    for b in range(1 if sweep else 0, n):
        cur = (q[b], rot[b], A[b], link[b], fa[b], r[b], S[b], first[b])
        if sweep:                       # row b continues from row b − 1
            a = b - 1
            _copy_state((q[a], rot[a], A[a], link[a], fa[a], r[a], S[a], first[a]), cur)
            res[b], cond[b], last[b] = res[a], cond[a], last[a]
            x0, tb, have_b = x_cur[a], tangent[0], b >= 2
        else:
            x0, tb, have_b = x_from[b], tangent[b], have
        x1, xc = x_to[b], x_cur[b]
        # ------------------------------------------------ the path (one pass for NEWTON)
        span_s = 0.0
        for i in range(ni):
            xc[i] = x0[i]
            v = abs((x1[i] - x0[i]) / PF[o_insc + i])
            if v > span_s or v != v:
                span_s = v
        if not newton_only and span_s > fopts[7]:
            return -(b + 1)                     # a path longer than MAX_PATH: refused
        lam, h = 0.0, 1.0
        stop = 0
        path_its = 0
        active = newton_only or span_s > 0
        need = True
        while active:
            big_pred = 0.0
            final = True
            hh = 0.0
            if newton_only:
                _copy(q[b], cq)
                _copy(rot[b], crot)
            else:
                if need:                # the tangent: the analogs at the current pose
                    f = cur[7]
                    miss = False
                    for c in range(nv):
                        for i in range(ni):
                            if f[c, i] != f[c, i]:
                                miss = True
                    if not miss:
                        _copy(f, newf)
                    else:               # not computed with a converged step: computed here
                        _fill(newf, 0.0)
                        for i in range(ni):
                            newf[PI[o_inv + i], i] = 1.0
                        if nu > 0:
                            _scaled_jacobian(PI, PF, cur[6], ucols, Ju)
                            _scaled_jacobian(PI, PF, cur[6], icols, Jin)
                            fast, c_, inv0 = _lsq(Ju, rank, W)
                            for a in range(m):
                                R[a, 0] = 0.0
                                for i in range(ni):
                                    R[a, 1 + i] = Jin[a, i] / PF[o_incs + i]
                            _lsq_solve(Ju, fast, W[3], W[4], W[5], W[6], R, X, W[8], W[9])
                            for k in range(nu):
                                for i in range(ni):
                                    newf[PI[o_unk + k], i] = -X[k, 1 + i] * PF[o_unkcs + k]
                    # at a singular configuration the previous tangent is kept
                    if not (have_b and cond[b] > tangent_cond):
                        _copy(newf, tb)
                    have_b = True
                    need = False
                hh = min(h, 1.0 - lam)
                big = 0.0
                for i in range(ni):
                    dx[i] = x0[i] + (lam + hh) * (x1[i] - x0[i]) - xc[i]
                for c in range(nv):
                    s = 0.0
                    for i in range(ni):
                        s += tb[c, i] * dx[i]
                    v = abs(s / PF[o_cs + c])
                    if v > big or v != v:
                        big = v
                shrink = min(1.0, path_step / max(big, 1e-300))
                hh = hh * shrink
                final = lam + hh >= 1.0
                for i in range(ni):
                    xt[i] = x1[i] if final else xc[i] + dx[i] * shrink
                for c in range(nv):     # predictor: along the tangent to xt
                    s = 0.0
                    for i in range(ni):
                        s += tb[c, i] * (xt[i] - xc[i])
                    dv[c] = s / PF[o_cs + c]
                    v = abs(dv[c])
                    if v > big_pred or v != v:
                        big_pred = v
                _apply(PI, PF, cur[0], cur[1], dv, pq, prot, R3)
                for i in range(ni):
                    pq[PI[o_inq + i]] = xt[i]
                _copy(pq, cq)
                _copy(prot, crot)
            # ------------------------------------------------ Newton on the state co
            _evaluate(PI, PF, PM, cq, crot, cA, clink, cfa, cr, cS, T, w3)
            n_res = _scaled_residual(cr, scale, rs)
            prev = np.inf
            n_its = 0
            done = nu == 0
            n_cond = 1.0
            n_last = np.nan
            _fill(cfirst, np.nan)
            for i in range(ni):
                for c in range(ni):
                    cfirst[PI[o_inv + i], c] = 1.0 if i == c else 0.0
            for _ in range(maxiter if newton_only else min(maxiter, 8)):
                if done:
                    break
                _scaled_jacobian(PI, PF, cS, ucols, Ju)
                _scaled_jacobian(PI, PF, cS, icols, Jin)
                fast, n_cond, inv0 = _lsq(Ju, rank, W)
                n_its += 1
                for a in range(m):
                    R[a, 0] = rs[a]
                    for i in range(ni):
                        R[a, 1 + i] = Jin[a, i] / PF[o_incs + i]
                _lsq_solve(Ju, fast, W[3], W[4], W[5], W[6], R, X, W[8], W[9])
                big = 0.0
                for k in range(nu):
                    v = abs(X[k, 0])
                    if v > big or v != v:
                        big = v
                # converged: the residual at rounding level, or steps of at most xtol
                # that no longer reduce it; near a singular configuration the step must
                # also be what rounding in the residual explains (noise / σ_min)
                stalled = n_its > 1 and n_res > 0.5 * prev
                tol_step = max(xtl, noise * _inv_smin(fast, inv0, xtl / noise, W[3], W[2],
                                                      W[7]))
                conv = big <= tol_step and (n_res <= floor or stalled)
                prev = n_res
                if conv:
                    done = True
                    n_last = big
                    for k in range(nu):
                        for i in range(ni):
                            cfirst[PI[o_unk + k], i] = -X[k, 1 + i] * PF[o_unkcs + k]
                    break
                fac = min(1.0, max_step / max(big, 1e-300))
                _fill(step, 0.0)
                for k in range(nu):
                    step[ucols[k]] = -X[k, 0] * fac
                # backtracking: the longest of 1, 1/2, 1/4 ... not raising the residual
                for hs in range(8):
                    if hs:
                        for c in range(nv):
                            step[c] *= 0.5
                    _apply(PI, PF, cq, crot, step, tq, trot, R3)
                    _evaluate(PI, PF, PM, tq, trot, tA, tlink, tfa, tr, tS, T, w3)
                    rn = _scaled_residual(tr, scale, rs)
                    if rn <= n_res * (1 + 1e-9) or rn < floor or hs == 7:
                        # the trial becomes the current state: swap the buffers
                        cq, tq, crot, trot, cA, tA = tq, cq, trot, crot, tA, cA
                        clink, tlink, cfa, tfa, cr, tr, cS, tS = tlink, clink, tfa, cfa, tr, \
                            cr, tS, cS
                        n_res = rn
                        break
            # ------------------------------------------------ accept or halve
            co = (cq, crot, cA, clink, cfa, cr, cS, cfirst)
            if newton_only:
                _copy_state(co, cur)
                if not done:            # the condition at the state returned
                    _scaled_jacobian(PI, PF, cS, ucols, Ju)
                    n_cond = _lsq(Ju, rank, W)[1]
                res[b], its[b], cond[b], flag[b], last[b] = n_res, n_its, n_cond, done, n_last
                break
            jump = _distance(PI, PF, cq, crot, pq, prot, dv, R3, w3)
            if done and n_res <= rtol and jump <= 0.5 * big_pred:
                _copy_state(co, cur)
                for i in range(ni):
                    xc[i] = xt[i]
                res[b], cond[b], last[b] = n_res, n_cond, n_last
                path_its += n_its
                lam = 1.0 if final else lam + hh
                h = 2.0 * hh
                need = True
                if final:
                    active = False
            else:
                h = 0.5 * hh
                if h * span_s < min_step:
                    stop = 3 if (done and n_res > rtol) else 4
                    active = False
        if not newton_only:
            its[b], flag[b] = path_its, stop
            if sweep and stop:
                return b + 1
    return n


@numba.njit(**_JIT)
def evaluate_batch(PI, PF, PM, q, rot, A, link, fa, r, S):
    """:func:`_evaluate` for every member of a batch."""
    T, w3 = np.zeros((3, 4, 4)), np.zeros(3)
    for b in range(q.shape[0]):
        _evaluate(PI, PF, PM, q[b], rot[b], A[b], link[b], fa[b], r[b], S[b], T, w3)


@numba.njit(**_JIT)
def twists_batch(PI, PF, q, fa, S):
    """:func:`_twists` for every member of a batch."""
    for b in range(q.shape[0]):
        _twists(PI, PF, q[b], fa[b], S[b])


@numba.njit(**_JIT)
def apply_batch(PI, PF, q, rot, dv, q_out, rot_out):
    """:func:`_apply` for every member of a batch."""
    R3 = np.zeros((1, 3, 3))
    for b in range(q.shape[0]):
        _apply(PI, PF, q[b], rot[b], dv[b], q_out[b], rot_out[b], R3)


@numba.njit(**_JIT)
def distance_batch(PI, PF, qa, rota, qb, rotb, out):
    """:func:`_distance` for every member of a batch."""
    R3, w3 = np.zeros((1, 3, 3)), np.zeros(3)
    for b in range(qa.shape[0]):
        _distance(PI, PF, qa[b], rota[b], qb[b], rotb[b], out[b], R3, w3)


@numba.njit(**_JIT)
def scaled_jacobian_batch(PI, PF, S, cols, J):
    """:func:`_scaled_jacobian` for every member of a batch."""
    for b in range(S.shape[0]):
        _scaled_jacobian(PI, PF, S[b], cols, J[b])


@numba.njit(**_JIT)
def lsq_batch(task, J, rank, fast, cond, inv0, Ginv, U, inv_s, Vt, R, X, above):
    """The least squares over a batch (:class:`closure.lstsq._LstSq`): task 0 factors
    every ``J`` (Cholesky or truncated SVD; ``fast``, ``cond``, ``inv0`` and the factors
    out), 1 solves ``J X = R`` with those factors, 2 puts 1 / s_min (the estimate above
    ``above``) into ``cond``."""
    B, m, n = J.shape
    W = _lsq_work(m, n, R.shape[2])
    for b in range(B):
        if task == 0:
            fast[b], cond[b], inv0[b] = _lsq(J[b], rank, W)
            if fast[b]:
                _copy(W[3], Ginv[b])
            else:
                _copy(W[4], U[b])
                _copy(W[5], inv_s[b])
                _copy(W[6], Vt[b])
        elif task == 1:
            _lsq_solve(J[b], fast[b], Ginv[b], U[b], inv_s[b], Vt[b], R[b], X[b], W[8], W[9])
        else:
            cond[b] = _inv_smin(fast[b], inv0[b], above, Ginv[b], W[2], W[7])

