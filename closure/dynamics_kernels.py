"""Compiled kernels of the dynamics (numba): the terms of Lagrange's equations at solved
poses, and the steps of forward dynamics' right-hand side around the solver's Newton.

:func:`step`, task ``TERMS``, forms for every pose of a batch what
:meth:`closure.Dynamics.terms` returns: the first analogs of every coordinate from the
loop Jacobian (the minimum-norm solve of :class:`closure.lstsq._LstSq`: the same
compiled factorisation, Cholesky with iterative refinement or the truncated SVD, as
:func:`closure.kinematics.analogs`), the coordinates' velocity-product accelerations
``Σ_ij (d²q/dx_i dx_j) ẋ_i ẋ_j`` by one more solve with that factorisation (the column
twist rates ``[V_c, S_c] q̇_c`` summed by the loop coefficients: the second analogs
contracted with the rates, :mod:`closure.kinematics`), and from them, per body, the
Jacobians of its centre-of-mass velocity and angular velocity and their
velocity-product accelerations: ``M = Σ m J_vᵀ J_v + J_ωᵀ I_c J_ω``,
``h = Σ m J_vᵀ a_c + J_ωᵀ (I_c α + ω × I_c ω)``, gravity ``Q = Σ m J_vᵀ g`` (Lagrange's
equations in the Newton–Euler form of :mod:`closure.dynamics`, taken about each body's
centre of mass rather than the world origin, so that a model far from the origin keeps
its digits), springs and dampers on joint coordinates mapped through the first analogs,
the dampers' power and the gravity and spring energies.

Forward dynamics' right-hand side (:meth:`closure.Dynamics.simulate`,
:class:`closure.integrate.PoseTracker`) is one compiled call, ``step`` task ``RHS``
(:func:`_stage_members`): the last solved pose moved along its tangent to the new inputs (plus
second- and third-order terms, :func:`_curvature`), corrected by the position solver's Newton
(:func:`closure.solve_kernels._newton`: the iterations, tolerances and convergence test
of :func:`closure.solver.newton`, one implementation for both), the corrected pose judged
(closed, its condition against the limit above which the dynamics are taken as their
limit along the branch), the terms formed there, with the Newton's last factorisation of
the loop Jacobian where it is the pose's, and ``M⁻¹ (Q − h)`` with ``M⁻¹`` (the caller
adds drives and given joint forces as ``M⁻¹ F``), and the tracker moved on.  The
integrator's step poses take task ``PREDICT``, the solver's Newton
(:func:`closure.solve_kernels.drive`, task ``NEWTON``) and task ``TRACK``, which judges
without the terms.  What the kernel cannot settle it reports instead (a pose that does
not close, a near-singular one, a non-finite force, a mass matrix without a Cholesky
factor) and the caller takes the pose-by-pose path.  Batched forward dynamics
(:func:`closure.batch_dynamics.simulate_batch`: B trajectories in lockstep) runs task
``RHS`` for all its members in one call (:func:`stage`), each on its own: where the loop
Jacobian is dense and of full expected rank (one loop), the Newton of
:data:`closure.lane_kernels.LANES` members at a time in SIMD lanes (:func:`_stage_lanes`:
the same arithmetic, so every member's right-hand side is the one-member stage's bit for
bit), else member by member; it also keeps each member's solved pose nearest every
output time (:func:`nearest_poses`).

The mechanism's structure comes packed by :func:`closure.solve_kernels.pack`; the
dynamics' own data by :func:`pack` here, into ``DI`` (int64: counts, offsets, each
body's link, each column's carrier link and the columns that move its frame, each
spring's and damper's coordinates) and ``DF`` (float64: gravity, each body's mass,
centre of mass and inertia in its link frame, the tree's path signs, the loop
coefficients, each element's coefficient and free value).

numba compiles the kernels on first use (``cache=True``, once per installation: about
50 s after the solver's, :func:`stage`'s lanes about 80 s more when a batch first needs
them).  They call kernels of :mod:`closure.solve_kernels` and
:mod:`closure.lane_kernels`, whose compiled code numba copies into theirs, and numba's
cache checks only the file of the function it caches: the cache index of every kernel
here also carries the stamps of those modules and :mod:`closure.lstsq` (:func:`_njit`),
so that a change there recompiles these kernels too.
"""
from __future__ import annotations

import math
import os

import numba
import numpy as np

from . import lstsq as _lstsq_module
from . import solve_kernels as _sk
from . import lane_kernels as _lk
from .solve_kernels import (_JIT, F_COLSC, F_OFFSET, F_ROWMAP, F_SCALE, H_NC, H_NJ, H_NL, H_NV,
                            O_INQ, P_DENSE, P_M, P_NNZ, _apply, _borrowed, _borrowed_lsq_work,
                            _borrowed_sp_work, _borrowed_state, _cholesky, _dn_solve,
                            _inv_smin, _keep_alive, _lsq, _lsq_solve, _lsq_work,
                            _member_state, _newton, _pattern, _scaled_jacobian,
                            _sp_work, _svd_parts)
from .solve_kernels import _evaluate as _evaluate_state

__all__ = ["pack", "layout", "options", "step", "stage", "PREDICT", "TRACK", "RHS", "TERMS",
           "nearest_poses", "OK",
           "NOT_CLOSED", "SINGULAR", "NON_FINITE", "NOT_SPD"]


def _stamp(module) -> tuple:
    st = os.stat(module.__file__)
    return module.__name__, st.st_mtime, st.st_size


#: the files whose compiled code the kernels here contain
_DEPENDENCIES = (_stamp(_sk), _stamp(_lstsq_module), _stamp(_lk))


def _njit(fn, lanes=False):
    """``numba.njit`` with the options of :mod:`closure.solve_kernels` (``lanes``: of
    :mod:`closure.lane_kernels`), the cache index stamped with the files this module's
    kernels depend on (see the module notes)."""
    disp = numba.njit(**(_lk._LJIT if lanes else _JIT))(fn)
    cache_file = getattr(getattr(disp, "_cache", None), "_cache_file", None)
    if cache_file is not None and hasattr(cache_file, "_source_stamp"):
        cache_file._source_stamp = (cache_file._source_stamp, _DEPENDENCIES)
    return disp


# DI's header: counts, then the offsets of the tables in DI and DF
(D_NB, D_NE, D_BLINK, D_CARRIER, D_DPTR, D_DIDX, D_ECOL, D_EQC, D_EKIND,
 D_FBODY, D_FPSIGN, D_FLOOP, D_FELEM, D_HEAD) = range(14)

#: element kinds
SPRING, DAMPER = 0, 1

#: ``(DI, DF)`` of no dynamics: the arguments of :func:`step`'s tasks that use none
NO_DYNAMICS = (np.zeros(D_HEAD, dtype=np.int64), np.zeros(3))

#: what :func:`step` reports
OK, NOT_CLOSED, SINGULAR, NON_FINITE, NOT_SPD = 0, 1, 2, 3, 4


def pack(dynamics, plan):
    """The kernels' view of a :class:`closure.Dynamics`: ``(DI, DF)`` (module notes), from
    its bodies, springs and dampers (given forces are evaluated by the caller) and the
    compiled ``plan`` of its mechanism."""
    mech = dynamics.m
    t = mech.tree
    nl, nv = len(t.links), t.nv
    bodies = dynamics.bodies
    lin = [e for e in dynamics.elements if e.kind in ("spring", "damper")]
    blink = [t.link_index[b.link] for b in bodies]
    dptr = np.cumsum([0] + [len(d) for d in plan.deps])
    didx = [d for dep in plan.deps for d in dep]
    ints = [blink, plan.carrier, dptr, didx, [e.column for e in lin],
            [e.qcolumn for e in lin], [SPRING if e.kind == "spring" else DAMPER for e in lin]]
    head = np.zeros(D_HEAD, dtype=np.int64)
    head[D_NB], head[D_NE] = len(bodies), len(lin)
    parts, n = [head], D_HEAD
    for key, v in zip((D_BLINK, D_CARRIER, D_DPTR, D_DIDX, D_ECOL, D_EQC, D_EKIND), ints):
        v = np.asarray(v, dtype=np.int64).reshape(-1)
        head[key] = n
        parts.append(v)
        n += v.size
    DI = np.concatenate(parts)
    body = np.array([np.r_[b.mass, b.com, np.asarray(b.inertia, float).reshape(9)]
                     for b in bodies], dtype=float).reshape(-1)
    flts = [np.asarray(dynamics.gravity, float).reshape(3), body,
            np.asarray(t.path_sign, float).reshape(nl * nv),
            np.asarray(t.loop_coef, float).reshape(-1),
            np.array([(e.value, e.free if e.kind == "spring" else 0.0) for e in lin],
                     dtype=float).reshape(-1)]
    parts, n = [], 0
    for key, v in zip((-1, D_FBODY, D_FPSIGN, D_FLOOP, D_FELEM), flts):
        if key >= 0:
            DI[key] = n
        parts.append(v)
        n += v.size
    return DI, np.concatenate(parts)


# ---------------------------------------------------------------------- the terms
@_njit
def _work(PI, ni, nu):
    """Scratch of :func:`_terms` for a mechanism with ``ni`` inputs and ``nu`` unknowns:
    ``(W, Ju, Jin, R, X, R1, X1, Vl, bias, G, acc, Ic, L)`` (``L`` (ni, ni): the mass
    matrix's Cholesky factor in :func:`_pose_rhs`)."""
    nv, nc, nl = PI[H_NV], PI[H_NC], PI[H_NL]
    m = 6 * nc
    return (_lsq_work(m, nu, ni), np.zeros((m, nu)), np.zeros((m, ni)),
            np.zeros((m, ni)), np.zeros((nu, ni)), np.zeros((m, 1)),
            np.zeros((nu, 1)), np.zeros((nl, 6)), np.zeros((nv, 6)), np.zeros((ni, 6)),
            np.zeros(6), np.zeros((3, 3)), np.zeros((ni, ni)))


@_njit
def _borrowed_work(wk):
    """:func:`closure.solve_kernels._borrowed` of every array of the scratch of
    :func:`_work` (the caller keeps ``wk`` alive while they are used)."""
    return (_borrowed_lsq_work(wk[0]), _borrowed(wk[1]), _borrowed(wk[2]),
            _borrowed(wk[3]), _borrowed(wk[4]), _borrowed(wk[5]), _borrowed(wk[6]),
            _borrowed(wk[7]), _borrowed(wk[8]), _borrowed(wk[9]), _borrowed(wk[10]),
            _borrowed(wk[11]), _borrowed(wk[12]))


