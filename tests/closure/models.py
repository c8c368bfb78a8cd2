"""Benchmark mechanisms for the closure tests, each with an independent reference.

- ``n_fourbar``: the IFToMM N-four-bar (cranks and couplers of 1 m), drawn horizontal,
  i.e. at one of its singular configurations; on its parallelogram branch every crank
  turns by the same angle and the couplers translate.
- ``parallelogram``: one parallelogram four-bar drawn flat (all pivots collinear).
- ``andrews``: Andrews' squeezing mechanism (7 bodies, 3 loops) with the constraint
  equations of Hairer & Wanner (Solving ODE II, sec. VII.7) as the reference.
"""
import numpy as np
from scipy.optimize import least_squares

from closure import Mechanism, translation


def n_fourbar(n_cranks=3, length=1.0, shift=None):
    """Cranks ``c0 … c{n-1}`` pivoted on the ground at ``(i L, 0)``, pointing along +x;
    couplers ``k{i}`` join the tips of cranks i and i+1.  Input: joint ``G0``."""
    G = np.eye(4) if shift is None else shift
    cr = [f"c{i}" for i in range(n_cranks)]
    cp = [f"k{i}" for i in range(n_cranks - 1)]
    m = Mechanism(cr + cp)
    for i in range(n_cranks):
        m.add_joint(f"G{i}", "R", "ground", cr[i], at=G @ translation((i * length, 0, 0)))
    for i in range(n_cranks - 1):
        m.add_joint(f"T{i}", "R", cr[i], cp[i], at=G @ translation(((i + 1) * length, 0, 0)))
        m.add_joint(f"U{i}", "R", cp[i], cr[i + 1], at=G @ translation(((i + 2) * length, 0, 0)))
    m.add_input("G0")
    return m


def n_fourbar_reference_rhs(n_cranks=3, length=1.0, mass=1.0, g=9.81):
    """θ̈(θ) of the parallelogram branch (rods of uniform mass, gravity −y): cranks turn
    about their ends, couplers translate with the tips."""
    nc, nk = n_cranks, n_cranks - 1
    inertia = mass * length ** 2 * (nc / 3 + nk)
    moment = mass * g * length * (nc / 2 + nk)

    def rhs(t, y):
        return [y[1], -moment * np.cos(y[0]) / inertia]
    return rhs


def n_fourbar_dynamics(n_cranks=3, length=1.0, mass=1.0, g=9.81):
    from closure import Dynamics
    m = n_fourbar(n_cranks, length)
    d = Dynamics(m, gravity=(0, -g, 0))
    rod = mass * length ** 2 / 12 * np.diag([0.0, 1.0, 1.0])
    for i in range(n_cranks):
        d.add_body(f"c{i}", mass, ((i + 0.5) * length, 0, 0), rod)
    for i in range(n_cranks - 1):
        d.add_body(f"k{i}", mass, ((i + 1.5) * length, 0, 0), rod)
    return m, d


def parallelogram(crank=1.0, ground=2.0):
    """A parallelogram drawn flat: A (0, 0) – B (crank, 0) – C (ground + crank, 0) – D (ground, 0)."""
    m = Mechanism(["crank", "coupler", "rocker"])
    m.add_joint("A", "R", "ground", "crank", at=translation((0, 0, 0)))
    m.add_joint("B", "R", "crank", "coupler", at=translation((crank, 0, 0)))
    m.add_joint("C", "R", "coupler", "rocker", at=translation((ground + crank, 0, 0)))
    m.add_joint("D", "R", "ground", "rocker", at=translation((ground, 0, 0)))
    m.add_input("A")
    return m


# ---------------------------------------------------------------- Andrews' squeezer
AND = dict(xa=-0.06934, ya=-0.00227, xb=-0.03635, yb=0.03273, d=0.028, e=0.02,
           zf=0.02, zt=0.04, rr=0.007, ss=0.035, u=0.04)
#: β, Θ, γ, Φ, δ, Ω, ε at the initial pose (Hairer & Wanner)
AND_Q0 = np.array([-0.0617138900142764496358948458001, 0.0,
                   0.455279819163070380255912382449, 0.222668390165885884674473185609,
                   0.487364979543842550225598953530, -0.222668390165885884674473185609,
                   1.23054744454982119249735015568])


def andrews_constraints(q):
    """The six constraint equations g(β, Θ, γ, Φ, δ, Ω, ε) = 0."""
    b, th, ga, ph, de, om, ep = q
    p = AND
    ex = p["rr"] * np.cos(b) - p["d"] * np.cos(b + th)
    ey = p["rr"] * np.sin(b) - p["d"] * np.sin(b + th)
    return np.array([
        ex - p["ss"] * np.sin(ga) - p["xb"],
        ey + p["ss"] * np.cos(ga) - p["yb"],
        ex - p["e"] * np.sin(ph + de) - p["zt"] * np.cos(de) - p["xa"],
        ey + p["e"] * np.cos(ph + de) - p["zt"] * np.sin(de) - p["ya"],
        ex - p["zf"] * np.cos(om + ep) - p["u"] * np.sin(ep) - p["xa"],
        ey - p["zf"] * np.sin(om + ep) + p["u"] * np.cos(ep) - p["ya"]])


def andrews_points(q):
    """World points O, F, E, G (K4–K5), H (K6–K7) of the Hairer–Wanner coordinates."""
    b, th, ga, ph, de, om, ep = q
    p = AND
    F = np.array([p["rr"] * np.cos(b), p["rr"] * np.sin(b)])
    E = F - p["d"] * np.array([np.cos(b + th), np.sin(b + th)])
    A = np.array([p["xa"], p["ya"]])
    G = A + p["zt"] * np.array([np.cos(de), np.sin(de)])
    H = A + p["u"] * np.array([np.sin(ep), -np.cos(ep)])
    B = np.array([p["xb"], p["yb"]])
    return dict(O=np.zeros(2), F=F, E=E, G=G, H=H, A=A, B=B)


def andrews():
    """The squeezer in the engine, assembled at the initial pose; input: the crank O."""
    P = {k: np.r_[v, 0.0] for k, v in andrews_points(AND_Q0).items()}
    m = Mechanism(["K1", "K2", "K3", "K4", "K5", "K6", "K7"])
    for name, a, b, pt in [("O", "ground", "K1", "O"), ("F", "K1", "K2", "F"),
                           ("E3", "K2", "K3", "E"), ("B", "K3", "ground", "B"),
                           ("E4", "K2", "K4", "E"), ("G", "K4", "K5", "G"),
                           ("A5", "K5", "ground", "A"), ("E6", "K2", "K6", "E"),
                           ("H", "K6", "K7", "H"), ("A7", "K7", "ground", "A")]:
        m.add_joint(name, "R", a, b, at=translation(P[pt]))
    m.add_input("O")
    return m


def andrews_reference(betas):
    """Reference poses along β (continuation with scipy least_squares, small steps)."""
    out, q = [], AND_Q0.copy()
    b0 = AND_Q0[0]
    for beta in betas:
        path = np.linspace(q[0], b0 + beta, 20)
        for bb in path[1:]:
            sol = least_squares(lambda z: andrews_constraints(np.r_[bb, z]), q[1:],
                                xtol=1e-15, ftol=1e-15, gtol=1e-15)
            q = np.r_[bb, sol.x]
        out.append(q.copy())
    return np.array(out)
