"""``linkwright stiffness``: hexapod geometry, pose, frame and load → the stiffness report."""
from __future__ import annotations

import warnings
from typing import NamedTuple

import numpy as np
import pandas as pd

from closure import exp_so3, log_so3
from stiffness import (Hexapod, SingularPoseError, SingularPoseWarning, StiffnessError,
                       stiffness_indices)
from stiffness.matrices import compliance_of

from .output import Outputs
from .render import DIMENSIONLESS, Report, fmt_list, fmt_num, fmt_q, quantity, varying_axes
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


def hexapod_of(study: Study):
    """The hexapod and pose ``(hx, T)`` of a hexapod stiffness study (errors name the key)."""
    h = study.section("hexapod")
    k = h.get("leg_stiffness", "vec" if isinstance(h.data.get("leg_stiffness"), list) else "float")
    try:
        hx = Hexapod(h.get("base_points", "points"), h.get("platform_points", "points"), k)
    except StiffnessError as e:
        key = _hexapod_key(str(e))
        raise h.error(key, str(e).split(":", 1)[1].strip() if key else str(e)) from None
    return hx, _pose(study.section("pose"))


def run(study: Study, out: Outputs, progress) -> dict:
    if study.has("mechanism"):
        return run_mechanism(study, out, progress)
    hx, T = hexapod_of(study)
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
    positions = blocked_map = None
    msec = study.section("map", required=False)
    if msec:
        xs, ys, zs = (_axis(msec, k) for k in ("x", "y", "z"))    # each count checked first
        counts = [1 if a is None else a.size for a in (xs, ys, zs)]
        xs = xs if xs is not None else np.array([T[0, 3]])
        ys = ys if ys is not None else np.array([T[1, 3]])
        zs = zs if zs is not None else np.array([T[2, 3]])
        blocked = msec.get("blocked", "str", None, choices=("dask", "serial"))
        if blocked is None and np.prod(counts, dtype=float) > MAX_MAP_POSES:
            blocked = "dask"
        if blocked is None:
            positions = np.array(np.meshgrid(xs, ys, zs, indexing="ij")).reshape(3, -1).T
        else:
            from .bigmap import map_from_study
            blocked_map = map_from_study(msec, hx, T, (xs, ys, zs), blocked, progress)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", SingularPoseWarning)
        rep, tables, summary = stiffness_report(
            hx, T, res, frame_name=frame, wrench=wrench, positions=positions,
            title=study.section("study").get("title", "str", "Hexapod stiffness report"),
            source=f"Study: {study.path.name}.", progress=progress)
    for w in sorted({str(w.message) for w in caught
                     if issubclass(w.category, SingularPoseWarning)}):
        study.warn("pose", w)
    for w in caught:                                   # any other warning: passed on
        if not issubclass(w.category, SingularPoseWarning):
            warnings.warn(w.message, w.category, stacklevel=2)
    if blocked_map is not None:
        summary.update(blocked_map.report(rep, tables))
    tsec = study.section("tolerance", required=False)
    if tsec is not None:
        summary.update(_tolerance_section(rep, tables, tsec, hx, T, progress))
    for name, df in tables.items():
        out.add_csv(name, df)
    rep.add_to(out)
    return summary


def _tolerance_section(rep: Report, tables: dict, sec, hx: Hexapod, T, progress) -> dict:
    """The ``[tolerance]`` study (:func:`stiffness.tolerance.hexapod_tolerance`) as a report
    section and ``tolerance.csv``; its figures for the JSON summary."""
    from stiffness.tolerance import hexapod_tolerance
    n = sec.get("samples", "int", 2000, low=10)
    if progress is not None:
        progress(f"tolerance study: {n} made hexapods")
    ps, ks = sec.get("point_sigma", low=0.0), sec.get("stiffness_sigma", "float", 0.0, low=0.0)
    try:
        r = hexapod_tolerance(hx, T, point_sigma=ps, stiffness_sigma=ks, samples=n,
                              seed=sec.get("seed", "int", 0, low=0))
    except StiffnessError as e:
        raise sec.error("", str(e)) from None
    t = r.summary
    tables["tolerance.csv"] = t
    rep.heading("Manufacturing tolerances")
    kt = t.set_index("index").loc["kt_min"]
    rep.findings(f"With attachment points made to σ = {fmt_q(ps, 'm')} per coordinate and leg "
                 f"stiffnesses to {fmt_num(100 * ks, 3)} %: kt_min {fmt_q(kt['mean'], 'N/m')} ± "
                 f"{fmt_q(kt['std'], 'N/m')} over {n} made hexapods (design "
                 f"{fmt_q(kt['nominal'], 'N/m')}); first order "
                 f"{'holds' if kt['first_order'] == 'reliable' else 'does not hold (a nearly repeated eigenvalue: the sampled figures are the answer)'}.")
    rep.text("Sampled mean and standard deviation of each index beside the first-order "
             "prediction (the model's sensitivities by central differences, applied to the "
             "same samples; `sd_predicted` = sqrt(J Σ Jᵀ)); `gap`: the index eigenvalue's "
             "relative distance from its neighbour at the design.")
    rep.table(t, "{:.4g}")
    return {"tolerance_kt_min_mean": quantity(float(kt["mean"]), "N/m"),
            "tolerance_kt_min_std": quantity(float(kt["std"]), "N/m")}


