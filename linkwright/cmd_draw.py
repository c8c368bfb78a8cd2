"""``linkwright draw``: the drawings (PNG) and the offline animation (HTML) of a study.

``analyze`` studies: the mechanism at its sweep's closed poses with the point paths
(``mechanism.png``, ``mechanism.html``; the animation subsampled to at most 120 frames).
``synth`` studies: every regular variant (at most :data:`VIEWER`, the best-ranked)
driven by the engine to its joint values at every task position, the body's given frames
drawn beside the reached ones: a still figure of each of the :data:`BEST` best
(``variant<N>.png``) and one animation with a variant selector (``variants.html``).
``stiffness`` studies: the hexapod (``hexapod.png``, ``hexapod.html``) or the mechanism
(``mechanism.png``, ``mechanism.html``) at its pose, the weakest and stiffest translation
directions as arrows.
"""
from __future__ import annotations

import numpy as np

from closure import REACHED, Mechanism, Pose, transform

from .draw import html_animation, scene, subsample
from .draw import draw as draw_scene
from .output import Outputs
from .render import figure_png
from .study import Study

__all__ = ["run", "analyze_scene", "synth_scenes", "variant_scenes", "regular_variants",
           "chain_mechanism", "sphere_pose", "hexapod_drawing", "mechanism_drawing", "BEST",
           "VIEWER", "FRAMES"]

