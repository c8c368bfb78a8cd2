"""Binary links of R, H and C joints (issue 13, first increment): generating chains are
recovered, HH links satisfy Tsai & Roth's screw triangle (rebuilt here from line
geometry), pitch 0 reproduces rr_links, free parameters give the generating link back,
and degenerate tasks raise SynthesisError naming the cause.

Positions are built from the generating chain with closure's ``exp_se3`` (a screw about
the line (u, c) by angle θ and slide d is the exponential of the twist
``(−θ u × c + d u, θ u)``), not with the package's own code.
"""
import numpy as np
import pytest
from scipy.optimize import least_squares

from closure import exp_se3
from synthesis import (Line, Screw, SynthesisError, cc_direction_residual, cc_links, cr_links,
                       helical_links, rc_links, rr_links)
from synthesis.validate import task_scale
from synthesis.verify import verify_links

TOL_AXIS = 1e-8          # rad, and relative to the task's size


def unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def screw_T(u, c, theta, slide):
    """4x4 screw about the line (u, c): rotation θ (rad) and slide along u."""
    u, c = np.asarray(u, float), np.asarray(c, float)
    return exp_se3(np.r_[-theta * np.cross(u, c) + slide * u, theta * u])


def fast_screw(u, c, theta, slide):
    """The same screw by Rodrigues' formula (cheap, for the least-squares reference)."""
    K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    R = np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * K @ K
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, c - R @ c + slide * u
    return T


def chain_positions(g, cg, w, cw, th, a, ph, b):
    """Positions (n, 4, 4) of a binary link: fixed screw (g, cg; θ, a) after the moving
    screw (w, cw; φ, b) (moving axis in position 1)."""
    return np.array([screw_T(g, cg, th[k], a[k]) @ screw_T(w, cw, ph[k], b[k])
                     for k in range(len(th))])


def random_chain(rng, n, kinds, pitches):
    g, w = unit(rng), unit(rng)
    cg, cw = rng.normal(size=3), rng.normal(size=3)
    th = np.r_[0.0, rng.choice([-1, 1], n - 1) * rng.uniform(0.3, 2.5, n - 1)]
    ph = np.r_[0.0, rng.choice([-1, 1], n - 1) * rng.uniform(0.3, 2.5, n - 1)]
    a = pitches[0] * th if kinds[0] != "C" else np.r_[0.0, rng.normal(size=n - 1)]
    b = pitches[1] * ph if kinds[1] != "C" else np.r_[0.0, rng.normal(size=n - 1)]
    T = chain_positions(g, cg, w, cw, th, a, ph, b)
    return dict(g=g, cg=cg, w=w, cw=cw, th=th, a=a, ph=ph, b=b, T=T,
                screws=[Screw.from_matrix(t) for t in T[1:]])


def size_of(T):
    _, L, _ = task_scale(T)
    return L


def line_error(u, c, ln: Line, L):
    """Angle (rad) between the directions and distance of c from the line over L."""
    ang = np.arcsin(min(1.0, np.linalg.norm(np.cross(u, ln.direction))))
    dist = np.linalg.norm(np.cross(ln.direction, c - ln.point)) / L
    return max(ang, dist)


def chain_error(ch, link, L):
    return max(line_error(ch["g"], ch["cg"], link.fixed_axis, L),
               line_error(ch["w"], ch["cw"], link.moving_axis, L))


def oriented(ch, link):
    """The link's joint values (fixed angles, slides, moving angles, slides) with its axes
    oriented as the chain's (a flipped axis flips its angles and slides)."""
    sg = np.sign(ch["g"] @ link.fixed_axis.direction)
    sw = np.sign(ch["w"] @ link.moving_axis.direction)
    return (sg * link.fixed_angles, sg * link.fixed_slides, sw * link.moving_angles,
            sw * link.moving_slides)


def best_match(ch, links, L):
    assert links, "no link returned"
    errs = [chain_error(ch, lk, L) for lk in links]
    return links[int(np.argmin(errs))], min(errs)


