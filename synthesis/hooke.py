"""Binary links with a universal (Hooke) joint in the ground — Kharatyan's two-degree-of-
freedom spherical pair С₂ — and a revolute or prismatic joint on the link (UR, UP),
through finite positions, with the free parameters explicit.

A U joint has a centre O, a first axis a fixed in the ground and a cross axis b ⊥ a on
the link (through O, turning with the first angle): the link turns about O by
``Rot(a, α) Rot(b, γ)``.  A rotation L is of that form exactly when ``a · L b = 0``, so a
U link is an S link (sphere centre O in the ground, see :mod:`synthesis.spherical`)
whose link rotations L_j (j = 1…n, L₁ = I) all satisfy ``aᵀ L_j b = 0``: the
sphere-ended link's free parameter, and then a direction problem.

Counting (U: centre 3, a 2, b 1; R axis 4, P direction 2; 6 − 3 = 3 conditions per
position):

==========  =========  ==============================================================
link        positions  free parameters (explicit arguments)
==========  =========  ==============================================================
UP          3          ``slide_azimuth`` (rad: the body's slide direction, as for SP)
                       and ``axis_azimuth`` (rad: the first axis a on a great circle):
                       a satisfies ``det[a, L₂ᵀa, L₃ᵀa] = 0``, a cubic form, so up to
                       3 axes per circle; up to 2 × 3 links
UH          4          ``pitch`` given, ``azimuth`` (rad: the body's helical axis, as
                       for SH), then the U directions as for UR
UR          4          ``azimuth`` (rad: the body's revolute axis, as for SR); the
                       directions (a, b) with ``aᵀ L_j b = 0``, j = 1…4, are 4 bilinear
                       equations with 6 complex solutions, all computed (resultant of
                       two plane cubics, degree 9 less 3 base points); up to 8 × 6 links
==========  =========  ==============================================================

Azimuths refer to the task's reference frame (:func:`synthesis.spherical.task_frame`).
UC          4          ``centre`` (length, 3: the U joint's centre O) and ``azimuth``
                       (rad: the body's cylinder axis direction w): the body line W must
                       keep its distance from O, i.e. be equidistant from O and T_j⁻¹O
                       (j = 2…4): the four points project onto a plane ⊥ w as concyclic
                       points, a cubic cone in w (up to 3 per circle), W through the
                       circle's centre; then the U directions as for UR

UC through six positions (finitely many links) is not implemented here.
"""
from __future__ import annotations

import numpy as np

from .binary import BinaryLink, _cross, _rot, _signed_angle, _task
from .errors import SynthesisError
from .screw import Line
from .spherical import _circle, _frame_arg, _trig_roots, sh_links, sp_links, sr_links
from .validate import array, number, screws as _screws, vec3
from .verify import pose_errors

__all__ = ["up_links", "ur_links", "uh_links", "uc_links", "u_directions"]


def _u_angles(a, b, L):
    """Angles α_j about a and γ_j about b with ``L_j = Rot(a, α_j) Rot(b, γ_j)``
    (L (n, 3, 3), a ⊥ b, a · L_j b = 0)."""
    n = len(L)
    Lb = L @ b
    al = _signed_angle(np.broadcast_to(b, (n, 3)), Lb, a)
    M = np.swapaxes(_rot(a, al), -1, -2) @ L                     # = Rot(b, γ)
    ga = _signed_angle(np.broadcast_to(a, (n, 3)), M @ a, b)
    return al, ga


def _null_b(a, L):
    """The cross axis b ⊥ every L_jᵀ a (rows), or None when not determined (rank < 2)."""
    M = np.einsum("mji,j->mi", L, a)                            # rows (L_jᵀ a)ᵀ
    _, s, Vt = np.linalg.svd(M)
    if s[1] < 1e-8 * s[0]:
        return None, s
    return Vt[-1], s


