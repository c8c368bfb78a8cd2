"""Outputs of a command: built in memory, then committed as one set (written into a
temporary folder beside the output folder and swapped in at once), and progress on the
terminal.  Reports are rendered by :mod:`linkwright.render` (``Report`` is re-exported
here)."""
from __future__ import annotations

import errno
import json
import os
import sys
from pathlib import Path

import pandas as pd

from . import __version__
from .atomic import make_parents, make_temp_dir, remove_empty, remove_tree, swap_in
from .interrupt import held_signals
from .render import Report, have_matplotlib

__all__ = ["Outputs", "OutputFolderError", "OutputWriteError", "Report", "Progress",
           "have_matplotlib", "MARKER"]

#: the file that marks a folder as a linkwright output set (it lists the set's entries)
MARKER = ".linkwright.json"


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


class Progress:
    """Progress on stderr while long work runs: one-line messages and tqdm bars, shown only
    when stderr is a terminal and not ``quiet`` (silent in pipes, logs and tests; tqdm
    is imported only then)."""

    def __init__(self, quiet: bool = False, stream=None):
        self.stream = stream if stream is not None else sys.stderr
        isatty = getattr(self.stream, "isatty", None)
        self.on = not quiet and bool(isatty and isatty())

    def __call__(self, msg: str) -> None:
        if self.on:
            from tqdm.std import tqdm
            tqdm.write(f"linkwright: {msg}", file=self.stream)
            self.stream.flush()

    def bar(self, iterable=None, *, total=None, desc: str = "", unit: str = "it"):
        """``iterable`` wrapped in a progress bar (or a bar to ``update(n)`` by hand when
        ``iterable`` is None); the iterable itself / a no-op bar when progress is off."""
        if not self.on:
            return _NoBar(iterable)
        from tqdm.std import tqdm
        return tqdm(iterable, total=total, desc=f"linkwright: {desc}" if desc else None,
                    unit=unit, file=self.stream, leave=False, dynamic_ncols=True)


class _NoBar:
    """The bar of a silent :class:`Progress`: iterates, updates and closes doing nothing."""

    def __init__(self, iterable=None):
        self.iterable = iterable

    def __iter__(self):
        return iter(self.iterable if self.iterable is not None else ())

    def update(self, n=1):
        pass

    def set_postfix_str(self, s=""):
        pass

    @staticmethod
    def write(text, file=None):
        print(text, file=file if file is not None else sys.stdout, flush=True)

    def close(self):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False
