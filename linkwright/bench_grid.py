"""Benchmark of studies that outgrow one process: a hexapod grid study case by case, serial
against a Dask LocalCluster of 2 workers, and the blocked stiffness map
(:mod:`linkwright.bigmap`): poses per second, the peak memory of one block, and the time a
1e8-pose map takes at that rate (extrapolated, not run).

    python -m linkwright.bench grid [--quick]
"""
from __future__ import annotations

import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np


def _grid_study(folder: Path, n_side: int) -> Path:
    from .examples import folder as examples
    text = (examples() / "hexapod.toml").read_text()
    text = text[:text.index("[map]")] if "[map]" in text else text
    p = folder / "hexapod_grid.toml"
    p.write_text(text + "\n[grid]\n"
                 f'"hexapod.leg_stiffness" = {{start = 1.0e7, stop = 4.0e7, num = {n_side}}}\n'
                 f'"pose.position[2]" = {{start = 0.6, stop = 0.8, num = {n_side}}}\n'
                 f'"pose.position[0]" = {{start = -0.1, stop = 0.1, num = {n_side}}}\n')
    return p


def bench_grid(quick: bool = False) -> list[str]:
    from .distributed import run_study
    import importlib.util
    try:
        import distributed
        if importlib.util.find_spec("pyarrow") is None:
            raise ImportError("pyarrow")
    except ImportError:
        return ["## grid: studies on Dask", "",
                "Not run: needs the `dist` extra (dask[distributed], pyarrow): "
                "`pip install \"linkwright[dist]\"`.", ""]
    from .bigmap import stiffness_map
    from .cmd_stiffness import hexapod_of
    from .examples import folder as examples
    from .study import load_study
    n_side = 5 if quick else 10
    lines = ["## grid: studies on Dask", "",
             f"A hexapod stiffness study over {n_side ** 3} cases (leg stiffness × height × x), "
             "each case the `linkwright stiffness` computation without figures; serial in "
             "this process against a LocalCluster of 2 worker processes (start-up included).",
             "", "| run | cases | wall time (s) | cases/s |", "|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as d:
        study = _grid_study(Path(d), n_side)
        t0 = time.perf_counter()
        a = run_study(study, serial=True)
        ts = time.perf_counter() - t0
        t0 = time.perf_counter()
        cluster = distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                                           dashboard_address=None)
        client = distributed.Client(cluster)
        try:
            b = run_study(study, client)
            tc = time.perf_counter() - t0
            assert a.drop(columns="error").equals(b.drop(columns="error"))
            hx = hexapod_of(load_study(examples() / "hexapod.toml"))[0]
            m = 100 if quick else 200
            axes = (np.linspace(-0.1, 0.1, m), np.linspace(-0.1, 0.1, m),
                    np.linspace(0.6, 0.8, 10 if quick else 25))
            n_poses = int(np.prod([len(x) for x in axes]))
            t0 = time.perf_counter()
            s = stiffness_map(hx, *axes, client=client, block=50_000)
            tm = time.perf_counter() - t0
        finally:
            client.close()
            cluster.close()
    lines += [f"| serial | {len(a)} | {ts:.2f} | {len(a) / ts:.0f} |",
              f"| LocalCluster, 2 workers | {len(b)} | {tc:.2f} | {len(b) / tc:.0f} |", ""]
    # one block's peak memory (traced numpy and pandas allocations) in this process
    from .bigmap import _block_task
    block = 200_000
    tracemalloc.start()
    _block_task(hx, axes, np.zeros(3), 0, min(block, n_poses), None, 0)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    rate = n_poses / tm
    lines += [f"Blocked stiffness map (`linkwright.bigmap.stiffness_map`): {n_poses:,} poses "
              f"in blocks of 50,000 on the 2 workers: {tm:.2f} s, {rate:,.0f} poses/s, "
              f"{s.singular} singular; summary kt_min {s.quantiles.iloc[0]['min']:.4g} … "
              f"{s.quantiles.iloc[0]['max']:.4g} N/m.  Peak memory of one block of "
              f"{min(block, n_poses):,} poses: {peak / 1e6:.0f} MB (traced allocations), "
              "independent of the map's size.  A 1e8-pose map at this rate: "
              f"{1e8 / rate / 60:.0f} min on these 2 workers (extrapolated, not run); its "
              "output is ~11 GB of Parquet parts plus the merged summary.", ""]
    return lines
