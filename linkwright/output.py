"""Outputs of a command: built in memory, then committed as one set (written into a
temporary folder beside the output folder and swapped in at once), and reports rendered as
Markdown and as one self-contained HTML page."""
from __future__ import annotations

import base64
import errno
import html
import io
import json
import os
import sys
from pathlib import Path

import pandas as pd

from . import __version__
from .atomic import make_parents, make_temp_dir, remove_empty, remove_tree, swap_in
from .interrupt import held_signals

__all__ = ["Outputs", "OutputFolderError", "OutputWriteError", "Report", "Progress",
           "have_matplotlib", "MARKER"]

#: the file that marks a folder as a linkwright output set (it lists the set's entries)
MARKER = ".linkwright.json"


def have_matplotlib() -> bool:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


class OutputFolderError(ValueError):
    """The output folder cannot take the outputs: it is a file (or a file is in its path),
    the current folder, read-only, or it holds files linkwright did not write.  Nothing
    was written."""

    def __init__(self, folder, message: str):
        self.folder = str(folder)
        super().__init__(f"output folder {folder}: {message}")


class OutputWriteError(OSError):
    """Writing the outputs failed (disk full, read-only, ...); the output folder is as it was."""

    def __init__(self, message: str, code: int | None = None):
        super().__init__(message)
        self.errno = code


def _names(entries, limit: int = 5) -> str:
    e = sorted(entries)
    return ", ".join(e[:limit]) + (f" and {len(e) - limit} more" if len(e) > limit else "")


def _read_listing(folder: Path, fd: int | None) -> tuple[set, set | None, bool]:
    entries = set(os.listdir(folder if fd is None else fd))
    writable = os.access(folder, os.W_OK) if fd is None else os.access(".", os.W_OK, dir_fd=fd)
    allowed = None
    if MARKER in entries:
        try:
            if fd is None:
                text = (folder / MARKER).read_bytes()
            else:
                with os.fdopen(os.open(MARKER, os.O_RDONLY, dir_fd=fd), "rb") as f:
                    text = f.read()
            data = json.loads(text.decode("utf-8"))
            if data.get("tool") == "linkwright" and isinstance(data.get("entries"), list):
                allowed = {str(x) for x in data["entries"]}
        except (OSError, ValueError, AttributeError):
            pass
    return entries, allowed, writable


def _listing(folder: Path, tries: int = 100) -> tuple[set, set | None, bool]:
    """The entries of ``folder``, those its marker lists (None: not a linkwright output set)
    and whether it is writable, all read from one folder that was in place while they were
    read, even if concurrent runs swap it meanwhile (where the system has ``dir_fd``)."""
    if not (os.listdir in os.supports_fd and os.open in os.supports_dir_fd
            and os.access in os.supports_dir_fd):
        return _read_listing(folder, None)
    for _ in range(tries):
        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
        try:
            out = _read_listing(folder, fd)
            if os.path.samestat(os.fstat(fd), os.stat(folder)):
                return out
        finally:
            os.close(fd)
    raise OSError(errno.EBUSY, "the folder kept changing under concurrent runs", str(folder))


