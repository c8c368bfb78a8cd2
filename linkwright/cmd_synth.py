"""``linkwright synth``: positions → the variant table and a ranked report."""
from __future__ import annotations

import numpy as np
import pandas as pd

from synthesis import Line, Screw, SynthesisError, enumerate_dyads
from synthesis.validate import task_scale

from .output import Outputs
from .render import DIMENSIONLESS, Report, fmt_num, fmt_q, quantity
from .study import Study

CRITERIA = ("link_length", "axis_distance")


def joint_numbers(row) -> list[int]:
    """The joints of a table row, 1-based from the ground: (1, 2, 3) for a dyad, (1, 2)
    for a binary link of :func:`synthesis.complete_dyads`."""
    return [k for k in (1, 2, 3) if isinstance(row.get(f"j{k}_type"), str)]


def _elements(row):
    """The joints as Lines, or centre points (arrays) for spheres."""
    out = []
    for k in joint_numbers(row):
        p = np.array([row[f"j{k}_x"], row[f"j{k}_y"], row[f"j{k}_z"]])
        if row[f"j{k}_type"] == "S":
            out.append(p)
        else:
            out.append(Line(np.array([row[f"j{k}_ux"], row[f"j{k}_uy"], row[f"j{k}_uz"]]), p))
    return out


def _distance(a, b):
    if isinstance(a, Line) and isinstance(b, Line):
        return a.distance_to(b)
    if not isinstance(a, Line) and not isinstance(b, Line):
        return float(np.linalg.norm(a - b))
    line, pt = (a, b) if isinstance(a, Line) else (b, a)
    return float(np.linalg.norm(pt - line.foot_from(pt)))


def criterion_values(df: pd.DataFrame, kind: str, center=None) -> np.ndarray:
    """``link_length``: the sum of the links' lengths (common normals, the distance from an
    axis to a sphere centre, or between two centres); ``axis_distance``: the largest distance of the
    joints (axes or sphere centre) from ``center`` (both in length units)."""
    out = np.full(len(df), np.nan)
    for i, (_, r) in enumerate(df.iterrows()):
        if r.get("reason", ""):
            continue
        E = _elements(r)
        if kind == "link_length":
            out[i] = sum(_distance(a, b) for a, b in zip(E[:-1], E[1:]))
        else:
            out[i] = max(np.linalg.norm(center - e) if not isinstance(e, Line)
                         else _distance(e, center) for e in E)
    return out


#: an axis this close to unit length is used as it is; up to AXIS_FIX it is normalised
#: with a warning; beyond, it is an error
AXIS_TOL, AXIS_FIX = 1e-6, 1e-2


def _axis(p: Study) -> np.ndarray:
    u = p.get("axis", "vec3")
    n = float(np.linalg.norm(u))
    if abs(n - 1) <= AXIS_TOL:
        return u
    if abs(n - 1) <= AXIS_FIX:
        p.warn("axis", f"not of unit length (|axis| = {n:.7g}); normalised to "
                       f"{[round(float(x), 9) for x in u / n]}")
        return u / n
    raise p.error("axis", f"expected a unit direction (|axis| within {AXIS_FIX:g} of 1), "
                          f"got |axis| = {n:.6g}")


def _degenerate(study: Study, positions: list[Study], screws: list) -> None:
    """A headline error for positions the method cannot use: a planar motion, a position
    given twice, a position equal to the first one."""
    size = max([1.0] + [float(np.abs(s.point).max()) for s in screws]
               + [abs(s.slide) for s in screws])
    tol = 1e-9
    for i, (p, s) in enumerate(zip(positions, screws)):
        if abs(np.sin(s.angle / 2)) <= tol and abs(s.slide) <= tol * size:
            raise p.error("angle_deg", f"position[{i}] is the first position again (no "
                                       "rotation, no slide): give a displacement")
        for j in range(i):
            t = screws[j]
            same_axis = np.linalg.norm(np.cross(s.axis, t.axis)) <= tol
            if same_axis and float(np.linalg.norm(np.cross(s.point - t.point, s.axis))) \
                    <= tol * size:
                sgn = float(np.dot(s.axis, t.axis))
                if abs(np.sin((s.angle - sgn * t.angle) / 2)) <= tol and \
                        abs(s.slide - sgn * t.slide) <= tol * size:
                    raise p.error("", f"position[{j}] and position[{i}] are the same "
                                      f"displacement (positions {j + 2} and {i + 2} of the "
                                      "body coincide): remove one or give another")
    axes = np.array([s.axis for s in screws])
    if len(screws) > 1 and np.all(np.linalg.norm(np.cross(axes, axes[0]), axis=1) <= tol) \
            and all(abs(s.slide) <= tol * size for s in screws):
        raise study.error("position", "positions are planar: use the planar case (every "
                          f"screw axis is parallel to {[round(float(x), 6) for x in axes[0]]} "
                          "with no slide, so the body moves in a plane and the spatial "
                          "dyads through them are not isolated)")


