"""The lane kernels (closure.lane_kernels) and the batched right-hand side that runs the
solver's Newton on blocks of members in them: bit for bit the one-member kernels."""
import numpy as np
import pytest

from closure import dynamics_kernels as dk
from closure import lane_kernels as lk
from closure import solve_kernels as sk
from closure.batch_dynamics import _Members
from closure.lstsq import FAST_COND, _expected_rank
from closure.solver import SolverOptions

from .models import n_fourbar_dynamics
from .test_dynamics import fourbar_model
from .test_dynamics_kernels import MODELS, crane_dynamics, rucc_dynamics

L = lk.LANES


def _non_grashof():
    """A four-bar whose crank toggles at a fold: members near it are near-singular."""
    return fourbar_model(dict(a=2.0, b=2.5, c=1.5, d=3.0), (1.0, 1.0, 1.0), 0.5)[1]


FOLD = np.arccos((4.0 + 9.0 - 16.0) / 12.0) - 0.5       # its crank angle at the fold (rad)

CASES = {
    "fourbar": (MODELS["fourbar"][0], (-0.8, 2.0)),
    "fourbar far from the origin": (MODELS["fourbar far from the origin"][0], (-0.8, 2.0)),
    "rucc": (rucc_dynamics, (-0.5, 0.5)),
    "crane": (crane_dynamics, ((-0.05, 0.17), (0.3, -0.05))),
    "non-Grashof near its fold": (_non_grashof, (0.6, FOLD - 1e-2)),
    "parallelogram through its flat pose": (lambda: n_fourbar_dynamics(2)[1], (-0.5, 0.5)),
}


def _inputs(name, B, rng):
    lo, hi = (np.atleast_1d(v) for v in CASES[name][1])
    X = lo + (hi - lo) * rng.uniform(size=(B, lo.size))
    if name.startswith("non-Grashof"):                   # up to 1e-9 rad from the fold
        X[-10:, 0] = FOLD - np.geomspace(1e-2, 1e-9, 10)
    if name.startswith("parallelogram"):                 # on and near the singular pose
        X[-6:, 0] = [0.0, 0.0, 1e-12, -1e-9, 1e-6, -1e-3]
    return X


def _stage(mem, y, per_member, members=None):
    """Task RHS for ``members`` (default all; ``y`` their states): one call of the batch's
    stage (blocks of lanes) or one call of simulate's step per member (the one-member
    stage).  Returns the batch's arrays after the call and the bad count."""
    B, n = mem.B, mem.n
    members = np.arange(B) if members is None else members
    bq, brot, bx, tan = mem.bq.copy(), mem.brot.copy(), mem.bx.copy(), mem.tangent.copy()
    buf, y = mem.buf.copy(), y.copy()
    if per_member:                                       # simulate's: one member a call
        blocks, nq = buf.reshape(B, -1), bq.shape[1]
        head = (dk.RHS, *mem._stage_head, np.zeros((0, nq)), np.zeros((0, 0, 3, 3)),
                np.zeros((0, 0, 4, 4)), np.zeros((0, 0, 6)), np.zeros(0), np.zeros(0),
                np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))
        bad = sum(dk.step(*head, bq[b], brot[b], bx[b], tan[b], y[a], blocks[b])
                  for a, b in enumerate(members))
    else:
        bad = dk.stage(*mem._stage_head, members.astype(np.int64), bq.reshape(-1),
                       brot.reshape(-1, 3, 3), bx.reshape(-1), tan.reshape(-1, n),
                       y.reshape(-1), buf, *mem._nokeep)
    return (bq, brot, bx, tan, buf, y), bad


@pytest.mark.parametrize("name", list(CASES))
def test_the_stage_in_lanes_is_the_one_member_stage_bit_for_bit(name):
    d = CASES[name][0]()
    rng = np.random.default_rng(11)
    B = 2 * L + 5                                        # two full blocks and a short one
    X = _inputs(name, B, rng)
    start = d.m.solve(X)
    assert start.ok.all()
    n = X.shape[1]
    XD = rng.normal(size=X.shape)
    mem = _Members(d, start, start.ok, XD, SolverOptions())
    # steps of the inputs from tiny (Newton converges at once) to large (backtracking,
    # members that do not converge or do not close, loop transforms past a quarter turn)
    size = np.geomspace(1e-9, 1.5, B)[rng.permutation(B)]
    y0 = np.c_[X + size[:, None] * rng.choice([-1, 1], (B, n)), XD, np.zeros((B, 2))]
    if name.startswith("non-Grashof"):                   # at the fold
        y0[-5:, 0] = FOLD + np.array([-1e-12, -1e-14, 0.0, 1e-14, 1e-12])
    if name.startswith("parallelogram"):                 # the Newton's truncated SVD
        y0[-6:, 0] = [0.0, 1e-15, 0.0, 0.0, -1e-6, 0.0]
    y0 = np.ascontiguousarray(y0)
    codes, its, conds = [], [], []
    for call in range(2):                                # the second from the first's bases
        lanes, bad_l = _stage(mem, y0, False)
        ones, bad_1 = _stage(mem, y0, True)
        assert bad_l == bad_1
        for a, b in zip(lanes, ones):
            assert np.array_equal(a, b, equal_nan=True)
        mem.bq, mem.brot, mem.bx, mem.tangent, mem.buf, _ = lanes
        blocks = mem.buf.reshape(B, -1)
        codes += blocks[:, mem.layout["code"]].tolist()
        its += blocks[:, mem.layout["fig"] + dk.FIG_ITS].tolist()
        conds += blocks[:, mem.layout["fig"] + dk.FIG_COND].tolist()
        y0 = np.ascontiguousarray(y0 + np.c_[0.01 * XD, np.zeros((B, n + 2))])
    # a subset of the members (every third: one short block of lanes, members apart):
    # theirs moved as above, the others' untouched
    sub = np.arange(0, B, 3)
    lanes, bad_l = _stage(mem, y0[sub], False, sub)
    ones, bad_1 = _stage(mem, y0[sub], True, sub)
    assert bad_l == bad_1
    for a, b in zip(lanes, ones):
        assert np.array_equal(a, b, equal_nan=True)
    rest = np.setdiff1d(np.arange(B), sub)
    assert np.array_equal(lanes[4].reshape(B, -1)[rest], mem.buf.reshape(B, -1)[rest],
                          equal_nan=True)
    assert not np.array_equal(lanes[4].reshape(B, -1)[sub], mem.buf.reshape(B, -1)[sub])
    # the calls took the lanes' paths: several iteration counts, failures among them
    if not name.startswith("parallelogram"):
        assert len(set(its)) >= 3
        assert max(its) >= 4
    if name.startswith("non-Grashof"):
        assert dk.SINGULAR in codes and dk.NOT_CLOSED in codes
    if name.startswith(("non-Grashof", "parallelogram")):
        assert np.nanmax(conds) > FAST_COND