def _cubic_axes(L, a0, b0):
    """First axes a on the great circle (a0, b0) with ``det[a, L₂ᵀa, L₃ᵀa] = 0``."""
    def f(u):
        r2 = np.einsum("ji,nj->ni", L[1], u)
        r3 = np.einsum("ji,nj->ni", L[2], u)
        return np.sum(u * _cross(r2, r3), -1)
    bt, scale = _trig_roots(f, a0, b0, 3, 8)
    if scale == 0:
        raise SynthesisError("axis_azimuth: degenerate: every first axis on this great circle "
                             "admits a cross axis (the link rotations share an axis?)")
    return [np.cos(x) * a0 + np.sin(x) * b0 for x in bt]


def _u_link(base: BinaryLink, types, a, b, task, params):
    L = base.sphere_rotations
    al, ga = _u_angles(a, b, L)
    O = base.fixed_axis.point
    link = BinaryLink(types, Line._exact(a.copy(), O.copy()), base.moving_axis, 0.0,
                      base.moving_pitch, al, np.zeros(len(L)), base.moving_angles.copy(),
                      base.moving_slides.copy(), 0.0, dict(params), cross_axis=b.copy(),
                      cross_angles=ga)
    rot, pos = pose_errors(link.poses(), task.T, task.reach)
    link.residual = float(max(rot.max(), pos.max()))
    return link


def u_directions(link_rotations) -> np.ndarray:
    """Every real pair (a, b) of unit directions with ``aᵀ L_j b = 0`` for four rotations
    (L₁ = I): the universal joints whose link can take the four orientations.

    Parameters
    ----------
    link_rotations : array_like, shape (4, 3, 3)
        The link's rotations L₁ (the identity) … L₄.

    Returns
    -------
    numpy.ndarray, shape (k, 2, 3)
        k ≤ 6 pairs (first axis a, cross axis b); a and −a (b and −b) are the same
        joint, one sign is returned.

    Method: with ``b ∝ a × L₂ᵀ a`` the conditions j = 3, 4 are two cubic forms in a;
    their resultant (in two affine charts, merged) is a degree-9 polynomial whose roots
    include the 3 eigenvectors of L₂ (base points, dropped); the rest are polished by
    Gauss–Newton on the four bilinear equations.
    """
    L = array(link_rotations, "link_rotations", (4, 3, 3),
              what="four rotation matrices, the first the identity")
    if np.abs(np.swapaxes(L, 1, 2) @ L - np.eye(3)).max() > 1e-9 or np.any(np.linalg.det(L) < 0):
        raise SynthesisError("link_rotations: expected rotation matrices (orthonormal, "
                             "determinant +1)")
    if np.abs(L[0] - np.eye(3)).max() > 1e-9:
        raise SynthesisError("link_rotations: expected the identity as the first rotation (L₁ = I)")
    return _directions4(L)


def _cubics(a, L):
    bb = _cross(a, np.einsum("ji,...j->...i", L[1], a))
    return np.stack([np.einsum("...i,ij,...j->...", a, L[2], bb),
                     np.einsum("...i,ij,...j->...", a, L[3], bb)], -1)


def _monomials(x, y):
    return np.stack([x ** i * y ** j for i in range(4) for j in range(4 - i)], -1)


