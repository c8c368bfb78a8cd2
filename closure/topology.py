"""The structure of a mechanism: spanning tree, independent loops, coordinate layout.

:func:`compile_tree` turns a mechanism's description (links, joints) into a
:class:`Topology`: a breadth-first spanning tree from the ground fixes every link's
pose from the joint coordinates, each joint outside the tree closes one independent
loop, and the velocity coordinates of the joints are laid out one after another.
It knows nothing of poses or solving (:mod:`closure.state`, :mod:`closure.solver`).
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from .errors import MechanismError

__all__ = ["Topology", "compile_tree"]


@dataclass(frozen=True)
class Topology:
    """The compiled structure of a mechanism: its spanning tree from the ground, the
    loop-closing joints (one independent loop each) and the coordinate layout."""
    links: tuple            # link names, ground first
    parent_joint: tuple     # per link: index of the tree joint to its parent (-1 for ground)
    forward: tuple          # per link: True if the parent is the joint's link_a
    order: tuple            # links in BFS order (parents before children)
    chords: tuple           # indices of the loop-closing joints
    path_sign: np.ndarray   # (nlinks, nv): link twist = Σ sign · column · rate
    loop_coef: np.ndarray   # (nloops, nv): loop velocity constraint coefficients
    v_offset: tuple         # per joint: first velocity coordinate
    q_offset: tuple         # per joint: first stored scalar coordinate
    s_index: tuple          # per joint: index among spherical joints (-1 if not S)
    nv: int
    nq: int
    ns: int
    length_cols: np.ndarray  # velocity coordinates that are lengths (P, C slide)
    scale: float            # characteristic length of the mechanism
    centre: np.ndarray      # (3,) centroid of the joint origins at assembly (m)
    link_index: dict          # link name -> index
    joint_link_a: np.ndarray  # (njoints,) index of each joint's link a
    frames_a: np.ndarray      # (njoints, 4, 4) the joints' frames on link a


def compile_tree(joints, links, ground: str) -> Topology:
    """The :class:`Topology` of the joints (:class:`~closure.joints.Joint`, in their index
    order) between the links (names, ground first).

    Raises
    ------
    MechanismError
        No joints, or links not connected to the ground.
    """
    if not joints:
        raise MechanismError("mechanism has no joints")
    nl = len(links)
    lidx = {n: i for i, n in enumerate(links)}
    adj: list[list[int]] = [[] for _ in range(nl)]
    for j in joints:
        adj[lidx[j.link_a]].append(j.index)
        adj[lidx[j.link_b]].append(j.index)
    parent = [-1] * nl
    forward = [True] * nl
    seen = [False] * nl
    seen[0] = True
    order = [0]
    tree_joints = set()
    queue = deque([0])
    while queue:
        li = queue.popleft()
        for ji in adj[li]:
            j = joints[ji]
            other = lidx[j.link_b] if lidx[j.link_a] == li else lidx[j.link_a]
            if not seen[other]:
                seen[other] = True
                parent[other] = ji
                forward[other] = lidx[j.link_a] == li
                tree_joints.add(ji)
                order.append(other)
                queue.append(other)
    lost = [links[i] for i in range(nl) if not seen[i]]
    if lost:
        raise MechanismError(f"links not connected to the ground {ground!r}: "
                             f"{', '.join(lost)}")
    chords = tuple(j.index for j in joints if j.index not in tree_joints)
    v_off, q_off, s_idx = [], [], []
    nv = nq = ns = 0
    length_cols = []
    for j in joints:
        v_off.append(nv)
        q_off.append(nq)
        s_idx.append(ns if j.kind == "S" else -1)
        if j.kind == "P":
            length_cols.append(nv)
        if j.kind == "C":
            length_cols.append(nv + 1)
        nv += j.nv
        nq += j.nq
        ns += j.kind == "S"
    sign = np.zeros((nl, nv))
    for li in order[1:]:
        ji = parent[li]
        j = joints[ji]
        p = lidx[j.link_a] if forward[li] else lidx[j.link_b]
        sign[li] = sign[p]
        sign[li, v_off[ji]:v_off[ji] + j.nv] = 1.0 if forward[li] else -1.0
    loop = np.zeros((len(chords), nv))
    for k, ci in enumerate(chords):
        j = joints[ci]
        loop[k] = sign[lidx[j.link_a]] - sign[lidx[j.link_b]]
        loop[k, v_off[ci]:v_off[ci] + j.nv] += 1.0
    pts = np.array([j.frame_a[:3, 3] for j in joints])
    centre = pts.mean(0)
    scale = float(np.max(np.linalg.norm(pts - centre, axis=1)))
    if scale == 0.0:
        scale = 1.0
    return Topology(tuple(links), tuple(parent), tuple(forward), tuple(order), chords,
                 sign, loop, tuple(v_off), tuple(q_off), tuple(s_idx), nv, nq, ns,
                 np.array(length_cols, dtype=int), scale, centre, lidx,
                 np.array([lidx[j.link_a] for j in joints]),
                 np.array([j.frame_a for j in joints]))

