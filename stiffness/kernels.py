"""Compiled hexapod kernels: the one evaluation path of :meth:`Hexapod.stiffness_batch`
and :meth:`Hexapod.map`.

:func:`stiffness_kernel` takes a batch of platform transforms ``T (B, 4, 4)`` and, in one
pass over the poses, checks each transform, builds every leg (platform point in the base
frame, leg vector, length, unit vector, moment) and sums ``K = Σ k_i w_i w_iᵀ`` over the
legs' Plücker lines ``w_i = (u_i, m_i)``: nothing but ``T`` is read and ``K`` written.
:func:`cond_kernel` takes the condition number of the dimensionless leg matrix from the
extreme eigenvalues of its 6x6 Gram matrix by cyclic Jacobi rotations; the caller
recomputes the poses whose figure exceeds :data:`stiffness.hexapod.GRAM_COND_LIMIT` by
singular values of :func:`scaled_leg_matrices` (squaring the condition would lose its
digits there).

Both kernels work on groups of :data:`LANES` poses held lane by lane (entry-major, pose
innermost), so that each step is one loop over the group's poses that the compiler
turns into SIMD instructions; every pose goes through the same operations in the same
order as it would alone, so a result does not depend on the batch it came in (a Jacobi
rotation that a pose does not need is the identity there, exactly).

numba compiles the kernels on first use (``cache=True``: once per installation, then
loaded from numba's cache; the first-call time is reported by ``linkwright bench
kernels``).  :mod:`stiffness.hexapod` imports this module when a batch is first
evaluated, so ``import stiffness`` does not import numba.  fastmath is off: every sum is
evaluated in the written order, without reassociation or fused multiply-adds.
"""
from __future__ import annotations

import math

import numpy as np

import numba

__all__ = ["LANES", "stiffness_kernel", "cond_kernel", "scaled_leg_matrices"]

#: poses per group of the kernels (their working arrays stay in the L1 cache)
LANES = 64
#: a Jacobi rotation is skipped where a_pq² ≤ this × |a_pp a_qq| (relative criterion)
_JACOBI_TOL2 = 1e-32
#: at most this many Jacobi sweeps (a 6x6 Gram matrix converges in 4 to 7)
_JACOBI_SWEEPS = 40

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")
#: small helpers of the lane loops, inlined by numba (the loops stay vectorisable)
_inline = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")


@_jit
def _gather(T, s0, m, X):
    """Entries ``T00 … T33`` (row by row) of poses ``s0 … s0 + m − 1`` into lanes
    ``0 … m − 1`` of ``X (16 LANES,)``: entry e of lane l at ``X[e LANES + l]``."""
    for e in range(16):
        r = e // 4
        j = e % 4
        for l in range(m):
            X[e * LANES + l] = T[s0 + l, r, j]


@_inline
def _transforms_ok(X, m, tol):
    """Whether the ``m`` transforms held in ``X`` are rigid to ``tol``: finite, last row
    (0, 0, 0, 1), rotation rows r0, r1 of unit length and orthogonal, r0 × r1 = r2 (as
    :func:`stiffness.validate.transform` checks; NaN fails every comparison)."""
    bad = False
    for l in range(m):
        a0, a1, a2 = X[l], X[LANES + l], X[2 * LANES + l]
        b0, b1, b2 = X[4 * LANES + l], X[5 * LANES + l], X[6 * LANES + l]
        ok = ((abs(a0 * a0 + a1 * a1 + a2 * a2 - 1.0) <= tol)
              & (abs(b0 * b0 + b1 * b1 + b2 * b2 - 1.0) <= tol)
              & (abs(a0 * b0 + a1 * b1 + a2 * b2) <= tol)
              & (abs(a1 * b2 - a2 * b1 - X[8 * LANES + l]) <= tol)
              & (abs(a2 * b0 - a0 * b2 - X[9 * LANES + l]) <= tol)
              & (abs(a0 * b1 - a1 * b0 - X[10 * LANES + l]) <= tol)
              & (abs(X[12 * LANES + l]) <= tol) & (abs(X[13 * LANES + l]) <= tol)
              & (abs(X[14 * LANES + l]) <= tol)
              & (abs(X[15 * LANES + l] - 1.0) <= tol)
              & (abs(X[3 * LANES + l]) < math.inf) & (abs(X[7 * LANES + l]) < math.inf)
              & (abs(X[11 * LANES + l]) < math.inf))
        bad = bad | (not ok)
    return not bad


