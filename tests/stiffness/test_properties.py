"""Property-based tests of the stiffness package's public API (hypothesis).

Bad inputs raise the package's errors naming the argument; results are invariant
under a rigid motion of the whole model (also far from the origin), transform as
derived under a change of length and stiffness units, and a batch equals the
poses one by one.  Singular and near-singular poses raise or warn with cond(P).
"""
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st

from closure import exp_so3
from stiffness import (Hexapod, SingularPoseError, SingularPoseWarning, StiffnessError, blocks,
                       compose_frames, design_leg_stiffness, from_blocks, plucker, report,
                       rotate_six, rotational_compliance_eigenvalues, screw_eigenvalues,
                       shift_twist, shift_wrench, skew, spring_stiffness, stiffness_indices,
                       stiffness_matrix, to_moment_first, transform_blocks, transform_stiffness,
                       translational_eigenvalues, twist_transform, twist_transform_inverse,
                       wrench_transform, wrench_transform_inverse)

FAST = settings(max_examples=40, deadline=None, database=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow])

_A = np.radians([0, 100, 120, 220, 240, 340])
_B = np.radians([40, 80, 160, 200, 280, 320])
BASE = np.c_[0.8 * np.cos(_A), 0.8 * np.sin(_A), np.zeros(6)]
PLAT = np.c_[0.4 * np.cos(_B), 0.4 * np.sin(_B), np.zeros(6)]
K_LEGS = np.array([1.1e7, 0.9e7, 1.3e7, 1.0e7, 0.8e7, 1.2e7])
HX = Hexapod(BASE, PLAT, K_LEGS)


def pose(rv=(0, 0, 0), t=(0, 0, 0.7)):
    T = np.eye(4)
    T[:3, :3] = exp_so3(np.asarray(rv, float))
    T[:3, 3] = t
    return T


T0 = pose((0.05, -0.1, 0.15), (0.03, -0.02, 0.68))
R0, P0 = exp_so3(np.array([0.3, -0.2, 0.5])), np.array([0.1, -0.2, 0.3])
K0 = HX.stiffness(T0).K
W0 = np.array([120.0, -80.0, -2500.0, 40.0, 15.0, -25.0])

# ------------------------------------------------------------------ bad inputs
# every public function with valid arguments; each argument is corrupted in turn
CASES = {
    "skew": (skew, dict(p=P0)),
    "plucker": (plucker, dict(n=np.array([1.0, 2, 3]), r=P0)),
    "wrench_transform": (wrench_transform, dict(R=R0, p=P0)),
    "twist_transform": (twist_transform, dict(R=R0, p=P0)),
    "wrench_transform_inverse": (wrench_transform_inverse, dict(R=R0, p=P0)),
    "twist_transform_inverse": (twist_transform_inverse, dict(R=R0, p=P0)),
    "shift_wrench": (shift_wrench, dict(p=P0)),
    "shift_twist": (shift_twist, dict(p=P0)),
    "rotate_six": (rotate_six, dict(R=R0)),
    "compose_frames": (compose_frames, dict(R1=R0, p1=P0, R2=R0.T, p2=-P0)),
    "to_moment_first": (to_moment_first, dict(X=K0)),
    "spring_stiffness": (spring_stiffness, dict(k=K_LEGS, directions=BASE + [0, 0, 1],
                                                points=BASE)),
    "stiffness_matrix": (stiffness_matrix, dict(P=HX.leg_matrix(T0), k=K_LEGS)),
    "transform_stiffness": (transform_stiffness, dict(K=K0, R=R0, p=P0)),
    "transform_blocks": (transform_blocks, dict(K=K0, R=R0, p=P0)),
    "blocks": (blocks, dict(K=K0)),
    "from_blocks": (from_blocks, dict(Kn=K0[:3, :3], Kc=K0[:3, 3:], Kk=K0[3:, 3:])),
    "screw_eigenvalues": (screw_eigenvalues, dict(K=K0)),
    "translational_eigenvalues": (translational_eigenvalues, dict(K=K0)),
    "rotational_compliance_eigenvalues": (rotational_compliance_eigenvalues, dict(K=K0)),
    "stiffness_indices": (stiffness_indices, dict(K=K0)),
    "Hexapod": (Hexapod, dict(base_points=BASE, platform_points=PLAT, leg_stiffness=K_LEGS)),
    "Hexapod.stiffness": (HX.stiffness, dict(pose=T0)),
    "Hexapod.compliance": (HX.compliance, dict(pose=T0)),
    "Hexapod.leg_forces": (HX.leg_forces, dict(pose=T0, wrench=W0)),
    "Hexapod.deflection": (HX.deflection, dict(pose=T0, wrench=W0)),
    "Hexapod.loaded_stiffness": (HX.loaded_stiffness, dict(pose=T0, wrench=W0)),
    "Hexapod.legs": (HX.legs, dict(pose=T0)),
    "Hexapod.leg_matrix": (HX.leg_matrix, dict(pose=T0)),
    "Hexapod.cond_P": (HX.cond_P, dict(pose=T0)),
    "Hexapod.platform_points_world": (HX.platform_points_world, dict(pose=T0)),
    "Hexapod.map": (HX.map, dict(positions=np.array([[0, 0, 0.7], [0.1, 0, 0.65]]),
                                 rotations=np.array([[0, 0, 0.1]]))),
    "Hexapod.stiffness_batch": (HX.stiffness_batch, dict(T=T0[None])),
}
ROTATIONS = {"R", "R1", "R2"}
TRANSFORMS = {"pose", "T"}
#: arguments whose trailing shape is free (a new trailing size is a valid other input)
FREE_LAST = {"k", "P", "leg_stiffness"}


