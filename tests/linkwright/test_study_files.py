"""Study files: one strict schema per command (unknown keys are errors with a suggestion),
the reference page and starter studies generated from it, `run` dispatching on
[study].command, degenerate input as one-line errors, output folders checked first."""
import json
import os
import pathlib
import re

import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

from linkwright import schema
from linkwright.cli import main
from linkwright.examples import folder as examples_folder, studies
from linkwright.output import MARKER, Outputs
from linkwright.study import StudyError, load_study

from .util import ROOT, tree

EX = examples_folder()
DOC = ROOT / "docs" / "study-files.md"
COMMAND_OF = {"seed001_rrr.toml": "synth", "hexapod.toml": "stiffness",
              "seed004_cylinder.toml": "approx", "fourbar_dynamics.toml": "analyze",
              "seed000_swash_plate.toml": "analyze", "three_rps_head.toml": "stiffness",
              "delta_robot.toml": "stiffness", "three_rps_beams.toml": "stiffness"}


def run(args, capsys):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def clean(err: str) -> None:
    """No numpy reprs, Python warning lines or tracebacks on the terminal."""
    for bad in ("np.float64(", "array(", "Traceback", "Warning:", "warnings.warn", ".py:"):
        assert bad not in err, err


def edited(tmp_path, name, old, new, count=1):
    text = (EX / name).read_text()
    if old.startswith("re:"):
        text, n = re.subn(old[3:], new, text, count=count, flags=re.M)
        assert n, old
    else:
        assert old in text, old
        text = text.replace(old, new, count)
    p = tmp_path / name
    p.write_text(text)
    return p


def earlier_outputs(folder) -> dict:
    """An earlier run's output set in ``folder``; returns its snapshot."""
    o = Outputs(folder, "stiffness")
    o.add("old.csv", "a,b\n1,2\n")
    o.commit()
    return tree(folder)


# name → (study, old text, new text, command, key, words); key None: the message names
# the file only (a binary file)
MALFORMED = {
    "unknown key": ("hexapod.toml", "rotation_deg =", "rotation_degs =", "stiffness",
                    "pose.rotation_degs", "unknown key; did you mean 'rotation_deg'?"),
    "unknown section": ("hexapod.toml", "[report]", "[reprot]", "stiffness", "reprot",
                        "unknown section; did you mean 'report'?"),
    "grid in a plain run": ("hexapod.toml", "[report]", '[grid]\n"hexapod.leg_stiffness" = '
                            '[1.0e7, 2.0e7]\n[report]', "stiffness", "grid",
                            "runs case by case with `linkwright grid FILE -o OUT`"),
    "NaN": ("hexapod.toml", "position = [0.0, 0.0, 0.7]", "position = [0.0, nan, 0.7]",
            "stiffness", "pose.position", "expected finite numbers"),
    "wrong type": ("seed001_rrr.toml", "angle_deg = 30.0", 'angle_deg = "30"', "synth",
                   "position[0].angle_deg", "expected a number"),
    "negative stiffness": ("hexapod.toml", "leg_stiffness = 2.0e7", "leg_stiffness = -2.0e7",
                           "stiffness", "hexapod.leg_stiffness", "> 0 (N/m)"),
    "empty list": ("fourbar_dynamics.toml", 'links = ["crank", "coupler", "rocker"]',
                   "links = []", "analyze", "mechanism.links", "non-empty list"),
    "singular pose": ("hexapod.toml", "position = [0.0, 0.0, 0.7]",
                      "position = [0.0, 0.0, 0.0]", "stiffness", "pose",
                      "pose is singular (cond(P) = "),
    "wrong command": ("hexapod.toml", "[pose]", "[pose]", "synth", "study.command",
                      "this is a stiffness study"),
    "binary file": ("hexapod.toml", None, None, "stiffness", None, "not a text file"),
}


