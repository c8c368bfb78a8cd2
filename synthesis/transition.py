"""Transition joints of the family decompositions (Kharatyan 1981): the joint that carries
the body from a transition position s to the remaining positions while the main binary
link's joint in the body (J3, already known) turns freely.

The problem.  Find a joint X (its axis ``t`` in the ground) such that, for every remaining
position l, ``T_l = X_t(ψ_l) · Y_s(Δ_l) · T_s``, where ``Y_s`` is J3's screw motion about its
axis at position s (angle Δ_l, slide σ_l: 0 for R, pitch·Δ_l for H, free for C; P slides
only).  With ``D_l = T_l T_s⁻¹`` this reads ``E_l = D_l Y_s(−Δ_l, −σ_l) = X_t(ψ_l)``: a
binary link (X, J3) whose moving joint is known.

Written with dual quaternions (``q = r + ε d``, :mod:`synthesis.dualquat`), the screw of
J3 is linear in ``(cos Δ/2, sin Δ/2)`` and in σ times them, so every condition below is a
small closed form:

* X revolute (one remaining position): E must have zero slide, i.e. the scalar dual part
  of ``q_D q_Y(−Δ, −σ)`` vanishes: ``f = α cos Δ/2 + β sin Δ/2 + σ (γ cos Δ/2 + δ sin Δ/2)
  = 0``.  J3 = R (σ = 0): one root Δ (mod 2π), the unique pure rotation (R carrying an R
  axis, five conditions).  J3 = P (Δ = 0): σ = −α/γ.  J3 = H (σ = pΔ): the roots of a
  transcendental equation on Δ ∈ (−π, π], all found on a fine grid and refined.  J3 = C:
  a one-parameter family; the free parameter is J3's rotation Δ (``transition_angle``,
  rad) and σ follows linearly.  The transition axis is E's axis.
* X cylindrical (two remaining positions l, m, J3 = C): the rotation parts
  ``r_D (cos Δ/2 − sin Δ/2 u)`` have vector parts in the plane spanned by ``vec(r_D)`` and
  ``vec(r_D u)``; the two planes meet in the single direction w of the C axis (up to
  sign), which fixes Δ_l, Δ_m; the axis moments are then affine in σ_l, σ_m and equal for
  one (σ_l, σ_m), by a 3x2 linear least-squares solve that must be consistent.

Batches.  :func:`transition_joints` solves n problems of one kind at once (the family
enumerations collect every variant's problem first); :func:`transition_joint` is its
one-problem form.  The R transitions run in a compiled kernel, one problem after another
(:mod:`synthesis.transition_kernels`), the C transitions as numpy arrays over the problems.

Sphere-ended transitions (R or P carrying a sphere centre) are point problems: see
:func:`synthesis.dyads.circle_axis` and the PRS construction.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .binary import _screw_matrix
from .dualquat import dq_from_matrix, dq_mul, qmul
from .errors import SynthesisError
from .screw import Line

__all__ = ["Transition", "Transitions", "transition_joint", "transition_joints",
           "TRANSITION_POSITIONS"]

#: (transition joint, J3) → remaining positions it carries (the counting of the module notes)
TRANSITION_POSITIONS = {("R", "R"): 1, ("R", "H"): 1, ("R", "P"): 1, ("R", "C"): 1,
                        ("C", "C"): 2}


@dataclass
class Transition:
    """One transition joint: its axis ``line`` (ground, position-1 location of the body: the
    axis at the configuration of the transition position), its joint values ``psi (k, 2)``
    (angle rad, slide length) and J3's increments ``delta (k, 2)`` (angle, slide) at the
    remaining positions."""

    line: Line
    psi: np.ndarray
    delta: np.ndarray


@dataclass
class Transitions:
    """The transition joints of n problems (:func:`transition_joints`), m joints in all.

    Attributes
    ----------
    owner : numpy.ndarray of int, shape (m,)
        The problem each joint solves (ascending; a problem's joints in the order of
        :func:`transition_joint`).
    direction, point : numpy.ndarray, shape (m, 3)
        Each joint's axis: unit direction and the foot of the perpendicular from the origin
        (length), in the ground at the configuration of the transition position.
    psi, delta : numpy.ndarray, shape (m, k, 2)
        The joint's values and J3's increments at the k remaining positions (angle rad,
        slide length).
    error : numpy.ndarray of object, shape (n,)
        ``""``, or why problem i has no joint (a degenerate configuration; none of its
        joints is then listed).  A problem without error may still have no joint (an H
        carried without a real root).
    """

    owner: np.ndarray
    direction: np.ndarray
    point: np.ndarray
    psi: np.ndarray
    delta: np.ndarray
    error: np.ndarray


def _dot(a, b):
    """Dot products over the last axis (broadcast)."""
    return np.einsum("...i,...i->...", a, b)


def _cross(a, b):
    """Cross products of 3-vectors ``(..., 3)`` (broadcast)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def _screw_dq(u, m, angle, slide):
    """Dual quaternions ``(..., 8)`` of the screws about the lines with Plücker coordinates
    ``(u, m = p × u) (..., 3)`` by ``angle`` (rad) and ``slide`` (length), broadcast."""
    angle, slide = np.asarray(angle, float), np.asarray(slide, float)
    c, s = np.cos(angle / 2)[..., None], np.sin(angle / 2)[..., None]
    h = 0.5 * slide[..., None]
    out = np.empty(np.broadcast_shapes(angle.shape, slide.shape, u.shape[:-1]) + (8,))
    out[..., :1] = c
    out[..., 1:4] = s * u
    out[..., 4:5] = -h * s
    out[..., 5:] = h * c * u + s * m
    return out


