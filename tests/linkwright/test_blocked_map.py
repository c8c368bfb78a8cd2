"""A hexapod stiffness study's map run in blocks from the study file ([map] blocked, block,
parts, resume): its summary against the same map computed in memory."""
import json
import os

import numpy as np
import pandas as pd
import pytest

from linkwright.cli import main

from linkwright.examples import folder as examples_folder

EX = examples_folder()

pytest.importorskip("pyarrow")

MAP = "[map]\nx = [-0.15, 0.15, 25]\ny = [-0.15, 0.15, 13]\nz = [0.6, 0.8, 7]\n"   # 2,275 poses


def _study(tmp_path, extra=""):
    text = (EX / "hexapod.toml").read_text()
    head, _, tail = text.partition("[map]")
    rest = tail.split("\n[", 1)                     # the sections after [map], if any
    text = head + MAP + extra + ("\n[" + rest[1] if len(rest) > 1 else "")
    path = tmp_path / "big.toml"
    path.write_text(text.replace("rotation_deg = [0.0, 0.0, 0.0]", "rotation_deg = [0.0, 5.0, 10.0]"))
    return path


@pytest.fixture(scope="module")
def in_memory(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("mem")
    assert main(["stiffness", str(_study(tmp)), "-o", str(tmp / "o"), "--quiet"]) == 0
    return pd.read_csv(tmp / "o" / "map.csv")


def test_blocked_map_summary_equals_the_map_in_memory(tmp_path, in_memory, capsys):
    parts = tmp_path / "parts"
    study = _study(tmp_path, f'blocked = "serial"\nblock = 1000\nparts = "{parts.as_posix()}"\n')
    assert main(["stiffness", str(study), "-o", str(tmp_path / "o"), "--json"]) == 0
    summ = json.loads(capsys.readouterr().out)
    out = tmp_path / "o"
    assert not (out / "map.csv").exists()
    q = pd.read_csv(out / "map_quantiles.csv").set_index("index")
    mp = in_memory
    assert summ["map_poses"] == len(mp) == 2275
    assert summ["map_singular"] == int(mp.singular.sum())
    for col in ("kt_min", "kt_max", "cr_max", "cond_P"):
        assert q.loc[col, "min"] == pytest.approx(mp[col].min(), rel=1e-12)
        assert q.loc[col, "max"] == pytest.approx(mp[col].max(), rel=1e-12)
        # quantiles to one logarithmic bin (a factor 10^(20/1000))
        ref = np.quantile(mp[col], 0.5)
        assert abs(np.log10(q.loc[col, "q50"] / ref)) <= 20 / 1000 + 1e-12
    worst = pd.read_csv(out / "map_worst.csv")
    ref = mp.nsmallest(len(worst), "kt_min")
    assert np.allclose(worst.kt_min, ref.kt_min, rtol=1e-12)
    assert np.allclose(worst[["x", "y", "z"]], ref[["x", "y", "z"]], atol=1e-15)
    assert np.allclose(summ["map_rotation"]["value"], [0.0, 5.0, 10.0])
    # the rows kept as parts: the in-memory map, block by block
    rows = pd.concat([pd.read_parquet(parts / f) for f in sorted(os.listdir(parts))
                      if f.endswith(".parquet")], ignore_index=True)
    assert len(rows) == len(mp) and np.allclose(rows.kt_min, mp.kt_min, rtol=1e-12)
    md = (out / "report.md").read_text()
    assert "Map over poses (in blocks)" in md and "3 blocks" in md


def test_blocked_map_resumes_from_its_parts(tmp_path, capsys):
    parts = tmp_path / "parts"
    keys = f'blocked = "serial"\nblock = 1000\nparts = "{parts.as_posix()}"\n'
    study = _study(tmp_path, keys)
    assert main(["stiffness", str(study), "-o", str(tmp_path / "a"), "--json"]) == 0
    first = json.loads(capsys.readouterr().out)
    # a second run into the same parts without resume: refused, naming the key
    assert main(["stiffness", str(study), "-o", str(tmp_path / "b")]) == 2
    assert "map.parts" in capsys.readouterr().err
    for f in ("part-000001.parquet", "part-000001.json"):
        (parts / f).unlink()
    study = _study(tmp_path, keys + "resume = true\n")
    assert main(["stiffness", str(study), "-o", str(tmp_path / "c"), "--json"]) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["map_poses"] == first["map_poses"]
    assert again["map_kt_min"] == first["map_kt_min"]
    assert "1 of them in this run" in (tmp_path / "c" / "report.md").read_text()
    a = pd.read_csv(tmp_path / "a" / "map_quantiles.csv")
    c = pd.read_csv(tmp_path / "c" / "map_quantiles.csv")
    pd.testing.assert_frame_equal(a, c)


@pytest.mark.parametrize("extra, key", [("resume = true\n", "map.resume"),
                                        ("block = 10\n", "map.block"),
                                        ('blocked = "cluster"\n', "map.blocked")])
def test_blocked_map_bad_keys_name_the_key(tmp_path, capsys, extra, key):
    study = _study(tmp_path, 'blocked = "serial"\n' * ("blocked" not in extra) + extra)
    assert main(["stiffness", str(study), "-o", str(tmp_path / "o")]) == 2
    assert key in capsys.readouterr().err


def test_mechanism_maps_refuse_the_blocked_keys(tmp_path, capsys):
    text = (EX / "three_rps_head.toml").read_text()
    assert "[map]" in text
    study = tmp_path / "m.toml"
    study.write_text(text.replace("[map]\n", '[map]\nblocked = "serial"\n'))
    assert main(["stiffness", str(study), "-o", str(tmp_path / "o")]) == 2
    assert "map.blocked" in capsys.readouterr().err


def test_maps_above_two_million_poses_run_in_blocks_on_dask(tmp_path, monkeypatch):
    """A 2000 × 2000 map (each axis allowed, not both in memory) goes to the blocked map on
    Dask by itself; its run is stubbed here (a real one is the test above)."""
    import linkwright.bigmap as bigmap
    seen = {}

    def stub(msec, hx, T, axes, mode, progress=None):
        seen.update(mode=mode, poses=int(np.prod([len(a) for a in axes])))
        raise RuntimeError("stub: stop before any work")

    monkeypatch.setattr(bigmap, "map_from_study", stub)
    text = (EX / "hexapod.toml").read_text()
    head, _, tail = text.partition("[map]")
    rest = tail.split("\n[", 1)
    study = tmp_path / "huge.toml"
    study.write_text(head + "[map]\nx = [-0.1, 0.1, 2000]\ny = [-0.1, 0.1, 2000]\n"
                     + ("\n[" + rest[1] if len(rest) > 1 else ""))
    assert main(["stiffness", str(study), "-o", str(tmp_path / "o"), "--quiet"]) == 1
    assert seen == {"mode": "dask", "poses": 4_000_000}
