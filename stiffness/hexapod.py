"""Hexapods (Gough–Stewart platforms): legs, leg matrix P, K = P Kθ Pᵀ, loads and maps."""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd

from closure.frames import exp_so3, skew

from .errors import SingularPoseWarning, StiffnessError
from .matrices import _check_points, stiffness_matrix, transform_stiffness
from .sixvector import check_rotation

__all__ = ["Hexapod", "StiffnessResult"]


@dataclass
class StiffnessResult:
    """Stiffness of a hexapod at a pose.

    Attributes
    ----------
    K : numpy.ndarray, shape (6, 6)
        Stiffness relating ``W = (f, m)`` to ``Δ = (δ, θ)`` (blocks N/m, N/rad, N·m/rad).
    reference : numpy.ndarray, shape (3,)
        The reference point (origin of the result's frame) in base coordinates (m).
    R : numpy.ndarray, shape (3, 3)
        Axes of the result's frame: ``r' = R (r − reference)``.
    loaded : bool
        False: the unloaded (congruence) stiffness P Kθ Pᵀ; True: with the geometric
        term of the leg forces (in general not symmetric).
    cond_P : float
        Condition number of the dimensionless leg matrix (moment rows divided by
        the platform radius).
    """

    K: np.ndarray
    reference: np.ndarray
    R: np.ndarray
    loaded: bool
    cond_P: float