def _screw_of(E):
    """Axes u (unit), points (foot from the origin), angles in [0, π] and slides of rigid
    motions ``E (n, 4, 4)`` that turn (angle > 0; where one does not, angle 0, u and the
    point NaN)."""
    from .dualquat import quat_from_rotation
    q = quat_from_rotation(E[..., :3, :3])
    sh = np.sqrt(_dot(q[..., 1:], q[..., 1:]))
    ang = 2 * np.arctan2(sh, q[..., 0])
    with np.errstate(invalid="ignore", divide="ignore"):
        u = q[..., 1:] / sh[..., None]
        t = E[..., :3, 3]
        slide = _dot(t, u)
        tp = t - slide[..., None] * u
        p = 0.5 * (tp + _cross(u, tp) / np.tan(ang / 2)[..., None])
        p = p - _dot(p, u)[..., None] * u
    return u, p, ang, slide


def transition_joints(kind: str, y_kind: str, direction, point, y_pitch, D, length: float,
                      *, angle=None) -> Transitions:
    """All transition joints of kind ``kind`` carrying J3 for n problems at once (see the
    module notes and :func:`transition_joint`, the one-problem form).

    Parameters
    ----------
    kind : str
        The transition joint: ``"R"`` (one remaining position) or ``"C"`` (two, J3 = C).
    y_kind : str
        J3's kind: R, H, P or C.
    direction, point : array_like, shape (n, 3)
        J3's axes at the transition positions: unit directions (for P: the slide
        directions) and points on them (length).
    y_pitch : float or array_like, shape (n,)
        J3's pitch (length/rad) when ``y_kind`` is H.
    D : array_like, shape (n, k, 4, 4)
        ``T_l T_s⁻¹`` for the k remaining positions l of each problem.
    length : float
        The task's reach (round-off thresholds).
    angle : array_like, shape (n,), optional
        J3's rotation Δ (rad) for an R transition carrying a C joint (the free
        parameter); required then.

    Returns
    -------
    Transitions
        The joints of every problem, and per problem the reason (an empty string when
        none) it has no joint.

    Raises
    ------
    SynthesisError
        Naming the argument: an unimplemented pair of kinds, or arrays of the wrong shape.
    """
    key = (kind, y_kind)
    if key not in TRANSITION_POSITIONS:
        raise SynthesisError(f"transition: a {kind} joint carrying a {y_kind} joint is not "
                             "implemented")
    k = TRANSITION_POSITIONS[key]
    D = np.asarray(D, float)
    if D.ndim != 4 or D.shape[2:] != (4, 4):
        raise SynthesisError(f"D: expected an (n, k, 4, 4) array of displacements, got shape "
                             f"{D.shape}")
    n = len(D)
    if D.shape[1] != k:
        raise SynthesisError(f"transition: {kind} carrying {y_kind} takes {k} remaining "
                             f"positions, got {D.shape[1]}")
    u, p = np.asarray(direction, float), np.asarray(point, float)
    if u.shape != (n, 3) or p.shape != (n, 3):
        raise SynthesisError(f"direction, point: expected ({n}, 3) arrays (one J3 axis per "
                             f"problem of D), got shapes {u.shape}, {p.shape}")
    pitch = np.asarray(y_pitch, float)
    if pitch.shape not in ((), (n,)):
        raise SynthesisError(f"y_pitch: expected a number or ({n},) numbers, got shape "
                             f"{pitch.shape}")
    pitch = np.broadcast_to(pitch, (n,))
    if key == ("R", "C"):
        if angle is None:
            raise SynthesisError("angle: required for an R transition carrying a C joint "
                                 "(J3's rotation, rad)")
        angle = np.asarray(angle, float)
        if angle.shape not in ((), (n,)):
            raise SynthesisError(f"angle: expected a number or ({n},) angles (rad), got shape "
                                 f"{angle.shape}")
        angle = np.broadcast_to(angle, (n,))
    if n == 0:
        e = np.zeros((0, 3))
        return Transitions(np.zeros(0, np.int64), e, e, np.zeros((0, k, 2)), np.zeros((0, k, 2)),
                           np.zeros(0, dtype=object))
    m = _cross(p, u)
    if kind == "R":
        return _revolute(y_kind, u, m, p, pitch, D[:, 0], length, angle)
    return _cylindric(u, m, p, D, length)


