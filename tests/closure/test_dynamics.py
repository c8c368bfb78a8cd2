"""Dynamics on the engine against analytic equations, conservation laws and the seed's formula."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from closure import Mechanism, MechanismError, translation
from closure.dynamics import Body, Dynamics, pseudo_inertia
from linkwright.references import fourbar, fourbar_rod_reference

G = 9.81


def rod_inertia(m, L, u):
    u = np.asarray(u, float) / np.linalg.norm(u)
    return m * L * L / 12 * (np.eye(3) - np.outer(u, u))


def test_pseudo_inertia_kinetic_energy_equals_trace_formula():
    rng = np.random.default_rng(1)
    m, c = 3.0, rng.normal(size=3)
    A_ = rng.normal(size=(3, 3))
    I = A_ @ A_.T + np.eye(3)
    J = pseudo_inertia(m, c, I)
    assert np.isclose(J[3, 3], m) and np.allclose(J[:3, 3], m * c)
    # seed 000: J_xx = ½(−I_xx + I_yy + I_zz) about the com (c = 0)
    J0 = pseudo_inertia(m, np.zeros(3), I)
    assert np.isclose(J0[0, 0], 0.5 * (-I[0, 0] + I[1, 1] + I[2, 2]))
    # ½ tr(Ȧ J Ȧᵀ) equals ½ m |v_c|² + ½ ωᵀ I ω for a random motion
    from closure import exp_se3, hat
    A = exp_se3(rng.normal(size=6))
    V = rng.normal(size=6)
    Ad = hat(V) @ A
    T_trace = 0.5 * np.trace(Ad @ J @ Ad.T)
    R = A[:3, :3]
    cw = A[:3, :3] @ c + A[:3, 3]
    vc = V[:3] + np.cross(V[3:], cw)
    T_ref = 0.5 * m * vc @ vc + 0.5 * V[3:] @ (R @ I @ R.T) @ V[3:]
    assert np.isclose(T_trace, T_ref, rtol=1e-12)


def test_body_checks():
    with pytest.raises(MechanismError, match="mass must be positive"):
        Body("a", 0.0, np.zeros(3), np.eye(3))
    with pytest.raises(MechanismError, match="triangle inequality"):
        Body("a", 1.0, np.zeros(3), np.diag([1.0, 1.0, 3.0]))
    with pytest.raises(MechanismError, match="positive semidefinite"):
        Body("a", 1.0, np.zeros(3), np.diag([1.0, -1.0, 1.0]))


def pendulum_chain(n_links=1):
    links = [f"l{k}" for k in range(n_links)]
    m = Mechanism(links)
    prev = "ground"
    for k, lk in enumerate(links):
        m.add_joint(f"j{k}", "R", prev, lk, at=translation([k * 1.0, 0, 0]))
        m.add_input(f"j{k}")
        prev = lk
    return m


def test_simple_and_double_pendulum_against_analytic():
    # simple: point mass m at distance l, angle from +x, gravity −y: θ̈ = −(g/l) cos θ
    m = pendulum_chain(1)
    d = Dynamics(m, gravity=(0, -G, 0))
    d.add_body("l0", 2.0, (1, 0, 0))
    t = np.linspace(0, 3, 31)
    df = d.simulate((0, 3), [0.3], [0.5], t_eval=t)
    ref = solve_ivp(lambda t, y: [y[1], -G * np.cos(y[0])], (0, 3), [0.3, 0.5], t_eval=t,
                    rtol=1e-12, atol=1e-12, method="DOP853")
    assert np.abs(df.j0 - ref.y[0]).max() < 1e-8
    # double: two point masses at the ends of unit links; absolute angles φ1 = θ1, φ2 = θ1 + θ2
    m2 = pendulum_chain(2)
    d2 = Dynamics(m2, gravity=(0, -G, 0))
    m1_, m2_ = 1.0, 1.5
    d2.add_body("l0", m1_, (1, 0, 0))
    d2.add_body("l1", m2_, (2, 0, 0))

    def rhs(t, y):
        p1, p2, w1, w2 = y
        # Lagrange for point masses, angles from +x, gravity −y, unit lengths
        M = np.array([[m1_ + m2_, m2_ * np.cos(p1 - p2)], [m2_ * np.cos(p1 - p2), m2_]])
        f = np.array([-m2_ * np.sin(p1 - p2) * w2 ** 2 - (m1_ + m2_) * G * np.cos(p1),
                      m2_ * np.sin(p1 - p2) * w1 ** 2 - m2_ * G * np.cos(p2)])
        a = np.linalg.solve(M, f)
        return [w1, w2, a[0], a[1]]

    x0, xd0 = [0.2, 0.4], [0.0, -0.3]
    df2 = d2.simulate((0, 2), x0, xd0, t_eval=np.linspace(0, 2, 21))
    ref2 = solve_ivp(rhs, (0, 2), [0.2, 0.6, 0.0, -0.3], t_eval=np.linspace(0, 2, 21),
                     rtol=1e-12, atol=1e-12, method="DOP853")
    assert np.abs(df2.j0 - ref2.y[0]).max() < 1e-8
    assert np.abs(df2.j0 + df2.j1 - ref2.y[1]).max() < 1e-8


def fourbar_model(geom, masses, t20):
    m, (t30, t40) = fourbar(**geom, t2_0=t20)
    d = Dynamics(m, gravity=(0, -G, 0))
    a, b, c, dd = geom["a"], geom["b"], geom["c"], geom["d"]
    B0 = a * np.array([np.cos(t20), np.sin(t20), 0])
    u2 = np.array([np.cos(t20), np.sin(t20), 0])
    u3 = np.array([np.cos(t30), np.sin(t30), 0])
    u4 = np.array([np.cos(t40), np.sin(t40), 0])
    d.add_body("crank", masses[0], a / 2 * u2, rod_inertia(masses[0], a, u2))
    d.add_body("coupler", masses[1], B0 + b / 2 * u3, rod_inertia(masses[1], b, u3))
    d.add_body("rocker", masses[2], np.array([dd, 0, 0]) + c / 2 * u4,
               rod_inertia(masses[2], c, u4))
    return m, d


GEOM = dict(a=1.0, b=3.0, c=2.5, d=3.2)
MASSES = (1.0, 3.0, 2.5)


def test_fourbar_under_gravity_against_independent_reference():
    t20 = 0.3
    _, d = fourbar_model(GEOM, MASSES, t20)
    t = np.linspace(0, 2, 41)
    df = d.simulate((0, 2), [0.0], [0.0], t_eval=t)
    acc = fourbar_rod_reference(GEOM, MASSES, t20, g=G)
    ref = solve_ivp(lambda t, y: [y[1], acc(y[0], y[1])], (0, 2), [t20, 0.0], t_eval=t,
                    rtol=1e-12, atol=1e-12, method="DOP853")
    assert np.abs(t20 + df.A - ref.y[0]).max() < 1e-6
    assert df.residual.max() < 1e-12


def test_energy_conserved_and_dissipation_balanced():
    _, d = fourbar_model(GEOM, MASSES, 0.3)
    # 4 s: the crank swings through more than half a turn and back under gravity
    df = d.simulate((0, 4), [0.0], [1.0], t_eval=np.linspace(0, 4, 41), rtol=1e-12, atol=1e-12)
    assert np.ptp(df.A) > 3.0
    assert np.abs(df.energy - df.energy[0]).max() / abs(df.energy[0]) < 1e-8
    _, d2 = fourbar_model(GEOM, MASSES, 0.3)
    d2.add_damper("C", 0.8)
    d2.add_spring("D", 5.0, free=0.1)
    df2 = d2.simulate((0, 2), [0.0], [1.0], t_eval=np.linspace(0, 2, 21), rtol=1e-12, atol=1e-12)
    assert df2.dissipated.iloc[-1] > 0.05 * abs(df2.energy[0] - df2.potential[0]) or \
        df2.dissipated.iloc[-1] > 1e-3
    assert (np.diff(df2.energy) <= 1e-9).all()                    # energy only decreases
    assert np.abs(df2.balance).max() < 1e-8 * max(1.0, abs(df2.energy[0]))


def test_inverse_and_forward_agree():
    _, d = fourbar_model(GEOM, MASSES, 0.3)
    d.add_damper("B", 0.3)
    law = lambda t: (0.4 * np.sin(2 * t), 0.8 * np.cos(2 * t), -1.6 * np.sin(2 * t))

    def drive(t, x, xd):
        return d.inverse(np.array([t]), lambda tt: tuple(np.reshape(v, (-1, 1)) for v in law(tt)))[
            "drive:A"].to_numpy()

    t = np.linspace(0, 1.5, 16)
    inv = d.inverse(t, lambda tt: tuple(np.reshape(v, (-1, 1)) for v in law(tt)))
    assert "drive:A" in inv and inv.residual.max() < 1e-12
    fwd = d.simulate((0, 1.5), [0.0], [0.8], t_eval=t, drive=drive, rtol=1e-11, atol=1e-12)
    assert np.abs(fwd.A - law(t)[0]).max() < 1e-7


def test_oscillating_cylinder_drive_force_is_seed_formula():
    from approx import cylinder as cy
    m = cy.mechanism()
    d = Dynamics(m, gravity=(0, 0, 0))
    C = m.joint("C").frame_a[:3, 3]                  # the rocker tip, at L3 = B3 from A
    d.add_body("rocker", cy.M3, C)
    t = np.linspace(0, cy.TAU, 51)
    q, qd, qdd = cy.drive_law(t)
    inv = d.inverse(t, q[:, None], qd[:, None], qdd[:, None])
    q3dd = cy.psi31(q) * qdd + cy.dpsi31(q) * qd ** 2
    Q1 = cy.psi31(q) * cy.M3 * cy.B3 ** 2 * q3dd
    assert np.abs(inv["drive:slide"] - Q1).max() < 1e-9 * np.abs(Q1).max()


def test_parallelogram_through_flat_position_stays_on_branch():
    # a parallelogram: crank = rocker = 1, coupler = ground = 2
    t20 = 0.5
    m = Mechanism(["crank", "coupler", "rocker"])
    P = {"A": (0, 0, 0), "B": (np.cos(t20), np.sin(t20), 0),
         "C": (2 + np.cos(t20), np.sin(t20), 0), "D": (2, 0, 0)}
    for name, la, lb in [("A", "ground", "crank"), ("B", "crank", "coupler"),
                         ("C", "coupler", "rocker"), ("D", "ground", "rocker")]:
        m.add_joint(name, "R", la, lb, at=translation(P[name]))
    m.add_input("A")
    d = Dynamics(m, gravity=(0, -G, 0))
    u = np.array([np.cos(t20), np.sin(t20), 0])
    d.add_body("crank", 1.0, u / 2, rod_inertia(1.0, 1.0, u))
    d.add_body("coupler", 2.0, np.array(P["B"]) + [1, 0, 0], rod_inertia(2.0, 2.0, [1, 0, 0]))
    d.add_body("rocker", 1.0, np.array(P["D"]) + u / 2, rod_inertia(1.0, 1.0, u))
    df = d.simulate((0, 1.2), [0.0], [0.0], t_eval=np.linspace(0, 1.2, 61),
                    stop_at_dead_point=False, rtol=1e-10, atol=1e-12)
    th = t20 + df.A
    assert th.min() < -0.5                         # it swung through the flat position θ = 0
    # parallelogram branch: the coupler stays parallel to the ground (θ3 = 0), θ4 = θ2
    assert np.abs(df.A + df["q:B"]).max() < 1e-8
    assert np.abs(df["q:D"] - df.A).max() < 1e-8
    assert np.abs(df.balance).max() < 1e-6 * abs(df.energy[0]) + 1e-9
    # the trajectory crossed the flat position θ2 = 0, where the loop Jacobian is singular
    assert (th > 0).any() and (th < 0).any()
    flat = m.solve(-t20, raise_on_failure=False)
    assert flat.condition[0] > 1e7 and flat.status_text[0] == "near-singular"


def _load_example(name):
    import importlib.util
    import pathlib
    spec = importlib.util.spec_from_file_location(
        name, pathlib.Path(__file__).parents[2] / "examples" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_crane_two_loops_two_dof_inverse_forward_and_energy():
    cr = _load_example("crane")
    d = cr.dynamics()
    assert d.m.n_loops == 2 and d.m.mobility == 2
    law = cr.lifting_motion

    def drive(t, x, xd):
        return d.inverse(np.array([t]), law).iloc[0][["drive:stroke1", "drive:stroke2"]] \
            .to_numpy(float)

    t = np.linspace(0, 1.0, 6)
    fwd = d.simulate((0, 1.0), [0.0, 0.0], [0.0, 0.0], t_eval=t, drive=drive, rtol=1e-10,
                     atol=1e-12)
    x_ref = law(t)[0]
    assert np.abs(fwd[["stroke1", "stroke2"]].to_numpy() - x_ref).max() < 1e-7
    assert np.abs(fwd.balance).max() < 1e-6 * abs(fwd.energy[0])


def test_stiff_method_on_the_pendulum():
    # a stiff (implicit) scipy method on the simple pendulum (the dead-point event of a
    # four-bar driven into its toggle: test_dynamics_branches.test_toggle_still_stops_...)
    m = pendulum_chain(1)
    d = Dynamics(m, gravity=(0, -G, 0))
    d.add_body("l0", 2.0, (1, 0, 0))
    t = np.linspace(0, 1, 11)
    df = d.simulate((0, 1), [0.3], [0.5], t_eval=t, method="Radau", rtol=1e-10, atol=1e-12)
    ref = solve_ivp(lambda t, y: [y[1], -G * np.cos(y[0])], (0, 1), [0.3, 0.5], t_eval=t,
                    rtol=1e-12, atol=1e-12, method="DOP853")
    assert np.abs(df.j0 - ref.y[0]).max() < 1e-7


def test_given_joint_force_work_enters_the_energy_balance():
    _, d = fourbar_model(GEOM, MASSES, 0.3)
    d.add_force("A", lambda t, q, qd: 5.0 + 0 * q)           # a constant crank torque
    d.add_damper("C", 0.5)
    df = d.simulate((0, 1), [0.0], [0.0], t_eval=np.linspace(0, 1, 5), rtol=1e-11, atol=1e-12)
    assert abs(df.work.iloc[-1]) > 1.0 and df.dissipated.iloc[-1] > 0.1
    assert np.abs(df.balance).max() < 1e-8 * max(1.0, np.abs(df.energy).max())
