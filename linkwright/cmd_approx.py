"""``linkwright approx``: a 1-DOF mechanism or the seed's closed form, a range, and δ / n /
knots → the coefficient table, error figures, plots of the analogs and of the drive force."""
from __future__ import annotations

import re

import numpy as np
import pandas as pd

from approx import ApproxError, EngineAnalogs, cylinder, fit, fit_least_squares
from approx.fit import MAX_N

from .mechspec import build_mechanism, coordinate_unit
from .output import Outputs
from .render import DIMENSIONLESS, Report, fmt_num, fmt_q, quantity
from .study import Study


def _source(study: Study, sec: Study, a, b):
    kind = sec.get("source", "str", choices=("oscillating_cylinder", "mechanism"))
    if kind == "oscillating_cylinder":
        cy = study.section("cylinder", required=False)
        B = cy.get("B", "float", cylinder.B, low=0) if cy else cylinder.B
        B0 = cy.get("B0", "float", cylinder.B0, low=0) if cy else cylinder.B0
        B3 = cy.get("B3", "float", cylinder.B3, low=0) if cy else cylinder.B3
        for key, v in (("B0", B0), ("B3", B3)):
            if not v > 0:
                raise cy.error(key, f"expected a length > 0 (m), got {v}")
        if cy and not abs(B0 - B3) < B < B0 + B3:     # the triangle B0, B3, B closes
            raise cy.error("B", f"the cylinder assembles only for |B0 − B3| < B < B0 + B3 = "
                                f"{B0 + B3:g} m (B0 = {B0:g} m, B3 = {B3:g} m), got B = {B:g} m")
        return ((lambda x: cylinder.f3(x, B, B0, B3)), (lambda x: cylinder.psi31(x, B, B0, B3)),
                (lambda x: cylinder.dpsi31(x, B, B0, B3)), "closed form (seed 004)", B3,
                ("m", "rad"))
    mech = build_mechanism(study.section("mechanism"))
    o = sec.section("output")
    try:
        ex = EngineAnalogs(mech, o.get("joint", "str"), a, b, index=o.get("index", "int", 0),
                           offset=o.get("offset", "float", 0.0), sign=o.get("sign", "float", 1.0))
    except ApproxError as e:
        key = str(e).split(":", 1)[0]
        if key in ("joint", "index", "offset", "sign"):
            raise o.error(key, str(e)) from None
        if key == "mechanism":
            raise study.error("mechanism", str(e)) from None
        raise sec.error("b" if key == "a, b" else "a", str(e)) from None
    return (ex.position, ex.velocity, ex.acceleration, "closure engine", None,
            (coordinate_unit(mech, mech.input_labels()[0]), coordinate_unit(mech, o.get("joint", "str"))))


def _fit_key(message: str, a: float, b: float, given: str) -> str:
    """The ``[approx]`` key a fit error is about: the one it names; for an analog that is
    not finite at some x (a range beyond the mechanism's reach), ``b`` (``a`` when x is
    at a); else the knot rule given (delta, n or knots)."""
    key = message.split(":", 1)[0]
    if key in ("gamma", "knots", "delta", "n"):
        return key
    m = re.search(r"at x = ([-+0-9.eE]+)", message)
    if key in ("f", "df", "d2f") or m:
        try:
            x = float(m.group(1)) if m else b
        except ValueError:
            x = b
        return "a" if abs(x - a) <= 1e-9 * max(1.0, abs(a), abs(b)) else "b"
    return given


