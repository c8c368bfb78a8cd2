"""synthesis.assemble: closing dyads into mechanisms and their defects (issue #14)."""
import numpy as np
import pytest

from synthesis import Screw, SynthesisError, rr_links
from synthesis.assemble import assemble

SEED = [Screw.from_degrees([0, 0, 1], [0, 0, 0], 30, 0.7),
        Screw.from_degrees([0.34202, 0, 0.939693], [0, 1.1, 0], 65, 0.5)]


def _dist_twist(l1, l2):
    """Common-normal length and sin of the twist angle between two lines (independent)."""
    n = np.cross(l1.direction, l2.direction)
    s = np.linalg.norm(n)
    return abs((l2.point - l1.point) @ n) / s, s


def test_bennett_from_seed_001():
    links = rr_links(*SEED)
    a = assemble(links, SEED)
    assert a.mobility == 1 and a.idle == 0
    assert np.all(a.loop_residual < 1e-12) and np.all(a.pose_error < 1e-12)
    assert a.reached.all() and not a.branch_defect and not a.dead_point
    assert 0 < a.transmission <= 1
    g1, m1 = links[0].fixed_axis, links[0].moving_axis
    g2, m2 = links[1].fixed_axis, links[1].moving_axis
    a_ground, s_ground = _dist_twist(g1, g2)
    a_body, s_body = _dist_twist(m1, m2)
    a_l1, s_l1 = _dist_twist(g1, m1)
    a_l2, s_l2 = _dist_twist(g2, m2)
    assert abs(a_ground - a_body) < 1e-12 and abs(a_l1 - a_l2) < 1e-12
    assert abs(s_ground - s_body) < 1e-12 and abs(s_l1 - s_l2) < 1e-12
    assert abs(a_ground / s_ground - a_l1 / s_l1) < 1e-12


def test_bad_inputs():
    links = rr_links(*SEED)
    for bad in (None, "RR", links[:1], [links[0], 3]):
        with pytest.raises(SynthesisError, match="links"):
            assemble(bad, SEED)
    with pytest.raises(SynthesisError, match="screws"):
        assemble(links, [SEED[0], None])
    with pytest.raises(SynthesisError, match="positions"):
        assemble(links, SEED[:1])
    for bad in ("x1", "g3", 1):
        with pytest.raises(SynthesisError, match="drive"):
            assemble(links, SEED, drive=bad)
    with pytest.raises(SynthesisError, match="steps"):
        assemble(links, SEED, steps=2)
    with pytest.raises(SynthesisError, match="tol"):
        assemble(links, SEED, tol=-1.0)


# ------------------------------------------------------------------ a constructed RRSS
from synthesis import BinaryLink, Line, RRLink  # noqa: E402
from synthesis.rr import _rot  # noqa: E402

G = Line(np.array([0, 0, 1.0]), np.array([0.0, 0, 0]))
W = Line(np.array([1.0, 0, 0]), np.array([0.0, 0, 0.8]))
A, B0 = np.array([1.2, 0.9, 0.3]), np.array([0.5, 0.7, 1.1])
ELL2 = np.sum((B0 - A) ** 2)


def _phis(theta):
    """Both roots φ of |G(θ) W(φ) B0 − A| = |B0 − A| (the two branches), in closed form."""
    f = [np.sum(((_rot(G, theta) @ _rot(W, p) @ np.r_[B0, 1])[:3] - A) ** 2) - ELL2
         for p in (0.0, np.pi / 2, np.pi)]
    # f(φ) = a cos φ + b sin φ + c exactly (a circle's points, distance squared)
    c = (f[0] + f[2]) / 2
    a, b = f[0] - c, f[1] - c
    r, ph = np.hypot(a, b), np.arctan2(b, a)
    d = np.arccos(np.clip(-c / r, -1, 1))
    return np.array([ph + d, ph - d])


def _branch_a(theta):
    """The root on the branch through (0, 0), followed in small steps of θ."""
    phi = 0.0
    for t in np.linspace(0, theta, 200)[1:]:
        r = _phis(t)
        phi = r[np.argmin(np.abs((r - phi + np.pi) % (2 * np.pi) - np.pi))]
    return phi


def _rrss(thetas, phis):
    T = [_rot(G, t) @ _rot(W, p) for t, p in zip(thetas, phis)]
    screws = [Screw.from_matrix(t) for t in T[1:]]
    rr = RRLink(G, W, 0.8, np.pi / 2, np.array(thetas), np.array(phis), 0.0)
    z = np.zeros(len(thetas))
    ss = BinaryLink("SS", Line(np.array([0, 0, 1.0]), A), Line(np.array([0, 0, 1.0]), B0),
                    np.nan, np.nan, z, z, z, z, 0.0)
    return [rr, ss], screws


