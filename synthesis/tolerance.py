"""Manufacturing tolerances of a synthesised chain: Monte Carlo on the closure engine,
against the first-order prediction.

Each joint axis of the chain (a table row of :func:`synthesis.enumerate_dyads` or
:func:`synthesis.complete_dyads`) is made with errors: its direction tilted by a small
rotation about two axes perpendicular to it (each N(0, σ_dir), rad) and its point shifted
perpendicular to it (each N(0, σ_pos), length; a prismatic joint's point is immaterial
and is not perturbed).  The made chain is driven to the design's joint values at every
task position by the engine (all samples hang from one mechanism, one batched call per
block; the made chain is zeroed at position 1, where its body is placed, so the errors
there vanish), and the body's error against the design chain is measured at a body point: the
rotation error (rad) and the point's displacement (length).

The first-order prediction uses the same engine: the sensitivities ``J = ∂e/∂p`` of the
six error components to the 4 parameters per joint, by central differences of the
engine's poses, so the error covariance is ``J Σ Jᵀ`` (Σ diagonal: σ_dir², σ_pos²), and
the linear errors ``J δp`` of the very same samples give the predicted distribution of
the error magnitudes (mean, standard deviation) beside the sampled one.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from closure import Mechanism
from closure.frames import exp_so3, log_so3, transform

from .errors import SynthesisError
from .validate import integer, number

__all__ = ["ToleranceResult", "chain_tolerance"]

_BLOCK = 32           # chains per engine mechanism (the engine's batched solve is quadratic in it)


@dataclass
class ToleranceResult:
    """A tolerance study of one chain.

    Attributes
    ----------
    summary : pandas.DataFrame
        One row per position: ``position``, ``rot_mean``, ``rot_std`` (sampled rotation
        error, rad), ``rot_mean_linear``, ``rot_std_linear`` (first order, the same
        samples), ``pos_mean``, ``pos_std``, ``pos_mean_linear``, ``pos_std_linear``
        (the body point's displacement, length), ``rot_sd_predicted``,
        ``pos_sd_predicted`` (root of the trace of the rotation and displacement blocks
        of ``J Σ Jᵀ``: the RMS error magnitudes to first order).
    errors : numpy.ndarray, shape (samples, P, 6)
        Sampled error components (rotation vector rad, displacement length).
    linear : numpy.ndarray, shape (samples, P, 6)
        ``J δp`` for the same samples.
    sensitivity : numpy.ndarray, shape (P, 6, n_parameters)
        ``∂e/∂p`` per position (parameters: per joint two tilts (rad), two shifts
        (length)).
    parameters : list of str
        The parameter names, ``j{k}_tilt1, j{k}_tilt2, j{k}_shift1, j{k}_shift2``.
    """

    summary: pd.DataFrame
    errors: np.ndarray
    linear: np.ndarray
    sensitivity: np.ndarray
    parameters: list


def _chain(row):
    """Kinds, lines (u, c), and the engine's input values (P, n_inputs) of a table row."""
    if not hasattr(row, "get") or not hasattr(row, "__getitem__") or isinstance(row, str):
        raise SynthesisError(f"row: expected a table row (pandas Series or mapping), got "
                             f"{type(row).__name__}")
    try:
        return _chain_of_row(row)
    except KeyError as e:
        raise SynthesisError(f"row: missing column {e}") from None


def _chain_of_row(row):
    ks = [k for k in (1, 2, 3) if isinstance(row.get(f"j{k}_type"), str)]
    kinds = [row[f"j{k}_type"] for k in ks]
    if not ks or any(t not in "RPHC" for t in kinds):
        raise SynthesisError(f"row: tolerances are computed for chains of R, P, H and C joints, "
                             f"got {''.join(kinds)!r}")
    if row.get("reason", ""):
        raise SynthesisError(f"row: variant {row.get('variant')} is degenerate: {row['reason']}")
    n = 0
    while f"q1_pos{n + 1}" in row:
        n += 1
    lines, cols, pitches = [], [], []
    for k, t in zip(ks, kinds):
        u = np.array([row[f"j{k}_u{c}"] for c in "xyz"], float)
        c = np.array([row[f"j{k}_{c}"] for c in "xyz"], float)
        lines.append((u / np.linalg.norm(u), c))
        pitches.append(float(row[f"j{k}_pitch"]) if t == "H" else None)
        cols.append([row[f"q{k}_pos{p}"] for p in range(1, n + 1)])
        if t == "C":
            cols.append([row[f"d{k}_pos{p}"] for p in range(1, n + 1)])
    x = np.asarray(cols, float).T
    if not np.all(np.isfinite(x)) or np.any([not np.all(np.isfinite(np.r_[u, c]))
                                             for u, c in lines]):
        raise SynthesisError(f"row: variant {row.get('variant')} has missing axes or joint values")
    return kinds, lines, pitches, x


def _perp(u):
    a = np.array([1.0, 0, 0]) if abs(u[0]) < 0.9 else np.array([0, 1.0, 0])
    e1 = a - (a @ u) * u
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(u, e1)


def _made(lines, kinds, dp):
    """The lines made with parameter errors ``dp (4 n_joints,)``."""
    out = []
    for j, ((u, c), t) in enumerate(zip(lines, kinds)):
        e1, e2 = _perp(u)
        a1, a2, b1, b2 = dp[4 * j:4 * j + 4]
        uu = exp_so3(a1 * e1 + a2 * e2) @ u
        cc = c if t == "P" else c + b1 * e1 + b2 * e2
        out.append((uu, cc))
    return out


def _bodies(chains, kinds, pitches, x):
    """Body frames (P, V, 4, 4) of chains (lists of lines) driven to the values ``x``."""
    out = []
    for s in range(0, len(chains), _BLOCK):
        block = chains[s:s + _BLOCK]
        m = Mechanism()
        for v, lines in enumerate(block):
            names = ["ground"] + [f"L{v}_{k}" for k in range(len(kinds))]
            for nme in names[1:]:
                m.add_link(nme)
            for k, ((u, c), t) in enumerate(zip(lines, kinds)):
                e1, e2 = _perp(u)
                jn = f"v{v}j{k}"
                m.add_joint(jn, t, names[k], names[k + 1],
                            at=transform(np.stack([e1, e2, u], -1), c), validate=False,
                            pitch=pitches[k])
                m.add_input(jn, 0)
                if t == "C":
                    m.add_input(jn, 1)
        pose = m.solve(np.tile(x, (1, len(block))), continuation=False)
        link = pose.kinematics(twists=False).link
        out.append(link[:, [m.links.index(f"L{v}_{len(kinds) - 1}") for v in range(len(block))]])
    return np.concatenate(out, 1)


def _errors(B, B0, point):
    """Error components (…, 6): rotation vector of B0ᵀ B and the point's displacement."""
    rot = log_so3(np.swapaxes(B0[..., :3, :3], -1, -2) @ B[..., :3, :3])
    rot = np.einsum("...ij,...j->...i", B0[..., :3, :3], rot)          # in the ground frame
    disp = (np.einsum("...ij,j->...i", B[..., :3, :3], point) + B[..., :3, 3]
            - np.einsum("...ij,j->...i", B0[..., :3, :3], point) - B0[..., :3, 3])
    return np.concatenate([rot, disp], -1)


def chain_tolerance(row, *, direction_sigma: float, position_sigma: float,
                    samples: int = 10000, seed: int = 0, point=None,
                    length: float = 1.0) -> ToleranceResult:
    """Monte Carlo tolerance study of a synthesised chain against its first-order
    prediction (module notes).

    Parameters
    ----------
    row : mapping (a pandas Series)
        A regular row of a synthesis table (joints R, P, H, C).
    direction_sigma : float
        Standard deviation (rad) of each of the two tilts of every joint axis.
    position_sigma : float
        Standard deviation (length) of each of the two perpendicular shifts of every axis.
    samples : int
        Monte Carlo samples (≥ 10).
    seed : int
        Seed of the samples (the same seed gives the same study).
    point : array_like (3,), optional
        The body point whose displacement is measured, in position 1 (length); default
        the origin.
    length : float
        The task's size: sets the finite-difference step of the positions.

    Returns
    -------
    ToleranceResult

    Raises
    ------
    SynthesisError
        Bad input, naming it; a row that is degenerate or has joints other than R, P, H, C.
    """
    ds = number(direction_sigma, "direction_sigma", unit_="rad")
    ps = number(position_sigma, "position_sigma", unit_="length")
    for name, v in (("direction_sigma", ds), ("position_sigma", ps)):
        if v < 0:
            raise SynthesisError(f"{name}: expected a standard deviation ≥ 0, got {v}")
    n = integer(samples, "samples", low=10)
    seed = integer(seed, "seed", low=0)
    length = number(length, "length", positive=True)
    pt = np.zeros(3) if point is None else np.asarray(point, float)
    if pt.shape != (3,) or not np.all(np.isfinite(pt)):
        raise SynthesisError(f"point: expected a finite 3-vector, got {point!r}")
    kinds, lines, pitches, x = _chain(row)
    nj = len(kinds)
    names = [f"j{k + 1}_{w}" for k in range(nj) for w in ("tilt1", "tilt2", "shift1", "shift2")]
    sig = np.tile([ds, ds, ps, ps], nj)
    sig[[4 * j + 2 for j, t in enumerate(kinds) if t == "P"]] = 0.0
    sig[[4 * j + 3 for j, t in enumerate(kinds) if t == "P"]] = 0.0
    # first order: central differences of the engine's poses
    h = np.tile([1e-6, 1e-6, 1e-6 * length, 1e-6 * length], nj)
    fd = [_made(lines, kinds, s * h[i] * np.eye(len(h))[i]) for i in range(len(h))
          for s in (1.0, -1.0)]
    dp = np.random.default_rng(seed).normal(size=(n, len(sig))) * sig
    made = [_made(lines, kinds, d) for d in dp]
    B = _bodies([lines] + fd + made, kinds, pitches, x)                     # (P, 1 + 2k + n)
    B0 = B[:, :1]
    E_fd = _errors(B[:, 1:1 + len(fd)], B0, pt)                             # (P, 2k, 6)
    J = (E_fd[:, 0::2] - E_fd[:, 1::2]) / (2 * h)[None, :, None]           # (P, k, 6)
    J = np.swapaxes(J, 1, 2)                                                # (P, 6, k)
    E = np.swapaxes(_errors(B[:, 1 + len(fd):], B0, pt), 0, 1)              # (n, P, 6)
    L = np.einsum("pik,nk->npi", J, dp)
    C = np.einsum("pik,k,pjk->pij", J, sig ** 2, J)
    rows = []
    for p in range(x.shape[0]):
        r, rl = np.linalg.norm(E[:, p, :3], axis=1), np.linalg.norm(L[:, p, :3], axis=1)
        d, dl = np.linalg.norm(E[:, p, 3:], axis=1), np.linalg.norm(L[:, p, 3:], axis=1)
        rows.append({"position": p + 1, "rot_mean": r.mean(), "rot_std": r.std(ddof=1),
                     "rot_mean_linear": rl.mean(), "rot_std_linear": rl.std(ddof=1),
                     "pos_mean": d.mean(), "pos_std": d.std(ddof=1),
                     "pos_mean_linear": dl.mean(), "pos_std_linear": dl.std(ddof=1),
                     "rot_sd_predicted": float(np.sqrt(np.trace(C[p, :3, :3]))),
                     "pos_sd_predicted": float(np.sqrt(np.trace(C[p, 3:, 3:])))})
    return ToleranceResult(pd.DataFrame(rows), E, L, J, names)