# ------------------------------------------------------------------ HH, RH, HR
@pytest.mark.parametrize("kinds,n_chains", [("HH", 6), ("RH", 3), ("HR", 3)])
def test_generating_helical_link_is_among_the_solutions(kinds, n_chains):
    rng = np.random.default_rng({"HH": 11, "RH": 12, "HR": 13}[kinds])
    worst = 0.0
    for _ in range(n_chains):
        p = [0.0 if k == "R" else rng.uniform(-1, 1) for k in kinds]
        ch = random_chain(rng, 3, kinds, p)
        L = size_of(ch["T"])
        links = helical_links(*ch["screws"], p[0], p[1])
        link, err = best_match(ch, links, L)
        assert err < TOL_AXIS, err
        assert link.types == kinds
        th, a, ph, b = oriented(ch, link)
        np.testing.assert_allclose(th, ch["th"], atol=1e-8)
        np.testing.assert_allclose(ph, ch["ph"], atol=1e-8)
        np.testing.assert_allclose(a, ch["a"], atol=1e-8 * L)
        np.testing.assert_allclose(b, ch["b"], atol=1e-8 * L)
        np.testing.assert_allclose([link.fixed_pitch, link.moving_pitch], p, atol=1e-12)
        assert all(lk.residual <= 1e-9 for lk in links)
        # every solution, driven by the closure engine, reaches the positions
        res = verify_links([lk.chain() for lk in links], ch["T"], task_scale(ch["T"])[2])
        assert res.max() <= 1e-9, res
        worst = max(worst, err)
    print(f"{kinds}: worst generating-link error {worst:.1e}")


def test_pitch_zero_reproduces_rr_links():
    rng = np.random.default_rng(5)
    for _ in range(4):
        ch = random_chain(rng, 3, "RR", (0.0, 0.0))
        L = size_of(ch["T"])
        hl = helical_links(*ch["screws"], 0.0, 0.0)
        rr = rr_links(*ch["screws"])
        assert len(hl) == len(rr) == 2
        for r in rr:
            errs = [max(line_error(r.fixed_axis.direction, r.fixed_axis.point, h.fixed_axis, L),
                        line_error(r.moving_axis.direction, r.moving_axis.point, h.moving_axis, L))
                    for h in hl]
            assert min(errs) < 1e-9, errs
            h = hl[int(np.argmin(errs))]
            assert h.types == "RR" and np.all(h.fixed_slides == 0) and np.all(h.moving_slides == 0)


def _common_normal(u1, c1, u2, c2):
    """Feet on line 1 and line 2 and the unit normal direction (line geometry)."""
    n = np.cross(u1, u2)
    if np.linalg.norm(n) < 1e-12:
        raise AssertionError("parallel lines")
    n /= np.linalg.norm(n)
    # c1 + s u1 + λ n = c2 + t u2
    M = np.stack([u1, -u2, n], 1)
    s, t, _ = np.linalg.solve(M, c2 - c1)
    return c1 + s * u1, c2 + t * u2, n


def _rodrigues(u, ang, v):
    return v * np.cos(ang) + np.cross(u, v) * np.sin(ang) + u * (u @ v) * (1 - np.cos(ang))


def screw_triangle_residual(link, screw: Screw):
    """Tsai & Roth's screw triangle, rebuilt from line geometry: with N the common normal
    of G and W, A = N screwed about G by half the fixed joint's dual angle, B = N screwed
    about W by minus half the moving joint's, the relative screw's axis is the common
    normal of B and A, its angle twice the angle from B to A and its slide twice their
    distance.  Returns the largest mismatch (rad, length)."""
    j = link._position
    g, cg = link.fixed_axis.direction, link.fixed_axis.point
    w, cw = link.moving_axis.direction, link.moving_axis.point
    fg, fw, n = _common_normal(g, cg, w, cw)
    th, a = link.fixed_angles[j], link.fixed_slides[j]
    ph, b = link.moving_angles[j], link.moving_slides[j]
    A_dir, A_pt = _rodrigues(g, th / 2, n), fg + a / 2 * g
    B_dir, B_pt = _rodrigues(w, -ph / 2, n), fw - b / 2 * w
    fb, fa, s = _common_normal(B_dir, B_pt, A_dir, A_pt)
    if s @ screw.axis < 0:
        s = -s
    ang = np.arctan2(s @ np.cross(B_dir, A_dir), B_dir @ A_dir)      # from B to A about s
    slide = 2 * (fa - fb) @ s
    sig = (2 * ang - screw.angle * np.sign(s @ screw.axis)) % (2 * np.pi)
    errs = [1 - abs(s @ screw.axis), min(sig, 2 * np.pi - sig),
            np.linalg.norm(np.cross(screw.axis, fa - screw.point)),
            abs(slide - screw.slide)]
    return max(errs)


