"""``linkwright stiffness``: hexapod geometry, pose, frame and load → the stiffness report."""
from __future__ import annotations

import warnings

import numpy as np
import pandas as pd

from closure import exp_so3
from stiffness import (Hexapod, SingularPoseError, SingularPoseWarning, StiffnessError,
                       stiffness_indices)
from stiffness.report import _fmt_value

from .output import Outputs, Report
from .study import Study, StudyError


def _pose(sec):
    T = np.eye(4)
    T[:3, :3] = exp_so3(np.radians(sec.get("rotation_deg", "vec3", np.zeros(3))))
    T[:3, 3] = sec.get("position", "vec3")
    return T


#: largest stiffness map one run computes in memory (about 1 KB per pose while it runs)
MAX_MAP_POSES = 2_000_000


def _axis(sec, key):
    v = sec.get(key, "vec", None, length=3)
    if v is None:
        return None
    if v[2] < 1 or v[2] != int(v[2]) or v[2] > MAX_MAP_POSES:
        raise sec.error(key, f"expected [from, to, count] with an integer count from 1 to "
                             f"{MAX_MAP_POSES:,}, got {[float(x) for x in v]}")
    return np.linspace(v[0], v[1], int(v[2]))


def _hexapod_key(message: str) -> str:
    """The key of ``[hexapod]`` a :class:`StiffnessError` message is about."""
    head = message.split(":", 1)[0].strip()
    return head if head in ("base_points", "platform_points", "leg_stiffness") else ""


def degenerate_legs(hx: Hexapod, T) -> list[int]:
    """The legs (1-based) whose Plücker lines are linearly dependent at pose ``T``: those
    with a share above 1 % in the null space of the leg matrix P (moments scaled by the
    platform radius, as cond(P) is)."""
    P = np.array(hx.leg_matrix(T), dtype=float)
    P[3:] /= getattr(hx, "radius", 1.0) or 1.0
    _, s, vt = np.linalg.svd(P)
    if not np.all(np.isfinite(s)) or s[0] == 0:
        return list(range(1, P.shape[1] + 1))
    null = vt[s <= s[0] / hx.singular_cond] if np.any(s <= s[0] / hx.singular_cond) else vt[-1:]
    share = (null ** 2).sum(axis=0)
    return [int(i) + 1 for i in np.flatnonzero(share > 0.01)]


def _singular(study: Study, hx: Hexapod, T, cond) -> StudyError:
    legs = degenerate_legs(hx, T)
    which = ("legs " + ", ".join(map(str, legs)) + " are") if len(legs) > 1 else \
        (f"leg {legs[0]} is" if legs else "the legs are")
    c = "inf" if not np.isfinite(cond) else f"{float(cond):.3g}"
    return study.error("pose", f"pose is singular (cond(P) = {c}): {which} degenerate "
                               "(linearly dependent leg lines); move or turn the platform")


def run(study: Study, out: Outputs, progress) -> dict:
    h = study.section("hexapod")
    k = h.get("leg_stiffness", "vec" if isinstance(h.data.get("leg_stiffness"), list) else "float")
    try:
        hx = Hexapod(h.get("base_points", "points"), h.get("platform_points", "points"), k)
    except StiffnessError as e:
        key = _hexapod_key(str(e))
        raise h.error(key, str(e).split(":", 1)[1].strip() if key else str(e)) from None
    T = _pose(study.section("pose"))
    try:
        return _report(study, out, progress, hx, T)
    except SingularPoseError:     # K or P singular past the package's limits: bad input
        raise _singular(study, hx, T, float(hx.cond_P(T))) from None


