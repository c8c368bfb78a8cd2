"""Every solution of a bilinear system ``M(λ) x = 0``: a rectangular multiparameter
eigenvalue problem, solved as one square generalised eigenproblem.

The problem.  ``M(λ) = λ₀ A₀ + λ₁ A₁ + … + λ_k A_k`` with k + 1 matrices of shape
(n + k − 1) × n; the unknowns are x ∈ Pⁿ⁻¹ and λ ∈ Pᵏ (both up to scale).  Generically
it has exactly C(n + k − 1, k) solutions over the complex numbers (the degree of the
locus where an (n + k − 1) × n matrix of linear forms in λ drops rank; equally the
multihomogeneous Bézout number of n + k − 1 equations of bidegree (1, 1) on
Pⁿ⁻¹ × Pᵏ).  Two synthesis problems are of this form:

- the directions of a CC link through five positions, ``gᵀ (R_j − I) w = 0``
  (j = 2…5): n = 3, k = 2, **6** solutions (Murray & McCarthy);
- the centres of an SS (or TS) link through seven positions (six bilinear equations in
  the homogeneous fixed and moving centres): n = 4, k = 3, **20** solutions (Innocenti;
  Liao & McCarthy).

The linearisation (Hochstenbach, Košir & Plestenjak, "Numerical methods for rectangular
multiparameter eigenvalue problems").  With λ₀ = 1, the wedge products
``Δ₀(x) = A₁x ∧ … ∧ A_kx`` and ``Δ_i(x)`` (A_i replaced by A₀) are forms of degree k in x
with values in Λᵏ(C^{n+k−1}), i.e. the k × k minors of the matrix ``[A₁x … A_kx]``.  At a
solution ``A₀x = −Σ λ_j A_j x``, so by multilinearity ``Δ_i(x) = −λ_i Δ₀(x)`` (Cramer's
rule).  Written on the C(n + k − 1, k) monomials of degree k in x the Δ's are square
matrices, and every solution is an eigenpair of the pencil ``(Δ₁, Δ₀)`` with the
eigenvector the monomials of x.  Since the pencil has exactly that many eigenvalues,
**all** solutions are found: no starting guesses and no path tracking.  The eigenvectors
give x, λ follows as the null vector of ``[A₀x … A_kx]``, and each solution is polished by
a few Newton steps on the original equations (complex arithmetic); the residual before
and after is kept, so an ill-conditioned solution is reported, not hidden.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass
from math import comb

import numpy as np
import scipy.linalg

__all__ = ["BilinearSolutions", "solve_bilinear"]


@dataclass
class BilinearSolutions:
    """All solutions of ``M(λ) x = 0``.

    Attributes
    ----------
    x : numpy.ndarray, complex, shape (s, n)
        The x of each solution, scaled so that its largest entry is 1.
    lam : numpy.ndarray, complex, shape (s, k + 1)
        The λ of each solution, scaled so that its largest entry is 1.
    residual : numpy.ndarray, shape (s,)
        ``|M(λ) x|`` after polishing, relative to ``Σ |A_i|`` (inf where the eigenvector
        gave no x: a failed eigenpair).
    real : numpy.ndarray of bool, shape (s,)
        Whether the solution is real (x and λ real to 1e-8 after the scaling).
    expected : int
        C(n + k − 1, k), the generic number of solutions.
    singular : bool
        The linearising pencil is singular (some generalised eigenvalue is 0/0): the
        problem is degenerate, its solution set is not finite (or some solutions are
        not isolated), and the eigenpairs are not to be trusted.
    rcond : numpy.ndarray, shape (s,)
        Reciprocal condition number of the equations' Jacobian at each solution (in the
        chart of the scaling): near 0 for a solution that is not isolated (a
        degenerate problem whose pencil was not seen to be singular) or a double one.
    """

    x: np.ndarray
    lam: np.ndarray
    residual: np.ndarray
    real: np.ndarray
    expected: int
    singular: bool = False
    rcond: np.ndarray | None = None


def _forms(As, n, k):
    """Coefficient matrix ``(C, C)`` of the k x k minors of ``[A_1 x … A_k x]`` on the
    monomials of degree k in x, for the k matrices ``As`` ((n + k − 1) × n each).

    Rows: the row subsets (lexicographic); columns: the monomials (sorted multisets of
    variable indices, lexicographic)."""
    rows = np.array(list(itertools.combinations(range(n + k - 1), k)))       # (C, k)
    monos = list(itertools.combinations_with_replacement(range(n), k))
    index = {m: i for i, m in enumerate(monos)}
    # every index tuple (m_1..m_k) -> the monomial it multiplies
    tuples = list(itertools.product(range(n), repeat=k))
    col = np.array([index[tuple(sorted(t))] for t in tuples])
    T = np.zeros((len(rows),) + (n,) * k, dtype=np.result_type(*As))
    letters = "abcdefgh"[:k]
    spec = ",".join(f"r{c}" for c in letters) + "->r" + letters
    for perm in itertools.permutations(range(k)):
        sign = np.linalg.det(np.eye(k)[list(perm)])
        # Π_j A_j[row_{σ(j)}, m_j]
        T = T + sign * np.einsum(spec, *[As[j][rows[:, perm[j]]] for j in range(k)])
    T = T.reshape(len(rows), -1)
    D = np.zeros((len(rows), len(monos)), dtype=T.dtype)
    for c in range(len(monos)):
        D[:, c] = T[:, col == c].sum(1)
    return D, monos


def _x_from_monomials(v, monos, n, k):
    """x (up to scale) from eigenvectors ``v (C, s)`` that are the monomials of x."""
    pure = np.array([monos.index((i,) * k) for i in range(n)])
    m = np.argmax(np.abs(v[pure]), axis=0)                 # the largest variable, per vector
    x = np.empty((n, v.shape[1]), dtype=complex)
    for i in range(n):
        # the monomial x_i x_m^(k−1)
        idx = np.array([monos.index(tuple(sorted((i,) + (mm,) * (k - 1)))) for mm in m])
        x[i] = v[idx, np.arange(v.shape[1])]
    return x.T


def _null(Ms):
    """Null vectors of a batch ``(s, r, c)`` (right singular vectors of the smallest value)."""
    _, _, Vh = np.linalg.svd(Ms)
    return Vh[:, -1].conj()


def _scaled(v):
    """Scale each row so that its largest entry (in modulus) is 1."""
    i = np.argmax(np.abs(v), axis=-1)
    return v / v[np.arange(len(v)), i][:, None]


def solve_bilinear(A, *, newton: int = 3, seed: int = 1) -> BilinearSolutions:
    """All solutions ``(x, λ)`` of ``Σ_i λ_i A_i x = 0``.

    Parameters
    ----------
    A : array_like, shape (k + 1, n + k − 1, n)
        The matrices A_0 … A_k (real or complex).
    newton : int
        Newton steps polishing each solution on the original equations.
    seed : int
        Seed of the fixed random change of coordinates of λ that keeps the pencil's
        chart λ₀ = 1 away from the solutions (the result does not depend on it beyond
        round-off).

    Returns
    -------
    BilinearSolutions
        Every eigenpair of the linearising pencil (C(n + k − 1, k) of them), polished.
    """
    A = np.asarray(A)
    k = A.shape[0] - 1
    n = A.shape[2]
    if A.shape[1] != n + k - 1:
        raise ValueError(f"A: expected shape (k + 1, n + k − 1, n), got {A.shape}")
    scale = np.abs(A).sum(0).max()
    A = A / scale
    # a fixed random orthogonal change of λ coordinates: μ = Qᵀ λ
    Q = np.linalg.qr(np.random.default_rng(seed).normal(size=(k + 1, k + 1)))[0]
    Am = np.einsum("ji,jrc->irc", Q, A)
    D0, monos = _forms([Am[j] for j in range(1, k + 1)], n, k)
    D1, _ = _forms([Am[0]] + [Am[j] for j in range(2, k + 1)], n, k)
    # a generic combination of the Δ_i (distinct eigenvalues even where λ_1 repeats)
    w = np.random.default_rng(seed + 1).uniform(0.5, 1.5, k)
    Dc = w[0] * D1
    for i in range(2, k + 1):
        Di, _ = _forms([Am[j] if j != i else Am[0] for j in range(1, k + 1)], n, k)
        Dc = Dc + w[i - 1] * Di
    ab, V = scipy.linalg.eig(Dc, D0, homogeneous_eigvals=True)
    # a singular pencil (α = β = 0 for some eigenvalue): the solution set is not finite
    tiny = 1e-11 * max(np.abs(Dc).max(), np.abs(D0).max())
    singular = bool(np.any((np.abs(ab[0]) <= tiny) & (np.abs(ab[1]) <= tiny)))
    C = comb(n + k - 1, k)
    if singular:                         # nothing to trust: report it, return no solution
        return BilinearSolutions(np.zeros((0, n), complex), np.zeros((0, k + 1), complex),
                                 np.zeros(0), np.zeros(0, bool), C, True, np.zeros(0))
    with np.errstate(all="ignore"):
        x = _scaled(_x_from_monomials(V, monos, n, k))
    ok = np.all(np.isfinite(x), 1)
    x[~ok] = np.nan
    lam = np.full((len(x), k + 1), np.nan, complex)
    rcond = np.zeros(len(x))
    # λ: the null vector of [A_0 x, …, A_k x]
    cols = np.einsum("irc,sc->sri", A, x[ok])                # (s, n + k − 1, k + 1)
    if ok.any():
        lam[ok] = _scaled(_null(cols))
        x[ok], lam[ok], rcond[ok] = _newton(A, x[ok], lam[ok], newton)
    with np.errstate(all="ignore"):
        res = np.linalg.norm(np.einsum("si,irc,sc->sr", lam, A, x), axis=1)
    res[~np.isfinite(res)] = np.inf
    real = (np.abs(x.imag).max(1) <= 1e-8) & (np.abs(lam.imag).max(1) <= 1e-8) & ok
    return BilinearSolutions(x, lam, res, real, C, singular, rcond)


def _newton(A, x, lam, steps):
    """Newton on ``M(λ) x = 0`` with the largest entries of x and λ fixed at 1 (complex)."""
    s, n = x.shape
    k1 = lam.shape[1]
    ix = np.argmax(np.abs(x), 1)
    il = np.argmax(np.abs(lam), 1)
    r = np.arange(s)
    keep = np.ones((s, n + k1), bool)            # fixed entries: their columns are dropped
    keep[r, ix] = False
    keep[r, n + il] = False

    def jacobian(x, lam):
        Jx = np.einsum("si,irc->src", lam, A)                           # (s, m, n)
        Jl = np.einsum("irc,sc->sri", A, x)                             # (s, m, k+1)
        J = np.concatenate([Jx, Jl], 2)
        return J[keep[:, None, :].repeat(J.shape[1], 1)].reshape(s, J.shape[1], -1)

    for _ in range(steps):
        F = np.einsum("si,irc,sc->sr", lam, A, x)                        # (s, m)
        Js = jacobian(x, lam)                    # square: m × (n − 1 + k)
        with np.errstate(all="ignore"):
            try:
                step = np.linalg.solve(Js, F[..., None])[..., 0]
            except np.linalg.LinAlgError:          # a singular one: least squares, per solution
                step = np.stack([np.linalg.lstsq(Js[i], F[i], rcond=None)[0] for i in range(s)])
        full = np.zeros((s, n + k1), dtype=complex)
        full[keep] = step.reshape(-1)
        ok = np.all(np.isfinite(full), 1)
        x = np.where(ok[:, None], x - full[:, :n], x)
        lam = np.where(ok[:, None], lam - full[:, n:], lam)
    sv = np.linalg.svd(jacobian(x, lam), compute_uv=False)
    return x, lam, sv[:, -1] / sv[:, 0]
