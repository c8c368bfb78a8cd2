"""Benchmarks: time per evaluation beside error against a reference, and the ratio against
the method a user would otherwise use.

    python -m linkwright.bench [closure ...] [--quick]
"""
from __future__ import annotations

import argparse
import sys
import time
from typing import Callable, Iterator

import numpy as np


def _timeit(fn, repeat=3):
    best = np.inf
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def first_call(code: str) -> tuple[float, float]:
    """Seconds of the first run of ``code`` (Python source that sets ``t``, the seconds of
    its own first call of a compiled kernel) in a fresh interpreter with an empty numba
    cache, then again in another with that cache: ``(compile, cache load)``."""
    import os
    import subprocess
    import tempfile
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        return tuple(float(subprocess.run([sys.executable, "-c", code + "\nprint(t)"], env=env,
                                          capture_output=True, text=True, check=True)
                           .stdout.split()[-1]) for _ in range(2))


def _rssr_closed_newton(phi, psi, iters=50):
    """Vectorised Newton on the RSSR's one-unknown loop equation
    K(φ) cos ψ + L(φ) sin ψ = M(φ) (|B − A| = b, B on the rocker's circle), from ``psi``;
    returns ψ and the iterations taken."""
    from linkwright.references import RSSR, rssr_frame

    a, b, c, P0 = RSSR["a"], RSSR["b"], RSSR["c"], RSSR["P0"]
    _, e1, e2 = rssr_frame()
    Dx, Dy, Dz = P0[0] - a * np.cos(phi), P0[1] - a * np.sin(phi), P0[2] + 0 * phi
    K = 2 * c * (Dx * e1[0] + Dy * e1[1] + Dz * e1[2])
    L = 2 * c * (Dx * e2[0] + Dy * e2[1] + Dz * e2[2])
    M = b * b - c * c - (Dx * Dx + Dy * Dy + Dz * Dz)
    psi = np.array(psi, dtype=float)
    for k in range(1, iters + 1):
        cs, sn = np.cos(psi), np.sin(psi)
        step = (K * cs + L * sn - M) / (L * cs - K * sn)
        psi -= step
        if np.max(np.abs(step)) <= 1e-14 * (1 + np.max(np.abs(psi))):
            break
    return psi, k


