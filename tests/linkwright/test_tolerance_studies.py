"""`[tolerance]` in hexapod stiffness studies: the table, the report, the JSON summary, and
the study-file checks."""
import json

import pandas as pd

from linkwright.cli import main
from linkwright.examples import folder

HEX = (folder() / "hexapod.toml").read_text()
TOL = "\n[tolerance]\npoint_sigma = 0.001\nstiffness_sigma = 0.05\nsamples = 200\nseed = 1\n"


def test_hexapod_tolerance_study(tmp_path, capsys):
    from stiffness.tolerance import hexapod_tolerance
    from linkwright.cmd_stiffness import hexapod_of
    from linkwright.study import load_study
    p = tmp_path / "h.toml"
    p.write_text(HEX + TOL)
    assert main(["stiffness", str(p), "-o", str(tmp_path / "o"), "--json"]) == 0
    summ = json.loads(capsys.readouterr().out)
    t = pd.read_csv(tmp_path / "o" / "tolerance.csv").set_index("index")
    hx, T = hexapod_of(load_study(p))
    ref = hexapod_tolerance(hx, T, point_sigma=0.001, stiffness_sigma=0.05, samples=200,
                            seed=1).summary.set_index("index")
    assert abs(t.loc["kt_min", "mean"] / ref.loc["kt_min", "mean"] - 1) < 1e-12
    assert summ["tolerance_kt_min_mean"]["value"] == t.loc["kt_min", "mean"]
    assert "Manufacturing tolerances" in (tmp_path / "o" / "report.md").read_text()


def test_tolerance_keys_are_checked(tmp_path, capsys):
    p = tmp_path / "bad.toml"
    p.write_text(HEX + TOL.replace("point_sigma = 0.001", "point_sigma = -1.0"))
    assert main(["stiffness", str(p), "-o", str(tmp_path / "o")]) == 2
    assert "'tolerance.point_sigma'" in capsys.readouterr().err


FOURBAR = (folder() / "fourbar_dynamics.toml").read_text()
DRIVE_TOL = "\n[tolerance]\nposition_sigma = 0.001\nsamples = 60\nseed = 2\n"


def test_drive_tolerance_study(tmp_path, capsys):
    """`[tolerance]` in an analyze study: drive_tolerance.csv is the library's result for
    the study's mechanism and motion; the report and the summary carry its figures."""
    import numpy as np
    from closure.tolerance import drive_tolerance
    from linkwright.mechspec import build_dynamics, build_mechanism, joint_frames
    from linkwright.study import load_study
    p = tmp_path / "f.toml"
    p.write_text(FOURBAR.replace("steps = 37", "steps = 13") + DRIVE_TOL)
    assert main(["analyze", str(p), "-o", str(tmp_path / "o"), "--json"]) == 0
    summ = json.loads(capsys.readouterr().out)
    got = pd.read_csv(tmp_path / "o" / "drive_tolerance.csv")
    s = load_study(p)
    ms, ds = s.section("mechanism"), s.section("dynamics")
    drive = pd.read_csv(tmp_path / "o" / "drive.csv")
    t = drive.t.to_numpy()
    T, a, b = 2.0, 0.0, np.pi
    u = t / T
    law = tuple(v[:, None] for v in (a + (b - a) * (u - np.sin(2 * np.pi * u) / (2 * np.pi)),
                                     (b - a) * (1 - np.cos(2 * np.pi * u)) / T,
                                     (b - a) * 2 * np.pi * np.sin(2 * np.pi * u) / T ** 2))
    ref = drive_tolerance(lambda fr: build_dynamics(ds, build_mechanism(ms, fr)),
                          *joint_frames(ms), t, law, position_sigma=0.001, samples=60, seed=2)
    assert np.allclose(got.sd, ref.summary.sd, rtol=1e-9)
    assert np.allclose(got.drive, drive["drive:A"], rtol=1e-9, atol=1e-9)
    assert summ["drive_tolerance_failed"] == 0
    assert summ["peak_drive_sd"]["unit"] == "N·m"
    assert "Drive force tolerances" in (tmp_path / "o" / "report.md").read_text()


def test_drive_tolerance_study_checks(tmp_path, capsys):
    p = tmp_path / "f.toml"
    no_dyn = FOURBAR[:FOURBAR.index("[dynamics]")]
    p.write_text(no_dyn + DRIVE_TOL)
    assert main(["analyze", str(p), "-o", str(tmp_path / "o")]) == 2
    assert "tolerance" in capsys.readouterr().err
    p.write_text(FOURBAR + DRIVE_TOL.replace("position_sigma = 0.001", "position_sigma = 0.0"))
    assert main(["analyze", str(p), "-o", str(tmp_path / "o")]) == 2
    assert "tolerance.position_sigma" in capsys.readouterr().err
    # tilts stop the planar four-bar: counted and said, not sampled
    p.write_text(FOURBAR.replace("steps = 37", "steps = 7") + DRIVE_TOL.replace(
        "position_sigma = 0.001", "direction_sigma_deg = 0.05").replace("60", "10"))
    assert main(["analyze", str(p), "-o", str(tmp_path / "o2"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["drive_tolerance_failed"] == 10
    assert "cannot follow the motion" in (tmp_path / "o2" / "report.md").read_text()
