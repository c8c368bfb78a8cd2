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

from closure.frames import skew as _skew

from .errors import SingularPoseError, StiffnessError
from .sixvector import SWAP, plucker, wrench_transform
from .validate import as_array, broadcast, matrix6, number, rotation, vec3

__all__ = ["spring_stiffness", "stiffness_matrix", "transform_stiffness", "blocks",
           "from_blocks", "transform_blocks", "screw_eigenvalues", "translational_eigenvalues",
           "rotational_compliance_eigenvalues", "stiffness_indices", "compliance_of"]


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
    k = as_array(k, "k", (None,), what="spring stiffnesses (..., n) (N/m)")
    d = as_array(directions, "directions", (None, 3))
    r = as_array(points, "points", (None, 3))
    if d.shape[-2] != k.shape[-1] or r.shape[-2] != k.shape[-1]:
        raise StiffnessError(f"directions, points: expected {k.shape[-1]} springs (..., "
                             f"{k.shape[-1]}, 3) like k, got shapes {d.shape} and {r.shape}")
    if np.any(np.linalg.norm(d, axis=-1) == 0):
        raise StiffnessError("directions: a spring axis has zero length (expected non-zero "
                             "directions)")
    N = plucker(d, r)
    return stiffness_matrix(np.swapaxes(N, -1, -2), k)


def stiffness_matrix(P, k) -> np.ndarray:
    """``K = P diag(k) Pᵀ`` for a leg matrix ``P`` (..., 6, n) of Plücker columns.

    Parameters
    ----------
    P : array_like, shape (..., 6, n)
        Leg (spring) lines' Plücker columns ``(n, r × n)`` (dimensionless, m).
    k : array_like, shape (..., n)
        Axial stiffnesses (N/m), finite and non-negative.

    Returns
    -------
    numpy.ndarray, shape (..., 6, 6)
        Blocks N/m, N/rad, N·m/rad.

    Raises
    ------
    StiffnessError
        If shapes disagree, batch shapes do not broadcast, or any entry is
        non-finite or any ``k`` negative.
    """
    P = as_array(P, "P", (6, None))
    k = as_array(k, "k", (None,), what="stiffnesses (..., n) (N/m)")
    if k.shape[-1] != P.shape[-1]:
        raise StiffnessError(f"k: expected {P.shape[-1]} stiffnesses (one per column of P), got "
                             f"shape {k.shape}")
    broadcast(P=P.shape[:-2], k=k.shape[:-1])
    if np.any(k < 0):
        raise StiffnessError("k: stiffnesses must be finite and non-negative (N/m), got "
                             f"{k[np.unravel_index(np.argmin(k), k.shape)]}")
    return _congruence(P, k)


def _congruence(P, k) -> np.ndarray:
    """``P diag(k) Pᵀ`` of checked arrays (the hot path of maps)."""
    return np.matmul(P * k[..., None, :], np.swapaxes(P, -1, -2))


def transform_stiffness(K, R, p) -> np.ndarray:
    """``K' = T K Tᵀ``: the (unloaded) stiffness in the frame with origin ``p`` and
    ``r' = R (r − p)``.  For a loaded (non-symmetric) K this holds only for
    ``p = 0``; see :meth:`Hexapod.loaded_stiffness`.

    Parameters
    ----------
    K : array_like, shape (..., 6, 6)
        Stiffness (blocks N/m, N/rad, N·m/rad).
    R : array_like, shape (..., 3, 3)
        Axes of the new frame (a proper rotation).
    p : array_like, shape (..., 3)
        Origin of the new frame in old coordinates (m).

    Returns
    -------
    numpy.ndarray, shape (..., 6, 6)
    """
    K = matrix6(K, "K")
    T = wrench_transform(R, p)
    broadcast(K=K.shape[:-2], R_p=T.shape[:-2])
    return T @ K @ np.swapaxes(T, -1, -2)


