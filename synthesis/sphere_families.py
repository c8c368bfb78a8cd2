"""Sphere-ended dyad families (joint 3 spherical: RRS, PRS, RPS; with a helical joint RHS,
HRS, PHS, HPS) by Kharatyan's decomposition, with the main link's free parameter explicit.

The main link is RS or HS (four positions; HS with the helical joint's ``pitch`` given,
length/rad) or PS (three positions), its fixed axis (or slide)
direction on the great circle of ``azimuth`` ψ in the task's reference frame
(:func:`synthesis.spherical.task_frame` of all the screws; :func:`synthesis.spherical.
azimuth_of` reads ψ off a direction).  The transition joint then carries the sphere centre
C from its position at the transition position s to the remaining ones: an R joint through
two remaining positions (the axis of the circle through the three positions of C), a P
joint through one (the slide along C_l − C_s).  Arrangement (a): the transition joint is
joint 1 (in the ground); (b): joint 2, whose position-1 axis is the transition axis moved
back by the main fixed joint's screw at s (for H the rotation θ_s with the slide
pitch · θ_s).  A sphere leaves the orientation free, so the
variants are verified through the centre (:func:`synthesis.verify.verify_points`: joints 1
and 2 driven by the engine, helical joints with their pitch, one batched call).

Table 3 rows 16 (RHS, HRS) and 17 (PHS, HPS) print N = 7 and 6: there the pitch is a
design variable (HS through five positions).  Here the pitch is given (a required choice),
so the HS link goes through four positions and N is one less: 6 (RHS: HS joints 2–3 and R
joint 1, arrangement a; HRS: HS joints 1 and 3, R joint 2, arrangement b) and 5 (PHS, a;
HPS, b).  For H the joint value columns are ``q`` = angle (rad) and ``d`` = pitch · angle.
"""
from __future__ import annotations

import itertools
import re

import numpy as np

from .binary import _rot
from .decompose import angle_grid, nan_geometry, task_positions
from .errors import SynthesisError
from .screw import Line
from .validate import number
from .verify import verify_points
from .dyads import _row

__all__ = ["sphere_arrangements", "sphere_family_dyads", "SPHERE_MAIN_POSITIONS"]

#: main link → positions; transition joint → remaining positions it carries
SPHERE_MAIN_POSITIONS = {"RS": 4, "PS": 3, "HS": 4}
_EZ = np.array([0, 0, 1.0])
_TRANS = {"R": 2, "P": 1}
#: default azimuth grid (rad)
DEFAULT_AZIMUTHS = np.arange(4) * np.pi / 4
#: family → (positions, free parameters, note for :func:`synthesis.families`)
_H_NOTE = ("implemented with the pitch given (the choice pitch): main HS link ({arr}) through 4 "
           "positions (azimuth free) + {x} transition (joint {j}) through {k}: N = {n}; the "
           "printed N = {m} takes the pitch as a design variable (HS through 5), not "
           "implemented")
FAMILIES = {"RRS": (6, ("azimuth",), ""), "PRS": (5, ("azimuth",), ""),
            "RPS": (5, ("azimuth",), ""),
            "RHS": (6, ("azimuth", "pitch"), _H_NOTE.format(arr="joints 2–3", x="R", j=1, k=2,
                                                             n=6, m=7)),
            "HRS": (6, ("azimuth", "pitch"), _H_NOTE.format(arr="joints 1 and 3", x="R", j=2,
                                                             k=2, n=6, m=7)),
            "PHS": (5, ("azimuth", "pitch"), _H_NOTE.format(arr="joints 2–3", x="P", j=1, k=1,
                                                             n=5, m=6)),
            "HPS": (5, ("azimuth", "pitch"), _H_NOTE.format(arr="joints 1 and 3", x="P", j=2,
                                                             k=1, n=5, m=6))}


def sphere_arrangements(family: str, n_positions: int | None = None) -> list[tuple]:
    """``(name, main, transition kind, n_b, k)`` of the sphere-ended ``family``."""
    out = []
    if len(family) != 3 or family[2] != "S":
        return out
    for name, main, x in (("a", family[1:], family[0]), ("b", family[0] + "S", family[1])):
        if main in SPHERE_MAIN_POSITIONS and x in _TRANS:
            n = SPHERE_MAIN_POSITIONS[main] + _TRANS[x]
            if n_positions is None or n == n_positions:
                out.append((name, main, x, SPHERE_MAIN_POSITIONS[main], _TRANS[x]))
    return out


