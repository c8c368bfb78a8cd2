"""Drawings and animations of mechanisms (linkwright.draw, ``linkwright draw``): the drawn
geometry is the engine's, the page is offline and well formed, the command writes its files
and rejects bad input with exit status 2."""
from __future__ import annotations

import json
import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from linkwright.cli import main
from linkwright.study import load_study

EX = Path(__file__).resolve().parents[2] / "linkwright" / "examples"


def _analyze(name="seed000_swash_plate.toml"):
    from linkwright.cmd_draw import analyze_scene
    return analyze_scene(load_study(EX / name, None))


def test_joint_positions_are_the_pose_joint_frames():
    """Every frame's joint origin and axis equal link frame × joint placement (independent
    of the engine's stored joint frames) to 1e-12; the U and S joints of the swash plate
    included, and the frame on link b too."""
    mech, poses, scn = _analyze()
    assert len(scn) == len(poses) and {j["kind"] for j in scn.joints} >= {"R", "U", "S"}
    for k, j in enumerate(mech.joints):
        Ta = np.asarray(poses.link_frame(j.link_a)) @ j.frame_a
        Tb = np.asarray(poses.link_frame(j.link_b)) @ j.frame_b
        assert np.abs(scn.position[:, k] - Ta[:, :3, 3]).max() < 1e-12
        assert np.abs(scn.axis[:, k] - Ta[:, :3, 2]).max() < 1e-12
        assert np.abs(scn.position_b[:, k] - Tb[:, :3, 3]).max() < 1e-12
        assert np.abs(scn.axis_b[:, k] - Tb[:, :3, 2]).max() < 1e-12
        assert scn.joints[k]["ground"] == (mech.ground in (j.link_a, j.link_b))


def test_point_paths_and_html_frames_match_the_engine():
    from linkwright.draw import html_animation, subsample
    mech, poses, scn = _analyze("fourbar_dynamics.toml")
    P = np.asarray(poses.point("coupler", [1.5, 1.5, 0.0]))
    assert np.abs(scn.paths["coupler_mid"] - P).max() < 1e-12
    page = html_animation(scn, limit=10)
    data = json.loads(re.search(r'<script id="scene-data" type="application/json">(.*?)'
                                r"</script>", page, re.S).group(1).replace("<\\/", "</"))
    idx = subsample(len(scn), 10)
    assert len(data["frames"]) == len(idx) <= 10 and idx[0] == 0 and idx[-1] == len(scn) - 1
    for f, i in zip(data["frames"], idx):       # the page's joints are the engine's
        for k, j in enumerate(mech.joints):
            Ta = np.asarray(poses.link_frame(j.link_a))[i] @ j.frame_a
            assert np.abs(np.array(f["position"][k]) - Ta[:3, 3]).max() < 1e-12
            assert np.abs(np.array(f["axis"][k]) - Ta[:3, 2]).max() < 1e-12


def test_html_is_offline_and_parses():
    from linkwright.draw import html_animation
    _, _, scn = _analyze()
    page = html_animation(scn)
    assert not re.search(r"https?:|//cdn|<link|src=", page, re.I)

    class P(HTMLParser):
        def __init__(self):
            super().__init__()
            self.tags, self.open = [], []

        def handle_starttag(self, tag, attrs):
            self.tags.append(tag)

    p = P()
    p.feed(page)
    p.close()
    assert {"html", "canvas", "script", "input"} <= set(p.tags)
    data = json.loads(re.search(r'type="application/json">(.*?)</script>', page, re.S)
                      .group(1).replace("<\\/", "</"))
    assert len(data["frames"]) == len(scn) == 37


def test_rrr_variant_body_frames_are_the_task_poses():
    from linkwright.cmd_draw import synth_scenes
    scenes, skipped = synth_scenes(load_study(EX / "seed001_rrr.toml", None), best=2)
    assert len(scenes) == 2 and skipped == 0
    for _, scn, T in scenes:
        assert len(scn) == 4 and np.abs(scn.fixed_frames["given"] - T).max() == 0
        assert np.abs(scn.frames["body"] - T).max() < 1e-9
        # the body's joint (j3) moves with the body: its frame is the body's pose × placement
        assert np.abs(scn.position_b[:, 2] - (T[:, :3, :3] @ scn.position_b[0, 2])
                      - T[:, :3, 3]).max() < 1e-9


