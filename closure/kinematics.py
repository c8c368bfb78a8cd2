"""Velocities, accelerations and transfer functions (analogs) of solved poses.

With the world-frame unit twists S_c of the velocity coordinates, every loop
gives ``Σ_c L_lc S_c q̇_c = 0`` (``J q̇ = 0``).  Differentiating once more,
``J q̈ + Σ_c L_lc [V_c, S_c] q̇_c = 0``, where ``V_c`` is the world twist of the
frame in which S_c is fixed (the velocity of the joint's link *a* plus the
earlier coordinates of the same joint that carry it) and ``[·,·]`` is the Lie
bracket of twists.  This replaces seed 000's garbled acceleration formula and
is checked against finite differences in the tests.

Analogs are derivatives with respect to the inputs: first-order
``dq/dx`` (B, nv, ni) and second-order ``d²q/dx dx`` (B, nv, ni, ni).  For a
spherical joint the "coordinates" are the angular velocity of link *b*
relative to link *a*, in the *a* frame.
"""
from __future__ import annotations

import numpy as np

from .errors import MechanismError
from .checks import shown
from .frames import _cross, as_array, as_index
from .lstsq import _LstSq, _expected_rank
from .state import KinematicState

__all__ = ["analogs", "bracket", "carrier_twists", "link_twists", "point_analogs", "joint_analogs"]


