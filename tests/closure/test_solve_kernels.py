"""The compiled position solver (closure.solve_kernels), each figure against an independent
reference: numpy compositions of the joint transforms with closure.log_se3 / exp_so3,
central differences, closed forms (Freudenstein, the RSSR's output equation), and the
per-row Python loop the one-call sweep replaced."""
import subprocess
import sys

import numpy as np
import pytest

from closure import MechanismError, exp_so3, log_se3, log_so3
from closure import solve_kernels as K
from closure import solver as S
from linkwright.examples import crane
from linkwright.references import fourbar, freudenstein, rssr, rssr_output

from .models import parallelogram
from .test_spatial import _mixed_mechanism


def wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def hand_links(m, q, rot):
    """World pose of every link for one state, composed with numpy through the spanning
    tree from Joint.matrix and the joint frames (T_b = T_a F_a A(q) F_b⁻¹)."""
    t = m.tree
    T = [None] * len(m.links)
    T[0] = np.eye(4)
    for li in t.order[1:]:
        j = m.joints[t.parent_joint[li]]
        qj = q[None, t.q_offset[j.index]:t.q_offset[j.index] + j.nq]
        A = j.matrix(qj, rot[None, t.s_index[j.index]] if j.kind == "S" else None)[0]
        rel = j.frame_a @ A @ np.linalg.inv(j.frame_b)
        if t.forward[li]:
            T[li] = T[t.link_index[j.link_a]] @ rel
        else:
            T[li] = T[t.link_index[j.link_b]] @ np.linalg.inv(rel)
    return np.array(T)


@pytest.mark.parametrize("build", [lambda: rssr(0.2, 1)[0], crane.build, _mixed_mechanism])
def test_kernel_state_equals_numpy_composition_at_any_loop_rotation(build):
    """Links, joint frames, joint matrices and the loop residual twists (log of the loop
    transform about the centre, rotations of any size up to a half turn) of random
    states against numpy."""
    m = build()
    t = m.tree
    rng = np.random.default_rng(7)
    B = 40
    q = rng.normal(size=(B, t.nq)) * 1.5
    rot = exp_so3(rng.normal(size=(B, t.ns, 3)))
    ks = m.kinematic_state((q, rot))
    big = 0.0
    for b in range(B):
        T = hand_links(m, q[b], rot[b])
        np.testing.assert_allclose(ks.link[b], T, rtol=0, atol=1e-12)
        for j in m.joints:
            qj = q[b, None, t.q_offset[j.index]:t.q_offset[j.index] + j.nq]
            A = j.matrix(qj, rot[b, None, t.s_index[j.index]] if j.kind == "S" else None)[0]
            np.testing.assert_allclose(ks.A[b, j.index], A, rtol=0, atol=1e-14)
            np.testing.assert_allclose(ks.frame_a[b, j.index],
                                       T[t.link_index[j.link_a]] @ j.frame_a, rtol=0,
                                       atol=1e-12)
        for k, ci in enumerate(t.chords):
            j = m.joints[ci]
            qj = q[b, None, t.q_offset[j.index]:t.q_offset[j.index] + j.nq]
            A = j.matrix(qj, rot[b, None, t.s_index[j.index]] if j.kind == "S" else None)[0]
            G = T[t.link_index[j.link_a]] @ j.frame_a @ A @ np.linalg.inv(j.frame_b) @ \
                np.linalg.inv(T[t.link_index[j.link_b]])
            c = t.centre
            G[:3, 3] += G[:3, :3] @ c - c                   # about the centre
            ref = log_se3(G)
            big = max(big, np.linalg.norm(ref[3:]))
            np.testing.assert_allclose(ks.r[b, k], ref, rtol=0, atol=1e-9)
    assert big > np.pi / 2                                 # past a quarter turn too
    # the twists the plan computes from given frames are the state's
    np.testing.assert_array_equal(m.plan.twists(q, ks.frame_a), ks.S)