def bench_closure(quick: bool = False) -> list[str]:
    """RSSR over many crank angles: the batched engine against the baselines a competent
    user would write (scipy ``least_squares`` per position, trf with finite differences
    and lm with the engine's analytic Jacobian; a vectorised Newton on the RSSR's own
    closed-form one-unknown equation), all from the same guesses; plus one-pose and
    one-sweep-step latencies and the engine's peak memory per position."""
    import tracemalloc

    from scipy.optimize import least_squares

    from closure import Pose
    from closure.solver import _apply
    from linkwright.references import rssr, rssr_output

    n = 2000 if quick else 10_000
    n_trf = 30 if quick else 200
    n_lm = 30 if quick else 200
    n_one = 10 if quick else 40
    phi0, branch = 0.2, 1
    m, psi0 = rssr(phi0, branch)
    x = np.linspace(-np.pi, np.pi, n, endpoint=False) - phi0
    # guesses: the nearest pose of a coarse continuation sweep (as a user would do)
    coarse_x = np.linspace(x.min(), x.max(), 64)
    upper = m.sweep(np.r_[0.0, coarse_x[coarse_x > 0]], return_pose=True)[1]
    lower = m.sweep(np.r_[0.0, coarse_x[coarse_x < 0][::-1]], return_pose=True)[1]
    cx = np.r_[upper.inputs[:, 0], lower.inputs[:, 0]]
    cq = np.r_[upper.q, lower.q]
    crot = np.r_[upper.rot, lower.rot]
    near = np.abs(x[:, None] - cx[None]).argmin(1)
    guess = Pose(m, cx[near, None], cq[near], crot[near], *(np.zeros(n),) * 3,
                 np.zeros(n, int))
    ref = rssr_output(phi0 + x, branch)
    col = m.tree.q_offset[m.joint("out").index]

    def err(psi, idx=slice(None)):
        return np.abs((psi - ref[idx] + np.pi) % (2 * np.pi) - np.pi).max()

    rows = []                       # (method, positions timed, s per position, error)
    t_batch, pose = _timeit(lambda: m.solve(x, guess=guess))
    rows.append(("batched engine (`Mechanism.solve`, continuation from the guesses)", n,
                 t_batch / n, err(psi0 + pose["out"])))
    tracemalloc.start()
    m.solve(x, guess=guess)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()

    # per position: scipy least_squares on the same (dimensionless) loop residual
    unknown = m.unknown_columns()

    def problem(i):
        g = (guess.q[i:i + 1].copy(), guess.rot[i:i + 1].copy())
        g[0][:, m.input_q_columns()] = x[i]

        def state(u):
            dv = np.zeros((1, m.tree.nv))
            dv[0, unknown] = u
            return _apply(m, g, dv)

        def f(u):
            return m._scaled_residual(m.kinematic_state(state(u), twists=False))[0]

        def jac(u):                      # the engine's twists: J of the scaled loop residual
            return m._scaled_jacobian(m.kinematic_state(state(u)))[0][:, unknown]

        return state, f, jac

    def pinned(f, jac):
        """lm needs as many residuals as unknowns: pin the rod's idle spin (the null
        vector of the Jacobian at the guess) with one more residual."""
        J0 = jac(np.zeros(unknown.size))
        v = np.linalg.svd(J0)[2][-1]
        return (lambda u: np.r_[f(u), v @ u]), (lambda u: np.vstack([jac(u), v]))

    def per_position(idx, method):
        out, nfev = [], 0
        for i in idx:
            state, f, jac = problem(i)
            kw = {}
            if method == "lm":
                f, jac = pinned(f, jac)
                kw = dict(jac=jac)
            r = least_squares(f, np.zeros(unknown.size), xtol=1e-12, ftol=1e-12, gtol=1e-12,
                              method=method, **kw)
            nfev += r.nfev
            out.append(state(r.x)[0][0, col])
        return np.array(out), nfev / len(idx)

    for method, k, label in (("trf", n_trf, "scipy `least_squares` trf, finite differences"),
                             ("lm", n_lm, "scipy `least_squares` lm, analytic Jacobian "
                                          "(engine twists), rod spin pinned")):
        idx = np.linspace(0, n - 1, k).astype(int)
        t0 = time.perf_counter()
        q_out, nfev = per_position(idx, method)
        t = (time.perf_counter() - t0) / k
        rows.append((f"{label}, per position (timed on {k}; {nfev:.1f} residual calls each)",
                     k, t, err(psi0 + q_out, idx)))

    # vectorised Newton on the closed-form one-unknown equation, from the same guesses
    psi_g = psi0 + guess.q[:, col]
    t_cf, (psi_cf, its_cf) = _timeit(lambda: _rssr_closed_newton(phi0 + x, psi_g), repeat=5)
    rows.append((f"vectorised Newton on the closed-form RSSR equation ({its_cf} iterations)",
                 n, t_cf / n, err(psi_cf)))

    # latencies: one pose (solve from its nearest coarse pose), one sweep step, one
    # closed-form Newton on one pose
    from closure.solver import _take_pose

    sel = np.linspace(0, n - 1, n_one).astype(int)
    g1 = [_take_pose(guess, [i]) for i in sel]
    m.solve(x[sel[0]], guess=g1[0])
    t_one, _ = _timeit(lambda: [m.solve(x[i], guess=g) for i, g in zip(sel, g1)])
    t_one /= sel.size
    xs = np.linspace(0.0, 0.4 if quick else 2.0, 21 if quick else 101)     # 0.02 rad apart
    t_sweep, _ = _timeit(lambda: m.sweep(xs))
    t_sweep /= xs.size - 1
    t_cf1, _ = _timeit(lambda: [_rssr_closed_newton(phi0 + x[i], psi_g[i]) for i in sel])
    t_cf1 /= sel.size

    us = 1e6
    out = [
        "## closure: RSSR positions, every method from the same guesses",
        "",
        "| method | positions | µs / position | positions / s | max error vs closed form "
        "(rad) | time ratio to the engine batch |",
        "|---|---|---|---|---|---|",
    ]
    for label, k, t, e in rows:
        out.append(f"| {label} | {k} | {t * us:.2f} | {1 / t:,.0f} | {e:.2e} | "
                   f"{t / rows[0][2]:.3g}× |")
    out += [
        "",
        "| latency | µs |",
        "|---|---|",
        f"| engine, one pose (`solve` of one input from its nearest coarse pose) | "
        f"{t_one * us:.0f} |",
        f"| engine, one sweep step (`sweep` over {xs.size} inputs {xs[1] - xs[0]:.2g} rad "
        f"apart, per step) | {t_sweep * us:.0f} |",
        f"| closed-form Newton, one pose | {t_cf1 * us:.1f} |",
        "",
        f"engine batch: {t_batch / n * us:.2f} µs per position, peak memory "
        f"{peak / n:,.0f} B per position (tracemalloc); largest residual "
        f"{pose.residual.max():.1e}, largest condition {pose.condition.max():.1f}, iterations ≤ "
        f"{pose.iterations.max()}.  Speed: **{rows[1][2] / rows[0][2]:.0f}×** the trf loop, "
        f"**{rows[2][2] / rows[0][2]:.0f}×** the lm loop; the closed-form vectorised Newton is "
        f"**{rows[0][2] / rows[3][2]:.0f}×** faster than the engine.",
        "",
    ]
    return out


