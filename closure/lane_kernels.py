"""Lane forms of the solver's kernels: the same arithmetic for up to :data:`LANES` members
at once, each member's values in one lane of a trailing axis.

:mod:`closure.solve_kernels` evaluates one member at a time: its loops run over the
mechanism's structure (joints, links, loops, columns), a few iterations each, with the
structure's tables read and its branches taken per member.  Members of one mechanism share
that structure, so here every per-member array gets a trailing lane axis (``q`` (nq, L),
``link`` (nl, 4, 4, L), ``S`` (nv, 6, L), ``J`` (m, n, L) ...) and every statement of the
one-member kernel becomes a loop over the lanes, innermost, of the same arithmetic: the
structure is read once per block of members, and the compiler turns the lane loops into
SIMD instructions.  Results are those of the one-member kernels bit for bit (the same
operations in the same order, no fast-math; ``sin`` and ``cos`` from the kernels' own
series, :func:`closure.solve_kernels._sincos`, vectorised like the rest, ``atan2`` from
the same libm in a lane loop of its own), which the tests check.

Where a member leaves the common path its lane is flagged and the caller takes the
one-member kernel for it: a loop transform turning a quarter turn or more (the rotation's
log from its symmetric part, :func:`closure.solve_kernels._loop_log`: :func:`evaluate`
does it per lane itself), a Gram matrix without a Cholesky factor or whose condition
estimate exceeds ``FAST_COND`` (:func:`factor`: the truncated SVD).

:func:`closure.dynamics_kernels.stage` (batched forward dynamics' right-hand side, task
``RHS`` for B members) runs the solver's Newton and the terms on blocks of :data:`LANES`
members with these kernels.

The kernels are compiled with LLVM's ``noalias`` on their array arguments (numba's flag of
that name, otherwise set only for parallel loops): without it the compiler must assume a
store to one array may change another and does not vectorise the lane loops.  Every
caller passes distinct arrays.
"""
from __future__ import annotations

import math

import numba
import numpy as np
from numba.core.compiler import Compiler

from .lstsq import FAST_COND
from .solve_kernels import (_JIT, F_CENTRE, F_COLSC, F_LOOP, F_PITCH, F_ROWMAP, F_SV, F_SW,
                            F_UMID, H_NC, H_NJ, H_NL, H_NV, M_CFBI, M_FA, M_TL, M_TR, O_CJ,
                            O_CLB, O_COLJ, O_INV, O_JLA, O_KIND, O_KV, O_KW, O_QOFF, O_SCALQ,
                            O_SCALV, O_SCOLS, O_SIDX, O_SORD, O_TFWD, O_TJ, O_TLI, O_TPL,
                            O_UQ0, SINCOS_REDUCED, _exp_so3, _loop_log, _rigid, _rigid_inv,
                            _rigid_mul, _sincos_reduced)

__all__ = ["LANES", "evaluate", "residual", "apply", "jacobian", "factor", "solve", "lane_state"]

#: lanes per block (the trailing axis of every lane array): more lanes spread each block's
#: scalar work (the structure's tables, loop control, libm's atan2 loop) over more members;
#: a whole B = 1,000 four-bar run took 1.29x the time with 8 lanes, 0.88-0.90x with 32 and
#: 0.88x with 64 against 16 (paired runs)
LANES = 64


