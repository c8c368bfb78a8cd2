"""``linkwright analyze``: a mechanism and an input range → the sweep table (joint values,
point paths, analogs) and, with masses, the drive forces."""
from __future__ import annotations

import numpy as np
import pandas as pd

from closure import ClosureError, point_analogs

from .mechspec import build_dynamics, build_mechanism, sweep_values
from .output import Outputs, Report
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
    ok = df.status == "ok"
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
    rep = Report("Mechanism analysis")
    rep.text(f"Study: {study.path.name}. {len(mech.links)} links, {len(mech.joints)} joints, "
             f"{mech.n_loops} loops, mobility {mech.mobility}; {int(ok.sum())} of {len(df)} "
             f"poses closed; largest residual {df.residual.max():.2e}, largest condition "
             f"{df.condition.max():.3g}.")
    bad = df[~ok]
    if len(bad):
        rep.text(f"The sweep stopped: {bad.status.iloc[0]} near input "
                 f"{bad.filter(like='reached').iloc[0].iloc[0] if bad.filter(like='reached').size else '?'}.")
    rep.heading("Sweep (joint values: rad or m; analogs per unit input)")
    rep.table(table[[f"input:{lab}"] + mech.coordinate_labels() + ["residual", "condition",
                                                                      "status"]])

    def plot_joints(ax):
        for c in mech.coordinate_labels():
            ax.plot(table[f"input:{lab}"][ok], table[c][ok], label=c)
        ax.set_xlabel(f"input {lab}")
        ax.legend(fontsize=7)
    rep.figure("joints.png", plot_joints)
    summary = {"command": "analyze", "poses": int(len(df)), "closed": int(ok.sum()),
               "max_residual": float(df.residual.max()), "max_condition": float(df.condition.max())}
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
        rep.heading(f"Drive force for the motion {a:.4g} → {b:.4g} in {T} s "
                    "(x = a + (b − a)(t/T − sin(2πt/T)/2π))")
        rep.table(inv[["t", lab, f"drive:{lab}", "residual"]])

        def plot_drive(ax):
            ax.plot(inv.t, inv[f"drive:{lab}"])
            ax.set_xlabel("t (s)")
            ax.set_ylabel(f"drive {lab} (N or N·m)")
        rep.figure("drive.png", plot_drive)
        summary["max_drive"] = float(np.abs(inv[f"drive:{lab}"]).max())
    rep.add_to(out)
    return summary
