"""The position solver's block-sparse least squares (loop chains: the Gram matrix factored
on its envelope) against the dense factorisation it replaces, and the batch solve (one
kernel call: every guess corrected, then continued) against the two-step path, its
independence of batch size and order, and its memory per position."""
import tracemalloc

import numpy as np
import pytest

from closure import Mechanism, solver as S, transform, translation
from linkwright.references import fourbar_chain, rssr

from .models import parallelogram


@pytest.fixture
def dense():
    """Run the solver with every Jacobian factored densely (the reference)."""
    def run(fn):
        S.DENSE_LSQ = True
        try:
            return fn()
        finally:
            S.DENSE_LSQ = False
    return run


def _same_poses(a, b, atol=1e-12):
    """Two solves of the same inputs agree to rounding: same branch, iterations and
    status, coordinates and residuals to ``atol``."""
    np.testing.assert_array_equal(a.status, b.status)
    np.testing.assert_array_equal(a.iterations, b.iterations)
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=atol)
    np.testing.assert_allclose(a.residual, b.residual, rtol=0, atol=1e-14)


@pytest.mark.parametrize("n", [2, 5, 12])
def test_block_sparse_path_equals_the_dense_one_on_chains_of_four_bars(n, dense):
    """N four-bars in series (a block-bidiagonal Jacobian): one pose, a batch, a sweep and
    a Newton correction give the dense factorisation's poses, iterations and conditions
    to rounding."""
    m = fourbar_chain(n)
    p0 = m.solve(0.0)
    x = np.linspace(-0.4, 0.4, 9)
    _same_poses(m.solve(x, guess=p0), dense(lambda: m.solve(x, guess=p0)))
    one, one_d = m.solve(0.25, guess=p0), dense(lambda: m.solve(0.25, guess=p0))
    _same_poses(one, one_d)
    np.testing.assert_allclose(one.kinematics().first, one_d.kinematics().first, rtol=1e-10,
                               atol=1e-12)
    np.testing.assert_allclose(one.condition, one_d.condition, rtol=1e-9)
    nc, nc_d = m.solve(0.05, guess=p0, continuation=False), \
        dense(lambda: m.solve(0.05, guess=p0, continuation=False))
    _same_poses(nc, nc_d)
    df, df_d = m.sweep(np.linspace(0.0, 0.6, 7)), dense(lambda: m.sweep(np.linspace(0, 0.6, 7)))
    np.testing.assert_array_equal(df.iterations, df_d.iterations)
    assert df.status.tolist() == df_d.status.tolist()
    np.testing.assert_allclose(df.condition, df_d.condition, rtol=1e-9)


@pytest.mark.parametrize("t2", [1e-2, 1e-3, 1e-6])
def test_block_sparse_path_near_singular_chain(t2, dense):
    """Parallelograms in series drawn almost flat: the Jacobian's condition 1e4 to 1e10,
    so that its smallest singular value is estimated by the trace of powers of G⁻¹ (the
    envelope factor's inverse made dense) or the truncated SVD takes over: the Newton
    corrections, and continuation through the flat position, equal the dense path's."""
    m = fourbar_chain(4, 1.0, 3.0, 1.0, 3.0, t2_0=t2)
    q, rot = m.assembly()
    rng = np.random.default_rng(3)
    guess = (q + rng.normal(size=(6, q.shape[1])) * 1e-3, np.repeat(rot, 6, 0))
    guess[0][:, m.input_q_columns()] = q[:, m.input_q_columns()]
    opts = S.SolverOptions()
    a = S.newton(m, guess, opts)
    b = dense(lambda: S.newton(m, guess, opts))
    np.testing.assert_array_equal(a[2], b[2])                 # iterations
    np.testing.assert_array_equal(a[4], b[4])                 # converged
    # rounding, amplified by the condition (the pose is that sharp along its near-null
    # direction only)
    np.testing.assert_allclose(a[0][0], b[0][0], rtol=0, atol=max(1e-12, 1e-15 * b[3].max()))
    np.testing.assert_allclose(a[1], b[1], rtol=0, atol=1e-14)  # residual
    np.testing.assert_allclose(a[3], b[3], rtol=1e-3)         # condition, at those poses
    assert a[3].max() > 1e3
    x = np.linspace(-0.05, 0.05, 5) - t2                      # across the flat position
    p0 = m.solve(0.0)
    _same_poses(m.solve(x, guess=p0, raise_on_failure=False),
                dense(lambda: m.solve(x, guess=p0, raise_on_failure=False)), atol=1e-9)


