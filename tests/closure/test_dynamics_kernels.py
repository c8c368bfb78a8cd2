"""The compiled dynamics kernels (closure.dynamics_kernels) against the numpy formulation they
replaced (spatial inertias about the world origin, the engine's second analogs), against
finite differences of the energies, and forward dynamics against the closed-form four-bar."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from closure import Dynamics, Mechanism, frame_from_points, translation
from closure import dynamics_kernels as dk
from closure.forward import _rhs
from closure.frames import _cross, skew
from closure.integrate import RHS_COND, PoseTracker, solve_along
from closure.kinematics import _bias, analogs, link_twists
from closure.solver import SolverOptions
from linkwright.examples import crane as cr
from linkwright.references import fourbar, fourbar_rod_reference

G = 9.81
GEOM = dict(a=1.0, b=3.0, c=2.5, d=3.2)
MASSES = (1.0, 3.0, 2.5)


# ---------------------------------------------------------------------- the reference
def numpy_terms(d, pose, xd, t=0.0):
    """M, h, Q, q̇ by the numpy formulation the kernels replaced: link twists from the
    first and second analogs of closure.kinematics, world spatial inertias Λ about the
    origin, ``M = Σ Γᵀ Λ Γ``, ``h = Σ Γᵀ (Λ a + V ×* Λ V)``, gravity ``Σ Γᵀ (f, c × f)``."""
    mech = d.m
    B = len(pose)
    xd = np.broadcast_to(np.asarray(xd, float), (B, len(mech.inputs)))
    ks = pose.kinematics()
    first, second = analogs(mech, pose, ks=ks)
    n = first.shape[2]
    qd = np.einsum("bci,bi->bc", first, xd)
    M, h, Q = np.zeros((B, n, n)), np.zeros((B, n)), np.zeros((B, n))
    if d.bodies:
        li = [mech.links.index(b.link) for b in d.bodies]
        Gam = np.stack([link_twists(mech, ks, first[:, :, i])[:, li] for i in range(n)], -1)
        qdd0 = np.einsum("bcij,bi,bj->bc", second, xd, xd)
        acc0 = (link_twists(mech, ks, qdd0)
                + np.einsum("lc,bcs->bls", mech.tree.path_sign, _bias(mech, ks, qd, qd)))[:, li]
        V = np.einsum("bksi,bi->bks", Gam, xd)
        A = ks.link[:, li]
        R, p = A[..., :3, :3], A[..., :3, 3]
        m = np.array([b.mass for b in d.bodies])
        c = np.einsum("bkij,kj->bki", R, np.array([b.com for b in d.bodies])) + p
        Ic = np.einsum("bkij,kjl,bkml->bkim", R, np.array([b.inertia for b in d.bodies]), R)
        C = skew(c)
        Lam = np.zeros(A.shape[:2] + (6, 6))
        Lam[..., :3, :3] = m[:, None, None] * np.eye(3)
        Lam[..., :3, 3:] = -m[:, None, None] * C
        Lam[..., 3:, :3] = m[:, None, None] * C
        Lam[..., 3:, 3:] = Ic - m[:, None, None] * (C @ C)
        LV = np.einsum("bkst,bkt->bks", Lam, V)
        w, v = V[..., 3:], V[..., :3]
        cross_star = np.concatenate([_cross(w, LV[..., :3]),
                                     _cross(v, LV[..., :3]) + _cross(w, LV[..., 3:])], -1)
        M = np.einsum("bksi,bkst,bktj->bij", Gam, Lam, Gam)
        h = np.einsum("bksi,bks->bi", Gam, np.einsum("bkst,bkt->bks", Lam, acc0) + cross_star)
        f = np.broadcast_to(m[None, :, None] * d.gravity, c.shape)
        Q += np.einsum("bksi,bks->bi", Gam, np.concatenate([f, _cross(c, f)], -1))
    for e in d.elements:
        q = pose.q[:, e.qcolumn]
        if e.kind == "spring":
            tau = -e.value * (q - e.free)
        elif e.kind == "damper":
            tau = -e.value * qd[:, e.column]
        else:
            tau = np.broadcast_to(np.asarray(e.value(t, q, qd[:, e.column]), float), (B,))
        Q += first[:, e.column, :] * tau[:, None]
    return M, h, Q, qd


# ---------------------------------------------------------------------- models
def rod(m, L, u):
    u = np.asarray(u, float) / np.linalg.norm(u)
    return m * L * L / 12 * (np.eye(3) - np.outer(u, u))


def fourbar_dynamics(shift=None):
    t20 = 0.3
    m, (t30, t40) = fourbar(**GEOM, t2_0=t20, origin_shift=shift)
    S = np.eye(4) if shift is None else shift
    R, s = S[:3, :3], S[:3, 3]
    d = Dynamics(m, gravity=R @ np.array([0, -G, 0]))
    a, b, c, dd = GEOM["a"], GEOM["b"], GEOM["c"], GEOM["d"]
    u2, u3, u4 = (np.array([np.cos(v), np.sin(v), 0]) for v in (t20, t30, t40))
    for link, mass, com, L, u in (("crank", MASSES[0], a / 2 * u2, a, u2),
                                  ("coupler", MASSES[1], a * u2 + b / 2 * u3, b, u3),
                                  ("rocker", MASSES[2], np.array([dd, 0, 0]) + c / 2 * u4, c, u4)):
        d.add_body(link, mass, R @ com + s, R @ rod(mass, L, u) @ R.T)
    return d


def _frame(o, z, x):
    o = np.array(o, float)
    return frame_from_points(o, o + np.array(x, float), o + np.array(z, float))


def rucc_dynamics():
    """A spatial R–U–C–C loop: a Hooke joint, cylindrical joints (one a chord), a spring on
    the chord's slide, a damper and a given force."""
    m = Mechanism(["crank", "coupler", "follower"])
    m.add_joint("A", "R", "ground", "crank", at=_frame((0, 0, 0), (0, 0, 1), (1, 0, 0)))
    m.add_joint("B", "U", "crank", "coupler", at=_frame((1, 0, 0.2), (0, 0, 1), (0, 1, 0)))
    m.add_joint("C", "C", "coupler", "follower", at=_frame((1.6, 1.2, 0.5), (1, 0.2, 0.3),
                                                          (0, 1, 0)))
    m.add_joint("D", "C", "follower", "ground", at=_frame((2.5, 0.3, 0.1), (0.2, 0.1, 1),
                                                         (1, 0, -0.2)))
    m.add_input("A")
    d = Dynamics(m, gravity=(0.5, -9.81, 1.0))
    for k, (link, c) in enumerate((("crank", (0.5, 0, 0.1)), ("coupler", (1.3, 0.6, 0.35)),
                                   ("follower", (2.0, 0.7, 0.3)))):
        d.add_body(link, 1.0 + k, c, np.diag([0.02, 0.03, 0.04]) * (1 + k))
    d.add_spring("C", 40.0, free=0.1, index=1)
    d.add_damper("D", 0.7)
    d.add_force("B", lambda t, q, qd: 0.3 - q + 0.1 * qd, index=1)
    return d