def bench_stiffness(quick: bool = False) -> list[str]:
    """Vectorised hexapod K over many poses vs a Python loop over formula (2)."""
    from closure import exp_so3
    from stiffness import Hexapod

    n = 20_000 if quick else 200_000
    n_loop = 2_000
    rng = np.random.default_rng(0)
    a = np.radians([0, 100, 120, 220, 240, 340])
    b = np.radians([40, 80, 160, 200, 280, 320])
    hx = Hexapod(np.c_[0.8 * np.cos(a), 0.8 * np.sin(a), np.zeros(6)],
                 np.c_[0.4 * np.cos(b), 0.4 * np.sin(b), np.zeros(6)],
                 rng.uniform(5e6, 2e7, 6))
    T = np.zeros((n, 4, 4))
    T[:, :3, :3] = exp_so3(rng.normal(scale=0.15, size=(n, 3)))
    T[:, :3, 3] = rng.normal(scale=0.05, size=(n, 3)) + [0, 0, 0.7]
    T[:, 3, 3] = 1
    t_vec, (K, _) = _timeit(lambda: hx.stiffness_batch(T, cond=False))
    t_cond, _ = _timeit(lambda: hx.stiffness_batch(T, cond=True), repeat=1)

    def loop(Ts):
        out = []
        for Ti in Ts:                                   # formula (2), element by element
            Kl = np.zeros((6, 6))
            for i in range(6):
                P = Ti[:3, :3] @ hx.platform[i] + Ti[:3, 3]
                u = (P - hx.base[i]) / np.linalg.norm(P - hx.base[i])
                Rv = np.r_[u, np.cross(P, u)]
                for j in range(6):
                    for l in range(6):
                        Kl[j, l] += hx.k[i] * Rv[j] * Rv[l]
            out.append(Kl)
        return np.array(out)

    t0 = time.perf_counter()
    Kl = loop(T[:n_loop])
    t_loop = (time.perf_counter() - t0) / n_loop * n
    diff = np.abs(Kl - K[:n_loop]).max() / np.abs(Kl).max()
    return [
        "## stiffness: hexapod K over many poses",
        "",
        "| method | poses | time (s) | poses / s |",
        "|---|---|---|---|",
        f"| vectorised `Hexapod.stiffness_batch` (K) | {n} | {t_vec:.3f} | {n / t_vec:,.0f} |",
        f"| vectorised, K and cond(P) by batched SVD | {n} | {t_cond:.3f} | {n / t_cond:,.0f} |",
        f"| Python loop over formula (2) (timed on {n_loop}, scaled) | {n} | {t_loop:.1f} | "
        f"{n / t_loop:,.0f} |",
        "",
        f"speed ratio: **{t_loop / t_vec:.0f}×**; largest relative difference {diff:.1e}",
        "",
    ]