#: a variant whose engine-verified residual exceeds this (relative to the task's size) is
#: excluded from the ranking; below it the residual is only a check, never a rank key
RESIDUAL_TOL = 1e-9
#: worst Jacobian condition above which a variant counts as near a singular pose
COND_OK = 100.0


def _sig(v, digits: int = 4) -> float:
    """``v`` rounded to ``digits`` significant digits (rank keys ignore round-off)."""
    return float(f"{v:.{digits - 1}e}") if np.isfinite(v) else np.inf


def _line(row, k):
    return (np.array([row[f"j{k}_ux"], row[f"j{k}_uy"], row[f"j{k}_uz"]], float),
            np.array([row[f"j{k}_x"], row[f"j{k}_y"], row[f"j{k}_z"]], float))


def _joint_twists(row, k, G, p):
    """The unit twists ``(6,)`` of joint ``k`` (1-based) at position ``p`` with the joint
    placed by ``G`` (4x4): R (u, c × u); H (u, c × u + h u); P (0, u); C both of R and P;
    U its first axis a and its cross axis b turned by the first angle; S three rotations
    about the centre.  None where the table lacks what is needed."""
    t = row[f"j{k}_type"]
    u, c = _line(row, k)
    R, c = G[:3, :3], G[:3, :3] @ c + G[:3, 3]
    u = R @ u
    if t in "RH":
        h = float(row[f"j{k}_pitch"]) if t == "H" else 0.0
        return [np.r_[u, np.cross(c, u) + h * u]]
    if t == "P":
        return [np.r_[np.zeros(3), u]]
    if t == "C":
        return [np.r_[u, np.cross(c, u)], np.r_[np.zeros(3), u]]
    if t == "S":
        return [np.r_[e, np.cross(c, e)] for e in np.eye(3)]
    if t == "U":
        al = _value(row, f"q{k}_pos{p}")
        b = np.array([row.get("u_cross_x"), row.get("u_cross_y"), row.get("u_cross_z")], float)
        if al is None or not np.all(np.isfinite(b)):
            return None
        b = _rotation(u, al) @ (R @ b)          # the cross axis turned by α about a
        return [np.r_[u, np.cross(c, u)], np.r_[b, np.cross(c, b)]]
    return None


def _value(row, key):
    try:
        v = float(row.get(key, np.nan))
    except (TypeError, ValueError):
        return None
    return v if np.isfinite(v) else None


def _rotation(u, q):
    K = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    return np.eye(3) + np.sin(q) * K + (1 - np.cos(q)) * K @ K


def _about(R, c, slide=np.zeros(3)):
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = R, c - R @ c + slide
    return M


def _motion(row, k, p):
    """The 4x4 displacement of joint ``k`` (1-based) at position ``p`` by its tabulated
    values (in the joint's own first-position placement), or None where they are missing
    (a sphere's rotation is not in the table)."""
    t = row[f"j{k}_type"]
    u, c = _line(row, k)
    u = u / np.linalg.norm(u)
    q = _value(row, f"q{k}_pos{p}")
    if t == "S" or q is None:
        return None
    if t == "P":
        return _about(np.eye(3), c, q * u)
    if t in "RH":
        h = float(row[f"j{k}_pitch"]) if t == "H" else 0.0
        return _about(_rotation(u, q), c, h * q * u)
    d = _value(row, f"d{k}_pos{p}")
    if d is None:
        return None
    if t == "C":
        return _about(_rotation(u, q), c, d * u)
    b = np.array([row["u_cross_x"], row["u_cross_y"], row["u_cross_z"]], float)
    return _about(_rotation(u, q) @ _rotation(b, d), c)           # U: Rot(a, α) Rot(b, γ)


