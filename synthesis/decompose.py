"""The family table's decompositions (Kharatyan 1981, Table 3): every dyad family J1 J2 J3
(ground → body) built from a main binary link and a transition joint, enumerated into one
table and verified by the closure engine.

Arrangements.  (a) The main link is (J2, J3), synthesised through the main positions
P_main (position 1 and n_b − 1 others) with J1 locked; J1 (in the ground) then carries the
body from a transition position s ∈ P_main to each remaining position, J2 locked at its
value at s and J3 free.  (b) The main link is (J1, J3); the transition joint is J2 (the
middle joint), locked through P_main; at the remaining positions J1 stays at its value at
s.  Its axis at the configuration of s is exactly arrangement (a)'s transition axis t*
(``T_l = X_{t*}(ψ_l) · Y_s(Δ_l) · T_s``), so its position-1 location is
``G_{J1}(q1_s)⁻¹ t*``.  Both reduce to the same transition problem
(:mod:`synthesis.transition`).

Counting (Table 3's N): n_b positions of the main link plus the remaining positions the
transition joint carries (R carrying R, H, P or C: one; C carrying C: two).  Every choice
is enumerated: the main positions (always containing position 1), every solution of the
main link (and every value of its free parameters on the user's grid), every transition
position s, every root of the transition, both arrangements where they apply.

Enumeration.  The variants are listed first (main-link solutions × transition positions ×
transition angles); the transition problems they pose (distinct per main link, transition
position and angle) are solved in one batched call per transition kind
(:func:`synthesis.transition.transition_joints`), and the table's columns are built as
arrays (axes canonicalised and oriented for all variants at once) before the regular
variants are verified by the engine in one call.  The RC, CR, HC, CH main links of a
direction grid are solved in one batch per main-position set
(:func:`synthesis.cylindric.fixed_direction_links`).

Free parameters (keyword choices of :func:`synthesis.enumerate_dyads`; a scalar/one
vector or a grid; the table has a column per parameter):

* ``pitch`` (length/rad): the pitch of every helical joint (a number, or three numbers,
  one per joint, ignored at non-helical joints).  Required for families with H.
* ``slide_direction`` (unit 3-vector or (m, 3)): the main link's prismatic slide
  direction (PR, PH, PC: in the ground; RP, HP, CP: in the body at position 1).  Default:
  4 directions spread over a hemisphere of the task's frame
  (:func:`synthesis.spherical.task_frame`: they turn with the task).
* ``prismatic_slide`` (length, scalar or (m,)): the main PC/CP link's prismatic slide from
  position 1 to its other main position.  Default: ±0.5 × the task's reach.
* ``fixed_direction`` (unit 3-vector or (m, 3)): the main RC, CR, HC or CH link's fixed
  axis direction.  Default: the same 4 directions of the task's frame.
* ``transition_angle`` (rad, scalar or (m,)): J3's rotation while an R transition joint
  carries a C joint (from the transition position to the remaining one).  Default:
  −1.5, −0.5, 0.5, 1.5.
"""
from __future__ import annotations

import functools
import itertools

import numpy as np
import pandas as pd

from .binary import BinaryLink, _fibonacci, _screw_matrix
from .errors import SynthesisError
from .screw import Line, Screw
from .spherical import task_frame
from .transition import TRANSITION_POSITIONS, transition_joints
from .twopos import two_position_links
from .validate import array, task_scale
from .verify import line_frames, verify_frames

__all__ = ["MAIN_POSITIONS", "arrangements", "decomposed_dyads", "FREE_PARAMETERS"]

#: main binary link → positions it is synthesised through
MAIN_POSITIONS = {"RR": 3, "RH": 3, "HR": 3, "HH": 3, "PR": 2, "PH": 2, "RP": 2, "HP": 2,
                  "RC": 3, "CR": 3, "HC": 3, "CH": 3, "CC": 5, "PC": 2, "CP": 2}

#: free parameter → (unit, what it is)
FREE_PARAMETERS = {
    "pitch": ("length/rad", "pitch of the helical joints (given, not enumerated)"),
    "slide_direction": ("unit vector", "the main link's prismatic slide direction"),
    "prismatic_slide": ("length", "the main PC/CP link's prismatic slide"),
    "fixed_direction": ("unit vector", "the main RC/CR/HC/CH link's fixed axis direction"),
    "transition_angle": ("rad", "J3's rotation while an R transition carries a C joint"),
}