def map_chunked(hx: Hexapod, positions, rotations, progress=None, chunk: int = 4096):
    """:meth:`Hexapod.map` in chunks of positions, with a progress bar on a terminal."""
    positions = np.asarray(positions, float)
    if not hasattr(progress, "bar") or len(positions) <= chunk:
        return hx.map(positions, rotations)
    parts = []
    with progress.bar(total=len(positions), desc="stiffness map", unit="pose") as bar:
        for i in range(0, len(positions), chunk):
            parts.append(hx.map(positions[i:i + chunk], rotations))
            bar.update(len(parts[-1]))
    mp = pd.concat(parts, ignore_index=True)
    mp.attrs = dict(parts[0].attrs)
    return mp


def _directions(Kn):
    """Eigenvalues (ascending) and unit eigenvectors (columns, largest component > 0)."""
    w, V = np.linalg.eigh(0.5 * (Kn + Kn.T))
    for j in range(3):
        if V[np.argmax(np.abs(V[:, j])), j] < 0:
            V[:, j] *= -1
    return w, V


def _dir(v) -> str:
    return fmt_list(np.round(v, 3) + 0.0, 3)


def stiffness_report(hx: Hexapod, T, res, *, frame_name: str, wrench=None, positions=None,
                     rotations=None, title: str = "Hexapod stiffness report", source: str = "",
                     progress=None, figures: bool = True):
    """The stiffness report of a hexapod at pose ``T`` (shared by ``linkwright stiffness``
    and :func:`stiffness.report`).

    Parameters
    ----------
    hx : Hexapod
    T : (4, 4) pose
    res : StiffnessResult at ``T`` (in the report's frame)
    frame_name : str
        Words for the frame of ``res`` (``"platform"``, ``"base"``, ``"given"``).
    wrench : (6,) or None
        Load case about the base origin (N, N·m).
    positions : (M, 3) or None
        Map positions (m); the map is taken at ``rotations`` (rotation vectors, rad),
        by default the pose's own rotation.
    figures : bool
        Draw the map's heat map (False: text and tables only).

    Returns
    -------
    (Report, dict of name → DataFrame, dict)
        The report, its CSV tables and the JSON summary (quantities with units).
    """
    K = res.K
    rv = log_so3(T[:3, :3])
    kt, V = _directions(K[:3, :3])
    idx = stiffness_indices(K)
    cr = idx[idx["index"] == "cr"].value.to_numpy()
    kc = float(idx[idx["index"] == "coupling"].value.iloc[0])
    _, Vr = _directions(compliance_of(K)[3:, 3:])
    axes_words = "platform axes" if frame_name == "platform" else (
        "base axes" if frame_name == "base" else "the frame's axes")
    rep = Report(title)
    c = float(res.cond_P)
    health = ("far from singular" if c < 10 else "well conditioned" if c < 100 else
              "approaching a singular pose" if c < 1e4 else "near a singular pose")
    weak = f"along {_dir(V[:, 0])}"
    if kt[1] - kt[0] <= 1e-3 * kt[0]:
        weak = (f"in every direction normal to {_dir(V[:, 2])} (the two smallest "
                f"eigenvalues agree within {fmt_num(100 * (kt[1] - kt[0]) / kt[0], 2)} %)")
    rep.findings(
        f"Weakest translation {weak}: kt_min = {fmt_q(kt[0], 'N/m')}; stiffest along "
        f"{_dir(V[:, 2])}: kt_max = {fmt_q(kt[2], 'N/m')} ({fmt_num(kt[2] / kt[0], 3)} times "
        f"stiffer); directions in the {axes_words}.",
        f"Rotational compliance {fmt_q(cr[0], 'rad/(N·m)')} to {fmt_q(cr[-1], 'rad/(N·m)')} "
        f"(most compliant about {_dir(Vr[:, 2])}); "
        f"coupling ‖K_c‖ = {fmt_q(kc, 'N/rad')} about the {frame_name} reference point.",
        f"cond(P) = {fmt_num(c)} ({health}; singular above {fmt_num(hx.singular_cond)}).")
    rep.text((source + " " if source else "") + "Wrench W = (f, m) in N, N·m; displacement "
             "Δ = (δ, θ) in m, rad (seed 003). K is the unloaded (congruence) stiffness "
             "P Kθ Pᵀ.")
    rep.heading("Pose and frame")
    rep.table(pd.DataFrame([
        ("platform origin (base frame)", fmt_list(T[:3, 3], 6), "m"),
        ("platform rotation vector", fmt_list(np.degrees(rv), 6), "deg"),
        ("reference point of K (base coordinates)", fmt_list(np.atleast_1d(res.reference), 6), "m"),
        ("axes of K, rows of R (r' = R (r − p))", fmt_list(res.R, 6), DIMENSIONLESS),
        ("cond(P) (moments / platform radius " + fmt_q(hx.radius, "m") + ")", fmt_num(c), DIMENSIONLESS),
    ], columns=["quantity", "value", "unit"]))
    rep.heading("Stiffness matrix K")
    rep.text("Rows: wrench components (f in N, m in N·m); columns: displacement components "
             "(δ in m, θ in rad); an entry's unit is its row's over its column's: N/m, N/rad, "
             "N·m/m = N, N·m/rad.")
    kdf = pd.DataFrame(K, columns=["δx (m)", "δy (m)", "δz (m)", "θx (rad)", "θy (rad)",
                                   "θz (rad)"])
    kdf.insert(0, "row", ["fx (N)", "fy (N)", "fz (N)", "mx (N·m)", "my (N·m)", "mz (N·m)"])
    rep.table(kdf, "{:.4e}")
    rep.heading("Indices")
    rep.table(idx, "{:.5g}")
    tables = {"stiffness.csv": pd.DataFrame(K, columns=["dx", "dy", "dz", "tx", "ty", "tz"])
              .assign(row=["fx", "fy", "fz", "mx", "my", "mz"])}
    summary = {"command": "stiffness", "frame": frame_name,
               "cond_P": quantity(c, DIMENSIONLESS), "kt_min": quantity(kt[0], "N/m"),
               "kt_max": quantity(kt[2], "N/m"),
               "weakest_direction": quantity(np.round(V[:, 0], 6) + 0.0, DIMENSIONLESS),
               "stiffest_direction": quantity(np.round(V[:, 2], 6) + 0.0, DIMENSIONLESS),
               "cr_max": quantity(cr[-1], "rad/(N·m)"),
               "most_compliant_rotation_axis": quantity(np.round(Vr[:, 2], 6) + 0.0,
                                                        DIMENSIONLESS),
               "coupling": quantity(kc, "N/rad")}
    if wrench is not None:
        W = np.asarray(wrench, float)
        tau = hx.leg_forces(T, W)
        d = hx.deflection(T, W)
        lf = pd.DataFrame({"leg": np.arange(1, tau.size + 1), "force_N": tau})
        tables["leg_forces.csv"] = lf
        rep.heading("Load case (wrench about the base origin)")
        rep.text(f"W = f {fmt_q(W[:3], 'N')}, m {fmt_q(W[3:], 'N·m')}; leg forces positive in "
                 "tension.")
        rep.table(lf.rename(columns={"force_N": "force (N)"}), "{:.5g}")
        rep.table(pd.DataFrame([("translation δ", fmt_list(d[:3]), "m"),
                                ("rotation θ", fmt_list(d[3:]), "rad")],
                               columns=["deflection about the base origin", "value", "unit"]))
        i = int(np.argmax(np.abs(tau)))
        rep.findings(f"Under the load case: largest leg force {fmt_q(abs(tau[i]), 'N')} in "
                     f"{'tension' if tau[i] > 0 else 'compression'} (leg {i + 1}); "
                     f"deflection δ = {fmt_q(d[:3], 'm', 3)}, θ = {fmt_q(d[3:], 'rad', 3)}.")
        summary["max_leg_force"] = quantity(float(np.abs(tau).max()), "N")
        summary["deflection_translation"] = quantity(d[:3], "m")
        summary["deflection_rotation"] = quantity(d[3:], "rad")
    if figures:
        _hexapod_drawing(rep, hx, T, res, None if wrench is None else tau)
    if positions is not None:
        rots = np.atleast_2d(rv) if rotations is None else rotations   # checked by map
        if progress is not None:
            progress(f"stiffness map over {len(positions) * len(rots)} poses")
        mp = map_chunked(hx, positions, rots, progress)
        rots = mp[["rx", "ry", "rz"]].drop_duplicates().to_numpy()
        tables["map.csv"] = mp
        _map_section(rep, mp, hx, figures)
        summary["map_poses"] = int(len(mp))
        summary["map_singular"] = int(mp.singular.sum())
        summary["map_rotation"] = quantity(np.degrees(rots[0]) if len(rots) == 1 else
                                           np.degrees(rots), "deg")
        summary["map_kt_min"] = quantity(float(mp.kt_min.min()), "N/m")
    return rep, tables, summary


