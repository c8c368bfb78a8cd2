"""Binary links with a spherical joint (RS, SR, PS, SP, HS, SH) at explicit free parameters.

Positions are built from a generating link with closure's ``exp_se3`` (not the package's
own kinematics); every returned link is driven through the positions by the closure
engine; completeness is checked against independent references written here (dense
sampling of the circle condition with Brent refinement; multi-start ``least_squares``
on the link's own equations).
"""
import numpy as np
import pytest
from scipy.optimize import brentq, least_squares

from closure import exp_se3
from synthesis import Screw, SynthesisError
from synthesis.spherical import (azimuth_of, hs_links, ps_links, rs_links_at, sh_links, sp_links,
                                 sr_links, task_frame)
from synthesis.validate import task_scale
from synthesis.verify import verify_open_chains

TOL = 1e-8


def unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def screw_T(u, c, theta, slide):
    u, c = np.asarray(u, float), np.asarray(c, float)
    return exp_se3(np.r_[-theta * np.cross(u, c) + slide * u, theta * u])


def fast_screw(u, c, theta, slide):
    """4x4 screw about the line (u, c) by Rodrigues' formula (cheap, for least_squares)."""
    K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    R = np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * K @ K
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, c - R @ c + slide * np.asarray(u)
    return T


def about(rotvec, c):
    """Rotation by the rotation vector about the point c."""
    rotvec = np.asarray(rotvec, float)
    return exp_se3(np.r_[-np.cross(rotvec, c), rotvec])


def slide(d, s):
    T = np.eye(4)
    T[:3, 3] = s * np.asarray(d)
    return T


def screws_of(T):
    return [Screw.from_matrix(t) for t in T[1:]]


def generic(rng, n):
    T = [np.eye(4)] + [screw_T(unit(rng), rng.normal(size=3), rng.uniform(0.3, 2.5), rng.normal())
                       for _ in range(n - 1)]
    return np.array(T)


def line_err(u, c, ln, L):
    ang = np.arcsin(min(1.0, np.linalg.norm(np.cross(u, ln.direction))))
    return max(ang, np.linalg.norm(np.cross(ln.direction, c - ln.point)) / L)


def reach(T):
    return task_scale(T)[2]


def verify(links, T):
    return verify_open_chains([lk.engine_chain() for lk in links], T, reach(T))


# ------------------------------------------------------------------ generators
def gen_rs(rng, pitch=0.0, inverse=False):
    g, cg, C = unit(rng), rng.normal(size=3), rng.normal(size=3)
    T = [np.eye(4)]
    for _ in range(3):
        th = rng.choice([-1, 1]) * rng.uniform(0.3, 2.5)
        H, S = screw_T(g, cg, th, pitch * th), about(rng.normal(size=3), C)
        T.append(S @ H if inverse else H @ S)
    return dict(g=g, cg=cg, C=C, T=np.array(T))


def gen_ps(rng, inverse=False):
    d, C = unit(rng), rng.normal(size=3)
    T = [np.eye(4)]
    for _ in range(2):
        P, S = slide(d, rng.normal()), about(rng.normal(size=3), C)
        T.append(S @ P if inverse else P @ S)
    return dict(d=d, C=C, T=np.array(T))


def rs_error(ch, link, L, kind):
    """Generating RS/SR/HS/SH link against a returned one."""
    if kind in ("RS", "HS"):
        return max(line_err(ch["g"], ch["cg"], link.fixed_axis, L),
                   np.linalg.norm(link.moving_axis.point - ch["C"]) / L)
    return max(line_err(ch["g"], ch["cg"], link.moving_axis, L),
               np.linalg.norm(link.fixed_axis.point - ch["C"]) / L)


# ------------------------------------------------------------------ RS, SR
@pytest.mark.parametrize("kind", ["RS", "SR"])
def test_generating_rs_link_comes_back_at_its_azimuth(kind):
    rng = np.random.default_rng({"RS": 1, "SR": 2}[kind])
    fn = rs_links_at if kind == "RS" else sr_links
    worst = 0.0
    for _ in range(20):
        ch = gen_rs(rng, inverse=kind == "SR")
        scr = screws_of(ch["T"])
        L = task_scale(ch["T"])[1]
        links = fn(scr, azimuth_of(ch["g"], scr))
        err = min(rs_error(ch, lk, L, kind) for lk in links)
        assert err < TOL, err
        assert all(lk.types == kind for lk in links)
        worst = max(worst, err)
    print(f"{kind}: worst generating-link error {worst:.1e}")


