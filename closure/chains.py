"""Open chains driven at every joint, in bulk.

A chain ground –j1– L1 –j2– L2 … –jk– Lk whose joints are all driven has no loop to
close: each link pose is the product of the constant joint frames and the joint
matrices of :mod:`closure.joints`,

    L_j = L_{j-1} · F_j · A_j(q_j) · F'_j⁻¹,    L_0 = I,

with ``F_j`` the joint frame in the ground frame at the assembly pose (every coordinate
zero) and ``F'_j = F_j · A_j(0)`` its frame on link *j* (``A_j(0) = I`` but for the Hooke
joint).  These are the products :meth:`closure.Mechanism.solve` evaluates for the same
chain hung from the ground with every joint coordinate an input, computed here for many
chains and positions at once, without building a mechanism.
"""
from __future__ import annotations

import numpy as np

from .checks import shown
from .errors import MechanismError
from .frames import _inverse, as_array, check_transform
from .joints import _U_MID
from .state import _rz

__all__ = ["open_chain_poses"]

_DRIVEN = "RPCHU"


def _kinds(kinds) -> np.ndarray:
    """Joint letters as a ``(V or 1, k)`` array of one-byte strings, checked."""
    rows = [kinds] if isinstance(kinds, str) else \
        list(kinds) if isinstance(kinds, (list, tuple, np.ndarray)) else []
    try:
        joined = "".join(rows)
    except TypeError:
        joined = ""
    if not joined:
        raise MechanismError(f"kinds: expected a string of joint letters from {_DRIVEN} (e.g. "
                             f"'RUC') or one such string per chain, got {shown(kinds)}")
    k = len(rows[0])
    if set(map(len, rows)) != {k}:
        raise MechanismError(f"kinds: expected strings of one length (joints per chain), got "
                             f"lengths {sorted(set(map(len, rows)))}")
    letters = set(joined)
    if "S" in letters:
        raise MechanismError("kinds: a spherical joint (S) cannot be driven; expected letters "
                             f"from {_DRIVEN}")
    if not letters <= set(_DRIVEN):
        raise MechanismError(f"kinds: unknown joint letters {sorted(letters - set(_DRIVEN))}; "
                             f"expected letters from {_DRIVEN}")
    return np.frombuffer(joined.encode("ascii"), "S1").reshape(len(rows), k)


