import warnings

import numpy as np
import pandas as pd
import pytest

from closure import exp_so3, skew as skew_c
from stiffness import (Hexapod, SingularPoseWarning, StiffnessError, blocks, compose_frames,
                       from_blocks, transform_blocks,
                       design_leg_stiffness, from_moment_first, plucker, report,
                       rotate_six, screw_eigenvalues, shift_twist, shift_wrench,
                       spring_stiffness, stiffness_matrix, to_moment_first, transform_stiffness,
                       translational_eigenvalues, twist_transform, twist_transform_inverse,
                       wrench_transform, wrench_transform_inverse)

rng = np.random.default_rng(3)


def rand_frame():
    return exp_so3(rng.normal(size=3)), rng.normal(size=3)


def pose(rv, t):
    T = np.eye(4)
    T[:3, :3] = exp_so3(np.asarray(rv, float))
    T[:3, 3] = t
    return T


def general_hexapod(k=None):
    a = np.radians([0, 100, 120, 220, 240, 340])
    b = np.radians([40, 80, 160, 200, 280, 320])
    base = np.c_[0.8 * np.cos(a), 0.8 * np.sin(a), np.zeros(6)]
    plat = np.c_[0.4 * np.cos(b), 0.4 * np.sin(b), np.zeros(6)]
    return Hexapod(base, plat, k if k is not None else rng.uniform(5e6, 2e7, 6))


# ------------------------------------------------------------------ Table 1
def test_table1_transforms_and_work_invariance():
    R, p = rand_frame()
    T, Ts = wrench_transform(R, p), twist_transform(R, p)
    assert np.allclose(Ts.T @ T, np.eye(6), atol=1e-13)             # T*ᵀ T = E
    assert np.allclose(Ts, np.linalg.inv(T).T, atol=1e-13)           # T* = T⁻ᵀ
    assert np.allclose(T, rotate_six(R) @ shift_wrench(p), atol=1e-14)
    assert np.allclose(Ts, rotate_six(R) @ shift_twist(p), atol=1e-14)
    assert np.allclose(wrench_transform_inverse(R, p) @ T, np.eye(6), atol=1e-13)
    assert np.allclose(twist_transform_inverse(R, p) @ Ts, np.eye(6), atol=1e-13)
    W, D = rng.normal(size=6), rng.normal(size=6)
    assert np.isclose((Ts @ D) @ (T @ W), D @ W)                     # work is invariant
    # a force through a point: in the new frame it is the same force through r' = R(r − p)
    f, r = rng.normal(size=3), rng.normal(size=3)
    W = np.r_[f, np.cross(r, f)]
    assert np.allclose(T @ W, np.r_[R @ f, np.cross(R @ (r - p), R @ f)], atol=1e-13)
    # a small displacement: the new origin moves by δ + θ × p
    d, th = rng.normal(size=3), rng.normal(size=3)
    assert np.allclose(Ts @ np.r_[d, th], np.r_[R @ (d + np.cross(th, p)), R @ th], atol=1e-13)


def test_composition_of_successive_transforms():
    R1, p1 = rand_frame()
    R2, p2 = rand_frame()
    R, p = compose_frames(R1, p1, R2, p2)
    assert np.allclose(wrench_transform(R2, p2) @ wrench_transform(R1, p1),
                       wrench_transform(R, p), atol=1e-13)
    # check against point maps: r'' = R2 (R1 (r − p1) − p2)
    r = rng.normal(size=3)
    assert np.allclose(R2 @ (R1 @ (r - p1) - p2), R @ (r - p), atol=1e-13)


