"""RS links (revolute in the ground, spherical joint in the body) through four positions
as :class:`RSLink` records, for the sphere-ended dyads RRS and PRS of :mod:`synthesis.dyads`.

An RS link (revolute axis in the ground, sphere centre C in the body) reaches
four positions when C's four positions lie on a circle about the axis: a
one-parameter family of links.  :func:`synthesis.spherical.rs_links_at` returns every
member whose axis direction lies on one great circle of directions (the free
parameter, an azimuth), from the roots of a univariate trigonometric polynomial.
:func:`rs_links` collects the members on a set of great circles (default: the three
coordinate planes and three diagonal planes), every root on each circle.
"""
from __future__ import annotations

import numpy as np

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


def _great_circles():
    e = np.eye(3)
    return [(e[0], e[1]), (e[1], e[2]), (e[2], e[0]),
            (e[0], (e[1] + e[2]) / np.sqrt(2)), (e[1], (e[2] + e[0]) / np.sqrt(2)),
            (e[2], (e[0] + e[1]) / np.sqrt(2))]


def rs_links(T, *, samples: int = 720, tol: float = 1e-9, circles=None) -> list[RSLink]:
    """RS links through four positions ``T`` (4, 4, 4), position 1 the identity.

    Returns every member of the one-parameter family met on the great circles of
    axis directions ``circles`` (pairs of orthonormal vectors; default the three
    coordinate planes and three diagonal planes), each reaching the positions to
    ``tol`` (relative to the task's reach, the size of its coordinates).

    Parameters
    ----------
    T : array_like, shape (4, 4, 4)
        Rigid transforms of positions 1–4; ``T[0]`` is the identity.
    samples : int
        Kept for compatibility (validated, ≥ 3): the links on each circle are now the
        roots of a polynomial, all found without sampling, so it no longer changes the
        result.
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
    from .screw import Screw
    from .spherical import rs_links_at
    scr = [Screw.from_matrix(t) for t in T[1:]]
    out: list[RSLink] = []
    for e1, e2 in (circles or _great_circles()):
        # the great circle cos β e1 + sin β e2 is azimuth 0 of the frame (e2, e1 × e2, e1)
        e2 = e2 - (e2 @ e1) * e1
        e2 /= np.linalg.norm(e2)
        F = np.stack([e2, np.cross(e1, e2), e1], 1)
        try:
            found = rs_links_at(scr, 0.0, frame=F, tol=tol)
        except SynthesisError as e:
            if "screws" in str(e):
                raise SynthesisError(f"T: {e}") from None
            raise
        for lk in found:
            link = RSLink(lk.fixed_axis, lk.moving_axis.point, lk.fixed_angles, lk.residual)
            if not any(_same(link, o, size) for o in out):
                out.append(link)
    if not out:
        raise SynthesisError("rs_links: no RS link found on the given great circles of "
                             "directions (positions degenerate, or the family misses them)")
    return out


def _same(a: RSLink, b: RSLink, size: float) -> bool:
    return abs(abs(a.axis.direction @ b.axis.direction) - 1) < 1e-8 and \
        np.linalg.norm(a.centre - b.centre) < 1e-7 * max(size, np.linalg.norm(a.centre))
