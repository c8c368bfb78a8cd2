"""Complete solution sets at the maximal number of positions, and least-squares synthesis
through more positions than that.

:func:`complete_dyads` returns **every** real solution of a chain's finite-position
synthesis at N_max, with the number of solutions over the complex numbers, in the table
layout of :func:`synthesis.enumerate_dyads`:

=====  =====  =========  ==========================================================
chain  N_max  solutions  method (all solutions, no starting guesses)
=====  =====  =========  ==========================================================
RR     3      2          factorisation of the Bennett motion polynomial
                         (:func:`synthesis.rr_links`; Suh; Brunnthaler, Schröcker & Husty)
CC     5      6          directions: the spherical five-orientation Burmester problem
                         ``gᵀ (R_j − I) w = 0``, j = 2…5 (Murray & McCarthy), as a 6 × 6
                         generalised eigenproblem; the axis points and slides are then
                         linear (:func:`synthesis.cylindric.cc5_directions`)
CS     6      26         cylinder axis direction d given (``fixed_direction``): the centre's
                         positions projected on the plane ⊥ d are concyclic, a 5 × 3
                         matrix of degrees (2, 1, 1) in the S centre drops rank
                         (Su, Wampler & McCarthy): the null space of its minors' Macaulay
                         matrix and a 26 × 26 shift eigenproblem (:mod:`synthesis.cs`)
SS, TS 7      20         the sphere conditions ``|T_j q − p| = |q − p|``, j = 2…7, are six
                         bilinear equations in the homogeneous centres (p, 1), (q, 1)
                         (Innocenti; Liao & McCarthy): a 20 × 20 generalised eigenproblem
=====  =====  =========  ==========================================================

The CS count is the degree of the locus where a 5 × 3 matrix whose columns have degrees
(2, 1, 1) drops rank, h₃(2, 1, 1) = 26 (Thom–Porteous); the Macaulay matrix's null space
has exactly that dimension, read off its singular values (reported as ``nullity``, with
the singular-value ``gap``), so again every solution is found without path tracking.

The CC and SS counts are the generic numbers of solutions of a rectangular
multiparameter eigenvalue problem (an (n + k − 1) × n matrix linear in k + 1 homogeneous
parameters drops rank at C(n + k − 1, k) points): the linearising pencil has exactly that
many eigenvalues, so the method finds all of them (see :mod:`synthesis.rmep`).  No path is
tracked; ``paths_tracked`` is 0 and ``failed_paths`` counts the eigenpairs that did not
polish to a solution (they are reported, not hidden).

A TS chain (T: a universal joint at the ground) constrains the body exactly as an SS
chain does (its moving centre stays on a sphere about the fixed one), so its solutions
are the SS ones; the universal joint's fixed axis is the direction farthest from every
position of the link (so the joint stays away from its singularity), its second axis
is perpendicular to that and to the link in position 1.

:func:`least_squares_dyads` handles over-determined tasks (more positions than N_max, e.g.
measured poses): it minimises the chain's pose error over all positions, started from every
exact solution of every N_max-subset of the positions, and reports the residual per
position.
"""
from __future__ import annotations

import itertools
import time

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from .binary import _check_rotations, _perp, _rot, _signed_angle, _task
from .cs import cs_centres, cs_frame
from .cylindric import _cc5
from .dyads import DYAD_COLUMNS
from .errors import SynthesisError
from .rmep import solve_bilinear
from .rr import rr_links
from .screw import Line, Screw
from .validate import screws as _screws, unit as _unit
from .verify import pose_errors, verify_links, verify_open_chains, verify_points

__all__ = ["complete_dyads", "least_squares_dyads", "COMPLETE_CHAINS", "ss_centres"]

#: chain → (N_max, number of solutions over the complex numbers, source)
COMPLETE_CHAINS = {
    "RR": (3, 2, "Suh; Brunnthaler, Schröcker & Husty 2005 (the Bennett pair)"),
    "CC": (5, 6, "Murray & McCarthy 1994"),
    "CS": (6, 26, "Su, Wampler & McCarthy 2004"),
    "SS": (7, 20, "Innocenti 1995; Liao & McCarthy 2001"),
    "TS": (7, 20, "Innocenti 1995; Liao & McCarthy 2001"),
}


def _chain_name(chain, allowed) -> str:
    if not isinstance(chain, str):
        raise SynthesisError(f"chain: expected a chain name, one of {', '.join(allowed)}, got "
                             f"{type(chain).__name__} {chain!r}")
    name = chain.upper()
    if name not in allowed:
        raise SynthesisError(f"chain {chain!r}: expected one of {', '.join(allowed)} (the chains "
                             "with a complete solver at their maximal number of positions)")
    return name