def corruptions(name, value):
    """(kind, bad value) pairs for one argument; every one is invalid for it."""
    v = np.asarray(value, float)
    out = [("str", "abc"), ("None", None), ("dict", {"a": 1}), ("object", object()),
           ("complex", v.astype(complex) + 1j), ("ragged", [[1.0, 2.0], [3.0]])]
    for bad in (np.nan, np.inf, -np.inf):
        w = v.copy()
        w.flat[w.size // 2] = bad
        out.append((f"{bad}", w))
    if name not in FREE_LAST and name != "leg_stiffness":
        out += [("short", v[..., :-1]), ("long", np.concatenate([v, v[..., :1]], -1)),
                ("scalar", 1.0)]
    if name in ROTATIONS:
        out.append(("not orthonormal", 1.01 * v))
        out.append(("reflection", v @ np.diag([1.0, 1, -1])))
    if name in TRANSFORMS:
        w = v.copy()
        w[..., 3, 0] = 0.5
        out.append(("last row", w))
        w = v.copy()
        w[..., :3, :3] *= 1.01
        out.append(("not rigid", w))
    if name in ("k", "leg_stiffness"):
        out.append(("negative", -np.abs(v)))
        out.append(("wrong count", v[..., :-1]))
    if name == "leg_stiffness":
        out.append(("zero", 0.0 * v))
    return out


BAD = [(f, arg, kind) for f, (_, kw) in CASES.items() for arg in kw
       for kind, _ in corruptions(arg, kw[arg])]


@settings(FAST, max_examples=120)
@given(st.sampled_from(BAD))
def test_bad_input_raises_the_package_error_naming_the_argument(case):
    fname, arg, kind = case
    f, kw = CASES[fname]
    bad = dict(corruptions(arg, kw[arg]))[kind]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SingularPoseWarning)
        with pytest.raises(StiffnessError) as info:
            f(**{**kw, arg: bad})
    assert isinstance(info.value, ValueError)
    assert arg in str(info.value), (fname, arg, kind, str(info.value))


@pytest.mark.parametrize("fname", sorted(CASES))
def test_the_tables_valid_arguments_work(fname):
    """The reference calls of the bad-input table are valid (so each corruption is the
    only thing wrong in its call)."""
    f, kw = CASES[fname]
    f(**kw)


