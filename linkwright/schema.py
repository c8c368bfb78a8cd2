"""The study-file schemas, one per study command, in code (pydantic v2, ``extra="forbid"``).

Validation (:func:`validate`), the reference page (:func:`reference_markdown`,
``linkwright schema CMD``, ``docs/study-files.md``) and the commented starter studies
(:func:`starter`, ``linkwright init CMD``) are all generated from these classes, so a key
is documented exactly as it is checked.  Every key has a type, a unit, a default (or is
required), a meaning and an example.

Errors are translated into :class:`linkwright.study.StudyError`: the file, the dotted key
(``position[1].axis``) and what was expected; an unknown key or section gets a suggestion.
"""
from __future__ import annotations

import difflib
import math
import typing
from typing import Annotated, Literal, Optional, Union

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from .study import StudyError

__all__ = ["SCHEMAS", "COMMANDS", "validate", "reference_markdown", "reference", "starter",
           "example_keys"]

_NO_DEFAULT = object()


class Kind:
    """How a value type reads in messages and in the reference (Annotated metadata)."""

    def __init__(self, text: str):
        self.text = text


Number = Annotated[float, Field(allow_inf_nan=False), Kind("a number")]
Integer = Annotated[int, Kind("an integer")]
Name = Annotated[str, Field(min_length=1), Kind("a non-empty string")]
Vec3 = Annotated[list[Number], Field(min_length=3, max_length=3), Kind("3 numbers [x, y, z]")]
Vec6 = Annotated[list[Number], Field(min_length=6, max_length=6), Kind("6 numbers")]
Points = Annotated[list[Vec3], Field(min_length=1),
                   Kind("a non-empty list of [x, y, z] points")]
Matrix3 = Annotated[list[Vec3], Field(min_length=3, max_length=3),
                    Kind("a 3 × 3 matrix (3 rows of 3 numbers)")]
Names = Annotated[list[Name], Field(min_length=1), Kind("a non-empty list of strings")]
Numbers = Annotated[list[Number], Field(min_length=2), Kind("a list of at least 2 numbers")]
Range = Annotated[list[Number], Field(min_length=3, max_length=3),
                  Kind("[from, to, count]: 3 numbers")]


def F(default=_NO_DEFAULT, doc: str = "", *, unit: str = "", example=None,
      default_text: str | None = None, kind: str | None = None, alias: str | None = None,
      **constraints):
    """A field: default (absent: required), meaning, unit, example; ``default_text`` says
    what an absent optional key means; ``kind`` overrides the type's wording."""
    extra = {"unit": unit, "example": example, "default_text": default_text, "kind": kind}
    args = () if default is _NO_DEFAULT else (default,)
    return Field(*args, description=doc, json_schema_extra=extra, alias=alias, **constraints)


class Section(BaseModel):
    """A table of a study file: unknown keys are errors; types are strict (no "1" for 1)."""

    model_config = ConfigDict(extra="forbid", strict=True, populate_by_name=False)

    def check(self, path) -> None:
        """Rules across sections (a :class:`StudyError` naming the file and the key)."""


# --------------------------------------------------------------------------- common

STUDY_COMMANDS = ("synth", "stiffness", "approx", "analyze")


class StudySection(Section):
    """What the file is: the command that runs it (`linkwright run` dispatches on it)
    and a title for reports and the demo index."""

    command: Optional[Literal[STUDY_COMMANDS]] = F(
        None, "the command that runs this study; `linkwright run FILE` needs it, and the "
        "other commands refuse a study of another kind", example="stiffness",
        default_text="(none: run it with its command)")
    title: Optional[Name] = F(None, "a title for the report and the demo index",
                              example="Hexapod stiffness report",
                              default_text="the file name")


# --------------------------------------------------------------------------- synth

Values = Union[Number, Annotated[list[Number], Field(min_length=1)]]
Vec3s = Union[Vec3, Annotated[list[Vec3], Field(min_length=1)]]
_VALUES = "a number, or a list of numbers (each is enumerated)"
_VEC3S = "[x, y, z], or a list of them (each is enumerated)"


class SynthesisSection(Section):
    """The dyad family to synthesise and its free parameters (the choices of
    `synthesis.enumerate_dyads`): each a value or a list the enumeration runs over; a
    choice the family does not have is an error, an absent one takes its default grid."""

    family: Name = F(doc="dyad family: three joint letters from the ground to the body "
                         "(R, P, C, H, S, U) of seed 001's Table 3 or its reverse; "
                         "`synthesis.families()` lists the 51 families and how many "
                         "positions each takes.  Modes `complete` and `least-squares`: the "
                         "binary link (RR, CC, SS, TS; least squares: RR, CC)", example="RRR")
    mode: Literal["enumerate", "complete", "least-squares"] = F(
        "enumerate", "`enumerate`: every variant of the family's construction (its free "
        "parameters below); `complete`: every real solution of a binary link at its maximal "
        "number of positions (RR 3, CC 5, SS and TS 7) with the count over the complex "
        "numbers; `least-squares`: RR or CC through more positions than that (measured "
        "poses), best fit first", example="complete")
    pitch: Optional[Number] = F(None, "the helical joints' pitch: slide per radian of "
                                "rotation (required by the families with an H joint)",
                                unit="m/rad", example=0.05, default_text="(no helical joint)")
    azimuth_deg: Optional[Values] = F(
        None, "sphere and Hooke families: the main link's body-joint axis lies on the great "
        "circle of this azimuth in the task's reference frame", unit="deg",
        example=[0.0, 45.0, 90.0, 135.0], default_text="0, 45, 90, 135", kind=_VALUES)
    axis_azimuth_deg: Optional[Values] = F(
        None, "RUP, URP: the U joint's first axis on the great circle of this azimuth",
        unit="deg", example=[30.0, 120.0], default_text="30, 120", kind=_VALUES)
    transition_angle_deg: Optional[Values] = F(
        None, "an R transition joint carrying a C joint: the C joint's rotation meanwhile",
        unit="deg", example=[-30.0, 30.0], default_text="the family's grid", kind=_VALUES)
    fixed_direction: Optional[Vec3s] = F(
        None, "main RC, CR, HC, CH links: the fixed axis direction (unit vector or a list)",
        unit="1", example=[0.0, 0.0, 1.0], default_text="4 directions over a hemisphere", kind=_VEC3S)
    slide_direction: Optional[Vec3s] = F(
        None, "main links with a P joint: the slide direction (unit vector or a list)",
        unit="1", example=[1.0, 0.0, 0.0], default_text="4 directions over a hemisphere", kind=_VEC3S)
    prismatic_slide: Optional[Values] = F(
        None, "main PC, CP links: the P joint's slide to the other main position", unit="m",
        example=[0.1, 0.2], default_text="±0.5 × the task's reach", kind=_VALUES)
    centre: Optional[Vec3s] = F(
        None, "RUC, URC: the U joint's centre (a point or a list of points)", unit="m",
        example=[0.0, 0.0, 0.5], default_text="3 points around the task's centre", kind=_VEC3S)