def _row(chain, variant, order, types, lines, residual, joint_values=None, slides=None, **extra):
    """One row in the layout of :func:`synthesis.enumerate_dyads` (joint 1 at the ground)."""
    row = {"family": chain, "variant": variant, "order": order}
    for k, (t, ln) in enumerate(zip(types, lines), start=1):
        row[f"j{k}_type"] = t
        row[f"j{k}_ux"], row[f"j{k}_uy"], row[f"j{k}_uz"] = ln.direction
        row[f"j{k}_x"], row[f"j{k}_y"], row[f"j{k}_z"] = ln.point
        row[f"j{k}_pitch"] = {"R": 0.0, "P": np.inf}.get(t, np.nan)
    row["residual"] = residual
    row["reason"] = ""
    row.update(extra)
    for name, vals in (("q", joint_values), ("d", slides)):
        if vals is not None:
            for p in range(vals.shape[0]):
                for k in range(vals.shape[1]):
                    row[f"{name}{k + 1}_pos{p + 1}"] = vals[p, k]
    return row


def _verified(rows, residuals, what: str, unit: str):
    """Set each row's engine ``residual``; a row missing the positions by more than 1e-9
    gets its reason (the construction lost its accuracy)."""
    for row, rv in zip(rows, residuals):
        row["residual"] = float(rv)
        if rv > 1e-9:
            row["reason"] = (f"ill-conditioned: driven by the engine the {what} misses the "
                             f"positions by {rv:.1e} ({unit})")


def _table(rows, attrs) -> pd.DataFrame:
    df = pd.DataFrame(rows)
    extra = [c for c in df.columns if c not in DYAD_COLUMNS]
    df = df.reindex(columns=list(DYAD_COLUMNS) + extra)
    df.attrs.update(attrs)
    return df


def complete_dyads(chain: str, screws, fixed_direction=None) -> pd.DataFrame:
    """Every real solution of a chain's synthesis at its maximal number of positions.

    Parameters
    ----------
    chain : str
        ``"RR"`` (3 positions), ``"CC"`` (5), ``"CS"`` (6), ``"SS"`` or ``"TS"`` (7).
    screws : sequence of Screw
        S₁₂ … S₁N (N = N_max of the chain), the displacements from position 1.
    fixed_direction : array_like, shape (3,), optional
        CS only, and required there: the unit direction of the C joint's axis (the
        free choice of Su, Wampler & McCarthy: 2 parameters).  Refused for the other
        chains.

    Returns
    -------
    pandas.DataFrame
        One row per real solution, in the layout of :func:`synthesis.enumerate_dyads`:
        ``family`` (the chain), ``variant`` (1, 2, …), ``order``, per joint k
        (1 at the ground, 2 on the body; the ``j3_*`` columns are empty)
        ``j{k}_type, j{k}_ux, j{k}_uy, j{k}_uz, j{k}_x, j{k}_y, j{k}_z`` in position 1
        (a spherical joint has no axis: its direction is NaN and its point is the
        centre; a C joint's point is the foot of the perpendicular from the origin),
        ``residual`` (the largest pose error, rad or length over the task's reach,
        when the closure engine drives the chain through all positions; for SS/TS the
        moving centre's error, driven through the ground joint's two rotations; for CS
        the body's pose error, driven through the C joint's angle and slide and the S
        joint as three revolutes about x, y, z at its centre: XYZ angles of its
        rotations), ``radius`` (SS, TS: the link's length; CS: the centre's distance
        from the C axis),
        ``reason`` (empty), the joint rotations ``q{k}_pos{p}`` (rad) and, for C joints,
        the slides ``d{k}_pos{p}`` (length).  ``.attrs``: ``chain``, ``positions``,
        ``complex_count`` (solutions found over the complex numbers, real ones
        included), ``expected_count`` (the generic number from the literature) and
        ``source``, ``real_count`` (real solutions of the equations), ``rejected``
        (real solutions that are no working chain, e.g. parallel CC axes),
        ``at_infinity`` (SS, CS: solutions with a centre, or for CS a circle, at
        infinity), ``paths_tracked``, ``failed_paths`` (eigenpairs that did not polish
        to a solution, or polished to one found already), ``method``, ``time_s`` (s);
        CS also ``fixed_direction``, ``nullity`` (the Macaulay matrix's null space
        dimension: the complex solution count with multiplicity) and ``gap`` (its
        last nonzero and first zero singular values over the largest).

    Raises
    ------
    SynthesisError
        ``chain`` not a string or not one of the chains above; ``screws`` not a
        sequence of N_max − 1 Screw; ``fixed_direction`` missing for CS, given for
        another chain, or not a unit 3-vector; a degenerate task (coincident positions,
        a planar motion, …: the message names the cause).
    """
    name = _chain_name(chain, COMPLETE_CHAINS)
    n_max, expected, source = COMPLETE_CHAINS[name]
    scr = _screws(screws, "screws")
    if len(scr) != n_max - 1:
        raise SynthesisError(f"screws: {name} has finitely many solutions through {n_max} "
                             f"positions: expected {n_max - 1} screws S_12 … S_1{n_max}, got "
                             f"{len(scr)}")
    if name == "CS":
        if fixed_direction is None:
            raise SynthesisError("fixed_direction: CS has finitely many solutions through six "
                                 "positions only with the C axis direction given: expected a "
                                 "unit 3-vector, got None")
        d = _unit(fixed_direction, "fixed_direction")
    elif fixed_direction is not None:
        raise SynthesisError(f"fixed_direction: only CS takes a fixed direction (its free "
                             f"choice); {name} is complete without one: expected None, got "
                             f"{fixed_direction!r}")
    t0 = time.perf_counter()
    order = f"complete: positions 1–{n_max}"
    if name == "RR":
        rows, info = _rr_rows(scr, order)
    elif name == "CS":
        rows, info = _cs_rows(scr, order, d)
    elif name == "CC":
        rows, info = _cc_rows(scr, order)
    else:
        rows, info = _ss_rows(scr, order, name)
    attrs = {"chain": name, "positions": n_max, "expected_count": expected, "source": source,
             "paths_tracked": 0, "time_s": time.perf_counter() - t0}
    attrs.update(info)
    return _table(rows, attrs)


