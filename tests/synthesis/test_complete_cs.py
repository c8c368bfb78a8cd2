"""CS chains through six positions with the C axis direction given (issue 14; Su, Wampler &
McCarthy 2004): 26 solutions over the complex numbers.

The count is checked on random tasks against the Thom–Porteous degree (and a colleague's
total-degree homotopy, 26 finite endpoints), every solution is checked on the circle
conditions written here independently (distance of the centre's positions from the axis
line, in the task's own coordinates), and the count is cross-checked by Newton's method
from many random complex starts on those equations: it finds no solution outside the set.
Every real solution is driven by the closure engine (the table's residual) and by the
joint values re-applied here; the generating chain of random tasks is among the solutions.
Positions are built with closure's ``exp_se3`` and scipy's rotations.
"""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from closure import exp_se3
from synthesis import Screw, SynthesisError
from synthesis.complete import COMPLETE_CHAINS, complete_dyads
from synthesis.cs import cs_centres


def unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def screw_T(u, c, theta, slide):
    """4x4 screw about the line (u, c): rotation θ (rad) and slide along u."""
    return exp_se3(np.r_[-theta * np.cross(u, c) + slide * u, theta * u])


def random_task(rng):
    """Six random positions (T_1 = I) and a random unit direction."""
    T = [np.eye(4)]
    for R in Rotation.random(5, random_state=rng.integers(1 << 30)).as_matrix():
        t = np.eye(4)
        t[:3, :3], t[:3, 3] = R, rng.normal(size=3)
        T.append(t)
    return np.array(T), unit(rng)


def cs_chain(rng):
    """A random CS chain (axis direction d through p, S centre q) and six positions it
    reaches: a screw about the axis after a random rotation about the centre."""
    d = unit(rng)
    p = rng.normal(size=3)
    p -= (p @ d) * d
    q = rng.normal(size=3)
    T = [np.eye(4)]
    for R in Rotation.random(5, random_state=rng.integers(1 << 30)).as_matrix():
        M = np.eye(4)
        M[:3, :3], M[:3, 3] = R, q - R @ q
        T.append(screw_T(d, p, rng.uniform(-np.pi, np.pi), rng.normal()) @ M)
    return dict(d=d, p=p, q=q, r=np.linalg.norm(np.cross(q - p, d)), T=np.array(T))


def screws_of(T):
    return [Screw.from_matrix(t) for t in T[1:]]


def circle_residual(T, d, q, p, r2):
    """``|w|² − (w·d)² − r²`` for ``w = T_i q − p`` (complex, no conjugation), relative
    to the terms' sizes: (s, 6)."""
    w = np.einsum("pij,sj->spi", T[:, :3, :3], q) + T[None, :, :3, 3] - p[:, None]
    wd = w @ d
    f = np.sum(w * w, -1) - wd ** 2 - r2[:, None]
    return np.abs(f) / (np.sum(np.abs(w) ** 2, -1) + np.abs(wd) ** 2 + np.abs(r2)[:, None])


def test_table_entry():
    assert COMPLETE_CHAINS["CS"] == (6, 26, "Su, Wampler & McCarthy 2004")


@pytest.mark.parametrize("seed", range(20))
def test_26_solutions_on_random_tasks(seed):
    T, d = random_task(np.random.default_rng(seed))
    sol = cs_centres(T[1:, :3, :3], T[1:, :3, 3], d)
    assert sol.nullity == 26
    assert sol.gap[0] > 1e-5 and sol.gap[1] < 1e-12          # a clear null space
    assert np.all(sol.residual < 1e-10)
    assert not sol.duplicate.any() and not sol.at_infinity.any()
    # the axis point is the foot of the perpendicular (⊥ d), and the solutions satisfy
    # the circle conditions written here
    assert np.abs(sol.axis_point @ d).max() < 1e-10 * max(1, np.abs(sol.axis_point).max())
    assert circle_residual(T, d, sol.q, sol.axis_point, sol.radius2).max() < 1e-10
    # 26 distinct solutions
    Z = np.c_[sol.q, sol.axis_point]
    sep = np.abs(Z[:, None] - Z[None]).max(-1) + np.eye(26)
    assert sep.min() > 1e-6
    # the real ones come with their conjugates' count even
    assert sol.real.sum() % 2 == 0


