"""Six-vectors of seed 003 and their frame transforms (its Table 1).

A wrench is ``W = (f, m)`` (N, N·m), a small displacement ``Δ = (δ, θ)`` (m,
rad), a line's normalised Plücker coordinates ``N = (n, r × n)``; work is
``Δᵀ W``.  The new frame has its origin at ``p`` (old coordinates) and maps
points by ``r' = R (r − p)``.  Then

=========  ====================================  ===================================
           wrenches ``W' = X W``                 displacements ``Δ' = X* Δ``
=========  ====================================  ===================================
shift      ``S  = [[E, 0], [−[p], E]]``          ``S* = [[E, −[p]], [0, E]]``
rotation   ``H  = [[R, 0], [0, R]]``             ``H* = H``
general    ``T  = H S = [[R, 0], [−R[p], R]]``   ``T* = H* S* = [[R, −R[p]], [0, R]]``
=========  ====================================  ===================================

with ``T* = T⁻ᵀ`` (so work is frame-invariant) and ``K' = T K Tᵀ``.
All functions broadcast over leading axes.
"""
from __future__ import annotations

import numpy as np

from closure.frames import skew as _skew

from .errors import StiffnessError
from .validate import as_array, broadcast, rotation, vec3

__all__ = ["skew", "plucker", "shift_wrench", "shift_twist", "rotate_six", "wrench_transform",
           "twist_transform", "wrench_transform_inverse", "twist_transform_inverse",
           "compose_frames", "check_rotation", "to_moment_first", "from_moment_first"]

_E = np.eye(3)
SWAP = np.block([[np.zeros((3, 3)), _E], [_E, np.zeros((3, 3))]])


def check_rotation(R, name: str = "R", tol: float = 1e-9) -> np.ndarray:
    """``R`` as an array after checking it is a proper rotation ``(..., 3, 3)``.

    Raises
    ------
    StiffnessError
        Naming ``name``: wrong shape, non-finite entries, or not orthonormal and
        right-handed to ``tol``.
    """
    return rotation(R, name, tol)


def skew(p) -> np.ndarray:
    """Skew-symmetric matrices ``[p]`` with ``[p] x = p × x``.

    Parameters
    ----------
    p : array_like, shape (..., 3)
        Finite 3-vectors (any unit).

    Returns
    -------
    numpy.ndarray, shape (..., 3, 3)
    """
    return _skew(vec3(p, "p"))


def _rp(R, p):
    """Checked ``R (..., 3, 3)``, ``p (..., 3)`` and zeros of their broadcast block shape."""
    R, p = rotation(R, "R"), vec3(p, "p")
    batch = broadcast(R=R.shape[:-2], p=p.shape[:-1])
    return R, p, np.zeros(batch + (3, 3))


def _blocks(A, B, C, D):
    top = np.concatenate(np.broadcast_arrays(A, B), -1)
    bot = np.concatenate(np.broadcast_arrays(C, D), -1)
    return np.concatenate(np.broadcast_arrays(top, bot), -2)


def plucker(n, r) -> np.ndarray:
    """Normalised Plücker coordinates ``N = (n, r × n)`` of lines through ``r`` along ``n``.

    Parameters
    ----------
    n : array_like, shape (..., 3)
        Directions (normalised here; any non-zero length).
    r : array_like, shape (..., 3)
        Points on the lines (m).

    Returns
    -------
    numpy.ndarray, shape (..., 6)
        ``(n, r × n)`` (dimensionless, m).

    Raises
    ------
    StiffnessError
        Non-finite or wrongly shaped input, batch shapes that do not broadcast, or a
        zero direction.
    """
    n, r = vec3(n, "n"), vec3(r, "r")
    broadcast(n=n.shape[:-1], r=r.shape[:-1])
    ln = np.linalg.norm(n, axis=-1, keepdims=True)
    if np.any(ln == 0):
        raise StiffnessError("n: direction n has zero length (expected a non-zero direction)")
    n = n / ln
    n, r = np.broadcast_arrays(n, r)
    return np.concatenate([n, np.cross(r, n)], -1)


