import numpy as np
import pytest

from approx import (ApproxError, EngineAnalogs, PiecewiseAnalog, TransferFunction, cylinder as cy,
                    fit, fit_least_squares)
from approx.analog import interval_sigma

F = (cy.f3, cy.psi31, cy.dpsi31)


def cubic():
    return (lambda x: x ** 3 - 2 * x ** 2 + x + 1, lambda x: 3 * x ** 2 - 4 * x + 1,
            lambda x: 6 * x - 4)


def test_cubic_is_exact_with_hand_coefficients():
    f, df, d2f = cubic()
    an = fit(f, df, d2f, -1.0, 2.0, knots=[-1, 0, 0.5, 2])
    t = an.table
    # F'' = 6x − 4 on every interval: k = 6, b = −4; F' = 3x² − 4x + c with c = 1; d = 1
    assert np.allclose(t.k, 6) and np.allclose(t.b, -4) and np.allclose(t.c, 1) and np.allclose(t.d, 1)
    assert np.allclose(t.sigma, 0, atol=1e-12)
    x = np.linspace(-1, 2, 301)
    assert np.abs(an.position(x) - f(x)).max() < 1e-13
    assert np.abs(an.velocity(x) - df(x)).max() < 1e-13
    assert list(t.columns) == ["x0", "x1", "k", "b", "c", "d", "sigma"]


def test_seed_coefficients_follow_formulas_2_to_4():
    an = fit(*F, 0.0, 0.3, knots=[0, 0.1, 0.2, 0.3])
    x, y = an.knots, cy.dpsi31(an.knots)
    k = (y[1:] - y[:-1]) / (x[1:] - x[:-1])           # the corrected slope
    assert np.allclose(an.k, k) and np.allclose(an.b, y[:-1] - k * x[:-1])
    assert np.isclose(an.c[0], cy.psi31(0.0)) and np.isclose(an.d[0], cy.f3(0.0))   # a = 0
    # continuity of F, F', F'' at inner knots
    for xi in x[1:-1]:
        for g in (an.position, an.velocity, an.acceleration):
            assert np.isclose(g(xi - 1e-12), g(xi + 1e-12), atol=1e-9)
    assert an.gamma == pytest.approx(1 / (cy.dpsi31(0.3) - cy.dpsi31(0.0)), rel=1e-6)
    assert an.gamma == pytest.approx(0.051, abs=5e-4)    # the seed's γ
    # σ by formula (1) against an independent fine trapezoid rule
    xs = np.linspace(0.1, 0.2, 200001)
    chord = np.interp(xs, x, y)
    ref = np.sqrt(an.gamma * np.trapezoid((chord - cy.dpsi31(xs)) ** 2, xs))
    assert an.sigma[1] == pytest.approx(ref, rel=1e-8)


def test_adaptive_fewest_intervals_against_brute_force():
    delta, gamma = 0.3, 1.0
    an = fit(lambda x: np.exp(2 * x), lambda x: 2 * np.exp(2 * x), lambda x: 4 * np.exp(2 * x),
             0.0, 1.0, delta=delta, gamma=gamma)
    assert np.all(an.sigma <= delta * (1 + 1e-9))
    n = an.n
    assert n >= 2
    # exhaustive search: no partition with n − 1 intervals on a fine grid of knots works
    d2 = lambda x: 4 * np.exp(2 * x)
    grid = np.linspace(0, 1, 801)
    if n - 1 == 1:
        assert interval_sigma(d2, 0.0, 1.0, d2(0.0), d2(1.0), gamma) > delta
    else:
        assert n - 1 == 2, "brute force written for up to two intervals"
        inner = grid[1:-1]
        s1 = interval_sigma(d2, 0.0 * inner, inner, d2(0.0 * inner), d2(inner), gamma)
        s2 = interval_sigma(d2, inner, 0 * inner + 1.0, d2(inner), d2(0 * inner + 1.0), gamma)
        assert np.all(np.maximum(s1, s2) > delta)


def test_minimax_equal_sigma_and_better_than_uniform():
    an = fit(*F, 0.0, 0.3, n=4)
    assert an.n == 4
    assert np.ptp(an.sigma) / an.sigma.max() < 1e-6
    uni = fit(*F, 0.0, 0.3, knots=np.linspace(0, 0.3, 5))
    assert an.sigma.max() < uni.sigma.max()
    adaptive = fit(*F, 0.0, 0.3, delta=an.sigma.max() * (1 + 1e-6))
    assert adaptive.n == 4


