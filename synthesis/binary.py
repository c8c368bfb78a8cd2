"""Binary links of two joints through finite positions: the :class:`BinaryLink` result
(screw-type joints R, H, C, P, and the spherical S and universal U joints of
:mod:`synthesis.spherical` and :mod:`synthesis.hooke`) and the shared algebra of
:mod:`synthesis.helical` and :mod:`synthesis.cylindric` (after Tsai & Roth
1972, "Design of dyads with helical, cylindric, spherical, revolute and prismatic
joints", Mech. Mach. Theory 7).

A binary link has a fixed joint on the line G (direction g, point c_g) in the ground
and a moving joint on the line W (direction w, point c_w, given in position 1) in the
body.  Position j is reached by the moving joint's screw (angle φ_j, slide b_j along
w) followed by the fixed joint's (θ_j, a_j along g): ``T_j = G(θ_j, a_j) W(φ_j, b_j)``.
A revolute joint has slide 0, a helical one slide = pitch · angle (length / rad), a
cylindrical one a free slide.

Screw triangle.  Written with dual numbers, ``G(θ̂) W(φ̂) = S_1j(σ̂)``: the axes G, W
and S_1j form a spatial triangle whose sides are their common normals, with dual
angles θ̂_j/2 at G, φ̂_j/2 at W and σ̂_j/2 at S_1j.  Its real (spherical) part says
that the angle between g and the moving axis is the same in every position,
``g · (R_j − I) w = 0``; given the directions, the angles θ_j, φ_j follow, and the
dual part (the translations ``t_j = (I − R_g) c_g + a_j g + R_g ((I − R_w) c_w +
b_j w)``) is *linear* in the axis points and the slides.  So every problem here is a
search over directions (the spherical RR problem: a 2-parameter family of (g, w) for 3
positions, 1 for 4, finitely many for 5) followed by linear algebra, and the free
choices are explicit: a direction of the fixed axis, or its point.

All work is done in coordinates centred on the task and scaled by its size
(:func:`synthesis.validate.task_scale`), so results move and scale with the task.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from functools import lru_cache

import numpy as np

from .errors import SynthesisError
from .screw import Line
from .validate import number, screws as _screws, task_scale
from .verify import pose_errors

__all__ = ["BinaryLink"]


@dataclass
class BinaryLink:
    """A binary link of two joints (R, H, C or P) that guides a body through positions.

    Attributes
    ----------
    types : str
        Two joint letters, fixed (ground) joint first, e.g. ``"HH"``, ``"RC"``.
    fixed_axis, moving_axis : Line
        The joint axes in position 1 (fixed: canonical point, the foot of the
        perpendicular from the origin; moving: the foot of the common normal).
    fixed_pitch, moving_pitch : float
        Slide per radian (length / rad): 0 for R, the given pitch for H, NaN for C
        (slide free), inf for P (no rotation; its axis has a direction only, the
        point stored is immaterial).
    fixed_angles, moving_angles : numpy.ndarray, shape (n,)
        Joint rotations at positions 1…n (rad, 0 at position 1, in (−π, π]).
    fixed_slides, moving_slides : numpy.ndarray, shape (n,)
        Joint slides along the axes at positions 1…n (length; pitch · angle for H).
    residual : float
        Largest pose error of the link's forward kinematics over the positions:
        rotation (rad) or translation divided by the task's reach.
    parameters : dict
        The free parameters the link was computed for (name → value, units in the
        function's documentation); empty when the solution set is finite.
    cross_axis : numpy.ndarray, shape (3,), optional
        Universal joint (type letter ``"U"``, always the fixed joint here): the unit
        direction of its second (cross) axis in position 1; it passes through the
        joint's centre, is perpendicular to the first axis and turns with the first
        angle.  None for other joints.
    cross_angles : numpy.ndarray, shape (n,), optional
        Universal joint: the rotations about the cross axis at positions 1…n (rad, 0 at
        position 1); the rotations about the first axis are ``fixed_angles``.
    sphere_rotations : numpy.ndarray, shape (n, 3, 3), optional
        Spherical joint (type letter ``"S"``): its relative rotation at positions 1…n
        (the identity at position 1), about its centre: for a fixed S the link's
        rotation, for a moving S the body's rotation relative to the link.

    Spherical and universal joints
    ------------------------------
    An ``"S"`` joint is stored as a :class:`Line` whose point is the sphere's centre;
    its direction is immaterial (the other joint's direction is copied there), its
    pitch NaN, its angles and slides 0; its motion is ``sphere_rotations``.  A ``"U"``
    joint is stored as its first axis (point: the joint's centre, not a canonical
    foot), pitch 0, ``fixed_angles`` about the first axis and ``cross_angles`` about
    ``cross_axis``.  Forward kinematics: fixed S ``x ↦ S_j (x − c) + c``; fixed U the
    rotation about the centre ``Rot(a, α_j) Rot(b, γ_j)`` (b the cross axis in
    position 1); moving S ``x ↦ S_j (x − c) + c`` applied before the fixed joint.
    :meth:`moving_elements` gives the moving joint's axis (or centre) and the cross
    axis at every position, and :meth:`engine_chain` the link as revolute, helical,
    cylindrical and prismatic joints (an S as three revolutes along x, y, z through
    its centre, a U as its two axes) for :func:`synthesis.verify.verify_open_chains`.
    """

    types: str
    fixed_axis: Line
    moving_axis: Line
    fixed_pitch: float
    moving_pitch: float
    fixed_angles: np.ndarray
    fixed_slides: np.ndarray
    moving_angles: np.ndarray
    moving_slides: np.ndarray
    residual: float
    parameters: dict = field(default_factory=dict)
    cross_axis: np.ndarray | None = None
    cross_angles: np.ndarray | None = None
    sphere_rotations: np.ndarray | None = None

    def pose(self, fixed_angle: float, fixed_slide: float, moving_angle: float,
             moving_slide: float) -> np.ndarray:
        """Body pose ``(4, 4)`` relative to position 1 at the given joint values (rad,
        length); for R and H joints the slide argument is ignored (0, resp. pitch·angle),
        for P joints the angle (0).  Links with an S or U joint: use :meth:`poses`."""
        if "S" in self.types or "U" in self.types:
            raise SynthesisError(f"types: pose() takes the joint values of screw joints (R, H, "
                                 f"C, P); a {self.types} link has S/U joints: use poses()")
        q = [number(v, n) for v, n in ((fixed_angle, "fixed_angle"), (fixed_slide, "fixed_slide"),
                                        (moving_angle, "moving_angle"), (moving_slide, "moving_slide"))]
        a = _slide(self.types[0], self.fixed_pitch, q[0], q[1])
        b = _slide(self.types[1], self.moving_pitch, q[2], q[3])
        q[0] = 0.0 if self.types[0] == "P" else q[0]
        q[2] = 0.0 if self.types[1] == "P" else q[2]
        return _screw_matrix(self.fixed_axis.direction, self.fixed_axis.point, q[0], a) @ \
            _screw_matrix(self.moving_axis.direction, self.moving_axis.point, q[2], b)

    def poses(self) -> np.ndarray:
        """Body poses ``(n, 4, 4)`` at the link's own joint values (one per position)."""
        return self._fixed_motion() @ self._moving_motion()

    def _fixed_motion(self) -> np.ndarray:
        """The link's poses ``(n, 4, 4)`` (the fixed joint's motion)."""
        ax = self.fixed_axis
        if self.types[0] == "S":
            return _about(self.sphere_rotations, ax.point)
        if self.types[0] == "U":
            R = _rot(ax.direction, self.fixed_angles) @ _rot(self.cross_axis, self.cross_angles)
            return _about(R, ax.point)
        return _screw_matrix(ax.direction, ax.point, self.fixed_angles, self.fixed_slides)

    def _moving_motion(self) -> np.ndarray:
        """The body's poses relative to the link ``(n, 4, 4)`` (in position-1 coordinates)."""
        ax = self.moving_axis
        if self.types[1] == "S":
            return _about(self.sphere_rotations, ax.point)
        return _screw_matrix(ax.direction, ax.point, self.moving_angles, self.moving_slides)

    def moving_elements(self) -> dict:
        """The moving joint's element and the link's other carried elements at every
        position (world coordinates).

        Returns
        -------
        dict with
            ``"directions"`` (n, 3): the moving joint's axis direction (for an S joint
            the direction stored, immaterial); ``"points"`` (n, 3): its point (the sphere
            centre for S); ``"link"`` (n, 4, 4): the link's poses; and for a fixed U
            ``"cross_directions"`` (n, 3): the cross axis (through the centre).
        """
        Lk = self._fixed_motion()
        ax = self.moving_axis
        out = {"directions": Lk[:, :3, :3] @ ax.direction,
               "points": Lk[:, :3, :3] @ ax.point + Lk[:, :3, 3], "link": Lk}
        if self.types[0] == "U":
            out["cross_directions"] = Lk[:, :3, :3] @ self.cross_axis
        return out

    def engine_chain(self):
        """``(types, lines, pitches, joint_values)`` of the link as screw joints only (R,
        H, C, P): an S joint becomes three revolutes along x, y, z through its centre
        driven by the XYZ angles of its rotations (``S_j = Rx(a) Ry(b) Rz(c)``), a U its
        two axes (first, then cross); input of
        :func:`synthesis.verify.verify_open_chains`."""
        from scipy.spatial.transform import Rotation

        types, lines, pitches, cols = "", [], [], []
        for k, kind in enumerate(self.types):
            ax = self.fixed_axis if k == 0 else self.moving_axis
            if kind == "S":
                e = Rotation.from_matrix(self.sphere_rotations).as_euler("XYZ")
                for i in range(3):
                    types += "R"
                    lines.append(Line._exact(np.eye(3)[i], ax.point.copy()))
                    pitches.append(0.0)
                    cols.append(e[:, i])
            elif kind == "U":
                types += "RR"
                lines += [ax, Line._exact(np.asarray(self.cross_axis, float), ax.point.copy())]
                pitches += [0.0, 0.0]
                cols += [self.fixed_angles, self.cross_angles]
            else:
                ang = self.fixed_angles if k == 0 else self.moving_angles
                sl = self.fixed_slides if k == 0 else self.moving_slides
                p = self.fixed_pitch if k == 0 else self.moving_pitch
                types += kind
                lines.append(ax)
                pitches.append(0.0 if kind in "CP" else float(p))
                cols += [sl] if kind == "P" else [ang, sl] if kind == "C" else [ang]
        return types, lines, pitches, np.stack(cols, 1)

    def joint_values(self) -> np.ndarray:
        """Driven coordinates per position ``(n, k)`` in the engine's order (angle per R/H
        joint, angle and slide per C joint, slide per P joint): the input of
        :func:`synthesis.verify.verify_links`.  A U joint gives two angle columns (first
        axis, cross axis); an S joint none (its motion is ``sphere_rotations``)."""
        cols = []
        for kind, ang, sl in ((self.types[0], self.fixed_angles, self.fixed_slides),
                              (self.types[1], self.moving_angles, self.moving_slides)):
            if kind == "S":
                continue
            cols += [sl] if kind == "P" else [ang, sl] if kind == "C" else \
                [ang, self.cross_angles] if kind == "U" else [ang]
        return np.stack(cols, 1)

    def chain(self):
        """``(types, lines, pitches, joint_values)`` for :func:`synthesis.verify.verify_links`
        (R, H, C, P joints); for a link with an S or U joint the expanded
        :meth:`engine_chain` (for :func:`synthesis.verify.verify_open_chains`)."""
        if "S" in self.types or "U" in self.types:
            return self.engine_chain()
        return (self.types, [self.fixed_axis, self.moving_axis],
                [0.0 if t in "CP" else p for t, p in zip(self.types, (self.fixed_pitch,
                                                                       self.moving_pitch))],
                self.joint_values())


def _about(R, c) -> np.ndarray:
    """Rotations ``R (n, 3, 3)`` about the point ``c (3,)`` as 4x4 transforms."""
    R = np.asarray(R, float)
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = c - R @ c
    T[..., 3, 3] = 1.0
    return T


def _slide(kind, pitch, angle, slide):
    return 0.0 if kind == "R" else pitch * angle if kind == "H" else slide      # C, P: free


# ------------------------------------------------------------------ batched geometry
def _rot(u, ang):
    """Rotations ``(..., 3, 3)`` about unit ``u (..., 3)`` by ``ang (...)`` (Rodrigues)."""
    u = np.asarray(u, float)
    ang = np.asarray(ang, float)
    c, s = np.cos(ang)[..., None, None], np.sin(ang)[..., None, None]
    K = np.zeros(np.broadcast_shapes(u.shape[:-1], ang.shape) + (3, 3))
    K[..., 0, 1], K[..., 0, 2] = -u[..., 2], u[..., 1]
    K[..., 1, 0], K[..., 1, 2] = u[..., 2], -u[..., 0]
    K[..., 2, 0], K[..., 2, 1] = -u[..., 1], u[..., 0]
    return np.eye(3) + s * K + (1 - c) * (K @ K)


def _screw_matrix(u, c, ang, slide):
    """4x4 screws ``(..., 4, 4)``: rotation ``ang`` (rad) about the lines (u, c)
    ``(..., 3)``, then ``slide`` (length) along u (all broadcast)."""
    u, c = np.asarray(u, float), np.asarray(c, float)
    ang, slide = np.asarray(ang, float), np.asarray(slide, float)
    R = _rot(u, ang)
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = c - np.einsum("...ij,...j->...i", R, c) + slide[..., None] * u
    T[..., 3, 3] = 1.0
    return T


def _cross(a, b):
    """``np.cross`` of 3-vectors over broadcast leading axes, without its axis handling
    (the same products and differences, a fraction of the call overhead)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], -1)


def _perp(u):
    """Two unit vectors ``(..., 3)`` completing unit ``u (..., 3)`` to a right-handed frame."""
    a = np.where((np.abs(u[..., 0]) < 0.9)[..., None], [1.0, 0, 0], [0, 1.0, 0])
    e1 = a - np.sum(a * u, -1, keepdims=True) * u
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    return e1, _cross(u, e1)


def _signed_angle(a, b, u):
    """Angle ``(...)`` about ``u`` from ``a`` to ``b`` (their components ⊥ u)."""
    return np.arctan2(np.sum(u * _cross(a, b), -1), np.sum(a * b, -1) - np.sum(a * u, -1)
                      * np.sum(b * u, -1))


def _angles(g, w, R):
    """Joint rotations for directions ``g, w (N, 3)`` through rotations ``R (m, 3, 3)``
    (positions 2…n): θ carries w to R_j w about g, φ is the rest about w.  Also the
    decomposition's error (nonzero where the directions do not satisfy the constant-angle
    condition) and how far g, w are from parallel (|g × w|)."""
    Rw = np.einsum("mij,nj->nmi", R, w)                       # (N, m, 3)
    th = _signed_angle(w[:, None], Rw, g[:, None])
    Gm = _rot(g[:, None], th)                                  # (N, m, 3, 3)
    M = np.swapaxes(Gm, -1, -2) @ R                            # = Rot(w, φ)
    v = g - np.sum(g * w, -1, keepdims=True) * w
    Mv = np.einsum("nmij,nj->nmi", M, v)
    ph = _signed_angle(v[:, None], Mv, w[:, None])
    sin_gw = np.linalg.norm(_cross(g, w), axis=-1)
    return th, ph, Gm, sin_gw


def _system(g, w, th, ph, Gm, t, kinds, pitches, fixed_point=None):
    """The translation equations ``A x = rhs`` of positions 2…n, batched over N direction
    pairs.  Unknowns x: fixed-axis point (2, in the plane ⊥ g; absent when
    ``fixed_point`` is given), moving-axis point (2, ⊥ w), then one slide per position for
    each C joint.  Returns ``A (N, 3m, k)``, ``rhs (N, 3m)``, the bases (e1, e2, f1, f2)."""
    N, m = th.shape
    Wm = _rot(w[:, None], ph)                                  # (N, m, 3, 3)
    e1, e2 = _perp(g)
    f1, f2 = _perp(w)
    I = np.eye(3)
    cols = []
    if fixed_point is None:
        for e in (e1, e2):
            cols.append(np.einsum("nmij,nj->nmi", I - Gm, e))
    for f in (f1, f2):
        cols.append(np.einsum("nmij,nmj->nmi", Gm, np.einsum("nmij,nj->nmi", I - Wm, f)))
    A = np.stack(cols, -1).reshape(N, 3 * m, len(cols))        # (N, 3m, k0)
    Gw = np.einsum("nmij,nj->nmi", Gm, w)                      # R_g w (N, m, 3)
    rhs = np.broadcast_to(t, (N, m, 3)).copy()
    if fixed_point is not None:
        rhs -= np.einsum("nmij,j->nmi", I - Gm, fixed_point)
    blocks = [A]
    for kind, p, vec, ang in ((kinds[0], pitches[0], np.broadcast_to(g[:, None], (N, m, 3)), th),
                              (kinds[1], pitches[1], Gw, ph)):
        if kind == "C":
            B = np.zeros((N, m, 3, m))
            B[:, np.arange(m), :, np.arange(m)] = np.swapaxes(vec, 0, 1)
            blocks.append(B.reshape(N, 3 * m, m))
        elif kind == "H":
            rhs -= p * ang[..., None] * vec
    return np.concatenate(blocks, -1), rhs.reshape(N, 3 * m), (e1, e2, f1, f2)


# ------------------------------------------------------------------ the task
@dataclass
class _Task:
    """Positions in normalised coordinates: ``x ↦ (x − c) / L``."""
    T: np.ndarray          # (n, 4, 4) user coordinates, T[0] = I
    Tn: np.ndarray         # (n, 4, 4) normalised
    c: np.ndarray
    L: float
    reach: float

    @property
    def R(self):
        return self.Tn[1:, :3, :3]

    @property
    def t(self):
        return self.Tn[1:, :3, 3]


def _task(screws, name: str = "screws", n: tuple = (3,)) -> _Task:
    """Check the screws S_12…S_1n and build the normalised task; coincident positions
    raise (naming them)."""
    scr = _screws(screws, name)
    if len(scr) + 1 not in n:
        raise SynthesisError(f"{name}: expected {' or '.join(str(k - 1) for k in n)} screws "
                             f"S_12 … S_1n for {' or '.join(map(str, n))} positions, got {len(scr)}")
    T = np.stack([np.eye(4)] + [s.matrix() for s in scr])
    c, L, reach = task_scale(T, [s.axis for s in scr], [s.point for s in scr])
    j, k = np.tril_indices(len(T), -1)          # the pairs k < j, in the order j, then k
    rot, pos = pose_errors(T[j], T[k], reach)
    same = np.flatnonzero(np.maximum(rot, pos) < 1e-12)
    if same.size:
        j, k = j[same[0]], k[same[0]]
        raise SynthesisError(f"{name}: positions {k + 1} and {j + 1} coincide (their "
                             f"relative screw is the identity): degenerate task")
    C = np.eye(4)
    C[:3, 3] = -c
    C[:3] /= L
    C[3] = (0, 0, 0, 1.0)
    Ci = np.linalg.inv(C)
    return _Task(T, C @ T @ Ci, c, L, reach)


def _check_rotations(task: _Task, name: str = "screws"):
    """Every relative screw must rotate (a binary link of screw joints R, H, C whose relative
    screw is a pure translation needs parallel axes, whose solutions are not isolated), and
    the relative screws' axes must not all be parallel (a planar motion: every pair of
    parallel axes through circle points is a solution)."""
    T = task.T
    n = len(T)
    axes = []
    for j in range(n):
        for k in range(j):
            R = T[k, :3, :3].T @ T[j, :3, :3]
            ang = np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))
            axes.append(np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]))
            if ang < 1e-6:
                raise SynthesisError(
                    f"{name}: the relative screw S_{k + 1}{j + 1} is (nearly) a pure translation "
                    f"(rotation {ang:.1e} rad): a binary link of R, H or C joints then needs "
                    "parallel axes, whose solutions are not isolated (degenerate task)")
    U = np.array([a / np.linalg.norm(a) for a in axes if np.linalg.norm(a) > 1e-12])
    if len(U) >= 2 and np.linalg.svd(U, compute_uv=False)[1] < 1e-9:
        raise SynthesisError(f"{name}: the relative screws' axes are all parallel (a planar "
                             "motion): binary links of R, H or C joints are then not isolated "
                             "(every pair of parallel axes through corresponding circle points "
                             "reaches the positions): degenerate task")


def _unfinished(task: _Task, types, pitches, g, cg, w, cw, th, a, ph, b,
                params) -> BinaryLink:
    """A BinaryLink in user coordinates from normalised directions, points and joint values
    at positions 2…n (pitches in normalised units), its residual not yet computed
    (:func:`_residuals` does that for many links at once)."""
    L, c = task.L, task.c
    G = Line(g, cg * L + c).canonical()
    W = Line(w, cw * L + c).canonical(G)
    z = np.zeros(1)
    pg = np.nan if types[0] == "C" else pitches[0] * L
    pw = np.nan if types[1] == "C" else pitches[1] * L
    return BinaryLink("".join(types), G, W, float(pg), float(pw), np.r_[z, th],
                      np.r_[z, a * L], np.r_[z, ph], np.r_[z, b * L], 0.0, dict(params or {}))


def _residuals(links, task: _Task):
    """Set every link's ``residual`` (its largest pose error over the task: rad, or
    translation / the task's reach), in one batched pose comparison; returns the links."""
    if links:
        rot, pos = pose_errors(np.stack([lk.poses() for lk in links]), task.T, task.reach)
        for lk, r in zip(links, np.maximum(rot.max(-1), pos.max(-1)).tolist()):
            lk.residual = r
    return links


