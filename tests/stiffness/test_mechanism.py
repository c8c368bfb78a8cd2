"""Stiffness of mechanisms built in the closure engine, against independent references."""
import numpy as np
import pytest

from closure import Mechanism, exp_so3
from linkwright.references import axis_frame, ups_platform
from stiffness import Hexapod, SingularPoseError, StiffnessError, mechanism_map, of_mechanism

rng = np.random.default_rng(17)


frame = axis_frame
ups = ups_platform


A_ = np.radians([0, 100, 120, 220, 240, 340])
B_ = np.radians([40, 80, 160, 200, 280, 320])
BASE = np.c_[0.8 * np.cos(A_), 0.8 * np.sin(A_), np.zeros(6)]
PLAT = np.c_[0.4 * np.cos(B_), 0.4 * np.sin(B_), np.zeros(6)]
KLEG = np.array([1e7, 2e7, 1.5e7, 0.8e7, 1.2e7, 3e7])
T0 = np.eye(4)
T0[:3, :3] = exp_so3(np.r_[0.05, -0.1, 0.15])
T0[:3, 3] = [0.02, 0.01, 0.7]
SPRINGS = {f"P{i}": KLEG[i] for i in range(6)}


def rel(A, B):
    return np.abs(A - B).max() / np.abs(B).max()


def test_6ups_equals_hexapod_P_Ktheta_Pt_at_random_poses():
    hx = Hexapod(BASE, PLAT, KLEG)
    m = ups(BASE, PLAT, T0)
    pose = m.solve(rng.normal(size=(20, 6)) * 0.02)
    assert pose.ok.all()
    Ts = pose.link_frame("platform") @ T0                 # the hexapod's platform poses
    res = of_mechanism(m, pose, platform="platform", springs=SPRINGS)
    assert (res.rigid == 0).all() and res.elastic == [f"P{i}" for i in range(6)]
    assert len(res.passive) == 30 and res.locked == []
    for i in range(20):
        assert rel(res.K[i], hx.stiffness(Ts[i]).K) < 1e-10
        assert rel(res.C[i], hx.compliance(Ts[i])) < 1e-10
    # in the hexapod's platform frame
    R, p = T0[:3, :3].T, T0[:3, 3]
    one = of_mechanism(m, m.solve(np.zeros(6)), platform="platform", springs=SPRINGS,
                       frame=(R, p))
    assert rel(one.K[0], hx.stiffness(T0, frame="platform").K) < 1e-10


@pytest.mark.parametrize("far", [1e3, 1e5])
def test_origin_free_far_from_the_world_origin(far):
    """The whole model moved far away: the stiffness in a frame carried along is unchanged."""
    Q, s = exp_so3(np.r_[0.4, -0.9, 1.3]), far * np.r_[0.36, -0.48, 0.8]
    m0, m1 = ups(BASE, PLAT, T0), ups(BASE, PLAT, T0, Q, s)
    x = rng.normal(size=(5, 6)) * 0.02
    R, p = T0[:3, :3].T, T0[:3, 3]
    r0 = of_mechanism(m0, m0.solve(x), platform="platform", springs=SPRINGS, frame=(R, p))
    r1 = of_mechanism(m1, m1.solve(x), platform="platform", springs=SPRINGS,
                      frame=(R @ Q.T, Q @ p + s))
    assert rel(r1.K, r0.K) < 1e-9
    assert np.allclose(r1.condition, r0.condition, rtol=1e-6)


def test_locked_actuator_and_free_motion():
    m = ups(BASE, PLAT, T0)
    pose = m.solve(np.zeros(6))
    five = {f"P{i}": KLEG[i] for i in range(5)}
    res = of_mechanism(m, pose, platform="platform", springs=five)   # P5 locked by default
    assert res.locked == ["P5"] and res.rigid[0] == 1
    P = Hexapod(BASE, PLAT, KLEG).leg_matrix(T0)
    Pi = np.linalg.inv(P)
    C = Pi.T @ np.diag(np.r_[1 / KLEG[:5], 0]) @ Pi                   # leg 6 rigid
    assert rel(res.C[0], C) < 1e-10
    assert np.allclose(res.K[0] @ res.C[0] @ res.K[0], res.K[0], rtol=0,
                       atol=1e-9 * np.abs(res.K[0]).max())
    with pytest.raises(SingularPoseError, match="move without deforming any spring"):
        of_mechanism(m, pose, platform="platform", springs=five, locked=[])