def test_hh_links_satisfy_the_screw_triangle():
    rng = np.random.default_rng(21)
    worst = 0.0
    for _ in range(4):
        p = (rng.uniform(-1, 1), rng.uniform(-1, 1))
        ch = random_chain(rng, 3, "HH", p)
        links = helical_links(*ch["screws"], *p)
        assert links
        for lk in links:
            for j, s in ((1, ch["screws"][0]), (2, ch["screws"][1])):
                lk._position = j
                worst = max(worst, screw_triangle_residual(lk, s))
    assert worst < 1e-9, worst
    print(f"screw triangle: worst mismatch {worst:.1e}")


def test_multistart_least_squares_finds_no_hh_link_that_helical_links_misses():
    """An independent formulation (axes as direction + point, joint angles, 12 pose
    equations) solved by least_squares from 20 random starts per task."""
    rng = np.random.default_rng(31)
    for _ in range(2):
        p = (rng.uniform(-0.8, 0.8), rng.uniform(-0.8, 0.8))
        ch = random_chain(rng, 3, "HH", p)
        T = ch["T"]
        L = size_of(T)
        links = helical_links(*ch["screws"], *p)

        def F(z):
            g, w = z[0:3] / np.linalg.norm(z[0:3]), z[3:6] / np.linalg.norm(z[3:6])
            out = [np.r_[z[0:3] @ z[0:3] - 1, z[3:6] @ z[3:6] - 1]]
            for k in (1, 2):
                th, ph = z[12 + 2 * (k - 1)], z[13 + 2 * (k - 1)]
                P = fast_screw(g, z[6:9], th, p[0] * th) @ fast_screw(w, z[9:12], ph, p[1] * ph)
                out.append((P - T[k])[:3].ravel())
            return np.concatenate(out)

        converged = 0
        for _ in range(20):
            z0 = np.r_[unit(rng), unit(rng), rng.normal(size=6), rng.uniform(-3, 3, 4)]
            sol = least_squares(F, z0, xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=300)
            if np.linalg.norm(sol.fun) > 1e-10:
                continue
            z = sol.x
            angles = z[12:]
            if np.any(np.abs(angles) > np.pi):          # another branch of the helix
                continue
            found = dict(g=z[0:3] / np.linalg.norm(z[0:3]), cg=z[6:9],
                         w=z[3:6] / np.linalg.norm(z[3:6]), cw=z[9:12])
            assert min(chain_error(found, lk, L) for lk in links) < 1e-7
            converged += 1
        assert converged > 0                  # the reference did find links


# ------------------------------------------------------------------ C joints
@pytest.mark.parametrize("kinds", ["RC", "HC", "CR", "CH"])
def test_one_cylinder_link_gives_the_generating_chain_back(kinds):
    rng = np.random.default_rng(sum(map(ord, kinds)))
    for _ in range(5):
        p = [rng.uniform(-1, 1) if k == "H" else 0.0 for k in kinds]
        ch = random_chain(rng, 3, kinds, p)
        L = size_of(ch["T"])
        if kinds[0] == "C":
            links = cr_links(*ch["screws"], ch["g"], moving_pitch=p[1])
        else:
            links = rc_links(*ch["screws"], ch["g"], fixed_pitch=p[0])
        assert len(links) == 1 and links[0].types == kinds
        assert chain_error(ch, links[0], L) < TOL_AXIS
        np.testing.assert_allclose(links[0].parameters["fixed_direction"], ch["g"])
        assert links[0].residual <= 1e-9
        # another fixed direction gives another link of the family, also exact
        other = (rc_links if kinds[1] == "C" else cr_links)(*ch["screws"], unit(rng))[0]
        assert other.residual <= 1e-9


