"""Drive-force tolerances (closure.tolerance): Monte Carlo on the engine's inverse dynamics
against the first-order prediction, on a planar four-bar (position errors; tilts stop an
over-constrained design) and a spatial R-S-C-R loop (tilts and shifts)."""
import numpy as np
import pytest

from closure import Dynamics, Mechanism, MechanismError, exp_so3, transform
from closure.tolerance import drive_tolerance, joint_error_parameters, made_frames

from linkwright.examples import folder
from linkwright.mechspec import build_dynamics, build_mechanism, joint_frames
from linkwright.study import load_study


def law(a, b, T, n):
    t = np.linspace(0, T, n)
    s = t / T
    return t, tuple(v[:, None] for v in (a + (b - a) * (s - np.sin(2 * np.pi * s) / (2 * np.pi)),
                                         (b - a) * (1 - np.cos(2 * np.pi * s)) / T,
                                         (b - a) * 2 * np.pi * np.sin(2 * np.pi * s) / T ** 2))


@pytest.fixture(scope="module")
def fourbar():
    s = load_study(folder() / "fourbar_dynamics.toml")
    ms, ds = s.section("mechanism"), s.section("dynamics")
    frames, kinds = joint_frames(ms)
    return (lambda fr: build_dynamics(ds, build_mechanism(ms, fr))), frames, kinds


def rscr(frames):
    m = Mechanism(["crank", "coupler", "rocker"])
    for name, kind, a, b in (("A", "R", "ground", "crank"), ("B", "S", "crank", "coupler"),
                             ("C", "C", "coupler", "rocker"), ("D", "R", "rocker", "ground")):
        m.add_joint(name, kind, a, b, at=frames[name])
    m.add_input("A")
    d = Dynamics(m, gravity=(0, 0, -9.81))
    d.add_body("crank", 1.0, [0.0, 0.4, 0.0])
    d.add_body("coupler", 2.0, [1.0, 1.0, 0.3], np.diag([0.1, 0.4, 0.4]))
    d.add_body("rocker", 1.5, [1.8, 0.4, 0.2])
    return d


RSCR_FRAMES = {"A": transform(np.eye(3), [0.0, 0.0, 0.0]),
               "B": transform(np.eye(3), [0.0, 0.8, 0.0]),
               "C": transform(exp_so3([0.3, -0.5, 0.2]), [1.9, 1.3, 0.5]),
               "D": transform(exp_so3([0.2, 0.9, 0.0]), [2.2, 0.0, 0.1])}
RSCR_KINDS = {"A": "R", "B": "S", "C": "C", "D": "R"}


def test_fourbar_position_errors_sampled_and_to_first_order(fourbar):
    build, frames, kinds = fourbar
    t, lw = law(0.0, np.pi, 2.0, 13)
    r = drive_tolerance(build, frames, kinds, t, lw, direction_sigma=0.0, position_sigma=1e-3,
                        samples=400, seed=1)
    assert r.failed == 0 and r.changes.shape == (400, 13, 1)
    s = r.summary
    # the same samples to first order: the changes are linear in δp to O(σ²)
    assert np.allclose(s.sd_linear, s.sd, rtol=0.01)
    assert np.abs(r.changes - r.linear).max() <= 0.02 * np.abs(r.changes).max()
    # sqrt(diag(J Σ Jᵀ)) against the sample sd: sampling error of an sd at 400 samples
    # is 3.5 % (one σ); 15 % is four of them
    assert np.all(np.abs(s.sd / s.sd_predicted - 1) <= 0.15)
    # the drive at the design equals the engine's inverse dynamics (continuation)
    inv = build(frames).inverse(t, *lw)
    assert np.allclose(s.drive, inv["drive:A"], atol=1e-9 * np.abs(inv["drive:A"]).max())
    # a planar linkage: a tilt alone stops it (over-constrained); shifts never do
    assert sorted(r.rigid) == sorted(f"{j}.tilt_{a}" for j in "ABCD" for a in "xy")


def test_fourbar_tilted_axes_cannot_move_and_are_counted(fourbar):
    build, frames, kinds = fourbar
    t, lw = law(0.0, np.pi, 2.0, 7)
    r = drive_tolerance(build, frames, kinds, t, lw, direction_sigma=np.radians(0.05),
                        position_sigma=0.0, samples=12, seed=3)
    assert r.failed == 12 and r.changes.shape == (0, 7, 1)
    assert np.isnan(r.peak["mean"]).all()


