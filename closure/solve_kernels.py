"""Compiled kernels of the position solver (numba): kinematic state, loop Jacobian,
minimum-norm steps, damped Newton and continuation, one pose at a time.

Every kernel loops over the members of a batch and treats each on its own (the batched
numpy code they replace decided per member too), so one pose and a batch of 2,048 run the
same instructions and a member's result does not depend on the batch it is in.  The
mechanism's structure comes packed once per compiled tree (:func:`pack`, kept by
:class:`closure.state.Plan`) into three arrays: ``PI`` (int64: counts, then each table's
offset, then the tables: joint kinds, coordinate offsets, the tree's links in BFS order,
the chords, the columns' joints and axes, the inputs and unknowns), ``PF`` (float64:
pitches, centre, scale, the U joint's middle rotation, the row map to dimensionless twists
about the centre, the loop coefficients, the columns' weights and scales) and ``PM``
(the constant 4x4 frames: joints on link a, either side of each tree joint, the chords'
link-b frames inverted).  Three arrays rather than a tuple of forty keep the compiled code
small (every array passed costs code at every call).

The algorithms are those of the numpy code they replace (the same formulas, branch tests
and tolerances, IEEE arithmetic as numpy's: ``error_model="numpy"``), so results agree
with it to rounding:

* :func:`_evaluate` — joint matrices ``A(q)``, link poses through the spanning tree,
  joint frames, loop residual twists (``log`` of the loop transforms about the centre)
  and the world twists of the velocity coordinates (:meth:`closure.state.Plan.evaluate`);
* :func:`_factor`, :func:`_svd_parts`, :func:`_lsq_solve`, :func:`_inv_smin` — the
  pseudo-inverse truncated to the expected rank, by Cholesky of the Gram matrix (``J Jᵀ``
  wide, ``Jᵀ J`` tall) with one step of iterative refinement where the condition
  estimate ``sqrt(‖J‖²_F · tr G⁻¹)`` is at most ``FAST_COND``, by the truncated SVD
  (LAPACK's gesdd, as numpy) elsewhere (:class:`closure.lstsq._LstSq`): singular values
  are computed only for SVD poses (the exact condition numbers asked for later come from
  numpy's SVD without the vectors, :meth:`closure.state.Plan.condition`);
* :func:`_pattern`, :func:`_sp_factor`, :func:`_sp_solve`, :func:`_sp_inv_smin` — the
  same least squares for the solver, on the Jacobian's block structure: column c enters
  loop l only where its loop coefficient is not zero, so a chain of loops that share few
  joints has a block-banded Jacobian, and its Gram matrix is factored on its envelope
  (Cholesky, tr G⁻¹ by the selected inverse, triangular solves): the cost of a step is
  linear in the number of loops.  The same sums as the dense kernels less their zero
  terms (steps equal to rounding); a full envelope (one loop) uses the dense kernels,
  whose values it then has bit for bit;
* :func:`drive` — damped Gauss–Newton with backtracking and the fused first analogs
  (:func:`closure.solver.newton`; :func:`_newton`, which batched forward dynamics also
  runs, :mod:`closure.dynamics_kernels`), and the continuation around it: predictor along the
  analogs, corrector, acceptance and step halving (:func:`closure.solver._continue`), for
  a batch of targets or a sweep's rows, or the whole batch solve from guesses
  (``SOLVE``: each guess corrected, then continued, its state in the kernel's scratch),
  each member on its own.

Inside a member the helpers take whole arrays and indices rather than views, and
:func:`drive` works on borrowed arrays (:func:`_borrowed`: no reference count), so the
views, tuples and calls of the inner loop make no atomic reference-count updates (each
costs more than a 4x4 product's arithmetic; together they were a third of the solver's
time).

numba compiles the kernels on the first solve (``cache=True``: once per installation,
then loaded from the cache); :mod:`closure.state` imports this module when a mechanism is
first compiled, so ``import closure`` does not import numba.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .lstsq import FAST_COND, SINGULAR_RTOL      # constants of the kernels once compiled

from numba.core import cgutils                  # noqa: E402  (numba's own helpers)
from numba.extending import intrinsic           # noqa: E402

__all__ = ["pack", "KIND_CODE", "drive", "evaluate_batch", "twists_batch", "apply_batch",
           "distance_batch", "scaled_jacobian_batch", "lsq_batch", "NEWTON", "CONTINUE",
           "SWEEP", "SOLVE"]

_JIT = dict(cache=True, nogil=True, error_model="numpy")

#: joint kind → code used by the kernels
KIND_CODE = {"R": 0, "P": 1, "C": 2, "H": 3, "U": 4, "S": 5}

# PI's header: counts, then the offsets of the tables in PI, PF and PM
(H_NJ, H_NL, H_NC, H_NV,
 O_KIND, O_QOFF, O_SIDX, O_JLA, O_TLI, O_TPL, O_TJ, O_TFWD, O_CJ, O_CLB, O_COLJ, O_KW, O_KV,
 O_UQ0, O_SCALV, O_SCALQ, O_SCOLS, O_SORD, O_INV, O_INQ, O_UNK,
 F_PITCH, F_CENTRE, F_SCALE, F_OFFSET, F_UMID, F_ROWMAP, F_LOOP, F_SW, F_SV, F_COLSC, F_INCS,
 F_INSC, F_UNKCS,
 M_FA, M_TL, M_TR, M_CFBI, HEADER) = range(43)


def pack(plan, mech, tree):
    """The kernels' view of a compiled mechanism: ``(PI, PF, PM)`` (module notes)."""
    joints = mech.joints
    t = tree
    order = list(t.order[1:])
    tree_pl = []
    for li in order:
        j = joints[t.parent_joint[li]]
        tree_pl.append(t.link_index[j.link_a] if t.forward[li] else t.link_index[j.link_b])
    col_uq0 = np.full(t.nv, -1)                 # the U joints' second pins: their φ column
    for j in joints:
        if j.kind == "U":
            col_uq0[t.v_offset[j.index] + 1] = t.q_offset[j.index]
    ints = {O_KIND: [KIND_CODE[j.kind] for j in joints], O_QOFF: t.q_offset,
            O_SIDX: t.s_index, O_JLA: t.joint_link_a, O_TLI: order, O_TPL: tree_pl,
            O_TJ: [t.parent_joint[li] for li in order],
            O_TFWD: [int(t.forward[li]) for li in order], O_CJ: plan.chords,
            O_CLB: plan.chord_link_b, O_COLJ: plan.col_joint, O_KW: plan.kw, O_KV: plan.kv,
            O_UQ0: col_uq0, O_SCALV: plan.scal_v, O_SCALQ: plan.scal_q,
            O_SCOLS: plan.s_cols.reshape(-1), O_SORD: plan.s_order, O_INV: plan.input_v,
            O_INQ: plan.input_q, O_UNK: plan.unknown}
    flts = {F_PITCH: [j.pitch for j in joints], F_CENTRE: t.centre, F_SCALE: [t.scale],
            F_OFFSET: [plan.offset], F_UMID: plan._u_mid[:3, :3].reshape(-1),
            F_ROWMAP: plan.row_map.reshape(-1), F_LOOP: plan.loop_scaled.reshape(-1),
            F_SW: plan.sw, F_SV: plan.sv, F_COLSC: plan.col_scale, F_INCS: plan.input_cscale,
            F_INSC: plan.input_scale, F_UNKCS: plan.unknown_cscale}
    mats = {M_FA: plan.frames_a, M_TL: plan.tree_left, M_TR: plan.tree_right,
            M_CFBI: plan.chord_fbi}
    head = np.zeros(HEADER, dtype=np.int64)
    head[[H_NJ, H_NL, H_NC, H_NV]] = len(joints), len(t.links), len(t.chords), t.nv
    parts, n = [head], HEADER
    for key, v in ints.items():
        v = np.asarray(v, dtype=np.int64).reshape(-1)
        head[key] = n
        parts.append(v)
        n += v.size
    PI = np.concatenate(parts)
    parts, n = [], 0
    for key, v in flts.items():
        v = np.asarray(v, dtype=float).reshape(-1)
        PI[key] = n
        parts.append(v)
        n += v.size
    PF = np.concatenate(parts)
    parts, n = [], 0
    for key, v in mats.items():
        v = np.asarray(v, dtype=float).reshape(-1, 4, 4)
        PI[key] = n
        parts.append(v)
        n += v.shape[0]
    PM = np.ascontiguousarray(np.concatenate(parts))
    return PI, PF, PM


# ---------------------------------------------------------------------- small rigid algebra
# A rigid transform is carried as the 12 values of its top three rows (a tuple: registers,
# not memory), read from and written to whole arrays at an index (a view costs two atomic
# reference-count updates, several times a 4x4 product's own work); a chain of products
# then keeps its intermediate transforms out of memory.
@numba.njit(inline="always", **_JIT)
def _rigid(T, it):
    """The top three rows of the rigid transform ``T[it]``, row by row (12 values)."""
    return (T[it, 0, 0], T[it, 0, 1], T[it, 0, 2], T[it, 0, 3],
            T[it, 1, 0], T[it, 1, 1], T[it, 1, 2], T[it, 1, 3],
            T[it, 2, 0], T[it, 2, 1], T[it, 2, 2], T[it, 2, 3])


@numba.njit(inline="always", **_JIT)
def _rigid_put(t, out, io):
    """``out[io]``: the rigid transform of the 12 values ``t`` (:func:`_rigid`)."""
    out[io, 0, 0], out[io, 0, 1], out[io, 0, 2], out[io, 0, 3] = t[0], t[1], t[2], t[3]
    out[io, 1, 0], out[io, 1, 1], out[io, 1, 2], out[io, 1, 3] = t[4], t[5], t[6], t[7]
    out[io, 2, 0], out[io, 2, 1], out[io, 2, 2], out[io, 2, 3] = t[8], t[9], t[10], t[11]
    out[io, 3, 0], out[io, 3, 1], out[io, 3, 2], out[io, 3, 3] = 0.0, 0.0, 0.0, 1.0


@numba.njit(inline="always", **_JIT)
def _rigid_mul(a, b):
    """``a @ b`` of rigid transforms given as 12 values (:func:`_rigid`)."""
    a00, a01, a02, a03, a10, a11, a12, a13, a20, a21, a22, a23 = a
    b00, b01, b02, b03, b10, b11, b12, b13, b20, b21, b22, b23 = b
    return (a00 * b00 + a01 * b10 + a02 * b20, a00 * b01 + a01 * b11 + a02 * b21,
            a00 * b02 + a01 * b12 + a02 * b22, a00 * b03 + a01 * b13 + a02 * b23 + a03,
            a10 * b00 + a11 * b10 + a12 * b20, a10 * b01 + a11 * b11 + a12 * b21,
            a10 * b02 + a11 * b12 + a12 * b22, a10 * b03 + a11 * b13 + a12 * b23 + a13,
            a20 * b00 + a21 * b10 + a22 * b20, a20 * b01 + a21 * b11 + a22 * b21,
            a20 * b02 + a21 * b12 + a22 * b22, a20 * b03 + a21 * b13 + a22 * b23 + a23)


@numba.njit(inline="always", **_JIT)
def _rigid_inv(t):
    """The inverse of the rigid transform given as 12 values (:func:`_rigid`)."""
    r00, r01, r02, p0, r10, r11, r12, p1, r20, r21, r22, p2 = t
    return (r00, r10, r20, -(r00 * p0 + r10 * p1 + r20 * p2),
            r01, r11, r21, -(r01 * p0 + r11 * p1 + r21 * p2),
            r02, r12, r22, -(r02 * p0 + r12 * p1 + r22 * p2))