def rssr_chain(n):
    """``n`` spatial RSSR loops in series: each rocker (a revolute joint to the ground on
    a tilted axis) drives the next loop's S–S rod.  Every loop has 7 unknowns for its 6
    rows (the rod's idle spin): the wide case, G = J Jᵀ block-tridiagonal over loops."""
    links = ["crank"] + [f"{x}{k}" for k in range(n) for x in ("rod", "rocker")]
    m = Mechanism(links)
    m.add_joint("A0", "R", "ground", "crank", at=np.eye(4))
    u = np.array([0.2, 1.0, 0.3]) / np.linalg.norm([0.2, 1.0, 0.3])
    e1 = np.cross(u, [0, 0, 1.0])
    e1 /= np.linalg.norm(e1)
    R = np.stack([e1, np.cross(u, e1), u], -1)
    driver, a = "crank", np.array([1.0, 0.0, 0.0])
    for k in range(n):
        P = np.array([2.0 + 2.0 * k, 0.5, 0.8])
        b = P + 1.6 * R[:, 0] * np.cos(0.4 + 0.3 * k) + 1.6 * R[:, 1] * np.sin(0.4 + 0.3 * k)
        m.add_joint(f"Sa{k}", "S", driver, f"rod{k}", at=translation(a))
        m.add_joint(f"Sb{k}", "S", f"rod{k}", f"rocker{k}", at=translation(b))
        m.add_joint(f"R{k}", "R", "ground", f"rocker{k}", at=transform(R, P))
        driver, a = f"rocker{k}", b + 0.7 * np.cross(u, b - P) / np.linalg.norm(b - P)
    m.add_input("A0")
    return m


def test_block_sparse_path_equals_the_dense_one_on_a_chain_of_spatial_loops(dense):
    """RSSR loops in series (wide Jacobian blocks: the Gram matrix over rows): batch,
    one pose and sweep equal the dense factorisation's."""
    from closure import solve_kernels as K
    m = rssr_chain(5)
    P = K._pattern(*m.plan.packed[:2], m.plan._ucols)
    assert P[K.P_WIDE] == 1 and P[K.P_DENSE] == 0
    p0 = m.solve(0.0)
    x = np.linspace(-0.3, 0.3, 7)
    _same_poses(m.solve(x, guess=p0), dense(lambda: m.solve(x, guess=p0)))
    one, one_d = m.solve(0.2, guess=p0), dense(lambda: m.solve(0.2, guess=p0))
    _same_poses(one, one_d)
    np.testing.assert_allclose(one.kinematics().first, one_d.kinematics().first, rtol=1e-10,
                               atol=1e-12)
    df, df_d = m.sweep(np.linspace(0, 0.5, 6)), dense(lambda: m.sweep(np.linspace(0, 0.5, 6)))
    np.testing.assert_array_equal(df.iterations, df_d.iterations)
    np.testing.assert_allclose(df.condition, df_d.condition, rtol=1e-9)


def _two_step(m, x, guess, opts):
    """The poses of solve by the former two calls: the guesses corrected, then continued."""
    start, owned = S._start_pose(m, guess, x.shape[0], opts)
    reached, q, rot, res, its, cond, ks, stop, _ = S._walk(m, start, x, opts, owned=owned)
    code = np.where(start.status >= 2, start.status, stop)
    return q, rot, res, its, code, reached