def transform_blocks(K, R, p):
    """Block form (15) of the frame change: the new blocks from the old ones.

    ``K_n' = R K_n Rᵀ``, ``K_c' = R (K_c + K_n [p]) Rᵀ``,
    ``K_k' = R (K_k − [p] K_c + K_cᵀ [p] − [p] K_n [p]) Rᵀ``; equal to ``T K Tᵀ``.

    Parameters
    ----------
    K : array_like, shape (..., 6, 6)
        Stiffness (blocks N/m, N/rad, N·m/rad).
    R : array_like, shape (..., 3, 3)
        Axes of the new frame (a proper rotation).
    p : array_like, shape (..., 3)
        Origin of the new frame in old coordinates (m).

    Returns
    -------
    (K_n', K_c', K_k') : numpy.ndarray, each (..., 3, 3)
    """
    Kn, Kc, Kk = blocks(K)
    R, p = rotation(R, "R"), vec3(p, "p")
    broadcast(K=Kn.shape[:-2], R=R.shape[:-2], p=p.shape[:-1])
    P = _skew(p)
    Rt = np.swapaxes(R, -1, -2)
    KcT = np.swapaxes(Kc, -1, -2)
    return (R @ Kn @ Rt, R @ (Kc + Kn @ P) @ Rt, R @ (Kk - P @ Kc + KcT @ P - P @ Kn @ P) @ Rt)


def blocks(K):
    """The blocks of (15): translational ``K_n`` (N/m), coupling ``K_c`` (N/rad), torsional
    ``K_k`` (N·m/rad), each ``(..., 3, 3)``, of ``K`` ``(..., 6, 6)``."""
    K = matrix6(K, "K")
    return K[..., :3, :3], K[..., :3, 3:], K[..., 3:, 3:]


def from_blocks(Kn, Kc, Kk) -> np.ndarray:
    """Assemble ``[[K_n, K_c], [K_cᵀ, K_k]]`` ``(..., 6, 6)`` from three ``(..., 3, 3)`` blocks."""
    Kn, Kc, Kk = (as_array(a, n, (3, 3)) for a, n in ((Kn, "Kn"), (Kc, "Kc"), (Kk, "Kk")))
    batch = broadcast(Kn=Kn.shape[:-2], Kc=Kc.shape[:-2], Kk=Kk.shape[:-2]) + (3, 3)
    Kn, Kc, Kk = (np.broadcast_to(a, batch) for a in (Kn, Kc, Kk))
    top = np.concatenate([Kn, Kc], -1)
    bot = np.concatenate([np.swapaxes(Kc, -1, -2), Kk], -1)
    return np.concatenate([top, bot], -2)


def translational_eigenvalues(K) -> np.ndarray:
    """Eigenvalues of the translational block ``K_n`` (N/m), ascending, ``(..., 3)``."""
    Kn = matrix6(K, "K")[..., :3, :3]
    return np.linalg.eigvalsh(0.5 * (Kn + np.swapaxes(Kn, -1, -2)))


def rotational_compliance_eigenvalues(K) -> np.ndarray:
    """Eigenvalues of the rotational block of the compliance ``C = K⁻¹`` (rad/(N·m)),
    ascending, ``(..., 3)``.

    Raises
    ------
    SingularPoseError
        If K is singular or so near it that ``C`` would carry a relative error above
        1e-3 (see :func:`compliance_of`).
    """
    C = compliance_of(K)[..., 3:, 3:]
    return np.linalg.eigvalsh(0.5 * (C + np.swapaxes(C, -1, -2)))


def screw_eigenvalues(K) -> np.ndarray:
    """Frame-invariant eigenvalues of ``K t = λ Δ t`` with ``Δ = [[0, I], [I, 0]]`` (N).

    ``T Δ Tᵀ = Δ`` for every frame change, so these do not depend on the frame.
    They come in ± pairs for a positive definite K (real: the principal screws'
    stiffnesses).  Returned sorted by real part, ``(6,)`` complex.
    """
    K = matrix6(K, "K", single=True)
    lam = scipy.linalg.eigvals(K, SWAP)
    return lam[np.argsort(lam.real)]


#: cond(K) · ε above which a compliance from K is refused (relative error above 1e-3)
K_INVERSE_ERROR = 1e-3


