"""Binary links with a prismatic joint and a revolute, helical or cylindrical one (PR, RP,
PC, CP through three positions; PR, RP, PH, HP through two).  PR and RP are the limit of the helical links HR, RH as the helical pitch goes to infinity
(the joint's rotation, slide / pitch, goes to zero).

A P joint adds no rotation, so the relative rotations of the positions must all turn
about one direction (the revolute axis's): otherwise no PR or RP link reaches them
(:class:`SynthesisError` says so).  Then the link is found by linear algebra.

PR (slide a_j along g in the ground, then rotation φ_j about the moving line (w, c_w)):
``t_j = a_j g + (I − R_j) c_w``.  With ``h_j = t_j · w = a_j (g · w)`` and ``u_j`` the
part of t_j across w, ``h₃ (u₂ − (I − R₂) c_w) = h₂ (u₃ − (I − R₃) c_w)``: two linear
equations for c_w in the plane across w, then ``g ∝ t₂ − (I − R₂) c_w``.

RP (rotation θ_j about the fixed line (g, c_g), then slide b_j along w carried by it):
``R_jᵀ t_j = (R_jᵀ − I) c_g + b_j w``: the same equations with ``R_jᵀ t_j`` and
``R_jᵀ − I``.

PC, CP: the cylinder's axis direction is the rotations' common one; the slide direction
of the P joint is the free choice (two parameters), after which six linear equations
give the cylinder's axis point and the four slides.

Two positions (PR, RP, PH, HP): the rotating joint's axis direction w is S₁₂'s axis and
its angle φ S₁₂'s angle (in (0, π]); the slide direction d (unit vector: the two free
parameters, ``fixed_direction`` for PR/PH, ``moving_direction`` in position 1 for RP/HP)
then leaves three linear equations for the slide and the axis point:
``t = a d + (I − R) c_w + p φ w`` (PR, PH; p the pitch, 0 for R) and
``t = b R d + (I − R) c_g + p θ g`` (RP, HP).  They are singular when d ⊥ w (the slide
could not supply the translation along the axis).

==========  =========  ==================================================
link        positions  free parameters
==========  =========  ==================================================
PR, RP      3          none (positions turned about one direction only)
PR, RP      2          ``fixed_direction`` / ``moving_direction`` (2)
PH, HP      2          ``fixed_direction`` / ``moving_direction`` (2), pitch given
PC, CP      3          ``fixed_direction`` / ``moving_direction`` (2)
==========  =========  ==================================================
"""
from __future__ import annotations

import numpy as np

from .binary import BinaryLink, _signed_angle, _task
from .errors import SynthesisError
from .screw import Line
from .validate import number, screw as _screw, unit
from .verify import pose_errors

__all__ = ["pr_links", "rp_links", "pc_links", "cp_links", "ph_links", "hp_links"]


def _common_axis(task, name):
    """The direction all relative rotations of the task turn about, or raise."""
    T = task.T
    axes = []
    for j in range(len(T)):
        for k in range(j):
            R = T[k, :3, :3].T @ T[j, :3, :3]
            v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
            ang = np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))
            if ang < 1e-6:
                raise SynthesisError(f"{name}: the relative screw S_{k + 1}{j + 1} is (nearly) a "
                                     f"pure translation (rotation {ang:.1e} rad): the revolute "
                                     "joint would not turn and the link is not determined")
            if np.pi - ang < 1e-6:
                raise SynthesisError(f"{name}: the relative screw S_{k + 1}{j + 1} is a half turn: "
                                     "its axis direction is not resolved; degenerate task")
            axes.append(v / np.linalg.norm(v))
    U = np.array(axes)
    _, s, Vt = np.linalg.svd(U)
    if s[1] > 1e-9 * s[0]:
        raise SynthesisError(f"{name}: the relative rotations do not share one axis direction "
                             f"(spread {s[1] / s[0]:.1e}): a P joint adds no rotation, so a PR or "
                             "RP link reaches only positions turned about one direction")
    w = Vt[0]
    return w if w @ axes[0] > 0 else -w


