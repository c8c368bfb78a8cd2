"""Complete solution sets at N_max (issue 14): RR through 3 positions (2 solutions), CC
through 5 (6 complex; Murray & McCarthy), SS and TS through 7 (20 complex; Innocenti,
Liao & McCarthy), and least squares through more positions.

Every count is checked against the literature's and, independently, by a different
method written here (Newton from many random complex starts on the bilinear equations;
real Newton from a dense grid of directions); every real solution is checked by the
closure engine (the table's residual) and by the constraint computed here; the
generating chain of random tasks is among the solutions.  Positions are built with
closure's ``exp_se3`` and scipy's rotations, not with the package's own code.
"""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from closure import exp_se3
from synthesis import Screw, SynthesisError, cc_links, rr_links
from synthesis.binary import _task
from synthesis.complete import complete_dyads, least_squares_dyads
from synthesis.rmep import solve_bilinear
from synthesis.validate import task_scale


def unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def screw_T(u, c, theta, slide):
    """4x4 screw about the line (u, c): rotation θ (rad) and slide along u."""
    return exp_se3(np.r_[-theta * np.cross(u, c) + slide * u, theta * u])


def binary_chain(rng, n, cylindric):
    """Positions (n, 4, 4) of a random RR (or CC) link: fixed screw after moving screw."""
    g, w, cg, cw = unit(rng), unit(rng), rng.normal(size=3), rng.normal(size=3)
    ang = rng.choice([-1, 1], (n - 1, 2)) * rng.uniform(0.3, 2.5, (n - 1, 2))
    sl = rng.normal(size=(n - 1, 2)) if cylindric else np.zeros((n - 1, 2))
    T = np.array([np.eye(4)] + [screw_T(g, cg, a[0], s[0]) @ screw_T(w, cw, a[1], s[1])
                                for a, s in zip(ang, sl)])
    return dict(g=g, cg=cg, w=w, cw=cw, T=T, screws=[Screw.from_matrix(t) for t in T[1:]])


def ss_chain(rng, n=7):
    """A random SS link (fixed centre p, moving centre q) and n positions keeping
    |T q − p| = |q − p|: random rotations, q carried to random points of the sphere."""
    p, q = rng.normal(size=3), rng.normal(size=3)
    r = np.linalg.norm(q - p)
    T = [np.eye(4)]
    for R in Rotation.random(n - 1, random_state=rng.integers(1 << 30)).as_matrix():
        t = np.eye(4)
        t[:3, :3], t[:3, 3] = R, p + r * unit(rng) - R @ q
        T.append(t)
    T = np.array(T)
    return dict(p=p, q=q, T=T, screws=[Screw.from_matrix(t) for t in T[1:]])


def size_of(T):
    return task_scale(T)[1]


def axis(row, k):
    return (np.array([row[f"j{k}_ux"], row[f"j{k}_uy"], row[f"j{k}_uz"]]),
            np.array([row[f"j{k}_x"], row[f"j{k}_y"], row[f"j{k}_z"]]))


def line_error(u, c, row, k, L):
    """Angle (rad) between the directions and distance of c from the row's axis k over L."""
    d, p = axis(row, k)
    ang = np.arcsin(min(1.0, np.linalg.norm(np.cross(u, d))))
    return max(ang, np.linalg.norm(np.cross(d, c - p)) / L)


def binary_error(ch, row, L):
    return max(line_error(ch["g"], ch["cg"], row, 1, L), line_error(ch["w"], ch["cw"], row, 2, L))


