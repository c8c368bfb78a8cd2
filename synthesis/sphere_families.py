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
from dataclasses import dataclass

import numpy as np

from .binary import _rot
from .decompose import DEFAULT_AZIMUTHS, angle_grid, task_positions
from .errors import SynthesisError
from .screw import Line
from .validate import number
from .verify import verify_points

__all__ = ["sphere_arrangements", "sphere_family_dyads", "SPHERE_MAIN_POSITIONS"]

#: main link → positions; transition joint → remaining positions it carries
SPHERE_MAIN_POSITIONS = {"RS": 4, "PS": 3, "HS": 4}
_EZ = np.array([0, 0, 1.0])
_TRANS = {"R": 2, "P": 1}
#: default azimuth grid (rad)
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


def sphere_family_dyads(family: str, screws, *, azimuth=None, pitch=None) -> dict:
    """The table of every variant of a sphere-ended family, as columns; see
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

    Returns
    -------
    dict
        Column name → array (one entry per variant, in table order), the columns in the
        table's order (:func:`_columns`).

    Raises
    ------
    SynthesisError
        Bad input, naming the argument (``screws``, ``azimuth``, ``pitch``).
    """
    task = sphere_task(family, screws, azimuth, pitch, sphere_arrangements)
    T, N, arr, reach, ph, psis, frame, axes, points = task
    mains = {}
    parts = []
    for name, main, x, n_b, k in arr:
        combos = np.array(list(itertools.combinations(range(1, N), n_b - 1)), int)
        if main not in mains:
            mains[main] = _main_links(main, screws, T, axes, points, combos, psis, ph, frame)
        parts.append(_arrangement_rows(family, name, main, x, combos, psis, mains[main], T,
                                       reach, ph))
    cols = _columns(family, T, reach, ph, parts)
    cols["variant"] = np.arange(1, len(cols["family"]) + 1)
    return cols


def sphere_task(family, screws, azimuth, pitch, arrangements):
    """The checked task of a sphere family (end or middle sphere): positions ``T (N, 4,
    4)``, N, the family's ``arrangements(family, N)``, the reach, the helical pitch, the
    azimuth grid, the task's frame and the screws' ``axes, points (N − 1, 3)``."""
    from .spherical import task_frame
    T, N, arr, reach = task_positions(family, screws, arrangements)
    ph = _helical_pitch(family, pitch)
    psis = angle_grid(azimuth, "azimuth", DEFAULT_AZIMUTHS)
    axes = np.array([s.axis for s in screws], float)
    points = np.array([s.point for s in screws], float)
    return T, N, arr, reach, ph, psis, task_frame(screws), axes, points


@dataclass
class _MainLinks:
    """The main links of every sub-task (positions 1 and ``others``) and azimuth, m in
    all: ``block (m,)`` = sub-task · len(azimuths) + azimuth index (ascending),
    ``elevation (m,)`` (rad), the fixed axis ``fixed_dir, fixed_point (m, 3)``, the
    sphere centre ``centre (m, 3)`` (position 1), the fixed joint's values at the
    sub-task's positions ``values (m, n_b)`` (angle rad, or slide for P) and per
    sub-task and azimuth the error message ``error (S, len(azimuths))`` (``""``)."""

    block: np.ndarray
    elevation: np.ndarray
    fixed_dir: np.ndarray
    fixed_point: np.ndarray
    centre: np.ndarray
    values: np.ndarray
    error: np.ndarray


