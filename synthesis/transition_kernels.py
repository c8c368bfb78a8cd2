"""Compiled kernel of the revolute transition joints (:func:`synthesis.transition_joints`):
every problem solved one after another in one call, so the one-problem form
(:func:`synthesis.transition.transition_joint`, called once per variant by the sphere- and
Hooke-ended families) costs microseconds, and a batch scales with its size.

The steps are those of the module notes of :mod:`synthesis.transition`: the zero-slide
coefficients α, β, γ, δ from the dual quaternion of the displacement, J3's increment for
each kind of J3 (closed forms; the roots of the transcendental H equation on a grid of
intervals, refined by safeguarded Newton iterations), then the transition axis from the
screw of ``E = D · Y(−Δ, −σ)`` (a pure rotation).

numba compiles the kernel on first use (``cache=True``: once per installation, then loaded
from the cache); :mod:`synthesis.transition` imports this module only when a transition is
solved, so ``import synthesis`` does not import numba.
"""
from __future__ import annotations

import math

import numpy as np

import numba

_kernel = numba.njit(cache=True, nogil=True, error_model="numpy")

#: error codes of :func:`revolute` (0: none)
DEGENERATE_R, DEGENERATE_P, DEGENERATE_C, NO_TURN, NOT_PURE = 1, 2, 3, 4, 5


@_kernel
def _quat(R, q):
    """Unit quaternion (w, x, y, z), w ≥ 0, of the rotation block ``R`` of a 4x4 (or 3x3)
    matrix, by Shepperd's method (as :func:`synthesis.dualquat.quat_from_rotation`)."""
    r00, r01, r02 = R[0, 0], R[0, 1], R[0, 2]
    r10, r11, r12 = R[1, 0], R[1, 1], R[1, 2]
    r20, r21, r22 = R[2, 0], R[2, 1], R[2, 2]
    tr = r00 + r11 + r22
    k = 0
    best = tr
    if r00 > best:
        k, best = 1, r00
    if r11 > best:
        k, best = 2, r11
    if r22 > best:
        k = 3
    if k == 0:
        kk, a, b, c = 1 + tr, r21 - r12, r02 - r20, r10 - r01
    elif k == 1:
        kk, a, b, c = 1 + r00 - r11 - r22, r21 - r12, r10 + r01, r20 + r02
    elif k == 2:
        kk, a, b, c = 1 + r11 - r22 - r00, r02 - r20, r10 + r01, r21 + r12
    else:
        kk, a, b, c = 1 + r22 - r00 - r11, r10 - r01, r20 + r02, r21 + r12
    v = 0.5 * math.sqrt(kk)
    f = 4 * v
    # row k of Shepperd's symmetric matrix / (4 v), its k-th entry v
    if k == 0:
        q[0], q[1], q[2], q[3] = v, a / f, b / f, c / f
    elif k == 1:
        q[0], q[1], q[2], q[3] = a / f, v, b / f, c / f
    elif k == 2:
        q[0], q[1], q[2], q[3] = a / f, b / f, v, c / f
    else:
        q[0], q[1], q[2], q[3] = a / f, b / f, c / f, v
    if not q[0] >= 0:
        for i in range(4):
            q[i] = -q[i]


@_kernel
def _zero_slide(D, u, m, q, out):
    """α, β, γ, δ of f(Δ, σ) = scalar dual part of q_D q_Y(−Δ, −σ) into ``out (4,)``."""
    _quat(D, q)
    t0, t1, t2 = D[0, 3], D[1, 3], D[2, 3]
    w2, x2, y2, z2 = q[0], q[1], q[2], q[3]
    # dual part ½ (0, t) q
    d0 = 0.5 * (0.0 * w2 - t0 * x2 - t1 * y2 - t2 * z2)
    d1 = 0.5 * (0.0 * x2 + t0 * w2 + t1 * z2 - t2 * y2)
    d2 = 0.5 * (0.0 * y2 - t0 * z2 + t1 * w2 + t2 * x2)
    d3 = 0.5 * (0.0 * z2 + t0 * y2 - t1 * x2 + t2 * w2)
    # f is the linear functional (d0, −d⃗, r0, −r⃗) · (screw's dual quaternion)
    for j in range(4):
        ang = 0.0 if j % 2 == 0 else math.pi
        sl = 0.0 if j < 2 else 1.0
        c, s = math.cos(-ang / 2), math.sin(-ang / 2)
        h = 0.5 * -sl
        f = (d0 * c - d1 * (s * u[0]) - d2 * (s * u[1]) - d3 * (s * u[2]) + w2 * (-h * s)
             - x2 * (h * c * u[0] + s * m[0]) - y2 * (h * c * u[1] + s * m[1])
             - z2 * (h * c * u[2] + s * m[2]))
        out[j] = f
    out[2] -= out[0]
    out[3] -= out[1]