# sin and cos of the joint angles: Cody–Waite reduction by π/2 (π/2 in three parts of
# 33, 33 and 53 bits, so k·P1 and k·P2 are exact for |k| < 2^20) and the Taylor series on
# |r| ≤ π/4 to r¹⁷ and r¹⁸ (the next terms below 1e-19); within 2 ulp of the exact value
# for |x| < 1e5 (libm's are within 0.5 ulp), libm's beyond.  Plain arithmetic, no call, so
# the lane kernels' loops over members (closure.lane_kernels) run it in SIMD lanes; both
# layouts call the same function and agree bit for bit.
_PIO2_1 = float.fromhex("0x1.921fb54400000p+0")
_PIO2_2 = float.fromhex("0x1.0b4611a600000p-34")
_PIO2_3 = float.fromhex("0x1.3198a2e037073p-69")
_INV_PIO2 = float.fromhex("0x1.45f306dc9c883p-1")
_S3, _S5, _S7, _S9, _S11, _S13, _S15, _S17 = (
    (-1.0) ** k / math.factorial(2 * k + 1) for k in range(1, 9))
_C4, _C6, _C8, _C10, _C12, _C14, _C16, _C18 = (
    (-1.0) ** k / math.factorial(2 * k) for k in range(2, 10))
#: where the reduction above stops being exact enough: libm's sin and cos beyond
SINCOS_REDUCED = 1e5


@numba.njit(inline="always", **_JIT)
def _sincos_reduced(x):
    """``(sin x, cos x)`` by the reduction and series above, for |x| < SINCOS_REDUCED.
    Beyond it and for non-finite x the values are meaningless (the callers replace them:
    :func:`_sincos`, the lane kernels' ``_sincos_beyond``) but defined: the quadrant's
    conversion to an integer stays in range there too."""
    k = math.floor(x * _INV_PIO2 + 0.5)
    r = ((x - k * _PIO2_1) - k * _PIO2_2) - k * _PIO2_3
    z = r * r
    s = r + r * z * (_S3 + z * (_S5 + z * (_S7 + z * (_S9 + z * (_S11 + z * (
        _S13 + z * (_S15 + z * _S17)))))))
    if abs(r) < 7.450580596923828e-09:          # 2^-27: sin r = r (and −0 stays −0)
        s = r
    hz = 0.5 * z
    w = 1.0 - hz                                # 1 − r²/2 and its rounding error
    c = w + (((1.0 - w) - hz) + z * z * (_C4 + z * (_C6 + z * (_C8 + z * (_C10 + z * (
        _C12 + z * (_C14 + z * (_C16 + z * _C18))))))))
    q = np.int64(k if abs(k) < 1048576.0 else 0.0)      # the quadrant (|k| < 2^20 here)
    a = c if q & 1 else s
    b = s if q & 1 else c
    return (-a if q & 2 else a), (-b if (q + 1) & 2 else b)


@numba.njit(inline="always", **_JIT)
def _sincos(x):
    """``(sin x, cos x)`` (notes above): :func:`_sincos_reduced`, libm's for |x| ≥
    SINCOS_REDUCED and non-finite x."""
    if not abs(x) < SINCOS_REDUCED:
        return math.sin(x), math.cos(x)
    return _sincos_reduced(x)


@numba.njit(**_JIT)
def _exp_so3(w0, w1, w2, out, io):
    """``out[io]``: the rotation matrix of the rotation vector ``w`` (series near 0, as
    :func:`closure.exp_so3`)."""
    th2 = w0 * w0 + w1 * w1 + w2 * w2
    if th2 < 1e-8:
        a = 1 - th2 / 6 + th2 ** 2 / 120
        b = 0.5 - th2 / 24 + th2 ** 2 / 720
    else:
        th = math.sqrt(th2)
        a = math.sin(th) / th
        b = (1 - math.cos(th)) / th ** 2
    K = ((0.0, -w2, w1), (w2, 0.0, -w0), (-w1, w0, 0.0))
    for i in range(3):
        for j in range(3):
            kk = K[i][0] * K[0][j] + K[i][1] * K[1][j] + K[i][2] * K[2][j]
            out[io, i, j] = (1.0 if i == j else 0.0) + a * K[i][j] + b * kk


@numba.njit(**_JIT)
def _log_so3(R, ir, out):
    """Rotation vector ``out`` (3,) of the rotation ``R[ir, :3, :3]`` at any angle (as
    :func:`closure.frames._log_so3`: past a quarter turn the axis from the symmetric
    part)."""
    v0 = 0.5 * (R[ir, 2, 1] - R[ir, 1, 2])
    v1 = 0.5 * (R[ir, 0, 2] - R[ir, 2, 0])
    v2 = 0.5 * (R[ir, 1, 0] - R[ir, 0, 1])
    s = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    th = math.atan2(s, (R[ir, 0, 0] + R[ir, 1, 1] + R[ir, 2, 2] - 1) / 2)
    if th < 1e-5:
        sc = 1 + th ** 2 / 6 + 7 * th ** 4 / 360
    else:
        sc = th / math.sin(th)
    out[0], out[1], out[2] = v0 * sc, v1 * sc, v2 * sc
    if th > np.pi / 2:
        c = math.cos(th)
        best, k = -np.inf, 0
        for i in range(3):
            d = ((R[ir, i, i] + R[ir, i, i]) / 2 - c) / (1 - c)
            if d > best:
                best, k = d, i
        a0 = ((R[ir, 0, k] + R[ir, k, 0]) / 2 - (c if k == 0 else 0.0)) / (1 - c)
        a1 = ((R[ir, 1, k] + R[ir, k, 1]) / 2 - (c if k == 1 else 0.0)) / (1 - c)
        a2 = ((R[ir, 2, k] + R[ir, k, 2]) / 2 - (c if k == 2 else 0.0)) / (1 - c)
        n = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        a0, a1, a2 = a0 / n, a1 / n, a2 / n
        d = a0 * v0 + a1 * v1 + a2 * v2
        sg = -1.0 if d < 0 else 1.0
        out[0], out[1], out[2] = a0 * sg * th, a1 * sg * th, a2 * sg * th


@numba.njit(inline="always", **_JIT)
def _rot_log(R, ir, out):
    """Rotation vector ``out`` (3,) of the rotation ``R[ir, :3, :3]`` below a quarter turn
    (as :func:`closure.state._rot_log`); returns ``(θ, θ², sin θ, cos θ)``, or θ = −1
    (``out`` untouched) when it turns a quarter turn or more."""
    v0 = 0.5 * (R[ir, 2, 1] - R[ir, 1, 2])
    v1 = 0.5 * (R[ir, 0, 2] - R[ir, 2, 0])
    v2 = 0.5 * (R[ir, 1, 0] - R[ir, 0, 1])
    cth = 0.5 * (R[ir, 0, 0] + R[ir, 1, 1] + R[ir, 2, 2] - 1.0)
    if not cth > 0.0:
        return -1.0, 0.0, 0.0, 0.0
    th = math.atan2(math.sqrt(v0 * v0 + v1 * v1 + v2 * v2), cth)
    th2 = th * th
    s_, c_ = _sincos(th)
    if th2 < 1e-10:
        sc = 1 + th2 / 6 + 7 * th2 * th2 / 360
    else:
        sc = th / s_
    out[0], out[1], out[2] = v0 * sc, v1 * sc, v2 * sc
    return th, th2, s_, c_


@numba.njit(inline="always", **_JIT)
def _loop_log(G, ig, r, ir, w):
    """``r[ir]``: the twist ``(v, ω)``, ``log`` of the loop transform ``G[ig]`` (as
    :func:`closure.state._loop_log`, with :func:`closure.frames._log_se3` past a quarter
    turn); ``w`` (3,) scratch."""
    th, th2, s_, c_ = _rot_log(G, ig, w)
    if th < 0.0:
        _log_so3(G, ig, w)
        th2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
        if th2 < 1e-8:
            e = 1 / 12 + th2 / 720
        else:
            t = math.sqrt(th2)
            e = (1 - t * math.sin(t) / (2 * (1 - math.cos(t)))) / t ** 2
    elif th2 < 1e-8:
        e = 1 / 12 + th2 / 720
    else:
        e = (1 - th * s_ / (2 * (1 - c_))) / th2
    p0, p1, p2 = G[ig, 0, 3], G[ig, 1, 3], G[ig, 2, 3]
    w0, w1, w2 = w[0], w[1], w[2]
    # V⁻¹ p = p − ½ ω × p + e ω × (ω × p)
    c0 = w1 * p2 - w2 * p1
    c1 = w2 * p0 - w0 * p2
    c2 = w0 * p1 - w1 * p0
    d0 = w1 * c2 - w2 * c1
    d1 = w2 * c0 - w0 * c2
    d2 = w0 * c1 - w1 * c0
    r[ir, 0] = p0 - 0.5 * c0 + e * d0
    r[ir, 1] = p1 - 0.5 * c1 + e * d1
    r[ir, 2] = p2 - 0.5 * c2 + e * d2
    r[ir, 3], r[ir, 4], r[ir, 5] = w0, w1, w2


# ---------------------------------------------------------------------- array helpers
@intrinsic
def _borrowed(typingctx, arr):
    """``arr`` without its reference count: the same data, shape and strides, no meminfo
    (numba then skips the atomic reference-count updates on every view, tuple and call
    that carries it, which otherwise cost the solver about a third of its time).  Only for
    arrays that outlive every use of the borrowed one: :func:`drive` borrows its arguments
    and the scratch it allocated, which it keeps to its end (:func:`_keep_alive`)."""
    def codegen(context, builder, sig, args):
        src = context.make_array(sig.args[0])(context, builder, value=args[0])
        out = context.make_array(sig.return_type)(context, builder, value=src._getvalue())
        out.meminfo = cgutils.get_null_value(out.meminfo.type)
        out.parent = cgutils.get_null_value(out.parent.type)
        return out._getvalue()
    return arr(arr), codegen


@intrinsic
def _flat(typingctx, arr):
    """The C-contiguous ``arr`` as a flat, borrowed (:func:`_borrowed`) view: its data
    with shape ``(arr.size,)``, made inline (``reshape`` calls numba's helper)."""
    from numba.core import types
    if not isinstance(arr, types.Array) or arr.layout != "C":
        return None
    flat = types.Array(arr.dtype, 1, "C")

    def codegen(context, builder, sig, args):
        src = context.make_array(sig.args[0])(context, builder, value=args[0])
        out = context.make_array(flat)(context, builder)
        context.populate_array(out, data=src.data, shape=[src.nitems],
                               strides=[src.itemsize], itemsize=src.itemsize, meminfo=None)
        return out._getvalue()
    return flat(arr), codegen


@numba.njit(inline="always", **_JIT)
def _keep_alive(owners):
    """Nothing: a use of ``owners`` that keeps them (and the arrays borrowed from them)
    alive up to this call."""
    return None


@numba.njit(**_JIT)
def _borrowed_state(st):
    """:func:`_borrowed` of every array of a member's state tuple."""
    return (_borrowed(st[0]), _borrowed(st[1]), _borrowed(st[2]), _borrowed(st[3]),
            _borrowed(st[4]), _borrowed(st[5]), _borrowed(st[6]), _borrowed(st[7]))


@numba.njit(**_JIT)
def _copy(src, dst):
    """``dst[...] = src`` for C-contiguous arrays of one shape (a flat loop: numba's
    broadcasting assignment compiles to far more code)."""
    s, d = _flat(src), _flat(dst)
    for i in range(s.size):
        d[i] = s[i]


@numba.njit(**_JIT)
def _fill(dst, v):
    """``dst[...] = v`` for a C-contiguous array."""
    d = _flat(dst)
    for i in range(d.size):
        d[i] = v


