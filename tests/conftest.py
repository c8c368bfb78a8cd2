"""Suite-wide set-up: for the whole suite (``python -m pytest`` with no paths, the
README's test command) on several xdist workers, the numba kernels are compiled once, by
:func:`linkwright.warmup.compile_kernels` (one process per group, as many as workers),
before the workers start; they then load them from numba's cache instead of each
compiling every kernel itself.  The time it took is printed in the summary."""
from __future__ import annotations

import time

_WARMUP: list[str] = []


def pytest_configure(config):
    import pytest
    workers = getattr(config.option, "numprocesses", None)
    if hasattr(config, "workerinput") or not isinstance(workers, int) or workers < 2 \
            or config.args_source != pytest.Config.ArgsSource.TESTPATHS:
        return
    from linkwright.warmup import compile_kernels
    t0 = time.perf_counter()
    try:
        table = compile_kernels(processes=workers)
    except Exception as e:      # the tests of that group meet the failure themselves
        _WARMUP.append(f"kernel warm-up failed: {type(e).__name__}: {e}")
        return
    groups = ", ".join(f"{r.group} {r.compile_seconds:.0f} s" for r in table.itertuples())
    _WARMUP.append(f"numba kernels compiled before the workers started: "
                   f"{time.perf_counter() - t0:.0f} s ({groups} compiling)")


def pytest_terminal_summary(terminalreporter):
    for line in _WARMUP:
        terminalreporter.write_line(line)
