"""Joint (kinematic pair) transforms of seed 000, with their unit twists.

A joint connects a frame fixed on link *a* to a frame fixed on link *b*; its
variable transform ``A(q)`` maps coordinates in the *b* frame to the *a* frame.
Frame rules (seed 000): Z along the axis of R, P, C and H joints; for the Hooke
joint (U) the Z axes lie along the two cross pins; for the spherical joint (S)
both origins sit at the ball centre.

========  =========================================  ===========================
kind      A(q)                                       coordinates
========  =========================================  ===========================
``R``     Rz(θ)                                      θ (rad)
``P``     Tz(s)                                      s (length)
``C``     Rz(θ) Tz(s)                                θ (rad), s (length)
``H``     Rz(θ) Tz(h θ), pitch h (length / rad)      θ (rad)
``U``     Rz(φ) Ry(π/2) Rz(θ)                        φ, θ (rad)
``S``     R, a rotation matrix                       rotation; Z–X–Z angles out
========  =========================================  ===========================

The Hooke joint's frame on link *a* has Z along the pin held by link *a* and X
along the pin held by link *b* (at φ = 0); link *b*'s frame has Z along its pin.
Seed 000 measures its angles from the cross normal t instead: its φ is ours plus
π/2 and its θ ours minus π/2 (its Table 1 matrix is Rz(φ) Rx(π/2) Rz(θ + π),
whose misprinted last row should read (−sin θ, −cos θ, 0)).  The derivation is
checked in the tests: every matrix is a rotation and ``dA/dq`` equals the twist.

The spherical joint keeps its relative rotation as a matrix and is updated by a
rotation vector ``ω`` (expressed in the *a* frame): ``R ← exp(ω) R``.  So the
solver never meets the Euler-angle singularity; Euler angles are output only.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .errors import MechanismError
from .frames import _euler_zxz, _inverse, _transform, exp_so3, rot_y, rot_z, transform

__all__ = ["Joint", "JOINT_KINDS"]

#: number of velocity coordinates of each kind
JOINT_KINDS = {"R": 1, "P": 1, "C": 2, "H": 1, "U": 2, "S": 3}

_RX = np.array([0, 0, 0, 1.0, 0, 0])
_RY = np.array([0, 0, 0, 0, 1.0, 0])
_RZ = np.array([0, 0, 0, 0, 0, 1.0])
_TZ = np.array([0, 0, 1.0, 0, 0, 0])
_U_MID = transform(rot_y(np.pi / 2))


@dataclass
class Joint:
    """A joint between two links.

    Attributes
    ----------
    name : str
    kind : str
        One of ``"R", "P", "C", "H", "U", "S"``.
    link_a, link_b : str
        The links; ``A(q)`` maps link *b*'s joint frame into link *a*'s.
    frame_a, frame_b : numpy.ndarray, shape (4, 4)
        The joint frames in the coordinates of link *a* and link *b* (constant).
    pitch : float
        Helical joints only: slide per radian (length / rad).
    """

    name: str
    kind: str
    link_a: str
    link_b: str
    frame_a: np.ndarray
    frame_b: np.ndarray
    pitch: float = 0.0
    index: int = field(default=0, repr=False)

    @cached_property
    def frame_a_inv(self) -> np.ndarray:
        """Inverse of ``frame_a`` (the frames are constant once the joint is added)."""
        return _inverse(self.frame_a)

    @cached_property
    def frame_b_inv(self) -> np.ndarray:
        """Inverse of ``frame_b``."""
        return _inverse(self.frame_b)

    @property
    def nv(self) -> int:
        """Number of velocity coordinates (degrees of freedom of the pair)."""
        return JOINT_KINDS[self.kind]

    @property
    def nq(self) -> int:
        """Number of scalar coordinates stored (0 for S, whose state is a rotation)."""
        return 0 if self.kind == "S" else self.nv

    @property
    def coordinate_names(self) -> list[str]:
        """Names of the reported coordinates (S: Z–X–Z Euler angles)."""
        return {"R": ["theta"], "P": ["s"], "C": ["theta", "s"], "H": ["theta"],
                "U": ["phi", "theta"], "S": ["psi", "theta", "phi"]}[self.kind]

    # ------------------------------------------------------------------ matrices
    def matrix(self, q: np.ndarray, rot: np.ndarray | None = None) -> np.ndarray:
        """``A(q)`` for a batch: ``q`` is ``(B, nq)``, ``rot`` is ``(B, 3, 3)`` for S joints."""
        k = self.kind
        if k == "S":
            return _transform(rot)
        if k == "R":
            return _transform(rot_z(q[:, 0]))
        if k == "P":
            return _transform(None, np.stack([0 * q[:, 0], 0 * q[:, 0], q[:, 0]], -1))
        if k in "CH":
            s = q[:, 1] if k == "C" else self.pitch * q[:, 0]
            return _transform(rot_z(q[:, 0]), np.stack([0 * s, 0 * s, s], -1))
        # U
        return _transform(rot_z(q[:, 0]) @ _U_MID[:3, :3] @ rot_z(q[:, 1]))

    def columns(self, q: np.ndarray):
        """Unit twists of the joint's velocity coordinates.

        Returns a list, one entry per velocity coordinate, of
        ``(prefix, xi, deps)``: the twist ``xi`` (6,) is constant in the frame
        ``frame_a · prefix`` (``prefix`` is ``None`` for the identity, or
        ``(B, 4, 4)``), and ``deps`` lists the earlier coordinates of this joint
        that move that frame (needed for the acceleration terms).
        """
        k = self.kind
        if k == "R":
            return [(None, _RZ, ())]
        if k == "P":
            return [(None, _TZ, ())]
        if k == "C":
            return [(None, _RZ, ()), (None, _TZ, ())]
        if k == "H":
            return [(None, _RZ + self.pitch * _TZ, ())]
        if k == "S":
            return [(None, _RX, ()), (None, _RY, ()), (None, _RZ, ())]
        return [(None, _RZ, ()), (_transform(rot_z(q[:, 0])) @ _U_MID, _RZ, (0,))]

    def update(self, q: np.ndarray, rot: np.ndarray | None, dv: np.ndarray):
        """Apply velocity-coordinate increments ``dv`` ``(B, nv)``; returns new ``(q, rot)``."""
        if self.kind == "S":
            return q, exp_so3(dv) @ rot
        return q + dv, rot

    def values(self, q: np.ndarray, rot: np.ndarray | None) -> np.ndarray:
        """Reported coordinates ``(B, len(coordinate_names))`` (S: Z–X–Z Euler angles)."""
        return _euler_zxz(rot) if self.kind == "S" else q

    def coordinates_of(self, A: np.ndarray, tol: float = 1e-9):
        """Read the joint coordinates from a relative transform ``A`` (4, 4).

        Returns ``(q (nq,), rot (3, 3) or None)``.

        Raises
        ------
        MechanismError
            If ``A`` is not a transform this kind of joint can produce (the
            two frames do not share the joint's axis / centre).
        """
        R, p = A[:3, :3], A[:3, 3]
        k = self.kind
        if k == "S":
            q, rot = np.zeros(0), R.copy()
        elif k == "U":
            phi = np.arctan2(R[1, 2], R[0, 2])
            Rt = (rot_z(phi) @ _U_MID[:3, :3]).T @ R
            q, rot = np.array([phi, np.arctan2(Rt[1, 0], Rt[0, 0])]), None
        elif k == "P":
            q, rot = np.array([p[2]]), None
        else:
            th = np.arctan2(R[1, 0], R[0, 0])
            q = np.array([th, p[2]]) if k == "C" else np.array([th])
            rot = None
        back = self.matrix(q[None, :], None if rot is None else rot[None])[0]
        err = np.max(np.abs(back - A))
        if err > tol * max(1.0, np.max(np.abs(p))):
            raise MechanismError(
                f"joint {self.name!r}: the frames given for links {self.link_a!r} and "
                f"{self.link_b!r} are not related by a {k} joint (mismatch {err:.2e}); "
                "expected frames sharing the joint's axis and origin")
        return q, rot