class PositionSection(Section):
    """One displacement S₁ₖ of the body from its first position, as a screw: the body
    turns by `angle_deg` about the axis and slides by `slide` along it.  Three entries
    give the four positions of an RRR dyad."""

    axis: Vec3 = F(doc="unit direction of the screw axis (normalised with a warning when "
                       "within 1e-2 of unit length, an error beyond)", unit="1",
                   example=[0.0, 0.0, 1.0])
    point: Vec3 = F(doc="a point on the screw axis", unit="m", example=[0.0, 0.0, 0.0])
    angle_deg: Number = F(doc="rotation about the axis", unit="deg", example=30.0,
                          ge=-360, le=360)
    slide: Number = F(doc="translation along the axis", unit="m", example=0.7)


class AssembleSection(Section):
    """Mechanisms from the solutions: every combination of `links` regular links of the
    table (modes `complete`, `least-squares`) closed into one mechanism sharing ground and
    body, swept by the engine from position 1 and checked for order, branch and
    dead-point defects (`assemblies.csv`, ranked: no defects first, then transmission)."""

    links: Annotated[int, Field(ge=2, le=6)] = F(2, "links per mechanism (2 RR links: a "
                                                 "Bennett 4R)", example=2)
    drive: Name = F("g1", "the driven joint: `g<i>` the ground joint of link i, `m<i>` its "
                    "moving joint (an R, H or P joint)", example="g1")


class ToleranceSection(Section):
    """Manufacturing tolerances of one variant: every joint axis tilted (two angles) and
    shifted (two lengths, perpendicular to it) at random, the made chain driven by the
    engine to the design's joint values at every position, and the body's error
    distribution reported beside its first-order prediction (`tolerance.csv`)."""

    direction_sigma_deg: Annotated[Number, Field(ge=0)] = F(
        doc="standard deviation of each tilt of every joint axis", unit="deg", example=0.1)
    position_sigma: Annotated[Number, Field(ge=0)] = F(
        doc="standard deviation of each perpendicular shift of every joint axis", unit="m",
        example=1e-4)
    samples: Annotated[int, Field(ge=10, le=1_000_000)] = F(10000, "Monte Carlo samples",
                                                             example=10000)
    seed: Annotated[int, Field(ge=0)] = F(0, "seed of the samples", example=1)
    variant: Optional[Annotated[int, Field(ge=1)]] = F(
        None, "the variant studied", example=1, default_text="the best-ranked variant")
    point: Optional[Vec3] = F(None, "the body point whose displacement is measured (first "
                              "position)", unit="m", example=[0.0, 0.0, 0.0],
                              default_text="the task's centre")


class CriterionSection(Section):
    """How the variants are ranked in the report."""

    kind: Literal["link_length", "axis_distance"] = F(
        "link_length", "`link_length`: total length of the two links (common normals); "
        "`axis_distance`: largest distance of a joint from `center`", example="link_length")
    center: Vec3 = F([0.0, 0.0, 0.0], "the point `axis_distance` measures from", unit="m",
                     example=[0.0, 0.0, 0.0])


class SynthStudy(Section):
    """`linkwright synth`: positions of a body (screws from its first position) → every
    dyad variant, ranked by a design criterion (`variants.csv`, `report.md`, `report.html`)."""

    study: Optional[StudySection] = F(None, "what the file is", default_text="(none)")
    synthesis: SynthesisSection = F(doc="the dyad family")
    position: Annotated[list[PositionSection], Field(min_length=1)] = F(
        doc="the displacements S₁₂ … S₁ₙ from the first position")
    criterion: Optional[CriterionSection] = F(None, "ranking of the variants",
                                              default_text="link_length")
    tolerance: Optional[ToleranceSection] = F(None, "manufacturing tolerances of one variant",
                                              default_text="(none)")
    assemble: Optional[AssembleSection] = F(None, "mechanisms from combinations of the "
                                            "solutions (modes complete, least-squares)",
                                            default_text="(none)")


# --------------------------------------------------------------------------- stiffness

class HexapodSection(Section):
    """The hexapod's geometry and leg stiffness (seed 003)."""

    base_points: Points = F(doc="leg attachment points on the base, base frame", unit="m",
                            example=[[0.8, 0.0, 0.0], [-0.4, 0.69282, 0.0], ["…"]])
    platform_points: Points = F(doc="leg attachment points on the platform, platform "
                                    "frame; one per base point", unit="m",
                                example=[[0.306418, 0.257115, 0.0], ["…"]])
    leg_stiffness: Union[Annotated[Number, Field(gt=0)],
                         Annotated[list[Annotated[Number, Field(gt=0)]], Field(min_length=1)]] \
        = F(doc="axial stiffness of every leg, or one per leg", unit="N/m", example=2.0e7,
            kind="a number > 0, or a list of numbers > 0 (one per leg)")


class PoseSection(Section):
    """The platform's pose in the base frame."""

    position: Vec3 = F(doc="platform origin in the base frame", unit="m",
                       example=[0.0, 0.0, 0.7])
    rotation_deg: Vec3 = F([0.0, 0.0, 0.0], "rotation vector of the platform (axis × "
                           "angle)", unit="deg", example=[0.0, 0.0, 15.0])


class ReportSection(Section):
    """The frame of the stiffness matrix and an optional load case."""

    frame: Literal["platform", "base"] = F(
        "platform", "reference point and axes of K: the platform frame (for a mechanism: the "
        "platform link's axes at `elastic.point`), or the base origin and axes",
        example="platform")
    wrench: Optional[Vec6] = F(None, "load case (f, m) about the base origin: leg forces "
                               "and deflection (for a mechanism: the loaded stiffness and the "
                               "deflection)", unit="N, N·m", example=[0, 0, -5000, 100, 0, 0],
                               default_text="(none: no load case)")


