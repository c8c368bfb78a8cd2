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

Batching: the public functions solve one subset of positions at one choice of the free
parameters; the dyad families (:mod:`synthesis.hooke_families`) solve every subset and
every choice of a task through the same core (``_u_grids``): the base (S-ended) links of
each subset at all azimuths / centres, then the U directions of all their rotation sets at
once (:func:`u_directions`' resultant and root finding as batched companion-matrix
eigenvalues, the Gauss–Newton polish on all candidates together) and all the U links'
residuals in one pose comparison.  The cross axis b is returned with its largest component
positive (b and −b are the same joint; the null-space solve's own sign is round-off).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .binary import BinaryLink, _cross, _rot, _signed_angle, _task
from .errors import SynthesisError
from .screw import Line
from .spherical import _frame_arg, _sphere_links, _subtasks, _trig_roots_batch, sh_links
from .validate import array, number, screws as _screws, vec3
from .verify import pose_errors

__all__ = ["up_links", "ur_links", "uh_links", "uc_links", "u_directions"]

# ------------------------------------------------------------------ U directions
#: two generic affine charts ``a = x E0 + y E1 + E2`` of the direction sphere (fixed, well
#: away from each other): (2, 3, 3), columns E0, E1, E2
_E = np.linalg.qr(np.array([[0.31, -0.72, 0.62], [0.83, 0.18, -0.53], [0.46, 0.67, 0.58]]))[0]
_CHARTS = np.stack([_E, _E[:, [2, 0, 1]]])
#: the cubics are fitted in each chart from 30 fixed sample points (x, y): the monomials
#: x^i y^j (i + j ≤ 3), their least-squares fit operator (10, 30) and the chart points
_MONO = np.array([(i, j) for i in range(4) for j in range(4 - i)])
_SAMPLES = np.random.default_rng(7).uniform(-1, 1, (30, 2))
_FIT = np.linalg.pinv(_SAMPLES[:, :1] ** _MONO[:, 0] * _SAMPLES[:, 1:] ** _MONO[:, 1])
_CHART_POINTS = (_SAMPLES[None, :, :1] * _CHARTS[:, None, :, 0]
                 + _SAMPLES[None, :, 1:] * _CHARTS[:, None, :, 1] + _CHARTS[:, None, :, 2])
#: the resultant in y is sampled at K roots of unity (its degree is 9 < K)
_K_RES = 16
_Y_SAMPLES = np.exp(2j * np.pi * np.arange(_K_RES) / _K_RES)


def _poly_roots(C, start) -> np.ndarray:
    """Roots of the polynomials ``C[i, start[i]:]`` (coefficients highest first; further
    leading zeros skipped), as :func:`numpy.roots`: the companion matrices of each degree
    in one eigenvalue call (real ones in real arithmetic).

    Parameters
    ----------
    C : numpy.ndarray, shape (k, d + 1)
    start : numpy.ndarray of int, shape (k,)

    Returns
    -------
    numpy.ndarray, complex, shape (k, d)
        Row i's roots first, NaN after them (rows of lower degree).
    """
    k, d1 = C.shape
    out = np.full((k, d1 - 1), np.nan, complex)
    lead = (C != 0) & (np.arange(d1) >= np.asarray(start)[:, None])
    first = np.where(lead.any(1), np.argmax(lead, 1), d1)
    real = (np.imag(C) == 0).all(1)                             # real rows: real arithmetic
    for s in np.unique(first[first < d1 - 1]):                  # one pass per degree
        for re in (True, False):
            rows = np.flatnonzero((first == s) & (real == re))
            if not len(rows):
                continue
            p = C[rows, s:].real if re else C[rows, s:]
            deg = d1 - 1 - s
            A = np.zeros((len(rows), deg, deg), p.dtype)
            A[:, 0] = -p[:, 1:] / p[:, :1]
            A[:, np.arange(1, deg), np.arange(deg - 1)] = 1
            out[rows, :deg] = np.linalg.eigvals(A)
    return out


def _chart_candidates(L):
    """Candidate first axes a of the four rotations ``L (m, 4, 3, 3)``: the real chart
    solutions of the two cubics (their resultant in y, degree 9, then the common x), both
    charts; returns unit vectors ``(m, 2, 9, 3)`` and their validity ``(m, 2, 9)``."""
    m = len(L)
    A = _CHART_POINTS                                           # (2, 30, 3)
    bb = _cross(A[None], A[None] @ L[:, None, 1])               # a × L₂ᵀ a (m, 2, 30, 3)
    cub = np.stack([np.sum((A[None] @ L[:, None, j]) * bb, -1) for j in (2, 3)], -2)
    cf = cub @ _FIT.T                                           # (m, 2, 2, 10)
    W = np.zeros((m, 2, 2, 4, 4))              # W[.., 3 − i, j]: coefficient of x^i y^j
    W[..., 3 - _MONO[:, 0], _MONO[:, 1]] = cf
    Wt = np.swapaxes(W, -1, -2)

    def xpoly(y):          # (m, 2, K) → (m, 2, 2, K, 4): coefficients in x, highest first
        return (y[..., None] ** np.arange(4))[:, :, None] @ Wt
    pq = xpoly(np.broadcast_to(_Y_SAMPLES, (m, 2, _K_RES)))
    S = np.zeros((m, 2, _K_RES, 6, 6), complex)
    for r in range(3):
        S[..., r, r:r + 4] = pq[:, :, 0]
        S[..., r + 3, r:r + 4] = pq[:, :, 1]
    c = np.fft.fft(np.linalg.det(S), axis=-1) / _K_RES           # c[k]: coefficient of y^k
    # complex arithmetic for the resultant's roots (as numpy.roots of these coefficients):
    # their order, the order of the links, is LAPACK's for the complex companion matrix
    coef = c[..., :10][..., ::-1].reshape(-1, 10)
    scale = np.abs(coef).max(1)
    has = scale > 0
    coef = np.where(has[:, None], coef / np.where(has, scale, 1.0)[:, None], 0)
    big = np.abs(coef) > 1e-12
    start = np.where(has & big.any(1), np.argmax(big, 1), 10)
    y = _poly_roots(coef, start).reshape(m, 2, 9)
    pq = xpoly(np.nan_to_num(y))
    p, q = pq[:, :, 0], pq[:, :, 1]
    lead = np.abs(p[..., 0]) > 1e-12 * np.abs(p).max(-1)
    # the common root x of p and q at each y; skipped where a = x E0 + y E1 + E2 cannot
    # pass the realness test below whatever root x of p is taken: |Im a| ≥ |Im y| / √3
    # and |a| ≤ (|x|² + |y|² + 1)^½ with |x| under the Cauchy bound of p
    st = np.where(lead, 0, 1)[..., None]
    c0 = np.abs(np.take_along_axis(p, st, -1))
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = 1 + np.where(np.arange(4) > st, np.abs(p), 0).max(-1) / c0[..., 0]
        hopeless = np.abs(y.imag) > 2e-5 * np.sqrt(3 * (bound ** 2 + np.abs(y) ** 2 + 1))
    todo = np.isfinite(y) & ~hopeless
    xr = np.full((m, 2, 9, 3), np.nan, complex)
    xr[todo] = _poly_roots(p[todo], st[todo][:, 0])
    v = np.zeros_like(xr)
    for j in range(4):                                          # Horner (numpy.polyval)
        v = v * xr + q[..., j:j + 1]
    v = np.where(np.isnan(xr), np.inf, np.abs(v))
    x = np.take_along_axis(xr, np.argmin(v, -1)[..., None], -1)[..., 0]
    a = (x[..., None] * _CHARTS[None, :, None, :, 0] + y[..., None] * _CHARTS[None, :, None, :, 1]
         + _CHARTS[None, :, None, :, 2])
    with np.errstate(invalid="ignore"):
        ok = ~np.isnan(a).any(-1) & ~(np.abs(a.imag).max(-1) > 1e-5 * np.abs(a).max(-1))
    ar = np.where(ok[..., None], a.real, 1.0)
    return ar / np.linalg.norm(ar, axis=-1, keepdims=True), ok


def _rows(a, L):
    """``L_jᵀ a`` ``(..., n, 3)`` for ``a (..., 3)``, ``L (..., n, 3, 3)``."""
    return (a[..., None, None, :] @ L)[..., 0, :]


def _null_b(a, L):
    """Cross axes b ⊥ every ``L_jᵀ a`` for ``a (k, 3)``, ``L (k, n, 3, 3)``: ``b (k, 3)``
    and whether it is determined (rank of the rows ≥ 2) ``(k,)``."""
    _, s, Vt = np.linalg.svd(_rows(a, L))
    return Vt[:, -1], ~(s[:, 1] < 1e-8 * s[:, 0])


def _oriented(b):
    """Unit directions ``b (k, 3)`` turned so that the largest component (the first of
    equal ones) is positive, the table's rule for axes: b and −b are the same cross axis,
    and the sign the null-space solve returns is round-off (it flips under 1e-16 changes
    of a, the null space being exact)."""
    i = np.argmax(np.abs(b) - np.array([0.0, 1e-12, 2e-12]), -1)
    return np.where((np.take_along_axis(b, i[:, None], -1) < 0), -b, b)


def _bilinear(a, L, b):
    """``aᵀ L_j b`` ``(k, n)``."""
    return np.sum(_rows(a, L) * b[:, None], -1)


def _polish(a, L, iters: int = 8):
    """Gauss–Newton on the bilinear equations for the unit ``a (k, 3)`` (b the null
    vector), each row until its equations are below 1e-15 (the rows still moving in one
    pass per step); returns a, b ``(k, 3)`` and whether b stayed determined ``(k,)``."""
    a = a.copy()
    live = np.ones(len(a), bool)
    idx = np.arange(len(a))                                     # rows still moving
    h = 1e-7
    for _ in range(iters):
        ai, Li = a[idx], L[idx]
        b, ok = _null_b(ai, Li)
        live[idx[~ok]] = False
        r = _bilinear(ai, Li, b)
        go = ok & ~(np.abs(r).max(1) < 1e-15)
        idx, ai, Li, b, r = idx[go], ai[go], Li[go], b[go], r[go]
        if not len(idx):
            break
        ref = np.where((np.abs(ai[:, 0]) < 0.9)[:, None], [1.0, 0, 0], [0, 1.0, 0])
        e1 = _cross(ai, ref)
        e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
        e = np.stack([e1, _cross(ai, e1)], 1)                   # (k, 2, 3)
        ap = ai[:, None] + h * e
        ap /= np.linalg.norm(ap, axis=-1, keepdims=True)
        bp, okp = _null_b(ap.reshape(-1, 3), np.repeat(Li, 2, axis=0))
        okp = okp.reshape(-1, 2).all(1)
        live[idx[~okp]] = False
        idx, ai, Li, b, r, e, ap = (v[okp] for v in (idx, ai, Li, b, r, e, ap))
        bp = bp.reshape(-1, 2, 3)[okp]
        if not len(idx):
            break
        bp = bp * np.sign(np.sum(bp * b[:, None], -1))[..., None]
        Jt = np.sum(_rows(ap, Li[:, None]) * bp[:, :, None], -1)   # (k, 2, n)
        J = (np.swapaxes(Jt, 1, 2) - r[..., None]) / h              # (k, n, 2)
        du = (np.linalg.pinv(J) @ -r[..., None])[..., 0]
        an = ai + np.sum(du[..., None] * e, 1)
        a[idx] = an / np.linalg.norm(an, axis=1, keepdims=True)
    b, ok = _null_b(a, L)
    return a, b, live & ok


def _directions(L):
    """Every real U direction pair of each rotation set ``L (m, 4, 3, 3)`` (L₁ = I), all
    sets in one pass: ``(owner (k,), a (k, 3), b (k, 3))``, ordered by owner, each owner's
    pairs in the order of :func:`u_directions`."""
    m = len(L)
    a, ok = _chart_candidates(L)
    a, ok = a.reshape(m, 18, 3), ok.reshape(m, 18)
    # drop the base points: the eigenvectors of L₂ᵀ (real: its axis)
    ok &= np.linalg.norm(_cross(a, np.einsum("mji,mcj->mci", L[:, 1], a)), axis=-1) >= 1e-6
    own, cand = np.nonzero(ok)
    b = np.zeros_like(a)
    if len(own):
        ap, bp, good = _polish(a[own, cand], L[own])
        good &= ~(np.abs(_bilinear(ap, L[own], bp)).max(1) > 1e-10)
        a[own, cand], b[own, cand], ok[own, cand] = ap, bp, good
    # duplicates (the same joint from both charts, or a and −a): the first one kept
    same = ((np.abs(np.abs(np.einsum("mik,mjk->mij", a, a)) - 1) < 1e-8)
            & (np.abs(np.abs(np.einsum("mik,mjk->mij", b, b)) - 1) < 1e-8)
            & ok[:, None, :] & np.tri(18, 18, -1, bool))
    ok &= ~same.any(-1)
    own, cand = np.nonzero(ok)
    return own, a[own, cand], _oriented(b[own, cand])


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
        joint, one sign is returned (b with its largest component positive).

    Method: with ``b ∝ a × L₂ᵀ a`` the conditions j = 3, 4 are two cubic forms in a;
    their resultant (in two affine charts, merged) is a degree-9 polynomial whose roots
    include the 3 eigenvectors of L₂ (base points, dropped); the rest are polished by
    Gauss–Newton on the four bilinear equations.  Many rotation sets are solved in one
    vectorised pass internally (all azimuths, centres and position subsets of a task).
    """
    L = array(link_rotations, "link_rotations", (4, 3, 3),
              what="four rotation matrices, the first the identity")
    if np.abs(np.swapaxes(L, 1, 2) @ L - np.eye(3)).max() > 1e-9 or np.any(np.linalg.det(L) < 0):
        raise SynthesisError("link_rotations: expected rotation matrices (orthonormal, "
                             "determinant +1)")
    if np.abs(L[0] - np.eye(3)).max() > 1e-9:
        raise SynthesisError("link_rotations: expected the identity as the first rotation (L₁ = I)")
    return _directions4(L)


def _directions4(L) -> np.ndarray:
    """:func:`u_directions` of checked rotations ``L (4, 3, 3)``: pairs (k, 2, 3)."""
    _, a, b = _directions(L[None])
    return np.stack([a, b], 1)


# ------------------------------------------------------------------ U links in batches
@dataclass
class _Bases:
    """Sphere-ended links (sphere centre in the ground) the U links of some sub-tasks are
    built on, in user coordinates, m of them.

    sub, group : (m,) int — the sub-task and the free-parameter choice each belongs to;
    L : (m, n, 3, 3) — the link's rotations; O : (m, 3) — the centre (length); md, mp :
    (m, 3) — the moving axis in position 1 (direction, point); mang, msl : (m, n) — its
    angles (rad) and slides (length); elevation : (m,) — rad; kind, pitch — the moving
    joint's letter and pitch.
    """

    sub: np.ndarray
    group: np.ndarray
    L: np.ndarray
    O: np.ndarray
    md: np.ndarray
    mp: np.ndarray
    mang: np.ndarray
    msl: np.ndarray
    elevation: np.ndarray
    kind: str
    pitch: float

    @classmethod
    def of(cls, links, sub, groups, n, kind, pitch):
        """From BinaryLink objects (S in the ground), their sub-tasks and groups."""
        if not links:
            z = np.zeros((0, 3))
            return cls(np.zeros(0, int), np.zeros(0, int), np.zeros((0, n, 3, 3)), z, z, z,
                       np.zeros((0, n)), np.zeros((0, n)), np.zeros(0), kind, pitch)
        return cls(np.asarray(sub, int), np.asarray(groups, int),
                   np.stack([lk.sphere_rotations for lk in links]),
                   np.stack([lk.fixed_axis.point for lk in links]),
                   np.stack([lk.moving_axis.direction for lk in links]),
                   np.stack([lk.moving_axis.point for lk in links]),
                   np.stack([lk.moving_angles for lk in links]),
                   np.stack([lk.moving_slides for lk in links]),
                   np.array([lk.parameters["elevation"] for lk in links], float), kind, pitch)

    @classmethod
    def of_sphere(cls, sl, n_groups, kind, pitch):
        """From the SR / SP links :class:`synthesis.spherical._SphereLinks` of sub-tasks
        × azimuths (block = sub-task · n_groups + azimuth index)."""
        rot = kind == "R"
        return cls(sl.block // n_groups, sl.block % n_groups, sl.rotations, sl.fixed_point,
                   sl.moving_dir, sl.moving_point,
                   sl.moving_values if rot else np.zeros_like(sl.moving_values),
                   np.zeros_like(sl.moving_values) if rot else sl.moving_values,
                   sl.elevation, kind, pitch)


@dataclass
class _ULinks:
    """U links (user coordinates), k of them, ordered by sub-task and group.

    bases : the links they are built on; base : (k,) int — index into ``bases``; a, b :
    (k, 3) — first and cross axis (position 1); al, ga : (k, n) — the U joint's angles
    (rad); residual : (k,); elevation : (k,) — rad (of a for UP, else the base's);
    errors : list of str — per group, the SynthesisError that left it without links (else
    "").
    """

    bases: _Bases
    base: np.ndarray
    a: np.ndarray
    b: np.ndarray
    al: np.ndarray
    ga: np.ndarray
    residual: np.ndarray
    elevation: np.ndarray
    errors: list

    @property
    def group(self):
        return self.bases.group[self.base]

    def of_sub(self, i, errors) -> "_ULinks":
        """The links of sub-task i, with its ``errors``."""
        k = self.bases.sub[self.base] == i
        return _ULinks(self.bases, self.base[k], self.a[k], self.b[k], self.al[k], self.ga[k],
                       self.residual[k], self.elevation[k], list(errors))


def _u_links(sub, bases: _Bases, base, a, b, tol, elevation=None) -> _ULinks:
    """The U links ``(bases[base], a, b)``: their U angles and pose residuals over their
    sub-task's positions (``sub`` the :class:`synthesis.spherical._SubTasks`), those within
    ``tol`` kept (one batched pass)."""
    L = bases.L[base]
    O, md, mp = bases.O[base], bases.md[base], bases.mp[base]
    Lb = np.einsum("knij,kj->kni", L, b)
    al = _signed_angle(np.broadcast_to(b[:, None], Lb.shape), Lb, a[:, None])
    Ra = _rot(a[:, None], al)
    Ma = np.einsum("knji,knjl,kl->kni", Ra, L, a)               # Rot(b, γ) a
    ga = _signed_angle(np.broadcast_to(a[:, None], Ma.shape), Ma, b[:, None])
    Rf = Ra @ _rot(b[:, None], ga)                              # the link's rotations
    Rm = _rot(md[:, None], bases.mang[base])
    T = np.zeros(L.shape[:2] + (4, 4))
    T[..., :3, :3] = Rf @ Rm
    tm = mp[:, None] - np.einsum("knij,kj->kni", Rm, mp) + bases.msl[base][..., None] * md[:, None]
    T[..., :3, 3] = np.einsum("knij,knj->kni", Rf, tm) + O[:, None] \
        - np.einsum("knij,kj->kni", Rf, O)
    T[..., 3, 3] = 1.0
    s = bases.sub[base]
    rot, pos = pose_errors(T, sub.T[s], sub.reach[s][:, None])
    res = np.maximum(rot.max(-1), pos.max(-1)) if len(T) else np.zeros(0)
    keep = res <= tol
    elev = bases.elevation[base] if elevation is None else elevation
    return _ULinks(bases, base[keep], a[keep], b[keep], al[keep], ga[keep], res[keep],
                   elev[keep], [])


def _on_bases(sub, bases: _Bases, tol) -> _ULinks:
    """Every U link on every base at once: the U directions of all their rotation sets in
    one :func:`_directions` pass and the links' residuals in one comparison."""
    if len(bases.sub):
        own, a, b = _directions(bases.L)
    else:
        own, a, b = np.zeros(0, int), np.zeros((0, 3)), np.zeros((0, 3))
    return _u_links(sub, bases, own, a, b, tol)


def _group_error(fn, *args):
    try:
        return fn(*args), ""
    except SynthesisError as e:
        return [], str(e)


def _uh_bases(screws, sub, subsets, pitch, psis, F, tol) -> tuple:
    """The SH links (SR for pitch 0) of each sub-task at each azimuth (groups): ``(_Bases,
    errors (S, len(psis)))``."""
    links, subs, groups = [], [], []
    errors = np.repeat(sub.error[:, None], len(psis), 1)
    for i in np.flatnonzero(sub.error == ""):
        scr = [screws[j - 1] for j in subsets[i][1:]]
        for g, psi in enumerate(psis):
            lks, errors[i, g] = _group_error(lambda x: sh_links(scr, pitch, x, frame=F, tol=tol),
                                             psi)
            links += lks
            subs += [i] * len(lks)
            groups += [g] * len(lks)
    n = sub.T.shape[1]
    return _Bases.of(links, subs, groups, n, "H" if pitch != 0 else "R", pitch), errors


_AXIS_DEGENERATE = ("axis_azimuth: degenerate: every first axis on this great circle admits "
                    "a cross axis (the link rotations share an axis?)")


def _up_links(sub, psis, chis, F, tol) -> tuple:
    """UP links of each sub-task (three positions) at each (slide azimuth, axis azimuth) of
    ``psis × chis`` (groups, the slide azimuth first): the SP links of all sub-tasks and
    slide azimuths in one pass, the first axes of every sub-task's axis circles from one
    root search (the link's rotations are the body's, the same for every SP link of a
    sub-task): ``(_ULinks, errors (S, groups))``."""
    S, na, nc = len(sub.T), len(psis), len(chis)
    sl = _sphere_links(sub, np.asarray(psis, float), F, "SP", tol)
    bases = _Bases.of_sphere(sl, na, "P", np.inf)
    Lr = np.concatenate([np.broadcast_to(np.eye(3), (S, 1, 3, 3)), sub.Tn[:, 1:, :3, :3]], 1)
    # the axis circles of every sub-task: det[a, L₂ᵀa, L₃ᵀa] = 0 (a cubic form)
    cs, cc = np.divmod(np.arange(S * nc), nc)                   # circle → sub-task, chi
    A0 = np.broadcast_to(F[:, 2], (S * nc, 3))
    B0 = np.cos(np.asarray(chis, float))[cc][:, None] * F[:, 0] \
        + np.sin(np.asarray(chis, float))[cc][:, None] * F[:, 1]

    def f(u, i):
        L = Lr[cs[i]]
        r2, r3 = np.einsum("mi,mij->mj", u, L[:, 1]), np.einsum("mi,mij->mj", u, L[:, 2])
        return np.sum(u * _cross(r2, r3), -1)
    bt, circ, scale = _trig_roots_batch(f, A0, B0, 3, 8)
    # a root at the circle's pole a0 (β = 0 ≡ π) comes out as either end by round-off:
    # taken as β ≈ 0 (a ≈ a0), first
    bt = np.where(bt > np.pi - 1e-9, bt - np.pi, bt)
    o = np.lexsort((bt, circ))
    bt, circ = bt[o], circ[o]
    ac = np.cos(bt)[:, None] * A0[circ] + np.sin(bt)[:, None] * B0[circ]
    if len(ac):
        bc, okc = _null_b(ac, Lr[cs[circ]])
    else:
        bc, okc = np.zeros((0, 3)), np.zeros(0, bool)
    ac, bc, circ = ac[okc], _oriented(bc[okc]), circ[okc]
    elev = np.arctan2(np.sum(ac * B0[circ], -1), np.sum(ac * A0[circ], -1)) % np.pi
    # errors per (sub-task, slide azimuth, axis azimuth): the SP link's, else (when it has
    # links) the axis circle's
    has = np.zeros((S, na), bool)
    has[bases.sub, bases.group] = True
    sp_err = sl.error.reshape(S, na)
    ax_err = np.where((scale == 0).reshape(S, nc), _AXIS_DEGENERATE, "")
    errors = np.where((sp_err != "")[:, :, None], sp_err[:, :, None],
                      np.where(has[:, :, None], ax_err[:, None, :], "")).astype(object)
    # the links: per group, each first axis (ascending) with each SP link
    pairs_b, pairs_a = [], []
    for s_, ia, cbase in ((s_, ia, c_) for s_ in range(S) for ia in range(na)
                          for c_ in range(nc)):
        if errors[s_, ia, cbase]:
            continue
        kb = np.flatnonzero((bases.sub == s_) & (bases.group == ia))
        ka = np.flatnonzero(circ == s_ * nc + cbase)
        pairs_a.append(np.repeat(ka, len(kb)))
        pairs_b.append(np.tile(kb, len(ka)))
    ia_ = np.concatenate(pairs_a).astype(int) if pairs_a else np.zeros(0, int)
    ib_ = np.concatenate(pairs_b).astype(int) if pairs_b else np.zeros(0, int)
    # the group of a UP link is (slide azimuth, axis azimuth): its base's group re-indexed
    grp = bases.group[ib_] * nc + (circ[ia_] % nc)
    ub = _Bases(bases.sub[ib_], grp, bases.L[ib_], bases.O[ib_], bases.md[ib_], bases.mp[ib_],
                bases.mang[ib_], bases.msl[ib_], bases.elevation[ib_], "P", np.inf)
    ul = _u_links(sub, ub, np.arange(len(ib_)), ac[ia_], bc[ia_], tol, elev[ia_])
    return ul, errors.reshape(S, na * nc)


def _uc_cone(u, P, D, n2):
    """The UC concyclicity condition at directions ``u (N, 3)`` for the centres' body
    points ``P (N, n, 3)`` (per direction; ``D = P[:, 1:] − P[:, :1]``, ``n2 = |P|²``)."""
    M = np.zeros(u.shape[:1] + (4, 4))
    M[:, :3, :3] = 2 * D
    pw = np.einsum("nki,ni->nk", P, u)                          # (N, 4)
    M[:, :3, 3] = -((n2[:, 1:] - n2[:, :1]) * np.sum(u * u, -1)[:, None]
                    - (pw[:, 1:] ** 2 - pw[:, :1] ** 2))
    M[:, 3, :3] = u
    return np.linalg.det(M)


_UC_DEGENERATE = ("centre, azimuth: degenerate: every direction of this circle is admissible "
                  "(the centre's positions are degenerate)")


def _uc_bases(sub, centres, psis, F) -> tuple:
    """The SC links of each sub-task at each (azimuth, centre) of ``psis × centres (m,
    3)`` (groups, the azimuth first): the cylinder axes of every circle from one root
    search, then every axis's SC link in one vectorised pass: ``(_Bases, errors (S,
    groups))``."""
    S, n = sub.T.shape[:2]
    na, nc = len(psis), len(centres)
    errors = np.repeat(sub.error[:, None], na * nc, 1)
    Ln, c0 = sub.L, sub.c
    On = (centres[None] - c0[:, None]) / Ln[:, None, None]      # (S, nc, 3)
    Ti = np.linalg.inv(sub.Tn)                                  # (S, n, 4, 4)
    P = np.einsum("snij,scj->scni", Ti[..., :3, :3], On) + Ti[:, None, :, :3, 3]  # O from the body
    D = P[:, :, 1:] - P[:, :, :1]
    n2 = np.sum(P * P, -1)
    # circles: (sub-task, azimuth, centre) of the valid sub-tasks
    cs, ci, cc = (x.ravel() for x in np.meshgrid(np.flatnonzero(sub.error == ""), np.arange(na),
                                                 np.arange(nc), indexing="ij"))
    psis = np.asarray(psis, float)
    A0 = np.broadcast_to(F[:, 2], (len(cs), 3))
    B0 = np.cos(psis[ci])[:, None] * F[:, 0] + np.sin(psis[ci])[:, None] * F[:, 1]
    beta, circ, scale = _trig_roots_batch(
        lambda u, i: _uc_cone(u, P[cs[i], cc[i]], D[cs[i], cc[i]], n2[cs[i], cc[i]]),
        A0, B0, 3, 8)
    errors[cs[scale == 0], ci[scale == 0] * nc + cc[scale == 0]] = _UC_DEGENERATE
    s, c, g = cs[circ], cc[circ], ci[circ] * nc + cc[circ]
    w = np.cos(beta)[:, None] * A0[circ] + np.sin(beta)[:, None] * B0[circ]
    Pr, Onr = P[s, c], On[s, c]
    pw = np.einsum("rni,ri->rn", Pr, w)
    rhs = np.concatenate([(n2[s, c, 1:] - n2[s, c, :1]) - (pw[:, 1:] ** 2 - pw[:, :1] ** 2),
                          np.zeros((len(w), 1))], 1)
    A = np.concatenate([2 * D[s, c], w[:, None]], 1)            # (r, 4, 3)
    ok = np.ones(len(w), bool)
    X = np.zeros((0, 3))
    if len(w):
        sv = np.linalg.svd(A, compute_uv=False)
        ok = ~(sv[:, -1] < 1e-10 * sv[:, 0])
        X = np.einsum("rij,rj->ri", np.linalg.pinv(A), rhs)
    foot = X + np.sum(Onr * w, -1)[:, None] * w                 # foot of O on W (position 1)
    u2 = foot - Onr
    nu = np.linalg.norm(u2, axis=1)
    ok &= ~(nu < 1e-9)                                          # W through the centre
    s, c, g, beta, w, Pr, Onr, X, foot, pw = (v[ok] for v in (s, c, g, beta, w, Pr, Onr, X,
                                                                foot, pw))
    u2 = u2[ok] / nu[ok][:, None]
    R, t = sub.Tn[s, :, :3, :3], sub.Tn[s, :, :3, 3]            # (r, n, 3, 3), (r, n, 3)
    wj = np.einsum("rnij,rj->rni", R, w)
    # foot of O on T_j W: T_j (foot of T_j⁻¹ O on W)
    fb = X[:, None] + pw[..., None] * w[:, None]                # feet of P_j on W (r, n, 3)
    vj = np.einsum("rnij,rnj->rni", R, fb) + t - Onr[:, None]
    vj /= np.linalg.norm(vj, axis=-1, keepdims=True)
    Fr = np.stack([wj, vj, _cross(wj, vj)], -1)                 # (r, n, 3, 3)
    F0 = np.stack([w, u2, _cross(w, u2)], -1)
    Lr = Fr @ np.swapaxes(F0, -1, -2)[:, None]
    M = np.swapaxes(Lr, -1, -2) @ R                             # body relative to link
    Mu = np.einsum("rnij,rj->rni", M, u2)
    phi = _signed_angle(np.broadcast_to(u2[:, None], Mu.shape), Mu, w[:, None])
    # body pose relative to the link: x ↦ L⁻¹ (T x − O) + O; slide of the foot along w
    Tf = np.einsum("rnij,rj->rni", R, foot) + t
    sl = np.einsum("rnji,rnj->rni", Lr, Tf - Onr[:, None]) + Onr[:, None] - foot[:, None]
    s_j = np.sum(sl * w[:, None], -1)
    md = w / np.linalg.norm(w, axis=1, keepdims=True)
    L_, c_ = Ln[s][:, None], c0[s]
    return _Bases(s, g, Lr, centres[c], md, foot * L_ + c_, phi, s_j * L_, beta, "C",
                  np.nan), errors


def _binary_links(ul: _ULinks, types: str, params) -> list[BinaryLink]:
    """BinaryLink objects of U links (``params(i)``: the parameters of link i)."""
    bs = ul.bases
    n = bs.L.shape[1]
    out = []
    for i, j in enumerate(ul.base):
        link = BinaryLink(types, Line._exact(ul.a[i].copy(), bs.O[j].copy()),
                          Line._exact(bs.md[j].copy(), bs.mp[j].copy()), 0.0, bs.pitch,
                          ul.al[i].copy(), np.zeros(n), bs.mang[j].copy(), bs.msl[j].copy(),
                          float(ul.residual[i]), params(i), cross_axis=ul.b[i].copy(),
                          cross_angles=ul.ga[i].copy())
        out.append(link)
    return out


def _raise_group(ul: _ULinks):
    """Raise the one-choice call's error (its only group's), if any."""
    if ul.errors and ul.errors[0]:
        raise SynthesisError(ul.errors[0])


def _u_grids(main, screws, subsets, psis, chis, pitch, centres, F, tol) -> list:
    """The U links (``main`` UR, UH, UC or UP) of several sub-tasks of one task (subsets
    of its positions) at every free-parameter choice, in one pass: the base links of all
    sub-tasks and choices together (:func:`synthesis.spherical._sphere_links`; UH per
    sub-task and azimuth), then all their U directions at once.

    Parameters
    ----------
    main : str
        ``"UR"``, ``"UH"``, ``"UC"`` or ``"UP"``.
    screws : list of Screw
        The task's S₁₂ … S₁N (validated).
    subsets : array_like of int, shape (S, n)
        The positions (0-based, each row starting at 0) of each sub-task: n = 4, or 3 for
        UP.
    psis : sequence of float
        Azimuths (rad): of the body joint's axis (UR, UH, UC) or slide (UP).
    chis : sequence of float or [None]
        UP: the first axis's azimuths (rad).
    pitch : float or None
        UH: the helical joint's pitch (length/rad).
    centres : array_like (m, 3) or [None]
        UC: the U joint's centres (length).
    F : numpy.ndarray, shape (3, 3)
        The reference frame of the azimuths.
    tol : float
        Largest pose error accepted.

    Returns
    -------
    list of _ULinks
        Per sub-task its links, whose groups are the choices in the order of
        ``itertools.product(psis, chis, centres)``, with per group the reason it has no
        link (or ""; a sub-task whose positions coincide has that reason everywhere).
    """
    subsets = np.asarray(subsets, int)
    T = np.stack([np.eye(4)] + [sc.matrix() for sc in screws])
    axes = np.array([sc.axis for sc in screws], float).reshape(-1, 3)
    points = np.array([sc.point for sc in screws], float).reshape(-1, 3)
    sub = _subtasks(T, axes, points, subsets)
    if main == "UP":
        ul, errors = _up_links(sub, psis, chis, F, tol)
    else:
        if main == "UR":
            sl = _sphere_links(sub, np.asarray(psis, float), F, "SR", tol)
            bases, errors = _Bases.of_sphere(sl, len(psis), "R", 0.0), sl.error
        elif main == "UH":
            bases, errors = _uh_bases(screws, sub, subsets, pitch, psis, F, tol)
        else:
            bases, errors = _uc_bases(sub, np.asarray(centres, float), psis, F)
        ul = _on_bases(sub, bases, tol)
    return [ul.of_sub(i, errors[i]) for i in range(len(subsets))]


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
    _task(screws, "screws", (3,))
    scr = _screws(screws, "screws")
    psi_s = number(slide_azimuth, "slide_azimuth", unit_="rad")
    psi_a = number(axis_azimuth, "axis_azimuth", unit_="rad")
    F = _frame_arg(frame, scr)
    tol = number(tol, "tol", positive=True)
    ul = _u_grids("UP", scr, [np.arange(3)], [psi_s], [psi_a], None, [None], F, tol)[0]
    _raise_group(ul)
    return _binary_links(ul, "UP", lambda i: {"slide_azimuth": psi_s, "axis_azimuth": psi_a,
                                               "elevation": float(ul.elevation[i])})


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
    _task(screws, "screws", (4,))
    scr = _screws(screws, "screws")
    psi = number(azimuth, "azimuth", unit_="rad")
    F = _frame_arg(frame, scr)
    tol = number(tol, "tol", positive=True)
    ul = _u_grids("UR", scr, [np.arange(4)], [psi], [None], None, [None], F, tol)[0]
    _raise_group(ul)
    return _binary_links(ul, "UR", lambda i: {"azimuth": psi,
                                               "elevation": float(ul.elevation[i])})


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
    _task(screws, "screws", (4,))
    scr = _screws(screws, "screws")
    p = number(pitch, "pitch", unit_="length/rad")
    psi = number(azimuth, "azimuth", unit_="rad")
    F = _frame_arg(frame, scr)
    tol = number(tol, "tol", positive=True)
    ul = _u_grids("UH", scr, [np.arange(4)], [psi], [None], p, [None], F, tol)[0]
    _raise_group(ul)
    return _binary_links(ul, "UH" if p != 0 else "UR",
                         lambda i: {"azimuth": psi, "elevation": float(ul.elevation[i])})


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
    _task(screws, "screws", (4,))
    scr = _screws(screws, "screws")
    O = vec3(centre, "centre")
    psi = number(azimuth, "azimuth", unit_="rad")
    F = _frame_arg(frame, scr)
    tol = number(tol, "tol", positive=True)
    ul = _u_grids("UC", scr, [np.arange(4)], [psi], [None], None, O[None], F, tol)[0]
    _raise_group(ul)
    return _binary_links(ul, "UC", lambda i: {"centre": O.copy(), "azimuth": psi,
                                               "elevation": float(ul.elevation[i])})