@pytest.mark.parametrize("kind", ["RS", "SR", "PS", "SP"])
def test_every_link_reaches_generic_positions(kind):
    rng = np.random.default_rng(7)
    n = 4 if kind in ("RS", "SR") else 3
    fn = {"RS": rs_links_at, "SR": sr_links, "PS": ps_links, "SP": sp_links}[kind]
    total = 0
    for _ in range(3):
        T = generic(rng, n)
        for psi in (0.1, 1.3, 2.7):
            links = fn(screws_of(T), psi)
            total += len(links)
            if links:
                assert verify(links, T).max() <= 1e-9
                assert max(lk.residual for lk in links) <= 1e-9
                assert all(abs(lk.parameters["azimuth"] - psi) == 0 for lk in links)
    assert total > 0


def _old_h(g, T):
    """Independent circle condition, batched over directions g (N, 3): the sphere centre
    from the three plane conditions, then the 4x4 determinant of the circle through the
    four coplanar points."""
    A = np.stack([g @ (t[:3, :3] - np.eye(3)) for t in T[1:]], 1)
    b = -np.stack([g @ t[:3, 3] for t in T[1:]], 1)
    C = np.linalg.solve(A, b[..., None])[..., 0]
    Cs = np.stack([C @ t[:3, :3].T + t[:3, 3] for t in T], 1)
    rows = [np.concatenate([Cs[:, 0] - Cs[:, j], -0.5 * (np.sum(Cs[:, 0] ** 2, -1)
                                                       - np.sum(Cs[:, j] ** 2, -1))[:, None]], 1)
            for j in (1, 2, 3)]
    rows.append(np.concatenate([g, -np.sum(g * Cs[:, 0], -1)[:, None]], 1))
    scale = np.maximum(1.0, np.abs(Cs).max(axis=(1, 2)))
    return np.linalg.det(np.stack(rows, 1)) / scale ** 4, C, Cs


def test_rs_finds_every_root_that_dense_sampling_finds():
    """Dense sampling (20 000 directions per circle) of an independently written circle
    condition, every sign change refined by Brent's method and kept when the four
    centres really lie on a circle about the axis: nothing the function misses."""
    rng = np.random.default_rng(5)
    found_ref = 0
    for _ in range(4):
        T = generic(rng, 4)
        scr = screws_of(T)
        F = task_frame(scr)
        for psi in rng.uniform(0, np.pi, 2):
            a, b = F[:, 2], np.cos(psi) * F[:, 0] + np.sin(psi) * F[:, 1]
            u = lambda x: np.multiply.outer(np.cos(x), a) + np.multiply.outer(np.sin(x), b)
            xs = np.linspace(0, np.pi, 20001)
            hv = _old_h(u(xs), T)[0]
            ours = [lk.parameters["elevation"] for lk in rs_links_at(scr, psi)]
            h1 = lambda x: _old_h(u(np.array([x])), T)[0][0]
            for i in np.flatnonzero(hv[:-1] * hv[1:] < 0):
                lo, hi = h1(xs[i]), h1(xs[i + 1])
                x = brentq(h1, xs[i], xs[i + 1], xtol=1e-14) if lo * hi < 0 else \
                    xs[i] if abs(lo) < abs(hi) else xs[i + 1]      # a root at a sample
                _, C, Cs = _old_h(u(np.array([x])), T)
                C, Cs = C[0], Cs[0]
                g = u(x)
                P = Cs - np.outer(Cs @ g, g)                    # projections on a plane ⊥ g
                O = np.linalg.lstsq(np.c_[2 * (P[1:] - P[0])], np.sum(P[1:] ** 2, 1)
                                    - P[0] @ P[0], rcond=None)[0]
                r = np.linalg.norm(P - O, axis=1)
                if np.ptp(r) > 1e-7 * max(1, r.max()) or np.abs(C).max() > 1e6:
                    continue                                   # a pole (centre at infinity)
                found_ref += 1
                assert min(abs(x - y) for y in ours) < 1e-7, (x, ours)
    assert found_ref > 0


def test_rs_links_move_with_the_task():
    rng = np.random.default_rng(9)
    T = generic(rng, 4)
    M = screw_T(unit(rng), [300.0, -200.0, 100.0], 0.9, 50.0)
    M[:3, 3] += [1000.0, -500.0, 700.0]
    Mi = np.linalg.inv(M)
    T2 = np.array([M @ t @ Mi for t in T])
    L = reach(T2)
    for fn in (rs_links_at, sr_links):
        a = fn(screws_of(T), 0.8)
        b = fn(screws_of(T2), 0.8)
        assert len(a) == len(b) > 0
        for x, y in zip(a, b):
            for k, (l1, l2) in enumerate(((x.fixed_axis, y.fixed_axis),
                                          (x.moving_axis, y.moving_axis))):
                moved = l1.transformed(M)
                if x.types[k] == "S":                          # the sphere centre
                    np.testing.assert_allclose(l2.point, moved.point, atol=1e-8 * L)
                else:                                          # the axis, as a line
                    assert abs(abs(moved.direction @ l2.direction) - 1) < 1e-10
                    assert moved.distance_to(l2) < 1e-8 * L