def complex_newton(A, starts, seed=0, iters=40):
    """Distinct solutions of Σ λ_i A_i x = 0 found by Newton from random complex starts
    (normalised by random complex a·x = 1, b·λ = 1): an independent count."""
    rng = np.random.default_rng(seed)
    k1, m, n = A.shape
    a = rng.normal(size=n) + 1j * rng.normal(size=n)
    b = rng.normal(size=k1) + 1j * rng.normal(size=k1)
    x = rng.normal(size=(starts, n)) + 1j * rng.normal(size=(starts, n))
    lam = rng.normal(size=(starts, k1)) + 1j * rng.normal(size=(starts, k1))

    def F(x, lam):
        return np.concatenate([np.einsum("si,irc,sc->sr", lam, A, x), (x @ a - 1)[:, None],
                               (lam @ b - 1)[:, None]], 1)
    for _ in range(iters):
        J = np.zeros((starts, m + 2, n + k1), complex)
        J[:, :m, :n] = np.einsum("si,irc->src", lam, A)
        J[:, :m, n:] = np.einsum("irc,sc->sri", A, x)
        J[:, m, :n], J[:, m + 1, n:] = a, b
        with np.errstate(all="ignore"):
            d = np.linalg.solve(J, F(x, lam)[..., None])[..., 0]
        x, lam = x - d[:, :n], lam - d[:, n:]
    f = F(x, lam)
    ok = np.all(np.isfinite(f), 1) & (np.abs(f).max(1) < 1e-10)
    out = []
    for v in np.c_[x, lam][ok]:
        if not any(np.abs(v - u).max() < 1e-6 * max(1, np.abs(u).max()) for u in out):
            out.append(v)
    return out


# ------------------------------------------------------------------ the linearisation
@pytest.mark.parametrize("n,k", [(2, 1), (3, 2), (4, 3), (3, 3)])
def test_bilinear_solver_finds_the_generic_count(n, k):
    """Random complex problems: C(n + k − 1, k) distinct solutions, each solving the
    equations; Newton from random starts finds no other one."""
    from math import comb
    rng = np.random.default_rng(n + 10 * k)
    A = rng.normal(size=(k + 1, n + k - 1, n)) + 1j * rng.normal(size=(k + 1, n + k - 1, n))
    sol = solve_bilinear(A)
    assert len(sol.x) == sol.expected == comb(n + k - 1, k)
    assert not sol.singular
    assert sol.residual.max() < 1e-12
    ref = complex_newton(A, 400 if k < 3 else 1500)
    assert len(ref) == sol.expected
    # every Newton solution is one of ours (compare the lines x, λ up to scale)
    for v in ref:
        x, lam = v[:n], v[n:]
        cx = np.abs(np.einsum("i,si->s", x.conj(), sol.x)) / np.linalg.norm(x) / \
            np.linalg.norm(sol.x, axis=1)
        cl = np.abs(np.einsum("i,si->s", lam.conj(), sol.lam)) / np.linalg.norm(lam) / \
            np.linalg.norm(sol.lam, axis=1)
        assert np.max(np.minimum(cx, cl)) > 1 - 1e-9


# ------------------------------------------------------------------ RR
def test_rr_complete_is_both_rr_links_verified():
    rng = np.random.default_rng(1)
    for _ in range(10):
        ch = binary_chain(rng, 3, False)
        df = complete_dyads("RR", ch["screws"])
        assert len(df) == 2 and df.attrs["complex_count"] == df.attrs["expected_count"] == 2
        assert (df.residual <= 1e-9).all()
        assert min(binary_error(ch, r, size_of(ch["T"])) for _, r in df.iterrows()) < 1e-8
        links = rr_links(*ch["screws"])
        for lk in links:
            assert min(line_error(lk.fixed_axis.direction, lk.fixed_axis.point, r, 1, 1.0)
                       for _, r in df.iterrows()) < 1e-12
        assert list(df.j1_type) == ["R", "R"] and df.j3_type.isna().all()


