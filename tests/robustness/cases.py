"""The catalogue of the robustness census (issue 11).

``BAD``: inputs that are wrong (NaN or inf, wrong shapes or types, bools for numbers,
out-of-range choices, non-rigid transforms, bad study files ...).  Each must raise the
package's own error (a ValueError subclass) whose message names ``arg``.

``VALID``: awkward but valid inputs (far from the origin, tiny or huge units, near-singular
but regular poses, batches, integer values for floats ...) whose ``check()`` compares the
answer with an independent reference and returns True when it is right.

Every case works through the public API of closure, synthesis, stiffness, approx and the
``linkwright`` command line (in process, with study files written to a temporary folder).
"""
from __future__ import annotations

import atexit
import contextlib
import io
import json
import math
import shutil
import tempfile
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Callable

import numpy as np

import approx
import closure
import stiffness
import synthesis
from approx import cylinder

__all__ = ["BadCase", "ValidCase", "BAD", "VALID", "CliError", "CliFailure"]

NAN, INF = float("nan"), float("inf")


@dataclass(frozen=True)
class BadCase:
    package: str
    name: str
    call: Callable[[], object]
    arg: str          # the message must name this argument (or study key)


@dataclass(frozen=True)
class ValidCase:
    package: str
    name: str
    check: Callable[[], bool]


BAD: list[BadCase] = []
VALID: list[ValidCase] = []


def bad(package, name, call, arg):
    name = f"{package}.{name}"
    assert not any(c.name == name for c in BAD), name
    BAD.append(BadCase(package, name, call, arg))


def valid(package, name):
    def deco(check, name=name):
        name = f"{package}.{name}"
        assert not any(c.name == name for c in VALID), name
        VALID.append(ValidCase(package, name, check))
        return check
    return deco


# ------------------------------------------------------------------ value variants
def array_variants(good, *, empty=True, bools=True):
    """Bad versions of a good numeric array (label, value)."""
    g = np.array(good, float)
    flat = g.ravel()
    out = []
    for label, v in (("nan", NAN), ("inf", INF), ("-inf", -INF)):
        b = flat.copy()
        b[-1] = v
        out.append((label, b.reshape(g.shape)))
    out += [("str", "abc"), ("None", None), ("dict", {"x": 1.0}),
            ("strs", np.full(g.shape, "a").tolist()),
            ("complex", g + 1j)]
    if g.ndim >= 1:
        out.append(("short", g[..., :-1]))
        r0 = g.reshape(-1, g.shape[-1])[0].tolist()
        out.append(("ragged", [1.0, [1.0, 2.0]] if g.ndim == 1 else [r0, r0 + [1.0]]))
    if empty and g.ndim >= 1:
        out.append(("empty", []))
    if bools:
        out.append(("bool", np.ones(g.shape, bool)))
    return out


def scalar_variants(*, positive=False, nonneg=False, arrays=True):
    out = [("nan", NAN), ("inf", INF), ("-inf", -INF), ("str", "1.0"), ("None", None),
           ("bool", True), ("complex", 1 + 1j), ("dict", {})]
    if arrays:
        out.append(("list", [1.0, 2.0]))
    if positive:
        out += [("zero", 0.0), ("negative", -1.0)]
    elif nonneg:
        out += [("negative", -1.0)]
    return out


def index_variants(high=None):
    out = [("float", 1.5), ("bool", True), ("str", "0"), ("None", None), ("nan", NAN),
           ("negative", -1)]
    if high is not None:
        out.append(("too-large", high))
    return out


def each(package, prefix, fn, args: dict, arg, variants, *, msg=None, kwargs=()):
    """One case per variant of argument ``arg`` of ``fn(**args)``."""
    for label, value in variants:
        def call(fn=fn, args=dict(args), value=value):
            a = dict(args)
            a[arg] = value
            pos = [a.pop(k) for k in list(a) if k not in kwargs]
            return fn(*pos, **a)
        bad(package, f"{prefix}:{arg}={label}", call, msg or arg)


# ------------------------------------------------------------------ shared fixtures
R0 = closure.exp_so3([0.3, -0.2, 0.5])
P0 = np.array([0.1, 0.2, 0.3])
T0 = closure.transform(R0, P0)


def bad_transforms():
    """Transforms with a bad last row, a non-orthonormal or reflected rotation block."""
    lastrow = T0.copy()
    lastrow[3, 0] = 0.5
    scaled = T0.copy()
    scaled[:3, :3] *= 2.0
    shear = T0.copy()
    shear[0, 1] += 0.1
    mirror = T0.copy()
    mirror[:3, 0] *= -1
    return [("last-row", lastrow), ("scaled-R", scaled), ("sheared-R", shear),
            ("reflection", mirror)]


def bad_rotations():
    return [(label, T[:3, :3]) for label, T in bad_transforms()[1:]]


@cache
def fourbar(shift=(0.0, 0.0, 0.0), scale=1.0):
    """The README's four-bar (crank 1, coupler √10, rocker 2, ground 3), optionally moved
    by ``shift`` and scaled by ``scale``; input: joint A."""
    s = np.array(shift)
    m = closure.Mechanism(["crank", "coupler", "rocker"])
    for name, a, b, p in [("A", "ground", "crank", (0, 0, 0)), ("B", "crank", "coupler", (0, 1, 0)),
                          ("C", "coupler", "rocker", (3, 2, 0)), ("D", "ground", "rocker", (3, 0, 0))]:
        m.add_joint(name, "R", a, b, at=closure.translation(s + scale * np.array(p, float)))
    m.add_input("A")
    return m


@cache
def fourbar_pose():
    return fourbar().solve([0.2, 0.4])


@cache
def other_pose():
    return slider_crank().solve(0.1)


@cache
def slider_crank(r=0.1, l=0.35, shift=(0.0, 0.0, 0.0)):
    s = np.array(shift)
    x0 = math.sqrt(l * l - r * r)
    B, C = s + [0.0, r, 0.0], s + [x0, 0.0, 0.0]
    m = closure.Mechanism(["crank", "rod", "slider"])
    m.add_joint("A", "R", "ground", "crank", at=closure.translation(s))
    m.add_joint("B", "R", "crank", "rod", at=closure.translation(B))
    m.add_joint("C", "R", "rod", "slider", at=closure.translation(C))
    m.add_joint("D", "P", "ground", "slider",
                at=closure.frame_from_points(C, C + [0, 1, 0], C + [1, 0, 0]))
    m.add_input("A")
    return m


def slider_s(t, r=0.1, l=0.35):
    t = np.asarray(t, float)
    return -r * np.sin(t) + np.sqrt(l * l - r * r * np.cos(t) ** 2) - math.sqrt(l * l - r * r)


@cache
def dynamics():
    d = closure.Dynamics(fourbar(), gravity=(0.0, -9.81, 0.0))
    d.add_body("crank", 1.0, (0.0, 0.5, 0.0))
    d.add_body("coupler", 3.0, (1.5, 1.5, 0.0))
    d.add_body("rocker", 2.0, (3.0, 1.0, 0.0))
    return d


def cubic():
    return (lambda x: x ** 3, lambda x: 3 * x ** 2, lambda x: 6 * x)


@cache
def analog():
    return approx.fit(*cubic(), 0.0, 1.0, n=4)


@cache
def engine_analogs():
    return approx.EngineAnalogs(cylinder.mechanism(), "A", 0.0, 0.3, offset=cylinder.f3(0.0),
                                sign=-1.0, samples=9)


@cache
def hexapod():
    a = np.radians([0, 100, 120, 220, 240, 340])
    b = np.radians([40, 80, 160, 200, 280, 320])
    base = np.c_[0.8 * np.cos(a), 0.8 * np.sin(a), np.zeros(6)]
    plat = np.c_[0.4 * np.cos(b), 0.4 * np.sin(b), np.zeros(6)]
    return stiffness.Hexapod(base, plat, 2e7)


HEX_POSE = closure.transform(closure.exp_so3([0.05, -0.03, 0.1]), [0.02, -0.01, 0.7])
K0 = stiffness.stiffness_matrix(np.random.default_rng(1).normal(size=(6, 6)), np.arange(1.0, 7.0))

SEED = [synthesis.Screw.from_degrees([0, 0, 1], [0, 0, 0], 30, 0.7),
        synthesis.Screw.from_degrees([0.34202, 0, 0.939693], [0, 1.1, 0], 65, 0.5),
        synthesis.Screw.from_degrees([0.66, 0.043589, 0.75], [0.25, 1.2, -0.289742], 75, 0.3)]


# ================================================================== closure: bad inputs
C = "closure"
for fname, arg, good in [("skew", "p", P0), ("hat", "xi", np.arange(6.0)), ("vee", "X", closure.hat(np.arange(6.0))),
                         ("exp_so3", "w", P0), ("log_so3", "R", R0), ("exp_se3", "xi", np.arange(6.0) / 10),
                         ("log_se3", "T", T0), ("translation", "p", P0), ("inverse", "T", T0),
                         ("adjoint", "T", T0), ("ad", "xi", np.arange(6.0)), ("euler_zxz", "R", R0)]:
    each(C, fname, getattr(closure, fname), {arg: good}, arg, array_variants(good, empty=True))
for fname, arg in [("inverse", "T"), ("log_se3", "T"), ("adjoint", "T")]:
    each(C, fname, getattr(closure, fname), {arg: T0}, arg, bad_transforms())
for fname in ("log_so3", "euler_zxz"):
    each(C, fname, getattr(closure, fname), {"R": R0}, "R", bad_rotations())
def no(variants, *labels):
    """``variants`` without those labelled ``labels`` (valid for that argument)."""
    return [(k, v) for k, v in variants if k not in labels]


each(C, "transform", closure.transform, {"R": R0, "p": P0}, "R",
     no(array_variants(R0), "None") + bad_rotations())
each(C, "transform", closure.transform, {"R": R0, "p": P0}, "p", no(array_variants(P0), "None"))
each(C, "cross", closure.cross, {"a": P0, "b": P0[::-1]}, "a", array_variants(P0))
each(C, "cross", closure.cross, {"a": P0, "b": P0[::-1]}, "b", array_variants(P0)[:5])
each(C, "rotation", closure.rotation, {"axis": [0.0, 0.0, 1.0], "angle": 0.3}, "axis",
     array_variants([0.0, 0.0, 1.0]) + [("zero", [0.0, 0.0, 0.0])])
each(C, "rotation", closure.rotation, {"axis": [0.0, 0.0, 1.0], "angle": 0.3}, "angle",
     scalar_variants(arrays=False))
for fname in ("rot_x", "rot_y", "rot_z"):
    each(C, fname, getattr(closure, fname), {"angle": 0.3}, "angle", scalar_variants(arrays=False))
for arg in ("origin", "x_point", "z_point"):
    good = {"origin": [0.0, 0.0, 0.0], "x_point": [1.0, 0.0, 0.0], "z_point": [0.0, 0.0, 1.0]}
    each(C, "frame_from_points", closure.frame_from_points, good, arg,
         array_variants(good[arg])[:9])
bad(C, "frame_from_points:collinear",
    lambda: closure.frame_from_points([0, 0, 0], [0, 0, 2.0], [0, 0, 1.0]), "x_point")
each(C, "pseudo_inertia", closure.pseudo_inertia,
     {"mass": 1.0, "com": P0, "inertia": np.eye(3)}, "mass", scalar_variants(positive=True))
each(C, "pseudo_inertia", closure.pseudo_inertia,
     {"mass": 1.0, "com": P0, "inertia": np.eye(3)}, "com", array_variants(P0)[:9])
each(C, "pseudo_inertia", closure.pseudo_inertia,
     {"mass": 1.0, "com": P0, "inertia": np.eye(3)}, "inertia",
     array_variants(np.eye(3))[:9] + [("asymmetric", np.eye(3) + np.triu(np.ones((3, 3)), 1)),
                                      ("negative", -np.eye(3))])


bad(C, "Mechanism:links=str", lambda: closure.Mechanism("crank"), "links")
bad(C, "Mechanism:links=int", lambda: closure.Mechanism(5), "links")
bad(C, "Mechanism:links=None", lambda: closure.Mechanism(None), "links")
bad(C, "Mechanism:links=ints", lambda: closure.Mechanism([1, 2]), "links")
bad(C, "Mechanism:links=dup", lambda: closure.Mechanism(["a", "a"]), "links")
bad(C, "Mechanism:links=ground", lambda: closure.Mechanism(["ground"]), "links")
bad(C, "Mechanism:ground=None", lambda: closure.Mechanism(["a"], None), "ground")
bad(C, "Mechanism:ground=empty", lambda: closure.Mechanism(["a"], ""), "ground")
bad(C, "Mechanism:ground=int", lambda: closure.Mechanism(["a"], 3), "ground")
bad(C, "add_link:name=None", lambda: closure.Mechanism(["a"]).add_link(None), "name")
bad(C, "add_link:name=empty", lambda: closure.Mechanism(["a"]).add_link(""), "name")
bad(C, "add_link:name=int", lambda: closure.Mechanism(["a"]).add_link(3), "name")
bad(C, "add_link:name=dup", lambda: closure.Mechanism(["a"]).add_link("a"), "link")


def _add_joint(**kw):
    m = closure.Mechanism(["a", "b"])
    a = dict(name="J", kind="R", link_a="ground", link_b="a", at=np.eye(4))
    a.update(kw)
    return m.add_joint(a.pop("name"), a.pop("kind"), a.pop("link_a"), a.pop("link_b"), a.pop("at"), **a)


for label, v in [("None", None), ("empty", ""), ("int", 3)]:
    bad(C, f"add_joint:name={label}", lambda v=v: _add_joint(name=v), "name")
for label, v in [("unknown", "X"), ("None", None), ("lower", "r"), ("int", 1), ("list", ["R"])]:
    bad(C, f"add_joint:kind={label}", lambda v=v: _add_joint(kind=v), "kind")
for label, v in [("unknown", "nope"), ("None", None), ("int", 0)]:
    bad(C, f"add_joint:link_a={label}", lambda v=v: _add_joint(link_a=v), "link_a")
    bad(C, f"add_joint:link_b={label}", lambda v=v: _add_joint(link_b=v), "link_b")
