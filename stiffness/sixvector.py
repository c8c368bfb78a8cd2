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

from closure.frames import skew

from .errors import StiffnessError

__all__ = ["skew", "plucker", "shift_wrench", "shift_twist", "rotate_six", "wrench_transform",
           "twist_transform", "wrench_transform_inverse", "twist_transform_inverse",
           "compose_frames", "check_rotation", "to_moment_first", "from_moment_first"]

_E = np.eye(3)
SWAP = np.block([[np.zeros((3, 3)), _E], [_E, np.zeros((3, 3))]])


def check_rotation(R, name: str = "R", tol: float = 1e-9) -> np.ndarray:
    """``R`` as an array after checking it is a proper rotation ``(..., 3, 3)``."""
    R = np.asarray(R, dtype=float)
    if R.shape[-2:] != (3, 3):
        raise StiffnessError(f"{name}: expected a 3x3 rotation matrix, got shape {R.shape}")
    if not np.all(np.isfinite(R)):
        raise StiffnessError(f"{name}: contains non-finite entries")
    if R.size == 0:
        return R
    # rows orthonormal and right-handed: row0 × row1 = row2 (covers det = +1)
    r0, r1, r2 = R[..., 0, :], R[..., 1, :], R[..., 2, :]
    c = np.stack([r0[..., 1] * r1[..., 2] - r0[..., 2] * r1[..., 1],
                  r0[..., 2] * r1[..., 0] - r0[..., 0] * r1[..., 2],
                  r0[..., 0] * r1[..., 1] - r0[..., 1] * r1[..., 0]], -1)
    err = max(float(np.max(np.abs(np.einsum("...i,...i->...", r0, r0) - 1))),
              float(np.max(np.abs(np.einsum("...i,...i->...", r1, r1) - 1))),
              float(np.max(np.abs(np.einsum("...i,...i->...", r0, r1)))),
              float(np.max(np.abs(c - r2))))
    if err > tol:
        raise StiffnessError(f"{name}: not a proper rotation (|R Rᵀ − I| = {err:.1e}, "
                             f"tolerance {tol:.0e})")
    return R


def _vec3(p, name):
    p = np.asarray(p, dtype=float)
    if p.shape[-1:] != (3,):
        raise StiffnessError(f"{name}: expected 3-vectors (..., 3), got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise StiffnessError(f"{name}: contains non-finite entries")
    return p


def _blocks(A, B, C, D):
    top = np.concatenate(np.broadcast_arrays(A, B), -1)
    bot = np.concatenate(np.broadcast_arrays(C, D), -1)
    return np.concatenate(np.broadcast_arrays(top, bot), -2)


def plucker(n, r) -> np.ndarray:
    """Normalised Plücker coordinates ``N = (n, r × n)`` of lines through ``r`` along ``n``.

    ``n`` is normalised (a zero direction raises).  Shapes ``(..., 3)`` → ``(..., 6)``.
    """
    n, r = _vec3(n, "n"), _vec3(r, "r")
    ln = np.linalg.norm(n, axis=-1, keepdims=True)
    if np.any(ln < 1e-12):
        raise StiffnessError("plucker: direction n has zero length")
    n = n / ln
    n, r = np.broadcast_arrays(n, r)
    return np.concatenate([n, np.cross(r, n)], -1)


def shift_wrench(p) -> np.ndarray:
    """S: wrench transform for a shift of the origin to ``p``: ``m' = m − p × f``."""
    p = _vec3(p, "p")
    Z = np.zeros(p.shape[:-1] + (3, 3))
    return _blocks(Z + _E, Z, -skew(p), Z + _E)


def shift_twist(p) -> np.ndarray:
    """S*: displacement transform for a shift of the origin to ``p``: ``δ' = δ − p × θ``."""
    p = _vec3(p, "p")
    Z = np.zeros(p.shape[:-1] + (3, 3))
    return _blocks(Z + _E, -skew(p), Z, Z + _E)


def rotate_six(R) -> np.ndarray:
    """H = H*: six-vector transform for a rotation of the axes, ``diag(R, R)``."""
    R = check_rotation(R)
    Z = np.zeros_like(R)
    return _blocks(R, Z, Z, R)


def wrench_transform(R, p) -> np.ndarray:
    """T = H S = ``[[R, 0], [−R[p], R]]``: wrenches into the frame (origin ``p``, ``r' = R(r − p)``)."""
    R = check_rotation(R)
    p = _vec3(p, "p")
    Z = np.zeros(np.broadcast_shapes(R.shape, p.shape[:-1] + (3, 3)))
    return _blocks(R + Z, Z, -R @ skew(p), R + Z)


def twist_transform(R, p) -> np.ndarray:
    """T* = H* S* = ``[[R, −R[p]], [0, R]]``: small displacements into the new frame (= T⁻ᵀ)."""
    R = check_rotation(R)
    p = _vec3(p, "p")
    Z = np.zeros(np.broadcast_shapes(R.shape, p.shape[:-1] + (3, 3)))
    return _blocks(R + Z, -R @ skew(p), Z, R + Z)


def wrench_transform_inverse(R, p) -> np.ndarray:
    """T⁻¹ = ``[[Rᵀ, 0], [[p] Rᵀ, Rᵀ]]`` (back to the old frame)."""
    R = check_rotation(R)
    Rt = np.swapaxes(R, -1, -2)
    p = _vec3(p, "p")
    Z = np.zeros(np.broadcast_shapes(R.shape, p.shape[:-1] + (3, 3)))
    return _blocks(Rt + Z, Z, skew(p) @ Rt, Rt + Z)


def twist_transform_inverse(R, p) -> np.ndarray:
    """T*⁻¹ = ``[[Rᵀ, [p] Rᵀ], [0, Rᵀ]]``."""
    R = check_rotation(R)
    Rt = np.swapaxes(R, -1, -2)
    p = _vec3(p, "p")
    Z = np.zeros(np.broadcast_shapes(R.shape, p.shape[:-1] + (3, 3)))
    return _blocks(Rt + Z, skew(p) @ Rt, Z, Rt + Z)


def compose_frames(R1, p1, R2, p2):
    """The single frame change equal to (R1, p1) followed by (R2, p2 given in frame 1).

    Returns ``(R, p)`` with ``T(R, p) = T(R2, p2) T(R1, p1)``: ``R = R2 R1`` and
    ``p = p1 + R1ᵀ p2``.
    """
    R1, R2 = check_rotation(R1, "R1"), check_rotation(R2, "R2")
    p1, p2 = _vec3(p1, "p1"), _vec3(p2, "p2")
    return R2 @ R1, p1 + (np.swapaxes(R1, -1, -2) @ p2[..., None])[..., 0]


def to_moment_first(X) -> np.ndarray:
    """Reorder a six-vector ``(..., 6)`` or 6x6 matrix ``(..., 6, 6)`` from force-first
    ``(f, m)`` / ``(δ, θ)`` to moment-first ``(m, f)`` / ``(θ, δ)`` (Featherstone,
    Modern Robotics, pinocchio): ``S X`` or ``S X S`` with ``S = [[0, I], [I, 0]]``."""
    X = np.asarray(X, dtype=float)
    if X.shape[-2:] == (6, 6):
        return SWAP @ X @ SWAP
    if X.shape[-1:] == (6,):
        return X[..., [3, 4, 5, 0, 1, 2]]
    raise StiffnessError(f"to_moment_first: expected (..., 6) or (..., 6, 6), got {X.shape}")


from_moment_first = to_moment_first  # the swap is its own inverse
