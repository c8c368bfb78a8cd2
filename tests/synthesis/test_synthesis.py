import numpy as np
import pytest

from closure import exp_se3
from synthesis import (DYAD_COLUMNS, Line, Screw, SynthesisError, enumerate_dyads, families,
                       inverse_screws, invert_chain, relative_screw, rr_links, verify_chain)
from synthesis.rr import _rot

SEED = [Screw.from_degrees([0, 0, 1], [0, 0, 0], 30, 0.7),
        Screw.from_degrees([0.34202, 0, 0.939693], [0, 1.1, 0], 65, 0.5),
        Screw.from_degrees([0.66, 0.043589, 0.75], [0.25, 1.2, -0.289742], 75, 0.3)]


def rows_lines(row):
    return [Line(np.array([row[f"j{k}_ux"], row[f"j{k}_uy"], row[f"j{k}_uz"]]),
                 np.array([row[f"j{k}_x"], row[f"j{k}_y"], row[f"j{k}_z"]])) for k in (1, 2, 3)]


def same_line(a: Line, b: Line, tol=1e-7):
    return abs(abs(a.direction @ b.direction) - 1) < tol and a.distance_to(b) < tol * 10 and \
        np.linalg.norm(np.cross(a.direction, b.point - a.point)) < tol * 10


# ------------------------------------------------------------------ screws
def test_screw_roundtrip_identity_and_translation():
    rng = np.random.default_rng(0)
    for _ in range(20):
        T = exp_se3(rng.normal(size=6))
        assert np.allclose(Screw.from_matrix(T).matrix(), T, atol=1e-12)
    s = Screw.from_matrix(np.eye(4))
    assert s.angle == 0 and s.slide == 0
    T = np.eye(4)
    T[:3, 3] = [0, 3, 4]
    s = Screw.from_matrix(T)
    assert s.angle == 0 and np.isclose(s.slide, 5) and np.allclose(s.axis, [0, 0.6, 0.8])
    with pytest.raises(SynthesisError, match="length 2 is not 1"):
        Screw([0, 0, 2], [0, 0, 0], 0.1, 0)
    # the seed's axes are unit to 6 digits: normalised silently
    assert np.isclose(np.linalg.norm(SEED[2].axis), 1.0)
    r = relative_screw(SEED[0], SEED[1])
    assert np.allclose(r.matrix() @ SEED[0].matrix(), SEED[1].matrix())


# ------------------------------------------------------------------ RR
def test_rr_links_two_solutions_reach_three_positions():
    links = rr_links(SEED[0], SEED[1])
    assert len(links) == 2
    T = [np.eye(4), SEED[0].matrix(), SEED[1].matrix()]
    for link in links:
        for k in range(3):
            P = link.pose(link.fixed_angles[k], link.moving_angles[k])
            assert np.abs(P - T[k]).max() < 1e-12
    # Suh: the two RR links make a Bennett linkage (equal length and twist)
    assert np.isclose(links[0].length, links[1].length) and np.isclose(links[0].twist,
                                                                       links[1].twist)


def test_rr_recovers_a_generating_link():
    rng = np.random.default_rng(5)
    g = Line(rng.normal(size=3) / np.linalg.norm(rng.normal(size=3)) if False else
             (lambda v: v / np.linalg.norm(v))(rng.normal(size=3)), rng.normal(size=3))
    w = Line((lambda v: v / np.linalg.norm(v))(rng.normal(size=3)), rng.normal(size=3))
    T2 = _rot(g, 0.7) @ _rot(w, -0.4)
    T3 = _rot(g, -0.5) @ _rot(w, 1.1)
    links = rr_links(Screw.from_matrix(T2), Screw.from_matrix(T3))
    assert any(same_line(l.fixed_axis, g) and same_line(l.moving_axis, w) for l in links)


