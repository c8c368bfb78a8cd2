"""Dyads by finite positions (seed 001): RRR by four positions, enumerated and verified
(RRS and PRS: :mod:`synthesis.rs`).

RRR (seed 001, Fig. 1).  An RR link ("2–3") is synthesised through three of
the positions (always position 1 and two of 2, 3, 4: the screws are given from
position 1).  The fourth ("last") position is reached from one of those three
(the "transition" position s) by turning about axis 1 with joint 2 locked
(and joint 3 free): axis 1 is the pure rotation that carries axis 3 from its
s-th to its last position (L ⊥ (M_last − M_s), L ⊥ (Q_last − Q_s); the seed prints (Q₁ − Q₃) for (Q₄ − Q₃), a misprint).

Counting: 3 choices of the RR triple {1, j, n} × 3 choices of the transition
position s ∈ {1, j, n} × 2 RR solutions × 2 mechanisms = 36 variants.
Mechanism "a" (Fig. 1a) is ground –1– A –2– B –3– body with axis 1 fixed in
the ground; mechanism "b" (Fig. 1b) is ground –2– A –1– B –3– body, where axis
1 rides on the link turned by joint 2, so its position-1 location is axis 1
turned back about axis 2 by joint 2's angle at position s.

Every variant is verified with the closure engine: all synthesised open chains
hang from the ground of one :class:`closure.Mechanism`, are driven to their
joint values at all positions in one batched call, and each body pose is
compared with the given pose.
"""
from __future__ import annotations

import itertools

import numpy as np
import pandas as pd

from closure import Mechanism, transform
from closure.frames import cross, log_so3

from .errors import SynthesisError
from .rr import _angle_about, _rot, rotation_axis_between, rr_links
from .screw import Line
from .validate import array, line, number, screws as _screws, task_scale
from .validate import transform as _transform

__all__ = ["enumerate_dyads", "rrr_dyads", "verify_chain", "verify_chains", "chain_mechanism", "DYAD_COLUMNS"]

DYAD_COLUMNS = (["family", "variant", "order"]
                + [f"j{k}_{c}" for k in (1, 2, 3)
                   for c in ("type", "ux", "uy", "uz", "x", "y", "z")]
                + ["residual"])


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
            raise SynthesisError("chain_mechanism: spherical joints are verified through their "
                                 "rotation, not driven; use verify_chain with rotations")
        m.add_joint(f"j{k + 1}", t, links[k], links[k + 1], at=_frame_of(axis))
        m.add_input(f"j{k + 1}")
    return m


def _pose_errors(A, B, length):
    rot = np.linalg.norm(log_so3(np.swapaxes(A[..., :3, :3], -1, -2) @ B[..., :3, :3]), axis=-1)
    pos = np.linalg.norm(A[..., :3, 3] - B[..., :3, 3], axis=-1)
    return rot, pos / length


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
    rot, pos = _pose_errors(bodies, np.asarray(targets, float)[:, None], length)
    return np.maximum(rot.max(0), pos.max(0))


def verify_points(chains, targets, length: float = 1.0) -> np.ndarray:
    """Verify sphere-ended chains: the two joints before the sphere are driven by the engine
    (all chains in one mechanism, one batched call) and the sphere centre's position is
    compared with its given positions (the sphere leaves the orientation free).

    chains : list of (types (2), lines (2), joint_values (P, 2), centre (3,))
    Returns each chain's largest centre error divided by ``length``.
    """
    if not chains:
        return np.zeros(0)
    m = Mechanism()
    _hang_chains(m, chains, 2)
    pose = m.solve(np.concatenate([np.asarray(jv, float) for _, _, jv, _ in chains], 1))
    T = np.asarray(targets, float)
    err = []
    for v, (_, _, _, c) in enumerate(chains):
        got = np.atleast_2d(pose.point(f"B{v}", c))
        want = T[:, :3, :3] @ c + T[:, :3, 3]
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