def rssr_dynamics():
    """A spatial R–S–S–R loop: spherical joints (rotation states), the coupler's idle spin
    about the S–S line (the analogs' truncated SVD), a spring and a damper."""
    m = Mechanism(["crank", "coupler", "rocker"])
    m.add_joint("A", "R", "ground", "crank", at=_frame((0, 0, 0), (0, 0, 1), (1, 0, 0)))
    m.add_joint("B", "S", "crank", "coupler", at=translation((1.0, 0.0, 0.2)))
    m.add_joint("C", "S", "coupler", "rocker", at=translation((2.4, 1.6, 0.9)))
    m.add_joint("D", "R", "rocker", "ground", at=_frame((3.0, 1.0, 0.0), (0.3, 1.0, 0.5),
                                                       (1, -0.3, 0)))
    m.add_input("A")
    d = Dynamics(m, gravity=(0, 0, -G))
    d.add_body("crank", 1.0, (0.5, 0, 0.1), rod(1.0, 1.0, (1, 0, 0.2)))
    d.add_body("coupler", 2.0, (1.7, 0.8, 0.55), rod(2.0, 2.2, (1.4, 1.6, 0.7)) +
               0.01 * np.eye(3))
    d.add_body("rocker", 1.5, (2.7, 1.3, 0.45), rod(1.5, 1.2, (-0.6, 0.6, 0.9)))
    d.add_spring("D", 3.0, free=-0.2)
    d.add_damper("A", 0.4)
    return d


def crane_dynamics():
    d = cr.dynamics()
    d.add_spring("stroke2", 2e3, free=0.05)
    return d


