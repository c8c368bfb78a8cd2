"""Forward dynamics through singular crossings, from a chosen branch, with public scipy API:
the IFToMM N-four-bar against its one-coordinate equation of motion on the parallelogram
branch (an independent closed-form model), and energy."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from closure import ClosureError, MechanismError
from closure.integrate import METHODS, IntegrationResult

from .models import n_fourbar_dynamics, n_fourbar_reference_rhs


def reference(x0, xd0, t):
    return solve_ivp(n_fourbar_reference_rhs(), (0, t[-1]), [x0, xd0], t_eval=t, rtol=1e-13,
                     atol=1e-14, method="DOP853").y


@pytest.mark.parametrize("x0, xd0, T", [(-np.pi / 2, -6.0, 0.5),   # swings through θ = −π
                                        (0.0, -1.0, 3.0)])          # starts at a singular pose
def test_tight_tolerance_run_crosses_singular_configurations(x0, xd0, T):
    _, d = n_fourbar_dynamics()
    t = np.linspace(0, T, 31)
    df = d.simulate((0, T), [x0], [xd0], t_eval=t, rtol=1e-12, atol=1e-14)
    sol = df.attrs["ivp"]
    assert isinstance(sol, IntegrationResult)
    assert sol.status == 0 and df.attrs["status"] == "completed"
    assert df.G0.min() < -np.pi                        # it did cross the flat position
    assert sol.nfev < 5000                             # no step collapse
    ref = reference(x0, xd0, t)
    assert np.abs(df.G0 - ref[0]).max() < 1e-9
    assert np.abs(df["rate:G0"] - ref[1]).max() < 1e-8
    # parallelogram branch throughout: every crank at the input angle
    assert np.abs(df["q:G1"] - df.G0).max() < 1e-10 and np.abs(df["q:G2"] - df.G0).max() < 1e-10
    scale = df.kinetic.max() + np.ptp(df.potential)
    assert np.abs(df.balance).max() < 1e-9 * scale
    # only a row that sits on the singular configuration itself is flagged
    flagged = df.flag != ""
    assert (df.condition[flagged] > 1e7).all()


def test_step_output_reuses_the_integrator_poses():
    _, d = n_fourbar_dynamics()
    df = d.simulate((0, 0.3), [-np.pi / 2], [-6.0], rtol=1e-10)
    sol = df.attrs["ivp"]
    assert len(df) == sol.steps + 1 and np.array_equal(df.t, sol.t)
    assert df.residual.max() < 1e-12


def test_far_start_keeps_the_branch_of_the_assembly_or_of_a_guess():
    m, d = n_fourbar_dynamics()
    x0 = -10.325                                        # three flat positions from assembly
    t = np.linspace(0, 0.3, 7)
    df = d.simulate((0, 0.3), [x0], [0.0], t_eval=t, rtol=1e-11)
    assert np.abs(df["q:G1"] - df.G0).max() < 1e-10
    assert np.abs(df.G0 - reference(x0, 0.0, t)[0]).max() < 1e-9
    _, guess = m.sweep(np.linspace(0, -10.3, 60), return_pose=True)
    g = guess
    from closure import Pose
    last = Pose(m, g.inputs[-1:], g.q[-1:], g.rot[-1:], g.residual[-1:], g.iterations[-1:],
                g.condition[-1:], g.status[-1:])
    df2 = d.simulate((0, 0.3), [x0], [0.0], t_eval=t, rtol=1e-11, guess=last)
    assert np.abs(df2.G0 - df.G0).max() < 1e-12


def test_methods_are_scipys_public_classes_and_bad_arguments_are_named():
    import scipy.integrate as si
    assert all(METHODS[k] is getattr(si, k) for k in METHODS)
    _, d = n_fourbar_dynamics()
    with pytest.raises(MechanismError, match="method 'RK99' unknown"):
        d.simulate((0, 1), [0.1], [0.0], method="RK99")
    with pytest.raises(MechanismError, match="x0"):
        d.simulate((0, 1), [np.nan], [0.0])
    with pytest.raises(MechanismError, match="t_span"):
        d.simulate((1, 0), [0.1], [0.0])
    with pytest.raises(MechanismError, match="non-finite generalised force"):
        d.simulate((0, 1), [-1.0], [0.0], drive=lambda t, x, xd: np.array([np.nan]))


def test_toggle_still_stops_with_the_trajectory():
    from .test_dynamics import fourbar_model
    a, b, c, dd = 2.0, 2.5, 1.5, 3.0
    t_lim = np.arccos((a * a + dd * dd - (b + c) ** 2) / (2 * a * dd))
    _, d4 = fourbar_model(dict(a=a, b=b, c=c, d=dd), (1.0, 1.0, 1.0), 0.5)
    d4.gravity = np.zeros(3)
    out = d4.simulate((0, 5), [0.0], [0.0], drive=lambda t, x, xd: np.array([20.0]),
                      rtol=1e-9, atol=1e-11)
    assert out.attrs["ivp"].status == 1 and out.attrs["status"] == "dead point"
    assert abs(0.5 + out.A.iloc[-1] - t_lim) < 1e-3
    assert out.condition.iloc[-1] > 1e6
    assert out.flag.iloc[-1] != ""                      # the last row says why it is doubtful
    with pytest.raises(ClosureError):
        d4.m.solve(t_lim - 0.5 + 0.05)
