"""Outputs of a command: built in memory, then written atomically into the output folder,
and reports rendered as Markdown and as one self-contained HTML page."""
from __future__ import annotations

import base64
import html
import io
import os
import shutil
import sys
import tempfile
from pathlib import Path

import pandas as pd

__all__ = ["Outputs", "Report", "Progress", "have_matplotlib"]


def have_matplotlib() -> bool:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


class Outputs:
    """Files to write into ``folder``.  Nothing touches the disk until :meth:`commit`,
    which writes everything into a temporary folder beside the target and then moves
    each file into place with ``os.replace``; an error or Ctrl-C before that leaves
    the folder as it was."""

    def __init__(self, folder):
        self.folder = Path(folder)
        self.files: dict[str, bytes] = {}

    def add(self, name: str, content) -> None:
        self.files[name] = content.encode("utf-8") if isinstance(content, str) else content

    def add_csv(self, name: str, df: pd.DataFrame) -> None:
        self.add(name, df.to_csv(index=False))

    def commit(self) -> list[Path]:
        self.folder.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=".linkwright-", dir=self.folder))
        try:
            for name, data in self.files.items():
                p = tmp / name
                p.parent.mkdir(parents=True, exist_ok=True)
                p.write_bytes(data)
            out = []
            for name in self.files:
                dest = self.folder / name
                dest.parent.mkdir(parents=True, exist_ok=True)
                os.replace(tmp / name, dest)
                out.append(dest)
            return out
        finally:
            shutil.rmtree(tmp, ignore_errors=True)


class Report:
    """A report of headings, text, tables and figures, rendered to Markdown and HTML."""

    def __init__(self, title: str):
        self.title = title
        self.blocks: list[tuple] = []
        self.figures: dict[str, bytes] = {}

    def heading(self, text, level=2):
        self.blocks.append(("h", level, text))

    def text(self, text):
        self.blocks.append(("p", text))

    def table(self, df: pd.DataFrame, floatfmt="{:.6g}", max_rows: int | None = 60):
        d = df if max_rows is None or len(df) <= max_rows else df.head(max_rows)
        self.blocks.append(("t", d.copy(), floatfmt, len(df)))

    def figure(self, name: str, make) -> None:
        """Add a figure made by ``make(ax)`` when matplotlib is installed; otherwise a note."""
        if not have_matplotlib():
            self.blocks.append(("p", "(plots need the `plot` extra: pip install 'linkwright[plot]')"))
            return
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(6, 3.6))
        make(ax)
        fig.tight_layout()
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=90)
        plt.close(fig)
        self.figures[name] = buf.getvalue()
        self.blocks.append(("f", name))

    def _fmt(self, df, floatfmt):
        d = df.copy()
        for c in d.columns:
            if pd.api.types.is_float_dtype(d[c]):
                d[c] = d[c].map(lambda v: "" if pd.isna(v) else floatfmt.format(v))
        return d

    def markdown(self) -> str:
        out = [f"# {self.title}", ""]
        for b in self.blocks:
            if b[0] == "h":
                out += ["#" * b[1] + " " + b[2], ""]
            elif b[0] == "p":
                out += [b[1], ""]
            elif b[0] == "t":
                d = self._fmt(b[1], b[2])
                out.append("| " + " | ".join(map(str, d.columns)) + " |")
                out.append("|" + "---|" * len(d.columns))
                out += ["| " + " | ".join(map(str, r)) + " |" for r in d.itertuples(index=False)]
                if b[3] > len(d):
                    out.append(f"\n({b[3] - len(d)} more rows in the CSV)")
                out.append("")
            elif b[0] == "f":
                out += [f"![{b[1]}]({b[1]})", ""]
        return "\n".join(out)

    def html(self) -> str:
        parts = ["<!DOCTYPE html><html><head><meta charset='utf-8'>",
                 f"<title>{html.escape(self.title)}</title><style>"
                 "body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em}"
                 "table{border-collapse:collapse;font-size:0.85em;margin:0.5em 0}"
                 "td,th{border:1px solid #bbb;padding:2px 6px;text-align:right}"
                 "th{background:#eee}</style></head><body>",
                 f"<h1>{html.escape(self.title)}</h1>"]
        for b in self.blocks:
            if b[0] == "h":
                parts.append(f"<h{b[1]}>{html.escape(b[2])}</h{b[1]}>")
            elif b[0] == "p":
                parts.append(f"<p>{html.escape(b[1])}</p>")
            elif b[0] == "t":
                parts.append(self._fmt(b[1], b[2]).to_html(index=False, border=0))
                if b[3] > len(b[1]):
                    parts.append(f"<p>({b[3] - len(b[1])} more rows in the CSV)</p>")
            elif b[0] == "f":
                data = base64.b64encode(self.figures[b[1]]).decode()
                parts.append(f"<p><img alt='{html.escape(b[1])}' src='data:image/png;base64,{data}'>"
                             "</p>")
        parts.append("</body></html>")
        return "\n".join(parts)

    def add_to(self, outputs: Outputs, stem: str = "report") -> None:
        outputs.add(f"{stem}.md", self.markdown())
        outputs.add(f"{stem}.html", self.html())
        for name, data in self.figures.items():
            outputs.add(name, data)


class Progress:
    """Progress lines on stderr when it is a terminal (silent with ``quiet``)."""

    def __init__(self, quiet: bool = False):
        self.on = not quiet and sys.stderr.isatty()

    def __call__(self, msg: str) -> None:
        if self.on:
            print(f"linkwright: {msg}", file=sys.stderr, flush=True)
