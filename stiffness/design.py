"""Leg-stiffness allocation by convex optimisation (an LMI, solved with cvxpy)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import StiffnessError
from .validate import number, transform

__all__ = ["design_leg_stiffness", "DesignResult"]


@dataclass
class DesignResult:
    """Outcome of :func:`design_leg_stiffness`.

    Attributes
    ----------
    k : numpy.ndarray (n,)
        Leg stiffnesses (N/m).
    objective : float
        The solver's optimum: worst-case smallest translational eigenvalue (N/m).
    verified : float
        The same figure recomputed from ``k`` by eigenvalues (N/m).
    per_pose : numpy.ndarray
        Smallest translational eigenvalue at each design pose (N/m).
    solver, status : str
    """

    k: np.ndarray
    objective: float
    verified: float
    per_pose: np.ndarray
    solver: str
    status: str


def design_leg_stiffness(hexapod, poses, budget: float, *, k_min: float = 0.0,
                         solver: str | None = None) -> DesignResult:
    """Leg stiffnesses ``k ≥ k_min`` with ``Σ k ≤ budget`` that maximise the worst-case
    smallest eigenvalue of the translational stiffness block over ``poses``.

    The translational block ``K_n(k) = Σ_i k_i u_i u_iᵀ`` is linear in ``k``, so the
    problem ``max t  s.t.  K_n,j(k) ⪰ t I`` for every pose j is a semidefinite
    program (solved by cvxpy; Clarabel or SCS, which ship with it).

    Parameters
    ----------
    hexapod : Hexapod
        Its leg stiffnesses are ignored (only the geometry is used).
    poses : array_like, shape (4, 4) or (B, 4, 4)
        Design poses of the platform in the base frame.
    budget : float
        Total stiffness available (N/m), positive.
    k_min : float
        Smallest stiffness of a leg (N/m), non-negative.
    solver : str, optional
        A cvxpy solver name installed here (default: cvxpy's choice).

    Returns
    -------
    DesignResult

    Raises
    ------
    StiffnessError
        Bad input (naming the argument), an unknown solver, or a solver failure.
    """
    import cvxpy as cp

    from .hexapod import Hexapod

    if not isinstance(hexapod, Hexapod):
        raise StiffnessError(f"hexapod: expected a Hexapod, got {type(hexapod).__name__}")
    T = transform(poses, "poses")
    if T.ndim == 2:
        T = T[None]
    if T.ndim != 3 or T.shape[0] == 0:
        raise StiffnessError(f"poses: expected one pose (4, 4) or a batch (B, 4, 4) with B ≥ 1, "
                             f"got shape {T.shape}")
    budget = number(budget, "budget", positive=True, unit="N/m")
    k_min = number(k_min, "k_min", nonnegative=True, unit="N/m")
    if solver is not None and (not isinstance(solver, str) or
                               solver.upper() not in cp.installed_solvers()):
        raise StiffnessError(f"solver: expected None or one of the installed cvxpy solvers "
                             f"{', '.join(cp.installed_solvers())}, got {solver!r}")
    n = hexapod.base.shape[0]
    if k_min * n > budget:
        raise StiffnessError(f"k_min: {n} legs × {k_min} exceeds the budget {budget}")
    _, u = hexapod.legs(T)                                  # (B, n, 3)
    scale = budget / n                                      # work in units of the mean leg
    x = cp.Variable(n)
    t = cp.Variable()
    cons = [x >= k_min / scale, cp.sum(x) <= n]
    for j in range(T.shape[0]):
        Kn = sum(x[i] * np.outer(u[j, i], u[j, i]) for i in range(n))
        cons.append(0.5 * (Kn + Kn.T) - t * np.eye(3) >> 0)
    prob = cp.Problem(cp.Maximize(t), cons)
    try:
        prob.solve(solver=solver)
    except cp.error.SolverError as e:
        raise StiffnessError(f"solver: {solver or 'the default solver'} failed ({e})") from None
    if x.value is None:
        raise StiffnessError(f"design_leg_stiffness: solver status {prob.status}")
    k = np.maximum(np.asarray(x.value) * scale, 0.0)
    per = np.linalg.eigvalsh(np.einsum("i,bij,bik->bjk", k, u, u))[:, 0]
    return DesignResult(k, float(t.value) * scale, float(per.min()), per,
                        str(prob.solver_stats.solver_name), str(prob.status))
