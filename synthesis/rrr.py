"""RRR dyads through four positions, all 36 variants in one vectorised pass (seed 001,
Fig. 1; the method and the counting are in :mod:`synthesis.dyads`).

The three RR links through positions {1, j, n} are solved together by the core of
:func:`synthesis.rr.rr_links`; the 18 transition axes (3 triples × 3 transition
positions × 2 RR solutions, :func:`synthesis.rr.rotation_axis_between`), the joint 3
angles at the last position, the 36 chains' canonical lines and joint values are
arrays, the chains are verified in one bulk engine call from their joint frames
(:func:`synthesis.verify.verify_frames`) and the table is built from its columns.
"""
from __future__ import annotations

import functools

import numpy as np
import pandas as pd

from .dyads import DYAD_COLUMNS, _PITCH
from .rr import _angles_about, _dot, _norm, _rotation_axes, _rots, _rr_solve
from .verify import _first_slot, line_frames, verify_frames

__all__ = ["rrr_table"]

#: the RR triples {1, j, n}, the last position of each, and per triple the index of
#: positions 1–4 in it (the last position: −1)
_TRIPLES = ((1, 2, 3), (1, 2, 4), (1, 3, 4))
_LAST = (4, 3, 2)
_INDEX = np.array([[0, 1, 2, -1], [0, 1, -1, 2], [0, -1, 1, 2]])
#: the variants in table order: (triple, transition position, RR solution, arrangement)
_SHAPE = (3, 3, 2, 2)
_ORDER = np.array([f"RR through {t}; axis 1 carries position {s} to {last}"
                   for t, last in zip(_TRIPLES, _LAST) for s in t for _ in range(4)], object)
_MAIN = np.array([str(t) for t in _TRIPLES for _ in range(12)], object)
_TRANSITION = np.array([s for t in _TRIPLES for s in t for _ in range(4)])
_MECH = np.array(["a", "b"] * 18, object)
_RR = np.tile([0, 0, 1, 1], 9)
_JOINT = [f"j{k}_{c}" for k in (1, 2, 3) for c in ("ux", "uy", "uz", "x", "y", "z")]
_Q = [f"q{k + 1}_pos{p + 1}" for p in range(4) for k in range(3)]
_EXTRA = ["main_link", "main_positions", "transition_position"]
#: column order of the table (as rows built one by one gave it): a failed first row
#: starts with DYAD_COLUMNS, a regular one with its joints
#: the lines (direction, point) put in place of a failed triple's fixed and moving axes
_PLACEHOLDER = (np.array([[0.0, 0, 1], [0, 0, 0]]), np.array([[1.0, 0, 0], [0, 1, 0]]))
_FAILED_FIRST = DYAD_COLUMNS + ["mechanism", "rr"]
_REGULAR_FIRST = (["family", "variant", "order"]
                  + [f"j{k}_{c}" for k in (1, 2, 3)
                     for c in ("type", "ux", "uy", "uz", "x", "y", "z", "pitch")]
                  + ["residual", "reason", "arrangement", "transition", "mechanism", "rr"])


