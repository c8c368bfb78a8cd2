"""The compiled helpers of the helical root searches (:mod:`synthesis.kernels`) against
independent numpy references."""
import numpy as np
import pytest

from synthesis.kernels import hh_grid, hs_grid_minima


def _minima_reference(f):
    """Local minima of f (nb, nt, nt, nt) against its eight neighbours by shifted copies:
    β wraps to β ± π with the θ axes reversed, θ padded with +inf (no wrap)."""
    P = np.concatenate([f[-1:, ::-1, ::-1, ::-1], f, f[:1, ::-1, ::-1, ::-1]], 0)
    P = np.pad(P, [(0, 0), (1, 1), (1, 1), (1, 1)], constant_values=np.inf)
    core = P[1:-1, 1:-1, 1:-1, 1:-1]
    ok = np.ones(f.shape, bool)
    for ax in range(4):
        for sh in (-1, 1):
            sl = [slice(1, -1)] * 4
            sl[ax] = slice(1 + sh, P.shape[ax] - 1 + sh)
            ok &= core <= P[tuple(sl)]
    return ok


@pytest.mark.parametrize("seed", range(40))
def test_hs_grid_minima_match_the_shifted_copies(seed):
    rng = np.random.default_rng(seed)
    nb, nt = rng.integers(2, 8), rng.integers(2, 7)
    f = rng.integers(0, 4, (nb, nt, nt, nt)).astype(float)      # many ties
    f[rng.random(f.shape) < 0.05] = np.nan                        # singular cells
    np.testing.assert_array_equal(hs_grid_minima(f), _minima_reference(f))


def test_hh_grid_is_the_least_squares_misfit():
    """The grid's misfit from its normal equations equals numpy's least-squares residual
    of the same six equations (helical._equations) for every direction."""
    from synthesis import Screw
    from synthesis.binary import _fibonacci, _task
    from synthesis.helical import _equations
    rng = np.random.default_rng(3)
    s = []
    for _ in range(2):
        u = rng.normal(size=3)
        s.append(Screw(u / np.linalg.norm(u), rng.normal(size=3), rng.uniform(0.4, 2.0),
                       rng.normal()))
    task = _task(s, "s", (3,))
    pn = (0.2, -0.1)
    G = _fibonacci(400)
    f = hh_grid(G, np.ascontiguousarray(task.R), np.ascontiguousarray(task.t), np.array(pn))
    A, rhs, *_, ok = _equations(G, task.R, task.t, ("H", "H"), pn)
    ref = np.array([np.linalg.norm(a @ np.linalg.lstsq(a, r, rcond=None)[0] - r)
                    for a, r in zip(A, rhs)])
    assert np.all(np.isinf(f[~ok]))
    np.testing.assert_allclose(f[ok], ref[ok], rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("seed", range(6))
def test_hs_jacobian_matches_central_differences(seed):
    """The HS residual's exact variable-projection Jacobian against central differences
    of the residual itself (h = 1e-6: their error ~1e-10 of the entries)."""
    from scipy.spatial.transform import Rotation

    from synthesis import kernels as K
    rng = np.random.default_rng(seed)
    R = Rotation.random(3, random_state=seed).as_matrix()
    t = rng.normal(size=(3, 3))
    a = rng.normal(size=3)
    a /= np.linalg.norm(a)
    b = np.cross(a, rng.normal(size=3))
    b /= np.linalg.norm(b)
    z = np.r_[rng.uniform(0, np.pi), rng.uniform(-3, 3, 3)]
    p = rng.uniform(-0.5, 0.5)
    V, Ms, _, _, _, _, _, A9, rhs9, Q = K._scratch()

    def residual(zz):
        f = np.empty(9)
        K._hs_residual(zz, a, b, R, t, p, f, V, Ms, A9, rhs9, Q)
        return f

    f = residual(z)
    J = np.empty((9, 4))
    assert K._hs_jacobian(z, a, b, R, t, p, f, J, V, Ms, A9, rhs9, Q, np.zeros((9, 9)))
    h = 1e-6
    Jfd = np.stack([(residual(z + h * e) - residual(z - h * e)) / (2 * h) for e in np.eye(4)], 1)
    assert np.linalg.norm(f) > 0.1                        # away from a root: both terms count
    np.testing.assert_allclose(J, Jfd, atol=1e-8 * np.abs(J).max())
