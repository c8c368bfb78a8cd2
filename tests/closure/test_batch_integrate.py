"""closure.batch_integrate: B trajectories in lockstep, each scipy's ``solve_ivp`` alone.

1. Against scipy, member by member, for RK45 and DOP853 on a harmonic oscillator, a
   damped pendulum, Van der Pol (μ = 1), a Kepler orbit and a forced (time-dependent)
   oscillator: the same step sequence (accepted steps, ``nfev``), the step times, the
   end state and the ``t_eval`` output.  The step times agree to rounding amplified
   by the controller: where the error estimate is far below the tolerance it is
   rounding noise (scipy sums the stages by BLAS, we element-wise), and the next
   step size follows it (``h ∝ err^(-1/5)``); the states agree to ~1e-12.
2. Stops: by the right-hand side (mask, reasons, non-finite rows, at t0, inside
   DOP853's dense-output stages), step size too small (scipy's status -1).
3. Properties (hypothesis): batching invariance (bit-for-bit), time-shift invariance
   of autonomous systems, bad inputs raise MechanismError naming the argument.
"""
from __future__ import annotations

import numpy as np
import pytest
import scipy.integrate as si
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from closure import MechanismError
from closure import batch_integrate as bi
from closure.batch_integrate import BatchResult, integrate_batch

FAST = settings(max_examples=20, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow])
METHODS = ["RK45", "DOP853"]


# ------------------------------------------------------------------ systems
# each: (batched rhs, single-member rhs factory, y0 (B, m), t_span)

def harmonic():
    w = np.array([1.0, 2.0, 0.5, 3.0])
    y0 = np.array([[1.0, 0.0], [0.3, -1.0], [2.0, 0.5], [0.0, 1.0]])

    def f(t, y, m):
        return np.stack([y[:, 1], -w[m] ** 2 * y[:, 0]], axis=1)

    return f, lambda b: (lambda t, y: [y[1], -w[b] ** 2 * y[0]]), y0, (0.0, 10.0)


def pendulum():
    p = np.array([[9.81, 0.0], [9.81, 0.3], [4.0, 0.1]])     # g/L (1/s²), damping (1/s)
    y0 = np.array([[1.0, 0.0], [3.0, 0.0], [0.2, 2.0]])

    def f(t, y, m):
        return np.stack([y[:, 1], -p[m, 0] * np.sin(y[:, 0]) - p[m, 1] * y[:, 1]], axis=1)

    return (f, lambda b: (lambda t, y: [y[1], -p[b, 0] * np.sin(y[0]) - p[b, 1] * y[1]]),
            y0, (0.0, 5.0))


def van_der_pol():
    y0 = np.array([[2.0, 0.0], [0.1, 0.0], [-1.0, 3.0]])

    def f(t, y, m):
        return np.stack([y[:, 1], (1 - y[:, 0] ** 2) * y[:, 1] - y[:, 0]], axis=1)

    return f, lambda b: (lambda t, y: [y[1], (1 - y[0] ** 2) * y[1] - y[0]]), y0, (0.0, 8.0)


def kepler():
    e = np.array([0.0, 0.3, 0.6])
    y0 = np.column_stack([1 - e, 0 * e, 0 * e, np.sqrt((1 + e) / (1 - e))])

    def f(t, y, m):
        r3 = (y[:, 0] ** 2 + y[:, 1] ** 2) ** 1.5
        return np.stack([y[:, 2], y[:, 3], -y[:, 0] / r3, -y[:, 1] / r3], axis=1)

    def single(b):
        def g(t, y):
            r3 = (y[0] ** 2 + y[1] ** 2) ** 1.5
            return [y[2], y[3], -y[0] / r3, -y[1] / r3]
        return g

    return f, single, y0, (0.0, 2 * np.pi)


def forced():
    """y'' + 0.1 y' + y = cos(ω t): each member's own t reaches the right-hand side."""
    w = np.array([0.5, 1.0, 3.0])
    y0 = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, -1.0]])

    def f(t, y, m):
        return np.stack([y[:, 1], np.cos(w[m] * t) - 0.1 * y[:, 1] - y[:, 0]], axis=1)

    return (f, lambda b: (lambda t, y: [y[1], np.cos(w[b] * t) - 0.1 * y[1] - y[0]]),
            y0, (0.0, 12.0))


