"""Property-based tests of the approx package's public API (hypothesis).

Bad inputs (NaN or ±inf anywhere, wrong types and shapes, functions that return NaN or
the wrong shape, n above its documented maximum) raise ApproxError naming the argument;
a batch evaluation equals the points one by one; fits move with a shift of the input
(up to |shift| = 1e6) and scale as derived under a change of the input's and the
output's units.
"""
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from approx import ApproxError, EngineAnalogs, fit, fit_least_squares
from approx.fit import MAX_N

from .slider_crank import mechanism

FAST = settings(max_examples=40, deadline=None, database=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow])


def family(A, w, phi, B):
    """f = A sin(w x + phi) + B x³ with its two derivatives (vectorised)."""
    return ((lambda x: A * np.sin(w * x + phi) + B * x ** 3),
            (lambda x: A * w * np.cos(w * x + phi) + 3 * B * x ** 2),
            (lambda x: -A * w * w * np.sin(w * x + phi) + 6 * B * x))


F0 = family(1.0, 2.0, 0.3, 0.2)
KNOTS = np.array([0.0, 0.3, 0.7, 1.0])

params = st.tuples(st.floats(0.2, 3.0), st.floats(0.5, 3.0), st.floats(-3.0, 3.0),
                   st.floats(-1.0, 1.0))


@st.composite
def inner_knots(draw, min_gap=0.05):
    """Knots of [0, 1] with gaps of at least ``min_gap``."""
    k = draw(st.integers(1, 5))
    raw = np.sort(draw(st.lists(st.floats(0.0, 1.0), min_size=k, max_size=k)))
    x = min_gap + raw * (1 - (k + 1) * min_gap) + min_gap * np.arange(k)
    return np.r_[0.0, x, 1.0]


# ------------------------------------------------------------------ bad inputs
NON_FINITE = [np.nan, np.inf, -np.inf]
BAD_REAL = NON_FINITE + ["0.5", 1j, [0.5], True, None, 10 ** 400]
BAD = {
    "a": BAD_REAL,
    "b": BAD_REAL,
    "delta": NON_FINITE + ["0.1", 1j, [0.1], True, 0.0, -0.1],
    "gamma": NON_FINITE + ["1", 1j, [1.0], True, 0.0, -1.0],
    "n": NON_FINITE + [2.5, "4", True, 0, -3, [4], MAX_N + 1, 10 ** 6, 1e6],
}


@FAST
@given(st.sampled_from([(k, v) for k, vs in BAD.items() for v in vs]),
       st.sampled_from(["knots", "delta", "n"]))
def test_bad_scalar_arguments_name_the_argument(bad, mode):
    name, value = bad
    calls = []
    f, df, d2f = F0
    kw = {"knots": dict(knots=KNOTS), "delta": dict(delta=1e-3), "n": dict(n=3)}[mode]
    if name in ("delta", "n"):
        kw = {name: value}
    else:
        kw[name] = value
    a, b = kw.pop("a", 0.0), kw.pop("b", 1.0)
    spy = lambda x: calls.append(1) or d2f(x)
    with pytest.raises(ApproxError, match=rf"^{name}: "):
        fit(f, df, spy, a, b, **kw)
    assert not calls                    # rejected before any evaluation (n = 10**6 is instant)


@FAST
@given(st.integers(0, 3), st.sampled_from(NON_FINITE + ["x"]),
       st.sampled_from(["fit", "least squares"]))
def test_bad_knots_name_knots(pos, value, which):
    knots = KNOTS.astype(object)
    knots[pos] = value
    f, df, d2f = F0
    with pytest.raises(ApproxError, match=r"^knots: "):
        if which == "fit":
            fit(f, df, d2f, 0.0, 1.0, knots=knots)
        else:
            fit_least_squares(f, df, d2f, knots)


@pytest.mark.parametrize("knots, what", [([[0.0, 0.5], [0.5, 1.0]], "1-D"), ([0.0], "two"),
                                         ([0.0, 0.7, 0.5, 1.0], "increasing"),
                                         (np.array([0, 0.5j, 1]), "real"),
                                         ([0.1, 0.5, 1.0], "start at a")])
def test_bad_knot_shapes_name_knots(knots, what):
    f, df, d2f = F0
    with pytest.raises(ApproxError, match=rf"^knots: .*{what}"):
        fit(f, df, d2f, 0.0, 1.0, knots=knots)


@FAST
@given(st.sampled_from(["f", "df", "d2f"]), st.sampled_from(["nan", "inf", "shape", "type",
                                                              "not callable"]),
       st.floats(0.0, 0.99), st.sampled_from(["knots", "delta", "n", "least squares"]))
