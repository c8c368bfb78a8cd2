"""Dyad families with a Hooke joint (Kharatyan's С₂, a universal joint U) before the body
joint: RUR, URR (Table 3, row 11), RUP, URP (row 12), RUH (row 6), URH (row 7) and RUC,
URC (row 9), by the table's decomposition with the main link's free parameters explicit.

The main link is UR or UH (four positions, :func:`synthesis.hooke.ur_links`,
:func:`synthesis.hooke.uh_links`, free parameter ``azimuth``: the body joint's axis
direction on that great circle of the task's reference frame; UH with the helical
joint's ``pitch`` given), UP (three positions, :func:`synthesis.hooke.up_links`:
``azimuth`` of the slide direction in the body and ``axis_azimuth`` of the U joint's first
axis) or UC (four positions, :func:`synthesis.hooke.uc_links`: the U joint's ``centre`` and
the ``azimuth`` of the cylinder axis).  An R joint then carries joint 3 from the
transition position s to the remaining position (:mod:`synthesis.transition`): joint 1 in
arrangement (a) (RUR, RUP, RUH, RUC), joint 2 in (b) (URR, URP, URH, URC: its position-1
axis is the transition axis turned back about the centre by the U joint's rotation at
s).  R carrying H has several roots (column ``root``); R carrying C has J3's rotation
free (``transition_angle``, rad).  So the construction reaches UR, UH, UC through
4 + 1 = 5 positions and UP through 3 + 1 = 4.  Table 3 prints N = 4 for RUR, URR, RUH,
URH (the main link through one position fewer, with more free parameters), 3 for RUP, URP
and 5 for RUC, URC (as here).

A U joint (centre O, first axis a in the ground-side link, cross axis b ⊥ a turning with
the first angle α) turns the next link by ``Rot(a, α) Rot(b, γ)`` about O; the engine's U
joint is the same with its frame's z along a and x along b, so every variant is driven
through all positions by the engine (one mechanism, one batched call).  In the table the U
joint's row holds a (``j{k}_ux…``), O (``j{k}_x…``), b (``u_cross_x, u_cross_y,
u_cross_z``) and the angles (``q{k}_pos{p}`` = α, ``d{k}_pos{p}`` = γ); the other joints'
``q`` is the driven coordinate (angle, or a P joint's slide) and ``d`` the slide along the
axis (pitch · angle for H, free for C).
"""
from __future__ import annotations

import itertools

import numpy as np

from closure import Mechanism

from .decompose import _grid_numbers, angle_grid, nan_geometry, task_positions
from .errors import SynthesisError
from .screw import Line
from .transition import transition_joint
from .validate import array
from .verify import _frames_of, in_chunks, pose_errors

__all__ = ["hooke_arrangements", "hooke_family_dyads"]

#: main link → positions it is synthesised through
_MAIN = {"UR": 4, "UP": 3, "UH": 4, "UC": 4}
DEFAULT_AZIMUTHS = np.arange(4) * np.pi / 4
DEFAULT_AXIS_AZIMUTHS = np.array([np.pi / 6, 2 * np.pi / 3])
#: default UC centres: the task's centre moved by half its reach along e1, e2, e3 of the
#: task's reference frame (so the grid moves with the task)
DEFAULT_CENTRE_OFFSETS = 0.5 * np.eye(3)
DEFAULT_TRANSITION_ANGLES = np.array([-1.0, 1.0])

_N_NOTE = ("the {l} link implemented is through {m} positions (its maximum with isolated "
           "solutions{p}), so the construction reaches N = {n}, one more than printed; the "
           "printed N = {k} would leave the {l} link through one position fewer, with more "
           "free parameters")