# ------------------------------------------------------------------ RRR variants
def test_seed_example_all_36_variants_reach_all_positions():
    df = enumerate_dyads("RRR", SEED)
    assert len(df) == 36 and set(DYAD_COLUMNS) <= set(df.columns)
    assert (df.reason == "").all()
    assert df.residual.max() <= 1e-9
    # orderings: 3 RR triples × 3 transition positions, each × 2 RR × 2 mechanisms
    assert df.order.nunique() == 9 and (df.groupby("order").size() == 4).all()
    assert set(df.mechanism) == {"a", "b"} and set(df.rr) == {0, 1}
    # axes are unit; the first joint's point is the foot from the origin
    for k in (1, 2, 3):
        u = df[[f"j{k}_ux", f"j{k}_uy", f"j{k}_uz"]].to_numpy()
        assert np.allclose(np.linalg.norm(u, axis=1), 1)
    p1 = df[["j1_x", "j1_y", "j1_z"]].to_numpy()
    u1 = df[["j1_ux", "j1_uy", "j1_uz"]].to_numpy()
    assert np.abs(np.sum(p1 * u1, 1)).max() < 1e-12


def _random_rrr(seed):
    rng = np.random.default_rng(seed)
    unit = lambda v: v / np.linalg.norm(v)
    L = [Line(unit(rng.normal(size=3)), rng.normal(size=3)) for _ in range(3)]
    q = np.zeros((4, 3))
    q[1, 1:] = rng.uniform(-1.2, 1.2, 2)
    q[2, 1:] = rng.uniform(-1.2, 1.2, 2)
    q[3] = [rng.uniform(0.4, 1.2), q[2, 1], rng.uniform(-1.2, 1.2)]   # from position 3 to 4
    T = [_rot(L[0], a) @ _rot(L[1], b) @ _rot(L[2], c) for a, b, c in q]
    return L, [Screw.from_matrix(t) for t in T[1:]]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_generating_chain_is_among_the_variants(seed):
    L, screws = _random_rrr(seed)
    df = enumerate_dyads("RRR", screws)
    ok = df[df.reason == ""]
    assert ok.residual.max() <= 1e-9
    found = [all(same_line(a, b, 1e-6) for a, b in zip(rows_lines(r), L)) for _, r in ok.iterrows()]
    assert any(found)


def test_invariance_under_rigid_motion_and_scale():
    G = exp_se3(np.array([3.0, -2.0, 5.0, 0.3, 0.8, -0.5]))
    lam = 7.5
    moved = [Screw.from_matrix(G @ s.matrix() @ np.linalg.inv(G)) for s in SEED]
    scaled = [Screw(s.axis, lam * s.point, s.angle, lam * s.slide) for s in SEED]
    d0 = enumerate_dyads("RRR", SEED)
    for screws, f in ((moved, lambda ln: ln.transformed(G)),
                      (scaled, lambda ln: Line(ln.direction, lam * ln.point))):
        d1 = enumerate_dyads("RRR", screws)
        assert d1.residual.max() <= 1e-9
        for (_, r0), (_, r1) in zip(d0.iterrows(), d1.iterrows()):
            assert all(same_line(f(a), b, 1e-6) for a, b in zip(rows_lines(r0), rows_lines(r1)))


def test_hard_cases_accurate_or_clear():
    with pytest.raises(SynthesisError, match="pure translation"):
        rr_links(Screw([1, 0, 0], [0, 0, 0], 0.0, 0.5), SEED[1])
    with pytest.raises(SynthesisError, match="parallel"):
        rr_links(Screw([0, 0, 1], [0, 0, 0], 0.3, 0.1), Screw([0, 0, 1], [1, 0, 0], 0.5, 0.2))
    with pytest.raises(SynthesisError, match=r"rotates by 1\.0e-08 rad"):
        rr_links(Screw([0, 0, 1], [0, 0, 0], 1e-8, 0.7), SEED[1])
    with pytest.raises(SynthesisError, match="coincide"):
        rr_links(Screw([0, 0, 1], [0, 0, 0], 0.0, 0.0), SEED[1])
    with pytest.raises(SynthesisError, match="coincide"):
        rr_links(SEED[1], SEED[1])
    # positions 2 and 3 coincide: degenerate variants are kept with their reason, not dropped:
    # the RR triple (1, 2, 3) (12 rows) and the transitions 2 → 3 and 3 → 2 (4 rows each)
    screws = [SEED[0], SEED[0], SEED[2]]
    df = enumerate_dyads("RRR", screws)
    assert len(df) == 36 and (df.reason.str.contains("coincide")).sum() == 20
    assert df[df.reason == ""].residual.max() <= 1e-9
    # far from the origin (×1000 offsets): same accuracy, axes shifted
    off = np.array([1000.0, -1000.0, 1000.0])
    far = [Screw(s.axis, s.point + off, s.angle, s.slide) for s in SEED]
    d0, d1 = enumerate_dyads("RRR", SEED), enumerate_dyads("RRR", far)
    assert d1.residual.max() <= 1e-9
    shift = np.eye(4)
    shift[:3, 3] = off
    for (_, r0), (_, r1) in zip(d0.iterrows(), d1.iterrows()):
        assert all(same_line(a.transformed(shift), b, 1e-6)
                   for a, b in zip(rows_lines(r0), rows_lines(r1)))