def transition_joint(kind: str, y_kind: str, y_line: Line, y_pitch: float, D, length: float,
                     *, angle: float | None = None) -> list[Transition]:
    """All transition joints of kind ``kind`` carrying J3 (``y_kind`` on ``y_line`` at the
    transition position) through the relative displacements ``D`` (one problem of
    :func:`transition_joints`).

    Parameters
    ----------
    kind : str
        The transition joint: ``"R"`` (one remaining position) or ``"C"`` (two, J3 = C).
    y_kind : str
        J3's kind: R, H, P or C.
    y_line : Line
        J3's axis at the transition position (for P: its slide direction).
    y_pitch : float
        J3's pitch (length/rad) when ``y_kind`` is H.
    D : array_like, shape (k, 4, 4)
        ``T_l T_s⁻¹`` for the remaining positions l.
    length : float
        The task's reach (round-off thresholds).
    angle : float, optional
        J3's rotation Δ (rad) for an R transition carrying a C joint (the free parameter).

    Returns
    -------
    list of Transition (empty when no real solution exists).

    Raises
    ------
    SynthesisError
        A degenerate configuration (the reason names it).
    """
    D = np.asarray(D, float).reshape(1, -1, 4, 4)
    tr = transition_joints(kind, y_kind, y_line.direction[None], y_line.point[None], y_pitch,
                           D, length, angle=None if angle is None else [angle])
    if tr.error[0]:
        raise SynthesisError(tr.error[0])
    return [Transition(Line._exact(tr.direction[i], tr.point[i]), tr.psi[i], tr.delta[i])
            for i in range(len(tr.owner))]


#: the H roots' bracketing grid on [−π, π] (2048 intervals)
_H_GRID = np.linspace(-np.pi, np.pi, 2049)

_MESSAGES = {
    1: "transition: every rotation of J3 leaves a pure rotation (the remaining position is on "
       "J3's own motion): degenerate",
    2: "transition: J3's slide does not change the transition's slide (slide direction ⊥ the "
       "rotation axis): degenerate",
    3: "transition_angle {:.6g}: J3's slide cannot cancel the transition's slide at this "
       "angle: degenerate",
    4: "transition: the transition joint would not turn (the remaining position is reached by "
       "J3 alone): degenerate",
    5: "transition: no pure rotation (slide {:.2e} left): degenerate"}


def _revolute(y_kind, u, m, p, pitch, D, length, angle):
    """R transitions (one remaining position, ``D (n, 4, 4)``), by the compiled kernel
    :func:`synthesis.transition_kernels.revolute`."""
    from .transition_kernels import revolute
    n = len(D)
    owner, out, code, value = revolute(
        "RPHC".index(y_kind), np.ascontiguousarray(u), np.ascontiguousarray(m),
        np.ascontiguousarray(p), np.ascontiguousarray(pitch, dtype=float),
        np.ascontiguousarray(D), float(length),
        np.zeros(n) if angle is None else np.ascontiguousarray(angle, dtype=float), _H_GRID)
    error = np.full(n, "", dtype=object)
    for i in np.flatnonzero(code):
        error[i] = _MESSAGES[code[i]].format(value[i])
    z = np.zeros(len(owner))
    return Transitions(owner, out[:, 3:6], out[:, 6:9], np.stack([out[:, 2], z], -1)[:, None],
                       out[:, None, 0:2], error)