def test_moment_first_against_an_independent_adjoint():
    """Modern Robotics: for T_ab = (R, t), Ad = [[R, 0], [[t]R, R]] acts on (ω, v) twists.
    The seed's new frame is T_new_old = (R, −R p), so T* in moment-first order equals it."""
    R, p = rand_frame()
    t = -R @ p
    Ad = np.block([[R, np.zeros((3, 3))], [skew_c(t) @ R, R]])
    assert np.allclose(to_moment_first(twist_transform(R, p)), Ad, atol=1e-13)
    # wrenches (m, f) transform by Ad⁻ᵀ
    assert np.allclose(to_moment_first(wrench_transform(R, p)), np.linalg.inv(Ad).T, atol=1e-13)
    K = general_hexapod().stiffness(np.eye(4) @ pose([0, 0, 0], [0, 0, 0.7])).K
    Km = to_moment_first(K)
    assert np.allclose(from_moment_first(Km), K) and np.allclose(Km[:3, :3], K[3:, 3:])
    v = rng.normal(size=6)
    assert np.allclose(to_moment_first(v), np.r_[v[3:], v[:3]])


def test_formula_2_equals_P_diag_k_Pt_and_block_form_15():
    k = rng.uniform(1, 5, 7)
    a, r = rng.normal(size=(7, 3)), rng.normal(size=(7, 3))
    K = spring_stiffness(k, a, r)
    # formula (2) element by element, in a Python loop
    Rv = [np.r_[ai / np.linalg.norm(ai), np.cross(ri, ai / np.linalg.norm(ai))] for ai, ri in zip(a, r)]
    K2 = np.array([[sum(k[i] * Rv[i][j] * Rv[i][l] for i in range(7)) for l in range(6)]
                   for j in range(6)])
    assert np.allclose(K, K2, rtol=1e-13)
    # block form (15): the new blocks from the old ones equal T K Tᵀ
    R, p = rand_frame()
    Kp = transform_stiffness(K, R, p)
    for got, want in zip(transform_blocks(K, R, p), blocks(Kp)):
        assert np.allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(K).max())
    assert np.allclose(from_blocks(*blocks(K)), K)
    # recompute K from the springs written in the new frame: T K Tᵀ
    a2, r2 = (R @ a.T).T, (R @ (r - p).T).T
    assert np.allclose(spring_stiffness(k, a2, r2), Kp, rtol=1e-12, atol=1e-12 * np.abs(K).max())


# ------------------------------------------------------------------ hexapod
def test_cube_hexapod_diagonal_at_cube_centre():
    """Legs on the six cube edges that miss two opposite corners (side s, centre at the origin).
    By hand: each axis carries two legs → K_n = 2k I; leg moments about the centre give
    K_k = 2k h² [[2,1,1],[1,2,1],[1,1,2]] (h = s/2): eigenvalues 8kh² along the diagonal
    (1,1,1) and 2kh² across it, and K_c = 0.  In a frame with z along the diagonal:
    K = diag(2k, 2k, 2k, 2kh², 2kh², 8kh²)."""
    s, k = 0.6, 3.0e7
    h = s / 2
    base = [(h, h, -h), (h, -h, h), (h, -h, h), (-h, h, h), (-h, h, h), (h, h, -h)]
    plat = [(h, -h, -h), (h, -h, -h), (-h, -h, h), (-h, -h, h), (-h, h, -h), (-h, h, -h)]
    hx = Hexapod(base, plat, k)
    z = np.ones(3) / np.sqrt(3)
    x = np.array([1.0, -1, 0]) / np.sqrt(2)
    R = np.stack([x, np.cross(z, x), z])            # rows: new axes in base coordinates
    K = hx.stiffness(np.eye(4), frame=(R, np.zeros(3))).K
    expect = np.diag([2 * k, 2 * k, 2 * k, 2 * k * h * h, 2 * k * h * h, 8 * k * h * h])
    assert np.allclose(K, expect, rtol=1e-12, atol=1e-6)


