"""Compiled kernels of the helical root searches: the misfit grids and Levenberg–Marquardt
of :func:`synthesis.helical_links` (HH, RH, HR) and :func:`synthesis.hs_links` (HS, SH).

Slide = pitch · angle makes these equations transcendental, so their solutions are found
by refining the local minima of a misfit on a grid of starting points.  Both steps run
here, compiled, one small system after another:

* the residual functions (a helical link's six translation equations for a fixed-axis
  direction, the HS link's nine for an elevation and three helical angles), each with
  its linear unknowns (the axes' points, the sphere centre) projected out;
* the misfit on a grid of directions (HH) or of (elevation, angles) (HS), and the HS
  grid's local minima as starting points (:func:`hs_starts`, every circle of a task in
  one call);
* one Levenberg–Marquardt, compiled once per residual (Jacobian by forward differences
  for HH, exact for HS, from the residual's own factorisation), its residual's call
  chain inlined;
* the HS equations of many converged starts, for their least-squares points.

The HS search does, operation for operation, what it did as numpy-driven kernels one
circle at a time (the same grid values, minima, iterates and roots, bit for bit), at
about half the time: the grid's 5x5 factorisations side by side in SIMD lanes
(:func:`_misfit_lanes`), the residual's factorisation reused by its Jacobian, the
Jacobian's four columns built side by side, one padded grid reused for every circle,
and no Python between the steps of a circle.

Inlining (numba's ``inline="always"``) pays where a small function runs in a tight loop
(the HH equations in the grid: 2× faster), but every inlined call site is a copy to
compile: the Levenberg–Marquardt calls each residual from two places only, and the HH
residual, the HH equations inlined into it, is one compiled function it calls (half the
time of calling the equations themselves, whose array arguments the residual then
passed one by one; inlining the whole residual at both call sites saved another 10 %
for 13 s more first compile, measured).  The HH equations keep their intermediates in
local scalars, not scratch arrays (the compiler must take views of one scratch array
for aliases of each other, and goes through memory: 10–15 % slower, measured).

numba compiles them on first use (``cache=True``: once per installation, then loaded
from the cache); :mod:`synthesis.helical` and :mod:`synthesis.spherical` import this
module only when a helical search runs, so ``import synthesis`` does not import numba.
"""
from __future__ import annotations

import math

import numpy as np

import numba

_kernel = numba.njit(cache=True, nogil=True, error_model="numpy")
#: the residuals' call chain, inlined into the search (a call passes ~20 array structs)
_inline = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")


# ------------------------------------------------------------------ small linear algebra
@_inline
def _perp3t(u0, u1, u2):
    """Two unit vectors completing unit u to a right-handed frame (as ``binary._perp``):
    their six components."""
    if abs(u0) < 0.9:
        a0, a1, a2 = 1.0, 0.0, 0.0
    else:
        a0, a1, a2 = 0.0, 1.0, 0.0
    d = a0 * u0 + a1 * u1 + a2 * u2
    e0, e1, e2 = a0 - d * u0, a1 - d * u1, a2 - d * u2
    n = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    e0, e1, e2 = e0 / n, e1 / n, e2 / n
    return e0, e1, e2, u1 * e2 - u2 * e1, u2 * e0 - u0 * e2, u0 * e1 - u1 * e0


@_inline
def _perp3(u, e1, e2):
    """:func:`_perp3t` of u (3,) into e1, e2 (3,)."""
    e1[0], e1[1], e1[2], e2[0], e2[1], e2[2] = _perp3t(u[0], u[1], u[2])


@_inline
def _rot3(u, ang, out):
    """Rotation about unit u by ang (Rodrigues), as ``binary._rot``."""
    _rot3cs(u, math.cos(ang), math.sin(ang), out)


@_inline
def _rot3cst(u0, u1, u2, c, s):
    """Rotation about unit u by the angle of cosine c and sine s: its nine entries, row by
    row."""
    C = 1.0 - c
    return (1.0 + C * (-u2 * u2 - u1 * u1), -s * u2 + C * u0 * u1, s * u1 + C * u0 * u2,
            s * u2 + C * u0 * u1, 1.0 + C * (-u2 * u2 - u0 * u0), -s * u0 + C * u1 * u2,
            -s * u1 + C * u0 * u2, s * u0 + C * u1 * u2, 1.0 + C * (-u1 * u1 - u0 * u0))


@_inline
def _rot3cs(u, c, s, out):
    """:func:`_rot3cst` of u (3,) into out (3, 3)."""
    (out[0, 0], out[0, 1], out[0, 2], out[1, 0], out[1, 1], out[1, 2], out[2, 0], out[2, 1],
     out[2, 2]) = _rot3cst(u[0], u[1], u[2], c, s)


@_inline
def _signed_angle3t(a0, a1, a2, b0, b1, b2, u0, u1, u2):
    """Angle about u from a to b (their components ⊥ u), as ``binary._signed_angle``, and
    that rotation about u (:func:`_rot3cst`), its cosine and sine taken from the two
    components (no trigonometric call; the identity where a or b is parallel to u)."""
    cx = a1 * b2 - a2 * b1
    cy = a2 * b0 - a0 * b2
    cz = a0 * b1 - a1 * b0
    ab = a0 * b0 + a1 * b1 + a2 * b2
    au = a0 * u0 + a1 * u1 + a2 * u2
    bu = b0 * u0 + b1 * u1 + b2 * u2
    y, x = u0 * cx + u1 * cy + u2 * cz, ab - au * bu
    r = math.sqrt(x * x + y * y)
    c, s = (x / r, y / r) if r > 0.0 else (1.0, 0.0)
    return math.atan2(y, x), _rot3cst(u0, u1, u2, c, s)


@_inline
def _mat_vec(M, x0, x1, x2):
    """M x for a 3x3 matrix M given as its nine entries, row by row."""
    return (M[0] * x0 + M[1] * x1 + M[2] * x2, M[3] * x0 + M[4] * x1 + M[5] * x2,
            M[6] * x0 + M[7] * x1 + M[8] * x2)


@_inline
def _cholesky(M):
    """M = L Lᵀ in place (the lower triangle of a small symmetric positive definite M read,
    overwritten by L); False where a pivot is not positive or not finite."""
    n = M.shape[0]
    for j in range(n):
        d = M[j, j]
        for k in range(j):
            d -= M[j, k] * M[j, k]
        if not d > 0.0 or not math.isfinite(d):
            return False
        d = math.sqrt(d)
        M[j, j] = d
        for i in range(j + 1, n):
            s = M[i, j]
            for k in range(j):
                s -= M[i, k] * M[j, k]
            M[i, j] = s / d
    return True


@_inline
def _forward(L, v, y):
    """y = L⁻¹ v for a lower triangular L (y may be v)."""
    for i in range(L.shape[0]):
        s = v[i]
        for k in range(i):
            s -= L[i, k] * y[k]
        y[i] = s / L[i, i]


