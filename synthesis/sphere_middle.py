"""Dyad families with a spherical joint before the body joint (RSR, SRR, RSP, SRP) by
Kharatyan's decomposition (1981, Table 3, rows 9 and 10), the main link's free parameter
explicit.

The main link is SR (four positions) or SP (three): the sphere centre O in the ground (or
on joint 1's link), the revolute axis (slide direction) in the body, on the great circle
of ``azimuth`` ψ in the task's reference frame (:func:`synthesis.spherical.sr_links`,
:func:`synthesis.spherical.sp_links` with :func:`synthesis.spherical.task_frame` of all
the screws).  Joint 3 (R or P) is then carried from the transition position s to the
remaining position by an R joint (:mod:`synthesis.transition`: R carrying R or P, one
position): joint 1 in arrangement (a) (RSR, RSP), joint 2 in (b) (SRR, SRP, whose
position-1 axis is the transition axis turned back about O by the sphere's rotation at s).

A spherical joint cannot be driven, so the variants are verified by splitting the chain
at the sphere: the engine moves O with the joints before it (from the ground) and with
the joints after it taken backwards from the body (their values negated, the body at
each given pose); the two positions of O must coincide (then a sphere rotation exists).
All variants hang from one mechanism, one batched call.
"""
from __future__ import annotations

import itertools

import numpy as np

from closure import Mechanism

from .decompose import angle_grid, nan_geometry, task_positions
from .errors import SynthesisError
from .screw import Line
from .transition import transition_joint
from .verify import _frames_of

__all__ = ["middle_arrangements", "sphere_middle_dyads", "verify_split"]

_MAIN = {"SR": 4, "SP": 3}
DEFAULT_AZIMUTHS = np.arange(4) * np.pi / 4
#: family → (positions, free parameters, note for :func:`synthesis.families`)
FAMILIES = {"RSR": (5, ("azimuth",), ""), "SRR": (5, ("azimuth",), ""),
            "RSP": (4, ("azimuth",), ""), "SRP": (4, ("azimuth",), "")}


def middle_arrangements(family: str, n_positions: int | None = None) -> list[tuple]:
    """``(name, main, transition kind, n_b, k)`` for RSR, RSP (a) and SRR, SRP (b)."""
    out = []
    if len(family) != 3:
        return out
    for name, main, x in (("a", family[1:], family[0]), ("b", family[0] + family[2], family[1])):
        if main in _MAIN and x == "R" and family[2] in "RP":
            n = _MAIN[main] + 1
            if n_positions is None or n == n_positions:
                out.append((name, main, x, _MAIN[main], 1))
    return out


def verify_split(chains, targets, length: float) -> np.ndarray:
    """Centre errors of chains with a sphere: each chain is ``(before, after, O)`` with
    ``before`` and ``after`` lists of ``(kind, Line, values (P,))`` (joints before the
    sphere from the ground; after it, from the sphere to the body), ``O`` the centre in
    position 1.  Returns max_p |O moved by ``before`` − T_p · (O moved back by ``after``)|
    / ``length`` per chain, both sides driven by the engine in one batched call."""
    if not chains:
        return np.zeros(0)
    T = np.asarray(targets, float)
    m = Mechanism()
    lines = [ln for before, after, _ in chains for _, ln, _ in before + after[::-1]]
    cols = []
    frames = iter(_frames_of(lines)) if lines else iter(())
    names = []
    for v, (before, after, O) in enumerate(chains):
        pair = []
        for side, joints, sign in (("g", before, 1.0), ("b", after[::-1], -1.0)):
            prev = "ground"
            for j, (kind, ln, vals) in enumerate(joints):
                link = f"{side}{v}_{j}"
                m.add_link(link)
                jn = f"{side}{v}j{j}"
                m.add_joint(jn, kind, prev, link, at=next(frames), validate=False)
                m.add_input(jn, 0)
                cols.append(sign * np.asarray(vals, float))
                prev = link
            pair.append(prev)
        names.append(pair)
    if cols:
        pose = m.solve(np.stack(cols, 1), continuation=False)
    err = []
    for (before, after, O), (g, b) in zip(chains, names):
        pg = np.broadcast_to(O, (len(T), 3)) if g == "ground" else \
            np.atleast_2d(pose.point(g, O))
        pb = np.broadcast_to(O, (len(T), 3)) if b == "ground" else \
            np.atleast_2d(pose.point(b, O))
        pb = np.einsum("pij,pj->pi", T[:, :3, :3], pb) + T[:, :3, 3]
        err.append(np.linalg.norm(pg - pb, axis=1).max() / length)
    return np.array(err)


def _rot_about(O, R):
    S = np.eye(4)
    S[:3, :3], S[:3, 3] = R, O - R @ O
    return S


