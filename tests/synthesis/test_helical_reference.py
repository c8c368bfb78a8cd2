"""helical_links against independent references: random HH, RH, HR and RR chains built
here by Rodrigues screw products (random axes, pitches in {0, 0.2, −0.5}, joint
rotations 0.1–2.5 rad).  The generating link must be among the results, every result
must reach the three positions by this file's own forward kinematics, and at pitch 0
the results must be the RR links of rr_links (an independent, algebraic method)."""
import numpy as np
import pytest

from synthesis import Screw, helical_links, rr_links
from synthesis.validate import task_scale

AXIS_TOL = 1e-8          # rad, and relative to the task's size


def rodrigues(u, c, theta, slide):
    """4x4 screw about the line (u, c): rotation θ, then slide along u."""
    u, c = np.asarray(u, float), np.asarray(c, float)
    K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    R = np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * K @ K
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, c - R @ c + slide * u
    return T


def unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def random_chain(rng, pitches=None):
    pg, pw = rng.choice([0.0, 0.2, -0.5], 2) if pitches is None else pitches
    g, w = unit(rng), unit(rng)
    cg, cw = rng.normal(size=3), rng.normal(size=3)
    th = rng.choice([-1, 1], 2) * rng.uniform(0.1, 2.5, 2)
    ph = rng.choice([-1, 1], 2) * rng.uniform(0.1, 2.5, 2)
    T = np.stack([np.eye(4)] + [rodrigues(g, cg, th[k], pg * th[k]) @ rodrigues(w, cw, ph[k], pw * ph[k])
                                for k in range(2)])
    _, L, reach = task_scale(T)
    return dict(g=g, cg=cg, w=w, cw=cw, pg=float(pg), pw=float(pw), T=T, L=L, reach=reach,
                screws=[Screw.from_matrix(t) for t in T[1:]])


def line_error(u, c, direction, point, L):
    """Angle between the directions (rad) and distance of c from the line, over L."""
    ang = np.arcsin(min(1.0, np.linalg.norm(np.cross(u, direction))))
    return max(ang, np.linalg.norm(np.cross(direction, c - point)) / L)


def pose_error(link, T, reach):
    """Largest rotation (rad) or translation / reach error of the link's forward
    kinematics (this file's Rodrigues products) at positions 2, 3."""
    G, W = link.fixed_axis, link.moving_axis
    worst = 0.0
    for j in (1, 2):
        P = rodrigues(G.direction, G.point, link.fixed_angles[j], link.fixed_slides[j]) @ \
            rodrigues(W.direction, W.point, link.moving_angles[j], link.moving_slides[j])
        D = P[:3, :3].T @ T[j, :3, :3]
        rot = np.linalg.norm(D - np.eye(3)) / np.sqrt(2)    # = 2 sin(angle / 2): no arccos round-off
        worst = max(worst, rot, np.linalg.norm(P[:3, 3] - T[j, :3, 3]) / reach)
        assert link.fixed_angles[0] == 0 and link.moving_angles[0] == 0
    return worst


def test_generating_link_recovered_and_every_link_reaches_the_positions():
    rng = np.random.default_rng(2024)
    worst_gen, worst_pose = 0.0, 0.0
    for _ in range(20):
        ch = random_chain(rng)
        links = helical_links(*ch["screws"], ch["pg"], ch["pw"])
        assert links
        errs = [max(line_error(ch["g"], ch["cg"], lk.fixed_axis.direction, lk.fixed_axis.point, ch["L"]),
                    line_error(ch["w"], ch["cw"], lk.moving_axis.direction, lk.moving_axis.point, ch["L"]))
                for lk in links]
        assert min(errs) < AXIS_TOL, (min(errs), ch["pg"], ch["pw"])
        worst_gen = max(worst_gen, min(errs))
        kinds = ("R" if ch["pg"] == 0 else "H") + ("R" if ch["pw"] == 0 else "H")
        for lk in links:
            assert lk.types == kinds
            assert lk.residual <= 1e-9
            np.testing.assert_allclose(lk.fixed_slides, ch["pg"] * lk.fixed_angles, atol=1e-12 * ch["L"])
            np.testing.assert_allclose(lk.moving_slides, ch["pw"] * lk.moving_angles, atol=1e-12 * ch["L"])
            assert np.all(np.abs(lk.fixed_angles) <= np.pi) and np.all(np.abs(lk.moving_angles) <= np.pi)
            err = pose_error(lk, ch["T"], ch["reach"])
            assert err <= 1e-9, err
            worst_pose = max(worst_pose, err)
        # distinct links
        for a in range(len(links)):
            for b in range(a):
                same = [abs(abs(x.direction @ y.direction) - 1) < 1e-6 and x.distance_to(y) < 1e-6 * ch["L"]
                        for x, y in ((links[a].fixed_axis, links[b].fixed_axis),
                                     (links[a].moving_axis, links[b].moving_axis))]
                assert not all(same)
    print(f"worst generating-link error {worst_gen:.1e}, worst pose error {worst_pose:.1e}")


@pytest.mark.parametrize("seed", [7, 8])
def test_pitch_zero_equals_rr_links(seed):
    rng = np.random.default_rng(seed)
    for _ in range(5):
        ch = random_chain(rng, (0.0, 0.0))
        hl = helical_links(*ch["screws"], 0.0, 0.0)
        rr = rr_links(*ch["screws"])
        assert len(hl) == len(rr)
        for r in rr:
            errs = [max(line_error(r.fixed_axis.direction, r.fixed_axis.point, h.fixed_axis.direction,
                                   h.fixed_axis.point, ch["L"]),
                        line_error(r.moving_axis.direction, r.moving_axis.point, h.moving_axis.direction,
                                   h.moving_axis.point, ch["L"])) for h in hl]
            assert min(errs) < AXIS_TOL, min(errs)
            h = hl[int(np.argmin(errs))]
            assert h.types == "RR"
            s = np.sign(h.fixed_axis.direction @ r.fixed_axis.direction)
            np.testing.assert_allclose(s * h.fixed_angles, r.fixed_angles, atol=1e-8)
            s = np.sign(h.moving_axis.direction @ r.moving_axis.direction)
            np.testing.assert_allclose(s * h.moving_angles, r.moving_angles, atol=1e-8)


def test_results_are_ordered_by_the_fixed_direction():
    rng = np.random.default_rng(99)
    for _ in range(5):
        ch = random_chain(rng)
        links = helical_links(*ch["screws"], ch["pg"], ch["pw"])
        keys = []
        for lk in links:
            d = lk.fixed_axis.direction
            keys.append(tuple(np.round(d * np.sign(d[np.argmax(np.abs(d))]), 12)))
        assert keys == sorted(keys)