def hexapod_scene_of(hx: Hexapod, T, res, forces=None):
    """The drawing of the hexapod at its pose: legs coloured by ``forces`` (N, one per
    leg; None: unloaded), the weakest and stiffest translation directions of ``res.K`` as
    arrows at K's reference point."""
    from .draw import hexapod_scene
    _, V = _directions(res.K[:3, :3])
    Rt = np.asarray(res.R, float).reshape(3, 3).T            # the result's axes → base axes
    ref = np.asarray(res.reference, float).reshape(3)
    L = 0.3 * float(np.linalg.norm(np.ptp(np.vstack([hx.base, hx.platform_points_world(T)]),
                                          axis=0)))           # of the drawing's size
    scn = hexapod_scene(hx.base, hx.platform, T, forces=forces, title="Hexapod at the pose",
                        arrows={"weakest": (ref, L * (Rt @ V[:, 0]), "#d62728"),
                                "stiffest": (ref, L * (Rt @ V[:, 2]), "#2ca02c")})
    return scn


#: the caption of the hexapod drawing (report and ``linkwright draw``)
def hexapod_caption(loaded: bool) -> str:
    return ("The hexapod at the pose (base frame): Hooke crosses at the base, balls at the "
            "platform; arrows at K's reference point along the weakest (red) and stiffest "
            "(green) translation directions"
            + ("; legs coloured by force, tension red, compression blue, the legend giving "
               "each force." if loaded else "."))


def _hexapod_drawing(rep: Report, hx: Hexapod, T, res, forces) -> None:
    scn = hexapod_scene_of(hx, T, res, forces)
    rep.heading("Drawing")
    rep.drawing("hexapod", scn, hexapod_caption(forces is not None))