class MapSection(Section):
    """A stiffness map.  A hexapod: over platform positions (the pose's rotation held); an
    axis left out stays at the pose's coordinate; above 2,000,000 poses (or with `blocked`)
    the map runs in blocks of poses on Dask (the scheduler at `DASK_SCHEDULER_ADDRESS`,
    else a local cluster; needs `linkwright[dist]`) and the report holds its summary:
    counts, exact minima and maxima, quantiles, the weakest poses.  A mechanism: over its
    inputs (`inputs`, one range per input), at most 2,000,000 poses."""

    x: Optional[Range] = F(None, "x positions (hexapod): from, to and an integer count ≥ 1",
                           unit="m", example=[-0.15, 0.15, 13], default_text="the pose's x")
    y: Optional[Range] = F(None, "y positions (hexapod): from, to and an integer count ≥ 1",
                           unit="m", example=[-0.15, 0.15, 13], default_text="the pose's y")
    z: Optional[Range] = F(None, "z positions (hexapod): from, to and an integer count ≥ 1",
                           unit="m", example=[0.7, 0.7, 1], default_text="the pose's z")
    inputs: Optional[Annotated[list[Range], Field(min_length=1)]] = F(
        None, "input values (mechanism): one [from, to, count] per input, in the order of "
        "`[[mechanism.input]]`; the map is the grid of all of them", unit="m or rad",
        example=[[-0.03, 0.03, 7], [0.0, 0.0, 1], [0.0, 0.0, 1]],
        default_text="(required for a mechanism's map)",
        kind="a list of [from, to, count], one per input")
    blocked: Optional[Literal["dask", "serial"]] = F(
        None, "run a hexapod's map in blocks and report its summary: on Dask, or one "
        "block after another in this process", example="dask",
        default_text="in blocks on Dask above 2,000,000 poses, else in memory (`map.csv`)")
    block: Annotated[int, Field(ge=1000)] = F(200_000, "poses per block of a blocked map "
                                              "(memory per worker about 1 KB per pose)",
                                              example=200_000)
    parts: Optional[Name] = F(None, "folder for the blocked map's rows, one Parquet part per "
                              "block (relative to the current folder); a stopped run "
                              "resumes from the parts found there with `resume`",
                              example="hexapod-map-parts", default_text="(rows not kept)")
    resume: bool = F(False, "keep the parts already in `parts` (the same map) and compute "
                            "only the missing blocks", example=True)


class HexapodToleranceSection(Section):
    """Manufacturing tolerances of the hexapod: attachment points and leg stiffnesses made
    with random errors, the stiffness indices at the pose sampled and set beside their
    first-order prediction (`tolerance.csv`)."""

    point_sigma: Annotated[Number, Field(ge=0)] = F(
        doc="standard deviation of every coordinate of every attachment point", unit="m",
        example=0.001)
    stiffness_sigma: Annotated[Number, Field(ge=0)] = F(
        0.0, "relative standard deviation of every leg stiffness", unit="1", example=0.05)
    samples: Annotated[int, Field(ge=10, le=1_000_000)] = F(2000, "Monte Carlo samples",
                                                            example=2000)
    seed: Annotated[int, Field(ge=0)] = F(0, "seed of the samples", example=1)


class StiffnessStudy(Section):
    """`linkwright stiffness`: a hexapod (`[hexapod]` and `[pose]`) or any mechanism
    (`[mechanism]` and `[elastic]`: exactly one of the two), a frame and a load → the
    stiffness and compliance matrices, indices, leg forces or the loaded stiffness, and a
    map (`stiffness.csv`, `compliance.csv` (mechanism), `leg_forces.csv` (hexapod),
    `map.csv`, `report.md`, `report.html`)."""

    study: Optional[StudySection] = F(None, "what the file is", default_text="(none)")
    hexapod: Optional[HexapodSection] = F(None, "geometry and leg stiffness",
                                          default_text="(or [mechanism])")
    pose: Optional[PoseSection] = F(None, "the platform pose (with [hexapod])",
                                    default_text="(required with [hexapod])")
    mechanism: Optional["MechanismSection"] = F(None, "any mechanism, built from joints "
                                                "(as in `analyze` studies)",
                                                default_text="(or [hexapod])")
    elastic: Optional["ElasticSection"] = F(None, "platform, springs and pose of the "
                                            "mechanism (with [mechanism])",
                                            default_text="(required with [mechanism])")
    report: Optional[ReportSection] = F(None, "frame and load case",
                                        default_text="platform frame, no load")
    map: Optional[MapSection] = F(None, "a stiffness map", default_text="(no map)")
    tolerance: Optional[HexapodToleranceSection] = F(
        None, "manufacturing tolerances of the hexapod (with [hexapod])",
        default_text="(none)")

    def check(self, path) -> None:
        """Exactly one of `[hexapod]` (with `[pose]`) and `[mechanism]` (with `[elastic]`),
        and the `[map]` keys of that kind."""
        hx, mech = self.hexapod is not None, self.mechanism is not None
        if self.tolerance is not None and not hx:
            raise StudyError(path, "tolerance", "tolerance studies are made of hexapods "
                             "([hexapod]); a mechanism stiffness study has none yet")
        if hx and mech:
            raise StudyError(path, "mechanism", "a stiffness study gives either [hexapod] "
                             "(with [pose]) or [mechanism] (with [elastic]), not both")
        if not hx and not mech:
            raise StudyError(path, "hexapod", "missing: a stiffness study gives [hexapod] "
                             "(with [pose]) or [mechanism] (with [elastic])")
        if hx:
            if self.pose is None:
                raise StudyError(path, "pose", "missing section [pose] (required with "
                                 "[hexapod])")
            if self.elastic is not None:
                raise StudyError(path, "elastic", "[elastic] goes with [mechanism], not "
                                 "with [hexapod]")
            if self.map is not None and self.map.inputs is not None:
                raise StudyError(path, "map.inputs", "a mechanism's key: a hexapod's map "
                                 "takes x, y and z")
        else:
            if self.elastic is None:
                raise StudyError(path, "elastic", "missing section [elastic] (required with "
                                 "[mechanism]: platform, springs and inputs)")
            if self.pose is not None:
                raise StudyError(path, "pose", "[pose] goes with [hexapod]; a mechanism's "
                                 "pose is `elastic.inputs`")
            if self.elastic.springs is None and self.elastic.link is None:
                raise StudyError(path, "elastic.springs", "missing: give joint springs, "
                                 "elastic links ([[elastic.link]]) or both")
            if self.map is not None:
                for k in ("blocked", "parts"):
                    if getattr(self.map, k) is not None:
                        raise StudyError(path, f"map.{k}", "a hexapod's key: a mechanism's "
                                         "map runs in memory (at most 2,000,000 poses)")
                for k in ("x", "y", "z"):
                    if getattr(self.map, k) is not None:
                        raise StudyError(path, f"map.{k}", "a hexapod's key: a mechanism's "
                                         "map takes `inputs` (one [from, to, count] per input)")
                if self.map.inputs is None:
                    raise StudyError(path, "map.inputs", "missing; a mechanism's map takes "
                                     "one [from, to, count] per input")


