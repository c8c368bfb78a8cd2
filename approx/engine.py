"""Exact analogs of a 1-DOF mechanism from the closure engine (not finite differences)."""
from __future__ import annotations

import numpy as np

from closure import Pose, joint_analogs

from .analog import ApproxError, TransferFunction

__all__ = ["EngineAnalogs"]


class EngineAnalogs(TransferFunction):
    """f, f', f'' of one joint coordinate of a 1-DOF mechanism against its input.

    Every call solves the loops for the whole batch of x at once (Gauss–Newton
    started from the nearest pose of a continuation sweep made once over
    ``[a, b]``), then takes the first and second analogs from the engine's
    velocity and acceleration solutions.

    Parameters
    ----------
    mechanism : closure.Mechanism
        With exactly one input.
    joint : str
    index : int
        Coordinate of ``joint`` (0 for one-coordinate joints).
    a, b : float
        Range of the input.
    offset, sign : float
        The output is ``offset + sign · q`` (to match a closed form's zero and direction).
    samples : int
        Poses of the guiding sweep.
    """

    def __init__(self, mechanism, joint: str, a: float, b: float, *, index: int = 0,
                 offset: float = 0.0, sign: float = 1.0, samples: int = 65):
        if len(mechanism.inputs) != 1:
            raise ApproxError(f"mechanism: expected one input, it has {len(mechanism.inputs)}")
        if not a < b:
            raise ApproxError(f"a, b: expected a < b, got a={a}, b={b}")
        self.m, self.joint, self.index = mechanism, joint, index
        self.offset, self.sign = float(offset), float(sign)
        self.a, self.b = float(a), float(b)
        xs = np.linspace(a, b, samples)
        # sweep from the assembly input (0) to a and to b, keep the poses within [a, b]
        parts = []
        for side in (xs[xs >= 0], xs[xs < 0][::-1]):
            if side.size:
                df, pose = mechanism.sweep(np.r_[0.0, side], return_pose=True)
                if (df.status != "ok").any():
                    bad = df[df.status != "ok"].iloc[0]
                    raise ApproxError(f"range [{a}, {b}]: the mechanism cannot be driven past "
                                      f"x = {bad.filter(like='reached').iloc[0]} ({bad.status})")
                parts.append(pose)
        self._guide = Pose(mechanism, np.concatenate([p.inputs for p in parts]),
                           np.concatenate([p.q for p in parts]),
                           np.concatenate([p.rot for p in parts]),
                           *(np.zeros(sum(len(p) for p in parts)),) * 3,
                           np.zeros(sum(len(p) for p in parts), int))

    def _solve(self, x):
        x = np.atleast_1d(np.asarray(x, float))
        near = np.abs(x[:, None] - self._guide.inputs[None, :, 0]).argmin(1)
        g = self._guide
        guess = Pose(self.m, g.inputs[near], g.q[near], g.rot[near], *(np.zeros(x.size),) * 3,
                     np.zeros(x.size, int))
        return self.m.solve(x, guess=guess)

    def all(self, x):
        """``(f, f', f'')`` at ``x`` (each shaped like ``x``)."""
        shape = np.shape(x)
        val, d1, d2 = joint_analogs(self.m, self._solve(x), self.joint, self.index)
        s = self.sign
        return ((self.offset + s * val).reshape(shape), (s * d1).reshape(shape),
                (s * d2).reshape(shape))

    def position(self, x):
        return self.all(x)[0]

    def velocity(self, x):
        return self.all(x)[1]

    def acceleration(self, x):
        return self.all(x)[2]
