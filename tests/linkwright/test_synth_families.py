"""`linkwright synth` for every kind of family: the free parameters from the study file,
the generic report, and the ranking's chain Jacobian (R, P, H, C, U, S joints) checked
against the engine's own finite differences."""
import json

import numpy as np
import pytest

from closure import Mechanism
from linkwright.cli import main
from linkwright.cmd_draw import _chain_of, _values
from linkwright.cmd_synth import chain_jacobian
from linkwright.examples import folder as examples_folder

SEED = (examples_folder() / "seed001_rrr.toml").read_text()


def _study(tmp_path, family, extra=""):
    p = tmp_path / f"{family.lower()}.toml"
    p.write_text(SEED.replace('family = "RRR"', f'family = "{family}"\n{extra}'))
    return p


def _engine_twists(row, p, eps=1e-6):
    """Spatial twists (ω, v at the origin) of the body per joint coordinate, by central
    differences of the engine's body pose at position p (1-based)."""
    kinds, frames = _chain_of(row)
    m = Mechanism(["A", "B", "body"])
    links = ["ground", "A", "B", "body"]
    for k, t in enumerate(kinds):
        pitch = float(row[f"j{k + 1}_pitch"]) if t == "H" else None
        m.add_joint(f"j{k + 1}", t, links[k], links[k + 1], at=frames[k], pitch=pitch)
        m.add_input(f"j{k + 1}", 0)
        if t in "CU":
            m.add_input(f"j{k + 1}", 1)
    x = _values(row, kinds, p)[p - 1]
    cols = []
    for j in range(len(x)):
        dx = np.zeros_like(x)
        dx[j] = eps
        Tp, Tm = (m.solve(x + s * dx, continuation=False).link_frame("body").reshape(-1, 4, 4)[0]
                  for s in (1, -1))
        dT = (Tp - Tm) / (2 * eps)
        W = dT @ np.linalg.inv(0.5 * (Tp + Tm))
        cols.append(np.r_[W[2, 1], W[0, 2], W[1, 0], W[:3, 3]])
    return np.array(cols).T


@pytest.mark.parametrize("family", ["RCH", "RUC", "RPC"])
def test_chain_jacobian_is_the_engines_body_twist(family):
    from synthesis import enumerate_dyads
    if family == "RUC":
        from tests.synthesis.test_families_hooke_hc import _generate
        screws, T, _, params = _generate(family, 3)
    else:
        from tests.synthesis.test_families import _generate
        screws, T, _, params = _generate(family, 3)
    df = enumerate_dyads(family, screws, **params)
    ok = df[df.reason == ""]
    for _, row in ok.iloc[:3].iterrows():
        for p in range(1, len(T) + 1):
            J = chain_jacobian(row, p)
            E = _engine_twists(row, p)
            assert J.shape == E.shape
            assert np.abs(J - E).max() <= 1e-6 * max(1.0, np.abs(E).max()), (family, p)


def test_synth_study_with_a_helical_family_and_its_pitch(tmp_path, capsys):
    code = main(["synth", str(_study(tmp_path, "RHR", "pitch = 0.05")), "-o",
                 str(tmp_path / "out"), "--json"])
    out = capsys.readouterr().out
    assert code == 0, out
    summ = json.loads(out)
    assert summ["family"] == "RHR" and summ["ranked"] >= 1
    assert summ["max_residual"]["value"] <= 1e-9
    rep = (tmp_path / "out" / "report.md").read_text()
    assert "Best variant" in rep and "carries position" in rep
    import pandas as pd
    df = pd.read_csv(tmp_path / "out" / "variants.csv")
    assert (df.j2_pitch.dropna() == 0.05).all() and df.condition.notna().any()


@pytest.mark.parametrize("family, extra, key", [
    ("RHR", "", "synthesis.pitch"),
    ("RCR", "azimuth_deg = 30.0", "synthesis.azimuth_deg"),
    ("RPR", "", "position"),                                # RPR takes 3 positions, not 4
    ("RRC", "transition_angle_deg = [[1.0]]", "synthesis.transition_angle_deg"),
])
def test_synth_study_errors_name_the_key(tmp_path, capsys, family, extra, key):
    code = main(["synth", str(_study(tmp_path, family, extra)), "-o", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code != 0 and f"'{key}'" in err, err
