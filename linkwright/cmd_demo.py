"""``linkwright demo``: every study in an examples folder into an output folder with an index."""
from __future__ import annotations

import html
from pathlib import Path

from .output import Outputs
from .study import Study

__all__ = ["run_demo", "find_examples"]


def find_examples(folder=None) -> Path:
    """The examples folder: the one given, else ``./examples`` (the checkout's)."""
    p = Path(folder) if folder else Path.cwd() / "examples"
    if not p.is_dir() or not list(p.glob("*.toml")):
        raise FileNotFoundError(f"no study files (*.toml) in {p}; run from the linkwright "
                                "checkout or pass --examples DIR")
    return p


def run_demo(folder, out_dir, commands, progress) -> dict:
    ex = find_examples(folder)
    out_dir = Path(out_dir)
    rows = []
    for path in sorted(ex.glob("*.toml")):
        study = Study(path)
        meta = study.section("study")
        cmd = meta.get("command", "str", choices=tuple(commands))
        title = meta.get("title", "str", path.stem)
        progress(f"{path.name}: {cmd}")
        outs = Outputs(out_dir / path.stem)
        summary = commands[cmd](study, outs, progress)
        outs.commit()
        rows.append((path.stem, title, cmd, summary))
    index = Outputs(out_dir)
    md = ["# linkwright demo", "", "| study | command | summary |", "|---|---|---|"]
    h = ["<!DOCTYPE html><html><head><meta charset='utf-8'><title>linkwright demo</title>"
         "</head><body><h1>linkwright demo</h1><table border='1'><tr><th>study</th>"
         "<th>command</th><th>summary</th></tr>"]
    for stem, title, cmd, summ in rows:
        brief = ", ".join(f"{k} = {v:.3g}" if isinstance(v, float) else f"{k} = {v}"
                          for k, v in summ.items() if k != "command")
        md.append(f"| [{title}]({stem}/report.md) | {cmd} | {brief} |")
        h.append(f"<tr><td><a href='{stem}/report.html'>{html.escape(title)}</a></td>"
                 f"<td>{cmd}</td><td>{html.escape(brief)}</td></tr>")
    h.append("</table></body></html>")
    index.add("index.md", "\n".join(md) + "\n")
    index.add("index.html", "\n".join(h))
    index.commit()
    return {"command": "demo", "studies": [r[0] for r in rows], "out": str(out_dir)}
