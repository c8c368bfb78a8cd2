"""Compiled kernel of the reduced dynamics (numba): transfer functions, link poses,
column twists, Lagrange's terms and the forward right-hand side in one call.

:class:`closure.reduced.ReducedDynamics` replaces the loop closures of a
:class:`closure.Dynamics` by transfer functions ``q_c = F_c(x_i)``.  :func:`step` does
all of its arithmetic for a batch of B input states: every transfer function given as
polynomial pieces (:func:`pack_transfer`: the surrogates of :mod:`approx`, a constant),
the link poses down the spanning tree (each tree joint's ``left · A(q) · right`` a
weighted sum of constant matrices, :func:`pack`), the world unit twists of the tree
columns, the Newton–Euler sums of Lagrange's equations (M, h and gravity's Q: the sums
the Newton–Euler kernel it replaced forms, with the Lie brackets as cross products),
springs and dampers; task ``RHS`` then adds the given generalised forces τ, solves
``M ẍ = Q − h + τ`` and writes the integrator's derivative
``(ẋ, ẍ, dissipated power, τ·ẋ)``.  So forward dynamics costs one compiled call per
right-hand side, with no Python but the integrator's, the drive's and the caller's few
lines.

A transfer function is packed as polynomial pieces in local coordinates (the layout of
:class:`approx.kernels.Pieces`: ``F = Σ_j coef[i, j] (x − origin[i])^j`` on piece i, found
by one multiplication for equal pieces or by a binary search in the inner breakpoints),
used on an interval ``inside``, and optionally a Chebyshev series of F, F', F'' in
``u = s x + o`` used outside it (Clenshaw's recurrence, the operations of
:func:`approx.surrogate._clenshaw`); points outside the accepted interval, or not
finite, are refused (status ``TRANSFER``: the caller names the transfer).  The piece
search :func:`_piece` and Horner's scheme with derivatives :func:`_horner` are the
ones :mod:`approx.kernels` evaluates the surrogates with, so a surrogate gives the same
numbers here as through its own ``all``.

Data come packed by :func:`pack` into ``PI`` (int64) and ``PF`` (float64), with a header
of counts and table offsets (``H_*``, ``O_*``), and all inputs and outputs of a call
live in one float64 work array ``W`` laid out by :func:`layout` (the caller takes numpy
views of it): a call passes five arguments (numba's dispatch costs about 0.15 µs an
argument).  :func:`step` is one function with flat indexing, not a tree of helpers:
numba compiles every helper it calls as a library that each caller links and optimises
again, so that keeps the first compile short (about 4–5 s CPU, once per installation;
numba's ``cache=True``).  :mod:`approx.kernels` compiles the piece search and Horner's
scheme into its own kernels, whose cache index therefore carries this file's stamp
(:func:`cached_njit`: numba checks only the file of the function it caches).
"""
from __future__ import annotations

import math
import os
from typing import Callable

import numba
import numpy as np


__all__ = ["pack", "pack_transfer", "layout", "step", "cached_njit", "COORDS", "TERMS",
           "RHS", "OK", "TRANSFER", "NON_FINITE", "SINGULAR"]

#: tasks of :func:`step`
COORDS, TERMS, RHS = 0, 1, 2
#: what :func:`step` reports
OK, TRANSFER, NON_FINITE, SINGULAR = 0, 1, 2, 3

#: joint kinds of the tree: R, P, C, H (four matrices) or U (ten; :func:`step`)
J_LIN, J_U = 0, 1

# PI's header: counts, then the offsets of the tables in PI and in PF
(H_NI, H_NV, H_NL, H_NK, H_NC, H_NB, H_NE, H_NT,
 O_JOINT, O_INP, O_OFIN, O_TC, O_CARRIER, O_UQ, O_DPTR, O_DIDX, O_BL, O_LCOL, O_TRANS,
 O_FJOINT, O_FCOL, O_FPC, O_FPB, O_FLB, O_FLIN, O_FTRANS, H_HEAD) = range(27)

