"""Compile linkwright's numba kernels ahead of use, one process per group of kernels.

linkwright's compiled kernels (numba, ``cache=True``) are compiled on their first call in
a new installation and loaded from numba's cache by every later process.  The first
compile is long (the position solver alone takes most of a minute), and a process that
meets several groups compiles them one after the other.  :func:`compile_kernels` runs a
small workload of each group in its own process, as many at a time as asked, so that a
machine with two cores compiles the lot in about half the time; later processes (studies,
tests, Dask workers) then only load the cache.  ``linkwright compile`` is the command.

    >>> from linkwright.warmup import compile_kernels
    >>> table = compile_kernels()            # doctest: +SKIP
    >>> table[["group", "seconds", "compile_seconds"]]          # doctest: +SKIP

The numbers are what numba reports: ``compile_seconds`` is the time spent compiling in
that group's process (0 when every kernel came from the cache).
"""
from __future__ import annotations

import os
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from multiprocessing import get_context
from typing import Callable, Sequence

import numpy as np

__all__ = ["GROUPS", "NEEDS", "compile_kernels"]


def _solver() -> None:
    """The position solver (``closure.solve_kernels``): one pose, a batch from guesses,
    a sweep, a chain of loops (block-sparse least squares)."""
    from linkwright.references import fourbar, fourbar_chain, rssr
    m = rssr(0.2, 1)[0]
    p = m.solve(0.0)
    m.solve(np.array([0.1, -0.1]), guess=p)
    m.sweep([0.0, 0.05])
    fourbar_chain(3).solve(0.01)
    fourbar(1.0, 3.0, 2.5, 3.2, 0.3)[0].solve(0.1).condition


def _fourbar_dynamics():
    from closure import Dynamics
    from linkwright.references import fourbar
    m = fourbar(1.0, 3.0, 2.5, 3.2, 0.3)[0]
    d = Dynamics(m, gravity=(0, -9.81, 0))
    for i, name in enumerate(("crank", "coupler", "rocker")):
        d.add_body(name, 1.0 + i, (0.5, 0.1 * i, 0.0), np.diag([0.01, 0.1, 0.1]))
    return d


def _dynamics() -> None:
    """Forward dynamics (``closure.dynamics_kernels``): one trajectory and a batch."""
    d = _fourbar_dynamics()
    d.simulate((0.0, 0.01), [0.0], [1.0])
    d.simulate_batch((0.0, 0.01), np.zeros((2, 1)), np.ones((2, 1)))


def _stiffness() -> None:
    """The hexapod's stiffness kernels (``stiffness.kernels``): K, cond(P), a map."""
    from stiffness import Hexapod
    base = np.deg2rad([0, 100, 120, 220, 240, 340])      # seed 003's hexapod
    plat = np.deg2rad([40, 80, 160, 200, 280, 320])
    hx = Hexapod(0.8 * np.stack([np.cos(base), np.sin(base), 0 * base], -1),
                 0.4 * np.stack([np.cos(plat), np.sin(plat), 0 * plat], -1), np.full(6, 2e7))
    pose = np.eye(4)
    pose[2, 3] = 0.7
    hx.stiffness(pose)
    hx.cond_P(pose)
    hx.map(np.array([[0.0, 0.0, 0.7], [0.05, 0.0, 0.7]]))


def _synthesis() -> None:
    """Dyad synthesis kernels (``synthesis.kernels``, ``synthesis.transition_kernels``):
    a family with a helical main link and one with a helical–spherical one."""
    from linkwright.bench_families import PITCH, generate, generate_sphere
    from synthesis import enumerate_dyads
    task = generate("HRR", 0)
    enumerate_dyads("HRR", task[0], **task[3])
    enumerate_dyads("RHS", generate_sphere("RHS", 0)[0], pitch=PITCH)