def _helical_pitch(family: str, pitch) -> float:
    """The given pitch of the family's helical joint (length/rad), or 0 without one."""
    if "H" not in family:
        if pitch is not None:
            raise SynthesisError(f"pitch: family {family} has no helical joint")
        return 0.0
    if pitch is None:
        raise SynthesisError(f"pitch: family {family} has a helical joint; give its pitch "
                             "(length/rad, nonzero)")
    p = number(pitch, "pitch", unit_="length/rad")
    if p == 0:
        raise SynthesisError(f"pitch: the helical joint of {family} with pitch 0 is a revolute "
                             "joint: use the family with R there")
    return p


def _renumbered(err: str, others) -> str:
    """A main link's error message with its screws named as in the whole task: the link is
    solved through positions 1 and ``others`` (0-based), so its k-th screw "S_1{k+2}" is
    S₁ of position ``others[k] + 1``."""
    def sub(m):
        k = int(m.group(1)) - 2
        return f"S_1{others[k] + 1}" if 0 <= k < len(others) else m.group(0)
    return re.sub(r"\bS_1(\d)\b", sub, err)


def sphere_family_dyads(family: str, screws, *, azimuth=None, pitch=None) -> list[dict]:
    """Rows (dicts) of every variant of a sphere-ended family; see
    :func:`synthesis.enumerate_dyads`.

    Parameters
    ----------
    family : str
        ``"RRS"``, ``"PRS"``, ``"RPS"``, ``"RHS"``, ``"HRS"``, ``"PHS"`` or ``"HPS"``.
    screws : list of Screw
        S₁₂ … S₁N (N = 6 for RRS, RHS, HRS; 5 for PRS, RPS, PHS, HPS).
    azimuth : float or array_like, optional
        ψ (rad) of the main link's fixed axis (slide) direction; default 0, π/4, π/2, 3π/4.
    pitch : float
        The helical joint's pitch (length/rad, nonzero), required for RHS, HRS, PHS, HPS
        (given, not a design variable); not allowed for the others.

    Raises
    ------
    SynthesisError
        Bad input, naming the argument (``screws``, ``azimuth``, ``pitch``).
    """
    from .spherical import task_frame
    T, N, arr, reach = task_positions(family, screws, sphere_arrangements)
    ph = _helical_pitch(family, pitch)
    psis = angle_grid(azimuth, "azimuth", DEFAULT_AZIMUTHS)
    frame = task_frame(screws)
    rows, chains = [], []
    cache = {}
    for name, main, x, n_b, k in arr:
        for others in itertools.combinations(range(1, N), n_b - 1):
            Pm = (0,) + others
            rest = [i for i in range(N) if i not in Pm]
            if (main, Pm) not in cache:
                cache[main, Pm] = _main_links(main, [screws[i - 1] for i in others], psis, ph,
                                              frame, others)
            for psi, (links, err) in zip(psis, cache[main, Pm]):
                base = (family, name, main, x, Pm, rest, psi)
                if not links:
                    reason = err or f"no real {main} link on the circle of this azimuth"
                    rows.extend(_failed(*base[:5], s, *base[5:], reason, ph) for s in Pm)
                    continue
                _variant_rows(base, links, T, reach, ph, rows, chains)
    res = verify_points([c for _, c in chains], T, reach)
    for (i, _), r in zip(chains, res):
        rows[i]["residual"] = float(r)
    for v, row in enumerate(rows, start=1):
        row["variant"] = v
    return rows


def _main_links(main, sub, psis, ph, frame, others) -> list[tuple]:
    """``(links, error message)`` of the main link through positions 1 and ``others`` at
    each azimuth of ``psis`` (the links of the task's screws ``sub``)."""
    from .spherical import hs_links, ps_links, rs_links_grid
    if main == "RS":
        out = rs_links_grid(sub, [float(psi) for psi in psis], frame=frame)
    else:
        out = []
        for psi in psis:
            try:
                out.append((ps_links(sub, float(psi), frame=frame) if main == "PS" else
                            hs_links(sub, ph, float(psi), frame=frame), ""))
            except SynthesisError as e:
                out.append(([], str(e)))
    return [(links, _renumbered(err, others) if err else "") for links, err in out]


