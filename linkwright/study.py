"""Study files (TOML): reading (a binary or malformed file is an error naming it), checking
against the command's schema (:func:`load_study`, schemas in :mod:`linkwright.schema`) and
typed getters over the checked tables; every error names the file and the dotted key."""
from __future__ import annotations

import math
import re
import sys
from pathlib import Path

import numpy as np

try:  # Python ≥ 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["Study", "StudyError", "MISSING", "load_study", "read_toml", "study_command"]

MISSING = object()


class StudyError(ValueError):
    """A study file is malformed or a key has a wrong value.

    The message reads ``<file>: key '<key>': <what was expected>``.
    """

    def __init__(self, path, key, message):
        self.path, self.key = str(path), key
        message = _plain(str(message))
        where = f"{self.path}: " + (f"key '{key}': " if key else "")
        super().__init__(where + message)


def _plain(message: str) -> str:
    """``message`` without numpy reprs (``np.float64(1.5)`` → ``1.5``, ``array([1, 2])`` →
    ``[1, 2]``): a safety net for values formatted deep inside the packages."""
    message = re.sub(r"np\.\w+\(([^()]*)\)", r"\1", message)
    return re.sub(r"\barray\((\[[^()]*\])(?:, dtype=\w+)?\)", r"\1", message)


def read_toml(path) -> dict:
    """The tables of a TOML file; a missing, unreadable, binary or malformed file is a
    :class:`StudyError` naming it."""
    try:
        with open(path, "rb") as f:
            raw = f.read()
    except FileNotFoundError:
        raise StudyError(path, None, "file not found") from None
    except IsADirectoryError:
        raise StudyError(path, None, "is a folder, not a study file (TOML)") from None
    except OSError as e:
        raise StudyError(path, None, f"cannot read it: {e.strerror or e}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise StudyError(path, None, f"not a text file (byte {e.start} is not UTF-8); a study "
                         "file is TOML text") from None
    if "\x00" in text:
        raise StudyError(path, None, "not a text file (it holds NUL bytes); a study file is "
                         "TOML text") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise StudyError(path, None, f"malformed TOML: {e}") from None


def study_command(path, data: dict) -> str | None:
    """``[study].command`` of a study file's tables (None when absent)."""
    from .schema import COMMANDS
    meta = data.get("study", {})
    if not isinstance(meta, dict):
        raise StudyError(path, "study", f"expected a table [study], got {type(meta).__name__}")
    cmd = meta.get("command")
    if cmd is not None and cmd not in COMMANDS:
        raise StudyError(path, "study.command", f"expected one of "
                         f"{', '.join(map(repr, COMMANDS))}, got {cmd!r}")
    return cmd


def load_study(path, command: str | None = None, warn=None) -> "Study":
    """Read a study file and check it against the schema of ``command`` (default: its
    ``[study].command``): the returned :class:`Study` holds the validated tables with the
    schema's defaults filled in.

    Raises
    ------
    StudyError
        The file, the dotted key and what was wrong; a study of another kind says which.
    """
    from .schema import dump, validate
    data = read_toml(path)
    declared = study_command(path, data)
    if command is None:
        if declared is None:
            raise StudyError(path, "study.command", "missing; `linkwright run` reads the "
                             "command from it: add [study] command = \"synth\" (or "
                             "\"stiffness\", \"approx\", \"analyze\"), or run the study "
                             "with its command")
        command = declared
    elif declared is not None and declared != command:
        raise StudyError(path, "study.command", f"this is a {declared} study; run it with "
                         f"`linkwright {declared}` or `linkwright run`, not `linkwright "
                         f"{command}`")
    model = validate(path, data, command)
    study = Study(path, dump(model), warn=warn)
    study.command = command
    return study


def _print_warning(message: str) -> None:
    print(f"linkwright: warning: {message}", file=sys.stderr, flush=True)


