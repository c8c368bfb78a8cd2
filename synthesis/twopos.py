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

__all__ = ["two_position_link", "two_position_links"]


def two_position_link(kinds: str, T2, *, slide_direction, pitch: float = 0.0,
                      prismatic_slide: float | None = None, reach: float = 1.0) -> BinaryLink:
    """The binary link ``kinds`` (PR, PH, RP, HP, PC or CP) through position 1 and ``T2``
    (one link of :func:`two_position_links`).

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
    (out,) = two_position_links(kinds, T2, slide_directions=[slide_direction], pitch=pitch,
                                prismatic_slides=[prismatic_slide], reach=reach)
    if isinstance(out, SynthesisError):
        raise out
    return out


def two_position_links(kinds: str, T2, *, slide_directions, pitch: float = 0.0,
                       prismatic_slides=None, reach: float = 1.0) -> list:
    """The binary links ``kinds`` (PR, PH, RP, HP, PC or CP) through position 1 and ``T2``
    for m choices of their free parameters at once (one screw of T2, one least-squares
    solve for all axis points, one residual evaluation).

    Parameters
    ----------
    kinds : str
        Fixed (ground) joint first.
    T2 : array_like, shape (4, 4)
        Position 2 relative to position 1.
    slide_directions : array_like, shape (m, 3)
        Unit slide directions of the prismatic joint (in the ground for PR, PH, PC; in the
        body at position 1 for RP, HP, CP).
    pitch : float
        The helical joint's pitch (length/rad) for PH, HP.
    prismatic_slides : sequence of m floats (or None), optional
        For PC and CP (required then): the prismatic joint's slide from position 1 to 2
        (length), one per slide direction.
    reach : float
        The task's reach (residual and round-off scale).

    Returns
    -------
    list of m entries: the BinaryLink of each choice, or the SynthesisError saying why
    that choice gives none, naming the argument: a slide direction that is not a unit
    vector or lies across the rotation axis (PR, PH, RP, HP), a missing prismatic slide;
    or, for every choice, a bad ``pitch`` or position 2 not turned (a pure translation: the
    turning joint's axis is not determined).

    Raises
    ------
    SynthesisError
        Naming the argument: bad ``kinds``, ``prismatic_slides`` of another length than
        ``slide_directions``.
    """
    if kinds not in ("PR", "PH", "RP", "HP", "PC", "CP"):
        raise SynthesisError(f"kinds: expected PR, PH, RP, HP, PC or CP, got {kinds!r}")
    T2 = np.asarray(T2, float)
    m = len(slide_directions)
    slides = [None] * m if prismatic_slides is None else list(prismatic_slides)
    if len(slides) != m:
        raise SynthesisError(f"prismatic_slides: expected {m} slides (one per slide "
                             f"direction), got {len(slides)}")
    out, dirs = [None] * m, [None] * m
    for n, d in enumerate(slide_directions):
        try:
            dirs[n] = unit(d, "slide_direction")
        except SynthesisError as e:
            out[n] = e
    try:
        p = number(pitch, "pitch", unit_="length/rad")
        s = Screw.from_matrix(T2)
        if abs(s.angle) < 1e-9:
            raise SynthesisError(f"screws: position 2 of the {kinds} link is (nearly) a pure "
                                 f"translation (rotation {abs(s.angle):.1e} rad): the turning "
                                 "joint's axis is not determined: degenerate")
    except SynthesisError as e:                    # common to every choice left
        return [e if x is None else x for x in out]
    w, phi = s.axis, s.angle
    R, t = T2[:3, :3], T2[:3, 3]
    fixed_p = kinds[0] == "P"
    turn = kinds[1] if fixed_p else kinds[0]
    todo, A, axial = [], [], []
    for n, (d, a) in enumerate(zip(dirs, slides)):
        if d is None:
            continue
        dd = d if fixed_p else R @ d                      # the slide direction at position 2
        try:
            if turn in "RH":
                pp = p if turn == "H" else 0.0
                if abs(d @ w) < 1e-9:
                    raise SynthesisError(f"slide_direction: across the rotation axis (d·w = "
                                         f"{d @ w:.1e}): the {kinds} slide is not determined: "
                                         "degenerate")
                a = (t @ w - pp * phi) / (dd @ w)
                ax = pp * phi
            else:
                if a is None:
                    raise SynthesisError(f"prismatic_slide: required for a {kinds} link through "
                                         "two positions (length)")
                a = number(a, "prismatic_slide", unit_="length")
                ax = (t - a * dd) @ w                     # the cylinder's slide σ
        except SynthesisError as err:
            out[n] = err
            continue
        todo.append((n, d, dd))
        A.append(a)
        axial.append(ax)
    if not todo:
        return out
    dd = np.array([x[2] for x in todo])
    A, axial = np.array(A, float), np.array(axial, float)
    V = t - A[:, None] * dd - axial[:, None] * w
    V = V - (V @ w)[:, None] * w
    # the points c ⊥ w with (I − R) c = v (v ⊥ w): one least-squares matrix for all
    C, *_ = np.linalg.lstsq(np.vstack([np.eye(3) - R, w[None]]),
                            np.vstack([V.T, np.zeros((1, len(V)))]), rcond=None)
    turn_pitch = np.nan if turn == "C" else (p if turn == "H" else 0.0)
    z = np.zeros(2)
    ang = np.r_[0.0, phi]
    links = []
    for (n, d, _), c, a, ax in zip(todo, C.T, A, axial):
        sl, pz = np.r_[0.0, ax], np.r_[0.0, a]
        turn_line = Line(w, c).canonical()
        slide_line = Line(d, turn_line.point)
        if fixed_p:
            slide_line = slide_line.canonical()
            link = BinaryLink(kinds, slide_line, turn_line.canonical(slide_line), np.inf,
                              turn_pitch, z, pz, ang, sl, 0.0)
        else:
            link = BinaryLink(kinds, turn_line, slide_line.canonical(turn_line), turn_pitch,
                              np.inf, ang, sl, z, pz, 0.0)
        link.parameters = {"slide_direction": d.copy()}
        if turn == "C":
            link.parameters["prismatic_slide"] = float(a)
        links.append(link)
        out[n] = link
    rot, pos = pose_errors(np.stack([lk.poses() for lk in links]), np.stack([np.eye(4), T2]),
                           reach)
    for lk, r in zip(links, np.maximum(rot.max(1), pos.max(1)).tolist()):
        lk.residual = r
    return out
