"""Benchmark of the dyad family engine (Kharatyan's Table 3): per family the time of one
enumeration, its variants and largest engine residual, how often the generating chain of
random positions built by the family's own construction is recovered, and a multi-start
``scipy.optimize.least_squares`` baseline on the same chain equations.

    python -m linkwright.bench_families [--quick]
"""
from __future__ import annotations

import argparse
import time

import numpy as np


def _unit(v):
    return v / np.linalg.norm(v)


def _fk(types, lines, pitches, vals):
    from synthesis.binary import _screw_matrix
    T = np.eye(4)
    for k, t in enumerate(types):
        a, s = vals[k]
        a = 0.0 if t == "P" else a
        s = 0.0 if t == "R" else pitches[k] * a if t == "H" else s
        T = T @ _screw_matrix(lines[k][0], lines[k][1], a, s)
    return T


def generate(family: str, seed: int, pitch: float = 0.3):
    """Positions built by the family's construction from a random chain (see the tests):
    returns screws, the poses (N, 4, 4), the chain's lines [(u, p)] and its free
    parameters in the table's conventions."""
    from synthesis import Screw
    from synthesis.decompose import arrangements
    rng = np.random.default_rng(seed)
    arr = arrangements(family)
    name, main, x, n_b, k = arr[seed % len(arr)]
    N = n_b + k
    lines = [(_unit(rng.normal(size=3)), rng.normal(size=3)) for _ in range(3)]
    pitches = [pitch if t == "H" else 0.0 for t in family]
    X, F = (0, 1) if name == "a" else (1, 0)
    vals = np.zeros((N, 3, 2))
    for p in range(1, n_b):
        vals[p, F] = rng.uniform(-2.5, 2.5), rng.uniform(-1, 1)
        vals[p, 2] = rng.uniform(-2.5, 2.5), rng.uniform(-1, 1)
    s = int(rng.integers(n_b))
    for p in range(n_b, N):
        vals[p, X] = rng.uniform(-2.5, 2.5), rng.uniform(-1, 1)
        vals[p, F] = vals[s, F]
        vals[p, 2] = vals[s, 2] + (rng.uniform(-2.5, 2.5), rng.uniform(-1, 1))
    T = np.array([_fk(family, lines, pitches, v) for v in vals])
    mi = [1, 2] if name == "a" else [0, 2]
    params = {}
    if "H" in family:
        params["pitch"] = pitch
    if main in ("RC", "CR", "HC", "CH"):
        params["fixed_direction"] = lines[mi[0]][0]
    if "P" in main:
        kp = mi[main.index("P")]
        params["slide_direction"] = lines[kp][0]
        if "C" in main:
            params["prismatic_slide"] = vals[1, kp, 1]
    if (x, family[2]) == ("R", "C"):
        d = vals[-1, 2, 0] - vals[s, 2, 0]
        u = lines[2][0]
        params["transition_angle"] = (-1 if u[np.argmax(np.abs(u))] < 0 else 1) * \
            np.arctan2(np.sin(d), np.cos(d))
    return [Screw.from_matrix(t) for t in T[1:]], T, lines, params


def distance(family, df, lines, size):
    """Smallest distance (rad, or length / size) of a regular row's axes from ``lines``."""
    ok = df[df.reason == ""]
    best = np.inf
    for r in ok.itertuples():
        err = 0.0
        for k in range(3):
            u = np.array([getattr(r, f"j{k + 1}_u{c}") for c in "xyz"])
            p = np.array([getattr(r, f"j{k + 1}_{c}") for c in "xyz"])
            e = np.linalg.norm(np.cross(u, lines[k][0]))
            if family[k] != "P":
                e = max(e, np.linalg.norm(np.cross(lines[k][0], p - lines[k][1])) / size)
            err = max(err, e)
        best = min(best, err)
    return best