bad(C, "add_joint:link_b=same", lambda: _add_joint(link_b="ground"), "link_b")
for label, v in array_variants(np.eye(4))[:9] + bad_transforms() + [("3x3", np.eye(3)),
                                                                    ("3-pair", np.stack([np.eye(4)] * 3))]:
    bad(C, f"add_joint:at={label}", lambda v=v: _add_joint(at=v), "at")
pair_bad = np.stack([np.eye(4), bad_transforms()[1][1]])
bad(C, "add_joint:at=pair-scaled", lambda: _add_joint(at=pair_bad), "at")
for label, v in scalar_variants(arrays=True):
    bad(C, f"add_joint:pitch={label}", lambda v=v: _add_joint(kind="H", pitch=v), "pitch")
bad(C, "add_joint:pitch=missing", lambda: _add_joint(kind="H"), "pitch")
bad(C, "add_joint:pitch=on-R", lambda: _add_joint(kind="R", pitch=0.1), "pitch")
bad(C, "add_joint:validate=str", lambda: _add_joint(validate="no"), "validate")


def _add_input(joint="A", index=0):
    m = closure.Mechanism(["a"])
    m.add_joint("A", "U", "ground", "a", at=np.eye(4))
    m.add_joint("S", "S", "ground", "a", at=np.eye(4)) if joint == "S" else None
    m.add_input(joint, index)


for label, v in [("unknown", "nope"), ("None", None), ("int", 1), ("spherical", "S")]:
    bad(C, f"add_input:joint={label}", lambda v=v: _add_input(joint=v), "joint")
for label, v in index_variants(high=2):
    bad(C, f"add_input:index={label}", lambda v=v: _add_input(index=v), "index")


def _fresh_fourbar():
    m = closure.Mechanism(["crank", "coupler", "rocker"])
    for name, a, b, p in [("A", "ground", "crank", (0, 0, 0)), ("B", "crank", "coupler", (0, 1, 0)),
                          ("C", "coupler", "rocker", (3, 2, 0)), ("D", "ground", "rocker", (3, 0, 0))]:
        m.add_joint(name, "R", a, b, at=closure.translation(p))
    return m


bad(C, "add_input:joint=twice", lambda: (lambda m: (m.add_input("A"), m.add_input("A")))(
    _fresh_fourbar()), "A")
bad(C, "add_input:too-many", lambda: (lambda m: (m.add_input("A"), m.add_input("B"), m.solve([0.1, 0.1])))(
    _fresh_fourbar()), "inputs")
bad(C, "solve:no-inputs", lambda: _fresh_fourbar().solve(0.1), "inputs")
bad(C, "joint:name=unknown", lambda: fourbar().joint("nope"), "joint")
bad(C, "joint:name=None", lambda: fourbar().joint(None), "joint")

for meth, arg in (("solve", "inputs"), ("sweep", "values")):
    for label, v in no(array_variants([0.1, 0.2], empty=True), "short") + [("2d-wide", np.zeros((2, 2))),
                                                              ("3d", np.zeros((2, 1, 1)))]:
        bad(C, f"{meth}:{arg}={label}", lambda meth=meth, v=v: getattr(fourbar(), meth)(v), arg)
    for label, v in [("str", "pose"), ("int", 3), ("other-mechanism", None)]:
        bad(C, f"{meth}:guess={label}",
            lambda meth=meth, v=v: getattr(fourbar(), meth)([0.1], v if v is not None else other_pose()),
            "guess")
    for label, v in [("str", "fast"), ("dict", {"xtol": 1e-9})]:
        bad(C, f"{meth}:options={label}", lambda meth=meth, v=v: getattr(fourbar(), meth)([0.1], options=v),
            "options")
bad(C, "solve:raise_on_failure=str", lambda: fourbar().solve([0.1], raise_on_failure="no"),
    "raise_on_failure")
bad(C, "solve:continuation=str", lambda: fourbar().solve([0.1], continuation="no"), "continuation")
bad(C, "sweep:return_pose=str", lambda: fourbar().sweep([0.1], return_pose="yes"), "return_pose")
for arg in ("xtol", "rtol", "max_step", "cond_limit", "path_step"):
    for label, v in scalar_variants(positive=True, arrays=True):
        bad(C, f"SolverOptions:{arg}={label}", lambda arg=arg, v=v: closure.SolverOptions(**{arg: v}), arg)
for label, v in [("float", 1.5), ("bool", True), ("zero", 0), ("negative", -3), ("str", "10"),
                 ("nan", NAN), ("None", None)]:
    bad(C, f"SolverOptions:maxiter={label}", lambda v=v: closure.SolverOptions(maxiter=v), "maxiter")
bad(C, "SolverOptions.replace:xtol=nan", lambda: closure.SolverOptions().replace(xtol=NAN), "xtol")

for label, v in [("None", None), ("str", "pose"), ("other-mechanism", "other")]:
    def _p(v=v):
        return other_pose() if v == "other" else v
    bad(C, f"analogs:pose={label}", lambda _p=_p: fourbar().analogs(_p()), "pose")
    bad(C, f"velocities:pose={label}", lambda _p=_p: fourbar().velocities(_p(), [1.0]), "pose")
    bad(C, f"joint_analogs:pose={label}", lambda _p=_p: closure.joint_analogs(fourbar(), _p(), "D"), "pose")
    bad(C, f"point_analogs:pose={label}",
        lambda _p=_p: closure.point_analogs(fourbar(), _p(), "coupler", P0), "pose")
bad(C, "analogs:second=str", lambda: fourbar().analogs(fourbar_pose(), second="no"), "second")
for label, v in array_variants([[1.0], [1.0]], empty=True, bools=True) + [("wide", np.ones((2, 3)))]:
    bad(C, f"velocities:rates={label}", lambda v=v: fourbar().velocities(fourbar_pose(), v), "rates")
    bad(C, f"accelerations:accels={label}",
        lambda v=v: fourbar().accelerations(fourbar_pose(), [1.0], v), "accels")
bad(C, "accelerations:rates=nan",
    lambda: fourbar().accelerations(fourbar_pose(), [NAN], [0.0]), "rates")
for label, v in [("unknown", "nope"), ("None", None), ("int", 3)]:
    bad(C, f"joint_analogs:joint={label}", lambda v=v: closure.joint_analogs(fourbar(), fourbar_pose(), v),
        "joint")
for label, v in index_variants(high=1):
    bad(C, f"joint_analogs:index={label}",
        lambda v=v: closure.joint_analogs(fourbar(), fourbar_pose(), "D", index=v), "index")
    bad(C, f"joint_analogs:input={label}",
        lambda v=v: closure.joint_analogs(fourbar(), fourbar_pose(), "D", input=v), "input")
for label, v in [("unknown", "nope"), ("None", None), ("int", 0)]:
    bad(C, f"point_analogs:link={label}",
        lambda v=v: closure.point_analogs(fourbar(), fourbar_pose(), v, P0), "link")
    bad(C, f"Pose.point:link={label}", lambda v=v: fourbar_pose().point(v, P0), "link")
    bad(C, f"Pose.link_frame:link={label}", lambda v=v: fourbar_pose().link_frame(v), "link")
    bad(C, f"Pose[]:name={label}", lambda v=v: fourbar_pose()[v], "joint")
for label, v in array_variants(P0)[:10]:
    bad(C, f"point_analogs:xyz={label}",
        lambda v=v: closure.point_analogs(fourbar(), fourbar_pose(), "coupler", v), "xyz")
    bad(C, f"Pose.point:xyz={label}", lambda v=v: fourbar_pose().point("coupler", v), "xyz")
bad(C, "Pose.rotation:name=R-joint", lambda: fourbar_pose().rotation("A"), "A")

# dynamics
for label, v in array_variants([0.0, -9.81, 0.0])[:10]:
    bad(C, f"Dynamics:gravity={label}", lambda v=v: closure.Dynamics(fourbar(), gravity=v), "gravity")
for label, v in [("str", "m"), ("None", None)]:
    bad(C, f"Dynamics:mechanism={label}", lambda v=v: closure.Dynamics(v), "mechanism")


def _body(**kw):
    d = closure.Dynamics(fourbar())
    a = dict(link="crank", mass=1.0, com=(0.0, 0.5, 0.0), inertia=None)
    a.update(kw)
    return d.add_body(**a)


for label, v in [("unknown", "nope"), ("ground", "ground"), ("None", None), ("int", 1)]:
    bad(C, f"add_body:link={label}", lambda v=v: _body(link=v), "link")
for label, v in scalar_variants(positive=True):
    bad(C, f"add_body:mass={label}", lambda v=v: _body(mass=v), "mass")
for label, v in array_variants([0.0, 0.5, 0.0])[:10]:
    bad(C, f"add_body:com={label}", lambda v=v: _body(com=v), "com")
for label, v in no(array_variants(np.eye(3) * 0.1)[:10], "None") + [("negative", -np.eye(3)),
                                                       ("asymmetric", np.eye(3) + np.triu(np.ones((3, 3)), 1))]:
    bad(C, f"add_body:inertia={label}", lambda v=v: _body(inertia=v), "inertia")


def _dyn_call(method, **kw):
    d = closure.Dynamics(fourbar())
    return getattr(d, method)(**kw)


for label, v in [("unknown", "nope"), ("None", None)]:
    bad(C, f"add_spring:joint={label}", lambda v=v: _dyn_call("add_spring", joint=v, stiffness=1.0), "joint")
    bad(C, f"add_damper:joint={label}", lambda v=v: _dyn_call("add_damper", joint=v, coefficient=1.0), "joint")
    bad(C, f"add_force:joint={label}", lambda v=v: _dyn_call("add_force", joint=v, func=lambda t, q, qd: 0.0),
        "joint")
for label, v in scalar_variants(nonneg=True, arrays=True):
    bad(C, f"add_spring:stiffness={label}", lambda v=v: _dyn_call("add_spring", joint="A", stiffness=v),
        "stiffness")
    bad(C, f"add_damper:coefficient={label}",
        lambda v=v: _dyn_call("add_damper", joint="A", coefficient=v), "coefficient")
for label, v in scalar_variants(arrays=True)[:8]:
    bad(C, f"add_spring:free={label}", lambda v=v: _dyn_call("add_spring", joint="A", stiffness=1.0, free=v),
        "free")
for label, v in index_variants(high=1):
    bad(C, f"add_spring:index={label}",
        lambda v=v: _dyn_call("add_spring", joint="A", stiffness=1.0, index=v), "index")
for label, v in [("int", 3), ("str", "f"), ("None", None)]:
    bad(C, f"add_force:func={label}", lambda v=v: _dyn_call("add_force", joint="A", func=v), "func")
bad(C, "Dynamics.inverse:x=rows-mismatch",
    lambda: dynamics().inverse([0.0], [[0.1], [0.2]], [[0.0], [0.0]], [[0.0], [0.0]]), "x")
for arg, good in (("t", [0.0, 0.1]), ("x", [[0.1], [0.2]])):
    for label, v in no(array_variants(good, empty=False), "short" if arg == "t" else ""):
        def _inv(arg=arg, v=v):
            kw = {"t": [0.0, 0.1], "x": [[0.1], [0.2]]}
            kw[arg] = v
            return dynamics().inverse(kw["t"], kw["x"], [[0.0], [0.0]], [[0.0], [0.0]])
        bad(C, f"Dynamics.inverse:{arg}={label}", _inv, arg)
for label, v in [("nan", [0.0, NAN]), ("reversed", [1.0, 0.0]), ("str", "ab"), ("scalar", 1.0),
                 ("three", [0.0, 1.0, 2.0]), ("None", None)]:
    bad(C, f"Dynamics.simulate:t_span={label}",
        lambda v=v: dynamics().simulate(v, [0.1], [0.0]), "t_span")
for label, v in array_variants([0.1], empty=True)[:9]:
    bad(C, f"Dynamics.simulate:x0={label}", lambda v=v: dynamics().simulate([0, 0.1], v, [0.0]), "x0")
    bad(C, f"Dynamics.simulate:xd0={label}", lambda v=v: dynamics().simulate([0, 0.1], [0.1], v), "xd0")
bad(C, "Dynamics.simulate:method=unknown",
    lambda: dynamics().simulate([0, 0.1], [0.1], [0.0], method="nope"), "method")
bad(C, "Dynamics.simulate:drive=int", lambda: dynamics().simulate([0, 0.1], [0.1], [0.0], drive=3), "drive")
for label, v in [("nan", NAN), ("negative", -1.0), ("str", "x")]:
    bad(C, f"Dynamics.simulate:rtol={label}",
        lambda v=v: dynamics().simulate([0, 0.1], [0.1], [0.0], rtol=v), "rtol")
bad(C, "Dynamics.energy:xd=nan", lambda: dynamics().energy(fourbar_pose(), [[NAN], [0.0]]), "xd")


# ================================================================== approx: bad inputs
A = "approx"
F3 = cubic()
fit_good = dict(f=F3[0], df=F3[1], d2f=F3[2], a=0.0, b=1.0)
for arg in ("f", "df", "d2f"):
    for label, v in [("int", 3), ("str", "x**3"), ("None", None)]:
        each(A, "fit", approx.fit, dict(fit_good, n=4), arg, [(label, v)], kwargs=("n",))
bad(A, "fit:d2f=returns-str", lambda: approx.fit(F3[0], F3[1], lambda x: "a", 0.0, 1.0, n=2), "d2f")
bad(A, "fit:d2f=returns-nan", lambda: approx.fit(F3[0], F3[1], lambda x: x * NAN, 0.0, 1.0, n=2), "d2f")
bad(A, "fit:f=returns-nan", lambda: approx.fit(lambda x: x * NAN, F3[1], F3[2], 0.0, 1.0, n=2), "f")
bad(A, "fit:df=returns-inf", lambda: approx.fit(F3[0], lambda x: x * INF, F3[2], 0.0, 1.0, n=2), "df")
for arg in ("a", "b"):
    each(A, "fit", approx.fit, dict(fit_good, n=4), arg, scalar_variants(arrays=True), kwargs=("n",))
