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
import math

import numpy as np
import pandas as pd

from closure import Mechanism

from .binary import BinaryLink, _fibonacci, _screw_matrix
from .errors import SynthesisError
from .screw import Line
from .spherical import task_frame
from .transition import TRANSITION_POSITIONS, transition_joint
from .twopos import two_position_link
from .validate import array, task_scale
from .verify import _frames_of, in_chunks, pose_errors

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


def nan_geometry(row: dict, family: str) -> dict:
    """A failed variant's joint columns: types and pitches, NaN axes and points."""
    for k, t in enumerate(family, start=1):
        row[f"j{k}_type"] = t
        for c in ("ux", "uy", "uz", "x", "y", "z"):
            row[f"j{k}_{c}"] = np.nan
        row[f"j{k}_pitch"] = PITCH_OF_KIND.get(t, np.nan)
    return row



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
def _main_links(kinds, pitches, T, reach, choices):
    """Main-link solutions through the positions T (n_b, 4, 4) (T[0] = I): a list of
    (BinaryLink or None, parameters dict, reason)."""
    from .screw import Screw
    scr = [Screw.from_matrix(t) for t in T[1:]]
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
        from .cylindric import cr_links, rc_links
        for g in choices["fixed_direction"]:
            if kinds[1] == "C":
                fn = (lambda g=g: rc_links(*scr, g, fixed_pitch=0.0 if kinds[0] == "R" else pf))
            else:
                fn = (lambda g=g: cr_links(*scr, g, moving_pitch=0.0 if kinds[1] == "R" else pm))
            attempt(fn, {"fixed_direction": g})
    elif kinds == "CC":
        from .cylindric import cc_links
        attempt(lambda: cc_links(scr), {})
    else:                                                          # two positions with a P
        slides = choices["prismatic_slide"] if "C" in kinds else [None]
        hp = pm if kinds[1] == "H" else pf if kinds[0] == "H" else 0.0
        for d in choices["slide_direction"]:
            for a in slides:
                params = {"slide_direction": d}
                if a is not None:
                    params["prismatic_slide"] = float(a)
                attempt(lambda d=d, a=a: [two_position_link(kinds, T[1], slide_direction=d,
                                                            pitch=hp, prismatic_slide=a,
                                                            reach=reach)], params)
    return out


def _from_rr(lk) -> BinaryLink:
    z = np.zeros(len(lk.fixed_angles))
    return BinaryLink("RR", lk.fixed_axis, lk.moving_axis, 0.0, 0.0, np.asarray(lk.fixed_angles),
                      z, np.asarray(lk.moving_angles), z.copy(), lk.residual)


# ------------------------------------------------------------------ verification
@in_chunks
def verify_dyads(chains, targets, length: float) -> np.ndarray:
    """Drive three-joint chains (R, P, C, H) through their joint values with the closure
    engine (all in one mechanism, one batched call) and return each chain's largest pose
    error (rad, or translation / ``length``).

    chains : list of (types (3 letters), lines (3 Line), pitches (3), values (P, 3, 2):
    angle (rad) and slide (length) of every joint at every position).
    """
    if not chains:
        return np.zeros(0)
    m = Mechanism()
    frames = _frames_of([ln for c in chains for ln in c[1]])
    cols = []
    for v, (types, lines, pitches, vals) in enumerate(chains):
        names = ["ground", f"A{v}", f"B{v}", f"body{v}"]
        for n in names[1:]:
            m.add_link(n)
        for k, t in enumerate(types):
            jn = f"v{v}j{k + 1}"
            m.add_joint(jn, t, names[k], names[k + 1], at=frames[3 * v + k], validate=False,
                        pitch=float(pitches[k]) if t == "H" else None)
            m.add_input(jn, 0)
            if t == "C":
                m.add_input(jn, 1)
            cols.append(vals[:, k, 1] if t == "P" else vals[:, k, 0])
            if t == "C":
                cols.append(vals[:, k, 1])
    pose = m.solve(np.stack(cols, 1), continuation=False)
    link = pose.kinematics(twists=False)["link"]
    bodies = link[:, [m.links.index(f"body{v}") for v in range(len(chains))]]
    rot, pos = pose_errors(bodies, np.asarray(targets, float)[:, None], length)
    return np.maximum(rot.max(0), pos.max(0))


