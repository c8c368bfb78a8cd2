"""Every family of Kharatyan's Table 3 that is implemented: generic positions reached by every
regular variant (checked by the test's own forward kinematics, not the engine), the
generating chain recovered from positions built by the family's own construction (with
its free parameters passed), and the table itself against the paper's printed N, N_max."""
import numpy as np
import pytest

from synthesis import Line, Screw, SynthesisError, enumerate_dyads, families
from synthesis.decompose import _used_parameters, arrangements
from synthesis.dyads import implemented_families
from synthesis.transition import transition_joint
from synthesis.validate import task_scale

# N and N_max as printed in Table 3 (row: (families as printed, N, N_max)), typed from the
# paper; row 8's ПВП is read as PRC, row 15's ВВС as RPS (misprints), ВГ'В as RHR
PRINTED = {1: ("RRR RHH RHR", 4, 5), 2: ("RRH HRH HRR", 4, 5), 3: ("RPR RRP RPH RHP", 3, 4),
           4: ("PRR PRH HRP", 3, 4), 5: ("RCC RSH CRC SRH", 6, 13), 6: ("RRC RCR RUH", 4, 7),
           7: ("CRR URH", 4, 7), 8: ("RPC RCP PRC CRP", 3, 6), 9: ("RSR RUC SRR URC", 5, 12),
           10: ("RSP SRP", 4, 10), 11: ("RUR URR", 4, 6), 12: ("RUP URP", 3, 5),
           13: ("RHC RCH HRC CRH", 5, 7), 14: ("RRS", 6, 12), 15: ("RPS PRS", 5, 10),
           16: ("RHS HRS", 7, 13), 17: ("PHS HPS", 6, 11), 18: ("CPC PCC", 4, 11),
           19: ("CRC RCC", 5, 13), 20: ("CHC HCC", 6, 14)}

PITCH = 0.3
# families decomposed here (not the sphere-ended RRR/RRS/PRS paths, tested elsewhere);
# the five whose main link is an RH/HR/HH link through 3 positions take ~2 s each
# (helical_links' direction search) and run in the bench script instead
SLOW = {"RHH", "RRH", "HRH", "HRR", "RHR"}
DECOMPOSED = sorted(f for f, (how, _) in implemented_families().items()
                    if how == "direct" and f != "RRR" and arrangements(f))
FAST = [f for f in DECOMPOSED if f not in SLOW]


def test_table_has_51_families_with_printed_counts():
    f = families()
    assert f.family.nunique() == 51 and len(f) == 53 and f.implemented.all()
    for row, (names, n, nmax) in PRINTED.items():
        sub = f[f.row == row]
        assert list(sub.family) == names.split()
        assert (sub.N == n).all() and (sub.N_max == nmax).all()
    assert "misprint" in f[(f.row == 15) & (f.family == "RPS")].note.iloc[0]
    assert "ПВП" in f[(f.row == 8) & (f.family == "PRC")].note.iloc[0]
    # implemented means enumerate_dyads builds it through the positions it lists
    for _, r in f[f.implemented].iterrows():
        assert len(r.N_implemented) and r.arrangement
        if r.N not in r.N_implemented:
            assert "N =" in r.note                   # never silently a different N


# ------------------------------------------------------------------ an independent FK
def _unit(v):
    return v / np.linalg.norm(v)


def _screw(u, p, ang, slide):
    """Rodrigues: rotation ``ang`` about the line (u, p) and ``slide`` along u."""
    K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    R = np.eye(3) + np.sin(ang) * K + (1 - np.cos(ang)) * K @ K
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p - R @ p + slide * u
    return T


def _fk(types, lines, pitches, vals):
    T = np.eye(4)
    for k, t in enumerate(types):
        a, s = vals[k]
        a = 0.0 if t == "P" else a
        s = 0.0 if t == "R" else pitches[k] * a if t == "H" else s
        T = T @ _screw(lines[k].direction, lines[k].point, a, s)
    return T