@pytest.mark.parametrize("name", ["fourbar far from the origin", "rucc", "crane", "rssr"])
def test_lane_kernels_equal_the_one_member_kernels(name):
    make, X = MODELS[name]
    d = make()
    plan = d.m.plan
    PI, PF, PM = plan.packed
    rng = np.random.default_rng(5)
    X = np.repeat(X, 3, axis=0)[:L - 3]                # a short block
    pose = d.m.solve(X)
    LN = len(X)
    # coordinates near closure and far from it (loop rotations past a quarter turn)
    q = pose.q + np.where(np.arange(LN)[:, None] % 2, 2.0, 1e-3) * \
        rng.uniform(-1, 1, pose.q.shape)
    rot = np.array(pose.rot)
    nj, nl, nc, nv = PI[sk.H_NJ], PI[sk.H_NL], PI[sk.H_NC], PI[sk.H_NV]
    nq, ns = q.shape[1], rot.shape[1]
    ql, rotl, link, r, S = lk.lane_state(nq, ns, nj, nl, nc, nv)
    ql[:, :LN], rotl[..., :LN] = q.T, np.moveaxis(rot, 0, -1)
    A, fa = np.zeros((nj, 4, 4, L)), np.zeros((nj, 4, 4, L))
    lk.evaluate(PI, PF, PM, ql, rotl, link, r, S, A, fa, np.zeros((3, 4, 4, L)),
                np.zeros((1, 4, 4, L)), np.zeros((8, L)), np.zeros((3, 4, 4)), np.zeros((1, 6)),
                np.zeros(3), LN)
    ucols = plan._ucols
    m, nu = 6 * nc, ucols.size
    k, rank = min(m, nu), _expected_rank(d.m)
    J = np.zeros((m, nu, L))
    lk.jacobian(PI, PF, S, ucols, J, LN)
    Gl, Lc, Linv, Ginv = (np.zeros((k, k, L)) for _ in range(4))
    fast, inv0 = np.zeros(L), np.zeros(L)
    lk.factor(J, Gl, Lc, Linv, Ginv, fast, inv0, np.zeros((3, L)), LN)
    R = rng.normal(size=(m, L))
    Xl = np.zeros((nu, L))
    lk.solve(J, Ginv, R, Xl, np.zeros((k, L)), np.zeros((m, L)), np.zeros(L), LN)
    quarter = 0
    for b in range(LN):
        st = sk._member_state(nq, ns, nj, nl, nc, nv, 0)
        st[0][:], st[1][:] = q[b], rot[b]
        sk._evaluate(PI, PF, PM, st[0], st[1], st[2], st[3], st[4], st[5], st[6],
                     np.zeros((3, 4, 4)), np.zeros(3))
        assert np.array_equal(link[..., b], st[3])
        assert np.array_equal(r[..., b], st[5])
        assert np.array_equal(S[..., b], st[6])
        Jb = np.zeros((m, nu))
        sk._scaled_jacobian(PI, PF, st[6], ucols, Jb)
        assert np.array_equal(J[..., b], Jb)
        if rank < k:                                     # never factored in lanes
            continue
        W = sk._lsq_work(m, nu, 1)
        f1, inv1 = sk._factor(Jb, rank, W[0], W[1], W[2], W[3])
        assert f1 == (fast[b] == 1.0)
        if f1:
            assert inv1 == inv0[b] and np.array_equal(W[3], Ginv[..., b])
            Xb = np.zeros((nu, 1))
            sk._dn_solve(Jb, True, W[3], W[4], W[5], W[6], R[:, b:b + 1], Xb, 0, W[8], W[9])
            assert np.array_equal(Xb[:, 0], Xl[:, b])
        quarter += int(np.any(np.abs(r[:, 3:, b]).max(axis=1) > np.pi / 2))
    if rank == k:
        assert np.count_nonzero(fast[:LN]) >= LN // 3
    if name != "crane":
        assert quarter >= 1                              # the one-lane log was taken