_PITCH_OF = {"R": 0.0, "C": np.nan, "P": np.inf}
#: pitch column of a joint kind (H: the given pitch; C, S, U: NaN)
PITCH_OF_KIND = {"R": 0.0, "P": np.inf}
#: the azimuth grid (rad) of the sphere and Hooke families when the user gives none
DEFAULT_AZIMUTHS = np.arange(4) * np.pi / 4


def arrangements(family: str, n_positions: int | None = None) -> list[tuple]:
    """The arrangements that build ``family`` (three joint letters, ground first):
    ``(name, main link kinds, transition kind, main positions n_b, transition positions)``,
    only those implemented; with ``n_positions``, only those using that many positions."""
    out = []
    for name, main, x in (("a", family[1:], family[0]), ("b", family[0] + family[2], family[1])):
        key = (x, family[2])
        if main in MAIN_POSITIONS and key in TRANSITION_POSITIONS:
            n = MAIN_POSITIONS[main] + TRANSITION_POSITIONS[key]
            if n_positions is None or n == n_positions:
                out.append((name, main, x, MAIN_POSITIONS[main], TRANSITION_POSITIONS[key]))
    return out


# ------------------------------------------------------------------ choices
def _grid_vectors(v, name, default):
    if v is None:
        return default
    a = array(v, name, None, what="a unit 3-vector or an (m, 3) array of them")
    a = np.atleast_2d(a)
    if a.ndim != 2 or a.shape[1] != 3 or len(a) == 0:
        raise SynthesisError(f"{name}: expected a unit 3-vector or an (m, 3) array of them, got "
                             f"shape {np.shape(v)}")
    n = np.linalg.norm(a, axis=1)
    if np.any(np.abs(n - 1) > 1e-6):
        raise SynthesisError(f"{name}: expected unit vectors, got lengths "
                             f"{np.array2string(n, precision=6)}")
    return a / n[:, None]


def _grid_numbers(v, name, default):
    if v is None:
        return np.asarray(default, float)
    a = np.atleast_1d(array(v, name, None, what="a number or a 1-D array of numbers"))
    if a.ndim != 1 or len(a) == 0:
        raise SynthesisError(f"{name}: expected a number or a 1-D array of numbers, got shape "
                             f"{np.shape(v)}")
    return a.astype(float)

def task_positions(family: str, screws, arrangements_of):
    """The positions ``T (N, 4, 4)`` (position 1 the identity), the family's arrangements
    through N positions (``arrangements_of(family, N)``) and the task's reach; a clear
    error naming ``screws`` when the family is not built through that many."""
    T = np.stack([np.eye(4)] + [s.matrix() for s in screws])
    N = len(T)
    arr = arrangements_of(family, N)
    if not arr:
        counts = sorted({a[3] + a[4] for a in arrangements_of(family)})
        raise SynthesisError(f"screws: family {family} is built through "
                             f"{' or '.join(map(str, counts))} positions "
                             f"({' or '.join(str(c - 1) for c in counts)} screws), got {N - 1}")
    _, _, reach = task_scale(T, [s.axis for s in screws], [s.point for s in screws])
    return T, N, arr, reach


def angle_grid(v, name: str, default) -> np.ndarray:
    """A free angle given as a number or a 1-D array (rad); ``default`` when None."""
    if v is None:
        return np.asarray(default, float)
    a = np.atleast_1d(array(v, name, None, what="a number or a 1-D array (rad)"))
    if a.ndim != 1 or len(a) == 0:
        raise SynthesisError(f"{name}: expected a number or a 1-D array of angles (rad), got "
                             f"shape {np.shape(v)}")
    return a


def _pitches(family, pitch):
    if "H" not in family:
        if pitch is not None:
            raise SynthesisError(f"pitch: family {family} has no helical joint")
        return [_PITCH_OF[t] for t in family]
    if pitch is None:
        raise SynthesisError(f"pitch: family {family} has helical joints; give their pitch "
                             "(length/rad, a number or one per joint)")
    p = np.atleast_1d(array(pitch, "pitch", None, what="a number or three numbers"))
    if p.shape not in ((1,), (3,)):
        raise SynthesisError(f"pitch: expected a number or three numbers (one per joint), got "
                             f"shape {p.shape}")
    p = np.broadcast_to(p, (3,))
    out = []
    for k, t in enumerate(family):
        if t == "H":
            if not np.isfinite(p[k]):
                raise SynthesisError(f"pitch: joint {k + 1} is helical; expected a finite pitch, "
                                     f"got {p[k]}")
            if p[k] == 0:
                raise SynthesisError(f"pitch: joint {k + 1} is helical with pitch 0, which makes "
                                     "it a revolute joint: use the family with R there")
            out.append(float(p[k]))
        else:
            out.append(_PITCH_OF[t])
    return out


