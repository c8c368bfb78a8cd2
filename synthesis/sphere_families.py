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

from .binary import _screw_matrix
from .decompose import angle_grid, nan_geometry, task_positions
from .errors import SynthesisError
from .screw import Line
from .validate import number
from .verify import verify_points

__all__ = ["sphere_arrangements", "sphere_family_dyads", "SPHERE_MAIN_POSITIONS"]

#: main link → positions; transition joint → remaining positions it carries
SPHERE_MAIN_POSITIONS = {"RS": 4, "PS": 3, "HS": 4}
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


def _circle(p1, p2, p3):
    from .dyads import circle_axis
    return circle_axis(p1, p2, p3)


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
    from .dyads import _canonical_chain, _row
    from .spherical import hs_links, ps_links, rs_links_at, task_frame
    T, N, arr, reach = task_positions(family, screws, sphere_arrangements)
    ph = _helical_pitch(family, pitch)
    psis = angle_grid(azimuth, "azimuth", DEFAULT_AZIMUTHS)
    frame = task_frame(screws)
    rows, chains = [], []
    cache = {}
    types = family[:2]
    pitches = [ph if t == "H" else 0.0 for t in types]
    for name, main, x, n_b, k in arr:
        for others in itertools.combinations(range(1, N), n_b - 1):
            Pm = (0,) + others
            rest = [i for i in range(N) if i not in Pm]
            for psi in psis:
                key = (main, Pm, float(psi))
                if key not in cache:
                    sub = [screws[i - 1] for i in others]
                    try:
                        if main == "RS":
                            links = rs_links_at(sub, float(psi), frame=frame)
                        elif main == "PS":
                            links = ps_links(sub, float(psi), frame=frame)
                        else:
                            links = hs_links(sub, ph, float(psi), frame=frame)
                        cache[key] = (links, "")
                    except SynthesisError as e:
                        cache[key] = ([], _renumbered(str(e), others))
                links, err = cache[key]
                if not links:
                    reason = err or f"no real {main} link on the circle of this azimuth"
                    for s in Pm:
                        rows.append(_failed(family, name, main, x, Pm, s, rest, psi, reason,
                                            ph))
                    continue
                for m_i, lk in enumerate(links):
                    C = lk.moving_axis.point
                    Cs = T[:, :3, :3] @ C + T[:, :3, 3]
                    fv = lk.fixed_slides if main == "PS" else lk.fixed_angles
                    for si, s in enumerate(Pm):
                        base = (family, name, main, x, Pm, s, rest, psi)
                        try:
                            if x == "R":
                                ax, angs = _circle(Cs[s], Cs[rest[0]], Cs[rest[1]])
                                xv = list(angs)
                            else:
                                d = Cs[rest[0]] - Cs[s]
                                if np.linalg.norm(d) < 1e-12 * reach:
                                    raise SynthesisError("prismatic axis: the sphere centre does "
                                                         f"not move from position {s + 1} to "
                                                         f"{rest[0] + 1}")
                                ax = Line(d / np.linalg.norm(d), Cs[s]).canonical()
                                xv = [float(np.linalg.norm(d))]
                        except SynthesisError as e:
                            rows.append(_failed(*base, str(e), ph))
                            continue
                        jv = np.zeros((N, 2))
                        X, F = (0, 1) if name == "a" else (1, 0)
                        for i, p in enumerate(Pm):
                            jv[p, F] = fv[i]
                        for j, l in enumerate(rest):
                            jv[l, X], jv[l, F] = xv[j], fv[si]
                        Fl = lk.fixed_axis
                        if name == "a":
                            lines = [ax, Fl]
                        else:                     # the main fixed joint's screw at s, undone
                            G = _screw_matrix(Fl.direction, Fl.point,
                                              0.0 if main == "PS" else fv[si],
                                              {"RS": 0.0, "PS": fv[si], "HS": ph * fv[si]}[main])
                            lines = [Fl, ax.transformed(np.linalg.inv(G))]
                        lines = _canonical_chain(lines)
                        centre = Line(np.array([0, 0, 1.0]), C)
                        row = _row(family, 0, _order(*base), family.replace("H", "R"),
                                   lines + [centre], np.nan, arrangement=name,
                                   transition=x + "S", main_link=main,
                                   main_positions=str(tuple(p + 1 for p in Pm)),
                                   transition_position=s + 1, member=m_i,
                                   azimuth=float(psi),
                                   elevation=float(lk.parameters.get("elevation", np.nan)),
                                   joint_values=np.c_[jv, np.full(N, np.nan)])
                        for kk, t in enumerate(family):
                            row[f"j{kk + 1}_type"] = t
                            row[f"j{kk + 1}_pitch"] = {"R": 0.0, "P": np.inf, "H": ph}.get(
                                t, np.nan)
                        for c in ("ux", "uy", "uz"):
                            row[f"j3_{c}"] = np.nan
                        for p in range(N):
                            for kk, t in enumerate(types):
                                row[f"d{kk + 1}_pos{p + 1}"] = \
                                    {"P": jv[p, kk], "H": ph * jv[p, kk]}.get(t, 0.0)
                        rows.append(row)
                        chains.append((len(rows) - 1, (types, lines, jv, C, pitches)))
    res = verify_points([c for _, c in chains], T, reach)
    for (i, _), r in zip(chains, res):
        rows[i]["residual"] = float(r)
    for v, row in enumerate(rows, start=1):
        row["variant"] = v
    return rows


def _order(family, name, main, x, Pm, s, rest, psi):
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
