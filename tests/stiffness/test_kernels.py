"""The compiled kernels of stiffness_batch (stiffness.kernels) against an independent numpy
computation, pose by pose: ``P diag(k) Pᵀ`` from the legs' Plücker lines and
``np.linalg.cond`` of the dimensionless leg matrix."""
import numpy as np
import pytest

from closure import exp_so3
from stiffness import Hexapod
from stiffness.hexapod import GRAM_COND_LIMIT


EPS = np.finfo(float).eps


def _cond_tol(c, scale=1.0):
    """Relative error allowed of cond(P) = c: the Gram matrix's eigenvalues carry ~c² ε
    (above GRAM_COND_LIMIT singular values, ~c ε), leg vectors built from coordinates of
    size ``scale`` (m) ~c · scale · ε."""
    return 2 * EPS * np.minimum(c, GRAM_COND_LIMIT) ** 2 + 10 * EPS * c * scale


def _hexapod(legs, shift=np.zeros(3), seed=0):
    """A general hexapod (``legs`` legs, attachment points in two planes: the pose at zero
    height is singular) with its base moved by ``shift`` (m)."""
    rng = np.random.default_rng(seed)
    a = np.sort(rng.uniform(0, 2 * np.pi, legs))
    b = np.sort(rng.uniform(0, 2 * np.pi, legs))
    base = np.c_[0.8 * np.cos(a), 0.8 * np.sin(a), np.zeros(legs)]
    plat = np.c_[0.4 * np.cos(b), 0.4 * np.sin(b), np.zeros(legs)]
    return Hexapod(base + shift, plat, rng.uniform(5e6, 2e7, legs))


def _poses(n, shift=np.zeros(3), seed=1):
    rng = np.random.default_rng(seed)
    T = np.zeros((n, 4, 4))
    T[:, :3, :3] = exp_so3(rng.normal(scale=0.2, size=(n, 3)))
    T[:, :3, 3] = rng.normal(scale=0.05, size=(n, 3)) + [0, 0, 0.7] + shift
    T[:, 3, 3] = 1.0
    return T


def _reference(hx, T, frame):
    """K (one pose, numpy) from the leg matrix, and np.linalg.cond of the dimensionless leg
    matrix (moments about the platform centroid over the platform radius)."""
    R, t = T[:3, :3], T[:3, 3]
    d = hx.platform @ R.T + t - hx.base
    u = d / np.linalg.norm(d, axis=1)[:, None]          # (n, 3) unit legs, base axes
    if frame == "platform":
        v = u @ R                                         # rows Rᵀ u: platform axes
        P = np.vstack([v.T, np.cross(hx.platform, v).T])  # about the platform origin
    else:
        P = np.vstack([u.T, np.cross(hx.platform @ R.T + t, u).T])
    K = P @ np.diag(hx.k) @ P.T
    q = (hx.platform - hx.platform.mean(0)) @ R.T
    Ps = np.vstack([u.T, np.cross(q, u).T / hx.radius])
    return K, np.linalg.cond(Ps)


@pytest.mark.parametrize("legs", [6, 8])
@pytest.mark.parametrize("frame", [None, "platform"])
def test_kernel_K_and_cond_against_numpy_per_pose(legs, frame):
    hx = _hexapod(legs)
    T = _poses(300)
    T[7] = np.eye(4)
    T[7, 2, 3] = 1e-7                                    # nearly flat: P near singular
    K, c = hx.stiffness_batch(T, frame)
    assert K.shape == (300, 6, 6) and c.shape == (300,)
    for i in range(len(T)):
        Kr, cr = _reference(hx, T[i], frame)
        assert np.abs(K[i] - Kr).max() <= 1e-14 * np.abs(Kr).max()
        assert np.array_equal(K[i], K[i].T)
        assert abs(c[i] / cr - 1) <= _cond_tol(cr)
    assert c[7] > 1e6 and np.median(c) < 100


@pytest.mark.parametrize("far", [1e3, -1e3])
def test_kernel_far_from_the_origin(far):
    """The whole model 1e3 m from the base origin: K about the base origin against numpy
    (relative to its largest entry, which grows as |origin|² k), and about the platform —
    a property of the mechanism alone — against the same hexapod at the origin, as is
    cond(P) (moments about the platform centroid)."""
    shift = far * np.array([0.6, -0.8, 0.3])
    near, moved = _hexapod(6), _hexapod(6, shift)
    T0, T1 = _poses(200), _poses(200, shift)
    K0, c0 = near.stiffness_batch(T0, "platform")
    K1, c1 = moved.stiffness_batch(T1, "platform")
    Kb, cb = moved.stiffness_batch(T1)
    for i in range(len(T1)):
        Kr, cr = _reference(moved, T1[i], None)
        assert np.abs(Kb[i] - Kr).max() <= 1e-14 * np.abs(Kr).max()
        assert abs(cb[i] / cr - 1) <= _cond_tol(cr, 1e3)
    # the leg vectors carry the 1e3 m coordinates' rounding: ~1e3 ε relative to a leg
    assert np.abs(K1 - K0).max() <= 1e3 * 10 * EPS * np.abs(K0).max()
    assert np.all(np.abs(c1 / c0 - 1) <= _cond_tol(c0, 1e3)) and np.array_equal(cb, c1)


def test_kernel_refuses_bad_poses_with_their_index():
    from stiffness import StiffnessError
    hx = _hexapod(6)
    T = _poses(150)
    bad = T.copy()
    bad[130, 3, 0] = 0.5
    with pytest.raises(StiffnessError, match=r"T: last row must be \(0, 0, 0, 1\)"):
        hx.stiffness_batch(bad)
    bad = T.copy()
    bad[100, :3, 3] = hx.base[2] - hx.platform[2]       # leg 3 of pose 100 has zero length
    bad[100, :3, :3] = np.eye(3)
    with pytest.raises(StiffnessError, match=r"leg 3 has zero length .*pose index \(100,\)"):
        hx.stiffness_batch(bad)
    K, c = hx.stiffness_batch(T[:0])
    assert K.shape == (0, 6, 6) and c.shape == (0,)


def test_import_stiffness_does_not_import_numba():
    """numba is imported by stiffness.kernels only, when a batch is first evaluated."""
    import subprocess
    import sys
    code = ("import sys, numpy as np, stiffness\n"
            "assert 'numba' not in sys.modules\n"
            "from linkwright.bench_stiffness_speed import _hexapod_and_poses\n"
            "hx, T = _hexapod_and_poses(3)\n"
            "hx.stiffness_batch(T)\n"
            "assert 'numba' in sys.modules\n")
    subprocess.run([sys.executable, "-c", code], check=True)
