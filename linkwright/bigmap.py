"""Hexapod stiffness maps too large for one process: the pose grid cut into blocks of flat
indices, each block one task (on Dask, or in-process with ``serial=True``) that builds its
own poses from the grid axes, computes :meth:`stiffness.Hexapod.map`, writes its rows as
one Parquet part (atomically: a stopped run resumes from the parts it finds) and returns
a small summary.  The summaries merge into exact counts, minima and maxima, the worst
poses, and quantiles from fixed logarithmic histograms (1,000 bins per index over the
index's decades: a quantile is exact to one bin, a factor 10^(1/100) ≈ 2.3 %).

Memory stays bounded by the block: a task holds its block's poses and rows only (about
110 bytes per pose in the table, a few times that while computing), so ``block =
200_000`` keeps a worker well under 1 GB whatever the map's size.
"""
from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from .render import DIMENSIONLESS

__all__ = ["MapSummary", "StudyMap", "stiffness_map", "map_from_study", "INDICES", "UNITS"]

#: the map's indices summarised, and their histogram ranges (log10 of the value)
INDICES = {"kt_min": (-2.0, 18.0), "kt_max": (-2.0, 18.0), "cr_max": (-18.0, 2.0),
           "cond_P": (0.0, 20.0)}
#: the units of the map's indices (a stiffness study's map section, in memory or blocked)
UNITS = {"kt_min": "N/m", "kt_max": "N/m", "cr_max": "rad/(N·m)", "cond_P": DIMENSIONLESS}
_BINS = 1000
_WORST = 10
_PART = "part-{:06d}.parquet"
_PART_RE = re.compile(r"^part-(\d{6})\.json$")


@dataclass
class MapSummary:
    """The summary of a blocked map.

    Attributes
    ----------
    poses, singular : int
        Poses computed and singular ones (cond(P) above the hexapod's limit).
    quantiles : pandas.DataFrame
        Per index (rows): ``min``, ``q01``, ``q05``, ``q50``, ``q95``, ``q99``, ``max``
        (min and max exact, quantiles to one histogram bin: 2.3 %).
    worst : pandas.DataFrame
        The poses of lowest ``kt_min`` (up to 10), with every index.
    blocks : int
        Blocks computed in this run (the others were found finished).
    """

    poses: int
    singular: int
    quantiles: pd.DataFrame
    worst: pd.DataFrame
    blocks: int


def _block_task(hx, axes, rotation, start, stop, folder, index):
    """One block: its poses from the flat indices, the map, the part file, the summary."""
    nx, ny, nz = (len(a) for a in axes)
    i, j, k = np.unravel_index(np.arange(start, stop), (nx, ny, nz))
    P = np.column_stack([axes[0][i], axes[1][j], axes[2][k]])
    mp = hx.map(P, np.asarray(rotation, float).reshape(1, 3))
    summ = {"n": int(len(mp)), "singular": int(mp.singular.sum()), "index": index}
    for col, (lo, hi) in INDICES.items():
        v = mp[col].to_numpy(float)
        ok = np.isfinite(v) & (v > 0)
        h, _ = np.histogram(np.log10(np.clip(v[ok], 10 ** lo, 10 ** hi)), bins=_BINS,
                            range=(lo, hi))
        summ[col] = {"min": float(v[ok].min()) if ok.any() else None,
                     "max": float(v[ok].max()) if ok.any() else None, "hist": h.tolist()}
    summ["worst"] = mp.nsmallest(_WORST, "kt_min").to_dict("records")
    if folder is not None:
        from .atomic import write_new_file
        import io
        buf = io.BytesIO()
        mp.to_parquet(buf, index=False, engine="pyarrow")
        try:
            write_new_file(Path(folder) / _PART.format(index), buf.getvalue())
            write_new_file(Path(folder) / f"part-{index:06d}.json", json.dumps(summ).encode())
        except FileExistsError:             # a retried task: the same block
            pass
    return summ


