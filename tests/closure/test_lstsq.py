"""The Newton step without an SVD per iteration: the Cholesky path of ``_LstSq`` gives the
truncated-SVD pseudo-inverse, falls back to it where it must, and the condition reported
is the SVD's; a batch solved in chunks equals the batch solved at once."""
import numpy as np
import pytest

import closure.solver as S
from closure.solver import _LstSq, _condition, _pinv_parts
from linkwright.references import rssr


def _matrices(rng, B, m, n, cond):
    """B matrices (m, n) of full rank min(m, n) with condition numbers up to ``cond``."""
    k = min(m, n)
    out = np.empty((B, m, n))
    for b in range(B):
        U = np.linalg.qr(rng.normal(size=(m, m)))[0][:, :k]
        V = np.linalg.qr(rng.normal(size=(n, n)))[0][:, :k]
        s = np.exp(rng.uniform(-np.log(cond), 0, k))
        s[0] = 1.0
        out[b] = (U * s) @ V.T
    return out


def _pinv_solve(J, rank, R):
    U, inv_s, Vt, _ = _pinv_parts(J, rank)
    return np.einsum("bkn,bk,bmk,bmj->bnj", Vt, inv_s, U, R)


@pytest.mark.parametrize("m, n", [(6, 7), (6, 3), (6, 5), (12, 12), (24, 12)])
@pytest.mark.parametrize("cond", [10.0, 1e4, 1e9])
def test_cholesky_path_is_the_truncated_svd_pseudo_inverse(m, n, cond):
    rng = np.random.default_rng(m * 100 + n)
    J = _matrices(rng, 40, m, n, cond)
    R = rng.normal(size=(40, m, 2))
    ls = _LstSq(J, min(m, n))
    ref = _pinv_solve(J, min(m, n), R)
    s = np.linalg.svd(J, compute_uv=False)
    true_cond = s[:, 0] / s[:, -1]
    # the condition estimate is an upper bound: no pose above FAST_COND is solved by Cholesky
    assert not (ls.fast & (true_cond > S.FAST_COND)).any()
    if cond <= 1e4:
        assert ls.fast.all()
    # minimum-norm least squares to the accuracy of the SVD (eps · cond)
    err = np.abs(ls.solve(R) - ref).max(axis=(1, 2)) / np.abs(ref).max(axis=(1, 2))
    assert (err <= 1e-14 * true_cond + 1e-14).all()
    # 1 / s_min: as the SVD's on SVD poses; on Cholesky poses an upper bound within
    # min(m, n)^(1/16) (up to the eps · cond² of the normal equations)
    inv = ls.inv_smin(0.0)
    tol = 1e-15 * true_cond + 1e-9 + np.where(ls.fast, 1e-15 * true_cond ** 2, 0.0)
    assert (inv >= (1 - tol) / s[:, -1]).all()
    assert (inv <= min(m, n) ** (1 / 16) * (1 + tol) / s[:, -1]).all()
    np.testing.assert_array_equal(np.isnan(ls.cond), ls.fast)
    np.testing.assert_allclose(ls.cond[~ls.fast], true_cond[~ls.fast], rtol=1e-12)
    np.testing.assert_allclose(_condition(J, min(m, n)), _pinv_parts(J, min(m, n))[3],
                               rtol=1e-12)


def test_rank_below_the_matrix_size_and_singular_poses_take_the_svd():
    rng = np.random.default_rng(3)
    J = _matrices(rng, 10, 6, 7, 10.0)
    J[3] = 0.0                                    # exactly singular: minimum norm, no 1/0
    J[5, 2] = J[5, 1]                             # rank 5 of 6
    R = rng.normal(size=(10, 6, 1))
    ls = _LstSq(J, 6)
    assert not ls.fast[3] and not ls.fast[5] and ls.fast[[0, 1, 2, 4]].all()
    X = ls.solve(R)
    assert np.isfinite(X).all() and (X[3] == 0).all()
    np.testing.assert_allclose(X, _pinv_solve(J, 6, R), rtol=0, atol=1e-12)
    low = _LstSq(J, 5)                            # expected rank 5 < 6: always the SVD
    assert not low.fast.any()
    np.testing.assert_allclose(low.solve(R), _pinv_solve(J, 5, R), rtol=0, atol=1e-12)


def test_chunked_batch_equals_one_batch(monkeypatch):
    m, _ = rssr(0.2, 1)
    x = np.linspace(-2.5, 2.5, 301)
    whole = m.solve(x)
    monkeypatch.setattr(S, "CHUNK", 64)
    parts = m.solve(x)
    for f in ("q", "rot", "residual", "condition", "iterations", "status", "reached"):
        np.testing.assert_array_equal(getattr(parts, f), getattr(whole, f))
    few = S._take_pose(whole, [0, 1, 2])
    with pytest.raises(S.MechanismError, match="guess: has 3 poses"):
        m.solve(x, guess=few)
    guided = m.solve(x, guess=whole)               # one guess per input, chunk by chunk
    np.testing.assert_allclose(guided.q, whole.q, rtol=0, atol=1e-12)


def test_big_batches_factorised_with_blas_on_one_thread():
    """The engine's batched factorisations run BLAS on one thread where its matrices are
    big enough for BLAS to thread, and leave small ones (and BLAS afterwards) alone."""
    import contextlib

    from threadpoolctl import threadpool_info

    from closure.lstsq import SERIAL_BLAS_ENTRIES, _serial_blas

    def blas_threads():
        return [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]
    before = blas_threads()
    with _serial_blas(np.zeros((3, 16, SERIAL_BLAS_ENTRIES // 16))):
        assert blas_threads() and all(n == 1 for n in blas_threads())
    assert blas_threads() == before
    assert isinstance(_serial_blas(np.zeros((500, 6, 7))), contextlib.nullcontext)