# inlined into its two callers: as a call, its ~30 array arguments (each passed field by
# field, with reference counts) cost 16 % of a batch member's right-hand side
@numba.njit(inline="always", **_JIT)
def _terms(PI, PF, DI, DF, q, link, S, xd, rank, ucols, icols, wk, first, qd, qdd, M, h, Q,
           en, fac):
    """The terms of one solved pose (link poses ``link``, column twists ``S``, stored
    coordinates ``q``) at input rates ``xd``: first analogs ``first`` (nv, ni), rates
    ``qd`` (nv), velocity-product accelerations ``qdd`` (nv), ``M`` (ni, ni), ``h``,
    ``Q`` (ni) (gravity, springs, dampers), ``en`` = (dampers' power, gravity energy,
    spring energy), all overwritten; ``wk`` the scratch of :func:`_work`, borrowed
    (:func:`_borrowed_work`).  ``fac`` =
    ``(given, J, W, fast, cond, inv0)``: where ``given``, the unknowns' dense Jacobian at
    this pose and its factorisation (:func:`closure.solve_kernels._lsq` into ``W``, as the
    solver's Newton left them at the pose it converged to), else formed here.

    Returns ``(fast, bound)``: ``fast`` the Cholesky path was taken, ``bound`` then the
    estimate ``sqrt(‖J‖²_F · tr G⁻¹)`` (at least the condition number), else the
    condition number of the truncated SVD."""
    # every array borrowed (:func:`closure.solve_kernels._borrowed`: no reference counts;
    # the caller keeps them alive for the call); the scratch comes borrowed
    W, Ju, Jin, R, X, R1, X1, Vl, bias, G, acc, Ic, _ = wk
    PI, PF, DI, DF, q, link, S, xd = _borrowed(PI), _borrowed(PF), _borrowed(DI), \
        _borrowed(DF), _borrowed(q), _borrowed(link), _borrowed(S), _borrowed(xd)
    ucols, icols, first, qd, qdd = _borrowed(ucols), _borrowed(icols), _borrowed(first), \
        _borrowed(qd), _borrowed(qdd)
    M, h, Q, en = _borrowed(M), _borrowed(h), _borrowed(Q), _borrowed(en)
    nv, nc, nl = PI[H_NV], PI[H_NC], PI[H_NL]
    m = 6 * nc
    nu, ni = ucols.shape[0], icols.shape[0]
    o_cs, o_rm = PI[F_COLSC], PI[F_ROWMAP]
    o_ps, o_lp, o_car, o_dptr, o_didx = DI[D_FPSIGN], DI[D_FLOOP], DI[D_CARRIER], \
        DI[D_DPTR], DI[D_DIDX]
    # first analogs: the unknowns' minimum-norm solve of the input columns (analogs)
    if fac[0]:
        Ju, W, fast, cond, inv0 = fac[1], fac[2], fac[3], fac[4], fac[5]
    else:
        _scaled_jacobian(PI, PF, S, ucols, Ju)
        fast, cond, inv0 = _lsq(Ju, rank, W)
    _scaled_jacobian(PI, PF, S, icols, Jin)
    if fast:
        jj = 0.0
        for a in range(m):
            for k in range(nu):
                jj += Ju[a, k] * Ju[a, k]
        bound = math.sqrt(jj) * inv0
    else:
        bound = cond
    for a in range(m):
        for i in range(ni):
            R[a, i] = Jin[a, i] / PF[o_cs + icols[i]]
    _lsq_solve(Ju, fast, W[3], W[4], W[5], W[6], R, X, W[8], W[9])
    for c in range(nv):
        for i in range(ni):
            first[c, i] = 0.0
    for i in range(ni):
        first[icols[i], i] = 1.0
    for k in range(nu):
        for i in range(ni):
            first[ucols[k], i] = -X[k, i] * PF[o_cs + ucols[k]]
    for c in range(nv):
        s = 0.0
        for i in range(ni):
            s += first[c, i] * xd[i]
        qd[c] = s
    # link twists of the rates, then each column's twist rate [V_c, S_c] q̇_c with V_c
    # its carrier's twist (plus the joint's earlier coordinates that move its frame)
    for li in range(nl):                # (each sum over c in order, as 6 running sums)
        for s in range(6):
            Vl[li, s] = 0.0
        for c in range(nv):
            p = DF[o_ps + nv * li + c]
            if p != 0.0:
                r = qd[c]
                for s in range(6):
                    Vl[li, s] += p * (S[c, s] * r)
    for c in range(nv):
        car = DI[o_car + c]
        for s in range(6):
            acc[s] = Vl[car, s]
        for x in range(DI[o_dptr + c], DI[o_dptr + c + 1]):
            d = DI[o_didx + x]
            for s in range(6):
                acc[s] += S[d, s] * qd[d]
        # [a, b] = (ω_a × v_b − ω_b × v_a, ω_a × ω_b)
        v0, v1, v2, w0, w1, w2 = acc[0], acc[1], acc[2], acc[3], acc[4], acc[5]
        sv0, sv1, sv2, sw0, sw1, sw2 = S[c, 0], S[c, 1], S[c, 2], S[c, 3], S[c, 4], S[c, 5]
        r = qd[c]
        bias[c, 0] = ((w1 * sv2 - w2 * sv1) - (sw1 * v2 - sw2 * v1)) * r
        bias[c, 1] = ((w2 * sv0 - w0 * sv2) - (sw2 * v0 - sw0 * v2)) * r
        bias[c, 2] = ((w0 * sv1 - w1 * sv0) - (sw0 * v1 - sw1 * v0)) * r
        bias[c, 3] = (w1 * sw2 - w2 * sw1) * r
        bias[c, 4] = (w2 * sw0 - w0 * sw2) * r
        bias[c, 5] = (w0 * sw1 - w1 * sw0) * r
    # velocity-product accelerations of the unknowns: J_u q̈_u = −Σ_c L_lc [V_c, S_c] q̇_c
    for lp in range(nc):
        for s in range(6):
            acc[s] = 0.0
        for c in range(nv):
            L = DF[o_lp + nv * lp + c]
            if L != 0.0:
                for s in range(6):
                    acc[s] += L * bias[c, s]
        for s in range(6):
            v = 0.0
            for t in range(6):
                v += PF[o_rm + 6 * s + t] * acc[t]
            R1[6 * lp + s, 0] = v
    _lsq_solve(Ju, fast, W[3], W[4], W[5], W[6], R1, X1, W[8], W[9])
    for c in range(nv):
        qdd[c] = 0.0
    for k in range(nu):
        qdd[ucols[k]] = -X1[k, 0] * PF[o_cs + ucols[k]]
    # the bodies, about their centres of mass
    for i in range(ni):
        for j in range(ni):
            M[i, j] = 0.0
        h[i] = 0.0
        Q[i] = 0.0
    g0, g1, g2 = DF[0], DF[1], DF[2]
    vg = 0.0
    o_b, o_bl = DI[D_FBODY], DI[D_BLINK]
    for kb in range(DI[D_NB]):
        li = DI[o_bl + kb]
        o = o_b + 13 * kb
        mass = DF[o]
        # Γ (input columns of the link's world twist) and the velocity-product acceleration
        for i in range(ni):
            for s in range(6):
                G[i, s] = 0.0
        for s in range(6):
            acc[s] = 0.0
        for c in range(nv):
            p = DF[o_ps + nv * li + c]
            if p != 0.0:
                for s in range(6):
                    acc[s] += p * (S[c, s] * qdd[c] + bias[c, s])
                for i in range(ni):
                    f = first[c, i]
                    if f != 0.0:
                        for s in range(6):
                            G[i, s] += p * (S[c, s] * f)
        # centre of mass c = R com + p and the inertia I_c = R I Rᵀ in the world
        c0 = link[li, 0, 3] + link[li, 0, 0] * DF[o + 1] + link[li, 0, 1] * DF[o + 2] + \
            link[li, 0, 2] * DF[o + 3]
        c1 = link[li, 1, 3] + link[li, 1, 0] * DF[o + 1] + link[li, 1, 1] * DF[o + 2] + \
            link[li, 1, 2] * DF[o + 3]
        c2 = link[li, 2, 3] + link[li, 2, 0] * DF[o + 1] + link[li, 2, 1] * DF[o + 2] + \
            link[li, 2, 2] * DF[o + 3]
        for b in range(3):                  # column b of I Rᵀ, then R times it
            t0, t1, t2 = 0.0, 0.0, 0.0
            for w in range(3):                # (each of the three sums in w's order)
                r_bw = link[li, b, w]
                t0 += DF[o + 4 + w] * r_bw
                t1 += DF[o + 7 + w] * r_bw
                t2 += DF[o + 10 + w] * r_bw
            for a in range(3):
                s = 0.0
                s += link[li, a, 0] * t0
                s += link[li, a, 1] * t1
                s += link[li, a, 2] * t2
                Ic[a, b] = s
        w0, w1, w2 = Vl[li, 3], Vl[li, 4], Vl[li, 5]
        # com velocity v + ω × c, its velocity-product acceleration a + α × c + ω × v_c
        u0 = Vl[li, 0] + (w1 * c2 - w2 * c1)
        u1 = Vl[li, 1] + (w2 * c0 - w0 * c2)
        u2 = Vl[li, 2] + (w0 * c1 - w1 * c0)
        al0, al1, al2 = acc[3], acc[4], acc[5]
        a0 = acc[0] + (al1 * c2 - al2 * c1) + (w1 * u2 - w2 * u1)
        a1 = acc[1] + (al2 * c0 - al0 * c2) + (w2 * u0 - w0 * u2)
        a2 = acc[2] + (al0 * c1 - al1 * c0) + (w0 * u1 - w1 * u0)
        # moment about the com: I_c α + ω × I_c ω
        iw0 = Ic[0, 0] * w0 + Ic[0, 1] * w1 + Ic[0, 2] * w2
        iw1 = Ic[1, 0] * w0 + Ic[1, 1] * w1 + Ic[1, 2] * w2
        iw2 = Ic[2, 0] * w0 + Ic[2, 1] * w1 + Ic[2, 2] * w2
        n0 = Ic[0, 0] * al0 + Ic[0, 1] * al1 + Ic[0, 2] * al2 + (w1 * iw2 - w2 * iw1)
        n1 = Ic[1, 0] * al0 + Ic[1, 1] * al1 + Ic[1, 2] * al2 + (w2 * iw0 - w0 * iw2)
        n2 = Ic[2, 0] * al0 + Ic[2, 1] * al1 + Ic[2, 2] * al2 + (w0 * iw1 - w1 * iw0)
        # per input: J_v = Γ_v + Γ_ω × c (into G[:, :3]), J_ω = Γ_ω
        for i in range(ni):
            gw0, gw1, gw2 = G[i, 3], G[i, 4], G[i, 5]
            G[i, 0] += gw1 * c2 - gw2 * c1
            G[i, 1] += gw2 * c0 - gw0 * c2
            G[i, 2] += gw0 * c1 - gw1 * c0
        for i in range(ni):
            gv0, gv1, gv2, gw0, gw1, gw2 = G[i, 0], G[i, 1], G[i, 2], G[i, 3], G[i, 4], G[i, 5]
            for j in range(i + 1):
                e = mass * (gv0 * G[j, 0] + gv1 * G[j, 1] + gv2 * G[j, 2])
                for a in range(3):
                    e += G[i, 3 + a] * (Ic[a, 0] * G[j, 3] + Ic[a, 1] * G[j, 4] +
                                        Ic[a, 2] * G[j, 5])
                M[i, j] += e
            h[i] += mass * (gv0 * a0 + gv1 * a1 + gv2 * a2) + gw0 * n0 + gw1 * n1 + gw2 * n2
            Q[i] += mass * (gv0 * g0 + gv1 * g1 + gv2 * g2)
        vg -= mass * (c0 * g0 + c1 * g1 + c2 * g2)
    for i in range(ni):
        for j in range(i):
            M[j, i] = M[i, j]
    # springs and dampers on joint coordinates, through the first analogs
    diss, vs = 0.0, 0.0
    o_ec, o_eq, o_ek, o_ef = DI[D_ECOL], DI[D_EQC], DI[D_EKIND], DI[D_FELEM]
    for e in range(DI[D_NE]):
        col = DI[o_ec + e]
        k = DF[o_ef + 2 * e]
        if DI[o_ek + e] == SPRING:
            dq = q[DI[o_eq + e]] - DF[o_ef + 2 * e + 1]
            tau = -k * dq
            vs += 0.5 * k * dq * dq
        else:
            tau = -k * qd[col]
            diss -= tau * qd[col]
        for i in range(ni):
            Q[i] += first[col, i] * tau
    en[0], en[1], en[2] = diss, vg, vs
    return fast, bound