def rrr_table(screws: list, T: np.ndarray, reach: float) -> pd.DataFrame:
    """The 36 RRR variants through four positions (the table of :func:`enumerate_dyads`).

    Parameters
    ----------
    screws : list of three Screw
        S₁₂, S₁₃, S₁₄ (checked).
    T : numpy.ndarray, shape (4, 4, 4)
        The positions (the identity first, then the screws' matrices).
    reach : float
        The task's reach (length): residuals are relative to it.

    Returns
    -------
    pandas.DataFrame
        One row per variant (see :func:`synthesis.dyads.enumerate_dyads`); a degenerate
        variant has NaN geometry and its reason.
    """
    sol = _rr_solve([screws[0], screws[0], screws[1]], [screws[1], screws[2], screws[2]],
                    T[[1, 1, 2]], T[[2, 3, 3]], 1e-9)
    # a triple without links goes on with a placeholder (skew unit axes, zero angles):
    # its variants keep its reason, and the stacked solves stay finite
    failed = np.array([e is not None for e in sol.error])
    if failed.any():
        sol.fixed[failed], sol.moving[failed] = _PLACEHOLDER
        sol.fixed_angles[failed] = sol.moving_angles[failed] = 0.0
    # the 18 transitions, shape (3, 3, 2): triple, transition position s, RR solution
    gu, gp = sol.fixed[:, None, :, 0], sol.fixed[:, None, :, 1]        # (3, 1, 2, 3)
    wu, wp = sol.moving[:, None, :, 0], sol.moving[:, None, :, 1]
    Ts = T[np.array(_TRIPLES) - 1][:, :, None]                          # (3, 3, 1, 4, 4)
    Tl = T[np.array(_LAST) - 1][:, None, None]                          # (3, 1, 1, 4, 4)
    m3, m4 = (_turn(X, wu) for X in (Ts, Tl))
    m3, m4 = m3 / _norm(m3)[..., None], m4 / _norm(m4)[..., None]
    # axis 1: the pure rotation carrying axis 3 from its s-th to its last position
    ax, ap, phi, why = _rotation_axes(m3, _move(Ts, wp), m4, _move(Tl, wp))
    fa_s = np.swapaxes(sol.fixed_angles, 1, 2)                          # (3, 3, 2): [t, s, rr]
    # joint 3 at the last position: the rest of the body's motion about axis 3
    pre = _rots(ax, ap, phi) @ _rots(gu, gp, fa_s)
    beta = _angles_about(wu, (np.linalg.inv(pre) @ Tl)[..., :3, :3])
    # arrangement b: axis 1 rides on link A, turned back about axis 2 by its angle at s
    back = _rots(gu, gp, -fa_s)
    bu, bp = _turn(back, ax), _move(back, ap)
    # the chains' lines (3, 3, 2, 2, 3 joints, 3): a is axis 1, 2, 3; b is 2, axis 1, 3
    U, P = np.empty((2,) + _SHAPE + (3, 3))
    U[:, :, :, 0, 0], U[:, :, :, 0, 1], U[:, :, :, 0, 2] = ax, gu, wu
    U[:, :, :, 1, 0], U[:, :, :, 1, 1], U[:, :, :, 1, 2] = gu, bu, wu
    P[:, :, :, 0, 0], P[:, :, :, 0, 1], P[:, :, :, 0, 2] = ap, gp, wp
    P[:, :, :, 1, 0], P[:, :, :, 1, 1], P[:, :, :, 1, 2] = gp, bp, wp
    P = _canonical_points(U, P)
    jv = _joint_values(sol.fixed_angles, sol.moving_angles, fa_s, phi, beta)
    # status per variant: the triple's RR error, else the transition's
    reason = np.empty(_SHAPE, object)
    reason[...] = np.broadcast_to(why[..., None], _SHAPE)
    for t, e in enumerate(sol.error):
        if e is not None:
            reason[t] = e
    reason = reason.reshape(-1)
    ok = reason == ""
    U, P, jv = U.reshape(36, 3, 3), P.reshape(36, 3, 3), jv.reshape(36, 4, 3)
    residual = np.full(36, np.nan)
    idx = np.flatnonzero(ok)
    if idx.size:
        frames = line_frames(U[idx].reshape(-1, 3), P[idx].reshape(-1, 3), check=False)
        residual[idx] = verify_frames("RRR", frames.reshape(-1, 3, 4, 4),
                                      _first_slot(np.swapaxes(jv[idx], 0, 1)), 0.0, T, reach)
    return _table(ok, reason, U, P, jv, residual)


def _turn(T, u):
    """Directions ``u (..., 3)`` turned by the rotation blocks of ``T (..., 4, 4)``."""
    return (T[..., :3, :3] @ u[..., None])[..., 0]


def _move(T, p):
    """Points ``p (..., 3)`` moved by the rigid transforms ``T (..., 4, 4)``."""
    return (T[..., :3, :3] @ p[..., None])[..., 0] + T[..., :3, 3]


def _canonical_points(U, P):
    """Canonical points of chains of lines (as :meth:`synthesis.screw.Line.canonical`, joint
    by joint): the first joint's foot from the origin, each next the foot of its common
    normal with the previous joint (parallel: the foot of the perpendicular from the
    previous joint's point).  ``U, P (..., k, 3)``: unit directions and points (length)."""
    out = np.empty(np.broadcast_shapes(U.shape, P.shape))
    u = U[..., 0, :]
    out[..., 0, :] = P[..., 0, :] + _dot(0.0 - P[..., 0, :], u)[..., None] * u
    for k in range(1, U.shape[-2]):
        u, v, w = U[..., k - 1, :], U[..., k, :], out[..., k - 1, :] - P[..., k, :]
        b = _dot(u, v)
        den = 1 - b * b
        d, e = _dot(u, w), _dot(v, w)
        par = den < 1e-12
        t = np.where(par, e, (e - b * d) / np.where(par, 1.0, den))
        out[..., k, :] = P[..., k, :] + t[..., None] * v
    return out