def _chart_roots(L, E):
    """Candidate a (complex chart solutions mapped to the sphere) in the chart
    a = x E0 + y E1 + E2."""
    rng = np.random.default_rng(7)
    P = rng.uniform(-1, 1, (30, 2))
    A = P[:, :1] * E[:, 0] + P[:, 1:] * E[:, 1] + E[:, 2]
    cf = np.linalg.lstsq(_monomials(P[:, 0], P[:, 1]), _cubics(A, L), rcond=None)[0]  # (10, 2)
    # W[k, 3 − i, j]: coefficient of x^i y^j in cubic k
    W = np.zeros((2, 4, 4))
    for m, (i, j) in enumerate((i, j) for i in range(4) for j in range(4 - i)):
        W[:, 3 - i, j] = cf[m]

    def xpoly(y):          # (N,) → (2, N, 4): coefficients in x, highest first
        return np.einsum("kij,nj->kni", W, np.power.outer(y, np.arange(4)))
    K = 32
    ys = np.exp(2j * np.pi * np.arange(K) / K)
    pq = xpoly(ys)
    S = np.zeros((K, 6, 6), complex)
    for r in range(3):
        S[:, r, r:r + 4] = pq[0]
        S[:, r + 3, r:r + 4] = pq[1]
    c = np.fft.fft(np.linalg.det(S)) / K                       # c[k]: coefficient of y^k
    coef = c[:10][::-1]
    if np.abs(coef).max() == 0:
        return []
    coef = coef / np.abs(coef).max()
    nz = np.flatnonzero(np.abs(coef) > 1e-12)
    y = np.roots(coef[nz[0]:])
    if len(y) == 0:
        return []
    p, q = xpoly(y)
    out = []
    lead = np.abs(p[:, 0]) > 1e-12 * np.abs(p).max(1)
    for k in range(len(y)):
        xr = np.roots(p[k] if lead[k] else p[k, 1:])
        if len(xr) == 0:
            continue
        x = xr[np.argmin(np.abs(np.polyval(q[k], xr)))]
        a = x * E[:, 0] + y[k] * E[:, 1] + E[:, 2]
        if np.abs(a.imag).max() > 1e-5 * np.abs(a).max():
            continue
        out.append(a.real / np.linalg.norm(a.real))
    return out


def _polish(a, L, iters=8):
    """Gauss–Newton on the bilinear equations for a on the sphere (b the null vector)."""
    for _ in range(iters):
        b, s = _null_b(a, L)
        if b is None:
            return None, None
        r = np.einsum("i,mij,j->m", a, L, b)
        if np.abs(r).max() < 1e-15:
            break
        e1 = _cross(a, np.array([1.0, 0, 0]) if abs(a[0]) < 0.9 else np.array([0, 1.0, 0]))
        e1 /= np.linalg.norm(e1)
        e2 = _cross(a, e1)
        J = np.zeros((4, 2))
        h = 1e-7
        for k, e in enumerate((e1, e2)):
            ap = (a + h * e) / np.linalg.norm(a + h * e)
            bp, _ = _null_b(ap, L)
            if bp is None:
                return None, None
            bp = bp * np.sign(bp @ b)
            J[:, k] = (np.einsum("i,mij,j->m", ap, L, bp) - r) / h
        du = np.linalg.lstsq(J, -r, rcond=None)[0]
        a = a + du[0] * e1 + du[1] * e2
        a /= np.linalg.norm(a)
    b, s = _null_b(a, L)
    return a, b


def _directions4(L):
    ev_bad = []
    w, V = np.linalg.eig(L[1].T)
    for k in range(3):
        ev_bad.append(V[:, k])
    # two generic charts (fixed, well away from each other)
    E1 = np.linalg.qr(np.array([[0.31, -0.72, 0.62], [0.83, 0.18, -0.53], [0.46, 0.67, 0.58]]))[0]
    E2 = E1[:, [2, 0, 1]]
    cands = _chart_roots(L, E1) + _chart_roots(L, E2)
    out = []
    for a in cands:
        # drop the base points: the eigenvectors of L₂ᵀ (real: its axis)
        if np.linalg.norm(_cross(a, np.einsum("ji,j->i", L[1], a))) < 1e-6:
            continue
        a, b = _polish(a, L)
        if a is None:
            continue
        r = np.abs(np.einsum("i,mij,j->m", a, L, b)).max()
        if r > 1e-10:
            continue
        if any(abs(abs(a @ o[0]) - 1) < 1e-8 and abs(abs(b @ o[1]) - 1) < 1e-8 for o in out):
            continue
        out.append((a, b))
    return np.array(out).reshape(-1, 2, 3)