def test_serial_6r_arm_is_J_inv_T_Ktheta_J_inv():
    names = [f"l{i}" for i in range(1, 7)]
    m = Mechanism(names)
    ats = []
    links = ["ground"] + names
    for i in range(6):
        at = frame(rng.normal(size=3), rng.normal(size=3), rng.normal(size=3))
        ats.append(at)
        m.add_joint(f"R{i}", "R", links[i], links[i + 1], at=at)
        m.add_input(f"R{i}")
    kt = rng.uniform(1e4, 1e5, 6)
    pose = m.solve(rng.normal(size=6))
    res = of_mechanism(m, pose, platform="l6", springs={f"R{i}": kt[i] for i in range(6)})
    # the arm's Jacobian from the world joint axes: column (p × ω, ω) about the world origin
    J = np.empty((6, 6))
    for i in range(6):
        F = pose.link_frame(links[i]) @ ats[i]
        w, p = F[:3, 2], F[:3, 3]
        J[:, i] = np.r_[np.cross(p, w), w]
    Ji = np.linalg.inv(J)
    assert rel(res.K[0], Ji.T @ np.diag(kt) @ Ji) < 1e-10


def planar_rpr(base, plat):
    """A planar 3-RPR (R at the base, P along the leg: the inputs, R at the platform; every
    axis along z) drawn with its legs from ``base`` to ``plat`` (3, 3)."""
    m = Mechanism([f"a{i}" for i in range(3)] + [f"b{i}" for i in range(3)] + ["platform"])
    for i in range(3):
        leg = plat[i] - base[i]
        m.add_joint(f"R{i}", "R", "ground", f"a{i}", at=frame([0, 0, 1], leg, base[i]))
        m.add_joint(f"P{i}", "P", f"a{i}", f"b{i}", at=frame(leg, [0, 0, 1], base[i]))
        m.add_joint(f"T{i}", "R", f"b{i}", "platform", at=frame([0, 0, 1], leg, plat[i]))
        m.add_input(f"P{i}")
    return m


def test_planar_3rpr_closed_form():
    """A planar 3-RPR with elastic legs: K on (x, y, θz) is Σ k pᵢ pᵢᵀ with pᵢ = (uᵢ, (rᵢ × uᵢ)_z);
    the other three directions are rigid."""
    base = np.array([[0, 0, 0], [2.0, 0, 0], [0.8, 1.9, 0]])
    plat = np.array([[0.7, 0.6, 0], [1.3, 0.5, 0], [1.0, 1.1, 0]])
    k = np.array([2e6, 3e6, 5e6])
    m = planar_rpr(base, plat)
    pose = m.solve(np.array([[0.0, 0, 0], [0.05, -0.03, 0.02]]))
    res = of_mechanism(m, pose, platform="platform", springs={f"P{i}": k[i] for i in range(3)})
    assert (res.rigid == 3).all()
    for b in range(2):
        Tp = pose.link_frame("platform")[b]
        r = plat @ Tp[:3, :3].T + Tp[:3, 3]
        u = r - base
        u /= np.linalg.norm(u, axis=1)[:, None]
        P = np.c_[u[:, 0], u[:, 1], np.cross(r, u)[:, 2]].T
        Kp = P @ np.diag(k) @ P.T
        sel = [0, 1, 5]
        assert rel(res.K[b][np.ix_(sel, sel)], Kp) < 1e-10
        others = np.ones((6, 6), bool)
        others[np.ix_(sel, sel)] = False
        assert np.abs(res.K[b][others]).max() < 1e-10 * np.abs(Kp).max()