@_inline
def _spd_solve(M, v, x):
    """x = M⁻¹ v for a small symmetric positive definite M (Cholesky, M overwritten by its
    factor, v kept).  False (x zero) where a pivot is not positive or not finite."""
    if not _cholesky(M):
        x[:] = 0.0
        return False
    _forward(M, v, x)
    for i in range(M.shape[0] - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, M.shape[0]):
            s -= M[k, i] * x[k]
        x[i] = s / M[i, i]
    return True


@_kernel
def _solve(M, v, x):
    """x = M⁻¹ v by Gaussian elimination with partial pivoting (M, v overwritten).  False
    (x zero) for an exactly singular M."""
    n = M.shape[0]
    for j in range(n):
        p = j
        for i in range(j + 1, n):
            if abs(M[i, j]) > abs(M[p, j]):
                p = i
        if M[p, j] == 0.0:
            x[:] = 0.0
            return False
        if p != j:
            for k in range(n):
                M[j, k], M[p, k] = M[p, k], M[j, k]
            v[j], v[p] = v[p], v[j]
        for i in range(j + 1, n):
            f = M[i, j] / M[j, j]
            for k in range(j, n):
                M[i, k] -= f * M[j, k]
            v[i] -= f * v[j]
    for i in range(n - 1, -1, -1):
        s = v[i]
        for k in range(i + 1, n):
            s -= M[i, k] * x[k]
        x[i] = s / M[i, i]
    return True


@_kernel
def _scratch():
    """Scratch arrays of the residuals, allocated once per search (an allocation, or a
    tuple of arrays passed down, costs more than a residual; so they are passed one by
    one): the HS residual's vectors V (7, 3) and 3x3 matrices Ms (3, 3, 3), the HH
    equations A6 (6, 4), rhs6 (6,) and their normal equations M (4, 4), b, x (4,); the HS
    equations' A9 (9, 5) (for :func:`hs_systems`' layout; the search builds it transposed
    in Q), rhs9 (9,) and Gram–Schmidt Q (5, 9)."""
    return (np.zeros((7, 3)), np.zeros((3, 3, 3)), np.zeros((6, 4)), np.zeros(6),
            np.zeros((4, 4)), np.zeros(4), np.zeros(4), np.zeros((9, 5)), np.zeros(9),
            np.zeros((5, 9)))


# ------------------------------------------------------------------ HH, RH, HR links
@_inline
def _hh_equations(g0, g1, g2, R, t, pn, A, rhs):
    """A helical link's translation equations for the fixed-axis direction g = (g0, g1, g2)
    through the rotations R (2, 3, 3) and translations t (2, 3) of positions 2, 3,
    pitches pn (2,) (normalised length / rad): fills A (6, 4), rhs (6,) as
    ``helical._equations``, the moving direction w, the joint rotations θ_j, φ_j and
    their rotation matrices local scalars (see the module notes).  Returns (|w| before
    normalising, |g × w|): the direction pair is valid where both exceed 1e-9."""
    a00 = (R[0, 0, 0] * g0 + R[0, 1, 0] * g1 + R[0, 2, 0] * g2) - g0       # (R_j − I)ᵀ g
    a01 = (R[0, 0, 1] * g0 + R[0, 1, 1] * g1 + R[0, 2, 1] * g2) - g1
    a02 = (R[0, 0, 2] * g0 + R[0, 1, 2] * g1 + R[0, 2, 2] * g2) - g2
    a10 = (R[1, 0, 0] * g0 + R[1, 1, 0] * g1 + R[1, 2, 0] * g2) - g0
    a11 = (R[1, 0, 1] * g0 + R[1, 1, 1] * g1 + R[1, 2, 1] * g2) - g1
    a12 = (R[1, 0, 2] * g0 + R[1, 1, 2] * g1 + R[1, 2, 2] * g2) - g2
    w0, w1, w2 = a01 * a12 - a02 * a11, a02 * a10 - a00 * a12, a00 * a11 - a01 * a10
    wn = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    if wn > 1e-9:
        w0, w1, w2 = w0 / wn, w1 / wn, w2 / wn
    else:
        w0, w1, w2 = 0.0, 0.0, 1.0
    gw = g0 * w0 + g1 * w1 + g2 * w2
    v0, v1, v2 = g0 - gw * w0, g1 - gw * w1, g2 - gw * w2
    e10, e11, e12, e20, e21, e22 = _perp3t(g0, g1, g2)
    f10, f11, f12, f20, f21, f22 = _perp3t(w0, w1, w2)
    for m in range(2):
        Rm = R[m]
        x0, x1, x2 = _mat_vec((Rm[0, 0], Rm[0, 1], Rm[0, 2], Rm[1, 0], Rm[1, 1], Rm[1, 2],
                               Rm[2, 0], Rm[2, 1], Rm[2, 2]), w0, w1, w2)             # R_j w
        th, G = _signed_angle3t(w0, w1, w2, x0, x1, x2, g0, g1, g2)
        M = (G[0] * Rm[0, 0] + G[3] * Rm[1, 0] + G[6] * Rm[2, 0],           # Gᵀ R_j
             G[0] * Rm[0, 1] + G[3] * Rm[1, 1] + G[6] * Rm[2, 1],
             G[0] * Rm[0, 2] + G[3] * Rm[1, 2] + G[6] * Rm[2, 2],
             G[1] * Rm[0, 0] + G[4] * Rm[1, 0] + G[7] * Rm[2, 0],
             G[1] * Rm[0, 1] + G[4] * Rm[1, 1] + G[7] * Rm[2, 1],
             G[1] * Rm[0, 2] + G[4] * Rm[1, 2] + G[7] * Rm[2, 2],
             G[2] * Rm[0, 0] + G[5] * Rm[1, 0] + G[8] * Rm[2, 0],
             G[2] * Rm[0, 1] + G[5] * Rm[1, 1] + G[8] * Rm[2, 1],
             G[2] * Rm[0, 2] + G[5] * Rm[1, 2] + G[8] * Rm[2, 2])
        x0, x1, x2 = _mat_vec(M, v0, v1, v2)
        ph, W = _signed_angle3t(v0, v1, v2, x0, x1, x2, w0, w1, w2)
        r = 3 * m
        x0, x1, x2 = _mat_vec(G, e10, e11, e12)
        A[r, 0], A[r + 1, 0], A[r + 2, 0] = e10 - x0, e11 - x1, e12 - x2
        x0, x1, x2 = _mat_vec(G, e20, e21, e22)
        A[r, 1], A[r + 1, 1], A[r + 2, 1] = e20 - x0, e21 - x1, e22 - x2
        x0, x1, x2 = _mat_vec(W, f10, f11, f12)
        A[r, 2], A[r + 1, 2], A[r + 2, 2] = _mat_vec(G, f10 - x0, f11 - x1, f12 - x2)
        x0, x1, x2 = _mat_vec(W, f20, f21, f22)
        A[r, 3], A[r + 1, 3], A[r + 2, 3] = _mat_vec(G, f20 - x0, f21 - x1, f22 - x2)
        x0, x1, x2 = _mat_vec(G, w0, w1, w2)
        rhs[r] = t[m, 0] - pn[0] * th * g0 - pn[1] * ph * x0
        rhs[r + 1] = t[m, 1] - pn[0] * th * g1 - pn[1] * ph * x1
        rhs[r + 2] = t[m, 2] - pn[0] * th * g2 - pn[1] * ph * x2
    q0, q1, q2 = g1 * w2 - g2 * w1, g2 * w0 - g0 * w2, g0 * w1 - g1 * w0
    return wn, math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)


