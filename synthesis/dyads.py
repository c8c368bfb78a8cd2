"""Dyads by finite positions (seed 001), the family table's decompositions: RRR by four
positions, RRS by six and PRS by five, enumerated and verified by the engine
(:mod:`synthesis.verify`).

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

RRS (seed 001, Fig. 2): the RS link ("2–3") works through positions 1–4 with
joint 1 locked; the two later positions are reached by turning about axis 1
(joint 2 locked at its value in the transition position s, the sphere free),
so axis 1 is the axis of the circle through C_s, C_5, C_6.  PRS: the slide
of the prismatic joint 1 carries C from C_s to C_5.
"""
from __future__ import annotations

import itertools

import numpy as np
import pandas as pd

from closure.frames import cross

from .errors import SynthesisError
from .rr import _angle_about, _rot, rotation_axis_between, rr_links
from .rs import rs_links
from .screw import Line
from .validate import screws as _screws, task_scale
# chain_mechanism, verify_chain, verify_chains: re-exported (they lived here before synthesis.verify)
from .verify import chain_mechanism, verify_chain, verify_chains, verify_points  # noqa: F401

__all__ = ["enumerate_dyads", "rrr_dyads", "verify_chain", "verify_chains", "chain_mechanism", "DYAD_COLUMNS"]

DYAD_COLUMNS = (["family", "variant", "order"]
                + [f"j{k}_{c}" for k in (1, 2, 3)
                   for c in ("type", "ux", "uy", "uz", "x", "y", "z")]
                + ["residual"])


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
    return pd.DataFrame(sphere_dyads("RRS", _check_screws(screws, 6, "RRS")))


def prs_dyads(screws) -> pd.DataFrame:
    """PRS dyads through five positions (RS link through 1–4, the slide carries the sphere
    centre to position 5); see :mod:`synthesis.rs`."""
    return pd.DataFrame(sphere_dyads("PRS", _check_screws(screws, 5, "PRS")))


def circle_axis(p1, p2, p3):
    """Axis (Line) of the circle through three points, and the angles of p2, p3 about it
    from p1."""
    p1, p2, p3 = (np.asarray(p, float) for p in (p1, p2, p3))
    n = cross(p2 - p1, p3 - p1)
    # collinear to round-off: relative to the triangle's size and the coordinates' size
    size = max(np.abs(p2 - p1).max(), np.abs(p3 - p1).max(), np.abs(p3 - p2).max())
    if np.linalg.norm(n) <= 1e-12 * size * max(size, np.abs([p1, p2, p3]).max()):
        raise SynthesisError("axis 1: the later positions of the sphere centre are collinear "
                             "or coincide; no circle through them")
    n /= np.linalg.norm(n)
    A = np.array([2 * (p2 - p1), 2 * (p3 - p1), n])
    b = np.array([p2 @ p2 - p1 @ p1, p3 @ p3 - p1 @ p1, n @ p1])
    O = np.linalg.solve(A, b)
    u = p1 - O
    angs = [float(np.arctan2(cross(u, p - O) @ n, u @ (p - O))) for p in (p2, p3)]
    return Line(n, O).canonical(), angs


def sphere_dyads(family, screws):
    """RRS (six positions) or PRS (five positions) dyads as rows for the variant table."""
    n_pos = 6 if family == "RRS" else 5
    T, size = _task(screws)
    links = rs_links(np.array(T[:4]))
    rows, chains = [], []
    variant = 0
    for s in (1, 2, 3, 4):
        later = list(range(5, n_pos + 1))
        order = f"RS through (1, 2, 3, 4); joint 1 carries position {s} to {tuple(later)}"
        for m_i, link in enumerate(links):
            variant += 1
            Cs = [t[:3, :3] @ link.centre + t[:3, 3] for t in T]
            ax2 = link.axis
            try:
                if family == "RRS":
                    ax1, angs = circle_axis(Cs[s - 1], Cs[4], Cs[5])
                    q1 = [0.0] * 4 + angs
                    types = "RRS"
                else:
                    d = Cs[4] - Cs[s - 1]
                    if np.linalg.norm(d) < 1e-12 * size:
                        raise SynthesisError("prismatic axis: the sphere centre does not move "
                                             f"from position {s} to 5")
                    ax1 = Line(d / np.linalg.norm(d), Cs[s - 1]).canonical()
                    q1 = [0.0] * 4 + [float(np.linalg.norm(d))]
                    types = "PRS"
            except SynthesisError as e:
                row = _row(family, variant, order, family, [ax2, ax2, ax2], np.nan)
                row["reason"] = str(e)
                rows.append(row)
                continue
            q2 = list(link.angles[:4]) + [link.angles[s - 1]] * (n_pos - 4)
            centre = Line(np.array([0, 0, 1.0]), link.centre)
            lines = [ax1, ax2.canonical(ax1), centre]
            jv = np.c_[q1, q2]
            row = _row(family, variant, order, types, lines, np.nan, member=m_i,
                       joint_values=np.c_[jv, np.full(n_pos, np.nan)])
            for c in ("ux", "uy", "uz"):
                row[f"j3_{c}"] = np.nan                        # a sphere has no axis
            rows.append(row)
            chains.append((len(rows) - 1, (types[:2], lines[:2], jv, link.centre)))
    res = verify_points([c for _, c in chains], np.array(T), size)
    for (i, _), r in zip(chains, res):
        rows[i]["residual"] = float(r)
    return rows


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