def _transition_axes(x, Cs, Pm, rest, reach):
    """The transition joint of every (main link, transition position) variant, in one pass.

    Parameters
    ----------
    x : str
        ``"R"`` (the circle through the sphere centre at s and its two remaining positions)
        or ``"P"`` (the slide from s to the remaining position).
    Cs : ndarray, shape (L, N, 3)
        The sphere centre of each of the L main links in every position.
    Pm, rest : sequence of int
        The main link's positions (each a transition position s) and the remaining ones.
    reach : float
        The task's length scale.

    Returns
    -------
    u, p : ndarray, shape (L, len(Pm), 3)
        Axis direction and canonical point (foot of the perpendicular from the origin).
    xv : ndarray, shape (L, len(Pm), len(rest))
        The transition joint's values at the remaining positions (angles or slides).
    reasons : ndarray of str, shape (L, len(Pm))
        ``""``, or why the variant has no transition joint.
    """
    from .dyads import CIRCLE_ERROR, circle_axes
    L, m = Cs.shape[0], len(Pm)
    p1 = Cs[:, list(Pm)].reshape(-1, 3)
    far = [np.repeat(Cs[:, r], m, axis=0) for r in rest]
    if x == "R":
        u, O, xv, ok = circle_axes(p1, *far)
        reasons = np.where(ok, "", CIRCLE_ERROR)
    else:
        d = far[0] - p1
        nd = np.linalg.norm(d, axis=-1)
        ok = ~(nd < 1e-12 * reach)
        u, O, xv = d / np.where(ok, nd, 1.0)[:, None], p1, nd[:, None]
        reasons = np.array(["" if o else "prismatic axis: the sphere centre does not move "
                            f"from position {Pm[i % m] + 1} to {rest[0] + 1}"
                            for i, o in enumerate(ok)])
    p = O + np.einsum("mi,mi->m", -O, u)[:, None] * u
    return (u.reshape(L, m, 3), p.reshape(L, m, 3), xv.reshape(L, m, -1),
            reasons.reshape(L, m))


def _variant_rows(base, links, T, reach, ph, rows, chains):
    """Append the rows of every (main link, transition position) variant of one main-link
    solve to ``rows``, and their chains to verify (``(row index, chain)``) to ``chains``."""
    family, name, main, x, Pm, rest, psi = base
    N = T.shape[0]
    Cs = np.array([T[:, :3, :3] @ lk.moving_axis.point + T[:, :3, 3] for lk in links])
    U, P, XV, reasons = _transition_axes(x, Cs, Pm, rest, reach)
    X, F = (0, 1) if name == "a" else (1, 0)
    types = family[:2]
    pitches = [ph if t == "H" else 0.0 for t in types]
    fixed = {f"j{kk + 1}_type": t for kk, t in enumerate(family)}
    fixed.update({f"j{kk + 1}_pitch": {"R": 0.0, "P": np.inf, "H": ph}.get(t, np.nan)
                  for kk, t in enumerate(family)})
    fixed.update(j3_ux=np.nan, j3_uy=np.nan, j3_uz=np.nan)
    dscale = np.array([1.0 if t == "P" else ph if t == "H" else 0.0 for t in types])
    m = len(Pm)
    FV = np.array([lk.fixed_slides if main == "PS" else lk.fixed_angles for lk in links],
                  float)
    lines = _joint_lines(name, main, U, P, np.array([lk.fixed_axis.direction for lk in links]),
                         np.array([lk.fixed_axis.point for lk in links]), FV[:, :m], ph)
    for m_i, (lk, fv) in enumerate(zip(links, FV)):
        C = lk.moving_axis.point
        for si, s in enumerate(Pm):
            if reasons[m_i, si]:
                rows.append(_failed(family, name, main, x, Pm, s, rest, psi, reasons[m_i, si],
                                    ph))
                continue
            jv = np.zeros((N, 2))
            jv[list(Pm), F] = fv[:m]
            jv[rest, X], jv[rest, F] = XV[m_i, si], fv[si]
            pair = [Line._exact(u, p) for u, p in lines[m_i, si]]
            row = _row(family, 0, _order(family, name, main, x, Pm, s, rest, psi),
                       family.replace("H", "R"), pair + [Line._exact(_EZ, C)], np.nan,
                       arrangement=name, transition=x + "S", main_link=main,
                       main_positions=str(tuple(p + 1 for p in Pm)),
                       transition_position=s + 1, member=m_i, azimuth=float(psi),
                       elevation=float(lk.parameters.get("elevation", np.nan)),
                       joint_values=np.hstack([jv, np.full((N, 1), np.nan)]))
            row.update(fixed)
            d = jv * dscale
            row.update({f"d{kk + 1}_pos{p + 1}": d[p, kk] for p in range(N)
                        for kk in range(2)})
            rows.append(row)
            chains.append((len(rows) - 1, (types, pair, jv, C, pitches)))