@_inline
def _normal6(A, rhs, M, b):
    """Normal equations M = AᵀA + 1e-14 I (4, 4), b = Aᵀ rhs (4,) of A (6, 4), rhs (6,)."""
    for i in range(4):
        for j in range(i + 1):
            s = 0.0
            for r in range(6):
                s += A[r, i] * A[r, j]
            M[i, j] = s
            M[j, i] = s
        M[i, i] += 1e-14
        s = 0.0
        for r in range(6):
            s += A[r, i] * rhs[r]
        b[i] = s


@_inline
def _hh_normal(g0, g1, g2, R, t, pn, A, rhs, M, b):
    """The six equations for direction g (A (6, 4), rhs (6,)) and their normal equations
    (:func:`_normal6`) (scratch as :func:`_scratch`); returns the validity of g."""
    wn, sgw = _hh_equations(g0, g1, g2, R, t, pn, A, rhs)
    _normal6(A, rhs, M, b)
    return wn > 1e-9 and sgw > 1e-9


@_inline
def _hh_misfit(g0, g1, g2, R, t, pn, f, A, rhs, M, b, x):
    """The six equations' least-squares misfit vector f (6,) for direction g, the points
    solved by normal equations; returns the validity of g."""
    ok = _hh_normal(g0, g1, g2, R, t, pn, A, rhs, M, b)
    _spd_solve(M, b, x)
    for i in range(4):
        if not math.isfinite(x[i]):
            x[i] = 0.0
    for r in range(6):
        f[r] = A[r, 0] * x[0] + A[r, 1] * x[1] + A[r, 2] * x[2] + A[r, 3] * x[3] - rhs[r]
    return ok


@_kernel
def hh_grid(G, R, t, pn):
    """Misfit (n,) of the helical link's equations for the fixed-axis directions G (n, 3)
    (R, t, pn as :func:`_hh_equations`), from the normal equations (:func:`_misfit`);
    inf where the direction pair is not valid."""
    n = G.shape[0]
    out = np.empty(n)
    _, _, A, rhs, M, b, _, _, _, _ = _scratch()
    for k in range(n):
        wn, sgw = _hh_equations(G[k, 0], G[k, 1], G[k, 2], R, t, pn, A, rhs)
        if wn > 1e-9 and sgw > 1e-9:
            _normal6(A, rhs, M, b)
            rr = 0.0
            for r in range(6):
                rr += rhs[r] * rhs[r]
            out[k] = _misfit(M, b, rr)
        else:
            out[k] = np.inf
    return out


@_kernel
def _hh_residual(z, base, R, t, pn, f, A, rhs, M, b, x):
    """Residual f (6,) at tangent coordinates z (2,) about base = (g0, e1, e2) (3, 3):
    the direction g = normalise(g0 + z₁ e1 + z₂ e2) (scratch as :func:`_scratch`)."""
    g0 = base[0, 0] + z[0] * base[1, 0] + z[1] * base[2, 0]
    g1 = base[0, 1] + z[0] * base[1, 1] + z[1] * base[2, 1]
    g2 = base[0, 2] + z[0] * base[1, 2] + z[1] * base[2, 2]
    n = math.sqrt(g0 * g0 + g1 * g1 + g2 * g2)
    _hh_misfit(g0 / n, g1 / n, g2 / n, R, t, pn, f, A, rhs, M, b, x)


# ------------------------------------------------------------------ HS links
@_inline
def _hs_rows(g, th, R, t, p, A, rhs, V, G):
    """Position j's three HS translation equations ``(R_j − G_j) C + (G_j − I) c = p θ g
    − t_j`` for the axis direction g (3,) and helical angle θ: A (3, 5) (sphere centre C,
    then the axis point's coordinates on ``_perp(g)``), rhs (3,); R (3, 3), t (3,);
    V (2, 3), G (3, 3) scratch."""
    e1, e2 = V[0], V[1]
    _rot3(g, th, G)
    _perp3(g, e1, e2)
    for i in range(3):
        for j in range(3):
            A[i, j] = R[i, j] - G[i, j]
        A[i, 3] = G[i, 0] * e1[0] + G[i, 1] * e1[1] + G[i, 2] * e1[2] - e1[i]
        A[i, 4] = G[i, 0] * e2[0] + G[i, 1] * e2[1] + G[i, 2] * e2[2] - e2[i]
        rhs[i] = p * th * g[i] - t[i]


@_kernel
def hs_systems(g, th, R, t, p):
    """The nine HS equations for each axis direction g (M, 3) and angles θ (M, 3):
    A (M, 9, 5), rhs (M, 9) (R (3, 3, 3), t (3, 3), pitch p)."""
    m = g.shape[0]
    A, rhs = np.empty((m, 9, 5)), np.empty((m, 9))
    V, G = np.empty((2, 3)), np.empty((3, 3))
    for k in range(m):
        for j in range(3):
            _hs_rows(g[k], th[k, j], R[j], t[j], p, A[k, 3 * j:3 * j + 3],
                     rhs[k, 3 * j:3 * j + 3], V, G)
    return A, rhs


