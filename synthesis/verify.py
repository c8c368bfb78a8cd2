"""Verification of synthesised chains by the closure engine, shared by every binary-link
and dyad module of the package (it imports none of them).

Every synthesised open chain is driven to its joint values at all positions by the
engine's bulk open-chain evaluation (:func:`closure.open_chain_poses`: all chains of a call
in one vectorised product of the engine's joint frames and joint matrices, the poses
:meth:`closure.Mechanism.solve` gives for the chain hung from the ground with every joint
an input), and each body pose (or, for sphere-ended chains, the sphere centre) is compared
with the given one.  Errors are rotations (rad) or translations divided by a length (the
task's reach).
"""
from __future__ import annotations

import functools

import numpy as np

from closure import Mechanism, open_chain_poses, transform
from closure.frames import _log_so3, cross, log_so3
from closure.frames import _transform as _exact_transform

from .errors import SynthesisError
from .screw import Line
from .validate import array, line, number
from .validate import transform as _transform

__all__ = ["in_chunks", "chain_mechanism", "verify_chain", "verify_chains", "verify_points", "pose_error",
           "pose_errors", "verify_links", "verify_open_chains", "verify_driven", "verify_frames",
           "line_frames", "pin_frames"]


#: chains per engine mechanism in the verifications that build one (measured: a few dozen
#: is fastest)
VERIFY_CHUNK = 32


def in_chunks(verify):
    """Run a verification ``verify(chains, targets, length)`` over chunks of
    :data:`VERIFY_CHUNK` chains, one engine mechanism each, and join the errors: the
    engine's batched solve carries dense (positions, coordinates, inputs) arrays,
    quadratic in the chains of one mechanism, and the chains are independent (same
    poses, same errors).  (The verifications of this module need no chunks: their open
    chains go through :func:`closure.open_chain_poses`, linear in the chains.)"""
    @functools.wraps(verify)
    def run(chains, targets, length: float = 1.0):
        chains = list(chains)
        if len(chains) <= VERIFY_CHUNK:
            return verify(chains, targets, length)
        return np.concatenate([verify(chains[i:i + VERIFY_CHUNK], targets, length)
                               for i in range(0, len(chains), VERIFY_CHUNK)])
    return run


def _frame_of(line: Line) -> np.ndarray:
    """A joint frame with Z along the line at its point."""
    return _frames_of([line])[0]


def _frames_of(lines, check: bool = True) -> np.ndarray:
    """Joint frames (N, 4, 4) with Z along each line at its point (:func:`line_frames` of
    the Lines' directions and points)."""
    # (concatenate: a third faster than np.array on thousands of 3-vectors)
    return line_frames(np.concatenate([ln.direction for ln in lines]).reshape(-1, 3),
                       np.concatenate([ln.point for ln in lines]).reshape(-1, 3), check)


def line_frames(directions, points, check: bool = True) -> np.ndarray:
    """Joint frames (N, 4, 4) with Z along each unit direction (N, 3) at its point (N, 3),
    in one vectorised pass (rotations exact by construction; ``check=False`` leaves out
    their check, for callers that check the frames' entries themselves)."""
    z = directions
    a = np.where((np.abs(z[:, 0]) < 0.9)[:, None], [1.0, 0, 0], [0, 1.0, 0])
    x = a - np.sum(a * z, 1, keepdims=True) * z
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    return (transform if check else _exact_transform)(np.stack([x, cross(z, x), z], -1),
                                                      points)


def pin_frames(a, b, O) -> np.ndarray:
    """Frames (N, 4, 4) of U joints from their pins and centres (N, 3): Z along ``a`` (the
    pin on the link before the joint), X along ``b`` (the pin on the link after it), at
    ``O``."""
    F = np.zeros((len(a), 4, 4))
    F[:, :3, 0], F[:, :3, 1], F[:, :3, 2], F[:, :3, 3] = b, np.cross(a, b), a, O
    F[:, 3, 3] = 1.0
    return F


