"""Hexapod tolerance studies (stiffness.tolerance): Monte Carlo against the first-order
prediction, the sensitivities against the closed form of an eigenvalue's derivative, and
the flag where first order cannot hold (a nearly repeated eigenvalue of a symmetric design)."""
import numpy as np
import pytest

from stiffness import Hexapod, StiffnessError
from stiffness.tolerance import hexapod_tolerance

# seed 003's hexapod (the shipped example): 3-fold symmetric, two equal smallest kt
SYM = Hexapod([[0.8, 0.0, 0.0], [-0.138919, 0.787846, 0.0], [-0.4, 0.69282, 0.0],
               [-0.61284, -0.514230, 0.0], [-0.4, -0.69282, 0.0], [0.751754, -0.273616, 0.0]],
              [[0.306418, 0.257115, 0.0], [0.069459, 0.393923, 0.0], [-0.375877, 0.136808, 0.0],
               [-0.375877, -0.136808, 0.0], [0.069459, -0.393923, 0.0],
               [0.306418, -0.257115, 0.0]], 2.0e7)
T = np.eye(4)
T[2, 3] = 0.7
rng = np.random.default_rng(3)
ASYM = Hexapod(SYM.base + 0.08 * rng.normal(size=(6, 3)) * [1, 1, 0],
               SYM.platform + 0.05 * rng.normal(size=(6, 3)) * [1, 1, 0],
               SYM.k * (1 + 0.3 * rng.uniform(-1, 1, 6)))


def test_sampled_indices_match_the_first_order_prediction():
    r = hexapod_tolerance(ASYM, T, point_sigma=1e-3, stiffness_sigma=0.05, samples=3000, seed=1)
    s = r.summary.set_index("index")
    assert (s.first_order == "reliable").all()
    assert np.all(np.abs(s["mean"] / s.mean_linear - 1) < 0.01)
    assert np.all(np.abs(s["std"] / s.std_linear - 1) < 0.10)
    assert np.all(np.abs(s["std"] / s.sd_predicted - 1) < 0.10)


def test_stiffness_sensitivity_is_the_eigenvalue_derivative():
    """∂λ/∂k_i of K_tt = Σ k u uᵀ is (v · u_i)² for the eigenvector v: with relative
    stiffness errors the sensitivity to k_i(1 + ε_i) is k_i (v · u_i)²."""
    r = hexapod_tolerance(ASYM, T, point_sigma=0.0, stiffness_sigma=0.0, samples=10)
    R, t = T[:3, :3], T[:3, 3]
    a = ASYM.platform @ R.T + t
    u = a - ASYM.base
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    Ktt = np.einsum("i,ij,ik->jk", ASYM.k, u, u)
    w, V = np.linalg.eigh(Ktt)
    for row, col in ((0, 0), (1, 2)):                        # kt_min, kt_max
        want = ASYM.k * (u @ V[:, col]) ** 2
        assert np.allclose(r.sensitivity[row, 36:], want, rtol=1e-5)
    assert np.allclose(r.summary.nominal[:2], [w[0], w[2]], rtol=1e-12)
    assert np.abs(r.samples - r.summary.nominal.to_numpy()).max() == 0     # σ = 0: no error


def test_symmetric_design_flags_the_nearly_repeated_eigenvalues():
    r = hexapod_tolerance(SYM, T, point_sigma=1e-3, stiffness_sigma=0.05, samples=500, seed=2)
    s = r.summary.set_index("index")
    assert s.loc["kt_max", "first_order"] == "reliable"
    assert s.loc["kt_min", "first_order"].startswith("unreliable")
    # the smallest of a repeated pair is biased low by the errors: first order misses it
    assert s.loc["kt_min", "mean"] < s.loc["kt_min", "nominal"] - 0.3 * s.loc["kt_min", "std"]


@pytest.mark.parametrize("kw, name", [
    ({"point_sigma": -1.0}, "point_sigma"), ({"point_sigma": np.nan}, "point_sigma"),
    ({"point_sigma": 1e-3, "stiffness_sigma": "x"}, "stiffness_sigma"),
    ({"point_sigma": 1e-3, "samples": 3}, "samples"), ({"point_sigma": 1e-3, "seed": -1}, "seed")])
def test_bad_input_names_the_argument(kw, name):
    with pytest.raises(StiffnessError, match=name):
        hexapod_tolerance(ASYM, T, **kw)
    with pytest.raises(StiffnessError, match="pose"):
        hexapod_tolerance(ASYM, np.eye(3), point_sigma=1e-3)
    with pytest.raises(StiffnessError, match="hx"):
        hexapod_tolerance("hexapod", T, point_sigma=1e-3)
