"""Property-based tests of the synthesis package's public API (hypothesis).

Bad inputs raise SynthesisError naming the argument; screws, RR links and the RRR
variant table move with a rigid motion of the whole task (also 1e3–1e6 away from
the origin) and scale with its length unit (1e-13 … 1e8), with the same variant
count and regular flags; a batch verification equals the chains one by one.
"""
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st

from closure import exp_so3
from synthesis import (Line, Screw, SynthesisError, chain_mechanism, enumerate_dyads, families,
                       inverse_screws, invert_chain, relative_screw, rotation_axis_between,
                       rr_links, rrr_dyads, rs_links, verify_chain)
from synthesis import (cc_direction_residual, cc_directions, cc_links, cr_links, helical_links,
                       hh_links_free_pitch,
                       cp_links, pc_links, pr_links, rc_links, rp_links)
from synthesis import (azimuth_of, complete_dyads, hp_links, hs_links, implemented_families,
                       least_squares_dyads, ph_links, ps_links, rs_links_at, sh_links, sp_links,
                       sr_links, task_frame, u_directions, uc_links, uh_links, up_links, ur_links)
from synthesis import assemble, assemble_table, chain_tolerance, link_from_row
from synthesis.dyads import verify_chains
from synthesis.rr import _rot

FAST = settings(max_examples=25, deadline=None, database=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow])

SEED = [Screw.from_degrees([0, 0, 1], [0, 0, 0], 30, 0.7),
        Screw.from_degrees([0.34202, 0, 0.939693], [0, 1.1, 0], 65, 0.5),
        Screw.from_degrees([0.66, 0.043589, 0.75], [0.25, 1.2, -0.289742], 75, 0.3)]
D0 = enumerate_dyads("RRR", SEED)
L0 = Line(np.array([0, 0, 1.0]), np.array([1.0, 0, 0]))
L1 = Line(np.array([1.0, 0, 0]), np.array([0.1, -0.2, 0.3]))
P0 = np.array([0.1, -0.2, 0.3])
LINK = rr_links(SEED[0], SEED[1])[0]
T4 = np.array([np.eye(4)] + [s.matrix() for s in SEED])
SEED5 = SEED + [Screw.from_degrees([0.0, 0.6, 0.8], [0.3, -0.4, 0.5], 50, -0.4)]
G0 = np.array([0.48, 0.6, 0.64])
COAXIAL = [Screw.from_degrees([0, 0, 1], [0.2, 0.1, 0], 40, 0.3),
           Screw.from_degrees([0, 0, 1], [-0.3, 0.5, 0], -70, 0.5)]   # a PR/RP task
HLINK = helical_links(SEED[0], SEED[1], 0.3, -0.2, samples=1000)[0]
SEED7 = SEED5 + [Screw.from_degrees([0.6, 0.0, 0.8], [-0.2, 0.3, 0.1], 40, 0.2),
                 Screw.from_degrees([0.0, 0.8, 0.6], [0.5, 0.1, -0.3], -35, 0.6)]
ROT4 = np.array([np.eye(3)] + [s.matrix()[:3, :3] for s in SEED])
#: screws each function takes (None: any number ≥ 1; (n, None): at least n)
N_SCREWS = {"task_frame": None, "azimuth_of": None, "ps_links": 2, "sp_links": 2,
            "up_links": 2, "rs_links_at": 3, "sr_links": 3, "hs_links": 3, "sh_links": 3,
            "ur_links": 3, "uh_links": 3, "uc_links": 3, "complete_dyads": 4,
            "least_squares_dyads": (3, None), "assemble": (2, None), "assemble_table": (2, None)}


def row_lines(row):
    return [Line(np.array([row[f"j{k}_ux"], row[f"j{k}_uy"], row[f"j{k}_uz"]]),
                 np.array([row[f"j{k}_x"], row[f"j{k}_y"], row[f"j{k}_z"]])) for k in (1, 2, 3)]