def _generate(family, seed):
    """Positions built by the family's own construction from a random chain: the main link
    moves through its positions with the transition joint locked at 0, the remaining
    positions are reached by the transition joint from position s (the main link's
    fixed joint locked at its value at s, joint 3 turned further)."""
    rng = np.random.default_rng(seed)
    arr = arrangements(family)
    name, main, x, n_b, k = arr[seed % len(arr)]
    N = n_b + k
    lines = [Line(_unit(rng.normal(size=3)), rng.normal(size=3)) for _ in range(3)]
    pitches = [PITCH if t == "H" else 0.0 for t in family]
    X, F = (0, 1) if name == "a" else (1, 0)
    vals = np.zeros((N, 3, 2))
    for p in range(1, n_b):
        vals[p, F] = rng.uniform(-2.5, 2.5), rng.uniform(-1, 1)
        vals[p, 2] = rng.uniform(-2.5, 2.5), rng.uniform(-1, 1)
    s = int(rng.integers(n_b))
    for p in range(n_b, N):
        vals[p, X] = rng.uniform(-2.5, 2.5), rng.uniform(-1, 1)
        vals[p, F] = vals[s, F]
        vals[p, 2] = vals[s, 2] + (rng.uniform(-2.5, 2.5), rng.uniform(-1, 1))
    T = [_fk(family, lines, pitches, v) for v in vals]
    # the generating chain's free parameters, in the table's conventions
    mi = [1, 2] if name == "a" else [0, 2]
    params = {}
    if "H" in family:
        params["pitch"] = PITCH
    if main in ("RC", "CR", "HC", "CH"):
        params["fixed_direction"] = lines[mi[0]].direction
    if "P" in main:
        kp = mi[main.index("P")]
        params["slide_direction"] = lines[kp].direction
        if "C" in main:
            params["prismatic_slide"] = vals[1, kp, 1]
    if (x, family[2]) == ("R", "C"):
        d = vals[-1, 2, 0] - vals[s, 2, 0]
        u = lines[2].direction
        flip = u[np.argmax(np.abs(u))] < 0          # angles about the table's orientation
        params["transition_angle"] = (-1 if flip else 1) * np.arctan2(np.sin(d), np.cos(d))
    return [Screw.from_matrix(t) for t in T[1:]], np.array(T), lines, params


def _row_lines(r, joints=(1, 2, 3)):
    return [Line(np.array([r[f"j{k}_ux"], r[f"j{k}_uy"], r[f"j{k}_uz"]]),
                 np.array([r[f"j{k}_x"], r[f"j{k}_y"], r[f"j{k}_z"]])) for k in joints]


def _fk_error(family, r, T, size):
    """Largest pose error of the row's chain by the test's own forward kinematics."""
    lines = _row_lines(r)
    pitches = [r[f"j{k}_pitch"] for k in (1, 2, 3)]
    err = 0.0
    for p in range(len(T)):
        vals = [(r[f"q{k}_pos{p + 1}"], r[f"d{k}_pos{p + 1}"]) for k in (1, 2, 3)]
        A = _fk(family, lines, pitches, vals)
        err = max(err, np.abs(A[:3, :3] - T[p][:3, :3]).max(),
                  np.abs(A[:3, 3] - T[p][:3, 3]).max() / size)
    return err


def _distance_to_generator(family, r, lines, size):
    err = 0.0
    for k, (a, b) in enumerate(zip(_row_lines(r), lines)):
        e = np.linalg.norm(np.cross(a.direction, b.direction))
        if family[k] != "P":                        # a slide direction has no point
            e = max(e, np.linalg.norm(np.cross(b.direction, a.point - b.point)) / size)
        err = max(err, e)
    return err