def test_apply_and_distance_against_numpy():
    m = _mixed_mechanism()
    plan, t = m.plan, m.tree
    rng = np.random.default_rng(11)
    B = 30
    q = rng.normal(size=(B, t.nq))
    rot = exp_so3(rng.normal(size=(B, t.ns, 3)))
    dv = rng.normal(size=(B, t.nv)) * 0.7
    q1, rot1 = plan.apply(q, rot, dv)
    np.testing.assert_allclose(q1[:, plan.scal_q], q[:, plan.scal_q] +
                               dv[:, plan.scal_v] * plan.col_scale[plan.scal_v], rtol=0,
                               atol=1e-15)
    for k, so in enumerate(plan.s_order):
        ref = exp_so3(dv[:, plan.s_cols[k]]) @ rot[:, so]
        np.testing.assert_allclose(rot1[:, so], ref, rtol=0, atol=1e-14)
    d = plan.distance((q1, rot1), (q, rot))                # the step back (rotations < π)
    np.testing.assert_allclose(d, dv, rtol=0, atol=1e-12)
    for k, so in enumerate(plan.s_order):                  # and numpy's log past a half turn
        rel = rot1[:, so] @ np.swapaxes(rot[:, so], -1, -2)
        np.testing.assert_allclose(d[:, plan.s_cols[k]], log_so3(rel), rtol=0, atol=1e-12)


def test_one_pose_equals_its_batch_member_and_the_closed_forms():
    """One input per call gives, bit for bit, the member of a batch from the same guess
    (every member is solved on its own), and the closed-form outputs."""
    phi0 = 0.2
    m, psi0 = rssr(phi0, 1)
    p0 = m.solve(0.0)
    x = np.array([0.02, -0.1, 0.3, 0.9, -1.4])
    batch = m.solve(x, guess=p0)
    col = m.tree.q_offset[m.joint("out").index]
    for i, xi in enumerate(x):
        one = m.solve(xi, guess=p0)
        for f in ("q", "rot", "residual", "iterations", "status", "reached"):
            np.testing.assert_array_equal(getattr(one, f)[0], getattr(batch, f)[i])
        assert one.condition == batch.condition[i]
    np.testing.assert_allclose(wrap(psi0 + batch.q[:, col] - rssr_output(phi0 + x, 1)), 0,
                               atol=1e-12)
    geom = dict(a=1.0, b=3.0, c=2.5, d=3.2)
    m, (t3, t4) = fourbar(**geom, t2_0=0.3)
    g = m.solve(0.0)
    for xi in (0.05, -0.6, 1.3):
        p = m.solve(xi, guess=g)
        r3, r4 = freudenstein(0.3 + xi, **geom)
        assert abs(wrap(p["D"] - (r4 - t4))) < 1e-12
        assert abs(wrap(p["A"] + p["B"] - (r3 - t3))) < 1e-12
        assert p.residual[0] < 1e-13 and p.iterations[0] >= 1


def test_fused_analogs_of_two_inputs_equal_central_differences():
    """With two inputs (the crane's strokes, lengths) the solver's last Newton step gives
    complete analogs (input rows the unit vectors), equal to central differences."""
    m = crane.build()
    x0 = np.array([0.05, -0.03])
    p = m.solve(x0)
    first = p.kinematics().first
    assert first is not None and not np.isnan(first).any()
    np.testing.assert_array_equal(first[0, m.input_columns()], np.eye(2))
    ks = m.kinematic_state(p.state)                       # no fused analogs: recomputed
    from closure.pose import Pose
    bare = Pose(m, p.inputs, p.q, p.rot, p.residual, p.iterations, p.condition, p.status,
                _ks=ks)
    np.testing.assert_allclose(m.analogs(bare, second=False)[0], first, rtol=0, atol=1e-12)
    h = 1e-6
    cols = [m.tree.v_offset[j.index] for j in m.joints]   # one coordinate per joint
    for i in range(2):
        e = np.eye(2)[i] * h
        fd = (m.solve(x0 + e, guess=p).q - m.solve(x0 - e, guess=p).q)[0] / (2 * h)
        np.testing.assert_allclose(first[0, cols, i], fd, rtol=0, atol=1e-7)
    # a solved pose with complete analogs needs no correction as the next guess
    assert S._settled(m, p, S.SolverOptions())


def test_sweep_rows_equal_the_per_row_continuation():
    """The sweep's rows in one kernel call are those of continuing row by row from the
    previous row with its tangent (the Python loop the call replaced), bit for bit."""
    for m, x in ((rssr(0.2, 1)[0], np.linspace(0.0, 1.2, 13)),
                 (parallelogram(1.0, 2.0), np.linspace(0.0, 2 * np.pi, 9))):
        opts = S.SolverOptions()
        df, pose = m.sweep(x, return_pose=True)
        cur = m.solve(x[0], raise_on_failure=False)
        q, its, tangent = [cur.q[0]], [cur.iterations[0]], None
        for xi in x[1:]:
            cur, stop, tangent = S._continue(m, cur, xi[None], opts, tangent=tangent)
            assert stop[0] == 0
            q.append(cur.q[0])
            its.append(cur.iterations[0])
        np.testing.assert_array_equal(pose.q, np.array(q))
        np.testing.assert_array_equal(df.iterations.to_numpy(), its)