def open_chain_poses(kinds, frames, values, pitches=None, *, validate: bool = True) -> np.ndarray:
    """Link poses of open chains hung from the ground with every joint driven.

    Parameters
    ----------
    kinds : str or sequence of str
        Joint letters from R, P, C, H, U, ground joint first: one string of ``k`` letters
        for every chain, or one string of ``k`` letters per chain (``V`` strings).
    frames : array_like, shape (V, k, 4, 4)
        Each joint's frame in the ground frame with every joint coordinate zero (as
        :meth:`closure.Mechanism.add_joint`'s ``at``): Z along the axis of R, P, C, H
        joints; for U, Z along the pin on the link before the joint and X along the pin
        on the link after it.  Lengths in any unit.
    values : array_like, shape (P, V, k, 2) or (P, V, k)
        The joint coordinates at each of ``P`` positions, in the order of
        :mod:`closure.joints`: slot 0 is θ (rad) of R, C, H, s (length) of P, φ (rad) of U;
        slot 1 is s (length) of C and θ (rad) of U, and is not read for R, P, H.  Shape
        (P, V, k) when no joint is C or U.
    pitches : array_like, broadcastable to (V, k), optional
        Slide per radian (length / rad) of each joint; required, finite, where a joint is
        H, not read elsewhere.
    validate : bool
        Check that ``frames`` are rigid transforms (skip only for frames a program built
        as exact rotations, as :meth:`closure.Mechanism.add_joint` allows; they must still
        be finite).

    Returns
    -------
    numpy.ndarray, shape (P, V, k, 4, 4)
        ``[p, v, j]``: the world pose of the link after joint ``j + 1`` of chain ``v`` at
        position ``p`` (``[:, :, -1]`` the last link), identity at zero coordinates; what
        :meth:`closure.Mechanism.solve` and its kinematics give for the chain hung from the
        ground with every coordinate an input.

    Raises
    ------
    MechanismError
        Bad input, naming the argument: unknown or spherical joint letters, strings of
        different lengths, frames that are not rigid transforms or not (V, k, 4, 4),
        values of the wrong shape or not finite, a helical joint without a finite pitch.

    Notes
    -----
    The products are the engine's (:meth:`closure.state.Plan.evaluate`: ``F · A · F'⁻¹``
    per joint, then down the chain), in the same order, so they equal the mechanism's to
    the last bit in practice; the cost is a few 4x4 products per joint, position and chain
    (no mechanism, no assembly, no Newton step), linear in the chains.

    Examples
    --------
    >>> import numpy as np
    >>> from closure import open_chain_poses, translation
    >>> F = np.array([[translation([1.0, 0, 0]), translation([2.0, 0, 0])]])   # (1, 2, 4, 4)
    >>> L = open_chain_poses("RP", F, np.array([[[np.pi / 2, 0.5]]]))             # (1, 1, 2, ...)
    >>> np.round(L[0, 0, -1] @ [2.0, 0, 0, 1], 12)          # the P link's point (2, 0, 0)
    array([1. , 1. , 0.5, 1. ])
    """
    K = _kinds(kinds)
    k = K.shape[1]
    F = check_transform(frames, "frames") if validate else as_array(frames, "frames")
    V = F.shape[0] if F.ndim == 4 else -1
    if F.ndim != 4 or F.shape[1:] != (k, 4, 4) or K.shape[0] not in (1, V):
        n = "V" if K.shape[0] == 1 else K.shape[0]
        raise MechanismError(f"frames: expected shape ({n}, {k}, 4, 4) (chains, joints), got "
                             f"{F.shape}")
    K = np.broadcast_to(K, (V, k))
    two = bool(((K == b"C") | (K == b"U")).any())
    q = as_array(values, "values")
    if not ((q.ndim == 4 and q.shape[1:] == (V, k, 2)) or
            (q.ndim == 3 and q.shape[1:] == (V, k) and not two)):
        want = f"(P, {V}, {k}, 2)" + ("" if two else f" or (P, {V}, {k})")
        raise MechanismError(f"values: expected shape {want} (positions, chains, joints"
                             f"{', coordinates' if two else ''}), got {q.shape}")
    q0, q1 = (q[..., 0], q[..., 1]) if q.ndim == 4 else (q, q)
    h = np.zeros((V, k))
    if pitches is not None:
        h = as_array(pitches, "pitches", finite=False)
        try:
            h = np.broadcast_to(h, (V, k))
        except ValueError:
            raise MechanismError(f"pitches: expected shape ({V}, {k}) or one broadcasting to "
                                 f"it, got {h.shape}") from None
    helical = K == b"H"
    if helical.any() and (pitches is None or not np.isfinite(h[helical]).all()):
        raise MechanismError("pitches: a helical (H) joint needs a finite pitch (length / rad), "
                             f"got {'none' if pitches is None else 'a non-finite one'}")
    h = np.where(helical, h, 0.0)               # other joints' pitches are not read (inf: P)
    u = K == b"U"
    hooke = bool(u.any())
    Fb = F
    if hooke:
        Fb = F.copy()
        Fb[u] = F[u] @ _U_MID                   # the frame on link b: F · A(0)
    # A(q) (P, V, k, 4, 4) of every joint at every position, as
    # closure.state.Plan.joint_matrices builds it
    th = np.where((K == b"P") | u, 0.0, q0)
    c, s = np.cos(th), np.sin(th)
    A = np.zeros(q0.shape + (4, 4))
    A[..., 0, 0], A[..., 0, 1], A[..., 1, 0], A[..., 1, 1] = c, -s, s, c
    A[..., 2, 2] = A[..., 3, 3] = 1.0
    A[..., 2, 3] = np.where(K == b"P", q0, np.where(K == b"C", q1,
                                                    np.where(helical, q0 * h, 0.0)))
    if hooke:
        A[:, u, :3, :3] = _rz(q0[:, u]) @ _U_MID[:3, :3] @ _rz(q1[:, u])
    Fbi = _inverse(Fb)
    for j in range(k):                          # joint j of every chain at every position
        rel = F[:, j] @ A[:, :, j] @ Fbi[:, j]  # link j in link j − 1, as the engine's tree
        A[:, :, j] = rel if j == 0 else A[:, :, j - 1] @ rel     # (A becomes the poses)
    return A