def test_draw_figure_has_equal_scales():
    from linkwright.draw import draw
    _, _, scn = _analyze("fourbar_dynamics.toml")
    fig = draw(scn)
    ax = fig.axes[0]
    spans = [np.ptp(ax.get_xlim()), np.ptp(ax.get_ylim()), np.ptp(ax.get_zlim())]
    assert np.allclose(spans, spans[0])
    import matplotlib.pyplot as plt
    plt.close(fig)


def test_draw_command_on_the_examples(tmp_path, capsys):
    assert main(["examples", "-o", str(tmp_path / "ex")]) == 0
    assert main(["draw", str(tmp_path / "ex" / "fourbar_dynamics.toml"), "-o",
                 str(tmp_path / "a"), "--quiet"]) == 0
    assert (tmp_path / "a" / "mechanism.png").read_bytes()[:4] == b"\x89PNG"
    assert "<canvas" in (tmp_path / "a" / "mechanism.html").read_text()
    capsys.readouterr()
    assert main(["draw", str(tmp_path / "ex" / "seed001_rrr.toml"), "-o", str(tmp_path / "s"),
                 "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["variants"] and all(Path(f).exists() for f in summary["files"])
    assert {Path(f).suffix for f in summary["files"]} == {".png", ".html"}


def test_draw_command_on_a_hexapod_stiffness_study(tmp_path, capsys):
    from linkwright.cmd_draw import hexapod_drawing
    from linkwright.study import load_study as load
    assert main(["draw", str(EX / "hexapod.toml"), "-o", str(tmp_path / "h"), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert {Path(f).name for f in summary["files"]} == {"hexapod.png", "hexapod.html"}
    # the drawn joints are the hexapod's attachment points at the study's pose
    from linkwright.cmd_stiffness import hexapod_of
    study = load(EX / "hexapod.toml")
    hx, T = hexapod_of(study)
    scn, _ = hexapod_drawing(study)
    want = np.vstack([hx.base, hx.platform_points_world(T)])
    got = np.asarray(scn.position[0], float).reshape(-1, 3)
    for w in want:
        assert np.min(np.linalg.norm(got - w, axis=1)) < 1e-12


@pytest.mark.parametrize("name", ["seed004_cylinder.toml", "missing.toml"])
def test_draw_bad_input_exits_2_naming_the_file(name, tmp_path, capsys):
    study = (EX / name) if (EX / name).exists() else tmp_path / name
    assert main(["draw", str(study), "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert str(study) in err and ("approx study" in err or "file not found" in err)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("name", ["three_rps_head.toml", "three_rps_beams.toml",
                                  "delta_robot.toml"])
def test_draw_command_on_a_mechanism_stiffness_study(name, tmp_path, capsys):
    """``linkwright draw`` on a mechanism stiffness study: the mechanism at the study's
    pose (PNG and page), its joints the engine's joint frames at the solved pose (1e-12),
    the arrows the weakest and stiffest translation directions of the stiffness report at
    K's reference point; the drawing is the report's."""
    import pandas as pd

    from linkwright.cmd_draw import mechanism_drawing
    from linkwright.cmd_stiffness import mechanism_of
    assert main(["draw", str(EX / name), "-o", str(tmp_path / "d"), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert {Path(f).name for f in summary["files"]} == {"mechanism.png", "mechanism.html"}
    assert (tmp_path / "d" / "mechanism.png").read_bytes()[:4] == b"\x89PNG"
    study = load_study(EX / name, None)
    ms = mechanism_of(study)
    data = _page_data((tmp_path / "d" / "mechanism.html").read_text())
    (frame,) = data["frames"]
    for k, j in enumerate(ms.mech.joints):
        Ta = np.asarray(ms.pose.link_frame(j.link_a)).reshape(4, 4) @ j.frame_a
        Tb = np.asarray(ms.pose.link_frame(j.link_b)).reshape(4, 4) @ j.frame_b
        assert np.abs(np.array(frame["position"][k]) - Ta[:3, 3]).max() < 1e-12
        assert np.abs(np.array(frame["axis"][k]) - Ta[:3, 2]).max() < 1e-12
        assert np.abs(np.array(frame["position_b"][k]) - Tb[:3, 3]).max() < 1e-12
    assert main(["stiffness", str(EX / name), "-o", str(tmp_path / "s"), "--quiet"]) == 0
    C = pd.read_csv(tmp_path / "s" / "compliance.csv")[["fx", "fy", "fz"]].to_numpy()[:3]
    w, V = np.linalg.eigh((C + C.T) / 2)                  # ascending compliance
    R = np.asarray(ms.res.R[0])
    for arrow, v in (("weakest", V[:, 2]), ("stiffest", V[:, 0])):
        o, d = (np.array(a) for a in frame["arrows"][arrow])
        assert np.abs(o - np.asarray(ms.res.reference[0])).max() < 1e-12
        assert abs(abs((d / np.linalg.norm(d)) @ (R.T @ v)) - 1) < 1e-6
    assert _page_data((tmp_path / "s" / "mechanism.html").read_text()) == data
    assert mechanism_drawing(study).title == data["title"]


@pytest.mark.skipif(shutil.which("chromium") is None, reason="Debian chromium not installed")
def test_html_in_a_real_browser(tmp_path):
    """Headless Chromium: the page loads without console errors and another slider position
    (``#frame=N``, which sets the slider) draws other pixels."""
    from linkwright.draw import html_animation
    _, _, scn = _analyze("fourbar_dynamics.toml")
    page = tmp_path / "m.html"
    page.write_text(html_animation(scn))
    shots = [_shot(page, f"frame={frame}") for frame in (0, len(scn) - 1)]
    assert np.abs(shots[0] - shots[1]).sum() > 0


def _shot(page, hash_):
    """A headless Chromium screenshot of ``page`` opened at ``#hash_`` (pixels), checking
    that the page logged no uncaught error."""
    from PIL import Image
    png = page.with_name(page.stem + hash_.replace("=", "").replace("&", "_") + ".png")
    r = subprocess.run(["chromium", "--headless", "--no-sandbox", "--disable-gpu",
                        "--enable-logging=stderr", "--window-size=800,760",
                        f"--screenshot={png}", page.as_uri() + f"#{hash_}"],
                       capture_output=True, text=True, timeout=60)
    assert png.exists(), r.stderr
    assert "Uncaught" not in r.stderr
    return np.asarray(Image.open(png).convert("RGB"), int)


@pytest.mark.skipif(shutil.which("chromium") is None, reason="Debian chromium not installed")
def test_variant_page_in_a_real_browser(tmp_path):
    """Headless Chromium on a synth study's page of every variant: ``#variant=K`` (which
    sets the selector) draws another variant."""
    assert main(["draw", str(EX / "seed001_rrr.toml"), "-o", str(tmp_path / "d"),
                 "--quiet"]) == 0
    page = tmp_path / "d" / "variants.html"
    a, b = (_shot(page, f"frame=2&variant={k}") for k in (0, 7))
    assert np.abs(a - b).sum() > 0


_STUB = r"""
// run the page's inline script with a recording canvas: print the drawing calls of two frames
const fs = require("fs");
const html = fs.readFileSync(process.argv[2], "utf8");
const data = /<script id="scene-data" type="application\/json">([\s\S]*?)<\/script>/.exec(html)[1];
const code = /<script>\n([\s\S]*?)<\/script>/.exec(html)[1];
let calls = [];
const ctx = new Proxy({}, {get: (t, k) => (k in t ? t[k] : (...a) => calls.push([k, ...a])),
                           set: (t, k, v) => { t[k] = v; return true; }});
const handlers = {};
function el(id) {
  return {id, textContent: id === "scene-data" ? data : "", width: 720, height: 540, value: 0, max: 0,
    getContext: () => ctx, setPointerCapture() {}, options: [],
    appendChild(o) { this.options.push(o); },
    addEventListener: (ev, f) => { handlers[id + ":" + ev] = f; }};
}
const els = {};
global.document = {getElementById: (id) => (els[id] = els[id] || el(id)),
                   createElement: (tag) => ({tag})};
global.location = {hash: ""};
new Function(code)();
const first = JSON.stringify(calls); calls = [];
els.slider.value = String(+els.slider.max);
handlers["slider:input"].call(els.slider);
const last = JSON.stringify(calls);
let variant = null;
if (handlers["variant:change"]) {      // choose the last variant: other drawing, its frames
  calls = [];
  els.variant.value = String(els.variant.options.length - 1);
  handlers["variant:change"].call(els.variant);
  variant = {changed: JSON.stringify(calls) !== last, options: els.variant.options.length,
             max: els.slider.max, sub: els.sub.textContent, shown: !els.pick.hidden};
}
console.log(JSON.stringify({n: first.length, changed: first !== last, label: els.label.textContent,
                            max: els.slider.max, variant}));
"""


@pytest.mark.skipif(shutil.which("node") is None, reason="node not installed")
def test_page_script_runs_and_the_slider_redraws(tmp_path):
    """The page's inline script under node with a recording canvas: it runs without an
    error, the slider spans every frame, moving it draws other coordinates."""
    from linkwright.draw import html_animation
    _, _, scn = _analyze()
    page = tmp_path / "m.html"
    page.write_text(html_animation(scn))
    (tmp_path / "stub.js").write_text(_STUB)
    r = subprocess.run(["node", str(tmp_path / "stub.js"), str(page)], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["changed"] and int(out["max"]) == len(scn) - 1
    assert out["label"].startswith(f"frame {len(scn)} of {len(scn)}")


@pytest.mark.skipif(shutil.which("node") is None, reason="node not installed")
def test_variant_selector_switches_the_scene(tmp_path):
    """A page of several scenes: the selector lists them, choosing one draws it with its
    own frames on the slider."""
    from linkwright.draw import html_animation
    _, _, a = _analyze()
    _, _, b = _analyze("fourbar_dynamics.toml")
    page = tmp_path / "v.html"
    page.write_text(html_animation([a, b], names=["swash", "four-bar"], limit=10))
    (tmp_path / "stub.js").write_text(_STUB)
    r = subprocess.run(["node", str(tmp_path / "stub.js"), str(page)], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert int(out["max"]) == 9 and out["variant"]["options"] == 2 and out["variant"]["shown"]
    assert out["variant"]["changed"] and int(out["variant"]["max"]) == min(len(b), 10) - 1
    assert out["variant"]["sub"] == b.title


def _page_data(page):
    return json.loads(re.search(r'<script id="scene-data" type="application/json">(.*?)'
                                r"</script>", page, re.S).group(1).replace("<\\/", "</"))


def test_reports_embed_the_engine_drawing(tmp_path):
    """The analyze and synth reports carry the drawing and its animation: the HTML report's
    frame is the animation page itself (offline), whose joints are the engine's joint frames;
    the synth report's drawn body frames are the task poses (the demo index's thumbnails:
    tests/linkwright/test_reports.py)."""
    import html as _html
    assert main(["examples", "-o", str(tmp_path / "ex")]) == 0
    assert main(["analyze", str(tmp_path / "ex" / "fourbar_dynamics.toml"), "-o",
                 str(tmp_path / "a"), "--quiet"]) == 0
    rep = (tmp_path / "a" / "report.html").read_text()
    page = (tmp_path / "a" / "mechanism.html").read_text()
    src = re.search(r"srcdoc='(.*?)'", rep, re.S).group(1)
    assert _html.unescape(src) == page and "http" not in page.split("<script")[0]
    assert "mechanism.html" in (tmp_path / "a" / "report.md").read_text()
    mech, poses, _ = _analyze("fourbar_dynamics.toml")
    data = _page_data(page)
    for f, i in zip(data["frames"], range(len(data["frames"]))):
        for k, j in enumerate(mech.joints):
            Ta = np.asarray(poses.link_frame(j.link_a))[i] @ j.frame_a
            assert np.abs(np.array(f["position"][k]) - Ta[:3, 3]).max() < 1e-12
    assert main(["synth", str(tmp_path / "ex" / "seed001_rrr.toml"), "-o", str(tmp_path / "s"),
                 "--quiet"]) == 0
    (anim,) = (tmp_path / "s").glob("variant*.html")
    assert anim.name == "variants.html" and (tmp_path / "s" / "variants.png").exists()
    for data in _page_data(anim.read_text())["variants"]:
        T = np.array(data["fixed_frames"]["given"])
        body = np.array([f["frames"]["body"] for f in data["frames"]])
        assert len(body) == len(T) == 4 and np.abs(body - T).max() < 1e-9


def _engine_joints(row, T):
    """The joint frames (on link a) of a variant row driven by the engine at the task
    positions, from its link frames × joint placements (not from the drawing)."""
    from linkwright.cmd_draw import _values, chain_mechanism, sphere_pose
    m, kinds, _ = chain_mechanism(row)
    X = _values(row, kinds, len(T))
    pose = sphere_pose(m, X, T) if "S" in kinds else m.solve(X, continuation=False)
    return m, np.stack([np.asarray(pose.link_frame(j.link_a)) @ j.frame_a for j in m.joints],
                       1)


def _ranked_seed001():
    from linkwright.cmd_synth import rank_variants, synthesise
    family, _, df, T, size = synthesise(load_study(EX / "seed001_rrr.toml", None))
    return rank_variants(df, "link_length", np.zeros(3), size, len(T)), np.stack(T), df


def test_synth_report_views_every_regular_variant(tmp_path):
    """The seed001 RRR synth report: one still figure (the best variant), and its HTML
    page embeds one scene per regular variant, best-ranked first; each variant's drawn
    joints are the engine's (chain_mechanism) to 1e-12 and its body frames the task poses
    at the task positions to 1e-9."""
    assert main(["synth", str(EX / "seed001_rrr.toml"), "-o", str(tmp_path / "s"),
                 "--quiet"]) == 0
    assert sorted(p.name for p in (tmp_path / "s").glob("*.png")) == ["variants.png"]
    page = (tmp_path / "s" / "variants.html").read_text()
    data = _page_data(page)
    ranked, T, df = _ranked_seed001()
    regular = ranked[ranked.reason == ""].sort_values("rank")
    assert len(data["variants"]) == len(data["names"]) == len(regular) == (df.reason == "").sum()
    assert '<select id="variant">' in page and not re.search(r"https?:|<link|src=", page)
    for (_, row), v, name in zip(regular.iterrows(), data["variants"], data["names"]):
        assert name.startswith(f"RRR variant {int(row.variant)} (rank {int(row['rank'])})")
        m, J = _engine_joints(row, T)
        got = np.array([f["position"] for f in v["frames"]])
        assert got.shape == (len(T), len(m.joints), 3)
        assert np.abs(got - J[..., :3, 3]).max() < 1e-12
        assert np.abs(np.array([f["axis"] for f in v["frames"]]) - J[..., :3, 2]).max() < 1e-12
        body = np.array([f["frames"]["body"] for f in v["frames"]])
        assert np.abs(body - T).max() < 1e-9
        assert np.array_equal(np.array(v["fixed_frames"]["given"]), T)
    md = (tmp_path / "s" / "report.md").read_text()
    assert f"holds all {len(regular)} drawable regular variants" in md
    assert "variants.html" in md and "variants.png" in md


def test_variant_viewer_caps_the_variants_not_the_frames(monkeypatch, tmp_path):
    """More regular variants than the viewer holds: the best-ranked ones are embedded, the
    report says so; every embedded variant keeps all its task positions."""
    import linkwright.cmd_draw as cd
    monkeypatch.setattr(cd, "VIEWER", 5)
    assert main(["synth", str(EX / "seed001_rrr.toml"), "-o", str(tmp_path / "s"),
                 "--quiet"]) == 0
    data = _page_data((tmp_path / "s" / "variants.html").read_text())
    ranked, T, _ = _ranked_seed001()
    best = ranked.sort_values("rank").variant.head(5).astype(int).tolist()
    assert [int(re.search(r"variant (\d+)", n).group(1)) for n in data["names"]] == best
    assert all(len(v["frames"]) == len(T) for v in data["variants"])
    md = (tmp_path / "s" / "report.md").read_text()
    assert "the 5 best-ranked of the 36 drawable regular variants (at most 5 are embedded)" in md


def test_draw_command_views_every_variant(tmp_path, capsys):
    """``linkwright draw`` on a synth study: still figures of the three best variants, one
    page with every regular variant in its selector."""
    assert main(["draw", str(EX / "seed001_rrr.toml"), "-o", str(tmp_path / "d"),
                 "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    names = sorted(Path(f).name for f in summary["files"])
    assert names == sorted([f"variant{v}.png" for v in summary["figures"]] + ["variants.html"])
    data = _page_data((tmp_path / "d" / "variants.html").read_text())
    assert len(data["variants"]) == len(summary["variants"]) == 36 and summary["not_drawn"] == 0


def test_hexapod_scene_is_the_hexapods_geometry():
    """Legs run from the base points to the platform points moved by the pose (1e-12),
    coloured by the sign of their force; the stiffness report's arrows are its weakest and
    stiffest directions taken to the base axes."""
    from closure import exp_so3
    from linkwright.draw import hexapod_scene
    from stiffness import Hexapod
    a, b = np.radians([-15, 15, 105, 135, 225, 255]), np.radians([-45, 45, 75, 165, 195, 285])
    base = np.c_[np.cos(a), np.sin(a), np.zeros(6)]
    plat = 0.5 * np.c_[np.cos(b), np.sin(b), np.zeros(6)]
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = exp_so3([0.1, -0.05, 0.2]), [0.05, -0.02, 1.1]
    hx = Hexapod(base, plat, 1e7)
    f = hx.leg_forces(T, [10.0, 0, -500, 0, 20, 0])
    scn = hexapod_scene(base, plat, T, forces=f)
    assert np.abs(scn.position[0, :6] - base).max() < 1e-12
    assert np.abs(scn.position[0, 6:] - hx.platform_points_world(T)).max() < 1e-12
    for k in range(6):
        c = scn.links[k]["color"]
        r, b = int(c[1:3], 16), int(c[5:7], 16)
        assert (r > b) == (f[k] > 0) and scn.links[k]["vertices"] == [("joint", k, "a"),
                                                                     ("joint", 6 + k, "a")]


def test_stiffness_report_draws_its_directions(tmp_path):
    assert main(["examples", "-o", str(tmp_path / "ex")]) == 0
    assert main(["stiffness", str(tmp_path / "ex" / "hexapod.toml"), "-o", str(tmp_path / "h"),
                 "--json", "--quiet"]) == 0
    data = _page_data((tmp_path / "h" / "hexapod.html").read_text())
    import pandas as pd
    K = pd.read_csv(tmp_path / "h" / "stiffness.csv")[["dx", "dy", "dz"]].to_numpy()[:3]
    w, V = np.linalg.eigh((K + K.T) / 2)
    (arrow,) = [v for k, v in data["frames"][0]["arrows"].items() if k == "weakest"]
    d = np.array(arrow[1]) / np.linalg.norm(arrow[1])
    # the report's frame is the platform's: the arrow is R_platform · (weakest eigenvector)
    R = np.array(data["frames"][0]["frames"]["platform"])[:3, :3]
    assert abs(abs(d @ (R @ V[:, 0])) - 1) < 1e-9
    forces = pd.read_csv(tmp_path / "h" / "leg_forces.csv").force_N.to_numpy()
    for f, ln in zip(forces, data["links"][:6]):           # tension red, compression blue
        c = ln["color"]
        assert (int(c[1:3], 16) > int(c[5:7], 16)) == (f > 0)


def test_hooke_variants_are_drawn_at_the_task_poses():
    """A dyad with a universal joint (RUR) is driven by the engine through its two angles:
    its drawn body frames are the task poses (1e-9), for every drawn variant."""
    from linkwright.cmd_draw import variant_scenes
    from linkwright.cmd_synth import rank_variants
    from synthesis import enumerate_dyads
    from synthesis.validate import task_scale
    from tests.synthesis.test_families import _generate_hooke
    screws, T = _generate_hooke("RUR", 1)[:2]
    df = enumerate_dyads("RUR", screws, azimuth=[0.3])
    _, ext, _ = task_scale(list(T))
    ranked = rank_variants(df, "link_length", np.zeros(3), ext, len(T))
    scenes, skipped = variant_scenes(ranked, np.asarray(T), "RUR", best=3)
    assert len(scenes) == 3 and skipped == 0
    for _, scn, TT in scenes:
        assert "U" in [j["kind"] for j in scn.joints]
        assert np.abs(scn.frames["body"] - TT).max() < 1e-9


@pytest.mark.parametrize("family", ["RSR", "SRR", "RSP", "SRP"])
def test_sphere_before_the_last_joint_is_turned_to_the_task_poses(family):
    """A dyad with its sphere before the last joint: the sphere's rotation at each task
    position comes from its links' poses on the two sides; every regular variant is drawn,
    its body frames are the task poses (1e-9), the ball is the table's centre at the first
    position and one point of both its links at every position (1e-9), and the drawn joints
    are the engine's joint frames (1e-12)."""
    from linkwright.cmd_draw import variant_scenes
    from linkwright.cmd_synth import rank_variants
    from synthesis import enumerate_dyads
    from synthesis.spherical import azimuth_of, task_frame
    from synthesis.validate import task_scale
    from tests.synthesis.test_families import _generate_middle
    screws, T, _, _, M, _ = _generate_middle(family, 1)
    df = enumerate_dyads(family, screws, azimuth=azimuth_of(M.direction, frame=task_frame(screws)))
    _, ext, size = task_scale(list(T))
    ranked = rank_variants(df, "link_length", np.zeros(3), ext, len(T))
    scenes, skipped = variant_scenes(ranked, np.asarray(T), family, best=None)
    rows = ranked[ranked.reason == ""].set_index("variant")
    assert len(scenes) == len(rows) > 0 and skipped == 0
    ks = family.index("S")
    for v, scn, TT in scenes:
        row = rows.loc[v]
        assert scn.joints[ks]["kind"] == "S"
        assert np.abs(scn.frames["body"] - TT).max() < 1e-9
        centre = np.array([row[f"j{ks + 1}_{c}"] for c in "xyz"])
        assert np.abs(scn.position[0, ks] - centre).max() < 1e-9 * size
        assert np.abs(scn.position_b[:, ks] - scn.position[:, ks]).max() < 1e-9 * size
        _, J = _engine_joints(row.to_dict() | {"variant": v}, np.asarray(T))
        assert np.abs(scn.position - J[..., :3, 3]).max() < 1e-12
        assert np.abs(scn.axis - J[..., :3, 2]).max() < 1e-12


def test_sphere_pose_rotation_is_the_relative_turn_of_its_links():
    """The pose's sphere rotation is its link b's frame relative to its link a's (a proper
    rotation), and where the centres from the two sides miss each other the residual says
    by how much."""
    from linkwright.cmd_draw import _values, chain_mechanism, sphere_pose
    from linkwright.cmd_synth import rank_variants
    from synthesis import enumerate_dyads
    from synthesis.spherical import azimuth_of, task_frame
    from synthesis.validate import task_scale
    from tests.synthesis.test_families import _generate_middle
    screws, T, _, _, M, _ = _generate_middle("RSR", 2)
    df = enumerate_dyads("RSR", screws, azimuth=azimuth_of(M.direction, frame=task_frame(screws)))
    _, ext, size = task_scale(list(T))
    row = rank_variants(df, "link_length", np.zeros(3), ext, len(T)).sort_values("rank").iloc[0]
    m, kinds, _ = chain_mechanism(row)
    X = _values(row, kinds, len(T))
    pose = sphere_pose(m, X, np.asarray(T))
    R = pose.rot[:, 0]
    assert np.abs(R @ np.swapaxes(R, 1, 2) - np.eye(3)).max() < 1e-12
    assert np.all(np.linalg.det(R) > 0) and pose.residual.max() < 1e-9 * size
    j = m.joint("j2")
    Wa = np.asarray(pose.link_frame("A")) @ j.frame_a
    Wb = np.asarray(pose.link_frame("B")) @ j.frame_b
    A = np.linalg.inv(Wa) @ Wb
    assert np.abs(A[:, :3, :3] - R).max() < 1e-9 and np.abs(A[:, :3, 3]).max() < 1e-9 * size
    off = np.asarray(T).copy()
    off[1:, :3, 3] += 0.01 * size                     # move the body: the centres miss
    assert sphere_pose(m, X, off).residual[1:].min() > 1e-4 * size