def up_links(screws, *, slide_azimuth: float, axis_azimuth: float, frame=None,
             tol: float = 1e-9) -> list[BinaryLink]:
    """Every UP link (universal joint in the ground, prismatic joint in the body) through
    three positions at the given free parameters.

    Parameters
    ----------
    screws : sequence of two Screw
        S₁₂, S₁₃.
    slide_azimuth : float
        Azimuth (rad) of the body's slide direction in position 1 (as
        :func:`synthesis.spherical.sp_links`): fixes the centre and slide (0 or 2).
    axis_azimuth : float
        Azimuth (rad) of the U joint's first axis a (fixed in the ground) in the task's
        frame: every a on that great circle with ``det[a, R₂ᵀa, R₃ᵀa] = 0`` (1 to 3).
    frame : array_like (3, 3), optional
        Columns e1, e2, e3 replacing the task's reference frame.
    tol : float
        Largest pose error accepted (rad, or translation relative to the task's reach).

    Returns
    -------
    list of BinaryLink
        Types ``"UP"``: ``fixed_axis`` the first axis through the centre (its point is
        the centre), ``cross_axis`` b in position 1, ``fixed_angles`` / ``cross_angles``
        (rad), ``moving_axis`` the slide direction, ``moving_slides`` (length);
        ``parameters`` ``{"slide_azimuth", "axis_azimuth", "elevation"}`` (elevation: of a
        on its circle, rad).

    Raises
    ------
    SynthesisError
        Bad input (naming it), coincident positions, or a degenerate circle.
    """
    task = _task(screws, "screws", (3,))
    scr = _screws(screws, "screws")
    psi_s = number(slide_azimuth, "slide_azimuth", unit_="rad")
    psi_a = number(axis_azimuth, "axis_azimuth", unit_="rad")
    F = _frame_arg(frame, scr)
    tol = number(tol, "tol", positive=True)
    a0, b0 = _circle(F, psi_a)
    bases = sp_links(scr, psi_s, frame=F, tol=tol)
    out = []
    if not bases:
        return out
    Lr = bases[0].sphere_rotations                      # the body's (= link's) rotations
    for a in _cubic_axes(Lr, a0, b0):
        b, _ = _null_b(a, Lr)
        if b is None:
            continue
        elev = float(np.arctan2(a @ b0, a @ a0) % np.pi)
        for base in bases:
            link = _u_link(base, "UP", a, b, task, {"slide_azimuth": psi_s,
                                                    "axis_azimuth": psi_a, "elevation": elev})
            if link.residual <= tol:
                out.append(link)
    return out


def ur_links(screws, *, azimuth: float, frame=None, tol: float = 1e-9) -> list[BinaryLink]:
    """Every UR link (universal joint in the ground, revolute joint in the body) through
    four positions at the given free parameter.

    Parameters
    ----------
    screws : sequence of three Screw
        S₁₂, S₁₃, S₁₄ (each must rotate).
    azimuth : float
        Azimuth (rad) of the body's revolute axis direction in position 1 (the SR
        link's parameter, :func:`synthesis.spherical.sr_links`).
    frame : array_like (3, 3), optional
        Columns e1, e2, e3 replacing the task's reference frame.
    tol : float
        Largest pose error accepted.

    Returns
    -------
    list of BinaryLink
        Types ``"UR"`` (for each SR link at the azimuth, every real U direction pair,
        up to 6): ``fixed_axis`` the first axis (point: the centre), ``cross_axis``,
        ``fixed_angles`` / ``cross_angles``, ``moving_axis`` the revolute axis in
        position 1, ``moving_angles``; ``parameters`` ``{"azimuth", "elevation"}``.

    Raises
    ------
    SynthesisError
        As :func:`synthesis.spherical.sr_links`.
    """
    task = _task(screws, "screws", (4,))
    scr = _screws(screws, "screws")
    psi = number(azimuth, "azimuth", unit_="rad")
    F = _frame_arg(frame, scr)
    tol = number(tol, "tol", positive=True)
    out = []
    for base in sr_links(scr, psi, frame=F, tol=tol):
        for a, b in _directions4(base.sphere_rotations):
            link = _u_link(base, "UR", a, b, task, base.parameters)
            if link.residual <= tol:
                out.append(link)
    return out


