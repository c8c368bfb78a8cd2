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
Every side of every variant goes through the engine's bulk open-chain evaluation.
"""
from __future__ import annotations

import itertools

import numpy as np

from closure import open_chain_poses

from .errors import SynthesisError
from .screw import Line
from .verify import _frames_of

__all__ = ["middle_arrangements", "sphere_middle_dyads", "verify_split"]

_MAIN = {"SR": 4, "SP": 3, "SH": 4}
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
        chain, each side an open chain hung from the ground and driven by the engine's
        bulk evaluation (:func:`closure.open_chain_poses`, the chains of one joint sequence
        in one call; the joints after the sphere reversed, their values negated: a helical
        joint's inverse is the same joint turned by −θ).

    Raises
    ------
    SynthesisError
        A helical joint without a finite pitch.
    """
    chains = list(chains)
    if not chains:
        return np.zeros(0)
    for v, (before, after, _) in enumerate(chains):
        for jt in before + after[::-1]:
            if jt[0] == "H":
                pitch = float(jt[3]) if len(jt) > 3 and jt[3] is not None else np.nan
                if not np.isfinite(pitch):
                    raise SynthesisError(f"chains[{v}]: pitch: a helical joint needs a "
                                         f"finite pitch, got {pitch}")
    T = np.asarray(targets, float)
    O = np.array([c[2] for c in chains], float).reshape(-1, 3)
    ends = []
    for sign, joints in ((1.0, [c[0] for c in chains]), (-1.0, [c[1][::-1] for c in chains])):
        pts = np.array(np.broadcast_to(O, (len(T),) + O.shape))               # (P, V, 3)
        groups = {}
        for v, js in enumerate(joints):
            if js:
                groups.setdefault("".join(jt[0] for jt in js), []).append(v)
        for kinds, vs in groups.items():
            k = len(kinds)
            F = _frames_of([joints[v][i][1] for v in vs for i in range(k)]).reshape(-1, k, 4, 4)
            q = sign * np.array([[joints[v][i][2] for i in range(k)] for v in vs], float)
            h = np.array([[float(jt[3]) if jt[0] == "H" else 0.0 for jt in joints[v]]
                          for v in vs])
            L = open_chain_poses(kinds, F, np.moveaxis(q, -1, 0), h, validate=False)[:, :, -1]
            pts[:, vs] = (L[..., :3, :3] @ O[vs][..., None])[..., 0] + L[..., :3, 3]
        ends.append(pts)
    pg, pb = ends
    pb = (T[:, None, :3, :3] @ pb[..., None])[..., 0] + T[:, None, :3, 3]
    return np.linalg.norm(pg - pb, axis=-1).max(0) / length