# ------------------------------------------------------------------ spherical positions
# The property test's falsifying example: a generating RR whose axes meet (g through gp
# passes through the origin, where the moving axis w does), so every position is a
# rotation about one point.
_G, _GP, _W = np.array([0.6, 0.8, 0.0]), np.array([0.75, 1.0, 0.0]), np.array([0.0, 0.0, 1.0])
_N = np.cross(_G, _W) / np.linalg.norm(np.cross(_G, _W))


def _spherical_task(centre, delta, R=np.eye(3)):
    """The generator (fixed axis, moving axis) with the moving axis ``delta`` off the common
    point (along the common normal), the whole moved so the point is at ``centre``, and its
    positions 2, 3 as screws."""
    gl = Line(R @ _G, R @ _GP + centre)
    wl = Line(R @ _W, R @ (delta * _N) + centre)
    T2, T3 = _rot(gl, 0.7) @ _rot(wl, -0.4), _rot(gl, -0.5) @ _rot(wl, 1.1)
    return gl, wl, Screw.from_matrix(T2), Screw.from_matrix(T3)


def _axis_error(ref: Line, got: Line, centre, size):
    """Direction error (rad) and distance of ref's point nearest the task from got / size."""
    p = ref.foot_from(centre)
    return max(np.linalg.norm(np.cross(ref.direction, got.direction)),
               np.linalg.norm(np.cross(got.direction, p - got.point)) / size)


_ROT = exp_se3(np.array([0.3, -1.2, 2.0, 0, 0, 0]))[:3, :3]


@pytest.mark.parametrize("centre, R", [((0.0, 0.0, 1.0), np.eye(3)),
                                       ((3e3, -2e3, 1e3), _ROT), ((-0.4, 0.2, 0.7), _ROT)])
def test_spherical_positions_raise_naming_the_point(centre, R):
    """Concurrent screw axes without slides (a spherical RR generator): the RR link is not
    isolated (a two-parameter family of spherical RRs), so rr_links says so and names the
    common point; the RRR rows that use it carry that reason."""
    centre = np.array(centre)
    _, _, s12, s13 = _spherical_task(centre, 0.0, R)
    with pytest.raises(SynthesisError, match=r"the positions are spherical \(to within "
                                             r"round-off\): all relative screws are pure "
                                             r"rotations about one point") as info:
        rr_links(s12, s13)
    msg = str(info.value)
    assert "not isolated" in msg
    point = np.array([float(v) for v in msg.split("one point (")[1].split(")")[0].split(",")])
    assert np.allclose(point, centre, rtol=0, atol=1e-9 * max(1.0, np.abs(centre).max()))
    s14 = Screw.from_matrix(_rot(Line(R @ _G, R @ _GP + centre), 1.3)
                            @ _rot(Line(R @ _W, centre), 0.6))
    df = enumerate_dyads("RRR", [s12, s13, s14])
    assert len(df) == 36 and df.reason.str.contains("positions are spherical").all()


