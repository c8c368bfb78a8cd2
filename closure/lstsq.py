"""Minimum-norm least-squares steps for batches of small matrices.

The pseudo-inverse truncated to an expected rank, applied by batched Cholesky on the
normal equations where the matrix is well conditioned and by the truncated SVD
elsewhere (:class:`_LstSq`), and the condition numbers ``s_max / s_rank``.  Shared by
the position solver and the analogs (:mod:`closure.kinematics`).
"""
from __future__ import annotations

import contextlib
import functools

import numpy as np

__all__: list[str] = []


def _expected_rank(mech) -> int:
    """Rank of the unknowns' Jacobian at a regular pose: the unknowns minus the idle
    freedoms (kept with the compiled plan once the mobility is known)."""
    plan = mech.plan
    if plan.rank is None:
        n_unknown = mech.tree.nv - len(mech.inputs)
        idle = mech.mobility - len(mech.inputs)
        plan.rank = n_unknown - idle
    return plan.rank


#: matrices of at least this many entries are factorised with BLAS on one thread: a batch
#: of the engine's small matrices gains nothing from BLAS threads and loses to their
#: start-up and spinning (measured: an SVD batch of 200 48x64 matrices 0.22 s on one
#: thread, 12 s with OpenBLAS's two beside another busy process); smaller ones run no
#: BLAS threads anyway, so they skip the limit's cost (~16 µs)
SERIAL_BLAS_ENTRIES = 256


@functools.lru_cache(maxsize=1)
def _threadpools():
    from threadpoolctl import ThreadpoolController
    return ThreadpoolController()


def _serial_blas(J):
    """Context: BLAS on one thread while the batch ``J (..., m, n)`` is factorised, where
    its matrices are big enough for BLAS to thread (:data:`SERIAL_BLAS_ENTRIES`)."""
    if J.shape[-1] * J.shape[-2] < SERIAL_BLAS_ENTRIES:
        return contextlib.nullcontext()
    return _threadpools().limit(limits=1, user_api="blas")


#: singular values below this fraction of the largest are treated as zero in steps
#: (minimum-norm steps at exactly singular poses, never a 1/0 blow-up)
SINGULAR_RTOL = 1e-12


def _pinv_parts(J, rank):
    """Truncated SVD pieces of a batch of matrices: (U, inv_s, Vt, condition).

    Keeps the ``rank`` largest singular values, and of those only the ones above
    ``SINGULAR_RTOL`` times the largest; the condition is ``s_max / s_rank``."""
    if J.shape[-1] == 0 or J.shape[-2] == 0:         # open chain: nothing to solve
        k = min(J.shape[-2:])
        B = J.shape[:-2]
        return (np.zeros(B + (J.shape[-2], k)), np.zeros(B + (k,)),
                np.zeros(B + (k, J.shape[-1])), np.ones(B))
    with _serial_blas(J):
        U, s, Vt = np.linalg.svd(J, full_matrices=False)
    rank = min(rank, s.shape[-1])
    k = np.arange(s.shape[-1])
    keep = (k < rank) & (s > SINGULAR_RTOL * s[..., :1])
    with np.errstate(divide="ignore", over="ignore"):
        inv_s = np.where(keep & (s > 1e-300), 1.0 / np.where(s > 0, s, 1.0), 0.0)
    return U, inv_s, Vt, _cond_of(s, rank)


def _cond_of(s, rank):
    """``s_max / s_rank`` from singular values ``(..., k)`` (inf where ``s_rank`` is 0)."""
    rank = min(rank, s.shape[-1])
    srank = s[..., rank - 1] if rank > 0 else np.ones(s.shape[:-1])
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return np.where(srank > 0, s[..., 0] / np.where(srank > 0, srank, 1.0), np.inf)


def _condition(J, rank):
    """Condition number ``s_max / s_rank`` of a batch of matrices (as :func:`_pinv_parts`,
    from the singular values alone)."""
    if J.shape[-1] == 0 or J.shape[-2] == 0:
        return np.ones(J.shape[:-2])
    with _serial_blas(J):
        return _cond_of(np.linalg.svd(J, compute_uv=False), rank)


#: poses whose estimated condition number (an upper bound, within a factor min(m, n))
#: is at most this solve by the normal equations (Cholesky, one step of iterative
#: refinement); the others by the truncated SVD
FAST_COND = 1e6


