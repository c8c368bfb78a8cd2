"""``linkwright analyze``: a mechanism and an input range → the sweep table (joint values,
point paths, analogs) and, with masses, the drive forces."""
from __future__ import annotations

import numpy as np
import pandas as pd

from closure import REACHED, ClosureError, point_analogs

from .mechspec import (build_dynamics, build_mechanism, coordinate_unit, joint_frames,
                       sweep_values)
from .output import Outputs
from .render import DIMENSIONLESS, Report, fmt_num, fmt_q, quantity
from .study import Study


def run(study: Study, out: Outputs, progress) -> dict:
    mech = build_mechanism(study.section("mechanism"))
    x = sweep_values(study.section("sweep"), mech)
    progress(f"sweeping {len(x)} input values")
    df, poses = mech.sweep(x, return_pose=True)
    first, second = mech.analogs(poses) if len(poses) else (None, None)
    vel = pd.DataFrame(first[:, :, 0], columns=[f"d:{c}" for c in mech.velocity_labels()]) \
        if len(poses) else pd.DataFrame()
    acc = pd.DataFrame(second[:, :, 0, 0], columns=[f"dd:{c}" for c in mech.velocity_labels()]) \
        if len(poses) else pd.DataFrame()
    ok = df.status.isin(REACHED)          # the rows with a pose (ok or near-singular)
    table = df.copy()
    for frame in (vel, acc):
        for c in frame.columns:
            table.loc[ok, c] = frame[c].to_numpy()
    points = study.sections("point", required=False)
    for p in points:
        name, link = p.get("name", "str"), p.get("link", "str")
        if link not in mech.links:
            raise p.error("link", f"unknown link {link!r}; links: {', '.join(mech.links)}")
        if len(poses):
            xyz, d1, d2 = point_analogs(mech, poses, link, p.get("at", "vec3"))
            for k, ax in enumerate("xyz"):
                table.loc[ok, f"{name}.{ax}"] = xyz[:, k]
                table.loc[ok, f"{name}.d{ax}"] = d1[:, k, 0]
                table.loc[ok, f"{name}.dd{ax}"] = d2[:, k, 0, 0]
    out.add_csv("sweep.csv", table)
    lab = mech.input_labels()[0]
    iu = coordinate_unit(mech, lab)
    coords = mech.coordinate_labels()
    cu = {c: coordinate_unit(mech, c) for c in coords}
    rep = Report("Mechanism analysis")

    def span(values, unit):
        v = np.asarray(values, float)
        v = v[np.isfinite(v)]
        if not v.size:
            return "none"
        v = np.where(np.abs(v) <= 1e-9 * max(1.0, float(np.abs(v).max())), 0.0, v)
        if unit == "rad":
            return f"{fmt_num(np.degrees(v.min()))} to {fmt_num(np.degrees(v.max()))} deg"
        return f"{fmt_num(v.min())} to {fmt_num(v.max())} {unit}"
    xin = table[f"input:{lab}"][ok]
    statuses = df.status.value_counts()
    bad = df[~ok]
    moved = [c for c in coords if np.ptp(table[c][ok].to_numpy(float)) > 1e-9] if ok.any() else []
    dead = ""
    if len(bad):
        reached = bad.filter(like="reached")
        where = (f" near input {fmt_q(reached.iloc[0].iloc[0], iu)}" if reached.size and
                 np.isfinite(reached.iloc[0].iloc[0]) else "")
        dead = f"the sweep stopped: {bad.status.iloc[0]}{where}"
    rep.findings(
        f"Range of motion: input {lab} {span(xin, iu)} ({int(ok.sum())} of {len(df)} poses "
        f"closed); " + "; ".join(f"{c} {span(table[c][ok], cu[c])}" for c in moved[:8])
        + (f"; and {len(moved) - 8} more coordinates" if len(moved) > 8 else "") + ".",
        "Dead points met: " + (dead if dead else "none") + " (statuses: " +
        ", ".join(f"{k}: {int(v)}" for k, v in statuses.items()) + ").",
        f"Largest condition number of the loop equations: {fmt_num(df.condition.max())} "
        f"(large near a singular pose); largest closure residual {fmt_num(df.residual.max(), 2)}.")
    rep.text(f"Study: {study.path.name}. {len(mech.links)} links, {len(mech.joints)} joints, "
             f"{mech.n_loops} loops, mobility {mech.mobility}. Joint angles in rad, slides in m "
             "(plotted in deg and m).")
    rep.heading("Sweep")
    units = {f"input:{lab}": iu, **cu, "residual": DIMENSIONLESS, "condition": DIMENSIONLESS}
    rep.table(table[[f"input:{lab}"] + coords + ["residual", "condition", "status"]],
              units=units)
    ang = [c for c in coords if cu[c] == "rad"]
    lin = [c for c in coords if cu[c] == "m"]
    xplot = np.degrees(xin) if iu == "rad" else xin
    xlabel = f"input {lab} ({'deg' if iu == 'rad' else 'm'})"
    panels = [(cs, u) for cs, u in ((ang, "deg"), (lin, "m")) if cs]
    if panels:
        def plot_joints(axes):
            axes = np.atleast_1d(axes)
            for ax, (cs, u) in zip(axes, panels):
                for c in cs:
                    y = table[c][ok].to_numpy(float)
                    ax.plot(xplot, np.degrees(y) if u == "deg" else y, label=c)
                ax.set_ylabel(f"joint {'angles' if u == 'deg' else 'slides'} ({u})")
                ax.set_xlabel(xlabel)
                ax.legend(fontsize=7, ncol=2)
        rep.figure("joints.png", plot_joints, nrows=len(panels))
    if ok.any():
        from .cmd_draw import FRAMES, analyze_scene
        rep.heading("Drawing")
        rep.drawing("mechanism", analyze_scene(study, mech, poses)[2],
                    f"The mechanism at the sweep's closed poses (up to six drawn, earlier ones "
                    f"fainter; the interactive view has at most {FRAMES} of them), joints "
                    "drawn from the engine's joint frames, point paths dashed.",
                    frames=FRAMES)
    summary = {"command": "analyze", "poses": int(len(df)), "closed": int(ok.sum()),
               "input_range": quantity([float(xin.min()), float(xin.max())] if ok.any()
                                       else [], iu),
               "dead_point": dead or None,
               "statuses": {str(k): int(v) for k, v in statuses.items()},
               "max_residual": quantity(float(df.residual.max()), DIMENSIONLESS),
               "max_condition": quantity(float(df.condition.max()), DIMENSIONLESS)}
    if points and ok.any():
        rep.heading("Point paths")
        rows = []
        for p in points:
            name = p.get("name", "str")
            P = table.loc[ok, [f"{name}.x", f"{name}.y", f"{name}.z"]].to_numpy(float)
            rows.append({"point": name, "link": p.get("link", "str"),
                         "x min": P[:, 0].min(), "x max": P[:, 0].max(),
                         "y min": P[:, 1].min(), "y max": P[:, 1].max(),
                         "z min": P[:, 2].min(), "z max": P[:, 2].max(),
                         "path length": float(np.linalg.norm(np.diff(P, axis=0), axis=1).sum())})
        rep.table(pd.DataFrame(rows), "{:.5g}", units={k: "m" for k in rows[0]
                                                       if k not in ("point", "link")})

        def plot_points(axes):
            ax1, ax2 = axes
            paths = {p.get("name", "str"): table.loc[ok, [f"{p.get('name', 'str')}.{c}"
                                                          for c in "xyz"]].to_numpy(float)
                     for p in points}
            spread = np.max([np.ptp(P, axis=0) for P in paths.values()], axis=0)
            i, j = sorted(int(k) for k in np.argsort(spread)[::-1][:2])
            for name, P in paths.items():
                ax1.plot(P[:, i], P[:, j], label=name)
                for k in range(3):
                    ax2.plot(xplot, P[:, k], label=f"{name}.{'xyz'[k]}")
            ax1.set_xlabel(f"{'xyz'[i]} (m)")
            ax1.set_ylabel(f"{'xyz'[j]} (m)")
            ax1.set_aspect("equal", adjustable="datalim")
            ax1.set_title("point paths")
            ax1.legend(fontsize=7)
            ax2.set_xlabel(xlabel)
            ax2.set_ylabel("point coordinates (m)")
            ax2.legend(fontsize=7, ncol=3)
        rep.figure("points.png", plot_points, nrows=2)
        summary["points"] = [r["point"] for r in rows]
    dsec = study.section("dynamics", required=False)
    if dsec is not None:
        d = build_dynamics(dsec, mech)
        T = dsec.get("duration", low=1e-9)
        t = np.linspace(0, T, len(x))
        a, b = x[0], x[-1]
        s = t / T
        law = (a + (b - a) * (s - np.sin(2 * np.pi * s) / (2 * np.pi)),
               (b - a) * (1 - np.cos(2 * np.pi * s)) / T,
               (b - a) * 2 * np.pi * np.sin(2 * np.pi * s) / T ** 2)
        progress("inverse dynamics along the sweep")
        try:
            inv = d.inverse(t, *(v[:, None] for v in law))
        except ClosureError as e:
            raise dsec.error("duration", f"the motion cannot be followed: {e}") from None
        out.add_csv("drive.csv", inv)
        du = "N·m" if iu == "rad" else "N"
        rep.heading("Drive force for the motion x = a + (b − a)(t/T − sin(2πt/T)/2π)")
        rep.text(f"From a = {fmt_q(a, iu)} to b = {fmt_q(b, iu)} in T = {fmt_q(T, 's')}.")
        rep.table(inv[["t", lab, f"drive:{lab}", "residual"]],
                  units={"t": "s", lab: iu, f"drive:{lab}": du, "residual": DIMENSIONLESS})
        peak = float(np.abs(inv[f"drive:{lab}"]).max())
        rep.findings(f"Drive {'torque' if iu == 'rad' else 'force'} for the motion in "
                     f"{fmt_q(T, 's')}: peak {fmt_q(peak, du)}.")

        def plot_drive(ax):
            ax.plot(inv.t, inv[f"drive:{lab}"])
            ax.set_xlabel("t (s)")
            ax.set_ylabel(f"drive {lab} ({du})")
        rep.figure("drive.png", plot_drive)
        summary["max_drive"] = quantity(peak, du)
        tsec = study.section("tolerance", required=False)
        if tsec is not None:
            summary.update(_drive_tolerance(study, tsec, t, law, du, rep, out, progress))
    rep.add_to(out)
    return summary