def chain_jacobian(row, p: int):
    """The chain's Jacobian at position ``p`` (1-based): one column per joint coordinate,
    the joint's unit twist (ω, v) (v: the velocity of the point at the origin) with the
    joints before it moved by the variant's joint values; None where the values needed
    are not tabulated (a sphere before the last joint)."""
    G = np.eye(4)
    cols = []
    ks = joint_numbers(row)
    for k in ks:
        tw = _joint_twists(row, k, G, p)
        if tw is None:
            return None
        cols += tw
        if k < ks[-1]:
            M = _motion(row, k, p)
            if M is None:
                return None
            G = G @ M
    return np.array(cols).T


def chain_condition(row, n_positions: int, size: float) -> float:
    """The worst (largest) condition number, over the task's positions, of the chain's
    Jacobian (:func:`chain_jacobian`, moment rows divided by the task's size, so it is
    dimensionless).  Large near a singular pose (joint screws becoming dependent),
    where the dyad transmits motion and force poorly; NaN when the joint values needed
    are not tabulated."""
    worst = 0.0
    for p in range(1, n_positions + 1):
        J = chain_jacobian(row, p)
        if J is None:
            return np.nan
        J[3:] /= size
        sv = np.linalg.svd(J, compute_uv=False)
        worst = max(worst, sv[0] / sv[-1] if sv[-1] > 0 else np.inf)
    return float(worst)


def rank_variants(df: pd.DataFrame, kind: str, center, size: float, n_positions: int,
                  tol: float = RESIDUAL_TOL, progress=None, fit_first: bool = False) -> pd.DataFrame:
    """The variants with the design figures and the rank (1 best; NaN: excluded).

    Added columns: ``criterion`` (the study's criterion, m), ``size_ratio`` (criterion /
    task size), ``link1``, ``link2`` (common-normal lengths, m; link2 NaN for a binary
    link), ``offset`` (distance between the feet of the two common normals on axis 2, m),
    ``condition`` (worst
    Jacobian condition over the positions, :func:`chain_condition`), ``check``
    (``ok`` or why the variant is excluded) and ``rank``.

    Ranking (the residual is never a key): variants that are degenerate or whose
    residual exceeds ``tol`` are excluded; the others are ranked first by whether they
    stay away from singular poses (condition ≤ COND_OK), then by the size ratio, then by
    the condition, both rounded to 4 significant digits so that round-off cannot reorder
    them, then by variant number.  ``fit_first`` (least-squares synthesis: the residual
    is the fit to measured positions, not a check) ranks by the residual, rounded the
    same way, before everything else.
    """
    out = df.copy()
    out["criterion"] = criterion_values(df, kind, center)
    out["size_ratio"] = out.criterion / size
    link1, link2, offset, cond = (np.full(len(df), np.nan) for _ in range(4))
    rows = progress.bar(list(df.iterrows()), desc="ranking variants", unit="variant") \
        if hasattr(progress, "bar") else df.iterrows()
    reason = (out["reason"] if "reason" in out else pd.Series("", index=out.index)) \
        .fillna("").astype(str)
    for i, (_, r) in enumerate(rows):
        if reason.iloc[i]:
            continue
        E = _elements(r)
        link1[i] = _distance(E[0], E[1])
        if len(E) == 3:
            link2[i] = _distance(E[1], E[2])
        if len(E) == 3 and all(isinstance(e, Line) for e in E):
            a = _feet(E[0], E[1])
            b = _feet(E[2], E[1])
            offset[i] = float(abs(np.dot(b - a, E[1].direction))) if a is not None \
                and b is not None else np.nan
        cond[i] = chain_condition(r, n_positions, size)
    out["link1"], out["link2"], out["offset"], out["condition"] = link1, link2, offset, cond
    res = out.residual.to_numpy(float)
    check = np.where(reason != "", "degenerate: " + reason,
                     np.where(~np.isfinite(res), "no residual (not verified)",
                              np.where(~(res <= tol), f"residual above {tol:g}", "ok")))
    out["check"] = check
    ok = out.check == "ok"
    keys = pd.DataFrame({
        "fit": [_sig(v) if fit_first else 0.0 for v in res],
        "near_singular": ~(out.condition.fillna(0) <= COND_OK),
        "size": [_sig(v) for v in out.size_ratio],
        "cond": [_sig(v) for v in out.condition.fillna(0)],
        "variant": out.variant}, index=out.index)[ok]
    order = keys.sort_values(["fit", "near_singular", "size", "cond", "variant"]).index
    out["rank"] = np.nan
    out.loc[order, "rank"] = np.arange(1, len(order) + 1)
    return out