def compliance_of(K, name: str = "K") -> np.ndarray:
    """``C = K⁻¹`` ``(..., 6, 6)`` after checking that K is far enough from singular.

    K's blocks have different units, so its condition number is taken after making it
    dimensionless with its own length ``ℓ = sqrt(tr K_k / tr K_n)`` (m):
    ``D K D`` with ``D = diag(1, 1, 1, 1/ℓ, 1/ℓ, 1/ℓ)``; this is unchanged by a change of
    length unit.

    Raises
    ------
    SingularPoseError
        ``"the stiffness is singular (cond(K) = …)"`` when ``cond(D K D) · ε > 1e-3``.
    """
    K = matrix6(K, name)
    tn = np.trace(K[..., :3, :3], axis1=-2, axis2=-1)
    tk = np.trace(K[..., 3:, 3:], axis1=-2, axis2=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ell = np.sqrt(np.where((tn > 0) & (tk > 0), tk / tn, 1.0))
    d = np.concatenate([np.ones(ell.shape + (3,)), np.repeat(1 / ell[..., None], 3, -1)], -1)
    Ks = K * d[..., :, None] * d[..., None, :]
    s = np.linalg.svd(Ks, compute_uv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.where(s[..., -1] > 0, s[..., 0] / s[..., -1], np.inf)
    limit = K_INVERSE_ERROR / np.finfo(float).eps
    if np.any(~(c <= limit)):
        i = np.unravel_index(np.argmax(np.where(np.isnan(c), np.inf, c)), c.shape)
        where = f" at index {tuple(int(j) for j in i)}" if c.ndim else ""
        raise SingularPoseError(
            f"{name}: the stiffness is singular (cond(K) = {float(c[i]):.2e} > {limit:.1e}, K made "
            f"dimensionless with its length ℓ = {float(ell[i]):.3g} m){where}: the pose is "
            "singular and the compliance is undefined")
    Ci = np.linalg.inv(Ks)
    return Ci * d[..., :, None] * d[..., None, :]


def stiffness_indices(K, *, singular_cond: float = 1e8) -> pd.DataFrame:
    """The indices a report shows as a tidy table: one number per row, never mixing units.

    Columns: ``index`` (``kt``: eigenvalue of the translational block K_n; ``cr``:
    eigenvalue of the rotational block of the compliance C = K⁻¹; ``screw``: the
    frame-invariant screw eigenvalues of ``K t = λ Δ t``; ``coupling``: ‖K_c‖, the
    Frobenius norm of the coupling block), ``component`` (1, 2, … in ascending order of
    the values; 1 for the coupling), ``value`` (a float), ``unit`` (N/m, rad/(N·m), N,
    N/rad) and ``meaning`` (what the row is, in words).  Select one index with
    ``df[df["index"] == "kt"].value``.

    Parameters
    ----------
    K : array_like, shape (6, 6), or StiffnessResult
        The stiffness (blocks N/m, N/rad, N·m/rad); a :class:`StiffnessResult` also
        brings the pose's cond(P).
    singular_cond : float
        cond(P) above which a result's pose counts as singular (the default of
        :class:`Hexapod`).

    Raises
    ------
    SingularPoseError
        ``"pose is singular (cond(P) = …)"`` for a result above ``singular_cond``;
        ``"the stiffness is singular (cond(K) = …)"`` when K is too near singular to
        invert (the rotational compliance is undefined).
    """
    singular_cond = number(singular_cond, "singular_cond", positive=True)
    cond_P = getattr(K, "cond_P", None)
    if cond_P is not None:
        if not cond_P <= singular_cond:
            raise SingularPoseError(f"K: pose is singular (cond(P) = {cond_P:.2e} > "
                                    f"{singular_cond:.0e}): the rotational compliance is "
                                    "undefined")
        K = K.K
    K = matrix6(K, "K", single=True)
    groups = [("kt", translational_eigenvalues(K), "N/m",
               "translational stiffness: eigenvalue of the translational block K_n"),
              ("cr", rotational_compliance_eigenvalues(K), "rad/(N·m)",
               "rotational compliance: eigenvalue of the rotational block of C = K⁻¹"),
              ("screw", screw_eigenvalues(K).real, "N",
               "screw eigenvalue of K t = λ Δ t (frame-invariant)"),
              ("coupling", np.array([np.linalg.norm(K[:3, 3:])]), "N/rad",
               "‖K_c‖: Frobenius norm of the coupling block")]
    rows = [{"index": name, "component": i + 1, "value": float(v), "unit": unit,
             "meaning": meaning}
            for name, values, unit, meaning in groups for i, v in enumerate(values)]
    return pd.DataFrame(rows, columns=["index", "component", "value", "unit", "meaning"])
