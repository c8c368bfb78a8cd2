"""Dyads by finite positions (Kharatyan 1981), the entry point of the family table's
decompositions: RRR by four positions here, the sphere-ended and all other families in
:mod:`synthesis.sphere_families` and :mod:`synthesis.decompose`, enumerated and verified
by the engine (:mod:`synthesis.verify`).

RRR (seed 001, Fig. 1).  An RR link ("2–3") is synthesised through three of
the positions (always position 1 and two of 2, 3, 4: the screws are given from
position 1).  The fourth ("last") position is reached from one of those three
(the "transition" position s) by turning about axis 1 with joint 2 locked
(and joint 3 free): axis 1 is the pure rotation that carries axis 3 from its
s-th to its last position (L ⊥ (M_last − M_s), L ⊥ (Q_last − Q_s); the seed prints (Q₁ − Q₃) for (Q₄ − Q₃), a misprint).

Counting: 3 choices of the RR triple {1, j, n} × 3 choices of the transition
position s ∈ {1, j, n} × 2 RR solutions × 2 mechanisms = 36 variants.
Mechanism "a" (Fig. 1a) is ground –1– A –2– B –3– body with axis 1 fixed in
the ground; mechanism "b" (Fig. 1b) is ground –2– A –1– B –3– body, where axis
1 rides on the link turned by joint 2, so its position-1 location is axis 1
turned back about axis 2 by joint 2's angle at position s.

Every variant is verified with the closure engine: all synthesised open chains
hang from the ground of one :class:`closure.Mechanism`, are driven to their
joint values at all positions in one batched call, and each body pose is
compared with the given pose.

RRS (seed 001, Fig. 2): the RS link ("2–3") works through four positions with
joint 1 locked; the two later positions are reached by turning about axis 1
(joint 2 locked at its value in the transition position s, the sphere free),
so axis 1 is the axis of the circle through C_s, C_5, C_6.  PRS: the slide
of the prismatic joint 1 carries C from C_s to C_5.  These, RPS, and both
arrangements of each, are built in :mod:`synthesis.sphere_families`; every other
family of the table in :mod:`synthesis.decompose`.  :func:`enumerate_dyads` is the
entry point for all of them.
"""
from __future__ import annotations

import functools

import numpy as np
import pandas as pd

from .errors import SynthesisError
from .screw import Line, _matrices
from .validate import screws as _screws, task_scale
# chain_mechanism, verify_chain, verify_chains: re-exported (they lived here before synthesis.verify)
from .verify import chain_mechanism, verify_chain, verify_chains

__all__ = ["enumerate_dyads", "rrr_dyads", "rrs_dyads", "prs_dyads", "rps_dyads",
           "implemented_families", "verify_chain", "verify_chains", "chain_mechanism",
           "DYAD_COLUMNS", "circle_axis"]

DYAD_COLUMNS = (["family", "variant", "order", "arrangement", "transition"]
                + [f"j{k}_{c}" for k in (1, 2, 3)
                   for c in ("type", "ux", "uy", "uz", "x", "y", "z", "pitch")]
                + ["residual", "reason"])

#: pitch column of each joint kind that has no pitch of its own (H: the given pitch)
_PITCH = {"R": 0.0, "P": np.inf, "C": np.nan, "S": np.nan, "U": np.nan}


def _check_screws(screws, n, family):
    out = _screws(screws, "screws")
    if len(out) != n - 1:
        raise SynthesisError(f"screws: {family} expected {n - 1} screws S_12 … S_1{n} for {n} "
                             f"positions, got {len(out)}")
    return out


def _task(screws):
    """Positions ``(n, 4, 4)`` (the identity first) and the task's reach (residuals are
    relative to it)."""
    T = np.concatenate([np.eye(4)[None], _matrices(screws)])
    _, _, reach = task_scale(T, [s.axis for s in screws], [s.point for s in screws])
    return T, reach


def rrr_dyads(screws) -> pd.DataFrame:
    """All RRR dyads through four positions (see the module notes for the 36 variants).

    Parameters
    ----------
    screws : sequence of three Screw
        S₁₂, S₁₃, S₁₄.

    Returns
    -------
    pandas.DataFrame
        The 36 variants (:func:`synthesis.rrr.rrr_table`: the three RR triples solved,
        the variants built and verified in one vectorised pass).
    """
    from .rrr import rrr_table
    screws = _check_screws(screws, 4, "RRR")
    T, size = _task(screws)                                   # T[k]: position k+1 from 1
    return rrr_table(screws, T, size)


