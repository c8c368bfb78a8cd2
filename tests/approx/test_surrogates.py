"""The surrogate family (issue 16): spline and Chebyshev analogs against closed forms with
their error bounds, ``choose``, and seed 004's own table with its reading of σ."""
import numpy as np
import pytest

from approx import (ApproxError, ChebyshevAnalog, PiecewiseAnalog, SplineAnalog,
                    TransferFunction, choose, cylinder as cy, fit, fit_chebyshev, fit_spline)

from . import slider_crank as sc

CYL = (cy.f3, cy.psi31, cy.dpsi31, 0.0, 0.3)
SC = (sc.s, sc.ds, sc.d2s, -1.0, 2.5)


def _check_bounds(s, f, df, d2f, a, b):
    x = np.linspace(a, b, 20001)
    F, F1, F2 = s.all(x)
    eF, e1, e2 = (np.abs(F - f(x)).max(), np.abs(F1 - df(x)).max(), np.abs(F2 - d2f(x)).max())
    assert eF <= s.error["bound_F"] and e1 <= s.error["bound_dF"]
    assert e2 == pytest.approx(s.error["max_d2F"], rel=0.1)     # the estimate, not a bound
    # the three at once equal the three alone; a float in gives the batch's value
    for k, m in enumerate(("position", "velocity", "acceleration")):
        assert np.array_equal(getattr(s, m)(x), (F, F1, F2)[k])
        v = getattr(s, m)(float(x[777]))
        assert isinstance(v, float) and v == pytest.approx((F, F1, F2)[k][777], rel=1e-13,
                                                            abs=1e-13)
    assert s.all(x[:20000].reshape(4, -1)[:, :5])[0].shape == (4, 5)
    # the data of the seed: F(a) = f(a), F'(a) = f'(a)
    assert s.position(a) == pytest.approx(float(f(np.array([a]))[0]), abs=1e-14)
    assert s.velocity(a) == pytest.approx(float(df(np.array([a]))[0]), abs=1e-13)
    return eF


@pytest.mark.parametrize("case", [CYL, SC], ids=["cylinder", "slider-crank"])
def test_spline_against_closed_form_within_its_bounds(case):
    f, df, d2f, a, b = case
    prev = np.inf
    for n in (4, 8, 16, 32):
        s = fit_spline(f, df, d2f, a, b, n=n)
        assert isinstance(s, SplineAnalog) and isinstance(s, TransferFunction)
        lin = fit(f, df, d2f, a, b, n=n)
        assert np.array_equal(s.knots, lin.knots)           # the seed's data and knots
        assert np.allclose(s.acceleration(s.knots), d2f(s.knots), rtol=1e-12, atol=1e-12)
        e = _check_bounds(s, f, df, d2f, a, b)
        if n >= 8:                                           # past the coarsest knots
            assert e < lin.errors(f, df, d2f)["max_abs_F"]
            assert e < prev / 6                              # O(h^4) or better
        prev = e


@pytest.mark.parametrize("case", [CYL, SC], ids=["cylinder", "slider-crank"])
def test_chebyshev_against_closed_form_within_its_bounds(case):
    f, df, d2f, a, b = case
    errs = []
    for m in (6, 10, 16):
        c = fit_chebyshev(f, df, d2f, a, b, degree=m)
        assert isinstance(c, ChebyshevAnalog) and c.n_coefficients == m + 3
        errs.append(_check_bounds(c, f, df, d2f, a, b))
    assert errs[2] < 1e-3 * errs[0]                          # spectral convergence


def test_spline_drive_force_beats_the_broken_line_on_the_same_data():
    t = np.linspace(0, cy.TAU, 2001)
    q, qd, qdd = cy.drive_law(t)
    I3 = cy.M3 * cy.B3 ** 2
    Qe = cy.psi31(q) * I3 * (cy.psi31(q) * qdd + cy.dpsi31(q) * qd ** 2)
    rms = lambda s: np.sqrt(np.mean((s.force(q, qd, qdd, I3) - Qe) ** 2) / np.mean(Qe ** 2))
    got = [(rms(fit(*CYL, n=n)), rms(fit_spline(*CYL, n=n))) for n in (4, 8, 16)]
    # issue 16: 3.09 / 0.755 / 0.188 % for the broken line, 1.21 / 0.052 / 0.0015 % spline
    for (lin, spl), want in zip(got, (0.0121, 0.00052, 1.5e-5)):
        assert spl < lin and spl == pytest.approx(want, rel=0.05)


