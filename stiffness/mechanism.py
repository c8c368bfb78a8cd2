"""Stiffness of a link of any mechanism the closure engine models.

The mechanism's joint coordinates ``q`` (velocity coordinates of the engine, ``nv`` of
them) move the links; at a solved pose the loops allow the small motions ``dq`` with
``J dq = 0`` (J the loop-closure Jacobian) and the chosen link (the "platform") moves
by the small displacement ``Δ = A dq`` (A its twist columns).  Each coordinate is

* **elastic**: a spring on the coordinate (N/m for a slide, N·m/rad for a rotation),
  or a symmetric matrix on the coordinates of one joint;
* **locked**: held rigidly (``dq = 0``), by default the mechanism's inputs (actuated
  joints) that are not given a spring;
* **passive**: free (every other coordinate), eliminated through the loop constraints.

With ``Z`` a basis of the allowed motions (null space of J over the free and elastic
coordinates) the elastic energy is ``½ yᵀ H y`` with ``H = Zᵀ Kq Z`` for ``dq = Z y``
and the platform moves by ``Δ = M y`` with ``M = A Z``.  The compliance is
``C = M H⁻¹ Mᵀ`` over the motions that store energy, and ``K`` its inverse over the
platform's compliant directions.  For a hexapod with elastic legs this is
``K = P Kθ Pᵀ``; for a serial arm with elastic joints ``K = J⁻ᵀ Kθ J⁻¹``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from .beam import beam_geometric_stiffness
from .errors import SingularPoseError, StiffnessError
from .sixvector import rotate_six, twist_transform
from closure.frames import adjoint, skew

from .validate import as_array, number, reference_frame, transform, vec3

__all__ = ["MechanismStiffness", "of_mechanism", "mechanism_map"]

#: poses per chunk of :func:`mechanism_map` (bounds its working memory)
MAP_CHUNK = 2048

#: singular values of the dimensionless loop Jacobian below this fraction of the
#: largest count as zero (the engine's own rank rule)
RANK_RTOL = 1e-8
#: energy eigenvalues below this fraction of the largest are motions that deform no spring
ENERGY_RTOL = 1e-12
#: a zero-energy motion moving the platform by more than this (dimensionless) is free
FREE_MOTION_TOL = 1e-8


@dataclass(repr=False)
class MechanismStiffness:
    """Cartesian stiffness of a mechanism's link at a batch of solved poses ``(B,)``.

    Attributes
    ----------
    K : numpy.ndarray, shape (B, 6, 6)
        Stiffness relating ``W = (f, m)`` (N, N·m) to ``Δ = (δ, θ)`` (m, rad) about the
        reference point, over the link's compliant directions (blocks N/m, N/rad,
        N·m/rad).  Where the mechanism holds the link rigidly (``rigid > 0``), K is the
        pseudo-inverse of ``C``: finite on the compliant directions, zero on the others,
        which are infinitely stiff.
    C : numpy.ndarray, shape (B, 6, 6)
        Compliance ``Δ = C W`` (blocks m/N, m/(N·m), rad/N, rad/(N·m)).
    rigid : numpy.ndarray of int, shape (B,)
        Number of directions in which the mechanism holds the link rigidly (no spring
        deforms when it moves that way): 0 for a link that is elastic in every
        direction, 3 for a planar mechanism seen in space.
    reference : numpy.ndarray, shape (B, 3)
        The reference point (origin of the result's frame), world coordinates (m).
    R : numpy.ndarray, shape (B, 3, 3)
        Axes of the result's frame: ``r' = R (r − reference)``.
    condition : numpy.ndarray, shape (B,)
        Condition number of the dimensionless loop Jacobian over the free and elastic
        coordinates (1 for an open chain): large near a singular pose.
    elastic, locked, passive : list of str
        Labels of the coordinates in each role.
    loaded : bool
        True: the stiffness under the load given to :func:`of_mechanism` (the
        derivative of the wrench holding the link, about the reference point carried by
        it; in general not symmetric).
    """

    K: np.ndarray
    C: np.ndarray
    rigid: np.ndarray
    reference: np.ndarray
    R: np.ndarray
    condition: np.ndarray
    elastic: list
    locked: list
    passive: list
    loaded: bool = False

    def __repr__(self) -> str:
        B = self.K.shape[0]
        kt = np.linalg.eigvalsh(0.5 * (self.K[:, :3, :3] + np.swapaxes(self.K[:, :3, :3], 1, 2)))
        pos = kt[kt > 0]
        span = f"{pos.min():.4g} … {pos.max():.4g} N/m" if pos.size else "none"
        return (f"MechanismStiffness({'loaded, ' if self.loaded else ''}{B} "
                f"pose{'s' if B != 1 else ''}, translational stiffness "
                f"{span}, rigid directions {int(self.rigid.min())}…{int(self.rigid.max())}, "
                f"{len(self.elastic)} elastic / {len(self.locked)} locked / {len(self.passive)} "
                "passive coordinates)")


@dataclass(frozen=True)
class _LinkSpring:
    """A checked link spring: link and joint (names, indices), its frame F (4, 4, world at
    the assembly pose), stiffness K (6, 6), beam length (m, or None) and label."""

    link: str
    joint: str
    li: int
    col: int
    F: np.ndarray
    K: np.ndarray
    length: float | None
    label: str

    def __iter__(self):                         # (li, col, F, K, label), the unloaded view
        return iter((self.li, self.col, self.F, self.K, self.label))


def _link_springs(mech, link_springs) -> list:
    """Checked :class:`_LinkSpring` of each item of ``link_springs``."""
    if link_springs is None:
        return []
    if isinstance(link_springs, (str, dict)) or not hasattr(link_springs, "__iter__"):
        raise StiffnessError("link_springs: expected a list of (link, joint, frame, K) or "
                             f"(link, joint, frame, K, length), got {type(link_springs).__name__}")
    out = []
    for i, item in enumerate(link_springs):
        where = f"link_springs[{i}]"
        try:
            link, joint, F, K, *rest = item
            if len(rest) > 1:
                raise ValueError
        except (TypeError, ValueError):
            raise StiffnessError(f"{where}: expected (link, joint, frame, K) or (link, joint, "
                                 f"frame, K, length), got {type(item).__name__}") from None
        length = None
        if rest and rest[0] is not None:
            length = number(rest[0], f"{where}: length", positive=True)
        if not isinstance(link, str) or link not in mech.links or link == mech.links[0]:
            raise StiffnessError(f"{where}: link: expected a moving link, got {link!r}")
        names = [j.name for j in mech.joints]
        if not isinstance(joint, str) or joint not in names:
            raise StiffnessError(f"{where}: joint: no joint named {joint!r}")
        j = mech.joints[names.index(joint)]
        if link not in (j.link_a, j.link_b):
            raise StiffnessError(f"{where}: joint {joint!r} joins {j.link_a!r} and "
                                 f"{j.link_b!r}, not the link {link!r}")
        F = transform(F, f"{where}: frame")
        if F.shape != (4, 4):
            raise StiffnessError(f"{where}: frame: expected one 4x4 transform, got shape "
                                 f"{F.shape}")
        K6 = _spd(K, f"{where}: K", 6)
        if any(x.link == link and x.joint == joint for x in out):
            raise StiffnessError(f"{where}: the link {link!r} is given two springs at the joint "
                                 f"{joint!r}; expected one (add their compliances)")
        out.append(_LinkSpring(link, joint, mech.tree.link_index[link],
                               mech.tree.v_offset[j.index], F, K6, length, f"{link}@{joint}"))
    return out


def _spd(value, name, n):
    """A symmetric positive definite n x n matrix from a number, n numbers or a matrix."""
    k = as_array(value, name, what=f"a stiffness (N/m or N·m/rad), {n} of them or a "
                                   f"{n}x{n} matrix")
    if k.shape in ((), (1,), (n,)):
        k = np.diag(np.broadcast_to(k, (n,)).astype(float))
    elif k.shape != (n, n):
        raise StiffnessError(f"{name}: expected a stiffness, {n} of them or a {n}x{n} matrix, "
                             f"got shape {k.shape}")
    if not np.allclose(k, k.T, rtol=1e-12, atol=0) or np.linalg.eigvalsh(k).min() <= 0:
        raise StiffnessError(f"{name}: expected positive stiffness (a symmetric positive "
                             "definite matrix)")
    return 0.5 * (k + k.T)


def _roles(mech, springs, locked, link_springs=None):
    """(Kq (nv, nv), elastic, locked, passive index arrays, link springs) from the user's
    spring maps."""
    labels = mech.velocity_labels()
    t = mech.tree
    cols_of = {}
    for j in mech.joints:
        cols = list(range(t.v_offset[j.index], t.v_offset[j.index] + j.nv))
        cols_of[j.name] = cols
        if j.nv > 1:
            for c in cols:
                cols_of[labels[c]] = [c]
    links = _link_springs(mech, link_springs)
    if springs is None and links:
        springs = {}
    if not isinstance(springs, dict) or not (springs or links):
        raise StiffnessError("springs: expected a non-empty dict {joint or 'joint.coordinate': "
                             f"stiffness}}, got {type(springs).__name__}")
    Kq = np.zeros((t.nv, t.nv))
    elastic: list[int] = []
    for key, value in springs.items():
        if key not in cols_of:
            raise StiffnessError(f"springs: no joint or coordinate named {key!r}; expected one "
                                 f"of {', '.join(sorted(cols_of))}")
        cols = cols_of[key]
        if set(cols) & set(elastic):
            raise StiffnessError(f"springs: {key!r} given a spring twice")
        Kq[np.ix_(cols, cols)] = _spd(value, f"springs[{key!r}]", len(cols))
        elastic += cols
    if locked is None:
        lock = [c for c in mech.input_columns() if c not in elastic]
    else:
        if isinstance(locked, str):
            locked = [locked]
        lock = []
        for key in locked:
            if key not in cols_of:
                raise StiffnessError(f"locked: no joint or coordinate named {key!r}; expected "
                                     f"one of {', '.join(sorted(cols_of))}")
            if set(cols_of[key]) & set(elastic):
                raise StiffnessError(f"locked: {key!r} also has a spring")
            lock += cols_of[key]
    elastic_a, lock_a = np.array(sorted(elastic), int), np.array(sorted(set(lock)), int)
    passive = np.setdiff1d(np.arange(t.nv), np.r_[elastic_a, lock_a])
    return Kq, elastic_a, lock_a, passive, links


def _frame(frame, link_T):
    """(R (B, 3, 3), p (B, 3)) of the result's frame, one frame for every pose."""
    B = link_T.shape[0]
    R, p = reference_frame(frame, link_T)
    if R.shape[:-2] != p.shape[:-1] or R.ndim not in (2, 3) or \
            R.ndim == 3 and not isinstance(frame, str):
        raise StiffnessError(f"frame: expected one frame (R (3, 3), p (3,)), got shapes "
                             f"{R.shape} and {p.shape}")
    return np.broadcast_to(R, (B, 3, 3)), np.broadcast_to(p, (B, 3))


def _by_rank(values, fn):
    """Apply ``fn(index_array, rank)`` to each group of poses sharing a rank (a handful of
    groups: the rank changes only at singular poses)."""
    for r in np.unique(values):
        fn(np.flatnonzero(values == r), int(r))


def of_mechanism(mechanism, pose, *, platform: str, springs: dict | None = None, locked=None,
                 link_springs=None, frame=None, wrench=None) -> MechanismStiffness:
    """Cartesian stiffness of the link ``platform`` of a mechanism at solved poses.

    Parameters
    ----------
    mechanism : closure.Mechanism
    pose : closure.Pose
        Poses of ``mechanism`` (from :meth:`Mechanism.solve` or ``sweep``), one or a batch.
    platform : str
        The link whose stiffness is wanted (the moving platform, the tool).
    springs : dict
        ``{joint: stiffness}`` or ``{"joint.coordinate": stiffness}`` (labels as
        :meth:`Mechanism.velocity_labels`): N/m for slides (P, C's ``s``), N·m/rad for
        rotations (R, C's ``theta``, H, U, S; S coordinates are rotations about the
        joint's *a*-frame axes ``wx, wy, wz``).  A joint's value may be one number for
        each of its coordinates, one per coordinate, or a symmetric positive definite
        matrix over them.
    locked : iterable of str, optional
        Joints or coordinates held rigidly.  Default: the mechanism's inputs that have
        no spring (actuators locked).  Every other coordinate without a spring is passive.
    link_springs : list of (link, joint, frame, K) or (link, joint, frame, K, length)
        Elastic links (the virtual-joint method): the link deforms between its body and
        its attachment to ``joint`` by a small displacement resisted by the 6x6 stiffness
        ``K`` (about the origin of ``frame``, in its axes; blocks N/m, N/rad, N·m/rad).
        ``frame`` is a 4x4 transform given, like joint frames, in world coordinates at
        the assembly pose; :func:`beam_stiffness` gives K for a beam.  A beam joining
        ``joint`` to the link's other joint is a cantilever clamped at ``joint``: take
        ``frame`` at the other end, x along the beam away from ``joint``.  With a
        ``length`` (m) the link is such a straight beam and, under a ``wrench``, its axial
        force N changes its bending stiffness (:func:`beam_geometric_stiffness`, the
        P-δ effect); without one it is a general 6x6 spring with no such term.
    frame : "base" (or None), "platform" or (R, p)
        The result's reference point and axes: the ground's (world) origin and axes (the
        default), the platform link's frame, or origin ``p`` (world coordinates, m) with
        ``r' = R (r − p)``.
    wrench : array_like, shape (6,), optional
        An external load ``(f, m)`` (N, N·m) on the platform, about the world origin:
        then the loaded stiffness, the derivative of the wrench holding the platform
        displaced by ``Δ`` about the reference point it carries, at ``pose`` taken as the
        loaded equilibrium.  The springs carry the load as the linear elastic solution
        at this pose distributes it (exactly the spring forces of the equilibrium where
        the springs are statically determinate, as in a hexapod or a 3-RPS), the loops
        by the least-norm loop wrenches (no self-stress); moving the mechanism turns the
        joints that carry these forces, which adds the geometric term (non-symmetric
        where a moment acts about the reference point).  An elastic link is then the
        explicit chain of its deformation (see Notes); the pose is its loaded shape.

    Returns
    -------
    MechanismStiffness
        K, C, rigid directions, frame and condition for every pose.

    Raises
    ------
    StiffnessError
        Bad arguments (naming them).
    SingularPoseError
        A pose where the platform can move without deforming any spring (a free motion
        of the mechanism: lock or spring more joints), a pose that is not solved, or a
        ``wrench`` at a critical (buckling) load, where the loaded stiffness is singular.

    Notes
    -----
    Computed from the engine's own loop Jacobian in its dimensionless form (twists about
    the mechanism's centre, lengths divided by its size), so the result does not depend
    on where the world origin is.  One SVD and one symmetric eigenproblem per pose,
    batched; poses are grouped only where the Jacobian's rank differs (singular poses).

    Elastic links under load.  Each link spring is made an explicit chain in a copy of
    the mechanism: the joint is cut from the link and ends on the beam's root, which
    carries the link's body through three slides along the frame's axes and a spherical
    joint at its origin, so the spring's six coordinates are the nodal displacements of
    matrix structural analysis: the tip point's translation, then the rotation about it,
    in the frame's axes carried by the root.  ``K`` is the link's tangent stiffness in
    these coordinates at the (loaded) pose.  The load then reaches every geometric term
    through the engine's twist brackets like any joint: the load carried by the link
    from its deflected tip (the transport of the wrench along the deflected link), the
    turning of the joints beyond it, and the loops.  A beam given its ``length`` also
    gets the consistent geometric stiffness of its axial force N (tension positive),
    ``N/L [6/5, 2L²/15, ∓L/10]`` on its bending coordinates (one cubic beam element:
    a cantilever column's critical load comes out 2.486 EI/L², 0.75 % above Euler's
    π²EI/4L²); the axial shortening by bending and the torsional (Wagner) terms are not
    modelled.
    """
    _check(mechanism, pose, platform)
    bad = np.flatnonzero(np.atleast_1d(pose.status) >= 2)
    if bad.size:
        raise SingularPoseError(f"pose: pose index {int(bad[0])} is not solved (status "
                                f"{int(np.atleast_1d(pose.status)[bad[0]])}); its stiffness is "
                                "undefined")
    roles = _roles(mechanism, springs, locked, link_springs)
    if wrench is not None:
        wrench = as_array(wrench, "wrench", what="a wrench (f, m) of shape (6,) (N, N·m)")
        if wrench.shape != (6,):
            raise StiffnessError(f"wrench: expected a wrench (f, m) of shape (6,) (N, N·m), got "
                                 f"shape {wrench.shape}")
    ks = pose.kinematics()
    R, p = _frame(frame, ks.link[:, mechanism.tree.link_index[platform]])
    if wrench is not None and roles[4]:
        # elastic links under load: their deformation joints made explicit (see _augment)
        aug, ks_a, roles_a, beams = _augment(mechanism, pose, roles)
        res, free = _stiffness(aug, ks_a, platform, roles_a, R, p, wrench, beams)
        res.elastic = _labels(mechanism, roles[1]) + [x.label for x in roles[4]]
        res.locked, res.passive = _labels(mechanism, roles[2]), _labels(mechanism, roles[3])
        # the loop condition as the unloaded result reports it (the copy's extra joints
        # move the centre and size that make its Jacobian dimensionless)
        res.condition = _stiffness(mechanism, ks, platform, roles, R, p)[0].condition
    else:
        res, free = _stiffness(mechanism, ks, platform, roles, R, p, wrench)
    res.loaded = wrench is not None
    if free.any():
        b = int(np.flatnonzero(free)[0])
        raise SingularPoseError(
            f"pose: at pose index {b} the platform {platform!r} can move without deforming any "
            f"spring (a free motion of the mechanism, loop condition {res.condition[b]:.3g}): "
            "give springs to more joints or lock them (passive coordinates: "
            f"{', '.join(res.passive) or 'none'})")
    return res


def _check(mechanism, pose, platform):
    from closure import Mechanism, Pose
    if not isinstance(mechanism, Mechanism):
        raise StiffnessError(f"mechanism: expected a closure.Mechanism, got "
                             f"{type(mechanism).__name__}")
    if not isinstance(pose, Pose) or pose.mechanism is not mechanism:
        raise StiffnessError("pose: expected a closure.Pose of this mechanism (from "
                             f"mechanism.solve), got {type(pose).__name__}")
    if not isinstance(platform, str) or platform not in mechanism.links or \
            platform == mechanism.links[0]:
        raise StiffnessError(f"platform: expected the name of a moving link ("
                             f"{', '.join(mechanism.links[1:])}), got {platform!r}")


def _columns(mechanism, ks, platform, roles, free):
    """The motion columns of a batch: the free and elastic joint coordinates, then six per
    link spring.  Returns their world twists ``(B, n, 6)``, loop coefficients ``(nloops,
    n)``, platform-path coefficients ``(n,)``, length scale of each column ``(n,)`` and
    the stiffness over them ``(n, n)`` (units of the columns)."""
    Kq, links = roles[0], roles[4]
    t = mechanism.tree
    col = np.ones(t.nv)
    col[t.length_cols] = t.scale                          # dq = col · dq_s, dq_s dimensionless
    path = t.path_sign[t.link_index[platform]]
    twists = [ks.S[:, free]]
    loop, along, scale = [t.loop_coef[:, free]], [path[free]], [col[free]]
    stiff = [Kq[np.ix_(free, free)]]
    for li, c, F, K6, _ in links:
        # a deformation of the link in series with the joint: six unit twists of the frame
        # F carried by the link, with the joint's own loop and path coefficients
        twists.append(np.swapaxes(adjoint(ks.link[:, li] @ F), 1, 2))
        loop.append(np.repeat(t.loop_coef[:, c:c + 1], 6, 1))
        along.append(np.full(6, path[c]))
        scale.append(np.r_[np.full(3, t.scale), np.ones(3)])
        stiff.append(K6)
    n = sum(len(a) for a in along)
    Kall = np.zeros((n, n))
    i = 0
    for k in stiff:
        Kall[i:i + len(k), i:i + len(k)] = k
        i += len(k)
    return (np.concatenate(twists, 1), np.concatenate(loop, 1), np.concatenate(along),
            np.concatenate(scale), Kall)


def _augment(mechanism, pose, roles):
    """The mechanism with each link spring's deformation made explicit, for the loaded
    stiffness: the spring's link *l* is cut from its joint *c*, which now ends on a new
    link (the attachment, the beam's root), and the attachment carries *l*'s body through
    three slides along the axes of the spring's frame F followed by a spherical joint at
    F's origin (the tip).  These six coordinates are the nodal displacements of the tip
    relative to the root (the tip point's translation, then the rotation about it, in F's
    axes carried by the root), in F's order ``(δ, θ)``, so the spring's K applies to them
    as it stands; the engine's own twist brackets then give every geometric term of the
    load carried through the deflected link.

    Returns the augmented mechanism, its kinematic state at ``pose`` (undeformed links:
    the same link poses), its roles (the spring blocks added to Kq as elastic columns)
    and ``[(first column, length or None)]`` of each spring."""
    from closure import Mechanism
    Kq, elastic, lock, passive, links = roles
    t = mechanism.tree
    aug = Mechanism(mechanism.links[1:] + [f"{x.label}:{k}" for x in links
                                           for k in ("root", "x", "y", "z")],
                    ground=mechanism.ground)
    cut = {(x.joint, x.link): f"{x.label}:root" for x in links}
    for j in mechanism.joints:                            # a cut joint ends on the root(s)
        a, b = cut.get((j.name, j.link_a), j.link_a), cut.get((j.name, j.link_b), j.link_b)
        aug.add_joint(j.name, j.kind, a, b, at=(j.frame_a, j.frame_b),
                      pitch=j.pitch if j.kind == "H" else None)
    perm = ((1, 2, 0), (2, 0, 1), (0, 1, 2))              # slide frames: z along F's x, y, z
    for x in links:
        F = x.F
        chain = [f"{x.label}:{k}" for k in ("root", "x", "y", "z")] + [x.link]
        for k in range(3):
            Fk = F.copy()
            Fk[:3, :3] = F[:3, :3][:, perm[k]]
            aug.add_joint(f"{x.label}:d{'xyz'[k]}", "P", chain[k], chain[k + 1], at=Fk)
        aug.add_joint(f"{x.label}:r", "S", chain[3], chain[4], at=F)
    for ji, k in mechanism.inputs:
        aug.add_input(mechanism.joints[ji].name, k)
    ta = aug.tree
    B = pose.q.shape[0]
    q = np.concatenate([pose.q, np.zeros((B, ta.nq - t.nq))], 1)
    rot = np.concatenate([pose.rot.reshape(B, t.ns, 3, 3),
                          np.broadcast_to(np.eye(3), (B, len(links), 3, 3))], 1)
    ks = aug.kinematic_state((q, rot))
    n = ta.nv
    Kq_a = np.zeros((n, n))
    Kq_a[:t.nv, :t.nv] = Kq
    beams, new = [], []
    for i, x in enumerate(links):
        c0 = t.nv + 6 * i
        Kq_a[c0:c0 + 6, c0:c0 + 6] = x.K
        beams.append((c0, x.length))
        new += range(c0, c0 + 6)
    roles_a = (Kq_a, np.r_[elastic, new].astype(int), lock, passive, [])
    return aug, ks, roles_a, beams


def _stiffness(mechanism, ks, platform, roles, R, p, wrench=None, beams=()):
    """The result for one batch of kinematic states in the frames ``R (B, 3, 3)``, ``p (B,
    3)``, and which poses have a free motion (their K, C are left zero there).  With a
    ``wrench`` (6,) about the world origin, the loaded stiffness."""
    Kq, elastic, lock, passive, links = roles
    t = mechanism.tree
    free = np.sort(np.r_[elastic, passive].astype(int))   # the columns that move
    W, loop, along, colf, Kc = _columns(mechanism, ks, platform, roles, free)
    B, nf = W.shape[:2]
    L = t.scale
    Kq_s = Kc * colf[:, None] * colf                      # energy per dimensionless motion
    A0 = (along[:, None] * W).transpose(0, 2, 1) * colf   # (B, 6, nf): Δ about the world origin
    A = twist_transform(R, p) @ A0                        # Δ about p, in the frame's axes
    if t.chords:
        Jw = np.einsum("kc,bcs->bksc", loop, W).reshape(B, -1, nf)
        J = mechanism._scaled_rows(Jw) * colf             # dimensionless, about the centre
        UJ, s, Vt = np.linalg.svd(J, full_matrices=True)
        rank = np.sum(s > RANK_RTOL * np.maximum(s[:, :1], 1e-300), axis=1)
    else:
        UJ = np.zeros((B, 0, 0))
        Vt = np.broadcast_to(np.eye(nf), (B, nf, nf))
        s = np.ones((B, 1))
        rank = np.zeros(B, int)
    cond = np.ones(B)
    C = np.zeros((B, 6, 6))
    K = np.zeros((B, 6, 6))
    rigid = np.zeros(B, int)
    free_motion = np.zeros(B, bool)
    unit = np.r_[np.full(3, 1 / L), np.ones(3)]           # Δ made dimensionless

    def group(idx, r):
        if r:
            cond[idx] = s[idx, 0] / s[idx, r - 1]
        Z = np.swapaxes(Vt[idx, r:], 1, 2)                # (b, nf, m) allowed motions
        H = np.swapaxes(Z, 1, 2) @ Kq_s @ Z
        lam, V = np.linalg.eigh(H)
        M = A[idx] @ Z @ V                                # platform motion of each mode
        Ms = M * unit[:, None]
        stored = lam > ENERGY_RTOL * np.maximum(lam[:, -1:], 1e-300)
        moves = np.linalg.norm(Ms, axis=1) > FREE_MOTION_TOL
        loose = (moves & ~stored).any(1)
        free_motion[idx] = loose
        stored &= ~loose[:, None]                         # those poses are left at zero
        inv = np.where(stored, 1 / np.where(stored, lam, 1), 0.0)
        C[idx] = np.einsum("bik,bk,bjk->bij", M, inv, M)
        # compliant directions: the range of the energy-storing modes' platform motions
        Ms_st = Ms * stored[:, None, :]
        U, sv, _ = np.linalg.svd(Ms_st, full_matrices=True)
        n_c = np.sum(sv > RANK_RTOL * np.maximum(sv[:, :1], 1e-300), axis=1)
        rigid[idx] = 6 - n_c
        for nc in np.unique(n_c):                          # a handful of groups
            g = np.flatnonzero(n_c == nc)
            # K = D pinv(D C D) D with D = diag(unit): the pseudo-inverse taken on
            # dimensionless displacements, over the compliant directions only
            Qi = U[g, :, :nc] * unit[:, None]
            Cq = np.swapaxes(Qi, 1, 2) @ C[idx[g]] @ Qi
            K[idx[g]] = Qi @ np.linalg.inv(Cq) @ np.swapaxes(Qi, 1, 2)
            if wrench is None:
                continue
            for ns in np.unique(stored[g].sum(1)):
                h = g[stored[g].sum(1) == ns]
                keep = np.argsort(~stored[h], axis=1, kind="stable")[:, :ns]   # stored modes
                Zr = Z[h] @ np.take_along_axis(V[h], keep[:, None, :], 2)
                lam_r = np.take_along_axis(lam[h], keep, 1)
                j = idx[h]
                H6 = rotate_six(R[j])                     # world axes → the frame's
                Kl, Cl = _loaded(mechanism, ks, j, free, Zr, lam_r, A0[j], colf, loop, along,
                                 Kq_s, (UJ[j], s[j], Vt[j], rank[j]), wrench, p[j],
                                 np.swapaxes(H6, 1, 2) @ U[h, :, :nc], unit, beams)
                K[j] = H6 @ Kl @ np.swapaxes(H6, 1, 2)
                C[j] = H6 @ Cl @ np.swapaxes(H6, 1, 2)

    _by_rank(rank, group)
    rigid[free_motion] = 0
    return MechanismStiffness(K, C, rigid, np.array(p, dtype=float), np.array(R, dtype=float),
                              cond, _labels(mechanism, elastic) + [x.label for x in links],
                              _labels(mechanism, lock), _labels(mechanism, passive)), free_motion


#: the permutation symbol ε_kij (cross products as contractions)
_EPS = np.zeros((3, 3, 3))
_EPS[0, 1, 2] = _EPS[1, 2, 0] = _EPS[2, 0, 1] = 1.0
_EPS[0, 2, 1] = _EPS[2, 1, 0] = _EPS[1, 0, 2] = -1.0

#: the loaded energy form is refused as singular (a critical load) when its smallest
#: singular value is below this fraction of the softest unloaded energy eigenvalue
CRITICAL_RTOL = 1e-10


def _loaded(mechanism, ks, idx, free, Zr, lam, A0, colf, loop, along, Kq_s, svd, wrench, p,
            Uc, unit, beams=()):
    """Loaded stiffness and compliance about the carried points ``p`` (world axes) of the
    poses ``idx``, from their energy-storing modes ``Zr (b, n, r)`` (dimensionless
    coordinates of the columns ``free``) with energies ``lam (b, r)``.

    The load W (about the world origin) is carried by spring forces ``τ`` (the elastic
    solution at this pose) and by loop wrenches ``λ`` (``τ − Aᵀ W − Jᵀ λ = 0``,
    least-norm ``λ``: no self-stress).  Moving along admissible rates v turns every
    joint's twist column (``Ẇ_c = [V_carrier, W_c]``), so the wrench ``Λ_c = along_c W +
    Σ_k loop_kc λ_k`` passing through column c adds ``−Σ_c u_c Λ_cᵀ Ẇ_c(v)`` to the
    energy form ``uᵀ Kq v``; the held wrench about the carried point adds ``[f] δ`` (as
    for :meth:`Hexapod.loaded_stiffness`).  Returns ``(K, C)`` over the compliant
    directions ``Uc`` (scaled displacements)."""
    from closure import carrier_twists
    from closure.kinematics import bracket
    t = mechanism.tree
    b, n, r = Zr.shape
    Wt = np.broadcast_to(wrench, (b, 6))
    # elastic solution: mode coordinates y = Λ⁻¹ (A0 Zr)ᵀ W, spring forces τ = Kq dq
    y = np.einsum("bsn,bnr,bs->br", A0, Zr, Wt) / lam
    tau = np.einsum("nm,bmr,br->bn", Kq_s, Zr, y)
    rhs = tau - np.einsum("bsn,bs->bn", A0, Wt)           # = Jᵀ λ (dimensionless columns)
    Lam = along[None, :, None] * Wt[:, None, :]           # (b, n, 6)
    if t.chords:
        UJ, sJ, Vt, rank = svd
        k = int(rank.max())
        ok = np.arange(k) < rank[:, None]
        inv_s = np.where(ok, 1 / np.where(ok, sJ[:, :k], 1), 0.0)
        # J = U diag(s) Vᵀ (rows about the centre): the least-norm λ of Jᵀ λ = rhs
        lam_sc = np.einsum("bmk,bk,bkn,bn->bm", UJ[:, :, :k], inv_s, Vt[:, :k], rhs)
        lam_sc = lam_sc.reshape(b, -1, 6)
        f = lam_sc[..., :3] / t.scale                      # rows were (v + ω × c) / L
        m = lam_sc[..., 3:] + np.cross(t.centre, f)        # moments back to the world origin
        Lam = Lam + np.einsum("kc,bks->bcs", loop, np.concatenate([f, m], -1))
    # rates of every coordinate along each mode (true units)
    rates = np.zeros((b, r, t.nv))
    rates[:, :, free] = np.swapaxes(Zr * colf[:, None], 1, 2)
    sub = ks.take(idx)
    S = sub.S                                              # (b, nv, 6)
    Vc = carrier_twists(mechanism, sub, rates)             # (b, r, nv, 6)
    Wdot = bracket(Vc, S[:, None])[:, :, free]             # (b, r, n, 6)
    Hl = -np.einsum("bci,bcs,bjcs->bij", Zr * colf[:, None], Lam, Wdot)
    Hl += lam[:, :, None] * np.eye(r)
    # a spherical joint's coordinates are angular velocities, not a chart: a spring on it
    # (linear in the rotation vector of the joint's turn, K its Hessian there) holding a
    # moment τ adds −½ τ · (u × v) to the form (the second derivative of the rotation
    # vector along the angular velocities u, v)
    for j in mechanism.joints:
        if j.kind != "S":
            continue
        c0 = mechanism.tree.v_offset[j.index]
        i0 = int(np.searchsorted(free, c0))
        if i0 + 2 >= len(free) or free[i0] != c0:
            continue
        Us = Zr[:, i0:i0 + 3]                              # (b, 3, r), rad per mode
        Hl += 0.5 * np.einsum("bk,kij,bir,bjs->brs", tau[:, i0:i0 + 3], _EPS, Us, Us)
    for c0, length in beams:                               # the beams' own P-δ term
        if length is None:
            continue
        i0 = int(np.searchsorted(free, c0))
        sl = slice(i0, i0 + 6)
        N = tau[:, i0] / colf[i0]                          # axial force (N), tension > 0
        Gs = beam_geometric_stiffness(length, 1.0) * colf[sl, None] * colf[sl]
        Hl += N[:, None, None] * np.einsum("bir,ij,bjs->brs", Zr[:, sl], Gs, Zr[:, sl])
    M = twist_transform(np.eye(3), p) @ A0 @ Zr            # Δ about p, world axes
    Qi, Qd = Uc * unit[:, None], Uc / unit[:, None]        # D U_c and D⁻¹ U_c
    # the unloaded stiffness on the compliant directions: the scale of "singular"
    Mq = np.swapaxes(Qi, 1, 2) @ M
    K0 = np.linalg.inv(Mq @ (np.swapaxes(Mq, 1, 2) / lam[:, :, None]))
    soft = np.linalg.svd(K0, compute_uv=False)[:, -1]
    sv = np.linalg.svd(Hl, compute_uv=False)
    _critical(idx, sv[:, -1] / sv[:, 0] < 1e-14, "its energy form is singular")
    Cp = M @ np.linalg.solve(Hl, np.swapaxes(M, 1, 2))
    Kp = Qi @ np.linalg.inv(np.swapaxes(Qi, 1, 2) @ Cp @ Qi) @ np.swapaxes(Qi, 1, 2)
    G = np.zeros((b, 6, 6))
    G[:, 3:, :3] = skew(Wt[:, :3])                         # m' = m − δ × f adds [f] δ
    Kc = Kp + Qi @ np.swapaxes(Qd, 1, 2) @ G @ Qd @ np.swapaxes(Qi, 1, 2)
    Kr = np.swapaxes(Qd, 1, 2) @ Kc @ Qd                   # on the compliant directions
    low = np.linalg.svd(Kr, compute_uv=False)[:, -1] / soft
    _critical(idx, ~(low > CRITICAL_RTOL), "its smallest singular value is "
              f"{float(np.min(low)):.1e} of the unloaded one's")
    return Kc, Qd @ np.linalg.inv(Kr) @ np.swapaxes(Qd, 1, 2)


def _critical(idx, bad, why):
    """Raise at the first pose ``bad`` where the load is critical (the loaded stiffness is
    singular: a buckling load)."""
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise SingularPoseError(f"wrench: at pose index {int(idx[i])} the loaded stiffness is "
                                f"singular ({why}): the load is at a critical (buckling) load "
                                "of the mechanism")


def mechanism_map(mechanism, pose, *, platform: str, springs: dict | None = None, locked=None,
                  link_springs=None, point=None) -> pd.DataFrame:
    """Compliance indices of a link over a batch of solved poses, one row per pose.

    The poses are processed in chunks of :data:`MAP_CHUNK` (bounded memory); a pose where
    the link can move without deforming any spring is flagged, not raised.

    Parameters
    ----------
    mechanism, pose, platform, springs, locked, link_springs
        As :func:`of_mechanism` (``pose`` a batch from ``solve`` or ``sweep``).
    point : array_like, shape (3,), optional
        Reference point of the indices: a point of the platform link given by its world
        coordinates at the assembly pose (closure's convention for points on links), for
        instance the tool centre.  Default: the link frame's origin, which is the world
        origin at the assembly pose.  Axes: the platform's.

    Returns
    -------
    pandas.DataFrame
        The inputs (one column per input, rad or m), the reference point ``x, y, z`` (world,
        m), ``ct_max`` (m/N: the largest translational compliance, the deflection per
        newton in the weakest direction), ``cr_max`` (rad/(N·m)), ``rigid`` (directions
        held rigidly), ``condition`` (of the loop Jacobian), ``free`` (True: the link can
        move without deforming a spring; its compliance is then infinite: ``inf``) and
        ``ok`` (the pose closed: status below 2; other rows are ``NaN`` with ``ok``
        False).  ``.attrs["units"]`` gives the units.
    """
    _check(mechanism, pose, platform)
    c = np.zeros(3) if point is None else vec3(point, "point")
    if c.shape != (3,):
        raise StiffnessError(f"point: expected one point (3,) (m), got shape {c.shape}")
    roles = _roles(mechanism, springs, locked, link_springs)
    B = len(pose.residual)
    ok = np.atleast_1d(pose.status) < 2
    ct = np.full(B, np.nan)
    cr = np.full(B, np.nan)
    rigid = np.zeros(B, int)
    cond = np.full(B, np.nan)
    free = np.zeros(B, bool)
    origin = np.full((B, 3), np.nan)
    t = mechanism.tree
    good = np.flatnonzero(ok)
    for a in range(0, good.size, MAP_CHUNK):
        idx = good[a:a + MAP_CHUNK]
        ks = mechanism.kinematic_state((pose.q[idx], pose.rot[idx]))
        T = ks.link[:, t.link_index[platform]]
        R = np.swapaxes(T[:, :3, :3], 1, 2)
        ref = T[:, :3, :3] @ c + T[:, :3, 3]
        res, fr = _stiffness(mechanism, ks, platform, roles, R, ref)
        Ct, Cr = res.C[:, :3, :3], res.C[:, 3:, 3:]
        ct[idx] = np.linalg.eigvalsh(0.5 * (Ct + np.swapaxes(Ct, 1, 2)))[:, -1]
        cr[idx] = np.linalg.eigvalsh(0.5 * (Cr + np.swapaxes(Cr, 1, 2)))[:, -1]
        ct[idx[fr]] = cr[idx[fr]] = np.inf
        rigid[idx], cond[idx], free[idx] = res.rigid, res.condition, fr
        origin[idx] = ref
    inputs = np.atleast_2d(pose.inputs).reshape(B, -1)
    df = pd.DataFrame({lab: inputs[:, i] for i, lab in enumerate(mechanism.input_labels())})
    df = df.assign(x=origin[:, 0], y=origin[:, 1], z=origin[:, 2], ct_max=ct, cr_max=cr,
                   rigid=rigid, condition=cond, free=free, ok=ok)
    df.attrs["reference"] = "platform point " + str([float(v) for v in c]) + " m"
    df.attrs["units"] = {"x": "m", "y": "m", "z": "m", "ct_max": "m/N", "cr_max": "rad/(N·m)"}
    return df


def _labels(mech, cols) -> list:
    labels = mech.velocity_labels()
    return [labels[int(c)] for c in cols]