bad(A, "fit:b=equal-a", lambda: approx.fit(*F3, 1.0, 1.0, n=2), "b")
bad(A, "fit:b<a", lambda: approx.fit(*F3, 1.0, 0.0, n=2), "b")
each(A, "fit", approx.fit, dict(fit_good, delta=1e-3), "delta", scalar_variants(positive=True),
     kwargs=("delta",))
each(A, "fit", approx.fit, dict(fit_good, n=4, gamma=1.0), "gamma", no(scalar_variants(positive=True), "None"),
     kwargs=("n", "gamma"))
each(A, "fit", approx.fit, dict(fit_good, n=4), "n",
     index_variants(high=approx.MAX_N + 1) + [("zero", 0), ("str-int", "4")], kwargs=("n",))
each(A, "fit", approx.fit, dict(fit_good, knots=[0.0, 0.5, 1.0]), "knots",
     array_variants([0.0, 0.5, 1.0], empty=True) +
     [("decreasing", [1.0, 0.5, 0.0]), ("repeated", [0.0, 0.5, 0.5, 1.0]), ("one", [0.0]),
      ("2d", [[0.0, 0.5, 1.0]]), ("not-spanning", [0.0, 0.5]), ("outside", [-1.0, 0.5, 1.0])],
     kwargs=("knots",))
for label, v in [("str", "yes"), ("int", 1), ("None", None)]:
    bad(A, f"fit:extrapolate={label}", lambda v=v: approx.fit(*F3, 0.0, 1.0, n=2, extrapolate=v), "extrapolate")
bad(A, "fit:none-of-delta-knots-n", lambda: approx.fit(*F3, 0.0, 1.0), "delta")
bad(A, "fit:delta-and-n", lambda: approx.fit(*F3, 0.0, 1.0, n=2, delta=0.1), "delta")
ls_good = dict(f=F3[0], df=F3[1], d2f=F3[2], knots=[0.0, 0.5, 1.0])
each(A, "fit_least_squares", approx.fit_least_squares, ls_good, "knots",
     no(array_variants([0.0, 0.5, 1.0], empty=True), "short") + [("decreasing", [1.0, 0.5, 0.0]),
                                                                 ("one", [0.0])])
each(A, "fit_least_squares", approx.fit_least_squares, dict(ls_good, gamma=1.0), "gamma",
     no(scalar_variants(positive=True), "None"), kwargs=("gamma",))
for arg in ("end_conditions", "extrapolate"):
    for label, v in [("str", "yes"), ("int", 1), ("None", None)]:
        bad(A, f"fit_least_squares:{arg}={label}",
            lambda arg=arg, v=v: approx.fit_least_squares(*F3, [0.0, 0.5, 1.0], **{arg: v}), arg)
bad(A, "fit_least_squares:f=int", lambda: approx.fit_least_squares(3, F3[1], F3[2], [0.0, 1.0]), "f")
for arg in ("a", "b"):
    each(A, "default_gamma", approx.default_gamma, dict(d2f=F3[2], a=0.0, b=1.0), arg,
         scalar_variants(arrays=True)[:9])
each(A, "default_gamma", approx.default_gamma, dict(d2f=F3[2], a=0.0, b=1.0, samples=101), "samples",
     index_variants() + [("zero", 0), ("one", 1)], kwargs=("samples",))
bad(A, "default_gamma:d2f=str", lambda: approx.default_gamma("6x", 0.0, 1.0), "d2f")
for meth in ("position", "velocity", "acceleration"):
    for label, v in no(array_variants([0.2, 0.5], bools=True), "short", "empty") + [("outside", 1.5), ("below", -0.5),
                                                                   ("obj", np.array([object()]))]:
        bad(A, f"PiecewiseAnalog.{meth}:x={label}", lambda meth=meth, v=v: getattr(analog(), meth)(v), "x")
    for label, v in [("nan", NAN), ("outside", 0.5), ("str", "a"), ("None", None)]:
        bad(A, f"EngineAnalogs.{meth}:x={label}",
            lambda meth=meth, v=v: getattr(engine_analogs(), meth)(v), "x")
for arg in ("x", "xd", "xdd"):
    for label, v in [("nan", NAN), ("inf", INF), ("str", "a"), ("None", None), ("complex", 1j)]:
        def _force(arg=arg, v=v):
            kw = dict(x=0.5, xd=1.0, xdd=0.0, mass_moment=2.0)
            kw[arg] = v
            return analog().force(**kw)
        bad(A, f"PiecewiseAnalog.force:{arg}={label}", _force, arg)
bad(A, "PiecewiseAnalog.force:shapes", lambda: analog().force([0.1, 0.2], [1.0, 1.0, 1.0], 0.0, 1.0), "xd")
for label, v in scalar_variants(nonneg=True):
    bad(A, f"PiecewiseAnalog.force:mass_moment={label}", lambda v=v: analog().force(0.5, 1.0, 0.0, v),
        "mass_moment")
for label, v in index_variants() + [("one", 1)]:
    bad(A, f"PiecewiseAnalog.errors:samples={label}", lambda v=v: analog().errors(*F3, samples=v), "samples")
bad(A, "PiecewiseAnalog.errors:f=str", lambda: analog().errors("f", F3[1], F3[2]), "f")
fv_good = dict(knots=[0.0, 0.5, 1.0], y=[0.0, 3.0, 6.0], f_a=0.0, df_a=0.0)
for arg in ("knots", "y"):
    each(A, "PiecewiseAnalog.from_values", approx.PiecewiseAnalog.from_values, fv_good, arg,
         array_variants(fv_good[arg], empty=True)[:11] + [("decreasing" if arg == "knots" else "long",
                                                           [1.0, 0.5, 0.0] if arg == "knots" else [0.0, 1.0, 2.0, 3.0])])
for arg in ("f_a", "df_a"):
    each(A, "PiecewiseAnalog.from_values", approx.PiecewiseAnalog.from_values, fv_good, arg,
         scalar_variants(arrays=True))
each(A, "PiecewiseAnalog.from_values", approx.PiecewiseAnalog.from_values, dict(fv_good, gamma=1.0),
     "gamma", scalar_variants(positive=True), kwargs=("gamma",))


def _engine(**kw):
    a = dict(mechanism=cylinder.mechanism(), joint="A", a=0.0, b=0.3)
    a.update(kw)
    return approx.EngineAnalogs(a.pop("mechanism"), a.pop("joint"), a.pop("a"), a.pop("b"),
                                samples=5, **a)


for label, v in [("str", "m"), ("None", None), ("two-inputs", "2in")]:
    def _m(v=v):
        if v == "2in":
            m = _fresh_fourbar()
            m.add_input("A")
            m.add_input("B")
            return m
        return v
    bad(A, f"EngineAnalogs:mechanism={label}", lambda _m=_m: _engine(mechanism=_m()), "mechanism")
for label, v in [("unknown", "nope"), ("None", None), ("int", 1)]:
    bad(A, f"EngineAnalogs:joint={label}", lambda v=v: _engine(joint=v), "joint")
for arg in ("a", "b"):
    for label, v in scalar_variants(arrays=True):
        bad(A, f"EngineAnalogs:{arg}={label}", lambda arg=arg, v=v: _engine(**{arg: v}), arg)
bad(A, "EngineAnalogs:b<a", lambda: _engine(a=0.3, b=0.0), "b")
for label, v in index_variants(high=1):
    bad(A, f"EngineAnalogs:index={label}", lambda v=v: _engine(index=v), "index")
for arg in ("offset", "sign"):
    for label, v in scalar_variants(arrays=True):
        bad(A, f"EngineAnalogs:{arg}={label}", lambda arg=arg, v=v: _engine(**{arg: v}), arg)
bad(A, "EngineAnalogs:sign=zero", lambda: _engine(sign=0.0), "sign")
for label, v in index_variants() + [("one", 1)]:
    bad(A, f"EngineAnalogs:samples={label}",
        lambda v=v: approx.EngineAnalogs(cylinder.mechanism(), "A", 0.0, 0.3, samples=v), "samples")
for label, v in [("str", "tf"), ("None", None), ("function", lambda x: x)]:
    bad(A, f"TransferDynamics:transfer={label}", lambda v=v: approx.TransferDynamics(v, 1.0), "transfer")
for label, v in scalar_variants(positive=True):
    bad(A, f"TransferDynamics:inertia={label}", lambda v=v: approx.TransferDynamics(analog(), v), "inertia")
bad(A, "TransferDynamics:load=int", lambda: approx.TransferDynamics(analog(), 1.0, load=3), "load")


def _td():
    return approx.TransferDynamics(analog(), 2.0)


for label, v in [("nan", [0.0, NAN]), ("str", "ab"), ("scalar", 1.0),
                 ("three", [0.0, 1.0, 2.0]), ("None", None), ("inf", [0.0, INF])]:
    bad(A, f"TransferDynamics.simulate:t_span={label}",
        lambda v=v: _td().simulate(v, 0.5, 0.0, lambda t, x, xd: 0.0), "t_span")
for arg in ("x0", "xd0"):
    for label, v in scalar_variants(arrays=True):
        def _sim(arg=arg, v=v):
            kw = dict(x0=0.5, xd0=0.0)
            kw[arg] = v
            return _td().simulate([0.0, 0.1], kw["x0"], kw["xd0"], lambda t, x, xd: 0.0)
        bad(A, f"TransferDynamics.simulate:{arg}={label}", _sim, arg)
bad(A, "TransferDynamics.simulate:x0=outside", lambda: _td().simulate([0, 0.1], 1.5, 0.0, lambda t, x, xd: 0.0),
    "x0")
bad(A, "TransferDynamics.simulate:drive=int", lambda: _td().simulate([0, 0.1], 0.5, 0.0, 3), "drive")
bad(A, "TransferDynamics.simulate:method=unknown",
    lambda: _td().simulate([0, 0.1], 0.5, 0.0, lambda t, x, xd: 0.0, method="nope"), "method")
for arg in ("rtol", "atol"):
    for label, v in [("nan", NAN), ("negative", -1.0), ("str", "x")]:
        bad(A, f"TransferDynamics.simulate:{arg}={label}",
            lambda arg=arg, v=v: _td().simulate([0, 0.1], 0.5, 0.0, lambda t, x, xd: 0.0, **{arg: v}), arg)
bad(A, "TransferDynamics.simulate:t_eval=outside",
    lambda: _td().simulate([0, 0.1], 0.5, 0.0, lambda t, x, xd: 0.0, t_eval=[0.0, 5.0]), "t_eval")
bad(A, "TransferDynamics.simulate:t_eval=nan",
    lambda: _td().simulate([0, 0.1], 0.5, 0.0, lambda t, x, xd: 0.0, t_eval=[0.0, NAN]), "t_eval")
for arg in ("x", "xd", "xdd"):
    bad(A, f"TransferDynamics.drive:{arg}=nan",
        lambda arg=arg: _td().drive(0.0, **{"x": 0.5, "xd": 1.0, "xdd": 0.0, arg: NAN}), arg)
bad(A, "TransferDynamics.drive:t=nan", lambda: approx.TransferDynamics(
    analog(), 1.0, load=lambda t, x, xd: 0.0).drive(NAN, 0.5, 1.0, 0.0), "t")
for label, v in [("unknown", "rms"), ("int", 1), ("None", None)]:
    bad(A, f"fit:sigma_rule={label}", lambda v=v: approx.fit(*F3, 0.0, 1.0, n=2, sigma_rule=v),
        "sigma_rule")
# the surrogate family (issue 16): fit_spline, fit_chebyshev, choose and the analogs
sp_good = dict(f=F3[0], df=F3[1], d2f=F3[2], a=0.0, b=1.0)
for fname, fn, extra in (("fit_spline", approx.fit_spline, dict(n=4)),
                         ("fit_chebyshev", approx.fit_chebyshev, dict(degree=4)),
                         ("choose", approx.choose, dict(tol=1e-3))):
    kw = tuple(extra)
    for arg in ("f", "df", "d2f"):
        each(A, fname, fn, dict(sp_good, **extra), arg, [("int", 3), ("str", "x**3"), ("None", None)],
             kwargs=kw)
    for arg in ("a", "b"):
        each(A, fname, fn, dict(sp_good, **extra), arg, scalar_variants(arrays=True), kwargs=kw)
    bad(A, f"{fname}:b<a", lambda fn=fn, extra=extra: fn(*F3, 1.0, 0.0, **extra), "b")
    bad(A, f"{fname}:d2f=returns-nan",
        lambda fn=fn, extra=extra: fn(F3[0], F3[1], lambda x: x * NAN, 0.0, 1.0, **extra), "d2f")
for fname, fn, extra in (("fit_spline", approx.fit_spline, dict(n=4)),
                         ("fit_chebyshev", approx.fit_chebyshev, dict(degree=4))):
    for label, v in [("str", "yes"), ("int", 1), ("None", None)]:
        bad(A, f"{fname}:extrapolate={label}",
            lambda fn=fn, extra=extra, v=v: fn(*F3, 0.0, 1.0, extrapolate=v, **extra), "extrapolate")
each(A, "fit_spline", approx.fit_spline, dict(sp_good, n=4), "n",
     index_variants(high=approx.MAX_N + 1) + [("zero", 0), ("str-int", "4")], kwargs=("n",))
each(A, "fit_spline", approx.fit_spline, dict(sp_good, knots=[0.0, 0.5, 1.0]), "knots",
     array_variants([0.0, 0.5, 1.0], empty=True) +
     [("decreasing", [1.0, 0.5, 0.0]), ("one", [0.0]), ("not-spanning", [0.0, 0.5])],
     kwargs=("knots",))
bad(A, "fit_spline:none-of-n-knots", lambda: approx.fit_spline(*F3, 0.0, 1.0), "knots")
bad(A, "fit_spline:n-and-knots", lambda: approx.fit_spline(*F3, 0.0, 1.0, n=2, knots=[0.0, 1.0]), "n")
for label, v in [("unknown", "periodic"), ("int", 1), ("None", None)]:
    bad(A, f"fit_spline:bc={label}", lambda v=v: approx.fit_spline(*F3, 0.0, 1.0, n=2, bc=v), "bc")