def _feet(a: Line, b: Line):
    """The foot on ``b`` of the common normal of lines ``a`` and ``b`` (None if parallel)."""
    n = np.cross(a.direction, b.direction)
    nn = float(n @ n)
    if nn < 1e-18:
        return None
    d = b.point - a.point
    t = float(np.dot(np.cross(d, a.direction), n)) / nn
    return b.point + t * b.direction


def task_screws(study: Study) -> list:
    """The screws S₁₂ … S₁N of a synth study's ``[[position]]`` tables, checked (an error
    names the position's key; degenerate tasks are refused)."""
    screws = []
    positions = study.sections("position")
    for p in positions:
        try:
            screws.append(Screw.from_degrees(_axis(p), p.get("point", "vec3"),
                                             p.get("angle_deg", low=-360, high=360),
                                             p.get("slide")))
        except SynthesisError as e:
            raise p.error("axis", str(e)) from None
    _degenerate(study, positions, screws)
    return screws


#: study key → (enumerate_dyads choice, factor to the choice's unit)
CHOICE_KEYS = {"pitch": ("pitch", 1.0), "azimuth_deg": ("azimuth", np.pi / 180),
               "axis_azimuth_deg": ("axis_azimuth", np.pi / 180),
               "transition_angle_deg": ("transition_angle", np.pi / 180),
               "fixed_direction": ("fixed_direction", 1.0),
               "slide_direction": ("slide_direction", 1.0),
               "prismatic_slide": ("prismatic_slide", 1.0), "centre": ("centre", 1.0)}


def task_choices(study: Study) -> dict:
    """The free parameters of a synth study's ``[synthesis]`` table as choices of
    :func:`synthesis.enumerate_dyads` (angles converted from degrees to radians)."""
    sec = study.section("synthesis")
    out = {}
    for key, (name, f) in CHOICE_KEYS.items():
        v = sec.get(key, "any", None)
        if v is not None:
            out[name] = np.asarray(v, float) * f
    return out


MODES = ("enumerate", "complete", "least-squares")