@_inline
def _leg(X, l, p0, p1, p2, b0, b1, b2):
    """Leg vector ``d = R p + t − b`` (m) of the pose in lane ``l``, in the order of
    :meth:`Hexapod._leg_matrix`, and its length."""
    dx = (X[l] * p0 + X[LANES + l] * p1 + X[2 * LANES + l] * p2
          + X[3 * LANES + l] - b0)
    dy = (X[4 * LANES + l] * p0 + X[5 * LANES + l] * p1 + X[6 * LANES + l] * p2
          + X[7 * LANES + l] - b1)
    dz = (X[8 * LANES + l] * p0 + X[9 * LANES + l] * p1 + X[10 * LANES + l] * p2
          + X[11 * LANES + l] - b2)
    return dx, dy, dz, math.sqrt(dx * dx + dy * dy + dz * dz)


@_inline
def _accumulate(A, l, ki, u0, u1, u2, m0, m1, m2):
    """Add ``k w wᵀ`` (upper triangle, 21 entries) of the line ``w = (u, m)`` to lane l."""
    w0, w1, w2, w3, w4, w5 = ki * u0, ki * u1, ki * u2, ki * m0, ki * m1, ki * m2
    A[l] += w0 * u0
    A[LANES + l] += w0 * u1
    A[2 * LANES + l] += w0 * u2
    A[3 * LANES + l] += w0 * m0
    A[4 * LANES + l] += w0 * m1
    A[5 * LANES + l] += w0 * m2
    A[6 * LANES + l] += w1 * u1
    A[7 * LANES + l] += w1 * u2
    A[8 * LANES + l] += w1 * m0
    A[9 * LANES + l] += w1 * m1
    A[10 * LANES + l] += w1 * m2
    A[11 * LANES + l] += w2 * u2
    A[12 * LANES + l] += w2 * m0
    A[13 * LANES + l] += w2 * m1
    A[14 * LANES + l] += w2 * m2
    A[15 * LANES + l] += w3 * m0
    A[16 * LANES + l] += w3 * m1
    A[17 * LANES + l] += w3 * m2
    A[18 * LANES + l] += w4 * m1
    A[19 * LANES + l] += w4 * m2
    A[20 * LANES + l] += w5 * m2