def _lsq_baseline(family, screws, T, params, df, starts, rng):
    """Multi-start least squares on the chain equations of arrangement a with main
    positions (1, …, n_b), transition position 1, the free parameters fixed as given:
    unknowns the three lines and the joint values, equations the poses."""
    from scipy.optimize import least_squares

    from synthesis.decompose import arrangements
    from synthesis.validate import task_scale
    name, main, x, n_b, k = [a for a in arrangements(family) if a[0] == "a"][0]
    N = len(T)
    dof = {"R": 1, "H": 1, "P": 1, "C": 2}
    pitch = params.get("pitch", 0.0)
    pitches = [pitch if t == "H" else 0.0 for t in family]
    fixed_dir = params.get("slide_direction")
    n_line = 18
    n_main = (n_b - 1) * (dof[family[1]] + dof[family[2]])
    n_rest = (N - n_b) * (dof[family[0]] + dof[family[2]])

    def unpack(z):
        lines = []
        for j in range(3):
            u, p = z[6 * j:6 * j + 3], z[6 * j + 3:6 * j + 6]
            if family[j] == "P" and fixed_dir is not None and j > 0:
                u = fixed_dir
            if j == 1 and params.get("fixed_direction") is not None:
                u = params["fixed_direction"]
            lines.append((u / np.linalg.norm(u), p))
        vals = np.zeros((N, 3, 2))
        i = n_line
        for p in range(1, n_b):
            for j in (1, 2):
                for c in range(dof[family[j]]):
                    vals[p, j, 1 if family[j] == "P" else c] = z[i]
                    i += 1
        for p in range(n_b, N):
            for j in (0, 2):
                for c in range(dof[family[j]]):
                    off = vals[0, j, 1 if family[j] == "P" else c] if j == 2 else 0.0
                    vals[p, j, 1 if family[j] == "P" else c] = z[i] + off
                    i += 1
        return lines, vals

    def resid(z):
        lines, vals = unpack(z)
        out = []
        for p in range(1, N):
            A = _fk(family, lines, pitches, vals[p])
            out.append((A[:3] - T[p][:3]).ravel())
        out.append([np.linalg.norm(z[6 * j:6 * j + 3]) - 1 for j in range(3)])
        out.append([lines[j][1] @ lines[j][0] for j in range(3)])
        return np.concatenate(out)

    _, _, size = task_scale(T)
    t0 = time.perf_counter()
    conv = missed = 0
    for _ in range(starts):
        z0 = np.r_[rng.normal(size=n_line), rng.uniform(-np.pi, np.pi, n_main + n_rest)]
        r = least_squares(resid, z0, xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=2000)
        if np.abs(r.fun).max() < 1e-9:
            conv += 1
            lines, _ = unpack(r.x)
            if distance(family, df, lines, size) > 1e-6:
                missed += 1
    return time.perf_counter() - t0, conv, missed


def _rot_about(O, R):
    S = np.eye(4)
    S[:3, :3], S[:3, 3] = R, O - R @ O
    return S


PITCH = 0.3


def _joint(kind, u, p, q, slide=0.0):
    """An R, P, H (pitch ``PITCH``) or C (slide ``slide``) joint's screw at value q."""
    from synthesis.binary import _screw_matrix
    return _screw_matrix(u, p, 0.0 if kind == "P" else q,
                         {"R": 0.0, "P": q, "H": PITCH * q, "C": slide}[kind])