@pytest.mark.parametrize("family", FAST)
def test_generic_positions_every_regular_variant_reaches_them(family):
    rng = np.random.default_rng(sum(map(ord, family)))
    n = sorted({a[3] + a[4] for a in arrangements(family)})[0]
    T = [np.eye(4)]
    for _ in range(n - 1):                          # generic: random screws of order-1 size
        ax = _unit(rng.normal(size=3))
        T.append(Screw(ax, rng.normal(size=3), rng.uniform(0.3, 2.0), rng.normal()).matrix())
    screws = [Screw.from_matrix(t) for t in T[1:]]
    # small grids of the free parameters (the default grids are the bench's)
    grid = {"fixed_direction": [_unit(rng.normal(size=3)) for _ in range(2)],
            "slide_direction": [_unit(rng.normal(size=3)) for _ in range(2)],
            "prismatic_slide": [0.4], "transition_angle": [0.7, -1.1]}
    used = _used_parameters(family, arrangements(family, n))
    choices = {k: v for k, v in grid.items() if k in used}
    if "H" in family:
        choices["pitch"] = PITCH
    df = enumerate_dyads(family, screws, **choices)
    _, _, size = task_scale(np.array(T))
    ok = df[df.reason == ""]
    assert len(ok) >= 1
    assert ok.residual.max() <= 1e-9
    geo = [f"j{k}_{c}" for k in (1, 2, 3) for c in ("ux", "uy", "uz", "x", "y", "z")]
    assert np.isfinite(ok[geo].to_numpy(float)).all()
    for _, r in ok.iloc[::4].iterrows():         # every 4th: the engine checked them all
        assert _fk_error(family, r, T, size) <= 1e-9
    bad = df[df.reason != ""]
    assert bad.residual.isna().all()                 # degenerate rows never look regular


@pytest.mark.parametrize("family", FAST)
def test_generating_chain_is_recovered(family):
    for seed in (1, 2):
        screws, T, lines, params = _generate(family, seed)
        df = enumerate_dyads(family, screws, **params)
        _, _, size = task_scale(T)
        ok = df[df.reason == ""]
        assert ok.residual.max() <= 1e-9
        best = min(_distance_to_generator(family, r, lines, size) for _, r in ok.iterrows())
        assert best <= 1e-8, (family, seed, best)


@pytest.mark.parametrize("family", ["CPR", "CCR", "PHR"])
def test_inverse_families_reach_the_positions(family):
    screws, T, lines, params = _generate(family[::-1], 3)
    Ti = np.array([np.linalg.inv(t) for t in T])
    inv = [Screw.from_matrix(t) for t in Ti[1:]]
    df = enumerate_dyads(family, inv, **params)
    _, _, size = task_scale(Ti)
    ok = df[df.reason == ""]
    assert (ok.family == family).all() and ok.residual.max() <= 1e-9
    for _, r in ok.head(8).iterrows():
        assert _fk_error(family, r, Ti, size) <= 1e-9
    # the generating chain, reversed, is among them (same axes as lines)
    best = min(_distance_to_generator(family, r, lines[::-1], size) for _, r in ok.iterrows())
    assert best <= 1e-8


def test_rr_transition_is_seed_formula():
    """R carrying R: the closed form equals the seed's pure rotation (rotation_axis_between)."""
    from synthesis import rotation_axis_between
    rng = np.random.default_rng(4)
    y = Line(_unit(rng.normal(size=3)), rng.normal(size=3))
    t = Line(_unit(rng.normal(size=3)), rng.normal(size=3))
    D = _screw(t.direction, t.point, 0.9, 0.0) @ _screw(y.direction, y.point, -0.6, 0.0)
    (tr,) = transition_joint("R", "R", y, 0.0, D[None], 1.0)
    M4, Q4 = D[:3, :3] @ y.direction, D[:3, :3] @ y.point + D[:3, 3]
    ref, ang = rotation_axis_between(y.direction, y.point, M4, Q4)
    assert np.linalg.norm(np.cross(tr.line.direction, ref.direction)) < 1e-12
    assert np.linalg.norm(tr.line.point - ref.point) < 1e-12
    assert np.isclose(abs(tr.psi[0, 0]), abs(0.9)) and np.isclose(tr.delta[0, 0], -0.6)


