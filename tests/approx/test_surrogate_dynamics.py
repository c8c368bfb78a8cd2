"""Surrogate analogs inside the engine's multi-DOF dynamics (issue 16): the reduced model
(``Dynamics.reduced``, built by ``approx.surrogate_dynamics``) against the exact engine on
the two-loop crane and the four-loop three-cylinder arm; its energy conservation; errors."""
import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from approx import ApproxError, arm
from approx.multiloop import LoopAnalogs, loop_inputs, surrogate_dynamics
from closure import Dynamics, Mechanism, MechanismError, translation
from closure.reduced import ReducedDynamics
from linkwright.examples import crane as cr

CRANE_RANGES = {"stroke1": (-0.05, 0.3), "stroke2": (-0.05, 0.17)}


class _Exact:
    """Exact analogs of one coordinate as a bare duck-typed transfer (no ``all``)."""

    def __init__(self, loop, c):
        self.f = loop.coordinate(c)

    def position(self, x):
        return self.f[0](np.atleast_1d(x))

    def velocity(self, x):
        return self.f[1](np.atleast_1d(x))

    def acceleration(self, x):
        return self.f[2](np.atleast_1d(x))


@pytest.fixture(scope="module")
def crane():
    d = cr.dynamics()
    t = np.linspace(0, 4.0, 41)
    exact = d.inverse(t, cr.lifting_motion)
    return d, t, exact


@pytest.fixture(scope="module")
def crane_cheb(crane):
    return surrogate_dynamics(crane[0], ranges=CRANE_RANGES, kind="chebyshev", size=12)


def _drives(df, labels):
    return df[[f"drive:{k}" for k in labels]].to_numpy()


def _rms_rel(got, want):
    """RMS error of each input's drive force over the motion, relative to its RMS."""
    return np.sqrt(np.mean((got - want) ** 2, 0) / np.mean(want ** 2, 0))


def test_hook_with_exact_analogs_is_the_engine(crane):
    # the hook on the engine's own analogs (bare position/velocity/acceleration objects):
    # mass matrix, bias, applied forces, rates and energies equal the exact engine's
    d = crane[0]
    m = d.m
    owner = loop_inputs(m, CRANE_RANGES)
    labels = m.coordinate_labels()
    assert owner.tolist() == [0, 0, 0, 0, 1, 1, 1, 1]     # O, G1, stroke1, B1 | T, B2, …
    transfers = {}
    for i, name in enumerate(m.input_labels()):
        loop = LoopAnalogs(m, name, *CRANE_RANGES[name])
        transfers.update({labels[c]: (name, _Exact(loop, c)) for c in range(len(labels))
                          if owner[c] == i and labels[c] != name})
    red = d.reduced(transfers, CRANE_RANGES)
    assert isinstance(red, ReducedDynamics)
    rng = np.random.default_rng(7)
    X = np.c_[rng.uniform(-0.05, 0.3, 6), rng.uniform(-0.05, 0.17, 6)]
    XD = rng.normal(size=(6, 2))
    pose = m.solve(X)
    for got, want in zip(red.terms(X, XD), d.terms(pose, XD)):
        assert np.abs(got - want).max() <= 1e-10 * np.abs(want).max()
    e_red, e_ex = red.energy(X, XD), d.energy(pose, XD)
    for k in ("kinetic", "gravity", "total"):
        assert np.allclose(e_red[k], e_ex[k], rtol=1e-11, atol=1e-9)
    assert red.coordinates(X).residual.max() < 1e-10        # exact analogs close the loops