# ------------------------------------------------------------------ main links
def _main_links(kinds, pitches, T, scr, reach, choices):
    """Main-link solutions through the positions T (n_b, 4, 4) (T[0] = I), ``scr`` their
    screws from position 1 (``Screw.from_matrix`` of T[1:]): a list of (BinaryLink or None,
    parameters dict, reason)."""
    pf, pm = pitches
    out = []

    def attempt(fn, params):
        try:
            links = fn()
        except SynthesisError as e:
            out.append((None, params, str(e)))
            return
        if not links:
            out.append((None, params, f"no real {kinds} link through these positions"))
        for lk in links:
            out.append((_oriented(lk), params, ""))

    if kinds == "RR":
        from .rr import rr_links
        attempt(lambda: [_from_rr(lk) for lk in rr_links(*scr)], {})
    elif kinds in ("RH", "HR", "HH"):
        from .helical import helical_links
        attempt(lambda: helical_links(*scr, fixed_pitch=0.0 if kinds[0] == "R" else pf,
                                      moving_pitch=0.0 if kinds[1] == "R" else pm), {})
    elif kinds in ("RC", "HC", "CR", "CH"):
        from .cylindric import fixed_direction_links
        G = choices["fixed_direction"]
        try:                                       # every direction of the grid at once
            res = fixed_direction_links(
                "RC" if kinds[1] == "C" else "CR", *scr, G,
                (0.0 if kinds[0] == "R" else pf) if kinds[1] == "C" else
                (0.0 if kinds[1] == "R" else pm))
        except SynthesisError as e:
            res = [e] * len(G)
        for g, r in zip(G, res):
            if isinstance(r, SynthesisError):
                out.append((None, {"fixed_direction": g}, str(r)))
            else:
                out.extend((_oriented(lk), {"fixed_direction": g}, "") for lk in r)
    elif kinds == "CC":
        from .cylindric import cc_links
        attempt(lambda: cc_links(scr), {})
    else:                                                          # two positions with a P
        slides = choices["prismatic_slide"] if "C" in kinds else [None]
        hp = pm if kinds[1] == "H" else pf if kinds[0] == "H" else 0.0
        grid = [(dv, a) for dv in choices["slide_direction"] for a in slides]
        # every (slide direction, prismatic slide) of the grid at once
        links = two_position_links(kinds, T[1], slide_directions=[g[0] for g in grid],
                                   pitch=hp, prismatic_slides=[g[1] for g in grid],
                                   reach=reach)
        for (dv, a), lk in zip(grid, links):
            params = {"slide_direction": dv}
            if a is not None:
                params["prismatic_slide"] = float(a)
            if isinstance(lk, SynthesisError):
                out.append((None, params, str(lk)))
            else:
                out.append((_oriented(lk), params, ""))
    return out


def _from_rr(lk) -> BinaryLink:
    z = np.zeros(len(lk.fixed_angles))
    return BinaryLink("RR", lk.fixed_axis, lk.moving_axis, 0.0, 0.0, np.asarray(lk.fixed_angles),
                      z, np.asarray(lk.moving_angles), z.copy(), lk.residual)


# ------------------------------------------------------------------ verification
def verify_dyads(family, U, P, pitches, values, targets, length: float) -> np.ndarray:
    """Drive m three-joint chains of ``family`` (R, P, C, H) through their joint values
    with the closure engine (all in one bulk evaluation,
    :func:`synthesis.verify.verify_frames`) and return each chain's largest pose error
    (rad, or translation / ``length``).

    Parameters
    ----------
    family : str
        The chains' three joint letters.
    U, P : array_like, shape (3, m, 3)
        Per joint the chains' unit axis directions and points in position 1.
    pitches : array_like, shape (3,) or (m, 3)
        Length / rad, read for H joints.
    values : numpy.ndarray, shape (m, n, 3, 2)
        Angle (rad) and slide (length) of every joint at each of the n positions.
    targets : numpy.ndarray, shape (n, 4, 4)
        The body's given poses.
    length : float
        Length the translation errors are divided by.

    Returns
    -------
    numpy.ndarray, shape (m,)
    """
    F = line_frames(np.swapaxes(U, 0, 1).reshape(-1, 3), np.swapaxes(P, 0, 1).reshape(-1, 3),
                    check=False)
    return verify_frames(family, F.reshape(-1, 3, 4, 4), np.swapaxes(values, 0, 1), pitches,
                         targets, length)