# ------------------------------------------------------------------ RR
def _rr_rows(scr, order):
    links = rr_links(scr[0], scr[1])
    T = np.stack([np.eye(4)] + [s.matrix() for s in scr])
    task = _task(scr, "screws", (3,))
    jv = [np.stack([lk.fixed_angles, lk.moving_angles], 1) for lk in links]
    res = verify_links([("RR", [lk.fixed_axis, lk.moving_axis], (0.0, 0.0), q)
                        for lk, q in zip(links, jv)], T, task.reach)
    rows = [_row("RR", v + 1, order, "RR", [lk.fixed_axis, lk.moving_axis], float(r),
                 joint_values=q, length=lk.length, twist=lk.twist)
            for v, (lk, q, r) in enumerate(zip(links, jv, res))]
    return rows, {"complex_count": 2, "real_count": 2, "rejected": 0, "at_infinity": 0,
                  "failed_paths": 0, "method": "factorisation of the Bennett motion polynomial"}


# ------------------------------------------------------------------ CC
def _cc_rows(scr, order):
    task = _task(scr, "screws", (5,))
    _check_rotations(task, "screws")
    links, info = _cc5(task, 1e-9)
    rows = []
    if links:
        res = verify_links([lk.chain() for lk in links], task.T, task.reach)
        for v, (lk, r) in enumerate(zip(links, res)):
            rows.append(_row("CC", v + 1, order, "CC", [lk.fixed_axis, lk.moving_axis], float(r),
                             joint_values=np.stack([lk.fixed_angles, lk.moving_angles], 1),
                             slides=np.stack([lk.fixed_slides, lk.moving_slides], 1)))
    return rows, {"complex_count": info["complex"], "real_count": info["real"],
                  "rejected": info["rejected"], "at_infinity": 0,
                  "failed_paths": info["unsolved"],
                  "method": "directions: 6 x 6 generalised eigenproblem; moments: linear"}


