"""``linkwright examples``: list the studies shipped with linkwright, or copy them (and the
example scripts) into a folder to edit and run."""
from __future__ import annotations

from . import examples
from .output import Outputs
from .study import Study

__all__ = ["list_examples", "copy_examples"]


def list_examples() -> list[dict]:
    """The shipped studies: name, command, title and file.

    Returns
    -------
    list of dict
    """
    rows = []
    for path in examples.studies():
        meta = Study(path).section("study")
        rows.append({"name": path.stem, "command": meta.get("command", "str"),
                     "title": meta.get("title", "str", path.stem), "file": str(path)})
    return rows


def copy_examples(out: Outputs) -> dict:
    """Add every shipped study (``*.toml``) and example script to ``out`` (the caller
    commits it into a new or empty folder).

    Returns
    -------
    dict
        The summary: the studies copied.
    """
    folder = examples.folder()
    for path in sorted(folder.iterdir()):
        if path.is_file() and (path.suffix == ".toml" or
                               (path.suffix == ".py" and not path.name.startswith("_"))):
            out.add(path.name, path.read_bytes())
    return {"command": "examples", "studies": [p.stem for p in examples.studies(folder)],
            "out": str(out.folder)}