def _rucc():
    """A spatial R–U–C–C loop (mobility 1): a Hooke joint in the tree, a cylindrical joint
    reached backwards from the ground, and a cylindrical chord."""
    from closure import frame_from_points

    def fr(o, z, x):
        o = np.array(o, float)
        return frame_from_points(o, o + np.array(x, float), o + np.array(z, float))
    m = Mechanism(["crank", "coupler", "follower"])
    m.add_joint("A", "R", "ground", "crank", at=fr((0, 0, 0), (0, 0, 1), (1, 0, 0)))
    m.add_joint("B", "U", "crank", "coupler", at=fr((1, 0, 0.2), (0, 0, 1), (0, 1, 0)))
    m.add_joint("C", "C", "coupler", "follower", at=fr((1.6, 1.2, 0.5), (1, 0.2, 0.3),
                                                       (0, 1, 0)))
    m.add_joint("D", "C", "follower", "ground", at=fr((2.5, 0.3, 0.1), (0.2, 0.1, 1),
                                                      (1, 0, -0.2)))
    m.add_input("A")
    d = Dynamics(m, gravity=(0.5, -9.81, 1.0))
    for k, (link, c) in enumerate((("crank", (0.5, 0, 0.1)), ("coupler", (1.3, 0.6, 0.35)),
                                   ("follower", (2.0, 0.7, 0.3)))):
        d.add_body(link, 1.0 + k, c, np.diag([0.02, 0.03, 0.04]) * (1 + k))
    d.add_spring("C", 40.0, free=0.1, index=1)          # on the chord's slide
    d.add_damper("D", 0.7)
    d.add_force("B", lambda t, q, qd: 0.3 - q, index=1)
    return d


def test_hook_spatial_joints_against_the_engine():
    # the general joint paths (U with its moving second axis, C reached backwards through
    # the tree, elements on a chord) with the engine's exact analogs as transfers
    d = _rucc()
    m = d.m
    assert m.mobility == 1 and m.tree.forward[m.links.index("follower")] is False
    loop = LoopAnalogs(m, "A", -0.5, 0.5)
    labels = m.coordinate_labels()
    red = d.reduced({k: ("A", _Exact(loop, c)) for c, k in enumerate(labels) if k != "A"})
    X = np.linspace(-0.5, 0.5, 5)[:, None]
    XD = np.linspace(-2.0, 1.5, 5)[:, None]
    pose = m.solve(X)
    for got, want in zip(red.terms(X, XD, t=0.3), d.terms(pose, XD, t=0.3)):
        assert np.abs(got - want).max() <= 1e-10 * max(np.abs(want).max(), 1.0)
    e_red, e_ex = red.energy(X, XD), d.energy(pose, XD)
    for k in ("kinetic", "gravity", "spring"):
        assert np.allclose(e_red[k], e_ex[k], rtol=1e-11, atol=1e-12)


def test_crane_inverse_and_forward_against_the_engine(crane, crane_cheb):
    d, t, exact = crane
    labels = d.m.input_labels()
    F = _drives(exact, labels)
    # drive forces: RMS error ≤ 1 % for the spline of 8 intervals and the Chebyshev form
    spline = surrogate_dynamics(d, ranges=CRANE_RANGES, kind="spline", size=8)
    e_spline = _rms_rel(_drives(spline.inverse(t, cr.lifting_motion), labels), F)
    e_cheb = _rms_rel(_drives(crane_cheb.inverse(t, cr.lifting_motion), labels), F)
    assert e_spline.max() < 0.01 and e_cheb.max() < 1e-4
    assert e_cheb.max() < e_spline.max() / 10                # the better kind is better
    fits = crane_cheb.info["fits"]
    assert set(fits.coordinate) == {"O", "G1", "B1", "T", "B2", "J2"}
    assert fits.max_abs_F.max() < 1e-5                       # rad, against the engine
    # a short forward run under the exact inverse's drive forces: the same trajectory
    drive = CubicSpline(t, F)
    te = np.linspace(0, 0.4, 5)
    run = dict(t_eval=te, drive=lambda tt, x, xd: drive(tt), rtol=1e-9, atol=1e-11)
    ex = d.simulate((0, 0.4), [0, 0], [0, 0], **run)
    red = crane_cheb.simulate((0, 0.4), [0, 0], [0, 0], **run)
    assert red.attrs["status"] == "completed"
    law = cr.lifting_motion(te)[0]
    x_ex, x_red = ex[labels].to_numpy(), red[labels].to_numpy()
    assert np.abs(x_ex - law).max() < 1e-5                   # the drive replays the motion
    # the drives are mostly the static holding forces: a relative force error ε moves the
    # strokes by about ε·F/m·t²/2, here a few µm against 1.6 mm of motion
    assert np.abs(x_red - x_ex).max() < 5e-6                 # m
    assert np.abs(red.balance).max() < 1e-7 * np.abs(red.work).max()
    q = [f"q:{k}" for k in ("O", "T")]
    assert np.abs(red[q].to_numpy() - ex[q].to_numpy()).max() < 5e-6     # rad
    # under its own inverse dynamics' forces the reduced model replays the motion exactly
    own = CubicSpline(np.linspace(0, 0.4, 81), _drives(
        crane_cheb.inverse(np.linspace(0, 0.4, 81), cr.lifting_motion), labels))
    again = crane_cheb.simulate((0, 0.4), [0, 0], [0, 0], t_eval=te,
                                drive=lambda tt, x, xd: own(tt), rtol=1e-10, atol=1e-12)
    assert np.abs(again[labels].to_numpy() - law).max() < 2e-8


