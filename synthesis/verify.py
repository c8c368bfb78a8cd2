"""Verification of synthesised chains by the closure engine, shared by every binary-link
and dyad module of the package (it imports none of them).

Every synthesised open chain hangs from the ground of one :class:`closure.Mechanism`,
is driven to its joint values at all positions in one batched call, and each body pose
(or, for sphere-ended chains, the sphere centre) is compared with the given one.
Errors are rotations (rad) or translations divided by a length (the task's reach).
"""
from __future__ import annotations

import functools

import numpy as np

from closure import Mechanism, transform
from closure.frames import cross, log_so3

from .errors import SynthesisError
from .screw import Line
from .validate import array, line, number
from .validate import transform as _transform

__all__ = ["in_chunks", "chain_mechanism", "verify_chain", "verify_chains", "verify_points", "pose_error",
           "pose_errors", "verify_links", "verify_open_chains"]


#: chains per engine mechanism in the verifications (measured: a few dozen is fastest)
VERIFY_CHUNK = 32


def in_chunks(verify):
    """Run a verification ``verify(chains, targets, length)`` over chunks of
    :data:`VERIFY_CHUNK` chains, one engine mechanism each, and join the errors: the
    engine's batched solve carries dense (positions, coordinates, inputs) arrays,
    quadratic in the chains of one mechanism, and the chains are independent (same
    poses, same errors)."""
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


def _frames_of(lines) -> np.ndarray:
    """Joint frames (N, 4, 4) with Z along each line at its point, in one vectorised pass."""
    z = np.array([ln.direction for ln in lines])
    a = np.where((np.abs(z[:, 0]) < 0.9)[:, None], [1.0, 0, 0], [0, 1.0, 0])
    x = a - np.sum(a * z, 1, keepdims=True) * z
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    return transform(np.stack([x, cross(z, x), z], -1), np.array([ln.point for ln in lines]))


def _hang_chains(m: Mechanism, chains, n_links: int):
    """Hang every chain (types, lines, ...) from the ground of ``m``: links A{v}, B{v}[, body{v}],
    joints v{v}j{k} as inputs; frames built in one pass (exact rotations, not re-validated)."""
    frames = _frames_of([ln for c in chains for ln in c[1][:n_links]])
    f = 0
    for v, chain in enumerate(chains):
        types = chain[0]
        links = ["ground", f"A{v}", f"B{v}", f"body{v}"][:n_links + 1]
        for name in links[1:]:
            m.add_link(name)
        for k in range(n_links):
            m.add_joint(f"v{v}j{k + 1}", types[k], links[k], links[k + 1], at=frames[f],
                        validate=False)
            m.add_input(f"v{v}j{k + 1}")
            f += 1


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


@in_chunks
def verify_chains(chains, targets, length: float = 1.0) -> np.ndarray:
    """Verify many synthesised chains at once: all of them hang from the ground of one
    engine mechanism, driven by their joint values at every position in one batched call.

    Parameters
    ----------
    chains : list of (types, lines, joint_values (P, 3))
    targets : (P, 4, 4) the given poses

    Returns
    -------
    numpy.ndarray (len(chains),): each chain's largest pose error (rad, or translation /
    ``length``).
    """
    if not chains:
        return np.zeros(0)
    m = Mechanism()
    _hang_chains(m, chains, 3)
    x = np.concatenate([np.asarray(jv, float) for _, _, jv in chains], 1)
    pose = m.solve(x)
    link = pose.kinematics(twists=False)["link"]
    bodies = link[:, [m.links.index(f"body{v}") for v in range(len(chains))]]   # (P, V, 4, 4)
    rot, pos = pose_errors(bodies, np.asarray(targets, float)[:, None], length)
    return np.maximum(rot.max(0), pos.max(0))


@in_chunks
def verify_points(chains, targets, length: float = 1.0) -> np.ndarray:
    """Verify sphere-ended chains: the two joints before the sphere are driven by the engine
    (all chains in one mechanism, one batched call) and the sphere centre's position is
    compared with its given positions (the sphere leaves the orientation free).

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
    m = Mechanism()
    frames = _frames_of([ln for c in chains for ln in c[1][:2]])
    for v, c in enumerate(chains):
        types = c[0]
        pitches = c[4] if len(c) > 4 else None
        links = ["ground", f"A{v}", f"B{v}"]
        m.add_link(links[1])
        m.add_link(links[2])
        for k in range(2):
            p = None
            if types[k] == "H":
                p = None if pitches is None else float(pitches[k])
                if p is None or not np.isfinite(p):
                    raise SynthesisError(f"chains[{v}]: pitches: joint {k + 1} is helical; "
                                         f"expected a finite pitch, got {p}")
            m.add_joint(f"v{v}j{k + 1}", types[k], links[k], links[k + 1], at=frames[2 * v + k],
                        validate=False, pitch=p)
            m.add_input(f"v{v}j{k + 1}")
    pose = m.solve(np.concatenate([np.asarray(c[2], float) for c in chains], 1))
    T = np.asarray(targets, float)
    err = []
    for v, c in enumerate(chains):
        centre = c[3]
        got = np.atleast_2d(pose.point(f"B{v}", centre))
        want = T[:, :3, :3] @ centre + T[:, :3, 3]
        err.append(np.linalg.norm(got - want, axis=1).max() / length)
    return np.array(err)


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
    """Verify binary links (two joints R, H, C or P) with the closure engine: every link hangs
    from the ground of one mechanism, driven by its joint values at every position in one
    batched call, and the body pose is compared with the given one.

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
    every chain hangs from the ground of one mechanism, driven by its joint values at every
    position in one batched call, and its last link's pose is compared with the given one.

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
    m = Mechanism()
    frames = _frames_of([ln for ch in chains for ln in ch[1]])
    cols, f, last = [], 0, []
    for v, (types, lines, pitches, jv) in enumerate(chains):
        if not isinstance(types, str) or not types or any(t not in "RHCP" for t in types) \
                or len(lines) != len(types) or len(pitches) != len(types):
            raise SynthesisError(f"{name}[{v}]: types: expected letters of R, H, C, P, one Line "
                                 f"and one pitch per joint, got {types!r}")
        names = ["ground"] + [f"v{v}L{k + 1}" for k in range(len(types))]
        for k, t in enumerate(types):
            m.add_link(names[k + 1])
            jn = f"v{v}j{k + 1}"
            m.add_joint(jn, t, names[k], names[k + 1], at=frames[f], validate=False,
                        pitch=float(pitches[k]) if t == "H" else None)
            f += 1
            m.add_input(jn, 0)
            if t == "C":
                m.add_input(jn, 1)
        jv = np.asarray(jv, float)
        if jv.shape != (targets.shape[0], sum(2 if t == "C" else 1 for t in types)):
            raise SynthesisError(f"{name}[{v}]: joint_values: expected one row per target and "
                                 f"one column per driven coordinate, got shape {jv.shape}")
        cols.append(jv)
        last.append(names[-1])
    pose = m.solve(np.concatenate(cols, 1), continuation=False)
    link = pose.kinematics(twists=False)["link"]
    bodies = link[:, [m.links.index(n) for n in last]]
    rot, pos = pose_errors(bodies, targets[:, None], length)
    return np.maximum(rot.max(0), pos.max(0))