def test_degenerate_inputs_raise_or_give_reasons():
    screws, T, lines, params = _generate("RPR", 1)
    with pytest.raises(SynthesisError, match="pitch"):
        enumerate_dyads("RPH", screws, pitch=0.0)                  # H with pitch 0 is R
    with pytest.raises(SynthesisError, match="pitch"):
        enumerate_dyads("RPH", screws)                              # pitch missing
    with pytest.raises(SynthesisError, match="transition_angle"):
        enumerate_dyads("RPR", screws, transition_angle=0.5)        # not a choice of RPR
    with pytest.raises(SynthesisError, match="bogus"):
        enumerate_dyads("RPR", screws, bogus=1)
    with pytest.raises(SynthesisError, match="slide_direction"):
        enumerate_dyads("RPR", screws, slide_direction=[1, 1, 0])   # not a unit vector
    with pytest.raises(SynthesisError, match="screws"):
        enumerate_dyads("RPR", screws[:1])
    # a pure translation from position 1 to 2: the PR link's R axis is undetermined
    tr = Screw([1.0, 0, 0], [0, 0, 0], 0.0, 0.7)
    df = enumerate_dyads("RPR", [tr, screws[1]], slide_direction=[0, 0.6, 0.8])
    bad = df[df.main_positions == "(1, 2)"]
    assert len(bad) and (bad.reason.str.contains("pure translation")).all()
    assert bad.residual.isna().all() and bad.j1_ux.isna().all()
    # a slide direction across the rotation axis: the slide is not determined
    w = Screw.from_matrix(T[1]).axis
    across = _unit(np.cross(w, [0.3, 0.1, 0.9]))
    df = enumerate_dyads("RPR", screws, slide_direction=across)
    assert df[df.main_positions == "(1, 2)"].reason.str.contains("across").all()


# ------------------------------------------------------------------ sphere-ended families
def _rot_about(C, R):
    S = np.eye(4)
    S[:3, :3], S[:3, 3] = R, C - R @ C
    return S


def _generate_sphere(family, seed):
    """A random chain J1 J2 S of the family's construction (main RS/PS link locked through
    its positions, the transition joint from position s; the sphere adds any rotation)."""
    from closure import exp_so3
    from synthesis.sphere_families import sphere_arrangements
    rng = np.random.default_rng(seed)
    arr = sphere_arrangements(family)
    name, main, x, n_b, k = arr[seed % len(arr)]
    N = n_b + k
    lines = [Line(_unit(rng.normal(size=3)), rng.normal(size=3)) for _ in range(2)]
    C = rng.normal(size=3)
    X, F = (0, 1) if name == "a" else (1, 0)
    q = np.zeros((N, 2))
    q[1:n_b, F] = rng.uniform(-2.5, 2.5, n_b - 1)
    s = int(rng.integers(n_b))
    q[n_b:, X] = rng.uniform(-2.5, 2.5, k)
    q[n_b:, F] = q[s, F]
    T = []
    for p in range(N):
        A = np.eye(4)
        for j in range(2):
            t = family[j]
            A = A @ _screw(lines[j].direction, lines[j].point, 0.0 if t == "P" else q[p, j],
                           q[p, j] if t == "P" else 0.0)
        T.append(A @ _rot_about(C, exp_so3(rng.normal(size=3) * 0.5) if p else np.eye(3)))
    screws = [Screw.from_matrix(t) for t in T[1:]]
    return screws, np.array(T), lines, C, lines[F].direction


