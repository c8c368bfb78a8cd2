"""Fits from the closure engine's exact analogs (EngineAnalogs) of a slider-crank, checked
against its closed form (tests/approx/slider_crank.py)."""
import numpy as np
import pytest

from approx import ApproxError, EngineAnalogs, fit, fit_least_squares

from .slider_crank import d2s, ds, mechanism, s

RANGES = [(0.0, 1.2), (0.3, 1.5), (-0.6, 0.4), (-2.0, -1.0)]


def sigma_bounds(an):
    """Bounds on |F − f| and |F' − f'| over [a, b] implied by σ (formula 1).

    e = F − f has e(a) = e'(a) = 0 (both built into the fit), so
    e(x) = ∫_a^x (x − t) e''(t) dt and e'(x) = ∫_a^x e''(t) dt.  With
    σ_i² = γ ∫_i e''² (interval i), Cauchy–Schwarz gives
        |e(x)|  ≤ sqrt((b − a)³ / 3) · sqrt(Σ σ_i² / γ),
        |e'(x)| ≤ sqrt(b − a)       · sqrt(Σ σ_i² / γ).
    """
    L = an.b_end - an.a
    e2 = np.sqrt(np.sum(an.sigma ** 2) / an.gamma)
    return np.sqrt(L ** 3 / 3) * e2, np.sqrt(L) * e2


@pytest.mark.parametrize("a, b", RANGES)
@pytest.mark.parametrize("samples", [2, 65])
def test_engine_slider_crank_equals_closed_form_for_any_shape_of_x(a, b, samples):
    ex = EngineAnalogs(mechanism(), "D", a, b, samples=samples)
    for x in (np.linspace(a, b, 41),                         # the reported call
              np.linspace(a, b, 6 * 48).reshape(6, 48),      # what σ's quadrature passes
              np.linspace(a, b, 24).reshape(2, 3, 4)):
        f, d1, d2 = ex.all(x)
        assert f.shape == d1.shape == d2.shape == x.shape
        assert np.abs(f - s(x)).max() <= 1e-10
        assert np.abs(d1 - ds(x)).max() <= 1e-10
        assert np.abs(d2 - d2s(x)).max() <= 1e-10
        assert np.array_equal(ex.position(x), f) and np.array_equal(ex.acceleration(x), d2)
    x0 = 0.5 * (a + b)
    assert ex.position(x0).shape == () and abs(ex.velocity(x0) - ds(x0)) <= 1e-10


@pytest.mark.parametrize("a, b", RANGES[:3])
def test_fit_from_engine_analogs_n6_and_delta_within_the_sigma_bound(a, b):
    ex = EngineAnalogs(mechanism(), "D", a, b)
    x = np.linspace(a, b, 2001)
    for kw in ({"n": 6}, {"delta": 1e-3}):
        an = fit(ex.position, ex.velocity, ex.acceleration, a, b, **kw)
        ref = fit(s, ds, d2s, a, b, **kw)            # the same fit from the closed form
        if "n" in kw:
            assert an.n == 6 and np.ptp(an.sigma) <= 1e-7 * an.sigma.max()
        else:
            assert np.all(an.sigma <= 1e-3 * (1 + 1e-9))
        assert an.n == ref.n
        assert np.allclose(an.knots, ref.knots, rtol=0, atol=1e-9)
        assert np.allclose(an.sigma, ref.sigma, rtol=1e-7)
        for m in ("k", "b", "c", "d"):
            assert np.allclose(an.table[m], ref.table[m], rtol=1e-7, atol=1e-12)
        bound_F, bound_dF = sigma_bounds(an)
        err_F = np.abs(an.position(x) - s(x)).max()
        err_dF = np.abs(an.velocity(x) - ds(x)).max()
        assert 0 < err_F <= bound_F + 1e-12
        assert err_dF <= bound_dF + 1e-12
        assert abs(an.position(a) - s(a)) <= 1e-12 and abs(an.velocity(a) - ds(a)) <= 1e-12
    ls = fit_least_squares(ex.position, ex.velocity, ex.acceleration, an.knots)
    assert abs(ls.position(b) - s(b)) <= 1e-10 and abs(ls.velocity(b) - ds(b)) <= 1e-10


def test_engine_analogs_bad_inputs_name_the_argument():
    m = mechanism()
    ex = EngineAnalogs(m, "D", 0.0, 1.2)
    with pytest.raises(ApproxError, match="^x: "):
        ex.position(np.array([0.1, np.nan]))
    with pytest.raises(ApproxError, match="^x: "):
        ex.acceleration("0.5")
    with pytest.raises(ApproxError, match="^joint: "):
        EngineAnalogs(m, "no such joint", 0.0, 1.2)
    with pytest.raises(ApproxError, match="^index: "):
        EngineAnalogs(m, "D", 0.0, 1.2, index=1)
    with pytest.raises(ApproxError, match="^a: "):
        EngineAnalogs(m, "D", np.nan, 1.2)
    with pytest.raises(ApproxError, match="^b: "):
        EngineAnalogs(m, "D", 0.0, np.inf)
    with pytest.raises(ApproxError, match="^a, b: expected a < b"):
        EngineAnalogs(m, "D", 1.2, 0.0)
    with pytest.raises(ApproxError, match="^samples: "):
        EngineAnalogs(m, "D", 0.0, 1.2, samples=1)
    with pytest.raises(ApproxError, match="^sign: "):
        EngineAnalogs(m, "D", 0.0, 1.2, sign=np.nan)
