"""Mechanisms: links, joints, inputs, the spanning tree and the independent loops.

A :class:`Mechanism` is described at one assembly pose: every link's frame
coincides with the ground frame there, so a point or joint frame "on a link" is
given by its ground coordinates at that pose (seed 000's constant link
matrices follow: A_ij = A_0i⁻¹ A_0j).  The links form a graph whose spanning
tree from the ground fixes every link's pose from the joint coordinates; each
joint outside the tree closes one independent loop (so the loops are found from
the graph, any number, branching links included: :mod:`closure.topology`).  The
mechanism compiles that structure and its evaluation plan (:mod:`closure.state`)
lazily, at the first solve after a change.
"""
from __future__ import annotations

import numpy as np

from .checks import shown
from .errors import MechanismError
from .frames import _inverse, as_array, check_transform, input_rates
from .joints import JOINT_KINDS, Joint
from .state import KinematicState, Plan
from .topology import Topology, compile_tree

__all__ = ["Mechanism"]


class Mechanism:
    """A multi-loop spatial mechanism.

    Parameters
    ----------
    links : iterable of str, optional
        Link names besides the ground (more can be added by :meth:`add_link`).
    ground : str
        Name of the fixed link.

    Examples
    --------
    A planar four-bar (all axes along z):

    >>> import numpy as np
    >>> from closure import Mechanism, transform
    >>> m = Mechanism(["crank", "coupler", "rocker"])
    >>> pts = {"A": (0, 0, 0), "B": (0, 1, 0), "C": (3, 2, 0), "D": (3, 0, 0)}
    >>> for name, a, b, p in [("A", "ground", "crank", "A"), ("B", "crank", "coupler", "B"),
    ...                       ("C", "coupler", "rocker", "C"), ("D", "ground", "rocker", "D")]:
    ...     _ = m.add_joint(name, "R", a, b, at=transform(None, pts[p]))
    >>> m.add_input("A")
    >>> pose = m.solve(0.3)
    >>> bool(pose.residual.max() < 1e-12)
    True
    """

    def __init__(self, links=(), ground: str = "ground"):
        if isinstance(links, str):
            raise MechanismError(f"links: expected an iterable of link names, got the string "
                                 f"{links!r} (write [{links!r}] for one link)")
        try:
            links = list(links)
        except TypeError:
            raise MechanismError(f"links: expected an iterable of link names, got "
                                 f"{type(links).__name__} {links!r}") from None
        if not isinstance(ground, str) or not ground:
            raise MechanismError(f"ground: expected a non-empty string, got {ground!r}")
        self.ground = ground
        self.links: list[str] = [self.ground]
        self._link_set = {self.ground}
        self.joints: list[Joint] = []
        self._joint_by_name: dict[str, Joint] = {}
        self._singular_assembly = False
        self.inputs: list[tuple[int, int]] = []
        self._input_set: set[tuple[int, int]] = set()
        self._q0: list[np.ndarray] = []
        self._rot0: list[np.ndarray | None] = []
        self._tree: Topology | None = None
        self._plan: Plan | None = None
        self._mobility: int | None = None
        for i, name in enumerate(links):
            if not isinstance(name, str) or not name:
                raise MechanismError(f"links: expected non-empty strings (link names), got "
                                     f"{shown(name)} at position {i}")
            if name in self._link_set:
                raise MechanismError(f"links: {name!r} appears twice (or is the ground's name); "
                                     "expected distinct link names")
            self.add_link(name)

    # ------------------------------------------------------------ description
    def add_link(self, name: str) -> None:
        """Add a link (its frame is the ground frame at the assembly pose)."""
        if not isinstance(name, str) or not name:
            raise MechanismError(f"add_link: name must be a non-empty string, got {name!r}")
        if name in self._link_set:
            raise MechanismError(f"add_link: link {name!r} already exists")
        self.links.append(name)
        self._link_set.add(name)
        self._tree = None

    def add_joint(self, name: str, kind: str, link_a: str, link_b: str, at, *,
                  pitch: float | None = None, validate: bool = True) -> Joint:
        """Add a joint between two links.

        Parameters
        ----------
        name : str
            Unique joint name.
        kind : {"R", "P", "C", "H", "U", "S"}
        link_a, link_b : str
            The joined links (declared before).
        at : array_like (4, 4) or pair of them
            The joint frame in the ground frame at the assembly pose (then the
            joint's coordinates are zero there), or a pair ``(frame_a,
            frame_b)`` of the frames on link *a* and link *b* (then the
            coordinates are read from ``frame_a⁻¹ frame_b``).  Frame rules are
            those of :mod:`closure.joints` (Z along the axis; U: Z along link
            *a*'s pin, X along link *b*'s pin).
        pitch : float
            Helical joints: slide per radian of rotation (length / rad).
        validate : bool
            Check that ``at`` is a proper rigid transform (skip only for frames a
            program built as exact rotations, e.g. by :func:`frame_from_points`).

        Returns
        -------
        Joint
        """
        if not isinstance(name, str) or not name:
            raise MechanismError(f"add_joint: name must be a non-empty string, got {name!r}")
        if name in self._joint_by_name:
            raise MechanismError(f"add_joint: joint {name!r} already exists")
        if not isinstance(kind, str) or kind not in JOINT_KINDS:
            raise MechanismError(f"joint {name!r}: kind {kind!r} unknown; expected one of "
                                 f"{', '.join(JOINT_KINDS)}")
        for field_, link in (("link_a", link_a), ("link_b", link_b)):
            if not isinstance(link, str) or link not in self._link_set:
                raise MechanismError(f"joint {name!r}: {field_} {link!r} is not a link of this "
                                     f"mechanism; known links: {', '.join(self.links)}")
        if link_a == link_b:
            raise MechanismError(f"joint {name!r}: link_a and link_b are both {link_a!r}")
        if not isinstance(validate, (bool, np.bool_)):
            raise MechanismError(f"joint {name!r}: validate: expected True or False, got "
                                 f"{shown(validate)}")
        if kind == "H":
            if not isinstance(pitch, (int, float, np.integer, np.floating)) or \
                    isinstance(pitch, (bool, np.bool_)) or not np.isfinite(pitch):
                raise MechanismError(f"joint {name!r}: a helical joint needs a finite pitch "
                                     "(length per radian)")
        elif pitch is not None:
            raise MechanismError(f"joint {name!r}: pitch is only for helical (H) joints")
        at_arr = as_array(at, f"joint {name!r}: at (a 4x4 transform or a pair of them)")
        if at_arr.shape not in ((4, 4), (2, 4, 4)):
            raise MechanismError(f"joint {name!r}: at must have shape (4, 4) or (2, 4, 4) (a pair "
                                 f"of frames on link a and link b), got {at_arr.shape}")
        if at_arr.shape == (2, 4, 4):
            fa = check_transform(at_arr[0], f"joint {name!r}: at[0]")
            fb = check_transform(at_arr[1], f"joint {name!r}: at[1]")
        else:
            fa = check_transform(at_arr, f"joint {name!r}: at") if validate else at_arr
            fb = None
        joint = Joint(name, kind, link_a, link_b, fa, fa, float(pitch or 0.0), len(self.joints))
        if fb is None:
            q0 = np.zeros(joint.nq)
            rot0 = np.eye(3) if kind == "S" else None
            # A(0) is the identity for every kind but the Hooke joint
            joint.frame_b = fa @ joint.matrix(q0[None])[0] if kind == "U" else fa.copy()
        else:
            q0, rot0 = joint.coordinates_of(_inverse(fa) @ fb)
            joint.frame_b = fb
        self.joints.append(joint)
        self._joint_by_name[name] = joint
        self._q0.append(q0)
        self._rot0.append(rot0)
        self._tree = None
        return joint

    def add_input(self, joint: str, index: int = 0) -> None:
        """Declare coordinate ``index`` of ``joint`` an input (driven) coordinate."""
        j = self.joint(joint)
        if j.kind == "S":
            raise MechanismError(f"add_input: joint {joint!r} is spherical; its rotation is not a "
                                 "joint parameter that can be driven (use R, P, C, H or U)")
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
            raise MechanismError(f"add_input: index must be an integer coordinate index of joint "
                                 f"{joint!r} {j.coordinate_names}, got {index!r}")
        if not (0 <= int(index) < j.nq):
            raise MechanismError(f"add_input: joint {joint!r} ({j.kind}) has coordinates "
                                 f"{j.coordinate_names}; index {index} is out of range")
        key = (j.index, int(index))
        if key in self._input_set:                 # a set: declaring n inputs stays O(n)
            raise MechanismError(f"add_input: {joint}[{index}] is already an input")
        self.inputs.append(key)
        self._input_set.add(key)
        self._tree = None

    def joint(self, name: str) -> Joint:
        """The joint called ``name``."""
        j = self._joint_by_name.get(name) if isinstance(name, str) else None
        if j is not None:
            return j
        raise MechanismError(f"no joint named {name!r}; joints: "
                             f"{', '.join(j.name for j in self.joints)}")

    # ------------------------------------------------------------ compilation
    @property
    def tree(self) -> Topology:
        """The compiled spanning tree and loops (rebuilt after any change)."""
        if self._tree is None:
            self._tree = compile_tree(self.joints, self.links, self.ground)
            self._plan = Plan(self, self._tree)
            self._check_mobility()
        return self._tree

    def _loop_rank(self, state) -> np.ndarray:
        """Numerical rank of the dimensionless loop Jacobian at each state ``(B,)``."""
        J = self._scaled_jacobian(self.kinematic_state(state))
        s = np.linalg.svd(J, compute_uv=False)
        return np.sum(s > 1e-8 * np.maximum(s[:, :1], 1e-300), axis=1)

    def _check_mobility(self) -> None:
        """Mobility from the rank of the loop Jacobian at generic poses.

        The rank at the assembly pose can be low when the drawing itself is a
        singular configuration (a parallelogram drawn flat): the rank is therefore
        also taken at a few feasible poses near the assembly (random coordinate
        perturbations projected back onto the loop equations by minimum-norm
        Gauss–Newton), and the largest rank counts.  ``assembly_singular`` says when
        the assembly pose's own rank is below it."""
        t = self._tree
        if not t.chords:                          # open chain (tree): every coordinate is free
            self._mobility, self._singular_assembly = t.nv, False
        else:
            from .solver import project
            q0, rot0 = self.assembly()
            rank0 = int(self._loop_rank((q0, rot0))[0])
            rng = np.random.default_rng(20261122)
            n_try = 4
            dv = rng.normal(size=(n_try, t.nv)) * 1e-3
            from .solver import _apply
            trial = _apply(self, (np.repeat(q0, n_try, 0), np.repeat(rot0, n_try, 0)), dv)
            proj, res = project(self, trial)
            good = res < 1e-10
            ranks = self._loop_rank((proj[0][good], proj[1][good])) if good.any() else []
            rank = max([rank0] + [int(r) for r in ranks])
            self._mobility = t.nv - rank
            self._singular_assembly = rank0 < rank
        if len(self.inputs) > self._mobility:
            self._tree = None
            raise MechanismError(f"{len(self.inputs)} inputs declared but the mechanism's mobility "
                                 f"is {self._mobility}")

    @property
    def mobility(self) -> int:
        """Degrees of freedom (joint coordinates minus the generic rank of the loop
        Jacobian near the assembly pose), idle freedoms such as the spin of an S–S rod
        included."""
        _ = self.tree
        return self._mobility

    @property
    def assembly_singular(self) -> bool:
        """True when the assembly pose is a singular configuration: the loop Jacobian's
        rank there is below its generic rank (e.g. a parallelogram drawn flat)."""
        _ = self.tree
        return self._singular_assembly

    @property
    def n_loops(self) -> int:
        """Number of independent loops."""
        return len(self.tree.chords)

    # ------------------------------------------------------------ state helpers
    def assembly(self):
        """The assembly pose as a one-element state ``(q (1, nq), rot (1, ns, 3, 3))``."""
        t = self.tree
        q = np.concatenate([q for q in self._q0]) if t.nq else np.zeros(0)
        rot = np.array([r for r in self._rot0 if r is not None]).reshape(t.ns, 3, 3)
        return q[None, :], rot[None]

    def input_columns(self) -> np.ndarray:
        """Velocity-coordinate indices of the inputs, in declaration order."""
        return self.plan.input_v.copy()

    def input_q_columns(self) -> np.ndarray:
        """Stored-coordinate indices of the inputs, in declaration order."""
        return self.plan.input_q.copy()

    def unknown_columns(self) -> np.ndarray:
        """Velocity-coordinate indices solved for (all but the inputs); read-only, kept
        with the compiled tree (the solver asks for them at every call)."""
        return self.plan.unknown

    def input_labels(self) -> list[str]:
        """Labels of the inputs (``joint`` or ``joint.coordinate``)."""
        out = []
        for ji, k in self.inputs:
            j = self.joints[ji]
            out.append(j.name if j.nq == 1 else f"{j.name}.{j.coordinate_names[k]}")
        return out

    def coordinate_labels(self) -> list[str]:
        """Column labels of the reported joint coordinates (``joint`` or ``joint.name``)."""
        out = []
        for j in self.joints:
            names = j.coordinate_names
            out += [j.name] if len(names) == 1 else [f"{j.name}.{n}" for n in names]
        return out

    def velocity_labels(self) -> list[str]:
        """Labels of the velocity coordinates (S joints: ``joint.wx, .wy, .wz``, in frame a)."""
        out = []
        for j in self.joints:
            names = ["wx", "wy", "wz"] if j.kind == "S" else j.coordinate_names
            out += [j.name] if len(names) == 1 else [f"{j.name}.{n}" for n in names]
        return out

    # ------------------------------------------------------------ kinematics core
    @property
    def plan(self) -> Plan:
        """The compiled evaluation plan (index arrays and stacked constant frames), built
        with the tree at the first solve and rebuilt after any change."""
        _ = self.tree
        return self._plan

    def kinematic_state(self, state, twists: bool = True) -> KinematicState:
        """Link poses, joint frames and world-frame unit twists for a batch of states.

        Parameters
        ----------
        state : tuple (q (B, nq), rot (B, ns, 3, 3))
        twists : bool
            Also compute the column twists ``S``.

        Returns
        -------
        KinematicState
            ``link`` (B, nlinks, 4, 4), ``frame_a`` (B, njoints, 4, 4) (the world pose of
            each joint's *a* frame), ``A`` (B, njoints, 4, 4), the loop residual ``r``
            (B, nloops, 6), ``S`` (B, nv, 6) world twists of the velocity coordinates,
            ``carrier`` (per column: the index of the link carrying it) and ``deps``.
        """
        q, rot = state
        return self.plan.evaluate(q, rot, twists)

    def _joint_matrices(self, q, rot) -> list:
        """A(q) of every joint, as a list of ``(B, 4, 4)`` arrays."""
        A = self.plan.joint_matrices(q, rot)
        return [A[:, k] for k in range(A.shape[1])]

    def jacobian(self, ks) -> np.ndarray:
        """Loop-closure Jacobian ``(B, 6·nloops, nv)`` in world twists ``(v, ω)``."""
        t = self.tree
        J = np.einsum("lc,bcs->blsc", t.loop_coef, ks.S)
        return J.reshape(J.shape[0], -1, t.nv)

    def _scaled_rows(self, X) -> np.ndarray:
        """World twist rows ``(B, 6·nloops, k)`` → dimensionless rows about the centre.

        Twists are taken about the mechanism's centre (``v + ω × c``) and their
        translation rows divided by its length scale, so that condition numbers,
        convergence tests and flags do not depend on where the world origin is."""
        t = self.tree
        B, k = X.shape[0], X.shape[-1]
        Y = X.reshape(B, -1, 6, k).copy()
        w = Y[:, :, 3:]
        c = t.centre
        Y[:, :, 0] += w[:, :, 1] * c[2] - w[:, :, 2] * c[1]
        Y[:, :, 1] += w[:, :, 2] * c[0] - w[:, :, 0] * c[2]
        Y[:, :, 2] += w[:, :, 0] * c[1] - w[:, :, 1] * c[0]
        Y[:, :, :3] /= t.scale
        return Y.reshape(B, -1, k)

    def _scaled_jacobian(self, ks) -> np.ndarray:
        """Dimensionless Jacobian: twists about the centre, translation rows and length
        columns divided / multiplied by the scale."""
        plan = self.plan
        return plan.scaled_jacobian(ks.S, plan.all_cols)

    def _scaled_residual(self, ks) -> np.ndarray:
        return self.plan.scaled_residual(ks.r)

    # ------------------------------------------------------------ solving
    def solve(self, inputs, guess=None, *, options=None, raise_on_failure: bool = True,
              continuation: bool = True):
        """Solve the loops for one input value or a batch: see :func:`closure.solve`
        (same arguments; returns a :class:`Pose`)."""
        from .solver import solve
        inputs = as_array(inputs, "inputs", finite=False)   # the solver checks shape and values
        if inputs.size == 0:
            raise MechanismError("inputs: empty; expected at least one input value")
        return solve(self, inputs, guess, options=options, raise_on_failure=raise_on_failure,
                     continuation=continuation)

    def sweep(self, values, guess=None, *, options=None, return_pose: bool = False):
        """Continuation along the inputs into a table: see :func:`closure.sweep` (same
        arguments; returns a DataFrame, and the reached poses with ``return_pose=True``)."""
        from .solver import sweep
        values = as_array(values, "values", finite=False)   # the solver checks shape and values
        if values.size == 0:
            raise MechanismError("values: empty; expected at least one input value")
        return sweep(self, values, guess, options=options, return_pose=return_pose)

    def analogs(self, pose, second: bool = True):
        """First- and second-order transfer functions: see :func:`closure.analogs`."""
        from .kinematics import analogs
        return analogs(self, pose, second)

    def velocities(self, pose, rates) -> np.ndarray:
        """Coordinate rates ``(B, nv)`` for input rates ``(B, ni)`` or ``(ni,)``."""
        first, _ = self.analogs(pose, second=False)
        xd = input_rates(rates, "rates", first.shape[:1] + first.shape[2:])
        return np.einsum("bci,bi->bc", first, xd)

    def accelerations(self, pose, rates, accels) -> np.ndarray:
        """Coordinate accelerations ``(B, nv)`` for input rates and accelerations ``(B, ni)``."""
        first, sec = self.analogs(pose)
        shp = first.shape[:1] + first.shape[2:]
        xd, xdd = input_rates(rates, "rates", shp), input_rates(accels, "accels", shp)
        return np.einsum("bci,bi->bc", first, xdd) + np.einsum("bcij,bi,bj->bc", sec, xd, xd)

    def __repr__(self) -> str:
        kinds = "".join(j.kind for j in self.joints)
        return (f"Mechanism({len(self.links)} links, joints {kinds}, "
                f"{len(self.inputs)} inputs)")