def test_every_public_function_is_covered_by_the_bad_input_table():
    import stiffness
    covered = {name.split(".")[0] for name in CASES} | {
        "design_leg_stiffness", "report", "plot_map", "StiffnessResult", "StiffnessError",
        "SingularPoseError", "SingularPoseWarning", "from_moment_first",
        # their own bad-input tables: test_mechanism, test_beams and test_tolerance
        "of_mechanism", "MechanismStiffness", "mechanism_map", "beam_stiffness", "beam_compliance",
        "beam_geometric_stiffness", "hexapod_tolerance", "HexapodTolerance"}
    assert set(stiffness.__all__) <= covered


@pytest.mark.parametrize("kw,arg", [
    (dict(hexapod="hx"), "hexapod"), (dict(budget=float("nan")), "budget"),
    (dict(budget="6e7"), "budget"), (dict(budget=-1.0), "budget"), (dict(k_min=-1.0), "k_min"),
    (dict(k_min=float("inf")), "k_min"), (dict(poses=np.eye(3)), "poses"),
    (dict(solver="NO_SUCH_SOLVER"), "solver"), (dict(solver=3), "solver")])
def test_design_bad_inputs(kw, arg):
    args = dict(hexapod=HX, poses=T0[None], budget=6e7) | kw
    with pytest.raises(StiffnessError, match=arg):
        design_leg_stiffness(**args)


@pytest.mark.parametrize("kw,arg", [
    (dict(hexapod=None), "hexapod"), (dict(wrench=[1.0, 2.0]), "wrench"),
    (dict(wrench=[np.nan] * 6), "wrench"), (dict(pose=np.stack([T0, T0])), "pose"),
    (dict(frame="nope"), "frame"), (dict(frame=(np.eye(3), [0, np.inf, 0])), "frame p")])
def test_report_bad_inputs(kw, arg, tmp_path):
    args = dict(hexapod=HX, pose=T0) | kw
    with pytest.raises(StiffnessError, match=arg):
        report(**args)


def test_known_cases_nan_wrench_and_shapes():
    """The issue's cases, each with the argument and the expected shape in the message."""
    W = W0.copy()
    W[3] = np.nan
    for f in (HX.leg_forces, HX.deflection, HX.loaded_stiffness):
        with pytest.raises(StiffnessError, match=r"wrench: expected finite"):
            f(T0, W)
    with pytest.raises(StiffnessError, match=r"p: expected shape \(\.\.\., 3\)"):
        skew([1.0, 2.0])
    with pytest.raises(StiffnessError, match=r"R: expected a 3x3 rotation"):
        wrench_transform(np.eye(4), P0)
    with pytest.raises(StiffnessError, match=r"K: expected shape \(\.\.\., 6, 6\)"):
        transform_stiffness(np.eye(5), R0, P0)
    with pytest.raises(StiffnessError, match=r"base_points: expected \(n, 3\)"):
        Hexapod(BASE[:, :2], PLAT, 1e7)
    with pytest.raises(StiffnessError, match=r"R, p: batch shapes do not broadcast"):
        wrench_transform(np.stack([R0, R0]), np.zeros((3, 3)))
    with pytest.raises(StiffnessError, match=r"pose: last row must be \(0, 0, 0, 1\)"):
        HX.stiffness(np.r_[T0[:3], [[0.1, 0, 0, 1]]])
    with pytest.raises(StiffnessError, match=r"T: expected a batch of poses \(B, 4, 4\)"):
        HX.stiffness_batch(T0)
    for k in (0.0, -1e6):
        with pytest.raises(StiffnessError, match="leg_stiffness: expected positive"):
            Hexapod(BASE, PLAT, k)


# ------------------------------------------------------------------ singular poses
FLAT = pose(t=(0, 0, 1e-9))          # platform in the base plane: cond(P) ≈ 6.9e8