class Study:
    """A view of (a section of) a TOML study file with typed getters.

    Made by :func:`load_study`, it holds tables already checked against the command's
    schema (:mod:`linkwright.schema`), so the getters only convert; made directly, it
    reads the file unchecked.
    """

    def __init__(self, path, data=None, prefix: str = "", warn=None):
        self.path = Path(path)
        if data is None:
            data = read_toml(path)
        self.data, self.prefix = data, prefix
        self.command = None
        self._warn = warn or _print_warning

    def warn(self, key, message) -> None:
        """Print a one-line warning naming the file and the key (no Python warning lines)."""
        self._warn(str(StudyError(self.path, self._key(key), message)))

    def _key(self, key):
        return f"{self.prefix}{key}" if key else self.prefix.rstrip(".")

    def error(self, key, message) -> StudyError:
        return StudyError(self.path, self._key(key), message)

    def has(self, key) -> bool:
        return key in self.data

    def section(self, key, required: bool = True) -> "Study | None":
        v = self.data.get(key, MISSING)
        if v is MISSING:
            if required:
                raise self.error(key, "missing section")
            return None
        if not isinstance(v, dict):
            raise self.error(key, f"expected a table [{self._key(key)}], got {type(v).__name__}")
        return Study(self.path, v, self._key(key) + ".", self._warn)

    def sections(self, key, required: bool = True) -> list["Study"]:
        """An array of tables ``[[key]]``."""
        v = self.data.get(key, MISSING)
        if v is MISSING:
            if required:
                raise self.error(key, "missing; expected one or more [[" + self._key(key) + "]]")
            return []
        if not isinstance(v, list) or not all(isinstance(x, dict) for x in v):
            raise self.error(key, f"expected an array of tables [[{self._key(key)}]]")
        return [Study(self.path, x, f"{self._key(key)}[{i}].", self._warn)
                for i, x in enumerate(v)]

    def get(self, key, kind: str = "float", default=MISSING, *, choices=None, low=None,
            high=None, length=None):
        """A validated value.

        kind: ``str``, ``float``, ``int``, ``bool``, ``vec`` (list of numbers),
        ``vec3``, ``points`` (list of 3-vectors), ``matrix`` (list of equal rows),
        ``strs`` (list of strings), ``any``.
        """
        v = self.data.get(key, MISSING)
        if v is MISSING:
            if default is MISSING:
                raise self.error(key, f"missing; expected {_describe(kind, choices, length)}")
            return default
        out = self._convert(key, v, kind, length)
        if choices is not None and out not in choices:
            raise self.error(key, f"expected one of {', '.join(map(repr, choices))}, got {v!r}")
        if kind in ("float", "int"):
            if low is not None and out < low:
                raise self.error(key, f"expected a value ≥ {low}, got {v!r}")
            if high is not None and out > high:
                raise self.error(key, f"expected a value ≤ {high}, got {v!r}")
        return out

    def _convert(self, key, v, kind, length):
        def bad(expected):
            return self.error(key, f"expected {expected}, got {v!r} ({type(v).__name__})")

        if kind == "any":
            return v
        if kind == "str":
            if not isinstance(v, str) or not v:
                raise bad("a non-empty string")
            return v
        if kind == "bool":
            if not isinstance(v, bool):
                raise bad("true or false")
            return v
        if kind == "int":
            if isinstance(v, bool) or not isinstance(v, int):
                raise bad("an integer")
            return v
        if kind == "float":
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise bad("a finite number")
            return float(v)
        if kind == "strs":
            if not isinstance(v, list) or not all(isinstance(x, str) and x for x in v):
                raise bad("a list of strings")
            return list(v)
        if kind in ("vec", "vec3"):
            n = 3 if kind == "vec3" else length
            if not _numbers(v) or (n is not None and len(v) != n):
                raise bad(f"a list of {n or 'some'} numbers")
            return np.array(v, float)
        if kind in ("points", "matrix"):
            if not isinstance(v, list) or not v or not all(_numbers(r) for r in v):
                raise bad("a list of rows of numbers")
            width = 3 if kind == "points" else len(v[0])
            if any(len(r) != width for r in v):
                raise bad(f"rows of {width} numbers each")
            if length is not None and len(v) != length:
                raise bad(f"{length} rows")
            return np.array(v, float)
        raise ValueError(f"unknown kind {kind}")


def _numbers(v):
    return isinstance(v, list) and all(not isinstance(x, bool) and isinstance(x, (int, float))
                                       and math.isfinite(x) for x in v)


def _describe(kind, choices, length):
    if choices:
        return "one of " + ", ".join(map(repr, choices))
    return {"str": "a string", "float": "a number", "int": "an integer", "bool": "true or false",
            "vec3": "a list of 3 numbers", "vec": f"a list of {length or 'some'} numbers",
            "points": "a list of [x, y, z] points", "matrix": "a list of rows of numbers",
            "strs": "a list of strings"}.get(kind, kind)