each(A, "fit_chebyshev", approx.fit_chebyshev, dict(sp_good, degree=4), "degree",
     index_variants(high=approx.MAX_DEGREE + 1) + [("str-int", "4")], kwargs=("degree",))
each(A, "choose", approx.choose, dict(sp_good, tol=1e-3), "tol", scalar_variants(positive=True),
     kwargs=("tol",))
for arg, vs in (("target", [("unknown", "speed"), ("int", 1), ("None", None)]),
                ("cost", [("unknown", "money"), ("int", 1), ("None", None)]),
                ("kinds", [("unknown", ["pade"]), ("empty", []), ("int", 3), ("None", None),
                           ("repeated", ["spline", "spline"])]),
                ("samples", index_variants() + [("one", 1), ("too-large", 10 ** 7)])):
    each(A, "choose", approx.choose, dict(sp_good, tol=1e-3), arg, vs, kwargs=("tol", arg))
bad(A, "choose:tol=unreachable",
    lambda: approx.choose(np.sin, np.cos, lambda x: -np.sin(x), 0.0, 50.0, tol=1e-30,
                          kinds=["chebyshev"]), "tol")


@cache
def _spline():
    return approx.fit_spline(*cubic(), 0.0, 1.0, n=4)


@cache
def _cheb():
    return approx.fit_chebyshev(*cubic(), 0.0, 1.0, degree=4)


for cname, make in (("SplineAnalog", _spline), ("ChebyshevAnalog", _cheb)):
    for meth in ("position", "velocity", "acceleration", "all"):
        for label, v in no(array_variants([0.2, 0.5], bools=True), "short", "empty") + [
                ("outside", 1.5), ("below", -0.5), ("obj", np.array([object()]))]:
            bad(A, f"{cname}.{meth}:x={label}", lambda make=make, meth=meth, v=v: getattr(make(), meth)(v),
                "x")
    for label, v in [("nan", NAN), ("str", "a")]:
        bad(A, f"{cname}.force:x={label}", lambda make=make, v=v: make().force(v, 1.0, 0.0, 1.0), "x")
    bad(A, f"{cname}.errors:f=str", lambda make=make: make().errors("f", F3[1], F3[2]), "f")


@valid(A, "surrogates:cubic-exact")
def _surrogates_exact():
    # f'' = 6x is linear: the spline and a degree-1 Chebyshev form are exact, and choose takes
    # the smallest Chebyshev form (5 coefficients) for a tight tolerance
    f, df, d2f = cubic()
    x = np.linspace(0.0, 1.0, 101)
    ok = all(np.abs(s.position(x) - f(x)).max() < 1e-13 for s in (_spline(), _cheb()))
    best, table = approx.choose(f, df, d2f, 0.0, 1.0, tol=1e-12)
    return bool(ok and abs(best.position(0.7) - f(0.7)) < 1e-12 and table.chosen.sum() == 1)


for fname in ("f3", "psi31", "dpsi31"):
    fn = getattr(cylinder, fname)
    for label, v in [("nan", NAN), ("inf", INF), ("str", "a"), ("None", None), ("complex", 1j),
                     ("dict", {})]:
        bad(A, f"cylinder.{fname}:q1={label}", lambda fn=fn, v=v: fn(v), "q1")
    for arg in ("b", "b0", "b3"):
        for label, v in [("nan", NAN), ("negative", -0.7), ("zero", 0.0), ("str", "a")]:
            bad(A, f"cylinder.{fname}:{arg}={label}", lambda fn=fn, arg=arg, v=v: fn(0.1, **{arg: v}), arg)
for label, v in [("nan", NAN), ("str", "a"), ("None", None)]:
    bad(A, f"cylinder.drive_law:t={label}", lambda v=v: cylinder.drive_law(v), "t")
for label, v in [("nan", NAN), ("zero", 0.0), ("negative", -1.0), ("str", "5")]:
    bad(A, f"cylinder.drive_law:tau={label}", lambda v=v: cylinder.drive_law(1.0, tau=v), "tau")
for label, v in [("nan", NAN), ("str", "a"), ("inf", INF)]:
    bad(A, f"cylinder.drive_law:stroke={label}", lambda v=v: cylinder.drive_law(1.0, stroke=v), "stroke")
for arg in ("b", "b0", "b3"):
    for label, v in [("nan", NAN), ("negative", -0.7), ("zero", 0.0), ("str", "a"), ("None", None)]:
        bad(A, f"cylinder.mechanism:{arg}={label}", lambda arg=arg, v=v: cylinder.mechanism(**{arg: v}), arg)
bad(A, "cylinder.mechanism:b=too-long", lambda: cylinder.mechanism(b=2.0), "b")


# ================================================================== stiffness: bad inputs
S = "stiffness"
for fname, args in [("skew", {"p": P0}), ("plucker", {"n": [0.0, 0.0, 1.0], "r": P0}),
                    ("wrench_transform", {"R": R0, "p": P0}), ("twist_transform", {"R": R0, "p": P0}),
                    ("wrench_transform_inverse", {"R": R0, "p": P0}),
                    ("twist_transform_inverse", {"R": R0, "p": P0}),
                    ("shift_wrench", {"p": P0}), ("shift_twist", {"p": P0}), ("rotate_six", {"R": R0}),
                    ("compose_frames", {"R1": R0, "p1": P0, "R2": R0.T, "p2": -P0}),
                    ("to_moment_first", {"X": K0}), ("from_moment_first", {"X": K0}),
                    ("blocks", {"K": K0}), ("screw_eigenvalues", {"K": K0}),
                    ("translational_eigenvalues", {"K": K0}),
                    ("rotational_compliance_eigenvalues", {"K": K0}),
                    ("stiffness_indices", {"K": K0}),
                    ("transform_stiffness", {"K": K0, "R": R0, "p": P0}),
                    ("transform_blocks", {"K": K0, "R": R0, "p": P0}),
                    ("stiffness_matrix", {"P": np.eye(6), "k": np.ones(6)}),
                    ("spring_stiffness", {"k": [1.0, 2.0], "directions": [[1.0, 0, 0], [0, 1.0, 0]],
                                          "points": [[0.0, 0, 0], [1.0, 0, 0]]}),
                    ("from_blocks", {"Kn": np.eye(3), "Kc": np.zeros((3, 3)), "Kk": np.eye(3)})]:
    fn = getattr(stiffness, fname)
    for arg, good in args.items():
        variants = array_variants(good)
        if arg.startswith("R"):
            variants = variants + bad_rotations()
        each(S, fname, fn, args, arg, variants)
bad(S, "plucker:n=zero", lambda: stiffness.plucker([0.0, 0.0, 0.0], P0), "n")
bad(S, "stiffness_matrix:k=negative", lambda: stiffness.stiffness_matrix(np.eye(6), -np.ones(6)), "k")
bad(S, "spring_stiffness:k=negative",
    lambda: stiffness.spring_stiffness([-1.0], [[1.0, 0, 0]], [[0.0, 0, 0]]), "k")
bad(S, "spring_stiffness:directions=zero",
    lambda: stiffness.spring_stiffness([1.0], [[0.0, 0, 0]], [[0.0, 0, 0]]), "directions")
for label, v in scalar_variants(positive=True):
    bad(S, f"stiffness_indices:singular_cond={label}",
        lambda v=v: stiffness.stiffness_indices(K0, singular_cond=v), "singular_cond")


def _hex(**kw):
    a = np.radians([0, 100, 120, 220, 240, 340])
    b = np.radians([40, 80, 160, 200, 280, 320])
    args = dict(base_points=np.c_[0.8 * np.cos(a), 0.8 * np.sin(a), np.zeros(6)],
                platform_points=np.c_[0.4 * np.cos(b), 0.4 * np.sin(b), np.zeros(6)],
                leg_stiffness=2e7)
    args.update(kw)
    return stiffness.Hexapod(**args)


for arg in ("base_points", "platform_points"):
    good = np.zeros((6, 3)) + np.arange(6)[:, None]
    for label, v in array_variants(good)[:11] + [("five", good[:5])]:
        bad(S, f"Hexapod:{arg}={label}", lambda arg=arg, v=v: _hex(**{arg: v}), arg)
for label, v in scalar_variants(positive=True, arrays=False) + [("five", np.ones(5)), ("some-zero", [1.0] * 5 + [0.0])]:
    bad(S, f"Hexapod:leg_stiffness={label}", lambda v=v: _hex(leg_stiffness=v), "leg_stiffness")
for arg in ("singular_cond", "warn_cond"):
    for label, v in scalar_variants(positive=True, arrays=False)[:8]:
        bad(S, f"Hexapod:{arg}={label}", lambda arg=arg, v=v: _hex(**{arg: v}), arg)
for meth in ("stiffness", "compliance", "cond_P", "legs", "leg_matrix"):
    for label, v in array_variants(HEX_POSE)[:8] + bad_transforms():
        bad(S, f"Hexapod.{meth}:pose={label}", lambda meth=meth, v=v: getattr(hexapod(), meth)(v), "pose")
for label, v in [("unknown", "world"), ("int", 3), ("bad-pair", (bad_rotations()[0][1], P0)),
                 ("nan-pair", (R0, [NAN, 0, 0]))]:
    bad(S, f"Hexapod.stiffness:frame={label}", lambda v=v: hexapod().stiffness(HEX_POSE, frame=v), "frame")
for meth in ("leg_forces", "deflection", "loaded_stiffness"):
    for label, v in array_variants(np.arange(6.0))[:10]:
        bad(S, f"Hexapod.{meth}:wrench={label}", lambda meth=meth, v=v: getattr(hexapod(), meth)(HEX_POSE, v),
            "wrench")
for label, v in array_variants([[0.0, 0.0, 0.7]])[:10]:
    bad(S, f"Hexapod.map:positions={label}", lambda v=v: hexapod().map(v), "positions")
for label, v in no(array_variants([[0.0, 0.0, 0.1]])[:10], "None"):
    bad(S, f"Hexapod.map:rotations={label}", lambda v=v: hexapod().map([[0, 0, 0.7]], v), "rotations")
for label, v in array_variants(HEX_POSE[None])[:8] + [("2d", HEX_POSE)]:
    bad(S, f"Hexapod.stiffness_batch:T={label}", lambda v=v: hexapod().stiffness_batch(v), "T")
bad(S, "Hexapod.stiffness_batch:cond=str", lambda: hexapod().stiffness_batch(HEX_POSE[None], cond="no"), "cond")
bad(S, "report:hexapod=str", lambda: stiffness.report("hex", HEX_POSE), "hexapod")
bad(S, "report:pose=nan", lambda: stiffness.report(hexapod(), HEX_POSE * NAN), "pose")
bad(S, "report:wrench=short", lambda: stiffness.report(hexapod(), HEX_POSE, wrench=[1.0, 2.0]), "wrench")
bad(S, "report:positions=nan", lambda: stiffness.report(hexapod(), HEX_POSE, positions=[[NAN, 0, 0.7]]),
    "positions")
bad(S, "report:frame=unknown", lambda: stiffness.report(hexapod(), HEX_POSE, frame="world"), "frame")
bad(S, "design_leg_stiffness:budget=nan",
    lambda: stiffness.design_leg_stiffness(hexapod(), [HEX_POSE], NAN), "budget")
bad(S, "design_leg_stiffness:budget=negative",
    lambda: stiffness.design_leg_stiffness(hexapod(), [HEX_POSE], -1.0), "budget")
bad(S, "design_leg_stiffness:hexapod=str",
    lambda: stiffness.design_leg_stiffness("hex", [HEX_POSE], 1e8), "hexapod")
bad(S, "design_leg_stiffness:poses=nan",
    lambda: stiffness.design_leg_stiffness(hexapod(), [HEX_POSE * NAN], 1e8), "poses")
bad(S, "design_leg_stiffness:k_min=negative",
    lambda: stiffness.design_leg_stiffness(hexapod(), [HEX_POSE], 1e8, k_min=-1.0), "k_min")


# ================================================================== synthesis: bad inputs
Y = "synthesis"
scr_good = dict(axis=[0.0, 0.0, 1.0], point=[0.0, 0.0, 0.0], angle=0.5, slide=0.1)
for arg in ("axis", "point"):
    each(Y, "Screw", synthesis.Screw, scr_good, arg, array_variants(scr_good[arg]))
    each(Y, "Screw.from_degrees", synthesis.Screw.from_degrees,
         {"axis": scr_good["axis"], "point": scr_good["point"], "angle_deg": 30.0, "slide": 0.1}, arg,
         array_variants(scr_good[arg])[:9])
bad(Y, "Screw:axis=zero", lambda: synthesis.Screw([0.0, 0, 0], [0.0, 0, 0], 0.5, 0.1), "axis")
for arg in ("angle", "slide"):
    each(Y, "Screw", synthesis.Screw, scr_good, arg, scalar_variants(arrays=True))
for arg in ("angle_deg", "slide"):
    each(Y, "Screw.from_degrees", synthesis.Screw.from_degrees,
         {"axis": scr_good["axis"], "point": scr_good["point"], "angle_deg": 30.0, "slide": 0.1}, arg,
         scalar_variants(arrays=True))
each(Y, "Screw.from_matrix", synthesis.Screw.from_matrix, {"T": T0}, "T",
     array_variants(T0) + bad_transforms())
for label, v in scalar_variants(positive=True)[:9]:
    bad(Y, f"Screw.from_matrix:tol={label}", lambda v=v: synthesis.Screw.from_matrix(T0, tol=v), "tol")
line_good = dict(direction=[0.0, 0.0, 1.0], point=[1.0, 0.0, 0.0])
for arg in ("direction", "point"):
    each(Y, "Line", synthesis.Line, line_good, arg, array_variants(line_good[arg]))
bad(Y, "Line:direction=zero", lambda: synthesis.Line([0.0, 0, 0], [0.0, 0, 0]), "direction")
L0 = synthesis.Line(np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))
for label, v in array_variants(T0)[:8] + bad_transforms():
    bad(Y, f"Line.transformed:T={label}", lambda v=v: L0.transformed(v), "T")
for label, v in array_variants(P0)[:9]:
    bad(Y, f"Line.foot_from:x={label}", lambda v=v: L0.foot_from(v), "x")