def test_singular_pose_raises_with_cond_not_linalg_error():
    for f, args in ((HX.compliance, ()), (HX.leg_forces, (W0,)), (HX.deflection, (W0,)),
                    (HX.loaded_stiffness, (W0,))):
        with pytest.raises(SingularPoseError, match=r"pose is singular \(cond\(P\) = 6\.\d\de\+08"):
            f(FLAT, *args)
    # exactly singular: P is rank deficient (LinAlgError or garbage before)
    with pytest.raises(SingularPoseError, match=r"cond\(P\) = "):
        HX.compliance(pose(t=(0, 0, 0.0)))
    # a batch names the singular pose
    with pytest.raises(SingularPoseError, match=r"pose index \(1,\)"):
        HX.leg_forces(np.stack([T0, FLAT]), W0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SingularPoseWarning)
        res = HX.stiffness(FLAT)
    with pytest.raises(SingularPoseError, match=r"pose is singular \(cond\(P\) = 6\.\d\de\+08"):
        stiffness_indices(res)
    with pytest.raises(SingularPoseError, match=r"K: the stiffness is singular \(cond\(K\) = "):
        stiffness_indices(res.K)
    with pytest.raises(SingularPoseError, match=r"K: the stiffness is singular"):
        stiffness_indices(np.zeros((6, 6)))
    with pytest.raises(SingularPoseError, match=r"K: the stiffness is singular"):
        rotational_compliance_eigenvalues(res.K)
    assert issubclass(SingularPoseError, StiffnessError) and issubclass(StiffnessError, ValueError)


def test_near_singular_leg_forces_warn_with_the_figure():
    """At cond(P) ≈ 4.7e7 (below the singular limit) a 4.5 kN load needs ≈ 3e10 N leg
    forces: correct for rigid legs, and flagged with a SingularPoseWarning."""
    T = pose(t=(0, 0, 1.4638e-8))
    W = np.array([0, 0, 4500.0, 0, 0, 0])
    assert 4e7 < HX.cond_P(T) < 5e7
    with pytest.warns(SingularPoseWarning, match=r"cond\(P\) = 4\.\d\de\+07.*largest leg force "
                                                 r"[23]\.\d\de\+10 N"):
        tau = HX.leg_forces(T, W)
    assert 2e10 < np.abs(tau).max() < 4e10
    # independent reference: the forces balance the load (P τ = W, to round-off × cond)
    P = HX.leg_matrix(T)
    assert np.abs(P @ tau - W).max() <= 1e-6 * np.abs(P).max() * np.abs(tau).max()
    with pytest.warns(SingularPoseWarning, match="warn_cond"):
        HX.compliance(T)
    # a regular pose stays silent, and warn_cond is the user's to set
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        HX.leg_forces(T0, W0)
        Hexapod(BASE, PLAT, K_LEGS, warn_cond=1e8).leg_forces(T, W)


# ------------------------------------------------------------------ invariances
@st.composite
def rigid_motions(draw, far=(3.0, 6.0)):
    """(R, t) with |t| = 10^U(far) in a random direction."""
    rv = np.array(draw(st.lists(st.floats(-3, 3), min_size=3, max_size=3)))
    d = np.array(draw(st.lists(st.floats(-1, 1), min_size=3, max_size=3)))
    assume(np.linalg.norm(d) > 0.1)
    mag = 10 ** draw(st.floats(*far))
    return exp_so3(rv), mag * d / np.linalg.norm(d)


poses = st.builds(lambda rv, t: pose(np.array(rv) * 0.2, np.array(t) * 0.1 + [0, 0, 0.7]),
                  st.lists(st.floats(-1, 1), min_size=3, max_size=3),
                  st.lists(st.floats(-1, 1), min_size=3, max_size=3))


def rel(a, b):
    return np.abs(np.asarray(a) - np.asarray(b)).max() / np.abs(b).max()


