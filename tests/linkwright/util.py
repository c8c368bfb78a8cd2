"""Helpers of the linkwright tests: the command in a subprocess, folder snapshots."""
from __future__ import annotations

import os
import sys
from pathlib import Path

import linkwright

#: the source tree under test (the subprocesses import the same code as the tests)
ROOT = Path(linkwright.__file__).resolve().parents[1]


def env(**extra) -> dict:
    """The environment of a subprocess that imports the code under test."""
    e = dict(os.environ, **extra)
    e["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + ([e["PYTHONPATH"]] if e.get("PYTHONPATH")
                                                      else []))
    return e


def command(*args) -> list[str]:
    """``python -m linkwright ARGS`` with this interpreter."""
    return [sys.executable, "-m", "linkwright", *map(str, args)]


def tree(folder) -> dict[str, bytes | None]:
    """Every file (bytes) and folder (None) under ``folder``, by relative path."""
    folder = Path(folder)
    return {p.relative_to(folder).as_posix(): (None if p.is_dir() else p.read_bytes())
            for p in folder.rglob("*")}


def temporaries(folder) -> list[Path]:
    """linkwright's temporary folders left anywhere under ``folder``."""
    return sorted(Path(folder).rglob(".linkwright-*"))