def _approx() -> None:
    """Surrogate evaluation kernels (``approx.kernels``) and the reduced model's
    right-hand side (``closure.reduced_kernels``): the crane's forward dynamics with its
    loops replaced by spline surrogates."""
    from approx import fit_chebyshev, fit_spline
    from approx.multiloop import surrogate_dynamics
    from linkwright.examples import crane
    f, df, d2f = np.sin, np.cos, lambda x: -np.sin(x)
    for s in (fit_spline(f, df, d2f, 0.0, 1.0, n=4), fit_chebyshev(f, df, d2f, 0.0, 1.0,
                                                                     degree=4)):
        for x in (np.linspace(0.0, 1.0, 3), 0.5):
            s.position(x), s.velocity(x), s.acceleration(x)
    red = surrogate_dynamics(crane.dynamics(), ranges={"stroke1": (0.0, 0.1),
                                                      "stroke2": (0.0, 0.1)}, size=2)
    red.simulate((0.0, 0.01), [0.05, 0.05], [0.0, 0.0])


#: the groups, heaviest first: name → workload (a function of no arguments)
GROUPS: dict[str, Callable[[], None]] = {"solver": _solver, "synthesis": _synthesis,
                                         "dynamics": _dynamics, "stiffness": _stiffness,
                                         "approx": _approx}
#: groups that call another group's kernels: started once that group is cached (two
#: processes compiling the same kernel at once would each do all the work)
NEEDS: dict[str, tuple[str, ...]] = {"dynamics": ("solver",), "approx": ("solver",)}


def _run(name: str) -> dict:
    """One group's workload in this process: its wall time and numba's compile time."""
    from numba.core import event

    class _Compiles(event.Listener):          # outermost compile events only
        def __init__(self):
            self.depth, self.start, self.total = 0, 0.0, 0.0

        def on_start(self, ev):
            if self.depth == 0:
                self.start = time.perf_counter()
            self.depth += 1

        def on_end(self, ev):
            self.depth -= 1
            if self.depth == 0:
                self.total += time.perf_counter() - self.start

    listener = _Compiles()
    t0 = time.perf_counter()
    with event.install_listener("numba:compile", listener):
        GROUPS[name]()
    return {"group": name, "seconds": time.perf_counter() - t0,
            "compile_seconds": listener.total, "pid": os.getpid()}


def compile_kernels(groups: Sequence[str] | None = None, processes: int | None = None):
    """Compile (or load from numba's cache) the kernels of ``groups``, each group in its
    own process, ``processes`` at a time.

    Parameters
    ----------
    groups : sequence of str, optional
        Names from :data:`GROUPS` (default: all of them).
    processes : int, optional
        Worker processes (default: the number of CPUs, at most the number of groups).

    Returns
    -------
    pandas.DataFrame
        One row per group: ``group``, ``seconds`` (wall time of its workload, s),
        ``compile_seconds`` (of it, numba compiling, s; 0 when all came from the cache),
        ``pid`` (the process).

    Raises
    ------
    ValueError
        An unknown group name, or ``processes`` not a positive integer.
    """
    import pandas as pd

    names = list(GROUPS) if groups is None else list(groups)
    unknown = [g for g in names if g not in GROUPS]
    if unknown:
        raise ValueError(f"groups: unknown {unknown}; expected names from {list(GROUPS)}")
    if processes is None:
        processes = os.cpu_count() or 1
    if isinstance(processes, bool) or not isinstance(processes, (int, np.integer)) \
            or processes < 1:
        raise ValueError(f"processes: expected a positive integer, got {processes!r}")
    processes = min(int(processes), max(len(names), 1))
    pending, running, rows = list(dict.fromkeys(names)), {}, {}
    # spawn: a fresh interpreter per worker (no forked numba or BLAS state); a group is
    # started when a worker is free and the groups it needs are done
    with ProcessPoolExecutor(processes, mp_context=get_context("spawn")) as pool:
        while pending or running:
            for name in [g for g in pending if all(n in rows or n not in pending and
                                                  n not in running.values()
                                                  for n in NEEDS.get(g, ()))]:
                if len(running) < processes:
                    running[pool.submit(_run, name)] = name
                    pending.remove(name)
            finished, _ = wait(running, return_when=FIRST_COMPLETED)
            for f in finished:
                rows[running.pop(f)] = f.result()
    return pd.DataFrame([rows[g] for g in dict.fromkeys(names)],
                        columns=["group", "seconds", "compile_seconds", "pid"])
