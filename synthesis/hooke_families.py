"""Dyad families with a Hooke joint (Kharatyan's С₂, a universal joint U) before an R or P
body joint: RUR, URR (Table 3, row 11) and RUP, URP (row 12), by the table's
decomposition with the main link's free parameters explicit.

The main link is UR (four positions, :func:`synthesis.hooke.ur_links`, free parameter
``azimuth``: the revolute axis direction on that great circle of the task's reference
frame) or UP (three positions, :func:`synthesis.hooke.up_links`: ``azimuth`` of the slide
direction in the body and ``axis_azimuth`` of the U joint's first axis).  An R joint then
carries joint 3 from the transition position s to the remaining position
(:mod:`synthesis.transition`): joint 1 in arrangement (a) (RUR, RUP), joint 2 in (b) (URR,
URP: its position-1 axis is the transition axis turned back about the centre by the U
joint's rotation at s).  So the construction reaches one position more than the table
prints (UR through 4 + 1 = 5 for RUR, URR; UP through 3 + 1 = 4 for RUP, URP).

A U joint (centre O, first axis a in the ground-side link, cross axis b ⊥ a turning with
the first angle α) turns the next link by ``Rot(a, α) Rot(b, γ)`` about O; the engine's U
joint is the same with its frame's z along a and x along b, so every variant is driven
through all positions by the engine (one mechanism, one batched call).  In the table the U
joint's row holds a (``j{k}_ux…``), O (``j{k}_x…``), b (``u_cross_x, u_cross_y,
u_cross_z``) and the angles (``q{k}_pos{p}`` = α, ``d{k}_pos{p}`` = γ).
"""
from __future__ import annotations

import itertools

import numpy as np

from closure import Mechanism

from .decompose import angle_grid, nan_geometry, task_positions
from .errors import SynthesisError
from .screw import Line
from .transition import transition_joint
from .verify import _frames_of, pose_errors

__all__ = ["hooke_arrangements", "hooke_family_dyads"]

_MAIN = {"UR": 4, "UP": 3}
DEFAULT_AZIMUTHS = np.arange(4) * np.pi / 4
DEFAULT_AXIS_AZIMUTHS = np.array([np.pi / 6, 2 * np.pi / 3])
#: family → (positions, free parameters, note for :func:`synthesis.families`)
FAMILIES = {"RUR": (5, ("azimuth",), ""), "URR": (5, ("azimuth",), ""),
            "RUP": (4, ("azimuth", "axis_azimuth"), ""),
            "URP": (4, ("azimuth", "axis_azimuth"), "")}


def hooke_arrangements(family: str, n_positions: int | None = None) -> list[tuple]:
    """``(name, main, transition kind, n_b, k)`` for RUR, RUP (a) and URR, URP (b)."""
    out = []
    if len(family) != 3:
        return out
    for name, main, x in (("a", family[1:], family[0]), ("b", family[0] + family[2], family[1])):
        if main in _MAIN and x == "R" and family[2] in "RP":
            n = _MAIN[main] + 1
            if n_positions is None or n == n_positions:
                out.append((name, main, x, _MAIN[main], 1))
    return out


def _u_frame(a, b, O):
    F = np.eye(4)
    F[:3, 0], F[:3, 1], F[:3, 2], F[:3, 3] = b, np.cross(a, b), a, O
    return F


def _about(R, O):
    S = np.eye(4)
    S[:3, :3], S[:3, 3] = R, O - R @ O
    return S


def _rot(u, ang):
    K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return np.eye(3) + np.sin(ang) * K + (1 - np.cos(ang)) * K @ K