def _solve(T, w, kind, name):
    """Common linear step (in normalised coordinates): the revolute axis point ``c`` (⊥ w)
    and the slide direction ``d`` for positions ``T (3, 4, 4)``; ``kind`` "PR" or "RP"."""
    I = np.eye(3)
    Ms, ts = [], []
    for Tj in T[1:]:
        R, t = Tj[:3, :3], Tj[:3, 3]
        if kind == "PR":
            Ms.append(I - R)
            ts.append(t)
        else:
            Ms.append(R.T - I)
            ts.append(R.T @ t)
    h = [t @ w for t in ts]
    if max(abs(h[0]), abs(h[1])) < 1e-12:
        raise SynthesisError(f"{name}: the translations have no component along the rotation "
                             "axis (a planar motion): the slide direction is not determined "
                             "(it may be any direction across the axis): degenerate task")
    u = [t - (t @ w) * w for t in ts]
    M = h[1] * Ms[0] - h[0] * Ms[1]
    rhs = h[1] * u[0] - h[0] * u[1]
    A = np.vstack([M, w])
    b = np.r_[rhs, 0.0]
    sv = np.linalg.svd(A, compute_uv=False)
    if sv[-1] < 1e-9 * sv[0]:
        raise SynthesisError(f"{name}: degenerate: the revolute axis is not determined by the "
                             f"translations (condition {sv[0] / max(sv[-1], 1e-300):.1e})")
    c = np.linalg.lstsq(A, b, rcond=None)[0]
    j = int(np.argmax(np.abs(h)))
    d = ts[j] - Ms[j] @ c
    d /= np.linalg.norm(d)
    slides = np.array([v @ d for v in (ts[0] - Ms[0] @ c, ts[1] - Ms[1] @ c)])
    return c, d, slides


def _link(screws, kind, name):
    task = _task(screws, name, (3,))
    w = _common_axis(task, name)
    c, d, slides = _solve(task.Tn, w, kind, name)
    R = task.Tn[1:, :3, :3]
    e1 = np.cross(w, [1.0, 0, 0] if abs(w[0]) < 0.9 else [0, 1.0, 0])
    ang = np.r_[0.0, _signed_angle(np.broadcast_to(e1, (2, 3)), R @ e1, w)]
    L, cen = task.L, task.c
    rev = Line(w, c * L + cen).canonical()
    pri = Line(d, rev.point).canonical()
    z = np.zeros(3)
    sl = np.r_[0.0, slides * L]
    if kind == "PR":
        link = BinaryLink("PR", pri, rev.canonical(pri), np.inf, 0.0, z, sl, ang, z, 0.0)
    else:
        link = BinaryLink("RP", rev, pri.canonical(rev), 0.0, np.inf, ang, z, z, sl, 0.0)
    rot, pos = pose_errors(link.poses(), task.T, task.reach)
    link.residual = float(max(rot.max(), pos.max()))
    return [link]


def pr_links(s12, s13=None, *, fixed_direction=None) -> list[BinaryLink]:
    """The PR link (prismatic joint in the ground, revolute in the body) through three
    positions whose relative rotations share one axis direction, or through two
    positions for a chosen slide direction.

    Parameters
    ----------
    s12, s13 : Screw
        Displacements from position 1 to positions 2 and 3; ``s13`` None for two
        positions.
    fixed_direction : array_like (3,), optional
        Two positions only (required then): the unit slide direction in the ground, the
        two free parameters (not perpendicular to S₁₂'s axis).

    Returns
    -------
    list of one BinaryLink (types ``"PR"``; the fixed axis holds the slide direction,
    ``fixed_pitch`` inf, ``fixed_slides`` the slides, length).

    Raises
    ------
    SynthesisError
        Bad input (named); coincident positions; relative rotations about different
        directions (no PR link); pure-translation or half-turn relative screws; a
        planar motion (slide direction not determined).  Two positions: S₁₂ a pure
        translation, or a slide direction perpendicular to its axis.
    """
    if s13 is None:
        return _two(s12, "PR", 0.0, fixed_direction, "fixed_direction", none="s13")
    if fixed_direction is not None:
        raise SynthesisError("fixed_direction: only for two positions (s13 None); through three "
                             "the PR link is unique")
    return _link([_screw(s12, "s12"), _screw(s13, "s13")], "PR", "s12, s13")


def rp_links(s12, s13=None, *, moving_direction=None) -> list[BinaryLink]:
    """The RP link (revolute joint in the ground, prismatic in the body) through three
    positions whose relative rotations share one axis direction, or through two
    positions for a chosen slide direction.

    Parameters
    ----------
    s12, s13 : Screw
        Displacements from position 1 to positions 2 and 3; ``s13`` None for two
        positions.
    moving_direction : array_like (3,), optional
        Two positions only (required then): the unit slide direction in the body in
        position 1, the two free parameters.

    Returns
    -------
    list of one BinaryLink (types ``"RP"``; the moving axis holds the slide direction
    in position 1, ``moving_pitch`` inf).

    Raises
    ------
    SynthesisError
        As :func:`pr_links`.
    """
    if s13 is None:
        return _two(s12, "RP", 0.0, moving_direction, "moving_direction", none="s13")
    if moving_direction is not None:
        raise SynthesisError("moving_direction: only for two positions (s13 None); through "
                             "three the RP link is unique")
    return _link([_screw(s12, "s12"), _screw(s13, "s13")], "RP", "s12, s13")