def test_exactly_spherical_screws_raise():
    """Scale-free screws (pure rotations about axes through the origin, no length at all)."""
    s12 = Screw([0, 0, 1], [0, 0, 0], 0.7, 0.0)
    s13 = Screw(np.array([1.0, 1.0, 1.0]) / np.sqrt(3), [0, 0, 0], 0.5, 0.0)
    with pytest.raises(SynthesisError, match=r"spherical \(exactly\).*one point \(0, 0, 0\)"):
        rr_links(s12, s13)


def test_spherical_at_the_origin_is_a_tiny_task():
    """The same generator about the origin, from points of size 1: the screws keep only a
    round-off remainder of translation (~1e-17), which as data is a generic task of that size
    (unit invariance forbids an absolute floor). Its own two links are returned and reach
    the given positions; they are not the generator, which these data do not determine."""
    from synthesis.validate import task_scale
    _, _, s12, s13 = _spherical_task(np.zeros(3), 0.0)
    _, L, _ = task_scale([s12.matrix(), s13.matrix()], [s12.axis, s13.axis],
                         [s12.point, s13.point])
    assert L < 1e-15
    links = rr_links(s12, s13)
    assert len(links) == 2 and max(l.residual for l in links) < 1e-12


@pytest.mark.parametrize("centre, R", [((0.0, 0.0, 1.0), np.eye(3)),
                                       ((3e3, -2e3, 1e3), _ROT)])
def test_nearly_spherical_positions_are_accurate_or_raise(centre, R):
    """As the generator's axes approach each other (distance δ → 0) the task shrinks to its
    centre while its coordinates keep their round-off: the links are known to ~ε·reach/L.
    rr_links either returns the generator to within its stated accuracy (≤ 1e-6), or raises
    naming the positions spherical; never a silently wrong link."""
    from synthesis.validate import task_scale
    centre = np.array(centre)
    returned, raised = [], []
    for k in range(0, 17):
        delta = 10.0 ** -k
        gl, wl, s12, s13 = _spherical_task(centre, delta, R)
        c, L, reach = task_scale([s12.matrix(), s13.matrix()], [s12.axis, s13.axis],
                                 [s12.point, s13.point])
        try:
            links = rr_links(s12, s13)
        except SynthesisError as e:
            assert "positions are spherical" in str(e), str(e)
            raised.append(delta)
            continue
        returned.append(delta)
        acc = max(l.info["accuracy"] for l in links)
        assert acc <= 1e-6
        err = min(max(_axis_error(gl, l.fixed_axis, c, L), _axis_error(wl, l.moving_axis, c, L))
                  for l in links)
        assert err <= 10 * acc, (delta, err, acc)
    # one switch, where the estimate (≳ ε·reach/L, L ≈ 0.42 δ, reach ≈ 1 or 3e3) passes 1e-6:
    # measured, δ = 1e-7 (err 9e-9) still returns about (0, 0, 1), δ = 1e-3 (err 3e-9) far away
    assert returned and raised and min(returned) > max(raised)
    assert min(returned) <= (1e-6 if centre[2] == 1.0 else 1e-2)
    assert max(raised) >= (1e-10 if centre[2] == 1.0 else 1e-6)


def test_kinematic_inversion_reaches_the_inverse_positions():
    df = enumerate_dyads("RRR", SEED)
    inv = invert_chain(df.iloc[5])
    targets = [np.eye(4)] + [s.matrix() for s in inverse_screws(SEED)]
    jv = np.array([[inv[f"q{k}_pos{p}"] for k in (1, 2, 3)] for p in (1, 2, 3, 4)])
    lines = rows_lines(inv)
    assert verify_chain("RRR", lines, jv, np.array(targets), 1.0) <= 1e-9
    assert inv["family"] == "RRR" and inv["order"].startswith("inverse of")


def test_families_table_and_unimplemented_family():
    f = families()
    assert {"family", "seed", "binary_links", "N", "N_max", "implemented"} <= set(f.columns)
    rrr = f[f.family == "RRR"].iloc[0]
    assert rrr.N == 4 and rrr.N_max == 5 and rrr.implemented
    assert (f.N < f.N_max).all()
    assert {"RRR", "RRS", "PRS", "RPR", "CPC"} <= set(f[f.implemented].family)
    # every family of the table is implemented; the reverse of a Hooke family is not
    assert f.implemented.all()
    with pytest.raises(SynthesisError, match="not implemented yet"):
        enumerate_dyads("HUR", SEED)
    with pytest.raises(SynthesisError, match="unknown"):
        enumerate_dyads("XYZ", SEED)
    with pytest.raises(SynthesisError, match="expected 3 screws"):
        enumerate_dyads("RRR", SEED[:2])