# ------------------------------------------------------------------ CC
def real_directions_by_grid(R, samples=2000):
    """Real direction pairs (g, w) of gᵀ (R_j − I) w = 0 by Newton from a dense grid of g
    (w the null vector of the 4x3 matrix), with |g| = |w| = 1: the second method."""
    M = R - np.eye(3)
    k = np.arange(samples) + 0.5
    z = k / samples
    phi = np.pi * (1 + 5 ** 0.5) * k
    g = np.stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z], -1)
    B = np.einsum("mji,nj->nmi", M, g)
    w = np.linalg.svd(B)[2][:, -1]
    for _ in range(30):
        F = np.c_[np.einsum("ni,mij,nj->nm", g, M, w), (g * g).sum(1) - 1, (w * w).sum(1) - 1]
        J = np.zeros((samples, 6, 6))
        J[:, :4, :3] = np.einsum("mij,nj->nmi", M, w)
        J[:, :4, 3:] = np.einsum("ni,mij->nmj", g, M)
        J[:, 4, :3], J[:, 5, 3:] = 2 * g, 2 * w
        with np.errstate(all="ignore"):
            d = np.linalg.solve(J, F[..., None])[..., 0]
        g, w = g - d[:, :3], w - d[:, 3:]
    F = np.c_[np.einsum("ni,mij,nj->nm", g, M, w), (g * g).sum(1) - 1, (w * w).sum(1) - 1]
    ok = np.all(np.isfinite(F), 1) & (np.abs(F).max(1) < 1e-12)
    out = []
    for a, b in zip(g[ok], w[ok]):
        if not any(abs(abs(a @ c) - 1) < 1e-8 and abs(abs(b @ e) - 1) < 1e-8 for c, e in out):
            out.append((a, b))
    return out


def test_cc_five_positions_all_solutions_over_50_tasks():
    """50 random CC tasks: 6 complex solutions each, an even number ≤ 6 of them real, the
    generating link among them, every link reaching all 5 positions (engine) and solving
    the direction equations to 1e-10; for 4 tasks the real directions are counted again
    by grid + Newton and the complex ones by Newton from random complex starts."""
    rng = np.random.default_rng(5)
    counts = []
    for i in range(50):
        ch = binary_chain(rng, 5, True)
        L = size_of(ch["T"])
        df = complete_dyads("CC", ch["screws"])
        a = df.attrs
        assert a["complex_count"] == a["expected_count"] == 6 and a["failed_paths"] == 0
        assert a["real_count"] % 2 == 0 and a["real_count"] <= 6
        assert len(df) == a["real_count"] - a["rejected"]
        assert (df.residual <= 1e-9).all(), df.residual.max()
        assert min(binary_error(ch, r, L) for _, r in df.iterrows()) < 1e-8
        R = ch["T"][1:, :3, :3]
        for _, r in df.iterrows():
            g, w = axis(r, 1)[0], axis(r, 2)[0]
            assert np.abs(np.einsum("i,mij,j->m", g, R - np.eye(3), w)).max() < 1e-10
        counts.append(a["real_count"])
        if i < 4:
            assert len(real_directions_by_grid(R)) == a["real_count"]
            A = np.transpose(R - np.eye(3), (1, 0, 2)).astype(complex)
            assert len(complex_newton(A, 300, seed=i)) == 6
    assert max(counts) >= 4                    # not always the same count: a real test


def test_cc_links_five_positions_is_the_complete_set():
    """cc_links through five positions returns the complete set's links."""
    rng = np.random.default_rng(8)
    for _ in range(4):
        ch = binary_chain(rng, 5, True)
        links = cc_links(ch["screws"])
        df = complete_dyads("CC", ch["screws"])
        assert len(links) == len(df)
        for lk in links:
            assert min(line_error(lk.fixed_axis.direction, lk.fixed_axis.point, r, 1, 1.0)
                       for _, r in df.iterrows()) < 1e-12


