"""Binary links with a cylindrical joint (RC, CR, HC, CH, CC) through finite positions, by
the screw triangle (Tsai & Roth 1972): the spherical part fixes the directions, the
dual part is then linear in the axis points and the free slides (see
:mod:`synthesis.binary`).

Counting (directions: a 2-parameter family of (g, w) through three positions, one
through four, finitely many through five; translations: three equations per later
position, unknowns two per axis point and one per free slide and position):

==========  =========  ===========================================================
link        positions  free parameters (explicit arguments)
==========  =========  ===========================================================
RC, HC      3          ``fixed_direction``: the fixed axis direction (2 dof, unit vector)
CR, CH      3          ``fixed_direction`` (2 dof)
CC          3          ``fixed_axis``: the whole fixed axis (direction and point: 4 dof)
CC          4          ``azimuth`` (rad: the admissible fixed directions in that half-plane
                       through z, up to three, or ``fixed_direction`` on the admissible
                       curve, see :func:`cc_direction_residual`) and ``fixed_point``
                       (length: the fixed axis of the 1-parameter parallel family nearest it)
CC          5          none: every solution is returned (the directions are the 6
                       complex eigenpairs of a 6 × 6 pencil, :func:`cc5_directions`)
==========  =========  ===========================================================
"""
from __future__ import annotations

import numpy as np

from .binary import (BinaryLink, _angles, _check_rotations, _residuals, _same, _system, _task,
                     _unfinished)
from .errors import SynthesisError
from .rmep import solve_bilinear
from .screw import Line
from .validate import integer, line as _line, number, screw as _screw, unit, vec3

__all__ = ["rc_links", "cr_links", "fixed_direction_links", "cc_links", "cc_direction_residual",
           "cc_directions"]


def _solve_square(task, kinds, pitches, g, *, fixed_point=None, what: str):
    """The unique link for a given fixed direction ``g`` (3 positions, one C joint, or CC
    with the fixed point given): w from the constant-angle condition, then 6 linear
    equations in 6 unknowns (:func:`_square_links` for one direction, raising)."""
    out = _square_links(task, kinds, pitches, g[None], fixed_point=fixed_point, what=what)[0]
    if isinstance(out, SynthesisError):
        raise out
    return out


def _square_links(task, kinds, pitches, G, *, fixed_point=None, what: str):
    """The unique link of each fixed direction ``G (m, 3)`` (unit) through three positions
    (one C joint, or CC with ``fixed_point`` given), all solved in one batch: a list of m
    BinaryLink or SynthesisError (why that direction gives no link)."""
    R = task.R
    a = np.einsum("kji,nj->nki", R - np.eye(3), G)                  # (m, 2, 3)
    w = np.cross(a[:, 0], a[:, 1])
    nw = np.linalg.norm(w, axis=1)
    out = [None] * len(G)
    ok = []
    for n in range(len(G)):
        if nw[n] < 1e-9:
            out[n] = SynthesisError(
                f"fixed_direction: degenerate: the moving axis direction is not determined by "
                f"{np.round(G[n], 6)} (it is perpendicular to both relative rotations' image "
                "directions, e.g. along a screw axis)")
        else:
            ok.append(n)
    if ok:
        links = _direction_links(task, kinds, pitches, G[ok], w[ok] / nw[ok, None],
                                 fixed_point=fixed_point, what=what)
        for n, lk in zip(ok, links):
            out[n] = lk
    return out


def _from_directions(task, kinds, pitches, g, w, *, fixed_point=None, near_point=None,
                     what: str, params=None):
    """Links for direction pairs ``g, w (N, 3)`` (:func:`_direction_links`), raising the
    first pair's error."""
    out = _direction_links(task, kinds, pitches, g, w, fixed_point=fixed_point,
                           near_point=near_point, what=what, params=params)
    for lk in out:
        if isinstance(lk, SynthesisError):
            raise lk
    return out


