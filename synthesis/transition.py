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

Sphere-ended transitions (R or P carrying a sphere centre) are point problems: see
:func:`synthesis.dyads.circle_axis` and the PRS construction.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .dualquat import dq_from_matrix, dq_mul, qmul
from .errors import SynthesisError
from .screw import Line

__all__ = ["Transition", "transition_joint", "TRANSITION_POSITIONS"]

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


def _screw_dq(u, m, angle, slide):
    """Dual quaternion (8,) of the screw about the line with Plücker coordinates (u, m = p × u)."""
    c, s = np.cos(angle / 2), np.sin(angle / 2)
    h = 0.5 * slide
    return np.array([c, s * u[0], s * u[1], s * u[2], -h * s, h * c * u[0] + s * m[0],
                     h * c * u[1] + s * m[1], h * c * u[2] + s * m[2]])


def _cross(a, b):
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


def _screw_matrix(u, p, angle, slide):
    """4x4 screw: rotation ``angle`` about the line (u, p), then ``slide`` along u."""
    c, s = np.cos(angle), np.sin(angle)
    K = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    R = np.eye(3) + s * K + (1 - c) * (K @ K)
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p - R @ p + slide * u
    return T


def _screw_of(E):
    """Axis u (unit), point (foot from the origin), angle in [0, π] and slide of a rigid
    motion that turns (angle > 0)."""
    from .dualquat import quat_from_rotation
    q = quat_from_rotation(E[:3, :3])
    sh = np.linalg.norm(q[1:])
    ang = 2 * np.arctan2(sh, q[0])
    if sh == 0:
        return np.array([0.0, 0.0, 1.0]), np.zeros(3), 0.0, float(np.linalg.norm(E[:3, 3]))
    u = q[1:] / sh
    t = E[:3, 3]
    slide = float(t @ u)
    tp = t - slide * u
    p = 0.5 * (tp + _cross(u, tp) / np.tan(ang / 2))
    return u, p - (p @ u) * u, float(ang), slide


def _zero_slide_coeffs(D, u, m):
    """α, β, γ, δ of f(Δ, σ) = scalar dual part of q_D q_Y(−Δ, −σ) (see module notes)."""
    qD = dq_from_matrix(D)
    # the dual scalar part of a product is the linear functional w · (the second factor):
    # a₀b₄ − a⃗·b⃗_d + a₄b₀ − a⃗_d·b⃗, so f is four dot products (no dual-quaternion products)
    w = np.concatenate([qD[4:5], -qD[5:8], qD[0:1], -qD[1:4]])

    def f(ang, sl):
        return float(w @ _screw_dq(u, m, -ang, -sl))
    a, b = f(0.0, 0.0), f(np.pi, 0.0)
    return a, b, f(0.0, 1.0) - a, f(np.pi, 1.0) - b


def _as_rotation(E, length, what):
    """Axis line and angle of a rigid motion that must be a pure rotation."""
    u, p, ang, slide = _screw_of(E)
    if abs(ang) < 1e-9:
        raise SynthesisError(f"{what}: the transition joint would not turn (the remaining "
                             "position is reached by J3 alone): degenerate")
    if abs(slide) > 1e-8 * length:
        raise SynthesisError(f"{what}: no pure rotation (slide {slide:.2e} left): degenerate")
    return Line._exact(u, p), ang


def _h_roots(a, b, g, d, p, n: int = 2048):
    """Roots Δ ∈ (−π, π] of α cos Δ/2 + β sin Δ/2 + pΔ(γ cos Δ/2 + δ sin Δ/2)."""
    def f(x):
        c, s = np.cos(x / 2), np.sin(x / 2)
        return a * c + b * s + p * x * (g * c + d * s)

    def df(x):
        c, s = np.cos(x / 2), np.sin(x / 2)
        return 0.5 * (-a * s + b * c) + p * (g * c + d * s) + 0.5 * p * x * (-g * s + d * c)
    x = np.linspace(-np.pi, np.pi, n + 1)
    v = f(x)
    idx = np.flatnonzero(np.sign(v[:-1]) * np.sign(v[1:]) <= 0)
    lo, hi = x[idx], x[idx + 1]
    r = 0.5 * (lo + hi)
    for _ in range(60):                            # safeguarded Newton, vectorised
        fr = f(r)
        step = fr / np.where(df(r) == 0, 1e-300, df(r))
        rn = r - step
        bad = (rn < lo) | (rn > hi) | ~np.isfinite(rn)
        flo = f(lo)
        left = np.sign(fr) == np.sign(flo)
        lo, hi = np.where(left, r, lo), np.where(left, hi, r)
        r = np.where(bad, 0.5 * (lo + hi), rn)
        if np.all(np.abs(step) < 1e-15):
            break
    r = np.unique(np.round(r, 12))
    return r[(r > -np.pi) | np.isclose(r, np.pi)]


