"""Study grids: a ``[grid]`` table in a study file turns it into many cases.

Each key of ``[grid]`` is the dotted path of a numeric key of the study
(``"hexapod.leg_stiffness"``, ``"pose.position[2]"``); its value is a list of numbers, a
range ``{start = , stop = , num = }`` or samples ``{sampler = "lhs" | "sobol", n = ,
bounds = [lo, hi], seed = }``.  Lists and ranges are combined as a product; the sampled
keys are drawn jointly (one design of as many dimensions as sampled keys, which must agree
on ``n`` and ``seed``) and that design is one more factor of the product.

Each case is the study with its values substituted, checked against the command's schema
and run by the command's own ``run`` (outputs kept in memory, never written); its summary
(the headline figures) is flattened into one row.  A case that raises is recorded with its
message in the ``error`` column.  Distribution and partitioned output are in
:mod:`linkwright.distributed`.
"""
from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .study import StudyError, read_toml, study_command

__all__ = ["GridStudy", "load_grid_study", "run_case", "run_partition", "flatten_summary"]

_PART = re.compile(r"([^.\[\]]+)|\[(\d+)\]")


@dataclass
class GridStudy:
    """A study with a ``[grid]`` table, expanded into cases.

    Attributes
    ----------
    path : Path
        The study file.
    command : str
        The study command (``stiffness``, ``synth``, ``approx``, ``analyze``).
    base : dict
        The validated study without ``[grid]`` (defaults filled in).
    keys : list of str
        The grid keys, in file order (the parameter columns of the table).
    cases : list of dict
        One mapping key → value per case.
    """

    path: Path
    command: str
    base: dict
    keys: list
    cases: list = field(default_factory=list)

    def case_data(self, i: int) -> dict:
        """The study tables of case ``i`` (not yet checked against the schema)."""
        data = copy.deepcopy(self.base)
        for key, value in self.cases[i].items():
            _assign(data, _parse_path(self.path, key), value)
        return data

    def fingerprint(self) -> str:
        """A hash of the base study and the cases (a resumed run must match it)."""
        text = json.dumps([self.command, self.base, self.cases], sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def _parse_path(path, key: str) -> list:
    parts, pos = [], 0
    for m in _PART.finditer(key):
        if m.start() != pos and key[pos:m.start()] != ".":
            break
        parts.append(m.group(1) if m.group(1) is not None else int(m.group(2)))
        pos = m.end()
    if not parts or pos != len(key):
        raise StudyError(path, f"grid.{key}", "expected a dotted path of a study key "
                         "(e.g. \"hexapod.leg_stiffness\" or \"pose.position[2]\")")
    return [int(p) if isinstance(p, str) and p.isdigit() else p for p in parts]


def _lookup(data, parts):
    v = data
    for p in parts:
        if isinstance(p, int):
            if not isinstance(v, list) or not -len(v) <= p < len(v):
                return _MISSING
            v = v[p]
        else:
            if not isinstance(v, dict) or p not in v:
                return _MISSING
            v = v[p]
    return v


def _assign(data, parts, value):
    v = data
    for p in parts[:-1]:
        v = v[p]
    v[parts[-1]] = value


_MISSING = object()


def _is_number(x) -> bool:
    return not isinstance(x, bool) and isinstance(x, (int, float)) and math.isfinite(x)


def _values(path, key, spec) -> list | dict:
    """A list of values, or the sampler spec (dict) to be drawn jointly."""
    k = f"grid.{key}"
    if isinstance(spec, list):
        if not spec or not all(_is_number(x) for x in spec):
            raise StudyError(path, k, f"expected a non-empty list of finite numbers, got {spec!r}")
        return list(spec)
    if not isinstance(spec, dict):
        raise StudyError(path, k, "expected a list of numbers, a range {start, stop, num} "
                         f"or samples {{sampler, n, bounds, seed}}, got {spec!r}")
    if "sampler" in spec:
        extra = set(spec) - {"sampler", "n", "bounds", "seed"}
        if extra:
            raise StudyError(path, k, f"unknown key {sorted(extra)[0]!r}; samples take "
                             "sampler, n, bounds, seed")
        if spec["sampler"] not in ("lhs", "sobol"):
            raise StudyError(path, k, f"sampler: expected 'lhs' or 'sobol', got {spec['sampler']!r}")
        n = spec.get("n")
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise StudyError(path, k, f"n: expected an integer ≥ 1, got {n!r}")
        b = spec.get("bounds")
        if not (isinstance(b, list) and len(b) == 2 and all(_is_number(x) for x in b)
                and b[0] < b[1]):
            raise StudyError(path, k, f"bounds: expected [lo, hi] with lo < hi, got {b!r}")
        seed = spec.get("seed", 0)
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise StudyError(path, k, f"seed: expected an integer ≥ 0, got {seed!r}")
        return {"sampler": spec["sampler"], "n": n, "bounds": b, "seed": seed}
    if set(spec) != {"start", "stop", "num"}:
        missing = sorted({"start", "stop", "num"} - set(spec))
        extra = sorted(set(spec) - {"start", "stop", "num"})
        raise StudyError(path, k, "a range needs start, stop and num: "
                         + (f"missing {missing[0]!r}" if missing else f"unknown key {extra[0]!r}"))
    s, e, n = spec["start"], spec["stop"], spec["num"]
    if not (_is_number(s) and _is_number(e)):
        raise StudyError(path, k, f"range start and stop: expected finite numbers, got {s!r}, {e!r}")
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise StudyError(path, k, f"range num: expected an integer ≥ 1, got {n!r}")
    return [float(x) for x in np.linspace(s, e, n)]


def _samples(path, keys, specs) -> list[tuple]:
    first = specs[0]
    for key, s in zip(keys, specs):
        if (s["sampler"], s["n"], s["seed"]) != (first["sampler"], first["n"], first["seed"]):
            raise StudyError(path, f"grid.{key}", "sampled keys are drawn jointly: they must "
                             f"share sampler, n and seed (as grid.{keys[0]})")
    from scipy.stats import qmc
    d, n = len(specs), first["n"]
    if first["sampler"] == "lhs":
        u = qmc.LatinHypercube(d=d, seed=first["seed"]).random(n)
    else:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")      # n not a power of 2: balance warning
            u = qmc.Sobol(d=d, scramble=True, seed=first["seed"]).random(n)
    lo = np.array([s["bounds"][0] for s in specs], float)
    hi = np.array([s["bounds"][1] for s in specs], float)
    x = qmc.scale(u, lo, hi)
    return [tuple(float(v) for v in row) for row in x]


def load_grid_study(path, command: str | None = None) -> GridStudy:
    """Read a study file with a ``[grid]`` table and expand it into cases.

    Raises
    ------
    StudyError
        No or an empty ``[grid]``; a grid key that is not a key of the study, not a
        number, or whose values are malformed (the message names ``grid.KEY``); or the
        base study itself is invalid.
    """
    from .schema import dump, validate
    raw = read_toml(path)
    grid = raw.pop("grid", None)
    if not isinstance(grid, dict) or not grid:
        raise StudyError(path, "grid", "missing or empty; a grid study has a [grid] table of "
                         "dotted study keys and their values")
    declared = study_command(path, raw)
    command = command or declared
    if command is None:
        raise StudyError(path, "study.command", "missing; add [study] command = "
                         "\"stiffness\" (or synth, approx, analyze)")
    if declared is not None and declared != command:
        raise StudyError(path, "study.command", f"this is a {declared} study, not {command}")
    base = dump(validate(path, raw, command))
    keys, lists, skeys, sspecs = [], [], [], []
    for key, spec in grid.items():
        parts = _parse_path(path, key)
        target = _lookup(base, parts)
        if target is _MISSING:
            raise StudyError(path, f"grid.{key}", f"unknown key: {key!r} is not a key of "
                             f"this {command} study (give it a value in the study first)")
        if not _is_number(target):
            raise StudyError(path, f"grid.{key}", f"not a numeric key: the study's value is "
                             f"{target!r}; a grid varies single numbers (index lists as "
                             f"{key}[0])")
        vals = _values(path, key, spec)
        if isinstance(target, int):
            def as_int(v):
                if float(v) != int(v):
                    raise StudyError(path, f"grid.{key}", f"an integer key: expected whole "
                                     f"numbers, got {v!r}")
                return int(v)
            if isinstance(vals, list):
                vals = [as_int(v) for v in vals]
            else:
                raise StudyError(path, f"grid.{key}", "an integer key cannot be sampled")
        keys.append(key)
        if isinstance(vals, list):
            lists.append((key, vals))
        else:
            skeys.append(key)
            sspecs.append(vals)
    factors = [[((k, v),) for v in vals] for k, vals in lists]
    if skeys:
        factors.append([tuple(zip(skeys, row)) for row in _samples(path, skeys, sspecs)])
    cases = [dict(itertools.chain.from_iterable(combo)) for combo in itertools.product(*factors)]
    cases = [{k: c[k] for k in keys} for c in cases]
    return GridStudy(Path(path), command, base, keys, cases)


def flatten_summary(summary: dict) -> dict:
    """A command's summary as flat columns: quantities ``{value, unit}`` become
    ``name [unit]``, short vectors one column per component, nested tables
    ``outer.inner``; long lists and the file list are left out."""
    row: dict = {}

    def put(name, v):
        if isinstance(v, dict) and set(v) == {"value", "unit"}:
            u = v["unit"]
            put(f"{name} [{u}]" if u and u != "1" else name, v["value"])
        elif isinstance(v, dict):
            for k, x in v.items():
                put(f"{name}.{k}", x)
        elif isinstance(v, (list, tuple, np.ndarray)):
            v = list(np.asarray(v).ravel()) if isinstance(v, np.ndarray) else list(v)
            if len(v) <= 12 and all(_is_scalar(x) for x in v):
                base, unit = (name.rsplit(" [", 1) + [""])[:2] if name.endswith("]") and " [" in name \
                    else (name, "")
                for i, x in enumerate(v):
                    put(f"{base}[{i}]" + (f" [{unit}" if unit else ""), x)
        elif _is_scalar(v):
            row[name] = v.item() if isinstance(v, np.generic) else v

    for k, v in summary.items():
        if k not in ("command", "files", "results"):
            put(k, v)
    return row


def _is_scalar(x) -> bool:
    return x is None or isinstance(x, (bool, int, float, str, np.generic))


def run_case(command: str, path, data: dict) -> dict:
    """Run one case (study tables ``data``) by the command's own code and return its
    flattened figures plus ``error`` (None, or ``Type: message`` when it raised)."""
    import tempfile
    from .cli import _commands
    from .output import Outputs, Progress
    from .schema import dump, validate
    from .render import figures_off
    from .study import Study
    try:
        model = validate(path, data, command)
        study = Study(path, dump(model), warn=lambda m: None)
        study.command = command
        with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings(), figures_off():
            warnings.simplefilter("ignore")
            # outputs stay in memory: the Outputs set is never committed
            summary = _commands()[command](study, Outputs(Path(tmp) / "out", command),
                                           Progress(quiet=True))
        row = flatten_summary(summary)
        row["error"] = None
    except Exception as e:  # a case that fails is a row, not the end of the study
        text = str(e)
        if text.startswith(f"{path}: "):     # the study file is the same for every case
            text = text[len(f"{path}: "):]
        row = {"error": f"{type(e).__name__}: {text}"}
    return row


def run_partition(command: str, path, cases: list[tuple[int, dict, dict]]) -> list[dict]:
    """Run the cases ``(index, parameters, study tables)`` of one partition; the rows
    (``case``, the parameters, the figures, ``error``)."""
    rows = []
    for i, params, data in cases:
        rows.append({"case": i, **params, **run_case(command, path, data)})
    return rows