def test_functions_returning_nan_or_wrong_shapes_are_named(name, fault, where, mode):
    good = dict(zip(("f", "df", "d2f"), F0))
    g = good[name]
    if fault in ("nan", "inf"):
        bad = np.nan if fault == "nan" else np.inf
        # f and f' are needed at the ends only; f'' on all of [a, b]
        lo = 0.0 if name != "d2f" else where
        good[name] = lambda x: np.where((x >= lo) & (x <= lo + 0.01), bad, g(x))
    elif fault == "shape":
        good[name] = lambda x: np.zeros(np.size(x) + 1)
    elif fault == "type":
        good[name] = lambda x: np.full(np.shape(x), "a")
    else:
        good[name] = 1.0
    with pytest.raises(ApproxError, match=rf"^{name}: "):
        if mode == "least squares":
            fit_least_squares(good["f"], good["df"], good["d2f"], KNOTS)
        else:
            kw = {"knots": dict(knots=KNOTS), "delta": dict(delta=1e-3), "n": dict(n=3)}[mode]
            fit(good["f"], good["df"], good["d2f"], 0.0, 1.0, **kw)


@FAST
@given(st.sampled_from(["position", "velocity", "acceleration", "xd", "xdd", "mass_moment"]),
       st.integers(0, 9), st.sampled_from(NON_FINITE + ["s"]))
def test_bad_evaluation_points_name_the_argument(method, pos, value):
    an = fit(*F0, 0.0, 1.0, knots=KNOTS)
    x = np.linspace(0, 1, 10).astype(object)
    x[pos] = value
    ok = np.linspace(0, 1, 10)
    if method in ("position", "velocity", "acceleration"):
        with pytest.raises(ApproxError, match=r"^x: "):
            getattr(an, method)(x)
        with pytest.raises(ApproxError, match=r"^x: "):
            an.force(x, ok, ok, 1.0)
    elif method == "mass_moment":
        with pytest.raises(ApproxError, match=r"^mass_moment: "):
            an.force(ok, ok, ok, value)
    else:
        args = {"xd": (ok, x, ok), "xdd": (ok, ok, x)}[method]
        with pytest.raises(ApproxError, match=rf"^{method}: "):
            an.force(*args, 1.0)


def test_engine_analogs_reject_non_finite_x():
    ex = EngineAnalogs(mechanism(), "D", 0.0, 1.0)
    for v in NON_FINITE:
        with pytest.raises(ApproxError, match=r"^x: "):
            ex.velocity(np.array([[0.2, v]]))


def test_n_at_its_maximum_is_fast_enough_to_run_and_equalises_sigma():
    an = fit(*F0, 0.0, 1.0, n=MAX_N)
    assert an.n == MAX_N and np.ptp(an.sigma) <= 1e-7 * an.sigma.max()


# ------------------------------------------------------------------ batch vs one by one
@FAST
@given(params, inner_knots(), st.lists(st.floats(0.0, 1.0), min_size=1, max_size=12),
       st.booleans())
def test_batch_equals_one_by_one(p, knots, xs, least_squares):
    f, df, d2f = family(*p)
    an = fit_least_squares(f, df, d2f, knots) if least_squares else \
        fit(f, df, d2f, 0.0, 1.0, knots=knots)
    x = np.array(xs + list(knots))
    for m in ("position", "velocity", "acceleration"):
        batch = getattr(an, m)(x)
        one = np.array([getattr(an, m)(float(v)) for v in x])
        assert batch.shape == x.shape and np.array_equal(batch, one)
        if x.size % 2 == 0:
            assert np.array_equal(getattr(an, m)(x.reshape(2, -1)), batch.reshape(2, -1))


def test_engine_batch_equals_one_by_one():
    ex = EngineAnalogs(mechanism(), "D", -0.5, 1.0)
    x = np.linspace(-0.5, 1.0, 7)
    batch = np.array(ex.all(x))
    one = np.array([ex.all(v) for v in x]).T
    assert np.abs(batch - one).max() <= 1e-13
    assert np.abs(np.array(ex.all(x.reshape(7, 1))).reshape(3, 7) - batch).max() == 0


# ------------------------------------------------------------------ invariances
def scales(an, L):
    """Natural sizes of F, F', F'' over a range of length L: a rounding ε of x moves
    each by at most (derivative)·ε, so errors are measured against these."""
    x = np.linspace(an.a, an.b_end, 201)
    P, V, A = (np.abs(getattr(an, m)(x)).max() for m in ("position", "velocity",
                                                          "acceleration"))
    K = np.abs(an.k).max()
    return {"position": P + L * V, "velocity": V + L * A, "acceleration": A + L * K}