@_inline
def _hs_eval(z, a, b, R, t, p, f, V, Ms, rhs, Q, W):
    """The nine HS equations at z = (β, θ₂, θ₃, θ₄), the axis direction g = cos β a + sin β b
    (R (3, 3, 3), t (3, 3), pitch p), and their residual off the range of their matrix A
    (9, 5): fills rhs (9,) and Aᵀ (as :func:`_hs_rows`) into Q (5, 9), then its modified
    Gram–Schmidt factorisation A = Qᵀ U (Q in place, U = W[:5, :5]), and the residual
    f (9,) = P rhs − rhs (P the projector on A's columns, projected column by column:
    backward stable, Björck & Paige 1992; a zero column skipped); keeps g, dg/dβ, e1, e2,
    cos θ_j, sin θ_j in V[0:6] and the rotations G_j in Ms for :func:`_hs_jac`.  Returns
    (|f|², inf where not finite; whether A has full rank, i.e. the Jacobian exists)."""
    g, gp, e1, e2, cs, sn = V[0], V[1], V[2], V[3], V[4], V[5]
    U = W[0:5, 0:5]
    cb, sb = math.cos(z[0]), math.sin(z[0])
    for i in range(3):
        g[i] = cb * a[i] + sb * b[i]
        gp[i] = -sb * a[i] + cb * b[i]                                  # dg/dβ
    _perp3(g, e1, e2)
    for j in range(3):
        th = z[1 + j]
        c, s = math.cos(th), math.sin(th)
        cs[j], sn[j] = c, s
        G = Ms[j]
        _rot3cs(g, c, s, G)
        for i in range(3):
            r = 3 * j + i
            for k in range(3):
                Q[k, r] = R[j, i, k] - G[i, k]
            Q[3, r] = G[i, 0] * e1[0] + G[i, 1] * e1[1] + G[i, 2] * e1[2] - e1[i]
            Q[4, r] = G[i, 0] * e2[0] + G[i, 1] * e2[1] + G[i, 2] * e2[2] - e2[i]
            rhs[r] = p * th * g[i] - t[j, i]
            f[r] = rhs[r]
    full = True
    for j in range(5):                  # modified Gram–Schmidt on Q's rows, in place
        for k in range(j):
            d = 0.0
            for i in range(9):
                d += Q[k, i] * Q[j, i]
            U[k, j] = d
            for i in range(9):
                Q[j, i] -= d * Q[k, i]
        d = 0.0
        for i in range(9):
            d += Q[j, i] * Q[j, i]
        d = math.sqrt(d)
        if not d > 0.0:
            full = False
            if d == 0.0:
                continue                            # a zero column: nothing to project
        U[j, j] = d
        for k in range(j + 1, 5):
            U[k, j] = 0.0
        for i in range(9):
            Q[j, i] /= d
        d = 0.0
        for i in range(9):
            d += Q[j, i] * f[i]
        for i in range(9):
            f[i] -= d * Q[j, i]
    cost = 0.0
    for i in range(9):
        f[i] = -f[i]
        cost += f[i] * f[i]
    return (cost if math.isfinite(cost) else np.inf), full


@_inline
def _hs_jac(z, p, f, J, V, Ms, rhs, Q, W, X):
    """Jacobian J (9, 4) of the HS residual f (9,) at the point z of the last
    :func:`_hs_eval` (its factorisation of full rank), exact (Golub & Pereyra 1973): with
    x = A⁺ rhs = U⁻¹ Q rhs, column k is ``(I − QᵀQ)(∂A_k x − ∂rhs_k) − Qᵀ U⁻ᵀ ∂A_kᵀ f``.
    Position j's rows ``[R_j − G_j | (G_j − I) e1 | (G_j − I) e2]`` change with θ_j and β
    through G_j only (the residual depends on A's column space, which e1, e2 ⊥ g do not
    change), so ``∂A_j x = D (c − C)`` with D = ∂G_j (C the centre, c the axis point):
    ``D = ∂G_j/∂β`` (:func:`_dg_times`; Dᵀ is D at −θ_j) for column 0, ``D = [g]× G_j`` for
    column 1 + j.  The four columns are built side by side (X (4, 9, 4) scratch: ∂A x −
    ∂rhs, ∂Aᵀ f, U⁻ᵀ ∂Aᵀ f, Q (∂A x − ∂rhs) + U⁻ᵀ ∂Aᵀ f, a column each)."""
    g, gp, e1, e2, cs, sn = V[0], V[1], V[2], V[3], V[4], V[5]
    dv = V[6]
    U, x, y = W[0:5, 0:5], W[5, 0:5], W[6, 0:5]
    uu, w, yy, qu = X[0], X[1], X[2], X[3]
    for k in range(5):                               # x = U⁻¹ Q rhs
        d = 0.0
        for i in range(9):
            d += Q[k, i] * rhs[i]
        y[k] = d
    for k in range(4, -1, -1):
        d = y[k]
        for m in range(k + 1, 5):
            d -= U[k, m] * x[m]
        x[k] = d / U[k, k]
    u0 = x[3] * e1[0] + x[4] * e2[0] - x[0]                         # c − C
    u1 = x[3] * e1[1] + x[4] * e2[1] - x[1]
    u2 = x[3] * e1[2] + x[4] * e2[2] - x[2]
    for m in range(5):
        for c in range(4):
            w[m, c] = 0.0
    for i in range(9):
        for c in range(1, 4):
            uu[i, c] = 0.0
    for j in range(3):
        th = z[1 + j]
        fj = f[3 * j:3 * j + 3]
        omc = 1.0 - cs[j]                                             # column 0
        dv[0], dv[1], dv[2] = u0, u1, u2
        _dg_times(g, gp, sn[j], omc, dv, dv)
        for i in range(3):
            uu[3 * j + i, 0] = dv[i] - p * th * gp[i]
        _dg_times(g, gp, -sn[j], omc, fj, dv)
        w[0, 0] -= dv[0]
        w[1, 0] -= dv[1]
        w[2, 0] -= dv[2]
        w[3, 0] += e1[0] * dv[0] + e1[1] * dv[1] + e1[2] * dv[2]
        w[4, 0] += e2[0] * dv[0] + e2[1] * dv[1] + e2[2] * dv[2]
        G, c = Ms[j], 1 + j                                           # column 1 + j
        d0 = G[0, 0] * u0 + G[0, 1] * u1 + G[0, 2] * u2               # G_j (c − C)
        d1 = G[1, 0] * u0 + G[1, 1] * u1 + G[1, 2] * u2
        d2 = G[2, 0] * u0 + G[2, 1] * u1 + G[2, 2] * u2
        uu[3 * j, c] = (g[1] * d2 - g[2] * d1) - p * g[0]
        uu[3 * j + 1, c] = (g[2] * d0 - g[0] * d2) - p * g[1]
        uu[3 * j + 2, c] = (g[0] * d1 - g[1] * d0) - p * g[2]
        t0 = fj[1] * g[2] - fj[2] * g[1]                              # Dᵀ f = G_jᵀ (f × g)
        t1 = fj[2] * g[0] - fj[0] * g[2]
        t2 = fj[0] * g[1] - fj[1] * g[0]
        d0 = G[0, 0] * t0 + G[1, 0] * t1 + G[2, 0] * t2
        d1 = G[0, 1] * t0 + G[1, 1] * t1 + G[2, 1] * t2
        d2 = G[0, 2] * t0 + G[1, 2] * t1 + G[2, 2] * t2
        w[0, c] -= d0
        w[1, c] -= d1
        w[2, c] -= d2
        w[3, c] += e1[0] * d0 + e1[1] * d1 + e1[2] * d2
        w[4, c] += e2[0] * d0 + e2[1] * d1 + e2[2] * d2
    for k in range(5):                                                # U⁻ᵀ ∂Aᵀ f
        for c in range(4):
            d = w[k, c]
            for m in range(k):
                d -= U[m, k] * yy[m, c]
            yy[k, c] = d / U[k, k]
    for k in range(5):
        for c in range(4):
            d = 0.0
            for i in range(9):
                d += Q[k, i] * uu[i, c]
            qu[k, c] = d + yy[k, c]
    for i in range(9):                                                # project
        for c in range(4):
            d = uu[i, c]
            for k in range(5):
                d -= Q[k, i] * qu[k, c]
            J[i, c] = d