def bench_approx(quick: bool = False) -> list[str]:
    """Seed 004's oscillating cylinder: speed against error of every surrogate kind and size
    (the seed's broken line, the cubic spline on the same data, one Chebyshev form), against
    the closed form and the closure engine."""
    from approx import (EngineAnalogs, cylinder as cy, fit, fit_chebyshev, fit_least_squares,
                        fit_spline)

    F = (cy.f3, cy.psi31, cy.dpsi31)
    t = np.linspace(0, cy.TAU, 2001)
    q, qd, qdd = cy.drive_law(t)
    I3 = cy.M3 * cy.B3 ** 2
    exact = cy.psi31(q) * I3 * (cy.psi31(q) * qdd + cy.dpsi31(q) * qd ** 2)
    rms_ex = np.sqrt(np.mean(exact ** 2))
    engine = EngineAnalogs(cy.mechanism(), "A", 0.0, 0.3, offset=cy.f3(0.0), sign=-1.0)
    x = np.linspace(0, 0.3, 20_000 if quick else 200_000)
    xs = x[::max(1, x.size // 200)].tolist()          # scalar calls
    closed = lambda v: (cy.f3(v), cy.psi31(v), cy.dpsi31(v))
    t_closed, _ = _timeit(lambda: closed(x))
    t_closed /= x.size
    t0 = time.perf_counter()
    for v in xs:
        closed(v)
    s_closed = (time.perf_counter() - t0) / len(xs)
    xe = x[:2000]
    t_engine, _ = _timeit(lambda: engine.all(xe), repeat=1)
    t_engine /= xe.size
    t0 = time.perf_counter()
    for v in xs[:20]:
        engine.all(np.array([v]))
    s_engine = (time.perf_counter() - t0) / 20
    rows = ["## approx: oscillating cylinder (seed 004), q1 in [0, 0.3] m, drive law τ = 5 s",
            "",
            "Speed against error of the surrogate family (F, F′, F″ evaluated together; "
            "'scalar' is one call per point with a Python float).",
            "",
            "| kind | size | coefficients | fit (s) | batch s/point | scalar s/call | "
            "max abs(F−f) (rad) | bound abs(F−f) (rad) | RMS err Q1 | closed/surrogate batch | "
            "closed/surrogate scalar | engine/surrogate batch | engine/surrogate scalar |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    makers = [("linear (seed)", n, lambda n=n: fit(*F, 0.0, 0.3, n=n)) for n in (4, 8, 16, 32)]
    makers += [("spline", n, lambda n=n: fit_spline(*F, 0.0, 0.3, n=n)) for n in (4, 8, 16, 32)]
    makers += [("chebyshev", m, lambda m=m: fit_chebyshev(*F, 0.0, 0.3, degree=m))
               for m in (4, 8, 12, 16, 24)]
    makers += [("least squares (knots of linear n=4)", 4,
                lambda: fit_least_squares(*F, fit(*F, 0.0, 0.3, n=4).knots))]
    from approx.surrogate import _n_coef
    t_compile, t_load = first_call(
        "import time, numpy as np\nfrom approx.kernels import Pieces\n"
        "p = Pieces([0.0], [[1.0, 2.0]], inner=[])\nt0 = time.perf_counter()\n"
        "p(np.zeros(2)); p.scalar(0.5)\nt = time.perf_counter() - t0")
    for kind, size, make in makers:
        make().all(x[:10]), make().all(0.1)      # kernels loaded before timing
        t_fit, an = _timeit(make)
        e = an.errors(*F)
        Q = an.force(q, qd, qdd, I3)
        rms = np.sqrt(np.mean((Q - exact) ** 2)) / rms_ex
        t_b, _ = _timeit(lambda: an.all(x))
        t_b /= x.size
        t0 = time.perf_counter()
        for v in xs:
            an.all(v)
        t_s = (time.perf_counter() - t0) / len(xs)
        rows.append(f"| {kind} | {size} | {_n_coef(an)} | {t_fit:.1e} | {t_b:.1e} | {t_s:.1e} | "
                    f"{e['max_abs_F']:.2e} | {an.error['bound_F']:.2e} | {100 * rms:.2g} % | "
                    f"{t_closed / t_b:.2f}× | {s_closed / t_s:.1f}× | {t_engine / t_b:.0f}× | "
                    f"{s_engine / t_s:.0f}× |")
    rows += ["", f"closed form: {t_closed:.1e} s per point (batch), {s_closed:.1e} s per scalar "
             f"call; closure engine: {t_engine:.1e} s per point (timed on {xe.size} points), "
             f"{s_engine:.1e} s per scalar call.  γ from the seed's rule 1/(max f″ − min f″); "
             "size = intervals (linear, spline) or degree of the f″ interpolant (chebyshev); "
             "bound = ∫(b − s)·abs(F″ − f″) ds, the surrogate's own error estimate.  "
             "Every kind evaluates through one compiled kernel (numba): its first call "
             f"in a new installation compiles it ({t_compile:.2f} s), later processes load "
             f"it from numba's cache ({1e3 * t_load:.0f} ms).", ""]
    return rows


def _scipy_floor(rtol: float) -> float:
    """CPU seconds per right-hand-side call of scipy's DOP853 itself: a trivial right-hand
    side (a harmonic oscillator with the engine's four states: x, ẋ and the two energy
    integrals) stepped as ``closure.integrate.integrate`` steps (``step`` and the dense
    output of every step) at ``rtol`` (atol ``rtol`` · 1e-2), over enough steps to time."""
    from scipy.integrate import DOP853

    def f(t, y):
        return np.array([y[1], -y[0], 0.0, 0.0])

    t0 = time.process_time()
    solver = DOP853(f, 0.0, np.array([1.0, 0.0, 0.0, 0.0]), 40.0, rtol=rtol, atol=rtol * 1e-2)
    while solver.status == "running":
        solver.step()
        solver.dense_output()
    return (time.process_time() - t0) / solver.nfev


def bench_dynamics(quick: bool = False) -> list[str]:
    """Forward dynamics: CPU time per simulated second of the engine and of a hand-written
    closed-form four-bar model (Freudenstein kinematics, the accuracy reference) in
    alternating runs of one process, scipy's own cost per right-hand side as the floor,
    energy drift and error; the two-loop crane."""
    from scipy.integrate import solve_ivp

    from closure import Dynamics
    from linkwright.references import fourbar, fourbar_rod_reference

    geom, masses, t20 = dict(a=1.0, b=3.0, c=2.5, d=3.2), (1.0, 3.0, 2.5), 0.3
    m, (t30, t40) = fourbar(**geom, t2_0=t20)
    d = Dynamics(m, gravity=(0, -9.81, 0))

    def rod(mass, L, u):
        u = np.asarray(u, float)
        return mass * L * L / 12 * (np.eye(3) - np.outer(u, u))

    e = lambda t: np.array([np.cos(t), np.sin(t), 0.0])
    d.add_body("crank", masses[0], geom["a"] / 2 * e(t20), rod(masses[0], geom["a"], e(t20)))
    d.add_body("coupler", masses[1], geom["a"] * e(t20) + geom["b"] / 2 * e(t30),
               rod(masses[1], geom["b"], e(t30)))
    d.add_body("rocker", masses[2], np.array([geom["d"], 0, 0]) + geom["c"] / 2 * e(t40),
               rod(masses[2], geom["c"], e(t40)))
    span = 1.0 if quick else 3.0
    reps = 3 if quick else 5
    t = np.linspace(0, span, 31)
    acc = fourbar_rod_reference(geom, masses, t20)

    def ref_rhs(tt, y):
        return [y[1], acc(y[0], y[1])]

    def cpu(fn):
        t0 = time.process_time()
        out = fn()
        return time.process_time() - t0, out

    rows = ["## dynamics: forward simulation (DOP853)", "",
            "| model | rtol | simulated (s) | CPU s per simulated s | × closed form | RHS calls | "
            "µs per RHS call | max abs energy drift (J) | max abs error vs reference (rad) |",
            "|---|---|---|---|---|---|---|---|---|"]
    strict = solve_ivp(ref_rhs, (0, span), [t20, 0.0], t_eval=t, rtol=1e-13, atol=1e-14,
                       method="DOP853")
    for rtol in (1e-8, 1e-11):
        def engine():
            return d.simulate((0, span), [0.0], [0.0], t_eval=t, rtol=rtol, atol=rtol * 1e-2)

        def closed():
            return solve_ivp(ref_rhs, (0, span), [t20, 0.0], t_eval=t, rtol=rtol,
                             atol=rtol * 1e-2, method="DOP853")
        engine(), closed(), _scipy_floor(rtol)            # warm: compiled kernels, caches
        c_eng, c_ref, c_floor = [], [], []
        for _ in range(reps):                             # alternating A/B runs
            c, df = cpu(engine)
            c_eng.append(c)
            c, ref = cpu(closed)
            c_ref.append(c)
            c_floor.append(_scipy_floor(rtol))
        c_e, c_r, f = np.median(c_eng), np.median(c_ref), np.median(c_floor)
        nfev = df.attrs["ivp"].nfev
        err = np.abs(t20 + df.A - strict.y[0]).max()
        err_ref = np.abs(ref.y[0] - strict.y[0]).max()
        rows.append(f"| four-bar, engine | {rtol:.0e} | {span} | {c_e / span:.3f} | "
                    f"{c_e / c_r:.2f} | {nfev} | {1e6 * c_e / nfev:.0f} | "
                    f"{np.abs(df.balance).max():.1e} | {err:.1e} |")
        rows.append(f"| four-bar, closed-form model | {rtol:.0e} | {span} | {c_r / span:.3f} | "
                    f"1 | {ref.nfev} | {1e6 * c_r / ref.nfev:.0f} | – | {err_ref:.1e} |")
        rows.append(f"| scipy's floor (trivial RHS, the engine's calls) | {rtol:.0e} | {span} | "
                    f"{f * nfev / span:.4f} | {f * nfev / c_r:.2f} | {nfev} | {1e6 * f:.1f} | "
                    f"– | – |")
    from linkwright.examples import crane as cr

    dc = cr.dynamics()
    hold = dc.inverse(np.array([0.0]), cr.lifting_motion)[["drive:stroke1", "drive:stroke2"]] \
        .to_numpy()[0]
    span_c = 0.5 if quick else 1.0

    def crane():
        return dc.simulate((0, span_c), [0, 0], [0, 0], t_eval=np.linspace(0, span_c, 11),
                           drive=lambda tt, x, xd: 0.9 * hold, rtol=1e-9, atol=1e-11)
    crane()
    runs = [cpu(crane) for _ in range(reps)]
    c_c, fc = float(np.median([r[0] for r in runs])), runs[-1][1]
    nfev = fc.attrs["ivp"].nfev
    rows.append(f"| crane (2 loops, 2 DOF, dampers, drives) | 1e-09 | {span_c} | "
                f"{c_c / span_c:.3f} | – | {nfev} | {1e6 * c_c / nfev:.0f} | balance "
                f"{np.abs(fc.balance).max():.1e} | – |")
    rows += ["", f"CPU time (process time), median of {reps} alternating runs in one process; "
             "× closed form: the engine's CPU time over that of the hand-written closed-form "
             "model integrated by the same scipy method (a Python right-hand side). scipy's "
             "floor: DOP853's own CPU time per right-hand-side call (a trivial right-hand "
             "side, stepped with the dense output of every step as the engine's integrator "
             "does) times the engine's calls. energy drift: max abs(E + dissipated − work − "
             "E0); the reference error is against the closed-form model integrated at rtol "
             "1e-13. MuJoCo and Exudyn are not installed here: no row for them.", ""]
    return rows


def bench_batch_dynamics(quick: bool = False) -> list[str]:
    """Batched forward dynamics (``Dynamics.simulate_batch``, issue #15): CPU time per
    trajectory at B = 1, 10, 100, 1,000 members against one ``Dynamics.simulate`` of the
    same model and tolerances (alternating runs, median), and the members' agreement with
    their own single simulations (inputs and energies)."""
    from closure import Dynamics

    from linkwright.references import fourbar

    geom, masses, t20 = dict(a=1.0, b=3.0, c=2.5, d=3.2), (1.0, 3.0, 2.5), 0.3
    m, (t30, t40) = fourbar(**geom, t2_0=t20)
    d = Dynamics(m, gravity=(0, -9.81, 0))
    e = lambda t: np.array([np.cos(t), np.sin(t), 0.0])              # noqa: E731

    def rod(mass, L, u):
        return mass * L * L / 12 * (np.eye(3) - np.outer(u, u))
    d.add_body("crank", masses[0], geom["a"] / 2 * e(t20), rod(masses[0], geom["a"], e(t20)))
    d.add_body("coupler", masses[1], geom["a"] * e(t20) + geom["b"] / 2 * e(t30),
               rod(masses[1], geom["b"], e(t30)))
    d.add_body("rocker", masses[2], np.array([geom["d"], 0, 0]) + geom["c"] / 2 * e(t40),
               rod(masses[2], geom["c"], e(t40)))
    rtol, atol, span = 1e-8, 1e-10, 1.0
    t_eval = np.linspace(0, span, 11)
    sizes = (1, 10, 100) if quick else (1, 10, 100, 1000)
    reps = 3 if quick else 5
    rng = np.random.default_rng(15)
    x0 = rng.uniform(-0.5, 0.5, (max(sizes), 1))
    xd0 = rng.uniform(-1.0, 1.0, (max(sizes), 1))

    def cpu(fn):
        t0 = time.process_time()
        out = fn()
        return time.process_time() - t0, out

    def single(b):
        return d.simulate((0, span), x0[b], xd0[b], t_eval=t_eval, rtol=rtol, atol=atol)

    def batch(B):
        return d.simulate_batch((0, span), x0[:B], xd0[:B], t_eval=t_eval, rtol=rtol,
                                atol=atol)
    single(0), batch(2)                                   # warm: compiled kernels, caches
    c_single, call_single, c_batch, res = [], [], {B: [] for B in sizes}, {}
    for r in range(reps):                                 # alternating runs
        for B in sizes:
            c, res[B] = cpu(lambda: batch(B))
            c_batch[B].append(c / B)
            c, df = cpu(lambda: single(r % 5))
            c_single.append(c)
            call_single.append(c / df.attrs["ivp"].nfev)
    s, s_call = float(np.median(c_single)), float(np.median(call_single))
    # accuracy: members against their own single simulations
    big = res[max(sizes)]
    dx = de = 0.0
    for b in range(5):
        df = single(b)
        dx = max(dx, np.abs(df.A.values - big.x[b, 0]).max())
        de = max(de, np.abs(df.energy.values - big.energy[b]).max())
    rows = ["## dynamics: batched trajectories (`Dynamics.simulate_batch`, DOP853)", "",
            "| members B | ms per trajectory | × one `simulate` | RHS calls per member | "
            "µs per member-evaluation | × one `simulate`'s per RHS call |",
            "|---|---|---|---|---|---|"]
    for B in sizes:
        c = float(np.median(c_batch[B]))
        nfev = float(res[B].nfev.mean())
        rows.append(f"| {B:,} | {1e3 * c:.2f} | {100 * c / s:.1f} % | {nfev:.0f} | "
                    f"{1e6 * c / nfev:.2f} | {100 * c / nfev / s_call:.1f} % |")
    rows += ["", f"Four-bar of uniform rods under gravity, rtol {rtol:.0e}, atol {atol:.0e}, "
             f"{span:g} s, {t_eval.size} output times with energies; random initial angles "
             "(±0.5 rad) and rates (±1 rad/s).  One `Dynamics.simulate` of a member: "
             f"{1e3 * s:.2f} ms (CPU time, median of {reps} runs alternating with the "
             f"batches), {1e6 * s_call:.1f} µs per right-hand-side call: it does more "
             "per trajectory than a member of the batch (DOP853's dense output at every "
             "step, three more right-hand sides a step, and a pose solved at every step; "
             "the batch forms dense output only for steps holding output times), so the "
             "last column compares the cost per call.  Members against their own "
             f"`simulate` (5 members of the largest "
             f"batch): max abs input difference {dx:.1e} rad, energy {de:.1e} J.", ""]
    return rows


def bench_synthesis(quick: bool = False) -> list[str]:
    """RRR enumeration of seed 001's example, and the RR link by algebra vs multi-start
    scipy least squares on the RR equations."""
    from scipy.optimize import least_squares

    from closure.frames import exp_so3, log_so3
    from synthesis import Screw, enumerate_dyads, rr_links
    from synthesis.screw import Line

    S = [Screw.from_degrees([0, 0, 1], [0, 0, 0], 30, 0.7),
         Screw.from_degrees([0.34202, 0, 0.939693], [0, 1.1, 0], 65, 0.5),
         Screw.from_degrees([0.66, 0.043589, 0.75], [0.25, 1.2, -0.289742], 75, 0.3)]
    enumerate_dyads("RRR", S)
    t_enum, df = _timeit(lambda: enumerate_dyads("RRR", S), repeat=5)
    t_rr, links = _timeit(lambda: rr_links(S[0], S[1]), repeat=5)
    T2, T3 = S[0].matrix(), S[1].matrix()

    def rot(g, G, a):
        R = exp_so3(g / np.linalg.norm(g) * a)
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, G - R @ G
        return T

    def resid(x):
        g, G, w, W, a2, b2, a3, b3 = x[:3], x[3:6], x[6:9], x[9:12], *x[12:]
        out = []
        for T, a, b in ((T2, a2, b2), (T3, a3, b3)):
            P = rot(g, G, a) @ rot(w, W, b)
            out += list(log_so3(P[:3, :3].T @ T[:3, :3])) + list(P[:3, 3] - T[:3, 3])
        out += [g @ g - 1, w @ w - 1, G @ g, W @ w]
        return np.array(out)

    rng = np.random.default_rng(0)
    starts = 10 if quick else 30
    found = set()
    t0 = time.perf_counter()
    n_conv = 0
    for _ in range(starts):
        x0 = np.r_[rng.normal(size=12), rng.uniform(-np.pi, np.pi, 4)]
        r = least_squares(resid, x0, xtol=1e-14, ftol=1e-14, gtol=1e-14)
        if np.abs(r.fun).max() < 1e-9:
            n_conv += 1
            g = Line(r.x[:3] / np.linalg.norm(r.x[:3]), r.x[3:6])
            for i, link in enumerate(links):
                if abs(abs(g.direction @ link.fixed_axis.direction) - 1) < 1e-6 and \
                        g.distance_to(link.fixed_axis) < 1e-6:
                    found.add(i)
    t_ms = time.perf_counter() - t0
    return [
        "## synthesis: seed 001's RRR example",
        "",
        f"- full RRR enumeration with engine verification: **{1e3 * t_enum:.1f} ms** for "
        f"{len(df)} variants ({int((df.reason == '').sum())} regular), largest residual "
        f"{df.residual.max():.1e} (goal ≤ 20 ms)",
        f"- one RR link pair by the motion-polynomial algebra: {1e3 * t_rr:.2f} ms, both "
        f"solutions, residuals {links[0].residual:.1e}, {links[1].residual:.1e}",
        f"- multi-start `scipy.optimize.least_squares` on the RR equations ({starts} random "
        f"starts): {t_ms:.2f} s, {n_conv} converged, found {len(found)} of the 2 solutions; "
        f"time ratio {t_ms / t_rr:.0f}×",
        "",
        "| variant | order | mechanism | rr | residual |",
        "|---|---|---|---|---|",
    ] + [f"| {r.variant} | {r.order} | {r.mechanism} | {r.rr} | {r.residual:.1e} |"
         for r in df.itertuples()] + [""]


def bench_mechanism(quick: bool = False) -> list[str]:
    """Stiffness of a 6-UPS platform built from joints: batched ``of_mechanism`` vs a
    per-pose loop over the same call, error against ``Hexapod``'s closed form P Kθ Pᵀ."""
    from stiffness import Hexapod, of_mechanism
    from linkwright.references import ups_platform
    from closure import exp_so3

    n = 200 if quick else 10_000
    n_loop = 50 if quick else 200
    rng = np.random.default_rng(1)
    a = np.radians([0, 100, 120, 220, 240, 340])
    b = np.radians([40, 80, 160, 200, 280, 320])
    base = np.c_[0.8 * np.cos(a), 0.8 * np.sin(a), np.zeros(6)]
    plat = np.c_[0.4 * np.cos(b), 0.4 * np.sin(b), np.zeros(6)]
    k = rng.uniform(5e6, 2e7, 6)
    T0 = np.eye(4)
    T0[:3, :3] = exp_so3(np.r_[0.05, -0.1, 0.15])
    T0[:3, 3] = [0.02, 0.01, 0.7]
    m = ups_platform(base, plat, T0)
    springs = {f"P{i}": k[i] for i in range(6)}
    t_solve, pose = _timeit(lambda: m.solve(rng.normal(scale=0.02, size=(n, 6))), repeat=1)
    t_vec, res = _timeit(lambda: of_mechanism(m, pose, platform="platform", springs=springs))
    one = [pose.mechanism.solve(pose.inputs[i]) for i in range(n_loop)]
    t0 = time.perf_counter()
    for p in one:
        of_mechanism(m, p, platform="platform", springs=springs)
    t_loop = (time.perf_counter() - t0) / n_loop * n
    hx = Hexapod(base, plat, k)
    Kref = hx.stiffness(pose.link_frame("platform") @ T0).K
    err = (np.abs(res.K - Kref).max(axis=(1, 2)) / np.abs(Kref).max(axis=(1, 2))).max()
    return [
        "## stiffness of a mechanism built from joints (6-UPS, 36 coordinates, 5 loops)",
        "",
        "| method | poses | time (s) | µs / pose |",
        "|---|---|---|---|",
        f"| batched `stiffness.of_mechanism` | {n} | {t_vec:.3f} | {t_vec / n * 1e6:.0f} |",
        f"| per-pose loop over `of_mechanism` (timed on {n_loop}, scaled) | {n} | {t_loop:.2f} | "
        f"{t_loop / n * 1e6:.0f} |",
        f"| (solving the poses: `Mechanism.solve`, batched) | {n} | {t_solve:.2f} | "
        f"{t_solve / n * 1e6:.0f} |",
        "",
        f"speed ratio: **{t_loop / t_vec:.0f}×**; largest relative difference from the "
        f"hexapod's P Kθ Pᵀ {err:.1e}",
        "",
    ]


def _lazy(module: str, function: str) -> Callable[[bool], list[str]]:
    """A benchmark kept in its own module, imported only when it runs."""
    def run(quick: bool = False) -> list[str]:
        import importlib
        return getattr(importlib.import_module(f"linkwright.{module}"), function)(quick)
    run.__name__ = function
    return run


BENCHES = {"closure": bench_closure, "synthesis": bench_synthesis, "stiffness": bench_stiffness,
           "mechanism": bench_mechanism, "approx": bench_approx, "dynamics": bench_dynamics,
           "batch-dynamics": bench_batch_dynamics,
           "engine": _lazy("bench_closure_speed", "bench_closure_speed"),
           "peers": _lazy("bench_peers", "bench_peers"),
           "links": _lazy("bench_links", "bench_links"),
           "families": _lazy("bench_families", "bench_families"),
           "complete": _lazy("bench_complete", "bench_complete"),
           "grid": _lazy("bench_grid", "bench_grid"),
           "kernels": _lazy("bench_stiffness_speed", "bench_stiffness_speed"),
           "surrogate-dynamics": _lazy("bench_approx_dynamics", "bench_surrogate_dynamics")}


def stream(modules=None, quick: bool = False) -> Iterator[tuple[str, str, Exception | None]]:
    """Run the benchmarks of ``modules`` (default all) one by one.

    Yields
    ------
    (name, text, error)
        The module, its Markdown table (or a note saying it failed) and the exception
        (None when it ran), as soon as the module has finished; a failing module does
        not stop the others.
    """
    for name in list(modules or BENCHES):
        t0 = time.perf_counter()
        try:
            text = "\n".join(BENCHES[name](quick))
        except Exception as e:  # report it, run the others
            yield name, f"## {name}: failed\n\n{type(e).__name__}: {e}\n", e
            continue
        yield name, text + f"\n(benchmark wall time {time.perf_counter() - t0:.1f} s)\n", None


def tables(modules=None, quick: bool = False) -> str:
    """The benchmark tables of ``modules`` (default all) as one Markdown text."""
    return "\n".join("\n".join(BENCHES[name](quick)) for name in (list(modules) or list(BENCHES)))


def run(modules=None, quick: bool = False, write: Callable[[str], None] | None = None) -> int:
    """Print each module's table as soon as it is done; 1 if any module failed, 2 for an
    unknown module."""
    modules = list(modules or BENCHES)
    for name in modules:
        if name not in BENCHES:
            print(f"unknown benchmark {name!r}; available: {', '.join(BENCHES)}", file=sys.stderr)
            return 2
    write = write or (lambda text: print(text, flush=True))
    failed = []
    for name, text, error in stream(modules, quick):
        write(text)
        if error is not None:
            failed.append(name)
            print(f"benchmark {name} failed: {type(error).__name__}: {error}", file=sys.stderr,
                  flush=True)
    if failed:
        print(f"{len(failed)} of {len(modules)} benchmarks failed: {', '.join(failed)}",
              file=sys.stderr, flush=True)
    return 1 if failed else 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m linkwright.bench", description=__doc__)
    p.add_argument("modules", nargs="*")
    p.add_argument("--quick", action="store_true")
    a = p.parse_args(argv)
    return run(a.modules, a.quick)


if __name__ == "__main__":
    sys.exit(main())
