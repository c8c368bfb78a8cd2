"""Hexapods (Gough–Stewart platforms): legs, leg matrix P, K = P Kθ Pᵀ, loads and maps."""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd

from closure.frames import exp_so3, skew

from .errors import SingularPoseError, SingularPoseWarning, StiffnessError
from .matrices import _congruence
from .sixvector import rotate_six, shift_wrench, wrench_transform
from .validate import (ROTATION_TOL, as_array, broadcast, first_bad, number, points,
                       reference_frame, transform)

__all__ = ["Hexapod", "StiffnessResult"]

#: the unique products u_a u_b of a leg direction (a ≤ b)
_PAIRS = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
_LAST_ROW = np.array([0.0, 0.0, 0.0, 1.0])
# rotation check on the rows (T00 … T23): products of entries _CHK_A × _CHK_B, combined
_CHK_A = np.array([0, 1, 2, 4, 5, 6, 0, 1, 2, 1, 2, 0, 2, 0, 1])
_CHK_B = np.array([0, 1, 2, 4, 5, 6, 4, 5, 6, 6, 4, 5, 5, 6, 4])
_CHK_SEL = np.zeros((6, 18))
_CHK_SEL[0, 0:3] = _CHK_SEL[1, 3:6] = _CHK_SEL[2, 6:9] = 1.0
for _k in range(3):
    _CHK_SEL[3 + _k, [9 + _k, 12 + _k, 15 + _k]] = (1.0, -1.0, -1.0)
_CHK_OFF = np.array([1.0, 1.0, 0.0, 0.0, 0.0, 0.0])[:, None]
#: cond(P) from the Gram matrix's eigenvalues up to this value (relative error about
#: cond² · ε there, below 1e-7); above it, from singular values
GRAM_COND_LIMIT = 1e4
#: poses per chunk of :meth:`Hexapod.map` (bounds its working memory)
MAP_CHUNK = 4096
#: the float columns of a map, in order (then ``singular``)
_MAP_FLOATS = ("x", "y", "z", "rx", "ry", "rz", "kt_min", "kt_max", "cr_max", "cond_P")


@dataclass(repr=False)
class StiffnessResult:
    """Stiffness of a hexapod at a pose or a batch of poses ``(...)``.

    Attributes
    ----------
    K : numpy.ndarray, shape (..., 6, 6)
        Stiffness relating ``W = (f, m)`` to ``Δ = (δ, θ)`` (blocks N/m, N/rad, N·m/rad).
    reference : numpy.ndarray, shape (..., 3)
        The reference point (origin of the result's frame) in base coordinates (m).
    R : numpy.ndarray, shape (..., 3, 3)
        Axes of the result's frame: ``r' = R (r − reference)``.
    loaded : bool
        False: the unloaded (congruence) stiffness P Kθ Pᵀ; True: with the geometric
        term of the leg forces (in general not symmetric).
    cond_P : float or numpy.ndarray, shape (...)
        Condition number of the dimensionless leg matrix (moments about the platform
        points' centroid divided by the platform radius; see :meth:`Hexapod.cond_P`).
    """

    K: np.ndarray
    reference: np.ndarray
    R: np.ndarray
    loaded: bool
    cond_P: float | np.ndarray

    def __repr__(self) -> str:
        kind = "loaded" if self.loaded else "unloaded"
        batch = self.K.shape[:-2]
        if batch:
            c = np.asarray(self.cond_P)
            return (f"StiffnessResult({kind}, {' × '.join(map(str, batch))} poses, "
                    f"cond(P) {c.min():.3g} … {c.max():.3g})")
        kt = np.linalg.eigvalsh(0.5 * (self.K[:3, :3] + self.K[:3, :3].T))
        ref = ", ".join(f"{v:.4g}" for v in self.reference)
        return (f"StiffnessResult({kind}, about ({ref}) m, translational stiffness "
                f"{kt[0]:.4g} … {kt[-1]:.4g} N/m, cond(P) {float(self.cond_P):.4g})")