# ------------------------------------------------------------------ SS, TS
def test_ss_seven_positions_20_solutions_and_the_generating_link():
    rng = np.random.default_rng(3)
    for i in range(10):
        ch = ss_chain(rng)
        L = size_of(ch["T"])
        df = complete_dyads("SS", ch["screws"])
        a = df.attrs
        assert a["complex_count"] == a["expected_count"] == 20 and a["failed_paths"] == 0
        assert a["real_count"] % 2 == 0 and len(df) == a["real_count"] - a["rejected"] - \
            a["at_infinity"]
        assert (df.residual <= 1e-9).all(), df.residual.max()
        P = df[["j1_x", "j1_y", "j1_z"]].to_numpy()
        Q = df[["j2_x", "j2_y", "j2_z"]].to_numpy()
        # the sphere condition at all 7 positions, computed here
        moved = np.einsum("pij,sj->spi", ch["T"][:, :3, :3], Q) + ch["T"][None, :, :3, 3]
        d = np.linalg.norm(moved - P[:, None], axis=2)
        assert np.abs(d - d[:, :1]).max() <= 1e-9 * L
        err = np.maximum(np.linalg.norm(P - ch["p"], axis=1), np.linalg.norm(Q - ch["q"], axis=1))
        assert err.min() < 1e-8 * L
        assert df.j1_ux.isna().all() and (df.j1_type == "S").all()
        if i == 0:
            task = _task(ch["screws"], "screws", (7,))
            E = np.zeros((6, 4, 4))
            E[:, :3, :3] = np.eye(3) - task.R
            E[:, :3, 3] = -task.t
            E[:, 3, :3] = np.einsum("mi,mij->mj", task.t, task.R)
            E[:, 3, 3] = 0.5 * (task.t ** 2).sum(1)
            assert len(complex_newton(np.transpose(E, (1, 0, 2)).astype(complex), 2000)) == 20


def test_ts_has_the_ss_centres_and_a_working_universal_joint():
    rng = np.random.default_rng(4)
    ch = ss_chain(rng)
    ss, ts = complete_dyads("SS", ch["screws"]), complete_dyads("TS", ch["screws"])
    assert len(ss) == len(ts) and ts.attrs["complex_count"] == 20
    cols = ["j1_x", "j1_y", "j1_z", "j2_x", "j2_y", "j2_z"]
    np.testing.assert_allclose(ts[cols].to_numpy(), ss[cols].to_numpy(), atol=1e-12)
    assert (ts.j1_type == "U").all() and ts.j1_ux.notna().all()
    assert (ts.residual <= 1e-9).all()


# ------------------------------------------------------------------ invariance
def moved(screws, G):
    return [Screw.from_matrix(G @ s.matrix() @ np.linalg.inv(G)) for s in screws]


@pytest.mark.parametrize("chain", ["RR", "CC", "SS"])
def test_rigid_motion_and_scale_invariance(chain):
    rng = np.random.default_rng(11)
    ch = {"RR": lambda: binary_chain(rng, 3, False), "CC": lambda: binary_chain(rng, 5, True),
          "SS": lambda: ss_chain(rng)}[chain]()
    G = exp_se3(np.r_[rng.normal(size=3) * 5, rng.normal(size=3)])
    s = 7.5
    Gs = G.copy()
    Gs[:3] *= s                                        # rigid motion and scale by s
    Gs[3] = (0, 0, 0, 1)
    ref = complete_dyads(chain, ch["screws"])
    got = complete_dyads(chain, moved(ch["screws"], Gs))
    assert len(ref) == len(got) >= 1
    assert got.attrs["complex_count"] == ref.attrs["complex_count"]
    L = size_of(ch["T"])
    for _, r in ref.iterrows():
        errs = []
        for _, q in got.iterrows():
            e = 0.0
            for k in (1, 2):
                u, c = axis(r, k)
                v, d = axis(q, k)
                c2 = G[:3, :3] @ c * s + G[:3, 3] * s
                if np.isnan(u[0]):                     # a sphere centre: the point itself
                    e = max(e, np.linalg.norm(c2 - d) / (s * L))
                else:
                    e = max(e, np.arcsin(min(1, np.linalg.norm(np.cross(G[:3, :3] @ u, v)))),
                            np.linalg.norm(np.cross(v, c2 - d)) / (s * L))
            errs.append(e)
        assert min(errs) < 1e-9, min(errs)