def test_cc_links_three_and_four_positions_with_the_generating_parameters():
    rng = np.random.default_rng(7)
    for n in (3, 4):
        for _ in range(5):
            ch = random_chain(rng, n, "CC", (0, 0))
            L = size_of(ch["T"])
            if n == 3:
                links = cc_links(ch["screws"], fixed_axis=Line(ch["g"], ch["cg"]))
            else:
                assert cc_direction_residual(ch["screws"], ch["g"]) < 1e-12
                assert cc_direction_residual(ch["screws"], unit(rng)) > 1e-6
                links = cc_links(ch["screws"], fixed_direction=ch["g"], fixed_point=ch["cg"])
                # the same link from the azimuth (rad) of the generating direction: one of
                # the up to three admissible directions in that half-plane
                psi = np.arctan2(ch["g"][1], ch["g"][0])
                by_azimuth = cc_links(ch["screws"], azimuth=psi, fixed_point=ch["cg"])
                assert 1 <= len(by_azimuth) <= 3
                assert all(cc_direction_residual(ch["screws"], lk.fixed_axis.direction) < 1e-12
                           and lk.residual <= 1e-9 for lk in by_azimuth)
                assert min(chain_error(ch, lk, L) for lk in by_azimuth) < TOL_AXIS
                # another point: another member of the family, also exact, its axis nearer
                # to the point than the generating one is (or as near)
                P = ch["cg"] + rng.normal(size=3)
                other = cc_links(ch["screws"], fixed_direction=ch["g"], fixed_point=P)[0]
                assert other.residual <= 1e-9
                assert np.linalg.norm(np.cross(ch["g"], P - other.fixed_axis.point)) <= \
                    np.linalg.norm(np.cross(ch["g"], P - ch["cg"])) + 1e-12
            assert len(links) == 1 and chain_error(ch, links[0], L) < TOL_AXIS
            _, a, _, b = oriented(ch, links[0])
            np.testing.assert_allclose(a, ch["a"], atol=1e-8 * L)
            np.testing.assert_allclose(b, ch["b"], atol=1e-8 * L)


def test_cc_links_five_positions_contain_the_generating_link():
    rng = np.random.default_rng(9)
    worst = 0.0
    for _ in range(8):
        ch = random_chain(rng, 5, "CC", (0, 0))
        L = size_of(ch["T"])
        links = cc_links(ch["screws"])
        _, err = best_match(ch, links, L)
        worst = max(worst, err)
        res = verify_links([lk.chain() for lk in links], ch["T"], task_scale(ch["T"])[2])
        assert res.max() <= 1e-9
    assert worst < TOL_AXIS, worst
    print(f"CC5: worst generating-link error {worst:.1e}")


# ------------------------------------------------------------------ degenerate tasks
def test_degenerate_tasks_raise_naming_the_cause():
    rng = np.random.default_rng(3)
    ch = random_chain(rng, 3, "HH", (0.2, 0.1))
    s12, s13 = ch["screws"]
    ident = Screw([0, 0, 1.0], [0, 0, 0], 0.0, 0.0)
    with pytest.raises(SynthesisError, match="coincide"):
        helical_links(ident, s13, 0.2, 0.1)
    with pytest.raises(SynthesisError, match="coincide"):
        rc_links(s12, s12, [0, 0, 1.0])
    trans = Screw([0, 0, 1.0], [0, 0, 0], 0.0, 0.4)
    with pytest.raises(SynthesisError, match="pure translation"):
        helical_links(trans, s13, 0.2, 0.1)
    with pytest.raises(SynthesisError, match="pure translation"):
        cc_links([s12, trans])           # fixed axis not needed to see it
    # parallel relative screw axes: a planar task
    z = [0, 0, 1.0]
    planar = [Screw(z, [0.3, 0.1, 0], 0.7, 0.0), Screw(z, [-0.2, 0.5, 0], -1.1, 0.0)]
    for call in (lambda: helical_links(*planar), lambda: rc_links(*planar, [1.0, 0, 0]),
                 lambda: cc_links(planar, fixed_axis=Line([1.0, 0, 0], [0, 0, 0]))):
        with pytest.raises(SynthesisError, match="parallel"):
            call()
    # a fixed direction for which the moving axis is not determined
    with pytest.raises(SynthesisError, match="fixed_direction: degenerate"):
        rc_links(s12, s13, s12.axis)
    # four positions: a direction off the admissible curve
    ch4 = random_chain(rng, 4, "CC", (0, 0))
    with pytest.raises(SynthesisError, match="fixed_direction: not on the curve"):
        cc_links(ch4["screws"], fixed_direction=unit(rng), fixed_point=np.zeros(3))
    with pytest.raises(SynthesisError, match="fixed_axis: required"):
        cc_links(ch["screws"])


