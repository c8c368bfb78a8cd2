"""Elastic links: beam end stiffness against textbook closed forms, and beams inside
mechanisms (series and parallel) against compliance / stiffness addition."""
import numpy as np
import pytest

from closure import Mechanism, exp_so3
from stiffness import (StiffnessError, beam_compliance, beam_stiffness, of_mechanism,
                       transform_stiffness, twist_transform)

STEEL = dict(E=2.1e11, G=8.1e10)


def tube(d=0.04, t=0.004):
    """Section properties of a round tube (m², m⁴)."""
    ro, ri = d / 2, d / 2 - t
    A = np.pi * (ro**2 - ri**2)
    I = np.pi / 4 * (ro**4 - ri**4)
    return dict(area=A, Iy=I, Iz=I, J=2 * I)


def rect(b=0.03, h=0.05):
    return dict(area=b * h, Iy=b * h**3 / 12, Iz=h * b**3 / 12, J=0.229 * h * b**3)


def test_cantilever_closed_forms():
    L, sec = 0.8, rect()
    E, G = STEEL["E"], STEEL["G"]
    C = beam_compliance(L, **STEEL, **sec)
    K = beam_stiffness(L, **STEEL, **sec)
    assert np.isclose(1 / C[1, 1], 3 * E * sec["Iz"] / L**3, rtol=1e-14)   # end free to turn
    assert np.isclose(1 / C[2, 2], 3 * E * sec["Iy"] / L**3, rtol=1e-14)
    assert np.isclose(K[0, 0], E * sec["area"] / L, rtol=1e-12)
    assert np.isclose(K[3, 3], G * sec["J"] / L, rtol=1e-12)
    assert np.isclose(K[1, 1], 12 * E * sec["Iz"] / L**3, rtol=1e-12)     # end rotation held
    assert np.isclose(K[1, 5], -6 * E * sec["Iz"] / L**2, rtol=1e-12)
    assert np.isclose(K[5, 5], 4 * E * sec["Iz"] / L, rtol=1e-12)
    assert np.isclose(K[2, 4], 6 * E * sec["Iy"] / L**2, rtol=1e-12)
    # a tip force along y turns the end about +z (the slope dy/dx)
    d = C @ np.r_[0, 1.0, 0, 0, 0, 0]
    assert d[5] > 0 and np.isclose(d[5], L**2 / (2 * E * sec["Iz"]), rtol=1e-14)
    # Timoshenko: shear adds L / (G κA) to the tip deflection
    Cs = beam_compliance(L, **STEEL, **sec, shear_area_y=5 / 6 * sec["area"])
    assert np.isclose(Cs[1, 1] - C[1, 1], L / (G * 5 / 6 * sec["area"]), rtol=1e-12)


@pytest.mark.parametrize("kw, arg", [(dict(length=0.0), "length"), (dict(E=-1.0), "E"),
                                     (dict(area=float("nan")), "area"), (dict(J="x"), "J"),
                                     (dict(shear_area_y=0.0), "shear_area_y")])
def test_beam_bad_inputs(kw, arg):
    args = dict(length=0.8, **STEEL, **rect()) | kw
    with pytest.raises(StiffnessError, match=arg):
        beam_stiffness(**args)


def frame(o, R=np.eye(3)):
    F = np.eye(4)
    F[:3, :3], F[:3, 3] = R, o
    return F


def beam_frame(a, b):
    """A frame at b with x along the beam from a to b."""
    x = (b - a) / np.linalg.norm(b - a)
    y = np.cross([0.3, -0.2, 1.0], x)
    y /= np.linalg.norm(y)
    return frame(b, np.c_[x, y, np.cross(x, y)])


def test_cantilever_link_alone():
    """A link clamped to the ground by a locked joint: its tip stiffness is the beam's."""
    root, tip = np.r_[0.2, -0.1, 0.3], np.r_[0.9, 0.4, 0.5]
    F = beam_frame(root, tip)
    Kb = beam_stiffness(np.linalg.norm(tip - root), **STEEL, **tube())
    m = Mechanism(["beam"])
    m.add_joint("X", "R", "ground", "beam", at=frame(root))
    m.add_input("X")
    pose = m.solve(0.0)
    res = of_mechanism(m, pose, platform="beam", locked=["X"],
                       link_springs=[("beam", "X", F, Kb)], frame=(F[:3, :3].T, F[:3, 3]))
    assert res.rigid[0] == 0 and res.elastic == ["beam@X"]
    assert np.abs(res.K[0] - Kb).max() < 1e-10 * np.abs(Kb).max()
    # about the root, world axes: the congruence of the tip stiffness
    at_root = of_mechanism(m, pose, platform="beam", locked=["X"],
                           link_springs=[("beam", "X", F, Kb)], frame=(np.eye(3), root))
    Kw = transform_stiffness(Kb, F[:3, :3], -F[:3, :3].T @ (F[:3, 3] - root))
    assert np.abs(at_root.K[0] - Kw).max() < 1e-10 * np.abs(Kw).max()