def _sphere_positions(seed, n_pos, prismatic=False):
    """Positions from a generating RRS / PRS chain: joint 1 locked through positions 1–4,
    then turned (or slid) from position 4; the sphere adds arbitrary rotations."""
    from closure import exp_so3
    rng = np.random.default_rng(seed)
    unit = lambda v: v / np.linalg.norm(v)
    L1, L2 = (Line(unit(rng.normal(size=3)), rng.normal(size=3)) for _ in range(2))
    C = rng.normal(size=3)
    q2 = [0.0, 0.5, -0.7, 1.0]
    T = []
    for k in range(n_pos):
        if k < 4:
            Tk = _rot(L2, q2[k])
        elif prismatic:
            Tk = np.eye(4)
            Tk[:3, 3] = L1.direction * 0.8
            Tk = Tk @ _rot(L2, q2[3])
        else:
            Tk = _rot(L1, [0.6, -0.5][k - 4]) @ _rot(L2, q2[3])
        R = exp_so3(rng.normal(size=3) * 0.3) if k else np.eye(3)
        S = np.eye(4)
        S[:3, :3], S[:3, 3] = R, C - R @ C
        T.append(Tk @ S)
    return [Screw.from_matrix(t) for t in T[1:]], C, L2


@pytest.mark.parametrize("family,n_pos,prismatic", [("RRS", 6, False), ("PRS", 5, True)])
def test_sphere_dyads_on_generated_positions(family, n_pos, prismatic):
    screws, C, L2 = _sphere_positions(11, n_pos, prismatic)
    df = enumerate_dyads(family, screws)
    ok = df[df.reason == ""]
    assert len(ok) >= 4 and ok.residual.max() <= 1e-9
    assert (ok.j3_type == "S").all() and ok.j3_ux.isna().all()
    # every member is a genuine RS link: its centre's first four positions are concyclic
    # about its axis 2 (checked independently of the engine's residual)
    T = [np.eye(4)] + [s.matrix() for s in screws]
    main = ok[(ok.arrangement == "a") & (ok.main_positions == "(1, 2, 3, 4)")]
    assert len(main) >= 4
    for _, r in main.iterrows():
        ax2 = Line(np.array([r.j2_ux, r.j2_uy, r.j2_uz]), np.array([r.j2_x, r.j2_y, r.j2_z]))
        c = np.array([r.j3_x, r.j3_y, r.j3_z])
        pts = np.array([t[:3, :3] @ c + t[:3, 3] for t in T[:4]])
        rad = [np.linalg.norm(np.cross(ax2.direction, p - ax2.point)) for p in pts]
        assert np.ptp(rad) < 1e-9 and np.ptp(pts @ ax2.direction) < 1e-9


def test_inversion_of_a_sphere_ended_dyad():
    screws, C, _ = _sphere_positions(11, 5, prismatic=True)
    df = enumerate_dyads("PRS", screws)
    row = df[(df.reason == "") & (df.arrangement == "a")].iloc[0]
    inv = invert_chain(row)
    assert inv["family"] == "SRP" and inv["j1_type"] == "S"
    assert np.allclose([inv["j1_x"], inv["j1_y"], inv["j1_z"]], [row.j3_x, row.j3_y, row.j3_z])
    # the revolute axis is unchanged as a line; its point is now the foot from the centre
    d = np.array([inv["j2_ux"], inv["j2_uy"], inv["j2_uz"]])
    p = np.array([inv["j2_x"], inv["j2_y"], inv["j2_z"]])
    assert abs(d @ (p - np.array([inv["j1_x"], inv["j1_y"], inv["j1_z"]]))) < 1e-12
    assert np.isclose(inv["q3_pos5"], -row.q1_pos5)