def test_families_row_15_is_rps_prs():
    from synthesis import families
    f = families()
    row15 = f[f.row == 15]
    assert list(row15.family) == ["RPS", "PRS"]
    assert list(row15.N) == [5, 5] and list(row15.N_max) == [10, 10]
    assert "misprint" in row15.iloc[0].note
    assert list(f[f.row == 14].family) == ["RRS"]
    # 53 spellings, 51 distinct families (RCC and CRC are printed in rows 5 and 19 alike)
    assert len(f) == 53 and f.family.nunique() == 51


# ------------------------------------------------------------------ P joints
def _pr_chain(rng, kind, g, cg, w, cw):
    if kind == "PR":
        a, ph = np.r_[0.0, rng.normal(size=2)], np.r_[0.0, rng.uniform(0.3, 2.5, 2) * [1, -1]]
        T = np.array([screw_T(g, cg, 0.0, a[k]) @ screw_T(w, cw, ph[k], 0.0) for k in range(3)])
        return T, a
    th, b = np.r_[0.0, rng.uniform(0.3, 2.5, 2) * [1, -1]], np.r_[0.0, rng.normal(size=2)]
    T = np.array([screw_T(g, cg, th[k], 0.0) @ screw_T(w, cw, 0.0, b[k]) for k in range(3)])
    return T, b


@pytest.mark.parametrize("kind", ["PR", "RP"])
def test_prismatic_links_give_the_generating_link_back(kind):
    from synthesis import pr_links, rp_links
    rng = np.random.default_rng({"PR": 51, "RP": 52}[kind])
    worst = 0.0
    for _ in range(10):
        g, w, cg, cw = unit(rng), unit(rng), rng.normal(size=3), rng.normal(size=3)
        T, slides = _pr_chain(rng, kind, g, cg, w, cw)
        L = size_of(T)
        link = (pr_links if kind == "PR" else rp_links)(*[Screw.from_matrix(t) for t in T[1:]])[0]
        assert link.types == kind and link.residual <= 1e-9
        if kind == "PR":
            err = max(np.linalg.norm(np.cross(g, link.fixed_axis.direction)),
                      line_error(w, cw, link.moving_axis, L))
            got = link.fixed_slides * np.sign(g @ link.fixed_axis.direction)
        else:
            err = max(np.linalg.norm(np.cross(w, link.moving_axis.direction)),
                      line_error(g, cg, link.fixed_axis, L))
            got = link.moving_slides * np.sign(w @ link.moving_axis.direction)
        np.testing.assert_allclose(got, slides, atol=1e-8 * L)
        assert verify_links([link.chain()], T, task_scale(T)[2])[0] <= 1e-9
        worst = max(worst, err)
    assert worst < TOL_AXIS, worst
    print(f"{kind}: worst generating-link error {worst:.1e}")


def test_prismatic_links_need_one_rotation_direction():
    from synthesis import pr_links, rp_links
    rng = np.random.default_rng(8)
    ch = random_chain(rng, 3, "RR", (0, 0))
    for f in (pr_links, rp_links):
        with pytest.raises(SynthesisError, match="do not share one axis direction"):
            f(*ch["screws"])
    z = [0, 0, 1.0]
    planar = [Screw(z, [0.3, 0.1, 0], 0.7, 0.0), Screw(z, [-0.2, 0.5, 0], -1.1, 0.0)]
    with pytest.raises(SynthesisError, match="planar motion"):
        pr_links(*planar)


