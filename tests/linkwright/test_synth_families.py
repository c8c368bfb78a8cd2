"""`linkwright synth` for every kind of family: the free parameters from the study file,
the generic report, and the ranking's chain Jacobian (R, P, H, C, U, S joints) checked
against the engine's own finite differences."""
import json

import numpy as np
import pytest

from linkwright.cli import main
from linkwright.cmd_draw import _values, chain_mechanism
from linkwright.cmd_synth import chain_jacobian
from linkwright.examples import folder as examples_folder

SEED = (examples_folder() / "seed001_rrr.toml").read_text()


def _study(tmp_path, family, extra=""):
    p = tmp_path / f"{family.lower()}.toml"
    p.write_text(SEED.replace('family = "RRR"', f'family = "{family}"\n{extra}'))
    return p


def _engine_twists(row, p, eps=1e-6):
    """Spatial twists (ω, v at the origin) of the body per joint coordinate, by central
    differences of the engine's body pose at position p (1-based)."""
    m, kinds, _ = chain_mechanism(row)
    x = _values(row, kinds, p)[p - 1]
    cols = []
    for j in range(len(x)):
        dx = np.zeros_like(x)
        dx[j] = eps
        Tp, Tm = (m.solve(x + s * dx, continuation=False).link_frame("body").reshape(-1, 4, 4)[0]
                  for s in (1, -1))
        dT = (Tp - Tm) / (2 * eps)
        W = dT @ np.linalg.inv(0.5 * (Tp + Tm))
        cols.append(np.r_[W[2, 1], W[0, 2], W[1, 0], W[:3, 3]])
    return np.array(cols).T


@pytest.mark.parametrize("family", ["RCH", "RUC", "RPC"])
def test_chain_jacobian_is_the_engines_body_twist(family):
    from synthesis import enumerate_dyads
    if family == "RUC":
        from tests.synthesis.test_families_hooke_hc import _generate
        screws, T, _, params = _generate(family, 3)
    else:
        from tests.synthesis.test_families import _generate
        screws, T, _, params = _generate(family, 3)
    df = enumerate_dyads(family, screws, **params)
    ok = df[df.reason == ""]
    for _, row in ok.iloc[:3].iterrows():
        for p in range(1, len(T) + 1):
            J = chain_jacobian(row, p)
            E = _engine_twists(row, p)
            assert J.shape == E.shape
            assert np.abs(J - E).max() <= 1e-6 * max(1.0, np.abs(E).max()), (family, p)


def test_synth_study_with_a_helical_family_and_its_pitch(tmp_path, capsys):
    code = main(["synth", str(_study(tmp_path, "RHR", "pitch = 0.05")), "-o",
                 str(tmp_path / "out"), "--json"])
    out = capsys.readouterr().out
    assert code == 0, out
    summ = json.loads(out)
    assert summ["family"] == "RHR" and summ["ranked"] >= 1
    assert summ["max_residual"]["value"] <= 1e-9
    rep = (tmp_path / "out" / "report.md").read_text()
    assert "Best variant" in rep and "carries position" in rep
    import pandas as pd
    df = pd.read_csv(tmp_path / "out" / "variants.csv")
    assert (df.j2_pitch.dropna() == 0.05).all() and df.condition.notna().any()


