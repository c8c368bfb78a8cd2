"""A two-cylinder loader crane (after the SF-65 of seed 004): two loops, two degrees of freedom.

The boom turns about the ground pivot O and is raised by hydraulic cylinder 1
(barrel pivoted on the ground at G1, rod on the boom at B1).  The jib turns
about the boom tip T and is worked by cylinder 2 (barrel on the boom at B2, rod
on the jib at J2).  The independent coordinates are the two cylinder strokes.

Run it to print the drive forces of a lifting motion (inverse dynamics) and a
short free fall under gravity with the drives holding their initial forces
(forward dynamics, with the energy balance)::

    python -m linkwright.examples.crane
"""
from __future__ import annotations

import numpy as np

from closure import Dynamics, Mechanism, frame_from_points, translation

O = np.array([0.0, 0.0, 0.0])
G1 = np.array([0.6, -0.8, 0.0])
B1 = np.array([1.2, 0.25, 0.0])
T = np.array([3.0, 0.6, 0.0])
B2 = np.array([1.8, 0.75, 0.0])
J2 = np.array([3.4, 1.1, 0.0])
TIP = np.array([5.0, 0.2, 0.0])
LOAD = 150.0  # kg at the jib tip


def _rod_inertia(m, a, b):
    u = (b - a) / np.linalg.norm(b - a)
    return m * np.sum((b - a) ** 2) / 12 * (np.eye(3) - np.outer(u, u))


def build() -> Mechanism:
    """The crane's mechanism at its assembly pose (strokes 0)."""
    m = Mechanism(["boom", "jib", "barrel1", "rod1", "barrel2", "rod2"])
    z = np.array([0, 0, 1.0])
    m.add_joint("O", "R", "ground", "boom", at=translation(O))
    m.add_joint("G1", "R", "ground", "barrel1", at=translation(G1))
    m.add_joint("stroke1", "P", "barrel1", "rod1", at=frame_from_points(G1, G1 + z, B1))
    m.add_joint("B1", "R", "rod1", "boom", at=translation(B1))
    m.add_joint("T", "R", "boom", "jib", at=translation(T))
    m.add_joint("B2", "R", "boom", "barrel2", at=translation(B2))
    m.add_joint("stroke2", "P", "barrel2", "rod2", at=frame_from_points(B2, B2 + z, J2))
    m.add_joint("J2", "R", "rod2", "jib", at=translation(J2))
    m.add_input("stroke1")
    m.add_input("stroke2")
    return m


def dynamics(m: Mechanism | None = None) -> Dynamics:
    """Mass model: boom 120 kg and jib 80 kg (uniform beams), the load at the jib tip,
    cylinders 15 kg each (barrel and rod), gravity −y, light dampers in the pivots."""
    m = m or build()
    d = Dynamics(m, gravity=(0, -9.81, 0))
    d.add_body("boom", 120.0, (O + T) / 2, _rod_inertia(120.0, O, T))
    jib_com = (80.0 * (T + TIP) / 2 + LOAD * TIP) / (80.0 + LOAD)
    d.add_body("jib", 80.0 + LOAD, jib_com, _rod_inertia(80.0, T, TIP))
    for link, a, b in [("barrel1", G1, B1), ("rod1", G1, B1), ("barrel2", B2, J2),
                       ("rod2", B2, J2)]:
        d.add_body(link, 15.0, a + 0.5 * (b - a) * (0.6 if "barrel" in link else 1.4),
                   _rod_inertia(15.0, a, a + 0.5 * (b - a)))
    d.add_damper("O", 20.0)
    d.add_damper("T", 10.0)
    return d


def lifting_motion(t, duration=4.0):
    """Strokes rising smoothly by 0.25 m and 0.15 m over ``duration``: (x, xd, xdd) (m)."""
    s = np.clip(np.asarray(t, float) / duration, 0, 1)
    w = 2 * np.pi / duration
    base = s - np.sin(2 * np.pi * s) / (2 * np.pi)
    rate = (1 - np.cos(2 * np.pi * s)) / duration
    acc = w * np.sin(2 * np.pi * s) / duration
    amp = np.array([0.25, 0.15])
    return base[:, None] * amp, rate[:, None] * amp, acc[:, None] * amp


def main() -> None:
    m = build()
    d = dynamics(m)
    print(f"crane: {m.n_loops} loops, mobility {m.mobility}, inputs {m.input_labels()}")
    t = np.linspace(0, 4, 9)
    inv = d.inverse(t, lifting_motion)
    print("\ninverse dynamics (drive forces of the lifting motion, N):")
    print(inv[["t", "stroke1", "stroke2", "drive:stroke1", "drive:stroke2", "residual",
               "condition"]].to_string(index=False, float_format=lambda v: f"{v: .6g}"))
    hold = inv[["drive:stroke1", "drive:stroke2"]].to_numpy()[0]
    fwd = d.simulate((0, 1.0), [0.0, 0.0], [0.0, 0.0], t_eval=np.linspace(0, 1, 6),
                     drive=lambda t, x, xd: 0.9 * hold, rtol=1e-9, atol=1e-11)
    print("\nforward dynamics (drives at 90 % of the holding forces):")
    print(fwd[["t", "stroke1", "stroke2", "energy", "dissipated", "work", "balance",
               "residual"]].to_string(index=False, float_format=lambda v: f"{v: .6g}"))


if __name__ == "__main__":
    main()