# ------------------------------------------------------------------ CS
def _cs_rows(scr, order, d):
    task = _task(scr, "screws", (6,))
    # a point fixed in every position (a spherical motion): a CS chain with its S centre
    # there and any axis of direction d reaches them all (the solutions are not isolated)
    A = (task.R - np.eye(3)).reshape(-1, 3)
    fix = np.linalg.lstsq(A, -task.t.reshape(-1), rcond=None)[0]
    if np.abs(A @ fix + task.t.reshape(-1)).max() < 1e-9:
        raise SynthesisError(
            f"screws: degenerate task: the positions are (nearly) spherical, rotations about "
            f"the point {np.round(fix * task.L + task.c, 6).tolist()}: every CS chain with its "
            "S centre there reaches them (the solutions are not isolated)")
    sol = cs_centres(task.R, task.t, d)
    # the null space must be clear (its singular values some orders of magnitude below
    # the rest) and the shift defined: otherwise the solutions are not isolated, or some
    # are too far away to be told apart (e.g. rotation axes all nearly parallel to d)
    if sol.nullity == 0 or sol.shift_rcond < 1e-6 or sol.gap[0] < 1e4 * sol.gap[1]:
        raise SynthesisError(
            f"screws: degenerate task for fixed_direction {np.round(d, 6).tolist()}: the CS "
            "circle conditions through these six positions do not have finitely many "
            f"solutions, or nearly so (Macaulay null space {sol.nullity}, singular-value gap "
            f"{sol.gap[0]:.1e}/{sol.gap[1]:.1e}, shift conditioning {sol.shift_rcond:.1e}; e.g. "
            "every rotation about an axis (nearly) parallel to the fixed direction, or a pure "
            "translation)")
    good = (sol.residual <= 1e-9) & ~sol.duplicate
    use = good & sol.real
    T, L, c = task.T, task.L, task.c
    F = cs_frame(d)
    rows, chains, rejected = [], [], 0
    for i in np.flatnonzero(use):
        qn = sol.q[i].real
        pn = sol.axis_point[i].real
        r2 = float(sol.radius2[i].real)
        if r2 <= 1e-16:                     # the centre on the axis: no link (angles undefined)
            rejected += 1
            continue
        # joint values in the frame of d: the centre's positions about the axis trace
        Pn = np.einsum("pij,j->pi", task.Tn[:, :3, :3], qn) + task.Tn[:, :3, 3]
        U = (Pn - pn) @ F
        ang = np.arctan2(U[:, 1], U[:, 0])
        theta = np.angle(np.exp(1j * (ang - ang[0])))
        slide = (U[:, 2] - U[0, 2]) * L
        axis = Line(d, pn * L + c).canonical()
        q = qn * L + c
        # the S joint's rotations: the body's, less the C joint's turn about d
        Rd = _rot(d, theta)                                              # (P, 3, 3)
        S = np.swapaxes(Rd, 1, 2) @ T[:, :3, :3]
        e = Rotation.from_matrix(S).as_euler("XYZ")
        lines = [axis] + [Line._exact(np.eye(3)[k], q.copy()) for k in range(3)]
        chains.append(("CRRR", lines, [0.0] * 4, np.column_stack([theta, slide, e])))
        rows.append(_row("CS", len(rows) + 1, order, "CS",
                         [axis, Line._exact(np.full(3, np.nan), q)], np.nan,
                         joint_values=theta[:, None], slides=slide[:, None],
                         radius=float(np.sqrt(r2) * L)))
    if chains:
        _verified(rows, verify_open_chains(chains, T, task.reach), "chain",
                  "rad, or relative to the task's reach")
    return rows, {"complex_count": int(good.sum()), "real_count": int(use.sum()),
                  "rejected": rejected, "at_infinity": int(sol.at_infinity.sum()),
                  "failed_paths": int((~good & ~sol.at_infinity).sum()),
                  "fixed_direction": d.copy(), "nullity": sol.nullity, "gap": sol.gap,
                  "method": f"Macaulay null space of the 10 rank-drop minors (degree 6, "
                            f"100 x 84) and a {sol.nullity} x {sol.nullity} shift eigenproblem"}


# ------------------------------------------------------------------ SS, TS
def ss_centres(task):
    """All solutions of the SS sphere conditions through seven positions (normalised task).

    ``|T_j q − p|² = |q − p|²`` (j = 2…7) reads, for the fixed centre p and the moving
    centre q (position 1), ``pᵀ (I − R_j) q + tᵀ R_j q − pᵀ t + |t|²/2 = 0``: bilinear
    in the homogeneous ``(p, p₀)``, ``(q, q₀)``, i.e. ``(p, p₀)ᵀ E_j (q, q₀) = 0`` with
    ``E_j = [[I − R_j, −t_j], [t_jᵀ R_j, |t_j|²/2]]``.

    Returns
    -------
    p, q : numpy.ndarray, complex, shape (20, 4)
        Homogeneous centres (largest entry 1).
    real, residual : numpy.ndarray (20,)
    singular : bool
        The pencil is singular: the solution set is not finite (a degenerate task).
    """
    R, t = task.R, task.t
    m = len(R)
    E = np.zeros((m, 4, 4))
    E[:, :3, :3] = np.eye(3) - R
    E[:, :3, 3] = -t
    E[:, 3, :3] = np.einsum("mi,mij->mj", t, R)
    E[:, 3, 3] = 0.5 * np.sum(t * t, 1)
    sol = solve_bilinear(np.transpose(E, (1, 0, 2)))      # A_i[j, c] = E_j[i, c]
    return sol.lam, sol.x, sol.real, sol.residual, sol.singular