@_jit
def stiffness_kernel(T, base, platform, k, platform_frame, tol, zero_leg, K):
    """Unloaded stiffness ``K = P diag(k) Pᵀ`` of every pose of a batch, in one pass.

    Parameters
    ----------
    T : numpy.ndarray, shape (B, 4, 4), float64
        Platform transforms in the base frame (rotation dimensionless, translation m).
    base : numpy.ndarray, shape (n, 3), float64
        Base attachment points, base frame (m).
    platform : numpy.ndarray, shape (n, 3), float64
        Platform attachment points, platform frame (m).
    k : numpy.ndarray, shape (n,), float64
        Axial leg stiffnesses (N/m).
    platform_frame : bool
        False: K about the base origin in base axes (moments ``b_i × u_i``); True: about
        the platform origin in platform axes (``u' = Rᵀ u``, moments ``p_i × u'``).
    tol : float
        Tolerance of the transform checks (dimensionless).
    zero_leg : float
        A leg not longer than this (m) has no direction.
    K : numpy.ndarray, shape (B, 6, 6), float64
        Output (blocks N/m, N/rad, N·m/rad).

    Returns
    -------
    pose : int
        −1 when every pose was evaluated; else the first pose found invalid (``K`` is
        written up to its group of :data:`LANES` poses).
    leg : int
        −1 if that pose's transform failed the checks; else its first leg of length
        ≤ ``zero_leg``.
    length : float
        That leg's length (m), 0 otherwise.
    """
    B = T.shape[0]
    n = base.shape[0]
    X = np.empty(16 * LANES)
    A = np.empty(21 * LANES)
    for s0 in range(0, B, LANES):
        m = min(LANES, B - s0)
        _gather(T, s0, m, X)
        if not _transforms_ok(X, m, tol):
            for l in range(m):
                _gather(T, s0 + l, 1, X)
                if not _transforms_ok(X, 1, tol):
                    return s0 + l, -1, 0.0
            _gather(T, s0, m, X)
        for j in range(21 * LANES):
            A[j] = 0.0
        short = False
        for i in range(n):
            p0, p1, p2 = platform[i, 0], platform[i, 1], platform[i, 2]
            b0, b1, b2 = base[i, 0], base[i, 1], base[i, 2]
            ki = k[i]
            if platform_frame:
                for l in range(m):
                    dx, dy, dz, L = _leg(X, l, p0, p1, p2, b0, b1, b2)
                    short = short | (not (L > zero_leg))
                    ux, uy, uz = dx / L, dy / L, dz / L
                    # u' = Rᵀ u, moment about the platform origin p × u' (platform axes)
                    vx = X[l] * ux + X[4 * LANES + l] * uy + X[8 * LANES + l] * uz
                    vy = X[LANES + l] * ux + X[5 * LANES + l] * uy + X[9 * LANES + l] * uz
                    vz = X[2 * LANES + l] * ux + X[6 * LANES + l] * uy + X[10 * LANES + l] * uz
                    _accumulate(A, l, ki, vx, vy, vz, p1 * vz - p2 * vy, p2 * vx - p0 * vz,
                                p0 * vy - p1 * vx)
            else:
                for l in range(m):
                    dx, dy, dz, L = _leg(X, l, p0, p1, p2, b0, b1, b2)
                    short = short | (not (L > zero_leg))
                    ux, uy, uz = dx / L, dy / L, dz / L
                    # moment about the base origin b × u (= p_world × u: p − b is along u)
                    _accumulate(A, l, ki, ux, uy, uz, b1 * uz - b2 * uy, b2 * ux - b0 * uz,
                                b0 * uy - b1 * ux)
        if short:
            for l in range(m):
                for i in range(n):
                    L = _leg(X, l, platform[i, 0], platform[i, 1], platform[i, 2],
                             base[i, 0], base[i, 1], base[i, 2])[3]
                    if not (L > zero_leg):
                        return s0 + l, i, L
        for l in range(m):
            o = K[s0 + l]
            j = 0
            for a in range(6):
                o[a, a] = A[j * LANES + l]
                j += 1
                for b in range(a + 1, 6):
                    o[a, b] = o[b, a] = A[j * LANES + l]
                    j += 1
    return -1, -1, 0.0


@_inline
def _scaled_column(X, l, p0, p1, p2, b0, b1, b2, q0, q1, q2, radius):
    """Column of the dimensionless leg matrix of lane l: the unit leg vector (base axes)
    and its moment about the platform points' centroid divided by ``radius``,
    ``(R q) × u / radius`` with ``q = p − c`` in platform coordinates (a far base origin
    cancels no digits)."""
    dx, dy, dz, L = _leg(X, l, p0, p1, p2, b0, b1, b2)
    ux, uy, uz = dx / L, dy / L, dz / L
    x = X[l] * q0 + X[LANES + l] * q1 + X[2 * LANES + l] * q2
    y = X[4 * LANES + l] * q0 + X[5 * LANES + l] * q1 + X[6 * LANES + l] * q2
    z = X[8 * LANES + l] * q0 + X[9 * LANES + l] * q1 + X[10 * LANES + l] * q2
    return (ux, uy, uz, (y * uz - z * uy) / radius, (z * ux - x * uz) / radius,
            (x * uy - y * ux) / radius)


