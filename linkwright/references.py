"""Reference mechanisms with closed-form solutions, shared by the tests and the benchmarks."""
import numpy as np

from closure import Mechanism, frame_from_points, rot_x, rot_z, transform, translation


def dh(theta, a, alpha):
    """Denavit–Hartenberg step Rz(θ) Tx(a) Rx(α)."""
    return transform(rot_z(theta)) @ translation([a, 0, 0]) @ transform(rot_x(alpha))


# ---------------------------------------------------------------- planar four-bar
def freudenstein(t2, a, b, c, d, branch=1):
    """Output angle θ4 and coupler angle θ3 of a four-bar (ground d along x, crank a at the
    origin, coupler b, rocker c pivoted at (d, 0)) by Freudenstein's equation."""
    K1, K2, K3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
    A = np.cos(t2) - K1 - K2 * np.cos(t2) + K3
    B = -2 * np.sin(t2)
    C = K1 - (K2 + 1) * np.cos(t2) + K3
    t4 = 2 * np.arctan2(-B + branch * np.sqrt(B * B - 4 * A * C), 2 * A)
    Bx, By = a * np.cos(t2), a * np.sin(t2)
    Cx, Cy = d + c * np.cos(t4), c * np.sin(t4)
    t3 = np.arctan2(Cy - By, Cx - Bx)
    return t3, t4


def fourbar_rates(t2, w2, al2, a, b, c, d, branch=1):
    """Closed-form angular velocities and accelerations of coupler (3) and rocker (4)."""
    t3, t4 = freudenstein(t2, a, b, c, d, branch)
    w3 = a * w2 * np.sin(t4 - t2) / (b * np.sin(t3 - t4))
    w4 = a * w2 * np.sin(t2 - t3) / (c * np.sin(t4 - t3))
    # loop a e^{i t2} + b e^{i t3} - c e^{i t4} - d = 0, differentiated twice
    A_, B_ = c * np.sin(t4), b * np.sin(t3)
    D_, E_ = c * np.cos(t4), b * np.cos(t3)
    C_ = a * al2 * np.sin(t2) + a * w2 ** 2 * np.cos(t2) + b * w3 ** 2 * np.cos(t3) \
        - c * w4 ** 2 * np.cos(t4)
    F_ = a * al2 * np.cos(t2) - a * w2 ** 2 * np.sin(t2) - b * w3 ** 2 * np.sin(t3) \
        + c * w4 ** 2 * np.sin(t4)
    al4 = (C_ * E_ - B_ * F_) / (A_ * E_ - B_ * D_)
    al3 = (C_ * D_ - A_ * F_) / (A_ * E_ - B_ * D_)
    return (t3, t4), (w3, w4), (al3, al4)


def fourbar(a, b, c, d, t2_0, branch=1, origin_shift=None):
    """A planar four-bar in the engine, assembled at crank angle ``t2_0``.

    Joints: A ground→crank, B crank→coupler, C coupler→rocker, D ground→rocker;
    joint values are the angles relative to the assembly pose.
    """
    t3, t4 = freudenstein(t2_0, a, b, c, d, branch)
    P = {"A": (0, 0, 0), "B": (a * np.cos(t2_0), a * np.sin(t2_0), 0),
         "C": (d + c * np.cos(t4), c * np.sin(t4), 0), "D": (d, 0, 0)}
    G = np.eye(4) if origin_shift is None else origin_shift
    m = Mechanism(["crank", "coupler", "rocker"])
    for name, la, lb in [("A", "ground", "crank"), ("B", "crank", "coupler"),
                         ("C", "coupler", "rocker"), ("D", "ground", "rocker")]:
        m.add_joint(name, "R", la, lb, at=G @ translation(P[name]))
    m.add_input("A")
    return m, (t3, t4)