def verify_hooke(chains, targets, length: float) -> np.ndarray:
    """Pose errors of chains with a U joint, driven by the engine in one batched call.

    chains : list of (types, joints, values): ``joints`` per joint a Line (R, P) or
    ``(a, b, O)`` (U); ``values (P, 3, 2)``: angle or slide of R/P joints in slot 0 / 1,
    (α, γ) of the U joint.
    """
    if not chains:
        return np.zeros(0)
    T = np.asarray(targets, float)
    plain = [j for types, joints, _ in chains for t, j in zip(types, joints) if t != "U"]
    pf = iter(_frames_of(plain))
    m = Mechanism()
    cols = []
    for v, (types, joints, vals) in enumerate(chains):
        names = ["ground", f"A{v}", f"B{v}", f"body{v}"]
        for n in names[1:]:
            m.add_link(n)
        for k, (t, j) in enumerate(zip(types, joints)):
            jn = f"v{v}j{k + 1}"
            frame = _u_frame(*j) if t == "U" else next(pf)
            m.add_joint(jn, t, names[k], names[k + 1], at=frame, validate=False)
            m.add_input(jn, 0)
            if t == "U":
                m.add_input(jn, 1)
                cols += [vals[:, k, 0], vals[:, k, 1]]
            else:
                cols.append(vals[:, k, 1] if t == "P" else vals[:, k, 0])
    pose = m.solve(np.stack(cols, 1), continuation=False)
    link = pose.kinematics(twists=False)["link"]
    bodies = link[:, [m.links.index(f"body{v}") for v in range(len(chains))]]
    rot, pos = pose_errors(bodies, T[:, None], length)
    return np.maximum(rot.max(0), pos.max(0))


def hooke_family_dyads(family: str, screws, *, azimuth=None, axis_azimuth=None) -> list[dict]:
    """Rows (dicts) of every variant of RUR, URR, RUP or URP; see the module notes and
    :func:`synthesis.enumerate_dyads` (``azimuth``, ``axis_azimuth``: rad, defaults
    0, π/4, π/2, 3π/4 and π/6, 2π/3)."""
    from .decompose import _flipped
    from .hooke import up_links, ur_links
    from .spherical import task_frame
    T, N, arr, reach = task_positions(family, screws, hooke_arrangements)
    if axis_azimuth is not None and family[2] != "P":
        raise SynthesisError(f"axis_azimuth: not a free parameter of family {family} (only of "
                             "RUP, URP)")
    psis = angle_grid(azimuth, "azimuth", DEFAULT_AZIMUTHS)
    chis = angle_grid(axis_azimuth, "axis_azimuth", DEFAULT_AXIS_AZIMUTHS) if family[2] == "P" \
        else [None]
    frame = task_frame(screws)
    y = family[2]
    rows, chains = [], []
    for name, main, x, n_b, k in arr:
        for others in itertools.combinations(range(1, N), n_b - 1):
            Pm = (0,) + others
            rest = [i for i in range(N) if i not in Pm]
            scr = [screws[i - 1] for i in others]
            for psi, chi in itertools.product(psis, chis):
                params = {"azimuth": float(psi)}
                if chi is not None:
                    params["axis_azimuth"] = float(chi)
                try:
                    links = (ur_links(scr, azimuth=float(psi), frame=frame) if main == "UR" else
                             up_links(scr, slide_azimuth=float(psi), axis_azimuth=float(chi),
                                      frame=frame))
                    err = ""
                except SynthesisError as e:
                    links, err = [], str(e)
                if not links:
                    for s in Pm:
                        rows.append(_failed(family, name, main, Pm, s, rest, params,
                                            err or f"no real {main} link at these parameters"))
                    continue
                for lk in links:
                    a, O, b = lk.fixed_axis.direction, lk.fixed_axis.point, lk.cross_axis
                    al, ga = lk.fixed_angles, lk.cross_angles
                    M = lk.moving_axis
                    mv = lk.moving_angles if y == "R" else lk.moving_slides
                    if _flipped(M.direction):
                        M, mv = Line._exact(-M.direction, M.point), -mv
                    for si, s in enumerate(Pm):
                        Ts = T[s]
                        yl = Line._exact(Ts[:3, :3] @ M.direction, Ts[:3, :3] @ M.point + Ts[:3, 3])
                        try:
                            (tr,) = transition_joint("R", y, yl, 0.0,
                                                     (T[rest[0]] @ np.linalg.inv(Ts))[None], reach)
                        except SynthesisError as e:
                            rows.append(_failed(family, name, main, Pm, s, rest, params, str(e)))
                            continue
                        vals = np.zeros((N, 3, 2))
                        U, X = (1, 0) if name == "a" else (0, 1)
                        for i, p in enumerate(Pm):
                            vals[p, U] = al[i], ga[i]
                            vals[p, 2, 0 if y == "R" else 1] = mv[i]
                        l = rest[0]
                        vals[l, U] = al[si], ga[si]
                        vals[l, X, 0] = tr.psi[0, 0]
                        vals[l, 2, 0 if y == "R" else 1] = mv[si] + (
                            tr.delta[0, 0] if y == "R" else tr.delta[0, 1])
                        if name == "a":
                            Xl = tr.line.canonical()
                        else:
                            G = np.linalg.inv(_about(_rot(a, al[si]) @ _rot(b, ga[si]), O))
                            Xl = Line._exact(G[:3, :3] @ tr.line.direction,
                                             G[:3, :3] @ tr.line.point + G[:3, 3])
                            Xl = Line._exact(Xl.direction, Xl.foot_from(O))
                        if _flipped(Xl.direction):
                            Xl = Line._exact(-Xl.direction, Xl.point)
                            vals[:, X, 0] *= -1
                        M3 = M.canonical(Xl) if name == "b" else Line._exact(M.direction,
                                                                            M.foot_from(O))
                        joints = [Xl, (a, b, O), M3] if name == "a" else [(a, b, O), Xl, M3]
                        row = _row(family, name, main, Pm, s, rest, params, joints, vals)
                        rows.append(row)
                        chains.append((len(rows) - 1, (family, joints, vals)))
    res = verify_hooke([c for _, c in chains], T, reach)
    for (i, _), r in zip(chains, res):
        rows[i]["residual"] = float(r)
    for v, row in enumerate(rows, start=1):
        row["variant"] = v
    return rows