def test_far_inputs_are_refused_where_the_path_gets_there():
    m, _ = fourbar(1.0, 3.0, 2.5, 3.2, 0.3)
    with pytest.raises(MechanismError, match=r"lie 1e\+05 \(dimensionless\) from the guess "
                                             r"at \[0\.0\]"):
        m.solve(1e5)
    with pytest.raises(MechanismError, match=r"\[20000\.1\] lie 2e\+04 \(dimensionless\) from "
                                             r"the guess at \[0\.1\]"):
        m.sweep([0.0, 0.1, 20000.1, 0.2])
    # a path that stops first (the dead point of a non-Grashof crank) never gets there
    m, _ = fourbar(2.0, 2.5, 1.5, 3.0, t2_0=0.5)
    df = m.sweep([0.0, 2.0, 2e4])
    assert df.status.tolist() == ["ok", "dead point", "not reached"]


def test_exactly_singular_pose_gives_a_finite_minimum_norm_answer():
    """Newton at the flat parallelogram (rank-deficient Jacobian): the truncated SVD's
    minimum-norm steps keep the answer finite and closed, the condition says singular."""
    m = parallelogram(1.0, 2.0)
    flat = m.solve(0.0, continuation=False)
    assert flat.status_text[0] == "near-singular" and flat.condition[0] > 1e12
    assert np.isfinite(flat.q).all() and flat.residual[0] < 1e-13
    # continuation through the other flat position stays on the parallelogram branch:
    # the couplers translate (B = −x, C = D = x)
    moved = m.solve(np.pi, guess=m.solve(np.pi / 2))
    assert moved.status_text[0] == "near-singular" and moved.residual[0] < 1e-13
    np.testing.assert_allclose(wrap(moved.q[0] - np.pi * np.array([1, -1, 1, 1])), 0,
                               atol=1e-9)


@pytest.mark.parametrize("build", [lambda: rssr(0.2, 1)[0], lambda: parallelogram(1.0, 2.0)])
def test_step_bound_bounds_the_newton_step_and_the_condition_estimate(build):
    """The bound that ends a batch member's path without factoring its last Jacobian
    (:func:`closure.solve_kernels._step_bound`: Weyl from the previous iteration's
    factorisation) is at least the minimum-norm Newton step and the condition estimate
    it stands for, from near a solved pose to far from it (then no bound: inf)."""
    m = build()
    plan, ucols = m.plan, m.plan._ucols
    PI, PF, _ = plan.packed
    P = K._pattern(PI, PF, ucols)
    W = K._sp_work(P, 2)
    p = m.solve(0.3)
    def gram(J):                        # J Jᵀ wide, Jᵀ J tall
        return J @ J.T if J.shape[0] < J.shape[1] else J.T @ J
    J0 = plan.scaled_jacobian(p.kinematics().S, ucols)[0]
    inv_prev = np.sqrt(np.trace(np.linalg.inv(gram(J0))))
    rng = np.random.default_rng(2)
    for size in (1e-10, 1e-7, 1e-4, 1e-2, 1.0):
        dv = np.zeros((1, plan.nv))
        dv[0, ucols] = rng.normal(size=ucols.size) * size
        ks = plan.evaluate(*plan.apply(p.q, p.rot, dv))
        J = plan.scaled_jacobian(ks.S, ucols)[0]
        r = plan.scaled_residual(ks.r)[0]
        W[5][:] = J
        step_bound, cond_bound = K._step_bound(P, K._jac_values(P, W), J0.ravel(),
                                                  inv_prev, r)
        if size == 1.0:
            assert step_bound == cond_bound == np.inf
            continue
        step = np.linalg.pinv(J) @ r
        cest = np.sqrt((J * J).sum() * np.trace(np.linalg.inv(gram(J))))
        assert np.linalg.norm(step) <= step_bound < np.inf
        assert cest <= cond_bound