def _ss_rows(scr, order, name):
    task = _task(scr, "screws", (7,))
    if task.L < 1e-8 * task.reach:
        raise SynthesisError(
            f"screws: degenerate task: the positions are (nearly) spherical, rotations about "
            f"one point to within {task.L / task.reach:.1e} of the coordinates' size "
            f"{task.reach:.3g}: every SS link with its fixed centre there reaches them (the "
            "solutions are not isolated)")
    p, q, real, res, singular = ss_centres(task)
    if singular:
        raise SynthesisError("screws: degenerate task: the SS sphere conditions through these "
                             "seven positions do not have finitely many solutions, or nearly "
                             "so (the linearising pencil is numerically singular; e.g. a planar "
                             "or nearly planar motion)")
    good = res <= 1e-9
    # a centre at infinity (p₀ or q₀ = 0): no SS chain
    inf = good & ((np.abs(p[:, 3]) < 1e-9) | (np.abs(q[:, 3]) < 1e-9))
    use = good & real & ~inf
    P = (p[use, :3] / p[use, 3:]).real * task.L + task.c
    Qc = (q[use, :3] / q[use, 3:]).real * task.L + task.c
    rows, chains, rejected = [], [], 0
    T = task.T
    for v in range(len(P)):
        chain = _ground_universal(P[v], Qc[v], T)
        if chain is None:
            rejected += 1            # a link of zero length: no chain
            continue
        lines, jv = chain
        chains.append(("RR", lines, jv, Qc[v]))
        types = "US" if name == "TS" else "SS"
        g1 = lines[0] if name == "TS" else Line._exact(np.full(3, np.nan), P[v])
        rows.append(_row(name, len(rows) + 1, order, types,
                         [g1, Line._exact(np.full(3, np.nan), Qc[v])], np.nan,
                         joint_values=jv, radius=float(np.linalg.norm(Qc[v] - P[v]))))
    if chains:
        _verified(rows, verify_points(chains, T, task.reach), "link",
                  "relative to the task's reach")
    return rows, {"complex_count": int(good.sum()), "real_count": int((good & real).sum()),
                  "rejected": rejected, "at_infinity": int(inf.sum()),
                  "failed_paths": int((~good).sum()),
                  "method": "20 x 20 generalised eigenproblem (bilinear sphere conditions)"}


def _ground_universal(p, q, T):
    """The two intersecting axes at the fixed centre p (a universal joint) that carry the
    moving centre q to its positions ``T_j q``, and their angles ``(P, 2)`` (rad).

    Axis 1 is the direction least aligned with every position of the link (the smallest
    singular vector of the link vectors), axis 2 is ⊥ axis 1 and the link in position 1;
    turning about axis 2 sets the angle from axis 1, then about axis 1 the azimuth."""
    V = np.einsum("pij,j->pi", T[:, :3, :3], q) + T[:, :3, 3] - p          # (P, 3)
    r = np.linalg.norm(V[0])
    if r <= 1e-12 * max(1.0, np.abs(p).max()):
        return None
    a1 = np.linalg.svd(V)[2][-1]
    a2 = np.cross(a1, V[0])
    a2 /= np.linalg.norm(a2)
    elev = np.arctan2(np.linalg.norm(np.cross(a1, V), axis=1), V @ a1)     # angle from a1
    th2 = elev - elev[0]
    W = np.einsum("pij,j->pi", _rot(a2, th2), V[0])
    th1 = _signed_angle(W, V, a1[None])
    return [Line._exact(a1, p.copy()), Line._exact(a2, p.copy())], np.stack([th1, th2], 1)


# ------------------------------------------------------------------ least squares
LSQ_CHAINS = ("RR", "CC")