def run(study: Study, out: Outputs, progress) -> dict:
    sec = study.section("approx")
    a, b = sec.get("a"), sec.get("b")
    if not a < b:
        raise sec.error("b", f"expected b > a = {a}, got {b}")
    f, df, d2f, source, arm, (xu, fu) = _source(study, sec, a, b)
    given = [k for k in ("delta", "n", "knots") if sec.has(k)]
    if len(given) != 1:
        raise sec.error("delta", "give exactly one of delta, n, knots")
    kw = {"gamma": sec.get("gamma", "float", None, low=0.0)}
    if given[0] == "delta":
        kw["delta"] = sec.get("delta", low=1e-12)
    elif given[0] == "n":
        kw["n"] = sec.get("n", "int", low=1, high=MAX_N)
    else:
        kw["knots"] = sec.get("knots", "vec")
    progress(f"fitting the acceleration analog on [{a}, {b}] ({given[0]})")
    try:
        an = fit(f, df, d2f, a, b, **kw)
        ls = fit_least_squares(f, df, d2f, an.knots, gamma=an.gamma)
    except ApproxError as e:
        raise sec.error(_fit_key(str(e), a, b, given[0]), str(e)) from None
    out.add_csv("coefficients.csv", an.table)
    out.add_csv("coefficients_least_squares.csv", ls.table)
    x = np.linspace(a, b, 301)
    samples = pd.DataFrame({"x": x, "f": f(x), "F": an.position(x), "F_ls": ls.position(x),
                            "df": df(x), "dF": an.velocity(x), "d2f": d2f(x),
                            "d2F": an.acceleration(x)})
    out.add_csv("analogs.csv", samples)
    e_i, e_l = an.errors(f, df, d2f), ls.errors(f, df, d2f)
    u = {"F": fu, "dF": f"{fu}/{xu}", "d2F": f"{fu}/{xu}²"}
    su = f"({fu}/{xu})^½"                  # σ² = γ ∫ (f'' − F'')² dx, γ in 1/(f'' unit)
    rep = Report("Piecewise-linear acceleration analog")
    rng = f"on [{fmt_num(a)}, {fmt_num(b)}] {xu}"
    smax = fmt_q(float(an.sigma.max()), su)
    first = {"delta": f"{an.n} intervals {rng} are needed for the error asked, σ ≤ δ = "
                      f"{fmt_q(kw.get('delta', np.nan), su)}; largest σ achieved {smax} "
                      f"({an.method}).",
             "n": f"{an.n} intervals {rng}, as asked, knots placed to minimise the largest "
                  f"σ: largest σ achieved {smax} ({an.method}).",
             "knots": f"{an.n} intervals {rng} from the knots given: largest σ {smax}."}
    rep.findings(
        first[given[0]],
        f"Achieved error of the interpolating analog: |F − f| ≤ {fmt_q(e_i['max_abs_F'], u['F'], 3)}, "
        f"|F' − f'| ≤ {fmt_q(e_i['max_abs_dF'], u['dF'], 3)}, |F'' − f''| ≤ "
        f"{fmt_q(e_i['max_abs_d2F'], u['d2F'], 3)}; least squares on the same knots: "
        f"|F'' − f''| ≤ {fmt_q(e_l['max_abs_d2F'], u['d2F'], 3)}.")
    rep.text(f"Study: {study.path.name}. Exact analogs from the {source}; input x in {xu}, "
             f"output f in {fu}; range [{fmt_num(a)}, {fmt_num(b)}] {xu}; {an.method}; "
             f"γ = {fmt_q(an.gamma, f'{xu}²/{fu}')} ({an.gamma_rule or 'given'}).")
    rep.heading("Coefficients (formulas 2–4 of seed 004), σ by formula (1)")
    rep.text("F'' = k x + b, F' = k x²/2 + b x + c, F = k x³/6 + b x²/2 + c x + d on "
             "[x0, x1].")
    rep.table(an.table, "{:.6g}", units={"x0": xu, "x1": xu, "k": f"{fu}/{xu}³",
                                         "b": f"{fu}/{xu}²", "c": f"{fu}/{xu}", "d": fu,
                                         "sigma": su})
    rep.heading("Errors: interpolation and least squares (same knots, end conditions)")
    rep.table(pd.DataFrame([{"variant": "interpolation", **e_i},
                            {"variant": "least squares", **e_l}]), "{:.3e}",
              units={"max_abs_F": u["F"], "max_abs_dF": u["dF"], "max_abs_d2F": u["d2F"]})

    def plot_d2(ax):
        ax.plot(x, d2f(x), "k--", label="exact f''")
        ax.plot(x, an.acceleration(x), label="F'' (interpolation)")
        ax.plot(x, ls.acceleration(x), label="F'' (least squares)")
        for k in an.knots:
            ax.axvline(k, color="0.8", lw=0.8)
        ax.set_xlabel(f"x ({xu})")
        ax.set_ylabel(f"acceleration analog f'' ({u['d2F']})")
        ax.legend()
    rep.figure("acceleration_analog.png", plot_d2)
    summary = {"command": "approx", "intervals": int(an.n),
               "max_sigma": quantity(float(an.sigma.max()), su),
               "gamma": quantity(float(an.gamma), f"{xu}²/{fu}"),
               **{f"interp_{k}": quantity(v, u[k.split("_")[-1]]) for k, v in e_i.items()},
               **{f"ls_{k}": quantity(v, u[k.split("_")[-1]]) for k, v in e_l.items()}}
    if given[0] == "delta":
        summary["delta"] = quantity(kw["delta"], su)
    fsec = study.section("force", required=False)
    if fsec:
        mass = fsec.get("mass", low=0.0)
        L = fsec.get("arm", "float", arm if arm is not None else 1.0, low=0.0)
        tau = fsec.get("duration", "float", cylinder.TAU, low=1e-9)
        stroke = fsec.get("stroke", "float", b - a)
        if not 0 < stroke <= (b - a) * (1 + 1e-12):
            raise fsec.error("stroke", f"expected 0 < stroke ≤ b − a = {b - a:g} (m): the "
                                       f"drive law moves from a by the stroke, got {stroke:g}")
        t = np.linspace(0, tau, 401)
        q, qd, qdd = cylinder.drive_law(t, tau, stroke)
        q = a + q
        I = mass * L * L
        exact = df(q) * I * (df(q) * qdd + d2f(q) * qd ** 2)
        Qa, Ql = an.force(q, qd, qdd, I), ls.force(q, qd, qdd, I)
        fr = pd.DataFrame({"t": t, "q": q, "Q_exact": exact, "Q_interp": Qa, "Q_ls": Ql})
        out.add_csv("force.csv", fr)
        rms = lambda e: float(np.sqrt(np.mean(e ** 2)) / np.sqrt(np.mean(exact ** 2)))
        rep.heading("Drive force Q = Ψ m L² q̈ (seed 004, formula 5)")
        rep.text(f"m = {fmt_q(mass, 'kg')}, L = {fmt_q(L, 'm')}, τ = {fmt_q(tau, 's')}; RMS "
                 f"error: interpolation {100 * rms(Qa - exact):.3f} %, least squares "
                 f"{100 * rms(Ql - exact):.3f} %.")
        rep.findings(f"Drive force over τ = {fmt_q(tau, 's')}: peak |Q| = "
                     f"{fmt_q(float(np.abs(exact).max()), 'N')}; RMS error of the analog "
                     f"{100 * rms(Qa - exact):.3f} % (interpolation), "
                     f"{100 * rms(Ql - exact):.3f} % (least squares).")

        def plot_q(ax):
            ax.plot(t, exact, "k--", label="exact")
            ax.plot(t, Qa, label="interpolation")
            ax.plot(t, Ql, label="least squares")
            ax.set_xlabel("t (s)")
            ax.set_ylabel("Q (N)")
            ax.legend()
        rep.figure("drive_force.png", plot_q)
        summary.update(force_rms_interp=quantity(rms(Qa - exact), DIMENSIONLESS),
                       force_rms_ls=quantity(rms(Ql - exact), DIMENSIONLESS),
                       force_peak=quantity(float(np.abs(exact).max()), "N"))
    rep.add_to(out)
    return summary