@pytest.mark.parametrize("family", ["RRS", "PRS", "RPS"])
def test_sphere_families_recover_the_generating_chain(family):
    from synthesis.spherical import azimuth_of, task_frame
    for seed in (1, 2):
        screws, T, lines, C, main_dir = _generate_sphere(family, seed)
        psi = azimuth_of(main_dir, frame=task_frame(screws))
        df = enumerate_dyads(family, screws, azimuth=psi)
        _, _, size = task_scale(T)
        ok = df[df.reason == ""]
        assert ok.residual.max() <= 1e-9
        # regular variants (every 5th): the centre's positions by the test's own kinematics
        for _, r in ok.iloc[::5].iterrows():
            ln = _row_lines(r, (1, 2))
            c = np.array([r.j3_x, r.j3_y, r.j3_z])
            for p in range(len(T)):
                A = np.eye(4)
                for j in range(2):
                    qv = r[f"q{j + 1}_pos{p + 1}"]
                    P = family[j] == "P"
                    A = A @ _screw(ln[j].direction, ln[j].point, 0.0 if P else qv, qv if P else 0.0)
                want = T[p][:3, :3] @ c + T[p][:3, 3]
                assert np.linalg.norm(A[:3, :3] @ c + A[:3, 3] - want) <= 1e-9 * size
        best = np.inf
        for _, r in ok.iterrows():
            err = np.linalg.norm(np.array([r.j3_x, r.j3_y, r.j3_z]) - C) / size
            for k, (a, b) in enumerate(zip(_row_lines(r, (1, 2)), lines)):
                err = max(err, np.linalg.norm(np.cross(a.direction, b.direction)))
                if family[k] != "P":
                    err = max(err, np.linalg.norm(np.cross(b.direction, a.point - b.point)) / size)
            best = min(best, err)
        assert best <= 1e-8, (family, seed, best)


def _generate_middle(family, seed):
    """A random chain with the sphere before joint 3 (RSR, RSP: R, S, J3; SRR, SRP: S, R,
    J3) built by its construction: the SR/SP main link with the R transition locked, then
    the transition from position s to the last position."""
    from closure import exp_so3
    from synthesis.sphere_middle import middle_arrangements
    rng = np.random.default_rng(seed)
    name, main, x, n_b, k = middle_arrangements(family)[0]
    O = rng.normal(size=3)
    X = Line(_unit(rng.normal(size=3)), rng.normal(size=3))
    M = Line(_unit(rng.normal(size=3)), rng.normal(size=3))
    y = family[2]

    def J(kind, ln, q):
        return _screw(ln.direction, ln.point, 0.0 if kind == "P" else q, q if kind == "P" else 0.0)
    Rs = [np.eye(3)] + [exp_so3(rng.normal(size=3) * 0.6) for _ in range(n_b - 1)]
    q3 = [0.0] + list(rng.uniform(-2.5, 2.5, n_b - 1))
    s, qx, d = int(rng.integers(n_b)), rng.uniform(-2.5, 2.5), rng.uniform(-2.5, 2.5)
    T = [_rot_about(O, Rs[p]) @ J(y, M, q3[p]) for p in range(n_b)]
    if name == "a":
        T.append(J("R", X, qx) @ _rot_about(O, Rs[s]) @ J(y, M, q3[s] + d))
    else:
        T.append(_rot_about(O, Rs[s]) @ J("R", X, qx) @ J(y, M, q3[s] + d))
    T = np.array(T)
    return [Screw.from_matrix(t) for t in T[1:]], T, O, X, M, J


@pytest.mark.parametrize("family", ["RSR", "SRR", "RSP", "SRP"])
def test_sphere_middle_families_recover_the_generating_chain(family):
    from synthesis.spherical import azimuth_of, task_frame
    for seed in (1, 2):
        screws, T, O, X, M, J = _generate_middle(family, seed)
        df = enumerate_dyads(family, screws, azimuth=azimuth_of(M.direction,
                                                               frame=task_frame(screws)))
        _, _, size = task_scale(T)
        ok = df[df.reason == ""]
        assert len(ok) and ok.residual.max() <= 1e-9
        ks, kx = (2, 1) if family[0] == "R" else (1, 2)          # the sphere, the R joint
        best = np.inf
        for _, r in ok.iterrows():
            c = np.array([r[f"j{ks}_x"], r[f"j{ks}_y"], r[f"j{ks}_z"]])
            ln = _row_lines(r, (kx, 3))
            # the test's own check: the centre moved from the ground side and back from the
            # body side coincide at every position
            for p in range(len(T)):
                qx, q3 = r[f"q{kx}_pos{p + 1}"], r[f"q3_pos{p + 1}"]
                back = T[p] @ J(family[2], ln[1], -q3)
                if kx == 1:
                    g = J("R", ln[0], qx)
                else:
                    g, back = np.eye(4), back @ J("R", ln[0], -qx)
                assert np.linalg.norm((g[:3, :3] @ c + g[:3, 3]) - (back[:3, :3] @ c + back[:3, 3])) \
                    <= 1e-9 * size
            e = max(np.linalg.norm(c - O) / size,
                    np.linalg.norm(np.cross(ln[0].direction, X.direction)),
                    np.linalg.norm(np.cross(X.direction, ln[0].point - X.point)) / size,
                    np.linalg.norm(np.cross(ln[1].direction, M.direction)),
                    0.0 if family[2] == "P" else
                    np.linalg.norm(np.cross(M.direction, ln[1].point - M.point)) / size)
            best = min(best, e)
        assert best <= 1e-8, (family, seed, best)