def synthesise(study: Study):
    """A synth study's synthesis: ``(family, screws, table, T (P, 4, 4), size)``.

    ``[synthesis] mode``: ``enumerate`` (default: :func:`synthesis.enumerate_dyads` of the
    family with its choices), ``complete`` (:func:`synthesis.complete_dyads`: every real
    solution of the binary link ``family`` = RR, CC, SS, TS or CS at its maximal number of
    positions; CS with its ``fixed_direction``) or ``least-squares`` (:func:`synthesis.least_squares_dyads`: RR or CC
    through more positions, best fit).  An error names the study key at fault (a choice
    the family does not have, a missing pitch, positions the family cannot take)."""
    from synthesis import complete_dyads, least_squares_dyads
    sec = study.section("synthesis")
    family = sec.get("family", "str")
    mode = sec.get("mode", "str", "enumerate", choices=MODES)
    screws = task_screws(study)
    choices = task_choices(study)
    # a complete CS solve takes its cylinder axis direction; nothing else takes a choice
    allowed = {"fixed_direction"} if mode == "complete" and family.upper() == "CS" else set()
    if mode != "enumerate" and set(choices) - allowed:
        key = next(k for k, (n, _) in CHOICE_KEYS.items() if n in set(choices) - allowed)
        raise study.error(f"synthesis.{key}", f"mode {mode!r} has no free parameters (the "
                          "solutions of a binary link at its maximal number of positions are "
                          "isolated; CS takes fixed_direction only); remove it or use "
                          "mode = \"enumerate\"")
    try:
        if mode == "complete":
            df = complete_dyads(family, screws, **choices)
        elif mode == "least-squares":
            df = least_squares_dyads(family, screws)
        else:
            df = enumerate_dyads(family, screws, **choices)
    except SynthesisError as e:
        msg = str(e)
        key = next((k for k, (n, _) in CHOICE_KEYS.items() if msg.startswith(n + ":")
                    or msg.startswith(n + ",")), None)
        raise study.error(f"synthesis.{key}" if key else "position"
                          if msg.startswith("screws") else "synthesis.family"
                          if "family" in msg or "chain" in msg else "position", msg) from None
    T = np.stack([np.eye(4)] + [s.matrix() for s in screws])
    _, extent, reach = task_scale(list(T), [s.axis for s in screws], [s.point for s in screws])
    size = extent if extent > 0 else (reach if reach > 0 else 1.0)
    return family, screws, df, T, size


#: the scalar free-parameter columns of the variant tables and their units
PARAMETER_UNITS = {"azimuth": "rad", "axis_azimuth": "rad", "transition_angle": "rad",
                   "prismatic_slide": "m", "pitch": "m/rad", "root": DIMENSIONLESS}


def _how_columns(df: pd.DataFrame) -> list[str]:
    """The columns that say how a variant was built: RRR's mechanism and RR solution, or
    the arrangement, the transition, the root and the scalar free parameters."""
    if "rr" in df:
        return ["mechanism", "rr"]
    return [c for c in ("arrangement", "main_link", "transition", "transition_position",
                        *PARAMETER_UNITS) if c in df]


def _how(row) -> str:
    if "rr" in row:
        return f"mechanism {row.mechanism}, RR solution {int(row.rr)}"
    return f"{row.order}" if "order" in row else ""


def _assemblies(study, mode, ranked, screws, rep, out, progress):
    """The ``[assemble]`` table: every combination of regular links assembled and swept
    (:func:`synthesis.assemble_table`), written and reported; None without the section."""
    from synthesis import assemble_table
    sec = study.section("assemble", required=False)
    if sec is None:
        return None
    if mode == "enumerate":
        raise study.error("assemble", "assembles binary links: use mode = \"complete\" or "
                          "\"least-squares\" (a dyad of three joints closes with another into "
                          "a loop without mobility)")
    n = sec.get("links", "int", 2, low=2, high=6)
    drive = sec.get("drive", "str", "g1")
    progress(f"assembling the solutions {n} by {n}")
    try:
        t = assemble_table(ranked, screws, links=n, drive=drive)
    except SynthesisError as e:
        raise study.error("assemble.drive" if "drive" in str(e) else "assemble",
                          str(e)) from None
    out.add_csv("assemblies.csv", t)
    rep.heading(f"Mechanisms from {n} links of the table")
    good = t[t["rank"].notna()].sort_values("rank")
    clean = good[~good.defects.astype(bool)]
    rep.text(f"{len(t)} combinations, {len(good)} assembled into mechanisms of mobility 1 "
             f"and swept from position 1 by the drive {drive}; {len(clean)} without order, "
             "branch or dead-point defects. Transmission: the smallest inverse condition of "
             "the loop's Jacobian along the sweep (0 at a singularity, 1 ideal).")
    cols = ["rank", "variants", "mobility", "order_defect", "branch_defect", "dead_point",
            "transmission", "pose_error", "reason"]
    rep.table(t.sort_values("rank")[cols], "{:.4g}",
              units={"transmission": DIMENSIONLESS, "pose_error": DIMENSIONLESS,
                     "mobility": DIMENSIONLESS})
    return t