# ---------------------------------------------------------------------- kinematic state
@numba.njit(**_JIT)
def _evaluate(PI, PF, PM, q, rot, A, link, fa, r, S, T, w3):
    """The kinematic state of one member: ``A`` (nj, 4, 4), ``link`` (nl, 4, 4), ``fa``
    (nj, 4, 4), ``r`` (nc, 6) and ``S`` (nv, 6) overwritten
    (:meth:`closure.state.Plan.evaluate`); ``T`` (3, 4, 4) and ``w3`` (3,) scratch."""
    nj, nc = PI[H_NJ], PI[H_NC]
    t2 = np.int64(2)                    # T's slot of the loop transform
    o_kind, o_qoff, o_sidx, o_pitch, o_um = PI[O_KIND], PI[O_QOFF], PI[O_SIDX], PI[F_PITCH], \
        PI[F_UMID]
    # joint matrices
    for j in range(nj):
        for a in range(4):
            for b in range(4):
                A[j, a, b] = 1.0 if a == b else 0.0
        k = PI[o_kind + j]
        qj = PI[o_qoff + j]
        if k == 0 or k == 2 or k == 3:                 # R, C, H: Rz(θ)
            s, c = _sincos(q[qj])
            A[j, 0, 0], A[j, 0, 1], A[j, 1, 0], A[j, 1, 1] = c, -s, s, c
            if k == 2:
                A[j, 2, 3] = q[qj + 1]
            elif k == 3:
                A[j, 2, 3] = q[qj] * PF[o_pitch + j]
        elif k == 1:                                    # P: Tz(s)
            A[j, 2, 3] = q[qj]
        elif k == 5:                                    # S: the rotation
            si = PI[o_sidx + j]
            for a in range(3):
                for b in range(3):
                    A[j, a, b] = rot[si, a, b]
        else:                                           # U: Rz(φ) Ry(π/2) Rz(θ)
            s, c = _sincos(q[qj])
            s2, c2 = _sincos(q[qj + 1])
            for b in range(3):                          # Rz(φ) umid into T[0, :3, :3]
                T[0, 0, b] = c * PF[o_um + b] - s * PF[o_um + 3 + b]
                T[0, 1, b] = s * PF[o_um + b] + c * PF[o_um + 3 + b]
                T[0, 2, b] = PF[o_um + 6 + b]
            for a in range(3):                          # ... Rz(θ)
                A[j, a, 0] = T[0, a, 0] * c2 + T[0, a, 1] * s2
                A[j, a, 1] = T[0, a, 0] * -s2 + T[0, a, 1] * c2
                A[j, a, 2] = T[0, a, 2]
    # links through the tree, parents first: T_link = T_parent (left A^±1 right)
    for a in range(4):
        for b in range(4):
            link[0, a, b] = 1.0 if a == b else 0.0
    o_tli, o_tpl, o_tj, o_tfwd = PI[O_TLI], PI[O_TPL], PI[O_TJ], PI[O_TFWD]
    m_tl, m_tr = PI[M_TL], PI[M_TR]
    for k in range(PI[H_NL] - 1):
        aj = _rigid(A, PI[o_tj + k])
        if not PI[o_tfwd + k]:
            aj = _rigid_inv(aj)
        t = _rigid_mul(_rigid_mul(_rigid(PM, m_tl + k), aj), _rigid(PM, m_tr + k))
        li, pl = PI[o_tli + k], PI[o_tpl + k]
        if pl != 0:
            t = _rigid_mul(_rigid(link, pl), t)
        _rigid_put(t, link, li)
    o_jla, m_fa = PI[O_JLA], PI[M_FA]
    for j in range(nj):
        la = PI[o_jla + j]
        if la == 0:                                     # on the ground: I · F_a
            for a in range(3):
                for b in range(4):
                    fa[j, a, b] = PM[m_fa + j, a, b]
            fa[j, 3, 0], fa[j, 3, 1], fa[j, 3, 2], fa[j, 3, 3] = 0.0, 0.0, 0.0, 1.0
        else:
            _rigid_put(_rigid_mul(_rigid(link, la), _rigid(PM, m_fa + j)), fa, j)
    # loops: G = F_a A F_b⁻¹ T_b⁻¹ about the centre, and its log
    o_cj, o_clb, m_cf, o_c = PI[O_CJ], PI[O_CLB], PI[M_CFBI], PI[F_CENTRE]
    c0, c1, c2 = PF[o_c], PF[o_c + 1], PF[o_c + 2]
    for k in range(nc):
        c = PI[o_cj + k]
        t = _rigid_mul(_rigid_mul(_rigid(fa, c), _rigid(A, c)), _rigid(PM, m_cf + k))
        _rigid_put(_rigid_mul(t, _rigid_inv(_rigid(link, PI[o_clb + k]))), T, t2)
        for a in range(3):
            T[2, a, 3] += (T[2, a, 0] * c0 + T[2, a, 1] * c1 + T[2, a, 2] * c2) - PF[o_c + a]
        _loop_log(T, t2, r, k, w3)
    _twists(PI, PF, q, fa, S)


@numba.njit(inline="always", **_JIT)
def _twists(PI, PF, q, fa, S):
    """World twists ``S`` (nv, 6) of the velocity coordinates from the joint frames ``fa``:
    ``ω = s_w R e_kw`` (a U joint's second pin: ``R Rz(φ) umid e_z``), ``v = p × ω +
    s_v R e_kv`` (:meth:`closure.state.Plan.twists`)."""
    o_colj, o_kw, o_kv, o_uq0 = PI[O_COLJ], PI[O_KW], PI[O_KV], PI[O_UQ0]
    o_sw, o_sv, o_um = PI[F_SW], PI[F_SV], PI[F_UMID]
    u02, u12, u22 = PF[o_um + 2], PF[o_um + 5], PF[o_um + 8]
    for ci in range(PI[H_NV]):
        j = PI[o_colj + ci]
        u = PI[o_uq0 + ci]
        if u >= 0:
            s, c = _sincos(q[u])
            e0 = c * u02 - s * u12
            e1 = s * u02 + c * u12
            e2 = u22
            w0 = fa[j, 0, 0] * e0 + fa[j, 0, 1] * e1 + fa[j, 0, 2] * e2
            w1 = fa[j, 1, 0] * e0 + fa[j, 1, 1] * e1 + fa[j, 1, 2] * e2
            w2 = fa[j, 2, 0] * e0 + fa[j, 2, 1] * e1 + fa[j, 2, 2] * e2
        else:
            a = PI[o_kw + ci]
            w0, w1, w2 = fa[j, 0, a], fa[j, 1, a], fa[j, 2, a]
        sw = PF[o_sw + ci]
        if sw != 1.0:
            w0, w1, w2 = w0 * sw, w1 * sw, w2 * sw
        p0, p1, p2 = fa[j, 0, 3], fa[j, 1, 3], fa[j, 2, 3]
        S[ci, 3], S[ci, 4], S[ci, 5] = w0, w1, w2
        v0 = p1 * w2 - p2 * w1
        v1 = p2 * w0 - p0 * w2
        v2 = p0 * w1 - p1 * w0
        sv = PF[o_sv + ci]
        if sv != 0.0:
            a = PI[o_kv + ci]
            v0 += fa[j, 0, a] * sv
            v1 += fa[j, 1, a] * sv
            v2 += fa[j, 2, a] * sv
        S[ci, 0], S[ci, 1], S[ci, 2] = v0, v1, v2


@numba.njit(inline="always", **_JIT)
def _scaled_residual(r, scale, out):
    """Dimensionless loop residual (translations / scale) into ``out``; returns its largest
    absolute entry (0 without loops)."""
    big = 0.0
    for k in range(r.shape[0]):
        for s in range(6):
            v = r[k, s] / scale if s < 3 else r[k, s]
            out[6 * k + s] = v
            if abs(v) > big or v != v:
                big = abs(v)
    return big


@numba.njit(inline="always", **_JIT)
def _twist_rows(PF, o_rm, S, c):
    """The dimensionless twist about the centre of column ``c`` of the twists ``S``, six
    values: ``Σ_t row_map[s, t] S[c, t]`` for the row map at ``PF[o_rm]``, which maps
    ``(v, ω)`` to ``((v + ω × c) / L, ω)`` (:class:`closure.state.Plan`): its entries known
    to be zero or one are not multiplied out (the same values)."""
    s0, s1, s2, s3, s4, s5 = S[c, 0], S[c, 1], S[c, 2], S[c, 3], S[c, 4], S[c, 5]
    return (s0 * PF[o_rm] + s4 * PF[o_rm + 4] + s5 * PF[o_rm + 5],
            s1 * PF[o_rm + 7] + s3 * PF[o_rm + 9] + s5 * PF[o_rm + 11],
            s2 * PF[o_rm + 14] + s3 * PF[o_rm + 15] + s4 * PF[o_rm + 16], s3, s4, s5)


@numba.njit(**_JIT)
def _scaled_jacobian(PI, PF, S, cols, J):
    """Dimensionless loop Jacobian ``J`` (6·nloops, len(cols)) of columns ``cols``: the
    twists about the centre with translations / scale (the row map), times the loop
    coefficients with length columns × scale."""
    nc, nv, o_rm, o_lp = PI[H_NC], PI[H_NV], PI[F_ROWMAP], PI[F_LOOP]
    for k in range(cols.shape[0]):
        c = cols[k]
        v0, v1, v2, v3, v4, v5 = _twist_rows(PF, o_rm, S, c)
        for lp in range(nc):
            f = PF[o_lp + nv * lp + c]
            J[6 * lp, k] = f * v0
            J[6 * lp + 1, k] = f * v1
            J[6 * lp + 2, k] = f * v2
            J[6 * lp + 3, k] = f * v3
            J[6 * lp + 4, k] = f * v4
            J[6 * lp + 5, k] = f * v5


@numba.njit(**_JIT)
def _apply(PI, PF, q, rot, dv, q_out, rot_out, R3):
    """New ``(q, rot)`` from a dimensionless step ``dv`` (nv) over all coordinates;
    ``R3`` (1, 3, 3) scratch."""
    o_v, o_q, o_cs = PI[O_SCALV], PI[O_SCALQ], PI[F_COLSC]
    o_sc, o_so = PI[O_SCOLS], PI[O_SORD]
    for i in range(q.shape[0]):
        q_out[i] = q[i]
    for i in range(PI[O_SCALQ] - PI[O_SCALV]):
        v, qi = PI[o_v + i], PI[o_q + i]
        q_out[qi] = q[qi] + dv[v] * PF[o_cs + v]
    for k in range(PI[O_INV] - PI[O_SORD]):
        _exp_so3(dv[PI[o_sc + 3 * k]], dv[PI[o_sc + 3 * k + 1]], dv[PI[o_sc + 3 * k + 2]],
                 R3, np.int64(0))
        si = PI[o_so + k]
        for a in range(3):
            for b in range(3):
                rot_out[si, a, b] = R3[0, a, 0] * rot[si, 0, b] + R3[0, a, 1] * rot[si, 1, b] + \
                    R3[0, a, 2] * rot[si, 2, b]


@numba.njit(**_JIT)
def _distance(PI, PF, qa, rota, qb, rotb, out, R3, w3):
    """Dimensionless distance per velocity coordinate between two states into ``out``
    (nv) (:meth:`closure.state.Plan.distance`); returns its largest absolute entry;
    ``R3`` (1, 3, 3) and ``w3`` (3,) scratch."""
    o_v, o_q, o_cs = PI[O_SCALV], PI[O_SCALQ], PI[F_COLSC]
    o_sc, o_so = PI[O_SCOLS], PI[O_SORD]
    i0 = np.int64(0)                    # not a literal: one compile of the callees
    for c in range(out.shape[0]):
        out[c] = 0.0
    for i in range(PI[O_SCALQ] - PI[O_SCALV]):
        v, qi = PI[o_v + i], PI[o_q + i]
        out[v] = (qa[qi] - qb[qi]) / PF[o_cs + v]
    for k in range(PI[O_INV] - PI[O_SORD]):
        si = PI[o_so + k]
        for a in range(3):
            for b in range(3):
                R3[0, a, b] = rota[si, a, 0] * rotb[si, b, 0] + rota[si, a, 1] * rotb[si, b, 1] + \
                    rota[si, a, 2] * rotb[si, b, 2]
        th, _, _, _ = _rot_log(R3, i0, w3)
        if th < 0.0:
            _log_so3(R3, i0, w3)
        for a in range(3):
            out[PI[o_sc + 3 * k + a]] = w3[a]
    big = 0.0
    for c in range(out.shape[0]):
        d = abs(out[c])
        if d > big or d != d:
            big = d
    return big