def least_squares_dyads(chain: str, screws) -> pd.DataFrame:
    """RR or CC links through more positions than N_max, by least squares.

    Every N_max-subset of the positions is solved exactly (:func:`complete_dyads` on the
    subset's relative screws, moved back to position 1), and each exact solution starts
    a Levenberg–Marquardt minimisation of the pose errors over **all** positions
    (rotation: the chordal error ``(R − R_j)/√2``, of norm 2 sin(θ/2) ≈ θ rad; translation
    in units of the task's size; the joint values per position are unknowns too).
    Distinct minima are returned, best first.

    Parameters
    ----------
    chain : str
        ``"RR"`` or ``"CC"``.
    screws : sequence of Screw
        S₁₂ … S₁N with N > N_max (4 or more positions for RR, 6 or more for CC).

    Returns
    -------
    pandas.DataFrame
        The layout of :func:`complete_dyads`; ``residual`` is the largest pose error over
        the positions (engine-verified at the fitted joint values), ``residual_pos{p}``
        the error at each position (the same measure: rad, or length over the task's
        reach), ``rms`` the root mean square of all pose-error
        components.  ``.attrs``: ``starts`` (exact solutions used as starts),
        ``subsets``, ``time_s``.

    Raises
    ------
    SynthesisError
        ``chain`` not RR or CC; ``screws`` not a sequence of at least N_max Screw
        (N_max − 1 give the exact problem: use :func:`complete_dyads`).
    """
    name = _chain_name(chain, LSQ_CHAINS)
    n_max = COMPLETE_CHAINS[name][0]
    scr = _screws(screws, "screws")
    if len(scr) < n_max:
        raise SynthesisError(f"screws: least squares needs more than {n_max} positions for "
                             f"{name}: expected at least {n_max} screws, got {len(scr)} "
                             f"(use complete_dyads for exactly {n_max} positions)")
    t0 = time.perf_counter()
    task = _task(scr, "screws", (len(scr) + 1,))
    T = task.T
    n = len(T)
    starts, subsets = [], 0
    for sub in itertools.combinations(range(n), n_max):
        a = sub[0]
        Ta_inv = np.linalg.inv(T[a])
        rel = [Screw.from_matrix(T[b] @ Ta_inv) for b in sub[1:]]
        try:
            axes = _exact_axes(name, rel)
        except SynthesisError:
            continue
        subsets += 1
        for g, w in axes:
            # axes found in position a: the fixed one is fixed, the moving one moves back
            w = w.transformed(Ta_inv)
            starts.append(((g.direction, (g.point - task.c) / task.L),
                           (w.direction, (w.point - task.c) / task.L)))
    if not starts:
        raise SynthesisError(f"screws: no {n_max}-subset of the positions has an exact {name} "
                             "solution to start from (degenerate task)")
    fits = _fit_all(name, task, starts)
    fits.sort(key=lambda f: f["cost"])
    kept = []
    for f in fits:
        if not any(_same_axes(f, k) for k in kept):
            kept.append(f)
    rows = []
    links = []
    for v, f in enumerate(kept):
        g = Line(f["g"], f["cg"] * task.L + task.c).canonical()
        w = Line(f["w"], f["cw"] * task.L + task.c).canonical(g)
        q = np.c_[f["th"], f["ph"]]
        d = np.c_[f["a"], f["b"]] * task.L
        jv = np.stack([q[:, 0], d[:, 0], q[:, 1], d[:, 1]], 1) if name == "CC" else q
        links.append((name, [g, w], (0.0, 0.0), jv))
        extra = {"rms": f["rms"]}
        for p in range(n):
            extra[f"residual_pos{p + 1}"] = float(f["per_pos"][p])
        rows.append(_row(name, v + 1, f"least squares: positions 1–{n}", name, [g, w], np.nan,
                         joint_values=q, slides=d if name == "CC" else None, **extra))
    res = verify_links(links, T, task.reach)
    for row, r in zip(rows, res):
        row["residual"] = float(r)
    return _table(rows, {"chain": name, "positions": n, "starts": len(starts),
                         "subsets": subsets, "time_s": time.perf_counter() - t0})


def _exact_axes(name, rel):
    """(fixed axis, moving axis) of every exact RR or CC solution through the positions
    ``rel`` (screws from the subset's first position)."""
    if name == "RR":
        return [(lk.fixed_axis, lk.moving_axis) for lk in rr_links(rel[0], rel[1])]
    task = _task(rel, "screws", (5,))
    _check_rotations(task, "screws")
    return [(lk.fixed_axis, lk.moving_axis) for lk in _cc5(task, 1e-9)[0]]


def _same_axes(a, b, tol=1e-6):
    for u, c, v, e in ((a["g"], a["cg"], b["g"], b["cg"]), (a["w"], a["cw"], b["w"], b["cw"])):
        if np.linalg.norm(np.cross(u, v)) > tol or np.linalg.norm(np.cross(u, c - e)) > tol:
            return False
    return True


