"""Binary links of two revolute or helical joints (HH, RH, HR; RR as the pitch-0 case)
through three positions, by the screw triangle (Tsai & Roth 1972).

For a fixed axis direction g the moving axis direction is forced by the constant
angle of the two axes, ``w ∝ ((R₂ − I)ᵀ g) × ((R₃ − I)ᵀ g)``, and with it the joint
rotations θ_j, φ_j; the dual part of the screw triangle is then six linear equations
(translations of positions 2 and 3) in the four coordinates of the axes' points, the
slides being pitch · rotation.  They are consistent only on isolated directions g: two
conditions on the sphere of directions.  ``helical_links`` evaluates the least-squares
misfit of the six equations on a near-uniform grid of directions, refines every local
minimum by Levenberg–Marquardt on the six equations in (g, points) (both compiled,
:mod:`synthesis.kernels`), and keeps the distinct links that reach the positions to
``tol``.  With both pitches 0 the two links are the RR links of :func:`synthesis.rr_links`.

With both pitches free (:func:`hh_links_free_pitch`) the six equations are linear in
the points and the pitches for every direction g: a two-parameter family, g the free
choice.

Joint rotations are taken in (−π, π]: a helical link turned by a further whole turn is
another link (its slide differs by 2π · pitch) and is not listed.
"""
from __future__ import annotations

import numpy as np

from .binary import (BinaryLink, _angles, _check_rotations, _cross, _fibonacci_neighbours,
                     _finish, _local_minima, _perp, _residuals, _same, _system, _task,
                     _unfinished)
from .errors import SynthesisError
from .validate import integer, number, screw as _screw, unit

__all__ = ["helical_links", "hh_links_free_pitch"]


