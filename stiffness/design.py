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
        The solver's optimum: worst-case smallest eigenvalue of the criterion's matrix
        (N/m).
    verified : float
        The same figure recomputed from ``k`` by eigenvalues (N/m).
    per_pose : numpy.ndarray
        Smallest eigenvalue at each design pose (N/m).
    solver, status : str
    criterion : str
        "whole" or "translational" (see :func:`design_leg_stiffness`).
    """

    k: np.ndarray
    objective: float
    verified: float
    per_pose: np.ndarray
    solver: str
    status: str
    criterion: str = "whole"


def design_leg_stiffness(hexapod, poses, budget: float, *, k_min: float = 0.0,
                         criterion: str = "whole", solver: str | None = None) -> DesignResult:
    """Leg stiffnesses ``k ≥ k_min`` with ``Σ k ≤ budget`` that maximise the worst-case
    smallest eigenvalue of the stiffness over ``poses``.

    ``criterion="whole"`` (default) takes the whole 6x6 stiffness made dimensionless:
    about the platform points' centroid, moments divided by the platform radius r
    (``K̂ = Σ k_i p̂_i p̂_iᵀ`` with ``p̂_i = (u_i, (c_i × u_i)/r)``), so no direction of
    the platform, translation or rotation, is left weak.  ``"translational"`` takes only
    the translational block ``K_n = Σ k_i u_i u_iᵀ``, which three legs can serve alone:
    give ``k_min`` then, or the other legs may be left without stiffness and K singular.
    Either matrix is linear in ``k``, so ``max t  s.t.  K_j(k) ⪰ t I`` for every pose j
    is a semidefinite program (solved by cvxpy; Clarabel or SCS, which ship with it).

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
    criterion : {"whole", "translational"}
        The matrix whose worst-case smallest eigenvalue is maximised (N/m).
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
    if criterion not in ("whole", "translational"):
        raise StiffnessError(f"criterion: expected 'whole' or 'translational', got {criterion!r}")
    n = hexapod.base.shape[0]
    if k_min * n > budget:
        raise StiffnessError(f"k_min: {n} legs × {k_min} exceeds the budget {budget}")
    if criterion == "whole":
        Pc = hexapod._at_centroid(hexapod.leg_matrix(T), T)       # (B, 6, n)
        Pc[:, 3:] /= hexapod.radius
        u = np.swapaxes(Pc, 1, 2)                                 # (B, n, 6) columns p̂_i
    else:
        u = hexapod.legs(T)[1]                                    # (B, n, 3)
    d = u.shape[-1]
    scale = budget / n                                      # work in units of the mean leg
    x = cp.Variable(n)
    t = cp.Variable()
    cons = [x >= k_min / scale, cp.sum(x) <= n]
    for j in range(T.shape[0]):
        Kj = sum(x[i] * np.outer(u[j, i], u[j, i]) for i in range(n))
        cons.append(0.5 * (Kj + Kj.T) - t * np.eye(d) >> 0)
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
                        str(prob.solver_stats.solver_name), str(prob.status), criterion)
