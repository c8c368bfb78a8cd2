"""Closing synthesised dyads into a mechanism and sweeping it for the classical defects.

:func:`assemble` joins two or more binary links that share the ground and the body
(two RR links → a Bennett 4R, RR + SS → an RRSS, …) into one closure
:class:`~closure.Mechanism` assembled at position 1 (every joint coordinate zero there),
checks its mobility, and drives one joint from position 1 through the task's positions
by the engine's continuation (which stays on the branch it starts on).  A mechanism with
no joint to drive (a 5-SS platform: every joint spherical) is driven through a body
coordinate instead: a virtual chain of three slides and a ball (ground–P–P–P–S–body,
adding no constraint and no freedom) whose first slide, the displacement of a body point
along a fixed direction, is the input.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from closure.frames import transform
from closure.mechanism import Mechanism

from .binary import BinaryLink
from .errors import SynthesisError
from .rr import RRLink
from .rs import RSLink
from .screw import Line
from .validate import integer, number, screws as _screws, task_scale, unit, vec3
from .verify import _frame_of, pose_errors

__all__ = ["Assembly", "assemble", "assemble_table", "link_from_row"]


@dataclass
class Assembly:
    """An assembled mechanism and its defect analysis.

    Attributes
    ----------
    mechanism : closure.Mechanism
        Links ``L1…Ln`` and ``body``; joints ``g<i>`` (ground–L<i>) and ``m<i>`` (L<i>–body).
    mobility : int
        The engine's mobility, idle freedoms (the spin of an S–S link) included.
    idle : int
        Number of idle freedoms (links with two spherical joints).
    drive : str
        The driven joint (R, H or P), or ``"body"``: the body coordinate of the virtual
        chain (joints ``body_slide``, ``body_e1``, ``body_e2``, ``body_ball``), the
        displacement of ``drive_point`` along ``drive_direction``.
    drive_values : numpy.ndarray, shape (P,)
        The drive's coordinate at each task position (rad, or length for P and body).
    travel : numpy.ndarray, shape (P,)
        Drive travel from position 1 to each position in the sense of the sweep (rad or
        length, ≥ 0 for angles).
    pose_error : numpy.ndarray, shape (P,)
        Body pose error at each position's drive value on the swept branch: the larger
        of rotation (rad) and translation divided by the task's reach; inf where the
        sweep stopped before.
    loop_residual : numpy.ndarray, shape (P,)
        The engine's loop-closure residual at those rows (dimensionless; inf if not reached).
    reached : numpy.ndarray of bool, shape (P,)
        ``pose_error <= tol``.
    order_defect : bool
        The travels of positions 2…P are not strictly increasing: the drive, turning
        from position 1 toward position 2, meets the positions out of the task's order.
    branch_defect : bool
        A position is not reached on the branch swept from position 1 (it lies on
        another branch or circuit of the assembly: every dyad passes it by construction).
    dead_point : bool
        The sweep stopped (a fold of the drive: "dead point", or "no assembly") or met a
        near-singular configuration (condition above the engine's limit) before the last
        position.
    transmission : float
        Transmission quality: the smallest inverse condition number (dimensionless, in
        [0, 1]; 0 at a singularity) of the engine's Jacobian of the unknowns along the
        sweep from position 1 to the last position reached.
    sweep : pandas.DataFrame
        The engine's sweep table.
    drive_point, drive_direction : numpy.ndarray, shape (3,) or None
        For ``drive="body"``: the body point (position 1, length) and the unit direction
        of its driven displacement; None for a joint drive.
    """

    mechanism: Mechanism
    mobility: int
    idle: int
    drive: str
    drive_values: np.ndarray
    travel: np.ndarray
    pose_error: np.ndarray
    loop_residual: np.ndarray
    reached: np.ndarray
    order_defect: bool
    branch_defect: bool
    dead_point: bool
    transmission: float
    sweep: object = field(repr=False, default=None)
    drive_point: np.ndarray | None = None
    drive_direction: np.ndarray | None = None

    @property
    def defects(self) -> bool:
        """True when any defect (order, branch, dead point) was found."""
        return bool(self.order_defect or self.branch_defect or self.dead_point)


def _joints_of(link, v: int):
    """``[(kind, frame, pitch, values (P,) or None)]`` for the fixed and moving joint."""
    if isinstance(link, RRLink):
        return [("R", _frame_of(link.fixed_axis), None, np.asarray(link.fixed_angles, float)),
                ("R", _frame_of(link.moving_axis), None, np.asarray(link.moving_angles, float))]
    if isinstance(link, RSLink):
        return [("R", _frame_of(link.axis), None, np.asarray(link.angles, float)),
                ("S", transform(None, link.centre), None, None)]
    if isinstance(link, BinaryLink):
        out = []
        for k, kind in enumerate(link.types):
            ax = link.fixed_axis if k == 0 else link.moving_axis
            pitch = link.fixed_pitch if k == 0 else link.moving_pitch
            ang = link.fixed_angles if k == 0 else link.moving_angles
            sl = link.fixed_slides if k == 0 else link.moving_slides
            if kind == "S":
                out.append(("S", transform(None, ax.point), None, None))
            elif kind in "RHP":
                out.append((kind, _frame_of(ax), float(pitch) if kind == "H" else None,
                            np.asarray(sl if kind == "P" else ang, float)))
            elif kind == "C":
                out.append(("C", _frame_of(ax), None, None))
            else:
                raise SynthesisError(f"links[{v}]: types {link.types!r}: assemble takes R, H, "
                                     "C, P and S joints (not U)")
        return out
    raise SynthesisError(f"links[{v}]: expected an RRLink, RSLink or BinaryLink, got "
                         f"{type(link).__name__}")


def assemble(links, screws, *, drive: str | None = None, steps: int = 180,
             tol: float = 1e-9, drive_point=None, drive_direction=None) -> Assembly:
    """Close binary links sharing ground and body into a mechanism and sweep it.

    Parameters
    ----------
    links : sequence of RRLink, RSLink or BinaryLink (at least two)
        Links through the same positions, ground joint first (joints R, H, C, P, S).
    screws : sequence of Screw, length P − 1
        The task: displacements S12…S1P from position 1.
    drive : str, optional
        The driven joint, ``"g<i>"`` (ground joint of link i, 1-based) or ``"m<i>"``; an
        R, H or P joint; or ``"body"``: a body coordinate, the displacement of a body
        point along a fixed direction, through a virtual chain ground–P–P–P–S–body that
        adds no constraint (for mechanisms without a drivable joint, e.g. a 5-SS
        platform; a dead point then means that coordinate turns back, and the order is
        the order along it).  Default: the first R, H or P joint of g1, m1, g2, …, else
        ``"body"``.
    steps : int
        Rows of the sweep per full turn of an angle drive (or over the travel of a P
        drive), at least 8; the engine subdivides further to stay on its branch.
    tol : float
        Largest pose error (rad, or relative to the task's reach) of a reached position.
    drive_point, drive_direction : array_like, shape (3,), optional
        For ``drive="body"``: the body point (in position 1, length) and the direction
        of its driven displacement; default the task's centre and the direction in which
        it travels to position 2.  A slide drive sweeps forward from position 1 and, for
        positions behind it, backward.

    Returns
    -------
    Assembly

    Raises
    ------
    SynthesisError
        Bad arguments (named), links that do not have one joint value per position, or
        a mechanism whose mobility less its idle freedoms is not 1.
    """
    if isinstance(links, (str, bytes)) or not isinstance(links, (list, tuple)):
        raise SynthesisError(f"links: expected a list of at least two links, got "
                             f"{type(links).__name__}")
    links = list(links)
    if len(links) < 2:
        raise SynthesisError(f"links: expected at least two links, got {len(links)}")
    try:
        scr = _screws(screws, "screws")
    except SynthesisError:
        raise
    except Exception as e:          # pragma: no cover - validate raises SynthesisError
        raise SynthesisError(f"screws: expected a sequence of Screw ({e})") from None
    if len(scr) < 1:
        raise SynthesisError("screws: expected at least one screw (two positions)")
    steps = integer(steps, "steps", low=8)
    tol = number(tol, "tol", positive=True)
    P = len(scr) + 1
    T = np.array([np.eye(4)] + [s.matrix() for s in scr])
    centre, _, reach = task_scale(list(T[1:]), [s.axis for s in scr], [s.point for s in scr])
    joints = [_joints_of(lk, v) for v, lk in enumerate(links)]
    for v, js in enumerate(joints):
        for kind, _, _, vals in js:
            if vals is not None and vals.shape != (P,):
                raise SynthesisError(f"links[{v}]: has joint values for {vals.shape[0]} "
                                     f"positions, but screws give {P} positions")
    names = [f"{c}{i + 1}" for i in range(len(links)) for c in "gm"]
    kinds = {n: joints[i // 2][i % 2][0] for i, n in enumerate(names)}
    if drive is None:
        drive = next((n for n in names if kinds[n] in "RHP"), "body")
    if not isinstance(drive, str) or drive not in names + ["body"]:
        raise SynthesisError(f"drive: expected one of {names + ['body']}, got {drive!r}")
    if drive != "body" and kinds[drive] not in "RHP":
        raise SynthesisError(f"drive: {drive} is a {kinds[drive]} joint; expected an R, H or "
                             "P joint, or 'body'")
    m = Mechanism([f"L{i + 1}" for i in range(len(links))] + ["body"])
    for i, js in enumerate(joints):
        for c, (kind, frame, pitch, _), a, b in zip("gm", js, ("ground", f"L{i + 1}"),
                                                    (f"L{i + 1}", "body")):
            m.add_joint(f"{c}{i + 1}", kind, a, b, at=frame, pitch=pitch)
    idle = sum(1 for js in joints if js[0][0] == "S" and js[1][0] == "S")
    mob = m.mobility
    if mob - idle != 1:
        raise SynthesisError(f"links: the assembled mechanism has mobility {mob} ({idle} idle "
                             f"freedoms); assemble sweeps mechanisms of one degree of freedom")
    point = direction = None
    if drive == "body":
        if drive_point is not None:
            centre = vec3(drive_point, "drive_point")
        point, direction, dvals = _body_drive(
            m, T, centre, reach, None if drive_direction is None else
            unit(drive_direction, "drive_direction"))
        dkind = "P"
    else:
        dkind, _, _, dvals = joints[int(drive[1:]) - 1][0 if drive[0] == "g" else 1]
        m.add_input(drive)
    angle = dkind != "P"
    # the sense of travel: toward position 2 first (the short way for an angle)
    d2 = dvals[1] - dvals[0]
    if angle:
        d2 = (d2 + np.pi) % (2 * np.pi) - np.pi
    sense = 1.0 if d2 >= 0 else -1.0
    travel = sense * (dvals - dvals[0])
    if angle:
        travel = travel % (2 * np.pi)
    order = bool(np.any(np.diff(travel[1:]) <= 0)) or bool(np.any(travel[1:] <= 0))
    err = np.full(P, np.inf)
    res = np.full(P, np.inf)
    tables, conds, stopped, near = [], [], False, False
    # from position 1 forward, and for a slide also backward to positions behind it
    for side in (1.0, -1.0) if not angle and np.any(travel < 0) else (1.0,):
        mine = side * travel >= 0
        end = float(np.max(side * travel[mine]))
        span = 2 * np.pi if angle else max(float(np.abs(travel).max()), 1e-300)
        grid = np.linspace(0.0, end, max(2, int(np.ceil(steps * end / span)) + 1))
        path = np.unique(np.concatenate([grid, side * travel[mine]]))
        df, poses = m.sweep(dvals[0] + sense * side * path, return_pose=True)
        ok = df["status"].isin(["ok", "near-singular"]).to_numpy()
        n_ok = len(ok) if ok.all() else int(np.argmin(ok))
        body = poses.kinematics(twists=False).link[:, m.links.index("body")]
        for p in np.flatnonzero(mine):
            row = int(np.searchsorted(path, side * travel[p]))
            if row < n_ok:
                rot, pos = pose_errors(body[row], T[p], reach)
                err[p] = max(float(rot), float(pos))
                res[p] = float(df["residual"].iloc[row])
        conds.append(df["condition"].to_numpy()[:n_ok].astype(float))
        near |= bool(np.any(df["status"].to_numpy()[:n_ok] == "near-singular"))
        stopped |= n_ok < len(ok)
        tables.append(df if side > 0 else df.iloc[:0:-1])
    df = pd.concat(tables[::-1], ignore_index=True) if len(tables) > 1 else tables[0]
    cond = np.concatenate(conds)
    reached = err <= tol
    return Assembly(m, int(mob), idle, drive, dvals.copy(), travel, err, res, reached,
                    order_defect=order, branch_defect=bool(not reached.all()),
                    dead_point=bool(stopped or near),
                    transmission=float(np.min(1.0 / cond)) if cond.size else 0.0, sweep=df,
                    drive_point=point, drive_direction=direction)


def _body_drive(m, T, c, reach, d=None):
    """Drive ``m`` through a body coordinate: the virtual chain ground –P(d)– –P(e1)–
    –P(e2)– –S– body at the body point c (position 1), its first slide the input (every
    coordinate zero at position 1, so the chain closes there).  d defaults to the
    direction in which c travels to position 2.  Returns ``(c, d, drive values (P,))``."""
    moved = T[:, :3, :3] @ c + T[:, :3, 3] - c                  # c's displacement (P, 3)
    if d is None:
        n2 = float(np.linalg.norm(moved[1]))
        if not n2 > 1e-9 * reach:
            raise SynthesisError("drive: 'body': the drive point does not move from position "
                                 f"1 to 2 (by {n2:.1e}); give drive_direction or drive a joint")
        d = moved[1] / n2
    e1 = np.cross(d, [1.0, 0, 0] if abs(d[0]) < 0.9 else [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    names = ["body_slide", "body_e1", "body_e2"]
    m.add_link("body_V1")
    m.add_link("body_V2")
    m.add_link("body_V3")
    chain = ["ground", "body_V1", "body_V2", "body_V3"]
    for k, (name, z) in enumerate(zip(names, (d, e1, e2))):
        x = e1 if k == 0 else d
        m.add_joint(name, "P", chain[k], chain[k + 1],
                    at=transform(np.stack([x, np.cross(z, x), z], -1), c))
    m.add_joint("body_ball", "S", "body_V3", "body", at=transform(None, c))
    m.add_input("body_slide")
    return c, d, moved @ d


def link_from_row(row) -> BinaryLink:
    """The binary link of a two-joint table row (:func:`synthesis.complete_dyads`,
    :func:`synthesis.least_squares_dyads`): its joint kinds, axes (or sphere centres) in
    position 1 and joint values ``q{k}_pos{p}`` (angle rad, or a P joint's slide) and
    ``d{k}_pos{p}`` (slide, length) at every position.

    Raises
    ------
    SynthesisError
        A row that is not a regular two-joint link (naming what is missing).
    """
    if not hasattr(row, "get") or not hasattr(row, "__getitem__") or isinstance(row, str):
        raise SynthesisError(f"row: expected a table row (pandas Series or mapping), got "
                             f"{type(row).__name__}")
    types = "".join(str(row.get(f"j{k}_type", "")) for k in (1, 2))
    if len(types) != 2 or any(t not in "RHPCS" for t in types) or \
            isinstance(row.get("j3_type"), str):
        raise SynthesisError(f"row: expected a two-joint link (kinds R, H, P, C, S), got "
                             f"types {types!r}")
    if row.get("reason", ""):
        raise SynthesisError(f"row: variant {row.get('variant')} is degenerate: {row['reason']}")
    lines, vals = [], []
    n = 0
    while f"q1_pos{n + 1}" in row:
        n += 1
    for k, t in enumerate(types, start=1):
        try:
            u = np.array([row[f"j{k}_u{c}"] for c in "xyz"], float)
            pt = np.array([row[f"j{k}_{c}"] for c in "xyz"], float)
        except KeyError as e:
            raise SynthesisError(f"row: missing column {e}") from None
        if t == "S":
            u = np.array([0.0, 0.0, 1.0])
        if not (np.all(np.isfinite(u)) and np.all(np.isfinite(pt))):
            raise SynthesisError(f"row: joint {k} has a non-finite axis or point")
        lines.append(Line(u, pt))
        q = np.array([row.get(f"q{k}_pos{p}", np.nan) for p in range(1, n + 1)], float)
        d = np.array([row.get(f"d{k}_pos{p}", 0.0) for p in range(1, n + 1)], float)
        pitch = float(row.get(f"j{k}_pitch", np.nan))
        ang = np.zeros(n) if t == "P" else q
        sl = q if t == "P" else pitch * q if t == "H" else np.nan_to_num(d) if t == "C" \
            else np.zeros(n)
        vals.append((pitch, ang, sl))
    (pf, af, sf), (pm, am, sm) = vals
    return BinaryLink(types, lines[0], lines[1], pf, pm, af, sf, am, sm,
                      float(row.get("residual", np.nan)), {})


def assemble_table(table: pd.DataFrame, screws, *, links: int = 2, drive: str | None = None,
                   steps: int = 180, tol: float = 1e-9) -> pd.DataFrame:
    """Every mechanism of ``links`` regular binary links of a solution table, assembled
    (:func:`assemble`) and swept through the task: the pairing's defects and transmission,
    ranked — mechanisms without defects first, then by transmission (best first).

    Parameters
    ----------
    table : pandas.DataFrame
        Rows of two-joint links (:func:`synthesis.complete_dyads`,
        :func:`synthesis.least_squares_dyads`) through the positions of ``screws``.
    screws : sequence of Screw
        The task (S₁₂ … S₁N).
    links : int
        Links per mechanism (2: RR + RR is a Bennett 4R).
    drive, steps, tol
        As :func:`assemble`.

    Returns
    -------
    pandas.DataFrame
        One row per combination: ``variants`` (the table's variant numbers, joined by
        "+"), ``mobility``, ``order_defect``, ``branch_defect``, ``dead_point``,
        ``defects`` (any of the three), ``transmission``, ``pose_error`` (largest over
        the positions; inf where not reached), ``reason`` (why it could not be assembled:
        mobility not 1, or ``drive`` not a drivable joint), ``rank`` (1 best; NaN where not
        assembled).
    """
    from .validate import integer
    links = integer(links, "links", low=2)
    steps = integer(steps, "steps", low=8)
    tol = number(tol, "tol", positive=True)
    if not isinstance(table, pd.DataFrame):
        raise SynthesisError(f"table: expected a pandas DataFrame, got {type(table).__name__}")
    scr = _screws(screws, "screws")
    n_pos = sum(1 for c in table.columns if str(c).startswith("q1_pos"))
    if n_pos and len(scr) + 1 != n_pos:
        raise SynthesisError(f"screws: the table's links go through {n_pos} positions, the "
                             f"screws give {len(scr) + 1}")
    ok = table[table.get("reason", pd.Series("", index=table.index)).fillna("") == ""]
    rows = []
    for combo in itertools.combinations(range(len(ok)), links):
        rs = [ok.iloc[i] for i in combo]
        rec = {"variants": "+".join(str(int(r["variant"])) for r in rs), "mobility": np.nan,
               "order_defect": np.nan, "branch_defect": np.nan, "dead_point": np.nan,
               "defects": np.nan, "transmission": np.nan, "pose_error": np.nan, "reason": ""}
        try:
            a = assemble([link_from_row(r) for r in rs], screws, drive=drive, steps=steps,
                         tol=tol)
        except SynthesisError as e:
            rec["reason"] = str(e)
        else:
            rec.update(mobility=a.mobility, order_defect=a.order_defect,
                       branch_defect=a.branch_defect, dead_point=a.dead_point,
                       defects=a.defects, transmission=a.transmission,
                       pose_error=float(np.max(a.pose_error)))
        rows.append(rec)
    out = pd.DataFrame(rows, columns=["variants", "mobility", "order_defect", "branch_defect",
                                      "dead_point", "defects", "transmission", "pose_error",
                                      "reason"])
    good = out[out.reason == ""]
    order = good.assign(d=good.defects.astype(bool)).sort_values(
        ["d", "transmission"], ascending=[True, False]).index
    out["rank"] = np.nan
    out.loc[order, "rank"] = np.arange(1, len(order) + 1)
    return out
