"""Dyad families with a spherical joint before the body joint (RSR, SRR, RSP, SRP, and with
a helical body joint RSH, SRH) by Kharatyan's decomposition (1981, Table 3, rows 9, 10
and 5), the main link's free parameter explicit.

The main link is SR or SH (four positions; SH with the helical joint's ``pitch`` given,
length/rad) or SP (three): the sphere centre O in the ground (or on joint 1's link), the
revolute or helical axis (slide direction) in the body, on the great circle of
``azimuth`` ψ in the task's reference frame (:func:`synthesis.spherical.sr_links`,
:func:`synthesis.spherical.sh_links`, :func:`synthesis.spherical.sp_links` with
:func:`synthesis.spherical.task_frame` of all the screws).  Joint 3 (R, P or H) is then
carried from the transition position s to the remaining position by an R joint
(:mod:`synthesis.transition`: R carrying R, P or H, one position; R carrying H may have
several roots, each a variant, column ``root``): joint 1 in arrangement (a) (RSR, RSP,
RSH), joint 2 in (b) (SRR, SRP, SRH, whose position-1 axis is the transition axis turned
back about O by the sphere's rotation at s).

Table 3 row 5 prints N = 6 for RSH and SRH: there the pitch is a design variable (SH
through five positions).  Here the pitch is given (a required choice), so SH goes through
four positions and N = 5.  For H the joint value columns are ``q`` = angle (rad) and
``d`` = pitch · angle.

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
from .verify import _frames_of, in_chunks

__all__ = ["middle_arrangements", "sphere_middle_dyads", "verify_split"]

_MAIN = {"SR": 4, "SP": 3, "SH": 4}
DEFAULT_AZIMUTHS = np.arange(4) * np.pi / 4
#: family → (positions, free parameters, note for :func:`synthesis.families`)
FAMILIES = {"RSR": (5, ("azimuth",), ""), "SRR": (5, ("azimuth",), ""),
            "RSP": (4, ("azimuth",), ""), "SRP": (4, ("azimuth",), ""),
            "RSH": (5, ("azimuth", "pitch"),
                    "implemented with the pitch given (the choice pitch): main SH link (joints "
                    "2–3) through 4 positions (azimuth free) + R transition (joint 1) carrying "
                    "H through 1: N = 5; the printed N = 6 takes the pitch as a design "
                    "variable (SH through 5), not implemented"),
            "SRH": (5, ("azimuth", "pitch"),
                    "implemented with the pitch given (the choice pitch): main SH link (joints "
                    "1 and 3) through 4 positions (azimuth free) + R transition (joint 2) "
                    "carrying H through 1: N = 5; the printed N = 6 takes the pitch as a "
                    "design variable (SH through 5), not implemented")}


def middle_arrangements(family: str, n_positions: int | None = None) -> list[tuple]:
    """``(name, main, transition kind, n_b, k)`` for RSR, RSP, RSH (a) and SRR, SRP, SRH
    (b)."""
    out = []
    if len(family) != 3:
        return out
    for name, main, x in (("a", family[1:], family[0]), ("b", family[0] + family[2], family[1])):
        if main in _MAIN and x == "R" and family[2] in "RPH":
            n = _MAIN[main] + 1
            if n_positions is None or n == n_positions:
                out.append((name, main, x, _MAIN[main], 1))
    return out


@in_chunks
def verify_split(chains, targets, length: float) -> np.ndarray:
    """Centre errors of chains with a sphere, split at the sphere.

    Parameters
    ----------
    chains : list of (before, after, O)
        ``before`` and ``after`` lists of joints ``(kind, Line, values (P,))`` or
        ``(kind, Line, values (P,), pitch)`` (kind R, P or H; values: angle rad, or slide
        length for P; pitch length/rad, required for H): the joints before the sphere
        from the ground, and after it from the sphere to the body; ``O`` the centre in
        position 1.
    targets : array_like, shape (P, 4, 4)
        The body's given poses.
    length : float
        Length the errors are divided by.

    Returns
    -------
    numpy.ndarray, shape (len(chains),)
        max_p |O moved by ``before`` − T_p · (O moved back by ``after``)| / ``length`` per
        chain, both sides driven by the engine in one batched call (the joints after the
        sphere with their values negated: a helical joint's inverse is the same joint
        turned by −θ).

    Raises
    ------
    SynthesisError
        A helical joint without a finite pitch.
    """
    if not chains:
        return np.zeros(0)
    T = np.asarray(targets, float)
    m = Mechanism()
    lines = [jt[1] for before, after, _ in chains for jt in before + after[::-1]]
    cols = []
    frames = iter(_frames_of(lines)) if lines else iter(())
    names = []
    for v, (before, after, O) in enumerate(chains):
        pair = []
        for side, joints, sign in (("g", before, 1.0), ("b", after[::-1], -1.0)):
            prev = "ground"
            for j, jt in enumerate(joints):
                kind, ln, vals = jt[:3]
                pitch = None
                if kind == "H":
                    pitch = float(jt[3]) if len(jt) > 3 and jt[3] is not None else np.nan
                    if not np.isfinite(pitch):
                        raise SynthesisError(f"chains[{v}]: pitch: a helical joint needs a "
                                             f"finite pitch, got {pitch}")
                link = f"{side}{v}_{j}"
                m.add_link(link)
                jn = f"{side}{v}j{j}"
                m.add_joint(jn, kind, prev, link, at=next(frames), validate=False, pitch=pitch)
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


def sphere_middle_dyads(family: str, screws, *, azimuth=None, pitch=None) -> list[dict]:
    """Rows (dicts) of every variant of RSR, SRR, RSP, SRP, RSH or SRH; see
    :func:`synthesis.enumerate_dyads`.

    Parameters
    ----------
    family : str
        ``"RSR"``, ``"SRR"``, ``"RSH"``, ``"SRH"`` (five positions), ``"RSP"`` or ``"SRP"``
        (four).
    screws : list of Screw
        S₁₂ … S₁N.
    azimuth : float or array_like, optional
        ψ (rad) of the main link's moving axis (slide) direction on that great circle;
        default 0, π/4, π/2, 3π/4.
    pitch : float
        The helical joint's pitch (length/rad, nonzero), required for RSH and SRH (given,
        not a design variable); not allowed for the others.

    Raises
    ------
    SynthesisError
        Bad input, naming the argument (``screws``, ``azimuth``, ``pitch``).
    """
    from .decompose import _flipped
    from .sphere_families import _helical_pitch, _renumbered
    from .spherical import sh_links, sp_links, sr_links, task_frame
    T, N, arr, reach = task_positions(family, screws, middle_arrangements)
    ph = _helical_pitch(family, pitch)
    psis = angle_grid(azimuth, "azimuth", DEFAULT_AZIMUTHS)
    frame = task_frame(screws)
    rows, chains = [], []
    y_kind = family[2]
    for name, main, x, n_b, k in arr:
        for others in itertools.combinations(range(1, N), n_b - 1):
            Pm = (0,) + others
            rest = [i for i in range(N) if i not in Pm]
            for psi in psis:
                sub = [screws[i - 1] for i in others]
                try:
                    if main == "SR":
                        links = sr_links(sub, float(psi), frame=frame)
                    elif main == "SP":
                        links = sp_links(sub, float(psi), frame=frame)
                    else:
                        links = sh_links(sub, ph, float(psi), frame=frame)
                    err = ""
                except SynthesisError as e:
                    links, err = [], _renumbered(str(e), others)
                if not links:
                    for s in Pm:
                        rows.append(_failed(family, name, main, Pm, s, rest, psi,
                                            err or f"no real {main} link on this azimuth", ph))
                    continue
                for m_i, lk in enumerate(links):
                    O = lk.fixed_axis.point
                    M = lk.moving_axis
                    mv = lk.moving_slides if y_kind == "P" else lk.moving_angles
                    if _flipped(M.direction):
                        M, mv = Line._exact(-M.direction, M.point), -mv
                    Srot = lk.sphere_rotations
                    for si, s in enumerate(Pm):
                        Ts = T[s]
                        y_line = Line._exact(Ts[:3, :3] @ M.direction,
                                             Ts[:3, :3] @ M.point + Ts[:3, 3])
                        try:
                            trs = transition_joint("R", y_kind, y_line, ph,
                                                   (T[rest[0]] @ np.linalg.inv(Ts))[None], reach)
                            if not trs:
                                raise SynthesisError("transition: no real root of the R "
                                                     "transition carrying H (no angle of J3 "
                                                     "leaves a pure rotation)")
                        except (SynthesisError, ValueError) as e:
                            rows.append(_failed(family, name, main, Pm, s, rest, psi, str(e),
                                                ph))
                            continue
                        for root, tr in enumerate(trs):
                            q3 = np.zeros(N)
                            qx = np.zeros(N)
                            for i, p in enumerate(Pm):
                                q3[p] = mv[i]
                            l = rest[0]
                            qx[l] = tr.psi[0, 0]
                            # J3's increment: the angle (R, H) or the slide (P)
                            q3[l] = mv[si] + (tr.delta[0, 1] if y_kind == "P" else tr.delta[0, 0])
                            if name == "a":
                                X = tr.line
                            else:
                                G = _rot_about(O, Srot[si])
                                Gi = np.linalg.inv(G)
                                X = Line._exact(Gi[:3, :3] @ tr.line.direction,
                                                Gi[:3, :3] @ tr.line.point + Gi[:3, 3])
                            if name == "a":               # feet: from the origin, the centre
                                X = X.canonical()
                                M3 = Line._exact(M.direction, M.foot_from(O))
                            else:
                                X = Line._exact(X.direction, X.foot_from(O))
                                M3 = M.canonical(X)
                            if _flipped(X.direction):
                                X, qx = Line._exact(-X.direction, X.point), -qx
                            j3 = (y_kind, M3, q3, ph) if y_kind == "H" else (y_kind, M3, q3)
                            if name == "a":
                                before, after = [("R", X, qx)], [j3]
                                lines = [X, None, M3]
                            else:
                                before, after = [], [("R", X, qx), j3]
                                lines = [None, X, M3]
                            row = _row(family, name, main, Pm, s, rest, psi, lines, O, m_i,
                                       lk.parameters.get("elevation", np.nan), ph)
                            if y_kind == "H":
                                row["root"] = root          # which root of R carrying H
                            for p in range(N):
                                vals = [qx[p], np.nan, q3[p]] if name == "a" else \
                                    [np.nan, qx[p], q3[p]]
                                for kk in range(3):
                                    row[f"q{kk + 1}_pos{p + 1}"] = vals[kk]
                                    row[f"d{kk + 1}_pos{p + 1}"] = \
                                        {"P": vals[kk], "R": 0.0, "H": ph * vals[kk]}.get(
                                            family[kk], np.nan)
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


def _row(family, name, main, Pm, s, rest, psi, lines, O, member, elevation, pitch=0.0):
    row = _base(family, name, main, Pm, s, rest, psi)
    for k, (t, ln) in enumerate(zip(family, lines), start=1):
        row[f"j{k}_type"] = t
        if ln is None:                                         # the sphere: a centre only
            row[f"j{k}_ux"] = row[f"j{k}_uy"] = row[f"j{k}_uz"] = np.nan
            row[f"j{k}_x"], row[f"j{k}_y"], row[f"j{k}_z"] = O
        else:
            row[f"j{k}_ux"], row[f"j{k}_uy"], row[f"j{k}_uz"] = ln.direction
            row[f"j{k}_x"], row[f"j{k}_y"], row[f"j{k}_z"] = ln.point
        row[f"j{k}_pitch"] = {"R": 0.0, "P": np.inf, "H": pitch}.get(t, np.nan)
    row["residual"] = np.nan
    row["reason"] = ""
    _tail(row, family, main, Pm, s, psi)
    row["member"] = member
    row["elevation"] = float(elevation)
    return row


def _failed(family, name, main, Pm, s, rest, psi, reason, pitch=0.0):
    row = _base(family, name, main, Pm, s, rest, psi)
    nan_geometry(row, family)
    for k, t in enumerate(family, start=1):
        if t == "H":
            row[f"j{k}_pitch"] = pitch
    row["residual"] = np.nan
    row["reason"] = reason
    _tail(row, family, main, Pm, s, psi)
    return row


ARRANGEMENTS = middle_arrangements
BUILD = sphere_middle_dyads