@FAST
@given(params, inner_knots(), st.floats(-1e6, 1e6), st.booleans())
def test_shift_invariance(p, u, shift, least_squares):
    f, df, d2f = family(*p)
    g, dg, d2g = (lambda x: f(x - shift)), (lambda x: df(x - shift)), (lambda x: d2f(x - shift))
    build = (lambda F, D, D2, k: fit_least_squares(F, D, D2, k)) if least_squares else \
        (lambda F, D, D2, k: fit(F, D, D2, k[0], k[-1], knots=k))
    ref, moved = build(f, df, d2f, u), build(g, dg, d2g, u + shift)
    t = np.linspace(0, 1, 301)
    sc = scales(ref, 1.0)
    for m in ("position", "velocity", "acceleration"):
        assert np.abs(getattr(moved, m)(t + shift) - getattr(ref, m)(t)).max() <= 1e-9 * sc[m]
    # σ: f'' is evaluated at abscissae rounded to ε = ulp(|shift| + 1); σ² of an interval of
    # width h grows like h⁵, so moving its nodes by ε changes σ by ≲ 5 ε / h relative.  Least
    # squares also moves the knot values (solved from those f'' values) by ~ε |f'''|, which
    # moves σ = sqrt(γ h) × rms(F'' − f'') by up to sqrt(γ h) · 2 ε |f'''|.
    eps = np.spacing(abs(shift) + 1.0)
    h = np.diff(u)
    tol = (1e-9 + 5 * eps / h.min()) * ref.sigma + 1e-12 * ref.sigma.max()
    if least_squares:
        A, w, _, B = p
        tol = tol + 2 * np.sqrt(ref.gamma * h) * eps * (A * w ** 3 + 6 * abs(B))
    assert np.all(np.abs(moved.sigma - ref.sigma) <= tol)


@FAST
@given(params, st.floats(-1e6, 1e6), st.integers(2, 12))
def test_shift_invariance_of_the_minimax_knots(p, shift, n):
    f, df, d2f = family(*p)
    ref = fit(f, df, d2f, 0.0, 1.0, n=n)
    moved = fit(lambda x: f(x - shift), lambda x: df(x - shift), lambda x: d2f(x - shift),
                shift, shift + 1.0, n=n)
    # σ_i are equalised to 1e-7 relative, which fixes the knots to about that fraction of h
    assert np.abs(moved.knots - shift - ref.knots).max() <= 1e-6
    assert np.isclose(moved.sigma.max(), ref.sigma.max(), rtol=1e-6)


@FAST
@given(params, inner_knots(), st.floats(1e-3, 1e3), st.floats(1e-2, 1e2), st.booleans(),
       st.floats(-10.0, 10.0))
def test_scale_invariance(p, u, s, c, negative, a0):
    """x → s·x and f → c·f: G(s x) = c F(x), G' = c F' / s, G'' = c F'' / s²; with the seed's
    γ = 1 / (max f'' − min f''), γ_g = γ s² / |c| and σ_g = σ · sqrt(|c| / s)."""
    c = -c if negative else c
    f, df, d2f = family(*p)
    u = a0 + u
    ref = fit(f, df, d2f, u[0], u[-1], knots=u)
    g = (lambda x: c * f(x / s)), (lambda x: c * df(x / s) / s), (lambda x: c * d2f(x / s) / s ** 2)
    scaled = fit(*g, s * u[0], s * u[-1], knots=s * u)
    t = np.linspace(u[0], u[-1], 301)
    sc = scales(ref, 1.0)
    for m, factor in (("position", c), ("velocity", c / s), ("acceleration", c / s ** 2)):
        err = np.abs(getattr(scaled, m)(s * t) / factor - getattr(ref, m)(t)).max()
        assert err <= 1e-9 * sc[m], m
    assert np.isclose(scaled.gamma, ref.gamma * s ** 2 / abs(c), rtol=1e-12)
    assert np.allclose(scaled.sigma, ref.sigma * np.sqrt(abs(c) / s), rtol=1e-9,
                       atol=1e-12 * ref.sigma.max() * np.sqrt(abs(c) / s))
    n = 4
    rn = fit(f, df, d2f, u[0], u[-1], n=n)
    sn = fit(*g, s * u[0], s * u[-1], n=n)
    assert np.abs(sn.knots / s - rn.knots).max() <= 1e-6 * (u[-1] - u[0])
    assert np.isclose(sn.sigma.max(), rn.sigma.max() * np.sqrt(abs(c) / s), rtol=1e-6)