_H = " with the pitch given, the choice pitch"
#: family → (positions, free parameters, note for :func:`synthesis.families`)
FAMILIES = {
    "RUR": (5, ("azimuth",), _N_NOTE.format(l="UR", m=4, n=5, k=4, p="")),
    "URR": (5, ("azimuth",), _N_NOTE.format(l="UR", m=4, n=5, k=4, p="")),
    "RUP": (4, ("azimuth", "axis_azimuth"), _N_NOTE.format(l="UP", m=3, n=4, k=3, p="")),
    "URP": (4, ("azimuth", "axis_azimuth"), _N_NOTE.format(l="UP", m=3, n=4, k=3, p="")),
    "RUH": (5, ("azimuth", "pitch"), _N_NOTE.format(l="UH", m=4, n=5, k=4, p=_H)),
    "URH": (5, ("azimuth", "pitch"), _N_NOTE.format(l="UH", m=4, n=5, k=4, p=_H)),
    "RUC": (5, ("azimuth", "centre", "transition_angle"), ""),
    "URC": (5, ("azimuth", "centre", "transition_angle"), ""),
}


def hooke_arrangements(family: str, n_positions: int | None = None) -> list[tuple]:
    """``(name, main, transition kind, n_b, k)``: (a) for RU·, (b) for UR· families."""
    out = []
    if len(family) != 3:
        return out
    for name, main, x in (("a", family[1:], family[0]), ("b", family[0] + family[2], family[1])):
        if main in _MAIN and x == "R" and family[2] in "RPHC":
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


#: the engine coordinates each joint kind is driven by: slot 0 (angle) and / or 1 (slide)
_SLOTS = {"R": (0,), "H": (0,), "P": (1,), "C": (0, 1), "U": (0, 1)}


@in_chunks
def verify_hooke(chains, targets, length: float) -> np.ndarray:
    """Pose errors of chains with a U joint, driven by the engine in one batched call.

    chains : list of (types, joints, values, pitch): ``joints`` per joint a Line (R, P, H,
    C) or ``(a, b, O)`` (U); ``values (P, 3, 2)``: (angle, slide) of R, P, H, C joints, (α,
    γ) of the U joint; ``pitch`` (length/rad) of an H joint.
    """
    if not chains:
        return np.zeros(0)
    T = np.asarray(targets, float)
    plain = [j for types, joints, *_ in chains for t, j in zip(types, joints) if t != "U"]
    pf = iter(_frames_of(plain))
    m = Mechanism()
    cols = []
    for v, (types, joints, vals, pitch) in enumerate(chains):
        names = ["ground", f"A{v}", f"B{v}", f"body{v}"]
        for n in names[1:]:
            m.add_link(n)
        for k, (t, j) in enumerate(zip(types, joints)):
            jn = f"v{v}j{k + 1}"
            frame = _u_frame(*j) if t == "U" else next(pf)
            m.add_joint(jn, t, names[k], names[k + 1], at=frame, validate=False,
                        pitch=pitch if t == "H" else None)
            for i, slot in enumerate(_SLOTS[t]):
                m.add_input(jn, i)
                cols.append(vals[:, k, slot])
    pose = m.solve(np.stack(cols, 1), continuation=False)
    link = pose.kinematics(twists=False)["link"]
    bodies = link[:, [m.links.index(f"body{v}") for v in range(len(chains))]]
    rot, pos = pose_errors(bodies, T[:, None], length)
    return np.maximum(rot.max(0), pos.max(0))


def _centres(centre, screws, reach):
    """The UC centres: (m, 3) given, or the default grid (moves with the task)."""
    from .spherical import task_frame
    from .validate import task_scale
    if centre is not None:
        c = np.atleast_2d(array(centre, "centre", None,
                                what="a point (3,) or an (m, 3) array of points"))
        if c.ndim != 2 or c.shape[1] != 3 or len(c) == 0:
            raise SynthesisError(f"centre: expected a point (3,) or an (m, 3) array of points "
                                 f"(length), got shape {np.shape(centre)}")
        return c
    c0, _, _ = task_scale([s.matrix() for s in screws], [s.axis for s in screws],
                          [s.point for s in screws])
    return c0 + reach * DEFAULT_CENTRE_OFFSETS @ task_frame(screws).T


def _main_links(main, scr, psi, chi, ph, O, frame):
    from .hooke import uc_links, uh_links, up_links, ur_links
    if main == "UR":
        return ur_links(scr, azimuth=psi, frame=frame)
    if main == "UP":
        return up_links(scr, slide_azimuth=psi, axis_azimuth=chi, frame=frame)
    if main == "UH":
        return uh_links(scr, pitch=ph, azimuth=psi, frame=frame)
    return uc_links(scr, centre=O, azimuth=psi, frame=frame)