def _check_screws(screws, n, family):
    out = _screws(screws, "screws")
    if len(out) != n - 1:
        raise SynthesisError(f"screws: {family} expected {n - 1} screws S_12 … S_1{n} for {n} "
                             f"positions, got {len(out)}")
    return out


def _task(screws):
    """Positions (the identity first) and the task's reach (residuals are relative to it)."""
    T = [np.eye(4)] + [s.matrix() for s in screws]
    _, _, reach = task_scale(T, [s.axis for s in screws], [s.point for s in screws])
    return T, reach


def rrr_dyads(screws) -> pd.DataFrame:
    """All RRR dyads through four positions (see the module notes for the 36 variants).

    Parameters
    ----------
    screws : sequence of three Screw
        S₁₂, S₁₃, S₁₄.
    """
    screws = _check_screws(screws, 4, "RRR")
    T, size = _task(screws)                                   # T[k]: position k+1 from 1
    rows, chains = [], []
    variant = 0
    for triple in ((1, 2, 3), (1, 2, 4), (1, 3, 4)):
        last = ({1, 2, 3, 4} - set(triple)).pop()
        j, n = triple[1], triple[2]
        try:
            links = rr_links(screws[j - 2], screws[n - 2])
            err = None
        except SynthesisError as e:
            links, err = [], str(e)
        for s in triple:
            order = f"RR through {triple}; axis 1 carries position {s} to {last}"
            if err is not None:
                for rr_i, mech in itertools.product((0, 1), "ab"):
                    variant += 1
                    rows.append(_failed_row(variant, order, mech, rr_i, err))
                continue
            for rr_i, link in enumerate(links):
                angles = {1: 0, j: 1, n: 2}
                fa = {k: link.fixed_angles[i] for k, i in angles.items()}
                ma = {k: link.moving_angles[i] for k, i in angles.items()}
                M, Q = link.moving_axis.direction, link.moving_axis.point
                Ts, Tl = T[s - 1], T[last - 1]
                try:
                    ax1, phi = rotation_axis_between(Ts[:3, :3] @ M, Ts[:3, :3] @ Q + Ts[:3, 3],
                                                     Tl[:3, :3] @ M, Tl[:3, :3] @ Q + Tl[:3, 3])
                except SynthesisError as e:
                    for mech in "ab":
                        variant += 1
                        rows.append(_failed_row(variant, order, mech, rr_i, str(e)))
                    continue
                # joint 3 at the last position: the rest of the body's motion about axis 3
                pre = _rot(ax1, phi) @ _rot(link.fixed_axis, fa[s])
                beta = _angle_about(link.moving_axis, np.linalg.inv(pre) @ Tl)
                for mech in "ab":
                    variant += 1
                    if mech == "a":
                        lines = [ax1, link.fixed_axis, link.moving_axis]
                        vals = {k: (0.0, fa[k], ma[k]) for k in triple}
                        vals[last] = (phi, fa[s], beta)
                    else:
                        ax1b = ax1.transformed(_rot(link.fixed_axis, -fa[s]))
                        lines = [link.fixed_axis, ax1b, link.moving_axis]
                        vals = {k: (fa[k], 0.0, ma[k]) for k in triple}
                        vals[last] = (fa[s], phi, beta)
                    lines = _canonical_chain(lines)
                    jv = np.array([vals[k] for k in (1, 2, 3, 4)])
                    rows.append(_row("RRR", variant, order, "RRR", lines, np.nan,
                                     mechanism=mech, rr=rr_i, joint_values=jv))
                    chains.append((len(rows) - 1, ("RRR", lines, jv)))
    res = verify_chains([c for _, c in chains], np.array(T), size)
    for (i, _), r in zip(chains, res):
        rows[i]["residual"] = float(r)
    return pd.DataFrame(rows)


