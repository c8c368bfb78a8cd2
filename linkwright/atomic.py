"""Folders swapped in at once: a new set of files is written into a temporary folder beside
the target and then renamed onto it, so that the target holds either the old set or the
new one, never a mix.

On Linux the swap of a non-empty target is one ``renameat2(RENAME_EXCHANGE)`` call;
elsewhere (or on file systems without it) the old folder is renamed aside and the new one
renamed in, with SIGINT and SIGTERM held in between by the caller.
"""
from __future__ import annotations

import ctypes
import errno
import os
import secrets
import shutil
import stat
import sys
from pathlib import Path
from typing import Callable

__all__ = ["TEMP_PREFIX", "write_new_file", "make_temp_dir", "make_parents", "remove_empty",
           "remove_tree", "swap_in"]

#: name prefix of every temporary folder linkwright makes beside an output folder
TEMP_PREFIX = ".linkwright-"

_RENAME_EXCHANGE = 2
_AT_FDCWD = -100
_renameat2_fn = None          # None: not looked up yet; False: unavailable


def write_new_file(path, data: bytes) -> None:
    """Write a new file at once: into a temporary file beside it, then hard-linked into
    place, which fails if ``path`` exists (``FileExistsError``), so an existing file is
    never overwritten and ``path`` never holds part of ``data``.  Where hard links are not
    supported, the file is created exclusively and written."""
    path = Path(path)
    tmp = path.parent / f"{TEMP_PREFIX}{secrets.token_hex(6)}.tmp"
    with open(tmp, "xb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    try:
        os.link(tmp, path)
    except FileExistsError:
        raise
    except OSError:                  # no hard links here: exclusive create instead
        with open(path, "xb") as f:
            f.write(data)
    finally:
        os.unlink(tmp)


def make_temp_dir(parent: Path) -> Path:
    """A new, empty folder ``parent/.linkwright-<random>`` (mode as by ``mkdir``)."""
    while True:
        p = Path(parent) / f"{TEMP_PREFIX}{secrets.token_hex(6)}"
        try:
            os.mkdir(p)
            return p
        except FileExistsError:  # pragma: no cover - 48 random bits
            continue


def make_parents(folder: Path) -> list[Path]:
    """Create ``folder`` and its missing ancestors; return the ones created, outermost first."""
    missing = []
    p = Path(folder)
    while not p.exists():
        missing.append(p)
        if p.parent == p:
            break
        p = p.parent
    created = []
    for p in reversed(missing):
        try:
            os.mkdir(p)
            created.append(p)
        except FileExistsError:
            pass
    return created


def remove_empty(created: list[Path]) -> None:
    """Remove the folders of :func:`make_parents` again, innermost first, if still empty."""
    for p in reversed(created):
        try:
            os.rmdir(p)
        except OSError:
            pass


def remove_tree(path: Path) -> None:
    """Remove a folder linkwright owns, making read-only parts writable where needed."""
    def retry(func, p, exc_info):
        try:
            os.chmod(os.path.dirname(p), stat.S_IRWXU)
            if os.path.isdir(p) and not os.path.islink(p):
                os.chmod(p, stat.S_IRWXU)
            func(p)
        except OSError:
            pass
    if sys.version_info >= (3, 12):
        shutil.rmtree(path, onexc=retry)
    else:
        shutil.rmtree(path, onerror=retry)


def _renameat2():
    global _renameat2_fn
    if _renameat2_fn is None:
        _renameat2_fn = False
        try:
            fn = ctypes.CDLL(None, use_errno=True).renameat2
            fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                           ctypes.c_uint]
            fn.restype = ctypes.c_int
            _renameat2_fn = fn
        except (AttributeError, OSError, TypeError):
            pass
    return _renameat2_fn


def _exchange(a: Path, b: Path) -> bool:
    """Exchange two folders atomically; False when the system cannot."""
    global _renameat2_fn
    fn = _renameat2()
    if not fn:
        return False
    if fn(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    e = ctypes.get_errno()
    if e in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP, errno.EPERM):
        _renameat2_fn = False    # this system or file system cannot: use two renames
        return False
    raise OSError(e, os.strerror(e), str(b))


def swap_in(new: Path, target: Path, check: Callable[[Path], None], tries: int = 100) -> None:
    """Put folder ``new`` in place of ``target`` (same parent folder) in one step.

    Parameters
    ----------
    new : Path
        The complete new set; it is renamed (it no longer exists afterwards).
    target : Path
        The folder to create or replace; the folder it replaces is removed.
    check : callable
        ``check(target)`` raises if an existing non-empty ``target`` may not be replaced;
        called right before each replacement (another run may have put its set there).
    tries : int
        How often to retry when concurrent runs keep replacing ``target``.
    """
    new, target = Path(new), Path(target)
    for _ in range(tries):
        try:
            os.rename(new, target)           # target absent or an empty folder
            return
        except OSError as e:
            if e.errno not in (errno.ENOTEMPTY, errno.EEXIST):
                raise
        check(target)
        try:
            if _exchange(new, target):
                remove_tree(new)             # now the old set
                return
        except FileNotFoundError:            # target went away meanwhile: start again
            continue
        old = target.parent / f"{TEMP_PREFIX}{secrets.token_hex(6)}"
        try:
            os.rename(target, old)
        except FileNotFoundError:
            continue
        try:
            os.rename(new, target)
        except OSError as e:
            if e.errno not in (errno.ENOTEMPTY, errno.EEXIST):
                os.rename(old, target)       # put the old set back
                raise
            remove_tree(old)                 # another run's set came in between: retry
            continue
        remove_tree(old)
        return
    raise OSError(errno.EBUSY, "the folder kept changing under concurrent runs", str(target))
