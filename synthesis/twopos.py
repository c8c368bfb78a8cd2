"""Binary links with a prismatic joint through two positions (PR, PH, RP, HP, PC, CP), in
closed form, with their free parameters explicit.

Through two positions the relative screw S₁₂ (axis w, angle φ, position 1 → 2) fixes the
direction of the joint that turns: its axis is parallel to S₁₂'s (rotation about one
direction only).  The translation equation of position 2 is then linear:

====  ============================================  ========================================
link  translation of position 2                     free parameters → unknowns
====  ============================================  ========================================
PR    ``t = a d + (I − R) c + p φ w`` (p = 0)        ``slide_direction`` d → slide a, point c
PH    the same, p the helical pitch                  ``slide_direction`` d → a, c
RP    ``t = b R d + (I − R) c + p θ g`` (p = 0)      ``slide_direction`` d (body, position 1)
                                                     → slide b, point c
HP    the same with p                                ``slide_direction`` d → b, c
PC    ``t = a d + (I − R) c + σ w``                  ``slide_direction`` d and
                                                     ``prismatic_slide`` a → σ, c
CP    ``t = b R d + (I − R) c + σ g``                d and b → σ, c
====  ============================================  ========================================

The component along the rotation axis gives the slide (PR, PH, RP, HP: divided by
``d · w``, so a slide direction across the axis is degenerate), the part across it the
axis point c (``I − R`` is invertible across the axis when φ ≠ 0).
"""
from __future__ import annotations

import numpy as np

from .binary import BinaryLink
from .errors import SynthesisError
from .screw import Line, Screw
from .validate import number, unit
from .verify import pose_errors

__all__ = ["two_position_link"]


def _across(R, v, w):
    """The point c ⊥ w with (I − R) c = v (v ⊥ w)."""
    A = np.vstack([np.eye(3) - R, w[None]])
    c, *_ = np.linalg.lstsq(A, np.r_[v, 0.0], rcond=None)
    return c


def two_position_link(kinds: str, T2, *, slide_direction, pitch: float = 0.0,
                      prismatic_slide: float | None = None, reach: float = 1.0) -> BinaryLink:
    """The binary link ``kinds`` (PR, PH, RP, HP, PC or CP) through position 1 and ``T2``.

    Parameters
    ----------
    kinds : str
        Fixed (ground) joint first.
    T2 : array_like, shape (4, 4)
        Position 2 relative to position 1.
    slide_direction : array_like, shape (3,)
        Unit slide direction of the prismatic joint (in the ground for PR, PH, PC; in the
        body at position 1 for RP, HP, CP).
    pitch : float
        The helical joint's pitch (length/rad) for PH, HP.
    prismatic_slide : float
        For PC and CP: the prismatic joint's slide from position 1 to 2 (length).
    reach : float
        The task's reach (residual and round-off scale).

    Returns
    -------
    BinaryLink

    Raises
    ------
    SynthesisError
        Naming the argument; position 2 not turned (a pure translation: the turning joint's
        axis is not determined); a slide direction across the rotation axis (PR, PH, RP,
        HP: the slide is not determined).
    """
    if kinds not in ("PR", "PH", "RP", "HP", "PC", "CP"):
        raise SynthesisError(f"kinds: expected PR, PH, RP, HP, PC or CP, got {kinds!r}")
    T2 = np.asarray(T2, float)
    d = unit(slide_direction, "slide_direction")
    p = number(pitch, "pitch", unit_="length/rad")
    s = Screw.from_matrix(T2)
    if abs(s.angle) < 1e-9:
        raise SynthesisError(f"screws: position 2 of the {kinds} link is (nearly) a pure "
                             f"translation (rotation {abs(s.angle):.1e} rad): the turning "
                             "joint's axis is not determined: degenerate")
    w, phi = s.axis, s.angle
    R, t = T2[:3, :3], T2[:3, 3]
    fixed_p = kinds[0] == "P"
    turn = kinds[1] if fixed_p else kinds[0]
    dd = d if fixed_p else R @ d                          # the slide direction at position 2
    z = np.zeros(2)
    if turn in "RH":
        pp = p if turn == "H" else 0.0
        if abs(d @ w) < 1e-9:
            raise SynthesisError(f"slide_direction: across the rotation axis (d·w = "
                                 f"{d @ w:.1e}): the {kinds} slide is not determined: degenerate")
        a = (t @ w - pp * phi) / (dd @ w)
        axial = pp * phi
    else:
        if prismatic_slide is None:
            raise SynthesisError(f"prismatic_slide: required for a {kinds} link through two "
                                 "positions (length)")
        a = number(prismatic_slide, "prismatic_slide", unit_="length")
        axial = (t - a * dd) @ w                          # the cylinder's slide σ
    v = t - a * dd - axial * w
    v = v - (v @ w) * w
    c = _across(R, v, w)
    ang = np.r_[0.0, phi]
    sl = np.r_[0.0, axial]
    pz = np.r_[0.0, a]
    turn_pitch = np.nan if turn == "C" else (p if turn == "H" else 0.0)
    turn_line = Line(w, c).canonical()
    slide_line = Line(d, turn_line.point)
    if fixed_p:
        slide_line = slide_line.canonical()
        link = BinaryLink(kinds, slide_line, turn_line.canonical(slide_line), np.inf, turn_pitch,
                          z, pz, ang, sl, 0.0)
    else:
        link = BinaryLink(kinds, turn_line, slide_line.canonical(turn_line), turn_pitch, np.inf,
                          ang, sl, z, pz, 0.0)
    link.parameters = {"slide_direction": d.copy()}
    if turn == "C":
        link.parameters["prismatic_slide"] = float(a)
    rot, pos = pose_errors(link.poses(), np.stack([np.eye(4), T2]), reach)
    link.residual = float(max(rot.max(), pos.max()))
    return link