# ---------------------------------------------------------------------- least squares
@numba.njit(inline="always", **_JIT)
def _cholesky(G, L, k):
    """The Cholesky factor ``L`` (lower triangle written) of ``G[:k, :k]`` (lower triangle
    read); False when ``G`` is not positive definite (inlined: a ``k`` known when compiled
    unrolls its loops)."""
    for j in range(k):
        d = G[j, j]
        for t in range(j):
            d -= L[j, t] * L[j, t]
        if not d > 0.0:
            return False
        d = math.sqrt(d)
        L[j, j] = d
        for i in range(j + 1, k):
            s = G[i, j]
            for t in range(j):
                s -= L[i, t] * L[j, t]
            L[i, j] = s / d
    return True


@numba.njit(inline="always", **_JIT)
def _factor_k(J, G, L, Linv, Ginv, m, n, k):
    """:func:`_factor` of ``J`` (m, n), ``k = min(m, n)`` > 0, past its rank test."""
    if m < n:                                           # wide: G = J Jᵀ
        for i in range(k):
            for j in range(i + 1):
                s = 0.0
                for t in range(n):
                    s += J[i, t] * J[j, t]
                G[i, j] = s
    else:                                               # tall: G = Jᵀ J, row by row
        for i in range(k):
            for j in range(i + 1):
                G[i, j] = 0.0
        for t in range(m):
            for i in range(k):
                a = J[t, i]
                for j in range(i + 1):
                    G[i, j] += a * J[t, j]
    for i in range(k):
        for j in range(i):
            G[j, i] = G[i, j]
    jj = 0.0                                            # ‖J‖²_F = tr G
    for i in range(k):
        jj += G[i, i]
    if not _cholesky(G, L, k):                          # G = L Lᵀ
        return False, 0.0
    tr_inv = 0.0
    for j in range(k):                                  # L⁻¹, lower triangular
        Linv[j, j] = 1.0 / L[j, j]
        for i in range(j + 1, k):
            s = 0.0
            for t in range(j, i):
                s -= L[i, t] * Linv[t, j]
            Linv[i, j] = s / L[i, i]
        for i in range(j, k):
            tr_inv += Linv[i, j] * Linv[i, j]
    cest = math.sqrt(jj * tr_inv)
    if not cest <= FAST_COND:
        return False, 0.0
    for i in range(k):                                  # G⁻¹ = L⁻ᵀ L⁻¹
        for j in range(i + 1):
            s = 0.0
            for t in range(i, k):
                s += Linv[t, i] * Linv[t, j]
            Ginv[i, j] = s
            Ginv[j, i] = s
    return True, math.sqrt(tr_inv)


@numba.njit(**_JIT)
def _factor(J, rank, G, L, Linv, Ginv):
    """Cholesky path of the minimum-norm solve of ``J`` (m, n) truncated to ``rank``:
    the Gram matrix ``G`` (``J Jᵀ`` wide, ``Jᵀ J`` tall) factored, ``Ginv = G⁻¹``.

    Returns ``(fast, sqrt(tr G⁻¹))``; ``fast`` is False (the SVD path) when the expected
    rank is below ``min(m, n)``, the factorisation fails or the condition estimate
    ``sqrt(‖J‖²_F · tr G⁻¹)`` (≥ s_max / s_min) exceeds ``FAST_COND``.  A Gram matrix of
    one loop's six rows (k = 6) has its own copy of :func:`_factor_k`, compiled with k
    known (its short loops unrolled: about half the time; the same operations)."""
    m, n = J.shape
    k = min(m, n)
    if k == 0 or min(rank, k) != k:
        return False, 0.0
    if k == 6:
        return _factor_k(J, G, L, Linv, Ginv, m, n, 6)
    return _factor_k(J, G, L, Linv, Ginv, m, n, k)


@numba.njit(**_JIT)
def _cond_of(s, rank):
    """``s_max / s_rank`` of singular values ``s`` (inf where ``s_rank`` is 0)."""
    rk = min(rank, s.shape[0])
    srank = s[rk - 1] if rk > 0 else 1.0
    if srank > 0:
        return s[0] / srank
    return np.inf


@numba.njit(**_JIT)
def _svd_parts(J, rank, U, inv_s, Vt):
    """Truncated SVD of ``J`` (m, n): into ``U`` (m, k), ``inv_s`` (k), ``Vt`` (k, n) the
    ``rank`` largest singular values above ``SINGULAR_RTOL`` times the largest inverted,
    the others dropped.  Returns ``(s_max / s_rank, 1 / s_min kept)``; ``(1, 0)`` for an
    empty ``J``."""
    m, n = J.shape
    k = min(m, n)
    if k == 0:
        return 1.0, 0.0
    Uf, s, Vtf = np.linalg.svd(J, full_matrices=False)
    rk = min(rank, k)
    big = 0.0
    for i in range(k):
        if i < rk and s[i] > SINGULAR_RTOL * s[0] and s[i] > 1e-300:
            inv_s[i] = 1.0 / s[i]
        else:
            inv_s[i] = 0.0
        if inv_s[i] > big:
            big = inv_s[i]
        for a in range(m):
            U[a, i] = Uf[a, i]
        for b in range(n):
            Vt[i, b] = Vtf[i, b]
    return _cond_of(s, rank), big


@numba.njit(inline="always", **_JIT)
def _lsq_solve(J, fast, Ginv, U, inv_s, Vt, R, X, T1, T2):
    """Minimum-norm ``X`` (n, j) of ``J X = R`` (R: m, j): Cholesky poses with one step of
    iterative refinement, SVD poses by the truncated pseudo-inverse, column by column
    (:func:`_dn_solve`); ``T1`` (k, ≥ 1) and ``T2`` (m, ≥ 1) scratch (their column 0)."""
    for c in range(R.shape[1]):
        _dn_solve(J, fast, Ginv, U, inv_s, Vt, R, X, c, T1, T2)


@numba.njit(**_JIT)
def _inv_smin(fast, inv0, above, Ginv, M1, M2):
    """1 / (smallest kept singular value): ``inv0`` for SVD poses, and for Cholesky poses
    where ``sqrt(tr G⁻¹)`` is at most ``above``; else the 8th-power trace estimate of
    ``λ_max(G⁻¹)`` (:meth:`closure.lstsq._LstSq.inv_smin`); ``M1``, ``M2`` (k, k)
    scratch."""
    if not fast or not inv0 > above:
        return inv0
    k = Ginv.shape[0]
    lam = inv0 ** 2
    for i in range(k):
        for j in range(k):
            M1[i, j] = Ginv[i, j] / lam
    p = 1.0
    for _ in range(3):                  # λ_max(G⁻¹) ≤ tr(G⁻ᵖ)^(1/p), p = 2, 4, 8
        p *= 2.0
        t = 0.0
        for i in range(k):
            for j in range(k):
                s = 0.0
                for a in range(k):
                    s += M1[i, a] * M1[a, j]
                M2[i, j] = s
            t += M2[i, i]
        lam *= t ** (1.0 / p)
        for i in range(k):
            for j in range(k):
                M1[i, j] = M2[i, j] / t
    return math.sqrt(lam)


@numba.njit(**_JIT)
def _lsq_work(m, n, nr):
    """Scratch of the least-squares kernels for ``J`` (m, n) and ``nr`` right-hand sides:
    ``(G, L, Linv, Ginv, U, inv_s, Vt, M, T1, T2)``."""
    k = min(m, n)
    nr = max(nr, 1)
    return (np.zeros((k, k)), np.zeros((k, k)), np.zeros((k, k)), np.zeros((k, k)),
            np.zeros((m, k)), np.zeros(k), np.zeros((k, n)), np.zeros((k, k)),
            np.zeros((k, nr)), np.zeros((m, nr)))


# ---------------------------------------------------------------------- block-sparse least squares
# The loop Jacobian of columns ``cols`` is block-sparse: column c has a 6-row block in loop
# lp only where the loop coefficient of c in lp is not zero (a chain of loops that share
# few joints: block-banded).  :func:`_pattern` lays out, once per kernel call, that
# structure and the envelope (skyline) of the Gram matrix; the Jacobian is kept as its
# nonzero blocks (``Jv``: 6 values per (column, loop) entry, columns in turn) and the Gram
# matrix and its Cholesky factor as their envelope, row by row.  Every sum runs over the
# same terms in the same order as the dense kernels above, less the terms that are exactly
# zero, so G, its factor, the steps' products and the residual are the dense path's values;
# tr G⁻¹ comes from the selected inverse on the envelope (Takahashi's equations) and the
# solves from triangular solves on the envelope instead of the explicit G⁻¹ (the same to
# rounding).  The cost of a factorisation is O(Σ envelope row²), linear in the number of
# loops of a chain; poses that need the truncated SVD get the dense matrix.

# the pattern's header: sizes, then the offsets of its tables
(P_N, P_M, P_K, P_WIDE, P_NNZ, P_ENV, P_CPTR, P_CLP, P_RPTR, P_RCOL, P_RPOS, P_F, P_EPTR,
 P_LAST, P_DENSE, P_HEAD) = range(16)


@numba.njit(**_JIT)
def _pattern(PI, PF, cols):
    """The block structure of the loop Jacobian of columns ``cols`` and the envelope of its
    Gram matrix (``J Jᵀ`` over rows when wide, ``Jᵀ J`` over columns when tall), as one
    int64 array: the header ``P_*``, then per column the loops it enters (``cptr``,
    ``clp``; entry e of column k is ``Jv[6 e : 6 e + 6]``), per loop its columns in order
    and their entries (``rptr``, ``rcol``, ``rpos``), per Gram row the first column of its
    envelope ``f``, its offset ``eptr`` and per Gram column the last row whose envelope
    reaches it ``last``."""
    nc, nv, o_lp = PI[H_NC], PI[H_NV], PI[F_LOOP]
    n = cols.shape[0]
    m = 6 * nc
    nnz = 0
    for k in range(n):
        for lp in range(nc):
            if PF[o_lp + nv * lp + cols[k]] != 0.0:
                nnz += 1
    wide = m < n
    kk = min(m, n)
    o_cptr = P_HEAD
    o_clp = o_cptr + n + 1
    o_rptr = o_clp + nnz
    o_rcol = o_rptr + nc + 1
    o_rpos = o_rcol + nnz
    o_f = o_rpos + nnz
    o_eptr = o_f + kk
    o_last = o_eptr + kk + 1
    P = np.zeros(o_last + kk, dtype=np.int64)
    P[P_N], P[P_M], P[P_K], P[P_WIDE], P[P_NNZ] = n, m, kk, 1 if wide else 0, nnz
    P[P_CPTR], P[P_CLP], P[P_RPTR], P[P_RCOL], P[P_RPOS] = o_cptr, o_clp, o_rptr, o_rcol, o_rpos
    P[P_F], P[P_EPTR], P[P_LAST] = o_f, o_eptr, o_last
    e = 0
    for k in range(n):                              # columns: their loops
        P[o_cptr + k] = e
        for lp in range(nc):
            if PF[o_lp + nv * lp + cols[k]] != 0.0:
                P[o_clp + e] = lp
                e += 1
    P[o_cptr + n] = e
    x = 0
    for lp in range(nc):                            # loops: their columns, in order
        P[o_rptr + lp] = x
        for k in range(n):
            for e in range(P[o_cptr + k], P[o_cptr + k + 1]):
                if P[o_clp + e] == lp:
                    P[o_rcol + x] = k
                    P[o_rpos + x] = e
                    x += 1
    P[o_rptr + nc] = x
    # the envelope: the first Gram column each row reaches
    if wide:                                        # rows of loop lp: the first loop that
        for lp in range(nc):                        # shares a column with it
            fl = lp
            for x in range(P[o_rptr + lp], P[o_rptr + lp + 1]):
                k = P[o_rcol + x]
                l0 = P[o_clp + P[o_cptr + k]]
                if l0 < fl:
                    fl = l0
            for s in range(6):
                P[o_f + 6 * lp + s] = 6 * fl
    else:                                           # column k: the first column that
        for k in range(kk):                         # shares a loop with it
            fk = k
            for e in range(P[o_cptr + k], P[o_cptr + k + 1]):
                lp = P[o_clp + e]
                if P[o_rptr + lp + 1] > P[o_rptr + lp]:
                    k0 = P[o_rcol + P[o_rptr + lp]]
                    if k0 < fk:
                        fk = k0
            P[o_f + k] = fk
    env = 0
    for i in range(kk):
        P[o_eptr + i] = env
        env += i - P[o_f + i] + 1
        P[o_last + i] = i
    P[o_eptr + kk] = env
    P[P_ENV] = env
    # a full envelope (one loop, or loops that all share columns): the dense kernels
    P[P_DENSE] = 1 if 2 * env == kk * (kk + 1) else 0
    for i in range(kk):
        for j in range(P[o_f + i], i):
            if P[o_last + j] < i:
                P[o_last + j] = i
    return P


