"""Manufacturing tolerances of a hexapod: Monte Carlo on the stiffness model against the
first-order prediction.

Each made hexapod has its base and platform attachment points displaced (every coordinate
N(0, σ_p), m) and its leg stiffnesses scaled by ``1 + N(0, σ_k)`` (relative); at the
study's pose its stiffness ``K = P diag(k) Pᵀ`` gives the indices ``kt_min``, ``kt_max``
(N/m: the translational block's eigenvalues) and ``cr_max`` (rad/(N·m): the rotational
compliance's largest eigenvalue), which do not depend on the moment reference point.  The
first-order prediction uses the same model: the sensitivities of the three indices to the
42 parameters (18 + 18 coordinates, 6 stiffnesses) by central differences, applied to the
same samples (``*_linear``) and as the standard deviation ``sqrt(J Σ Jᵀ)``
(``sd_predicted``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from .errors import StiffnessError
from .hexapod import Hexapod
from .matrices import rotational_compliance_eigenvalues, translational_eigenvalues

__all__ = ["HexapodTolerance", "hexapod_tolerance", "TOLERANCE_INDICES"]

TOLERANCE_INDICES = ("kt_min", "kt_max", "cr_max")


@dataclass
class HexapodTolerance:
    """A hexapod tolerance study.

    Attributes
    ----------
    summary : pandas.DataFrame
        One row per index: ``index``, ``unit``, ``nominal``, ``mean``, ``std`` (sampled),
        ``mean_linear``, ``std_linear`` (first order, the same samples), ``sd_predicted``
        (``sqrt(J Σ Jᵀ)``), ``gap`` (the relative distance of the index's eigenvalue from
        its neighbour at the nominal design) and ``first_order``: "reliable", or
        "unreliable: nearly repeated eigenvalue" where the gap is below three predicted
        standard deviations — an extreme eigenvalue of a nearly repeated pair is not
        differentiable there (symmetric designs), so the sampled distribution is the
        answer and the linear one is biased.
    samples : numpy.ndarray, shape (n, 3)
        The indices of every made hexapod.
    linear : numpy.ndarray, shape (n, 3)
        Their first-order values.
    sensitivity : numpy.ndarray, shape (3, 42)
        ∂index/∂parameter: base points (18, per m), platform points (18, per m), relative
        leg stiffnesses (6).
    """

    summary: pd.DataFrame
    samples: np.ndarray
    linear: np.ndarray
    sensitivity: np.ndarray


def _indices(hx: Hexapod, T, dp) -> np.ndarray:
    """The three indices of the hexapods made with parameter errors ``dp (m, 42)``."""
    n = hx.base.shape[0]
    out = np.empty((len(dp), 3))
    gaps = np.empty((len(dp), 3))
    for i, d in enumerate(dp):
        h = Hexapod(hx.base + d[:3 * n].reshape(n, 3), hx.platform + d[3 * n:6 * n].reshape(n, 3),
                    hx.k * (1.0 + d[6 * n:]))
        K = h.stiffness(T).K
        kt = translational_eigenvalues(K)
        cr = rotational_compliance_eigenvalues(K)
        out[i] = kt[0], kt[-1], cr[-1]
        gaps[i] = (kt[1] - kt[0]) / kt[0], (kt[2] - kt[1]) / kt[2], (cr[2] - cr[1]) / cr[2]
    return out, gaps


def hexapod_tolerance(hx: Hexapod, pose, *, point_sigma: float, stiffness_sigma: float = 0.0,
                      samples: int = 2000, seed: int = 0) -> HexapodTolerance:
    """Monte Carlo tolerance study of a hexapod's stiffness indices at ``pose`` against the
    first-order prediction (module notes).

    Parameters
    ----------
    hx : Hexapod
    pose : array_like, shape (4, 4)
    point_sigma : float
        Standard deviation of every coordinate of every attachment point (m).
    stiffness_sigma : float
        Relative standard deviation of every leg stiffness.
    samples : int
        Monte Carlo samples (≥ 10).
    seed : int

    Returns
    -------
    HexapodTolerance

    Raises
    ------
    StiffnessError
        Bad input (naming it); a singular pose.
    """
    if not isinstance(hx, Hexapod):
        raise StiffnessError(f"hx: expected a Hexapod, got {type(hx).__name__}")
    sig = {}
    for name, v in (("point_sigma", point_sigma), ("stiffness_sigma", stiffness_sigma)):
        if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)) \
                or not np.isfinite(v) or v < 0:
            raise StiffnessError(f"{name}: expected a standard deviation ≥ 0, got {v!r}")
        sig[name] = float(v)
    for name, v, low in (("samples", samples, 10), ("seed", seed, 0)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
            raise StiffnessError(f"{name}: expected an integer ≥ {low}, got {v!r}")
    T = np.asarray(pose, float)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise StiffnessError(f"pose: expected a finite 4x4 transform, got shape {T.shape}")
    n = hx.base.shape[0]
    s = np.r_[np.full(6 * n, sig["point_sigma"]), np.full(n, sig["stiffness_sigma"])]
    h = np.r_[np.full(6 * n, 1e-7), np.full(n, 1e-6)]
    fd = np.concatenate([np.diag(h), -np.diag(h)])
    vals, gaps = _indices(hx, T, np.vstack([np.zeros(len(s)), fd]))
    nominal, gap = vals[0], gaps[0]
    J = ((vals[1:1 + len(s)] - vals[1 + len(s):]) / (2 * h)[:, None]).T          # (3, 42)
    dp = np.random.default_rng(seed).normal(size=(samples, len(s))) * s
    got, _ = _indices(hx, T, dp)
    lin = nominal + dp @ J.T
    sd = np.sqrt(np.einsum("ik,k,ik->i", J, s ** 2, J))
    units = {"kt_min": "N/m", "kt_max": "N/m", "cr_max": "rad/(N·m)"}
    summary = pd.DataFrame({"index": TOLERANCE_INDICES, "unit": [units[k] for k in TOLERANCE_INDICES],
                            "nominal": nominal, "mean": got.mean(0), "std": got.std(0, ddof=1),
                            "mean_linear": lin.mean(0), "std_linear": lin.std(0, ddof=1),
                            "sd_predicted": sd, "gap": gap,
                            "first_order": np.where(gap > 3 * sd / np.abs(nominal), "reliable",
                                                    "unreliable: nearly repeated eigenvalue")})
    return HexapodTolerance(summary, got, lin, J)
