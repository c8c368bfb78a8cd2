"""``linkwright draw``: the drawings (PNG) and the offline animation (HTML) of a study.

``analyze`` studies: the mechanism at its sweep's closed poses with the point paths
(``mechanism.png``, ``mechanism.html``; the animation subsampled to at most 120 frames).
``synth`` studies: each of the best few variants driven by the engine to its joint values
at every task position, the body's given frames drawn beside the reached ones
(``variant<N>.png``, ``variant<N>.html``).
"""
from __future__ import annotations

import numpy as np

from closure import REACHED, Mechanism, transform

from .draw import html_animation, scene, subsample
from .draw import draw as draw_scene
from .output import Outputs
from .render import figure_png
from .study import Study

__all__ = ["run", "analyze_scene", "synth_scenes", "variant_scenes", "BEST", "FRAMES"]

#: how many of the best-ranked synthesis variants are drawn
BEST = 3
#: largest number of frames of an animation
FRAMES = 120


def analyze_scene(study: Study, mech: Mechanism | None = None, poses=None):
    """The scene of an ``analyze`` study: its mechanism at the sweep's closed poses (the
    study's own sweep, or ``mech`` and its ``poses`` when the caller has swept already)."""
    from .mechspec import build_mechanism, sweep_values
    if mech is None:
        mech = build_mechanism(study.section("mechanism"))
        x = sweep_values(study.section("sweep"), mech)
        df, poses = mech.sweep(x, return_pose=True)
        if not df.status.isin(REACHED).any():
            raise study.error("sweep", "no pose of the sweep closed: nothing to draw")
    points = {}
    for p in study.sections("point", required=False):
        link = p.get("link", "str")
        if link not in mech.links:
            raise p.error("link", f"unknown link {link!r}; links: {', '.join(mech.links)}")
        points[p.get("name", "str")] = (link, p.get("at", "vec3"))
    title = study.data.get("study", {}).get("title", study.path.stem)
    return mech, poses, scene(mech, poses, points=points, title=title)


def _chain_of(row):
    """Joint kinds, Z-along-axis frames and the sphere centre of a variant row: a sphere at
    the body end is left out of the driven chain (its centre returned, else None); ``None``
    where the joints cannot be driven (a sphere before the last joint: its rotation is not
    in the table)."""
    from .cmd_synth import joint_numbers
    ks = joint_numbers(row)
    kinds = [row[f"j{k}_type"] for k in ks]
    centre = None
    if kinds and kinds[-1] == "S":
        centre = np.array([row[f"j{ks[-1]}_{c}"] for c in "xyz"], float)
        ks, kinds = ks[:-1], kinds[:-1]
    if any(t not in "RPCHU" for t in kinds):
        return None
    frames = []
    for k in ks:
        u = np.array([row[f"j{k}_u{c}"] for c in "xyz"], float)
        p = np.array([row[f"j{k}_{c}"] for c in "xyz"], float)
        u = u / np.linalg.norm(u)
        if kinds[k - 1] == "U":          # the engine's U: z along the first axis, x the cross
            a = np.array([row[f"u_cross_{c}"] for c in "xyz"], float)
        else:
            a = np.array([1.0, 0, 0]) if abs(u[0]) < 0.9 else np.array([0, 1.0, 0])
        x = a - (a @ u) * u
        x /= np.linalg.norm(x)
        frames.append(transform(np.stack([x, np.cross(u, x), u], -1), p))
    return kinds, frames, centre


def chain_mechanism(row):
    """The variant's open chain as an engine mechanism, every joint coordinate an input
    (links ``A``, ``B``, ``body``; with a sphere at the body end the chain stops at the
    sphere's link): ``(mechanism, driven joint kinds, sphere centre or None)``, or None
    where the joints cannot be driven."""
    chain = _chain_of(row)
    if chain is None:
        return None
    kinds, frames, centre = chain
    links = ["ground", "A", "B"][:len(kinds)] + ["body"] if centre is None else \
        ["ground", "A", "B"][:len(kinds) + 1]          # ends at the sphere's link
    m = Mechanism(links[1:])
    for k, t in enumerate(kinds):
        pitch = float(row[f"j{k + 1}_pitch"]) if t == "H" else None
        m.add_joint(f"j{k + 1}", t, links[k], links[k + 1], at=frames[k], pitch=pitch)
        m.add_input(f"j{k + 1}", 0)
        if t in "CU":
            m.add_input(f"j{k + 1}", 1)
    return m, kinds, centre


def _values(row, kinds, n):
    cols = []
    for k, t in enumerate(kinds, start=1):
        q = [row.get(f"q{k}_pos{p}", np.nan) for p in range(1, n + 1)]
        d = [row.get(f"d{k}_pos{p}", np.nan) for p in range(1, n + 1)]
        if t == "P":
            cols.append(d if np.all(np.isfinite(np.asarray(d, float))) else q)
        else:
            cols.append(q)
            if t in "CU":                # C: slide; U: the cross axis's angle
                cols.append(d)
    return np.asarray(cols, float).T