@_kernel
def _axis(D, u, p, dl, sl, q, E, res):
    """The screw of ``E = D · Y(−dl, −sl)`` (Y: about the line (u, p)) into ``res``:
    angle, slide, axis (3), foot point (3)."""
    c, s = math.cos(-dl), math.sin(-dl)
    K = np.zeros((3, 3))
    K[0, 1], K[0, 2] = -u[2], u[1]
    K[1, 0], K[1, 2] = u[2], -u[0]
    K[2, 0], K[2, 1] = -u[1], u[0]
    S = np.eye(4)
    for i in range(3):
        for j in range(3):
            kk = 0.0
            for l in range(3):
                kk += K[i, l] * K[l, j]
            S[i, j] = (S[i, j] + s * K[i, j]) + (1 - c) * kk
    for i in range(3):
        rp = S[i, 0] * p[0] + S[i, 1] * p[1] + S[i, 2] * p[2]
        S[i, 3] = p[i] - rp + -sl * u[i]
    for i in range(4):
        for j in range(4):
            acc = 0.0
            for l in range(4):
                acc += D[i, l] * S[l, j]
            E[i, j] = acc
    _quat(E, q)
    sh = math.sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    ang = 2 * math.atan2(sh, q[0])
    res[0] = ang
    if sh == 0:
        res[1] = 0.0
        return
    a0, a1, a2 = q[1] / sh, q[2] / sh, q[3] / sh
    t0, t1, t2 = E[0, 3], E[1, 3], E[2, 3]
    slide = t0 * a0 + t1 * a1 + t2 * a2
    p0, p1, p2 = t0 - slide * a0, t1 - slide * a1, t2 - slide * a2
    tn = math.tan(ang / 2)
    f0 = 0.5 * (p0 + (a1 * p2 - a2 * p1) / tn)
    f1 = 0.5 * (p1 + (a2 * p0 - a0 * p2) / tn)
    f2 = 0.5 * (p2 + (a0 * p1 - a1 * p0) / tn)
    along = f0 * a0 + f1 * a1 + f2 * a2
    res[1] = slide
    res[2], res[3], res[4] = a0, a1, a2
    res[5], res[6], res[7] = f0 - along * a0, f1 - along * a1, f2 - along * a2


@_kernel
def _sign(x):
    if x > 0:
        return 1.0
    if x < 0:
        return -1.0
    if x == 0:
        return 0.0
    return np.nan


@_kernel
def _hf(x, a, b, g, d, p):
    c, s = math.cos(x / 2), math.sin(x / 2)
    return a * c + b * s + p * x * (g * c + d * s)


@_kernel
def _hdf(x, a, b, g, d, p):
    c, s = math.cos(x / 2), math.sin(x / 2)
    return 0.5 * (-a * s + b * c) + p * (g * c + d * s) + 0.5 * p * x * (-g * s + d * c)