def _tolerance(study, best_rows, ranked, T, screws, rep, out, progress):
    """The ``[tolerance]`` study of one variant (:func:`synthesis.tolerance.chain_tolerance`),
    written and reported; None without the section."""
    from synthesis.tolerance import chain_tolerance
    sec = study.section("tolerance", required=False)
    if sec is None:
        return None
    v = sec.get("variant", "int", None)
    if v is None:
        if not len(best_rows):
            raise study.error("tolerance", "no ranked variant to study")
        row = best_rows.iloc[0]
    else:
        sel = ranked[ranked.variant == v]
        if not len(sel):
            raise study.error("tolerance.variant", f"no variant {v} (variants 1–{len(ranked)})")
        row = sel.iloc[0]
    centre, _, reach = task_scale(list(T), [s.axis for s in screws], [s.point for s in screws])
    pt = sec.get("point", "vec3", None)
    n = sec.get("samples", "int", 10000, low=10)
    progress(f"tolerance study of variant {int(row.variant)}: {n} samples")
    try:
        res = chain_tolerance(row, direction_sigma=np.radians(sec.get("direction_sigma_deg",
                                                                      low=0.0)),
                              position_sigma=sec.get("position_sigma", low=0.0), samples=n,
                              seed=sec.get("seed", "int", 0, low=0),
                              point=centre if pt is None else pt, length=reach)
    except SynthesisError as e:
        raise study.error("tolerance", str(e)) from None
    t = res.summary.assign(variant=int(row.variant))
    out.add_csv("tolerance.csv", t)
    rep.heading(f"Tolerances of variant {int(row.variant)}")
    worst = t.iloc[t.pos_mean.to_numpy().argmax()]
    rep.text(f"{n} made chains (every axis tilted with σ = "
             f"{fmt_num(sec.get('direction_sigma_deg'), 3)}° about two perpendiculars and "
             f"shifted with σ = {fmt_q(sec.get('position_sigma'), 'm')} across), zeroed at "
             "position 1 and driven by the engine to the design's joint values. The body "
             f"point's displacement is largest at position {int(worst.position)}: mean "
             f"{fmt_q(worst.pos_mean, 'm')}, standard deviation {fmt_q(worst.pos_std, 'm')} "
             f"(first order: {fmt_q(worst.pos_mean_linear, 'm')}, "
             f"{fmt_q(worst.pos_std_linear, 'm')}). First order: the engine's sensitivities "
             "to the axis errors (central differences) applied to the same samples; "
             "`*_sd_predicted` is the RMS error from J Σ Jᵀ.")
    rep.table(t.drop(columns="variant"), "{:.4g}",
              units={c: ("rad" if c.startswith("rot") else "m") for c in t.columns
                     if c.startswith(("rot", "pos_"))})
    return res


def _solution_count(df, mode) -> list[str]:
    """The complete solvers' account of the solution set (from the table's attrs)."""
    a = df.attrs
    if mode == "complete":
        return [f"{a.get('real_count', len(df))} real solutions of {a.get('complex_count')} "
                f"over the complex numbers (the generic count is {a.get('expected_count')}; "
                f"{a.get('method', '')}); {a.get('failed_paths', 0)} candidates did not polish "
                f"to a solution; {fmt_num(1e3 * a.get('time_s', np.nan), 3)} ms."]
    if mode == "least-squares":
        return [f"{a.get('starts')} exact solutions of {a.get('subsets')} position subsets "
                f"started the fit; {fmt_num(1e3 * a.get('time_s', np.nan), 3)} ms."]
    return []