def _joint_frames(types, joints) -> np.ndarray:
    """Joint frames (V, k, 4, 4) of V chains of k joints: ``types`` V strings of k letters,
    ``joints`` per chain k joints, a Line (Z along it at its point) or, for a U joint, its
    pins and centre ``(a, b, O)`` (:func:`pin_frames`)."""
    flat = [j for js in joints for j in js]
    letters = "".join(types)
    pins = [i for i, t in enumerate(letters) if t == "U" and not isinstance(flat[i], Line)] \
        if "U" in letters else []
    if not pins:
        return _frames_of(flat, check=False).reshape(len(joints), -1, 4, 4)
    lines = np.ones(len(flat), bool)
    lines[pins] = False
    F = np.zeros((len(flat), 4, 4))
    if lines.any():
        F[lines] = _frames_of([j for j, ln in zip(flat, lines) if ln], check=False)
    F[pins] = pin_frames(*(np.array(x, float) for x in zip(*[flat[i] for i in pins])))
    return F.reshape(len(joints), -1, 4, 4)


def _drive(types, joints, values, pitches=None) -> np.ndarray:
    """Link poses (P, V, k, 4, 4) of V open chains of k joints hung from the ground and
    driven by ``values`` (P, V, k, 2) (the engine's coordinates, see
    :func:`closure.open_chain_poses`; ``joints`` as in :func:`_joint_frames`: exact
    rotations, so the engine checks only that the frames are finite)."""
    return open_chain_poses(types, _joint_frames(types, joints), values, pitches, validate=False)


def _worst(bodies, targets, length) -> np.ndarray:
    """Each chain's largest pose error over the positions, as :func:`pose_errors` (without
    its rotation check: ``bodies`` (P, V, 4, 4) are products of exact rotations, the targets
    checked by the callers)."""
    T = np.asarray(targets, float)[:, None]
    rot = np.linalg.norm(_log_so3(np.swapaxes(bodies[..., :3, :3], -1, -2) @ T[..., :3, :3]),
                         axis=-1)
    pos = np.linalg.norm(bodies[..., :3, 3] - T[..., :3, 3], axis=-1) / length
    return np.maximum(rot.max(0), pos.max(0))


def _stacked(arrays) -> np.ndarray:
    """Per-chain arrays (P, ...) as one array (P, V, ...)."""
    return np.array(arrays, float).swapaxes(0, 1)


def _first_slot(jv) -> np.ndarray:
    """One value per joint (P, V, k) as the engine's coordinates (P, V, k, 2): the second
    coordinate of a C or U joint (not driven by these chains) stays zero."""
    return np.stack([jv, np.zeros_like(jv)], -1)


_KINDS = "RPCHU"


def _check_chain(types, lines, n: int = 3):
    """Joint letters and Lines of an open chain of ``n`` joints (kinds R, P, C, H, U, and S
    only where stated by the caller)."""
    if not isinstance(types, str) or len(types) != n or any(t not in _KINDS + "S" for t in types):
        raise SynthesisError(f"types: expected {n} joint letters from {_KINDS}S (e.g. 'RRR'), "
                             f"got {types!r}")
    if isinstance(lines, (str, bytes)) or not hasattr(lines, "__iter__"):
        raise SynthesisError(f"lines: expected {n} Lines, got {type(lines).__name__}")
    lines = list(lines)
    if len(lines) != n:
        raise SynthesisError(f"lines: expected {n} Lines, got {len(lines)}")
    return types, [line(ln, f"lines[{k}]") for k, ln in enumerate(lines)]


def chain_mechanism(types, lines) -> Mechanism:
    """The open chain ground –j1– A –j2– B –j3– body as an engine mechanism with every
    joint an input (so the chain is driven by its joint values).

    Parameters
    ----------
    types : str
        Three joint letters (R, P, C, H, U), ground joint first.
    lines : sequence of three Line
        The joint axes in the first position.
    """
    types, lines = _check_chain(types, lines)
    m = Mechanism(["A", "B", "body"])
    links = ["ground", "A", "B", "body"]
    for k, (t, axis) in enumerate(zip(types, lines)):
        if t == "S":
            raise SynthesisError("types: chain_mechanism drives every joint, and a spherical "
                                 "joint cannot be driven; verify sphere-ended chains through "
                                 "their centre (verify_points)")
        m.add_joint(f"j{k + 1}", t, links[k], links[k + 1], at=_frame_of(axis))
        m.add_input(f"j{k + 1}")
    return m