@_kernel
def _h_roots(a, b, g, d, p, x, r):
    """Roots Δ ∈ (−π, π] of α cos Δ/2 + β sin Δ/2 + pΔ(γ cos Δ/2 + δ sin Δ/2), bracketed
    on the grid ``x`` and refined until every root has converged, rounded to 1e-12,
    ascending and distinct, into ``r``; returns their number."""
    n = len(x) - 1
    lo = np.empty(n)
    hi = np.empty(n)
    k = 0
    v0 = _hf(x[0], a, b, g, d, p)
    for i in range(n):
        v1 = _hf(x[i + 1], a, b, g, d, p)
        if _sign(v0) * _sign(v1) <= 0:
            lo[k], hi[k] = x[i], x[i + 1]
            k += 1
        v0 = v1
    for i in range(k):
        r[i] = 0.5 * (lo[i] + hi[i])
    for _ in range(60):                                 # safeguarded Newton
        done = True
        for i in range(k):
            fr = _hf(r[i], a, b, g, d, p)
            dr = _hdf(r[i], a, b, g, d, p)
            step = fr / (1e-300 if dr == 0 else dr)
            rn = r[i] - step
            bad = rn < lo[i] or rn > hi[i] or not math.isfinite(rn)
            if _sign(fr) == _sign(_hf(lo[i], a, b, g, d, p)):
                lo[i] = r[i]
            else:
                hi[i] = r[i]
            r[i] = 0.5 * (lo[i] + hi[i]) if bad else rn
            if not abs(step) < 1e-15:
                done = False
        if done:
            break
    for i in range(k):
        r[i] = np.rint(r[i] * 1e12) / 1e12
    r[:k].sort()
    m = 0
    for i in range(k):
        if i > 0 and r[i] == r[i - 1]:
            continue
        if r[i] > -math.pi or abs(r[i] - math.pi) <= 1e-8 + 1e-5 * math.pi:
            r[m] = r[i]
            m += 1
    return m


@_kernel
def revolute(code, u, m, p, pitch, D, length, angle, grid):
    """The R transition joints of n problems (J3 of kind ``code``: 0 R, 1 P, 2 H, 3 C).

    Parameters
    ----------
    u, m, p : (n, 3)  J3's directions, moments p × u and points at the transition position
    pitch, angle : (n,)  J3's pitch (H, length/rad) and rotation (C, rad)
    D : (n, 4, 4)  the displacement to the remaining position
    length : float  the task's reach (round-off thresholds)
    grid : (g + 1,)  the bracketing grid of the H roots on [−π, π]

    Returns
    -------
    owner : (r,) int  the problem of each joint (ascending)
    out : (r, 9)  Δ (rad), σ (length), the joint's angle ψ (rad), its axis (3) and foot
        point (3)
    error : (n,) int  0, or the code of the reason the problem has no joint
    value : (n,)  the number its message quotes (the slide left, or the angle)
    """
    n = D.shape[0]
    cap = n + 8
    owner = np.empty(cap, np.int64)
    out = np.empty((cap, 9))
    error = np.zeros(n, np.int64)
    value = np.zeros(n)
    q = np.empty(4)
    co = np.empty(4)
    E = np.empty((4, 4))
    res = np.empty(8)
    roots = np.empty(len(grid))
    sls = np.empty(len(grid))
    total = 0
    for i in range(n):
        _zero_slide(D[i], u[i], m[i], q, co)
        a, b, g, d = co[0], co[1], co[2], co[3]
        k = 1
        if code == 0:
            if math.hypot(a, b) < 1e-14 * (1 + length):
                error[i] = DEGENERATE_R
                continue
            dl = 2 * math.atan2(-a, b)
            roots[0], sls[0] = math.atan2(math.sin(dl), math.cos(dl)), 0.0
        elif code == 1:
            if abs(g) < 1e-12:
                error[i] = DEGENERATE_P
                continue
            roots[0], sls[0] = 0.0, -a / g
        elif code == 2:
            k = _h_roots(a, b, g, d, pitch[i], grid, roots)
            for j in range(k):
                sls[j] = pitch[i] * roots[j]
        else:
            c, s = math.cos(angle[i] / 2), math.sin(angle[i] / 2)
            den = g * c + d * s
            if abs(den) < 1e-12:
                error[i], value[i] = DEGENERATE_C, angle[i]
                continue
            roots[0] = math.atan2(math.sin(angle[i]), math.cos(angle[i]))
            sls[0] = -(a * c + b * s) / den
        if total + k > cap:
            cap = 2 * (total + k)
            o2, x2 = np.empty(cap, np.int64), np.empty((cap, 9))
            o2[:total], x2[:total] = owner[:total], out[:total]
            owner, out = o2, x2
        for j in range(k):
            _axis(D[i], u[i], p[i], roots[j], sls[j], q, E, res)
            if abs(res[0]) < 1e-9:
                error[i] = NO_TURN
                break
            if abs(res[1]) > 1e-8 * length:
                error[i], value[i] = NOT_PURE, res[1]
                break
            owner[total + j] = i
            out[total + j, 0], out[total + j, 1] = roots[j], sls[j]
            out[total + j, 2] = res[0]
            out[total + j, 3:] = res[2:]
        if error[i] == 0:
            total += k
    return owner[:total], out[:total], error, value
