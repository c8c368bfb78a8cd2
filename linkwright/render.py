"""The one rendering layer of linkwright: numbers with their units, tables, figures and
reports (Markdown and one self-contained HTML page), used by every ``cmd_*`` module and by
the library's thin report and plot functions (:func:`stiffness.report`,
:func:`stiffness.plot_map`).

It imports no package of the project (closure, synthesis, stiffness, approx), so any of
them may call it without an import cycle.

Conventions
-----------
* A number shown to a user carries its unit: ``2.027e+07 N/m``; a dimensionless number
  has the unit ``1`` (SI's "unit one"): ``cond(P) = 2.81 (1)`` in a table header.
* In JSON summaries every quantity is ``{"value": ..., "unit": "..."}``
  (:func:`quantity`); a count of things (poses, variants, intervals) is a plain integer
  whose key says what it counts.
* Arrays print as lists with a few significant digits (``[0, 0, 0.7] m``), never as
  numpy reprs; table cells never hold a line break.
"""
from __future__ import annotations

import base64
import contextlib
import html
import io
import math
import os
import re
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pandas as pd

__all__ = ["DIMENSIONLESS", "fmt_num", "fmt_list", "fmt_q", "quantity", "cell", "header",
           "have_matplotlib", "figures_off", "new_figure", "save_figure", "figure_png", "heat_map",
           "varying_axes", "Report", "write_atomic"]

#: the unit of a dimensionless number (condition numbers, ratios, relative errors)
DIMENSIONLESS = "1"


def fmt_num(v, digits: int = 4) -> str:
    """A number with ``digits`` significant digits (integers as they are; NaN as ``NaN``)."""
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    try:
        x = float(v)
    except (TypeError, ValueError):
        return str(v)
    if math.isnan(x):
        return "NaN"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if x == 0:
        return "0"
    return f"{x:.{digits}g}"


def fmt_list(values, digits: int = 4) -> str:
    """An array as a flat list ``[a, b, c]`` (rows of a matrix as nested lists)."""
    a = np.asarray(values)
    if a.ndim == 0:
        return fmt_num(a.item(), digits)
    return "[" + ", ".join(fmt_list(x, digits) if np.ndim(x) else fmt_num(x, digits)
                           for x in a) + "]"


def fmt_q(value, unit: str, digits: int = 4) -> str:
    """A quantity as text: ``2.027e+07 N/m``, ``[0, 0, 0.7] m``; dimensionless: the number."""
    text = fmt_list(value, digits) if np.ndim(value) else fmt_num(value, digits)
    return text if unit in ("", DIMENSIONLESS) else f"{text} {unit}"


def _plain(value):
    if isinstance(value, np.ndarray):
        return [_plain(v) for v in value.tolist()]
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return float(value)
    return value


def quantity(value, unit: str) -> dict:
    """The JSON form of a quantity: ``{"value": 2.03e7, "unit": "N/m"}`` (arrays as lists)."""
    return {"value": _plain(value), "unit": unit}


def cell(v, floatfmt: str = "{:.6g}") -> str:
    """A table cell as one line of text: numbers formatted, arrays as lists, no line breaks."""
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return ""
    if isinstance(v, (np.ndarray, list, tuple)):
        return fmt_list(v)
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return floatfmt.format(float(v))
    return " ".join(str(v).split())


def header(name: str, unit: str | None) -> str:
    """A column header with its unit: ``kt_min (N/m)``."""
    return name if unit is None else f"{name} ({unit})"


# --------------------------------------------------------------------------- figures


#: cleared by :func:`figures_off` (reports then take their "no matplotlib" path)
_FIGURES = {"on": True}


def have_matplotlib() -> bool:
    """Whether figures are drawn: matplotlib is installed and :func:`figures_off` is not
    in effect."""
    if not _FIGURES["on"]:
        return False
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


@contextlib.contextmanager
def figures_off():
    """Reports made inside draw no figures (e.g. a grid study's cases, whose reports are
    discarded: PNG rendering is most of their time).  Process-wide: one case per thread."""
    saved = _FIGURES["on"]
    _FIGURES["on"] = False
    try:
        yield
    finally:
        _FIGURES["on"] = saved