def _lanes(fn):
    return _njit(fn, lanes=True)


@_lanes
def _terms_lanes(PI, PF, DI, DF, q, link, S, xd, ucols, icols, J, Ginv, inv0, sc, first, qd,
                 qdd, M, h, Q, en, bound, LN):
    """:func:`_terms` of lanes ``0 .. LN − 1`` of a block (:mod:`closure.lane_kernels`) on
    the Cholesky path, the factorisation given: ``q`` (nq, L), ``link`` (nl, 4, 4, L),
    ``S`` (nv, 6, L), rates ``xd`` (ni, L), the unknowns' Jacobian ``J`` (m, nu, L), its
    ``Ginv`` (k, k, L) and ``inv0`` (L) (:func:`closure.lane_kernels.factor`); into
    ``first`` (nv, ni, L), ``qd``, ``qdd`` (nv, L), ``M`` (ni, ni, L), ``h``, ``Q`` (ni,
    L), ``en`` (3, L) and ``bound`` (L); ``sc`` the scratch of :func:`_lane_work`.  Every
    value the one-member kernel's, bit for bit (a term it skips where a first analog is
    zero is selected away here)."""
    Jin, R, X, T1, T2, acc1, Vl, bias, G, acc, Ic, cw, an, Gv = sc
    nv, nc, nl = PI[H_NV], PI[H_NC], PI[H_NL]
    m = 6 * nc
    nu, ni = ucols.shape[0], icols.shape[0]
    o_cs, o_rm = PI[F_COLSC], PI[F_ROWMAP]
    o_ps, o_lp, o_car, o_dptr, o_didx = DI[D_FPSIGN], DI[D_FLOOP], DI[D_CARRIER], \
        DI[D_DPTR], DI[D_DIDX]
    # first analogs: the unknowns' minimum-norm solve of the input columns
    _lk.jacobian(PI, PF, S, icols, Jin, LN)
    for l in range(LN):
        acc1[l] = 0.0
    for a in range(m):
        for k in range(nu):
            for l in range(LN):
                acc1[l] += J[a, k, l] * J[a, k, l]
    for l in range(LN):
        bound[l] = math.sqrt(acc1[l]) * inv0[l]
    for i in range(ni):
        f = PF[o_cs + icols[i]]
        for a in range(m):
            for l in range(LN):
                R[i, a, l] = Jin[a, i, l] / f
        _lk.solve(J, Ginv, R[i], X[i], T1, T2, acc1, LN)
    for c in range(nv):
        for i in range(ni):
            for l in range(LN):
                first[c, i, l] = 0.0
    for i in range(ni):
        for l in range(LN):
            first[icols[i], i, l] = 1.0
    for k in range(nu):
        f = PF[o_cs + ucols[k]]
        for i in range(ni):
            for l in range(LN):
                first[ucols[k], i, l] = -X[i, k, l] * f
    for c in range(nv):
        for l in range(LN):
            acc1[l] = 0.0
        for i in range(ni):
            for l in range(LN):
                acc1[l] += first[c, i, l] * xd[i, l]
        for l in range(LN):
            qd[c, l] = acc1[l]
    # link twists of the rates, each column's twist rate [V_c, S_c] q̇_c
    for li in range(nl):
        for s in range(6):
            for l in range(LN):
                Vl[li, s, l] = 0.0
        for c in range(nv):
            p = DF[o_ps + nv * li + c]
            if p != 0.0:
                for s in range(6):
                    for l in range(LN):
                        Vl[li, s, l] += p * (S[c, s, l] * qd[c, l])
    for c in range(nv):
        car = DI[o_car + c]
        for s in range(6):
            for l in range(LN):
                acc[s, l] = Vl[car, s, l]
        for x in range(DI[o_dptr + c], DI[o_dptr + c + 1]):
            d = DI[o_didx + x]
            for s in range(6):
                for l in range(LN):
                    acc[s, l] += S[d, s, l] * qd[d, l]
        for l in range(LN):
            v0, v1, v2, w0, w1, w2 = acc[0, l], acc[1, l], acc[2, l], acc[3, l], acc[4, l], \
                acc[5, l]
            sv0, sv1, sv2, sw0, sw1, sw2 = S[c, 0, l], S[c, 1, l], S[c, 2, l], S[c, 3, l], \
                S[c, 4, l], S[c, 5, l]
            r = qd[c, l]
            bias[c, 0, l] = ((w1 * sv2 - w2 * sv1) - (sw1 * v2 - sw2 * v1)) * r
            bias[c, 1, l] = ((w2 * sv0 - w0 * sv2) - (sw2 * v0 - sw0 * v2)) * r
            bias[c, 2, l] = ((w0 * sv1 - w1 * sv0) - (sw0 * v1 - sw1 * v0)) * r
            bias[c, 3, l] = (w1 * sw2 - w2 * sw1) * r
            bias[c, 4, l] = (w2 * sw0 - w0 * sw2) * r
            bias[c, 5, l] = (w0 * sw1 - w1 * sw0) * r
    # velocity-product accelerations of the unknowns: J_u q̈_u = −Σ_c L_lc [V_c, S_c] q̇_c
    for lp in range(nc):
        for s in range(6):
            for l in range(LN):
                acc[s, l] = 0.0
        for c in range(nv):
            Lc = DF[o_lp + nv * lp + c]
            if Lc != 0.0:
                for s in range(6):
                    for l in range(LN):
                        acc[s, l] += Lc * bias[c, s, l]
        for s in range(6):
            for l in range(LN):
                acc1[l] = 0.0
            for t in range(6):
                f = PF[o_rm + 6 * s + t]
                for l in range(LN):
                    acc1[l] += f * acc[t, l]
            for l in range(LN):
                R[ni, 6 * lp + s, l] = acc1[l]
    _lk.solve(J, Ginv, R[ni], X[ni], T1, T2, acc1, LN)
    for c in range(nv):
        for l in range(LN):
            qdd[c, l] = 0.0
    for k in range(nu):
        f = PF[o_cs + ucols[k]]
        for l in range(LN):
            qdd[ucols[k], l] = -X[ni, k, l] * f
    # the bodies, about their centres of mass
    for i in range(ni):
        for l in range(LN):
            for j in range(ni):
                M[i, j, l] = 0.0
            h[i, l] = 0.0
            Q[i, l] = 0.0
    g0, g1, g2 = DF[0], DF[1], DF[2]
    for l in range(LN):
        en[1, l] = 0.0
    o_b, o_bl = DI[D_FBODY], DI[D_BLINK]
    for kb in range(DI[D_NB]):
        li = DI[o_bl + kb]
        o = o_b + 13 * kb
        mass = DF[o]
        for i in range(ni):
            for s in range(6):
                for l in range(LN):
                    G[i, s, l] = 0.0
        for s in range(6):
            for l in range(LN):
                acc[s, l] = 0.0
        for c in range(nv):
            p = DF[o_ps + nv * li + c]
            if p != 0.0:
                for s in range(6):
                    for l in range(LN):
                        acc[s, l] += p * (S[c, s, l] * qdd[c, l] + bias[c, s, l])
                for i in range(ni):
                    for s in range(6):
                        for l in range(LN):
                            f = first[c, i, l]
                            g = G[i, s, l] + p * (S[c, s, l] * f)
                            G[i, s, l] = g if f != 0.0 else G[i, s, l]
        # (in lane loops that each write arrays they do not read: vectorised)
        cm0, cm1, cm2 = DF[o + 1], DF[o + 2], DF[o + 3]
        for l in range(LN):                 # the centre of mass, the inertia in the world
            cw[0, l] = link[li, 0, 3, l] + link[li, 0, 0, l] * cm0 + link[li, 0, 1, l] * cm1 + \
                link[li, 0, 2, l] * cm2
            cw[1, l] = link[li, 1, 3, l] + link[li, 1, 0, l] * cm0 + link[li, 1, 1, l] * cm1 + \
                link[li, 1, 2, l] * cm2
            cw[2, l] = link[li, 2, 3, l] + link[li, 2, 0, l] * cm0 + link[li, 2, 1, l] * cm1 + \
                link[li, 2, 2, l] * cm2
            for b in range(3):              # column b of I Rᵀ, then R times it
                t0, t1, t2 = 0.0, 0.0, 0.0
                for w in range(3):
                    r_bw = link[li, b, w, l]
                    t0 += DF[o + 4 + w] * r_bw
                    t1 += DF[o + 7 + w] * r_bw
                    t2 += DF[o + 10 + w] * r_bw
                for a in range(3):
                    s = 0.0
                    s += link[li, a, 0, l] * t0
                    s += link[li, a, 1, l] * t1
                    s += link[li, a, 2, l] * t2
                    Ic[a, b, l] = s
        for l in range(LN):                 # the centre's acceleration, the moment's rate
            c0, c1, c2 = cw[0, l], cw[1, l], cw[2, l]
            w0, w1, w2 = Vl[li, 3, l], Vl[li, 4, l], Vl[li, 5, l]
            u0 = Vl[li, 0, l] + (w1 * c2 - w2 * c1)
            u1 = Vl[li, 1, l] + (w2 * c0 - w0 * c2)
            u2 = Vl[li, 2, l] + (w0 * c1 - w1 * c0)
            al0, al1, al2 = acc[3, l], acc[4, l], acc[5, l]
            an[0, l] = acc[0, l] + (al1 * c2 - al2 * c1) + (w1 * u2 - w2 * u1)
            an[1, l] = acc[1, l] + (al2 * c0 - al0 * c2) + (w2 * u0 - w0 * u2)
            an[2, l] = acc[2, l] + (al0 * c1 - al1 * c0) + (w0 * u1 - w1 * u0)
            I00, I01, I02 = Ic[0, 0, l], Ic[0, 1, l], Ic[0, 2, l]
            I10, I11, I12 = Ic[1, 0, l], Ic[1, 1, l], Ic[1, 2, l]
            I20, I21, I22 = Ic[2, 0, l], Ic[2, 1, l], Ic[2, 2, l]
            iw0 = I00 * w0 + I01 * w1 + I02 * w2
            iw1 = I10 * w0 + I11 * w1 + I12 * w2
            iw2 = I20 * w0 + I21 * w1 + I22 * w2
            an[3, l] = I00 * al0 + I01 * al1 + I02 * al2 + (w1 * iw2 - w2 * iw1)
            an[4, l] = I10 * al0 + I11 * al1 + I12 * al2 + (w2 * iw0 - w0 * iw2)
            an[5, l] = I20 * al0 + I21 * al1 + I22 * al2 + (w0 * iw1 - w1 * iw0)
            en[1, l] -= mass * (c0 * g0 + c1 * g1 + c2 * g2)
        for i in range(ni):                 # J_v = Γ_v + Γ_ω × c, J_ω = Γ_ω
            for l in range(LN):
                c0, c1, c2 = cw[0, l], cw[1, l], cw[2, l]
                gw0, gw1, gw2 = G[i, 3, l], G[i, 4, l], G[i, 5, l]
                Gv[i, 0, l] = G[i, 0, l] + (gw1 * c2 - gw2 * c1)
                Gv[i, 1, l] = G[i, 1, l] + (gw2 * c0 - gw0 * c2)
                Gv[i, 2, l] = G[i, 2, l] + (gw0 * c1 - gw1 * c0)
        for i in range(ni):                 # (the lane loops innermost)
            for j in range(i + 1):
                for l in range(LN):
                    gv0, gv1, gv2 = Gv[i, 0, l], Gv[i, 1, l], Gv[i, 2, l]
                    gw0, gw1, gw2 = G[i, 3, l], G[i, 4, l], G[i, 5, l]
                    e = mass * (gv0 * Gv[j, 0, l] + gv1 * Gv[j, 1, l] + gv2 * Gv[j, 2, l])
                    e += gw0 * (Ic[0, 0, l] * G[j, 3, l] + Ic[0, 1, l] * G[j, 4, l] +
                                Ic[0, 2, l] * G[j, 5, l])
                    e += gw1 * (Ic[1, 0, l] * G[j, 3, l] + Ic[1, 1, l] * G[j, 4, l] +
                                Ic[1, 2, l] * G[j, 5, l])
                    e += gw2 * (Ic[2, 0, l] * G[j, 3, l] + Ic[2, 1, l] * G[j, 4, l] +
                                Ic[2, 2, l] * G[j, 5, l])
                    M[i, j, l] += e
            for l in range(LN):
                gv0, gv1, gv2 = Gv[i, 0, l], Gv[i, 1, l], Gv[i, 2, l]
                h[i, l] += mass * (gv0 * an[0, l] + gv1 * an[1, l] + gv2 * an[2, l]) + \
                    G[i, 3, l] * an[3, l] + G[i, 4, l] * an[4, l] + G[i, 5, l] * an[5, l]
                Q[i, l] += mass * (gv0 * g0 + gv1 * g1 + gv2 * g2)
    for i in range(ni):
        for j in range(i):
            for l in range(LN):
                M[j, i, l] = M[i, j, l]
    # springs and dampers on joint coordinates, through the first analogs
    for l in range(LN):
        en[0, l], en[2, l] = 0.0, 0.0
    o_ec, o_eq, o_ek, o_ef = DI[D_ECOL], DI[D_EQC], DI[D_EKIND], DI[D_FELEM]
    for e in range(DI[D_NE]):
        col, qc = DI[o_ec + e], DI[o_eq + e]
        k, free = DF[o_ef + 2 * e], DF[o_ef + 2 * e + 1]
        spring = DI[o_ek + e] == SPRING
        for l in range(LN):
            if spring:
                dq = q[qc, l] - free
                tau = -k * dq
                en[2, l] += 0.5 * k * dq * dq
            else:
                tau = -k * qd[col, l]
                en[0, l] -= tau * qd[col, l]
            for i in range(ni):
                Q[i, l] += first[col, i, l] * tau


