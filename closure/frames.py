"""Rigid-body frames: rotations, 4x4 homogeneous transforms, twists and SE(3) exp/log.

Conventions: a transform is ``[[R, p], [0, 1]]`` acting on
column vectors ``(x, y, z, 1)``; every function broadcasts over leading axes, so
one pose is ``(4, 4)`` and a batch is ``(..., 4, 4)``.  A twist is the 6-vector
``(v, ω)``: linear part first, as in seed 003's six-vectors, where ``v`` is the
velocity of the body point at the origin of the frame the twist is written in.
"""
from __future__ import annotations


import numpy as np

from .errors import MechanismError
from .checks import real_array, real_number

__all__ = [
    "skew", "cross", "unskew", "hat", "vee", "rotation", "rot_x", "rot_y", "rot_z",
    "transform", "translation", "inverse", "adjoint", "ad", "exp_so3", "log_so3",
    "exp_se3", "log_se3", "frame_from_points", "euler_zxz", "check_transform", "check_rotation",
    "as_array", "as_number", "as_index",
]

_EYE3 = np.eye(3)


# ------------------------------------------------------------ input validation helpers
def as_array(x, name: str, tail: tuple = (), finite: bool = True) -> np.ndarray:
    """``x`` as a float array, checked; every public function validates through this.

    Parameters
    ----------
    name : str
        The argument's name, used in the message.
    tail : tuple of int
        Required trailing shape (e.g. ``(3,)`` for points, ``(4, 4)`` for transforms);
        leading batch axes are free.
    finite : bool
        Reject NaN and infinite entries.

    Raises
    ------
    MechanismError
        Naming ``name``: not numbers (strings, ragged nesting, objects), a wrong
        trailing shape, or non-finite entries.
    """
    a = real_array(x, name, MechanismError)
    tail = tuple(tail)
    if tail and (a.ndim < len(tail) or a.shape[a.ndim - len(tail):] != tail):
        want = "x".join(map(str, tail))
        raise MechanismError(f"{name}: expected shape (..., {', '.join(map(str, tail))}) "
                             f"({want} {'vector' if len(tail) == 1 else 'array'}), got {a.shape}")
    if finite and not np.all(np.isfinite(a)):
        raise MechanismError(f"{name}: contains non-finite values (NaN or inf)")
    return a


def as_number(x, name: str) -> float:
    """``x`` as one finite float (a real scalar, not a bool or a string); raises
    MechanismError naming ``name`` otherwise."""
    return real_number(x, name, MechanismError)


def as_index(x, name: str) -> int:
    """``x`` as a Python int (integers only: not bools, floats or strings)."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, np.integer)):
        raise MechanismError(f"{name}: expected an integer index, got {x!r}")
    return int(x)


def input_rates(v, name: str, shape: tuple) -> np.ndarray:
    """Input rates or accelerations ``v`` checked (real, finite) and broadcast to ``shape``
    ``(B, n_inputs)``; a single ``(n_inputs,)`` row serves every pose."""
    a = as_array(v, name)
    try:
        return np.broadcast_to(a, shape)
    except ValueError:
        raise MechanismError(f"{name}: expected shape (B, n_inputs) = {shape} or "
                             f"({shape[1]},), got {a.shape}") from None


def _broadcast(name, *shapes):
    try:
        return np.broadcast_shapes(*shapes)
    except ValueError:
        raise MechanismError(f"{name}: batch shapes {', '.join(map(str, shapes))} do not "
                             "broadcast") from None


def skew(p: np.ndarray) -> np.ndarray:
    """Skew-symmetric matrix ``[p]×`` of a 3-vector, shape ``(..., 3)`` → ``(..., 3, 3)``."""
    return _skew(as_array(p, "skew: p", (3,)))


def _skew(p):
    out = np.zeros(p.shape[:-1] + (3, 3))
    x, y, w = p[..., 0], p[..., 1], p[..., 2]
    out[..., 0, 1], out[..., 0, 2] = -w, y
    out[..., 1, 0], out[..., 1, 2] = w, -x
    out[..., 2, 0], out[..., 2, 1] = -y, x
    return out


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of 3-vectors over broadcast leading axes (faster than ``np.cross``
    on small batches)."""
    a, b = as_array(a, "cross: a", (3,)), as_array(b, "cross: b", (3,))
    return _cross(a, b, _broadcast("cross", a.shape, b.shape))