def _row(family, variant, order, types, lines, residual, **extra):
    row = {"family": family, "variant": variant, "order": order}
    for k, (t, ln) in enumerate(zip(types, lines), start=1):
        row[f"j{k}_type"] = t
        row[f"j{k}_ux"], row[f"j{k}_uy"], row[f"j{k}_uz"] = ln.direction
        row[f"j{k}_x"], row[f"j{k}_y"], row[f"j{k}_z"] = ln.point
        row[f"j{k}_pitch"] = _PITCH[t]
    row["residual"] = residual
    row["reason"] = ""
    jv = extra.pop("joint_values", None)
    row.update(extra)
    if jv is not None:
        for p in range(jv.shape[0]):
            for k in range(jv.shape[1]):
                row[f"q{k + 1}_pos{p + 1}"] = jv[p, k]
    return row


def rrs_dyads(screws, *, azimuth=None) -> pd.DataFrame:
    """RRS dyads through six positions (RS link through four, the R transition joint through
    the circle of the sphere centre's two other positions); see
    :mod:`synthesis.sphere_families`."""
    from .sphere_families import sphere_family_dyads
    return pd.DataFrame(sphere_family_dyads("RRS", _check_screws(screws, 6, "RRS"),
                                            azimuth=azimuth))


def prs_dyads(screws, *, azimuth=None) -> pd.DataFrame:
    """PRS dyads through five positions (RS link through four and the slide carrying the
    sphere centre to the fifth, or PS through three and R through two); see
    :mod:`synthesis.sphere_families`."""
    from .sphere_families import sphere_family_dyads
    return pd.DataFrame(sphere_family_dyads("PRS", _check_screws(screws, 5, "PRS"),
                                            azimuth=azimuth))


def rps_dyads(screws, *, azimuth=None) -> pd.DataFrame:
    """RPS dyads through five positions (PS through three and R through two, or RS through
    four and the slide of joint 2 through one); see :mod:`synthesis.sphere_families`."""
    from .sphere_families import sphere_family_dyads
    return pd.DataFrame(sphere_family_dyads("RPS", _check_screws(screws, 5, "RPS"),
                                            azimuth=azimuth))


#: the reason of a degenerate circle (:func:`circle_axes`)
CIRCLE_ERROR = ("axis 1: the later positions of the sphere centre are collinear or coincide; "
                "no circle through them")


def circle_axes(p1, p2, p3):
    """Axes of the circles through many point triples, in one pass.

    Parameters
    ----------
    p1, p2, p3 : array_like, shape (m, 3)
        The triples' points.

    Returns
    -------
    n, O : ndarray, shape (m, 3)
        Unit axis direction (normal of the triple's plane) and the circle centre (NaN
        where degenerate).
    angles : ndarray, shape (m, 2)
        Angles (rad) of p2 and p3 about the axis from p1.
    ok : ndarray of bool, shape (m,)
        False where the points are collinear or coincide to round-off (the reason is
        :data:`CIRCLE_ERROR`).
    """
    p1, p2, p3 = (np.asarray(p, float).reshape(-1, 3) for p in (p1, p2, p3))
    d2, d3 = p2 - p1, p3 - p1
    n = np.cross(d2, d3)
    # collinear to round-off: relative to the triangle's size and the coordinates' size
    size = np.maximum.reduce([np.abs(d2).max(-1), np.abs(d3).max(-1),
                              np.abs(p3 - p2).max(-1)])
    big = np.abs(np.stack([p1, p2, p3], 1)).max((1, 2))
    nn = np.sqrt(np.einsum("mi,mi->m", n, n))
    ok = nn > 1e-12 * size * np.maximum(size, big)
    n = np.where(ok[:, None], n, np.nan) / np.where(ok, nn, 1.0)[:, None]
    A = np.stack([2 * d2, 2 * d3, n], 1)
    A[~ok] = np.eye(3)
    sq = lambda p: np.einsum("mi,mi->m", p, p)
    b = np.stack([sq(p2) - sq(p1), sq(p3) - sq(p1), np.einsum("mi,mi->m", n, p1)], 1)
    O = np.linalg.solve(A, b[..., None])[..., 0]
    O[~ok] = np.nan
    u = p1 - O
    angles = np.stack([np.arctan2(np.einsum("mi,mi->m", np.cross(u, p - O), n),
                                  np.einsum("mi,mi->m", u, p - O)) for p in (p2, p3)], 1)
    return n, O, angles, ok