def test_K_equals_fd_hessian_of_leg_energy_at_a_displaced_pose():
    hx = general_hexapod()
    T0 = pose([0.1, -0.05, 0.2], [0.03, -0.02, 0.65])
    L0, _ = hx.legs(T0)                                # free lengths: legs unstressed here

    def energy(D):
        T = T0.copy()
        T[:3, :3] = exp_so3(D[3:]) @ T0[:3, :3]
        T[:3, 3] = exp_so3(D[3:]) @ T0[:3, 3] + D[:3]
        L, _ = hx.legs(T)
        return 0.5 * np.sum(hx.k * (L - L0) ** 2)

    h = np.r_[1e-5 * np.ones(3), 1e-5 * np.ones(3)]
    H = np.zeros((6, 6))
    for i in range(6):
        for j in range(6):
            e_i, e_j = np.eye(6)[i] * h[i], np.eye(6)[j] * h[j]
            H[i, j] = (energy(e_i + e_j) - energy(e_i - e_j) - energy(-e_i + e_j)
                       + energy(-e_i - e_j)) / (4 * h[i] * h[j])
    K = hx.stiffness(T0).K
    assert np.abs(H - K).max() / np.abs(K).max() < 1e-6
    assert np.allclose(K, K.T) and np.linalg.eigvalsh(K).min() > 0


def test_frame_change_equals_recomputation_and_invariant_indices():
    hx = general_hexapod()
    T0 = pose([0.1, 0.2, -0.1], [0.05, 0.02, 0.7])
    K = hx.stiffness(T0).K
    Kp = hx.stiffness(T0, frame="platform").K
    # recompute: the same hexapod described in the platform frame as its base frame
    Tinv = np.linalg.inv(T0)
    base2 = (Tinv[:3, :3] @ hx.base.T).T + Tinv[:3, 3]
    hx2 = Hexapod(base2, hx.platform, hx.k)
    K2 = hx2.stiffness(np.eye(4)).K
    assert np.abs(Kp - K2).max() / np.abs(K2).max() < 1e-12
    assert np.allclose(np.sort(screw_eigenvalues(K).real), np.sort(screw_eigenvalues(Kp).real),
                       rtol=1e-9)
    assert np.allclose(translational_eigenvalues(K), translational_eigenvalues(Kp), rtol=1e-12)
    # batch map: same K as the one-pose call
    Kb, _ = hx.stiffness_batch(T0[None], "platform")
    assert np.allclose(Kb[0], Kp, rtol=1e-12)


def test_compliance_through_P_deflection_and_leg_forces():
    hx = general_hexapod()
    T0 = pose([0.0, 0.1, 0.0], [0.0, 0.05, 0.6])
    K = hx.stiffness(T0).K
    C = hx.compliance(T0)
    assert np.allclose(C @ K, np.eye(6), atol=1e-9)
    W = np.r_[100.0, -50, 2000, 10, -30, 5]
    tau = hx.leg_forces(T0, W)
    assert np.allclose(hx.leg_matrix(T0) @ tau, W)
    assert np.allclose(K @ hx.deflection(T0, W), W)


def test_loaded_stiffness_against_fd_of_equilibrium():
    hx = general_hexapod()
    T0 = pose([0.05, -0.1, 0.15], [0.02, 0.01, 0.7])
    W0 = np.r_[300.0, -200, -5000, 400, 250, -100]       # a moment about the base origin
    res = hx.loaded_stiffness(T0, W0)
    tau0 = hx.leg_forces(T0, W0)
    L0, _ = hx.legs(T0)

    def held_wrench(D):
        T = T0.copy()
        T[:3, :3] = exp_so3(D[3:]) @ T0[:3, :3]
        T[:3, 3] = exp_so3(D[3:]) @ T0[:3, 3] + D[:3]
        L, _ = hx.legs(T)
        W = hx.leg_matrix(T) @ (tau0 + hx.k * (L - L0))       # about the base origin
        return np.r_[W[:3], W[3:] - np.cross(D[:3], W[:3])]   # about the carried point δ

    h = 1e-6
    Kfd = np.stack([(held_wrench(np.eye(6)[i] * h) - held_wrench(-np.eye(6)[i] * h)) / (2 * h)
                    for i in range(6)], 1)
    assert res.loaded
    assert np.abs(Kfd - res.K).max() / np.abs(res.K).max() < 1e-7
    # not symmetric under a moment about the reference point; symmetric under a pure force there
    skew_part = 0.5 * (res.K - res.K.T)
    assert np.allclose(skew_part[3:, 3:], -0.5 * skew_c(W0[3:]), atol=1e-6)
    Kf = hx.loaded_stiffness(T0, np.r_[W0[:3], 0, 0, 0]).K
    assert np.abs(Kf - Kf.T).max() < 1e-8 * np.abs(Kf).max()
    # with no load, the loaded stiffness is the unloaded one
    assert np.allclose(hx.loaded_stiffness(T0, np.zeros(6)).K, hx.stiffness(T0).K)


