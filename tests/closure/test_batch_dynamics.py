"""Batched forward dynamics (closure.batch_dynamics.simulate_batch), issue #15."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from closure import MechanismError
from closure import dynamics_kernels as dk
from closure.batch_dynamics import simulate_batch
from linkwright.references import freudenstein, fourbar_rates

from .models import n_fourbar_dynamics, n_fourbar_reference_rhs
from .test_dynamics import GEOM, MASSES, G, fourbar_model

X0 = np.array([[0.0], [0.2], [-0.3], [0.5]])
XD0 = np.array([[0.0], [1.0], [-0.5], [2.0]])
T = np.linspace(0, 1, 11)


@pytest.fixture(scope="module")
def model():
    return fourbar_model(GEOM, MASSES, 0.3)[1]


@pytest.fixture(scope="module")
def batch(model):
    return simulate_batch(model, (0, 1), X0, XD0, t_eval=T, rtol=1e-10, atol=1e-12)


def test_each_member_equals_its_single_simulation(model, batch):
    assert batch.status.tolist() == [0] * len(X0)
    assert batch.x.shape == (len(X0), 1, len(T)) and batch.xd.shape == batch.x.shape
    for b in range(len(X0)):
        df = model.simulate((0, 1), X0[b], XD0[b], t_eval=T, rtol=1e-10, atol=1e-12)
        assert np.abs(df.A.values - batch.x[b, 0]).max() < 1e-9
        assert np.abs(df["rate:A"].values - batch.xd[b, 0]).max() < 1e-8


def test_batching_invariance(model, batch):
    order = [3, 1, 0]
    sub = simulate_batch(model, (0, 1), X0[order], XD0[order], t_eval=T, rtol=1e-10,
                         atol=1e-12)
    assert np.abs(sub.x - batch.x[order]).max() < 1e-12
    assert np.abs(sub.xd - batch.xd[order]).max() < 1e-11


def test_member_reaching_a_fold_stops_and_the_others_finish():
    a, b, c, dd = 2.0, 2.5, 1.5, 3.0                     # non-Grashof: the crank toggles
    _, d4 = fourbar_model(dict(a=a, b=b, c=c, d=dd), (1.0, 1.0, 1.0), 0.5)
    d4.gravity = np.zeros(3)
    x0 = np.zeros((3, 1))
    xd0 = np.array([[0.0], [3.0], [-0.5]])
    res = simulate_batch(d4, (0, 1), x0, xd0, rtol=1e-9, atol=1e-11,
                         t_eval=np.linspace(0, 1, 5))
    assert res.status.tolist() == [0, 1, 0]
    assert "dead point" in res.message[1] or "does not close" in res.message[1]
    t_lim = np.arccos((a * a + dd * dd - (b + c) ** 2) / (2 * a * dd))
    assert res.t_end[1] < 1 and abs(0.5 + res.x_end[1, 0] - t_lim) < 1e-2
    assert np.isfinite(res.x[[0, 2]]).all()
    single = d4.simulate((0, 1), x0[2], xd0[2], t_eval=np.linspace(0, 1, 5), rtol=1e-9,
                         atol=1e-11)
    assert np.abs(single.A.values - res.x[2, 0]).max() < 1e-8


def test_vectorised_drive(model):
    drive = lambda t, x, xd: np.full_like(x, 2.0)      # noqa: E731
    res = simulate_batch(model, (0, 0.5), X0[:2], XD0[:2], t_eval=[0, 0.5], drive=drive)
    for b in range(2):
        df = model.simulate((0, 0.5), X0[b], XD0[b], t_eval=[0, 0.5],
                            drive=lambda t, x, xd: np.array([2.0]))
        assert np.abs(df.A.values - res.x[b, 0]).max() < 1e-9


@pytest.mark.parametrize("kw, name", [
    (dict(x0=[[np.nan]]), "x0"), (dict(x0=np.zeros((2, 2))), "x0"),
    (dict(xd0=np.zeros((3, 1))), "xd0"), (dict(t_span=(1, 0)), "t_span"),
    (dict(rtol=-1.0), "rtol"), (dict(method="RK99"), "method"),
    (dict(drive=3.0), "drive")])
def test_bad_inputs_name_the_argument(model, kw, name):
    args = dict(t_span=(0, 1), x0=np.zeros((2, 1)), xd0=np.zeros((2, 1)))
    args.update(kw)
    with pytest.raises(MechanismError, match=name):
        simulate_batch(model, args.pop("t_span"), args.pop("x0"), args.pop("xd0"), **args)


def test_the_dynamics_method_is_the_function():
    d = fourbar_model(GEOM, MASSES, 0.3)[1]
    x0, xd0 = np.array([[0.3], [0.5]]), np.zeros((2, 1))
    a = d.simulate_batch((0, 0.2), x0, xd0, t_eval=[0.1, 0.2], rtol=1e-8, atol=1e-10)
    b = simulate_batch(d, (0, 0.2), x0, xd0, t_eval=[0.1, 0.2], rtol=1e-8, atol=1e-10)
    np.testing.assert_array_equal(a.x, b.x)


def closed_form_energies(x, xd, t20=0.3, geom=GEOM, masses=MASSES, g=G):
    """Kinetic and gravitational energy of the four-bar of uniform rods of
    :func:`fourbar_model` at crank angles ``t20 + x`` and rates ``xd`` (arrays), from
    Freudenstein's closed-form kinematics (not the engine): ``T = Σ ½ m |v_c|² + ½ I ω²``
    with ``I = m L² / 12``, ``V = Σ m g y_c``."""
    a, b, c, d = geom["a"], geom["b"], geom["c"], geom["d"]
    t2 = t20 + np.asarray(x, float)
    w2 = np.asarray(xd, float)
    t3, t4 = freudenstein(t2, a, b, c, d)
    _, (w3, w4), _ = fourbar_rates(t2, w2, 0.0, a, b, c, d)

    def e(t):
        return np.array([np.cos(t), np.sin(t)])

    def en(t):
        return np.array([-np.sin(t), np.cos(t)])
    ground_d = np.array([d, 0.0]).reshape((2,) + (1,) * t4.ndim)
    com = [a / 2 * e(t2), a * e(t2) + b / 2 * e(t3), ground_d + c / 2 * e(t4)]
    vel = [a / 2 * w2 * en(t2), a * w2 * en(t2) + b / 2 * w3 * en(t3), c / 2 * w4 * en(t4)]
    T = sum(0.5 * m * (v * v).sum(axis=0) + 0.5 * m * L * L / 12 * w * w
            for m, v, L, w in zip(masses, vel, (a, b, c), (w2, w3, w4)))
    V = sum(m * g * r[1] for m, r in zip(masses, com))
    return T, V


def test_energies_equal_the_single_simulation_and_the_closed_form(model, batch):
    T_ref, V_ref = closed_form_energies(batch.x[:, 0], batch.xd[:, 0])
    scale = np.abs(T_ref).max() + np.abs(V_ref).max()
    assert np.abs(batch.kinetic - T_ref).max() < 1e-12 * scale
    assert np.abs(batch.potential - V_ref).max() < 1e-12 * scale
    assert np.abs(batch.energy - batch.kinetic - batch.potential).max() < 1e-12 * scale
    # a conservative model: the balance is the integration error only
    assert np.abs(batch.balance).max() < 1e-8 * scale
    for b in range(len(X0)):
        df = model.simulate((0, 1), X0[b], XD0[b], t_eval=T, rtol=1e-10, atol=1e-12)
        for col in ("kinetic", "potential", "energy", "balance", "dissipated", "work"):
            assert np.abs(df[col].values - getattr(batch, col)[b]).max() < 1e-9 * scale, col


def test_springs_dampers_given_forces_and_drives_as_the_single_simulation():
    _, d = fourbar_model(GEOM, MASSES, 0.3)
    d.add_damper("C", 0.5)
    d.add_spring("D", 5.0, free=0.1)
    d.add_force("A", lambda t, q, qd: 2.0 + 0.5 * np.sin(3 * t) - 0.2 * qd)   # vectorised
    x0, xd0, t = X0[:3], XD0[:3], np.linspace(0, 0.8, 9)
    res = simulate_batch(d, (0, 0.8), x0, xd0, t_eval=t, rtol=1e-10, atol=1e-12,
                         drive=lambda tt, x, xd: 1.5 * np.cos(tt)[:, None] - 0.1 * x)
    assert res.status.tolist() == [0, 0, 0]
    assert (res.dissipated[:, -1] > 1e-3).all() and (np.abs(res.work[:, -1]) > 0.1).all()
    scale = np.nanmax(np.abs(res.energy)) + np.nanmax(np.abs(res.work))
    assert np.abs(res.balance).max() < 1e-8 * scale        # energy + dissipated − work = E0
    for b in range(3):
        df = d.simulate((0, 0.8), x0[b], xd0[b], t_eval=t, rtol=1e-10, atol=1e-12,
                        drive=lambda tt, x, xd: 1.5 * np.cos(tt) - 0.1 * x)
        assert np.abs(df.A.values - res.x[b, 0]).max() < 1e-9
        assert np.abs(df["rate:A"].values - res.xd[b, 0]).max() < 1e-8
        for col in ("dissipated", "work", "kinetic", "potential", "energy", "balance"):
            assert np.abs(df[col].values - getattr(res, col)[b]).max() < 1e-9 * scale, col


def test_singular_crossings_against_the_closed_form_and_the_single_simulation():
    # the parallelogram branch of three cranks: members that swing through the flat
    # position θ = −π, start on the singular pose θ = 0, and pass near it (the dynamics
    # taken as their limit along the branch there, as simulate does)
    _, d = n_fourbar_dynamics()
    x0, xd0 = np.array([[-np.pi / 2], [0.0], [0.3]]), np.array([[-6.0], [-1.0], [2.0]])
    t = np.linspace(0, 0.5, 31)
    res = simulate_batch(d, (0, 0.5), x0, xd0, t_eval=t, rtol=1e-12, atol=1e-14)
    assert res.status.tolist() == [0, 0, 0]
    assert res.x[0, 0].min() < -np.pi and res.x[2, 0].min() < 0 < res.x[2, 0].max()
    scale = np.nanmax(res.kinetic) + np.ptp(res.potential)
    for b in range(3):
        ref = solve_ivp(n_fourbar_reference_rhs(), (0, 0.5), [x0[b, 0], xd0[b, 0]], t_eval=t,
                        rtol=1e-13, atol=1e-14, method="DOP853").y
        assert np.abs(res.x[b, 0] - ref[0]).max() < 1e-9
        assert np.abs(res.xd[b, 0] - ref[1]).max() < 1e-8
        df = d.simulate((0, 0.5), x0[b], xd0[b], t_eval=t, rtol=1e-12, atol=1e-14)
        assert np.abs(df.G0.values - res.x[b, 0]).max() < 1e-9
        assert np.abs(df.energy.values - res.energy[b]).max() < 1e-9 * scale
    assert np.abs(res.balance).max() < 1e-9 * scale


def test_without_energies_or_output_times(model):
    res = simulate_batch(model, (0, 0.2), X0[:2], XD0[:2], t_eval=[0, 0.1, 0.2],
                         rtol=1e-8, atol=1e-10, energy=False)
    assert np.isfinite(res.x).all() and np.isnan(res.energy).all()
    assert np.isnan(res.kinetic).all() and np.isnan(res.balance).all()
    res = simulate_batch(model, (0, 0.2), X0[:2], XD0[:2], rtol=1e-8, atol=1e-10)
    assert res.x.shape == (2, 1, 0) and res.energy.shape == (2, 0)
    assert (res.t_end == 0.2).all() and np.isfinite(res.x_end).all()


def test_the_packed_model_is_kept_until_the_model_changes():
    _, d = fourbar_model(GEOM, MASSES, 0.3)
    a = d._packed()
    assert d._packed() is a
    DI, DF = dk.pack(d, d.m.plan)
    np.testing.assert_array_equal(a[1], DI)
    np.testing.assert_array_equal(a[2], DF)
    d.add_damper("C", 0.5)                                   # a new element
    b = d._packed()
    assert b is not a and b[1].size > a[1].size
    d.gravity = np.array([0.0, -1.0, 0.0])                   # gravity replaced
    c = d._packed()
    assert c is not b and c[2][1] == -1.0
    d.bodies[0].mass = 2.0                                   # a body changed in place
    e = d._packed()
    assert e is not c
    np.testing.assert_array_equal(e[2], dk.pack(d, d.m.plan)[1])
