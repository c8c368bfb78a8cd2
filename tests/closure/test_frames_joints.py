import numpy as np
import pytest

from closure import (JOINT_KINDS, Mechanism, MechanismError, adjoint, euler_zxz, exp_se3,
                     frame_from_points, inverse, log_se3, rot_x, rot_z, transform, vee)
from closure.joints import Joint

rng = np.random.default_rng(7)


def test_exp_log_roundtrip_including_small_and_near_pi_angles():
    xi = rng.normal(size=(500, 6))
    ang = np.concatenate([rng.uniform(0, np.pi - 1e-6, 300), np.full(100, 1e-9),
                          np.full(100, np.pi - 1e-9)])
    xi[:, 3:] *= (ang / np.linalg.norm(xi[:, 3:], axis=1))[:, None]
    T = exp_se3(xi)
    assert np.abs(log_se3(T) - xi).max() < 1e-8
    R = T[:, :3, :3]
    assert np.abs(R @ np.swapaxes(R, 1, 2) - np.eye(3)).max() < 1e-14


def test_adjoint_matches_conjugation():
    T = exp_se3(rng.normal(size=6))
    xi = rng.normal(size=6)
    hat = lambda x: np.block([[np.array([[0, -x[5], x[4]], [x[5], 0, -x[3]], [-x[4], x[3], 0]]),
                               x[:3, None]], [np.zeros((1, 4))]])
    assert np.allclose(adjoint(T) @ xi, vee(T @ hat(xi) @ inverse(T)), atol=1e-13)


def test_frame_from_points_rule_and_errors():
    F = frame_from_points([1, 2, 3], [2, 2.5, 3], [1, 2, 5])
    assert np.allclose(F[:3, 2], [0, 0, 1]) and np.allclose(F[:3, 3], [1, 2, 3])
    assert np.allclose(F[:3, 0], [2, 1, 0] / np.sqrt(5))
    with pytest.raises(MechanismError, match="collinear"):
        frame_from_points([0, 0, 0], [0, 0, 2], [0, 0, 1])
    with pytest.raises(MechanismError, match="coincides"):
        frame_from_points([0, 0, 0], [1, 0, 0], [0, 0, 0])


def test_euler_zxz_roundtrip_and_singular():
    ang = np.array([0.3, 1.2, -2.0])
    R = rot_z(ang[0]) @ rot_x(ang[1]) @ rot_z(ang[2])
    assert np.allclose(euler_zxz(R), ang)
    R0 = rot_z(0.4) @ rot_z(0.5)                     # θ = 0: only ψ + φ defined
    e = euler_zxz(R0)
    assert abs(e[1]) < 1e-15 and np.isclose(e[0] + e[2], 0.9)


@pytest.mark.parametrize("kind", list(JOINT_KINDS))
def test_joint_matrix_is_rigid_and_derivative_is_the_twist(kind):
    j = Joint("j", kind, "a", "b", np.eye(4), np.eye(4), pitch=0.37 if kind == "H" else 0.0)
    q = rng.normal(size=(1, j.nq))
    rot = exp_se3(np.r_[0, 0, 0, rng.normal(size=3)])[None, :3, :3] if kind == "S" else None
    A = j.matrix(q, rot)[0]
    assert np.abs(A[:3, :3] @ A[:3, :3].T - np.eye(3)).max() < 1e-14
    assert np.isclose(np.linalg.det(A[:3, :3]), 1.0) and np.allclose(A[3], [0, 0, 0, 1])
    h = 1e-6
    for k, (prefix, xi, _) in enumerate(j.columns(q)):
        e = np.zeros(j.nv)
        e[k] = h
        if kind == "S":
            Ap = j.matrix(q, j.update(q, rot, e[None])[1])[0]
            Am = j.matrix(q, j.update(q, rot, -e[None])[1])[0]
        else:
            Ap, Am = j.matrix(q + e, None)[0], j.matrix(q - e, None)[0]
        dA = (Ap - Am) / (2 * h) @ inverse(A)
        P = np.eye(4) if prefix is None else prefix[0]
        assert np.abs(vee(dA) - adjoint(P) @ xi).max() < 1e-8


