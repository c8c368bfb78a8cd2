"""`linkwright stiffness` with a `[mechanism]` (issue 17): the shipped 3-RPS head and Delta
robot, the report against `stiffness.of_mechanism`, the loaded case, the map over the
inputs, and bad studies as exit 2 naming the file and the key."""
import json
import re

import numpy as np
import pandas as pd
import pytest

from linkwright import schema
from linkwright.cli import main
from linkwright.cmd_stiffness import _mechanism_inputs
from linkwright.examples import folder as examples_folder
from linkwright.study import load_study
from stiffness import of_mechanism

EX = examples_folder()
RPS, DELTA = EX / "three_rps_head.toml", EX / "delta_robot.toml"


def run(args, capsys):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def edited(tmp_path, src, old, new, name=None):
    text = src.read_text(encoding="utf-8")
    if old is not None:
        assert re.search(old, text, re.M), old
        text = re.sub(old, new, text, count=1, flags=re.M)
    path = tmp_path / (name or src.name)
    path.write_text(text, encoding="utf-8")
    return path


def library(path, wrench=None):
    """The study's mechanism, pose and K from the library, without the command."""
    study = load_study(path, "stiffness")
    mech, _, platform, springs, locked, x, point = _mechanism_inputs(study)
    pose = mech.solve(x)
    rsec = study.data.get("report", {})
    T = np.asarray(pose.link_frame(platform), float).reshape(-1, 4, 4)[0]
    if rsec.get("frame", "platform") == "platform":
        frame = (T[:3, :3].T, T[:3, :3] @ point + T[:3, 3])
    else:
        frame = "base"
    return mech, pose, of_mechanism(mech, pose, platform=platform, springs=springs,
                                    locked=locked, frame=frame, wrench=wrench)


@pytest.fixture(scope="module")
def rps_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("rps") / "o"
    assert main(["stiffness", str(RPS), "-o", str(out), "--json", "--quiet"]) == 0
    return out


def test_three_rps_report_equals_the_library(rps_run, capsys):
    out = rps_run
    mech, pose, res = library(RPS)
    assert mech.mobility == 3 and pose.ok.all()
    K = pd.read_csv(out / "stiffness.csv").drop(columns="row").to_numpy()
    C = pd.read_csv(out / "compliance.csv").drop(columns="row").to_numpy()
    assert np.abs(K - res.K[0]).max() <= 1e-12 * np.abs(res.K[0]).max()
    assert np.abs(C - res.C[0]).max() <= 1e-12 * np.abs(res.C[0]).max()
    assert res.rigid[0] == 3 and res.elastic == ["P0", "P1", "P2"] and res.locked == []
    rep = (out / "report.md").read_text(encoding="utf-8")
    assert rep.index("## Findings") < rep.index("## Stiffness matrix K")
    assert "3 directions held rigidly" in rep and "Loop condition" in rep
    ct = np.linalg.eigvalsh(res.C[0][:3, :3])                 # the weakest translation
    assert f"a deflection of {ct[-1]:.4g} m/N" in rep


def test_three_rps_loaded_case(rps_run):
    out = rps_run
    study = load_study(RPS, "stiffness")
    W = np.array(study.data["report"]["wrench"], float)
    _, _, loaded = library(RPS, wrench=W)
    _, _, res = library(RPS)
    Kl = pd.read_csv(out / "loaded_stiffness.csv").drop(columns="row").to_numpy()
    assert np.abs(Kl - loaded.K[0]).max() <= 1e-12 * np.abs(loaded.K[0]).max()
    assert loaded.loaded and not np.allclose(Kl, res.K[0], rtol=0, atol=0)
    rep = (out / "report.md").read_text(encoding="utf-8")
    assert "## Load case" in rep and "Loaded stiffness matrix" in rep
    assert "Under the load case: deflection" in rep
    # the deflection Δ = C W of the reference point (W moved to it, in the frame's axes)
    R, p = res.R[0], res.reference[0]
    d = res.C[0] @ np.r_[R @ W[:3], R @ (W[3:] - np.cross(p, W[:3]))]
    assert f"{d[2]:.4g}" in rep


def test_three_rps_map_rows(rps_run):
    mp = pd.read_csv(rps_run / "map.csv")
    assert len(mp) == 7 and mp.ok.all() and not mp.free.any() and (mp.rigid == 3).all()
    assert np.allclose(mp.P0, np.linspace(-0.03, 0.03, 7)) and (mp.P1 == -0.005).all()
    assert (mp.ct_max > 0).all() and (rps_run / "map.png").exists()