@_njit
def _lane_work(PI, ni, nu):
    """Scratch of :func:`_terms_lanes`: ``(Jin (m, ni, L), R (ni + 1, m, L), X (ni + 1,
    nu, L), T1 (k, L), T2 (m, L), acc1 (L), Vl (nl, 6, L), bias (nv, 6, L), G (ni, 6, L),
    acc (6, L), Ic (3, 3, L), cw (3, L), an (6, L), Gv (ni, 3, L))``."""
    L = _lk.LANES
    nv, nc, nl = PI[H_NV], PI[H_NC], PI[H_NL]
    m = 6 * nc
    k = min(m, nu)
    return (np.zeros((m, ni, L)), np.zeros((ni + 1, m, L)), np.zeros((ni + 1, nu, L)),
            np.zeros((k, L)), np.zeros((m, L)), np.zeros(L), np.zeros((nl, 6, L)),
            np.zeros((nv, 6, L)), np.zeros((ni, 6, L)), np.zeros((6, L)), np.zeros((3, 3, L)),
            np.zeros((3, L)), np.zeros((6, L)), np.zeros((ni, 3, L)))

# ---------------------------------------------------------------------- the entry kernel
#: tasks of :func:`step`
PREDICT, TRACK, RHS, TERMS = 0, 1, 2, 3

# iopt: the solver's maxiter, the expected rank, Newton's task code, 0 (the solver's
# ``have``), then the offsets of the fields of a member's block of ``buf`` and its size
(I_MAXITER, I_RANK, I_NEWTON, I_HAVE, B_M, B_H, B_Q, B_FIRST, B_QD, B_EN, B_FIG, B_OUT,
 B_MINV, B_COORD, B_CODE, B_QDD, B_PX, B_PA, B_SIZE, I_LEN) = range(20)

#: the figures of a solved pose in its block: residual, iterations, condition number (NaN:
#: at most the limit of ``fopts[8]``, not computed), converged, closed
FIG_RES, FIG_ITS, FIG_COND, FIG_CONV, FIG_CLOSED = range(5)


def layout(ni: int, nv: int, nq: int) -> dict:
    """Offsets of the fields of a member's block of ``buf`` (:func:`step`) for ``ni`` inputs,
    ``nv`` velocity and ``nq`` stored coordinates, and the block's ``size``: ``M`` (ni, ni),
    ``h``, ``Q`` (ni), ``first`` (nv, ni), ``qd`` (nv), ``en`` (3: dampers' power, gravity
    and spring energy), ``fig`` (5), ``out`` (2 ni + 2), ``Minv`` (ni, ni), ``q`` (nq),
    ``code`` (1: the pose's code of task ``RHS``), ``qdd`` (nv: the velocity-product
    accelerations), ``px`` (1), ``pa`` (nv) (the base before: its input and second analogs,
    :func:`_keep_analogs`)."""
    sizes = (("M", ni * ni), ("h", ni), ("Q", ni), ("first", nv * ni), ("qd", nv), ("en", 3),
             ("fig", 5), ("out", 2 * ni + 2), ("Minv", ni * ni), ("q", nq), ("code", 1),
             ("qdd", nv), ("px", 1), ("pa", nv))
    out, o = {}, 0
    for name, k in sizes:
        out[name] = o
        o += k
    out["size"] = o
    return out


def options(opts, rank: int, rhs_cond: float, ni: int, nv: int, nq: int):
    """``(fopts, iopt)`` of :func:`step`: the solver's options (``_path_options``) and the
    condition number above which forward dynamics takes the limit along the branch; the
    solver's maxiter, the expected rank, Newton's task code and the block layout."""
    from .solver import _path_options
    lay = layout(ni, nv, nq)
    iopt = np.zeros(I_LEN, dtype=np.int64)
    iopt[I_MAXITER], iopt[I_RANK], iopt[I_NEWTON] = opts.maxiter, rank, _sk.NEWTON
    for key, name in ((B_M, "M"), (B_H, "h"), (B_Q, "Q"), (B_FIRST, "first"), (B_QD, "qd"),
                      (B_EN, "en"), (B_FIG, "fig"), (B_OUT, "out"), (B_MINV, "Minv"),
                      (B_COORD, "q"), (B_CODE, "code"), (B_QDD, "qdd"), (B_PX, "px"),
                      (B_PA, "pa"), (B_SIZE, "size")):
        iopt[key] = lay[name]
    return np.r_[_path_options(opts, 0.0), rhs_cond], iopt


@_njit
def _exact_condition(PI, PF, S, ucols, rank, Ju, W):
    """The condition number ``s_max / s_rank`` (truncated SVD) of the unknowns' Jacobian at
    twists ``S``, as :meth:`closure.state.Plan.condition`."""
    if Ju.shape[0] == 0 or Ju.shape[1] == 0:
        return 1.0
    _scaled_jacobian(PI, PF, S, ucols, Ju)
    return _svd_parts(Ju, rank, W[4], W[5], W[6])[0]


@numba.njit(inline="always", **_JIT)
def _mat(a, o, n0, n1):
    """``a[o:o + n0 n1]`` (1-D) as an (n0, n1) row-major view: numba's ``reshape`` calls a
    C helper (~12 ns a call, on every member's path here), a strided view does not."""
    s = a.strides[0]
    return np.lib.stride_tricks.as_strided(a[o:], shape=(n0, n1), strides=(n1 * s, s))