def pose_errors(A, B, length: float = 1.0):
    """Rotation (rad) and translation (divided by ``length``) errors between poses.

    Parameters
    ----------
    A, B : numpy.ndarray, shape (..., 4, 4)
        Rigid transforms (broadcast against each other).
    length : float
        Length the translation error is divided by.

    Returns
    -------
    rot, pos : numpy.ndarray, shape (...)
    """
    rot = np.linalg.norm(log_so3(np.swapaxes(A[..., :3, :3], -1, -2) @ B[..., :3, :3]), axis=-1)
    pos = np.linalg.norm(A[..., :3, 3] - B[..., :3, 3], axis=-1)
    return rot, pos / length


def verify_chains(chains, targets, length: float = 1.0) -> np.ndarray:
    """Verify many synthesised chains at once: all of them are driven by their joint values
    at every position in one bulk engine evaluation (:func:`closure.open_chain_poses`).

    Parameters
    ----------
    chains : list of (types, lines, joint_values (P, 3))
        One value per joint (angle rad, or slide length for P; a C or U joint's second
        coordinate stays zero).
    targets : (P, 4, 4) the given poses

    Returns
    -------
    numpy.ndarray (len(chains),): each chain's largest pose error (rad, or translation /
    ``length``).
    """
    if not chains:
        return np.zeros(0)
    jv = _stacked([c[2] for c in chains])
    poses = _drive([c[0] for c in chains], [c[1][:3] for c in chains], _first_slot(jv))
    return _worst(poses[:, :, -1], targets, length)


def verify_points(chains, targets, length: float = 1.0) -> np.ndarray:
    """Verify sphere-ended chains: the two joints before the sphere are driven by the engine
    (all chains in one bulk evaluation, :func:`closure.open_chain_poses`) and the sphere
    centre carried by the second link is compared with its given positions (the sphere
    leaves the orientation free).

    Parameters
    ----------
    chains : list of (types (2), lines (2), joint_values (P, 2), centre (3,)[, pitches (2)])
        Joint letters R, P, C, H, U of the two joints (ground first), their axes in
        position 1, their driven values per position (angle rad, or slide length for P),
        the sphere centre in position 1, and optionally the two pitches (length/rad, used
        by H joints; required when a joint is H).
    targets : array_like, shape (P, 4, 4)
        The body's given poses.
    length : float
        Length the centre errors are divided by.

    Returns
    -------
    numpy.ndarray, shape (len(chains),)
        Each chain's largest centre error divided by ``length``.

    Raises
    ------
    SynthesisError
        A helical joint without a finite pitch (naming ``chains[v]: pitches``).
    """
    if not chains:
        return np.zeros(0)
    types = [c[0][:2] for c in chains]
    h = None
    if any("H" in t for t in types):
        h = np.zeros((len(chains), 2))
        for v, c in enumerate(chains):
            pitches = c[4] if len(c) > 4 else None
            for k in range(2):
                if types[v][k] == "H":
                    p = None if pitches is None else float(pitches[k])
                    if p is None or not np.isfinite(p):
                        raise SynthesisError(f"chains[{v}]: pitches: joint {k + 1} is helical; "
                                             f"expected a finite pitch, got {p}")
                    h[v, k] = p
    jv = _stacked([c[2] for c in chains])
    B = _drive(types, [c[1][:2] for c in chains], _first_slot(jv), h)[:, :, 1]   # (P, V, 4, 4)
    O = np.array([c[3] for c in chains], float)                                 # (V, 3)
    T = np.asarray(targets, float)
    got = (B[..., :3, :3] @ O[..., None])[..., 0] + B[..., :3, 3]
    want = (T[:, None, :3, :3] @ O[..., None])[..., 0] + T[:, None, :3, 3]
    return np.linalg.norm(got - want, axis=-1).max(0) / length