def test_coincident_positions_give_reasons_not_nan_rows():
    s = Screw([0, 0, 1.0], [0, 0, 0], 0.5, 0.7)
    df = enumerate_dyads("RPR", [s, s], slide_direction=[0, 0.6, 0.8])
    # position 3 is position 2: the R transition cannot reach it by turning
    assert (df.reason != "").all() and df.residual.isna().all()
    assert df.reason.str.contains("degenerate").all()
    with pytest.raises(SynthesisError, match="transition_angle"):
        enumerate_dyads("RRC", [s, s, s], transition_angle=[[0.5]])


def _generate_hooke(family, seed):
    """A random chain with a Hooke joint (RUR, RUP: R, U, J3; URR, URP: U, R, J3) built by
    its construction; the U joint turns by Rot(a, α) Rot(b, γ) about its centre."""
    from synthesis.hooke_families import hooke_arrangements
    rng = np.random.default_rng(seed)
    name, main, x, n_b, k = hooke_arrangements(family)[0]
    O, a = rng.normal(size=3), _unit(rng.normal(size=3))
    b = _unit(np.cross(a, rng.normal(size=3)))
    X = Line(_unit(rng.normal(size=3)), rng.normal(size=3))
    M = Line(_unit(rng.normal(size=3)), rng.normal(size=3))
    y = family[2]
    al, ga = ([0.0] + list(rng.uniform(-1.5, 1.5, n_b - 1)) for _ in range(2))
    q3 = [0.0] + list(rng.uniform(-2.5, 2.5, n_b - 1))
    s, qx, d = int(rng.integers(n_b)), rng.uniform(-2.5, 2.5), rng.uniform(-2.5, 2.5)

    def J(kind, ln, q):
        return _screw(ln.direction, ln.point, 0.0 if kind == "P" else q, q if kind == "P" else 0.0)

    def U(i):
        R = _screw(a, np.zeros(3), al[i], 0.0)[:3, :3] @ _screw(b, np.zeros(3), ga[i], 0.0)[:3, :3]
        return _rot_about(O, R)
    T = [U(p) @ J(y, M, q3[p]) for p in range(n_b)]
    T.append(J("R", X, qx) @ U(s) @ J(y, M, q3[s] + d) if name == "a" else
             U(s) @ J("R", X, qx) @ J(y, M, q3[s] + d))
    T = np.array(T)
    return [Screw.from_matrix(t) for t in T[1:]], T, O, a, X, M


