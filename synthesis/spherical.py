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
has D as a factor.  On the circle u(β) it is a trigonometric polynomial of degree ≤ 13:
it is sampled at 32 angles, its Fourier coefficients give a polynomial in e^{iβ} whose
unit-modulus roots (companion matrix, :func:`numpy.roots`) are every real β; each is
polished by Newton's method, the roots of D (C at infinity) are dropped, and C, the axis
point (circle centre) and the angles follow by linear algebra.

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

import numpy as np

from .binary import BinaryLink, _cross, _rot, _signed_angle, _task
from .errors import SynthesisError
from .screw import Line
from .validate import array, number, screws as _screws, unit
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
    """For directions ``g (N, 3)``: A's rows, D = det A, N = adj(A) b and Q_j (N, 3, 3)."""
    I = np.eye(3)
    r = np.einsum("mji,nj->nmi", R - I, g)                   # rows gᵀ (R_j − I)
    b = -np.einsum("mi,ni->nm", t, g)
    c0, c1, c2 = _cross(r[:, 1], r[:, 2]), _cross(r[:, 2], r[:, 0]), _cross(r[:, 0], r[:, 1])
    D = np.sum(r[:, 0] * c0, -1)
    N = c0 * b[:, :1] + c1 * b[:, 1:2] + c2 * b[:, 2:3]
    Q = np.einsum("mij,nj->nmi", R - I, N) + t[None] * D[:, None, None]
    return r, D, N, Q


def _rs_H(g, R, t):
    """The circle condition H(g) (N,) (degree 13 in g)."""
    _, _, _, Q = _rs_parts(g, R, t)
    M = np.zeros(g.shape[:1] + (4, 4))
    M[:, :3, :3] = 2 * Q
    M[:, :3, 3] = np.sum(Q * Q, -1)
    M[:, 3, :3] = g
    return np.linalg.det(M)


def _trig_roots(f, a, b, degree, K, polish: int = 4):
    """Every real root β ∈ [0, π) of the trigonometric polynomial ``f(u(β))`` (degree ≤
    ``degree``, odd or even, u(β) = cos β a + sin β b) from ``K > 2·degree`` samples:
    ``(β, scale)`` (:func:`_trig_roots_many` of one circle)."""
    return _trig_roots_many(f, [(a, b)], degree, K, polish)[0]


def _trig_roots_many(f, circles, degree, K, polish: int = 4) -> list[tuple]:
    """:func:`_trig_roots` on several great circles ``(a, b)`` at once (``f`` evaluated on
    all of them in each call).  Roots come from the companion matrix of ``z^degree f``;
    those within 1e-4 of the unit circle are polished by Newton's method on f itself.

    Returns
    -------
    list of (ndarray, float)
        Per circle, its roots β (sorted, distinct) and the largest Fourier coefficient of
        f on it (0 when f vanishes there; then no roots).
    """
    beta = 2 * np.pi * np.arange(K) / K
    A = np.array([a for a, _ in circles])[:, None]
    B = np.array([b for _, b in circles])[:, None]
    u = np.cos(beta)[None, :, None] * A + np.sin(beta)[None, :, None] * B
    h = f(u.reshape(-1, 3)).reshape(len(circles), K)
    cs = np.fft.fft(h, axis=-1) / K
    starts = [_unit_roots(c, degree, K) for c in cs]
    bts = _newton(f, [bt for bt, _ in starts], A[:, 0], B[:, 0], polish)
    return [(_distinct(bt) if len(bt0) else bt0, scale)
            for bt, (bt0, scale) in zip(bts, starts)]


def _unit_roots(c, degree, K):
    """The angles in [0, π) of the roots near the unit circle of the polynomial whose
    coefficients are the Fourier coefficients ``c`` (K,) of frequency +degree … −degree,
    and the largest coefficient's magnitude (``(empty, 0.0)`` when none is finite and
    nonzero)."""
    coef = np.array([c[k] if k >= 0 else c[K + k] for k in range(degree, -degree - 1, -1)])
    scale = np.abs(coef).max()
    if not np.isfinite(scale) or scale == 0:
        return np.zeros(0), 0.0
    coef = coef / scale
    nz = np.flatnonzero(np.abs(coef) > 1e-13)
    z = np.roots(coef[nz[0]:nz[-1] + 1]) if len(nz) > 1 else np.zeros(0)
    z = z[np.abs(np.abs(z) - 1) < 1e-4]
    return np.angle(z) % np.pi, scale