SYSTEMS = {"harmonic": harmonic, "pendulum": pendulum, "van_der_pol": van_der_pol,
           "kepler": kepler, "forced": forced}


def _compare(system, method, rtol, atol, *, t_tol, y_tol, t_span=None, n_eval=23, **kw):
    f, single, y0, span = SYSTEMS[system]()
    span = t_span or span
    te = np.linspace(span[0], span[1], n_eval)
    r = integrate_batch(f, span, y0, method=method, t_eval=te, rtol=rtol, atol=atol,
                        keep_steps=True, **kw)
    assert (r.status == 0).all(), r.message
    length = abs(span[1] - span[0])
    for b in range(len(y0)):
        steps = si.solve_ivp(single(b), span, y0[b], method=method, rtol=rtol, atol=atol, **kw)
        dense = si.solve_ivp(single(b), span, y0[b], method=method, rtol=rtol, atol=atol,
                             t_eval=te, **kw)
        scale = np.abs(steps.y).max()
        # the same step sequence: accepted steps and evaluations (2 + S per attempt
        # + 3 per dense output of DOP853)
        assert r.steps[b] == len(steps.t) - 1
        assert r.nfev[b] == dense.nfev
        t_b = r.t_steps[b, :r.steps[b] + 1]
        assert np.abs(t_b - steps.t).max() <= t_tol * length
        assert r.t_end[b] == span[1]
        np.testing.assert_allclose(r.y_end[b], steps.y[:, -1], rtol=0, atol=y_tol * scale)
        np.testing.assert_array_equal(r.y_steps[b, :, r.steps[b]], r.y_end[b])
        np.testing.assert_allclose(r.y[b], dense.y, rtol=0, atol=y_tol * scale)
    assert np.isnan(r.t_steps[r.steps < r.steps.max(), -1]).all()
    return r


@pytest.mark.parametrize("system", list(SYSTEMS))
@pytest.mark.parametrize("method", METHODS)
def test_each_member_is_scipys_run_alone(system, method):
    r = _compare(system, method, 1e-7, 1e-10, t_tol=1e-6, y_tol=1e-11)
    # members finish after different numbers of steps
    assert len(set(r.steps.tolist())) > 1


@pytest.mark.parametrize("method", METHODS)
def test_loose_tolerance_same_steps(method):
    """rtol 1e-3: few, large steps, many rejections; still scipy's sequence."""
    r = _compare("van_der_pol", method, 1e-3, 1e-6, t_tol=1e-6, y_tol=1e-8)
    assert r.rejected.sum() > 0


@pytest.mark.parametrize("method", METHODS)
def test_backwards_max_step_first_step(method):
    _compare("pendulum", method, 1e-8, 1e-10, t_tol=1e-6, y_tol=1e-11, t_span=(5.0, -1.0))
    _compare("harmonic", method, 1e-6, 1e-9, t_tol=1e-6, y_tol=1e-11, max_step=0.3)
    _compare("kepler", method, 1e-6, 1e-9, t_tol=1e-6, y_tol=1e-11, first_step=1e-3)


def test_tolerances_per_member_and_component():
    f, single, y0, span = SYSTEMS["kepler"]()
    rtol = np.array([1e-4, 1e-6, 1e-8])
    atol = np.array([1e-7, 1e-7, 1e-9, 1e-9])         # per component (m,)
    r = integrate_batch(f, span, y0, rtol=rtol, atol=atol)
    for b in range(3):
        s = si.solve_ivp(single(b), span, y0[b], rtol=rtol[b], atol=atol)
        assert r.steps[b] == len(s.t) - 1 and r.nfev[b] == s.nfev
        np.testing.assert_allclose(r.y_end[b], s.y[:, -1], rtol=0, atol=1e-11)
    atol_b = np.array([[1e-6], [1e-8], [1e-10]])      # per member (B, 1)
    r = integrate_batch(f, span, y0, rtol=1e-6, atol=atol_b)
    for b in range(3):
        s = si.solve_ivp(single(b), span, y0[b], rtol=1e-6, atol=atol_b[b, 0])
        assert r.steps[b] == len(s.t) - 1 and r.nfev[b] == s.nfev