def test_kernels_compile_once_whatever_the_mechanism():
    """Every mechanism, batch size and solver path calls the kernels with arrays of the
    same types: one compiled version each (the first-call compile is paid once)."""
    for build, x in ((lambda: rssr(0.2, 1)[0], 0.1), (crane.build, np.array([0.02, 0.01])),
                     (_mixed_mechanism, np.array([0.05, 0.02, -0.03, 0.04])),
                     (lambda: parallelogram(1.0, 2.0), 0.3)):
        m = build()
        p = m.solve(x)
        p.condition
        m.solve(x, continuation=False)
        m.solve(np.stack([x] * 3) if np.ndim(x) else np.full(3, x))
        m.sweep(np.stack([x * 0, x]) if np.ndim(x) else [0.0, x])
        m.analogs(p)
    for f in (K.drive, K.evaluate_batch, K.apply_batch, K.lsq_batch,
              K.scaled_jacobian_batch):
        assert len(f.signatures) <= 1, (f, f.signatures)


def test_import_closure_does_not_import_numba():
    code = ("import sys, closure\n"
            "assert 'numba' not in sys.modules\n"
            "from linkwright.references import rssr\n"
            "rssr(0.2, 1)[0].solve(0.1)\n"
            "assert 'numba' in sys.modules\n")
    subprocess.run([sys.executable, "-c", code], check=True)


# -------------------------------------------------------------------- the kernels' sin, cos

_PI = ("3.14159265358979323846264338327950288419716939937510582097494459230781640628620"
       "89986280348253421170679821480865132823066470938446")


def _exact_sin_cos(x: float):
    """sin x and cos x to 60 digits (decimal arithmetic: reduction by 2π, Taylor series)."""
    from decimal import Decimal, localcontext
    with localcontext() as ctx:
        ctx.prec = 60
        pi = Decimal(_PI)
        d = Decimal(x)                                  # exact
        r = d - (d / (2 * pi)).to_integral_value() * 2 * pi
        s = c = Decimal(0)
        t = Decimal(1)
        for n in range(90):
            if n % 2:
                s += t if n % 4 == 1 else -t
            else:
                c += t if n % 4 == 0 else -t
            t = t * r / (n + 1)
        return s, c


def _ulps(got: np.ndarray, exact) -> float:
    from decimal import Decimal
    return max(float(abs(Decimal(float(g)) - e) / Decimal(float(np.spacing(abs(float(e))))))
               for g, e in zip(got, exact))


@pytest.fixture(scope="module")
def sincos():
    import numba

    @numba.njit
    def both(x):
        s, c = np.empty_like(x), np.empty_like(x)
        for i in range(x.size):
            s[i], c[i] = K._sincos(x[i])
        return s, c
    return both


@pytest.mark.parametrize("lo, hi", [(0.0, 0.8), (0.8, 7.0), (7.0, 1e3), (1e3, 99_999.0)])
def test_kernel_sin_cos_within_two_ulp_of_the_exact_values(sincos, lo, hi):
    rng = np.random.default_rng(int(hi))
    x = rng.uniform(lo, hi, 600) * rng.choice([-1.0, 1.0], 600)
    if lo == 0.8:                                        # next to multiples of π/2 and π/4
        k = rng.integers(1, 4, 100)
        x[:100] = np.nextafter(k * np.pi / 2, k * np.pi / 2 + rng.choice([-1, 1], 100))
        x[100:200] = k * np.pi / 4 * (1 + rng.uniform(-1e-12, 1e-12, 100))
    s, c = sincos(x)
    exact = [_exact_sin_cos(v) for v in x]
    assert _ulps(s, [e[0] for e in exact]) <= 2.0
    assert _ulps(c, [e[1] for e in exact]) <= 2.0


def test_kernel_sin_cos_beyond_the_reduction_and_at_special_values(sincos):
    import math
    x = np.array([1e5, -1e5, 3.7e7, -1e300, 0.0, -0.0, 5e-324])
    s, c = sincos(x)
    assert s.tolist() == [math.sin(v) for v in x]        # libm's from 1e5 on
    assert c.tolist() == [math.cos(v) for v in x]
    assert np.signbit(s[5]) and s[6] == 5e-324 and c[4] == c[5] == 1.0
    s, c = sincos(np.array([np.inf, -np.inf, np.nan]))
    assert np.isnan(s).all() and np.isnan(c).all()