# --------------------------------------------------------------------------- mechanisms

JOINT_KIND_NAMES = ("R", "P", "C", "H", "U", "S")


class JointSection(Section):
    """A joint between two links; its frame by three points (origin, a point on its X
    axis, a point on its Z axis: the joint axis)."""

    name: Name = F(doc="the joint's name (inputs and outputs refer to it)", example="A")
    kind: Literal[JOINT_KIND_NAMES] = F(doc="R revolute, P prismatic, C cylindrical, H "
                                            "helical, U universal, S spherical", example="R")
    links: Annotated[list[Name], Field(min_length=2, max_length=2)] = F(
        doc="the two links it joins (`ground` is the fixed link)", example=["ground", "crank"],
        kind="2 link names [link_a, link_b]")
    origin: Vec3 = F(doc="origin of the joint frame", unit="m", example=[0.0, 0.0, 0.0])
    x_point: Vec3 = F(doc="a point on the frame's X axis", unit="m", example=[1.0, 0.0, 0.0])
    z_point: Vec3 = F(doc="a point on the frame's Z axis (the joint axis)", unit="m",
                      example=[0.0, 0.0, 1.0])
    pitch: Optional[Number] = F(None, "lead per radian of an H joint (required for H)",
                                unit="m/rad", example=0.001, default_text="(only for H)")


class InputSection(Section):
    """A driven joint coordinate."""

    joint: Name = F(doc="the driven joint", example="A")
    index: Integer = F(0, "which coordinate of the joint (0 for R, P, H)", example=0, ge=0)


class MechanismSection(Section):
    """A mechanism: its moving links, joints and inputs."""

    links: Names = F(doc="the moving links (`ground` is implicit)",
                     example=["crank", "coupler", "rocker"])
    joint: Annotated[list[JointSection], Field(min_length=1)] = F(doc="the joints")
    input: Annotated[list[InputSection], Field(min_length=1)] = F(doc="the inputs")


Stiffnesses = Annotated[dict[Name, Union[Annotated[Number, Field(gt=0)],
                                         Annotated[list[Annotated[Number, Field(gt=0)]],
                                                   Field(min_length=1)]]],
                        Field(min_length=1),
                        Kind("a table {joint or \"joint.coordinate\" = a number > 0, or a list "
                             "of numbers > 0, one per coordinate}")]


class ElasticSection(Section):
    """The mechanism's elastic model and pose for `linkwright stiffness`: which link is the
    platform, the joint springs, the locked joints and the input values.  Joints and
    coordinates without a spring are passive (free), except the locked ones; by default the
    inputs without a spring are locked (actuators held)."""

    platform: Name = F(doc="the link whose stiffness is wanted (the moving platform, the "
                           "tool holder)", example="head")
    springs: Optional[Stiffnesses] = F(
        None, doc="spring of each elastic joint or coordinate (`S0.wx`, `C1.s`, …): one number "
        "for every coordinate of the joint, or one per coordinate; N/m for slides (P, the `s` "
        "of C), N·m/rad for rotations", unit="N/m or N·m/rad",
        example={"P0": 2.0e7, "P1": 2.0e7, "P2": 2.0e7},
        default_text="(none: then at least one `[[elastic.link]]`)")
    link: Optional[Annotated[list["LinkSpringSection"], Field(min_length=1)]] = F(
        None, "elastic links: straight beams, each clamped at one of its joints",
        default_text="(none: the links are rigid)")
    locked: Optional[list[Name]] = F(None, "joints or coordinates held rigidly",
                                     example=["R0"],
                                     default_text="the inputs without a spring",
                                     kind="a list of joint or coordinate names")
    inputs: Annotated[list[Number], Field(min_length=1)] = F(
        doc="the pose: one value per input, in the order of `[[mechanism.input]]` (0 is the "
            "drawn assembly pose)", unit="m or rad", example=[0.01, -0.005, 0.0],
        kind="a list of numbers, one per input")
    point: Optional[Vec3] = F(None, "reference point of K on the platform, given by its world "
                              "coordinates at the assembly pose (the tool centre)", unit="m",
                              example=[0.0, 0.0, 0.35],
                              default_text="the platform link's origin")


PositiveNumber = Annotated[float, Field(allow_inf_nan=False, gt=0), Kind("a number")]


class LinkSpringSection(Section):
    """An elastic link: a straight beam (Euler–Bernoulli, with the P-δ effect of its axial
    force under load) from the origin of the joint it is clamped at to its free end `tip`,
    where the link's other joint is.  Its 6x6 end compliance is a virtual spring in series
    with that joint (the virtual-joint method)."""

    link: Name = F(doc="the elastic link", example="upper0")
    joint: Name = F(doc="the joint of `link` at which the beam is clamped (its root)",
                    example="P0")
    tip: Vec3 = F(doc="the beam's free end (world coordinates at the assembly pose), "
                      "usually the link's other joint", unit="m", example=[0.0, 0.12, 0.35])
    length: Optional[PositiveNumber] = F(
        None, "the beam's length", unit="m", example=0.37,
        default_text="the distance from the joint's origin to `tip`")
    area: PositiveNumber = F(doc="cross-section area A", unit="m²", example=3.0e-4)
    Iy: PositiveNumber = F(doc="second moment of the section about its y axis", unit="m⁴",
                           example=2.5e-8)
    Iz: PositiveNumber = F(doc="second moment of the section about its z axis", unit="m⁴",
                           example=2.5e-8)
    J: PositiveNumber = F(doc="torsion constant of the section", unit="m⁴", example=5.0e-8)
    E: PositiveNumber = F(doc="Young's modulus", unit="Pa", example=2.1e11)
    G: PositiveNumber = F(doc="shear modulus", unit="Pa", example=8.1e10)
    y_axis: Optional[Vec3] = F(None, "direction of the section's y axis (made perpendicular "
                               "to the beam)", unit="1", example=[0.0, 0.0, 1.0],
                               default_text="the world axis most perpendicular to the beam")