for label, v in [("str", "line"), ("None", None), ("array", np.zeros(3))]:
    bad(Y, f"Line.distance_to:other={label}", lambda v=v: L0.distance_to(v), "other")
    bad(Y, f"Line.canonical:previous={label}", lambda v=v: L0.canonical(v) if v is not None else
        L0.canonical(3), "previous")
    bad(Y, f"Screw.compose:other={label}", lambda v=v: SEED[0].compose(v), "other")
for arg in ("s1j", "s1k"):
    for label, v in [("str", "s"), ("None", None), ("matrix", T0)]:
        bad(Y, f"relative_screw:{arg}={label}",
            lambda arg=arg, v=v: synthesis.relative_screw(**dict({"s1j": SEED[0], "s1k": SEED[1]}, **{arg: v})),
            arg)
        bad(Y, f"rr_links:{arg.replace('1j', '12').replace('1k', '13')}={label}",
            lambda arg=arg, v=v: synthesis.rr_links(**dict({"s12": SEED[0], "s13": SEED[1]},
                                                          **{arg.replace('1j', '12').replace('1k', '13'): v})),
            arg.replace('1j', '12').replace('1k', '13'))
for label, v in scalar_variants(positive=True)[:9]:
    bad(Y, f"rr_links:tol={label}", lambda v=v: synthesis.rr_links(SEED[0], SEED[1], tol=v), "tol")
rab = dict(m3=[0.0, 0.0, 1.0], q3=[0.0, 0.0, 0.0], m4=[0.0, 1.0, 0.0], q4=[1.0, 0.0, 0.0])
for arg in rab:
    each(Y, "rotation_axis_between", synthesis.rotation_axis_between, rab, arg, array_variants(rab[arg])[:9])
for label, v in [("unknown", "XYZ"), ("None", None), ("int", 3), ("not-implemented", "CCC")]:
    bad(Y, f"enumerate_dyads:family={label}", lambda v=v: synthesis.enumerate_dyads(v, SEED), "family")
for label, v in [("two", SEED[:2]), ("str", "abc"), ("None", None), ("strs", ["a", "b", "c"]),
                 ("matrices-nan", [T0 * NAN] * 3), ("four", SEED + SEED[:1])]:
    bad(Y, f"enumerate_dyads:screws={label}", lambda v=v: synthesis.enumerate_dyads("RRR", v), "screws")
    bad(Y, f"rrr_dyads:screws={label}", lambda v=v: synthesis.rrr_dyads(v), "screws")
    if label not in ("two", "four"):      # any number of screws is fine for inverse_screws
        bad(Y, f"inverse_screws:screws={label}", lambda v=v: synthesis.inverse_screws(v), "screws")
for label, v in [("nan", [T0 * NAN] * 5), ("str", "T"), ("None", None), ("three", [T0] * 3),
                 ("bad-rows", [bad_transforms()[1][1]] * 5)]:
    bad(Y, f"rs_links:T={label}", lambda v=v: synthesis.rs_links(v), "T")
for label, v in index_variants() + [("zero", 0)]:
    bad(Y, f"rs_links:samples={label}",
        lambda v=v: synthesis.rs_links([np.eye(4)] + [closure.exp_se3(np.r_[0.1 * k, 0, 0, 0, 0, 0.3 * k])
                                                      for k in range(1, 4)], samples=v), "samples")
for label, v in [("unknown", "XRR"), ("None", None), ("short", "RR"), ("int", 3)]:
    bad(Y, f"chain_mechanism:types={label}", lambda v=v: synthesis.chain_mechanism(v, [L0] * 3), "types")
for label, v in [("str", "abc"), ("None", None), ("short", [L0]), ("arrays", [np.zeros(3)] * 3)]:
    bad(Y, f"chain_mechanism:lines={label}", lambda v=v: synthesis.chain_mechanism("RRR", v), "lines")
for label, v in [("str", "row"), ("None", None), ("dict", {"family": "RRR"})]:
    bad(Y, f"invert_chain:row={label}", lambda v=v: synthesis.invert_chain(v), "row")
for label, v in array_variants(np.zeros((4, 3)))[:9]:
    bad(Y, f"verify_chain:joint_values={label}",
        lambda v=v: synthesis.verify_chain("RRR", [L0] * 3, v, [np.eye(4)] * 4), "joint_values")
for label, v in [("nan", [T0 * NAN] * 4), ("str", "T"), ("None", None), ("bad-rows", [bad_transforms()[1][1]] * 4)]:
    bad(Y, f"verify_chain:targets={label}",
        lambda v=v: synthesis.verify_chain("RRR", [L0] * 3, np.zeros((4, 3)), v), "targets")
for label, v in scalar_variants(positive=True)[:9]:
    bad(Y, f"verify_chain:length={label}",
        lambda v=v: synthesis.verify_chain("RRR", [L0] * 3, np.zeros((4, 3)), [np.eye(4)] * 4, length=v),
        "length")


# ================================================================== linkwright: bad study files
class CliError(ValueError):
    """The command refused its input (exit status 2); the message is what it printed."""


class CliFailure(RuntimeError):
    """The command failed (exit status 1): not a clear refusal of a bad input."""


_TMP: list[Path] = []


def tmpdir() -> Path:
    if not _TMP:
        d = Path(tempfile.mkdtemp(prefix="lw-census-"))
        atexit.register(shutil.rmtree, d, True)
        _TMP.append(d)
    return _TMP[0]


