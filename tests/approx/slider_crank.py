"""An in-line slider-crank (crank r = 0.1 m, rod l = 0.35 m): the engine model built with the
public closure API, its closed form, and the same mechanism as a study-file section.

Convention: at the assembly pose (crank angle θ = 0) the crank pin B is at (0, r, 0), the
slider pin C on the x axis at (√(l² − r²), 0, 0); the crank turns about +z, so
B(θ) = (−r sin θ, r cos θ, 0), and the slider joint "D" (prismatic, Z along +x) reads the
slider's displacement from its assembly position:

    s(θ) = −r sin θ + √(l² − r² cos² θ) − √(l² − r²)

(|C − B| = l gives (x_C + r sin θ)² + r² cos² θ = l²).  The engine's output is then
``EngineAnalogs(m, "D", a, b)`` with sign +1 and offset 0.
"""
import numpy as np

from closure import Mechanism, frame_from_points, translation

R, L = 0.1, 0.35
X0 = float(np.sqrt(L * L - R * R))            # slider pin at θ = 0 (m)


def s(t):
    """Slider displacement (m) for crank angle θ (rad)."""
    t = np.asarray(t, float)
    return -R * np.sin(t) + np.sqrt(L * L - R * R * np.cos(t) ** 2) - X0


def ds(t):
    """ds/dθ (m/rad): −r cos θ + r² sin θ cos θ / √Q, Q = l² − r² cos² θ."""
    t = np.asarray(t, float)
    Q = L * L - R * R * np.cos(t) ** 2
    return -R * np.cos(t) + R * R * np.sin(t) * np.cos(t) / np.sqrt(Q)


def d2s(t):
    """d²s/dθ² (m/rad²): r sin θ + r² cos 2θ / √Q − r⁴ sin² θ cos² θ / Q^(3/2)."""
    t = np.asarray(t, float)
    Q = L * L - R * R * np.cos(t) ** 2
    return (R * np.sin(t) + R * R * np.cos(2 * t) / np.sqrt(Q)
            - R ** 4 * np.sin(t) ** 2 * np.cos(t) ** 2 / Q ** 1.5)


def mechanism() -> Mechanism:
    """ground –R(A)– crank –R(B)– rod –R(C)– slider –P(D)– ground; input: joint A."""
    B, C = np.array([0.0, R, 0.0]), np.array([X0, 0.0, 0.0])
    m = Mechanism(["crank", "rod", "slider"])
    m.add_joint("A", "R", "ground", "crank", at=translation([0.0, 0.0, 0.0]))
    m.add_joint("B", "R", "crank", "rod", at=translation(B))
    m.add_joint("C", "R", "rod", "slider", at=translation(C))
    m.add_joint("D", "P", "ground", "slider", at=frame_from_points(C, C + [0, 1, 0], C + [1, 0, 0]))
    m.add_input("A")
    return m


def study_toml(a: float, b: float, mode: str, joint: str = "D") -> str:
    """A ``linkwright approx`` study of this mechanism on [a, b] (rad); ``mode`` is the
    TOML line that chooses the knots (``n = 6``, ``delta = 1e-3``, ``knots = [...]``)."""
    def v(p):
        return "[" + ", ".join(repr(float(c)) for c in p) + "]"
    joints = [("A", "R", ("ground", "crank"), (0, 0, 0), (1, 0, 0), (0, 0, 1)),
              ("B", "R", ("crank", "rod"), (0, R, 0), (1, R, 0), (0, R, 1)),
              ("C", "R", ("rod", "slider"), (X0, 0, 0), (X0 + 1, 0, 0), (X0, 0, 1)),
              ("D", "P", ("ground", "slider"), (X0, 0, 0), (X0, 1, 0), (X0 + 1, 0, 0))]
    text = ["[study]", 'command = "approx"', 'title = "slider-crank"', "",
            "[approx]", 'source = "mechanism"', f"a = {a!r}", f"b = {b!r}", mode, "",
            "[approx.output]", f'joint = "{joint}"', "",
            "[mechanism]", 'links = ["crank", "rod", "slider"]', ""]
    for name, kind, links, o, xp, zp in joints:
        text += ["[[mechanism.joint]]", f'name = "{name}"', f'kind = "{kind}"',
                 f'links = ["{links[0]}", "{links[1]}"]', f"origin = {v(o)}",
                 f"x_point = {v(xp)}", f"z_point = {v(zp)}", ""]
    text += ["[[mechanism.input]]", 'joint = "A"', ""]
    return "\n".join(text)
