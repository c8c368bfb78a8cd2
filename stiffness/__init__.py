"""stiffness — six-vectors, frame transforms and the 6x6 stiffness of parallel mechanisms.

Seed 003 (Strutynsky & Kyrychenko): wrenches ``W = (f, m)``, small displacements
``Δ = (δ, θ)``, Plücker lines ``N = (n, r × n)``, their frame transforms S, H, T
and S*, H*, T* (Table 1), ``K' = T K Tᵀ`` and the hexapod's ``K = P Kθ Pᵀ``.

Main names
----------
skew, plucker, wrench_transform (T), twist_transform (T*), shift_wrench (S),
shift_twist (S*), rotate_six (H), their inverses, compose_frames,
to_moment_first / from_moment_first
spring_stiffness (formula 2), stiffness_matrix (P diag(k) Pᵀ), transform_stiffness,
blocks, screw_eigenvalues, translational_eigenvalues, rotational_compliance_eigenvalues,
stiffness_indices       the report's indices with their units, as a table
Hexapod                 legs, P, stiffness, compliance, leg forces, loaded stiffness, maps
of_mechanism            K and C of a link of any closure.Mechanism: elastic, locked and
                        passive joints (MechanismStiffness); mechanism_map: its
                        compliance indices over a batch of poses, in chunks
beam_stiffness          6x6 end stiffness of a beam (Euler–Bernoulli, Timoshenko shear):
                        elastic links for of_mechanism's link_springs; its P-δ term under
                        an axial force: beam_geometric_stiffness
design_leg_stiffness    convex (LMI) allocation of leg stiffness with cvxpy
hexapod_tolerance       Monte Carlo manufacturing tolerances of the stiffness indices
                        against the first-order prediction (stiffness.tolerance)
report                  Markdown + CSV stiffness report
StiffnessError          bad input (names the argument and the expected shape); its subclass
                        SingularPoseError: a singular pose (gives cond(P) or cond(K))
SingularPoseWarning     near-singular pose (leg forces, deflections amplified ~cond(P))
"""
from .beam import beam_compliance, beam_geometric_stiffness, beam_stiffness
from .design import design_leg_stiffness
from .errors import SingularPoseError, SingularPoseWarning, StiffnessError
from .hexapod import Hexapod, StiffnessResult
from .mechanism import MechanismStiffness, mechanism_map, of_mechanism
from .matrices import (blocks, from_blocks, rotational_compliance_eigenvalues, screw_eigenvalues,
                       spring_stiffness, stiffness_indices, stiffness_matrix, transform_blocks,
                       transform_stiffness,
                       translational_eigenvalues)
from .plot import plot_map
from .report import report
from .tolerance import HexapodTolerance, hexapod_tolerance
from .sixvector import (compose_frames, from_moment_first, plucker, rotate_six, shift_twist,
                        shift_wrench, skew, to_moment_first, twist_transform,
                        twist_transform_inverse, wrench_transform, wrench_transform_inverse)

__all__ = [
    "skew", "plucker", "wrench_transform", "twist_transform", "wrench_transform_inverse",
    "twist_transform_inverse", "shift_wrench", "shift_twist", "rotate_six", "compose_frames",
    "to_moment_first", "from_moment_first", "spring_stiffness", "stiffness_matrix",
    "transform_stiffness", "transform_blocks", "blocks", "stiffness_indices", "from_blocks", "screw_eigenvalues",
    "translational_eigenvalues", "rotational_compliance_eigenvalues", "Hexapod",
    "StiffnessResult", "design_leg_stiffness", "report", "plot_map", "StiffnessError", "SingularPoseError",
    "SingularPoseWarning", "of_mechanism", "MechanismStiffness", "mechanism_map", "beam_stiffness",
    "beam_compliance", "beam_geometric_stiffness", "hexapod_tolerance", "HexapodTolerance",
]
