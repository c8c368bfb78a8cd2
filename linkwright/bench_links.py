"""Benchmark of the binary links with spherical, universal, helical and prismatic joints
(RS, SR, HS, SH, PS, SP, UR, UH, UP, UC, PH, HP) at explicit free parameters: time per call,
links found, largest engine residual, against a multi-start ``scipy.optimize.least_squares``
on the same equations at the same free parameter (what a competent user would write):
its time, the distinct solutions it finds and how many of them the function misses.

    python -c "from linkwright.bench_links import bench_links; print('\\n'.join(bench_links()))"
"""
from __future__ import annotations

import time

import numpy as np


def _timeit(fn, repeat=3):
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def _screw(u, c, th, d):
    K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    R = np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, c - R @ c + d * np.asarray(u)
    return T


def _basis(g):
    e1 = np.cross(g, [1.0, 0, 0]) if abs(g[0]) < 0.9 else np.cross(g, [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(g, e1)


def _hs_equations(T, a, b, p):
    """T_j C = H(θ_j) C for j = 2…4 in z = (β, C, axis point (2), θ₂, θ₃, θ₄)."""
    def f(z):
        g = np.cos(z[0]) * a + np.sin(z[0]) * b
        e1, e2 = _basis(g)
        c = z[4] * e1 + z[5] * e2
        C = np.r_[z[1:4], 1.0]
        return np.concatenate([((T[j] - _screw(g, c, z[5 + j], p * z[5 + j])) @ C)[:3]
                               for j in (1, 2, 3)])
    return f, 9, lambda z: np.r_[z[1:4]], lambda z: np.all(np.abs(z[6:]) <= np.pi)


def _ps_equations(T, a, b, p):
    def f(z):
        d = np.cos(z[0]) * a + np.sin(z[0]) * b
        return np.concatenate([(T[j, :3, :3] - np.eye(3)) @ z[1:4] - z[3 + j] * d + T[j, :3, 3]
                               for j in (1, 2)])
    return f, 6, lambda z: np.r_[z[1:4]], lambda z: True


def _u_equations(L):
    def s2(u, v):
        return np.array([np.sin(u) * np.cos(v), np.sin(u) * np.sin(v), np.cos(u)])

    def f(z):
        return np.einsum("i,mij,j->m", s2(*z[:2]), L, s2(*z[2:]))
    return f, 4, lambda z: s2(*z[:2]), lambda z: True


def _multistart(eqs, n, key, ok, starts, rng, scale=1.0):
    from scipy.optimize import least_squares

    found = []
    t0 = time.perf_counter()
    for _ in range(starts):
        z0 = rng.uniform(-np.pi, np.pi, n)
        z0[1:4] *= scale
        r = least_squares(eqs, z0, xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=200 * n)
        if np.abs(r.fun).max() < 1e-9 and ok(r.x):
            k = key(r.x)
            if not any(np.linalg.norm(np.abs(k) - np.abs(f)) < 1e-6 for f in found):
                found.append(k)
    return time.perf_counter() - t0, found


def bench_links(quick: bool = False) -> list[str]:
    """Every pair on one generic task (seeded), with its free parameters fixed; the
    baseline is ``least_squares`` from random starts on the same equations."""
    from synthesis import Screw
    from synthesis.binary import _task
    from synthesis.helical import helical_links
    from synthesis.hooke import u_directions, uc_links, uh_links, up_links, ur_links
    from synthesis.prismatic import hp_links, ph_links
    from synthesis.spherical import (hs_links, ps_links, rs_links_at, sh_links, sp_links,
                                     sr_links, task_frame)
    from synthesis.verify import verify_open_chains

    rng = np.random.default_rng(2024)

    def unit():
        v = rng.normal(size=3)
        return v / np.linalg.norm(v)
    scr = [Screw(unit(), rng.normal(size=3), rng.uniform(0.5, 2.0), rng.normal())
           for _ in range(3)]
    starts = 8 if quick else 60
    psi, pitch = 0.9, 0.25
    F = task_frame(scr)
    a, b = F[:, 2], np.cos(psi) * F[:, 0] + np.sin(psi) * F[:, 1]
    rows = []

    def case(name, n_pos, fn, eq=None, inverse=False):
        s = scr[:n_pos - 1]
        fn()
        t, links = _timeit(fn, repeat=2 if quick else 3)
        task = _task(s, "screws", (n_pos,))
        res = verify_open_chains([lk.engine_chain() for lk in links], task.T, task.reach)
        base = "—", "—", "—", "—"
        if eq is not None:
            T = task.T if not inverse else np.linalg.inv(task.T)
            f, n, key, ok = eq(T)
            tb, found = _multistart(f, n, key, ok, starts, rng)
            ours = [eq_key(lk, name) for lk in links]
            missed = sum(min([np.linalg.norm(np.abs(k) - np.abs(o)) for o in ours] + [9]) > 1e-6
                         for k in found)
            base = f"{tb * 1e3:.0f}", f"{len(found)}", f"{missed}", f"{tb / t:.0f}×"
        rows.append(f"| {name} | {n_pos} | {t * 1e3:.2f} | {len(links)} | "
                    f"{(res.max() if len(res) else float('nan')):.1e} | {base[0]} | {base[1]} | "
                    f"{base[2]} | {base[3]} |")
        return links

    def eq_key(lk, name):
        if name.split()[0] in ("RS", "HS", "PS"):
            return lk.moving_axis.point
        return lk.fixed_axis.point                     # SR, SH, SP: the sphere centre

    case("RS", 4, lambda: rs_links_at(scr, psi), lambda T: _hs_equations(T, a, b, 0.0))
    case("SR", 4, lambda: sr_links(scr, psi), lambda T: _hs_equations(T, a, b, 0.0), True)
    case(f"HS (pitch {pitch})", 4, lambda: hs_links(scr, pitch, psi),
         lambda T: _hs_equations(T, a, b, pitch))
    case(f"SH (pitch {pitch})", 4, lambda: sh_links(scr, pitch, psi),
         lambda T: _hs_equations(T, a, b, pitch), True)
    case(f"HH (pitches {pitch}, {-pitch})", 3, lambda: helical_links(scr[0], scr[1], pitch,
                                                                      -pitch))
    case(f"RH (pitch {pitch})", 3, lambda: helical_links(scr[0], scr[1], 0.0, pitch))
    case("PS", 3, lambda: ps_links(scr[:2], psi), lambda T: _ps_equations(T, a, b, 0.0))
    case("SP", 3, lambda: sp_links(scr[:2], psi), lambda T: _ps_equations(T, a, b, 0.0), True)
    case("UR", 4, lambda: ur_links(scr, azimuth=psi))
    case(f"UH (pitch {pitch})", 4, lambda: uh_links(scr, pitch=pitch, azimuth=psi))
    case("UP", 3, lambda: up_links(scr[:2], slide_azimuth=psi, axis_azimuth=0.3))
    case("UC (centre given)", 4, lambda: uc_links(scr, centre=[0.3, -0.2, 0.5], azimuth=psi))
    d = unit()
    case("PH (pitch 0.25)", 2, lambda: ph_links(scr[0], pitch=pitch, fixed_direction=d))
    case("HP (pitch 0.25)", 2, lambda: hp_links(scr[0], pitch=pitch, moving_direction=d))
    # the U direction problem alone (the part of UR beyond SR): 4 bilinear equations
    base = sr_links(scr, psi)[0].sphere_rotations
    t_u, pairs = _timeit(lambda: u_directions(base))
    f, n, key, ok = _u_equations(base)
    tb, found = _multistart(f, n, key, ok, starts, rng)
    missed = sum(min([abs(abs(k @ p[0]) - 1) for p in pairs] + [9]) > 1e-6 for k in found)
    rows.append(f"| U directions (4 orientations) | 4 | {t_u * 1e3:.2f} | {len(pairs)} | — | "
                f"{tb * 1e3:.0f} | {len(found)} | {missed} | {tb / t_u:.0f}× |")
    from linkwright.bench import first_call
    t_compile, t_load = first_call(
        "import time\nfrom linkwright.bench_families import generate_sphere\n"
        "from synthesis.helical import helical_links\nfrom synthesis.spherical import hs_links\n"
        "s = generate_sphere('RHS', 0)[0]\nt0 = time.perf_counter()\n"
        "helical_links(s[0], s[1], 0.25, 0.0)\nhs_links(s[:3], 0.25, 0.9)\n"
        "t = time.perf_counter() - t0")
    return [
        "## synthesis: binary links with S, U, H and P joints at explicit free parameters",
        "",
        f"One generic task (seeded), azimuth ψ = {psi} rad; baseline: `least_squares` from "
        f"{starts} random starts on the same equations at the same ψ (distinct solutions with "
        "angles in (−π, π]; 'missed' = baseline solutions the function does not return).  "
        "Residual: engine verification (rad, or length / reach).",
        "",
        "| link | positions | ms / call | links | largest residual | baseline ms | baseline "
        "solutions | missed | time ratio |",
        "|---|---|---|---|---|---|---|---|---|",
    ] + rows + ["", f"The helical searches (HH, RH, HR, HS, SH, UH) run compiled kernels "
                      f"(`synthesis.kernels`, numba): first helical_links + hs_links call in a new "
                      f"installation {t_compile:.1f} s (compiling), in a later process "
                      f"{t_load:.2f} s (cache load and the two searches).", ""]
