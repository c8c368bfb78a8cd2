"""Kinematic inversion of a synthesised chain (seed 001: e.g. RPC → CPR).

Fixing the body and letting the old ground move reverses the chain: joint k
becomes joint 4 − k, the axes (given in the first position, where body and
ground frames coincide) stay where they are, the new "positions" are the
inverse displacements S₁ⱼ⁻¹, and the joint values change sign.
"""
from __future__ import annotations

import numpy as np

from .errors import SynthesisError
from .screw import Line, Screw
from .validate import array, screws as _screws, vec3

__all__ = ["invert_chain", "inverse_screws"]


def inverse_screws(screws) -> list[Screw]:
    """The displacements of the old ground seen from the body: ``S_1j⁻¹``.

    Parameters
    ----------
    screws : sequence of Screw

    Raises
    ------
    SynthesisError
        If ``screws`` is not a sequence of :class:`Screw`.
    """
    screws = _screws(screws, "screws")
    return [Screw.from_matrix(np.linalg.inv(s.matrix())) for s in screws]


def invert_chain(row) -> dict:
    """The inverse of a synthesised dyad (a row of :func:`enumerate_dyads` or a dict).

    Parameters
    ----------
    row : pandas.Series or dict
        A regular variant (``reason`` empty): failed rows have no axes to invert.

    Returns a dict with the same column names: joint types and axes in reverse
    order (re-canonicalised from the new ground joint; a sphere keeps its centre),
    ``family`` reversed (e.g. PRS → SRP), and the joint values ``q{k}_pos{p}``
    reversed and negated (a sphere's entry stays undefined).
    """
    if not hasattr(row, "__getitem__") or isinstance(row, (str, bytes)):
        raise SynthesisError(f"row: expected a row of enumerate_dyads (a Series or dict), got "
                             f"{type(row).__name__}")

    def get(key):
        try:
            return row[key]
        except (KeyError, IndexError, TypeError):
            raise SynthesisError(f"row: missing column {key!r} (expected a row of "
                                 "enumerate_dyads)") from None

    try:
        reason = row["reason"]
    except (KeyError, IndexError, TypeError):
        reason = ""
    if isinstance(reason, str) and reason:
        raise SynthesisError(f"row: variant {row['variant'] if 'variant' in row else '?'} "
                             f"failed ({reason}); a failed variant cannot be inverted")
    types = [get(f"j{k}_type") for k in (1, 2, 3)][::-1]
    for k, t in enumerate(types[::-1], start=1):
        if not isinstance(t, str) or t not in ("R", "P", "C", "H", "U", "S"):
            raise SynthesisError(f"row: j{k}_type must be a joint letter R, P, C, H, U or S, "
                                 f"got {t!r} (a failed variant cannot be inverted)")
    pts = [vec3([get(f"j{k}_x"), get(f"j{k}_y"), get(f"j{k}_z")], f"row j{k}_x, j{k}_y, j{k}_z")
           for k in (1, 2, 3)][::-1]
    dirs = [np.array([get(f"j{k}_ux"), get(f"j{k}_uy"), get(f"j{k}_uz")], dtype=float)
            if t == "S" else
            array([get(f"j{k}_ux"), get(f"j{k}_uy"), get(f"j{k}_uz")],
                  f"row j{k}_ux, j{k}_uy, j{k}_uz", (3,))
            for k, t in zip((3, 2, 1), types)]
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
            vals = [row[f"q{k}_pos{p}"] for k in (1, 2, 3)]
        except (KeyError, IndexError):
            break
        for k, v in enumerate(vals[::-1], start=1):
            out[f"q{k}_pos{p}"] = -v
        p += 1
    return out