def _map_section(rep: Report, mp: pd.DataFrame, hx: Hexapod, figures: bool = True) -> None:
    from .bigmap import UNITS as units
    vary = varying_axes(mp)
    rots = mp[["rx", "ry", "rz"]].drop_duplicates().to_numpy()
    rot_text = (f"at the platform rotation vector {fmt_q(np.degrees(rots[0]), 'deg')}"
                if len(rots) == 1 else f"over {len(rots)} rotations")
    rep.heading("Map over poses")
    rep.text(f"{len(mp)} poses {rot_text}; the indices are the same about any reference "
             f"point. Varying: {', '.join(vary) or 'nothing (one pose)'}.")
    rep.table(pd.DataFrame([(col, float(mp[col].min()), float(mp[col].max()), units[col])
                            for col in units], columns=["index", "min", "max", "unit"]), "{:.5g}")
    i = int(np.nanargmin(mp.kt_min.to_numpy())) if mp.kt_min.notna().any() else 0
    where = fmt_q(mp.loc[i, ["x", "y", "z"]].to_numpy(float), "m")
    rep.findings(f"Over the map ({len(mp)} poses {rot_text}): kt_min from "
                 f"{fmt_q(mp.kt_min.min(), 'N/m')} (at {where}) to {fmt_q(mp.kt_min.max(), 'N/m')}; "
                 f"{int(mp.singular.sum())} singular poses (cond(P) > {fmt_num(hx.singular_cond)}).")
    if not vary or not figures:
        return
    sl, fixed = mp, ""
    if len(vary) > 2:
        third = vary[2]
        sl = mp[mp[third] == mp[third].iloc[0]]
        v = sl[third].iloc[0]
        fixed = (f", {third} = {fmt_q(v, 'm')}" if third in "xyz"
                 else f", {third} = {fmt_q(np.degrees(v), 'deg')}")
    held = [f"{c} = {fmt_q(sl[c].iloc[0], 'm')}" for c in "xyz" if c not in vary]
    if len(rots) == 1:
        held.append(f"rotation {fmt_q(np.degrees(rots[0]), 'deg', 3)}")
    from .render import heat_map
    rep.figure("map.png", lambda ax: heat_map(
        ax, sl, "kt_min", vary[0], vary[1] if len(vary) > 1 else None, "N/m",
        title=f"smallest translational stiffness{fixed}\n({', '.join(held)})"))


# --------------------------------------------------------------------------- mechanisms

def _mechanism_key(message: str) -> str:
    """The key of a study a :class:`StiffnessError` of :func:`stiffness.of_mechanism` is
    about (``springs['P0']: …`` → ``elastic.springs``)."""
    head = message.split(":", 1)[0].strip()
    for arg, key in (("springs", "elastic.springs"), ("link_springs", "elastic.link"),
                     ("locked", "elastic.locked"),
                     ("platform", "elastic.platform"), ("point", "elastic.point"),
                     ("wrench", "report.wrench"), ("pose", "elastic.inputs")):
        if head == arg or head.startswith(arg + "[") or head.startswith(arg + " "):
            return key
    return "elastic"


def _health(c: float) -> str:
    return ("far from singular" if c < 10 else "well conditioned" if c < 100 else
            "approaching a singular pose" if c < 1e4 else "near a singular pose")


def _mechanism_inputs(study: Study):
    """(mechanism, elastic section, platform, springs, locked, inputs, point) checked."""
    from closure import MechanismError
    from .mechspec import build_mechanism
    msec = study.section("mechanism")
    mech = build_mechanism(msec)
    try:
        mech.mobility                                      # assembles: inputs ≤ mobility
    except MechanismError as e:
        raise msec.error("input", str(e)) from None
    e = study.section("elastic")
    platform = e.get("platform", "str")
    if platform not in mech.links[1:]:
        raise e.error("platform", f"expected a moving link ({', '.join(mech.links[1:])}), "
                                  f"got {platform!r}")
    springs = {k: (float(v) if not isinstance(v, list) else [float(x) for x in v])
               for k, v in e.get("springs", "any", {}).items()}
    locked = e.get("locked", "strs", None)
    x = e.get("inputs", "vec")
    labels = mech.input_labels()
    if x.size != len(labels):
        raise e.error("inputs", f"expected {len(labels)} values, one per input "
                                f"({', '.join(labels)}), got {x.size}")
    point = e.get("point", "vec3", np.zeros(3))
    return mech, e, platform, springs, locked, x, point


def link_springs(e, mech) -> list:
    """``[[elastic.link]]``: each beam as ``(link, joint, F, K, length)`` for
    :func:`stiffness.of_mechanism` (F at the tip, x along the beam from the joint's
    origin, y the section's y axis; K its end stiffness), checked with the study's keys."""
    from stiffness import beam_stiffness
    out = []
    for i, b in enumerate(e.sections("link", required=False)):
        link, joint = b.get("link", "str"), b.get("joint", "str")
        if link not in mech.links[1:]:
            raise b.error("link", f"expected a moving link ({', '.join(mech.links[1:])}), "
                                  f"got {link!r}")
        names = [j.name for j in mech.joints]
        if joint not in names:
            raise b.error("joint", f"no joint named {joint!r}; joints: {', '.join(names)}")
        j = mech.joints[names.index(joint)]
        if link not in (j.link_a, j.link_b):
            raise b.error("joint", f"joint {joint!r} joins {j.link_a!r} and {j.link_b!r}, not "
                                   f"the link {link!r}")
        root = (j.frame_a if j.link_a == link else j.frame_b)[:3, 3]
        tip = b.get("tip", "vec3")
        axis = tip - root
        span = float(np.linalg.norm(axis))
        size = max(float(mech.tree.scale), 1e-300)
        if span <= 1e-9 * size:
            raise b.error("tip", f"the tip {fmt_list(tip)} is at the joint {joint!r}'s origin: "
                                 "expected the beam's other end")
        x = axis / span
        ydir = b.get("y_axis", "vec3", None)
        if ydir is None:
            ydir = np.eye(3)[int(np.argmin(np.abs(x)))]
        y = ydir - x * (x @ ydir)
        if np.linalg.norm(y) <= 1e-6 * max(np.linalg.norm(ydir), 1e-300):
            raise b.error("y_axis", f"{fmt_list(ydir)} is along the beam; expected a direction "
                                    "across it")
        y = y / np.linalg.norm(y)
        F = np.eye(4)
        F[:3, :3] = np.c_[x, y, np.cross(x, y)]
        F[:3, 3] = tip
        length = b.get("length", "float", span)
        K = beam_stiffness(length, E=b.get("E", "float"), G=b.get("G", "float"),
                           area=b.get("area", "float"), Iy=b.get("Iy", "float"),
                           Iz=b.get("Iz", "float"), J=b.get("J", "float"))
        out.append((link, joint, F, K, length))
    return out