@pytest.mark.parametrize("target,tol", [("position", 1e-5), ("force", 1e-3)])
def test_choose_meets_the_tolerance_at_least_cost(target, tol):
    s, table = choose(*CYL, tol=tol, target=target)
    assert table.chosen.sum() == 1 and set(table.kind) == {"linear", "spline", "chebyshev"}
    row = table[table.chosen].iloc[0]
    assert row.coefficients == table[table.meets].coefficients.min()
    x = np.linspace(0.0, 0.3, 7777)                          # not the grid choose used
    F, F1, F2 = (s.position(x), s.velocity(x), s.acceleration(x))
    if target == "position":
        assert np.abs(F - cy.f3(x)).max() <= tol
    else:
        d1, d2 = cy.psi31(x), cy.dpsi31(x)
        assert np.abs(F1 ** 2 - d1 ** 2).max() <= tol * np.abs(d1 ** 2).max()
        assert np.abs(F1 * F2 - d1 * d2).max() <= tol * np.abs(d1 * d2).max()
    # the other kinds were fitted until they met it too (or ran out of sizes)
    for kind, rows in table.groupby("kind"):
        assert rows.meets.iloc[-1] and not rows.meets.iloc[:-1].any(), kind
    only = choose(*CYL, tol=tol, target=target, kinds=["spline"])[0]
    assert isinstance(only, SplineAnalog)
    fast, t2 = choose(*CYL, tol=tol, target=target, cost="time")
    assert t2[t2.chosen].eval_s_batch.iloc[0] == t2[t2.meets].eval_s_batch.min()


def test_choose_and_fitters_refuse_bad_arguments_by_name():
    for kw, name in [(dict(tol=0.0), "tol"), (dict(tol=np.nan), "tol"),
                     (dict(tol=1e-3, target="speed"), "target"),
                     (dict(tol=1e-3, cost="money"), "cost"),
                     (dict(tol=1e-3, kinds=["pade"]), "kinds"),
                     (dict(tol=1e-3, kinds=[]), "kinds"),
                     (dict(tol=1e-3, samples=1), "samples"),
                     (dict(tol=1e-30, kinds=["chebyshev"]), "tol")]:
        with pytest.raises(ApproxError, match=name):
            choose(*CYL, **kw)
    with pytest.raises(ApproxError, match="n, knots"):
        fit_spline(*CYL)
    with pytest.raises(ApproxError, match="bc"):
        fit_spline(*CYL, n=4, bc="periodic")
    with pytest.raises(ApproxError, match="degree"):
        fit_chebyshev(*CYL, degree=-1)
    with pytest.raises(ApproxError, match="outside"):
        fit_chebyshev(*CYL, degree=4).position(0.31)
    with pytest.raises(ApproxError, match="outside"):
        fit_spline(*CYL, n=4).all([0.1, -0.01])


# ---------------------------------------------------------------- seed 004's own table
SEED_KNOTS = [0.0, 0.15003, 0.23099, 0.27900, 0.3]
# k, b, c, d of formulas (2)–(4) on the knots the paper's table implies (its breakpoints
# x_{i+1} = (b_{i+1} − b_i)/(k_i − k_{i+1})), to five significant figures.  The seed text
# available to the project withholds the printed table (kept as an acceptance check), so
# these are the values formulas (2)–(4) give at the paper's γ = 0.051; they reproduce the
# breakpoints to the paper's five digits.
SEED_TABLE = {"k": [20.854, 55.645, 135.97, 260.68],
              "b": [1.6978, -3.5219, -22.077, -56.869],
              "c": [2.6087, 3.0003, 5.1433, 9.9968],
              "d": [-0.28975, -0.30933, -0.47433, -0.92572]}


def test_seed_table_regression():
    an = fit(cy.f3, cy.psi31, cy.dpsi31, 0.0, 0.3, knots=SEED_KNOTS, gamma=0.051)
    for col, want in SEED_TABLE.items():
        got = getattr(an, col)
        assert np.allclose(got, want, rtol=5e-5, atol=0), (col, got)
    k, b = np.array(SEED_TABLE["k"]), np.array(SEED_TABLE["b"])
    implied = (b[1:] - b[:-1]) / (k[:-1] - k[1:])
    assert np.allclose(implied, SEED_KNOTS[1:-1], atol=2e-5)
    # c_0 = f'(a), d_0 = f(a) for a = 0, as the seed writes (4)
    assert an.c[0] == pytest.approx(cy.psi31(0.0)) and an.d[0] == pytest.approx(cy.f3(0.0))