_M = ups(BASE, PLAT, T0)
_POSE = _M.solve(np.zeros(6))
_GOOD = dict(mechanism=_M, pose=_POSE, platform="platform", springs=SPRINGS)


@pytest.mark.parametrize("change, arg", [
    (dict(mechanism="m"), "mechanism"), (dict(mechanism=None), "mechanism"),
    (dict(pose="pose"), "pose"), (dict(pose=ups(BASE, PLAT, T0).solve(np.zeros(6))), "pose"),
    (dict(platform="ground"), "platform"), (dict(platform=3), "platform"),
    (dict(platform="nowhere"), "platform"),
    (dict(springs={}), "springs"), (dict(springs=[1e6] * 6), "springs"),
    (dict(springs={"Q1": 1e6}), "springs"), (dict(springs={"P0": -1.0}), "springs['P0']"),
    (dict(springs={"P0": 0.0}), "springs['P0']"), (dict(springs={"P0": float("nan")}), "springs['P0']"),
    (dict(springs={"P0": float("inf")}), "springs['P0']"), (dict(springs={"P0": "1e6"}), "springs['P0']"),
    (dict(springs={"P0": 1e6 + 1j}), "springs['P0']"), (dict(springs={"P0": [1e6, 2e6]}), "springs['P0']"),
    (dict(springs={"U0": [[1e6, 1e5], [0, 1e6]]}), "springs['U0']"),
    (dict(springs={"U0": [[1e6, 2e6], [2e6, 1e6]]}), "springs['U0']"),
    (dict(springs={"U0.phi": 1e3, "U0": 1e3}), "springs"),
    (dict(locked=["P0"]), "locked"), (dict(locked=["nothing"]), "locked"),
    (dict(frame="tool"), "frame"), (dict(frame=(np.eye(3) * 1.01, np.zeros(3))), "frame R"),
    (dict(frame=(np.eye(3), np.array([0, np.nan, 0]))), "frame p"), (dict(frame=3), "frame"),
    (dict(wrench=[0, 0, np.nan, 0, 0, 0]), "wrench"), (dict(wrench=[1.0, 2, 3]), "wrench"),
    (dict(wrench="up"), "wrench"),
    (dict(wrench=np.zeros(6), link_springs=[("l0", "U0", np.eye(4), np.eye(6), -1.0)]),
     "link_springs[0]: length"),
    (dict(link_springs=[("l0", "U0", np.eye(4), np.eye(6), 1.0, 2.0)]), "link_springs[0]"),
])
def test_bad_arguments_are_named(change, arg):
    with pytest.raises(StiffnessError) as info:
        of_mechanism(**{**_GOOD, **change})
    assert arg in str(info.value), str(info.value)


def test_a_failed_pose_is_refused():
    bad = _M.solve(np.array([[0.0] * 6, [5.0] * 6]), raise_on_failure=False)
    assert (bad.status >= 2).any()
    with pytest.raises(SingularPoseError, match="pose index 1 is not solved"):
        of_mechanism(**{**_GOOD, "pose": bad})