def _of_mechanism(study, e, mech, pose, **kw):
    """:func:`stiffness.of_mechanism` with its errors as study errors (exit 2)."""
    from stiffness import of_mechanism
    try:
        return of_mechanism(mech, pose, **kw)
    except SingularPoseError as err:
        if str(err).startswith("wrench:"):                  # a critical (buckling) load
            raise StudyError(study.path, "report.wrench", str(err).split(":", 1)[1].strip()) \
                from None
        msg = str(err).split(":", 1)[1].strip() if str(err).startswith("pose:") else str(err)
        raise e.error("springs", msg) from None
    except StiffnessError as err:
        key, msg = _mechanism_key(str(err)), str(err)
        head, _, rest = msg.partition(":")
        if rest and key.endswith("." + head.strip()):      # the key says it already
            msg = rest.strip()
        raise StudyError(study.path, key, msg) from None


class MechanismStudy(NamedTuple):
    """A mechanism stiffness study solved at its inputs (:func:`mechanism_of`)."""

    mech: object
    pose: object
    res: object          #: MechanismStiffness at the pose (unloaded), in the report's frame
    elastic: Study       #: the ``[elastic]`` section
    kw: dict             #: the keywords of :func:`stiffness.of_mechanism`
    point: np.ndarray
    frame: str           #: "platform" or "base"
    wrench: np.ndarray | None


def mechanism_of(study: Study, progress=lambda msg: None) -> MechanismStudy:
    """A mechanism stiffness study (``[mechanism]`` and ``[elastic]``) checked, its
    mechanism solved at the inputs and its unloaded stiffness there (study errors: exit
    2)."""
    from closure import ClosureError
    mech, e, platform, springs, locked, x, point = _mechanism_inputs(study)
    progress(f"solving the mechanism at inputs {fmt_list(x)}")
    try:
        pose = mech.solve(x)
    except ClosureError as err:
        raise e.error("inputs", f"the mechanism does not close at these inputs: {err}") from None
    rsec = study.section("report", required=False)
    frame = rsec.get("frame", "str", "platform", choices=("platform", "base")) if rsec \
        else "platform"
    wrench = rsec.get("wrench", "vec", None, length=6) if rsec else None
    T = np.asarray(pose.link_frame(platform), float).reshape(-1, 4, 4)[0]
    if frame == "platform":
        R, p = T[:3, :3].T, T[:3, :3] @ point + T[:3, 3]
    else:
        R, p = np.eye(3), np.zeros(3)
    kw = dict(platform=platform, springs=springs, locked=locked,
              link_springs=link_springs(e, mech) or None, frame=(R, p))
    res = _of_mechanism(study, e, mech, pose, **kw)
    return MechanismStudy(mech, pose, res, e, kw, point, frame, wrench)


def run_mechanism(study: Study, out: Outputs, progress) -> dict:
    """A stiffness study of a mechanism: ``[mechanism]`` and ``[elastic]``."""
    ms = mechanism_of(study, progress)
    mech, pose, kw, wrench = ms.mech, ms.pose, ms.kw, ms.wrench
    loaded = _of_mechanism(study, ms.elastic, mech, pose, wrench=wrench, **kw) \
        if wrench is not None else None
    values = None
    msec = study.section("map", required=False)
    if msec:
        values = _input_grid(msec, len(mech.input_labels()))
    rep, tables, summary = mechanism_report(
        mech, pose, ms.res, platform=kw["platform"], springs=kw["springs"],
        locked=kw["locked"], point=ms.point, link_springs=kw["link_springs"],
        frame_name=ms.frame, wrench=wrench, loaded=loaded, map_inputs=values,
        title=mechanism_title(study), source=f"Study: {study.path.name}.", progress=progress)
    for name, df in tables.items():
        out.add_csv(name, df)
    rep.add_to(out)
    return summary


def mechanism_title(study: Study) -> str:
    """The report's title: ``[study] title`` or a default."""
    sec = study.section("study", required=False)
    return sec.get("title", "str", "Mechanism stiffness report") if sec else \
        "Mechanism stiffness report"


def _input_grid(msec, n: int) -> np.ndarray:
    """``[map] inputs``: the grid of input values ``(M, n)``."""
    ranges = msec.data.get("inputs")
    if len(ranges) != n:
        raise msec.error("inputs", f"expected {n} ranges [from, to, count], one per input, "
                                   f"got {len(ranges)}")
    axes = []
    for i, v in enumerate(ranges):
        if v[2] < 1 or v[2] != int(v[2]) or v[2] > MAX_MAP_POSES:
            raise msec.error(f"inputs[{i}]", "expected [from, to, count] with an integer count "
                             f"from 1 to {MAX_MAP_POSES:,}, got {[float(a) for a in v]}")
        axes.append(np.linspace(v[0], v[1], int(v[2])))
    counts = [a.size for a in axes]
    if np.prod(counts, dtype=float) > MAX_MAP_POSES:
        raise msec.error("inputs", f"the map has {np.prod(counts, dtype=float):.3g} poses "
                                   f"({' × '.join(map(str, counts))}); at most "
                                   f"{MAX_MAP_POSES:,} fit one run: use fewer values per input")
    return np.array(np.meshgrid(*axes, indexing="ij")).reshape(n, -1).T


_W_ROWS = ["fx (N)", "fy (N)", "fz (N)", "mx (N·m)", "my (N·m)", "mz (N·m)"]
_D_COLS = ["δx (m)", "δy (m)", "δz (m)", "θx (rad)", "θy (rad)", "θz (rad)"]