def test_rs_bad_inputs_raise_naming_the_argument():
    rng = np.random.default_rng(3)
    scr = screws_of(generic(rng, 4))
    cases = [(lambda: rs_links_at(scr[:2], 0.1), "screws"),
             (lambda: rs_links_at(scr, np.nan), "azimuth"),
             (lambda: rs_links_at(scr, "x"), "azimuth"),
             (lambda: rs_links_at(scr, 0.1, frame=np.ones((3, 3))), "frame"),
             (lambda: rs_links_at(scr, 0.1, tol=-1.0), "tol"),
             (lambda: sr_links([scr[0], None, scr[2]], 0.1), "screws"),
             (lambda: hs_links(scr, np.inf, 0.1), "pitch"),
             (lambda: ps_links(scr, 0.1), "screws"),
             (lambda: sp_links(scr[:2], [1.0]), "azimuth"),
             (lambda: azimuth_of([0, 0, 0], scr), "direction"),
             (lambda: rs_links_at([Screw([0, 0, 1], [0, 0, 0], 0.0, 1.0)] + scr[1:], 0.1), "S_12")]
    for f, name in cases:
        with pytest.raises(SynthesisError) as e:
            f()
        assert name in str(e.value)


# ------------------------------------------------------------------ PS, SP
@pytest.mark.parametrize("kind", ["PS", "SP"])
def test_generating_ps_link_comes_back_at_its_azimuth(kind):
    rng = np.random.default_rng({"PS": 21, "SP": 22}[kind])
    fn = ps_links if kind == "PS" else sp_links
    for _ in range(20):
        ch = gen_ps(rng, inverse=kind == "SP")
        scr = screws_of(ch["T"])
        L = task_scale(ch["T"])[1]
        links = fn(scr, azimuth_of(ch["d"], scr))
        errs = [max(np.arcsin(min(1, np.linalg.norm(np.cross(ch["d"], (lk.fixed_axis if kind == "PS"
                                                                       else lk.moving_axis).direction)))),
                    np.linalg.norm((lk.moving_axis if kind == "PS" else lk.fixed_axis).point
                                   - ch["C"]) / L) for lk in links]
        assert min(errs) < TOL, errs
        assert verify(links, ch["T"]).max() <= 1e-9


def test_ps_multistart_least_squares_finds_nothing_more():
    rng = np.random.default_rng(31)
    for _ in range(3):
        T = generic(rng, 3)
        scr = screws_of(T)
        F = task_frame(scr)
        psi = rng.uniform(0, np.pi)
        a, b = F[:, 2], np.cos(psi) * F[:, 0] + np.sin(psi) * F[:, 1]
        ours = [lk.parameters["elevation"] for lk in ps_links(scr, psi)]

        def eqs(z):
            d = np.cos(z[0]) * a + np.sin(z[0]) * b
            return np.concatenate([(T[j, :3, :3] - np.eye(3)) @ z[1:4] - z[3 + j] * d + T[j, :3, 3]
                                   for j in (1, 2)])
        for _ in range(25):
            sol = least_squares(eqs, np.r_[rng.uniform(0, np.pi), rng.normal(size=5)],
                                xtol=1e-15, ftol=1e-15, gtol=1e-15)
            if np.abs(sol.fun).max() < 1e-10:
                x = sol.x[0] % np.pi
                assert min(min(abs(x - y), np.pi - abs(x - y)) for y in ours) < 1e-6, (x, ours)


# ------------------------------------------------------------------ HS, SH
@pytest.mark.parametrize("kind", ["HS", "SH"])
def test_generating_hs_link_comes_back_at_its_azimuth(kind):
    rng = np.random.default_rng({"HS": 41, "SH": 42}[kind])
    fn = hs_links if kind == "HS" else sh_links
    for _ in range(5):
        p = rng.uniform(-0.5, 0.5)
        ch = gen_rs(rng, pitch=p, inverse=kind == "SH")
        scr = screws_of(ch["T"])
        L = task_scale(ch["T"])[1]
        links = fn(scr, p, azimuth_of(ch["g"], scr))
        err = min(rs_error(ch, lk, L, kind) for lk in links)
        assert err < TOL, err
        assert verify(links, ch["T"]).max() <= 1e-9
        for lk in links:              # the sphere's side holds no joint value, the helix's
            sphere = (lk.moving_angles, lk.moving_slides) if kind == "HS" else \
                (lk.fixed_angles, lk.fixed_slides)
            helix = (lk.fixed_angles, lk.fixed_slides) if kind == "HS" else \
                (lk.moving_angles, lk.moving_slides)
            for v in sphere:
                np.testing.assert_array_equal(v, np.zeros(4))
            assert helix[0].shape == (4,) and helix[0][0] == 0
            np.testing.assert_allclose(helix[1], p * helix[0], rtol=1e-12, atol=1e-15)


