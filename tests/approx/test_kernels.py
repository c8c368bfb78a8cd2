"""The compiled piecewise-polynomial kernel against numpy's polynomial evaluation, and the
one-pass check of x through the surrogates."""
import numpy as np
import pytest
from numpy.polynomial import polynomial as Pn

from approx import ApproxError, fit, fit_chebyshev, fit_spline
from approx import cylinder as cy
from approx.kernels import Pieces

CYL = (cy.f3, cy.psi31, cy.dpsi31)


def reference(coef, origin, piece, x):
    """F, F', F'' by numpy's polyval of each point's piece (ascending coefficients)."""
    out = np.empty((3, x.size))
    for k, (v, i) in enumerate(zip(x, piece)):
        c = coef[i]
        for w in range(3):
            out[w, k] = Pn.polyval(v - origin[i], Pn.polyder(c, w) if w else c)
    return out


@pytest.mark.parametrize("uniform", [False, True])
def test_pieces_equal_numpy_polyval(uniform):
    rng = np.random.default_rng(3)
    P, K = 7, 6
    coef = rng.normal(size=(P, K))
    if uniform:
        lo, h = -2.0, 0.5
        edges = lo + h * np.arange(P + 1)
        pcs = Pieces(edges[:-1] + h / 2, coef, lo=lo, inv_h=1 / h)
        origin = edges[:-1] + h / 2
    else:
        edges = np.sort(rng.uniform(-2, 2, P + 1))
        pcs = Pieces(edges[:-1], coef, inner=edges[1:-1])
        origin = edges[:-1]
    x = np.r_[rng.uniform(edges[0] - 0.3, edges[-1] + 0.3, 400), edges]
    piece = np.clip(np.searchsorted(edges[1:-1], x, side="right"), 0, P - 1)
    if uniform:           # equal pieces: by floor((x − lo)/h), the last one closed
        piece = np.clip(np.floor((x - lo) / h).astype(int), 0, P - 1)
    ref = reference(coef, origin, piece, x)
    got, bad = pcs(x)
    assert bad == -1
    scale = np.abs(ref).max(1)
    for w in range(3):
        assert np.abs(got[w] - ref[w]).max() <= 1e-13 * scale[w]
        one, _ = pcs(x, w)
        assert np.array_equal(one, got[w])
    # shapes kept; 0-d gives numpy floats; the scalar entry is the same kernel
    g2, _ = pcs(x[:12].reshape(3, 4))
    assert g2[0].shape == (3, 4) and np.array_equal(g2[1].ravel(), got[1][:12])
    g0, _ = pcs(np.float64(x[5]))
    assert isinstance(g0[0], np.float64)
    assert pcs.scalar(float(x[5])) == (got[0][5], got[1][5], got[2][5])


def test_first_bad_point_reported():
    pcs = Pieces([0.0], [[1.0, 2.0, 3.0]], inner=[])
    assert pcs(np.array([0.1, 0.2, np.inf, 0.3]))[1] == 2
    assert pcs(np.array([0.1, np.nan]))[1] == 1
    assert pcs(np.array([0.1, 0.5, 2.0]), None, 0.0, 1.0)[1] == 2
    assert pcs(np.array([0.0, 1.0]), None, 0.0, 1.0)[1] == -1


@pytest.mark.parametrize("make", [lambda: fit(*CYL, 0.0, 0.3, n=8),
                                  lambda: fit_spline(*CYL, 0.0, 0.3, n=8),
                                  lambda: fit_chebyshev(*CYL, 0.0, 0.3, degree=12)])
def test_surrogates_check_x_in_the_same_pass(make):
    s = make()
    x = np.linspace(0.0, 0.3, 101)
    for bad, msg in ((np.inf, "non-finite"), (np.nan, "non-finite"), (0.31, "outside")):
        y = x.copy()
        y[57] = bad
        with pytest.raises(ApproxError, match=msg):
            s.all(y)
        with pytest.raises(ApproxError, match=msg):
            s.position(y[57])
    with pytest.raises(ApproxError, match="x: expected real numbers"):
        s.velocity(np.array(["a"]))
    # every output equals the scalar entry's
    F = s.all(x)
    for k in (0, 50, 100):
        assert s.all(float(x[k])) == pytest.approx((F[0][k], F[1][k], F[2][k]), rel=0, abs=0)
