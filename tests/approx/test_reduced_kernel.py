"""The reduced model's compiled right-hand side (closure.reduced_kernels) against the
numpy evaluation it replaced, kept here as the reference: the transfers by their own
``all``, link poses and column twists by numpy products, the Newton–Euler sums, springs,
dampers and given forces, ``M⁻¹ (Q − h + τ)`` by numpy's solve.  Terms and right-hand
sides agree to 1e-12 on random states (inside the fitted ranges and a little beyond,
where the Chebyshev form switches to its series), trajectories to the integrator's
tolerance; surrogate kinds, the spatial joints (U, C reached backwards), transfers the
kernel does not evaluate, and the errors it reports."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

from approx import arm
from approx.multiloop import surrogate_dynamics
from closure import MechanismError
from closure import reduced_kernels as rk
from closure.frames import _cross, _inverse, skew
from tests.approx.newton_euler_reference import newton_euler
from closure.state import _SKEW_BASIS
from linkwright.examples import crane as cr

CRANE_RANGES = {"stroke1": (-0.05, 0.3), "stroke2": (-0.05, 0.17)}

#: ad(V) = Σ_m V_m _AD3[m]: the Lie bracket [V, ·] of twists (v, ω), as the previous
#: evaluation passed it to tests.approx.newton_euler_reference.newton_euler
_AD3 = np.zeros((6, 6, 6))
for _k in range(3):
    _E = _SKEW_BASIS.reshape(3, 3, 3)[_k]
    _AD3[3 + _k, :3, :3] = _AD3[3 + _k, 3:, 3:] = _E      # ω×
    _AD3[_k, :3, 3:] = _E                                 # v×
del _k, _E


class NumpyReference:
    """The previous numpy right-hand side of a ReducedDynamics ``red`` (its constants
    rebuilt from the mechanism and the model, its transfers evaluated by their ``all``
    or position/velocity/acceleration)."""

    def __init__(self, red):
        self.red = red
        dyn, mech = red.dynamics, red.m
        t = mech.tree
        self.n, self.nv = len(mech.inputs), t.nv
        self.inp = mech.input_columns()
        self.of_input = red._of_input
        self.maps = [(c, i, obj) for c, i, obj, _, _ in red._maps]
        tj = [mech.joints[t.parent_joint[li]] for li in t.order[1:]]
        self.tj = tj
        self.order = [(li, t.link_index[j.link_a if t.forward[li] else j.link_b], k)
                      for k, (li, j) in enumerate(zip(t.order[1:], tj))]
        self.fwd = [t.forward[li] for li in t.order[1:]]
        self.left = [j.frame_a if f else j.frame_b for j, f in zip(tj, self.fwd)]
        self.right = [j.frame_b_inv if f else j.frame_a_inv for j, f in zip(tj, self.fwd)]
        tc = np.nonzero(np.abs(t.path_sign).sum(0) > 0)[0]
        self.tc = tc
        xi, fa, carrier, deps, self.uprefix = [], [], [], [], []
        for j in mech.joints:
            for k, (prefix, x, dep) in enumerate(j.columns(np.zeros((1, max(j.nq, 1))))):
                c = t.v_offset[j.index] + k
                if c not in tc:
                    continue
                pos = int(np.nonzero(tc == c)[0][0])
                xi.append(x)
                fa.append(j.frame_a)
                carrier.append(t.link_index[j.link_a])
                deps.append([int(np.nonzero(tc == t.v_offset[j.index] + d)[0][0]) for d in dep])
                if prefix is not None:
                    self.uprefix.append((pos, j))
        self.xi = np.array(xi).reshape(-1, 6)
        self.fa = np.array(fa).reshape(-1, 4, 4)
        sw = np.einsum("cij,cj->ci", self.fa[:, :3, :3], self.xi[:, 3:])
        sv = np.einsum("cij,cj->ci", self.fa[:, :3, :3], self.xi[:, :3]) + \
            np.cross(self.fa[:, :3, 3], sw)
        self.sv, self.sw = sv[..., None], sw[..., None]
        self.carrier = np.array(carrier, dtype=int)
        self.dep_ptr = np.cumsum([0] + [len(d) for d in deps]).astype(np.int64)
        self.dep_idx = np.array([i for d in deps for i in d], dtype=np.int64)
        li = [mech.links.index(b.link) for b in dyn.bodies]
        self.bl = np.array(li, dtype=int)
        mass = np.array([b.mass for b in dyn.bodies])
        com = np.array([b.com for b in dyn.bodies]).reshape(-1, 3)
        Ib = np.array([b.inertia for b in dyn.bodies]).reshape(-1, 3, 3)
        Cx = np.array([skew(c) for c in com]).reshape(-1, 3, 3)
        m_ = mass[:, None, None]
        self.Lb = np.zeros((len(li), 6, 6))
        self.Lb[:, :3, :3] = m_ * np.eye(3)
        self.Lb[:, :3, 3:] = -m_ * Cx
        self.Lb[:, 3:, :3] = m_ * Cx
        self.Lb[:, 3:, 3:] = Ib - m_ * (Cx @ Cx)
        self.Pb = t.path_sign[li][:, tc]
        self.Pc = t.path_sign[self.carrier][:, tc]
        self.E = np.eye(self.n)[self.of_input[tc]]
        self.lin = [e for e in dyn.elements if e.kind in ("spring", "damper")]
        self.forces = [e for e in dyn.elements if e.kind == "force"]

    def coordinates(self, x):
        B = x.shape[0]
        out = np.zeros((3, B, self.nv))
        out[0][:, self.inp] = x
        out[1][:, self.inp] = 1.0
        for c, i, obj in self.maps:
            xi = float(x[0, i]) if B == 1 else x[:, i]
            r = obj.all(xi) if hasattr(obj, "all") else (
                obj.position(xi), obj.velocity(xi), obj.acceleration(xi))
            out[:, :, c] = np.reshape(r, (3, -1))
        return out

    def links(self, q):
        B = q.shape[0]
        t = self.red.m.tree
        rel = np.empty((B, len(self.tj), 4, 4))
        for k, j in enumerate(self.tj):
            o = t.q_offset[j.index]
            A = j.matrix(q[:, o:o + j.nq])
            if not self.fwd[k]:
                A = _inverse(A)
            rel[:, k] = self.left[k] @ A @ self.right[k]
        link = np.empty((B, len(t.links), 4, 4))
        link[:, 0] = np.eye(4)
        for li, parent, k in self.order:
            link[:, li] = link[:, parent] @ rel[:, k]
        return link

    def twists(self, link, q):
        Lc = link[:, self.carrier]
        R, p = Lc[..., :3, :3], Lc[..., :3, 3]
        S = np.empty(Lc.shape[:2] + (6,))
        S[..., 3:] = w = (R @ self.sw)[..., 0]
        S[..., :3] = (R @ self.sv)[..., 0] + _cross(p, w)
        t = self.red.m.tree
        for pos, j in self.uprefix:
            o = t.q_offset[j.index]
            F = Lc[:, pos] @ self.fa[pos] @ j.columns(q[:, o:o + j.nq])[1][0]
            w = F[:, :3, :3] @ self.xi[pos, 3:]
            S[:, pos, 3:] = w
            S[:, pos, :3] = F[:, :3, :3] @ self.xi[pos, :3] + _cross(F[:, :3, 3], w)
        return S

    def terms(self, x, xd, t=0.0):
        """M, h, Q (gravity, springs, dampers, given forces), q̇, dissipated and force
        power at inputs x, rates xd (B, n)."""
        B, n = x.shape
        q, d1, d2 = self.coordinates(x)
        xr = xd[:, self.of_input]
        qd = d1 * xr
        M, h, Q = np.zeros((B, n, n)), np.zeros((B, n)), np.zeros((B, n))
        if self.bl.size:
            link = self.links(q)
            S = self.twists(link, q)
            g6 = np.r_[self.red.dynamics.gravity, 0.0, 0.0, 0.0]
            newton_euler(S, qd, d1, d2 * xr * xr, self.tc, self.Pc, self.dep_ptr,
                         self.dep_idx, self.Pb, self.E, self.bl, link, self.Lb, g6, _AD3,
                         M, h, Q)
        diss, work = np.zeros(B), np.zeros(B)
        for e in self.lin:
            c, rate = e.column, qd[:, e.column]
            tau = -e.value * rate if e.kind == "damper" else -e.value * (q[:, e.qcolumn] - e.free)
            Q[:, self.of_input[c]] += d1[:, c] * tau
            if e.kind == "damper":
                diss += e.value * rate * rate
        for e in self.forces:
            rate = qd[:, e.column]
            tau = np.broadcast_to(np.asarray(e.value(t, q[:, e.qcolumn], rate), float), (B,))
            Q[:, self.of_input[e.column]] += d1[:, e.column] * tau
            work += tau * rate
        return M, h, Q, qd, diss, work

    def rhs(self, t, y, drive=None):
        """The integrator's derivative (ẋ, ẍ, dissipated power, drive and force power)."""
        n = self.n
        x, xd = y[:n], y[n:2 * n]
        M, h, Q, _, diss, work = self.terms(x[None], xd[None], t)
        F, dw = Q[0] - h[0], work[0]
        if drive is not None:
            tau = np.asarray(drive(t, x, xd), float).reshape(n)
            F, dw = F + tau, dw + float(tau @ xd)
        return np.r_[xd, np.linalg.solve(M[0], F), diss[0], dw]