def _direction_links(task, kinds, pitches, g, w, *, fixed_point=None, near_point=None,
                     what: str, params=None):
    """Links for direction pairs ``g, w (N, 3)`` that satisfy the constant-angle condition
    at every position, by solving the (square) translation equations; with ``near_point``
    (normalised) the equations have a one-parameter family of solutions and the fixed
    axis nearest that point is taken.  A list of N BinaryLink or SynthesisError (why that
    pair gives no link: parallel axes or singular translation equations); the links'
    residuals are computed in one batch."""
    R, t = task.R, task.t
    th, ph, Gm, sin_gw = _angles(g, w, R)
    fp = None if fixed_point is None else fixed_point
    A, rhs, (e1, e2, f1, f2) = _system(g, w, th, ph, Gm, t, kinds, pitches, fp)
    out = []
    for n in range(len(g)):
        if sin_gw[n] < 1e-9:
            out.append(SynthesisError(f"{what}: degenerate: the fixed and moving axes are "
                                      "parallel (the link's axes are then not determined)"))
            continue
        _, s, Vt = np.linalg.svd(A[n])
        free = A[n].shape[1] - A[n].shape[0] if near_point is not None else 0
        if A[n].shape[0] < A[n].shape[1] - free or s[-1] < 1e-9 * s[0]:
            out.append(SynthesisError(
                f"{what}: degenerate: the translation equations are singular (condition "
                f"{s[0] / max(s[-1], 1e-300):.1e}); a relative screw is a pure rotation about "
                "an axis meeting the joint axes, or the axes are parallel"))
            continue
        x = np.linalg.lstsq(A[n], rhs[n], rcond=None)[0]
        if free:
            # the family x + s·v (v the null vector): the fixed axis nearest near_point
            v = Vt[-1]
            q = np.array([near_point @ e1[n], near_point @ e2[n]])
            vv = v[:2] @ v[:2]
            if vv > 1e-12:
                x = x + v * ((q - x[:2]) @ v[:2]) / vv
        m = th.shape[1]
        k = 0
        if fp is None:
            cg = x[0] * e1[n] + x[1] * e2[n]
            k = 2
        else:
            cg = fp
        cw = x[k] * f1[n] + x[k + 1] * f2[n]
        k += 2
        if kinds[0] == "C":
            a, k = x[k:k + m], k + m
        else:
            a = pitches[0] * th[n]
        b = x[k:k + m] if kinds[1] == "C" else pitches[1] * ph[n]
        out.append(_unfinished(task, kinds, pitches, g[n], cg, w[n], cw, th[n], a, ph[n], b,
                               params or {}))
    _residuals([lk for lk in out if not isinstance(lk, SynthesisError)], task)
    return out


def _types(kind_fixed, kind_moving, pf, pm):
    k = (("R" if pf == 0 else "H") if kind_fixed != "C" else "C",
         ("R" if pm == 0 else "H") if kind_moving != "C" else "C")
    return "".join(k)


def rc_links(s12, s13, fixed_direction, *, fixed_pitch: float = 0.0) -> list[BinaryLink]:
    """The RC (or HC) link through three positions for a chosen fixed-axis direction.

    The RC links through three positions form a two-parameter family: any fixed-axis
    direction g (where the moving axis is determined) gives exactly one link.

    Parameters
    ----------
    s12, s13 : Screw
        Displacements from position 1 to positions 2 and 3.
    fixed_direction : array_like, shape (3,)
        Unit direction of the fixed (revolute or helical) axis: the free parameters
        (two, dimensionless); g and −g give the same link.
    fixed_pitch : float
        Pitch of the fixed joint (length / rad): 0 for R (default), else H.

    Returns
    -------
    list of one BinaryLink (types ``"RC"`` or ``"HC"``), ``parameters`` holding the
    direction.

    Raises
    ------
    SynthesisError
        Bad input (naming it), coincident positions, a pure-translation relative
        screw, or a direction for which the link degenerates (named).
    """
    return _one(fixed_direction_links("RC", s12, s13, [fixed_direction], fixed_pitch))


def cr_links(s12, s13, fixed_direction, *, moving_pitch: float = 0.0) -> list[BinaryLink]:
    """The CR (or CH) link through three positions for a chosen fixed-axis direction.

    Parameters
    ----------
    s12, s13 : Screw
        Displacements from position 1 to positions 2 and 3.
    fixed_direction : array_like, shape (3,)
        Unit direction of the fixed (cylindrical) axis: the two free parameters.
    moving_pitch : float
        Pitch of the moving joint (length / rad): 0 for R (default), else H.

    Returns
    -------
    list of one BinaryLink (``"CR"`` or ``"CH"``).

    Raises
    ------
    SynthesisError
        As :func:`rc_links`.
    """
    return _one(fixed_direction_links("CR", s12, s13, [fixed_direction], moving_pitch))