# ------------------------------------------------------------------ enumeration
def _flipped(u) -> bool:
    """Orientation rule of every axis in the table: its largest component (the first of
    equal ones) is positive."""
    a = u.tolist() if isinstance(u, np.ndarray) else [float(x) for x in u]
    if len(a) != 3 or any(x != x for x in a):                   # NaN: numpy's argmax rule
        return bool(u[np.argmax(np.abs(u) - 1e-12 * np.arange(3))] < 0)
    b = [abs(a[0]), abs(a[1]) - 1e-12, abs(a[2]) - 2e-12]
    return a[max(range(3), key=b.__getitem__)] < 0


def _flip_signs(u) -> np.ndarray:
    """:func:`_flipped` of directions ``u (n, 3)`` as signs ``(n,)``: −1 where flipped."""
    i = np.argmax(np.abs(u) - 1e-12 * np.arange(3), axis=-1)
    return np.where(np.take_along_axis(u, i[:, None], 1)[:, 0] < 0, -1.0, 1.0)


def _oriented(lk: BinaryLink) -> BinaryLink:
    """The same link with both axes oriented by :func:`_flipped` (a flipped axis turns and
    slides the other way: its joint values change sign; a pitch does not)."""
    out = BinaryLink(lk.types, lk.fixed_axis, lk.moving_axis, lk.fixed_pitch, lk.moving_pitch,
                     lk.fixed_angles, lk.fixed_slides, lk.moving_angles, lk.moving_slides,
                     lk.residual, dict(lk.parameters))
    if _flipped(lk.fixed_axis.direction):
        out.fixed_axis = Line._exact(-lk.fixed_axis.direction, lk.fixed_axis.point)
        out.fixed_angles, out.fixed_slides = -lk.fixed_angles, -lk.fixed_slides
    if _flipped(lk.moving_axis.direction):
        out.moving_axis = Line._exact(-lk.moving_axis.direction, lk.moving_axis.point)
        out.moving_angles, out.moving_slides = -lk.moving_angles, -lk.moving_slides
    return out


def _canonical_points(U, P):
    """Canonical points ``(3, n, 3)`` of chains of three lines (directions ``U``, points
    ``P``, ``(3, n, 3)``), as :meth:`Line.canonical`: joint 1 the foot from the origin, the
    others the foot of the common normal with the previous joint (parallel: the
    perpendicular foot of the previous joint's point)."""
    P = P.copy()
    P[0] = P[0] + np.einsum("ij,ij->i", -P[0], U[0])[:, None] * U[0]
    for k in (1, 2):
        u, v, w = U[k - 1], U[k], P[k - 1] - P[k]
        b = np.einsum("ij,ij->i", u, v)
        den = 1 - b * b
        d, e = np.einsum("ij,ij->i", u, w), np.einsum("ij,ij->i", v, w)
        par = den < 1e-12
        t = np.where(par, e, (e - b * d) / np.where(par, 1.0, den))
        P[k] = P[k] + t[:, None] * v
    return P


