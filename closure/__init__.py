"""closure — the shared engine of linkwright.

Multi-loop spatial mechanisms with R, P, C, H, U and S joints modelled by 4x4
transforms (seed 000): loop closure by damped Gauss–Newton, continuation
sweeps, velocities, accelerations, transfer functions (analogs) and point paths.

Main names
----------
Mechanism            links, joints, inputs; ``solve``, ``sweep``, analogs
Pose                 a solved batch of poses with residual, iterations, condition
open_chain_poses     link poses of open chains with every joint driven, in bulk (no mechanism)
KinematicState       link poses, joint frames, loop residuals and column twists of poses
carrier_twists       twists of the frames carrying the columns (acceleration terms)
STATUS, REACHED      the status codes of a pose; the statuses of poses that closed
frame_from_points    a joint frame from three points (seed 000's rule)
transform, inverse, exp_se3, log_se3, rot_x, rot_y, rot_z, rotation, skew
MechanismError       bad input (a ValueError)
ClosureError         the loops could not be closed (carries the figures)
Dynamics, Body       closure.dynamics: pseudo-inertias, terms, inverse dynamics; forward
                     dynamics in closure.forward (one trajectory) and closure.batch_dynamics
ReducedDynamics      the same model with each loop replaced by transfer functions
                     (``Dynamics.reduced``; surrogates from approx.surrogate_dynamics)
drive_tolerance      drive forces of mechanisms made with joint errors (closure.tolerance)
"""
from .chains import open_chain_poses
from .dynamics import Body, Dynamics, pseudo_inertia
from .reduced import ReducedDynamics
from .errors import ClosureError, MechanismError
from .frames import (ad, adjoint, cross, euler_zxz, exp_se3, exp_so3, frame_from_points, hat, inverse,
                     log_se3, log_so3, rot_x, rot_y, rot_z, rotation, skew, transform,
                     translation, vee)
from .joints import JOINT_KINDS, Joint
from .kinematics import analogs, carrier_twists, joint_analogs, link_twists, point_analogs
from .mechanism import Mechanism
from .pose import REACHED, STATUS, Pose
from .solver import SolverOptions, solve, sweep
from .state import KinematicState
from .tolerance import DriveTolerance, drive_tolerance

__all__ = [
    "Mechanism", "Pose", "STATUS", "REACHED", "Joint", "JOINT_KINDS", "SolverOptions", "MechanismError",
    "ClosureError", "solve", "sweep", "analogs", "joint_analogs", "point_analogs",
    "frame_from_points", "transform", "translation", "inverse", "exp_se3", "log_se3",
    "exp_so3", "log_so3", "rot_x", "rot_y", "rot_z", "rotation", "skew", "hat", "vee",
    "adjoint", "ad", "euler_zxz", "Dynamics", "ReducedDynamics", "Body", "pseudo_inertia", "cross",
    "KinematicState", "carrier_twists", "link_twists", "DriveTolerance", "drive_tolerance",
    "open_chain_poses",
]
