"""The wobble-plate drive of examples/ (U and S joints, two loops) against an independent
solution: the plate's rotation from the Hooke-joint condition, the lever from the rod length."""
import importlib.util
import pathlib

import numpy as np
from scipy.optimize import brentq

from closure import rot_x, rot_z, rotation

spec = importlib.util.spec_from_file_location(
    "swash_plate", pathlib.Path(__file__).parents[2] / "examples" / "swash_plate.py")
sp = importlib.util.module_from_spec(spec)
spec.loader.exec_module(sp)


def reference(theta):
    """Lever angle by hand: R_plate = Rx(θ) Rot(j, γ) with the plate pin (y) ⊥ the frame pin (z);
    then |Q(δ) − P| = rod length for the lever point Q turning about its vertical axis."""
    j = np.array([np.cos(sp.BETA), 0, np.sin(sp.BETA)])
    out, g, d = [], 0.0, 0.0          # follow both roots continuously from the assembly
    ell = np.linalg.norm(sp.ROD_END - sp.ARM)
    r = sp.ROD_END - sp.LEVER_AXIS
    for t in theta:
        f = lambda x: (rot_x(t) @ rotation(j, x) @ [0, 1, 0])[2]
        g = brentq(f, g - 0.6, g + 0.1, xtol=1e-15)
        P = rot_x(t) @ rotation(j, g) @ sp.ARM
        h = lambda x: np.linalg.norm(sp.LEVER_AXIS + rot_z(x) @ r - P) - ell
        d = brentq(h, d - 0.3, d + 0.3, xtol=1e-15) if t > 0 else 0.0
        out.append(d)
    return np.array(out)


def test_swash_plate_two_loops_against_independent_solution():
    m = sp.build()
    assert m.n_loops == 2 and m.mobility == 1
    theta = np.linspace(0, 2 * np.pi, 49)
    df = m.sweep(theta)
    assert (df.status == "ok").all() and df.residual.max() < 1e-12
    # joint "lever" runs from the lever to the ground: the lever turns by −q
    assert np.abs(-df["lever"].to_numpy() - reference(theta)).max() < 1e-10
    # one full shaft turn brings every joint back (the journal by −2π)
    last = df.iloc[-1]
    assert abs(last["lever"]) < 1e-10 and abs(last["journal"] + 2 * np.pi) < 1e-10


def test_swash_plate_example_runs(capsys):
    sp.main()
    out = capsys.readouterr().out
    assert "2 loops, mobility 1" in out and "not reached" not in out
