"""RS links (revolute in the ground, spherical joint in the body) through four positions
(the sphere-ended dyads RRS and PRS built from them are in :mod:`synthesis.dyads`).

An RS link (revolute axis in the ground, sphere centre C in the body) reaches
four positions when C's four positions lie on a circle about the axis.  For an
axis direction g, C is fixed by the three linear conditions (C_j − C_1)·g = 0;
the circle's centre O then needs (C_1 − C_j)·O = ½(|C_1|² − |C_j|²) and
g·O = g·C_1: four linear equations for three unknowns, consistent only when
their 4x4 augmented determinant h(g) vanishes.  So the RS links form a
one-parameter family (a curve of directions g on the sphere): linkwright traces
it deterministically along great circles of directions (a fine sampling of
h, every sign change refined by Brent's method), and keeps the links that then
reach the four positions to tolerance.
"""
from __future__ import annotations

import warnings

import numpy as np
from scipy.optimize import brentq

from closure.frames import cross

from .errors import SynthesisError
from .screw import Line
from .validate import integer, number, task_scale, transform, unit

__all__ = ["rs_links", "RSLink"]


class RSLink:
    """An RS link: ``axis`` (Line in the ground, canonical point) and ``centre`` (the sphere
    centre in the first position), with the joint angles at the positions and the circle
    residual (length)."""

    def __init__(self, axis: Line, centre, angles, residual):
        self.axis, self.centre = axis, np.asarray(centre, float)
        self.angles, self.residual = np.asarray(angles, float), float(residual)


def _centre_for(g, T):
    """Sphere centres C for axis directions g (..., 3): (C_j − C_1)·g = 0, j = 2, 3, 4."""
    g = np.asarray(g, float)
    A = np.stack([g @ (t[:3, :3] - np.eye(3)) for t in T[1:]], -2)        # (..., 3, 3)
    b = -np.stack([g @ t[:3, 3] for t in T[1:]], -1)
    cond = np.linalg.cond(A)
    ok = np.isfinite(cond) & (cond < 1e10)
    C = np.full(g.shape, np.nan)
    if np.any(ok):
        C[ok] = np.linalg.solve(A[ok], b[ok][..., None])[..., 0]
    return C, cond


def _h(g, T):
    """Concyclicity determinant of the sphere centre's four positions, batched over g."""
    g = np.atleast_2d(np.asarray(g, float))
    C, _ = _centre_for(g, T)
    Cs = np.stack([C @ t[:3, :3].T + t[:3, 3] for t in T], 1)              # (B, 4, 3)
    rows = [np.concatenate([Cs[:, 0] - Cs[:, j], -0.5 * (np.sum(Cs[:, 0] ** 2, -1)
                                                       - np.sum(Cs[:, j] ** 2, -1))[:, None]], -1)
            for j in (1, 2, 3)]
    rows.append(np.concatenate([g, -np.sum(g * Cs[:, 0], -1)[:, None]], -1))
    M = np.stack(rows, 1)
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        scale = np.nanmax(np.abs(Cs), axis=(1, 2))
        scale = np.where(scale > 0, scale, 1.0)
        return np.linalg.det(np.nan_to_num(M, nan=0.0)) / scale ** 4 * \
            np.where(np.isnan(C).any(-1), np.nan, 1.0)


def _great_circles():
    e = np.eye(3)
    return [(e[0], e[1]), (e[1], e[2]), (e[2], e[0]),
            (e[0], (e[1] + e[2]) / np.sqrt(2)), (e[1], (e[2] + e[0]) / np.sqrt(2)),
            (e[2], (e[0] + e[1]) / np.sqrt(2))]


