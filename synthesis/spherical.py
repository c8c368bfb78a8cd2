"""Binary links with a spherical joint (RS, SR, PS, SP, HS, SH) through finite positions, every
solution at explicit values of the free parameter (after Tsai & Roth 1972, "Design of
dyads with helical, cylindric, spherical, revolute and prismatic joints", Mech. Mach.
Theory 7; positions as in Kharatyan 1981, Table 3).

==========  =========  ==============================================================
link        positions  free parameter (explicit argument)
==========  =========  ==============================================================
RS          4          ``azimuth`` ψ (rad): the fixed (revolute) axis direction lies on
                       the great circle through the task's reference axis e3 at azimuth
                       ψ; every link on that circle is returned (up to 8)
SR          4          ``azimuth`` of the moving (revolute) axis direction in position 1
PS          3          ``azimuth`` of the slide direction (ground); up to 2 links
SP          3          ``azimuth`` of the slide direction in the body (position 1)
HS          4          ``pitch`` given; ``azimuth`` of the fixed (helical) axis direction
SH          4          ``pitch`` given; ``azimuth`` of the moving axis direction
==========  =========  ==============================================================

Reference frame of a task (:func:`task_frame`): e3 is the axis of S₁₂ (as
:meth:`Screw.from_matrix` gives it, rotation in [0, π]), e1 the part of S₁₃'s axis
perpendicular to e3 (S₁₄'s if S₁₃'s is parallel to e3), e2 = e3 × e1.  It moves with the
task under a rigid motion, so the links for a given azimuth move with it.  Azimuth ψ
selects the great circle ``u(β) = cos β e3 + sin β (cos ψ e1 + sin ψ e2)``, β ∈ [0, π):
ψ and ψ + π give the same circle (as lines), so ψ ∈ [0, π) covers every direction once
(e3 itself lies on every circle).  :func:`azimuth_of` reads ψ off any direction, so a
designer gets any link back from its own axis.

RS (revolute axis G = (g, c_g) in the ground, sphere centre C in the body): C's four
positions C_j = R_j C + t_j lie on a circle about G.  For a direction g the planes
``g · (C_j − C_1) = 0`` fix C linearly (``A(g) C = b(g)``, A's rows ``gᵀ(R_j − I)``);
with Cramer's rule ``D C = N`` (D = det A, degree 3 in g) and ``Q_j = D (C_j − C_1)``,
the circle through the four coplanar points exists when
``H(g) = det [[2 Q_j, |Q_j|²] (j = 2, 3, 4); [g, 0]] = 0``, a form of degree 13 in g that
has D as a factor.  On the circle u(β) it is a trigonometric polynomial of degree ≤ 13
with odd harmonics only (H is odd in g): it is sampled at 32 angles, its Fourier
coefficients give a polynomial of degree 13 in e^{2iβ} whose roots near the unit circle
(companion matrices, the eigenvalues of every circle in one call) are every real β;
each is polished by Newton's method, the roots of D (C at infinity) are dropped, and C,
the axis point (circle centre) and the angles follow by linear algebra.  Every circle of
every sub-task of a task (the positions of a dyad family's main link) and azimuth is
solved in one vectorised pass (:func:`_sphere_links_of`).

PS (slide direction d in the ground, sphere centre C): ``(R_j − I) C − s_j d = −t_j``
(j = 2, 3) are six linear equations in C and the slides s₂, s₃; they are consistent when
the 6x6 determinant of the augmented system vanishes, a quadratic form in d: on the
circle ``a + ρ cos(2β − φ) = 0``, solved in closed form (0 or 2 roots).

HS (helical axis of pitch p in the ground): ``T_j C = H(θ_j) C`` is linear in C and the
axis point for given (g, θ_j), but the slide p θ_j makes the problem transcendental: see
:func:`hs_links` for the search (exact RS links continued in the pitch, plus a grid).

SR, SP and SH are RS, PS and HS of the inverse task (positions ``S₁ⱼ⁻¹``, see
:func:`synthesis.inverse_screws`): the sphere is then in the ground, and the azimuth is
that of the moving axis (slide) direction in position 1, in the forward task's frame.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .binary import BinaryLink, _cross, _residuals, _rot, _signed_angle, _task
from .errors import SynthesisError
from .screw import Line
from .validate import array, number, screws as _screws, task_scales, unit
from .verify import pose_errors

__all__ = ["task_frame", "azimuth_of", "rs_links_at", "sr_links", "ps_links", "sp_links", "hs_links", "sh_links",
           "rs_condition", "ps_condition"]

_DEG_RS = 13                 # degree of H(g)
_K_RS = 32                   # samples on the circle (> 2 · degree: exact Fourier coefficients)


# ------------------------------------------------------------------ reference frame
def _frame_from_axes(axes) -> np.ndarray:
    e3 = axes[0] / np.linalg.norm(axes[0])
    for a in axes[1:]:
        v = a - (a @ e3) * e3
        if np.linalg.norm(v) > 1e-6:
            e1 = v / np.linalg.norm(v)
            break
    else:                                        # all screw axes parallel: any e1 ⊥ e3
        a = np.array([1.0, 0, 0]) if abs(e3[0]) < 0.9 else np.array([0, 1.0, 0])
        e1 = a - (a @ e3) * e3
        e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(e3, e1), e3], 1)


def task_frame(screws) -> np.ndarray:
    """The task's reference frame for azimuths: columns e1, e2, e3 (a rotation matrix).

    e3 is the axis of S₁₂, e1 the part of S₁₃'s axis perpendicular to it (S₁₄'s,
    ... if parallel; an arbitrary perpendicular when every axis is parallel to e3), e2 =
    e3 × e1.  It turns with the task under a rigid motion.

    Parameters
    ----------
    screws : sequence of Screw
        S₁₂ … S₁N (at least one).

    Returns
    -------
    numpy.ndarray, shape (3, 3)
    """
    scr = _screws(screws, "screws")
    if not scr:
        raise SynthesisError("screws: expected at least one Screw S_12")
    return _frame_from_axes([s.axis for s in scr])


def _frame_arg(frame, screws_list) -> np.ndarray:
    if frame is None:
        return _frame_from_axes([s.axis for s in screws_list])
    F = array(frame, "frame", (3, 3), what="a rotation matrix (3, 3) whose columns are e1, e2, e3")
    if np.abs(F.T @ F - np.eye(3)).max() > 1e-9 or np.linalg.det(F) < 0:
        raise SynthesisError("frame: expected a rotation matrix (orthonormal columns e1, e2, e3, "
                             "determinant +1)")
    return F


def azimuth_of(direction, screws=None, *, frame=None) -> float:
    """The azimuth ψ ∈ [0, π) (rad) of a direction in the task's reference frame: the
    value of the free parameter that puts ``direction`` on the searched great circle.

    Parameters
    ----------
    direction : array_like, shape (3,)
        Unit direction (a fixed axis for RS/PS, a moving one in position 1 for SR/SP).
    screws : sequence of Screw, optional
        The task (its :func:`task_frame`); or give ``frame``.
    frame : array_like (3, 3), optional
        A rotation matrix whose columns are e1, e2, e3.

    Returns
    -------
    float
        ψ in [0, π); 0 for a direction along e3 (on every circle).
    """
    u = unit(direction, "direction")
    if frame is None and screws is None:
        raise SynthesisError("screws, frame: give the task's screws or a frame")
    F = _frame_arg(frame, None if screws is None else _screws(screws, "screws")) \
        if frame is not None else task_frame(screws)
    x, y = u @ F[:, 0], u @ F[:, 1]
    if np.hypot(x, y) < 1e-15:
        return 0.0
    return float(np.arctan2(y, x) % np.pi)


def _circle(F, psi):
    """The great circle at azimuth ψ: ``u(β) = cos β a + sin β b``."""
    return F[:, 2], np.cos(psi) * F[:, 0] + np.sin(psi) * F[:, 1]


# ------------------------------------------------------------------ RS condition
def _rs_parts(g, R, t):
    """A's rows, D = det A, N = adj(A) b and the Q_j of the RS circle condition.

    Parameters
    ----------
    g : ndarray, shape (n, 3)
        Fixed axis directions.
    R, t : ndarray, shape (3, 3, 3) and (3, 3), or (n, 3, 3, 3) and (n, 3, 3)
        Rotations and translations of positions 2–4 (normalised): one task, or one per
        direction.

    Returns
    -------
    r : ndarray (n, 3, 3)
        A's rows ``gᵀ (R_j − I)``.
    D : ndarray (n,)
    N : ndarray (n, 3)
    Q : ndarray (n, 3, 3)
    """
    RI = R - np.eye(3)
    r = np.einsum("...mji,...j->...mi", RI, g)                 # rows gᵀ (R_j − I)
    b = -np.einsum("...mi,...i->...m", t, g)
    c0, c1, c2 = (_cross(r[:, 1], r[:, 2]), _cross(r[:, 2], r[:, 0]),
                  _cross(r[:, 0], r[:, 1]))
    D = np.sum(r[:, 0] * c0, -1)
    N = c0 * b[:, :1] + c1 * b[:, 1:2] + c2 * b[:, 2:3]
    Q = np.einsum("...mij,...j->...mi", RI, N) + t * D[:, None, None]
    return r, D, N, Q


def _rs_H(g, R, t):
    """The circle condition H(g) (n,) (degree 13 in g; R, t as :func:`_rs_parts`)."""
    _, _, _, Q = _rs_parts(g, R, t)
    M = np.zeros(g.shape[:1] + (4, 4))
    M[:, :3, :3] = 2 * Q
    M[:, :3, 3] = np.sum(Q * Q, -1)
    M[:, 3, :3] = g
    return np.linalg.det(M)


def _fourier(f, A, B, degree, K):
    """Samples and Fourier coefficients of ``f(u(β))`` on great circles
    ``u(β) = cos β A[i] + sin β B[i]``.

    Parameters
    ----------
    f : callable
        ``f(u (m, 3), circle (m,))`` → values (m,) at directions on the given circles.
    A, B : ndarray, shape (n, 3)
        The circles.
    degree, K : int
        f's degree in u and the samples per circle (K > 2 · degree: exact coefficients).

    Returns
    -------
    h : ndarray (n, K)
        f at β = 2πk/K.
    c : ndarray (n, K), complex
        Its Fourier coefficients (frequency k at index k mod K).
    scale : ndarray (n,)
        The largest magnitude of the coefficients of frequency −degree … degree (0 when
        not finite).
    """
    beta = 2 * np.pi * np.arange(K) / K
    u = np.cos(beta)[None, :, None] * A[:, None] + np.sin(beta)[None, :, None] * B[:, None]
    h = f(u.reshape(-1, 3), np.repeat(np.arange(len(A)), K)).reshape(len(A), K)
    c = np.fft.fft(h, axis=-1) / K
    scale = np.abs(c[:, np.arange(-degree, degree + 1) % K]).max(-1, initial=0.0)
    return h, c, np.where(np.isfinite(scale), scale, 0.0)


def _trig_roots_batch(f, A, B, degree, K, polish: int = 4):
    """Every real root β ∈ [0, π) of ``f(u(β))`` (f a form of ``degree`` in u: f(−u) =
    (−1)^degree f(u); u(β) = cos β A[i] + sin β B[i]) on n great circles at once, from
    ``K > 2 · degree`` samples each.

    f(u(β)) has the harmonics e^{ijβ}, j = −degree, −degree + 2, …, degree (the parity of
    the form), so ``e^{i·degree·β} f = P(w)`` is a polynomial of degree ``degree`` in
    ``w = e^{2iβ}`` whose coefficients are the Fourier coefficients of f (those below
    1e-13 of the largest at either end trimmed).  Its roots are the eigenvalues of the
    companion matrices (the circles of one degree in one call); those with
    ``||w|^½ − 1| < 1e-4`` (e^{iβ} within 1e-4 of the unit circle) give β = arg(w)/2 and
    are polished by ``polish`` Newton steps on f itself (central-difference derivative,
    steps clipped to 0.05 rad), then reduced to [0, π), sorted, and those within 1e-9
    (also across 0 ≡ π) merged.

    Parameters
    ----------
    f : callable
        ``f(u (m, 3), circle (m,))`` → values (m,) at directions on the given circles.
    A, B : ndarray, shape (n, 3)
        The circles.
    degree, K : int
    polish : int

    Returns
    -------
    beta : ndarray (r,)
        The roots (rad), grouped by circle, ascending within a circle.
    circle : ndarray of int (r,)
        The circle of each root (ascending).
    scale : ndarray (n,)
        The largest Fourier coefficient of f on each circle (0 when f vanishes there or is
        not finite; then no roots).
    """
    _, c, scale = _fourier(f, A, B, degree, K)
    live = np.flatnonzero(scale > 0)
    freq = np.arange(degree, -degree - 1, -2)                     # descending powers of w
    coef = c[live][:, freq % K] / scale[live, None]
    big = np.abs(coef) > 1e-13
    lead, last = np.argmax(big, 1), degree - np.argmax(big[:, ::-1], 1)
    cs, bs = [], []
    for lo, hi in set(zip(lead.tolist(), last.tolist())):        # usually one group
        grp = np.flatnonzero((lead == lo) & (last == hi))
        d = hi - lo
        if d < 1:
            continue
        comp = np.zeros((len(grp), d, d), complex)
        comp[:, 0] = -coef[grp, lo + 1:hi + 1] / coef[grp, lo:lo + 1]
        comp[:, np.arange(1, d), np.arange(d - 1)] = 1.0
        w = np.linalg.eigvals(comp)
        with np.errstate(all="ignore"):
            near = np.abs(np.sqrt(np.abs(w)) - 1) < 1e-4
        ci, ki = np.nonzero(near)
        cs.append(live[grp[ci]])
        bs.append(np.angle(w[ci, ki]) / 2)
    circle = np.concatenate(cs) if cs else np.zeros(0, int)
    bt = np.concatenate(bs) if bs else np.zeros(0)
    if polish and len(bt):
        bt = _newton(f, bt, circle, A, B, polish)
    return (*_distinct(bt, circle), scale)


def _newton(f, bt, circle, A, B, polish):
    """The roots ``bt (r,)`` of ``f(u(β))`` on their circles (``circle (r,)`` into A, B
    (n, 3)) polished by ``polish`` Newton steps (central-difference derivative, steps
    clipped to 0.05 rad), all roots in one evaluation of f per step."""
    a, b, cc = np.tile(A[circle], (3, 1)), np.tile(B[circle], (3, 1)), np.tile(circle, 3)
    hs = 1e-6
    n = len(bt)
    for _ in range(polish):                     # f and f' in one call
        x = np.concatenate([bt, bt + hs, bt - hs])
        f0, fp, fm = np.split(f(np.cos(x)[:, None] * a + np.sin(x)[:, None] * b, cc),
                              [n, 2 * n])
        d = (fp - fm) / (2 * hs)
        with np.errstate(all="ignore"):
            step = np.where(np.abs(d) > 0, f0 / d, 0.0)
        bt = bt - np.clip(np.nan_to_num(step), -0.05, 0.05)
    return bt


def _distinct(bt, circle):
    """Roots reduced to [0, π), sorted per circle, duplicates (within 1e-9, also across
    0 ≡ π) dropped: ``(bt, circle)`` grouped by circle."""
    if not len(bt):
        return bt, circle
    bt = bt % np.pi
    order = np.lexsort((bt, circle))
    bt, circle = bt[order], circle[order]
    first = np.r_[True, circle[1:] != circle[:-1]]
    keep = first | np.r_[True, np.diff(bt) > 1e-9]
    bt, circle = bt[keep], circle[keep]
    first = np.r_[True, circle[1:] != circle[:-1]]
    start = np.flatnonzero(first)
    last = np.r_[start[1:], len(bt)] - 1
    wrap = (last > start) & (bt[last] - bt[start] > np.pi - 1e-9)
    drop = np.zeros(len(bt), bool)
    drop[last[wrap]] = True
    return bt[~drop], circle[~drop]


def _turning_errors(T, name: str = "screws") -> np.ndarray:
    """Per task of ``T (B, n, 4, 4)`` (position 1 first): ``""``, or the error naming its
    first relative screw S₁ⱼ that (nearly) does not rotate (the RS sphere-centre planes are
    then not determined)."""
    ang = np.arccos(np.clip((np.trace(T[:, 1:, :3, :3], axis1=-2, axis2=-1) - 1) / 2, -1, 1))
    err = np.full(len(T), "", dtype=object)
    for b, j in zip(*np.nonzero(ang < 1e-6)):
        if not err[b]:
            err[b] = (f"{name}: S_1{j + 2} is (nearly) a pure translation (rotation "
                      f"{ang[b, j]:.1e} rad): the sphere-centre planes ⊥ the axis are then "
                      "not determined by the rotations; this case is not supported")
    return err


def _check_turning(task, name):
    err = _turning_errors(task.T[None], name)[0]
    if err:
        raise SynthesisError(err)


def _rs_batch(R, t, A, B, sub, tol_rank=1e-10):
    """RS links (normalised coordinates) on n great circles of S sub-tasks, in one pass.

    Parameters
    ----------
    R, t : ndarray, shape (S, 3, 3, 3) and (S, 3, 3)
        Each sub-task's rotations and translations of positions 2–4 (normalised).
    A, B : ndarray, shape (n, 3)
        The circles ``u(β) = cos β A + sin β B``.
    sub : ndarray of int, shape (n,)
        The sub-task of each circle.
    tol_rank : float
        Relative smallest singular value of A(g) below which g is a root of D (C at
        infinity: dropped).

    Returns
    -------
    circle : ndarray of int (m,)
        The circle of each link (ascending; a circle's links by ascending β).
    beta : ndarray (m,)
        Elevation β (rad).
    g, C, O : ndarray (m, 3)
        Fixed axis direction, sphere centre (position 1), axis point (circle centre).
    th : ndarray (m, 3)
        Revolute angles at positions 2–4 (rad).
    S : ndarray (m, 3, 3, 3)
        The body's rotations relative to the link at positions 2–4.
    scale : ndarray (n,)
        The condition's largest Fourier coefficient per circle (0: it vanishes on the
        whole circle, no links).
    """
    bt, circle, scale = _trig_roots_batch(lambda u, i: _rs_H(u, R[sub[i]], t[sub[i]]), A, B,
                                          _DEG_RS, _K_RS)
    if not len(bt):
        e = np.zeros((0, 3))
        return circle, bt, e, e, e, e, np.zeros((0, 3, 3, 3)), scale
    s = sub[circle]
    Rs, ts = R[s], t[s]
    g = np.cos(bt)[:, None] * A[circle] + np.sin(bt)[:, None] * B[circle]
    r, D, N, _ = _rs_parts(g, Rs, ts)
    sv = np.linalg.svd(r, compute_uv=False)
    ok = ~(sv[:, -1] < tol_rank * np.maximum(sv[:, 0], 1e-300))     # roots of D: C at ∞
    with np.errstate(all="ignore"):
        C = np.where(ok[:, None], N, 0.0) / np.where(ok, D, 1.0)[:, None]
    Cs = np.concatenate([C[:, None], np.einsum("mkij,mj->mki", Rs, C) + ts], 1)   # (m, 4, 3)
    A4 = np.concatenate([2 * (Cs[:, 1:] - Cs[:, :1]), g[:, None]], 1)
    b4 = np.concatenate([np.sum(Cs[:, 1:] ** 2, -1) - np.sum(Cs[:, 0] ** 2, -1)[:, None],
                         np.sum(g * Cs[:, 0], -1)[:, None]], 1)
    A4 = np.where(ok[:, None, None], A4, np.eye(4, 3))
    O = np.einsum("mij,mj->mi", np.linalg.pinv(A4), np.where(ok[:, None], b4, 0.0))
    u0 = Cs[:, 0] - O
    with np.errstate(invalid="ignore"):
        ok &= ~(np.linalg.norm(u0, axis=-1) < 1e-12 * np.maximum(1.0, np.abs(Cs).max((1, 2))))
    th = _signed_angle(u0[:, None], Cs[:, 1:] - O[:, None], g[:, None])
    S = np.swapaxes(_rot(g[:, None], th), -1, -2) @ Rs
    return circle[ok], bt[ok], g[ok], C[ok], O[ok], th[ok], S[ok], scale


_RS_DEGENERATE = ("screws: degenerate: the circle condition vanishes on the whole great circle "
                  "of this azimuth (every direction admissible?)")


def rs_condition(screws, direction, *, frame=None) -> float:
    """The RS circle condition ``H(g) / ‖H‖`` at a fixed-axis direction (dimensionless,
    normalised by the largest Fourier coefficient on the direction's great circle): it
    vanishes on the admissible directions (and on the roots of D, where no RS link
    exists).  For checking and plotting the one-parameter family."""
    task = _task(screws, "screws", (4,))
    g = unit(direction, "direction")
    F = _frame_arg(frame, _screws(screws, "screws"))
    a, b = _circle(F, azimuth_of(g, frame=F))
    R, t = task.R, task.t
    _, _, scale = _fourier(lambda u, i: _rs_H(u, R, t), a[None], b[None], _DEG_RS, _K_RS)
    return float(_rs_H(g[None], R, t)[0] / scale[0]) if scale[0] else 0.0


def _inverse(R, t):
    Ri = np.swapaxes(R, -1, -2)
    return Ri, -np.einsum("...ij,...j->...i", Ri, t)


# ------------------------------------------------------------------ batched sub-tasks
@dataclass
class _SubTasks:
    """Sub-tasks of one task (the positions of ``subsets``), each normalised as
    :func:`synthesis.binary._task` normalises a task of its own.

    Attributes
    ----------
    T : ndarray (S, n, 4, 4)
        Each sub-task's positions (user coordinates, position 1 first).
    Tn : ndarray (S, n, 4, 4)
        Normalised: ``x ↦ (x − c) / L``.
    c : ndarray (S, 3)
    L, reach : ndarray (S,)
    error : ndarray of object (S,)
        ``""``, or why the sub-task is degenerate (coincident positions).
    """

    T: np.ndarray
    Tn: np.ndarray
    c: np.ndarray
    L: np.ndarray
    reach: np.ndarray
    error: np.ndarray


def _subtasks(T, axes, points, subsets, name: str = "screws") -> _SubTasks:
    """The normalised sub-tasks of the task ``T (N, 4, 4)`` (screw ``axes``, ``points``
    (N − 1, 3) of S₁₂ … S₁N) through the positions ``subsets (S, n)`` (each starting at
    0), their coincident positions found in one batched comparison (the message of
    :func:`synthesis.binary._task`, positions numbered within the sub-task)."""
    subsets = np.asarray(subsets, int)
    S, n = subsets.shape
    Ts = T[subsets]
    c, L, reach = task_scales(Ts, axes[subsets[:, 1:] - 1], points[subsets[:, 1:] - 1])
    J, K = (np.array(x, int) for x in zip(*[(j, k) for j in range(n) for k in range(j)]))
    rot, pos = pose_errors(Ts[:, J], Ts[:, K], reach[:, None])
    same = np.maximum(rot, pos) < 1e-12
    error = np.full(S, "", dtype=object)
    for b in np.flatnonzero(same.any(1)):
        i = int(np.argmax(same[b]))
        error[b] = (f"{name}: positions {K[i] + 1} and {J[i] + 1} coincide (their relative "
                    "screw is the identity): degenerate task")
    C = np.zeros((S, 4, 4))
    C[:, :3, :3] = np.eye(3) / L[:, None, None]
    C[:, :3, 3] = -c / L[:, None]
    C[:, 3, 3] = 1.0
    Tn = C[:, None] @ Ts @ np.linalg.inv(C)[:, None]
    return _SubTasks(Ts, Tn, c, L, reach, error)


def _task_arrays(screws, n: int):
    """Validated screws of an n-position link task: ``(T (n, 4, 4), axes, points (n − 1,
    3))``, the errors of :func:`synthesis.binary._task` for the count."""
    scr = _screws(screws, "screws")
    if len(scr) + 1 != n:
        raise SynthesisError(f"screws: expected {n - 1} screws S_12 … S_1n for {n} positions, "
                             f"got {len(scr)}")
    T = np.stack([np.eye(4)] + [s.matrix() for s in scr])
    return (T, np.array([s.axis for s in scr], float).reshape(-1, 3),
            np.array([s.point for s in scr], float).reshape(-1, 3))


# ------------------------------------------------------------------ sphere links as arrays
@dataclass
class _SphereLinks:
    """RS, SR, PS or SP links of several sub-tasks and azimuths (:func:`_sphere_links_of`), as
    arrays; m links in all, n positions per sub-task.

    Attributes
    ----------
    kind : str
        ``"RS"``, ``"SR"``, ``"PS"`` or ``"SP"``.
    block : ndarray of int (m,)
        ``sub-task · len(azimuths) + azimuth index`` of each link (ascending; a block's
        links by ascending elevation).
    elevation : ndarray (m,)
        β (rad) on the circle of the azimuth.
    fixed_dir, fixed_point, moving_dir, moving_point : ndarray (m, 3)
        The joints' axes in position 1 as :class:`BinaryLink` holds them (an S joint: its
        centre, the other joint's direction).
    fixed_values, moving_values : ndarray (m, n)
        The fixed and moving joints' values at positions 1…n (angle rad for R, slide
        length for P; 0 for S).
    rotations : ndarray (m, n, 3, 3)
        The sphere's rotations (``sphere_rotations``).
    residual : ndarray (m,)
        Largest pose error over the sub-task's positions (rad, or relative to its reach).
    error : ndarray of object (S, len(azimuths))
        ``""``, or the message of the :class:`SynthesisError` the one-azimuth function
        raises for that sub-task and azimuth (then no links).
    """

    kind: str
    block: np.ndarray
    elevation: np.ndarray
    fixed_dir: np.ndarray
    fixed_point: np.ndarray
    moving_dir: np.ndarray
    moving_point: np.ndarray
    fixed_values: np.ndarray
    moving_values: np.ndarray
    rotations: np.ndarray
    residual: np.ndarray
    error: np.ndarray

    def take(self, keep) -> "_SphereLinks":
        """The links selected by ``keep`` (mask or indices), errors unchanged."""
        f = {k: getattr(self, k)[keep] for k in ("block", "elevation", "fixed_dir",
                                                  "fixed_point", "moving_dir", "moving_point",
                                                  "fixed_values", "moving_values", "rotations",
                                                  "residual")}
        return _SphereLinks(self.kind, error=self.error, **f)

    def binary_links(self, azimuths) -> list[list[BinaryLink]]:
        """The links of each block as :class:`BinaryLink` (blocks in order; ``azimuths``
        (rad) the grid the blocks index, for the links' ``parameters``)."""
        kind = self.kind
        out = [[] for _ in range(self.error.size)]
        z = np.zeros(self.fixed_values.shape[1])
        pitch = {"R": 0.0, "P": np.inf, "S": np.nan}

        def values(k, v):          # (angles, slides) of a joint of kind k with values v
            return (v.copy(), z.copy()) if k == "R" else (z.copy(), v.copy()) if k == "P" \
                else (z.copy(), z.copy())
        for i, blk in enumerate(self.block.tolist()):
            link = BinaryLink(kind, Line._exact(self.fixed_dir[i].copy(),
                                                self.fixed_point[i].copy()),
                              Line._exact(self.moving_dir[i].copy(), self.moving_point[i].copy()),
                              pitch[kind[0]], pitch[kind[1]],
                              *values(kind[0], self.fixed_values[i]),
                              *values(kind[1], self.moving_values[i]), float(self.residual[i]),
                              {"azimuth": float(azimuths[blk % len(azimuths)]),
                               "elevation": float(self.elevation[i])},
                              sphere_rotations=self.rotations[i].copy())
            out[blk].append(link)
        return out


def _screw_poses(u, p, ang, slide):
    """Screw motions ``(m, n, 4, 4)`` about the lines (u, p) ``(m, 3)`` by the angles and
    slides ``(m, n)``."""
    R = _rot(u[:, None], ang)
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = p[:, None] - np.einsum("mnij,mj->mni", R, p) + slide[..., None] * u[:, None]
    T[..., 3, 3] = 1.0
    return T


def _sphere_poses(R, c):
    """Rotations ``R (m, n, 3, 3)`` about the centres ``c (m, 3)`` as 4x4 transforms."""
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = c[:, None] - np.einsum("mnij,mj->mni", R, c)
    T[..., 3, 3] = 1.0
    return T


def _joint_poses(kind, d, p, v, rotations):
    zero = np.zeros_like(v)
    if kind == "S":
        return _sphere_poses(rotations, p)
    return _screw_poses(d, p, v, zero) if kind == "R" else _screw_poses(d, p, zero, v)


def _sphere_links_of(T, axes, points, subsets, azimuths, frame, kind: str, tol: float = 1e-9,
                 name: str = "screws") -> _SphereLinks:
    """Every RS, SR, PS or SP link of several sub-tasks of one task at several azimuths,
    in one pass (what :func:`rs_links_at`, :func:`sr_links`, :func:`ps_links` and
    :func:`sp_links` return, for each sub-task and azimuth).

    Parameters
    ----------
    T : ndarray, shape (N, 4, 4)
        The task's positions (position 1 the identity).
    axes, points : ndarray, shape (N − 1, 3)
        The axes (unit) and points of its screws S₁₂ … S₁N.
    subsets : array_like of int, shape (S, n)
        The positions (0-based, each row starting at 0) of each sub-task: n = 4 for RS
        and SR, 3 for PS and SP.
    azimuths : sequence of float
        ψ (rad) of each great circle (validated numbers).
    frame : ndarray, shape (3, 3)
        The reference frame (columns e1, e2, e3) of the azimuths (validated).
    kind : str
        ``"RS"``, ``"SR"``, ``"PS"`` or ``"SP"``.
    tol : float
        Largest pose error accepted (rad, or translation relative to the sub-task's reach).
    name : str
        The screws' argument name in messages.

    Returns
    -------
    _SphereLinks
        The links and, per sub-task and azimuth, the error (coincident positions, a screw
        that does not rotate for RS/SR, a condition vanishing on the whole circle).
    """
    sub = _subtasks(T, axes, points, subsets, name)
    return _sphere_links(sub, np.asarray(azimuths, float), frame, kind, tol)


def _sphere_links(sub: _SubTasks, psis, F, kind: str, tol: float) -> _SphereLinks:
    """:func:`_sphere_links_of` of validated sub-tasks (:func:`_subtasks`): ``psis`` the
    azimuths (A,) (rad, numbers), ``F`` the frame (3, 3), ``kind`` RS, SR, PS or SP,
    ``tol`` the largest pose error accepted."""
    S, n = sub.T.shape[:2]
    A = len(psis)
    error = np.repeat(sub.error[:, None], A, 1)
    if kind in ("RS", "SR"):
        turn = _turning_errors(sub.T)
        error[(sub.error == "") & (turn != "")] = turn[(sub.error == "") & (turn != "")][:, None]
    R, t = sub.Tn[:, 1:, :3, :3], sub.Tn[:, 1:, :3, 3]
    if kind in ("SR", "SP"):
        R, t = _inverse(R, t)
    bs, az = np.nonzero(error == "")
    a = np.broadcast_to(F[:, 2], (len(bs), 3))
    b = np.cos(psis[az])[:, None] * F[:, 0] + np.sin(psis[az])[:, None] * F[:, 1]
    if kind in ("RS", "SR"):
        circle, beta, g, C, O, th, Srot, scale = _rs_batch(R, t, a, b, bs)
        message = _RS_DEGENERATE
    else:
        circle, beta, g, C, sl, scale = _ps_batch(R, t, a, b, bs)
        message = ("azimuth: degenerate: every slide direction on this great circle "
                   "satisfies the PS condition (positions degenerate)")
    error[bs[scale == 0], az[scale == 0]] = message
    s = bs[circle]
    L, c0 = sub.L[s], sub.c[s]
    Cw = C * L[:, None] + c0
    m = len(circle)
    I3 = np.broadcast_to(np.eye(3), (m, 1, 3, 3))
    zero = np.zeros((m, n))
    if kind in ("RS", "SR"):
        Op = O * L[:, None] + c0
        u = g / np.linalg.norm(g, axis=-1, keepdims=True)              # as Line normalises
        ang = np.concatenate([np.zeros((m, 1)), th], 1)
        if kind == "RS":
            foot = Op - np.sum(Op * u, -1, keepdims=True) * u          # canonical point
            geo = (u, foot, g, Cw, ang, zero, np.concatenate([I3, Srot], 1))
        else:          # T_j = Rot_C(S'_jᵀ) G(−θ_j): sphere in the ground, axis in the body
            foot = Op + np.sum((Cw - Op) * u, -1, keepdims=True) * u
            geo = (g, Cw, g, foot, zero, -ang, np.concatenate([I3, np.swapaxes(Srot, -1, -2)], 1))
    else:
        sv = np.concatenate([np.zeros((m, 1)), sl * L[:, None]], 1)
        Rb = sub.Tn[s, 1:, :3, :3]           # the body's rotations (P does not turn)
        geo = ((g, Cw, g, Cw, sv, zero) if kind == "PS" else (g, Cw, g, Cw, zero, -sv)) + \
            (np.concatenate([I3, Rb], 1),)
    fd, fp, md, mp, fv, mv, rots = geo
    res = np.zeros(0)
    if m:
        poses = _joint_poses(kind[0], fd, fp, fv, rots) @ _joint_poses(kind[1], md, mp, mv, rots)
        rot, pos = pose_errors(poses, sub.T[s], sub.reach[s][:, None])
        res = np.maximum(rot.max(-1), pos.max(-1))
    links = _SphereLinks(kind, bs[circle] * A + az[circle], beta, fd, fp, md, mp, fv, mv, rots,
                        res, error)
    return links.take(res <= tol)


def _one_task(screws, azimuths, frame, tol, kind: str):
    """The links of one task at each azimuth (:func:`_sphere_links_of`), the arguments
    validated in the order of the one-azimuth functions: ``(links, azimuths)``."""
    n = 4 if kind in ("RS", "SR") else 3
    T, axes, points = _task_arrays(screws, n)
    sub = _subtasks(T, axes, points, np.arange(n)[None])
    if sub.error[0]:
        raise SynthesisError(sub.error[0])
    psis = np.array([number(psi, "azimuth", unit_="rad") for psi in azimuths], float)
    tol = number(tol, "tol", positive=True)
    F = _frame_arg(frame, _screws(screws, "screws"))
    return _sphere_links(sub, psis, F, kind, tol), psis


def _sphere_family(screws, azimuth, frame, tol, kind: str) -> list[BinaryLink]:
    """RS, SR, PS or SP links of one task at one azimuth, in user coordinates; an error
    raises."""
    links, psis = _one_task(screws, [azimuth], frame, tol, kind)
    if links.error[0, 0]:
        raise SynthesisError(links.error[0, 0])
    return links.binary_links(psis)[0]


def _rs_family(screws, azimuth, frame, tol, kind: str):
    """RS (``kind`` "RS") or SR ("SR") links at an azimuth, in user coordinates."""
    return _sphere_family(screws, azimuth, frame, tol, kind)


def rs_links_grid(screws, azimuths, *, frame=None, tol: float = 1e-9) -> list[tuple]:
    """:func:`rs_links_at` at each of several azimuths, the task validated once.

    Parameters
    ----------
    screws : sequence of three Screw
        S₁₂, S₁₃, S₁₄.
    azimuths : sequence of float
        ψ (rad) of each great circle.
    frame, tol
        As :func:`rs_links_at`.

    Returns
    -------
    list of (list of BinaryLink, str)
        Per azimuth, its links and ``""``, or no links and the message of the
        :class:`SynthesisError` that :func:`rs_links_at` raises there.
    """
    try:
        links, psis = _one_task(screws, azimuths, frame, tol, "RS")
    except SynthesisError as e:
        return [([], str(e)) for _ in azimuths]
    return [(lk, err) for lk, err in zip(links.binary_links(psis), links.error[0])]


def rs_links_at(screws, azimuth: float, *, frame=None, tol: float = 1e-9) -> list[BinaryLink]:
    """Every RS link (revolute axis in the ground, sphere centre in the body) through four
    positions whose fixed axis direction lies on the great circle of ``azimuth``.

    Parameters
    ----------
    screws : sequence of three Screw
        S₁₂, S₁₃, S₁₄ (each must rotate).
    azimuth : float
        ψ (rad), the free parameter: the fixed axis direction is
        ``cos β e3 + sin β (cos ψ e1 + sin ψ e2)`` for some β (see :func:`task_frame`;
        :func:`azimuth_of` reads ψ off a direction).  ψ and ψ + π are the same circle.
    frame : array_like (3, 3), optional
        Columns e1, e2, e3 replacing the task's reference frame.
    tol : float
        Largest pose error accepted (rad, or translation relative to the task's reach).

    Returns
    -------
    list of BinaryLink
        Types ``"RS"``, ordered by β: ``fixed_axis`` the revolute axis (canonical point),
        ``moving_axis.point`` the sphere centre in position 1 (its direction, a copy of
        the fixed one, is immaterial), ``fixed_angles`` the revolute angles,
        ``sphere_rotations`` the body's rotations relative to the link, ``parameters``
        ``{"azimuth": ψ, "elevation": β}`` (rad).  Up to 8 links; empty when none is
        real on this circle.

    Raises
    ------
    SynthesisError
        Bad input (naming it), coincident positions, a relative screw S₁ⱼ that does not
        rotate, or a condition vanishing on the whole circle.
    """
    return _rs_family(screws, azimuth, frame, tol, "RS")


def sr_links(screws, azimuth: float, *, frame=None, tol: float = 1e-9) -> list[BinaryLink]:
    """Every SR link (sphere centre in the ground, revolute axis in the body) through four
    positions whose moving axis direction (in position 1) lies on the great circle of
    ``azimuth`` (the RS links of the inverse task).

    Parameters
    ----------
    screws : sequence of three Screw
        S₁₂, S₁₃, S₁₄.
    azimuth : float
        ψ (rad) of the moving axis direction in the task's frame (:func:`task_frame` of
        these screws).
    frame : array_like (3, 3), optional
        Columns e1, e2, e3 replacing the task's reference frame.
    tol : float
        Largest pose error accepted (rad, or translation relative to the task's reach).

    Returns
    -------
    list of BinaryLink
        Types ``"SR"``: ``fixed_axis.point`` the sphere centre (direction immaterial),
        ``moving_axis`` the revolute axis in position 1 (point: foot of the perpendicular
        from the centre), ``moving_angles``, ``sphere_rotations`` the link's rotations.

    Raises
    ------
    SynthesisError
        As :func:`rs_links_at`.
    """
    return _rs_family(screws, azimuth, frame, tol, "SR")


# ------------------------------------------------------------------ PS
def _ps_det(d, R, t):
    """The 6x6 consistency determinant of ``(R_j − I) C − s_j d = −t_j`` (n,) for slide
    directions ``d (n, 3)``; ``R (2, 3, 3)``, ``t (2, 3)`` the rotations and translations
    of positions 2, 3 (one task), or ``(n, 2, 3, 3)``, ``(n, 2, 3)`` (one per direction)."""
    N = d.shape[0]
    M = np.zeros((N, 6, 6))
    for j in range(2):
        M[:, 3 * j:3 * j + 3, :3] = R[..., j, :, :] - np.eye(3)
        M[:, 3 * j:3 * j + 3, 3 + j] = -d
        M[:, 3 * j:3 * j + 3, 5] = t[..., j, :]
    return np.linalg.det(M)


def _ps_batch(R, t, A, B, sub):
    """PS links (normalised coordinates) on n great circles of S sub-tasks, in one pass:
    on a circle the condition is ``a + b cos 2β + c sin 2β = 0`` (three samples give it),
    solved in closed form (0 or 2 roots).

    Parameters
    ----------
    R, t : ndarray, shape (S, 2, 3, 3) and (S, 2, 3)
        Each sub-task's rotations and translations of positions 2, 3 (normalised).
    A, B : ndarray, shape (n, 3)
        The circles ``d(β) = cos β A + sin β B``.
    sub : ndarray of int, shape (n,)
        The sub-task of each circle.

    Returns
    -------
    circle : ndarray of int (m,)
        The circle of each link (ascending; a circle's links by ascending β).
    beta : ndarray (m,)
        Elevation β (rad).
    d, C : ndarray (m, 3)
        Slide direction and sphere centre (position 1).
    s : ndarray (m, 2)
        Slides at positions 2, 3.
    scale : ndarray (n,)
        The condition's size on each circle (0: it vanishes on the whole circle).
    """
    n = len(A)
    X = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    d3 = X[None, :, :1] * A[:, None] + X[None, :, 1:] * B[:, None]          # (n, 3, 3)
    v = _ps_det(d3.reshape(-1, 3), np.repeat(R[sub], 3, 0),
                np.repeat(t[sub], 3, 0)).reshape(n, 3)
    c0, c2 = v[:, 0], v[:, 1]
    c1 = v[:, 2] - c0 - c2
    Aq, Bq, Cq = (c0 + c2) / 2, (c0 - c2) / 2, c1 / 2              # A + B cos 2β + C sin 2β
    rho = np.hypot(Bq, Cq)
    scale = np.maximum(np.abs(Aq), rho)
    live = np.flatnonzero((scale != 0) & ~(rho < 1e-12 * scale) &
                          ~(np.abs(Aq) > rho * (1 + 1e-12)))
    phi = np.arctan2(Cq[live], Bq[live])
    acs = np.arccos(np.clip(-Aq[live] / rho[live], -1, 1))
    two = np.sort(np.round(np.stack([(phi + acs) / 2, (phi - acs) / 2], 1) % np.pi, 14), 1)
    keep = np.ones(two.shape, bool)
    keep[:, 1] = two[:, 1] != two[:, 0]
    ci, ki = np.nonzero(keep)
    circle, beta = live[ci], two[ci, ki]
    d = np.cos(beta)[:, None] * A[circle] + np.sin(beta)[:, None] * B[circle]
    s = sub[circle]
    M = np.zeros((len(beta), 6, 5))
    for j in range(2):
        M[:, 3 * j:3 * j + 3, :3] = R[s, j] - np.eye(3)
        M[:, 3 * j:3 * j + 3, 3 + j] = -d
    if len(beta):
        sv = np.linalg.svd(M, compute_uv=False)
        ok = ~(sv[:, -1] < 1e-10 * sv[:, 0])                        # C not determined
        x = np.einsum("mij,mj->mi", np.linalg.pinv(np.where(ok[:, None, None], M, np.eye(6, 5))),
                      -t[s].reshape(-1, 6))
    else:
        ok, x = np.zeros(0, bool), np.zeros((0, 5))
    return circle[ok], beta[ok], d[ok], x[ok, :3], x[ok, 3:], scale


def ps_condition(screws, direction) -> float:
    """The PS consistency determinant at a slide direction, divided by the largest
    magnitude of the quadratic form on the unit sphere's coordinate axes
    (dimensionless): zero on the admissible directions."""
    task = _task(screws, "screws", (3,))
    d = unit(direction, "direction")
    R, t = task.R, task.t
    sc = np.abs(_ps_det(np.eye(3), R, t)).max()
    v = _ps_det(d[None], R, t)[0]
    return float(v / sc) if sc > 0 else float(v)


def ps_links(screws, azimuth: float, *, frame=None, tol: float = 1e-9) -> list[BinaryLink]:
    """Every PS link (prismatic joint in the ground, sphere centre in the body) through
    three positions whose slide direction lies on the great circle of ``azimuth``.

    Parameters
    ----------
    screws : sequence of two Screw
        S₁₂, S₁₃.
    azimuth : float
        ψ (rad), the free parameter (see :func:`task_frame`, :func:`azimuth_of`).
    frame : array_like (3, 3), optional
        Columns e1, e2, e3 replacing the task's reference frame.
    tol : float
        Largest pose error accepted (rad, or translation relative to the task's reach).

    Returns
    -------
    list of BinaryLink
        Types ``"PS"`` (0 or 2 links): ``fixed_axis`` the slide direction (its line drawn
        through the sphere centre; the point is immaterial), ``fixed_slides`` (length),
        ``moving_axis.point`` the sphere centre in position 1, ``sphere_rotations`` the
        body's rotations, ``parameters`` ``{"azimuth", "elevation"}`` (rad).

    Raises
    ------
    SynthesisError
        Bad input (naming it), coincident positions, or a condition vanishing on the
        whole circle.
    """
    return _sphere_family(screws, azimuth, frame, tol, "PS")


def sp_links(screws, azimuth: float, *, frame=None, tol: float = 1e-9) -> list[BinaryLink]:
    """Every SP link (sphere centre in the ground, prismatic joint in the body) through
    three positions whose slide direction in the body (position 1) lies on the great
    circle of ``azimuth`` (the PS links of the inverse task).

    Parameters
    ----------
    screws : sequence of two Screw
        S₁₂, S₁₃.
    azimuth : float
        ψ (rad) of the body's slide direction in the task's frame.
    frame : array_like (3, 3), optional
        Columns e1, e2, e3 replacing the task's reference frame.
    tol : float
        Largest pose error accepted.

    Returns
    -------
    list of BinaryLink
        Types ``"SP"``: ``fixed_axis.point`` the sphere centre, ``moving_axis`` the slide
        direction in position 1 (drawn through the centre), ``moving_slides``,
        ``sphere_rotations`` the link's rotations (the body's, as P does not turn).

    Raises
    ------
    SynthesisError
        As :func:`ps_links`.
    """
    return _sphere_family(screws, azimuth, frame, tol, "SP")



# ------------------------------------------------------------------ HS
#: the (elevation, angle) grids whose local minima start the HS search: each alone misses
#: about 1.7 % of generating links (2 of 120 random chains), both together none of 120
_HS_GRIDS = ((24, 10), (36, 10))


def _hs_roots(R, t, P, p, circle, z, steps: int = 3):
    """HS links (normalised) on the great circles P (n, 2, 3) (``g(β) = cos β P[i, 0] +
    sin β P[i, 1]``) with pitch p ≠ 0, R (3, 3, 3), t (3, 3) C-contiguous.  Starting
    points: the RS links z (m, 4) = (β, θ₂, θ₃, θ₄) of the circles ``circle`` (m,)
    (ascending; exact, pitch 0) continued to pitch p in ``steps`` steps, and the local
    minima of the variable-projection misfit on the grids ``_HS_GRIDS`` over the elevation
    β and the three helical angles (:func:`synthesis.kernels.hs_starts`); all refined by
    Levenberg–Marquardt (:func:`synthesis.kernels.hs_refine`), every circle in one call.
    Returns per circle its links (β, g, C, c, θ), by ascending β."""
    from .binary import _perp
    from .kernels import hs_distinct, hs_refine, hs_starts, hs_systems
    for k in range(1, steps + 1):
        z, _, _ = hs_refine(z, P, circle, R, t, p * k / steps, 10)
    z, own, m = hs_starts(R, t, P, circle, z, p, np.array(_HS_GRIDS, np.int64))
    z, res, _ = hs_refine(z[:m], P, own[:m], R, t, p, 40)
    own = own[:m]
    keep = (res < 1e-9) & np.all(np.abs(z[:, 1:]) <= np.pi, 1)   # (−π, π]: no further turn
    z, own = z[keep], own[keep]
    G = np.cos(z[:, :1]) * P[own, 0] + np.sin(z[:, :1]) * P[own, 1]
    # every converged start's points at once: least squares by the SVD (as lstsq's gelsd)
    A, rhs = hs_systems(G, np.ascontiguousarray(z[:, 1:]), R, t, p)
    U, s, Vt = np.linalg.svd(A, full_matrices=False)
    x = np.einsum("kij,ki->kj", Vt, np.einsum("kji,kj->ki", U, rhs) / s)
    E1, E2 = _perp(G)
    ok = s[:, -1] >= 1e-9 * s[:, 0]
    z, own, G, C = z[ok], own[ok], G[ok], x[ok, :3]
    c = x[ok, 3:4] * E1[ok] + x[ok, 4:5] * E2[ok]
    beta, th = z[:, 0], z[:, 1:]
    k2 = np.where((beta < 0) | (beta >= np.pi), np.floor(beta / np.pi), 0.0)   # β ∈ [0, π)
    flip = np.where(np.mod(k2, 2) != 0, -1.0, 1.0)[:, None]
    beta, G, th = beta - k2 * np.pi, G * flip, th * flip
    keep = hs_distinct(own, G, C)
    out = [[] for _ in range(len(P))]
    for k in np.flatnonzero(keep):
        out[own[k]].append((float(beta[k]), G[k], C[k], c[k], th[k]))
    for o in out:
        o.sort(key=lambda o: o[0])
    return out


def _hs_tasks(T, axes, points, subsets):
    """The sub-tasks of the task ``T (N, 4, 4)`` (screw ``axes``, ``points`` (N − 1, 3))
    through the positions ``subsets (S, 4)`` (0-based, each starting at 0), normalised by
    :func:`_subtasks`: a list of ``_Task``, None where the sub-task's positions coincide,
    and the error messages (S,) (``""``, or :func:`_subtasks`' message)."""
    from .binary import _Task
    sub = _subtasks(T, axes, points, subsets)
    return [None if msg else _Task(sub.T[b], sub.Tn[b], sub.c[b], sub.L[b], sub.reach[b])
            for b, msg in enumerate(sub.error)], sub.error


def _hs_many(tasks, errors, p, psis, F, tol, kind):
    """HS (``kind`` "HS") or SH links of pitch p ≠ 0 of several sub-tasks (``_Task``, or
    None where ``errors`` names why not) at each azimuth of ``psis`` (validated numbers;
    F the frame): per sub-task a list with, per azimuth, its links (residual ≤ tol) or
    the SynthesisError it raised.  A sub-task's error (coincident positions, a screw that
    does not turn) holds for each of its azimuths; the RS links (pitch 0, the
    continuation's starts) of every sub-task and azimuth are found in one pass, the HS
    roots of a sub-task's azimuths in one compiled search (:func:`_hs_roots`)."""
    A = len(psis)
    out: list = [None] * len(tasks)
    live = []
    for s, task in enumerate(tasks):
        msg = errors[s] or _turning_errors(task.T[None], "screws")[0]
        if msg:
            out[s] = [SynthesisError(msg)] * A
        else:
            live.append(s)
    if not live:
        return out
    Rt = []
    for s in live:
        R, t = tasks[s].R, tasks[s].t
        if kind == "SH":
            R, t = _inverse(R, t)
        Rt.append((np.ascontiguousarray(R), np.ascontiguousarray(t)))
    circles = [_circle(F, psi) for psi in psis]
    P = np.array(circles)                                        # (A, 2, 3)
    # the RS links (pitch 0) of every sub-task's circles at once: the continuation's starts
    circle, rs_beta, *_, rs_th, _, scale = _rs_batch(
        np.stack([R for R, _ in Rt]), np.stack([t for _, t in Rt]),
        np.tile(P[:, 0], (len(live), 1)), np.tile(P[:, 1], (len(live), 1)),
        np.repeat(np.arange(len(live)), A))
    z = np.zeros(4)
    I3 = np.eye(3)[None]
    for k, s in enumerate(live):
        task, (R, t) = tasks[s], Rt[k]
        L, c0 = task.L, task.c
        sc = scale[k * A:(k + 1) * A]
        live_c = np.flatnonzero(sc != 0)      # elsewhere the RS condition vanishes on it
        rank = np.cumsum(sc != 0) - 1
        mine = (circle >= k * A) & (circle < (k + 1) * A)
        mine[mine] = sc[circle[mine] - k * A] != 0
        roots = _hs_roots(R, t, np.ascontiguousarray(P[live_c]), p / L,
                          rank[circle[mine] - k * A],
                          np.concatenate([rs_beta[mine, None], rs_th[mine]], 1)) \
            if len(live_c) else []
        res, links = [], []
        for i, psi in enumerate(psis):
            if sc[i] == 0:
                res.append(SynthesisError(_RS_DEGENERATE))
                continue
            res.append([])
            for beta, g, C, c, th in roots[rank[i]]:
                G = _rot(g, th)
                S = np.swapaxes(G, -1, -2) @ R
                Cw = C * L + c0
                axis = Line(g, c * L + c0)
                params = {"azimuth": psi, "elevation": beta}
                ang = np.r_[0.0, th]
                if kind == "HS":
                    link = BinaryLink("HS", axis.canonical(), Line._exact(g.copy(), Cw), p,
                                      np.nan, ang, p * ang, z.copy(), z.copy(), 0.0, params,
                                      sphere_rotations=np.concatenate([I3, S]))
                else:
                    link = BinaryLink("SH", Line._exact(g.copy(), Cw), Line._exact(
                        g.copy(), axis.foot_from(Cw)), np.nan, p, z, z.copy(), -ang, -p * ang,
                        0.0, params, sphere_rotations=np.concatenate([I3, np.swapaxes(S, -1, -2)]))
                res[-1].append(link)
                links.append(link)
        _residuals(links, task)                       # all azimuths' links at once
        out[s] = [r if isinstance(r, SynthesisError) else [lk for lk in r if lk.residual <= tol]
                  for r in res]
    return out


def _hs_family(screws, pitch, azimuths, frame, tol, kind):
    """HS (``kind`` "HS") or SH links through the positions of ``screws`` for each of the
    ``azimuths``: a list with, per azimuth, its links or the SynthesisError it raised.
    The task is validated and normalised once for all azimuths (bad input common to all
    of them raises)."""
    T, axes, points = _task_arrays(screws, 4)
    tasks, errors = _hs_tasks(T, axes, points, np.arange(4)[None])
    if errors[0]:
        raise SynthesisError(errors[0])
    scr = _screws(screws, "screws")
    p = number(pitch, "pitch", unit_="length/rad")
    psis = [number(psi, "azimuth", unit_="rad") for psi in azimuths]
    tol = number(tol, "tol", positive=True)
    F = _frame_arg(frame, scr)
    if p == 0:
        out: list = []
        for psi in psis:
            try:
                out.append(_rs_family(scr, psi, F, tol, "RS" if kind == "HS" else "SR"))
            except SynthesisError as e:
                out.append(e)
        return out
    _check_turning(tasks[0], "screws")
    return _hs_many(tasks, errors, p, psis, F, tol, kind)[0]


def _hs_links_grid(kind, screws, combos, psis, pitch, frame):
    """HS (``kind`` "HS") or SH links of every sub-task × azimuth of a task: sub-task i
    takes the screws of positions ``combos[i]`` (1-based, position 1 implied), azimuth a
    the ψ ``psis[a]`` on the great circles of ``frame`` (the task's, (3, 3)); the
    sub-tasks validated and their RS links found together (:func:`_hs_many`).  Returns
    the links, each link's block ``i · len(psis) + a`` (ndarray of int) and the error
    message of each block (``""`` where it solved), an (len(combos), len(psis)) object
    array."""
    combos = np.asarray(combos, int).reshape(len(combos), -1)
    error = np.full((len(combos), len(psis)), "", dtype=object)
    T, axes, points = _task_arrays(screws, len(screws) + 1)
    p = number(pitch, "pitch", unit_="length/rad")
    psis = [number(float(psi), "azimuth", unit_="rad") for psi in psis]
    F = _frame_arg(frame, _screws(screws, "screws"))
    if p == 0:
        res = []
        for i, others in enumerate(combos.tolist()):
            try:
                res.append(_hs_family([screws[j - 1] for j in others], p, psis, F, 1e-9, kind))
            except SynthesisError as e:
                res.append([e] * len(psis))
    else:
        res = _hs_many(*_hs_tasks(T, axes, points, np.concatenate(
            [np.zeros((len(combos), 1), int), combos], 1)), p, psis, F, 1e-9, kind)
    links, blocks = [], []
    for i, found_i in enumerate(res):
        for a, found in enumerate(found_i):
            if isinstance(found, SynthesisError):
                error[i, a] = str(found)
                continue
            links += found
            blocks += [i * len(psis) + a] * len(found)
    return links, np.array(blocks, int), error


def _one_azimuth(found):
    """The links of a single azimuth's result, raising its error."""
    if isinstance(found[0], SynthesisError):
        raise found[0]
    return found[0]


def hs_links(screws, pitch: float, azimuth: float, *, frame=None,
             tol: float = 1e-9) -> list[BinaryLink]:
    """HS links (helical joint of given pitch in the ground, sphere centre in the body)
    through four positions whose fixed axis direction lies on the great circle of
    ``azimuth``.

    The helical angle brings transcendental terms (slide = pitch · angle), so no
    polynomial gives the solutions: the nine translation equations
    ``(R_j − G_j) C + (G_j − I) c_g = p θ_j g − t_j`` are linear in the sphere centre C
    and the axis point c_g, and the elevation β and the three angles θ_j ∈ (−π, π] are
    found from two sets of starting points refined by Levenberg–Marquardt: the RS links
    of the circle (all of them, exact) continued in the pitch from 0, and the local
    minima of the misfit on two grids over (β, θ₂, θ₃, θ₄) (24 × 10³ and 36 × 10³).  Not a proof of
    completeness (a solution born away from pitch 0 whose basin is narrower than the
    grid can be missed); pitch 0 returns :func:`rs_links_at` exactly.

    Parameters
    ----------
    screws : sequence of three Screw
        S₁₂, S₁₃, S₁₄ (each must rotate).
    pitch : float
        Slide per radian of the helical joint (length / rad); 0 gives the RS links.
    azimuth : float
        ψ (rad), the free parameter, as for :func:`rs_links_at`.
    frame : array_like (3, 3), optional
        Columns e1, e2, e3 replacing the task's reference frame.
    tol : float
        Largest pose error accepted.

    Returns
    -------
    list of BinaryLink
        Types ``"HS"`` (``"RS"`` for pitch 0), ordered by β; helical angles in (−π, π]
        (a further whole turn is another link, not listed), slides pitch · angle.

    Raises
    ------
    SynthesisError
        As :func:`rs_links_at`.
    """
    return _one_azimuth(_hs_family(screws, pitch, [azimuth], frame, tol, "HS"))


def sh_links(screws, pitch: float, azimuth: float, *, frame=None,
             tol: float = 1e-9) -> list[BinaryLink]:
    """SH links (sphere centre in the ground, helical joint of given pitch in the body)
    through four positions whose moving axis direction (position 1) lies on the great
    circle of ``azimuth``: the HS links of the inverse task (see :func:`hs_links` for the
    method and its limits; pitch 0 returns :func:`sr_links`).

    Parameters
    ----------
    screws : sequence of three Screw
        S₁₂, S₁₃, S₁₄.
    pitch : float
        Slide per radian (length / rad).
    azimuth : float
        ψ (rad) of the moving axis direction in the task's frame.
    frame : array_like (3, 3), optional
    tol : float

    Returns
    -------
    list of BinaryLink
        Types ``"SH"`` (``"SR"`` for pitch 0).

    Raises
    ------
    SynthesisError
        As :func:`rs_links_at`.
    """
    return _one_azimuth(_hs_family(screws, pitch, [azimuth], frame, tol, "SH"))
