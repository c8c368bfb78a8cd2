"""Benchmark of the hexapod stiffness kernels (issue 15's stiffness targets): K = P Kθ Pᵀ
per pose, cond(P) per pose and the memory of :meth:`stiffness.Hexapod.map`, each beside
honest baselines measured in the same run and the hardware floor.

    python -c "from linkwright.bench_stiffness_speed import bench_stiffness_speed as b; \
print('\\n'.join(b(quick=True)))"
"""
from __future__ import annotations

import time
import tracemalloc

import numpy as np


def _cpu(fn, repeat=3):
    """Median CPU (process) time of ``fn()`` over ``repeat`` runs, and its last result."""
    times, out = [], None
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        times.append(time.process_time() - t0)
    return float(np.median(times)), out


def _hexapod_and_poses(n, seed=0):
    from closure import exp_so3
    from stiffness import Hexapod
    rng = np.random.default_rng(seed)
    a = np.radians([0, 100, 120, 220, 240, 340])
    b = np.radians([40, 80, 160, 200, 280, 320])
    hx = Hexapod(np.c_[0.8 * np.cos(a), 0.8 * np.sin(a), np.zeros(6)],
                 np.c_[0.4 * np.cos(b), 0.4 * np.sin(b), np.zeros(6)], rng.uniform(5e6, 2e7, 6))
    T = np.zeros((n, 4, 4))
    T[:, :3, :3] = exp_so3(rng.normal(scale=0.15, size=(n, 3)))
    T[:, :3, 3] = rng.normal(scale=0.05, size=(n, 3)) + [0, 0, 0.7]
    T[:, 3, 3] = 1
    return hx, T