def verify_chain(types, lines, joint_values, targets, length: float = 1.0) -> float:
    """Drive the synthesised chain through its joint values with the closure engine and
    return the largest pose error over all positions: rotation (rad) or translation
    divided by ``length`` (the positions' size).

    Parameters
    ----------
    types : str
        Three joint letters (R, P, C, H, U), ground joint first.
    lines : sequence of three Line
        Joint axes in the first position.
    joint_values : array_like, shape (n, 3) or (3,)
        Joint values at each position (rad, or length for P).
    targets : array_like, shape (n, 4, 4)
        The body's given poses (rigid transforms).
    length : float
        Positive length that translation errors are divided by.

    Raises
    ------
    SynthesisError
        Bad input, naming the argument.
    """
    types, lines = _check_chain(types, lines)
    if "S" in types:
        raise SynthesisError("types: spherical joints are verified through their centre "
                             "(verify_points), not driven; expected R, P, C, H or U")
    targets = _transform(targets, "targets", batch=True)
    n = targets.shape[0]
    jv = array(joint_values, "joint_values", None, what=f"joint values ({n}, 3), one row per target")
    if jv.shape == (3,) and n == 1:
        jv = jv[None]
    if jv.shape != (n, 3):
        raise SynthesisError(f"joint_values: expected joint values ({n}, 3), one row per "
                             f"target, got shape {jv.shape}")
    length = number(length, "length", positive=True)
    return float(verify_chains([(types, lines, jv)], targets, length)[0])




def pose_error(A, B, length_scale: float = 1.0) -> float:
    """Largest of the rotation error (rad) and the translation error divided by
    ``length_scale`` between two poses ``(4, 4)`` (the task's reach: so the figure does
    not depend on the unit)."""
    # ‖R − I‖_F = 2√2 |sin(θ/2)|: accurate for small θ, which is what a residual measures
    E = np.linalg.norm(A[:3, :3].T @ B[:3, :3] - np.eye(3))
    rot = 2 * np.arcsin(min(1.0, E / (2 * np.sqrt(2))))
    return float(max(rot, np.abs(A[:3, 3] - B[:3, 3]).max() / length_scale))


def verify_links(links, targets, length: float = 1.0) -> np.ndarray:
    """Verify binary links (two joints R, H, C or P) with the closure engine: every link is
    driven by its joint values at every position in one bulk evaluation
    (:func:`closure.open_chain_poses`), and the body pose is compared with the given one.

    Parameters
    ----------
    links : sequence of (types, lines, pitches, joint_values)
        ``types`` two letters of R, H, C, P (ground joint first); ``lines`` two Line (axes in
        the first position); ``pitches`` two floats (length / rad, used by H joints);
        ``joint_values`` (P, k): per position the driven coordinates in joint order, one
        per R or H joint (angle, rad), two per C joint (angle rad, slide length), one
        per P joint (slide, length).
    targets : array_like, shape (P, 4, 4)
        The body's given poses.
    length : float
        Positive length the translation errors are divided by.

    Returns
    -------
    numpy.ndarray, shape (len(links),)
        Each link's largest pose error over the positions (rad, or translation / length).
    """
    for v, lk in enumerate(links):
        types = lk[0] if isinstance(lk, (tuple, list)) and lk else None
        if not isinstance(types, str) or len(types) != 2 or any(t not in "RHCP" for t in types):
            raise SynthesisError(f"links[{v}]: types: expected two letters of R, H, C, P, got "
                                 f"{types!r}")
    return _verify_open(links, targets, length, "links")


def verify_open_chains(chains, targets, length: float = 1.0) -> np.ndarray:
    """Verify open chains of any number of screw joints (R, H, C, P) with the closure engine:
    every chain is driven by its joint values at every position in one bulk evaluation per
    string of joint letters (:func:`closure.open_chain_poses`), and its last link's pose is
    compared with the given one.

    Binary links with spherical or universal joints are verified through their
    :meth:`synthesis.BinaryLink.engine_chain` (an S as three revolutes, a U as two).

    Parameters
    ----------
    chains : sequence of (types, lines, pitches, joint_values)
        ``types`` k letters of R, H, C, P (ground joint first); ``lines`` k Line (axes in
        the first position); ``pitches`` k floats (length / rad, used by H joints);
        ``joint_values`` (P, m): the driven coordinates in joint order (one per R, H, P
        joint, two per C joint: angle rad, slide length).
    targets : array_like, shape (P, 4, 4)
        The body's given poses.
    length : float
        Positive length the translation errors are divided by.

    Returns
    -------
    numpy.ndarray, shape (len(chains),)
        Each chain's largest pose error over the positions (rad, or translation / length).
    """
    return _verify_open(chains, targets, length, "chains")


