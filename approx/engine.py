"""Exact analogs of a 1-DOF mechanism from the closure engine (not finite differences)."""
from __future__ import annotations

import numpy as np

from closure import REACHED, ClosureError, MechanismError, Pose, joint_analogs

from .analog import ApproxError, TransferFunction, as_points, as_real

__all__ = ["EngineAnalogs"]


class EngineAnalogs(TransferFunction):
    """f, f', f'' of one joint coordinate of a 1-DOF mechanism against its input.

    Every call solves the loops for the whole batch of x at once (Gauss–Newton
    started from the nearest pose of a continuation sweep made once over
    ``[a, b]``), then takes the first and second analogs from the engine's
    velocity and acceleration solutions.  ``x`` may have any shape (the fits
    evaluate f'' on ``(intervals, nodes)`` arrays); the results have the shape
    of ``x``.  The last batch is remembered, so ``position``, ``velocity`` and
    ``acceleration`` at the same points cost one solve.

    Parameters
    ----------
    mechanism : closure.Mechanism
        With exactly one input.
    joint : str
        The output joint (not spherical).
    a, b : float
        Range of the input (rad or m), ``a < b``.  The guiding sweep runs from the
        input's assembly value to ``a`` and to ``b``, so the range need not contain it.
    index : int
        Coordinate of ``joint`` (0 for one-coordinate joints).
    offset, sign : float
        The output is ``offset + sign · q`` (to match a closed form's zero and direction).
    samples : int
        Poses of the guiding sweep over ``[a, b]`` (at least 2).

    Raises
    ------
    ApproxError
        Bad arguments (named in the message), or a range the mechanism cannot be
        driven through from its assembly pose (the input value reached is given).
    """

    def __init__(self, mechanism, joint: str, a: float, b: float, *, index: int = 0,
                 offset: float = 0.0, sign: float = 1.0, samples: int = 65):
        if not hasattr(mechanism, "inputs") or not hasattr(mechanism, "sweep"):
            raise ApproxError(f"mechanism: expected a closure.Mechanism, got "
                              f"{type(mechanism).__name__}")
        if len(mechanism.inputs) != 1:
            raise ApproxError(f"mechanism: expected one input, it has {len(mechanism.inputs)}")
        a, b = as_real(a, "a"), as_real(b, "b")
        if not a < b:
            raise ApproxError(f"a, b: expected a < b, got a={a}, b={b}")
        if not isinstance(joint, str):
            raise ApproxError(f"joint: expected a joint name (str), got {joint!r}")
        try:
            j = mechanism.joint(joint)
        except MechanismError as e:
            raise ApproxError(f"joint: {e}") from None
        if j.kind == "S":
            raise ApproxError(f"joint: {joint!r} is spherical; expected a joint with scalar "
                              "coordinates (R, P, C, H, U)")
        if isinstance(index, (bool, np.bool_)) or not isinstance(index, (int, np.integer)) \
                or not 0 <= index < j.nq:
            raise ApproxError(f"index: expected an integer in [0, {j.nq}) for joint {joint!r} "
                              f"({j.kind}), got {index!r}")
        if isinstance(samples, (bool, np.bool_)) or not isinstance(samples, (int, np.integer)) \
                or samples < 2:
            raise ApproxError(f"samples: expected an integer ≥ 2, got {samples!r}")
        self.m, self.joint, self.index = mechanism, joint, int(index)
        self.offset, self.sign = as_real(offset, "offset"), as_real(sign, "sign")
        if self.sign == 0:
            raise ApproxError("sign: expected a non-zero factor (1 or -1 to flip the output), "
                              "got 0.0")
        self.a, self.b = a, b
        self._cache = None
        xs = np.linspace(a, b, int(samples))
        # the assembly value of the input: the sweeps start there (it is 0 unless the
        # input joint was given as a pair of frames)
        q0 = mechanism.assembly()[0]
        x0 = float(q0[0, mechanism.input_q_columns()[0]])
        # sweep from the assembly input to b and to a, keep the poses reached
        parts = []
        for side in (xs[xs >= x0], xs[xs < x0][::-1]):
            if side.size:
                df, pose = mechanism.sweep(np.r_[x0, side], return_pose=True)
                if not df.status.isin(REACHED).all():
                    bad = df[~df.status.isin(REACHED)].iloc[0]
                    raise ApproxError(f"a, b: the mechanism cannot be driven from its assembly "
                                      f"input {x0} through [{a}, {b}]: stopped at x = "
                                      f"{bad.filter(like='reached').iloc[0]} ({bad.status})")
                parts.append(pose)
        n = sum(len(p) for p in parts)
        self._guide = Pose(mechanism, np.concatenate([p.inputs for p in parts]),
                           np.concatenate([p.q for p in parts]),
                           np.concatenate([p.rot for p in parts]),
                           *(np.zeros(n),) * 3, np.zeros(n, int))
        order = np.argsort(self._guide.inputs[:, 0], kind="stable")
        self._gx = self._guide.inputs[order, 0]
        self._gorder = order

    def _solve(self, x):
        """Poses at the flat array ``x`` (B,), each started from the nearest guide pose."""
        gx = self._gx
        j = np.clip(np.searchsorted(gx, x), 1, gx.size - 1) if gx.size > 1 else \
            np.zeros(x.size, int)
        if gx.size > 1:
            j = np.where(np.abs(x - gx[j - 1]) <= np.abs(x - gx[j]), j - 1, j)
        near = self._gorder[j]
        g = self._guide
        guess = Pose(self.m, g.inputs[near], g.q[near], g.rot[near], *(np.zeros(x.size),) * 3,
                     np.zeros(x.size, int))
        return self.m.solve(x, guess=guess)

    def all(self, x):
        """``(f, f', f'')`` at ``x`` (each shaped like ``x``; any shape).

        Units: f in the joint coordinate's unit (rad or m), f' per unit of input,
        f'' per unit of input squared.
        """
        x = as_points(x, "x")
        shape = x.shape
        key = (shape, x.tobytes())
        if self._cache is not None and self._cache[0] == key:
            return tuple(o.copy() for o in self._cache[1])
        flat = x.ravel()
        if flat.size == 0:
            out = (np.zeros(shape),) * 3
        else:
            try:
                pose = self._solve(flat)
            except ClosureError as e:
                raise ApproxError(f"x: the mechanism cannot reach every x (fitted range "
                                  f"[{self.a}, {self.b}]): {e}") from None
            val, d1, d2 = joint_analogs(self.m, pose, self.joint, self.index)
            s = self.sign
            out = ((self.offset + s * val).reshape(shape), (s * d1).reshape(shape),
                   (s * d2).reshape(shape))
        self._cache = (key, out)
        return tuple(o.copy() for o in out)

    def position(self, x):
        """f(x): ``offset + sign · q`` of the output coordinate, shaped like ``x``."""
        return self.all(x)[0]

    def velocity(self, x):
        """f'(x) = ``sign · dq/dx`` (the engine's first analog), shaped like ``x``."""
        return self.all(x)[1]

    def acceleration(self, x):
        """f''(x) = ``sign · d²q/dx²`` (the engine's second analog), shaped like ``x``."""
        return self.all(x)[2]