@pytest.mark.parametrize("family", ["RUR", "URR", "RUP", "URP"])
def test_hooke_families_recover_the_generating_chain(family):
    from synthesis.spherical import azimuth_of, task_frame
    screws, T, O, a, X, M = _generate_hooke(family, 1)
    fr = task_frame(screws)
    params = {"azimuth": azimuth_of(M.direction, frame=fr)}
    if family[2] == "P":
        params["axis_azimuth"] = azimuth_of(a, frame=fr)
    df = enumerate_dyads(family, screws, **params)
    _, _, size = task_scale(T)
    ok = df[df.reason == ""]
    assert len(ok) and ok.residual.max() <= 1e-9
    ku, kx = (2, 1) if family[0] == "R" else (1, 2)
    best = np.inf
    for _, r in ok.iterrows():
        Oc = np.array([r[f"j{ku}_x"], r[f"j{ku}_y"], r[f"j{ku}_z"]])
        ua = np.array([r[f"j{ku}_ux"], r[f"j{ku}_uy"], r[f"j{ku}_uz"]])
        ln = _row_lines(r, (kx, 3))
        e = max(np.linalg.norm(Oc - O) / size, np.linalg.norm(np.cross(ua, a)),
                np.linalg.norm(np.cross(ln[0].direction, X.direction)),
                np.linalg.norm(np.cross(X.direction, ln[0].point - X.point)) / size,
                np.linalg.norm(np.cross(ln[1].direction, M.direction)),
                0.0 if family[2] == "P" else
                np.linalg.norm(np.cross(M.direction, ln[1].point - M.point)) / size)
        best = min(best, e)
    assert best <= 1e-8, (family, best)
    # the U joint's two axes stay perpendicular and unit in every regular row
    b = ok[["u_cross_x", "u_cross_y", "u_cross_z"]].to_numpy(float)
    A = ok[[f"j{ku}_ux", f"j{ku}_uy", f"j{ku}_uz"]].to_numpy(float)
    assert np.abs(np.einsum("ij,ij->i", A, b)).max() < 1e-9


@pytest.mark.parametrize("family", ["RPR", "RCR", "PRR"])
def test_default_grids_move_with_the_task(family):
    """With the default grids (slide and fixed directions), a task moved by a rigid motion far
    from the origin gives the same variants moved by that motion."""
    rng = np.random.default_rng(7)
    n = sorted({a[3] + a[4] for a in arrangements(family)})[0]
    T = [np.eye(4)] + [Screw(_unit(rng.normal(size=3)), rng.normal(size=3),
                             rng.uniform(0.3, 2.0), rng.normal()).matrix() for _ in range(n - 1)]
    G = _screw(_unit(rng.normal(size=3)), np.zeros(3), 2.1, 0.0)
    G[:3, 3] = [1000.0, -700.0, 400.0]
    moved = [G @ t @ np.linalg.inv(G) for t in T]        # the same motion seen from a moved frame
    a = enumerate_dyads(family, [Screw.from_matrix(t) for t in T[1:]])
    b = enumerate_dyads(family, [Screw.from_matrix(t) for t in moved[1:]])
    a, b = a[a.reason == ""], b[b.reason == ""]
    assert len(a) == len(b) >= 1
    la = [G[:3, :3] @ ln.direction for _, r in a.iterrows() for ln in _row_lines(r)]
    lb = [ln.direction for _, r in b.iterrows() for ln in _row_lines(r)]
    # every moved line direction of the first table is in the second (up to sign)
    Lb = np.array(lb)
    for d in la:
        assert np.min(np.minimum(np.linalg.norm(Lb - d, axis=1),
                                 np.linalg.norm(Lb + d, axis=1))) <= 1e-7


@pytest.mark.ill_conditioned_ok
@pytest.mark.parametrize("seed", [0, 3])
def test_nearly_coincident_positions_are_flagged_not_regular(seed):
    """Position 5 is position 2 turned 1e-9 further: variants that lose their accuracy are
    flagged with their residual kept; none above 1e-9 is regular."""
    rng = np.random.default_rng(seed)
    base = [Screw(_unit(rng.normal(size=3)), rng.normal(size=3), rng.uniform(0.3, 2),
                  rng.normal()) for _ in range(3)]
    near = base + [Screw(base[0].axis, base[0].point, base[0].angle * (1 + 1e-9), base[0].slide)]
    df = enumerate_dyads("RCC", near)
    flagged = df.reason.str.startswith("ill-conditioned")
    assert flagged.any() and (df[flagged].residual > 1e-9).all()
    assert df[flagged].reason.str.contains("nearly coincident").all()
    assert (df[df.reason == ""].residual <= 1e-9).all()