def _one(results):
    """The one direction's result of :func:`fixed_direction_links`, raising its error."""
    if isinstance(results[0], SynthesisError):
        raise results[0]
    return results[0]


def fixed_direction_links(kinds: str, s12, s13, fixed_directions, pitch: float = 0.0) -> list:
    """:func:`rc_links` (``kinds`` ``"RC"``) or :func:`cr_links` (``"CR"``) for several
    fixed-axis directions at once: one task, one batched solve.

    Parameters
    ----------
    kinds : str
        ``"RC"`` (the R or H joint fixed) or ``"CR"`` (the C joint fixed).
    s12, s13 : Screw
        Displacements from position 1 to positions 2 and 3.
    fixed_directions : array_like, shape (m, 3)
        Unit directions of the fixed axis.
    pitch : float
        Pitch of the R/H joint (length / rad): 0 for R, else H.

    Returns
    -------
    list of m entries: ``[BinaryLink]`` (as rc_links / cr_links return) or the
    SynthesisError of that direction.

    Raises
    ------
    SynthesisError
        Bad input (naming it), coincident positions or a pure-translation relative screw
        (the task's errors, common to every direction).
    """
    if kinds not in ("RC", "CR"):
        raise SynthesisError(f"kinds: expected 'RC' or 'CR', got {kinds!r}")
    task = _task([_screw(s12, "s12"), _screw(s13, "s13")], "s12, s13", (3,))
    out, G = [], []
    for d in fixed_directions:
        try:
            G.append(unit(d, "fixed_direction"))
            out.append(None)
        except SynthesisError as e:
            out.append(e)
    if kinds == "RC":
        p = number(pitch, "fixed_pitch", unit_="length/rad")
        types, pn = _types("R", "C", p, 0), (p / task.L, 0.0)
    else:
        p = number(pitch, "moving_pitch", unit_="length/rad")
        types, pn = _types("C", "R", 0, p), (0.0, p / task.L)
    _check_rotations(task, "s12, s13")
    ok = [n for n, e in enumerate(out) if e is None]
    links = _square_links(task, types, pn, np.array(G).reshape(-1, 3),
                          what="fixed_direction") if G else []
    for n, g, lk in zip(ok, G, links):
        if not isinstance(lk, SynthesisError):
            lk.parameters = {"fixed_direction": g.copy()}
            lk = [lk]
        out[n] = lk
    return out


def cc_direction_residual(screws, fixed_direction) -> float:
    """How far ``fixed_direction`` is from admitting a CC (or any R/H/C) link through the
    positions: the smallest singular value of the rows ``gᵀ (R_j − I)`` (j = 2…n), which
    vanishes when one moving-axis direction keeps a constant angle with g in every
    position (dimensionless; always 0 for three positions)."""
    task = _task(screws, "screws", (3, 4, 5))
    g = unit(fixed_direction, "fixed_direction")
    B = np.einsum("mji,j->mi", task.R - np.eye(3), g)
    return float(np.linalg.svd(B, compute_uv=False)[-1]) if len(B) >= 3 else 0.0


def cc_directions(screws, azimuth: float) -> np.ndarray:
    """The fixed-axis directions admissible for CC (or RC, HC, ...) links through four
    positions whose azimuth about z is ``azimuth``.

    Through four positions a moving direction w with ``gᵀ (R_j − I) w = 0`` (j = 2, 3, 4)
    exists only where ``det [(R_j − I)ᵀ g] = 0``, a cubic cone of directions g.  On the
    half great circle ``g(β) = cos β z + sin β (cos ψ x + sin ψ y)``, β ∈ [0, π), the
    determinant is a homogeneous cubic in (cos β, sin β): its real roots are the
    admissible directions (one to three).

    Parameters
    ----------
    screws : sequence of three Screw
        S_12, S_13, S_14.
    azimuth : float
        ψ (rad): the half-plane through the z axis the direction is taken in.

    Returns
    -------
    numpy.ndarray, shape (k, 3)
        Unit directions, k ≤ 3 (ordered by β).
    """
    task = _task(screws, "screws", (4,))
    psi = number(azimuth, "azimuth", unit_="rad")
    return _cubic_directions(task, psi)