def _finish(task: _Task, types, pitches, g, cg, w, cw, th, a, ph, b, params) -> BinaryLink:
    """:func:`_unfinished` with its residual."""
    return _residuals([_unfinished(task, types, pitches, g, cg, w, cw, th, a, ph, b, params)],
                      task)[0]


def _same(a: BinaryLink, b: BinaryLink, L: float, tol: float = 1e-6) -> bool:
    for x, y in ((a.fixed_axis, b.fixed_axis), (a.moving_axis, b.moving_axis)):
        if abs(abs(x.direction @ y.direction) - 1) > tol or x.distance_to(y) > tol * L:
            return False
    return True


def _fibonacci(n: int) -> np.ndarray:
    """``n`` nearly uniform unit vectors on the upper hemisphere (z ≥ 0) (n, 3)."""
    k = np.arange(n) + 0.5
    z = k / n
    phi = np.pi * (1 + 5 ** 0.5) * k
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], -1)


@lru_cache(maxsize=8)
def _fibonacci_neighbours(n: int, k: int):
    """The Fibonacci grid of ``n`` directions (n, 3) and each point's ``k`` nearest
    neighbours among ±grid (n, k) (indices into the doubled grid), built once per size
    (read-only arrays)."""
    from scipy.spatial import cKDTree
    G = _fibonacci(n)
    _, idx = cKDTree(np.concatenate([G, -G])).query(G, k + 1)
    nbr = np.ascontiguousarray(idx[:, 1:])
    G.flags.writeable = nbr.flags.writeable = False
    return G, nbr


def _local_minima(f: np.ndarray, nbr: np.ndarray) -> np.ndarray:
    """Indices of the grid points whose value ``f`` (n,) is finite and no larger than at
    their neighbours ``nbr`` (n, k) (indices into the doubled grid, ±g identified)."""
    fb = np.concatenate([f, f])
    low = np.isfinite(f)
    for k in range(nbr.shape[1]):       # a neighbour at a time (np.all over the short axis of
        low &= f <= fb[nbr[:, k]]       # an (n, k) comparison: 6× the time, measured)
    return np.flatnonzero(low)
