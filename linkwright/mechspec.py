"""Mechanisms described in study files (joints with three-point frames), shared by
``analyze`` and ``approx``."""
from __future__ import annotations

import numpy as np

from closure import JOINT_KINDS, Dynamics, Mechanism, MechanismError, frame_from_points

from .study import Study

__all__ = ["build_mechanism", "build_dynamics", "sweep_values", "joint_frames"]


def joint_frames(sec: Study) -> tuple[dict, dict]:
    """The joint frames ``{name: (4, 4)}`` (ground frame, assembly pose) and kinds
    ``{name: kind}`` of ``[mechanism]``."""
    frames, kinds = {}, {}
    for j in sec.sections("joint"):
        name = j.get("name", "str")
        kinds[name] = j.get("kind", "str", choices=list(JOINT_KINDS))
        try:
            frames[name] = frame_from_points(j.get("origin", "vec3"), j.get("x_point", "vec3"),
                                             j.get("z_point", "vec3"))
        except MechanismError as e:
            raise j.error("", str(e)) from None
    return frames, kinds


def build_mechanism(sec: Study, frames: dict | None = None) -> Mechanism:
    """``[mechanism]`` with ``links``, ``[[mechanism.joint]]`` (name, kind, links = [a, b],
    origin, x_point, z_point, pitch for H) and ``[[mechanism.input]]`` (joint, index);
    ``frames`` (``{joint: (4, 4)}``) replaces the joints' frames (a made mechanism)."""
    m = Mechanism(sec.get("links", "strs"))
    if frames is None:
        frames, _ = joint_frames(sec)
    for j in sec.sections("joint"):
        name = j.get("name", "str")
        kind = j.get("kind", "str", choices=list(JOINT_KINDS))
        la, lb = _pair(j, "links")
        try:
            F = frames[name]
            pitch = j.get("pitch", "float") if kind == "H" else None
            m.add_joint(name, kind, la, lb, at=F, pitch=pitch)
        except MechanismError as e:
            raise j.error("", str(e)) from None
    for inp in sec.sections("input"):
        try:
            m.add_input(inp.get("joint", "str"), inp.get("index", "int", 0, low=0))
        except MechanismError as e:
            raise inp.error("joint", str(e)) from None
    return m


def _pair(sec, key):
    v = sec.get(key, "strs")
    if len(v) != 2:
        raise sec.error(key, f"expected two link names [link_a, link_b], got {v!r}")
    return v


def sweep_values(sec: Study, mech: Mechanism) -> np.ndarray:
    """``[sweep]``: ``from``/``to`` (SI: m or rad) or ``from_deg``/``to_deg`` for angular
    inputs, and ``steps``; one input."""
    if len(mech.inputs) != 1:
        raise sec.error("", f"a sweep drives one input; the mechanism has {len(mech.inputs)}")
    steps = sec.get("steps", "int", low=2, high=100_000)
    if sec.has("from_deg") or sec.has("to_deg"):
        a, b = np.radians(sec.get("from_deg")), np.radians(sec.get("to_deg"))
    else:
        a, b = sec.get("from"), sec.get("to")
    return np.linspace(a, b, steps)


def build_dynamics(sec: Study, mech: Mechanism) -> Dynamics:
    """``[dynamics]``: ``gravity`` and ``[[dynamics.body]]`` (link, mass, com, inertia),
    optional ``[[dynamics.damper]]`` (joint, coefficient) and ``[[dynamics.spring]]``
    (joint, stiffness, free)."""
    d = Dynamics(mech, gravity=sec.get("gravity", "vec3", np.array([0, 0, -9.81])))
    for b in sec.sections("body"):
        try:
            d.add_body(b.get("link", "str"), b.get("mass", low=0.0), b.get("com", "vec3"),
                       b.get("inertia", "matrix", None))
        except MechanismError as e:
            raise b.error("", str(e)) from None
    for k in sec.sections("damper", required=False):
        d.add_damper(k.get("joint", "str"), k.get("coefficient", low=0.0))
    for k in sec.sections("spring", required=False):
        d.add_spring(k.get("joint", "str"), k.get("stiffness", low=0.0), k.get("free", "float", 0.0))
    return d


def coordinate_unit(mech, label: str) -> str:
    """The unit of a joint coordinate label (``joint`` or ``joint.coordinate``, as in
    ``Mechanism.coordinate_labels``): m for a slide (P, the ``s`` of C), rad otherwise."""
    name, _, coord = label.partition(".")
    for j in getattr(mech, "joints", []):
        if j.name == name:
            c = coord or j.coordinate_names[0]
            return "m" if c == "s" else "rad"
    return "rad"