@_kernel
def _hs_residual(z, a, b, R, t, p, f, V, Ms, A, rhs, Q):
    """The HS residual f (9,) at z (:func:`_hs_jacobian`, its Jacobian dropped; scratch as
    :func:`_scratch`)."""
    _hs_jacobian(z, a, b, R, t, p, f, np.empty((9, 4)), V, Ms, A, rhs, Q, np.empty((9, 9)))


@_kernel
def _hs_jacobian(z, a, b, R, t, p, f, J, V, Ms, A, rhs, Q, W):
    """The HS residual f (9,) and its exact Jacobian J (9, 4) at z (:func:`_hs_eval`,
    :func:`_hs_jac`); False (J not filled) where the equations' matrix is rank deficient
    (scratch as :func:`_scratch`, W (9, 9); A not used)."""
    _, full = _hs_eval(z, a, b, R, t, p, f, V, Ms, rhs, Q, W)
    if full:
        _hs_jac(z, p, f, J, V, Ms, rhs, Q, W, np.empty((4, 9, 4)))
    return full


@_inline
def _dg_times(g, gp, s, omc, v, out):
    """out = (s [g′]× + omc ([g′]× [g]× + [g]× [g′]×)) v: the derivative of the rotation
    about g by θ (s = sin θ, omc = 1 − cos θ) along g′ ⊥ g, applied to v."""
    a0 = g[1] * v[2] - g[2] * v[1]                    # g × v
    a1 = g[2] * v[0] - g[0] * v[2]
    a2 = g[0] * v[1] - g[1] * v[0]
    b0 = gp[1] * v[2] - gp[2] * v[1]                  # g′ × v
    b1 = gp[2] * v[0] - gp[0] * v[2]
    b2 = gp[0] * v[1] - gp[1] * v[0]
    out[0] = s * b0 + omc * ((gp[1] * a2 - gp[2] * a1) + (g[1] * b2 - g[2] * b1))
    out[1] = s * b1 + omc * ((gp[2] * a0 - gp[0] * a2) + (g[2] * b0 - g[0] * b2))
    out[2] = s * b2 + omc * ((gp[0] * a1 - gp[1] * a0) + (g[0] * b1 - g[1] * b0))


#: lanes of the grid's Cholesky factorisations, side by side (a multiple of the SIMD width)
_LANES = 128


@_kernel
def _hs_blocks(a, b, R, t, p, nb, nt):
    """Position j's part of the grid's normal equations at each elevation and angle of
    :func:`hs_grid`: B (3, nb, 21, nt), the lower triangle of AᵀA row by row (15), Aᵀr (5)
    and rᵀr of its three rows (:func:`_hs_rows`)."""
    B = np.empty((3, nb, 21, nt))
    A, r, g = np.empty((3, 5)), np.empty(3), np.empty(3)
    e1, e2, G = np.empty(3), np.empty(3), np.empty((3, 3))
    for ib in range(nb):
        beta = (ib + 0.5) * np.pi / nb
        cb, sb = math.cos(beta), math.sin(beta)
        for i in range(3):
            g[i] = cb * a[i] + sb * b[i]
        _perp3(g, e1, e2)
        for it in range(nt):
            th = -np.pi + (it + 0.5) * 2 * np.pi / nt
            _rot3(g, th, G)
            for j in range(3):
                for i in range(3):
                    for k in range(3):
                        A[i, k] = R[j, i, k] - G[i, k]
                    A[i, 3] = G[i, 0] * e1[0] + G[i, 1] * e1[1] + G[i, 2] * e1[2] - e1[i]
                    A[i, 4] = G[i, 0] * e2[0] + G[i, 1] * e2[1] + G[i, 2] * e2[2] - e2[i]
                    r[i] = p * th * g[i] - t[j, i]
                q = 0
                for u in range(5):
                    for w in range(u + 1):
                        B[j, ib, q, it] = A[0, u] * A[0, w] + A[1, u] * A[1, w] + A[2, u] * A[2, w]
                        q += 1
                for u in range(5):
                    B[j, ib, 15 + u, it] = A[0, u] * r[0] + A[1, u] * r[1] + A[2, u] * r[2]
                B[j, ib, 20, it] = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    return B


@_kernel
def _misfit_lanes(P, out, n):
    """:func:`_misfit` of the normal equations in lanes 0 … n − 1 (n ≤ ``_LANES``) of P
    (21 · _LANES,): entry q of lane l at ``P[q · _LANES + l]`` (q as :func:`_hs_blocks`,
    1e-12 added to the diagonal here), the same operations in the same order, branch-free
    so that the lanes run side by side (SIMD): a pivot that is not positive or not finite
    gives NaN."""
    for l in range(n):
        m00 = P[l] + 1e-12
        m11 = P[2 * _LANES + l] + 1e-12
        m22 = P[5 * _LANES + l] + 1e-12
        m33 = P[9 * _LANES + l] + 1e-12
        m44 = P[14 * _LANES + l] + 1e-12
        d0 = m00
        l00 = np.sqrt(d0)
        l10 = P[_LANES + l] / l00
        l20 = P[3 * _LANES + l] / l00
        l30 = P[6 * _LANES + l] / l00
        l40 = P[10 * _LANES + l] / l00
        d1 = m11 - l10 * l10
        l11 = np.sqrt(d1)
        l21 = (P[4 * _LANES + l] - l20 * l10) / l11
        l31 = (P[7 * _LANES + l] - l30 * l10) / l11
        l41 = (P[11 * _LANES + l] - l40 * l10) / l11
        d2 = m22 - l20 * l20 - l21 * l21
        l22 = np.sqrt(d2)
        l32 = (P[8 * _LANES + l] - l30 * l20 - l31 * l21) / l22
        l42 = (P[12 * _LANES + l] - l40 * l20 - l41 * l21) / l22
        d3 = m33 - l30 * l30 - l31 * l31 - l32 * l32
        l33 = np.sqrt(d3)
        l43 = (P[13 * _LANES + l] - l40 * l30 - l41 * l31 - l42 * l32) / l33
        d4 = m44 - l40 * l40 - l41 * l41 - l42 * l42 - l43 * l43
        l44 = np.sqrt(d4)
        y0 = P[15 * _LANES + l] / l00
        y1 = (P[16 * _LANES + l] - l10 * y0) / l11
        y2 = (P[17 * _LANES + l] - l20 * y0 - l21 * y1) / l22
        y3 = (P[18 * _LANES + l] - l30 * y0 - l31 * y1 - l32 * y2) / l33
        y4 = (P[19 * _LANES + l] - l40 * y0 - l41 * y1 - l42 * y2 - l43 * y3) / l44
        s = P[20 * _LANES + l] - y0 * y0 - y1 * y1 - y2 * y2 - y3 * y3 - y4 * y4
        ok = ((d0 > 0.0) & (d1 > 0.0) & (d2 > 0.0) & (d3 > 0.0) & (d4 > 0.0) & (d0 < np.inf)
              & (d1 < np.inf) & (d2 < np.inf) & (d3 < np.inf) & (d4 < np.inf))
        out[l] = np.sqrt(abs(s)) if ok else np.nan


