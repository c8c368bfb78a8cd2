"""The previous compiled Newton–Euler kernel of the reduced dynamics, kept as the
tests' reference for :mod:`closure.reduced_kernels`.

:func:`newton_euler` forms, for each pose of a batch, the mass matrix, the velocity
terms and the gravity forces of a tree of bodies from the world twists of its joint
columns (:class:`closure.reduced.ReducedDynamics`, module notes there): the carrier
twists and their velocity products, each body's twist, acceleration and input Jacobian
taken into the body's frame, and ``M = Σ Gᵀ Λ G``, ``h = Σ Gᵀ (Λ a − ad(V)ᵀ Λ V)``,
``Q = Σ Gᵀ Λ g`` — the same sums, in the same order, as the numpy expressions they
replace, in one pass with no temporaries but a few 6-vectors.

numba compiles the kernel on first use (``cache=True``: once per installation);
:mod:`closure.dynamics` imports this module on the first evaluation of a reduced model,
so ``import closure`` does not import numba.
"""
from __future__ import annotations

import numba
import numpy as np

__all__ = ["newton_euler"]


@numba.njit(cache=True, nogil=True)
def _ad(v, AD, out):
    """ad(v) (6, 6) of a twist v = (v, ω): ``Σ_m v_m AD[m]``."""
    for i in range(6):
        for j in range(6):
            s = 0.0
            for m in range(6):
                s += v[m] * AD[m, i, j]
            out[i, j] = s


@numba.njit(cache=True, nogil=True)
def newton_euler(S, qd, d1, acc, tc, Pc, dep_ptr, dep_idx, Pb, E, bl, link, Lb, g6, AD,
                 M, h, Q):
    """Mass matrix, velocity terms and gravity forces of a batch of poses.

    Parameters
    ----------
    S : (B, c, 6)
        World unit twists of the tree columns.
    qd, d1, acc : (B, nv)
        Coordinate rates, first analogs, and ``F'' ẋ²`` (the analogs' velocity part of
        the coordinates' accelerations).
    tc : (c,) int
        The coordinate of each column.
    Pc : (c, c)
        Path signs of each column's carrier link; ``dep_ptr (c + 1,)``, ``dep_idx``: the
        columns each column's carrier also moves with (CSR).
    Pb : (k, c)
        Path signs of the bodies' links; ``E (c, n)``: each column's input (one-hot).
    bl : (k,) int
        The bodies' links; ``link (B, links, 4, 4)`` their world poses.
    Lb : (k, 6, 6)
        Spatial inertias in the link frames; ``g6 (6,)``: (g, 0); ``AD (6, 6, 6)``: ad's
        coefficients.
    M, h, Q : (B, n, n), (B, n), (B, n)
        Outputs (overwritten).
    """
    B, c = S.shape[0], S.shape[1]
    k, n = Pb.shape[0], E.shape[1]
    Sq = np.empty((c, 6))
    Vc = np.empty(6)
    bias = np.empty((c, 6))
    adm = np.empty((6, 6))
    X = np.empty((6, n + 3))
    Y = np.empty((6, n + 3))
    col = np.empty((c, 6))
    w = np.empty(6)
    for b in range(B):
        for p in range(c):
            s = qd[b, tc[p]]
            for i in range(6):
                Sq[p, i] = S[b, p, i] * s
        for p in range(c):                    # carrier twists, their products with S q̇
            for i in range(6):
                v = 0.0
                for q in range(c):
                    v += Pc[p, q] * Sq[q, i]
                for r in range(dep_ptr[p], dep_ptr[p + 1]):
                    v += Sq[dep_idx[r], i]
                Vc[i] = v
            _ad(Vc, AD, adm)
            for i in range(6):
                v = 0.0
                for j in range(6):
                    v += adm[i, j] * Sq[p, j]
                bias[p, i] = v
            a = acc[b, tc[p]]
            for i in range(6):
                col[p, i] = S[b, p, i] * a + bias[p, i]
        for i in range(n):
            for j in range(n):
                M[b, i, j] = 0.0
            h[b, i] = 0.0
            Q[b, i] = 0.0
        for kk in range(k):
            L = link[b, bl[kk]]
            # X = Ad(L⁻¹) [G | a | g | V]: Ad(L⁻¹) = [[Rᵀ, −Rᵀ [p]×], [0, Rᵀ]]
            for i in range(6):
                for j in range(n + 3):
                    X[i, j] = 0.0
            for jc in range(n + 3):
                for i in range(6):             # the world 6-vector of this column
                    w[i] = 0.0
                if jc < n:
                    for p in range(c):
                        f = Pb[kk, p] * E[p, jc] * d1[b, tc[p]]
                        if f != 0.0:
                            for i in range(6):
                                w[i] += f * S[b, p, i]
                elif jc == n:
                    for p in range(c):
                        f = Pb[kk, p]
                        if f != 0.0:
                            for i in range(6):
                                w[i] += f * col[p, i]
                elif jc == n + 1:
                    for i in range(6):
                        w[i] = g6[i]
                else:
                    for p in range(c):
                        f = Pb[kk, p]
                        if f != 0.0:
                            for i in range(6):
                                w[i] += f * Sq[p, i]
                # v' = Rᵀ (v − p × ω), ω' = Rᵀ ω
                px, py, pz = L[0, 3], L[1, 3], L[2, 3]
                ux = w[0] - (py * w[5] - pz * w[4])
                uy = w[1] - (pz * w[3] - px * w[5])
                uz = w[2] - (px * w[4] - py * w[3])
                for i in range(3):
                    X[i, jc] = L[0, i] * ux + L[1, i] * uy + L[2, i] * uz
                    X[3 + i, jc] = L[0, i] * w[3] + L[1, i] * w[4] + L[2, i] * w[5]
            for i in range(6):
                for j in range(n + 3):
                    v = 0.0
                    for m in range(6):
                        v += Lb[kk, i, m] * X[m, j]
                    Y[i, j] = v
            for i in range(6):
                Vc[i] = X[i, n + 2]
            _ad(Vc, AD, adm)
            for i in range(6):                # Y_a −= ad(V)ᵀ Λ V
                v = 0.0
                for m in range(6):
                    v += adm[m, i] * Y[m, n + 2]
                Y[i, n] -= v
            for i in range(n):
                for j in range(n + 2):
                    v = 0.0
                    for m in range(6):
                        v += X[m, i] * Y[m, j]
                    if j < n:
                        M[b, i, j] += v
                    elif j == n:
                        h[b, i] += v
                    else:
                        Q[b, i] += v