ElasticSection.model_rebuild()
StiffnessStudy.model_rebuild()


class SweepSection(Section):
    """The input range of a sweep: `from`/`to` (m or rad) or `from_deg`/`to_deg` for an
    angular input, in `steps` values."""

    from_: Optional[Number] = F(None, "first input value", unit="m or rad", example=0.0,
                                alias="from", default_text="(or from_deg)")
    to: Optional[Number] = F(None, "last input value", unit="m or rad", example=3.14159,
                             default_text="(or to_deg)")
    from_deg: Optional[Number] = F(None, "first input angle", unit="deg", example=0.0,
                                   default_text="(or from)")
    to_deg: Optional[Number] = F(None, "last input angle", unit="deg", example=180.0,
                                 default_text="(or to)")
    steps: Integer = F(doc="number of input values, ends included", example=37, ge=2,
                       le=100_000)


class PointSection(Section):
    """A point on a link whose path, velocity and acceleration analogs are tabulated."""

    name: Name = F(doc="column prefix in `sweep.csv`", example="coupler_mid")
    link: Name = F(doc="the link carrying the point", example="coupler")
    at: Vec3 = F(doc="the point in the first pose (base frame)", unit="m",
                 example=[1.5, 1.5, 0.0])


class BodySection(Section):
    """Mass properties of a link."""

    link: Name = F(doc="the link", example="coupler")
    mass: Number = F(doc="mass", unit="kg", example=3.0, ge=0)
    com: Vec3 = F(doc="centre of mass in the first pose (base frame)", unit="m",
                  example=[1.5, 1.5, 0.0])
    inertia: Optional[Matrix3] = F(None, "inertia tensor about the centre of mass",
                                   unit="kg·m²", example=[[0.1, 0, 0], [0, 0.8, 0], [0, 0, 0.8]],
                                   default_text="point mass")


class DamperSection(Section):
    """Viscous damping of a joint."""

    joint: Name = F(doc="the joint", example="B")
    coefficient: Number = F(doc="damping coefficient", unit="N·s/m or N·m·s/rad",
                            example=0.5, ge=0)


class SpringSection(Section):
    """A linear spring on a joint coordinate."""

    joint: Name = F(doc="the joint", example="B")
    stiffness: Number = F(doc="spring rate", unit="N/m or N·m/rad", example=100.0, ge=0)
    free: Number = F(0.0, "coordinate at which the spring is relaxed", unit="m or rad",
                     example=0.0)


class DynamicsSection(Section):
    """Inverse dynamics along the sweep: the input follows a cycloidal law from the
    sweep's first to its last value in `duration` seconds."""

    gravity: Vec3 = F([0.0, 0.0, -9.81], "gravity in the base frame", unit="m/s²",
                      example=[0.0, -9.81, 0.0])
    duration: Number = F(doc="time for the sweep's input range", unit="s", example=2.0, gt=0)
    body: Annotated[list[BodySection], Field(min_length=1)] = F(doc="mass properties")
    damper: Optional[list[DamperSection]] = F(None, "joint dampers", default_text="(none)")
    spring: Optional[list[SpringSection]] = F(None, "joint springs", default_text="(none)")


class DriveToleranceSection(Section):
    """Manufacturing tolerances of the mechanism's drive force (with `[dynamics]`): every
    joint frame tilted about its X and Y axes and shifted along them at random (a P joint
    tilted only, an S joint shifted along X, Y and Z), each made mechanism driven through
    the same motion, and the drive force's distribution set beside its first-order
    prediction (`drive_tolerance.csv`).  A made mechanism that cannot move (an
    over-constrained design, e.g. a planar linkage with tilted axes) is counted, not
    sampled."""

    direction_sigma_deg: Annotated[Number, Field(ge=0)] = F(
        0.0, "standard deviation of each tilt of every joint frame", unit="deg", example=0.05)
    position_sigma: Annotated[Number, Field(ge=0)] = F(
        0.0, "standard deviation of each shift of every joint frame", unit="m", example=1e-4)
    samples: Annotated[int, Field(ge=10, le=1_000_000)] = F(1000, "Monte Carlo samples",
                                                            example=1000)
    seed: Annotated[int, Field(ge=0)] = F(0, "seed of the samples", example=1)


class AnalyzeStudy(Section):
    """`linkwright analyze`: a mechanism and an input range → the sweep table with point
    paths and analogs and, with `[dynamics]`, the drive force and its tolerances
    (`sweep.csv`, `drive.csv`, `drive_tolerance.csv`, `report.md`, `report.html`)."""

    study: Optional[StudySection] = F(None, "what the file is", default_text="(none)")
    mechanism: MechanismSection = F(doc="the mechanism")
    sweep: SweepSection = F(doc="the input range")
    point: Optional[list[PointSection]] = F(None, "tracked points", default_text="(none)")
    dynamics: Optional[DynamicsSection] = F(None, "inverse dynamics",
                                            default_text="(kinematics only)")
    tolerance: Optional[DriveToleranceSection] = F(
        None, "manufacturing tolerances of the drive force (with [dynamics])",
        default_text="(none)")

    def check(self, path) -> None:
        """`[tolerance]` needs `[dynamics]` and at least one nonzero standard deviation."""
        if self.tolerance is not None:
            if self.dynamics is None:
                raise StudyError(path, "tolerance", "drive-force tolerances need [dynamics] "
                                 "(the masses and the motion's duration)")
            if self.tolerance.direction_sigma_deg == 0 and self.tolerance.position_sigma == 0:
                raise StudyError(path, "tolerance.position_sigma", "give position_sigma or "
                                 "direction_sigma_deg > 0")


# --------------------------------------------------------------------------- approx

class OutputSection(Section):
    """The output coordinate of a mechanism source: f(x) = sign · q + offset."""

    joint: Name = F(doc="the joint whose coordinate is the output", example="D")
    index: Integer = F(0, "which coordinate of the joint", example=0, ge=0)
    offset: Number = F(0.0, "added to the coordinate", unit="m or rad", example=0.0)
    sign: Number = F(1.0, "multiplies the coordinate", unit="1", example=1.0)