def _report(study: Study, out: Outputs, progress, hx: Hexapod, T) -> dict:
    rsec = study.section("report", required=False)
    frame = rsec.get("frame", "str", "platform", choices=("platform", "base")) if rsec else "platform"
    wrench = rsec.get("wrench", "vec", None, length=6) if rsec else None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SingularPoseWarning)   # decided just below
            res = hx.stiffness(T, frame=None if frame == "base" else "platform")
    except SingularPoseError:
        raise
    except StiffnessError as e:
        raise study.error("pose", str(e)) from None
    if not res.cond_P <= hx.singular_cond:
        raise _singular(study, hx, T, res.cond_P)
    K = res.K
    cols = ["dx", "dy", "dz", "tx", "ty", "tz"]
    out.add_csv("stiffness.csv", pd.DataFrame(K, columns=cols).assign(
        row=["fx", "fy", "fz", "mx", "my", "mz"]))
    rep = Report("Hexapod stiffness report")
    rep.text(f"Study: {study.path.name}. Wrench W = (f, m) in N, N·m; displacement Δ = (δ, θ) "
             "in m, rad (seed 003). K is the unloaded (congruence) stiffness P Kθ Pᵀ.")
    rep.heading("Pose and frame")
    rep.text(f"Platform origin {np.round(T[:3, 3], 6).tolist()} m; reference point "
             f"{np.round(np.atleast_1d(res.reference), 6).tolist()} m ({frame} frame); "
             f"cond(P) = {res.cond_P:.4g}.")
    rep.heading("Stiffness matrix (blocks N/m, N/rad, N·m/rad)")
    rep.table(pd.DataFrame(K, columns=["δx", "δy", "δz", "θx", "θy", "θz"]), "{:.4e}")
    idx = stiffness_indices(K)
    kt = idx.value[0]
    rep.heading("Indices")
    rep.table(idx.assign(value=idx.value.map(_fmt_value)))
    summary = {"command": "stiffness", "frame": frame, "cond_P": float(res.cond_P),
               "kt_min": float(kt[0]), "kt_max": float(kt[-1])}
    if wrench is not None:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", SingularPoseWarning)
            tau = hx.leg_forces(T, wrench)
            d = hx.deflection(T, wrench)
        for w in sorted({str(w.message) for w in caught}):
            study.warn("pose", w)
        lf = pd.DataFrame({"leg": np.arange(1, tau.size + 1), "force_N": tau})
        out.add_csv("leg_forces.csv", lf)
        rep.heading("Load case (wrench about the base origin)")
        rep.table(lf)
        rep.text(f"Deflection about the base origin: δ = {np.array2string(d[:3], precision=5)} m, "
                 f"θ = {np.array2string(d[3:], precision=5)} rad.")
        summary["max_leg_force"] = float(np.abs(tau).max())
    msec = study.section("map", required=False)
    if msec:
        xs, ys, zs = (_axis(msec, k) for k in ("x", "y", "z"))    # each count checked first
        counts = [1 if a is None else a.size for a in (xs, ys, zs)]
        if np.prod(counts, dtype=float) > MAX_MAP_POSES:
            raise msec.error("x", f"the map has {np.prod(counts, dtype=float):.3g} poses "
                                  f"({' × '.join(map(str, counts))}); at most {MAX_MAP_POSES:,} "
                                  "fit one run: use fewer points per axis or split the map")
        xs = xs if xs is not None else np.array([T[0, 3]])
        ys = ys if ys is not None else np.array([T[1, 3]])
        zs = zs if zs is not None else np.array([T[2, 3]])
        pos = np.array(np.meshgrid(xs, ys, zs, indexing="ij")).reshape(3, -1).T
        progress(f"stiffness map over {len(pos)} poses")
        mp = hx.map(pos, None)
        out.add_csv("map.csv", mp)
        rep.heading(f"Map over {len(mp)} positions (about the {mp.attrs['reference']})")
        rep.table(mp.describe().loc[["min", "max"], ["kt_min", "kt_max", "cr_max", "cond_P"]]
                  .reset_index())
        sl = mp[mp.z == mp.z.iloc[0]]

        def heat(ax):
            g = sl.pivot_table(index="y", columns="x", values="kt_min")
            m = ax.pcolormesh(g.columns, g.index, g.to_numpy(), shading="auto")
            ax.figure.colorbar(m, ax=ax, label="kt_min (N/m)")
            ax.set_xlabel("x (m)")
            ax.set_ylabel("y (m)")
            ax.set_title(f"smallest translational stiffness, z = {sl.z.iloc[0]:.3g} m")
        rep.figure("map.png", heat)
        summary["map_poses"] = int(len(mp))
        summary["map_singular"] = int(mp.singular.sum())
    rep.add_to(out)
    return summary
