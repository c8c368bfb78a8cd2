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

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from closure.frames import _cross, rotation

from .dualquat import dq_conj, dq_from_matrix, dq_mul, qconj, qmul
from .errors import SynthesisError
from .screw import Line, Screw
from .validate import number, screw, task_scales, unit, vec3

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
    """4x4 rotation by ``angle`` (rad) about ``line`` (:func:`_rots` for one line)."""
    return _rots(line.direction, line.point, angle)


def _dot(a, b) -> np.ndarray:
    """Dot products over the last axis (broadcast), the same sums bit for bit as ``a @ b``
    of 1-d arrays: a stacked problem gives what it gives alone (``numpy.vecdot``, or a
    stacked matmul before numpy 2)."""
    if _VECDOT is not None:
        return _VECDOT(a, b)
    return (np.asarray(a)[..., None, :] @ np.asarray(b)[..., :, None])[..., 0, 0]


_VECDOT = getattr(np, "vecdot", None)


def _norm(a) -> np.ndarray:
    """Euclidean norms over the last axis (bit for bit :func:`numpy.linalg.norm` of a 1-d
    array)."""
    return np.sqrt(_dot(a, a))


def _rotmats(u, angle) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` by ``angle`` (rad, shape (...)) about the unit
    directions ``u (..., 3)`` (Rodrigues; broadcast)."""
    u, angle = np.asarray(u, float), np.asarray(angle, float)
    c, s = np.cos(angle)[..., None, None], np.sin(angle)[..., None, None]
    # the cross-product matrix of u, its entries picked from (0, u, −u)
    K = np.concatenate([np.zeros(u.shape[:-1] + (1,)), u, -u], -1)[..., _SKEW]
    return c * np.eye(3) + s * K.reshape(u.shape[:-1] + (3, 3)) + \
        (1 - c) * (u[..., :, None] * u[..., None, :])


#: the entries of the cross-product matrix [u]× in (0, u₀, u₁, u₂, −u₀, −u₁, −u₂), row by row
_SKEW = np.array([0, 6, 2, 3, 0, 4, 5, 1, 0])


def _rots(u, p, angle) -> np.ndarray:
    """4x4 rotations ``(..., 4, 4)`` by ``angle`` (rad, shape (...)) about the lines through
    the points ``p (..., 3)`` (length) along the unit directions ``u (..., 3)`` (broadcast)."""
    p = np.asarray(p, float)
    R = _rotmats(u, angle)
    shape = np.broadcast_shapes(R.shape[:-2], p.shape[:-1])
    T = np.zeros(shape + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = p - (R @ p[..., None])[..., 0]
    T[..., 3, 3] = 1.0
    return T


def _angles_about(u, R) -> np.ndarray:
    """Signed rotation angles (rad, shape (...)) of the rotations ``R (..., 3, 3)`` about the
    unit directions ``u (..., 3)`` (the turn of a vector normal to u; broadcast)."""
    u = np.asarray(u, float)
    a = np.where((np.abs(u[..., 0]) < 0.9)[..., None], [1.0, 0, 0], [0, 1.0, 0])
    a = a - _dot(a, u)[..., None] * u
    a = a / _norm(a)[..., None]
    b = (R @ a[..., None])[..., 0]
    return np.arctan2(_dot(_cross(a, b), u), _dot(a, b))


def _pose_gaps(A, B, length) -> np.ndarray:
    """:func:`synthesis.verify.pose_error` over stacks: the larger of the rotation error
    (rad) and the translation error divided by ``length`` between the rigid transforms
    ``A, B (..., 4, 4)`` (``length`` (...) broadcast against their leading axes)."""
    D = np.swapaxes(A[..., :3, :3], -1, -2) @ B[..., :3, :3] - np.eye(3)
    E = _norm(D.reshape(D.shape[:-2] + (9,)))
    rot = 2 * np.arcsin(np.minimum(1.0, E / (2 * np.sqrt(2))))
    return np.maximum(rot, np.abs(A[..., :3, 3] - B[..., :3, 3]).max(-1) / length)


def _common_normals(u1, p1, u2, p2):
    """Feet ``(on line 1, on line 2)`` ``(..., 3)`` of the common normals of the lines
    (unit directions ``u``, points ``p``, length; shapes (..., 3)), as
    :func:`synthesis.screw.common_normal` (parallel lines: the foot on line 2 of the
    perpendicular from line 1's point)."""
    w = p1 - p2
    b = _dot(u1, u2)
    den = 1 - b * b
    par = den < 1e-12
    d, e = _dot(u1, w), _dot(u2, w)
    safe = np.where(par, 1.0, den)
    s = np.where(par, 0.0, (b * e - d) / safe)
    t = np.where(par, e, (e - b * d) / safe)
    return p1 + s[..., None] * u1, p2 + t[..., None] * u2


_ONE = np.eye(8)[0]                     # the dual quaternion 1 (position 1, the identity)


def _study(a, b) -> np.ndarray:
    """Study bilinear form ½(r_a·d_b + r_b·d_a) of dual quaternions ``(..., 8)``."""
    return 0.5 * (_dot(a[..., :4], b[..., 4:]) + _dot(b[..., :4], a[..., 4:]))


def _dq_inv(a) -> np.ndarray:
    """Inverses of dual quaternions ``(..., 8)`` with non-zero primal part
    (:func:`synthesis.dualquat.dq_inv` over stacks)."""
    r, d = a[..., :4], a[..., 4:]
    ri = qconj(r) / _dot(r, r)[..., None]
    return np.concatenate([ri, -qmul(qmul(ri, d), ri)], -1)


def _roots(coeffs) -> np.ndarray:
    """Roots of many real polynomials, as :func:`numpy.roots` gives them.

    Parameters
    ----------
    coeffs : numpy.ndarray, shape (m, n + 1)
        Coefficients, highest power first.

    Returns
    -------
    numpy.ndarray of complex, shape (m, n)
        The eigenvalues of each companion matrix (one stacked ``eigvals``); a polynomial
        with leading or trailing zero coefficients (rare) goes through ``numpy.roots``,
        its missing roots NaN; a polynomial that is not finite has NaN roots.
    """
    m, n = coeffs.shape[0], coeffs.shape[1] - 1
    out = np.full((m, n), np.nan + 0j)
    finite = np.isfinite(coeffs).all(1)
    fast = finite & (coeffs[:, 0] != 0) & (coeffs[:, -1] != 0)
    if fast.any():
        p = coeffs[fast]
        A = np.zeros((len(p), n, n))
        A[:, 1:, :-1] = np.eye(n - 1)
        A[:, 0, :] = -p[:, 1:] / p[:, :1]
        out[fast] = np.linalg.eigvals(A)
    for i in np.flatnonzero(finite & ~fast):
        r = np.roots(coeffs[i])
        out[i, :len(r)] = r
    return out


def _first_error(err: list, bad, message) -> None:
    """Set ``err[p] = message(p)`` where ``bad[p]`` and problem p has no error yet (the
    checks run in rr_links's order, so each problem keeps its first failure)."""
    bad = np.asarray(bad, bool)
    if bad.any():
        for p in np.flatnonzero(bad):
            if err[p] is None:
                err[p] = message(int(p))


def _message(check, *args) -> str | None:
    """The message of the SynthesisError that ``check(*args)`` raises (None if it passes)."""
    try:
        check(*args)
    except SynthesisError as e:
        return str(e)
    return None


@dataclass
class _Solved:
    """The RR links of a stack of P problems (:func:`_rr_solve`).

    Attributes
    ----------
    error : list of (str or None), length P
        Why the problem has no links (rr_links's message), None when solved.
    fixed, moving : numpy.ndarray, shape (P, 2, 2, 3)
        Per problem and link: the axis's unit direction and canonical point (length).
    length, twist, residual, accuracy : numpy.ndarray, shape (P, 2)
        As :class:`RRLink` (length; rad; rad or relative; ``info["accuracy"]``).
    fixed_angles, moving_angles : numpy.ndarray, shape (P, 2, 3)
        Joint angles (rad) at positions 1, 2, 3 of the problem.
    """

    error: list
    fixed: np.ndarray
    moving: np.ndarray
    length: np.ndarray
    twist: np.ndarray
    residual: np.ndarray
    accuracy: np.ndarray
    fixed_angles: np.ndarray
    moving_angles: np.ndarray

    def links(self, p: int) -> list[RRLink]:
        """The two :class:`RRLink` of problem ``p`` (solved)."""
        return [RRLink(Line._exact(self.fixed[p, i, 0], self.fixed[p, i, 1]),
                       Line._exact(self.moving[p, i, 0], self.moving[p, i, 1]),
                       float(self.length[p, i]), float(self.twist[p, i]),
                       self.fixed_angles[p, i], self.moving_angles[p, i],
                       float(self.residual[p, i]), {"accuracy": float(self.accuracy[p, i])})
                for i in range(2)]


def rr_links(s12: Screw, s13: Screw, *, tol: float = 1e-9) -> list[RRLink]:
    """Both RR links that carry a body through positions 1, 2, 3.

    Parameters
    ----------
    s12, s13 : Screw
        Displacements from position 1 to positions 2 and 3.
    tol : float
        Positive; the links' residual and accuracy must be within ``tol * 1e3``.

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

    The work is done by the vectorised core :func:`_rr_solve` (one problem here; the
    RRR enumeration solves its three position triples in one call).
    """
    s12, s13 = screw(s12, "s12"), screw(s13, "s13")
    tol = number(tol, "tol", positive=True)
    sol = _rr_solve([s12], [s13], s12.matrix()[None], s13.matrix()[None], tol)
    if sol.error[0] is not None:
        raise SynthesisError(sol.error[0])
    return sol.links(0)


def _rr_solve(s12: list, s13: list, T2: np.ndarray, T3: np.ndarray, tol: float) -> _Solved:
    """The RR links of P problems at once (the vectorised core of :func:`rr_links`).

    Parameters
    ----------
    s12, s13 : list of Screw, length P
        Each problem's displacements from position 1 to positions 2 and 3 (checked).
    T2, T3 : numpy.ndarray, shape (P, 4, 4)
        Their matrices (``Screw.matrix``).
    tol : float
        As rr_links (positive).

    Returns
    -------
    _Solved
        The links, or per problem the message rr_links raises (its checks in its order).

    Every problem and its accuracy trials go through one stacked pass: the normalised
    poses as dual quaternions, the norm quartics' roots as eigenvalues of stacked
    companion matrices, the factors, the parameters of the positions on the motion, and
    the links' axes, angles and residuals.
    """
    n = len(s12)
    err = [None] * n
    axes = np.array([[a.axis, b.axis] for a, b in zip(s12, s13)]).reshape(n, 2, 3)
    points = np.array([[a.point, b.point] for a, b in zip(s12, s13)]).reshape(n, 2, 3)
    c, L, reach = task_scales(np.stack([T2, T3], 1).reshape(n, 2, 4, 4), axes, points)
    w = np.array([[a.angle, b.angle] for a, b in zip(s12, s13)]).reshape(n, 2)
    slide = np.array([[a.slide, b.slide] for a, b in zip(s12, s13)]).reshape(n, 2)
    eye = np.broadcast_to(np.eye(4), T2.shape)
    same = _pose_gaps(np.stack([T2, T3, T2]), np.stack([eye, eye, T3]), reach) < 1e-12
    _first_error(err, same[0], lambda p: "S12 is the identity: two of the positions coincide")
    _first_error(err, same[1], lambda p: "S13 is the identity: two of the positions coincide")
    _first_error(err, same[2], lambda p: "S12 equals S13: positions 2 and 3 coincide")
    for j, name in enumerate(("S12", "S13")):
        _first_error(err, np.abs(w[:, j]) < 1e-6,
                     lambda p: _translation_message(name, w[p, j], slide[p, j]))
    _first_error(err, ~(2 * _EPS * reach / L <= tol * 1e3),
                 lambda p: _message(_check_spherical, c[p], L[p], reach[p], tol))
    # work in coordinates centred on each task and scaled to its size (invariance,
    # conditioning): Tn = S C (C the shift by −c, S the scaling by 1/L), Ti its inverse
    # (a problem that failed already goes on unscaled: its figures are not used)
    going = np.array([e is None for e in err])
    Ls, cs = np.where(going, L, 1.0), np.where(going[:, None], c, 0.0)
    Tn = np.zeros((n, 4, 4))
    Tn[:, [0, 1, 2], [0, 1, 2]] = (1 / Ls)[:, None]
    Tn[:, :3, 3] = (1 / Ls)[:, None] * -cs
    Tn[:, 3, 3] = 1.0
    Ti = np.linalg.inv(Tn)
    N2, N3 = Tn @ T2 @ Ti, Tn @ T3 @ Ti
    # the accuracy trials (see _accuracy_of): the positions moved by their round-off times
    # an amplification, stacked after the problems: rows [problems, trial 1, trial 2]
    noise = _EPS * (reach / L + 1.0)
    amp = np.where(noise < 1e-7, np.minimum(1e4, 1e-7 / noise), 1.0)
    E = np.zeros((2, n, 2, 4, 4))                # trial, problem, position 2 or 3
    dirs = _trial_directions()
    E[..., :3, :3] = rotation(dirs[:, None, :, 0], (amp * _EPS)[None, :, None])
    E[..., :3, 3] = (amp * noise)[None, :, None, None] * dirs[:, None, :, 1]
    E[..., 3, 3] = 1.0
    X2 = np.concatenate([N2[None], E[:, :, 0] @ N2]).reshape(3 * n, 4, 4)
    X3 = np.concatenate([N3[None], E[:, :, 1] @ N3]).reshape(3 * n, 4, 4)
    Q2, Q3 = dq_from_matrix(np.stack([X2, X3]))
    a, b, cc = _study(_ONE, Q2[:n]), _study(_ONE, Q3[:n]), _study(Q2[:n], Q3[:n])
    axes_par = np.abs(np.abs(np.einsum("pi,pi->p", axes[:, 0], axes[:, 1])) - 1) < 1e-10
    # Study products are the pitches of S12, S13, S23 (normalised lengths): round-off
    # makes them ~ε·reach/L, so "zero" is relative to that
    zero = 1e-14 * (reach / L)
    big = np.maximum(np.maximum(np.abs(a), np.abs(b)), np.abs(cc))
    small = np.minimum(np.minimum(np.abs(a), np.abs(b)), np.abs(cc))
    # all three relative screws (S12, S13, S23) pure rotations, about axes that meet
    # pairwise: one common point (an exactly scale-free task lands here)
    _first_error(err, ~axes_par & (big < zero),
                 lambda p: _message(_spherical_error, c[p], L[p], reach[p], np.inf, "exactly"))
    _first_error(err, axes_par | (small < zero), lambda p: _degenerate_message(
        axes_par[p], small[p], w[p, 0], w[p, 1]))
    with np.errstate(all="ignore"):            # failed problems' figures are not used
        c1, c0, H, ferr = _factors(Q2, Q3)
        _first_error(err, [e is not None for e in ferr[:n]], lambda p: ferr[p])
        ts, perr = _parameters(c1[:n], c0[:n], Q2[:n], Q3[:n])
        _first_error(err, [e is not None for e in perr], lambda p: perr[p])
        # forward-error estimate: the round-off of the coordinates (ε·reach, i.e. ε·reach/L
        # here) times the sensitivity of the axes, measured by re-solving perturbed positions
        acc, ref_ok = _accuracy_of(H, ferr, amp)
        _first_error(err, ~ref_ok, lambda p: "degenerate factor")
        _first_error(err, ~(acc <= tol * 1e3), lambda p: _message(
            _check_accuracy, acc[p], tol, c[p], L[p], reach[p], w[p, 0], w[p, 1]))
        return _links(H[:n], ts, c, L, reach, Tn, Ti, T2, T3, acc, tol, w, err)


def _links(H, ts, c, L, reach, Tn, Ti, T2, T3, acc, tol, w, err) -> _Solved:
    """The links of P normalised problems from their factors ``H (P, 2, 2, 8)`` (root pair,
    (h₁, h₂)) and the parameters ``ts (P, 2)`` of positions 2, 3: the canonical axes in the
    user's coordinates, joint angles, residuals against the poses ``T2, T3 (P, 4, 4)`` and
    accuracy (``acc (P,)``: the trials' estimate).  ``c (P, 3)``, ``L, reach (P,)``: the
    tasks' centres and sizes (length); ``Tn, Ti (P, 4, 4)``: the normalisation and its
    inverse; ``w (P, 2)``: the screws' angles (rad).  rr_links's last checks (per link:
    a factor without an axis, the residual, the accuracy) put their messages into ``err``."""
    n = len(H)
    v = H[..., 1:4]
    nv = _norm(v)
    # (t − h) = (t − h0) − v − ε (h_d0 + v_d): a line (direction u, moment m) with v = n u,
    # v_d = n m (pure rotation needs h_d0 = 0)
    u = v / nv[..., None]
    pt = _cross(u, H[..., 5:8] / nv[..., None])
    u = u / _norm(u)[..., None]        # as Line normalises it, here and in the user's frame
    u = u / _norm(u)[..., None]
    pt = pt * L[:, None, None, None] + c[:, None, None]               # the user's coordinates
    gu, wu = u[:, :, 0], u[:, :, 1]                                    # (P, 2, 3)
    gp = pt[:, :, 0] + _dot(0.0 - pt[:, :, 0], gu)[..., None] * gu     # foot from the origin
    _, wp = _common_normals(gu, gp, wu, pt[:, :, 1])                   # the common normal's
    # joint angles at positions 2, 3: the rotation of the factor (t − h) at t = t₂, t₃ (the
    # rotation block of the transform taken back to the user's coordinates)
    r = np.broadcast_to(-H[:, :, :, None, :4], (n, 2, 2, 2, 4)).copy()
    r[..., 0] += ts[:, None, None, :]
    R = _quat_matrices(r / np.sqrt(_dot(r, r))[..., None])
    R = Ti[:, None, None, None, :3, :3] @ R @ Tn[:, None, None, None, :3, :3]
    angles = np.zeros((n, 2, 2, 3))
    angles[..., 1:] = _angles_about(u[:, :, :, None], R)               # (P, 2, 2, 2)
    foot_g, foot_w = _common_normals(gu, gp, wu, wp)
    length = _norm(foot_w - foot_g)
    twist = np.arccos(np.clip(_dot(gu, wu), -1, 1))
    # residual: the link's forward kinematics at the three positions
    pose = _rots(gu[:, :, None], gp[:, :, None], angles[:, :, 0]) @ \
        _rots(wu[:, :, None], wp[:, :, None], angles[:, :, 1])          # (P, 2, 3, 4, 4)
    target = np.stack([np.broadcast_to(np.eye(4), T2.shape), T2, T3], 1)[:, None]
    residual = _pose_gaps(pose, target, reach[:, None, None]).max(-1)   # (P, 2)
    # a link that misses the positions is no better than its miss (relative to L)
    accuracy = np.fmax(acc[:, None], residual * reach[:, None] / L[:, None])
    for i in range(2):                        # rr_links's checks, link by link
        _first_error(err, (nv[:, i] < 1e-12).any(-1),
                     lambda p: "degenerate factor: the rotation axis has no direction")
        _first_error(err, residual[:, i] > tol * 1e3, lambda p: (
            f"rr_links: a solution misses the positions by {residual[p, i]:.1e} "
            "(ill-conditioned positions)"))
        _first_error(err, ~(accuracy[:, i] <= tol * 1e3), lambda p: _message(
            _check_accuracy, accuracy[p, i], tol, c[p], L[p], reach[p], w[p, 0], w[p, 1]))
    return _Solved(err, np.stack([gu, gp], 2), np.stack([wu, wp], 2), length, twist,
                   residual, accuracy, angles[:, :, 0], angles[:, :, 1])


def _quat_matrices(q) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of unit quaternions ``q (..., 4)`` (w, x, y, z): row
    by row ``1 − 2 (y² + z²), 2 (xy − wz), 2 (xz + wy); 2 (xy + wz), 1 − 2 (x² + z²),
    2 (yz − wx); 2 (xz − wy), 2 (yz + wx), 1 − 2 (x² + y²)``, from the products of the
    components taken at once."""
    P = (q[..., :, None] * q[..., None, :]).reshape(q.shape[:-1] + (16,))
    M = 2 * (P[..., _QM_FIRST] + P[..., _QM_SECOND] * _QM_SIGN)
    M[..., ::4] = 1 - M[..., ::4]
    return M.reshape(q.shape[:-1] + (3, 3))


#: the products q_i q_j (index 4 i + j) of the entries of _quat_matrices, and the sign of
#: the second
_QM_FIRST = np.array([10, 6, 7, 6, 5, 11, 7, 11, 5])
_QM_SECOND = np.array([15, 3, 2, 3, 15, 1, 2, 1, 10])
_QM_SIGN = np.array([1.0, -1, 1, 1, 1, -1, -1, 1, 1])


def _translation_message(name: str, angle: float, slide: float) -> str:
    size = abs(slide) / max(abs(angle), 1e-300)
    return (f"{name} rotates by {angle:.1e} rad, (nearly) a pure translation: an RR link "
            "translates a body only with parallel axes (a planar motion, where RR links "
            "through three positions are not isolated); as the angle goes to zero the link "
            f"goes to infinity (size ~ slide/angle = {size:.1e})")


def _degenerate_message(axes_par: bool, small: float, w2: float, w3: float) -> str:
    what = ("the screw axes are parallel: the motion is planar and the RR links through three "
            "positions are not isolated (every circle point gives one)") if axes_par else \
        f"the Study products of the poses vanish (|B| = {small:.1e})"
    return f"rr_links: degenerate positions, {what}; rotation angles {w2:.3g}, {w3:.3g} rad"


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


@functools.lru_cache(maxsize=1)
def _trial_directions() -> np.ndarray:
    """The accuracy trials' random unit directions ``(2, 2, 2, 3)`` (trial, position 2 or 3,
    rotation axis or translation): seed 0, the same for every task (deterministic: the
    same task, the same figure)."""
    rng = np.random.default_rng(0)
    out = np.empty((2, 2, 2, 3))
    for i in np.ndindex(2, 2, 2):
        v = rng.normal(size=3)
        out[i] = v / np.linalg.norm(v)
    out.flags.writeable = False
    return out


def _accuracy_of(H, ferr, amp):
    """Forward-error estimate of the RR axes (direction in rad, position relative to the
    task's size L) of P problems, from the factors ``H (3P, 2, 2, 8)`` of the normalised
    problems (rows 0..P-1) and of their two accuracy trials (rows P.., 2P..) and the
    trials' amplification ``amp (P,)``.  Returns the estimates (P,) and whether each
    problem's own axes have a direction (P,) bool.

    The positions are known to their round-off: ε in rotation and ε·reach in
    translation (ε·reach/L in the normalised coordinates).  They are moved by random
    displacements of that size times an amplification (so the change is well above the
    solve's own round-off), re-solved, and the largest change of the axes (Plücker
    coordinates in the normalised frame) is scaled back.  A nearly spherical task
    (L ≪ reach) gives about ε·reach/L (measured errors: 0.3–2 times that); a generic
    one a few tens of ε; an ill-conditioned Bennett motion more.  A perturbation that
    makes the problem degenerate gives inf."""
    n = len(amp)
    v = H[..., 1:4]
    nv = _norm(v)[..., None]
    pl = np.concatenate([v / nv, H[..., 5:8] / nv], -1).reshape(3, n, 4, 6)  # 4 axes each
    nv = nv.reshape(3, n, 4)
    ref, got = pl[0], pl[1:]
    failed = np.array([e is not None for e in ferr]).reshape(3, n)[1:].any(0) | \
        ~(nv[1:] >= 1e-300).all((0, 2)) | ~np.isfinite(got).all((0, 2, 3))
    # the pairs may swap order: match each axis to its nearest
    d = np.minimum(np.abs(ref[None, :, :, None] - got[:, :, None]).max(-1),
                   np.abs(ref[None, :, :, None] + got[:, :, None]).max(-1)).min(-1)
    worst = d.max((0, 2))
    acc = np.maximum(worst / amp, 32 * _EPS)
    return np.where(failed, np.inf, acc), (nv[0] >= 1e-300).all(-1)


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


def _factors(P2, P3):
    """The monic quadratic motions ``C(t) = t² + c₁ t + c₀`` through normalised poses (1 at
    t = ∞, ``P2, P3 (m, 8)``) and their two factorisations ``(t − h₁)(t − h₂)``.

    Returns
    -------
    c1, c0 : numpy.ndarray, shape (m, 8)
    h : numpy.ndarray, shape (m, 2, 2, 8)
        Per root pair of the norm quartic (by increasing real part) ``(h₁, h₂)``.
    error : list of (str or None), length m
        Why a motion does not factor (rr_links's message), None when it does.
    """
    m = len(P2)
    err = [None] * m
    a, b, cc = _study(_ONE, P2), _study(_ONE, P3), _study(P2, P3)
    # the conic  a x0 x2 + b x0 x3 + c x2 x3 = 0  with P0 at t = ∞ (see the module notes)
    lead = (cc * b / a)[:, None]
    c1 = (-cc[:, None] * _ONE - b[:, None] * P2 + a[:, None] * P3) / lead
    c0 = a[:, None] * P2 / lead
    # norm polynomial N(t) = C(t) C̃(t): real quartic (its dual part vanishes)
    coeffs = np.stack([np.broadcast_to(_ONE, c1.shape), c1, c0], 1)   # t², t, 1
    prod = dq_mul(coeffs[:, :, None], dq_conj(coeffs)[:, None])       # (m, 3, 3, 8)
    Np = np.zeros((m, 5, 8))
    for i in range(3):                  # each power's terms summed in the order of i
        Np[:, i:i + 3] += prod[:, i]
    study_err = np.abs(Np[..., 4:]).max((1, 2)) / np.abs(Np[..., 0]).max(1)
    _first_error(err, study_err > 1e-8, lambda p: (
        f"rr_links: the interpolating motion leaves the Study quadric ({study_err[p]:.1e}); "
        "positions numerically degenerate"))
    _first_error(err, ~np.isfinite(Np).all((1, 2)), lambda p: (
        "rr_links: the interpolating motion is not finite; positions numerically degenerate"))
    roots = _roots(Np[..., 0])                                         # (m, 4)
    up = roots.imag > 0
    real = (np.abs(roots.imag) < 1e-10 * np.maximum(1.0, np.abs(roots))).any(1)
    _first_error(err, real | (up.sum(1) != 2), lambda p: (
        "rr_links: the norm polynomial has real roots: the interpolating Bennett motion "
        "degenerates (positions related by a pure rotation or translation?)"))
    # each pair of complex-conjugate roots: the real quadratic factor M(t) = t² + m₁ t + m₀;
    # the remainder C − M = r₁ t + r₀ gives the right factor t − h₂, h₂ = −r₁⁻¹ r₀
    pair = np.argsort(np.where(up, roots.real, np.inf), 1, kind="stable")[:, :2]
    z = roots[np.arange(m)[:, None], pair]                              # (m, 2)
    r1 = np.repeat(c1[:, None], 2, 1)
    r0 = np.repeat(c0[:, None], 2, 1)
    r1[..., 0] -= -2 * z.real
    # |z|² as one root's abs(z) ** 2 gives it (libm pow, not the array square): a stacked
    # problem gives the factors, bit for bit, that it gives alone
    r0[..., 0] -= np.array([math.pow(v, 2) for v in np.hypot(z.real, z.imag).ravel().tolist()]
                           ).reshape(z.shape)
    h2 = -dq_mul(_dq_inv(r1), r0)
    h = np.stack([-c1[:, None] - h2, h2], 2)                           # (m, 2, 2, 8)
    screw_ = np.abs(h[..., 4]) > 1e-8 * np.maximum(1.0, np.abs(h).max(-1))
    first = np.argmax(screw_.reshape(m, 4), 1)
    _first_error(err, screw_.reshape(m, 4).any(1), lambda p: (
        f"rr_links: a factor is a screw, not a rotation (dual scalar "
        f"{h[p].reshape(4, 8)[first[p], 4]:.1e})"))
    return c1, c0, h, err


def _parameters(c1, c0, P2, P3):
    """Parameters t₂, t₃ ``(m, 2)`` at which the motions ``C(t)`` (``c1, c0 (m, 8)``) pass
    through positions 2 and 3 (``P2, P3 (m, 8)``): least squares on C(t) ∥ P_j, solved
    exactly as a quadratic's common root; and per motion the error message (or None)."""
    m = len(c1)
    P = np.stack([P2, P3], 1)                                          # (m, 2, 8)
    # C(t) = λ P  ⇔  components orthogonal to P vanish: project onto the complement
    Pn = P / _norm(P)[..., None]
    proj = np.eye(8) - Pn[..., :, None] * Pn[..., None, :]
    A = np.stack([(proj @ x[:, None, :, None])[..., 0]                 # columns t², t, 1
                  for x in (np.broadcast_to(_ONE, c1.shape), c1, c0)], -1)
    # the quadratic t² A0 + t A1 + A2 = 0 in all rows: take the row-space combination
    i, j = np.arange(m)[:, None], np.arange(2)
    q = A[i, j, np.argmax(np.abs(A).sum(-1), -1)]                       # (m, 2, 3)
    t = _roots(q.reshape(2 * m, 3)).reshape(m, 2, 2)
    ok = np.isfinite(t) & (np.abs(t.imag) <= 1e-8 * np.maximum(1, np.hypot(t.real, t.imag)))
    t = t.real
    r = _norm((A[:, :, None] @ np.stack([t * t, t, np.ones_like(t)], -1)[..., None])[..., 0])
    r = np.where(ok & ~np.isnan(r), r / np.maximum(1.0, t * t), np.inf)
    best = np.argmin(r, -1)
    found = (r[i, j, best] < np.inf).all(-1)
    err = [None if f else "rr_links: no real parameter for a position on the motion"
           for f in found.tolist()]
    return t[i, j, best], err


_AXIS1 = ("axis 1: axis 3 does not move between the two positions (the positions coincide)",
          "axis 1: (Q4 − Q3) and (M4 − M3) are parallel or zero; no unique pure rotation "
          "carries axis 3 between the two positions",
          "axis 1: axis 3 is parallel to the rotation axis",
          "axis 1: axis 3 is not turned between the two positions")


def rotation_axis_between(m3, q3, m4, q4) -> tuple[Line, float]:
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
    L, P, ang, why = _rotation_axes(m3[None], q3[None], m4[None], q4[None])
    if why[0]:
        raise SynthesisError(why[0])
    return Line._exact(L[0], P[0]), float(ang[0])


def _rotation_axes(m3, q3, m4, q4):
    """:func:`rotation_axis_between` over stacks of lines (unit directions ``m``, points
    ``q`` (length), shapes (..., 3)).

    Returns
    -------
    axis, point : numpy.ndarray, shape (..., 3)
        The rotation axes (unit) and their feet from the origin.
    angle : numpy.ndarray, shape (...)
        The rotation angles (rad, in (0, π] about the axis as oriented).
    reason : numpy.ndarray of str, shape (...)
        Why no pure rotation exists (rotation_axis_between's message), '' where it does.
    """
    dm, dq = m4 - m3, q4 - q3
    n = _cross(dq, dm)
    size = np.maximum(np.abs(q3).max(-1), np.abs(q4).max(-1))      # the coordinates' size
    ndm, ndq, nn = _norm(dm), _norm(dq), _norm(n)
    with np.errstate(all="ignore"):                # the degenerate rows are flagged below
        L = n / nn[..., None]
        # orient L so that the rotation angle of M is in (0, π]
        a = m3 - _dot(m3, L)[..., None] * L
        b = m4 - _dot(m4, L)[..., None] * L
        ang = np.arctan2(_dot(_cross(a, b), L), _dot(a, b))
        # the centre of the plane rotation by ang that takes Q3 to Q4 (Q4 − Q3 ⊥ L):
        # midpoint + ½ cot(ang/2) L × (Q4 − Q3); then the foot from the origin
        P = 0.5 * (q3 + q4) + (0.5 / np.tan(ang / 2))[..., None] * _cross(L, dq)
        P = P - _dot(P, L)[..., None] * L
        why = np.full(ang.shape, "", dtype=object)   # the first failing check's message
        why[np.abs(np.sin(ang / 2)) < 1e-12] = _AXIS1[3]
        why[_norm(a) < 1e-12] = _AXIS1[2]
        why[nn <= 1e-10 * ndq * ndm] = _AXIS1[1]
        why[(ndm < 1e-12) & (ndq <= 1e-12 * size)] = _AXIS1[0]
    return L, P, ang, why
