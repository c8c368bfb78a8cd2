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

from closure.frames import cross

from .dualquat import dq_conj, dq_from_matrix, dq_inv, dq_mul, dq_to_matrix
from .errors import SynthesisError
from .screw import Line, Screw, common_normal

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
        Largest pose error of the link's forward kinematics at the three positions.
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
        """Body pose (4x4, relative to position 1) at the given joint angles."""
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
        points, and are not determined), or when the problem degenerates
        otherwise; the message names the cause and the figure.
    """
    T2, T3 = s12.matrix(), s13.matrix()
    scale = max(1.0, np.abs(T2[:3, 3]).max(), np.abs(T3[:3, 3]).max(), np.abs(s12.point).max(),
                np.abs(s13.point).max())
    for name, T in (("S12", T2), ("S13", T3)):
        if np.abs(T - np.eye(4)).max() / scale < 1e-12:
            raise SynthesisError(f"{name} is the identity: two of the positions coincide")
    if np.abs(T2 - T3).max() / scale < 1e-12:
        raise SynthesisError("S12 equals S13: positions 2 and 3 coincide")
    for name, s in (("S12", s12), ("S13", s13)):
        if abs(s.angle) < 1e-6:
            size = abs(s.slide) / max(abs(s.angle), 1e-300)
            raise SynthesisError(
                f"{name} rotates by {s.angle:.1e} rad, (nearly) a pure translation: an RR link "
                "translates a body only with parallel axes (a planar motion, where RR links "
                "through three positions are not isolated); as the angle goes to zero the link "
                f"goes to infinity (size ~ slide/angle = {size:.1e})")
    # work in coordinates centred on the data and scaled to unit size (invariance, conditioning)
    c = 0.5 * (s12.point + s13.point)
    L = max(scale, 1e-300)
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
    if axes_par or min(abs(a), abs(b), abs(cc)) < 1e-14:
        what = ("the screw axes are parallel: the motion is planar and the RR links through three "
                "positions are not isolated (every circle point gives one)") if axes_par else \
            f"the Study products of the poses vanish (|B| = {min(abs(a), abs(b), abs(cc)):.1e})"
        raise SynthesisError(f"rr_links: degenerate positions, {what}; rotation angles "
                             f"{w2:.3g}, {w3:.3g} rad")
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
    ts = _parameters(c1, c0, P2, P3)
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
        link.residual = max(_pose_error(link.pose(fa[k], ma[k]), T, L)
                            for k, T in enumerate([np.eye(4), T2, T3]))
        if link.residual > tol * 1e3:
            raise SynthesisError(f"rr_links: a solution misses the positions by "
                                 f"{link.residual:.1e} (ill-conditioned positions)")
        out.append(link)
    return out


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


def _pose_error(A, B, length_scale=1.0):
    """Largest of the rotation error (rad) and the translation error (length)."""
    # ‖R − I‖_F = 2√2 |sin(θ/2)|: accurate for small θ, which is what a residual measures
    E = np.linalg.norm(A[:3, :3].T @ B[:3, :3] - np.eye(3))
    rot = 2 * np.arcsin(min(1.0, E / (2 * np.sqrt(2))))
    return float(max(rot, np.abs(A[:3, 3] - B[:3, 3]).max()))


def rotation_axis_between(m3, q3, m4, q4):
    """The pure rotation carrying the line (direction m3, point q3) pointwise to (m4, q4).

    Seed 001 (with DESIGN.md's correction): L ⊥ (M₄ − M₃), L ⊥ (Q₄ − Q₃); the
    angle from M₃ to M₄ about L, and the point from the plane rotation that
    takes Q₃ to Q₄.  Returns ``(Line, angle)``.

    Raises
    ------
    SynthesisError
        When no pure rotation exists (the two differences are parallel or zero).
    """
    m3, m4, q3, q4 = (np.asarray(v, float) for v in (m3, m4, q3, q4))
    dm, dq = m4 - m3, q4 - q3
    n = cross(dq, dm)
    size = max(1.0, np.abs(q3).max(), np.abs(q4).max())
    if np.linalg.norm(dm) < 1e-12 and np.linalg.norm(dq) < 1e-12 * size:
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
