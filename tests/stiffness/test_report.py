"""The stiffness report and plot are thin functions over the application's one rendering
layer: no import cycle between stiffness.plot and stiffness.report (nor anywhere in the
project's module-level imports), and the report's content is parsed, not eyeballed."""
import ast
import itertools
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from stiffness import Hexapod, report, stiffness_indices

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("closure", "synthesis", "stiffness", "approx", "linkwright")


def _module_imports(path: Path, module: str) -> set[str]:
    """Project modules imported at module level (not inside functions) by one file."""
    tree = ast.parse(path.read_text())
    pkg = module if path.name == "__init__.py" else module.rpartition(".")[0]
    out = set()
    for node in tree.body:
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = pkg.split(".")
                parts = parts[:len(parts) - node.level + 1]
                base = ".".join(parts + ([base] if base else []))
            out.add(base)
            out |= {f"{base}.{a.name}" for a in node.names}
    return {m for m in out if m.split(".")[0] in PACKAGES}


def _graph():
    mods = {}
    for pkg in PACKAGES:
        for f in (ROOT / pkg).rglob("*.py"):
            rel = f.relative_to(ROOT).with_suffix("")
            name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
            mods[name] = f
    return {m: {d for d in _module_imports(f, m) if d in mods and d != m}
            for m, f in mods.items()}


def _reaches(g, a, b):
    seen, todo = set(), [a]
    while todo:
        m = todo.pop()
        for d in g.get(m, ()):
            if d == b:
                return True
            if d not in seen:
                seen.add(d)
                todo.append(d)
    return False


def test_no_import_cycle_between_plot_and_report():
    g = _graph()
    assert "stiffness.report" not in g["stiffness.plot"]
    assert "stiffness.plot" not in g["stiffness.report"]
    assert not (_reaches(g, "stiffness.plot", "stiffness.report")
                and _reaches(g, "stiffness.report", "stiffness.plot"))
    # the rendering layer imports no package of the project: anyone may call it
    assert g["linkwright.render"] == set()
    for sub in ("stiffness.plot", "stiffness.report"):
        assert not _reaches(g, sub, "linkwright.render")          # imported lazily only


def test_no_module_level_import_cycle_between_modules_of_the_project():
    g = _graph()
    mods = [m for m in g if m not in PACKAGES]      # a package's __init__ imports its modules
    for a, b in itertools.combinations(mods, 2):
        assert not (_reaches(g, a, b) and _reaches(g, b, a)), (a, b)


def test_fresh_interpreter_imports_in_either_order():
    for first, second in [("stiffness.plot", "stiffness.report"),
                          ("stiffness.report", "stiffness.plot"),
                          ("linkwright.render", "stiffness.plot")]:
        code = (f"import importlib, sys; importlib.import_module({first!r}); "
                f"importlib.import_module({second!r}); "
                "import stiffness; assert callable(stiffness.report) and callable(stiffness.plot_map); "
                "print('ok')")
        r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True)
        assert r.returncode == 0 and r.stdout.strip() == "ok", r.stderr


def _hexapod():
    a = np.radians([0, 100, 120, 220, 240, 340])
    b = np.radians([40, 80, 160, 200, 280, 320])
    return Hexapod(np.c_[0.8 * np.cos(a), 0.8 * np.sin(a), np.zeros(6)],
                   np.c_[0.4 * np.cos(b), 0.4 * np.sin(b), np.zeros(6)], 2e7)


def test_indices_are_a_tidy_table():
    hx = _hexapod()
    T = np.eye(4)
    T[2, 3] = 0.7
    idx = stiffness_indices(hx.stiffness(T))
    assert list(idx.columns) == ["index", "component", "value", "unit", "meaning"]
    assert idx.value.map(lambda v: isinstance(v, float)).all()
    assert idx.groupby("index").size().to_dict() == {"kt": 3, "cr": 3, "screw": 6, "coupling": 1}
    assert set(idx.groupby("index").unit.nunique()) == {1}
    kt = idx[idx["index"] == "kt"].value.to_numpy()
    assert np.all(np.diff(kt) >= 0)


def test_report_starts_with_findings_and_maps_at_the_pose_rotation(tmp_path):
    from closure import exp_so3
    hx = _hexapod()
    T = np.eye(4)
    T[:3, :3] = exp_so3(np.radians([0, 0, 15]))
    T[:3, 3] = [0, 0, 0.7]
    pos = np.c_[np.linspace(-0.1, 0.1, 3), np.zeros(3), np.full(3, 0.7)]
    text = report(hx, T, frame="platform", positions=pos, path=tmp_path / "r.md")
    lines = [ln for ln in text.splitlines() if ln.strip()]
    assert lines[1] == "## Findings" and "kt_min = " in lines[2] and "N/m" in lines[2]
    assert "cond(P) = " in text
    mp = pd.read_csv(tmp_path / "r_map.csv", index_col=0)
    assert np.allclose(mp.rz, np.radians(15)) and np.allclose(mp[["rx", "ry"]], 0)
    assert (tmp_path / "r_map.png").exists() and "![r_map.png](r_map.png)" in text
    for ln in text.splitlines():
        if ln.startswith("| "):
            assert "np." not in ln and "array(" not in ln
