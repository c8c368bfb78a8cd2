"""The typed kinematic state, the compiled evaluation plan, the solver's fused analogs, the
lazily kept state and condition numbers, and the public carrier twists, each against an
independent reference (hand-composed joint transforms, central differences, Freudenstein's
closed form, numpy's SVD)."""
import numpy as np
import pytest

from closure import (KinematicState, Mechanism, MechanismError, carrier_twists, exp_so3,
                     link_twists, log_se3, rot_x, rot_y, rot_z, transform)
from closure.kinematics import _carrier_twists, bracket
from closure.pose import KEEP_STATE

from linkwright.references import RSSR, fourbar, fourbar_rates, rssr_frame, rssr_output


def mixed_chain():
    """An open tree with every joint kind and a joint entered backwards (ground is its
    link b), so that the link poses can be composed by hand."""
    m = Mechanism(["a", "b", "c", "d", "e", "f"])
    m.add_joint("j1", "R", "ground", "a", at=transform(rot_x(0.3), (0.1, 0, 0)))
    m.add_joint("j2", "U", "a", "b", at=transform(rot_y(0.2), (1, 0, 0)))
    m.add_joint("j3", "C", "b", "c", at=transform(rot_z(0.4) @ rot_x(1.0), (1, 1, 0)))
    m.add_joint("j4", "H", "c", "d", at=transform(rot_x(0.7), (0, 1, 1)), pitch=0.3)
    m.add_joint("j5", "S", "d", "e", at=transform(None, (0.5, 1, 1)))
    m.add_joint("j6", "P", "f", "ground", at=transform(rot_y(1.1), (0.2, 0.3, 0.5)))
    return m


def hand_links(m, q, rot):
    """World pose of every link of ``mixed_chain`` for one state, from Joint.matrix and the
    joint frames alone (each tree joint: T_b = T_a F_a A(q) F_b⁻¹)."""
    t = m.tree
    T = {"ground": np.eye(4)}
    for name in ("j1", "j2", "j3", "j4", "j5", "j6"):
        j = m.joint(name)
        qj = q[None, t.q_offset[j.index]:t.q_offset[j.index] + j.nq]
        A = j.matrix(qj, rot[None, t.s_index[j.index]] if j.kind == "S" else None)[0]
        rel = j.frame_a @ A @ np.linalg.inv(j.frame_b)
        if j.link_a in T:
            T[j.link_b] = T[j.link_a] @ rel
        else:                                      # entered from link b
            T[j.link_a] = T[j.link_b] @ np.linalg.inv(rel)
    return np.array([T[n] for n in m.links])


def test_state_is_typed_links_match_hand_composition_and_twists_match_differences():
    m = mixed_chain()
    t = m.tree
    rng = np.random.default_rng(3)
    q = rng.normal(size=(3, t.nq))
    rot = exp_so3(rng.normal(size=(3, t.ns, 3)))
    ks = m.kinematic_state((q, rot))
    assert isinstance(ks, KinematicState) and not hasattr(ks, "__dict__")
    assert isinstance(ks, KinematicState) and ks.S.shape == (3, t.nv, 6)
    for b in range(3):
        np.testing.assert_allclose(ks.link[b], hand_links(m, q[b], rot[b]), rtol=0, atol=1e-12)
    # every column's twist: d/dε of the world pose of the link it drives, by central
    # differences of the hand-composed poses (the S joint turns by exp(ε e_k) in frame a)
    h = 1e-6
    for j in m.joints:
        li = m.links.index(j.link_b if j.name != "j6" else j.link_a)
        sign = -1.0 if j.name == "j6" else 1.0
        for k in range(j.nv):
            c = t.v_offset[j.index] + k
            Tp, Tm = [], []
            for e, out in ((h, Tp), (-h, Tm)):
                qq, rr = q[0].copy(), rot[0].copy()
                if j.kind == "S":
                    rr[t.s_index[j.index]] = exp_so3(e * np.eye(3)[k]) @ rr[t.s_index[j.index]]
                else:
                    qq[t.q_offset[j.index] + k] += e
                out.append(hand_links(m, qq, rr)[li])
            T0 = hand_links(m, q[0], rot[0])[li]
            fd = (log_se3(Tp[0] @ np.linalg.inv(T0)) - log_se3(Tm[0] @ np.linalg.inv(T0))) / (2 * h)
            np.testing.assert_allclose(sign * fd, ks.S[0, c], rtol=0, atol=1e-8)


def rsur():
    """The RSSR of the references with its second ball joint replaced by a Hooke joint
    (pins along the rod's direction-normal and an arbitrary cross direction): mobility 1,
    no idle spin, and a column (the U joint's second pin) carried by its first pin."""
    a, c, P0 = RSSR["a"], RSSR["c"], RSSR["P0"]
    u, e1, e2 = rssr_frame()
    phi0, psi0 = 0.2, rssr_output(0.2, 1)
    A = np.array([a * np.cos(phi0), a * np.sin(phi0), 0])
    Bp = P0 + c * (np.cos(psi0) * e1 + np.sin(psi0) * e2)
    m = Mechanism(["crank", "rod", "rocker"])
    m.add_joint("in", "R", "ground", "crank", at=np.eye(4))
    m.add_joint("S1", "S", "crank", "rod", at=transform(None, A))
    m.add_joint("U2", "U", "rod", "rocker", at=transform(rot_x(0.4) @ rot_y(0.9), Bp))
    m.add_joint("out", "R", "ground", "rocker", at=transform(np.stack([e1, e2, u], -1), P0))
    m.add_input("in")
    return m