def _joint_lines(name, main, u, p, Fu, Fp, f, ph):
    """Joint 1 and 2 axes (position 1, canonical chain) of the variants of one main-link
    solve, one per (main link, transition position s).

    Parameters
    ----------
    name : str
        Arrangement ``"a"`` (transition joint 1) or ``"b"`` (joint 2: the transition axis
        moved back by the main fixed joint's screw at s).
    main : str
        The main link, ``"RS"``, ``"PS"`` or ``"HS"``.
    u, p : ndarray, shape (L, m, 3)
        The transition axis of each variant.
    Fu, Fp : ndarray, shape (L, 3)
        Each main link's fixed axis (direction, point).
    f : ndarray, shape (L, m)
        The main fixed joint's value at each transition position.
    ph : float
        The helical pitch.

    Returns
    -------
    ndarray, shape (L, m, 2, 2, 3)
        Per variant, ``(direction, point)`` of joints 1 and 2.
    """
    shape = u.shape[:2]
    Fu, Fp = (np.broadcast_to(X[:, None], u.shape).reshape(-1, 3) for X in (Fu, Fp))
    u, p, f = u.reshape(-1, 3), p.reshape(-1, 3), f.reshape(-1)
    if name == "a":
        pairs = _canonical_pairs(u, p, Fu, Fp)
    else:                         # undo the screw: rotate by −angle about it, slide back
        zero = np.zeros_like(f)
        ang, slide = {"RS": (f, zero), "PS": (zero, f), "HS": (f, ph * f)}[main]
        Ri = _rot(Fu, -ang)
        pairs = _canonical_pairs(Fu, Fp, np.einsum("mij,mj->mi", Ri, u),
                                 Fp + np.einsum("mij,mj->mi", Ri, p - Fp) - slide[:, None] * Fu)
    return pairs.reshape(shape + (2, 2, 3))


def _dot(a, b):
    return np.einsum("mi,mi->m", a, b)


def _canonical_pairs(u1, p1, u2, p2):
    """Batched :func:`synthesis.dyads._canonical_chain` of line pairs: the first line's
    point the foot of the perpendicular from the origin, the second's the foot of the
    common normal with the first (of the perpendicular from the first's point when they
    are parallel, as :func:`synthesis.screw.common_normal`).  Returns ``(m, 2, 2, 3)``."""
    p1 = p1 - _dot(p1, u1)[:, None] * u1
    b = _dot(u1, u2)
    den = 1 - b * b
    w = p1 - p2
    d, e = _dot(u1, w), _dot(u2, w)
    par = den < 1e-12
    t = np.where(par, e, (e - b * d) / np.where(par, 1.0, den))
    p2 = p2 + t[:, None] * u2
    return np.stack([np.stack([u1, p1], 1), np.stack([u2, p2], 1)], 1)


def _order(family, name, main, x, Pm, s, rest, psi):
    """The ``order`` text of a variant."""
    return (f"{main} through {tuple(p + 1 for p in Pm)}; {x} "
            f"({'J1' if name == 'a' else 'J2'}) carries position {s + 1} to "
            f"{tuple(i + 1 for i in rest)}")


def _failed(family, name, main, x, Pm, s, rest, psi, reason, pitch=0.0):
    row = {"family": family, "variant": 0, "order": _order(family, name, main, x, Pm, s, rest,
                                                             psi),
           "arrangement": name, "transition": x + "S", "main_link": main,
           "main_positions": str(tuple(p + 1 for p in Pm)), "transition_position": s + 1,
           "azimuth": float(psi), "residual": np.nan, "reason": reason}
    nan_geometry(row, family)
    for k, t in enumerate(family, start=1):
        if t == "H":
            row[f"j{k}_pitch"] = pitch
    return row


ARRANGEMENTS = sphere_arrangements
BUILD = sphere_family_dyads