def decomposed_dyads(family: str, screws, *, _verify: bool = True, **choices) -> pd.DataFrame:
    """Every variant of ``family`` (R, P, C, H joints) through the positions ``screws``
    by the decompositions of the module notes; see :func:`synthesis.enumerate_dyads` for
    the table's columns and the keyword choices.

    ``_verify=False`` (internal: kinematic inversion verifies the reversed chains itself)
    leaves the engine check out: every residual is NaN.

    The enumeration lists the variants (main link solutions × transition positions ×
    transition angles) first, then solves the transition joints of all of them in one
    batched call per transition kind (:func:`synthesis.transition.transition_joints`) and
    builds the table's columns as arrays."""
    T, N, arr, reach = task_positions(family, screws, arrangements)
    unknown = set(choices) - set(FREE_PARAMETERS)
    if unknown:
        raise SynthesisError(f"{', '.join(sorted(unknown))}: unknown choice; expected "
                             f"{', '.join(FREE_PARAMETERS)}")
    pitches = _pitches(family, choices.get("pitch"))
    # default direction grids live in the task's own frame, so they move with the task
    dirs = _fibonacci(4) @ task_frame(screws).T
    ch = {"fixed_direction": _grid_vectors(choices.get("fixed_direction"), "fixed_direction",
                                           dirs),
          "slide_direction": _grid_vectors(choices.get("slide_direction"), "slide_direction",
                                           dirs),
          "prismatic_slide": _grid_numbers(choices.get("prismatic_slide"), "prismatic_slide",
                                           [-0.5 * reach, 0.5 * reach]),
          "transition_angle": _grid_numbers(choices.get("transition_angle"), "transition_angle",
                                            [-1.5, -0.5, 0.5, 1.5])}
    used = _used_parameters(family, arr)
    for name in ("fixed_direction", "slide_direction", "prismatic_slide", "transition_angle"):
        if choices.get(name) is not None and name not in used:
            raise SynthesisError(f"{name}: not a free parameter of family {family} through "
                                 f"{N} positions (its free parameters: "
                                 f"{', '.join(sorted(used)) or 'none'})")
    y_kind = family[2]
    scr = [None] + [Screw.from_matrix(t) for t in T[1:]]      # each position's screw, once
    # ---- 1. the variants' slots (one per main link solution, transition position and
    # transition angle: rows (group, transition position index, main-link entry,
    # transition-angle index or −1)) and the main links
    groups, blocks = [], []             # groups: (name, main, x, Pm, rest)
    entries, entry_of = [], {}          # main-link solutions (link or None, params, reason)
    cache = {}
    for name, main, x, n_b, k in arr:
        mp = [pitches[1], pitches[2]] if name == "a" else [pitches[0], pitches[2]]
        n_ang = len(ch["transition_angle"]) if (x, y_kind) == ("R", "C") else 1
        # (transition position index, angle index) of one main-link solution, s first
        sa = np.stack([np.repeat(np.arange(n_b), n_ang), np.tile(np.arange(n_ang), n_b)], 1)
        if (x, y_kind) != ("R", "C"):
            sa[:, 1] = -1
        for others in itertools.combinations(range(1, N), n_b - 1):
            Pm = (0,) + others
            rest = tuple(i for i in range(N) if i not in Pm)
            key = (main, tuple(mp), Pm)
            if key not in cache:
                cache[key] = _main_links(main, mp, T[list(Pm)], [scr[i] for i in others],
                                         reach, ch)
            ids = []
            for li, e in enumerate(cache[key]):
                if (key, li) not in entry_of:
                    entry_of[key, li] = len(entries)
                    entries.append(e)
                ids.append(entry_of[key, li])
            blk = np.empty((len(ids) * len(sa), 4), np.int64)
            blk[:, 0] = len(groups)
            blk[:, 1:4:2] = np.tile(sa, (len(ids), 1))
            blk[:, 2] = np.repeat(ids, len(sa))
            blocks.append(blk)
            groups.append((name, main, x, Pm, rest))
    slot = np.concatenate(blocks)
    # ---- 2. the distinct transition problems, solved in one batch per transition kind: a
    # problem depends on the main link, s and the angle only (arrangements a and b with
    # the same main link and transition kind, J1 = J2, share it)
    g_x = np.array(["RC".index(g[2]) for g in groups])
    g_pm, g_rest = _padded([g[3] for g in groups]), _padded([g[4] for g in groups])
    linked = np.array([e[0] is not None for e in entries])[slot[:, 2]]
    keys = np.stack([slot[:, 2], g_x[slot[:, 0]], g_pm[slot[:, 0], slot[:, 1]], slot[:, 3]], 1)
    ji = np.full(len(slot), -1)
    n_jobs = 0
    if linked.any():
        jkeys, first, inv = np.unique(keys[linked], axis=0, return_index=True,
                                      return_inverse=True)
        ji[linked] = inv.reshape(-1)
        n_jobs = len(jkeys)
        j_group = slot[np.flatnonzero(linked)[first], 0]
    # (one padding entry at the end: slots without a transition problem index it as −1)
    job_err = np.full(n_jobs + 1, "", dtype=object)
    job_start, job_count = np.zeros(n_jobs + 1, np.int64), np.zeros(n_jobs + 1, np.int64)
    trs = {}
    for xc in np.unique(jkeys[:, 1]) if n_jobs else []:
        ids = np.flatnonzero(jkeys[:, 1] == xc)
        x = "RC"[xc]
        ang = jkeys[ids, 3]
        trs[x] = tr = _transitions_of(
            x, y_kind, pitches[2], jkeys[ids, 0], jkeys[ids, 2],
            g_rest[j_group[ids], :TRANSITION_POSITIONS[x, y_kind]], entries, T, reach,
            None if ang[0] < 0 else np.asarray(ch["transition_angle"], float)[ang])
        job_err[ids] = tr.error
        cnt = np.bincount(tr.owner, minlength=len(ids))
        job_count[ids] = cnt
        job_start[ids] = np.cumsum(cnt) - cnt
    # ---- 3. the rows: a slot gives one row per transition joint, or one failed row
    e_reason = np.array([e[2] for e in entries] + [""], dtype=object)
    err = np.where(linked, job_err[ji], e_reason[slot[:, 2]])
    count = np.where(linked, job_count[ji], 0)
    err = np.where(linked & (err == "") & (count == 0), "no real transition joint", err)
    ok = err == ""
    per = np.where(ok, count, 1)
    row_slot = np.repeat(np.arange(len(slot)), per)
    nrow = len(row_slot)
    first = np.cumsum(per) - per
    row_tr = np.where(ok[row_slot], job_start[ji[row_slot]] + np.arange(nrow) - first[row_slot],
                      -1)
    row_ok = ok[row_slot]
    rs = slot[row_slot]
    return _table(family, N, T, reach, pitches, groups, entries, trs, rs, row_tr, row_ok,
                  err[row_slot], ch["transition_angle"], _verify)