@_kernel
def _hs_grid_into(a, b, R, t, p, nb, nt, F):
    """:func:`hs_grid` written into F, the flat (nb + 2) × (nt + 2)³ array of the grid
    padded by one point on each side (C order): the misfit at grid point
    (ib, i2, i3, i4) goes to padded point (ib + 1, i2 + 1, i3 + 1, i4 + 1), the padding is
    left alone (:func:`_hs_minima_into` reads it)."""
    if nt > _LANES:
        raise ValueError("hs_grid: more angles than _LANES")
    B = _hs_blocks(a, b, R, t, p, nb, nt)
    P = np.empty(21 * _LANES)
    out = np.empty(_LANES)
    rows = _LANES // nt
    m = nt + 2
    for ib in range(nb):
        B0, B1, B2 = B[0, ib], B[1, ib], B[2, ib]
        for i2 in range(nt):
            for i3s in range(0, nt, rows):                  # θ₃ rows i3s … i3s + nr − 1
                nr = min(rows, nt - i3s)
                for q in range(21):
                    s0 = B0[q, i2]
                    for r in range(nr):
                        s = s0 + B1[q, i3s + r]
                        for i4 in range(nt):
                            P[q * _LANES + r * nt + i4] = s + B2[q, i4]
                _misfit_lanes(P, out, nr * nt)
                for r in range(nr):
                    o = (((ib + 1) * m + i2 + 1) * m + i3s + r + 1) * m + 1
                    for i4 in range(nt):
                        F[o + i4] = out[r * nt + i4]


@_kernel
def hs_grid(a, b, R, t, p, nb, nt):
    """The variable-projection misfit (normal equations) of the HS equations on the grid
    of ``nb`` elevations β ∈ (0, π) and ``nt`` ≤ ``_LANES`` angles per position in
    (−π, π) (a, b the circle, R (3, 3, 3), t (3, 3), pitch p): position j's rows depend on
    (β, θ_j) only, so the 5x5 normal equations of a grid point are sums of three
    precomputed blocks (:func:`_hs_blocks`), factorised a few θ₃ rows at a time
    (:func:`_misfit_lanes`).  Returns the misfit (nb, nt, nt, nt) (NaN where the
    equations are singular)."""
    m = nt + 2
    F = np.empty((nb + 2) * m ** 3)
    _hs_grid_into(a, b, R, t, p, nb, nt, F)
    f = np.empty((nb, nt, nt, nt))
    for ib in range(nb):
        for i2 in range(nt):
            for i3 in range(nt):
                o = (((ib + 1) * m + i2 + 1) * m + i3 + 1) * m + 1
                for i4 in range(nt):
                    f[ib, i2, i3, i4] = F[o + i4]
    return f


@_kernel
def _hs_minima_into(F, nb, nt, hits):
    """The local minima (:func:`hs_grid_minima`) of the misfit held in F as
    :func:`_hs_grid_into` leaves it, its θ padding +inf: its β padding (the slices before
    and after) set here to the wrapped slices, then every point compared with its eight
    neighbours, the θ₄ comparisons side by side.  Writes the minima's indices into the
    (nb, nt, nt, nt) grid in C order to hits (≥ nb nt³,) and returns their count."""
    m = nt + 2
    sb, s2, s3 = m * m * m, m * m, m                  # strides of β, θ₂, θ₃ in F
    for i2 in range(nt):
        for i3 in range(nt):
            for i4 in range(nt):
                o = (i2 + 1) * s2 + (i3 + 1) * s3 + i4 + 1
                w = (nt - i2) * s2 + (nt - i3) * s3 + nt - i4      # θ → −θ
                F[o] = F[nb * sb + w]
                F[(nb + 1) * sb + o] = F[sb + w]
    n = 0
    ok = np.empty(nt, np.bool_)
    for ib in range(nb):
        for i2 in range(nt):
            for i3 in range(nt):
                c = (ib + 1) * sb + (i2 + 1) * s2 + (i3 + 1) * s3 + 1
                for i4 in range(nt):
                    v = F[c + i4]
                    ok[i4] = ((v <= F[c + i4 - sb]) & (v <= F[c + i4 + sb])
                              & (v <= F[c + i4 - s2]) & (v <= F[c + i4 + s2])
                              & (v <= F[c + i4 - s3]) & (v <= F[c + i4 + s3])
                              & (v <= F[c + i4 - 1]) & (v <= F[c + i4 + 1]))
                k = ((ib * nt + i2) * nt + i3) * nt
                for i4 in range(nt):
                    if ok[i4]:
                        hits[n] = k + i4
                        n += 1
    return n


@_kernel
def hs_grid_minima(f):
    """Mask (nb, nt, nt, nt) of the local minima of the HS grid misfit f (from
    :func:`hs_grid`): no larger than any of its eight neighbours (so never where f or a
    neighbour is NaN), β wrapping to β ± π with θ → −θ (the same axis reversed; the θ
    grid is symmetric), θ not wrapping.  Compared with a copy of f padded by those
    wrapped slices in β and by +inf in θ (:func:`_hs_minima_into`)."""
    nb, nt = f.shape[0], f.shape[1]
    m = nt + 2
    F = np.full((nb + 2) * m ** 3, np.inf)
    for ib in range(nb):
        for i2 in range(nt):
            for i3 in range(nt):
                o = (((ib + 1) * m + i2 + 1) * m + i3 + 1) * m + 1
                for i4 in range(nt):
                    F[o + i4] = f[ib, i2, i3, i4]
    hits = np.empty(nb * nt ** 3, np.int64)
    out = np.zeros(f.shape, np.bool_)
    for k in hits[:_hs_minima_into(F, nb, nt, hits)]:
        k, i4 = divmod(k, nt)
        k, i3 = divmod(k, nt)
        ib, i2 = divmod(k, nt)
        out[ib, i2, i3, i4] = True
    return out