def _merge(summaries) -> tuple[int, int, pd.DataFrame, pd.DataFrame]:
    n = sum(s["n"] for s in summaries)
    sing = sum(s["singular"] for s in summaries)
    rows = []
    for col, (lo, hi) in INDICES.items():
        h = np.sum([s[col]["hist"] for s in summaries], axis=0).astype(float)
        mins = [s[col]["min"] for s in summaries if s[col]["min"] is not None]
        maxs = [s[col]["max"] for s in summaries if s[col]["max"] is not None]
        edges = np.linspace(lo, hi, _BINS + 1)
        c = np.cumsum(h)
        r = {"index": col, "min": min(mins) if mins else np.nan}
        for q in (0.01, 0.05, 0.5, 0.95, 0.99):
            if c[-1] == 0:
                r[f"q{int(q * 100):02d}"] = np.nan
                continue
            b = int(np.searchsorted(c, q * c[-1]))
            prev = c[b - 1] if b else 0.0
            f = (q * c[-1] - prev) / max(h[b], 1.0)
            r[f"q{int(q * 100):02d}"] = float(10 ** (edges[b] + f * (edges[b + 1] - edges[b])))
        r["max"] = max(maxs) if maxs else np.nan
        for q in ("q01", "q05", "q50", "q95", "q99"):       # a bin may reach past the ends
            r[q] = float(np.clip(r[q], r["min"], r["max"])) if np.isfinite(r[q]) else r[q]
        rows.append(r)
    worst = pd.DataFrame([w for s in summaries for w in s["worst"]])
    if len(worst):
        worst = worst.nsmallest(_WORST, "kt_min").reset_index(drop=True)
    return n, sing, pd.DataFrame(rows), worst


def stiffness_map(hx, xs, ys, zs, rotation=(0.0, 0.0, 0.0), *, out=None, client=None,
                  serial: bool = False, block: int = 200_000, resume: bool = False,
                  progress=None) -> MapSummary:
    """The stiffness map of ``hx`` over the grid ``xs × ys × zs`` (m) at one platform
    rotation (rotation vector, rad), in blocks (module notes).

    Parameters
    ----------
    hx : stiffness.Hexapod
    xs, ys, zs : array_like (n,)
        The grid axes (m).
    rotation : array_like (3,)
        The platform's rotation vector (rad).
    out : path-like, optional
        Folder for the parts (``part-NNNNNN.parquet`` and its summary ``.json``); without
        it only the summary is kept.
    client : distributed.Client, optional
        Where the blocks run (default: the scheduler at ``DASK_SCHEDULER_ADDRESS``, else a
        LocalCluster sized to the machine; unless ``serial``).
    serial : bool
        Run the blocks in this process.
    block : int
        Poses per block (≥ 1,000).
    resume : bool
        Keep the blocks already in ``out``.

    Returns
    -------
    MapSummary
    """
    axes = [np.atleast_1d(np.asarray(a, float)) for a in (xs, ys, zs)]
    for name, a in zip("xyz", axes):
        if a.ndim != 1 or not len(a) or not np.all(np.isfinite(a)):
            raise ValueError(f"{name}s: expected a non-empty 1-D array of finite positions (m)")
    rot = np.asarray(rotation, float)
    if rot.shape != (3,) or not np.all(np.isfinite(rot)):
        raise ValueError(f"rotation: expected a finite rotation vector (3,), got {rotation!r}")
    if int(block) != block or block < 1000:
        raise ValueError(f"block: expected an integer ≥ 1000, got {block!r}")
    n = int(np.prod([len(a) for a in axes]))
    starts = list(range(0, n, int(block)))
    folder = None if out is None else Path(out)
    done = {}
    if folder is not None:
        from .distributed import _need
        _need("pyarrow")
        folder.mkdir(parents=True, exist_ok=True)
        found = [m for f in os.listdir(folder) if (m := _PART_RE.match(f))]
        if found and not resume:
            raise FileExistsError(f"{folder}: holds map parts already; resume=True finishes "
                                  "that run, or give a new folder")
        for m in found:
            done[int(m.group(1))] = json.loads((folder / m.group(0)).read_text())
    todo = [b for b in range(len(starts)) if b not in done]
    args = [(hx, axes, rot, starts[b], min(starts[b] + int(block), n),
             None if folder is None else str(folder), b) for b in todo]
    bar = progress.bar(total=n, desc="stiffness map", unit="pose") \
        if hasattr(progress, "bar") else None
    results = list(done.values())
    try:
        if serial:
            for a in args:
                results.append(_block_task(*a))
                if bar is not None:
                    bar.update(results[-1]["n"])
        else:
            from .distributed import dask_client
            with dask_client(client) as (client, distributed):
                futs = [client.submit(_block_task, *a, pure=False) for a in args]
                for f in distributed.as_completed(futs):
                    results.append(f.result())
                    if bar is not None:
                        bar.update(results[-1]["n"])
    finally:
        if bar is not None:
            bar.close()
    poses, sing, q, worst = _merge(results)
    return MapSummary(poses, sing, q, worst, len(todo))