def test_two_beams_in_series_add_compliances():
    """An L-shaped arm of two beams: the tip compliance is the sum of each beam's compliance
    carried to the tip (displacements: T* C T*ᵀ)."""
    a, b, c = np.r_[0, 0, 0.0], np.r_[0.7, 0, 0.1], np.r_[0.8, 0.5, 0.3]
    F1, F2 = beam_frame(a, b), beam_frame(b, c)
    C1 = beam_compliance(np.linalg.norm(b - a), **STEEL, **rect())
    C2 = beam_compliance(np.linalg.norm(c - b), **STEEL, **tube())
    m = Mechanism(["b1", "b2"])
    m.add_joint("X", "R", "ground", "b1", at=frame(a))
    m.add_joint("Y", "R", "b1", "b2", at=frame(b, exp_so3(np.r_[0.3, 0.2, 0.1])))
    m.add_input("X")
    m.add_input("Y")
    pose = m.solve(np.zeros(2))
    R, p = F2[:3, :3].T, F2[:3, 3]                                # the tip frame
    res = of_mechanism(m, pose, platform="b2", locked=["X", "Y"],
                       link_springs=[("b1", "X", F1, np.linalg.inv(C1)),
                                     ("b2", "Y", F2, np.linalg.inv(C2))], frame=(R, p))
    # beam 1's end displacement (about b, its axes) seen at the tip c in the tip frame
    T1 = twist_transform(R @ F1[:3, :3], F1[:3, :3].T @ (c - b))
    C_ref = T1 @ C1 @ T1.T + C2
    assert np.abs(res.C[0] - C_ref).max() < 1e-10 * np.abs(C_ref).max()


def test_two_beams_in_parallel_add_stiffnesses():
    """A platform welded to two cantilevers (one loop): K is the sum of the beams' tip
    stiffnesses carried to the platform frame (wrenches: T K Tᵀ)."""
    a1, b1 = np.r_[0, 0, 0.0], np.r_[1.0, 0, 0.2]
    a2, b2 = np.r_[0, 1.0, 0.0], np.r_[1.1, 1.2, 0.1]
    F1, F2 = beam_frame(a1, b1), beam_frame(a2, b2)
    K1 = beam_stiffness(np.linalg.norm(b1 - a1), **STEEL, **tube())
    K2 = beam_stiffness(np.linalg.norm(b2 - a2), **STEEL, **rect())
    m = Mechanism(["beam1", "beam2", "platform"])
    m.add_joint("X1", "R", "ground", "beam1", at=frame(a1))
    m.add_joint("Y1", "R", "beam1", "platform", at=frame(b1))
    m.add_joint("X2", "R", "ground", "beam2", at=frame(a2))
    m.add_joint("Y2", "R", "beam2", "platform", at=frame(b2))
    m.add_input("X1")
    pose = m.solve(0.0)
    R, p = exp_so3(np.r_[0.1, 0.5, -0.3]), np.r_[0.6, 0.7, 0.4]
    res = of_mechanism(m, pose, platform="platform", locked=["X1", "Y1", "X2", "Y2"],
                       link_springs=[("beam1", "X1", F1, K1), ("beam2", "X2", F2, K2)],
                       frame=(R, p))
    K_ref = sum(transform_stiffness(Ki, R @ Fi[:3, :3], Fi[:3, :3].T @ (p - Fi[:3, 3]))
                for Ki, Fi in ((K1, F1), (K2, F2)))
    assert res.rigid[0] == 0
    assert np.abs(res.K[0] - K_ref).max() < 1e-9 * np.abs(K_ref).max()


@pytest.mark.parametrize("spec, arg", [
    ("beam", "link_springs"), ([("beam", "X")], "link_springs[0]"),
    ([("nothing", "X", np.eye(4), np.eye(6))], "link_springs[0]: link"),
    ([("beam", "Z", np.eye(4), np.eye(6))], "link_springs[0]: joint"),
    ([("beam", "X", np.eye(3), np.eye(6))], "link_springs[0]: frame"),
    ([("beam", "X", np.eye(4), -np.eye(6))], "link_springs[0]: K"),
    ([("beam", "X", np.eye(4), np.eye(5))], "link_springs[0]: K")])
def test_link_spring_bad_inputs(spec, arg):
    m = Mechanism(["beam"])
    m.add_joint("X", "R", "ground", "beam", at=np.eye(4))
    m.add_input("X")
    with pytest.raises(StiffnessError) as info:
        of_mechanism(m, m.solve(0.0), platform="beam", locked=["X"], link_springs=spec)
    assert arg in str(info.value), str(info.value)