def _drawings(rep: Report, ranked: pd.DataFrame, T, family: str) -> None:
    """The report's drawing: the best drawable variant's still figure, and every regular
    variant (at most :data:`~linkwright.cmd_draw.VIEWER`, the best-ranked) at the task
    positions in the interactive view's variant selector."""
    from .cmd_draw import VIEWER, regular_variants, variant_scenes
    scenes, not_drawn = variant_scenes(ranked, T, family, best=VIEWER)
    if not scenes:
        return
    v, scn, _ = scenes[0]
    sphere = "sphere centre" in scn.paths
    drawable = len(regular_variants(ranked)) - not_drawn
    held = (f"all {len(scenes)} drawable regular variants" if len(scenes) == drawable else
            f"the {len(scenes)} best-ranked of the {drawable} drawable regular variants "
            f"(at most {VIEWER} are embedded)")
    rep.heading("Drawing of the variants")
    rep.drawing("variants", scn,
                f"The figure: {scn.title}, driven by the engine to its joint values at "
                f"the {len(T)} task positions: " + (
                    "the sphere centre's reached positions as points, the body (free to "
                    "turn about the sphere) at the given poses (triads)" if sphere else
                    "the body's reached frames (solid triads) on the given ones (dotted), "
                    "the body origin's positions as points")
                + f"; earlier positions fainter. The interactive view holds {held}: choose "
                "one with its variant selector, the slider steps through the task "
                "positions."
                + (f" {not_drawn} regular variant(s) are not drawn (two spherical joints, "
                   "or joint values missing from the table)." if not_drawn else ""),
                variants=[s for _, s, _ in scenes])


