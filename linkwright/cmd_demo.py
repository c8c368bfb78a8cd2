"""``linkwright demo``: every study of a folder (by default the studies shipped with
linkwright) into one output folder with an index, committed as one set."""
from __future__ import annotations

import html
from pathlib import Path

from . import examples
from .output import Outputs
from .study import StudyError, load_study

__all__ = ["run_demo", "find_examples"]


def find_examples(folder=None) -> Path:
    """The folder of study files: the one given, else the studies shipped with linkwright.

    Raises
    ------
    StudyError
        The folder holds no ``*.toml`` study files.
    """
    p = Path(folder) if folder else examples.folder()
    if not p.is_dir() or not examples.studies(p):
        raise StudyError(p, None, "no study files (*.toml) in this folder; give a folder of "
                         "study files with --examples DIR, or none for the shipped studies")
    return p


def run_demo(folder, out, commands: dict, progress) -> dict:
    """Run every study of ``folder`` into ``out``: one subfolder per study and an index.

    Parameters
    ----------
    folder : path-like or None
        The study files; None for the shipped studies.
    out : Outputs or path-like
        The output set to fill (the caller commits it), or a folder to commit to here.
    commands : dict
        Command name → ``run(study, outputs, progress) -> summary``.
    progress : callable
        Progress messages.

    Returns
    -------
    dict
        The summary: the studies run and the output folder.
    """
    own = not isinstance(out, Outputs)
    if own:
        out = Outputs(out, "demo")
        out.check()
    ex = find_examples(folder)
    rows = []
    studies = [load_study(path) for path in examples.studies(ex)]   # all checked first
    pairs = list(zip(examples.studies(ex), studies))
    bar = progress.bar(pairs, desc="demo", unit="study") if hasattr(progress, "bar") else pairs
    for path, study in bar:
        cmd = study.command
        title = study.section("study").get("title", "str", path.stem)
        progress(f"{path.name}: {cmd}")
        sub = Outputs(out.folder / path.stem, cmd)
        summary = commands[cmd](study, sub, progress)
        thumb = next((n for n in sub.files if n.endswith(".png") and
                      (n.startswith("mechanism") or n.startswith("variant"))), None)
        out.merge(sub, path.stem)
        rows.append((path.stem, title, cmd, summary, thumb))
    md = ["# linkwright demo", "", "| study | command | summary | drawing |", "|---|---|---|---|"]
    h = ["<!DOCTYPE html><html><head><meta charset='utf-8'><title>linkwright demo</title>"
         "</head><body><h1>linkwright demo</h1><table border='1'><tr><th>study</th>"
         "<th>command</th><th>summary</th><th>drawing</th></tr>"]
    from .cli import summary_line
    for stem, title, cmd, summ, thumb in rows:
        brief = summary_line(summ)
        pic = f"![{stem}]({stem}/{thumb})" if thumb else ""
        md.append(f"| [{title}]({stem}/report.md) | {cmd} | {brief} | {pic} |")
        img = (f"<a href='{stem}/report.html'><img src='{stem}/{html.escape(thumb)}' "
               f"alt='{html.escape(title)}' width='180'></a>" if thumb else "")
        h.append(f"<tr><td><a href='{stem}/report.html'>{html.escape(title)}</a></td>"
                 f"<td>{cmd}</td><td>{html.escape(brief)}</td><td>{img}</td></tr>")
    h.append("</table></body></html>")
    out.add("index.md", "\n".join(md) + "\n")
    out.add("index.html", "\n".join(h))
    if own:
        out.commit()
    return {"command": "demo", "studies": [r[0] for r in rows], "out": str(out.folder),
            "results": {r[0]: r[3] for r in rows}}
