"""RR links (two revolute joints) that guide a body through three positions.

Method (exact and algebraic, no search).  Written as dual quaternions, the
three poses 1 (the identity), S₁₂ and S₁₃ span a plane of P⁷ which cuts the
Study quadric in a conic: the motion of the Bennett linkage that Suh built
from the two RR solutions.  Parametrised with position 1 at t = ∞ it is a
monic quadratic motion polynomial ``C(t) = t² + c₁ t + c₀``.  Its norm
``C C̃`` is a real quartic without real roots; each of its two pairs of
complex-conjugate roots gives a real quadratic factor M(t), and the linear
remainder ``C − M = r₁ t + r₀`` yields the right factor ``t − h₂`` with
``h₂ = −r₁⁻¹ r₀``, then ``h₁ = −c₁ − h₂`` (Hegedüs, Schicho & Schröcker's
factorisation of motion polynomials).  So ``C(t) = (t − h₁)(t − h₂)``: a
rotation about the fixed axis (h₁) after one about the moving axis (h₂, in
position 1).  Computationally this is seed 001's "one cubic (the quartic's
resolvent), two quadratics and three linear systems", after Tsai.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from closure.frames import cross, rotation

from .dualquat import dq_conj, dq_from_matrix, dq_inv, dq_mul, dq_to_matrix
from .errors import SynthesisError
from .screw import Line, Screw, common_normal
from .validate import number, screw, task_scale, unit, vec3
from .verify import pose_error as _pose_error

__all__ = ["RRLink", "rr_links", "rotation_axis_between"]


@dataclass
class RRLink:
    """One RR link through three positions.

    Attributes
    ----------
    fixed_axis : Line
        Axis fixed in the ground (canonical point: foot of the perpendicular from the origin).
    moving_axis : Line
        Axis fixed in the body, in position 1 (canonical point: foot of the common normal).
    length : float
        Length of the common normal between the axes.
    twist : float
        Angle between the axes (rad, in [0, π]).
    fixed_angles, moving_angles : numpy.ndarray (3,)
        Joint angles at positions 1, 2, 3 (rad, zero at position 1).
    residual : float
        Largest pose error of the link's forward kinematics at the three positions:
        rotation (rad) or translation relative to the task's reach (the size of its
        coordinates, see :func:`synthesis.validate.task_scale`).
    """

    fixed_axis: Line
    moving_axis: Line
    length: float
    twist: float
    fixed_angles: np.ndarray
    moving_angles: np.ndarray
    residual: float
    info: dict = field(default_factory=dict)

    def pose(self, fixed_angle: float, moving_angle: float) -> np.ndarray:
        """Body pose (4x4, relative to position 1) at the given joint angles (rad)."""
        fixed_angle = number(fixed_angle, "fixed_angle", unit_="rad")
        moving_angle = number(moving_angle, "moving_angle", unit_="rad")
        return _rot(self.fixed_axis, fixed_angle) @ _rot(self.moving_axis, moving_angle)


def _rot(line: Line, angle: float) -> np.ndarray:
    """4x4 rotation by ``angle`` about ``line`` (Rodrigues; the direction is unit)."""
    u = line.direction
    c, s = np.cos(angle), np.sin(angle)
    K = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    R = c * np.eye(3) + s * K + (1 - c) * np.outer(u, u)
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = line.point - R @ line.point
    return T


def _study(a, b):
    """Study bilinear form ½(r_a·d_b + r_b·d_a)."""
    return 0.5 * (a[:4] @ b[4:] + b[:4] @ a[4:])


def _axis_of_factor(h):
    """Line of the rotation factor ``t − h`` (h a dual quaternion with pure dual scalar)."""
    v = h[1:4]
    n = np.linalg.norm(v)
    if n < 1e-12:
        raise SynthesisError("degenerate factor: the rotation axis has no direction")
    # (t − h) = (t − h0) − v − ε (h_d0 + v_d): a line (direction u, moment m) with v = n u,
    # v_d = n m (pure rotation needs h_d0 = 0)
    u = v / n
    m = h[5:8] / n
    return Line(u, cross(u, m)), float(h[4] / n)


def _angle_about(line, T_factor):
    """Signed rotation angle of a transform about a line's direction."""
    R = T_factor[:3, :3]
    u = line.direction
    a = np.array([1.0, 0, 0]) if abs(u[0]) < 0.9 else np.array([0, 1.0, 0])
    a = a - (a @ u) * u
    a /= np.linalg.norm(a)
    b = R @ a
    return float(np.arctan2(cross(a, b) @ u, a @ b))