def _newton(f, bts, A, B, polish):
    """Polish the roots ``bts`` (one array per circle (A[i], B[i])) of ``f(u(β))`` by
    ``polish`` Newton steps (central-difference derivative, steps clipped to 0.05 rad),
    every circle's roots in one evaluation of f per step."""
    sizes = [len(bt) for bt in bts]
    bt = np.concatenate(bts)
    if len(bt) == 0:
        return bts
    a, b = (np.tile(np.repeat(X, sizes, axis=0), (3, 1)) for X in (A, B))
    hs = 1e-6
    n = len(bt)
    for _ in range(polish):                     # f and f' in one call
        x = np.concatenate([bt, bt + hs, bt - hs])
        f0, fp, fm = np.split(f(np.cos(x)[:, None] * a + np.sin(x)[:, None] * b), [n, 2 * n])
        d = (fp - fm) / (2 * hs)
        with np.errstate(all="ignore"):
            step = np.where(np.abs(d) > 0, f0 / d, 0.0)
        bt = bt - np.clip(np.nan_to_num(step), -0.05, 0.05)
    return np.split(bt, np.cumsum(sizes)[:-1])


def _distinct(bt):
    """Polished roots reduced to [0, π), sorted, duplicates (within 1e-9, also across
    0 ≡ π) dropped."""
    bt = np.sort(bt % np.pi)
    keep = np.r_[True, np.diff(bt) > 1e-9]
    bt = bt[keep]
    if len(bt) > 1 and bt[-1] - bt[0] > np.pi - 1e-9:
        bt = bt[:-1]
    return bt


def _check_turning(task, name):
    for j, Tj in enumerate(task.T[1:], start=2):
        ang = np.arccos(np.clip((np.trace(Tj[:3, :3]) - 1) / 2, -1, 1))
        if ang < 1e-6:
            raise SynthesisError(f"{name}: S_1{j} is (nearly) a pure translation (rotation "
                                 f"{ang:.1e} rad): the sphere-centre planes ⊥ the axis are then "
                                 "not determined by the rotations; this case is not supported")


def _rs_roots(R, t, circles) -> list[tuple]:
    """``(β, scale)`` of the RS circle condition on each great circle ``(a, b)``."""
    return _trig_roots_many(lambda u: _rs_H(u, R, t), circles, _DEG_RS, _K_RS)


def _rs_core(R, t, a, b, tol_rank=1e-10, roots=None):
    """RS links (normalised coordinates) on the great circle (a, b): list of
    (β, g, C, O, θ (m,), S (m, 3, 3), D-relative); ``roots`` the circle's
    :func:`_rs_roots` when already found."""
    bt, scale = _rs_roots(R, t, [(a, b)])[0] if roots is None else roots
    if scale == 0:
        raise SynthesisError("screws: degenerate: the circle condition vanishes on the whole "
                             "great circle of this azimuth (every direction admissible?)")
    out = []
    gs = np.cos(bt)[:, None] * a + np.sin(bt)[:, None] * b
    rs, Ds, Ns, _ = _rs_parts(gs, R, t)
    svs = np.linalg.svd(rs, compute_uv=False) if len(bt) else np.zeros((0, 3))
    for beta, g, D, N, s in zip(bt, gs, Ds, Ns, svs):
        if s[-1] < tol_rank * max(s[0], 1e-300):
            continue                                            # a root of D: C at infinity
        C = N / D
        Cs = np.vstack([C, np.einsum("mij,j->mi", R, C) + t])
        A4 = np.vstack([2 * (Cs[1:] - Cs[0]), g])
        b4 = np.r_[np.sum(Cs[1:] ** 2, -1) - Cs[0] @ Cs[0], g @ Cs[0]]
        O = np.linalg.lstsq(A4, b4, rcond=None)[0]
        u0 = Cs[0] - O
        if np.linalg.norm(u0) < 1e-12 * max(1.0, np.abs(Cs).max()):
            continue                                            # centre on the axis
        th = _signed_angle(np.broadcast_to(u0, (len(R), 3)), Cs[1:] - O, g)
        S = np.swapaxes(_rot(g, th), -1, -2) @ R
        out.append((beta, g, C, O, th, S))
    return out


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
    _, scale = _trig_roots(lambda u: _rs_H(u, R, t), a, b, _DEG_RS, _K_RS, polish=0)
    return float(_rs_H(g[None], R, t)[0] / scale) if scale else 0.0


def _residual(link, task):
    """Set the link's ``residual`` (largest pose error over the task); returns the link."""
    return _residuals([link], task)[0]


