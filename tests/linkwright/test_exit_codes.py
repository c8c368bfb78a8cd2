"""Exit status and JSON summaries: numerical failures exit 1 saying what failed (never 2,
which means bad input and names the key); ``--json`` is valid JSON whatever the numbers."""
import json
import math
import re
import time

import numpy as np
import pytest

import linkwright.cli as cli
import linkwright.cmd_synth as cmd_synth
from linkwright.cli import jsonable, main
from linkwright.examples import folder as examples_folder

EX = examples_folder()


def run(args, capsys):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def strict_json(text):
    def bad(name):
        raise AssertionError(f"not JSON: {name}")
    return json.loads(text, parse_constant=bad)


def test_a_singular_matrix_exits_1_and_says_what_failed(tmp_path, capsys, monkeypatch):
    def singular(*a, **k):
        raise np.linalg.LinAlgError("Singular matrix")   # a ValueError subclass
    monkeypatch.setattr(cmd_synth, "enumerate_dyads", singular)
    study = EX / "seed001_rrr.toml"
    code, _, err = run(["synth", study, "-o", tmp_path / "o"], capsys)
    assert code == 1
    assert "failed" in err and "LinAlgError: Singular matrix" in err and str(study) in err
    assert "error:" not in err
    assert not (tmp_path / "o").exists()


def test_a_plain_value_error_deep_inside_is_a_failure_not_bad_input(tmp_path, capsys,
                                                                    monkeypatch):
    def deep(*a, **k):
        raise ValueError("array must not contain infs or NaNs")
    monkeypatch.setattr(cmd_synth, "enumerate_dyads", deep)
    code, _, err = run(["synth", EX / "seed001_rrr.toml", "-o", tmp_path / "o"], capsys)
    assert code == 1 and "ValueError: array must not contain infs or NaNs" in err


def test_json_summary_never_prints_nan(tmp_path, capsys, monkeypatch):
    def numbers(study, out, progress):
        out.add("x.txt", "x")
        return {"command": "synth", "nan": math.nan, "inf": np.inf, "ninf": -np.inf,
                "np_nan": np.float64("nan"), "n": np.int64(3), "v": np.array([1.0, np.nan]),
                "ok": 0.5}
    real = cli._commands
    monkeypatch.setattr(cli, "_commands", lambda: dict(real(), synth=numbers))
    code, out, _ = run(["synth", EX / "seed001_rrr.toml", "-o", tmp_path / "o", "--json"],
                       capsys)
    assert code == 0
    s = strict_json(out)
    assert s["nan"] is None and s["np_nan"] is None and s["v"] == [1.0, None]
    assert s["inf"] == "inf" and s["ninf"] == "-inf" and s["n"] == 3 and s["ok"] == 0.5


def test_json_summary_of_a_real_study_is_strict_json(tmp_path, capsys):
    code, out, _ = run(["synth", EX / "seed001_rrr.toml", "-o", tmp_path / "o", "--json"],
                       capsys)
    assert code == 0 and strict_json(out)["variants"] == 36


@pytest.mark.parametrize("value, expected", [(float("nan"), None), (float("inf"), "inf"),
                                             ((1, np.float32(2.5)), [1, 2.5]),
                                             ({"a": np.bool_(True)}, {"a": True})])
def test_jsonable(value, expected):
    assert jsonable(value) == expected



@pytest.mark.parametrize("command, study, pattern, line, key, words", [
    ("stiffness", "hexapod.toml", r"(?m)^x\s*=.*$", "x = [-0.1, 0.1, 1e9]", "map.x",
     "count from 1 to"),
    ("approx", "seed004_cylinder.toml", r"(?m)^B0\s*=.*$", "B0 = 0", "cylinder.B0",
     "length > 0"),
])
def test_oversized_maps_and_zero_lengths_are_bad_input_found_before_any_work(
        tmp_path, capsys, command, study, pattern, line, key, words):
    text = re.sub(pattern, line, (EX / study).read_text())
    bad = tmp_path / study
    bad.write_text(text)
    t0 = time.perf_counter()
    code, _, err = run([command, bad, "-o", tmp_path / "out"], capsys)
    assert code == 2 and f"key '{key}'" in err and words in err, err
    assert time.perf_counter() - t0 < 5 and not (tmp_path / "out").exists()