def uh_links(screws, *, pitch: float, azimuth: float, frame=None,
             tol: float = 1e-9) -> list[BinaryLink]:
    """Every UH link (universal joint in the ground, helical joint of given pitch in the
    body) through four positions at the given free parameter found by
    :func:`synthesis.spherical.sh_links` (its method and limits), each with every real
    U direction pair (:func:`u_directions`).

    Parameters
    ----------
    screws : sequence of three Screw
        S₁₂, S₁₃, S₁₄ (each must rotate).
    pitch : float
        Slide per radian of the helical joint (length / rad); 0 gives the UR links.
    azimuth : float
        Azimuth (rad) of the body's helical axis direction in position 1.
    frame : array_like (3, 3), optional
        Columns e1, e2, e3 replacing the task's reference frame.
    tol : float
        Largest pose error accepted.

    Returns
    -------
    list of BinaryLink
        Types ``"UH"`` (``"UR"`` for pitch 0), fields as :func:`ur_links`.

    Raises
    ------
    SynthesisError
        As :func:`synthesis.spherical.sh_links`.
    """
    task = _task(screws, "screws", (4,))
    scr = _screws(screws, "screws")
    p = number(pitch, "pitch", unit_="length/rad")
    psi = number(azimuth, "azimuth", unit_="rad")
    F = _frame_arg(frame, scr)
    tol = number(tol, "tol", positive=True)
    out = []
    for base in sh_links(scr, p, psi, frame=F, tol=tol):
        for a, b in _directions4(base.sphere_rotations):
            link = _u_link(base, "U" + base.types[1], a, b, task, base.parameters)
            if link.residual <= tol:
                out.append(link)
    return out


