"""Leg-stiffness allocation by convex optimisation (an LMI, solved with cvxpy)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import StiffnessError

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
    poses : array_like, shape (B, 4, 4)
    budget : float
        Total stiffness available (N/m).
    """
    import cvxpy as cp

    T = np.asarray(poses, dtype=float)
    if T.ndim == 2:
        T = T[None]
    if not (np.isfinite(budget) and budget > 0):
        raise StiffnessError(f"budget: expected a positive total stiffness (N/m), got {budget}")
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
    prob.solve(solver=solver)
    if x.value is None:
        raise StiffnessError(f"design_leg_stiffness: solver status {prob.status}")
    k = np.maximum(np.asarray(x.value) * scale, 0.0)
    per = np.linalg.eigvalsh(np.einsum("i,bij,bik->bjk", k, u, u))[:, 0]
    return DesignResult(k, float(t.value) * scale, float(per.min()), per,
                        str(prob.solver_stats.solver_name), str(prob.status))
