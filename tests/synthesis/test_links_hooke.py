"""Binary links with a universal (Hooke) joint in the ground: UR through four positions,
UP through three, at explicit free parameters.

Positions come from a generating link built with closure's ``exp_se3``; every returned
link is driven through the positions by the closure engine (the U as its two revolutes);
the U direction pairs are checked against a multi-start ``least_squares`` on the four
bilinear equations written here.
"""
import numpy as np
import pytest
from scipy.optimize import least_squares

from closure import exp_se3
from synthesis import Line, Screw, SynthesisError
from synthesis.hooke import u_directions, uc_links, uh_links, up_links, ur_links
from synthesis.spherical import azimuth_of
from synthesis.validate import task_scale
from synthesis.verify import verify_open_chains

TOL = 1e-8


def unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def screw_T(u, c, theta, slide):
    u, c = np.asarray(u, float), np.asarray(c, float)
    return exp_se3(np.r_[-theta * np.cross(u, c) + slide * u, theta * u])


def u_pose(O, a, b, al, ga):
    """The link pose of a universal joint (centre O, first axis a, cross axis b in
    position 1): Rot(a, α) Rot(b, γ) about O."""
    return screw_T(a, O, al, 0.0) @ screw_T(b, O, ga, 0.0)


def screws_of(T):
    return [Screw.from_matrix(t) for t in T[1:]]


def verify(links, T):
    return verify_open_chains([lk.engine_chain() for lk in links], T, task_scale(T)[2])


def gen(rng, kind, pitch=0.0):
    O, a = rng.normal(size=3), unit(rng)
    b = np.cross(a, unit(rng))
    b /= np.linalg.norm(b)
    w, cw = unit(rng), rng.normal(size=3)
    n = 4 if kind in ("UR", "UH", "UC") else 3
    T = [np.eye(4)]
    for _ in range(n - 1):
        al, ga, q = rng.uniform(-2, 2, 3)
        inner = screw_T(w, cw, q, pitch * q) if kind in ("UR", "UH") else \
            screw_T(w, cw, q, rng.normal()) if kind == "UC" else screw_T(w, np.zeros(3), 0.0, q)
        T.append(u_pose(O, a, b, al, ga) @ inner)
    return dict(O=O, a=a, b=b, w=w, cw=cw, T=np.array(T))


def u_error(ch, lk, L, kind):
    e = [abs(abs(lk.fixed_axis.direction @ ch["a"]) - 1), abs(abs(lk.cross_axis @ ch["b"]) - 1),
         np.linalg.norm(lk.fixed_axis.point - ch["O"]) / L,
         np.arcsin(min(1, np.linalg.norm(np.cross(lk.moving_axis.direction, ch["w"]))))]
    if kind in ("UR", "UH", "UC"):
        e.append(lk.moving_axis.distance_to(Line(ch["w"], ch["cw"])) / L)
    return max(e)


@pytest.mark.parametrize("kind", ["UR", "UP", "UC"])
def test_generating_u_link_comes_back_at_its_parameters(kind):
    rng = np.random.default_rng({"UR": 1, "UP": 2, "UC": 3}[kind])
    worst = 0.0
    for _ in range(20):
        ch = gen(rng, kind)
        scr = screws_of(ch["T"])
        L = task_scale(ch["T"])[1]
        if kind == "UR":
            links = ur_links(scr, azimuth=azimuth_of(ch["w"], scr))
        elif kind == "UC":
            links = uc_links(scr, centre=ch["O"], azimuth=azimuth_of(ch["w"], scr))
        else:
            links = up_links(scr, slide_azimuth=azimuth_of(ch["w"], scr),
                             axis_azimuth=azimuth_of(ch["a"], scr))
        err = min(u_error(ch, lk, L, kind) for lk in links)
        assert err < TOL, err
        assert all(lk.types == kind for lk in links)
        assert verify(links, ch["T"]).max() <= 1e-9
        worst = max(worst, err)
    print(f"{kind}: worst generating-link error {worst:.1e}")


def test_generating_uh_link_comes_back_and_pitch_zero_is_ur():
    rng = np.random.default_rng(4)
    for _ in range(3):
        p = rng.uniform(-0.5, 0.5)
        ch = gen(rng, "UH", p)
        scr = screws_of(ch["T"])
        L = task_scale(ch["T"])[1]
        links = uh_links(scr, pitch=p, azimuth=azimuth_of(ch["w"], scr))
        assert min(u_error(ch, lk, L, "UH") for lk in links) < TOL
        assert all(lk.types == "UH" and lk.moving_pitch == p for lk in links)
        assert verify(links, ch["T"]).max() <= 1e-9
    x = uh_links(scr, pitch=0.0, azimuth=0.5)
    y = ur_links(scr, azimuth=0.5)
    assert [lk.types for lk in x] == ["UR"] * len(y)
    for p, q in zip(x, y):
        np.testing.assert_array_equal(p.cross_axis, q.cross_axis)
        np.testing.assert_array_equal(p.moving_axis.point, q.moving_axis.point)


def test_u_links_reach_generic_positions():
    rng = np.random.default_rng(5)
    total = 0
    for n, fn in ((4, lambda s, x: ur_links(s, azimuth=x)),
                  (3, lambda s, x: up_links(s, slide_azimuth=x, axis_azimuth=2 * x))):
        for _ in range(3):
            T = np.array([np.eye(4)] + [screw_T(unit(rng), rng.normal(size=3), rng.uniform(0.3, 2.5),
                                                rng.normal()) for _ in range(n - 1)])
            for psi in (0.2, 1.9):
                links = fn(screws_of(T), psi)
                total += len(links)
                if links:
                    assert verify(links, T).max() <= 1e-9
                    for lk in links:         # a U joint: cross axis ⊥ first axis, angles exact
                        assert abs(lk.fixed_axis.direction @ lk.cross_axis) < 1e-12
    assert total > 0


