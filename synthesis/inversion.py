"""Kinematic inversion of a synthesised chain (seed 001: e.g. RPC → CPR).

Fixing the body and letting the old ground move reverses the chain: joint k
becomes joint 4 − k, the axes (given in the first position, where body and
ground frames coincide) stay where they are, the new "positions" are the
inverse displacements S₁ⱼ⁻¹, and the joint values change sign.
"""
from __future__ import annotations

import numpy as np

from .screw import Line, Screw

__all__ = ["invert_chain", "inverse_screws"]


def inverse_screws(screws) -> list[Screw]:
    """The displacements of the old ground seen from the body: ``S_1j⁻¹``."""
    return [Screw.from_matrix(np.linalg.inv(s.matrix())) for s in screws]


def invert_chain(row) -> dict:
    """The inverse of a synthesised dyad (a row of :func:`enumerate_dyads` or a dict).

    Returns a dict with the same column names: joint types and axes in reverse
    order (re-canonicalised from the new ground joint; a sphere keeps its centre),
    ``family`` reversed (e.g. PRS → SRP), and the joint values ``q{k}_pos{p}``
    reversed and negated (a sphere's entry stays undefined).
    """
    get = row.__getitem__
    types = [get(f"j{k}_type") for k in (1, 2, 3)][::-1]
    pts = [np.array([get(f"j{k}_x"), get(f"j{k}_y"), get(f"j{k}_z")]) for k in (1, 2, 3)][::-1]
    dirs = [np.array([get(f"j{k}_ux"), get(f"j{k}_uy"), get(f"j{k}_uz")]) for k in (1, 2, 3)][::-1]
    # a sphere keeps its centre; an axis is re-canonicalised from the joint before it
    # (the foot of the common normal, or of the perpendicular from a sphere's centre)
    canon, prev = [], None
    for t, p, d in zip(types, pts, dirs):
        if t == "S":
            canon.append((np.full(3, np.nan), p))
            prev = p
            continue
        ln = Line(d, p)
        if prev is None:
            ln = ln.canonical()
        elif isinstance(prev, Line):
            ln = ln.canonical(prev)
        else:
            ln = Line(ln.direction, ln.foot_from(prev))
        canon.append((ln.direction, ln.point))
        prev = ln
    out = {"family": "".join(types), "variant": get("variant"),
           "order": f"inverse of: {get('order')}"}
    for k, (t, (d, p)) in enumerate(zip(types, canon), start=1):
        out[f"j{k}_type"] = t
        out[f"j{k}_ux"], out[f"j{k}_uy"], out[f"j{k}_uz"] = d
        out[f"j{k}_x"], out[f"j{k}_y"], out[f"j{k}_z"] = p
    p = 1
    while True:
        try:
            vals = [get(f"q{k}_pos{p}") for k in (1, 2, 3)]
        except KeyError:
            break
        for k, v in enumerate(vals[::-1], start=1):
            out[f"q{k}_pos{p}"] = -v
        p += 1
    return out