def circle_axis(p1, p2, p3):
    """Axis (Line) of the circle through three points, and the angles of p2, p3 about it
    from p1 (:func:`circle_axes` for one triple; raises :class:`SynthesisError` when the
    points are collinear)."""
    n, O, angles, ok = circle_axes(p1, p2, p3)
    if not ok[0]:
        raise SynthesisError(CIRCLE_ERROR)
    return Line(n[0], O[0]).canonical(), [float(a) for a in angles[0]]


#: the family modules whose families have their own builder: each holds ``FAMILIES``
#: ({family: (positions, free-parameter names, note)}), an arrangement function
#: ``ARRANGEMENTS(family, n_positions)`` and ``BUILD(family, screws, **choices)`` (rows)
_FAMILY_MODULES = ("sphere_families", "sphere_middle", "hooke_families")


def _family_module(fam):
    """The module that builds ``fam`` (or None: RRR and the decomposed families)."""
    import importlib
    for name in _FAMILY_MODULES:
        mod = importlib.import_module(f"{__package__}.{name}")
        if fam in mod.FAMILIES:
            return mod
    return None


def _module_solver(fam, mod):
    n, allowed, _ = mod.FAMILIES[fam]

    def solve(screws, **choices) -> pd.DataFrame:
        bad = set(choices) - set(allowed)
        if bad:
            raise SynthesisError(f"{', '.join(sorted(bad))}: not a free parameter of family "
                                 f"{fam} (its free parameters: "
                                 f"{', '.join(sorted(allowed)) or 'none'})")
        return pd.DataFrame(mod.BUILD(fam, _screws(screws, "screws"), **choices))
    solve.__name__ = f"{fam.lower()}_dyads"
    return solve


def implemented_families() -> dict:
    """Family → how :func:`enumerate_dyads` builds it (``"direct"`` or ``"inverse of XYZ"``)
    and the numbers of positions it takes."""
    return dict(_implemented())


@functools.lru_cache(maxsize=1)
def _implemented() -> dict:
    from .decompose import arrangements
    from .families import family_names
    import importlib
    out = {"RRR": ("direct", (4,))}
    for name in _FAMILY_MODULES:
        mod = importlib.import_module(f"{__package__}.{name}")
        out.update({f: ("direct", (n,)) for f, (n, _, _) in mod.FAMILIES.items()})
    names = set(family_names())
    for fam in sorted(names | {f[::-1] for f in names}):
        if fam in out or "S" in fam or "U" in fam:
            continue
        arr = arrangements(fam)
        if arr:
            out[fam] = ("direct", tuple(sorted({a[3] + a[4] for a in arr})))
    for fam in sorted(names | {f[::-1] for f in names}):
        if fam not in out and "S" not in fam and "U" not in fam and fam[::-1] in out and \
                out[fam[::-1]][0] == "direct":
            out[fam] = (f"inverse of {fam[::-1]}", out[fam[::-1]][1])
    return out