FAR = translation((1.0e3, -2.0e3, 5.0e2)) @ _frame((0, 0, 0), (0.2, 0.3, 1.0), (1, -0.1, 0))

MODELS = {
    "fourbar": (fourbar_dynamics, np.linspace(-0.8, 2.0, 5)[:, None]),
    "fourbar far from the origin": (lambda: fourbar_dynamics(FAR),
                                    np.linspace(-0.8, 2.0, 5)[:, None]),
    "rucc": (rucc_dynamics, np.linspace(-0.5, 0.5, 5)[:, None]),
    "rssr": (rssr_dynamics, np.linspace(0.05, 1.25, 5)[:, None]),
    "crane": (crane_dynamics, np.c_[np.linspace(-0.05, 0.3, 5), np.linspace(0.17, -0.05, 5)]),
}


@pytest.fixture(scope="module", params=list(MODELS))
def model(request):
    make, X = MODELS[request.param]
    d = make()
    pose = d.m.solve(X)
    assert pose.ok.all()
    rng = np.random.default_rng(3)
    XD = rng.normal(size=X.shape)
    return request.param, d, pose, X, XD


# ---------------------------------------------------------------------- the terms
def test_terms_equal_the_numpy_formulation(model):
    name, d, pose, X, XD = model
    got = d.terms(pose, XD, t=0.4)
    want = numpy_terms(d, pose, XD, t=0.4)
    # the reference's spatial inertias about the world origin lose digits like the model's
    # offset from it (1 + |centre| / scale: about 700 far from the origin)
    tol = 1e-10 * d.m.plan.offset
    for g, w, what in zip(got, want, ("M", "h", "Q", "qd")):
        assert g.shape == w.shape, what
        assert np.abs(g - w).max() <= tol * max(np.abs(w).max(), 1.0), (name, what)
    M = got[0]
    assert np.allclose(M, np.swapaxes(M, 1, 2), rtol=0, atol=1e-13 * np.abs(M).max())
    assert (np.linalg.eigvalsh(M) > 0).all()


