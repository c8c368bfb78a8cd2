"""Sphere-ended dyad families (joint 3 spherical: RRS, PRS, RPS) by Kharatyan's
decomposition, with the main link's free parameter explicit.

The main link is RS (four positions) or PS (three positions), its fixed axis (or slide)
direction on the great circle of ``azimuth`` ψ in the task's reference frame
(:func:`synthesis.spherical.task_frame` of all the screws; :func:`synthesis.spherical.
azimuth_of` reads ψ off a direction).  The transition joint then carries the sphere centre
C from its position at the transition position s to the remaining ones: an R joint through
two remaining positions (the axis of the circle through the three positions of C), a P
joint through one (the slide along C_l − C_s).  Arrangement (a): the transition joint is
joint 1 (in the ground); (b): joint 2, whose position-1 axis is the transition axis moved
back by the main fixed joint's value at s.  A sphere leaves the orientation free, so the
variants are verified through the centre (:func:`synthesis.verify.verify_points`: joints 1
and 2 driven by the engine, one batched call).
"""
from __future__ import annotations

import itertools

import numpy as np

from .binary import _screw_matrix
from .decompose import angle_grid, nan_geometry, task_positions
from .errors import SynthesisError
from .screw import Line
from .verify import verify_points

__all__ = ["sphere_arrangements", "sphere_family_dyads", "SPHERE_MAIN_POSITIONS"]

#: main link → positions; transition joint → remaining positions it carries
SPHERE_MAIN_POSITIONS = {"RS": 4, "PS": 3}
_TRANS = {"R": 2, "P": 1}
#: default azimuth grid (rad)
DEFAULT_AZIMUTHS = np.arange(4) * np.pi / 4
#: family → (positions, free parameters, note for :func:`synthesis.families`)
FAMILIES = {"RRS": (6, ("azimuth",), ""), "PRS": (5, ("azimuth",), ""),
            "RPS": (5, ("azimuth",), "")}


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


def sphere_family_dyads(family: str, screws, *, azimuth=None) -> list[dict]:
    """Rows (dicts) of every variant of a sphere-ended family; see
    :func:`synthesis.enumerate_dyads`.

    Parameters
    ----------
    family : str
        ``"RRS"``, ``"PRS"`` or ``"RPS"``.
    screws : list of Screw
    azimuth : float or array_like, optional
        ψ (rad) of the main link's fixed axis (slide) direction; default 0, π/4, π/2, 3π/4.
    """
    from .dyads import _canonical_chain, _row
    from .spherical import ps_links, rs_links_at, task_frame
    T, N, arr, reach = task_positions(family, screws, sphere_arrangements)
    psis = angle_grid(azimuth, "azimuth", DEFAULT_AZIMUTHS)
    frame = task_frame(screws)
    rows, chains = [], []
    cache = {}
    for name, main, x, n_b, k in arr:
        for others in itertools.combinations(range(1, N), n_b - 1):
            Pm = (0,) + others
            rest = [i for i in range(N) if i not in Pm]
            for psi in psis:
                key = (main, Pm, float(psi))
                if key not in cache:
                    fn = rs_links_at if main == "RS" else ps_links
                    try:
                        cache[key] = (fn([screws[i - 1] for i in others], float(psi),
                                         frame=frame), "")
                    except SynthesisError as e:
                        cache[key] = ([], str(e))
                links, err = cache[key]
                if not links:
                    reason = err or f"no real {main} link on the circle of this azimuth"
                    for s in Pm:
                        rows.append(_failed(family, name, main, x, Pm, s, rest, psi, reason))
                    continue
                for m_i, lk in enumerate(links):
                    C = lk.moving_axis.point
                    Cs = T[:, :3, :3] @ C + T[:, :3, 3]
                    fv = lk.fixed_angles if main == "RS" else lk.fixed_slides
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
                            rows.append(_failed(*base, str(e)))
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
                        else:
                            G = _screw_matrix(Fl.direction, Fl.point,
                                              fv[si] if main == "RS" else 0.0,
                                              fv[si] if main == "PS" else 0.0)
                            lines = [Fl, ax.transformed(np.linalg.inv(G))]
                        lines = _canonical_chain(lines)
                        centre = Line(np.array([0, 0, 1.0]), C)
                        types = family[:2]
                        row = _row(family, 0, _order(*base), family, lines + [centre], np.nan,
                                   arrangement=name, transition=x + "S", main_link=main,
                                   main_positions=str(tuple(p + 1 for p in Pm)),
                                   transition_position=s + 1, member=m_i,
                                   azimuth=float(psi),
                                   elevation=float(lk.parameters.get("elevation", np.nan)),
                                   joint_values=np.c_[jv, np.full(N, np.nan)])
                        for c in ("ux", "uy", "uz"):
                            row[f"j3_{c}"] = np.nan
                        for p in range(N):
                            for kk, t in enumerate(types):
                                row[f"d{kk + 1}_pos{p + 1}"] = jv[p, kk] if t == "P" else 0.0
                        rows.append(row)
                        chains.append((len(rows) - 1, (types, lines, jv, C)))
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


def _failed(family, name, main, x, Pm, s, rest, psi, reason):
    row = {"family": family, "variant": 0, "order": _order(family, name, main, x, Pm, s, rest,
                                                             psi),
           "arrangement": name, "transition": x + "S", "main_link": main,
           "main_positions": str(tuple(p + 1 for p in Pm)), "transition_position": s + 1,
           "azimuth": float(psi), "residual": np.nan, "reason": reason}
    return nan_geometry(row, family)


ARRANGEMENTS = sphere_arrangements
BUILD = sphere_family_dyads
