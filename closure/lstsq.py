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

from .state import _arr

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
    return _serial_blas_entries(J.shape[-1] * J.shape[-2])


_NULL = contextlib.nullcontext()


def _serial_blas_entries(entries: int):
    """:func:`_serial_blas` for matrices of ``entries`` entries."""
    if entries < SERIAL_BLAS_ENTRIES:
        return _NULL
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
    if (srank > 1e-290).all():                  # no zero, no overflow: plain division
        return s[..., 0] / srank
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return np.where(srank > 0, s[..., 0] / np.where(srank > 0, srank, 1.0), np.inf)


def _condition(J, rank):
    """Condition number ``s_max / s_rank`` of a batch of matrices (as :func:`_pinv_parts`,
    from the singular values alone: numpy's batched SVD without the vectors)."""
    if J.shape[-1] == 0 or J.shape[-2] == 0:
        return np.ones(J.shape[:-2])
    with _serial_blas(J):
        return _cond_of(np.linalg.svd(J, compute_uv=False), rank)


#: placeholders for the arguments a task of closure.solve_kernels.lsq_batch does not use
_NO_1, _NO_3 = np.zeros(0), np.zeros((0, 0, 0))
_NO_R = np.zeros((0, 0, 1))


#: poses whose estimated condition number (an upper bound, within a factor min(m, n))
#: is at most this solve by the normal equations (Cholesky, one step of iterative
#: refinement); the others by the truncated SVD
FAST_COND = 1e6


class _LstSq:
    """Minimum-norm least-squares solutions ``J X = R`` for a batch of matrices ``J``
    (B, m, n) truncated to ``rank``: the pseudo-inverse of :func:`_pinv_parts`.

    Where the expected rank is full (``min(m, n)``) the Gram matrix ``G`` (``J Jᵀ`` for
    wide, ``Jᵀ J`` for tall matrices) is factored by Cholesky and solves take one step of
    iterative refinement; poses whose factorisation fails or whose condition estimate
    ``sqrt(tr G · tr G⁻¹)`` (at least the condition, at most ``min(m, n)`` times it)
    exceeds :data:`FAST_COND`, and every pose of a mechanism whose expected rank is below
    ``min(m, n)``, use the truncated SVD (minimum-norm steps, never a 1/0).  No singular
    value is truncated at a Cholesky pose (its condition is far below
    ``1 / SINGULAR_RTOL``), so both give the same pseudo-inverse.  The work is done per
    matrix by the compiled kernels the solver's Newton step uses
    (:mod:`closure.solve_kernels`).

    Attributes
    ----------
    cond : (B,)
        ``s_max / s_rank`` for SVD poses, NaN for Cholesky poses (see :func:`_condition`).
    """

    def __init__(self, J, rank):
        from . import solve_kernels
        self._k = solve_kernels
        J = _arr(J)
        B, m, n = J.shape
        k = min(m, n)
        self.J, self.wide = J, m < n
        self.fast = np.zeros(B, dtype=bool)
        self.cond = np.empty(B)
        self._inv_smin = np.empty(B)
        self.Ginv = np.zeros((B, k, k))
        self.U, self.inv_s, self.Vt = np.zeros((B, m, k)), np.zeros((B, k)), np.zeros((B, k, n))
        with _serial_blas(J):
            solve_kernels.lsq_batch(0, J, int(rank), self.fast, self.cond, self._inv_smin,
                                    self.Ginv, self.U, self.inv_s, self.Vt, _NO_R, _NO_3, 0.0)
        self.slow = np.nonzero(~self.fast)[0]

    def inv_smin(self, above):
        """1 / (smallest kept singular value): exact for SVD poses; for Cholesky poses
        ``sqrt(tr G⁻¹)`` (at most ``sqrt(min(m, n))`` times it) where that is at most
        ``above``, else the 8th-power trace estimate (an upper bound within a factor
        ``min(m, n)^(1/16)``, nearly exact where that singular value stands apart; both to
        the eps · cond² ≤ 1e-4 of the normal equations)."""
        out = np.empty(self.fast.size)
        self._k.lsq_batch(2, self.J, 0, self.fast, out, self._inv_smin, self.Ginv, self.U,
                          self.inv_s, self.Vt, _NO_R, _NO_3, float(above))
        return out

    def solve(self, R):
        """``X`` (B, n, j) for right-hand sides ``R`` (B, m, j).  On the Cholesky poses one
        step of iterative refinement takes the relative error from about eps · cond² to
        (eps · cond²)² + eps · cond (≤ 1e-8 at ``FAST_COND``; the SVD's is eps · cond)."""
        B, m, n = self.J.shape
        R = _arr(R)
        if R.shape[:2] != (B, m):
            raise ValueError(f"solve: expected right-hand sides ({B}, {m}, j), got {R.shape}")
        X = np.empty((B, n, R.shape[2]))
        self._k.lsq_batch(1, self.J, 0, self.fast, _NO_1, _NO_1, self.Ginv, self.U, self.inv_s,
                          self.Vt, R, X, 0.0)
        return X