def test_energy_equals_the_mass_matrix_and_the_potentials(model):
    name, d, pose, X, XD = model
    en = d.energy(pose, XD)
    M = numpy_terms(d, pose, XD)[0]
    off = d.m.plan.offset               # the reference's digits lost to the world origin
    assert np.allclose(en["kinetic"], 0.5 * np.einsum("bi,bij,bj->b", XD, M, XD),
                       rtol=1e-11 * off, atol=1e-12)
    ks = d.m.kinematic_state(pose.state, twists=False)
    Vg = np.zeros(len(pose))
    for b in d.bodies:
        A = ks.link[:, d.m.links.index(b.link)]
        Vg -= b.mass * (A[:, :3, :3] @ b.com + A[:, :3, 3]) @ d.gravity
    assert np.allclose(en["gravity"], Vg, rtol=1e-12, atol=1e-9)
    Vs = sum(0.5 * e.value * (pose.q[:, e.qcolumn] - e.free) ** 2
             for e in d.elements if e.kind == "spring") + np.zeros(len(pose))
    assert np.allclose(en["spring"], Vs, rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("name", ["fourbar", "rssr", "crane"])
def test_terms_against_finite_differences_of_the_energies(name):
    # Lagrange: h_i = Σ_jk ∂_k M_ij ẋ_j ẋ_k − ½ Σ_jk ∂_i M_jk ẋ_j ẋ_k, and without dampers
    # and given forces Q = −∂(V_gravity + V_spring)/∂x; derivatives along the branch
    make, X = MODELS[name]
    d = make()
    d.elements = [e for e in d.elements if e.kind == "spring"]
    m = d.m
    x = X[1]
    n = x.size
    pose = m.solve(x[None])
    xd = np.linspace(0.7, -1.1, n)
    M, h, Q, _ = d.terms(pose, xd)
    delta = 1e-5 * m.plan.input_scale
    dM, dV = np.zeros((n, n, n)), np.zeros(n)
    for k in range(n):
        e = np.zeros(n)
        e[k] = delta[k]
        side = []
        for s in (1, -1):
            p = m.solve((x + s * e)[None], guess=pose)
            en = d.energy(p, xd)
            side.append((d.terms(p, xd)[0][0], en["gravity"][0] + en["spring"][0]))
        dM[:, :, k] = (side[0][0] - side[1][0]) / (2 * delta[k])
        dV[k] = (side[0][1] - side[1][1]) / (2 * delta[k])
    h_fd = np.einsum("ijk,j,k->i", dM, xd, xd) - 0.5 * np.einsum("jki,j,k->i", dM, xd, xd)
    scale = np.abs(M).max() * np.abs(xd).max() ** 2 / min(m.plan.input_scale)
    assert np.abs(h[0] - h_fd).max() <= 1e-6 * scale
    assert np.abs(Q[0] + dV).max() <= 1e-6 * max(np.abs(dV).max(), 1.0)


def test_far_from_the_origin_the_terms_are_those_at_the_origin():
    # the bodies' terms are taken about their centres of mass: a model 2 km from the world
    # origin keeps them to ~1e-12 (the former spatial inertias about the origin, ~3e-10)
    X = MODELS["fourbar"][1]
    d0, d1 = fourbar_dynamics(), fourbar_dynamics(FAR)
    XD = np.linspace(-1.0, 2.0, len(X))[:, None]
    a = d0.terms(d0.m.solve(X), XD)
    b = d1.terms(d1.m.solve(X), XD)
    for g, w in zip(b[:3], a[:3]):
        assert np.abs(g - w).max() <= 1e-11 * np.abs(w).max()


# ---------------------------------------------------------------------- forward dynamics
def test_right_hand_side_is_the_terms_at_the_tracked_pose():
    # one RHS call: the pose solved from the tracker's predictor, the kernel's M⁻¹ (Q − h)
    # plus drives and given forces, and the energy rates, against the terms at that pose
    d = rucc_dynamics()
    m = d.m
    opts = SolverOptions()
    start = m.solve([0.1])
    start.scalar = False
    drive = lambda t, x, xd: np.array([0.2 - 0.5 * xd[0]])
    tracker = PoseTracker(m, start, opts, np.ones(1), dynamics=d._packed()[1:])
    rhs = _rhs(d, tracker, drive, opts)
    for x, xd, t in ((0.13, 0.7, 0.1), (0.18, -0.4, 0.2), (0.11, 1.3, 0.3)):
        y = np.array([x, xd, 0.0, 0.0])
        base, tangent = tracker.pose, tracker.first.copy()
        out = rhs(t, y)
        p = tracker.pose
        want = solve_along(m, base, tangent, np.array([[x]]), opts)
        assert np.abs(p.q - want.q).max() < 1e-12 and p.residual[0] < 1e-12
        M, h, Q, qd = d.terms(p, [xd], t)
        tau = drive(t, [x], [xd])
        assert out[0] == xd
        assert np.isclose(out[1], np.linalg.solve(M[0], Q[0] - h[0] + tau)[0], rtol=1e-12)
        damper = next(e for e in d.elements if e.kind == "damper")
        force = next(e for e in d.elements if e.kind == "force")
        assert np.isclose(out[2], damper.value * qd[0, damper.column] ** 2, rtol=1e-12)
        fq = force.value(t, p.q[:, force.qcolumn], qd[:, force.column])[0]
        assert np.isclose(out[3], fq * qd[0, force.column] + tau[0] * xd, rtol=1e-12)
        assert np.allclose(tracker.first, analogs(m, p, second=False)[0][0], rtol=1e-12,
                           atol=1e-14)


def test_near_singular_poses_are_left_to_the_limit_along_the_branch():
    # a parallelogram near its flat position: the kernel reports the pose as singular
    # (condition above RHS_COND), the pose-by-pose path evaluates it, the run crosses it
    m = Mechanism(["crank", "coupler", "rocker"])
    P = {"A": (0, 0, 0), "B": (1, 0, 0), "C": (3, 0, 0), "D": (2, 0, 0)}
    for name, la, lb in [("A", "ground", "crank"), ("B", "crank", "coupler"),
                         ("C", "coupler", "rocker"), ("D", "ground", "rocker")]:
        m.add_joint(name, "R", la, lb, at=translation(P[name]))
    m.add_input("A")
    d = Dynamics(m, gravity=(0, -G, 0))
    d.add_body("crank", 1.0, (0.5, 0, 0), rod(1.0, 1.0, (1, 0, 0)))
    d.add_body("coupler", 2.0, (2, 0, 0), rod(2.0, 2.0, (1, 0, 0)))
    d.add_body("rocker", 1.0, (2.5, 0, 0), rod(1.0, 1.0, (1, 0, 0)))
    opts = SolverOptions()
    start = m.solve([0.3])
    start.scalar = False
    tracker = PoseTracker(m, start, opts, -np.ones(1), dynamics=d._packed()[1:])
    for x in (0.2, 0.1, 0.05, 0.02):
        tracker.at(np.array([x]))
    assert tracker.solve(dk.RHS, np.array([1e-6, -1.0, 0, 0])) == dk.SINGULAR
    assert tracker.pose.condition[0] > RHS_COND
    df = d.simulate((0, 0.6), [0.3], [0.0], t_eval=np.linspace(0, 0.6, 13), rtol=1e-10,
                    atol=1e-12, stop_at_dead_point=False)
    assert df.A.min() < 0 < df.A.max()
    assert np.abs(df.A + df["q:B"]).max() < 1e-8                # parallelogram branch
    assert np.abs(df.balance).max() < 1e-8 * abs(df.energy[0]) + 1e-9


def test_simulated_fourbar_against_the_closed_form_reference():
    t20 = 0.3
    d = fourbar_dynamics()
    acc = fourbar_rod_reference(GEOM, MASSES, t20, g=G)
    t = np.linspace(0, 1.0, 31)
    strict = solve_ivp(lambda tt, y: [y[1], acc(y[0], y[1])], (0, 1.0), [t20, 0.0], t_eval=t,
                       rtol=1e-13, atol=1e-14, method="DOP853")
    for rtol, err_max, balance_max in ((1e-8, 1e-8, 1e-6), (1e-11, 2e-10, 1e-8)):
        df = d.simulate((0, 1.0), [0.0], [0.0], t_eval=t, rtol=rtol, atol=rtol * 1e-2)
        ref = solve_ivp(lambda tt, y: [y[1], acc(y[0], y[1])], (0, 1.0), [t20, 0.0],
                        t_eval=t, rtol=rtol, atol=rtol * 1e-2, method="DOP853")
        err = np.abs(t20 + df.A - strict.y[0]).max()
        assert err < err_max
        assert err < 20 * np.abs(ref.y[0] - strict.y[0]).max()    # the model's own error
        assert np.abs(df.balance).max() < balance_max
        assert df.residual.max() < 1e-12 and (df.flag == "").all()


def _predicted(mem, y):
    """Task PREDICT of member 0 of ``mem`` (a batch of one) at the state ``y``: the
    predicted coordinates (nq,)."""
    nq = mem.bq.shape[1]
    q, rot = np.zeros((1, nq)), np.zeros((1,) + mem.brot.shape[1:])
    dk.step(dk.PREDICT, *mem._stage_head, q, rot, np.zeros((0, 0, 4, 4)),
            np.zeros((0, 0, 6)), np.zeros(0), np.zeros(0), np.zeros(0, dtype=np.int64),
            np.zeros(0, dtype=np.int64), mem.bq[0], mem.brot[0], mem.bx[0], mem.tangent[0],
            y, mem.buf)
    return q[0]


@pytest.mark.parametrize("third", [True, False])
def test_the_predictor_is_fourth_order_with_its_third_order_term(third):
    """Two right-hand sides at x1 = x2 − H and x2, then the prediction at x2 + Δ against the
    solved pose there: error O(Δ⁴) for H = Δ (third-order term from the two poses' second
    analogs), O(Δ³) without it (the block's earlier base forgotten)."""
    from closure.batch_dynamics import _Members
    d = fourbar_dynamics()
    x2, rate = 0.4, 1.3
    errors = []
    for D in (0.08, 0.04, 0.02, 0.01):
        start = d.m.solve(np.array([[x2 - 2 * D]]))
        mem = _Members(d, start, np.array([True]), np.array([[rate]]), SolverOptions())
        for x in (x2 - D, x2):                           # the stages: the bases there
            y = np.array([x, rate, 0.0, 0.0])
            assert mem.solve(np.zeros(1, dtype=np.int64), y, np.zeros(1)) == 0
        if not third:
            mem.buf[mem.layout["px"]] = np.nan
        q = _predicted(mem, np.array([x2 + D, rate, 0.0, 0.0]))
        errors.append(np.abs(q - d.m.solve(np.array([[x2 + D]])).q[0]).max())
    order = np.log2(np.array(errors[:-1]) / errors[1:])
    if third:
        assert np.all(order > 3.6)
    else:
        assert np.all((order > 2.7) & (order < 3.3))