def same_line(a: Line, b: Line, tol: float, size: float = 1.0) -> bool:
    """The reference line ``a`` and the computed ``b`` coincide: parallel directions (either
    sense), and a's point (near the task) on b, to ``tol`` (lengths relative to ``size``).
    b's canonical point may lie far along the line (the foot from the origin), where
    any direction error is multiplied by that distance, so b is measured at a's point."""
    return abs(abs(a.direction @ b.direction) - 1) < tol and \
        np.linalg.norm(np.cross(b.direction, a.point - b.point)) < tol * size


def moved(G, line: Line) -> Line:
    return Line(G[:3, :3] @ line.direction, G[:3, :3] @ line.point + G[:3, 3])


# ------------------------------------------------------------------ bad inputs
_RRR = enumerate_dyads("RRR", SEED)
_RRR_ROW = _RRR[_RRR.reason == ""].iloc[0]

CASES = {
    "Screw": (Screw, dict(axis=np.array([0, 0, 1.0]), point=P0, angle=0.5, slide=0.1)),
    "Screw.from_degrees": (Screw.from_degrees, dict(axis=np.array([0, 0, 1.0]), point=P0,
                                                    angle_deg=30.0, slide=0.1)),
    "Screw.from_matrix": (Screw.from_matrix, dict(T=SEED[1].matrix())),
    "Screw.compose": (SEED[0].compose, dict(other=SEED[1])),
    "Line": (Line, dict(direction=np.array([0, 0, 1.0]), point=P0)),
    "Line.transformed": (L0.transformed, dict(T=SEED[1].matrix())),
    "Line.foot_from": (L0.foot_from, dict(x=P0)),
    "Line.canonical": (L0.canonical, dict(previous=L1)),
    "Line.distance_to": (L0.distance_to, dict(other=L1)),
    "relative_screw": (relative_screw, dict(s1j=SEED[0], s1k=SEED[1])),
    "rr_links": (rr_links, dict(s12=SEED[0], s13=SEED[1], tol=1e-9)),
    "RRLink.pose": (LINK.pose, dict(fixed_angle=0.3, moving_angle=-0.2)),
    "rotation_axis_between": (rotation_axis_between, dict(
        m3=np.array([0, 0, 1.0]), q3=np.array([1.0, 0, 0]), m4=np.array([0, 1.0, 0]),
        q4=np.array([0, 1.0, 0.5]))),
    "enumerate_dyads": (enumerate_dyads, dict(family="RRR", screws=SEED)),
    "rrr_dyads": (rrr_dyads, dict(screws=SEED)),
    "rs_links": (rs_links, dict(T=T4, samples=60, tol=1e-9)),
    "inverse_screws": (inverse_screws, dict(screws=SEED)),
    "verify_chain": (verify_chain, dict(types="RRR", lines=[L0, L1, L0],
                                        joint_values=np.zeros((2, 3)),
                                        targets=np.array([np.eye(4), np.eye(4)]), length=1.0)),
    "chain_mechanism": (chain_mechanism, dict(types="RRR", lines=[L0, L1, L0])),
    "invert_chain": (invert_chain, dict(row=D0.iloc[3])),
    "helical_links": (helical_links, dict(s12=SEED[0], s13=SEED[1], fixed_pitch=0.3,
                                          moving_pitch=-0.2, samples=300, tol=1e-9)),
    "BinaryLink.pose": (HLINK.pose, dict(fixed_angle=0.3, fixed_slide=0.0, moving_angle=-0.2,
                                         moving_slide=0.0)),
    "hh_links_free_pitch": (hh_links_free_pitch, dict(s12=SEED[0], s13=SEED[1], fixed_direction=G0)),
    "rc_links": (rc_links, dict(s12=SEED[0], s13=SEED[1], fixed_direction=G0, fixed_pitch=0.0)),
    "cr_links": (cr_links, dict(s12=SEED[0], s13=SEED[1], fixed_direction=G0, moving_pitch=0.1)),
    "cc_links": (cc_links, dict(screws=SEED5, samples=300, tol=1e-9)),
    "cc_links.three": (cc_links, dict(screws=SEED[:2], fixed_axis=L1)),
    "cc_direction_residual": (cc_direction_residual, dict(screws=SEED, fixed_direction=G0)),
    "cc_directions": (cc_directions, dict(screws=SEED, azimuth=0.4)),
    "pr_links": (pr_links, dict(s12=COAXIAL[0], s13=COAXIAL[1])),
    "rp_links": (rp_links, dict(s12=COAXIAL[0], s13=COAXIAL[1])),
    "pc_links": (pc_links, dict(s12=COAXIAL[0], s13=COAXIAL[1], fixed_direction=G0)),
    "cp_links": (cp_links, dict(s12=COAXIAL[0], s13=COAXIAL[1], moving_direction=G0)),
    "cc_links.four": (cc_links, dict(screws=SEED, azimuth=0.4, fixed_point=P0)),
    "task_frame": (task_frame, dict(screws=SEED)),
    "azimuth_of": (azimuth_of, dict(direction=G0, screws=SEED)),
    "rs_links_at": (rs_links_at, dict(screws=SEED, azimuth=0.9, tol=1e-9)),
    "sr_links": (sr_links, dict(screws=SEED, azimuth=0.9, tol=1e-9)),
    "ps_links": (ps_links, dict(screws=SEED[:2], azimuth=0.9, tol=1e-9)),
    "sp_links": (sp_links, dict(screws=SEED[:2], azimuth=0.9, tol=1e-9)),
    "hs_links": (hs_links, dict(screws=SEED, pitch=0.25, azimuth=0.9, tol=1e-9)),
    "sh_links": (sh_links, dict(screws=SEED, pitch=0.25, azimuth=0.9, tol=1e-9)),
    "ur_links": (ur_links, dict(screws=SEED, azimuth=0.9, tol=1e-9)),
    "up_links": (up_links, dict(screws=SEED[:2], slide_azimuth=0.9, axis_azimuth=0.3, tol=1e-9)),
    "uh_links": (uh_links, dict(screws=SEED, pitch=0.25, azimuth=0.9, tol=1e-9)),
    "uc_links": (uc_links, dict(screws=SEED, centre=P0, azimuth=0.9, tol=1e-9)),
    "u_directions": (u_directions, dict(link_rotations=ROT4)),
    "ph_links": (ph_links, dict(s12=SEED[0], pitch=0.25, fixed_direction=G0)),
    "hp_links": (hp_links, dict(s12=SEED[0], pitch=0.25, moving_direction=G0)),
    "complete_dyads": (complete_dyads, dict(chain="CC", screws=SEED5)),
    "least_squares_dyads": (least_squares_dyads, dict(chain="RR", screws=SEED)),
    "implemented_families": (implemented_families, dict()),
    "assemble": (assemble, dict(links=rr_links(SEED[0], SEED[1]), screws=SEED[:2], steps=60,
                                tol=1e-9)),
    "assemble_table": (assemble_table, dict(table=complete_dyads("RR", SEED[:2]),
                                            screws=SEED[:2], steps=60, tol=1e-9)),
    "link_from_row": (link_from_row, dict(row=complete_dyads("RR", SEED[:2]).iloc[0])),
    "chain_tolerance": (chain_tolerance, dict(row=_RRR_ROW, direction_sigma=1e-3,
                                              position_sigma=1e-3, samples=20, length=1.0)),
}
SCREWS, LINES = {"other", "s1j", "s1k", "s12", "s13"}, {"previous", "other_line"}
POSITIVE = {"tol", "length"}