def _canonical_chain(lines):
    out = [lines[0].canonical()]
    for ln in lines[1:]:
        out.append(ln.canonical(out[-1]))
    return out


def _row(family, variant, order, types, lines, residual, **extra):
    row = {"family": family, "variant": variant, "order": order}
    for k, (t, ln) in enumerate(zip(types, lines), start=1):
        row[f"j{k}_type"] = t
        row[f"j{k}_ux"], row[f"j{k}_uy"], row[f"j{k}_uz"] = ln.direction
        row[f"j{k}_x"], row[f"j{k}_y"], row[f"j{k}_z"] = ln.point
    row["residual"] = residual
    row["reason"] = ""
    jv = extra.pop("joint_values", None)
    row.update(extra)
    if jv is not None:
        for p in range(jv.shape[0]):
            for k in range(jv.shape[1]):
                row[f"q{k + 1}_pos{p + 1}"] = jv[p, k]
    return row


def _failed_row(variant, order, mech, rr_i, reason):
    row = {c: np.nan for c in DYAD_COLUMNS}
    row.update(family="RRR", variant=variant, order=order, mechanism=mech, rr=rr_i,
               reason=reason, j1_type="R", j2_type="R", j3_type="R")
    return row


def rrs_dyads(screws) -> pd.DataFrame:
    """RRS dyads through six positions (RS link through 1–4, axis 1 from the circle of the
    sphere centre's later positions); see :mod:`synthesis.rs`."""
    from .rs import sphere_dyads
    return pd.DataFrame(sphere_dyads("RRS", _check_screws(screws, 6, "RRS")))


def prs_dyads(screws) -> pd.DataFrame:
    """PRS dyads through five positions (RS link through 1–4, the slide carries the sphere
    centre to position 5); see :mod:`synthesis.rs`."""
    from .rs import sphere_dyads
    return pd.DataFrame(sphere_dyads("PRS", _check_screws(screws, 5, "PRS")))


FAMILY_SOLVERS = {"RRR": rrr_dyads, "RRS": rrs_dyads, "PRS": prs_dyads}


def enumerate_dyads(family: str, screws) -> pd.DataFrame:
    """Every variant the method yields for ``family`` through the given positions.

    Parameters
    ----------
    family : str
        A dyad family of :func:`families` that is implemented (``"RRR"``).
    screws : sequence of Screw
        S₁₂ … S₁N, the displacements from position 1.

    Returns
    -------
    pandas.DataFrame
        Columns ``family, variant, order``, per joint k = 1, 2, 3 (1 at the
        ground, 3 at the body) ``j{k}_type, j{k}_ux, j{k}_uy, j{k}_uz, j{k}_x,
        j{k}_y, j{k}_z`` (axes in the first position, canonical points),
        ``residual`` (largest pose error when the engine drives the dyad through
        all positions: rad, or length relative to the task's reach, the size of
        its coordinates),
        ``reason`` (why a variant degenerated, else empty), ``mechanism``
        (Fig. 1a/1b), ``rr`` (which RR solution) and the joint values
        ``q{k}_pos{p}`` (rad) at every position.

    Raises
    ------
    SynthesisError
        An unknown or unimplemented family, or screws that are not a sequence of
        the right number of :class:`Screw`.
    """
    if not isinstance(family, str):
        raise SynthesisError(f"family: expected a family name such as 'RRR', got "
                             f"{type(family).__name__} {family!r}")
    fam = family.upper()
    if fam not in FAMILY_SOLVERS:
        from .families import families
        known = families()
        if fam in set(known.family):
            raise SynthesisError(f"family {family!r}: in seed 001's table but not implemented yet; "
                                 f"implemented: {', '.join(FAMILY_SOLVERS)}")
        raise SynthesisError(f"family {family!r}: unknown; expected one of "
                             f"{', '.join(sorted(set(known.family)))}")
    return FAMILY_SOLVERS[fam](_screws(screws, "screws"))