def _transitions(y, yl, ph, D, reach, angles):
    """[(transition angle or None, root, Transition)] of the R joint carrying J3."""
    if y == "C":
        return [(float(ang), 0, tr) for ang in angles
                for tr in transition_joint("R", "C", yl, 0.0, D, reach, angle=float(ang))]
    trs = transition_joint("R", y, yl, ph, D, reach)
    if not trs:
        raise SynthesisError("transition: no real root of the R transition carrying H (no "
                             "angle of J3 leaves a pure rotation)")
    return [(None, root, tr) for root, tr in enumerate(trs)]


def hooke_family_dyads(family: str, screws, *, azimuth=None, axis_azimuth=None, pitch=None,
                       centre=None, transition_angle=None) -> list[dict]:
    """Rows (dicts) of every variant of RUR, URR, RUP, URP, RUH, URH, RUC or URC; see the
    module notes and :func:`synthesis.enumerate_dyads`.

    Parameters
    ----------
    azimuth : float or array_like (m,)
        rad; default 0, π/4, π/2, 3π/4.
    axis_azimuth : float or array_like (m,)
        rad (RUP, URP); default π/6, 2π/3.
    pitch : float
        length/rad, nonzero (RUH, URH: required).
    centre : array_like (3,) or (m, 3)
        The U joint's centre (RUC, URC; length); default: the task's centre moved by half
        its reach along each axis of the task's reference frame.
    transition_angle : float or array_like (m,)
        J3's rotation (rad) while the R transition joint carries the C joint (RUC, URC);
        default −1, 1.
    """
    from .decompose import _flipped
    from .sphere_families import _helical_pitch
    from .spherical import task_frame
    T, N, arr, reach = task_positions(family, screws, hooke_arrangements)
    y = family[2]
    for name, v, ok in (("axis_azimuth", axis_azimuth, y == "P"), ("centre", centre, y == "C"),
                        ("transition_angle", transition_angle, y == "C")):
        if v is not None and not ok:
            raise SynthesisError(f"{name}: not a free parameter of family {family}")
    ph = _helical_pitch(family, pitch)
    psis = angle_grid(azimuth, "azimuth", DEFAULT_AZIMUTHS)
    chis = angle_grid(axis_azimuth, "axis_azimuth", DEFAULT_AXIS_AZIMUTHS) if y == "P" \
        else [None]
    Os = _centres(centre, screws, reach) if y == "C" else [None]
    angles = _grid_numbers(transition_angle, "transition_angle", DEFAULT_TRANSITION_ANGLES)
    frame = task_frame(screws)
    rows, chains = [], []
    for name, main, x, n_b, k in arr:
        for others in itertools.combinations(range(1, N), n_b - 1):
            Pm = (0,) + others
            rest = [i for i in range(N) if i not in Pm]
            scr = [screws[i - 1] for i in others]
            for psi, chi, O_c in itertools.product(psis, chis, Os):
                params = {"azimuth": float(psi)}
                if chi is not None:
                    params["axis_azimuth"] = float(chi)
                if O_c is not None:
                    params.update(centre_x=O_c[0], centre_y=O_c[1], centre_z=O_c[2])
                try:
                    links = _main_links(main, scr, float(psi), chi, ph, O_c, frame)
                    err = ""
                except SynthesisError as e:
                    links, err = [], str(e)
                if not links:
                    for s in Pm:
                        rows.append(_failed(family, name, main, Pm, s, rest, params, ph,
                                            err or f"no real {main} link at these parameters"))
                    continue
                for lk in links:
                    a, O, b = lk.fixed_axis.direction, lk.fixed_axis.point, lk.cross_axis
                    al, ga = lk.fixed_angles, lk.cross_angles
                    M = lk.moving_axis
                    mv = np.stack([lk.moving_angles, lk.moving_slides], 1)   # (n_b, 2)
                    if _flipped(M.direction):
                        M, mv = Line._exact(-M.direction, M.point), -mv
                    for si, s in enumerate(Pm):
                        Ts = T[s]
                        yl = Line._exact(Ts[:3, :3] @ M.direction, Ts[:3, :3] @ M.point + Ts[:3, 3])
                        try:
                            trs = _transitions(y, yl, ph, (T[rest[0]] @ np.linalg.inv(Ts))[None],
                                               reach, angles)
                        except SynthesisError as e:
                            rows.append(_failed(family, name, main, Pm, s, rest, params, ph,
                                                str(e)))
                            continue
                        for ang, root, tr in trs:
                            joints, vals = _chain(name, a, b, O, al, ga, M, mv, Pm, si, rest,
                                                  tr, N)
                            p = dict(params)
                            if ang is not None:
                                p["transition_angle"] = ang
                            row = _row(family, name, main, Pm, s, rest, p, joints, vals, ph)
                            if y == "H":
                                row["root"] = root          # which root of R carrying H
                            rows.append(row)
                            chains.append((len(rows) - 1, (family, joints, vals, ph)))
    res = verify_hooke([c for _, c in chains], T, reach)
    for (i, _), r in zip(chains, res):
        rows[i]["residual"] = float(r)
    for v, row in enumerate(rows, start=1):
        row["variant"] = v
    return rows