def sphere_middle_dyads(family: str, screws, *, azimuth=None) -> list[dict]:
    """Rows (dicts) of every variant of RSR, SRR, RSP or SRP; see
    :func:`synthesis.enumerate_dyads` (``azimuth``: rad, the main link's moving axis or
    slide direction on that great circle; default 0, π/4, π/2, 3π/4)."""
    from .decompose import _flipped
    from .spherical import sp_links, sr_links, task_frame
    T, N, arr, reach = task_positions(family, screws, middle_arrangements)
    psis = angle_grid(azimuth, "azimuth", DEFAULT_AZIMUTHS)
    frame = task_frame(screws)
    rows, chains = [], []
    y_kind = family[2]
    for name, main, x, n_b, k in arr:
        for others in itertools.combinations(range(1, N), n_b - 1):
            Pm = (0,) + others
            rest = [i for i in range(N) if i not in Pm]
            for psi in psis:
                fn = sr_links if main == "SR" else sp_links
                try:
                    links, err = fn([screws[i - 1] for i in others], float(psi), frame=frame), ""
                except SynthesisError as e:
                    links, err = [], str(e)
                if not links:
                    for s in Pm:
                        rows.append(_failed(family, name, main, Pm, s, rest, psi,
                                            err or f"no real {main} link on this azimuth"))
                    continue
                for m_i, lk in enumerate(links):
                    O = lk.fixed_axis.point
                    M = lk.moving_axis
                    mv = lk.moving_angles if y_kind == "R" else lk.moving_slides
                    if _flipped(M.direction):
                        M, mv = Line._exact(-M.direction, M.point), -mv
                    Srot = lk.sphere_rotations
                    for si, s in enumerate(Pm):
                        Ts = T[s]
                        y_line = Line._exact(Ts[:3, :3] @ M.direction,
                                             Ts[:3, :3] @ M.point + Ts[:3, 3])
                        try:
                            (tr,) = transition_joint("R", y_kind, y_line, 0.0,
                                                     (T[rest[0]] @ np.linalg.inv(Ts))[None], reach)
                        except (SynthesisError, ValueError) as e:
                            rows.append(_failed(family, name, main, Pm, s, rest, psi, str(e)))
                            continue
                        q3 = np.zeros(N)
                        qx = np.zeros(N)
                        for i, p in enumerate(Pm):
                            q3[p] = mv[i]
                        l = rest[0]
                        qx[l] = tr.psi[0, 0]
                        q3[l] = mv[si] + (tr.delta[0, 0] if y_kind == "R" else tr.delta[0, 1])
                        if name == "a":
                            X = tr.line
                        else:
                            G = _rot_about(O, Srot[si])
                            Gi = np.linalg.inv(G)
                            X = Line._exact(Gi[:3, :3] @ tr.line.direction,
                                            Gi[:3, :3] @ tr.line.point + Gi[:3, 3])
                        if name == "a":                   # feet: from the origin, the centre
                            X = X.canonical()
                            M3 = Line._exact(M.direction, M.foot_from(O))
                        else:
                            X = Line._exact(X.direction, X.foot_from(O))
                            M3 = M.canonical(X)
                        if _flipped(X.direction):
                            X, qx = Line._exact(-X.direction, X.point), -qx
                        if name == "a":
                            before, after = [("R", X, qx)], [(y_kind, M3, q3)]
                            lines = [X, None, M3]
                        else:
                            before, after = [], [("R", X, qx), (y_kind, M3, q3)]
                            lines = [None, X, M3]
                        row = _row(family, name, main, Pm, s, rest, psi, lines, O, m_i,
                                   lk.parameters.get("elevation", np.nan))
                        for p in range(N):
                            vals = [qx[p], np.nan, q3[p]] if name == "a" else \
                                [np.nan, qx[p], q3[p]]
                            for kk in range(3):
                                row[f"q{kk + 1}_pos{p + 1}"] = vals[kk]
                                row[f"d{kk + 1}_pos{p + 1}"] = vals[kk] if family[kk] == "P" \
                                    else (0.0 if family[kk] == "R" else np.nan)
                        rows.append(row)
                        chains.append((len(rows) - 1, (before, after, O)))
    res = verify_split([c for _, c in chains], T, reach)
    for (i, _), r in zip(chains, res):
        rows[i]["residual"] = float(r)
    for v, row in enumerate(rows, start=1):
        row["variant"] = v
    return rows


def _order(name, main, Pm, s, rest):
    return (f"{main} through {tuple(p + 1 for p in Pm)}; R ({'J1' if name == 'a' else 'J2'}) "
            f"carries position {s + 1} to {tuple(i + 1 for i in rest)}")


def _base(family, name, main, Pm, s, rest, psi):
    row = {"family": family, "variant": 0, "order": _order(name, main, Pm, s, rest),
           "arrangement": name, "transition": "R" + family[2]}
    return row


def _tail(row, family, main, Pm, s, psi):
    row.update(main_link=main, main_positions=str(tuple(p + 1 for p in Pm)),
               transition_position=s + 1, azimuth=float(psi))


def _row(family, name, main, Pm, s, rest, psi, lines, O, member, elevation):
    row = _base(family, name, main, Pm, s, rest, psi)
    for k, (t, ln) in enumerate(zip(family, lines), start=1):
        row[f"j{k}_type"] = t
        if ln is None:                                         # the sphere: a centre only
            row[f"j{k}_ux"] = row[f"j{k}_uy"] = row[f"j{k}_uz"] = np.nan
            row[f"j{k}_x"], row[f"j{k}_y"], row[f"j{k}_z"] = O
        else:
            row[f"j{k}_ux"], row[f"j{k}_uy"], row[f"j{k}_uz"] = ln.direction
            row[f"j{k}_x"], row[f"j{k}_y"], row[f"j{k}_z"] = ln.point
        row[f"j{k}_pitch"] = {"R": 0.0, "P": np.inf}.get(t, np.nan)
    row["residual"] = np.nan
    row["reason"] = ""
    _tail(row, family, main, Pm, s, psi)
    row["member"] = member
    row["elevation"] = float(elevation)
    return row


def _failed(family, name, main, Pm, s, rest, psi, reason):
    row = _base(family, name, main, Pm, s, rest, psi)
    nan_geometry(row, family)
    row["residual"] = np.nan
    row["reason"] = reason
    _tail(row, family, main, Pm, s, psi)
    return row


ARRANGEMENTS = middle_arrangements
BUILD = sphere_middle_dyads
