"""Report content checked by parsing (not screenshots): units in every numeric header of
every report of ``linkwright demo``, clean table cells, a findings section first, JSON
summaries with units, the stiffness map at the study's rotation, the RRR ranking
independent of residual noise, ``--quiet`` and progress on a terminal."""
import io
import json
import math
import re
import sys

import numpy as np
import pandas as pd
import pytest

from linkwright.cli import main
from linkwright.examples import folder as examples_folder
from linkwright.render import is_number

EX = examples_folder()
#: identifier columns (numbers that name things, not quantities)
IDS = {"rank", "variant", "rr", "leg", "component", "joint"}


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo") / "d"
    buf = io.StringIO()
    old, sys.stdout = sys.stdout, buf
    try:
        assert main(["demo", "-o", str(out), "--json", "--quiet"]) == 0
    finally:
        sys.stdout = old
    return out, json.loads(buf.getvalue())


def md_tables(text):
    """Each Markdown table as (header cells, rows of cells)."""
    tables, lines, i = [], text.splitlines(), 0
    while i < len(lines):
        if lines[i].startswith("| ") and i + 1 < len(lines) and lines[i + 1].startswith("|---"):
            head = [c.strip() for c in lines[i].strip("|").split(" | ")]
            rows, i = [], i + 2
            while i < len(lines) and lines[i].startswith("| "):
                rows.append([c.strip() for c in lines[i].strip().strip("|").split(" | ")])
                i += 1
            tables.append((head, rows))
        else:
            i += 1
    return tables


def reports(folder):
    return sorted(folder.rglob("report.md"))


def test_every_demo_report_starts_with_findings(demo):
    folder, _ = demo
    assert len(reports(folder)) == 8
    for p in reports(folder):
        lines = [ln for ln in p.read_text().splitlines() if ln.strip()]
        assert lines[0].startswith("# ")
        assert lines[1] == "## Findings", p
        assert lines[2].startswith("- ") and re.search(r"\d", lines[2]), p
        html = (p.parent / "report.html").read_text()
        assert html.index("<h2>Findings</h2>") < html.index("<table")


def test_analyze_plots_the_requested_points_angles_and_lengths_apart(demo):
    folder, _ = demo
    for stem in ("fourbar_dynamics", "seed000_swash_plate"):
        md = (folder / stem / "report.md").read_text()
        assert "## Point paths" in md and "![points.png](points.png)" in md
        assert (folder / stem / "points.png").stat().st_size > 1000
        assert "![joints.png](joints.png)" in md


def test_units_in_every_numeric_header_and_clean_cells(demo):
    folder, _ = demo
    checked = 0
    for p in reports(folder):
        for head, rows in md_tables(p.read_text()):
            for row in rows:
                assert len(row) == len(head), (p, head, row)
                for c in row:
                    assert "\\n" not in c and "np." not in c and "array(" not in c, (p, c)
            if "unit" in head:                       # tidy tables: the unit in its column
                continue
            for j, h in enumerate(head):
                cells = [r[j] for r in rows if r[j]]
                if cells and all(is_number(c) or c.startswith("[") for c in cells) \
                        and h not in IDS:
                    assert re.search(r"\(.+\)$", h), f"{p}: header {h!r} has no unit"
                    checked += 1
        html = (p.parent / "report.html").read_text()
        for c in re.findall(r"<td>(.*?)</td>", html, re.S):
            assert "\n" not in c and "np." not in c and "array(" not in c
    assert checked > 30


def _bare_floats(value, path=""):
    """Paths of floats in a JSON summary that are not the value of a {value, unit}."""
    if isinstance(value, dict):
        if set(value) == {"value", "unit"}:
            assert isinstance(value["unit"], str) and value["unit"], path
            return []
        return [p for k, v in value.items() for p in _bare_floats(v, f"{path}.{k}")]
    if isinstance(value, list):
        return [p for i, v in enumerate(value) for p in _bare_floats(v, f"{path}[{i}]")]
    return [path] if isinstance(value, float) else []


def test_json_summaries_carry_units(demo, tmp_path, capsys):
    _, summary = demo
    results = summary["results"]
    assert set(results) == {"fourbar_dynamics", "hexapod", "seed000_swash_plate",
                            "seed001_rrr", "seed004_cylinder", "three_rps_head", "delta_robot",
                            "three_rps_beams"}
    for name, s in results.items():
        assert _bare_floats(s) == [], name
    assert results["hexapod"]["kt_min"]["unit"] == "N/m"
    assert math.isclose(results["hexapod"]["kt_min"]["value"], 2.0271e7, rel_tol=1e-3)
    assert results["seed004_cylinder"]["max_sigma"]["unit"] == "(rad/m)^½"
    assert results["fourbar_dynamics"]["max_drive"]["unit"] == "N·m"
    # the one-line summary shows the units too
    assert main(["stiffness", str(EX / "hexapod.toml"), "-o", str(tmp_path / "s")]) == 0
    assert "kt_min = 2.027e+07 N/m" in capsys.readouterr().out


