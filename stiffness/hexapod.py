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
            self._zero_length(i, float(L[i]))

    def _zero_length(self, i, length):
        """Raise for leg ``i[-1]`` of pose ``i[:-1]``, of ``length`` (m)."""
        raise StiffnessError(f"pose: leg {i[-1] + 1} has zero length ({length:.1e} m, "
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
        """P for a checked batch ``(B, 4, 4)`` (the pose methods; batches and maps take the
        compiled kernels of :mod:`stiffness.kernels`)."""
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
        K, c = self._kernel_batch(T, False, True)
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
        """Unloaded stiffness and cond(P) of a batch of poses, without warnings (the caller
        flags singular rows).

        Parameters
        ----------
        T : array_like, shape (B, 4, 4)
            Platform transforms in the base frame (translations m), checked.
        frame : None or "platform"
            K about the base origin in base axes (None), or about the platform origin in
            the platform's axes.
        cond : bool
            Also return cond(P) (else ``None`` in its place).

        Returns
        -------
        K : numpy.ndarray, shape (B, 6, 6)
            ``P diag(k) Pᵀ`` (blocks N/m, N/rad, N·m/rad).
        cond : numpy.ndarray, shape (B,), or None
            Condition number of the dimensionless leg matrix (see :meth:`cond_P`).

        Raises
        ------
        StiffnessError
            A transform that is not rigid (naming its index), a leg of zero length, a
            ``frame`` other than None or "platform", or a ``cond`` that is not a bool.

        Notes
        -----
        Evaluated by the compiled kernels of :mod:`stiffness.kernels` (one pass over the
        poses: transform checks, legs, unit vectors, moments and ``Σ k w wᵀ`` over the legs'
        lines ``w = (u, m)``).  cond(P) is taken from the eigenvalues of the dimensionless
        Gram matrix ``P Pᵀ`` (``cond = sqrt(λmax/λmin)``, cyclic Jacobi), recomputed by
        singular values where it exceeds :data:`GRAM_COND_LIMIT` (squaring the condition
        would lose its digits there).  The first call in a new installation compiles the
        kernels (a few seconds); later processes load them from numba's cache.
        """
        fast = (type(T) is np.ndarray and T.dtype == np.float64 and T.ndim == 3
                and T.shape[1:] == (4, 4))           # else checked here, then by the kernel
        if not fast:
            T = transform(T, "T")
        if not isinstance(cond, (bool, np.bool_)):
            raise StiffnessError(f"cond: expected True or False, got {type(cond).__name__}")
        if T.ndim != 3:
            raise StiffnessError(f"T: expected a batch of poses (B, 4, 4), got shape {T.shape}")
        if not (frame is None or isinstance(frame, str) and frame == "platform"):
            raise StiffnessError(f"frame: expected None or 'platform' for a batch, got {frame!r}")
        return self._kernel_batch(T, frame is not None, bool(cond))

    def _kernel_batch(self, T, platform_frame: bool, cond: bool):
        """K ``(B, 6, 6)`` and cond(P) ``(B,)`` (or None) of a float64 batch ``(B, 4, 4)`` by
        the compiled kernels, the transforms checked on the way (an invalid one raises as
        :func:`transform` does, a leg of zero length as :meth:`legs` does).  K about the
        base origin, or about the platform origin in its axes with ``platform_frame``."""
        from .kernels import cond_kernel, scaled_leg_matrices, stiffness_kernel
        T = np.ascontiguousarray(T, dtype=np.float64)
        base, plat = np.ascontiguousarray(self.base), np.ascontiguousarray(self.platform)
        K = np.empty((T.shape[0], 6, 6))
        pose, leg, length = stiffness_kernel(T, base, plat, np.ascontiguousarray(self.k),
                                             platform_frame, ROTATION_TOL,
                                             self._ZERO_LEG * self.size, K)
        if pose >= 0:
            transform(T, "T")                    # raises with the first bad pose's index
            if leg >= 0:
                self._zero_length((pose, leg), length)
            raise StiffnessError(f"T rotation: not a proper rotation at index ({pose},) "
                                 f"(tolerance {ROTATION_TOL:.0e})")
        if not cond:
            return K, None
        c = np.empty(T.shape[0])
        centroid = np.ascontiguousarray(self._centroid)
        cond_kernel(T, base, plat, centroid, self.radius, c)
        bad = ~(c <= GRAM_COND_LIMIT)
        if bad.any():
            Ps = np.empty((int(bad.sum()), 6, base.shape[0]))
            scaled_leg_matrices(T[bad], base, plat, centroid, self.radius, Ps)
            sv = np.linalg.svd(Ps, compute_uv=False)
            with np.errstate(divide="ignore"):
                c[bad] = np.where(sv[:, -1] > 0, sv[:, 0] / sv[:, -1], np.inf)
        return K, c