def test_u_directions_multistart_least_squares_finds_nothing_more():
    """a, b on the unit sphere (spherical angles) with aᵀ L_j b = 0 (j = 1…4): every
    solution least_squares reaches from 40 random starts is among u_directions'."""
    rng = np.random.default_rng(8)
    for _ in range(2):
        L = np.array([np.eye(3)] + [exp_se3(np.r_[0, 0, 0, rng.normal(size=3)])[:3, :3]
                                    for _ in range(3)])
        ours = u_directions(L)
        for a, b in ours:
            assert np.abs(np.einsum("i,mij,j->m", a, L, b)).max() < 1e-12

        def s2(u, v):
            return np.array([np.sin(u) * np.cos(v), np.sin(u) * np.sin(v), np.cos(u)])

        def eqs(z):
            a, b = s2(*z[:2]), s2(*z[2:])
            return np.einsum("i,mij,j->m", a, L, b)
        for _ in range(40):
            sol = least_squares(eqs, rng.uniform(0, 2 * np.pi, 4), xtol=1e-15, ftol=1e-15,
                                gtol=1e-15)
            if np.abs(sol.fun).max() < 1e-12:
                a, b = s2(*sol.x[:2]), s2(*sol.x[2:])
                assert min(max(abs(abs(a @ x) - 1), abs(abs(b @ y) - 1)) for x, y in ours) < 1e-7


def test_u_links_move_with_the_task():
    rng = np.random.default_rng(13)
    ch = gen(rng, "UR")
    M = screw_T(unit(rng), [300.0, -200.0, 100.0], 0.9, 50.0)
    M[:3, 3] += [1000.0, -500.0, 700.0]
    T2 = np.array([M @ t @ np.linalg.inv(M) for t in ch["T"]])
    L = task_scale(T2)[2]
    x = ur_links(screws_of(ch["T"]), azimuth=0.7)
    y = ur_links(screws_of(T2), azimuth=0.7)
    assert len(x) == len(y) > 0

    def gap(p, q):               # p moved by M against q (the order of the list may differ)
        return max(np.linalg.norm(q.fixed_axis.point - M[:3, :3] @ p.fixed_axis.point
                                  - M[:3, 3]) / L,
                   abs(abs(q.fixed_axis.direction @ (M[:3, :3] @ p.fixed_axis.direction)) - 1),
                   abs(abs(q.cross_axis @ (M[:3, :3] @ p.cross_axis)) - 1),
                   q.moving_axis.distance_to(p.moving_axis.transformed(M)) / L)
    for p in x:
        assert min(gap(p, q) for q in y) < 1e-8


def test_u_bad_inputs_raise_naming_the_argument():
    rng = np.random.default_rng(3)
    scr = screws_of(gen(rng, "UR")["T"])
    cases = [(lambda: ur_links(scr[:2], azimuth=0.1), "screws"),
             (lambda: ur_links(scr, azimuth=np.nan), "azimuth"),
             (lambda: up_links(scr[:2], slide_azimuth=0.1, axis_azimuth="a"), "axis_azimuth"),
             (lambda: up_links(scr[:2], slide_azimuth=None, axis_azimuth=0.1), "slide_azimuth"),
             (lambda: up_links(scr, slide_azimuth=0.1, axis_azimuth=0.1), "screws"),
             (lambda: ur_links(scr, azimuth=0.1, tol=0.0), "tol"),
             (lambda: u_directions(np.eye(3)), "link_rotations"),
             (lambda: uc_links(scr, centre=[0.0, np.nan, 1.0], azimuth=0.1), "centre"),
             (lambda: uh_links(scr, pitch="p", azimuth=0.1), "pitch")]
    for f, name in cases:
        with pytest.raises(SynthesisError) as e:
            f()
        assert name in str(e.value)


def test_moving_elements_follow_the_body_and_the_cross_axis_stays_perpendicular():
    """moving_elements: the moving joint's axis at position j is the body's axis moved by
    the given pose T_j; a U link's cross axis stays ⊥ its first axis; for an RS link the
    sphere centre at position j is T_j C."""
    from synthesis.spherical import rs_links_at
    rng = np.random.default_rng(17)
    ch = gen(rng, "UR")
    scr = screws_of(ch["T"])
    for lk in ur_links(scr, azimuth=azimuth_of(ch["w"], scr)):
        el = lk.moving_elements()
        np.testing.assert_allclose(el["directions"], ch["T"][:, :3, :3] @ lk.moving_axis.direction,
                                   atol=1e-12)
        moved = ch["T"][:, :3, :3] @ lk.moving_axis.point + ch["T"][:, :3, 3]
        np.testing.assert_allclose(el["points"], moved, atol=1e-9 * task_scale(ch["T"])[2])
        assert np.abs(el["cross_directions"] @ lk.fixed_axis.direction).max() < 1e-12
    for lk in rs_links_at(scr, 0.4):
        el = lk.moving_elements()
        C = lk.moving_axis.point
        np.testing.assert_allclose(el["points"], ch["T"][:, :3, :3] @ C + ch["T"][:, :3, 3],
                                   atol=1e-9 * task_scale(ch["T"])[2])
