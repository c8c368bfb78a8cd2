"""Tolerance studies of a synthesised chain (synthesis.tolerance): the seed 001 RRR dyad with
axis tilts σ = 0.1° and shifts σ = 0.1 mm, Monte Carlo on the engine against the first-order
prediction, and the engine's sensitivities against the test's own forward kinematics."""
import numpy as np
import pytest

from synthesis import Screw, SynthesisError, enumerate_dyads
from synthesis.tolerance import chain_tolerance
from tests.synthesis.test_families import _screw

SEED = [Screw.from_degrees([0, 0, 1], [0, 0, 0], 30, 0.7),
        Screw.from_degrees([0.34202, 0, 0.939693], [0, 1.1, 0], 65, 0.5),
        Screw.from_degrees([0.66, 0.043589, 0.75], [0.25, 1.2, -0.289742], 75, 0.3)]


@pytest.fixture(scope="module")
def rrr_row():
    df = enumerate_dyads("RRR", SEED)
    return df[df.reason == ""].iloc[0]


def test_seed001_sampled_errors_match_the_first_order_prediction(rrr_row):
    r = chain_tolerance(rrr_row, direction_sigma=np.radians(0.1), position_sigma=1e-4,
                        samples=10000, seed=1, point=[0.2, 0.5, 0.0])
    s = r.summary.iloc[1:]                                 # position 1: zero by construction
    assert (r.summary.iloc[0][["rot_mean", "pos_mean"]] < 1e-12).all()
    for q in ("rot", "pos"):
        for m in ("mean", "std"):
            rel = np.abs(s[f"{q}_{m}"] / s[f"{q}_{m}_linear"] - 1)
            assert (rel < 0.10).all(), (q, m, rel)
        # the RMS of the sampled magnitudes against the covariance J Σ Jᵀ (no sampling)
        rms = np.sqrt(s[f"{q}_mean"] ** 2 + s[f"{q}_std"] ** 2)
        assert (np.abs(rms / s[f"{q}_sd_predicted"] - 1) < 0.10).all(), q
    # the error components are centred (first order: zero mean) and their spread is J Σ Jᵀ
    sig = np.tile([np.radians(0.1)] * 2 + [1e-4] * 2, 3)
    C = np.einsum("pik,k,pjk->pij", r.sensitivity, sig ** 2, r.sensitivity)
    sd = np.sqrt(np.einsum("pii->pi", C))[1:]
    got = r.errors[:, 1:].std(0, ddof=1)
    assert np.all(np.abs(got / sd - 1) < 0.05)
    assert np.all(np.abs(r.errors[:, 1:].mean(0)) < 0.05 * sd)


def _fk_point(lines, q, point):
    A = np.eye(4)
    for (u, c), a in zip(lines, q):
        A = A @ _screw(u, c, a, 0.0)
    return A[:3, :3] @ point + A[:3, 3]


def test_sensitivities_against_the_tests_own_kinematics(rrr_row):
    from synthesis.tolerance import _chain, _made
    r = chain_tolerance(rrr_row, direction_sigma=1e-3, position_sigma=1e-3, samples=10,
                        point=[0.2, 0.5, 0.0])
    kinds, lines, _, x = _chain(rrr_row)
    pt, h = np.array([0.2, 0.5, 0.0]), 1e-6
    for i in range(12):
        dp = np.zeros(12)
        dp[i] = h
        for p in range(1, 4):
            d = (_fk_point(_made(lines, kinds, dp), x[p], pt)
                 - _fk_point(_made(lines, kinds, -dp), x[p], pt)) / (2 * h)
            assert np.allclose(r.sensitivity[p, 3:, i], d, atol=1e-6), (i, p)


def test_zero_tolerances_and_bad_inputs(rrr_row):
    r = chain_tolerance(rrr_row, direction_sigma=0.0, position_sigma=0.0, samples=10)
    assert np.abs(r.errors).max() < 1e-12
    for kw, name in (({"direction_sigma": -1.0, "position_sigma": 0.0}, "direction_sigma"),
                     ({"direction_sigma": 0.0, "position_sigma": np.nan}, "position_sigma"),
                     ({"direction_sigma": 0.0, "position_sigma": 0.0, "samples": 3}, "samples"),
                     ({"direction_sigma": 0.0, "position_sigma": 0.0, "point": [1, 2]}, "point")):
        with pytest.raises(SynthesisError, match=name):
            chain_tolerance(rrr_row, **kw)
    bad = rrr_row.copy()
    bad["j3_type"] = "S"
    with pytest.raises(SynthesisError, match="row"):
        chain_tolerance(bad, direction_sigma=0.0, position_sigma=0.0)