def test_least_squares_end_conditions_and_smaller_position_error():
    interp = fit(*F, 0.0, 0.3, n=4)
    ls = fit_least_squares(*F, interp.knots, end_conditions=True)
    assert abs(ls.position(0.3) - cy.f3(0.3)) < 1e-12
    assert abs(ls.velocity(0.3) - cy.psi31(0.3)) < 1e-12
    assert abs(ls.position(0.0) - cy.f3(0.0)) < 1e-15 and abs(ls.velocity(0.0) - cy.psi31(0.0)) < 1e-15
    e_i, e_l = interp.errors(*F), ls.errors(*F)
    assert e_l["max_abs_F"] <= e_i["max_abs_F"]


def test_engine_analogs_equal_closed_form():
    ex = EngineAnalogs(cy.mechanism(), "A", 0.0, 0.3, offset=cy.f3(0.0), sign=-1.0)
    x = np.linspace(0, 0.3, 31)
    f, d1, d2 = ex.all(x)
    assert np.abs(f - cy.f3(x)).max() < 1e-10
    assert np.abs(d1 - cy.psi31(x)).max() < 1e-10
    assert np.abs(d2 - cy.dpsi31(x)).max() < 1e-10 * np.abs(cy.dpsi31(x)).max()


def test_drive_force_exact_engine_and_surrogate():
    t = np.linspace(0, cy.TAU, 401)
    q, qd, qdd = cy.drive_law(t)
    I3 = cy.M3 * cy.B3 ** 2
    exact = cy.psi31(q) * I3 * (cy.psi31(q) * qdd + cy.dpsi31(q) * qd ** 2)
    ex = EngineAnalogs(cy.mechanism(), "A", 0.0, 0.3, offset=cy.f3(0.0), sign=-1.0)
    assert isinstance(ex, TransferFunction)
    assert np.abs(ex.force(q, qd, qdd, I3) - exact).max() < 1e-9 * np.abs(exact).max()
    sur = fit(*F, 0.0, 0.3, delta=0.0005)
    assert isinstance(sur, PiecewiseAnalog) and isinstance(sur, TransferFunction)
    rms = np.sqrt(np.mean((sur.force(q, qd, qdd, I3) - exact) ** 2)) / np.sqrt(np.mean(exact ** 2))
    assert rms < 0.01


def test_range_towards_dead_point_and_infinite_analog():
    # the dead point: B + q1 = B0 + B3, q1 = 0.4, where f'' is infinite
    near = fit(*F, 0.0, 0.399, delta=0.01)
    w = np.diff(near.knots)
    assert w[-1] < w[0] / 10                          # knots cluster at the dead point
    assert np.all(near.sigma <= 0.01 * (1 + 1e-9))
    with pytest.raises(ApproxError, match="not finite at x = 0.4"):
        fit(*F, 0.0, 0.4, delta=0.01)


def test_bad_inputs_raise_clearly():
    f, df, d2f = cubic()
    with pytest.raises(ApproxError, match="a < b"):
        fit(f, df, d2f, 1.0, 1.0, n=2)
    with pytest.raises(ApproxError, match="finite"):
        fit(f, df, d2f, 0.0, np.inf, n=2)
    with pytest.raises(ApproxError, match="strictly increasing"):
        fit(f, df, d2f, 0.0, 1.0, knots=[0, 0.6, 0.4, 1])
    with pytest.raises(ApproxError, match="start at a"):
        fit(f, df, d2f, 0.0, 1.0, knots=[-0.5, 0.5, 1])
    with pytest.raises(ApproxError, match="exactly one"):
        fit(f, df, d2f, 0.0, 1.0, n=2, delta=0.1)
    with pytest.raises(ApproxError, match="not finite"):
        fit(f, df, lambda x: np.where(x > 0.5, np.nan, 1.0), 0.0, 1.0, n=2)
    an = fit(f, df, d2f, 0.0, 1.0, n=2)
    with pytest.raises(ApproxError, match="outside"):
        an.position(1.5)
    an.extrapolate = True
    assert np.isclose(an.position(1.5), f(1.5))       # the end cubic is exact here