@numba.njit(**_JIT)
def _sp_work(P, nr):
    """Scratch of the block-sparse least squares for pattern ``P`` and ``nr`` right-hand
    sides: ``(Jv, L, Z, T1, T2, Jd, U, inv_s, Vt, Ginv, M1, M2)``: the Jacobian's blocks,
    the envelope of the Cholesky factor and of G⁻¹, two vectors, and (not touched unless a
    pose needs them: the truncated SVD, the trace estimate) the dense matrices."""
    n, m, k = P[P_N], P[P_M], P[P_K]
    return (np.zeros(6 * P[P_NNZ]), np.zeros(P[P_ENV]), np.zeros(P[P_ENV]),
            np.zeros(max(m, n, 1)), np.zeros(max(m, 1)), np.empty((m, n)), np.empty((m, k)),
            np.empty(k), np.empty((k, n)), np.empty((k, k)), np.empty((k, k)),
            np.empty((k, k)))


@numba.njit(**_JIT)
def _sp_jacobian(PI, PF, S, cols, P, Jv):
    """The nonzero blocks ``Jv`` of the dimensionless loop Jacobian of columns ``cols``
    (:func:`_scaled_jacobian`'s values)."""
    nv, o_rm, o_lp = PI[H_NV], PI[F_ROWMAP], PI[F_LOOP]
    o_cptr, o_clp = P[P_CPTR], P[P_CLP]
    for k in range(P[P_N]):
        e0, e1 = P[o_cptr + k], P[o_cptr + k + 1]
        if e0 == e1:
            continue
        v = _twist_rows(PF, o_rm, S, cols[k])
        for s in range(6):
            for e in range(e0, e1):
                Jv[6 * e + s] = PF[o_lp + nv * P[o_clp + e] + cols[k]] * v[s]


@numba.njit(**_JIT)
def _sp_dense(P, Jv, J):
    """The dense ``J`` (m, n) of the blocks ``Jv``."""
    m, n = P[P_M], P[P_N]
    o_cptr, o_clp = P[P_CPTR], P[P_CLP]
    for a in range(m):
        for b in range(n):
            J[a, b] = 0.0
    for k in range(n):
        for e in range(P[o_cptr + k], P[o_cptr + k + 1]):
            lp = P[o_clp + e]
            for s in range(6):
                J[6 * lp + s, k] = Jv[6 * e + s]


