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

from .validate import line as _line
from .validate import number, screw as _screw, transform, unit, vec3

__all__ = ["Screw", "Line", "relative_screw"]

_AXIS_TOL = 1e-6


@dataclass(frozen=True)
class Line:
    """A line (joint axis): unit ``direction`` and a ``point`` on it (its canonical point).

    Parameters
    ----------
    direction : array_like, shape (3,)
        Unit direction (normalised if within 1e-6 of unit length).
    point : array_like, shape (3,)
        A point on the line (length unit of the task).

    Raises
    ------
    SynthesisError
        Naming ``direction`` or ``point``: wrong shape or type, NaN or inf, or a
        direction that is not of unit length.
    """

    direction: np.ndarray
    point: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "direction", unit(self.direction, "direction", _AXIS_TOL))
        object.__setattr__(self, "point", vec3(self.point, "point"))

    @classmethod
    def _exact(cls, direction, point) -> "Line":
        """A line from a direction already of unit length (internal: skips validation)."""
        ln = object.__new__(cls)
        object.__setattr__(ln, "direction", direction)
        object.__setattr__(ln, "point", point)
        return ln

    def transformed(self, T) -> "Line":
        """The line moved by the rigid 4x4 transform ``T`` (point moved, not re-canonicalised)."""
        T = transform(T, "T")
        return Line._exact(T[:3, :3] @ self.direction, T[:3, :3] @ self.point + T[:3, 3])

    def foot_from(self, x) -> np.ndarray:
        """The foot of the perpendicular from the point ``x`` ``(3,)`` to the line."""
        x = vec3(x, "x")
        return self.point + ((x - self.point) @ self.direction) * self.direction

    def canonical(self, previous: "Line | None" = None) -> "Line":
        """Same line with the canonical point: foot of the perpendicular from the origin
        (``previous=None``) or foot of the common normal with ``previous`` (the
        perpendicular foot of previous's point when the lines are parallel)."""
        if previous is None:
            return Line._exact(self.direction, self.foot_from(np.zeros(3)))
        _line(previous, "previous")
        return Line._exact(self.direction, common_normal(previous, self)[1])

    def distance_to(self, other: "Line") -> float:
        """Shortest distance between the two lines."""
        _line(other, "other")
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
    axis : array_like, shape (3,)
        Unit direction (normalised if within 1e-6 of unit length).
    point : array_like, shape (3,)
        A point on the axis (length unit of the task).
    angle : float
        Rotation about the axis (rad).
    slide : float
        Translation along the axis (length unit of the task).

    Raises
    ------
    SynthesisError
        Naming the argument: wrong shape or type, NaN or inf, or an axis that is not
        of unit length.
    """

    axis: np.ndarray
    point: np.ndarray
    angle: float
    slide: float

    def __post_init__(self):
        object.__setattr__(self, "axis", unit(self.axis, "axis", _AXIS_TOL))
        object.__setattr__(self, "point", vec3(self.point, "point"))
        object.__setattr__(self, "angle", number(self.angle, "angle", unit_="rad"))
        object.__setattr__(self, "slide", number(self.slide, "slide"))

    @classmethod
    def from_degrees(cls, axis, point, angle_deg: float, slide: float) -> "Screw":
        """The screw with its rotation given in degrees (as seed 001's Table 1)."""
        return cls(axis, point, np.radians(number(angle_deg, "angle_deg", unit_="degrees")), slide)

    def matrix(self) -> np.ndarray:
        """4x4 transform ``x ↦ R (x − c) + c + slide · axis``."""
        return _matrices([self])[0]

    @classmethod
    def from_matrix(cls, T, tol: float = 1e-12) -> "Screw":
        """The screw of a rigid transform (Chasles).

        The identity gives angle 0, slide 0 and axis z through the origin; a pure
        translation gives angle 0 with the axis along the translation.  The axis
        point is the foot of the perpendicular from the origin; angle in [0, π].

        Parameters
        ----------
        T : array_like, shape (4, 4)
            A rigid transform: finite, last row ``(0, 0, 0, 1)`` and a proper rotation
            block (to 1e-9).
        tol : float
            Rotation angle (rad) at or below which T counts as a pure translation
            (the identity when it does not translate at all: a translation of any
            length, however small, is kept, so the result does not depend on the unit).

        Raises
        ------
        SynthesisError
            Naming ``T`` (or ``tol``) and what was wrong.
        """
        T = transform(T, "T")
        tol = number(tol, "tol", positive=True)
        R, p = T[:3, :3], T[:3, 3]
        w = log_so3(R)
        th = float(np.linalg.norm(w))
        if th <= tol:
            n = float(np.linalg.norm(p))
            if n == 0:
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
        _screw(other, "other")
        return Screw.from_matrix(self.matrix() @ other.matrix())

    def inverse(self) -> "Screw":
        return Screw(self.axis, self.point, -self.angle, -self.slide)


def _matrices(screws) -> np.ndarray:
    """:meth:`Screw.matrix` of many screws ``(n, 4, 4)``, in one vectorised pass (each
    screw's matrix the same, bit for bit, as alone)."""
    axis = np.array([s.axis for s in screws]).reshape(-1, 3)
    point = np.array([s.point for s in screws]).reshape(-1, 3)
    R = rotation(axis, np.array([s.angle for s in screws], float))
    T = np.zeros((len(axis), 4, 4))
    T[:, :3, :3] = R
    T[:, :3, 3] = point - (R @ point[..., None])[..., 0] + \
        np.array([s.slide for s in screws], float)[:, None] * axis
    T[:, 3, 3] = 1.0
    return T


def relative_screw(s1j: Screw, s1k: Screw) -> Screw:
    """The screw ``S_jk`` from position j to position k, both given from position 1:
    ``S_1k = S_jk ∘ S_1j``."""
    _screw(s1j, "s1j")
    _screw(s1k, "s1k")
    return Screw.from_matrix(s1k.matrix() @ np.linalg.inv(s1j.matrix()))