@pytest.mark.parametrize("family, extra, key", [
    ("RHR", "", "synthesis.pitch"),
    ("RCR", "azimuth_deg = 30.0", "synthesis.azimuth_deg"),
    ("RPR", "", "position"),                                # RPR takes 3 positions, not 4
    ("RRC", "transition_angle_deg = [[1.0]]", "synthesis.transition_angle_deg"),
])
def test_synth_study_errors_name_the_key(tmp_path, capsys, family, extra, key):
    code = main(["synth", str(_study(tmp_path, family, extra)), "-o", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code != 0 and f"'{key}'" in err, err


def _two_positions(text):
    """The seed study cut to its first two screws (three positions: RR's maximum)."""
    i = text.index("[[position]]")
    j = text.index("[[position]]", text.index("[[position]]", i + 1) + 1)
    return text[:j] + text[text.index("[criterion]"):]


def test_complete_mode_gives_every_rr_solution(tmp_path, capsys):
    import pandas as pd
    from synthesis import Screw, complete_dyads
    p = tmp_path / "rr.toml"
    p.write_text(_two_positions(SEED).replace('family = "RRR"', 'family = "RR"\nmode = "complete"'))
    code = main(["synth", str(p), "-o", str(tmp_path / "out"), "--json"])
    out = capsys.readouterr().out
    assert code == 0, out
    df = pd.read_csv(tmp_path / "out" / "variants.csv")
    ref = complete_dyads("RR", [Screw.from_degrees([0, 0, 1], [0, 0, 0], 30, 0.7),
                                Screw.from_degrees([0.34202, 0, 0.939693], [0, 1.1, 0], 65, 0.5)])
    assert len(df) == len(ref) == 2 and (df.residual <= 1e-9).all()
    got = np.sort(df[["j1_ux", "j1_uy", "j1_uz"]].to_numpy(), axis=0)
    assert np.allclose(got, np.sort(ref[["j1_ux", "j1_uy", "j1_uz"]].to_numpy(float), axis=0),
                       atol=1e-12)
    assert df.link2.isna().all() and df.condition.notna().all()
    assert "2 real solutions of 2 over the complex numbers" in \
        (tmp_path / "out" / "report.md").read_text()


def test_least_squares_mode_ranks_by_fit(tmp_path, capsys):
    import pandas as pd
    p = tmp_path / "rrls.toml"
    p.write_text(SEED.replace('family = "RRR"', 'family = "RR"\nmode = "least-squares"'))
    assert main(["synth", str(p), "-o", str(tmp_path / "out")]) == 0
    df = pd.read_csv(tmp_path / "out" / "variants.csv").sort_values("rank")
    assert len(df) >= 1 and df["rank"].notna().all()         # none excluded for its fit
    assert np.all(np.diff(df.residual.to_numpy()) >= -1e-3 * df.residual.abs().max())
    assert "Best fit" in (tmp_path / "out" / "report.md").read_text()


def test_complete_mode_refuses_free_parameters(tmp_path, capsys):
    p = tmp_path / "bad.toml"
    p.write_text(_two_positions(SEED).replace(
        'family = "RRR"', 'family = "RR"\nmode = "complete"\nazimuth_deg = 10.0'))
    assert main(["synth", str(p), "-o", str(tmp_path / "o")]) != 0
    assert "'synthesis.azimuth_deg'" in capsys.readouterr().err


def test_assemble_section_closes_the_rr_solutions_into_a_bennett_linkage(tmp_path, capsys):
    import pandas as pd
    p = tmp_path / "rr.toml"
    p.write_text(_two_positions(SEED).replace('family = "RRR"', 'family = "RR"\nmode = "complete"')
                 + "\n[assemble]\nlinks = 2\n")
    assert main(["synth", str(p), "-o", str(tmp_path / "out"), "--json"]) == 0
    summ = json.loads(capsys.readouterr().out)
    assert summ["assemblies"] == 1 and summ["assemblies_without_defects"] == 1
    t = pd.read_csv(tmp_path / "out" / "assemblies.csv")
    assert t.mobility.iloc[0] == 1 and t.pose_error.iloc[0] < 1e-12
    q = tmp_path / "bad.toml"
    q.write_text(SEED + "\n[assemble]\nlinks = 2\n")
    assert main(["synth", str(q), "-o", str(tmp_path / "o2")]) != 0
    assert "'assemble'" in capsys.readouterr().err


def test_tolerance_section_reports_sampled_and_first_order_errors(tmp_path, capsys):
    import pandas as pd
    p = tmp_path / "tol.toml"
    p.write_text(SEED + "\n[tolerance]\ndirection_sigma_deg = 0.1\nposition_sigma = 1e-4\n"
                 "samples = 200\nseed = 2\nvariant = 3\n")
    assert main(["synth", str(p), "-o", str(tmp_path / "out"), "--json"]) == 0
    summ = json.loads(capsys.readouterr().out)
    t = pd.read_csv(tmp_path / "out" / "tolerance.csv")
    assert list(t.position) == [1, 2, 3, 4] and (t.variant == 3).all()
    assert summ["tolerance_worst_displacement_mean"]["value"] == pytest.approx(t.pos_mean.max())
    assert "Tolerances of variant 3" in (tmp_path / "out" / "report.md").read_text()
    q = tmp_path / "bad.toml"
    q.write_text(SEED + "\n[tolerance]\ndirection_sigma_deg = 0.1\nposition_sigma = 1e-4\n"
                 "variant = 999\n")
    assert main(["synth", str(q), "-o", str(tmp_path / "o2")]) != 0
    assert "'tolerance.variant'" in capsys.readouterr().err


def test_sphere_ended_variants_are_drawn_with_their_centre_on_the_task():
    from linkwright.cmd_draw import variant_scenes
    from linkwright.cmd_synth import rank_variants
    from synthesis import Screw, enumerate_dyads
    S = [Screw.from_degrees([0, 0, 1], [0, 0, 0], 30, 0.7),
         Screw.from_degrees([0.34202, 0, 0.939693], [0, 1.1, 0], 65, 0.5),
         Screw.from_degrees([0.66, 0.043589, 0.75], [0.25, 1.2, -0.289742], 75, 0.3),
         Screw.from_degrees([0, 1, 0], [0.5, 0, 0.2], 40, -0.2)]
    T = np.stack([np.eye(4)] + [s.matrix() for s in S])
    ranked = rank_variants(enumerate_dyads("PRS", S), "link_length", np.zeros(3), 1.0, len(T))
    scenes, skipped = variant_scenes(ranked, T, "PRS", best=2)
    assert len(scenes) == 2 and skipped == 0
    for v, scn, _ in scenes:
        row = ranked[ranked.variant == v].iloc[0]
        c = np.array([row.j3_x, row.j3_y, row.j3_z])
        want = np.einsum("pij,j->pi", T[:, :3, :3], c) + T[:, :3, 3]
        assert np.abs(scn.paths["sphere centre"] - want).max() < 1e-9


def test_complete_mode_cs_takes_its_cylinder_direction(tmp_path, capsys):
    """`mode = "complete"` with family CS: every real CS chain through six positions for
    the study's fixed_direction, as complete_dyads gives them; other choices refused."""
    import pandas as pd
    from synthesis import Screw, complete_dyads
    rng = np.random.default_rng(5)
    scr = []
    for _ in range(5):
        u = rng.normal(size=3)
        scr.append(Screw(u / np.linalg.norm(u), rng.normal(size=3), rng.uniform(0.4, 1.5),
                         rng.normal()))
    d = np.array([0.0, 0.6, 0.8])
    text = ('[study]\ncommand = "synth"\ntitle = "CS"\n\n[synthesis]\nfamily = "CS"\n'
            'mode = "complete"\nfixed_direction = [0.0, 0.6, 0.8]\n\n' +
            "".join(f"[[position]]\naxis = {list(map(float, s.axis))}\n"
                    f"point = {list(map(float, s.point))}\n"
                    f"angle_deg = {float(np.degrees(s.angle))!r}\nslide = {float(s.slide)!r}\n\n"
                    for s in scr))
    p = tmp_path / "cs.toml"
    p.write_text(text)
    assert main(["synth", str(p), "-o", str(tmp_path / "out")]) == 0, capsys.readouterr().err
    df = pd.read_csv(tmp_path / "out" / "variants.csv")
    ref = complete_dyads("CS", [Screw.from_matrix(s.matrix()) for s in scr], fixed_direction=d)
    assert len(df) == len(ref) and len(ref) >= 2 and (df.residual <= 1e-9).all()
    assert np.allclose(np.sort(df.j2_x.to_numpy()), np.sort(ref.j2_x.to_numpy(float)),
                       atol=1e-9)
    q = tmp_path / "bad.toml"
    q.write_text(text.replace("fixed_direction", "pitch = 0.1\nfixed_direction"))
    assert main(["synth", str(q), "-o", str(tmp_path / "o2")]) != 0
    assert "'synthesis.pitch'" in capsys.readouterr().err
