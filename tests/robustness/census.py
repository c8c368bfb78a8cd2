"""Classify every case of :mod:`tests.robustness.cases` and print the census table.

Bad inputs: ``clear`` (the package's own error — a ValueError subclass from closure,
synthesis, stiffness, approx or linkwright — whose message names the argument),
``unclear`` (any other exception, or a project error that does not name the argument),
``nan`` (returned a result holding NaN or inf without an error), ``accepted`` (returned).
Valid inputs: ``correct``, ``wrong`` (the reference check failed) or ``raised``.

``python -m tests.robustness.census [--details]`` prints the table (per package and in
total) in Markdown; ``--details`` lists every case that is not clear or not correct.
"""
from __future__ import annotations

import re
import sys
import time
import warnings
from collections import Counter

import numpy as np
import pandas as pd

from . import cases as C

PACKAGES = ("closure", "synthesis", "stiffness", "approx", "linkwright")
BAD_KINDS = ("clear", "unclear", "nan", "accepted")
VALID_KINDS = ("correct", "wrong", "raised")


def project_error(e: BaseException) -> bool:
    """One of the project's own input errors: a ValueError subclass defined in one of its
    packages (MechanismError, SynthesisError, StiffnessError, ApproxError, StudyError ...),
    or the command's refusal (exit status 2, :class:`cases.CliError`)."""
    if isinstance(e, C.CliError):
        return True
    mod = type(e).__module__.split(".")[0]
    return isinstance(e, ValueError) and mod in PACKAGES


def _word(message: str, word: str) -> bool:
    return re.search(r"(?<![\w.])" + re.escape(word) + r"(?![\w])", message) is not None


def names(message: str, arg: str, cli: bool = False) -> bool:
    """Whether ``message`` mentions ``arg`` as a word (``skew: p``).  A study key
    (``cli``) is named by the key itself (``key 'approx.n'``), by its table and its last
    part (``key 'hexapod': leg_stiffness: ...``), or by the entry of an array of tables that
    holds it (``key 'mechanism.joint[1]': joint 'B': link_b ...``)."""
    if _word(message, arg):
        return True
    if not cli or "." not in arg:
        return False
    parent, leaf = arg.rsplit(".", 1)
    return _word(message, parent) and (parent.endswith("]") or _word(message, leaf))


def _has_nonfinite(x, depth=0) -> bool:
    if depth > 4:
        return False
    if isinstance(x, (pd.DataFrame, pd.Series)):
        num = x.select_dtypes("number") if isinstance(x, pd.DataFrame) else x
        try:
            return not np.all(np.isfinite(np.asarray(num, float)))
        except (TypeError, ValueError):
            return False
    if isinstance(x, (float, complex, np.floating, np.complexfloating)):
        return not np.isfinite(x)
    if isinstance(x, np.ndarray):
        return x.dtype.kind in "fc" and not np.all(np.isfinite(x))
    if isinstance(x, dict):
        if "value" in x and "unit" in x and x["value"] is None:
            return True      # a quantity of the command's JSON summary: NaN prints as null
        return any(_has_nonfinite(v, depth + 1) for v in x.values())
    if isinstance(x, (list, tuple)):
        return any(v is None or _has_nonfinite(v, depth + 1) for v in x)
    if hasattr(x, "__dict__") and not isinstance(x, type):
        return any(_has_nonfinite(v, depth + 1) for k, v in vars(x).items()
                   if not k.startswith("_") and k != "mechanism")
    if isinstance(x, str) and depth > 0:
        return x in ("inf", "-inf")
    return False


def classify_bad(case: C.BadCase) -> tuple[str, str]:
    """(kind, what happened)."""
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            out = case.call()
    except Exception as e:   # noqa: BLE001 - the census records what escaped
        text = f"{type(e).__name__}: {e}"
        if project_error(e) and names(str(e), case.arg, cli=case.package == "linkwright"):
            return "clear", text
        return "unclear", text
    if _has_nonfinite(out):
        return "nan", f"returned {type(out).__name__} with NaN/inf"
    return "accepted", f"returned {type(out).__name__}"


def classify_valid(case: C.ValidCase) -> tuple[str, str]:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ok = case.check()
    except Exception as e:   # noqa: BLE001
        return "raised", f"{type(e).__name__}: {e}"
    if isinstance(ok, (bool, np.bool_)) and bool(ok):
        return "correct", ""
    return "wrong", f"check returned {ok!r}"


def run(bad=None, valid=None):
    """Classify the cases; returns two DataFrames (bad, valid) with package, name, kind, what."""
    bad = C.BAD if bad is None else bad
    valid = C.VALID if valid is None else valid
    rb = [(c.package, c.name, *classify_bad(c)) for c in bad]
    rv = [(c.package, c.name, *classify_valid(c)) for c in valid]
    cols = ["package", "name", "kind", "what"]
    return pd.DataFrame(rb, columns=cols), pd.DataFrame(rv, columns=cols)


def table(db: pd.DataFrame, dv: pd.DataFrame) -> str:
    head = ("| package | bad inputs tried | clear errors | raw / unclear exceptions | silent NaN "
            "| silently accepted | valid inputs | correct | wrong | raised |")
    lines = [head, "|" + "---|" * 10]
    for pkg in PACKAGES + ("total",):
        b = db if pkg == "total" else db[db.package == pkg]
        v = dv if pkg == "total" else dv[dv.package == pkg]
        cb, cv = Counter(b.kind), Counter(v.kind)
        name = f"**{pkg}**" if pkg == "total" else pkg
        lines.append(f"| {name} | {len(b)} | " + " | ".join(str(cb[k]) for k in BAD_KINDS)
                     + f" | {len(v)} | " + " | ".join(str(cv[k]) for k in VALID_KINDS) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    t = time.perf_counter()
    db, dv = run()
    print(table(db, dv))
    print(f"\n{len(db)} bad and {len(dv)} valid cases in {time.perf_counter() - t:.1f} s")
    if "--details" in argv:
        for _, r in db[db.kind != "clear"].iterrows():
            print(f"- BAD {r['kind']}: {r['name']}: {r['what'][:300]}")
        for _, r in dv[dv.kind != "correct"].iterrows():
            print(f"- VALID {r['kind']}: {r['name']}: {r['what'][:300]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
