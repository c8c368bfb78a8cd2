"""approx — piecewise-linear approximation of acceleration analogs (seed 004).

The acceleration analog f''(x) of a 1-DOF loop is replaced by a broken line,
integrated twice into cubic pieces, so that dynamics can run on cheap
polynomials instead of the exact closure.

Main names
----------
fit                 knots given, adaptive knots (σ ≤ δ) or minimax n intervals
                    (n ≤ MAX_N = 1000; adaptive fits up to MAX_ADAPTIVE = 10,000 intervals)
fit_least_squares   knot values by least squares, with end conditions at b
PiecewiseAnalog     ``.knots``, ``.table`` (x0, x1, k, b, c, d, sigma), ``.position``,
                    ``.velocity``, ``.acceleration`` (vectorised), ``.force``
EngineAnalogs       exact f, f', f'' of a closure-engine mechanism (same interface)
TransferFunction    the interface both share
TransferDynamics    the 1-DOF drive model of seed 004 (5) on either transfer function
cylinder            the seed's oscillating-cylinder mechanism (closed form and engine)
"""
from . import cylinder
from .analog import ApproxError, PiecewiseAnalog, TransferFunction
from .dynamics import TransferDynamics
from .engine import EngineAnalogs
from .fit import MAX_ADAPTIVE, MAX_N, default_gamma, fit, fit_least_squares

__all__ = ["fit", "fit_least_squares", "default_gamma", "PiecewiseAnalog", "EngineAnalogs",
           "TransferFunction", "TransferDynamics", "ApproxError", "cylinder", "MAX_N",
           "MAX_ADAPTIVE"]