def corruptions(fname, name, value):
    """(kind, bad value) pairs for one argument; every one is invalid for it."""
    common = [("str", "abc"), ("None", None), ("dict", {"a": 1}), ("object", object())]
    if name in ("previous", "fixed_axis") or (name == "other" and fname.startswith("Line")):
        return [k for k in common if k[0] != "None"] + [("screw", SEED[0]), ("array", P0)]
    if name in SCREWS:
        return common + [("line", L0), ("matrix", SEED[0].matrix())]
    if name == "screws" and fname in ("cc_directions", "cc_links.four"):
        return [("str", "abc"), ("None", None), ("one screw", SEED[0]), ("int", 3),
                ("with a matrix", [SEED[0], SEED[1].matrix(), SEED[2]]),
                ("with None", [SEED[0], None, SEED[2]]), ("too few", SEED[:2]),
                ("too many", SEED5)] if fname == "cc_directions" else \
            [("str", "abc"), ("None", None), ("one screw", SEED[0]), ("int", 3),
             ("with a matrix", [SEED[0], SEED[1].matrix(), SEED[2]]),
             ("with None", [SEED[0], None, SEED[2]])]
    if name == "screws" and fname in N_SCREWS:
        n = N_SCREWS[fname]
        out = [("str", "abc"), ("None", None), ("one screw", SEED[0]), ("int", 3),
               ("with a matrix", [SEED[0], SEED[1].matrix()]), ("with None", [SEED[0], None]),
               ("empty", [])]
        if isinstance(n, int):
            out += [("too few", SEED7[:n - 1]), ("too many", SEED7[:n + 1])]
        elif isinstance(n, tuple):
            out += [("too few", SEED7[:n[0] - 1])]
        return out
    if name == "links":
        return [("None", None), ("str", "RR"), ("one link", value[:1]), ("with an int", [value[0], 3])]
    if name == "chain":
        return [("None", None), ("int", 3), ("unknown", "XX"), ("list", ["R", "R"])]
    if name == "screws" and fname.startswith("cc_"):      # 2, 3 or 4 screws are all valid
        return [("str", "abc"), ("None", None), ("one screw", SEED[0]), ("int", 3),
                ("with a matrix", [SEED[0], SEED[1].matrix(), SEED[2]]),
                ("with None", [SEED[0], None, SEED[2]]), ("two positions", SEED[:1]),
                ("six positions", SEED5 + SEED[:1])]
    if name == "screws":
        return [("str", "abc"), ("None", None), ("one screw", SEED[0]), ("int", 3),
                ("with a matrix", [SEED[0], SEED[1].matrix(), SEED[2]]),
                ("with None", [SEED[0], None, SEED[2]])] + \
            ([("too few", SEED[:2]), ("too many", SEED + SEED[:1])] if fname != "inverse_screws"
             else [])
    if name == "family":
        return [("None", None), ("int", 3), ("unknown", "XYZ"), ("unimplemented", "RPR")]
    if name == "types":
        return [("None", None), ("list", ["R", "R", "R"]), ("short", "RR"), ("unknown", "RXR"),
                ("sphere", "RRS")] if fname == "verify_chain" else \
            [("None", None), ("short", "RR"), ("unknown", "RXR"), ("sphere", "RRS")]
    if name == "lines":
        return [("None", None), ("str", "abc"), ("short", [L0, L1]), ("with a screw", [L0, SEED[0], L1])]
    if name == "row":
        r, f = value.copy(), value.copy()
        r["j2_ux"] = np.nan
        f["reason"] = "degenerate positions"
        return [("None", None), ("int", 3), ("missing column", value.drop("j2_uy")),
                ("NaN axis", r), ("failed variant", f), ("dict missing", {"j1_type": "R"})]
    if name == "table":
        return common + [("list", [1.0, 2.0]), ("records", value.to_dict("records")),
                         ("array", np.ones((2, 3)))]
    if name in ("samples", "steps"):
        return [("float", 60.5), ("str", "60"), ("None", None), ("too few", 1), ("bool", True)]
    if isinstance(value, float):
        out = common + [("nan", np.nan), ("inf", np.inf), ("-inf", -np.inf), ("list", [1.0, 2.0]),
                        ("complex", 1 + 2j), ("array", np.ones(3))]
        if name in POSITIVE:
            out += [("zero", 0.0), ("negative", -1.0)]
        return out
    v = np.asarray(value, float)
    out = common + [("complex", v.astype(complex) + 1j), ("ragged", [[1.0, 2.0], [3.0]]),
                    ("scalar", 1.0), ("short", v[..., :-1]), ("long", np.concatenate([v, v[..., :1]], -1)),
                    ("batched", v[None])]
    for bad in (np.nan, np.inf, -np.inf):
        w = v.copy()
        w.flat[w.size // 2] = bad
        out.append((f"{bad}", w))
    if fname == "u_directions":
        w = v.copy()
        w[0] = v[1]
        out += [("first not identity", w), ("not orthonormal", 1.01 * v)]
    if name in ("axis", "direction", "m3", "m4", "fixed_direction", "moving_direction"):
        out += [("zero", np.zeros(3)), ("not unit", 2 * v)]
    if v.shape[-2:] == (4, 4):
        w = v.copy()
        w[..., 3, 1] = 0.25
        out.append(("last row", w))
        w = v.copy()
        w[..., :3, :3] *= 1.01
        out.append(("not orthonormal", w))
        w = v.copy()
        w[..., :3, 0] *= -1
        out.append(("reflection", w))
    if fname == "rs_links" and name == "T":
        w = v.copy()
        w[0] = w[1]
        out.append(("first not identity", w))
        out.append(("three positions", v[:3]))
    if fname == "verify_chain" and name == "joint_values":
        out.append(("rows ≠ targets", np.zeros((3, 3))))
    return out


BAD = [(f, arg, kind) for f, (_, kw) in CASES.items() for arg in kw
       for kind, _ in corruptions(f, arg, kw[arg])]


@settings(FAST, max_examples=150)
@given(st.sampled_from(BAD))
def test_bad_input_raises_synthesis_error_naming_the_argument(case):
    fname, arg, kind = case
    f, kw = CASES[fname]
    bad = dict(corruptions(fname, arg, kw[arg]))[kind]
    with pytest.raises(SynthesisError) as info:
        f(**{**kw, arg: bad})
    assert isinstance(info.value, ValueError)
    assert arg in str(info.value), (fname, arg, kind, str(info.value))


@pytest.mark.parametrize("fname", sorted(CASES))
def test_the_tables_valid_arguments_work(fname):
    """The reference calls of the bad-input table are valid (so each corruption is the
    only thing wrong in its call)."""
    f, kw = CASES[fname]
    f(**kw)


def test_every_public_function_is_covered_by_the_bad_input_table():
    import synthesis
    covered = {name.split(".")[0] for name in CASES} | {
        "RRLink", "RSLink", "BinaryLink", "Assembly", "SynthesisError", "DYAD_COLUMNS", "JOINT_LETTERS", "families",
        "ToleranceResult"}
    assert set(synthesis.__all__) <= covered
    assert families().shape[0] > 0


def test_known_cases():
    """The issue's cases: NaN and wrong shapes into Screw, Line and Screw.from_matrix."""
    with pytest.raises(SynthesisError, match="angle: expected a finite number"):
        Screw([0, 0, 1], P0, np.nan, 0.0)
    with pytest.raises(SynthesisError, match="angle: expected a number"):
        Screw([0, 0, 1], P0, "0.5", 0.0)
    with pytest.raises(SynthesisError, match=r"point: expected finite values, got nan"):
        Line([0, 0, 1], [0, np.nan, 0])
    with pytest.raises(SynthesisError, match=r"T: expected a finite 4x4 rigid transform \(4, 4\), "
                                             r"got shape \(1, 4, 4\)"):
        Screw.from_matrix(np.eye(4)[None])
    bad_row = np.eye(4)
    bad_row[3] = [1, 0, 0, 1]
    with pytest.raises(SynthesisError, match=r"T: last row must be \(0, 0, 0, 1\)"):
        Screw.from_matrix(bad_row)
    with pytest.raises(SynthesisError, match="T: rotation block is not a proper rotation"):
        Screw.from_matrix(np.diag([1, 1, 1.1, 1]))
    with pytest.raises(SynthesisError, match="s12: expected a Screw"):
        rr_links(SEED[0].matrix(), SEED[1])


# ------------------------------------------------------------------ tolerances and scale
def test_rr_and_rrr_residual_checks_are_relative_to_the_task():
    """At 1e8 m a 2e-14 relative error was called ill-conditioned (absolute 1e-6 check),
    and at 1e-13 m the Study products fell under an absolute 1e-14: both now regular."""
    for lam in (1e8, 1e-13):
        scaled = [Screw(s.axis, lam * s.point, s.angle, lam * s.slide) for s in SEED]
        links = rr_links(scaled[0], scaled[1])
        ref = rr_links(SEED[0], SEED[1])
        assert len(links) == 2 and max(l.residual for l in links) < 1e-12
        for a, b in zip(ref, links):
            assert same_line(Line(a.fixed_axis.direction, lam * a.fixed_axis.point),
                             b.fixed_axis, 1e-9, lam)
            assert np.isclose(b.length, lam * a.length, rtol=1e-9)
        df = enumerate_dyads("RRR", scaled)
        assert len(df) == 36 and (df.reason == "").all() and df.residual.max() < 1e-12


@st.composite
def rigid_motions(draw, far=(3.0, 6.0)):
    rv = np.array(draw(st.lists(st.floats(-3, 3), min_size=3, max_size=3)))
    d = np.array(draw(st.lists(st.floats(-1, 1), min_size=3, max_size=3)))
    assume(np.linalg.norm(d) > 0.1)
    G = np.eye(4)
    G[:3, :3] = exp_so3(rv)
    G[:3, 3] = 10 ** draw(st.floats(*far)) * d / np.linalg.norm(d)
    return G


def conjugate(G, screws):
    """The task moved by G: S ↦ G S G⁻¹."""
    Gi = np.linalg.inv(G)
    return [Screw.from_matrix(G @ s.matrix() @ Gi) for s in screws]


@settings(FAST, max_examples=12)
@given(rigid_motions())
@example(np.array([[1.0, 0, 0, 1e6], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]))
def test_rrr_table_moves_with_the_task_far_from_the_origin(G):
    """Conjugating every screw by a rigid motion 1e3–1e6 m away keeps the 36 variants and
    their regular flags, and every axis is the moved one (to round-off of the offset)."""
    d1 = enumerate_dyads("RRR", conjugate(G, SEED))
    assert len(d1) == 36
    assert (d1.reason == "").tolist() == (D0.reason == "").tolist()
    assert d1.residual.max() < 1e-12
    off = np.abs(G[:3, 3]).max()
    for (_, r0), (_, r1) in zip(D0.iterrows(), d1.iterrows()):
        assert all(same_line(moved(G, a), b, 1e-13 * off + 1e-9)
                   for a, b in zip(row_lines(r0), row_lines(r1)))


@settings(FAST, max_examples=10)
@given(st.floats(-13, 8))
@example(-13.0)
@example(8.0)
def test_rrr_table_scales_with_the_length_unit(log_lam):
    lam = 10.0 ** log_lam
    d1 = enumerate_dyads("RRR", [Screw(s.axis, lam * s.point, s.angle, lam * s.slide)
                                 for s in SEED])
    assert len(d1) == 36 and (d1.reason == "").all() and d1.residual.max() < 1e-12
    for (_, r0), (_, r1) in zip(D0.iterrows(), d1.iterrows()):
        assert all(same_line(Line(a.direction, lam * a.point), b, 1e-9, lam)
                   for a, b in zip(row_lines(r0), row_lines(r1)))
        assert np.allclose([r1[f"q{k}_pos{p}"] for k in (1, 2, 3) for p in (1, 2, 3, 4)],
                           [r0[f"q{k}_pos{p}"] for k in (1, 2, 3) for p in (1, 2, 3, 4)],
                           atol=1e-9)


unit_vectors = st.lists(st.floats(-1, 1), min_size=3, max_size=3).map(np.array).filter(
    lambda v: np.linalg.norm(v) > 0.2).map(lambda v: v / np.linalg.norm(v))
points = st.lists(st.floats(-1, 1), min_size=3, max_size=3).map(np.array)


@settings(FAST, max_examples=30)
@given(unit_vectors, points, st.floats(0.05, 3.0), st.floats(-2, 2), rigid_motions(),
       st.floats(-13, 8))
def test_screw_from_matrix_moves_and_scales(axis, point, angle, slide, G, log_lam):
    """from_matrix(G S G⁻¹) is S's axis moved by G with the same angle and slide; lengths
    × λ scale the point and the slide only."""
    s = Screw(axis, point, angle, slide)
    m = Screw.from_matrix(G @ s.matrix() @ np.linalg.inv(G))
    off = np.abs(G[:3, 3]).max()
    assert abs(m.angle - angle) < 1e-9
    sign = np.sign(m.axis @ (G[:3, :3] @ axis))
    assert abs(m.slide - sign * slide) < 1e-15 * off + 1e-9
    assert same_line(moved(G, s.line()), m.line(), 1e-13 * off + 1e-9)
    lam = 10.0 ** log_lam
    sc = Screw.from_matrix(Screw(axis, lam * point, angle, lam * slide).matrix())
    ref = Screw.from_matrix(s.matrix())
    assert abs(sc.slide - lam * ref.slide) <= 1e-12 * lam and np.allclose(sc.axis, ref.axis)
    assert np.allclose(sc.point, lam * ref.point, rtol=0, atol=1e-12 * lam)


_G6 = np.eye(4)
_G6[:3, :3], _G6[:3, 3] = exp_so3(np.array([0.3, -1.2, 2.0])), [4e5, -7e5, 5e5]


@settings(FAST, max_examples=20)
@given(unit_vectors, points, unit_vectors, points, rigid_motions(far=(-1.0, 6.0)),
       st.floats(-12, 8))
@example(np.array([0.6, 0.0, 0.8]), np.array([0.2, -0.5, 0.1]), np.array([0.0, 0.6, -0.8]),
         np.array([-0.4, 0.3, 0.9]), _G6, 8.0)
@example(np.array([0.6, 0.0, 0.8]), np.array([0.2, -0.5, 0.1]), np.array([0.0, 0.6, -0.8]),
         np.array([-0.4, 0.3, 0.9]), _G6, -12.0)
def test_rr_links_move_and_scale_with_the_task(g, gp, w, wp, G, log_lam):
    """A generating RR link is among the two solutions; moving the task by G (up to 1e6 m)
    moves both solutions, scaling it by λ scales them.

    Generic tasks only: a generator whose axes (nearly) intersect gives spherical positions,
    where the RR link is not isolated (tests/synthesis/test_synthesis.py, the spherical
    cases); built from points of size ~1 its task is only as accurate as ε / (axis distance)."""
    assume(abs(g @ w) < 0.95)
    gl, wl = Line(g, gp), Line(w, wp)
    assume(gl.distance_to(wl) > 1e-3 * max(1.0, np.abs(gp).max(), np.abs(wp).max()))
    T2, T3 = _rot(gl, 0.7) @ _rot(wl, -0.4), _rot(gl, -0.5) @ _rot(wl, 1.1)
    try:
        ref = rr_links(Screw.from_matrix(T2), Screw.from_matrix(T3))
    except SynthesisError:
        assume(False)
    assert any(same_line(l.fixed_axis, gl, 1e-7) and same_line(l.moving_axis, wl, 1e-7)
               for l in ref)
    assert all(l.info["accuracy"] < 1e-6 for l in ref)
    Gi = np.linalg.inv(G)
    off = np.abs(G[:3, 3]).max()
    try:
        got = rr_links(Screw.from_matrix(G @ T2 @ Gi), Screw.from_matrix(G @ T3 @ Gi))
    except SynthesisError as e:
        # moved far away, a task that is small against its distance from the origin is
        # spherical to the round-off of its coordinates: only then may it refuse
        assert "spherical" in str(e) and off > 1e6 * gl.distance_to(wl), str(e)
        got = []
    for a, b in zip(ref, got):
        assert same_line(moved(G, a.fixed_axis), b.fixed_axis, 1e-12 * off + 1e-8)
        assert same_line(moved(G, a.moving_axis), b.moving_axis, 1e-12 * off + 1e-8)
        assert b.residual < 1e-10
    lam = 10.0 ** log_lam
    S = np.diag([lam, lam, lam, 1.0])
    Si = np.diag([1 / lam, 1 / lam, 1 / lam, 1.0])
    got = rr_links(Screw.from_matrix(S @ T2 @ Si), Screw.from_matrix(S @ T3 @ Si))
    for a, b in zip(ref, got):
        assert same_line(Line(a.fixed_axis.direction, lam * a.fixed_axis.point), b.fixed_axis,
                         1e-8, lam)
        assert np.isclose(b.length, lam * a.length, rtol=1e-7, atol=1e-9 * lam)
        assert np.allclose(b.fixed_angles, a.fixed_angles, atol=1e-8)


def test_batch_verification_equals_one_by_one():
    """verify_chains (all variants hung from one mechanism, one batched solve) gives each
    row's residual; verify_chain on that row alone gives the same figure, and so does the
    table (whose residual is relative to the task's reach)."""
    from synthesis.validate import task_scale
    ok = D0[D0.reason == ""].iloc[::5]
    _, _, reach = task_scale(T4, [s.axis for s in SEED], [s.point for s in SEED])
    chains, one = [], []
    for _, r in ok.iterrows():
        jv = np.array([[r[f"q{k}_pos{p}"] for k in (1, 2, 3)] for p in (1, 2, 3, 4)])
        chains.append(("RRR", row_lines(r), jv))
        one.append(verify_chain("RRR", row_lines(r), jv, T4, reach))
    batch = verify_chains(chains, T4, reach)
    assert np.allclose(batch, one, rtol=0, atol=1e-15) and max(one) < 1e-12
    assert np.allclose(ok.residual.to_numpy(), one, rtol=0, atol=1e-14)


def test_scaled_sphere_dyads_keep_their_members():
    """PRS through five positions at a 1e-6 m and a 1e5 m scale: same members, regular."""
    from tests.synthesis.test_synthesis import _sphere_positions
    screws, _, _ = _sphere_positions(11, 5, prismatic=True)
    d0 = enumerate_dyads("PRS", screws)
    for lam in (1e-6, 1e5):
        d1 = enumerate_dyads("PRS", [Screw(s.axis, lam * s.point, s.angle, lam * s.slide)
                                     for s in screws])
        assert len(d1) == len(d0) and (d1.reason == "").tolist() == (d0.reason == "").tolist()
        ok = d1.reason == ""
        assert d1[ok].residual.max() < 1e-9
        assert np.allclose(d1[ok][["j3_x", "j3_y", "j3_z"]].to_numpy(),
                           lam * d0[ok][["j3_x", "j3_y", "j3_z"]].to_numpy(), rtol=1e-6,
                           atol=1e-9 * lam)


@settings(FAST, max_examples=25)
@given(st.lists(st.tuples(unit_vectors, points, st.floats(0.05, 3.0), st.floats(-2, 2)),
                min_size=2, max_size=2), rigid_motions(far=(-1.0, 6.0)), st.floats(-8, 8),
       st.integers(1, 3))
def test_task_scales_batch_motion_and_units(screws, G, log_lam, copies):
    """task_scales of a batch equals task_scale of each task; the centre moves with a rigid
    motion (also far from the origin) while the extent stays, and both scale with the
    length unit.  (A task without any length, rotations about concurrent axes, takes its
    reach as its size: excluded by a slide.)"""
    from synthesis.validate import task_scale, task_scales
    assume(max(abs(s[3]) for s in screws) > 1e-2)
    scr = [Screw(u, p, a, s) for u, p, a, s in screws]

    def parts(Gm, lam):
        T = np.array([Gm @ sc.matrix() @ np.linalg.inv(Gm) for sc in scr])
        T[:, :3, 3] *= lam
        U = np.array([Gm[:3, :3] @ sc.axis for sc in scr])
        P = lam * np.array([Gm[:3, :3] @ sc.point + Gm[:3, 3] for sc in scr])
        return T, U, P
    lam = 10.0 ** log_lam
    tasks = [parts(np.eye(4), 1.0), parts(G, 1.0), parts(np.eye(4), lam)]
    c, ext, reach = task_scales(*(np.stack([t[k] for t in tasks] * copies) for k in range(3)))
    for i, t in enumerate(tasks * copies):
        ci, ei, ri = task_scale(*t)
        np.testing.assert_allclose(c[i], ci, rtol=0, atol=1e-12 * max(ri, 1e-300))
        assert abs(ext[i] - ei) <= 1e-12 * ei and abs(reach[i] - ri) <= 1e-12 * ri
    off = np.abs(G[:3, 3]).max() + 1.0
    np.testing.assert_allclose(c[1], G[:3, :3] @ c[0] + G[:3, 3], rtol=0, atol=1e-12 * off)
    assert abs(ext[1] - ext[0]) <= 1e-12 * off
    np.testing.assert_allclose(c[2], lam * c[0], rtol=0,
                               atol=1e-12 * lam * (1 + np.abs(c[0]).max()))
    assert abs(ext[2] - lam * ext[0]) <= 1e-12 * lam * ext[0]