def test_arm_four_loops_three_inputs():
    d = arm.dynamics()
    m = d.m
    assert m.n_loops == 4 and m.mobility == 3
    owner = dict(zip(m.coordinate_labels(), loop_inputs(m, arm.RANGES).tolist()))
    # the bucket linkage (cylinder loop and four-bar) moves with stroke 3 alone
    assert {k for k, v in owner.items() if v == 2} == {"stroke3", "T2", "B3", "L1", "K", "L2",
                                                       "W"}
    red = surrogate_dynamics(d, ranges=arm.RANGES, kind="chebyshev", size=8)
    t = np.linspace(0, 3.0, 31)
    labels = m.input_labels()
    F = _drives(d.inverse(t, arm.motion), labels)
    got = red.inverse(t, arm.motion)
    assert _rms_rel(_drives(got, labels), F).max() < 0.01
    assert got.residual.max() < 1e-4          # the surrogate kinematics nearly close the loops
    with pytest.raises(MechanismError, match="inverse: x: input 'stroke3'"):
        red.inverse(np.array([0.0]), np.array([[0.0, 0.0, 0.2]]), np.zeros((1, 3)),
                    np.zeros((1, 3)))


def test_reduced_model_conserves_energy():
    # no dampers, no drives: springs on the strokes and gravity.  The reduced model is a
    # Lagrangian system of the surrogate kinematics, so E stays constant (to the
    # integrator's tolerance) although the surrogate does not close the loops exactly.
    d = arm.dynamics(damping=False)
    for k, s in (("stroke1", 2e5), ("stroke2", 1e5), ("stroke3", 5e4)):
        d.add_spring(k, s)
    red = surrogate_dynamics(d, ranges=arm.RANGES, kind="chebyshev", size=4)
    out = red.simulate((0, 0.3), [0.0, 0.0, 0.0], [0.05, -0.05, 0.04], rtol=1e-11,
                       atol=1e-13, t_eval=np.linspace(0, 0.3, 16))
    assert out.attrs["status"] == "completed"
    assert np.ptp(out.kinetic) > 50.0                        # J: energy moves between forms
    assert out.residual.max() > 1e-6                         # the loops are not closed…
    assert np.abs(out.energy - out.energy[0]).max() < 1e-8 * np.ptp(out.kinetic)   # …E is
    assert (out.dissipated == 0).all() and (out.work == 0).all()


def test_dampers_and_range_end(crane_cheb):
    # with the crane's pivot dampers and drives at 90 % of the holding forces: the energy
    # balance holds, and the run stops where an input leaves its fitted range
    d = crane_cheb.dynamics
    hold = _drives(d.inverse(np.array([0.0]), cr.lifting_motion), d.m.input_labels())[0]
    out = crane_cheb.simulate((0, 2.0), [0, 0], [0, 0], drive=lambda t, x, xd: 0.9 * hold,
                              rtol=1e-10, atol=1e-12)
    assert out.attrs["status"] == "left range"
    assert out.t.iloc[-1] < 2.0
    assert out.stroke1.iloc[-1] == pytest.approx(CRANE_RANGES["stroke1"][0], abs=1e-9)
    assert out.dissipated.iloc[-1] > 0
    assert np.abs(out.balance).max() < 1e-8 * np.abs(out.work).max()