def _three_legged(kind):
    """A 3-RPS (R at the base tangent to its circle, P along the leg, S at the platform) or a
    3-PRS (vertical actuated P, R tangent, a rigid leg, S), drawn symmetric at height 1; or a
    planar 3-RPR (R, P along the leg, R, all axes along z; the platform turned by 40°)."""
    ang = np.radians([90, 210, 330])
    radial = np.c_[np.cos(ang), np.sin(ang), np.zeros(3)]
    tangent = np.c_[-np.sin(ang), np.cos(ang), np.zeros(3)]
    base, plat = 1.0 * radial, 0.5 * radial + [0, 0, 1.0]
    if kind == "RPR":
        turned = np.radians([130, 250, 370])
        return planar_rpr(base, 0.5 * np.c_[np.cos(turned), np.sin(turned), np.zeros(3)])
    m = Mechanism([f"a{i}" for i in range(3)] + [f"b{i}" for i in range(3)] + ["platform"])
    for i in range(3):
        if kind == "RPS":
            leg = plat[i] - base[i]
            m.add_joint(f"R{i}", "R", "ground", f"a{i}", at=frame(tangent[i], leg, base[i]))
            m.add_joint(f"P{i}", "P", f"a{i}", f"b{i}", at=frame(leg, tangent[i], base[i]))
        else:                                     # slider at height 0.3 under the leg's R
            knee = base[i] + [0, 0, 0.3]
            m.add_joint(f"P{i}", "P", "ground", f"a{i}", at=frame([0, 0, 1], radial[i], base[i]))
            m.add_joint(f"R{i}", "R", f"a{i}", f"b{i}", at=frame(tangent[i], radial[i], knee))
        m.add_joint(f"S{i}", "S", f"b{i}", "platform", at=frame([0, 0, 1], [1, 0, 0], plat[i]))
        m.add_input(f"P{i}")
    return m


@pytest.mark.parametrize("kind, all_joints", [("RPS", True), ("RPS", False), ("PRS", False),
                                              ("RPR", False)])
def test_three_legged_against_fd_hessian_of_the_elastic_energy(kind, all_joints):
    """K of a 3-RPS / 3-PRS / planar 3-RPR against an independent reference built from the engine's solve
    only: the platform's motion and every joint's deflection as functions of the three inputs
    s (central differences of solved poses), the elastic energy's Hessian in s by second
    differences of U(s), and C = A H⁻¹ Aᵀ.  Three directions are rigid (the legs' joints
    allow only the 3-DOF motion)."""
    from closure import log_se3, log_so3
    m = _three_legged(kind)
    kP, kR, kS = 2e7, 3e4, np.array([1e4, 2e4, 1.5e4])
    springs = {f"P{i}": kP for i in range(3)}
    if all_joints:
        springs.update({f"R{i}": kR for i in range(3)})
        springs.update({f"S{i}": kS for i in range(3)})
    x0 = np.array([0.02, -0.03, 0.01])
    at = m.solve(x0)
    res = of_mechanism(m, at, platform="platform", springs=springs)
    assert res.rigid[0] == 3

    def deflections(poses):
        """Each spring's coordinate relative to its value at x0, (B, n)."""
        cols = []
        for i in range(3):
            cols.append(poses[f"P{i}"] - at[f"P{i}"])
            if all_joints:
                cols.append(poses[f"R{i}"] - at[f"R{i}"])
                Rr = np.swapaxes(at.rotation(f"S{i}"), -1, -2) @ poses.rotation(f"S{i}")
                cols.append(log_so3(Rr))
        return np.column_stack(cols)                     # (B,) and (B, 3) columns

    stiff = [kP] + ([kR, *kS] if all_joints else [])
    kvec = np.tile(stiff, 3)

    def energy(xs):
        poses = m.solve(xs)
        d = deflections(poses)
        return 0.5 * (d * d * kvec).sum(1)

    h = 1e-4
    E = np.eye(3) * h
    stencil = [x0 + a + b for a in (E[0], -E[0], E[1], -E[1], E[2], -E[2]) for b in
               (E[0], -E[0], E[1], -E[1], E[2], -E[2])]
    U = energy(np.array(stencil)).reshape(6, 6)
    H = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            H[i, j] = (U[2 * i, 2 * j] - U[2 * i, 2 * j + 1] - U[2 * i + 1, 2 * j]
                       + U[2 * i + 1, 2 * j + 1]) / (4 * h * h)
    hd = 1e-6
    Tp = m.solve(np.r_[x0 + np.eye(3) * hd, x0 - np.eye(3) * hd]).link_frame("platform")
    T0p = at.link_frame("platform")
    D = log_se3(Tp @ np.linalg.inv(T0p))                   # platform twists about the origin
    A = (D[:3] - D[3:]).T / (2 * hd)                       # (6, 3) dΔ/ds
    C_ref = A @ np.linalg.inv(H) @ A.T
    assert rel(res.C[0], C_ref) < 1e-6