@_jit
def scaled_leg_matrices(T, base, platform, centroid, radius, Ps):
    """The dimensionless leg matrices of checked poses, for their singular values.

    Parameters
    ----------
    T : numpy.ndarray, shape (B, 4, 4), float64
        Checked platform transforms (no leg of zero length).
    base, platform : numpy.ndarray, shape (n, 3), float64
        Attachment points, base and platform frame (m).
    centroid : numpy.ndarray, shape (3,), float64
        Centroid of the platform points, platform frame (m).
    radius : float
        Platform radius (m).
    Ps : numpy.ndarray, shape (B, 6, n), float64
        Output: columns ``(u, (R (p − c)) × u / radius)`` (dimensionless), the matrices
        whose Gram matrices :func:`cond_kernel` takes, entry for entry.
    """
    X = np.empty(16 * LANES)
    for s in range(T.shape[0]):
        _gather(T, s, 1, X)
        for i in range(base.shape[0]):
            col = _scaled_column(X, 0, platform[i, 0], platform[i, 1], platform[i, 2],
                                 base[i, 0], base[i, 1], base[i, 2], platform[i, 0] - centroid[0],
                                 platform[i, 1] - centroid[1], platform[i, 2] - centroid[2],
                                 radius)
            for a in range(6):
                Ps[s, a, i] = col[a]


@_jit
def _jacobi(A, cs, ss, m):
    """Diagonalise the symmetric 6x6 matrices of lanes ``l < m`` (entry (p, q) at
    ``A[(6 p + q) LANES + l]``, upper triangles read) by cyclic Jacobi rotations in place:
    their eigenvalues end on the diagonal.

    A rotation is the identity where ``a_pq² ≤ ε² |a_pp a_qq|`` (relative criterion: the
    small eigenvalues of a positive semidefinite matrix keep their digits); the sweeps end
    when no lane rotates.  ``t = sgn(d) h / (|d| + sqrt(d² + h²))`` with ``d = a_qq − a_pp``,
    ``h = 2 a_pq`` is the tangent of the smaller rotation angle.
    """
    for _ in range(_JACOBI_SWEEPS):
        rot = False
        for p in range(5):
            for q in range(p + 1, 6):
                for l in range(m):
                    apq = A[(p * 6 + q) * LANES + l]
                    app = A[(p * 6 + p) * LANES + l]
                    aqq = A[(q * 6 + q) * LANES + l]
                    do = apq * apq > _JACOBI_TOL2 * abs(app * aqq)
                    d = aqq - app
                    h = 2.0 * apq
                    t = h / (abs(d) + math.sqrt(d * d + h * h))
                    t = -t if d < 0.0 else t
                    t = t if do else 0.0
                    c = 1.0 / math.sqrt(t * t + 1.0)
                    cs[l] = c
                    ss[l] = t * c
                    A[(p * 6 + p) * LANES + l] = app - t * apq
                    A[(q * 6 + q) * LANES + l] = aqq + t * apq
                    A[(p * 6 + q) * LANES + l] = 0.0 if do else apq
                    rot = rot | do
                for r in range(p):
                    for l in range(m):
                        x = A[(r * 6 + p) * LANES + l]
                        y = A[(r * 6 + q) * LANES + l]
                        A[(r * 6 + p) * LANES + l] = cs[l] * x - ss[l] * y
                        A[(r * 6 + q) * LANES + l] = ss[l] * x + cs[l] * y
                for r in range(p + 1, q):
                    for l in range(m):
                        x = A[(p * 6 + r) * LANES + l]
                        y = A[(r * 6 + q) * LANES + l]
                        A[(p * 6 + r) * LANES + l] = cs[l] * x - ss[l] * y
                        A[(r * 6 + q) * LANES + l] = ss[l] * x + cs[l] * y
                for r in range(q + 1, 6):
                    for l in range(m):
                        x = A[(p * 6 + r) * LANES + l]
                        y = A[(q * 6 + r) * LANES + l]
                        A[(p * 6 + r) * LANES + l] = cs[l] * x - ss[l] * y
                        A[(q * 6 + r) * LANES + l] = ss[l] * x + cs[l] * y
        if not rot:
            break


