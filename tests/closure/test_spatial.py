"""Spatial loops against closed forms; analogs against finite differences."""
import numpy as np
import pytest

from closure import Mechanism, frame_from_points, point_analogs, translation

from linkwright.references import (bennett_theta2, bricard_even, dh_loop, rssr, rssr_output)


def wrap(x):
    return (x + np.pi) % (2 * np.pi) - np.pi


@pytest.mark.parametrize("branch", [1, -1])
def test_rssr_both_branches_closed_form(branch):
    phi0 = 0.2
    m, psi0 = rssr(phi0, branch)
    assert m.mobility == 2          # the rod's idle spin between its two spheres
    phis = np.linspace(-np.pi, np.pi, 91)
    x = phis - phi0
    df = m.sweep(np.r_[0, x[x > 0]])                 # forwards from the assembly pose
    df2 = m.sweep(np.r_[0, x[x < 0][::-1]])          # and backwards
    for d in (df, df2):
        assert (d.status == "ok").all()
        ref = rssr_output(phi0 + d["input:in"].to_numpy(), branch)
        assert np.abs(wrap(psi0 + d["out"].to_numpy() - ref)).max() < 1e-10
        assert d.residual.max() < 1e-12
    # the batched solve from the assembly pose agrees near it
    p = m.solve(np.linspace(-0.5, 0.5, 11))
    ref = rssr_output(phi0 + np.linspace(-0.5, 0.5, 11), branch)
    assert np.abs(wrap(psi0 + p["out"] - ref)).max() < 1e-10


def test_spherical_joint_through_euler_singularity():
    """At the assembly pose both spheres sit at the identity rotation, which is the Z–X–Z
    singular configuration (θ = 0); sweeping through it keeps full accuracy."""
    m, psi0 = rssr(0.2, 1)
    x = np.linspace(-0.05, 0.05, 101)
    df = m.sweep(x - 0.0)
    ref = rssr_output(0.2 + x, 1)
    assert np.abs(wrap(psi0 + df["out"].to_numpy() - ref)).max() < 1e-12
    assert np.abs(df["S1.theta"]).min() < 1e-3           # passes through θ ≈ 0
    assert df.residual.max() < 1e-12 and df.condition.max() < 1e3


def test_bennett_linkage_full_cycle():
    a, alpha, beta = 1.0, 0.5, 1.1
    b = a * np.sin(beta) / np.sin(alpha)
    t1 = 0.7
    t2 = bennett_theta2(t1, alpha, beta)
    m = dh_loop([(a, alpha), (b, beta), (a, alpha), (b, beta)], [t1, t2, -t1, -t2])
    m.add_input("J1")
    assert m.mobility == 1                # 4 joints, rank 3: overconstrained
    x = np.linspace(t1, t1 + 2 * np.pi - 0.3, 80)
    x = x[np.abs(np.sin(x / 2)) > 0.05]
    df = m.sweep(x)
    assert (df.status == "ok").all()
    ref2 = bennett_theta2(df["J1"].to_numpy(), alpha, beta)
    assert np.abs(wrap(df["J2"].to_numpy() - ref2)).max() < 1e-10
    assert np.abs(wrap(df["J3"] + df["J1"])).max() < 1e-10
    assert np.abs(wrap(df["J4"] + df["J2"])).max() < 1e-10
    assert df.residual.max() <= 1e-12


def test_bricard_orthogonal_6r():
    t1 = 2.0
    t2 = bricard_even(t1)
    par = [(1.0, np.pi / 2), (1.0, -np.pi / 2)] * 3
    m = dh_loop(par, [t1, t2] * 3)
    m.add_input("J1")
    assert m.mobility == 1
    J = m._scaled_jacobian(m.kinematic_state(m.assembly()))[0]
    assert np.linalg.matrix_rank(J, 1e-9) == 5     # 6 equations, one redundant
    x = np.linspace(t1, 1.0, 60)
    df = m.sweep(x)
    assert (df.status == "ok").all()
    ref = bricard_even(df["J1"].to_numpy())
    for k in (2, 4, 6):
        assert np.abs(wrap(df[f"J{k}"] - ref)).max() < 1e-10
    for k in (3, 5):
        assert np.abs(wrap(df[f"J{k}"] - df["J1"])).max() < 1e-10
    assert df.residual.max() <= 1e-12