def _padded(seqs) -> np.ndarray:
    """Integer sequences as the rows of an array, padded with −1 to the longest."""
    n = max(map(len, seqs))
    return np.array([tuple(s) + (-1,) * (n - len(s)) for s in seqs], dtype=np.int64)


def _used_parameters(family, arr):
    used = set()
    for name, main, x, _, _ in arr:
        if main in ("RC", "CR", "HC", "CH"):
            used.add("fixed_direction")
        if "P" in main:
            used.add("slide_direction")
        if main in ("PC", "CP"):
            used.add("prismatic_slide")
        if (x, family[2]) == ("R", "C"):
            used.add("transition_angle")
    return used


def _transitions_of(x, y_kind, y_pitch, entry, s, rest, entries, T, reach, angle):
    """The transition joints of kind ``x`` of the problems (main-link ``entry`` (m,),
    transition position ``s`` (m,), remaining positions ``rest`` (m, k), J3's
    rotation ``angle`` (m,) or None) in one :func:`transition_joints` call: J3's axis moved
    to the transition position s, the displacements ``T_l T_s⁻¹`` to the remaining
    positions."""
    ue, inv = np.unique(entry, return_inverse=True)
    md = np.stack([entries[i][0].moving_axis.direction for i in ue])[inv]
    mpt = np.stack([entries[i][0].moving_axis.point for i in ue])[inv]
    Rs, ts = T[s, :3, :3], T[s, :3, 3]
    # T_l T_s⁻¹ once per distinct (s, remaining positions)
    sr, inv = np.unique(np.column_stack([s, rest]), axis=0, return_inverse=True)
    D = np.stack([T[r[1:]] @ np.linalg.inv(T[r[0]]) for r in sr])[inv.reshape(-1)]
    return transition_joints(x, y_kind, np.einsum("nij,nj->ni", Rs, md),
                             np.einsum("nij,nj->ni", Rs, mpt) + ts, y_pitch, D, reach,
                             angle=angle)