def generate_sphere(family: str, seed: int):
    """Positions of a random sphere or Hooke chain built by its construction: ``(screws, T,
    error function of a table row against the generating chain, the chain's free
    parameters as choices of enumerate_dyads)``.  Sphere at the end (RRS, PRS, RPS, RHS,
    HRS, PHS, HPS) or before joint 3 (RSR, SRR, RSP, SRP, RSH, SRH), or a Hooke joint (RUR,
    URR, RUP, URP, RUH, URH, RUC, URC); helical joints of pitch ``PITCH``."""
    from closure import exp_so3
    from synthesis import Screw
    from synthesis.sphere_families import sphere_arrangements
    from synthesis.sphere_middle import middle_arrangements
    rng = np.random.default_rng(seed)
    L = [(_unit(rng.normal(size=3)), rng.normal(size=3)) for _ in range(2)]
    O = rng.normal(size=3)
    if "U" in family:
        return _generate_hooke(family, rng, L, O)
    from synthesis.spherical import azimuth_of, task_frame
    if family[2] == "S":
        arr = sphere_arrangements(family)
        name, main, x, n_b, k = arr[seed % len(arr)]
        N = n_b + k
        X, F = (0, 1) if name == "a" else (1, 0)
        q = np.zeros((N, 2))
        q[1:n_b, F] = rng.uniform(-2.5, 2.5, n_b - 1)
        s = int(rng.integers(n_b))
        q[n_b:, X] = rng.uniform(-2.5, 2.5, k)
        q[n_b:, F] = q[s, F]
        T = np.array([_joint(family[0], *L[0], q[p, 0]) @ _joint(family[1], *L[1], q[p, 1])
                      @ _rot_about(O, exp_so3(rng.normal(size=3) * 0.5) if p else np.eye(3))
                      for p in range(N)])
        lines, ks, main_dir = [L[0], L[1]], 3, L[F][0]
    else:
        name, main, x, n_b, k = middle_arrangements(family)[0]
        Rs = [np.eye(3)] + [exp_so3(rng.normal(size=3) * 0.6) for _ in range(n_b - 1)]
        q3 = [0.0] + list(rng.uniform(-2.5, 2.5, n_b - 1))
        s, qx, d = int(rng.integers(n_b)), rng.uniform(-2.5, 2.5), rng.uniform(-2.5, 2.5)
        Xl, M, y = L[0], L[1], family[2]
        T = [_rot_about(O, Rs[p]) @ _joint(y, *M, q3[p]) for p in range(n_b)]
        if name == "a":
            T.append(_joint("R", *Xl, qx) @ _rot_about(O, Rs[s]) @ _joint(y, *M, q3[s] + d))
            lines, ks = [Xl, None, M], 2
        else:
            T.append(_rot_about(O, Rs[s]) @ _joint("R", *Xl, qx) @ _joint(y, *M, q3[s] + d))
            lines, ks = [None, Xl, M], 1
        T = np.array(T)
        main_dir = M[0]
    screws = [Screw.from_matrix(t) for t in T[1:]]
    choices = {"azimuth": azimuth_of(main_dir, frame=task_frame(screws))}
    if "H" in family:
        choices["pitch"] = PITCH

    def error(r, size):
        e = np.linalg.norm(np.array([getattr(r, f"j{ks}_{c}") for c in "xyz"]) - O) / size
        for k, ln in enumerate(lines, start=1):
            if ln is None or k == ks:
                continue
            u = np.array([getattr(r, f"j{k}_u{c}") for c in "xyz"])
            p = np.array([getattr(r, f"j{k}_{c}") for c in "xyz"])
            e = max(e, np.linalg.norm(np.cross(u, ln[0])))
            if family[k - 1] != "P":
                e = max(e, np.linalg.norm(np.cross(ln[0], p - ln[1])) / size)
        return e
    return screws, T, error, choices


