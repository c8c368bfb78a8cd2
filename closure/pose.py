"""Solved poses of a mechanism: joint coordinates with their error figures."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from .errors import MechanismError
from .frames import as_array
from .state import KinematicState

__all__ = ["Pose", "STATUS", "REACHED"]

#: status codes of a solved pose
STATUS = {0: "ok", 1: "near-singular", 2: "no convergence", 3: "no assembly", 4: "dead point"}
#: the statuses of a pose that closed (a sweep's rows with a pose)
REACHED = ("ok", "near-singular")
#: poses returned by the solver keep their kinematic state (link poses, joint frames,
#: twists: about 2 KB per pose for an RSSR) only up to this many members; larger
#: batches keep the coordinates alone and recompute the state when asked
KEEP_STATE = 64


@dataclass(repr=False)
class Pose:
    """A batch of solved poses (or the assembly pose).

    Attributes
    ----------
    mechanism : Mechanism
    inputs : numpy.ndarray, shape (B, n_inputs)
    q : numpy.ndarray, shape (B, nq)
        Scalar joint coordinates (rad or length), spherical joints excluded.
    rot : numpy.ndarray, shape (B, ns, 3, 3)
        Relative rotations of the spherical joints.
    residual : numpy.ndarray, shape (B,)
        Largest loop-closure error: rotation (rad) or translation divided by
        the mechanism's length scale (the largest joint distance from the
        joints' centroid).
    iterations : numpy.ndarray, shape (B,)
        Newton iterations spent reaching each pose from its start (the guess, or the
        previous row of a sweep), over every internal step of the continuation.
    condition : numpy.ndarray, shape (B,)
        Condition number of the (dimensionless) Jacobian of the unknowns,
        over its expected rank (idle freedoms excluded).  Where the solver's step
        showed it to be at most ``closure.lstsq.FAST_COND`` (so below any limit that
        flags a pose) it is computed on first access, by one batched SVD.
    status : numpy.ndarray of int, shape (B,)
        0 ok, 1 near-singular (condition above the limit), 2 no convergence,
        3 no assembly (converged to a loop transform that is not the identity),
        4 dead point (the continuation from the guess stopped at a fold before
        the input: see ``reached``).
    scalar : bool
        True when a single input value was given (accessors then drop the batch axis).
    reached : numpy.ndarray, shape (B, n_inputs), optional
        The inputs the solver actually reached (differs from ``inputs`` only where
        ``status`` is 4, "dead point"); None where not tracked.
    """

    mechanism: object
    inputs: np.ndarray
    q: np.ndarray
    rot: np.ndarray
    residual: np.ndarray
    iterations: np.ndarray
    condition: np.ndarray
    status: np.ndarray
    scalar: bool = False
    _ks: KinematicState | None = field(default=None, repr=False, compare=False)
    reached: np.ndarray | None = field(default=None, repr=False, compare=False)
    _cond_pending: bool = field(default=False, repr=False, compare=False)

    @property
    def _raw_condition(self) -> np.ndarray:
        """The condition numbers as stored (NaN where not yet computed)."""
        return self.__dict__["_condition"]

    def _fill_condition(self) -> None:
        """Compute the condition numbers left NaN by the solver (one SVD per pose, from the
        kept twists, else from states recomputed in chunks)."""
        c = self.__dict__["_condition"]
        idx = np.nonzero(np.isnan(c))[0]
        if idx.size:
            from .lstsq import _expected_rank
            m = self.mechanism
            plan = m.plan
            _expected_rank(m)                   # known with the plan from the first solve
            ks = self._ks
            if ks is not None and ks.S is not None:
                c[idx] = plan.condition(ks.S, idx)
            else:
                for a in range(0, idx.size, 2048):
                    sub = idx[a:a + 2048]
                    c[sub] = plan.condition(plan.evaluate(self.q[sub], self.rot[sub]).S,
                                            np.arange(sub.size))
        self._cond_pending = False

    @property
    def state(self):
        """``(q, rot)``: the engine's state arrays."""
        return self.q, self.rot

    def kinematics(self, twists: bool = True) -> KinematicState:
        """The engine's kinematic state of these poses (see
        :meth:`Mechanism.kinematic_state`): kept from the solver for small batches
        (at most :data:`KEEP_STATE` poses), computed here and cached otherwise."""
        ks = self._ks
        if ks is None or (twists and ks.S is None):
            ks = self.mechanism.kinematic_state(self.state, twists=twists)
            self._ks = ks
        return ks

    def __repr__(self) -> str:
        B = len(self)
        m = self.mechanism
        counts = pd.Series(self.status_text).value_counts()
        parts = [f"{B} pose{'s' if B != 1 else ''} of a mechanism with {len(m.links)} links, "
                 f"{len(m.joints)} joints"]
        for k, lab in enumerate(m.input_labels()):
            x = self.inputs[:, k]
            parts.append(f"input {lab} {x.min():.6g}" + (f" … {x.max():.6g}" if B > 1 else ""))
        if B:
            parts.append(f"residual ≤ {np.max(self.residual):.1e}, condition "
                         f"{np.min(self.condition):.3g} … {np.max(self.condition):.3g}")
        parts.append("status: " + ", ".join(f"{n} {s}" for s, n in counts.items()))
        return "Pose(" + "; ".join(parts) + ")"

    @property
    def ok(self) -> np.ndarray:
        """Boolean mask of poses that closed to tolerance (status 0 or 1)."""
        return self.status <= 1

    @property
    def status_text(self) -> np.ndarray:
        """Status as words."""
        return np.array([STATUS[int(s)] for s in self.status])

    def _out(self, a):
        return a[0] if self.scalar else a

    def __len__(self) -> int:
        return self.q.shape[0]

    def __getitem__(self, name: str) -> np.ndarray:
        """Coordinates of joint ``name``: ``(B,)`` for one-coordinate joints, else
        ``(B, k)`` (S: Z–X–Z Euler angles ψ, θ, φ in rad)."""
        m = self.mechanism
        j = m.joint(name)
        t = m.tree
        if j.kind == "S":
            v = j.values(None, self.rot[:, t.s_index[j.index]])
        else:
            v = self.q[:, t.q_offset[j.index]:t.q_offset[j.index] + j.nq]
        return self._out(v[:, 0] if v.shape[1] == 1 else v)

    def rotation(self, name: str) -> np.ndarray:
        """Relative rotation ``(B, 3, 3)`` of spherical joint ``name``."""
        m = self.mechanism
        j = m.joint(name)
        if j.kind != "S":
            raise MechanismError(f"rotation: joint {name!r} is {j.kind}, not spherical")
        return self._out(self.rot[:, m.tree.s_index[j.index]])

    def values(self) -> np.ndarray:
        """All reported coordinates ``(B, n)`` in the order of ``coordinate_labels()``."""
        m = self.mechanism
        cols = []
        for j in m.joints:
            v = self[j.name] if not self.scalar else np.asarray(self[j.name])[None]
            cols.append(v.reshape(len(self), -1))
        return np.concatenate(cols, 1)

    def link_frame(self, link: str) -> np.ndarray:
        """World pose ``(B, 4, 4)`` of ``link`` (its frame is the ground frame at assembly)."""
        m = self.mechanism
        if not isinstance(link, str) or link not in m.links:
            raise MechanismError(f"no link named {link!r}; links: {', '.join(m.links)}")
        return self._out(self.kinematics(twists=False).link[:, m.tree.link_index[link]])

    def point(self, link: str, xyz) -> np.ndarray:
        """World position ``(B, 3)`` of a point of ``link`` given by its ground coordinates
        at the assembly pose."""
        T = np.asarray(self.link_frame(link))
        p = as_array(xyz, "point: xyz")
        if p.shape != (3,):
            raise MechanismError(f"point: xyz must be a 3-vector, got shape {p.shape}")
        return T[..., :3, :3] @ p + T[..., :3, 3]

    def table(self) -> pd.DataFrame:
        """One row per pose: inputs, joint coordinates, residual, condition, iterations, status."""
        return pd.DataFrame(self._columns())

    def _columns(self) -> dict:
        """The columns of :meth:`table`, in order (one DataFrame built from them)."""
        m = self.mechanism
        cols = {f"input:{lab}": self.inputs[:, k] for k, lab in enumerate(m.input_labels())}
        vals = self.values()
        labels = m.coordinate_labels()
        if len(set(labels)) < len(labels) or set(labels) & set(cols):    # never, by naming
            df = pd.DataFrame(self.inputs, columns=list(cols))
            df = pd.concat([df, pd.DataFrame(vals, columns=labels)], axis=1)
            df["residual"], df["condition"] = self.residual, self.condition
            df["iterations"], df["status"] = self.iterations, self.status_text
            return df
        cols.update((lab, vals[:, k]) for k, lab in enumerate(labels))
        cols["residual"] = self.residual
        cols["condition"] = self.condition
        cols["iterations"] = self.iterations
        cols["status"] = self.status_text
        return cols


def _get_condition(self) -> np.ndarray:
    if self._cond_pending:
        self._fill_condition()
    return self.__dict__["_condition"]


def _set_condition(self, value) -> None:
    self.__dict__["_condition"] = value
    self.__dict__["_cond_pending"] = False


Pose.condition = property(_get_condition, _set_condition, doc="Condition number of the "
                          "Jacobian of the unknowns ``(B,)`` (see the class notes).")