def test_stiffness_map_uses_the_study_rotation_and_the_axes_that_vary(tmp_path, capsys):
    text = (EX / "hexapod.toml").read_text()
    text = text.replace("rotation_deg = [0.0, 0.0, 0.0]", "rotation_deg = [0.0, 5.0, 10.0]")
    text = text.replace("y = [-0.15, 0.15, 13]", "z = [0.6, 0.8, 5]").replace(
        "z = [0.7, 0.7, 1]", "")
    study = tmp_path / "xz.toml"
    study.write_text(text)
    assert main(["stiffness", str(study), "-o", str(tmp_path / "o"), "--json"]) == 0
    summ = json.loads(capsys.readouterr().out)
    mp = pd.read_csv(tmp_path / "o" / "map.csv")
    assert len(mp) == 13 * 5 and mp.y.nunique() == 1
    want = np.radians([0.0, 5.0, 10.0])
    assert np.allclose(mp[["rx", "ry", "rz"]].to_numpy(), want, atol=1e-12)
    assert np.allclose(summ["map_rotation"]["value"], [0.0, 5.0, 10.0])
    md = (tmp_path / "o" / "report.md").read_text()
    assert "Varying: x, z" in md and "![map.png](map.png)" in md
    # the map equals the API's map at the same rotation
    from linkwright.study import load_study
    from stiffness import Hexapod
    h = load_study(study).section("hexapod")
    hx = Hexapod(h.get("base_points", "points"), h.get("platform_points", "points"), 2.0e7)
    ref = hx.map(mp[["x", "y", "z"]].to_numpy(), [want])
    assert np.allclose(mp.kt_min, ref.kt_min, rtol=1e-12)


def test_plot_map_draws_the_axes_that_vary(tmp_path):
    from stiffness import Hexapod, plot_map
    from linkwright.study import load_study
    h = load_study(EX / "hexapod.toml").section("hexapod")
    hx = Hexapod(h.get("base_points", "points"), h.get("platform_points", "points"), 2.0e7)
    pos = np.array([(x, 0.0, z) for x in np.linspace(-0.1, 0.1, 4) for z in (0.6, 0.7, 0.8)])
    fig = plot_map(hx.map(pos), "kt_min")
    ax = fig.axes[0]
    assert ax.get_xlabel() == "x (m)" and ax.get_ylabel() == "z (m)"
    assert np.isfinite(ax.collections[0].get_array()).all()     # not blank


def _rrr():
    from linkwright.study import load_study
    from synthesis import Screw, enumerate_dyads
    from synthesis.validate import task_scale
    s = load_study(EX / "seed001_rrr.toml")
    screws = [Screw.from_degrees(p.get("axis", "vec3"), p.get("point", "vec3"),
                                 p.get("angle_deg"), p.get("slide"))
              for p in s.sections("position")]
    T = [np.eye(4)] + [sc.matrix() for sc in screws]
    _, extent, _ = task_scale(T, [sc.axis for sc in screws], [sc.point for sc in screws])
    return enumerate_dyads("RRR", screws), extent, len(T)


def test_rrr_ranking_does_not_depend_on_residual_noise():
    from linkwright.cmd_synth import rank_variants
    df, size, n = _rrr()
    base = rank_variants(df, "link_length", np.zeros(3), size, n)
    assert base["rank"].notna().all()
    rng = np.random.default_rng(1)
    for _ in range(3):
        noisy = df.copy()
        noisy["residual"] = rng.uniform(0, 3e-15, len(df))
        r = rank_variants(noisy, "link_length", np.zeros(3), size, n)
        assert (r["rank"] == base["rank"]).all()
    # lengths perturbed at round-off do not reorder either
    jitter = df.copy()
    cols = [c for c in df.columns if re.match(r"j\d_[xyz]$", c)]
    jitter[cols] = jitter[cols] * (1 + rng.uniform(-1e-15, 1e-15, (len(df), len(cols))))
    assert (rank_variants(jitter, "link_length", np.zeros(3), size, n)["rank"]
            == base["rank"]).all()
    # a variant whose residual exceeds the tolerance is excluded, not ranked last
    bad = df.copy()
    best = base.loc[base["rank"] == 1].index[0]
    bad.loc[best, "residual"] = 1e-6
    r = rank_variants(bad, "link_length", np.zeros(3), size, n)
    assert np.isnan(r.loc[best, "rank"]) and r.loc[best, "check"].startswith("residual above")
    assert r["rank"].max() == len(df) - 1
    assert np.all(base.condition > 1) and np.all(np.isfinite(base.condition))


class FakeTerminal(io.StringIO):
    def isatty(self):
        return True


@pytest.mark.parametrize("quiet", [False, True])
def test_quiet_and_progress_on_a_terminal(quiet, tmp_path, monkeypatch, capsys):
    term = FakeTerminal()
    monkeypatch.setattr(sys, "stderr", term)
    args = ["synth", str(EX / "seed001_rrr.toml"), "-o", str(tmp_path / "o")]
    assert main(args + (["--quiet"] if quiet else [])) == 0
    out = capsys.readouterr().out
    if quiet:
        assert term.getvalue() == "" and out == ""
    else:
        assert "linkwright: synthesising RRR through 4 positions" in term.getvalue()
        assert "ranking variants" in term.getvalue()          # the tqdm bar
        assert out.startswith("linkwright synth: family = RRR")


def test_progress_is_silent_when_not_a_terminal(tmp_path, capsys):
    assert main(["synth", str(EX / "seed001_rrr.toml"), "-o", str(tmp_path / "o")]) == 0
    assert capsys.readouterr().err == ""


def test_demo_index_shows_a_drawing_per_drawn_study(demo):
    folder, _ = demo
    index = (folder / "index.html").read_text()
    for stem in ("fourbar_dynamics", "seed000_swash_plate", "seed001_rrr"):
        (img,) = re.findall(rf"<img src='({stem}/[^']+\.png)'", index)
        assert (folder / img).read_bytes()[:4] == b"\x89PNG"
        assert (folder / img).with_suffix(".html").exists()       # and its animation