# ------------------------------------------------------------------ least squares
def noisy(T, rng, noise, L):
    out = T.copy()
    for j in range(1, len(T)):
        xi = rng.normal(size=6)
        out[j] = T[j] @ exp_se3(np.r_[xi[:3] * noise * L, xi[3:] * noise])
    return out


def test_least_squares_rr_through_eight_positions():
    """8 positions of a random RR: exact data give the generating axes to 1e-9; noise of
    1e-4 of the task's size gives them to 1e-3 (rad and relative length)."""
    rng = np.random.default_rng(21)
    ch = binary_chain(rng, 8, False)
    L = size_of(ch["T"])
    for noise, tol in ((0.0, 1e-9), (1e-4, 1e-3)):
        T = noisy(ch["T"], rng, noise, L)
        df = least_squares_dyads("RR", [Screw.from_matrix(t) for t in T[1:]])
        best = df.iloc[0]
        assert binary_error(ch, best, L) < tol
        assert df.attrs["subsets"] == 56 and df.attrs["starts"] == 112
        per = best[[f"residual_pos{p}" for p in range(1, 9)]].to_numpy(float)
        assert per.max() <= (1e-12 if noise == 0 else 10 * noise)
        # the engine's residual (driven at the fitted joint values) is the largest one
        assert best.residual == pytest.approx(per.max(), rel=1e-6, abs=1e-14)
        assert (np.diff(df.rms.to_numpy()) >= 0).all()                       # best first


def test_least_squares_cc_through_six_positions():
    rng = np.random.default_rng(22)
    ch = binary_chain(rng, 6, True)
    L = size_of(ch["T"])
    df = least_squares_dyads("CC", ch["screws"])
    assert binary_error(ch, df.iloc[0], L) < 1e-9 and df.iloc[0].residual < 1e-12


# ------------------------------------------------------------------ bad input
def test_bad_input_raises_naming_the_argument():
    rng = np.random.default_rng(2)
    ch = binary_chain(rng, 5, True)
    for bad, what in ((None, "chain"), (3, "chain"), ("RRP", "chain"), ("", "chain")):
        with pytest.raises(SynthesisError, match=what):
            complete_dyads(bad, ch["screws"])
    for bad in (None, "abc", ch["screws"][:3], ch["screws"] + ch["screws"][:1],
                [ch["screws"][0], None, *ch["screws"][2:]], ch["screws"][0]):
        with pytest.raises(SynthesisError, match="screws"):
            complete_dyads("CC", bad)
    with pytest.raises(SynthesisError, match="screws"):
        least_squares_dyads("RR", ch["screws"][:2])
    with pytest.raises(SynthesisError, match="chain"):
        least_squares_dyads("SS", ch["screws"])
    # coincident positions
    with pytest.raises(SynthesisError, match="coincide"):
        complete_dyads("CC", ch["screws"][:3] + ch["screws"][:1])


def test_planar_task_is_reported_degenerate():
    """Seven positions of a planar motion: SS links are then not isolated (any height)."""
    z = np.array([0.0, 0, 1])
    rng = np.random.default_rng(6)
    scr = [Screw(z, np.r_[rng.normal(size=2), 0.0], rng.uniform(0.3, 2.0), 0.0)
           for _ in range(6)]
    with pytest.raises(SynthesisError, match="screws"):
        complete_dyads("SS", scr)
    with pytest.raises(SynthesisError, match="parallel"):
        complete_dyads("CC", scr[:4])


def test_spherical_task_is_reported_degenerate():
    """Seven rotations about one point: every SS link centred there reaches them."""
    O = np.array([1.0, 2.0, 3.0])
    scr = []
    for R in Rotation.random(6, random_state=1).as_matrix():
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, O - R @ O
        scr.append(Screw.from_matrix(T))
    with pytest.raises(SynthesisError, match="screws: degenerate task: the positions are"):
        complete_dyads("SS", scr)