#: how many of the best-ranked synthesis variants get a still figure of their own
BEST = 3
#: most synthesis variants embedded in an interactive view (the best-ranked ones)
VIEWER = 200
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
    the body end is left out of the driven chain (its centre returned, else None); a sphere
    before the last joint stays in the chain (its frame at its centre, turned by
    :func:`sphere_pose`); ``None`` where the joints cannot be drawn (two spheres, or a
    sphere before the last joint of a chain ending in another)."""
    from .cmd_synth import joint_numbers
    ks = joint_numbers(row)
    kinds = [row[f"j{k}_type"] for k in ks]
    centre = None
    if kinds and kinds[-1] == "S":
        centre = np.array([row[f"j{ks[-1]}_{c}"] for c in "xyz"], float)
        ks, kinds = ks[:-1], kinds[:-1]
    if any(t not in "RPCHUS" for t in kinds) or \
            kinds.count("S") > (0 if centre is not None else 1):
        return None
    return kinds, [_joint_frame(row, k, t) for k, t in zip(ks, kinds)], centre


def _joint_frame(row, k, kind):
    """The engine frame of joint ``k`` (1-based) of a variant row at the first position: Z
    along the axis (U: the first axis, X the cross axis), a sphere's axes the ground's."""
    p = np.array([row[f"j{k}_{c}"] for c in "xyz"], float)
    if kind == "S":
        return transform(np.eye(3), p)
    u = np.array([row[f"j{k}_u{c}"] for c in "xyz"], float)
    u = u / np.linalg.norm(u)
    if kind == "U":                      # the engine's U: z along the first axis, x the cross
        a = np.array([row[f"u_cross_{c}"] for c in "xyz"], float)
    else:
        a = np.array([1.0, 0, 0]) if abs(u[0]) < 0.9 else np.array([0, 1.0, 0])
    x = a - (a @ u) * u
    x /= np.linalg.norm(x)
    return transform(np.stack([x, np.cross(u, x), u], -1), p)


def chain_mechanism(row):
    """The variant's open chain as an engine mechanism, every joint coordinate but a
    sphere's an input (links ``A``, ``B``, ``body``; with a sphere at the body end the
    chain stops at the sphere's link): ``(mechanism, joint kinds, sphere centre or None)``
    (the kinds of the chain's joints, a sphere before the last joint included), or None
    where the joints cannot be drawn."""
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
        if t != "S":
            m.add_input(f"j{k + 1}", 0)
        if t in "CU":
            m.add_input(f"j{k + 1}", 1)
    return m, kinds, centre


def _values(row, kinds, n):
    """The inputs of :func:`chain_mechanism` at the ``n`` task positions, ``(n, inputs)``
    (NaN where the table lacks a value)."""
    cols = []
    for k, t in enumerate(kinds, start=1):
        q = [row.get(f"q{k}_pos{p}", np.nan) for p in range(1, n + 1)]
        d = [row.get(f"d{k}_pos{p}", np.nan) for p in range(1, n + 1)]
        if t == "P":
            cols.append(d if np.all(np.isfinite(np.asarray(d, float))) else q)
        elif t != "S":
            cols.append(q)
            if t in "CU":                # C: slide; U: the cross axis's angle
                cols.append(d)
    return np.asarray(cols, float).T.reshape(n, -1)


def _state_pose(m: Mechanism, X, rot) -> Pose:
    """The engine's poses of an open chain ``m`` whose scalar coordinates are all inputs,
    at inputs ``X (B, n)`` and sphere rotations ``rot (B, ns, 3, 3)``."""
    q0, _ = m.assembly()
    q = np.repeat(q0, len(X), axis=0)
    q[:, m.input_q_columns()] = X
    B = len(X)
    return Pose(m, np.asarray(X, float), q, np.asarray(rot, float), np.zeros(B),
                np.zeros(B, int), np.full(B, np.nan), np.zeros(B, int))


def sphere_pose(m: Mechanism, X, T) -> Pose:
    """The poses of a chain with a sphere before its last joint at the task positions.

    The sphere's rotation is not in the table: at each position it is the relative
    rotation of the sphere's frames on its two links, the one before it placed from the
    ground by the joint values before the sphere, the one after it from the body at the
    task's pose ``T[p]`` taken back by the joint values after the sphere.

    Parameters
    ----------
    m : closure.Mechanism
        The chain of :func:`chain_mechanism` (one S joint, links ending at ``body``).
    X : numpy.ndarray, shape (P, inputs)
        The other joints' values at the P task positions.
    T : numpy.ndarray, shape (P, 4, 4)
        The body's given poses.

    Returns
    -------
    closure.Pose
        Its ``residual`` is the distance (length) between the sphere centre placed from
        the two sides: zero where the variant closes.
    """
    s = next(j.index for j in m.joints if j.kind == "S")
    pose = _state_pose(m, X, np.repeat(m.assembly()[1], len(X), axis=0))   # sphere unturned
    Wa = np.asarray(pose.kinematics(twists=False).frame_a, float)[:, s]     # = frame on b
    Wb = np.asarray(T, float) @ np.linalg.inv(pose.link_frame("body")) @ Wa
    A = np.linalg.inv(Wa) @ Wb                         # the sphere's turn, frame a → frame b
    out = _state_pose(m, X, A[:, None, :3, :3])
    out.residual = np.linalg.norm(A[:, :3, 3], axis=1)
    return out


def regular_variants(ranked):
    """The regular (not degenerate) rows of a ranked table, best-ranked first, the
    unranked ones (residual above the tolerance) after them by variant number."""
    rows = ranked[ranked["reason"].fillna("").astype(str) == ""] if "reason" in ranked \
        else ranked
    return rows.sort_values(["rank", "variant"], na_position="last")


def synth_scenes(study: Study, best: int | None = BEST):
    """The scenes of a ``synth`` study: the best ``best`` variants at every task position.

    Returns
    -------
    list of (variant, Scene, targets (P, 4, 4)); and the number of regular variants not
    drawn (:func:`variant_scenes`).
    """
    from .cmd_synth import rank_variants, synthesise
    family, _, df, T, size = synthesise(study)
    crit = study.section("criterion", required=False)
    kind = crit.get("kind", "str", "link_length") if crit else "link_length"
    center = crit.get("center", "vec3", np.zeros(3)) if crit else np.zeros(3)
    ranked = rank_variants(df, kind, center, size, len(T))
    return variant_scenes(ranked, T, family, best)


def variant_scenes(ranked, T, family: str, best: int | None = BEST):
    """The scenes of the ``best`` best-ranked regular variants of a ranked synthesis table
    (all of them if None; unranked regular ones after the ranked), each driven by the
    engine to its joint values at every task position ``T (P, 4, 4)``.

    Returns
    -------
    list of (variant, Scene, targets (P, 4, 4)); and the number of regular variants not
    drawn (two spheres, or joint values missing from the table).
    """
    T = np.asarray(T, float)
    out, skipped = [], 0
    for _, row in regular_variants(ranked).iterrows():
        chain = _chain_of(row)
        X = None if chain is None else _values(row, chain[0], len(T))
        if X is None or not np.all(np.isfinite(X)):
            skipped += 1
        elif best is None or len(out) < best:
            out.append((int(row.variant), _variant_scene(row, X, T, family), T))
    return out, skipped


def _variant_scene(row, X, T, family: str):
    """The scene of one variant row driven to its joint values ``X`` at the positions
    ``T``: the body's reached frames on the given ones (with a sphere at the body end the
    body, free to turn about it, at the given poses and the centre's path)."""
    m, kinds, centre = chain_mechanism(row)
    pose = sphere_pose(m, X, T) if "S" in kinds else m.solve(X, continuation=False)
    if centre is None:
        pts, body = {"body origin": ("body", np.zeros(3))}, pose.link_frame("body")
    else:       # the sphere frees the body's rotation: it is at the task's poses
        pts, body = {"sphere centre": (m.links[-1], centre)}, T
    rank = row.get("rank", np.nan)
    how = f"rank {int(rank)}" if np.isfinite(rank) else \
        f"not ranked: {row.get('check', 'residual above the tolerance')}"
    return scene(m, pose, points=pts, frames={"body": body}, fixed_frames={"given": T},
                 labels=[f"position {p + 1} of {len(T)}" for p in range(len(T))],
                 title=f"{family} variant {int(row.variant)} ({how})")


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
        progress("synthesising and drawing the variants")
        scenes, skipped = synth_scenes(study, best=VIEWER)
        if not scenes:
            raise study.error("synthesis.family", "no regular variant can be drawn (the "
                              "drawings drive R, P, C, H and U joints and one spherical "
                              "joint; their values must be in the table)")
        for v, scn, _ in scenes[:BEST]:
            out.add(f"variant{v}.png", figure_png(draw_scene(scn), dpi=110))
        out.add("variants.html", html_animation([s for _, s, _ in scenes], limit=FRAMES,
                                                title=f"{study.path.stem}: the variants"))
        return {"command": "draw", "study": "synth", "variants": [v for v, _, _ in scenes],
                "figures": [v for v, _, _ in scenes[:BEST]], "not_drawn": skipped}
    if study.command == "stiffness" and study.has("hexapod"):
        progress("drawing the hexapod at its pose")
        scn, loaded = hexapod_drawing(study)
        out.add("hexapod.png", figure_png(draw_scene(scn), dpi=110))
        out.add("hexapod.html", html_animation(scn, limit=FRAMES))
        return {"command": "draw", "study": "stiffness", "loaded": loaded}
    if study.command == "stiffness" and study.has("mechanism"):
        progress("solving the mechanism and drawing it at its pose")
        scn = mechanism_drawing(study)
        out.add("mechanism.png", figure_png(draw_scene(scn), dpi=110))
        out.add("mechanism.html", html_animation(scn, limit=FRAMES))
        return {"command": "draw", "study": "stiffness", "kind": "mechanism"}
    raise study.error("study.command", f"linkwright draw draws analyze, synth and stiffness "
                      f"studies; this is a {study.command} study (no drawing of its own)")


def mechanism_drawing(study: Study):
    """The scene of a mechanism stiffness study at its pose, the weakest and stiffest
    translation directions of its (unloaded) stiffness as arrows at K's reference point:
    the report's drawing."""
    from .cmd_stiffness import mechanism_of, mechanism_scene_of, mechanism_title
    ms = mechanism_of(study)
    return mechanism_scene_of(ms.mech, ms.pose, ms.res, mechanism_title(study))


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