def _fit_all(name, task, starts):
    """Least-squares fits of RR or CC links to the normalised poses ``Tn (n, 4, 4)`` from
    every start ((g, cg), (w, cw)), all at once (batched Levenberg–Marquardt); the joint
    values per position are unknowns too.  Returns one dict per start; its per-position
    errors are those of the table's ``residual``: rotation (rad) or translation of the
    user's frame over the task's reach."""
    Tn = task.Tn
    n = len(Tn)
    m = n - 1
    cyl = name == "CC"
    g0 = np.array([s[0][0] for s in starts])
    w0 = np.array([s[1][0] for s in starts])
    cg0 = np.array([s[0][1] for s in starts])
    cw0 = np.array([s[1][1] for s in starts])
    cg0 = cg0 - np.sum(cg0 * g0, 1, keepdims=True) * g0
    cw0 = cw0 - np.sum(cw0 * w0, 1, keepdims=True) * w0
    eg, ew = _perp(g0), _perp(w0)
    per = 4 if cyl else 2                                  # joint values per position
    k = 8 + per * m

    def unpack(x, rows):
        g = g0[rows] + x[:, :1] * eg[0][rows] + x[:, 1:2] * eg[1][rows]
        g /= np.linalg.norm(g, axis=1, keepdims=True)
        w = w0[rows] + x[:, 2:3] * ew[0][rows] + x[:, 3:4] * ew[1][rows]
        w /= np.linalg.norm(w, axis=1, keepdims=True)
        cg = cg0[rows] + x[:, 4:5] * eg[0][rows] + x[:, 5:6] * eg[1][rows]
        cw = cw0[rows] + x[:, 6:7] * ew[0][rows] + x[:, 7:8] * ew[1][rows]
        q = x[:, 8:].reshape(len(x), m, per)
        return g, cg, w, cw, q

    def poses(x, rows):
        g, cg, w, cw, q = unpack(x, rows)
        G, W = _rot(g[:, None], q[..., 0]), _rot(w[:, None], q[..., 1])          # (N, m, 3, 3)
        tw = cw[:, None] - np.einsum("nmij,nj->nmi", W, cw)
        tg = cg[:, None] - np.einsum("nmij,nj->nmi", G, cg)
        if cyl:
            tw = tw + q[..., 3:4] * w[:, None]
            tg = tg + q[..., 2:3] * g[:, None]
        return G @ W, np.einsum("nmij,nmj->nmi", G, tw) + tg

    def F(x, rows):
        R, t = poses(x, rows)
        # chordal rotation error (R − R_j)/√2: its norm is 2 sin(θ/2) ≈ θ, zero only at θ = 0
        rot = ((R - Tn[1:, :3, :3]) / np.sqrt(2)).reshape(R.shape[:-2] + (9,))
        return np.concatenate([rot, t - Tn[1:, :3, 3]], -1).reshape(len(x), -1)

    # start values of the joints: angles carrying w and the body about the axes, slides by
    # least squares
    x0 = np.zeros((len(starts), k))
    q0 = np.zeros((len(starts), m, per))
    for i in range(len(starts)):
        th, ph = _start_angles(g0[i], w0[i], Tn)
        q0[i, :, 0], q0[i, :, 1] = th, ph
        if cyl:
            q0[i, :, 2], q0[i, :, 3] = _start_slides(g0[i], cg0[i], w0[i], cw0[i], th, ph, Tn)
    x0[:, 8:] = q0.reshape(len(starts), -1)
    # column groups that touch disjoint residual rows (one joint value of every position)
    groups = [np.array([c]) for c in range(8)] + \
        [8 + per * np.arange(m) + j for j in range(per)]
    x, cost = _batched_lm(F, x0, groups)
    g, cg, w, cw, q = unpack(x, np.arange(len(x)))
    R, t = poses(x, np.arange(len(x)))
    P = np.zeros((len(x), n, 4, 4))
    P[:, 0] = np.eye(4)
    P[:, 1:, :3, :3], P[:, 1:, :3, 3], P[:, 1:, 3, 3] = R, t, 1.0
    # back to the user's coordinates (x ↦ L x + c) for the errors
    Cn = np.diag([task.L, task.L, task.L, 1.0])
    Cn[:3, 3] = task.c
    rot, pos = pose_errors(Cn @ P @ np.linalg.inv(Cn), task.T[None], task.reach)
    r = F(x, np.arange(len(x)))
    out = []
    for i in range(len(x)):
        qi = np.vstack([np.zeros(per), q[i]])
        out.append({"g": g[i], "cg": cg[i] - (cg[i] @ g[i]) * g[i], "w": w[i],
                    "cw": cw[i] - (cw[i] @ w[i]) * w[i], "th": qi[:, 0], "ph": qi[:, 1],
                    "a": qi[:, 2] if cyl else np.zeros(n), "b": qi[:, 3] if cyl else np.zeros(n),
                    "cost": float(cost[i]), "rms": float(np.sqrt(np.mean(r[i] ** 2))),
                    "per_pos": np.maximum(rot[i], pos[i])})
    return out


