"""The example studies shipped with linkwright: one TOML study file per seed paper plus a
dynamics study, and two scripts (``crane``, ``swash_plate``) that build their mechanisms
in Python.

They are package data, so ``linkwright demo`` and ``linkwright bench`` find them from any
folder; ``linkwright examples -o DIR`` copies them out for editing.  Run a script with
``python -m linkwright.examples.crane``.
"""
from __future__ import annotations

import atexit
import shutil
import tempfile
from importlib import resources
from pathlib import Path

__all__ = ["folder", "studies"]

_extracted: Path | None = None


def folder() -> Path:
    """The folder holding the shipped studies (extracted to a temporary folder when the
    package is not installed as plain files, e.g. from a zip).

    Returns
    -------
    Path
        A folder with the ``*.toml`` studies and the example scripts.
    """
    global _extracted
    root = resources.files(__name__)
    if isinstance(root, Path):
        return root
    if _extracted is None:
        tmp = Path(tempfile.mkdtemp(prefix="linkwright-examples-"))
        atexit.register(shutil.rmtree, tmp, True)
        for item in root.iterdir():
            if item.is_file() and item.name.endswith((".toml", ".py")):
                (tmp / item.name).write_bytes(item.read_bytes())
        _extracted = tmp
    return _extracted


def studies(where=None) -> list[Path]:
    """The study files (``*.toml``) of ``where`` (default: the shipped ones), sorted by name.

    Parameters
    ----------
    where : path-like, optional
        A folder of study files.

    Returns
    -------
    list of Path
    """
    return sorted(Path(where or folder()).glob("*.toml"))
