"""Benchmark of the closure engine's latency, batch throughput and memory.

    python -m linkwright.bench_closure_speed [--quick]

One pose (``Mechanism.solve`` of one input from a solved nearby pose), one sweep step
(``Mechanism.sweep`` per row), and the RSSR batch per position at 1e3, 1e4 and 1e5
positions with its memory per position, each against an honest baseline measured in
the same run: scipy ``least_squares(method="lm")`` per pose on the engine's own
dimensionless loop residual with its analytic Jacobian, and a vectorised Newton on the
RSSR's closed-form one-unknown equation; and the first call of the solver's compiled
kernels (numba: compiled once per installation, then loaded from the cache).  Times are
CPU times (``time.process_time``), medians of repeats.
"""
from __future__ import annotations

import sys
import time
import tracemalloc

import numpy as np


def _cpu(fn, repeat: int = 5) -> float:
    """Median CPU time of ``fn()`` over ``repeat`` calls (s)."""
    ts = []
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        ts.append(time.process_time() - t0)
    return float(np.median(ts))


def _lm_one(m, guess, x):
    """One pose by scipy ``least_squares(method="lm")`` on the engine's dimensionless loop
    residual with the engine's analytic Jacobian (the idle spin of an S–S rod pinned by
    one more residual along the Jacobian's null vector); returns the solved state."""
    from scipy.optimize import least_squares

    plan = m.plan
    unknown = m.unknown_columns()
    q0, rot0 = guess.q[:1].copy(), guess.rot[:1].copy()
    q0[:, m.input_q_columns()] = x

    def state(u):
        dv = np.zeros((1, plan.nv))
        dv[0, unknown] = u
        return plan.apply(q0, rot0, dv)

    def f(u):
        return plan.scaled_residual(plan.evaluate(*state(u), twists=False).r)[0]

    def jac(u):
        return plan.scaled_jacobian(plan.evaluate(*state(u)).S, unknown)[0]

    J0 = jac(np.zeros(unknown.size))
    extra = J0.shape[1] - np.linalg.matrix_rank(J0)
    if extra:
        v = np.linalg.svd(J0)[2][-extra:]
        fun, jf = (lambda u: np.r_[f(u), v @ u]), (lambda u: np.vstack([jac(u), v]))
    else:
        fun, jf = f, jac
    r = least_squares(fun, np.zeros(unknown.size), jac=jf, method="lm", xtol=1e-12,
                      ftol=1e-12, gtol=1e-12)
    return state(r.x)


def _rssr_guesses(m, x):
    """Guesses for the RSSR batch: the nearest pose of a coarse continuation sweep."""
    from closure import Pose

    coarse = np.linspace(x.min(), x.max(), 64)
    up = m.sweep(np.r_[0.0, coarse[coarse > 0]], return_pose=True)[1]
    lo = m.sweep(np.r_[0.0, coarse[coarse < 0][::-1]], return_pose=True)[1]
    cx = np.r_[up.inputs[:, 0], lo.inputs[:, 0]]
    cq, crot = np.r_[up.q, lo.q], np.r_[up.rot, lo.rot]
    near = np.abs(x[:, None] - cx[None]).argmin(1)
    n = x.size
    return Pose(m, cx[near, None], cq[near], crot[near], *(np.zeros(n),) * 3,
                np.zeros(n, int))