def test_spatial_loop_tilts_and_shifts():
    t, lw = law(0.0, 1.2, 1.5, 9)
    r = drive_tolerance(rscr, RSCR_FRAMES, RSCR_KINDS, t, lw, direction_sigma=np.radians(0.1),
                        position_sigma=5e-4, samples=300, seed=4)
    assert r.failed == 0 and r.rigid == []
    assert r.parameters == joint_error_parameters(RSCR_KINDS)
    assert len(r.parameters) == 4 + 3 + 4 + 4          # S: three shifts, no tilt
    s = r.summary
    assert np.allclose(s.sd_linear, s.sd, rtol=0.02)
    assert np.all(np.abs(s.sd / s.sd_predicted - 1) <= 0.15)
    # the sensitivities against a one-sided difference of the engine at another step
    build, dp = rscr, np.zeros(len(r.parameters))
    k = r.parameters.index("C.tilt_y")
    dp[k] = 1e-5
    d = build(made_frames(RSCR_FRAMES, RSCR_KINDS, dp))
    F1 = d.inverse(t, *lw)["drive:A"].to_numpy()
    F0 = rscr(RSCR_FRAMES).inverse(t, *lw)["drive:A"].to_numpy()
    assert np.allclose((F1 - F0) / 1e-5, r.sensitivity[:, 0, k], rtol=1e-3,
                       atol=1e-3 * np.abs(r.sensitivity[:, 0, k]).max())


def test_made_frames_move_each_joint_as_named():
    dp = np.zeros(15)
    names = joint_error_parameters(RSCR_KINDS)
    dp[names.index("B.shift_z")] = 0.01
    dp[names.index("D.tilt_x")] = 0.02
    out = made_frames(RSCR_FRAMES, RSCR_KINDS, dp)
    assert np.allclose(out["B"][:3, 3] - RSCR_FRAMES["B"][:3, 3], RSCR_FRAMES["B"][:3, 2] * 0.01)
    R0, R1 = RSCR_FRAMES["D"][:3, :3], out["D"][:3, :3]
    assert np.allclose(R1[:, 0], R0[:, 0])                         # about its own X
    assert np.isclose(R1[:, 2] @ R0[:, 2], np.cos(0.02))
    assert np.array_equal(out["A"], RSCR_FRAMES["A"])


@pytest.mark.parametrize("kw, name", [(dict(direction_sigma=-1.0), "direction_sigma"),
                                      (dict(position_sigma=np.nan), "position_sigma"),
                                      (dict(position_sigma=0.0), "position_sigma"),
                                      (dict(samples=5), "samples"),
                                      (dict(samples=True), "samples"),
                                      (dict(seed=-1), "seed")])
def test_bad_inputs_name_the_argument(kw, name):
    t, lw = law(0.0, 1.0, 1.0, 5)
    args = dict(direction_sigma=0.0, position_sigma=1e-3, samples=20, seed=0)
    args.update(kw)
    with pytest.raises(MechanismError, match=name):
        drive_tolerance(rscr, RSCR_FRAMES, RSCR_KINDS, t, lw, **args)
    with pytest.raises(MechanismError, match="frames, kinds"):
        drive_tolerance(rscr, RSCR_FRAMES, {"A": "R"}, t, lw, position_sigma=1e-3)


def test_rigid_motion_far_from_the_origin_changes_nothing():
    """The whole loop and gravity moved by a rigid motion 1 km away: the same samples (the
    errors are in each joint's own frame) give the same drive forces and statistics."""
    G = transform(exp_so3([0.4, -1.1, 0.7]), [800.0, -450.0, 300.0])

    def moved(frames):
        d0 = rscr({k: np.linalg.inv(G) @ F for k, F in frames.items()})   # to build bodies
        m = Mechanism(["crank", "coupler", "rocker"])
        for j in d0.m.joints:
            m.add_joint(j.name, j.kind, j.link_a, j.link_b, at=frames[j.name])
        m.add_input("A")
        d = Dynamics(m, gravity=G[:3, :3] @ np.array([0, 0, -9.81]))
        for b in d0.bodies:
            com = G[:3, :3] @ np.asarray(b.com) + G[:3, 3]
            d.add_body(b.link, b.mass, com, G[:3, :3] @ np.asarray(b.inertia) @ G[:3, :3].T)
        return d

    t, lw = law(0.0, 1.2, 1.5, 7)
    kw = dict(direction_sigma=np.radians(0.1), position_sigma=5e-4, samples=20, seed=9)
    a = drive_tolerance(rscr, RSCR_FRAMES, RSCR_KINDS, t, lw, **kw)
    b = drive_tolerance(moved, {k: G @ F for k, F in RSCR_FRAMES.items()}, RSCR_KINDS, t, lw,
                        **kw)
    scale = np.abs(a.summary.drive).max()
    assert np.allclose(b.summary.drive, a.summary.drive, atol=1e-9 * scale)
    assert np.allclose(b.changes, a.changes, atol=1e-6 * np.abs(a.changes).max())
    assert a.failed == b.failed == 0