@pytest.mark.parametrize("case", list(MALFORMED) + ["unwritable output"])
def test_malformed_study_files_exit_2_name_file_and_key_and_write_nothing(case, tmp_path,
                                                                           capsys, monkeypatch):
    out = tmp_path / "out"
    before = earlier_outputs(out)
    fresh = tmp_path / "fresh"
    if case == "unwritable output":
        (tmp_path / "afile").write_text("x")
        real = os.access

        def read_only(path, mode, *a, **k):     # root writes anywhere: pretend
            if mode & os.W_OK and (pathlib.Path(path) in (tmp_path, out) or "dir_fd" in k):
                return False
            return real(path, mode, *a, **k)
        for target, words in ((tmp_path / "afile" / "sub", "is a file, not a folder"),
                              (fresh, "read-only"), (out, "read-only")):
            if target != tmp_path / "afile" / "sub":
                monkeypatch.setattr(os, "access", read_only)
            code, stdout, err = run(["run", EX / "hexapod.toml", "-o", target], capsys)
            assert code == 2 and f"output folder {target}" in err and words in err, err
            assert len(err.strip().splitlines()) == 1 and stdout == ""
            clean(err)
        assert not fresh.exists() and (tmp_path / "afile").read_text() == "x"
        assert tree(out) == before
        return
    name, old, new, cmd, key, words = MALFORMED[case]
    if old is None:
        study = tmp_path / name
        study.write_bytes(bytes(range(256)) * 4)
    else:
        study = edited(tmp_path, name, old, new)
    for target in (out, fresh):
        code, stdout, err = run([cmd, study, "-o", target], capsys)
        assert code == 2, err
        assert str(study) in err and words in err, err
        if key is not None:
            assert f"key '{key}'" in err, err
        assert len(err.strip().splitlines()) == 1, err     # a headline, not a table
        clean(err)
        assert stdout == ""
    assert tree(out) == before and not fresh.exists()


def test_singular_pose_names_the_degenerate_legs(tmp_path, capsys):
    study = edited(tmp_path, "hexapod.toml", "position = [0.0, 0.0, 0.7]",
                   "position = [0.0, 0.0, 0.0]")
    code, _, err = run(["stiffness", study, "-o", tmp_path / "o"], capsys)
    assert code == 2
    assert re.search(r"key 'pose': pose is singular \(cond\(P\) = [^)]+\): legs [\d, ]+ are "
                     r"degenerate", err), err


def test_hexapod_errors_keep_the_file_and_the_key(tmp_path, capsys):
    study = edited(tmp_path, "hexapod.toml", "[-0.375877, -0.136808, 0.0],", "")
    code, _, err = run(["stiffness", study, "-o", tmp_path / "o"], capsys)
    assert code == 2 and str(study) in err and "key 'hexapod.platform_points'" in err, err


def test_an_out_of_reach_range_is_blamed_on_b_not_on_n(tmp_path, capsys):
    study = edited(tmp_path, "seed004_cylinder.toml", "b = 0.3", "b = 5.0")
    code, _, err = run(["approx", study, "-o", tmp_path / "o"], capsys)
    assert code == 2 and "key 'approx.b'" in err, err


def test_every_error_is_one_line_with_file_and_dotted_key():
    p = EX / "fourbar_dynamics.toml"
    data = tomllib.loads(p.read_text())
    data["mechanism"]["joint"][2]["orign"] = [0, 0, 0]
    with pytest.raises(StudyError, match=r"key 'mechanism.joint\[2\].orign': unknown key; "
                                         r"did you mean 'origin'\?"):
        schema.validate(p, data, "analyze")
    data = tomllib.loads(p.read_text())
    data["dynamics"]["body"][1]["inertia"] = [[1, 0, 0], [0, float("inf"), 0]]
    with pytest.raises(StudyError, match=r"key 'dynamics.body\[1\].inertia': expected finite"):
        schema.validate(p, data, "analyze")
    data = tomllib.loads(p.read_text())
    data["sweep"]["steps"] = 37.0
    with pytest.raises(StudyError, match=r"key 'sweep.steps': expected an integer, got 37.0"):
        schema.validate(p, data, "analyze")
    data["sweep"] = 3
    with pytest.raises(StudyError, match=r"key 'sweep': expected a table \[sweep\]"):
        schema.validate(p, data, "analyze")


# ----------------------------------------------------------------------------- synth input