def _kernel_rhs(red, t, y, drive=None):
    """The reduced model's right-hand side as ``simulate`` integrates it."""
    return red._rhs(drive)(t, np.asarray(y, float))


def _rucc_surrogate():
    """The spatial R–U–C–C loop of test_surrogate_dynamics (a Hooke joint in the tree, a
    cylindrical joint reached backwards, a spring, a damper and a given force) with
    Chebyshev surrogates of its loop."""
    from tests.approx.test_surrogate_dynamics import _rucc
    d = _rucc()
    return d, surrogate_dynamics(d, ranges={"A": (-0.5, 0.5)}, kind="chebyshev", size=10)


@pytest.fixture(scope="module")
def models():
    d = cr.dynamics()
    out = {f"crane {k}": (surrogate_dynamics(d, ranges=CRANE_RANGES, kind=k, size=8),
                          CRANE_RANGES) for k in ("linear", "spline", "chebyshev")}
    out["arm chebyshev"] = (surrogate_dynamics(arm.dynamics(), ranges=arm.RANGES,
                                               kind="chebyshev", size=6), arm.RANGES)
    out["rucc chebyshev"] = (_rucc_surrogate()[1], {"A": (-0.5, 0.5)})
    return out


def _states(red, ranges, B, seed):
    """B random inputs over the ranges and 5 % beyond each end, random rates."""
    rng = np.random.default_rng(seed)
    lo = np.array([ranges[k][0] for k in red._inputs])
    hi = np.array([ranges[k][1] for k in red._inputs])
    X = lo + (hi - lo) * rng.uniform(-0.05, 1.05, (B, lo.size))
    return X, rng.normal(size=X.shape)


