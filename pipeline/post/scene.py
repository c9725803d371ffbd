"""Off-screen pictures of a whole machine: stills, several positions in one still, and
animations. Flexible links are coloured by their elastic displacement (magnified by a
stated factor); rigid links are grey. pyvista is imported inside the functions."""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from pipeline.core.atomic import atomic_path
from pipeline.core.errors import ConfigError
from pipeline.kinematics import evaluate_tree
from pipeline.kinematics.compiled import coordinate_vector
from pipeline.post.render import _pyvista, save_png
from pipeline.post.views import check_camera, view_direction


def link_poses(mech, q) -> np.ndarray:
    """(n_links, 4, 4) body-to-ground transforms at q (compute once per configuration)."""
    return evaluate_tree(mech, np.asarray(q, dtype=float), derivatives=False).A


def drawn_configuration(mech, q, scale: float) -> np.ndarray:
    """q (n,) with every modal coordinate multiplied by ``scale``: the configuration whose
    link poses (with :func:`drawing_mechanism`) draw a deformation exaggerated ``scale``
    times along the whole chain, so that a link hanging on a flexible one stays on its
    (magnified) tip."""
    q = np.array(coordinate_vector(q, mech.n), dtype=float)
    q[mech.modal_coordinates] *= scale
    return q


_DRAWING: OrderedDict = OrderedDict()  # (id(mech), scale) -> (mech, its drawing mechanism)


def drawing_mechanism(mech, scale: float):
    """``mech`` with every frame's second-order translation (the foreshortening of a bent
    link, ``Frame.hess``) divided by ``scale``: posed at :func:`drawn_configuration`, its
    frames then move by ``scale`` times their true elastic displacement, second-order part
    included, as the links' own fields are drawn. With the true second-order terms the
    magnified amplitudes would draw the foreshortening scale^2 times: at x20 the main job's
    lower bar hung 4 cm (drawn) off the upper bar's tip. ``mech`` itself for scale 0 or 1
    or a machine without second-order terms."""
    if scale in (0.0, 1.0) or not any(f.hess is not None for lk in mech.links
                                       for f in lk.frames):
        return mech
    key = (id(mech), float(scale))
    if key not in _DRAWING:
        from pipeline.kinematics import build_mechanism

        links = [replace(lk, frames=tuple(f if f.hess is None else replace(f, hess=f.hess / scale)
                                          for f in lk.frames)) for lk in mech.links]
        _DRAWING[key] = (mech, build_mechanism(links, mech.joints, mech.ground))
        while len(_DRAWING) > 8:  # a few machines and scales are drawn at a time
            _DRAWING.popitem(last=False)
    return _DRAWING[key][1]


def drawn_poses(mech, q, scale: float) -> np.ndarray:
    """(n_links, 4, 4) the link poses that draw q's deformation ``scale`` times along the
    whole chain (:func:`drawn_configuration` on :func:`drawing_mechanism`)."""
    return link_poses(drawing_mechanism(mech, scale), drawn_configuration(mech, q, scale))


