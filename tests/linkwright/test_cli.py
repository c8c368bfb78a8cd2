"""End-to-end runs of the linkwright command on the examples, and bad study files."""
import json

import numpy as np
import pandas as pd
import pytest

from linkwright.cli import main
from linkwright.examples import folder as examples_folder

EX = examples_folder()        # the studies shipped inside the package


def run(args, capsys):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_synth_end_to_end(tmp_path, capsys):
    from synthesis import Screw, enumerate_dyads
    code, out, _ = run(["synth", EX / "seed001_rrr.toml", "-o", tmp_path, "--json"], capsys)
    assert code == 0
    summ = json.loads(out)
    assert summ["variants"] == 36 and summ["max_residual"]["value"] <= 1e-9
    df = pd.read_csv(tmp_path / "variants.csv")
    S = [Screw.from_degrees([0, 0, 1], [0, 0, 0], 30, 0.7),
         Screw.from_degrees([0.34202, 0, 0.939693], [0, 1.1, 0], 65, 0.5),
         Screw.from_degrees([0.66, 0.043589, 0.75], [0.25, 1.2, -0.289742], 75, 0.3)]
    ref = enumerate_dyads("RRR", S)
    cols = [f"j{k}_{c}" for k in (1, 2, 3) for c in ("ux", "uy", "uz", "x", "y", "z")]
    assert np.allclose(df[cols].to_numpy(), ref[cols].to_numpy(), atol=1e-12)
    md = (tmp_path / "report.md").read_text()
    assert "Ranked variants (criterion: link_length)" in md
    assert (tmp_path / "report.html").read_text().startswith("<!DOCTYPE html>")


def test_stiffness_end_to_end(tmp_path, capsys):
    from closure import exp_so3
    from linkwright.study import Study
    from stiffness import Hexapod
    code, out, _ = run(["stiffness", EX / "hexapod.toml", "-o", tmp_path, "--json"], capsys)
    assert code == 0
    K = pd.read_csv(tmp_path / "stiffness.csv").drop(columns="row").to_numpy()
    s = Study(EX / "hexapod.toml")
    h = s.section("hexapod")
    hx = Hexapod(h.get("base_points", "points"), h.get("platform_points", "points"), 2.0e7)
    T = np.eye(4)
    T[:3, 3] = [0, 0, 0.7]
    T[:3, :3] = exp_so3(np.zeros(3))
    assert np.allclose(K, hx.stiffness(T, frame="platform").K, rtol=1e-12)
    lf = pd.read_csv(tmp_path / "leg_forces.csv")
    assert np.allclose(lf.force_N, hx.leg_forces(T, [0, 0, -5000.0, 100, 0, 0]))
    mp = pd.read_csv(tmp_path / "map.csv")
    assert len(mp) == 169 and json.loads(out)["map_poses"] == 169
    assert (tmp_path / "map.png").exists()


def test_approx_end_to_end(tmp_path, capsys):
    from approx import cylinder as cy, fit
    code, out, _ = run(["approx", EX / "seed004_cylinder.toml", "-o", tmp_path, "--json"], capsys)
    assert code == 0
    t = pd.read_csv(tmp_path / "coefficients.csv")
    ref = fit(cy.f3, cy.psi31, cy.dpsi31, 0.0, 0.3, n=4).table
    assert np.allclose(t.to_numpy(), ref.to_numpy(), rtol=1e-10)
    f = pd.read_csv(tmp_path / "force.csv")
    q, qd, qdd = cy.drive_law(f.t.to_numpy())
    exact = cy.psi31(q) * 500 * 0.4 ** 2 * (cy.psi31(q) * qdd + cy.dpsi31(q) * qd ** 2)
    assert np.allclose(f.Q_exact, exact, rtol=1e-12, atol=1e-9)
    rms = np.sqrt(np.mean((f.Q_ls - exact) ** 2) / np.mean(exact ** 2))
    assert np.isclose(json.loads(out)["force_rms_ls"]["value"], rms) and rms < 0.01
    assert (tmp_path / "drive_force.png").exists()