def _matrix_table(M, rows, cols):
    df = pd.DataFrame(M, columns=cols)
    df.insert(0, "row", rows)
    return df


def _shown(M, w):
    """``M`` for display: entries below 1e-12 of the largest (in the units made comparable
    by the length weights ``w``) shown as 0 (rounding noise on rigid directions)."""
    Ms = np.abs(M * w[:, None] * w[None, :])
    return np.where(Ms > 1e-12 * Ms.max(), M, 0.0) if Ms.max() > 0 else M


def _rigid_words(C, n_rigid: int, L: float) -> str:
    """What the rigid directions are: the null space of C (displacements scaled by L)."""
    if n_rigid == 0:
        return ("no direction is held rigidly: every small motion of the platform deforms "
                "a spring")
    D = np.r_[np.full(3, 1 / L), np.ones(3)]
    Cs = C * D[:, None] * D[None, :]
    U, _, _ = np.linalg.svd(0.5 * (Cs + Cs.T))
    N = U[:, 6 - n_rigid:]                              # rigid directions (scaled)
    rot = float(np.linalg.norm(N[3:]) ** 2 / n_rigid)   # share of rotation in them
    what = ("the three rotations: the platform only translates" if n_rigid == 3 and rot > 1 - 1e-6
            else "the three translations" if n_rigid == 3 and rot < 1e-6 else
            f"{fmt_num(100 * rot, 3)} % rotation, {fmt_num(100 * (1 - rot), 3)} % "
            "translation: the constrained, parasitic motions")
    return (f"{n_rigid} direction{'s' if n_rigid != 1 else ''} held rigidly ({what}); the "
            "joints allow the platform no motion there that deforms a spring, so the links "
            "and passive joints (modelled rigid) carry any load in them: K is zero there "
            "(infinitely stiff) and so is C")


