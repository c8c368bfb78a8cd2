"""Heat maps of stiffness indices (needs the ``plot`` extra: matplotlib)."""
from __future__ import annotations

import numpy as np

from .errors import StiffnessError

__all__ = ["plot_map"]


def plot_map(df, index: str = "kt_min", x: str = "x", y: str = "y", path=None, *, ax=None):
    """Heat map of ``index`` over the ``x``–``y`` slice of a :meth:`Hexapod.map` table.

    Rows are averaged over the other columns' values only if several share an
    (x, y) cell; pass a slice (e.g. ``df[df.z == 0.7]``) to plot one plane.
    Singular poses (NaN) are left blank.  Returns the matplotlib Figure; saved
    to ``path`` (PNG/SVG/PDF by suffix) when given.
    """
    try:
        import matplotlib
        matplotlib.use("Agg") if ax is None and path is not None else None
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("plot_map needs matplotlib: pip install 'linkwright[plot]'") from exc
    import pandas as pd
    if not isinstance(df, pd.DataFrame):
        raise StiffnessError(f"df: expected the DataFrame of Hexapod.map, got "
                             f"{type(df).__name__}")
    for col in (index, x, y):
        if col not in df.columns:
            raise StiffnessError(f"plot_map: column {col!r} not in the map; columns: "
                                 f"{', '.join(df.columns)}")
    grid = df.pivot_table(index=y, columns=x, values=index, aggfunc="mean", dropna=False)
    fig = None
    if ax is None:
        fig, ax = plt.subplots(figsize=(5, 4))
    else:
        fig = ax.figure
    X, Y = np.meshgrid(grid.columns.to_numpy(float), grid.index.to_numpy(float))
    m = ax.pcolormesh(X, Y, grid.to_numpy(float), shading="auto")
    unit = df.attrs.get("units", {}).get(index, "")
    fig.colorbar(m, ax=ax, label=f"{index} ({unit})" if unit else index)
    ax.set_xlabel(f"{x} (m)")
    ax.set_ylabel(f"{y} (m)")
    ax.set_title(index)
    if path is not None:
        from .report import _save_figure
        _save_figure(fig, path)
    return fig