def _main_links(main, screws, T, axes, points, combos, psis, ph, frame) -> _MainLinks:
    """The main link through positions 1 and each row of ``combos`` (S, n_b − 1) at each
    azimuth of ``psis`` (``screws`` the task's, ``T`` its positions, ``axes, points``
    (N − 1, 3) its screw axes): RS and PS links of all sub-tasks and azimuths in one pass
    (:func:`synthesis.spherical._sphere_links_of`), HS links per sub-task and azimuth
    (:func:`synthesis.spherical.hs_links`); errors with the screws named as in the
    whole task."""
    from .spherical import _hs_links_grid, _sphere_links_of
    S = len(combos)
    subsets = np.concatenate([np.zeros((S, 1), int), combos], 1)
    if main in ("RS", "PS"):
        sl = _sphere_links_of(T, axes, points, subsets, psis, frame, main)
        error = sl.error
        out = _MainLinks(sl.block, sl.elevation, sl.fixed_dir, sl.fixed_point, sl.moving_point,
                         sl.fixed_values, error)
    else:
        links, blocks, error = _hs_links_grid("HS", screws, combos, psis, ph, frame)
        n = subsets.shape[1]
        arr = lambda f, shape: np.array([f(lk) for lk in links], float).reshape(shape)
        out = _MainLinks(blocks,
                         arr(lambda lk: lk.parameters.get("elevation", np.nan), (-1,)),
                         arr(lambda lk: lk.fixed_axis.direction, (-1, 3)),
                         arr(lambda lk: lk.fixed_axis.point, (-1, 3)),
                         arr(lambda lk: lk.moving_axis.point, (-1, 3)),
                         arr(lambda lk: lk.fixed_angles, (-1, n)), error)
    for i, j in zip(*np.nonzero(error != "")):
        error[i, j] = _renumbered(error[i, j], combos[i].tolist())
    return out



def _joint_columns(family, geometry, ph) -> dict:
    """The table's joint columns ``j{k}_type, j{k}_ux … j{k}_z, j{k}_pitch`` of R rows from
    their joints' (direction, point) ``geometry (R, 3, 2, 3)`` (NaN where absent) and the
    helical pitch ``ph``."""
    R = len(geometry)
    out = {}
    for k, t in enumerate(family):
        out[f"j{k + 1}_type"] = np.full(R, t, dtype=object)
        for i, c in enumerate(("ux", "uy", "uz")):
            out[f"j{k + 1}_{c}"] = geometry[:, k, 0, i]
        for i, c in enumerate("xyz"):
            out[f"j{k + 1}_{c}"] = geometry[:, k, 1, i]
        out[f"j{k + 1}_pitch"] = np.full(R, {"R": 0.0, "P": np.inf, "H": ph}.get(t, np.nan))
    return out


def _transition_axes(x, Cs, Pm, rest, reach):
    """The transition joint of every (main link, transition position) variant, in one pass.

    Parameters
    ----------
    x : str
        ``"R"`` (the circle through the sphere centre at s and its two remaining positions)
        or ``"P"`` (the slide from s to the remaining position).
    Cs : ndarray, shape (L, N, 3)
        The sphere centre of each of the L main links in every position.
    Pm, rest : ndarray of int, shape (L, m) and (L, k)
        Each link's main positions (each a transition position s) and remaining ones.
    reach : float
        The task's length scale.

    Returns
    -------
    u, p : ndarray, shape (L, m, 3)
        Axis direction and canonical point (foot of the perpendicular from the origin).
    xv : ndarray, shape (L, m, k)
        The transition joint's values at the remaining positions (angles or slides).
    reasons : ndarray of str, shape (L, m)
        ``""``, or why the variant has no transition joint.
    """
    from .dyads import CIRCLE_ERROR, circle_axes
    (L, m), k = Pm.shape, rest.shape[1]
    if L == 0:
        e = np.zeros((0, m, 3))
        return e, e, np.zeros((0, m, k)), np.zeros((0, m), str)
    p1 = Cs[np.arange(L)[:, None], Pm].reshape(-1, 3)
    far = [np.repeat(Cs[np.arange(L), rest[:, r]], m, axis=0) for r in range(k)]
    if x == "R":
        u, O, xv, ok = circle_axes(p1, *far)
        reasons = np.where(ok, "", CIRCLE_ERROR)
    else:
        d = far[0] - p1
        nd = np.linalg.norm(d, axis=-1)
        ok = ~(nd < 1e-12 * reach)
        u, O, xv = d / np.where(ok, nd, 1.0)[:, None], p1, nd[:, None]
        reasons = np.array(["" if o else "prismatic axis: the sphere centre does not move "
                            f"from position {Pm[i // m, i % m] + 1} to {rest[i // m, 0] + 1}"
                            for i, o in enumerate(ok.tolist())])
    p = O + np.einsum("mi,mi->m", -O, u)[:, None] * u
    return (u.reshape(L, m, 3), p.reshape(L, m, 3), xv.reshape(L, m, -1),
            reasons.reshape(L, m))


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