def test_map_chunks_flags_and_matches_the_hexapod(monkeypatch):
    import stiffness.mechanism as sm
    hx = Hexapod(BASE, PLAT, KLEG)
    x = np.r_[rng.normal(size=(9, 6)) * 0.02, np.full((1, 6), 5.0)]    # the last cannot close
    pose = _M.solve(x, raise_on_failure=False)
    monkeypatch.setattr(sm, "MAP_CHUNK", 4)
    tcp = T0[:3, 3]                               # the platform centre at the assembly pose
    df = mechanism_map(_M, pose, platform="platform", springs=SPRINGS, point=tcp)
    assert list(df.columns[:6]) == [f"P{i}" for i in range(6)] and len(df) == 10
    assert df.ok[:9].all() and not df.ok[9] and np.isnan(df.ct_max[9])
    Ts = pose.link_frame("platform") @ T0
    for i in range(9):
        R, p = Ts[i, :3, :3].T, Ts[i, :3, 3]        # the hexapod's platform frame at its centre
        assert np.allclose(df[["x", "y", "z"]].iloc[i], p, rtol=0, atol=1e-12)
        C = hx.compliance(Ts[i])                 # its rotational block is the same about any point
        Cp = np.linalg.inv(hx.stiffness(Ts[i], frame=(R, p)).K)
        assert np.isclose(df.ct_max[i], np.linalg.eigvalsh(Cp[:3, :3])[-1], rtol=1e-9)
        assert np.isclose(df.cr_max[i], np.linalg.eigvalsh(C[3:, 3:])[-1], rtol=1e-9)
    monkeypatch.setattr(sm, "MAP_CHUNK", 2048)
    whole = mechanism_map(_M, pose, platform="platform", springs=SPRINGS, point=tcp)
    assert np.allclose(whole.ct_max[:9], df.ct_max[:9], rtol=1e-13)
    five = {f"P{i}": KLEG[i] for i in range(5)}
    loose = mechanism_map(_M, pose, platform="platform", springs=five, locked=[])
    assert loose.free[:9].all() and np.isinf(loose.ct_max[:9]).all()


@pytest.mark.parametrize("change, arg", [
    (dict(point=[0, np.nan, 0]), "point"), (dict(point=[0, 0]), "point"), (dict(point="tcp"), "point"),
    (dict(point=np.zeros((2, 3))), "point"), (dict(springs={"P0": -1}), "springs['P0']"),
    (dict(platform="l9"), "platform"), (dict(pose=None), "pose")])
def test_map_bad_arguments_are_named(change, arg):
    with pytest.raises(StiffnessError) as info:
        mechanism_map(**{**_GOOD, **change})
    assert arg in str(info.value), str(info.value)


W_LOAD = np.r_[300.0, -200, -5000, 400, 250, -100]     # N, N·m about the world origin


@pytest.mark.parametrize("which", ["base", "platform", "general"])
def test_loaded_6ups_equals_the_hexapods_loaded_stiffness(which):
    """The geometric term from the engine's twist brackets and loop wrenches equals the
    hexapod's closed form (itself checked against finite differences of the equilibrium)."""
    hx = Hexapod(BASE, PLAT, KLEG)
    pose = _M.solve(rng.normal(size=(4, 6)) * 0.02)
    Ts = pose.link_frame("platform") @ T0
    for i in range(4):
        if which == "base":
            f_hx, f_m = None, None
        elif which == "platform":
            f_hx = f_m = (Ts[i, :3, :3].T, Ts[i, :3, 3])
        else:
            f_hx = f_m = (exp_so3(rng.normal(size=3)), rng.normal(size=3))
        res = of_mechanism(_M, _M.solve(pose.inputs[i]), platform="platform", springs=SPRINGS,
                           frame=f_m, wrench=W_LOAD)
        ref = hx.loaded_stiffness(Ts[i], W_LOAD, frame=f_hx).K
        assert res.loaded and rel(res.K[0], ref) < 1e-10
        assert rel(res.C[0], np.linalg.inv(ref)) < 1e-9
    # the load's geometric term is really there: the unloaded K differs by more than 1e-5
    assert rel(hx.stiffness(Ts[0]).K, hx.loaded_stiffness(Ts[0], W_LOAD).K) > 1e-5