def _bandwidth(nbytes=256 * 2**20):
    """Sustained copy bandwidth (bytes read + written per second) of one core."""
    src = np.ones(nbytes // 8)
    dst = np.empty_like(src)
    t, _ = _cpu(lambda: np.copyto(dst, src), repeat=5)
    return 2 * nbytes / t


def bench_stiffness_speed(quick: bool = False) -> list[str]:
    """K per pose, cond(P) per pose and the map's memory per pose for a hexapod batch,
    against a per-pose numpy loop, an einsum over the batched leg matrix, the previous
    implementation (leg matrix then ``P diag(k) Pᵀ`` by batched matmul; cond by batched
    SVD) and the memory-traffic floor (read T, write K)."""
    from stiffness.matrices import _congruence
    from stiffness.hexapod import MAP_CHUNK
    from stiffness.validate import transform

    n = 20_000 if quick else 200_000
    n_loop = 2_000 if quick else 10_000
    hx, T = _hexapod_and_poses(n)
    k = hx.k

    t_new, (K, _) = _cpu(lambda: hx.stiffness_batch(T, cond=False))

    def previous(T):                                # the former stiffness_batch(cond=False)
        T = transform(T, "T")
        blk = hx._BLOCK
        return np.concatenate([_congruence(hx._leg_matrix(T[i:i + blk]), k)
                               for i in range(0, len(T), blk)])

    t_prev, K_prev = _cpu(lambda: previous(T))

    def einsum(T):
        P = hx._leg_matrix(T)
        return np.einsum("bin,n,bjn->bij", P, k, P, optimize=True)

    t_ein, K_ein = _cpu(lambda: einsum(T))

    def loop(Ts):                                   # one pose at a time, numpy inside
        out = np.empty((len(Ts), 6, 6))
        for i, Ti in enumerate(Ts):
            p = hx.platform @ Ti[:3, :3].T + Ti[:3, 3]
            u = p - hx.base
            u /= np.linalg.norm(u, axis=1)[:, None]
            P = np.vstack([u.T, np.cross(p, u).T])
            out[i] = (P * k) @ P.T
        return out

    t_loop, K_loop = _cpu(lambda: loop(T[:n_loop]), repeat=1)
    t_loop *= n / n_loop
    scale = np.abs(K_prev).max()
    err = max(np.abs(K - K_prev).max(), np.abs(K[:n_loop] - K_loop).max(),
              np.abs(K - K_ein).max()) / scale
    bw = _bandwidth()
    floor = n * (16 + 36) * 8 / bw                  # read T (16 doubles), write K (36)

    # cond(P): Gram eigenvalues (SVD above 1e4) vs the batched SVD of the leg matrix
    nc = n // 10
    Tc = T[:nc]
    t_c_new, (_, c_new) = _cpu(lambda: hx.stiffness_batch(Tc, cond=True))
    t_c_k, _ = _cpu(lambda: hx.stiffness_batch(Tc, cond=False))
    t_c_svd, c_svd = _cpu(lambda: hx._cond(hx._leg_matrix(Tc), Tc))
    c_err = float(np.abs(c_new / c_svd - 1).max())

    # map memory: peak traced bytes per pose of Hexapod.map and of map_chunks
    g = np.linspace(-0.05, 0.05, 50)
    pos = np.array(np.meshgrid(g, g, 0.7 + g[:16])).reshape(3, -1).T
    rot = np.random.default_rng(1).normal(scale=0.1, size=(4 if quick else 8, 3))
    hx.map(pos[:4], rot)                            # warm caches outside the trace
    tracemalloc.start()
    t_map0 = time.process_time()
    df = hx.map(pos, rot)
    t_map = time.process_time() - t_map0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    nm = len(df)
    del df
    tracemalloc.start()
    rows = sum(len(part) for part in hx.map_chunks(pos, rot))
    _, peak_chunks = tracemalloc.get_traced_memory()
    tracemalloc.stop()

    ns = 1e9 / n
    return [
        "## stiffness kernels: hexapod K = P Kθ Pᵀ, cond(P) and map memory",
        "",
        "CPU time per pose (median of 3, one thread); K about the base origin, transforms "
        "checked.",
        "",
        "| method | poses | ns / pose | ratio (ours faster by) |",
        "|---|---|---|---|",
        f"| `Hexapod.stiffness_batch(T, cond=False)`: u uᵀ products then one "
        f"(B, 36) @ (36, 36) product per block | {n} | {t_new * ns:.0f} | 1 |",
        f"| previous: transforms checked, leg matrix, then `P diag(k) Pᵀ` by batched matmul "
        f"(blocks of {hx._BLOCK}) | {n} | {t_prev * ns:.0f} | {t_prev / t_new:.1f}× |",
        f"| einsum `bin,n,bjn->bij` over the batched leg matrix | {n} | {t_ein * ns:.0f} | "
        f"{t_ein / t_new:.1f}× |",
        f"| per-pose numpy loop (timed on {n_loop}, scaled) | {n} | {t_loop * ns:.0f} | "
        f"{t_loop / t_new:.0f}× |",
        f"| memory-traffic floor: read T, write K (416 B at {bw / 1e9:.1f} GB/s copy "
        f"bandwidth) | {n} | {floor * ns:.1f} | ours at {t_new / floor:.1f}× the floor |",
        "",
        f"largest difference between the methods: {err:.1e} of max |K|",
        "",
        "| cond(P) | poses | ns / pose (cond only) | ratio |",
        "|---|---|---|---|",
        f"| eigenvalues of the dimensionless Gram matrix P Pᵀ (SVD above cond 1e4) | {nc} | "
        f"{(t_c_new - t_c_k) * 1e9 / nc:.0f} | 1 |",
        f"| batched SVD of the dimensionless leg matrix (previous) | {nc} | "
        f"{t_c_svd * 1e9 / nc:.0f} | {t_c_svd / max(t_c_new - t_c_k, 1e-12):.1f}× |",
        "",
        f"largest relative difference of cond(P) from the SVD's: {c_err:.1e}",
        "",
        "| `Hexapod.map` memory | poses | peak traced bytes / pose | time (µs / pose) |",
        "|---|---|---|---|",
        f"| `map` (table of 10 floats + 1 bool = 81 B / pose, filled chunk by chunk) | {nm} | "
        f"{peak / nm:.0f} | {t_map / nm * 1e6:.1f} |",
        f"| `map_chunks` ({MAP_CHUNK} poses a chunk, streamed) | {rows} | {peak_chunks / rows:.0f} "
        f"(constant {peak_chunks / 2**20:.1f} MiB) | |",
        "| before this change (issue 15's measurement) | 1e7 | 1,030 | |",
        "",
    ]


if __name__ == "__main__":                          # pragma: no cover
    print("\n".join(bench_stiffness_speed(quick=True)))
