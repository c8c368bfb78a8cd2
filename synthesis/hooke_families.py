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
axis (pitch · angle for H, free for C).  The cross axis b is given with its largest
component positive (b and −b are the same joint; γ turns sign with it).

A task is solved in a few batched passes, not per variant: the main links of all subsets
of positions and all free-parameter choices together (:func:`synthesis.hooke._u_grids`),
the transition joints of every (link, transition position, angle) in one call
(:func:`synthesis.transition.transition_joints`), the variants' joints and values as
arrays, and the table as columns.
"""
from __future__ import annotations

import itertools

import numpy as np

from .decompose import DEFAULT_AZIMUTHS, PITCH_OF_KIND, _grid_numbers, angle_grid, task_positions
from .errors import SynthesisError
from .transition import Transitions, transition_joints
from .validate import array
from .verify import line_frames, pin_frames, verify_frames

__all__ = ["hooke_arrangements", "hooke_family_dyads"]

#: main link → positions it is synthesised through
_MAIN = {"UR": 4, "UP": 3, "UH": 4, "UC": 4}
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


def _flipped_rows(u) -> np.ndarray:
    """:func:`synthesis.decompose._flipped` of each row of ``u (k, 3)``: whether its
    largest component (the first of equal ones) is negative."""
    i = np.argmax(np.abs(u) - np.array([0.0, 1e-12, 2e-12]), -1)
    return np.take_along_axis(u, i[:, None], -1)[:, 0] < 0


def hooke_family_dyads(family: str, screws, *, azimuth=None, axis_azimuth=None, pitch=None,
                       centre=None, transition_angle=None) -> dict:
    """The table of every variant of RUR, URR, RUP, URP, RUH, URH, RUC or URC as columns
    (name → array of one value per variant, in the table's column order); see the module
    notes and :func:`synthesis.enumerate_dyads`.

    The main links of each subset of positions are solved for all free-parameter choices
    at once (:mod:`synthesis.hooke`), the transition joints of every (link, transition
    position, angle) in one call (:func:`synthesis.transition.transition_joints`), and the
    variants' joints, values and columns as arrays.

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

    Returns
    -------
    dict
        Column name → numpy.ndarray (n_variants,).

    Raises
    ------
    SynthesisError
        A choice that is not a free parameter of the family, or bad input (naming it).
    """
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
    na = len(angles) if y == "C" else 1
    frame = task_frame(screws)
    n_groups = len(psis) * len(chis) * len(Os)
    # ---- main links of every subset of positions (block), all choices at once
    from .hooke import _u_grids
    blocks, links = [], []
    for name, main, x, n_b, k in arr:
        subsets = list(itertools.combinations(range(1, N), n_b - 1))
        uls = _u_grids(main, list(screws), [(0,) + others for others in subsets], list(psis),
                       list(chis), ph, Os, frame, 1e-9)
        for others, ul in zip(subsets, uls):
            Pm = (0,) + others
            blocks.append((name, main, Pm, [i for i in range(N) if i not in Pm], ul.errors))
            if len(ul.base):
                links.append((len(blocks) - 1, ul))
    n_b = arr[0][3]
    lk = _link_arrays(links, n_b)
    # ---- groups without a link: one failed row per transition position
    has = np.zeros((len(blocks), n_groups), bool)
    has[lk["block"], lk["group"]] = True
    fb, fg = np.nonzero(~has)
    failed = [(b, g, -1, si, blocks[b][4][g] or f"no real {blocks[b][1]} link at these "
               "parameters") for b, g in zip(fb, fg) for si in range(n_b)]
    # ---- transition joints of every (link, position s, angle)
    tr, pair_err = _transition_problems(lk, blocks, T, y, ph, reach, angles, n_b, na)
    L = len(lk["block"])
    for l, si in zip(*np.nonzero(pair_err != "")):
        failed.append((lk["block"][l], lk["group"][l], l, si, pair_err[l, si]))
    prob = tr.owner
    keep = (pair_err.ravel()[prob // na] == "") if L else np.zeros(0, bool)
    j = np.flatnonzero(keep)
    prob = prob[j]
    l, si, ai = prob // (n_b * na), (prob // na) % n_b, prob % na
    root = j - np.searchsorted(tr.owner, tr.owner[j])
    V = len(j)
    # ---- the variants' joints and values, their verification
    geo = _variants(blocks, lk, l, si, tr, j, N)
    residual = verify_frames(family, _frames(geo), geo["vals"].swapaxes(0, 1),
                             np.nan if ph is None else ph, T, reach)
    # ---- rows in the table's order
    fa = np.array(failed, dtype=object).reshape(-1, 5)
    kb = np.r_[lk["block"][l], fa[:, 0].astype(int)]
    kg = np.r_[lk["group"][l], fa[:, 1].astype(int)]
    kl = np.r_[l, fa[:, 2].astype(int)]
    ks = np.r_[si, fa[:, 3].astype(int)]
    kt = np.r_[j, -np.ones(len(fa), int)]
    order = np.lexsort((kt, ks, kl, kg, kb))
    return _columns(family, blocks, order, V, kb, kg, ks, fa[:, 4], geo, residual,
                    angles[ai] if y == "C" else None, root if y == "H" else None,
                    psis, chis, Os, ph, n_b)


def _link_arrays(links, n_b) -> dict:
    """The main links of every block as arrays (k links): block, group (k,); a, b, O
    (the U joint), Md, Mp (the body joint's axis, oriented by the table's rule) (k, 3);
    al, ga (k, n_b) the U angles; mv (k, n_b, 2) the body joint's (angle, slide)."""
    if not links:
        z3, zn = np.zeros((0, 3)), np.zeros((0, n_b))
        return dict(block=np.zeros(0, int), group=np.zeros(0, int), a=z3, b=z3, O=z3, Md=z3,
                    Mp=z3, al=zn, ga=zn, mv=np.zeros((0, n_b, 2)))
    cat = lambda f: np.concatenate([f(ul) for _, ul in links])
    out = dict(block=np.concatenate([np.full(len(ul.base), b) for b, ul in links]),
               group=cat(lambda ul: ul.group), a=cat(lambda ul: ul.a),
               b=cat(lambda ul: ul.b), O=cat(lambda ul: ul.bases.O[ul.base]),
               Md=cat(lambda ul: ul.bases.md[ul.base]), Mp=cat(lambda ul: ul.bases.mp[ul.base]),
               al=cat(lambda ul: ul.al), ga=cat(lambda ul: ul.ga),
               mv=cat(lambda ul: np.stack([ul.bases.mang[ul.base], ul.bases.msl[ul.base]], -1)))
    fl = _flipped_rows(out["Md"])
    out["Md"] = np.where(fl[:, None], -out["Md"], out["Md"])
    out["mv"] = np.where(fl[:, None, None], -out["mv"], out["mv"])
    return out


def _transition_problems(lk, blocks, T, y, ph, reach, angles, n_b, na):
    """The R transition joints carrying J3 from each link's position s to the remaining
    one, every (link, s, angle) problem in one call: the joints, and per (link, s) the
    reason it has none (the first angle's with one), (k, n_b) strings."""
    L = len(lk["block"])
    if not L:
        z = np.zeros((0, 3))
        return Transitions(np.zeros(0, int), z, z, np.zeros((0, 1, 2)), np.zeros((0, 1, 2)),
                           np.zeros(0, object)), np.zeros((0, n_b), object)
    Pm = np.array([b[2] for b in blocks]).reshape(len(blocks), n_b)
    rest = np.array([b[3][0] for b in blocks], int)
    s = Pm[lk["block"]]                                          # (L, n_b)
    Ts = T[s]
    D = T[rest[lk["block"]]][:, None] @ np.linalg.inv(T)[s]      # (L, n_b, 4, 4)
    d = np.einsum("lsij,lj->lsi", Ts[..., :3, :3], lk["Md"])
    p = np.einsum("lsij,lj->lsi", Ts[..., :3, :3], lk["Mp"]) + Ts[..., :3, 3]
    rep = lambda v: np.repeat(v.reshape((L * n_b,) + v.shape[2:]), na, axis=0)
    tr = transition_joints("R", y, rep(d), rep(p), 0.0 if y == "C" else ph, rep(D)[:, None],
                           reach, angle=np.tile(angles, L * n_b) if y == "C" else None)
    err = tr.error.reshape(L, n_b, na)
    first = np.argmax(err != "", -1)
    pair = np.take_along_axis(err, first[..., None], -1)[..., 0].astype(object)
    if y == "H":
        n_joints = np.bincount(tr.owner // na, minlength=L * n_b).reshape(L, n_b)
        pair = np.where((pair == "") & (n_joints == 0),
                        "transition: no real root of the R transition carrying H (no angle of "
                        "J3 leaves a pure rotation)", pair)
    return tr, pair.reshape(L, n_b)


def _variants(blocks, lk, l, si, tr, j, N) -> dict:
    """Joint axes and values of the V variants (link ``l``, transition position index
    ``si``, transition joint ``j``): the transition axis X (Xd, Xp), the body joint's axis
    point M3 (k, 3) and the values ``vals (V, N, 3, 2)`` (angle, slide per position and
    joint; the U joint's (α, γ))."""
    from .binary import _rot
    V = len(l)
    name = blocks[0][0]
    U, X = (1, 0) if name == "a" else (0, 1)
    n_b = lk["al"].shape[1]
    Pm = np.array([b[2] for b in blocks]).reshape(len(blocks), n_b)[lk["block"][l]]
    rest = np.array([b[3][0] for b in blocks], int)[lk["block"][l]]
    a, b, O = lk["a"][l], lk["b"][l], lk["O"][l]
    al, ga, mv = lk["al"][l], lk["ga"][l], lk["mv"][l]
    Md, Mp = lk["Md"][l], lk["Mp"][l]
    r = np.arange(V)
    vals = np.zeros((V, N, 3, 2))
    vals[r[:, None], Pm, U, 0] = al
    vals[r[:, None], Pm, U, 1] = ga
    vals[r[:, None], Pm, 2] = mv
    als, gas = al[r, si], ga[r, si]
    vals[r, rest, U, 0], vals[r, rest, U, 1] = als, gas
    vals[r, rest, X, 0] = tr.psi[j, 0, 0]
    vals[r, rest, 2] = mv[r, si] + tr.delta[j, 0]
    dX, pX = tr.direction[j], tr.point[j]
    dot = lambda u, v: np.sum(u * v, -1)[:, None]
    if name == "a":
        Xd, Xp = dX, pX - dot(pX, dX) * dX                        # foot from the origin
    else:               # turned back about O by the U joint's rotation at s, foot from O
        Rt = np.swapaxes(_rot(a, als) @ _rot(b, gas), -1, -2)
        Xd = np.einsum("vij,vj->vi", Rt, dX)
        Xp = np.einsum("vij,vj->vi", Rt, pX - O) + O
        Xp = Xp + dot(O - Xp, Xd) * Xd
    fl = _flipped_rows(Xd) if V else np.zeros(0, bool)
    Xd = np.where(fl[:, None], -Xd, Xd)
    vals[:, :, X, 0] *= np.where(fl, -1.0, 1.0)[:, None]
    if name == "b":     # the foot of the common normal with X (parallel: from X's point)
        bb = dot(Xd, Md)
        den = 1 - bb * bb
        w = Xp - Mp
        with np.errstate(invalid="ignore", divide="ignore"):
            t = (dot(Md, w) - bb * dot(Xd, w)) / den
        M3 = Mp + np.where(den < 1e-12, dot(Xp - Mp, Md), t) * Md
    else:
        M3 = Mp + dot(O - Mp, Md) * Md
    return dict(Xd=Xd, Xp=Xp, M3=M3, vals=vals, a=a, b=b, O=O, Md=Md, name=name)


def _joint_columns(geo) -> list:
    """Per joint (ground first) its (direction, point) arrays (V, 3); the U joint's are
    its first axis and centre."""
    X, Uj, M = (geo["Xd"], geo["Xp"]), (geo["a"], geo["O"]), (geo["Md"], geo["M3"])
    return [X, Uj, M] if geo["name"] == "a" else [Uj, X, M]


def _frames(geo) -> np.ndarray:
    """The variants' joint frames (V, 3, 4, 4) for :func:`synthesis.verify.verify_frames`
    (ground joint first: the transition joint X and the U joint in the arrangement's
    order, then the body joint M)."""
    X = line_frames(geo["Xd"], geo["Xp"], check=False)
    U = pin_frames(geo["a"], geo["b"], geo["O"])
    M = line_frames(geo["Md"], geo["M3"], check=False)
    return np.stack([X, U, M] if geo["name"] == "a" else [U, X, M], 1)


def _columns(family, blocks, order, V, kb, kg, ks, reasons, geo, residual, tangle, root,
             psis, chis, Os, ph, n_b) -> dict:
    """The table's columns: rows ``order`` of the V regular rows followed by the failed
    ones (block, group, position index, reason), in the column order of the row dicts
    the table was built from (the first row's keys, then the other kind's)."""
    n = len(order)
    N = geo["vals"].shape[1]
    reg = order < V                                               # regular rows (in order)
    ri = order[reg]
    col = {}

    def put(key, reg_vals, fail_vals=np.nan, dtype=float):
        out = np.empty(n, dtype)
        if dtype is object or dtype is float:
            out[:] = fail_vals
        out[reg] = np.asarray(reg_vals)[ri] if np.ndim(reg_vals) else reg_vals
        col[key] = out
    Pm = np.array([b[2] for b in blocks]).reshape(len(blocks), n_b)
    blk, grp, sidx = kb[order], kg[order], ks[order]
    s = Pm[blk, sidx]
    obj = lambda vals: np.array(vals, dtype=object)
    # the text columns of each block (and transition position), indexed per row
    orders = obj([[f"{b[1]} through {tuple(p + 1 for p in b[2])}; R "
                   f"({'J1' if b[0] == 'a' else 'J2'}) carries position {p + 1} to "
                   f"{tuple(r + 1 for r in b[3])}" for p in b[2]] for b in blocks])
    base = {"family": np.full(n, family, dtype=object), "variant": np.arange(1, n + 1),
            "order": orders[blk, sidx], "arrangement": obj([b[0] for b in blocks])[blk],
            "transition": np.full(n, "R" + family[2], dtype=object)}
    col.update(base)
    fail_keys, reg_keys = list(base), list(base)
    joints = _joint_columns(geo)
    for k, t in enumerate(family, start=1):
        col[f"j{k}_type"] = np.full(n, t, dtype=object)
        for c, (arr_, i) in zip(("ux", "uy", "uz", "x", "y", "z"),
                                [(joints[k - 1][0], i) for i in range(3)]
                                + [(joints[k - 1][1], i) for i in range(3)]):
            put(f"j{k}_{c}", arr_[:, i])
        keys = [f"j{k}_{c}" for c in ("type", "ux", "uy", "uz", "x", "y", "z", "pitch")]
        col[f"j{k}_pitch"] = np.full(n, ph if t == "H" else PITCH_OF_KIND.get(t, np.nan))
        fail_keys += keys
        reg_keys += keys
        if t == "U":
            for i, c in enumerate("xyz"):
                put(f"u_cross_{c}", geo["b"][:, i])
            reg_keys += ["u_cross_x", "u_cross_y", "u_cross_z"]
    put("residual", residual)
    rs = np.full(n, "", dtype=object)
    rs[~reg] = reasons[order[~reg] - V]
    col["reason"] = rs
    col["main_link"] = obj([b[1] for b in blocks])[blk]
    col["main_positions"] = obj([str(tuple(p + 1 for p in b[2])) for b in blocks])[blk]
    col["transition_position"] = s + 1
    tail = ["residual", "reason", "main_link", "main_positions", "transition_position"]
    nc, no = len(chis), len(Os)
    col["azimuth"] = np.asarray(psis, float)[grp // (nc * no)]
    tail.append("azimuth")
    if chis[0] is not None:
        col["axis_azimuth"] = np.asarray(chis, float)[(grp // no) % nc]
        tail.append("axis_azimuth")
    if Os[0] is not None:
        for i, c in enumerate("xyz"):
            col[f"centre_{c}"] = np.asarray(Os, float)[grp % no, i]
        tail += ["centre_x", "centre_y", "centre_z"]
    fail_keys += tail
    reg_keys += tail
    if tangle is not None:
        put("transition_angle", tangle)
        reg_keys.append("transition_angle")
    vals = geo["vals"]
    for p in range(N):
        for k, t in enumerate(family):
            put(f"q{k + 1}_pos{p + 1}", vals[:, p, k, 1 if t == "P" else 0])
            put(f"d{k + 1}_pos{p + 1}", vals[:, p, k, 1])
            reg_keys += [f"q{k + 1}_pos{p + 1}", f"d{k + 1}_pos{p + 1}"]
    if root is not None:                        # which root of R carrying H
        if reg.all():
            col["root"] = np.asarray(root, int)[ri]
        else:
            put("root", np.asarray(root, float))
        reg_keys.append("root")
    first, other = (reg_keys, fail_keys) if reg[0] else (fail_keys, reg_keys)
    if reg.all():
        other = []
    elif not reg.any():
        first, other = fail_keys, []
    keys = first + [k for k in other if k not in first]
    return {k: col[k] for k in keys}


ARRANGEMENTS = hooke_arrangements
BUILD = hooke_family_dyads