@_kernel
def hs_starts(R, t, P, circle, z, p, grids):
    """The starting points of the HS search on n great circles of one task (R (3, 3, 3),
    t (3, 3), pitch p): per circle, its roots ``z`` (m, 4) = (β, θ₂, θ₃, θ₄) (the RS links
    continued to pitch p; ``circle`` (m,) ascending), then the local minima
    (:func:`_hs_minima_into`) of each grid (nb, nt) of ``grids`` (k, 2) (:func:`hs_grid`),
    in the grid's C order.

    Parameters
    ----------
    P : ndarray (n, 2, 3)
        Circle i: ``g(β) = cos β P[i, 0] + sin β P[i, 1]``.

    Returns
    -------
    starts : ndarray (≥ M, 4)
    own : ndarray (≥ M,) of int
        The circle of each start (ascending).
    M : int
        The number of starts (the rows after them are not set).
    """
    # one padded grid and one list of minima for all the circles and grids (the padding
    # refilled where the angles change)
    size, most = 0, 0
    for q in range(grids.shape[0]):
        nb, nt = grids[q, 0], grids[q, 1]
        size, most = max(size, (nb + 2) * (nt + 2) ** 3), max(most, nb * nt ** 3)
    F, hits = np.empty(size), np.empty(most, np.int64)
    cap = z.shape[0] + 256
    buf, own = np.empty((cap, 4)), np.empty(cap, np.int64)
    m, j, last = 0, 0, -1
    for i in range(P.shape[0]):
        while j < circle.shape[0] and circle[j] == i:
            buf[m] = z[j]
            own[m] = i
            m, j = m + 1, j + 1
        for q in range(grids.shape[0]):
            nb, nt = grids[q, 0], grids[q, 1]
            if nt != last:
                F[:] = np.inf
                last = nt
            _hs_grid_into(P[i, 0], P[i, 1], R, t, p, nb, nt, F)
            n = _hs_minima_into(F, nb, nt, hits)
            if m + n + circle.shape[0] - j > cap:          # room for the later circles' roots
                cap = 2 * (m + n) + circle.shape[0] - j
                grown, owned = np.empty((cap, 4)), np.empty(cap, np.int64)
                for r in range(m):
                    owned[r] = own[r]
                    for c in range(4):
                        grown[r, c] = buf[r, c]
                buf, own = grown, owned
            for h in hits[:n]:
                h, i4 = divmod(h, nt)
                h, i3 = divmod(h, nt)
                ib, i2 = divmod(h, nt)
                buf[m, 0] = (ib + 0.5) * np.pi / nb
                buf[m, 1] = -np.pi + (i2 + 0.5) * 2 * np.pi / nt
                buf[m, 2] = -np.pi + (i3 + 0.5) * 2 * np.pi / nt
                buf[m, 3] = -np.pi + (i4 + 0.5) * 2 * np.pi / nt
                own[m] = i
                m += 1
    return buf, own, m


@_kernel
def hs_distinct(own, g, C):
    """Mask of the links to keep, in order: link k is dropped when an earlier kept link of
    the same circle ``own`` has the same axis direction (|g·g'| within 1e-8 of 1) and
    sphere centre (within 1e-7); g, C (M, 3)."""
    M = own.shape[0]
    keep = np.zeros(M, np.bool_)
    for k in range(M):
        keep[k] = True
        for j in range(k - 1, -1, -1):
            if own[j] != own[k]:
                break
            if not keep[j]:
                continue
            d = g[k, 0] * g[j, 0] + g[k, 1] * g[j, 1] + g[k, 2] * g[j, 2]
            e = math.sqrt((C[k, 0] - C[j, 0]) ** 2 + (C[k, 1] - C[j, 1]) ** 2
                          + (C[k, 2] - C[j, 2]) ** 2)
            if abs(abs(d) - 1) < 1e-8 and e < 1e-7:
                keep[k] = False
                break
    return keep


@_inline
def _misfit(M, v, rr):
    """sqrt(|rr − vᵀ M⁻¹ v|) for the normal equations M (lower triangle read, overwritten by
    its Cholesky factor L) and v (overwritten by L⁻¹ v): the least-squares misfit, as
    vᵀ M⁻¹ v = |L⁻¹ v|².  NaN where M is not positive definite."""
    if not _cholesky(M):
        return np.nan
    _forward(M, v, v)
    s = rr
    for j in range(v.shape[0]):
        s -= v[j] * v[j]
    return math.sqrt(abs(s))


# ------------------------------------------------------------------ Levenberg–Marquardt
@_inline
def _cost_hh(z, P, R, t, v, f, V, Ms, A6, rhs6, M, b, x, rhs9, Q, W):
    """A system's residual f at z, P its parameters: the HH misfit about the base
    P = (g0, e1, e2) with pitches v (scratch as :func:`_scratch`, W (9, 9)).  Returns
    (|f|², inf where not finite; True: the Jacobian is then tried)."""
    _hh_residual(z, P, R, t, v, f, A6, rhs6, M, b, x)
    cost = 0.0
    for r in range(f.shape[0]):
        cost += f[r] * f[r]
    return (cost if math.isfinite(cost) else np.inf), True


@_inline
def _cost_hs(z, P, R, t, v, f, V, Ms, A6, rhs6, M, b, x, rhs9, Q, W):
    """As :func:`_cost_hh`, the HS residual on the circle P = (a, b) with pitch v[0]
    (:func:`_hs_eval`); the second value says whether the equations' factorisation has
    full rank, i.e. whether the Jacobian is to be had there (:func:`_jac_hs` reuses it)."""
    return _hs_eval(z, P[0], P[1], R, t, v[0], f, V, Ms, rhs9, Q, W)


@_inline
def _jac_hh(z, f0, P, R, t, v, h, J, fp, zt, V, Ms, A6, rhs6, M, b, x, rhs9, Q, W, X):
    """Jacobian J (6, 2) of the HH misfit at z (f0 its residual there) by forward
    differences (as MINPACK's lmdif; measured: the same links as central ones on the
    reference tasks, at half the residuals); False where not finite."""
    for i in range(z.shape[0]):
        zt[:] = z
        zt[i] = z[i] + h
        _hh_residual(zt, P, R, t, v, fp, A6, rhs6, M, b, x)
        for r in range(fp.shape[0]):
            J[r, i] = (fp[r] - f0[r]) / h
            if not math.isfinite(J[r, i]):
                return False
    return True


@_inline
def _jac_hs(z, f0, P, R, t, v, h, J, fp, zt, V, Ms, A6, rhs6, M, b, x, rhs9, Q, W, X):
    """The exact variable-projection Jacobian of the HS residual at z (:func:`_hs_jac`,
    from the factorisation of the :func:`_cost_hs` call there just before: one evaluation
    against central differences' eight; the links of 116 reference tasks kept, 20 more
    found).  Scratch as :func:`_cost_hh`, X (4, 9, 4)."""
    _hs_jac(z, v[0], f0, J, V, Ms, rhs9, Q, W, X)
    return True


