"""Manufacturing tolerances of a mechanism's drive forces: Monte Carlo on the engine's
inverse dynamics against the first-order prediction.

Every joint is made with errors of its frame at the assembly pose (the frame the joint is
given by, Z along its axis): the frame turned about its own X and Y axes (two tilts,
each N(0, σ_dir), rad) and its origin shifted along X and Y (two shifts, each N(0, σ_pos),
length) — for R, H, C and U joints; a P joint is tilted only (its origin is
immaterial), an S joint shifted only, along X, Y and Z (its axes are immaterial).  Each
made mechanism is assembled at the made frames (its links take the made joints' places),
driven through the same input motion, and its drive forces compared with the design's.
A made mechanism that cannot follow the motion (an over-constrained design, e.g. a planar
linkage with tilted axes, loses its mobility) is counted, not sampled.

The first-order prediction uses the same engine: the sensitivities ``J = ∂F/∂p`` of the
drive forces at every time to every parameter by central differences, the linear changes
``J δp`` of the very same samples, and the predicted standard deviation
``sqrt(diag(J Σ Jᵀ))`` (Σ diagonal: σ_dir², σ_pos²).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import pandas as pd

from .errors import ClosureError, MechanismError
from .frames import as_index, as_number, exp_so3
from .pose import REACHED, STATUS, Pose

__all__ = ["DriveTolerance", "drive_tolerance", "joint_error_parameters", "made_frames"]

#: the error parameters of a joint kind: tilts about the frame's X, Y; shifts along X, Y (Z)
_PARAMETERS = {"R": ("tilt_x", "tilt_y", "shift_x", "shift_y"), "H": None, "C": None,
               "U": None, "P": ("tilt_x", "tilt_y"), "S": ("shift_x", "shift_y", "shift_z")}
for _k in "HCU":
    _PARAMETERS[_k] = _PARAMETERS["R"]
#: the status codes of a pose that closed
_CLOSED = [k for k, v in STATUS.items() if v in REACHED]
#: a made mechanism whose coordinates differ from the design's by more than this times
#: max(1, the largest joint distance from the origin) (rad or length) at some time has
#: left the design's branch: a failure, not a sample
_BRANCH = 0.1


@dataclass
class DriveTolerance:
    """A drive-force tolerance study (:func:`drive_tolerance`).

    Attributes
    ----------
    summary : pandas.DataFrame
        One row per time and input: ``t``, ``input``, ``drive`` (the design's, N or
        N·m), ``mean``, ``sd`` (of the sampled change F − F_design), ``mean_linear``,
        ``sd_linear`` (of ``J δp``, the same samples), ``sd_predicted``
        (``sqrt(diag(J Σ Jᵀ))``).
    peak : pandas.DataFrame
        One row per input: ``design`` (largest |F| over the motion), ``mean``, ``sd``
        (sampled), ``mean_linear``, ``sd_linear`` (the largest |F + J δp|).
    changes, linear : numpy.ndarray, shape (samples, N, inputs)
        Sampled and first-order drive-force changes of the samples that moved.
    sensitivity : numpy.ndarray, shape (N, inputs, parameters)
        ``∂F/∂p``.
    parameters : list of str
        ``<joint>.<tilt_x|tilt_y|shift_x|shift_y|shift_z>``.
    failed : int
        Samples whose made mechanism could not follow the motion (or left the design's
        branch: a coordinate further than 0.1 · max(1, size) from the design's).
    rigid : list of str
        Parameters whose small change alone stops the motion (their sensitivity is not
        defined; an over-constrained design loses its mobility).
    """

    summary: pd.DataFrame
    peak: pd.DataFrame
    changes: np.ndarray
    linear: np.ndarray
    sensitivity: np.ndarray
    parameters: list
    failed: int
    rigid: list


def joint_error_parameters(kinds: dict) -> list:
    """The error parameters ``<joint>.<name>`` of joints ``{name: kind}``, in order."""
    return [f"{j}.{p}" for j, k in kinds.items() for p in _PARAMETERS[k]]


def made_frames(frames: dict, kinds: dict, dp) -> dict:
    """The joint frames ``{name: (4, 4)}`` made with the errors ``dp`` (one value per
    :func:`joint_error_parameters`, rad and length)."""
    out, i = {}, 0
    for j, F in frames.items():
        names = _PARAMETERS[kinds[j]]
        v = dict(zip(names, dp[i:i + len(names)]))
        i += len(names)
        G = np.array(F, float)
        R = G[:3, :3]
        G[:3, 3] = G[:3, 3] + R @ [v.get("shift_x", 0.0), v.get("shift_y", 0.0),
                                   v.get("shift_z", 0.0)]
        G[:3, :3] = R @ exp_so3(np.array([v.get("tilt_x", 0.0), v.get("tilt_y", 0.0), 0.0]))
        out[j] = G
    return out


def drive_tolerance(build: Callable, frames: dict, kinds: dict, t, law, *,
                    direction_sigma: float = 0.0, position_sigma: float = 0.0,
                    samples: int = 1000, seed: int = 0, step: float = 1e-6) -> DriveTolerance:
    """Drive forces of a mechanism made with joint errors, sampled and to first order.

    Parameters
    ----------
    build : callable
        ``build(frames) -> closure.Dynamics``: the model with its joints at ``frames``
        (``{joint name: (4, 4) frame in the ground frame at the assembly pose}``).
    frames, kinds : dict
        The design's joint frames and kinds (``{name: "R" | "P" | ...}``).
    t : array_like (N,)
        Times (s).
    law : tuple of three arrays (N, inputs)
        The input motion: positions, rates, accelerations.  The design follows it by the
        engine's continuation; a made mechanism is solved at all times at once from the
        design's poses (its own branch, errors being small).
    direction_sigma : float
        Standard deviation of each of a joint's two tilts (rad).
    position_sigma : float
        Standard deviation of each of a joint's shifts (length).
    samples : int
        Monte Carlo samples (≥ 10).
    seed : int
        Seed of the samples.
    step : float
        Central-difference step of the sensitivities (rad, and length × the largest
        joint distance from the origin).

    Returns
    -------
    DriveTolerance

    Raises
    ------
    MechanismError
        Bad input, naming the argument; ``frames`` whose design cannot follow the motion.
    """
    direction_sigma = _at_least(as_number(direction_sigma, "direction_sigma"),
                                "direction_sigma", 0.0)
    position_sigma = _at_least(as_number(position_sigma, "position_sigma"), "position_sigma",
                               0.0)
    if direction_sigma == 0 and position_sigma == 0:
        raise MechanismError("direction_sigma, position_sigma: at least one must be > 0")
    samples = _at_least(as_index(samples, "samples"), "samples", 10)
    seed = _at_least(as_index(seed, "seed"), "seed", 0)
    if set(frames) != set(kinds) or any(k not in _PARAMETERS for k in kinds.values()):
        raise MechanismError("frames, kinds: one frame and one kind (R, P, C, H, U, S) per joint")
    names = joint_error_parameters(kinds)
    sig = np.array([direction_sigma if n.split(".")[1].startswith("tilt") else position_sigma
                    for n in names])
    size = max(1.0, max(np.linalg.norm(np.asarray(F, float)[:3, 3]) for F in frames.values()))
    h = np.where([n.split(".")[1].startswith("tilt") for n in names], step, step * size)

    design = build(frames)
    x, xd, xdd = (np.asarray(v, float) for v in law)
    ref = design.m.sweep(x, return_pose=True)[1]          # the design's branch
    if len(ref) != len(x):
        raise MechanismError("frames: the design itself cannot follow the motion")

    def drive(dp):
        """The made mechanism's drive forces (N, inputs), or None where it cannot follow
        the motion: Newton at every time at once from the design's poses (the same
        branch); lost mobility (the engine's MechanismError) or a loop that does not
        close (a pose not reached) is a failure."""
        try:
            d = build(made_frames(frames, kinds, dp))
            guess = Pose(d.m, x, ref.q, ref.rot, ref.residual, np.zeros(len(x), int),
                         np.full(len(x), np.nan), np.zeros(len(x), int))
            pose = d.m.solve(x, guess, continuation=False, raise_on_failure=False)
        except (ClosureError, MechanismError):
            return None
        if not np.all(np.isin(pose.status, _CLOSED)):
            return None
        if np.abs(pose.q - ref.q).max() > _BRANCH * size:   # left the design's branch
            return None
        M, h_, Q, _ = d.terms(pose, xd, t)
        return np.einsum("bij,bj->bi", M, xdd) + h_ - Q

    F0 = drive(np.zeros(len(names)))
    if F0 is None:
        raise MechanismError("frames: the design itself cannot follow the motion")
    J = np.empty(F0.shape + (len(names),))
    for i in range(len(names)):
        e = np.zeros(len(names))
        e[i] = h[i]
        Fp, Fm = drive(e), drive(-e)
        if Fp is None or Fm is None:        # the parameter breaks the mobility: no gradient
            J[..., i] = np.nan
        else:
            J[..., i] = (Fp - Fm) / (2 * h[i])
    rng = np.random.default_rng(seed)
    dps = rng.normal(size=(samples, len(names))) * sig
    got, lin = [], []
    for dp in dps:
        F = drive(dp)
        if F is not None:
            got.append(F - F0)
            lin.append(np.nan_to_num(J) @ dp)
    failed = samples - len(got)
    changes = np.array(got).reshape(-1, *F0.shape)
    linear = np.array(lin).reshape(-1, *F0.shape)
    Jf = np.where(np.isfinite(J), J, 0.0)
    pred = np.sqrt(np.einsum("nip,p,nip->ni", Jf, sig ** 2, Jf))
    labels = design.m.input_labels()
    rows = []
    for k, lab in enumerate(labels):
        for n in range(len(t)):
            c, l_ = changes[:, n, k], linear[:, n, k]
            rows.append({"t": float(t[n]), "input": lab, "drive": float(F0[n, k]),
                         "mean": _stat(np.mean, c), "sd": _stat(np.std, c, ddof=1),
                         "mean_linear": _stat(np.mean, l_), "sd_linear": _stat(np.std, l_, ddof=1),
                         "sd_predicted": float(pred[n, k])})
    peaks = []
    for k, lab in enumerate(labels):
        p = np.abs(F0[None, :, k] + changes[:, :, k]).max(1)
        pl = np.abs(F0[None, :, k] + linear[:, :, k]).max(1)
        peaks.append({"input": lab, "design": float(np.abs(F0[:, k]).max()),
                      "mean": _stat(np.mean, p), "sd": _stat(np.std, p, ddof=1),
                      "mean_linear": _stat(np.mean, pl), "sd_linear": _stat(np.std, pl, ddof=1)})
    rigid = [n for i, n in enumerate(names) if not np.all(np.isfinite(J[..., i]))]
    return DriveTolerance(pd.DataFrame(rows), pd.DataFrame(peaks), changes, linear, J, names,
                          failed, rigid)


def _at_least(v, name, low):
    """``v`` itself, or MechanismError naming ``name`` when it is below ``low``."""
    if v < low:
        raise MechanismError(f"{name}: expected a value ≥ {low}, got {v!r}")
    return v


def _stat(f, v, **kw):
    return float(f(v, **kw)) if len(v) > 1 else float("nan")