def rs_links(T, *, samples: int = 720, tol: float = 1e-9, circles=None) -> list[RSLink]:
    """RS links through four positions ``T`` (4, 4, 4), position 1 the identity.

    Returns the members of the one-parameter family met on the great circles of
    axis directions ``circles`` (pairs of orthonormal vectors; default the three
    coordinate planes and three diagonal planes), each reaching the positions to
    ``tol`` (relative to the task's reach, the size of its coordinates).

    Parameters
    ----------
    T : array_like, shape (4, 4, 4)
        Rigid transforms of positions 1–4; ``T[0]`` is the identity.
    samples : int
        Directions sampled per great circle (≥ 3).
    tol : float
        Largest circle residual accepted (relative), positive.
    circles : sequence of pairs of orthonormal 3-vectors, optional

    Raises
    ------
    SynthesisError
        Bad input (naming the argument), or when no link is found.
    """
    T = transform(T, "T", batch=True)
    if T.shape[0] != 4:
        raise SynthesisError(f"T: expected four 4x4 positions (4, 4, 4), got shape {T.shape}")
    _, _, size = task_scale(T)
    if np.abs(T[0, :3, :3] - np.eye(3)).max() > 1e-12 or \
            np.abs(T[0, :3, 3]).max() > 1e-12 * size:
        raise SynthesisError("T: expected T[0] to be the identity (position 1), got "
                             f"{np.array2string(T[0], precision=3)}")
    samples = integer(samples, "samples", low=3)
    tol = number(tol, "tol", positive=True)
    if circles is not None:
        try:
            circles = [(unit(a, f"circles[{i}][0]"), unit(b, f"circles[{i}][1]"))
                       for i, (a, b) in enumerate(circles)]
        except (TypeError, ValueError) as e:
            if isinstance(e, SynthesisError):
                raise
            raise SynthesisError("circles: expected pairs of orthonormal 3-vectors") from None
        for i, (a, b) in enumerate(circles):
            if abs(a @ b) > 1e-6:
                raise SynthesisError(f"circles[{i}]: the two vectors are not orthogonal "
                                     f"(dot product {a @ b:.1e})")
    out = []
    for e1, e2 in (circles or _great_circles()):
        psi = np.linspace(0, np.pi, samples, endpoint=False)     # g and −g are the same axis
        g = np.cos(psi)[:, None] * e1 + np.sin(psi)[:, None] * e2
        hv = _h(g, T)
        for i in range(samples - 1):
            a, b = hv[i], hv[i + 1]
            if not (np.isfinite(a) and np.isfinite(b)) or a * b > 0:
                continue
            f = lambda p: float(_h(np.cos(p) * e1 + np.sin(p) * e2, T)[0])
            try:
                p = brentq(f, psi[i], psi[i + 1], xtol=1e-15, rtol=1e-15)
            except ValueError:
                continue
            link = _rs_from_direction(np.cos(p) * e1 + np.sin(p) * e2, T, size)
            if link is not None and link.residual <= tol and \
                    not any(_same(link, o, size) for o in out):
                out.append(link)
    if not out:
        raise SynthesisError("rs_links: no RS link found on the sampled directions (positions "
                             "degenerate, or the family misses these great circles)")
    return out


def _same(a: RSLink, b: RSLink, size: float) -> bool:
    return abs(abs(a.axis.direction @ b.axis.direction) - 1) < 1e-8 and \
        np.linalg.norm(a.centre - b.centre) < 1e-7 * max(size, np.linalg.norm(a.centre))


def _rs_from_direction(g, T, size):
    g = g / np.linalg.norm(g)
    C, _ = _centre_for(g[None], T)
    C = C[0]
    if not np.all(np.isfinite(C)):
        return None
    Cs = np.array([t[:3, :3] @ C + t[:3, 3] for t in T])
    A = np.array([2 * (Cs[0] - c) for c in Cs[1:]] + [g])
    b = np.array([Cs[0] @ Cs[0] - c @ c for c in Cs[1:]] + [g @ Cs[0]])
    O, *_ = np.linalg.lstsq(A, b, rcond=None)
    r = np.linalg.norm(Cs - O, axis=1)
    resid = max(np.ptp(r), np.abs((Cs - Cs[0]) @ g).max()) / size
    if r.min() < 1e-9 * size:
        return None
    axis = Line(g, O).canonical()
    u0 = Cs[0] - O
    ang = [float(np.arctan2(cross(u0, c - O) @ g, u0 @ (c - O))) for c in Cs]
    return RSLink(axis, C, ang, resid)