def enumerate_dyads(family: str, screws, **choices) -> pd.DataFrame:
    """Every variant the method yields for ``family`` through the given positions.

    Parameters
    ----------
    family : str
        Three joint letters, ground joint first (R, P, C, H, S; e.g. ``"RRR"``,
        ``"RPC"``): a family of :func:`families` that is implemented, or the reverse of
        one (enumerated by kinematic inversion: the reverse family through the inverse
        displacements, each chain reversed and verified again).
    screws : sequence of Screw
        S₁₂ … S₁N, the displacements from position 1.
    **choices
        Free parameters of the decomposition (see :mod:`synthesis.decompose`), each a
        scalar (one vector) or a grid the user sets: ``pitch`` (length/rad, required for
        families with a helical joint), ``slide_direction`` (unit vector(s)),
        ``prismatic_slide`` (length), ``fixed_direction`` (unit vector(s)),
        ``transition_angle`` (rad); for the sphere-ended families ``azimuth`` (rad: the
        main RS/PS link's fixed axis or slide direction lies on the great circle of
        azimuth ψ in the task's reference frame, :func:`synthesis.spherical.task_frame`
        of all the screws; default 0, π/4, π/2, 3π/4).  A choice the family does not have
        raises.  RUR, URR take ``azimuth`` (the UR link's revolute axis), RUP, URP
        ``azimuth`` (the UP link's slide direction) and ``axis_azimuth`` (its U joint's
        first axis), rad; RUH, URH ``azimuth`` (the helical axis) and ``pitch``; RUC, URC
        ``azimuth`` (the cylinder axis), ``centre`` (the U joint's centre, length, (3,) or
        (m, 3); default the task's centre moved by half its reach along each axis of the
        task's reference frame) and ``transition_angle`` (rad, default −1, 1); see
        :mod:`synthesis.hooke_families`.  The sphere families with a helical joint (RHS,
        HRS, PHS, HPS, RSH, SRH) take ``azimuth`` and ``pitch``.

    Returns
    -------
    pandas.DataFrame
        One row per variant.  Columns ``family, variant, order`` (how the positions
        were assigned), ``arrangement`` (``"a"``: the main link is joints 2–3 and joint
        1 is the transition joint; ``"b"``: the main link is joints 1 and 3, joint 2 the
        transition joint), ``transition`` (the transition joint's kind and the joint it
        carries, e.g. ``"RC"``), per joint k = 1, 2, 3 (1 at the ground, 3 at the body)
        ``j{k}_type, j{k}_ux, j{k}_uy, j{k}_uz, j{k}_x, j{k}_y, j{k}_z`` (axes in the
        first position, oriented with their largest component positive for the
        decomposed families; canonical points; a prismatic joint's point is immaterial, a
        sphere has a centre and no axis), ``j{k}_pitch`` (length/rad: 0 for R, the pitch
        for H, inf for P, NaN for C and S), ``residual`` (largest pose error when the
        engine drives the dyad through all positions: rad, or length relative to the
        task's reach, the size of its coordinates), ``reason`` (why a variant
        degenerated, else empty; such rows have NaN geometry and no residual), and
        ``main_link, main_positions, transition_position``, one column per free
        parameter used (vectors as ``name_x, name_y, name_z``), the joint values
        ``q{k}_pos{p}`` (the driven coordinate: angle in rad, a prismatic joint's slide)
        and, for the decomposed families, ``d{k}_pos{p}`` (slide along the axis, length).
        RRR also has ``mechanism`` (= arrangement) and ``rr`` (which RR solution).

    Raises
    ------
    SynthesisError
        An unknown or unimplemented family, screws that are not a sequence of the right
        number of :class:`Screw`, an unknown or inapplicable choice, or a missing pitch.
    """
    if not isinstance(family, str):
        raise SynthesisError(f"family: expected a family name such as 'RRR', got "
                             f"{type(family).__name__} {family!r}")
    fam = family.upper()
    impl = _implemented()
    if fam not in impl:
        from .families import family_names
        known = set(family_names())
        if fam in known or fam[::-1] in known:
            raise SynthesisError(f"family {family!r}: in Kharatyan's Table 3 (or its reverse) but "
                                 f"not implemented yet; implemented: {', '.join(sorted(impl))}")
        raise SynthesisError(f"family {family!r}: unknown; expected one of "
                             f"{', '.join(sorted(known))}")
    how = impl[fam][0]
    if how != "direct":
        return _flag_ill_conditioned(_inverse_family(fam, screws, choices))
    if fam == "RRR":
        if choices:
            raise SynthesisError(f"{', '.join(sorted(choices))}: not a free parameter of "
                                 "family RRR (its free parameters: none)")
        return _flag_ill_conditioned(rrr_dyads(screws))
    mod = _family_module(fam)
    if mod is not None:
        return _flag_ill_conditioned(_module_solver(fam, mod)(screws, **choices))
    from .decompose import decomposed_dyads
    return _flag_ill_conditioned(decomposed_dyads(fam, _screws(screws, "screws"), **choices))


#: a variant the engine drives through the positions with a larger pose error than this
#: (rad, or relative to the task's reach) is not regular: its reason says so
REGULAR_RESIDUAL = 1e-9


def _flag_ill_conditioned(df: pd.DataFrame) -> pd.DataFrame:
    """Rows without a reason whose engine residual exceeds :data:`REGULAR_RESIDUAL` (or is
    missing) get one: the construction lost its accuracy (nearly coincident positions,
    nearly parallel axes); their residual stays, to show by how much."""
    if not len(df) or "residual" not in df or "reason" not in df:
        return df
    res = df["residual"].to_numpy(float)
    bad = ~(res <= REGULAR_RESIDUAL)
    if bad.any():                   # (the reasons compared only then: a string column is slow)
        bad &= (df["reason"].fillna("") == "").to_numpy()
    if bad.any():
        df = df.copy()
        df.loc[bad, "reason"] = [
            f"ill-conditioned: the engine's pose error {r:.1e} exceeds {REGULAR_RESIDUAL:g} "
            "(nearly coincident positions or nearly parallel axes)" if np.isfinite(r) else
            "not verified: the engine could not drive this variant through the positions"
            for r in res[bad]]
    return df


