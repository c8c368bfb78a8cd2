"""The HS / SH root search (synthesis.kernels: hs_grid, hs_starts, hs_refine; its driver
synthesis.spherical._hs_roots): its grid against numpy's least squares, its starting
points against the grid's own minima, the batched family path against the one-task
functions, and the roots the search found before it was compiled end to end."""
import numpy as np
import pytest

from closure import exp_se3
from synthesis import Screw
from synthesis.spherical import _hs_links_grid, hs_links, sh_links, task_frame

#: (kind, task seed, pitch, azimuth) → (elevation, sphere centre) of every link the search
#: found when its steps were numpy-driven kernels, one circle at a time (commit 3123d79)
REFERENCE = {
    ("HS", 71, 0.35, 0.6): [
        (1.1688629117142357, -1.684451979281409, -0.36758369101135424, 0.6169287164679007),
        (2.4962550399080743, -3.396688039587965, 3.554266313819111, 6.3075466711103685)],
    ("HS", 72, -0.8, 2.2): [
        (1.9769696786590123, 10.883778664805615, -0.6935432132815814, -8.245676651961851)],
    ("SH", 73, 0.5, 1.3): [
        (0.24461726202606004, 9.612877167054167, -4.924275526520915, -5.191750531436156),
        (0.34300724030563146, -9.449602018522135, 6.163159820157532, -9.833270139684926),
        (0.3800921428290542, 0.6939232112900224, 0.8288037934705202, -7.229436679980832),
        (2.4916950383483654, -3.0939422289948952, 2.3892133941470535, 1.846196388423426),
        (2.8683098116388255, -1.163709211712387, -1.4376492366350295, 2.556516862303112)],
    ("SH", 74, -0.25, 0.1): [
        (1.1490178786797767, 1.2260284002624873, 0.15413949056831888, 0.6139583675381551),
        (1.1503407892038713, 1.184868449027479, -1.4404622992441687, 1.6413975151044848),
        (2.236615769006794, 1.3176222414153897, 0.0534603225912359, 0.3088608759760866),
        (3.111837385735025, -104.59497899292172, 138.69017382215907, 240.57769792905924)],
}


def task(seed, n=4):
    rng = np.random.default_rng(seed)
    T = [np.eye(4)]
    for _ in range(n - 1):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        c = rng.normal(size=3)
        th, s = rng.uniform(0.3, 2.5), rng.normal()
        T.append(exp_se3(np.r_[-th * np.cross(u, c) + s * u, th * u]))
    return [Screw.from_matrix(t) for t in T[1:]]


def normalised(seed):
    """A task's normalised R (3, 3, 3), t (3, 3) and a unit circle (a, b)."""
    from synthesis.binary import _task
    tk = _task(task(seed), "screws", (4,))
    F = task_frame(task(seed))
    return (np.ascontiguousarray(tk.R), np.ascontiguousarray(tk.t), F[:, 2],
            np.cos(0.7) * F[:, 0] + np.sin(0.7) * F[:, 1])


@pytest.mark.parametrize("key", list(REFERENCE))
def test_the_search_finds_the_links_it_found_before(key):
    kind, seed, p, psi = key
    links = (hs_links if kind == "HS" else sh_links)(task(seed), p, psi)
    got = np.array([[lk.parameters["elevation"],
                     *(lk.moving_axis.point if kind == "HS" else lk.fixed_axis.point)]
                    for lk in links]).reshape(-1, 4)
    ref = np.array(REFERENCE[key])
    assert len(got) == len(ref)
    for r in ref:
        assert np.abs(got - r).max(1).min() <= 1e-8 * max(1.0, np.abs(r).max()), r


def test_hs_grid_is_the_least_squares_misfit():
    """Every grid point's misfit equals numpy's least-squares residual of the nine HS
    equations (kernels.hs_systems) there."""
    from synthesis.kernels import hs_grid, hs_systems
    R, t, a, b = normalised(5)
    p, nb, nt = 0.3, 3, 4
    f = hs_grid(a, b, R, t, p, nb, nt)
    bt = (np.arange(nb) + 0.5) * np.pi / nb
    tg = -np.pi + (np.arange(nt) + 0.5) * 2 * np.pi / nt
    Z = np.stack(np.meshgrid(bt, tg, tg, tg, indexing="ij"), -1).reshape(-1, 4)
    g = np.cos(Z[:, :1]) * a + np.sin(Z[:, :1]) * b
    A, rhs = hs_systems(g, np.ascontiguousarray(Z[:, 1:]), R, t, p)
    ref = [np.linalg.norm(m @ np.linalg.lstsq(m, r, rcond=None)[0] - r) for m, r in zip(A, rhs)]
    np.testing.assert_allclose(f.ravel(), ref, rtol=1e-6, atol=1e-9)


def test_starts_are_the_roots_then_each_grids_minima():
    """hs_starts: per circle its given roots, then the minima of hs_grid (hs_grid_minima) of
    each grid in C order, at the grid points' coordinates."""
    from synthesis.kernels import hs_grid, hs_grid_minima, hs_starts
    R, t, a, b = normalised(6)
    P = np.stack([np.stack([a, b]), np.stack([b, -a])])
    grids = np.array([[5, 4], [7, 3]])
    z = np.array([[0.1, 0.2, 0.3, 0.4], [0.5, 0.6, 0.7, 0.8], [0.9, 1.0, 1.1, 1.2]])
    circle = np.array([0, 1, 1])
    starts, own, m = hs_starts(R, t, P, circle, z, 0.4, grids)
    starts, own = starts[:m], own[:m]
    expected, owners = [], []
    for i in range(2):
        parts = [z[circle == i]]
        for nb, nt in grids:
            idx = np.argwhere(hs_grid_minima(hs_grid(P[i, 0], P[i, 1], R, t, 0.4, nb, nt)))
            bt = (np.arange(nb) + 0.5) * np.pi / nb
            tg = -np.pi + (np.arange(nt) + 0.5) * 2 * np.pi / nt
            parts.append(np.c_[bt[idx[:, 0]], tg[idx[:, 1]], tg[idx[:, 2]], tg[idx[:, 3]]])
        expected += parts
        owners.append(np.full(sum(map(len, parts)), i))
    np.testing.assert_array_equal(starts, np.concatenate(expected))
    np.testing.assert_array_equal(own, np.concatenate(owners))


@pytest.mark.parametrize("kind", ["HS", "SH"])
def test_family_batch_equals_the_one_task_functions(kind):
    """_hs_links_grid (every sub-task and azimuth together) returns, block by block, the
    links of hs_links / sh_links on that sub-task, value for value."""
    scr = task({"HS": 81, "SH": 82}[kind], 5)
    combos = np.array([[1, 2, 3], [1, 2, 4], [2, 3, 4]])
    psis = np.array([0.0, 1.2])
    F = task_frame(scr)
    links, blocks, error = _hs_links_grid(kind, scr, combos, psis, 0.3, F)
    assert (error == "").all()
    fn = hs_links if kind == "HS" else sh_links
    for i, others in enumerate(combos):
        for a, psi in enumerate(psis):
            mine = [lk for lk, blk in zip(links, blocks) if blk == i * len(psis) + a]
            ref = fn([scr[j - 1] for j in others], 0.3, psi, frame=F)
            assert len(mine) == len(ref)
            for x, y in zip(mine, ref):
                for ax in ("fixed_axis", "moving_axis"):
                    np.testing.assert_array_equal(getattr(x, ax).direction,
                                                  getattr(y, ax).direction)
                    np.testing.assert_array_equal(getattr(x, ax).point, getattr(y, ax).point)
                assert x.residual == y.residual