def _toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v == INF else "-inf" if v == -INF else repr(v))
    if isinstance(v, (int, str)):
        return json.dumps(v, ensure_ascii=False) if isinstance(v, str) else repr(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(v)


def to_toml(data: dict, prefix: str = "") -> str:
    """A small TOML writer for the census's study files (tables, arrays of tables)."""
    lines, tables = [], []
    for k, v in data.items():
        if isinstance(v, dict):
            tables.append((k, v, False))
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            tables.append((k, v, True))
        else:
            lines.append(f"{k} = {_toml_value(v)}")
    out = "\n".join(lines) + ("\n" if lines else "")
    for k, v, many in tables:
        name = prefix + k
        for t in (v if many else [v]):
            out += f"\n[[{name}]]\n" if many else f"\n[{name}]\n"
            out += to_toml(t, name + ".")
    return out


STUDIES = {
    "approx": {"study": {"command": "approx"},
               "approx": {"source": "oscillating_cylinder", "a": 0.0, "b": 0.3, "n": 2},
               "cylinder": {"B": 0.7, "B0": 0.7, "B3": 0.4},
               "force": {"mass": 500.0, "arm": 0.4, "duration": 5.0, "stroke": 0.3}},
    "stiffness": {"study": {"command": "stiffness"},
                  "hexapod": {"base_points": [[0.8, 0.0, 0.0], [-0.138919, 0.787846, 0.0],
                                              [-0.4, 0.69282, 0.0], [-0.61284, -0.51423, 0.0],
                                              [-0.4, -0.69282, 0.0], [0.751754, -0.273616, 0.0]],
                              "platform_points": [[0.306418, 0.257115, 0.0], [0.069459, 0.393923, 0.0],
                                                  [-0.375877, 0.136808, 0.0], [-0.375877, -0.136808, 0.0],
                                                  [0.069459, -0.393923, 0.0], [0.306418, -0.257115, 0.0]],
                              "leg_stiffness": 2.0e7},
                  "pose": {"position": [0.0, 0.0, 0.7], "rotation_deg": [0.0, 0.0, 0.0]},
                  "report": {"frame": "platform", "wrench": [0.0, 0.0, -5000.0, 100.0, 0.0, 0.0]},
                  "map": {"x": [-0.1, 0.1, 2], "y": [-0.1, 0.1, 2], "z": [0.7, 0.7, 1]}},
    "synth": {"study": {"command": "synth"},
              "synthesis": {"family": "RRR"},
              "position": [{"axis": [0.0, 0.0, 1.0], "point": [0.0, 0.0, 0.0], "angle_deg": 30.0, "slide": 0.7},
                           {"axis": [0.34202, 0.0, 0.939693], "point": [0.0, 1.1, 0.0], "angle_deg": 65.0,
                            "slide": 0.5},
                           {"axis": [0.66, 0.043589, 0.75], "point": [0.25, 1.2, -0.289742],
                            "angle_deg": 75.0, "slide": 0.3}],
              "criterion": {"kind": "link_length"}},
    "analyze": {"study": {"command": "analyze"},
                "mechanism": {"links": ["crank", "coupler", "rocker"],
                              "joint": [{"name": n, "kind": "R", "links": ls, "origin": o,
                                         "x_point": [o[0] + 1.0, o[1], o[2]], "z_point": [o[0], o[1], 1.0]}
                                        for n, ls, o in (("A", ["ground", "crank"], [0.0, 0.0, 0.0]),
                                                         ("B", ["crank", "coupler"], [0.0, 1.0, 0.0]),
                                                         ("C", ["coupler", "rocker"], [3.0, 2.0, 0.0]),
                                                         ("D", ["ground", "rocker"], [3.0, 0.0, 0.0]))],
                              "input": [{"joint": "A"}]},
                "sweep": {"from_deg": 0.0, "to_deg": 90.0, "steps": 4},
                "point": [{"name": "mid", "link": "coupler", "at": [1.5, 1.5, 0.0]}],
                "dynamics": {"gravity": [0.0, -9.81, 0.0], "duration": 2.0,
                             "body": [{"link": "crank", "mass": 1.0, "com": [0.0, 0.5, 0.0]},
                                      {"link": "coupler", "mass": 3.0, "com": [1.5, 1.5, 0.0]}]}},
}
_RUN = [0]


def run_cli(command: str, study: dict | str, *extra, filename: str = "study{}.toml") -> dict:
    """Write ``study`` to a file, run ``linkwright COMMAND FILE -o OUT --json`` in process:
    the JSON summary (exit 0), :class:`CliError` (exit 2) or :class:`CliFailure` (else)."""
    from linkwright.cli import main
    _RUN[0] += 1
    d = tmpdir()
    path = d / filename.format(_RUN[0])
    path.write_text(study if isinstance(study, str) else to_toml(study), encoding="utf-8")
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main([command, str(path), "-o", str(d / f"out{_RUN[0]}"), "--json", *extra])
    if rc == 0:
        return json.loads(out.getvalue())
    if rc == 2:
        raise CliError(err.getvalue().strip())
    raise CliFailure(f"exit {rc}: {err.getvalue().strip()}")


def _set(data: dict, key: str, value):
    """A deep copy of ``data`` with dotted ``key`` (``position[1].axis``) set, or removed
    when ``value`` is ``...``."""
    data = json.loads(json.dumps(data))
    parts = key.replace("]", "").split(".")
    node = data
    for p in parts[:-1]:
        name, _, i = p.partition("[")
        node = node[name] if not i else node[name][int(i)]
    last, _, i = parts[-1].partition("[")
    if i:
        node[last][int(i)] = value
    elif value is ...:
        del node[last]
    else:
        node[last] = value
    return data


L = "linkwright"
SCALARS_STUDY = [("nan", NAN), ("inf", INF), ("str", "x"), ("bool", True), ("list", [1.0]),
                 ("table", {"v": 1.0})]
for command, key, variants in [
        ("approx", "approx.a", SCALARS_STUDY), ("approx", "approx.b", SCALARS_STUDY + [("below-a", -1.0)]),
        ("approx", "approx.n", [("zero", 0), ("float", 1.5), ("str", "2"), ("bool", True), ("huge", 10 ** 6),
                                ("negative", -2)]),
        ("approx", "approx.source", [("unknown", "nope"), ("int", 3)]),
        ("approx", "cylinder.B", SCALARS_STUDY[:4] + [("negative", -0.7), ("too-long", 2.0)]),
        ("approx", "cylinder.B0", [("zero", 0.0), ("nan", NAN), ("negative", -1.0)]),
        ("approx", "cylinder.B3", [("zero", 0.0), ("inf", INF)]),
        ("approx", "force.mass", [("negative", -1.0), ("nan", NAN), ("str", "heavy")]),
        ("approx", "force.duration", [("zero", 0.0), ("negative", -5.0), ("inf", INF)]),
        ("approx", "force.arm", [("negative", -0.4), ("nan", NAN)]),
        ("approx", "force.stroke", [("nan", NAN), ("str", "x")]),
        ("stiffness", "hexapod.leg_stiffness", SCALARS_STUDY[:4] + [("negative", -2e7), ("zero", 0.0),
                                                                     ("five", [2e7] * 5)]),
        ("stiffness", "hexapod.base_points", [("short-row", [[0.0, 0.0]] * 6), ("five", [[0.0, 0.0, 0.0]] * 5),
                                              ("nan", [[NAN, 0.0, 0.0]] * 6), ("str", "circle")]),
        ("stiffness", "hexapod.platform_points", [("five", [[0.0, 0.0, 0.0]] * 5), ("inf", [[INF, 0.0, 0.0]] * 6)]),
        ("stiffness", "pose.position", [("short", [0.0, 0.7]), ("nan", [0.0, 0.0, NAN]), ("str", "up")]),
        ("stiffness", "pose.rotation_deg", [("inf", [INF, 0.0, 0.0]), ("long", [0.0] * 4)]),
        ("stiffness", "report.frame", [("unknown", "world"), ("int", 1)]),
        ("stiffness", "report.wrench", [("short", [0.0] * 5), ("nan", [NAN] * 6)]),
        ("stiffness", "map.x", [("zero-count", [-0.1, 0.1, 0]), ("float-count", [-0.1, 0.1, 2.5]),
                                ("nan", [NAN, 0.1, 2]), ("short", [-0.1, 0.1]), ("negative-count", [0.0, 1.0, -3])]),
        ("synth", "synthesis.family", [("unknown", "XYZ"), ("int", 3)]),
        ("synth", "position[0].axis", [("zero", [0.0, 0.0, 0.0]), ("nan", [NAN, 0.0, 1.0]), ("short", [0.0, 1.0])]),
        ("synth", "position[0].point", [("inf", [INF, 0.0, 0.0]), ("str", "origin")]),
        ("synth", "position[1].angle_deg", SCALARS_STUDY[:4] + [("too-large", 1000.0)]),
        ("synth", "position[2].slide", SCALARS_STUDY[:4]),
        ("synth", "criterion.kind", [("unknown", "beauty"), ("int", 1)]),
        ("synth", "criterion.center", [("nan", [NAN, 0.0, 0.0]), ("short", [0.0])]),
        ("analyze", "mechanism.links", [("str", "crank"), ("ints", [1, 2, 3])]),
        ("analyze", "mechanism.joint[0].kind", [("unknown", "X"), ("int", 1)]),
        ("analyze", "mechanism.joint[1].links", [("unknown", ["crank", "nope"]), ("one", ["crank"]),
                                                 ("same", ["crank", "crank"])]),
        ("analyze", "mechanism.joint[2].origin", [("nan", [NAN, 2.0, 0.0]), ("short", [3.0, 2.0])]),
        ("analyze", "mechanism.joint[2].z_point", [("coincident", [3.0, 2.0, 0.0])]),
        ("analyze", "mechanism.input[0].joint", [("unknown", "Z"), ("int", 0)]),
        ("analyze", "mechanism.input[0].index", [("negative", -1), ("too-large", 3), ("float", 0.5)]),
        ("analyze", "sweep.steps", [("zero", 0), ("one", 1), ("float", 2.5), ("huge", 10 ** 7)]),
        ("analyze", "sweep.from_deg", SCALARS_STUDY[:4]),
        ("analyze", "point[0].link", [("unknown", "nope"), ("int", 1)]),
        ("analyze", "point[0].at", [("nan", [NAN, 0.0, 0.0]), ("short", [1.0])]),
        ("analyze", "dynamics.gravity", [("nan", [0.0, NAN, 0.0]), ("short", [0.0, -9.81])]),
        ("analyze", "dynamics.duration", [("zero", 0.0), ("nan", NAN), ("negative", -1.0)]),
        ("analyze", "dynamics.body[0].mass", [("negative", -1.0), ("zero", 0.0), ("nan", NAN)]),
        ("analyze", "dynamics.body[0].link", [("unknown", "nope"), ("ground", "ground")]),
        ("analyze", "dynamics.body[1].com", [("inf", [INF, 0.0, 0.0]), ("short", [1.5])]),
]:
    for label, v in variants:
        bad(L, f"cli {command}:{key}={label}",
            lambda command=command, key=key, v=v: run_cli(command, _set(STUDIES[command], key, v)), key)
bad(L, "cli approx:approx.n=missing-all",
    lambda: run_cli("approx", _set(STUDIES["approx"], "approx.n", ...)), "approx.delta")
bad(L, "cli approx:approx=missing", lambda: run_cli("approx", _set(STUDIES["approx"], "approx", ...)), "approx")
bad(L, "cli analyze:sweep=missing", lambda: run_cli("analyze", _set(STUDIES["analyze"], "sweep", ...)), "sweep")
bad(L, "cli synth:position=two", lambda: run_cli("synth", _set(STUDIES["synth"], "position",
                                                               STUDIES["synth"]["position"][:2])), "position")
bad(L, "cli approx:malformed-toml", lambda: run_cli("approx", "[approx\na = "), "TOML")
bad(L, "cli approx:file=missing", lambda: _missing_file(), "not found")
bad(L, "cli approx:command=mismatch", lambda: run_cli("approx", STUDIES["synth"]), "approx")


def _missing_file():
    from linkwright.cli import main
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        rc = main(["approx", str(tmpdir() / "nope.toml"), "-o", str(tmpdir() / "nope-out")])
    if rc == 2:
        raise CliError(err.getvalue().strip())
    raise CliFailure(f"exit {rc}: {err.getvalue().strip()}")


# ================================================================== valid inputs
def close(a, b, rtol=1e-12, atol=0.0) -> bool:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return a.shape == b.shape and bool(np.allclose(a, b, rtol=rtol, atol=atol))


def rot_ref(axis, angle):
    """Rodrigues' formula, written out (the reference for the rotation helpers)."""
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * (K @ K)


def fourbar_ref(theta, shift=(0.0, 0.0, 0.0), scale=1.0):
    """Closed-form rocker angle (joint D) of :func:`fourbar` for crank angle θ."""
    Bp = scale * np.array([-math.sin(theta), math.cos(theta)])
    D = scale * np.array([3.0, 0.0])
    r1, r2 = scale * math.sqrt(10.0), 2.0 * scale
    d = np.linalg.norm(D - Bp)
    a = (r1 * r1 - r2 * r2 + d * d) / (2 * d)
    h = math.sqrt(r1 * r1 - a * a)
    e = (D - Bp) / d
    perp = np.array([-e[1], e[0]])
    sols = [Bp + a * e + s * h * perp for s in (1, -1)]
    # the assembly mode: C to the left of B→D (as at θ = 0, where C = (3, 2))
    Cp = next(c for c in sols if np.cross(D - Bp, c - Bp) > 0)
    return math.atan2(Cp[1] - D[1], Cp[0] - D[0]) - math.pi / 2


V = "closure"


@valid(V, "rot_xyz: tiny, huge and negative angles against Rodrigues")
def _():
    ok = True
    for angle in (1e-300, 1e-9, -2.5, 1e6, -1e4):
        for fn, ax in ((closure.rot_x, [1, 0, 0]), (closure.rot_y, [0, 1, 0]), (closure.rot_z, [0, 0, 1])):
            ok &= close(fn(angle), rot_ref(ax, angle), atol=1e-15)
    return ok


@valid(V, "rotation: axis of length 1e-8 and 1e8 gives the unit-axis rotation")
def _():
    ax = np.array([1.0, -2.0, 0.5])
    R = rot_ref(ax, 0.7)
    return close(closure.rotation(1e-8 * ax, 0.7), R, atol=1e-14) and \
        close(closure.rotation(1e8 * ax, 0.7), R, atol=1e-14)


@valid(V, "exp_so3: rotation vector of 1e-12 rad is I + [w]x to first order")
def _():
    w = np.array([1e-12, -2e-12, 3e-12])
    K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    return close(closure.exp_so3(w), np.eye(3) + K, atol=1e-23)


@valid(V, "exp_so3: batch (7, 3) equals one by one")
def _():
    W = np.random.default_rng(5).normal(size=(7, 3)) * 2
    return close(closure.exp_so3(W), np.stack([rot_ref(w, np.linalg.norm(w)) for w in W]), atol=1e-14)


@valid(V, "log_so3: angle pi - 1e-9 and exactly pi round-trip")
def _():
    ax = np.array([0.3, -0.4, 0.5])
    ok = True
    for angle in (math.pi - 1e-9, math.pi, 1e-10):
        R = rot_ref(ax, angle)
        w = closure.log_so3(R)
        ok &= abs(np.linalg.norm(w) - angle) < 1e-8 and close(rot_ref(w, np.linalg.norm(w)), R, atol=1e-12)
    return ok


@valid(V, "exp_se3 / log_se3: round trip of a pose 100 km from the origin")
def _():
    T = closure.transform(rot_ref([1, 2, 3], 2.0), [1e5, -3e4, 2e5])
    return close(closure.exp_se3(closure.log_se3(T)), T, rtol=0, atol=1e-9 * 1e5)


@valid(V, "inverse: T at 1 km and at 100 km")
def _():
    ok = True
    for far in (1e3, 1e5):
        T = closure.transform(rot_ref([1, -1, 2], 1.1), [far, 2 * far, -far])
        ok &= close(closure.inverse(T) @ T, np.eye(4), atol=1e-16 * far * 10)
        ok &= close(T @ closure.inverse(T), np.eye(4), atol=1e-16 * far * 10)
    return ok


@valid(V, "adjoint: Ad_T xi equals vee(T hat(xi) T^-1) at 1 km")
def _():
    T = closure.transform(rot_ref([0, 1, 1], 0.4), [1e3, 0, 5e2])
    xi = np.array([0.1, 0.2, -0.3, 0.5, -0.1, 0.2])
    X = T @ closure.hat(xi) @ np.linalg.inv(T)
    return close(closure.adjoint(T) @ xi, closure.vee(X), rtol=1e-10, atol=1e-10)


@valid(V, "ad: ad_xi eta equals the matrix commutator")
def _():
    rng = np.random.default_rng(2)
    xi, eta = rng.normal(size=6), rng.normal(size=6)
    A, B = closure.hat(xi), closure.hat(eta)
    return close(closure.ad(xi) @ eta, closure.vee(A @ B - B @ A), atol=1e-13)


@valid(V, "euler_zxz: generic and singular (theta = 0) rotations round-trip")
def _():
    ok = True
    for R in (rot_ref([1, 2, 3], 1.0), rot_ref([0, 0, 1], 0.8), rot_ref([0, 0, 1], -3.0)):
        psi, th, phi = closure.euler_zxz(R)
        ok &= close(closure.rot_z(psi) @ closure.rot_x(th) @ closure.rot_z(phi), R, atol=1e-13)
    return ok


@valid(V, "skew, cross: agree with numpy's cross product")
def _():
    rng = np.random.default_rng(3)
    p, q = rng.normal(size=(2, 5, 3))
    return close(closure.skew(p) @ q[..., None], np.cross(p, q)[..., None], atol=1e-14) and \
        close(closure.cross(p, q), np.cross(p, q), atol=1e-14)


@valid(V, "frame_from_points: 100 km from the origin equals the frame at the origin, moved")
def _():
    o, x, z = np.array([0.0, 0, 0]), np.array([1.0, 0.2, 0]), np.array([0.1, 0, 1.0])
    s = np.array([1e5, -1e5, 5e4])
    F0, F1 = closure.frame_from_points(o, x, z), closure.frame_from_points(o + s, x + s, z + s)
    return close(F1[:3, :3], F0[:3, :3], atol=1e-10) and close(F1[:3, 3], s, atol=1e-9)


@valid(V, "frame_from_points: batch equals one by one, z axis along z_point - origin")
def _():
    rng = np.random.default_rng(4)
    o, x, z = rng.normal(size=(3, 6, 3))
    F = closure.frame_from_points(o, x, z)
    one = np.stack([closure.frame_from_points(*args) for args in zip(o, x, z)])
    zz = (z - o) / np.linalg.norm(z - o, axis=1, keepdims=True)
    return close(F, one, atol=1e-15) and close(F[:, :3, 2], zz, atol=1e-14)


@valid(V, "transform/translation: integer and float32 inputs")
def _():
    T = closure.transform(np.eye(3, dtype=int), np.array([1, 2, 3]))
    T2 = closure.translation(np.array([1, 2, 3], np.float32))
    ref = np.eye(4)
    ref[:3, 3] = [1, 2, 3]
    return close(T, ref) and close(T2, ref)


@valid(V, "pseudo_inertia: point mass equals m [c cT, c; cT, 1]")
def _():
    m, c = 2.5, np.array([0.3, -0.2, 1.0])
    ref = m * np.block([[np.outer(c, c), c[:, None]], [c[None, :], np.ones((1, 1))]])
    return close(closure.pseudo_inertia(m, c, np.zeros((3, 3))), ref, atol=1e-15)


@valid(V, "four-bar: solve against the closed form, crank angles up to 5 rad")
def _():
    th = np.array([-1.0, 0.0, 0.5, 2.5, 5.0])
    pose = fourbar().solve(th)
    return close(pose["D"], [fourbar_ref(t) for t in th], atol=1e-10)


for far in (1e3, 1e5):
    @valid(V, f"four-bar moved {far:.0e} m from the origin: same joint angles")
    def _(far=far):
        shift = (far, -far / 2, far / 3)
        th = np.array([0.3, 1.7, 4.0])
        p0, p1 = fourbar().solve(th), fourbar(shift).solve(th)
        return close(p1.values(), p0.values(), atol=1e-9) and close(p1["D"], [fourbar_ref(t) for t in th],
                                                                    atol=1e-9)


for scale in (1e-3, 1e3):
    @valid(V, f"four-bar scaled by {scale:g} (units): same joint angles")
    def _(scale=scale):
        th = np.array([0.3, 1.7, 4.0])
        return close(fourbar(scale=scale).solve(th)["D"], [fourbar_ref(t) for t in th], atol=1e-10)


@valid(V, "four-bar: sweep rows equal one-by-one solves")
def _():
    th = np.linspace(0, 2 * np.pi, 9)
    table = fourbar().sweep(th)
    one = [float(fourbar().solve(t)["D"]) for t in th]
    col = [c for c in table.columns if c.startswith("D")][0]
    return close(table[col].to_numpy(), one, atol=1e-10)


@valid(V, "four-bar: joint_analogs against central differences of the closed form")
def _():
    th, h = np.array([0.4, 2.0]), 1e-5
    val, d1, d2 = closure.joint_analogs(fourbar(), fourbar().solve(th), "D")
    f = np.vectorize(fourbar_ref)
    fd1 = (f(th + h) - f(th - h)) / (2 * h)
    fd2 = (f(th + h) - 2 * f(th) + f(th - h)) / h ** 2
    return close(val, f(th), atol=1e-10) and close(d1, fd1, atol=1e-8) and close(d2, fd2, atol=1e-4)


@valid(V, "four-bar: point_analogs against central differences of Pose.point (1 km away)")
def _():
    s = np.array([1e3, 1e3, 0.0])
    m, th, h = fourbar(tuple(s)), 0.8, 1e-5
    xyz = s + [1.5, 1.5, 0.0]
    p, d1, d2 = closure.point_analogs(m, m.solve(th), "coupler", xyz)
    P = [m.solve(t).point("coupler", xyz) for t in (th - h, th, th + h)]
    H = 1e-3                  # second differences: a longer step (round-off of 1 km / H²)
    Q = [m.solve(t).point("coupler", xyz) for t in (th - H, th + H)]
    return close(np.ravel(p), np.ravel(P[1]), atol=1e-9) and \
        close(np.ravel(d1), np.ravel((P[2] - P[0]) / (2 * h)), atol=1e-6) and \
        close(np.ravel(d2), np.ravel((Q[1] - 2 * P[1] + Q[0]) / H ** 2), atol=1e-5)


@valid(V, "slider-crank: displacement against the closed form, 1 km from the origin")
def _():
    th = np.array([0.3, 1.5, 3.0, 4.5])
    pose = slider_crank(shift=(1e3, -2e3, 0.0)).solve(th)
    return close(pose["D"], slider_s(th), atol=1e-9)


@valid(V, "slider-crank with the rod barely longer than the crank (near-singular, regular)")
def _():
    r, l = 0.1, 0.1002
    th = np.array([0.2, 0.5])
    pose = slider_crank(r, l).solve(th)
    return close(pose["D"], slider_s(th, r, l), atol=1e-8)


@valid(V, "slider-crank: velocities and accelerations against the closed form")
def _():
    m, th, w, al = slider_crank(), 0.7, 3.0, -2.0
    pose = m.solve(th)
    lab = m.velocity_labels()
    i = [k for k, s in enumerate(lab) if s.startswith("D")][0]
    h = 1e-4
    ds = (slider_s(th + h) - slider_s(th - h)) / (2 * h)
    d2s = (slider_s(th + h) - 2 * slider_s(th) + slider_s(th - h)) / h ** 2
    v = m.velocities(pose, [w])[0, i]
    a = m.accelerations(pose, [w], [al])[0, i]
    return abs(v - ds * w) < 1e-7 and abs(a - (ds * al + d2s * w * w)) < 1e-5


@valid(V, "solve: integer inputs and numpy integer scalars")
def _():
    p1, p2 = fourbar().solve([0, 1, 2]), fourbar().solve(np.int64(2))
    return close(p1["D"], [fourbar_ref(t) for t in (0, 1, 2)], atol=1e-10) and \
        abs(float(p2["D"]) - fourbar_ref(2.0)) < 1e-10


@valid(V, "Mechanism: links from a tuple and a generator give the same mechanism")
def _():
    a = closure.Mechanism(("x", "y")).links
    b = closure.Mechanism(n for n in ("x", "y")).links
    return a == b == ["ground", "x", "y"]


@valid(V, "Dynamics: holding torque at rest equals dV/dtheta of the closed-form poses")
def _():
    d, th, h = dynamics(), 0.6, 1e-5
    bodies = [("crank", 1.0, (0.0, 0.5, 0.0)), ("coupler", 3.0, (1.5, 1.5, 0.0)), ("rocker", 2.0, (3.0, 1.0, 0.0))]

    def V(t):
        p = fourbar().solve(t)
        return sum(m * 9.81 * float(np.ravel(p.point(link, c))[1]) for link, m, c in bodies)

    df = d.inverse([0.0], [[th]], [[0.0]], [[0.0]])
    tau = float(df.filter(like="drive").iloc[0, 0])
    return abs(tau - (V(th + h) - V(th - h)) / (2 * h)) < 1e-6


@valid(V, "SolverOptions: integer tolerances and numpy scalars accepted")
def _():
    o = closure.SolverOptions(xtol=np.float32(1e-12), rtol=1e-10, maxiter=np.int64(40), max_step=1)
    return abs(float(fourbar().solve(1.0, options=o)["D"]) - fourbar_ref(1.0)) < 1e-10


V = "approx"


@valid(V, "fit: a cubic is reproduced exactly by any knots")
def _():
    an = approx.fit(*cubic(), 0.0, 1.0, knots=[0.0, 0.13, 0.5, 1.0])
    x = np.linspace(0, 1, 101)
    return close(an.position(x), x ** 3, atol=1e-14) and close(an.velocity(x), 3 * x ** 2, atol=1e-13) \
        and close(an.acceleration(x), 6 * x, atol=1e-12)


@valid(V, "fit: a cubic 1e6 from the origin (local forms keep the digits)")
def _():
    s = 1e6
    f = (lambda x: (x - s) ** 3, lambda x: 3 * (x - s) ** 2, lambda x: 6 * (x - s))
    an = approx.fit(*f, s, s + 1.0, n=3)
    x = s + np.linspace(0, 1, 31)
    return close(an.position(x), (x - s) ** 3, atol=1e-9)


@valid(V, "fit: shifting the range by 1000 shifts the knots and keeps the values")
def _():
    s = 1000.0
    f0 = (np.sin, np.cos, lambda x: -np.sin(x))
    f1 = (lambda x: np.sin(x - s), lambda x: np.cos(x - s), lambda x: -np.sin(x - s))
    a0, a1 = approx.fit(*f0, 0.0, 1.5, n=4), approx.fit(*f1, s, s + 1.5, n=4)
    x = np.linspace(0, 1.5, 25)
    return close(a1.knots - s, a0.knots, atol=1e-8) and close(a1.position(x + s), a0.position(x), atol=1e-8)


@valid(V, "fit: millimetre range [0, 1e-3] of a cubic is exact")
def _():
    an = approx.fit(*cubic(), 0.0, 1e-3, n=3)
    x = np.linspace(0, 1e-3, 21)
    return close(an.position(x), x ** 3, rtol=1e-10, atol=1e-22)


@valid(V, "fit_least_squares: a cubic is exact, with and without end conditions")
def _():
    x = np.linspace(0, 2, 17)
    ok = True
    for ec in (True, False):
        an = approx.fit_least_squares(*cubic(), [0.0, 0.7, 2.0], end_conditions=ec)
        ok &= close(an.position(x), x ** 3, atol=1e-12)
    return ok


@valid(V, "fit: interpolation at the knots, F and F' continuous across them")
def _():
    an = approx.fit(np.sin, np.cos, lambda x: -np.sin(x), 0.0, 3.0, delta=1e-3)
    k, e = an.knots[1:-1], 1e-12
    return close(an.acceleration(an.knots), -np.sin(an.knots), atol=1e-13) and \
        close(an.position(k - e), an.position(k + e), atol=1e-11) and \
        close(an.velocity(k - e), an.velocity(k + e), atol=1e-11) and bool(np.all(an.sigma <= 1e-3 * (1 + 1e-6)))


@valid(V, "PiecewiseAnalog: a (3, 4) batch equals one-by-one evaluation")
def _():
    an = analog()
    X = np.linspace(0, 1, 12).reshape(3, 4)
    return close(an.position(X), np.vectorize(lambda v: float(an.position(v)))(X), atol=0) and \
        close(an.acceleration(X), np.vectorize(lambda v: float(an.acceleration(v)))(X), atol=0)


@valid(V, "fit: extrapolate=True continues a cubic exactly beyond the range")
def _():
    an = approx.fit(*cubic(), 0.0, 1.0, n=2, extrapolate=True)
    x = np.array([-0.5, 1.5, 3.0])
    return close(an.position(x), x ** 3, atol=1e-12)


@valid(V, "PiecewiseAnalog.from_values: linear F'' integrates to the cubic")
def _():
    k = np.array([0.0, 0.25, 1.0, 2.0])
    an = approx.PiecewiseAnalog.from_values(k, 6 * k, 0.0, 0.0)
    x = np.linspace(0, 2, 9)
    return close(an.position(x), x ** 3, atol=1e-13)


@valid(V, "default_gamma: 1/(max f'' - min f'') for 6x on [0, 1]; 1 for a constant")
def _():
    return abs(approx.default_gamma(lambda x: 6 * x, 0, 1) - 1 / 6) < 1e-14 and \
        approx.default_gamma(lambda x: 0 * x + 2.0, 0.0, 1.0) == 1.0


@valid(V, "fit: integer range, numpy scalars and n = 4.0 give the same analog as floats")
def _():
    a0 = approx.fit(*cubic(), 0.0, 1.0, n=4)
    a1 = approx.fit(*cubic(), 0, 1, n=4.0)
    a2 = approx.fit(*cubic(), np.float32(0.0), np.int64(1), n=np.int64(4))
    return close(a1.knots, a0.knots, atol=1e-15) and close(a2.knots, a0.knots, atol=1e-15)


@valid(V, "EngineAnalogs: the cylinder against the closed forms f3, psi31, dpsi31")
def _():
    ex = engine_analogs()
    x = np.linspace(0.0, 0.3, 7)
    f, d1, d2 = ex.all(x)
    return close(f, cylinder.f3(x), atol=1e-10) and close(d1, cylinder.psi31(x), rtol=1e-9) and \
        close(d2, cylinder.dpsi31(x), rtol=1e-7, atol=1e-9)


@valid(V, "EngineAnalogs: slider-crank 1 km from the origin against its closed form")
def _():
    ex = approx.EngineAnalogs(slider_crank(shift=(1e3, 1e3, 0.0)), "D", 0.0, 1.0, samples=9)
    x = np.linspace(0, 1, 5)
    return close(ex.position(x), slider_s(x), atol=1e-9)


@valid(V, "force: Q = f' I (f' xdd + f'' xd^2) for a cubic analog")
def _():
    an = analog()
    x, xd, xdd, I = np.array([0.2, 0.7]), np.array([1.0, -2.0]), np.array([3.0, 0.5]), 2.5
    ref = 3 * x ** 2 * I * (3 * x ** 2 * xdd + 6 * x * xd ** 2)
    return close(an.force(x, xd, xdd, I), ref, rtol=1e-12, atol=1e-14)


@valid(V, "TransferDynamics: constant drive on a linear transfer gives uniform acceleration")
def _():
    lin = approx.fit(lambda x: 2 * x, lambda x: 0 * x + 2, lambda x: 0 * x, 0.0, 10.0, n=1)
    td = approx.TransferDynamics(lin, 0.5)
    df = td.simulate([0.0, 1.0], 0.1, 0.2, lambda t, x, xd: 4.0, t_eval=[1.0])
    acc = 4.0 / (0.5 * 4)
    return abs(df.x.iloc[-1] - (0.1 + 0.2 + 0.5 * acc)) < 1e-9 and abs(df.xd.iloc[-1] - (0.2 + acc)) < 1e-9


@valid(V, "TransferDynamics: drive equals the force formula minus the load")
def _():
    td = approx.TransferDynamics(analog(), 1.5, load=lambda t, x, xd: 0.25 * np.ones_like(x))
    x, xd, xdd = 0.4, 1.0, 2.0
    ref = 3 * x ** 2 * 1.5 * (3 * x ** 2 * xdd + 6 * x * xd ** 2) - 0.25
    return close(td.drive(0.0, x, xd, xdd), ref, rtol=1e-12)


@valid(V, "cylinder: f3(0) closed form and drive_law against differences")
def _():
    u = (0.7 ** 2 - 0.7 ** 2 - 0.4 ** 2) / (2 * 0.7 * 0.4)
    t, h = np.array([0.7, 2.2]), 1e-5
    q, qd, qdd = cylinder.drive_law(t)
    qp, qm = cylinder.drive_law(t + h)[0], cylinder.drive_law(t - h)[0]
    return abs(float(cylinder.f3(0.0)) - math.asin(u)) < 1e-15 and close(qd, (qp - qm) / (2 * h), atol=1e-9) \
        and close(qdd, (qp - 2 * q + qm) / h ** 2, atol=1e-5)


V = "stiffness"


@valid(V, "wrench transforms: inverse and T* = T^-T, 100 km away")
def _():
    R, p = rot_ref([1, 2, -1], 0.9), np.array([1e5, -2e5, 3e4])
    T = stiffness.wrench_transform(R, p)
    return close(stiffness.wrench_transform_inverse(R, p) @ T, np.eye(6), atol=1e-9) and \
        close(stiffness.twist_transform(R, p), np.linalg.inv(T).T, rtol=1e-9, atol=1e-9)


@valid(V, "wrench_transform: a force through a point keeps its line")
def _():
    R, p = rot_ref([0, 1, 1], 0.3), np.array([1e3, 0.0, 2.0])
    f, r = np.array([1.0, -2.0, 0.5]), np.array([1e3 + 1.0, 2.0, -1.0])
    W = np.r_[f, np.cross(r, f)]
    ref = np.r_[R @ f, np.cross(R @ (r - p), R @ f)]
    return close(stiffness.wrench_transform(R, p) @ W, ref, atol=1e-9)


@valid(V, "spring_stiffness: one spring along x through the origin")
def _():
    K = stiffness.spring_stiffness([5.0], [[1.0, 0, 0]], [[0.0, 0, 0]])
    ref = np.zeros((6, 6))
    ref[0, 0] = 5.0
    return close(K, ref, atol=1e-15)


@valid(V, "stiffness_matrix: P diag(k) P^T with integer stiffnesses")
def _():
    P = np.random.default_rng(7).normal(size=(6, 6))
    k = np.array([1, 2, 3, 4, 5, 6])
    return close(stiffness.stiffness_matrix(P, k), P @ np.diag(k) @ P.T, rtol=1e-13, atol=1e-13)


@valid(V, "blocks/from_blocks and to/from_moment_first round-trip")
def _():
    return close(stiffness.from_blocks(*stiffness.blocks(K0)), K0, atol=0) and \
        close(stiffness.from_moment_first(stiffness.to_moment_first(K0)), K0, atol=0)


@valid(V, "translational_eigenvalues of an uncoupled K are its force block's")
def _():
    K = np.diag([3.0, 1.0, 2.0, 10.0, 20.0, 30.0])
    return close(np.sort(stiffness.translational_eigenvalues(K)), [1.0, 2.0, 3.0], atol=1e-12)


def _hexapod_far(shift=(0.0, 0.0, 0.0), scale=1.0):
    a = np.radians([0, 100, 120, 220, 240, 340])
    b = np.radians([40, 80, 160, 200, 280, 320])
    base = scale * np.c_[0.8 * np.cos(a), 0.8 * np.sin(a), np.zeros(6)] + shift
    plat = scale * np.c_[0.4 * np.cos(b), 0.4 * np.sin(b), np.zeros(6)]
    T = HEX_POSE.copy()
    T[:3, 3] = scale * T[:3, 3] + shift
    return stiffness.Hexapod(base, plat, 2e7), T


for far in (1e3, 1e5):
    @valid(V, f"Hexapod: the whole machine {far:.0e} m away has the same K in the platform frame")
    def _(far=far):
        h0, T0_ = _hexapod_far()
        h1, T1 = _hexapod_far((far, -far, 0.5 * far))
        K0_, K1 = h0.stiffness(T0_, frame="platform").K, h1.stiffness(T1, frame="platform").K
        return close(K1, K0_, rtol=1e-6, atol=1e-6 * np.abs(K0_).max())


@valid(V, "Hexapod: millimetres instead of metres scale the K blocks by 1, 1e3, 1e6")
def _():
    h0, T0_ = _hexapod_far()
    h1, T1 = _hexapod_far(scale=1e3)
    K, Ks = h0.stiffness(T0_, frame="platform").K, h1.stiffness(T1, frame="platform").K
    S = np.diag([1, 1, 1, 1e3, 1e3, 1e3])
    return close(Ks, S @ K @ S, rtol=1e-9, atol=1e-9 * np.abs(S @ K @ S).max())


@valid(V, "Hexapod: stiffness_batch equals one-by-one stiffness")
def _():
    h = hexapod()
    T = np.stack([HEX_POSE, closure.transform(closure.exp_so3([0.1, 0, 0]), [0, 0.05, 0.75])])
    Kb = h.stiffness_batch(T)[0]
    return close(Kb, np.stack([h.stiffness(t).K for t in T]), rtol=1e-12, atol=1e-3)


@valid(V, "Hexapod: leg forces balance the wrench (P tau = W), and K d = W")
def _():
    h, W = hexapod(), np.array([100.0, -50.0, -5000.0, 20.0, 10.0, -5.0])
    tau = h.leg_forces(HEX_POSE, W)
    d = h.deflection(HEX_POSE, W)
    return close(h.leg_matrix(HEX_POSE) @ tau, W, atol=1e-8) and \
        close(h.stiffness(HEX_POSE).K @ d, W, rtol=1e-8, atol=1e-8)


@valid(V, "Hexapod: integer leg stiffnesses give the float K")
def _():
    K1 = _hex(leg_stiffness=[20000000] * 6).stiffness(HEX_POSE).K
    return close(K1, hexapod().stiffness(HEX_POSE).K, rtol=0, atol=0)


@valid(V, "transform_stiffness: equals T K T^T with the wrench transform")
def _():
    R, p = rot_ref([1, 0, 1], 0.5), np.array([0.3, 1e3, -2.0])
    T = stiffness.wrench_transform(R, p)
    return close(stiffness.transform_stiffness(K0, R, p), T @ K0 @ T.T, rtol=1e-12, atol=1e-9)


V = "synthesis"


@valid(V, "Screw: from_matrix round-trips a 1e-9 rad screw, a half turn and a pure slide")
def _():
    ok = True
    for s in (synthesis.Screw([0.0, 0, 1], [1.0, 2, 0], 1e-9, 0.3),
              synthesis.Screw([0.6, 0.8, 0], [0.0, 0, 5], math.pi - 1e-9, -0.2),
              synthesis.Screw([0.0, 1, 0], [0.0, 0, 0], 0.0, 2.0)):
        ok &= close(synthesis.Screw.from_matrix(s.matrix()).matrix(), s.matrix(), atol=1e-12)
    return ok


@valid(V, "Screw: matrix against Rodrigues about an axis 1 km away")
def _():
    ax, pt, ang, sl = np.array([0.0, 0.6, 0.8]), np.array([1e3, 0.0, 0.0]), 0.7, 0.25
    R = rot_ref(ax, ang)
    ref = closure.transform(R, (np.eye(3) - R) @ pt + sl * ax)
    return close(synthesis.Screw(ax, pt, ang, sl).matrix(), ref, atol=1e-10)


@valid(V, "relative_screw and compose agree with matrix products, 1 km away")
def _():
    off = np.array([1e3, -1e3, 0.0])
    a, b = (synthesis.Screw(s.axis, s.point + off, s.angle, s.slide) for s in SEED[:2])
    r = synthesis.relative_screw(a, b)
    return close(r.matrix() @ a.matrix(), b.matrix(), atol=1e-9) and \
        close(a.compose(b).matrix(), a.matrix() @ b.matrix(), atol=1e-9)   # first b, then a


@valid(V, "inverse_screws: each the inverse matrix")
def _():
    inv = synthesis.inverse_screws(SEED)
    return all(close(i.matrix() @ s.matrix(), np.eye(4), atol=1e-12) for i, s in zip(inv, SEED))


@valid(V, "Line: distance between skew lines and foot of a point, closed form")
def _():
    l1 = synthesis.Line(np.array([0.0, 0, 1]), np.array([0.0, 0, 0]))
    l2 = synthesis.Line(np.array([1.0, 0, 0]), np.array([0.0, 2.5, 7.0]))
    return abs(l1.distance_to(l2) - 2.5) < 1e-14 and close(l1.foot_from([3.0, 4.0, 5.0]), [0.0, 0, 5.0], atol=1e-14)


def _rr_summary(links):
    return sorted((round(float(lk.length), 6), round(abs(float(lk.twist)), 6)) for lk in links)


@valid(V, "rr_links: two links through the seed's positions; same after a 1 km move")
def _():
    L0_ = synthesis.rr_links(SEED[0], SEED[1])
    G = closure.transform(rot_ref([1, 1, 0], 0.4), [1e3, 2e3, -1e3])
    moved = [synthesis.Screw.from_matrix(G @ s.matrix() @ closure.inverse(G)) for s in SEED[:2]]
    L1 = synthesis.rr_links(*moved)
    return len(L0_) == 2 and _rr_summary(L0_) == _rr_summary(L1)


@valid(V, "rr_links: lengths scale with the unit (x1000), twists do not")
def _():
    L0_ = synthesis.rr_links(SEED[0], SEED[1])
    sc = [synthesis.Screw(s.axis, 1e3 * s.point, s.angle, 1e3 * s.slide) for s in SEED[:2]]
    L1 = synthesis.rr_links(*sc)
    a, b = _rr_summary(L0_), _rr_summary(L1)
    return len(b) == 2 and all(abs(x[0] * 1e3 - y[0]) < 1e-3 and abs(x[1] - y[1]) < 1e-6 for x, y in zip(a, b))


@valid(V, "enumerate_dyads: RRR of the seed 1 km away, 36 variants verified by the engine")
def _():
    off = np.array([1e3, 0.0, -1e3])
    far = [synthesis.Screw(s.axis, s.point + off, s.angle, s.slide) for s in SEED]
    df = synthesis.enumerate_dyads("RRR", far)
    res = df.filter(like="residual").to_numpy(float)
    return len(df) == 36 and bool(np.nanmax(res) < 1e-6)


V = "linkwright"


def num(v):
    """A summary figure: a plain number or a quantity ``{"value": ..., "unit": ...}``."""
    return v["value"] if isinstance(v, dict) and "value" in v else v


def _same(x, y, rtol) -> bool:
    x, y = num(x), num(y)
    if isinstance(x, (int, float)) and not isinstance(x, bool) and isinstance(y, (int, float)):
        return math.isclose(x, y, rel_tol=rtol, abs_tol=1e-12)
    if isinstance(x, list) and isinstance(y, list):
        return len(x) == len(y) and all(_same(p, q, rtol) for p, q in zip(x, y))
    return x == y


def _summary_close(a: dict, b: dict, rtol=1e-9) -> bool:
    return a.keys() == b.keys() and all(_same(a[k], b[k], rtol) for k in a if k != "files")


@cache
def _base_summary(command):
    return run_cli(command, STUDIES[command])


@valid(V, "cli approx: integer mass and stroke give the float study's figures")
def _():
    s = _set(_set(STUDIES["approx"], "force.mass", 500), "cylinder.B0", 0.7)
    return _summary_close(run_cli("approx", s), _base_summary("approx"))


@valid(V, "cli approx: knots from the file equal approx.fit's in process")
def _():
    s = _set(_set(STUDIES["approx"], "approx.n", ...), "approx.knots", [0, 0.1, 0.2, 0.3])
    out = run_cli("approx", s)
    ref = approx.fit(cylinder.f3, cylinder.psi31, cylinder.dpsi31, 0.0, 0.3, knots=[0.0, 0.1, 0.2, 0.3])
    return out["intervals"] == 3 and math.isclose(num(out["max_sigma"]), float(ref.sigma.max()), rel_tol=1e-9)


@valid(V, "cli stiffness: the machine and pose moved 1 km give the same figures")
def _():
    s = json.loads(json.dumps(STUDIES["stiffness"]))
    off = [1e3, -1e3, 0.0]
    s["hexapod"]["base_points"] = [[a + o for a, o in zip(p, off)] for p in s["hexapod"]["base_points"]]
    s["pose"]["position"] = [a + o for a, o in zip(s["pose"]["position"], off)]
    s.pop("map")
    s["report"].pop("wrench")
    out, base = run_cli("stiffness", s), _base_summary("stiffness")
    return all(math.isclose(num(out[k]), num(base[k]), rel_tol=1e-7) for k in ("cond_P", "kt_min", "kt_max"))


@valid(V, "cli stiffness: integer leg stiffness and integer points give the float figures")
def _():
    s = _set(STUDIES["stiffness"], "hexapod.leg_stiffness", 20000000)
    s = _set(s, "pose.position", [0, 0, 0.7])
    return _summary_close(run_cli("stiffness", s), _base_summary("stiffness"))


@valid(V, "cli synth: the seed's positions 1 km away give the same ranking")
def _():
    s = json.loads(json.dumps(STUDIES["synth"]))
    for p in s["position"]:
        p["point"] = [p["point"][0] + 1e3, p["point"][1], p["point"][2] - 1e3]
    out, base = run_cli("synth", s), _base_summary("synth")
    return out["variants"] == base["variants"] == 36 and out["regular"] == 36 and \
        out["best_variant"] == base["best_variant"]


@valid(V, "cli analyze: the four-bar 1 km away has the same drive torque")
def _():
    s = json.loads(json.dumps(STUDIES["analyze"]))
    for j in s["mechanism"]["joint"]:
        for k in ("origin", "x_point", "z_point"):
            j[k] = [j[k][0] + 1e3, j[k][1] + 1e3, j[k][2]]
    for b in s["dynamics"]["body"]:
        b["com"] = [b["com"][0] + 1e3, b["com"][1] + 1e3, b["com"][2]]
    s["point"][0]["at"] = [1e3 + 1.5, 1e3 + 1.5, 0.0]
    out, base = run_cli("analyze", s), _base_summary("analyze")
    return out["closed"] == 4 and math.isclose(num(out["max_drive"]), num(base["max_drive"]), rel_tol=1e-6)


@valid(V, "cli analyze: a study file named with spaces and non-ASCII letters")
def _():
    out = run_cli("analyze", STUDIES["analyze"], filename="four bar étude {}.toml")
    return _summary_close(out, _base_summary("analyze"))


# ------------------------------------------------------------------ more valid inputs
@valid("closure", "parallelogram: a sweep through its flat (singular) position stays on its branch")
def _():
    m = closure.Mechanism(["crank", "coupler", "rocker"])
    for n, a, b, q in [("A", "ground", "crank", (0, 0, 0)), ("B", "crank", "coupler", (0, 1, 0)),
                       ("C", "coupler", "rocker", (2, 1, 0)), ("D", "ground", "rocker", (2, 0, 0))]:
        m.add_joint(n, "R", a, b, at=closure.translation(q))
    m.add_input("A")
    th = np.linspace(0, np.pi, 13)          # θ = π/2 is the flat position
    table, pose = m.sweep(th, return_pose=True)
    flat = np.isclose(np.cos(th), 0)        # that row says "near-singular", the others "ok"
    return bool((table.status[flat] == "near-singular").all()
                and (table.status[~flat] == "ok").all()) and len(pose) == th.size and \
        close(pose["D"], th, atol=1e-9) and close(pose["B"], -th, atol=1e-9)   # it translates


@valid("closure", "helical joint 1 km away: a point moves by pitch x angle along the axis")
def _():
    c = np.array([1e3, 0.0, 0.0])
    m = closure.Mechanism(["nut"])
    m.add_joint("H", "H", "ground", "nut", at=closure.translation(c), pitch=0.01)
    m.add_input("H")
    th = np.array([0.5, 10.0, -3.0])
    p = m.solve(th).point("nut", c + [1.0, 0.0, 0.0])
    ref = c + np.c_[np.cos(th), np.sin(th), 0.01 * th]
    return close(p, ref, atol=1e-10)


@valid("approx", "fit: delta = 1e-7 on sin, F'' within the error bound of a broken line")
def _():
    an = approx.fit(np.sin, np.cos, lambda x: -np.sin(x), 0.0, 3.0, delta=1e-7)
    x = np.linspace(0, 3, 3001)
    h = np.diff(an.knots).max()
    return bool(np.all(an.sigma <= 1e-7 * (1 + 1e-6))) and \
        float(np.abs(an.acceleration(x) + np.sin(x)).max()) <= h * h / 8 * 1.0 + 1e-15


@valid("approx", "fit: n = 1 (one interval) of a quadratic F'' gives the chord of f''")
def _():
    f = (lambda x: x ** 4 / 12, lambda x: x ** 3 / 3, lambda x: x ** 2)
    an = approx.fit(*f, 0.0, 2.0, n=1)
    x = np.linspace(0, 2, 9)
    return close(an.acceleration(x), 2 * x, atol=1e-13) and abs(float(an.position(0.0))) < 1e-15


@valid("stiffness", "Hexapod: leg forces balance a wrench at a 40-degree tilted pose")
def _():
    h = hexapod()
    T = closure.transform(closure.rotation([1.0, 0.5, 0.0], np.radians(40)), [0.1, -0.05, 0.6])
    W = np.array([10.0, 20.0, -300.0, 5.0, -4.0, 3.0])
    return close(h.leg_matrix(T) @ h.leg_forces(T, W), W, atol=1e-8)


@valid("synthesis", "Screw.from_degrees: an axis unit to 6 digits equals the normalised axis")
def _():
    a = synthesis.Screw.from_degrees([0.66, 0.043589, 0.75], [0.25, 1.2, -0.289742], 75.0, 0.3)
    ax = np.array([0.66, 0.043589, 0.75])
    b = synthesis.Screw(ax / np.linalg.norm(ax), [0.25, 1.2, -0.289742], np.radians(75.0), 0.3)
    return close(a.matrix(), b.matrix(), atol=1e-15)
