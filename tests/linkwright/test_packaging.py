"""The installed package runs its own demo, examples and benchmarks from any folder: the
example studies ship inside it as package data; benchmarks stream module by module."""
import fnmatch
import os
import shutil
import subprocess
import sys
from importlib import resources

import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

from linkwright import bench
from linkwright.cli import main

from .util import ROOT, command, env

SHIPPED = {"seed001_rrr.toml", "hexapod.toml", "seed004_cylinder.toml",
           "seed000_swash_plate.toml", "fourbar_dynamics.toml", "crane.py", "swash_plate.py"}
PYPROJECT = ROOT / "pyproject.toml"
needs_source = pytest.mark.skipif(not PYPROJECT.exists(), reason="needs the source tree")


def test_example_studies_ship_inside_the_package():
    names = {p.name for p in resources.files("linkwright.examples").iterdir()}
    assert SHIPPED <= names
    from linkwright.examples import crane, swash_plate
    assert crane.build().mobility == 2 and swash_plate.build().n_loops == 2


def install_like_a_wheel(dest):
    """Copy what the wheel holds, by pyproject's package list and package data."""
    st = tomllib.loads(PYPROJECT.read_text())["tool"]["setuptools"]
    data = st.get("package-data", {})
    for pkg in st["packages"]:
        src = ROOT.joinpath(*pkg.split("."))
        to = dest.joinpath(*pkg.split("."))
        to.mkdir(parents=True, exist_ok=True)
        for f in src.iterdir():
            if f.is_file() and (f.suffix == ".py" or any(fnmatch.fnmatch(f.name, pat)
                                                         for pat in data.get(pkg, []))):
                shutil.copy2(f, to / f.name)


@needs_source
def test_pyproject_packs_every_package_and_example_file(tmp_path):
    st = tomllib.loads(PYPROJECT.read_text())["tool"]["setuptools"]
    for init in (ROOT / "linkwright").rglob("__init__.py"):
        if "__pycache__" not in init.parts:
            assert ".".join(init.parent.relative_to(ROOT).parts) in st["packages"]
    install_like_a_wheel(tmp_path)
    shipped = {p.name for p in (tmp_path / "linkwright" / "examples").iterdir()}
    source = {p.name for p in (ROOT / "linkwright" / "examples").iterdir() if p.is_file()}
    assert shipped == source and SHIPPED <= shipped


@needs_source
def test_installed_layout_runs_demo_and_examples_from_an_empty_folder(tmp_path):
    site, work = tmp_path / "site", tmp_path / "work"
    install_like_a_wheel(site)
    work.mkdir()
    e = env()
    e["PYTHONPATH"] = os.pathsep.join([str(site), e["PYTHONPATH"]])
    where = subprocess.run([sys.executable, "-c", "import linkwright; print(linkwright.__file__)"],
                           cwd=work, env=e, capture_output=True, text=True)
    assert where.stdout.startswith(str(site))

    def lw(*args):
        r = subprocess.run(command(*args), cwd=work, env=e, capture_output=True, text=True,
                           timeout=600)
        assert r.returncode == 0, r.stderr
        return r.stdout
    lw("demo", "-o", "demo", "--quiet")
    assert (work / "demo" / "index.html").exists()
    assert (work / "demo" / "seed001_rrr" / "report.html").exists()
    lw("examples", "-o", "studies")
    lw("synth", "studies/seed001_rrr.toml", "-o", "out/rrr", "--quiet")
    assert (work / "out" / "rrr" / "variants.csv").exists()
    # the benchmarks from an installed wheel: CI's second part (`linkwright bench --quick`)


def test_bench_streams_each_table_and_survives_a_failing_module(tmp_path, capsys, monkeypatch):
    printed_before_last = []

    def first(quick):
        return ["## first table"]

    def broken(quick):
        raise FileNotFoundError("site-packages/examples/crane.py")

    def last(quick):
        printed_before_last.append(capsys.readouterr())
        return ["## last table"]
    monkeypatch.setattr(bench, "BENCHES", {"first": first, "broken": broken, "last": last})
    code = main(["bench", "-o", str(tmp_path / "b")])
    out = capsys.readouterr()
    assert code == 1
    before = printed_before_last[0]
    assert "## first table" in before.out                     # streamed, not held back
    assert "## broken: failed" in before.out
    assert "bench broken failed: FileNotFoundError" in before.err
    assert "## last table" in out.out and "1 of 3" in out.err
    md = (tmp_path / "b" / "bench.md").read_text()
    assert "## first table" in md and "## broken: failed" in md and "## last table" in md
    monkeypatch.setattr(bench, "BENCHES", {"first": first, "broken": broken, "last": last})
    assert bench.run(["first", "broken", "last"]) == 1
    assert "## last table" in capsys.readouterr().out


def test_demo_from_an_empty_folder_uses_the_shipped_studies(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["demo", "-o", "d", "--quiet"]) == 0
    assert (tmp_path / "d" / "hexapod" / "report.html").exists()
    assert main(["demo", "--examples", str(tmp_path / "none"), "-o", "e"]) == 2
    assert "no study files" in capsys.readouterr().err