@dataclass
class StudyMap:
    """A blocked map run for a stiffness study (:func:`map_from_study`): its summary and
    how it ran, and :meth:`report` for the study's report."""

    summary: MapSummary
    counts: tuple
    rotation: np.ndarray          #: rotation vector of the platform (rad)
    block: int
    where: str
    parts: str | None
    singular_cond: float

    def report(self, rep, tables: dict) -> dict:
        """Add the map's section to ``rep`` and its tables (``map_quantiles.csv``,
        ``map_worst.csv``) to ``tables``; return the JSON summary's map entries."""
        from .render import fmt_num, fmt_q, quantity
        s = self.summary
        q = s.quantiles.copy()
        q.insert(1, "unit", [UNITS[i] for i in q["index"]])
        kt = q.set_index("index").loc["kt_min"]
        rep.heading("Map over poses (in blocks)")
        total = -(-s.poses // self.block)
        ran = f"{s.blocks} of them in this run, the others" if s.blocks < total else ""
        rows = f"in {self.parts}, one Parquet part per block" if self.parts else "not kept"
        rep.text(f"{s.poses:,} poses ({' × '.join(map(str, self.counts))} positions in x, y, "
                 f"z) at the platform rotation vector {fmt_q(np.degrees(self.rotation), 'deg')}, "
                 f"computed {self.where} in {total} blocks of up to {self.block:,} poses"
                 + (f" ({ran} found in the parts)" if ran else "") + f"; rows {rows}. "
                 "Minima and maxima are exact; the quantiles come from logarithmic "
                 "histograms of 1,000 bins per index (exact to one bin, 2.3 %).")
        rep.table(q, "{:.5g}")
        rep.findings(f"Over the map ({s.poses:,} poses): kt_min from {fmt_q(kt['min'], 'N/m')} "
                     f"to {fmt_q(kt['max'], 'N/m')}, median {fmt_q(kt['q50'], 'N/m')}; "
                     f"{s.singular:,} singular poses (cond(P) > {fmt_num(self.singular_cond)}).")
        if len(s.worst):
            rep.heading("Weakest poses of the map")
            rep.table(s.worst, "{:.5g}")
        tables["map_quantiles.csv"] = q
        tables["map_worst.csv"] = s.worst
        return {"map_poses": int(s.poses), "map_singular": int(s.singular),
                "map_rotation": quantity(np.degrees(self.rotation), "deg"),
                "map_kt_min": quantity(float(kt["min"]), "N/m"),
                "map_kt_min_median": quantity(float(kt["q50"]), "N/m")}


def map_from_study(msec, hx, T, axes, mode: str, progress=None) -> StudyMap:
    """The ``[map]`` of a hexapod stiffness study run in blocks (``mode`` "dask" or
    "serial") at the pose's rotation: keys ``block``, ``parts``, ``resume``; errors name
    the key (a missing extra: ``map.blocked``; parts of another run: ``map.parts``)."""
    from closure import log_so3
    from .distributed import MissingExtraError
    block = msec.get("block", "int", 200_000, low=1000)
    parts = msec.get("parts", "str", None)
    resume = msec.get("resume", "bool", False)
    if resume and parts is None:
        raise msec.error("resume", "needs `parts`: the folder whose parts are kept")
    rot = log_so3(np.asarray(T, float)[:3, :3])
    n = int(np.prod([len(a) for a in axes]))
    if progress is not None:
        progress(f"stiffness map over {n:,} poses in blocks of {block:,}")
    try:
        s = stiffness_map(hx, *axes, rot, out=parts, serial=mode == "serial", block=block,
                          resume=resume, progress=progress)
    except MissingExtraError as e:
        raise msec.error("blocked", str(e)) from None
    except FileExistsError as e:
        raise msec.error("parts", str(e).replace("resume=True", "`resume = true`")) from None
    where = "in this process" if mode == "serial" else "on Dask"
    return StudyMap(s, tuple(len(a) for a in axes), rot, block, where, parts,
                    float(hx.singular_cond))