def test_constructed_task_needs_a_branch_change():
    th = [0.0, 0.3, 0.6]
    other = _phis(0.6)
    pa = _branch_a(0.6)
    pb = other[np.argmax(np.abs((other - pa + np.pi) % (2 * np.pi) - np.pi))]
    assert abs(((pb - pa + np.pi) % (2 * np.pi)) - np.pi) > 0.3    # two distinct branches
    links, screws = _rrss(th, [0.0, _branch_a(0.3), pb])
    a = assemble(links, screws)
    assert a.mobility == 2 and a.idle == 1
    assert list(a.reached) == [True, True, False]
    assert a.branch_defect and not a.order_defect


def test_constructed_task_reached_out_of_order():
    th = [0.0, 0.6, 0.3]
    links, screws = _rrss(th, [0.0, _branch_a(0.6), _branch_a(0.3)])
    a = assemble(links, screws)
    assert a.reached.all() and np.all(a.pose_error < 1e-10)
    assert a.order_defect and not a.branch_defect


# ------------------------------------------------------------------ tables of solutions
def test_assemble_table_of_the_complete_rr_solutions_is_the_bennett_linkage():
    from synthesis import complete_dyads
    from synthesis.assemble import assemble_table, link_from_row
    df = complete_dyads("RR", SEED)
    t = assemble_table(df, SEED)
    assert len(t) == 1 and t.reason.iloc[0] == "" and t["rank"].iloc[0] == 1
    ref = assemble(rr_links(*SEED), SEED)
    assert t.mobility.iloc[0] == 1 and not t.defects.iloc[0]
    assert abs(t.transmission.iloc[0] - ref.transmission) < 1e-9
    assert t.pose_error.iloc[0] < 1e-12
    # the row's link reproduces the solver's link (axes and joint values)
    for i in range(2):
        lk = link_from_row(df.iloc[i])
        same = [o for o in rr_links(*SEED)
                if np.linalg.norm(np.cross(o.fixed_axis.direction, lk.fixed_axis.direction)) < 1e-12]
        assert len(same) == 1
        assert np.allclose(np.cos(same[0].fixed_angles), np.cos(lk.fixed_angles), atol=1e-12)


def test_assemble_table_records_why_a_combination_is_not_a_mechanism():
    from synthesis import complete_dyads
    from synthesis.assemble import assemble_table
    rng = np.random.default_rng(4)
    S = [Screw(v / np.linalg.norm(v), rng.normal(size=3), rng.uniform(0.4, 2.0), rng.normal())
         for v in rng.normal(size=(4, 3))]
    df = complete_dyads("CC", S)
    if len(df) < 2:
        pytest.skip("fewer than two real CC links on this task")
    t = assemble_table(df, S)
    assert len(t) == len(df) * (len(df) - 1) // 2
    # two CC links: 4 + 4 freedoms, 6 constraints — not a one-freedom mechanism
    assert t.reason.str.contains("mobility 2").all() and t["rank"].isna().all()
    t = assemble_table(df, S, drive="g1")
    assert t.reason.str.contains("g1 is a C joint").all() and t["rank"].isna().all()
    with pytest.raises(SynthesisError, match="table"):
        assemble_table(df.to_dict(), S)
    with pytest.raises(SynthesisError, match="links"):
        assemble_table(df, S, links=1)


def test_rc_and_cc_links_of_an_rccc_loop_close_back_into_it():
    """An R-C-C-C loop (random frames) driven to three input values gives a task; the RC
    link at the generating R direction and the CC link on the generating ground C axis
    are its two dyads, and assembling them gives back a one-freedom mechanism that passes
    the three positions in order on one branch."""
    from closure import Mechanism, exp_so3, transform
    from synthesis import Line
    from synthesis.cylindric import cc_links, rc_links
    rng = np.random.default_rng(3)      # a loop that moves well (condition 5–9 on the way)
    F = [transform(exp_so3(rng.normal(size=3)), rng.normal(size=3)) for _ in range(4)]
    m = Mechanism(["L1", "body", "L2"])
    for name, kind, a, b, f in (("g1", "R", "ground", "L1", F[0]), ("m1", "C", "L1", "body", F[1]),
                                ("m2", "C", "body", "L2", F[2]), ("g2", "C", "L2", "ground", F[3])):
        m.add_joint(name, kind, a, b, at=f)
    m.add_input("g1")
    assert m.mobility == 1
    pose = m.sweep(np.array([0.0, 0.2, 0.45]), return_pose=True)[1]
    T = pose.link_frame("body")
    assert len(T) == 3 and np.allclose(T[0], np.eye(4), atol=1e-12)
    scr = [Screw.from_matrix(t) for t in T[1:]]
    rc, = rc_links(*scr, F[0][:3, 2])
    cc, = cc_links(scr, fixed_axis=Line(F[3][:3, 2], F[3][:3, 3]))
    for got, f in ((rc.fixed_axis, F[0]), (rc.moving_axis, F[1]), (cc.fixed_axis, F[3]),
                   (cc.moving_axis, F[2])):
        assert abs(abs(got.direction @ f[:3, 2]) - 1) < 1e-9
        assert np.linalg.norm(np.cross(f[:3, 2], got.point - f[:3, 3])) < 1e-9
    a = assemble([rc, cc], scr, drive="g1")
    assert a.mobility == 1 and a.idle == 0
    assert a.reached.all() and np.all(a.pose_error < 1e-9)
    assert not a.order_defect and not a.branch_defect and not a.dead_point