def fourbar_chain(n, a=1.0, b=3.0, c=2.5, d=3.2, t2_0=0.3):
    """``n`` planar four-bars in series, one input: four-bar k's rocker is the crank of
    four-bar k + 1 (pivot at x = (k + 1) d, crank length a), assembled at crank angle
    ``t2_0``.  ``n`` loops sharing one joint each: the unknowns' Jacobian is block
    bidiagonal."""
    m = Mechanism(["crank"] + [f"{k}_{x}" for k in range(n) for x in ("coupler", "rocker")])
    m.add_joint("A0", "R", "ground", "crank", at=translation((0, 0, 0)))
    crank, t2 = "crank", t2_0
    for k in range(n):
        x0 = k * d
        t3, t4 = freudenstein(t2, a, b, c, d, 1)
        m.add_joint(f"B{k}", "R", crank, f"{k}_coupler",
                    at=translation((x0 + a * np.cos(t2), a * np.sin(t2), 0)))
        m.add_joint(f"C{k}", "R", f"{k}_coupler", f"{k}_rocker",
                    at=translation((x0 + d + c * np.cos(t4), c * np.sin(t4), 0)))
        m.add_joint(f"D{k}", "R", "ground", f"{k}_rocker", at=translation((x0 + d, 0, 0)))
        crank, t2 = f"{k}_rocker", t4
    m.add_input("A0")
    return m


# ---------------------------------------------------------------- spatial RSSR
RSSR = dict(a=1.0, b=2.5, c=1.6, P0=np.array([2.0, 0.5, 0.8]), u=np.array([0.2, 1.0, 0.3]))


