"""Dynamics of a 1-DOF loop through its transfer function (seed 004, formula 5).

The driven coordinate x (e.g. the piston stroke q₁) moves an output link of
moment of inertia I about its pivot (e.g. the rocker, I = m₃ L₃²) through
q_out = f(x).  Lagrange's equation of this model is

    I f'(x)² ẍ + I f'(x) f''(x) ẋ² = Q_drive + Q_load(t, x, ẋ),

so Q_drive = Ψ I q̈_out with Ψ = f' and q̈_out = f' ẍ + f'' ẋ², the seed's (5).
Any :class:`~approx.analog.TransferFunction` can supply f', f'': the exact
closure (:class:`~approx.engine.EngineAnalogs`) or the fast surrogate
(:class:`~approx.analog.PiecewiseAnalog`); a study switches between them by
passing the other one.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
import pandas as pd

from .analog import ApproxError, TransferFunction, as_points, as_positive, as_real

__all__ = ["TransferDynamics"]

#: the method names of scipy's ``solve_ivp`` (an OdeSolver subclass is passed through)
METHODS = ("RK23", "RK45", "DOP853", "Radau", "BDF", "LSODA")


class TransferDynamics:
    """A driven 1-DOF loop with an output inertia, on any transfer function.

    Parameters
    ----------
    transfer : TransferFunction
        Exact (engine) or surrogate analogs of the output against the input.
    inertia : float
        Moment of inertia of the output link about its pivot (kg·m²), I = m L².
    load : callable ``load(t, x, xd) -> Q``, optional
        Further generalised force on the input (N), e.g. gravity through the analog.
    """

    def __init__(self, transfer: TransferFunction, inertia: float,
                 load: Callable | None = None):
        if not isinstance(transfer, TransferFunction):
            raise ApproxError("transfer: expected a TransferFunction (EngineAnalogs or "
                              "PiecewiseAnalog)")
        inertia = as_positive(inertia, "inertia", "a positive moment of inertia (kg·m²)")
        if load is not None and not callable(load):
            raise ApproxError(f"load: expected a callable load(t, x, xd) or None, got "
                              f"{type(load).__name__}")
        self.tf, self.I, self.load = transfer, inertia, load

    def drive(self, t, x, xd, xdd) -> np.ndarray:
        """Drive force for a given motion (inverse dynamics, no integration)."""
        Q = self.tf.force(x, xd, xdd, self.I)
        if self.load is not None:
            t = as_points(t, "t")
            Q = Q - np.asarray(self.load(t, x, xd), float)
        return Q

    def simulate(self, t_span, x0: float, xd0: float, drive: Callable, *, t_eval=None,
                 method: str = "DOP853", rtol: float = 1e-9, atol: float = 1e-12) -> pd.DataFrame:
        """Forward dynamics under ``drive(t, x, xd) -> Q`` (N) by ``solve_ivp``.

        Returns a DataFrame ``t, x, xd, q_out, energy, work`` where energy is the
        output's kinetic energy ½ I (f' ẋ)² and work the drive's integrated power;
        without a load their difference stays zero (the energy balance).
        """
        from scipy.integrate import solve_ivp

        ts = as_points(t_span, "t_span")
        if ts.shape != (2,):
            raise ApproxError(f"t_span: expected two times (t0, t1) (s), got "
                              f"{ts.tolist() if ts.size <= 4 else f'shape {ts.shape}'}")
        x0, xd0 = as_real(x0, "x0"), as_real(xd0, "xd0")
        try:
            self.tf.velocity(np.array([x0]))
        except ApproxError as e:
            raise ApproxError(f"x0: {e}") from None
        if not callable(drive):
            raise ApproxError(f"drive: expected a callable drive(t, x, xd), got "
                              f"{type(drive).__name__}")
        if isinstance(method, str) and method not in METHODS:
            raise ApproxError(f"method: {method!r} unknown; expected one of "
                              f"{', '.join(METHODS)}")
        rtol = as_positive(rtol, "rtol", "a positive tolerance")
        atol = as_positive(atol, "atol", "a positive tolerance")
        if t_eval is not None:
            t_eval = as_points(t_eval, "t_eval")
            lo, hi = min(ts), max(ts)
            if t_eval.ndim != 1 or (t_eval.size and (t_eval.min() < lo or t_eval.max() > hi)):
                raise ApproxError(f"t_eval: expected times (a 1-D array) within t_span "
                                  f"[{lo}, {hi}]")
        t_span = (float(ts[0]), float(ts[1]))

        def rhs(t, y):
            x, xd = y[0], y[1]
            d1 = float(self.tf.velocity(np.array([x]))[0])
            d2 = float(self.tf.acceleration(np.array([x]))[0])
            Q = float(drive(t, x, xd)) + (float(self.load(t, x, xd)) if self.load else 0.0)
            if abs(d1) < 1e-300:
                raise ApproxError(f"simulate: the transfer function's slope vanishes at x = {x} "
                                  "(a dead point: the output does not move the input)")
            xdd = (Q - self.I * d1 * d2 * xd ** 2) / (self.I * d1 * d1)
            return [xd, xdd, Q * xd]

        sol = solve_ivp(rhs, t_span, [x0, xd0, 0.0], method=method, t_eval=t_eval, rtol=rtol,
                        atol=atol)
        if not sol.success:
            raise ApproxError(f"simulate: solve_ivp failed: {sol.message}")
        x, xd = sol.y[0], sol.y[1]
        d1 = self.tf.velocity(x)
        E = 0.5 * self.I * (d1 * xd) ** 2
        return pd.DataFrame({"t": sol.t, "x": x, "xd": xd, "q_out": self.tf.position(x),
                             "energy": E, "work": sol.y[2], "balance": E - E[0] - sol.y[2]})