def test_controller_constants_are_scipys():
    from scipy.integrate._ivp import rk
    assert (bi.SAFETY, bi.MIN_FACTOR, bi.MAX_FACTOR) == (rk.SAFETY, rk.MIN_FACTOR, rk.MAX_FACTOR)
    for name, cls in (("RK45", si.RK45), ("DOP853", si.DOP853)):
        assert bi.BATCH_METHODS[name].exponent == -1 / (cls.error_estimator_order + 1)


def test_result_fields_and_counts():
    f, _, y0, span = SYSTEMS["harmonic"]()
    te = np.array([0.0, 2.5, 10.0])
    r = integrate_batch(f, span, y0, t_eval=te)
    B, m = y0.shape
    assert isinstance(r, BatchResult)
    assert r.y.shape == (B, m, 3) and r.t_end.shape == r.status.shape == (B,)
    assert r.y_end.shape == (B, m) and r.t_steps is None and r.y_steps is None
    assert r.success.all() and (r.message == bi._MSG_FINISHED).all()
    np.testing.assert_array_equal(r.y[:, :, 0], y0)
    np.testing.assert_allclose(r.y[:, :, -1], r.y_end, rtol=0, atol=1e-14)  # interpolant at t1
    # RK45 without dense output: 2 + 6 evaluations per attempt
    assert (r.nfev == 2 + 6 * (r.steps + r.rejected)).all()
    # no t_eval: no dense output, the end state only
    r2 = integrate_batch(f, span, y0)
    assert r2.y.shape == (B, m, 0) and r2.t_eval.shape == (0,)
    np.testing.assert_array_equal(r2.y_end, r.y_end)


def test_empty_span():
    f, _, y0, _ = SYSTEMS["harmonic"]()
    r = integrate_batch(f, (1.0, 1.0), y0, t_eval=[1.0])
    assert (r.status == 0).all() and (r.steps == 0).all() and (r.nfev == 1).all()
    np.testing.assert_array_equal(r.y[:, :, 0], y0)


def test_step_size_too_small_as_scipy():
    """y' = y² from y(0) = 1 blows up at t = 1: status -1 with scipy's steps and message;
    the other members (no blow-up before t = 2) finish."""
    y0 = np.array([[1.0], [0.2], [-1.0]])
    for method in METHODS:
        r = integrate_batch(lambda t, y, m: y ** 2, (0.0, 2.0), y0, method=method,
                            rtol=1e-6, atol=1e-9, t_eval=np.linspace(0, 2, 9))
        s = si.solve_ivp(lambda t, y: y ** 2, (0.0, 2.0), [1.0], method=method, rtol=1e-6,
                         atol=1e-9)
        assert r.status.tolist() == [-1, 0, 0]
        assert r.message[0] == s.message
        assert r.steps[0] == len(s.t) - 1
        assert abs(r.t_end[0] - s.t[-1]) < 1e-12
        assert np.isnan(r.y[0, 0, 5:]).all() and np.isfinite(r.y[0, 0, :5]).all()
        np.testing.assert_allclose(r.y_end[1:, 0], [1 / 3, -1 / 3], rtol=1e-5)


# ------------------------------------------------------------------ stops by the rhs

def _dead_above(limit, kind="mask"):
    """Harmonic oscillators that fail where x > ``limit`` (a stand-in for a dead point)."""
    def f(t, y, m):
        dy = np.stack([y[:, 1], -y[:, 0]], axis=1)
        bad = y[:, 0] > limit
        if kind == "mask":
            return dy, bad
        if kind == "reason":
            return dy, np.where(bad, "dead point", "")
        if kind == "object":
            return dy, np.array([f"x = {v:.3f}" if b else None for v, b in zip(y[:, 0], bad)],
                                dtype=object)
        dy[bad] = np.nan
        return dy
    return f


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("kind", ["mask", "reason", "object", "nan"])
def test_rhs_stops_a_member_the_others_go_on(method, kind):
    y0 = np.array([[0.5, 0.0], [0.0, 1.0], [0.2, 0.0], [0.9, 0.0]])   # amplitudes .5 1 .2 .9
    te = np.linspace(0, 6, 61)
    r = integrate_batch(_dead_above(0.95, kind), (0.0, 6.0), y0, method=method, t_eval=te,
                        rtol=1e-8, atol=1e-10, keep_steps=True)
    assert r.status.tolist() == [0, 1, 0, 0]
    assert r.success.all()
    # member 1 (x = sin t) stops before x reaches 0.95, at its last accepted step
    t_stop = r.t_end[1]
    assert 0.5 < t_stop < np.arcsin(0.95)
    assert t_stop == np.nanmax(r.t_steps[1])
    np.testing.assert_array_equal(r.y_end[1], r.y_steps[1, :, r.steps[1]])
    np.testing.assert_allclose(r.y_end[1], [np.sin(t_stop), np.cos(t_stop)], atol=1e-7)
    assert np.isnan(r.y[1][:, te > t_stop]).all() and np.isfinite(r.y[1][:, te <= t_stop]).all()
    expect = {"mask": "failed", "reason": "dead point", "object": "x = 0.9",
              "nan": "non-finite"}[kind]
    assert expect in r.message[1] and "right-hand side" in r.message[1]
    # the others are exactly as without member 1
    alone = integrate_batch(_dead_above(0.95, kind), (0.0, 6.0), y0[[0, 2, 3]], method=method,
                            t_eval=te, rtol=1e-8, atol=1e-10)
    np.testing.assert_array_equal(r.y[[0, 2, 3]], alone.y)
    np.testing.assert_array_equal(r.nfev[[0, 2, 3]], alone.nfev)