def test_hs_pitch_zero_is_rs_and_small_pitch_is_near_it():
    rng = np.random.default_rng(51)
    T = generic(rng, 4)
    scr = screws_of(T)
    rs = rs_links_at(scr, 0.4)
    h0 = hs_links(scr, 0.0, 0.4)
    assert [lk.types for lk in h0] == ["RS"] * len(rs)
    for x, y in zip(rs, h0):
        np.testing.assert_array_equal(x.fixed_axis.direction, y.fixed_axis.direction)
        np.testing.assert_array_equal(x.moving_axis.point, y.moving_axis.point)
    h = hs_links(scr, 1e-7, 0.4)
    assert len(h) == len(rs)
    for x, y in zip(rs, h):
        assert y.types == "HS"
        assert abs(abs(x.fixed_axis.direction @ y.fixed_axis.direction) - 1) < 1e-10
        assert np.linalg.norm(x.moving_axis.point - y.moving_axis.point) < 1e-5


def test_hs_multistart_gauss_newton_finds_nothing_more():
    """The nine equations T_j C = H(θ_j) C, linear in the sphere centre C and the axis
    point (solved by least squares inside), by a damped Gauss–Newton over
    (β, θ₂, θ₃, θ₄) from 600 random starts at once, written here: every solution with
    angles in (−π, π] is among the function's."""
    rng = np.random.default_rng(61)
    hits = 0
    for p, psi in ((0.3, 1.1), (-0.6, 2.3)):
        T = generic(rng, 4)
        scr = screws_of(T)
        F = task_frame(scr)
        a, b = F[:, 2], np.cos(psi) * F[:, 0] + np.sin(psi) * F[:, 1]
        ours = hs_links(scr, p, psi)

        def linear(z):                                  # z (N, 4) → residual (N, 9), x (N, 5)
            g = np.cos(z[:, :1]) * a + np.sin(z[:, :1]) * b
            e1 = np.cross(g, [0.6, 0.0, 0.8])
            e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
            e2 = np.cross(g, e1)
            K = np.zeros((len(z), 3, 3))
            K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -g[:, 2], g[:, 1], -g[:, 0]
            K -= np.swapaxes(K, 1, 2)
            A, r = [], []
            for j in (1, 2, 3):
                th = z[:, j, None, None]
                RG = np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K
                E = np.stack([e1, e2], -1)
                A.append(np.concatenate([T[j, :3, :3] - RG, (RG - np.eye(3)) @ E], -1))
                r.append(p * z[:, j, None] * g - T[j, :3, 3])
            A, r = np.concatenate(A, 1), np.concatenate(r, 1)
            x = np.linalg.lstsq(A[0], r[0], rcond=None)[0][None] if len(z) == 1 else \
                np.linalg.solve(np.swapaxes(A, 1, 2) @ A, np.einsum("nji,nj->ni", A, r)[..., None])[..., 0]
            return np.einsum("nij,nj->ni", A, x) - r, x

        z = np.c_[rng.uniform(0, np.pi, 600), rng.uniform(-np.pi, np.pi, (600, 3))]
        for _ in range(40):
            f, _ = linear(z)
            J = np.stack([(linear(z + 1e-7 * e)[0] - f) / 1e-7 for e in np.eye(4)], -1)
            step = np.linalg.lstsq(J[0], -f[0], rcond=None)[0][None] if len(z) == 1 else \
                np.linalg.solve(np.swapaxes(J, 1, 2) @ J + 1e-10 * np.eye(4),
                                -np.einsum("nji,nj->ni", J, f)[..., None])[..., 0]
            z = z + np.clip(step, -0.3, 0.3)
        f, x = linear(z)
        good = (np.abs(f).max(1) < 1e-9) & np.all(np.abs(z[:, 1:]) <= np.pi, 1)
        for C in x[good, :3]:
            hits += 1
            assert min(np.linalg.norm(lk.moving_axis.point - C) for lk in ours) < 1e-6, C
    assert hits > 0


def test_conditions_vanish_on_the_returned_directions_only():
    from synthesis.spherical import ps_condition, rs_condition
    rng = np.random.default_rng(71)
    T = generic(rng, 4)
    scr = screws_of(T)
    links = rs_links_at(scr, 0.6)
    assert links
    for lk in links:
        assert abs(rs_condition(scr, lk.fixed_axis.direction)) < 1e-10
        assert abs(azimuth_of(lk.fixed_axis.direction, scr) - 0.6) < 1e-12
    assert abs(rs_condition(scr, unit(rng))) > 1e-6
    for lk in ps_links(scr[:2], 2.0):
        assert abs(ps_condition(scr[:2], lk.fixed_axis.direction)) < 1e-12
    assert abs(ps_condition(scr[:2], unit(rng))) > 1e-6
