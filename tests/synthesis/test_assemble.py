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
    assert t.reason.str.contains("C joint").all() and t["rank"].isna().all()   # no drive
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