def test_rhs_fails_at_t0():
    y0 = np.array([[2.0, 0.0], [0.1, 0.0]])
    r = integrate_batch(_dead_above(1.0), (0.0, 1.0), y0, t_eval=[0.0, 0.5, 1.0])
    assert r.status.tolist() == [1, 0]
    assert r.t_end[0] == 0.0 and r.steps[0] == 0 and r.nfev[0] == 1
    np.testing.assert_array_equal(r.y[0, :, 0], y0[0])
    assert np.isnan(r.y[0, :, 1:]).all()


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("alone", [False, True])
def test_failure_at_any_evaluation(method, alone):
    """The failing member fails at its k-th evaluation, for every k (the derivative at
    t0, the initial-step probe, the stages of accepted and rejected attempts, DOP853's
    dense-output stages): it stops at its last accepted step with exactly k
    evaluations; the other member is unaffected."""
    y0 = np.array([[1.0, 0.0], [0.0, 1.0]])[1:] if alone else np.array([[1.0, 0.0], [0.0, 1.0]])
    j = len(y0) - 1                              # the failing member
    te = np.linspace(0, 3, 40)
    ref = integrate_batch(_dead_above(np.inf), (0.0, 3.0), y0, method=method, t_eval=te,
                          rtol=1e-3, atol=1e-6)
    assert ref.nfev[j] > 40
    for k in range(1, ref.nfev[j] + 1):
        count = [0]

        def f(t, y, m, k=k):
            dy = np.stack([y[:, 1], -y[:, 0]], axis=1)
            bad = np.zeros(len(m), bool)
            if j in m:
                count[0] += 1
                bad[m == j] = count[0] == k
            return dy, bad

        r = integrate_batch(f, (0.0, 3.0), y0, method=method, t_eval=te, rtol=1e-3, atol=1e-6,
                            keep_steps=True)
        assert r.status[j] == 1 and r.nfev[j] == k, (k, r.status, r.nfev)
        assert r.t_end[j] == np.nanmax(r.t_steps[j])
        np.testing.assert_array_equal(r.y_end[j], r.y_steps[j, :, r.steps[j]])
        covered = te <= r.t_end[j]
        assert np.isfinite(r.y[j][:, covered]).all() and np.isnan(r.y[j][:, ~covered]).all()
        np.testing.assert_array_equal(r.y[:j], ref.y[:j])
        np.testing.assert_array_equal(r.y[j][:, covered], ref.y[j][:, covered])


def test_rhs_wrong_shape_raises():
    with pytest.raises(MechanismError, match="rhs"):
        integrate_batch(lambda t, y, m: y[:, :1], (0, 1), np.ones((3, 2)))
    with pytest.raises(MechanismError, match="failed"):
        integrate_batch(lambda t, y, m: (y, np.zeros(2, bool)), (0, 1), np.ones((3, 2)))


def test_rhs_arguments_are_read_only():
    def f(t, y, m):
        m[0] = 5
        return y
    with pytest.raises(ValueError, match="read-only"):
        integrate_batch(f, (0, 1), np.ones((2, 1)))


# ------------------------------------------------------------------ properties

