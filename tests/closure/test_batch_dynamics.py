"""Batched forward dynamics (closure.batch_dynamics.simulate_batch), issue #15."""
import numpy as np
import pytest

from closure import MechanismError
from closure.batch_dynamics import simulate_batch

from .test_dynamics import GEOM, MASSES, fourbar_model

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