def run(study: Study, out: Outputs, progress) -> dict:
    crit = study.section("criterion", required=False)
    kind = crit.get("kind", "str", "link_length", choices=CRITERIA) if crit else "link_length"
    center = crit.get("center", "vec3", np.zeros(3)) if crit else np.zeros(3)
    family = study.section("synthesis").get("family", "str")
    progress(f"synthesising {family} through {len(study.sections('position')) + 1} positions")
    family, screws, df, T, size = synthesise(study)
    mode = study.section("synthesis").get("mode", "str", "enumerate", choices=MODES)
    fit = mode == "least-squares"
    if len(df) and not (df.reason == "").any():
        raise study.error("position", "no regular dyad through these positions: "
                          f"{df.reason.iloc[0]}")
    tol = np.inf if fit else RESIDUAL_TOL
    ranked = rank_variants(df, kind, center, size, len(T), tol=tol, progress=progress,
                           fit_first=fit)
    out.add_csv("variants.csv", ranked)
    best_rows = ranked[ranked["rank"].notna()].sort_values("rank")
    excluded = ranked[ranked["rank"].isna()]
    rep = Report(f"{family} " + {"enumerate": "dyad synthesis",
                                 "complete": "synthesis: every solution",
                                 "least-squares": "synthesis: least-squares fit"}[mode])
    crit_words = {"link_length": "the sum of the two links' lengths (common normals)",
                  "axis_distance": "the largest distance of a joint from the centre "
                                   f"{fmt_q(center, 'm')}"}[kind]
    if len(best_rows):
        b = best_rows.iloc[0]
        why = (f"it stays away from singular poses (worst Jacobian condition "
               f"{fmt_num(b.condition, 3)} ≤ {fmt_num(COND_OK)})" if b.condition <= COND_OK
               else "its Jacobian condition is not computed (the rotation of its spherical "
                    "joint before the last joint is not in the table)"
               if not np.isfinite(b.condition)
               else f"no variant stays below condition {fmt_num(COND_OK)}; its worst "
                    f"condition is {fmt_num(b.condition, 3)}")
        runner = ""
        if len(best_rows) > 1:
            s2 = best_rows.iloc[1]
            runner = (f" The next, variant {int(s2.variant)}, has criterion "
                      f"{fmt_q(s2.criterion, 'm')} and condition {fmt_num(s2.condition, 3)}.")
        links = (f"links {fmt_q(b.link1, 'm')} and {fmt_q(b.link2, 'm')}, offset "
                 f"{fmt_q(b.offset, 'm')}" if np.isfinite(b.link2) else
                 f"link length {fmt_q(b.link1, 'm')}")
        lead = (f"Best fit: variant {int(b.variant)} ({_how(b)}), largest pose error "
                f"{fmt_num(b.residual, 3)} over the {len(T)} positions (rad, or length over "
                "the task's reach)" if fit else f"Best variant: {int(b.variant)} ({_how(b)})")
        rep.findings(
            f"{lead}: {kind} = {fmt_q(b.criterion, 'm')}, {fmt_num(b.size_ratio, 3)} times "
            f"the task's size {fmt_q(size, 'm')} ({links}); {why}." + runner,
            f"{len(df)} variants, {len(best_rows)} ranked, {len(excluded)} excluded "
            + ("(degenerate); ranked by their fit first." if fit else
               f"(degenerate or residual above {RESIDUAL_TOL:g}); the largest residual of the "
               f"ranked ones is {fmt_num(best_rows.residual.max(), 2)} (a check of the "
               "engine-verified pose error, not a ranking key)."),
            *_solution_count(df, mode))
    elif mode != "enumerate":
        rep.findings("No real solution through these positions.", *_solution_count(df, mode))
    rep.text(f"Study: {study.path.name}. Ranking: variants with a residual above "
             f"{RESIDUAL_TOL:g} (relative to the task) or degenerate are excluded; the others "
             f"are ranked first by distance from singular poses (worst condition of the "
             f"chain's Jacobian over the {len(T)} positions, moments divided by the task's "
             f"size, at most {fmt_num(COND_OK)}: a large condition means poor motion and "
             f"force transmission), then by the design criterion {kind}: {crit_words}, "
             f"against the task's size {fmt_q(size, 'm')}, then by the condition. Both keys "
             "are rounded to 4 significant digits, so round-off never reorders them.")
    rep.heading(f"Ranked variants (criterion: {kind})")
    how = _how_columns(ranked)
    cols = ["rank", "variant", *how, "criterion", "size_ratio", "link1", "link2",
            "offset", "condition", "residual", "check"]
    units = {"criterion": "m", "size_ratio": DIMENSIONLESS, "link1": "m", "link2": "m",
             "offset": "m", "condition": DIMENSIONLESS, "residual": DIMENSIONLESS,
             **{c: PARAMETER_UNITS[c] for c in how if c in PARAMETER_UNITS}}
    show = best_rows[cols].assign(rank=best_rows["rank"].astype(int))
    rep.table(show, "{:.4g}", units=units)
    if len(excluded):
        rep.heading("Excluded variants")
        rep.table(excluded[["variant", *how, "residual", "check"]], "{:.3g}",
                  units={"residual": DIMENSIONLESS,
                         **{c: PARAMETER_UNITS[c] for c in how if c in PARAMETER_UNITS}})
    rep.heading("Axes of the best variant (first position)")
    if len(best_rows):
        best = best_rows.iloc[0]
        rep.table(pd.DataFrame([{"joint": k, "type": best[f"j{k}_type"],
                                 **{c: best[f"j{k}_{c}"] for c in ("ux", "uy", "uz", "x", "y", "z")}}
                                for k in joint_numbers(best)]), "{:.6g}",
                  units={"ux": DIMENSIONLESS, "uy": DIMENSIONLESS, "uz": DIMENSIONLESS,
                         "x": "m", "y": "m", "z": "m"})
    assemblies = _assemblies(study, mode, ranked, screws, rep, out, progress)
    tolerance = _tolerance(study, best_rows, ranked, T, screws, rep, out, progress)
    _drawings(rep, ranked, np.stack(T), family)
    rep.add_to(out)
    best = best_rows.iloc[0] if len(best_rows) else None
    return {"command": "synth", "family": family, "variants": int(len(df)),
            "ranked": int(len(best_rows)), "regular": int((df.reason == "").sum()),
            "max_residual": quantity(float(df[df.reason == ""].residual.max()), DIMENSIONLESS),
            "best_variant": int(best.variant) if best is not None else None,
            "criterion": kind,
            "best_criterion": quantity(float(best.criterion) if best is not None else None, "m"),
            "best_condition": quantity(float(best.condition) if best is not None else None,
                                       DIMENSIONLESS),
            "task_size": quantity(size, "m"),
            **({} if tolerance is None else {
                "tolerance_worst_displacement_mean": quantity(
                    float(tolerance.summary.pos_mean.max()), "m")}),
            **({} if assemblies is None else {
                "assemblies": int(len(assemblies)),
                "assemblies_without_defects": int(
                    (assemblies["rank"].notna() & ~assemblies.defects.astype(bool)).sum())})}