@numba.njit(inline="always", **_JIT)
def _member_sizes(ni, bq, brot, bx):
    """``(nq, ns)``: a member's stored coordinates and rotations in the stacked bases
    ``bq`` (B·nq), ``brot`` (B·ns, 3, 3) at inputs ``bx`` (B·ni)."""
    B = max(bx.shape[0] // ni, 1)
    return bq.shape[0] // B, brot.shape[0] // B


@numba.njit(inline="always", **_JIT)
def _cholesky_inverse(M, Minv, L):
    """``Minv = M⁻¹`` of a symmetric positive definite ``M`` (Cholesky); False when the
    factorisation fails."""
    n = M.shape[0]
    if not _cholesky(M, L, n):
        return False
    for j in range(n):                           # columns of M⁻¹: L Lᵀ x = e_j
        for i in range(n):
            s = 1.0 if i == j else 0.0
            for t in range(i):
                s -= L[i, t] * Minv[t, j]
            Minv[i, j] = s / L[i, i]
        for i in range(n - 1, -1, -1):
            s = Minv[i, j]
            for t in range(i + 1, n):
                s -= L[t, i] * Minv[t, j]
            Minv[i, j] = s / L[i, i]
    return True


@numba.njit(inline="always", **_JIT)
def _predict(PI, PF, bq, brot, bx, tangent, y, q, rot, dv, R3, blk, iopt, a):
    """The base pose ``bq``, ``brot`` (at inputs ``bx`` (ni,)) moved along its ``tangent``
    (nv, ni) to the inputs ``y[:ni]``, inputs set, into ``q`` (nq,) and ``rot`` (ns, 3, 3),
    with the higher-order terms of the base's block ``blk`` (:func:`_curvature`); ``dv``
    (nv,) and ``R3`` (1, 3, 3) scratch, ``a`` (nv,) the base's second analogs
    (:func:`_tangent_step`).  Returns :func:`_tangent_step`'s flag."""
    has = _tangent_step(PI, PF, bx, tangent, y, blk, iopt, dv, a)
    _apply(PI, PF, bq, brot, dv, q, rot, R3)
    o_inq = PI[O_INQ]
    for i in range(bx.shape[0]):
        q[PI[o_inq + i]] = y[i]
    return has


@numba.njit(inline="always", **_JIT)
def _tangent_step(PI, PF, bx, tangent, y, blk, iopt, dv, a):
    """:func:`_predict`'s dimensionless step ``dv`` (nv,) from the inputs ``bx`` to
    ``y[:ni]``: along ``tangent``, plus ``k q̈_v`` and ``k₃ (q̈_v / ẋ·ẋ − a)`` of the
    base's block ``blk`` (:func:`_curvature`, which leaves the base's second analogs
    ``q̈_v / ẋ²`` in ``a`` (nv,) where it returns True: :func:`_keep_analogs` keeps them
    for the predictor after the next)."""
    nv, o_cs = PI[H_NV], PI[F_COLSC]
    k, k3, has = _curvature(blk, iopt, nv, bx, y, a)
    o_qdd, o_pa = iopt[B_QDD], iopt[B_PA]
    for c in range(nv):
        s = 0.0
        for i in range(bx.shape[0]):
            s += tangent[c, i] * (y[i] - bx[i])
        if k != 0.0:
            s += k * blk[o_qdd + c]
        if k3 != 0.0:
            s += k3 * (a[c] - blk[o_pa + c])
        dv[c] = s / PF[o_cs + c]
    return has


@numba.njit(inline="always", **_JIT)
def _curvature(blk, iopt, nv, bx, y, a):
    """The factors ``(k, k₃, has)`` of the predictor's higher-order terms from the
    base's block ``blk`` (:func:`layout`: where its code is :data:`OK`, its rates ``ẋ``
    (``out[:ni]``) and velocity-product accelerations ``q̈_v`` (``qdd``, the second analogs
    contracted with ``ẋ``)) to the inputs ``y[:ni]`` from ``bx``:

    * second order, ``k q̈_v`` with ``k = ½ τ²``, ``τ = Δx·ẋ / ẋ·ẋ``: exact for one input
      and for a step along ``ẋ`` (the stages of a Runge–Kutta step), so the predictor's
      error falls from O(Δx²) to O(Δx³);
    * third order (one input), ``k₃ (q̈_v / ẋ² − a)`` with ``k₃ = Δx³ / 6H``: ``(1/6) q‴ Δx³``
      with ``q‴`` the difference quotient of the second analogs ``q̈_v / ẋ²`` here and
      ``a`` (``pa``) at the base before, ``H`` (``px``) away (:func:`_keep_analogs`); the
      error falls to O(Δx³ H + Δx⁴) and Newton needs fewer iterations.  Taken where the
      term is at most the second-order one (``|q‴ Δx| ≤ 3 |q″|``), so a poor difference
      quotient cannot push the prediction further off.

    ``k`` 0 where the block has none (its code not OK, ``ẋ`` 0), ``k₃`` 0 also where there
    is no earlier base (``px`` NaN) or more than one input.  ``has``: the base's second
    analogs ``q̈_v / ẋ²`` are in ``a`` (nv,) (one input, code OK, ``ẋ`` not 0)."""
    if blk[iopt[B_CODE]] != OK:
        return 0.0, 0.0, False
    o_out = iopt[B_OUT]
    dd, dx = 0.0, 0.0
    for i in range(bx.shape[0]):
        r = blk[o_out + i]
        dd += r * r
        dx += (y[i] - bx[i]) * r
    if not (dd > 1e-100 and dd < 1e100):
        return 0.0, 0.0, False
    tau = dx / dd
    k = 0.5 * tau * tau
    if bx.shape[0] != 1:
        return k, 0.0, False
    o_qdd, o_pa = iopt[B_QDD], iopt[B_PA]
    for c in range(nv):
        a[c] = blk[o_qdd + c] / dd
    H = bx[0] - blk[iopt[B_PX]]
    if not (abs(H) > 0.0):                      # no earlier base (NaN), or the same inputs
        return k, 0.0, True
    D = y[0] - bx[0]
    s2, sd = 0.0, 0.0
    for c in range(nv):
        e = a[c] - blk[o_pa + c]
        s2 += a[c] * a[c]
        sd += e * e
    if not (sd * D * D <= 9.0 * s2 * H * H):    # |q‴ Δx| > 3 |q″|: no third-order term
        return k, 0.0, True
    return k, D * D * D / (6.0 * H), True


@numba.njit(inline="always", **_JIT)
def _keep_analogs(has, bx, a, px, pa):
    """The base's inputs and second analogs ``q̈_v / ẋ²`` (``a`` (nv,), where ``has``:
    :func:`_curvature`) into ``px`` (1,) and ``pa`` (nv,), kept for the third-order term
    of the predictor after the next; ``px`` NaN (and ``pa`` 0) where there are none.
    ``pa`` may be ``a`` itself."""
    if has:
        px[0] = bx[0]
        for c in range(a.shape[0]):
            pa[c] = a[c]
    else:
        px[0] = np.nan
        for c in range(a.shape[0]):
            pa[c] = 0.0


@_njit
def step(task, PI, PF, PM, DI, DF, fopts, iopt, ucols, icols, q, rot, link, S, res, cond, its,
         flag, bq, brot, bx, tangent, y, buf):
    """The compiled steps of the dynamics (module notes), by ``task``:

    * ``PREDICT``: the tracker's base pose (``bq``, ``brot`` at inputs ``bx``) moved along
      its ``tangent`` (nv, ni) to the inputs ``y[:ni]`` (with the higher-order terms of the
      block ``buf``, :func:`_curvature`), inputs set, into ``q[0]``,
      ``rot[0]`` (the batch-of-one state the solver's Newton corrects next:
      :func:`closure.solve_kernels.drive`, task ``NEWTON``).
    * ``TRACK``: that corrected state (``q``, ``rot``, ``S`` and the solver's ``res``,
      ``cond``, ``its``, ``flag``) judged: the block's ``fig`` gets its residual,
      iterations, exact condition number (truncated SVD where the solver took the
      Cholesky path), converged, closed (converged and residual at most ``fopts[1]``);
      where it closed it becomes the base (``bq``, ``brot``, ``bx``).
    * ``RHS``: the right-hand side of B ≥ 1 trajectories (:func:`_stage_members`; ``q`` ...
      ``flag`` unused): for member b (base pose, inputs and tangent stacked in ``bq``
      (B·nq), ``brot`` (B·ns, 3, 3), ``bx`` (B·ni) and ``tangent`` (B·nv, ni), its state in
      ``y`` (B·(2 ni + 2)), its fields in block b of ``buf``) ``PREDICT`` (the base
      before kept for the next), the solver's Newton, the pose judged as ``TRACK`` (the
      condition number computed only where the estimate exceeds ``fopts[8]``), then the
      terms at the pose at rates ``y[ni:2 ni]``, the pose's coordinates into the block's
      ``q``; on a regular pose the first analogs become the ``tangent``, and ``out`` =
      (ẋ, M⁻¹ (Q − h), dampers' power, 0) with ``Minv``; its code in the block's ``code``.
    * ``TERMS``: :func:`_terms` for every pose ``q`` (B, nq), ``rot`` of a batch at rates
      ``y`` (B·ni), member b's fields in block b of ``buf`` (``link``, ``S`` unused);
      ``fig[FIG_COND]`` gets the condition estimate (or the condition).

    ``fopts``, ``iopt``: :func:`options`.  Returns :data:`OK` (``PREDICT``, ``TERMS``), the
    number of members whose code is not OK (``RHS``), or ``TRACK``'s code.  Codes:
    :data:`OK`, :data:`NOT_CLOSED` (the base kept), :data:`SINGULAR` (the pose's condition
    exceeds ``fopts[8]``: the base moved, the tangent and the acceleration are the
    caller's), :data:`NON_FINITE` (``Q − h`` not finite) or :data:`NOT_SPD` (no Cholesky
    factor of ``M``) (the base and tangent moved, the terms written)."""
    ni = icols.shape[0]
    nv, nu = PI[H_NV], ucols.shape[0]
    if task == PREDICT:                 # the batch-of-one member 0
        _predict(PI, PF, bq, brot, bx, tangent, y, q[0], rot[0], np.zeros(nv),
                 np.zeros((1, 3, 3)), buf, iopt, np.zeros(nv))
        return OK
    if task == RHS:
        return _stage_members(PI, PF, PM, DI, DF, fopts, iopt, ucols, icols,
                              np.zeros(1, dtype=np.int64), bq, brot, bx, tangent, y, buf)
    rank = iopt[I_RANK]
    blk = iopt[B_SIZE]
    o_M, o_h, o_Q, o_f, o_qd, o_en, o_fig = iopt[B_M], iopt[B_H], iopt[B_Q], iopt[B_FIRST], \
        iopt[B_QD], iopt[B_EN], iopt[B_FIG]
    # the scratch borrowed (no reference counts in the calls per pose), kept to the end
    owned = (_work(PI, ni, nu), np.zeros(nv))
    wk, qdd = _borrowed_work(owned[0]), _borrowed(owned[1])
    nofac = (False, wk[1], wk[0], False, 0.0, 0.0)  # no factorisation given to the terms
    if task == TERMS:
        nj, nl, nc = PI[H_NJ], PI[H_NL], PI[H_NC]
        A_, link_, fa_ = np.zeros((nj, 4, 4)), np.zeros((nl, 4, 4)), np.zeros((nj, 4, 4))
        r_, S_, T, w3 = np.zeros((nc, 6)), np.zeros((nv, 6)), np.zeros((3, 4, 4)), np.zeros(3)
        for b in range(q.shape[0]):
            o = b * blk
            _evaluate_state(PI, PF, PM, q[b], rot[b], A_, link_, fa_, r_, S_, T, w3)
            fast, bound = _terms(PI, PF, DI, DF, q[b], link_, S_, y[b * ni:(b + 1) * ni], rank,
                                 ucols, icols, wk,
                                 _mat(buf, o + o_f, nv, ni),
                                 buf[o + o_qd:o + o_qd + nv], qdd,
                                 _mat(buf, o + o_M, ni, ni),
                                 buf[o + o_h:o + o_h + ni], buf[o + o_Q:o + o_Q + ni],
                                 buf[o + o_en:o + o_en + 3], nofac)
            buf[o + o_fig + FIG_COND] = bound
        _keep_alive(owned)
        return OK
    # TRACK: the solver's corrected state of one pose, judged
    conv = flag[0] != 0
    closed = conv and res[0] <= fopts[1]
    fig = buf[o_fig:o_fig + 5]
    fig[FIG_RES], fig[FIG_ITS], fig[FIG_CONV] = res[0], its[0], 1.0 if conv else 0.0
    fig[FIG_CLOSED] = 1.0 if closed else 0.0
    c_ = cond[0]
    if c_ != c_:                                # the Cholesky path: the SVD's figure
        c_ = _exact_condition(PI, PF, S[0], ucols, rank, wk[1], wk[0])
    fig[FIG_COND] = c_
    _keep_alive(owned)
    if not closed:
        return NOT_CLOSED
    _adopt(q[0], rot[0], bq, brot, bx, y)
    return OK


@numba.njit(inline="always", **_JIT)
def _pose_rhs(PI, PF, DI, DF, fopts, iopt, ucols, icols, q, rot, link, S, res, its, flag, bq,
              brot, bx, tangent, y, buf, wk, qdd, fac):
    """Task ``RHS`` of :func:`step` at one corrected pose: its stored coordinates ``q``
    (nq,), ``rot`` (ns, 3, 3), link poses ``link`` (nl, 4, 4), twists ``S`` (nv, 6) and the
    solver's figures ``res``, ``its``, ``flag`` (scalars) judged into the
    block ``buf`` (:func:`layout`), the terms there at rates ``y[ni:2 ni]``, the base
    (``bq``, ``brot``, ``bx``) and ``tangent`` moved, ``out`` and ``Minv`` written; ``wk``
    (:func:`_work`) and ``qdd`` (nv,) scratch; ``fac``: :func:`_terms`'.  Returns
    :func:`step`'s code."""
    # borrowed (no reference counts on the views below): the caller keeps them alive
    iopt, icols, y, buf = _borrowed(iopt), _borrowed(icols), _borrowed(y), _borrowed(buf)
    ni, nv = icols.shape[0], PI[H_NV]
    o_f, o_qd, o_M = iopt[B_FIRST], iopt[B_QD], iopt[B_M]
    o_h, o_Q, o_en, o_qdd = iopt[B_H], iopt[B_Q], iopt[B_EN], iopt[B_QDD]
    fast, bound = _terms(PI, PF, DI, DF, q, link, S, y[ni:2 * ni], iopt[I_RANK], ucols, icols,
                         wk, _mat(buf, o_f, nv, ni), buf[o_qd:o_qd + nv],
                         qdd, _mat(buf, o_M, ni, ni), buf[o_h:o_h + ni],
                         buf[o_Q:o_Q + ni], buf[o_en:o_en + 3], fac)
    for c in range(nv):
        buf[o_qdd + c] = qdd[c]
    return _settle(PI, PF, fopts, iopt, ucols, icols, q, rot, S, res, its, flag, bq, brot, bx,
                   tangent, y, buf, wk, fast, bound)


@numba.njit(inline="always", **_JIT)
def _settle(PI, PF, fopts, iopt, ucols, icols, q, rot, S, res, its, flag, bq, brot, bx, tangent,
            y, buf, wk, fast, bound):
    """The rest of :func:`_pose_rhs` once the terms are in the block ``buf``: the pose
    judged (its figures, the condition where the terms' ``bound`` does not settle it),
    the base and ``tangent`` moved, ``out`` and ``Minv`` written.  Returns :func:`step`'s
    code."""
    PI, PF, fopts, iopt, ucols, icols = _borrowed(PI), _borrowed(PF), _borrowed(fopts), \
        _borrowed(iopt), _borrowed(ucols), _borrowed(icols)
    q, rot, bq, brot, bx, tangent = _borrowed(q), _borrowed(rot), _borrowed(bq), \
        _borrowed(brot), _borrowed(bx), _borrowed(tangent)
    y, buf = _borrowed(y), _borrowed(buf)
    ni = icols.shape[0]
    nv, nq = PI[H_NV], q.shape[0]
    o_f, o_M, o_fig = iopt[B_FIRST], iopt[B_M], iopt[B_FIG]
    conv = flag != 0
    closed = conv and res <= fopts[1]
    fig = buf[o_fig:o_fig + 5]
    fig[FIG_RES], fig[FIG_ITS], fig[FIG_CONV] = res, its, 1.0 if conv else 0.0
    fig[FIG_CLOSED] = 1.0 if closed else 0.0
    first = _mat(buf, o_f, nv, ni)
    M = _mat(buf, o_M, ni, ni)
    o_h, o_Q, o_en = iopt[B_H], iopt[B_Q], iopt[B_EN]
    h, Q, en = buf[o_h:o_h + ni], buf[o_Q:o_Q + ni], buf[o_en:o_en + 3]
    xd = y[ni:2 * ni]
    c_ = np.nan
    if not closed or not (fast and bound <= fopts[8]):
        c_ = bound if not fast else _exact_condition(PI, PF, S, ucols, iopt[I_RANK], wk[1],
                                                     wk[0])
    fig[FIG_COND] = c_
    if not closed:
        return NOT_CLOSED
    _adopt(q, rot, bq, brot, bx, y)
    o_q = iopt[B_COORD]
    for i in range(nq):
        buf[o_q + i] = q[i]
    if c_ > fopts[8]:
        return SINGULAR
    for c in range(nv):
        for i in range(ni):
            tangent[c, i] = first[c, i]
    o_out, o_mi = iopt[B_OUT], iopt[B_MINV]
    out = buf[o_out:o_out + 2 * ni + 2]
    finite = True
    for i in range(ni):
        out[i] = xd[i]
        f = Q[i] - h[i]
        out[ni + i] = f
        if not (f - f == 0.0):
            finite = False
    out[2 * ni], out[2 * ni + 1] = en[0], 0.0
    if not finite:
        return NON_FINITE
    Minv = _mat(buf, o_mi, ni, ni)
    if not _cholesky_inverse(M, Minv, wk[12]):
        return NOT_SPD
    for i in range(ni):
        s = 0.0
        for j in range(ni):
            s += Minv[i, j] * (Q[j] - h[j])
        out[ni + i] = s
    return OK


@_njit
def stage(PI, PF, PM, DI, DF, fopts, iopt, ucols, icols, members, bq, brot, bx, tangent, y,
          buf, T, t, near, sq, srot, sx, stan):
    """Task ``RHS`` of :func:`step` for A members of a batch
    (:func:`closure.batch_dynamics.simulate_batch`), with :func:`step`'s arguments from
    ``PI`` on (``q`` ... ``flag`` left out) and ``members`` (A,) int64, the members' indices
    in the batch's stacked bases and blocks (``bq`` ... ``tangent``, ``buf``: every member
    of the batch; ``y`` (A·(2 ni + 2)): the A members' states, in order):
    :func:`_stage_lanes` where A > 1 and the loop Jacobian is dense and of full expected
    rank (one loop), else :func:`_stage_members`.  Then, with output times ``T`` (N,
    ascending; N = 0: none), each member whose code is :data:`OK`, solved at the time
    ``t[a]``, has its new base kept for the output times around it
    (:func:`nearest_poses`: ``near`` ... ``stan``).  An entry of its own, so that the lanes
    compile when a batch first needs them, not with :func:`step`."""
    nu, rank = ucols.shape[0], iopt[I_RANK]
    m = 6 * PI[H_NC]
    if members.shape[0] > 1 and m > 0 and nu > 0 and \
            min(rank, m, nu) == min(m, nu) and _pattern(PI, PF, ucols)[P_DENSE] == 1:
        n_bad = _stage_lanes(PI, PF, PM, DI, DF, fopts, iopt, ucols, icols, members, bq, brot,
                             bx, tangent, y, buf)
    else:
        n_bad = _stage_members(PI, PF, PM, DI, DF, fopts, iopt, ucols, icols, members, bq,
                               brot, bx, tangent, y, buf)
    if T.shape[0]:
        ni, nv, blk, o_code = icols.shape[0], PI[H_NV], iopt[B_SIZE], iopt[B_CODE]
        nq, ns = _member_sizes(ni, bq, brot, bx)
        for a in range(members.shape[0]):
            g = members[a]
            if buf[g * blk + o_code] == OK:
                _keep_nearest(T, t[a], g, bq[g * nq:(g + 1) * nq], brot[g * ns:(g + 1) * ns],
                              bx[g * ni:(g + 1) * ni], tangent[g * nv:(g + 1) * nv], near, sq,
                              srot, sx, stan)
    return n_bad


@_njit
def _stage_members(PI, PF, PM, DI, DF, fopts, iopt, ucols, icols, members, bq, brot, bx,
                   tangent, y, buf):
    """The right-hand side of members ``members`` (A,) of B
    trajectories (one: :meth:`closure.Dynamics.simulate`; B:
    :func:`closure.batch_dynamics.simulate_batch`), each on its own, in one pass: the
    member's base pose moved along its tangent to the stage's inputs with the
    higher-order terms of its block (:func:`_predict`, :func:`_curvature`),
    corrected by the solver's Newton (:func:`closure.solve_kernels._newton`, in scratch),
    then judged and the terms formed (:func:`_pose_rhs`) with the Newton's last
    factorisation where it is the pose's and dense (one loop), so the Jacobian is not
    formed and factored twice.  Member b's base pose, inputs and tangent are stacked in
    ``bq`` (B·nq), ``brot`` (B·ns, 3, 3), ``bx`` (B·ni) and ``tangent`` (B·nv, ni), its
    fields in block b of ``buf``, its code in the block's ``code``; the state of the a-th
    member of ``members`` in ``y`` (A·(2 ni + 2)).  Returns the number of members whose
    code is not :data:`OK`."""
    ni, nu, rank, maxiter = icols.shape[0], ucols.shape[0], iopt[I_RANK], iopt[I_MAXITER]
    nv, nj, nl, nc = PI[H_NV], PI[H_NJ], PI[H_NL], PI[H_NC]
    mm, blk, o_code = 2 * ni + 2, iopt[B_SIZE], iopt[B_CODE]
    o_px, o_pa = iopt[B_PX], iopt[B_PA]
    nq, ns = _member_sizes(ni, bq, brot, bx)
    P, Pi = _pattern(PI, PF, ucols), _pattern(PI, PF, icols)
    m = P[P_M]
    # the Newton's scratch (its dense factors wide enough for the terms' ni right-hand
    # sides), two member states, the terms' scratch: owned here, used borrowed
    own = (P, Pi, _sp_work(P, 1), _lsq_work(m, nu, ni), np.zeros(6 * Pi[P_NNZ]),
           np.zeros(max(6 * P[P_NNZ], m * nu)),
           (_member_state(nq, ns, nj, nl, nc, nv, 0), _member_state(nq, ns, nj, nl, nc, nv, 0)),
           (np.zeros(m), np.zeros(nv), np.zeros(3), np.zeros(nv), np.zeros(nv), np.zeros(nv)),
           (np.zeros((m, 1)), np.zeros((nu, 1))), (np.zeros((3, 4, 4)), np.zeros((1, 3, 3))),
           _work(PI, ni, nu))
    W, Wd = _borrowed_sp_work(own[2]), _borrowed_lsq_work(own[3])
    P, Pi, Wi, Jp = _borrowed(P), _borrowed(Pi), (_borrowed(own[4]),), _borrowed(own[5])
    co, trial = _borrowed_state(own[6][0]), _borrowed_state(own[6][1])
    rs, step, w3, dv, qdd = _borrowed(own[7][0]), _borrowed(own[7][1]), _borrowed(own[7][2]), \
        _borrowed(own[7][3]), _borrowed(own[7][4])
    an = _borrowed(own[7][5])
    R, X, T, R3 = _borrowed(own[8][0]), _borrowed(own[8][1]), _borrowed(own[9][0]), \
        _borrowed(own[9][1])
    wk = _borrowed_work(own[10])
    PI, PF, PM, DI, DF = _borrowed(PI), _borrowed(PF), _borrowed(PM), _borrowed(DI), \
        _borrowed(DF)
    fopts, iopt, ucols, icols = _borrowed(fopts), _borrowed(iopt), _borrowed(ucols), \
        _borrowed(icols)
    bq, brot, bx, tangent, y, buf = _borrowed(bq), _borrowed(brot), _borrowed(bx), \
        _borrowed(tangent), _borrowed(y), _borrowed(buf)
    dense = P[P_DENSE] == 1
    n_bad = 0
    for a in range(members.shape[0]):
        b = members[a]
        o = b * blk
        xb, yb, blk_b = bx[b * ni:(b + 1) * ni], y[a * mm:(a + 1) * mm], buf[o:o + blk]
        bq_b, brot_b, tan_b = bq[b * nq:(b + 1) * nq], brot[b * ns:(b + 1) * ns], \
            tangent[b * nv:(b + 1) * nv]
        has = _predict(PI, PF, bq_b, brot_b, xb, tan_b, yb, co[0], co[1], dv, R3, blk_b,
                       iopt, an)
        _keep_analogs(has, xb, an, blk_b[o_px:o_px + 1], blk_b[o_pa:o_pa + nv])
        co, trial, done, n_res, n_its, n_cond, _, at_pose, fast, inv0 = _newton(
            PI, PF, PM, co, trial, maxiter, False, ucols, icols, P, Pi, W, Wd, Wi, Jp, rs, step,
            R, X, T, w3, R3, rank, fopts, False)
        fac = (at_pose and dense, W[5], Wd, fast, n_cond, inv0)
        code = _pose_rhs(PI, PF, DI, DF, fopts, iopt, ucols, icols, co[0], co[1], co[3], co[6],
                         n_res, n_its, np.int64(1 if done else 0), bq_b, brot_b, xb, tan_b, yb,
                         blk_b, wk, qdd, fac)
        buf[o + o_code] = code
        if code != OK:
            n_bad += 1
    _keep_alive(own)
    return n_bad


@_njit
def _stage_lanes(PI, PF, PM, DI, DF, fopts, iopt, ucols, icols, members, bq, brot, bx,
                 tangent, y, buf):
    """:func:`_stage_members` for A > 1 members of a mechanism whose loop Jacobian is
    dense and of full expected rank, :data:`closure.lane_kernels.LANES` members at a time
    (:mod:`closure.lane_kernels`: the same arithmetic, member by member in SIMD lanes):
    the predictors and the steps applied, the kinematic state, the Jacobian, its
    factorisation and the steps of the whole block in one call each, the solver's Newton
    (:func:`closure.solve_kernels._newton`: its iterations, tests and backtracking) per
    member, where a Gram matrix has no Cholesky factor within ``FAST_COND`` the
    one-member truncated SVD; the members that converged on the Cholesky path then have
    their terms in lanes (:func:`_terms_lanes`) and are judged and moved on
    (:func:`_settle`); the others (not converged, or converged on the SVD path) are run
    again by :func:`_stage_members`.  Every member's outputs are :func:`_stage_members`',
    bit for bit."""
    ni, nu, rank, maxiter = icols.shape[0], ucols.shape[0], iopt[I_RANK], iopt[I_MAXITER]
    nv, nj, nl, nc = PI[H_NV], PI[H_NJ], PI[H_NL], PI[H_NC]
    mm, blk, o_inq, o_px, o_pa = 2 * ni + 2, iopt[B_SIZE], PI[O_INQ], iopt[B_PX], iopt[B_PA]
    NA = members.shape[0]
    nq, ns = _member_sizes(ni, bq, brot, bx)
    m = 6 * nc
    k = min(m, nu)
    L = _lk.LANES
    xtol, max_step = fopts[0], fopts[2]
    scale, offset = PF[PI[F_SCALE]], PF[PI[F_OFFSET]]
    floor, xtl, noise = 1e-14 * offset, xtol * offset, 1e-15 * offset
    above = xtl / noise
    # the block's state (current and trial), its scratch, one member's scratch, the terms'
    own = (_lk.lane_state(nq, ns, nj, nl, nc, nv), _lk.lane_state(nq, ns, nj, nl, nc, nv),
           (np.zeros((nj, 4, 4, L)), np.zeros((nj, 4, 4, L)), np.zeros((3, 4, 4, L)),
            np.zeros((8, L)), np.zeros((3, 4, 4)), np.zeros((1, 6)), np.zeros(3),
            np.zeros((1, 4, 4, L))),
           (np.zeros((m, nu, L)), np.zeros((k, k, L)), np.zeros((k, k, L)),
            np.zeros((k, k, L)), np.zeros((k, k, L)), np.zeros(L), np.zeros(L),
            np.zeros((3, L))),
           (np.zeros((nu, L)), np.zeros((k, L)), np.zeros((m, L)), np.zeros(L),
            np.zeros((m, L)), np.zeros((nv, L))),
           (np.zeros(nq), np.zeros((ns, 3, 3)), np.zeros((nv, 6)), np.zeros((1, 3, 3))),
           (np.zeros((m, nu)), np.zeros((m, 1)), np.zeros((nu, 1))), _lsq_work(m, nu, ni),
           _work(PI, ni, nu),
           (np.zeros(L), np.zeros(L), np.zeros(L), np.zeros(L), np.zeros((ni, L)), np.zeros(L),
            np.zeros((nv, L)), np.zeros(L)),
           (np.zeros(L, dtype=np.int64), np.zeros(L, dtype=np.bool_),
            np.zeros(L, dtype=np.bool_)),
           _lane_work(PI, ni, nu),
           (np.zeros((nv, ni, L)), np.zeros((nv, L)), np.zeros((nv, L)),
            np.zeros((ni, ni, L)), np.zeros((ni, L)), np.zeros((ni, L)), np.zeros((3, L)),
            np.zeros(L)))
    cur, tri = _borrowed_lanes(own[0]), _borrowed_lanes(own[1])
    A, fa, T, tmp, T1, r1, w3, Tg = own[2]
    A, fa, T, tmp, T1 = _borrowed(A), _borrowed(fa), _borrowed(T), _borrowed(tmp), _borrowed(T1)
    r1, w3, Tg = _borrowed(r1), _borrowed(w3), _borrowed(Tg)
    J, G, Lc, Linv, Ginv, fl, il, vec = own[3]
    J, G, Lc, Linv, Ginv = _borrowed(J), _borrowed(G), _borrowed(Lc), _borrowed(Linv), \
        _borrowed(Ginv)
    fl, il, vec = _borrowed(fl), _borrowed(il), _borrowed(vec)
    X, T1l, T2l, acc, rs, stp = own[4]
    X, T1l, T2l, acc = _borrowed(X), _borrowed(T1l), _borrowed(T2l), _borrowed(acc)
    rs, stp = _borrowed(rs), _borrowed(stp)
    gq, grot, gS, R3 = own[5]
    gq, grot, gS, R3 = _borrowed(gq), _borrowed(grot), _borrowed(gS), _borrowed(R3)
    Jd, Rd, Xd = own[6]
    Jd, Rd, Xd = _borrowed(Jd), _borrowed(Rd), _borrowed(Xd)
    Wd, wk = _borrowed_lsq_work(own[7]), _borrowed_work(own[8])
    n_res, prev, inv0, wait, xd, bpx, bpa, rn_l = own[9]
    n_res, prev, inv0, wait = _borrowed(n_res), _borrowed(prev), _borrowed(inv0), \
        _borrowed(wait)
    xd, bpx, bpa, rn_l = _borrowed(xd), _borrowed(bpx), _borrowed(bpa), _borrowed(rn_l)
    n_its, done, ready = own[10]
    n_its, done, ready = _borrowed(n_its), _borrowed(done), _borrowed(ready)
    sc = own[11]
    lsc = (_borrowed(sc[0]), _borrowed(sc[1]), _borrowed(sc[2]), _borrowed(sc[3]),
           _borrowed(sc[4]), _borrowed(sc[5]), _borrowed(sc[6]), _borrowed(sc[7]),
           _borrowed(sc[8]), _borrowed(sc[9]), _borrowed(sc[10]), _borrowed(sc[11]),
           _borrowed(sc[12]), _borrowed(sc[13]))
    t_first, t_qd, t_qdd, t_M, t_h, t_Q, t_en, t_bound = own[12]
    t_first, t_qd, t_qdd, t_M = _borrowed(t_first), _borrowed(t_qd), _borrowed(t_qdd), \
        _borrowed(t_M)
    t_h, t_Q, t_en, t_bound = _borrowed(t_h), _borrowed(t_Q), _borrowed(t_en), \
        _borrowed(t_bound)
    PI, PF, PM, DI, DF = _borrowed(PI), _borrowed(PF), _borrowed(PM), _borrowed(DI), \
        _borrowed(DF)
    fopts, iopt, ucols, icols = _borrowed(fopts), _borrowed(iopt), _borrowed(ucols), \
        _borrowed(icols)
    members, bq, brot, bx, tangent, y, buf = _borrowed(members), _borrowed(bq), \
        _borrowed(brot), _borrowed(bx), _borrowed(tangent), _borrowed(y), _borrowed(buf)
    n_bad = 0
    for a0 in range(0, NA, L):
        LN = min(L, NA - a0)
        for l in range(LN):                     # the predictors (_predict), into the block
            a, b = a0 + l, members[a0 + l]
            o = b * blk
            xb, yb, blk_b = bx[b * ni:(b + 1) * ni], y[a * mm:(a + 1) * mm], buf[o:o + blk]
            has = _tangent_step(PI, PF, xb, tangent[b * nv:(b + 1) * nv], yb, blk_b, iopt,
                                stp[:, l], bpa[:, l])
            _keep_analogs(has, xb, bpa[:, l], bpx[l:l + 1], bpa[:, l])
            _to_lane(bq[b * nq:(b + 1) * nq], brot[b * ns:(b + 1) * ns], tri[0], tri[1], l)
        _lk.apply(PI, PF, tri[0], tri[1], stp, cur[0], cur[1], R3, LN)
        for l in range(LN):
            for i in range(ni):
                cur[0][PI[o_inq + i], l] = y[(a0 + l) * mm + i]
        _lk.evaluate(PI, PF, PM, cur[0], cur[1], cur[2], cur[3], cur[4], A, fa, T, Tg, tmp,
                     T1, r1, w3, LN)
        _lk.residual(cur[3], scale, rs, n_res, LN)
        for l in range(LN):
            prev[l], n_its[l], done[l], wait[l] = np.inf, 0, False, 0.0
            ready[l] = False
        n_ready = 0
        active = LN
        # A member that has converged keeps a zero step: the trial poses that the others'
        # line search makes are its own pose, bit for bit (q + 0, exp(0) R = R), and so
        # are its state, Jacobian and factor formed again there; its Newton's outputs stay
        # in the block (``cur``, ``J``, ``Ginv``, ``inv0``, ``n_res``, ``n_its``).
        for _ in range(maxiter):
            if active == 0:
                break
            _lk.jacobian(PI, PF, cur[4], ucols, J, LN)
            _lk.factor(J, G, Lc, Linv, Ginv, fl, il, vec, LN)
            _lk.solve(J, Ginv, rs, X, T1l, T2l, acc, LN)
            for l in range(LN):
                if done[l]:
                    continue
                n_its[l] += 1
                fast = fl[l] == 1.0
                if fast:
                    inv0[l] = il[l]
                else:                           # the truncated SVD, one member
                    _from_lane2(J, Jd, l)
                    fast, _, inv0[l] = _lsq(Jd, rank, Wd)
                    for r in range(m):
                        Rd[r, 0] = rs[r, l]
                    _dn_solve(Jd, fast, Wd[3], Wd[4], Wd[5], Wd[6], Rd, Xd, 0, Wd[8], Wd[9])
                    for c in range(nu):
                        X[c, l] = Xd[c, 0]
                big = 0.0
                for c in range(nu):
                    v = abs(X[c, l])
                    if v > big or v != v:
                        big = v
                stalled = n_its[l] > 1 and n_res[l] > 0.5 * prev[l]
                ism = inv0[l]
                if fast and inv0[l] > above:
                    _from_lane2(Ginv, Wd[3], l)
                    ism = _inv_smin(fast, inv0[l], above, Wd[3], Wd[2], Wd[7])
                tol_step = max(xtl, noise * ism)
                conv = big <= tol_step and (n_res[l] <= floor or stalled)
                prev[l] = n_res[l]
                for c in range(nv):
                    stp[c, l] = 0.0
                if conv:
                    done[l] = True
                    active -= 1
                    if fast:                    # its terms in lanes, once the Newton is done
                        ready[l] = True
                        n_ready += 1
                    continue
                fac = min(1.0, max_step / max(big, 1e-300))
                for c in range(nu):
                    stp[ucols[c], l] = -X[c, l] * fac
                wait[l] = 1.0                   # in the line search
            if active == 0:
                break
            # backtracking: the longest of 1, 1/2, 1/4 ... not raising the residual
            for hs in range(8):
                if hs:
                    for l in range(LN):
                        if not done[l] and wait[l] != 0.0:
                            for c in range(nv):
                                stp[c, l] *= 0.5
                _lk.apply(PI, PF, cur[0], cur[1], stp, tri[0], tri[1], R3, LN)
                _lk.evaluate(PI, PF, PM, tri[0], tri[1], tri[2], tri[3], tri[4], A, fa, T,
                             Tg, tmp, T1, r1, w3, LN)
                # every lane's residual (the same values in a lane that is not waiting: its
                # trial is the pose whose residual ``rs`` holds), then the tests
                _lk.residual(tri[3], scale, rs, rn_l, LN)
                left = 0
                for l in range(LN):
                    if done[l] or wait[l] == 0.0:
                        continue
                    rn = rn_l[l]
                    if rn <= n_res[l] * (1 + 1e-9) or rn < floor or hs == 7:
                        n_res[l] = rn
                        wait[l] = 0.0
                    else:
                        left += 1
                if left == 0:
                    break
            cur, tri = tri, cur                 # every member still running took its trial
        if n_ready:                             # the converged members' terms
            for l in range(LN):
                for i in range(ni):
                    xd[i, l] = y[(a0 + l) * mm + ni + i]
            _terms_lanes(PI, PF, DI, DF, cur[0], cur[2], cur[4], xd, ucols, icols, J, Ginv,
                         inv0, lsc, t_first, t_qd, t_qdd, t_M, t_h, t_Q, t_en, t_bound, LN)
            for l in range(LN):
                if not ready[l]:
                    continue
                a, b = a0 + l, members[a0 + l]
                o = b * blk
                _lane_terms_out(iopt, t_first, t_qd, t_qdd, t_M, t_h, t_Q, t_en, buf[o:o + blk],
                                l)
                _from_lane(cur[0], cur[1], gq, grot, l)
                _from_lane2(cur[4], gS, l)
                code = _settle(PI, PF, fopts, iopt, ucols, icols, gq, grot, gS, n_res[l],
                               n_its[l], np.int64(1), bq[b * nq:(b + 1) * nq],
                               brot[b * ns:(b + 1) * ns], bx[b * ni:(b + 1) * ni],
                               tangent[b * nv:(b + 1) * nv], y[a * mm:(a + 1) * mm],
                               buf[o:o + blk], wk, True, t_bound[l])
                buf[o + iopt[B_CODE]] = code
                if code != OK:
                    n_bad += 1
                buf[o + o_px] = bpx[l]              # the base before, for the next predictor
                for c in range(nv):
                    buf[o + o_pa + c] = bpa[c, l]
        for l in range(LN):                     # the others: the one-member stage, again
            if not ready[l]:
                a = a0 + l
                n_bad += _stage_members(PI, PF, PM, DI, DF, fopts, iopt, ucols, icols,
                                        members[a:a + 1], bq, brot, bx, tangent,
                                        y[a * mm:(a + 1) * mm], buf)
    _keep_alive(own)
    return n_bad


@numba.njit(inline="always", **_JIT)
def _borrowed_lanes(st):
    """:func:`closure.solve_kernels._borrowed` of every array of a block state."""
    return (_borrowed(st[0]), _borrowed(st[1]), _borrowed(st[2]), _borrowed(st[3]),
            _borrowed(st[4]))


@numba.njit(inline="always", **_JIT)
def _lane_terms_out(iopt, first, qd, qdd, M, h, Q, en, blk, l):
    """Lane ``l`` of :func:`_terms_lanes`' outputs into a member's block ``blk``
    (:func:`layout`)."""
    nv, ni = first.shape[0], first.shape[1]
    o_f, o_qd, o_qdd, o_M = iopt[B_FIRST], iopt[B_QD], iopt[B_QDD], iopt[B_M]
    o_h, o_Q, o_en = iopt[B_H], iopt[B_Q], iopt[B_EN]
    for c in range(nv):
        for i in range(ni):
            blk[o_f + ni * c + i] = first[c, i, l]
        blk[o_qd + c] = qd[c, l]
        blk[o_qdd + c] = qdd[c, l]
    for i in range(ni):
        for j in range(ni):
            blk[o_M + ni * i + j] = M[i, j, l]
        blk[o_h + i], blk[o_Q + i] = h[i, l], Q[i, l]
    for i in range(3):
        blk[o_en + i] = en[i, l]


@numba.njit(inline="always", **_JIT)
def _to_lane(q, rot, ql, rotl, l):
    """One member's ``q`` (nq,), ``rot`` (ns, 3, 3) into lane ``l`` of a block."""
    for i in range(q.shape[0]):
        ql[i, l] = q[i]
    for s in range(rot.shape[0]):
        for a in range(3):
            for b in range(3):
                rotl[s, a, b, l] = rot[s, a, b]


@numba.njit(inline="always", **_JIT)
def _from_lane(ql, rotl, q, rot, l):
    """Lane ``l`` of a block's ``q``, ``rot`` into one member's (:func:`_to_lane`)."""
    for i in range(q.shape[0]):
        q[i] = ql[i, l]
    for s in range(rot.shape[0]):
        for a in range(3):
            for b in range(3):
                rot[s, a, b] = rotl[s, a, b, l]


@numba.njit(inline="always", **_JIT)
def _from_lane2(Ml, M, l):
    """Lane ``l`` of ``Ml`` (r, c, L) into ``M`` (r, c)."""
    for a in range(M.shape[0]):
        for b in range(M.shape[1]):
            M[a, b] = Ml[a, b, l]


@numba.njit(inline="always", **_JIT)
def _adopt(q, rot, bq, brot, bx, y):
    """The corrected pose ``q`` (nq,), ``rot`` (ns, 3, 3) at inputs ``y[:ni]`` becomes the
    base."""
    for i in range(bq.shape[0]):
        bq[i] = q[i]
    for s in range(brot.shape[0]):
        for a in range(3):
            for b in range(3):
                brot[s, a, b] = rot[s, a, b]
    for i in range(bx.shape[0]):
        bx[i] = y[i]


@_njit
def nearest_poses(T, t, members, bq, brot, bx, tangent, near, sq, srot, sx, stan):
    """Keep, for each output time, the solved pose of each member nearest to it in time
    (the bases of its poses there: :func:`closure.batch_dynamics.simulate_batch`).

    Member ``a`` of a call (the batch's member ``g = members[a]``) was solved at the time
    ``t[a]``: its base pose ``bq[g]`` (nq,), ``brot[g]`` (ns, 3, 3), inputs ``bx[g]`` and
    ``tangent[g]`` (nv, ni) becomes the kept pose ``sq[g, k]``, ``srot[g, k]``, ``sx[g, k]``,
    ``stan[g, k]`` of the output times ``T[k]`` either side of ``t[a]`` (``T`` ascending;
    times of a backward run negated) where it is nearer than the one kept, ``near[g, k]``
    (initially inf) its distance in time."""
    for a in range(members.shape[0]):
        g = members[a]
        _keep_nearest(T, t[a], g, bq[g], brot[g], bx[g], tangent[g], near, sq, srot, sx, stan)


@numba.njit(inline="always", **_JIT)
def _keep_nearest(T, ta, g, q, rot, x, tan, near, sq, srot, sx, stan):
    """:func:`nearest_poses` of member ``g`` solved at the time ``ta``: its pose ``q`` (nq,),
    ``rot`` (ns, 3, 3), ``x`` (ni,), ``tan`` (nv, ni)."""
    N = T.shape[0]
    lo, hi = 0, N                               # the first output time at or after ta
    while lo < hi:
        mid = (lo + hi) // 2
        if T[mid] < ta:
            lo = mid + 1
        else:
            hi = mid
    for k in range(max(lo - 1, 0), min(lo + 1, N)):
        d = abs(ta - T[k])
        if d < near[g, k]:
            near[g, k] = d
            for i in range(q.shape[0]):
                sq[g, k, i] = q[i]
            for s_ in range(rot.shape[0]):
                for i in range(3):
                    for j in range(3):
                        srot[g, k, s_, i, j] = rot[s_, i, j]
            for i in range(x.shape[0]):
                sx[g, k, i] = x[i]
            for c in range(tan.shape[0]):
                for i in range(tan.shape[1]):
                    stan[g, k, c, i] = tan[c, i]