def test_hr_links_tend_to_the_pr_link_as_the_pitch_grows():
    """Positions of an HR chain of pitch p with fixed slides a_j (turning a_j / p) tend to
    those of the PR chain with the same axes.  The HR link helical_links finds at pitch p
    has the PR link's axes (found by pr_links on the limit positions), the same slides,
    and a fixed-joint rotation a_j / p → 0: the prismatic joint in the limit."""
    from synthesis import pr_links
    rng = np.random.default_rng(61)
    g, w, cg, cw = unit(rng), unit(rng), rng.normal(size=3), rng.normal(size=3)
    a, ph = np.r_[0.0, 0.7, -0.5], np.r_[0.0, 1.1, -0.8]
    T_lim = chain_positions(g, cg, w, cw, 0 * a, a, ph, 0 * ph)
    pr = pr_links(*[Screw.from_matrix(t) for t in T_lim[1:]])[0]
    L = size_of(T_lim)
    pr_slides = pr.fixed_slides * np.sign(g @ pr.fixed_axis.direction)
    for p in (1.0, 10.0, 100.0, 1000.0):
        T = chain_positions(g, cg, w, cw, a / p, a, ph, 0 * ph)
        links = helical_links(*[Screw.from_matrix(t) for t in T[1:]], p, 0.0)
        gaps = [max(np.linalg.norm(np.cross(pr.fixed_axis.direction, lk.fixed_axis.direction)),
                    line_error(pr.moving_axis.direction, pr.moving_axis.point, lk.moving_axis, L))
                for lk in links]
        hr = links[int(np.argmin(gaps))]
        assert min(gaps) < TOL_AXIS, (p, min(gaps))
        sgn = np.sign(g @ hr.fixed_axis.direction)
        np.testing.assert_allclose(sgn * hr.fixed_slides, pr_slides, atol=1e-8 * L)
        np.testing.assert_allclose(sgn * hr.fixed_angles, a / p, atol=1e-9)


@pytest.mark.parametrize("kind", ["PC", "CP"])
def test_prismatic_cylinder_links_give_the_generating_link_back(kind):
    from synthesis import cp_links, pc_links
    rng = np.random.default_rng({"PC": 71, "CP": 72}[kind])
    worst = 0.0
    for _ in range(10):
        g, w, cg, cw = unit(rng), unit(rng), rng.normal(size=3), rng.normal(size=3)
        s1, s2 = np.r_[0.0, rng.normal(size=2)], np.r_[0.0, rng.normal(size=2)]
        ang = np.r_[0.0, rng.uniform(0.3, 2.5, 2) * [1, -1]]
        if kind == "PC":    # slide s1 along g, then the cylinder (w, cw): angle, slide s2
            T = np.array([screw_T(g, cg, 0.0, s1[k]) @ screw_T(w, cw, ang[k], s2[k])
                          for k in range(3)])
            link = pc_links(*[Screw.from_matrix(t) for t in T[1:]], g)[0]
            err = max(np.linalg.norm(np.cross(g, link.fixed_axis.direction)),
                      line_error(w, cw, link.moving_axis, size_of(T)))
        else:               # the cylinder (g, cg): angle, slide s1, then slide s2 along w
            T = np.array([screw_T(g, cg, ang[k], s1[k]) @ screw_T(w, cw, 0.0, s2[k])
                          for k in range(3)])
            link = cp_links(*[Screw.from_matrix(t) for t in T[1:]], w)[0]
            err = max(np.linalg.norm(np.cross(w, link.moving_axis.direction)),
                      line_error(g, cg, link.fixed_axis, size_of(T)))
        assert link.types == kind and link.residual <= 1e-9
        assert verify_links([link.chain()], T, task_scale(T)[2])[0] <= 1e-9
        worst = max(worst, err)
    assert worst < TOL_AXIS, worst


def test_free_pitch_hh_gives_the_generating_pitches_back():
    from synthesis import hh_links_free_pitch
    rng = np.random.default_rng(81)
    for _ in range(10):
        p = (rng.uniform(-1, 1), rng.uniform(-1, 1))
        ch = random_chain(rng, 3, "HH", p)
        L = size_of(ch["T"])
        link = hh_links_free_pitch(*ch["screws"], ch["g"])[0]
        assert link.types == "HH" and link.residual <= 1e-9
        assert chain_error(ch, link, L) < TOL_AXIS
        np.testing.assert_allclose([link.fixed_pitch, link.moving_pitch], p, atol=1e-8 * L)
        # any other direction: another member of the family, also exact and verified
        other = hh_links_free_pitch(*ch["screws"], unit(rng))[0]
        assert verify_links([other.chain()], ch["T"], task_scale(ch["T"])[2])[0] <= 1e-9