#: ints per tree joint (link, parent link, kind, rotation q, slide q), per transfer
#: (column, input, pieces P, coefficients K, offsets of origin, inner, coef and series
#: in PF, series length); floats per tree joint (``_JM`` 4x4 matrices), per column
#: (u_0, u_1, u_2: its twist (u_v, u_ω) in the carrier's frame is u_0 + cos φ u_1 +
#: sin φ u_2, u_1 = u_2 = 0 but for a Hooke joint's second column), per transfer (lo,
#: 1/h, inside, accepted, s, o)
_JI, _TI, _JM, _CF, _TF = 5, 9, 10, 18, 8
_JF = 16 * _JM

_JIT = dict(cache=True, nogil=True, error_model="numpy")


def _stamp(module) -> tuple:
    st = os.stat(module.__file__)
    return module.__name__, st.st_mtime, st.st_size


def cached_njit(*dependencies, **options) -> Callable:
    """``numba.njit(cache=True, ...)`` whose cache index also carries the stamps (name,
    mtime, size) of the modules ``dependencies``, whose compiled code the function
    contains: numba checks only the file of the function it caches, so without them a
    change there would leave stale machine code in the cache.  ``options`` replace
    the defaults ``cache=True, nogil=True, error_model="numpy"``."""
    stamps = tuple(_stamp(m) for m in dependencies)

    def wrap(fn):
        disp = numba.njit(**{**_JIT, **options})(fn)
        cache_file = getattr(getattr(disp, "_cache", None), "_cache_file", None)
        if stamps and cache_file is not None and hasattr(cache_file, "_source_stamp"):
            cache_file._source_stamp = (cache_file._source_stamp, stamps)
        return disp
    return wrap


_njit = cached_njit()


# ----------------------------------------------------------------- polynomial pieces
@numba.njit(cache=True, nogil=True, inline="always")
def _piece(v: float, lo: float, inv_h: float, inner: np.ndarray, P: int) -> int:
    """The piece of x = v: by one multiplication for equal pieces (``inv_h > 0``), else a
    binary search in the sorted inner breakpoints (``searchsorted(inner, v, "right")``
    for every v but NaN, which the callers refuse first); points beyond the ends (and NaN
    for equal pieces) take the end pieces."""
    if inv_h > 0.0:
        s = (v - lo) * inv_h
        if not s > 0.0:                          # also NaN: the first piece
            return 0
        if s >= P:
            return P - 1
        return int(s)
    lo_, hi_ = 0, inner.size                    # searchsorted(inner, v, side="right")
    while lo_ < hi_:
        mid = (lo_ + hi_) >> 1
        if inner[mid] <= v:
            lo_ = mid + 1
        else:
            hi_ = mid
    return lo_


@numba.njit(cache=True, nogil=True, inline="always")
def _horner(c: np.ndarray, i: int, t: float) -> tuple:
    """F, F', F'' of piece i's polynomial (ascending coefficients ``c[i]``) at t."""
    K = c.shape[1]
    p = c[i, K - 1]
    d = 0.0
    dd = 0.0
    for j in range(K - 2, -1, -1):
        dd = dd * t + d
        d = d * t + p
        p = p * t + c[i, j]
    return p, d, 2.0 * dd


# ----------------------------------------------------------------- the work array
@_njit
def layout(B: int, PI: np.ndarray) -> np.ndarray:
    """Offsets in the work array ``W`` of a batch of B states, in this order: x, ẋ, τ
    (B, n) each (x and ẋ adjacent: for B = 1 the integrator's ``y[:2n]``), (g, 0) (6,),
    q, F', F'', q̇, F''ẋ² (B, nv) each, link poses (B, nl, 4, 4), column twists
    (B, c, 6), M (B, n, n), h, Q (B, n), dissipated power (B,), the derivative
    (B, 2n + 2); the last entry is W's size."""
    n, nv, nl, c = PI[H_NI], PI[H_NV], PI[H_NL], PI[H_NC]
    sizes = (B * n, B * n, B * n, 6, B * nv, B * nv, B * nv, B * nv, B * nv, B * nl * 16,
             B * c * 6, B * n * n, B * n, B * n, B, B * (2 * n + 2))
    out = np.empty(len(sizes) + 1, dtype=np.int64)
    o = 0
    for k in range(len(sizes)):
        out[k] = o
        o += sizes[k]
    out[len(sizes)] = o
    return out


