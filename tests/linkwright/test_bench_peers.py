"""The peer benchmark's models: MuJoCo's and Exudyn's four-bar reproduce the closed-form model
(an independent reference) at the accuracy the benchmark tunes them to; MuJoCo's Bricard
agrees with the engine's; without the peers the benchmark still runs and says so."""
import sys

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from linkwright import bench_peers as bp
from linkwright.references import fourbar_rod_reference

SPAN = 3.0
# the engine's crank-angle error on this four-bar over 3 s at rtol 1e-8 is 9e-8 rad: the
# peers' steps MUJOCO_FOURBAR_DT and EXUDYN_FOURBAR_H are tuned to stay under it
TUNED = 1e-7


@pytest.fixture(scope="module")
def closed_form():
    acc = fourbar_rod_reference(bp.FOURBAR, (1.0, 3.0, 2.5), bp.T20)
    sol = solve_ivp(lambda t, y: [y[1], acc(y[0], y[1])], (0, SPAN), [bp.T20, 0.0],
                    rtol=1e-13, atol=1e-14, method="DOP853", dense_output=True)
    return lambda t: sol.sol(t)[0]


def _check_fourbar(result, closed_form, drift_max):
    cpu, t, crank, energy = result
    assert t[0] == 0 and t[-1] == pytest.approx(SPAN) and len(t) == round(SPAN / bp.SAMPLE) + 1
    assert np.ptp(crank) > 3.0                     # it swings (0.3 → −2.8 rad): a real test
    assert np.abs(crank - closed_form(t)).max() < TUNED
    assert np.abs(energy - energy[0]).max() < drift_max    # no damping: E is constant
    assert cpu > 0


def test_mujoco_fourbar_matches_closed_form(closed_form):
    pytest.importorskip("mujoco", minversion="3.7")
    _check_fourbar(bp.mujoco_chain_result(1, bp.MUJOCO_FOURBAR_DT, SPAN), closed_form, 1e-5)


def test_exudyn_fourbar_matches_closed_form(closed_form):
    pytest.importorskip("exudyn", minversion="1.13")
    _check_fourbar(bp.exudyn_chain_result(1, bp.EXUDYN_FOURBAR_H, SPAN), closed_form, 1e-4)


def test_mujoco_bricard_agrees_with_the_engine():
    """The overconstrained loop: the engine (least squares on the 6R loop) and MuJoCo (a
    chain closed by soft equalities) move the joint points alike, energy kept."""
    pytest.importorskip("mujoco", minversion="3.7")
    span = 1.0
    t = np.linspace(0, span, round(span / bp.SAMPLE) + 1)
    df = bp.ours_bricard().simulate((0, span), [0.0], [0.0], t_eval=t, rtol=1e-10,
                                    atol=1e-12)
    ours = bp.bricard_points(df[[f"q:J{k}" for k in range(1, 7)]].to_numpy())
    assert np.abs(df.balance).max() < 1e-8
    assert np.abs(ours[-1] - ours[0]).max() > 0.3          # it moves
    _, tt, pts, energy = bp.mujoco_bricard_result(1e-3, span)
    assert np.array_equal(np.rint(tt / bp.SAMPLE), np.arange(len(t)))
    assert np.abs(pts - ours).max() < 1e-7
    assert np.abs(energy - energy[0]).max() < 1e-5


def test_bench_without_peers_says_not_installed(monkeypatch):
    for name in bp.PEERS:
        monkeypatch.setitem(sys.modules, name, None)       # `import name` raises ImportError
    rows = bp.bench_peers(quick=True)
    text = "\n".join(rows)
    assert rows[0].startswith("## peers")
    for model in ("four-bar", "Bricard"):
        ours = [r for r in rows if r.startswith(f"| {model}") and "| linkwright (" in r]
        assert len(ours) == 1
        cells = [c.strip() for c in ours[0].split("|")[1:-1]]
        assert float(cells[3]) < 1e-6 and float(cells[5]) > 0      # error, CPU s per s
        for name in bp.PEERS:
            assert any(r.startswith(f"| {model}") and f"| {name} | {bp.NOT_INSTALLED} |" in r
                       for r in rows)
    for name in bp.PEERS:
        assert f"| {name} | {bp.NOT_INSTALLED} |" in text             # footprint table
    assert "pip install linkwright[peers]" in bp.NOT_INSTALLED