@numba.njit(**_JIT)
def _sp_factor(P, Jv, L, Z):
    """Cholesky path of :func:`_factor` on the envelope: the Gram matrix into ``L`` and
    factored in place, G⁻¹ on the envelope into ``Z``.  Returns ``(fast, sqrt(tr G⁻¹))``
    as :func:`_factor`."""
    kk = P[P_K]
    o_f, o_e, o_last = P[P_F], P[P_EPTR], P[P_LAST]
    o_rptr, o_rcol, o_rpos = P[P_RPTR], P[P_RCOL], P[P_RPOS]
    nc = P[P_M] // 6
    for i in range(P[P_ENV]):
        L[i] = 0.0
    if P[P_WIDE]:                                   # G = J Jᵀ over rows: loop pairs
        for li in range(nc):
            a0, a1 = P[o_rptr + li], P[o_rptr + li + 1]
            for lj in range(P[o_f + 6 * li] // 6, li + 1):
                b0, b1 = P[o_rptr + lj], P[o_rptr + lj + 1]
                x, y = a0, b0
                while x < a1 and y < b1:            # the columns the two loops share
                    kx, ky = P[o_rcol + x], P[o_rcol + y]
                    if kx < ky:
                        x += 1
                    elif ky < kx:
                        y += 1
                    else:
                        ex, ey = 6 * P[o_rpos + x], 6 * P[o_rpos + y]
                        for si in range(6):
                            i = 6 * li + si
                            base = P[o_e + i] - P[o_f + i] + 6 * lj
                            vi = Jv[ex + si]
                            for sj in range(6 if lj < li else si + 1):
                                L[base + sj] += vi * Jv[ey + sj]
                        x += 1
                        y += 1
    else:                                           # G = Jᵀ J over columns: per loop
        for lp in range(nc):
            x0, x1 = P[o_rptr + lp], P[o_rptr + lp + 1]
            for x in range(x0, x1):
                a, ea = P[o_rcol + x], 6 * P[o_rpos + x]
                base = P[o_e + a] - P[o_f + a]
                for y in range(x0, x + 1):
                    b, eb = P[o_rcol + y], 6 * P[o_rpos + y]
                    s = L[base + b]
                    for t in range(6):
                        s += Jv[ea + t] * Jv[eb + t]
                    L[base + b] = s
    jj = 0.0                                        # ‖J‖²_F = tr G (the dense sum)
    for i in range(kk):
        jj += L[P[o_e + i] - P[o_f + i] + i]
    for j in range(kk):                             # G = L Lᵀ, column by column
        fj = P[o_f + j]
        dj = P[o_e + j] - fj
        d = L[dj + j]
        for t in range(fj, j):
            d -= L[dj + t] * L[dj + t]
        if not d > 0.0:
            return False, 0.0
        d = math.sqrt(d)
        L[dj + j] = d
        for i in range(j + 1, P[o_last + j] + 1):
            fi = P[o_f + i]
            if fi > j:
                continue
            di = P[o_e + i] - fi
            s = L[di + j]
            for t in range(max(fi, fj), j):
                s -= L[di + t] * L[dj + t]
            L[di + j] = s / d
    # tr G⁻¹: G⁻¹ on the envelope, last row first:
    # Z_ij = (δ_ij / L_ii − Σ_r L_ri Z_rj) / L_ii (Takahashi)
    tr_inv = 0.0
    for i in range(kk - 1, -1, -1):
        fi = P[o_f + i]
        lii = L[P[o_e + i] - fi + i]
        last = P[o_last + i]
        for j in range(i + 1, last + 1):
            fj = P[o_f + j]
            if fj > i:
                continue
            s = 0.0
            for r_ in range(i + 1, last + 1):
                fr = P[o_f + r_]
                if fr > i:
                    continue
                if r_ >= j:
                    z = Z[P[o_e + r_] - fr + j]
                else:
                    z = Z[P[o_e + j] - fj + r_]
                s += L[P[o_e + r_] - fr + i] * z
            Z[P[o_e + j] - fj + i] = -s / lii
        s = 0.0
        for r_ in range(i + 1, last + 1):
            fr = P[o_f + r_]
            if fr > i:
                continue
            s += L[P[o_e + r_] - fr + i] * Z[P[o_e + r_] - fr + i]
        zii = (1.0 / lii - s) / lii
        Z[P[o_e + i] - fi + i] = zii
        tr_inv += zii
    cest = math.sqrt(jj * tr_inv)
    if not cest <= FAST_COND:
        return False, 0.0
    return True, math.sqrt(tr_inv)


@numba.njit(**_JIT)
def _env_solve(P, L, y):
    """``y ← G⁻¹ y`` with the envelope Cholesky factor ``L`` of G."""
    kk, o_f, o_e = P[P_K], P[P_F], P[P_EPTR]
    for i in range(kk):                             # L z = y
        fi = P[o_f + i]
        di = P[o_e + i] - fi
        s = y[i]
        for t in range(fi, i):
            s -= L[di + t] * y[t]
        y[i] = s / L[di + i]
    for i in range(kk - 1, -1, -1):                 # Lᵀ x = z
        fi = P[o_f + i]
        di = P[o_e + i] - fi
        v = y[i] / L[di + i]
        y[i] = v
        for t in range(fi, i):
            y[t] -= L[di + t] * v


@numba.njit(**_JIT)
def _sp_lsq(P, rank, W):
    """Factor the Jacobian of blocks ``W[0]``: Cholesky on the envelope, or where that is
    not taken (as :func:`_factor`) the truncated SVD of the dense matrix; returns
    ``(fast, cond, inv0)`` as :func:`_lsq`."""
    kk = P[P_K]
    if kk > 0 and min(rank, kk) == kk:
        fast, inv0 = _sp_factor(P, W[0], W[1], W[2])
        if fast:
            return True, np.nan, inv0
    _sp_dense(P, W[0], W[5])
    cond, inv0 = _svd_parts(W[5], rank, W[6], W[7], W[8])
    return False, cond, inv0


@numba.njit(**_JIT)
def _sp_solve(P, fast, W, R, X, c):
    """Column ``c`` of the minimum-norm ``X`` (n, ·) of ``J X = R`` (m, ·), as
    :func:`_lsq_solve`: on the Cholesky path with one step of iterative refinement, by
    the truncated SVD elsewhere."""
    n, m, kk = P[P_N], P[P_M], P[P_K]
    Jv, L, T1, T2 = W[0], W[1], W[3], W[4]
    if not fast:                        # X = V diag(inv_s) Uᵀ R
        U, inv_s, Vt = W[6], W[7], W[8]
        for i in range(kk):
            T1[i] = 0.0
        for a in range(m):
            r_ = R[a, c]
            for i in range(kk):
                T1[i] += U[a, i] * r_
        for i in range(kk):
            T1[i] *= inv_s[i]
        for b in range(n):
            X[b, c] = 0.0
        for i in range(kk):
            t1 = T1[i]
            for b in range(n):
                X[b, c] += Vt[i, b] * t1
        return
    o_cptr, o_clp, o_rptr, o_rcol, o_rpos = P[P_CPTR], P[P_CLP], P[P_RPTR], P[P_RCOL], \
        P[P_RPOS]
    nc = m // 6
    wide = P[P_WIDE] == 1
    for it in range(2):                 # X = J⁺ R, then X += J⁺ (R − J X)
        if it == 0:
            for a in range(m):
                T2[a] = R[a, c]
        else:                           # R − J X, rows in turn
            for lp in range(nc):
                x0, x1 = P[o_rptr + lp], P[o_rptr + lp + 1]
                for s_ in range(6):
                    s = 0.0
                    for x in range(x0, x1):
                        s += Jv[6 * P[o_rpos + x] + s_] * X[P[o_rcol + x], c]
                    T2[6 * lp + s_] = R[6 * lp + s_, c] - s
        if wide:                        # Jᵀ (G⁻¹ T2)
            _env_solve(P, L, T2)
            for b in range(n):
                s = 0.0
                for e in range(P[o_cptr + b], P[o_cptr + b + 1]):
                    r0 = 6 * P[o_clp + e]
                    for s_ in range(6):
                        s += Jv[6 * e + s_] * T2[r0 + s_]
                X[b, c] = s if it == 0 else X[b, c] + s
        else:                           # G⁻¹ (Jᵀ T2)
            for b in range(n):
                s = 0.0
                for e in range(P[o_cptr + b], P[o_cptr + b + 1]):
                    r0 = 6 * P[o_clp + e]
                    for s_ in range(6):
                        s += Jv[6 * e + s_] * T2[r0 + s_]
                T1[b] = s
            _env_solve(P, L, T1)
            for b in range(n):
                X[b, c] = T1[b] if it == 0 else X[b, c] + T1[b]


@numba.njit(**_JIT)
def _sp_inv_smin(P, fast, inv0, above, W):
    """:func:`_inv_smin` of a factorisation by :func:`_sp_lsq` (G⁻¹ made dense, from the
    envelope factor, only where the trace estimate is needed)."""
    if not fast or not inv0 > above:
        return inv0
    kk = P[P_K]
    L, y, Ginv = W[1], W[3], W[9]
    for j in range(kk):
        for i in range(kk):
            y[i] = 1.0 if i == j else 0.0
        _env_solve(P, L, y)
        for i in range(kk):
            Ginv[i, j] = y[i]
    for i in range(kk):                 # symmetric, as L⁻ᵀ L⁻¹
        for j in range(i):
            v = 0.5 * (Ginv[i, j] + Ginv[j, i])
            Ginv[i, j] = v
            Ginv[j, i] = v
    return _inv_smin(fast, inv0, above, Ginv, W[10], W[11])


# A full envelope (a mechanism of one loop) gains nothing from the block structure and
# loses to its indirection: the dense kernels above then serve, on the dense Jacobian, with
# the solves taken one right-hand side at a time (:func:`_lsq_solve` loops over them).
@numba.njit(inline="always", **_JIT)
def _dn_refine(J, Ginv, T1, T2, R, X, c, m, n):
    """The Cholesky path of :func:`_dn_solve`: column ``c`` of ``X = J⁺ R``, then ``X +=
    J⁺ (R − J X)``, with ``Ginv`` = G⁻¹ of ``J`` (m, n); ``T1``, ``T2`` scratch."""
    k = min(m, n)
    for it in range(2):
        if it == 0:
            for a in range(m):
                T2[a, 0] = R[a, c]
        else:
            for a in range(m):
                s = 0.0
                for b in range(n):
                    s += J[a, b] * X[b, c]
                T2[a, 0] = R[a, c] - s
        if m < n:
            for i in range(k):
                s = 0.0
                for a in range(k):
                    s += Ginv[i, a] * T2[a, 0]
                T1[i, 0] = s
            for b in range(n):
                s = 0.0
                for a in range(m):
                    s += J[a, b] * T1[a, 0]
                X[b, c] = s if it == 0 else X[b, c] + s
        else:
            for i in range(k):
                T1[i, 0] = 0.0
            for a in range(m):
                t2 = T2[a, 0]
                for i in range(k):
                    T1[i, 0] += J[a, i] * t2
            for b in range(n):
                s = 0.0
                for a in range(k):
                    s += Ginv[b, a] * T1[a, 0]
                X[b, c] = s if it == 0 else X[b, c] + s


@numba.njit(**_JIT)
def _dn_solve(J, fast, Ginv, U, inv_s, Vt, R, X, c, T1, T2):
    """Column ``c`` of the minimum-norm ``X`` of ``J X = R`` with the factors of
    :func:`_lsq`: on the Cholesky path ``G⁻¹`` = ``Ginv`` and one step of iterative
    refinement, on the SVD path the truncated pseudo-inverse ``V diag(inv_s) Uᵀ``
    (``T1``, ``T2`` scratch: their column 0);
    on the Cholesky path of one loop's six rows the copy of :func:`_dn_refine` compiled
    with m = 6 (as :func:`_factor`)."""
    m, n = J.shape
    k = min(m, n)
    if not fast:
        for i in range(k):
            T1[i, 0] = 0.0
        for a in range(m):
            r_ = R[a, c]
            for i in range(k):
                T1[i, 0] += U[a, i] * r_
        for i in range(k):
            T1[i, 0] *= inv_s[i]
        for b in range(n):
            X[b, c] = 0.0
        for i in range(k):
            t1 = T1[i, 0]
            for b in range(n):
                X[b, c] += Vt[i, b] * t1
        return
    if m == 6:
        _dn_refine(J, Ginv, T1, T2, R, X, c, 6, n)
    else:
        _dn_refine(J, Ginv, T1, T2, R, X, c, m, n)


@numba.njit(inline="always", **_JIT)
def _ls_jacobian(PI, PF, S, cols, P, W):
    """The Jacobian of columns ``cols`` at twists ``S`` into ``W``: dense or blocks."""
    if P[P_DENSE]:
        _scaled_jacobian(PI, PF, S, cols, W[5])
    else:
        _sp_jacobian(PI, PF, S, cols, P, W[0])


@numba.njit(inline="always", **_JIT)
def _ls_factor(P, rank, W, Wd):
    """:func:`_lsq` (dense) or :func:`_sp_lsq` (blocks) of the Jacobian in ``W``."""
    if P[P_DENSE]:
        return _lsq(W[5], rank, Wd)
    return _sp_lsq(P, rank, W)


@numba.njit(inline="always", **_JIT)
def _ls_solve(P, fast, W, Wd, R, X, c):
    """Column ``c`` of the minimum-norm solution with the factorisation of
    :func:`_ls_factor`."""
    if P[P_DENSE]:
        _dn_solve(W[5], fast, Wd[3], Wd[4], Wd[5], Wd[6], R, X, c, Wd[8], Wd[9])
    else:
        _sp_solve(P, fast, W, R, X, c)


@numba.njit(inline="always", **_JIT)
def _ls_inv_smin(P, fast, inv0, above, W, Wd):
    """:func:`_inv_smin` of the factorisation of :func:`_ls_factor`."""
    if P[P_DENSE]:
        return _inv_smin(fast, inv0, above, Wd[3], Wd[2], Wd[7])
    return _sp_inv_smin(P, fast, inv0, above, W)


# ---------------------------------------------------------------------- solver
@numba.njit(inline="always", **_JIT)
def _lsq(J, rank, W):
    """Factor ``J`` (Cholesky or truncated SVD) into the buffers ``W`` of :func:`_lsq_work`;
    returns ``(fast, cond, inv0)``: ``cond`` NaN on the Cholesky path, ``inv0`` its
    ``sqrt(tr G⁻¹)`` or the SVD's 1 / (smallest kept singular value)."""
    fast, inv0 = _factor(J, rank, W[0], W[1], W[2], W[3])
    if fast:
        return True, np.nan, inv0
    cond, inv0 = _svd_parts(J, rank, W[4], W[5], W[6])
    return False, cond, inv0


@numba.njit(inline="always", **_JIT)
def _jac_values(P, W):
    """The values of the Jacobian in ``W`` (:func:`_ls_jacobian`), flat: the dense matrix's
    or the blocks'."""
    if P[P_DENSE]:
        return _flat(W[5])
    return W[0]


@numba.njit(**_JIT)
def _step_bound(P, J, Jp, inv_prev, rs):
    """Upper bounds, without factoring the Jacobian ``J`` (its values, flat:
    :func:`_jac_values`), of its minimum-norm step ``‖J⁺ r‖`` for the residual ``rs`` and
    of its condition estimate ``sqrt(‖J‖²_F · tr G⁻¹)`` (:func:`_factor`), from the
    previous iteration's Jacobian values ``Jp`` and its ``sqrt(tr G⁻¹) = inv_prev``
    (≥ 1 / σ_min): Weyl's ``σ_min(J) ≥ 1 / inv_prev − ‖J − J_prev‖_F =: σ``, then
    ``‖r‖ / σ`` and ``sqrt(k) ‖J‖_F / σ``; ``(inf, inf)`` where σ is not positive."""
    d2, jj = 0.0, 0.0
    for i in range(J.size):
        d = J[i] - Jp[i]
        d2 += d * d
        jj += J[i] * J[i]
    lo = 1.0 / inv_prev - math.sqrt(d2)
    if not lo > 0.0:
        return np.inf, np.inf
    rr = 0.0
    for a in range(P[P_M]):
        rr += rs[a] * rs[a]
    return math.sqrt(rr) / lo, math.sqrt(jj * P[P_K]) / lo


@numba.njit(inline="always", **_JIT)
def _copy_state(a, b, full=True):
    """State ``a`` into ``b`` (both ``(q, rot, A, link, frame_a, r, S, first)``); unless
    ``full``, only what a path from ``a`` reads (``q``, ``rot``, ``S``, ``first``), not the
    transforms and residual ``A``, ``link``, ``frame_a``, ``r``."""
    _copy(a[0], b[0])
    _copy(a[1], b[1])
    if full:
        _copy(a[2], b[2])
        _copy(a[3], b[3])
        _copy(a[4], b[4])
        _copy(a[5], b[5])
    _copy(a[6], b[6])
    _copy(a[7], b[7])


#: tasks of :func:`drive`
NEWTON, CONTINUE, SWEEP, SOLVE = 0, 1, 2, 3


@numba.njit(**_JIT)
def _member_state(nq, ns, nj, nl, nc, nv, ni):
    """A member's state ``(q, rot, A, link, frame_a, r, S, first)`` (zeros) for ``nq``
    stored coordinates, ``ns`` S joints, ``nj`` joints, ``nl`` links, ``nc`` loops, ``nv``
    velocity coordinates and ``ni`` analog columns."""
    return (np.zeros(nq), np.zeros((ns, 3, 3)), np.zeros((nj, 4, 4)), np.zeros((nl, 4, 4)),
            np.zeros((nj, 4, 4)), np.zeros((nc, 6)), np.zeros((nv, 6)), np.zeros((nv, ni)))


@numba.njit(**_JIT)
def _state_buffers(q, rot, A, link, r, S, first):
    """:func:`_member_state` of the sizes of the batch arrays given."""
    return _member_state(q.shape[1], rot.shape[1], A.shape[1], link.shape[1], r.shape[1],
                         S.shape[1], first.shape[2])


@numba.njit(inline="always", **_JIT)
def _borrowed_sp_work(W):
    """:func:`_borrowed` of every array of :func:`_sp_work`'s scratch."""
    return (_borrowed(W[0]), _borrowed(W[1]), _borrowed(W[2]), _borrowed(W[3]),
            _borrowed(W[4]), _borrowed(W[5]), _borrowed(W[6]), _borrowed(W[7]),
            _borrowed(W[8]), _borrowed(W[9]), _borrowed(W[10]), _borrowed(W[11]))


@numba.njit(inline="always", **_JIT)
def _borrowed_lsq_work(W):
    """:func:`_borrowed` of every array of :func:`_lsq_work`'s scratch."""
    return (_borrowed(W[0]), _borrowed(W[1]), _borrowed(W[2]), _borrowed(W[3]),
            _borrowed(W[4]), _borrowed(W[5]), _borrowed(W[6]), _borrowed(W[7]),
            _borrowed(W[8]), _borrowed(W[9]))


@numba.njit(**_JIT)
def _analog_rhs(PI, PF, S, icols, Pi, Jiv, R):
    """Columns 1, 2 ... of ``R``: the input columns' Jacobian at twists ``S`` over the
    inputs' column scales (the analogs' right-hand sides)."""
    m = Pi[P_M]
    o_incs = PI[F_INCS]
    _sp_jacobian(PI, PF, S, icols, Pi, Jiv)
    o_cptr, o_clp = Pi[P_CPTR], Pi[P_CLP]
    for i in range(icols.shape[0]):
        for a in range(m):
            R[a, 1 + i] = 0.0
        sc = PF[o_incs + i]
        for e in range(Pi[o_cptr + i], Pi[o_cptr + i + 1]):
            r0 = 6 * Pi[o_clp + e]
            for s in range(6):
                R[r0 + s, 1 + i] = Jiv[6 * e + s] / sc


@numba.njit(**_JIT)
def _same_guess(q, rot, x_from, a, b):
    """Members ``a`` and ``b`` start from the same guess (bit for bit)."""
    for i in range(q.shape[1]):
        if q[a, i] != q[b, i]:
            return False
    for i in range(x_from.shape[1]):
        if x_from[a, i] != x_from[b, i]:
            return False
    for s in range(rot.shape[1]):
        for i in range(3):
            for j in range(3):
                if rot[a, s, i, j] != rot[b, s, i, j]:
                    return False
    return True


@numba.njit(inline="always", **_JIT)
def _copy_out(st, b, q, rot, A, link, fa, r, S, first):
    """A member's state ``st`` into row ``b`` of the batch arrays (the kinematic state only
    where they have rows)."""
    _copy(st[0], q[b])
    _copy(st[1], rot[b])
    if A.shape[0] > b:
        _copy(st[2], A[b])
        _copy(st[3], link[b])
        _copy(st[4], fa[b])
        _copy(st[5], r[b])
        _copy(st[6], S[b])
        _copy(st[7], first[b])


@numba.njit(inline="always", **_JIT)
def _newton(PI, PF, PM, co, trial, n_iter, bounded, ucols, icols, P, Pi, W, Wd, Wi, Jp, rs,
            step, R, X, T, w3, R3, rank, fopts, cond_out):
    """Damped Gauss–Newton (:func:`closure.solver.newton`; :func:`drive`'s notes) on the
    member state ``co`` (a tuple like :func:`_state_buffers`' rows: q, rot, A, link, fa,
    r, S, first), ``trial`` the line search's state, at most ``n_iter`` iterations; the
    analogs of ``icols`` go to ``first`` once converged, unless ``bounded`` (the end of a
    SOLVE member's path whose state is not returned: no analogs, and the last step may be
    bounded instead of factored, :func:`_step_bound`).  ``P``, ``Pi``, ``W``, ``Wd``,
    ``Wi``, ``Jp``, ``rs``, ``step``, ``R``, ``X``, ``T``, ``w3``, ``R3``: :func:`drive`'s
    scratch (borrowed); ``fopts``: :func:`drive`'s.  ``cond_out``: where not converged, the
    condition at the state returned (a factorisation more) rather than the last step's.

    Returns ``(co, trial, done, n_res, n_its, n_cond, n_last, at_pose, fast, inv0)``: the
    state tuples (swapped where the iteration ended in the trial's buffers), converged,
    the scaled residual, the iterations, the condition (NaN on the Cholesky path), the
    last step, and whether the last factorisation (``fast``, ``inv0`` of
    :func:`_ls_factor`, left in ``W``, ``Wd``) is the returned pose's (converged by the
    test)."""
    xtol, max_step = fopts[0], fopts[2]
    scale, offset = PF[PI[F_SCALE]], PF[PI[F_OFFSET]]
    floor, xtl, noise = 1e-14 * offset, xtol * offset, 1e-15 * offset
    o_inv, o_unk, o_unkcs = PI[O_INV], PI[O_UNK], PI[F_UNKCS]
    nv, m, nu, ni = PI[H_NV], P[P_M], ucols.shape[0], co[7].shape[1]
    c0 = np.int64(0)                    # the step's column (not a literal: one compile)
    cq, crot, cA, clink, cfa, cr, cS, cfirst = co
    tq, trot, tA, tlink, tfa, tr_, tS, tfirst = trial
    _evaluate(PI, PF, PM, cq, crot, cA, clink, cfa, cr, cS, T, w3)
    n_res = _scaled_residual(cr, scale, rs)
    prev = np.inf
    prev_inv = np.inf
    n_its = 0
    done = nu == 0
    n_cond = 1.0
    n_last = np.nan
    at_pose = False
    fast, inv0 = False, 0.0
    _fill(cfirst, np.nan)
    for i in range(ni):
        for c in range(ni):
            cfirst[PI[o_inv + i], c] = 1.0 if i == c else 0.0
    for _ in range(n_iter):
        if done:
            break
        _ls_jacobian(PI, PF, cS, ucols, P, W)
        n_its += 1
        if bounded and n_res <= floor:  # converged if the step's bound says so
            sb, cb = _step_bound(P, _jac_values(P, W), Jp, prev_inv, rs)
            if sb <= 0.5 * xtl and cb <= 0.5 * FAST_COND:
                done = True
                n_cond, n_last = np.nan, sb
                break
        fast, n_cond, inv0 = _ls_factor(P, rank, W, Wd)
        if bounded:
            prev_inv = inv0 if fast else np.inf
            _copy(_jac_values(P, W), Jp)
        for a in range(m):
            R[a, 0] = rs[a]
        _ls_solve(P, fast, W, Wd, R, X, c0)
        big = 0.0
        for k in range(nu):
            v = abs(X[k, 0])
            if v > big or v != v:
                big = v
        # converged: the residual at rounding level, or steps of at most xtol
        # that no longer reduce it; near a singular configuration the step must
        # also be what rounding in the residual explains (noise / σ_min)
        stalled = n_its > 1 and n_res > 0.5 * prev
        tol_step = max(xtl, noise * _ls_inv_smin(P, fast, inv0, xtl / noise, W, Wd))
        conv = big <= tol_step and (n_res <= floor or stalled)
        prev = n_res
        if conv:
            done = True
            at_pose = True
            n_last = big
            if ni and not bounded:  # the analogs: the input columns as right-hand sides
                _analog_rhs(PI, PF, cS, icols, Pi, Wi[0], R)
                for i in range(ni):
                    _ls_solve(P, fast, W, Wd, R, X, 1 + i)
                for k in range(nu):
                    for i in range(ni):
                        cfirst[PI[o_unk + k], i] = -X[k, 1 + i] * PF[o_unkcs + k]
            break
        fac = min(1.0, max_step / max(big, 1e-300))
        _fill(step, 0.0)
        for k in range(nu):
            step[ucols[k]] = -X[k, 0] * fac
        # backtracking: the longest of 1, 1/2, 1/4 ... not raising the residual
        for hs in range(8):
            if hs:
                for c in range(nv):
                    step[c] *= 0.5
            _apply(PI, PF, cq, crot, step, tq, trot, R3)
            _evaluate(PI, PF, PM, tq, trot, tA, tlink, tfa, tr_, tS, T, w3)
            rn = _scaled_residual(tr_, scale, rs)
            if rn <= n_res * (1 + 1e-9) or rn < floor or hs == 7:
                # the trial becomes the current state: swap the buffers
                cq, tq, crot, trot, cA, tA = tq, cq, trot, crot, tA, cA
                clink, tlink, cfa, tfa, cr, tr_, cS, tS = tlink, clink, tfa, cfa, \
                    tr_, cr, tS, cS
                n_res = rn
                break
    co = (cq, crot, cA, clink, cfa, cr, cS, cfirst)
    trial = (tq, trot, tA, tlink, tfa, tr_, tS, tfirst)
    if cond_out and not done:           # the condition at the state returned
        _ls_jacobian(PI, PF, co[6], ucols, P, W)
        n_cond = _ls_factor(P, rank, W, Wd)[1]
    return co, trial, done, n_res, n_its, n_cond, n_last, at_pose, fast, inv0


@numba.njit(**_JIT)
def drive(task, PI, PF, PM, x_from, x_to, q, rot, A, link, fa, r, S, first, res, cond, last,
          its, flag, tangent, have, fopts, maxiter, rank, ucols, icols, x_cur):
    """The position solver over a batch, every member on its own; the state arrays
    ``(B, ...)`` (``q``, ``rot``, ``A``, ``link``, ``fa``, ``r``, ``S``, ``first``) and
    the figures ``res``, ``cond``, ``last`` (the last Newton step), ``its``, ``flag`` are
    updated in place.  ``fopts`` = (xtol, rtol, max_step, path_step, min_step,
    tangent_cond, dense, longest path) (``dense`` not 0: the dense least-squares kernels
    whatever the Jacobian's block structure, the reference of the block-sparse ones);
    ``ucols`` the columns solved for, ``icols`` the inputs' (their analogs go to
    ``first``).

    * ``NEWTON`` (:func:`closure.solver.newton`): damped Gauss–Newton on every member
      from its ``q``, ``rot``; ``flag`` converged (1) or not; the condition of the last
      step's factorisation, or where not converged at the returned state (NaN on the
      Cholesky path).
    * ``CONTINUE`` (:func:`closure.solver._continue`): every solved member walks from
      ``x_from`` to ``x_to`` (B, ni) by predictor along its analogs (``tangent`` (B, nv,
      ni); ``have``: given) and Newton corrector; ``x_cur`` where each stands, ``flag``
      its stop code (0 reached, 3 no assembly, 4 dead point), ``its`` the path's
      iterations.
    * ``SWEEP`` (:func:`closure.solver.sweep`): rows 1, 2 ... from the solved row 0
      (element 0 of every array): row i by continuation from row i − 1 to ``x_to[i]``,
      each row's tangent (``tangent[0]``) handed to the next, until a row stops.
    * ``SOLVE`` (:func:`closure.solver.solve` of a batch from guesses): ``NEWTON`` on
      every member's guess ``q``, ``rot`` (inputs ``x_from``: at most ``maxiter``
      iterations), then ``CONTINUE`` from there to ``x_to`` (corrector: at most
      min(``maxiter``, 8)), with the member's state in scratch: ``q``, ``rot`` and the
      figures are written, the kinematic state (``A`` ... ``first``, ``last``) only where
      those arrays have B rows (else pass them with none; ``tangent`` likewise unused);
      ``flag`` the start's status where it failed (2 not converged, 3 residual above
      ``rtol`` · offset) else the stop code.  Members whose guess (``q``, ``rot``,
      ``x_from``) equals the previous member's, bit for bit, share its correction.

    Newton (:func:`closure.solver.newton`): each iteration factors the dimensionless
    Jacobian of ``ucols`` (block-sparse: :func:`_sp_lsq`), takes the minimum-norm step
    from it and, once converged, the analogs (the input columns are extra right-hand
    sides of the same factorisation), stops when the step is below ``xtol`` · offset (or
    below what rounding of the residual explains near a singular configuration) and the
    residual is at rounding level or stopped falling, else caps the step at ``max_step``
    and backtracks (1, 1/2 ... 1/128) to the first trial that does not raise the
    residual.  At the end of a ``SOLVE`` member's path whose kinematic state is not
    returned, neither the analogs nor the last step itself are kept: a residual at
    rounding level converges there without a factorisation when an upper bound of the
    step (:func:`_step_bound`, from the previous iteration's) is at most half ``xtol`` ·
    offset and its condition estimate certainly on the Cholesky path (condition NaN, as
    there; ``last`` the bound), else the iteration goes on as above: the same poses,
    residuals and iterations.  Continuation: the predictor's change of any coordinate
    is capped at ``path_step``; a step is accepted when the corrector converges, the
    loops close (``rtol``) and the corrected pose lies within half the predicted step of
    the predictor, else halved down to ``min_step`` (then stop); at a pose whose
    condition exceeds ``tangent_cond`` the previous tangent is kept.

    Returns the number of members (rows) filled, or −(b + 1) when member (row) b's path
    is longer than ``fopts[7]`` (then nothing is done for it)."""
    B, nq = q.shape
    ns, nv, ni = rot.shape[1], first.shape[1], first.shape[2]
    nu = ucols.shape[0]
    P = _pattern(PI, PF, ucols)
    Pi = _pattern(PI, PF, icols)
    m = P[P_M]
    if fopts[6] != 0.0:                 # the dense kernels asked for (a reference)
        P[P_DENSE] = 1
    W = _sp_work(P, 1 + ni)
    dn = P[P_DENSE] == 1                # the dense kernels' scratch only where they serve
    Wd = _lsq_work(m if dn else 0, nu if dn else 0, ni)
    Jiv = np.zeros(6 * Pi[P_NNZ])
    Jp = np.zeros(max(6 * P[P_NNZ], m * nu))     # the previous iteration's Jacobian
    # scratch: the corrector's state, the line search's trial, the member's state
    # (SOLVE), the shared start (SOLVE); the predicted state, the Newton step's arrays
    sts = (_state_buffers(q, rot, A, link, r, S, first),
           _state_buffers(q, rot, A, link, r, S, first),
           _state_buffers(q, rot, A, link, r, S, first),
           _state_buffers(q, rot, A, link, r, S, first))
    vec = (np.zeros(nq), np.zeros(m), np.zeros(nv), np.zeros(3), np.zeros(ni), np.zeros(ni),
           np.zeros(nv))
    mat = (np.zeros((m, 1 + ni)), np.zeros((nu, 1 + ni)), np.zeros((nv, ni)),
           np.zeros((nv, ni)))
    m3 = (np.zeros((ns, 3, 3)), np.zeros((3, 4, 4)), np.zeros((1, 3, 3)))
    owners = (P, Pi, Jiv, Jp, W, Wd, sts, vec, mat, m3)
    # every array below is borrowed (:func:`_borrowed`): the owners above and the
    # arguments stay alive to the end (:func:`_keep_alive` at every return)
    PI, PF, PM, x_from, x_to = _borrowed(PI), _borrowed(PF), _borrowed(PM), \
        _borrowed(x_from), _borrowed(x_to)
    q, rot, A, link, fa, r, S, first = _borrowed_state((q, rot, A, link, fa, r, S, first))
    res, cond, last, its, flag = _borrowed(res), _borrowed(cond), _borrowed(last), \
        _borrowed(its), _borrowed(flag)
    tangent, fopts, ucols, icols, x_cur = _borrowed(tangent), _borrowed(fopts), \
        _borrowed(ucols), _borrowed(icols), _borrowed(x_cur)
    P, Pi, Wi, Jp = _borrowed(P), _borrowed(Pi), (_borrowed(Jiv),), _borrowed(Jp)
    W, Wd = _borrowed_sp_work(W), _borrowed_lsq_work(Wd)
    co, trial, own, kept = _borrowed_state(sts[0]), _borrowed_state(sts[1]), \
        _borrowed_state(sts[2]), _borrowed_state(sts[3])
    pq, rs, step, w3, dx, xt, dv = _borrowed(vec[0]), _borrowed(vec[1]), _borrowed(vec[2]), \
        _borrowed(vec[3]), _borrowed(vec[4]), _borrowed(vec[5]), _borrowed(vec[6])
    R, X, newf, own_tan = _borrowed(mat[0]), _borrowed(mat[1]), _borrowed(mat[2]), \
        _borrowed(mat[3])
    prot, T, R3 = _borrowed(m3[0]), _borrowed(m3[1]), _borrowed(m3[2])
    rtol, path_step = fopts[1], fopts[3]
    min_step, tangent_cond = fopts[4], fopts[5]
    o_inv, o_unk, o_unkcs = PI[O_INV], PI[O_UNK], PI[F_UNKCS]
    o_cs, o_inq, o_insc = PI[F_COLSC], PI[O_INQ], PI[F_INSC]
    rtol_off = rtol * PF[PI[F_OFFSET]]
    B = q.shape[0]
    nv, ni = first.shape[1], first.shape[2]
    nu = ucols.shape[0]
    sweep = task == SWEEP
    newton_only = task == NEWTON
    solve_t = task == SOLVE
    kept_out = A.shape[0] > 0           # SOLVE: the kinematic states returned
    corr_its = min(maxiter, 8)
    if sweep:
        _fill(tangent, 0.0)
    n = x_to.shape[0] if sweep else B
    shared = False
    k_done, k_res, k_cond, k_last = False, 0.0, 0.0, 0.0
    for b in range(1 if sweep else 0, n):
        start_code = 0
        # phase 0: Newton from the member's own q, rot (NEWTON; SOLVE's start); 1: the path
        phase = 1
        if solve_t:
            cur = own
            if shared:                  # the previous member's start, shared
                _copy_state(kept, own, kept_out)
                res[b], cond[b], last[b] = k_res, k_cond, k_last
                start_code = 0 if k_done else 2
                if k_done and k_res > rtol_off:
                    start_code = 3
                shared = b + 1 < n and _same_guess(q, rot, x_from, b, b + 1)
            else:
                phase = 0
            x0, tb, have_b = x_from[b], own_tan, False
        elif sweep:                     # row b continues from row b − 1
            cur = (q[b], rot[b], A[b], link[b], fa[b], r[b], S[b], first[b])
            a = b - 1
            _copy_state((q[a], rot[a], A[a], link[a], fa[a], r[a], S[a], first[a]), cur)
            res[b], cond[b], last[b] = res[a], cond[a], last[a]
            x0, tb, have_b = x_cur[a], tangent[0], b >= 2
        else:
            cur = (q[b], rot[b], A[b], link[b], fa[b], r[b], S[b], first[b])
            x0, tb, have_b = x_from[b], tangent[b], have
            if newton_only:
                phase = 0
        x1, xc = x_to[b], x_cur[b]
        lam, h = 0.0, 1.0
        stop = 0
        path_its = 0
        need = True
        started = False
        span_s = 0.0
        big_pred, hh, final = 0.0, 0.0, True
        while True:
            if phase == 1 and not started:  # ------------------- the path: its length
                started = True
                span_s = 0.0
                for i in range(ni):
                    xc[i] = x0[i]
                    v = abs((x1[i] - x0[i]) / PF[o_insc + i])
                    if v > span_s or v != v:
                        span_s = v
                if span_s > fopts[7]:
                    _keep_alive(owners)
                    return -(b + 1)             # a path longer than MAX_PATH: refused
                if not span_s > 0:
                    break
            n_iter = maxiter
            if phase == 0:
                _copy(q[b], co[0])
                _copy(rot[b], co[1])
            else:
                n_iter = corr_its
                big_pred = 0.0
                if need:                # the tangent: the analogs at the current pose
                    f = cur[7]
                    miss = False
                    for c in range(nv):
                        for i in range(ni):
                            if f[c, i] != f[c, i]:
                                miss = True
                    if not miss:
                        _copy(f, newf)
                    else:               # not computed with a converged step: computed here
                        _fill(newf, 0.0)
                        for i in range(ni):
                            newf[PI[o_inv + i], i] = 1.0
                        if nu > 0:
                            _ls_jacobian(PI, PF, cur[6], ucols, P, W)
                            fast, c_, inv0 = _ls_factor(P, rank, W, Wd)
                            _analog_rhs(PI, PF, cur[6], icols, Pi, Wi[0], R)
                            for i in range(ni):
                                _ls_solve(P, fast, W, Wd, R, X, 1 + i)
                            for k in range(nu):
                                for i in range(ni):
                                    newf[PI[o_unk + k], i] = -X[k, 1 + i] * PF[o_unkcs + k]
                    # at a singular configuration the previous tangent is kept
                    if not (have_b and cond[b] > tangent_cond):
                        _copy(newf, tb)
                    have_b = True
                    need = False
                hh = min(h, 1.0 - lam)
                big = 0.0
                for i in range(ni):
                    dx[i] = x0[i] + (lam + hh) * (x1[i] - x0[i]) - xc[i]
                for c in range(nv):
                    s = 0.0
                    for i in range(ni):
                        s += tb[c, i] * dx[i]
                    v = abs(s / PF[o_cs + c])
                    if v > big or v != v:
                        big = v
                shrink = min(1.0, path_step / max(big, 1e-300))
                hh = hh * shrink
                final = lam + hh >= 1.0
                for i in range(ni):
                    xt[i] = x1[i] if final else xc[i] + dx[i] * shrink
                for c in range(nv):     # predictor: along the tangent to xt
                    s = 0.0
                    for i in range(ni):
                        s += tb[c, i] * (xt[i] - xc[i])
                    dv[c] = s / PF[o_cs + c]
                    v = abs(dv[c])
                    if v > big_pred or v != v:
                        big_pred = v
                _apply(PI, PF, cur[0], cur[1], dv, pq, prot, R3)
                for i in range(ni):
                    pq[PI[o_inq + i]] = xt[i]
                _copy(pq, co[0])
                _copy(prot, co[1])
            # ------------------------------------------------ Newton on the state co
            # the end of a SOLVE member's path whose state is not returned: a converged
            # pose needs no analogs and its last step only as a test, which a bound of it
            # from the previous iteration's factorisation (1 / σ_min ≤ prev_inv) can pass
            bounded = solve_t and phase == 1 and final and not kept_out
            co, trial, done, n_res, n_its, n_cond, n_last, _, _, _ = _newton(
                PI, PF, PM, co, trial, n_iter, bounded, ucols, icols, P, Pi, W, Wd, Wi, Jp, rs,
                step, R, X, T, w3, R3, rank, fopts, phase == 0)
            if phase == 0:              # ------------------------ Newton's pose: its figures
                if newton_only:
                    _copy_state(co, cur)
                    res[b], its[b], cond[b], flag[b], last[b] = n_res, n_its, n_cond, done, \
                        n_last
                    break
                co, own = own, co       # SOLVE: the start, then the path from it
                cur = own
                res[b], cond[b], last[b] = n_res, n_cond, n_last
                start_code = 0 if done else 2
                if done and n_res > rtol_off:
                    start_code = 3
                shared = b + 1 < n and _same_guess(q, rot, x_from, b, b + 1)
                if shared:
                    _copy_state(own, kept, kept_out)
                    k_done, k_res, k_cond, k_last = done, n_res, n_cond, n_last
                phase = 1
                continue
            # ------------------------------------------------ accept or halve
            jump = _distance(PI, PF, co[0], co[1], pq, prot, dv, R3, w3)
            if done and n_res <= rtol and jump <= 0.5 * big_pred:
                if solve_t:             # the corrected state becomes the member's (cur is
                    co, own = own, co   # own: co only ever holds scratch)
                    cur = own
                else:
                    _copy_state(co, cur)
                for i in range(ni):
                    xc[i] = xt[i]
                res[b], cond[b], last[b] = n_res, n_cond, n_last
                path_its += n_its
                lam = 1.0 if final else lam + hh
                h = 2.0 * hh
                need = True
                if final:
                    break
            else:
                h = 0.5 * hh
                if h * span_s < min_step:
                    stop = 3 if (done and n_res > rtol) else 4
                    break
        if newton_only:
            continue
        its[b] = path_its
        if solve_t:
            _copy_out(own, b, q, rot, A, link, fa, r, S, first)
            flag[b] = start_code if start_code else stop
        else:
            flag[b] = stop
            if sweep and stop:
                _keep_alive(owners)
                return b + 1
    _keep_alive(owners)
    return n


@numba.njit(**_JIT)
def evaluate_batch(PI, PF, PM, q, rot, A, link, fa, r, S):
    """:func:`_evaluate` for every member of a batch."""
    T, w3 = np.zeros((3, 4, 4)), np.zeros(3)
    for b in range(q.shape[0]):
        _evaluate(PI, PF, PM, q[b], rot[b], A[b], link[b], fa[b], r[b], S[b], T, w3)


@numba.njit(**_JIT)
def twists_batch(PI, PF, q, fa, S):
    """:func:`_twists` for every member of a batch."""
    for b in range(q.shape[0]):
        _twists(PI, PF, q[b], fa[b], S[b])


@numba.njit(**_JIT)
def apply_batch(PI, PF, q, rot, dv, q_out, rot_out):
    """:func:`_apply` for every member of a batch."""
    R3 = np.zeros((1, 3, 3))
    for b in range(q.shape[0]):
        _apply(PI, PF, q[b], rot[b], dv[b], q_out[b], rot_out[b], R3)


@numba.njit(**_JIT)
def distance_batch(PI, PF, qa, rota, qb, rotb, out):
    """:func:`_distance` for every member of a batch."""
    R3, w3 = np.zeros((1, 3, 3)), np.zeros(3)
    for b in range(qa.shape[0]):
        _distance(PI, PF, qa[b], rota[b], qb[b], rotb[b], out[b], R3, w3)


@numba.njit(**_JIT)
def scaled_jacobian_batch(PI, PF, S, cols, J):
    """:func:`_scaled_jacobian` for every member of a batch."""
    for b in range(S.shape[0]):
        _scaled_jacobian(PI, PF, S[b], cols, J[b])


@numba.njit(**_JIT)
def lsq_batch(task, J, rank, fast, cond, inv0, Ginv, U, inv_s, Vt, R, X, above):
    """The least squares over a batch (:class:`closure.lstsq._LstSq`): task 0 factors
    every ``J`` (Cholesky or truncated SVD; ``fast``, ``cond``, ``inv0`` and the factors
    out), 1 solves ``J X = R`` with those factors, 2 puts 1 / s_min (the estimate above
    ``above``) into ``cond``."""
    B, m, n = J.shape
    W = _lsq_work(m, n, R.shape[2])
    for b in range(B):
        if task == 0:
            fast[b], cond[b], inv0[b] = _lsq(J[b], rank, W)
            if fast[b]:
                _copy(W[3], Ginv[b])
            else:
                _copy(W[4], U[b])
                _copy(W[5], inv_s[b])
                _copy(W[6], Vt[b])
        elif task == 1:
            _lsq_solve(J[b], fast[b], Ginv[b], U[b], inv_s[b], Vt[b], R[b], X[b], W[8], W[9])
        else:
            cond[b] = _inv_smin(fast[b], inv0[b], above, Ginv[b], W[2], W[7])