def mechanism_report(mech, pose, res, *, platform: str, springs: dict, locked, point,
                     link_springs=None, frame_name: str, wrench=None, loaded=None, map_inputs=None,
                     title: str = "Mechanism stiffness report", source: str = "",
                     progress=None, figures: bool = True):
    """The stiffness report of a mechanism's link at one solved pose (``linkwright
    stiffness`` with ``[mechanism]``).

    Parameters
    ----------
    mech : closure.Mechanism
    pose : closure.Pose, one pose
    res : MechanismStiffness at ``pose`` in the report's frame (unloaded)
    platform, springs, locked, point
        As in the study's ``[elastic]`` (``point``: world coordinates at assembly, m).
    link_springs : list of (link, joint, F, K, length) or None
        Elastic links (beams), as :func:`link_springs` gives them.
    frame_name : "platform" or "base"
    wrench : (6,) or None
        Load case about the base origin (N, N·m); ``loaded`` its loaded stiffness.
    map_inputs : (M, n_inputs) or None
        Input values of the map (m or rad).

    Returns
    -------
    (Report, dict of name → DataFrame, dict)
        The report, its CSV tables and the JSON summary (quantities with units).
    """
    from .mechspec import coordinate_unit
    K, C = res.K[0], res.C[0]
    R, p = res.R[0], res.reference[0]
    L = float(getattr(mech.tree, "scale", 1.0)) or 1.0
    ct, V = _directions(C[:3, :3])                      # ascending compliance
    cr, Vr = _directions(C[3:, 3:])
    cr = np.where(cr * L * L > 1e-9 * ct[2], cr, 0.0)   # rounding noise of rigid rotations
    n_rigid = int(res.rigid[0])
    cond = float(res.condition[0])
    axes_words = "platform axes" if frame_name == "platform" else "base axes"
    tiny = 1e-9 * max(ct[2], 1e-300)
    stiff = (f"stiffest along {_dir(V[:, 0])}: held rigidly (no translation that way deforms "
             "a spring)" if ct[0] <= tiny else
             f"stiffest along {_dir(V[:, 0])}: {fmt_q(ct[0], 'm/N')} "
             f"({fmt_q(1 / ct[0], 'N/m')}, {fmt_num(ct[2] / ct[0], 3)} times stiffer)")
    rep = Report(title)
    rep.findings(
        f"Weakest translation along {_dir(V[:, 2])}: a deflection of "
        f"{fmt_q(ct[2], 'm/N')} (a stiffness of {fmt_q(1 / ct[2], 'N/m')}); {stiff}; "
        f"directions in the {axes_words} about the reference point "
        f"{fmt_q(p, 'm')}.",
        (f"Rotational compliance up to {fmt_q(cr[2], 'rad/(N·m)')} (about {_dir(Vr[:, 2])})."
         if cr[2] * L * L > 1e-9 * ct[2] else
         "No rotation of the platform deforms a spring: the rotations are held rigidly."),
        _rigid_words(C, n_rigid, L)[0].upper() + _rigid_words(C, n_rigid, L)[1:] + ".",
        f"Loop condition {fmt_num(cond)} ({_health(cond)}; the condition number of the "
        "dimensionless loop Jacobian over the elastic and passive coordinates).")
    rep.text((source + " " if source else "") + f"{len(mech.links) - 1} moving links, "
             f"{len(mech.joints)} joints, {mech.n_loops} loops, mobility {mech.mobility}. "
             f"Platform link: {platform}. Wrench W = (f, m) in N, N·m; displacement "
             "Δ = (δ, θ) in m, rad. K is the unloaded stiffness over the compliant "
             "directions (the pseudo-inverse of C); C is the compliance Δ = C W.")
    labels = mech.input_labels()
    x = np.atleast_1d(np.asarray(pose.inputs, float)).ravel()
    iu = [coordinate_unit(mech, lab) for lab in labels]
    rep.heading("Pose and frame")
    rows = [(f"input {lab}", fmt_num(v, 6), u) for lab, v, u in zip(labels, x, iu)]
    rows += [("reference point of K (world coordinates)", fmt_list(p, 6), "m"),
             ("reference point on the platform (at assembly)", fmt_list(point, 6), "m"),
             ("axes of K, rows of R (r' = R (r − p))", fmt_list(R, 6), DIMENSIONLESS),
             ("loop condition", fmt_num(cond), DIMENSIONLESS),
             ("directions held rigidly", str(n_rigid), DIMENSIONLESS)]
    rep.table(pd.DataFrame(rows, columns=["quantity", "value", "unit"]))
    rep.heading("Joint coordinates")
    unit_of = {}
    beams = {f"{b[0]}@{b[1]}": b for b in link_springs or []}
    for lab in res.elastic:
        if lab in beams:
            Kb, Lb = beams[lab][3], beams[lab][4]
            unit_of[lab] = (f"beam of length {fmt_q(Lb, 'm')}: EA/L {fmt_q(Kb[0, 0], 'N/m')}, "
                            f"tip bending {fmt_q(1 / np.linalg.inv(Kb)[1, 1], 'N/m')} and "
                            f"{fmt_q(1 / np.linalg.inv(Kb)[2, 2], 'N/m')}, torsion "
                            f"{fmt_q(Kb[3, 3], 'N·m/rad')}",)
            continue
        key = lab if lab in springs else lab.split(".")[0]
        v = springs.get(key)
        if isinstance(v, list):
            names = [c for c in res.elastic if c.split(".")[0] == key]
            v = v[names.index(lab)] if len(v) == len(names) else v[0]
        unit_of[lab] = (v, "N/m" if coordinate_unit(mech, lab) == "m" else "N·m/rad")
    rep.table(pd.DataFrame(
        [("elastic", lab, unit_of[lab][0] if len(unit_of[lab]) == 1 else fmt_q(*unit_of[lab]))
         for lab in res.elastic] +
        [("locked", ", ".join(res.locked) or "none", "rigid")] +
        [("passive", ", ".join(res.passive) or "none", "free")],
        columns=["role", "coordinate", "stiffness"]), max_rows=None)
    rep.heading("Stiffness matrix K")
    rep.text("Rows: wrench components (f in N, m in N·m); columns: displacement components "
             "(δ in m, θ in rad); an entry's unit is its row's over its column's: N/m, N/rad, "
             "N·m/m = N, N·m/rad.")
    wK, wC = np.r_[np.full(3, L), np.ones(3)], np.r_[np.full(3, 1 / L), np.ones(3)]
    rep.table(_matrix_table(_shown(K, wK), _W_ROWS, _D_COLS), "{:.4e}")
    rep.heading("Compliance matrix C")
    rep.text("Rows: displacement components (δ in m, θ in rad); columns: wrench components "
             "(f in N, m in N·m): m/N, m/(N·m), rad/N, rad/(N·m).")
    rep.table(_matrix_table(_shown(C, wC), _D_COLS, _W_ROWS), "{:.4e}")
    tables = {"stiffness.csv": pd.DataFrame(K, columns=["dx", "dy", "dz", "tx", "ty", "tz"])
              .assign(row=["fx", "fy", "fz", "mx", "my", "mz"]),
              "compliance.csv": pd.DataFrame(C, columns=["fx", "fy", "fz", "mx", "my", "mz"])
              .assign(row=["dx", "dy", "dz", "tx", "ty", "tz"])}
    summary = {"command": "stiffness", "kind": "mechanism", "frame": frame_name,
               "platform": platform,
               "kt_weakest": quantity(1 / ct[2], "N/m"),
               "ct_max": quantity(ct[2], "m/N"),
               "weakest_direction": quantity(np.round(V[:, 2], 6) + 0.0, DIMENSIONLESS),
               "cr_max": quantity(cr[2], "rad/(N·m)"),
               "rigid_directions": n_rigid,
               "condition": quantity(cond, DIMENSIONLESS),
               "reference": quantity(p, "m")}
    if wrench is not None and loaded is not None:
        W = np.asarray(wrench, float)
        Wp = np.r_[R @ W[:3], R @ (W[3:] - np.cross(p, W[:3]))]   # about p, in the frame's axes
        d = C @ Wp
        Kl = loaded.K[0]
        change = float(np.abs(Kl - K).max() / np.abs(K).max())
        asym = float(np.abs(Kl - Kl.T).max() / np.abs(Kl).max())
        rep.heading("Load case (wrench about the base origin)")
        rep.text(f"W = f {fmt_q(W[:3], 'N')}, m {fmt_q(W[3:], 'N·m')} about the base origin; "
                 f"about the reference point in the {axes_words}: f {fmt_q(Wp[:3], 'N')}, "
                 f"m {fmt_q(Wp[3:], 'N·m')}. The loaded stiffness adds the geometric term of "
                 "the joint forces that carry the load (not symmetric in general)"
                 + ("; elastic links carry it through their deflection, and their axial "
                    "forces change their bending stiffness (P-δ)" if link_springs else "")
                 + "; the deflection is the linear one, Δ = C W.")
        rep.table(pd.DataFrame([("translation δ", fmt_list(d[:3]), "m"),
                                ("rotation θ", fmt_list(d[3:]), "rad")],
                               columns=["deflection of the reference point", "value", "unit"]))
        rep.heading("Loaded stiffness matrix", 3)
        rep.table(_matrix_table(_shown(Kl, wK), _W_ROWS, _D_COLS), "{:.4e}")
        rep.findings(f"Under the load case: deflection δ = {fmt_q(d[:3], 'm', 3)}, "
                     f"θ = {fmt_q(d[3:], 'rad', 3)} ({fmt_q(np.linalg.norm(d[:3]), 'm', 3)} in "
                     f"all); the load changes K by up to {fmt_num(100 * change, 3)} % of its "
                     f"largest entry (asymmetry {fmt_num(100 * asym, 3)} %).")
        tables["loaded_stiffness.csv"] = pd.DataFrame(
            Kl, columns=["dx", "dy", "dz", "tx", "ty", "tz"]).assign(
            row=["fx", "fy", "fz", "mx", "my", "mz"])
        summary["deflection_translation"] = quantity(d[:3], "m")
        summary["deflection_rotation"] = quantity(d[3:], "rad")
        summary["loaded_change"] = quantity(change, DIMENSIONLESS)
    if figures:
        rep.heading("Drawing")
        rep.drawing("mechanism", mechanism_scene_of(mech, pose, res, title), MECHANISM_CAPTION)
    if map_inputs is not None:
        from stiffness import mechanism_map
        if progress is not None:
            progress(f"stiffness map over {len(map_inputs)} poses")
        mpose = mech.solve(map_inputs, raise_on_failure=False)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            mp = mechanism_map(mech, mpose, platform=platform, springs=springs, locked=locked,
                               link_springs=link_springs,
                               point=point)
        tables["map.csv"] = mp
        _mechanism_map_section(rep, mp, labels, iu, figures)
        good = mp[mp.ok & ~mp.free]
        summary["map_poses"] = int(len(mp))
        summary["map_not_closed"] = int((~mp.ok).sum())
        summary["map_free"] = int(mp.free.sum())
        summary["map_ct_max"] = quantity(float(good.ct_max.max()) if len(good) else None, "m/N")
    return rep, tables, summary