def test_seed_sigma_reading():
    F = (cy.f3, cy.psi31, cy.dpsi31)
    printed = fit(*F, 0.0, 0.3, knots=SEED_KNOTS, gamma=0.051)
    rms = fit(*F, 0.0, 0.3, knots=SEED_KNOTS, gamma=0.051, sigma_rule="gamma_rms")
    assert np.all((printed.sigma[:3] > 0.023) & (printed.sigma[:3] < 0.0251))
    assert np.all((rms.sigma[:3] > 0.0052) & (rms.sigma[:3] < 0.0057))
    assert np.allclose(rms.sigma, 0.051 * printed.sigma / np.sqrt(0.051), rtol=1e-12)
    # δ = 0.005 gives the paper's 4 intervals only under σ = γ sqrt(∫e²)
    ad = fit(*F, 0.0, 0.3, delta=0.005, gamma=0.051, sigma_rule="gamma_rms")
    assert ad.n == 4 and np.allclose(ad.knots[1:-1], SEED_KNOTS[1:-1], atol=5e-3)
    assert fit(*F, 0.0, 0.3, delta=0.005, gamma=0.051).n == 7
    # and 4 is the fewest: the minimax σ of 3 intervals exceeds δ
    assert fit(*F, 0.0, 0.3, n=3, gamma=0.051, sigma_rule="gamma_rms").sigma.max() > 0.005
    assert ad.info["sigma_rule"] == "gamma_rms" and ad.gamma == 0.051
    with pytest.raises(ApproxError, match="sigma_rule"):
        fit(*F, 0.0, 0.3, n=4, sigma_rule="rms")


def test_linear_all_is_the_three_methods():
    an = fit(*CYL, n=5)
    assert isinstance(an, PiecewiseAnalog)
    x = np.linspace(0, 0.3, 101)
    for got, m in zip(an.all(x), ("position", "velocity", "acceleration")):
        assert np.array_equal(got, getattr(an, m)(x))
    for f, df, d2f, a, b in (CYL, SC):                       # the seed's analog's own bounds
        an = fit(f, df, d2f, a, b, n=6)
        e = an.errors(f, df, d2f, samples=20001)
        assert e["max_abs_F"] <= an.error["bound_F"] and e["max_abs_dF"] <= an.error["bound_dF"]


def test_fits_are_fast_and_place_the_same_knots_as_before():
    import time
    F = (cy.f3, cy.psi31, cy.dpsi31)
    # knots of the previous implementation (greedy reach by serial secant steps; Newton
    # equalisation), to 12 digits
    before = {"delta": ([0.0, 0.0957788512177, 0.159034219289, 0.204862477022,
                         0.239252476641, 0.265685337947, 0.286396447106, 0.3], 0.005),
              "n": ([0.0, 0.0843703508319, 0.14249597554, 0.186140389489, 0.219950055857,
                     0.246675700314, 0.268139885995, 0.285611316603, 0.3], 0.0033359578866)}
    for key, kw, limit in (("delta", dict(delta=0.005), 0.005), ("n", dict(n=8), 0.010)):
        best = np.inf
        for _ in range(5):
            t0 = time.perf_counter()
            an = fit(*F, 0.0, 0.3, **kw)
            best = min(best, time.perf_counter() - t0)
        knots, top = before[key]
        assert np.abs(an.knots - knots).max() < 1e-6 and abs(an.sigma.max() - top) < 1e-6 * top
        assert best < 10 * limit          # the targets (5 ms, 10 ms) with room for a busy machine


def test_chebyshev_batches_from_taylor_pieces():
    # large batches of a long Chebyshev form are evaluated from Taylor pieces of degree 7
    # (faster than Clenshaw's recurrence); they agree with numpy's chebval of the same
    # coefficients to 1e-13 of each output's range, and the three methods stay identical
    from numpy.polynomial import chebyshev as C
    x = np.linspace(0.0, 0.3, 5001)
    u = (2 * x - 0.3) / 0.3
    for m in (12, 24, 48):
        c = fit_chebyshev(*CYL, degree=m)
        got = c.all(x)
        assert c._pieces() is not False and c._pieces().origin.size <= 1024
        for w, name in enumerate(("position", "velocity", "acceleration")):
            ref = C.chebval(u, c.coef[:, w])
            assert np.abs(got[w] - ref).max() <= 1e-13 * np.abs(ref).max()
            assert np.array_equal(getattr(c, name)(x), got[w])
    # beyond the range (extrapolate=True) the series itself is evaluated
    c = fit_chebyshev(*CYL, degree=24, extrapolate=True)
    xe = np.linspace(-0.05, 0.35, 1001)
    ref = C.chebval((2 * xe - 0.3) / 0.3, c.coef[:, 0])
    assert np.abs(c.position(xe) - ref).max() <= 1e-13 * np.abs(ref).max()
