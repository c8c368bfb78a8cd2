"""approx — piecewise-linear approximation of acceleration analogs (seed 004).

The acceleration analog f''(x) of a 1-DOF loop is replaced by a broken line,
integrated twice into cubic pieces, so that dynamics can run on cheap
polynomials instead of the exact closure.

Main names
----------
fit                 knots given, adaptive knots (σ ≤ δ) or minimax n intervals; σ read
                    as printed (sigma_rule="seed") or as γ·sqrt(∫e²) ("gamma_rms")
                    (n ≤ MAX_N = 1000; adaptive fits up to MAX_ADAPTIVE = 10,000 intervals)
fit_least_squares   knot values by least squares, with end conditions at b
PiecewiseAnalog     ``.knots``, ``.table`` (x0, x1, k, b, c, d, sigma), ``.position``,
                    ``.velocity``, ``.acceleration`` (vectorised), ``.force``
EngineAnalogs       exact f, f', f'' of a closure-engine mechanism (same interface)
TransferFunction    the interface both share
fit_spline          cubic spline through f'' at the knots, integrated twice (SplineAnalog)
fit_chebyshev       one Chebyshev interpolant of f'' on [a, b], integrated twice
                    (ChebyshevAnalog)
choose              the cheapest surrogate (kinds KINDS) meeting a position or drive-force
                    tolerance, with the table it chose from
TransferDynamics    the 1-DOF drive model of seed 004 (5) on either transfer function
surrogate_dynamics  a multi-DOF engine model (loops driven by independent inputs) with every
                    loop closure replaced by surrogates fitted from the engine's exact
                    analogs (``closure.Dynamics.reduced``); LoopAnalogs, loop_inputs
cylinder            the seed's oscillating-cylinder mechanism (closed form and engine)
arm                 a three-cylinder manipulator arm (four loops, three inputs)
"""
from . import arm, cylinder
from .analog import ApproxError, PiecewiseAnalog, TransferFunction
from .dynamics import TransferDynamics
from .engine import EngineAnalogs
from .multiloop import LoopAnalogs, loop_inputs, surrogate_dynamics
from .fit import MAX_ADAPTIVE, MAX_N, SIGMA_RULES, default_gamma, fit, fit_least_squares
from .surrogate import (KINDS, MAX_DEGREE, ChebyshevAnalog, SplineAnalog, choose,
                        fit_chebyshev, fit_spline)

__all__ = ["fit", "fit_least_squares", "default_gamma", "PiecewiseAnalog", "EngineAnalogs",
           "TransferFunction", "TransferDynamics", "ApproxError", "cylinder", "MAX_N",
           "MAX_ADAPTIVE", "SIGMA_RULES", "SplineAnalog", "ChebyshevAnalog", "fit_spline",
           "fit_chebyshev", "choose", "KINDS", "MAX_DEGREE", "surrogate_dynamics",
           "LoopAnalogs", "loop_inputs", "arm"]