@pytest.mark.parametrize("seed", range(3))
def test_newton_from_random_complex_starts_finds_nothing_else(seed):
    """Independent count check: damped complex Newton on (q, axis trace, r²) from 4000
    random complex starts of random sizes; every converged point is one of the 26, and
    the 26 are reached but for a few of great size (circles of radius ~10² or more, which
    random starts seldom approach)."""
    rng = np.random.default_rng(100 + seed)
    T, d = random_task(rng)
    sol = cs_centres(T[1:, :3, :3], T[1:, :3, 3], d)
    u1, u2 = np.linalg.svd(d[None])[2][1:]
    R, t = T[:, :3, :3], T[:, :3, 3]
    n = 4000
    size = np.exp(rng.uniform(np.log(0.3), np.log(20), (n, 1)))
    z = (rng.normal(size=(n, 6)) + 1j * rng.normal(size=(n, 6))) * size
    Pd = np.eye(3) - np.outer(d, d)
    for _ in range(150):
        p = z[:, 3:4] * u1 + z[:, 4:5] * u2
        w = np.einsum("pij,sj->spi", R, z[:, :3]) + t[None] - p[:, None]
        wp = w @ Pd
        f = np.sum(wp * w, -1) - z[:, 5:6]
        J = np.empty((n, 6, 6), complex)
        J[..., :3] = 2 * np.einsum("spi,pij->spj", wp, R)
        J[..., 3], J[..., 4], J[..., 5] = -2 * wp @ u1, -2 * wp @ u2, -1.0
        with np.errstate(all="ignore"):
            step = np.linalg.solve(J, f[..., None])[..., 0]
        norm = np.linalg.norm(step, axis=1, keepdims=True)
        lim = 0.5 * (1 + np.linalg.norm(z, axis=1, keepdims=True))          # damped
        step = np.where(norm > lim, step * lim / np.where(norm > 0, norm, 1), step)
        z = np.where(np.isfinite(step).all(1, keepdims=True), z - step, z)
    p = z[:, 3:4] * u1 + z[:, 4:5] * u2
    res = circle_residual(T, d, z[:, :3], p, z[:, 5])
    conv = np.isfinite(res).all(1) & (res.max(1) < 1e-12) & (np.abs(z).max(1) < 1e8)
    assert conv.sum() > n // 2
    ref = np.c_[sol.q, sol.axis_point @ u1, sol.axis_point @ u2, sol.radius2]
    big = np.abs(ref).max(-1)
    dist = np.abs(z[conv, None] - ref[None]).max(-1) / (1 + big)                # (m, 26)
    assert dist.min(1).max() < 1e-8                # nothing outside the 26
    found = np.zeros(26, bool)
    found[dist.argmin(1)] = True
    assert found.sum() >= 20 and found[big < 20].all()


@pytest.mark.parametrize("seed", range(6))
def test_generating_chain_and_engine(seed):
    ch = cs_chain(np.random.default_rng(200 + seed))
    T, d = ch["T"], ch["d"]
    df = complete_dyads("CS", screws_of(T), fixed_direction=d)
    a = df.attrs
    assert a["complex_count"] == 26 and a["expected_count"] == 26 and a["nullity"] == 26
    assert a["failed_paths"] == 0 and a["at_infinity"] == 0 and a["paths_tracked"] == 0
    assert a["real_count"] == len(df) + a["rejected"] and a["real_count"] % 2 == 0
    assert (df["family"] == "CS").all() and (df["j1_type"] == "C").all()
    assert (df["j2_type"] == "S").all()
    assert (df["residual"] < 1e-9).all() and (df["reason"] == "").all()
    # the generating chain: centre, axis (line) and radius
    Q = df[["j2_x", "j2_y", "j2_z"]].to_numpy(float)
    i = np.abs(Q - ch["q"]).max(1).argmin()
    assert np.abs(Q[i] - ch["q"]).max() < 1e-8
    row = df.iloc[i]
    u = row[["j1_ux", "j1_uy", "j1_uz"]].to_numpy(float)
    c = row[["j1_x", "j1_y", "j1_z"]].to_numpy(float)
    assert np.linalg.norm(np.cross(u, d)) < 1e-12
    assert np.linalg.norm(np.cross(c - ch["p"], d)) < 1e-8
    assert abs(row["radius"] - ch["r"]) < 1e-8
    # every row's joint values, re-applied here, carry its centre to T_i q; its radius
    for _, row in df.iterrows():
        u = row[["j1_ux", "j1_uy", "j1_uz"]].to_numpy(float)
        c = row[["j1_x", "j1_y", "j1_z"]].to_numpy(float)
        q = row[["j2_x", "j2_y", "j2_z"]].to_numpy(float)
        assert abs(np.linalg.norm(np.cross(q - c, u)) - row["radius"]) < 1e-9
        for k in range(6):
            C = screw_T(u, c, row[f"q1_pos{k + 1}"], row[f"d1_pos{k + 1}"])
            want = T[k, :3, :3] @ q + T[k, :3, 3]
            assert np.abs(C[:3, :3] @ q + C[:3, 3] - want).max() < 1e-9 * max(1, np.abs(want).max())


