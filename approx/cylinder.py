"""The oscillating-cylinder mechanism of seed 004 (Fig. 2), in closed form and in the engine.

A hydraulic cylinder pivoted on the ground at O drives a rocker of length B₃
pivoted at A, |OA| = B₀; the cylinder's length is B + q₁.  Corrected formulas
(seed 004 with its misprints corrected: the analog's slope, (B₀B₃)⁻¹ in (7)):

    q₃ = f₃(q₁) = arcsin[((B + q₁)² − B₀² − B₃²) / (2 B₀ B₃)]
    Ψ₃₁ = df₃/dq₁ = 2 (B + q₁) / (B₀ B₃ sqrt(4 − u²)),  u = ((B + q₁)² − B₀² − B₃²)/(B₀ B₃)

q₃ is the rocker angle measured from the perpendicular to OA (q₃ = ∠OAC − π/2).
"""
from __future__ import annotations

import numpy as np

from closure import Mechanism, frame_from_points, translation

from .analog import ApproxError, as_points, as_positive, as_real

__all__ = ["B", "B0", "B3", "f3", "psi31", "dpsi31", "mechanism", "drive_law", "M3", "TAU"]

B = B0 = 0.7     # m
B3 = 0.4         # m
M3 = 500.0       # kg, rocker mass (a point mass at L3 = B3)
TAU = 5.0        # s, duration of the drive law


def _lengths(b, b0, b3):
    """The three lengths checked: finite and positive (m)."""
    return tuple(as_positive(v, name, "a positive length (m)")
                 for v, name in ((b, "b"), (b0, "b0"), (b3, "b3")))


def _args(q1, b, b0, b3):
    return (as_points(q1, "q1"), *_lengths(b, b0, b3))


def _u(q1, b=B, b0=B0, b3=B3):
    return ((b + q1) ** 2 - b0 ** 2 - b3 ** 2) / (b0 * b3)


def f3(q1, b=B, b0=B0, b3=B3):
    """Rocker angle q₃ (rad) for the piston stroke q₁ (m)."""
    q1, b, b0, b3 = _args(q1, b, b0, b3)
    return np.arcsin(0.5 * _u(q1, b, b0, b3))


def psi31(q1, b=B, b0=B0, b3=B3):
    """Ψ₃₁ = dq₃/dq₁ (rad/m), formula (6)."""
    q1, b, b0, b3 = _args(q1, b, b0, b3)
    with np.errstate(invalid="ignore", divide="ignore"):
        return 2 * (b + q1) / (b0 * b3 * np.sqrt(4 - _u(q1, b, b0, b3) ** 2))


def dpsi31(q1, b=B, b0=B0, b3=B3):
    """dΨ₃₁/dq₁ (rad/m²), formula (7) with (B₀B₃)⁻¹ for the misprinted (B₀B₁)⁻¹."""
    q1, b, b0, b3 = _args(q1, b, b0, b3)
    u = _u(q1, b, b0, b3)
    s = 4 - u ** 2
    with np.errstate(invalid="ignore", divide="ignore"):   # NaN / inf past the dead point
        return 2 / (b0 * b3) * s ** -0.5 + 4 * (b + q1) ** 2 * u / (b0 * b3) ** 2 * s ** -1.5


def drive_law(t, tau=TAU, stroke=0.3):
    """q₁(t) = 0.3 [t/τ − sin(2πt/τ)/(2π)] and its first two derivatives."""
    t = as_points(t, "t")
    tau = as_positive(tau, "tau", "a positive duration (s)")
    stroke = as_real(stroke, "stroke")
    w = 2 * np.pi / tau
    q = stroke * (t / tau - np.sin(w * t) / (2 * np.pi))
    qd = stroke * (1 / tau - np.cos(w * t) / tau)
    qdd = stroke * w * np.sin(w * t) / tau
    return q, qd, qdd


def mechanism(b=B, b0=B0, b3=B3) -> Mechanism:
    """The engine model: ground –R(O)– cylinder –P– piston –R(C)– rocker –R(A)– ground.

    The input is the slide of the P joint (q₁, zero at the assembly stroke
    q₁ = 0); the rocker's angle q₃ equals ``f3(0) − θ_A`` with θ_A the
    coordinate of joint "A".
    """
    b, b0, b3 = _lengths(b, b0, b3)
    if not abs(b0 - b3) < b < b0 + b3:
        raise ApproxError(f"b: expected a cylinder length between |b0 − b3| = {abs(b0 - b3):.6g} "
                          f"and b0 + b3 = {b0 + b3:.6g} (m) so that the mechanism assembles, "
                          f"got {b}")
    cosA = (b0 ** 2 + b3 ** 2 - b ** 2) / (2 * b0 * b3)       # angle OAC at q1 = 0
    ang = np.pi - np.arccos(cosA)                              # direction of AC from +x
    O, A = np.zeros(3), np.array([b0, 0.0, 0.0])
    C = A + b3 * np.array([np.cos(ang), np.sin(ang), 0.0])
    m = Mechanism(["cylinder", "piston", "rocker"])
    m.add_joint("O", "R", "ground", "cylinder", at=translation(O))
    m.add_joint("slide", "P", "cylinder", "piston", at=frame_from_points(O, O + [0, 0, 1], C))
    m.add_joint("C", "R", "piston", "rocker", at=translation(C))
    m.add_joint("A", "R", "ground", "rocker", at=translation(A))
    m.add_input("slide")
    return m