def _mixed_mechanism():
    """One loop R–C–U–S–P–H (10 coordinates, mobility 4): inputs the R angle, the C slide and
    both Hooke angles; the C rotation, the sphere, the slider and the helix are solved."""
    m = Mechanism(["l1", "l2", "l3", "l4", "l5"])
    m.add_joint("in", "R", "ground", "l1", at=np.eye(4))
    m.add_joint("cyl", "C", "l1", "l2", at=frame_from_points([1, 0, 0], [1, 1, 0], [1, 0.2, 1]))
    m.add_joint("hk", "U", "l2", "l3",
                at=frame_from_points([1.5, 1, 0.5], [2, 1, 1.5], [1.5, 2, 0.5]))
    m.add_joint("sph", "S", "l3", "l4", at=translation([2.5, 1.5, 0.3]))
    m.add_joint("pr", "P", "l4", "l5",
                at=frame_from_points([2.7, 0.5, 0.2], [3, 0.5, 1], [3.5, 0, 0]))
    m.add_joint("hel", "H", "l5", "ground",
                at=frame_from_points([3, -0.5, 0], [3, 0, 1], [3.3, -1.5, 0.2]), pitch=0.15)
    for joint, k in [("in", 0), ("cyl", 1), ("hk", 0), ("hk", 1)]:
        m.add_input(joint, k)
    return m


def test_mixed_joints_analogs_against_finite_differences():
    m = _mixed_mechanism()
    assert m.tree.nv == 10 and m.mobility == 4
    ni = len(m.inputs)
    x0 = np.array([0.05, 0.02, -0.03, 0.04])
    p0 = m.solve(x0)
    assert p0.residual.max() < 1e-12
    first, sec = m.analogs(p0)
    scalar_cols = [m.tree.v_offset[j.index] + k for j in m.joints if j.kind != "S"
                   for k in range(j.nq)]
    j = m.joint("sph")
    si, c0 = m.tree.s_index[j.index], m.tree.v_offset[j.index]
    pt = [2.6, 1.2, 0.4]
    x, d1, d2 = point_analogs(m, p0, "l4", pt)
    h = 1e-4
    for i in range(ni):
        e = np.zeros(ni)
        e[i] = h
        pp, pm = m.solve(x0 + e, guess=p0), m.solve(x0 - e, guess=p0)
        fd = (pp.q - pm.q)[0] / (2 * h)
        assert np.abs(first[0, scalar_cols, i] - fd).max() < 1e-7
        fd2 = (pp.q - 2 * p0.q + pm.q)[0] / h ** 2
        assert np.abs(sec[0, scalar_cols, i, i] - fd2).max() < 1e-5
        # spherical: the rotation's rate is ω (in the a frame)
        dR = (pp.rot[0, si] - pm.rot[0, si]) / (2 * h) @ p0.rot[0, si].T
        w = np.array([dR[2, 1], dR[0, 2], dR[1, 0]])
        assert np.abs(first[0, c0:c0 + 3, i] - w).max() < 1e-7
        xp, xm = pp.point("l4", pt), pm.point("l4", pt)
        assert np.abs(d1[0, :, i] - (xp - xm) / (2 * h)).max() < 1e-7
        assert np.abs(d2[0, :, i, i] - (xp - 2 * x[0] + xm) / h ** 2).max() < 1e-5
    # a mixed second derivative by the four-point formula
    e0, e1 = np.eye(ni)[0] * h, np.eye(ni)[2] * h
    qs = [m.solve(x0 + s0 * e0 + s1 * e1, guess=p0).q[0] for s0, s1 in
          [(1, 1), (1, -1), (-1, 1), (-1, -1)]]
    fd01 = (qs[0] - qs[1] - qs[2] + qs[3]) / (4 * h * h)
    assert np.abs(sec[0, scalar_cols, 0, 2] - fd01).max() < 1e-5
