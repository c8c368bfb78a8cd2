"""Drawings of mechanisms from the engine's poses: scene data, a matplotlib 3D figure and a
self-contained HTML animation.

:func:`scene` turns a :class:`closure.Mechanism` and a batch of its solved poses into plain
data (numpy arrays and lists): every joint's position and axis per frame, read from the
pose's joint frames, the links as polylines between the joints they carry, the ground joints
marked, point paths and extra frames (e.g. a body's given poses).  :func:`draw` makes a 3D
figure of a scene (equal axis scales); :func:`html_animation` an offline page with a slider
over the frames, drag to rotate and the wheel to zoom (inline script, no network).
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Scene", "scene", "hexapod_scene", "draw", "html_animation", "scene_json",
           "subsample", "force_color"]


@dataclass
class Scene:
    """Plain drawing data of a mechanism at F frames (poses).

    Attributes
    ----------
    joints : list of dict
        Per joint: ``name``, ``kind`` (R, P, C, H, U, S), ``links`` (a, b), ``ground``
        (True when one of its links is the ground).
    links : list of dict
        Per moving link: ``name`` and ``vertices``: the polyline's vertices as
        ``("joint", index, side)`` (side ``"a"`` or ``"b"``: the joint's frame on that
        link) or ``("point", name)``; optionally ``color`` (a CSS/matplotlib colour, e.g.
        a leg coloured by its force) and ``note`` (shown in the legend).
    position : numpy.ndarray, shape (F, J, 3)
        Origin of each joint's frame on its link *a* (world).
    axis : numpy.ndarray, shape (F, J, 3)
        Z axis of that frame (the joint's axis; U: link *a*'s pin).
    position_b, axis_b : numpy.ndarray, shape (F, J, 3)
        Origin and Z axis of the joint's frame on link *b* (P, C, H: slid along the axis;
        U: link *b*'s pin).
    paths : dict of str to numpy.ndarray (F, 3)
        Point paths.
    frames : dict of str to numpy.ndarray (F, 4, 4)
        Moving frames to draw as triads (e.g. a body's reached poses).
    fixed_frames : dict of str to numpy.ndarray (K, 4, 4)
        Frames drawn at every frame (e.g. the body's given poses).
    labels : list of str
        One caption per frame.
    title : str
    arrows : dict of str to (numpy.ndarray (F, 2, 3), colour)
        Arrows per frame: origin and vector (world, length units), and their colour
        (e.g. a stiffness report's weakest and stiffest directions).
    """

    joints: list
    links: list
    position: np.ndarray
    axis: np.ndarray
    position_b: np.ndarray
    axis_b: np.ndarray
    paths: dict = field(default_factory=dict)
    frames: dict = field(default_factory=dict)
    fixed_frames: dict = field(default_factory=dict)
    labels: list = field(default_factory=list)
    title: str = ""
    arrows: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return self.position.shape[0]

    def take(self, idx) -> "Scene":
        """The scene at frames ``idx`` (fixed frames kept)."""
        idx = np.asarray(idx, int)
        return Scene(self.joints, self.links, self.position[idx], self.axis[idx],
                     self.position_b[idx], self.axis_b[idx],
                     {k: v[idx] for k, v in self.paths.items()},
                     {k: v[idx] for k, v in self.frames.items()}, dict(self.fixed_frames),
                     [self.labels[i] for i in idx] if self.labels else [], self.title,
                     {k: (v[idx], c) for k, (v, c) in self.arrows.items()})

    def points(self) -> np.ndarray:
        """Every drawn point of every frame, ``(N, 3)`` (for the bounds)."""
        parts = [self.position.reshape(-1, 3), self.position_b.reshape(-1, 3)]
        parts += [p.reshape(-1, 3) for p in self.paths.values()]
        parts += [f[..., :3, 3].reshape(-1, 3) for f in self.frames.values()]
        parts += [f[..., :3, 3].reshape(-1, 3) for f in self.fixed_frames.values()]
        parts += [(a[:, 0] + a[:, 1]).reshape(-1, 3) for a, _ in self.arrows.values()]
        P = np.concatenate(parts)
        return P[np.all(np.isfinite(P), axis=1)]

    def size(self) -> float:
        """The drawing's length scale: the bounding box's diagonal (1 if a point)."""
        P = self.points()
        d = float(np.linalg.norm(np.ptp(P, axis=0))) if len(P) else 0.0
        return d if d > 0 else 1.0

    def vertices(self, link: dict) -> np.ndarray:
        """The polyline of ``link`` at every frame, ``(F, n, 3)``."""
        out = []
        for v in link["vertices"]:
            if v[0] == "joint":
                out.append((self.position if v[2] == "a" else self.position_b)[:, v[1]])
            else:
                out.append(self.paths[v[1]])
        return np.stack(out, 1)


def _frames_arg(name, value, B):
    out = {}
    for k, T in dict(value or {}).items():
        T = np.asarray(T, float)
        if T.ndim == 2:
            T = np.broadcast_to(T, (B, 4, 4))
        if T.shape[-2:] != (4, 4):
            raise ValueError(f"{name}[{k!r}]: expected 4x4 transforms, got shape {T.shape}")
        out[str(k)] = T
    return out


def scene(mechanism, pose_or_poses, *, points=None, frames=None, fixed_frames=None,
          labels=None, title: str = "") -> Scene:
    """The drawing data of ``mechanism`` at a batch of solved poses.

    Parameters
    ----------
    mechanism : closure.Mechanism
    pose_or_poses : closure.Pose
        Solved poses (a batch or one); only closed poses should be passed.
    points : dict of str to (link, xyz), optional
        Points to trace: a link name and the point's ground coordinates at the assembly
        pose; each becomes a path and a vertex of its link's polyline.
    frames : dict of str to (F, 4, 4) or (4, 4), optional
        Moving frames to draw as triads, one per pose.
    fixed_frames : dict of str to (K, 4, 4), optional
        Frames drawn in every frame (e.g. given task poses).
    labels : list of str, optional
        A caption per pose (default: the inputs).
    title : str

    Returns
    -------
    Scene
    """
    pose = pose_or_poses
    if getattr(pose, "mechanism", None) is not mechanism:
        raise ValueError("pose_or_poses: expected poses of this mechanism (Mechanism.solve "
                         "or Mechanism.sweep(..., return_pose=True))")
    ks = pose.kinematics(twists=False)
    Fa = np.asarray(ks.frame_a, float)                 # (B, J, 4, 4) world frames on link a
    Fb = Fa @ np.asarray(ks.A, float)                  # world frames on link b
    B = Fa.shape[0]
    ground = mechanism.ground
    joints = [{"name": j.name, "kind": j.kind, "links": [j.link_a, j.link_b],
               "ground": ground in (j.link_a, j.link_b)} for j in mechanism.joints]
    paths, on_link = {}, {}
    for name, spec in dict(points or {}).items():
        try:
            link, xyz = spec
        except (TypeError, ValueError):
            raise ValueError(f"points[{name!r}]: expected (link, xyz)") from None
        paths[str(name)] = np.asarray(pose.point(link, xyz), float).reshape(B, 3)
        on_link.setdefault(link, []).append(str(name))
    links = []
    for ln in mechanism.links:
        if ln == ground:
            continue
        verts = [("joint", j.index, "a" if j.link_a == ln else "b") for j in mechanism.joints
                 if ln in (j.link_a, j.link_b)]
        verts += [("point", n) for n in on_link.get(ln, [])]
        verts = _order(verts, Fa, Fb, paths)
        links.append({"name": ln, "vertices": verts})
    if labels is None:
        labs = mechanism.input_labels()
        X = np.asarray(pose.inputs, float).reshape(B, -1)
        labels = [", ".join(f"{lab} = {x:.4g}" for lab, x in zip(labs, row)) for row in X]
    labels = [str(s) for s in labels]
    if len(labels) != B:
        raise ValueError(f"labels: expected {B} captions, one per pose, got {len(labels)}")
    return Scene(joints, links, Fa[..., :3, 3].copy(), Fa[..., :3, 2].copy(),
                 Fb[..., :3, 3].copy(), Fb[..., :3, 2].copy(), paths,
                 _frames_arg("frames", frames, B),
                 {k: v.reshape(-1, 4, 4) for k, v in _frames_arg("fixed_frames", fixed_frames,
                                                                1).items()},
                 labels, title)


def force_color(f: float, scale: float) -> str:
    """A diverging colour of a force ``f`` against ``scale`` > 0 (N): tension red,
    compression blue, zero grey."""
    t = float(np.clip(f / scale, -1.0, 1.0)) if scale > 0 else 0.0
    grey, end = np.array([0.6, 0.6, 0.6]), (np.array([0.84, 0.15, 0.16]) if t > 0 else
                                            np.array([0.12, 0.35, 0.80]))
    c = grey + abs(t) * (end - grey)
    return "#" + "".join(f"{int(round(255 * v)):02x}" for v in c)


def hexapod_scene(base, platform, pose, *, forces=None, arrows=None, title: str = "") -> Scene:
    """The drawing data of a hexapod (or any parallel platform of legs between base and
    platform points) at one pose: base joints as Hooke crosses on the ground, platform
    joints as balls, each leg a link, optionally coloured by its axial force.

    Parameters
    ----------
    base : array_like, shape (n, 3)
        Base attachment points (ground frame, m).
    platform : array_like, shape (n, 3)
        Platform attachment points (platform frame, m).
    pose : array_like, shape (4, 4)
        The platform's pose in the ground frame.
    forces : array_like, shape (n,), optional
        Axial leg forces (N, tension positive): colours (:func:`force_color`) and legend.
    arrows : dict of str to ((3,), (3,), colour), optional
        Arrows to draw: origin, vector (m) and colour.
    title : str

    Returns
    -------
    Scene
        One frame; joint ``k`` (k < n) is base point k, ``n + k`` platform point k.
    """
    B = np.asarray(base, float).reshape(-1, 3)
    T = np.asarray(pose, float).reshape(4, 4)
    Pw = np.asarray(platform, float).reshape(-1, 3) @ T[:3, :3].T + T[:3, 3]
    n = len(B)
    if Pw.shape != B.shape:
        raise ValueError(f"platform: expected {n} points like base, got {len(Pw)}")
    u = Pw - B
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    a = np.where(np.abs(u[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    p1 = np.cross(u, a)
    p1 /= np.linalg.norm(p1, axis=1, keepdims=True)          # the cross's two pins ⊥ the leg
    p2 = np.cross(u, p1)
    joints = ([{"name": f"base {k + 1}", "kind": "U", "links": ["ground", f"leg {k + 1}"],
                "ground": True} for k in range(n)]
              + [{"name": f"platform {k + 1}", "kind": "S", "links": [f"leg {k + 1}", "platform"],
                  "ground": False} for k in range(n)])
    f = None if forces is None else np.asarray(forces, float).reshape(n)
    scale = float(np.abs(f).max()) if f is not None else 0.0
    links = []
    for k in range(n):
        ln = {"name": f"leg {k + 1}", "vertices": [("joint", k, "a"), ("joint", n + k, "a")]}
        if f is not None:
            ln["color"], ln["note"] = force_color(f[k], scale), f"{f[k]:.4g} N"
        links.append(ln)
    links.append({"name": "platform", "vertices": [("joint", n + k, "a") for k in range(n)],
                  "color": "#444444"})
    pos = np.concatenate([B, Pw])[None]
    ax = np.concatenate([p1, u])[None]
    ax_b = np.concatenate([p2, u])[None]
    arr = {str(k): (np.stack([np.asarray(o, float), np.asarray(v, float)])[None], c)
           for k, (o, v, c) in dict(arrows or {}).items()}
    return Scene(joints, links, pos, ax, pos.copy(), ax_b, {}, {"platform": T[None]}, {},
                 ["pose"], title, arr)


def _order(verts, Fa, Fb, paths):
    """Vertices of a link in polygon order (by angle about their centroid at the first pose,
    in their best-fitting plane)."""
    if len(verts) < 3:
        return verts
    P = np.array([(Fa if v[2] == "a" else Fb)[0, v[1], :3, 3] if v[0] == "joint"
                  else paths[v[1]][0] for v in verts])
    c = P.mean(0)
    _, _, Vt = np.linalg.svd(P - c)
    ang = np.arctan2((P - c) @ Vt[1], (P - c) @ Vt[0])
    return [verts[i] for i in np.argsort(ang, kind="stable")]


def subsample(n: int, limit: int = 120) -> np.ndarray:
    """At most ``limit`` indices of ``range(n)``, evenly spread, first and last included."""
    if n <= limit:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, limit)).astype(int))


# ---------------------------------------------------------------------- matplotlib
_COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2",
           "#17becf", "#bcbd22", "#7f7f7f"]


def _basis(z):
    z = z / np.linalg.norm(z)
    a = np.array([1.0, 0, 0]) if abs(z[0]) < 0.9 else np.array([0, 1.0, 0])
    x = a - (a @ z) * z
    x /= np.linalg.norm(x)
    return x, np.cross(z, x), z


def _view(P):
    """``(elev, azim)`` in degrees: looking at the points' plane, tilted 30°."""
    c = P - P.mean(0)
    if len(P) < 3:
        return 25.0, -60.0
    _, s, Vt = np.linalg.svd(c, full_matrices=False)
    n = Vt[-1] if s[-1] <= 0.2 * s[0] else np.array([1.0, -1.0, 1.0]) / np.sqrt(3)
    if n[2] < 0:
        n = -n
    t = Vt[0] if s[-1] <= 0.2 * s[0] else np.array([0, 0, 1.0])
    t = t - (t @ n) * n
    t = t / np.linalg.norm(t) if np.linalg.norm(t) > 1e-9 else _basis(n)[0]
    v = np.cos(np.radians(30)) * n + np.sin(np.radians(30)) * t
    v /= np.linalg.norm(v)
    return float(np.degrees(np.arcsin(np.clip(v[2], -1, 1)))), float(np.degrees(np.arctan2(v[1], v[0])))


def _cylinder(ax, p, z, r, h, color, alpha):
    x, y, z = _basis(z)
    th = np.linspace(0, 2 * np.pi, 16)
    s = np.array([-h / 2, h / 2])
    TH, S = np.meshgrid(th, s)
    X = p[:, None, None] + r * (np.cos(TH) * x[:, None, None] + np.sin(TH) * y[:, None, None]) \
        + S * z[:, None, None]
    ax.plot_surface(X[0], X[1], X[2], color=color, alpha=alpha, linewidth=0, shade=True)


def _ball(ax, p, r, color, alpha):
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 14), np.linspace(0, np.pi, 8))
    ax.plot_surface(p[0] + r * np.cos(u) * np.sin(v), p[1] + r * np.sin(u) * np.sin(v),
                    p[2] + r * np.cos(v), color=color, alpha=alpha, linewidth=0, shade=True)


def _box(ax, p, z, r, h, color, alpha):
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection
    x, y, z = _basis(z)
    c = [p + sx * r * x + sy * r * y + sz * h / 2 * z
         for sz in (-1, 1) for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    faces = [[c[0], c[1], c[2], c[3]], [c[4], c[5], c[6], c[7]]] + \
        [[c[i], c[(i + 1) % 4], c[(i + 1) % 4 + 4], c[i + 4]] for i in range(4)]
    ax.add_collection3d(Poly3DCollection(faces, facecolor=color, edgecolor="k", alpha=alpha,
                                         linewidths=0.4))


def _ground(ax, p, z, r, alpha):
    """A hatched ground mark below the joint: a bar across the axis with slanted ticks."""
    x, y, _ = _basis(z)
    down = -y if y[2] > 0 else y
    base = p + 1.6 * r * down
    a, b = base - 1.8 * r * x, base + 1.8 * r * x
    ax.plot(*np.c_[a, b], color="k", lw=1.2, alpha=alpha)
    for t in np.linspace(0, 1, 6):
        q = a + t * (b - a)
        ax.plot(*np.c_[q, q + 0.8 * r * (down - 0.6 * x)], color="k", lw=0.8, alpha=alpha)


def draw(scn: Scene, ax=None, *, frames=None, figsize=(6.4, 5.6)):
    """A matplotlib 3D drawing of a scene.

    Parameters
    ----------
    scn : Scene
    ax : mpl_toolkits.mplot3d.Axes3D, optional
        Draw into these axes (default: a new figure).
    frames : sequence of int, optional
        The frames to draw (default: all up to 6, else 5 evenly spread); earlier ones fainter.
    figsize : (float, float)

    Returns
    -------
    matplotlib.figure.Figure
    """
    if ax is None:
        from .render import _pyplot
        fig = _pyplot().figure(figsize=figsize)
        ax = fig.add_subplot(projection="3d")
    else:
        fig = ax.figure
    F = len(scn)
    if frames is None:
        frames = list(range(F)) if F <= 6 else [int(i) for i in np.linspace(0, F - 1, 5).round()]
    frames = [int(f) for f in frames]
    if any(not 0 <= f < F for f in frames):
        raise ValueError(f"frames: expected indices in 0 … {F - 1}, got {frames}")
    size = scn.size()
    r = 0.025 * size
    for k, name in enumerate(scn.paths):
        P = scn.paths[name]
        ax.plot(*P.T, color="0.35", lw=1.0, ls="--", label=f"path of {name}")
    for i, f in enumerate(frames):
        alpha = 1.0 if i == len(frames) - 1 else 0.25 + 0.5 * i / max(1, len(frames) - 1)
        for k, link in enumerate(scn.links):
            V = scn.vertices(link)[f]
            if len(V) >= 3:
                V = np.vstack([V, V[:1]])
            if len(V) >= 2:
                name = link["name"] + (f" ({link['note']})" if link.get("note") else "")
                ax.plot(*V.T, color=link.get("color", _COLORS[k % len(_COLORS)]), lw=3.0,
                        alpha=alpha, solid_capstyle="round",
                        label=name if i == len(frames) - 1 else None)
        for j, jt in enumerate(scn.joints):
            p, z = scn.position[f, j], scn.axis[f, j]
            pb, zb = scn.position_b[f, j], scn.axis_b[f, j]
            kind = jt["kind"]
            if kind in "RH":
                _cylinder(ax, p, z, r, 3 * r, "#888888", alpha)
                if kind == "H":
                    x, y, zz = _basis(z)
                    t = np.linspace(-1.5, 1.5, 60)
                    hx = p[:, None] + 1.15 * r * (np.cos(6 * t) * x[:, None] + np.sin(6 * t)
                                                  * y[:, None]) + r * t * zz[:, None]
                    ax.plot(*hx, color="k", lw=0.8, alpha=alpha)
            elif kind in "PC":
                (_box if kind == "P" else _cylinder)(ax, p, z, 1.3 * r, 4 * r, "#bbbbbb",
                                                     0.6 * alpha)
                ax.plot(*np.c_[p, pb], color="k", lw=2.0, alpha=alpha)
            elif kind == "U":
                for q, d in ((p, z), (pb, zb)):
                    ax.plot(*np.c_[q - 2 * r * d, q + 2 * r * d], color="k", lw=2.5, alpha=alpha)
            else:
                _ball(ax, p, 1.3 * r, "#666666", alpha)
            if jt["ground"] and i == len(frames) - 1:
                _ground(ax, p, z, r, 1.0)
        for name, T in scn.frames.items():
            _triad(ax, T[f], 3 * r, alpha, "-")
        for name, (A, col) in scn.arrows.items():
            ax.quiver(*A[f, 0], *A[f, 1], color=col, lw=2.0, alpha=alpha,
                      arrow_length_ratio=0.15, label=name if i == len(frames) - 1 else None)
    for name, T in scn.fixed_frames.items():
        for Tk in T:
            _triad(ax, Tk, 4 * r, 0.9, ":")
    P = scn.points()
    c = (P.max(0) + P.min(0)) / 2 if len(P) else np.zeros(3)
    h = 0.55 * max(float(np.ptp(P, axis=0).max()) if len(P) else 0.0, 1e-9) + 3 * r
    ax.set_xlim(c[0] - h, c[0] + h)
    ax.set_ylim(c[1] - h, c[1] + h)
    ax.set_zlim(c[2] - h, c[2] + h)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(*_view(P))
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_zlabel("z")
    if scn.title:
        ax.set_title(scn.title, fontsize=10)
    ax.legend(fontsize=7, loc="upper left")
    return fig


def _triad(ax, T, L, alpha, ls):
    for k, col in enumerate(("#d62728", "#2ca02c", "#1f77b4")):
        ax.plot(*np.c_[T[:3, 3], T[:3, 3] + L * T[:3, k]], color=col, lw=1.6, ls=ls,
                alpha=alpha)


# ---------------------------------------------------------------------- HTML
def _round(a):
    """Plain lists of floats (JSON keeps every digit: the page draws the engine's numbers)."""
    return np.asarray(a, float).tolist()


def scene_json(scn: Scene) -> dict:
    """The scene as JSON-ready data: static parts, the view (elevation, azimuth in degrees,
    as matplotlib's) and one entry per frame."""
    links = [{"name": ln["name"], "color": ln.get("color", _COLORS[k % len(_COLORS)]),
              "vertices": [list(v) for v in ln["vertices"]]} for k, ln in enumerate(scn.links)]
    frames = []
    for f in range(len(scn)):
        frames.append({"label": scn.labels[f] if scn.labels else str(f),
                       "position": _round(scn.position[f]), "axis": _round(scn.axis[f]),
                       "position_b": _round(scn.position_b[f]), "axis_b": _round(scn.axis_b[f]),
                       "points": {k: _round(v[f]) for k, v in scn.paths.items()},
                       "arrows": {k: _round(v[f]) for k, (v, _) in scn.arrows.items()},
                       "frames": {k: _round(v[f]) for k, v in scn.frames.items()}})
    P = scn.points()
    return {"title": scn.title, "joints": scn.joints, "links": links,
            "arrow_colors": {k: c for k, (_, c) in scn.arrows.items()},
            "paths": {k: _round(v) for k, v in scn.paths.items()},
            "fixed_frames": {k: _round(v) for k, v in scn.fixed_frames.items()},
            "size": scn.size(), "center": _round((P.max(0) + P.min(0)) / 2),
            "view": list(_view(P)), "frames": frames}


def html_animation(scn, *, limit: int = 120, names=None, title: str | None = None) -> str:
    """A self-contained HTML page animating a scene, or several (no network: inline script).

    A slider (and a play button) steps through the frames, subsampled to at most ``limit``;
    drag rotates (orthographic projection), the wheel zooms.  Given several scenes (e.g. a
    synthesis's variants at the task positions) a selector chooses the scene shown; every
    scene is embedded, only its frames are subsampled.  The page reads ``#frame=N`` (and
    ``#frame=N&variant=K``) from its address to start at frame N (of scene K).

    Parameters
    ----------
    scn : Scene or list of Scene
    limit : int
        Largest number of frames of a scene in the page.
    names : list of str, optional
        The selector's entry per scene (default: the scenes' titles).
    title : str, optional
        The page's title (default: the first scene's).

    Returns
    -------
    str
    """
    many = not isinstance(scn, Scene)
    scenes = list(scn) if many else [scn]
    if not scenes or any(len(s) == 0 for s in scenes):
        raise ValueError("scn: a scene has no frames (no closed pose to animate)")
    data = [scene_json(s.take(subsample(len(s), limit))) for s in scenes]
    if many:
        names = [s.title for s in scenes] if names is None else [str(n) for n in names]
        if len(names) != len(scenes):
            raise ValueError(f"names: expected {len(scenes)} names, one per scene, "
                             f"got {len(names)}")
        data = {"variants": data, "names": names}
    else:
        data = data[0]
    data = json.dumps(data, allow_nan=False).replace("</", "<\\/")
    title = (title or scenes[0].title or "mechanism").replace("&", "&amp;").replace("<", "&lt;")
    return _PAGE.replace("@TITLE@", title).replace("@DATA@", data)


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>@TITLE@</title>
<style>
body{font-family:sans-serif;margin:12px;color:#222}
#view{border:1px solid #ccc;cursor:grab;touch-action:none;background:#fff}
#bar{display:flex;gap:10px;align-items:center;margin:6px 0;max-width:720px}
#slider{flex:1}
#pick{margin:6px 0;max-width:720px;font-size:13px}
#sub{color:#555;margin-left:8px}
</style></head><body>
<h3>@TITLE@</h3>
<canvas id="view" width="720" height="540"></canvas>
<div id="pick" hidden><label>variant <select id="variant"></select></label>
<span id="sub"></span></div>
<div id="bar"><button id="play">play</button><input id="slider" type="range" min="0" value="0">
<span id="label"></span></div>
<p style="font-size:12px;color:#666">drag: rotate, wheel: zoom; joints: R/H cylinder, P/C
slot, U cross, S ball; hatched: ground; dashed: point paths, dotted triads: given frames.</p>
<script id="scene-data" type="application/json">@DATA@</script>
<script>
(function(){
"use strict";
var D=JSON.parse(document.getElementById("scene-data").textContent);
var ALL=D.variants||[D],S=ALL[0],vs=document.getElementById("variant");
var cv=document.getElementById("view"),g=cv.getContext("2d");
var sl=document.getElementById("slider"),lab=document.getElementById("label");
var NF=S.frames.length;sl.max=NF-1;
var yaw=(S.view[1]+90)*Math.PI/180,pitch=S.view[0]*Math.PI/180,zoom=1.0,cur=0,timer=null;
function rot(p){var x=p[0]-S.center[0],y=p[1]-S.center[1],z=p[2]-S.center[2];
 var c=Math.cos(yaw),s=Math.sin(yaw),x1=c*x+s*y,y1=-s*x+c*y;
 var cp=Math.cos(pitch),sp=Math.sin(pitch),y2=cp*y1-sp*z,z2=sp*y1+cp*z;
 return [x1,z2,y2];}
function pr(p){var q=rot(p),k=zoom*0.8*Math.min(cv.width,cv.height)/S.size;
 return [cv.width/2+k*q[0],cv.height/2-k*q[1],q[2]];}
function add(p,d,t){return [p[0]+t*d[0],p[1]+t*d[1],p[2]+t*d[2]];}
function line(a,b,col,w,dash){var A=pr(a),B=pr(b);g.beginPath();g.setLineDash(dash||[]);
 g.strokeStyle=col;g.lineWidth=w;g.lineCap="round";g.moveTo(A[0],A[1]);g.lineTo(B[0],B[1]);
 g.stroke();g.setLineDash([]);}
function poly(P,col,w,dash,close){if(P.length<2)return;g.beginPath();g.setLineDash(dash||[]);
 g.strokeStyle=col;g.lineWidth=w;g.lineJoin="round";g.lineCap="round";
 for(var i=0;i<P.length;i++){var A=pr(P[i]);if(i)g.lineTo(A[0],A[1]);else g.moveTo(A[0],A[1]);}
 if(close)g.closePath();g.stroke();g.setLineDash([]);}
function vert(F,v){if(v[0]==="joint")return (v[2]==="a"?F.position:F.position_b)[v[1]];
 return F.points[v[1]];}
function triad(T,L,dash){var o=[T[0][3],T[1][3],T[2][3]],cols=["#d62728","#2ca02c","#1f77b4"];
 for(var k=0;k<3;k++)line(o,add(o,[T[0][k],T[1][k],T[2][k]],L),cols[k],2,dash);}
function render(){
 var F=S.frames[cur],r=0.025*S.size;g.clearRect(0,0,cv.width,cv.height);
 for(var n in S.paths)poly(S.paths[n],"#777",1,[5,4],false);
 for(var n2 in S.fixed_frames)S.fixed_frames[n2].forEach(function(T){triad(T,4*r,[2,3]);});
 S.links.forEach(function(L){var P=L.vertices.map(function(v){return vert(F,v);});
  poly(P,L.color,5,[],P.length>2);});
 var order=S.joints.map(function(j,i){return i;}).sort(function(a,b){
  return pr(F.position[b])[2]-pr(F.position[a])[2];});
 order.forEach(function(i){var j=S.joints[i],p=F.position[i],z=F.axis[i],k=j.kind;
  if(k==="R"||k==="H"){line(add(p,z,-1.5*r),add(p,z,1.5*r),"#555",11);
   line(add(p,z,-1.5*r),add(p,z,1.5*r),"#aaa",7);}
  else if(k==="P"||k==="C"){line(add(p,z,-2*r),add(p,z,2*r),"#333",13);
   line(add(p,z,-2*r),add(p,z,2*r),"#ddd",9);line(p,F.position_b[i],"#111",3);}
  else if(k==="U"){line(add(p,z,-2*r),add(p,z,2*r),"#111",4);
   var zb=F.axis_b[i];line(add(p,zb,-2*r),add(p,zb,2*r),"#111",4);}
  else{var A=pr(p);g.beginPath();g.fillStyle="#666";
   g.arc(A[0],A[1],Math.max(3,1.3*r*zoom*0.8*Math.min(cv.width,cv.height)/S.size),0,6.2832);
   g.fill();}
  if(j.ground){var A2=pr(p);g.strokeStyle="#000";g.lineWidth=1.5;g.beginPath();
   g.moveTo(A2[0]-12,A2[1]+12);g.lineTo(A2[0]+12,A2[1]+12);g.stroke();
   for(var t=-12;t<=8;t+=5){g.beginPath();g.moveTo(A2[0]+t,A2[1]+12);
    g.lineTo(A2[0]+t-5,A2[1]+19);g.stroke();}}});
 for(var n3 in F.points){var A3=pr(F.points[n3]);g.fillStyle="#000";g.beginPath();
  g.arc(A3[0],A3[1],3,0,6.2832);g.fill();}
 for(var n4 in F.frames)triad(F.frames[n4],3*r,[]);
 for(var n5 in (F.arrows||{})){var a0=F.arrows[n5][0],a1=add(a0,F.arrows[n5][1],1),
  c5=S.arrow_colors[n5];line(a0,a1,c5,3);var P0=pr(a0),P1=pr(a1),
  an=Math.atan2(P1[1]-P0[1],P1[0]-P0[0]);g.fillStyle=c5;g.beginPath();g.moveTo(P1[0],P1[1]);
  g.lineTo(P1[0]-10*Math.cos(an-0.4),P1[1]-10*Math.sin(an-0.4));
  g.lineTo(P1[0]-10*Math.cos(an+0.4),P1[1]-10*Math.sin(an+0.4));g.fill();
  g.fillText(n5,P1[0]+4,P1[1]-4);}
 lab.textContent="frame "+(cur+1)+" of "+NF+": "+F.label;}
function setFrame(i){cur=Math.max(0,Math.min(NF-1,i|0));sl.value=cur;render();}
function setVariant(k){var i=Math.max(0,Math.min(ALL.length-1,k|0));S=ALL[i];
 NF=S.frames.length;sl.max=NF-1;vs.value=String(i);
 document.getElementById("sub").textContent=D.names&&D.names[i]!==S.title?S.title:"";
 setFrame(cur);}
if(D.variants){document.getElementById("pick").hidden=false;D.names.forEach(function(n,i){
 var o=document.createElement("option");o.value=String(i);o.textContent=n;vs.appendChild(o);});
 vs.addEventListener("change",function(){setVariant(+vs.value);});}
sl.addEventListener("input",function(){setFrame(+sl.value);});
document.getElementById("play").addEventListener("click",function(){
 if(timer){clearInterval(timer);timer=null;this.textContent="play";return;}
 this.textContent="pause";timer=setInterval(function(){setFrame((cur+1)%NF);},80);});
var drag=null;
cv.addEventListener("pointerdown",function(e){drag=[e.clientX,e.clientY];cv.setPointerCapture(e.pointerId);});
cv.addEventListener("pointermove",function(e){if(!drag)return;yaw+=(e.clientX-drag[0])*0.01;
 pitch+=(e.clientY-drag[1])*0.01;drag=[e.clientX,e.clientY];render();});
cv.addEventListener("pointerup",function(){drag=null;});
cv.addEventListener("wheel",function(e){e.preventDefault();zoom*=Math.exp(-e.deltaY*0.001);
 render();},{passive:false});
var m=/frame=(\\d+)/.exec(location.hash),mv=/variant=(\\d+)/.exec(location.hash);
cur=m?+m[1]:0;setVariant(mv?+mv[1]:0);
})();
</script></body></html>
"""