# ------------------------------------------------------------------ enumeration
def _canonical(lines):
    out = [lines[0].canonical()]
    for ln in lines[1:]:
        out.append(ln.canonical(out[-1]))
    return out


def _flipped(u) -> bool:
    """Orientation rule of every axis in the table: its largest component (the first of
    equal ones) is positive."""
    a = u.tolist() if isinstance(u, np.ndarray) else [float(x) for x in u]
    if len(a) != 3 or any(x != x for x in a):                   # NaN: numpy's argmax rule
        return bool(u[np.argmax(np.abs(u) - 1e-12 * np.arange(3))] < 0)
    b = [abs(a[0]), abs(a[1]) - 1e-12, abs(a[2]) - 2e-12]
    return a[max(range(3), key=b.__getitem__)] < 0


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


def _line_point_guard(ln: Line, reach: float) -> bool:
    # plain floats: called three times per variant, numpy's reductions cost more than this
    v = ln.direction.tolist() + ln.point.tolist()
    return all(map(math.isfinite, v)) and max(map(abs, v[3:])) < 1e8 * reach


def decomposed_dyads(family: str, screws, *, _verify: bool = True, **choices) -> pd.DataFrame:
    """Every variant of ``family`` (R, P, C, H joints) through the positions ``screws``
    by the decompositions of the module notes; see :func:`synthesis.enumerate_dyads` for
    the table's columns and the keyword choices.

    ``_verify=False`` (internal: kinematic inversion verifies the reversed chains itself)
    leaves the engine check out: every residual is NaN."""
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
    rows, chains = [], []
    cache, rel, trans = {}, {}, {}
    for name, main, x, n_b, k in arr:
        mp = [pitches[1], pitches[2]] if name == "a" else [pitches[0], pitches[2]]
        xp = pitches[0] if name == "a" else pitches[1]
        for others in itertools.combinations(range(1, N), n_b - 1):
            Pm = (0,) + others
            rest = [i for i in range(N) if i not in Pm]
            pm_text = tuple(i + 1 for i in Pm)
            key = (main, tuple(mp), Pm)
            if key not in cache:
                cache[key] = _main_links(main, mp, T[list(Pm)], reach, ch)
            for li, (lk, params, reason) in enumerate(cache[key]):
                for si, s in enumerate(Pm):
                    angles = ch["transition_angle"] if (x, family[2]) == ("R", "C") else [None]
                    for ang in angles:
                        p = dict(params)
                        if ang is not None:
                            p["transition_angle"] = float(ang)
                        order = (f"{main} through {pm_text}; {x} ({'J1' if name == 'a' else 'J2'})"
                                 f" carries position {s + 1} to {tuple(i + 1 for i in rest)}")
                        base = dict(family=family, order=order, arrangement=name, mechanism=name,
                                    main_link=main, main_positions=str(pm_text),
                                    transition=f"{x}{family[2]}", transition_position=s + 1)
                        if lk is None:
                            rows.append(_failed(base, family, pitches, p, reason))
                            continue
                        # the transition depends on the main link, s and the angle only:
                        # arrangements a and b with the same main link and transition kind
                        # (J1 = J2) share it
                        tkey = (key, li, x, s, ang)
                        if tkey not in trans:
                            try:
                                if (s, pm_text) not in rel:
                                    rel[s, pm_text] = T[rest] @ np.linalg.inv(T[s])
                                trans[tkey] = _transitions(lk, family[2], pitches[2], x, T, s,
                                                           si, rest, reach, ang,
                                                           D=rel[s, pm_text])
                            except SynthesisError as e:
                                trans[tkey] = e
                        trs = trans[tkey]
                        if isinstance(trs, SynthesisError):
                            rows.append(_failed(base, family, pitches, p, str(trs)))
                            continue
                        if not trs:
                            rows.append(_failed(base, family, pitches, p,
                                                "no real transition joint"))
                        for tr in trs:
                            row, chain = _variant(base, name, lk, tr, family, pitches, xp, p,
                                                  Pm, si, rest, N, reach)
                            rows.append(row)
                            if chain is not None:
                                chains.append((len(rows) - 1, chain))
    if _verify:
        res = verify_dyads([c for _, c in chains], T, reach)
        for (i, _), r in zip(chains, res):
            rows[i]["residual"] = float(r)
    for v, row in enumerate(rows, start=1):
        row["variant"] = v
    df = pd.DataFrame(rows)
    return _order_columns(df)


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