class ApproxSection(Section):
    """The function to approximate, its range and the knots: give exactly one of
    `delta`, `n` and `knots`."""

    source: Literal["oscillating_cylinder", "mechanism"] = F(
        doc="`oscillating_cylinder`: seed 004's closed form (`[cylinder]`); `mechanism`: the "
            "closure engine on `[mechanism]` with `[approx.output]`",
        example="oscillating_cylinder")
    a: Number = F(doc="start of the input range", unit="m or rad", example=0.0)
    b: Number = F(doc="end of the input range (> a)", unit="m or rad", example=0.3)
    delta: Optional[Number] = F(None, "largest acceptable error σ of the acceleration analog "
                                "(knots placed to meet it)", unit="as f''", example=0.01,
                                gt=0, default_text="(or n, or knots)")
    n: Optional[Integer] = F(None, "number of intervals, placed to minimise the largest σ",
                             example=4, ge=1, le=1000, default_text="(or delta, or knots)")
    knots: Optional[Numbers] = F(None, "the knots themselves, from a to b", unit="m or rad",
                                 example=[0.0, 0.1, 0.2, 0.3],
                                 default_text="(or delta, or n)")
    gamma: Optional[Number] = F(None, "the end-condition weight γ", unit="1", example=0.5,
                                ge=0, default_text="chosen by the fit's rule")
    output: Optional[OutputSection] = F(None, "the output coordinate (source = mechanism)",
                                        default_text="(required for source = mechanism)")


class CylinderSection(Section):
    """Seed 004's oscillating cylinder (source = oscillating_cylinder)."""

    B: Number = F(0.7, "frame distance B", unit="m", example=0.7, ge=0)
    B0: Number = F(0.7, "cylinder pivot distance B0", unit="m", example=0.7, gt=0)
    B3: Number = F(0.4, "rocker arm B3", unit="m", example=0.4, gt=0)


class ForceSection(Section):
    """The drive force Q = Ψ m L² q̈ for seed 004's drive law q(t)."""

    mass: Number = F(doc="mass of the rocker", unit="kg", example=500.0, ge=0)
    arm: Optional[Number] = F(None, "rocker length L", unit="m", example=0.4, ge=0,
                              default_text="B3 (cylinder), else 1")
    duration: Number = F(5.0, "duration τ of the motion", unit="s", example=5.0, gt=0)
    stroke: Optional[Number] = F(None, "stroke of the drive law, from a (0 < stroke ≤ b − a)",
                                 unit="m", example=0.3, gt=0, default_text="b − a")


class ApproxStudy(Section):
    """`linkwright approx`: a 1-DOF mechanism or seed 004's closed form, a range and
    δ / n / knots → the piecewise-linear analog's coefficients, errors and drive force
    (`coefficients.csv`, `analogs.csv`, `force.csv`, `report.md`, `report.html`)."""

    study: Optional[StudySection] = F(None, "what the file is", default_text="(none)")
    approx: ApproxSection = F(doc="function, range and knots")
    cylinder: Optional[CylinderSection] = F(None, "the closed form's dimensions",
                                            default_text="seed 004's")
    mechanism: Optional[MechanismSection] = F(None, "the mechanism (source = mechanism)",
                                              default_text="(required for source = mechanism)")
    force: Optional[ForceSection] = F(None, "drive force", default_text="(no force)")


SCHEMAS: dict[str, type[Section]] = {"synth": SynthStudy, "stiffness": StiffnessStudy,
                                     "approx": ApproxStudy, "analyze": AnalyzeStudy}
COMMANDS = tuple(SCHEMAS)


# --------------------------------------------------------------------------- introspection

def _fields(cls) -> dict:
    """Key (alias) → FieldInfo, in order."""
    return {(f.alias or name): f for name, f in cls.model_fields.items()}


def _strip(tp):
    """(type without Optional and Annotated, metadata found on the way)."""
    meta = []
    while True:
        if typing.get_origin(tp) is Annotated:
            meta += list(tp.__metadata__)
            tp = typing.get_args(tp)[0]
            continue
        if typing.get_origin(tp) is Union:
            args = [a for a in typing.get_args(tp) if a is not type(None)]
            if len(args) == 1:
                tp = args[0]
                continue
        return tp, meta


def _section_of(field):
    """(Section class, is an array of tables) for a section field, else None."""
    tp, _ = _strip(field.annotation)
    if isinstance(tp, type) and issubclass(tp, Section):
        return tp, False
    if typing.get_origin(tp) is list:
        inner, _ = _strip(typing.get_args(tp)[0])
        if isinstance(inner, type) and issubclass(inner, Section):
            return inner, True
    return None


def _extra(field) -> dict:
    return field.json_schema_extra or {}


def _kind(field) -> str:
    if _extra(field).get("kind"):
        return _extra(field)["kind"]
    tp, meta = _strip(field.annotation)
    for m in reversed(meta + list(field.metadata)):
        if isinstance(m, Kind):
            return m.text
    if typing.get_origin(tp) is Literal:
        return "one of " + ", ".join(map(repr, typing.get_args(tp)))
    return {float: "number", int: "integer", str: "string", bool: "true or false"}.get(tp, str(tp))


def _bounds(field) -> str:
    tp, meta = _strip(field.annotation)
    out = []
    for m in list(field.metadata) + meta:
        for attr, sym in (("gt", ">"), ("ge", "≥"), ("lt", "<"), ("le", "≤")):
            v = getattr(m, attr, None)
            if v is not None and not isinstance(v, bool):
                out.append(f"{sym} {v:g}")
    return ", ".join(out)


# --------------------------------------------------------------------------- validation

_TOML_TYPES = {str: "string", int: "integer", float: "number", bool: "boolean", list: "array",
               dict: "table"}


def _toml_type(v) -> str:
    return _TOML_TYPES.get(type(v), type(v).__name__)


def _show(v, limit: int = 80) -> str:
    s = _toml(v) if isinstance(v, (bool, int, float, str, list)) else \
        ("a table" if isinstance(v, dict) else str(v))
    return s if len(s) <= limit else s[:limit - 1] + "…"


_PRIORITY = {"extra_forbidden": 0, "missing": 0, "finite_number": 1, "greater_than": 2,
             "greater_than_equal": 2, "less_than": 2, "less_than_equal": 2, "literal_error": 3}