def test_loaded_3rps_against_fd_of_the_loaded_equilibrium():
    """A 3-RPS with elastic actuators under a load: the equilibrium is solved with the engine
    (spring forces k (s − s̄) balancing the load's generalized forces, found by Newton on
    central differences of solved poses), then a small extra wrench is added; the increment
    of the holding wrench about the carried point must equal K Δ on the compliant
    directions (rel. 1e-6)."""
    from closure import log_se3
    from stiffness import shift_wrench
    m = _three_legged("RPS")
    kP = 2e7
    springs = {f"P{i}": kP for i in range(3)}
    x_rest = np.array([0.02, -0.03, 0.01])
    c = m.solve(x_rest).link_frame("platform")[:3, 3] + [0.1, -0.05, 0.0]   # a platform point

    def twist_columns(s, h=1e-6):
        """d(platform twist about the world origin)/ds, (6, 3), central differences."""
        T = m.solve(np.r_[s + np.eye(3) * h, s - np.eye(3) * h]).link_frame("platform")
        D = log_se3(T @ np.linalg.inv(m.solve(s).link_frame("platform")))
        return (D[:3] - D[3:]).T / (2 * h)

    def equilibrium(W):
        s = x_rest.copy()
        for _ in range(8):                       # k (s − s̄) = A(s)ᵀ W, Newton with FD
            f = kP * (s - x_rest) - twist_columns(s).T @ W
            Jf = kP * np.eye(3) - np.stack([(twist_columns(s + e).T @ W
                                             - twist_columns(s - e).T @ W) / 2e-5
                                            for e in np.eye(3) * 1e-5], 1)
            s = s - np.linalg.solve(Jf, f)
        return s

    s0 = equilibrium(W_LOAD)
    assert np.abs(s0 - x_rest).max() > 1e-5                    # the load deflects the legs
    T_0 = m.solve(s0).link_frame("platform")
    res = of_mechanism(m, m.solve(s0), platform="platform", springs=springs, wrench=W_LOAD,
                       frame=(np.eye(3), c))                    # at the loaded pose
    unloaded = of_mechanism(m, m.solve(s0), platform="platform", springs=springs,
                            frame=(np.eye(3), c))
    assert res.rigid[0] == 3
    K = res.K[0]
    eps = 50.0
    worst_unloaded = 0.0
    for j in range(6):
        dW = np.eye(6)[j] * eps
        Tp = m.solve(equilibrium(W_LOAD + dW)).link_frame("platform")
        Tm = m.solve(equilibrium(W_LOAD - dW)).link_frame("platform")
        Dp, Dm = log_se3(Tp @ np.linalg.inv(T_0)), log_se3(Tm @ np.linalg.inv(T_0))
        V = (Dp - Dm) / 2                        # twist about the origin for +dW (first order)
        delta = np.r_[V[:3] + np.cross(V[3:], c), V[3:]]          # about the carried point
        dWc = shift_wrench(c) @ dW + np.r_[0, 0, 0, np.cross(delta[:3], -W_LOAD[:3])]
        # compare on the compliant directions: the load's part the springs feel
        err = K @ delta - K @ res.C[0] @ dWc
        assert np.abs(err).max() < 1e-6 * np.abs(dWc).max(), (j, err)
        e0 = unloaded.K[0] @ delta - unloaded.K[0] @ unloaded.C[0] @ (shift_wrench(c) @ dW)
        worst_unloaded = max(worst_unloaded, np.abs(e0).max() / np.abs(dWc).max())
    assert worst_unloaded > 1e-5                 # without the geometric term: 10x the tolerance