def _moved(ln: Line, T) -> Line:
    """The line moved by the rigid transform T (no re-validation)."""
    R = T[:3, :3]
    return Line._exact(R @ ln.direction, R @ ln.point + T[:3, 3])


def _transitions(lk: BinaryLink, y_kind, y_pitch, x, T, s, si, rest, reach, ang, D=None):
    Ts = T[s]
    y_line = _moved(lk.moving_axis, Ts)
    if D is None:                                 # T_l T_s⁻¹ (the caller may pass it cached)
        D = T[rest] @ np.linalg.inv(Ts)
    return transition_joint(x, y_kind, y_line, y_pitch, D, reach, angle=ang)


def _variant(base, name, lk, tr, family, pitches, xp, params, Pm, si, rest, N, reach):
    vals = np.zeros((N, 3, 2))
    fv = np.stack([lk.fixed_angles, lk.fixed_slides], 1)
    mv = np.stack([lk.moving_angles, lk.moving_slides], 1)
    X = 0 if name == "a" else 1
    F = 1 if name == "a" else 0
    for i, p in enumerate(Pm):
        vals[p, F], vals[p, 2] = fv[i], mv[i]
    for j, l in enumerate(rest):
        vals[l, X] = tr.psi[j]
        vals[l, F] = fv[si]
        vals[l, 2] = mv[si] + tr.delta[j]
    if name == "a":
        lines = [tr.line, lk.fixed_axis, lk.moving_axis]
    else:
        G = _screw_matrix(lk.fixed_axis.direction, lk.fixed_axis.point, fv[si, 0], fv[si, 1])
        t1 = _moved(tr.line, np.linalg.inv(G))
        lines = [lk.fixed_axis, t1, lk.moving_axis]
    lines = _canonical(lines)
    for k, ln in enumerate(lines):
        if _flipped(ln.direction):
            lines[k] = Line._exact(-ln.direction, ln.point)
            vals[:, k] *= -1
    row = dict(base)
    _geometry(row, family, lines, pitches)
    _params(row, params)
    q = vals[:, :, 0].copy()
    q[:, [k for k in range(3) if family[k] == "P"]] = vals[:, [k for k in range(3)
                                                                if family[k] == "P"], 1]
    row.update(zip(_value_columns(N), itertools.chain.from_iterable(
        zip(q.ravel().tolist(), vals[:, :, 1].ravel().tolist()))))
    row["residual"] = np.nan
    row["reason"] = ""
    if not all(_line_point_guard(ln, reach) for ln in lines) or not np.all(np.isfinite(vals)):
        row["reason"] = "degenerate: an axis at infinity or undefined joint values"
        return row, None
    return row, (family, lines, pitches, vals)


@functools.lru_cache(maxsize=None)
def _value_columns(N):
    """``q{k}_pos{p}, d{k}_pos{p}`` for p = 1…N, k = 1, 2, 3 (the order of the rows' keys)."""
    return tuple(c for p in range(1, N + 1) for k in (1, 2, 3)
                 for c in (f"q{k}_pos{p}", f"d{k}_pos{p}"))


def _geometry(row, family, lines, pitches):
    for k, t in enumerate(family, start=1):
        row[f"j{k}_type"] = t
        if lines is None:
            for c in ("ux", "uy", "uz", "x", "y", "z"):
                row[f"j{k}_{c}"] = np.nan
        else:
            ln = lines[k - 1]
            row[f"j{k}_ux"], row[f"j{k}_uy"], row[f"j{k}_uz"] = ln.direction.tolist()
            row[f"j{k}_x"], row[f"j{k}_y"], row[f"j{k}_z"] = ln.point.tolist()
        row[f"j{k}_pitch"] = pitches[k - 1]


def _params(row, params):
    for name, v in params.items():
        v = np.asarray(v, float)
        if v.ndim:
            for c, x in zip("xyz", v):
                row[f"{name}_{c}"] = float(x)
        else:
            row[name] = float(v)


def _failed(base, family, pitches, params, reason):
    row = dict(base)
    _geometry(row, family, None, pitches)
    _params(row, params)
    row["residual"] = np.nan
    row["reason"] = reason
    return row


def _order_columns(df):
    from .dyads import DYAD_COLUMNS
    first = [c for c in DYAD_COLUMNS if c in df.columns]
    return df[first + [c for c in df.columns if c not in first]]