# ------------------------------------------------------------------ P joints, two positions
@pytest.mark.parametrize("kind", ["PR", "RP", "PH", "HP"])
def test_two_position_prismatic_links_give_the_generating_link_back(kind):
    """A random PR/RP/PH/HP link moved to a second position: its own slide direction
    (the two free parameters) gives it back, axes, slide and angle."""
    from synthesis.prismatic import hp_links, ph_links, pr_links, rp_links
    rng = np.random.default_rng({"PR": 71, "RP": 72, "PH": 73, "HP": 74}[kind])
    worst = 0.0
    for _ in range(20):
        d, w, cw = unit(rng), unit(rng), rng.normal(size=3)
        p = 0.0 if "R" in kind else rng.uniform(-0.6, 0.6)
        s, phi = rng.normal(), rng.uniform(0.3, 2.8)
        if kind[0] == "P":          # slide in the ground, then the screw about (w, cw)
            T2 = screw_T(d, np.zeros(3), 0.0, s) @ screw_T(w, cw, phi, p * phi)
        else:                       # the screw about (w, cw) in the ground, then the slide
            T2 = screw_T(w, cw, phi, p * phi) @ screw_T(d, np.zeros(3), 0.0, s)
        T = np.array([np.eye(4), T2])
        s12 = Screw.from_matrix(T2)
        L = size_of(T)
        if kind == "PR":
            links = pr_links(s12, None, fixed_direction=d)
        elif kind == "RP":
            links = rp_links(s12, None, moving_direction=d)
        elif kind == "PH":
            links = ph_links(s12, pitch=p, fixed_direction=d)
        else:
            links = hp_links(s12, pitch=p, moving_direction=d)
        assert len(links) == 1
        lk = links[0]
        assert lk.types == (kind if p else kind.replace("H", "R"))
        pri, rot = (lk.fixed_axis, lk.moving_axis) if kind[0] == "P" else \
            (lk.moving_axis, lk.fixed_axis)
        err = max(np.linalg.norm(np.cross(d, pri.direction)), line_error(w, cw, rot, L))
        got_s = (lk.fixed_slides if kind[0] == "P" else lk.moving_slides)[1] * (d @ pri.direction)
        sgn = w @ rot.direction
        got_phi = (lk.moving_angles if kind[0] == "P" else lk.fixed_angles)[1] * sgn
        assert abs(got_s - s) < 1e-8 * L and abs(got_phi - phi) < 1e-10
        assert verify_links([lk.chain()], T, task_scale(T)[2])[0] <= 1e-9
        worst = max(worst, err)
    assert worst < TOL_AXIS, worst


def test_two_position_prismatic_links_pitch_zero_and_bad_input():
    from synthesis.prismatic import hp_links, ph_links, pr_links, rp_links
    rng = np.random.default_rng(75)
    s12 = Screw(unit(rng), rng.normal(size=3), 1.2, 0.4)
    d = unit(rng)
    for a, b in ((ph_links(s12, pitch=0.0, fixed_direction=d)[0],
                  pr_links(s12, None, fixed_direction=d)[0]),
                 (hp_links(s12, pitch=0.0, moving_direction=d)[0],
                  rp_links(s12, None, moving_direction=d)[0])):
        assert a.types == b.types
        np.testing.assert_array_equal(a.fixed_axis.point, b.fixed_axis.point)
        np.testing.assert_array_equal(a.moving_axis.point, b.moving_axis.point)
    perp = np.cross(s12.axis, d)
    perp /= np.linalg.norm(perp)
    cases = [(lambda: ph_links(s12, pitch=0.1, fixed_direction=perp), "fixed_direction"),
             (lambda: hp_links(s12, pitch=np.nan, moving_direction=d), "pitch"),
             (lambda: pr_links(s12, None), "s13"),
             (lambda: rp_links(s12, None, moving_direction=[1.0, 2.0]), "moving_direction"),
             (lambda: pr_links(s12, s12, fixed_direction=d), "fixed_direction"),
             (lambda: ph_links(Screw([0, 0, 1.0], [0, 0, 0], 0.0, 1.0), pitch=0.1,
                               fixed_direction=d), "s12")]
    for f, name in cases:
        with pytest.raises(SynthesisError) as e:
            f()
        assert name in str(e.value)