def _translate(path, schema, raw, err) -> tuple[str, str]:
    """(dotted key, message) of one pydantic error; in a table of the user's own names
    (:data:`FREE_TABLES`) the message names the entry and shows its value."""
    key, message = _translate_key(path, schema, raw, err)
    n = key.count(".") + 1
    loc = err["loc"]
    if key in FREE_TABLES and "[" not in key:
        value = raw
        for part in key.split("."):
            value = value.get(part) if isinstance(value, dict) else None
        if value != {} and not (len(loc) > n and isinstance(loc[n], str)):
            return key, message
        if value == {}:
            message = message.replace("got a table (table)", "got an empty table")
        elif isinstance(value, dict) and loc[n] in value:
            v = value[loc[n]]
            message = message.replace("got a table (table)", f"got {_show(v)} ({_toml_type(v)})")
            message = message.replace("got a table", f"got {_show(v)}")
            message = f"{loc[n]}: {message}"
    return key, message


def _translate_key(path, schema, raw, err) -> tuple[str, str]:
    """(dotted key, message) of one pydantic error."""
    loc, typ = err["loc"], err["type"]
    cls, parts, value, field, i = schema, [], raw, None, 0
    while i < len(loc):
        part = loc[i]
        fields = _fields(cls)
        if part not in fields:              # an unknown key (or a union member's tag)
            if typ != "extra_forbidden":
                break
            name = str(part)
            v = value.get(name) if isinstance(value, dict) else None
            is_sec = isinstance(v, dict) or (isinstance(v, list) and v and
                                             all(isinstance(x, dict) for x in v))
            known = list(fields)
            near = difflib.get_close_matches(name, known, n=1, cutoff=0.6)
            hint = (f"did you mean '{near[0]}'?" if near else
                    "expected one of " + ", ".join(f"'{k}'" for k in known))
            if name == "grid" and not parts:
                hint = ("a [grid] study runs case by case with `linkwright grid FILE -o OUT` "
                        "(on Dask, or --serial)")
            key = ".".join(parts + [name])
            return key, f"unknown {'section' if is_sec else 'key'}; {hint}"
        field = fields[part]
        parts.append(str(part))
        value = value.get(part) if isinstance(value, dict) else None
        i += 1
        sec = _section_of(field)
        if sec is None:
            break
        sub, is_list = sec
        if is_list:
            if i < len(loc) and isinstance(loc[i], int):
                parts[-1] += f"[{loc[i]}]"
                value = value[loc[i]] if isinstance(value, list) and loc[i] < len(value) else None
                i += 1
            else:
                break
        if i >= len(loc):
            break
        cls, field = sub, None
    key = ".".join(parts)
    if field is None:                       # an error about a whole table
        if typ == "model_type":
            return key, f"expected a table [{key}], got {_toml_type(err['input'])}"
        return key, err["msg"]
    sec = _section_of(field)
    if sec is not None:
        bare = key.split("[")[0] if sec[1] else key
        if typ == "missing":
            return key, (f"missing; expected one or more [[{bare}]]" if sec[1]
                         else f"missing section [{key}]")
        if sec[1] and typ == "too_short":
            return key, f"expected one or more [[{bare}]]"
        return key, (f"expected an array of tables [[{bare}]]" if sec[1]
                     else f"expected a table [{key}], got {_toml_type(value)}")
    unit = _extra(field).get("unit") or ""
    if typ == "missing":
        return key, f"missing; expected {_kind(field)}" + (f" ({unit})" if unit else "")
    got = f", got {_show(value)}"
    if typ == "finite_number":
        return key, f"expected finite numbers (no nan or inf){got}"
    if typ in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        ctx = err.get("ctx") or {}
        sym = {"gt": ">", "ge": "≥", "lt": "<", "le": "≤"}
        bound = " and ".join(f"{sym[k]} {v:g}" for k, v in ctx.items() if k in sym)
        noun = "a length" if unit == "m" else "a value"
        if isinstance(value, list):
            noun = "values"
        return key, f"expected {noun} {bound}" + (f" ({unit})" if unit and unit != "1" else "") \
            + got
    if typ == "literal_error":
        return key, f"expected {_kind(field)}{got}"
    return key, f"expected {_kind(field)}{got} ({_toml_type(value)})"


def validate(path, data: dict, command: str) -> Section:
    """``data`` (a study file's tables) checked against the schema of ``command``.

    Raises
    ------
    StudyError
        The first problem: the file, the dotted key and what was expected.
    """
    schema = SCHEMAS[command]
    try:
        model = schema.model_validate(data)
    except ValidationError as e:
        found = [(_translate(path, schema, data, err), err) for err in e.errors()]
        first_key = found[0][0][0]
        same = [f for f in found if f[0][0] == first_key]
        (key, message), _ = min(same, key=lambda f: _PRIORITY.get(f[1]["type"], 9))
        raise StudyError(path, key, message) from None
    model.check(path)
    return model


def dump(model: Section) -> dict:
    """The validated study as plain tables, defaults filled in, absent optional keys left out."""
    return model.model_dump(by_alias=True, exclude_none=True)


# --------------------------------------------------------------------------- reference

def _toml(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return "…" if v == "…" else '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, float):
        if not math.isfinite(v):
            return str(v)
        if v != 0 and not 1e-4 <= abs(v) < 1e6:
            for p in range(17):
                text = f"{v:.{p}e}"
                if float(text) == v:
                    break
            mant, exp = text.split("e")
            return f"{mant if '.' in mant else mant + '.0'}e{int(exp)}"
        return repr(v)
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_toml(x)}" for k, x in v.items()) + "}"
    if isinstance(v, list):
        if len(v) == 1 and v[0] == ["…"]:
            return "[…]"
        return "[" + ", ".join("…" if x == ["…"] else _toml(x) for x in v) + "]"
    return str(v)


def _default(field) -> str:
    if field.is_required():
        return "required"
    text = _extra(field).get("default_text")
    if text:
        return text
    return _toml(field.default)


def _walk(cls, prefix=""):
    """(dotted key, FieldInfo, Section class holding it, section info) in schema order."""
    for key, f in _fields(cls).items():
        full = prefix + key
        yield full, f, cls
        sec = _section_of(f)
        if sec is not None:
            yield from _walk(sec[0], full + ".")


