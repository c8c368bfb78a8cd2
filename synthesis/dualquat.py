"""Dual quaternions as 8-vectors ``(r, d)`` with ``r, d`` quaternions ``(w, x, y, z)``.

A transform (R, p) is ``σ = r + ε ½ p r`` with r the unit quaternion of R; the
product of dual quaternions is the composition of transforms.  Used for the
RR synthesis through the motion polynomial of three poses.
"""
from __future__ import annotations

import numpy as np

__all__ = ["quat_from_rotation", "qmul", "qconj", "dq_mul", "dq_conj", "dq_from_matrix", "dq_to_matrix", "dq_inv"]


def qmul(a, b):
    """Quaternion product (broadcasting; single quaternions take a scalar fast path)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.ndim == 1 and b.ndim == 1:
        w1, x1, y1, z1 = a.tolist()
        w2, x2, y2, z2 = b.tolist()
        return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                         w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])
    w1, x1, y1, z1 = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    w2, x2, y2, z2 = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                     w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], -1)


def qconj(a):
    a = np.asarray(a, float)
    return a * np.array([1, -1, -1, -1.0])


def dq_mul(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.concatenate([qmul(a[..., :4], b[..., :4]),
                           qmul(a[..., :4], b[..., 4:]) + qmul(a[..., 4:], b[..., :4])], -1)


def dq_conj(a):
    """Quaternion conjugate of both parts (σ σ̃ is the norm, real for rigid motions)."""
    a = np.asarray(a, float)
    return np.concatenate([qconj(a[..., :4]), qconj(a[..., 4:])], -1)


def dq_inv(a):
    """Inverse of a dual quaternion with non-zero primal part."""
    a = np.asarray(a, float)
    r, d = a[:4], a[4:]
    rn = r @ r
    ri = qconj(r) / rn
    return np.concatenate([ri, -qmul(qmul(ri, d), ri)])


def quat_from_rotation(R) -> np.ndarray:
    """Unit quaternions (w, x, y, z) of rotation matrices (Shepperd's method: the largest of
    the four squared components is taken first, so it is accurate at every angle).

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices.

    Returns
    -------
    numpy.ndarray, shape (..., 4)
        The quaternions, scalar part w ≥ 0.
    """
    R = np.asarray(R, float)
    r00, r01, r02 = R[..., 0, 0], R[..., 0, 1], R[..., 0, 2]
    r10, r11, r12 = R[..., 1, 0], R[..., 1, 1], R[..., 1, 2]
    r20, r21, r22 = R[..., 2, 0], R[..., 2, 1], R[..., 2, 2]
    tr = r00 + r11 + r22
    shape = tr.shape
    k = np.argmax(np.stack([tr, r00, r11, r22], -1), -1).reshape(-1)
    # Shepperd's symmetric matrix: the quaternion is row k / (4 v), its k-th entry
    # v = ½ √K_kk, for the largest diagonal entry k
    K = np.empty((4, 4) + shape)
    K[0, 0], K[1, 1] = 1 + tr, 1 + r00 - r11 - r22
    K[2, 2], K[3, 3] = 1 + r11 - r22 - r00, 1 + r22 - r00 - r11
    K[0, 1] = K[1, 0] = r21 - r12
    K[0, 2] = K[2, 0] = r02 - r20
    K[0, 3] = K[3, 0] = r10 - r01
    K[1, 2] = K[2, 1] = r10 + r01
    K[1, 3] = K[3, 1] = r20 + r02
    K[2, 3] = K[3, 2] = r21 + r12
    i = np.arange(len(k))
    row = K.reshape(4, 4, -1)[k, :, i]                                    # (n, 4)
    v = 0.5 * np.sqrt(row[i, k])
    q = row / (4 * v[:, None])
    q[i, k] = v
    q = q.reshape(shape + (4,))
    return np.where(q[..., :1] >= 0, q, -q)


def dq_from_matrix(T):
    """Unit dual quaternions ``(..., 8)`` of rigid transforms ``T (..., 4, 4)``."""
    T = np.asarray(T, float)
    r = quat_from_rotation(T[..., :3, :3])
    t = T[..., :3, 3]
    d = 0.5 * qmul(np.concatenate([np.zeros(t.shape[:-1] + (1,)), t], -1), r)
    return np.concatenate([r, d], -1)


def dq_to_matrix(s):
    """Transform of a (not necessarily normalised) dual quaternion."""
    s = np.asarray(s, float)
    r, d = s[:4], s[4:]
    n = r @ r
    w, x, y, z = r / np.sqrt(n)
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                  [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                  [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    p = 2 * qmul(d, qconj(r))[1:] / n
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T