def _cross(a, b, shape=None):
    """:func:`cross` without the checks (the engine's hot paths: float arrays (..., 3))."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape) if shape is None else shape)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def unskew(S: np.ndarray) -> np.ndarray:
    """The 3-vector of a skew-symmetric matrix (its antisymmetric part), ``(..., 3, 3)`` → ``(..., 3)``."""
    return _unskew(as_array(S, "unskew: S", (3, 3)))


def _unskew(S):
    return 0.5 * np.stack([S[..., 2, 1] - S[..., 1, 2], S[..., 0, 2] - S[..., 2, 0],
                           S[..., 1, 0] - S[..., 0, 1]], -1)


def hat(xi: np.ndarray) -> np.ndarray:
    """se(3) matrix of a twist ``(v, ω)``: ``(..., 6)`` → ``(..., 4, 4)``."""
    xi = as_array(xi, "hat: xi", (6,))
    out = np.zeros(xi.shape[:-1] + (4, 4))
    out[..., :3, :3] = skew(xi[..., 3:])
    out[..., :3, 3] = xi[..., :3]
    return out


def vee(X: np.ndarray) -> np.ndarray:
    """Twist ``(v, ω)`` of an se(3) matrix: ``(..., 4, 4)`` → ``(..., 6)``."""
    X = as_array(X, "vee: X", (4, 4))
    return np.concatenate([X[..., :3, 3], unskew(X[..., :3, :3])], -1)


def exp_so3(w: np.ndarray) -> np.ndarray:
    """Rotation matrix of a rotation vector (axis × angle, rad): ``(..., 3)`` → ``(..., 3, 3)``.

    Uses series expansions for small angles, so it is accurate down to zero.
    """
    return _exp_so3(as_array(w, "exp_so3: w", (3,)))


def _exp_so3(w):
    """:func:`exp_so3` without checks (engine-internal: a finite float array (..., 3))."""
    th2 = np.sum(w * w, -1)
    th = np.sqrt(th2)
    small = th2 < 1e-8
    ths = np.where(small, 1.0, th)
    a = np.where(small, 1 - th2 / 6 + th2 ** 2 / 120, np.sin(ths) / ths)
    b = np.where(small, 0.5 - th2 / 24 + th2 ** 2 / 720, (1 - np.cos(ths)) / ths ** 2)
    K = _skew(w)
    return _EYE3 + a[..., None, None] * K + b[..., None, None] * (K @ K)


def log_so3(R: np.ndarray) -> np.ndarray:
    """Rotation vector of a rotation matrix, angle in [0, π]: ``(..., 3, 3)`` → ``(..., 3)``.

    Accurate near 0 (series) and near π (from the symmetric part).  ``R`` is checked to be
    a proper rotation (orthonormal to 1e-9, determinant +1).
    """
    return _log_so3(check_rotation(R, "log_so3: R"))


def _log_so3(R):
    """:func:`log_so3` without checks (engine-internal)."""
    v = _unskew(R)                      # sin(th) * axis
    s = np.linalg.norm(v, axis=-1)
    th = np.arctan2(s, (np.trace(R, axis1=-2, axis2=-1) - 1) / 2)
    small = th < 1e-5
    scale = np.where(small, 1 + th ** 2 / 6 + 7 * th ** 4 / 360, th / np.where(small, 1, np.sin(th)))
    out = v * scale[..., None]
    near_pi = th > np.pi / 2
    if np.any(near_pi):
        # past a quarter turn the axis is better conditioned from the symmetric part (its
        # error ~ε / (1 − cos θ) ≤ ε, against ε / sin θ from the skew part, which grows
        # without bound at a half turn):
        # (R + Rᵀ)/2 = cos θ I + (1 - cos θ) a aᵀ: take the largest column of a aᵀ
        c = np.cos(th[near_pi])[..., None, None]
        M = ((R[near_pi] + np.swapaxes(R[near_pi], -1, -2)) / 2 - c * _EYE3) / (1 - c)
        k = np.argmax(np.diagonal(M, axis1=-2, axis2=-1), -1)
        a = np.take_along_axis(M, k[..., None, None], -1)[..., 0]
        a = a / np.linalg.norm(a, axis=-1, keepdims=True)
        sgn = np.sign(np.sum(a * v[near_pi], -1))
        sgn = np.where(sgn == 0, 1.0, sgn)
        out[near_pi] = a * (sgn * th[near_pi])[..., None]
    return out


def _left_jacobian_terms(th2):
    small = th2 < 1e-8
    th = np.sqrt(np.where(small, 1.0, th2))
    b = np.where(small, 0.5 - th2 / 24, (1 - np.cos(th)) / th ** 2)
    c = np.where(small, 1 / 6 - th2 / 120, (th - np.sin(th)) / th ** 3)
    return b, c


def exp_se3(xi: np.ndarray) -> np.ndarray:
    """Transform ``exp(ξ^)`` of a twist ``(v, ω)``: ``(..., 6)`` → ``(..., 4, 4)``."""
    xi = as_array(xi, "exp_se3: xi", (6,))
    w, v = xi[..., 3:], xi[..., :3]
    K = _skew(w)
    b, c = _left_jacobian_terms(np.sum(w * w, -1))
    V = _EYE3 + b[..., None, None] * K + c[..., None, None] * (K @ K)
    out = np.zeros(xi.shape[:-1] + (4, 4))
    out[..., :3, :3] = _exp_so3(w)
    out[..., :3, 3] = (V @ v[..., None])[..., 0]
    out[..., 3, 3] = 1.0
    return out


def log_se3(T: np.ndarray) -> np.ndarray:
    """Twist ``(v, ω)`` with ``exp_se3(ξ) = T``, rotation angle in [0, π]: ``(..., 4, 4)`` → ``(..., 6)``
    (``T`` checked as a rigid transform, as in :func:`inverse`)."""
    return _log_se3(check_transform(T, "log_se3: T"))


def _log_se3(T):
    """:func:`log_se3` without checks (engine-internal, hot path)."""
    w = _log_so3(T[..., :3, :3])
    th2 = np.sum(w * w, -1)
    small = th2 < 1e-8
    th = np.sqrt(np.where(small, 1.0, th2))
    # V^{-1} = I - K/2 + e K², e = (1 - th sin th / (2 (1 - cos th))) / th²
    e = np.where(small, 1 / 12 + th2 / 720,
                 (1 - th * np.sin(th) / (2 * (1 - np.cos(th)))) / th ** 2)
    K = _skew(w)
    Vinv = _EYE3 - 0.5 * K + e[..., None, None] * (K @ K)
    v = (Vinv @ T[..., :3, 3:4])[..., 0]
    return np.concatenate([v, w], -1)


def rotation(axis: np.ndarray, angle) -> np.ndarray:
    """Rotation by ``angle`` (rad) about a unit ``axis``: broadcasts to ``(..., 3, 3)``."""
    axis = as_array(axis, "rotation: axis", (3,))
    angle = as_array(angle, "rotation: angle")
    _broadcast("rotation: axis and angle", axis.shape[:-1], angle.shape)
    n = np.linalg.norm(axis, axis=-1, keepdims=True)
    if np.any(n < 1e-12):
        raise MechanismError("rotation: axis has zero length; expected a non-zero 3-vector")
    return _exp_so3(axis / n * angle[..., None])      # (finite: |axis / n| ≤ 1)


def _axis_rot(i, j, angle, name):
    a = as_array(angle, f"{name}: angle")
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(a.shape + (3, 3))
    k = 3 - i - j
    R[..., k, k] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., i, j] = -s
    R[..., j, i] = s
    return R


def rot_x(angle) -> np.ndarray:
    """Rotation about x by ``angle`` (rad), shape ``angle.shape + (3, 3)``."""
    return _axis_rot(1, 2, angle, "rot_x")


def rot_y(angle) -> np.ndarray:
    """Rotation about y by ``angle`` (rad), shape ``angle.shape + (3, 3)``."""
    return _axis_rot(2, 0, angle, "rot_y")


def rot_z(angle) -> np.ndarray:
    """Rotation about z by ``angle`` (rad), shape ``angle.shape + (3, 3)``."""
    return _axis_rot(0, 1, angle, "rot_z")


def transform(R: np.ndarray | None = None, p: np.ndarray | None = None) -> np.ndarray:
    """4x4 transform ``[[R, p], [0, 1]]`` from a rotation ``(..., 3, 3)`` (checked: proper, to
    1e-9) and a translation ``(..., 3)``."""
    R = _EYE3 if R is None else check_rotation(R, "transform: R")
    p = np.zeros(3) if p is None else as_array(p, "transform: p", (3,))
    return _transform(R, p, _broadcast("transform: R and p", R.shape[:-2], p.shape[:-1]))


def _transform(R, p=None, shape=None):
    """:func:`transform` without checks (engine-internal, hot path)."""
    if R is None:
        R = _EYE3
    if p is None:
        p = np.zeros(3)
    if shape is None:
        shape = np.broadcast_shapes(R.shape[:-2], p.shape[:-1])
    out = np.zeros(shape + (4, 4))
    out[..., :3, :3] = R
    out[..., :3, 3] = p
    out[..., 3, 3] = 1.0
    return out


def translation(p: np.ndarray) -> np.ndarray:
    """Pure translation by ``p`` ``(..., 3)`` → ``(..., 4, 4)``."""
    return transform(None, as_array(p, "translation: p", (3,)))


def inverse(T: np.ndarray) -> np.ndarray:
    """Inverse of rigid transforms ``(..., 4, 4)`` (uses Rᵀ, not a general inverse).

    ``T`` is checked like a joint frame (:func:`check_transform`: last row (0, 0, 0, 1), a
    proper rotation to 1e-9); a MechanismError naming ``T`` says what is wrong."""
    return _inverse(check_transform(T, "inverse: T"))


def _inverse(T):
    """:func:`inverse` without checks (engine-internal, hot path)."""
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    return _transform(Rt, -(Rt @ T[..., :3, 3:4])[..., 0])


def adjoint(T: np.ndarray) -> np.ndarray:
    """6x6 adjoint of ``T`` for twists ``(v, ω)``: ``Ad_T ξ = vee(T ξ^ T⁻¹)`` (``T`` checked
    as a rigid transform, as in :func:`inverse`)."""
    return _adjoint(check_transform(T, "adjoint: T"))


def _adjoint(T):
    """:func:`adjoint` without checks (engine-internal, hot path)."""
    R, p = T[..., :3, :3], T[..., :3, 3]
    out = np.zeros(T.shape[:-2] + (6, 6))
    out[..., :3, :3] = R
    out[..., 3:, 3:] = R
    out[..., :3, 3:] = _skew(p) @ R
    return out


def ad(xi: np.ndarray) -> np.ndarray:
    """6x6 matrix of the Lie bracket ``ad_ξ η = [ξ, η]`` for twists ``(v, ω)``."""
    xi = as_array(xi, "ad: xi", (6,))
    W, V = skew(xi[..., 3:]), skew(xi[..., :3])
    out = np.zeros(xi.shape[:-1] + (6, 6))
    out[..., :3, :3] = W
    out[..., 3:, 3:] = W
    out[..., :3, 3:] = V
    return out


def check_transform(T, name: str = "transform", tol: float = 1e-9) -> np.ndarray:
    """Return ``T`` as a float array after checking it is a rigid 4x4 transform.

    Raises
    ------
    MechanismError
        If the shape is not ``(..., 4, 4)``, the entries are not finite, the
        last row is not ``(0, 0, 0, 1)`` or the rotation block is not a proper
        rotation to ``tol``.  The message names ``name``.
    """
    T = as_array(T, name, finite=False)
    if T.ndim < 2 or T.shape[-2:] != (4, 4):
        raise MechanismError(f"{name}: expected a 4x4 transform, got shape {T.shape}")
    if not np.all(np.isfinite(T)):
        raise MechanismError(f"{name}: contains non-finite entries (NaN or inf)")
    if T.size == 0:
        return T
    if np.max(np.abs(T[..., 3, :] - [0, 0, 0, 1])) > tol:
        raise MechanismError(f"{name}: last row must be (0, 0, 0, 1)")
    _proper(T[..., :3, :3], f"{name}: rotation block", tol)
    return T


def check_rotation(R, name: str = "R", tol: float = 1e-9) -> np.ndarray:
    """Return ``R`` as a float array after checking it holds proper rotations ``(..., 3, 3)``
    (orthonormal to ``tol``, determinant +1); raises MechanismError naming ``name``."""
    R = as_array(R, name, (3, 3))
    if R.size:
        _proper(R, name, tol)
    return R


def _proper(R, what, tol):
    err = float(np.max(np.abs(R @ np.swapaxes(R, -1, -2) - _EYE3)))
    if err > tol or np.any(np.linalg.det(R) < 0):
        raise MechanismError(f"{what} is not a proper rotation "
                             f"(|R Rᵀ - I| = {err:.2e}, determinant "
                             f"{float(np.min(np.linalg.det(R))):.3g}, tolerance {tol:.0e})")


def frame_from_points(origin, x_point, z_point) -> np.ndarray:
    """Joint frame from three points (seed 000's rule).

    The origin is ``origin``; the Z axis points from ``origin`` to ``z_point``;
    the X axis points towards ``x_point``, made perpendicular to Z.

    Parameters
    ----------
    origin, x_point, z_point : array_like, shape (..., 3)
        Points in the ground frame (length units).

    Returns
    -------
    numpy.ndarray, shape (..., 4, 4)

    Raises
    ------
    MechanismError
        If ``z_point`` coincides with ``origin`` or the three points are
        collinear (relative tolerance 1e-9 of the points' spread).
    """
    o, xp, zp = (as_array(a, f"frame_from_points: {n}", (3,)) for a, n in
                 ((origin, "origin"), (x_point, "x_point"), (z_point, "z_point")))
    _broadcast("frame_from_points: origin, x_point and z_point", o.shape, xp.shape, zp.shape)
    z = zp - o
    x = xp - o
    zn = np.linalg.norm(z, axis=-1, keepdims=True)
    scale = np.maximum(zn, np.linalg.norm(x, axis=-1, keepdims=True))
    if np.any(zn <= 1e-12 * np.maximum(scale, 1e-300)) or np.any(zn == 0):
        raise MechanismError("frame_from_points: z_point coincides with origin; "
                             "expected a distinct point on the Z axis")
    z = z / zn
    x = x - np.sum(x * z, -1, keepdims=True) * z
    xn = np.linalg.norm(x, axis=-1, keepdims=True)
    if np.any(xn <= 1e-9 * scale):
        raise MechanismError("frame_from_points: the three points are collinear "
                             "(or x_point coincides with origin); expected x_point off the Z axis")
    x = x / xn
    y = _cross(z, x)
    return _transform(np.stack([x, y, z], -1), o)


def euler_zxz(R: np.ndarray) -> np.ndarray:
    """Z–X–Z (Z–N–Z) Euler angles ``(ψ, θ, φ)`` of rotations ``R = Rz(ψ) Rx(θ) Rz(φ)``.

    Output only (the solver never uses them).  At the singular ``θ = 0`` or ``π``
    only ``ψ ± φ`` is defined; then ``φ = 0`` is returned.  Shape ``(..., 3)``; ``R`` is
    checked to be a proper rotation.
    """
    return _euler_zxz(check_rotation(R, "euler_zxz: R"))


def _euler_zxz(R):
    """:func:`euler_zxz` without checks (engine-internal)."""
    th = np.arctan2(np.hypot(R[..., 0, 2], R[..., 1, 2]), R[..., 2, 2])
    sing = np.hypot(R[..., 0, 2], R[..., 1, 2]) < 1e-12
    psi = np.where(sing, np.arctan2(R[..., 1, 0], R[..., 0, 0]), np.arctan2(R[..., 0, 2], -R[..., 1, 2]))
    phi = np.where(sing, 0.0, np.arctan2(R[..., 2, 0], R[..., 2, 1]))
    return np.stack([psi, th, phi], -1)