def transition_joint(kind: str, y_kind: str, y_line: Line, y_pitch: float, D, length: float,
                     *, angle: float | None = None) -> list[Transition]:
    """All transition joints of kind ``kind`` carrying J3 (``y_kind`` on ``y_line`` at the
    transition position) through the relative displacements ``D``.

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
    D = np.asarray(D, float).reshape(-1, 4, 4)
    key = (kind, y_kind)
    if key not in TRANSITION_POSITIONS:
        raise SynthesisError(f"transition: a {kind} joint carrying a {y_kind} joint is not "
                             "implemented")
    if len(D) != TRANSITION_POSITIONS[key]:
        raise SynthesisError(f"transition: {kind} carrying {y_kind} takes "
                             f"{TRANSITION_POSITIONS[key]} remaining positions, got {len(D)}")
    u, m = y_line.direction, _cross(y_line.point, y_line.direction)
    if kind == "R":
        return _revolute(y_kind, u, m, y_line.point, y_pitch, D[0], length, angle)
    return _cylindric(u, m, y_line.point, D, length)


def _revolute(y_kind, u, m, p, pitch, D, length, angle):
    a, b, g, d = _zero_slide_coeffs(D, u, m)
    if y_kind == "R":
        if np.hypot(a, b) < 1e-14 * (1 + length):
            raise SynthesisError("transition: every rotation of J3 leaves a pure rotation "
                                 "(the remaining position is on J3's own motion): degenerate")
        deltas = [(2 * np.arctan2(-a, b), 0.0)]
    elif y_kind == "P":
        if abs(g) < 1e-12:
            raise SynthesisError("transition: J3's slide does not change the transition's "
                                 "slide (slide direction ⊥ the rotation axis): degenerate")
        deltas = [(0.0, -a / g)]
    elif y_kind == "H":
        deltas = [(x, pitch * x) for x in _h_roots(a, b, g, d, pitch)]
    else:                                                     # C: Δ is the free parameter
        c, s = np.cos(angle / 2), np.sin(angle / 2)
        den = g * c + d * s
        if abs(den) < 1e-12:
            raise SynthesisError(f"transition_angle {angle:.6g}: J3's slide cannot cancel the "
                                 "transition's slide at this angle: degenerate")
        deltas = [(float(angle), -(a * c + b * s) / den)]
    out = []
    for dl, sl in deltas:
        dl = float(np.arctan2(np.sin(dl), np.cos(dl))) if y_kind in "RC" else float(dl)
        E = D @ _screw_matrix(u, p, -dl, -sl)
        line, psi = _as_rotation(E, length, "transition")
        out.append(Transition(line, np.array([[psi, 0.0]]), np.array([[dl, sl]])))
    return out


def _cylindric(u, m, p, D, length):
    qs = [dq_from_matrix(Dl) for Dl in D]
    uq = np.r_[0.0, u]
    planes = [(q[1:4], qmul(q[:4], -uq)[1:]) for q in qs]          # spans of vec(r_E(Δ))
    n = [_cross(a, b) for a, b in planes]
    w = _cross(n[0], n[1])
    if min(np.linalg.norm(n[0]), np.linalg.norm(n[1])) < 1e-12 or np.linalg.norm(w) < 1e-10:
        raise SynthesisError("transition: the C axis direction is not determined (the "
                             "rotations' planes coincide): degenerate")
    w /= np.linalg.norm(w)
    cols, rots, dls = [], [], []
    for (a, b), q, Dl in zip(planes, qs, D):
        M = np.stack([_cross(a, w), _cross(b, w)], 1)
        _, _, Vt = np.linalg.svd(M)
        cs = Vt[-1] / np.linalg.norm(Vt[-1])
        dl = 2 * np.arctan2(cs[1], cs[0])
        e0 = dq_mul(q, _screw_dq(u, m, -dl, 0.0))
        e1 = dq_mul(q, _screw_dq(u, m, -dl, -1.0)) - e0
        sh, ch = e0[1:4] @ w, e0[0]
        if abs(sh) < 1e-9:
            raise SynthesisError("transition: the C transition joint would not turn at a "
                                 "remaining position: degenerate")
        # moment m(σ) = (v_d − (d/2) ch w)/sh with d = −2 s_d / sh: affine in σ
        mom = [(e[5:] + e[4] / sh * ch * w) / sh for e in (e0, e1)]
        cols.append(mom)
        rots.append((sh, ch))
        dls.append(dl)
    A = np.stack([cols[0][1], -cols[1][1]], 1)
    rhs = cols[1][0] - cols[0][0]
    sig, *_ = np.linalg.lstsq(A, rhs, rcond=None)
    if np.linalg.norm(A @ sig - rhs) > 1e-8 * max(1.0, np.linalg.norm(rhs)):
        raise SynthesisError("transition: no common C axis for the two remaining positions "
                             f"(moment misfit {np.linalg.norm(A @ sig - rhs):.1e})")
    mom = cols[0][0] + sig[0] * cols[0][1]
    pt = _cross(w, mom)
    line = Line._exact(w, pt - (pt @ w) * w)
    psi, delta = [], []
    for (sh, ch), dl, sl, Dl in zip(rots, dls, sig, D):
        E = Dl @ _screw_matrix(u, p, -dl, -sl)
        ax, _, ang, slide = _screw_of(E)
        sgn = 1.0 if ax @ w > 0 else -1.0
        psi.append((sgn * ang, sgn * slide))
        delta.append((float(np.arctan2(np.sin(dl), np.cos(dl))), float(sl)))
    return [Transition(line, np.array(psi), np.array(delta))]