def rssr_frame():
    u = RSSR["u"] / np.linalg.norm(RSSR["u"])
    e1 = np.cross(u, [0, 0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    return u, e1, e2


def rssr_output(phi, branch):
    """Closed-form rocker angle ψ of the RSSR (crank angle φ about z at the origin)."""
    a, b, c, P0 = RSSR["a"], RSSR["b"], RSSR["c"], RSSR["P0"]
    u, e1, e2 = rssr_frame()
    A = np.stack([a * np.cos(phi), a * np.sin(phi), 0 * phi], -1)
    D = P0 - A
    K, L = 2 * c * D @ e1, 2 * c * D @ e2
    M = b * b - c * c - np.sum(D * D, -1)
    return np.arctan2(L, K) + branch * np.arccos(M / np.hypot(K, L))


def rssr(phi0, branch):
    """The RSSR in the engine, assembled at crank angle φ0 on the given branch."""
    a, c, P0 = RSSR["a"], RSSR["c"], RSSR["P0"]
    u, e1, e2 = rssr_frame()
    psi0 = rssr_output(phi0, branch)
    A = np.array([a * np.cos(phi0), a * np.sin(phi0), 0])
    Bp = P0 + c * (np.cos(psi0) * e1 + np.sin(psi0) * e2)
    m = Mechanism(["crank", "rod", "rocker"])
    m.add_joint("in", "R", "ground", "crank", at=np.eye(4))
    m.add_joint("S1", "S", "crank", "rod", at=translation(A))
    m.add_joint("S2", "S", "rod", "rocker", at=translation(Bp))
    m.add_joint("out", "R", "ground", "rocker", at=transform(np.stack([e1, e2, u], -1), P0))
    m.add_input("in")
    return m, psi0


# ---------------------------------------------------------------- Bennett and Bricard
def dh_loop(params, thetas0, names=None):
    """A closed nR loop from DH parameters ``(a, α)``; joint k's frames are given as the pair
    (frame on link k-1, frame on link k) so the engine reads the absolute DH angles."""
    n = len(params)
    links = [f"L{k}" for k in range(1, n)]
    m = Mechanism(links)
    F = np.eye(4)
    for k in range(n):
        la = "ground" if k == 0 else links[k - 1]
        lb = links[k] if k < n - 1 else "ground"
        Fb = F @ transform(rot_z(thetas0[k]))
        m.add_joint(f"J{k + 1}", "R", la, lb, at=(F, Fb) if k < n - 1 else (F, Fb))
        F = F @ dh(thetas0[k], *params[k])
    return m


def bennett_theta2(t1, alpha, beta):
    """Bennett linkage: tan(θ1/2) tan(θ2/2) = sin((β+α)/2) / sin((β−α)/2); θ3 = −θ1, θ4 = −θ2."""
    return 2 * np.arctan(np.sin((beta + alpha) / 2) / np.sin((beta - alpha) / 2) / np.tan(t1 / 2))


def bricard_even(t_odd):
    """Equilateral orthogonal Bricard (a equal, α alternating ±90°, no offsets): θ1=θ3=θ5,
    θ2=θ4=θ6 and, since two links make a 120° rotation, cos θ1 cos θ2 + cos θ1 + cos θ2 = 0."""
    c = np.cos(t_odd)
    return np.arccos(-c / (1 + c))


# ---------------------------------------------------------------- four-bar dynamics reference
def fourbar_rod_reference(geom, masses, t2_0, g=9.81, branch=1):
    """Independent equations of motion of a four-bar of uniform rods (crank, coupler, rocker)
    under gravity −y, from Freudenstein's closed-form kinematics (not the engine).

    Returns ``accel(θ2, ω2) -> α2``: Lagrange's equation in the virtual-work form
    Σ m a_com · ∂r_com/∂θ2 + I α · ∂φ/∂θ2 = Σ m g · ∂r_com/∂θ2, linear in α2.
    """
    a, b, c, d = geom["a"], geom["b"], geom["c"], geom["d"]
    m2, m3, m4 = masses
    I2, I3, I4 = m2 * a * a / 12, m3 * b * b / 12, m4 * c * c / 12

    def e(t):
        return np.array([np.cos(t), np.sin(t)])

    def en(t):
        return np.array([-np.sin(t), np.cos(t)])

    def kin(t2, w2, al2):
        (t3, t4), (w3, w4), (al3, al4) = fourbar_rates(t2, w2, al2, a, b, c, d, branch)
        acc = [a / 2 * (al2 * en(t2) - w2 ** 2 * e(t2)),
               a * (al2 * en(t2) - w2 ** 2 * e(t2)) + b / 2 * (al3 * en(t3) - w3 ** 2 * e(t3)),
               c / 2 * (al4 * en(t4) - w4 ** 2 * e(t4))]
        return acc, (al2, al3, al4)

    def accel(t2, w2):
        (t3, t4), (r3, r4), _ = fourbar_rates(t2, 1.0, 0.0, a, b, c, d, branch)
        J = [a / 2 * en(t2), a * en(t2) + b / 2 * r3 * en(t3), c / 2 * r4 * en(t4)]
        Jphi = (1.0, r3, r4)
        grav = sum(m * np.array([0, -g]) @ Jk for m, Jk in zip((m2, m3, m4), J))

        def residual(al2):
            acc, alphas = kin(t2, w2, al2)
            return sum(m * ak @ Jk for m, ak, Jk in zip((m2, m3, m4), acc, J)) + \
                sum(I * al * jp for I, al, jp in zip((I2, I3, I4), alphas, Jphi)) - grav

        r0, r1 = residual(0.0), residual(1.0)
        return -r0 / (r1 - r0)

    return accel


# ---------------------------------------------------------------- 6-UPS platform
def axis_frame(z, x, o):
    """A 4x4 frame with Z along ``z``, X along the part of ``x`` normal to it, origin ``o``
    (seed 000's three-point rule, given directions instead of points)."""
    o = np.asarray(o, float)
    return frame_from_points(o, o + np.asarray(x, float), o + np.asarray(z, float))


def ups_platform(base, plat, T0, Q=np.eye(3), s=np.zeros(3)):
    """A 6-UPS platform (a hexapod built from joints) drawn with its platform at the pose
    ``T0``: per leg a Hooke joint at the base point, a prismatic joint ``P{i}`` along the leg
    (the inputs) and a spherical joint at the platform point; links ``l{i}``, ``u{i}`` and
    ``platform``.  ``Q, s`` move the whole drawing by ``r → Q r + s``."""
    def moved(T):
        out = T.copy()
        out[:3, :3] = Q @ T[:3, :3]
        out[:3, 3] = Q @ T[:3, 3] + s
        return out

    n = len(base)
    m = Mechanism([f"l{i}" for i in range(n)] + [f"u{i}" for i in range(n)] + ["platform"])
    w = plat @ T0[:3, :3].T + T0[:3, 3]
    for i in range(n):
        u = w[i] - base[i]
        e = np.eye(3)[np.argmin(abs(u))]
        pin = np.cross(u, e)
        m.add_joint(f"U{i}", "U", "ground", f"l{i}",
                    at=moved(axis_frame(pin, np.cross(u, pin), base[i])))
        m.add_joint(f"P{i}", "P", f"l{i}", f"u{i}", at=moved(axis_frame(u, e, base[i])))
        m.add_joint(f"S{i}", "S", f"u{i}", "platform",
                    at=moved(axis_frame([0, 0, 1], [1, 0, 0], w[i])))
        m.add_input(f"P{i}")
    return m