def _drive_tolerance(study: Study, tsec, t, law, du: str, rep: Report, out: Outputs,
                     progress) -> dict:
    """``[tolerance]``: the drive force of made mechanisms (:func:`closure.tolerance.
    drive_tolerance`) — a report section, ``drive_tolerance.csv`` and the summary's
    figures."""
    from closure.tolerance import drive_tolerance
    ms, ds = study.section("mechanism"), study.section("dynamics")
    frames, kinds = joint_frames(ms)
    sd = np.radians(tsec.get("direction_sigma_deg", "float", 0.0))
    sp = tsec.get("position_sigma", "float", 0.0)
    n = tsec.get("samples", "int", 1000)
    progress(f"drive-force tolerances: {n} made mechanisms")
    r = drive_tolerance(lambda fr: build_dynamics(ds, build_mechanism(ms, fr)), frames, kinds,
                        t, tuple(v[:, None] for v in law), direction_sigma=sd,
                        position_sigma=sp, samples=n, seed=tsec.get("seed", "int", 0))
    out.add_csv("drive_tolerance.csv", r.summary)
    rep.heading("Drive force tolerances")
    rep.text(f"{n} mechanisms made with every joint frame tilted about its X and Y axes "
             f"(σ = {fmt_q(np.degrees(sd), 'deg')} each) and shifted along them "
             f"(σ = {fmt_q(sp, 'm')} each; a P joint tilted only, an S joint shifted along "
             "X, Y, Z), driven through the same motion by the engine. 'linear': the "
             "first-order changes J δp of the same samples (J = ∂F/∂p by central "
             "differences of the engine); 'predicted': sqrt(diag(J Σ Jᵀ)).")
    moved = n - r.failed
    if r.failed:
        rep.findings(f"{r.failed} of {n} made mechanisms cannot follow the motion"
                     + (f" (the design is over-constrained: {', '.join(r.rigid[:6])}"
                        f"{' …' if len(r.rigid) > 6 else ''} alone stop it)" if r.rigid else "")
                     + ".")
    figures = {"drive_tolerance_failed": r.failed}
    if moved > 1:
        pk = r.peak.iloc[0]
        worst = r.summary.loc[r.summary.sd.idxmax()]
        rep.findings(f"Peak drive {'torque' if du == 'N·m' else 'force'} "
                     f"{fmt_q(pk.design, du)} by design; made: mean {fmt_q(pk['mean'], du)}, "
                     f"sd {fmt_q(pk.sd, du)} (first order: {fmt_q(pk.mean_linear, du)}, "
                     f"{fmt_q(pk.sd_linear, du)}); the drive varies most at t = "
                     f"{fmt_q(worst.t, 's')} (sd {fmt_q(worst.sd, du)}, predicted "
                     f"{fmt_q(worst.sd_predicted, du)}).")
        show = r.summary.iloc[np.unique(np.linspace(0, len(r.summary) - 1, 25).astype(int))]
        rep.table(show, "{:.5g}", units={"t": "s", "drive": du, "mean": du, "sd": du,
                                         "mean_linear": du, "sd_linear": du,
                                         "sd_predicted": du})
        figures.update(peak_drive_sd=quantity(float(pk.sd), du),
                       peak_drive_sd_linear=quantity(float(pk.sd_linear), du))
    return figures