def sphere_middle_dyads(family: str, screws, *, azimuth=None, pitch=None) -> dict:
    """The table of every variant of RSR, SRR, RSP, SRP, RSH or SRH, as columns; see
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
    from .sphere_families import sphere_task
    task = sphere_task(family, screws, azimuth, pitch, middle_arrangements)
    T, N, arr, reach, ph, psis, frame, axes, points = task
    parts = []
    for name, main, x, n_b, k in arr:
        combos = np.array(list(itertools.combinations(range(1, N), n_b - 1)), int)
        links = _main_links(main, screws, T, axes, points, combos, psis, ph, frame)
        parts.append(_arrangement_rows(family, name, main, combos, psis, links, T, reach, ph))
    cols = _columns(family, T, reach, ph, parts)
    cols["variant"] = np.arange(1, len(cols["family"]) + 1)
    return cols


def _main_links(main, screws, T, axes, points, combos, psis, ph, frame):
    """The main link (SR, SP or SH) through positions 1 and each row of ``combos``
    (S, n_b − 1) at each azimuth of ``psis``, as :class:`synthesis.spherical._SphereLinks`
    (block = sub-task · len(psis) + azimuth index; ``moving_values`` the moving joint's
    angles, or slides for SP): SR and SP of all sub-tasks and azimuths in one pass, SH per
    sub-task and azimuth (:func:`synthesis.spherical.sh_links`); errors with the screws
    named as in the whole task."""
    from .sphere_families import _renumbered
    from .spherical import _SphereLinks, _hs_links_grid, _sphere_links_of
    S = len(combos)
    subsets = np.concatenate([np.zeros((S, 1), int), combos], 1)
    if main in ("SR", "SP"):
        sl = _sphere_links_of(T, axes, points, subsets, psis, frame, main)
    else:
        links, blocks, error = _hs_links_grid("SH", screws, combos, psis, ph, frame)
        n = subsets.shape[1]
        arr = lambda f, shape: np.array([f(lk) for lk in links], float).reshape(shape)
        line = lambda ax, c: arr(lambda lk: getattr(getattr(lk, ax), c), (-1, 3))
        sl = _SphereLinks("SH", blocks,
                          arr(lambda lk: lk.parameters.get("elevation", np.nan), (-1,)),
                          line("fixed_axis", "direction"), line("fixed_axis", "point"),
                          line("moving_axis", "direction"), line("moving_axis", "point"),
                          np.zeros((len(links), n)), arr(lambda lk: lk.moving_angles, (-1, n)),
                          arr(lambda lk: lk.sphere_rotations, (-1, n, 3, 3)),
                          arr(lambda lk: lk.residual, (-1,)), error)
    for i, j in zip(*np.nonzero(sl.error != "")):
        sl.error[i, j] = _renumbered(sl.error[i, j], combos[i].tolist())
    return sl


def _foot(u, p, x):
    """Feet ``(m, 3)`` of the perpendiculars from the points x to the lines (u, p)."""
    return p + np.sum((x - p) * u, -1, keepdims=True) * u


def _arrangement_rows(family, name, main, combos, psis, sl, T, reach, ph) -> dict:
    """The rows of one arrangement, as arrays: every (sub-task, azimuth) block in order,
    in a block every main link (or one entry when it has none) × every transition
    position s × every root of its R transition (or one entry when it has none); the R
    transitions of all (link, s) in one call (:func:`synthesis.transition.transition_joints`).

    Returns
    -------
    dict
        Per row (R rows): ``order``, ``main_positions``, ``reason`` (object arrays),
        ``transition_position`` (int), ``azimuth``, ``elevation``, ``member``, ``root``
        (float, NaN where not regular), ``regular`` (bool), ``geometry`` (R, 3, 2, 3): per
        joint (direction, point) in position 1 (NaN where not regular; the sphere its
        centre, no direction), ``qx``, ``q3`` (R, N): the transition joint's and joint 3's
        values (0 where not regular), and ``name``.
    """
    from .decompose import _flip_signs
    from .transition import transition_joints
    N = T.shape[0]
    S, A = len(combos), len(psis)
    n_b = combos.shape[1] + 1
    y_kind = family[2]
    subsets = np.concatenate([np.zeros((S, 1), int), combos], 1)
    rests = np.array([[i for i in range(N) if i not in sb] for sb in subsets.tolist()], int)
    m = len(sl.block)
    lsub = sl.block // A
    O = sl.fixed_point
    sg = _flip_signs(sl.moving_dir) if m else np.ones(0)
    Md, Mp = sl.moving_dir * sg[:, None], sl.moving_point
    mv = sl.moving_values * sg[:, None]
    # one R transition problem per (link, s)
    Ts = T[subsets[lsub]].reshape(-1, 4, 4)                              # (m n_b, 4, 4)
    D = T[np.repeat(rests[lsub, 0], n_b)] @ np.linalg.inv(Ts)
    yd = np.einsum("pij,pj->pi", Ts[:, :3, :3], np.repeat(Md, n_b, 0))
    yp = np.einsum("pij,pj->pi", Ts[:, :3, :3], np.repeat(Mp, n_b, 0)) + Ts[:, :3, 3]
    tr = transition_joints("R", y_kind, yd, yp, ph, D[:, None], reach)
    nroot = np.bincount(tr.owner, minlength=m * n_b)
    # units: each root, one per (link, s) without a root, one per block without a link
    cnt = np.bincount(sl.block, minlength=S * A)
    empty = np.flatnonzero(cnt == 0)
    bare = np.flatnonzero(nroot == 0)
    key = np.concatenate([sl.block[tr.owner // n_b], sl.block[bare // n_b], empty])
    sub_key = np.concatenate([tr.owner, bare, np.full(len(empty), -1)])
    unit_root = np.concatenate([np.arange(len(tr.owner)), np.full(len(bare) + len(empty), -1)])
    o = np.lexsort((np.arange(len(key)), sub_key, key))
    ublock, uprob, uroot = key[o], sub_key[o], unit_root[o]
    # a block without links has a row per s; the others one per (link, s) [× root]
    rep = np.where(uprob < 0, n_b, 1)
    rb, rp, rr = np.repeat(ublock, rep), np.repeat(uprob, rep), np.repeat(uroot, rep)
    within = np.arange(len(rb)) - np.repeat(np.cumsum(rep) - rep, rep)
    rsi = np.where(rp >= 0, rp % n_b, within)                 # the transition position s
    sub, az = rb // A, rb % A
    R = len(rb)
    reason = np.full(R, "", dtype=object)
    nolink = rp < 0
    reason[nolink] = [sl.error[b, a] or f"no real {main} link on this azimuth"
                      for b, a in zip(sub[nolink].tolist(), az[nolink].tolist())]
    noroot = (rp >= 0) & (rr < 0)
    reason[noroot] = [tr.error[p] or "transition: no real root of the R transition carrying H "
                      "(no angle of J3 leaves a pure rotation)" for p in rp[noroot].tolist()]
    regular = rr >= 0
    r = np.flatnonzero(regular)
    j = rr[r]                                           # the transition of each regular row
    p = tr.owner[j]
    lk, si = p // n_b, p % n_b
    rest0 = rests[sub[r], 0]
    ri = np.arange(len(r))
    q3 = np.zeros((R, N))
    q3[r[:, None], subsets[sub[r]]] = mv[lk]
    q3[r, rest0] = mv[lk, si] + tr.delta[j, 0, 1 if y_kind == "P" else 0]
    qx = np.zeros((len(r), N))
    qx[ri, rest0] = tr.psi[j, 0, 0]
    Xd, Xp = tr.direction[j], tr.point[j]
    Ol, Mdl, Mpl = O[lk], Md[lk], Mp[lk]
    if name == "a":                                   # feet: from the origin, the centre
        Xp = Xp - np.sum(Xp * Xd, -1, keepdims=True) * Xd
        M3p = _foot(Mdl, Mpl, Ol)
    else:               # the transition axis turned back about O by the sphere at s
        G = np.zeros((len(r), 4, 4))
        G[:, :3, :3] = sl.rotations[lk, si]
        G[:, :3, 3] = Ol - np.einsum("mij,mj->mi", sl.rotations[lk, si], Ol)
        G[:, 3, 3] = 1.0
        Gi = np.linalg.inv(G)
        Xd = np.einsum("mij,mj->mi", Gi[:, :3, :3], Xd)
        Xp = _foot(Xd, np.einsum("mij,mj->mi", Gi[:, :3, :3], Xp) + Gi[:, :3, 3], Ol)
        M3p = _common_normal_feet(Xd, Xp, Mdl, Mpl)
    fx = _flip_signs(Xd) if len(r) else np.ones(0)
    Xd, qx = Xd * fx[:, None], qx * fx[:, None]
    geometry = np.full((R, 3, 2, 3), np.nan)
    kx, ks = (0, 1) if name == "a" else (1, 0)
    geometry[r, kx] = np.stack([Xd, Xp], 1)
    geometry[r, ks, 1] = Ol
    geometry[r, 2] = np.stack([Mdl, M3p], 1)
    QX = np.zeros((R, N))
    QX[r] = qx
    member = np.full(R, np.nan)
    member[r] = lk - np.r_[0, np.cumsum(cnt)[:-1]][sl.block[lk]]
    elevation = np.full(R, np.nan)
    elevation[r] = sl.elevation[lk]
    root = np.full(R, np.nan)
    root[r] = j - np.searchsorted(tr.owner, p)
    pos = [str(tuple(q + 1 for q in sb)) for sb in subsets.tolist()]
    orders = np.array([[_order(name, main, sb, s, rt) for s in sb]
                       for sb, rt in zip(subsets.tolist(), rests.tolist())], dtype=object)
    return {"name": name, "main": main, "order": orders[sub, rsi],
            "main_positions": np.array(pos, dtype=object)[sub],
            "transition_position": subsets[sub, rsi] + 1, "azimuth": np.asarray(psis, float)[az],
            "reason": reason, "regular": regular, "member": member, "elevation": elevation,
            "root": root, "geometry": geometry, "qx": QX, "q3": q3}


def _common_normal_feet(u, p, v, q):
    """Feet ``(m, 3)`` on the lines (v, q) of their common normals with the lines (u, p)
    (:func:`synthesis.screw.common_normal`; parallel lines: the foot of the perpendicular
    from p)."""
    b = np.sum(u * v, -1)
    den = 1 - b * b
    w = p - q
    d, e = np.sum(u * w, -1), np.sum(v * w, -1)
    par = den < 1e-12
    t = np.where(par, 0.0, (e - b * d) / np.where(par, 1.0, den))
    return np.where(par[:, None], _foot(v, q, p), q + t[:, None] * v)


def _columns(family, T, reach, ph, parts) -> dict:
    """The table's columns from the rows of the arrangements ``parts``
    (:func:`_arrangement_rows`), the regular variants verified in one call
    (:func:`verify_split`).

    The columns are those (and in the order) of the rows as dicts: ``family, variant,
    order, arrangement, transition``, joints 1–3 (``j{k}_type, _ux, _uy, _uz, _x, _y, _z,
    _pitch``), ``residual, reason, main_link, main_positions, transition_position,
    azimuth``, and when a row is regular ``member, elevation`` (``root`` for RSH, SRH:
    which root of R carrying H) and per position ``q{k}_pos{p}, d{k}_pos{p}`` (k = 1–3);
    ``member`` and ``root`` are integer columns when every row is regular.
    """
    from .sphere_families import _joint_columns
    N = T.shape[0]
    y_kind = family[2]
    cat = lambda key: np.concatenate([q[key] for q in parts])
    rep = lambda key: np.concatenate([np.full(len(q["reason"]), q[key], dtype=object)
                                      for q in parts])
    regular, geometry, qx, q3 = cat("regular"), cat("geometry"), cat("qx"), cat("q3")
    names = rep("name")
    R = len(regular)
    residual = np.full(R, np.nan)
    r = np.flatnonzero(regular)
    if len(r):
        chains = []
        for i in r.tolist():
            g, kx = geometry[i], 0 if names[i] == "a" else 1      # the transition joint
            X, M3 = Line._exact(g[kx, 0], g[kx, 1]), Line._exact(g[2, 0], g[2, 1])
            j3 = (y_kind, M3, q3[i], ph) if y_kind == "H" else (y_kind, M3, q3[i])
            O = g[1 - kx, 1]                                       # the sphere's centre
            chains.append(([("R", X, qx[i])], [j3], O) if kx == 0 else
                          ([], [("R", X, qx[i]), j3], O))
        residual[r] = verify_split(chains, T, reach)
    cols = {"family": np.full(R, family, dtype=object), "variant": np.zeros(R, int),
            "order": cat("order"), "arrangement": names,
            "transition": np.full(R, "R" + y_kind, dtype=object)}
    cols.update(_joint_columns(family, geometry, ph))
    cols.update(residual=residual, reason=cat("reason"), main_link=rep("main"),
                main_positions=cat("main_positions"),
                transition_position=cat("transition_position"), azimuth=cat("azimuth"))
    if not len(r):
        return cols
    whole = regular.all()
    cols["member"] = cat("member").astype(int) if whole else cat("member")
    cols["elevation"] = cat("elevation")
    if y_kind == "H":
        cols["root"] = cat("root").astype(int) if whole else cat("root")
    a = (names == "a")[:, None]
    vals = [np.where(a, qx, np.nan), np.where(a, np.nan, qx), q3]
    for p in range(N):
        for k in range(3):
            v = np.where(regular, vals[k][:, p], np.nan)
            cols[f"q{k + 1}_pos{p + 1}"] = v
            cols[f"d{k + 1}_pos{p + 1}"] = {"P": v, "R": np.where(regular, 0.0, np.nan),
                                            "H": ph * v}.get(family[k], np.full(R, np.nan))
    return cols


def _order(name, main, Pm, s, rest):
    return (f"{main} through {tuple(p + 1 for p in Pm)}; R ({'J1' if name == 'a' else 'J2'}) "
            f"carries position {s + 1} to {tuple(i + 1 for i in rest)}")


ARRANGEMENTS = middle_arrangements
BUILD = sphere_middle_dyads