def _cyl(s12, s13, kind, direction, dname):
    """PC (``direction``: the slide direction in the ground) or CP (``direction``: the slide
    direction in the body, position 1): one link, by 6 linear equations."""
    task = _task([_screw(s12, "s12"), _screw(s13, "s13")], "s12, s13", (3,))
    d = unit(direction, dname)
    u = _common_axis(task, "s12, s13")                       # the cylinder's axis direction
    if np.linalg.norm(np.cross(d, u)) < 1e-9:
        raise SynthesisError(f"{dname}: degenerate: parallel to the relative rotations' axis "
                             "(the slides along the two joints cannot be told apart)")
    Tn = task.Tn
    R, t = Tn[1:, :3, :3], Tn[1:, :3, 3]
    e1 = np.cross(u, [1.0, 0, 0] if abs(u[0]) < 0.9 else [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    A = np.zeros((6, 6))
    for j in range(2):
        rows = slice(3 * j, 3 * j + 3)
        A[rows, 0] = (np.eye(3) - R[j]) @ e1
        A[rows, 1] = (np.eye(3) - R[j]) @ e2
        if kind == "PC":                 # a_j along d (ground), b_j along u (cylinder axis)
            A[rows, 2 + j], A[rows, 4 + j] = d, u
        else:                            # a_j along u (cylinder), b_j along R_j d (body)
            A[rows, 2 + j], A[rows, 4 + j] = u, R[j] @ d
    sv = np.linalg.svd(A, compute_uv=False)
    if sv[-1] < 1e-9 * sv[0]:
        raise SynthesisError(f"{dname}: degenerate: the translation equations are singular "
                             f"(condition {sv[0] / max(sv[-1], 1e-300):.1e})")
    x = np.linalg.solve(A, t.reshape(-1))
    c = x[0] * e1 + x[1] * e2
    ang = np.r_[0.0, _signed_angle(np.broadcast_to(e1, (2, 3)), R @ e1, u)]
    L, cen = task.L, task.c
    cyl = Line(u, c * L + cen).canonical()
    pri = Line(d, cyl.point)
    z = np.zeros(3)
    first, second = np.r_[0.0, x[2:4] * L], np.r_[0.0, x[4:6] * L]
    if kind == "PC":
        pri = pri.canonical()
        link = BinaryLink("PC", pri, cyl.canonical(pri), np.inf, np.nan, z, first, ang, second,
                          0.0, {dname: d.copy()})
    else:
        link = BinaryLink("CP", cyl, pri.canonical(cyl), np.nan, np.inf, ang, first, z, second,
                          0.0, {dname: d.copy()})
    rot, pos = pose_errors(link.poses(), task.T, task.reach)
    link.residual = float(max(rot.max(), pos.max()))
    return [link]


def pc_links(s12, s13, fixed_direction) -> list[BinaryLink]:
    """The PC link (prismatic joint in the ground, cylindrical in the body) through three
    positions turned about one direction, for a chosen slide direction.

    The PC links through such positions form a two-parameter family: the slide
    direction (free) fixes the rest.

    Parameters
    ----------
    s12, s13 : Screw
        Displacements from position 1 to positions 2 and 3 (relative rotations about
        one direction).
    fixed_direction : array_like, shape (3,)
        Unit slide direction of the prismatic joint (the two free parameters).

    Returns
    -------
    list of one BinaryLink (``"PC"``).

    Raises
    ------
    SynthesisError
        Bad input (named); positions not turned about one direction; a slide direction
        along the rotation axis.
    """
    return _cyl(s12, s13, "PC", fixed_direction, "fixed_direction")


def cp_links(s12, s13, moving_direction) -> list[BinaryLink]:
    """The CP link (cylindrical joint in the ground, prismatic in the body) through three
    positions turned about one direction, for a chosen slide direction in the body.

    Parameters
    ----------
    s12, s13 : Screw
        Displacements from position 1 to positions 2 and 3 (relative rotations about
        one direction).
    moving_direction : array_like, shape (3,)
        Unit slide direction of the prismatic joint in position 1 (the two free
        parameters).

    Returns
    -------
    list of one BinaryLink (``"CP"``).

    Raises
    ------
    SynthesisError
        As :func:`pc_links`.
    """
    return _cyl(s12, s13, "CP", moving_direction, "moving_direction")


def _two(s12, kind, pitch, direction, dname, none=None):
    """PR, RP, PH, HP through two positions for a slide direction (user's units)."""
    sc = _screw(s12, "s12")
    if direction is None:
        pre = f"{none}: None means two positions, which need " if none else ""
        raise SynthesisError(f"{pre}{dname}: required (the slide direction, a unit 3-vector: "
                             "the two free parameters through two positions)")
    d = unit(direction, dname)
    task = _task([sc], "s12", (2,))
    if not sc.angle > 1e-6:
        raise SynthesisError(f"s12: (nearly) a pure translation (rotation {sc.angle:.1e} rad): "
                             f"the {kind[0] if kind[0] != 'P' else kind[1]} joint's axis is not "
                             "determined")
    w, phi = sc.axis, sc.angle
    R, t = task.R[0], task.t[0]
    pn = pitch / task.L
    e1 = np.cross(w, [1.0, 0, 0] if abs(w[0]) < 0.9 else [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(w, e1)
    if abs(d @ w) < 1e-9:
        raise SynthesisError(f"{dname}: degenerate: perpendicular to S_12's axis, so the slide "
                             "cannot supply the translation along it")
    first = kind[0] == "P"
    A = np.stack([d if first else R @ d, (np.eye(3) - R) @ e1, (np.eye(3) - R) @ e2], 1)
    x = np.linalg.solve(A, t - pn * phi * w)
    c = x[1] * e1 + x[2] * e2
    L, cen = task.L, task.c
    rot = Line(w, c * L + cen).canonical()
    z = np.zeros(2)
    sl = np.r_[0.0, x[0] * L]
    ang = np.r_[0.0, phi]
    p_user = float(pitch)
    rkind = "R" if pitch == 0 else "H"
    if first:
        pri = Line(d, rot.point).canonical()
        link = BinaryLink("P" + rkind, pri, rot.canonical(pri), np.inf, p_user, z, sl, ang,
                          p_user * ang, 0.0, {dname: d.copy()})
    else:
        pri = Line(d, rot.point).canonical(rot)
        link = BinaryLink(rkind + "P", rot, pri, p_user, np.inf, ang, p_user * ang, z, sl, 0.0,
                          {dname: d.copy()})
    rot_e, pos_e = pose_errors(link.poses(), task.T, task.reach)
    link.residual = float(max(rot_e.max(), pos_e.max()))
    return [link]


def ph_links(s12, *, pitch: float, fixed_direction) -> list[BinaryLink]:
    """The PH link (prismatic joint in the ground, helical in the body) through two
    positions for a chosen slide direction (pitch 0 gives the PR link).

    Parameters
    ----------
    s12 : Screw
        Displacement from position 1 to position 2 (must rotate).
    pitch : float
        The helical joint's pitch (length / rad); 0 makes it revolute (types ``"PR"``).
    fixed_direction : array_like, shape (3,)
        Unit slide direction in the ground: the two free parameters; not perpendicular
        to S₁₂'s axis.

    Returns
    -------
    list of one BinaryLink (``"PH"``): the helical axis is S₁₂'s axis direction, its angle
    S₁₂'s angle (rad, in (0, π]), its slide pitch · angle; ``fixed_slides`` the slide.

    Raises
    ------
    SynthesisError
        Bad input (named); S₁₂ a pure translation; a slide direction perpendicular to
        its axis.
    """
    p = number(pitch, "pitch", unit_="length/rad")
    return _two(s12, "PH", p, fixed_direction, "fixed_direction")


def hp_links(s12, *, pitch: float, moving_direction) -> list[BinaryLink]:
    """The HP link (helical joint in the ground, prismatic in the body) through two
    positions for a chosen slide direction in the body (pitch 0 gives the RP link).

    Parameters
    ----------
    s12 : Screw
        Displacement from position 1 to position 2 (must rotate).
    pitch : float
        The helical joint's pitch (length / rad); 0 makes it revolute (``"RP"``).
    moving_direction : array_like, shape (3,)
        Unit slide direction in the body in position 1: the two free parameters.

    Returns
    -------
    list of one BinaryLink (``"HP"``).

    Raises
    ------
    SynthesisError
        As :func:`ph_links`.
    """
    p = number(pitch, "pitch", unit_="length/rad")
    return _two(s12, "HP", p, moving_direction, "moving_direction")