def test_delta_robot_runs_and_translates_only(tmp_path, capsys):
    out = tmp_path / "d"
    code, stdout, _ = run(["stiffness", DELTA, "-o", out, "--json", "--quiet"], capsys)
    assert code == 0
    summary = json.loads(stdout)
    assert summary["kind"] == "mechanism" and summary["rigid_directions"] == 3
    assert summary["kt_weakest"]["unit"] == "N/m" and summary["ct_max"]["unit"] == "m/N"
    mech, pose, res = library(DELTA)
    assert mech.mobility == 9 and len(res.passive) == 36          # 6 idle rod spins
    K = pd.read_csv(out / "stiffness.csv").drop(columns="row").to_numpy()
    assert np.abs(K - res.K[0]).max() <= 1e-12 * np.abs(res.K[0]).max()
    assert np.abs(res.C[0][3:, 3:]).max() < 1e-20                # rotations rigid
    assert "the three rotations: the platform only translates" in \
        (out / "report.md").read_text(encoding="utf-8")
    mp = pd.read_csv(out / "map.csv")
    assert len(mp) == 49 and mp.ok.all() and (mp.rigid == 3).all()


def _fails(tmp_path, capsys, path, key, *words):
    code, _, err = run(["stiffness", path, "-o", tmp_path / "o"], capsys)
    assert code == 2, err
    assert str(path) in err and f"key '{key}'" in err, err
    for w in words:
        assert w in err, err
    assert "Traceback" not in err
    return err


def test_both_and_neither_sections(tmp_path, capsys):
    hexapod = (EX / "hexapod.toml").read_text(encoding="utf-8")
    rps = RPS.read_text(encoding="utf-8")
    body = hexapod[hexapod.index("[hexapod]"):hexapod.index("[report]")]
    both = tmp_path / "both.toml"
    both.write_text(rps + "\n" + body, encoding="utf-8")
    _fails(tmp_path, capsys, both, "mechanism", "not both")
    neither = tmp_path / "neither.toml"
    neither.write_text('[study]\ncommand = "stiffness"\n', encoding="utf-8")
    _fails(tmp_path, capsys, neither, "hexapod", "[mechanism]")
    no_elastic = tmp_path / "no_elastic.toml"
    no_elastic.write_text(rps[:rps.index("[elastic]")], encoding="utf-8")
    _fails(tmp_path, capsys, no_elastic, "elastic", "missing")
    with_pose = tmp_path / "with_pose.toml"
    with_pose.write_text(rps + "\n[pose]\nposition = [0.0, 0.0, 0.7]\n", encoding="utf-8")
    _fails(tmp_path, capsys, with_pose, "pose", "elastic.inputs")
    no_pose = tmp_path / "no_pose.toml"
    no_pose.write_text(hexapod[:hexapod.index("[pose]")], encoding="utf-8")
    _fails(tmp_path, capsys, no_pose, "pose", "missing")


def test_unknown_spring_joint(tmp_path, capsys):
    p = edited(tmp_path, RPS, r"^springs = \{P0 = ", "springs = {Q9 = 1.0e7, P0 = ")
    _fails(tmp_path, capsys, p, "elastic.springs", "'Q9'")
    p = edited(tmp_path, RPS, r"^springs = \{P0 = 2.0e7", "springs = {P0 = -2.0e7", "neg.toml")
    _fails(tmp_path, capsys, p, "elastic.springs", "P0: expected a value > 0", "-2.0e7")


def test_bad_locked_and_platform(tmp_path, capsys):
    p = edited(tmp_path, RPS, r"^inputs = \[0.01", 'locked = ["nothing"]\ninputs = [0.01')
    _fails(tmp_path, capsys, p, "elastic.locked", "'nothing'")
    p = edited(tmp_path, RPS, r'^platform = "head"', 'platform = "hed"', "p.toml")
    _fails(tmp_path, capsys, p, "elastic.platform", "head")


def test_free_motion(tmp_path, capsys):
    """Only one leg elastic and the others passive (not locked): the head moves freely."""
    p = edited(tmp_path, RPS, r"^springs = .*$",
               'springs = {P0 = 2.0e7}\nlocked = []')
    _fails(tmp_path, capsys, p, "elastic.springs", "without deforming any spring")


def test_inputs_that_do_not_close(tmp_path, capsys):
    p = edited(tmp_path, RPS, r"^inputs = \[0.01, -0.005, 0.0\]", "inputs = [2.0, -2.0, 0.0]")
    _fails(tmp_path, capsys, p, "elastic.inputs", "does not close")
    p = edited(tmp_path, RPS, r"^inputs = \[0.01, -0.005, 0.0\]", "inputs = [0.01, 0.0]",
               "n.toml")
    _fails(tmp_path, capsys, p, "elastic.inputs", "3 values")


def test_map_keys_of_the_other_kind(tmp_path, capsys):
    p = edited(tmp_path, RPS, r"^inputs = \[\[", "x = [-0.1, 0.1, 3]\ninputs = [[")
    _fails(tmp_path, capsys, p, "map.x", "hexapod")
    p = edited(tmp_path, RPS, r"^inputs = \[\[-0.03, 0.03, 7\], ", "inputs = [", "short.toml")
    _fails(tmp_path, capsys, p, "map.inputs", "3 ranges")
    h = edited(tmp_path, EX / "hexapod.toml", r"^\[map\]", "[map]\ninputs = [[0.0, 1.0, 2]]")
    _fails(tmp_path, capsys, h, "map.inputs", "hexapod")


