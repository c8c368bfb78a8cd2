"""Grid studies on Dask: cases in partitions, each partition one task, results written as
partitioned Parquet as they finish (each partition file written atomically), so a run
that stops can be resumed; the same partitions run in-process with ``serial=True``.

Dask (``dask[distributed]``) and pyarrow are imported only here, only when a grid runs.
"""
from __future__ import annotations

import contextlib
import io
import json
import os
import re
import time
from pathlib import Path

import pandas as pd

from .grid import GridStudy, load_grid_study, run_partition

__all__ = ["run_study", "read_table", "partitions", "MissingExtraError", "MANIFEST"]

#: the file describing a grid output folder (study fingerprint, cases, partition size)
MANIFEST = "_grid.json"
_PART_NAME = "part-{:05d}.parquet"
_PART_RE = re.compile(r"^part-(\d{5})\.parquet$")


class MissingExtraError(ImportError):
    """dask[distributed] or pyarrow is not installed."""


def _need(module: str):
    try:
        return __import__(module)
    except ImportError:
        raise MissingExtraError(
            f"studies on Dask (linkwright grid, blocked maps) need {module}, which is not "
            "installed: "
            "pip install \"linkwright[dist]\" (dask[distributed] and pyarrow)") from None


@contextlib.contextmanager
def dask_client(client=None):
    """``(client, distributed module)``: ``client`` itself, or one of its own (on the
    scheduler at ``DASK_SCHEDULER_ADDRESS``, else a LocalCluster sized to the machine),
    closed with its cluster on exit."""
    _need("dask")
    distributed = _need("distributed")
    own = None
    if client is None:
        addr = os.environ.get("DASK_SCHEDULER_ADDRESS")
        if addr:
            client = own = distributed.Client(addr)
        else:
            cluster = distributed.LocalCluster(processes=True, threads_per_worker=1,
                                               dashboard_address=None)
            client = own = distributed.Client(cluster)
    try:
        yield client, distributed
    finally:
        if own is not None:
            cluster = getattr(own, "cluster", None)
            own.close()
            if cluster is not None:
                cluster.close()


def partitions(n_cases: int, size: int) -> list[range]:
    """The case indices of each partition (consecutive blocks of ``size``)."""
    return [range(s, min(s + size, n_cases)) for s in range(0, n_cases, size)]


