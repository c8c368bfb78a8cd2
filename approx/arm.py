"""A three-cylinder manipulator arm (after the hydraulic manipulators of Kuzmin & Tomilova):
four loops, three degrees of freedom, built with the closure engine's joints.

In the vertical x–y plane (gravity −y): the boom turns about the ground pivot O and is
raised by cylinder 1 (barrel on the ground at G1, rod on the boom at B1); the stick turns
about the boom tip T1, worked by cylinder 2 (barrel on the boom at B2, rod on the stick
at S2); the tool turns about the stick tip T2 through a bucket linkage: cylinder 3
(barrel on the stick at B3) pushes the joint L of a lever (pivoted on the stick at K) and
a link that carries the tool at W.  The bucket linkage is a one-mobility group of two
loops (the cylinder loop and the four-bar K–L–W–T2), so every joint coordinate is a
function of one stroke: the structure :func:`approx.surrogate_dynamics` needs.

The independent coordinates are the three strokes (m, zero at the drawing).
"""
from __future__ import annotations

import numpy as np

from closure import Dynamics, Mechanism, frame_from_points, translation

__all__ = ["build", "dynamics", "motion", "RANGES", "POINTS"]

POINTS = {k: np.array(v + (0.0,)) for k, v in {
    "O": (0.0, 0.0), "G1": (0.4, -0.7), "B1": (1.0, 0.45), "T1": (2.6, 1.2),
    "B2": (1.4, 1.35), "S2": (2.9, 1.75), "T2": (3.9, 0.1), "B3": (3.0, 1.3),
    "L": (3.85, 0.6), "K": (3.7, 0.5), "W": (4.15, 0.3), "TIP": (4.4, -0.1)}.items()}

#: stroke ranges (m) of the three cylinders used by the tests and the benchmark
RANGES = {"stroke1": (-0.15, 0.25), "stroke2": (-0.15, 0.2), "stroke3": (-0.1, 0.08)}

LOAD = 100.0    # kg at the tool tip


def _rod(m, a, b):
    u = (b - a) / np.linalg.norm(b - a)
    return m * np.sum((b - a) ** 2) / 12 * (np.eye(3) - np.outer(u, u))


def build() -> Mechanism:
    """The arm's mechanism at its drawing pose (strokes 0)."""
    P = POINTS
    z = np.array([0, 0, 1.0])
    m = Mechanism(["boom", "barrel1", "rod1", "stick", "barrel2", "rod2", "tool", "barrel3",
                   "rod3", "lever", "link"])

    def R(name, a, b, p):
        m.add_joint(name, "R", a, b, at=translation(P[p]))

    def cyl(k, base, end, link_a, link_b):
        R(f"{base}", link_a, f"barrel{k}", base)
        m.add_joint(f"stroke{k}", "P", f"barrel{k}", f"rod{k}",
                    at=frame_from_points(P[base], P[base] + z, P[end]))
        m.add_input(f"stroke{k}")

    R("O", "ground", "boom", "O")
    cyl(1, "G1", "B1", "ground", "boom")
    R("B1", "rod1", "boom", "B1")
    R("T1", "boom", "stick", "T1")
    cyl(2, "B2", "S2", "boom", "stick")
    R("S2", "rod2", "stick", "S2")
    R("T2", "stick", "tool", "T2")
    cyl(3, "B3", "L", "stick", "tool")
    R("L1", "rod3", "lever", "L")
    R("K", "stick", "lever", "K")
    R("L2", "lever", "link", "L")
    R("W", "link", "tool", "W")
    return m


def dynamics(m: Mechanism | None = None, damping: bool = True) -> Dynamics:
    """Mass model: boom 300 kg, stick 150 kg (uniform beams), tool 60 kg with a 100 kg
    load at its tip, cylinders 20 kg per barrel and rod, lever and link 5 kg each;
    gravity −y; dampers in the three main pivots unless ``damping`` is False."""
    P = POINTS
    m = m or build()
    d = Dynamics(m, gravity=(0, -9.81, 0))
    d.add_body("boom", 300.0, (P["O"] + P["T1"]) / 2, _rod(300.0, P["O"], P["T1"]))
    d.add_body("stick", 150.0, (P["S2"] + P["T2"]) / 2, _rod(150.0, P["S2"], P["T2"]))
    com = (60.0 * (P["T2"] + P["TIP"]) / 2 + LOAD * P["TIP"]) / (60.0 + LOAD)
    d.add_body("tool", 60.0 + LOAD, com, _rod(60.0, P["T2"], P["TIP"]))
    for k, a, b in ((1, "G1", "B1"), (2, "B2", "S2"), (3, "B3", "L")):
        A, Bp = P[a], P[b]
        d.add_body(f"barrel{k}", 20.0, A + 0.3 * (Bp - A), _rod(20.0, A, A + 0.6 * (Bp - A)))
        d.add_body(f"rod{k}", 20.0, A + 0.7 * (Bp - A), _rod(20.0, A + 0.4 * (Bp - A), Bp))
    d.add_body("lever", 5.0, (P["K"] + P["L"]) / 2, _rod(5.0, P["K"], P["L"]))
    d.add_body("link", 5.0, (P["L"] + P["W"]) / 2, _rod(5.0, P["L"], P["W"]))
    if damping:
        for j, c in (("O", 50.0), ("T1", 30.0), ("T2", 10.0)):
            d.add_damper(j, c)
    return d


def motion(t, duration: float = 3.0):
    """Strokes moving smoothly from 0 to (0.2, 0.15, −0.08) m over ``duration`` s (a
    cycloidal rise): ``(x, xd, xdd)``, each (N, 3)."""
    s = np.clip(np.asarray(t, float) / duration, 0, 1)
    base = s - np.sin(2 * np.pi * s) / (2 * np.pi)
    rate = (1 - np.cos(2 * np.pi * s)) / duration
    acc = 2 * np.pi * np.sin(2 * np.pi * s) / duration ** 2
    amp = np.array([0.2, 0.15, -0.08])
    return base[:, None] * amp, rate[:, None] * amp, acc[:, None] * amp