@_jit
def cond_kernel(T, base, platform, centroid, radius, c):
    """cond(P) of the dimensionless leg matrix of every pose, from its Gram matrix.

    Parameters
    ----------
    T : numpy.ndarray, shape (B, 4, 4), float64
        Checked platform transforms in the base frame (no leg of zero length).
    base, platform : numpy.ndarray, shape (n, 3), float64
        Attachment points, base and platform frame (m).
    centroid : numpy.ndarray, shape (3,), float64
        Centroid of the platform points, platform frame (m): the moments' reference.
    radius : float
        Platform radius (m): the moments are divided by it.
    c : numpy.ndarray, shape (B,), float64
        Output: ``sqrt(λmax / λmin)`` of ``Ps Psᵀ`` (dimensionless; inf where λmin = 0,
        NaN where rounding made it negative), ``Ps`` as :func:`scaled_leg_matrices`
        gives it.  Exact to about ``cond² ε`` relative: the caller recomputes by singular
        values where it exceeds the Gram limit.
    """
    B = T.shape[0]
    n = base.shape[0]
    X = np.empty(16 * LANES)
    A = np.empty(36 * LANES)
    cs = np.empty(LANES)
    ss = np.empty(LANES)
    for s0 in range(0, B, LANES):
        m = min(LANES, B - s0)
        _gather(T, s0, m, X)
        for j in range(36 * LANES):
            A[j] = 0.0
        for i in range(n):
            p0, p1, p2 = platform[i, 0], platform[i, 1], platform[i, 2]
            b0, b1, b2 = base[i, 0], base[i, 1], base[i, 2]
            q0, q1, q2 = p0 - centroid[0], p1 - centroid[1], p2 - centroid[2]
            for l in range(m):
                v0, v1, v2, v3, v4, v5 = _scaled_column(X, l, p0, p1, p2, b0, b1, b2, q0, q1,
                                                        q2, radius)
                A[l] += v0 * v0
                A[LANES + l] += v0 * v1
                A[2 * LANES + l] += v0 * v2
                A[3 * LANES + l] += v0 * v3
                A[4 * LANES + l] += v0 * v4
                A[5 * LANES + l] += v0 * v5
                A[7 * LANES + l] += v1 * v1
                A[8 * LANES + l] += v1 * v2
                A[9 * LANES + l] += v1 * v3
                A[10 * LANES + l] += v1 * v4
                A[11 * LANES + l] += v1 * v5
                A[14 * LANES + l] += v2 * v2
                A[15 * LANES + l] += v2 * v3
                A[16 * LANES + l] += v2 * v4
                A[17 * LANES + l] += v2 * v5
                A[21 * LANES + l] += v3 * v3
                A[22 * LANES + l] += v3 * v4
                A[23 * LANES + l] += v3 * v5
                A[28 * LANES + l] += v4 * v4
                A[29 * LANES + l] += v4 * v5
                A[35 * LANES + l] += v5 * v5
        _jacobi(A, cs, ss, m)
        for l in range(m):
            lo = hi = A[l]
            for a in range(1, 6):
                lo = min(lo, A[(a * 6 + a) * LANES + l])
                hi = max(hi, A[(a * 6 + a) * LANES + l])
            if lo > 0.0:
                c[s0 + l] = math.sqrt(hi / lo)
            elif lo == 0.0:
                c[s0 + l] = math.inf
            else:
                c[s0 + l] = math.nan