class Hexapod:
    """A six-legged parallel mechanism with axially elastic legs.

    Parameters
    ----------
    base_points : array_like, shape (n, 3)
        Leg attachment points on the base, base frame (m), n ≥ 6.
    platform_points : array_like, shape (n, 3)
        Leg attachment points on the platform, platform frame (m).
    leg_stiffness : float or array_like, shape (n,)
        Axial stiffness of each leg (N/m), positive.
    singular_cond : float
        cond(P) above which a pose is singular: :meth:`stiffness` warns
        (:class:`SingularPoseWarning`), :meth:`map` flags the row, and the methods
        that invert P (:meth:`compliance`, :meth:`leg_forces`, :meth:`deflection`,
        :meth:`loaded_stiffness`) raise :class:`SingularPoseError`.
    warn_cond : float
        cond(P) above which those methods warn (:class:`SingularPoseWarning`): leg
        forces and deflections are then amplified by up to ~cond(P) and the pose is
        near a singularity (default 1e6, at most ``singular_cond``).

    Notes
    -----
    ``pose`` arguments are the platform's 4x4 transform in the base frame, or a
    batch ``(B, 4, 4)``.  Unless a frame is given, results refer to the base
    origin and base axes.  cond(P) is taken of P with moments about the platform
    points' centroid divided by the platform radius, so it depends on the mechanism
    alone (not on where the base frame is, nor on the length unit); every length
    tolerance is relative to the model's size.

    Raises
    ------
    StiffnessError
        Wrong shapes or types, non-finite values, fewer than 6 legs, non-positive
        leg stiffness, or all attachment points at the origin.
    """

    _BLOCK = 4096
    #: a leg shorter than this fraction of the model's size has no direction
    _ZERO_LEG = 1e-12

    def __init__(self, base_points, platform_points, leg_stiffness, *, singular_cond=1e8,
                 warn_cond=1e6):
        self.base = points(base_points, "base_points")
        n = self.base.shape[0]
        if n < 6:
            raise StiffnessError(f"base_points: a hexapod needs at least 6 legs, got {n}")
        self.platform = points(platform_points, "platform_points", n)
        k = as_array(leg_stiffness, "leg_stiffness",
                     what=f"a number or {n} numbers (N/m)")
        if k.shape not in ((), (1,), (n,)):
            raise StiffnessError(f"leg_stiffness: expected a number or {n} numbers (N/m), got "
                                 f"shape {k.shape}")
        k = np.broadcast_to(k, (n,)).copy()
        if np.any(k <= 0):
            raise StiffnessError(f"leg_stiffness: expected positive finite values (N/m), got "
                                 f"{k[np.argmin(k)]} for leg {int(np.argmin(k)) + 1}")
        self.k = k
        self.singular_cond = number(singular_cond, "singular_cond", positive=True)
        self.warn_cond = min(number(warn_cond, "warn_cond", positive=True), self.singular_cond)
        rb = float(np.linalg.norm(self.base, axis=1).max())
        rp = float(np.linalg.norm(self.platform, axis=1).max())
        #: the model's size (m): every length tolerance is relative to it
        self.size = max(rb, rp)
        if self.size == 0:
            raise StiffnessError("base_points, platform_points: every attachment point is at the "
                                 "origin; expected a hexapod of non-zero size")
        #: centroid (platform frame) and radius of the platform points (m): the reference
        #: and length that make P dimensionless for cond(P)
        self._centroid = self.platform.mean(0)
        rc = float(np.linalg.norm(self.platform - self._centroid, axis=1).max())
        self.radius = rc if rc > 0 else self.size

    # ---------------------------------------------------------------- geometry
    @staticmethod
    def _pose(pose):
        return transform(pose, "pose")

    def _check_lengths(self, L):
        """Raise if a leg has (relatively) zero length: its direction is undefined."""
        short = L <= self._ZERO_LEG * self.size
        if np.any(short):
            i = first_bad(short)
            raise StiffnessError(f"pose: leg {i[-1] + 1} has zero length ({float(L[i]):.1e} m, "
                                 f"model size {self.size:.3g} m): its attachment points "
                                 "coincide" + (f" (pose index {i[:-1]})" if len(i) > 1 else ""))

    def platform_points_world(self, pose) -> np.ndarray:
        """Platform attachment points in the base frame ``(..., n, 3)``."""
        T = self._pose(pose)
        return np.einsum("...ij,nj->...ni", T[..., :3, :3], self.platform) + T[..., None, :3, 3]

    def legs(self, pose):
        """Leg lengths ``(..., n)`` (m) and unit vectors ``(..., n, 3)`` from base to platform."""
        d = self.platform_points_world(pose) - self.base
        L = np.linalg.norm(d, axis=-1)
        self._check_lengths(L)
        return L, d / L[..., None]

    def leg_matrix(self, pose) -> np.ndarray:
        """``P`` ``(..., 6, n)``: columns are the legs' Plücker coordinates about the base origin."""
        return self._P(self._pose(pose))

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
        self._check_lengths(L)
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
        """Condition number of the dimensionless leg matrix at ``pose`` (see :meth:`_cond`):
        a property of the mechanism alone, unchanged by a rigid motion of the whole
        model or a change of length unit."""
        T = self._pose(pose)
        return self._cond(self._P(T), T)

    def _cond(self, P, T) -> np.ndarray:
        """cond of a leg matrix ``(..., 6, n)`` made dimensionless: moments taken about the
        platform points' centroid and divided by the platform radius (the points' largest
        distance from it).  Both belong to the platform, so the figure does not depend on
        where the base frame is (a far origin would otherwise swamp the moment rows) or on
        the length unit."""
        return self._cond_local(self._at_centroid(P, T))

    def _cond_local(self, Pc) -> np.ndarray:
        """cond of ``Pc`` (moments about the centroid) with the moment rows / radius."""
        Ps = Pc.copy()
        Ps[..., 3:, :] /= self.radius
        s = np.linalg.svd(Ps, compute_uv=False)
        with np.errstate(divide="ignore"):
            return np.where(s[..., -1] > 0, s[..., 0] / s[..., -1], np.inf)

    def _at_centroid(self, P, T) -> np.ndarray:
        """The legs' Plücker columns ``(..., 6, n)`` about the platform centroid (base axes).

        Moments are ``(R (p_i − c)) × n_i`` from the platform's own coordinates, never
        ``m − c × n``, which would cancel digits when the base origin is far away."""
        q = self.platform - self._centroid                                # (n, 3)
        R = T[..., :3, :3]
        x, y, z = (R[..., i, 0, None] * q[:, 0] + R[..., i, 1, None] * q[:, 1]
                   + R[..., i, 2, None] * q[:, 2] for i in range(3))       # (..., n) each
        n = P[..., :3, :]
        out = np.empty(P.shape)
        out[..., :3, :] = n
        ux, uy, uz = n[..., 0, :], n[..., 1, :], n[..., 2, :]
        out[..., 3, :] = y * uz - z * uy
        out[..., 4, :] = z * ux - x * uz
        out[..., 5, :] = x * uy - y * ux
        return out

    def _local(self, T):
        """``(S, Pc, cond)``: the wrench shift S ``(..., 6, 6)`` from the base origin to the
        platform centroid, P about the centroid (``Pc = S P``) and cond(P).  Leg forces,
        compliance and deflection are solved with Pc, which stays well conditioned
        however far the base origin is, and carried back to the base origin by S."""
        Pc = self._at_centroid(self._P(T), T)
        centre = T[..., :3, :3] @ self._centroid + T[..., :3, 3]
        return shift_wrench(centre), Pc, self._cond_local(Pc)

    def _warn(self, c, what):
        c = np.asarray(c)
        if np.any(c > self.singular_cond):
            warnings.warn(f"{what}: leg matrix near singular, cond(P) = {np.max(c):.2e} > "
                          f"{self.singular_cond:.0e}; stiffness there is unreliable",
                          SingularPoseWarning, stacklevel=3)

    def _regular(self, c, what) -> bool:
        """Raise :class:`SingularPoseError` where cond(P) exceeds ``singular_cond``; return
        whether any pose is beyond ``warn_cond`` (the caller warns with its figure)."""
        c = np.asarray(c, dtype=float)
        bad = ~(c <= self.singular_cond)
        if np.any(bad):
            i = first_bad(bad) if c.ndim else ()
            where = f" (pose index {i})" if i else ""
            raise SingularPoseError(f"pose: pose is singular (cond(P) = {float(c[i]):.2e} > "
                                    f"singular_cond = {self.singular_cond:.0e}){where}; {what} "
                                    "undefined there")
        return bool(np.any(c > self.warn_cond))

    def _near_singular(self, c, what, figure=""):
        warnings.warn(f"{what}: pose near singular, cond(P) = {float(np.max(c)):.2e} > "
                      f"warn_cond = {self.warn_cond:.0e}{figure}; leg forces and deflections "
                      "are amplified by up to ~cond(P) there", SingularPoseWarning, stacklevel=3)

    @staticmethod
    def _frame(frame, T):
        R, p = reference_frame(frame, T)
        if not isinstance(frame, str) and frame is not None:
            broadcast(pose=T.shape[:-2], frame_R=R.shape[:-2], frame_p=p.shape[:-1])
        return R, p

    # ---------------------------------------------------------------- stiffness
    def __repr__(self) -> str:
        k = self.k
        ks = f"{k[0]:.4g}" if np.all(k == k[0]) else f"{k.min():.4g} … {k.max():.4g}"
        return (f"Hexapod({len(k)} legs, base radius "
                f"{np.linalg.norm(self.base, axis=1).max():.4g} m, platform radius "
                f"{np.linalg.norm(self.platform, axis=1).max():.4g} m, leg stiffness {ks} N/m)")

    def stiffness(self, pose, frame=None) -> StiffnessResult:
        """Unloaded stiffness ``K = P diag(k) Pᵀ`` at ``pose``.

        Parameters
        ----------
        pose : array_like, shape (4, 4) or (B, 4, 4)
        frame : "base" (or None), "platform" or (R, p)
            The result's frame: base origin and axes (the default), the platform
            frame, or origin ``p`` (base coordinates) with ``r' = R (r − p)``.

        Returns
        -------
        StiffnessResult
            For one pose or a batch (then ``K`` is ``(..., 6, 6)``, ``reference``
            ``(..., 3)``, ``R`` ``(..., 3, 3)`` and ``cond_P`` ``(...)``); use
            :meth:`map` for tables of indices.
        """
        T = self._pose(pose)
        P = self._P(T)
        c = self._cond(P, T)
        self._warn(c, "stiffness")
        R, p = self._frame(frame, T)
        if frame is not None:
            # legs' lines into the frame first, then the congruence: exactly T K Tᵀ, but
            # the moment shift m − p × n is done on vectors, not on K's blocks (whose
            # terms grow as |p|² k and would cancel far from the origin)
            P = wrench_transform(R, p) @ P
        K = _congruence(P, self.k)
        batch = T.shape[:-2]
        ref = np.broadcast_to(np.asarray(p, dtype=float), batch + (3,)).copy()
        axes = np.broadcast_to(np.asarray(R, dtype=float), batch + (3, 3)).copy()
        return StiffnessResult(K, ref, axes, False, c if batch else float(c))

    def _P(self, T) -> np.ndarray:
        """P ``(..., 6, n)`` of checked poses ``(..., 4, 4)``."""
        return self._leg_matrix(T.reshape(-1, 4, 4)).reshape(T.shape[:-2] + (6, -1))

    def _wrench(self, wrench, T) -> np.ndarray:
        W = as_array(wrench, "wrench", (6,), what="a wrench (f, m) of shape (..., 6) (N, N·m)")
        broadcast(pose=T.shape[:-2], wrench=W.shape[:-1])
        return W

    def compliance(self, pose) -> np.ndarray:
        """Compliance ``C = K⁻¹`` about the base origin (blocks m/N, rad/N, rad/(N·m)).

        Six legs: ``C = P⁻ᵀ diag(1/k) P⁻¹`` (through P, never forming K), computed
        about the platform centroid, where P is well conditioned, and carried to the
        base origin by the wrench shift S: ``C = Sᵀ C_c S``.

        Parameters
        ----------
        pose : array_like, shape (4, 4) or (B, 4, 4)

        Returns
        -------
        numpy.ndarray, shape (6, 6) or (B, 6, 6)

        Raises
        ------
        SingularPoseError
            ``"pose is singular (cond(P) = …)"`` above ``singular_cond``; a
            :class:`SingularPoseWarning` is issued above ``warn_cond``.
        """
        T = self._pose(pose)
        S, Pc, c = self._local(T)
        near = self._regular(c, "the compliance is")
        C = np.swapaxes(S, -1, -2) @ self._compliance_local(Pc) @ S
        if near:
            self._near_singular(c, "compliance")
        return C

    def _compliance_local(self, Pc) -> np.ndarray:
        """Compliance about the platform centroid from the regular ``Pc``."""
        if Pc.shape[-1] != 6:
            return np.linalg.inv(_congruence(Pc, self.k))
        Pi = np.linalg.inv(Pc)
        return np.swapaxes(Pi, -1, -2) @ (Pi / self.k[:, None])

    def leg_forces(self, pose, wrench) -> np.ndarray:
        """Axial leg forces ``τ`` (N, tension positive: pulling the platform towards the
        base) that balance an external wrench ``(f, m)`` about the base origin: ``P τ = W``
        (more than six legs: the least-norm forces).

        Parameters
        ----------
        pose : array_like, shape (4, 4) or (B, 4, 4)
        wrench : array_like, shape (6,) or (B, 6)
            ``(f, m)`` (N, N·m) about the base origin, broadcast against the poses.

        Returns
        -------
        numpy.ndarray, shape (..., n)

        Raises
        ------
        SingularPoseError
            ``"pose is singular (cond(P) = …)"`` above ``singular_cond``; above
            ``warn_cond`` a :class:`SingularPoseWarning` gives the largest force.
        """
        T = self._pose(pose)
        W = self._wrench(wrench, T)
        S, Pc, c = self._local(T)
        near = self._regular(c, "the leg forces are")
        Wc = S @ W[..., None]                           # the load about the centroid
        if Pc.shape[-1] == 6:
            tau = np.linalg.solve(Pc, Wc)[..., 0]
        else:
            tau = (np.linalg.pinv(Pc) @ Wc)[..., 0]
        if near:
            self._near_singular(c, "leg_forces", f" (largest leg force {np.abs(tau).max():.2e} N "
                                                 f"for a load of |f| = "
                                                 f"{np.linalg.norm(W[..., :3], axis=-1).max():.2e} N)")
        return tau

    def deflection(self, pose, wrench) -> np.ndarray:
        """Small displacement ``Δ = C W`` (m, rad) about the base origin under a wrench
        ``W = (f, m)`` (N, N·m) about the base origin; shapes as :meth:`leg_forces`.

        Raises
        ------
        SingularPoseError
            At a singular pose (see :meth:`compliance`).
        """
        T = self._pose(pose)
        W = self._wrench(wrench, T)
        S, Pc, c = self._local(T)
        near = self._regular(c, "the deflection is")
        # Δ about the centroid under the load there, then back: Δ = Sᵀ Δc (work invariance)
        Dc = self._compliance_local(Pc) @ (S @ W[..., None])
        if near:
            self._near_singular(c, "deflection")
        return (np.swapaxes(S, -1, -2) @ Dc)[..., 0]

    def loaded_stiffness(self, pose, wrench, frame=None) -> StiffnessResult:
        """Stiffness under an external wrench ``W = (f, m)`` about the base origin.

        The legs balance the load with forces ``τ = P⁻¹ W`` (tension positive).
        K is the derivative of the wrench that holds the platform displaced by
        ``Δ``, taken about the reference point carried by the platform (the
        platform point at the frame's origin in this pose).  Moving the platform
        rotates the leg lines, which adds the geometric term of the
        conservative congruence transformation (Chen & Kao):
        ``K = P Kθ Pᵀ + Σ τ_i ∂N_i/∂Δ + [[0, 0], [[f], 0]]``.  It is symmetric
        exactly when the external moment about the reference point is zero.
        Under load the result is not carried to another reference point by
        ``T K Tᵀ`` (the load's moment arm turns with the platform), so it is
        computed about the requested point directly: with ``frame="platform"`` it
        depends on the mechanism alone, however far the base origin is.  Checked
        against finite differences of the equilibrium in the tests.

        Parameters
        ----------
        pose : array_like, shape (4, 4)
        wrench : array_like, shape (6,)
            ``(f, m)`` (N, N·m) about the base origin.
        frame : "base" (or None), "platform" or (R, p)
            The result's reference point and axes, as for :meth:`stiffness`: the
            base origin and axes (the default), the platform frame, or origin ``p``
            (base coordinates, m) with ``r' = R (r − p)``.

        Raises
        ------
        SingularPoseError
            At a singular pose (the leg forces are undefined).
        """
        T = self._pose(pose)
        if T.ndim != 2:
            raise StiffnessError(f"pose: loaded_stiffness takes one pose (4, 4), got shape "
                                 f"{T.shape}")
        W = as_array(wrench, "wrench", (6,), ndim=1, what="a wrench (f, m) of shape (6,)")
        R, p = self._frame(frame, T)
        if R.shape != (3, 3) or p.shape != (3,):
            raise StiffnessError("frame: loaded_stiffness takes one frame (R (3, 3), p (3,)), "
                                 f"got shapes {R.shape} and {p.shape}")
        c = self._cond(self._P(T), T)
        self._regular(c, "the loaded stiffness is")
        tau = self.leg_forces(T, W)
        L, u = self.legs(T)
        # platform points relative to the reference point, from the platform's own
        # coordinates (no cancellation of a far base origin)
        r = self.platform @ T[:3, :3].T + (T[:3, 3] - p)
        P = np.concatenate([u.T, np.cross(r, u).T], 0)        # legs' lines about p
        K = _congruence(P, self.k)
        # dr = δ + θ × r = [I, −[r]] Δ ;  du = (I − u uᵀ) dr / L ;
        # dN = (du, [r] du − [u] dr), all legs at once: (n, 3, 6)
        n = r.shape[0]
        Dr = np.concatenate([np.broadcast_to(np.eye(3), (n, 3, 3)), -skew(r)], 2)
        Du = (np.eye(3) - u[:, :, None] * u[:, None, :]) @ Dr / L[:, None, None]
        dN = np.concatenate([Du, skew(r) @ Du - skew(u) @ Dr], 1)
        G = np.einsum("i,ijk->jk", tau, dN)
        # held wrench about the carried reference point: m' = m − δ × f adds [f] δ
        G[3:, :3] += skew(W[:3])
        H = rotate_six(R)                                     # base axes → the frame's axes
        return StiffnessResult(H @ (K + G) @ H.T, np.asarray(p, dtype=float), np.asarray(R),
                               True, float(c))

    # ---------------------------------------------------------------- maps
    def map(self, positions, rotations=None, *, chunk: int = MAP_CHUNK) -> pd.DataFrame:
        """Stiffness indices over every combination of positions × orientations (vectorised).

        Parameters
        ----------
        positions : array_like, shape (M, 3)
            Platform origins in the base frame (m).
        rotations : array_like, shape (R, 3), optional
            Platform orientations as rotation vectors (rad); default the identity.
        chunk : int
            Poses evaluated at a time (pose ``i`` is position ``i // R``, rotation
            ``i % R``).

        Returns
        -------
        pandas.DataFrame
            One row per pose: ``x, y, z`` (m), ``rx, ry, rz`` (rad), ``kt_min``,
            ``kt_max`` (N/m, eigenvalues of the translational block), ``cr_max``
            (rad/(N·m), largest rotational compliance eigenvalue), ``cond_P`` and
            ``singular`` (cond_P above the limit).  Every index is the same about any
            reference point and in any axes: the translational block of K and the
            rotational block of C do not change when the reference point moves, and a
            rotation of the axes keeps their eigenvalues.

        Notes
        -----
        The poses are generated and evaluated ``chunk`` at a time into the table's own
        preallocated columns, so the working memory is the output (81 bytes per pose)
        plus one chunk; :meth:`map_chunks` yields the table a chunk at a time for maps
        larger than memory.
        """
        pos, rv, chunk = self._map_args(positions, rotations, chunk)
        B = pos.shape[0] * rv.shape[0]
        values = np.empty((B, len(_MAP_FLOATS)))
        singular = np.empty(B, bool)
        for a in range(0, B, chunk):
            self._map_chunk(pos, rv, a, min(B, a + chunk), values[a:a + chunk],
                            singular[a:a + chunk])
        return self._map_frame(values, singular, 0)

    def map_chunks(self, positions, rotations=None, *, chunk: int = MAP_CHUNK):
        """:meth:`map` a chunk of ``chunk`` poses at a time: an iterator of DataFrames (the
        rows of :meth:`map`, with its index), in bounded memory however many poses
        ``positions × rotations`` makes (write each chunk out as it comes)."""
        pos, rv, chunk = self._map_args(positions, rotations, chunk)
        B = pos.shape[0] * rv.shape[0]
        for a in range(0, B, chunk):
            b = min(B, a + chunk)
            values, singular = np.empty((b - a, len(_MAP_FLOATS))), np.empty(b - a, bool)
            self._map_chunk(pos, rv, a, b, values, singular)
            yield self._map_frame(values, singular, a)

    @staticmethod
    def _map_args(positions, rotations, chunk):
        pos = points(positions, "positions")
        rv = np.zeros((1, 3)) if rotations is None else points(rotations, "rotations")
        if isinstance(chunk, bool) or not isinstance(chunk, (int, np.integer)) or chunk < 1:
            raise StiffnessError(f"chunk: expected a positive integer (poses per chunk), got "
                                 f"{chunk!r}")
        return pos, rv, int(chunk)

    def _map_chunk(self, pos, rv, a, b, values, singular):
        """Rows ``a:b`` of the map (pose ``a`` is position ``a // R``, rotation ``a % R``)
        into ``values (b − a, 10)`` and ``singular (b − a,)``."""
        ip, ir = np.divmod(np.arange(a, b), rv.shape[0])
        n = b - a
        T = np.zeros((n, 4, 4))
        T[:, :3, :3] = exp_so3(rv)[ir]
        T[:, :3, 3] = pos[ip]
        T[:, 3, 3] = 1.0
        K, c = self._batch_base(T, True)
        values[:, 0:3] = pos[ip]
        values[:, 3:6] = rv[ir]
        # the translational block of K and the rotational block of C keep their eigenvalues
        # about any reference point and in any axes: the base frame's K serves
        kt = np.linalg.eigvalsh(K[:, :3, :3])
        values[:, 6], values[:, 7] = kt[:, 0], kt[:, 2]
        sing = c > self.singular_cond
        values[:, 8] = np.nan
        if (~sing).any():
            C = np.linalg.inv(K[~sing])[:, 3:, 3:]
            values[~sing, 8] = np.linalg.eigvalsh(0.5 * (C + np.swapaxes(C, -1, -2)))[:, 2]
        values[:, 9] = c
        singular[:] = sing

    @staticmethod
    def _map_frame(values, singular, start) -> pd.DataFrame:
        """The map's DataFrame over ``values`` without copying them."""
        df = pd.DataFrame(values, columns=list(_MAP_FLOATS), copy=False,
                          index=pd.RangeIndex(start, start + len(values)))
        df["singular"] = singular
        df.attrs["reference"] = "platform origin (the indices are the same about any point)"
        df.attrs["units"] = {"kt_min": "N/m", "kt_max": "N/m", "cr_max": "rad/(N·m)"}
        return df

    def stiffness_batch(self, T, frame=None, cond: bool = True):
        """K ``(B, 6, 6)`` and cond(P) ``(B,)`` for a batch of poses, no warnings
        (the caller flags singular rows).  ``frame``: None (base origin) or "platform".
        ``cond=False`` skips the condition numbers (cond is then None).

        Notes
        -----
        About the base origin, K is linear in the legs' direction products ``u uᵀ`` (the
        moment ``m = b × u`` of a leg is a constant matrix times u), so each block of poses
        costs one matrix product ``(B, 6n) @ (6n, 36)`` after the legs' directions, with the
        checks of the transforms fused into the same pass.  cond(P) is taken from the
        eigenvalues of the dimensionless Gram matrix ``P Pᵀ`` (``cond = sqrt(λmax/λmin)``),
        recomputed by singular values where it exceeds :data:`GRAM_COND_LIMIT` (squaring the
        condition would lose its digits there).
        """
        if (type(T) is np.ndarray and T.dtype == np.float64 and T.ndim == 3
                and T.shape[1:] == (4, 4) and frame is None):
            if not isinstance(cond, (bool, np.bool_)):
                raise StiffnessError(f"cond: expected True or False, got {type(cond).__name__}")
            return self._batch_base(T, cond)
        T = transform(T, "T")
        if not isinstance(cond, (bool, np.bool_)):
            raise StiffnessError(f"cond: expected True or False, got {type(cond).__name__}")
        if T.ndim != 3:
            raise StiffnessError(f"T: expected a batch of poses (B, 4, 4), got shape {T.shape}")
        if not (frame is None or isinstance(frame, str) and frame == "platform"):
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

    # ------------------------------------------------------- fast batched kernel
    #: poses per block of the fused kernel (its temporaries stay in cache)
    _FAST_BLOCK = 1024

    def _kernel_maps(self):
        """``(Md (3n, 13), L (6n, 36))``: leg vectors ``d = R p + t − b`` from the rows
        ``(T00 … T23, 1)`` of a pose, and K's 36 entries from the products ``u_a u_b``
        (rows pair-major: ``q n + i`` for pair q of leg i)."""
        cached = getattr(self, "_maps", None)
        if cached is not None:
            return cached
        n = self.base.shape[0]
        Md = np.zeros((3 * n, 13))
        for r in range(3):
            Md[r * n:(r + 1) * n, 4 * r:4 * r + 3] = self.platform
            Md[r * n:(r + 1) * n, 4 * r + 3] = 1.0
            Md[r * n:(r + 1) * n, 12] = -self.base[:, r]
        L = np.zeros((6 * n, 36))
        for q, (a, b) in enumerate(_PAIRS):
            E = np.zeros((3, 3))
            E[a, b] = E[b, a] = 1.0
            for i in range(n):
                G = np.vstack([np.eye(3), skew(self.base[i])])   # (u, b × u) = G u
                L[q * n + i] = (self.k[i] * G @ E @ G.T).ravel()
        self._maps = (Md, L)
        return self._maps

    def _batch_base(self, T, cond):
        """K about the base origin (and cond(P)) of a float64 batch ``(B, 4, 4)``, the
        transforms checked on the way (an invalid one raises as :func:`transform` does)."""
        B, n = T.shape[0], self.base.shape[0]
        Md, Lk = self._kernel_maps()
        K = np.empty((B, 6, 6))
        c = np.empty(B) if cond else None
        Kf = K.reshape(B, 36)
        Tf = T.reshape(B, 16)
        blk = max(1, min(self._FAST_BLOCK, B))
        X = np.empty((13, blk))
        X[12] = 1.0
        D = np.empty((3 * n, blk))
        U = np.empty((6, n, blk))
        Z = np.empty((18, blk))
        tol = ROTATION_TOL
        zero2 = (self._ZERO_LEG * self.size) ** 2
        for s in range(0, B, blk):
            m = min(B, s + blk) - s
            Xb, Db, Ub = X[:, :m], D[:, :m], U[:, :, :m]
            Xb[:12] = Tf[s:s + m, :12].T
            # the transforms: finite, last row (0, 0, 0, 1), rows orthonormal, right-handed
            # (r0·r0 − 1, r1·r1 − 1, r0·r1, r0 × r1 − r2 from 15 products and one product
            # by a constant matrix)
            Zb = Z[:, :m]
            np.multiply(Xb[_CHK_A], Xb[_CHK_B], out=Zb[:15])
            Zb[15:] = Xb[8:11]
            E = _CHK_SEL @ Zb
            E -= _CHK_OFF
            if not (np.abs(E).max() <= tol and np.abs(Tf[s:s + m, 12:] - _LAST_ROW).max() <= tol
                    and np.isfinite(Xb[3:12:4]).all()):
                transform(T, "T")                        # raises with the pose's index
            np.matmul(Md, Xb, out=Db)
            d = Db.reshape(3, n, m)
            L2 = d[0] * d[0]
            L2 += d[1] * d[1]
            L2 += d[2] * d[2]
            if L2.min() <= zero2:
                self._leg_matrix(T)                      # raises with the pose's index
            inv = 1.0 / L2
            for q, (a, b) in enumerate(_PAIRS):
                np.multiply(d[a], d[b], out=Ub[q])
                Ub[q] *= inv
            np.matmul(Ub.reshape(6 * n, m).T, Lk, out=Kf[s:s + m])
            if cond:
                c[s:s + m] = self._cond_fast(d, inv, T[s:s + m])
        return K, c

    def _cond_fast(self, d, inv, T):
        """cond(P) of a block from its leg vectors ``d (3, n, m)``: eigenvalues of the
        dimensionless Gram matrix, singular values where it is ill conditioned."""
        u = d * np.sqrt(inv)                                  # (3, n, m)
        q = self.platform - self._centroid
        R = T[:, :3, :3]
        rq = np.einsum("mij,nj->imn", R, q)                   # (3, m, n) R (p − c)
        Ps = np.empty((T.shape[0], 6, d.shape[1]))
        ut = u.transpose(0, 2, 1)                             # (3, m, n)
        Ps[:, :3] = ut.transpose(1, 0, 2)
        Ps[:, 3] = (rq[1] * ut[2] - rq[2] * ut[1]) / self.radius
        Ps[:, 4] = (rq[2] * ut[0] - rq[0] * ut[2]) / self.radius
        Ps[:, 5] = (rq[0] * ut[1] - rq[1] * ut[0]) / self.radius
        w = np.linalg.eigvalsh(Ps @ np.swapaxes(Ps, 1, 2))
        with np.errstate(divide="ignore", invalid="ignore"):
            c = np.sqrt(w[:, -1] / w[:, 0])
        bad = ~(c <= GRAM_COND_LIMIT)
        if bad.any():
            sv = np.linalg.svd(Ps[bad], compute_uv=False)
            with np.errstate(divide="ignore"):
                c[bad] = np.where(sv[:, -1] > 0, sv[:, 0] / sv[:, -1], np.inf)
        return c

    def _stiffness_block(self, T, frame, cond):
        P = self._leg_matrix(T)
        c = self._cond(P, T) if cond else None
        if frame == "platform":
            # shift the Plücker moments to the platform origin, rotate into its axes
            Rt = np.swapaxes(T[:, :3, :3], -1, -2)
            o = T[:, None, :3, 3]
            n = np.swapaxes(P[:, :3], -1, -2)
            m = np.swapaxes(P[:, 3:], -1, -2) - np.cross(o, n)
            P = np.concatenate([Rt @ np.swapaxes(n, -1, -2), Rt @ np.swapaxes(m, -1, -2)], 1)
        return _congruence(P, self.k), c