def _chain(name, a, b, O, al, ga, M, mv, Pm, si, rest, tr, N):
    """The chain's joints (ground first) and values ``(N, 3, 2)`` from the main link and
    the transition joint at position s = Pm[si]."""
    from .decompose import _flipped
    vals = np.zeros((N, 3, 2))
    U, X = (1, 0) if name == "a" else (0, 1)
    for i, p in enumerate(Pm):
        vals[p, U] = al[i], ga[i]
        vals[p, 2] = mv[i]
    l = rest[0]
    vals[l, U] = al[si], ga[si]
    vals[l, X, 0] = tr.psi[0, 0]
    vals[l, 2] = mv[si] + tr.delta[0]
    if name == "a":
        Xl = tr.line.canonical()
    else:
        G = np.linalg.inv(_about(_rot(a, al[si]) @ _rot(b, ga[si]), O))
        Xl = Line._exact(G[:3, :3] @ tr.line.direction, G[:3, :3] @ tr.line.point + G[:3, 3])
        Xl = Line._exact(Xl.direction, Xl.foot_from(O))
    if _flipped(Xl.direction):
        Xl = Line._exact(-Xl.direction, Xl.point)
        vals[:, X, 0] *= -1
    M3 = M.canonical(Xl) if name == "b" else Line._exact(M.direction, M.foot_from(O))
    return ([Xl, (a, b, O), M3] if name == "a" else [(a, b, O), Xl, M3]), vals


def _base(family, name, main, Pm, s, rest):
    return {"family": family, "variant": 0,
            "order": (f"{main} through {tuple(p + 1 for p in Pm)}; R "
                      f"({'J1' if name == 'a' else 'J2'}) carries position {s + 1} to "
                      f"{tuple(i + 1 for i in rest)}"),
            "arrangement": name, "transition": "R" + family[2]}


def _tail(row, main, Pm, s, params):
    row.update(main_link=main, main_positions=str(tuple(p + 1 for p in Pm)),
               transition_position=s + 1, **params)


def _row(family, name, main, Pm, s, rest, params, joints, vals, pitch):
    row = _base(family, name, main, Pm, s, rest)
    for k, (t, j) in enumerate(zip(family, joints), start=1):
        row[f"j{k}_type"] = t
        u, p = (j[0], j[2]) if t == "U" else (j.direction, j.point)
        row[f"j{k}_ux"], row[f"j{k}_uy"], row[f"j{k}_uz"] = u
        row[f"j{k}_x"], row[f"j{k}_y"], row[f"j{k}_z"] = p
        row[f"j{k}_pitch"] = {"R": 0.0, "P": np.inf, "H": pitch}.get(t, np.nan)
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


def _failed(family, name, main, Pm, s, rest, params, pitch, reason):
    row = _base(family, name, main, Pm, s, rest)
    nan_geometry(row, family)
    if "H" in family:
        row[f"j{family.index('H') + 1}_pitch"] = pitch
    row["residual"] = np.nan
    row["reason"] = reason
    _tail(row, main, Pm, s, params)
    return row


ARRANGEMENTS = hooke_arrangements
BUILD = hooke_family_dyads