(W_X, W_XD, W_TAU, W_G, W_Q, W_D1, W_D2, W_QD, W_ACC, W_LINK, W_S, W_M, W_H, W_Q_,
 W_DISS, W_OUT, W_SIZE) = range(17)


# ----------------------------------------------------------------- the entry
@_njit
def step(task: int, B: int, W: np.ndarray, PI: np.ndarray, PF: np.ndarray) -> int:
    """One call of the reduced model on B states held in ``W`` (:func:`layout`).

    In order, for each state: the coordinates (the inputs; each packed transfer's piece
    by :func:`_piece` and Horner's scheme :func:`_horner`, or beyond the pieces its
    Chebyshev series by Clenshaw's recurrence) and q̇ = F' ẋ, F'' ẋ²; the link poses
    down the tree, each tree joint's ``left · A(q) · right = Σ_m w_m C_m`` (:func:`pack`)
    with the weights ``(1, sin θ, 1 − cos θ, s)`` of R, P, C, H joints (s the slide, or
    θ for H) or ``(1, (1, cos φ, sin φ) ⊗ (1, cos θ, sin θ))`` of U joints; the
    columns' world twists ``ω = R_L u_ω``, ``v = R_L u_v + p_L × ω`` with (u_v, u_ω) in
    the carrier's frame (``u_0 + cos φ u_1 + sin φ u_2`` for the Hooke joint's second
    column, which turns with φ); the Newton–Euler sums: each column's rate S q̇ and
    velocity-product acceleration ``S F''ẋ² + [V_carrier, S q̇]``, each body's columns
    G (per input), acceleration a, gravity (g, 0) and twist V summed by the path signs
    and taken into its frame by ``Ad(L⁻¹)``, where its spatial inertia Λ is constant:
    ``M += Gᵀ Λ G``, ``h += Gᵀ (Λ a − ad(V)ᵀ Λ V)``, ``Q += Gᵀ Λ (g, 0)`` (the sums and
    order of the Newton–Euler kernel it replaced, the brackets as cross products);
    springs and dampers on their coordinates through F'.  Task RHS then solves
    ``M ẍ = Q − h + τ`` by Cholesky's factorisation: M = Σ Gᵀ Λ G is symmetric positive
    semi-definite, and singular when a pivot is not above 1e-14 times its diagonal entry
    plus the squares subtracted from it (for n ≤ 2 the tests ``m > 0`` and
    ``det > 1e-14 (|ad| + |bc|)`` of the closed forms).

    Parameters
    ----------
    task : int
        ``COORDS``: q, F', F'', q̇ and F''ẋ² from x and ẋ; ``TERMS``: also the link
        poses, column twists, M, h, Q (gravity, springs, dampers) and the dampers'
        power; ``RHS`` (B = 1): also the derivative ``(ẋ, ẍ, dissipated power, τ·ẋ)``
        (the state's units per second).
    B : int
        States in the batch.
    W : (layout(B, PI)[-1],) float64
        The work array: x, ẋ, τ (and for the transfers not packed, their q, F', F''
        columns) in, the rest out.
    PI, PF : int64 and float64 arrays
        The model (:func:`pack`).

    Returns
    -------
    int
        ``OK``; ``TRANSFER`` (a transfer refused its point or gave a non-finite value),
        ``NON_FINITE`` (Q − h + τ not finite) or ``SINGULAR`` (M), task ``RHS`` only.
    """
    n, nv, nl, c = PI[H_NI], PI[H_NV], PI[H_NL], PI[H_NC]
    nb, ne, nt, nk = PI[H_NB], PI[H_NE], PI[H_NT], PI[H_NK]
    o = layout(B, PI)
    ox, oxd, oq, od1, od2 = o[W_X], o[W_XD], o[W_Q], o[W_D1], o[W_D2]
    oqd, oac, oin, oof = o[W_QD], o[W_ACC], PI[O_INP], PI[O_OFIN]
    # -------- coordinates
    for b in range(B):
        bq, bx = b * nv, b * n
        for k in range(n):
            j = bq + PI[oin + k]
            W[oq + j] = W[ox + bx + k]
            W[od1 + j] = 1.0
            W[od2 + j] = 0.0
        for m in range(nt):
            r = PI[O_TRANS] + _TI * m
            f = PI[O_FTRANS] + _TF * m
            v = W[ox + bx + PI[r + 1]]
            if not (PF[f + 4] <= v <= PF[f + 5]) or not np.isfinite(v):
                return TRANSFER
            P = PI[r + 2]
            if P > 0 and PF[f + 2] <= v <= PF[f + 3]:
                K, oc, oi = PI[r + 3], PI[r + 6], PI[r + 5]
                i = _piece(v, PF[f], PF[f + 1], PF[oi:oi + P - 1], P)
                p, d, dd = _horner(PF[oc:oc + P * K].reshape((P, K)), i, v - PF[PI[r + 4] + i])
            else:                               # the series (columns F, F', F'')
                u2 = 2.0 * (v * PF[f + 6] + PF[f + 7])
                os_ = PI[r + 7]
                a1, a2, b1, b2, c1, c2 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
                for e in range(os_ + 3 * (PI[r + 8] - 1), os_, -3):
                    ta = a1 * u2 - a2 + PF[e]
                    tb = b1 * u2 - b2 + PF[e + 1]
                    tc = c1 * u2 - c2 + PF[e + 2]
                    a2, b2, c2 = a1, b1, c1
                    a1, b1, c1 = ta, tb, tc
                u = 0.5 * u2
                p = a1 * u - a2 + PF[os_]
                d = b1 * u - b2 + PF[os_ + 1]
                dd = c1 * u - c2 + PF[os_ + 2]
            if not (np.isfinite(p) and np.isfinite(d) and np.isfinite(dd)):
                return TRANSFER
            j = bq + PI[r]
            W[oq + j] = p
            W[od1 + j] = d
            W[od2 + j] = dd
        for k in range(nv):
            xr = W[oxd + bx + PI[oof + k]]
            W[oqd + bq + k] = W[od1 + bq + k] * xr
            W[oac + bq + k] = W[od2 + bq + k] * xr * xr
    if task == COORDS:
        return OK
    # -------- link poses (row-major 4x4 at olk + 16 (b nl + link)), column twists
    olk, oS = o[W_LINK], o[W_S]
    wt = np.zeros(_JM)
    rel = np.empty(16)
    u6 = np.empty(6)
    for b in range(B):
        lb = olk + 16 * nl * b
        for i in range(16):
            W[lb + i] = 1.0 if i % 5 == 0 else 0.0
        for k in range(nk):
            r = PI[O_JOINT] + _JI * k
            qa, qb = PI[r + 3], PI[r + 4]
            wt[0] = 1.0
            if PI[r + 2] == J_LIN:
                nm = 4
                wt[1], wt[2], wt[3] = 0.0, 0.0, 0.0
                if qa >= 0:
                    th = W[oq + b * nv + qa]
                    wt[1], wt[2] = math.sin(th), 1.0 - math.cos(th)
                if qb >= 0:
                    wt[3] = W[oq + b * nv + qb]
            else:
                nm = _JM
                ph, th = W[oq + b * nv + qa], W[oq + b * nv + qb]
                cp, sp, ct, st = math.cos(ph), math.sin(ph), math.cos(th), math.sin(th)
                wt[1], wt[2], wt[3] = 1.0, ct, st
                wt[4], wt[5], wt[6] = cp, cp * ct, cp * st
                wt[7], wt[8], wt[9] = sp, sp * ct, sp * st
            f = PI[O_FJOINT] + _JF * k
            for i in range(12):                 # the last row stays (0, 0, 0, 1)
                s = 0.0
                for mm in range(1, nm):
                    s += wt[mm] * PF[f + 16 * mm + i]
                rel[i] = s + PF[f + i]
            pa = lb + 16 * PI[r + 1]            # L_link = L_parent · rel
            la = lb + 16 * PI[r]
            for i in range(3):
                p0, p1, p2 = W[pa + 4 * i], W[pa + 4 * i + 1], W[pa + 4 * i + 2]
                for j in range(4):
                    W[la + 4 * i + j] = p0 * rel[j] + p1 * rel[4 + j] + p2 * rel[8 + j]
                W[la + 4 * i + 3] += W[pa + 4 * i + 3]
            for i in range(12, 16):
                W[la + i] = 1.0 if i == 15 else 0.0
        for pp in range(c):
            f = PI[O_FCOL] + _CF * pp
            cp, sp = 0.0, 0.0
            uq = PI[PI[O_UQ] + pp]
            if uq >= 0:
                cp, sp = math.cos(W[oq + b * nv + uq]), math.sin(W[oq + b * nv + uq])
            for i in range(6):
                u6[i] = PF[f + i] + cp * PF[f + 6 + i] + sp * PF[f + 12 + i]
            la = lb + 16 * PI[PI[O_CARRIER] + pp]
            so = oS + 6 * (b * c + pp)
            for i in range(3):
                li = la + 4 * i
                W[so + 3 + i] = W[li] * u6[3] + W[li + 1] * u6[4] + W[li + 2] * u6[5]
                W[so + i] = W[li] * u6[0] + W[li + 1] * u6[1] + W[li + 2] * u6[2]
            px, py, pz = W[la + 3], W[la + 7], W[la + 11]
            wx, wy, wz = W[so + 3], W[so + 4], W[so + 5]
            W[so] += py * wz - pz * wy
            W[so + 1] += pz * wx - px * wz
            W[so + 2] += px * wy - py * wx
    # -------- Lagrange's terms: Newton–Euler sums, then springs and dampers
    oM, oh, oQ, odi = o[W_M], o[W_H], o[W_Q_], o[W_DISS]
    otc, opc, opb, olb = PI[O_TC], PI[O_FPC], PI[O_FPB], PI[O_FLB]
    Sq = np.empty((c, 6))                       # column twist rates S_p q̇_p
    col = np.empty((c, 6))                      # S_p F''ẋ² + [V_carrier, S_p q̇_p]
    X = np.empty((6, n + 3))                    # in the body frame: G (n), a, g, V
    Y = np.empty((6, n + 3))                    # Λ X
    for i in range(oM, oQ + B * n):
        W[i] = 0.0
    for b in range(B):
        bS = oS + 6 * c * b
        for pp in range(c):
            rate = W[oqd + b * nv + PI[otc + pp]]
            for i in range(6):
                Sq[pp, i] = W[bS + 6 * pp + i] * rate
        for pp in range(c):                     # the carrier's twist V: Σ path signs · rates
            vx, vy, vz, wx, wy, wz = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
            for qq in range(c):
                sgn = PF[opc + c * pp + qq]
                if sgn != 0.0:
                    vx += sgn * Sq[qq, 0]
                    vy += sgn * Sq[qq, 1]
                    vz += sgn * Sq[qq, 2]
                    wx += sgn * Sq[qq, 3]
                    wy += sgn * Sq[qq, 4]
                    wz += sgn * Sq[qq, 5]
            for rr in range(PI[PI[O_DPTR] + pp], PI[PI[O_DPTR] + pp + 1]):
                qq = PI[PI[O_DIDX] + rr]
                vx += Sq[qq, 0]
                vy += Sq[qq, 1]
                vz += Sq[qq, 2]
                wx += Sq[qq, 3]
                wy += Sq[qq, 4]
                wz += Sq[qq, 5]
            # [V, s] = (ω × s_v + v × s_ω, ω × s_ω)
            sx, sy, sz, tx, ty, tz = Sq[pp, 0], Sq[pp, 1], Sq[pp, 2], Sq[pp, 3], Sq[pp, 4], \
                Sq[pp, 5]
            a = W[oac + b * nv + PI[otc + pp]]
            e = bS + 6 * pp
            col[pp, 0] = W[e] * a + (wy * sz - wz * sy + vy * tz - vz * ty)
            col[pp, 1] = W[e + 1] * a + (wz * sx - wx * sz + vz * tx - vx * tz)
            col[pp, 2] = W[e + 2] * a + (wx * sy - wy * sx + vx * ty - vy * tx)
            col[pp, 3] = W[e + 3] * a + (wy * tz - wz * ty)
            col[pp, 4] = W[e + 4] * a + (wz * tx - wx * tz)
            col[pp, 5] = W[e + 5] * a + (wx * ty - wy * tx)
        for kk in range(nb):
            for i in range(6):                  # the world 6-vectors of the body
                for j in range(n + 3):
                    X[i, j] = 0.0
                X[i, n + 1] = W[o[W_G] + i]
            for pp in range(c):
                sgn = PF[opb + c * kk + pp]
                if sgn != 0.0:
                    jj = PI[oof + PI[otc + pp]]
                    gd = sgn * W[od1 + b * nv + PI[otc + pp]]
                    for i in range(6):
                        X[i, jj] += gd * W[bS + 6 * pp + i]
                        X[i, n] += sgn * col[pp, i]
                        X[i, n + 2] += sgn * Sq[pp, i]
            la = olk + 16 * (nl * b + PI[PI[O_BL] + kk])
            px, py, pz = W[la + 3], W[la + 7], W[la + 11]
            for j in range(n + 3):              # Ad(L⁻¹): v' = Rᵀ (v − p × ω), ω' = Rᵀ ω
                ux = X[0, j] - (py * X[5, j] - pz * X[4, j])
                uy = X[1, j] - (pz * X[3, j] - px * X[5, j])
                uz = X[2, j] - (px * X[4, j] - py * X[3, j])
                wx, wy, wz = X[3, j], X[4, j], X[5, j]
                for i in range(3):
                    X[i, j] = W[la + i] * ux + W[la + 4 + i] * uy + W[la + 8 + i] * uz
                    X[3 + i, j] = W[la + i] * wx + W[la + 4 + i] * wy + W[la + 8 + i] * wz
            lb_ = olb + 36 * kk
            for i in range(6):
                for j in range(n + 3):
                    s = 0.0
                    for mm in range(6):
                        s += PF[lb_ + 6 * i + mm] * X[mm, j]
                    Y[i, j] = s
            # Y_a −= ad(V)ᵀ Λ V, ad(V)ᵀ (f, τ) = (−ω × f, −v × f − ω × τ)
            vx, vy, vz, wx, wy, wz = X[0, n + 2], X[1, n + 2], X[2, n + 2], X[3, n + 2], \
                X[4, n + 2], X[5, n + 2]
            fx, fy, fz, tx, ty, tz = Y[0, n + 2], Y[1, n + 2], Y[2, n + 2], Y[3, n + 2], \
                Y[4, n + 2], Y[5, n + 2]
            Y[0, n] += wy * fz - wz * fy
            Y[1, n] += wz * fx - wx * fz
            Y[2, n] += wx * fy - wy * fx
            Y[3, n] += vy * fz - vz * fy + wy * tz - wz * ty
            Y[4, n] += vz * fx - vx * fz + wz * tx - wx * tz
            Y[5, n] += vx * fy - vy * fx + wx * ty - wy * tx
            for i in range(n):                  # M += Gᵀ Λ G, h += Gᵀ (Λ a − ad(V)ᵀ Λ V),
                for j in range(n + 2):          # Q += Gᵀ Λ (Rᵀ g, 0)
                    s = 0.0
                    for mm in range(6):
                        s += X[mm, i] * Y[mm, j]
                    if j < n:
                        W[oM + n * (n * b + i) + j] += s
                    elif j == n:
                        W[oh + n * b + i] += s
                    else:
                        W[oQ + n * b + i] += s
    fl = PI[O_FLIN]                             # per element: k, free, c, −c
    for b in range(B):
        W[odi + b] = 0.0
        for e in range(ne):
            cc = PI[PI[O_LCOL] + e]
            j = b * nv + cc
            rate = W[oqd + j]
            t = rate * PF[fl + 4 * e + 3] - PF[fl + 4 * e] * (W[oq + j] - PF[fl + 4 * e + 1])
            W[oQ + b * n + PI[oof + cc]] += W[od1 + j] * t
            W[odi + b] += rate * rate * PF[fl + 4 * e + 2]
    if task != RHS:
        return OK
    # -------- M ẍ = Q − h + τ by Cholesky (M's factor in the lower triangle of L)
    oo, ot = o[W_OUT], o[W_TAU]
    L = np.empty((n, n))
    for i in range(n):
        F = W[oQ + i] - W[oh + i] + W[ot + i]
        if not np.isfinite(F):
            return NON_FINITE
        W[oo + n + i] = F
    for j in range(n):
        s = W[oM + j * n + j]
        t = s
        for k in range(j):
            s -= L[j, k] * L[j, k]
            t += L[j, k] * L[j, k]
        if not s > 1e-14 * t:
            return SINGULAR
        L[j, j] = math.sqrt(s)
        for i in range(j + 1, n):
            s = W[oM + i * n + j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / L[j, j]
    dw = 0.0
    for i in range(n):                          # L y = F, then Lᵀ ẍ = y
        s = W[oo + n + i]
        for k in range(i):
            s -= L[i, k] * W[oo + n + k]
        W[oo + n + i] = s / L[i, i]
        W[oo + i] = W[oxd + i]
        dw += W[ot + i] * W[oxd + i]
    for i in range(n - 1, -1, -1):
        s = W[oo + n + i]
        for k in range(i + 1, n):
            s -= L[k, i] * W[oo + n + k]
        W[oo + n + i] = s / L[i, i]
    W[oo + 2 * n] = W[odi]
    W[oo + 2 * n + 1] = dw
    return OK


# ----------------------------------------------------------------- packing
def pack_transfer(form: dict) -> tuple:
    """A transfer's ``kernel_form()`` (see :class:`closure.reduced.ReducedDynamics`) in
    the kernel's terms.

    Parameters
    ----------
    form : dict
        ``pieces``: ``(origin (P,), coef (P, K), inner (P − 1,), lo, inv_h)`` or None;
        ``series``: Chebyshev coefficients (K2, 3) of F, F', F'' or None, in
        ``u = s x + o`` with ``series_map = (s, o)``; ``inside``: (low, high), where the
        pieces apply when there is a series (x in the transfer's unit); ``accept``:
        (low, high), the x it evaluates.

    Returns
    -------
    counts : (P, K, K2)
    scalars : (8,) float
        lo, inv_h, inside, accept, s, o.
    arrays : tuple of 1-D float arrays
        origin, inner, coef and series (flattened), to append to PF.

    Raises
    ------
    ValueError
        Neither pieces nor a series, or arrays of inconsistent shapes.
    """
    pieces = form.get("pieces")
    series = form.get("series")
    if pieces is None and series is None:
        raise ValueError("kernel_form: neither pieces nor a series")
    if pieces is not None:
        origin, coef, inner, lo, inv_h = pieces
        coef = np.ascontiguousarray(coef, float)
        origin = np.ascontiguousarray(origin, float).ravel()
        inner = np.ascontiguousarray(inner, float).ravel()
        P, K = coef.shape
        if origin.size != P or (inv_h <= 0 and inner.size != P - 1):
            raise ValueError("kernel_form: origin (P,), coef (P, K), inner (P − 1,) expected")
        if inner.size != P - 1:             # equal pieces: the search is not used
            inner = np.zeros(max(P - 1, 0))
    else:
        origin = coef = inner = np.zeros(0)
        P, K, lo, inv_h = 0, 0, 0.0, 0.0
    if series is not None:
        series = np.ascontiguousarray(series, float)
        if series.ndim != 2 or series.shape[1] != 3 or series.shape[0] < 1:
            raise ValueError("kernel_form: series (K, 3) expected")
        s, o = form.get("series_map", (1.0, 0.0))
    else:
        series = np.zeros((0, 3))
        s, o = 1.0, 0.0
    inside = form.get("inside", (-np.inf, np.inf)) if series.size else (-np.inf, np.inf)
    accept = form.get("accept", (-np.inf, np.inf))
    scal = np.array([lo, inv_h, inside[0], inside[1], accept[0], accept[1], s, o], float)
    return (P, K, series.shape[0]), scal, (origin, inner, coef.ravel(), series.ravel())


def pack(tree_joints: list, columns: list, inputs, of_input, nv: int, nl: int, bodies: tuple,
         lin: tuple, transfers: list) -> tuple[np.ndarray, np.ndarray]:
    """``(PI, PF)`` of a reduced model (module notes).

    Parameters
    ----------
    tree_joints : list of (link, parent, kind, q of w_1, q of w_3, (_JM, 4, 4) floats)
        In the tree's order: ``left · A(q) · right = Σ_m w_m C_m`` (:func:`step`; the
        second and third entries of kind J_U are φ's and θ's coordinates, −1 where a
        J_LIN joint has no rotation or no slide).
    columns : list of (coordinate, carrier link, Hooke φ's q or −1, (18,) floats)
        Each tree column's (u_v, u_ω) in its carrier's frame, and their cos φ and sin φ
        parts (:func:`step`).
    inputs : (n,) int
        The input columns.
    of_input : (nv,) int
        The input that moves each coordinate.
    nv, nl : int
        Coordinates and links.
    bodies : (bl (k,), Pc (c, c), Pb (k, c), Lb (k, 6, 6), dep_ptr (c + 1,), dep_idx)
        The bodies' links; the path signs of each column's carrier link and of each
        body's link over the columns; the bodies' 6x6 spatial inertias about their link
        frames' origins ([[m E, −m [c]×], [m [c]×, I_c − m [c]×[c]×]], twists (v, ω));
        the columns each column's carrier also moves with (CSR: a Hooke joint's second
        column, moved by its first).
    lin : (cols (e,), (e, 4) floats: k, free, c, −c)
    transfers : list of (column, input, form)

    Returns
    -------
    PI : (·,) int64
    PF : (·,) float64
    """
    bl, Pc, Pb, Lb, dep_ptr, dep_idx = bodies
    lcols, lvals = lin
    n, c = len(inputs), len(columns)
    head = np.zeros(H_HEAD, dtype=np.int64)
    head[[H_NI, H_NV, H_NL, H_NK, H_NC, H_NB, H_NE, H_NT]] = (
        n, nv, nl, len(tree_joints), c, len(bl), len(lcols), len(transfers))
    packed = [pack_transfer(form) for _, _, form in transfers]
    # floats: joints, columns, Pc, Pb, Lb, lin, transfer scalars, then arrays
    fparts = [np.array([j[5] for j in tree_joints], float).reshape(-1),
              np.array([col[3] for col in columns], float).reshape(-1),
              np.asarray(Pc, float).reshape(-1), np.asarray(Pb, float).reshape(-1),
              np.asarray(Lb, float).reshape(-1), np.asarray(lvals, float).reshape(-1),
              np.array([p[1] for p in packed], float).reshape(-1)]
    fkeys = (O_FJOINT, O_FCOL, O_FPC, O_FPB, O_FLB, O_FLIN, O_FTRANS)
    f = 0
    for key, part in zip(fkeys, fparts):
        head[key] = f
        f += part.size
    trows = []
    for (col, inp, _), (counts, _, arrays) in zip(transfers, packed):
        P, K, Ks = counts
        offs = []
        for a in arrays:
            offs.append(f)
            fparts.append(a)
            f += a.size
        trows.append([col, inp, P, K, offs[0], offs[1], offs[2], offs[3] if Ks else -1, Ks])
    PF = np.concatenate(fparts) if fparts else np.zeros(0)
    ints = [np.array([j[:5] for j in tree_joints], dtype=np.int64).reshape(-1),
            np.asarray(inputs, dtype=np.int64), np.asarray(of_input, dtype=np.int64),
            np.array([col[0] for col in columns], dtype=np.int64),
            np.array([col[1] for col in columns], dtype=np.int64),
            np.array([col[2] for col in columns], dtype=np.int64),
            np.asarray(dep_ptr, dtype=np.int64), np.asarray(dep_idx, dtype=np.int64),
            np.asarray(bl, dtype=np.int64), np.asarray(lcols, dtype=np.int64),
            np.array(trows, dtype=np.int64).reshape(-1)]
    ikeys = (O_JOINT, O_INP, O_OFIN, O_TC, O_CARRIER, O_UQ, O_DPTR, O_DIDX, O_BL, O_LCOL,
             O_TRANS)
    parts, i = [head], H_HEAD
    for key, part in zip(ikeys, ints):
        head[key] = i
        parts.append(part)
        i += part.size
    return np.concatenate(parts), np.ascontiguousarray(PF)