def _pyplot():
    try:
        import matplotlib
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("plots need matplotlib: pip install matplotlib (or "
                          "pip install 'linkwright[plot]')") from exc
    if matplotlib.get_backend().lower() not in ("agg", "pdf", "svg", "ps", "cairo"):
        try:
            matplotlib.use("Agg")
        except Exception:  # pragma: no cover - an interactive session keeps its backend
            pass
    import matplotlib.pyplot as plt
    return plt


def new_figure(nrows: int = 1, ncols: int = 1, figsize=(6, 3.6), **kw):
    """``(fig, axes)`` of a new matplotlib figure (off screen)."""
    return _pyplot().subplots(nrows, ncols, figsize=figsize, **kw)


@contextmanager
def _atomic_target(path):
    """A temporary path beside ``path`` that replaces it on success (removed on error)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=path.suffix)
    os.close(fd)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def write_atomic(path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and ``os.replace``."""
    with _atomic_target(path) as tmp, open(tmp, "w", encoding="utf-8") as f:
        f.write(text)


def save_figure(fig, path) -> None:
    """Save a matplotlib figure atomically (PNG/SVG/PDF by the suffix)."""
    with _atomic_target(path) as tmp:
        fig.savefig(tmp, format=Path(path).suffix.lstrip(".") or "png")


def figure_png(fig, dpi: int = 90) -> bytes:
    """The PNG bytes of a figure (which is then closed)."""
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png", dpi=dpi)
    _pyplot().close(fig)
    return buf.getvalue()


def varying_axes(df: pd.DataFrame, candidates=("x", "y", "z", "rx", "ry", "rz")) -> list[str]:
    """The columns of ``candidates`` that take more than one value in ``df`` (in order)."""
    return [c for c in candidates if c in df.columns and df[c].nunique() > 1]


_LABELS = {"x": ("x", "m"), "y": ("y", "m"), "z": ("z", "m"),
           "rx": ("rotation vector x", "deg"), "ry": ("rotation vector y", "deg"),
           "rz": ("rotation vector z", "deg")}


def heat_map(ax, df: pd.DataFrame, value: str, x: str, y: str | None, unit: str = "",
             title: str | None = None):
    """A heat map of ``value`` over the ``x``–``y`` columns of ``df`` on ``ax`` (a line plot
    over ``x`` when ``y`` is None); rotation columns (rad) are shown in degrees.  Cells
    shared by several rows are averaged; NaN cells stay blank."""
    def coord(c):
        v = df[c].to_numpy(float)
        return np.degrees(v) if c in ("rx", "ry", "rz") else v

    def label(c):
        name, u = _LABELS.get(c, (c, ""))
        return f"{name} ({u})" if u else c
    vlabel = f"{value} ({unit})" if unit else value
    if y is None:
        d = pd.DataFrame({"x": coord(x), "v": df[value].to_numpy(float)}).groupby("x").v.mean()
        ax.plot(d.index, d.to_numpy(), marker=".")
        ax.set_xlabel(label(x))
        ax.set_ylabel(vlabel)
    else:
        d = pd.DataFrame({"x": coord(x), "y": coord(y), "v": df[value].to_numpy(float)})
        grid = d.pivot_table(index="y", columns="x", values="v", aggfunc="mean", dropna=False)
        X, Y = np.meshgrid(grid.columns.to_numpy(float), grid.index.to_numpy(float))
        m = ax.pcolormesh(X, Y, grid.to_numpy(float), shading="auto")
        ax.figure.colorbar(m, ax=ax, label=vlabel)
        ax.set_xlabel(label(x))
        ax.set_ylabel(label(y))
    ax.set_title(title or value)
    return ax


# --------------------------------------------------------------------------- reports


PLOT_NOTE = ("(plots need matplotlib, a dependency of linkwright: reinstall it with "
             "pip install linkwright; the `plot` extra installs it too)")