@pytest.mark.parametrize("name", ["crane linear", "crane spline", "crane chebyshev",
                                  "arm chebyshev", "rucc chebyshev"])
def test_kernel_terms_and_rhs_equal_numpy(models, name):
    red, ranges = models[name]
    ref = NumpyReference(red)
    assert not red._pymaps                       # every transfer evaluated compiled
    X, XD = _states(red, ranges, 40, 11)
    M, h, Q, qd = red.terms(X, XD, t=0.2)
    M0, h0, Q0, qd0, _, _ = ref.terms(X, XD, t=0.2)
    for got, want in ((M, M0), (h, h0), (Q, Q0), (qd, qd0)):
        assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()
    e_ref = ref.coordinates(X)
    for got, want in zip(red._coordinates(X), e_ref):
        assert np.abs(got - want).max() <= 1e-12 * max(np.abs(want).max(), 1.0)
    # one compiled step per right-hand side: derivative and powers, with a drive (on the
    # model without ranges: the states reach 5 % beyond them)
    n = red._ni
    free = red.dynamics.reduced(red.transfers)
    for b in range(8):
        y = np.r_[X[b], XD[b], 0.0, 0.0]

        def drive(t, x, xd):
            return 0.3 * np.sin(t) * np.abs(M0[b]).max() * np.ones(n)

        got = _kernel_rhs(free, 0.7, y, drive)
        want = ref.rhs(0.7, y, drive)
        scale = np.abs(want[n:2 * n]).max()
        assert np.abs(got[:2 * n] - want[:2 * n]).max() <= 1e-12 * scale + 1e-15
        assert np.abs(got[2 * n:] - want[2 * n:]).max() <= 1e-12 * max(np.abs(want[2 * n:]).max(),
                                                                       1e-300)


