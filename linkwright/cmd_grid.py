"""``linkwright grid STUDY.toml -o OUT``: every case of a study's ``[grid]`` table, on Dask
(a LocalCluster sized to the machine, or ``--scheduler`` / ``DASK_SCHEDULER_ADDRESS``) or
in-process with ``--serial``; the table is written as partitioned Parquet under OUT as
cases finish, and ``--resume`` runs only the missing partitions."""
from __future__ import annotations

import os
from pathlib import Path

__all__ = ["run_grid"]


class _Partial:
    """What an interrupted grid run leaves (for the command's interrupt message): the
    partitions finished so far, kept for ``--resume``."""

    committed = True

    def __init__(self, out: Path):
        self.folder = f"{out} (its finished partitions; add --resume to finish the run)"


def run_grid(args, progress, state: dict | None = None) -> dict:
    """Run the grid study of the parsed ``args``; the JSON summary (cases, failed cases,
    seconds, the output folder).  ``state["out"]`` is set for the interrupt message."""
    import time
    from .distributed import run_study
    from .grid import load_grid_study
    from .study import StudyError
    grid = load_grid_study(args.study)
    out = Path(args.out or Path("linkwright-out") / (Path(args.study).stem + "-grid"))
    client = None
    cluster = None
    if not args.serial:
        from .distributed import _need
        _need("dask")
        distributed = _need("distributed")
        addr = args.scheduler or os.environ.get("DASK_SCHEDULER_ADDRESS")
        if addr:
            client = distributed.Client(addr)
        else:
            if args.workers is not None and args.workers < 1:
                raise StudyError(args.study, None, f"--workers: expected an integer ≥ 1, "
                                 f"got {args.workers}")
            cluster = distributed.LocalCluster(n_workers=args.workers, threads_per_worker=1,
                                               processes=True, dashboard_address=None)
            client = distributed.Client(cluster)
    if state is not None:
        state["out"] = _Partial(out)
    t0 = time.perf_counter()
    try:
        df = run_study(grid, client, out=out, serial=args.serial, resume=args.resume,
                       partition_size=args.partition_size, progress=progress)
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    failed = int(df["error"].notna().sum())
    return {"command": "grid", "study": grid.command, "cases": int(len(df)),
            "failed": failed, "seconds": round(time.perf_counter() - t0, 3),
            "out": str(out)}
