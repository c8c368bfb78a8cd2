"""Stiffness reports: Markdown and CSV, written atomically.

A thin public function: the report is built by the application's one rendering layer
(:mod:`linkwright.render`, the same report ``linkwright stiffness`` writes); it does not
import :mod:`stiffness.plot`.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import StiffnessError
from .validate import as_array

__all__ = ["report", "write_atomic"]


def write_atomic(path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and ``os.replace``."""
    from linkwright.render import write_atomic as _write
    _write(path, text)


def report(hexapod, pose, *, frame=None, wrench=None, positions=None, rotations=None,
           path=None, title: str = "Stiffness report") -> str:
    """A Markdown stiffness report (and CSV files beside it when ``path`` is given).

    Contents: the findings (weakest and stiffest translation with their directions and
    values, the rotational compliance, cond(P)), the pose, the reference frame, K with
    the units of its rows and columns, the indices as a tidy table (translational
    eigenvalues N/m, rotational compliance eigenvalues rad/(N·m), frame-invariant screw
    eigenvalues N, ‖K_c‖ N/rad), leg forces and the deflection under ``wrench`` (about
    the base origin), and the map over ``positions`` × ``rotations`` when given
    (``rotations`` default: the pose's own rotation), with its heat map over the pose
    coordinates that vary (``STEM_map.png`` beside ``path``).

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
    W = None
    if wrench is not None:
        W = as_array(wrench, "wrench", (6,), ndim=1, what="a wrench (f, m) of shape (6,)")
    from linkwright.cmd_stiffness import stiffness_report
    name = frame if isinstance(frame, str) else ("base" if frame is None else "given")
    rep, tables, _ = stiffness_report(hexapod, T, res, frame_name=name, wrench=W,
                                      positions=positions, rotations=rotations, title=title,
                                      figures=path is not None)
    if path is not None:
        path = Path(path)
        if "map.png" in rep.figures:
            rep.figures[f"{path.stem}_map.png"] = rep.figures.pop("map.png")
            rep.blocks = [("f", f"{path.stem}_map.png") if b == ("f", "map.png") else b
                          for b in rep.blocks]
        csv = {}
        for name, df in tables.items():
            if name == "stiffness.csv":
                df = df.set_index("row")
                df.index.name = None
            elif name == "leg_forces.csv":
                df = df.set_index(np.arange(len(df)))
            csv[name] = df
        rep.write(path, csv)
    return rep.markdown()
