"""Heat maps of stiffness indices (matplotlib, a dependency of linkwright).

A thin public function over the application's one rendering layer
(:func:`linkwright.render.heat_map`); it does not import :mod:`stiffness.report`.
"""
from __future__ import annotations

from .errors import StiffnessError

__all__ = ["plot_map"]


def plot_map(df, index: str = "kt_min", x: str | None = None, y: str | None = None, path=None,
             *, ax=None):
    """Heat map of ``index`` over two pose columns of a :meth:`Hexapod.map` table.

    ``x`` and ``y`` default to the first two pose columns (``x, y, z, rx, ry, rz``) that
    take more than one value (``x``, ``y`` when none vary; a line plot when only one
    does): an x–z map is drawn over x and z.  Rows sharing an (x, y) cell are averaged;
    pass a slice (e.g. ``df[df.z == 0.7]``) to plot one plane.  Rotations are drawn in
    degrees, lengths in m.  Singular poses (NaN) are left blank.  Returns the matplotlib
    Figure; saved to ``path`` (PNG/SVG/PDF by suffix) when given.
    """
    import pandas as pd
    from linkwright import render
    if not isinstance(df, pd.DataFrame):
        raise StiffnessError(f"df: expected the DataFrame of Hexapod.map, got "
                             f"{type(df).__name__}")
    if x is None and y is None:
        vary = render.varying_axes(df)
        x, y = (vary + ["x", "y"])[:2] if len(vary) != 1 else (vary[0], None)
    for col in [c for c in (index, x, y) if c is not None]:
        if col not in df.columns:
            raise StiffnessError(f"plot_map: column {col!r} not in the map; columns: "
                                 f"{', '.join(df.columns)}")
    if ax is None:
        fig, ax = render.new_figure(figsize=(5, 4))
    fig = ax.figure
    unit = df.attrs.get("units", {}).get(index, "")
    render.heat_map(ax, df, index, x, y, unit)
    if path is not None:
        render.save_figure(fig, path)
    return fig