def _residuals(links, task):
    """:func:`_residual` of several links of one task, in one batched pose comparison."""
    if links:
        rot, pos = pose_errors(np.stack([lk.poses() for lk in links]), task.T, task.reach)
        for lk, r in zip(links, np.maximum(rot.max(-1), pos.max(-1))):
            lk.residual = float(r)
    return links


def _inverse(R, t):
    Ri = np.swapaxes(R, -1, -2)
    return Ri, -np.einsum("mij,mj->mi", Ri, t)


def _rs_setup(screws, azimuths, frame, tol, kind: str):
    """The validated RS/SR task (in the order :func:`rs_links_at` checks its arguments):
    ``(task, azimuths (list of float), tol, frame, R, t)``, R and t inverted for SR."""
    task = _task(screws, "screws", (4,))
    scr = _screws(screws, "screws")
    psis = [number(psi, "azimuth", unit_="rad") for psi in azimuths]
    tol = number(tol, "tol", positive=True)
    F = _frame_arg(frame, scr)
    _check_turning(task, "screws")
    R, t = task.R, task.t
    if kind == "SR":
        R, t = _inverse(R, t)
    return task, psis, tol, F, R, t


def _rs_on(task, psi, tol, F, R, t, kind: str, roots=None):
    """RS (``kind`` "RS") or SR ("SR") links of a set-up task (:func:`_rs_setup`) at the
    azimuth ``psi``, in user coordinates (``roots``: the circle's :func:`_rs_roots`, when
    already found)."""
    a, b = _circle(F, psi)
    L, c0 = task.L, task.c
    out = []
    n = len(task.T)
    z = np.zeros(n)
    I3 = np.eye(3)[None]
    for beta, g, C, O, th, S in _rs_core(R, t, a, b, roots=roots):
        Cw = C * L + c0
        axis = Line(g, O * L + c0)
        params = {"azimuth": psi, "elevation": float(beta)}
        if kind == "RS":
            ax = axis.canonical()
            link = BinaryLink("RS", ax, Line._exact(g.copy(), Cw), 0.0, np.nan, np.r_[0.0, th], z,
                              z.copy(), z.copy(), 0.0, params,
                              sphere_rotations=np.concatenate([I3, S]))
        else:              # T_j = Rot_C(S'_jᵀ) G(−θ_j): sphere in the ground, axis in the body
            ax = Line._exact(g.copy(), axis.foot_from(Cw))
            link = BinaryLink("SR", Line._exact(g.copy(), Cw), ax, np.nan, 0.0, z, z.copy(),
                              np.r_[0.0, -th], z.copy(), 0.0, params,
                              sphere_rotations=np.concatenate([I3, np.swapaxes(S, -1, -2)]))
        out.append(link)
    return [lk for lk in _residuals(out, task) if lk.residual <= tol]


def _rs_family(screws, azimuth, frame, tol, kind: str):
    """RS (``kind`` "RS") or SR ("SR") links at an azimuth, in user coordinates."""
    task, (psi,), tol, F, R, t = _rs_setup(screws, [azimuth], frame, tol, kind)
    return _rs_on(task, psi, tol, F, R, t, kind)


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
        task, psis, tol, F, R, t = _rs_setup(screws, azimuths, frame, tol, "RS")
    except SynthesisError as e:
        return [([], str(e)) for _ in azimuths]
    out = []
    roots = _rs_roots(R, t, [_circle(F, psi) for psi in psis])
    for psi, rt in zip(psis, roots):
        try:
            out.append((_rs_on(task, psi, tol, F, R, t, "RS", rt), ""))
        except SynthesisError as e:
            out.append(([], str(e)))
    return out


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
    """The 6x6 consistency determinant of ``(R_j − I) C − s_j d = −t_j`` (N,)."""
    N = d.shape[0]
    M = np.zeros((N, 6, 6))
    for j in range(2):
        M[:, 3 * j:3 * j + 3, :3] = R[j] - np.eye(3)
        M[:, 3 * j:3 * j + 3, 3 + j] = -d
        M[:, 3 * j:3 * j + 3, 5] = t[j]
    return np.linalg.det(M)


