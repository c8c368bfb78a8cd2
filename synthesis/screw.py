"""Finite screw displacements and lines (seed 001's positions and joint axes).

A screw ``Screw(axis, point, angle, slide)`` is the rotation by ``angle`` (rad)
about the line through ``point`` along the unit ``axis`` followed by the slide
``slide`` along it; ``matrix()`` is its 4x4 transform.  Position j of a body is
``S_1j`` applied to position 1.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from closure.frames import cross, log_so3, rotation

from .errors import SynthesisError

__all__ = ["Screw", "Line", "relative_screw"]

_AXIS_TOL = 1e-6


def _unit(v, name, tol=_AXIS_TOL):
    v = np.asarray(v, float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise SynthesisError(f"{name}: expected a finite 3-vector, got {v!r}")
    n = np.linalg.norm(v)
    if n == 0:
        raise SynthesisError(f"{name}: zero vector, expected a unit direction")
    if abs(n - 1) > tol:
        raise SynthesisError(f"{name}: length {n:.6g} is not 1 within {tol:g}; expected a unit "
                             "direction (normalise it first)")
    return v / n


@dataclass(frozen=True)
class Line:
    """A line (joint axis): unit ``direction`` and a ``point`` on it (its canonical point)."""

    direction: np.ndarray
    point: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "direction", _unit(self.direction, "direction", 1e-6))
        p = np.asarray(self.point, float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise SynthesisError(f"point: expected a finite 3-vector, got {self.point!r}")
        object.__setattr__(self, "point", p)

    @classmethod
    def _exact(cls, direction, point) -> "Line":
        """A line from a direction already of unit length (internal: skips validation)."""
        ln = object.__new__(cls)
        object.__setattr__(ln, "direction", direction)
        object.__setattr__(ln, "point", point)
        return ln

    def transformed(self, T) -> "Line":
        """The line moved by the 4x4 transform ``T`` (point moved, not re-canonicalised)."""
        T = np.asarray(T, float)
        return Line._exact(T[:3, :3] @ self.direction, T[:3, :3] @ self.point + T[:3, 3])

    def foot_from(self, x) -> np.ndarray:
        """The foot of the perpendicular from ``x`` to the line."""
        x = np.asarray(x, float)
        return self.point + ((x - self.point) @ self.direction) * self.direction

    def canonical(self, previous: "Line | None" = None) -> "Line":
        """Same line with the canonical point: foot of the perpendicular from the origin
        (``previous=None``) or foot of the common normal with ``previous`` (the
        perpendicular foot of previous's point when the lines are parallel)."""
        if previous is None:
            return Line._exact(self.direction, self.foot_from(np.zeros(3)))
        return Line._exact(self.direction, common_normal(previous, self)[1])

    def distance_to(self, other: "Line") -> float:
        """Shortest distance between the two lines."""
        a, b = common_normal(self, other)
        return float(np.linalg.norm(b - a))


def common_normal(l1: Line, l2: Line):
    """Feet ``(on l1, on l2)`` of the common normal of two lines (parallel lines: the foot
    on l2 of the perpendicular from l1's point)."""
    u, v = l1.direction, l2.direction
    w = l1.point - l2.point
    b = u @ v
    den = 1 - b * b
    if den < 1e-12:
        return l1.point.copy(), l2.foot_from(l1.point)
    d, e = u @ w, v @ w
    s = (b * e - d) / den
    t = (e - b * d) / den
    return l1.point + s * u, l2.point + t * v


@dataclass(frozen=True)
class Screw:
    """A finite screw displacement.

    Parameters
    ----------
    axis : (3,) unit direction (normalised if within 1e-6 of unit length)
    point : (3,) a point on the axis
    angle : float, rotation about the axis (rad)
    slide : float, translation along the axis (length)
    """

    axis: np.ndarray
    point: np.ndarray
    angle: float
    slide: float

    def __post_init__(self):
        object.__setattr__(self, "axis", _unit(self.axis, "axis"))
        p = np.asarray(self.point, float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise SynthesisError(f"point: expected a finite 3-vector, got {self.point!r}")
        object.__setattr__(self, "point", p)
        for name in ("angle", "slide"):
            v = float(getattr(self, name))
            if not np.isfinite(v):
                raise SynthesisError(f"{name}: expected a finite number, got {v}")
            object.__setattr__(self, name, v)

    @classmethod
    def from_degrees(cls, axis, point, angle_deg: float, slide: float) -> "Screw":
        """The screw with its rotation given in degrees (as seed 001's Table 1)."""
        return cls(axis, point, np.radians(angle_deg), slide)

    def matrix(self) -> np.ndarray:
        """4x4 transform ``x ↦ R (x − c) + c + slide · axis``."""
        R = rotation(self.axis, self.angle)
        T = np.eye(4)
        T[:3, :3] = R
        T[:3, 3] = self.point - R @ self.point + self.slide * self.axis
        return T

    @classmethod
    def from_matrix(cls, T, tol: float = 1e-12) -> "Screw":
        """The screw of a rigid transform (Chasles).

        The identity gives angle 0, slide 0 and axis z through the origin; a pure
        translation gives angle 0 with the axis along the translation.  The axis
        point is the foot of the perpendicular from the origin; angle in [0, π].
        """
        T = np.asarray(T, float)
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            raise SynthesisError(f"T: expected a finite 4x4 transform, got shape {T.shape}")
        R, p = T[:3, :3], T[:3, 3]
        if np.abs(R @ R.T - np.eye(3)).max() > 1e-9 or np.linalg.det(R) < 0:
            raise SynthesisError("T: rotation block is not a proper rotation")
        w = log_so3(R)
        th = float(np.linalg.norm(w))
        if th <= tol:
            n = float(np.linalg.norm(p))
            if n <= tol * max(1.0, n):
                return cls(np.array([0, 0, 1.0]), np.zeros(3), 0.0, 0.0)
            return cls(p / n, np.zeros(3), 0.0, n)
        a = w / th
        slide = float(a @ p)
        pp = p - slide * a
        c = 0.5 * (pp + cross(a, pp) / np.tan(th / 2))
        return cls(a, c, th, slide)

    def line(self) -> Line:
        """The screw axis as a :class:`Line`."""
        return Line(self.axis, self.point)

    def compose(self, other: "Screw") -> "Screw":
        """``self ∘ other``: first ``other``, then ``self``."""
        return Screw.from_matrix(self.matrix() @ other.matrix())

    def inverse(self) -> "Screw":
        return Screw(self.axis, self.point, -self.angle, -self.slide)


def relative_screw(s1j: Screw, s1k: Screw) -> Screw:
    """The screw ``S_jk`` from position j to position k, both given from position 1:
    ``S_1k = S_jk ∘ S_1j``."""
    return Screw.from_matrix(s1k.matrix() @ np.linalg.inv(s1j.matrix()))