# ------------------------------------------------------------------ a 5-SS platform
def _platform_poses(A, B, n, step, rng):
    """Poses of the body of a 5-SS platform (ground centres A, body centres B at the
    identity pose) moved along its one freedom, by scipy least squares on the five
    sphere conditions and one body coordinate (independent of the engine): the body
    point c travels ``step`` per pose along d, from small continuation steps.  Returns
    the poses, the leg lengths, c and d."""
    from scipy.optimize import least_squares
    from scipy.spatial.transform import Rotation
    radii = np.linalg.norm(B - A, axis=1)
    c, d = B.mean(0), rng.normal(size=3)
    d /= np.linalg.norm(d)

    def pose(z):
        T = np.eye(4)
        T[:3, :3] = Rotation.from_rotvec(z[:3]).as_matrix()
        T[:3, 3] = z[3:]
        return T

    def eqs(z, s):
        T = pose(z)
        Bw = B @ T[:3, :3].T + T[:3, 3]
        return np.r_[np.linalg.norm(Bw - A, axis=1) - radii, d @ (T[:3, :3] @ c + T[:3, 3] - c) - s]
    z, out = np.zeros(6), [np.eye(4)]
    for k in range(1, n):
        for s in np.linspace((k - 1) * step, k * step, 9)[1:]:
            z = least_squares(eqs, z, args=(s,), xtol=1e-15, ftol=1e-15, gtol=1e-15).x
        assert np.abs(eqs(z, k * step)).max() < 1e-12
        out.append(pose(z))
    return out, radii, c, d


def test_five_ss_platform_is_driven_through_its_positions_by_a_body_coordinate():
    """A 5-SS platform has one freedom and no joint to drive: assemble drives it by a body
    coordinate (a virtual P–P–P–S chain) and passes the platform's own positions in
    order, every leg keeping its length along the whole sweep."""
    from synthesis import Screw
    rng = np.random.default_rng(3)
    A = rng.normal(size=(5, 3)) * 2.0
    B = rng.normal(size=(5, 3)) + [0, 0, 3.0]
    T, radii, c, d = _platform_poses(A, B, 5, 0.08, rng)
    screws = [Screw.from_matrix(t) for t in T[1:]]
    z = np.zeros(len(T))
    legs = [BinaryLink("SS", Line(np.array([0, 0, 1.0]), a), Line(np.array([0, 0, 1.0]), b),
                       np.nan, np.nan, z, z, z, z, 0.0, {}) for a, b in zip(A, B)]
    # no drivable joint: the body coordinate the positions were made along
    a = assemble(legs, screws, drive_point=c, drive_direction=d)
    assert a.drive == "body" and a.mobility - a.idle == 1 and a.idle == 5
    assert np.allclose(a.drive_values, 0.08 * np.arange(5), atol=1e-12)
    assert a.reached.all() and np.all(a.pose_error < 1e-9)
    assert not a.order_defect and not a.branch_defect and not a.dead_point
    m, sweep = a.mechanism, a.sweep
    pose = m.solve(sweep["input:body_slide"].to_numpy())
    body = pose.kinematics(twists=False).link[:, m.links.index("body")]
    Bw = np.einsum("nij,kj->nki", body[:, :3, :3], B) + body[:, None, :3, 3]
    assert np.abs(np.linalg.norm(Bw - A, axis=2) - radii).max() < 1e-9
    # the same platform with position 1 in the middle of the task: the slide drive sweeps
    # forward to the positions ahead of it and backward to those behind (out of order)
    order = [2, 3, 1, 4, 0]
    T2 = T[order[0]]
    Tr = [T[k] @ np.linalg.inv(T2) for k in order]
    B2 = B @ T2[:3, :3].T + T2[:3, 3]
    legs2 = [BinaryLink("SS", Line(np.array([0, 0, 1.0]), a), Line(np.array([0, 0, 1.0]), b),
                        np.nan, np.nan, z, z, z, z, 0.0, {}) for a, b in zip(A, B2)]
    b = assemble(legs2, [Screw.from_matrix(t) for t in Tr[1:]],
                 drive_point=T2[:3, :3] @ c + T2[:3, 3], drive_direction=d)
    assert np.allclose(b.travel, [0, 0.08, -0.08, 0.16, -0.16], atol=1e-12)
    assert b.reached.all() and np.all(b.pose_error < 1e-9) and not b.dead_point
    assert b.order_defect and not b.branch_defect
    with pytest.raises(SynthesisError, match="drive: g1 is a S joint"):
        assemble(legs, screws, drive="g1")