def bracket(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Lie bracket ``[a, b]`` of twists ``(v, ω)``, shapes ``(..., 6)``."""
    va, wa, vb, wb = a[..., :3], a[..., 3:], b[..., :3], b[..., 3:]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., :3] = _cross(wa, vb) - _cross(wb, va)
    out[..., 3:] = _cross(wa, wb)
    return out


def _per_rate(S, rates):
    """The column twists ``S (B, nv, 6)`` shaped to broadcast against ``rates (B, ..., nv)``."""
    return S.reshape(S.shape[:1] + (1,) * (rates.ndim - 2) + S.shape[1:])


def _twists(ks, what: str) -> np.ndarray:
    """The column twists of a kinematic state with them (``what``: the caller, for the
    error)."""
    if not isinstance(ks, KinematicState) or ks.S is None:
        raise MechanismError(f"{what}: ks: expected a KinematicState with twists (from "
                             f"Pose.kinematics() or Mechanism.kinematic_state), got "
                             f"{type(ks).__name__}")
    return ks.S


def link_twists(mech, ks: KinematicState, rates: np.ndarray) -> np.ndarray:
    """World twists ``(B, ..., nlinks, 6)`` of every link for coordinate rates
    ``(B, ..., nv)`` (several rate vectors per pose allowed)."""
    S = _twists(ks, "link_twists")
    return np.einsum("lc,...cs->...ls", mech.tree.path_sign, _per_rate(S, rates) * rates[..., None])


def carrier_twists(mech, ks: KinematicState, rates: np.ndarray) -> np.ndarray:
    """World twists of the frames carrying the velocity coordinates' unit twists.

    Column c's unit twist ``S_c`` is constant in the frame of its joint on link *a*
    moved by the joint's own earlier coordinates (the Hooke joint's first pin carries
    its second); that frame's twist is the link's twist plus those coordinates' twists.
    It is the ``V_c`` of the acceleration term ``[V_c, S_c] q̇_c`` (the rate of change of
    a column twist along a motion: ``Ṡ_c = [V_c, S_c]``).

    Parameters
    ----------
    mech : Mechanism
    ks : KinematicState
        From :meth:`Mechanism.kinematic_state` or :meth:`Pose.kinematics` (with twists).
    rates : numpy.ndarray, shape (B, ..., nv)
        Coordinate rates (rad/s or length/s; S joints: angular velocity in the *a* frame),
        several rate vectors per pose allowed.

    Returns
    -------
    numpy.ndarray, shape (B, ..., nv, 6)
        World twists ``(v, ω)`` (length/s, rad/s), ``v`` the velocity of the body point
        at the world origin.
    """
    S, carrier, deps = _twists(ks, "carrier_twists"), ks.carrier, ks.deps
    Sr = _per_rate(S, rates)
    V = np.einsum("lc,...cs->...ls", mech.tree.path_sign, Sr * rates[..., None])[..., carrier, :]
    for c, dep in enumerate(deps):
        for d in dep:
            V[..., c, :] += Sr[..., d, :] * rates[..., d, None]
    return V


#: the former private name (kept for callers that imported it)
_carrier_twists = carrier_twists


def _bias(mech, ks, a, b):
    """Column twist rates ``(B, nv, 6)``: ``[V_c(a), S_c] b_c``, symmetrised in (a, b)."""
    S = ks.S
    Sa = bracket(carrier_twists(mech, ks, a), S) * b[..., None]
    Sb = bracket(carrier_twists(mech, ks, b), S) * a[..., None]
    return 0.5 * (Sa + Sb)


def analogs(mech, pose, second: bool = True, ks=None):
    """First- and second-order transfer functions of every coordinate.

    Parameters
    ----------
    mech : Mechanism
    pose : Pose
    second : bool
        Also compute the second-order analogs.

    Returns
    -------
    first : numpy.ndarray, shape (B, nv, ni)
        ``dq_c / dx_i`` (input columns are unit vectors).
    second : numpy.ndarray, shape (B, nv, ni, ni) or None
        ``d²q_c / dx_i dx_j``.
    """
    _check_pose(mech, pose, "analogs")
    if not isinstance(second, (bool, np.bool_)):
        raise MechanismError(f"analogs: second: expected True or False, got {shown(second)}")
    t = mech.tree
    ks = pose.kinematics() if ks is None else ks
    if not second and ks.first is not None \
            and not np.isnan(ks.first).any():
        return ks.first.copy(), None         # computed by the solver with its last step
    J = mech.jacobian(ks)
    unknown = mech.unknown_columns()
    inp = mech.input_columns()
    B, ni = J.shape[0], inp.size
    # solve in dimensionless coordinates for a meaningful truncation
    L = t.scale
    Js = mech._scaled_jacobian(ks)
    lstsq = _LstSq(Js[:, :, unknown], _expected_rank(mech))

    def solve_unknown(rhs_scaled):      # rhs (B, m, k) → (B, nu, k) dimensionless
        return lstsq.solve(rhs_scaled)

    row_scale = mech._scaled_rows        # world twist rows → dimensionless rows

    col_scale = np.ones(t.nv)
    col_scale[t.length_cols] = L
    first = np.zeros((B, t.nv, ni))
    first[:, inp, np.arange(ni)] = 1.0
    first[:, unknown] = -solve_unknown(row_scale(J[:, :, inp])) * col_scale[unknown, None]
    if not second:
        return first, None
    sec = np.zeros((B, t.nv, ni, ni))
    for i in range(ni):
        for k in range(i, ni):
            bias = _bias(mech, ks, first[:, :, i], first[:, :, k])        # (B, nv, 6)
            rhs = np.einsum("lc,bcs->bls", t.loop_coef, bias).reshape(B, -1, 1)
            s = -solve_unknown(row_scale(rhs))[..., 0] * col_scale[unknown]
            sec[:, unknown, i, k] = s
            sec[:, unknown, k, i] = s
    return first, sec


def _check_pose(mech, pose, what):
    from .pose import Pose
    if not isinstance(pose, Pose):
        raise MechanismError(f"{what}: pose must be a Pose (from Mechanism.solve), got "
                             f"{type(pose).__name__}")
    if pose.mechanism is not mech:
        raise MechanismError(f"{what}: pose belongs to another mechanism")


def joint_analogs(mech, pose, joint: str, index: int = 0, input: int = 0):
    """Transfer functions of one joint coordinate with respect to one input.

    Returns ``(value, first, second)``, each ``(B,)`` (``()`` for a scalar pose).
    """
    _check_pose(mech, pose, "joint_analogs")
    j = mech.joint(joint)
    index = as_index(index, "joint_analogs: index")
    input = as_index(input, "joint_analogs: input")
    if j.kind == "S":
        raise MechanismError(f"joint_analogs: {joint!r} is spherical; use analogs() for its "
                             "angular-velocity coordinates")
    if not 0 <= index < j.nq:
        raise MechanismError(f"joint_analogs: index {index} out of range for {joint!r} ({j.kind})")
    if not 0 <= input < len(mech.inputs):
        raise MechanismError(f"joint_analogs: input {input} out of range ({len(mech.inputs)} inputs)")
    first, sec = analogs(mech, pose)
    c = mech.tree.v_offset[j.index] + index
    val = pose.q[:, mech.tree.q_offset[j.index] + index]
    out = (val, first[:, c, input], sec[:, c, input, input])
    return tuple(o[0] for o in out) if pose.scalar else out


def point_analogs(mech, pose, link: str, xyz):
    """Position, first and second analogs of a point of ``link``.

    Parameters
    ----------
    link : str
    xyz : array_like, shape (3,)
        The point's ground coordinates at the assembly pose.

    Returns
    -------
    position : (B, 3)
    first : (B, 3, ni)
        ``dp/dx_i``.
    second : (B, 3, ni, ni)
        ``d²p/dx_i dx_j``.
    """
    _check_pose(mech, pose, "point_analogs")
    if not isinstance(link, str) or link not in mech.links:
        raise MechanismError(f"point_analogs: no link named {link!r}; links: "
                             f"{', '.join(mech.links)}")
    p = as_array(xyz, "point_analogs: xyz")
    if p.shape != (3,):
        raise MechanismError(f"point_analogs: xyz must be a 3-vector, got shape {p.shape}")
    t = mech.tree
    li = mech.tree.link_index[link]
    ks = pose.kinematics()
    first, sec = analogs(mech, pose, ks=ks)
    T = ks.link[:, li]
    x = T[:, :3, :3] @ p + T[:, :3, 3]
    ni = first.shape[2]
    V = np.stack([link_twists(mech, ks, first[:, :, i])[:, li] for i in range(ni)], 1)  # (B,ni,6)

    def vel(tw, pt):                     # velocity of the point pt under twist tw
        return tw[..., :3] + _cross(tw[..., 3:], pt)

    d1 = vel(V, x[:, None])              # (B, ni, 3)
    d2 = np.zeros(x.shape[:1] + (3, ni, ni))
    for i in range(ni):
        for k in range(ni):
            acc = link_twists(mech, ks, sec[:, :, i, k])[:, li]
            acc = acc + np.einsum("lc,bcs->bls", t.path_sign,
                                  _bias(mech, ks, first[:, :, i], first[:, :, k]))[:, li]
            d2[:, :, i, k] = vel(acc, x) + _cross(V[:, i, 3:], d1[:, k])
    # symmetrise the velocity-product term
    d2 = 0.5 * (d2 + np.swapaxes(d2, -1, -2))
    return x, np.swapaxes(d1, 1, 2), d2