def test_the_examples_use_only_documented_keys():
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib
    text = schema.reference("stiffness")
    for path in (RPS, DELTA, BEAMS):
        data = tomllib.loads(path.read_text(encoding="utf-8"))
        keys = schema.example_keys(data)
        assert "elastic.springs" in keys and not any(k.startswith("elastic.springs.")
                                                      for k in keys)
        for key in keys:
            assert f"`{key}`" in text or f"`[{key}]`" in text or f"`[[{key}]]`" in text, key


# ---------------------------------------------------------------- elastic links in a study
BEAMS = EX / "three_rps_beams.toml"


def _beams_by_hand(mech, data):
    """The study's link springs built independently of the command: F at the tip with x
    along the beam from the joint's origin (y the world axis most across it), K the
    beam's end stiffness."""
    from stiffness import beam_stiffness
    out = []
    for b in data["elastic"]["link"]:
        j = next(j for j in mech.joints if j.name == b["joint"])
        root, tip = j.frame_a[:3, 3], np.array(b["tip"], float)
        x = (tip - root) / np.linalg.norm(tip - root)
        y = np.eye(3)[np.argmin(np.abs(x))]
        y = y - x * (x @ y)
        y /= np.linalg.norm(y)
        F = np.eye(4)
        F[:3, :3], F[:3, 3] = np.c_[x, y, np.cross(x, y)], tip
        L = float(np.linalg.norm(tip - root))
        out.append((b["link"], b["joint"], F, beam_stiffness(
            L, E=b["E"], G=b["G"], area=b["area"], Iy=b["Iy"], Iz=b["Iz"], J=b["J"]), L))
    return out


def test_elastic_links_study_equals_the_library(tmp_path, capsys):
    """The shipped 3-RPS head with beam legs: the report's K, C and loaded K equal
    `of_mechanism` with the beams built by hand; the legs' bending makes the three
    directions the rigid legs held compliant."""
    out = tmp_path / "b"
    code, stdout, _ = run(["stiffness", BEAMS, "-o", out, "--json", "--quiet"], capsys)
    assert code == 0
    assert json.loads(stdout)["rigid_directions"] == 0
    study = load_study(BEAMS, "stiffness")
    mech, _, platform, springs, locked, x, point = _mechanism_inputs(study)
    beams = _beams_by_hand(mech, study.data)
    assert len(beams) == 3
    pose = mech.solve(x)
    T = np.asarray(pose.link_frame(platform), float).reshape(-1, 4, 4)[0]
    kw = dict(platform=platform, springs=springs, locked=locked, link_springs=beams,
              frame=(T[:3, :3].T, T[:3, :3] @ point + T[:3, 3]))
    res = of_mechanism(mech, pose, **kw)
    W = np.array(study.data["report"]["wrench"], float)
    loaded = of_mechanism(mech, pose, wrench=W, **kw)
    rigid_legs = of_mechanism(mech, pose, **{**kw, "link_springs": None})
    for name, ref in (("stiffness.csv", res.K[0]), ("compliance.csv", res.C[0]),
                      ("loaded_stiffness.csv", loaded.K[0])):
        M = pd.read_csv(out / name).drop(columns="row").to_numpy()
        assert np.abs(M - ref).max() <= 1e-12 * np.abs(ref).max(), name
    assert res.rigid[0] == 0 and rigid_legs.rigid[0] == 3
    # the beams add compliance: C with elastic legs exceeds C with rigid ones (PSD difference)
    assert np.linalg.eigvalsh(res.C[0] - rigid_legs.C[0]).min() > -1e-12 * np.abs(res.C[0]).max()
    rep = (out / "report.md").read_text(encoding="utf-8")
    assert "upper0@P0" in rep and "beam of length 0.3734 m" in rep and "P-δ" in rep
    mp = pd.read_csv(out / "map.csv")
    assert len(mp) == 7 and mp.ok.all() and (mp.rigid == 0).all()


def test_elastic_link_bad_keys(tmp_path, capsys):
    p = edited(tmp_path, BEAMS, r'^link = "upper0"', 'link = "uper0"')
    _fails(tmp_path, capsys, p, "elastic.link[0].link", "'uper0'")
    p = edited(tmp_path, BEAMS, r'^joint = "P1" +#', 'joint = "S0"  #', "j.toml")
    _fails(tmp_path, capsys, p, "elastic.link[1].joint", "'S0'", "'upper1'")
    p = edited(tmp_path, BEAMS, r"^tip = \[0.0, 0.12, 0.35\]", "tip = [0.0, 0.25, 0.0]", "t.toml")
    _fails(tmp_path, capsys, p, "elastic.link[0].tip", "origin")
    p = edited(tmp_path, BEAMS, r"^area = 2.545e-4", "area = -2.545e-4", "a.toml")
    _fails(tmp_path, capsys, p, "elastic.link[0].area", "> 0")
    p = edited(tmp_path, BEAMS, r"^springs = .*$", "", "s.toml")
    text = p.read_text(encoding="utf-8")
    p.write_text(text[:text.index("[[elastic.link]]")] + text[text.index("[report]"):],
                 encoding="utf-8")
    _fails(tmp_path, capsys, p, "elastic.springs", "[[elastic.link]]")