def rr_links(s12: Screw, s13: Screw, *, tol: float = 1e-9) -> list[RRLink]:
    """Both RR links that carry a body through positions 1, 2, 3.

    Parameters
    ----------
    s12, s13 : Screw
        Displacements from position 1 to positions 2 and 3.

    Returns
    -------
    list of two :class:`RRLink` (ordered by the root pairs of the norm polynomial).

    Raises
    ------
    SynthesisError
        When the positions coincide, when the screws are parallel (a planar
        motion: the RR links then form a two-parameter family, the circle
        points, and are not determined), when the positions are spherical (all
        relative screws pure rotations about one point, to within the round-off
        of the coordinates or so nearly that the links could not be trusted to
        ``tol * 1e3``: see the notes), or when the problem degenerates otherwise;
        the message names the cause and the figure.

    Notes
    -----
    Spherical positions (the screws' axes concurrent, no slides: e.g. those of a
    generating RR whose axes intersect) do not determine an RR link.  All the
    poses then lie in the 3-dimensional space of rotations about the common point
    O, so every quadratic motion through the three poses, and hence every RR link
    reaching them, is spherical: there is no RR with skew axes, and every line
    through O fixed in the body traces a circle whose axis through O completes a
    spherical RR (a two-parameter family).  As the task approaches a spherical one
    its own size L (the largest translation and axis distance about the point
    nearest the axes, :func:`synthesis.validate.task_scale`) goes to zero while
    the round-off of its coordinates stays ``ε · reach``: the axes found are then
    accurate only to about ``ε · reach / L`` (measured: 0.3–2 times that, in
    direction and in position relative to L).  Each link's ``info["accuracy"]``
    is a forward-error estimate measured by re-solving the positions moved by
    their round-off (so it also covers an ill-conditioned Bennett motion, e.g. a
    relative screw nearly a pure rotation); above ``tol * 1e3`` rr_links raises
    instead, naming the positions "nearly spherical" when that is the cause.  A task whose round-off is not visible in
    its coordinates (e.g. rotations about the origin computed from points of size
    1 with a 1e-17 remainder of translation) is, as data, a task of that tiny size:
    its own RR links are returned (unit invariance forbids an absolute floor).
    """
    s12, s13 = screw(s12, "s12"), screw(s13, "s13")
    tol = number(tol, "tol", positive=True)
    T2, T3 = s12.matrix(), s13.matrix()
    # the task's size: tolerances are relative to it (rigid motion and unit invariant)
    c, L, reach = task_scale([T2, T3], [s12.axis, s13.axis], [s12.point, s13.point])
    for name, T in (("S12", T2), ("S13", T3)):
        if _pose_error(T, np.eye(4), reach) < 1e-12:
            raise SynthesisError(f"{name} is the identity: two of the positions coincide")
    if _pose_error(T2, T3, reach) < 1e-12:
        raise SynthesisError("S12 equals S13: positions 2 and 3 coincide")
    for name, s in (("S12", s12), ("S13", s13)):
        if abs(s.angle) < 1e-6:
            size = abs(s.slide) / max(abs(s.angle), 1e-300)
            raise SynthesisError(
                f"{name} rotates by {s.angle:.1e} rad, (nearly) a pure translation: an RR link "
                "translates a body only with parallel axes (a planar motion, where RR links "
                "through three positions are not isolated); as the angle goes to zero the link "
                f"goes to infinity (size ~ slide/angle = {size:.1e})")
    _check_spherical(c, L, reach, tol)
    # work in coordinates centred on the task and scaled to its size (invariance, conditioning)
    C = np.eye(4)
    C[:3, 3] = -c
    S = np.diag([1 / L, 1 / L, 1 / L, 1.0])
    Tn = S @ C
    Ti = np.linalg.inv(Tn)
    P0 = dq_from_matrix(np.eye(4))
    P2 = dq_from_matrix(Tn @ T2 @ Ti)
    P3 = dq_from_matrix(Tn @ T3 @ Ti)
    a, b, cc = _study(P0, P2), _study(P0, P3), _study(P2, P3)
    w2, w3 = s12.angle, s13.angle
    axes_par = abs(abs(s12.axis @ s13.axis) - 1) < 1e-10
    # Study products are the pitches of S12, S13, S23 (normalised lengths): round-off
    # makes them ~ε·reach/L, so "zero" is relative to that
    if not axes_par and max(abs(a), abs(b), abs(cc)) < 1e-14 * (reach / L):
        # all three relative screws (S12, S13, S23) are pure rotations, about axes that
        # meet pairwise: one common point (an exactly scale-free task lands here)
        _spherical_error(c, L, reach, np.inf, "exactly")
    if axes_par or min(abs(a), abs(b), abs(cc)) < 1e-14 * (reach / L):
        what = ("the screw axes are parallel: the motion is planar and the RR links through three "
                "positions are not isolated (every circle point gives one)") if axes_par else \
            f"the Study products of the poses vanish (|B| = {min(abs(a), abs(b), abs(cc)):.1e})"
        raise SynthesisError(f"rr_links: degenerate positions, {what}; rotation angles "
                             f"{w2:.3g}, {w3:.3g} rad")
    c1, c0, factors = _factors(P0, P2, P3)
    ts = _parameters(c1, c0, P2, P3)
    # forward-error estimate: the round-off of the coordinates (ε·reach, i.e. ε·reach/L
    # here) times the sensitivity of the axes, measured by re-solving perturbed positions
    acc = _accuracy(Tn @ T2 @ Ti, Tn @ T3 @ Ti, factors, L, reach)
    _check_accuracy(acc, tol, c, L, reach, w2, w3)
    out = []
    for h1, h2 in factors:
        g, _ = _axis_of_factor(h1)
        w, _ = _axis_of_factor(h2)
        # back to the user's coordinates
        g = Line(g.direction, g.point * L + c)
        w = Line(w.direction, w.point * L + c)
        g = g.canonical()
        w = w.canonical(g)
        fa, ma = [0.0], [0.0]
        for t in ts:
            F1 = Ti @ dq_to_matrix(np.r_[t, 0, 0, 0, 0, 0, 0, 0] - h1) @ Tn
            F2 = Ti @ dq_to_matrix(np.r_[t, 0, 0, 0, 0, 0, 0, 0] - h2) @ Tn
            fa.append(_angle_about(g, F1))
            ma.append(_angle_about(w, F2))
        foot_g, foot_w = common_normal(g, w)
        link = RRLink(g, w, float(np.linalg.norm(foot_w - foot_g)),
                      float(np.arccos(np.clip(g.direction @ w.direction, -1, 1))),
                      np.array(fa), np.array(ma), 0.0)
        link.residual = max(_pose_error(link.pose(fa[k], ma[k]), T, reach)
                            for k, T in enumerate([np.eye(4), T2, T3]))
        if link.residual > tol * 1e3:
            raise SynthesisError(f"rr_links: a solution misses the positions by "
                                 f"{link.residual:.1e} (ill-conditioned positions)")
        # a link that misses the positions is no better than its miss (relative to L)
        link.info["accuracy"] = max(acc, link.residual * reach / L)
        _check_accuracy(link.info["accuracy"], tol, c, L, reach, w2, w3)
        out.append(link)
    return out


