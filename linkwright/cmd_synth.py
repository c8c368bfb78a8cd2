"""``linkwright synth``: positions → the variant table and a ranked report."""
from __future__ import annotations

import numpy as np
import pandas as pd

from synthesis import Line, Screw, SynthesisError, enumerate_dyads

from .output import Outputs, Report
from .study import Study

CRITERIA = ("link_length", "axis_distance")


def _elements(row):
    """The joints as Lines, or centre points (arrays) for spheres."""
    out = []
    for k in (1, 2, 3):
        p = np.array([row[f"j{k}_x"], row[f"j{k}_y"], row[f"j{k}_z"]])
        if row[f"j{k}_type"] == "S":
            out.append(p)
        else:
            out.append(Line(np.array([row[f"j{k}_ux"], row[f"j{k}_uy"], row[f"j{k}_uz"]]), p))
    return out


def _distance(a, b):
    if isinstance(a, Line) and isinstance(b, Line):
        return a.distance_to(b)
    line, pt = (a, b) if isinstance(a, Line) else (b, a)
    return float(np.linalg.norm(pt - line.foot_from(pt)))


def criterion_values(df: pd.DataFrame, kind: str, center=None) -> np.ndarray:
    """``link_length``: the sum of the two links' lengths (common normals, or the distance
    from an axis to a sphere centre); ``axis_distance``: the largest distance of the
    joints (axes or sphere centre) from ``center`` (both in length units)."""
    out = np.full(len(df), np.nan)
    for i, (_, r) in enumerate(df.iterrows()):
        if r.get("reason", ""):
            continue
        E = _elements(r)
        if kind == "link_length":
            out[i] = _distance(E[0], E[1]) + _distance(E[1], E[2])
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


def run(study: Study, out: Outputs, progress) -> dict:
    sec = study.section("synthesis")
    family = sec.get("family", "str")
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
    crit = study.section("criterion", required=False)
    kind = crit.get("kind", "str", "link_length", choices=CRITERIA) if crit else "link_length"
    center = crit.get("center", "vec3", np.zeros(3)) if crit else np.zeros(3)
    progress(f"synthesising {family} through {len(screws) + 1} positions")
    try:
        df = enumerate_dyads(family, screws)
    except SynthesisError as e:
        raise study.error("synthesis.family" if "family" in str(e) else "position", str(e)) \
            from None
    if len(df) and not (df.reason == "").any():
        raise study.error("position", "no regular dyad through these positions: "
                          f"{df.reason.iloc[0]}")
    df["criterion"] = criterion_values(df, kind, center)
    ranked = df.sort_values(["residual", "criterion"], na_position="last")
    by_crit = df[df.reason == ""].sort_values("criterion")
    out.add_csv("variants.csv", df)
    rep = Report(f"{family} dyad synthesis")
    rep.text(f"Study: {study.path.name}. {len(df)} variants, "
             f"{int((df.reason == '').sum())} regular; largest residual of the regular ones "
             f"{df[df.reason == ''].residual.max():.2e} (engine-verified pose error).")
    rep.heading(f"Ranked by the design criterion: {kind}")
    cols = [c for c in ("variant", "order", "mechanism", "rr", "member", "residual", "criterion")
            if c in df.columns]
    rep.table(by_crit[cols])
    rep.heading("Ranked by residual")
    rep.table(ranked[cols + ["reason"]])
    rep.heading("Axes of the best variant by the criterion (first position)")
    if len(by_crit):
        best = by_crit.iloc[0]
        rep.table(pd.DataFrame([{"joint": k, "type": best[f"j{k}_type"],
                                 **{c: best[f"j{k}_{c}"] for c in ("ux", "uy", "uz", "x", "y", "z")}}
                                for k in (1, 2, 3)]))
    rep.add_to(out)
    return {"command": "synth", "family": family, "variants": int(len(df)),
            "regular": int((df.reason == "").sum()),
            "max_residual": float(df[df.reason == ""].residual.max()),
            "best_variant": int(by_crit.iloc[0].variant) if len(by_crit) else None,
            "criterion": kind}
