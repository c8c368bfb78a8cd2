"""Stiffness reports: Markdown and CSV, written atomically."""
from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pandas as pd

from .errors import StiffnessError
from .matrices import stiffness_indices
from .validate import as_array

__all__ = ["report", "write_atomic"]


@contextmanager
def _atomic_target(path):
    """Yield a temporary path beside ``path``; on success it replaces ``path`` atomically,
    on any error (or Ctrl-C) it is removed and ``path`` is left untouched."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=path.suffix)
    os.close(fd)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def write_atomic(path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and ``os.replace``."""
    with _atomic_target(path) as tmp, open(tmp, "w", encoding="utf-8") as f:
        f.write(text)


def _save_figure(fig, path) -> None:
    """Save a matplotlib figure atomically."""
    with _atomic_target(path) as tmp:
        fig.savefig(tmp)


def _fmt_value(v) -> str:
    """An index value as text: arrays to five digits, numbers to five significant ones."""
    return np.array2string(v, precision=5) if isinstance(v, np.ndarray) else f"{v:.5g}"


def _matrix_md(M, fmt="{: .4e}"):
    rows = ["| " + " | ".join(fmt.format(v) for v in row) + " |" for row in M]
    head = "| " + " | ".join(["δx", "δy", "δz", "θx", "θy", "θz"][:M.shape[1]]) + " |"
    return "\n".join([head, "|" + "---|" * M.shape[1]] + rows)


def report(hexapod, pose, *, frame=None, wrench=None, positions=None, rotations=None,
           path=None, title: str = "Stiffness report") -> str:
    """A Markdown stiffness report (and CSV files beside it when ``path`` is given).

    Contents: the pose, the reference frame, K and its blocks with units, the
    indices (translational eigenvalues N/m, rotational compliance eigenvalues
    rad/(N·m), frame-invariant screw eigenvalues N, cond(P)), leg forces and
    the deflection under ``wrench`` (about the base origin), and the map over
    ``positions`` × ``rotations`` when given.

    Returns
    -------
    str : the Markdown text.

    Raises
    ------
    StiffnessError
        Bad input, naming the argument (``SingularPoseError`` at a singular pose
        with a load case).
    """
    from .hexapod import Hexapod
    if not isinstance(hexapod, Hexapod):
        raise StiffnessError(f"hexapod: expected a Hexapod, got {type(hexapod).__name__}")
    T = hexapod._pose(pose)
    if T.ndim != 2:
        raise StiffnessError(f"pose: a report takes one pose (4, 4), got shape {T.shape}")
    res = hexapod.stiffness(T, frame=frame)
    K = res.K
    lines = [f"# {title}", "",
             "Conventions: wrench W = (f, m) in N, N·m; displacement Δ = (δ, θ) in m, rad "
             "(seed 003); K is the unloaded (congruence) stiffness P Kθ Pᵀ.", "",
             "## Pose and frame", "",
             f"- platform origin in the base frame: {np.array2string(T[:3, 3], precision=6)} m",
             f"- platform rotation:\n\n```\n{np.array2string(T[:3, :3], precision=6)}\n```",
             f"- reference point (origin of K's frame), base coordinates: "
             f"{np.array2string(np.asarray(res.reference), precision=6)} m",
             f"- frame axes R (r' = R (r − p)):\n\n```\n{np.array2string(res.R, precision=6)}\n```",
             f"- cond(P) (moments about the platform centroid / platform radius "
             f"{hexapod.radius:.4g} m): {res.cond_P:.4g}",
             "", "## Stiffness matrix K", "",
             "Blocks: translational K_n (N/m), coupling K_c (N/rad), torsional K_k (N·m/rad).", "",
             _matrix_md(K), "",
             "## Indices", "",
             "| index | values | unit |", "|---|---|---|"]
    lines += [f"| {row.index} | {_fmt_value(row.value)} | {row.unit} |"
              for row in stiffness_indices(K).itertuples()]
    lines.append("")
    csv = {"stiffness.csv": pd.DataFrame(K, columns=["dx", "dy", "dz", "tx", "ty", "tz"],
                                         index=["fx", "fy", "fz", "mx", "my", "mz"])}
    if wrench is not None:
        W = as_array(wrench, "wrench", (6,), ndim=1, what="a wrench (f, m) of shape (6,)")
        tau = hexapod.leg_forces(T, W)
        d = hexapod.deflection(T, W)
        lines += ["## Load case", "",
                  f"External wrench about the base origin W = {np.array2string(W, precision=5)} "
                  "(N, N·m).", "",
                  "| leg | force (N, tension +) |", "|---|---|"]
        lines += [f"| {i + 1} | {v:.5g} |" for i, v in enumerate(tau)]
        lines += ["", f"Deflection Δ = C W about the base origin: δ = "
                  f"{np.array2string(d[:3], precision=5)} m, θ = "
                  f"{np.array2string(d[3:], precision=5)} rad.", ""]
        csv["leg_forces.csv"] = pd.DataFrame({"leg": np.arange(1, tau.size + 1), "force_N": tau})
    if positions is not None:
        mp = hexapod.map(positions, rotations)
        lines += ["## Map", "", f"{len(mp)} poses (the indices do not depend on the reference point).", "",
                  "| index | min | max |", "|---|---|---|"]
        for col in ["kt_min", "kt_max", "cr_max", "cond_P"]:
            lines.append(f"| {col} ({mp.attrs['units'].get(col, '-')}) | "
                         f"{mp[col].min():.5g} | {mp[col].max():.5g} |")
        lines += ["", f"singular poses (cond(P) > {hexapod.singular_cond:.0e}): "
                  f"{int(mp.singular.sum())}", ""]
        csv["map.csv"] = mp
        if path is not None:
            try:
                from .plot import plot_map
                png = Path(path).with_name(f"{Path(path).stem}_map.png")
                plot_map(mp[mp.z == mp.z.iloc[0]] if mp.z.nunique() > 1 else mp, "kt_min",
                         path=png)
                lines += [f"![kt_min map]({png.name})", ""]
            except ImportError:
                lines += ["(plots need the `plot` extra: pip install 'linkwright[plot]')", ""]
    text = "\n".join(lines)
    if path is not None:
        path = Path(path)
        for name, df in csv.items():
            write_atomic(path.parent / f"{path.stem}_{name}", df.to_csv())
        write_atomic(path, text)
    return text
