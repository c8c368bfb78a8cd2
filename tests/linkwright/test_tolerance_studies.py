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