def _moving_direction(g, R):
    """Moving-axis directions ``(N, 3)`` for fixed directions ``g (N, 3)`` through the
    rotations ``R (2, 3, 3)`` of positions 2, 3, and their unnormalised length."""
    a = np.einsum("mji,nj->nmi", R - np.eye(3), g)            # (R_j − I)ᵀ g
    w = _cross(a[:, 0], a[:, 1])
    n = np.linalg.norm(w, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return w / n[:, None], n


def _equations(g, R, t, kinds, pitches):
    """The six translation equations for fixed directions ``g (N, 3)``: ``A, rhs``, the
    moving directions, angles and bases, and a validity mask."""
    w, wn = _moving_direction(g, R)
    ok = wn > 1e-9
    w = np.where(ok[:, None], w, [0.0, 0.0, 1.0])
    th, ph, Gm, sin_gw = _angles(g, w, R)
    A, rhs, basis = _system(g, w, th, ph, Gm, t, kinds, pitches)
    ok &= sin_gw > 1e-9
    return A, rhs, w, th, ph, basis, ok


def helical_links(s12, s13, fixed_pitch: float = 0.0, moving_pitch: float = 0.0, *,
                  samples: int = 10000, tol: float = 1e-9) -> list[BinaryLink]:
    """All binary links of two screw joints of given pitches through three positions.

    Parameters
    ----------
    s12, s13 : Screw
        Displacements from position 1 to positions 2 and 3.
    fixed_pitch, moving_pitch : float
        Pitches of the fixed (ground) and moving joint: slide per radian of rotation
        (length of the task / rad).  0 makes the joint revolute (type letter R),
        anything else helical (H).
    samples : int
        Fixed-axis directions sampled on the hemisphere before refinement (≥ 100):
        the grid must resolve the solutions' basins (the default found the generating
        link of 80 of 80 random HH/RH/HR/RR chains with joint rotations 0.1–2.5 rad; 6000
        missed 3).  Not a proof of completeness: solutions whose basins are narrower
        than the grid spacing (~0.02 rad at the default) can be missed; against a grid
        of 40,000 directions the default missed 4 of 1,608 links on 720 random
        three-position tasks (each a link turning its moving joint by less than 0.35 rad
        or its fixed one by more than 2.8 rad), and found none the denser grid missed.
    tol : float
        Largest pose error accepted (rad, or translation relative to the task's reach).

    Returns
    -------
    list of BinaryLink
        Types ``"HH"``, ``"RH"``, ``"HR"`` or ``"RR"``; ordered by the fixed axis
        direction.  Empty when no real link exists.

    Raises
    ------
    SynthesisError
        Naming the argument for bad input; for coincident positions, or a relative screw
        that is a pure translation (the axes would be parallel and not isolated).
    """
    task = _task([_screw(s12, "s12"), _screw(s13, "s13")], "s12, s13", (3,))
    pg = number(fixed_pitch, "fixed_pitch", unit_="length/rad")
    pw = number(moving_pitch, "moving_pitch", unit_="length/rad")
    samples = integer(samples, "samples", low=100)
    tol = number(tol, "tol", positive=True)
    _check_rotations(task, "s12, s13")
    kinds = ("R" if pg == 0 else "H", "R" if pw == 0 else "H")
    pn = (pg / task.L, pw / task.L)
    from .kernels import hh_grid, hh_refine
    R, t, pc = np.ascontiguousarray(task.R), np.ascontiguousarray(task.t), np.array(pn)
    G, nbr = _fibonacci_neighbours(samples, 3)  # small neighbourhoods: close basins (measured)
    g0 = G[_local_minima(hh_grid(G, R, t, pc), nbr)]
    e1, e2 = _perp(g0)
    # variable projection: the points solved for each direction g(u) = g0 + u₁ e1 + u₂ e2
    u, res, _ = hh_refine(np.stack([g0, e1, e2], 1), R, t, pc, 80)
    conv = res < 1e-9
    g = g0[conv] + u[conv, :1] * e1[conv] + u[conv, 1:] * e2[conv]
    g /= np.linalg.norm(g, axis=1, keepdims=True)
    g *= np.where(g[:, 2:3] < 0, -1.0, 1.0)
    g = g[~np.any(np.tril(np.abs(g @ g.T) > 1 - 1e-14, -1), 1)]   # starts met at one root
    if not len(g):
        return []
    A, rhs, w, th, ph, (e1, e2, f1, f2), ok = _equations(g, R, t, ("H", "H"), pn)
    links = [_link(task, g[k], np.linalg.lstsq(A[k], rhs[k], rcond=None)[0], kinds, pn,
                   (A[k], w[k], th[k], ph[k], e1[k], e2[k], f1[k], f2[k], ok[k]))
             for k in range(len(g))]
    _residuals([lk for lk in links if lk is not None], task)
    out: list[BinaryLink] = []
    for link in links:
        if link is not None and link.residual <= tol and not any(_same(link, o, task.L) for o in out):
            out.append(link)
    out.sort(key=lambda lk: tuple(np.round(lk.fixed_axis.direction * np.sign(
        lk.fixed_axis.direction[np.argmax(np.abs(lk.fixed_axis.direction))]), 12)))
    return out


def _link(task, g, x, kinds, pn, eq):
    """The BinaryLink (residual not yet set) of a converged direction ``g`` and axis-point
    coordinates ``x`` (``eq``: that direction's equations, moving direction, angles, bases
    and validity from :func:`_equations`), or None where the axes are not determined
    (degenerate equations)."""
    A, w, th, ph, e1, e2, f1, f2, ok = eq
    s = np.linalg.svd(A, compute_uv=False)
    if not ok or s[-1] < 1e-7 * s[0]:
        return None
    cg = x[0] * e1 + x[1] * e2
    cw = x[2] * f1 + x[3] * f2
    return _unfinished(task, kinds, pn, g, cg, w, cw, th, pn[0] * th, ph, pn[1] * ph, {})


def hh_links_free_pitch(s12, s13, fixed_direction) -> list[BinaryLink]:
    """The HH link through three positions with both pitches free, for a chosen fixed-axis
    direction.

    With the pitches as design variables the HH links through three positions form a
    two-parameter family: the fixed axis direction g (free) fixes the moving direction and
    the joint rotations, and the six translation equations are linear in the four
    coordinates of the axes' points and the two pitches.

    Parameters
    ----------
    s12, s13 : Screw
        Displacements from position 1 to positions 2 and 3.
    fixed_direction : array_like, shape (3,)
        Unit direction of the fixed axis: the two free parameters (dimensionless).

    Returns
    -------
    list of one BinaryLink: types from the pitches found (a pitch that comes out 0 to
    round-off, ≤ 1e-12 of the task's size per rad, gives an R joint); ``parameters``
    holds the direction.

    Raises
    ------
    SynthesisError
        Bad input (named); coincident positions; a pure-translation relative screw;
        parallel screw axes; a direction for which the link degenerates (named).
    """
    task = _task([_screw(s12, "s12"), _screw(s13, "s13")], "s12, s13", (3,))
    g = unit(fixed_direction, "fixed_direction")
    _check_rotations(task, "s12, s13")
    R, t = task.R, task.t
    A, rhs, w, th, ph, (e1, e2, f1, f2), ok = _equations(g[None], R, t, ("H", "H"), (0.0, 0.0))
    if not ok[0]:
        raise SynthesisError(f"fixed_direction: degenerate: the moving axis is not determined "
                             f"by {np.round(g, 6)} (or is parallel to it)")
    Gm = np.stack([_rot_about(g, a) for a in th[0]])
    cols = np.zeros((6, 2))
    for j in range(2):
        cols[3 * j:3 * j + 3, 0] = th[0, j] * g
        cols[3 * j:3 * j + 3, 1] = ph[0, j] * (Gm[j] @ w[0])
    M = np.concatenate([A[0], cols], 1)
    sv = np.linalg.svd(M, compute_uv=False)
    if sv[-1] < 1e-9 * sv[0]:
        raise SynthesisError(f"fixed_direction: degenerate: the equations for the axes and "
                             f"pitches are singular (condition {sv[0] / max(sv[-1], 1e-300):.1e})")
    x = np.linalg.solve(M, rhs[0])
    pn = (float(x[4]), float(x[5]))
    kinds = tuple("R" if abs(p) <= 1e-12 else "H" for p in pn)
    pn = tuple(0.0 if k == "R" else p for k, p in zip(kinds, pn))
    cg = x[0] * e1[0] + x[1] * e2[0]
    cw = x[2] * f1[0] + x[3] * f2[0]
    link = _finish(task, kinds, pn, g, cg, w[0], cw, th[0], pn[0] * th[0], ph[0], pn[1] * ph[0],
                   {"fixed_direction": g.copy()})
    return [link]


def _rot_about(u, a):
    K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K