#: the caption of a mechanism stiffness study's drawing (report and ``linkwright draw``)
MECHANISM_CAPTION = ("The mechanism at the pose, joints drawn from the engine's joint "
                     "frames; arrows at K's reference point along the weakest (red) and "
                     "stiffest (green) translation directions.")


def mechanism_scene_of(mech, pose, res, title: str):
    """The drawing of a mechanism at its (one) pose with the weakest and stiffest
    translation directions of ``res`` (unloaded) as arrows at K's reference point, a third
    of the drawing's size long, in the base axes."""
    from .draw import scene
    _, V = _directions(res.C[0][:3, :3])                # ascending compliance
    R, p = res.R[0], res.reference[0]
    scn = scene(mech, pose, title=f"{title} at the pose")
    A = 0.3 * scn.size()
    scn.arrows = {name: (np.stack([p, A * (R.T @ v)])[None], col) for name, v, col in
                  (("weakest", V[:, 2], "#d62728"), ("stiffest", V[:, 0], "#2ca02c"))}
    return scn


def _mechanism_map_section(rep, mp, labels, iu, figures=True):
    units = {"ct_max": "m/N", "cr_max": "rad/(N·m)", "condition": DIMENSIONLESS}
    vary = [lab for lab in labels if mp[lab].nunique() > 1]
    good = mp[mp.ok & ~mp.free]
    rep.heading("Map over the inputs")
    rep.text(f"{len(mp)} poses; varying: {', '.join(vary) or 'nothing (one pose)'}; indices "
             f"about the reference point on the platform, in its axes; "
             f"{int((~mp.ok).sum())} poses do not close, {int(mp.free.sum())} have a free "
             "motion (infinite compliance).")
    rep.table(pd.DataFrame([(col, float(good[col].min()) if len(good) else np.nan,
                             float(good[col].max()) if len(good) else np.nan, units[col])
                            for col in units], columns=["index", "min", "max", "unit"]), "{:.5g}")
    rep.table(mp, "{:.5g}", units={**{lab: u for lab, u in zip(labels, iu)},
                                   "x": "m", "y": "m", "z": "m", "rigid": DIMENSIONLESS,
                                   **units})
    if len(good):
        i = good.ct_max.idxmax()
        at = ", ".join(f"{lab} = {fmt_q(mp.loc[i, lab], u)}" for lab, u in zip(labels, iu))
        rep.findings(f"Over the map ({len(mp)} poses): largest translational compliance "
                     f"{fmt_q(good.ct_max.min(), 'm/N')} to {fmt_q(good.ct_max.max(), 'm/N')} "
                     f"(the weakest at {at}); {int((~mp.ok).sum())} poses do not close, "
                     f"{int(mp.free.sum())} with a free motion.")
    if not vary or not figures or not len(good):
        return
    from .render import heat_map
    cols = {}
    for lab, u in zip(labels, iu):
        name = f"{lab} ({'deg' if u == 'rad' else u})"
        cols[lab] = name
    df = pd.DataFrame({cols[lab]: np.degrees(mp[lab]) if u == "rad" else mp[lab]
                       for lab, u in zip(labels, iu)})
    df["ct_max"] = mp.ct_max.where(mp.ok & ~mp.free)
    sl, fixed = df, ""
    if len(vary) > 2:
        third = cols[vary[2]]
        sl = df[df[third] == df[third].iloc[0]]
        fixed = f", {third} = {fmt_num(sl[third].iloc[0])}"
    held = [f"{lab} = {fmt_num(sl[cols[lab]].iloc[0])} {'deg' if u == 'rad' else u}"
            for lab, u in zip(labels, iu) if lab not in vary]
    held = f"\n({', '.join(held)})" if held else ""
    rep.figure("map.png", lambda ax: heat_map(
        ax, sl, "ct_max", cols[vary[0]], cols[vary[1]] if len(vary) > 1 else None, "m/N",
        title=f"largest translational compliance{fixed}{held}"))
