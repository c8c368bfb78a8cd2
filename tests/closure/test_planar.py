"""Planar four-bar and Watt six-bar against Freudenstein's closed form."""
import numpy as np
import pytest

from closure import ClosureError, Mechanism, exp_se3, translation

from linkwright.references import fourbar, fourbar_rates, freudenstein

GEOM = dict(a=1.0, b=3.0, c=2.5, d=3.2)   # Grashof crank-rocker


def wrap(x):
    return (x + np.pi) % (2 * np.pi) - np.pi


def test_fourbar_positions_velocities_accelerations_full_cycle():
    t20 = 0.3
    m, (t30, t40) = fourbar(**GEOM, t2_0=t20)
    df = m.sweep(t20 + np.linspace(0, 2 * np.pi, 73))
    assert (df.status == "ok").all()
    t2 = t20 + df["A"].to_numpy()
    t3, t4 = freudenstein(t2, **GEOM)
    assert np.abs(wrap(t40 + df["D"].to_numpy() - t4)).max() < 1e-10
    assert np.abs(wrap(t30 + df["A"].to_numpy() + df["B"].to_numpy() - t3)).max() < 1e-10
    assert df.residual.max() < 1e-12
    # velocities and accelerations at the swept poses
    _, poses = m.sweep(df["A"].to_numpy(), return_pose=True)
    w2, al2 = 2.0, -1.5
    _, (w3, w4), (al3, al4) = fourbar_rates(t2, w2, al2, **GEOM)
    qd = m.velocities(poses, [w2])
    qdd = m.accelerations(poses, [w2], [al2])
    ci = {n: i for i, n in enumerate(m.velocity_labels())}
    assert np.abs(qd[:, ci["D"]] - w4).max() < 1e-10
    assert np.abs(qd[:, ci["A"]] + qd[:, ci["B"]] - w3).max() < 1e-10
    assert np.abs(qdd[:, ci["D"]] - al4).max() < 1e-10
    assert np.abs(qdd[:, ci["A"]] + qdd[:, ci["B"]] - al3).max() < 1e-10


def test_toggle_position_is_flagged_not_wrong():
    a, b, c, d = 2.0, 2.5, 1.5, 3.0          # non-Grashof: the crank cannot turn fully
    t_lim = np.arccos((a * a + d * d - (b + c) ** 2) / (2 * a * d))
    m, _ = fourbar(a, b, c, d, t2_0=0.5)
    df = m.sweep(np.linspace(0, t_lim + 0.2 - 0.5, 41))
    bad = df[df.status != "ok"]
    assert len(bad) > 0
    first = bad.index[0]
    assert df.status[first] in ("dead point", "no assembly")
    reached = 0.5 + df["reached:A"][first]
    assert t_lim - 1e-3 < reached <= t_lim + 1e-9
    assert df.condition[first] > 1e3
    assert (df.status[first + 1:] == "not reached").all()
    ok = df[df.status == "ok"]
    t3, t4 = freudenstein(0.5 + ok["A"].to_numpy(), a, b, c, d)
    _, t40 = freudenstein(0.5, a, b, c, d)
    assert np.abs(wrap(t40 + ok["D"].to_numpy() - t4)).max() < 1e-9
    with pytest.raises(ClosureError, match="residual"):
        m.solve(t_lim + 0.1 - 0.5)


def test_invariance_under_rigid_motion_and_scale():
    G = exp_se3(np.array([100.0, -300.0, 1000.0, 0.4, -1.0, 2.0]))
    m0, _ = fourbar(**GEOM, t2_0=0.3)
    m1, _ = fourbar(**GEOM, t2_0=0.3, origin_shift=G)
    x = np.linspace(-0.3, 0.6, 10)
    p0, p1 = m0.solve(x), m1.solve(x)
    assert np.abs(p0.values() - p1.values()).max() < 1e-10
    m2, _ = fourbar(**{k: 1000 * v for k, v in GEOM.items()}, t2_0=0.3)
    p2 = m2.solve(x)
    assert np.abs(p0.values() - p2.values()).max() < 1e-10
    assert np.allclose(p0.condition, p2.condition, rtol=1e-8)


def test_watt_six_bar_two_loops():
    """Watt II: four-bar 1 drives four-bar 2 through the ternary rocker (two loops)."""
    g1 = dict(a=1.0, b=3.0, c=2.5, d=3.2)
    t20 = 0.4
    t3, t4 = freudenstein(t20, **g1)
    # second four-bar: rocker pivot D=(3.2,0) is its ground pivot; its crank is the rocker
    # extension of length 1.2 at angle t4 + 2.2; second ground pivot at E
    D = np.array([3.2, 0.0])
    E = np.array([5.5, 1.0])
    e, f, g = 1.2, 2.6, 1.9
    ed = E - D
    dist, base = np.hypot(*ed), np.arctan2(ed[1], ed[0])

    def second(t4_):
        s3, s4 = freudenstein(t4_ + 2.2 - base, e, f, g, dist)
        return s4 + base

    P = {"A": (0, 0, 0), "B": (np.cos(t20), np.sin(t20), 0),
         "C": (3.2 + 2.5 * np.cos(t4), 2.5 * np.sin(t4), 0), "D": (3.2, 0, 0)}
    F_ = D + e * np.array([np.cos(t4 + 2.2), np.sin(t4 + 2.2)])
    s4 = second(t4)
    G_ = E + g * np.array([np.cos(s4), np.sin(s4)])
    P.update(F=(*F_, 0), G=(*G_, 0), E=(*E, 0))
    m = Mechanism(["crank", "coupler", "rocker", "link5", "link6"])
    for name, la, lb in [("A", "ground", "crank"), ("B", "crank", "coupler"),
                         ("C", "coupler", "rocker"), ("D", "ground", "rocker"),
                         ("F", "rocker", "link5"), ("G", "link5", "link6"),
                         ("E", "ground", "link6")]:
        m.add_joint(name, "R", la, lb, at=translation(P[name]))
    m.add_input("A")
    assert m.n_loops == 2 and m.mobility == 1
    df = m.sweep(np.linspace(0, 2 * np.pi, 61))
    assert (df.status == "ok").all()
    t4s = freudenstein(t20 + df["A"].to_numpy(), **g1)[1]
    assert np.abs(wrap(t4 + df["D"] - t4s)).max() < 1e-10
    assert np.abs(wrap(s4 + df["E"] - second(t4s))).max() < 1e-10
    assert df.residual.max() < 1e-12