def test_surrogate_stands_in_for_the_exact_closure_in_dynamics():
    from approx import TransferDynamics
    from closure import Dynamics
    I3 = cy.M3 * cy.B3 ** 2
    exact = EngineAnalogs(cy.mechanism(), "A", 0.0, 0.3, offset=cy.f3(0.0), sign=-1.0)
    sur = fit(*F, 0.0, 0.3, delta=0.0005)
    t = np.linspace(0, cy.TAU, 101)
    q, qd, qdd = cy.drive_law(t)
    # inverse: the same call on both; the engine's full dynamics (rocker point mass at C)
    # gives the same force as the exact transfer model
    Qe = TransferDynamics(exact, I3).drive(t, q, qd, qdd)
    Qs = TransferDynamics(sur, I3).drive(t, q, qd, qdd)
    m = cy.mechanism()
    d = Dynamics(m, gravity=(0, 0, 0))
    d.add_body("rocker", cy.M3, m.joint("C").frame_a[:3, 3])
    Qd = d.inverse(t, q[:, None], qd[:, None], qdd[:, None])["drive:slide"].to_numpy()
    assert np.abs(Qe - Qd).max() < 1e-8 * np.abs(Qd).max()
    assert np.sqrt(np.mean((Qs - Qe) ** 2) / np.mean(Qe ** 2)) < 0.01
    # forward: the exact law's force fed to the surrogate model reproduces the motion
    law_force = lambda tt, x, xd: np.interp(tt, t, Qe)
    fwd = TransferDynamics(sur, I3).simulate((0, 2.0), 0.0, float(qd[0]), law_force,
                                             t_eval=np.linspace(0, 2.0, 11))
    q_ref = cy.drive_law(fwd.t.to_numpy())[0]
    assert np.abs(fwd.x - q_ref).max() < 2e-3
    assert np.abs(fwd.balance).max() < 1e-6 * max(1.0, fwd.energy.abs().max())
    with pytest.raises(ApproxError, match="TransferFunction"):
        TransferDynamics(lambda x: x, I3)


def test_far_from_the_origin_is_as_accurate_as_near_it():
    # issue 11: the cubics evaluated in global powers of x gave max |F − f| = 161 here
    an = fit(np.sin, np.cos, lambda x: -np.sin(x), 1e6, 1e6 + 1, n=4)
    x = np.linspace(1e6, 1e6 + 1, 2001)
    L, e2 = 1.0, np.sqrt(np.sum(an.sigma ** 2) / an.gamma)
    # e = F − f, e(a) = e'(a) = 0: |e| ≤ sqrt(L³/3)·sqrt(Σσ²/γ), |e'| ≤ sqrt(L)·sqrt(Σσ²/γ)
    assert np.abs(an.position(x) - np.sin(x)).max() <= np.sqrt(L ** 3 / 3) * e2
    assert np.abs(an.velocity(x) - np.cos(x)).max() <= np.sqrt(L) * e2
    assert list(an.table.columns) == ["x0", "x1", "k", "b", "c", "d", "sigma"]


@pytest.mark.parametrize("shift", [1.0, 1e3, 123456.789, 1e6, -1e6])
def test_shift_invariance_up_to_1e6(shift):
    f, df, d2f = np.sin, np.cos, lambda x: -np.sin(x)
    g, dg, d2g = (lambda x: f(x - shift)), (lambda x: df(x - shift)), (lambda x: d2f(x - shift))
    u = np.array([0.0, 0.2, 0.45, 0.8, 1.0])
    t = np.linspace(0, 1, 1001)
    rel = lambda A, B: np.abs(A - B).max() / np.abs(B).max()
    for ls, build in ((False, lambda F, D, D2, k: fit(F, D, D2, k[0], k[-1], knots=k)),
                      (True, lambda F, D, D2, k: fit_least_squares(F, D, D2, k))):
        ref, moved = build(f, df, d2f, u), build(g, dg, d2g, u + shift)
        for m in ("position", "velocity", "acceleration"):
            assert rel(getattr(moved, m)(t + shift), getattr(ref, m)(t)) <= 1e-9, m
        if not ls:
            assert np.all(np.abs(moved.sigma - ref.sigma) <= 1e-9 * ref.sigma)
        else:
            # least squares: every f'' value entering the solve is taken at an abscissa
            # rounded to eps = ulp(1e6) = 1.2e-10, so the knot values move by ~eps |f'''| and
            # sigma (= sqrt(gamma h) * rms of F'' - f'') by up to sqrt(gamma h) 2 eps |f'''|,
            # with |f'''| <= 1 here
            eps = np.spacing(abs(shift) + 1.0)
            tol = 1e-9 * ref.sigma + 2 * np.sqrt(ref.gamma * np.diff(u)) * eps
            assert np.all(np.abs(moved.sigma - ref.sigma) <= tol)
        # the table keeps the seed's global coefficients (k x + b = F'' up to the rounding
        # of their cancellation)
        x0, k, b = moved.knots[:-1], moved.k, moved.b
        assert np.all(np.abs(k * x0 + b - moved.acceleration(x0))
                      <= 1e-13 * (np.abs(k * x0) + np.abs(b)))
