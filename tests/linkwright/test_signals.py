"""SIGINT and SIGTERM during ``linkwright demo`` (a subprocess): exit 130 / 143 with a
message that says what was written; the demo is all-or-nothing; no temporary folder left."""
import json
import signal
import subprocess

import pytest

from linkwright.examples import studies
from linkwright.interrupt import Interrupted, catch_signals, reraise_caught
from linkwright.output import MARKER, Outputs

from .util import command, env, temporaries, tree

STUDIES = [p.stem for p in studies()]


def complete_demo(t: dict) -> bool:
    """The whole new demo set: index, every study's reports, markers; nothing old."""
    return ({"index.md", "index.html", MARKER} <= set(t) and "old.txt" not in t
            and json.loads(t[MARKER])["command"] == "demo"
            and all({f"{s}/report.md", f"{s}/report.html", f"{s}/{MARKER}"} <= set(t)
                    for s in STUDIES))


def _default_signals():
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, signal.SIG_DFL)


# early (imports), mid-run and late (writing); each signal at two of the three times
@pytest.mark.parametrize("sig, after", [(signal.SIGINT, 0.5), (signal.SIGTERM, 1.5),
                                        (signal.SIGINT, 3.0), (signal.SIGTERM, 0.5)],
                         ids=["SIGINT-0.5", "SIGTERM-1.5", "SIGINT-3.0", "SIGTERM-0.5"])
def test_a_signal_during_demo_leaves_all_or_nothing(tmp_path, sig, after):
    out = tmp_path / "demo"
    old = sig == signal.SIGINT          # SIGINT over a previous set, SIGTERM into a new folder
    if old:
        prev = Outputs(out, "demo")
        prev.add("old.txt", "a previous run")
        prev.add("index.html", "old index")
        prev.commit()
    before = tree(out) if old else None
    p = subprocess.Popen(command("demo", "-o", out, "--quiet"), cwd=tmp_path, env=env(),
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=_default_signals)
    try:
        p.wait(timeout=after)
    except subprocess.TimeoutExpired:
        p.send_signal(sig)
    _, err = p.communicate(timeout=300)
    assert temporaries(tmp_path) == []
    now = tree(out) if out.exists() else None
    if p.returncode == 0:                                 # it finished first
        assert complete_demo(now)
        return
    name = signal.Signals(sig).name
    assert p.returncode == 128 + sig, err
    assert f"interrupted by {name}" in err, err
    if "the outputs were written" in err:                 # the signal came after the swap
        assert complete_demo(now)
    else:
        assert "nothing was written" in err
        assert now == before                               # the old set, or no folder at all


def test_a_failure_that_follows_a_signal_is_the_interrupt():
    # code that catches the interrupt and fails on with an exception of its own (a plotting
    # library did: "ValueError: Invalid bounding box") still ends the run as interrupted
    with catch_signals():
        with pytest.raises(Interrupted) as info:
            try:
                try:
                    signal.raise_signal(signal.SIGINT)
                except KeyboardInterrupt:
                    raise ValueError("Invalid bounding box") from None
            except ValueError as e:
                reraise_caught(e)
    assert info.value.signum == signal.SIGINT and info.value.exit_code == 130
    with catch_signals():                   # a new run: an ordinary failure stays one
        reraise_caught(ValueError("no signal"))