def _chain(k):
    """k unit masses in a chain of springs (m = 2k, above numpy's pairwise-sum block)."""
    def f(t, y, mem):
        x, v = y[:, :k], y[:, k:]
        xp = np.pad(x, ((0, 0), (1, 1)))
        return np.concatenate([v, xp[:, :-2] - 2 * x + xp[:, 2:]], axis=1)
    return f


members = st.lists(st.tuples(st.floats(-2, 2), st.floats(-2, 2), st.floats(0.2, 3.0)),
                   min_size=2, max_size=12)


@FAST
@given(members=members, method=st.sampled_from(METHODS), seed=st.integers(0, 2 ** 16))
def test_batching_invariance(members, method, seed):
    """A member's result is bit-for-bit the same in any batch, in any order."""
    p = np.array(members)
    y0, w = p[:, :2], p[:, 2]

    def f(t, y, m, w=w):
        return np.stack([y[:, 1], -w[m] * np.sin(y[:, 0]) + 0.1 * np.cos(t)], axis=1)

    te = np.linspace(0, 4, 17)
    kw = dict(method=method, t_eval=te, rtol=1e-6, atol=1e-9, keep_steps=True)
    full = integrate_batch(f, (0.0, 4.0), y0, **kw)
    rng = np.random.default_rng(seed)
    perm = rng.permutation(len(p))
    sub = perm[:max(1, len(p) // 2)]
    for idx in (perm, sub):
        part = integrate_batch(lambda t, y, m: f(t, y, idx[m]), (0.0, 4.0), y0[idx], **kw)
        np.testing.assert_array_equal(part.y, full.y[idx])
        np.testing.assert_array_equal(part.y_end, full.y_end[idx])
        np.testing.assert_array_equal(part.nfev, full.nfev[idx])
        np.testing.assert_array_equal(part.steps, full.steps[idx])
        width = part.t_steps.shape[1]
        np.testing.assert_array_equal(part.t_steps, full.t_steps[idx, :width])


@FAST
@given(seed=st.integers(0, 2 ** 16), n=st.integers(2, 8), method=st.sampled_from(METHODS))
def test_batching_invariance_many_components(seed, n, method):
    y0 = np.random.default_rng(seed).normal(size=(n, 10))
    full = integrate_batch(_chain(5), (0.0, 2.0), y0, method=method, rtol=1e-6, atol=1e-9)
    one = integrate_batch(_chain(5), (0.0, 2.0), y0[n // 2:n // 2 + 1], method=method,
                          rtol=1e-6, atol=1e-9)
    np.testing.assert_array_equal(one.y_end[0], full.y_end[n // 2])


@FAST
@given(shift=st.floats(-50, 50), members=members, method=st.sampled_from(METHODS))
def test_time_shift_invariance(shift, members, method):
    """An autonomous system started at t0 + T gives the same states at t + T (to the
    rounding of the shifted times) and the same step counts up to a near-tie."""
    p = np.array(members)
    y0, w = p[:, :2], p[:, 2]

    def f(t, y, m):
        return np.stack([y[:, 1], -w[m] * np.sin(y[:, 0])], axis=1)

    te = np.linspace(0, 3, 13)
    kw = dict(method=method, rtol=1e-8, atol=1e-10)
    a = integrate_batch(f, (0.0, 3.0), y0, t_eval=te, **kw)
    b = integrate_batch(f, (shift, shift + 3.0), y0, t_eval=te + shift, **kw)
    scale = np.abs(a.y).max()
    np.testing.assert_allclose(b.y, a.y, rtol=0, atol=1e-7 * scale)
    assert np.abs(b.steps - a.steps).max() <= 2


def _bad_inputs():
    f = SYSTEMS["harmonic"]()[0]
    y0 = np.ones((3, 2))
    ok = dict(rhs=f, t_span=(0.0, 1.0), y0=y0)
    cases = [
        ("rhs", dict(ok, rhs="f")),
        ("method", dict(ok, method="RK23")),
        ("method", dict(ok, method="rk45")),
        ("t_span", dict(ok, t_span=(0.0,))),
        ("t_span", dict(ok, t_span=(0.0, np.inf))),
        ("t_span", dict(ok, t_span="ab")),
        ("y0", dict(ok, y0=np.ones(3))),
        ("y0", dict(ok, y0=np.ones((0, 2)))),
        ("y0", dict(ok, y0=np.ones((3, 0)))),
        ("y0", dict(ok, y0=np.ones((2, 2, 2)))),
        ("y0", dict(ok, y0=[[1.0, "a"]])),
        ("y0", dict(ok, y0=np.ones((3, 2)) * 1j)),
        ("rtol", dict(ok, rtol=0.0)),
        ("rtol", dict(ok, rtol=-1e-3)),
        ("rtol", dict(ok, rtol=np.nan)),
        ("rtol", dict(ok, rtol=np.ones(2) * 1e-3)),
        ("rtol", dict(ok, rtol="x")),
        ("atol", dict(ok, atol=0.0)),
        ("atol", dict(ok, atol=np.array([1e-6, -1.0]))),
        ("atol", dict(ok, atol=np.ones(3))),
        ("atol", dict(ok, atol=np.inf)),
        ("max_step", dict(ok, max_step=0.0)),
        ("max_step", dict(ok, max_step="big")),
        ("first_step", dict(ok, first_step=-1.0)),
        ("first_step", dict(ok, first_step=2.0)),
        ("t_eval", dict(ok, t_eval=[0.5, 2.0])),
        ("t_eval", dict(ok, t_eval=[-0.5])),
        ("t_eval", dict(ok, t_eval=[0.5, 0.2])),
        ("t_eval", dict(ok, t_eval=[0.5, 0.5])),
        ("t_eval", dict(ok, t_eval=[[0.5]])),
        ("t_eval", dict(ok, t_eval=[np.nan])),
        ("t_eval", dict(ok, t_span=(1.0, 0.0), t_eval=[0.2, 0.5])),
        ("keep_steps", dict(ok, keep_steps="yes")),
    ]
    return cases


@pytest.mark.parametrize("name,kwargs", _bad_inputs())
def test_bad_inputs_name_the_argument(name, kwargs):
    with pytest.raises(MechanismError, match=name):
        integrate_batch(**kwargs)


@FAST
@given(data=st.data(), B=st.integers(1, 5), m=st.integers(1, 4))
def test_bad_values_raise_naming_the_argument(data, B, m):
    """Random non-finite entries in y0, non-positive or non-finite tolerances, t_eval
    outside the span or out of order: a MechanismError (a ValueError) naming it."""
    y0 = np.ones((B, m))
    ok = dict(rhs=lambda t, y, mem: -y, t_span=(0.0, 1.0), y0=y0)
    which = data.draw(st.sampled_from(["y0", "rtol", "atol", "t_eval_out", "t_eval_order"]))
    bad_number = st.one_of(st.floats(max_value=0.0), st.sampled_from([np.nan, np.inf]))
    if which == "y0":
        y = y0.copy()
        y[data.draw(st.integers(0, B - 1)), data.draw(st.integers(0, m - 1))] = \
            data.draw(st.sampled_from([np.nan, np.inf, -np.inf]))
        kw, name = dict(ok, y0=y), "y0"
    elif which == "rtol":
        kw, name = dict(ok, rtol=data.draw(bad_number)), "rtol"
    elif which == "atol":
        a = np.full(m, 1e-6)
        a[data.draw(st.integers(0, m - 1))] = data.draw(bad_number)
        kw, name = dict(ok, atol=a), "atol"
    elif which == "t_eval_out":
        t = data.draw(st.one_of(st.floats(1.0, 1e6, exclude_min=True),
                                st.floats(-1e6, 0.0, exclude_max=True)))
        kw, name = dict(ok, t_eval=sorted([0.5, t])), "t_eval"
    else:
        t = sorted(data.draw(st.lists(st.floats(0, 1), min_size=2, max_size=6, unique=True)))
        kw, name = dict(ok, t_eval=t[::-1]), "t_eval"
    with pytest.raises(ValueError, match=name) as e:
        integrate_batch(**kw)
    assert isinstance(e.value, MechanismError)


def test_tiny_rtol_warns_and_is_raised_as_scipy():
    f, single, y0, _ = SYSTEMS["harmonic"]()
    with pytest.warns(UserWarning, match="rtol"):
        r = integrate_batch(f, (0.0, 0.2), y0[:1], rtol=1e-20, atol=1e-12)
    with pytest.warns(UserWarning, match="rtol"):
        s = si.solve_ivp(single(0), (0.0, 0.2), y0[0], rtol=1e-20, atol=1e-12)
    assert r.steps[0] == len(s.t) - 1 and r.nfev[0] == s.nfev