def _cubic_directions(task, psi):
    a = np.array([0.0, 0.0, 1.0])
    b = np.array([np.cos(psi), np.sin(psi), 0.0])
    M = task.R - np.eye(3)

    def det(x, y):
        g = x * a + y * b
        return np.linalg.det(np.einsum("mji,j->mi", M, g))
    xs = np.array([[1, 0], [0, 1], [1, 1], [1, -1]], float)
    V = np.array([[x ** 3, x * x * y, x * y * y, y ** 3] for x, y in xs])
    c = np.linalg.solve(V, [det(x, y) for x, y in xs])           # c0 x³ + c1 x²y + c2 xy² + c3 y³
    scale = np.abs(c).max()
    if scale == 0:
        raise SynthesisError("azimuth: degenerate: every direction of this half-plane is "
                             "admissible (the direction conditions vanish identically)")
    betas = []
    if abs(c[3]) <= 1e-12 * scale:                               # root at x = 0 (β = π/2)
        betas.append(np.pi / 2)
    for t in np.roots(c[::-1] if abs(c[3]) > 1e-12 * scale else c[2::-1]):
        if abs(t.imag) <= 1e-9 * max(1.0, abs(t)):
            betas.append(float(np.arctan(t.real)) % np.pi)
    betas = sorted(set(np.round(betas, 15)))
    out = []
    for beta in betas:                                          # polish on the circle
        for _ in range(3):
            h = 1e-7
            f0 = det(np.cos(beta), np.sin(beta))
            d = (det(np.cos(beta + h), np.sin(beta + h)) - det(np.cos(beta - h), np.sin(beta - h))) / (2 * h)
            if d != 0:
                beta -= f0 / d
        out.append(np.cos(beta) * a + np.sin(beta) * b)
    return np.array(out).reshape(-1, 3)


def cc_links(screws, *, fixed_axis: Line | None = None, fixed_direction=None, fixed_point=None,
             azimuth: float | None = None, samples: int = 20000,
             tol: float = 1e-9) -> list[BinaryLink]:
    """CC links (two cylindrical joints) through three, four or five positions.

    Parameters
    ----------
    screws : sequence of 2, 3 or 4 Screw
        S_12 … S_1n for n = 3, 4, 5 positions.
    fixed_axis : Line, optional
        Three positions: the fixed axis (direction and point, 4 free parameters,
        length of the task for the point).  Required then, else not allowed.
    fixed_direction : array_like (3,), optional
        Four positions: the fixed axis direction; it must lie on the one-parameter
        curve of admissible directions (:func:`cc_direction_residual` ≤ 1e-9).
    azimuth : float, optional
        Four positions, instead of ``fixed_direction``: ψ (rad); every admissible
        direction in the half-plane of azimuth ψ about z (:func:`cc_directions`)
        gives a link.
    fixed_point : array_like (3,), optional
        Four positions (length): for a given direction the admissible fixed axes are a
        one-parameter family of parallel lines (the second free parameter); the one
        nearest this point is taken (a point of an admissible axis, e.g. the generating
        link's, gives that axis exactly).
    samples : int
        Not used any more (≥ 100 is still checked, so existing calls keep working): the
        five-position directions are solved exactly, as the eigenpairs of a 6 × 6
        generalised eigenproblem, not sampled.
    tol : float
        Largest pose error accepted (rad, or translation relative to the task's reach).

    Returns
    -------
    list of BinaryLink (``"CC"``): all links through five positions; the one link for
    the given free parameters through three or four.

    Raises
    ------
    SynthesisError
        Bad or missing free parameters (named), coincident positions, pure-translation
        relative screws, or degenerate choices.
    """
    task = _task(screws, "screws", (3, 4, 5))
    n = len(task.T)
    tol = number(tol, "tol", positive=True)
    _check_rotations(task, "screws")
    pit = (0.0, 0.0)
    if n == 3:
        if fixed_direction is not None or fixed_point is not None:
            raise SynthesisError("fixed_direction, fixed_point: for three positions give the whole "
                                 "fixed_axis (a Line) instead")
        if fixed_axis is None:
            raise SynthesisError("fixed_axis: required for three positions (CC links through "
                                 "three positions form a 4-parameter family: the fixed axis)")
        ax = _line(fixed_axis, "fixed_axis")
        p = (ax.point - task.c) / task.L
        link = _solve_square(task, "CC", pit, ax.direction, fixed_point=p, what="fixed_axis")
        link.parameters = {"fixed_axis": ax}
        return [link]
    if fixed_axis is not None:
        raise SynthesisError("fixed_axis: only for three positions")
    if n == 4:
        if (fixed_direction is None) == (azimuth is None) or fixed_point is None:
            raise SynthesisError("fixed_direction or azimuth, fixed_point: for four positions give "
                                 "fixed_point and one of fixed_direction (on the admissible "
                                 "curve) or azimuth (rad)")
        P = vec3(fixed_point, "fixed_point")
        if azimuth is not None:
            psi = number(azimuth, "azimuth", unit_="rad")
            G = _cubic_directions(task, psi)
            name = "azimuth"
        else:
            G = unit(fixed_direction, "fixed_direction")[None]
            name = "fixed_direction"
        out = []
        for g in G:
            B = np.einsum("mji,j->mi", task.R - np.eye(3), g)
            _, s, Vt = np.linalg.svd(B)
            if s[-1] > 1e-9:
                raise SynthesisError(f"fixed_direction: not on the curve of admissible directions "
                                     f"for four positions (residual {s[-1]:.1e} > 1e-9; see "
                                     "cc_direction_residual)")
            if s[-2] < 1e-9:
                raise SynthesisError(f"{name}: degenerate: the moving axis direction is not "
                                     "determined (rank of the direction conditions below 2)")
            link = _from_directions(task, "CC", pit, g[None], Vt[-1][None],
                                    near_point=(P - task.c) / task.L,
                                    what=f"{name}, fixed_point")[0]
            link.parameters = {name: psi if azimuth is not None else g.copy(),
                               "fixed_point": P.copy()}
            out.append(link)
        return out
    # five positions: the directions are isolated
    if fixed_direction is not None or fixed_point is not None or azimuth is not None:
        raise SynthesisError("fixed_direction, fixed_point, azimuth: not free for five positions")
    integer(samples, "samples", low=100)            # no longer used (see the parameter's notes)
    return _cc5(task, tol)[0]


