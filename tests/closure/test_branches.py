"""Branch safety, generic mobility, far solves and origin-free conditioning, each against an
independent reference (closed forms, the Hairer–Wanner constraint equations, invariance)."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from closure import ClosureError, rot_x, rot_z, transform
from linkwright.references import fourbar, freudenstein

from .models import (AND_Q0, andrews, andrews_points, andrews_reference, n_fourbar,
                     parallelogram)


def wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


# ---------------------------------------------------------------- mobility (issue 10.6)
@pytest.mark.parametrize("build, branch", [
    (lambda: parallelogram(1.0, 2.0), lambda q, x: np.c_[q["B"] + x, q["C"] - x, q["D"] - x]),
    (lambda: n_fourbar(3), lambda q, x: np.c_[q["G1"] - x, q["G2"] - x, q["T0"] + x,
                                                q["U0"] - x, q["T1"] + x, q["U1"] - x]),
])
def test_flat_parallelograms_have_mobility_one_and_sweep_a_full_turn(build, branch):
    m = build()
    assert m.mobility == 1 and m.assembly_singular
    x = np.linspace(0, 2 * np.pi, 25)             # passes the flat positions at 0, π, 2π
    df, pose = m.sweep(x, return_pose=True)
    assert len(pose) == x.size
    # rows at the flat positions say so (condition above the limit); the others are "ok"
    flat = np.isclose(np.sin(x), 0, atol=1e-9)
    assert (df.status[flat] == "near-singular").all() and (df.status[~flat] == "ok").all()
    assert (df.condition[flat] > 1e7).all()
    q = {lab: df[lab].to_numpy() for lab in m.coordinate_labels()}
    # parallelogram branch: every crank turns with the input, couplers translate
    assert np.abs(branch(q, x)).max() < 1e-9
    assert df.residual.max() < 1e-12


def test_regular_assembly_is_not_reported_singular():
    m, _ = fourbar(1.0, 3.0, 2.5, 3.2, 0.3)
    assert m.mobility == 1 and not m.assembly_singular


# ---------------------------------------------------------------- far solves (issue 10.7)
def test_andrews_direct_solve_reaches_every_crank_angle_of_a_sweep():
    m = andrews()
    x = np.linspace(-np.pi, np.pi, 37)
    pose = m.solve(x)                               # raises if any input is not reached
    assert (pose.status <= 1).all() and np.array_equal(pose.reached, x[:, None])
    ref = andrews_reference(x)
    P0 = andrews_points(AND_Q0)
    for link, pt in (("K5", "G"), ("K7", "H"), ("K2", "E")):
        want = np.array([andrews_points(q)[pt] for q in ref])
        got = pose.point(link, np.r_[P0[pt], 0.0])[:, :2]
        assert np.abs(got - want).max() < 1e-12
    # the same inputs by a sweep from the assembly: the same poses
    df = m.sweep(np.r_[0.0, x[x >= 0]])
    assert (df.status == "ok").all()
    assert np.abs(df.B.to_numpy()[1:] - pose["B"][x >= 0]).max() < 1e-10


def test_solve_past_a_toggle_says_where_it_stopped():
    a, b, c, d = 2.0, 2.5, 1.5, 3.0                  # non-Grashof: the crank toggles
    m, _ = fourbar(a, b, c, d, 0.5)
    t_lim = np.arccos((a * a + d * d - (b + c) ** 2) / (2 * a * d))
    pose = m.solve([0.2, t_lim - 0.5 + 0.2], raise_on_failure=False)
    assert pose.status_text.tolist() == ["ok", "dead point"]
    assert abs(pose.reached[1, 0] + 0.5 - t_lim) < 1e-6
    with pytest.raises(ClosureError, match="dead point, reached"):
        m.solve(t_lim - 0.5 + 0.2)


# ---------------------------------------------------------------- branch safety (issue 11.1, 11.4)
@pytest.mark.parametrize("geom, start", [((1.949, 2.65, 2.929, 2.549), 4.605),
                                         ((0.875, 3.375, 3.5, 1.0625), 0.0)])
@pytest.mark.parametrize("step_deg", [30, 45, 90, 180])
def test_sweep_with_any_step_stays_on_its_branch(geom, start, step_deg):
    for branch in (1, -1):
        m, (_, t40) = fourbar(*geom, start, branch=branch)
        x = np.deg2rad(np.arange(0, 721, step_deg))
        df = m.sweep(x)
        assert (df.status == "ok").all()
        _, t4 = freudenstein(start + x, *geom, branch=branch)
        assert np.abs(wrap(t40 + df.D.to_numpy() - t4)).max() < 1e-10


@settings(max_examples=25, deadline=None)
@given(st.floats(0.2, 1.0), st.floats(2.0, 4.0), st.floats(2.0, 4.0), st.floats(1.0, 3.0),
       st.floats(0, 2 * np.pi), st.sampled_from([1, -1]), st.sampled_from([20, 45, 90, 120]))
def test_sweep_never_reports_ok_on_another_branch(a, b, c, d, start, branch, step_deg):
    lengths = sorted([a, b, c, d])
    if not (lengths[0] == a and lengths[0] + lengths[3] < lengths[1] + lengths[2] - 0.05):
        return                                        # Grashof crank-rockers only (crank a)
    m, (_, t40) = fourbar(a, b, c, d, start, branch=branch)
    x = np.deg2rad(np.arange(0, 361, step_deg))
    df = m.sweep(x)
    _, t4 = freudenstein(start + x, a, b, c, d, branch=branch)
    ok = (df.status == "ok").to_numpy()
    assert np.abs(wrap(t40 + df.D.to_numpy()[ok] - t4[ok])).max() < 1e-9


def test_batched_solve_stays_on_the_guess_branch():
    m, (_, t40) = fourbar(1.0, 3.0, 2.5, 3.2, 0.3)
    x = np.linspace(-np.pi, np.pi, 48)
    pose = m.solve(x - 0.3)
    _, t4 = freudenstein(x, 1.0, 3.0, 2.5, 3.2)
    assert (pose.status == 0).all()
    assert np.abs(wrap(t40 + pose["D"] - t4)).max() < 1e-10


# ---------------------------------------------------------------- origin-free (issue 11.2)
def test_condition_and_status_do_not_depend_on_the_world_origin():
    geom, start = (1.949, 2.65, 2.929, 2.549), 4.605
    out = []
    for off in (0.0, 1e3, 1e5):
        G = transform(rot_z(0.7) @ rot_x(0.3), [off, -off / 2, off / 3])
        m, _ = fourbar(*geom, start, origin_shift=G)
        pose = m.solve(np.linspace(0, 2 * np.pi, 9))
        df = m.sweep(np.linspace(0, 2 * np.pi, 13))
        out.append((pose.condition, pose.status_text.tolist(), df.status.tolist(),
                    df.D.to_numpy()))
    for cond, stat, sstat, d4 in out[1:]:
        assert np.allclose(cond, out[0][0], rtol=1e-6, atol=0)
        assert stat == out[0][1] and sstat == out[0][2]
        assert np.abs(d4 - out[0][3]).max() < 1e-9


@pytest.mark.parametrize("far", [1e3, 1e5])
def test_a_six_loop_platform_far_from_the_origin_closes_with_the_same_figures(far):
    """A 6-UPS (five loops) moved 1 km and 100 km from the world origin: its rounding floor
    grows with the distance (tolerances scale with 1 + |centre| / scale), so every pose still
    closes, with the same condition numbers to 1e-6."""
    from closure import exp_so3
    from linkwright.references import ups_platform
    a, b = np.radians([0, 100, 120, 220, 240, 340]), np.radians([40, 80, 160, 200, 280, 320])
    base = np.c_[0.8 * np.cos(a), 0.8 * np.sin(a), np.zeros(6)]
    plat = np.c_[0.4 * np.cos(b), 0.4 * np.sin(b), np.zeros(6)]
    T0 = np.eye(4)
    T0[:3, 3] = [0.02, 0.01, 0.7]
    x = np.random.default_rng(4).normal(size=(6, 6)) * 0.02
    near = ups_platform(base, plat, T0).solve(x)
    moved = ups_platform(base, plat, T0, exp_so3(np.r_[0.4, -0.9, 1.3]),
                         far * np.r_[0.36, -0.48, 0.8]).solve(x)
    assert (near.status == 0).all() and (moved.status == 0).all()
    assert np.allclose(moved.condition, near.condition, rtol=1e-6)
    assert np.allclose(moved.q, near.q, atol=1e-9 * far)
