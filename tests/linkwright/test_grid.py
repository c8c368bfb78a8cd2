"""Grid studies (linkwright.grid, linkwright.distributed, `linkwright grid`): the same grid
run serially and on a two-process Dask cluster gives identical tables; resumed and
SIGKILL-interrupted runs lose and duplicate no case; failing cases are rows; bad grid
keys name the key."""
import json
import os
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

distributed = pytest.importorskip("distributed")
pytest.importorskip("pyarrow")

from linkwright.cli import main                       # noqa: E402
from linkwright.distributed import read_table, run_study  # noqa: E402
from linkwright.examples import folder as examples_folder  # noqa: E402
from linkwright.grid import load_grid_study           # noqa: E402
from linkwright.study import StudyError               # noqa: E402

BASE = (examples_folder() / "hexapod.toml").read_text().split("[map]")[0]
GRID = """
[grid]
"hexapod.leg_stiffness" = [1.0e7, 2.0e7, -1.0]
"pose.position[2]" = {start = 0.6, stop = 0.8, num = 4}
"""


def study(tmp_path, grid=GRID, name="g.toml") -> Path:
    p = tmp_path / name
    p.write_text(BASE + grid)
    return p


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                                       host="127.0.0.1", dashboard_address=None)
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The serial table of GRID (12 cases, one partition per 2 cases)."""
    tmp = tmp_path_factory.mktemp("ref")
    return run_study(study(tmp), serial=True, out=tmp / "out", partition_size=2)


def test_serial_table(reference):
    df = reference
    assert list(df["case"]) == list(range(12))
    assert list(df.columns[:3]) == ["case", "hexapod.leg_stiffness", "pose.position[2]"]
    ok = df[df["error"].isna()]
    assert len(ok) == 8
    # stiffness scales linearly with the leg stiffness: an independent check of the rows
    a = ok[ok["hexapod.leg_stiffness"] == 1e7]["kt_min [N/m]"].to_numpy()
    b = ok[ok["hexapod.leg_stiffness"] == 2e7]["kt_min [N/m]"].to_numpy()
    np.testing.assert_allclose(b, 2 * a, rtol=1e-12)


def test_failing_case_is_recorded(reference):
    bad = reference[reference["hexapod.leg_stiffness"] == -1.0]
    assert len(bad) == 4
    for msg in bad["error"]:
        assert "hexapod.leg_stiffness" in msg and "expected a value > 0" in msg
    assert bad["kt_min [N/m]"].isna().all()


def test_cluster_equals_serial(tmp_path, client, reference):
    df = run_study(study(tmp_path), client, out=tmp_path / "out", partition_size=2)
    pd.testing.assert_frame_equal(df, reference, check_exact=True)
    assert len(list((tmp_path / "out").glob("part-*.parquet"))) == 6
    mem = run_study(study(tmp_path, name="m.toml"), client, partition_size=3)   # in memory
    pd.testing.assert_frame_equal(mem, reference, check_exact=True)


def test_resume_after_interrupted_run(tmp_path, client, reference):
    p, out = study(tmp_path), tmp_path / "out"
    part = run_study(p, serial=True, out=out, partition_size=2, _stop_after=2)
    assert list(part["case"]) == [0, 1, 2, 3]
    (out / "part-00001.parquet").unlink()              # a partition lost as well
    with pytest.raises(ValueError, match="--resume"):
        run_study(p, client, out=out)
    df = run_study(p, client, out=out, resume=True)
    pd.testing.assert_frame_equal(df, reference, check_exact=True)


def test_sigkill_worker_midway(tmp_path, client):
    p, out = study(tmp_path, GRID.replace("num = 4", "num = 20")), tmp_path / "out"
    reference = run_study(p, serial=True)                 # 60 cases
    pids = client.run(os.getpid)
    victim = sorted(pids.values())[0]
    killed = []

    def killer():
        t0 = time.monotonic()
        while time.monotonic() - t0 < 20:
            if out.exists() and any(out.glob("part-*.parquet")):
                os.kill(victim, signal.SIGKILL)
                killed.append(len(list(out.glob("part-*.parquet"))))
                return
            time.sleep(0.005)

    th = threading.Thread(target=killer)
    th.start()
    df = run_study(p, client, out=out, partition_size=1)
    th.join()
    assert killed and killed[0] < 60                   # killed before the end
    assert sorted(df["case"]) == list(range(60))       # none lost, none duplicated
    pd.testing.assert_frame_equal(df, reference, check_exact=True)
    client.wait_for_workers(2, timeout=30)             # the nanny restarted it


@pytest.mark.parametrize("grid, key, words", [
    ('"hexapod.leg_stifness" = [1.0]', "grid.hexapod.leg_stifness", "unknown key"),
    ('"report.frame" = [1.0]', "grid.report.frame", "not a numeric key"),
    ('"pose.position" = [1.0]', "grid.pose.position", "not a numeric key"),
    ('"pose.position[5]" = [1.0]', "grid.pose.position[5]", "unknown key"),
    ('"hexapod.leg_stiffness" = {start = 1.0, stop = 2.0, num = 0}',
     "grid.hexapod.leg_stiffness", "num"),
    ('"hexapod.leg_stiffness" = {start = 1.0, stop = 2.0}', "grid.hexapod.leg_stiffness",
     "missing 'num'"),
    ('"hexapod.leg_stiffness" = ["a"]', "grid.hexapod.leg_stiffness", "finite numbers"),
    ('"hexapod.leg_stiffness" = {sampler = "lhs", n = 4, bounds = [2.0, 1.0]}',
     "grid.hexapod.leg_stiffness", "bounds"),
    ('"hexapod.leg_stiffness" = {sampler = "halton", n = 4, bounds = [1.0, 2.0]}',
     "grid.hexapod.leg_stiffness", "sampler"),
])
def test_bad_grid_keys(tmp_path, grid, key, words):
    with pytest.raises(StudyError) as e:
        load_grid_study(study(tmp_path, "[grid]\n" + grid + "\n"))
    assert e.value.key == key and words in str(e.value)
    assert isinstance(e.value, ValueError)


def test_samples_are_joint_and_reproducible(tmp_path):
    g = """[grid]