_HH, _HS = 0, 1       # the residuals the Levenberg–Marquardt below knows


def _levenberg_marquardt(kind, r):
    """Levenberg–Marquardt for many independent small systems, one after another, of the
    residual ``kind`` (``_HH``: :func:`_cost_hh`, :func:`_jac_hh`; ``_HS``:
    :func:`_cost_hs`, :func:`_jac_hs`) of r components: ``lm(z0, P, sel, R, t, v, iters,
    h)``, compiled once per residual, the other one pruned (one function for both, a
    branch on the kind at run time, ran the HS search 35 % slower, measured).  The kind
    is a closure constant, an int, so that numba's cache holds the function (a closure
    over functions is compiled anew in every process), branched on in the loop itself
    (pruned before inlining: ~30 % less to compile than a branch in an inlined helper).

    System k's residual (r,) at z (n,) is the kind's with parameters ``P[sel[k]]``.  Each
    system stops when its residual vanishes (cost ≤ 1e-30, or ≤ 1e-26 and a step fails to
    lower it: round-off), when its damping runs away (≥ 1e12), or when it is stuck away
    from a zero: stationary (the gradient Jᵀf below 1e-6 of |J| |f|: f orthogonal to the
    Jacobian's range, which a system approaching a zero never is) or its cost lowered by
    less than 0.1 % over 10 iterations (a system in a zero's basin loses orders of
    magnitude an iteration).  Damping starts at 1e-3, divided by 5 on an accepted step
    and multiplied by 8 on a rejected one.  The start is evaluated as the first trial
    point, so that the residual and the Jacobian are each called from one place.

    Returns the final z (N, n), |f| (N,) and the iterations taken (N,)."""

    def lm(z0, P, sel, R, t, v, iters, h):
        N, n = z0.shape
        z = z0.copy()
        res = np.empty(N)
        its = np.zeros(N, np.int64)
        f, fn, fp = np.empty(r), np.empty(r), np.empty(r)
        J, Jn = np.empty((r, n)), np.empty((r, n))
        zt, za, step, Jtf, diag = np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n)
        JtJ = np.empty((n, n))
        hist = np.empty(iters + 1)
        V, Ms, A6, rhs6, M, b, x, _, rhs9, Q = _scratch()
        W, X = np.zeros((9, 9)), np.zeros((4, 9, 4))
        for k in range(N):
            zk = z[k]
            za[:] = zk
            cost = np.inf
            lam = 1e-3
            it = -1                                   # −1: the start, evaluated as a trial
            while True:
                # the kind's branches here, on the closure constant: numba prunes the other
                # one before inlining (inside an inlined helper it would inline both first)
                if kind == _HS:
                    cn, ok = _cost_hs(za, P[sel[k]], R, t, v, fn, V, Ms, A6, rhs6, M, b, x,
                                      rhs9, Q, W)
                else:
                    cn, ok = _cost_hh(za, P[sel[k]], R, t, v, fn, V, Ms, A6, rhs6, M, b, x,
                                      rhs9, Q, W)
                # the trial's Jacobian only where it is accepted (a rejected step: one residual)
                take = (it < 0 or cn < cost) and ok
                if take:
                    if kind == _HS:
                        take = _jac_hs(za, fn, P[sel[k]], R, t, v, h, Jn, fp, zt, V, Ms, A6,
                                       rhs6, M, b, x, rhs9, Q, W, X)
                    else:
                        take = _jac_hh(za, fn, P[sel[k]], R, t, v, h, Jn, fp, zt, V, Ms, A6,
                                       rhs6, M, b, x, rhs9, Q, W, X)
                if take:
                    zk[:] = za
                    f[:] = fn
                    J[:, :] = Jn
                    cost = cn
                    if it >= 0:
                        lam = max(lam / 5, 1e-12)
                elif it >= 0:
                    if cost <= 1e-26:
                        break                  # at round-off: a rejected step will not lower it
                    lam *= 8
                it += 1
                if it >= iters:
                    break
                hist[it] = cost
                if not (math.isfinite(cost) and cost > 1e-30 and lam < 1e12):
                    break
                if it >= 10 and not (cost < 0.999 * hist[it - 10] or cost <= 1e-20):
                    break
                its[k] = it + 1
                g2 = 0.0
                dsum = 0.0
                for i in range(n):
                    s = 0.0
                    for q in range(r):
                        s += J[q, i] * f[q]
                    Jtf[i] = -s
                    g2 += s * s
                    for j in range(n):
                        s = 0.0
                        for q in range(r):
                            s += J[q, i] * J[q, j]
                        JtJ[i, j] = s
                    diag[i] = JtJ[i, i]
                    dsum += diag[i]
                if math.sqrt(g2) <= 1e-6 * math.sqrt(dsum * cost) and cost > 1e-20:
                    break                                              # stationary
                for i in range(n):
                    JtJ[i, i] += lam * (diag[i] + 1e-12)
                if not _solve(JtJ, Jtf, step):
                    step[:] = 0.0
                for i in range(n):
                    za[i] = zk[i] + (step[i] if math.isfinite(step[i]) else 0.0)
            res[k] = math.sqrt(cost)
        return z, res, its
    return _kernel(lm)


_hh_lm = _levenberg_marquardt(_HH, 6)
_hs_lm = _levenberg_marquardt(_HS, 9)


# ------------------------------------------------------------------ entry points
def hh_refine(bases, R, t, pn, iters: int = 80):
    """Levenberg–Marquardt on the helical link's misfit from the directions ``bases[:, 0]``
    (bases (N, 3, 3): g0, e1, e2), in the tangent coordinates g = g0 + z₁ e1 + z₂ e2;
    R (2, 3, 3), t (2, 3), pn (2,) as :func:`_hh_equations`.  Returns z (N, 2), |f| (N,),
    iterations (N,)."""
    return _hh_lm(np.zeros((len(bases), 2)), bases, np.arange(len(bases)), R, t, pn, iters, 1e-8)



def hs_refine(z0, P, sel, R, t, p: float, iters: int):
    """Levenberg–Marquardt on the HS residual (``_hs_lm``) from z0 (N, 4) = (β, θ₂, θ₃, θ₄),
    start k on the circle ``P[sel[k]]`` = (a, b) (P (n, 2, 3), sel (N,) of int); R (3, 3,
    3), t (3, 3), pitch p; its Jacobian exact.  Returns z (N, 4), |f| (N,), iterations
    (N,)."""
    return _hs_lm(np.ascontiguousarray(z0, float), P, np.asarray(sel, np.int64), R, t,
                  np.array([p], float), iters, 0.0)