def _ps_core(R, t, a, b):
    """PS links (normalised) on the circle (a, b): list of (β, d, C, s (2,))."""
    p = lambda x, y: _ps_det((x * a + y * b)[None], R, t)[0]
    c0, c2 = p(1.0, 0.0), p(0.0, 1.0)
    c1 = p(1.0, 1.0) - c0 - c2
    A, B, Cc = (c0 + c2) / 2, (c0 - c2) / 2, c1 / 2                # A + B cos 2β + C sin 2β
    rho = np.hypot(B, Cc)
    scale = max(abs(A), rho)
    if scale == 0:
        raise SynthesisError("azimuth: degenerate: every slide direction on this great circle "
                             "satisfies the PS condition (positions degenerate)")
    if rho < 1e-12 * scale or abs(A) > rho * (1 + 1e-12):
        return []
    phi = np.arctan2(Cc, B)
    acs = np.arccos(np.clip(-A / rho, -1, 1))
    betas = np.unique(np.round(np.array([(phi + acs) / 2, (phi - acs) / 2]) % np.pi, 14))
    out = []
    for beta in betas:
        d = np.cos(beta) * a + np.sin(beta) * b
        M = np.zeros((6, 5))
        for j in range(2):
            M[3 * j:3 * j + 3, :3] = R[j] - np.eye(3)
            M[3 * j:3 * j + 3, 3 + j] = -d
        sv = np.linalg.svd(M, compute_uv=False)
        if sv[-1] < 1e-10 * sv[0]:
            continue                                            # C not determined
        x = np.linalg.lstsq(M, -t.reshape(-1), rcond=None)[0]
        out.append((float(beta), d, x[:3], x[3:]))
    return out


def _ps_family(screws, azimuth, frame, tol, kind):
    task = _task(screws, "screws", (3,))
    scr = _screws(screws, "screws")
    psi = number(azimuth, "azimuth", unit_="rad")
    tol = number(tol, "tol", positive=True)
    F = _frame_arg(frame, scr)
    R, t = task.R, task.t
    if kind == "SP":
        R, t = _inverse(R, t)
    a, b = _circle(F, psi)
    L, c0 = task.L, task.c
    z = np.zeros(3)
    I3 = np.eye(3)[None]
    out = []
    for beta, d, C, s in _ps_core(R, t, a, b):
        Cw = C * L + c0
        params = {"azimuth": psi, "elevation": beta}
        if kind == "PS":
            link = BinaryLink("PS", Line._exact(d.copy(), Cw), Line._exact(d.copy(), Cw.copy()),
                              np.inf, np.nan, z, np.r_[0.0, s * L], z.copy(), z.copy(), 0.0,
                              params, sphere_rotations=np.concatenate([I3, R]))
        else:          # inverse: T'_j = Trans(s_j d) Rot_C(R'_j) → T_j = Rot_C(R_j) Trans(−s_j d)
            link = BinaryLink("SP", Line._exact(d.copy(), Cw), Line._exact(d.copy(), Cw.copy()),
                              np.nan, np.inf, z, z.copy(), z.copy(), np.r_[0.0, -s * L], 0.0,
                              params, sphere_rotations=np.concatenate([I3, task.R]))
        _residual(link, task)
        if link.residual <= tol:
            out.append(link)
    return out


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
    return _ps_family(screws, azimuth, frame, tol, "PS")


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
    return _ps_family(screws, azimuth, frame, tol, "SP")



# ------------------------------------------------------------------ HS
#: the (elevation, angle) grids whose local minima start the HS search: each alone misses
#: about 1.7 % of generating links (2 of 120 random chains), both together none of 120
_HS_GRIDS = ((24, 10), (36, 10))


def _hs_grid_starts(R, t, a, b, p, nb, nt):
    """Local minima (β, θ₂, θ₃, θ₄) (M, 4) of the variable-projection misfit on a grid of
    ``nb`` elevations β ∈ (0, π) and ``nt`` angles per position in (−π, π)."""
    from .kernels import hs_grid
    f = hs_grid(a, b, R, t, p, nb, nt)
    # neighbours; β wraps to β ± π with θ → −θ (the same axis, reversed)
    P = np.concatenate([f[-1:, ::-1, ::-1, ::-1], f, f[:1, ::-1, ::-1, ::-1]], 0)
    P = np.pad(P, [(0, 0), (1, 1), (1, 1), (1, 1)], constant_values=np.inf)
    core = P[1:-1, 1:-1, 1:-1, 1:-1]
    ok = np.ones(f.shape, bool)
    for ax in range(4):
        for sh in (-1, 1):
            sl = [slice(1, -1)] * 4
            sl[ax] = slice(1 + sh, P.shape[ax] - 1 + sh)
            ok &= core <= P[tuple(sl)]
    ib, i2, i3, i4 = np.nonzero(ok)
    bt = (np.arange(nb) + 0.5) * np.pi / nb
    tg = -np.pi + (np.arange(nt) + 0.5) * 2 * np.pi / nt              # symmetric grid
    return np.stack([bt[ib], tg[i2], tg[i3], tg[i4]], -1)