def _batched_lm(F, x0, groups, iters: int = 100, h: float = 1e-7):
    """Levenberg–Marquardt for many independent least-squares problems at once; the
    Jacobian by central differences, one residual evaluation pair per column group
    (the columns of a group touch disjoint residual rows).  Returns x and the cost
    ``|F|²`` per problem."""
    x = np.array(x0, float)
    N, k = x.shape
    allr = np.arange(N)
    f = F(x, allr)
    cost = np.sum(f * f, 1)
    lam = np.full(N, 1e-3)
    eye = np.eye(k)
    r_of = None
    for _ in range(iters):
        act = np.flatnonzero((cost > 1e-30) & (lam < 1e10))
        if not len(act):
            break
        xa, fa = x[act], f[act]
        J = np.zeros(fa.shape + (k,))
        if r_of is None:                    # which residual rows each column touches
            r_of = {}
            for grp in groups:
                for c in grp:
                    d = np.zeros((1, k))
                    d[0, c] = 1e-3
                    r_of[c] = np.abs(F(x[:1] + d, allr[:1]) - f[:1])[0] > 0
        for grp in groups:
            d = np.zeros(k)
            d[grp] = h
            df = (F(xa + d, act) - F(xa - d, act)) / (2 * h)
            for c in grp:
                J[:, r_of[c], c] = df[:, r_of[c]]
        JtJ = np.swapaxes(J, 1, 2) @ J
        Jtf = np.einsum("nri,nr->ni", J, fa)
        diag = np.einsum("nii->ni", JtJ)
        with np.errstate(all="ignore"):
            step = np.linalg.solve(JtJ + lam[act, None, None] * (eye * (diag[:, None] + 1e-12)),
                                   -Jtf[..., None])[..., 0]
        xn = xa + np.nan_to_num(step)
        fn = F(xn, act)
        cn = np.sum(fn * fn, 1)
        better = np.isfinite(cn) & (cn < cost[act])
        small = (np.abs(step).max(1) <= 1e-15 * (1 + np.abs(xa).max(1))) | \
            (better & (cost[act] - cn <= 1e-12 * cost[act]))      # before the update
        ib = act[better]
        x[ib], f[ib], cost[ib] = xn[better], fn[better], cn[better]
        lam[ib] = np.maximum(lam[ib] / 5, 1e-15)
        lam[act[~better]] *= 8
        lam[act[small]] = np.inf                           # converged
    return x, cost


def _start_angles(g, w, Tn):
    """θ_j (about g, carrying w to R_j w) and φ_j (the rest about w), j = 2…n."""
    R = Tn[1:, :3, :3]
    Rw = np.einsum("pij,j->pi", R, w)
    th = _signed_angle(np.broadcast_to(w, Rw.shape), Rw, g[None])
    M = np.swapaxes(_rot(g, th), -1, -2) @ R
    v = g - (g @ w) * w
    ph = _signed_angle(np.broadcast_to(v, Rw.shape), np.einsum("pij,j->pi", M, v), w[None])
    return th, ph


def _start_slides(g, cg, w, cw, th, ph, Tn):
    """Least-squares slides along g and w given the angles (CC start)."""
    G, W = _rot(g, th), _rot(w, ph)
    base = np.einsum("pij,pj->pi", G, cw - np.einsum("pij,j->pi", W, cw)) + cg \
        - np.einsum("pij,j->pi", G, cg)
    rhs = Tn[1:, :3, 3] - base
    Gw = np.einsum("pij,j->pi", G, w)
    A = np.stack([np.broadcast_to(g, Gw.shape), Gw], 2)                    # (m, 3, 2)
    AtA = np.swapaxes(A, 1, 2) @ A
    ab = np.linalg.solve(AtA + 1e-12 * np.eye(2), np.einsum("pki,pk->pi", A, rhs)[..., None])[..., 0]
    return ab[:, 0], ab[:, 1]