def shift_wrench(p) -> np.ndarray:
    """S: wrench transform for a shift of the origin to ``p``: ``m' = m − p × f``."""
    p = vec3(p, "p")
    Z = np.zeros(p.shape[:-1] + (3, 3))
    return _blocks(Z + _E, Z, -_skew(p), Z + _E)


def shift_twist(p) -> np.ndarray:
    """S*: displacement transform for a shift of the origin to ``p``: ``δ' = δ − p × θ``."""
    p = vec3(p, "p")
    Z = np.zeros(p.shape[:-1] + (3, 3))
    return _blocks(Z + _E, -_skew(p), Z, Z + _E)


def rotate_six(R) -> np.ndarray:
    """H = H*: six-vector transform for a rotation of the axes, ``diag(R, R)``."""
    R = rotation(R, "R")
    Z = np.zeros_like(R)
    return _blocks(R, Z, Z, R)


def wrench_transform(R, p) -> np.ndarray:
    """T = H S = ``[[R, 0], [−R[p], R]]``: wrenches into the frame (origin ``p``, ``r' = R(r − p)``)."""
    R, p, Z = _rp(R, p)
    return _blocks(R + Z, Z, -R @ _skew(p), R + Z)


def twist_transform(R, p) -> np.ndarray:
    """T* = H* S* = ``[[R, −R[p]], [0, R]]``: small displacements into the new frame (= T⁻ᵀ)."""
    R, p, Z = _rp(R, p)
    return _blocks(R + Z, -R @ _skew(p), Z, R + Z)


def wrench_transform_inverse(R, p) -> np.ndarray:
    """T⁻¹ = ``[[Rᵀ, 0], [[p] Rᵀ, Rᵀ]]`` (back to the old frame)."""
    R, p, Z = _rp(R, p)
    Rt = np.swapaxes(R, -1, -2)
    return _blocks(Rt + Z, Z, _skew(p) @ Rt, Rt + Z)


def twist_transform_inverse(R, p) -> np.ndarray:
    """T*⁻¹ = ``[[Rᵀ, [p] Rᵀ], [0, Rᵀ]]``."""
    R, p, Z = _rp(R, p)
    Rt = np.swapaxes(R, -1, -2)
    return _blocks(Rt + Z, _skew(p) @ Rt, Z, Rt + Z)


def compose_frames(R1, p1, R2, p2):
    """The single frame change equal to (R1, p1) followed by (R2, p2 given in frame 1).

    Returns ``(R, p)`` with ``T(R, p) = T(R2, p2) T(R1, p1)``: ``R = R2 R1`` and
    ``p = p1 + R1ᵀ p2``.
    """
    R1, R2 = rotation(R1, "R1"), rotation(R2, "R2")
    p1, p2 = vec3(p1, "p1"), vec3(p2, "p2")
    broadcast(R1=R1.shape[:-2], p1=p1.shape[:-1], R2=R2.shape[:-2], p2=p2.shape[:-1])
    return R2 @ R1, p1 + (np.swapaxes(R1, -1, -2) @ p2[..., None])[..., 0]


def to_moment_first(X) -> np.ndarray:
    """Reorder a six-vector ``(..., 6)`` or 6x6 matrix ``(..., 6, 6)`` from force-first
    ``(f, m)`` / ``(δ, θ)`` to moment-first ``(m, f)`` / ``(θ, δ)`` (Featherstone,
    Modern Robotics, pinocchio): ``S X`` or ``S X S`` with ``S = [[0, I], [I, 0]]``."""
    X = as_array(X, "X", what="a six-vector (..., 6) or a 6x6 matrix (..., 6, 6)")
    if X.shape[-2:] == (6, 6):
        return SWAP @ X @ SWAP
    if X.shape[-1:] == (6,):
        return X[..., [3, 4, 5, 0, 1, 2]]
    raise StiffnessError(f"X: expected a six-vector (..., 6) or a 6x6 matrix (..., 6, 6), "
                         f"got shape {X.shape}")


from_moment_first = to_moment_first  # the swap is its own inverse