def test_hooke_joint_frames_follow_seed_rule():
    j = Joint("u", "U", "a", "b", np.eye(4), np.eye(4))
    A = j.matrix(np.array([[0.4, -0.7]]))[0]
    za, zb = np.array([0, 0, 1.0]), A[:3, 2]
    assert abs(za @ zb) < 1e-15                       # the pins are perpendicular
    t = np.cross(za, zb)                              # seed 000's cross normal
    # seed: φ_seed (from X_a to t about Z_a) = φ + π/2; θ_seed (from t to X_b about Z_b) = θ − π/2
    assert np.isclose(np.arctan2(t[1], t[0]), 0.4 + np.pi / 2)
    xb = A[:3, 0]
    assert np.isclose(np.arctan2(np.cross(t, xb) @ zb, t @ xb), -0.7 - np.pi / 2 + 2 * np.pi
                      if -0.7 - np.pi / 2 < -np.pi else -0.7 - np.pi / 2)


def test_joint_coordinates_read_from_frame_pairs():
    m = Mechanism(["b"])
    F = frame_from_points([1, 0, 0], [2, 0, 0], [1, 0, 1])
    m.add_joint("c", "C", "ground", "b", at=(F, F @ transform(rot_z(0.3), [0, 0, 0.2])))
    assert np.allclose(m._q0[0], [0.3, 0.2])
    with pytest.raises(MechanismError, match="not related by a R joint"):
        m.add_joint("r", "R", "ground", "b", at=(F, F @ transform(rot_x(0.3))))


def test_structure_errors_are_clear():
    m = Mechanism(["a"])
    with pytest.raises(MechanismError, match="link_b 'zz' is not a link"):
        m.add_joint("j", "R", "ground", "zz", at=np.eye(4))
    with pytest.raises(MechanismError, match="kind 'X' unknown"):
        m.add_joint("j", "X", "ground", "a", at=np.eye(4))
    with pytest.raises(MechanismError, match="pitch"):
        m.add_joint("j", "H", "ground", "a", at=np.eye(4))
    with pytest.raises(MechanismError, match="proper rotation"):
        m.add_joint("j", "R", "ground", "a", at=np.diag([1, 1, -1, 1.0]))
    m.add_joint("j", "R", "ground", "a", at=np.eye(4))
    with pytest.raises(MechanismError, match="index 1 is out of range"):
        m.add_input("j", 1)
    m2 = Mechanism(["a", "lost"])
    m2.add_joint("j", "R", "ground", "a", at=np.eye(4))
    m2.add_input("j")
    with pytest.raises(MechanismError, match="not connected to the ground.*lost"):
        m2.solve(0.1)
    m3 = Mechanism(["a"])
    m3.add_joint("j", "C", "ground", "a", at=np.eye(4))
    m3.add_input("j", 0)
    m3.add_input("j", 1)
    assert m3.mobility == 2
    m4 = Mechanism(["s"])
    m4.add_joint("s", "S", "ground", "s", at=np.eye(4))
    with pytest.raises(MechanismError, match="spherical"):
        m4.add_input("s")


def test_more_inputs_than_mobility_is_an_error():
    from linkwright.references import fourbar
    m, _ = fourbar(1.0, 3.0, 2.5, 3.2, t2_0=0.3)
    m.add_input("B")
    with pytest.raises(MechanismError, match="2 inputs declared but the mechanism's mobility"):
        m.solve([0.1, 0.2])


def test_an_input_declared_twice_is_refused_and_many_inputs_keep_their_order():
    from closure.frames import transform
    m = Mechanism()
    for v in range(300):
        m.add_link(f"L{v}")
        m.add_joint(f"j{v}", "C", "ground", f"L{v}", at=transform(None, [v, 0.0, 0.0]))
        m.add_input(f"j{v}", 1)
        m.add_input(f"j{v}", 0)
    assert m.inputs[:4] == [(0, 1), (0, 0), (1, 1), (1, 0)] and len(m.inputs) == 600
    with pytest.raises(MechanismError, match=r"j7\[0\] is already an input"):
        m.add_input("j7", 0)