@pytest.mark.parametrize("build", [lambda: rssr(0.2, 1)[0], lambda: fourbar_chain(3),
                                   lambda: parallelogram(1.0, 2.0)])
def test_one_call_batch_solve_equals_the_two_step_path(build):
    """The batch solve in one kernel call (guesses corrected and continued, members with
    the same guess sharing its correction) gives the two-step path's poses bit for bit,
    dead points and failures included."""
    m = build()
    opts = S.SolverOptions()
    g = m.solve(np.linspace(-0.6, 0.6, 5))
    idx = np.repeat(np.arange(5), 7)                          # runs of equal guesses
    x = np.linspace(-2.5, 2.5, idx.size)[:, None] + 0.3
    guess = S._take_pose(g, idx)
    guess._ks = None                                          # not settled: corrected
    p = m.solve(x, guess=guess, raise_on_failure=False)
    q, rot, res, its, code, reached = _two_step(m, x, guess, opts)
    np.testing.assert_array_equal(p.q, q)
    np.testing.assert_array_equal(p.rot, rot)
    np.testing.assert_array_equal(p.residual, res)
    np.testing.assert_array_equal(p.iterations, its)
    np.testing.assert_array_equal(p.reached, reached)
    np.testing.assert_array_equal(np.where(code > 0, code, 0), np.where(p.status >= 2,
                                                                          p.status, 0))


@pytest.mark.parametrize("build", [lambda: rssr(0.2, 1)[0], lambda: fourbar_chain(4)])
def test_batch_results_independent_of_batch_size_and_order(build):
    """Every member is solved on its own: a batch, its reverse, a permutation, sub-batches
    of any size (kept kinematic state or not) and single solves give the same poses bit
    for bit."""
    m = build()
    g = m.solve(np.linspace(-0.5, 0.5, 4))
    rng = np.random.default_rng(5)
    B = 150
    idx = np.sort(rng.integers(0, 4, B))
    x = rng.uniform(-1.0, 1.0, (B, 1))
    guess = S._take_pose(g, idx)
    guess._ks = None
    full = m.solve(x, guess=guess, raise_on_failure=False)
    for order in (np.arange(B)[::-1], rng.permutation(B)):
        p = m.solve(x[order], guess=S._take_pose(guess, order), raise_on_failure=False)
        for f in ("q", "rot", "residual", "iterations", "status", "reached"):
            np.testing.assert_array_equal(getattr(p, f), getattr(full, f)[order])
    for size in (1, 7, 64, 65):
        for a in range(0, B, 61):
            sl = np.arange(a, min(a + size, B))
            p = m.solve(x[sl], guess=S._take_pose(guess, sl), raise_on_failure=False)
            np.testing.assert_array_equal(p.q, full.q[sl])
            np.testing.assert_array_equal(p.iterations, full.iterations[sl])
            np.testing.assert_array_equal(p.condition, full.condition[sl])


def test_batch_solve_memory_per_position():
    """The batch solve holds no per-position kinematic state: peak Python-visible memory
    (tracemalloc) below 1 KB per position for the RSSR (the returned poses ~ 200 B)."""
    m, _ = rssr(0.2, 1)
    n = 6000
    x = np.linspace(-np.pi, np.pi, n, endpoint=False)
    g = m.solve(np.linspace(-np.pi, np.pi, 32, endpoint=False) * 0.98,
                raise_on_failure=False)
    near = np.abs(x[:, None] - g.inputs[None, :, 0]).argmin(1)
    guess = S._take_pose(g, near)
    guess._ks = None
    m.solve(x[:10], guess=S._take_pose(guess, np.arange(10)))
    tracemalloc.start()
    pose = m.solve(x, guess=guess, raise_on_failure=False)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert (pose.status <= 1).all()
    assert peak / n < 1024