def _base(family, name, main, Pm, s, rest, params):
    row = {"family": family, "variant": 0,
           "order": (f"{main} through {tuple(p + 1 for p in Pm)}; R "
                     f"({'J1' if name == 'a' else 'J2'}) carries position {s + 1} to "
                     f"{tuple(i + 1 for i in rest)}"),
           "arrangement": name, "transition": "R" + family[2]}
    return row


def _tail(row, main, Pm, s, params):
    row.update(main_link=main, main_positions=str(tuple(p + 1 for p in Pm)),
               transition_position=s + 1, **params)


def _row(family, name, main, Pm, s, rest, params, joints, vals):
    row = _base(family, name, main, Pm, s, rest, params)
    for k, (t, j) in enumerate(zip(family, joints), start=1):
        row[f"j{k}_type"] = t
        u, p = (j[0], j[2]) if t == "U" else (j.direction, j.point)
        row[f"j{k}_ux"], row[f"j{k}_uy"], row[f"j{k}_uz"] = u
        row[f"j{k}_x"], row[f"j{k}_y"], row[f"j{k}_z"] = p
        row[f"j{k}_pitch"] = {"R": 0.0, "P": np.inf}.get(t, np.nan)
        if t == "U":
            row["u_cross_x"], row["u_cross_y"], row["u_cross_z"] = j[1]
    row["residual"] = np.nan
    row["reason"] = ""
    _tail(row, main, Pm, s, params)
    for p in range(len(vals)):
        for k, t in enumerate(family):
            a, sl = vals[p, k]
            row[f"q{k + 1}_pos{p + 1}"] = sl if t == "P" else a
            row[f"d{k + 1}_pos{p + 1}"] = sl
    return row


def _failed(family, name, main, Pm, s, rest, params, reason):
    row = _base(family, name, main, Pm, s, rest, params)
    nan_geometry(row, family)
    row["residual"] = np.nan
    row["reason"] = reason
    _tail(row, main, Pm, s, params)
    return row


ARRANGEMENTS = hooke_arrangements
BUILD = hooke_family_dyads