class Hexapod:
    """A six-legged parallel mechanism with axially elastic legs.

    Parameters
    ----------
    base_points : array_like, shape (n, 3)
        Leg attachment points on the base, base frame (m).
    platform_points : array_like, shape (n, 3)
        Leg attachment points on the platform, platform frame (m).
    leg_stiffness : float or array_like, shape (n,)
        Axial stiffness of each leg (N/m).
    singular_cond : float
        cond(P) above which a :class:`SingularPoseWarning` is issued.

    Notes
    -----
    ``pose`` arguments are the platform's 4x4 transform in the base frame, or a
    batch ``(B, 4, 4)``.  Unless a frame is given, results refer to the base
    origin and base axes.
    """

    _BLOCK = 4096

    def __init__(self, base_points, platform_points, leg_stiffness, *, singular_cond=1e8):
        self.base = _check_points(base_points, "base_points")
        n = self.base.shape[0]
        if n < 6:
            raise StiffnessError(f"base_points: a hexapod needs at least 6 legs, got {n}")
        self.platform = _check_points(platform_points, "platform_points", n)
        try:
            k = np.broadcast_to(np.asarray(leg_stiffness, dtype=float), (n,)).copy()
        except (TypeError, ValueError):
            raise StiffnessError(f"leg_stiffness: expected a number or {n} numbers (N/m), got "
                                 f"{leg_stiffness!r}") from None
        if not np.all(np.isfinite(k)) or np.any(k <= 0):
            raise StiffnessError("leg_stiffness: expected positive finite values (N/m)")
        self.k = k
        self.singular_cond = float(singular_cond)
        self.radius = float(max(np.linalg.norm(self.platform, axis=1).max(),
                                np.linalg.norm(self.base, axis=1).max() * 1e-3, 1e-12))

    # ---------------------------------------------------------------- geometry
    @staticmethod
    def _pose(pose):
        T = np.asarray(pose, dtype=float)
        if T.shape[-2:] != (4, 4):
            raise StiffnessError(f"pose: expected a 4x4 transform or (B, 4, 4), got {T.shape}")
        check_rotation(T[..., :3, :3], "pose rotation")
        return T

    def platform_points_world(self, pose) -> np.ndarray:
        """Platform attachment points in the base frame ``(..., n, 3)``."""
        T = self._pose(pose)
        return np.einsum("...ij,nj->...ni", T[..., :3, :3], self.platform) + T[..., None, :3, 3]

    def legs(self, pose):
        """Leg lengths ``(..., n)`` (m) and unit vectors ``(..., n, 3)`` from base to platform."""
        d = self.platform_points_world(pose) - self.base
        L = np.linalg.norm(d, axis=-1)
        if np.any(L < 1e-12):
            raise StiffnessError("pose: a leg has zero length (attachment points coincide)")
        return L, d / L[..., None]

    def leg_matrix(self, pose) -> np.ndarray:
        """``P`` ``(..., 6, n)``: columns are the legs' Plücker coordinates about the base origin."""
        T = self._pose(pose)
        return self._leg_matrix(T.reshape(-1, 4, 4)).reshape(T.shape[:-2] + (6, -1))

    def _leg_matrix(self, T) -> np.ndarray:
        """P for a checked batch ``(B, 4, 4)`` (the hot path of maps)."""
        B = T.shape[0]
        Tc = np.ascontiguousarray(T[:, :3, :].transpose(1, 2, 0))        # (3, 4, B)
        p = self.platform
        # platform points in the base frame, one contiguous (B, n) array per coordinate
        x, y, z = (Tc[i, 0][:, None] * p[:, 0] + Tc[i, 1][:, None] * p[:, 1]
                   + Tc[i, 2][:, None] * p[:, 2] + Tc[i, 3][:, None] for i in range(3))
        dx, dy, dz = x - self.base[:, 0], y - self.base[:, 1], z - self.base[:, 2]
        L = np.sqrt(dx * dx + dy * dy + dz * dz)
        if np.any(L < 1e-12):
            raise StiffnessError("pose: a leg has zero length (attachment points coincide)")
        P = np.empty((B, 6, p.shape[0]))
        np.divide(dx, L, out=P[:, 0])
        np.divide(dy, L, out=P[:, 1])
        np.divide(dz, L, out=P[:, 2])
        ux, uy, uz = P[:, 0], P[:, 1], P[:, 2]
        P[:, 3] = y * uz - z * uy
        P[:, 4] = z * ux - x * uz
        P[:, 5] = x * uy - y * ux
        return P

    def cond_P(self, pose) -> np.ndarray:
        """Condition number of the dimensionless P (moment rows / platform radius)."""
        return self._cond(self.leg_matrix(pose))

    def _cond(self, P) -> np.ndarray:
        """cond of a leg matrix ``(..., 6, n)`` made dimensionless by the platform radius."""
        Ps = P.copy()
        Ps[..., 3:, :] /= self.radius
        s = np.linalg.svd(Ps, compute_uv=False)
        with np.errstate(divide="ignore"):
            return np.where(s[..., -1] > 0, s[..., 0] / s[..., -1], np.inf)

    def _warn(self, c, what):
        c = np.asarray(c)
        if np.any(c > self.singular_cond):
            warnings.warn(f"{what}: leg matrix near singular, cond(P) = {np.max(c):.2e} > "
                          f"{self.singular_cond:.0e}; stiffness there is unreliable",
                          SingularPoseWarning, stacklevel=3)

    @staticmethod
    def _frame(frame, pose):
        if frame is None:
            return np.eye(3), np.zeros(3)
        if isinstance(frame, str):
            if frame != "platform":
                raise StiffnessError(f"frame: expected None, 'platform' or (R, p), got {frame!r}")
            T = np.asarray(pose, dtype=float)
            return np.swapaxes(T[..., :3, :3], -1, -2), T[..., :3, 3]
        try:
            R, p = frame
        except (TypeError, ValueError):
            raise StiffnessError("frame: expected (R, p) with R 3x3 and p a 3-vector") from None
        return check_rotation(R, "frame R"), np.asarray(p, dtype=float)

    # ---------------------------------------------------------------- stiffness
    def stiffness(self, pose, frame=None) -> StiffnessResult | np.ndarray:
        """Unloaded stiffness ``K = P diag(k) Pᵀ`` at ``pose``.

        Parameters
        ----------
        pose : array_like, shape (4, 4) or (B, 4, 4)
        frame : None, "platform" or (R, p)
            The result's frame: base origin and axes (None), the platform frame,
            or origin ``p`` (base coordinates) with ``r' = R (r − p)``.

        Returns
        -------
        StiffnessResult for one pose; for a batch, the array ``(B, 6, 6)``
        (use :meth:`map` for tables).
        """
        T = self._pose(pose)
        P = self.leg_matrix(T)
        c = self._cond(P)
        self._warn(c, "stiffness")
        K = stiffness_matrix(P, self.k)
        R, p = self._frame(frame, T)
        if frame is not None:
            K = transform_stiffness(K, R, p)
        if T.ndim == 3:
            return K
        return StiffnessResult(K, np.asarray(p, dtype=float), np.asarray(R), False, float(c))

    def compliance(self, pose) -> np.ndarray:
        """``C = K⁻¹ = P⁻ᵀ diag(1/k) P⁻¹`` (six legs: through P, never forming K)."""
        P = self.leg_matrix(self._pose(pose))
        if P.shape[-1] != 6:
            return np.linalg.inv(stiffness_matrix(P, self.k))
        Pi = np.linalg.inv(P)
        self._warn(self._cond(P), "compliance")
        return np.swapaxes(Pi, -1, -2) @ (Pi / self.k[:, None])

    def leg_forces(self, pose, wrench) -> np.ndarray:
        """Axial leg forces ``τ`` (N, tension positive: pulling the platform towards the
        base) that balance an external wrench ``(f, m)`` about the base origin: ``P τ = W``."""
        W = np.asarray(wrench, dtype=float)
        if W.shape[-1:] != (6,):
            raise StiffnessError(f"wrench: expected a 6-vector (f, m), got shape {W.shape}")
        P = self.leg_matrix(self._pose(pose))
        self._warn(self._cond(P), "leg_forces")
        if P.shape[-1] == 6:
            return np.linalg.solve(P, W[..., None])[..., 0]
        return (np.linalg.pinv(P) @ W[..., None])[..., 0]

    def deflection(self, pose, wrench) -> np.ndarray:
        """Small displacement ``Δ = C W`` (m, rad) about the base origin under a wrench."""
        W = np.asarray(wrench, dtype=float)
        return (self.compliance(pose) @ W[..., None])[..., 0]

    def loaded_stiffness(self, pose, wrench) -> StiffnessResult:
        """Stiffness under an external wrench ``W = (f, m)`` about the base origin.

        The legs balance the load with forces ``τ = P⁻¹ W`` (tension positive).
        K is the derivative of the wrench that holds the platform displaced by
        ``Δ``, taken about the reference point carried by the platform (the
        platform point at the base origin in this pose).  Moving the platform
        rotates the leg lines, which adds the geometric term of the
        conservative congruence transformation (Chen & Kao):
        ``K = P Kθ Pᵀ + Σ τ_i ∂N_i/∂Δ + [[0, 0], [[f], 0]]``.  It is symmetric
        exactly when the external moment about the reference point is zero.
        Reference: base origin and axes.  Checked against finite differences of
        the equilibrium in the tests.
        """
        T = self._pose(pose)
        if T.ndim != 2:
            raise StiffnessError("loaded_stiffness: one pose at a time")
        tau = self.leg_forces(T, wrench)
        L, u = self.legs(T)
        r = self.platform_points_world(T)
        P = self.leg_matrix(T)
        K = stiffness_matrix(P, self.k)
        G = np.zeros((6, 6))
        for i in range(self.base.shape[0]):
            # dr = δ + θ × r = [I, −[r]] Δ ;  du = (I − u uᵀ) dr / L
            Dr = np.concatenate([np.eye(3), -skew(r[i])], 1)
            Du = (np.eye(3) - np.outer(u[i], u[i])) @ Dr / L[i]
            dN = np.concatenate([Du, skew(r[i]) @ Du - skew(u[i]) @ Dr], 0)
            G += tau[i] * dN
        # held wrench about the carried reference point: m' = m − δ × f adds [f] δ
        G[3:, :3] += skew(np.asarray(wrench, dtype=float)[:3])
        return StiffnessResult(K + G, np.zeros(3), np.eye(3), True, float(self._cond(P)))

    # ---------------------------------------------------------------- maps
    def map(self, positions, rotations=None, frame: str | None = "platform") -> pd.DataFrame:
        """Stiffness indices over every combination of positions × orientations (vectorised).

        Parameters
        ----------
        positions : array_like, shape (M, 3)
            Platform origins in the base frame (m).
        rotations : array_like, shape (R, 3), optional
            Platform orientations as rotation vectors (rad); default the identity.
        frame : "platform" or None
            Reference of the indices: the platform origin (default) or the base origin.

        Returns
        -------
        pandas.DataFrame
            One row per pose: ``x, y, z`` (m), ``rx, ry, rz`` (rad), ``kt_min``,
            ``kt_max`` (N/m, eigenvalues of the translational block), ``cr_max``
            (rad/(N·m), largest rotational compliance eigenvalue), ``cond_P`` and
            ``singular`` (cond_P above the limit).
        """
        pos = _check_points(positions, "positions")
        rv = np.zeros((1, 3)) if rotations is None else _check_points(rotations, "rotations")
        Rm = exp_so3(rv)
        B = pos.shape[0] * rv.shape[0]
        T = np.zeros((pos.shape[0], rv.shape[0], 4, 4))
        T[..., :3, :3] = Rm[None]
        T[..., :3, 3] = pos[:, None]
        T[..., 3, 3] = 1
        T = T.reshape(B, 4, 4)
        K, c = self.stiffness_batch(T, frame)
        kt = np.linalg.eigvalsh(K[:, :3, :3])
        sing = c > self.singular_cond
        cr = np.full((B, 3), np.nan)
        if (~sing).any():
            C = np.linalg.inv(K[~sing])[:, 3:, 3:]
            cr[~sing] = np.linalg.eigvalsh(0.5 * (C + np.swapaxes(C, -1, -2)))
        df = pd.DataFrame({
            "x": T[:, 0, 3], "y": T[:, 1, 3], "z": T[:, 2, 3],
            "rx": np.repeat(rv[None], pos.shape[0], 0).reshape(B, 3)[:, 0],
            "ry": np.repeat(rv[None], pos.shape[0], 0).reshape(B, 3)[:, 1],
            "rz": np.repeat(rv[None], pos.shape[0], 0).reshape(B, 3)[:, 2],
            "kt_min": kt[:, 0], "kt_max": kt[:, 2], "cr_max": cr[:, 2], "cond_P": c,
            "singular": sing,
        })
        df.attrs["reference"] = "platform origin" if frame == "platform" else "base origin"
        df.attrs["units"] = {"kt_min": "N/m", "kt_max": "N/m", "cr_max": "rad/(N·m)"}
        return df

    def stiffness_batch(self, T, frame=None, cond: bool = True):
        """K ``(B, 6, 6)`` and cond(P) ``(B,)`` for a batch of poses, no warnings
        (the caller flags singular rows).  ``frame``: None (base origin) or "platform".
        ``cond=False`` skips the singular values (cond is then None)."""
        T = self._pose(T)
        if frame not in (None, "platform"):
            raise StiffnessError(f"frame: expected None or 'platform' for a batch, got {frame!r}")
        B = T.shape[0]
        K = np.empty((B, 6, 6))
        c = np.empty(B) if cond else None
        # cache blocking: the temporaries of a block stay in cache (same arithmetic)
        for i in range(0, B, self._BLOCK):
            sl = slice(i, i + self._BLOCK)
            K[sl], ci = self._stiffness_block(T[sl], frame, cond)
            if cond:
                c[sl] = ci
        return K, c

    def _stiffness_block(self, T, frame, cond):
        P = self._leg_matrix(T)
        c = self._cond(P) if cond else None
        if frame == "platform":
            # shift the Plücker moments to the platform origin, rotate into its axes
            Rt = np.swapaxes(T[:, :3, :3], -1, -2)
            o = T[:, None, :3, 3]
            n = np.swapaxes(P[:, :3], -1, -2)
            m = np.swapaxes(P[:, 3:], -1, -2) - np.cross(o, n)
            P = np.concatenate([Rt @ np.swapaxes(n, -1, -2), Rt @ np.swapaxes(m, -1, -2)], 1)
        return stiffness_matrix(P, self.k), c