def test_analyze_end_to_end_with_dynamics(tmp_path, capsys):
    code, out, _ = run(["analyze", EX / "fourbar_dynamics.toml", "-o", tmp_path, "--quiet"], capsys)
    assert code == 0 and out == ""
    sw = pd.read_csv(tmp_path / "sweep.csv")
    from linkwright.references import freudenstein
    # the four-bar of the example: A (0,0), B (0,1), C (3,2), D (3,0): crank 1 at 90°
    a, b, c, d = 1.0, np.hypot(3, 1), 2.0, 3.0
    t2 = np.pi / 2 + sw["input:A"].to_numpy()
    branch = min((1, -1), key=lambda br: abs(np.cos(freudenstein(np.pi / 2, a, b, c, d, br)[1])))
    _, t4 = freudenstein(t2, a, b, c, d, branch)
    assert np.abs((np.pi / 2 + sw["D"] - t4 + np.pi) % (2 * np.pi) - np.pi).max() < 1e-10
    dr = pd.read_csv(tmp_path / "drive.csv")
    assert len(dr) == 37 and dr["residual"].max() < 1e-12
    assert {"coupler_mid.x", "coupler_mid.dx", "coupler_mid.ddx"} <= set(sw.columns)


def test_demo_and_index(tmp_path, capsys):
    code, out, _ = run(["demo", "--examples", EX, "-o", tmp_path / "demo", "--quiet"], capsys)
    assert code == 0
    idx = (tmp_path / "demo" / "index.md").read_text()
    for stem in ("seed001_rrr", "hexapod", "seed004_cylinder", "seed000_swash_plate",
                 "fourbar_dynamics"):
        assert f"{stem}/report.md" in idx
        assert (tmp_path / "demo" / stem / "report.html").exists()


BAD = {
    "missing key": ("seed001_rrr.toml", ('family = "RRR"', ""), "synthesis.family"),
    "wrong type": ("hexapod.toml", ("leg_stiffness = 2.0e7", 'leg_stiffness = "stiff"'),
                   "hexapod"),
    "unknown joint kind": ("seed000_swash_plate.toml", ('kind = "U"', 'kind = "X"'),
                           "mechanism.joint[2].kind"),
    "angle out of range": ("seed001_rrr.toml", ("angle_deg = 30.0", "angle_deg = 720.0"),
                           "position[0].angle_deg"),
    "malformed TOML": ("hexapod.toml", ("[pose]", "[pose"), "malformed TOML"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_study_files_exit_2_and_write_nothing(case, tmp_path, capsys):
    name, (old, new), key = BAD[case]
    text = (EX / name).read_text()
    assert old in text
    bad = tmp_path / name
    bad.write_text(text.replace(old, new, 1))
    cmd = {"seed001_rrr.toml": "synth", "hexapod.toml": "stiffness",
           "seed000_swash_plate.toml": "analyze"}[name]
    out_dir = tmp_path / "out"
    code, _, err = run([cmd, bad, "-o", out_dir], capsys)
    assert code == 2
    assert key in err and str(bad) in err
    assert not out_dir.exists() or not any(out_dir.iterdir())


def test_outputs_are_atomic_on_failure(tmp_path):
    from linkwright.output import Outputs
    o = Outputs(tmp_path / "o")
    o.add("a.txt", "x")
    o.files["sub/b.txt"] = None                       # not bytes: writing fails midway
    with pytest.raises(TypeError):
        o.commit()
    assert not (tmp_path / "o").exists()             # a failed run makes no (empty) folder
    assert list(tmp_path.iterdir()) == []             # and leaves no temporary folder


def test_report_without_matplotlib_says_plots_need_the_extra(tmp_path, capsys, monkeypatch):
    import linkwright.render as render
    monkeypatch.setattr(render, "have_matplotlib", lambda: False)
    code, _, _ = run(["approx", EX / "seed004_cylinder.toml", "-o", tmp_path, "--quiet"], capsys)
    assert code == 0
    md = (tmp_path / "report.md").read_text()
    assert "plots need matplotlib" in md and not list(tmp_path.glob("*.png"))
    assert "<table" in (tmp_path / "report.html").read_text()


def test_bench_subcommand_writes_its_tables(tmp_path, capsys):
    code, out, _ = run(["bench", "stiffness", "--quick", "-o", tmp_path], capsys)
    assert code == 0 and "poses / s" in out
    assert "speed ratio" in (tmp_path / "bench.md").read_text()
    code, _, err = run(["bench", "nonsense"], capsys)
    assert code == 2 and "unknown module 'nonsense'" in err