@FAST
@given(rigid_motions(), poses)
def test_rigid_motion_of_the_whole_hexapod_far_from_the_origin(G, T):
    """Move base, platform pose and load by G = (Rg, t), |t| up to 1e6 m: the stiffness
    about the platform and cond(P) are unchanged, the base-frame K is T K Tᵀ of the frame
    change (r' = Rg r + t: R = Rg, p = −Rgᵀ t), and the leg forces under the moved wrench
    are the same forces."""
    Rg, t = G
    Gm = np.eye(4)
    Gm[:3, :3], Gm[:3, 3] = Rg, t
    hx2 = Hexapod(BASE @ Rg.T + t, PLAT, K_LEGS)
    T2 = Gm @ T
    Kp, Kp2 = HX.stiffness(T, frame="platform").K, hx2.stiffness(T2, frame="platform").K
    scale = np.abs(t).max() / 0.8                       # round-off grows with the offset
    assert rel(Kp2, Kp) < 1e-13 * scale + 1e-12
    assert abs(hx2.cond_P(T2) / HX.cond_P(T) - 1) < 1e-12 * scale + 1e-11
    K2 = hx2.stiffness(T2).K
    assert rel(K2, transform_stiffness(HX.stiffness(T).K, Rg, -Rg.T @ t)) < 1e-15 * scale + 1e-12
    Tw = wrench_transform(Rg, -Rg.T @ t)
    tau, tau2 = HX.leg_forces(T, W0), hx2.leg_forces(T2, Tw @ W0)
    assert rel(tau2, tau) < 1e-13 * scale + 1e-11
    # deflection of the platform origin and rotation: the same motion seen in the new frame
    d, d2 = HX.deflection(T, W0), hx2.deflection(T2, Tw @ W0)
    assert rel(d2, twist_transform(Rg, -Rg.T @ t) @ d) < 1e-13 * scale + 1e-10


@FAST
@given(st.floats(-13, 6), st.floats(-3, 3), poses)
@example(-13.0, 0.0, T0)
@example(6.0, -3.0, T0)
def test_change_of_units_scales_K_as_derived(log_s, log_kappa, T):
    """Lengths × s and leg stiffness × κ.  Plücker directions are unchanged and moments
    r × n scale by s, so with D = diag(1, 1, 1, s, s, s): P' = D P and
    K' = κ D K D — the translational block × κ (N/m: unchanged when κ = 1, whatever s),
    the coupling × κ s, the torsional block × κ s².  cond(P) (moment rows over the
    platform radius, also × s) is unchanged, leg forces under W' = D W too, and the
    deflection is Δ' = D⁻¹ Δ / κ (δ / κ, θ / (κ s))."""
    s, kappa = 10.0 ** log_s, 10.0 ** log_kappa
    hx = Hexapod(BASE * s, PLAT * s, K_LEGS * kappa)
    Ts = T.copy()
    Ts[:3, 3] *= s
    D = np.r_[np.ones(3), np.full(3, s)]
    K, Ks = HX.stiffness(T).K, hx.stiffness(Ts).K
    assert rel(Ks, kappa * D[:, None] * K * D[None, :]) < 1e-12
    Kn, Kc, Kk = blocks(Ks)
    assert rel(Kn, kappa * blocks(K)[0]) < 1e-12
    assert rel(Kc, kappa * s * blocks(K)[1]) < 1e-12 and rel(Kk, kappa * s * s * blocks(K)[2]) < 1e-12
    assert abs(hx.cond_P(Ts) / HX.cond_P(T) - 1) < 1e-12
    assert rel(hx.leg_forces(Ts, D * W0), HX.leg_forces(T, W0)) < 1e-12
    assert rel(hx.deflection(Ts, D * W0), HX.deflection(T, W0) / D / kappa) < 1e-11
    # the indices' table scales with its units too
    idx, idx_s = stiffness_indices(K), stiffness_indices(Ks)
    kt, kt_s = (d[d["index"] == "kt"].value.to_numpy() for d in (idx, idx_s))
    cr, cr_s = (d[d["index"] == "cr"].value.to_numpy() for d in (idx, idx_s))
    assert rel(kt_s, kappa * kt) < 1e-12                                          # N/m
    assert rel(cr_s, cr / (kappa * s * s)) < 1e-10                                # rad/(N·m)