def _generate_hooke(family, rng, L, O):
    from synthesis import Screw
    from synthesis.binary import _about, _rot
    from synthesis.hooke_families import hooke_arrangements
    from synthesis.spherical import azimuth_of, task_frame
    name, main, x, n_b, k = hooke_arrangements(family)[0]
    a = _unit(rng.normal(size=3))
    b = _unit(np.cross(a, rng.normal(size=3)))
    al, ga = ([0.0] + list(rng.uniform(-1.5, 1.5, n_b - 1)) for _ in range(2))
    q3 = [0.0] + list(rng.uniform(-2.5, 2.5, n_b - 1))
    d3 = [0.0] + list(rng.uniform(-1, 1, n_b - 1))          # C joint's slides
    s, qx, d = int(rng.integers(n_b)), rng.uniform(-2.5, 2.5), rng.uniform(-2.5, 2.5)
    e3 = rng.uniform(-1, 1)
    Xl, M, y = L[0], L[1], family[2]

    def U(i):
        return _about(_rot(a, al[i]) @ _rot(b, ga[i]), O)
    T = [U(p) @ _joint(y, *M, q3[p], d3[p]) for p in range(n_b)]
    J3 = _joint(y, *M, q3[s] + d, d3[s] + e3)
    T.append(_joint("R", *Xl, qx) @ U(s) @ J3 if name == "a" else U(s) @ _joint("R", *Xl, qx) @ J3)
    T = np.array(T)
    ku, kx = (2, 1) if name == "a" else (1, 2)
    screws = [Screw.from_matrix(t) for t in T[1:]]
    fr = task_frame(screws)
    choices = {"azimuth": azimuth_of(M[0], frame=fr)}
    if y == "P":
        choices["axis_azimuth"] = azimuth_of(a, frame=fr)
    elif y == "H":
        choices["pitch"] = PITCH
    elif y == "C":
        flip = M[0][np.argmax(np.abs(M[0]))] < 0         # angles about the table's orientation
        choices["centre"] = O
        choices["transition_angle"] = (-1 if flip else 1) * np.arctan2(np.sin(d), np.cos(d))

    def error(r, size):
        e = max(np.linalg.norm(np.array([getattr(r, f"j{ku}_{c}") for c in "xyz"]) - O) / size,
                np.linalg.norm(np.cross([getattr(r, f"j{ku}_u{c}") for c in "xyz"], a)))
        for k, ln in ((kx, Xl), (3, M)):
            u = np.array([getattr(r, f"j{k}_u{c}") for c in "xyz"])
            p = np.array([getattr(r, f"j{k}_{c}") for c in "xyz"])
            e = max(e, np.linalg.norm(np.cross(u, ln[0])))
            if family[k - 1] != "P":
                e = max(e, np.linalg.norm(np.cross(ln[0], p - ln[1])) / size)
        return e
    return screws, T, error, choices