class _LstSq:
    """Minimum-norm least-squares solutions ``J X = R`` for a batch of matrices ``J``
    (B, m, n) truncated to ``rank``: the pseudo-inverse of :func:`_pinv_parts`.

    Where the expected rank is full (``min(m, n)``) the Gram matrix ``G`` (``J Jᵀ`` for
    wide, ``Jᵀ J`` for tall matrices) is factored by a batched Cholesky and solves take
    one step of iterative refinement; poses whose factorisation fails or whose condition
    estimate ``sqrt(tr G · tr G⁻¹)`` (at least the condition, at most ``min(m, n)``
    times it) exceeds :data:`FAST_COND`, and every pose of a mechanism whose expected
    rank is below ``min(m, n)``, use the truncated SVD as before (minimum-norm steps,
    never a 1/0).  No singular value is truncated at a Cholesky pose (its condition is
    far below ``1 / SINGULAR_RTOL``), so both give the same pseudo-inverse.

    Attributes
    ----------
    cond : (B,)
        ``s_max / s_rank`` for SVD poses, NaN for Cholesky poses (see :func:`_condition`).
    """

    def __init__(self, J, rank):
        B, m, n = J.shape
        k = min(m, n)
        self.J, self.wide = J, m < n
        self._inv_smin = np.zeros(B)
        with _serial_blas(J):
            self.fast = self._gram(J) if B and k and min(rank, k) == k else np.zeros(B, bool)
        self.slow = np.nonzero(~self.fast)[0]
        self.cond = np.full(B, np.nan)
        if self.slow.size:
            U, inv_s, Vt, cond = _pinv_parts(J[self.slow], rank)
            self.U, self.inv_s, self.Vt = U, inv_s, Vt
            self._inv_smin[self.slow] = np.max(inv_s, axis=1, initial=0.0)
            self.cond[self.slow] = cond

    def _gram(self, J):
        """Factor the Gram matrices; the poses that take the Cholesky path."""
        B = J.shape[0]
        Jt = np.swapaxes(J, 1, 2)
        G = J @ Jt if self.wide else Jt @ J
        ok = None
        try:
            L = np.linalg.cholesky(G)
        except np.linalg.LinAlgError:          # some not positive definite: screen them
            with np.errstate(all="ignore"):
                lam = np.linalg.eigvalsh(G)
            ok = lam[:, 0] > 1e-13 * lam[:, -1]
            L = np.tile(np.eye(G.shape[1]), (B, 1, 1))
            try:
                L[ok] = np.linalg.cholesky(G[ok])
            except np.linalg.LinAlgError:
                return np.zeros(B, dtype=bool)
        Linv = np.linalg.inv(L)                 # triangular with a positive diagonal
        tr_inv = np.einsum("bij,bij->b", Linv, Linv)                     # tr G⁻¹
        cest = np.sqrt(np.einsum("bij,bij->b", J, J) * tr_inv)           # ≥ s_max / s_min
        fast = cest <= FAST_COND                                         # False for NaN
        if ok is not None:
            fast &= ok
        if fast.all():
            self.Ginv = np.swapaxes(Linv, 1, 2) @ Linv                    # G⁻¹ = L⁻ᵀ L⁻¹
            self._inv_smin = np.sqrt(tr_inv)                             # ≥ 1 / s_min
        elif fast.any():
            Li = Linv[fast]
            self.Ginv = np.swapaxes(Li, 1, 2) @ Li
            self._inv_smin[fast] = np.sqrt(tr_inv[fast])
        return fast

    def inv_smin(self, above):
        """1 / (smallest kept singular value): exact for SVD poses; for Cholesky poses
        ``sqrt(tr G⁻¹)`` (at most ``sqrt(min(m, n))`` times it) where that is at most
        ``above``, else the 8th-power trace estimate (an upper bound within a factor
        ``min(m, n)^(1/16)``, nearly exact where that singular value stands apart; both to
        the eps · cond² ≤ 1e-4 of the normal equations)."""
        out = self._inv_smin.copy()
        big = self.fast & (out > above)
        if big.any():
            sel = big[self.fast]
            Gi = self.Ginv[sel]
            lam = out[big] ** 2                                          # tr G⁻¹
            M = Gi / lam[:, None, None]
            with np.errstate(all="ignore"):
                for p in (2, 4, 8):                  # λ_max(G⁻¹) ≤ tr(G⁻ᵖ)^(1/p)
                    M = M @ M
                    t = np.trace(M, axis1=1, axis2=2)
                    lam *= t ** (1.0 / p)
                    M /= t[:, None, None]
            out[big] = np.sqrt(lam)
        return out

    def solve(self, R):
        """``X`` (B, n, j) for right-hand sides ``R`` (B, m, j).  On the Cholesky poses one
        step of iterative refinement takes the relative error from about eps · cond² to
        (eps · cond²)² + eps · cond (≤ 1e-8 at ``FAST_COND``; the SVD's is eps · cond)."""
        B, m, n = self.J.shape
        X = np.zeros((B, n, R.shape[2]))
        if self.fast.any():
            allf = self.fast.all()
            J = self.J if allf else self.J[self.fast]
            Rf = R if allf else R[self.fast]
            Jt = np.swapaxes(J, 1, 2)
            Gi = self.Ginv
            if self.wide:
                Xf = Jt @ (Gi @ Rf)
                Xf += Jt @ (Gi @ (Rf - J @ Xf))
            else:
                Xf = Gi @ (Jt @ Rf)
                Xf += Gi @ (Jt @ (Rf - J @ Xf))
            if allf:
                return Xf
            X[self.fast] = Xf
        if self.slow.size:
            X[self.slow] = np.einsum("bkn,bk,bmk,bmj->bnj", self.Vt, self.inv_s, self.U,
                                     R[self.slow])
        return X