def synth_study(tmp_path, positions):
    text = ['[study]\ncommand = "synth"\n[synthesis]\nfamily = "RRR"']
    for axis, point, angle, slide in positions:
        text.append(f"[[position]]\naxis = {axis}\npoint = {point}\nangle_deg = {angle}\n"
                    f"slide = {slide}")
    p = tmp_path / "s.toml"
    p.write_text("\n".join(text) + "\n")
    return p


RRR = [([0.0, 0.0, 1.0], [0.0, 0.0, 0.0], 30.0, 0.7),
       ([0.34202, 0.0, 0.939693], [0.0, 1.1, 0.0], 65.0, 0.5),
       ([0.66, 0.043589, 0.75], [0.25, 1.2, -0.289742], 75.0, 0.3)]


def test_a_nearly_unit_screw_axis_is_normalised_with_a_one_line_warning(tmp_path, capsys):
    ref = tmp_path / "ref"
    assert run(["run", synth_study(tmp_path, RRR), "-o", ref, "--quiet"], capsys)[0] == 0
    scaled = [([0.0, 0.0, 1.004], *RRR[0][1:])] + RRR[1:]
    code, _, err = run(["run", synth_study(tmp_path, scaled), "-o", tmp_path / "o", "--quiet"],
                       capsys)
    assert code == 0
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("linkwright: warning: ") and \
        "key 'position[0].axis': not of unit length (|axis| = 1.004); normalised" in lines[0]
    clean(err)
    assert (tmp_path / "o" / "variants.csv").read_bytes() == (ref / "variants.csv").read_bytes()
    far = [([0.0, 0.0, 1.05], *RRR[0][1:])] + RRR[1:]
    code, _, err = run(["run", synth_study(tmp_path, far), "-o", tmp_path / "o2"], capsys)
    assert code == 2 and "key 'position[0].axis': expected a unit direction" in err
    assert not (tmp_path / "o2").exists()


def test_planar_and_repeated_positions_are_headline_errors(tmp_path, capsys):
    planar = [([0, 0, 1], [0, 0, 0], 30, 0), ([0, 0, 1], [1, 0, 0], 60, 0),
              ([0, 0, 1], [0, 1, 0], 45, 0)]
    code, _, err = run(["synth", synth_study(tmp_path, planar), "-o", tmp_path / "o"], capsys)
    assert code == 2 and "key 'position': positions are planar: use the planar case" in err
    twice = [RRR[0], RRR[1], RRR[1]]
    code, _, err = run(["synth", synth_study(tmp_path, twice), "-o", tmp_path / "o"], capsys)
    assert code == 2 and "key 'position[2]'" in err and \
        "position[1] and position[2] are the same displacement" in err, err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


# ----------------------------------------------------------------------------- commands

def test_run_dispatches_on_study_command(tmp_path, capsys):
    code, out, _ = run(["run", EX / "seed004_cylinder.toml", "-o", tmp_path / "o", "--json"],
                       capsys)
    assert code == 0 and json.loads(out)["command"] == "approx"
    assert json.loads((tmp_path / "o" / MARKER).read_text())["command"] == "approx"
    bare = tmp_path / "bare.toml"
    bare.write_text((EX / "seed001_rrr.toml").read_text().replace('command = "synth"', ""))
    code, _, err = run(["run", bare, "-o", tmp_path / "b"], capsys)
    assert code == 2 and "key 'study.command': missing" in err
    assert run(["synth", bare, "-o", tmp_path / "b", "--quiet"], capsys)[0] == 0


def test_schema_prints_the_reference_of_each_kind(capsys):
    for cmd in schema.COMMANDS:
        code, out, _ = run(["schema", cmd], capsys)
        assert code == 0 and out == schema.reference(cmd, level=1)
        for key, f, _ in schema._walk(schema.SCHEMAS[cmd]):
            if schema._section_of(f) is None:
                assert f"`{key}`" in out, key
    code, out, _ = run(["schema"], capsys)
    assert code == 0 and out == schema.reference_markdown()


