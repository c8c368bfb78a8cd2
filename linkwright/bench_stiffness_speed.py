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


def _cpu(fn, repeat=5):
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


# ---------------------------------------------------------------------------------------
# The previous numpy path of Hexapod.stiffness_batch / map (before the compiled kernels),
# kept here only as the benchmark's baseline: K about the base origin from the legs'
# direction products u_a u_b and one (B, 6n) @ (6n, 36) product per block of poses, the
# transforms checked in the same pass; cond(P) from numpy's eigenvalues of the Gram matrix
# (singular values above GRAM_COND_LIMIT).
_PAIRS = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
_LAST_ROW = np.array([0.0, 0.0, 0.0, 1.0])
_CHK_A = np.array([0, 1, 2, 4, 5, 6, 0, 1, 2, 1, 2, 0, 2, 0, 1])
_CHK_B = np.array([0, 1, 2, 4, 5, 6, 4, 5, 6, 6, 4, 5, 5, 6, 4])
_CHK_SEL = np.zeros((6, 18))
_CHK_SEL[0, 0:3] = _CHK_SEL[1, 3:6] = _CHK_SEL[2, 6:9] = 1.0
for _k in range(3):
    _CHK_SEL[3 + _k, [9 + _k, 12 + _k, 15 + _k]] = (1.0, -1.0, -1.0)
_CHK_OFF = np.array([1.0, 1.0, 0.0, 0.0, 0.0, 0.0])[:, None]
_NUMPY_BLOCK = 1024


def _numpy_maps(hx):
    """``(Md (3n, 13), L (6n, 36))``: leg vectors ``d = R p + t − b`` from the rows
    ``(T00 … T23, 1)`` of a pose, and K's 36 entries from the products ``u_a u_b``."""
    from stiffness import skew
    n = hx.base.shape[0]
    Md = np.zeros((3 * n, 13))
    for r in range(3):
        Md[r * n:(r + 1) * n, 4 * r:4 * r + 3] = hx.platform
        Md[r * n:(r + 1) * n, 4 * r + 3] = 1.0
        Md[r * n:(r + 1) * n, 12] = -hx.base[:, r]
    L = np.zeros((6 * n, 36))
    for q, (a, b) in enumerate(_PAIRS):
        E = np.zeros((3, 3))
        E[a, b] = E[b, a] = 1.0
        for i in range(n):
            G = np.vstack([np.eye(3), skew(hx.base[i])])
            L[q * n + i] = (hx.k[i] * G @ E @ G.T).ravel()
    return Md, L


def _numpy_cond(hx, d, inv, T):
    """cond(P) of a block from its leg vectors ``d (3, n, m)`` (previous numpy path)."""
    from stiffness.hexapod import GRAM_COND_LIMIT
    u = d * np.sqrt(inv)
    q = hx.platform - hx._centroid
    rq = np.einsum("mij,nj->imn", T[:, :3, :3], q)
    Ps = np.empty((T.shape[0], 6, d.shape[1]))
    ut = u.transpose(0, 2, 1)
    Ps[:, :3] = ut.transpose(1, 0, 2)
    Ps[:, 3] = (rq[1] * ut[2] - rq[2] * ut[1]) / hx.radius
    Ps[:, 4] = (rq[2] * ut[0] - rq[0] * ut[2]) / hx.radius
    Ps[:, 5] = (rq[0] * ut[1] - rq[1] * ut[0]) / hx.radius
    w = np.linalg.eigvalsh(Ps @ np.swapaxes(Ps, 1, 2))
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.sqrt(w[:, -1] / w[:, 0])
    bad = ~(c <= GRAM_COND_LIMIT)
    if bad.any():
        sv = np.linalg.svd(Ps[bad], compute_uv=False)
        with np.errstate(divide="ignore"):
            c[bad] = np.where(sv[:, -1] > 0, sv[:, 0] / sv[:, -1], np.inf)
    return c


def previous_numpy(hx, T, cond, maps=None):
    """K ``(B, 6, 6)`` about the base origin and cond(P) ``(B,)`` (or None) of a float64
    batch ``(B, 4, 4)`` by the previous numpy path (the benchmark's baseline)."""
    from stiffness.validate import ROTATION_TOL, transform
    B, n = T.shape[0], hx.base.shape[0]
    Md, Lk = maps if maps is not None else _numpy_maps(hx)
    K = np.empty((B, 6, 6))
    c = np.empty(B) if cond else None
    Kf = K.reshape(B, 36)
    Tf = T.reshape(B, 16)
    blk = max(1, min(_NUMPY_BLOCK, B))
    X = np.empty((13, blk))
    X[12] = 1.0
    D = np.empty((3 * n, blk))
    U = np.empty((6, n, blk))
    Z = np.empty((18, blk))
    zero2 = (hx._ZERO_LEG * hx.size) ** 2
    for s in range(0, B, blk):
        m = min(B, s + blk) - s
        Xb, Db, Ub = X[:, :m], D[:, :m], U[:, :, :m]
        Xb[:12] = Tf[s:s + m, :12].T
        Zb = Z[:, :m]
        np.multiply(Xb[_CHK_A], Xb[_CHK_B], out=Zb[:15])
        Zb[15:] = Xb[8:11]
        E = _CHK_SEL @ Zb
        E -= _CHK_OFF
        if not (np.abs(E).max() <= ROTATION_TOL
                and np.abs(Tf[s:s + m, 12:] - _LAST_ROW).max() <= ROTATION_TOL
                and np.isfinite(Xb[3:12:4]).all()):
            transform(T, "T")
        np.matmul(Md, Xb, out=Db)
        d = Db.reshape(3, n, m)
        L2 = d[0] * d[0]
        L2 += d[1] * d[1]
        L2 += d[2] * d[2]
        if L2.min() <= zero2:
            hx._leg_matrix(T)
        inv = 1.0 / L2
        for q, (a, b) in enumerate(_PAIRS):
            np.multiply(d[a], d[b], out=Ub[q])
            Ub[q] *= inv
        np.matmul(Ub.reshape(6 * n, m).T, Lk, out=Kf[s:s + m])
        if cond:
            c[s:s + m] = _numpy_cond(hx, d, inv, T[s:s + m])
    return K, c