def _table(family, N, T, reach, pitches, groups, entries, trs, rs, row_tr, row_ok,
           reason, angle_grid_, verify) -> pd.DataFrame:
    """The table, its columns built as arrays.

    Parameters
    ----------
    groups : list of (arrangement, main link kinds, transition kind, main positions,
        remaining positions)
    entries : list of (BinaryLink or None, parameters, reason): the main-link solutions
    trs : dict transition kind → Transitions (the solved transition problems)
    rs : numpy.ndarray of int, shape (n, 4)
        Each row's group, transition position (index into the group's main positions),
        main-link entry and transition-angle index (−1: none).
    row_tr : numpy.ndarray of int, shape (n,)
        Each regular row's joint in ``trs`` of its group's transition kind.
    row_ok : numpy.ndarray of bool, shape (n,)
        The rows with a main link and a transition joint (regular unless degenerate).
    reason : numpy.ndarray of object, shape (n,)
        Why a row is not regular ("" for the regular ones).
    angle_grid_ : array_like
        The transition angles (rad) the angle indices point into.
    verify : bool
        Drive the regular rows with the closure engine (the residual column).
    """
    n = len(rs)
    gi, si, ei, ai = rs[:, 0], rs[:, 1], rs[:, 2], rs[:, 3]
    cols = {}
    # base columns: per group and transition position
    g_name = np.array([g[0] for g in groups] + [""], dtype=object)
    g_main = np.array([g[1] for g in groups] + [""], dtype=object)
    g_pm = np.array([str(tuple(i + 1 for i in g[3])) for g in groups] + [""], dtype=object)
    g_tr = np.array([f"{g[2]}{family[2]}" for g in groups] + [""], dtype=object)
    nb = max(len(g[3]) for g in groups)
    order = np.empty((len(groups), nb), dtype=object)
    tpos = np.zeros((len(groups), nb), np.int64)
    for k, (name, main, x, Pm, rest) in enumerate(groups):
        head, tail = tuple(p + 1 for p in Pm), tuple(p + 1 for p in rest)
        for i, s in enumerate(Pm):
            order[k, i] = (f"{main} through {head}; {x} "
                           f"({'J1' if name == 'a' else 'J2'}) carries position {s + 1} to "
                           f"{tail}")
            tpos[k, i] = s + 1
    cols["family"] = [family] * n
    cols["order"] = order[gi, si].tolist()
    cols["arrangement"] = g_name[gi].tolist()
    cols["mechanism"] = cols["arrangement"]
    cols["main_link"] = g_main[gi].tolist()
    cols["main_positions"] = g_pm[gi].tolist()
    cols["transition"] = g_tr[gi].tolist()
    cols["transition_position"] = tpos[gi, si]
    # joint geometry and values of the regular rows
    U = np.full((3, n, 3), np.nan)
    P = np.full((3, n, 3), np.nan)
    vals = np.full((n, N, 3, 2), np.nan)
    reason = reason.copy()
    for name in sorted({g[0] for g in groups}):
        rows = np.flatnonzero(row_ok & (g_name[gi] == name))
        if len(rows):
            _regular(name, family, N, groups, entries, trs, rows, rs, row_tr, U, P, vals)
    good = row_ok.copy()
    if row_ok.any():
        r = np.flatnonzero(row_ok)
        P[:, r] = _canonical_points(U[:, r], P[:, r])
        sg = np.stack([_flip_signs(U[k, r]) for k in range(3)])       # (3, m)
        U[:, r] *= sg[..., None]
        vals[r] *= sg.T[:, None, :, None]
        lines_ok = (np.isfinite(U[:, r]).all((0, 2)) & np.isfinite(P[:, r]).all((0, 2))
                    & (np.abs(P[:, r]).max((0, 2)) < 1e8 * reach))
        fine = lines_ok & np.isfinite(vals[r]).all((1, 2, 3))
        reason[r[~fine]] = "degenerate: an axis at infinity or undefined joint values"
        good[r[~fine]] = False
    for k, t in enumerate(family):
        cols[f"j{k + 1}_type"] = [t] * n
        for c, j in zip(("ux", "uy", "uz"), range(3)):
            cols[f"j{k + 1}_{c}"] = U[k, :, j]
        for c, j in zip("xyz", range(3)):
            cols[f"j{k + 1}_{c}"] = P[k, :, j]
        cols[f"j{k + 1}_pitch"] = np.full(n, float(pitches[k]))
    # free parameters (per main-link entry, and the transition angle)
    pcols, pkeys = {}, []
    for e, (_, params, _) in enumerate(entries):
        keys = []
        for pname, v in params.items():
            v = np.asarray(v, float)
            for c, x in (zip((f"{pname}_{c}" for c in "xyz"), v) if v.ndim else
                         [(pname, v)]):
                pcols.setdefault(c, np.full(len(entries), np.nan))[e] = float(x)
                keys.append(c)
        pkeys.append(keys)
    for c, v in pcols.items():
        cols[c] = v[ei]
    if (ai >= 0).any():
        cols["transition_angle"] = np.where(ai >= 0, np.asarray(angle_grid_, float)[ai], np.nan)
    q = vals[:, :, :, 0].copy()
    for k in range(3):
        if family[k] == "P":
            q[:, :, k] = vals[:, :, k, 1]
    for c, x in zip(_value_columns(N), np.stack([q, vals[:, :, :, 1]], -1).reshape(n, -1).T):
        cols[c] = x
    residual = np.full(n, np.nan)
    if verify and good.any():
        r = np.flatnonzero(good)
        residual[r] = verify_dyads(family, U[:, r], P[:, r], pitches, vals[r], T, reach)
    cols["residual"] = residual
    cols["reason"] = reason.tolist()
    cols["variant"] = np.arange(1, n + 1)
    return pd.DataFrame({c: cols[c] for c in _column_names(N, pkeys, ei, ai, row_ok)})