class Report:
    """A report of headings, text, tables and figures, rendered to Markdown and HTML.

    Every report starts with its findings (:meth:`findings`): what the study found, in
    words and figures, before the tables.
    """

    def __init__(self, title: str):
        self.title = title
        self.found: list[str] = []
        self.blocks: list[tuple] = []
        self.figures: dict[str, bytes] = {}
        self.pages: dict[str, str] = {}
        #: the first drawing's PNG name (the demo index shows it as a thumbnail)
        self.thumbnail: str | None = None

    def findings(self, *sentences: str) -> None:
        """Sentences of the findings section (shown first, under the title)."""
        self.found += [" ".join(s.split()) for s in sentences if s]

    def heading(self, text, level=2):
        self.blocks.append(("h", level, text))

    def text(self, text):
        self.blocks.append(("p", text))

    def code(self, text):
        self.blocks.append(("c", text))

    def table(self, df: pd.DataFrame, floatfmt="{:.6g}", max_rows: int | None = 60,
              units: dict | None = None):
        """A table; ``units`` maps column → unit, shown in the header (``kt_min (N/m)``)."""
        d = df if max_rows is None or len(df) <= max_rows else df.head(max_rows)
        d = d.copy()
        if units:
            d.columns = [header(str(c), units.get(c)) for c in d.columns]
        self.blocks.append(("t", d, floatfmt, len(df)))

    def figure(self, name: str, make, nrows: int = 1, ncols: int = 1, figsize=None) -> None:
        """Add a figure made by ``make(ax)`` (``make(axes)`` with several panels) when
        matplotlib is installed; otherwise a note."""
        if not have_matplotlib():
            self.blocks.append(("p", PLOT_NOTE))
            return
        fig, ax = new_figure(nrows, ncols, figsize=figsize or (6, 3.6 * nrows))
        make(ax)
        self.figures[name] = figure_png(fig)
        self.blocks.append(("f", name))

    def drawing(self, name: str, scn, caption: str = "", *, frames: int = 120,
                variants=None) -> None:
        """Add a drawing of a :class:`~linkwright.draw.Scene`: a still figure
        (``NAME.png``) and its offline animation (``NAME.html``: slider over the frames,
        drag to rotate), embedded in the HTML report and linked from the Markdown one.
        Without matplotlib only the animation is added.  ``variants`` (a list of
        scenes) puts those in the animation instead, with a selector of their titles; the
        still figure stays ``scn``'s."""
        from .draw import draw, html_animation
        if caption:
            self.blocks.append(("p", caption))
        if have_matplotlib():
            self.figures[f"{name}.png"] = figure_png(draw(scn), dpi=100)
            self.blocks.append(("f", f"{name}.png"))
            if self.thumbnail is None:
                self.thumbnail = f"{name}.png"
        else:
            self.blocks.append(("p", PLOT_NOTE))
        self.pages[f"{name}.html"] = html_animation(scn, limit=frames) if variants is None \
            else html_animation(list(variants), limit=frames, title=self.title)
        self.blocks.append(("a", f"{name}.html"))

    @staticmethod
    def _cells(df, floatfmt):
        return [[cell(v, floatfmt) for v in row] for row in df.itertuples(index=False)]

    def _all_blocks(self):
        if self.found:
            return [("h", 2, "Findings"), ("ul", self.found)] + self.blocks
        return list(self.blocks)

    def markdown(self) -> str:
        out = [f"# {self.title}", ""]
        for b in self._all_blocks():
            if b[0] == "h":
                out += ["#" * b[1] + " " + b[2], ""]
            elif b[0] == "p":
                out += [b[1], ""]
            elif b[0] == "ul":
                out += [f"- {s}" for s in b[1]] + [""]
            elif b[0] == "c":
                out += ["```", b[1], "```", ""]
            elif b[0] == "t":
                d = b[1]
                out.append("| " + " | ".join(cell(c) for c in d.columns) + " |")
                out.append("|" + "---|" * len(d.columns))
                out += ["| " + " | ".join(r) + " |" for r in self._cells(d, b[2])]
                if b[3] > len(d):
                    out.append(f"\n({b[3] - len(d)} more rows in the CSV)")
                out.append("")
            elif b[0] == "f":
                out += [f"![{b[1]}]({b[1]})", ""]
            elif b[0] == "a":
                out += [f"[Interactive view: {b[1]}]({b[1]}) (slider over the frames, drag "
                        "to rotate)", ""]
        return "\n".join(out)

    def html(self) -> str:
        parts = ["<!DOCTYPE html><html><head><meta charset='utf-8'>",
                 f"<title>{html.escape(self.title)}</title><style>"
                 "body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em}"
                 "table{border-collapse:collapse;font-size:0.85em;margin:0.5em 0}"
                 "td,th{border:1px solid #bbb;padding:2px 6px;text-align:right}"
                 "th{background:#eee}</style></head><body>",
                 f"<h1>{html.escape(self.title)}</h1>"]
        for b in self._all_blocks():
            if b[0] == "h":
                parts.append(f"<h{b[1]}>{html.escape(b[2])}</h{b[1]}>")
            elif b[0] == "p":
                parts.append(f"<p>{html.escape(b[1])}</p>")
            elif b[0] == "ul":
                parts.append("<ul>" + "".join(f"<li>{html.escape(s)}</li>" for s in b[1])
                             + "</ul>")
            elif b[0] == "c":
                parts.append(f"<pre>{html.escape(b[1])}</pre>")
            elif b[0] == "t":
                d = b[1]
                rows = ["<table><thead><tr>" + "".join(f"<th>{html.escape(cell(c))}</th>"
                                                      for c in d.columns) + "</tr></thead><tbody>"]
                rows += ["<tr>" + "".join(f"<td>{html.escape(v)}</td>" for v in r) + "</tr>"
                         for r in self._cells(d, b[2])]
                parts.append("\n".join(rows) + "</tbody></table>")
                if b[3] > len(d):
                    parts.append(f"<p>({b[3] - len(d)} more rows in the CSV)</p>")
            elif b[0] == "f":
                data = base64.b64encode(self.figures[b[1]]).decode()
                parts.append(f"<p><img alt='{html.escape(b[1])}' src='data:image/png;base64,{data}'>"
                             "</p>")
            elif b[0] == "a":                  # the animation, self-contained in a frame
                parts.append(f"<p><iframe title='{html.escape(b[1])}' "
                             f"srcdoc='{html.escape(self.pages[b[1]], quote=True)}' "
                             "width='760' height='680' style='border:1px solid #ccc'>"
                             f"</iframe><br><a href='{html.escape(b[1])}'>open {html.escape(b[1])}"
                             "</a></p>")
        parts.append("</body></html>")
        return "\n".join(parts)

    def add_to(self, outputs, stem: str = "report") -> None:
        """Add ``STEM.md``, ``STEM.html`` and the figures to an :class:`~linkwright.output.Outputs`."""
        outputs.add(f"{stem}.md", self.markdown())
        outputs.add(f"{stem}.html", self.html())
        for name, data in self.figures.items():
            outputs.add(name, data)
        for name, page in self.pages.items():
            outputs.add(name, page)

    def write(self, path, csv: dict | None = None) -> None:
        """Write the Markdown to ``path``, its figures, animation pages and ``csv`` (name →
        DataFrame, saved with its index) beside it as ``STEM_NAME``, each atomically."""
        path = Path(path)
        for name, df in (csv or {}).items():
            write_atomic(path.parent / f"{path.stem}_{name}", df.to_csv())
        for name, data in self.figures.items():
            with _atomic_target(path.parent / name) as tmp, open(tmp, "wb") as f:
                f.write(data)
        for name, page in self.pages.items():
            write_atomic(path.parent / name, page)
        write_atomic(path, self.markdown())


_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^NaN$|^-?inf$")


def is_number(text: str) -> bool:
    """Whether a table cell holds one number (the tests' parser of reports uses it)."""
    return bool(_NUMBER.match(text.strip()))