class Outputs:
    """Files to write into ``folder``, committed as one set.

    Nothing touches the disk until :meth:`commit`, which writes every file into a
    temporary folder beside ``folder`` and swaps it in at once: afterwards ``folder``
    holds exactly the new set.  An error, SIGINT or SIGTERM before the swap leaves
    ``folder`` as it was (absent if it was) and no temporary folder behind.

    Parameters
    ----------
    folder : path-like
        The output folder.  It must be absent, empty, or a previous linkwright output
        set (marked by ``.linkwright.json`` and holding nothing else); it is replaced whole.
    command : str
        The command that makes the set (recorded in the marker).
    owned : bool
        False for a folder the user works in afterwards (``linkwright examples``): it
        must be absent or empty, and gets no marker.
    """

    def __init__(self, folder, command: str = "", *, owned: bool = True):
        self.folder = Path(folder)
        self.command = command
        self.owned = owned
        self.files: dict[str, bytes] = {}
        self.sets: dict[str, str] = {"": command}
        self.committed = False

    def add(self, name: str, content) -> None:
        self.files[name] = content.encode("utf-8") if isinstance(content, str) else content

    def add_csv(self, name: str, df: pd.DataFrame) -> None:
        self.add(name, df.to_csv(index=False))

    def merge(self, other: "Outputs", prefix: str) -> None:
        """Take the files of ``other`` into the subfolder ``prefix`` of this set (which
        gets its own marker, so it can later be replaced on its own)."""
        for name, data in other.files.items():
            self.files[f"{prefix}/{name}"] = data
        for sub, command in other.sets.items():
            self.sets[f"{prefix}/{sub}".rstrip("/")] = command

    def _target(self) -> Path:
        return Path(os.path.realpath(self.folder))

    def check(self) -> None:
        """Raise :class:`OutputFolderError` if the output folder cannot be made or replaced
        (a file in the way, a read-only folder, files linkwright did not write); call it
        before a long run."""
        t = self._target()
        cwd = Path(os.path.realpath(os.getcwd()))
        if t == cwd or t in cwd.parents:
            raise OutputFolderError(self.folder, "is the current folder or contains it; the "
                                    "outputs replace their folder whole: give a subfolder")
        self._check_replaceable(t)

    def _check_creatable(self, t: Path) -> None:
        """The nearest existing ancestor of a new output folder must be a writable folder."""
        p = t.parent
        while not os.path.lexists(p) and p.parent != p:
            p = p.parent
        if not os.path.isdir(p):
            raise OutputFolderError(self.folder, f"cannot be made: {p} is a file, not a folder")
        if not os.access(p, os.W_OK | os.X_OK):
            raise OutputFolderError(self.folder, f"cannot be made: {p} is read-only; nothing "
                                    "was changed")

    def _check_replaceable(self, t: Path) -> None:
        try:
            entries, allowed, writable = _listing(t)
        except FileNotFoundError:
            self._check_creatable(t)
            return
        except NotADirectoryError:
            if not os.path.lexists(t):
                self._check_creatable(t)
            raise OutputFolderError(self.folder, "exists and is not a folder") from None
        if not os.access(t.parent, os.W_OK | os.X_OK):
            raise OutputFolderError(self.folder, f"cannot be replaced: {t.parent} is "
                                    "read-only; nothing was changed")
        if not entries:
            return
        if not self.owned:
            raise OutputFolderError(self.folder, f"exists and is not empty ({_names(entries)}); "
                                    "give a new or an empty folder")
        if allowed is None:
            raise OutputFolderError(self.folder, f"holds files linkwright did not write "
                                    f"({_names(entries)}); give a new or an empty folder")
        extra = entries - allowed - {MARKER}
        if extra:
            raise OutputFolderError(self.folder, "holds files that are not linkwright outputs "
                                    f"({_names(extra)}); move them away or give another folder")
        if not writable:
            raise OutputFolderError(self.folder, "is read-only: the outputs cannot replace "
                                    "it; nothing was changed")

    def _markers(self) -> dict[str, bytes]:
        out = {}
        for prefix, command in self.sets.items():
            lead = f"{prefix}/" if prefix else ""
            entries = sorted({n[len(lead):].split("/", 1)[0] for n in self.files
                              if n.startswith(lead)})
            data = {"tool": "linkwright", "version": __version__, "command": command,
                    "entries": entries}
            out[f"{lead}{MARKER}"] = (json.dumps(data, indent=1) + "\n").encode()
        return out

    def commit(self) -> list[Path]:
        """Write the set and swap it in place of the output folder.

        Returns
        -------
        list of Path
            The files written (under the folder as given).

        Raises
        ------
        OutputFolderError
            The folder may not be replaced (checked again here: another run may have
            changed it).
        OutputWriteError
            An operating-system error (disk full, read-only, ...); nothing was changed.
        """
        self.check()
        t = self._target()
        created, tmp = [], None
        try:
            created = make_parents(t.parent)
            tmp = make_temp_dir(t.parent)
            files = dict(self.files, **(self._markers() if self.owned else {}))
            for name, data in files.items():
                p = tmp / name
                p.parent.mkdir(parents=True, exist_ok=True)
                p.write_bytes(data)
            with held_signals():
                swap_in(tmp, t, self._check_replaceable)
                tmp = None
                self.committed = True
        except OutputWriteError:
            raise
        except OSError as e:
            raise OutputWriteError(f"could not write the outputs to {self.folder}: "
                                   f"{e.strerror or e}; nothing was changed", e.errno) from e
        finally:
            with held_signals():
                if tmp is not None:
                    remove_tree(tmp)
                if not self.committed:
                    remove_empty(created)
        return [self.folder / name for name in self.files]


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