def test_public_carrier_twists_give_the_rate_of_the_column_twists():
    m = rsur()
    x, h = 0.3, 1e-5
    poses = m.solve(np.array([x - h, x, x + h]))
    ks = poses.kinematics()
    first, _ = m.analogs(poses, second=False)
    rates = first[:, :, 0]                                 # dq/dx along the path
    V = carrier_twists(m, ks, rates)
    assert _carrier_twists is carrier_twists
    # the former dict form is refused with an error naming the argument
    with pytest.raises(MechanismError, match="carrier_twists: ks: expected a KinematicState"):
        carrier_twists(m, {"S": ks.S, "carrier": ks.carrier, "deps": ks.deps}, rates)
    Sdot = bracket(V[1], ks.S[1])                          # dS_c/dx = [V_c, S_c]
    fd = (ks.S[2] - ks.S[0]) / (2 * h)
    np.testing.assert_allclose(Sdot, fd, rtol=0, atol=1e-8)
    assert any(ks.deps)                                   # the U joint's second pin


def test_fused_analogs_equal_freudenstein_and_large_batches_keep_no_state():
    geom = dict(a=1.0, b=3.0, c=2.5, d=3.2)
    t20 = 0.3
    m, _ = fourbar(**geom, t2_0=t20)
    x = np.linspace(-1.0, 1.0, KEEP_STATE + 40)
    big = m.solve(x)
    small = m.solve(x[:5])
    assert big._ks is None and small._ks is not None and small._ks.first is not None
    _, (w3, w4), _ = fourbar_rates(t20 + x, 1.0, 0.0, **geom)
    ci = {n: i for i, n in enumerate(m.velocity_labels())}
    for pose, n in ((small, 5), (big, x.size)):
        first, _ = m.analogs(pose, second=False)          # solver's (small) or recomputed
        np.testing.assert_allclose(first[:, ci["D"], 0], w4[:n], rtol=0, atol=1e-10)
        np.testing.assert_allclose(first[:, ci["A"], 0] + first[:, ci["B"], 0], w3[:n],
                                   rtol=0, atol=1e-10)
    # the recomputed state equals the one the solver kept
    ks = big.kinematics()
    np.testing.assert_allclose(ks.link[:5], small.kinematics().link, rtol=0, atol=1e-13)


def test_lazy_condition_numbers_equal_the_svd():
    m, _ = fourbar(1.0, 3.0, 2.5, 3.2, 0.3)
    x = np.linspace(-2.0, 2.0, 150)
    pose = m.solve(x)
    assert pose._cond_pending and np.isnan(pose._raw_condition).any()
    cond = pose.condition
    assert np.isfinite(cond).all() and not pose._cond_pending
    # independent: s_max / s_min of the dimensionless Jacobian of the unknowns
    J = m._scaled_jacobian(m.kinematic_state(pose.state))[:, :, m.unknown_columns()]
    s = np.linalg.svd(J, compute_uv=False)
    np.testing.assert_allclose(cond, s[:, 0] / s[:, -1], rtol=1e-12)
    # a limit below the fast-path bound flags from exact figures at once
    from closure import SolverOptions
    lim = float(np.median(cond))
    p2 = m.solve(x, options=SolverOptions(cond_limit=lim))
    np.testing.assert_array_equal(p2.status == 1, s[:, 0] / s[:, -1] > lim)


def test_state_without_twists_has_no_S():
    m, _ = fourbar(1.0, 3.0, 2.5, 3.2, 0.3)
    ks = m.kinematic_state(m.assembly(), twists=False)
    assert ks.S is None
    with pytest.raises(MechanismError, match="link_twists: ks: expected a KinematicState with "
                                             "twists"):
        link_twists(m, ks, np.zeros((1, m.tree.nv)))


def test_loop_log_inverts_exp_at_every_angle():
    from closure import exp_se3
    from closure.state import _loop_log, _rot_log
    rng = np.random.default_rng(5)
    for ang in (0.0, 1e-9, 1e-6, 1e-3, 0.3, 1.5, 2.0, 3.1):     # below and past a quarter turn
        xi = rng.normal(size=(20, 6))
        n = np.linalg.norm(xi[:, 3:], axis=1, keepdims=True)
        xi[:, 3:] *= ang / n
        np.testing.assert_allclose(_loop_log(exp_se3(xi)), xi, rtol=0, atol=1e-10)
        rl = _rot_log(exp_se3(xi)[:, :3, :3])
        assert (rl is None) == (ang > np.pi / 2)
        if rl is not None:
            np.testing.assert_allclose(rl[0], xi[:, 3:], rtol=0, atol=1e-13)
