"""6x6 stiffness matrices: formula (2) of seed 003, K = P Kθ Pᵀ, frame changes, indices.

Units: K relates ``W = (f, m)`` to ``Δ = (δ, θ)``, so its blocks are
translational ``K_n`` (N/m), coupling ``K_c`` (N/rad) and torsional ``K_k``
(N·m/rad); the compliance ``C = K⁻¹`` has blocks m/N, m/(N·m) = rad/N and
rad/(N·m).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import scipy.linalg

from .errors import StiffnessError
from .sixvector import SWAP, _vec3, plucker, wrench_transform

__all__ = ["spring_stiffness", "stiffness_matrix", "transform_stiffness", "blocks",
           "from_blocks", "transform_blocks", "screw_eigenvalues", "translational_eigenvalues",
           "rotational_compliance_eigenvalues", "stiffness_indices"]


def spring_stiffness(k, directions, points) -> np.ndarray:
    """Formula (2) of seed 003: ``k_jl = Σ_i k_i R_ji R_li`` for point-axial springs.

    Parameters
    ----------
    k : array_like, shape (..., n)
        Spring stiffnesses (N/m), non-negative.
    directions : array_like, shape (..., n, 3)
        Spring axes (normalised here).
    points : array_like, shape (..., n, 3)
        Points on the axes (m), in the frame of the result.

    Returns
    -------
    numpy.ndarray, shape (..., 6, 6)
    """
    N = plucker(directions, points)
    return stiffness_matrix(np.swapaxes(N, -1, -2), k)


def stiffness_matrix(P, k) -> np.ndarray:
    """``K = P diag(k) Pᵀ`` for a leg matrix ``P`` (..., 6, n) of Plücker columns.

    Raises
    ------
    StiffnessError
        If shapes disagree or any ``k`` is negative or non-finite.
    """
    P = np.asarray(P, dtype=float)
    k = np.asarray(k, dtype=float)
    if P.shape[-2] != 6:
        raise StiffnessError(f"P: expected shape (..., 6, n), got {P.shape}")
    if k.shape[-1] != P.shape[-1]:
        raise StiffnessError(f"k: expected {P.shape[-1]} stiffnesses, got shape {k.shape}")
    if not np.all(np.isfinite(k)) or np.any(k < 0):
        raise StiffnessError("k: stiffnesses must be finite and non-negative (N/m)")
    Pk = P * k[..., None, :]
    return np.matmul(Pk, np.swapaxes(P, -1, -2))


def transform_stiffness(K, R, p) -> np.ndarray:
    """``K' = T K Tᵀ``: the (unloaded) stiffness in the frame with origin ``p`` and
    ``r' = R (r − p)``.  For a loaded (non-symmetric) K this holds only for
    ``p = 0``; see :meth:`Hexapod.loaded_stiffness`."""
    K = np.asarray(K, dtype=float)
    if K.shape[-2:] != (6, 6):
        raise StiffnessError(f"K: expected shape (..., 6, 6), got {K.shape}")
    T = wrench_transform(R, p)
    return T @ K @ np.swapaxes(T, -1, -2)


def transform_blocks(K, R, p):
    """Block form (15) of the frame change: the new blocks from the old ones.

    ``K_n' = R K_n Rᵀ``, ``K_c' = R (K_c + K_n [p]) Rᵀ``,
    ``K_k' = R (K_k − [p] K_c + K_cᵀ [p] − [p] K_n [p]) Rᵀ``; equal to ``T K Tᵀ``.

    Returns
    -------
    (K_n', K_c', K_k')
    """
    from closure.frames import skew
    Kn, Kc, Kk = blocks(K)
    R = np.asarray(R, dtype=float)
    P = skew(np.asarray(p, dtype=float))
    Rt = np.swapaxes(R, -1, -2)
    KcT = np.swapaxes(Kc, -1, -2)
    return (R @ Kn @ Rt, R @ (Kc + Kn @ P) @ Rt, R @ (Kk - P @ Kc + KcT @ P - P @ Kn @ P) @ Rt)


def blocks(K):
    """The blocks of (15): translational ``K_n``, coupling ``K_c``, torsional ``K_k``."""
    K = np.asarray(K, dtype=float)
    return K[..., :3, :3], K[..., :3, 3:], K[..., 3:, 3:]


def from_blocks(Kn, Kc, Kk) -> np.ndarray:
    """Assemble ``[[K_n, K_c], [K_cᵀ, K_k]]``."""
    Kn, Kc, Kk = (np.asarray(a, dtype=float) for a in (Kn, Kc, Kk))
    top = np.concatenate([Kn, Kc], -1)
    bot = np.concatenate([np.swapaxes(Kc, -1, -2), Kk], -1)
    return np.concatenate([top, bot], -2)


def translational_eigenvalues(K) -> np.ndarray:
    """Eigenvalues of the translational block ``K_n`` (N/m), ascending, ``(..., 3)``."""
    Kn = np.asarray(K, dtype=float)[..., :3, :3]
    return np.linalg.eigvalsh(0.5 * (Kn + np.swapaxes(Kn, -1, -2)))


def rotational_compliance_eigenvalues(K) -> np.ndarray:
    """Eigenvalues of the rotational block of the compliance ``C = K⁻¹`` (rad/(N·m)),
    ascending, ``(..., 3)``."""
    C = np.linalg.inv(np.asarray(K, dtype=float))[..., 3:, 3:]
    return np.linalg.eigvalsh(0.5 * (C + np.swapaxes(C, -1, -2)))


def screw_eigenvalues(K) -> np.ndarray:
    """Frame-invariant eigenvalues of ``K t = λ Δ t`` with ``Δ = [[0, I], [I, 0]]`` (N).

    ``T Δ Tᵀ = Δ`` for every frame change, so these do not depend on the frame.
    They come in ± pairs for a positive definite K (real: the principal screws'
    stiffnesses).  Returned sorted by real part, ``(6,)`` complex.
    """
    K = np.asarray(K, dtype=float)
    if K.shape != (6, 6):
        raise StiffnessError(f"screw_eigenvalues: expected one 6x6 matrix, got {K.shape}")
    lam = scipy.linalg.eigvals(K, SWAP)
    return lam[np.argsort(lam.real)]


def stiffness_indices(K) -> pd.DataFrame:
    """The indices a report shows, one row each, never mixing units: ``index``,
    ``value`` (array or number) and ``unit``."""
    K = np.asarray(K, dtype=float)
    return pd.DataFrame({
        "index": ["eigenvalues of the translational block K_n",
                  "eigenvalues of the rotational compliance",
                  "screw eigenvalues K t = λ Δ t (frame-invariant)", "‖K_c‖ (coupling)"],
        "value": [translational_eigenvalues(K), rotational_compliance_eigenvalues(K),
                  screw_eigenvalues(K).real, float(np.linalg.norm(K[:3, 3:]))],
        "unit": ["N/m", "rad/(N·m)", "N", "N/rad"]})


def _check_points(a, name, n=None):
    a = _vec3(a, name)
    if a.ndim != 2 or (n is not None and a.shape[0] != n):
        raise StiffnessError(f"{name}: expected shape ({n or 'n'}, 3), got {a.shape}")
    return a