def _check_accuracy(acc, tol, c, L, reach, w2, w3):
    """Raise when the RR axes are known to worse than ``tol * 1e3``: spherical positions
    when that is the cause (the task small against its coordinates), else ill-conditioned."""
    if acc <= tol * 1e3:
        return
    if reach / L > 1e3 and _EPS * reach / L > 1e-3 * acc:
        _check_spherical(c, L, reach, 0.0, acc)
    also = (f"; the task is also nearly spherical: its own size is {L / reach:.1e} of its "
            f"coordinates' size {reach:.1e}, about the point "
            f"({', '.join(f'{v:.6g}' for v in c)})") if reach / L > 1e3 else ""
    raise SynthesisError(
        f"rr_links: ill-conditioned positions: the RR axes would be known only to ~{acc:.1e} "
        f"(rad, or relative to the task's size {L:.1e}): re-solving positions moved by their "
        f"round-off moves the axes that much (near-degenerate Bennett motion: a relative "
        f"screw nearly a pure rotation or translation, or nearly parallel axes?){also}; "
        f"rotation angles {w2:.3g}, {w3:.3g} rad")


_EPS = float(np.finfo(float).eps)


def _accuracy(T2n, T3n, factors, L, reach, trials: int = 2) -> float:
    """Forward-error estimate of the RR axes (direction in rad, position relative to the
    task's size L), from the normalised positions ``T2n, T3n`` and their ``factors``.

    The positions are known to their round-off: ε in rotation and ε·reach in
    translation (ε·reach/L in the normalised coordinates).  They are moved by random
    displacements of that size times an amplification (so the change is well above the
    solve's own round-off), re-solved, and the largest change of the axes (Plücker
    coordinates in the normalised frame) is scaled back.  A nearly spherical task
    (L ≪ reach) gives about ε·reach/L (measured errors: 0.3–2 times that); a generic
    one a few tens of ε; an ill-conditioned Bennett motion more.  A perturbation that
    makes the problem degenerate gives inf."""
    noise = _EPS * (reach / L + 1.0)
    amp = min(1e4, 1e-7 / noise) if noise < 1e-7 else 1.0
    rng = np.random.default_rng(0)          # deterministic: the same task, the same figure
    P0 = dq_from_matrix(np.eye(4))
    ref = [_pluecker(h) for pair in factors for h in pair]
    worst = 0.0
    for _ in range(trials):
        P = []
        for T in (T2n, T3n):
            E = np.eye(4)
            E[:3, :3] = rotation(_unit_random(rng), amp * _EPS)
            E[:3, 3] = amp * noise * _unit_random(rng)
            P.append(dq_from_matrix(E @ T))
        try:
            with np.errstate(all="raise"):
                _, _, fac = _factors(P0, P[0], P[1])
                got = [_pluecker(h) for pair in fac for h in pair]
        except (SynthesisError, np.linalg.LinAlgError, FloatingPointError, ValueError):
            return float("inf")
        if len(got) != len(ref):
            return float("inf")
        for r in ref:      # the pairs may swap order: match each axis to its nearest
            d = min(min(np.abs(r - q).max(), np.abs(r + q).max()) for q in got)
            worst = max(worst, d)
    return float(max(worst / amp, 32 * _EPS))