def _column_names(N, pkeys, ei, ai, row_ok) -> list:
    """The table's columns: :data:`synthesis.dyads.DYAD_COLUMNS` first, then the others in
    the order of a table built row by row (each row's keys: base, joints, its parameters
    (``pkeys`` of its main-link entry ``ei``, the transition angle where ``ai`` ≥ 0), the
    joint values of a regular row, residual, reason, variant)."""
    from .dyads import DYAD_COLUMNS
    base = ["family", "order", "arrangement", "mechanism", "main_link", "main_positions",
            "transition", "transition_position"] + [
        f"j{k}_{c}" for k in (1, 2, 3) for c in ("type", "ux", "uy", "uz", "x", "y", "z", "pitch")]
    names = {}                                          # insertion-ordered set
    _, firsts = np.unique(np.stack([ei, ai >= 0, row_ok], 1), axis=0, return_index=True)
    for i in np.sort(firsts):                           # the first row of each kind of keys
        for c in base + list(pkeys[ei[i]]) + (["transition_angle"] if ai[i] >= 0 else []) + (
                list(_value_columns(N)) if row_ok[i] else []) + ["residual", "reason",
                                                                 "variant"]:
            names.setdefault(c)
    first = [c for c in DYAD_COLUMNS if c in names]
    return first + [c for c in names if c not in first]


def _regular(name, family, N, groups, entries, trs, rows, rs, row_tr, U, P, vals):
    """Fill the axes ``U, P (3, n, 3)`` and joint values ``vals (n, N, 3, 2)`` of the
    regular ``rows`` of arrangement ``name`` (before canonical points and orientation)."""
    gi, si, ei = rs[rows, 0], rs[rows, 1], rs[rows, 2]
    x = groups[gi[0]][2]
    tr = trs[x]
    t = row_tr[rows]
    X, F = (0, 1) if name == "a" else (1, 0)
    ue, inv = np.unique(ei, return_inverse=True)
    links = [entries[e][0] for e in ue]
    fd = np.stack([lk.fixed_axis.direction for lk in links])[inv]
    fp = np.stack([lk.fixed_axis.point for lk in links])[inv]
    md = np.stack([lk.moving_axis.direction for lk in links])[inv]
    mp = np.stack([lk.moving_axis.point for lk in links])[inv]
    fv = np.stack([np.stack([lk.fixed_angles, lk.fixed_slides], 1) for lk in links])[inv]
    mv = np.stack([np.stack([lk.moving_angles, lk.moving_slides], 1) for lk in links])[inv]
    pm = _padded([g[3] for g in groups])[gi, :len(groups[gi[0]][3])]      # (m, n_b)
    rest = _padded([g[4] for g in groups])[gi, :len(groups[gi[0]][4])]    # (m, k)
    m = np.arange(len(rows))
    v = np.zeros((len(rows), N, 3, 2))
    v[m[:, None], pm, F] = fv
    v[m[:, None], pm, 2] = mv
    fs, ms = fv[m, si], mv[m, si]                                    # values at s (m, 2)
    v[m[:, None], rest, X] = tr.psi[t]
    v[m[:, None], rest, F] = fs[:, None]
    v[m[:, None], rest, 2] = ms[:, None] + tr.delta[t]
    vals[rows] = v
    td, tp = tr.direction[t], tr.point[t]
    if name == "a":
        U[0, rows], P[0, rows] = td, tp
        U[1, rows], P[1, rows] = fd, fp
    else:
        # the transition axis at position 1: moved back by J1's screw G at s
        G = _screw_matrix(fd, fp, fs[:, 0], fs[:, 1])
        R, c = G[:, :3, :3], G[:, :3, 3]
        U[0, rows], P[0, rows] = fd, fp
        U[1, rows] = np.einsum("nji,nj->ni", R, td)
        P[1, rows] = np.einsum("nji,nj->ni", R, tp - c)
    U[2, rows], P[2, rows] = md, mp


@functools.lru_cache(maxsize=None)
def _value_columns(N):
    """``q{k}_pos{p}, d{k}_pos{p}`` for p = 1…N, k = 1, 2, 3 (the order of the rows' keys)."""
    return tuple(c for p in range(1, N + 1) for k in (1, 2, 3)
                 for c in (f"q{k}_pos{p}", f"d{k}_pos{p}"))