def reference(command: str, level: int = 2) -> str:
    """The Markdown reference of one study kind."""
    schema = SCHEMAS[command]
    h = "#" * level
    out = [f"{h} `{command}` studies", "", _doc(schema), ""]
    tables = [("", schema, False, None)]
    for key, f, _ in _walk(schema):
        sec = _section_of(f)
        if sec is not None:
            tables.append((key, sec[0], sec[1], f))
    for key, cls, is_list, f in tables:
        if not key:
            continue
        head = f"[[{key}]]" if is_list else f"[{key}]"
        parent = key.rsplit(".", 1)[0] if "." in key else ""
        need = "required" if f.is_required() else "optional"
        if f.is_required() and parent:
            need += f" in `[{parent}]`"
        if is_list and f.is_required():
            need += ", one or more"
        out += [f"{h}# `{head}` ({need})", "", _doc(cls), "",
                "| key | type | unit | default | meaning | example |",
                "|---|---|---|---|---|---|"]
        for name, g in _fields(cls).items():
            if _section_of(g) is not None:
                continue
            typ = _kind(g) + (f" ({_bounds(g)})" if _bounds(g) else "")
            ex = command if (key, name) == ("study", "command") else _extra(g).get("example")
            out.append(f"| `{key}.{name}` | {typ} | {_extra(g).get('unit') or ''} | "
                       f"{_default(g)} | {g.description} | "
                       f"`{name} = {_toml(ex)}` |")
        out.append("")
    return "\n".join(out)


def _doc(cls) -> str:
    import inspect
    return " ".join(inspect.getdoc(cls).split())


def reference_markdown() -> str:
    """The whole study-file reference (``docs/study-files.md``), generated from the schemas."""
    intro = [
        "# Study files", "",
        "<!-- generated by linkwright.schema.reference_markdown(); do not edit: run "
        "`python -c \"import linkwright.schema as s; print(s.reference_markdown(), end='')\" "
        "> docs/study-files.md` -->", "",
        "A study is a TOML file run by one command: `linkwright synth`, `stiffness`, "
        "`approx` or `analyze`, or `linkwright run FILE`, which reads the command from "
        "`[study].command`. `linkwright schema CMD` prints the part of this page for one "
        "command, and `linkwright init CMD -o FILE` writes a commented starter study.", "",
        "Rules for every study:", "",
        "- Unknown keys and sections are errors (exit status 2) naming the file and the "
        "dotted key, with a suggestion: `hexapod.toml: key 'pose.rotation_degs': unknown "
        "key; did you mean 'rotation_deg'?`.",
        "- Types are strict: a number may be written as an integer (`2` for `2.0`) but not as "
        "a string or a boolean; an integer key refuses `2.0`. `nan` and `inf` are refused "
        "(\"expected finite numbers\").",
        "- Units are SI (m, kg, s, N) with angles in degrees where the key ends in `_deg` "
        "and in radians elsewhere.",
        "- `[study].command`, when given, must match the command that runs the file.", ""]
    body = [reference(c) for c in COMMANDS]
    return "\n".join(intro) + "\n" + "\n".join(body).rstrip("\n") + "\n"


#: keys whose value is a table of the user's own names (joints → stiffness), not sections
FREE_TABLES = {"elastic.springs"}


def example_keys(data: dict, prefix: str = "") -> set[str]:
    """Every dotted key (tables and values) used by a study's data (the entries of a
    table of the user's own names, :data:`FREE_TABLES`, are not keys of the schema)."""
    out = set()
    for k, v in data.items():
        full = prefix + k
        out.add(full)
        if isinstance(v, dict) and full not in FREE_TABLES:
            out |= example_keys(v, full + ".")
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            for x in v:
                out |= example_keys(x, full + ".")
    return out


# --------------------------------------------------------------------------- starters

#: the shipped example each starter study is made from
STARTER_EXAMPLES = {"synth": "seed001_rrr.toml", "stiffness": "hexapod.toml",
                    "approx": "seed004_cylinder.toml", "analyze": "fourbar_dynamics.toml"}


def _comment(f) -> str:
    unit = _extra(f).get("unit")
    return f"  # {f.description}" + (f" ({unit})" if unit and unit != "1" else "")


def _emit(cls, data: dict, prefix: str, out: list[str], explain: bool = True) -> None:
    fields = _fields(cls)
    for name, f in fields.items():
        if _section_of(f) is not None:
            continue
        if name in data:
            line = f"{name} = {_toml(data[name])}"
            if explain and len(line + _comment(f)) > 100:
                out.append(_comment(f).strip())
            elif explain:
                line += _comment(f)
            out.append(line)
        elif explain:
            v = f.default if not f.is_required() and f.default is not None \
                else _extra(f).get("example")
            if isinstance(v, list) and any(x == ["…"] for x in v):
                continue
            text = _default(f)
            note = "" if f.default is not None or text.startswith("(") else \
                f"; if absent: {text}"
            line = f"# {name} = {_toml(v)}"
            if len(line + _comment(f) + note) > 100:
                out += [(_comment(f) + note).strip(), line]
            else:
                out.append(line + _comment(f) + note)
    for name, f in fields.items():
        sec = _section_of(f)
        if sec is None:
            continue
        full = prefix + name
        if name not in data:
            out += ["", f"# [{'[' + full + ']' if sec[1] else full}]{' ' * 2}# optional: "
                        f"{f.description}; see `linkwright schema`"]
            continue
        for i, entry in enumerate(data[name] if sec[1] else [data[name]]):
            out += ["", f"[[{full}]]" if sec[1] else f"[{full}]"]
            if i == 0:
                out.append(f"# {_doc(sec[0])}")
            _emit(sec[0], entry, full + ".", out, explain and i == 0)


def starter(command: str) -> str:
    """A commented starter study for ``command``: a shipped example with every key
    explained and the optional keys commented out; it validates and runs as it is."""
    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        import tomli as tomllib
    from . import examples
    data = tomllib.loads((examples.folder() / STARTER_EXAMPLES[command]).read_text("utf-8"))
    data.setdefault("study", {})["command"] = command
    schema = SCHEMAS[command]
    out = [f"# A starter {command} study: edit it, then `linkwright run FILE -o OUT`.",
           f"# {_doc(schema)}",
           f"# Every key: `linkwright schema {command}`.  Lines starting with # are "
           "optional keys (shown with their default) or comments."]
    _emit(schema, data, "", out)
    return "\n".join(_wrap(out)) + "\n"


def _wrap(lines: list[str], width: int = 100):
    """Long comment-only lines wrapped at ``width``."""
    import textwrap
    for ln in lines:
        if ln.startswith("# ") and len(ln) > width and " = " not in ln:
            yield from textwrap.wrap(ln, width, subsequent_indent="# ")
        else:
            yield ln