def _arrangement_rows(family, name, main, x, combos, psis, ml: _MainLinks, T, reach,
                      ph) -> dict:
    """The rows of one arrangement, as arrays: every (sub-task, azimuth) block in order,
    in a block every main link (or one entry when it has none) × every transition
    position s of the sub-task.

    Returns
    -------
    dict
        Per row (R rows): ``order``, ``main_positions``, ``reason`` (object arrays),
        ``transition_position`` (int), ``azimuth``, ``elevation``, ``member`` (float,
        NaN without a link), ``regular`` (bool: a link and a transition joint),
        ``geometry`` (R, 3, 2, 3): per joint (direction, point) in position 1 (NaN where
        not regular; joint 3 the sphere centre, no direction), ``jv`` (R, N, 2) the
        values of joints 1 and 2 (0 where not regular), and ``name``, ``main``,
        ``transition`` (the arrangement's columns).
    """
    N = T.shape[0]
    S, A = len(combos), len(psis)
    n_b = combos.shape[1] + 1
    subsets = np.concatenate([np.zeros((S, 1), int), combos], 1)
    rests = np.array([[i for i in range(N) if i not in sb] for sb in subsets.tolist()], int)
    m = len(ml.block)
    cnt = np.bincount(ml.block, minlength=S * A)
    first = np.r_[0, np.cumsum(cnt)[:-1]]
    empty = np.flatnonzero(cnt == 0)
    ublock = np.concatenate([ml.block, empty])
    ulink = np.concatenate([np.arange(m), np.full(len(empty), -1)])
    o = np.argsort(ublock, kind="stable")
    rb, rl = np.repeat(ublock[o], n_b), np.repeat(ulink[o], n_b)
    rs = np.tile(np.arange(n_b), len(o))
    sub, az = rb // A, rb % A
    R = len(rb)
    # the transition joint of every (link, s)
    C = ml.centre
    Cs = np.einsum("nij,mj->mni", T[:, :3, :3], C) + T[:, :3, 3]
    lsub = ml.block // A
    U, P, XV, reasons = _transition_axes(x, Cs, subsets[lsub], rests[lsub], reach)
    lines = _joint_lines(name, main, U, P, ml.fixed_dir, ml.fixed_point, ml.values, ph)
    has = rl >= 0
    li, si = rl[has], rs[has]
    reason = np.empty(R, dtype=object)
    reason[~has] = [ml.error[b, a] or f"no real {main} link on the circle of this azimuth"
                    for b, a in zip(sub[~has].tolist(), az[~has].tolist())]
    reason[has] = reasons[li, si]
    regular = has.copy()
    regular[has] = reasons[li, si] == ""
    r = np.flatnonzero(regular)
    lr, sr = rl[r], rs[r]
    geometry = np.full((R, 3, 2, 3), np.nan)
    geometry[r, :2] = lines[lr, sr]
    geometry[r, 2, 1] = C[lr]
    X, F = (0, 1) if name == "a" else (1, 0)
    jv = np.zeros((R, N, 2))
    Pm, rest = subsets[sub[r]], rests[sub[r]]
    jv[r[:, None], Pm, F] = ml.values[lr]
    jv[r[:, None], rest, X] = XV[lr, sr]
    jv[r[:, None], rest, F] = ml.values[lr, sr][:, None]
    member = np.full(R, np.nan)
    member[r] = lr - first[ml.block[lr]]
    elevation = np.full(R, np.nan)
    elevation[r] = ml.elevation[lr]
    # text columns: one string per (sub-task, s)
    pos = [str(tuple(p + 1 for p in sb)) for sb in subsets.tolist()]
    orders = np.array([[_order(family, name, main, x, sb, s, rt, None) for s in sb]
                       for sb, rt in zip(subsets.tolist(), rests.tolist())], dtype=object)
    return {"name": name, "main": main, "transition": x + "S", "order": orders[sub, rs],
            "main_positions": np.array(pos, dtype=object)[sub],
            "transition_position": subsets[sub, rs] + 1, "azimuth": np.asarray(psis, float)[az],
            "reason": reason, "regular": regular, "member": member, "elevation": elevation,
            "geometry": geometry, "jv": jv}