def synth_scenes(study: Study, best: int = BEST):
    """The scenes of a ``synth`` study: the best ``best`` variants at every task position.

    Returns
    -------
    list of (variant, Scene, targets (P, 4, 4)); and the number of ranked variants not
    drawn because their joints cannot all be driven (S).
    """
    from .cmd_synth import rank_variants, synthesise
    family, _, df, T, size = synthesise(study)
    crit = study.section("criterion", required=False)
    kind = crit.get("kind", "str", "link_length") if crit else "link_length"
    center = crit.get("center", "vec3", np.zeros(3)) if crit else np.zeros(3)
    ranked = rank_variants(df, kind, center, size, len(T))
    return variant_scenes(ranked, T, family, best)


def variant_scenes(ranked, T, family: str, best: int = BEST):
    """The scenes of the ``best`` best-ranked variants of a ranked synthesis table, each
    driven by the engine to its joint values at every task position ``T (P, 4, 4)``.

    Returns
    -------
    list of (variant, Scene, targets (P, 4, 4)); and the number of ranked variants not
    drawn because their joints cannot all be driven (S).
    """
    rows = ranked[ranked["rank"].notna()].sort_values("rank")
    out, skipped = [], 0
    for _, row in rows.iterrows():
        if len(out) == best:
            break
        chain = chain_mechanism(row)
        if chain is None:
            skipped += 1
            continue
        m, kinds, centre = chain
        links = m.links
        pose = m.solve(_values(row, kinds, len(T)), continuation=False)
        v = int(row.variant)
        if centre is None:
            pts, body = {"body origin": ("body", np.zeros(3))}, pose.link_frame("body")
        else:       # the sphere frees the body's rotation: it is at the task's poses
            pts, body = {"sphere centre": (links[-1], centre)}, T
        scn = scene(m, pose, points=pts, frames={"body": body}, fixed_frames={"given": T},
                    labels=[f"position {p + 1}" for p in range(len(T))],
                    title=f"{family} variant {v} (rank {int(row['rank'])}) at the "
                          f"{len(T)} task positions")
        out.append((v, scn, T))
    return out, skipped


def run(study: Study, out: Outputs, progress) -> dict:
    """Write the drawings and animations of an ``analyze`` or ``synth`` study."""
    if study.command == "analyze":
        progress("sweeping and drawing the mechanism")
        _, _, scn = analyze_scene(study)
        out.add("mechanism.png", figure_png(draw_scene(scn), dpi=110))
        idx = subsample(len(scn), FRAMES)
        out.add("mechanism.html", html_animation(scn.take(idx), limit=FRAMES))
        return {"command": "draw", "study": "analyze", "poses": len(scn),
                "frames": int(len(idx))}
    if study.command == "synth":
        progress("synthesising and drawing the best variants")
        scenes, skipped = synth_scenes(study)
        if not scenes:
            raise study.error("synthesis.family", "no ranked variant can be drawn yet (the "
                              "drawings drive R, P, C, H and U joints, and a sphere at the body end; a sphere "
                              "before the last joint has its rotation missing from the table)")
        for v, scn, _ in scenes:
            out.add(f"variant{v}.png", figure_png(draw_scene(scn), dpi=110))
            out.add(f"variant{v}.html", html_animation(scn, limit=FRAMES))
        return {"command": "draw", "study": "synth", "variants": [v for v, _, _ in scenes],
                "not_drawn": skipped}
    if study.command == "stiffness" and study.has("hexapod"):
        progress("drawing the hexapod at its pose")
        scn, loaded = hexapod_drawing(study)
        out.add("hexapod.png", figure_png(draw_scene(scn), dpi=110))
        out.add("hexapod.html", html_animation(scn, limit=FRAMES))
        return {"command": "draw", "study": "stiffness", "loaded": loaded}
    where = {"stiffness": " (a mechanism stiffness study: its drawing is in its report, "
                          "linkwright stiffness)"}
    raise study.error("study.command", f"linkwright draw draws analyze, synth and hexapod "
                      f"stiffness studies; this is a {study.command} study"
                      + where.get(study.command, " (no drawing of its own)"))


def hexapod_drawing(study: Study):
    """The scene of a hexapod stiffness study at its pose (legs coloured by the load case's
    forces when ``[report] wrench`` is given) and whether it is loaded."""
    from .cmd_stiffness import _singular, hexapod_of, hexapod_scene_of
    hx, T = hexapod_of(study)
    rsec = study.section("report", required=False)
    wrench = rsec.get("wrench", "vec", None, length=6) if rsec else None
    res = hx.stiffness(T, frame="platform")
    if not res.cond_P <= hx.singular_cond:
        raise _singular(study, hx, T, res.cond_P)
    forces = None if wrench is None else hx.leg_forces(T, np.asarray(wrench, float))
    return hexapod_scene_of(hx, T, res, forces), forces is not None