def _cylindric(u, m, p, D, length):
    """C transitions carrying a C joint (two remaining positions, ``D (n, 2, 4, 4)``) for
    J3's Plücker lines ``u, m`` and points ``p (n, 3)``, as arrays over the problems (see
    the module notes)."""
    n = len(D)
    error = np.full(n, "", dtype=object)
    qs = dq_from_matrix(D)                                                  # (n, 2, 8)
    uq = np.concatenate([np.zeros((n, 1)), u], -1)[:, None]
    A0, B0 = qs[..., 1:4], qmul(qs[..., :4], -uq)[..., 1:]                  # spans of vec(r_E(Δ))
    nrm = _cross(A0, B0)                                                    # (n, 2, 3)
    w = _cross(nrm[:, 0], nrm[:, 1])
    nn = np.sqrt(_dot(nrm, nrm))
    wn = np.sqrt(_dot(w, w))
    ok = ~((nn.min(1) < 1e-12) | (wn < 1e-10))
    error[~ok] = ("transition: the C axis direction is not determined (the rotations' planes "
                  "coincide): degenerate")
    with np.errstate(invalid="ignore", divide="ignore"):
        w = w / wn[:, None]
        M = np.stack([_cross(A0, w[:, None]), _cross(B0, w[:, None])], -1)  # (n, 2, 3, 2)
        M = np.where(ok[:, None, None, None], M, np.eye(3, 2))
        _, _, Vt = np.linalg.svd(M)
        cs = Vt[..., -1, :] / np.sqrt(_dot(Vt[..., -1, :], Vt[..., -1, :]))[..., None]
        dl = 2 * np.arctan2(cs[..., 1], cs[..., 0])                         # (n, 2)
        um, mm = u[:, None], m[:, None]
        e0 = dq_mul(qs, _screw_dq(um, mm, -dl, 0.0))
        e1 = dq_mul(qs, _screw_dq(um, mm, -dl, -1.0)) - e0
        sh, ch = _dot(e0[..., 1:4], w[:, None]), e0[..., 0]
        turn = ~(np.abs(sh) < 1e-9).any(1)
        error[ok & ~turn] = ("transition: the C transition joint would not turn at a remaining "
                             "position: degenerate")
        ok &= turn
        # moment m(σ) = (v_d − (d/2) ch w)/sh with d = −2 s_d / sh: affine in σ
        mom0 = (e0[..., 5:] + (e0[..., 4] / sh * ch)[..., None] * w[:, None]) / sh[..., None]
        mom1 = (e1[..., 5:] + (e1[..., 4] / sh * ch)[..., None] * w[:, None]) / sh[..., None]
        A = np.stack([mom1[:, 0], -mom1[:, 1]], -1)                         # (n, 3, 2)
        rhs = mom0[:, 1] - mom0[:, 0]
        A = np.where(ok[:, None, None], A, np.eye(3, 2))
        rhs = np.where(ok[:, None], rhs, 0.0)
        sig = _lstsq(A, rhs)
        res = np.einsum("nij,nj->ni", A, sig) - rhs
        mis = np.sqrt(_dot(res, res))
    bad = ok & (mis > 1e-8 * np.maximum(1.0, np.sqrt(_dot(rhs, rhs))))
    for i in np.flatnonzero(bad):
        error[i] = ("transition: no common C axis for the two remaining positions "
                    f"(moment misfit {mis[i]:.1e})")
    ok &= ~bad
    own = np.flatnonzero(ok)
    w, sig, dl = w[own], sig[own], dl[own]
    mom = mom0[own, 0] + sig[:, :1] * mom1[own, 0]
    pt = _cross(w, mom)
    pt = pt - _dot(pt, w)[:, None] * w
    E = D[own] @ _screw_matrix(u[own][:, None], p[own][:, None], -dl, -sig)
    ax, _, ang, slide = _screw_of(E)
    sgn = np.where(_dot(ax, w[:, None]) > 0, 1.0, -1.0)
    psi = np.stack([sgn * ang, sgn * slide], -1)
    delta = np.stack([np.arctan2(np.sin(dl), np.cos(dl)), sig], -1)
    return Transitions(own, w, pt, psi, delta, error)


def _lstsq(A, b):
    """Least-squares solutions ``(n, 2)`` of ``A (n, 3, 2) x = b (n, 3)`` as
    :func:`numpy.linalg.lstsq` with ``rcond=None`` (by the SVD, singular values below
    ``3 eps`` times the largest cut)."""
    U, s, Vt = np.linalg.svd(A, full_matrices=False)
    cut = s > np.finfo(float).eps * 3 * s[:, :1]
    with np.errstate(invalid="ignore", divide="ignore"):
        c = np.where(cut, np.einsum("nij,ni->nj", U, b) / s, 0.0)
    return np.einsum("nji,nj->ni", Vt, c)