def bench_stiffness_speed(quick: bool = False) -> list[str]:
    """K per pose, cond(P) per pose and the map's memory per pose for a hexapod batch:
    the compiled kernels of :meth:`stiffness.Hexapod.stiffness_batch` against the previous
    numpy path (:func:`previous_numpy`), an einsum over the batched leg matrix, a per-pose
    numpy loop, batched SVD for cond(P) and the memory-traffic floor (read T, write K);
    with the kernels' first-call time (compile, then load from numba's cache)."""
    from linkwright.bench import first_call
    from stiffness.hexapod import GRAM_COND_LIMIT, MAP_CHUNK
    from stiffness.kernels import LANES

    n = 20_000 if quick else 200_000
    n_loop = 2_000 if quick else 10_000
    hx, T = _hexapod_and_poses(n)
    k = hx.k

    # first call of the kernels in a new process: compiled (empty numba cache), then loaded
    t_compile, t_load = first_call(
        "import time\nfrom linkwright.bench_stiffness_speed import _hexapod_and_poses\n"
        "hx, T = _hexapod_and_poses(10)\nt0 = time.perf_counter()\n"
        "hx.stiffness_batch(T, cond=True)\nt = time.perf_counter() - t0")

    hx.stiffness_batch(T, cond=True)                # loaded and warm (caches, allocator)
    t_new, (K, _) = _cpu(lambda: hx.stiffness_batch(T, cond=False))
    maps = _numpy_maps(hx)
    previous_numpy(hx, T, True, maps)
    t_prev, (K_prev, _) = _cpu(lambda: previous_numpy(hx, T, False, maps))

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

    # cond(P): Jacobi eigenvalues of the Gram matrix (SVD above the limit) in the kernel,
    # the previous numpy eigenvalues (same rule) and the batched SVD of the leg matrix
    nc = n // 4
    Tc = T[:nc]
    t_c_new, (_, c_new) = _cpu(lambda: hx.stiffness_batch(Tc, cond=True))
    t_c_k, _ = _cpu(lambda: hx.stiffness_batch(Tc, cond=False))
    t_c_prev, (_, c_prev) = _cpu(lambda: previous_numpy(hx, Tc, True, maps))
    t_c_pk, _ = _cpu(lambda: previous_numpy(hx, Tc, False, maps))
    t_c_svd, c_svd = _cpu(lambda: hx._cond(hx._leg_matrix(Tc), Tc))
    c_err = float(np.abs(c_new / c_svd - 1).max())
    c_err_prev = float(np.abs(c_new / c_prev - 1).max())
    c_cond, c_prev_only = max(t_c_new - t_c_k, 1e-12), max(t_c_prev - t_c_pk, 1e-12)

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
    nsc = 1e9 / nc
    return [
        "## stiffness kernels: hexapod K = P Kθ Pᵀ, cond(P) and map memory",
        "",
        "CPU time per pose (median of 5 runs, process CPU time: the kernels run on one "
        "thread, the threads of numpy's BLAS are counted); K about the base origin, transforms "
        "checked.",
        "",
        "| method | poses | ns / pose | ratio (ours faster by) |",
        "|---|---|---|---|",
        f"| `Hexapod.stiffness_batch(T, cond=False)`: compiled kernel (numba), one pass: "
        f"transform checks, legs, u, moments, Σ k w wᵀ ({LANES} poses a SIMD group) | {n} | "
        f"{t_new * ns:.0f} | 1 |",
        f"| previous numpy path: u uᵀ products then one (B, 36) @ (36, 36) product per block "
        f"of {_NUMPY_BLOCK} | {n} | {t_prev * ns:.0f} | {t_prev / t_new:.1f}× |",
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
        f"| compiled kernel: eigenvalues of the dimensionless Gram matrix P Pᵀ by cyclic "
        f"Jacobi (SVD above cond {GRAM_COND_LIMIT:.0e}) | {nc} | {c_cond * nsc:.0f} | 1 |",
        f"| previous numpy path: `eigvalsh` of the Gram matrix (same rule) | {nc} | "
        f"{c_prev_only * nsc:.0f} | {c_prev_only / c_cond:.1f}× |",
        f"| batched SVD of the dimensionless leg matrix | {nc} | {t_c_svd * nsc:.0f} | "
        f"{t_c_svd / c_cond:.1f}× |",
        "",
        f"largest relative difference of cond(P) from the SVD's: {c_err:.1e}; from the "
        f"previous numpy path's: {c_err_prev:.1e}",
        "",
        f"First call of the kernels (K and cond(P)) in a new process: {t_compile:.2f} s with "
        f"an empty numba cache (compiled once per installation), {1e3 * t_load:.0f} ms when "
        "loaded from the cache.",
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