def bench_closure_speed(quick: bool = False) -> list[str]:
    """Latency of one pose and one sweep step (four-bar, RSSR), the RSSR batch per
    position at 1e3 / 1e4 / 1e5 positions (1e5 timed once when ``quick``) with its memory
    per position, and building a mechanism of V chains; each beside its baseline
    (``least_squares`` lm per pose with the analytic Jacobian, the vectorised
    closed-form Newton), with the ratio.  Returns Markdown lines."""
    from closure import Mechanism, translation
    from linkwright.bench import _rssr_closed_newton
    from linkwright.references import fourbar, rssr, rssr_output

    us = 1e6
    out = ["## closure: latency, batch throughput and memory (CPU time, median of repeats)", ""]
    # ------------------------------------------------------------ one pose, one sweep step
    out += ["| mechanism | engine, one pose (µs) | same, condition read (µs) | engine, "
            "`continuation=False` (µs) | lm per pose, analytic J (µs) | ratio lm / engine | "
            "engine, one sweep step (µs) | max residual |", "|---|---|---|---|---|---|---|---|"]
    n_one = 8 if quick else 30
    phi0 = 0.2
    cases = (("planar four-bar", fourbar(1.0, 3.0, 2.5, 3.2, 0.3)[0]),
             ("spatial RSSR", rssr(phi0, 1)[0]))
    for label, m in cases:
        p0 = m.solve(0.0)
        xs1 = 0.02 + 0.004 * np.arange(n_one)
        m.solve(xs1[0], guess=p0)                             # compiled, warm
        t_one = _cpu(lambda: [m.solve(x, guess=p0) for x in xs1], 7) / n_one
        t_cnd = _cpu(lambda: [m.solve(x, guess=p0).condition for x in xs1], 7) / n_one
        t_nc = _cpu(lambda: [m.solve(x, guess=p0, continuation=False) for x in xs1], 7) / n_one
        t_lm = _cpu(lambda: [_lm_one(m, p0, x) for x in xs1], 3) / n_one
        xs = np.linspace(0.0, 0.4 if quick else 1.0, 21 if quick else 51)
        t_sw = _cpu(lambda: m.sweep(xs), 5) / (xs.size - 1)
        res = max(float(m.solve(x, guess=p0).residual.max()) for x in xs1)
        out.append(f"| {label} | {t_one * us:.0f} | {t_cnd * us:.0f} | {t_nc * us:.0f} | "
                   f"{t_lm * us:.0f} | "
                   f"{t_lm / t_one:.2g}× | "
                   f"{t_sw * us:.0f} | {res:.1e} |")
    # first call of the solver's compiled kernels in a new process: compiled (empty numba
    # cache), then loaded from the cache
    from linkwright.bench import first_call
    t_compile, t_load = first_call(
        "import time\nfrom linkwright.references import rssr\nt0 = time.perf_counter()\n"
        "m, _ = rssr(0.2, 1)\np = m.solve(0.1); p.condition; m.sweep([0.0, 0.05])\n"
        "t = time.perf_counter() - t0")
    out += ["", "One pose: `solve` of one input 0.02–0.14 rad from a solved pose (continuation: "
            "predictor, corrector, in the compiled kernel `closure.solve_kernels.drive`); its "
            "condition number is computed when first read (third column: one SVD); "
            "`continuation=False`: one Newton correction from the guess, as the lm baseline "
            "does (its residual and Jacobian evaluated by the same compiled kernels).  Sweep "
            "step: `sweep` over inputs 0.02 rad apart, per row, table included.  Target ≤ 100 µs.",
            "", f"First call of the solver kernels in a new installation (an RSSR built, "
            f"solved, its condition read and a sweep): {t_compile:.1f} s compiling them, "
            f"{t_load:.2f} s in later processes (numba's cache, numba's import included).", ""]
    # ------------------------------------------------------------ RSSR batch
    m, psi0 = rssr(phi0, 1)
    col = m.tree.q_offset[m.joint("out").index]
    out += ["| positions | engine µs / position | closed-form Newton µs / position | ratio "
            "engine / closed form | retained B / position | peak B / position | max error vs "
            "closed form (rad) |", "|---|---|---|---|---|---|---|"]
    sizes = (1_000, 10_000, 100_000)
    for n in sizes:
        x = np.linspace(-np.pi, np.pi, n, endpoint=False) - phi0
        guess = _rssr_guesses(m, x)
        rep = 3 if n <= 10_000 else (1 if quick else 3)
        t = _cpu(lambda: m.solve(x, guess=guess), rep) / n
        psi_g = psi0 + guess.q[:, col]
        t_cf = _cpu(lambda: _rssr_closed_newton(phi0 + x, psi_g), 5) / n
        tracemalloc.start()
        pose = m.solve(x, guess=guess)
        kept, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        ref = rssr_output(phi0 + x, 1)
        err = np.abs((psi0 + pose["out"] - ref + np.pi) % (2 * np.pi) - np.pi).max()
        out.append(f"| {n:,} | {t * us:.2f} | {t_cf * us:.3f} | {t / t_cf:.0f}× | "
                   f"{kept / n:,.0f} | {peak / n:,.0f} | {err:.1e} |")
    out += ["", "Retained: what the returned `Pose` holds (tracemalloc, after the call); peak: "
            "the call's peak including its temporaries (one kernel call corrects every guess "
            "and continues from it, each position's kinematic state in the kernel's scratch: "
            "a few KB per call, allocated by numba, which tracemalloc does not see).  Targets: "
            "≤ 5 µs and ≤ 1 KB per position.", ""]
    # ------------------------------------------------------------ chains of loops
    import closure.lstsq as lstsq
    import closure.solver as solver
    from linkwright.references import fourbar_chain
    out += ["| four-bars in series N | unknowns | one pose µs | same, dense factorisation µs | "
            "batch of 200, µs / position | same, dense | ratio dense / block | batch µs / "
            "position / loop | condition read, batch of 200, µs / position: BLAS on one "
            "thread | BLAS threads as installed | ratio |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    xb = np.linspace(-0.05, 0.05, 200)
    for n in ((1, 4, 16, 64) if quick else (1, 2, 4, 8, 16, 32, 64)):
        m = fourbar_chain(n)
        p0 = m.solve(0.0)
        xs1 = 0.02 + 0.004 * np.arange(n_one)
        m.solve(xs1[0], guess=p0)
        rep = 3 if n < 64 else 1

        def dense(fn):
            solver.DENSE_LSQ = True
            try:
                return fn()
            finally:
                solver.DENSE_LSQ = False
        t_one = _cpu(lambda: [m.solve(x, guess=p0) for x in xs1], rep + 2) / n_one
        t_one_d = dense(lambda: _cpu(lambda: [m.solve(x, guess=p0) for x in xs1], rep)) / n_one
        t_b = _cpu(lambda: m.solve(xb, guess=p0), rep) / xb.size
        t_b_d = dense(lambda: _cpu(lambda: m.solve(xb, guess=p0), rep)) / xb.size
        cells = ["—", "—", "—"]
        if n <= 16:                     # numpy's batched SVD of the Jacobians (cubic in N)
            pb = m.solve(xb, guess=p0)
            S = pb.kinematics().S

            def cond():
                return m.plan.condition(S, np.arange(xb.size))
            t_c = _cpu(cond, 3) / xb.size
            keep, lstsq.SERIAL_BLAS_ENTRIES = lstsq.SERIAL_BLAS_ENTRIES, np.inf
            try:
                t_ct = _cpu(cond, 3) / xb.size
            finally:
                lstsq.SERIAL_BLAS_ENTRIES = keep
            cells = [f"{t_c * us:.0f}", f"{t_ct * us:.0f}", f"{t_ct / t_c:.1f}×"]
        out.append(f"| {n} | {3 * n} | {t_one * us:.0f} | {t_one_d * us:.0f} | {t_b * us:.0f} | "
                   f"{t_b_d * us:.0f} | {t_b_d / t_b:.1f}× | {t_b / n * us:.1f} | "
                   + " | ".join(cells) + " |")
    out += ["", "One input drives N four-bars (each rocker the next crank): N loops sharing one "
            "joint each, a block-bidiagonal Jacobian (6N rows, 3N unknowns).  The solver "
            "factors its Gram matrix on its envelope (block-sparse Cholesky, "
            "`closure.solve_kernels._sp_factor`); \"dense\": the same solver with every "
            "Jacobian factored densely (`closure.solver.DENSE_LSQ`, the engine before the "
            "block-sparse path), the same iterations.  Target: cost per pose linear in N "
            "(flat µs / position / loop).  Condition read: the exact condition numbers "
            "(numpy's batched SVD without the vectors) of the batch's poses, with BLAS limited "
            "to one thread (threadpoolctl) as the engine does for matrices of at least "
            f"{lstsq.SERIAL_BLAS_ENTRIES} entries, and with BLAS threads as installed (CPU "
            "time, all threads).", ""]
    # ------------------------------------------------------------ building V chains
    out += ["| chains V | build µs / chain |", "|---|---|"]
    for V in ((100, 1000) if quick else (100, 1000, 10_000)):
        def build():
            mm = Mechanism()
            for v in range(V):
                mm.add_link(f"a{v}")
                mm.add_link(f"b{v}")
                mm.add_joint(f"v{v}j1", "R", "ground", f"a{v}", at=translation((v, 0, 0)))
                mm.add_joint(f"v{v}j2", "R", f"a{v}", f"b{v}", at=translation((v, 1, 0)))
                mm.joint(f"v{v}j1")
        out.append(f"| {V:,} | {_cpu(build, 3) / V * us:.0f} |")
    out += ["", "`add_link`, `add_joint` and `joint()` look names up in dicts: the cost per "
            "chain is flat in V.", ""]
    return out


if __name__ == "__main__":
    print("\n".join(bench_closure_speed("--quick" in sys.argv[1:])))
