"""Issue 11's robustness census as tests: every bad input of :mod:`tests.robustness.cases`
raises a clear project error naming its argument, every awkward-but-valid input gives the
reference answer.  The table itself: ``python -m tests.robustness.census``."""
from __future__ import annotations

from collections import Counter

import pytest

from . import cases as C
from .census import PACKAGES, classify_bad, classify_valid

#: Bad inputs not yet refused clearly (each still runs; its test fails once it is fixed, as
#: a reminder to take it out).  Empty: every bad input of the census is refused clearly.
KNOWN_OPEN: set = set()

BAD = {c.name: c for c in C.BAD}
VALID = {c.name: c for c in C.VALID}


def test_catalogue_size_and_coverage():
    assert len(BAD) == len(C.BAD) >= 400 and len(VALID) == len(C.VALID) >= 70
    bad, valid = Counter(c.package for c in C.BAD), Counter(c.package for c in C.VALID)
    assert all(bad[p] >= 30 and valid[p] >= 5 for p in PACKAGES), (bad, valid)
    assert KNOWN_OPEN <= set(BAD), KNOWN_OPEN - set(BAD)


@pytest.mark.parametrize("name", list(BAD))
def test_bad_input_is_refused_clearly(name):
    kind, what = classify_bad(BAD[name])
    if name in KNOWN_OPEN:
        assert kind != "clear", f"{name} is fixed: take it out of KNOWN_OPEN"
        return
    assert kind == "clear", f"{name}: {kind}: {what}"


@pytest.mark.parametrize("name", list(VALID))
def test_valid_input_is_answered_correctly(name):
    kind, what = classify_valid(VALID[name])
    assert kind == "correct", f"{name}: {kind}: {what}"