def _verify_open(chains, targets, length, name: str) -> np.ndarray:
    if not chains:
        return np.zeros(0)
    length = number(length, "length", positive=True)
    targets = _transform(targets, "targets", batch=True)
    groups = {}
    for v, (types, lines, pitches, jv) in enumerate(chains):
        if not isinstance(types, str) or not types or any(t not in "RHCP" for t in types) \
                or len(lines) != len(types) or len(pitches) != len(types):
            raise SynthesisError(f"{name}[{v}]: types: expected letters of R, H, C, P, one Line "
                                 f"and one pitch per joint, got {types!r}")
        jv = np.asarray(jv, float)
        if jv.shape != (targets.shape[0], len(types) + types.count("C")):
            raise SynthesisError(f"{name}[{v}]: joint_values: expected one row per target and "
                                 f"one column per driven coordinate, got shape {jv.shape}")
        groups.setdefault(types, []).append((v, jv))
    out = np.empty(len(chains))
    for types, group in groups.items():         # chains of one kind string: one evaluation
        idx = [v for v, _ in group]
        jv = _stacked([x for _, x in group])                                # (P, V, columns)
        col = np.cumsum([0] + [2 if t == "C" else 1 for t in types])
        q = np.zeros(jv.shape[:2] + (len(types), 2))
        for k, t in enumerate(types):
            q[..., k, :col[k + 1] - col[k]] = jv[..., col[k]:col[k + 1]]
        h = [[float(p) if t == "H" else 0.0 for t, p in zip(types, chains[v][2])] for v in idx]
        poses = _drive([types] * len(idx), [chains[v][1] for v in idx], q, h)
        out[idx] = _worst(poses[:, :, -1], targets, length)
    return out


def verify_driven(chains, targets, length: float) -> np.ndarray:
    """Pose errors of three-joint (or any k-joint) chains given as the dyad enumerations
    build them, driven in one bulk engine evaluation (:func:`closure.open_chain_poses`).

    Parameters
    ----------
    chains : list of (types, joints, values, pitches)
        ``types`` k letters of R, P, C, H, U (ground joint first, the same k for every
        chain); ``joints`` per joint a Line (R, P, C, H: the axis in position 1) or the
        U joint's ``(a, b, O)`` (its pin on the link before it, its pin on the link after
        it, its centre); ``values (P, k, 2)`` per position and joint (angle rad, slide
        length) of R, P, C, H (an H joint's slide follows from its angle) and (φ, θ) (rad)
        of a U; ``pitches`` k numbers or one (length / rad, read for H joints only).
    targets : array_like, shape (P, 4, 4)
        The body's given poses.
    length : float
        Length the translation errors are divided by.

    Returns
    -------
    numpy.ndarray, shape (len(chains),)
        Each chain's largest pose error over the positions (rad, or translation / length).
    """
    if not chains:
        return np.zeros(0)
    types = [c[0] for c in chains]
    h = np.array([c[3] for c in chains], float)
    return verify_frames(types, _joint_frames(types, [c[1] for c in chains]),
                         _stacked([c[2] for c in chains]), h[:, None] if h.ndim == 1 else h,
                         targets, length)


def verify_frames(types, frames, values, pitches, targets, length: float) -> np.ndarray:
    """:func:`verify_driven` of V chains given as arrays: their joint frames built by the
    caller (:func:`line_frames`, :func:`pin_frames`), no Line or tuple per joint.

    Parameters
    ----------
    types : str or list of str
        k letters of R, P, C, H, U (ground joint first): one string for every chain, or
        one per chain.
    frames : numpy.ndarray, shape (V, k, 4, 4)
        The joints' frames (exact rotations: not checked), as
        :func:`closure.open_chain_poses` takes them.
    values : numpy.ndarray, shape (P, V, k, 2)
        As :func:`verify_driven`'s values, per position and chain.
    pitches : array_like, broadcastable to (V, k)
        Length / rad, read for H joints only.
    targets, length
        As :func:`verify_driven`.

    Returns
    -------
    numpy.ndarray, shape (V,)
        Each chain's largest pose error over the positions (rad, or translation / length).
    """
    if not len(frames):
        return np.zeros(0)
    letters = [types] if isinstance(types, str) else types
    slide = np.frombuffer("".join(letters).encode(), "S1").reshape(len(letters), -1) == b"P"
    q = values.copy()
    q[..., 0] = np.where(slide, values[..., 1], values[..., 0])         # P: s is coordinate 0
    poses = open_chain_poses(types, frames, q, pitches, validate=False)
    return _worst(poses[:, :, -1], targets, length)