def _columns(family, T, reach, ph, parts) -> dict:
    """The table's columns from the rows of the arrangements ``parts``
    (:func:`_arrangement_rows`), the regular variants verified in one call
    (:func:`synthesis.verify.verify_points`).

    The columns are those (and in the order) of the rows as dicts: a regular row's
    ``family, variant, order``, joints 1–3 (``j{k}_type, _ux, _uy, _uz, _x, _y, _z,
    _pitch``), ``residual, reason, arrangement, transition, main_link, main_positions,
    transition_position, member, azimuth, elevation``, the values ``q{k}_pos{p}`` (k =
    1–3) and ``d{k}_pos{p}`` (k = 1, 2); a failed row's ``family, variant, order,
    arrangement, transition, main_link, main_positions, transition_position, azimuth,
    residual, reason`` and the joints; the kind of the first row first, the other's
    extra columns after it.  ``member`` is an integer column when every row is regular.
    """
    N = T.shape[0]
    cat = lambda key: np.concatenate([p[key] for p in parts])
    rep = lambda key: np.concatenate([np.full(len(p["reason"]), p[key], dtype=object)
                                      for p in parts])
    regular = cat("regular")
    R = len(regular)
    geometry, jv = cat("geometry"), cat("jv")
    r = np.flatnonzero(regular)
    types = family[:2]
    pitches = [ph if t == "H" else 0.0 for t in types]
    residual = np.full(R, np.nan)
    if len(r):
        chains = [(types, [Line._exact(g[0, 0], g[0, 1]), Line._exact(g[1, 0], g[1, 1])], v,
                   g[2, 1], pitches) for g, v in zip(geometry[r], jv[r])]
        residual[r] = verify_points(chains, T, reach)
    joints = _joint_columns(family, geometry, ph)
    head = {"family": np.full(R, family, dtype=object), "variant": np.zeros(R, int),
            "order": cat("order")}
    tail = {"arrangement": rep("name"), "transition": rep("transition"),
            "main_link": rep("main"), "main_positions": cat("main_positions"),
            "transition_position": cat("transition_position")}
    check = {"residual": residual, "reason": cat("reason")}
    member = cat("member")
    extra = {"member": member if not regular.all() else member.astype(int),
             "azimuth": cat("azimuth"), "elevation": cat("elevation")}
    vals = np.where(regular[:, None, None], jv, np.nan)
    dscale = np.array([1.0 if t == "P" else ph if t == "H" else 0.0 for t in types])
    q = {f"q{k + 1}_pos{p + 1}": vals[:, p, k] if k < 2 else np.full(R, np.nan)
         for p in range(N) for k in range(3)}
    d = {f"d{k + 1}_pos{p + 1}": vals[:, p, k] * dscale[k] for p in range(N) for k in range(2)}
    cols_regular = {**head, **joints, **check, **tail, **extra, **q, **d}
    if R and regular[0]:
        return cols_regular
    cols = {**head, **tail, "azimuth": extra["azimuth"], **check, **joints}
    if regular.any():
        cols.update({k: v for k, v in cols_regular.items() if k not in cols})
    return cols


ARRANGEMENTS = sphere_arrangements
BUILD = sphere_family_dyads