def _inverse_family(fam, screws, choices):
    """``fam`` by kinematic inversion of its reverse (see :func:`enumerate_dyads`).

    The reverse family's table is turned column-wise (joints k ↔ 4 − k, joint values
    negated), the regular rows' axes re-canonicalised and oriented as arrays, and every
    regular chain verified again by the closure engine.
    """
    from .decompose import _canonical_points, _flip_signs, verify_dyads
    from .inversion import inverse_screws
    screws = _screws(screws, "screws")
    ch = dict(choices)
    if ch.get("pitch") is not None and np.ndim(ch["pitch"]) == 1 and len(ch["pitch"]) == 3:
        ch["pitch"] = list(ch["pitch"])[::-1]
    rev = fam[::-1]
    if rev != "RRR" and _implemented()[rev][0] == "direct" and _family_module(rev) is None:
        # a decomposed family: its chains are verified once, reversed, below
        from .decompose import decomposed_dyads
        df = decomposed_dyads(rev, inverse_screws(screws), _verify=False, **ch)
    else:
        df = enumerate_dyads(rev, inverse_screws(screws), **ch)
    T, reach = _task(screws)
    n = len(T)
    cols = list(df.columns)
    out = {c: df[c].to_numpy(copy=True) for c in cols}
    out["family"] = np.full(len(df), fam, dtype=object)
    out["order"] = np.array([f"inverse of {fam[::-1]}: {o}" for o in df["order"].tolist()],
                            dtype=object)
    for c in ("type", "ux", "uy", "uz", "x", "y", "z", "pitch"):
        for k in (1, 2, 3):
            out[f"j{k}_{c}"] = df[f"j{4 - k}_{c}"].to_numpy(copy=True)
    for p in range(1, n + 1):
        for k in (1, 2, 3):
            for q in ("q", "d"):
                if f"{q}{4 - k}_pos{p}" in df.columns:
                    out[f"{q}{k}_pos{p}"] = -df[f"{q}{4 - k}_pos{p}"].to_numpy(dtype=float)
    out["residual"] = np.full(len(df), np.nan)
    reg = np.flatnonzero(df["reason"].to_numpy() == "")
    if reg.size:
        # lines of the regular rows as arrays (m, 3): unit directions (as Line normalises)
        U = [np.stack([out[f"j{k}_u{c}"][reg] for c in "xyz"], 1).astype(float)
             for k in (1, 2, 3)]
        P = [np.stack([out[f"j{k}_{c}"][reg] for c in "xyz"], 1).astype(float)
             for k in (1, 2, 3)]
        for k in range(3):
            nrm = np.linalg.norm(U[k], axis=1)
            if np.any(~np.isfinite(U[k])) or np.any(np.abs(nrm - 1) > 1e-6) or \
                    np.any(~np.isfinite(P[k])):
                raise SynthesisError(f"joint {k + 1}: a regular row of {fam[::-1]} has no "
                                     "finite unit axis")
            U[k] = U[k] / nrm[:, None]
        P = _canonical_points(U, P)                     # the canonical chain (Line.canonical)
        # orientation rule of the table (decompose._flipped): largest component positive
        sg = []
        for k in range(3):
            s = _flip_signs(U[k])
            U[k] = s[:, None] * U[k]
            sg.append(s)
            for p in range(1, n + 1):
                for q in ("q", "d"):
                    out[f"{q}{k + 1}_pos{p}"][reg] *= s
            for c, j in zip("xyz", range(3)):
                out[f"j{k + 1}_u{c}"][reg] = U[k][:, j]
                out[f"j{k + 1}_{c}"][reg] = P[k][:, j]
        vals = np.zeros((len(reg), n, 3, 2))
        for k in range(3):
            for p in range(n):
                if fam[k] != "P":
                    vals[:, p, k, 0] = out[f"q{k + 1}_pos{p + 1}"][reg]
                vals[:, p, k, 1] = out[f"d{k + 1}_pos{p + 1}"][reg]
        pitches = np.stack([out[f"j{k}_pitch"][reg] for k in (1, 2, 3)], 1).astype(float)
        out["residual"][reg] = verify_dyads(fam, U, P, pitches, vals, T, reach)
    return pd.DataFrame({c: out[c] for c in cols})