def _every_joint_kind():
    """An open chain ground–R–a–H–b–P–c–U–d–C–e with the H, U and C joints declared
    from the child to the parent (reached backwards through the tree), driven by the
    R joint: every other coordinate a Chebyshev or spline function of the input (one
    Chebyshev form evaluated by its series alone, as for a degree in the hundreds)."""
    from approx import fit_chebyshev, fit_spline
    from closure import Dynamics, Mechanism, frame_from_points

    def fr(o, z, x):
        o = np.array(o, float)
        return frame_from_points(o, o + np.array(x, float), o + np.array(z, float))
    m = Mechanism(["a", "b", "c", "d", "e"])
    m.add_joint("R", "R", "ground", "a", at=fr((0, 0, 0), (0, 0, 1), (1, 0, 0)))
    m.add_joint("H", "H", "b", "a", at=fr((0.5, 0.1, 0), (1, 0.2, 0.1), (0, 1, 0)), pitch=0.05)
    m.add_joint("P", "P", "b", "c", at=fr((0.8, 0.3, 0.2), (0.1, 1, 0.3), (1, 0, 0)))
    m.add_joint("U", "U", "d", "c", at=fr((1.1, 0.2, 0.4), (0, 0.3, 1), (1, 0, 0)))
    m.add_joint("C", "C", "e", "d", at=fr((1.4, 0.5, 0.1), (1, 0, 0.4), (0, 1, 0)))
    m.add_input("R")
    d = Dynamics(m, gravity=(0.3, -9.81, 0.5))
    for k, link in enumerate("abcde"):
        d.add_body(link, 1.0 + k, (0.3 * k, 0.2, 0.1 * k), np.diag([0.02, 0.03, 0.04]) * (1 + k))
    d.add_spring("P", 30.0, free=0.05)
    d.add_damper("U", 0.4, index=1)
    funcs = [(np.sin, np.cos, lambda x: -np.sin(x)),
             (lambda x: 0.3 * x ** 2, lambda x: 0.6 * x, lambda x: 0.6 + 0 * x),
             (np.cos, lambda x: -np.sin(x), lambda x: -np.cos(x))]
    transfers = {}
    for k, lab in enumerate(c for c in m.coordinate_labels() if c != "R"):
        f = funcs[k % 3]
        s = (fit_chebyshev(*f, -1.0, 1.0, degree=7) if k % 2 else
             fit_spline(*f, -1.0, 1.0, n=5))
        s.extrapolate = True
        if k == 1:                  # a Chebyshev form without Taylor pieces: the series
            s._pcs = False
        transfers[lab] = ("R", s)
    return d.reduced(transfers)


def test_every_joint_kind_against_numpy():
    red = _every_joint_kind()
    assert sorted(j.kind for j in red.m.joints) == ["C", "H", "P", "R", "U"]
    assert not red._pymaps
    assert sum(v[1]._pieces() is False for v in red.transfers.values()) == 1
    ref = NumpyReference(red)
    rng = np.random.default_rng(4)
    X, XD = rng.uniform(-1.2, 1.2, (30, 1)), rng.normal(size=(30, 1))
    for got, want in zip(red.terms(X, XD), ref.terms(X, XD)[:4]):
        assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()
    link, want = red._evaluate(X, XD)[5], ref.links(ref.coordinates(X)[0])
    assert np.abs(link - want).max() <= 1e-13 * np.abs(want).max()
    y = np.r_[X[3], XD[3], 0.0, 0.0]
    got, want = _kernel_rhs(red, 0.0, y), ref.rhs(0.0, y)
    assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()


def test_transfers_outside_the_kernel(models):
    # transfers without kernel_form (bare position/velocity/acceleration objects) are
    # evaluated by their own methods, the rest by the kernel: the same terms
    red, ranges = models["crane spline"]

    class Bare:
        def __init__(self, s):
            self.s = s

        def position(self, x):
            return self.s.position(x)

        def velocity(self, x):
            return self.s.velocity(x)

        def acceleration(self, x):
            return self.s.acceleration(x)

    mixed = {k: (i, Bare(s) if k in ("O", "B2") else s) for k, (i, s) in red.transfers.items()}
    red2 = red.dynamics.reduced(mixed, ranges)
    assert sorted(m[4] for m in red2._pymaps) == ["B2", "O"]
    X, XD = _states(red, ranges, 20, 5)
    for got, want in zip(red2.terms(X, XD), red.terms(X, XD)):
        assert np.abs(got - want).max() <= 1e-13 * np.abs(want).max()
    y = np.r_[X[3], XD[3], 0.0, 0.0]
    assert np.abs(_kernel_rhs(red2, 0.1, y) - _kernel_rhs(red, 0.1, y)).max() <= \
        1e-12 * np.abs(_kernel_rhs(red, 0.1, y)).max()