def test_tiny_hexapod_is_accepted():
    """A 1e-13-scale model (the absolute 1e-12 m leg check rejected it)."""
    hx = Hexapod(BASE * 1e-13, PLAT * 1e-13, K_LEGS)
    T = T0.copy()
    T[:3, 3] *= 1e-13
    Kn = blocks(hx.stiffness(T).K)[0]
    assert rel(Kn, blocks(K0)[0]) < 1e-12                 # N/m: unchanged by the scale
    assert abs(hx.cond_P(T) / HX.cond_P(T0) - 1) < 1e-12
    with pytest.raises(StiffnessError, match="leg 1 has zero length"):
        hx.stiffness(pose(t=hx.base[0] - hx.platform[0]))


@FAST
@given(st.lists(poses, min_size=1, max_size=5))
def test_batch_equals_one_by_one(Ts):
    T = np.array(Ts)
    Ws = W0 * np.arange(1, len(Ts) + 1)[:, None]
    Kb = HX.stiffness(T).K
    rp = HX.stiffness(T, frame="platform")
    Kpb = rp.K
    assert rp.reference.shape == (len(Ts), 3) and rp.cond_P.shape == (len(Ts),)
    Cb, taub, db = HX.compliance(T), HX.leg_forces(T, Ws), HX.deflection(T, Ws)
    Kbatch, cb = HX.stiffness_batch(T, "platform")
    for i, Ti in enumerate(Ts):
        assert rel(Kb[i], HX.stiffness(Ti).K) < 1e-14
        one = HX.stiffness(Ti, frame="platform")
        assert rel(Kpb[i], one.K) < 1e-13 and abs(rp.cond_P[i] - one.cond_P) < 1e-9 * one.cond_P
        assert np.array_equal(rp.reference[i], one.reference) and np.array_equal(rp.R[i], one.R)
        assert rel(Kbatch[i], Kpb[i]) < 1e-13 and abs(cb[i] - HX.cond_P(Ti)) < 1e-9 * cb[i]
        assert rel(Cb[i], HX.compliance(Ti)) < 1e-13
        assert rel(taub[i], HX.leg_forces(Ti, Ws[i])) < 1e-13
        assert rel(db[i], HX.deflection(Ti, Ws[i])) < 1e-13
    # vectorised six-vector functions against a loop
    R = exp_so3(np.array([[0.1 * i, -0.2, 0.3] for i in range(len(Ts))]))
    p = T[:, :3, 3]
    Tw = wrench_transform(R, p)
    for i in range(len(Ts)):
        assert np.allclose(Tw[i], wrench_transform(R[i], p[i]), rtol=0, atol=1e-15)
    P = HX.leg_matrix(T)
    Kk = stiffness_matrix(P, K_LEGS)
    assert all(rel(Kk[i], stiffness_matrix(P[i], K_LEGS)) < 1e-14 for i in range(len(Ts)))


@FAST
@given(rigid_motions(far=(-1.0, 6.0)), rigid_motions(far=(-1.0, 6.0)))
def test_six_vector_transforms_far_from_the_origin(F1, F2):
    """T* = T⁻ᵀ, power invariance and composition for frames up to 1e6 m away."""
    (R1, p1), (R2, p2) = F1, F2
    T, Ts = wrench_transform(R1, p1), twist_transform(R1, p1)
    n = 1 + np.abs(p1).max()
    assert np.abs(Ts.T @ T - np.eye(6)).max() < 1e-15 * n * n
    W, D = np.r_[1.0, -2, 3, 0.5, 0.1, -0.3], np.r_[0.01, 0.02, -0.01, 1e-3, -2e-3, 5e-4]
    assert abs((Ts @ D) @ (T @ W) - D @ W) < 1e-15 * n * n * 10
    R, p = compose_frames(R1, p1, R2, p2)
    m = n + np.abs(p2).max()
    assert np.abs(wrench_transform(R2, p2) @ T - wrench_transform(R, p)).max() < 1e-15 * m * 10