def bench_families(quick: bool = False) -> list[str]:
    """Every implemented family of Table 3: positions, variants, median time of one
    enumeration, largest residual, and the generating chain recovered (with its free
    parameters) over random chains; a multi-start least-squares baseline for a few."""
    from synthesis import enumerate_dyads
    from synthesis.decompose import arrangements
    from synthesis.dyads import implemented_families
    from synthesis.validate import task_scale

    impl = implemented_families()
    fams = sorted(f for f, (how, _) in impl.items() if how == "direct" and f != "RRR"
                  and arrangements(f))
    n_chains = 3 if quick else 20
    timed = {}                                  # family → median ms
    lines_out = ["## synthesis: dyad families of Kharatyan's Table 3", "",
                 "Positions from the family's own construction (random chain, seed 0); "
                 "default grids of the free parameters for the timing; the generating chain "
                 f"searched among the variants for {n_chains} random chains with its free "
                 "parameters passed (axes within 1e-8 rad, points within 1e-8 of the task "
                 "size).", "",
                 "| family | positions | variants | regular | median time (ms) | "
                 "largest residual | generating chain found |",
                 "|---|---|---|---|---|---|---|"]
    for fam in fams:
        screws, T, lines, params = generate(fam, 0)
        base = {"pitch": params["pitch"]} if "pitch" in params else {}
        enumerate_dyads(fam, screws, **base)
        reps = 3 if quick else 7
        times = []
        for _ in range(reps):
            t0 = time.perf_counter()
            df = enumerate_dyads(fam, screws, **base)
            times.append(time.perf_counter() - t0)
        ok = df[df.reason == ""]
        hits = 0
        nc = n_chains
        worst = ok.residual.max() if len(ok) else np.nan
        for seed in range(1, nc + 1):
            s2, T2, l2, p2 = generate(fam, seed)
            d2 = enumerate_dyads(fam, s2, **p2)
            _, _, size = task_scale(T2)
            hits += distance(fam, d2, l2, size) <= 1e-8
            o2 = d2[d2.reason == ""]
            if len(o2):
                worst = max(worst, o2.residual.max())
        timed[fam] = 1e3 * np.median(times)
        lines_out.append(f"| {fam} | {len(T)} | {len(df)} | {len(ok)} | "
                         f"{timed[fam]:.1f} | {worst:.1e} | {hits}/{nc} |")
    for fam in ("RRS", "PRS", "RPS", "RHS", "HRS", "PHS", "HPS", "RSR", "SRR", "RSP", "SRP",
                "RSH", "SRH", "RUR", "URR", "RUP", "URP", "RUH", "URH", "RUC", "URC"):
        slow = "H" in fam
        if quick and slow and fam not in ("RHS", "RUH"):
            continue
        screws, T, _, ch0 = generate_sphere(fam, 0)
        base = {"pitch": PITCH} if "H" in fam else {}
        if slow:                    # the compiled search loads (or compiles) outside the timing
            enumerate_dyads(fam, screws, **base)
        times = []
        for _ in range(1 if quick or slow else 3):
            t0 = time.perf_counter()
            df = enumerate_dyads(fam, screws, **base)
            times.append(time.perf_counter() - t0)
        ok = df[df.reason == ""]
        worst = ok.residual.max() if len(ok) else np.nan
        hits = 0
        nc = 1 if quick else (5 if slow else n_chains)
        for seed in range(1, nc + 1):
            s2, T2, err, ch = generate_sphere(fam, seed)
            d2 = enumerate_dyads(fam, s2, **ch)
            _, _, size = task_scale(T2)
            o2 = d2[d2.reason == ""]
            hits += len(o2) > 0 and min(err(r, size) for r in o2.itertuples()) <= 1e-8
            if len(o2):
                worst = max(worst, o2.residual.max())
        timed[fam] = 1e3 * np.median(times)
        lines_out.append(f"| {fam} | {len(T)} | {len(df)} | {len(ok)} | "
                         f"{timed[fam]:.1f} | {worst:.1e} | {hits}/{nc} |")
    over = sorted((f for f in timed if timed[f] > 50), key=timed.get)
    lines_out += ["", f"Target ≤ 50 ms per task (RRR ≤ 20): {len(timed) - len(over)} of "
                  f"{len(timed)} families timed here meet it" +
                  (f"; over: {', '.join(f'{f} {timed[f]:.0f} ms' for f in over)}." if over
                   else ".")]
    lines_out += ["", "Baseline: multi-start `scipy.optimize.least_squares` (trf, finite "
                  "differences) on the same chain equations (arrangement a, main positions "
                  "1…n_b, transition from position 1, free parameters fixed), random starts; "
                  "a converged solution not among the enumeration's variants is 'missed'.", "",
                  "| family | starts | least squares time (s) | converged | missed by the "
                  "enumeration | enumeration time (ms) | ratio |", "|---|---|---|---|---|---|---|"]
    rng = np.random.default_rng(7)
    starts = 5 if quick else 30
    for fam in (["RPR"] if quick else ["RRR", "RPR", "RCR"]):
        screws, T, lines, params = generate(fam, 2)
        if fam == "RRR":
            params = {}
        t0 = time.perf_counter()
        df = enumerate_dyads(fam, screws, **params)
        t_enum = time.perf_counter() - t0
        t_lsq, conv, missed = _lsq_baseline(fam, screws, T, params, df, starts, rng)
        lines_out.append(f"| {fam} | {starts} | {t_lsq:.2f} | {conv} | {missed} | "
                         f"{1e3 * t_enum:.1f} | {t_lsq / t_enum:.0f}× |")
    return lines_out + [""]


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    print("\n".join(bench_families(ap.parse_args().quick)))