def test_moves_with_the_task():
    """A rigid motion and a change of unit of the whole task move the solutions with it."""
    rng = np.random.default_rng(7)
    T, d = random_task(rng)
    df = complete_dyads("CS", screws_of(T), fixed_direction=d)
    G = screw_T(unit(rng), rng.normal(size=3), 0.8, 0.3)
    G[:3, 3] *= 1.0
    s = 2.5
    S = np.diag([s, s, s, 1.0])
    C = S @ G
    T2 = np.array([C @ t @ np.linalg.inv(C) for t in T])
    d2 = G[:3, :3] @ d
    df2 = complete_dyads("CS", screws_of(T2), fixed_direction=d2)
    assert df.attrs["complex_count"] == df2.attrs["complex_count"] == 26
    assert len(df) == len(df2)
    Q = (df[["j2_x", "j2_y", "j2_z"]].to_numpy(float) @ G[:3, :3].T + G[:3, 3]) * s
    Q2 = df2[["j2_x", "j2_y", "j2_z"]].to_numpy(float)
    assert np.abs(np.sort(Q, 0) - np.sort(Q2, 0)).max() < 1e-8
    assert np.allclose(np.sort(df["radius"]) * s, np.sort(df2["radius"]), atol=1e-8)


def test_arguments():
    T, d = random_task(np.random.default_rng(3))
    with pytest.raises(SynthesisError, match="fixed_direction"):
        complete_dyads("CS", screws_of(T))
    with pytest.raises(SynthesisError, match="fixed_direction"):
        complete_dyads("CS", screws_of(T), fixed_direction=2 * d)
    with pytest.raises(SynthesisError, match="fixed_direction"):
        complete_dyads("CS", screws_of(T), fixed_direction=d[:2])
    with pytest.raises(SynthesisError, match="fixed_direction"):
        complete_dyads("CC", screws_of(T[:5]), fixed_direction=d)
    with pytest.raises(SynthesisError, match="screws"):
        complete_dyads("CS", screws_of(T[:5]), fixed_direction=d)


@pytest.mark.parametrize("kind", ["planar about d", "planar about a line ⊥ d", "translations",
                                  "spherical"])
def test_degenerate_tasks_refused(kind):
    rng = np.random.default_rng(11)
    d = np.array([0.0, 0.6, 0.8])
    T = [np.eye(4)]
    for _ in range(5):
        c = rng.normal(size=3)
        if kind == "planar about d":
            T.append(screw_T(d, c - (c @ d) * d, rng.uniform(-3, 3), rng.normal()))
        elif kind == "planar about a line ⊥ d":
            e = np.array([1.0, 0, 0])
            T.append(screw_T(e, c - (c @ e) * e, rng.uniform(-3, 3), 0.0))
        elif kind == "translations":
            T.append(exp_se3(np.r_[c, 0, 0, 0]))
        else:
            R = np.eye(4)
            R[:3, :3] = Rotation.random(random_state=rng.integers(1 << 30)).as_matrix()
            T.append(R)
    with pytest.raises(SynthesisError, match="degenerate"):
        complete_dyads("CS", screws_of(np.array(T)), fixed_direction=d)


def test_nearly_planar_task_reports_far_solutions():
    """Rotation axes within 1e-3 rad of d (nearly the planar motion whose solutions are not
    isolated): some solutions run off far away; they are reported (at infinity, or as
    failed eigenpairs), never passed off as chains, and the rest still verify."""
    rng = np.random.default_rng(0)
    d = unit(rng)
    T = [np.eye(4)]
    for _ in range(5):
        T.append(exp_se3(np.r_[rng.normal(size=3), (d + 1e-3 * unit(rng)) * rng.uniform(-3, 3)]))
    df = complete_dyads("CS", screws_of(np.array(T)), fixed_direction=d)
    a = df.attrs
    assert a["nullity"] == 26
    assert a["complex_count"] + a["at_infinity"] + a["failed_paths"] == 26
    assert a["at_infinity"] > 0
    assert (df["residual"] < 1e-9).all()
