"""``linkwright approx`` on a mechanism (source = "mechanism"): a slider-crank given as a
``[mechanism]`` section, in every knot mode, its tables parsed back and checked against
the closed form s(θ) = −r sin θ + √(l² − r² cos² θ) − √(l² − r²)."""
import json

import numpy as np
import pandas as pd
import pytest

from approx import fit
from approx.fit import MAX_N
from linkwright.cli import main
from tests.approx.slider_crank import d2s, ds, s, study_toml

MODES = {"n": "n = 6", "delta": "delta = 1e-3", "knots": "knots = [{a}, {m1}, {m2}, {b}]"}


def run(tmp_path, capsys, a, b, mode, **kw):
    line = MODES[mode].format(a=a, b=b, m1=a + 0.3 * (b - a), m2=a + 0.65 * (b - a))
    path = tmp_path / f"slider_crank_{mode}.toml"
    path.write_text(study_toml(a, b, line, **kw))
    out = tmp_path / f"out_{mode}"
    code = main(["approx", str(path), "-o", str(out), "--json"])
    cap = capsys.readouterr()
    return code, cap, out, line


@pytest.mark.parametrize("a, b, mode", [(0.0, 1.2, "n"), (0.0, 1.2, "delta"),
                                        (0.0, 1.2, "knots"), (0.3, 1.5, "n"),
                                        (-0.6, 0.4, "delta")])
def test_approx_study_of_a_mechanism_in_every_knot_mode(tmp_path, capsys, a, b, mode):
    code, cap, out, line = run(tmp_path, capsys, a, b, mode)
    assert code == 0, cap.err
    summary = json.loads(cap.out)
    # the same fit from the closed form (the engine's analogs equal it to ~1e-15)
    kw = {"n": {"n": 6}, "delta": {"delta": 1e-3},
          "knots": {"knots": [a, a + 0.3 * (b - a), a + 0.65 * (b - a), b]}}[mode]
    ref = fit(s, ds, d2s, a, b, **kw)
    t = pd.read_csv(out / "coefficients.csv")
    assert list(t.columns) == ["x0", "x1", "k", "b", "c", "d", "sigma"]
    assert summary["intervals"] == len(t) == ref.n
    assert np.allclose(t.x0, ref.knots[:-1], rtol=0, atol=1e-9)
    assert np.allclose(t.x1, ref.knots[1:], rtol=0, atol=1e-9)
    for col in ("k", "b", "c", "d"):
        assert np.allclose(t[col], ref.table[col], rtol=1e-7, atol=1e-12), col
    assert np.allclose(t.sigma, ref.sigma, rtol=1e-7)
    if mode == "n":
        assert np.ptp(t.sigma) <= 1e-7 * t.sigma.max()
    if mode == "delta":
        assert t.sigma.max() <= 1e-3 * (1 + 1e-9)
    # the exact analogs column by column against the closed form, the surrogate against
    # the closed-form fit, and its error within the bound σ implies:
    # |F − f| ≤ sqrt((b − a)³ / 3) · sqrt(Σ σ² / γ)  (e(a) = e'(a) = 0, Cauchy–Schwarz)
    an = pd.read_csv(out / "analogs.csv")
    x = an.x.to_numpy()
    assert np.abs(an.f - s(x)).max() <= 1e-10
    assert np.abs(an.df - ds(x)).max() <= 1e-10
    assert np.abs(an.d2f - d2s(x)).max() <= 1e-10
    assert np.abs(an.F - ref.position(x)).max() <= 1e-9
    assert np.abs(an.d2F - ref.acceleration(x)).max() <= 1e-9
    bound = np.sqrt((b - a) ** 3 / 3) * np.sqrt(np.sum(t.sigma ** 2) / summary["gamma"]["value"])
    assert np.abs(an.F - s(x)).max() <= bound
    assert summary["interp_max_abs_F"]["value"] <= bound
    ls = pd.read_csv(out / "coefficients_least_squares.csv")
    assert np.allclose(ls[["x0", "x1"]].to_numpy(), t[["x0", "x1"]].to_numpy())
    assert "closure engine" in (out / "report.md").read_text()


def test_approx_study_errors_name_the_key(tmp_path, capsys):
    code, cap, out, _ = run(tmp_path, capsys, 0.0, 1.2, "n", joint="E")
    assert code == 2 and "approx.output.joint" in cap.err and "E" in cap.err
    assert not out.exists()
    path = tmp_path / "too_many.toml"
    path.write_text(study_toml(0.0, 1.2, f"n = {MAX_N + 1}"))
    code = main(["approx", str(path), "-o", str(tmp_path / "o2"), "--quiet"])
    assert code == 2 and "approx.n" in capsys.readouterr().err
