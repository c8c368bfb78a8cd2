"""Elastic links: beam end stiffness against textbook closed forms, and beams inside
mechanisms (series and parallel) against compliance / stiffness addition."""
import numpy as np
import pytest

from closure import Mechanism, exp_so3
from stiffness import (SingularPoseError, StiffnessError, beam_compliance, beam_geometric_stiffness,
                       beam_stiffness, of_mechanism,
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


@pytest.mark.parametrize("kw, arg", [(dict(length=0.0), "length"), (dict(length="1"), "length"),
                                     (dict(axial_force=np.nan), "axial_force")])
def test_geometric_stiffness_bad_inputs(kw, arg):
    with pytest.raises(StiffnessError, match=arg):
        beam_geometric_stiffness(**(dict(length=1.0, axial_force=10.0) | kw))


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


# ---------------------------------------------------------------- elastic links under load
def _column(P, E=STEEL["E"], G=STEEL["G"], L=1.2, sec=None):
    """A vertical cantilever column (a tube) clamped to the ground by a locked joint, loaded
    at its tip by ``P`` (N, compression positive): its loaded tip stiffness, tip frame."""
    sec = sec or tube()
    root, tip = np.r_[0.1, 0.2, 0.0], np.r_[0.1, 0.2, L]
    F = frame(tip, np.c_[[0, 0, 1.0], [1.0, 0, 0], [0, 1.0, 0]])      # x up the column
    Kb = beam_stiffness(L, **STEEL, **sec)
    m = Mechanism(["beam"])
    m.add_joint("X", "R", "ground", "beam", at=frame(root))
    m.add_input("X")
    f = np.r_[0, 0, -P]
    return of_mechanism(m, m.solve(0.0), platform="beam", locked=["X"],
                        link_springs=[("beam", "X", F, Kb, L)], frame=(F[:3, :3].T, tip),
                        wrench=np.r_[f, np.cross(tip, f)])


def test_column_under_axial_compression_buckles_at_the_models_critical_load():
    """A cantilever column with a compressive tip load P: with the tip free to turn, its
    lateral stiffness is the Schur complement of the tip block of K_E − P K_G (cubic beam
    element, Przemieniecki), (EI/L³)(12 − 5.2p + 0.15p²)/(4 − 2p/15) with p = PL²/EI; it
    vanishes at p = (5.2 − √19.84)/0.3 = 2.486, 0.75 % above Euler's π²/4."""
    L, sec = 1.2, tube()
    EI = STEEL["E"] * sec["Iz"]
    p_cr = (5.2 - np.sqrt(19.84)) / 0.3
    assert abs(p_cr / (np.pi**2 / 4) - 1) < 0.008                       # Euler's column
    k0 = None
    for frac in (0.0, 0.3, 0.9, 0.99):
        res = _column(frac * p_cr * EI / L**2, L=L, sec=sec)
        p = frac * p_cr
        k_ref = EI / L**3 * (12 - 5.2 * p + 0.15 * p * p) / (4 - 2 * p / 15)
        for axis in (1, 2):                                              # both bending planes
            assert np.isclose(1 / res.C[0][axis, axis], k_ref, rtol=1e-9, atol=0)
        assert np.isclose(res.K[0][0, 0], STEEL["E"] * sec["area"] / L, rtol=1e-9)
        k0 = k_ref if k0 is None else k0
    assert 1 / res.C[0][1, 1] < 0.011 * k0                              # 1 % below P_cr
    with pytest.raises(SingularPoseError, match="wrench: .*critical"):
        _column(p_cr * EI / L**2, L=L, sec=sec)
    # without the beam's length its own P-δ term is absent: the tip stiffness stays 3EI/L³
    m = Mechanism(["beam"])
    m.add_joint("X", "R", "ground", "beam", at=np.eye(4))
    m.add_input("X")
    F = frame(np.r_[0, 0, L], np.c_[[0, 0, 1.0], [1.0, 0, 0], [0, 1.0, 0]])
    res = of_mechanism(m, m.solve(0.0), platform="beam", locked=["X"],
                       link_springs=[("beam", "X", F, beam_stiffness(L, **STEEL, **sec))],
                       frame=(F[:3, :3].T, F[:3, 3]), wrench=[0, 0, -0.5 * p_cr * EI / L**2, 0, 0, 0])
    assert np.isclose(1 / res.C[0][1, 1], 3 * EI / L**3, rtol=1e-9)


def _deformation_joints(m, root, body, F, tag):
    """A beam's deformation as six input joints from ``root`` to ``body``: slides along
    F's x, y, z, then revolutes about them through F's origin (the tip)."""
    chain = [root] + [f"t{tag}{k}" for k in range(5)] + [body]
    for link in chain[1:-1]:
        m.add_link(link)
    for k in range(6):
        Fk = F.copy()
        Fk[:3, :3] = F[:3, :3][:, [(k + 1) % 3, (k + 2) % 3, k % 3]]       # z along x, y, z
        m.add_joint(f"d{tag}{k}", "P" if k < 3 else "R", chain[k], chain[k + 1], at=Fk)
        m.add_input(f"d{tag}{k}")


def _reference_compliance(ref, springs, c, f, h=1e-4, hd=1e-6):
    """C about the platform point ``c`` under the force ``f`` at it, from the reference
    machine ``ref`` (its inputs: the beams' deformation joints, six per beam in the order
    of ``springs``): the equilibrium's Hessian H in the inputs (the model's elastic energy
    ½ ξᵀ (K + N K_G) ξ + τ₀ᵀ ξ with exact derivatives of ξ = (t, log R), the load's −f·p
    by central second differences of solved poses) and A = ∂Δ/∂s; C = A H⁻¹ Aᵀ."""
    from closure import log_se3
    n = 6 * len(springs)
    E = np.eye(n)
    pts = [E[i] * s1 + E[j] * s2 for i in range(n) for j in range(i, n)
           for s1 in (h, -h) for s2 in (h, -h)]
    pts += [E[i] * s for i in range(n) for s in (hd, -hd)]
    Tp = ref.solve(np.array(pts)).link_frame("platform")
    pc = Tp[:, :3, :3] @ c + Tp[:, :3, 3]            # c is on the platform (assembly = here)
    k = 0
    Hp = np.zeros((n, n, 3))                         # ∂²p_c/∂s²
    for i in range(n):
        for j in range(i, n):
            Hp[i, j] = Hp[j, i] = (pc[k] - pc[k + 1] - pc[k + 2] + pc[k + 3]) / (4 * h * h)
            k += 4
    D = log_se3(Tp[k:])                              # platform twists about the origin
    A0 = (D[0::2] - D[1::2]).T / (2 * hd)            # (6, n)
    A = np.r_[A0[:3] + np.cross(A0[3:].T, c).T, A0[3:]]   # Δ about c
    tau0 = A[:3].T @ f                               # statics: ∂U/∂s = ∂(f·p_c)/∂s
    H = -np.einsum("ijk,k->ij", Hp, f)
    for leg, spring in enumerate(springs):
        sl = slice(6 * leg, 6 * leg + 6)
        t = tau0[sl]
        Kt = spring[3] + beam_geometric_stiffness(spring[4], t[0])
        M = np.zeros((6, 6))                         # τ₀ · ∂²log(Rx Ry Rz)
        M[3, 4] = M[4, 3] = t[5] / 2
        M[3, 5] = M[5, 3] = -t[4] / 2
        M[4, 5] = M[5, 4] = t[3] / 2
        H[sl, sl] += Kt + M
    return A @ np.linalg.solve(H, A.T), tau0


def _rps_beams(reference):
    """An irregular 3-RPS whose legs past the (locked) actuator are steel beams from the slide
    to the spherical joint.  ``reference``: the same machine with each beam's deformation
    as six joints (slides along the tip frame's axes, then revolutes about them at the
    tip), all inputs, the actuators merged into the legs' rigid roots."""
    base = np.array([[1.0, 0.1, 0], [-0.45, 0.9, 0.05], [-0.6, -0.8, 0]])
    plat = np.array([[0.5, 0.05, 1.0], [-0.2, 0.45, 1.1], [-0.3, -0.4, 0.95]])
    tangent = np.c_[-base[:, 1], base[:, 0], np.zeros(3)]
    m = Mechanism([f"a{i}" for i in range(3)] + [f"b{i}" for i in range(3)] + ["platform"])
    springs, frames = [], []
    for i in range(3):
        leg = plat[i] - base[i]
        x = leg / np.linalg.norm(leg)
        y = np.cross(tangent[i], x)
        y /= np.linalg.norm(y)
        F = frame(plat[i], np.c_[x, y, np.cross(x, y)])
        frames.append(F)
        tz = tangent[i] / np.linalg.norm(tangent[i])
        Ra = frame(base[i], np.c_[np.cross(y, tz), y, tz])
        m.add_joint(f"R{i}", "R", "ground", f"a{i}", at=Ra)
        if reference:
            _deformation_joints(m, f"a{i}", f"b{i}", F, str(i))
        else:
            m.add_joint(f"P{i}", "P", f"a{i}", f"b{i}", at=frame(base[i], F[:3, :3][:, [1, 2, 0]]))
            m.add_input(f"P{i}")
            springs.append((f"b{i}", f"P{i}", F, beam_stiffness(np.linalg.norm(leg), **STEEL,
                                                                **tube(0.03, 0.003)),
                            np.linalg.norm(leg)))
        m.add_joint(f"S{i}", "S", f"b{i}", "platform", at=frame(plat[i]))
    return m, springs, frames


def test_loaded_beams_in_a_3rps_against_the_equilibrium_by_finite_differences():
    """Elastic legs under a load (a force at a platform point, about which the loaded
    stiffness is symmetric) against the second-order equilibrium computed independently:
    the machine with each beam's deformation as six input joints, solved by the engine.
    The elastic energy is that of the model, ½ ξᵀ (K + N K_G) ξ + τ₀ᵀ ξ in each beam's
    tip displacement ξ = (t, log R) relative to the loaded state (its derivatives in the
    slide/revolute coordinates are exact: ∂ξ/∂s = I, and ∂²log R the Baker–Campbell–
    Hausdorff term ½ eⱼ × eₖ); the spring forces τ₀ balance the load (statics by central
    differences of solved poses); the load's potential −f·p(s) is differentiated twice by
    central differences of solved poses.  Then C = A H⁻¹ Aᵀ with A = ∂Δ/∂s (rel. 1e-6)."""
    m, springs, _ = _rps_beams(False)
    ref, _, _ = _rps_beams(True)
    c = np.r_[0.15, 0.05, 1.2]                       # the load's point on the platform
    f = np.r_[2000.0, -1500.0, -9000.0]
    pose = m.solve(np.zeros(3))
    res = of_mechanism(m, pose, platform="platform", link_springs=springs,
                       wrench=np.r_[f, np.cross(c, f)], frame=(np.eye(3), c))
    unloaded = of_mechanism(m, pose, platform="platform", link_springs=springs,
                            frame=(np.eye(3), c))
    assert res.rigid[0] == 0 and res.locked == ["P0", "P1", "P2"]

    C_ref, _ = _reference_compliance(ref, springs, c, f)
    assert np.abs(res.C[0] - C_ref).max() < 1e-6 * np.abs(C_ref).max()
    assert np.abs(unloaded.C[0] - C_ref).max() > 1e-3 * np.abs(C_ref).max()


def test_loaded_serial_beams_carry_moments_against_the_equilibrium():
    """Two beams in series (an L-shaped arm clamped to the ground, its joints locked)
    under a force at the tip: the beams carry moments and shear as well as axial force, so
    the load's transport along the deflected first beam and the rotation terms count;
    against the same independent equilibrium as the 3-RPS (rel. 1e-6)."""
    a, b, c = np.r_[0.0, 0, 0], np.r_[0.0, 0, 0.9], np.r_[0.5, 0.3, 0.95]
    F1, F2 = beam_frame(a, b), beam_frame(b, c)
    L1, L2 = np.linalg.norm(b - a), np.linalg.norm(c - b)
    K1 = beam_stiffness(L1, **STEEL, **tube())
    K2 = beam_stiffness(L2, **STEEL, **rect(0.02, 0.03))
    springs = [("b1", "X", F1, K1, L1), ("platform", "Y", F2, K2, L2)]
    m = Mechanism(["b1", "platform"])
    m.add_joint("X", "R", "ground", "b1", at=frame(a))
    m.add_joint("Y", "R", "b1", "platform", at=frame(b))
    m.add_input("X")
    m.add_input("Y")
    ref = Mechanism(["b1", "platform"])
    _deformation_joints(ref, "ground", "b1", F1, "1")
    _deformation_joints(ref, "b1", "platform", F2, "2")
    f = np.r_[-300.0, 200.0, -2500.0]
    tip = c + [0.02, -0.01, 0.0]                      # the load's point on the platform
    kw = dict(platform="platform", locked=["X", "Y"], link_springs=springs,
              frame=(np.eye(3), tip))
    res = of_mechanism(m, m.solve(np.zeros(2)), wrench=np.r_[f, np.cross(tip, f)], **kw)
    unloaded = of_mechanism(m, m.solve(np.zeros(2)), **kw)
    C_ref, tau0 = _reference_compliance(ref, springs, tip, f)
    assert np.abs(tau0[3:6]).max() > 100 and np.abs(tau0[:3]).max() > 100   # moments, forces
    assert np.abs(res.C[0] - C_ref).max() < 1e-6 * np.abs(C_ref).max()
    assert np.abs(unloaded.C[0] - C_ref).max() > 1e-3 * np.abs(C_ref).max()


def test_zero_load_through_the_explicit_chains_equals_the_unloaded_stiffness():
    """Invariance: under a zero wrench, the explicit deformation chains (the loaded path)
    give the unloaded K of the virtual columns, here with springs on both sides of one
    joint and two on one link."""
    a, b, c = np.r_[0.0, 0, 0], np.r_[0.1, 0, 0.9], np.r_[0.5, 0.3, 0.95]
    F1, F1b, F2 = beam_frame(a, b), beam_frame(b, a), beam_frame(b, c)
    springs = [("b1", "X", F1, beam_stiffness(0.9, **STEEL, **tube())),
               ("b1", "Y", F1b, beam_stiffness(0.9, **STEEL, **rect()), 0.9),
               ("platform", "Y", F2, beam_stiffness(0.6, **STEEL, **rect(0.02, 0.03)), 0.6)]
    m = Mechanism(["b1", "platform"])
    m.add_joint("X", "R", "ground", "b1", at=frame(a))
    m.add_joint("Y", "R", "b1", "platform", at=frame(b, exp_so3(np.r_[0.2, 0.1, 0.3])))
    m.add_input("X")
    m.add_input("Y")
    pose = m.solve(np.r_[0.3, -0.2])
    kw = dict(platform="platform", springs={"X": 5e4}, locked=["Y"], link_springs=springs,
              frame=(exp_so3(np.r_[0.1, 0.4, 0.2]), c))
    ref = of_mechanism(m, pose, **kw)
    res = of_mechanism(m, pose, wrench=np.zeros(6), **kw)
    assert res.loaded and not ref.loaded
    assert res.elastic == ref.elastic == ["X", "b1@X", "b1@Y", "platform@Y"]
    assert np.abs(res.K[0] - ref.K[0]).max() < 1e-10 * np.abs(ref.K[0]).max()
    assert res.condition[0] == ref.condition[0]
    with pytest.raises(StiffnessError, match=r"link_springs\[3\]: the link 'b1' is given two"):
        of_mechanism(m, pose, wrench=np.zeros(6), **{**kw, "link_springs": springs + springs[:1]})