def _default_size(n_cases: int) -> int:
    return max(1, min(16, -(-n_cases // 64)))


def _frame(rows: list[dict]) -> pd.DataFrame:
    df = pd.DataFrame(rows)
    if "error" not in df:
        df["error"] = None
    df["error"] = df["error"].astype(object)
    return df


def _write_part(folder: Path, index: int, rows: list[dict]) -> None:
    _need("pyarrow")
    from .atomic import write_new_file
    buf = io.BytesIO()
    _frame(rows).to_parquet(buf, index=False, engine="pyarrow")
    path = folder / _PART_NAME.format(index)
    try:
        write_new_file(path, buf.getvalue())
    except FileExistsError:      # another run (or a retried task) wrote it: same cases
        pass


def _done_parts(folder: Path) -> set[int]:
    return {int(m.group(1)) for name in os.listdir(folder) if (m := _PART_RE.match(name))}


def _assemble(frames: list[pd.DataFrame], keys: list[str]) -> pd.DataFrame:
    if not frames:
        return pd.DataFrame(columns=["case", *keys, "error"])
    df = pd.concat(frames, ignore_index=True, sort=False)
    figures = [c for c in df.columns if c not in ("case", "error", *keys)]
    df = df[["case", *keys, *figures, "error"]].sort_values("case", kind="stable")
    df = df.reset_index(drop=True)
    df["error"] = df["error"].astype(object).where(df["error"].notna(), None)
    return df


def read_table(folder) -> pd.DataFrame:
    """The table of a grid output folder (its finished partitions, in case order)."""
    _need("pyarrow")
    folder = Path(folder)
    man = json.loads((folder / MANIFEST).read_text())
    frames = [pd.read_parquet(folder / _PART_NAME.format(i))
              for i in sorted(_done_parts(folder))]
    return _assemble(frames, man["keys"])


def _prepare_out(out: Path, grid: GridStudy, size: int | None,
                 resume: bool) -> tuple[set[int], int]:
    """Make (or, resuming, check) the output folder; the finished partitions and the
    partition size (a resumed run keeps the size of the run it finishes)."""
    from .output import OutputFolderError
    from .atomic import make_parents, write_new_file
    man = {"tool": "linkwright", "command": grid.command, "study": str(grid.path),
           "fingerprint": grid.fingerprint(), "cases": len(grid.cases),
           "partition_size": size or _default_size(len(grid.cases)), "keys": grid.keys}
    if out.exists() and not out.is_dir():
        raise OutputFolderError(out, "is a file")
    if out.exists() and os.listdir(out):
        if not (out / MANIFEST).exists():
            raise OutputFolderError(out, "holds files that are not a linkwright grid run; "
                                    "give a new folder")
        old = json.loads((out / MANIFEST).read_text())
        if not resume:
            raise OutputFolderError(out, "holds a grid run already: add --resume to finish "
                                    "it, or give a new folder")
        if old.get("fingerprint") != man["fingerprint"]:
            raise OutputFolderError(out, "holds a run of another study or grid; --resume "
                                    "needs the same study file")
        if size is not None and size != old["partition_size"]:
            raise OutputFolderError(out, f"was run with partition size "
                                    f"{old['partition_size']}, not {size}; resume without "
                                    "--partition-size")
        return _done_parts(out), int(old["partition_size"])
    make_parents(out)
    write_new_file(out / MANIFEST, json.dumps(man, indent=2).encode())
    return set(), man["partition_size"]


def run_study(study, client=None, *, out=None, serial: bool = False, resume: bool = False,
              partition_size: int | None = None, progress=None,
              _stop_after: int | None = None) -> pd.DataFrame:
    """Run every case of a grid study and return the table.

    Parameters
    ----------
    study : path-like or GridStudy
        A study file with a ``[grid]`` table (see :mod:`linkwright.grid`).
    client : distributed.Client, optional
        Where the partitions run; None: a LocalCluster sized to the machine (unless
        ``serial``).
    out : path-like, optional
        Folder for the partitioned Parquet table (``part-NNNNN.parquet`` and
        ``_grid.json``); without it the table is only returned.
    serial : bool
        Run the same partitions in this process, without Dask.
    resume : bool
        Keep the partitions already in ``out`` and run only the missing ones.
    partition_size : int, optional
        Cases per task (default: up to 16, about 64 partitions).
    progress : linkwright.output.Progress, optional
        Shows cases done, rate and ETA on a terminal.

    Returns
    -------
    pandas.DataFrame
        ``case``, one column per grid key, the figures, ``error`` (None or the message).
    """
    grid = study if isinstance(study, GridStudy) else load_grid_study(study)
    folder = Path(out) if out is not None else None
    if partition_size is not None and partition_size < 1:
        raise ValueError(f"partition_size: expected an integer ≥ 1, got {partition_size}")
    if folder is not None:
        done, size = _prepare_out(folder, grid, partition_size, resume)
    else:
        done, size = set(), partition_size or _default_size(len(grid.cases))
    parts = partitions(len(grid.cases), size)
    todo = [p for p in range(len(parts)) if p not in done]
    results: dict[int, list[dict]] = {}

    def payload(p):
        return [(i, grid.cases[i], grid.case_data(i)) for i in parts[p]]

    bar = None
    if progress is not None:
        bar = progress.bar(total=len(grid.cases), desc=f"grid {grid.path.name}", unit="case")
        bar.update(sum(len(parts[p]) for p in done))

    def finished(p, rows):
        if folder is not None:
            _write_part(folder, p, rows)
        else:
            results[p] = rows
        if bar is not None:
            bar.update(len(rows))

    try:
        if serial:
            for n, p in enumerate(todo):
                if _stop_after is not None and n >= _stop_after:
                    break
                finished(p, run_partition(grid.command, str(grid.path), payload(p)))
        else:
            with dask_client(client) as (client, distributed):
                futures = {client.submit(run_partition, grid.command, str(grid.path),
                                         payload(p), pure=False, key=f"linkwright-part-{p}-"
                                         f"{time.time_ns()}"): p for p in todo}
                for fut in distributed.as_completed(futures):
                    finished(futures[fut], fut.result())
    finally:
        if bar is not None:
            bar.close()
    if folder is not None:
        return read_table(folder)
    return _assemble([_frame(results[p]) for p in sorted(results)], grid.keys)