@pytest.mark.parametrize("cmd", schema.COMMANDS)
def test_init_writes_a_starter_that_validates_and_runs_and_never_overwrites(cmd, tmp_path,
                                                                             capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, _ = run(["init", cmd], capsys)
    assert code == 0 and (tmp_path / f"{cmd}.toml").exists()
    text = (tmp_path / f"{cmd}.toml").read_text()
    assert text.count("\n#") > 3                         # commented
    assert load_study(tmp_path / f"{cmd}.toml").command == cmd
    code, _, err = run(["init", cmd, "-o", f"{cmd}.toml"], capsys)
    assert code == 2 and "never overwrites" in err
    assert (tmp_path / f"{cmd}.toml").read_text() == text
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".linkwright-")]
    code, _, err = run(["run", f"{cmd}.toml", "-o", "out", "--quiet"], capsys)
    assert code == 0, err
    assert run(["init", cmd, "-o", "-"], capsys)[1] == text


def test_a_rerun_leaves_no_stale_files_of_an_earlier_run(tmp_path, capsys):
    out = tmp_path / "out"
    assert run(["stiffness", EX / "hexapod.toml", "-o", out, "--quiet"], capsys)[0] == 0
    assert (out / "map.csv").exists() and (out / "leg_forces.csv").exists()
    text = (EX / "hexapod.toml").read_text()
    small = tmp_path / "small.toml"
    small.write_text(text[:text.index("[report]")])      # no load case, no map
    assert run(["stiffness", small, "-o", out, "--quiet"], capsys)[0] == 0
    marker = json.loads((out / MARKER).read_text())
    assert sorted(p.name for p in out.iterdir() if p.name != MARKER) == marker["entries"]
    assert not (out / "map.csv").exists() and not (out / "leg_forces.csv").exists()
    assert not (out / "map.png").exists()


# ----------------------------------------------------------------------------- the reference

def test_the_reference_page_is_generated_from_the_schema_and_lists_every_example_key():
    text = DOC.read_text(encoding="utf-8")
    assert text == schema.reference_markdown(), \
        "docs/study-files.md is stale: regenerate it (see its first comment)"
    parts = {cmd: schema.reference(cmd) for cmd in schema.COMMANDS}
    for path in studies():
        data = tomllib.loads(path.read_text())
        cmd = COMMAND_OF[path.name]
        assert data["study"]["command"] == cmd
        for key in schema.example_keys(data):
            is_table = _section_key(cmd, key)
            needles = ([f"### `[{key}]`", f"### `[[{key}]]`"] if is_table
                       else [f"| `{key}` |"])
            assert any(n in parts[cmd] and n in text for n in needles), (path.name, key)
    for cmd in schema.COMMANDS:                           # every key has its six columns
        for row in re.findall(r"^\| `[^`]+` \|.*$", parts[cmd], re.M):
            cells = [c.strip() for c in row.strip("|").split("|")]
            assert len(cells) == 6 and cells[3] and cells[4] and cells[5], row


def _section_key(cmd, key) -> bool:
    for k, f, _ in schema._walk(schema.SCHEMAS[cmd]):
        if k == key:
            return schema._section_of(f) is not None
    return False


def test_every_shipped_example_validates():
    for path in studies():
        assert load_study(path).command == COMMAND_OF[path.name]


def test_schema_defaults_and_limits_are_the_packages_own():
    from approx import cylinder
    from approx.fit import MAX_N
    from closure import JOINT_KINDS
    from linkwright.cmd_stiffness import MAX_MAP_POSES
    from linkwright.cmd_synth import CRITERIA
    cy = schema.CylinderSection.model_fields
    assert (cy["B"].default, cy["B0"].default, cy["B3"].default) == \
        (cylinder.B, cylinder.B0, cylinder.B3)
    assert schema.ForceSection.model_fields["duration"].default == cylinder.TAU
    assert f"≤ {MAX_N}" in schema._bounds(schema.ApproxSection.model_fields["n"])
    assert set(schema.JOINT_KIND_NAMES) == set(JOINT_KINDS)
    assert f"{MAX_MAP_POSES:,}" in schema.MapSection.__doc__
    assert "one of 'link_length', 'axis_distance'" == \
        schema._kind(schema.CriterionSection.model_fields["kind"]) and \
        CRITERIA == ("link_length", "axis_distance")