@pytest.mark.parametrize("name", ["crane linear", "crane chebyshev", "rucc chebyshev"])
def test_trajectories_equal_numpy(models, name):
    # the compiled model's trajectory against scipy on the numpy right-hand side, at the
    # same tolerances: equal to the integrator's tolerance
    red, ranges = models[name]
    ref = NumpyReference(red)
    n = red._ni
    if name.startswith("crane"):
        t = np.linspace(0, 4.0, 41)
        F = red.dynamics.inverse(t, cr.lifting_motion)[[f"drive:{k}" for k in red._inputs]]
        spline = CubicSpline(t, F.to_numpy())

        def drive(tt, x, xd):
            return spline(tt)
        x0, xd0 = np.zeros(n), np.zeros(n)
    else:
        drive, x0, xd0 = None, np.zeros(n), np.full(n, 1.5)
    te = np.linspace(0, 0.3, 7)
    got = red.simulate((0, 0.3), x0, xd0, t_eval=te, drive=drive, rtol=1e-10, atol=1e-12)
    assert got.attrs["status"] == "completed"
    want = solve_ivp(lambda t, y: ref.rhs(t, y, drive), (0, 0.3), np.r_[x0, xd0, 0.0, 0.0],
                     method="DOP853", t_eval=te, rtol=1e-10, atol=1e-12)
    X = got[red._inputs].to_numpy()
    XD = got[[f"rate:{k}" for k in red._inputs]].to_numpy()
    scale = max(np.abs(want.y[:n]).max(), 1e-3)
    assert np.abs(X - want.y[:n].T).max() <= 1e-8 * scale
    assert np.abs(XD - want.y[n:2 * n].T).max() <= 1e-8 * max(np.abs(want.y[n:2 * n]).max(), 1.0)
    for col, row in (("dissipated", 2 * n), ("work", 2 * n + 1)):
        assert np.abs(got[col].to_numpy() - want.y[row]).max() <= \
            1e-8 * np.abs(want.y[row]).max() + 1e-10          # J (atol 1e-12 a step)


def test_kernel_reports_name_the_culprit(models):
    red, ranges = models["crane chebyshev"]
    d = red.dynamics
    # a surrogate that refuses x beyond its range: the error names it, as before
    s = red.transfers["B1"][1]
    strict = surrogate_dynamics(d, ranges=CRANE_RANGES, kind="spline", size=2)
    tr = dict(strict.transfers)
    tr["B1"][1].extrapolate = False
    red2 = d.reduced(tr)
    with pytest.raises(MechanismError, match=r"transfers\['B1'\]: cannot be evaluated at "
                                             r"stroke1 = 0\.4"):
        red2.terms([0.4, 0.0], [0.0, 0.0])
    with pytest.raises(MechanismError, match=r"transfers\['B1'\]: cannot be evaluated"):
        red2.simulate((0, 1), [0.29, 0.0], [5.0, 0.0])
    assert s.extrapolate                       # the model's own surrogates extrapolate
    # a drive that returns NaN, and a coordinate whose mass vanishes
    with pytest.raises(MechanismError, match="simulate: non-finite generalised force"):
        red.simulate((0, 1), [0.0, 0.0], [0.0, 0.0], drive=lambda t, x, xd: [np.nan, 0.0])
    # stroke 1's loop frozen (constant transfers; its slide is a loop-closing joint, so
    # it moves no link itself): stroke 1 moves no mass, M is singular
    from approx.multiloop import ConstantTransfer
    flat = dict(red.transfers)
    for k in ("O", "G1", "B1"):
        flat[k] = ("stroke1", ConstantTransfer(0.0))
    with pytest.raises(MechanismError, match="simulate: the reduced mass matrix is singular"):
        d.reduced(flat).simulate((0, 1), [0.0, 0.0], [0.0, 0.0])


def test_pack_transfer_forms():
    # the kernel's form of each transfer kind: pieces, a series beyond them, a constant
    from approx.multiloop import ConstantTransfer
    from approx import fit_chebyshev
    ch = fit_chebyshev(np.sin, np.cos, lambda x: -np.sin(x), 0.0, 1.0, degree=6)
    counts, scal, arrays = rk.pack_transfer(ch.kernel_form())
    assert counts[2] == 9 and scal[2:4].tolist() == [0.0, 1.0]
    counts, scal, arrays = rk.pack_transfer(ConstantTransfer(2.5).kernel_form())
    assert counts == (1, 1, 0) and arrays[2].tolist() == [2.5]
    with pytest.raises(ValueError, match="neither pieces nor a series"):
        rk.pack_transfer({"accept": (0.0, 1.0)})
