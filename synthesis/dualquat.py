"""Dual quaternions as 8-vectors ``(r, d)`` with ``r, d`` quaternions ``(w, x, y, z)``.

A transform (R, p) is ``σ = r + ε ½ p r`` with r the unit quaternion of R; the
product of dual quaternions is the composition of transforms.  Used for the
RR synthesis through the motion polynomial of three poses.
"""
from __future__ import annotations

import numpy as np

__all__ = ["quat_from_rotation", "qmul", "qconj", "dq_mul", "dq_conj", "dq_from_matrix", "dq_to_matrix", "dq_inv"]


#: the products a_i b_j (index 4 i + j) in the terms of each component of qmul, and their signs
_TERMS = np.array([[0, 5, 10, 15], [1, 4, 11, 14], [2, 7, 8, 13], [3, 6, 9, 12]])
_SIGNS = np.array([[1.0, -1, -1, -1], [1, 1, 1, -1], [1, -1, 1, 1], [1, 1, -1, 1]])


def qmul(a, b):
    """Quaternion product (broadcasting; single quaternions take a scalar fast path)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.ndim == 1 and b.ndim == 1:
        w1, x1, y1, z1 = a.tolist()
        w2, x2, y2, z2 = b.tolist()
        return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                         w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])
    # the 16 products a_i b_j at once, then each component's four signed terms summed left
    # to right: the same operations, bit for bit, as the scalar path's expressions
    P = a[..., :, None] * b[..., None, :]
    T = P.reshape(P.shape[:-2] + (16,))[..., _TERMS] * _SIGNS
    return T[..., 0] + T[..., 1] + T[..., 2] + T[..., 3]


def qconj(a):
    a = np.asarray(a, float)
    return a * np.array([1, -1, -1, -1.0])


def dq_mul(a, b):
    """Dual quaternion product (broadcasting): ``(r_a r_b, r_a d_b + d_a r_b)``, the three
    quaternion products in one :func:`qmul`."""
    a, b = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
    q = qmul(np.stack([a[..., :4], a[..., :4], a[..., 4:]]),
             np.stack([b[..., :4], b[..., 4:], b[..., :4]]))
    return np.concatenate([q[0], q[1] + q[2]], -1)


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
    # Shepperd's symmetric matrix K (its ten distinct entries, _SHEPPERD): the quaternion
    # is row k / (4 v), its k-th entry v = ½ √K_kk, for the largest diagonal entry k
    K = np.stack([1 + tr, 1 + r00 - r11 - r22, 1 + r11 - r22 - r00, 1 + r22 - r00 - r11,
                  r21 - r12, r02 - r20, r10 - r01, r10 + r01, r20 + r02, r21 + r12])
    i = np.arange(len(k))
    row = K.reshape(10, -1)[_SHEPPERD[k], i[:, None]]                     # (n, 4)
    v = 0.5 * np.sqrt(row[i, k])
    q = row / (4 * v[:, None])
    q[i, k] = v
    q = q.reshape(shape + (4,))
    return np.where(q[..., :1] >= 0, q, -q)


#: Shepperd's matrix K (4 x 4, symmetric) as indices into its ten distinct entries
_SHEPPERD = np.array([[0, 4, 5, 6], [4, 1, 7, 8], [5, 7, 2, 9], [6, 8, 9, 3]])


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