def _joint_values(fa, ma, fa_s, phi, beta):
    """Joint values (rad) ``(3, 3, 2, 2, 4, 3)`` of the variants at positions 1–4: on the
    triple the RR link's angles (axis 1 at zero), at the last position axis 1 turned by
    ``phi``, the RR's fixed joint at its angle at s and joint 3 at ``beta``; arrangement
    b swaps joints 1 and 2.  ``fa, ma (3, 2, 3)``: the links' angles at the triple's
    positions; ``fa_s, phi, beta (3, 3, 2)``."""
    at = (np.arange(3)[:, None, None], np.arange(2)[:, None], np.maximum(_INDEX, 0)[:, None])
    last = (_INDEX == -1)[:, None, None, :]                              # (3, 1, 1, 4)
    f_s, ph, be = fa_s[..., None], phi[..., None], beta[..., None]      # (3, 3, 2, 1)
    out = np.zeros((3, 3, 2, 2, 4, 3))                                  # arrangement a, b
    out[:, :, :, 0, :, 1] = out[:, :, :, 1, :, 0] = np.where(last, f_s, fa[at][:, None])
    out[:, :, :, 0, :, 0] = out[:, :, :, 1, :, 1] = np.where(last, ph, 0.0)   # axis 1
    out[..., 2] = np.where(last, be, ma[at][:, None])[:, :, :, None]
    return out


@functools.lru_cache(maxsize=1)
def _constant_strings() -> dict:
    """The table's string columns that every task shares (family, order, arrangement,
    transition, joint types, mechanism) and those of a table whose variants are all
    regular (reason, main_link, main_positions), as the pandas arrays its constructor
    infers from them: built once (each table gets copies)."""
    n = len(_ORDER)
    cols = {"family": np.full(n, "RRR", object), "order": _ORDER, "arrangement": _MECH,
            "transition": np.full(n, "RR", object), "mechanism": _MECH,
            "reason": np.full(n, "", object), "main_link": np.full(n, "RR", object),
            "main_positions": _MAIN}
    cols.update({f"j{k}_type": np.full(n, "R", object) for k in (1, 2, 3)})
    return {c: pd.Series(v).array for c, v in cols.items()}


def _table(ok, reason, U, P, jv, residual) -> pd.DataFrame:
    """The table from the variants' columns (order and dtypes as :func:`pandas.DataFrame`
    gives them for the rows one by one: failed rows have NaN geometry and no
    ``main_link … q`` entries; ``reason`` is empty where ``ok``), the strings already the
    arrays the constructor would store (its string dtype)."""
    n = len(ok)
    const = _constant_strings()
    cols = {c: a.copy() for c, a in const.items()}
    if not ok.all():                # the failed variants' strings, as the constructor infers them
        string, nan = const["family"].dtype, np.full(n, np.nan, object)
        cols.update(reason=pd.array(reason, dtype=string),
                    main_link=pd.array(np.where(ok, "RR", nan), dtype=string),
                    main_positions=pd.array(np.where(ok, _MAIN, nan), dtype=string))
    cols["variant"] = np.arange(1, n + 1)
    geo = np.concatenate([U, P], -1).reshape(n, 18)                     # per joint u, p
    geo[~ok] = np.nan
    for k in (1, 2, 3):
        cols[f"j{k}_pitch"] = np.full(n, _PITCH["R"])
    cols.update(zip(_JOINT, geo.T))
    cols.update(residual=residual, rr=_RR.copy())
    if ok.any():
        cols["transition_position"] = _TRANSITION.copy() if ok.all() else \
            np.where(ok, _TRANSITION, np.nan)
        q = jv.reshape(n, 12).copy()
        q[~ok] = np.nan
        cols.update(zip(_Q, q.T))
    order = (_REGULAR_FIRST if ok[0] else _FAILED_FIRST) + (_EXTRA + _Q if ok.any() else [])
    return pd.DataFrame({c: cols[c] for c in order}, copy=False)