def uc_links(screws, *, centre, azimuth: float, frame=None,
             tol: float = 1e-9) -> list[BinaryLink]:
    """Every UC link (universal joint in the ground, cylindrical joint in the body) through
    four positions with its centre and the azimuth of its cylinder axis chosen (4 of the
    link's 10 parameters; through four positions 4 are free).

    The body's cylinder axis W keeps its distance from the centre O in every position:
    W is equidistant from O and the points T_j⁻¹ O, so their projections on a plane
    ⊥ w are concyclic, ``det [[2 (P_k − P_1), −c_k(w)] (k = 2…4); [w, 0]] = 0`` with
    ``c_k = |Π P_k|² − |Π P_1|²`` (Π the projection ⊥ w): a cubic form in w, solved on
    the great circle of ``azimuth``; W passes through the circle's centre.  The link's
    rotations L_j carry (w, foot of O) to their images, and every real U direction pair
    with ``aᵀ L_j b = 0`` (:func:`u_directions`) gives a link.

    Parameters
    ----------
    screws : sequence of three Screw
        S₁₂, S₁₃, S₁₄.
    centre : array_like, shape (3,)
        The U joint's centre O (length; a free parameter).
    azimuth : float
        Azimuth (rad) of the cylinder axis direction (body, position 1) in the task's
        frame.
    frame : array_like (3, 3), optional
        Columns e1, e2, e3 replacing the task's reference frame.
    tol : float
        Largest pose error accepted.

    Returns
    -------
    list of BinaryLink
        Types ``"UC"``: ``fixed_axis`` the first axis through the centre, ``cross_axis``,
        ``fixed_angles`` / ``cross_angles``, ``moving_axis`` the cylinder axis in position 1
        (point: the foot of the perpendicular from the centre), ``moving_angles`` and
        ``moving_slides``; ``parameters`` ``{"centre", "azimuth", "elevation"}``.

    Raises
    ------
    SynthesisError
        Bad input (naming it), coincident positions, or a degenerate circle.
    """
    task = _task(screws, "screws", (4,))
    scr = _screws(screws, "screws")
    O = vec3(centre, "centre")
    psi = number(azimuth, "azimuth", unit_="rad")
    F = _frame_arg(frame, scr)
    tol = number(tol, "tol", positive=True)
    Ln, c0 = task.L, task.c
    On = (O - c0) / Ln
    Ti = np.linalg.inv(task.Tn)
    P = Ti[:, :3, :3] @ On + Ti[:, :3, 3]                       # O seen from the body (4, 3)
    D = P[1:] - P[0]
    n2 = np.sum(P * P, -1)

    def f(u):
        M = np.zeros(u.shape[:1] + (4, 4))
        M[:, :3, :3] = 2 * D
        pw = u @ P.T                                            # (N, 4)
        M[:, :3, 3] = -((n2[1:] - n2[0]) * np.sum(u * u, -1)[:, None]
                        - (pw[:, 1:] ** 2 - pw[:, :1] ** 2))
        M[:, 3, :3] = u
        return np.linalg.det(M)
    a0, b0 = _circle(F, psi)
    bt, scale = _trig_roots(f, a0, b0, 3, 8)
    if scale == 0:
        raise SynthesisError("centre, azimuth: degenerate: every direction of this circle "
                             "is admissible (the centre's positions are degenerate)")
    out = []
    n = len(task.T)
    for beta in bt:
        w = np.cos(beta) * a0 + np.sin(beta) * b0
        pw = P @ w
        c = (n2[1:] - n2[0]) - (pw[1:] ** 2 - pw[0] ** 2)
        A = np.vstack([2 * D, w])
        sv = np.linalg.svd(A, compute_uv=False)
        if sv[-1] < 1e-10 * sv[0]:
            continue
        X = np.linalg.lstsq(A, np.r_[c, 0.0], rcond=None)[0]
        foot = X + (On @ w) * w                                 # foot of O on W (position 1)
        u2 = foot - On
        if np.linalg.norm(u2) < 1e-9:
            continue                                            # W through the centre
        u2 /= np.linalg.norm(u2)
        R, t = task.Tn[:, :3, :3], task.Tn[:, :3, 3]
        wj = R @ w
        # foot of O on T_j W: T_j (foot of T_j⁻¹ O on W)
        fb = X + (P @ w)[:, None] * w                           # feet of P_j on W (4, 3)
        fj = np.einsum("nij,nj->ni", R, fb) + t
        vj = fj - On
        vj /= np.linalg.norm(vj, axis=1, keepdims=True)
        Fr = np.stack([wj, vj, _cross(wj, vj)], -1)          # (4, 3, 3)
        F0 = np.stack([w, u2, _cross(w, u2)], -1)
        Lr = Fr @ F0.T
        M = np.swapaxes(Lr, -1, -2) @ R                         # body relative to link
        phi = _signed_angle(np.broadcast_to(u2, (n, 3)), M @ u2, w)
        # body pose relative to the link: x ↦ L⁻¹ (T x − O) + O; slide of the foot along w
        Tf = np.einsum("nij,j->ni", R, foot) + t
        sl = np.einsum("nij,nj->ni", np.swapaxes(Lr, -1, -2), Tf - On) + On - foot
        s_j = sl @ w
        Lw = Line(w, foot * Ln + c0)
        base = BinaryLink("SC", Line._exact(w.copy(), O.copy()), Lw, np.nan, np.nan,
                          np.zeros(n), np.zeros(n), phi, s_j * Ln, 0.0,
                          {"centre": O.copy(), "azimuth": psi, "elevation": float(beta)},
                          sphere_rotations=Lr)
        for a, b in _directions4(Lr):
            link = _u_link(base, "UC", a, b, task, base.parameters)
            if link.residual <= tol:
                out.append(link)
    return out
