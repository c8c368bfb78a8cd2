"""Compiled kernels of the helical root searches: the misfit grids and Levenberg–Marquardt
of :func:`synthesis.helical_links` (HH, RH, HR) and :func:`synthesis.hs_links` (HS, SH).

Slide = pitch · angle makes these equations transcendental, so their solutions are found
by refining the local minima of a misfit on a grid of starting points.  Both steps run
here, compiled, one small system after another:

* the residual functions (a helical link's six translation equations for a fixed-axis
  direction, the HS link's nine for an elevation and three helical angles), each with
  its linear unknowns (the axes' points, the sphere centre) projected out;
* the misfit on a grid of directions (HH) or of (elevation, angles) (HS), and the HS
  grid's local minima;
* one Levenberg–Marquardt for any of the residuals (Jacobian by forward differences for
  HH, exact for HS), its residual's call chain inlined;
* the HS equations of many converged starts, for their least-squares points.

Inlining (numba's ``inline="always"``) pays where a small function runs in a tight loop
(the HH equations in the grid: 2× faster), but every inlined call site is a copy to
compile: the Levenberg–Marquardt calls each residual from two places only, and calls
the HH equations rather than inlining them (first compile ~21 s, measured).

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
def _cross3(a, b, out):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@_inline
def _perp3(u, e1, e2):
    """Two unit vectors completing unit u to a right-handed frame (as ``binary._perp``)."""
    if abs(u[0]) < 0.9:
        a0, a1, a2 = 1.0, 0.0, 0.0
    else:
        a0, a1, a2 = 0.0, 1.0, 0.0
    d = a0 * u[0] + a1 * u[1] + a2 * u[2]
    e1[0], e1[1], e1[2] = a0 - d * u[0], a1 - d * u[1], a2 - d * u[2]
    n = math.sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2])
    e1[0] /= n
    e1[1] /= n
    e1[2] /= n
    _cross3(u, e1, e2)


@_inline
def _rot3(u, ang, out):
    """Rotation about unit u by ang (Rodrigues), as ``binary._rot``."""
    _rot3cs(u, math.cos(ang), math.sin(ang), out)


@_inline
def _rot3cs(u, c, s, out):
    """Rotation about unit u by the angle of cosine c and sine s."""
    C = 1.0 - c
    out[0, 0] = 1.0 + C * (-u[2] * u[2] - u[1] * u[1])
    out[0, 1] = -s * u[2] + C * u[0] * u[1]
    out[0, 2] = s * u[1] + C * u[0] * u[2]
    out[1, 0] = s * u[2] + C * u[0] * u[1]
    out[1, 1] = 1.0 + C * (-u[2] * u[2] - u[0] * u[0])
    out[1, 2] = -s * u[0] + C * u[1] * u[2]
    out[2, 0] = -s * u[1] + C * u[0] * u[2]
    out[2, 1] = s * u[0] + C * u[1] * u[2]
    out[2, 2] = 1.0 + C * (-u[1] * u[1] - u[0] * u[0])


@_inline
def _signed_angle3(a, b, u, out):
    """Angle about u from a to b (their components ⊥ u), as ``binary._signed_angle``, and
    that rotation about u in out (3, 3), its cosine and sine taken from the two components
    (no trigonometric call; the identity where a or b is parallel to u)."""
    cx = a[1] * b[2] - a[2] * b[1]
    cy = a[2] * b[0] - a[0] * b[2]
    cz = a[0] * b[1] - a[1] * b[0]
    ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    au = a[0] * u[0] + a[1] * u[1] + a[2] * u[2]
    bu = b[0] * u[0] + b[1] * u[1] + b[2] * u[2]
    y, x = u[0] * cx + u[1] * cy + u[2] * cz, ab - au * bu
    r = math.sqrt(x * x + y * y)
    c, s = (x / r, y / r) if r > 0.0 else (1.0, 0.0)
    _rot3cs(u, c, s, out)
    return math.atan2(y, x)


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


@_kernel
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
def _off_range(A, b, out, Q):
    """``P b − b``, P the orthogonal projector on the columns of A (m, n): minus the part
    of b (m,) off A's range, by modified Gram–Schmidt on [A b] (backward stable for the
    least-squares residual, Björck & Paige 1992); Q (n, m) scratch."""
    m, n = A.shape
    for j in range(n):
        for i in range(m):
            Q[j, i] = A[i, j]
    for i in range(m):
        out[i] = b[i]
    for j in range(n):
        for k in range(j):
            d = 0.0
            for i in range(m):
                d += Q[k, i] * Q[j, i]
            for i in range(m):
                Q[j, i] -= d * Q[k, i]
        s = 0.0
        for i in range(m):
            s += Q[j, i] * Q[j, i]
        nrm = math.sqrt(s)
        if nrm == 0.0:
            continue
        for i in range(m):
            Q[j, i] /= nrm
        d = 0.0
        for i in range(m):
            d += Q[j, i] * out[i]
        for i in range(m):
            out[i] -= d * Q[j, i]
    for i in range(m):
        out[i] = -out[i]


@_kernel
def _scratch():
    """Scratch arrays of the residuals, allocated once per search (an allocation, or a
    tuple of arrays passed down, costs more than a residual; so they are passed one by
    one): vectors V (16, 3), 3x3 matrices Ms (3, 3, 3), the HH equations A6 (6, 4), rhs6
    (6,) and their normal equations M (4, 4), b, x (4,); the HS equations A9 (9, 5), rhs9
    (9,) and Gram–Schmidt Q (5, 9)."""
    return (np.zeros((16, 3)), np.zeros((3, 3, 3)), np.zeros((6, 4)), np.zeros(6),
            np.zeros((4, 4)), np.zeros(4), np.zeros(4), np.zeros((9, 5)), np.zeros(9),
            np.zeros((5, 9)))


# ------------------------------------------------------------------ HH, RH, HR links
def _hh_equations(g, R, t, pn, A, rhs, w, th, ph, V, Ms):
    """A helical link's translation equations for the fixed-axis direction g (3,) through
    the rotations R (2, 3, 3) and translations t (2, 3) of positions 2, 3, pitches pn (2,)
    (normalised length / rad): fills A (6, 4), rhs (6,), the moving direction w (3,) and
    the joint rotations θ (2,), φ (2,), as ``helical._equations`` (V (10, 3), Ms (3, 3, 3)
    scratch).  Returns (|w| before normalising, |g × w|): the direction pair is valid
    where both exceed 1e-9."""
    a0, a1, v, e1, e2, f1, f2, Rw, Mv, q = V[0], V[1], V[2], V[3], V[4], V[5], V[6], V[7], \
        V[8], V[9]
    Gm, Wm, M = Ms[0], Ms[1], Ms[2]
    for i in range(3):
        a0[i] = (R[0, 0, i] * g[0] + R[0, 1, i] * g[1] + R[0, 2, i] * g[2]) - g[i]
        a1[i] = (R[1, 0, i] * g[0] + R[1, 1, i] * g[1] + R[1, 2, i] * g[2]) - g[i]
    _cross3(a0, a1, w)
    wn = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    if wn > 1e-9:
        w[0] /= wn
        w[1] /= wn
        w[2] /= wn
    else:
        w[0], w[1], w[2] = 0.0, 0.0, 1.0
    gw = g[0] * w[0] + g[1] * w[1] + g[2] * w[2]
    for i in range(3):
        v[i] = g[i] - gw * w[i]
    _perp3(g, e1, e2)
    _perp3(w, f1, f2)
    for m in range(2):
        for i in range(3):
            Rw[i] = R[m, i, 0] * w[0] + R[m, i, 1] * w[1] + R[m, i, 2] * w[2]
        th[m] = _signed_angle3(w, Rw, g, Gm)
        for i in range(3):
            for j in range(3):
                M[i, j] = Gm[0, i] * R[m, 0, j] + Gm[1, i] * R[m, 1, j] + Gm[2, i] * R[m, 2, j]
        for i in range(3):
            Mv[i] = M[i, 0] * v[0] + M[i, 1] * v[1] + M[i, 2] * v[2]
        ph[m] = _signed_angle3(v, Mv, w, Wm)
        for i in range(3):
            A[3 * m + i, 0] = e1[i] - (Gm[i, 0] * e1[0] + Gm[i, 1] * e1[1] + Gm[i, 2] * e1[2])
            A[3 * m + i, 1] = e2[i] - (Gm[i, 0] * e2[0] + Gm[i, 1] * e2[1] + Gm[i, 2] * e2[2])
        for c in range(2):
            f = f1 if c == 0 else f2
            for i in range(3):
                q[i] = f[i] - (Wm[i, 0] * f[0] + Wm[i, 1] * f[1] + Wm[i, 2] * f[2])
            for i in range(3):
                A[3 * m + i, 2 + c] = Gm[i, 0] * q[0] + Gm[i, 1] * q[1] + Gm[i, 2] * q[2]
        for i in range(3):
            Gw = Gm[i, 0] * w[0] + Gm[i, 1] * w[1] + Gm[i, 2] * w[2]
            rhs[3 * m + i] = t[m, i] - pn[0] * th[m] * g[i] - pn[1] * ph[m] * Gw
    _cross3(g, w, q)
    return wn, math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2])


#: compiled twice from one source: inlined into the grid, where it is nearly all the work
#: (2× faster, measured), and called from the Levenberg–Marquardt, whose compile time an
#: inlined copy at each of its call sites would triple (for no measured gain)
_hh_equations_inlined = _inline(_hh_equations)
_hh_equations = _kernel(_hh_equations)


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
def _hh_normal(g, R, t, pn, V, Ms, A, rhs, M, b):
    """The six equations for direction g (A (6, 4), rhs (6,)) and their normal equations
    (:func:`_normal6`) (scratch as :func:`_scratch`); returns the validity of g."""
    wn, sgw = _hh_equations(g, R, t, pn, A, rhs, V[10], V[11], V[12], V, Ms)
    _normal6(A, rhs, M, b)
    return wn > 1e-9 and sgw > 1e-9


@_inline
def _hh_misfit(g, R, t, pn, f, V, Ms, A, rhs, M, b, x):
    """The six equations' least-squares misfit vector f (6,) for direction g, the points
    solved by normal equations; returns the validity of g."""
    ok = _hh_normal(g, R, t, pn, V, Ms, A, rhs, M, b)
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
    V, Ms, A, rhs, M, b, _, _, _, _ = _scratch()
    for k in range(n):
        wn, sgw = _hh_equations_inlined(G[k], R, t, pn, A, rhs, V[10], V[11], V[12], V, Ms)
        if wn > 1e-9 and sgw > 1e-9:
            _normal6(A, rhs, M, b)
            rr = 0.0
            for r in range(6):
                rr += rhs[r] * rhs[r]
            out[k] = _misfit(M, b, rr)
        else:
            out[k] = np.inf
    return out


@_inline
def _hh_residual(z, base, R, t, pn, f, V, Ms, A, rhs, M, b, x):
    """Residual f (6,) at tangent coordinates z (2,) about base = (g0, e1, e2) (3, 3):
    the direction g = normalise(g0 + z₁ e1 + z₂ e2)."""
    g = V[13]
    for i in range(3):
        g[i] = base[0, i] + z[0] * base[1, i] + z[1] * base[2, i]
    n = math.sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2])
    for i in range(3):
        g[i] /= n
    _hh_misfit(g, R, t, pn, f, V, Ms, A, rhs, M, b, x)


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
def _hs_residual(z, a, b, R, t, p, f, V, Ms, A, rhs, Q):
    """The nine HS equations' residual f (9,) off the range of their matrix at
    z = (β, θ₂, θ₃, θ₄), the axis direction g = cos β a + sin β b; R (3, 3, 3), t (3, 3)
    (scratch as :func:`_scratch`)."""
    g = V[2]
    cb, sb = math.cos(z[0]), math.sin(z[0])
    for i in range(3):
        g[i] = cb * a[i] + sb * b[i]
    for j in range(3):
        _hs_rows(g, z[1 + j], R[j], t[j], p, A[3 * j:3 * j + 3], rhs[3 * j:3 * j + 3], V,
                 Ms[0])
    _off_range(A, rhs, f, Q)


@_kernel
def _hs_jacobian(z, a, b, R, t, p, f, J, V, Ms, A, rhs, Q, W):
    """Jacobian J (9, 4) of the HS residual f (9,) at z (:func:`_hs_residual`), exact
    (Golub & Pereyra 1973): with A = Qᵀ U (Gram–Schmidt), x = A⁺ rhs, column k is
    ``(I − QᵀQ)(∂A_k x − ∂rhs_k) − Qᵀ U⁻ᵀ ∂A_kᵀ f``.  Position j's rows
    ``[R_j − G_j | (G_j − I) e1 | (G_j − I) e2]`` change with θ_j and β through G_j only
    (the residual depends on A's column space, which e1, e2 ⊥ g do not change), so
    ``∂A_j x = D (c − C)`` with D = ∂G_j (C the centre, c the axis point).  False where A
    is rank deficient (scratch as :func:`_scratch`, W (9, 9))."""
    g, gp, dv, u, e1, e2 = V[2], V[3], V[4], V[5], V[6], V[7]
    G = Ms[0]
    U, x, y, w, uu = W[0:5, 0:5], W[5, 0:5], W[6, 0:5], W[7, 0:5], W[8]
    cb, sb = math.cos(z[0]), math.sin(z[0])
    for i in range(3):
        g[i] = cb * a[i] + sb * b[i]
        gp[i] = -sb * a[i] + cb * b[i]                                  # dg/dβ
    for j in range(3):
        _hs_rows(g, z[1 + j], R[j], t[j], p, A[3 * j:3 * j + 3], rhs[3 * j:3 * j + 3], V,
                 Ms[0])
    for i in range(3):
        e1[i], e2[i] = V[0, i], V[1, i]
    n = 5
    for j in range(n):                               # modified Gram–Schmidt, A = Qᵀ U
        for i in range(9):
            Q[j, i] = A[i, j]
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
            return False
        U[j, j] = d
        for k in range(j + 1, n):
            U[k, j] = 0.0
        for i in range(9):
            Q[j, i] /= d
    for k in range(n):                               # x = U⁻¹ Q rhs
        d = 0.0
        for i in range(9):
            d += Q[k, i] * rhs[i]
        y[k] = d
    for k in range(n - 1, -1, -1):
        d = y[k]
        for m in range(k + 1, n):
            d -= U[k, m] * x[m]
        x[k] = d / U[k, k]
    for i in range(3):
        u[i] = x[3] * e1[i] + x[4] * e2[i] - x[i]                    # c − C
    for col in range(4):
        for m in range(n):
            w[m] = 0.0
        for j in range(3):
            th = z[1 + j]
            if col > 0 and col != 1 + j:
                for i in range(3):
                    uu[3 * j + i] = 0.0
                continue
            if col == 0:                                              # D = ∂G_j/∂β
                sn, cs = math.sin(th), math.cos(th)
                _dg_times(g, gp, sn, 1.0 - cs, u, dv)
                for i in range(3):
                    uu[3 * j + i] = dv[i] - p * th * gp[i]
                _dg_times(g, gp, -sn, 1.0 - cs, f[3 * j:3 * j + 3], dv)   # Dᵀ = D at −θ
            else:                                                      # D = [g]× G_j
                _rot3(g, th, G)
                for i in range(3):                                    # G_j (c − C)
                    dv[i] = G[i, 0] * u[0] + G[i, 1] * u[1] + G[i, 2] * u[2]
                _cross3(g, dv, Ms[1, 0])
                for i in range(3):
                    uu[3 * j + i] = Ms[1, 0, i] - p * g[i]
                fj = f[3 * j:3 * j + 3]
                _cross3(fj, g, Ms[1, 1])                               # Dᵀ f = G_jᵀ (f × g)
                for i in range(3):
                    dv[i] = G[0, i] * Ms[1, 1, 0] + G[1, i] * Ms[1, 1, 1] + G[2, i] * Ms[1, 1, 2]
            for i in range(3):                                        # ∂A_jᵀ f_j
                w[i] -= dv[i]
            w[3] += e1[0] * dv[0] + e1[1] * dv[1] + e1[2] * dv[2]
            w[4] += e2[0] * dv[0] + e2[1] * dv[1] + e2[2] * dv[2]
        for k in range(n):                                            # y = U⁻ᵀ w
            d = w[k]
            for m in range(k):
                d -= U[m, k] * y[m]
            y[k] = d / U[k, k]
        for k in range(n):                                            # Q uu, then project
            d = 0.0
            for i in range(9):
                d += Q[k, i] * uu[i]
            w[k] = d
        for i in range(9):
            d = uu[i]
            for k in range(n):
                d -= Q[k, i] * (w[k] + y[k])
            J[i, col] = d
    return True


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


@_kernel
def hs_grid(a, b, R, t, p, nb, nt):
    """The variable-projection misfit (normal equations) of the HS equations on the grid
    of ``nb`` elevations β ∈ (0, π) and ``nt`` angles per position in (−π, π) (a, b the
    circle, R (3, 3, 3), t (3, 3), pitch p): position j's rows depend on (β, θ_j) only,
    so the 5x5 normal equations of a grid point are sums of three precomputed blocks.
    Returns the misfit (nb, nt, nt, nt) (NaN where the equations are singular)."""
    AtA = np.empty((3, nb, nt, 5, 5))
    Atr = np.empty((3, nb, nt, 5))
    rtr = np.empty((3, nb, nt))
    A, r, g, V, G = np.empty((3, 5)), np.empty(3), np.empty(3), np.empty((2, 3)), np.empty((3, 3))
    for ib in range(nb):
        beta = (ib + 0.5) * np.pi / nb
        cb, sb = math.cos(beta), math.sin(beta)
        for i in range(3):
            g[i] = cb * a[i] + sb * b[i]
        for it in range(nt):
            th = -np.pi + (it + 0.5) * 2 * np.pi / nt
            for j in range(3):
                _hs_rows(g, th, R[j], t[j], p, A, r, V, G)
                for u in range(5):
                    for v in range(5):
                        AtA[j, ib, it, u, v] = A[0, u] * A[0, v] + A[1, u] * A[1, v] + A[2, u] * A[2, v]
                    Atr[j, ib, it, u] = A[0, u] * r[0] + A[1, u] * r[1] + A[2, u] * r[2]
                rtr[j, ib, it] = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    f = np.empty((nb, nt, nt, nt))
    M, S, v, sv = np.empty((5, 5)), np.empty((5, 5)), np.empty(5), np.empty(5)
    for ib in range(nb):
        for i2 in range(nt):
            for i3 in range(nt):
                for u in range(5):                  # positions 2 and 3, once for every θ₄
                    for w in range(u + 1):
                        S[u, w] = AtA[0, ib, i2, u, w] + AtA[1, ib, i3, u, w]
                    sv[u] = Atr[0, ib, i2, u] + Atr[1, ib, i3, u]
                sr = rtr[0, ib, i2] + rtr[1, ib, i3]
                for i4 in range(nt):
                    for u in range(5):
                        for w in range(u + 1):
                            M[u, w] = S[u, w] + AtA[2, ib, i4, u, w]
                        M[u, u] += 1e-12
                        v[u] = sv[u] + Atr[2, ib, i4, u]
                    f[ib, i2, i3, i4] = _misfit(M, v, sr + rtr[2, ib, i4])
    return f


@_kernel
def hs_grid_minima(f):
    """Mask (nb, nt, nt, nt) of the local minima of the HS grid misfit f (from
    :func:`hs_grid`): no larger than any of its eight neighbours (so never where f or a
    neighbour is NaN), β wrapping to β ± π with θ → −θ (the same axis reversed; the θ
    grid is symmetric), θ not wrapping."""
    nb, nt = f.shape[0], f.shape[1]
    out = np.zeros(f.shape, np.bool_)
    for ib in range(nb):
        for i2 in range(nt):
            for i3 in range(nt):
                for i4 in range(nt):
                    v = f[ib, i2, i3, i4]
                    lo = f[ib - 1, i2, i3, i4] if ib > 0 else \
                        f[nb - 1, nt - 1 - i2, nt - 1 - i3, nt - 1 - i4]
                    hi = f[ib + 1, i2, i3, i4] if ib < nb - 1 else \
                        f[0, nt - 1 - i2, nt - 1 - i3, nt - 1 - i4]
                    ok = v <= lo and v <= hi                # False at NaN, either side
                    ok = ok and (i2 == 0 or v <= f[ib, i2 - 1, i3, i4])
                    ok = ok and (i2 == nt - 1 or v <= f[ib, i2 + 1, i3, i4])
                    ok = ok and (i3 == 0 or v <= f[ib, i2, i3 - 1, i4])
                    ok = ok and (i3 == nt - 1 or v <= f[ib, i2, i3 + 1, i4])
                    ok = ok and (i4 == 0 or v <= f[ib, i2, i3, i4 - 1])
                    ok = ok and (i4 == nt - 1 or v <= f[ib, i2, i3, i4 + 1])
                    out[ib, i2, i3, i4] = ok
    return out


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
_HH, _HS = 0, 1       # the residuals the Levenberg–Marquardt below knows


@_inline
def _residual(kind, z, k, P, R, t, v, f, V, Ms, A6, rhs6, M, b, x, A9, rhs9, Q):
    """System k's residual f at z: the HH misfit about base P[k] with pitches v, or the HS
    residual on the circle P[0] = (a, b) with pitch v[0] (scratch as :func:`_scratch`)."""
    if kind == _HH:
        _hh_residual(z, P[k], R, t, v, f, V, Ms, A6, rhs6, M, b, x)
    else:
        _hs_residual(z, P[0, 0], P[0, 1], R, t, v[0], f, V, Ms, A9, rhs9, Q)


@_inline
def _cost(kind, z, k, P, R, t, v, f, V, Ms, A6, rhs6, M, b, x, A9, rhs9, Q):
    """Residual f (r,) of system k at z; returns |f|² (inf where not finite); scratch as
    :func:`_scratch`."""
    _residual(kind, z, k, P, R, t, v, f, V, Ms, A6, rhs6, M, b, x, A9, rhs9, Q)
    cost = 0.0
    for r in range(f.shape[0]):
        cost += f[r] * f[r]
    return cost if math.isfinite(cost) else np.inf


@_inline
def _jacobian(kind, z, f0, k, P, R, t, v, h, J, fp, zt, V, Ms, A6, rhs6, M, b, x, A9, rhs9, Q,
              W):
    """Jacobian J (r, n) of system k at z (f0 its residual there): forward differences for
    the HH misfit (as MINPACK's lmdif; measured: the same links as central ones on the
    reference tasks, at half the residuals), the exact variable-projection Jacobian for the
    HS residual (:func:`_hs_jacobian`: one evaluation against central differences' eight;
    the links of 116 reference tasks kept, 20 more found); False where not finite.  The
    HH residual is called from one place here (each call site is a copy of it, inlined)."""
    if kind == _HS:
        return _hs_jacobian(z, P[0, 0], P[0, 1], R, t, v[0], f0, J, V, Ms, A9, rhs9, Q, W)
    for i in range(z.shape[0]):
        zt[:] = z
        zt[i] = z[i] + h
        _residual(kind, zt, k, P, R, t, v, fp, V, Ms, A6, rhs6, M, b, x, A9, rhs9, Q)
        for r in range(fp.shape[0]):
            J[r, i] = (fp[r] - f0[r]) / h
            if not math.isfinite(J[r, i]):
                return False
    return True


@_kernel
def _levenberg_marquardt(kind, z0, P, R, t, v, r, iters, h):
    """Levenberg–Marquardt for many independent small systems, one after another.

    System k's residual (r,) at z (n,) is ``_residual(kind, z, k, P, R, t, v, f)``.  Each
    system stops when its residual vanishes (cost ≤ 1e-30, or ≤ 1e-26 and a step fails to
    lower it: round-off), when its damping runs away (≥ 1e12), or when it is stuck away
    from a zero: stationary (the gradient Jᵀf below 1e-6 of |J| |f|: f orthogonal to the
    Jacobian's range, which a system approaching a zero never is) or its cost lowered by
    less than 0.1 % over 10 iterations (a system in a zero's basin loses orders of
    magnitude an iteration).  Damping starts at 1e-3, divided by 5 on an accepted step
    and multiplied by 8 on a rejected one.  The start is evaluated as the first trial
    point, so that the residual and the Jacobian are each called from one place.

    Returns the final z (N, n), |f| (N,) and the iterations taken (N,)."""
    N, n = z0.shape
    z = z0.copy()
    res = np.empty(N)
    its = np.zeros(N, np.int64)
    f, fn, fp = np.empty(r), np.empty(r), np.empty(r)
    J, Jn = np.empty((r, n)), np.empty((r, n))
    zt, za, step, Jtf, diag = np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    JtJ = np.empty((n, n))
    hist = np.empty(iters + 1)
    V, Ms, A6, rhs6, M, b, x, A9, rhs9, Q = _scratch()
    W = np.zeros((9, 9))
    for k in range(N):
        zk = z[k]
        za[:] = zk
        cost = np.inf
        lam = 1e-3
        it = -1                                   # −1: the start, evaluated as a trial
        while True:
            cn = _cost(kind, za, k, P, R, t, v, fn, V, Ms, A6, rhs6, M, b, x, A9, rhs9, Q)
            # the trial's Jacobian only where it is accepted (a rejected step costs one residual)
            if (it < 0 or cn < cost) and _jacobian(kind, za, fn, k, P, R, t, v, h, Jn, fp, zt,
                                                   V, Ms, A6, rhs6, M, b, x, A9, rhs9, Q, W):
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


# ------------------------------------------------------------------ entry points
def hh_refine(bases, R, t, pn, iters: int = 80):
    """Levenberg–Marquardt on the helical link's misfit from the directions ``bases[:, 0]``
    (bases (N, 3, 3): g0, e1, e2), in the tangent coordinates g = g0 + z₁ e1 + z₂ e2;
    R (2, 3, 3), t (2, 3), pn (2,) as :func:`_hh_equations`.  Returns z (N, 2), |f| (N,),
    iterations (N,)."""
    return _levenberg_marquardt(_HH, np.zeros((len(bases), 2)), bases, R, t, pn, 6, iters,
                                1e-8)


def hs_refine(z0, a, b, R, t, p: float, iters: int):
    """Levenberg–Marquardt on the HS residual from z0 (N, 4) = (β, θ₂, θ₃, θ₄) on the
    circle of a, b (3,); R (3, 3, 3), t (3, 3), pitch p; its Jacobian exact.  Returns
    z (N, 4), |f| (N,), iterations (N,)."""
    return _levenberg_marquardt(_HS, np.ascontiguousarray(z0, float), np.stack([a, b])[None],
                                R, t, np.array([p], float), 9, iters, 0.0)