"hexapod.leg_stiffness" = [1.0e7, 2.0e7]
"pose.position[0]" = {sampler = "lhs", n = 8, bounds = [-0.1, 0.1], seed = 3}
"pose.position[1]" = {sampler = "lhs", n = 8, bounds = [-0.2, 0.2], seed = 3}
"""
    a, b = load_grid_study(study(tmp_path, g)), load_grid_study(study(tmp_path, g))
    assert a.cases == b.cases and len(a.cases) == 16
    xy = np.array([[c["pose.position[0]"], c["pose.position[1]"]] for c in a.cases[:8]])
    assert (np.abs(xy[:, 0]) <= 0.1).all() and (np.abs(xy[:, 1]) <= 0.2).all()
    # Latin hypercube: one sample in each of the 8 strata of each axis
    for j, h in enumerate([0.1, 0.2]):
        assert sorted(np.floor((xy[:, j] + h) / (2 * h) * 8).astype(int)) == list(range(8))
    with pytest.raises(StudyError, match="jointly"):
        load_grid_study(study(tmp_path, g.replace("[-0.2, 0.2], seed = 3", "[-0.2, 0.2], seed = 4")))


def test_cli_serial_and_resume(tmp_path, capsys, reference):
    p, out = study(tmp_path), tmp_path / "out"
    assert main(["grid", str(p), "-o", str(out), "--serial", "--partition-size", "2",
                 "--json"]) == 0
    summ = json.loads(capsys.readouterr().out)
    assert summ["cases"] == 12 and summ["failed"] == 4
    pd.testing.assert_frame_equal(read_table(out), reference, check_exact=True)
    assert main(["grid", str(p), "-o", str(out), "--serial"]) == 2
    assert "--resume" in capsys.readouterr().err
    assert main(["grid", str(p), "-o", str(out), "--serial", "--resume", "--quiet"]) == 0
    (tmp_path / "nogrid.toml").write_text(BASE)
    assert main(["grid", str(tmp_path / "nogrid.toml"), "--serial"]) == 2
    assert "key 'grid'" in capsys.readouterr().err


def test_import_is_lazy():
    import subprocess
    import sys
    code = ("import sys, linkwright; assert 'dask' not in sys.modules; "
            "assert callable(linkwright.run_study)")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_missing_extra_is_a_clear_error(tmp_path):
    import subprocess
    import sys
    code = ("import sys; sys.modules['distributed'] = None; from linkwright.cli import main; "
            f"sys.exit(main(['grid', {str(study(tmp_path))!r}, '-o', {str(tmp_path / 'o')!r}]))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 2
    assert 'pip install "linkwright[dist]"' in r.stderr


# ------------------------------------------------------------------ blocked stiffness maps
def _hexapod():
    from linkwright.cmd_stiffness import hexapod_of
    from linkwright.study import load_study
    return hexapod_of(load_study(examples_folder() / "hexapod.toml"))[0]


AXES = (np.linspace(-0.1, 0.1, 21), np.linspace(-0.1, 0.1, 19), np.linspace(0.6, 0.8, 11))


@pytest.fixture(scope="module")
def exact_map():
    hx = _hexapod()
    X, Y, Z = np.meshgrid(*AXES, indexing="ij")
    return hx.map(np.column_stack([X.ravel(), Y.ravel(), Z.ravel()]), np.zeros((1, 3)))


def _check_summary(s, mp):
    from linkwright.bigmap import INDICES
    assert s.poses == len(mp) and s.singular == int(mp.singular.sum())
    q = s.quantiles.set_index("index")
    for col in INDICES:
        assert q.loc[col, "min"] == mp[col].min() and q.loc[col, "max"] == mp[col].max()
        for p in (1, 5, 50, 95, 99):
            exact = mp[col].quantile(p / 100)
            assert abs(q.loc[col, f"q{p:02d}"] / exact - 1) < 0.025, (col, p)   # one bin
    assert np.allclose(s.worst.kt_min, mp.kt_min.nsmallest(len(s.worst)), rtol=0, atol=0)


def test_blocked_map_summary_and_parts_are_the_exact_map(tmp_path, exact_map):
    from linkwright.bigmap import stiffness_map
    s = stiffness_map(_hexapod(), *AXES, out=tmp_path / "m", serial=True, block=1000)
    _check_summary(s, exact_map)
    parts = pd.concat([pd.read_parquet(p) for p in sorted((tmp_path / "m").glob("*.parquet"))])
    assert len(parts) == len(exact_map)
    cols = ["x", "y", "z", "kt_min", "cr_max"]
    a = parts[cols].sort_values(["x", "y", "z"]).to_numpy()
    b = exact_map[cols].sort_values(["x", "y", "z"]).to_numpy()
    assert np.array_equal(a, b)
    # a stopped run resumes: remove two blocks, run again, only those are computed
    for p in sorted((tmp_path / "m").glob("part-00000[13].*")):
        p.unlink()
    with pytest.raises(FileExistsError, match="resume"):
        stiffness_map(_hexapod(), *AXES, out=tmp_path / "m", serial=True, block=1000)
    r = stiffness_map(_hexapod(), *AXES, out=tmp_path / "m", serial=True, block=1000,
                      resume=True)
    assert r.blocks == 2
    _check_summary(r, exact_map)


def test_blocked_map_on_the_cluster_equals_serial(client, exact_map):
    from linkwright.bigmap import stiffness_map
    s = stiffness_map(_hexapod(), *AXES, client=client, block=1000)
    _check_summary(s, exact_map)


@pytest.mark.parametrize("kw, name", [({"block": 10}, "block"), ({"rotation": [0, 1]}, "rotation")])
def test_blocked_map_bad_input(kw, name):
    from linkwright.bigmap import stiffness_map
    with pytest.raises(ValueError, match=name):
        stiffness_map(_hexapod(), *AXES, serial=True, **kw)
    with pytest.raises(ValueError, match="xs"):
        stiffness_map(_hexapod(), [np.nan], AXES[1], AXES[2], serial=True)