def drawn_joint_points(mech, q, scale: float, poses=None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`joint_points` as drawn at q with the deformation ``scale`` times (``poses``:
    :func:`drawn_poses` at q, computed if None)."""
    return joint_points(drawing_mechanism(mech, scale), drawn_configuration(mech, q, scale),
                        poses)


def posed_points(mech, shape, q, scale: float = 1.0, poses=None) -> tuple[np.ndarray, np.ndarray]:
    """((N, 3) ground points, (N,) elastic displacement magnitude, m) of a link at q.

    The elastic deformation is drawn ``scale`` times: the link is placed by the poses of
    :func:`drawn_configuration` (every modal coordinate times ``scale``, so the joints of a
    chain stay together) and its own field sum_a u_a eta_a is multiplied by ``scale``;
    ``scale`` 1 is the true configuration. The magnitude is the true (unscaled) elastic
    displacement. ``poses``: :func:`drawn_poses` at q, when several links are drawn at the
    same q.
    """
    q = coordinate_vector(q, mech.n)
    li = mech.link_index(shape.link)
    A = (drawn_poses(mech, q, scale) if poses is None else poses)[li]
    return _placed(shape.points, shape.modes, A, q[mech.modal_index[li]], scale)


def joint_points(mech, q, poses=None) -> tuple[np.ndarray, np.ndarray]:
    """((J, 3) ground positions of the joints at q, m; (J,) True where the joint holds a
    link to ground) -- the pivots drawn in pictures."""
    from pipeline.kinematics.poses import step_pose

    q = np.asarray(q, dtype=float)
    A = link_poses(mech, q) if poses is None else poses
    P = np.array([step_pose(mech.marker(j.parent, j.parent_frame), A, q)[:3, 3]
                  for j in mech.joints]).reshape(-1, 3)
    grounded = np.array([mech.ground in (j.parent, j.child) for j in mech.joints], bool)
    return P, grounded


def drawn_joints(mech, shapes=None) -> np.ndarray:
    """(J,) True for the joints drawn with ``shapes`` (LinkShapes by name; None: all): those
    of a drawn link."""
    drawn = None if shapes is None else {s.link for s in shapes.values()}
    return np.array([drawn is None or bool({j.parent, j.child} & drawn)
                     for j in mech.joints], bool)


@dataclass(frozen=True)
class Picture:
    """A still written to ``path``; ``labels``: (text, (x0, y0, x1, y1)) pixel box of each
    label as drawn (origin at the lower left of the image)."""

    path: Path
    labels: tuple = ()


@dataclass(frozen=True)
class Style:
    """How a picture is drawn.

    Attributes
    ----------
    line_px : on-screen width of slender links, beams and the scale bar, pixels (a
        minimum: thick links are drawn as their surface).
    up : (3,) unit vector against gravity, ground axes; draws a ground line (2-D views)
        or plane (3-D) below the machine. None: no ground.
    font_px : label height, pixels.
    color : what flexible links are coloured by: "displacement" (elastic, mm) or
        "von_mises" (stress, MPa; links with stress modes, the others grey).
    frames : draw every link's frames (joint frames, interfaces, markers) as triads, x
        red, y green, z blue (a revolute or prismatic joint's axis is its frames' z), the
        links see-through: a model's preview.
    """

    line_px: float = 6.0
    up: tuple | None = None
    font_px: int = 16
    color: str = "displacement"
    frames: bool = False


def _polydata(pv, points, triangles=None, lines=None):
    if triangles is not None:
        t = np.asarray(triangles)
        return pv.PolyData(points, np.hstack([np.full((len(t), 1), 3), t]).ravel())
    ln = np.asarray(lines)
    return pv.PolyData(points, lines=np.hstack([np.full((len(ln), 1), 2), ln]).ravel())


def _placed(X, fields, A, eta, scale):
    """((N, 3) ground points, (N,) |elastic displacement|) of body points X."""
    flexible = fields is not None and eta.size and fields.shape[0]
    u = np.tensordot(eta, fields, axes=(0, 0)) if flexible else np.zeros_like(X)
    return (X + scale * u) @ A[:3, :3].T + A[:3, 3], np.linalg.norm(u, axis=1)


_SCALARS = "elastic displacement, mm"
_LABELS = {"displacement": _SCALARS, "von_mises": "von Mises stress, MPa"}


def _scalar(shape, X, eta, d, color):
    """Colour values of points X of ``shape``: elastic displacement (mm) or von Mises
    (MPa; a slender link's centre line shows each slice's largest)."""
    if color == "von_mises":
        v = shape.von_mises(eta) if X is shape.points else shape.spine_von_mises(eta)
        return None if v is None else 1e-6 * v
    return 1e3 * d


class _Drawn:
    """The actors of one configuration of the machine, updated in place from frame to
    frame (a new actor per frame costs a full render each)."""

    def __init__(self, plotter, pv, mech, shapes, q, scale, clim, style, opacity=1.0,
                 ghost=False):
        self.mech, self.scale, self.ghost, self.color = mech, scale, ghost, style.color
        self.meshes = []
        lw = style.line_px
        for shape in shapes.values():
            flexible = shape.modes is not None and shape.modes.shape[0] > 0
            parts = [(shape.points, shape.modes,
                      _polydata(pv, shape.points, shape.triangles, shape.lines))]
            spine = shape.spine
            if spine is not None:
                n = len(spine[0])
                parts.append((spine[0], spine[1], _polydata(
                    pv, spine[0], lines=np.column_stack([np.arange(n - 1), np.arange(1, n)]))))
            for X, fields, mesh in parts:
                self.meshes.append((shape, X, fields, mesh))
                is_line = mesh.n_lines > 0
                coloured = flexible and (style.color != "von_mises" or
                                         shape.stress is not None)
                kw = {"line_width": lw, "render_lines_as_tubes": True} if is_line else {}
                if ghost:
                    plotter.add_mesh(mesh, style="wireframe" if not is_line else "surface",
                                     color="darkgrey", opacity=0.5,
                                     line_width=max(1.0, lw / 3) if is_line else 1.0)
                elif coloured:
                    mesh.point_data[_SCALARS] = np.zeros(mesh.n_points)
                    plotter.add_mesh(mesh, scalars=_SCALARS, cmap="viridis", clim=clim,
                                     opacity=opacity, show_scalar_bar=False, **kw)
                else:
                    plotter.add_mesh(mesh, color="silver" if not is_line else "grey",
                                     opacity=opacity, **kw)
        self.update(q)

    def update(self, q, poses=None):
        """Move the actors to q; ``poses``: :func:`drawn_poses` at q (computed if None)."""
        q = np.asarray(q, dtype=float)
        scale = 0.0 if self.ghost else self.scale
        if poses is None:
            poses = drawn_poses(self.mech, q, scale)
        for shape, X, fields, mesh in self.meshes:
            li = self.mech.link_index(shape.link)
            eta = q[self.mech.modal_index[li]]
            P, d = _placed(X, fields, poses[li], eta, scale)
            mesh.points = P
            if _SCALARS in mesh.point_data:
                mesh.point_data[_SCALARS] = _scalar(shape, X, eta, d, self.color)


class _Pivots:
    """Joints as dots; joints to ground larger and dark red."""

    def __init__(self, plotter, pv, mech, q, style, shapes=None, scale: float = 1.0):
        """The joints of the links drawn (``shapes``: their LinkShapes; None: every joint),
        where the links are drawn with their deformation times ``scale``."""
        self.mech, self.scale = mech, scale
        P, grounded = drawn_joint_points(mech, q, scale)
        self.shown = drawn_joints(mech, shapes)
        P, grounded = P[self.shown], grounded[self.shown]
        self.grounded = grounded
        self.free = pv.PolyData(P[~grounded]) if (~grounded).any() else None
        self.fixed = pv.PolyData(P[grounded]) if grounded.any() else None
        if self.free is not None:
            plotter.add_mesh(self.free, color="black", point_size=1.8 * style.line_px,
                             render_points_as_spheres=True)
        if self.fixed is not None:
            plotter.add_mesh(self.fixed, color="firebrick", point_size=2.6 * style.line_px,
                             render_points_as_spheres=True)

    def update(self, q, poses=None):
        """``poses``: :func:`drawn_poses` at q, as :meth:`_Drawn.update`."""
        P = drawn_joint_points(self.mech, q, self.scale, poses)[0][self.shown]
        if self.free is not None:
            self.free.points = P[~self.grounded]
        if self.fixed is not None:
            self.fixed.points = P[self.grounded]


def configurations(mech, shapes, Q) -> list[tuple]:
    """[(mech, shapes, q)] for each configuration q of Q.

    ``mech`` and ``shapes`` (LinkShapes by name) are either one machine's, for every q, or
    sequences with one per q: the cases of an analysis may build different models (one
    keeps no modes), and each q is posed only with the model it belongs to.
    """
    Q = [np.asarray(q, dtype=float) for q in Q]
    mechs = list(mech) if isinstance(mech, (list, tuple)) else [mech] * len(Q)
    shaped = list(shapes) if isinstance(shapes, (list, tuple)) else [shapes] * len(Q)
    if not len(mechs) == len(shaped) == len(Q):
        raise ValueError(f"{len(Q)} configurations, {len(mechs)} mechanisms and "
                         f"{len(shaped)} shape sets: give one each, or one for all")
    return list(zip(mechs, shaped, Q))


def label_anchors(mech, shapes, Q, scale, sample: int = 400) -> np.ndarray:
    """(len(Q), 3) where to attach each configuration's label: its drawn point farthest
    from every other configuration (what tells it apart), m. ``mech``, ``shapes``: as in
    :func:`configurations`."""
    from scipy.spatial import cKDTree

    clouds = []
    for m, shp, q in configurations(mech, shapes, Q):
        P = np.vstack(_drawn_points(m, shp, q, scale))
        clouds.append(P[:: max(1, len(P) // sample)])
    if len(clouds) == 1:
        return clouds[0][[int(np.argmax(np.linalg.norm(clouds[0] - clouds[0].mean(0), axis=1)))]]
    out = []
    for i, P in enumerate(clouds):
        others = cKDTree(np.vstack([c for j, c in enumerate(clouds) if j != i]))
        out.append(P[int(np.argmax(others.query(P)[0]))])
    return np.array(out)


def _clim(mech, shapes, Q, scale, color="displacement"):
    top = 0.0
    for m, shp, q in configurations(mech, shapes, Q):
        poses = link_poses(m, q)
        for s in shp.values():
            eta = q[m.modal_index[m.link_index(s.link)]]
            v = _scalar(s, s.points, eta, posed_points(m, s, q, 1.0, poses)[1], color)
            if v is not None:
                top = max(top, float(np.max(v, initial=0.0)))
    return [0.0, max(top, 1e-9)]


def _bar(plotter, scale, clim, color="displacement"):
    if clim[1] > 1e-9:
        title = f"{_LABELS[color]} (drawn x{scale:g})"
        mesh = _pyvista().PolyData(np.zeros((1, 3)))
        mesh.point_data[title] = [0.0]
        plotter.add_mesh(mesh, scalars=title, cmap="viridis", clim=clim, point_size=0.0,
                         opacity=0.0, show_scalar_bar=True,
                         scalar_bar_args={"color": "black", "fmt": "%.4g"})


def scene_bounds(mech, shapes, Q, scale) -> np.ndarray:
    """(3, 2) min/max of every drawn point over the configurations Q, m. ``mech``,
    ``shapes``: as in :func:`configurations`."""
    P = np.vstack([p for m, shp, q in configurations(mech, shapes, Q)
                   for p in _drawn_points(m, shp, q, scale, joints=True)])
    return np.column_stack([P.min(axis=0), P.max(axis=0)])


def _drawn_points(mech, shapes, q, scale, joints: bool = False) -> list[np.ndarray]:
    """Ground points (m) of every link (and the joints drawn with them) at q as drawn, the
    poses computed once. Only the drawn links' joints: a picture of some links is framed
    on them (the tractor-semitrailer's springs anchor 100 m off, on links left out)."""
    poses = drawn_poses(mech, q, scale)
    out = [posed_points(mech, s, q, scale, poses)[0] for s in shapes.values()]
    if not joints:
        return out
    return out + [drawn_joint_points(mech, q, scale, poses)[0][drawn_joints(mech, shapes)]]


def nice_length(x: float) -> float:
    """The largest of 1, 2, 5 x 10^k not above x (a scale bar's length).

    >>> nice_length(0.37), nice_length(2.2), nice_length(7.0)
    (0.2, 2.0, 5.0)
    """
    k = np.floor(np.log10(x))
    m = x / 10 ** k
    return float(round((5 if m >= 5 else 2 if m >= 2 else 1) * 10 ** k, 12))


def _view_axes(camera) -> tuple[np.ndarray, np.ndarray] | None:
    """(right, up) unit vectors of a named 2-D view in ground axes; None for 3-D views."""
    e = np.eye(3)
    return {"xy": (e[0], e[1]), "xz": (e[0], e[2]), "yz": (e[1], e[2])}.get(
        camera if isinstance(camera, str) else None)


def _furniture(plotter, pv, bounds, camera, style) -> list[np.ndarray]:
    """Ground line or plane, scale bar and axes triad around the scene; returns the points
    they occupy (so the camera frames them)."""
    lo, hi = bounds[:, 0], bounds[:, 1]
    size = float(np.max(hi - lo)) or 1.0
    centre = 0.5 * (lo + hi)
    axes = _view_axes(camera)
    right = axes[0] if axes else np.array([1.0, 0.0, 0.0])
    drawn = []
    if style.up is not None:
        up = np.asarray(style.up, dtype=float)
        corners = np.array([[x, y, z] for x in bounds[0] for y in bounds[1] for z in bounds[2]])
        level = float((corners @ up).min()) - 0.04 * size
        base = centre + (level - centre @ up) * up
        if axes is not None and abs(axes[1] @ up) > 0.9:  # side view: a ground line
            ext = 0.5 * float(np.ptp(corners @ axes[0])) + 0.05 * size
            a, b = base - ext * axes[0], base + ext * axes[0]
            plotter.add_mesh(pv.Line(a, b), color="dimgrey", line_width=style.line_px / 2)
            drawn += [a, b]
        elif axes is None:
            plane = pv.Plane(center=base, direction=up, i_size=1.3 * size, j_size=1.3 * size)
            plotter.add_mesh(plane, color="tan", opacity=0.25)
            drawn += [base]
    # scale bar below and left of the machine, along the view's horizontal
    length = nice_length(0.25 * size)
    down = -(axes[1] if axes else np.asarray(style.up if style.up is not None else (0, 0, 1.0)))
    start = centre - 0.5 * float(np.ptp([c @ right for c in (lo, hi)])) * right \
        + (0.5 * float(np.ptp([c @ down for c in (lo, hi)])) + 0.1 * size) * down
    end = start + length * right
    plotter.add_mesh(pv.Line(start, end), color="black", line_width=style.line_px / 2)
    plotter.add_point_labels([0.5 * (start + end) + 0.05 * size * down],
                             [f"{length:g} m"], shape=None, font_size=style.font_px,
                             text_color="black", show_points=False, always_visible=True)
    drawn += [start, end]
    # axes triad at the ground origin, as long as the scale bar
    for k, (name, colour) in enumerate((("x", "red"), ("y", "green"), ("z", "blue"))):
        tip = length * 0.5 * np.eye(3)[k]
        plotter.add_mesh(pv.Line(np.zeros(3), tip), color=colour, line_width=style.line_px / 2)
        plotter.add_point_labels([tip * 1.15], [name], shape=None, font_size=style.font_px,
                                 text_color=colour, show_points=False, always_visible=True)
    return drawn


def view_setting(camera, up=None) -> tuple[np.ndarray, np.ndarray] | None:
    """(view direction (3,), view-up (3,)) of a 3-D camera: ``iso`` looks down on the
    machine from 35.26 deg above its horizontal, along the diagonal of the ground axes, with
    ``up`` (against gravity; default z) upright on the screen, so a machine whose vertical
    is y stands as one whose vertical is z does; a direction (3,) keeps ``up`` upright
    unless it looks along it. None for the 2-D views (xy, xz, yz)."""
    check_camera(camera)
    if isinstance(camera, str) and camera != "iso":
        return None
    u = np.array((0.0, 0.0, 1.0) if up is None else up, dtype=float)
    u /= np.linalg.norm(u)
    if isinstance(camera, str):  # iso
        h = np.ones(3) - np.ones(3) @ u * u
        if np.linalg.norm(h) < 1e-9:  # up along the diagonal itself
            h = np.array([1.0, -1.0, 0.0])
        v = np.sqrt(2.0 / 3.0) * h / np.linalg.norm(h) + np.sqrt(1.0 / 3.0) * u
        return v, u
    v = view_direction(camera)
    if abs(v @ u) >= 0.9:  # looking along up: the screen's up is a horizontal axis
        u = np.eye(3)[int(np.argmin(np.abs(v)))]
    return v, u


def _camera(plotter, camera, up=None):
    """Named view, or a view direction (3,) (from the scene towards the camera), with ``up``
    (against gravity) upright in the 3-D views (:func:`view_setting`). 2-D views are
    parallel projections (lengths read the same everywhere)."""
    setting = view_setting(camera, up)
    if setting is not None:
        plotter.view_vector(setting[0], viewup=setting[1])
        return
    {"xy": plotter.view_xy, "xz": plotter.view_xz, "yz": plotter.view_yz}[camera]()
    plotter.enable_parallel_projection()


def _frame(plotter, bounds, extra):
    P = np.vstack([bounds.T] + [np.atleast_2d(e) for e in extra])
    b = np.column_stack([P.min(axis=0), P.max(axis=0)]).ravel()
    plotter.reset_camera(bounds=b)
    plotter.camera.zoom(1.05)


def place_labels(anchors, sizes, window, taken=(), gap: float = 8.0) -> np.ndarray:
    """Lower-left pixel positions (n, 2) of n labels next to their anchors without overlap.

    Each label tries the four corners around its anchor at growing distances and takes
    the first spot inside the window that overlaps neither a placed label nor a box in
    ``taken`` ((x0, y0, x1, y1) each).

    >>> place_labels([[100, 100], [102, 101]], [[60, 16], [60, 16]], (400, 300)).tolist()
    [[108.0, 108.0], [110.0, 77.0]]
    """
    anchors, sizes = np.asarray(anchors, float), np.asarray(sizes, float)
    boxes = [tuple(b) for b in taken]
    out = np.zeros_like(anchors)
    for i, ((ax, ay), (w, h)) in enumerate(zip(anchors, sizes)):
        best = None
        for ring in range(12):
            d = gap + ring * 0.6 * h
            for dx, dy in ((d, d), (d, -d - h), (-d - w, d), (-d - w, -d - h)):
                x, y = ax + dx, ay + dy
                box = (x, y, x + w, y + h)
                inside = x >= 0 and y >= 0 and x + w <= window[0] and y + h <= window[1]
                if inside and not any(_overlap(box, b) for b in boxes):
                    best = (x, y)
                    break
            if best is not None:
                break
        if best is None:  # crowded: the first spot, even if it overlaps
            best = (ax + gap, ay + gap)
        out[i] = best
        boxes.append((best[0], best[1], best[0] + w, best[1] + h))
    return out


def _overlap(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _to_display(renderer, P) -> np.ndarray:
    out = []
    for p in np.atleast_2d(P):
        renderer.SetWorldPoint(*p, 1.0)
        renderer.WorldToDisplay()
        out.append(renderer.GetDisplayPoint()[:2])
    return np.array(out)


def _text_box(renderer, actor) -> tuple:
    """(x0, y0, x1, y1) pixels of a text actor as drawn (its position plus its extent)."""
    bb = [0.0] * 4
    actor.GetBoundingBox(renderer, bb)
    x, y = actor.GetPosition()
    return (x + bb[0], y + bb[2], x + bb[1], y + bb[3])


def _text_actor(renderer, text: str, font_px: int, box: bool = True):
    from vtkmodules.vtkRenderingCore import vtkTextActor

    a = vtkTextActor()
    a.SetInput(str(text))
    prop = a.GetTextProperty()
    prop.SetFontSize(font_px)
    prop.SetColor(0, 0, 0)
    if box:
        prop.SetBackgroundColor(1, 1, 1)
        prop.SetBackgroundOpacity(0.8)
    renderer.AddActor(a)
    return a


def _add_labels(plotter, anchors, texts, style) -> tuple:
    """Labels next to their anchors (world points), placed without overlap; returns
    (text, pixel box) of each."""
    ren = plotter.renderer
    actors = [_text_actor(ren, text, style.font_px) for text in texts]
    plotter.render()
    sizes = [(b[2] - b[0], b[3] - b[1]) for b in (_text_box(ren, a) for a in actors)]
    spots = place_labels(_to_display(ren, anchors), sizes, plotter.window_size)
    for a, (x, y) in zip(actors, spots):
        a.SetPosition(float(x), float(y))
    plotter.render()
    return tuple((str(t), _text_box(ren, a)) for t, a in zip(texts, actors))


def render_machine(path, mech, shapes, q, *, scale: float = 1.0, title: str | None = None,
                   camera: str = "iso", ghost_q=None, style: Style | None = None,
                   window_size: tuple[int, int] = (1200, 900)) -> Picture:
    """PNG of the machine at q (written atomically); optional grey wireframe at ``ghost_q``
    (e.g. the same configuration without elastic deformation)."""
    return render_positions(path, mech, shapes, [q], None, scale=scale, title=title,
                            camera=camera, ghost_q=None if ghost_q is None else [ghost_q],
                            style=style, window_size=window_size)


def render_positions(path, mech, shapes, Q, labels=None, *, scale: float = 1.0,
                     title: str | None = None, camera: str = "iso", ghost_q=None,
                     style: Style | None = None,
                     window_size: tuple[int, int] = (1200, 900)) -> Picture:
    """One PNG with the machine at several configurations (e.g. lower/middle/upper),
    one shared colour range, pivots, ground, scale bar and triad; ``labels`` are written
    next to each configuration without overlapping; ``ghost_q``: configurations drawn
    as grey wireframes (e.g. the undeformed ones), one per q. ``mech`` and ``shapes``:
    one machine's, or one per configuration (cases of different models; see
    :func:`configurations`)."""
    plotter, boxes = _machine_plotter(mech, shapes, Q, labels, scale=scale, title=title,
                                      camera=camera, ghost_q=ghost_q, style=style,
                                      window_size=window_size)
    try:
        image = plotter.screenshot(return_img=True)
    finally:
        plotter.close()
    return Picture(save_png(image, path), boxes)


def machine_plotter(mech, shapes, Q, labels=None, *, scale: float = 1.0,
                    title: str | None = None, camera: str = "iso", ghost_q=None,
                    style: Style | None = None, window_size: tuple[int, int] = (1200, 900)):
    """The off-screen pyvista Plotter of what :func:`render_positions` draws (Q: one
    configuration (n,) or several (k, n)), for a notebook to show or a script to add to;
    the caller closes it. Nothing process-wide is changed."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    return _machine_plotter(mech, shapes, Q, labels, scale=scale, title=title, camera=camera,
                            ghost_q=ghost_q, style=style, window_size=window_size)[0]


def _machine_plotter(mech, shapes, Q, labels, *, scale, title, camera, ghost_q, style,
                     window_size):
    """(Plotter, label boxes (display pixels)) of :func:`render_positions`'s picture."""
    pv = _pyvista()
    style = style or Style()
    scene = configurations(mech, shapes, Q)
    clim = _clim(mech, shapes, Q, scale, style.color)
    plotter = pv.Plotter(off_screen=True, window_size=window_size)
    try:
        plotter.set_background("white")
        if ghost_q is not None:
            for (m, shp, _), g in zip(scene, ghost_q, strict=True):
                _Drawn(plotter, pv, m, shp, g, 0.0, clim, style, ghost=True)
        for m, shp, q in scene:
            # see-through where the frames are drawn: most sit inside their link
            _Drawn(plotter, pv, m, shp, q, scale, clim, style,
                   opacity=0.35 if style.frames else 1.0 if len(scene) == 1 else 0.9)
            _Pivots(plotter, pv, m, q, style, shp, scale)
        bounds = scene_bounds(mech, shapes, Q, scale)
        if style.frames:  # framed with the frames (a marker may sit off its link)
            drawn = [(drawing_mechanism(m, scale), drawn_configuration(m, q, scale))
                     for m, _, q in scene]
            origins = np.array([P[:3, 3] for m, q in drawn for _, P in frame_poses(m, q)])
            if origins.size:
                bounds = np.column_stack([np.minimum(bounds[:, 0], origins.min(axis=0)),
                                          np.maximum(bounds[:, 1], origins.max(axis=0))])
            for m, q in drawn:
                _triads(plotter, pv, m, q,
                        0.04 * float(np.linalg.norm(bounds[:, 1] - bounds[:, 0])), style)
        extra = _furniture(plotter, pv, bounds, camera, style)
        _bar(plotter, scale, clim, style.color)
        if title:
            plotter.add_text(title, font_size=11, color="black")
        _camera(plotter, camera, style.up)
        _frame(plotter, bounds, extra)
        boxes = ()
        if labels:
            anchors = label_anchors(mech, shapes, Q, scale)
            boxes = _add_labels(plotter, anchors, labels, style)
    except BaseException:
        plotter.close()
        raise
    return plotter, boxes


def frame_poses(mech, q) -> tuple[tuple[str, np.ndarray], ...]:
    """("link.frame", (4, 4) pose in ground) of every frame of every link at q (n,)."""
    from pipeline.kinematics.poses import step_pose

    tree = evaluate_tree(mech, q, derivatives=False)
    return tuple((f"{link.name}.{f.name}", step_pose(mech.marker(link.name, f.name), tree.A, q))
                 for link in mech.links for f in link.frames)


def _triads(plotter, pv, mech, q, length: float, style: Style) -> None:
    """Each frame at q as three lines of ``length`` (m): x red, y green, z blue (flat
    colours)."""
    poses = [P for _, P in frame_poses(mech, q)]
    if not poses:
        return
    for axis, colour in enumerate(("red", (0.0, 0.6, 0.0), "blue")):
        points = np.concatenate([[P[:3, 3], P[:3, 3] + length * P[:3, axis]] for P in poses])
        lines = np.column_stack([np.full(len(poses), 2), np.arange(0, 2 * len(poses), 2),
                                 np.arange(1, 2 * len(poses), 2)]).ravel()
        plotter.add_mesh(pv.PolyData(points, lines=lines), color=colour, lighting=False,
                         line_width=0.5 * style.line_px, render_lines_as_tubes=False)


def animate_machine(path, mech, shapes, t, Q, *, scale: float = 1.0, fps: int = 15,
                    max_frames: int = 60, camera: str = "iso", style: Style | None = None,
                    window_size: tuple[int, int] = (800, 600)) -> Path:
    """GIF (or MP4 if the suffix is .mp4 and imageio-ffmpeg is installed) of the run; fixed
    camera framing the whole motion and one colour range; time in the title. The scene
    is built once and its points moved per frame (one render per frame)."""
    import imageio.v2 as imageio

    pv = _pyvista()
    style = style or Style(line_px=4.0)
    path = Path(path)
    t = np.asarray(t, dtype=float)
    Q = np.asarray(Q, dtype=float)
    if len(t) == 0:
        raise ConfigError(f"{path.name}: nothing to animate (no output times)")
    picks = np.unique(np.linspace(0, len(t) - 1, min(max_frames, len(t))).round().astype(int))
    clim = _clim(mech, shapes, Q[picks], scale, style.color)
    bounds = scene_bounds(mech, shapes, Q[picks[:: max(1, len(picks) // 12)]], scale)
    frames = []
    plotter = pv.Plotter(off_screen=True, window_size=window_size)
    try:
        plotter.set_background("white")
        drawn = _Drawn(plotter, pv, mech, shapes, Q[picks[0]], scale, clim, style)
        pivots = _Pivots(plotter, pv, mech, Q[picks[0]], style, shapes, scale)
        extra = _furniture(plotter, pv, bounds, camera, style)
        _bar(plotter, scale, clim, style.color)
        clock = _text_actor(plotter.renderer, "t = 0 s", style.font_px, box=False)
        clock.SetPosition(10, window_size[1] - 2.2 * style.font_px)
        _camera(plotter, camera, style.up)
        _frame(plotter, bounds, extra)
        for k in picks:
            poses = drawn_poses(mech, Q[k], scale)
            drawn.update(Q[k], poses)
            pivots.update(Q[k], poses)
            clock.SetInput(f"t = {t[k]:.3f} s")
            plotter.render()
            frames.append(plotter.screenshot(return_img=True))
    finally:
        plotter.close()
    suffix = path.suffix.lower()
    if suffix == ".mp4":
        try:
            import imageio_ffmpeg  # noqa: F401
        except ImportError:
            raise ConfigError(f"{path.name}: MP4 needs imageio-ffmpeg (pip install "
                              "imageio-ffmpeg); use format: gif") from None
    with atomic_path(path) as tmp:
        if suffix == ".mp4":
            imageio.mimsave(tmp, frames, fps=fps, format="FFMPEG")
        else:
            imageio.mimsave(tmp, frames, format="GIF", duration=1000.0 / fps, loop=0)
    return path
