"""Every CS chain with a given cylinder axis direction through six positions.

A CS chain: a cylindric joint C in the ground (axis line L; the link turns about it and
slides along it) and a spherical joint S whose centre q is fixed in the body.  The body
reaches its positions ``T_i`` (i = 1…N, ``T_1 = I``) exactly when the centre's positions
``T_i q`` all lie at one distance r from L (Su, Wampler & McCarthy 2004, "Geometric design
of cylindric PRS serial chains", ASME J. Mech. Des. 126(2)).  With L's direction d given
(the free choice, 2 parameters), in a frame whose z axis is d, the first two coordinates
``(X_i, Y_i)`` of ``T_i q`` (affine in q) lie on one circle about L's trace (a, b):

    X_i² + Y_i² − 2a X_i − 2b Y_i + k = 0,     i = 1…6,   k = a² + b² − r²,

six equations in the six unknowns q, a, b, k.  They are linear in (1, a, b, k): the 6 × 4
matrix with rows ``(X_i² + Y_i², −2X_i, −2Y_i, 1)`` drops rank, or, subtracting row 1,
the 5 × 3 matrix

    N(q) = [X_i² + Y_i² − X_1² − Y_1²,  X_i − X_1,  Y_i − Y_1]     (i = 2…6)

drops rank.  Its columns have degrees (2, 1, 1) in q, so the rank-drop locus (codimension
5 − 3 + 1 = 3 in q-space) has, by the Thom–Porteous formula, degree h₃(2, 1, 1) = 26
(the complete homogeneous symmetric polynomial of the column degrees): **26 solutions**
over the complex numbers, the count found by total-degree homotopy as well (26 finite
endpoints of 32 paths once k is eliminated).  The top-degree part of N (q at infinity) is
a generic 5 × 3 matrix of forms on the plane at infinity, which drops rank nowhere there,
so generically no solution is at infinity.

The method (an eigenvalue method, no path tracking, no starting guesses): the ten 3 × 3
minors of N(q) (quartics) generate the ideal of the solutions.  Their Macaulay matrix at
degree D (the minors times every monomial of degree ≤ D − 4, on the monomials of degree
≤ D in q; 100 × 84 at D = 6) has a null space of dimension equal to the number of
solutions, spanned by their monomial (Vandermonde) vectors; its dimension is read off the
singular values (a gap of some ten orders of magnitude on generic tasks).  Written
projectively (q = (ρ₁, ρ₂, ρ₃)/ρ₀), multiplying the monomials of degree ≤ D − 1 by two
random linear forms h₀(ρ), h₁(ρ) maps the null space into itself, and the solutions are
the eigenvectors of the resulting square "shift" matrix, eigenvalues h₁/h₀ (Stetter;
Dreesen, Batselier & De Moor's null-space formulation); the random projective chart keeps
solutions of any size equally well conditioned.  Each eigenvector gives ρ from its
monomials, (1, a, b, k) follows as the null vector of the 6 × 4 matrix, and a few Newton
steps on the six equations (complex arithmetic) polish it; the residual is kept, so an
eigenpair that does not polish is reported, not hidden.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import scipy.linalg

__all__ = ["CSSolutions", "cs_centres", "cs_frame"]

#: degree of the Macaulay matrix (the minors have degree 4; the null space of the
#: matrix restricted to degree ≤ D − 1 must still have full rank for the shift)
DEGREE = 6
#: relative singular value below which the Macaulay matrix's singular values count as 0
RANK_TOL = 1e-9


@dataclass
class CSSolutions:
    """All solutions of the CS circle conditions (normalised task coordinates).

    Attributes
    ----------
    q : numpy.ndarray, complex, shape (s, 3)
        The S centre in position 1 (NaN where the eigenvector gave none).
    axis_point : numpy.ndarray, complex, shape (s, 3)
        The point of the cylinder axis L nearest to the origin (L has the given direction).
    radius2 : numpy.ndarray, complex, shape (s,)
        r², the squared distance of the centre from L.
    residual : numpy.ndarray, shape (s,)
        Largest of ``|X_i² + Y_i² − 2a X_i − 2b Y_i + k|`` over i, each relative to the sum
        of its terms' moduli, after polishing (inf for a failed eigenpair).
    rcond : numpy.ndarray, shape (s,)
        Reciprocal condition number of the six equations' Jacobian at each solution.
    real : numpy.ndarray of bool, shape (s,)
        Real to 1e-8 (relative to the solution's size).
    duplicate : numpy.ndarray of bool, shape (s,)
        The eigenpair polished to a solution an earlier one gave (to 1e-8 relative): a
        double eigenvalue, or an eigenvector that converged to the wrong solution.
    at_infinity : numpy.ndarray of bool, shape (s,)
        The centre (ρ₀ ≈ 0) or the circle (the null vector's first entry ≈ 0: the points
        are collinear) is at infinity: no CS chain.
    nullity : int
        Dimension of the Macaulay matrix's null space: the number of solutions over the
        complex numbers (with multiplicity), 26 for a generic task.
    gap : tuple of float
        The last nonzero and the first zero singular value of the Macaulay matrix,
        relative to the largest (how clearly the nullity was decided).
    shift_rcond : float
        Smallest over largest singular value of the null space restricted to degree
        ≤ D − 1 and shifted by h₀: near 0 when the solution set is not finite (the shift
        is then not defined), i.e. a degenerate task.
    """

    q: np.ndarray
    axis_point: np.ndarray
    radius2: np.ndarray
    residual: np.ndarray
    rcond: np.ndarray
    real: np.ndarray
    duplicate: np.ndarray
    at_infinity: np.ndarray
    nullity: int
    gap: tuple
    shift_rcond: float


# ------------------------------------------------------------------ monomials
@lru_cache(maxsize=None)
def _monomials(D: int):
    """Exponents ``(n, 3)`` of the monomials of degree ≤ D in (x, y, z), graded, and a
    lookup array ``(D + 2,) * 3`` from exponents to their index (−1: beyond degree D)."""
    E = np.array([(i, j, d - i - j) for d in range(D + 1) for i in range(d, -1, -1)
                  for j in range(d - i, -1, -1)], dtype=int)
    look = np.full((D + 2,) * 3, -1, dtype=int)
    look[E[:, 0], E[:, 1], E[:, 2]] = np.arange(len(E))
    return E, look


@lru_cache(maxsize=None)
def _product_table(D: int = 4):
    """``(n², n)`` 0/1 matrix: the coefficient vectors' outer product ``a_i b_j`` on the
    monomials of degree ≤ D, mapped to the monomial of the product (pairs of total degree
    > D are dropped: callers multiply only within degree D)."""
    E, look = _monomials(D)
    n = len(E)
    S = E[:, None, :] + E[None, :, :]                              # (n, n, 3)
    ok = S.sum(-1) <= D
    tab = np.zeros((n * n, n))
    i, j = np.nonzero(ok)
    tab[i * n + j, look[S[i, j, 0], S[i, j, 1], S[i, j, 2]]] = 1.0
    return tab


def _mul(a, b):
    """Product of polynomials ``(..., n)`` on the monomials of degree ≤ 4 (the product's
    degree must be ≤ 4)."""
    n = a.shape[-1]
    return (a[..., :, None] * b[..., None, :]).reshape(a.shape[:-1] + (n * n,)) @ _product_table()


@lru_cache(maxsize=None)
def _macaulay_index(D: int):
    """Column index ``(m, 35)`` of every monomial of degree ≤ 4 shifted by every monomial
    of degree ≤ D − 4 (m of them), on the monomials of degree ≤ D."""
    E4, _ = _monomials(4)
    Es, _ = _monomials(D - 4)
    _, look = _monomials(D)
    S = Es[:, None, :] + E4[None, :, :]
    return look[S[..., 0], S[..., 1], S[..., 2]]


# ------------------------------------------------------------------ the equations
def cs_frame(d) -> np.ndarray:
    """A rotation ``F (3, 3)`` whose third column is the unit direction ``d``: the frame
    of the circle conditions (coordinates ``Fᵀ x``)."""
    d = np.asarray(d, float)
    a = np.array([1.0, 0, 0]) if abs(d[0]) < 0.9 else np.array([0, 1.0, 0])
    e1 = a - (a @ d) * d
    e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(d, e1), d], 1)


def _planar(R, t, F):
    """Affine coefficients ``(6, 2, 4)`` of ``(X_i, Y_i)`` in (x, y, z, 1), q in the frame
    F: the first two frame coordinates of ``T_i q``, i = 1…6 (``T_1 = I``)."""
    Rf = np.einsum("ji,mjk,kl->mil", F, R, F)
    tf = t @ F
    P = np.zeros((len(R) + 1, 2, 4))
    P[0, :, :3] = np.eye(3)[:2]
    P[1:, :, :3] = Rf[:, :2]
    P[1:, :, 3] = tf[:, :2]
    return P


def _minors(P):
    """The ten 3 × 3 minors ``(10, 35)`` of N(q) (coefficients on the monomials of degree
    ≤ 4) and the product of its three columns' largest coefficients (the minors' scale)."""
    E4, look = _monomials(4)
    lin = np.zeros(P.shape[:2] + (len(E4),))                       # (6, 2, 35)
    lin[..., look[0, 0, 0]] = P[..., 3]
    for j in range(3):
        lin[..., look[tuple(np.eye(3, dtype=int)[j])]] = P[..., j]
    s = _mul(lin[:, 0], lin[:, 0]) + _mul(lin[:, 1], lin[:, 1])    # X² + Y²  (6, 35)
    cols = np.stack([s[1:] - s[0], lin[1:, 0] - lin[0, 0], lin[1:, 1] - lin[0, 1]], 1)
    rows = np.array(list(itertools.combinations(range(5), 3)))     # (10, 3)
    out = np.zeros((len(rows), len(E4)))
    for perm in itertools.permutations(range(3)):
        sign = np.linalg.det(np.eye(3)[list(perm)])
        term = _mul(_mul(cols[rows[:, 0], perm[0]], cols[rows[:, 1], perm[1]]),
                    cols[rows[:, 2], perm[2]])
        out += sign * term
    scale = np.prod([np.abs(cols[:, j]).max() for j in range(3)])
    return out, scale


def _residuals(P, z):
    """The six equations at ``z = (x, y, z, a, b, k)`` ``(s, 6)``: values, moduli of their
    terms (summed), X and Y ``(s, 6)`` each."""
    X = z[:, :3] @ P[:, 0, :3].T + P[:, 0, 3]
    Y = z[:, :3] @ P[:, 1, :3].T + P[:, 1, 3]
    a, b, k = z[:, 3:4], z[:, 4:5], z[:, 5:6]
    F = X * X + Y * Y - 2 * a * X - 2 * b * Y + k
    scale = np.abs(X) ** 2 + np.abs(Y) ** 2 + 2 * np.abs(a * X) + 2 * np.abs(b * Y) + np.abs(k)
    return F, scale, X, Y


def _jacobian(P, z, X, Y):
    J = np.zeros(X.shape + (6,), complex)
    J[..., :3] = 2 * (X - z[:, 3:4])[..., None] * P[None, :, 0, :3] + \
        2 * (Y - z[:, 4:5])[..., None] * P[None, :, 1, :3]
    J[..., 3], J[..., 4], J[..., 5] = -2 * X, -2 * Y, 1.0
    return J


def _polish(P, z, steps):
    """Newton on the six equations (complex), per solution; returns z, residual, rcond."""
    for _ in range(steps):
        F, _, X, Y = _residuals(P, z)
        J = _jacobian(P, z, X, Y)
        with np.errstate(all="ignore"):
            try:
                dz = np.linalg.solve(J, F[..., None])[..., 0]
            except np.linalg.LinAlgError:         # a singular one: least squares, per solution
                dz = np.stack([np.linalg.lstsq(J[i], F[i], rcond=None)[0] for i in range(len(z))])
        ok = np.all(np.isfinite(dz), 1)
        z = np.where(ok[:, None], z - dz, z)
    F, scale, X, Y = _residuals(P, z)
    with np.errstate(all="ignore"):
        res = np.abs(F / np.where(scale > 0, scale, 1.0)).max(1)
    res[~np.isfinite(res)] = np.inf
    fin = np.all(np.isfinite(z), 1)
    rc = np.zeros(len(z))
    if fin.any():
        sv = np.linalg.svd(_jacobian(P, z[fin], X[fin], Y[fin]), compute_uv=False)
        with np.errstate(all="ignore"):
            rc[fin] = np.nan_to_num(sv[:, -1] / sv[:, 0])
    return z, res, rc


def cs_centres(R, t, d, *, degree: int = DEGREE, newton: int = 3, seed: int = 1) -> CSSolutions:
    """All solutions of the CS circle conditions through six positions.

    Parameters
    ----------
    R : array_like, shape (5, 3, 3)
        Rotations of positions 2…6 (position 1 is the identity).
    t : array_like, shape (5, 3)
        Their translations (length; best in the task's normalised coordinates, so that
        the solutions are of order 1).
    d : array_like, shape (3,)
        Unit direction of the cylinder axis L.
    degree : int
        Degree D ≥ 6 of the Macaulay matrix.
    newton : int
        Newton steps polishing each solution on the six equations.
    seed : int
        Seed of the fixed random projective chart (h₀, h₁) of the shift; the result does
        not depend on it beyond round-off.

    Returns
    -------
    CSSolutions
        One entry per eigenpair (``nullity`` of them), in the coordinates of ``R, t``.
    """
    R, t, d = np.asarray(R, float), np.asarray(t, float), np.asarray(d, float)
    F = cs_frame(d / np.linalg.norm(d))
    P = _planar(R, t, F)
    D = int(degree)
    E, look = _monomials(D)
    minors, scale = _minors(P)
    empty = CSSolutions(np.zeros((0, 3), complex), np.zeros((0, 3), complex), np.zeros(0, complex),
                        np.zeros(0), np.zeros(0), np.zeros(0, bool), np.zeros(0, bool),
                        np.zeros(0, bool), len(E), (0.0, 0.0), 0.0)
    if not np.abs(minors).max() > 1e-12 * scale:
        return empty        # N(q) drops rank everywhere: every centre is a solution
    # the Macaulay matrix: every minor times every monomial of degree ≤ D − 4
    idx = _macaulay_index(D)                                         # (m, 35)
    A = np.zeros((len(minors), len(idx), len(E)))
    A[:, np.arange(len(idx))[:, None], idx] = minors[:, None, :]
    A = A.reshape(-1, len(E))
    A /= np.maximum(np.linalg.norm(A, axis=1, keepdims=True), 1e-300)
    _, sv, Vh = np.linalg.svd(A, full_matrices=A.shape[0] < A.shape[1])
    sv_all = np.zeros(len(E))
    sv_all[:len(sv)] = sv
    rank = int(np.sum(sv_all > RANK_TOL * sv_all[0]))
    nullity = len(E) - rank
    gap = (float(sv_all[rank - 1] / sv_all[0]), float(sv_all[rank] / sv_all[0]) if nullity else 0.0)
    K = Vh[rank:].T.conj()                                           # (monomials, nullity)
    # shift of the monomials of degree ≤ D − 1 by the random linear forms h0, h1 of
    # ρ = (ρ0, x, y, z) (affine monomial e ↔ ρ0^(D − |e|) x^e: ρ0 keeps e, x_j adds e_j)
    low = np.flatnonzero(E.sum(1) <= D - 1)
    El = E[low]
    up = [low] + [look[El[:, 0] + (j == 0), El[:, 1] + (j == 1), El[:, 2] + (j == 2)]
                  for j in range(3)]
    H = np.linalg.qr(np.random.default_rng(seed).normal(size=(4, 4)))[0]
    Z0 = sum(H[j, 0] * K[up[j]] for j in range(4))
    Z1 = sum(H[j, 1] * K[up[j]] for j in range(4))
    s0 = np.linalg.svd(Z0, compute_uv=False) if nullity else np.ones(1)
    shift_rcond = float(s0[-1] / s0[0])
    if nullity == 0 or shift_rcond < 1e-10:
        empty.nullity, empty.gap, empty.shift_rcond = nullity, gap, shift_rcond
        return empty
    Tm = np.linalg.lstsq(Z0, Z1, rcond=None)[0]
    _, W = scipy.linalg.eig(Tm)
    V = K @ W                                                        # monomial vectors
    # ρ from the monomials ρ_m^(D−1) ρ_j, m the largest variable (largest pure power)
    pure = look[[0, D, 0, 0], [0, 0, D, 0], [0, 0, 0, D]]
    m = np.argmax(np.abs(V[pure]), 0)
    base = np.zeros((len(m), 3), dtype=int)
    base[m > 0, m[m > 0] - 1] = D - 1
    rho = np.empty((len(m), 4), complex)
    for j in range(4):
        e = base + (np.eye(4, dtype=int)[j, 1:] if j else 0)
        rho[:, j] = V[look[e[:, 0], e[:, 1], e[:, 2]], np.arange(len(m))]
    rho /= rho[np.arange(len(m)), np.argmax(np.abs(rho), 1)][:, None]
    inf_q = np.abs(rho[:, 0]) < 1e-9
    with np.errstate(all="ignore"):
        q = np.where(inf_q[:, None], np.nan, rho[:, 1:] / rho[:, :1])
    # (1, a, b, k): the null vector of the 6 × 4 matrix (X² + Y², −2X, −2Y, 1)
    Xq = np.nan_to_num(q) @ P[:, 0, :3].T + P[:, 0, 3]
    Yq = np.nan_to_num(q) @ P[:, 1, :3].T + P[:, 1, 3]
    M = np.stack([Xq * Xq + Yq * Yq, -2 * Xq, -2 * Yq, np.ones_like(Xq)], 2)
    v = np.linalg.svd(M)[2][:, -1].conj()
    v /= v[np.arange(len(v)), np.argmax(np.abs(v), 1)][:, None]
    inf_c = np.abs(v[:, 0]) < 1e-9
    at_inf = inf_q | inf_c
    with np.errstate(all="ignore"):
        z = np.concatenate([q, v[:, 1:] / v[:, :1]], 1)
    z[at_inf] = np.nan
    z, res, rc = _polish(P, z, newton)
    res[at_inf] = np.inf
    size = np.abs(z).max(1)
    real = (np.abs(z.imag).max(1) <= 1e-8 * np.maximum(1.0, size)) & ~at_inf
    with np.errstate(all="ignore"):
        close = np.abs(z[:, None] - z[None]).max(2) <= 1e-8 * np.maximum(1.0, size)[:, None]
    duplicate = np.any(np.tril(close, -1) & (res <= 1e-9)[None], 1) & (res <= 1e-9)
    a, b, k = z[:, 3], z[:, 4], z[:, 5]
    q_user = z[:, :3] @ F.T
    axis = np.stack([a, b, np.zeros_like(a)], 1) @ F.T
    return CSSolutions(q_user, axis, a * a + b * b - k, res, rc, real, duplicate, at_inf,
                       nullity, gap, shift_rcond)