def _hs_core(R, t, a, b, p, steps: int = 3):
    """HS links (normalised) on the circle (a, b) with pitch p ≠ 0.  Starting points: the
    RS links of the circle (exact, pitch 0) continued to pitch p in ``steps`` steps, and
    the local minima of the variable-projection misfit on the grids ``_HS_GRIDS`` over
    the elevation β and the three helical angles; all refined by Levenberg–Marquardt
    (compiled: :mod:`synthesis.kernels`).  Returns (β, g, C, c, θ)."""
    from .binary import _perp
    from .kernels import hs_refine, hs_system
    R, t = np.ascontiguousarray(R), np.ascontiguousarray(t)
    z = np.array([[beta, *th] for beta, _, _, _, th, _ in _rs_core(R, t, a, b)]).reshape(-1, 4)
    for k in range(1, steps + 1):
        z, _, _ = hs_refine(z, a, b, R, t, p * k / steps, 10)
    z0 = np.concatenate([z] + [_hs_grid_starts(R, t, a, b, p, nb, nt) for nb, nt in _HS_GRIDS])
    z, res, _ = hs_refine(z0, a, b, R, t, p, 40)
    out = []
    for k in np.flatnonzero(res < 1e-9):
        beta, th = z[k, 0], z[k, 1:]
        if np.any(np.abs(th) > np.pi):
            continue                       # a further turn: outside the convention (−π, π]
        g = np.cos(beta) * a + np.sin(beta) * b
        A, rhs = hs_system(g, th, R, t, p)
        s = np.linalg.svd(A, compute_uv=False)
        if s[-1] < 1e-9 * s[0]:
            continue
        x = np.linalg.lstsq(A, rhs, rcond=None)[0]
        e1, e2 = _perp(g)
        C, c = x[:3], x[3] * e1 + x[4] * e2
        if beta < 0 or beta >= np.pi:                            # back to β ∈ [0, π)
            k2 = np.floor(beta / np.pi)
            if int(k2) % 2:
                g, th = -g, -th
            beta = beta - k2 * np.pi
        if any(abs(abs(g @ o[1]) - 1) < 1e-8 and np.linalg.norm(C - o[2]) < 1e-7 for o in out):
            continue
        out.append((float(beta), g, C, c, th))
    out.sort(key=lambda o: o[0])
    return out


def _hs_family(screws, pitch, azimuth, frame, tol, kind):
    task = _task(screws, "screws", (4,))
    scr = _screws(screws, "screws")
    p = number(pitch, "pitch", unit_="length/rad")
    psi = number(azimuth, "azimuth", unit_="rad")
    tol = number(tol, "tol", positive=True)
    F = _frame_arg(frame, scr)
    if p == 0:
        return _rs_family(scr, psi, F, tol, "RS" if kind == "HS" else "SR")
    _check_turning(task, "screws")
    R, t = task.R, task.t
    if kind == "SH":
        R, t = _inverse(R, t)
    a, b = _circle(F, psi)
    L, c0 = task.L, task.c
    pn = p / L
    n = len(task.T)
    z = np.zeros(n)
    I3 = np.eye(3)[None]
    out = []
    for beta, g, C, c, th in _hs_core(R, t, a, b, pn):
        G = _rot(g, th)
        S = np.swapaxes(G, -1, -2) @ R
        Cw = C * L + c0
        axis = Line(g, c * L + c0)
        params = {"azimuth": psi, "elevation": beta}
        ang = np.r_[0.0, th]
        if kind == "HS":
            link = BinaryLink("HS", axis.canonical(), Line._exact(g.copy(), Cw), p, np.nan, ang,
                              p * ang, z.copy(), z.copy(), 0.0, params,
                              sphere_rotations=np.concatenate([I3, S]))
        else:
            link = BinaryLink("SH", Line._exact(g.copy(), Cw), Line._exact(g.copy(),
                              axis.foot_from(Cw)), np.nan, p, z, z.copy(), -ang, -p * ang, 0.0,
                              params, sphere_rotations=np.concatenate([I3, np.swapaxes(S, -1, -2)]))
        _residual(link, task)
        if link.residual <= tol:
            out.append(link)
    return out


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
    return _hs_family(screws, pitch, azimuth, frame, tol, "HS")


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
    return _hs_family(screws, pitch, azimuth, frame, tol, "SH")