class _NoAliasCompiler(Compiler):
    """numba's default pipeline with ``noalias`` on every array argument (module notes)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.state.flags.noalias = True


_LJIT = dict(_JIT, pipeline_class=_NoAliasCompiler)


@numba.njit(inline="always", **_JIT)
def _rigid_l(T, it, l):
    """:func:`closure.solve_kernels._rigid` of lane ``l``: the top rows of ``T[it, ..., l]``."""
    return (T[it, 0, 0, l], T[it, 0, 1, l], T[it, 0, 2, l], T[it, 0, 3, l],
            T[it, 1, 0, l], T[it, 1, 1, l], T[it, 1, 2, l], T[it, 1, 3, l],
            T[it, 2, 0, l], T[it, 2, 1, l], T[it, 2, 2, l], T[it, 2, 3, l])


@numba.njit(inline="always", **_JIT)
def _rigid_put_l(t, out, io, l):
    """:func:`closure.solve_kernels._rigid_put` into lane ``l`` of ``out[io]``."""
    out[io, 0, 0, l], out[io, 0, 1, l], out[io, 0, 2, l], out[io, 0, 3, l] = \
        t[0], t[1], t[2], t[3]
    out[io, 1, 0, l], out[io, 1, 1, l], out[io, 1, 2, l], out[io, 1, 3, l] = \
        t[4], t[5], t[6], t[7]
    out[io, 2, 0, l], out[io, 2, 1, l], out[io, 2, 2, l], out[io, 2, 3, l] = \
        t[8], t[9], t[10], t[11]
    out[io, 3, 0, l], out[io, 3, 1, l], out[io, 3, 2, l], out[io, 3, 3, l] = \
        0.0, 0.0, 0.0, 1.0


@numba.njit(inline="always", **_JIT)
def _sincos_beyond(x, s, c, LN):
    """The lanes of ``x`` (L,) at or beyond ``SINCOS_REDUCED`` (or not finite) get libm's
    ``s``, ``c`` (:func:`closure.solve_kernels._sincos`)."""
    for l in range(LN):
        if not abs(x[l]) < SINCOS_REDUCED:
            s[l], c[l] = math.sin(x[l]), math.cos(x[l])


@numba.njit(**_JIT)
def lane_state(nq, ns, nj, nl, nc, nv):
    """A block's state and scratch for :func:`evaluate`: ``(q (nq, L), rot (ns, 3, 3, L),
    link (nl, 4, 4, L), r (nc, 6, L), S (nv, 6, L))``."""
    L = LANES
    return (np.zeros((nq, L)), np.zeros((ns, 3, 3, L)), np.zeros((nl, 4, 4, L)),
            np.zeros((nc, 6, L)), np.zeros((nv, 6, L)))


@numba.njit(**_LJIT)
def evaluate(PI, PF, PM, q, rot, link, r, S, A, fa, T, Tg, tmp, T1, r1, w3, LN):
    """:func:`closure.solve_kernels._evaluate` of lanes ``0 .. LN − 1``: ``link``, ``r``,
    ``S`` overwritten from ``q`` (nq, L) and ``rot`` (ns, 3, 3, L); ``A``, ``fa`` (nj, 4,
    4, L), ``T`` (3, 4, 4, L), ``Tg`` (1, 4, 4, L), ``tmp`` (8, L) scratch, and ``T1`` (3,
    4, 4), ``r1`` (1, 6), ``w3`` (3,) the one-member scratch of the loop's log past a
    quarter turn.  The joint matrices, the tree's products and the loop transform are
    formed in lane loops that read and write different arrays: the compiler vectorises a
    lane loop only where it can tell its stores from its loads (``noalias`` holds between
    arrays, not within one)."""
    nj, nc = PI[H_NJ], PI[H_NC]
    o_kind, o_qoff, o_sidx, o_pitch, o_um = PI[O_KIND], PI[O_QOFF], PI[O_SIDX], \
        PI[F_PITCH], PI[F_UMID]
    for j in range(nj):                                 # joint matrices (rows 0-2 read)
        k = PI[o_kind + j]
        qj = PI[o_qoff + j]
        if k == 0 or k == 2 or k == 3:                  # R, C, H: Rz(θ), z 0 / d / θ p
            for l in range(LN):
                tmp[1, l], tmp[0, l] = _sincos_reduced(q[qj, l])
            _sincos_beyond(q[qj], tmp[1], tmp[0], LN)
            if k == 0:
                for l in range(LN):
                    tmp[2, l] = 0.0
            elif k == 2:
                for l in range(LN):
                    tmp[2, l] = q[qj + 1, l]
            else:
                p = PF[o_pitch + j]
                for l in range(LN):
                    tmp[2, l] = q[qj, l] * p
            for l in range(LN):
                c, s = tmp[0, l], tmp[1, l]
                _rigid_put_l((c, -s, 0.0, 0.0, s, c, 0.0, 0.0, 0.0, 0.0, 1.0, tmp[2, l]), A, j,
                             l)
            continue
        for a in range(4):
            for b in range(4):
                v = 1.0 if a == b else 0.0
                for l in range(LN):
                    A[j, a, b, l] = v
        if k == 1:                                      # P: Tz(s)
            for l in range(LN):
                A[j, 2, 3, l] = q[qj, l]
        elif k == 5:                                    # S: the rotation
            si = PI[o_sidx + j]
            for a in range(3):
                for b in range(3):
                    for l in range(LN):
                        A[j, a, b, l] = rot[si, a, b, l]
        else:                                           # U: Rz(φ) Ry(π/2) Rz(θ)
            for l in range(LN):
                tmp[1, l], tmp[0, l] = _sincos_reduced(q[qj, l])
                tmp[3, l], tmp[2, l] = _sincos_reduced(q[qj + 1, l])
            _sincos_beyond(q[qj], tmp[1], tmp[0], LN)
            _sincos_beyond(q[qj + 1], tmp[3], tmp[2], LN)
            for b in range(3):
                u0, u1, u2 = PF[o_um + b], PF[o_um + 3 + b], PF[o_um + 6 + b]
                for l in range(LN):
                    c, s = tmp[0, l], tmp[1, l]
                    T[0, 0, b, l] = c * u0 - s * u1
                    T[0, 1, b, l] = s * u0 + c * u1
                    T[0, 2, b, l] = u2
            for a in range(3):
                for l in range(LN):
                    c2, s2 = tmp[2, l], tmp[3, l]
                    A[j, a, 0, l] = T[0, a, 0, l] * c2 + T[0, a, 1, l] * s2
                    A[j, a, 1, l] = T[0, a, 0, l] * -s2 + T[0, a, 1, l] * c2
                    A[j, a, 2, l] = T[0, a, 2, l]
    for a in range(4):                                  # links through the tree
        for b in range(4):
            v = 1.0 if a == b else 0.0
            for l in range(LN):
                link[0, a, b, l] = v
    o_tli, o_tpl, o_tj, o_tfwd = PI[O_TLI], PI[O_TPL], PI[O_TJ], PI[O_TFWD]
    m_tl, m_tr = PI[M_TL], PI[M_TR]
    for k in range(PI[H_NL] - 1):
        tj, li, pl = PI[o_tj + k], PI[o_tli + k], PI[o_tpl + k]
        tl, tr = _rigid(PM, m_tl + k), _rigid(PM, m_tr + k)
        # the joint's part into T[0], the parent link's pose into T[1], then their product:
        # no loop both reads and writes one array (the compiler would not vectorise it)
        if PI[o_tfwd + k]:
            for l in range(LN):
                _rigid_put_l(_rigid_mul(_rigid_mul(tl, _rigid_l(A, tj, l)), tr), T, 0, l)
        else:
            for l in range(LN):
                _rigid_put_l(_rigid_mul(_rigid_mul(tl, _rigid_inv(_rigid_l(A, tj, l))), tr),
                             T, 0, l)
        if pl != 0:
            for l in range(LN):
                _rigid_put_l(_rigid_l(link, pl, l), T, 1, l)
            for l in range(LN):
                _rigid_put_l(_rigid_mul(_rigid_l(T, 1, l), _rigid_l(T, 0, l)), link, li, l)
        else:
            for l in range(LN):
                _rigid_put_l(_rigid_l(T, 0, l), link, li, l)
    o_jla, m_fa = PI[O_JLA], PI[M_FA]
    for j in range(nj):                                 # joint frames on link a
        la = PI[o_jla + j]
        f = _rigid(PM, m_fa + j)
        if la == 0:
            for l in range(LN):
                _rigid_put_l(f, fa, j, l)
        else:
            for l in range(LN):
                _rigid_put_l(_rigid_mul(_rigid_l(link, la, l), f), fa, j, l)
    # loops: G = F_a A F_b⁻¹ T_b⁻¹ about the centre, and its log
    o_cj, o_clb, m_cf, o_c = PI[O_CJ], PI[O_CLB], PI[M_CFBI], PI[F_CENTRE]
    c0, c1, c2 = PF[o_c], PF[o_c + 1], PF[o_c + 2]
    for k in range(nc):
        c = PI[o_cj + k]
        cf = _rigid(PM, m_cf + k)
        lb = PI[o_clb + k]
        for l in range(LN):                             # in three loops, each vectorised
            _rigid_put_l(_rigid_mul(_rigid_mul(_rigid_l(fa, c, l), _rigid_l(A, c, l)), cf),
                         Tg, 0, l)
        for l in range(LN):
            g00, g01, g02, g03, g10, g11, g12, g13, g20, g21, g22, g23 = \
                _rigid_mul(_rigid_l(Tg, 0, l), _rigid_inv(_rigid_l(link, lb, l)))
            g03 += (g00 * c0 + g01 * c1 + g02 * c2) - c0
            g13 += (g10 * c0 + g11 * c1 + g12 * c2) - c1
            g23 += (g20 * c0 + g21 * c1 + g22 * c2) - c2
            _rigid_put_l((g00, g01, g02, g03, g10, g11, g12, g13, g20, g21, g22, g23), T, 2,
                         l)
        for l in range(LN):
            g00, g01, g02, g03, g10, g11, g12, g13, g20, g21, g22, g23 = _rigid_l(T, 2, l)
            v0 = 0.5 * (g21 - g12)                      # _rot_log
            v1 = 0.5 * (g02 - g20)
            v2 = 0.5 * (g10 - g01)
            tmp[0, l], tmp[1, l], tmp[2, l] = v0, v1, v2
            tmp[3, l] = 0.5 * (g00 + g11 + g22 - 1.0)
            tmp[4, l] = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
        for l in range(LN):
            tmp[4, l] = math.atan2(tmp[4, l], tmp[3, l])
        for l in range(LN):                             # θ in [0, π/2]: no libm needed
            tmp[5, l], tmp[6, l] = _sincos_reduced(tmp[4, l])
        for l in range(LN):
            th, s_ = tmp[4, l], tmp[5, l]
            th2 = th * th
            sc = 1 + th2 / 6 + 7 * th2 * th2 / 360 if th2 < 1e-10 else th / s_
            w0, w1, w2 = tmp[0, l] * sc, tmp[1, l] * sc, tmp[2, l] * sc
            e = 1 / 12 + th2 / 720 if th2 < 1e-8 else \
                (1 - th * s_ / (2 * (1 - tmp[6, l]))) / th2
            p0, p1, p2 = T[2, 0, 3, l], T[2, 1, 3, l], T[2, 2, 3, l]
            # V⁻¹ p = p − ½ ω × p + e ω × (ω × p)
            x0 = w1 * p2 - w2 * p1
            x1 = w2 * p0 - w0 * p2
            x2 = w0 * p1 - w1 * p0
            y0 = w1 * x2 - w2 * x1
            y1 = w2 * x0 - w0 * x2
            y2 = w0 * x1 - w1 * x0
            r[k, 0, l] = p0 - 0.5 * x0 + e * y0
            r[k, 1, l] = p1 - 0.5 * x1 + e * y1
            r[k, 2, l] = p2 - 0.5 * x2 + e * y2
            r[k, 3, l], r[k, 4, l], r[k, 5, l] = w0, w1, w2
        for l in range(LN):                             # a quarter turn or more: one lane
            if not tmp[3, l] > 0.0:
                for a in range(4):
                    for b in range(4):
                        T1[2, a, b] = T[2, a, b, l]
                _loop_log(T1, np.int64(2), r1, np.int64(0), w3)
                for s in range(6):
                    r[k, s, l] = r1[0, s]
    # twists (closure.solve_kernels._twists)
    o_colj, o_kw, o_kv, o_uq0 = PI[O_COLJ], PI[O_KW], PI[O_KV], PI[O_UQ0]
    o_sw, o_sv = PI[F_SW], PI[F_SV]
    u02, u12, u22 = PF[o_um + 2], PF[o_um + 5], PF[o_um + 8]
    for ci in range(PI[H_NV]):
        j, u = PI[o_colj + ci], PI[o_uq0 + ci]
        sw, sv, kv = PF[o_sw + ci], PF[o_sv + ci], PI[o_kv + ci]
        if u >= 0:
            for l in range(LN):
                tmp[1, l], tmp[0, l] = _sincos_reduced(q[u, l])
            _sincos_beyond(q[u], tmp[1], tmp[0], LN)
            for l in range(LN):
                c, s = tmp[0, l], tmp[1, l]
                e0 = c * u02 - s * u12
                e1 = s * u02 + c * u12
                e2 = u22
                S[ci, 3, l] = fa[j, 0, 0, l] * e0 + fa[j, 0, 1, l] * e1 + fa[j, 0, 2, l] * e2
                S[ci, 4, l] = fa[j, 1, 0, l] * e0 + fa[j, 1, 1, l] * e1 + fa[j, 1, 2, l] * e2
                S[ci, 5, l] = fa[j, 2, 0, l] * e0 + fa[j, 2, 1, l] * e1 + fa[j, 2, 2, l] * e2
        else:
            a = PI[o_kw + ci]
            for l in range(LN):
                S[ci, 3, l], S[ci, 4, l], S[ci, 5, l] = fa[j, 0, a, l], fa[j, 1, a, l], \
                    fa[j, 2, a, l]
        if sw != 1.0:
            for l in range(LN):
                S[ci, 3, l], S[ci, 4, l], S[ci, 5, l] = S[ci, 3, l] * sw, S[ci, 4, l] * sw, \
                    S[ci, 5, l] * sw
        for l in range(LN):
            w0, w1, w2 = S[ci, 3, l], S[ci, 4, l], S[ci, 5, l]
            p0, p1, p2 = fa[j, 0, 3, l], fa[j, 1, 3, l], fa[j, 2, 3, l]
            S[ci, 0, l] = p1 * w2 - p2 * w1
            S[ci, 1, l] = p2 * w0 - p0 * w2
            S[ci, 2, l] = p0 * w1 - p1 * w0
        if sv != 0.0:
            for l in range(LN):
                S[ci, 0, l] += fa[j, 0, kv, l] * sv
                S[ci, 1, l] += fa[j, 1, kv, l] * sv
                S[ci, 2, l] += fa[j, 2, kv, l] * sv


@numba.njit(**_LJIT)
def residual(r, scale, out, big, LN):
    """:func:`closure.solve_kernels._scaled_residual` of lanes ``0 .. LN − 1``: the loop
    residuals ``r`` (nc, 6, L) made dimensionless into ``out`` (6 nc, L), each lane's
    largest absolute entry (NaN where one is NaN) into ``big`` (L,)."""
    for l in range(LN):
        big[l] = 0.0
    for k in range(r.shape[0]):
        for s in range(6):
            for l in range(LN):
                v = r[k, s, l] / scale if s < 3 else r[k, s, l]
                out[6 * k + s, l] = v
                big[l] = abs(v) if abs(v) > big[l] or v != v else big[l]


@numba.njit(**_LJIT)
def jacobian(PI, PF, S, cols, J, LN):
    """:func:`closure.solve_kernels._scaled_jacobian` of lanes ``0 .. LN − 1``: twists
    ``S`` (nv, 6, L) to ``J`` (6·nloops, len(cols), L)."""
    nc, nv, o_rm, o_lp = PI[H_NC], PI[H_NV], PI[F_ROWMAP], PI[F_LOOP]
    r0, r4, r5 = PF[o_rm], PF[o_rm + 4], PF[o_rm + 5]
    r7, r9, r11 = PF[o_rm + 7], PF[o_rm + 9], PF[o_rm + 11]
    r14, r15, r16 = PF[o_rm + 14], PF[o_rm + 15], PF[o_rm + 16]
    for k in range(cols.shape[0]):
        c = cols[k]
        for lp in range(nc):
            f = PF[o_lp + nv * lp + c]
            for l in range(LN):
                s0, s1, s2, s3, s4, s5 = S[c, 0, l], S[c, 1, l], S[c, 2, l], S[c, 3, l], \
                    S[c, 4, l], S[c, 5, l]
                J[6 * lp, k, l] = f * (s0 * r0 + s4 * r4 + s5 * r5)
                J[6 * lp + 1, k, l] = f * (s1 * r7 + s3 * r9 + s5 * r11)
                J[6 * lp + 2, k, l] = f * (s2 * r14 + s3 * r15 + s4 * r16)
                J[6 * lp + 3, k, l] = f * s3
                J[6 * lp + 4, k, l] = f * s4
                J[6 * lp + 5, k, l] = f * s5


@numba.njit(**_LJIT)
def factor(J, G, Lc, Linv, Ginv, fast, inv0, vec, LN):
    """:func:`closure.solve_kernels._factor_k` of lanes ``0 .. LN − 1`` of ``J`` (m, n, L)
    (the caller has passed the rank test): ``fast`` (L,) 1 where the Cholesky path holds,
    else 0 (that lane's other outputs are not used: the caller takes the one-member SVD),
    ``inv0`` (L,) its ``sqrt(tr G⁻¹)``, ``Ginv`` (k, k, L); ``G``, ``Lc``, ``Linv`` (k, k,
    L) and ``vec`` (3, L) scratch.  Every sum in the one-member kernel's order."""
    m, n = J.shape[0], J.shape[1]
    k = min(m, n)
    if m < n:                                           # wide: G = J Jᵀ
        for i in range(k):
            for j in range(i + 1):
                for l in range(LN):
                    vec[2, l] = 0.0
                for t in range(n):
                    for l in range(LN):
                        vec[2, l] += J[i, t, l] * J[j, t, l]
                for l in range(LN):
                    G[i, j, l] = vec[2, l]
    else:                                               # tall: G = Jᵀ J, row by row
        for i in range(k):
            for j in range(i + 1):
                for l in range(LN):
                    G[i, j, l] = 0.0
        for t in range(m):
            for i in range(k):
                for j in range(i + 1):
                    for l in range(LN):
                        G[i, j, l] += J[t, i, l] * J[t, j, l]
    for l in range(LN):
        fast[l] = 1.0
        vec[0, l] = 0.0                                 # ‖J‖²_F = tr G
        vec[1, l] = 0.0                                 # tr G⁻¹
    for i in range(k):
        for l in range(LN):
            vec[0, l] += G[i, i, l]
    for j in range(k):                                  # G = L Lᵀ
        for l in range(LN):
            vec[2, l] = G[j, j, l]
        for t in range(j):
            for l in range(LN):
                vec[2, l] -= Lc[j, t, l] * Lc[j, t, l]
        for l in range(LN):
            d = vec[2, l]
            fast[l] = fast[l] if d > 0.0 else 0.0
            Lc[j, j, l] = math.sqrt(d)
        for i in range(j + 1, k):
            for l in range(LN):
                vec[2, l] = G[i, j, l]
            for t in range(j):
                for l in range(LN):
                    vec[2, l] -= Lc[i, t, l] * Lc[j, t, l]
            for l in range(LN):
                Lc[i, j, l] = vec[2, l] / Lc[j, j, l]
    for j in range(k):                                  # L⁻¹
        for l in range(LN):
            Linv[j, j, l] = 1.0 / Lc[j, j, l]
        for i in range(j + 1, k):
            for l in range(LN):
                vec[2, l] = 0.0
            for t in range(j, i):
                for l in range(LN):
                    vec[2, l] -= Lc[i, t, l] * Linv[t, j, l]
            for l in range(LN):
                Linv[i, j, l] = vec[2, l] / Lc[i, i, l]
        for i in range(j, k):
            for l in range(LN):
                vec[1, l] += Linv[i, j, l] * Linv[i, j, l]
    for l in range(LN):
        cest = math.sqrt(vec[0, l] * vec[1, l])
        fast[l] = fast[l] if cest <= FAST_COND else 0.0
        inv0[l] = math.sqrt(vec[1, l])
    for i in range(k):                                  # G⁻¹ = L⁻ᵀ L⁻¹
        for j in range(i + 1):
            for l in range(LN):
                vec[2, l] = 0.0
            for t in range(i, k):
                for l in range(LN):
                    vec[2, l] += Linv[t, i, l] * Linv[t, j, l]
            for l in range(LN):
                Ginv[i, j, l] = vec[2, l]
                Ginv[j, i, l] = vec[2, l]


@numba.njit(**_LJIT)
def solve(J, Ginv, R, X, T1, T2, acc, LN):
    """:func:`closure.solve_kernels._dn_refine` (the Cholesky path of the minimum-norm
    solve, one step of iterative refinement) of lanes ``0 .. LN − 1``: ``R`` (m, L) to
    ``X`` (n, L) with ``Ginv`` of :func:`factor`; ``T1`` (k, L), ``T2`` (m, L), ``acc``
    (L,) scratch."""
    m, n = J.shape[0], J.shape[1]
    k = min(m, n)
    for it in range(2):
        if it == 0:
            for a in range(m):
                for l in range(LN):
                    T2[a, l] = R[a, l]
        else:
            for a in range(m):
                for l in range(LN):
                    acc[l] = 0.0
                for b in range(n):
                    for l in range(LN):
                        acc[l] += J[a, b, l] * X[b, l]
                for l in range(LN):
                    T2[a, l] = R[a, l] - acc[l]
        if m < n:
            for i in range(k):
                for l in range(LN):
                    acc[l] = 0.0
                for a in range(k):
                    for l in range(LN):
                        acc[l] += Ginv[i, a, l] * T2[a, l]
                for l in range(LN):
                    T1[i, l] = acc[l]
            for b in range(n):
                for l in range(LN):
                    acc[l] = 0.0
                for a in range(m):
                    for l in range(LN):
                        acc[l] += J[a, b, l] * T1[a, l]
                for l in range(LN):
                    X[b, l] = acc[l] if it == 0 else X[b, l] + acc[l]
        else:
            for i in range(k):
                for l in range(LN):
                    T1[i, l] = 0.0
            for a in range(m):
                for i in range(k):
                    for l in range(LN):
                        T1[i, l] += J[a, i, l] * T2[a, l]
            for b in range(n):
                for l in range(LN):
                    acc[l] = 0.0
                for a in range(k):
                    for l in range(LN):
                        acc[l] += Ginv[b, a, l] * T1[a, l]
                for l in range(LN):
                    X[b, l] = acc[l] if it == 0 else X[b, l] + acc[l]


@numba.njit(**_LJIT)
def apply(PI, PF, q, rot, dv, q_out, rot_out, R3, LN):
    """:func:`closure.solve_kernels._apply` of lanes ``0 .. LN − 1``: ``q_out`` (nq, L),
    ``rot_out`` (ns, 3, 3, L) from ``q``, ``rot`` and the dimensionless steps ``dv`` (nv,
    L); ``R3`` (1, 3, 3) scratch (an S joint's rotation, one lane at a time)."""
    o_v, o_q, o_cs = PI[O_SCALV], PI[O_SCALQ], PI[F_COLSC]
    o_sc, o_so = PI[O_SCOLS], PI[O_SORD]
    for i in range(q.shape[0]):
        for l in range(LN):
            q_out[i, l] = q[i, l]
    for i in range(PI[O_SCALQ] - PI[O_SCALV]):
        v, qi = PI[o_v + i], PI[o_q + i]
        f = PF[o_cs + v]
        for l in range(LN):
            q_out[qi, l] = q[qi, l] + dv[v, l] * f
    for k in range(PI[O_INV] - PI[O_SORD]):
        c0, c1, c2, si = PI[o_sc + 3 * k], PI[o_sc + 3 * k + 1], PI[o_sc + 3 * k + 2], \
            PI[o_so + k]
        for l in range(LN):
            _exp_so3(dv[c0, l], dv[c1, l], dv[c2, l], R3, np.int64(0))
            for a in range(3):
                for b in range(3):
                    rot_out[si, a, b, l] = R3[0, a, 0] * rot[si, 0, b, l] + \
                        R3[0, a, 1] * rot[si, 1, b, l] + R3[0, a, 2] * rot[si, 2, b, l]