def test_near_singular_pose_warns_and_bad_input_raises():
    hx = general_hexapod()
    base = hx.base
    flat = pose([0, 0, 0], [0, 0, 1e-9])                # platform in the base plane
    with pytest.warns(SingularPoseWarning, match="cond"):
        r = hx.stiffness(flat)
    assert r.cond_P > 1e8
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        hx.stiffness(pose([0, 0, 0], [0, 0, 0.8]))
    with pytest.raises(StiffnessError, match="not a proper rotation"):
        hx.stiffness(np.diag([1, 1, 2, 1.0]))
    with pytest.raises(StiffnessError, match="4x4"):
        hx.stiffness(np.eye(3))
    with pytest.raises(StiffnessError, match="platform_points"):
        Hexapod(base, base[:5], 1e6)
    with pytest.raises(StiffnessError, match="leg_stiffness"):
        Hexapod(base, base, -1.0)
    with pytest.raises(StiffnessError, match="direction n has zero length"):
        plucker([0, 0, 0], [1, 2, 3])
    with pytest.raises(StiffnessError, match="k: stiffnesses"):
        stiffness_matrix(np.zeros((6, 6)), -np.ones(6))


def test_map_vectorised_matches_single_poses_and_flags_singular():
    hx = general_hexapod()
    pos = np.c_[np.linspace(-0.1, 0.1, 5), np.zeros(5), np.r_[0.6, 0.65, 0.7, 0.75, 1e-9]]
    rot = np.array([[0, 0, 0], [0.1, 0, 0]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SingularPoseWarning)
        df = hx.map(pos, rot)
        assert len(df) == 10
        row = df.iloc[3]
        K = hx.stiffness(pose([0.1, 0, 0], pos[1]), frame="platform").K
    assert np.isclose(row.kt_min, np.linalg.eigvalsh(K[:3, :3])[0], rtol=1e-12)
    # only the untilted platform lying in the base plane is singular (a tilted one is not)
    sing = df[df.singular]
    assert len(sing) == 1 and sing.z.iloc[0] == 1e-9 and sing.rx.iloc[0] == 0
    assert sing.cr_max.isna().all() and df[~df.singular].cr_max.notna().all()


@pytest.mark.parametrize("criterion", ["whole", "translational"])
def test_convex_design_beats_uniform_and_random_allocations(criterion):
    hx = general_hexapod(np.ones(6))
    poses = np.array([pose(rv, t) for rv, t in [([0, 0, 0], [0, 0, 0.5]),
                                                ([0.3, 0, 0], [0.1, 0, 0.6]),
                                                ([0, -0.3, 0.2], [0, 0.1, 0.45])]])
    budget = 6e7
    res = design_leg_stiffness(hx, poses, budget, criterion=criterion)

    P = hx.leg_matrix(poses)                       # (B, 6, 6) about the base origin

    def worst(k):                                  # the criterion, from K = P diag(k) Pᵀ
        K = np.einsum("bin,n,bjn->bij", P, k, P)
        if criterion == "translational":
            return np.linalg.eigvalsh(K[:, :3, :3])[:, 0].min()
        c = poses[:, :3, :3] @ hx.platform.mean(0) + poses[:, :3, 3]     # the centroid
        Ks = np.array([transform_stiffness(K[b], np.eye(3), c[b]) for b in range(len(c))])
        D = np.diag(np.r_[np.ones(3), np.full(3, 1 / hx.radius)])       # moments / radius
        return np.linalg.eigvalsh(D @ Ks @ D)[:, 0].min()

    assert res.status == "optimal" and res.k.sum() <= budget * (1 + 1e-6)
    assert abs(worst(res.k) - res.verified) < 1e-6 * res.verified
    assert abs(res.verified - res.objective) / res.objective < 1e-4
    assert res.verified > worst(np.full(6, budget / 6)) * 1.001
    rng = np.random.default_rng(5)
    trials = rng.dirichlet(np.ones(6), 200) * budget
    assert max(worst(k) for k in trials) <= res.verified * (1 + 1e-4)
    if criterion == "whole":                       # no leg is left without stiffness
        assert res.k.min() > 0.01 * budget / 6


def test_report_markdown_and_csv(tmp_path):
    hx = general_hexapod()
    T0 = pose([0, 0, 0], [0, 0, 0.7])
    text = report(hx, T0, frame="platform", wrench=np.r_[0, 0, -1000.0, 0, 0, 0],
                  positions=np.c_[np.zeros(3), np.zeros(3), [0.6, 0.7, 0.8]], path=tmp_path / "r.md")
    assert "N/m" in text and "rad/(N·m)" in text and "reference point" in text
    import pandas as pd
    K = pd.read_csv(tmp_path / "r_stiffness.csv", index_col=0).to_numpy()
    assert np.allclose(K, hx.stiffness(T0, frame="platform").K)
    forces = pd.read_csv(tmp_path / "r_leg_forces.csv")
    assert np.allclose(forces.force_N, hx.leg_forces(T0, [0, 0, -1000.0, 0, 0, 0]))
    assert (tmp_path / "r_map.csv").exists() and not list(tmp_path.glob(".*"))


def test_plot_map_writes_png(tmp_path):
    pytest.importorskip("matplotlib")        # the `plot` extra (installed by the test extra)
    from stiffness import plot_map
    hx = general_hexapod()
    g = np.linspace(-0.1, 0.1, 4)
    pos = np.array([(x, y, 0.7) for x in g for y in g])
    fig = plot_map(hx.map(pos), "kt_min", path=tmp_path / "m.png")
    assert (tmp_path / "m.png").stat().st_size > 1000 and fig.axes
    with pytest.raises(StiffnessError, match="column 'nope'"):
        plot_map(hx.map(pos), "nope")


def test_blocked_batch_equals_unblocked():
    """A pose's K and cond(P) do not depend on the batch it comes in (the kernels work on
    groups of LANES poses): whole batch, pieces across the groups and one by one agree
    bit for bit."""
    from stiffness.kernels import LANES
    hx = general_hexapod()
    n = 2 * LANES + 5
    T = np.array([pose(rng.normal(scale=0.1, size=3), [0, 0, 0.7] + rng.normal(scale=0.05, size=3))
                  for _ in range(n)])
    for frame in (None, "platform"):
        K1, c1 = hx.stiffness_batch(T, frame)
        cuts = ((0, 3), (3, LANES + 9), (LANES + 9, n))
        parts = [hx.stiffness_batch(T[a:b], frame) for a, b in cuts]
        assert np.array_equal(K1, np.concatenate([K for K, _ in parts]))
        assert np.array_equal(c1, np.concatenate([c for _, c in parts]))
        for i in (0, LANES - 1, LANES, n - 1):
            Ki, ci = hx.stiffness_batch(T[i:i + 1], frame)
            assert np.array_equal(Ki[0], K1[i]) and ci[0] == c1[i]


def _held_wrench_fd(hx, T0, W0, R, p, h=1e-6):
    """Loaded stiffness by central differences of the equilibrium: the platform is displaced
    by Δ = (δ, θ) (frame axes) about the platform point at ``p``; the legs keep their forces
    plus k ΔL; the held wrench is taken about the displaced point, in the frame's axes."""
    tau0 = hx.leg_forces(T0, W0)
    L0, _ = hx.legs(T0)

    def held(D):
        d, th = R.T @ D[:3], R.T @ D[3:]                      # into base axes
        Q = exp_so3(th)
        T = T0.copy()
        T[:3, :3] = Q @ T0[:3, :3]
        T[:3, 3] = Q @ (T0[:3, 3] - p) + p + d
        L, _ = hx.legs(T)
        W = hx.leg_matrix(T) @ (tau0 + hx.k * (L - L0))       # about the base origin
        f, m = W[:3], W[3:] - np.cross(p + d, W[:3])          # about the carried point
        return np.r_[R @ f, R @ m]

    return np.stack([(held(np.eye(6)[i] * h) - held(-np.eye(6)[i] * h)) / (2 * h)
                     for i in range(6)], 1)


@pytest.mark.parametrize("which", ["platform", "general"])
def test_loaded_stiffness_in_a_frame_against_fd(which):
    hx = general_hexapod()
    T0 = pose([0.05, -0.1, 0.15], [0.02, 0.01, 0.7])
    W0 = np.r_[300.0, -200, -5000, 400, 250, -100]
    if which == "platform":
        frame, R, p = "platform", T0[:3, :3].T, T0[:3, 3]
    else:
        R, p = rand_frame()
        frame = (R, p)
    res = hx.loaded_stiffness(T0, W0, frame=frame)
    Kfd = _held_wrench_fd(hx, T0, W0, R, p)
    assert np.abs(Kfd - res.K).max() / np.abs(res.K).max() < 1e-7
    assert np.allclose(res.reference, p) and np.allclose(res.R, R)
    # unloaded: the congruence result in the same frame
    assert np.allclose(hx.loaded_stiffness(T0, np.zeros(6), frame=frame).K,
                       hx.stiffness(T0, frame=frame).K, rtol=1e-12, atol=1e-12 * np.abs(res.K).max())


@pytest.mark.parametrize("far", [1e3, 1e5])
def test_loaded_stiffness_about_the_platform_is_origin_free(far):
    """The same loaded hexapod with the whole model moved far from the base origin: about the
    platform frame the loaded stiffness agrees to 1e-9 relative (about the far base origin its
    moment blocks would carry |origin|² k and lose every digit)."""
    hx = general_hexapod(k=np.full(6, 1e7))
    T0 = pose([0.05, -0.1, 0.15], [0.02, 0.01, 0.7])
    W0 = np.r_[300.0, -200, -5000, 400, 250, -100]            # about the base origin
    K0 = hx.loaded_stiffness(T0, W0, frame="platform").K
    Q, s = exp_so3(np.array([0.3, -1.1, 0.7])), far * np.array([0.6, -0.8, 0.3])
    moved = Hexapod(hx.base @ Q.T + s, hx.platform, hx.k)
    T1 = T0.copy()
    T1[:3, :3] = Q @ T0[:3, :3]
    T1[:3, 3] = Q @ T0[:3, 3] + s
    W1 = np.r_[Q @ W0[:3], Q @ W0[3:] + np.cross(s, Q @ W0[:3])]   # the same load, new origin
    K1 = moved.loaded_stiffness(T1, W1, frame="platform").K
    assert np.abs(K1 - K0).max() / np.abs(K0).max() < 1e-9


def test_reprs_are_short_and_carry_units():
    hx = general_hexapod(k=np.full(6, 1e7))
    assert repr(hx) == ("Hexapod(6 legs, base radius 0.8 m, platform radius 0.4 m, "
                        "leg stiffness 1e+07 N/m)")
    T0 = pose([0, 0, 0], [0, 0, 0.7])
    one = hx.stiffness(T0)
    kt = np.linalg.eigvalsh(one.K[:3, :3])
    assert f"{kt[0]:.4g} … {kt[-1]:.4g} N/m" in repr(one) and "\n" not in repr(one)
    batch = hx.stiffness(np.stack([T0] * 73))
    assert "73 poses" in repr(batch) and len(repr(batch)) < 100


def test_base_frame_by_name_and_map_indices_about_any_point():
    hx = general_hexapod()
    T0 = pose([0.05, -0.1, 0.15], [0.02, 0.01, 0.7])
    assert np.array_equal(hx.stiffness(T0, frame="base").K, hx.stiffness(T0).K)
    W0 = np.r_[300.0, -200, -5000, 400, 250, -100]
    assert np.array_equal(hx.loaded_stiffness(T0, W0, frame="base").K,
                          hx.loaded_stiffness(T0, W0).K)
    row = hx.map(T0[None, :3, 3], [[0.05, -0.1, 0.15]]).iloc[0]
    for frame in ("base", "platform", rand_frame()):
        K = hx.stiffness(T0, frame=frame).K
        C = np.linalg.inv(K)
        assert np.isclose(row.kt_min, np.linalg.eigvalsh(K[:3, :3])[0], rtol=1e-9)
        assert np.isclose(row.kt_max, np.linalg.eigvalsh(K[:3, :3])[-1], rtol=1e-9)
        assert np.isclose(row.cr_max, np.linalg.eigvalsh(C[3:, 3:])[-1], rtol=1e-9)


def test_batch_kernel_matches_the_leg_matrix_and_svd_condition():
    """The batched kernel (K from the legs' u uᵀ products; cond(P) from the Gram matrix's
    eigenvalues, by singular values when ill conditioned) against P diag(k) Pᵀ and the SVD
    per pose, across blocks, with a near-singular pose; a bad transform far into the
    batch is refused (a non-finite one with its index)."""
    import stiffness.hexapod as sh
    from stiffness.kernels import LANES
    hx = general_hexapod()
    rng = np.random.default_rng(5)
    n = 2 * LANES + 7
    T = np.array([pose(rng.normal(scale=0.15, size=3), rng.normal(scale=0.05, size=3) +
                       [0, 0, 0.7]) for _ in range(n)])
    T[3] = pose([0, 0, 0], [0, 0, 1e-7])                 # nearly flat: P near singular
    K, c = hx.stiffness_batch(T)
    for i in (0, 3, LANES, n - 1):
        P = hx.leg_matrix(T[i])
        assert np.abs(K[i] - P @ np.diag(hx.k) @ P.T).max() <= 1e-14 * np.abs(K[i]).max()
        assert np.isclose(c[i], hx.cond_P(T[i]), rtol=1e-9)
    assert c[3] > sh.GRAM_COND_LIMIT and c[0] < sh.GRAM_COND_LIMIT
    bad = T.copy()
    bad[n - 2, 0, 0] = 1.01
    with pytest.raises(StiffnessError, match="T rotation: not a proper rotation"):
        hx.stiffness_batch(bad)
    bad = T.copy()
    bad[n - 2, 1, 3] = np.nan
    with pytest.raises(StiffnessError, match=f"T: expected finite values, got nan at index "
                                             f"\\({n - 2}, 1, 3\\)"):
        hx.stiffness_batch(bad)


def test_map_chunks_stream_the_same_rows_in_bounded_memory():
    import tracemalloc
    hx = general_hexapod()
    g = np.linspace(-0.05, 0.05, 30)
    pos = np.array(np.meshgrid(g, g, [0.65, 0.7, 0.75, 0.8])).reshape(3, -1).T    # 3600
    rot = np.array([[0, 0, 0], [0.05, -0.02, 0.1]] * 4) * np.arange(1, 9)[:, None]
    whole = hx.map(pos[:40], rot, chunk=7)
    parts = list(hx.map_chunks(pos[:40], rot, chunk=64))
    assert [len(p) for p in parts] == [64] * 5 and parts[1].index[0] == 64
    assert whole.equals(pd.concat(parts)) and whole.equals(hx.map(pos[:40], rot))
    hx.map(pos[:8], rot, chunk=512)                                  # warm up outside the trace
    tracemalloc.start()
    df = hx.map(pos, rot, chunk=512)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert len(df) == 28800 and peak / len(df) < 200                 # bytes per pose
    for bad in (0, 2.5, True):
        with pytest.raises(StiffnessError, match="chunk"):
            hx.map(pos, chunk=bad)