def cc5_directions(task):
    """Every direction pair (g, w) of a CC link through five positions (normalised task).

    The directions satisfy ``gᵀ (R_j − I) w = 0`` for j = 2…5: four bilinear equations,
    i.e. the 4 × 3 matrix with rows ``gᵀ (R_j − I)`` drops rank (the spherical
    five-orientation Burmester problem).  Generically it has exactly 6 solutions over
    the complex numbers (Murray & McCarthy); all of them are the eigenpairs of one 6 × 6
    generalised eigenproblem (:func:`synthesis.rmep.solve_bilinear`), so none is missed.

    Returns
    -------
    g, w : numpy.ndarray, complex, shape (6, 3)
        Fixed and moving directions (each scaled so its largest entry is 1).
    real : numpy.ndarray of bool, shape (6,)
    residual : numpy.ndarray, shape (6,)
        ``|gᵀ (R_j − I) w|`` after polishing, for the scaled vectors.
    """
    A = np.transpose(task.R - np.eye(3), (1, 0, 2))          # A_i[j, c] = (R_j − I)[i, c]
    sol = solve_bilinear(A)
    return sol.lam, sol.x, sol.real, sol.residual


def _cc5(task, tol):
    """All real CC links through five positions: every real direction pair of
    :func:`cc5_directions`, then the moments from the (square) translation equations.

    Returns the links and a dict: ``complex`` (direction pairs found over the complex
    numbers that satisfy the equations), ``real`` (of them real), ``rejected`` (real pairs
    that give no CC link: parallel axes or singular translation equations, or a pose
    error above ``tol``), ``unsolved`` (eigenpairs whose equation residual stayed above
    1e-9 after polishing)."""
    g, w, real, res = cc5_directions(task)
    good = res <= 1e-9
    g = g[real & good].real
    w = w[real & good].real
    g /= np.linalg.norm(g, axis=1, keepdims=True)
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    out: list[BinaryLink] = []
    rejected = 0
    for link in _direction_links(task, "CC", (0.0, 0.0), g, w, what="screws") if len(g) else []:
        if isinstance(link, SynthesisError) or link.residual > tol:
            rejected += 1   # parallel axes or singular translation equations: no CC link
        elif not any(_same(link, o, task.L) for o in out):
            out.append(link)
    return out, {"complex": int(good.sum()), "real": int((real & good).sum()),
                 "rejected": rejected, "unsolved": int((~good).sum())}