def _unit_random(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _pluecker(h):
    """Unit direction and moment of the axis of a rotation factor (normalised frame)."""
    v = h[1:4]
    n = np.linalg.norm(v)
    if n < 1e-300:
        raise SynthesisError("degenerate factor")
    return np.r_[v / n, h[5:8] / n]


def _check_spherical(c, L, reach, tol, acc=None):
    """Raise when the task is (nearly) spherical: its own size L is so small against the
    size of its coordinates that the RR axes would be known to worse than ``tol * 1e3``
    (``acc``: the measured estimate, else the round-off ratio 2 ε·reach/L)."""
    if acc is None:
        acc = 2 * _EPS * reach / L
    if acc > tol * 1e3:
        _spherical_error(c, L, reach, acc, "to within round-off" if acc > 1e-3 else "nearly")


def _spherical_error(c, L, reach, acc, how):
    # the centre to the coordinates' round-off (a point at the origin prints as 0, not 1e-17)
    x, y, z = (0.0 if abs(v) <= 1e-12 * reach else float(v) for v in c)
    size = ("the task has no length at all" if not np.isfinite(acc) else
            f"the task's own size {L:.1e} is {L / reach:.1e} of its coordinates' size "
            f"{reach:.1e}, so an RR link would be known only to ~{acc:.1e}")
    raise SynthesisError(
        f"rr_links: the positions are spherical ({how}): all relative screws are pure rotations "
        f"about one point ({x:.6g}, {y:.6g}, {z:.6g}) ({size}); the RR link is not isolated: "
        "every line through that point, fixed in the body, traces a circle whose axis through "
        "the point completes a spherical RR (a two-parameter family, and no RR with skew axes "
        "reaches the positions), so a generating RR cannot be recovered from three spherical "
        "positions")


def _factors(P0, P2, P3):
    """The monic quadratic motion ``C(t) = t² + c₁ t + c₀`` through the normalised poses
    (P0 at t = ∞) and its two factorisations ``(t − h₁)(t − h₂)``: ``(c1, c0, [(h1, h2)])``."""
    a, b, cc = _study(P0, P2), _study(P0, P3), _study(P2, P3)
    # the conic  a x0 x2 + b x0 x3 + c x2 x3 = 0  with P0 at t = ∞ (see the module notes)
    c1 = -cc * P0 - b * P2 + a * P3
    c0 = a * P2
    lead = cc * b / a
    c1, c0 = c1 / lead, c0 / lead
    # norm polynomial N(t) = C(t) C̃(t): real quartic (its dual part vanishes)
    one = np.r_[1.0, np.zeros(7)]
    coeffs = [one, c1, c0]                     # t², t, 1
    Np = np.zeros((5, 8))
    for i, ci in enumerate(coeffs):
        for k, ck in enumerate(coeffs):
            Np[i + k] += dq_mul(ci, dq_conj(ck))
    study_err = np.abs(Np[:, 4:]).max() / np.abs(Np[:, 0]).max()
    if study_err > 1e-8:
        raise SynthesisError(f"rr_links: the interpolating motion leaves the Study quadric "
                             f"({study_err:.1e}); positions numerically degenerate")
    roots = np.roots(Np[:, 0])
    if np.any(np.abs(roots.imag) < 1e-10 * np.maximum(1.0, np.abs(roots))):
        raise SynthesisError("rr_links: the norm polynomial has real roots: the interpolating "
                             "Bennett motion degenerates (positions related by a pure "
                             "rotation or translation?)")
    up = roots[roots.imag > 0]
    up = up[np.argsort(up.real)]
    out = []
    for z in up:
        m1, m0 = -2 * z.real, abs(z) ** 2
        r1 = c1 - m1 * one
        r0 = c0 - m0 * one
        h2 = -dq_mul(dq_inv(r1), r0)
        h1 = -c1 - h2
        for h in (h1, h2):
            if abs(h[4]) > 1e-8 * max(1.0, np.abs(h).max()):
                raise SynthesisError(f"rr_links: a factor is a screw, not a rotation "
                                     f"(dual scalar {h[4]:.1e})")
        out.append((h1, h2))
    return c1, c0, out


def _parameters(c1, c0, P2, P3):
    """Parameters t₂, t₃ at which C(t) passes through positions 2 and 3 (least squares on
    C(t) ∥ P_j, solved exactly as a quadratic's common root)."""
    ts = []
    one = np.r_[1.0, np.zeros(7)]
    for P in (P2, P3):
        # C(t) = λ P  ⇔  components orthogonal to P vanish: project onto the complement
        Pn = P / np.linalg.norm(P)
        proj = np.eye(8) - np.outer(Pn, Pn)
        A = np.stack([proj @ one, proj @ c1, proj @ c0], 1)      # (8, 3) for t², t, 1
        # the quadratic t² A0 + t A1 + A2 = 0 in all rows: take the row-space combination
        best, tbest = np.inf, None
        for t in np.roots(A[np.argmax(np.abs(A).sum(1))]):
            if abs(t.imag) > 1e-8 * max(1, abs(t)):
                continue
            t = t.real
            r = np.linalg.norm(A @ np.r_[t * t, t, 1.0]) / max(1.0, t * t)
            if r < best:
                best, tbest = r, t
        if tbest is None:
            raise SynthesisError("rr_links: no real parameter for a position on the motion")
        ts.append(tbest)
    return ts


def rotation_axis_between(m3, q3, m4, q4):
    """The pure rotation carrying the line (direction m3, point q3) pointwise to (m4, q4).

    Seed 001 (its misprint (Q₁ − Q₃) read as (Q₄ − Q₃)): L ⊥ (M₄ − M₃), L ⊥ (Q₄ − Q₃); the
    angle from M₃ to M₄ about L, and the point from the plane rotation that
    takes Q₃ to Q₄.  Returns ``(Line, angle)``.

    Parameters
    ----------
    m3, m4 : array_like, shape (3,)
        Unit directions of the line in its two positions.
    q3, q4 : array_like, shape (3,)
        Corresponding points of the line (length unit of the task).

    Raises
    ------
    SynthesisError
        Bad input (naming the argument), or when no pure rotation exists (the two
        differences are parallel or zero).
    """
    m3, m4 = unit(m3, "m3"), unit(m4, "m4")
    q3, q4 = vec3(q3, "q3"), vec3(q4, "q4")
    dm, dq = m4 - m3, q4 - q3
    n = cross(dq, dm)
    size = max(np.abs(q3).max(), np.abs(q4).max())      # the coordinates' size (round-off)
    if np.linalg.norm(dm) < 1e-12 and np.linalg.norm(dq) <= 1e-12 * size:
        raise SynthesisError("axis 1: axis 3 does not move between the two positions (the "
                             "positions coincide)")
    if np.linalg.norm(n) <= 1e-10 * np.linalg.norm(dq) * np.linalg.norm(dm):
        raise SynthesisError("axis 1: (Q4 − Q3) and (M4 − M3) are parallel or zero; no unique "
                             "pure rotation carries axis 3 between the two positions")
    L = n / np.linalg.norm(n)
    # orient L so that the rotation angle of M is in (0, π]
    a = m3 - (m3 @ L) * L
    b = m4 - (m4 @ L) * L
    if np.linalg.norm(a) < 1e-12:
        raise SynthesisError("axis 1: axis 3 is parallel to the rotation axis")
    ang = float(np.arctan2(cross(a, b) @ L, a @ b))
    if abs(np.sin(ang / 2)) < 1e-12:
        raise SynthesisError("axis 1: axis 3 is not turned between the two positions")
    # the centre of the plane rotation by ang that takes Q3 to Q4 (Q4 − Q3 ⊥ L):
    # midpoint + ½ cot(ang/2) L × (Q4 − Q3); then the foot from the origin
    P = 0.5 * (q3 + q4) + 0.5 / np.tan(ang / 2) * cross(L, dq)
    P = P - (P @ L) * L
    return Line._exact(L, P), ang