def test_bad_inputs_name_the_argument(crane_cheb):
    d = crane_cheb.dynamics
    good = dict(crane_cheb.transfers)
    with pytest.raises(MechanismError, match="transfers: expected a mapping"):
        d.reduced([1, 2])
    with pytest.raises(MechanismError, match=r"transfers: no transfer for coordinate\(s\) O"):
        d.reduced({k: v for k, v in good.items() if k != "O"})
    with pytest.raises(MechanismError, match="transfers: 'nope' is not a coordinate"):
        d.reduced({**good, "nope": good["O"]})
    with pytest.raises(MechanismError, match="transfers: 'stroke1' is an input"):
        d.reduced({**good, "stroke1": good["O"]})
    with pytest.raises(MechanismError, match=r"transfers\['O'\]: the transfer has no callable "
                                             r"position"):
        d.reduced({**good, "O": ("stroke1", object())})
    with pytest.raises(MechanismError, match=r"transfers\['O'\]: input 'boom' is not an input"):
        d.reduced({**good, "O": ("boom", good["O"][1])})
    with pytest.raises(MechanismError, match=r"ranges\['stroke1'\]: expected \(low, high\)"):
        d.reduced(good, {"stroke1": (0.3, 0.1)})

    class Bad:
        def position(self, x):
            return np.nan * np.asarray(x)
        velocity = acceleration = position

    red = d.reduced({**good, "B1": ("stroke1", Bad())})
    with pytest.raises(MechanismError, match=r"transfers\['B1'\]: returned a non-finite"):
        red.terms([0.1, 0.1], [0.0, 0.0])
    with pytest.raises(MechanismError, match="terms: x: expected shape"):
        crane_cheb.terms(np.zeros(3), np.zeros(2))
    with pytest.raises(MechanismError, match="simulate: x0: input 'stroke1'"):
        crane_cheb.simulate((0, 1), [0.5, 0.0], [0.0, 0.0])
    with pytest.raises(MechanismError, match="simulate: rtol"):
        crane_cheb.simulate((0, 1), [0.0, 0.0], [0.0, 0.0], rtol=-1)
    # the approx constructor
    with pytest.raises(ApproxError, match="dynamics: expected a closure.Dynamics"):
        surrogate_dynamics(d.m, ranges=CRANE_RANGES)
    with pytest.raises(ApproxError, match="kind: expected one of"):
        surrogate_dynamics(d, ranges=CRANE_RANGES, kind="cubic")
    with pytest.raises(ApproxError, match="size: expected"):
        surrogate_dynamics(d, ranges=CRANE_RANGES, size=0)
    with pytest.raises(ApproxError, match="ranges: no range for input 'stroke2'"):
        surrogate_dynamics(d, ranges={"stroke1": (0.0, 0.1)})
    with pytest.raises(ApproxError, match=r"ranges\['stroke2'\]: expected \(low, high\)"):
        surrogate_dynamics(d, ranges={"stroke1": (0.0, 0.1), "stroke2": (0.1, 0.1)})
    with pytest.raises(ApproxError, match="a, b: the mechanism cannot be driven"):
        surrogate_dynamics(d, ranges={"stroke1": (0.0, 0.1), "stroke2": (0.0, 0.4)})


def test_coupled_loop_is_refused():
    # a five-bar with two cranks: the coupler angles move with both inputs
    P = {"A": (0, 0, 0), "B": (0, 1, 0), "C": (1, 1.5, 0), "D": (2, 1, 0), "E": (2, 0, 0)}
    m = Mechanism(["c1", "l1", "l2", "c2"])
    for name, a, b in (("A", "ground", "c1"), ("B", "c1", "l1"), ("C", "l1", "l2"),
                       ("D", "l2", "c2"), ("E", "ground", "c2")):
        m.add_joint(name, "R", a, b, at=translation(P[name]))
    m.add_input("A")
    m.add_input("E")
    d = Dynamics(m)
    d.add_body("l1", 1.0, (0.5, 1.25, 0))
    with pytest.raises(ApproxError, match="coordinate 'B' moves with inputs A, E"):
        surrogate_dynamics(d, ranges={"A": (-0.1, 0.1), "E": (-0.1, 0.1)})
